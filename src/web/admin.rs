//! Admin pages and the export API.
//!
//! Login with a password (argon2, one check at a time on a blocking thread) opens a session
//! cookie (HttpOnly, SameSite=Strict, Secure behind HTTPS); repeated wrong passwords for an
//! account or from an address get 429 with `Retry-After` until the window ends. Every
//! state-changing form carries the session's CSRF token (compared in constant time), and a
//! cross-origin `Origin` header is refused. Roles: viewers see progress and export, researchers
//! also create, open, close and exclude, admins everything. `GET /api/v1/studies/{slug}/{file}`
//! serves the same streamed exports to a bearer token made with `facslab admin token`, which
//! reaches one study until it expires.

use std::collections::HashMap;

use axum::Router;
use axum::body::Body;
use axum::extract::{Form, FromRequest, FromRequestParts, Path, Query, Request, State};
use axum::http::request::Parts;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use axum_extra::extract::CookieJar;
use axum_extra::extract::cookie::SameSite;
use serde_json::json;

use super::limit::{self, ClientAddress};
use super::{AppState, WebError, merge};
use crate::db::admin::{AdminSession, Role};
use crate::db::export::{Format, Scope, codebook};
use crate::db::studies::StudyStatus;

const COOKIE: &str = "facslab_admin";

pub fn routes() -> Router<AppState> {
    Router::new()
        .route("/admin/login", get(login_page).post(login))
        .route("/admin/logout", post(logout))
        .route("/admin", get(dashboard))
        .route("/admin/studies", post(create_study))
        .route("/admin/studies/new", get(new_study_page))
        .route("/admin/studies/{slug}", get(study_page))
        .route("/admin/studies/{slug}/progress.json", get(progress_json))
        .route("/admin/studies/{slug}/status", post(set_status))
        .route("/admin/studies/{slug}/exclude", post(exclude))
        .route("/admin/studies/{slug}/export/{file}", get(export_by_session))
        .route("/api/v1/studies/{slug}/{file}", get(export_by_token))
}

/// The expression studio (`crate::studio`) for logged-in admins at `/admin/studio/`: anonymous
/// page visits go to the login page, anonymous API calls get 401.
pub fn studio(app: AppState) -> Router<AppState> {
    crate::studio::router_at("/admin/studio", crate::studio::StudioState::default())
        .route_layer(axum::middleware::from_fn_with_state(app, studio_gate))
        .route("/admin/studio", get(|| async { Redirect::permanent("/admin/studio/") }))
}

async fn studio_gate(admin: Result<Admin<Viewer>, WebError>, request: Request, next: axum::middleware::Next) -> Response {
    match admin {
        Ok(_) => next.run(request).await,
        Err(WebError::Unauthorized) if request.method() == axum::http::Method::GET && !request.uri().path().contains("/api/") => Redirect::to("/admin/login").into_response(),
        Err(e) => e.into_response(),
    }
}

/// The session token in the request's cookie, if there is one.
fn session_cookie(headers: &HeaderMap) -> Option<String> {
    CookieJar::from_headers(headers).get(COOKIE).map(|c| c.value().to_string())
}

/// How long a login cookie is kept (the session itself ends after as long: `db::admin`).
const SESSION_COOKIE_AGE: std::time::Duration = std::time::Duration::from_secs(43_200);

/// The logged-in admin with at least `role`.
async fn admin(app: &AppState, headers: &HeaderMap, role: Role) -> Result<AdminSession, WebError> {
    let token = session_cookie(headers).ok_or(WebError::Unauthorized)?;
    let session = app.db.admin_session(&token).await?.ok_or(WebError::Unauthorized)?;
    if session.role < role {
        return Err(WebError::Forbidden(format!("this needs the {} role; you are {}", role.as_str(), session.role.as_str())));
    }
    Ok(session)
}

/// Like [`admin`], for a state-changing form: also checks the CSRF token and the origin.
async fn admin_post(app: &AppState, headers: &HeaderMap, csrf: &str, role: Role) -> Result<AdminSession, WebError> {
    let session = admin(app, headers, role).await?;
    if !bool::from(subtle::ConstantTimeEq::ct_eq(csrf.as_bytes(), session.csrf_token.as_bytes())) {
        return Err(WebError::Forbidden("the form's security token is missing or stale; reload the page and try again".into()));
    }
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok()).unwrap_or("");
    if let Some(origin) = headers.get(header::ORIGIN).and_then(|o| o.to_str().ok())
        && origin != "null"
        && origin.split_once("://").map(|(_, rest)| rest) != Some(host)
    {
        return Err(WebError::Forbidden("cross-site request refused".into()));
    }
    Ok(session)
}

/// A role an admin route needs, as a type (`Admin<Researcher>`).
pub trait NeedsRole: Send + Sync + 'static {
    const ROLE: Role;
}

/// Viewers see progress and export.
pub enum Viewer {}
/// Researchers also create, open, close and exclude.
pub enum Researcher {}

impl NeedsRole for Viewer {
    const ROLE: Role = Role::Viewer;
}

impl NeedsRole for Researcher {
    const ROLE: Role = Role::Researcher;
}

/// The logged-in admin with at least the role `R` (an extractor: anonymous requests are
/// refused with 401, too low a role with 403; pages take `Result<Admin<R>, WebError>` and send
/// anonymous visitors to the login page).
pub struct Admin<R>(pub AdminSession, std::marker::PhantomData<R>);

impl<R: NeedsRole> FromRequestParts<AppState> for Admin<R> {
    type Rejection = WebError;

    async fn from_request_parts(parts: &mut Parts, app: &AppState) -> Result<Self, WebError> {
        admin(app, &parts.headers, R::ROLE).await.map(|session| Admin(session, std::marker::PhantomData))
    }
}

/// A state-changing admin form: the logged-in admin with at least the role `R`, and the form's
/// fields as `F` once its CSRF token and origin are checked (an extractor, like [`Admin`]).
/// Who may post is settled before the fields are read: a stranger gets 401/403, never 422.
pub struct AdminForm<R, F = HashMap<String, String>> {
    pub session: AdminSession,
    pub fields: F,
    role: std::marker::PhantomData<R>,
}

/// The CSRF token every admin form carries.
#[derive(serde::Deserialize)]
struct CsrfField {
    #[serde(default)]
    csrf: String,
}

impl<R: NeedsRole, F: serde::de::DeserializeOwned + Send + 'static> FromRequest<AppState> for AdminForm<R, F> {
    type Rejection = WebError;

    async fn from_request(request: Request, app: &AppState) -> Result<Self, WebError> {
        let headers = request.headers().clone();
        let body = axum::body::Bytes::from_request(request, app).await.map_err(|e| WebError::BadRequest(e.body_text()))?;
        let CsrfField { csrf } = serde_urlencoded::from_bytes(&body).map_err(|e| WebError::BadRequest(format!("not a form: {e}")))?;
        let session = admin_post(app, &headers, &csrf, R::ROLE).await?;
        let fields = serde_urlencoded::from_bytes(&body).map_err(|e| WebError::Unprocessable(format!("form: {}", crate::study::excerpt(&e.to_string(), 120))))?;
        Ok(AdminForm { session, fields, role: std::marker::PhantomData })
    }
}

/// `POST /admin/login`.
#[derive(serde::Deserialize)]
struct LoginForm {
    #[serde(default)]
    username: String,
    #[serde(default)]
    password: String,
}

/// `POST /admin/studies/{slug}/status` (parsed with [`form_status`], which names the field).
#[derive(serde::Deserialize)]
struct StatusForm {
    #[serde(default)]
    status: String,
}

/// `POST /admin/studies/{slug}/exclude`.
#[derive(serde::Deserialize)]
struct ExcludeForm {
    #[serde(default)]
    participant: String,
    /// `1` excludes, anything else includes again.
    #[serde(default)]
    excluded: String,
    #[serde(default)]
    reason: String,
}

/// `POST /admin/studies`.
#[derive(serde::Deserialize)]
struct NewStudyForm {
    #[serde(default)]
    spec: String,
    #[serde(default)]
    set_dir: String,
}

/// Pages send anonymous visitors to the login page; other errors render as usual.
fn or_login(result: Result<Response, WebError>) -> Response {
    match result {
        Err(WebError::Unauthorized) => Redirect::to("/admin/login").into_response(),
        Err(e) => e.into_response(),
        Ok(r) => r,
    }
}

fn base(session: Option<&AdminSession>, title: &str) -> serde_json::Value {
    json!({ "page_title": format!("{title} · facslab admin"), "header": "facslab admin", "session": session })
}


async fn login_page(State(app): State<AppState>) -> Response {
    or_login(app.render("admin_login.html", &merge(base(None, "Log in"), json!({ "error": null }))))
}

/// A 429 page saying when to try again.
fn too_many(app: &AppState, wait: std::time::Duration) -> Response {
    let minutes = wait.as_secs().div_ceil(60);
    let context = merge(base(None, "Log in"), json!({ "error": format!("Too many wrong passwords. Please try again in {minutes} minute(s).") }));
    let mut page = or_login(app.render("admin_login.html", &context));
    *page.status_mut() = StatusCode::TOO_MANY_REQUESTS;
    if let Ok(value) = limit::retry_after(wait).parse() {
        page.headers_mut().insert(header::RETRY_AFTER, value);
    }
    page
}

async fn login(State(app): State<AppState>, address: ClientAddress, jar: CookieJar, Form(form): Form<LoginForm>) -> Response {
    let LoginForm { username: user, password } = form;
    if user.len() > 64 || password.len() > crate::db::password::MAX_LEN * 4 {
        return WebError::BadRequest("the username or password is too long".into()).into_response();
    }
    let edge = &app.edge;
    let account = user.trim().to_lowercase();
    let address = address.key();
    // Every attempt counts before the password is checked, so a locked account or address costs
    // no argon2 work; a successful login is taken off again.
    let limited = edge.login_accounts.hit(&account).and(address.as_deref().map_or(Ok(()), |a| edge.login_addresses.hit(a)));
    if let Err(wait) = limited {
        return too_many(&app, wait);
    }
    let Ok(Ok(_permit)) = tokio::time::timeout(std::time::Duration::from_secs(5), edge.password_checks.acquire()).await else {
        return WebError::Unavailable("too many logins at once; please try again in a moment".into()).into_response();
    };
    match app.db.login(&user, &password).await {
        Ok(Some(token)) => {
            edge.login_accounts.clear(&account);
            if let Some(a) = address.as_deref() {
                edge.login_addresses.forgive(a);
            }
            (jar.add(edge.cookie(COOKIE, &token, SESSION_COOKIE_AGE, SameSite::Strict)), Redirect::to("/admin")).into_response()
        }
        Ok(None) => {
            let page = app.render("admin_login.html", &merge(base(None, "Log in"), json!({ "error": "Unknown username or wrong password." })));
            let mut page = or_login(page);
            *page.status_mut() = StatusCode::UNAUTHORIZED;
            page
        }
        Err(e) => WebError::from(e).into_response(),
    }
}

async fn logout(State(app): State<AppState>, jar: CookieJar, form: Result<AdminForm<Viewer>, WebError>) -> Response {
    or_login(async {
        form?;
        if let Some(token) = jar.get(COOKIE) {
            app.db.logout(token.value()).await?;
        }
        Ok((jar.add(app.edge.expired_cookie(COOKIE, SameSite::Strict)), Redirect::to("/admin/login")).into_response())
    }
    .await)
}

async fn dashboard(State(app): State<AppState>, admin: Result<Admin<Viewer>, WebError>) -> Response {
    or_login(async {
        let Admin(session, _) = admin?;
        let mut studies = Vec::new();
        for s in app.db.studies().await? {
            let progress = app.db.progress(s.id).await?;
            studies.push(json!({ "slug": s.slug, "title": s.title, "status": s.status, "progress": progress }));
        }
        app.render("admin_dashboard.html", &merge(base(Some(&session), "Studies"), json!({ "studies": studies })))
    }
    .await)
}

async fn study_page(State(app): State<AppState>, Path(slug): Path<String>, admin: Result<Admin<Viewer>, WebError>) -> Response {
    or_login(async {
        let Admin(session, _) = admin?;
        let row = app.db.study_by_slug(&slug).await?.ok_or(WebError::NotFound)?;
        let progress = app.db.progress(row.id).await?;
        let participants = app.db.participants(row.id).await?;
        let counts = app.db.completed_counts(row.id).await?;
        let design = row.design()?;
        let context = json!({
            "study": row,
            "task": design.task.as_str(),
            "target": design.ratings_per_stimulus,
            "sources": design.sources.iter().map(|s| json!({ "group": s.group, "platform": s.platform.as_str(), "params": s.platform.entry_params() })).collect::<Vec<_>>(),
            "arms": design.arms.iter().map(|a| a.name.as_str()).collect::<Vec<_>>(),
            "progress": progress,
            "participants": participants,
            "counts": counts,
            "can_edit": session.role >= Role::Researcher,
        });
        app.render("admin_study.html", &merge(base(Some(&session), &row.title), context))
    }
    .await)
}

async fn progress_json(State(app): State<AppState>, _: Admin<Viewer>, Path(slug): Path<String>) -> Result<Response, WebError> {
    let row = app.db.study_by_slug(&slug).await?.ok_or(WebError::NotFound)?;
    Ok(axum::Json(app.db.progress(row.id).await?).into_response())
}

async fn set_status(State(app): State<AppState>, Path(slug): Path<String>, form: Result<AdminForm<Researcher, StatusForm>, WebError>) -> Response {
    or_login(async {
        let status = form_status(&form?.fields.status)?;
        app.db.set_study_status(&slug, status).await?;
        Ok(Redirect::to(&format!("/admin/studies/{slug}")).into_response())
    }
    .await)
}

/// The form's `status` field, or 422 naming the field and the values it takes.
fn form_status(given: &str) -> Result<StudyStatus, WebError> {
    StudyStatus::parse(given).ok_or_else(|| {
        let shown: String = given.chars().take(40).collect();
        let allowed: Vec<_> = StudyStatus::ALL.iter().map(|s| s.as_str()).collect();
        WebError::Unprocessable(format!("status: \"{shown}\" is not one of {}", allowed.join(", ")))
    })
}

async fn exclude(State(app): State<AppState>, Path(slug): Path<String>, form: Result<AdminForm<Researcher, ExcludeForm>, WebError>) -> Response {
    or_login(async {
        let form = form?.fields;
        let row = app.db.study_by_slug(&slug).await?.ok_or(WebError::NotFound)?;
        let reason = Some(form.reason.trim()).filter(|r| !r.is_empty()).unwrap_or("excluded by an admin");
        app.db.set_excluded(row.id, &form.participant, form.excluded == "1", reason).await?;
        Ok(Redirect::to(&format!("/admin/studies/{slug}")).into_response())
    }
    .await)
}

async fn new_study_page(State(app): State<AppState>, admin: Result<Admin<Researcher>, WebError>) -> Response {
    or_login(async {
        let Admin(session, _) = admin?;
        let templates: Vec<_> = crate::study::templates::ALL.iter().map(|(name, text)| json!({ "name": name, "text": text })).collect();
        app.render("admin_new.html", &merge(base(Some(&session), "New study"), json!({ "templates": templates, "error": null, "spec": "", "set_dir": "" })))
    }
    .await)
}

async fn create_study(State(app): State<AppState>, form: Result<AdminForm<Researcher, NewStudyForm>, WebError>) -> Response {
    or_login(async {
        let AdminForm { session, fields: NewStudyForm { spec, set_dir }, .. } = form?;
        match app.db.create_study_from(&spec, std::path::Path::new(&set_dir), false).await {
            Ok(design) => Ok(Redirect::to(&format!("/admin/studies/{}", design.slug)).into_response()),
            Err(e) => {
                let message = e.to_string();
                let context = json!({ "templates": [], "error": message, "spec": spec, "set_dir": set_dir });
                let mut page = app.render("admin_new.html", &merge(base(Some(&session), "New study"), context))?;
                *page.status_mut() = StatusCode::UNPROCESSABLE_ENTITY;
                Ok(page)
            }
        }
    }
    .await)
}

async fn export_by_session(State(app): State<AppState>, Path((slug, file)): Path<(String, String)>, Query(q): Query<HashMap<String, String>>, admin: Result<Admin<Viewer>, WebError>) -> Response {
    or_login(async {
        admin?;
        export(&app, &slug, &file, &q).await
    }
    .await)
}

async fn export_by_token(State(app): State<AppState>, headers: HeaderMap, Path((slug, file)): Path<(String, String)>, Query(q): Query<HashMap<String, String>>) -> Response {
    let token = headers.get(header::AUTHORIZATION).and_then(|v| v.to_str().ok()).and_then(|v| v.strip_prefix("Bearer ")).unwrap_or("");
    let result = async {
        let scope = app.db.api_token_scope(token).await?.ok_or(WebError::Unauthorized)?;
        let study = app.study(&slug).await?;
        if scope.study_id != study.row.id || scope.role < Role::Viewer {
            return Err(WebError::Forbidden("this token does not reach this study".into()));
        }
        export(&app, &slug, &file, &q).await
    };
    result.await.unwrap_or_else(WebError::json)
}

/// A streamed export (`responses.csv`, `wide.csv`, `responses.json`) or the codebook.
async fn export(app: &AppState, slug: &str, file: &str, query: &HashMap<String, String>) -> Result<Response, WebError> {
    let study = app.study(slug).await?;
    let attachment = |name: String| format!("attachment; filename=\"{name}\"");
    if file == "codebook.csv" {
        let name = format!("{slug}-codebook.csv");
        return Ok(([(header::CONTENT_TYPE, "text/csv; charset=utf-8".to_string()), (header::CONTENT_DISPOSITION, attachment(name))], codebook(&study.design)).into_response());
    }
    let format = Format::parse(file).ok_or_else(|| WebError::BadRequest(format!("no export \"{file}\" (responses.csv, wide.csv, responses.json, codebook.csv)")))?;
    let scope = match query.get("scope").map(String::as_str) {
        None | Some("completed") => Scope::Completed,
        Some("all") => Scope::All,
        Some(other) => return Err(WebError::BadRequest(format!("scope \"{other}\" is not completed or all"))),
    };
    let stimuli = crate::db::studies::trial_stimulus_ids(study.stimuli.values());
    let rx = app.db.export(study.row.id, &study.design, stimuli, format, scope);
    let stream = futures_util::stream::unfold(rx, |mut rx| async move { rx.recv().await.map(|chunk| (chunk.map_err(std::io::Error::other), rx)) });
    Ok((
        [(header::CONTENT_TYPE, format.content_type().to_string()), (header::CONTENT_DISPOSITION, attachment(format.file_name(slug)))],
        Body::from_stream(stream),
    )
        .into_response())
}
