//! Responses in the long format (design.md §3), read and validated against the manifest.
//!
//! Header: `participant_id,group,stimulus_id,trial,measure,value,rt_ms` (found by name; extra
//! columns are ignored). One row per judgement:
//!
//! | measure | value | stimulus_id |
//! |---|---|---|
//! | `aus` | FACS notation of the AUs a coder marked; empty or `0` = none | required |
//! | `emotion` | an EmFACS label, `none` or `neutral` | required |
//! | `believability` | integer Likert 1–5 | required |
//! | `description_match` | integer 0–5 | required |
//! | `q1`, `q2` | integer 0–5 (seed 004: 0 = very little … 5 = very much) | required |
//! | `age` | years (number in 0–120) | empty |
//! | `gender`, `ethnicity`, `education` | free text (compared case-insensitively) | empty |
//!
//! Policies: `group` must not be empty and must be the same on every row of a participant; a
//! (participant, stimulus, measure) judgement may appear once; a missing judgement is a missing
//! row (never an empty Likert cell). Validation covers the whole file before anything is used.

use std::collections::HashMap;
use std::path::Path;

use super::input::{Fields, FxHashMap, InputError, Place, TableInput};
use super::manifest::Manifest;
use crate::facs::{Catalog, EmotionTable, Expression};

/// The numeric rating measures and their allowed integer ranges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    Believability,
    DescriptionMatch,
    Q1,
    Q2,
}

impl Scale {
    pub const ALL: [Scale; 4] = [Scale::Believability, Scale::DescriptionMatch, Scale::Q1, Scale::Q2];

    pub fn name(self) -> &'static str {
        match self {
            Scale::Believability => "believability",
            Scale::DescriptionMatch => "description_match",
            Scale::Q1 => "q1",
            Scale::Q2 => "q2",
        }
    }

    /// Inclusive integer range.
    pub fn range(self) -> (u8, u8) {
        match self {
            Scale::Believability => (1, 5),
            Scale::DescriptionMatch => (0, 5),
            Scale::Q1 | Scale::Q2 => (0, 5),
        }
    }
}

/// A participant (coder or rater) and their demographics.
#[derive(Debug, Clone, Default)]
pub struct Participant {
    pub id: String,
    /// Index into [`Responses::groups`].
    pub group: usize,
    pub age: Option<f64>,
    pub gender: Option<String>,
    pub ethnicity: Option<String>,
    pub education: Option<String>,
}

/// The AUs one coder marked on one stimulus.
#[derive(Debug, Clone)]
pub struct AuAnswer {
    pub participant: usize,
    pub stimulus: usize,
    pub aus: Expression,
}

/// The emotion one rater chose for one stimulus.
#[derive(Debug, Clone, Copy)]
pub struct EmotionAnswer {
    pub participant: usize,
    pub stimulus: usize,
    /// Index into [`Responses::emotion_labels`].
    pub label: usize,
}

/// One numeric rating.
#[derive(Debug, Clone, Copy)]
pub struct Rating {
    pub participant: usize,
    pub stimulus: usize,
    pub scale: Scale,
    pub value: f64,
}

/// Every response of a study, validated and indexed.
#[derive(Debug, Clone, Default)]
pub struct Responses {
    pub participants: Vec<Participant>,
    pub groups: Vec<String>,
    /// The answer options of the emotion task: the EmFACS labels in table order, then `none`.
    pub emotion_labels: Vec<String>,
    pub aus: Vec<AuAnswer>,
    pub emotions: Vec<EmotionAnswer>,
    pub ratings: Vec<Rating>,
    /// Data rows read.
    pub rows: u64,
}

#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Measure {
    Aus,
    Emotion,
    Scale(Scale),
    Age,
    Gender,
    Ethnicity,
    Education,
}

impl Measure {
    /// Measures given per stimulus (the rest are about the participant).
    const STIMULUS_MEASURES: u64 = 6;

    /// A dense index in `0..STIMULUS_MEASURES` for the measures given per stimulus.
    fn slot(self) -> u64 {
        match self {
            Measure::Aus => 0,
            Measure::Emotion => 1,
            Measure::Scale(Scale::Believability) => 2,
            Measure::Scale(Scale::DescriptionMatch) => 3,
            Measure::Scale(Scale::Q1) => 4,
            Measure::Scale(Scale::Q2) => 5,
            _ => unreachable!("only measures about a stimulus are keyed"),
        }
    }

    /// The measure's name for a [`Measure::slot`].
    fn slot_name(slot: u64) -> &'static str {
        ["aus", "emotion", "believability", "description_match", "q1", "q2"][slot as usize]
    }
}

/// One judgement about a stimulus, for the duplicate check.
#[derive(Clone, Copy)]
struct Judgement {
    key: u64,
    row: u64,
    line: u64,
}

/// The first judgement (in file order) that repeats an earlier one, with that earlier one.
fn first_duplicate(judgements: &mut [Judgement]) -> Option<(Judgement, Judgement)> {
    judgements.sort_unstable_by_key(|j| (j.key, j.row));
    judgements.windows(2).filter(|w| w[0].key == w[1].key).map(|w| (w[0], w[1])).min_by_key(|(_, dup)| dup.row)
}

fn measure(text: &str) -> Option<Measure> {
    Some(match text {
        "aus" => Measure::Aus,
        "emotion" => Measure::Emotion,
        "believability" => Measure::Scale(Scale::Believability),
        "description_match" => Measure::Scale(Scale::DescriptionMatch),
        "q1" => Measure::Scale(Scale::Q1),
        "q2" => Measure::Scale(Scale::Q2),
        "age" => Measure::Age,
        "gender" => Measure::Gender,
        "ethnicity" => Measure::Ethnicity,
        "education" => Measure::Education,
        _ => return None,
    })
}

impl Responses {
    /// Reads and validates a response file against `manifest`.
    pub fn read(path: &Path, manifest: &Manifest, catalog: &Catalog, emotions: &EmotionTable) -> Result<Responses, InputError> {
        Self::parse(TableInput::open(path)?, manifest, catalog, emotions)
    }

    /// Reads responses from CSV text (`name` is used in error messages).
    pub fn from_csv(
        name: &str,
        text: &str,
        manifest: &Manifest,
        catalog: &Catalog,
        emotions: &EmotionTable,
    ) -> Result<Responses, InputError> {
        let bytes = text.as_bytes().to_vec();
        Self::parse(TableInput::from_reader(Path::new(name), Box::new(std::io::Cursor::new(bytes)))?, manifest, catalog, emotions)
    }

    fn parse(mut input: TableInput, manifest: &Manifest, catalog: &Catalog, emotions: &EmotionTable) -> Result<Responses, InputError> {
        let c_part = input.column("participant_id")?;
        let c_group = input.column("group")?;
        let c_stim = input.column("stimulus_id")?;
        let c_trial = input.column("trial")?;
        let c_measure = input.column("measure")?;
        let c_value = input.column("value")?;
        let c_rt = input.column("rt_ms")?;
        let mut out = Responses {
            emotion_labels: emotions.iter().map(|e| e.label.clone()).chain(["none".to_string()]).collect(),
            ..Responses::default()
        };
        let label_index: HashMap<String, usize> = out.emotion_labels.iter().cloned().enumerate().map(|(i, l)| (l, i)).collect();
        // Ids are interned: each distinct participant, group and stimulus id is hashed into its
        // index once per run of equal ids (rows of one participant and one stimulus are usually
        // adjacent), and never copied per row.
        let mut participant_index: FxHashMap<Box<str>, usize> = FxHashMap::default();
        let mut group_index: FxHashMap<Box<str>, usize> = FxHashMap::default();
        let (mut last_pid, mut last_p) = (Vec::<u8>::new(), usize::MAX);
        let (mut last_sid, mut last_s) = (Vec::<u8>::new(), usize::MAX);
        // Every judgement as (participant, stimulus, measure) packed into one integer, with its
        // row and line; duplicates are found by sorting once at the end (or at the first other
        // error, so the error reported is still the first one in file order).
        let mut judgements: Vec<Judgement> = Vec::new();
        let n_stimuli = manifest.len() as u64;
        let mut aus_cache: HashMap<String, Expression> = HashMap::new();
        // `for_each_bytes` borrows the reader mutably; errors are built from a copy of the file name.
        let file = input.file.clone();
        let cell = |place: Place, column: &str, problem: String| InputError::Cell {
            file: file.clone(),
            row: place.row,
            line: place.line,
            column: column.to_string(),
            problem,
        };
        let header = input.header_names();
        let read = input.for_each_bytes(|record, place| {
            let r = Fields::new(record).map_err(|i| cell(place, header.get(i).map_or("?", String::as_str), "not valid UTF-8".into()))?;
            let pid = r.get(c_part);
            if pid.is_empty() {
                return Err(cell(place, "participant_id", "empty participant id".into()));
            }
            let group = r.get(c_group);
            if group.is_empty() {
                return Err(cell(place, "group", "empty group".into()));
            }
            let g = if last_p != usize::MAX && out.groups[out.participants[last_p].group] == group {
                out.participants[last_p].group
            } else {
                match group_index.get(group) {
                    Some(&g) => g,
                    None => {
                        out.groups.push(group.to_string());
                        group_index.insert(group.into(), out.groups.len() - 1);
                        out.groups.len() - 1
                    }
                }
            };
            let p = if last_p != usize::MAX && last_pid == pid.as_bytes() {
                last_p
            } else {
                let p = match participant_index.get(pid) {
                    Some(&p) => p,
                    None => {
                        out.participants.push(Participant { id: pid.to_string(), group: g, ..Participant::default() });
                        participant_index.insert(pid.into(), out.participants.len() - 1);
                        out.participants.len() - 1
                    }
                };
                last_pid.clear();
                last_pid.extend_from_slice(pid.as_bytes());
                last_p = p;
                p
            };
            if out.participants[p].group != g {
                return Err(cell(
                    place,
                    "group",
                    format!("participant \"{pid}\" is in group \"{}\" on an earlier row", out.groups[out.participants[p].group]),
                ));
            }
            let m_text = r.get(c_measure);
            let m = measure(m_text).ok_or_else(|| {
                cell(
                    place,
                    "measure",
                    format!("unknown measure \"{m_text}\" (aus, emotion, believability, description_match, q1, q2, age, gender, ethnicity, education)"),
                )
            })?;
            let trial = r.get(c_trial);
            if !trial.is_empty() && trial.parse::<u64>().is_err() {
                return Err(cell(place, "trial", format!("\"{trial}\" is not a whole number")));
            }
            let rt = r.get(c_rt);
            if !rt.is_empty() && !rt.parse::<f64>().is_ok_and(|v| v.is_finite() && v >= 0.0) {
                return Err(cell(place, "rt_ms", format!("\"{rt}\" is not a non-negative number of milliseconds")));
            }
            let value = r.get(c_value);
            let sid = r.get(c_stim);
            let demographic = matches!(m, Measure::Age | Measure::Gender | Measure::Ethnicity | Measure::Education);
            if demographic {
                if !sid.is_empty() {
                    return Err(cell(place, "stimulus_id", format!("measure \"{m_text}\" is about the participant: stimulus_id must be empty")));
                }
                let slot = match m {
                    Measure::Age => {
                        let age = value.parse::<f64>().ok().filter(|a| (0.0..=120.0).contains(a));
                        let age = age.ok_or_else(|| cell(place, "value", format!("age \"{value}\" is not a number of years in 0-120")))?;
                        out.participants[p].age = Some(age);
                        return Ok(());
                    }
                    Measure::Gender => &mut out.participants[p].gender,
                    Measure::Ethnicity => &mut out.participants[p].ethnicity,
                    _ => &mut out.participants[p].education,
                };
                if !value.is_empty() {
                    *slot = Some(value.to_lowercase());
                }
                return Ok(());
            }
            if sid.is_empty() {
                return Err(cell(place, "stimulus_id", format!("measure \"{m_text}\" needs a stimulus id")));
            }
            let s = if last_s != usize::MAX && last_sid == sid.as_bytes() {
                last_s
            } else {
                let s = manifest
                    .position(sid)
                    .ok_or_else(|| cell(place, "stimulus_id", format!("unknown stimulus id \"{sid}\" (not in the manifest)")))?;
                last_sid.clear();
                last_sid.extend_from_slice(sid.as_bytes());
                last_s = s;
                s
            };
            let key = (p as u64 * n_stimuli + s as u64) * Measure::STIMULUS_MEASURES + m.slot();
            judgements.push(Judgement { key, row: place.row, line: place.line });
            match m {
                Measure::Aus => {
                    let aus = match aus_cache.get(value) {
                        Some(e) => e.clone(),
                        None => {
                            let e = catalog.parse(value).map_err(|e| cell(place, "value", e.to_string()))?;
                            aus_cache.insert(value.to_string(), e.clone());
                            e
                        }
                    };
                    out.aus.push(AuAnswer { participant: p, stimulus: s, aus });
                }
                Measure::Emotion => {
                    let label = label_index.get(value).copied().ok_or_else(|| {
                        cell(place, "value", format!("\"{value}\" is not an emotion label (one of {})", out.emotion_labels.join(", ")))
                    })?;
                    out.emotions.push(EmotionAnswer { participant: p, stimulus: s, label });
                }
                Measure::Scale(scale) => {
                    let (lo, hi) = scale.range();
                    let v = value.parse::<u8>().ok().filter(|v| (lo..=hi).contains(v)).ok_or_else(|| {
                        cell(place, "value", format!("{} \"{value}\" is outside the scale {lo}-{hi} (whole numbers)", scale.name()))
                    })?;
                    out.ratings.push(Rating { participant: p, stimulus: s, scale, value: f64::from(v) });
                }
                _ => unreachable!("demographic measures returned above"),
            }
            Ok(())
        });
        if let Some((first, dup)) = first_duplicate(&mut judgements) {
            let (p, s, m) = (dup.key / (n_stimuli * Measure::STIMULUS_MEASURES), (dup.key / Measure::STIMULUS_MEASURES) % n_stimuli, dup.key % Measure::STIMULUS_MEASURES);
            let (pid, sid, m_text) = (&out.participants[p as usize].id, &manifest.stimuli[s as usize].id, Measure::slot_name(m));
            return Err(cell(
                Place { row: dup.row, line: dup.line },
                "measure",
                format!("participant \"{pid}\" already gave \"{m_text}\" for stimulus \"{sid}\" on row {}", first.row),
            ));
        }
        out.rows = read?;
        Ok(out)
    }

    /// The label index of `label` among the emotion answer options.
    pub fn label(&self, label: &str) -> Option<usize> {
        self.emotion_labels.iter().position(|l| l == label)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MANIFEST: &str = "stimulus_id,media,file,identity,expression,emotion,intensity\n\
        s1,video,s1.mp4,wm1,1+2,,1\n\
        s2,image,s2.png,wf1,6+12+25,happiness,1\n";
    const HEADER: &str = "participant_id,group,stimulus_id,trial,measure,value,rt_ms\n";

    fn read(body: &str) -> Result<Responses, InputError> {
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let manifest = Manifest::from_csv("m.csv", MANIFEST, catalog, &emotions).unwrap();
        Responses::from_csv("r.csv", &format!("{HEADER}{body}"), &manifest, catalog, &emotions)
    }

    #[test]
    fn reads_every_measure() {
        let r = read(
            "c1,coders,s1,1,aus,1+2+R14,1200\n\
             c1,coders,,,age,36,\n\
             c1,coders,,,gender,Female,\n\
             p1,amt,s2,1,emotion,happiness,900\n\
             p1,amt,s2,1,believability,4,\n\
             p1,amt,s1,2,emotion,none,\n\
             p1,amt,s1,2,aus,,\n",
        )
        .unwrap();
        assert_eq!(r.rows, 7);
        assert_eq!(r.groups, ["coders", "amt"]);
        assert_eq!(r.participants[0].age, Some(36.0));
        assert_eq!(r.participants[0].gender.as_deref(), Some("female"));
        assert_eq!(r.aus.len(), 2);
        assert!(r.aus[1].aus.is_neutral());
        assert_eq!(r.emotion_labels[r.emotions[1].label], "none");
        assert_eq!(r.ratings[0].value, 4.0);
    }

    fn error(body: &str) -> String {
        read(body).unwrap_err().to_string()
    }

    #[test]
    fn bad_cells_are_named_by_row_and_column() {
        let e = error("c1,g,s1,1,aus,1+2,\nc1,g,s9,2,aus,1,\n");
        assert!(e.contains("r.csv: row 2 (line 3), column \"stimulus_id\": unknown stimulus id \"s9\""), "{e}");
        let e = error("c1,g,s1,1,aus,1+77,\n");
        assert!(e.contains("row 1 (line 2), column \"value\"") && e.contains("AU 77"), "{e}");
        let e = error("p1,g,s2,1,believability,6,\n");
        assert!(e.contains("column \"value\": believability \"6\" is outside the scale 1-5"), "{e}");
        let e = error("p1,,s2,1,believability,3,\n");
        assert!(e.contains("column \"group\": empty group"), "{e}");
        let e = error("p1,a,s2,1,emotion,joy,\n");
        assert!(e.contains("\"joy\" is not an emotion label"), "{e}");
        let e = error("p1,a,s2,1,emotion,fear,\np1,b,s1,1,emotion,fear,\n");
        assert!(e.contains("row 2 (line 3), column \"group\""), "{e}");
        let e = error("p1,a,s2,1,emotion,fear,\np1,a,s2,1,emotion,anger,\n");
        assert!(e.contains("already gave"), "{e}");
        assert!(e.contains("row 2 (line 3), column \"measure\": participant \"p1\" already gave \"emotion\" for stimulus \"s2\" on row 1"), "{e}");
        // The first error in file order wins, also when the duplicate is found late.
        let e = error("p1,a,s2,1,q1,3,\np1,a,s1,1,q1,3,\np1,a,s2,1,q1,4,\np1,a,s1,1,q1,5,\np2,a,s9,1,q1,3,\n");
        assert!(e.contains("row 3 (line 4), column \"measure\"") && e.contains("on row 1"), "{e}");
        let e = error("p1,a,s2,1,q1,3,\np1,a,s2,1,q1,9,\n");
        assert!(e.contains("row 2 (line 3), column \"measure\""), "{e}");
        let e = error("p1,a,s2,x,emotion,fear,\n");
        assert!(e.contains("column \"trial\""), "{e}");
        let e = error("p1,a,s2,1,mood,fear,\n");
        assert!(e.contains("unknown measure \"mood\""), "{e}");
        let e = error("");
        assert!(e.contains("no data rows"), "{e}");
    }

    #[test]
    fn invalid_utf8_names_row_and_column() {
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let manifest = Manifest::from_csv("m.csv", MANIFEST, catalog, &emotions).unwrap();
        let mut bytes = format!("{HEADER}p1,a,s2,1,emotion,fear,\np2,a,s2,1,emotion,").into_bytes();
        bytes.extend_from_slice(b"\xff\xfe,\n");
        let input = TableInput::from_reader(Path::new("r.csv"), Box::new(std::io::Cursor::new(bytes))).unwrap();
        let e = Responses::parse(input, &manifest, catalog, &emotions).unwrap_err().to_string();
        assert!(e.contains("row 2 (line 3), column \"value\": not valid UTF-8"), "{e}");
    }

    #[test]
    fn missing_column_is_named() {
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let manifest = Manifest::from_csv("m.csv", MANIFEST, catalog, &emotions).unwrap();
        let e = Responses::from_csv("r.csv", "participant_id,group,stimulus_id,trial,value,rt_ms\np,g,s1,1,1,\n", &manifest, catalog, &emotions)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing column \"measure\""), "{e}");
    }
}
