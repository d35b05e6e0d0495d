//! Responses in the long format (design.md §3), read and validated against the manifest.
//!
//! Header: `participant_id,group,stimulus_id,trial,measure,value,rt_ms` (found by name; extra
//! columns are ignored). One row per judgement; the measures, their values and whether a row is
//! about a stimulus or about the participant (`stimulus_id` empty) are those declared in
//! [`crate::study::measure`]. Free-text demographics are compared case-insensitively.
//!
//! Policies: `group` must not be empty and must be the same on every row of a participant; a
//! (participant, stimulus, measure) judgement may appear once; a missing judgement is a missing
//! row (never an empty Likert cell). Validation covers the whole file before anything is used.

use std::path::Path;

use super::input::{Fields, FxHashMap, InputError, Place, TableInput};
use super::manifest::Manifest;
use crate::facs::{Catalog, EmotionTable, Expression};
use crate::study::measure::{About, DECLARATIONS, Demographic, LabelSet, Measure, Value};

pub use crate::study::measure::Scale;

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
    /// The answer options of the forced choice: the labels of the manifest's label set
    /// ([`Manifest::label_set`]; EmFACS for manifests that name none).
    pub emotion_labels: Vec<String>,
    pub aus: Vec<AuAnswer>,
    pub emotions: Vec<EmotionAnswer>,
    pub ratings: Vec<Rating>,
    /// Data rows read.
    pub rows: u64,
}

/// The header of the long format.
pub const LONG_HEADER: &str = "participant_id,group,stimulus_id,trial,measure,value,rt_ms\n";

/// One row of the long format as typed cells: what a study's database yields for an analysis
/// in memory, and what its `responses.csv` export is written from.
#[derive(Debug, Clone, PartialEq)]
pub struct LongRow {
    pub participant_id: String,
    pub group: String,
    /// Empty on rows about the participant.
    pub stimulus_id: String,
    /// 1-based presentation position; `None` on rows about the participant.
    pub trial: Option<i64>,
    pub measure: Measure,
    pub value: String,
    pub rt_ms: Option<f64>,
}

impl LongRow {
    /// Appends the row as a CSV line under [`LONG_HEADER`].
    pub fn write_csv(&self, out: &mut String) {
        let trial = self.trial.map(|t| t.to_string()).unwrap_or_default();
        let rt = self.rt_ms.map(|v| v.to_string()).unwrap_or_default();
        crate::tabular::record(out, [self.participant_id.as_str(), &self.group, &self.stimulus_id, &trial, self.measure.name(), &self.value, &rt]);
    }
}

/// A dense index of a measure, for packing judgement keys.
fn slot(measure: Measure) -> u64 {
    DECLARATIONS.iter().position(|d| d.measure == measure).expect("every measure is declared") as u64
}

const SLOTS: u64 = DECLARATIONS.len() as u64;

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

/// The columns of the long format, by index in the file.
struct Columns {
    participant: usize,
    group: usize,
    stimulus: usize,
    trial: usize,
    measure: usize,
    value: usize,
    rt: usize,
}

impl Columns {
    fn find(input: &TableInput) -> Result<Columns, InputError> {
        Ok(Columns {
            participant: input.column("participant_id")?,
            group: input.column("group")?,
            stimulus: input.column("stimulus_id")?,
            trial: input.column("trial")?,
            measure: input.column("measure")?,
            value: input.column("value")?,
            rt: input.column("rt_ms")?,
        })
    }
}

/// The state of one pass over a response file. Ids are interned: each distinct participant,
/// group and stimulus id is hashed into its index once per run of equal ids (rows of one
/// participant and one stimulus are usually adjacent), and never copied per row.
struct Reader<'a> {
    out: Responses,
    manifest: &'a Manifest,
    catalog: &'a Catalog,
    file: std::path::PathBuf,
    participant_index: FxHashMap<Box<str>, usize>,
    group_index: FxHashMap<Box<str>, usize>,
    last_participant: (Vec<u8>, usize),
    last_stimulus: (Vec<u8>, usize),
    /// Every judgement as (participant, stimulus, measure) packed into one integer, with its row
    /// and line; duplicates are found by sorting once at the end (or at the first other error,
    /// so the error reported is still the first one in file order).
    judgements: Vec<Judgement>,
    aus_cache: FxHashMap<Box<str>, Expression>,
}

impl<'a> Reader<'a> {
    fn new(file: std::path::PathBuf, manifest: &'a Manifest, catalog: &'a Catalog) -> Reader<'a> {
        Reader {
            out: Responses { emotion_labels: manifest.label_set().labels().to_vec(), ..Responses::default() },
            manifest,
            catalog,
            file,
            participant_index: FxHashMap::default(),
            group_index: FxHashMap::default(),
            last_participant: (Vec::new(), usize::MAX),
            last_stimulus: (Vec::new(), usize::MAX),
            judgements: Vec::new(),
            aus_cache: FxHashMap::default(),
        }
    }

    fn cell(&self, place: Place, column: &str, problem: String) -> InputError {
        InputError::Cell { file: self.file.clone(), row: place.row, line: place.line, column: column.to_string(), problem }
    }

    /// Reads one row of a file: checks the cells that are text there, then the judgement.
    fn row(&mut self, r: &Fields<'_>, c: &Columns, place: Place) -> Result<(), InputError> {
        let m_text = r.get(c.measure);
        let trial = r.get(c.trial);
        let rt = r.get(c.rt);
        let (pid, group) = (r.get(c.participant), r.get(c.group));
        self.participant_cells(pid, group, place)?;
        let measure = Measure::parse(m_text)
            .ok_or_else(|| self.cell(place, "measure", format!("unknown measure \"{}\" ({})", crate::study::excerpt(m_text, 32), Measure::names(", "))))?;
        if !trial.is_empty() && trial.parse::<u64>().is_err() {
            return Err(self.cell(place, "trial", format!("\"{}\" is not a whole number", crate::study::excerpt(trial, 32))));
        }
        if !rt.is_empty() && !rt.parse::<f64>().is_ok_and(|v| v.is_finite() && v >= 0.0) {
            return Err(self.cell(place, "rt_ms", format!("\"{}\" is not a non-negative number of milliseconds", crate::study::excerpt(rt, 32))));
        }
        self.judged(pid, group, r.get(c.stimulus), measure, r.get(c.value), place)
    }

    /// Reads one typed row (from a study's database).
    fn long_row(&mut self, r: &LongRow, place: Place) -> Result<(), InputError> {
        self.participant_cells(&r.participant_id, &r.group, place)?;
        if r.rt_ms.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
            return Err(self.cell(place, "rt_ms", "not a non-negative number of milliseconds".into()));
        }
        self.judged(&r.participant_id, &r.group, &r.stimulus_id, r.measure, &r.value, place)
    }

    fn participant_cells(&self, pid: &str, group: &str, place: Place) -> Result<(), InputError> {
        if pid.is_empty() {
            return Err(self.cell(place, "participant_id", "empty participant id".into()));
        }
        if group.is_empty() {
            return Err(self.cell(place, "group", "empty group".into()));
        }
        Ok(())
    }

    /// One judgement: about the participant (no stimulus) or about a stimulus, as declared.
    fn judged(&mut self, pid: &str, group: &str, sid: &str, measure: Measure, value: &str, place: Place) -> Result<(), InputError> {
        let p = self.participant(pid, group, place)?;
        match (measure.about(), sid.is_empty()) {
            (About::Participant, true) => self.demographic(p, measure, value, place),
            (About::Participant, false) => {
                Err(self.cell(place, "stimulus_id", format!("measure \"{}\" is about the participant: stimulus_id must be empty", measure.name())))
            }
            (About::Stimulus, true) => Err(self.cell(place, "stimulus_id", format!("measure \"{}\" needs a stimulus id", measure.name()))),
            (About::Stimulus, false) => {
                let s = self.stimulus(sid, place)?;
                self.judgements.push(Judgement { key: (p as u64 * self.manifest.len() as u64 + s as u64) * SLOTS + slot(measure), row: place.row, line: place.line });
                self.judgement(p, s, measure, value, place)
            }
        }
    }

    /// The index of `group`, added when new.
    fn group(&mut self, group: &str) -> usize {
        if let Some(&g) = self.group_index.get(group) {
            return g;
        }
        self.out.groups.push(group.to_string());
        self.group_index.insert(group.into(), self.out.groups.len() - 1);
        self.out.groups.len() - 1
    }

    /// The index of participant `pid`, added when new; refuses a change of group.
    fn participant(&mut self, pid: &str, group: &str, place: Place) -> Result<usize, InputError> {
        let p = if self.last_participant.1 != usize::MAX && self.last_participant.0 == pid.as_bytes() {
            self.last_participant.1
        } else {
            let p = match self.participant_index.get(pid) {
                Some(&p) => p,
                None => {
                    let g = self.group(group);
                    self.out.participants.push(Participant { id: pid.to_string(), group: g, ..Participant::default() });
                    self.participant_index.insert(pid.into(), self.out.participants.len() - 1);
                    self.out.participants.len() - 1
                }
            };
            self.last_participant.0.clear();
            self.last_participant.0.extend_from_slice(pid.as_bytes());
            self.last_participant.1 = p;
            p
        };
        let earlier = &self.out.groups[self.out.participants[p].group];
        if earlier != group {
            return Err(self.cell(place, "group", format!("participant \"{pid}\" is in group \"{earlier}\" on an earlier row")));
        }
        Ok(p)
    }

    /// The manifest index of stimulus `sid`.
    fn stimulus(&mut self, sid: &str, place: Place) -> Result<usize, InputError> {
        if self.last_stimulus.1 != usize::MAX && self.last_stimulus.0 == sid.as_bytes() {
            return Ok(self.last_stimulus.1);
        }
        let s = self
            .manifest
            .position(sid)
            .ok_or_else(|| self.cell(place, "stimulus_id", format!("unknown stimulus id \"{}\" (not in the manifest)", crate::study::excerpt(sid, 64))))?;
        self.last_stimulus.0.clear();
        self.last_stimulus.0.extend_from_slice(sid.as_bytes());
        self.last_stimulus.1 = s;
        Ok(s)
    }

    fn demographic(&mut self, p: usize, measure: Measure, value: &str, place: Place) -> Result<(), InputError> {
        let parsed = measure.value(value, self.catalog).map_err(|e| self.cell(place, "value", e))?;
        let participant = &mut self.out.participants[p];
        let text = match (measure, parsed) {
            (_, Value::Years(age)) => {
                participant.age = Some(age);
                return Ok(());
            }
            (_, Value::Text(t)) => t,
            _ => unreachable!("demographics are years or text"),
        };
        let slot = match measure {
            Measure::Demographic(Demographic::Gender) => &mut participant.gender,
            Measure::Demographic(Demographic::Ethnicity) => &mut participant.ethnicity,
            _ => &mut participant.education,
        };
        if !text.is_empty() {
            *slot = Some(text.to_lowercase());
        }
        Ok(())
    }

    fn judgement(&mut self, participant: usize, stimulus: usize, measure: Measure, value: &str, place: Place) -> Result<(), InputError> {
        if measure == Measure::Aus {
            let aus = match self.aus_cache.get(value) {
                Some(e) => e.clone(),
                None => {
                    let e = self.catalog.parse(value).map_err(|e| self.cell(place, "value", e.to_string()))?;
                    self.aus_cache.insert(value.into(), e.clone());
                    e
                }
            };
            self.out.aus.push(AuAnswer { participant, stimulus, aus });
            return Ok(());
        }
        match measure.value_in(value, self.catalog, self.manifest.label_set()).map_err(|e| self.cell(place, "value", e))? {
            Value::Label(_, label) => self.out.emotions.push(EmotionAnswer { participant, stimulus, label }),
            Value::Likert(v) => {
                let Measure::Scale(scale) = measure else { unreachable!("Likert values belong to scales") };
                self.out.ratings.push(Rating { participant, stimulus, scale, value: f64::from(v) });
            }
            other => unreachable!("{other:?} is not a value about a stimulus"),
        }
        Ok(())
    }

    /// The first repeated judgement, as an error.
    fn duplicate_error(&mut self) -> Option<InputError> {
        let (first, dup) = first_duplicate(&mut self.judgements)?;
        let n = self.manifest.len() as u64;
        let (p, s, m) = (dup.key / (n * SLOTS), (dup.key / SLOTS) % n, dup.key % SLOTS);
        let (pid, sid, m_text) = (&self.out.participants[p as usize].id, &self.manifest.stimuli[s as usize].id, DECLARATIONS[m as usize].name);
        let message = format!("participant \"{pid}\" already gave \"{m_text}\" for stimulus \"{sid}\" on row {}", first.row);
        Some(self.cell(Place { row: dup.row, line: dup.line }, "measure", message))
    }
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

    /// Reads typed rows (a study's database export, in memory); `name` is used in error
    /// messages, rows are numbered as the same rows in a file would be.
    pub fn from_rows(name: &str, rows: &[LongRow], manifest: &Manifest, catalog: &Catalog) -> Result<Responses, InputError> {
        let mut reader = Reader::new(name.into(), manifest, catalog);
        if rows.is_empty() {
            return Err(InputError::Empty { file: name.into() });
        }
        for (i, row) in rows.iter().enumerate() {
            reader.long_row(row, Place { row: i as u64 + 1, line: i as u64 + 2 })?;
        }
        if let Some(e) = reader.duplicate_error() {
            return Err(e);
        }
        reader.out.rows = rows.len() as u64;
        Ok(reader.out)
    }

    /// `emotions` is the table the manifest was read with; the answer labels are the declared
    /// label set's, which is built from the same shipped table.
    fn parse(mut input: TableInput, manifest: &Manifest, catalog: &Catalog, emotions: &EmotionTable) -> Result<Responses, InputError> {
        debug_assert!(emotions.iter().zip(LabelSet::emfacs().labels()).all(|(e, l)| &e.label == l));
        let columns = Columns::find(&input)?;
        let mut reader = Reader::new(input.file.clone(), manifest, catalog);
        let header = input.header_names();
        let read = input.for_each_bytes(|record, place| {
            let r = Fields::new(record).map_err(|i| reader.cell(place, header.get(i).map_or("?", String::as_str), "not valid UTF-8".into()))?;
            reader.row(&r, &columns, place)
        });
        if let Some(e) = reader.duplicate_error() {
            return Err(e);
        }
        reader.out.rows = read?;
        Ok(reader.out)
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
        let manifest = Manifest::from_csv("m.csv", MANIFEST, catalog).unwrap();
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
        assert!(e.contains("column \"value\": believability \"6\" is outside the scale 0-5"), "{e}");
        let e = error("p1,,s2,1,believability,3,\n");
        assert!(e.contains("column \"group\": empty group"), "{e}");
        let e = error("p1,a,s2,1,emotion,joy,\n");
        assert!(e.contains("\"joy\" is not a label of the emfacs set"), "{e}");
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
    fn typed_rows_read_as_their_csv_does() {
        let body = "c1,coders,s1,1,aus,1+2+R14,1200\nc1,coders,,,age,36,\np1,amt,s2,1,emotion,happiness,900.5\np1,amt,s2,1,believability,4,\n";
        let from_file = read(body).unwrap();
        let catalog = Catalog::built_in();
        let manifest = Manifest::from_csv("m.csv", MANIFEST, catalog).unwrap();
        let row = |pid: &str, group: &str, sid: &str, trial: Option<i64>, measure: Measure, value: &str, rt_ms: Option<f64>| LongRow {
            participant_id: pid.into(),
            group: group.into(),
            stimulus_id: sid.into(),
            trial,
            measure,
            value: value.into(),
            rt_ms,
        };
        let rows = [
            row("c1", "coders", "s1", Some(1), Measure::Aus, "1+2+R14", Some(1200.0)),
            row("c1", "coders", "", None, Measure::Demographic(Demographic::Age), "36", None),
            row("p1", "amt", "s2", Some(1), Measure::Emotion, "happiness", Some(900.5)),
            row("p1", "amt", "s2", Some(1), Measure::Scale(Scale::Believability), "4", None),
        ];
        let mut text = LONG_HEADER.to_string();
        rows.iter().for_each(|r| r.write_csv(&mut text));
        assert_eq!(text, format!("{HEADER}{body}"));
        let typed = Responses::from_rows("db", &rows, &manifest, catalog).unwrap();
        assert_eq!(format!("{typed:?}"), format!("{from_file:?}"));
        let mut twice = rows.to_vec();
        twice.push(rows[2].clone());
        let e = Responses::from_rows("db", &twice, &manifest, catalog).unwrap_err().to_string();
        assert!(e.contains("db: row 5 (line 6), column \"measure\": participant \"p1\" already gave \"emotion\""), "{e}");
    }

    #[test]
    fn invalid_utf8_names_row_and_column() {
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let manifest = Manifest::from_csv("m.csv", MANIFEST, catalog).unwrap();
        let mut bytes = format!("{HEADER}p1,a,s2,1,emotion,fear,\np2,a,s2,1,emotion,").into_bytes();
        bytes.extend_from_slice(b"\xff\xfe,\n");
        let input = TableInput::from_reader(Path::new("r.csv"), Box::new(std::io::Cursor::new(bytes))).unwrap();
        let e = Responses::parse(input, &manifest, catalog, &emotions).unwrap_err().to_string();
        assert!(e.contains("row 2 (line 3), column \"value\": not valid UTF-8"), "{e}");
    }

    #[test]
    fn missing_column_is_named() {
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let manifest = Manifest::from_csv("m.csv", MANIFEST, catalog).unwrap();
        let e = Responses::from_csv("r.csv", "participant_id,group,stimulus_id,trial,value,rt_ms\np,g,s1,1,1,\n", &manifest, catalog, &emotions)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing column \"measure\""), "{e}");
    }
}
