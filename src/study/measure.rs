//! The measures of a study, declared once: what each judgement is called, what it is about, the
//! values it takes, and the codebook's words for it.
//!
//! In: a measure's name (from a study design, a form, a response file). Out: a [`Measure`] and
//! its [`Declaration`], and a value parsed into a [`Value`] or refused with the reason. Every
//! consumer reads this table: design checks, the trial forms (`task`), the analysis's response
//! reader, the exports and their codebook, and the simulator. **Invariant:** a measure name that
//! is not in [`DECLARATIONS`] is not a measure anywhere (`every_consumer_reads_one_table`).

use crate::facs::{Catalog, Expression};

/// A rating scale (a Likert item) and its allowed integer range. In files by its declared name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(into = "&'static str", try_from = "String")]
pub enum Scale {
    Believability,
    DescriptionMatch,
    Q1,
    Q2,
}

/// Something asked once about the participant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Demographic {
    Age,
    Gender,
    Ethnicity,
    Education,
}

/// One kind of judgement of the long response format (design.md §3). In files by its declared
/// name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(into = "&'static str", try_from = "String")]
pub enum Measure {
    /// The AUs a FACS coder marked.
    Aus,
    /// The label a rater chose from a label set.
    Emotion,
    Scale(Scale),
    Demographic(Demographic),
}

/// What a judgement is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum About {
    /// One per (participant, stimulus).
    Stimulus,
    /// One per participant; its rows leave `stimulus_id` empty.
    Participant,
}

/// A closed set of answer labels: declared as data in `study::labels` (`stimuli/labels/*.toml`
/// and the user's own files); a study's forced choice offers its set's labels.
pub use super::labels::LabelSet;

/// The values a measure takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// FACS notation; empty (or `0`) for no AU.
    AuNotation,
    /// One answer of the study's label set ([`LabelSet`]; EmFACS when it names none).
    Labels,
    /// Whole numbers `min..=max`.
    Likert { min: u8, max: u8 },
    /// A number of years in `0..=max`.
    Years { max: u8 },
    /// Free text, compared case-insensitively (stored lowercased by the analysis).
    Text,
}

/// One measure's declaration.
#[derive(Debug, Clone, Copy)]
pub struct Declaration {
    pub measure: Measure,
    /// The name in files, forms and designs.
    pub name: &'static str,
    pub about: About,
    pub kind: Kind,
    /// The codebook's description.
    pub codebook: &'static str,
}

/// Every measure, in the order exports list them.
pub const DECLARATIONS: [Declaration; 10] = [
    declare(Measure::Aus, "aus", About::Stimulus, Kind::AuNotation, "AUs the coder marked, FACS notation (L/R = side, A-E = intensity); empty = no AU"),
    declare(Measure::Emotion, "emotion", About::Stimulus, Kind::Labels, "Label chosen from the study's label set (EmFACS emotions unless the study names another)"),
    // HapFACS reads "0: not believable at all, 5: very believable"; studies ask 1-5 by default.
    declare(Measure::Scale(Scale::Believability), "believability", About::Stimulus, Kind::Likert { min: 0, max: 5 }, "How believable the expression is"),
    declare(Measure::Scale(Scale::DescriptionMatch), "description_match", About::Stimulus, Kind::Likert { min: 0, max: 5 }, "How well the stimulus matches its description"),
    declare(Measure::Scale(Scale::Q1), "q1", About::Stimulus, Kind::Likert { min: 0, max: 5 }, "Rating item q1 (0 = very little ... 5 = very much)"),
    declare(Measure::Scale(Scale::Q2), "q2", About::Stimulus, Kind::Likert { min: 0, max: 5 }, "Rating item q2 (0 = very little ... 5 = very much)"),
    declare(Measure::Demographic(Demographic::Age), "age", About::Participant, Kind::Years { max: 120 }, "Age in years as stated"),
    declare(Measure::Demographic(Demographic::Gender), "gender", About::Participant, Kind::Text, "As stated"),
    declare(Measure::Demographic(Demographic::Ethnicity), "ethnicity", About::Participant, Kind::Text, "As stated"),
    declare(Measure::Demographic(Demographic::Education), "education", About::Participant, Kind::Text, "As stated"),
];

const fn declare(measure: Measure, name: &'static str, about: About, kind: Kind, codebook: &'static str) -> Declaration {
    Declaration { measure, name, about, kind, codebook }
}

impl From<Measure> for &'static str {
    fn from(m: Measure) -> &'static str {
        m.name()
    }
}

impl TryFrom<String> for Measure {
    type Error = String;
    fn try_from(name: String) -> Result<Measure, String> {
        Measure::parse(&name).ok_or_else(|| format!("unknown measure \"{}\" (one of {})", super::excerpt(&name, 32), Measure::names(", ")))
    }
}

impl From<Scale> for &'static str {
    fn from(s: Scale) -> &'static str {
        s.name()
    }
}

impl TryFrom<String> for Scale {
    type Error = String;
    fn try_from(name: String) -> Result<Scale, String> {
        let names = Scale::ALL.map(Scale::name).join(", ");
        Scale::parse(&name).ok_or_else(|| format!("\"{}\" is not a rating scale (one of {names})", super::excerpt(&name, 32)))
    }
}

/// A judgement's value, checked against its measure's [`Kind`].
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Aus(Expression),
    /// A label set and the index into its [`LabelSet::labels`].
    Label(LabelSet, usize),
    Likert(u8),
    Years(f64),
    Text(String),
}

impl Measure {
    /// Every measure, in declaration order.
    pub fn all() -> impl Iterator<Item = Measure> {
        DECLARATIONS.iter().map(|d| d.measure)
    }

    /// The measure called `name`, if any.
    pub fn parse(name: &str) -> Option<Measure> {
        DECLARATIONS.iter().find(|d| d.name == name).map(|d| d.measure)
    }

    pub fn declaration(self) -> &'static Declaration {
        DECLARATIONS.iter().find(|d| d.measure == self).expect("every measure is declared")
    }

    pub fn name(self) -> &'static str {
        self.declaration().name
    }

    pub fn about(self) -> About {
        self.declaration().about
    }

    /// The declared names joined by `sep` (for messages and the codebook's levels).
    pub fn names(sep: &str) -> String {
        DECLARATIONS.iter().map(|d| d.name).collect::<Vec<_>>().join(sep)
    }

    /// Parses `text` as a value of this measure, labels from the EmFACS set, or says why it is
    /// not one.
    pub fn value(self, text: &str, catalog: &Catalog) -> Result<Value, String> {
        self.value_in(text, catalog, LabelSet::emfacs())
    }

    /// Parses `text` as a value of this measure, labels from `labels`, or says why it is not one.
    pub fn value_in(self, text: &str, catalog: &Catalog, labels: LabelSet) -> Result<Value, String> {
        match self.declaration().kind {
            Kind::AuNotation => catalog.parse(text).map(Value::Aus).map_err(|e| e.to_string()),
            Kind::Labels => labels.position(text).map(|i| Value::Label(labels, i)).ok_or_else(|| format!("\"{text}\" is not a label of the {} set (one of {})", labels.id(), labels.labels().join(", "))),
            Kind::Likert { min, max } => text
                .parse::<u8>()
                .ok()
                .filter(|v| (min..=max).contains(v))
                .map(Value::Likert)
                .ok_or_else(|| format!("{} \"{text}\" is outside the scale {min}-{max} (whole numbers)", self.name())),
            Kind::Years { max } => text
                .parse::<f64>()
                .ok()
                .filter(|a| (0.0..=f64::from(max)).contains(a))
                .map(Value::Years)
                .ok_or_else(|| format!("{} \"{text}\" is not a number of years in 0-{max}", self.name())),
            Kind::Text => Ok(Value::Text(text.to_string())),
        }
    }
}

impl Scale {
    pub const ALL: [Scale; 4] = [Scale::Believability, Scale::DescriptionMatch, Scale::Q1, Scale::Q2];

    pub fn name(self) -> &'static str {
        Measure::Scale(self).name()
    }

    /// The scale called `name`, if any.
    pub fn parse(name: &str) -> Option<Scale> {
        match Measure::parse(name) {
            Some(Measure::Scale(s)) => Some(s),
            _ => None,
        }
    }

    /// Inclusive integer range.
    pub fn range(self) -> (u8, u8) {
        match Measure::Scale(self).declaration().kind {
            Kind::Likert { min, max } => (min, max),
            _ => unreachable!("scales are declared as Likert items"),
        }
    }
}

impl Demographic {
    pub const ALL: [Demographic; 4] = [Demographic::Age, Demographic::Gender, Demographic::Ethnicity, Demographic::Education];

    pub fn name(self) -> &'static str {
        Measure::Demographic(self).name()
    }
}

impl Value {
    /// The value as the long format writes it.
    pub fn text(&self, measure: Measure) -> String {
        match (self, measure.declaration().kind) {
            (Value::Aus(e), _) if e.is_neutral() => String::new(),
            (Value::Aus(e), _) => e.to_string(),
            (Value::Label(set, i), Kind::Labels) => set.labels().get(*i).cloned().unwrap_or_default(),
            (Value::Likert(v), _) => v.to_string(),
            (Value::Years(y), _) => y.to_string(),
            (Value::Text(t), _) => t.clone(),
            (Value::Label(_, i), _) => i.to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_consumer_reads_one_table() {
        let names: Vec<&str> = DECLARATIONS.iter().map(|d| d.name).collect();
        assert_eq!(names, ["aus", "emotion", "believability", "description_match", "q1", "q2", "age", "gender", "ethnicity", "education"]);
        for d in &DECLARATIONS {
            assert_eq!(Measure::parse(d.name), Some(d.measure));
            assert_eq!(d.measure.name(), d.name);
        }
        assert_eq!(Measure::parse("mood"), None);
        assert_eq!(Scale::ALL.map(Scale::name), ["believability", "description_match", "q1", "q2"]);
        assert_eq!(Scale::Believability.range(), (0, 5));
        assert_eq!(Scale::parse("age"), None);
        assert!(Demographic::ALL.iter().all(|d| Measure::Demographic(*d).about() == About::Participant));
    }

    #[test]
    fn values_are_checked_against_their_kind() {
        let catalog = Catalog::built_in();
        let b = Measure::Scale(Scale::Believability);
        assert_eq!(b.value("4", catalog), Ok(Value::Likert(4)));
        assert_eq!(b.value("0", catalog), Ok(Value::Likert(0)));
        assert_eq!(b.value("6", catalog).unwrap_err(), "believability \"6\" is outside the scale 0-5 (whole numbers)");
        assert_eq!(Measure::Scale(Scale::Q1).value("0", catalog), Ok(Value::Likert(0)));
        let age = Measure::Demographic(Demographic::Age);
        assert_eq!(age.value("36", catalog), Ok(Value::Years(36.0)));
        assert!(age.value("121", catalog).unwrap_err().contains("0-120"));
        let emotion = Measure::Emotion.value("none", catalog).unwrap();
        assert_eq!(emotion.text(Measure::Emotion), "none");
        assert!(Measure::Emotion.value("joy", catalog).unwrap_err().starts_with("\"joy\" is not a label of the emfacs set (one of "));
        let laughs = LabelSet::find("laughs").unwrap();
        let sly = Measure::Emotion.value_in("sly_smile", catalog, laughs).unwrap();
        assert_eq!(sly.text(Measure::Emotion), "sly_smile");
        assert!(Measure::Emotion.value_in("happiness", catalog, laughs).is_err());
        let aus = Measure::Aus.value("2+1B", catalog).unwrap();
        assert_eq!(aus.text(Measure::Aus), catalog.parse("2+1B").unwrap().to_string());
        assert_eq!(Measure::Aus.value("", catalog).unwrap().text(Measure::Aus), "");
        assert!(Measure::Aus.value("1+77", catalog).is_err());
        // The emotion task's choices: the nine EmFACS emotions, neutral, and none.
        let labels = LabelSet::emfacs().labels();
        assert_eq!(labels.len(), 11);
        assert!(labels.contains(&"neutral".to_string()) && labels.last().map(String::as_str) == Some("none"));
    }
}
