//! facslab studio: the expression editor in the browser and the live render API.
//!
//! In: HTTP requests: the editor page and its script, JSON render requests
//! (`POST /api/v1/render`), and expression updates over a WebSocket (`GET /api/v1/stream`).
//! Out: the page, PNG stills and MP4 videos rendered by the engine, JSON lists of the catalog,
//! people, presets and CPT sequences the page is built from, and JSON errors that name the field
//! and, for FACS notation, the token at fault (for a timeline, the track and its field).
//!
//! Invariants: a render request gives the bytes `facslab render` writes for the same expression,
//! person and size (or timeline); every input is bounded before anything is allocated
//! ([`request`]); renders run off the async runtime, at most [`RENDER_SLOTS`] at once, so a
//! burst of requests queues instead of starving the server. Absent: studies, participants, the
//! database; the studio keeps no state between requests.

pub mod request;
pub mod stream;

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{DefaultBodyLimit, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use tokio::sync::Semaphore;
use tower_http::set_header::SetResponseHeaderLayer;

use crate::engine::identity::IdentityTable;
use crate::engine::timeline::{ClipTiming, DEFAULT_FPS};
use crate::facs::{AppraisalTable, Catalog, EmotionTable};
pub use request::{Job, RenderRequest, Rendered, RequestError};

/// Renders running at once; each uses every core, so more would only queue inside rayon.
pub const RENDER_SLOTS: usize = 1;

/// Largest request body: a timeline of many tracks fits in far less.
pub const BODY_LIMIT: usize = 256 * 1024;

/// What the handlers share.
#[derive(Clone)]
pub struct StudioState {
    slots: Arc<Semaphore>,
}

impl Default for StudioState {
    fn default() -> Self {
        StudioState { slots: Arc::new(Semaphore::new(RENDER_SLOTS)) }
    }
}

impl StudioState {
    /// Renders `request` on a blocking thread once a render slot is free.
    pub async fn render(&self, request: RenderRequest) -> Result<Rendered, RequestError> {
        let job = request.parse()?;
        let _slot = self.slots.clone().acquire_owned().await.map_err(|_| RequestError::Unavailable)?;
        tokio::task::spawn_blocking(move || job.render()).await.map_err(|e| RequestError::Render(e.to_string()))?
    }
}

const PAGE: &str = include_str!("../../assets/studio/index.html");
const SCRIPT: &str = include_str!("../../assets/studio/studio.js");
const TIMELINE_SCRIPT: &str = include_str!("../../assets/studio/timeline.js");
const STYLE: &str = include_str!("../../assets/studio/studio.css");

/// The studio's routes (the page, its assets and the API) at the root, for `facslab studio`.
pub fn router(state: StudioState) -> Router {
    router_at("", state)
}

/// The studio's routes under `base` (`""` or a path such as `/admin/studio`; the page is at
/// `{base}/` and uses relative URLs for its script, style and API).
pub fn router_at<S: Clone + Send + Sync + 'static>(base: &str, state: StudioState) -> Router<S> {
    let csp = "default-src 'self'; img-src 'self' blob: data:; media-src 'self' blob:; style-src 'self'; script-src 'self'; connect-src 'self' blob:; frame-ancestors 'none'; base-uri 'none'";
    let at = |path: &str| format!("{base}{path}");
    Router::new()
        .route(&at("/"), get(|| async { Html(PAGE) }))
        .route(&at("/studio.js"), get(|| async { ([(header::CONTENT_TYPE, "text/javascript; charset=utf-8")], SCRIPT) }))
        .route(&at("/timeline.js"), get(|| async { ([(header::CONTENT_TYPE, "text/javascript; charset=utf-8")], TIMELINE_SCRIPT) }))
        .route(&at("/studio.css"), get(|| async { ([(header::CONTENT_TYPE, "text/css; charset=utf-8")], STYLE) }))
        .route(&at("/api/v1/catalog"), get(catalog))
        .route(&at("/api/v1/render"), post(render))
        .route(&at("/api/v1/timeline"), post(clip_timeline))
        .route(&at("/api/v1/timeline/check"), post(check_timeline))
        .route(&at("/api/v1/stream"), get(stream::upgrade))
        .route(&at("/health"), get(|| async { "ok" }))
        .layer(DefaultBodyLimit::max(BODY_LIMIT))
        .layer(SetResponseHeaderLayer::overriding(header::CONTENT_SECURITY_POLICY, HeaderValue::from_static(csp)))
        .layer(SetResponseHeaderLayer::overriding(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff")))
        .with_state(state)
}

/// Serves the studio on `addr` until Ctrl-C; `on_ready` gets the address it listens on.
pub async fn serve(addr: SocketAddr, on_ready: impl FnOnce(SocketAddr)) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await?;
    on_ready(listener.local_addr()?);
    axum::serve(listener, router(StudioState::default()))
        .with_graceful_shutdown(async {
            let _ = tokio::signal::ctrl_c().await;
        })
        .await
}

async fn catalog() -> Json<serde_json::Value> {
    Json(catalog_json())
}

/// Everything the page is built from: the AUs by region, the people, the EmFACS presets, the
/// CPT appraisal sequences (each check's AU groups in time order, as `cpt = [..]` in a set spec
/// plays them; the table is validated against the catalog when it loads), the HapFACS clip
/// timing and the defaults.
pub fn catalog_json() -> serde_json::Value {
    let aus: Vec<serde_json::Value> = Catalog::built_in()
        .iter()
        .map(|u| {
            serde_json::json!({
                "code": u.code, "name": u.name, "region": u.region, "unilateral": u.unilateral,
                "kind": u.kind, "appearance": u.appearance,
            })
        })
        .collect();
    let people: Vec<serde_json::Value> =
        IdentityTable::active().iter().map(|p| serde_json::json!({ "id": p.id, "description": p.description })).collect();
    let presets: Vec<serde_json::Value> =
        EmotionTable::built_in().iter().map(|e| serde_json::json!({ "label": e.label, "expression": e.expression.to_string() })).collect();
    let sequences: Vec<serde_json::Value> = AppraisalTable::built_in()
        .iter()
        .map(|c| serde_json::json!({ "name": c.name, "steps": c.steps.iter().map(|s| s.to_string()).collect::<Vec<_>>() }))
        .collect();
    let (width, height) = crate::engine::DEFAULT_SIZE;
    serde_json::json!({
        "aus": aus, "people": people, "presets": presets, "sequences": sequences,
        "clip": { "timing": ClipTiming::default(), "fps": DEFAULT_FPS },
        "defaults": { "identity": request::DEFAULT_IDENTITY, "size": format!("{width}x{height}") },
        "backdrops": ["grey", "black", "transparent"], "lights": ["studio", "soft", "dramatic"],
        "limits": { "expression_bytes": crate::facs::MAX_NOTATION_LEN, "timeline_bytes": BODY_LIMIT, "side": request::MAX_SIDE, "video_frames": request::MAX_VIDEO_FRAMES },
    })
}

/// `POST /api/v1/render`: JSON in, PNG or MP4 out.
async fn render(State(state): State<StudioState>, body: axum::body::Bytes) -> Response {
    let request = match serde_json::from_slice::<RenderRequest>(&body) {
        Ok(request) => request,
        Err(e) => return RequestError::Json(e.to_string()).into_response(),
    };
    match state.render(request).await {
        Ok(rendered) => ([(header::CONTENT_TYPE, rendered.content_type()), (header::CACHE_CONTROL, "no-store")], rendered.bytes).into_response(),
        Err(e) => e.into_response(),
    }
}

/// `POST /api/v1/timeline`: a HapFACS clip of an expression as timeline JSON (what
/// `facslab render EXPR --video --export-timeline FILE` writes).
async fn clip_timeline(body: axum::body::Bytes) -> Response {
    let clip = match serde_json::from_slice::<request::ClipRequest>(&body) {
        Ok(clip) => clip,
        Err(e) => return RequestError::Json(e.to_string()).into_response(),
    };
    match clip.timeline_json() {
        Ok(json) => ([(header::CONTENT_TYPE, "application/json")], json).into_response(),
        Err(e) => e.into_response(),
    }
}

/// `POST /api/v1/timeline/check`: a timeline JSON to import into the editor, validated as a
/// render request would be; answers the timeline as the server reads it, or the 422 naming the
/// track and field. Bodies over [`BODY_LIMIT`] are refused (413) before they are read.
async fn check_timeline(body: axum::body::Bytes) -> Response {
    match request::check_timeline(&body) {
        Ok(json) => ([(header::CONTENT_TYPE, "application/json")], json).into_response(),
        Err(e) => e.into_response(),
    }
}

impl IntoResponse for RequestError {
    fn into_response(self) -> Response {
        let status = match self {
            RequestError::Json(_) => StatusCode::BAD_REQUEST,
            RequestError::Render(_) => StatusCode::INTERNAL_SERVER_ERROR,
            RequestError::Unavailable => StatusCode::SERVICE_UNAVAILABLE,
            _ => StatusCode::UNPROCESSABLE_ENTITY,
        };
        (status, Json(self.to_json())).into_response()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_catalog_offers_the_cpt_sequences_step_by_step() {
        let json = catalog_json();
        let sequences = json["sequences"].as_array().unwrap();
        assert_eq!(sequences.len(), AppraisalTable::built_in().iter().count());
        assert_eq!(sequences[0], serde_json::json!({ "name": "novelty", "steps": ["1+2+5", "4+7+26+38"] }));
        let high_power = sequences.iter().find(|s| s["name"] == "control_high_power").unwrap();
        assert_eq!(high_power["steps"], serde_json::json!(["4+5", "7+23+25", "23+24+38"]));
        for sequence in sequences {
            for step in sequence["steps"].as_array().unwrap() {
                Catalog::built_in().parse(step.as_str().unwrap()).unwrap();
            }
        }
        assert_eq!(json["clip"], serde_json::json!({ "timing": { "onset_s": 1.0, "apex_s": 1.0, "offset_s": 1.0, "ramp": "linear" }, "fps": 30 }));
    }
}
