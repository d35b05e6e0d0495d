//! Stimulus-set specifications (TOML, `stimuli/sets/*.toml`) and their expansion into entries.
//!
//! A spec names the set, its seed, frame size and rate, the identities to rotate over, and
//! groups. Each group takes its expressions from exactly one source (every HapFACS AU, a list
//! of FACS expressions, EmFACS emotions, or CPT appraisal checks) and asks for videos at some
//! peak intensities and stills at some intensities:
//!
//! ```toml
//! name = "exp1"
//! seed = 1001
//! # size = [485, 480]; fps = 30; identities = ["wm1", "wm2", "bm1", "bm2", "wf1", "wf2", "bf1", "bf2"]
//! # identities_file = "people.toml"   # more people (relative to the spec), usable in `identities`
//! # backdrop = "grey"                  # or "black", "#RRGGBB", "transparent" (stills only)
//! # light = "studio"                   # or "soft", "dramatic"
//! # grayscale = false
//!
//! [[group]]
//! name = "single AUs"
//! aus = "hapfacs"                 # or: expressions = ["1+2", …] / emotions = "all" | [..] / cpt = "all" | [..] / labelled (below)
//! video_peaks = [1.0]             # one video per peak intensity
//! stills = [0.3, 0.6, 0.9]        # one still per intensity
//! timing = { onset_s = 1.0, apex_s = 1.0, offset_s = 1.0, ramp = "linear" }   # the default
//! identity = "rotate"             # or "each" (every identity) or one identity id
//! # speak = { sentences = ["…", …], voice = { name = "en-us", rate_wpm = 175, pitch = 50 } }
//!
//! [[group]]
//! name = "laughs"
//! laughs = "all"                  # or a list of ids of stimuli/laughs/types.toml
//! styles = ["realistic", "cartoon"]   # the default is ["realistic"]
//! video_peaks = [1.0]
//! ```
//!
//! A group with `labelled` gives each expression the label it portrays, from any declared label
//! set: the built-in ones or the user's own, declared by `label_sets = ["moods.toml"]` at the
//! top (paths relative to the spec; see `stimuli/labels/` for the format). The built set carries
//! the user's files in `labels/`, so its manifest's labels resolve wherever the set goes:
//!
//! ```toml
//! label_sets = ["moods.toml"]
//! [[group]]
//! name = "moods"
//! labelled = [{ label = "moods:astonished", expression = "1+2+5B+26" }, { label = "happiness", expression = "6+12" }]
//! stills = [1.0]
//! ```
//!
//! A group with `laughs` makes performed laugh and smile videos (see [`crate::laugh`]): each
//! type, on each of its people, one take seeded by the set's seed and its position, drawn in each
//! style from the same curves; the manifest labels it `laughs:<id>` and names its style.
//!
//! A group with `speak` makes speaking videos (see [`crate::speech`]): the face holds the item's
//! expression at each peak while it says a sentence, the sentences dealt out in an order shuffled
//! by the set's seed; `timing` and `stills` do not apply. The speech is synthesised while the
//! spec is read (eSpeak NG is needed then), so the frame count of every video is known before
//! anything is rendered.
//!
//! Validation is complete before anything is rendered: [`SetSpec::from_toml`] returns either the
//! full list of [`Entry`]s or an error naming the group and item at fault.

use serde::Deserialize;

use crate::engine::identity::IdentityTable;
use crate::engine::look::{Backdrop, Look};
use crate::engine::timeline::{ClipTiming, Timeline};
use crate::facs::{AppraisalTable, Catalog, EmotionTable, Expression};
use crate::engine::Style;
use crate::laugh::{LaughTable, Take};
use crate::speech::Staging;


/// A spec that cannot be built; `entry` says where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{entry}: {message}")]
pub struct SpecError {
    pub entry: String,
    pub message: String,
}

fn fail(entry: impl Into<String>, message: impl Into<String>) -> SpecError {
    SpecError { entry: entry.into(), message: message.into() }
}

/// "all" or a list of names.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
enum Selection {
    Word(String),
    List(Vec<String>),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpec {
    name: String,
    #[serde(default)]
    description: String,
    seed: u64,
    #[serde(default)]
    size: Option<[u32; 2]>,
    #[serde(default)]
    fps: Option<u32>,
    #[serde(default)]
    identities: Option<Vec<String>>,
    #[serde(default)]
    identities_file: Option<String>,
    #[serde(default)]
    backdrop: Option<String>,
    #[serde(default)]
    light: Option<String>,
    #[serde(default)]
    grayscale: bool,
    #[serde(default)]
    png_frames: bool,
    /// The user's label-set files (relative to the spec) that `labelled` groups name.
    #[serde(default)]
    label_sets: Vec<String>,
    group: Vec<RawGroup>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGroup {
    name: String,
    #[serde(default)]
    aus: Option<String>,
    #[serde(default)]
    expressions: Option<Vec<String>>,
    #[serde(default)]
    emotions: Option<Selection>,
    #[serde(default)]
    cpt: Option<Selection>,
    #[serde(default)]
    video_peaks: Vec<f64>,
    #[serde(default)]
    stills: Vec<f64>,
    #[serde(default)]
    timing: Option<ClipTiming>,
    #[serde(default)]
    identity: Option<String>,
    #[serde(default)]
    speak: Option<RawSpeak>,
    /// Laugh and smile types of seed 004 (`"all"` or ids of `stimuli/laughs/types.toml`).
    #[serde(default)]
    laughs: Option<Selection>,
    /// For `laughs`: the avatar styles, each type drawn in each (default `["realistic"]`).
    #[serde(default)]
    styles: Option<Vec<String>>,
    /// Expressions with the label each portrays (`moods:astonished`; a bare label is EmFACS).
    #[serde(default)]
    labelled: Option<Vec<RawLabelled>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLabelled {
    label: String,
    expression: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpeak {
    sentences: Vec<String>,
    #[serde(default)]
    voice: crate::speech::Voice,
}

/// The sound and speech of a speaking video, made when the spec is read.
#[derive(Debug, Clone, PartialEq)]
pub struct Spoken {
    pub text: String,
    pub voice: crate::speech::Voice,
    /// The sound, exactly as long as the video.
    pub samples: Vec<i16>,
    pub sample_rate: u32,
    /// The phone and viseme of every frame.
    pub frames: Vec<crate::speech::FrameSpeech>,
}

/// What one stimulus shows.
#[derive(Debug, Clone, PartialEq)]
pub enum Content {
    /// A still of this expression (already at its intensity).
    Image(Expression),
    /// A video: the timeline to render, with its clip timing for the manifest, and for a
    /// speaking video its sound and speech (the timing is then 0 s onset, the whole video as
    /// apex, 0 s offset: the expression is held while the face speaks).
    Video { timeline: Timeline, timing: ClipTiming, speech: Option<std::sync::Arc<Spoken>> },
}

/// One stimulus of a set, fully validated.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Position in the set (0-based); with the seed it gives the opaque stimulus id.
    pub index: usize,
    /// Where it comes from, for messages only (never written where a participant can see it).
    pub origin: String,
    pub identity: String,
    pub content: Content,
    /// FACS notation at the peak; for a CPT sequence, every AU of its steps (each once, at its
    /// highest intensity): the order and timing are in the timeline and the ground truth.
    pub expression: String,
    /// Emotion label or CPT check name; empty for AU stimuli.
    pub emotion: String,
    /// Peak intensity in [0, 1].
    pub intensity: f64,
    /// How the face is drawn, named in the manifest; `None` (every group but `laughs`): the
    /// realistic face, and no style column.
    pub style: Option<Style>,
}

/// A validated stimulus set.
#[derive(Debug, Clone)]
pub struct SetSpec {
    pub name: String,
    pub description: String,
    pub seed: u64,
    pub size: (u32, u32),
    pub fps: u32,
    /// Backdrop, light and colour of every stimulus.
    pub look: Look,
    /// Also write every video frame as PNG (`frames/<id>/000000.png`).
    pub png_frames: bool,
    /// The user's label sets the spec declares (`label_sets`), written into the built set.
    pub label_files: Vec<crate::stimuli::labels::LabelFile>,
    pub entries: Vec<Entry>,
}

/// One expression a group contributes, before media and intensities are applied.
struct Item {
    label: String,
    emotion: String,
    /// One step, or several for a CPT sequence.
    steps: Vec<Expression>,
}

/// Longest spec text read.
pub const MAX_SPEC_BYTES: usize = 1 << 20;
/// Longest expression in a spec.
pub const MAX_EXPRESSION_LEN: usize = crate::facs::MAX_NOTATION_LEN;
/// Most stimuli in one set.
pub const MAX_ENTRIES: usize = 20_000;
/// Most frames one set renders (videos count every frame, stills one).
pub const MAX_SET_FRAMES: usize = 2_000_000;

/// A short excerpt of `text` for a message.
fn excerpt(text: &str) -> String {
    let start: String = text.chars().take(32).collect();
    if start.len() < text.len() { format!("{start}…") } else { start }
}

/// Refuses over-long expressions before they are parsed (parse errors quote their input).
fn check_lengths(raw: &RawSpec) -> Result<(), SpecError> {
    for group in &raw.group {
        let labelled = group.labelled.iter().flatten().map(|l| &l.expression);
        for text in group.aus.iter().chain(group.expressions.iter().flatten()).chain(labelled) {
            if text.len() > MAX_EXPRESSION_LEN {
                return Err(fail(format!("group \"{}\"", excerpt(&group.name)), format!("expression \"{}\" has {} characters; at most {MAX_EXPRESSION_LEN}", excerpt(text), text.len())));
            }
        }
    }
    Ok(())
}

impl SetSpec {
    /// Reads and validates a spec against the built-in catalog, emotion and CPT tables and
    /// identities.
    pub fn from_toml(text: &str) -> Result<SetSpec, SpecError> {
        SetSpec::from_toml_in(text, std::path::Path::new("."))
    }

    /// As [`SetSpec::from_toml`], with the paths inside the spec (`identities_file`) relative
    /// to `base`; the people of `identities_file` are installed for the rest of the process.
    pub fn from_toml_in(text: &str, base: &std::path::Path) -> Result<SetSpec, SpecError> {
        if text.len() > MAX_SPEC_BYTES {
            return Err(fail("spec", format!("{} bytes is over the 1 MiB a set specification may have", text.len())));
        }
        let raw: RawSpec = toml::from_str(text).map_err(|e| fail("spec", format!("not a valid set specification: {e}")))?;
        check_lengths(&raw)?;
        let catalog = Catalog::built_in();
        if let Some(file) = &raw.identities_file {
            let path = base.join(file);
            let people = std::fs::read_to_string(&path).map_err(|e| fail("spec", format!("identities_file {}: {e}", path.display())))?;
            IdentityTable::install(&people).map_err(|e| fail("spec", format!("identities_file {}: {e}", path.display())))?;
        }
        let label_files = read_label_sets(&raw.label_sets, base)?;
        let identities_table = IdentityTable::active();
        let size = raw.size.unwrap_or([crate::engine::DEFAULT_SIZE.0, crate::engine::DEFAULT_SIZE.1]);
        if !(16..=4096).contains(&size[0]) || !(16..=4096).contains(&size[1]) {
            return Err(fail("spec", format!("size {}×{} is out of range (each side 16..=4096)", size[0], size[1])));
        }
        let fps = raw.fps.unwrap_or(crate::engine::timeline::DEFAULT_FPS);
        if !(1..=120).contains(&fps) {
            return Err(fail("spec", format!("fps {fps} is out of range (1..=120)")));
        }
        let rotation: Vec<String> = raw.identities.unwrap_or_else(|| crate::engine::identity::EVALUATION_PEOPLE.iter().map(|s| s.to_string()).collect());
        if rotation.is_empty() {
            return Err(fail("spec", "identities is empty"));
        }
        for id in &rotation {
            identities_table.get(id).map_err(|_| fail("spec", format!("identity \"{id}\" is not known (see `facslab identities`)")))?;
        }
        if raw.group.is_empty() {
            return Err(fail("spec", "no [[group]]"));
        }
        let look = Look::parse(raw.backdrop.as_deref(), raw.light.as_deref(), raw.grayscale).map_err(|e| fail("spec", e.to_string()))?;
        if look.backdrop == Backdrop::Transparent
            && let Some(group) = raw.group.iter().find(|g| !g.video_peaks.is_empty())
        {
            return Err(fail(format!("group \"{}\"", group.name), "videos cannot have a transparent backdrop (remove video_peaks or choose another backdrop)"));
        }

        let mut entries = Vec::new();
        let mut frames = 0usize;
        for (g, group) in raw.group.iter().enumerate() {
            let gname = format!("group {} \"{}\"", g + 1, group.name);
            if let Some(laughs) = &group.laughs {
                let staging = Staging { fps, identity: "", size: (size[0], size[1]), seed: raw.seed };
                for entry in laugh_entries(group, laughs, &gname, &rotation, staging, entries.len(), catalog)? {
                    frames += entry.frames();
                    check_size(entries.len() + 1, frames)?;
                    entries.push(entry);
                }
                continue;
            }
            let items = group_items(group, &gname, catalog)?;
            let timing = group.timing.unwrap_or_default();
            check_timing(&timing).map_err(|m| fail(&gname, m))?;
            for (what, list) in [("video_peaks", &group.video_peaks), ("stills", &group.stills)] {
                if let Some(v) = list.iter().find(|v| !(v.is_finite() && (0.0..=1.0).contains(*v))) {
                    return Err(fail(&gname, format!("{what}: intensity {v} is outside [0, 1]")));
                }
            }
            if group.video_peaks.is_empty() && group.stills.is_empty() {
                return Err(fail(&gname, "asks for no media (set video_peaks and/or stills)"));
            }
            let is_sequence = group.cpt.is_some();
            if is_sequence && !group.stills.is_empty() {
                return Err(fail(&gname, "CPT sequences are videos only (remove stills)"));
            }
            let mode = group.identity.as_deref().unwrap_or("rotate");
            if mode != "rotate" && mode != "each" {
                identities_table
                    .get(mode)
                    .map_err(|_| fail(&gname, format!("identity \"{mode}\" is not known (see `facslab identities`)")))?;
            }
            let sentences = speak_sentences(group, &gname, raw.seed)?;
            let mut speaking = 0usize;
            for (i, item) in items.iter().enumerate() {
                let item_name = format!("{gname}, item {} ({})", i + 1, item.label);
                for identity in people(group, i, &rotation, &item_name)? {
                    if let Some(speak) = &group.speak {
                        let sentence = &sentences[speaking % sentences.len()];
                        speaking += 1;
                        let staging = Staging { fps, identity: &identity, size: (size[0], size[1]), seed: raw.seed ^ entries.len() as u64 };
                        for &peak in &group.video_peaks {
                            let entry = spoken_entry(item, &item_name, sentence, &speak.voice, peak, staging, entries.len(), catalog)?;
                            frames += entry.frames();
                            check_size(entries.len() + 1, frames)?;
                            entries.push(entry);
                        }
                        continue;
                    }
                    for &peak in &group.video_peaks {
                        let steps: Vec<Expression> = item.steps.iter().map(|s| s.scaled(peak)).collect();
                        let timeline = if is_sequence {
                            Timeline::sequence(&steps, timing, fps, &identity, (size[0], size[1]))
                        } else {
                            Timeline::clip(&steps[0], timing, fps, &identity, (size[0], size[1]))
                        };
                        timeline.validate(catalog).map_err(|e| fail(&item_name, e.to_string()))?;
                        frames += timeline.frame_count();
                        check_size(entries.len() + 1, frames)?;
                        entries.push(Entry {
                            index: entries.len(),
                            origin: format!("{item_name}, video at {peak}, {identity}"),
                            identity: identity.clone(),
                            content: Content::Video { timeline, timing, speech: None },
                            expression: union(&steps, catalog).map_err(|e| fail(&item_name, e.to_string()))?.to_string(),
                            emotion: item.emotion.clone(),
                            intensity: peak,
                            style: None,
                        });
                    }
                    for &level in &group.stills {
                        frames += 1;
                        check_size(entries.len() + 1, frames)?;
                        let expression = item.steps[0].scaled(level);
                        entries.push(Entry {
                            index: entries.len(),
                            origin: format!("{item_name}, still at {level}, {identity}"),
                            identity: identity.clone(),
                            expression: expression.to_string(),
                            content: Content::Image(expression),
                            emotion: item.emotion.clone(),
                            intensity: level,
                            style: None,
                        });
                    }
                }
            }
        }
        Ok(SetSpec {
            name: raw.name,
            description: raw.description,
            seed: raw.seed,
            size: (size[0], size[1]),
            fps,
            look,
            png_frames: raw.png_frames,
            label_files,
            entries,
        })
    }

    /// Reads a spec file.
    pub fn load(path: &std::path::Path) -> Result<SetSpec, SpecError> {
        let bytes = std::fs::metadata(path).map_err(|e| fail(path.display().to_string(), e.to_string()))?.len();
        if bytes > MAX_SPEC_BYTES as u64 {
            return Err(fail(path.display().to_string(), format!("{bytes} bytes is over the 1 MiB a set specification may have")));
        }
        let text = std::fs::read_to_string(path).map_err(|e| fail(path.display().to_string(), e.to_string()))?;
        SetSpec::from_toml_in(&text, path.parent().unwrap_or(std::path::Path::new(".")))
    }

    /// How many frames the set renders (videos count every frame; stills count one).
    pub fn frame_total(&self) -> usize {
        self.entries.iter().map(Entry::frames).sum()
    }
}

impl Entry {
    /// Frames this entry renders (a still counts one).
    pub fn frames(&self) -> usize {
        match &self.content {
            Content::Image(_) => 1,
            Content::Video { timeline, .. } => timeline.frame_count(),
        }
    }
}

/// A `speak` group's sentences in the order the set's seed deals them out (empty without
/// `speak`); refuses speaking groups with stills, a timing, a CPT source or bad sentences.
fn speak_sentences(group: &RawGroup, gname: &str, seed: u64) -> Result<Vec<String>, SpecError> {
    let Some(speak) = &group.speak else { return Ok(Vec::new()) };
    if !group.stills.is_empty() || group.timing.is_some() || group.cpt.is_some() {
        return Err(fail(gname, "a speaking group makes videos of held expressions: remove stills, timing and cpt"));
    }
    if speak.sentences.is_empty() {
        return Err(fail(gname, "speak.sentences is empty"));
    }
    for text in &speak.sentences {
        crate::speech::check_text(text).map_err(|e| fail(gname, e.to_string()))?;
    }
    speak.voice.validate().map_err(|e| fail(gname, e.to_string()))?;
    let mut sentences = speak.sentences.clone();
    crate::seeded::SplitMix64(seed ^ 0x5EA4_5EED).shuffle(&mut sentences);
    Ok(sentences)
}

/// One speaking video: `item`'s expression at `peak`, saying `sentence`.
#[allow(clippy::too_many_arguments)]
fn spoken_entry(item: &Item, item_name: &str, sentence: &str, voice: &crate::speech::Voice, peak: f64, staging: Staging, index: usize, catalog: &Catalog) -> Result<Entry, SpecError> {
    let face = item.steps[0].scaled(peak);
    let performance = crate::speech::speak(sentence, voice, &crate::speech::Face::Held(face.clone()), staging).map_err(|e| fail(item_name, e.to_string()))?;
    performance.timeline.validate(catalog).map_err(|e| fail(item_name, e.to_string()))?;
    let timing = ClipTiming { onset_s: 0.0, apex_s: performance.timeline.duration_s, offset_s: 0.0, ramp: Default::default() };
    let spoken = Spoken { text: sentence.to_string(), voice: voice.clone(), samples: performance.samples, sample_rate: performance.sample_rate, frames: performance.frames };
    Ok(Entry {
        index,
        origin: format!("{item_name}, speaking at {peak}, {}", staging.identity),
        identity: staging.identity.to_string(),
        content: Content::Video { timeline: performance.timeline, timing, speech: Some(std::sync::Arc::new(spoken)) },
        expression: face.to_string(),
        emotion: item.emotion.clone(),
        intensity: peak,
        style: None,
    })
}

/// Every AU of `steps`, each once (first appearance order, highest intensity; an AU shown on
/// different sides in different steps becomes bilateral).
fn union(steps: &[Expression], catalog: &Catalog) -> Result<Expression, crate::facs::NotationError> {
    use crate::facs::{Activation, Intensity, Laterality};
    let mut out: Vec<Activation> = Vec::new();
    for activation in steps.iter().flat_map(|s| s.activations()) {
        match out.iter_mut().find(|a| a.au == activation.au) {
            Some(kept) => {
                if kept.side != activation.side {
                    kept.side = Laterality::Both;
                }
                let strongest = kept.strength().max(activation.strength());
                kept.intensity = Some(Intensity::Fraction(strongest));
            }
            None => out.push(*activation),
        }
    }
    Expression::from_activations(out, catalog)
}

/// Refuses a set that grows past [`MAX_ENTRIES`] stimuli or [`MAX_SET_FRAMES`] frames.
fn check_size(entries: usize, frames: usize) -> Result<(), SpecError> {
    if entries > MAX_ENTRIES {
        return Err(fail("spec", format!("the set has more than {MAX_ENTRIES} stimuli")));
    }
    if frames > MAX_SET_FRAMES {
        return Err(fail("spec", format!("the set renders more than {MAX_SET_FRAMES} frames")));
    }
    Ok(())
}

fn check_timing(t: &ClipTiming) -> Result<(), String> {
    for (what, v) in [("onset_s", t.onset_s), ("apex_s", t.apex_s), ("offset_s", t.offset_s)] {
        if !v.is_finite() || v < 0.0 {
            return Err(format!("timing: {what} = {} is a negative (or not a finite) duration", crate::engine::timeline::short_number(v)));
        }
    }
    if t.total_s() <= 0.0 {
        return Err("timing: the clip lasts 0 s".into());
    }
    let max = crate::engine::timeline::MAX_DURATION_S;
    if t.total_s() > max {
        return Err(format!("timing: the clip lasts {} s; at most {max} s", crate::engine::timeline::short_number(t.total_s())));
    }
    Ok(())
}

fn selection<'a>(sel: &'a Selection, gname: &str, what: &str) -> Result<Option<&'a [String]>, SpecError> {
    match sel {
        Selection::Word(w) if w == "all" => Ok(None),
        Selection::Word(w) => Err(fail(gname, format!("{what} = \"{w}\": use \"all\" or a list of names"))),
        Selection::List(list) => Ok(Some(list)),
    }
}

/// A `laughs` group's videos: each type, on each of its people, at each peak, performed with
/// a take seeded by the set's seed and the position of its first entry, then drawn in each
/// style from the same curves. The manifest's
/// timing is the type's nominal phases (rest and rise, apex, fall and rest) stretched to the
/// take's length; the frame-by-frame truth is in the timeline.
fn laugh_entries(
    group: &RawGroup,
    laughs: &Selection,
    gname: &str,
    rotation: &[String],
    staging: Staging<'_>,
    first_index: usize,
    catalog: &Catalog,
) -> Result<Vec<Entry>, SpecError> {
    let other = group.aus.is_some() || group.expressions.is_some() || group.emotions.is_some() || group.cpt.is_some() || group.labelled.is_some() || group.speak.is_some();
    if other || !group.stills.is_empty() || group.timing.is_some() {
        return Err(fail(gname, "a laughs group makes performed videos only: remove aus, expressions, emotions, cpt, labelled, speak, stills and timing"));
    }
    if group.video_peaks.is_empty() {
        return Err(fail(gname, "asks for no media (set video_peaks)"));
    }
    let table = LaughTable::built_in();
    let types: Vec<&crate::laugh::LaughType> = match selection(laughs, gname, "laughs")? {
        None => table.iter().collect(),
        Some(ids) => ids
            .iter()
            .map(|id| table.get(id).ok_or_else(|| fail(gname, format!("laughs: \"{}\" is not a laugh type; the types are: {}", excerpt(id), table.ids().join(", ")))))
            .collect::<Result<_, _>>()?,
    };
    let styles: Vec<Style> = match &group.styles {
        None => vec![Style::Realistic],
        Some(names) if names.is_empty() => return Err(fail(gname, "styles is empty")),
        Some(names) => names.iter().map(|n| n.parse::<Style>().map_err(|e| fail(gname, format!("styles: {e}")))).collect::<Result<_, _>>()?,
    };
    let mut entries = Vec::new();
    for (i, laugh) in types.iter().enumerate() {
        let item_name = format!("{gname}, laugh {} ({})", i + 1, laugh.id);
        for identity in people(group, i, rotation, &item_name)? {
            for &peak in &group.video_peaks {
                // One take per type, person and peak, drawn in every style (the same curves).
                let index = first_index + entries.len();
                let take = Take { fps: staging.fps, duration_s: None, intensity: peak, seed: staging.seed ^ index as u64 };
                let curves = crate::laugh::perform(laugh, &take).map_err(|e| fail(&item_name, e.to_string()))?;
                let timeline = curves.to_timeline(&identity, staging.size);
                timeline.validate(catalog).map_err(|e| fail(&item_name, e.to_string()))?;
                let e = &laugh.envelope;
                let stretch = timeline.duration_s / e.total();
                let timing = ClipTiming { onset_s: (e.lead + e.onset) * stretch, apex_s: e.apex * stretch, offset_s: (e.offset + e.tail) * stretch, ..ClipTiming::default() };
                let expression = curves.peak_expression(catalog).map_err(|e| fail(&item_name, e.to_string()))?.to_string();
                for &style in &styles {
                    entries.push(Entry {
                        index: first_index + entries.len(),
                        origin: format!("{item_name}, {} at {peak}, {identity}", style.name()),
                        identity: identity.clone(),
                        expression: expression.clone(),
                        content: Content::Video { timeline: timeline.clone(), timing, speech: None },
                        emotion: crate::study::labels::Qualified::text("laughs", &laugh.id),
                        intensity: peak,
                        style: Some(style),
                    });
                }
            }
        }
    }
    Ok(entries)
}

/// The people a group's `i`-th item is shown on (its `identity`: rotate, each, or one id).
fn people(group: &RawGroup, i: usize, rotation: &[String], item_name: &str) -> Result<Vec<String>, SpecError> {
    Ok(match group.identity.as_deref().unwrap_or("rotate") {
        "rotate" => vec![rotation[i % rotation.len()].clone()],
        "each" => rotation.to_vec(),
        one => {
            IdentityTable::active().get(one).map_err(|_| fail(item_name, format!("identity \"{one}\" is not known (see `facslab identities`)")))?;
            vec![one.to_string()]
        }
    })
}

/// Registers the spec's `label_sets` files (paths relative to `base`); the user's own sets among
/// them are kept to be written into the built set.
fn read_label_sets(files: &[String], base: &std::path::Path) -> Result<Vec<crate::stimuli::labels::LabelFile>, SpecError> {
    if files.len() > crate::stimuli::labels::MAX_FILES {
        return Err(fail("spec", format!("label_sets names {} files; at most {}", files.len(), crate::stimuli::labels::MAX_FILES)));
    }
    let mut declared: Vec<crate::stimuli::labels::LabelFile> = Vec::new();
    for file in files {
        let read = crate::stimuli::labels::register_file(&base.join(file)).map_err(|e| fail("spec", format!("label_sets: {e}")))?;
        if !read.set.is_built_in() && !declared.iter().any(|d| d.set == read.set) {
            declared.push(read);
        }
    }
    Ok(declared)
}

/// The items of a `labelled` group: each expression with the declared label it portrays.
fn labelled_items(list: &[RawLabelled], gname: &str, catalog: &Catalog) -> Result<Vec<Item>, SpecError> {
    let mut items = Vec::new();
    for (i, item) in list.iter().enumerate() {
        let at = format!("{gname}, item {} (\"{}\")", i + 1, excerpt(&item.label));
        let (set, label) = crate::study::labels::Qualified::split(item.label.trim())
            .resolve()
            .map_err(|e| fail(&at, format!("label: {e} (declare your own set in label_sets)")))?;
        let expression = catalog.parse(&item.expression).map_err(|e| fail(&at, format!("expression: {e}")))?;
        let emotion = crate::study::labels::Qualified::text(set.id(), &label.id);
        items.push(Item { label: emotion.clone(), emotion, steps: vec![expression] });
    }
    Ok(items)
}

fn group_items(group: &RawGroup, gname: &str, catalog: &Catalog) -> Result<Vec<Item>, SpecError> {
    let sources = [group.aus.is_some(), group.expressions.is_some(), group.emotions.is_some(), group.cpt.is_some(), group.labelled.is_some()];
    if sources.iter().filter(|&&s| s).count() != 1 {
        return Err(fail(gname, "needs exactly one of aus, expressions, emotions, cpt, labelled"));
    }
    let mut items = Vec::new();
    if let Some(list) = &group.labelled {
        items.extend(labelled_items(list, gname, catalog)?);
    }
    if let Some(aus) = &group.aus {
        if aus != "hapfacs" && aus != "all" {
            return Err(fail(gname, format!("aus = \"{aus}\": use \"hapfacs\" (the 49 HapFACS AUs) or \"all\"")));
        }
        for unit in catalog.iter().filter(|u| aus == "all" || u.hapfacs) {
            let expression = catalog.parse(&unit.code.to_string()).map_err(|e| fail(gname, e.to_string()))?;
            items.push(Item { label: format!("AU {}", unit.code), emotion: String::new(), steps: vec![expression] });
        }
    }
    if let Some(list) = &group.expressions {
        for (i, text) in list.iter().enumerate() {
            let expression = catalog
                .parse(text)
                .map_err(|e| fail(format!("{gname}, item {} (\"{text}\")", i + 1), e.to_string()))?;
            items.push(Item { label: format!("\"{text}\""), emotion: String::new(), steps: vec![expression] });
        }
    }
    if let Some(sel) = &group.emotions {
        let table = EmotionTable::built_in();
        match selection(sel, gname, "emotions")? {
            None => items.extend(table.iter().map(|e| Item {
                label: e.label.clone(),
                emotion: e.label.clone(),
                steps: vec![e.expression.clone()],
            })),
            Some(names) => {
                for (i, name) in names.iter().enumerate() {
                    let emotion = table.get(name).ok_or_else(|| {
                        fail(format!("{gname}, item {} (\"{name}\")", i + 1), format!("emotion \"{name}\" is not in the EmFACS table"))
                    })?;
                    items.push(Item { label: name.clone(), emotion: name.clone(), steps: vec![emotion.expression.clone()] });
                }
            }
        }
    }
    if let Some(sel) = &group.cpt {
        let table = AppraisalTable::built_in();
        let all: Vec<_> = table.iter().collect();
        let chosen: Vec<_> = match selection(sel, gname, "cpt")? {
            None => all,
            Some(names) => names
                .iter()
                .enumerate()
                .map(|(i, name)| {
                    all.iter().copied().find(|c| &c.name == name).ok_or_else(|| {
                        fail(format!("{gname}, item {} (\"{name}\")", i + 1), format!("CPT check \"{name}\" is not in the appraisal table"))
                    })
                })
                .collect::<Result<_, _>>()?,
        };
        for check in chosen {
            items.push(Item { label: check.name.clone(), emotion: check.name.clone(), steps: check.steps.clone() });
        }
    }
    if items.is_empty() {
        return Err(fail(gname, "selects no expressions"));
    }
    Ok(items)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "name = \"t\"\nseed = 7\nsize = [32, 32]\n";

    fn spec(groups: &str) -> Result<SetSpec, SpecError> {
        SetSpec::from_toml(&format!("{HEAD}{groups}"))
    }

    fn err(groups: &str) -> String {
        spec(groups).unwrap_err().to_string()
    }

    /// Speaking groups are checked before anything is synthesised (so these need no eSpeak NG).
    #[test]
    fn speaking_groups_refuse_stills_timing_and_bad_sentences() {
        let speak = "[[group]]\nname = \"talk\"\nemotions = [\"anger\"]\nvideo_peaks = [1]\n";
        let e = err(&format!("{speak}stills = [1]\n[group.speak]\nsentences = [\"Hi.\"]\n"));
        assert!(e.contains("group 1 \"talk\"") && e.contains("remove stills, timing and cpt"), "{e}");
        let e = err(&format!("{speak}[group.speak]\nsentences = []\n"));
        assert!(e.contains("speak.sentences is empty"), "{e}");
        let e = err(&format!("{speak}[group.speak]\nsentences = [\"  \"]\n"));
        assert!(e.contains("empty"), "{e}");
        let e = err(&format!("{speak}[group.speak]\nsentences = [\"Hi.\"]\nvoice = {{ rate_wpm = 20 }}\n"));
        assert!(e.contains("rate 20"), "{e}");
        let e = err(&format!("{speak}[group.speak]\nsentences = [\"Hi.\"]\nvoice = {{ name = \"en us; rm\" }}\n"));
        assert!(e.contains("voice"), "{e}");
    }

    #[test]
    fn the_seed_experiment_sets_expand_to_the_papers_counts() {
        let load = |name: &str| {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("stimuli/sets").join(name);
            SetSpec::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
        };
        let count = |s: &SetSpec, video: bool| s.entries.iter().filter(|e| matches!(e.content, Content::Video { .. }) == video).count();
        let exp1 = load("exp1.toml");
        assert_eq!((count(&exp1, true), count(&exp1, false)), (49, 147));
        let exp2 = load("exp2.toml");
        assert_eq!((count(&exp2, true), count(&exp2, false)), (54, 54));
        let exp3 = load("exp3.toml");
        assert_eq!((count(&exp3, true), count(&exp3, false)), (20, 20));
        let cpt = load("cpt.toml");
        assert_eq!((count(&cpt, true), count(&cpt, false)), (7, 0));
        let demo = load("demo.toml");
        assert_eq!(count(&demo, true), 2);
        // Exp. 1: a 3-s video at 30 fps, identities rotated over the eight.
        let Content::Video { timeline, .. } = &exp1.entries[0].content else { panic!() };
        assert_eq!((timeline.frame_count(), timeline.fps), (90, 30));
        let ids: Vec<&str> = exp1.entries.iter().step_by(4).take(9).map(|e| e.identity.as_str()).collect();
        assert_eq!(ids, ["wm1", "wm2", "bm1", "bm2", "wf1", "wf2", "bf1", "bf2", "wm1"]);
    }

    #[test]
    fn entries_carry_expression_intensity_and_emotion() {
        let s = spec("[[group]]\nname = \"e\"\nemotions = [\"happiness\"]\nvideo_peaks = [0.5]\nstills = [1.0]\n").unwrap();
        assert_eq!(s.entries.len(), 2);
        assert_eq!(s.entries[0].expression, "6@0.5+12@0.5+25@0.5");
        assert_eq!((s.entries[0].emotion.as_str(), s.entries[0].intensity), ("happiness", 0.5));
        assert_eq!(s.entries[1].expression, "6@1+12@1+25@1");
        let s = spec("[[group]]\nname = \"c\"\ncpt = [\"novelty\"]\nvideo_peaks = [1.0]\n").unwrap();
        assert_eq!(s.entries[0].expression, "1@1+2@1+5@1+4@1+7@1+26@1+38@1");
        let s = spec("[[group]]\nname = \"c\"\ncpt = \"all\"\nvideo_peaks = [0.5]\n").unwrap();
        let high_power = s.entries.iter().find(|e| e.emotion == "control_high_power").unwrap();
        assert_eq!(high_power.expression, "4@0.5+5@0.5+7@0.5+23@0.5+25@0.5+24@0.5+38@0.5");
        for entry in &s.entries {
            Catalog::built_in().parse(&entry.expression).unwrap_or_else(|e| panic!("{}: {e}", entry.emotion));
        }
        let s = spec("[[group]]\nname = \"x\"\nexpressions = [\"12\"]\nstills = [0.5]\nidentity = \"each\"\n").unwrap();
        assert_eq!(s.entries.len(), 8);
    }

    #[test]
    fn bad_specs_name_the_entry() {
        let e = err("[[group]]\nname = \"combos\"\nexpressions = [\"1+2\", \"1+99\"]\nstills = [0.7]\n");
        assert!(e.starts_with("group 1 \"combos\", item 2 (\"1+99\")") && e.contains("AU 99 is not in the catalog"), "{e}");
        let e = err("[[group]]\nname = \"g\"\nexpressions = [\"12\"]\nvideo_peaks = [1]\ntiming = { onset_s = -1.0, apex_s = 1.0, offset_s = 1.0 }\n");
        assert!(e.starts_with("group 1 \"g\"") && e.contains("onset_s = -1 is a negative"), "{e}");
        let e = err("[[group]]\nname = \"g\"\nexpressions = [\"12\"]\nstills = [0.5, 1.5]\n");
        assert!(e.contains("stills: intensity 1.5 is outside [0, 1]"), "{e}");
        let e = err("[[group]]\nname = \"g\"\nexpressions = [\"12\"]\nstills = [0.5]\nidentity = \"xx9\"\n");
        assert!(e.starts_with("group 1 \"g\"") && e.contains("identity \"xx9\" is not known"), "{e}");
        let e = SetSpec::from_toml("name = \"t\"\nseed = 1\nidentities = [\"wm1\", \"zz\"]\n[[group]]\nname = \"g\"\nexpressions = [\"1\"]\nstills = [1]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("identity \"zz\" is not known"), "{e}");
        let e = err("[[group]]\nname = \"g\"\nemotions = [\"joy\"]\nstills = [1]\n");
        assert!(e.contains("item 1 (\"joy\")") && e.contains("not in the EmFACS table"), "{e}");
        let e = err("[[group]]\nname = \"g\"\nexpressions = [\"1\"]\naus = \"hapfacs\"\nstills = [1]\n");
        assert!(e.contains("exactly one of"), "{e}");
        let e = err("[[group]]\nname = \"g\"\nexpressions = [\"1\"]\nstils = [1]\n");
        assert!(e.contains("unknown field"), "{e}");
    }

    #[test]
    fn sizes_are_bounded_before_anything_is_made() {
        let at = std::time::Instant::now();
        let e = err("[[group]]\nname = \"g\"\nexpressions = [\"12\"]\nvideo_peaks = [1]\ntiming = { onset_s = 3e10, apex_s = 0.0, offset_s = 0.0 }\n");
        assert!(e.contains("at most 300 s"), "{e}");
        let long = ["1"; 30_000].join("+").to_string();
        let e = err(&format!("[[group]]\nname = \"g\"\nexpressions = [\"{long}\"]\nstills = [1]\n"));
        assert!(e.contains("at most 512") && e.len() < 200, "{}", e.len());
        let many = (0..200).map(|_| "\"12\"").collect::<Vec<_>>().join(", ");
        let e = err(&format!("[[group]]\nname = \"g\"\nexpressions = [{many}]\nvideo_peaks = [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\nidentity = \"each\"\ntiming = {{ onset_s = 100.0, apex_s = 100.0, offset_s = 100.0 }}\n"));
        assert!(e.contains("more than 2000000 frames"), "{e}");
        assert!(at.elapsed() < std::time::Duration::from_secs(5));
    }
}
