//! The validation report: `report.json`, one CSV per table, `report.html` and its PNG plots.
//!
//! In: a validated manifest and responses. Out: a directory. `report.json` is the [`Report`]
//! serialised; every table is built once into the `table::Table` model (`tables`), and its CSV
//! file and its table on the page (`html`, tera templates) are both written from that model.
//! **Invariants:** everything is computed in memory first and written to a staging directory
//! beside the destination, which is renamed into place at the end, so a failure never leaves a
//! partial report; same input, same bytes.

mod html;
mod plots;
pub mod power;
pub mod table;
mod tables;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::analysis::Analysis;
use crate::analysis::coding::{CodingOptions, CodingReport};
use crate::analysis::demographics::Demographics;
use crate::analysis::manifest::Manifest;
use crate::analysis::rating::RatingReport;
use crate::analysis::styles::StyleScale;
use crate::analysis::responses::Responses;

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
    /// Seed 004's studies: ratings by label × style (means, two-way ANOVA, Scheffé); left out
    /// of `report.json` when the stimuli name no two styles.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub styles: Vec<StyleScale>,
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
    #[error("table {file}: {detail}")]
    Table { file: String, detail: String },
    #[error("report.html: {detail}")]
    Page { detail: String },
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// The report of [`crate::analysis::analyze`] on these inputs (the paths only name them).
pub fn build(manifest: &Manifest, responses: &Responses, options: CodingOptions, responses_path: &Path, manifest_path: &Path) -> Report {
    let Analysis { coding, rating, demographics, styles } = crate::analysis::analyze(manifest, responses, &options);
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
        coding,
        rating,
        demographics,
        styles,
    }
}

/// The files of a report, by name, as bytes: `report.json`, the CSV tables, the plots, `report.html`.
pub fn render(report: &Report) -> Result<Vec<(String, Vec<u8>)>, ReportError> {
    let json = serde_json::to_string_pretty(report).map_err(|e| ReportError::Output { path: "report.json".into(), detail: e.to_string() })?;
    let mut files = vec![("report.json".to_string(), json.into_bytes())];
    let tables = tables::all(report);
    for table in &tables {
        files.push((table.file.clone(), table.csv()?));
    }
    let mut figures = Vec::new();
    for (file, bytes, caption) in plots::all(report)? {
        figures.push(html::Figure { file: file.clone(), caption });
        files.push((file, bytes));
    }
    files.push(("report.html".into(), html::page(report, &tables, &figures)?.into_bytes()));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::simulate::{Design, SimOptions, simulate};
    use crate::facs::{Catalog, EmotionTable};

    fn report(design: Design, groups: &[&str]) -> Report {
        let options = SimOptions { design, seed: 3, participants: 4, groups: groups.iter().map(|g| g.to_string()).collect(), ..SimOptions::default() };
        let (manifest, responses) = simulate(&options);
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let manifest = Manifest::from_csv("manifest.csv", &manifest, catalog).unwrap();
        let responses = Responses::from_csv("responses.csv", &responses, &manifest, catalog, &emotions).unwrap();
        build(&manifest, &responses, CodingOptions::default(), Path::new("responses.csv"), Path::new("manifest.csv"))
    }

    fn file<'a>(files: &'a [(String, Vec<u8>)], name: &str) -> &'a str {
        let bytes = &files.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("{name} missing")).1;
        std::str::from_utf8(bytes).unwrap()
    }

    /// The `<table>` that follows `heading` on the page, as rows of cell texts (header first).
    fn page_table(html: &str, heading: &str) -> Vec<Vec<String>> {
        let start = html.find(heading).unwrap_or_else(|| panic!("{heading} not on the page"));
        let table = &html[start..start + html[start..].find("</table>").unwrap()];
        let cell = |c: &str| c.split_once('>').map_or("", |(_, text)| text).replace("<b>", "").replace("</b>", "");
        let cells = |row: &str| -> Vec<String> {
            row.split("<t").skip(1).filter(|c| c.starts_with('d') || c.starts_with('h')).map(|c| cell(c.split("</t").next().unwrap_or(""))).collect()
        };
        table.split("<tr>").skip(1).map(cells).collect()
    }

    #[test]
    fn a_table_s_csv_file_and_its_page_table_come_from_one_model() {
        let files = render(&report(Design::Exp1, &[])).unwrap();
        let mut csv = csv::Reader::from_reader(file(&files, "table1_grouped.csv").as_bytes());
        let header: Vec<String> = csv.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header, ["aus", "accuracy", "precision", "recall", "f1"]);
        let records: Vec<csv::StringRecord> = csv.records().collect::<Result<_, _>>().unwrap();
        let page = page_table(file(&files, "report.html"), "Table 1. AU recognition");
        assert_eq!(page[0], ["Action Unit", "Accuracy", "Precision", "Recall", "F1-Measure"]);
        assert!(!records.is_empty());
        assert_eq!(page.len() - 1, records.len(), "one page row per CSV row");
        for (row, record) in page[1..].iter().zip(&records) {
            assert_eq!(row[0], record[0]);
            for (text, value) in row[1..].iter().zip(record.iter().skip(1)) {
                assert_eq!(*text, format!("{:.2}", value.parse::<f64>().unwrap()), "the page rounds the file's number");
            }
        }
    }

    #[test]
    fn text_from_the_data_is_escaped_on_the_page_and_kept_in_the_files() {
        let files = render(&report(Design::Exp3, &["<script>", "b&b"])).unwrap();
        let html = file(&files, "report.html");
        assert!(!html.contains("<script>") && !html.contains("b&b"), "raw markup on the page");
        assert!(html.contains("&lt;script&gt;") && html.contains("b&amp;b"));
        let groups = page_table(html, "<h3>Group comparisons");
        assert!(groups.len() > 1 && groups[1][2].contains("&lt;script&gt;"), "{:?}", groups.get(1));
        assert!(file(&files, "group_tests.csv").contains("<script>"));
        assert!(file(&files, "report.json").contains("<script>"));
    }

    #[test]
    fn the_same_report_gives_the_same_bytes() {
        let report = report(Design::Exp3, &["local", "amt"]);
        assert_eq!(render(&report).unwrap(), render(&report).unwrap());
    }
}
