//! The Psych-DS export: a study's data as a dataset directory others can validate and reuse.
//!
//! In: a study (its design, its judgements in the scope asked for, its participations) and its
//! stimulus set's `manifest.json`. Out: a directory with
//! - `dataset_description.json`: a schema.org `Dataset` (JSON-LD) whose `variableMeasured`
//!   names every column of every data file, described from the study's codebook
//!   ([`super::export::codebook_rows`]); the measures' codebook entries sit under the `value`
//!   column as `valueReference`;
//! - `data/study-<slug>_data.csv`: the long responses, the bytes `facslab export` writes;
//! - `data/study-<slug>_description-participants_data.csv`: group, arm, state, demographics;
//! - `data/study-<slug>_description-stimuli_data.csv`: what each stimulus shows (the ground
//!   truth of the set's manifest);
//! - `README.md`.
//!
//! Invariants: every data file name matches Psych-DS's keyword pattern
//! (`([a-z]+-[a-zA-Z0-9]+)(_[a-z]+-[a-zA-Z0-9]+)*_data.csv`; the slug keeps its letters and
//! digits only); every column header of every data file is in `variableMeasured`; the dataset
//! is written into a sibling directory and renamed at the end, so a failed export leaves no
//! half-written dataset, and an existing directory is never overwritten; the same study gives
//! the same bytes.

use std::path::Path;

use serde_json::{Value, json};

use super::export::{Scope, codebook_rows};
use super::{Db, DbError, on_backend};
use crate::study::StudyDesign;
use crate::study::measure::Demographic;

/// The participants file's columns after `participant_id` and `group` (described here; the
/// demographic columns by their declarations).
const PARTICIPANT_COLUMNS: [(&str, &str); 2] = [
    ("arm", "The between-subject arm the participant joined (empty when the design has none)"),
    ("state", "How the participation ended: completed, or (with every participation exported) reserved, active, abandoned, screened_out"),
];

/// The stimuli file's columns: what each stimulus shows, from the set's manifest.
const STIMULUS_COLUMNS: [(&str, &str); 8] = [
    ("media", "image (PNG still) or video (H.264 MP4)"),
    ("identity", "The rendered person (facslab identity id)"),
    ("expression", "FACS notation of the expression at its peak: AUs joined by '+', L/R = one side, A-E = intensity"),
    ("emotion", "The EmFACS emotion the expression portrays (empty for AU stimuli)"),
    ("intensity", "Peak intensity, 0-1"),
    ("width", "Width of the picture in pixels"),
    ("height", "Height of the picture in pixels"),
    ("sha256", "SHA-256 of the stimulus file (which file was shown)"),
];

/// The slug as a Psych-DS keyword value (letters and digits only; `x` if nothing is left).
pub fn keyword_value(slug: &str) -> String {
    let kept: String = slug.chars().filter(char::is_ascii_alphanumeric).collect();
    if kept.is_empty() { "x".into() } else { kept }
}

/// One `variableMeasured` entry.
fn variable(name: &str, description: &str) -> Value {
    json!({ "@type": "PropertyValue", "name": name, "description": description })
}

impl Db {
    /// Writes study `study_id`'s Psych-DS dataset into `out` (which must not exist).
    pub async fn psych_ds(&self, study_id: i64, design: &StudyDesign, set_dir: &Path, scope: Scope, out: &Path) -> Result<(), DbError> {
        if out.exists() {
            return Err(DbError::Conflict(format!("{} exists already; choose a new directory for the dataset", out.display())));
        }
        let name = keyword_value(&design.slug);
        let mut responses = crate::analysis::responses::LONG_HEADER.to_string();
        self.long_rows(study_id, scope).await?.iter().for_each(|r| r.write_csv(&mut responses));
        let participants = self.participants_table(study_id, scope).await?;
        let shown: Vec<String> = self.study_stimuli(study_id).await?.into_iter().map(|s| s.stimulus_id.to_string()).collect();
        let stimuli = stimuli_table(set_dir, &shown)?;
        let files = [
            (format!("study-{name}_data.csv"), responses),
            (format!("study-{name}_description-participants_data.csv"), participants),
            (format!("study-{name}_description-stimuli_data.csv"), stimuli),
        ];
        let description = serde_json::to_string_pretty(&description(design, shown.len())).map_err(|e| DbError::Internal(e.to_string()))?;
        write_dataset(out, &description, &readme(design), &files)
    }

    /// The participants of the scope: id, group, arm, state and demographics, as CSV.
    async fn participants_table(&self, study_id: i64, scope: Scope) -> Result<String, DbError> {
        let sql = format!("SELECT p.id, p.public_id, p.grp, p.arm, p.state FROM participants p WHERE p.study_id = $1 AND {} ORDER BY p.id", super::export::scope_sql(scope));
        let rows: Vec<(i64, String, String, String, String)> = on_backend!(self, b => sqlx::query_as(sqlx::AssertSqlSafe(sql)).bind(study_id).fetch_all(&b.reader).await?);
        let demographics = self.demographics_of(study_id).await?;
        let mut out = crate::tabular::line(["participant_id", "group"].into_iter().chain(PARTICIPANT_COLUMNS.map(|c| c.0)).chain(Demographic::ALL.map(Demographic::name)));
        for (id, public_id, group, arm, state) in rows {
            let d = demographics.get(&id).cloned().unwrap_or_default();
            let fixed: [String; 4] = [public_id, group, arm, state];
            crate::tabular::record(&mut out, fixed.into_iter().chain(Demographic::ALL.map(|m| d.text(m))));
        }
        Ok(out)
    }
}

/// The manifest rows of the stimuli the study shows, as CSV.
fn stimuli_table(set_dir: &Path, shown: &[String]) -> Result<String, DbError> {
    let (_, rows) = super::studies::set_manifest(set_dir)?;
    let mut out = crate::tabular::line(std::iter::once("stimulus_id").chain(STIMULUS_COLUMNS.map(|c| c.0)));
    for r in rows.iter().filter(|r| shown.contains(&r.stimulus_id)) {
        let cells = [&r.stimulus_id, r.media.as_str(), &r.identity, &r.expression, &r.emotion, &r.intensity.to_string(), &r.width.to_string(), &r.height.to_string(), &r.sha256];
        crate::tabular::record(&mut out, cells);
    }
    Ok(out)
}

/// `dataset_description.json`: the study as a schema.org Dataset, every column described.
fn description(design: &StudyDesign, stimuli: usize) -> Value {
    let book = codebook_rows(design);
    let described = |column: &str| book.iter().find(|r| r[1] == column).map(|r| r[2].clone()).unwrap_or_default();
    let measures: Vec<Value> = book.iter().filter(|r| r[0].is_empty()).map(|r| json!({ "@type": "PropertyValue", "name": r[1], "description": r[2], "value": r[3] })).collect();
    let mut variables: Vec<Value> = crate::analysis::responses::LONG_HEADER.trim_end().split(',').map(|c| variable(c, &described(c))).collect();
    if let Some(value) = variables.iter_mut().find(|v| v["name"] == "value") {
        value["valueReference"] = Value::Array(measures);
    }
    variables.extend(PARTICIPANT_COLUMNS.iter().chain(&STIMULUS_COLUMNS).map(|(c, d)| variable(c, d)));
    variables.extend(Demographic::ALL.iter().map(|&d| variable(d.name(), &described(d.name()))));
    let groups: Vec<&str> = design.sources.iter().map(|s| s.group.as_str()).collect();
    json!({
        "@context": "https://schema.org/",
        "@type": "Dataset",
        "name": design.title,
        "description": format!(
            "facslab study \"{}\": task {}, {} stimuli, participant groups {}{}. Ground truth of every stimulus in the stimuli file; the codebook's descriptions are the variables' descriptions.",
            design.slug, design.task.as_str(), stimuli, groups.join(", "),
            if design.arms.is_empty() { String::new() } else { format!(", between-subject arms {}", design.arms.iter().map(|a| a.name.as_str()).collect::<Vec<_>>().join(", ")) }
        ),
        "keywords": ["facial expression", "FACS", "Action Units", design.task.as_str()],
        "variableMeasured": variables,
    })
}

fn readme(design: &StudyDesign) -> String {
    format!(
        "# {}\n\nA Psych-DS dataset exported by facslab from study `{}`.\n\n- `data/*_data.csv`: the long responses (one judgement per row; demographic rows have no stimulus), the participants, and the stimuli with what each shows.\n- `dataset_description.json`: every column described (`variableMeasured`).\n\nConsent text shown to participants:\n\n> {}\n",
        design.title,
        design.slug,
        design.consent.trim().replace('\n', "\n> ")
    )
}

/// Writes the dataset into `out.partial` and renames it to `out`.
fn write_dataset(out: &Path, description: &str, readme: &str, files: &[(String, String)]) -> Result<(), DbError> {
    let partial = out.with_file_name(format!(".{}.partial", out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()));
    let io = |path: &Path, e: std::io::Error| DbError::Internal(format!("{}: {e}", path.display()));
    if partial.exists() {
        std::fs::remove_dir_all(&partial).map_err(|e| io(&partial, e))?;
    }
    std::fs::create_dir_all(partial.join("data")).map_err(|e| io(&partial, e))?;
    std::fs::write(partial.join("dataset_description.json"), description).map_err(|e| io(&partial, e))?;
    std::fs::write(partial.join("README.md"), readme).map_err(|e| io(&partial, e))?;
    for (name, text) in files {
        std::fs::write(partial.join("data").join(name), text).map_err(|e| io(&partial, e))?;
    }
    std::fs::rename(&partial, out).map_err(|e| io(out, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slugs_become_keyword_values() {
        assert_eq!(keyword_value("exp3"), "exp3");
        assert_eq!(keyword_value("exp-3_local"), "exp3local");
        assert_eq!(keyword_value("--"), "x");
    }
}
