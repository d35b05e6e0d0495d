//! The validation report: `report.json`, one CSV per table, `report.html` and its PNG plots.
//!
//! In: a validated manifest and responses. Out: a directory. **Invariant:** everything is
//! computed in memory first and written to a staging directory beside the destination, which is
//! renamed into place at the end, so a failure never leaves a partial report.

mod html;
mod plots;
mod tables;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::analysis::coding::{self, CodingOptions, CodingReport};
use crate::analysis::demographics::{self, Demographics};
use crate::analysis::manifest::Manifest;
use crate::analysis::rating::{self, RatingReport};
use crate::analysis::responses::Responses;
use crate::facs::Catalog;

/// What went in.
#[derive(Debug, Clone, Serialize)]
pub struct Inputs {
    pub responses_file: String,
    pub manifest_file: String,
    pub rows: u64,
    pub participants: usize,
    pub groups: Vec<String>,
    pub stimuli: usize,
}

/// Every number of the report, in named sections (the schema of `report.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub facslab_version: String,
    pub inputs: Inputs,
    pub options: CodingOptions,
    /// Exp. 1–2: coders against the ground truth (Tables 1–4); absent without `aus` answers.
    pub coding: Option<CodingReport>,
    /// Exp. 3–4: lay raters (Tables 7–14); absent without emotion answers or ratings.
    pub rating: Option<RatingReport>,
    /// Table 6; absent when nobody stated demographics.
    pub demographics: Option<Demographics>,
}

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("output {path}: {detail}")]
    Output { path: PathBuf, detail: String },
    #[error("writing {path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("plot {name}: {detail}")]
    Plot { name: String, detail: String },
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Computes the report.
pub fn build(
    manifest: &Manifest,
    responses: &Responses,
    catalog: &Catalog,
    options: CodingOptions,
    responses_path: &Path,
    manifest_path: &Path,
) -> Report {
    Report {
        facslab_version: env!("CARGO_PKG_VERSION").to_string(),
        inputs: Inputs {
            responses_file: file_name(responses_path),
            manifest_file: file_name(manifest_path),
            rows: responses.rows,
            participants: responses.participants.len(),
            groups: responses.groups.clone(),
            stimuli: manifest.len(),
        },
        options,
        coding: coding::analyze(manifest, responses, catalog, options),
        rating: rating::analyze(manifest, responses),
        demographics: demographics::analyze(manifest, responses),
    }
}

/// The files of a report, by name, as bytes.
pub fn render(report: &Report) -> Result<Vec<(String, Vec<u8>)>, ReportError> {
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let json = serde_json::to_string_pretty(report).expect("the report serialises");
    files.push(("report.json".into(), json.into_bytes()));
    for (name, text) in tables::all(report) {
        files.push((name, text.into_bytes()));
    }
    let pngs = plots::all(report)?;
    let html = html::page(report, &pngs.iter().map(|(n, _, caption)| (n.clone(), caption.clone())).collect::<Vec<_>>());
    for (name, bytes, _) in pngs {
        files.push((name, bytes));
    }
    files.push(("report.html".into(), html.into_bytes()));
    Ok(files)
}

/// Writes the report into `dir`: all files go to a staging directory first, which then replaces
/// `dir`. `dir` must not exist, be empty, or hold an earlier report (a `report.json`).
pub fn write(report: &Report, dir: &Path) -> Result<(), ReportError> {
    let out_err = |detail: String| ReportError::Output { path: dir.to_path_buf(), detail };
    if dir.exists() {
        let entries: Vec<_> = std::fs::read_dir(dir).map_err(|e| out_err(e.to_string()))?.collect();
        if !entries.is_empty() && !dir.join("report.json").exists() {
            return Err(out_err("exists, is not empty and holds no earlier report: refusing to replace it".into()));
        }
    }
    let files = render(report)?;
    let parent = dir.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let stem = file_name(dir);
    let staging = parent.join(format!(".{stem}.partial"));
    let old = parent.join(format!(".{stem}.old"));
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| ReportError::Io { path, source }
    };
    if staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(io(&staging))?;
    }
    std::fs::create_dir_all(&staging).map_err(io(&staging))?;
    for (name, bytes) in &files {
        let path = staging.join(name);
        if let Err(e) = std::fs::write(&path, bytes) {
            let _ = std::fs::remove_dir_all(&staging);
            return Err(io(&path)(e));
        }
    }
    if dir.exists() {
        if old.exists() {
            std::fs::remove_dir_all(&old).map_err(io(&old))?;
        }
        std::fs::rename(dir, &old).map_err(io(dir))?;
    }
    std::fs::rename(&staging, dir).map_err(io(dir))?;
    if old.exists() {
        std::fs::remove_dir_all(&old).map_err(io(&old))?;
    }
    Ok(())
}

/// Rounds for display.
pub(crate) fn fmt(v: f64, decimals: usize) -> String {
    format!("{v:.decimals$}")
}
