//! Study server under load: 500 simulated participants on loopback, each arriving (start),
//! consenting, and saving 20 trials through the JSON save API (10,000 saves), against the real
//! axum app on a real SQLite file, or on a PostgreSQL database when `FACSLAB_LOAD_POSTGRES` holds
//! a server's URL (each run makes a database of its own there and drops it). Prints throughput (all saves over the wall time, and the rate
//! while every participant is active), p50/p99 save latency, start latency, errors and lost
//! responses (stored rows are counted in the database afterwards).
//! Run with `cargo bench --bench study_load`.

use std::sync::Arc;
use std::time::{Duration, Instant};

use facslab::db::{Db, DbUrl};
use sqlx::Connection;
use facslab::db::studies::StudyStimulus;
use facslab::study::StudyDesign;
use facslab::web::{AppState, router};

fn main() {
    divan::main();
}

const TRIALS: usize = 20;

fn env_ms(name: &str, default: u64) -> Duration {
    Duration::from_millis(std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default))
}

/// How many participants take part (default 500). `FACSLAB_LOAD_PARTICIPANTS` overrides.
fn participants() -> usize {
    std::env::var("FACSLAB_LOAD_PARTICIPANTS").ok().and_then(|v| v.parse().ok()).unwrap_or(500)
}

/// Arrivals (the start request) are spread evenly over this time (default 250 ms: everyone
/// arrives at once, the hardest case, and all 500 save together for most of the run; 5,000 ms
/// is 100 new participants a second, and its overall rate is set by the ramp, not the server).
/// `FACSLAB_LOAD_RAMP_MS` overrides.
fn ramp() -> Duration {
    env_ms("FACSLAB_LOAD_RAMP_MS", 250)
}

/// Pause between a participant's saves (looking at the next face), in milliseconds; 0 makes
/// every participant save as fast as the server answers. `FACSLAB_LOAD_THINK_MS` overrides.
fn think() -> Duration {
    env_ms("FACSLAB_LOAD_THINK_MS", 250)
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

/// What one participant saw, in times since the run began.
#[derive(Default)]
struct Participant {
    /// Start plus consent: from sending the start to the consent's answer.
    entry: Option<Duration>,
    /// Each save: (sent, answered).
    saves: Vec<(Duration, Duration)>,
    errors: usize,
}

async fn participant(http: reqwest::Client, base: Arc<String>, worker: usize, clock: Instant) -> Participant {
    let mut seen = Participant::default();
    // Participants arrive evenly over the ramp-up.
    tokio::time::sleep(ramp().mul_f64(worker as f64 / participants() as f64)).await;
    let arrived = Instant::now();
    let form = |url: String, body: &'static str| http.post(url).header("content-type", "application/x-www-form-urlencoded").body(body).send();
    let token = match form(format!("{base}/s/load/start"), "").await {
        Ok(r) if r.status() == 303 => r.headers().get("location").and_then(|l| l.to_str().ok()).and_then(|l| l.strip_prefix("/p/")).unwrap_or("").to_string(),
        _ => String::new(),
    };
    let consented = !token.is_empty() && form(format!("{base}/p/{token}/consent"), "agree=1").await.is_ok_and(|r| r.status() == 303);
    if !consented {
        seen.errors = 1;
        return seen;
    }
    seen.entry = Some(arrived.elapsed());
    let pause = think();
    for position in 0..TRIALS {
        tokio::time::sleep(pause).await;
        let body = format!(
            r#"{{"idempotency_key":"load-{worker:06}-{position:04}-key","fields":[["emotion","fear"],["believability","{}"]],"rt_ms":812.5}}"#,
            1 + position % 5
        );
        let sent = clock.elapsed();
        let reply = http.post(format!("{base}/p/{token}/api/trial/{position}")).header("content-type", "application/json").body(body).send().await;
        let ok = match reply {
            Ok(r) => r.status() == 200 && r.bytes().await.is_ok(),
            Err(_) => false,
        };
        seen.saves.push((sent, clock.elapsed()));
        seen.errors += usize::from(!ok);
    }
    seen
}

/// What one run measured.
struct Run {
    participants: Vec<Participant>,
    stored: i64,
    completed: i64,
    wall: Duration,
}

/// The PostgreSQL server to run against (`FACSLAB_LOAD_POSTGRES`), if any.
fn postgres() -> Option<String> {
    std::env::var("FACSLAB_LOAD_POSTGRES").ok().filter(|url| !url.is_empty())
}

/// Runs `statement` on the server's own database.
async fn on_server(server: &str, statement: String) {
    let mut conn = sqlx::PgConnection::connect(server).await.expect("the PostgreSQL server");
    sqlx::raw_sql(sqlx::AssertSqlSafe(statement)).execute(&mut conn).await.expect("statement");
}

/// The run's database: `load.db` in `dir`, or a new database on the PostgreSQL server (its name,
/// to drop it afterwards).
async fn database(dir: &std::path::Path) -> (DbUrl, Option<String>) {
    let Some(server) = postgres() else { return (DbUrl::Sqlite(dir.join("load.db")), None) };
    let name = format!("facslab_load_{}_{}", std::process::id(), Instant::now().elapsed().as_nanos() ^ u128::from(facslab::db::now_ms() as u64));
    on_server(&server, format!("CREATE DATABASE {name}")).await;
    let root = server.rsplit_once('/').map_or(server.as_str(), |(root, _)| root);
    (DbUrl::Postgres(format!("{root}/{name}")), Some(name))
}

async fn run_once() -> Run {
    let dir = tempfile::tempdir().expect("temp dir");
    let (url, made) = database(dir.path()).await;
    let db = Db::open(&url).await.expect("database");
    let design = StudyDesign::from_toml(DESIGN).expect("design");
    let stimuli: Vec<StudyStimulus> = (0..TRIALS)
        .map(|i| StudyStimulus::still(facslab::stimuli::StimulusId::parse(&facslab::stimuli::stimulus_id(1, i)).expect("id")))
        .collect();
    let study = db.create_study(&design, DESIGN, "set", &stimuli, true).await.expect("study");
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("listen");
    let base = Arc::new(format!("http://{}", listener.local_addr().expect("address")));
    let app = router(AppState::new(db.clone()).expect("templates"));
    let server = tokio::spawn(async move { axum::serve(listener, app).await });

    let http = reqwest::Client::builder().redirect(reqwest::redirect::Policy::none()).pool_max_idle_per_host(participants()).build().expect("client");
    let clock = Instant::now();
    let tasks: Vec<_> = (0..participants()).map(|w| tokio::spawn(participant(http.clone(), base.clone(), w, clock))).collect();
    let mut seen = Vec::with_capacity(tasks.len());
    for task in tasks {
        seen.push(task.await.expect("participant task"));
    }
    let wall = clock.elapsed();
    let progress = db.progress(study).await.expect("progress");
    server.abort();
    db.close().await;
    if let (Some(server), Some(name)) = (postgres(), made) {
        on_server(&server, format!("DROP DATABASE {name} WITH (FORCE)")).await;
    }
    Run { participants: seen, stored: progress.responses, completed: progress.completed, wall }
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    sorted[((sorted.len() as f64 * p).ceil() as usize).clamp(1, sorted.len()) - 1]
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Saves answered per second while every participant was active: from the last participant's
/// first save to the first participant's last answer. `None` when that window is under a second
/// (arrivals spread over about as long as one participation lasts).
fn rate_all_active(run: &Run) -> Option<(f64, Duration)> {
    let from = run.participants.iter().map(|p| p.saves.first().map_or(Duration::MAX, |s| s.0)).max()?;
    let to = run.participants.iter().map(|p| p.saves.last().map_or(Duration::ZERO, |s| s.1)).min()?;
    let window = to.checked_sub(from).filter(|w| *w >= Duration::from_secs(1))?;
    let answered = run.participants.iter().flat_map(|p| &p.saves).filter(|(_, answered)| (from..=to).contains(answered)).count();
    Some((answered as f64 / window.as_secs_f64(), window))
}

fn report(run: &Run) -> String {
    let n = run.participants.len();
    let mut latencies: Vec<Duration> = run.participants.iter().flat_map(|p| &p.saves).map(|(sent, answered)| *answered - *sent).collect();
    latencies.sort();
    let mut entries: Vec<Duration> = run.participants.iter().filter_map(|p| p.entry).collect();
    entries.sort();
    let saves = latencies.len();
    let errors: usize = run.participants.iter().map(|p| p.errors).sum();
    let active = match rate_all_active(run) {
        Some((rate, window)) => format!("{rate:.0} saves/s while all {n} active ({:.1} s)", window.as_secs_f64()),
        None => format!("all {n} active together for under 1 s"),
    };
    format!(
        "{n} participants, ramp {} ms, think {} ms: {saves} saves in {:.2} s = {:.0} saves/s overall, {active}; \
         save p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms; start+consent p50 {:.1} ms, p99 {:.1} ms; errors {errors}, stored {} (lost {}), completed {}",
        ramp().as_millis(),
        think().as_millis(),
        run.wall.as_secs_f64(),
        saves as f64 / run.wall.as_secs_f64(),
        ms(percentile(&latencies, 0.50)),
        ms(percentile(&latencies, 0.99)),
        latencies.last().map_or(0.0, |d| ms(*d)),
        ms(percentile(&entries, 0.50)),
        ms(percentile(&entries, 0.99)),
        run.stored,
        (n * TRIALS) as i64 - run.stored,
        run.completed,
    )
}

#[divan::bench(sample_count = 3, sample_size = 1)]
fn saves_from_concurrent_participants(bencher: divan::Bencher) {
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build().expect("runtime");
    bencher.bench_local(|| println!("{}", report(&runtime.block_on(run_once()))));
}
