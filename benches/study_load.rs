//! Study server under load: 500 simulated participants at once on loopback, each starting a
//! participation, consenting, and saving 20 trials through the JSON save API (10,000 saves),
//! against the real axum app on a real SQLite file. Prints throughput, p50/p99 save latency,
//! errors and lost responses (stored rows are counted in the database afterwards).
//! Run with `cargo bench --bench study_load`.

use std::sync::Arc;
use std::time::{Duration, Instant};

use facslab::db::Db;
use facslab::db::studies::StudyStimulus;
use facslab::study::StudyDesign;
use facslab::web::{AppState, router};

fn main() {
    divan::main();
}

const PARTICIPANTS: usize = 500;
const TRIALS: usize = 20;

/// Pause between a participant's saves (looking at the next face), in milliseconds; 0 makes
/// every participant save as fast as the server answers. `FACSLAB_LOAD_THINK_MS` overrides.
fn think() -> Duration {
    Duration::from_millis(std::env::var("FACSLAB_LOAD_THINK_MS").ok().and_then(|v| v.parse().ok()).unwrap_or(250))
}

const DESIGN: &str = r#"
slug = "load"
title = "Load"
task = "emotion"
stimuli = "set"
demographics = false
consent = "ok"
instructions = "go"
debrief = "thanks"
[emotion]
believability = true
"#;

/// What one run measured.
struct Run {
    latencies: Vec<Duration>,
    errors: usize,
    stored: i64,
    wall: Duration,
}

async fn participant(http: reqwest::Client, base: Arc<String>, worker: usize) -> (Vec<Duration>, usize) {
    let mut errors = 0;
    let start = http.post(format!("{base}/s/load/start")).header("content-type", "application/x-www-form-urlencoded").body("").send().await;
    let Ok(start) = start else { return (Vec::new(), 1) };
    let location = start.headers().get("location").and_then(|l| l.to_str().ok()).unwrap_or("").to_string();
    let token = location.rsplit('/').next().unwrap_or("").to_string();
    let consent = http.post(format!("{base}/p/{token}/consent")).header("content-type", "application/x-www-form-urlencoded").body("agree=1").send().await;
    if consent.map_or(true, |r| r.status() != 303) {
        return (Vec::new(), 1);
    }
    let mut latencies = Vec::with_capacity(TRIALS);
    let pause = think();
    // Participants arrive spread over one think time, not all in the same millisecond.
    tokio::time::sleep(pause.mul_f64((worker % 100) as f64 / 100.0)).await;
    for position in 0..TRIALS {
        tokio::time::sleep(pause).await;
        let body = format!(
            r#"{{"idempotency_key":"load-{worker:06}-{position:04}-key","fields":[["emotion","fear"],["believability","{}"]],"rt_ms":812.5}}"#,
            1 + position % 5
        );
        let t = Instant::now();
        let reply = http.post(format!("{base}/p/{token}/api/trial/{position}")).header("content-type", "application/json").body(body).send().await;
        let ok = match reply {
            Ok(r) => r.status() == 200 && r.bytes().await.is_ok(),
            Err(_) => false,
        };
        latencies.push(t.elapsed());
        errors += usize::from(!ok);
    }
    (latencies, errors)
}

async fn run_once() -> Run {
    let dir = tempfile::tempdir().expect("temp dir");
    let db = Db::open(&dir.path().join("load.db")).await.expect("database");
    let design = StudyDesign::from_toml(DESIGN).expect("design");
    let stimuli: Vec<StudyStimulus> = (0..TRIALS)
        .map(|i| StudyStimulus { stimulus_id: format!("s{i:02}"), media: "image".into(), file: format!("media/s{i:02}.png"), emotion: String::new() })
        .collect();
    let study = db.create_study(&design, DESIGN, "set", &stimuli, true).await.expect("study");
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("listen");
    let base = Arc::new(format!("http://{}", listener.local_addr().expect("address")));
    let app = router(AppState::new(db.clone()).expect("templates"));
    let server = tokio::spawn(async move { axum::serve(listener, app).await });

    let http = reqwest::Client::builder().redirect(reqwest::redirect::Policy::none()).pool_max_idle_per_host(PARTICIPANTS).build().expect("client");
    let started = Instant::now();
    let tasks: Vec<_> = (0..PARTICIPANTS).map(|w| tokio::spawn(participant(http.clone(), base.clone(), w))).collect();
    let (mut latencies, mut errors) = (Vec::with_capacity(PARTICIPANTS * TRIALS), 0);
    for task in tasks {
        let (l, e) = task.await.expect("participant task");
        latencies.extend(l);
        errors += e;
    }
    let wall = started.elapsed();
    let stored = db.progress(study).await.expect("progress").responses;
    server.abort();
    Run { latencies, errors, stored, wall }
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    sorted[((sorted.len() as f64 * p).ceil() as usize).clamp(1, sorted.len()) - 1]
}

#[divan::bench(sample_count = 3, sample_size = 1)]
fn saves_from_500_concurrent_participants(bencher: divan::Bencher) {
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build().expect("runtime");
    bencher.bench_local(|| {
        let mut run = runtime.block_on(run_once());
        run.latencies.sort();
        let saves = run.latencies.len();
        println!(
            "{PARTICIPANTS} participants, think {} ms, {saves} saves in {:.2} s: {:.0} saves/s, p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms, errors {}, stored {} (lost {})",
            think().as_millis(),
            run.wall.as_secs_f64(),
            saves as f64 / run.wall.as_secs_f64(),
            percentile(&run.latencies, 0.50).as_secs_f64() * 1e3,
            percentile(&run.latencies, 0.99).as_secs_f64() * 1e3,
            run.latencies.last().map_or(0.0, |d| d.as_secs_f64() * 1e3),
            run.errors,
            run.stored,
            (PARTICIPANTS * TRIALS) as i64 - run.stored,
        );
    });
}
