//! Helpers for the study-platform tests: a small built stimulus set, a study database (SQLite
//! or PostgreSQL, [`crate::backends`]) with studies and an admin, and the real `facslab serve`
//! process on a loopback port.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};

use crate::backends::{Backend, TestDb};
use crate::cli::facslab_ok;

/// Six emotion stills and one short video at 64×64 (fast to build).
pub const TINY_SET: &str = r#"
name = "tiny"
seed = 7
size = [64, 64]
fps = 10

[[group]]
name = "stills"
emotions = ["happiness", "sadness", "surprise", "anger", "fear", "disgust"]
stills = [1.0]

[[group]]
name = "video"
emotions = ["surprise"]
video_peaks = [1.0]
timing = { onset_s = 0.3, apex_s = 0.3, offset_s = 0.3 }
"#;

pub const ADMIN_PASSWORD: &str = "correct horse battery";

/// An emotion study over the tiny set (`extra` is appended to the design).
pub fn emotion_design(slug: &str, extra: &str) -> String {
    format!(
        r#"slug = "{slug}"
title = "Emotion test"
task = "emotion"
group = "raters"
stimuli = "set"
practice_trials = 1
consent = "I agree to take part."
instructions = "Choose the emotion."
debrief = "Thanks."
[emotion]
believability = true
{extra}"#
    )
}

/// A temporary lab: a stimulus set (the tiny one unless told) built in `dir/set`, a study
/// database with an admin (`dir/lab.db`, or a PostgreSQL database of its own).
pub struct Lab {
    /// The database, as `--db` takes it.
    pub db: String,
    /// Declared before `dir`: a PostgreSQL database is dropped before the directory goes.
    _store: TestDb,
    pub dir: tempfile::TempDir,
}

impl Lab {
    pub fn new() -> Lab {
        Lab::with_set(TINY_SET)
    }

    /// A lab with the tiny set on `backend`.
    pub fn on(backend: &Backend) -> Lab {
        Lab::with_set_on(TINY_SET, backend)
    }

    /// A lab whose set `dir/set` is built from the set specification `spec`.
    pub fn with_set(spec: &str) -> Lab {
        Lab::with_set_on(spec, &Backend::Sqlite)
    }

    /// A lab whose set is built from `spec`, its database on `backend`.
    pub fn with_set_on(spec: &str, backend: &Backend) -> Lab {
        Lab::with_files(spec, &[], backend)
    }

    /// A lab whose set is built from `spec` beside `files` (name, text) the spec names.
    pub fn with_files(spec: &str, files: &[(&str, &str)], backend: &Backend) -> Lab {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in files {
            std::fs::write(dir.path().join(name), text).unwrap();
        }
        std::fs::write(dir.path().join("set.toml"), spec).unwrap();
        facslab_ok(dir.path(), &["stimuli", "build", "set.toml", "-o", "set", "--jobs", "2"]);
        let store = TestDb::new(backend, dir.path());
        let out = Command::new(env!("CARGO_BIN_EXE_facslab"))
            .args(["admin", "create", "alice", "--db", &store.url])
            .env("FACSLAB_PASSWORD", ADMIN_PASSWORD)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        Lab { db: store.url.clone(), _store: store, dir }
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// Creates and opens a study from design text.
    pub fn study(&self, slug: &str, design: &str) {
        let file = format!("{slug}.toml");
        std::fs::write(self.path().join(&file), design).unwrap();
        facslab_ok(self.path(), &["study", "create", &file, "--set", "set", "--db", &self.db, "--open"]);
    }

    /// The set's manifest rows as (stimulus_id, emotion, expression, file).
    pub fn manifest(&self) -> Vec<(String, String, String, String)> {
        let text = std::fs::read_to_string(self.path().join("set/manifest.json")).unwrap();
        let rows: Vec<serde_json::Value> = serde_json::from_str(&text).unwrap();
        rows.iter()
            .map(|r| {
                let s = |k: &str| r[k].as_str().unwrap().to_string();
                (s("stimulus_id"), s("emotion"), s("expression"), s("file"))
            })
            .collect()
    }

    pub fn serve(&self) -> Server {
        Server::start(PathBuf::from(&self.db))
    }
}

/// A running `facslab serve`; killed when dropped.
pub struct Server {
    child: Child,
    pub base: String,
    db: PathBuf,
    /// What the server wrote to stderr, when started with [`Server::start_logged`].
    log: Arc<Mutex<String>>,
}

impl Server {
    pub fn start(db: PathBuf) -> Server {
        Server::start_with(db, &[])
    }

    /// `facslab serve` with more options.
    pub fn start_with(db: PathBuf, options: &[&str]) -> Server {
        Server::spawn(db, options, None)
    }

    /// `facslab serve` with the log filter `rust_log`, its stderr collected ([`Server::log`]).
    pub fn start_logged(db: PathBuf, rust_log: Option<&str>) -> Server {
        Server::spawn(db, &[], Some(rust_log))
    }

    fn spawn(db: PathBuf, options: &[&str], logged: Option<Option<&str>>) -> Server {
        let mut command = Command::new(env!("CARGO_BIN_EXE_facslab"));
        command.args(["serve", "--port", "0", "--db"]).arg(&db).args(options).stdout(Stdio::piped());
        match logged {
            // Warnings and errors only: a line per request would drown the test output.
            None => command.stderr(Stdio::inherit()).env("RUST_LOG", "facslab=warn"),
            Some(filter) => command.stderr(Stdio::piped()).env_remove("RUST_LOG").envs(filter.map(|f| ("RUST_LOG", f))),
        };
        let mut child = command.spawn().expect("facslab serve starts");
        let log = Arc::new(Mutex::new(String::new()));
        if let Some(stderr) = child.stderr.take() {
            let log = log.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                    let mut log = log.lock().unwrap();
                    log.push_str(&line);
                    log.push('\n');
                }
            });
        }
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let base = line.split_whitespace().find(|w| w.starts_with("http://")).expect("the server prints its address").trim_end_matches("/admin").to_string();
        Server { child, base, db, log }
    }

    /// The server's stderr so far (empty unless started with [`Server::start_logged`]).
    pub fn log(&self) -> String {
        self.log.lock().unwrap().clone()
    }

    /// Kills the server without any chance to clean up (like a crash or power cut).
    pub fn crash(mut self) -> PathBuf {
        let _ = self.child.kill();
        let _ = self.child.wait();
        self.db.clone()
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A lab with one open emotion study `slug`, its server and a client.
pub fn emotion_lab(slug: &str, extra: &str) -> (Lab, Server, reqwest::Client) {
    emotion_lab_on(&Backend::Sqlite, slug, extra)
}

/// [`emotion_lab`] with its database on `backend`.
pub fn emotion_lab_on(backend: &Backend, slug: &str, extra: &str) -> (Lab, Server, reqwest::Client) {
    let lab = Lab::on(backend);
    lab.study(slug, &emotion_design(slug, extra));
    let server = lab.serve();
    (lab, server, client())
}

/// An HTTP client that does not follow redirects (tests look at them).
pub fn client() -> reqwest::Client {
    reqwest::Client::builder().redirect(reqwest::redirect::Policy::none()).build().unwrap()
}

/// The `Location` of a redirect response.
pub fn location(response: &reqwest::Response) -> String {
    response.headers().get("location").map(|l| l.to_str().unwrap().to_string()).unwrap_or_default()
}

/// Starts a participation and returns its token (`query` is the link's query string).
pub async fn start(http: &reqwest::Client, server: &Server, slug: &str, form: &[(&str, &str)]) -> String {
    let r = http.post(server.url(&format!("/s/{slug}/start"))).form(form).send().await.unwrap();
    assert_eq!(r.status(), 303, "{:?}", r.text().await);
    location(&r).rsplit('/').next().unwrap().to_string()
}

/// Consents and answers the demographics.
pub async fn consent_and_demographics(http: &reqwest::Client, server: &Server, token: &str) {
    let r = http.post(server.url(&format!("/p/{token}/consent"))).form(&[("agree", "1")]).send().await.unwrap();
    assert_eq!(r.status(), 303);
    let r = http
        .post(server.url(&format!("/p/{token}/demographics")))
        .form(&[("age", "34"), ("gender", "female"), ("ethnicity", "asian"), ("education", "doctorate")])
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 303);
}

/// The position of the trial the participant is at now (from the trial page), if any.
pub async fn current_position(http: &reqwest::Client, server: &Server, token: &str) -> Option<i64> {
    let r = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap();
    if r.status() != 200 {
        return None;
    }
    let html = r.text().await.unwrap();
    let marker = format!("/p/{token}/trial/");
    let at = html.find(&marker)? + marker.len();
    html[at..].split('"').next()?.parse().ok()
}

/// Saves one answer through the JSON API; returns (status, body).
pub async fn save(http: &reqwest::Client, server: &Server, token: &str, position: i64, key: &str, fields: &[(&str, &str)]) -> (u16, serde_json::Value) {
    let body = serde_json::json!({
        "idempotency_key": key,
        "fields": fields.iter().map(|(n, v)| [n, v]).collect::<Vec<_>>(),
        "rt_ms": 900.5,
    });
    let r = http.post(server.url(&format!("/p/{token}/api/trial/{position}"))).json(&body).send().await.unwrap();
    let status = r.status().as_u16();
    (status, r.json().await.unwrap_or(serde_json::Value::Null))
}

/// Logs in as the lab's admin; returns the session cookie header value.
pub async fn admin_cookie(http: &reqwest::Client, server: &Server) -> String {
    let r = http.post(server.url("/admin/login")).form(&[("username", "alice"), ("password", ADMIN_PASSWORD)]).send().await.unwrap();
    assert_eq!(r.status(), 303);
    let cookie = r.headers().get("set-cookie").unwrap().to_str().unwrap();
    cookie.split(';').next().unwrap().to_string()
}
