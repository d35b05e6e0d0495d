//! The study web app: axum routes for participants ([`participant`]) and admins ([`admin`]),
//! tera templates (`templates/`, compiled into the binary) and the static page assets.
//!
//! In: HTTP requests. Out: pages, media and exports; every state change goes through
//! `crate::db`. Invariants: participant pages, URLs and headers never name a stimulus's AUs,
//! emotion or file (media are served by trial position under the participant's secret token);
//! request bodies are capped; every response carries no-referrer, nosniff and a strict CSP.

pub mod admin;
pub mod cli;
pub mod error;
pub mod participant;

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, RwLock};

use axum::Router;
use axum::extract::{DefaultBodyLimit, Path};
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use tower_http::set_header::SetResponseHeaderLayer;

use crate::db::Db;
use crate::db::studies::{StudyRow, StudyStimulus};
use crate::study::StudyDesign;
pub use error::WebError;

/// Largest accepted request body (a trial save is well under 4 KiB).
pub const BODY_LIMIT: usize = 64 * 1024;

/// A study with its design and stimuli, as the pages need it (cached: both never change).
#[derive(Debug)]
pub struct LoadedStudy {
    pub row: StudyRow,
    pub design: StudyDesign,
    pub stimuli: HashMap<String, StudyStimulus>,
    pub set_dir: PathBuf,
}

/// What every handler shares.
#[derive(Clone)]
pub struct AppState {
    pub db: Db,
    pub templates: Arc<tera::Tera>,
    studies: Arc<RwLock<HashMap<String, Arc<LoadedStudy>>>>,
}

const TEMPLATES: [(&str, &str); 12] = [
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
        tera.add_raw_templates(TEMPLATES).map_err(|e| WebError::Internal(format!("templates: {e}")))?;
        Ok(AppState { db, templates: Arc::new(tera), studies: Arc::default() })
    }

    /// Renders a template with a serialisable context.
    pub fn render(&self, name: &str, context: &impl serde::Serialize) -> Result<Response, WebError> {
        let context = tera::Context::from_serialize(context).map_err(|e| WebError::Internal(format!("template context: {e}")))?;
        let html = self.templates.render(name, &context).map_err(|e| WebError::Internal(format!("template {name}: {e}")))?;
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

    async fn load(&self, row: StudyRow) -> Result<Arc<LoadedStudy>, WebError> {
        let design = row.design()?;
        let stimuli = self.db.study_stimuli(row.id).await?.into_iter().map(|s| (s.stimulus_id.clone(), s)).collect();
        let loaded = Arc::new(LoadedStudy { set_dir: PathBuf::from(&row.set_dir), row, design, stimuli });
        if let Ok(mut map) = self.studies.write() {
            map.insert(loaded.row.slug.clone(), loaded.clone());
        }
        Ok(loaded)
    }
}

/// The value of cookie `name` in a request's headers.
pub fn cookie<'a>(headers: &'a axum::http::HeaderMap, name: &str) -> Option<&'a str> {
    headers.get_all(header::COOKIE).iter().filter_map(|v| v.to_str().ok()).flat_map(|v| v.split(';')).find_map(|pair| {
        let (k, v) = pair.trim().split_once('=')?;
        (k == name).then_some(v)
    })
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
    let csp = "default-src 'self'; img-src 'self'; media-src 'self'; style-src 'self' 'unsafe-inline'; script-src 'self'; form-action 'self' https:; frame-ancestors 'none'; base-uri 'none'";
    Router::new()
        .merge(participant::routes())
        .merge(admin::routes())
        .route("/static/{file}", get(asset))
        .route("/health", get(|| async { "ok" }))
        .layer(DefaultBodyLimit::max(BODY_LIMIT))
        .layer(SetResponseHeaderLayer::overriding(header::REFERRER_POLICY, HeaderValue::from_static("no-referrer")))
        .layer(SetResponseHeaderLayer::overriding(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff")))
        .layer(SetResponseHeaderLayer::if_not_present(header::CONTENT_SECURITY_POLICY, HeaderValue::from_static(csp)))
        .layer(SetResponseHeaderLayer::if_not_present(header::CACHE_CONTROL, HeaderValue::from_static("no-store")))
        .with_state(state)
}

async fn asset(Path(file): Path<String>) -> Result<Response, WebError> {
    let (_, content_type, body) = ASSETS.iter().find(|(name, _, _)| *name == file).ok_or(WebError::NotFound)?;
    Ok(([(header::CONTENT_TYPE, *content_type), (header::CACHE_CONTROL, "public, max-age=300")], *body).into_response())
}

/// Serves the app on `addr` until Ctrl-C, abandoning expired reservations once a minute.
pub async fn serve(state: AppState, addr: SocketAddr, on_ready: impl FnOnce(SocketAddr)) -> anyhow::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await.map_err(|e| anyhow::anyhow!("cannot listen on {addr}: {e}"))?;
    let bound = listener.local_addr()?;
    let reaper = tokio::spawn(reap_forever(state.db.clone()));
    on_ready(bound);
    axum::serve(listener, router(state.clone()))
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
            eprintln!("reaper: {e}");
        }
    }
}
