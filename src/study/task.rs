//! A participant's answer to one trial: from submitted form fields to validated judgements.
//!
//! In: a [`Submission`], the same for a plain HTML form post and for the page script's JSON
//! (the script sends the form's fields as `[name, value]` pairs). Out: an [`Answer`], typed
//! [`Judgement`]s of the declared measures (`super::measure`), stored as the `(measure, value)`
//! pairs of the long response format (design.md §3), or an [`AnswerError`] naming the field.
//! Nothing unknown, missing, repeated or out of range gets through.
//!
//! Fields by task: *emotion*: `emotion` (an EmFACS label, `neutral` or `none`); *AU coding*:
//! `au` once per marked AU (its number), optional `intensity_<n>` (A–E) and `side_<n>` (L or R),
//! or `no_aus=1`; *every task*: one field per Likert item, named by its measure.

use serde::Deserialize;

use super::design::{StudyDesign, TaskKind};
use super::measure::{Measure, Value};
use super::viewing::Viewing;
use crate::facs::{Catalog, Expression};

/// Longest accepted field value, in bytes.
const MAX_VALUE: usize = 200;

/// What the browser sends for one trial.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Submission {
    /// Chosen by the page once per trial view; a repeated save with the same key is a no-op.
    pub idempotency_key: String,
    pub fields: Vec<(String, String)>,
    /// Milliseconds from the stimulus's first painted frame to the answer.
    #[serde(default)]
    pub rt_ms: Option<f64>,
    /// For videos: whether the video played to its end before the answer.
    #[serde(default)]
    pub video_ended: Option<bool>,
    /// The stimulus failed to load.
    #[serde(default)]
    pub load_failed: bool,
    /// How the media were viewed (the page script's counts; absent from a plain form post).
    #[serde(default)]
    pub viewing: Option<Viewing>,
}

/// A submission that cannot be stored.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("field \"{field}\": {message}")]
pub struct AnswerError {
    pub field: String,
    pub message: String,
}

pub(super) fn fail(field: impl Into<String>, message: impl Into<String>) -> AnswerError {
    AnswerError { field: super::excerpt(&field.into(), 64), message: super::excerpt(&message.into(), 200) }
}

/// One judgement: a declared measure and a value of its kind. Stored (and serialised) as the
/// long format's `[measure, value]` pair.
#[derive(Debug, Clone, PartialEq)]
pub struct Judgement {
    pub measure: Measure,
    pub value: Value,
}

impl serde::Serialize for Judgement {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        (self.measure.name(), self.value.text(self.measure)).serialize(serializer)
    }
}

/// The validated judgements of one trial, in a fixed order (main measure, then items).
#[derive(Debug, Clone, PartialEq)]
pub struct Answer(pub Vec<Judgement>);

impl Answer {
    pub fn get(&self, measure: Measure) -> Option<&Value> {
        self.0.iter().find(|j| j.measure == measure).map(|j| &j.value)
    }

    /// An emotion task's answer choosing `label` (for tests of the layers that store answers).
    #[cfg(test)]
    pub(crate) fn emotion(label: &str) -> Answer {
        let value = Measure::Emotion.value(label, Catalog::built_in()).expect("an emotion label");
        Answer(vec![Judgement { measure: Measure::Emotion, value }])
    }

    /// The value of `measure` as the long format writes it.
    pub fn text(&self, measure: Measure) -> Option<String> {
        self.get(measure).map(|v| v.text(measure))
    }
}

impl Submission {
    /// Builds a submission from a form post's fields (`idempotency_key`, `rt_ms`, `video_ended`
    /// and `load_failed` are taken out; the rest are the answer's fields).
    pub fn from_form(pairs: Vec<(String, String)>) -> Result<Submission, AnswerError> {
        let mut s = Submission { idempotency_key: String::new(), fields: Vec::new(), rt_ms: None, video_ended: None, load_failed: false, viewing: None };
        for (name, value) in pairs {
            match name.as_str() {
                "idempotency_key" => s.idempotency_key = value,
                "rt_ms" if value.is_empty() => {}
                "rt_ms" => s.rt_ms = Some(value.parse().map_err(|_| fail("rt_ms", "not a number"))?),
                "video_ended" if !value.is_empty() => s.video_ended = Some(value == "1" || value == "true"),
                "load_failed" => s.load_failed = value == "1" || value == "true",
                _ => s.fields.push((name, value)),
            }
        }
        Ok(s)
    }

    /// Checks the key and timing fields that do not depend on the task.
    pub fn check_envelope(&self) -> Result<(), AnswerError> {
        let key_ok = (16..=64).contains(&self.idempotency_key.len())
            && self.idempotency_key.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
        if !key_ok {
            return Err(fail("idempotency_key", "must be 16-64 letters, digits, '-' or '_'"));
        }
        if let Some(rt) = self.rt_ms
            && !(rt.is_finite() && (0.0..=86_400_000.0).contains(&rt))
        {
            return Err(fail("rt_ms", format!("{rt} is not a time between 0 and one day in milliseconds")));
        }
        if let Some(Err(e)) = self.viewing.as_ref().map(Viewing::check) {
            return Err(fail(format!("viewing.{}", e.field), e.message));
        }
        if self.fields.len() > 200 {
            return Err(fail("fields", "too many fields"));
        }
        if let Some((name, _)) = self.fields.iter().find(|(n, v)| n.len() > 64 || v.len() > MAX_VALUE) {
            return Err(fail(name.chars().take(64).collect::<String>(), format!("longer than {MAX_VALUE} bytes")));
        }
        Ok(())
    }

    /// The judgements of this submission under `design`.
    pub fn answer(&self, design: &StudyDesign) -> Result<Answer, AnswerError> {
        self.check_envelope()?;
        let mut fields = Fields::new(&self.fields);
        let mut answer = Vec::new();
        match design.task {
            TaskKind::Emotion => {
                let name = Measure::Emotion.name();
                let label = fields.take_one(name)?.ok_or_else(|| fail(name, "choose one emotion"))?;
                let value = Measure::Emotion.value_in(label, Catalog::built_in(), design.labels).map_err(|_| fail(name, format!("\"{label}\" is not one of the choices")))?;
                answer.push(Judgement { measure: Measure::Emotion, value });
            }
            TaskKind::AuCoding => answer.push(Judgement { measure: Measure::Aus, value: Value::Aus(coded_aus(&mut fields, design)?) }),
            TaskKind::Rating => {}
        }
        for item in &design.items {
            let name = item.measure.name();
            let text = fields.take_one(name)?.ok_or_else(|| fail(name, "please answer this question"))?;
            match text.parse::<u8>() {
                Ok(v) if item.values().contains(&v) => answer.push(Judgement { measure: Measure::Scale(item.measure), value: Value::Likert(v) }),
                _ => return Err(fail(name, format!("\"{text}\" is not a whole number from {} to {}", item.min, item.max))),
            }
        }
        fields.finish()?;
        Ok(Answer(answer))
    }
}

/// The AUs a coder marked (neutral when they marked none).
fn coded_aus(fields: &mut Fields<'_>, design: &StudyDesign) -> Result<Expression, AnswerError> {
    let catalog = Catalog::built_in();
    let marked = fields.take_all("au");
    let none = fields.take_one("no_aus")?.is_some();
    if marked.is_empty() && !none {
        return Err(fail("au", "mark the AUs you see, or tick \"no AU present\""));
    }
    if !marked.is_empty() && none {
        return Err(fail("no_aus", "AUs are marked and \"no AU present\" is ticked"));
    }
    let mut terms = Vec::with_capacity(marked.len());
    for code in marked {
        let number: u16 = code.parse().map_err(|_| fail("au", format!("\"{code}\" is not an AU number")))?;
        let side = match fields.take_one(&format!("side_{number}"))? {
            None | Some("") | Some("B") => "",
            Some(s @ ("L" | "R")) if design.au_coding.side => s,
            Some(other) => return Err(fail(format!("side_{number}"), format!("\"{other}\" is not a side this study asks for"))),
        };
        let letter = match fields.take_one(&format!("intensity_{number}"))? {
            None | Some("") => "",
            Some(l @ ("A" | "B" | "C" | "D" | "E")) if design.au_coding.intensity => l,
            Some(other) => return Err(fail(format!("intensity_{number}"), format!("\"{other}\" is not an intensity this study asks for"))),
        };
        terms.push(format!("{side}{number}{letter}"));
    }
    // The page has an intensity and a side menu for every AU: those of unmarked AUs come empty
    // and mean nothing; a value in one is a slip the coder is told about.
    for (name, value) in fields.take_matching(|n| n.starts_with("intensity_") || n.starts_with("side_")) {
        if !value.is_empty() {
            let (what, au) = name.split_once('_').unwrap_or((name, ""));
            let what = if what == "side" { "a side" } else { "an intensity" };
            return Err(fail(name, format!("AU {au} has {what} but is not marked: mark it, or set the menu back")));
        }
    }
    catalog.parse(&terms.join("+")).map_err(|e| fail("au", e.to_string()))
}

/// The submitted fields, each taken at most once; whatever is left over is an error.
struct Fields<'a> {
    pairs: Vec<(&'a str, &'a str)>,
}

impl<'a> Fields<'a> {
    fn new(pairs: &'a [(String, String)]) -> Fields<'a> {
        Fields { pairs: pairs.iter().map(|(n, v)| (n.as_str(), v.as_str())).collect() }
    }

    fn take_all(&mut self, name: &str) -> Vec<&'a str> {
        let (taken, rest): (Vec<_>, Vec<_>) = self.pairs.iter().partition(|(n, _)| *n == name);
        self.pairs = rest;
        taken.into_iter().map(|(_, v)| v).collect()
    }

    /// Takes every field whose name passes `wanted`, with its value.
    fn take_matching(&mut self, wanted: impl Fn(&str) -> bool) -> Vec<(&'a str, &'a str)> {
        let (taken, rest): (Vec<_>, Vec<_>) = self.pairs.iter().partition(|(n, _)| wanted(n));
        self.pairs = rest;
        taken
    }

    fn take_one(&mut self, name: &str) -> Result<Option<&'a str>, AnswerError> {
        match self.take_all(name)[..] {
            [] => Ok(None),
            [one] => Ok(Some(one)),
            _ => Err(fail(name, "given more than once")),
        }
    }

    fn finish(self) -> Result<(), AnswerError> {
        match self.pairs.first() {
            Some((name, _)) => Err(fail(*name, "not a question of this study")),
            None => Ok(()),
        }
    }
}

/// Whether an attention-check answer passes: the same value, or for AU coding the same AUs.
pub fn passes_check(answer: &Answer, measure: Measure, expected: &str) -> bool {
    let Some(given) = answer.get(measure) else { return false };
    match (given, measure.value(expected, Catalog::built_in())) {
        (Value::Aus(g), Ok(Value::Aus(e))) => g.codes() == e.codes(),
        (Value::Label(set, _), _) => measure.value_in(expected, Catalog::built_in(), *set).is_ok_and(|e| *given == e),
        (given, Ok(expected)) => *given == expected,
        (_, Err(_)) => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn design(task: &str, extra: &str) -> StudyDesign {
        StudyDesign::from_toml(&format!(
            "slug = \"t\"\ntitle = \"T\"\ntask = \"{task}\"\nstimuli = \"s\"\nconsent = \"c\"\ninstructions = \"i\"\ndebrief = \"d\"\n{extra}"
        ))
        .unwrap()
    }

    fn submit(fields: &[(&str, &str)]) -> Submission {
        Submission {
            idempotency_key: "k-0123456789abcdef".into(),
            fields: fields.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect(),
            rt_ms: Some(850.0),
            video_ended: None,
            load_failed: false,
            viewing: None,
        }
    }

    #[test]
    fn emotion_with_believability() {
        let d = design("emotion", "[emotion]\nbelievability = true\n");
        let a = submit(&[("emotion", "fear"), ("believability", "4")]).answer(&d).unwrap();
        assert_eq!(serde_json::to_string(&a.0).unwrap(), r#"[["emotion","fear"],["believability","4"]]"#);
        for (fields, field) in [
            (vec![("believability", "4")], "emotion"),
            (vec![("emotion", "joy"), ("believability", "4")], "emotion"),
            (vec![("emotion", "fear"), ("believability", "6")], "believability"),
            (vec![("emotion", "fear"), ("believability", "4"), ("emotion", "anger")], "emotion"),
            (vec![("emotion", "fear"), ("believability", "4"), ("mood", "x")], "mood"),
        ] {
            assert_eq!(submit(&fields).answer(&d).unwrap_err().field, field);
        }
        // 0 only where the study asks on HapFACS's 0-5 reading.
        assert_eq!(submit(&[("emotion", "fear"), ("believability", "0")]).answer(&d).unwrap_err().field, "believability");
        let paper = design("emotion", "[emotion]\nbelievability = true\nbelievability_range = [0, 5]\n");
        assert!(submit(&[("emotion", "fear"), ("believability", "0")]).answer(&paper).is_ok());
    }

    #[test]
    fn au_coding_builds_notation() {
        let d = design("au_coding", "[au_coding]\nintensity = true\nside = true\n");
        let a = submit(&[("au", "12"), ("au", "1"), ("intensity_12", "C"), ("side_12", "L"), ("au", "2")]).answer(&d).unwrap();
        assert_eq!(a.text(Measure::Aus).as_deref(), Some("L12C+1+2"));
        assert_eq!(submit(&[("no_aus", "1")]).answer(&d).unwrap().text(Measure::Aus).as_deref(), Some(""));
        assert_eq!(submit(&[]).answer(&d).unwrap_err().field, "au");
        assert_eq!(submit(&[("au", "99")]).answer(&d).unwrap_err().field, "au");
        assert_eq!(submit(&[("au", "1"), ("intensity_1", "F")]).answer(&d).unwrap_err().field, "intensity_1");
        // The form sends the empty menus of every AU not marked; a value there is refused.
        let form = [("au", "12"), ("intensity_12", "C"), ("side_12", "L"), ("intensity_1", ""), ("side_1", ""), ("intensity_17", "")];
        assert_eq!(submit(&form).answer(&d).unwrap().text(Measure::Aus).as_deref(), Some("L12C"));
        assert_eq!(submit(&[("no_aus", "1"), ("intensity_1", ""), ("side_2", "")]).answer(&d).unwrap().text(Measure::Aus).as_deref(), Some(""));
        let slip = submit(&[("au", "12"), ("intensity_4", "B")]).answer(&d).unwrap_err();
        assert_eq!((slip.field.as_str(), slip.message.as_str()), ("intensity_4", "AU 4 has an intensity but is not marked: mark it, or set the menu back"));
        assert_eq!(submit(&[("au", "12"), ("side_1", "R")]).answer(&d).unwrap_err().field, "side_1");
        let plain = design("au_coding", "");
        assert_eq!(submit(&[("au", "1"), ("side_1", "L")]).answer(&plain).unwrap_err().field, "side_1");
    }

    #[test]
    fn envelope_checks() {
        let d = design("rating", "[[rating.item]]\nmeasure = \"q1\"\nprompt = \"?\"\nmin = 0\nmax = 5\n");
        let mut s = submit(&[("q1", "0")]);
        assert_eq!(s.answer(&d).unwrap().text(Measure::Scale(super::super::measure::Scale::Q1)).as_deref(), Some("0"));
        s.idempotency_key = "short".into();
        assert_eq!(s.answer(&d).unwrap_err().field, "idempotency_key");
        let mut s = submit(&[("q1", "0")]);
        s.rt_ms = Some(-1.0);
        assert_eq!(s.answer(&d).unwrap_err().field, "rt_ms");
        let mut s = submit(&[("q1", "0")]);
        s.viewing = Some(Viewing { speeds: vec![3.0], ..Viewing::default() });
        assert_eq!(s.answer(&d).unwrap_err().field, "viewing.speeds");
        let long = "x".repeat(300);
        assert_eq!(submit(&[("q1", &long)]).answer(&d).unwrap_err().field, "q1");
    }

    #[test]
    fn form_fields_split_from_the_envelope() {
        let pairs = [("idempotency_key", "abcdefghijklmnop"), ("rt_ms", "12.5"), ("video_ended", "1"), ("emotion", "fear")];
        let s = Submission::from_form(pairs.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect()).unwrap();
        assert_eq!((s.rt_ms, s.video_ended, s.fields.len()), (Some(12.5), Some(true), 1));
    }

    #[test]
    fn attention_checks_compare_values_or_au_sets() {
        let catalog = Catalog::built_in();
        let judge = |measure: Measure, text: &str| Answer(vec![Judgement { measure, value: measure.value(text, catalog).unwrap() }]);
        let a = judge(Measure::Aus, "2+1B");
        assert!(passes_check(&a, Measure::Aus, "1+2"));
        assert!(!passes_check(&a, Measure::Aus, "1"));
        assert!(passes_check(&judge(Measure::Emotion, "surprise"), Measure::Emotion, "surprise"));
        assert!(!passes_check(&judge(Measure::Emotion, "fear"), Measure::Emotion, "surprise"));
        assert!(!passes_check(&Answer(vec![]), Measure::Emotion, "surprise"));
    }
}
