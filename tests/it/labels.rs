//! A user's own label set end to end: a spec declares `moods.toml` and labels its expressions
//! from it, the built set carries the file, a study offers its labels (created and served by
//! separate processes, which learn the set from the stimulus set alone), and the report is
//! headed by it and scores the answers against it.

use crate::backends::Backend;
use crate::cli::{facslab, facslab_ok};
use crate::server::*;

const MOODS: &str = r#"id = "moods"
name = "Moods of the lab"
none = true

[[label]]
id = "astonished"
name = "Astonished"
description = "Something quite unexpected has just happened."

[[label]]
id = "content"
name = "Content"
description = "All is well."

[[label]]
id = "cross"
name = "Cross"
description = "Someone has let you down."
"#;

const SPEC: &str = r#"name = "moods"
seed = 21
size = [32, 32]
identities = ["wm1"]
label_sets = ["moods.toml"]

[[group]]
name = "moods"
labelled = [
  { label = "moods:astonished", expression = "1+2+5B+26" },
  { label = "moods:content", expression = "6+12" },
  { label = "moods:cross", expression = "4+5+7+23" },
]
stills = [1.0]
"#;

const DESIGN: &str = r#"slug = "moods"
title = "Which mood?"
task = "emotion"
labels = "moods"
stimuli = "set"
trials_per_participant = 0
practice_trials = 0
demographics = false
consent = "ok"
instructions = "go"
debrief = "thanks"
"#;

#[tokio::test(flavor = "multi_thread")]
async fn a_users_own_label_set_travels_with_its_stimuli_into_the_study_and_report() {
    let lab = Lab::with_files(SPEC, &[("moods.toml", MOODS)], &Backend::Sqlite);
    let carried = std::fs::read_to_string(lab.path().join("set/labels/moods.toml")).unwrap();
    assert_eq!(carried, MOODS, "the set carries the declared file unchanged");
    let labels: Vec<String> = lab.manifest().into_iter().map(|(_, label, _, _)| label).collect();
    assert_eq!(labels, ["moods:astonished", "moods:content", "moods:cross"]);

    lab.study("moods", DESIGN);
    let server = lab.serve();
    let http = client();
    let token = start(&http, &server, "moods", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let mut answered = 0;
    while let Some(position) = current_position(&http, &server, &token).await {
        let page = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap().text().await.unwrap();
        for name in ["Astonished", "Content", "Cross", "None of these"] {
            assert!(page.contains(name), "the trial offers {name}");
        }
        assert!(!page.contains("Happiness"), "not the EmFACS labels");
        let (status, ack) = save(&http, &server, &token, position, &format!("moods-bad-{token}-{position}"), &[("emotion", "happiness")]).await;
        assert_eq!((status, ack["field"].as_str()), (422, Some("emotion")), "a label of another set is refused: {ack}");
        let (status, ack) = save(&http, &server, &token, position, &format!("moods-{token}-{position}"), &[("emotion", "astonished")]).await;
        assert_eq!(status, 200, "{ack}");
        answered += 1;
    }
    assert_eq!(answered, 3);

    facslab_ok(lab.path(), &["report", "--study", "moods", "--db", &lab.db, "-o", "report"]);
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(lab.path().join("report/report.json")).unwrap()).unwrap();
    let rating = &report["rating"];
    assert_eq!((rating["label_set"].as_str(), rating["label_set_name"].as_str()), (Some("moods"), Some("Moods of the lab")));
    assert_eq!(rating["labels"], serde_json::json!(["astonished", "content", "cross", "none"]));
    let rows = rating["conditions"][0]["emotions"].as_array().unwrap();
    let rate = |label: &str| rows.iter().find(|r| r["emotion"] == label).map(|r| r["rate"].as_f64().unwrap());
    assert_eq!((rate("astonished"), rate("content"), rate("cross")), (Some(1.0), Some(0.0), Some(0.0)), "every answer was astonished: {rows:?}");
}

#[test]
fn a_spec_naming_an_undeclared_label_says_which_item() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("moods.toml"), MOODS).unwrap();
    std::fs::write(dir.path().join("bad.toml"), SPEC.replace("moods:cross", "moods:bored")).unwrap();
    let out = facslab(dir.path(), &["stimuli", "build", "bad.toml", "-o", "set"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("item 3") && err.contains("\"bored\" is not a label of the moods label set"), "{err}");
    std::fs::write(dir.path().join("none.toml"), SPEC.replace("moods.toml", "missing.toml")).unwrap();
    let out = facslab(dir.path(), &["stimuli", "build", "none.toml", "-o", "set"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("missing.toml"), "{err}");
    assert!(!dir.path().join("set/manifest.csv").exists(), "nothing is built");
}
