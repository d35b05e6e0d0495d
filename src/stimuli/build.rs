//! Building a stimulus set: entries → media files, ground truth and the manifest.
//!
//! Layout of a built set (everything relative to the output directory):
//!
//! ```text
//! manifest.csv, manifest.json     one row per stimulus (see `manifest`)
//! media/<id>.png | media/<id>.mp4 what participants see (dithered)
//! posters/<id>.png                first frame of each video (neutral, dithered), for <video poster>
//! ground_truth/<id>.csv           per-frame AU intensities of each video
//! timelines/<id>.json             the timeline that reproduces each video exactly
//! frames/<id>/000000.png …        every video frame as PNG, when the spec asks (png_frames; not dithered)
//! dither.key                      the set's secret dither key (never served; see `dither`)
//! ```
//!
//! Media and posters are dithered with the set's key ([`Dithering`]): every still, every video
//! frame before it is encoded, every poster. The per-frame PNGs, ground truth and timelines are the
//! engine's own. The manifest's `dither` column holds the key's fingerprint, so files made with
//! another key, or without one, are never taken as up to date.
//!
//! Ids are opaque: the first 16 hex digits of SHA-256 over a fixed key, the set seed and the
//! entry index, so file names and paths say nothing about what a stimulus shows. Every file is
//! written under a temporary name and renamed into place; the manifest is written last, so a
//! failed build never leaves a partial file or a manifest describing files that do not exist.
//! An entry whose manifest row would be unchanged and whose media file still has the recorded
//! sha256 is not rendered again.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;
use sha2::{Digest, Sha256};

use super::dither::{Dither, DitherKey, DitherKeyError};
use super::frames::{FrameKey, SharedFrames};
use super::manifest::{self, ManifestRow, Media};
use super::spec::{Content, Entry, SetSpec};
use crate::engine::identity::IdentityTable;
use crate::engine::image::RgbImage;
use crate::engine::timeline::Timeline;
use crate::engine::video::{Mp4Encoder, even_size};
use crate::engine::look::{Backdrop, Look};
use crate::engine::{self, FrameSettings};
use crate::facs::Catalog;

/// The version written in every manifest row: images depend on the engine's code and tables.
pub const ENGINE_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Why a set could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{entry}: {message}")]
    Render { entry: String, message: String },
    #[error("two entries got the same stimulus id {0}; change the seed")]
    IdCollision(String),
    #[error("could not start {0} worker threads: {1}")]
    Threads(usize, String),
    #[error(transparent)]
    DitherKey(#[from] DitherKeyError),
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> BuildError + '_ {
    move |source| BuildError::Io { path: path.to_path_buf(), source }
}

/// How to build.
#[derive(Debug, Clone, Default)]
pub struct BuildOptions {
    /// Worker threads (`None` = all cores).
    pub jobs: Option<usize>,
    /// Draw a progress bar on stderr (hidden automatically when stderr is not a terminal).
    pub progress: bool,
    /// Which key dithers the media.
    pub dither: Dithering,
}

/// Which key dithers a set's media.
#[derive(Debug, Clone, Default)]
pub enum Dithering {
    /// The set directory's `dither.key`, made from the operating system's randomness on the first build.
    #[default]
    SetKey,
    /// This key (kept as the set directory's `dither.key`), e.g. one key for all shards of a set.
    Key(DitherKey),
    /// No dither and no key: the media are the engine's bytes, as `facslab render` writes them.
    Off,
}

impl Dithering {
    /// The key the build into `out` uses, kept in `out` (`None` without dither).
    pub fn key_for(&self, out: &Path) -> Result<Option<DitherKey>, BuildError> {
        match self {
            Dithering::SetKey => Ok(Some(DitherKey::of_set(out)?)),
            Dithering::Key(key) => {
                key.keep_in_set(out)?;
                Ok(Some(key.clone()))
            }
            Dithering::Off => Ok(None),
        }
    }
}

/// The manifest's `dither` value: the key's fingerprint, empty without dither.
pub fn dither_column(key: Option<&DitherKey>) -> String {
    key.map(DitherKey::fingerprint).unwrap_or_default()
}

/// What a build did.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildSummary {
    pub stimuli: usize,
    pub rendered: usize,
    pub skipped: usize,
    pub frames_rendered: usize,
    pub rows: Vec<ManifestRow>,
}

/// The opaque id of entry `index` in a set with `seed`.
pub fn stimulus_id(seed: u64, index: usize) -> String {
    let mut hash = Sha256::new();
    hash.update(b"facslab stimulus id v1\0");
    hash.update(seed.to_le_bytes());
    hash.update((index as u64).to_le_bytes());
    hex::encode(&hash.finalize()[..8])
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

/// Writes `bytes` to `path` through a temporary file in the same directory.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BuildError> {
    let partial = path.with_file_name(format!(
        ".{}.partial",
        path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
    ));
    std::fs::write(&partial, bytes).map_err(io(&partial))?;
    std::fs::rename(&partial, path).map_err(io(path))
}

/// The manifest rows the whole set will have, in spec order, `sha256` still empty (`dither` is
/// the [`dither_column`]).
pub fn plan(spec: &SetSpec, dither: &str) -> Vec<ManifestRow> {
    spec.entries.iter().map(|entry| planned_row(spec, entry, &stimulus_id(spec.seed, entry.index), dither)).collect()
}

/// The engine version, with the look appended when it is not the default (so that a change of
/// look makes the files out of date): e.g. `0.1.0+backdrop-black+light-soft+grayscale`.
fn engine_version(look: &Look) -> String {
    let mut version = ENGINE_VERSION.to_string();
    let default = Look::default();
    if look.backdrop != default.backdrop {
        version += &format!("+backdrop-{}", look.backdrop.to_string().trim_start_matches('#'));
    }
    if look.light != default.light {
        version += &format!("+light-{}", look.light);
    }
    if look.grayscale {
        version += "+grayscale";
    }
    version
}

/// The row an entry will have, with `sha256` still empty.
fn planned_row(spec: &SetSpec, entry: &Entry, id: &str, dither: &str) -> ManifestRow {
    let (w, h) = spec.size;
    let base = ManifestRow {
        stimulus_id: id.to_string(),
        media: Media::Image,
        file: String::new(),
        identity: entry.identity.clone(),
        expression: entry.expression.clone(),
        emotion: entry.emotion.clone(),
        intensity: entry.intensity,
        onset_s: None,
        apex_s: None,
        offset_s: None,
        frames: None,
        fps: None,
        width: w,
        height: h,
        sha256: String::new(),
        set_seed: spec.seed,
        engine_version: engine_version(&spec.look),
        dither: dither.to_string(),
        style: entry.style.map_or_else(String::new, |s| s.name().to_string()),
    };
    match &entry.content {
        Content::Image(_) => ManifestRow { media: Media::Image, file: format!("media/{id}.png"), ..base },
        Content::Video { timeline, timing, .. } => {
            let (ew, eh) = even_size(w, h);
            ManifestRow {
                media: Media::Video,
                file: format!("media/{id}.mp4"),
                onset_s: Some(timing.onset_s),
                apex_s: Some(timing.apex_s),
                offset_s: Some(timing.offset_s),
                frames: Some(timeline.frame_count()),
                fps: Some(timeline.fps),
                width: ew,
                height: eh,
                ..base
            }
        }
    }
}

/// The files besides the media file that an entry needs.
fn side_files(out: &Path, entry: &Entry, id: &str, png_frames: bool) -> Vec<PathBuf> {
    match &entry.content {
        Content::Image(_) => vec![],
        Content::Video { .. } => {
            let mut files = vec![
                out.join("posters").join(format!("{id}.png")),
                out.join("ground_truth").join(format!("{id}.csv")),
                out.join("timelines").join(format!("{id}.json")),
            ];
            if png_frames {
                files.push(out.join("frames").join(id));
            }
            files
        }
    }
}

fn up_to_date(out: &Path, old: Option<&ManifestRow>, planned: &ManifestRow, sides: &[PathBuf]) -> bool {
    let Some(old) = old else { return false };
    if (ManifestRow { sha256: String::new(), ..old.clone() }) != *planned {
        return false;
    }
    if !sides.iter().all(|p| p.exists()) {
        return false;
    }
    match std::fs::read(out.join(&old.file)) {
        Ok(bytes) => sha256_hex(&bytes) == old.sha256,
        Err(_) => false,
    }
}

/// Builds `spec` into `out`. The spec is already validated; rendering starts only here.
pub fn build(spec: &SetSpec, out: &Path, options: &BuildOptions) -> Result<BuildSummary, BuildError> {
    let ids: Vec<String> = spec.entries.iter().map(|e| stimulus_id(spec.seed, e.index)).collect();
    let mut seen = std::collections::BTreeSet::new();
    for id in &ids {
        if !seen.insert(id) {
            return Err(BuildError::IdCollision(id.clone()));
        }
    }
    for dir in ["media", "posters", "ground_truth", "timelines"] {
        let path = out.join(dir);
        std::fs::create_dir_all(&path).map_err(io(&path))?;
    }
    let key = options.dither.key_for(out)?;
    let dither = dither_column(key.as_ref());
    let manifest_json = out.join("manifest.json");
    let old: Vec<ManifestRow> = match std::fs::read_to_string(&manifest_json) {
        Ok(text) => manifest::from_json(&text).unwrap_or_default(),
        Err(_) => Vec::new(),
    };

    let plans: Vec<(ManifestRow, bool)> = spec
        .entries
        .iter()
        .zip(&ids)
        .map(|(entry, id)| {
            let planned = planned_row(spec, entry, id, &dither);
            let previous = old.iter().find(|r| r.stimulus_id == *id);
            let sides = side_files(out, entry, id, spec.png_frames);
            let fresh = up_to_date(out, previous, &planned, &sides);
            let row = if fresh { previous.cloned().expect("fresh rows have a previous row") } else { planned };
            (row, fresh)
        })
        .collect();

    let todo: Vec<usize> = (0..plans.len()).filter(|&i| !plans[i].1).collect();
    let frames_todo: usize = todo
        .iter()
        .map(|&i| match &spec.entries[i].content {
            Content::Image(_) => 1,
            Content::Video { timeline, .. } => timeline.frame_count(),
        })
        .sum();
    let bar = if options.progress {
        crate::progress::bar(frames_todo as u64, "frames", format!("{}: {} stimuli ({} up to date)", spec.name, plans.len(), plans.len() - todo.len()))
    } else {
        indicatif::ProgressBar::hidden()
    };
    let frames_rendered = AtomicUsize::new(0);

    let frame_keys: Vec<BTreeSet<FrameKey>> = todo.iter().map(|&i| entry_frames(spec, &spec.entries[i])).collect::<Result<_, _>>()?;
    let shared = SharedFrames::new(frame_keys, SHARED_FRAME_BYTES);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.jobs.unwrap_or(0))
        .build()
        .map_err(|e| BuildError::Threads(options.jobs.unwrap_or(0), e.to_string()))?;
    // Longest jobs first, so the pool does not end on one long video.
    let mut order = todo.clone();
    order.sort_by_key(|&i| std::cmp::Reverse(planned_frames(&spec.entries[i])));
    let results: Vec<(usize, Result<String, BuildError>)> = pool.install(|| {
        order
            .par_iter()
            .map(|&i| {
                let entry = &spec.entries[i];
                let dither = key.as_ref().map(|key| Dither { key, stimulus_id: &ids[i], grey: spec.look.grayscale });
                let result = render_entry(spec, entry, &ids[i], out, &shared, dither, &|n| {
                    bar.inc(n as u64);
                    frames_rendered.fetch_add(n, Ordering::Relaxed);
                });
                (i, result)
            })
            .collect()
    });
    bar.finish_and_clear();

    let mut rows: Vec<ManifestRow> = plans.iter().map(|(row, _)| row.clone()).collect();
    for (i, result) in results {
        rows[i].sha256 = result?;
    }
    crate::stimuli::labels::write_set(out, &spec.label_files)?;
    write_atomic(&out.join("manifest.csv"), manifest::to_csv(&rows).as_bytes())?;
    write_atomic(&manifest_json, manifest::to_json(&rows).as_bytes())?;
    Ok(BuildSummary {
        stimuli: rows.len(),
        rendered: todo.len(),
        skipped: rows.len() - todo.len(),
        frames_rendered: frames_rendered.into_inner(),
        rows,
    })
}

/// The most bytes of frames a build keeps for reuse by later entries (about 700 frames of
/// 485×480).
const SHARED_FRAME_BYTES: usize = 512 << 20;

/// The distinct frames an entry shows.
fn entry_frames(spec: &SetSpec, entry: &Entry) -> Result<BTreeSet<FrameKey>, BuildError> {
    let key = |frame: &dyn std::fmt::Display| FrameKey::new(&entry.identity, spec.size, &frame.to_string());
    match &entry.content {
        Content::Image(expression) => Ok(BTreeSet::from([key(expression)])),
        Content::Video { timeline, .. } => (0..timeline.frame_count())
            .map(|f| timeline.frame_key(f, Catalog::built_in()).map(|k| key(&k)))
            .collect::<Result<_, _>>()
            .map_err(|e| BuildError::Render { entry: entry.origin.clone(), message: e.to_string() }),
    }
}

fn planned_frames(entry: &Entry) -> usize {
    match &entry.content {
        Content::Image(_) => 1,
        Content::Video { timeline, .. } => timeline.frame_count(),
    }
}

/// Renders one entry's files (media and poster dithered with `dither`) and returns the sha256 of
/// its media file.
fn render_entry(
    spec: &SetSpec,
    entry: &Entry,
    id: &str,
    out: &Path,
    shared: &SharedFrames,
    dither: Option<Dither>,
    progress: &dyn Fn(usize),
) -> Result<String, BuildError> {
    let fail = |message: String| BuildError::Render { entry: entry.origin.clone(), message };
    let identity = IdentityTable::active().get(&entry.identity).map_err(|e| fail(e.to_string()))?;
    let style = entry.style.unwrap_or_default();
    let settings = FrameSettings { width: spec.size.0, height: spec.size.1, threads: Some(1), look: spec.look, style, shoulders: 0.0 };
    match &entry.content {
        Content::Image(expression) if spec.look.backdrop == Backdrop::Transparent => {
            // RGBA stills are not shared with videos (which have no alpha).
            let frame = engine::render_frame(expression, identity, settings).map_err(|e| fail(e.to_string()))?;
            let key = FrameKey::new(&entry.identity, spec.size, expression);
            shared.release([&key]);
            let bytes = match dither {
                Some(d) => d.frame(frame, 0),
                None => frame,
            }
            .encode_png();
            write_atomic(&out.join("media").join(format!("{id}.png")), &bytes)?;
            progress(1);
            Ok(sha256_hex(&bytes))
        }
        Content::Image(expression) => {
            let key = FrameKey::new(&entry.identity, spec.size, expression);
            let image = match shared.get(&key) {
                Some(image) => image,
                None => {
                    let image = Arc::new(engine::render_still(expression, identity, settings).map_err(|e| fail(e.to_string()))?);
                    shared.offer(&key, &image);
                    image
                }
            };
            shared.release([&key]);
            let bytes = dither.map_or_else(|| image.encode_png(), |d| d.rgb(&image, 0).encode_png());
            write_atomic(&out.join("media").join(format!("{id}.png")), &bytes)?;
            progress(1);
            Ok(sha256_hex(&bytes))
        }
        Content::Video { timeline, speech, .. } => {
            let frames_dir = spec.png_frames.then(|| out.join("frames").join(id));
            let mut poster = None;
            let sound = match speech {
                Some(spoken) => Some(crate::speech::encode_sound(&spoken.samples, spoken.sample_rate).map_err(|e| fail(e.to_string()))?),
                None => None,
            };
            let bytes = render_video(timeline, settings, frames_dir.as_deref(), false, Some(shared), dither, sound, &mut |frame, image| {
                if frame == 0 {
                    poster = Some(image.encode_png());
                }
                progress(1);
            })
            .map_err(|e| match e {
                VideoBuildError::Io(e) => e,
                other => fail(other.to_string()),
            })?;
            write_atomic(&out.join("media").join(format!("{id}.mp4")), &bytes)?;
            write_atomic(&out.join("posters").join(format!("{id}.png")), &poster.expect("a video has a first frame"))?;
            let truth = match speech {
                Some(spoken) => manifest::speech_ground_truth_csv(timeline, &spoken.frames),
                None => manifest::ground_truth_csv(timeline),
            };
            write_atomic(&out.join("ground_truth").join(format!("{id}.csv")), truth.as_bytes())?;
            write_atomic(&out.join("timelines").join(format!("{id}.json")), timeline.to_json().as_bytes())?;
            Ok(sha256_hex(&bytes))
        }
    }
}

/// Why a timeline could not be rendered to video.
#[derive(Debug, thiserror::Error)]
pub enum VideoBuildError {
    #[error(transparent)]
    Notation(#[from] crate::facs::NotationError),
    #[error(transparent)]
    Engine(#[from] engine::EngineError),
    #[error(transparent)]
    Video(#[from] crate::engine::video::VideoError),
    #[error(transparent)]
    Io(BuildError),
}

/// Renders every frame of `timeline` (on the calling thread, or in parallel over frames with
/// `parallel`; each distinct expression is rendered once, or taken from `shared` when another
/// entry of the build has rendered it), encodes the MP4, and optionally writes the PNG frames
/// into `frames_dir` (through a temporary directory renamed into place). With `dither`, each
/// frame is dithered before it is encoded; the PNG frames stay the engine's. `on_frame` sees
/// each frame as encoded. With `sound`, the MP4 carries it as its sound track.
#[allow(clippy::too_many_arguments)]
pub fn render_video(
    timeline: &Timeline,
    settings: FrameSettings,
    frames_dir: Option<&Path>,
    parallel: bool,
    shared: Option<&SharedFrames>,
    dither: Option<Dither>,
    sound: Option<crate::engine::video::OpusTrack>,
    on_frame: &mut dyn FnMut(usize, &RgbImage),
) -> Result<Vec<u8>, VideoBuildError> {
    let catalog = Catalog::built_in();
    let identity = IdentityTable::active().get(&timeline.identity).map_err(|e| {
        VideoBuildError::Io(BuildError::Render { entry: timeline.identity.clone(), message: e.to_string() })
    })?;
    let partial_dir = frames_dir.map(|d| d.with_file_name(format!(".{}.partial", d.file_name().unwrap_or_default().to_string_lossy())));
    if let Some(dir) = &partial_dir {
        let _ = std::fs::remove_dir_all(dir);
        std::fs::create_dir_all(dir).map_err(|e| VideoBuildError::Io(io(dir)(e)))?;
    }
    let mut encoder = Mp4Encoder::with_sound(settings.width, settings.height, timeline.fps, sound)?;
    let expressions: Vec<crate::facs::Expression> =
        (0..timeline.frame_count()).map(|f| timeline.frame_expression(f, catalog)).collect::<Result<_, _>>()?;
    // Each distinct expression is rendered once: the apex is held, and a falling ramp passes
    // through the rising ramp's values (see `timeline::RAMP_STEP`). Rendered frames are kept
    // for reuse up to a memory budget. In parallel mode, chunks of frames render at once.
    const CACHE_BYTES: usize = 96 << 20;
    let mut cache: HashMap<String, Arc<RgbImage>> = HashMap::new();
    let mut cached_bytes = 0usize;
    let chunk = if parallel { 4 * rayon::current_num_threads() } else { 1 };
    let frame_settings = FrameSettings { threads: if parallel { Some(1) } else { settings.threads }, ..settings };
    let keys: Vec<String> = expressions.iter().enumerate().map(|(f, e)| timeline.frame_key_of(f, e)).collect();
    for start in (0..expressions.len()).step_by(chunk) {
        let end = (start + chunk).min(expressions.len());
        let mut fresh: Vec<usize> = Vec::new();
        for f in start..end {
            if !cache.contains_key(&keys[f]) && !fresh.iter().any(|&g| keys[g] == keys[f]) {
                fresh.push(f);
            }
        }
        let frame_key = |f: usize| FrameKey::new(&timeline.identity, (settings.width, settings.height), &keys[f]).in_style(settings.style);
        let render = |&f: &usize| -> Result<(usize, Arc<RgbImage>), engine::EngineError> {
            if let Some(image) = shared.and_then(|s| s.get(&frame_key(f))) {
                return Ok((f, image));
            }
            let settings = FrameSettings { shoulders: timeline.frame_shoulders(f), ..frame_settings };
            let image = Arc::new(engine::render_still(&expressions[f], identity, settings)?);
            if let Some(shared) = shared {
                shared.offer(&frame_key(f), &image);
            }
            Ok((f, image))
        };
        let rendered: Vec<(usize, Arc<RgbImage>)> = if parallel {
            fresh.par_iter().map(render).collect::<Result<_, _>>()?
        } else {
            fresh.iter().map(render).collect::<Result<_, _>>()?
        };
        let local: HashMap<&str, Arc<RgbImage>> = rendered.into_iter().map(|(f, image)| (keys[f].as_str(), image)).collect();
        for (frame, key) in keys.iter().enumerate().take(end).skip(start) {
            let key = key.as_str();
            let image = local.get(key).or_else(|| cache.get(key)).cloned().expect("every frame is rendered or cached");
            let shown = match dither {
                Some(d) => std::borrow::Cow::Owned(d.rgb(&image, frame)),
                None => std::borrow::Cow::Borrowed(&*image),
            };
            encoder.push(&shown)?;
            if let Some(dir) = &partial_dir {
                let path = dir.join(format!("{frame:06}.png"));
                std::fs::write(&path, image.encode_png()).map_err(|e| VideoBuildError::Io(io(&path)(e)))?;
            }
            on_frame(frame, &shown);
        }
        for (key, image) in local {
            if cached_bytes + image.data.len() <= CACHE_BYTES {
                cached_bytes += image.data.len();
                cache.insert(key.to_string(), image);
            }
        }
    }
    if let Some(shared) = shared {
        let distinct: BTreeSet<&String> = keys.iter().collect();
        let done: Vec<FrameKey> = distinct.into_iter().map(|k| FrameKey::new(&timeline.identity, (settings.width, settings.height), k).in_style(settings.style)).collect();
        shared.release(&done);
    }
    let bytes = encoder.finish()?;
    if let (Some(partial), Some(dir)) = (&partial_dir, frames_dir) {
        move_frames_into_place(partial, dir, timeline.frame_count()).map_err(VideoBuildError::Io)?;
    }
    Ok(bytes)
}

/// Moves the frames from `partial` into `dir`: a plain rename when `dir` does not exist;
/// otherwise frame by frame, removing frame files past `count` left by an older, longer video
/// (nothing else in `dir` is touched).
fn move_frames_into_place(partial: &Path, dir: &Path, count: usize) -> Result<(), BuildError> {
    if !dir.exists() {
        return std::fs::rename(partial, dir).map_err(io(dir));
    }
    let entries = std::fs::read_dir(dir).map_err(io(dir))?;
    for entry in entries {
        let path = entry.map_err(io(dir))?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if let Some(stem) = name.strip_suffix(".png")
            && stem.len() == 6
            && stem.parse::<usize>().is_ok_and(|n| n >= count)
        {
            std::fs::remove_file(&path).map_err(io(&path))?;
        }
    }
    for frame in 0..count {
        let name = format!("{frame:06}.png");
        std::fs::rename(partial.join(&name), dir.join(&name)).map_err(io(&dir.join(&name)))?;
    }
    std::fs::remove_dir(partial).map_err(io(partial))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_opaque_stable_and_distinct() {
        assert_eq!(stimulus_id(7, 0), stimulus_id(7, 0));
        assert_ne!(stimulus_id(7, 0), stimulus_id(7, 1));
        assert_ne!(stimulus_id(7, 0), stimulus_id(8, 0));
        assert_eq!(stimulus_id(7, 0).len(), 16);
        assert!(stimulus_id(7, 0).chars().all(|c| c.is_ascii_hexdigit()));
    }
}
