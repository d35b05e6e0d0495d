//! `facslab laugh`: one of the thirteen laugh and smile types of seed 004 as an MP4, in the
//! realistic or the cartoon style, from the type table (a seeded take) or from a fitted curve
//! set; optionally its curves as Maya `.anim`, its timeline, its per-frame ground truth and a
//! strip of frames.
//!
//! Order, so that a failure leaves nothing partial: every argument is checked and the curves
//! made first; the frames are rendered and encoded in memory; only then are the files written
//! (each atomically).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};

use crate::engine::identity::IdentityTable;
use crate::engine::image::RgbImage;
use crate::engine::{self, FrameSettings, Style};
use crate::facs::Catalog;
use crate::laugh::strip::{side_by_side, strip_frames};
use crate::laugh::{anim, perform, Curves, LaughTable, LaughType, Take};
use crate::stimuli;

/// Largest curves file read, bytes.
const MAX_CURVES_BYTES: u64 = 16 << 20;

/// The arguments of `facslab laugh`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  facslab laugh --list\n  facslab laugh uproarious_laughter --identity wf1 -o uproarious.mp4\n  facslab laugh false_smile --identity bm2 --style cartoon -o false.mp4 --anim false.anim\n  facslab laugh laughter --duration 6 --intensity 0.7 --seed 3 -o laughter.mp4 --export-timeline laughter.json\n  facslab laugh open_mouthed_smile --curves fitted.json -o fitted.mp4      # curves from `facslab curves fit`\n  facslab laugh sly_smile --size 240x240 -o sly.mp4 --strip sly.png --ground-truth\n\nThe same --seed gives the same take (and the same bytes); other seeds vary the timing, the\npeaks and the laugh pulses. Limits: --duration 0.5-20 s, --intensity (0, 1], --fps 1-60.\nThe .anim file is Maya ASCII (animImportExport): one attribute per AU (AU12, AU12L, ...) on\nthe node facslab_face, one key per frame.")]
pub struct LaughArgs {
    /// The laugh or smile type (see --list).
    #[arg(required_unless_present = "list")]
    laugh_type: Option<String>,
    /// List the types (id first on each line) and exit.
    #[arg(long, conflicts_with = "laugh_type")]
    list: bool,
    /// Who laughs (see `facslab identities`).
    #[arg(long, default_value = "wm1")]
    identity: String,
    /// Output MP4.
    #[arg(short, long, required_unless_present = "list")]
    output: Option<PathBuf>,
    /// How the face is drawn: realistic or cartoon.
    #[arg(long, default_value = "realistic")]
    style: Style,
    /// Length of the take in seconds (0.5-20; default: the type's natural length).
    #[arg(long, conflicts_with = "curves")]
    duration: Option<f64>,
    /// Scales every AU's peak, in (0, 1].
    #[arg(long, default_value_t = 1.0, conflicts_with = "curves")]
    intensity: f64,
    /// Seed of the take's variation (timing, peaks, pulses).
    #[arg(long, default_value_t = 1, conflicts_with = "curves")]
    seed: u64,
    /// Frames per second (1-60).
    #[arg(long, default_value_t = 30, conflicts_with = "curves")]
    fps: u32,
    /// Play this curve set (facslab-curves/1 JSON, e.g. from `facslab curves fit`) instead of
    /// the table; its type must be TYPE.
    #[arg(long)]
    curves: Option<PathBuf>,
    /// Frame size as WIDTHxHEIGHT [default: 485x480].
    #[arg(long, value_parser = engine::parse_size)]
    size: Option<(u32, u32)>,
    /// Also write the curves as a Maya ASCII .anim file.
    #[arg(long)]
    anim: Option<PathBuf>,
    /// Also write the timeline to this JSON file.
    #[arg(long)]
    export_timeline: Option<PathBuf>,
    /// Also write the per-frame ground truth beside the MP4 (same name, .csv).
    #[arg(long)]
    ground_truth: bool,
    /// Also write six frames spread over the take (the middles of six equal parts), side by
    /// side, as a PNG.
    #[arg(long)]
    strip: Option<PathBuf>,
    /// Rendering threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Runs `facslab laugh`.
pub fn laugh_command(args: LaughArgs) -> anyhow::Result<()> {
    let table = LaughTable::built_in();
    if args.list {
        print!("{}", list(table));
        return Ok(());
    }
    let (Some(id), Some(output)) = (&args.laugh_type, &args.output) else { bail!("give a laugh type and -o OUTPUT.mp4 (or --list)") };
    if output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() != Some("mp4") {
        bail!("output {} must end in .mp4", output.display());
    }
    let laugh = table.get(id).with_context(|| format!("laugh type `{}` is not one of: {}", excerpt(id), table.ids().join(", ")))?;
    IdentityTable::active().get(&args.identity)?;
    let curves = match &args.curves {
        Some(path) => read_curves(path, laugh)?,
        None => perform(laugh, &Take { fps: args.fps, duration_s: args.duration, intensity: args.intensity, seed: args.seed })?,
    };
    let size = args.size.unwrap_or(engine::DEFAULT_SIZE);
    let timeline = curves.to_timeline(&args.identity, size);
    timeline.validate(Catalog::built_in()).context("the laugh's timeline")?;
    let settings = FrameSettings { width: size.0, height: size.1, threads: Some(1), style: args.style, ..Default::default() };
    let picks = strip_frames(timeline.frame_count());
    let mut picked: Vec<RgbImage> = Vec::new();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(args.threads.unwrap_or(0)).build()?;
    let bar = crate::progress::bar(timeline.frame_count() as u64, "frames", "laugh");
    let bytes = pool.install(|| {
        stimuli::render_video(&timeline, settings, None, true, None, None, None, &mut |frame, image| {
            bar.set_position(frame as u64 + 1);
            if args.strip.is_some() && picks.contains(&frame) {
                picked.push(image.clone());
            }
        })
    })?;
    bar.finish_and_clear();
    stimuli::build::write_atomic(output, &bytes)?;
    if let Some(path) = &args.anim {
        stimuli::build::write_atomic(path, anim::to_anim(&curves).as_bytes())?;
    }
    if let Some(path) = &args.export_timeline {
        stimuli::build::write_atomic(path, timeline.to_json().as_bytes())?;
    }
    if args.ground_truth {
        stimuli::build::write_atomic(&output.with_extension("csv"), stimuli::manifest::ground_truth_csv(&timeline).as_bytes())?;
    }
    if let Some(path) = &args.strip {
        stimuli::build::write_atomic(path, &side_by_side(&picked).encode_png())?;
    }
    Ok(())
}

fn excerpt(text: &str) -> String {
    text.chars().take(40).collect()
}

/// One line per type: id, name, kind, natural length, description.
fn list(table: &LaughTable) -> String {
    table
        .iter()
        .map(|t| {
            let kind = if t.pulses.is_some() { "laugh" } else { "smile" };
            format!("{:<20} {} ({kind}, {:.1} s): {}\n", t.id, t.name, t.envelope.total(), t.description)
        })
        .collect()
}

/// Reads a curve set for `laugh`, refusing one of another type.
fn read_curves(path: &Path, laugh: &LaughType) -> anyhow::Result<Curves> {
    let bytes = std::fs::metadata(path).with_context(|| format!("reading {}", path.display()))?.len();
    if bytes > MAX_CURVES_BYTES {
        bail!("{} is {bytes} bytes; a curves file has at most {MAX_CURVES_BYTES}", path.display());
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let curves = Curves::from_json(&text, Catalog::built_in()).with_context(|| format!("in {}", path.display()))?;
    if curves.laugh_type != laugh.id {
        bail!("{} holds curves of type `{}`, not `{}`", path.display(), excerpt(&curves.laugh_type), laugh.id);
    }
    Ok(curves)
}
