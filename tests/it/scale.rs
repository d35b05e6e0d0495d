//! Several `facslab serve` instances on one PostgreSQL database, as behind a load balancer:
//! participants alternate between the instances at every step.

use std::collections::HashMap;

use facslab::db::{Db, DbUrl};

use crate::backends::postgres;
use crate::server::*;

const DESIGN: &str = r#"
slug = "duo"
title = "Two servers"
task = "emotion"
stimuli = "set"
practice_trials = 0
trials_per_participant = 3
ratings_per_stimulus = 4
reservation_minutes = 30
demographics = false
consent = "ok"
instructions = "go"
debrief = "thanks"
"#;

/// What one participant's run left: `None` when the study was full, else the saves the servers
/// acknowledged (position → idempotency key; empty for one who walked away).
type Run = Option<HashMap<i64, String>>;

/// One participant, the `n`th: starts on one instance and switches instance at every step; every
/// save is sent again to the other instance (a retry after a lost reply), which must answer
/// "repeated". Every third participant walks away after starting.
async fn participant(http: reqwest::Client, servers: [String; 2], n: usize) -> Run {
    let at = |step: usize, path: &str| format!("{}{path}", servers[(n + step) % 2]);
    let r = http.post(at(0, "/s/duo/start")).form(&[("worker", format!("w{n}"))]).send().await.unwrap();
    if r.status() == 200 {
        return None;
    }
    assert_eq!(r.status(), 303, "start of w{n}");
    let token = location(&r).rsplit('/').next().unwrap().to_string();
    let mut acknowledged = HashMap::new();
    if n.is_multiple_of(3) {
        return Some(acknowledged);
    }
    let r = http.post(at(1, &format!("/p/{token}/consent"))).form(&[("agree", "1")]).send().await.unwrap();
    assert_eq!(r.status(), 303, "consent of w{n}");
    for step in 2.. {
        let page = http.get(at(step, &format!("/p/{token}/trial"))).send().await.unwrap();
        if page.status() != 200 {
            break;
        }
        let html = page.text().await.unwrap();
        let marker = format!("/p/{token}/trial/");
        let Some(position) = html.find(&marker).and_then(|i| html[i + marker.len()..].split('"').next()?.parse::<i64>().ok()) else { break };
        let key = format!("duo-{token}-{position}");
        let body = serde_json::json!({ "idempotency_key": key, "fields": [["emotion", "fear"]], "rt_ms": 700.0 });
        let url = |s: usize| at(s, &format!("/p/{token}/api/trial/{position}"));
        let first = http.post(url(step)).json(&body).send().await.unwrap();
        assert_eq!(first.status(), 200, "save of w{n} at {position}");
        acknowledged.insert(position, key);
        let retry: serde_json::Value = http.post(url(step + 1)).json(&body).send().await.unwrap().json().await.unwrap();
        assert_eq!(retry["saved"], "repeated", "the other instance sees the save: {retry}");
    }
    Some(acknowledged)
}

#[tokio::test(flavor = "multi_thread")]
async fn scale_two_servers_on_one_postgres_database_serve_one_study() {
    let Some(backend) = postgres() else { return };
    let lab = Lab::on(&backend);
    lab.study("duo", DESIGN);
    // Every participant comes from 127.0.0.1: lift the per-address limit on starts.
    let serve = || Server::start_with(std::path::PathBuf::from(&lab.db), &["--starts-per-address", "1000"]);
    let (a, b) = (serve(), serve());
    let servers = [a.base.clone(), b.base.clone()];
    let db = Db::open(&lab.db.parse::<DbUrl>().unwrap()).await.unwrap();
    let study = db.study_by_slug("duo").await.unwrap().unwrap().id;
    let http = client();

    let (mut saves, mut completed, mut abandoned, mut n) = (HashMap::new(), 0, 0, 0);
    loop {
        // A wave of eight participants arriving together on both instances.
        let wave: Vec<_> = (0..8).map(|i| tokio::spawn(participant(http.clone(), servers.clone(), n + i))).collect();
        n += 8;
        let mut admitted = 0;
        for run in wave {
            let Some(acknowledged) = run.await.unwrap() else { continue };
            admitted += 1;
            if acknowledged.is_empty() {
                abandoned += 1;
            } else {
                assert_eq!(acknowledged.len(), 3, "every trial was saved");
                completed += 1;
                saves.extend(acknowledged.into_values().map(|key| (key, ())));
            }
        }
        // The walk-aways' reservations time out, which frees their stimuli.
        db.reap(facslab::db::now_ms() + 31 * 60_000).await.unwrap();
        if admitted == 0 {
            break;
        }
        assert!(n < 400, "the study never filled");
    }

    // Every acknowledged save is stored once, and every participant who stayed completed.
    let people = db.participants(study).await.unwrap();
    let stored: i64 = people.iter().map(|p| p.answered).sum();
    assert_eq!(stored as usize, saves.len(), "acknowledged saves: {}, stored: {stored}", saves.len());
    assert_eq!(people.iter().filter(|p| p.state == "completed").count(), completed);
    assert_eq!(people.iter().filter(|p| p.state == "abandoned").count(), abandoned);
    // The first wave, into an empty study, is admitted whole (8 × 3 reservations ≤ 28), so its
    // three walk-aways are counted; who of a later wave gets in is a race between arrivals.
    // The study fills: fewer than three ratings are left when no one is admitted.
    assert!(completed >= 9 && abandoned >= 3, "completed {completed}, abandoned {abandoned}");
    // Balance across both instances: seven stimuli, each rated four times, at most one over.
    let counts = db.completed_counts(study).await.unwrap();
    assert_eq!(counts.len(), 7);
    for (stimulus, n) in &counts {
        assert!((4..=5).contains(n), "{stimulus} ended with {n} ratings (target 4, at most one over): {counts:?}");
    }
    assert_eq!(counts.iter().map(|(_, n)| n).sum::<i64>(), completed as i64 * 3);
    db.close().await;
}

/// Each instance reads the set from its own copy: one whose copy differs from the set the study
/// was made with (here a media file changed after the study was made) refuses to serve the
/// study, saying why, and serves it again once the copy is right.
#[tokio::test(flavor = "multi_thread")]
async fn scale_a_server_whose_copy_of_the_set_differs_refuses_to_serve_the_study() {
    let lab = Lab::new();
    lab.study("emo", &emotion_design("emo", ""));
    let server = Server::start_logged(std::path::PathBuf::from(&lab.db), Some("facslab=warn"));
    let http = client();
    let manifest = lab.manifest();
    let file = lab.path().join("set").join(&manifest[0].3);
    let original = std::fs::read(&file).unwrap();
    let mut changed = original.clone();
    let last = changed.len() - 1;
    changed[last] ^= 1;
    std::fs::write(&file, &changed).unwrap();

    let refused = http.get(server.url("/s/emo")).send().await.unwrap();
    assert_eq!(refused.status(), 503);
    let text = refused.text().await.unwrap();
    assert!(text.contains("copy of the study&#39;s stimulus set differs") || text.contains("copy of the study's stimulus set differs"), "{text}");
    assert!(!text.contains(&manifest[0].0), "the page does not name the stimulus: {text}");
    let log = logged(&server, "refusing to serve").await;
    assert!(log.contains(&manifest[0].3) && log.contains("copy the set again"), "{log}");
    // A changed manifest is refused as well, naming both hashes in the log.
    std::fs::write(&file, &original).unwrap();
    let manifest_file = lab.path().join("set/manifest.json");
    let text = std::fs::read_to_string(&manifest_file).unwrap();
    std::fs::write(&manifest_file, format!("{text}\n")).unwrap();
    assert_eq!(http.get(server.url("/s/emo")).send().await.unwrap().status(), 503);
    assert!(logged(&server, "the study recorded").await.contains("its manifest.json has SHA-256"));
    std::fs::write(&manifest_file, &text).unwrap();
    assert_eq!(http.get(server.url("/s/emo")).send().await.unwrap().status(), 200, "the right copy is served");
}

/// The server's log once it has a line containing `needle` (lines are written after the response).
async fn logged(server: &Server, needle: &str) -> String {
    for _ in 0..100 {
        let log = server.log();
        if log.contains(needle) {
            return log;
        }
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
    panic!("no log line with {needle:?}:\n{}", server.log());
}
