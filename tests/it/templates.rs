//! The shipped HapFACS templates (`studies/`) on reduced sets of their own specifications
//! (`stimuli/sets/`: same entries, 64 × 64 pixels, 5 frames per second): each study is created
//! over its set and participants are walked through it over real HTTP, checking the paper's
//! design (seed 001 §4): groups, media, intensities, scales and what each participant sees.

use std::collections::{BTreeMap, BTreeSet};

use crate::server::*;

/// A shipped file of the project, as text.
fn shipped(path: &str) -> String {
    std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap()
}

/// The set specification `stimuli/sets/NAME.toml` with small frames and few video frames,
/// after checking that the shipped one renders at the paper's `size` at 30 fps.
fn reduced_set(name: &str, size: [u32; 2]) -> String {
    let spec = shipped(&format!("stimuli/sets/{name}.toml"));
    let line = spec.lines().find(|l| l.starts_with("size = ")).expect("a size line").to_string();
    assert_eq!(line, format!("size = [{}, {}]", size[0], size[1]), "{name}: the paper's frame size");
    let size = line;
    let reduced = spec.replace(&size, "size = [64, 64]").replace("fps = 30", "fps = 5");
    assert!(reduced.contains("fps = 5"), "{name}.toml: no fps line to reduce");
    reduced
}

/// Manifest facts by stimulus id: (media, emotion, intensity in percent).
fn facts(lab: &Lab) -> BTreeMap<String, (String, String, u32)> {
    let text = std::fs::read_to_string(lab.path().join("set/manifest.json")).unwrap();
    let rows: Vec<serde_json::Value> = serde_json::from_str(&text).unwrap();
    rows.iter()
        .map(|r| {
            let percent = (r["intensity"].as_f64().unwrap() * 100.0).round() as u32;
            (r["stimulus_id"].as_str().unwrap().into(), (r["media"].as_str().unwrap().into(), r["emotion"].as_str().unwrap().into(), percent))
        })
        .collect()
}

/// Consents, then answers every trial with `fields` (the page never says which stimulus it
/// shows: the test reads that from the wide export afterwards); returns the trials answered.
async fn walk(http: &reqwest::Client, server: &Server, token: &str, fields: &[(&str, &str)]) -> usize {
    consent_and_demographics(http, server, token).await;
    let mut trials = 0;
    while let Some(position) = current_position(http, server, token).await {
        let page = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap().text().await.unwrap();
        if page.contains("name=\"believability\"") {
            // The paper's scale: 0 (not believable at all) to 5 (very believable).
            assert!(page.contains("name=\"believability\" value=\"0\"") && page.contains("name=\"believability\" value=\"5\""), "believability is not 0-5");
        }
        let (status, ack) = save(http, server, token, position, &format!("k-{token}-{position}"), fields).await;
        assert_eq!(status, 200, "{ack}");
        trials += 1;
    }
    trials
}

/// The admin's wide export: (participant_id, group, arm, stimulus ids answered).
async fn wide(http: &reqwest::Client, server: &Server, slug: &str) -> Vec<(String, String, String, BTreeSet<String>)> {
    let cookie = admin_cookie(http, server).await;
    let csv = http.get(server.url(&format!("/admin/studies/{slug}/export/wide.csv"))).header("cookie", &cookie).send().await.unwrap().text().await.unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&head[..3], ["participant_id", "group", "arm"]);
    lines
        .map(|line| {
            let cells: Vec<&str> = line.split(',').collect();
            let answered = head.iter().zip(&cells).skip(7).filter(|(h, v)| !v.is_empty() && h.ends_with(":emotion")).map(|(h, _)| h.split(':').next().unwrap().to_string()).collect();
            (cells[0].into(), cells[1].into(), cells[2].into(), answered)
        })
        .collect()
}

const MTURK: [(&str, &str); 4] = [("workerId", "A1B2C3D4E5F6G7"), ("assignmentId", "3ABCDEFGHIJ"), ("hitId", "3HIT"), ("turkSubmitTo", "https://workersandbox.mturk.com")];

#[tokio::test(flavor = "multi_thread")]
async fn templates_exp3_reproduces_the_papers_groups_and_arms() {
    let lab = Lab::with_set(&reduced_set("exp3", [485, 485]));
    lab.study("exp3", &shipped("studies/exp3-emotions.toml"));
    let (server, http, facts) = (lab.serve(), client(), facts(&lab));
    let answer = [("emotion", "surprise"), ("believability", "0")];

    // The landing page's time is for one arm's ten faces, not the set's forty.
    let landing = http.get(server.url("/s/exp3")).send().await.unwrap().text().await.unwrap();
    assert!(landing.contains("It takes about 3 minutes"), "{landing}");

    // Exp. 3: a local participant (plain link) and an MTurk worker (the HIT's link), each in
    // one of the four stimulus groups: ten stimuli of one media at one intensity, one per emotion.
    let local = start(&http, &server, "exp3", &[]).await;
    assert_eq!(walk(&http, &server, &local, &answer).await, 10 + 2, "ten stimuli and the two attention checks");
    let worker = start(&http, &server, "exp3", &MTURK).await;
    assert_eq!(walk(&http, &server, &worker, &answer).await, 10 + 2);
    let done = http.get(server.url(&format!("/p/{worker}/done"))).send().await.unwrap().text().await.unwrap();
    assert!(done.contains("workersandbox.mturk.com/mturk/externalSubmit") || done.contains("www.mturk.com/mturk/externalSubmit"), "the MTurk worker is sent back to MTurk");
    let rows = wide(&http, &server, "exp3").await;
    assert_eq!(rows.iter().map(|r| r.1.as_str()).collect::<BTreeSet<_>>(), BTreeSet::from(["amt", "local"]));
    let arms: BTreeSet<&str> = rows.iter().map(|r| r.2.as_str()).collect();
    assert_eq!(arms.len(), 2, "the second participant joins another (smaller) arm: {arms:?}");
    for (pid, _, arm, seen) in &rows {
        let shown: BTreeSet<(String, u32)> = seen.iter().map(|s| (facts[s].0.clone(), facts[s].2)).collect();
        assert_eq!(shown.len(), 1, "{pid} ({arm}) saw several media/intensities: {shown:?}");
        let (media, percent) = shown.into_iter().next().unwrap();
        assert_eq!(arm, &format!("{}s-{percent}", media), "{pid}: arm and stimuli disagree");
        let emotions: BTreeSet<&str> = seen.iter().map(|s| facts[s].1.as_str()).collect();
        assert_eq!((seen.len(), emotions.len()), (10, 10), "{pid}: one stimulus per emotion");
    }

}

/// Exp. 4 on its own set (issue 17): every participant sees exactly the ten speaking videos,
/// one per emotion at 100 %, each with its Opus sound track.
#[tokio::test(flavor = "multi_thread")]
async fn templates_exp4_serves_exactly_the_ten_speaking_videos() {
    if !crate::speech::speech_tools() {
        return;
    }
    let lab = Lab::with_set(&reduced_set("exp4", [485, 485]));
    lab.study("exp4", &shipped("studies/exp4-emotions-video.toml"));
    let (server, http, facts) = (lab.serve(), client(), facts(&lab));
    assert_eq!(facts.len(), 10, "the Exp. 4 set has the ten speaking videos only");
    for (_, _, _, file) in lab.manifest() {
        let bytes = std::fs::read(lab.path().join("set").join(&file)).unwrap();
        assert!(bytes.windows(4).any(|w| w == b"dOps"), "{file} has no Opus sound track");
    }
    let answer = [("emotion", "surprise"), ("believability", "0")];
    let local = start(&http, &server, "exp4", &[]).await;
    assert_eq!(walk(&http, &server, &local, &answer).await, 10);
    let rows = wide(&http, &server, "exp4").await;
    let seen = &rows[0].3;
    assert_eq!(seen, &facts.keys().cloned().collect::<BTreeSet<_>>(), "exp4 shows exactly the set's ten videos");
    assert!(seen.iter().all(|s| facts[s].0 == "video" && facts[s].2 == 100), "exp4 shows only the 100 % videos");
    assert_eq!(seen.iter().map(|s| facts[s].1.as_str()).collect::<BTreeSet<_>>().len(), 10);
    assert_eq!(rows[0].1, "local");
    // Tables 12 and 13 from the platform's answers: every answer was "surprise", believability 0.
    crate::cli::facslab_ok(lab.path(), &["report", "--study", "exp4", "--db", "lab.db", "-o", "report"]);
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(lab.path().join("report/report.json")).unwrap()).unwrap();
    let condition = &report["rating"]["conditions"][0];
    assert_eq!(condition["key"], "video 100%", "{condition}");
    assert_eq!(condition["confusion"]["counts"].as_array().map(Vec::len), Some(10), "Table 12 has a row per emotion: {}", condition["confusion"]);
    assert_eq!(condition["scales"][0]["overall"]["mean"].as_f64(), Some(0.0), "Table 13: {}", condition["scales"][0]);
    assert_eq!(condition["scales"][0]["overall"]["n"].as_u64(), Some(10), "Table 13: {}", condition["scales"][0]);
}

#[tokio::test(flavor = "multi_thread")]
async fn templates_exp2_shows_every_coder_the_54_combinations_as_video_with_a_still() {
    let lab = Lab::with_set(&reduced_set("exp2", [485, 480]));
    lab.study("exp2", &shipped("studies/exp2-coders.toml"));
    let (server, http) = (lab.serve(), client());
    let coder = start(&http, &server, "exp2", &[]).await;
    consent_and_demographics(&http, &server, &coder).await;
    let mut trials = 0;
    while let Some(position) = current_position(&http, &server, &coder).await {
        let page = http.get(server.url(&format!("/p/{coder}/trial"))).send().await.unwrap().text().await.unwrap();
        assert!(!page.contains("name=\"intensity_"), "the paper's coders gave no intensities (§4.1)");
        // Each combination's video comes with one still of it (§4.1), as one judgement.
        assert!(page.contains("<video") && page.contains(&format!("/p/{coder}/media/{position}/1\"")), "trial {position}: no video with its still");
        assert!(!page.contains(&format!("/p/{coder}/media/{position}/2\"")), "trial {position}: more than one still");
        let (status, ack) = save(&http, &server, &coder, position, &format!("k-{coder}-{position}"), &[("au", "12")]).await;
        assert_eq!(status, 200, "{ack}");
        trials += 1;
    }
    // One practice trial and one attention check around the 54 combinations.
    assert_eq!(trials, 54 + 1 + 1, "the 54 combinations of Table 4, every one to every coder, each once");
}
