//! `facslab export --format psych-ds` on a finished study, checked against the rules of the
//! Psych-DS specification (the dataset_description.json fields, the data directory, the data
//! file name pattern, columns matching `variableMeasured`, rectangular CSV). The specification's
//! own validator is not on the package registries this project installs from, so the rules
//! are checked here.

use std::collections::BTreeSet;
use std::path::Path;

use crate::cli::{facslab, facslab_ok};
use crate::server::*;

/// `([a-z]+-[a-zA-Z0-9]+)(_[a-z]+-[a-zA-Z0-9]+)*_data.csv`, Psych-DS's data file pattern.
fn is_data_file_name(name: &str) -> bool {
    let Some(stem) = name.strip_suffix("_data.csv") else { return false };
    !stem.is_empty()
        && stem.split('_').all(|pair| match pair.split_once('-') {
            Some((key, value)) => !key.is_empty() && key.bytes().all(|b| b.is_ascii_lowercase()) && !value.is_empty() && value.bytes().all(|b| b.is_ascii_alphanumeric()),
            None => false,
        })
}

/// Every rule a Psych-DS validator reports as an error, as messages (empty: valid).
fn psych_ds_errors(root: &Path) -> Vec<String> {
    let mut errors = Vec::new();
    let Ok(text) = std::fs::read_to_string(root.join("dataset_description.json")) else { return vec!["no dataset_description.json".into()] };
    let Ok(meta) = serde_json::from_str::<serde_json::Value>(&text) else { return vec!["dataset_description.json is not JSON".into()] };
    if !meta["@context"].as_str().is_some_and(|c| c.trim_end_matches('/').ends_with("schema.org")) {
        errors.push("@context is not schema.org".into());
    }
    if meta["@type"] != "Dataset" {
        errors.push("@type is not Dataset".into());
    }
    for field in ["name", "description"] {
        if meta[field].as_str().is_none_or(|v| v.trim().is_empty()) {
            errors.push(format!("{field} missing"));
        }
    }
    let variables: BTreeSet<String> = match meta["variableMeasured"].as_array() {
        Some(list) => list.iter().filter_map(|v| v.as_str().or_else(|| (v["@type"] == "PropertyValue").then(|| v["name"].as_str()).flatten())).map(String::from).collect(),
        None => return vec!["variableMeasured is not an array".into()],
    };
    let Ok(entries) = std::fs::read_dir(root.join("data")) else { return vec!["no data directory".into()] };
    let mut data_files = 0;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.ends_with(".csv") {
            continue;
        }
        if !is_data_file_name(&name) {
            errors.push(format!("{name}: not a Psych-DS data file name"));
            continue;
        }
        data_files += 1;
        let mut reader = csv::Reader::from_path(entry.path()).unwrap();
        let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
        errors.extend(header.iter().filter(|h| !variables.contains(*h)).map(|h| format!("{name}: column {h} is not in variableMeasured")));
        if header.iter().collect::<BTreeSet<_>>().len() != header.len() {
            errors.push(format!("{name}: a column header appears twice"));
        }
        errors.extend(reader.records().filter_map(Result::err).map(|e| format!("{name}: {e}")));
    }
    if data_files == 0 {
        errors.push("no data file".into());
    }
    errors
}

#[test]
fn psych_ds_rules_catch_what_they_should() {
    assert!(is_data_file_name("study-exp3_data.csv") && is_data_file_name("study-exp3_description-stimuli_data.csv"));
    for bad in ["exp3_data.csv", "study-exp-3_data.csv", "Study-x_data.csv", "study-x.csv", "_data.csv"] {
        assert!(!is_data_file_name(bad), "{bad}");
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("data")).unwrap();
    std::fs::write(dir.path().join("dataset_description.json"), r#"{"@context": "https://schema.org/", "@type": "Dataset", "name": "n", "description": "d", "variableMeasured": ["a"]}"#).unwrap();
    std::fs::write(dir.path().join("data/study-x_data.csv"), "a,b\n1,2\n3\n").unwrap();
    let errors = psych_ds_errors(dir.path());
    assert!(errors.iter().any(|e| e.contains("column b")) && errors.iter().any(|e| e.contains("record")), "{errors:?}");
}

#[tokio::test(flavor = "multi_thread")]
async fn psych_ds_export_of_a_finished_study_follows_the_specification() {
    let (lab, server, http) = emotion_lab("emo-1", "");
    let token = start(&http, &server, "emo-1", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    while let Some(position) = current_position(&http, &server, &token).await {
        let (status, ack) = save(&http, &server, &token, position, &format!("key-{token}-{position}"), &[("emotion", "fear"), ("believability", "3")]).await;
        assert_eq!(status, 200, "{ack}");
    }
    drop(server);
    facslab_ok(lab.path(), &["export", "--study", "emo-1", "--format", "psych-ds", "--db", "lab.db", "-o", "dataset"]);
    let root = lab.path().join("dataset");
    assert_eq!(psych_ds_errors(&root), Vec::<String>::new());

    // The responses file is the long export; the stimuli file tells what each stimulus showed.
    facslab_ok(lab.path(), &["export", "--study", "emo-1", "--db", "lab.db", "-o", "long.csv"]);
    let read = |p: &str| std::fs::read_to_string(lab.path().join(p)).unwrap();
    assert_eq!(read("dataset/data/study-emo1_data.csv"), read("long.csv"));
    let stimuli = read("dataset/data/study-emo1_description-stimuli_data.csv");
    assert_eq!(stimuli.lines().count(), 1 + 7, "one row per stimulus of the study:\n{stimuli}");
    assert!(stimuli.lines().next().unwrap().starts_with("stimulus_id,media,identity,expression,emotion,intensity"));
    let participants = read("dataset/data/study-emo1_description-participants_data.csv");
    assert!(participants.lines().nth(1).unwrap().contains(",raters,,completed,34,female,asian,doctorate"), "{participants}");
    let meta: serde_json::Value = serde_json::from_str(&read("dataset/dataset_description.json")).unwrap();
    let value = meta["variableMeasured"].as_array().unwrap().iter().find(|v| v["name"] == "value").unwrap();
    assert!(value["valueReference"].as_array().unwrap().iter().any(|m| m["name"] == "believability"), "the measures' codebook sits under value");

    // An existing directory is never overwritten, and the same study gives the same bytes.
    let again = facslab(lab.path(), &["export", "--study", "emo-1", "--format", "psych-ds", "--db", "lab.db", "-o", "dataset"]);
    assert!(!again.status.success() && String::from_utf8_lossy(&again.stderr).contains("exists already"));
    facslab_ok(lab.path(), &["export", "--study", "emo-1", "--format", "psych-ds", "--db", "lab.db", "-o", "dataset2"]);
    for file in ["dataset_description.json", "README.md", "data/study-emo1_data.csv", "data/study-emo1_description-participants_data.csv"] {
        assert_eq!(read(&format!("dataset/{file}")), read(&format!("dataset2/{file}")), "{file}");
    }
}
