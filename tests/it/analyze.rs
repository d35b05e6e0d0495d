//! `facslab simulate` then `facslab analyze`: the report's files, its structure (snapshots shaped
//! like the seed's Tables 1–4 and 6–14), determinism, and bad input.

use std::path::Path;

use serde_json::{Value, json};

use crate::cli::{facslab, facslab_ok, stderr};

fn simulate_and_analyze(dir: &Path, design: &str, extra: &[&str]) -> Value {
    let mut args = vec!["simulate", "--design", design, "--seed", "11", "-o", "sim"];
    args.extend_from_slice(extra);
    facslab_ok(dir, &args);
    facslab_ok(dir, &["analyze", "--responses", "sim/responses.csv", "--manifest", "sim/manifest.csv", "-o", "report"]);
    serde_json::from_str(&std::fs::read_to_string(dir.join("report/report.json")).unwrap()).unwrap()
}

/// Rounds every number to 6 decimals so snapshots do not depend on the last bits of libm.
fn round(v: &Value) -> Value {
    match v {
        Value::Number(n) if n.is_f64() => json!((n.as_f64().unwrap() * 1e6).round() / 1e6),
        Value::Array(a) => Value::Array(a.iter().map(round).collect()),
        Value::Object(o) => Value::Object(o.iter().map(|(k, v)| (k.clone(), round(v))).collect()),
        other => other.clone(),
    }
}

fn pick(v: &Value, keys: &[&str]) -> Value {
    Value::Object(keys.iter().map(|k| (k.to_string(), v[*k].clone())).collect())
}

#[test]
fn exp1_report_has_tables_1_and_2() {
    let dir = tempfile::tempdir().unwrap();
    let report = simulate_and_analyze(dir.path(), "exp1", &[]);
    for file in ["report.html", "table1_3_per_au.csv", "table1_grouped.csv", "table2_alpha.csv", "coder_agreement.csv", "table6_demographics.csv", "plot_f1_per_au.png"] {
        assert!(dir.path().join("report").join(file).exists(), "{file} missing");
    }
    let coding = &report["coding"];
    assert_eq!(coding["coders"].as_array().unwrap().len(), 3);
    assert_eq!(coding["stimuli"], 49);
    let table2: Vec<Value> = coding["per_au"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["shown_in"].as_u64() > Some(0))
        .map(|r| pick(r, &["au", "alpha", "mistaken_for"]))
        .collect();
    insta::assert_json_snapshot!("exp1_tables_1_2", round(&json!({
        "table1": coding["table1_groups"],
        "table2": table2,
        "macro_mean": coding["macro_mean"],
        "micro": coding["micro"],
    })));
}

#[test]
fn exp2_report_has_tables_3_and_4() {
    let dir = tempfile::tempdir().unwrap();
    let report = simulate_and_analyze(dir.path(), "exp2", &[]);
    let coding = &report["coding"];
    assert_eq!(coding["combinations"].as_array().unwrap().len(), 54);
    let table3: Vec<Value> = coding["per_au"].as_array().unwrap().iter().map(|r| pick(r, &["au", "counts", "metrics"])).collect();
    let table4: Vec<Value> =
        coding["combinations"].as_array().unwrap().iter().map(|r| pick(r, &["combination", "recognised_display", "metrics"])).collect();
    insta::assert_json_snapshot!("exp2_tables_3_4", round(&json!({
        "table3": table3,
        "table4": table4,
        "table4_mean": coding["combinations_macro_mean"],
        "agreement": coding["agreement"],
    })));
    let html = std::fs::read_to_string(dir.path().join("report/report.html")).unwrap();
    assert!(html.contains("Table 4. AU combinations"));
}

#[test]
fn exp3_report_has_tables_6_to_11() {
    let dir = tempfile::tempdir().unwrap();
    let report = simulate_and_analyze(dir.path(), "exp3", &["--participants", "12", "--missing", "0.01"]);
    let rating = &report["rating"];
    let conditions = rating["conditions"].as_array().unwrap();
    let keys: Vec<&str> = conditions.iter().map(|c| c["key"].as_str().unwrap()).collect();
    assert_eq!(keys, ["video 100%", "video 50%", "image 100%", "image 50%"]);
    for file in ["confusion_video_100_percent.csv", "plot_confusion_image_50.png", "plot_believability.png", "table11_ratings.csv", "anova.csv", "group_tests.csv", "table14_comparison.csv"] {
        assert!(dir.path().join("report").join(file).exists(), "{file} missing");
    }
    // Every statistic in the rater section states its convention.
    assert!(rating["convention"].as_str().unwrap().contains("Type II and Type III"));
    let tables_7_10: Vec<Value> = conditions.iter().map(|c| pick(c, &["key", "confusion", "average_rate"])).collect();
    let table11: Vec<Value> = conditions
        .iter()
        .map(|c| {
            let s = &c["scales"][0];
            json!({"condition": c["key"], "cells": s["cells"], "overall": s["overall"], "alpha": s["alpha"]})
        })
        .collect();
    insta::assert_json_snapshot!("exp3_tables_6_to_11", round(&json!({
        "table6": report["demographics"]["rows"],
        "tables_7_10": tables_7_10,
        "table11": table11,
    })));
    // Two groups: Student and Welch tests with df, p and d per condition.
    let t = &rating["group_tests"][0];
    assert!(t["student"]["df"].is_number() && t["welch"]["cohen_d"].is_number(), "{t}");
    assert_eq!(rating["anova"].as_array().unwrap().len(), 4);
    let terms: Vec<&str> = rating["anova"][0]["type_ii"]["rows"].as_array().unwrap().iter().map(|r| r["term"].as_str().unwrap()).collect();
    assert_eq!(terms, ["emotion", "intensity", "emotion:intensity", "residual"], "terms named after the factors");
    exp3_design_tests(dir.path(), rating);
}

/// Exp. 3 as simulated (each rater sees every emotion of one media × intensity condition): RM
/// ANOVA over emotion and a one-way ANOVA between the condition groups, no paired test.
fn exp3_design_tests(dir: &Path, rating: &Value) {
    let design = &rating["design"];
    assert_eq!(design["within_emotion"].as_array().unwrap().len(), 8, "4 conditions × recognition and believability");
    assert_eq!(design["between_conditions"].as_array().unwrap().len(), 2);
    assert!(design["paired"].as_array().unwrap().is_empty(), "separate groups: no paired test");
    let html = std::fs::read_to_string(dir.join("report/report.html")).unwrap();
    assert!(html.contains("Repeated-measures ANOVA over emotion") && html.contains("One-way ANOVA between the condition groups"));
    assert!(!html.contains("Paired t-tests (the same"), "no paired table without a within-subject two-level factor");
    assert!(html.contains("Intraclass correlation"));
    let icc: Vec<Value> = rating["conditions"].as_array().unwrap().iter().map(|c| json!({"condition": c["key"], "alpha": c["scales"][0]["alpha"], "icc": c["scales"][0]["icc"]})).collect();
    insta::assert_json_snapshot!("exp3_design_tests", round(&json!({"design": design, "icc": icc})));
}

#[test]
fn exp4_report_has_tables_12_to_14() {
    let dir = tempfile::tempdir().unwrap();
    // HapFACS Exp. 4: ten videos at 100 %, one per emotion, 20 local and 40 AMT participants.
    let report = simulate_and_analyze(dir.path(), "exp4", &["--participants", "60", "--identities", "1"]);
    let rating = &report["rating"];
    let conditions = rating["conditions"].as_array().unwrap();
    assert_eq!(conditions.iter().map(|c| c["key"].as_str().unwrap()).collect::<Vec<_>>(), ["video 100%"]);
    let c = &conditions[0];
    let s = &c["scales"][0];
    // Table 13's alpha (participants as items, the ten videos as cases) has a value with one
    // video per emotion; the per-emotion alpha cannot (one case each).
    assert!(s["alpha"].is_number(), "{s}");
    insta::assert_json_snapshot!("exp4_tables_12_to_14", round(&json!({
        "table12": pick(c, &["key", "confusion", "average_rate"]),
        "table13": {"cells": s["cells"], "overall": s["overall"], "alpha": s["alpha"]},
        "table14": rating["table14"],
    })));
    // Local and AMT raters compared per emotion, as the paper did.
    assert!(rating["group_tests"].as_array().unwrap().iter().any(|t| t["student"]["df"].is_number()));
}

#[test]
fn same_seed_gives_identical_files() {
    let dir = tempfile::tempdir().unwrap();
    for out in ["a", "b"] {
        facslab_ok(dir.path(), &["simulate", "--design", "exp3", "--seed", "5", "--participants", "3", "-o", out]);
    }
    for f in ["manifest.csv", "responses.csv"] {
        assert_eq!(std::fs::read(dir.path().join("a").join(f)).unwrap(), std::fs::read(dir.path().join("b").join(f)).unwrap());
    }
}

/// Runs analyze on a broken response file and checks the message and that nothing was written.
fn bad_responses(body: &str, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["simulate", "--design", "exp1", "-o", "sim"]);
    let manifest = std::fs::read_to_string(dir.path().join("sim/manifest.csv")).unwrap();
    let id = manifest.lines().nth(1).unwrap().split(',').next().unwrap().to_string();
    std::fs::write(dir.path().join("bad.csv"), body.replace("ID", &id)).unwrap();
    let out = facslab(dir.path(), &["analyze", "--responses", "bad.csv", "--manifest", "sim/manifest.csv", "-o", "report"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    for e in expect {
        assert!(err.contains(e), "expected {e:?} in: {err}");
    }
    assert!(!dir.path().join("report").exists(), "a partial report was written");
    assert!(!dir.path().join(".report.partial").exists(), "a staging directory was left");
}

const HEADER: &str = "participant_id,group,stimulus_id,trial,measure,value,rt_ms\n";

#[test]
fn unknown_stimulus_id_names_row_and_column() {
    bad_responses(&format!("{HEADER}c1,g,ID,1,aus,1,\nc1,g,nope,2,aus,1,\n"), &["bad.csv: row 2 (line 3), column \"stimulus_id\"", "unknown stimulus id \"nope\""]);
}

#[test]
fn unknown_au_names_row_and_column() {
    bad_responses(&format!("{HEADER}c1,g,ID,1,aus,1+2+99,\n"), &["row 1 (line 2), column \"value\"", "AU 99 is not in the catalog"]);
}

#[test]
fn likert_out_of_range_names_row_and_column() {
    bad_responses(&format!("{HEADER}p1,g,ID,1,believability,3,\np1,g,ID,1,q1,9,\n"), &["row 2 (line 3), column \"value\"", "outside the scale 0-5"]);
}

#[test]
fn empty_group_names_row_and_column() {
    bad_responses(&format!("{HEADER}p1,g,ID,1,emotion,fear,\np2,,ID,1,emotion,fear,\n"), &["row 2 (line 3), column \"group\": empty group"]);
}

#[test]
fn missing_column_is_named() {
    bad_responses("participant_id,group,stimulus_id,trial,value,rt_ms\np1,g,ID,1,3,\n", &["missing column \"measure\""]);
}

#[test]
fn refuses_to_replace_a_directory_that_is_not_a_report() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["simulate", "--design", "exp1", "-o", "sim"]);
    std::fs::create_dir(dir.path().join("keep")).unwrap();
    std::fs::write(dir.path().join("keep/notes.txt"), "mine").unwrap();
    let out = facslab(dir.path(), &["analyze", "--responses", "sim/responses.csv", "--manifest", "sim/manifest.csv", "-o", "keep"]);
    assert!(!out.status.success());
    assert_eq!(std::fs::read_to_string(dir.path().join("keep/notes.txt")).unwrap(), "mine");
    // An earlier report is replaced.
    facslab_ok(dir.path(), &["analyze", "--responses", "sim/responses.csv", "--manifest", "sim/manifest.csv", "-o", "r"]);
    facslab_ok(dir.path(), &["analyze", "--responses", "sim/responses.csv", "--manifest", "sim/manifest.csv", "-o", "r", "--match-side"]);
    let json = std::fs::read_to_string(dir.path().join("r/report.json")).unwrap();
    assert!(json.contains("\"match_side\": true"));
}

#[test]
fn convert_needs_one_parquet_side() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["simulate", "--design", "exp1", "-o", "sim"]);
    let out = facslab(dir.path(), &["convert", "sim/responses.csv", "-o", "copy.csv"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("neither file is Parquet"), "{}", stderr(&out));
    assert!(!dir.path().join("copy.csv").exists());
}

#[cfg(not(feature = "polars"))]
#[test]
fn without_the_polars_feature_parquet_says_how_to_rebuild() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["simulate", "--design", "exp1", "-o", "sim"]);
    let out = facslab(dir.path(), &["convert", "sim/responses.csv", "-o", "r.parquet"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("r.parquet: Parquet files need facslab built with the `polars` feature"), "{}", stderr(&out));
    let out = facslab(dir.path(), &["analyze", "--responses", "r.parquet", "--manifest", "sim/manifest.csv", "-o", "report"]);
    assert!(stderr(&out).contains("--features polars"), "{}", stderr(&out));
}

/// Parquet input and `facslab convert` (built with `--features polars`).
#[cfg(feature = "polars")]
mod parquet {
    use std::path::Path;

    use super::*;

    /// Every cell of a CSV file, row by row (the header included).
    fn cells(path: &Path) -> Vec<Vec<String>> {
        let mut reader = csv::ReaderBuilder::new().has_headers(false).from_path(path).unwrap();
        reader.records().map(|r| r.unwrap().iter().map(str::to_string).collect()).collect()
    }

    #[test]
    fn csv_to_parquet_to_csv_keeps_every_cell() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        facslab_ok(d, &["simulate", "--design", "exp3", "--participants", "4", "--missing", "0.05", "-o", "sim3"]);
        facslab_ok(d, &["simulate", "--design", "exp1", "-o", "sim1"]);
        for csv in ["sim3/responses.csv", "sim3/manifest.csv", "sim1/responses.csv", "sim1/manifest.csv"] {
            let parquet = csv.replace(".csv", ".parquet");
            let back = csv.replace(".csv", ".back.csv");
            facslab_ok(d, &["convert", csv, "-o", &parquet]);
            facslab_ok(d, &["convert", &parquet, "-o", &back]);
            let (before, after) = (cells(&d.join(csv)), cells(&d.join(&back)));
            assert!(before.len() > 1 && before.iter().flatten().any(String::is_empty), "{csv}: rows and empty cells");
            assert_eq!(after, before, "{csv}");
        }
    }

    /// Analyses `responses` and `manifest` into `out` and returns its files, sorted, with the
    /// input file names in report.json and report.html replaced by their CSV names.
    fn report_files(d: &Path, responses: &str, manifest: &str, out: &str) -> Vec<(String, Vec<u8>)> {
        facslab_ok(d, &["analyze", "--responses", responses, "--manifest", manifest, "-o", out]);
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(d.join(out))
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                let name = e.file_name().to_string_lossy().into_owned();
                let mut bytes = std::fs::read(e.path()).unwrap();
                if name == "report.json" || name == "report.html" {
                    bytes = String::from_utf8(bytes).unwrap().replace("responses.parquet", "responses.csv").replace("manifest.parquet", "manifest.csv").into_bytes();
                }
                (name, bytes)
            })
            .collect();
        files.sort();
        files
    }

    #[test]
    fn analyze_on_parquet_gives_the_same_report_as_on_csv() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for (design, extra) in [("exp3", &["--participants", "6", "--missing", "0.02"][..]), ("exp1", &[][..])] {
            let mut args = vec!["simulate", "--design", design, "-o", design];
            args.extend_from_slice(extra);
            facslab_ok(d, &args);
            let path = |file: &str| format!("{design}/{file}");
            for file in ["responses", "manifest"] {
                facslab_ok(d, &["convert", &path(&format!("{file}.csv")), "-o", &path(&format!("{file}.parquet"))]);
            }
            let from_csv = report_files(d, &path("responses.csv"), &path("manifest.csv"), &path("from_csv"));
            let from_parquet = report_files(d, &path("responses.parquet"), &path("manifest.parquet"), &path("from_parquet"));
            assert!(from_csv.iter().any(|(name, _)| name == "report.json"));
            assert_eq!(from_csv.len(), from_parquet.len(), "{design}");
            for ((name, csv), (_, parquet)) in from_csv.iter().zip(&from_parquet) {
                assert!(csv == parquet, "{design}: {name} differs between the CSV and the Parquet input");
            }
        }
    }

    /// Writes `csv` as bad.csv and as bad.parquet, analyses both, and returns the Parquet run's
    /// message after checking that it is the CSV run's with the file name changed.
    fn same_error_for_both(d: &Path, csv: &str) -> String {
        std::fs::write(d.join("bad.csv"), csv).unwrap();
        facslab_ok(d, &["convert", "bad.csv", "-o", "bad.parquet"]);
        let message = |file: &str| {
            let out = facslab(d, &["analyze", "--responses", file, "--manifest", "sim/manifest.csv", "-o", "report"]);
            assert!(!out.status.success());
            assert!(!d.join("report").exists(), "a report was written");
            stderr(&out)
        };
        let from_parquet = message("bad.parquet");
        assert_eq!(from_parquet.replace("bad.parquet", "bad.csv"), message("bad.csv"));
        from_parquet
    }

    #[test]
    fn bad_parquet_errors_name_the_column_and_row_as_for_csv() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        facslab_ok(d, &["simulate", "--design", "exp3", "--participants", "1", "-o", "sim"]);
        let text = std::fs::read_to_string(d.join("sim/responses.csv")).unwrap();
        // A missing column.
        let without_measure: String = text.lines().map(|l| {
            let mut cells: Vec<&str> = l.split(',').collect();
            cells.remove(4);
            cells.join(",") + "\n"
        }).collect();
        let e = same_error_for_both(d, &without_measure);
        assert!(e.contains("bad.parquet: missing column \"measure\" (the header has: participant_id,group,stimulus_id,trial,value,rt_ms)"), "{e}");
        // A bad cell on the fifth data row.
        let id = text.lines().nth(5).unwrap().split(',').nth(2).unwrap().to_string();
        let e = same_error_for_both(d, &text.replacen(&format!(",{id},"), ",nope,", 1));
        assert!(e.contains("bad.parquet: row 5 (line 6), column \"stimulus_id\": unknown stimulus id \"nope\""), "{e}");
    }

    #[test]
    fn a_file_that_is_not_parquet_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        facslab_ok(d, &["simulate", "--design", "exp1", "-o", "sim"]);
        std::fs::copy(d.join("sim/responses.csv"), d.join("r.parquet")).unwrap();
        let out = facslab(d, &["analyze", "--responses", "r.parquet", "--manifest", "sim/manifest.csv", "-o", "report"]);
        assert!(!out.status.success());
        assert!(stderr(&out).contains("r.parquet: not usable as Parquet"), "{}", stderr(&out));
        assert!(!d.join("report").exists());
    }
}

/// Every field path of a JSON value (`a.b[].c`), with the kinds of value seen there.
fn field_paths(v: &Value, at: &str, out: &mut std::collections::BTreeMap<String, std::collections::BTreeSet<&'static str>>) {
    let kind = match v {
        Value::Null => "null",
        Value::Bool(_) => "bool",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    };
    if !at.is_empty() {
        out.entry(at.to_string()).or_default().insert(kind);
    }
    match v {
        Value::Array(items) => items.iter().for_each(|item| field_paths(item, &format!("{at}[]"), out)),
        Value::Object(fields) => {
            for (k, item) in fields {
                // Keys that are data (stimulus ids, labels) rather than field names.
                let key = if at.ends_with(".published") { "*" } else { k.as_str() };
                let path = if at.is_empty() { key.to_string() } else { format!("{at}.{key}") };
                field_paths(item, &path, out);
            }
        }
        _ => {}
    }
}

#[test]
fn report_json_fields_are_documented_and_their_shape_is_kept() {
    let dir = tempfile::tempdir().unwrap();
    let mut paths = std::collections::BTreeMap::new();
    for (design, extra) in [("exp1", &[][..]), ("exp3", &["--participants", "6", "--missing", "0.02"][..])] {
        let sub = dir.path().join(design);
        std::fs::create_dir_all(&sub).unwrap();
        let report = simulate_and_analyze(&sub, design, extra);
        field_paths(&report, "", &mut paths);
    }
    let keys: Vec<&String> = paths.keys().collect();
    assert!(keys.iter().all(|k| !k.split(['.', '[']).any(|part| part == "Ok" || part == "Err")), "serde Result wrappers in report.json");
    let docs = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/report-json.md")).unwrap();
    let undocumented: Vec<&&String> = keys.iter().filter(|k| !docs.contains(&format!("| `{k}` |"))).collect();
    assert!(undocumented.is_empty(), "fields of report.json missing from docs/report-json.md: {undocumented:#?}");
    let shape: Vec<String> = paths.iter().map(|(k, kinds)| format!("{k}: {}", kinds.iter().copied().collect::<Vec<_>>().join(" | "))).collect();
    insta::assert_json_snapshot!("report_json_shape", shape);
}
