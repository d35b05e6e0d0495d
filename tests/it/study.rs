//! The study platform over real HTTP: the `facslab serve` process on a real database (an SQLite
//! file, and a PostgreSQL database when there is a server: [`crate::backends`]).

use std::collections::{BTreeMap, HashSet};

use crate::backends::{Backend, backends};
use crate::cli::facslab_ok;
use crate::server::*;

/// A Prolific participant id (24 hexadecimal digits).
const PID: &str = "5f1a2b3c4d5e6f708192a3b4";

/// Answers every remaining trial (attention checks as asked); returns the saved positions.
async fn answer_all(http: &reqwest::Client, server: &Server, token: &str) -> Vec<i64> {
    let mut saved = Vec::new();
    while let Some(position) = current_position(http, server, token).await {
        let key = format!("key-{token}-{position}");
        let (status, ack) = save(http, server, token, position, &key, &[("emotion", "surprise"), ("believability", "4")]).await;
        assert_eq!(status, 200, "{ack}");
        saved.push(position);
    }
    saved
}

#[tokio::test(flavor = "multi_thread")]
async fn study_participant_completes_and_admin_exports_the_long_csv() {
    for backend in backends() {
        participant_completes_and_admin_exports(&backend).await;
    }
}

async fn participant_completes_and_admin_exports(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let (lab, server, http) = emotion_lab_on(backend, "emo", "[recruitment]\nplatform = \"prolific\"\ncompletion_code = \"C0DE42\"\n");

    // A GET of the link creates nothing (link previews), and the link needs the worker id.
    let landing = http.get(server.url(&format!("/s/emo?PROLIFIC_PID={PID}&STUDY_ID=s&SESSION_ID=x"))).send().await.unwrap();
    assert_eq!(landing.status(), 200);
    assert!(landing.text().await.unwrap().contains(&format!("name=\"PROLIFIC_PID\" value=\"{PID}\"")));
    assert_eq!(http.get(server.url("/s/emo")).send().await.unwrap().status(), 400);

    let token = start(&http, &server, "emo", &[("PROLIFIC_PID", PID), ("STUDY_ID", "s"), ("SESSION_ID", "x")]).await;
    // One participation per worker: starting again from the same browser (its cookie) gives the same one.
    let again = http.post(server.url("/s/emo/start")).header("cookie", format!("facslab_emo={token}")).form(&[("PROLIFIC_PID", PID)]).send().await.unwrap();
    assert_eq!(location(&again), format!("/p/{token}"));
    // The completion page is not reachable before the end.
    let early = http.get(server.url(&format!("/p/{token}/done"))).send().await.unwrap();
    assert_eq!(early.status(), 303);
    consent_and_demographics(&http, &server, &token).await;
    let saved = answer_all(&http, &server, &token).await;
    assert_eq!(saved.len(), 7 + 1, "1 practice + 7 stimuli");

    let done = http.get(server.url(&format!("/p/{token}/done"))).send().await.unwrap().text().await.unwrap();
    assert!(done.contains("https://app.prolific.com/submissions/complete?cc=C0DE42"), "{done}");

    // Admin: anonymous requests are refused; after login the long CSV has every judgement.
    let anonymous = http.get(server.url("/admin/studies/emo/export/responses.csv")).send().await.unwrap();
    assert_eq!((anonymous.status().as_u16(), location(&anonymous)), (303, "/admin/login".into()));
    let cookie = admin_cookie(&http, &server).await;
    let dashboard = http.get(server.url("/admin")).header("cookie", &cookie).send().await.unwrap().text().await.unwrap();
    assert!(dashboard.contains("Emotion test") && dashboard.contains("data-field=\"completed\">1<"), "{dashboard}");
    let csv = http.get(server.url("/admin/studies/emo/export/responses.csv")).header("cookie", &cookie).send().await.unwrap().text().await.unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "participant_id,group,stimulus_id,trial,measure,value,rt_ms");
    assert_eq!(lines.iter().filter(|l| l.contains(",emotion,surprise,")).count(), 7, "{csv}");
    assert_eq!(lines.iter().filter(|l| l.contains(",believability,4,900.5")).count(), 7);
    assert!(lines.iter().any(|l| l.ends_with(",,,age,34,")));

    // The export is the analysis's input: analyze it against the set's manifest.
    std::fs::write(lab.path().join("responses.csv"), &csv).unwrap();
    facslab_ok(lab.path(), &["analyze", "--responses", "responses.csv", "--manifest", "set/manifest.csv", "-o", "report"]);
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(lab.path().join("report/report.json")).unwrap()).unwrap();
    assert!(report.to_string().contains("surprise"));

    // The CLI export gives the same bytes as the web export.
    drop(server);
    facslab_ok(lab.path(), &["export", "--study", "emo", "--db", &lab.db, "-o", "cli.csv"]);
    assert_eq!(std::fs::read_to_string(lab.path().join("cli.csv")).unwrap(), csv);
    // And the report straight from the database.
    facslab_ok(lab.path(), &["report", "--study", "emo", "--db", &lab.db, "-o", "from-db"]);
    assert_eq!(std::fs::read_to_string(lab.path().join("from-db.inputs/responses.csv")).unwrap(), csv);
    assert!(lab.path().join("from-db/report.html").is_file());
    // Analysed in memory from the database, the report is the one of the exported file.
    let read = |dir: &str| std::fs::read_to_string(lab.path().join(dir).join("report.json")).unwrap();
    assert_eq!(read("from-db"), read("report"));
}

#[tokio::test(flavor = "multi_thread")]
async fn study_survives_a_crash_and_repeated_requests() {
    for backend in backends() {
        survives_a_crash_and_repeated_requests(&backend).await;
    }
}

async fn survives_a_crash_and_repeated_requests(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let (_lab, server, http) = emotion_lab_on(backend, "emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;

    // Two trials; each save is sent three times (a client retrying after lost replies).
    let mut acknowledged = Vec::new();
    for _ in 0..2 {
        let position = current_position(&http, &server, &token).await.unwrap();
        let key = format!("retry-key-{position:08}");
        let fields = [("emotion", "fear"), ("believability", "2")];
        let first = save(&http, &server, &token, position, &key, &fields).await;
        let again = save(&http, &server, &token, position, &key, &fields).await;
        let third = save(&http, &server, &token, position, &key, &fields).await;
        assert_eq!((first.0, first.1["saved"].as_str()), (200, Some("stored")));
        assert_eq!((again.0, again.1["saved"].as_str()), (200, Some("repeated")));
        assert_eq!(third.1["saved"].as_str(), Some("repeated"));
        // A different answer to an answered trial is refused and changes nothing.
        let other = save(&http, &server, &token, position, "another-key-0000000", &[("emotion", "anger"), ("believability", "5")]).await;
        assert_eq!(other.0, 409);
        acknowledged.push(position);
    }

    // The server dies mid-session; a save sent while it is down fails at the client.
    let db = server.crash();
    let position = acknowledged[1] + 1;
    let down = http.post(format!("http://127.0.0.1:1/p/{token}/api/trial/{position}")).send().await;
    assert!(down.is_err());

    // After the restart the participant resumes at the first unanswered trial.
    let server = Server::start(db);
    let resume = http.get(server.url(&format!("/p/{token}"))).send().await.unwrap();
    assert_eq!(location(&resume), format!("/p/{token}/trial"));
    assert_eq!(current_position(&http, &server, &token).await, Some(position));
    // The client's queue replays an acknowledged save: still stored once.
    let replay = save(&http, &server, &token, acknowledged[0], &format!("retry-key-{:08}", acknowledged[0]), &[("emotion", "fear"), ("believability", "2")]).await;
    assert_eq!(replay.1["saved"].as_str(), Some("repeated"));
    let rest = answer_all(&http, &server, &token).await;
    assert_eq!(acknowledged.len() + rest.len(), 8, "1 practice + 7 stimuli: {acknowledged:?} {rest:?}");

    let cookie = admin_cookie(&http, &server).await;
    let json: serde_json::Value = http.get(server.url("/admin/studies/emo/export/responses.json")).header("cookie", &cookie).send().await.unwrap().json().await.unwrap();
    let trials = json["participants"][0]["trials"].as_array().unwrap();
    let positions: Vec<i64> = trials.iter().map(|t| t["trial"].as_i64().unwrap() - 1).collect();
    let unique: HashSet<i64> = positions.iter().copied().collect();
    assert_eq!(positions.len(), unique.len(), "a trial stored twice: {positions:?}");
    assert_eq!(positions.len(), 8);
    for p in &acknowledged {
        let t = trials.iter().find(|t| t["trial"].as_i64() == Some(p + 1)).unwrap();
        assert_eq!(t["answers"][0][1], "fear", "the first acknowledged answer is the stored one");
    }
}

/// Replaces every occurrence of the volatile parts of a trial page with fixed words.
fn normalise(html: &str, token: &str) -> String {
    let mut out = html.replace(token, "TOKEN");
    for marker in ["name=\"idempotency_key\" value=\"", "/trial/", "/api/trial/", "/media/", "aria-valuenow=\"", "width: ", "\"progress\">"] {
        let mut result = String::new();
        let mut rest = out.as_str();
        while let Some(at) = rest.find(marker) {
            result.push_str(&rest[..at + marker.len()]);
            rest = &rest[at + marker.len()..];
            let end = rest.find(['"', '%', '<']).unwrap_or(rest.len());
            result.push('X');
            rest = &rest[end..];
        }
        result.push_str(rest);
        out = result;
    }
    out
}

#[tokio::test(flavor = "multi_thread")]
async fn study_pages_reveal_nothing_about_the_stimulus() {
    let (lab, server, http) = emotion_lab("emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let manifest = lab.manifest();
    let secrets: Vec<String> = manifest.iter().flat_map(|(id, _, expression, file)| [id.clone(), expression.clone(), file.clone()]).collect();

    let mut image_pages = BTreeMap::new();
    let mut seen = Vec::new();
    while let Some(position) = current_position(&http, &server, &token).await {
        let page = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap();
        let headers = format!("{:?}", page.headers());
        let html = page.text().await.unwrap();
        let media = http.get(server.url(&format!("/p/{token}/media/{position}"))).send().await.unwrap();
        let media_headers = format!("{:?}", media.headers());
        for secret in &secrets {
            assert!(!html.contains(secret.as_str()) && !headers.contains(secret.as_str()) && !media_headers.contains(secret.as_str()), "trial {position} reveals {secret}");
        }
        assert!(!media_headers.contains("content-disposition"));
        let kind = if html.contains("<video") { "video" } else { "image" };
        let practice_or_check = html.contains("class=\"badge\"") || html.contains("class=\"attention\"");
        if kind == "image" && !practice_or_check {
            image_pages.insert(position, normalise(&html, &token));
        }
        seen.push(position);
        save(&http, &server, &token, position, &format!("k{token}{position:04}"), &[("emotion", "none"), ("believability", "3")]).await;
    }
    assert!(image_pages.len() >= 5, "{seen:?}");
    // Every image trial page is the same page: nothing in it depends on what the face shows.
    let first = image_pages.values().next().unwrap();
    for (position, page) in &image_pages {
        assert_eq!(page, first, "trial {position} differs from the first image trial");
    }
    // The script is the same for everyone and names no stimulus.
    let js = http.get(server.url("/static/trial.js")).send().await.unwrap().text().await.unwrap();
    assert!(secrets.iter().all(|s| !js.contains(s.as_str())));
}

#[tokio::test(flavor = "multi_thread")]
async fn study_bad_input_gets_a_clear_4xx_and_stores_nothing() {
    for backend in backends() {
        bad_input_gets_a_clear_4xx(&backend).await;
    }
}

async fn bad_input_gets_a_clear_4xx(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let (lab, server, http) = emotion_lab_on(backend, "emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let position = current_position(&http, &server, &token).await.unwrap();
    let api = server.url(&format!("/p/{token}/api/trial/{position}"));

    let malformed = http.post(&api).header("content-type", "application/json").body("{\"idempotency_key\": ").send().await.unwrap();
    assert_eq!(malformed.status(), 400);
    assert!(malformed.text().await.unwrap().contains("not valid JSON"));
    let huge = http.post(&api).header("content-type", "application/json").body(vec![b' '; 70_000]).send().await.unwrap();
    assert_eq!(huge.status(), 413);
    for (fields, field) in [
        (vec![("emotion", "fear"), ("believability", "9")], "believability"),
        (vec![("emotion", "joy"), ("believability", "3")], "emotion"),
        (vec![("believability", "3")], "emotion"),
        (vec![("emotion", "fear"), ("believability", "3"), ("admin", "1")], "admin"),
    ] {
        let (status, body) = save(&http, &server, &token, position, "bad-input-key-0001", &fields).await;
        assert_eq!((status, body["field"].as_str()), (422, Some(field)), "{body}");
        assert!(!body["error"].as_str().unwrap().is_empty());
    }
    let (status, _) = save(&http, &server, &token, 999, "bad-input-key-0002", &[("emotion", "fear"), ("believability", "3")]).await;
    assert_eq!(status, 404);
    let (status, body) = save(&http, &server, &token, position, "short", &[("emotion", "fear"), ("believability", "3")]).await;
    assert_eq!((status, body["field"].as_str()), (422, Some("idempotency_key")));
    assert_eq!(http.get(server.url("/p/0123456789abcdef0123456789abcdef")).send().await.unwrap().status(), 404);
    let bad_age = http.post(server.url(&format!("/p/{token}/demographics"))).form(&[("age", "300")]).send().await.unwrap();
    assert_eq!(bad_age.status(), 422);

    // Nothing was stored, and the participant is still at the same trial.
    assert_eq!(current_position(&http, &server, &token).await, Some(position));
    let cookie = admin_cookie(&http, &server).await;
    let progress: serde_json::Value = http.get(server.url("/admin/studies/emo/progress.json")).header("cookie", &cookie).send().await.unwrap().json().await.unwrap();
    assert_eq!(progress["responses"], 0);

    // Admin routes: anonymous and token-less requests are refused; a form without the CSRF token too.
    assert_eq!(http.get(server.url("/admin/studies/emo/progress.json")).send().await.unwrap().status(), 401);
    assert_eq!(http.get(server.url("/api/v1/studies/emo/responses.csv")).send().await.unwrap().status(), 401);
    assert_eq!(http.get(server.url("/api/v1/studies/emo/responses.csv")).bearer_auth("fl_wrong").send().await.unwrap().status(), 401);
    let no_csrf = http.post(server.url("/admin/studies/emo/status")).header("cookie", &cookie).form(&[("status", "closed")]).send().await.unwrap();
    assert_eq!(no_csrf.status(), 403);
    let wrong = http.post(server.url("/admin/login")).form(&[("username", "alice"), ("password", "wrong password")]).send().await.unwrap();
    assert_eq!(wrong.status(), 401);

    // A token from the CLI opens the export API.
    let out = facslab_ok(lab.path(), &["admin", "token", "alice", "--study", "emo", "--db", &lab.db]);
    let api_token = String::from_utf8(out.stdout).unwrap().trim().to_string();
    let csv = http.get(server.url("/api/v1/studies/emo/responses.csv")).bearer_auth(&api_token).send().await.unwrap();
    assert_eq!(csv.status(), 200);
    assert_eq!(csv.text().await.unwrap(), "participant_id,group,stimulus_id,trial,measure,value,rt_ms\n");
}

#[tokio::test(flavor = "multi_thread")]
async fn study_attention_policy_screens_out_after_two_failures() {
    for backend in backends() {
        attention_policy_screens_out(&backend).await;
    }
}

async fn attention_policy_screens_out(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let checks = "[attention]\nmax_failures = 2\nchecks = [{ instruction = \"Choose Surprise.\", measure = \"emotion\", value = \"surprise\" }, { instruction = \"Choose None.\", measure = \"emotion\", value = \"none\" }]\n[recruitment]\nplatform = \"prolific\"\ncompletion_code = \"OK\"\nscreened_out_code = \"NOPE\"\n";
    let (_lab, server, http) = emotion_lab_on(backend, "att", checks);
    let token = start(&http, &server, "att", &[("PROLIFIC_PID", "0123456789abcdef01234567")]).await;
    consent_and_demographics(&http, &server, &token).await;
    let mut last = serde_json::Value::Null;
    while let Some(position) = current_position(&http, &server, &token).await {
        let (status, ack) = save(&http, &server, &token, position, &format!("attention-key-{position:06}"), &[("emotion", "anger"), ("believability", "3")]).await;
        assert_eq!(status, 200);
        last = ack;
    }
    assert_eq!(last["next"], format!("/p/{token}/done"));
    let done = http.get(server.url(&format!("/p/{token}/done"))).send().await.unwrap().text().await.unwrap();
    assert!(done.contains("cc=NOPE") && !done.contains("cc=OK"), "{done}");
    let cookie = admin_cookie(&http, &server).await;
    let progress: serde_json::Value = http.get(server.url("/admin/studies/att/progress.json")).header("cookie", &cookie).send().await.unwrap().json().await.unwrap();
    assert_eq!((progress["screened_out"].as_i64(), progress["completed"].as_i64()), (Some(1), Some(0)));
}

/// The Exp. 1 shape, small: three single AUs, each a video at 100 % and stills at 30/60/90 % on
/// one identity (identities rotating), at 64×64 and 10 fps.
pub const EXP1_SHAPE: &str = r#"
name = "exp1-small"
seed = 1001
size = [64, 64]
fps = 10

[[group]]
name = "single AUs"
expressions = ["1", "4", "R14"]
video_peaks = [1.0]
stills = [0.3, 0.6, 0.9]
timing = { onset_s = 0.3, apex_s = 0.2, offset_s = 0.3, ramp = "linear" }
identity = "rotate"
"#;

/// The manifest's rows as JSON objects.
fn manifest_rows(lab: &Lab) -> Vec<serde_json::Value> {
    serde_json::from_str(&std::fs::read_to_string(lab.path().join("set/manifest.json")).unwrap()).unwrap()
}

/// What a coder's trial of one entry shows: the video, then three stills by part, each served by
/// position and part only; a fourth part does not exist. Returns the page.
async fn entry_trial_page(http: &reqwest::Client, server: &Server, token: &str, position: i64, secrets: &[String]) -> String {
    let html = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap().text().await.unwrap();
    assert!(html.contains(&format!("<video id=\"stimulus\" class=\"stimulus\" aria-label=\"A moving face\" src=\"/p/{token}/media/{position}\"")), "{html}");
    assert!(html.contains("data-fps=\"10\"") && html.contains("id=\"step-forward\"") && html.contains("data-speed=\"0.25\""), "{html}");
    for part in 1..=3 {
        assert!(html.contains(&format!("src=\"/p/{token}/media/{position}/{part}\"")), "part {part} missing: {html}");
        let still = http.get(server.url(&format!("/p/{token}/media/{position}/{part}"))).send().await.unwrap();
        assert_eq!((still.status().as_u16(), still.headers()["content-type"].to_str().unwrap()), (200, "image/png"));
    }
    let video = http.get(server.url(&format!("/p/{token}/media/{position}"))).send().await.unwrap();
    assert_eq!(video.headers()["content-type"].to_str().unwrap(), "video/mp4");
    for missing in ["4", "0", "x"] {
        let r = http.get(server.url(&format!("/p/{token}/media/{position}/{missing}"))).send().await.unwrap();
        assert_eq!(r.status(), 404, "part {missing}");
    }
    for secret in secrets {
        assert!(!html.contains(secret.as_str()), "trial {position} reveals {secret}");
    }
    html
}

#[tokio::test(flavor = "multi_thread")]
async fn study_exp1_coder_codes_each_au_once_from_its_video_and_stills() {
    for backend in backends() {
        exp1_coder_codes_each_au_once(&backend).await;
    }
}

async fn exp1_coder_codes_each_au_once(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let lab = Lab::with_set_on(EXP1_SHAPE, backend);
    // The published template as it is, over the small set.
    lab.study("exp1", include_str!("../../studies/exp1-coders.toml"));
    let server = lab.serve();
    let http = client();
    let manifest = manifest_rows(&lab);
    assert_eq!(manifest.len(), 12);
    let secrets: Vec<String> = manifest.iter().flat_map(|r| ["stimulus_id", "expression", "file"].map(|k| r[k].as_str().unwrap().to_string())).collect();

    let token = start(&http, &server, "exp1", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let mut positions = Vec::new();
    while let Some(position) = current_position(&http, &server, &token).await {
        let html = entry_trial_page(&http, &server, &token, position, &secrets).await;
        // Every coder marks AU 1 (which also passes the check question).
        let body = serde_json::json!({
            "idempotency_key": format!("key-{token}-{position}"),
            "fields": [["au", "1"]],
            "rt_ms": 4000.0,
            "video_ended": true,
            "viewing": { "replays": position, "frame_steps": 3, "speeds": [1, 0.25], "time_on_task_ms": 3500.5 },
        });
        let r = http.post(server.url(&format!("/p/{token}/api/trial/{position}"))).json(&body).send().await.unwrap();
        assert_eq!(r.status(), 200, "{html}");
        positions.push(position);
    }
    // 1 practice + one trial per AU (not per medium) + 1 check question.
    assert_eq!(positions.len(), 1 + 3 + 1);

    let cookie = admin_cookie(&http, &server).await;
    let export = |file: &str| {
        let request = http.get(server.url(&format!("/admin/studies/exp1/export/{file}"))).header("cookie", &cookie);
        async move { request.send().await.unwrap().text().await.unwrap() }
    };
    check_entry_export(&manifest, &serde_json::from_str(&export("responses.json").await).unwrap());
    let csv = export("responses.csv").await;
    let coded: Vec<&str> = csv.lines().filter(|l| l.contains(",aus,")).collect();
    let videos: HashSet<String> = manifest.iter().filter(|r| r["media"] == "video").map(|r| r["stimulus_id"].as_str().unwrap().to_string()).collect();
    assert_eq!(coded.len(), 3, "{csv}");
    assert!(coded.iter().all(|l| videos.contains(l.split(',').nth(2).unwrap())), "judgements under the videos: {csv}");
    let wide = export("wide.csv").await;
    assert_eq!(wide.lines().next().unwrap().matches(":aus").count(), 3, "{wide}");
    // The dashboard's stimulus count is of trials: three AUs, not their twelve media.
    let progress = http.get(server.url("/admin/studies/exp1/progress.json")).header("cookie", &cookie).send().await.unwrap().text().await.unwrap();
    let progress: serde_json::Value = serde_json::from_str(&progress).unwrap();
    assert_eq!(progress["stimuli"], 3, "{progress}");
    let codebook = export("codebook.csv").await;
    for field in ["trials[].shown", "viewing.replays", "viewing.frame_steps", "viewing.speeds", "viewing.time_on_task_ms"] {
        assert!(codebook.contains(field), "{field} missing from the codebook:\n{codebook}");
    }

    // The analysis counts each AU once, with the video's ground truth: AU 1 is a hit once.
    std::fs::write(lab.path().join("responses.csv"), &csv).unwrap();
    facslab_ok(lab.path(), &["analyze", "--responses", "responses.csv", "--manifest", "set/manifest.csv", "-o", "report"]);
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(lab.path().join("report/report.json")).unwrap()).unwrap();
    assert_eq!(report["coding"]["stimuli"], 3, "{}", report["coding"]);
}

/// The JSON export of the Exp. 1 coder: every trial answered under its entry's video, `shown`
/// is that video and then the stills of the same face and AU by rising intensity, and the
/// viewing report is kept as sent.
fn check_entry_export(manifest: &[serde_json::Value], json: &serde_json::Value) {
    let by_id: BTreeMap<&str, &serde_json::Value> = manifest.iter().map(|r| (r["stimulus_id"].as_str().unwrap(), r)).collect();
    let trials = json["participants"][0]["trials"].as_array().unwrap();
    assert_eq!(trials.len(), 5, "{json}");
    for t in trials {
        let shown: Vec<&serde_json::Value> = t["shown"].as_array().unwrap().iter().map(|id| by_id[id.as_str().unwrap()]).collect();
        assert_eq!(t["stimulus_id"], shown[0]["stimulus_id"], "{t}");
        assert_eq!(shown.iter().map(|r| r["media"].as_str().unwrap()).collect::<Vec<_>>(), ["video", "image", "image", "image"], "{t}");
        assert_eq!(shown.iter().map(|r| r["intensity"].as_f64().unwrap()).collect::<Vec<_>>(), [1.0, 0.3, 0.6, 0.9], "{t}");
        let au = |r: &serde_json::Value| r["expression"].as_str().unwrap().split('@').next().unwrap().to_string();
        assert!(shown.iter().all(|r| r["identity"] == shown[0]["identity"] && au(r) == au(shown[0])), "one entry: {t}");
        let replays = t["trial"].as_i64().unwrap() - 1;
        assert_eq!(t["viewing"], serde_json::json!({ "replays": replays, "frame_steps": 3, "speeds": [1.0, 0.25], "time_on_task_ms": 3500.5 }), "{t}");
    }
}
