//! Exports of a study's responses: the long CSV (design.md §3, the `analyze` input), a wide CSV
//! (one row per participant), JSON (everything, practice and attention trials included), and
//! the codebook. Exports are streamed: rows are read in participant order and sent on as text
//! chunks, so memory stays flat however large the study.
//!
//! Scope: by default only *completed* participations that are not excluded; `Scope::All` adds
//! every other one except withdrawals (a withdrawn participant's answers never leave).

use std::collections::HashMap;

use futures_util::StreamExt;
use tokio::sync::mpsc;

use super::participants::Demographics;
use super::{Db, DbError, Fields, on_backend};
use crate::analysis::responses::LongRow;
use crate::stimuli::manifest::StimulusId;
use crate::study::StudyDesign;
use crate::study::measure::{Demographic, Kind, Measure};
use crate::study::viewing::{self, Viewing};

/// Which participations an export includes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scope {
    /// Completed and not excluded.
    #[default]
    Completed,
    /// Every participation except withdrawn ones.
    All,
}

/// The export formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Long,
    Wide,
    Json,
}

impl Format {
    pub fn parse(text: &str) -> Option<Format> {
        match text {
            "long" | "responses.csv" => Some(Format::Long),
            "wide" | "wide.csv" => Some(Format::Wide),
            "json" | "responses.json" => Some(Format::Json),
            _ => None,
        }
    }

    pub fn content_type(self) -> &'static str {
        match self {
            Format::Long | Format::Wide => "text/csv; charset=utf-8",
            Format::Json => "application/json",
        }
    }

    pub fn file_name(self, slug: &str) -> String {
        match self {
            Format::Long => format!("{slug}-responses.csv"),
            Format::Wide => format!("{slug}-wide.csv"),
            Format::Json => format!("{slug}-responses.json"),
        }
    }
}

pub use crate::analysis::responses::LONG_HEADER;

/// One participant's answers, gathered while streaming.
#[derive(Debug, Default, serde::Serialize)]
struct ParticipantRecord {
    participant_id: String,
    group: String,
    /// The between-subject arm (`study::arm`; empty without arms).
    arm: String,
    state: String,
    excluded: bool,
    demographics: Option<Demographics>,
    trials: Vec<TrialRecord>,
}

#[derive(Debug, serde::Serialize)]
struct TrialRecord {
    trial: i64,
    kind: String,
    /// The stimulus the answers are about (with `[au_coding] together`, the entry's lead).
    stimulus_id: String,
    /// Every stimulus the trial showed: `stimulus_id` first, then those beside it in page order.
    shown: Vec<String>,
    answers: Vec<(String, String)>,
    rt_ms: Option<f64>,
    video_ended: Option<bool>,
    load_failed: bool,
    /// Replays, frame steps, speeds and time on task (`study::viewing`); null without the page script.
    viewing: Option<Viewing>,
    received_at: i64,
}

/// The measures a study's answers have, in column order (their names).
pub fn measures(design: &StudyDesign) -> Vec<String> {
    design.measures().into_iter().map(|m| m.name().to_string()).collect()
}

impl ParticipantRecord {
    /// The participant's judgements as rows of the long format: demographics first, then the
    /// main trials' answers in presentation order (practice and attention trials are left out).
    fn long_rows(&self) -> Result<Vec<LongRow>, DbError> {
        let row = |stimulus_id: &str, trial: Option<i64>, measure: Measure, value: &str, rt_ms: Option<f64>| LongRow {
            participant_id: self.participant_id.clone(),
            group: self.group.clone(),
            stimulus_id: stimulus_id.to_string(),
            trial,
            measure,
            value: value.to_string(),
            rt_ms: rt_ms.map(|v| (v * 10.0).round() / 10.0),
        };
        let mut rows = Vec::new();
        if let Some(d) = &self.demographics {
            rows.extend(Demographic::ALL.iter().map(|&m| (m, d.text(m))).filter(|(_, v)| !v.is_empty()).map(|(m, v)| row("", None, Measure::Demographic(m), &v, None)));
        }
        for t in self.trials.iter().filter(|t| t.kind == "trial") {
            for (name, value) in &t.answers {
                let measure = Measure::parse(name).ok_or_else(|| DbError::Internal(format!("stored answer has an unknown measure \"{}\"", crate::study::excerpt(name, 32))))?;
                rows.push(row(&t.stimulus_id, Some(t.trial), measure, value, t.rt_ms));
            }
        }
        Ok(rows)
    }

    fn wide_row(&self, columns: &[(String, String)], out: &mut String) {
        let d = self.demographics.clone().unwrap_or_default();
        let mut cells = vec![self.participant_id.clone(), self.group.clone(), self.arm.clone()];
        cells.extend(Demographic::ALL.map(|m| d.text(m)));
        let answers: HashMap<(&str, &str), &str> = self
            .trials
            .iter()
            .filter(|t| t.kind == "trial")
            .flat_map(|t| t.answers.iter().map(move |(m, v)| ((t.stimulus_id.as_str(), m.as_str()), v.as_str())))
            .collect();
        for (stimulus, measure) in columns {
            cells.push(answers.get(&(stimulus.as_str(), measure.as_str())).map(|v| v.to_string()).unwrap_or_default());
        }
        crate::tabular::record(out, cells);
    }
}

/// The scope's condition on participations.
pub(super) fn scope_sql(scope: Scope) -> &'static str {
    match scope {
        Scope::Completed => "p.state = 'completed' AND NOT p.excluded",
        Scope::All => "p.state <> 'withdrawn'",
    }
}

impl Db {
    /// Streams an export as text chunks (the receiver ends after the last chunk or an error).
    pub fn export(&self, study_id: i64, design: &StudyDesign, stimuli: Vec<StimulusId>, format: Format, scope: Scope) -> mpsc::Receiver<Result<String, DbError>> {
        let (tx, rx) = mpsc::channel(16);
        let db = self.clone();
        let measures = measures(design);
        tokio::spawn(async move {
            if let Err(e) = db.export_into(study_id, &measures, &stimuli, format, scope, &tx).await {
                let _ = tx.send(Err(e)).await;
            }
        });
        rx
    }

    /// Every judgement of a study as typed rows of the long format (what `responses.csv` holds),
    /// for an analysis in memory.
    pub async fn long_rows(&self, study_id: i64, scope: Scope) -> Result<Vec<LongRow>, DbError> {
        let mut rows = Vec::new();
        let mut failure = None;
        self.records(study_id, scope, |record| {
            let keep_going = match record.long_rows() {
                Ok(these) => {
                    rows.extend(these);
                    true
                }
                Err(e) => {
                    failure = Some(e);
                    false
                }
            };
            async move { keep_going }
        })
        .await?;
        failure.map_or(Ok(rows), Err)
    }

    async fn export_into(&self, study_id: i64, measures: &[String], stimuli: &[StimulusId], format: Format, scope: Scope, tx: &mpsc::Sender<Result<String, DbError>>) -> Result<(), DbError> {
        let columns: Vec<(String, String)> = stimuli.iter().flat_map(|s| measures.iter().map(move |m| (s.to_string(), m.clone()))).collect();
        if tx.send(Ok(head(format, &columns))).await.is_err() {
            return Ok(());
        }
        let mut first = true;
        let mut chunk = String::new();
        let mut failure = None;
        self.records(study_id, scope, |record| {
            let emitted = emit(&record, format, &columns, &mut first, &mut chunk);
            let full = (chunk.len() > 64 * 1024).then(|| std::mem::take(&mut chunk));
            let keep_going = emitted.map_err(|e| failure = Some(e)).is_ok();
            async move {
                match full {
                    Some(text) if keep_going => tx.send(Ok(text)).await.is_ok(),
                    _ => keep_going,
                }
            }
        })
        .await?;
        if let Some(e) = failure {
            return Err(e);
        }
        if format == Format::Json {
            chunk.push_str("\n]}\n");
        }
        let _ = tx.send(Ok(chunk)).await;
        Ok(())
    }

    /// Reads the scope's participations with their saved trials, one participant at a time in
    /// participant order, handing each to `each` (which returns false to stop).
    async fn records<F, Fut>(&self, study_id: i64, scope: Scope, mut each: F) -> Result<(), DbError>
    where
        F: FnMut(ParticipantRecord) -> Fut,
        Fut: std::future::Future<Output = bool>,
    {
        let demographics = self.demographics_of(study_id).await?;
        let beside = self.shown_beside(study_id).await?;
        let sql = format!(
            "SELECT p.id, p.public_id, p.grp, p.state, p.excluded, t.position, t.kind, t.stimulus_id, r.answers, r.rt_ms, r.video_ended, r.load_failed, r.received_at, r.viewing, p.arm
             FROM participants p JOIN trials t ON t.participant_id = p.id JOIN responses r ON r.participant_id = t.participant_id AND r.position = t.position
             WHERE p.study_id = $1 AND {} ORDER BY p.id, t.position",
            scope_sql(scope)
        );
        on_backend!(self, b => {
        let mut rows = sqlx::query(sqlx::AssertSqlSafe(sql)).bind(study_id).fetch(&b.reader);
        let mut current: Option<(i64, ParticipantRecord)> = None;
        while let Some(row) = rows.next().await {
            let row = row?;
            let id: i64 = row.get(0);
            if current.as_ref().is_none_or(|(cid, _)| *cid != id) {
                if let Some((_, record)) = current.take()
                    && !each(record).await
                {
                    return Ok(());
                }
                let record = ParticipantRecord {
                    participant_id: row.get(1),
                    group: row.get(2),
                    arm: row.get(14),
                    state: row.get(3),
                    excluded: row.get(4),
                    demographics: demographics.get(&id).cloned(),
                    trials: Vec::new(),
                };
                current = Some((id, record));
            }
            if let Some((_, record)) = current.as_mut() {
                record.trials.push(trial_record(&row, &beside)?);
            }
        }
        if let Some((_, record)) = current.take() {
            each(record).await;
        }
        Ok(())
        })
    }

    /// The stimuli each lead shows beside it, in page order (`[au_coding] together`).
    async fn shown_beside(&self, study_id: i64) -> Result<HashMap<String, Vec<String>>, DbError> {
        let sql = "SELECT lead, stimulus_id FROM stimuli WHERE study_id = $1 AND lead IS NOT NULL ORDER BY lead, part";
        let rows: Vec<(String, String)> = on_backend!(self, b => sqlx::query_as(sql).bind(study_id).fetch_all(&b.reader).await?);
        let mut beside: HashMap<String, Vec<String>> = HashMap::new();
        for (lead, stimulus) in rows {
            beside.entry(lead).or_default().push(stimulus);
        }
        Ok(beside)
    }

    pub(super) async fn demographics_of(&self, study_id: i64) -> Result<HashMap<i64, Demographics>, DbError> {
        let sql = "SELECT d.participant_id, d.age, d.gender, d.ethnicity, d.education FROM demographics d JOIN participants p ON p.id = d.participant_id WHERE p.study_id = $1";
        let rows: Vec<(i64, Option<i64>, String, String, String)> = on_backend!(self, b => sqlx::query_as(sql).bind(study_id).fetch_all(&b.reader).await?);
        Ok(rows.into_iter().map(|(id, age, gender, ethnicity, education)| (id, Demographics { age, gender, ethnicity, education })).collect())
    }
}

/// One saved trial of the export query's row (`beside`: what each lead shows beside it).
fn trial_record(row: &impl Fields, beside: &HashMap<String, Vec<String>>) -> Result<TrialRecord, DbError> {
    let answers: String = row.get(8);
    let answers: Vec<(String, String)> = serde_json::from_str(&answers).map_err(|e| DbError::Internal(format!("stored answer unreadable: {e}")))?;
    let viewing = row.get::<Option<String>, _>(13).map(|v| serde_json::from_str(&v)).transpose().map_err(|e| DbError::Internal(format!("stored viewing unreadable: {e}")))?;
    let stimulus_id: String = row.get(7);
    let shown = std::iter::once(stimulus_id.clone()).chain(beside.get(&stimulus_id).into_iter().flatten().cloned()).collect();
    Ok(TrialRecord {
        trial: row.get::<i64, _>(5) + 1,
        kind: row.get(6),
        stimulus_id,
        shown,
        answers,
        rt_ms: row.get(9),
        video_ended: row.get(10),
        load_failed: row.get(11),
        viewing,
        received_at: row.get(12),
    })
}

/// The first chunk of an export: the CSV header, or the JSON document's opening.
fn head(format: Format, columns: &[(String, String)]) -> String {
    match format {
        Format::Long => LONG_HEADER.to_string(),
        Format::Wide => {
            let fixed = ["participant_id", "group", "arm"].into_iter().chain(Demographic::ALL.map(Demographic::name)).map(String::from);
            crate::tabular::line(fixed.chain(columns.iter().map(|(s, m)| format!("{s}:{m}"))))
        }
        Format::Json => "{\"participants\": [\n".to_string(),
    }
}

fn emit(record: &ParticipantRecord, format: Format, columns: &[(String, String)], first: &mut bool, out: &mut String) -> Result<(), DbError> {
    match format {
        Format::Long => record.long_rows()?.iter().for_each(|r| r.write_csv(out)),
        Format::Wide => record.wide_row(columns, out),
        Format::Json => {
            if !std::mem::take(first) {
                out.push_str(",\n");
            }
            out.push_str(&serde_json::to_string(record).map_err(|e| DbError::Internal(e.to_string()))?);
        }
    }
    Ok(())
}

/// The codebook of a study's exports: every column and, for categorical measures, its levels.
pub fn codebook(design: &StudyDesign) -> String {
    let mut out = String::from("file,column,description,levels\n");
    codebook_rows(design).iter().for_each(|r| crate::tabular::record(&mut out, r));
    out
}

/// The codebook's rows, `[file, column, description, levels]` (file empty on the rows that
/// describe a measure), read by [`codebook`] and the Psych-DS export.
pub fn codebook_rows(design: &StudyDesign) -> Vec<[String; 4]> {
    let mut out = Vec::new();
    let mut row = |file: &str, column: &str, description: &str, levels: &str| {
        out.push([file, column, description, levels].map(String::from));
    };
    let long = "responses.csv";
    let measures: Vec<Measure> = design.measures().into_iter().chain(Demographic::ALL.map(Measure::Demographic)).collect();
    row(long, "participant_id", "Opaque participant id (not the platform's worker id)", "");
    let groups: Vec<&str> = design.sources.iter().map(|s| s.group.as_str()).collect();
    row(long, "group", "The recruitment source's group label (the study's own group, then one per further platform)", &groups.join("|"));
    row(long, "stimulus_id", "Stimulus id of the set's manifest (empty on demographic rows)", "");
    row(long, "trial", "Presentation position of the trial, 1-based, counting practice and attention trials (empty on demographic rows)", "");
    row(long, "measure", "What the value is", &measures.iter().map(|m| m.name()).collect::<Vec<_>>().join("|"));
    row(long, "value", "The answer", "");
    row(long, "rt_ms", "Milliseconds from the stimulus's first painted frame to the answer, 0.1 ms resolution", "");
    for measure in measures {
        let declared = measure.declaration();
        match (measure, declared.kind) {
            (Measure::Scale(scale), _) => {
                let item = design.items.iter().find(|i| i.measure == scale).expect("a design's measures come from its items");
                row("", declared.name, &item.prompt, &format!("{}={} .. {}={}", item.min, item.min_label, item.max, item.max_label));
            }
            (_, Kind::Labels) => row("", declared.name, declared.codebook, &design.labels.labels().join("|")),
            _ => row("", declared.name, declared.codebook, ""),
        }
    }
    let arms: Vec<&str> = design.arms.iter().map(|a| a.name.as_str()).collect();
    row("wide.csv", "arm", "The between-subject arm the participant joined (empty when the design has none)", &arms.join("|"));
    row("wide.csv", "<stimulus_id>:<measure>", "One column per stimulus and measure; one row per participant", "");
    row(
        "responses.json",
        "participants[].trials[]",
        "Every saved trial with kind (practice|trial|attention), stimulus_id, shown, answers, rt_ms, video_ended, load_failed, viewing, received_at (Unix ms)",
        "",
    );
    let shown = if crate::study::entry::together(design) {
        "Stimulus ids the trial showed: its stimulus_id (the entry's video, which takes the answers) first, then the entry's stills by rising intensity"
    } else {
        "Stimulus ids the trial showed (its stimulus_id)"
    };
    row("responses.json", "participants[].trials[].shown", shown, "");
    row("responses.json", "participants[].trials[].viewing", "How the media were viewed (null when saved without the page script)", "");
    for field in viewing::FIELDS {
        row("responses.json", &format!("participants[].trials[].viewing.{}", field.name), field.codebook, "");
    }
    out
}
