//! Participant pages: landing (confirm) → start (POST) → consent → demographics → instructions
//! → trials → debrief with completion code and platform redirect.
//!
//! A participation is addressed by its secret token (`/p/{token}/…`). `GET /p/{token}` always
//! sends the participant to where they stand, so a reload or a crash resumes at the first
//! unanswered trial. Saves come as a plain form post (no script needed) or as JSON from the
//! page script, which waits for the acknowledgement before moving on.

use std::collections::HashMap;

use axum::extract::{Form, Path, Query, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use axum_extra::extract::CookieJar;
use axum_extra::extract::cookie::SameSite;
use serde_json::json;
use tower_http::services::ServeFile;

use super::extract::{MediaPart, ParticipationToken, TrialPosition};
use super::limit::ClientAddress;
use super::{AppState, LoadedStudy, WebError, merge};
use crate::db::participants::{Demographics, Participation, SaveOutcome, SaveTiming, Started, TrialRow};
use crate::db::studies::StudyStatus;
use crate::db::{secret_token, token_sha256};
use crate::facs::{Catalog, Region};
use crate::stimuli::manifest::Media;
use crate::study::assign::TrialKind;
use crate::study::measure::{Demographic, LabelSet};
use crate::study::screen::{self, ScreenError, Slot};
use crate::study::{Platform, SessionState, Submission, TaskKind, worker};

pub fn routes() -> Router<AppState> {
    Router::new()
        .route("/s/{slug}", get(landing))
        .route("/s/{slug}/start", post(start))
        .route("/p/{token}", get(resume))
        .route("/p/{token}/consent", get(consent_page).post(consent))
        .route("/p/{token}/demographics", get(demographics_page).post(demographics))
        .route("/p/{token}/instructions", get(instructions))
        .route("/p/{token}/trial", get(trial_page))
        .route("/p/{token}/trial/{position}", post(save_form))
        .route("/p/{token}/api/trial/{position}", post(save_json))
        .route("/p/{token}/media/{position}", get(media))
        .route("/p/{token}/media/{position}/{part}", get(media_part))
        .route("/p/{token}/done", get(done))
        .route("/p/{token}/withdraw", get(withdraw_page).post(withdraw))
}

/// Demographic questions and their choices (HapFACS Table 6 categories).
const GENDERS: [&str; 3] = ["female", "male", "non-binary or other"];
const ETHNICITIES: [&str; 6] = ["white", "black", "asian", "hispanic", "mixed", "other"];
const EDUCATION: [&str; 6] = ["high school", "some college", "bachelor's degree", "master's degree", "doctorate", "other"];

fn page<'a>(study: &'a LoadedStudy, title: &'a str) -> serde_json::Value {
    json!({ "page_title": format!("{title} · {}", study.design.title), "header": study.design.title })
}


/// The confirm page: nothing is created by a GET, so link previews cannot use up a link.
async fn landing(State(app): State<AppState>, Path(slug): Path<String>, Query(query): Query<HashMap<String, String>>) -> Result<Response, WebError> {
    let study = app.study(&slug).await?;
    let platform = study.design.source_for(|name| query.contains_key(name)).platform;
    let params = entry_params(platform, &query)?;
    let preview = platform == Platform::Mturk && query.get("assignmentId").is_some_and(|a| a == "ASSIGNMENT_ID_NOT_AVAILABLE");
    let open = is_open(&app, &slug).await?;
    let minutes = (trials_shown(&study).min(60) as f64 * 0.25).ceil().max(2.0);
    app.render(
        "landing.html",
        &merge(
            page(&study, "Welcome"),
            json!({ "title": study.design.title, "slug": slug, "params": params, "preview": preview, "closed": !open, "full": false, "minutes": minutes }),
        ),
    )
}

/// How many main trials a participant gets at most: the design's share, or every stimulus with
/// trials (not those only shown beside another) of the largest arm (of the study without arms).
fn trials_shown(study: &LoadedStudy) -> usize {
    let with_trials = || study.stimuli.values().filter(|s| s.has_trials());
    let all = match study.design.arms.is_empty() {
        true => with_trials().count(),
        false => study.design.arms.iter().map(|a| with_trials().filter(|s| s.arms.contains(&a.name)).count()).max().unwrap_or(0),
    };
    if study.design.labels_per_participant > 0 {
        let mut sizes: Vec<usize> = crate::db::studies::stimuli_per_label(with_trials()).into_values().collect();
        sizes.sort_unstable_by(|a, b| b.cmp(a));
        return sizes.iter().take(study.design.labels_per_participant).sum::<usize>().min(all);
    }
    if study.design.shares_stimuli() { study.design.trials_per_participant.min(all) } else { all }
}

/// The platform parameters a study keeps, checked; the worker id must be there for a platform,
/// and is normalised to the platform's one spelling ([`crate::study::worker`]).
fn entry_params(platform: Platform, given: &HashMap<String, String>) -> Result<Vec<(String, String)>, WebError> {
    let mut kept = Vec::new();
    for name in platform.entry_params() {
        let Some(value) = given.get(*name) else { continue };
        let value = if platform.worker_param() == Some(*name) {
            worker::normalise(platform, value).map_err(|e| WebError::BadRequest(e.to_string()))?
        } else if value.len() > 200 || value.chars().any(char::is_control) {
            return Err(WebError::BadRequest(format!("the link's parameter {name} is malformed")));
        } else {
            value.clone()
        };
        kept.push((name.to_string(), value));
    }
    if let Some(worker) = platform.worker_param()
        && !kept.iter().any(|(n, _)| n == worker)
    {
        return Err(WebError::BadRequest(format!("this study link needs the {} parameter {worker}; please use the link from {}", platform.as_str(), platform.as_str())));
    }
    Ok(kept)
}

/// Whether study `slug` takes participants now (its status is read each time: the study's
/// cached row does not follow an admin's change).
async fn is_open(app: &AppState, slug: &str) -> Result<bool, WebError> {
    Ok(app.db.study_by_slug(slug).await?.is_some_and(|s| s.status == StudyStatus::Open))
}

fn cookie_name(slug: &str) -> String {
    format!("facslab_{slug}")
}

/// How long a browser keeps the token of the participation it started.
const PARTICIPATION_COOKIE_AGE: std::time::Duration = std::time::Duration::from_secs(7 * 86_400);

/// The participation token this browser holds for study `slug`, if any.
fn held_token<'a>(jar: &'a CookieJar, slug: &str) -> Option<&'a str> {
    jar.get(&cookie_name(slug)).map(|c| c.value())
}


/// Trials past the current one whose media may be fetched already (for preloading).
pub const PRELOAD_AHEAD: i64 = 2;

/// A 429 answer with `Retry-After`.
fn too_many_starts(wait: std::time::Duration) -> Response {
    let message = format!("Too many starts from your network just now. Please try again in {} minute(s).", wait.as_secs().div_ceil(60));
    (StatusCode::TOO_MANY_REQUESTS, [(header::RETRY_AFTER, super::limit::retry_after(wait))], message).into_response()
}

async fn start(State(app): State<AppState>, Path(slug): Path<String>, address: ClientAddress, jar: CookieJar, Form(form): Form<Vec<(String, String)>>) -> Result<Response, WebError> {
    let study = app.study(&slug).await?;
    if let Some(Err(wait)) = address.key().map(|a| app.edge.starts.hit(&a)) {
        return Ok(too_many_starts(wait));
    }
    if !is_open(&app, &slug).await? {
        return Err(WebError::Conflict("this study is not open at the moment".into()));
    }
    let form: HashMap<String, String> = form.into_iter().collect();
    let source = study.design.source_for(|name| form.contains_key(name));
    let platform = source.platform;
    let params = entry_params(platform, &form)?;
    if platform == Platform::Local
        && let Some(token) = held_token(&jar, &slug)
        && app.db.participation(token).await?.is_some_and(|p| p.study_id == study.row.id)
    {
        return Ok(Redirect::to(&format!("/p/{token}")).into_response());
    }
    let worker = match platform.worker_param() {
        Some(name) => params.iter().find(|(n, _)| n == name).map(|(_, v)| v.clone()).unwrap_or_default(),
        None => format!("local-{}", secret_token()),
    };
    let params_json = serde_json::to_string(&params.iter().cloned().collect::<HashMap<_, _>>()).unwrap_or_default();
    let token = match app.db.start_participation(study.row.id, &study.design, source, &worker, &params_json).await? {
        Started::New(token) => token,
        // The participation's token goes only to the browser that holds it already.
        Started::Existing(existing) => match held_token(&jar, &slug) {
            Some(held) if same_secret(&token_sha256(held), &existing) => held.to_string(),
            _ => return started_elsewhere(&app, &study),
        },
        Started::Full => {
            return app.render(
                "landing.html",
                &merge(page(&study, "Full"), json!({ "title": study.design.title, "slug": slug, "params": [], "full": true })),
            );
        }
    };
    let cookie = app.edge.cookie(&cookie_name(&slug), &token, PARTICIPATION_COOKIE_AGE, SameSite::Lax);
    Ok((jar.add(cookie), Redirect::to(&format!("/p/{token}"))).into_response())
}

/// Whether two secrets are equal, in time that does not depend on where they differ.
fn same_secret(a: &str, b: &str) -> bool {
    use subtle::ConstantTimeEq;
    a.len() == b.len() && bool::from(a.as_bytes().ct_eq(b.as_bytes()))
}

/// A worker id that has a participation, from a browser without its cookie: the participation
/// stays where it was started (409), and the page says how to go on there.
fn started_elsewhere(app: &AppState, study: &LoadedStudy) -> Result<Response, WebError> {
    let context = json!({
        "heading": "You started this study in another browser",
        "message": "This study was already started with your id in another browser or on another device. \
                    To go on, open the study link again in the browser where you started it: it takes you back to where you stopped.\n\n\
                    If you cannot use that browser any more, please contact the researchers through the recruitment platform.",
    });
    let mut page = app.render("message.html", &merge(page(study, "Already started"), context))?;
    *page.status_mut() = StatusCode::CONFLICT;
    Ok(page)
}

/// A participation with its study, or 404.
async fn participation(app: &AppState, token: &ParticipationToken) -> Result<(Participation, std::sync::Arc<LoadedStudy>), WebError> {
    let p = app.db.participation(token.as_str()).await?.ok_or(WebError::NotFound)?;
    let study = app.study_by_id(p.study_id).await?;
    Ok((p, study))
}

/// The study of a participation, or 404, for writes that need no more: the writer checks the
/// participation's state itself, and the study behind a token is known from memory after the
/// first request.
async fn participation_study(app: &AppState, token: &ParticipationToken) -> Result<std::sync::Arc<LoadedStudy>, WebError> {
    let study = app.db.participation_study(token.as_str()).await?.ok_or(WebError::NotFound)?;
    app.study_by_id(study).await
}

/// Where a participation goes next.
fn next_url(token: &ParticipationToken, p: &Participation, study: &LoadedStudy, trials: &[TrialRow]) -> String {
    let t = token;
    match p.state {
        SessionState::Completed | SessionState::ScreenedOut | SessionState::Withdrawn | SessionState::Abandoned => format!("/p/{t}/done"),
        _ if !p.consented => format!("/p/{t}/consent"),
        _ if study.design.demographics && !p.has_demographics => format!("/p/{t}/demographics"),
        _ if !trials.iter().any(|t| t.answered) => format!("/p/{t}/instructions"),
        _ => format!("/p/{t}/trial"),
    }
}

async fn resume(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    let (p, study) = participation(&app, &token).await?;
    let trials = app.db.trials(p.id).await?;
    Ok(Redirect::to(&next_url(&token, &p, &study, &trials)).into_response())
}

/// Sends a participant who is not at `step` to where they belong.
async fn at_step(app: &AppState, token: &ParticipationToken, step: &str) -> Result<Result<(Participation, std::sync::Arc<LoadedStudy>, Vec<TrialRow>), Response>, WebError> {
    let (p, study) = participation(app, token).await?;
    let trials = app.db.trials(p.id).await?;
    let next = next_url(token, &p, &study, &trials);
    let here = next.ends_with(step) || (step == "/trial" && next.ends_with("/instructions") && p.state == SessionState::Active);
    if !here {
        return Ok(Err(Redirect::to(&next).into_response()));
    }
    Ok(Ok((p, study, trials)))
}

async fn consent_page(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    let (_, study, _) = match at_step(&app, &token, "/consent").await? {
        Ok(v) => v,
        Err(redirect) => return Ok(redirect),
    };
    app.render("consent.html", &merge(page(&study, "Consent"), json!({ "token": token, "consent": study.design.consent })))
}

/// `POST /p/{token}/consent`: the consent box.
#[derive(serde::Deserialize)]
struct ConsentForm {
    #[serde(default)]
    agree: String,
}

async fn consent(State(app): State<AppState>, token: ParticipationToken, Form(form): Form<ConsentForm>) -> Result<Response, WebError> {
    let study = participation_study(&app, &token).await?;
    if form.agree != "1" {
        return Err(WebError::BadRequest("please tick the consent box to take part, or close this page".into()));
    }
    app.db.give_consent(token.as_str(), &study.design.consent_sha256()).await?;
    Ok(Redirect::to(&format!("/p/{token}")).into_response())
}

fn demographics_context(study: &LoadedStudy, token: &ParticipationToken, error: Option<&str>) -> serde_json::Value {
    merge(
        page(study, "About you"),
        json!({
            "token": token,
            "error": error,
            "questions": [
                { "name": Demographic::Gender.name(), "label": "Gender", "options": GENDERS },
                { "name": Demographic::Ethnicity.name(), "label": "Ethnicity", "options": ETHNICITIES },
                { "name": Demographic::Education.name(), "label": "Highest education", "options": EDUCATION },
            ],
        }),
    )
}

async fn demographics_page(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    let (_, study, _) = match at_step(&app, &token, "/demographics").await? {
        Ok(v) => v,
        Err(redirect) => return Ok(redirect),
    };
    app.render("demographics.html", &demographics_context(&study, &token, None))
}

/// Reads the demographics form; `Err` names the field that is wrong.
fn read_demographics(form: &HashMap<String, String>) -> Result<Demographics, String> {
    let age = match form.get(Demographic::Age.name()).map(|a| a.trim()).filter(|a| !a.is_empty()) {
        None => None,
        Some(a) => match a.parse::<i64>() {
            Ok(v) if (16..=120).contains(&v) => Some(v),
            _ => return Err(format!("Age: \"{a}\" is not an age between 16 and 120.")),
        },
    };
    let pick = |measure: Demographic, options: &[&str]| -> Result<String, String> {
        let name = measure.name();
        let value = form.get(name).map(|v| v.trim()).unwrap_or("");
        if value.is_empty() || options.contains(&value) { Ok(value.to_string()) } else { Err(format!("{name}: \"{value}\" is not one of the choices.")) }
    };
    Ok(Demographics {
        age,
        gender: pick(Demographic::Gender, &GENDERS)?,
        ethnicity: pick(Demographic::Ethnicity, &ETHNICITIES)?,
        education: pick(Demographic::Education, &EDUCATION)?,
    })
}

async fn demographics(State(app): State<AppState>, token: ParticipationToken, Form(form): Form<HashMap<String, String>>) -> Result<Response, WebError> {
    let (p, study) = participation(&app, &token).await?;
    if !p.consented {
        return Ok(Redirect::to(&format!("/p/{token}")).into_response());
    }
    match read_demographics(&form) {
        Ok(d) => match app.db.save_demographics(token.as_str(), &d).await {
            Ok(()) => Ok(Redirect::to(&format!("/p/{token}")).into_response()),
            // Written once: a second post changes nothing.
            Err(crate::db::DbError::Conflict(message)) => {
                let context = json!({ "heading": "Already saved", "message": message, "redirect_url": format!("/p/{token}"), "redirect_label": "Continue" });
                let mut page = app.render("message.html", &merge(page(&study, "About you"), context))?;
                *page.status_mut() = StatusCode::CONFLICT;
                Ok(page)
            }
            Err(e) => Err(e.into()),
        },
        Err(message) => {
            let mut page = app.render("demographics.html", &demographics_context(&study, &token, Some(&message)))?;
            *page.status_mut() = StatusCode::UNPROCESSABLE_ENTITY;
            Ok(page)
        }
    }
}

async fn instructions(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    let (_, study, _) = match at_step(&app, &token, "/instructions").await? {
        Ok(v) => v,
        Err(redirect) => return Ok(redirect),
    };
    app.render("instructions.html", &merge(page(&study, "Instructions"), json!({ "token": token, "instructions": study.design.instructions })))
}

/// The AU checklist, grouped as coders know it.
fn au_groups() -> serde_json::Value {
    let catalog = Catalog::built_in();
    let group = |region: Region| {
        let aus: Vec<_> = catalog.iter().filter(|au| au.region == region).map(|au| json!({ "code": au.code.0, "name": au.name, "unilateral": au.unilateral })).collect();
        json!({ "label": capitalised(region.label()), "aus": aus })
    };
    json!([group(Region::Upper), group(Region::Lower), group(Region::HeadEye)])
}

fn capitalised(text: &str) -> String {
    let mut chars = text.chars();
    chars.next().map(|c| c.to_uppercase().chain(chars).collect()).unwrap_or_default()
}

/// The forced choice's options: the study's label set as declared (name, and the description
/// when the design asks for it).
fn label_choices(design: &crate::study::StudyDesign) -> Vec<serde_json::Value> {
    let set = design.labels;
    let describe = |answer: &str| design.emotion.describe_labels.then(|| set.label(answer).map(|l| l.description.clone())).flatten();
    set.labels().iter().map(|c| json!({ "value": c, "label": set.display(c), "description": describe(c) })).collect()
}

/// The description a rating trial shows: the design's own for the stimulus's label, else the
/// label's declared description.
fn stimulus_description(design: &crate::study::StudyDesign, label: &str) -> Option<String> {
    let declared = || crate::study::labels::Qualified::split(label).resolve().ok().map(|(_, l)| l.description.clone()).filter(|d| !d.is_empty());
    design.rating.descriptions.get(label).cloned().or_else(declared)
}

async fn trial_page(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    let (_, study, trials) = match at_step(&app, &token, "/trial").await? {
        Ok(v) => v,
        Err(redirect) => return Ok(redirect),
    };
    let Some(trial) = trials.iter().find(|t| !t.answered) else {
        return Ok(Redirect::to(&format!("/p/{token}")).into_response());
    };
    let design = &study.design;
    let shown = study.shown(&trial.stimulus_id);
    let stimulus = shown.first().ok_or_else(|| WebError::Internal { context: format!("stimulus {} missing from the study", trial.stimulus_id), source: None })?;
    let done = trials.iter().filter(|t| t.answered).count();
    let attention = trial.check_index.and_then(|i| design.attention.checks.get(i)).map(|c| c.instruction.clone());
    let description = (design.task == TaskKind::Rating).then(|| stimulus_description(design, &stimulus.emotion)).flatten();
    let choices = label_choices(design);
    let items = items_context(design, None);
    let together = shown_together(&study, &trials, trial.position);
    let context = json!({
        "token": token,
        "position": trial.position,
        "idempotency_key": secret_token(),
        "media": stimulus.media,
        "beside": beside_context(&token, trial.position, &shown),
        "fps": stimulus.fps,
        "speeds": crate::study::viewing::SPEEDS.map(|speed| json!({ "label": speed.to_string(), "normal": speed == 1.0 })),
        "practice": trial.kind == TrialKind::Practice,
        "attention": attention,
        "description": description,
        "task": design.task.as_str(),
        "choices": choices,
        "choice_question": if design.labels == LabelSet::emfacs() { "Which emotion does this face show?" } else { "Which of these does this face show?" },
        "au_groups": if design.task == TaskKind::AuCoding { au_groups() } else { json!([]) },
        "coding_intensity": design.au_coding.intensity,
        "coding_side": design.au_coding.side,
        "items": items,
        "screen": screen_context(&token, &study, &together),
        "done": done,
        "total": trials.len(),
        "percent": done * 100 / trials.len().max(1),
        "progress_label": progress_label(done, together.len().max(1), trials.len()),
    });
    app.render("trial.html", &merge(page(&study, "Face"), context))
}

/// A trial's Likert items; on a screen of several trials, each answer field names its trial
/// (`<measure>@<position>`, `study::screen`).
fn items_context(design: &crate::study::StudyDesign, position: Option<i64>) -> serde_json::Value {
    let name = |measure: &str| position.map_or_else(|| measure.to_string(), |p| format!("{measure}@{p}"));
    design
        .items
        .iter()
        .map(|i| json!({ "measure": i.measure, "name": name(i.measure.name()), "prompt": i.prompt, "values": i.values().collect::<Vec<_>>(), "min_label": i.min_label, "max_label": i.max_label }))
        .collect()
}

/// The positions of the screen that starts at the trial at `position` (itself first): that
/// trial alone unless the design shows a label's stimuli side by side.
fn shown_together(study: &LoadedStudy, trials: &[TrialRow], position: i64) -> Vec<i64> {
    if !study.design.rating.side_by_side {
        return vec![position];
    }
    screen::screen_at(&slots(study, trials), position, true).unwrap_or_else(|_| vec![position])
}

/// The trials of a screen of several (`positions`), each with its video and items; `null` for a
/// trial shown alone. The page never says which video is which.
fn screen_context(token: &ParticipationToken, study: &LoadedStudy, positions: &[i64]) -> serde_json::Value {
    if positions.len() < 2 {
        return serde_json::Value::Null;
    }
    let parts: Vec<_> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| json!({ "position": p, "number": i + 1, "url": format!("/p/{token}/media/{p}"), "items": items_context(&study.design, Some(*p)) }))
        .collect();
    json!(parts)
}

/// "3 of 14", or "3–4 of 14" for a screen of two trials.
fn progress_label(done: usize, shown: usize, total: usize) -> String {
    if shown > 1 { format!("{}–{} of {total}", done + 1, done + shown) } else { format!("{} of {total}", done + 1) }
}

/// The media a trial shows beside its first, by part (their URLs say only the position and part).
fn beside_context(token: &ParticipationToken, position: i64, shown: &[&crate::db::studies::StudyStimulus]) -> serde_json::Value {
    let count = shown.len().saturating_sub(1);
    let beside: Vec<_> = shown
        .iter()
        .enumerate()
        .skip(1)
        .map(|(part, s)| json!({ "url": format!("/p/{token}/media/{position}/{part}"), "media": s.media, "label": format!("The same face, picture {part} of {count}") }))
        .collect();
    json!(beside)
}

/// The plan as the screens see it: each trial's position, kind and stimulus label.
fn slots<'a>(study: &'a LoadedStudy, trials: &[TrialRow]) -> Vec<Slot<'a>> {
    trials.iter().map(|t| Slot { position: t.position, kind: t.kind, label: study.stimuli.get(&t.stimulus_id).map_or("", |s| s.emotion.as_str()) }).collect()
}

/// The positions of the screen a save at `position` answers (that trial alone unless the design
/// shows a label's stimuli side by side); a trial shown beside another is saved with it.
async fn screen_positions(app: &AppState, token: &ParticipationToken, study: &LoadedStudy, position: i64) -> Result<Vec<i64>, WebError> {
    if !study.design.rating.side_by_side {
        return Ok(vec![position]);
    }
    let (p, _) = participation(app, token).await?;
    let trials = app.db.trials(p.id).await?;
    match screen::screen_at(&slots(study, &trials), position, true) {
        Ok(positions) => Ok(positions),
        // The writer names a missing trial as it does for every design.
        Err(ScreenError::NoTrial(_)) => Ok(vec![position]),
        Err(e @ ScreenError::NotFirst { .. }) => Err(WebError::Conflict(e.to_string())),
    }
}

/// Validates and stores the answers of one screen (one trial, or a label's trials side by
/// side, stored together); returns where the participant goes next.
async fn save(app: &AppState, token: &ParticipationToken, position: i64, submission: Submission) -> Result<(SaveOutcome, String), WebError> {
    let study = participation_study(app, token).await?;
    let positions = screen_positions(app, token, &study, position).await?;
    let mut parts = Vec::with_capacity(positions.len());
    for (position, part) in screen::split(&submission, &positions)? {
        let answer = part.answer(&study.design).map_err(|e| screen::named_for(e, position, positions.len()))?;
        parts.push((position, part.idempotency_key, answer));
    }
    let timing = SaveTiming { rt_ms: submission.rt_ms, video_ended: submission.video_ended, load_failed: submission.load_failed, viewing: submission.viewing };
    let outcome = match parts.as_slice() {
        [(position, key, answer)] => app.db.save_response(token.as_str(), *position, key, answer, timing, &study.design).await?,
        _ => app.db.save_screen(token.as_str(), &parts, timing, &study.design).await?,
    };
    let next = if outcome.state == SessionState::Active && outcome.remaining > 0 { format!("/p/{token}/trial") } else { format!("/p/{token}/done") };
    Ok((outcome, next))
}

async fn save_form(State(app): State<AppState>, token: ParticipationToken, TrialPosition(position): TrialPosition, Form(form): Form<Vec<(String, String)>>) -> Result<Response, WebError> {
    let submission = Submission::from_form(form)?;
    match save(&app, &token, position, submission).await {
        Ok((_, next)) => Ok(Redirect::to(&next).into_response()),
        Err(WebError::Conflict(_)) => Ok(Redirect::to(&format!("/p/{token}")).into_response()),
        Err(e) => Err(e),
    }
}

async fn save_json(State(app): State<AppState>, token: ParticipationToken, TrialPosition(position): TrialPosition, body: axum::body::Bytes) -> Response {
    let submission: Submission = match serde_json::from_slice(&body) {
        Ok(s) => s,
        Err(e) => return WebError::BadRequest(format!("the save is not valid JSON: {e}")).json(),
    };
    match save(&app, &token, position, submission).await {
        Ok((outcome, next)) => Json(json!({ "saved": format!("{:?}", outcome.saved).to_lowercase(), "next": next, "remaining": outcome.remaining })).into_response(),
        Err(WebError::Conflict(message)) => (StatusCode::CONFLICT, Json(json!({ "error": message, "next": format!("/p/{token}") }))).into_response(),
        Err(e) => e.json(),
    }
}

/// The file of the trial at `position` (its `part`: 0 for its first medium, 1… for those shown
/// beside it) if the participant may fetch it now: the participant is at the trials (consent and
/// the design's steps done) and the trial is the current one, an answered one or one of the
/// [`PRELOAD_AHEAD`] after the current one (and the rest of a side-by-side screen); the file lies directly under the set's `media/`.
/// Anything else is 404.
async fn reachable_media(app: &AppState, token: &ParticipationToken, position: i64, part: usize) -> Result<(std::path::PathBuf, Media), WebError> {
    let (p, study) = participation(app, token).await?;
    let at_trials = p.state == SessionState::Active && (p.has_demographics || !study.design.demographics);
    if !at_trials {
        return Err(WebError::NotFound);
    }
    let trials = app.db.trials(p.id).await?;
    let current = trials.iter().find(|t| !t.answered).map_or(i64::MAX, |t| t.position);
    // A screen shows up to MAX_SIDE_BY_SIDE trials from the current one on.
    let ahead = if study.design.rating.side_by_side { PRELOAD_AHEAD + screen::MAX_SIDE_BY_SIDE as i64 - 1 } else { PRELOAD_AHEAD };
    let trial = trials.iter().find(|t| t.position == position && position <= current.saturating_add(ahead)).ok_or(WebError::NotFound)?;
    let shown = study.shown(&trial.stimulus_id);
    let stimulus = shown.get(part).filter(|s| crate::stimuli::manifest::is_media_path(&s.file)).ok_or(WebError::NotFound)?;
    Ok((study.set_dir.join(&stimulus.file), stimulus.media))
}

/// The first medium of a trial, by position only (the URL says nothing about what it shows).
async fn media(State(app): State<AppState>, token: ParticipationToken, TrialPosition(position): TrialPosition, request: axum::extract::Request) -> Result<Response, WebError> {
    let (file, kind) = reachable_media(&app, &token, position, 0).await?;
    serve_media(&app, &file, kind, request).await
}

/// A medium shown beside a trial's first, by position and part only.
async fn media_part(
    State(app): State<AppState>,
    token: ParticipationToken,
    TrialPosition(position): TrialPosition,
    MediaPart(part): MediaPart,
    request: axum::extract::Request,
) -> Result<Response, WebError> {
    let (file, kind) = reachable_media(&app, &token, position, part).await?;
    serve_media(&app, &file, kind, request).await
}

/// Serves a stimulus file. tower-http's `ServeFile` answers byte ranges (video elements seek
/// with them) and `If-Modified-Since`/`If-None-Match`-style revalidation; the type is the
/// stimulus's [`Media`].
async fn serve_media(app: &AppState, file: &std::path::Path, kind: Media, request: axum::extract::Request) -> Result<Response, WebError> {
    let served = ServeFile::new(file).try_call(request).await.map_err(|e| WebError::internal("reading a stimulus file", e))?;
    let mut response = served.map(axum::body::Body::new);
    if response.status() == StatusCode::NOT_FOUND {
        return Err(WebError::internal("a stimulus file is missing", format!("{} is not there", file.display())));
    }
    let headers = response.headers_mut();
    if headers.contains_key(header::CONTENT_TYPE) {
        headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(kind.content_type()));
    }
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("private, max-age=3600"));
    // Revalidation still works (a file built before the server started is older than this time),
    // but no file's own time is sent.
    if headers.contains_key(header::LAST_MODIFIED) {
        headers.insert(header::LAST_MODIFIED, app.edge.media_last_modified.clone());
    }
    headers.remove(header::ETAG);
    Ok(response)
}

/// The end of a participation: debrief, completion code and the platform's redirect (only
/// reachable once the last save is stored), or the screen-out, withdrawal or expiry message.
async fn done(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    let (p, study) = participation(&app, &token).await?;
    let r = study.design.source_of(&p.platform);
    let params: HashMap<String, String> = serde_json::from_str(&p.platform_params).unwrap_or_default();
    let (heading, message, code) = match p.state {
        SessionState::Completed => ("Thank you!", study.design.debrief.clone(), r.completion_code.clone()),
        SessionState::ScreenedOut => (
            "Thank you for your time",
            "Some of the check questions were not answered as asked, so this session has ended. Your answers are kept and will not be used.".into(),
            r.screened_out_code.clone(),
        ),
        SessionState::Withdrawn => ("You have withdrawn", "You have withdrawn from this study. Your answers will not be used. You can close this page.".into(), String::new()),
        SessionState::Abandoned => ("This session has expired", "This session was inactive for too long and has ended. Please contact the researchers if you think this is a mistake.".into(), String::new()),
        _ => return Ok(Redirect::to(&format!("/p/{token}")).into_response()),
    };
    let completed = p.state == SessionState::Completed;
    let mut context = json!({ "heading": heading, "message": message, "code": code });
    match r.platform {
        Platform::Prolific if !code.is_empty() && (completed || p.state == SessionState::ScreenedOut) => {
            context["redirect_url"] = json!(format!("https://app.prolific.com/submissions/complete?cc={}", urlencode(&code)));
            context["redirect_label"] = json!("Return to Prolific");
        }
        Platform::Sona if completed => {
            let id = params.get("id").cloned().unwrap_or_default();
            context["redirect_url"] = json!(r.sona_credit_url.replace("{id}", &urlencode(&id)));
            context["redirect_label"] = json!("Return to SONA and receive your credit");
        }
        Platform::Mturk if completed => {
            let host = if r.mturk_sandbox { "https://workersandbox.mturk.com" } else { "https://www.mturk.com" };
            context["mturk_action"] = json!(format!("{host}/mturk/externalSubmit"));
            context["mturk_assignment"] = json!(params.get("assignmentId").cloned().unwrap_or_default());
        }
        _ => {}
    }
    app.render("message.html", &merge(page(&study, heading), context))
}

/// Percent-encodes `text` for a URL's query or path: everything but RFC 3986's unreserved
/// characters.
fn urlencode(text: &str) -> String {
    const UNRESERVED: &percent_encoding::AsciiSet = &percent_encoding::NON_ALPHANUMERIC.remove(b'-').remove(b'_').remove(b'.').remove(b'~');
    percent_encoding::utf8_percent_encode(text, UNRESERVED).to_string()
}

async fn withdraw_page(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    let (p, study) = participation(&app, &token).await?;
    if !p.state.is_open() {
        return Ok(Redirect::to(&format!("/p/{token}/done")).into_response());
    }
    let context = json!({
        "heading": "Withdraw from the study?",
        "message": "You can stop at any time without giving a reason. If you withdraw, your answers will not be used.",
        "confirm_action": format!("/p/{token}/withdraw"),
        "confirm_label": "Withdraw",
        "back_url": format!("/p/{token}"),
    });
    app.render("message.html", &merge(page(&study, "Withdraw"), context))
}

async fn withdraw(State(app): State<AppState>, token: ParticipationToken) -> Result<Response, WebError> {
    participation(&app, &token).await?;
    app.db.withdraw(token.as_str()).await?;
    Ok(Redirect::to(&format!("/p/{token}/done")).into_response())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demographics_are_checked() {
        let form = |pairs: &[(&str, &str)]| pairs.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect::<HashMap<_, _>>();
        assert_eq!(read_demographics(&form(&[("age", "31"), ("gender", "female")])).unwrap().age, Some(31));
        assert!(read_demographics(&form(&[("age", "7")])).unwrap_err().starts_with("Age"));
        assert!(read_demographics(&form(&[("ethnicity", "martian")])).unwrap_err().starts_with("ethnicity"));
        assert_eq!(read_demographics(&form(&[])).unwrap(), Demographics::default());
    }

    #[test]
    fn platform_links_need_the_worker_id() {
        let given: HashMap<String, String> = [("PROLIFIC_PID".to_string(), " 5F1A2B3C4D5E6F708192A3B4\u{200b}".to_string()), ("other".to_string(), "x".to_string())].into();
        assert_eq!(entry_params(Platform::Prolific, &given).unwrap(), vec![("PROLIFIC_PID".to_string(), "5f1a2b3c4d5e6f708192a3b4".to_string())]);
        assert!(entry_params(Platform::Mturk, &given).is_err());
        assert!(entry_params(Platform::Local, &given).unwrap().is_empty());
        assert_eq!(urlencode("a b&c"), "a%20b%26c");
    }
}
