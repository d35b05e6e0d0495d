//! Study designs: the TOML a researcher writes (templates in `studies/`), checked in full.
//!
//! ```toml
//! slug = "exp3"                    # the study's address: /s/exp3
//! title = "Emotions in faces"
//! task = "emotion"                 # au_coding | emotion | rating
//! group = "raters"                 # the `group` column of the exported responses
//! stimuli = "../out/exp3"          # a built stimulus set, relative to this file
//! media = "all"                    # all | image | video
//! labels = "emfacs"                # the label set offered and described (study::labels; default emfacs)
//! intensities = [100]              # peak intensities admitted, whole percent (default: all)
//! trials_per_participant = 0       # 0 = every stimulus; n = a balanced share of n stimuli
//! labels_per_participant = 0       # or n = every stimulus of n labels, a label's one after another
//! ratings_per_stimulus = 0         # with a share: completed ratings wanted per stimulus
//! practice_trials = 1              # shown first, not exported with the trials
//! demographics = true              # age, gender, ethnicity, education (HapFACS Table 6)
//! reservation_minutes = 120        # a participation idle this long is abandoned
//! consent = "…"; instructions = "…"; debrief = "…"
//!
//! [emotion]    believability = true; believability_range = [1, 5]   # [0, 5]: HapFACS's reading
//!              describe_labels = false                              # show each label's description
//! [au_coding]  intensity = false; side = false; together = false   # together: an entry's video + stills, one trial
//! [[rating.item]]  measure = "q1"; prompt = "Does the motion feel right?"; min = 0; max = 5
//! [rating]     side_by_side = false   # a label's stimuli on one screen (with labels_per_participant)
//! [attention]  max_failures = 2; checks = [{ instruction = "…", measure = "emotion", value = "surprise" }]
//! [recruitment] platform = "prolific"; completion_code = "C0DE"
//! [[recruitment.sources]] group = "amt"; platform = "mturk"; completion_code = "…"   # more ways in
//! [[arm]] name = "video-100"; media = "video"; intensities = [100]   # between-subject arms
//! ```
//!
//! Sources (`study::recruitment`): each further platform recruits into the same study and is
//! exported under its own `group`. Arms (`study::arm`): each participant joins one arm and
//! sees only its stimuli (the study's own `media`/`intensities` filter applies first).
//!
//! [`StudyDesign::from_toml`] validates everything (task options, rating ranges against the
//! analysis's scales, attention-check answers, platform settings) and names the field at fault.

use serde::Deserialize;

use super::arm::{Arm, check_arms};
use super::labels::LabelSet;
use super::measure::{Measure, Scale};
pub use super::recruitment::{Platform, Recruitment, Source};

/// A design that cannot be used; `field` says where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("study design, {field}: {message}")]
pub struct DesignError {
    pub field: String,
    pub message: String,
}

pub(crate) fn fail(field: impl Into<String>, message: impl Into<String>) -> DesignError {
    DesignError { field: field.into(), message: message.into() }
}

/// What participants do with each stimulus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskKind {
    /// FACS coders mark the AUs present (measure `aus`).
    AuCoding,
    /// Lay raters choose an emotion (measure `emotion`), optionally rate believability.
    Emotion,
    /// Likert items only (seed 004's Q1/Q2, description match).
    Rating,
}

impl TaskKind {
    pub fn as_str(self) -> &'static str {
        match self {
            TaskKind::AuCoding => "au_coding",
            TaskKind::Emotion => "emotion",
            TaskKind::Rating => "rating",
        }
    }
}

/// Which of the set's stimuli a study uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MediaFilter {
    #[default]
    All,
    Image,
    Video,
}

impl MediaFilter {
    pub fn admits(self, media: crate::stimuli::manifest::Media) -> bool {
        use crate::stimuli::manifest::Media;
        match self {
            MediaFilter::All => true,
            MediaFilter::Image => media == Media::Image,
            MediaFilter::Video => media == Media::Video,
        }
    }
}

/// Whether a stimulus of `media` with peak `intensity` (in [0, 1]) passes a media filter and a
/// list of peak intensities in whole percent (empty: every one): the study's own filter and
/// each arm's (`study::arm`).
pub(crate) fn admits(filter: MediaFilter, intensities: &[u32], media: crate::stimuli::manifest::Media, intensity: f64) -> bool {
    let percent = (intensity * 100.0).round() as u32;
    filter.admits(media) && (intensities.is_empty() || intensities.contains(&percent))
}

/// One Likert item.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LikertItem {
    /// The long format's measure: one of the declared rating scales.
    pub measure: Scale,
    pub prompt: String,
    pub min: u8,
    pub max: u8,
    #[serde(default)]
    pub min_label: String,
    #[serde(default)]
    pub max_label: String,
}

impl LikertItem {
    pub fn values(&self) -> std::ops::RangeInclusive<u8> {
        self.min..=self.max
    }
}

/// An attention check: an instruction shown over a stimulus, with the one answer that passes.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttentionCheck {
    pub instruction: String,
    pub measure: Measure,
    pub value: String,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttentionPolicy {
    #[serde(default)]
    pub checks: Vec<AttentionCheck>,
    /// Screen out after this many failed checks.
    #[serde(default = "two")]
    pub max_failures: u32,
}

fn two() -> u32 {
    2
}

impl Default for AttentionPolicy {
    fn default() -> Self {
        AttentionPolicy { checks: Vec::new(), max_failures: 2 }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmotionOptions {
    /// Ask "How believable is this expression?" after the emotion.
    #[serde(default)]
    pub believability: bool,
    /// The believability item's range `[min, max]` (default `[1, 5]`). HapFACS's text reads
    /// "0: not believable at all, 5: very believable", i.e. `[0, 5]`; the declared scale
    /// (`measure::Scale::Believability`) admits both readings.
    #[serde(default = "believability_range")]
    pub believability_range: [u8; 2],
    /// Show each choice's declared description under its name (off: names only, as HapFACS).
    #[serde(default)]
    pub describe_labels: bool,
}

fn believability_range() -> [u8; 2] {
    [1, 5]
}

impl Default for EmotionOptions {
    fn default() -> Self {
        EmotionOptions { believability: false, believability_range: believability_range(), describe_labels: false }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct CodingOptions {
    /// Coders may give an intensity A–E per AU.
    #[serde(default)]
    pub intensity: bool,
    /// Coders may mark an AU as left or right only.
    #[serde(default)]
    pub side: bool,
    /// One trial per stimulus-set entry: its video with its stills beside it, coded once (HapFACS
    /// Exp. 1). The judgement is stored under the entry's video (`study::entry`); off: one trial
    /// per stimulus.
    #[serde(default)]
    pub together: bool,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct RatingOptions {
    #[serde(default)]
    pub item: Vec<LikertItem>,
    /// A description shown with each stimulus, by the manifest's label (seed 004 shows
    /// participants the expression's description; it is part of the stimulus there). A
    /// stimulus whose label has none here shows its label's declared description.
    #[serde(default)]
    pub descriptions: std::collections::BTreeMap<String, String>,
    /// A label's stimuli on one screen, each with its own items (`study::screen`; needs
    /// `labels_per_participant`): seed 004's study 1 shows the real and the generated video
    /// of a type together.
    #[serde(default)]
    pub side_by_side: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDesign {
    slug: String,
    title: String,
    task: TaskKind,
    #[serde(default = "default_group")]
    group: String,
    stimuli: String,
    #[serde(default)]
    media: MediaFilter,
    #[serde(default)]
    labels: Option<String>,
    #[serde(default)]
    intensities: Vec<u32>,
    #[serde(default)]
    trials_per_participant: usize,
    #[serde(default)]
    labels_per_participant: usize,
    #[serde(default)]
    ratings_per_stimulus: usize,
    #[serde(default)]
    practice_trials: usize,
    #[serde(default = "yes")]
    demographics: bool,
    #[serde(default = "default_reservation")]
    reservation_minutes: u32,
    consent: String,
    instructions: String,
    debrief: String,
    #[serde(default)]
    emotion: EmotionOptions,
    #[serde(default)]
    au_coding: CodingOptions,
    #[serde(default)]
    rating: RatingOptions,
    #[serde(default)]
    attention: AttentionPolicy,
    #[serde(default)]
    recruitment: Recruitment,
    #[serde(default)]
    arm: Vec<Arm>,
}

fn default_group() -> String {
    "participants".into()
}
fn yes() -> bool {
    true
}
fn default_reservation() -> u32 {
    120
}

/// A validated study design.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyDesign {
    pub slug: String,
    pub title: String,
    pub task: TaskKind,
    pub group: String,
    /// The stimulus set directory as written (relative to the design file).
    pub stimuli: String,
    pub media: MediaFilter,
    /// The label set a forced choice offers and descriptions come from (`labels`, default EmFACS).
    pub labels: LabelSet,
    /// The peak intensities admitted, in whole percent (empty = every one).
    pub intensities: Vec<u32>,
    /// 0 = every stimulus.
    pub trials_per_participant: usize,
    /// 0 = no grouping; n = every stimulus of n labels (the least-rated first), each label's
    /// stimuli one after another (seed 004's study 1: six or seven types, the real and the
    /// generated video of each).
    pub labels_per_participant: usize,
    /// 0 = no limit (every participant sees every stimulus).
    pub ratings_per_stimulus: usize,
    pub practice_trials: usize,
    pub demographics: bool,
    pub reservation_minutes: u32,
    pub consent: String,
    pub instructions: String,
    pub debrief: String,
    pub emotion: EmotionOptions,
    pub au_coding: CodingOptions,
    pub rating: RatingOptions,
    pub attention: AttentionPolicy,
    pub recruitment: Recruitment,
    /// Every way in, the study's own `[recruitment]` platform (under `group`) first.
    pub sources: Vec<Source>,
    /// Between-subject arms (empty: every participant draws from all the study's stimuli).
    pub arms: Vec<Arm>,
    /// The Likert items asked after the main question (emotion: believability; rating: items).
    pub items: Vec<LikertItem>,
}

/// The believability item of the emotion task over `[min, max]` (HapFACS: "0: not believable
/// at all, 5: very believable"; facslab's default 1–5).
pub fn believability_item([min, max]: [u8; 2]) -> LikertItem {
    LikertItem {
        measure: Scale::Believability,
        prompt: "How believable is this expression?".into(),
        min,
        max,
        min_label: "not believable at all".into(),
        max_label: "very believable".into(),
    }
}

impl StudyDesign {
    pub fn from_toml(text: &str) -> Result<StudyDesign, DesignError> {
        if text.len() > MAX_DESIGN_BYTES {
            return Err(fail("file", format!("{} bytes is over the 64 KiB a study design may have", text.len())));
        }
        let raw: RawDesign = toml::from_str(text).map_err(|e| fail(toml_field(&e), e.message().to_string()))?;
        raw.validate()
    }

    /// Whether a stimulus of `media` with peak `intensity` (in [0, 1]) belongs to this study.
    pub fn admits(&self, media: crate::stimuli::manifest::Media, intensity: f64) -> bool {
        admits(self.media, &self.intensities, media, intensity)
    }

    /// The measures each main trial records, in column order: the task's own measure, then the
    /// Likert items.
    pub fn measures(&self) -> Vec<Measure> {
        let main = match self.task {
            TaskKind::AuCoding => Some(Measure::Aus),
            TaskKind::Emotion => Some(Measure::Emotion),
            TaskKind::Rating => None,
        };
        main.into_iter().chain(self.items.iter().map(|i| Measure::Scale(i.measure))).collect()
    }

    /// The SHA-256 (hex) of the consent text, stored with each participant's consent.
    pub fn consent_sha256(&self) -> String {
        use sha2::Digest;
        hex::encode(sha2::Sha256::digest(self.consent.as_bytes()))
    }

    /// The source an entry link belongs to, by the worker parameter it carries
    /// ([`super::recruitment::source_for`]).
    pub fn source_for(&self, has_param: impl Fn(&str) -> bool) -> &Source {
        super::recruitment::source_for(&self.sources, has_param)
    }

    /// The source of a participation that stored `platform`.
    pub fn source_of(&self, platform: &str) -> &Source {
        super::recruitment::source_of(&self.sources, platform)
    }

    /// True when participants get a balanced share of the stimuli rather than all of them.
    pub fn shares_stimuli(&self) -> bool {
        self.trials_per_participant > 0 || self.labels_per_participant > 0
    }
}

fn toml_field(e: &toml::de::Error) -> String {
    match e.span() {
        Some(span) => format!("bytes {}..{}", span.start, span.end),
        None => "file".into(),
    }
}

/// Longest design text read.
pub const MAX_DESIGN_BYTES: usize = 64 * 1024;

impl RawDesign {
    /// Upper bounds on the numbers that size a participant's plan (checked before any plan is made).
    fn check_bounds(&self) -> Result<(), DesignError> {
        let bounds = [
            ("trials_per_participant", self.trials_per_participant, 5_000),
            ("labels_per_participant", self.labels_per_participant, 1_000),
            ("ratings_per_stimulus", self.ratings_per_stimulus, 100_000),
            ("practice_trials", self.practice_trials, 50),
            ("attention.checks", self.attention.checks.len(), 50),
            ("rating.item", self.rating.item.len(), 20),
            ("reservation_minutes", self.reservation_minutes as usize, 7 * 24 * 60),
        ];
        match bounds.into_iter().find(|(_, value, max)| value > max) {
            Some((field, value, max)) => Err(fail(field, format!("{value} is over the limit of {max}"))),
            None => Ok(()),
        }
    }

    fn validate(self) -> Result<StudyDesign, DesignError> {
        let slug_ok = !self.slug.is_empty()
            && self.slug.len() <= 64
            && self.slug.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_');
        if !slug_ok {
            return Err(fail("slug", format!("\"{}\" must be 1-64 characters of a-z, 0-9, '-' or '_'", super::excerpt(&self.slug, 64))));
        }
        for (field, text) in [("title", &self.title), ("group", &self.group), ("stimuli", &self.stimuli), ("consent", &self.consent)] {
            if text.trim().is_empty() {
                return Err(fail(field, "must not be empty"));
            }
        }
        if self.group.contains([',', '"', '\n']) {
            return Err(fail("group", "must not contain commas, quotes or line breaks"));
        }
        if self.trials_per_participant > 0 && self.labels_per_participant > 0 {
            return Err(fail("labels_per_participant", "give trials_per_participant (a share of stimuli) or labels_per_participant (whole labels), not both"));
        }
        if self.ratings_per_stimulus > 0 && self.trials_per_participant == 0 && self.labels_per_participant == 0 {
            return Err(fail("ratings_per_stimulus", "needs trials_per_participant > 0 or labels_per_participant > 0 (a share of the stimuli per participant)"));
        }
        if self.rating.side_by_side && (self.task != TaskKind::Rating || self.labels_per_participant == 0) {
            return Err(fail("rating.side_by_side", "shows a label's stimuli on one screen: it needs task = \"rating\" and labels_per_participant > 0"));
        }
        if self.reservation_minutes == 0 {
            return Err(fail("reservation_minutes", "must be at least 1"));
        }
        self.check_bounds()?;
        let items = match self.task {
            TaskKind::Emotion => self.emotion.believability.then(|| believability_item(self.emotion.believability_range)).into_iter().collect(),
            TaskKind::Rating => {
                if self.rating.item.is_empty() {
                    return Err(fail("rating.item", "a rating study needs at least one [[rating.item]]"));
                }
                self.rating.item.clone()
            }
            TaskKind::AuCoding => Vec::new(),
        };
        check_intensities(&self.intensities)?;
        check_items(&items)?;
        let labels = match &self.labels {
            Some(id) => LabelSet::find(id).map_err(|e| fail("labels", e.to_string()))?,
            None => LabelSet::emfacs(),
        };
        check_attention(self.task, &self.attention, &items, labels)?;
        let sources = self.recruitment.checked_sources(&self.group)?;
        check_arms(&self.arm)?;
        Ok(StudyDesign {
            slug: self.slug,
            title: self.title,
            task: self.task,
            group: self.group,
            stimuli: self.stimuli,
            media: self.media,
            labels,
            intensities: self.intensities,
            trials_per_participant: self.trials_per_participant,
            labels_per_participant: self.labels_per_participant,
            ratings_per_stimulus: self.ratings_per_stimulus,
            practice_trials: self.practice_trials,
            demographics: self.demographics,
            reservation_minutes: self.reservation_minutes,
            consent: self.consent,
            instructions: self.instructions,
            debrief: self.debrief,
            emotion: self.emotion,
            au_coding: self.au_coding,
            rating: self.rating,
            attention: self.attention,
            recruitment: self.recruitment,
            sources,
            arms: self.arm,
            items,
        })
    }
}

pub(crate) fn check_intensities(intensities: &[u32]) -> Result<(), DesignError> {
    for (i, &percent) in intensities.iter().enumerate() {
        if !(1..=100).contains(&percent) {
            return Err(fail("intensities", format!("{percent} is not a peak intensity in whole percent (1-100)")));
        }
        if intensities[..i].contains(&percent) {
            return Err(fail("intensities", format!("{percent} is listed twice")));
        }
    }
    Ok(())
}

fn check_items(items: &[LikertItem]) -> Result<(), DesignError> {
    for (i, item) in items.iter().enumerate() {
        let field = format!("rating.item[{}] ({})", i + 1, item.measure.name());
        let (lo, hi) = item.measure.range();
        if item.min >= item.max || item.min < lo || item.max > hi {
            return Err(fail(&field, format!("range {}..{} must lie within the analysis scale {lo}..{hi} and have min < max", item.min, item.max)));
        }
        if items[..i].iter().any(|other| other.measure == item.measure) {
            return Err(fail(&field, "measure asked twice"));
        }
    }
    Ok(())
}

fn check_attention(task: TaskKind, policy: &AttentionPolicy, items: &[LikertItem], labels: LabelSet) -> Result<(), DesignError> {
    if policy.max_failures == 0 {
        return Err(fail("attention.max_failures", "must be at least 1"));
    }
    for (i, check) in policy.checks.iter().enumerate() {
        let field = format!("attention.checks[{}]", i + 1);
        let possible = check.measure.value_in(&check.value, crate::facs::Catalog::built_in(), labels).is_ok();
        let ok = possible
            && match (task, check.measure) {
                (TaskKind::Emotion, Measure::Emotion) | (TaskKind::AuCoding, Measure::Aus) => true,
                (_, Measure::Scale(scale)) => items.iter().any(|item| item.measure == scale && check.value.parse::<u8>().is_ok_and(|v| item.values().contains(&v))),
                _ => false,
            };
        if !ok {
            return Err(fail(field, format!("answer {}=\"{}\" is not a possible answer of this {} task", check.measure.name(), super::excerpt(&check.value, 32), task.as_str())));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = r#"
slug = "exp3"
title = "Emotions"
task = "emotion"
stimuli = "out/exp3"
consent = "I agree."
instructions = "Choose the emotion."
debrief = "Thanks."
"#;

    #[test]
    fn minimal_design_takes_defaults() {
        let d = StudyDesign::from_toml(BASE).unwrap();
        assert_eq!(d.task, TaskKind::Emotion);
        assert_eq!(d.group, "participants");
        assert_eq!(d.attention.max_failures, 2);
        assert!(d.items.is_empty() && d.demographics && !d.shares_stimuli());
        assert_eq!(d.consent_sha256().len(), 64);
    }

    #[test]
    fn intensities_filter_the_stimuli() {
        use crate::stimuli::manifest::Media;
        let d = StudyDesign::from_toml(&format!("{BASE}media = \"video\"\nintensities = [100]\n")).unwrap();
        assert!(d.admits(Media::Video, 1.0) && !d.admits(Media::Video, 0.5) && !d.admits(Media::Image, 1.0));
        let all = StudyDesign::from_toml(BASE).unwrap();
        assert!(all.admits(Media::Video, 0.5) && all.admits(Media::Image, 1.0));
        for bad in ["[0]", "[101]", "[50, 50]"] {
            let e = StudyDesign::from_toml(&format!("{BASE}intensities = {bad}\n")).unwrap_err();
            assert_eq!(e.field, "intensities", "{e}");
        }
    }

    #[test]
    fn believability_adds_an_item() {
        let d = StudyDesign::from_toml(&format!("{BASE}[emotion]\nbelievability = true\n")).unwrap();
        assert_eq!(d.items, vec![believability_item([1, 5])]);
        // The seed's reading, 0 (not believable at all) to 5 (very believable).
        let d = StudyDesign::from_toml(&format!("{BASE}[emotion]\nbelievability = true\nbelievability_range = [0, 5]\n")).unwrap();
        assert_eq!((d.items[0].min, d.items[0].max), (0, 5));
        let e = StudyDesign::from_toml(&format!("{BASE}[emotion]\nbelievability = true\nbelievability_range = [0, 7]\n")).unwrap_err();
        assert_eq!(e.field, "rating.item[1] (believability)", "{e}");
    }

    #[test]
    fn a_design_names_its_label_set() {
        let d = StudyDesign::from_toml(BASE).unwrap();
        assert_eq!(d.labels, LabelSet::emfacs(), "a design without labels means EmFACS");
        let laughs = StudyDesign::from_toml(&format!("labels = \"laughs\"\n{BASE}[attention]\nchecks = [{{ instruction = \"x\", measure = \"emotion\", value = \"sly_smile\" }}]\n")).unwrap();
        assert_eq!(laughs.labels.id(), "laughs");
        let e = StudyDesign::from_toml(&format!("labels = \"laughs\"\n{BASE}[attention]\nchecks = [{{ instruction = \"x\", measure = \"emotion\", value = \"fear\" }}]\n")).unwrap_err();
        assert_eq!(e.field, "attention.checks[1]", "{e}");
        let e = StudyDesign::from_toml(&format!("labels = \"moods\"\n{BASE}")).unwrap_err();
        assert_eq!(e.field, "labels", "{e}");
        assert!(e.message.contains("emfacs, laughs"), "{e}");
    }

    #[test]
    fn sources_bring_their_own_groups_and_entry_parameters() {
        let text = format!("{BASE}group = \"local\"\n[recruitment]\nplatform = \"local\"\n[[recruitment.sources]]\ngroup = \"amt\"\nplatform = \"mturk\"\ncompletion_code = \"C\"\n");
        let d = StudyDesign::from_toml(&text).unwrap();
        let groups: Vec<(&str, Platform)> = d.sources.iter().map(|s| (s.group.as_str(), s.platform)).collect();
        assert_eq!(groups, vec![("local", Platform::Local), ("amt", Platform::Mturk)]);
        assert_eq!(d.source_for(|p| p == "workerId").group, "amt");
        assert_eq!(d.source_for(|_| false).group, "local");
        assert_eq!(d.source_for(|p| p == "PROLIFIC_PID").group, "local", "a platform the study does not use");
        assert_eq!(d.source_of("mturk").completion_code, "C");
        assert_eq!(d.source_of("local").group, "local");
        let bad = [
            ("[recruitment]\n[[recruitment.sources]]\ngroup = \"amt\"\nplatform = \"mturk\"\n", "recruitment.sources[1].completion_code"),
            ("[recruitment]\n[[recruitment.sources]]\ngroup = \"x\"\nplatform = \"local\"\n", "recruitment.sources[1].platform"),
            ("[recruitment]\n[[recruitment.sources]]\ngroup = \"participants\"\nplatform = \"sona\"\nsona_credit_url = \"https://x/{id}\"\n", "recruitment.sources[1]"),
            ("[recruitment]\nplatform = \"sona\"\nsona_credit_url = \"https://x/{id}\"\n[[recruitment.sources]]\ngroup = \"s2\"\nplatform = \"sona\"\nsona_credit_url = \"https://x/{id}\"\n", "recruitment.sources[1]"),
            ("[recruitment]\n[[recruitment.sources]]\ngroup = \"a,b\"\nplatform = \"mturk\"\ncompletion_code = \"C\"\n", "recruitment.sources[1].group"),
        ];
        for (extra, field) in bad {
            let e = StudyDesign::from_toml(&format!("{BASE}{extra}")).unwrap_err();
            assert_eq!(e.field, field, "{e}");
        }
    }

    #[test]
    fn arms_are_read_and_checked() {
        let text = format!("{BASE}[[arm]]\nname = \"images-50\"\nmedia = \"image\"\nintensities = [50]\n[[arm]]\nname = \"videos-100\"\nmedia = \"video\"\nintensities = [100]\n");
        let d = StudyDesign::from_toml(&text).unwrap();
        assert_eq!(d.arms.iter().map(|a| a.name.as_str()).collect::<Vec<_>>(), ["images-50", "videos-100"]);
        let e = StudyDesign::from_toml(&format!("{BASE}[[arm]]\nname = \"a\"\nintensities = [0]\n")).unwrap_err();
        assert_eq!(e.field, "arm[1].intensities", "{e}");
    }

    #[test]
    fn errors_name_the_field() {
        let cases = [
            (BASE.replace("exp3\"", "Exp 3\""), "slug"),
            (format!("{BASE}ratings_per_stimulus = 5\n"), "ratings_per_stimulus"),
            (BASE.replace("\"emotion\"", "\"rating\""), "rating.item"),
            (
                BASE.replace("\"emotion\"", "\"rating\"") + "[[rating.item]]\nmeasure = \"q1\"\nprompt = \"?\"\nmin = 0\nmax = 9\n",
                "rating.item[1] (q1)",
            ),
            (format!("{BASE}[attention]\nchecks = [{{ instruction = \"x\", measure = \"emotion\", value = \"joy\" }}]\n"), "attention.checks[1]"),
            (format!("{BASE}[recruitment]\nplatform = \"prolific\"\n"), "recruitment.completion_code"),
            (format!("{BASE}[recruitment]\nplatform = \"sona\"\nsona_credit_url = \"http://x\"\n"), "recruitment.sona_credit_url"),
            (BASE.replace("\"emotion\"", "\"rating\"") + "[rating]\nside_by_side = true\n[[rating.item]]\nmeasure = \"q1\"\nprompt = \"?\"\nmin = 0\nmax = 5\n", "rating.side_by_side"),
            (format!("labels_per_participant = 2\n{BASE}[rating]\nside_by_side = true\n"), "rating.side_by_side"),
        ];
        for (text, field) in cases {
            let e = StudyDesign::from_toml(&text).unwrap_err();
            assert_eq!(e.field, field, "{e}");
        }
        let e = StudyDesign::from_toml(&format!("{BASE}colour = 1\n")).unwrap_err();
        assert!(e.message.contains("colour"), "{e}");
    }
}
