//! The study web app: axum routes for participants ([`participant`]) and admins ([`admin`]),
//! tera templates (`templates/`, compiled into the binary) and the static page assets.
//!
//! In: HTTP requests. Out: pages, media and exports; every state change goes through
//! `crate::db`. Invariants: participant pages, URLs and headers never name a stimulus's AUs,
//! emotion or file (media are served by trial position under the participant's secret token);
//! request bodies are capped; every response carries no-referrer, nosniff and a strict CSP;
//! served behind HTTPS (`--public-url https://…`) cookies are `Secure` and responses carry HSTS;
//! logins and starts are rate limited per account and per client address ([`limit`]); cookies
//! are built in one place ([`Edge::cookie`]) and read through axum-extra's `CookieJar`; every
//! request gets an id and a log line without its path ([`log`]).

pub mod admin;
pub mod error;
pub mod extract;
pub mod limit;
pub mod log;
pub mod participant;

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, RwLock};
use std::time::Duration;

use axum::Router;
use axum::extract::{DefaultBodyLimit, Path};
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum_extra::extract::cookie::{Cookie, SameSite};
use tower_http::request_id::{MakeRequestUuid, PropagateRequestIdLayer, SetRequestIdLayer};
use tower_http::set_header::SetResponseHeaderLayer;
use tower_http::trace::TraceLayer;

use crate::db::Db;
use crate::db::studies::{StudyRow, StudyStimulus};
use crate::stimuli::manifest::StimulusId;
use crate::study::StudyDesign;
pub use error::WebError;

/// Largest accepted request body (a trial save is well under 4 KiB).
pub const BODY_LIMIT: usize = 64 * 1024;

/// A study with its design and stimuli, as the pages need it (cached: both never change).
#[derive(Debug)]
pub struct LoadedStudy {
    pub row: StudyRow,
    pub design: StudyDesign,
    pub stimuli: HashMap<StimulusId, StudyStimulus>,
    pub set_dir: PathBuf,
}

impl LoadedStudy {
    /// What a trial of stimulus `lead` shows: `lead` first, then the stimuli shown beside it
    /// (`[au_coding] together`) by their part; empty when the study has no such stimulus.
    pub fn shown(&self, lead: &StimulusId) -> Vec<&StudyStimulus> {
        let Some(first) = self.stimuli.get(lead) else { return Vec::new() };
        let mut beside: Vec<&StudyStimulus> = self.stimuli.values().filter(|s| s.lead.as_ref() == Some(lead)).collect();
        beside.sort_by_key(|s| s.part);
        std::iter::once(first).chain(beside).collect()
    }
}

/// How the server meets the world: behind HTTPS or not, behind a proxy or not, how many starts
/// one address may make.
#[derive(Debug, Clone)]
pub struct EdgeConfig {
    /// Served at an `https://` URL: cookies get `Secure`, responses get HSTS.
    pub https: bool,
    /// A reverse proxy in front appends the client's address to `X-Forwarded-For`.
    pub trusted_proxy: bool,
    /// Starts one client address may make per [`START_WINDOW`].
    pub starts_per_address: u32,
}

/// The window of [`EdgeConfig::starts_per_address`].
pub const START_WINDOW: Duration = Duration::from_secs(300);
/// Wrong passwords per account, and per client address, in [`LOGIN_WINDOW`] before logins
/// from there are refused with 429 until the window ends (the right password too).
pub const LOGIN_FAILURES_PER_ACCOUNT: u32 = 5;
pub const LOGIN_FAILURES_PER_ADDRESS: u32 = 20;
pub const LOGIN_WINDOW: Duration = Duration::from_secs(900);

impl Default for EdgeConfig {
    fn default() -> EdgeConfig {
        EdgeConfig { https: false, trusted_proxy: false, starts_per_address: 30 }
    }
}

/// The edge's configuration with its rate limiters.
#[derive(Debug)]
pub struct Edge {
    pub config: EdgeConfig,
    pub login_accounts: limit::Limiter,
    pub login_addresses: limit::Limiter,
    pub starts: limit::Limiter,
    /// One password check (argon2, a core for tens of milliseconds) at a time, so a flood of
    /// logins leaves the other core to everyone else.
    pub password_checks: tokio::sync::Semaphore,
    /// The `Last-Modified` every stimulus is served with: when this server started, the same for
    /// every file. A file's own time would tell the order the set was built in, which follows the
    /// spec's order, which follows what the stimuli show.
    pub media_last_modified: axum::http::HeaderValue,
}

impl Edge {
    fn new(config: EdgeConfig) -> Edge {
        Edge {
            login_accounts: limit::Limiter::new(LOGIN_FAILURES_PER_ACCOUNT, LOGIN_WINDOW),
            login_addresses: limit::Limiter::new(LOGIN_FAILURES_PER_ADDRESS, LOGIN_WINDOW),
            starts: limit::Limiter::new(config.starts_per_address, START_WINDOW),
            password_checks: tokio::sync::Semaphore::new(1),
            media_last_modified: axum::http::HeaderValue::from_str(&httpdate::fmt_http_date(std::time::SystemTime::now()))
                .expect("an HTTP date is a valid header value"),
            config,
        }
    }

    /// A cookie of this site: HttpOnly, on the whole site, kept `max_age`, `Secure` behind HTTPS.
    pub fn cookie(&self, name: &str, value: &str, max_age: Duration, same_site: SameSite) -> Cookie<'static> {
        let max_age = time::Duration::seconds(i64::try_from(max_age.as_secs()).unwrap_or(i64::MAX));
        Cookie::build((name.to_string(), value.to_string())).path("/").http_only(true).same_site(same_site).max_age(max_age).secure(self.config.https).build()
    }

    /// The cookie that makes a browser forget cookie `name` (same attributes, no value, expired).
    pub fn expired_cookie(&self, name: &str, same_site: SameSite) -> Cookie<'static> {
        let mut cookie = self.cookie(name, "", Duration::ZERO, same_site);
        cookie.make_removal();
        cookie
    }
}

/// What every handler shares.
#[derive(Clone)]
pub struct AppState {
    pub db: Db,
    pub templates: Arc<tera::Tera>,
    studies: Arc<RwLock<HashMap<String, Arc<LoadedStudy>>>>,
    pub edge: Arc<Edge>,
}

const TEMPLATES: [(&str, &str); 13] = [
    ("components.html", include_str!("../../templates/components.html")),
    ("base.html", include_str!("../../templates/base.html")),
    ("landing.html", include_str!("../../templates/landing.html")),
    ("consent.html", include_str!("../../templates/consent.html")),
    ("demographics.html", include_str!("../../templates/demographics.html")),
    ("instructions.html", include_str!("../../templates/instructions.html")),
    ("trial.html", include_str!("../../templates/trial.html")),
    ("message.html", include_str!("../../templates/message.html")),
    ("admin_base.html", include_str!("../../templates/admin_base.html")),
    ("admin_login.html", include_str!("../../templates/admin_login.html")),
    ("admin_dashboard.html", include_str!("../../templates/admin_dashboard.html")),
    ("admin_study.html", include_str!("../../templates/admin_study.html")),
    ("admin_new.html", include_str!("../../templates/admin_new.html")),
];

const ASSETS: [(&str, &str, &str); 3] = [
    ("style.css", "text/css; charset=utf-8", include_str!("../../assets/web/style.css")),
    ("trial.js", "text/javascript; charset=utf-8", include_str!("../../assets/web/trial.js")),
    ("admin.js", "text/javascript; charset=utf-8", include_str!("../../assets/web/admin.js")),
];

impl AppState {
    pub fn new(db: Db) -> Result<AppState, WebError> {
        let mut tera = tera::Tera::new();
        tera.autoescape_on([".html"]);
        tera.add_raw_templates(TEMPLATES).map_err(|e| WebError::internal("templates", e))?;
        Ok(AppState { db, templates: Arc::new(tera), studies: Arc::default(), edge: Arc::new(Edge::new(EdgeConfig::default())) })
    }

    /// The same state with another edge configuration.
    pub fn with_edge(mut self, config: EdgeConfig) -> AppState {
        self.edge = Arc::new(Edge::new(config));
        self
    }

    /// Renders a template with a serialisable context.
    pub fn render(&self, name: &str, context: &impl serde::Serialize) -> Result<Response, WebError> {
        let context = tera::Context::from_serialize(context).map_err(|e| WebError::internal("template context", e))?;
        let html = self.templates.render(name, &context).map_err(|e| WebError::internal(format!("template {name}"), e))?;
        Ok(axum::response::Html(html).into_response())
    }

    /// The study behind a slug, with its design and stimuli (loaded once, then cached).
    pub async fn study(&self, slug: &str) -> Result<Arc<LoadedStudy>, WebError> {
        if let Some(found) = self.studies.read().ok().and_then(|m| m.get(slug).cloned()) {
            return Ok(found);
        }
        let row = self.db.study_by_slug(slug).await?.ok_or(WebError::NotFound)?;
        self.load(row).await
    }

    pub async fn study_by_id(&self, id: i64) -> Result<Arc<LoadedStudy>, WebError> {
        if let Some(found) = self.studies.read().ok().and_then(|m| m.values().find(|s| s.row.id == id).cloned()) {
            return Ok(found);
        }
        let row = self.db.study_by_id(id).await?.ok_or(WebError::NotFound)?;
        self.load(row).await
    }

    /// Loads a study for serving, after checking that this server's copy of its set is the one
    /// the study was made with ([`crate::db::studies::check_set_copy`]; several servers may each
    /// read the set from a copy of their own). A study whose copy differs is not served (and not
    /// kept, so it is checked again at the next request).
    async fn load(&self, row: StudyRow) -> Result<Arc<LoadedStudy>, WebError> {
        let design = row.design()?;
        let stimuli: Vec<StudyStimulus> = self.db.study_stimuli(row.id).await?;
        if let Some(recorded) = row.set_sha256.clone() {
            let (set_dir, files) = (PathBuf::from(&row.set_dir), stimuli.iter().map(|s| s.file.clone()).collect::<Vec<_>>());
            let checked = tokio::task::spawn_blocking(move || crate::db::studies::check_set_copy(&set_dir, &recorded, &files.iter().map(String::as_str).collect::<Vec<_>>())).await;
            if let Err(e) = checked.map_err(|e| crate::db::DbError::Internal(e.to_string())).and_then(|c| c) {
                tracing::error!(study = %row.slug, error = %e, "refusing to serve the study");
                // The details (paths, file names) go to the log only: file names would tell participants the stimuli.
                return Err(WebError::Unavailable("this server's copy of the study's stimulus set differs from the one the study was made with (the server's log says how)".into()));
            }
        }
        let stimuli = stimuli.into_iter().map(|s| (s.stimulus_id.clone(), s)).collect();
        let loaded = Arc::new(LoadedStudy { set_dir: PathBuf::from(&row.set_dir), row, design, stimuli });
        if let Ok(mut map) = self.studies.write() {
            map.insert(loaded.row.slug.clone(), loaded.clone());
        }
        Ok(loaded)
    }
}

/// Adds the fields of JSON object `extra` to JSON object `base` (page contexts).
pub fn merge(mut base: serde_json::Value, extra: serde_json::Value) -> serde_json::Value {
    if let (Some(b), serde_json::Value::Object(e)) = (base.as_object_mut(), extra) {
        b.extend(e);
    }
    base
}

/// The whole app.
pub fn router(state: AppState) -> Router {
    let hsts = state.edge.config.https.then(|| HeaderValue::from_static("max-age=31536000; includeSubDomains"));
    let csp = "default-src 'self'; img-src 'self'; media-src 'self'; style-src 'self' 'unsafe-inline'; script-src 'self'; form-action 'self' https:; frame-ancestors 'none'; base-uri 'none'";
    Router::new()
        .merge(participant::routes())
        .merge(admin::routes())
        .merge(admin::studio(state.clone()))
        .route("/static/{file}", get(asset))
        .route("/health", get(|| async { "ok" }))
        .layer(DefaultBodyLimit::max(BODY_LIMIT))
        .layer(SetResponseHeaderLayer::overriding(header::REFERRER_POLICY, HeaderValue::from_static("no-referrer")))
        .layer(SetResponseHeaderLayer::overriding(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff")))
        .layer(SetResponseHeaderLayer::if_not_present(header::CONTENT_SECURITY_POLICY, HeaderValue::from_static(csp)))
        .layer(SetResponseHeaderLayer::if_not_present(header::CACHE_CONTROL, HeaderValue::from_static("no-store")))
        .layer(SetResponseHeaderLayer::overriding(header::STRICT_TRANSPORT_SECURITY, hsts))
        .layer(PropagateRequestIdLayer::x_request_id())
        .layer(TraceLayer::new_for_http().make_span_with(log::request_span).on_request(()).on_response(log::response_line).on_failure(()))
        .layer(SetRequestIdLayer::x_request_id(MakeRequestUuid))
        .with_state(state)
}

async fn asset(Path(file): Path<String>) -> Result<Response, WebError> {
    let (_, content_type, body) = ASSETS.iter().find(|(name, _, _)| *name == file).ok_or(WebError::NotFound)?;
    Ok(([(header::CONTENT_TYPE, *content_type), (header::CACHE_CONTROL, "public, max-age=300")], *body).into_response())
}

/// Serves the app on `addr` until Ctrl-C, abandoning expired reservations and deleting expired
/// admin sessions once a minute.
pub async fn serve(state: AppState, addr: SocketAddr, on_ready: impl FnOnce(SocketAddr)) -> anyhow::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await.map_err(|e| anyhow::anyhow!("cannot listen on {addr}: {e}"))?;
    let bound = listener.local_addr()?;
    let reaper = tokio::spawn(reap_forever(state.db.clone()));
    on_ready(bound);
    axum::serve(listener, router(state.clone()).into_make_service_with_connect_info::<SocketAddr>())
        .with_graceful_shutdown(async {
            let _ = tokio::signal::ctrl_c().await;
        })
        .await?;
    reaper.abort();
    state.db.close().await;
    Ok(())
}

async fn reap_forever(db: Db) {
    let mut tick = tokio::time::interval(std::time::Duration::from_secs(60));
    loop {
        tick.tick().await;
        if let Err(e) = db.reap(crate::db::now_ms()).await {
            tracing::error!(error = %e, "abandoning expired reservations failed");
        }
        if let Err(e) = db.purge_expired_sessions(crate::db::now_ms()).await {
            tracing::error!(error = %e, "deleting expired admin sessions failed");
        }
    }
}
