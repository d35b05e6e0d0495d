//! The study server's edge, tried as an attacker and as a participant would: each test tells
//! one story against the real `facslab serve` process and its SQLite file.

use crate::backends::{Backend, backends};
use crate::server::*;

/// An MTurk study over the tiny set.
fn mturk() -> String {
    "[recruitment]\nplatform = \"mturk\"\ncompletion_code = \"SECRET77\"\n".into()
}

const WORKER: &str = "A1B2C3D4E5F6G7";

/// Starts from a browser holding `cookie` (if any); returns the response.
async fn start_from(http: &reqwest::Client, server: &Server, slug: &str, cookie: Option<&str>, form: &[(&str, &str)]) -> reqwest::Response {
    let mut request = http.post(server.url(&format!("/s/{slug}/start"))).form(form);
    if let Some(cookie) = cookie {
        request = request.header("cookie", cookie);
    }
    request.send().await.unwrap()
}

/// The `name=value` part of a response's `Set-Cookie`.
fn set_cookie(response: &reqwest::Response) -> String {
    response.headers().get("set-cookie").map(|c| c.to_str().unwrap().split(';').next().unwrap().to_string()).unwrap_or_default()
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_a_stranger_with_a_known_worker_id_does_not_take_over_the_participation() {
    let (_lab, server, http) = emotion_lab("emo", &mturk());
    let entry = [("workerId", WORKER), ("assignmentId", "ASSIGN-VICTIM"), ("hitId", "HIT1"), ("turkSubmitTo", "https://www.mturk.com")];
    let victim = start_from(&http, &server, "emo", None, &entry).await;
    assert_eq!(victim.status(), 303);
    let token = location(&victim).rsplit('/').next().unwrap().to_string();
    let victim_cookie = set_cookie(&victim);
    consent_and_demographics(&http, &server, &token).await;

    // A stranger knows the worker id, and tries it as typed and in every spelling that reads the same.
    let fullwidth: String = WORKER.chars().map(|c| char::from_u32(c as u32 + 0xFEE0).unwrap()).collect();
    let variants = [WORKER.to_string(), WORKER.to_lowercase(), format!(" {WORKER}\u{a0}"), format!("\u{200b}{WORKER}\u{feff}"), "A1B2C3\u{200d}D4E5F6G7".to_string(), fullwidth];
    for variant in &variants {
        for cookie in [None, Some("facslab_emo=0123456789abcdef0123456789abcdef"), Some("facslab_other=1")] {
            let r = start_from(&http, &server, "emo", cookie, &[("workerId", variant), ("assignmentId", "ASSIGN-STRANGER")]).await;
            assert_eq!(r.status(), 409, "{variant:?} with {cookie:?}");
            assert!(location(&r).is_empty() && set_cookie(&r).is_empty());
            let page = r.text().await.unwrap();
            assert!(!page.contains(&token) && !page.contains("ASSIGN-VICTIM") && !page.contains("SECRET77"));
            assert!(page.contains("started this study in another browser") && page.contains("open the study link again in the browser where you started it"), "{page}");
        }
    }
    // Ids that are not MTurk worker ids are refused before anything is made.
    for bad in ["not-an-id", "B1B2C3D4E5F6G7", ""] {
        let r = start_from(&http, &server, "emo", None, &[("workerId", bad)]).await;
        assert_eq!(r.status(), 400, "{bad:?}");
    }

    // The victim's own browser goes on where it was.
    let again = start_from(&http, &server, "emo", Some(&victim_cookie), &[("workerId", &WORKER.to_lowercase())]).await;
    assert_eq!(location(&again), format!("/p/{token}"));
    let cookie = admin_cookie(&http, &server).await;
    let progress: serde_json::Value = http.get(server.url("/admin/studies/emo/progress.json")).header("cookie", &cookie).send().await.unwrap().json().await.unwrap();
    assert_eq!((progress["active"].as_i64(), progress["reserved"].as_i64()), (Some(1), Some(0)), "one participation: {progress}");
}

/// The answer stored for trial `position` of the only participant, from the JSON export.
async fn stored_answers(http: &reqwest::Client, server: &Server, slug: &str) -> serde_json::Value {
    let cookie = admin_cookie(http, server).await;
    let url = server.url(&format!("/admin/studies/{slug}/export/responses.json?scope=all"));
    http.get(url).header("cookie", &cookie).send().await.unwrap().json().await.unwrap()
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_an_idempotency_key_reused_with_another_answer_gets_409_and_the_first_answer_stays() {
    for backend in backends() {
        a_reused_idempotency_key_gets_409(&backend).await;
    }
}

async fn a_reused_idempotency_key_gets_409(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let (_lab, server, http) = emotion_lab_on(backend, "emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let position = current_position(&http, &server, &token).await.unwrap();
    let key = "the-one-key-of-this-trial";
    let first = save(&http, &server, &token, position, key, &[("emotion", "fear"), ("believability", "2")]).await;
    assert_eq!((first.0, first.1["saved"].as_str()), (200, Some("stored")));
    // A retry of the same answer is acknowledged as repeated.
    let retry = save(&http, &server, &token, position, key, &[("emotion", "fear"), ("believability", "2")]).await;
    assert_eq!((retry.0, retry.1["saved"].as_str()), (200, Some("repeated")));
    // The same key with another answer is refused, and says so.
    for other in [[("emotion", "anger"), ("believability", "2")], [("emotion", "fear"), ("believability", "5")]] {
        let (status, body) = save(&http, &server, &token, position, key, &other).await;
        assert_eq!(status, 409, "{body}");
        assert!(body["error"].as_str().unwrap().contains("another answer"), "{body}");
    }
    let export = stored_answers(&http, &server, "emo").await;
    let trial = &export["participants"][0]["trials"][0];
    assert_eq!((trial["trial"].as_i64(), &trial["answers"]), (Some(position + 1), &serde_json::json!([["emotion", "fear"], ["believability", "2"]])));
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_demographics_are_written_once_and_a_later_post_never_wipes_them() {
    for backend in backends() {
        demographics_are_written_once(&backend).await;
    }
}

async fn demographics_are_written_once(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let (_lab, server, http) = emotion_lab_on(backend, "emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    for later in [vec![], vec![("age", "71"), ("gender", "male")]] {
        let r = http.post(server.url(&format!("/p/{token}/demographics"))).form(&later).send().await.unwrap();
        assert_eq!(r.status(), 409, "{later:?}");
        assert!(r.text().await.unwrap().contains("saved already"));
    }
    let position = current_position(&http, &server, &token).await.unwrap();
    save(&http, &server, &token, position, "demographics-key-1", &[("emotion", "fear"), ("believability", "2")]).await;
    let export = stored_answers(&http, &server, "emo").await;
    let about = &export["participants"][0]["demographics"];
    assert_eq!((about["age"].as_i64(), about["gender"].as_str(), about["education"].as_str()), (Some(34), Some("female"), Some("doctorate")), "{export}");
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_saves_and_media_wait_for_the_steps_before_them() {
    let (_lab, server, http) = emotion_lab("emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    let media = |position: i64| http.get(server.url(&format!("/p/{token}/media/{position}"))).send();
    let answer = [("emotion", "fear"), ("believability", "2")];
    // Before consent: no save, no media (the plan cannot be fetched ahead).
    assert_eq!(save(&http, &server, &token, 0, "too-early-key-0001", &answer).await.0, 409);
    assert_eq!(media(0).await.unwrap().status(), 404);
    let r = http.post(server.url(&format!("/p/{token}/consent"))).form(&[("agree", "1")]).send().await.unwrap();
    assert_eq!(r.status(), 303);
    // Consent given, the design's demographics not yet: still refused.
    let (status, body) = save(&http, &server, &token, 0, "too-early-key-0002", &answer).await;
    assert_eq!(status, 409, "{body}");
    assert!(body["error"].as_str().unwrap().contains("questions about you"), "{body}");
    assert_eq!(media(0).await.unwrap().status(), 404);
    let r = http.post(server.url(&format!("/p/{token}/demographics"))).form(&[("age", "30")]).send().await.unwrap();
    assert_eq!(r.status(), 303);
    // At the trials: the current trial and the next two may load, later ones not yet.
    let position = current_position(&http, &server, &token).await.unwrap();
    for ahead in 0..=2 {
        assert_eq!(media(position + ahead).await.unwrap().status(), 200, "trial {}", position + ahead);
    }
    assert_eq!(media(position + 3).await.unwrap().status(), 404);
    assert_eq!(save(&http, &server, &token, position, "in-time-key-00001", &answer).await.0, 200);
    assert_eq!(media(position + 3).await.unwrap().status(), 200, "one trial on, one more may load");
    assert_eq!(media(position).await.unwrap().status(), 200, "an answered trial's face stays reachable");
}

/// A video element seeks with byte ranges, and a browser revalidates what it holds: the media
/// route answers both, with the stimulus's type and the edge's headers.
#[tokio::test(flavor = "multi_thread")]
async fn edge_media_answer_byte_ranges_and_revalidation() {
    let (lab, server, http) = emotion_lab("emo", "");
    // Each stimulus file gets a different old time, as a build in spec order would give them.
    let media: Vec<_> = std::fs::read_dir(lab.path().join("set/media")).unwrap().map(|e| e.unwrap().path()).collect();
    let old_dates: Vec<String> = (0..media.len())
        .map(|i| {
            let when = std::time::SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(978_307_200 + 86_400 * i as u64);
            std::fs::File::options().write(true).open(&media[i]).unwrap().set_modified(when).unwrap();
            httpdate::fmt_http_date(when)
        })
        .collect();
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let mut times_sent = Vec::new();
    let (url, video, last_modified) = loop {
        let position = current_position(&http, &server, &token).await.expect("the video comes before the end");
        let url = server.url(&format!("/p/{token}/media/{position}"));
        let whole = http.get(&url).send().await.unwrap();
        assert_eq!(whole.status(), 200);
        let header = |name: &str| whole.headers().get(name).map(|v| v.to_str().unwrap().to_string()).unwrap_or_default();
        let (content_type, last_modified) = (header("content-type"), header("last-modified"));
        assert_eq!((header("cache-control").as_str(), header("x-content-type-options").as_str(), header("accept-ranges").as_str()), ("private, max-age=3600", "nosniff", "bytes"));
        assert!(header("content-security-policy").contains("default-src 'self'"));
        times_sent.push(last_modified.clone());
        let bytes = whole.bytes().await.unwrap();
        if content_type == "video/mp4" {
            // One more stimulus to compare times with: an earlier trial's, or the next one's (which
            // may be preloaded) when the video is the first trial.
            let other = if position > 0 { position - 1 } else { position + 1 };
            let other = http.get(server.url(&format!("/p/{token}/media/{other}"))).send().await.unwrap();
            assert_eq!(other.status(), 200);
            times_sent.push(other.headers()["last-modified"].to_str().unwrap().to_string());
            break (url, bytes, last_modified);
        }
        assert_eq!(content_type, "image/png");
        let key = format!("range-test-key-{position:04}");
        assert_eq!(save(&http, &server, &token, position, &key, &[("emotion", "fear"), ("believability", "2")]).await.0, 200);
    };
    let len = video.len();
    assert!(len > 100 && video.get(4..8) == Some(&b"ftyp"[..]));
    for (range, start, end) in [("bytes=0-99", 0, 99), ("bytes=100-", 100, len - 1), ("bytes=-10", len - 10, len - 1)] {
        let r = http.get(&url).header("range", range).send().await.unwrap();
        assert_eq!(r.status(), 206, "{range}");
        assert_eq!(r.headers()["content-range"].to_str().unwrap(), format!("bytes {start}-{end}/{len}"), "{range}");
        assert_eq!(r.headers()["content-type"], "video/mp4");
        assert_eq!(r.bytes().await.unwrap(), video[start..=end], "{range}");
    }
    let past = http.get(&url).header("range", format!("bytes={}-{}", len + 5, len + 9)).send().await.unwrap();
    assert_eq!(past.status(), 416);
    assert_eq!(past.headers()["content-range"].to_str().unwrap(), format!("bytes */{len}"));
    assert!(!last_modified.is_empty(), "a time to revalidate against is sent");
    // ... and it is the same for every stimulus, never a file's own time (which would tell the
    // order the set was built in).
    assert!(times_sent.len() >= 2 && times_sent.iter().all(|t| *t == last_modified), "{times_sent:?}");
    assert!(media.len() >= 2);
    assert!(!old_dates.contains(&last_modified), "{last_modified} is a file's own time");
    let again = http.get(&url).header("if-modified-since", &last_modified).send().await.unwrap();
    assert_eq!(again.status(), 304);
    assert!(again.bytes().await.unwrap().is_empty());
}

/// Every byte of the database (the file and its write-ahead log).
fn database_bytes(lab: &Lab) -> Vec<u8> {
    let mut bytes = std::fs::read(lab.path().join("lab.db")).unwrap();
    bytes.extend(std::fs::read(lab.path().join("lab.db-wal")).unwrap_or_default());
    bytes
}

fn contains(haystack: &[u8], needle: &str) -> bool {
    haystack.windows(needle.len()).any(|w| w == needle.as_bytes())
}

/// The CSRF token in an admin page.
fn csrf_in(html: &str) -> String {
    let marker = "name=\"csrf\" value=\"";
    let at = html.find(marker).expect("a form with a CSRF token") + marker.len();
    html[at..].split('"').next().unwrap().to_string()
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_tokens_are_not_in_the_database_in_clear() {
    let (lab, server, http) = emotion_lab("emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let cookie = admin_cookie(&http, &server).await;
    let session = cookie.split_once('=').unwrap().1.to_string();
    let page = http.get(server.url("/admin/studies/emo")).header("cookie", &cookie).send().await.unwrap().text().await.unwrap();
    let csrf = csrf_in(&page);
    let out = crate::cli::facslab_ok(lab.path(), &["admin", "token", "alice", "--study", "emo", "--db", "lab.db"]);
    let api = String::from_utf8(out.stdout).unwrap().trim().to_string();
    // Each secret works...
    assert_eq!(http.get(server.url(&format!("/p/{token}"))).send().await.unwrap().status(), 303);
    let r = http.post(server.url("/admin/studies/emo/status")).header("cookie", &cookie).form(&[("csrf", csrf.as_str()), ("status", "open")]).send().await.unwrap();
    assert_eq!(r.status(), 303);
    assert_eq!(http.get(server.url("/api/v1/studies/emo/responses.csv")).bearer_auth(&api).send().await.unwrap().status(), 200);
    // ...and none is in the database, only SHA-256 digests.
    let bytes = database_bytes(&lab);
    for (name, secret) in [("participation token", &token), ("admin session", &session), ("CSRF token", &csrf), ("API token", &api)] {
        assert!(secret.len() >= 32, "{name}: {secret}");
        assert!(!contains(&bytes, secret), "the {name} is stored in clear");
    }
    assert!(contains(&bytes, &facslab::db::token_sha256(&token)), "the participation is found by its token's SHA-256");
    // A CSRF token that differs in its last character is refused.
    let mut forged = csrf.clone();
    let last = if forged.ends_with('0') { "1" } else { "0" };
    forged.replace_range(forged.len() - 1.., last);
    let r = http.post(server.url("/admin/studies/emo/status")).header("cookie", &cookie).form(&[("csrf", forged.as_str()), ("status", "closed")]).send().await.unwrap();
    assert_eq!(r.status(), 403);
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_a_posted_study_status_that_is_not_one_of_them_gets_422_naming_the_field() {
    let (_lab, server, http) = emotion_lab("emo", "");
    let cookie = admin_cookie(&http, &server).await;
    let page = http.get(server.url("/admin/studies/emo")).header("cookie", &cookie).send().await.unwrap().text().await.unwrap();
    let csrf = csrf_in(&page);
    for bad in ["paused", "Open", ""] {
        let r = http.post(server.url("/admin/studies/emo/status")).header("cookie", &cookie).form(&[("csrf", csrf.as_str()), ("status", bad)]).send().await.unwrap();
        assert_eq!(r.status(), 422, "{bad:?}");
        let body = r.text().await.unwrap();
        assert!(body.contains(&format!("status: &quot;{bad}&quot; is not one of draft, open, closed")), "{body}");
    }
    let landing = http.get(server.url("/s/emo")).send().await.unwrap().text().await.unwrap();
    assert!(!landing.contains("not open at the moment"), "the study stays open");
    let r = http.post(server.url("/admin/studies/emo/status")).header("cookie", &cookie).form(&[("csrf", csrf.as_str()), ("status", "closed")]).send().await.unwrap();
    assert_eq!(r.status(), 303);
    let landing = http.get(server.url("/s/emo")).send().await.unwrap().text().await.unwrap();
    assert!(landing.contains("not open at the moment"), "{landing}");
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_a_viewer_token_is_refused_on_another_study_and_after_it_expires() {
    let (lab, server, http) = emotion_lab("emo", "");
    lab.study("other", &emotion_design("other", ""));
    let out = crate::cli::facslab_ok(lab.path(), &["admin", "token", "alice", "--study", "emo", "--role", "viewer", "--days", "7", "--db", "lab.db"]);
    let api = String::from_utf8(out.stdout).unwrap().trim().to_string();
    let get = |slug: &str| http.get(server.url(&format!("/api/v1/studies/{slug}/responses.csv"))).bearer_auth(&api).send();
    assert_eq!(get("emo").await.unwrap().status(), 200);
    let other = get("other").await.unwrap();
    assert_eq!(other.status(), 403);
    assert!(!other.text().await.unwrap().contains("participant_id"));
    // Bounds on making tokens: a lifetime over a year, an admin role.
    for bad in [&["--days", "400"][..], &["--role", "admin"][..]] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_facslab"))
            .args(["admin", "token", "alice", "--study", "emo", "--db", "lab.db"])
            .args(bad)
            .current_dir(lab.path())
            .output()
            .unwrap();
        assert!(!out.status.success(), "{bad:?} was accepted");
    }
    // The token's expiry passes (moved into the past in the database): refused.
    let pool = sqlx::SqlitePool::connect(&format!("sqlite:{}", lab.path().join("lab.db").display())).await.unwrap();
    sqlx::query("UPDATE api_tokens SET expires_at = 0").execute(&pool).await.unwrap();
    pool.close().await;
    assert_eq!(get("emo").await.unwrap().status(), 401);
}

async fn login(http: &reqwest::Client, server: &Server, user: &str, password: &str) -> reqwest::Response {
    http.post(server.url("/admin/login")).form(&[("username", user), ("password", password)]).send().await.unwrap()
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_repeated_wrong_passwords_get_429_even_with_the_right_password_after() {
    let (_lab, server, http) = emotion_lab("emo", "");
    for attempt in 0..5 {
        assert_eq!(login(&http, &server, "alice", &format!("guess number {attempt}")).await.status(), 401);
    }
    let locked = login(&http, &server, "alice", "guess number 6").await;
    assert_eq!(locked.status(), 429);
    let wait: u64 = locked.headers()["retry-after"].to_str().unwrap().parse().unwrap();
    assert!((60..=900).contains(&wait), "Retry-After {wait}");
    // The right password does not get in while the account is locked (so guessing on is useless).
    let right = login(&http, &server, "alice", ADMIN_PASSWORD).await;
    assert_eq!(right.status(), 429);
    assert!(right.headers().get("set-cookie").is_none());
    // Guessing across many accounts from one address is limited too.
    let mut statuses = Vec::new();
    for n in 0..20 {
        statuses.push(login(&http, &server, &format!("user{n}"), "a wrong password").await.status().as_u16());
    }
    // Twenty attempts per address: five, and two refused, for alice; thirteen more.
    assert_eq!(statuses.iter().filter(|s| **s == 401).count(), 13, "{statuses:?}");
    assert_eq!(*statuses.last().unwrap(), 429);
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_a_login_flood_does_not_slow_other_requests() {
    let (_lab, server, http) = emotion_lab("emo", "");
    let flood: Vec<_> = (0..60)
        .map(|n| {
            let (http, url) = (http.clone(), server.url("/admin/login"));
            tokio::spawn(async move { http.post(url).form(&[("username", format!("nobody{n}")), ("password", "wrong password!".into())]).send().await.map(|r| r.status().as_u16()) })
        })
        .collect();
    let mut health = Vec::new();
    for _ in 0..40 {
        let at = std::time::Instant::now();
        assert_eq!(http.get(server.url("/health")).send().await.unwrap().status(), 200);
        health.push(at.elapsed());
        tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    }
    let statuses: Vec<u16> = futures_util_join(flood).await;
    health.sort();
    let p50 = health[health.len() / 2];
    assert!(p50 < std::time::Duration::from_millis(20), "/health p50 {p50:?} during the flood");
    assert!(statuses.iter().all(|s| [401, 429, 503].contains(s)), "{statuses:?}");
    assert!(statuses.contains(&429), "the flood is cut off: {statuses:?}");
}

async fn futures_util_join(tasks: Vec<tokio::task::JoinHandle<reqwest::Result<u16>>>) -> Vec<u16> {
    let mut out = Vec::new();
    for task in tasks {
        out.push(task.await.unwrap().unwrap());
    }
    out
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_behind_https_cookies_are_secure_and_hsts_is_sent() {
    let lab = Lab::new();
    lab.study("emo", &emotion_design("emo", ""));
    let http = client();
    let plain = lab.serve();
    let r = plain.url("/health");
    assert!(http.get(r).send().await.unwrap().headers().get("strict-transport-security").is_none());
    drop(plain);
    let server = Server::start_with(lab.path().join("lab.db"), &["--public-url", "https://faces.example.org"]);
    let health = http.get(server.url("/health")).send().await.unwrap();
    assert!(health.headers()["strict-transport-security"].to_str().unwrap().starts_with("max-age=31536000"));
    let r = http.post(server.url("/s/emo/start")).form(&[("x", "1")]).send().await.unwrap();
    assert_eq!(r.status(), 303);
    let participant = r.headers()["set-cookie"].to_str().unwrap().to_string();
    let r = login(&http, &server, "alice", ADMIN_PASSWORD).await;
    let admin = r.headers()["set-cookie"].to_str().unwrap().to_string();
    for cookie in [&participant, &admin] {
        assert!(cookie.contains("; Secure") && cookie.contains("HttpOnly"), "{cookie}");
    }
    let refused = std::process::Command::new(env!("CARGO_BIN_EXE_facslab")).args(["serve", "--port", "0", "--public-url", "ftp://x", "--db", "x.db"]).current_dir(lab.path()).output().unwrap();
    assert!(!refused.status.success());
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_a_flood_of_starts_is_bounded() {
    // One reservation fills this study: every participant sees all seven faces once.
    let lab = Lab::new();
    lab.study("emo", &emotion_design("emo", "").replace("practice_trials = 1", "practice_trials = 1\ntrials_per_participant = 7\nratings_per_stimulus = 1"));
    let server = lab.serve();
    let http = client();
    let mut statuses = Vec::new();
    for _ in 0..200 {
        let r = http.post(server.url("/s/emo/start")).form(&[("x", "1")]).send().await.unwrap();
        if r.status() == 429 {
            assert!(r.headers().get("retry-after").is_some());
        }
        statuses.push(r.status().as_u16());
    }
    let accepted = statuses.iter().filter(|s| **s != 429).count();
    assert_eq!(accepted, 30, "starts per address in five minutes: {statuses:?}");
    // The first start took the only place; reservations never consented hold it for at most ten minutes.
    let pool = sqlx::SqlitePool::connect(&format!("sqlite:{}", lab.path().join("lab.db").display())).await.unwrap();
    let reserved: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM participants WHERE state = 'reserved'").fetch_one(&pool).await.unwrap();
    assert_eq!(reserved, 1, "the others found the study full");
    drop(server);
    sqlx::query("UPDATE participants SET created_at = created_at - 11 * 60000").execute(&pool).await.unwrap();
    pool.close().await;
    let server = lab.serve();
    let r = http.post(server.url("/s/emo/start")).form(&[("x", "1")]).send().await.unwrap();
    assert_eq!(r.status(), 303, "eleven minutes on, the unconsented reservation no longer holds the place");
}

#[test]
fn edge_a_huge_video_is_refused_at_once_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let timeline = r#"{"duration_s": 1e12, "tracks": [{"au": 12, "start_intensity": 0, "end_intensity": 1, "start_s": 0, "end_s": 1}]}"#;
    std::fs::write(dir.path().join("long.json"), timeline).unwrap();
    let long_expression = ["1"; 30_000].join("+");
    let cases: [&[&str]; 5] = [
        &["render", "12", "--video", "--onset", "1e9", "-o", "out.mp4"],
        &["render", "12", "--video", "--apex", "1e300", "-o", "out.mp4"],
        &["render", "12", "--video", "--onset", "200", "--apex", "200", "-o", "out.mp4"],
        &["render", "--timeline", "long.json", "-o", "out.mp4"],
        &["render", &long_expression, "-o", "out.png"],
    ];
    for args in cases {
        let at = std::time::Instant::now();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_facslab")).args(args).current_dir(dir.path()).output().unwrap();
        let took = at.elapsed();
        let message = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(!out.status.success(), "{:?} was accepted", &args[..3]);
        assert!(took < std::time::Duration::from_secs(1), "{:?} took {took:?}", &args[..3]);
        assert!(message.len() < 300, "the message quotes a short excerpt only: {} bytes", message.len());
        let written: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).filter(|n| n != "long.json").collect();
        assert!(written.is_empty(), "{written:?}");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_an_oversized_answer_is_refused_quoting_a_short_excerpt() {
    let (lab, server, http) = emotion_lab("emo", "");
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let position = current_position(&http, &server, &token).await.unwrap();
    let huge = "j".repeat(50_000);
    for fields in [[("emotion", huge.as_str()), ("believability", "2")], [("emotion", "fear"), (huge.as_str(), "2")]] {
        let (status, body) = save(&http, &server, &token, position, "oversized-answer-1", &fields).await;
        assert_eq!(status, 422);
        assert!(body.to_string().len() < 400, "the error quotes {} bytes", body.to_string().len());
    }
    // A design with an over-long slug is refused by the CLI with a short message.
    std::fs::write(lab.path().join("long.toml"), emotion_design(&"x".repeat(5_000), "")).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_facslab")).args(["study", "check", "long.toml"]).current_dir(lab.path()).output().unwrap();
    assert!(!out.status.success());
    assert!(out.stderr.len() < 300, "{} bytes", out.stderr.len());
}

/// The attacker's story: a participant renders the public re-render of every stimulus (the set's
/// own expressions, people and timelines) and compares it with what the study serves; nothing
/// matches. And no URL reaches the set's `dither.key`, not even through a crafted manifest.
#[tokio::test(flavor = "multi_thread")]
async fn edge_served_media_differ_from_a_public_re_render_and_the_dither_key_is_never_served() {
    let (lab, server, http) = emotion_lab("emo", "");
    let set = lab.path().join("set");
    let rows: Vec<facslab::stimuli::ManifestRow> = serde_json::from_str(&std::fs::read_to_string(set.join("manifest.json")).unwrap()).unwrap();
    let public: Vec<Vec<u8>> = rows.iter().enumerate().map(|(n, row)| crate::stimuli::public_render(lab.path(), &set, row, &format!("public{n}"))).collect();
    let set_files: Vec<Vec<u8>> = rows.iter().map(|row| std::fs::read(set.join(&row.file)).unwrap()).collect();

    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let mut served = Vec::new();
    while let Some(position) = current_position(&http, &server, &token).await {
        let r = http.get(server.url(&format!("/p/{token}/media/{position}"))).send().await.unwrap();
        assert_eq!(r.status(), 200, "trial {position}");
        served.push(r.bytes().await.unwrap().to_vec());
        let key = format!("attacker-trial-{position:04}");
        assert_eq!(save(&http, &server, &token, position, &key, &[("emotion", "fear"), ("believability", "2")]).await.0, 200);
        assert!(served.len() <= 20, "the study never ends");
    }
    assert!(served.len() >= rows.len(), "every stimulus was shown: {} trials", served.len());
    for (n, bytes) in served.iter().enumerate() {
        assert!(set_files.contains(bytes), "trial {n} served a file that is not one of the set's media");
        assert!(!public.contains(bytes), "trial {n} served the bytes of a public re-render");
    }
    let videos = rows.iter().filter(|r| r.media == facslab::stimuli::Media::Video).count();
    assert!(videos > 0 && served.iter().any(|b| b.get(4..8) == Some(&b"ftyp"[..])), "a video was among the served media");

    // The key file is in the set directory, and no URL hands it out.
    let key = std::fs::read_to_string(set.join("dither.key")).unwrap().trim().to_string();
    assert_eq!(key.len(), 64);
    let cookie = admin_cookie(&http, &server).await;
    let paths = [
        "/dither.key".to_string(),
        "/set/dither.key".into(),
        "/s/emo/dither.key".into(),
        format!("/p/{token}/dither.key"),
        format!("/p/{token}/media/dither.key"),
        format!("/p/{token}/media/..%2Fdither.key"),
        format!("/p/{token}/media/%2e%2e/%2e%2e/set/dither.key"),
        format!("/p/{token}/media/-1"),
        format!("/p/{token}/media/99"),
        "/assets/dither.key".into(),
        "/assets/..%2F..%2Fset%2Fdither.key".into(),
        "/admin/dither.key".into(),
        "/admin/studies/emo/dither.key".into(),
        "/api/v1/studies/emo/dither.key".into(),
    ];
    for path in &paths {
        for with_cookie in [false, true] {
            let mut request = http.get(server.url(path));
            if with_cookie {
                request = request.header("cookie", &cookie);
            }
            let r = request.send().await.unwrap();
            let status = r.status();
            let body = r.text().await.unwrap_or_default();
            assert!(!body.contains(&key), "{path} hands out the dither key");
            assert!(status.is_client_error() || status.is_redirection(), "{path}: {status}");
        }
    }

    // A crafted manifest pointing a stimulus at the key (or anything outside media/) makes no study.
    for crafted_file in ["dither.key", "media/../dither.key", "posters/../dither.key"] {
        let crafted = lab.path().join("crafted");
        let _ = std::fs::remove_dir_all(&crafted);
        std::fs::create_dir_all(crafted.join("media")).unwrap();
        std::fs::copy(set.join("dither.key"), crafted.join("dither.key")).unwrap();
        let mut rows = rows.clone();
        for row in &rows {
            std::fs::copy(set.join(&row.file), crafted.join(&row.file)).unwrap();
        }
        rows[0].file = crafted_file.to_string();
        std::fs::write(crafted.join("manifest.json"), facslab::stimuli::manifest::to_json(&rows)).unwrap();
        std::fs::write(lab.path().join("crafted.toml"), emotion_design("crafted", "")).unwrap();
        let out = crate::cli::facslab(lab.path(), &["study", "create", "crafted.toml", "--set", "crafted", "--db", "lab.db", "--open"]);
        assert!(!out.status.success(), "{crafted_file}: a study was made");
        let err = crate::cli::stderr(&out);
        assert!(err.contains("is not in the set's media/ directory"), "{crafted_file}: {err}");
    }
}

/// Waits until the server's log has a line containing `needle` (log lines are written after
/// the response); returns that line.
async fn log_line(server: &Server, needle: &str) -> String {
    for _ in 0..100 {
        if let Some(line) = server.log().lines().find(|l| l.contains(needle)) {
            return line.to_string();
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    panic!("no log line with {needle:?} in:\n{}", server.log());
}

#[tokio::test(flavor = "multi_thread")]
async fn edge_the_log_has_route_status_and_latency_of_each_request_and_never_a_secret() {
    let lab = Lab::new();
    lab.study("emo", &emotion_design("emo", ""));
    let server = Server::start_logged(lab.path().join("lab.db"), None);
    let http = client();
    let token = start(&http, &server, "emo", &[]).await;
    consent_and_demographics(&http, &server, &token).await;
    let r = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap();
    assert_eq!(r.status(), 200);
    let id = r.headers()["x-request-id"].to_str().unwrap().to_string();
    let line = log_line(&server, &id).await;
    assert!(line.contains("INFO") && line.contains("method=GET") && line.contains("route=/p/{token}/trial") && line.contains("status=200"), "{line}");
    let latency: f64 = line.split("latency_ms=").nth(1).and_then(|rest| rest.split_whitespace().next()).and_then(|ms| ms.parse().ok()).expect(&line);
    assert!((0.0..10_000.0).contains(&latency), "{line}");
    // A path that matches no route, and a client's own request id, which is kept.
    let r = http.get(server.url(&format!("/p/{token}/nothing/here?token={token}"))).header("x-request-id", "client-chosen-id-1").send().await.unwrap();
    assert_eq!((r.status().as_u16(), r.headers()["x-request-id"].to_str().unwrap()), (404, "client-chosen-id-1"));
    let missing = log_line(&server, "client-chosen-id-1").await;
    assert!(missing.contains("status=404"), "{missing}");
    // Admin secrets stay out too.
    let cookie = admin_cookie(&http, &server).await;
    let session = cookie.split_once('=').unwrap().1.to_string();
    let r = http.get(server.url("/admin/studies/emo")).header("cookie", &cookie).send().await.unwrap();
    let admin_id = r.headers()["x-request-id"].to_str().unwrap().to_string();
    let csrf = csrf_in(&r.text().await.unwrap());
    assert!(log_line(&server, &admin_id).await.contains("route=/admin/studies/{slug}"));
    let log = server.log();
    for (name, secret) in [("participation token", &token), ("admin session", &session), ("CSRF token", &csrf)] {
        assert!(!log.contains(secret.as_str()), "the {name} is in the log:\n{log}");
    }
    assert!(log.lines().filter(|l| l.contains("status=")).count() >= 6, "{log}");

    // RUST_LOG chooses what is logged: warnings only leave the request lines out.
    drop(server);
    let quiet = Server::start_logged(lab.path().join("lab.db"), Some("facslab=warn"));
    assert_eq!(http.get(quiet.url("/health")).send().await.unwrap().status(), 200);
    tokio::time::sleep(std::time::Duration::from_millis(300)).await;
    assert!(!quiet.log().contains("status="), "{}", quiet.log());
}
