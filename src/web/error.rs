//! Errors at the HTTP edge: each becomes a status code and a clear message (HTML for pages,
//! JSON for the save API and the export API).

use axum::Json;
use axum::http::StatusCode;
use axum::response::{Html, IntoResponse, Response};

use crate::db::DbError;
use crate::study::AnswerError;

#[derive(Debug, thiserror::Error)]
pub enum WebError {
    #[error("not found")]
    NotFound,
    #[error("{0}")]
    BadRequest(String),
    #[error("{0}")]
    Invalid(AnswerError),
    #[error("{0}")]
    Conflict(String),
    #[error("please log in")]
    Unauthorized,
    #[error("{0}")]
    Forbidden(String),
    #[error("internal error: {0}")]
    Internal(String),
}

impl WebError {
    pub fn status(&self) -> StatusCode {
        match self {
            WebError::NotFound => StatusCode::NOT_FOUND,
            WebError::BadRequest(_) => StatusCode::BAD_REQUEST,
            WebError::Invalid(_) => StatusCode::UNPROCESSABLE_ENTITY,
            WebError::Conflict(_) => StatusCode::CONFLICT,
            WebError::Unauthorized => StatusCode::UNAUTHORIZED,
            WebError::Forbidden(_) => StatusCode::FORBIDDEN,
            WebError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// The message shown to people (internal details stay in the server log).
    pub fn public_message(&self) -> String {
        match self {
            WebError::Internal(_) => "Something went wrong on our side. Please try again in a moment.".into(),
            other => other.to_string(),
        }
    }

    /// The error as JSON: `{"error": "...", "field": "..."}`.
    pub fn json(self) -> Response {
        self.log();
        let field = match &self {
            WebError::Invalid(e) => Some(e.field.clone()),
            _ => None,
        };
        (self.status(), Json(serde_json::json!({ "error": self.public_message(), "field": field }))).into_response()
    }

    fn log(&self) {
        if let WebError::Internal(detail) = self {
            eprintln!("error: {detail}");
        }
    }
}

impl From<DbError> for WebError {
    fn from(e: DbError) -> WebError {
        match e {
            DbError::NotFound(_) => WebError::NotFound,
            DbError::Conflict(m) => WebError::Conflict(m),
            DbError::Design(e) => WebError::BadRequest(e.to_string()),
            other => WebError::Internal(other.to_string()),
        }
    }
}

impl From<AnswerError> for WebError {
    fn from(e: AnswerError) -> WebError {
        WebError::Invalid(e)
    }
}

impl IntoResponse for WebError {
    fn into_response(self) -> Response {
        self.log();
        let message = html_escape(&self.public_message());
        let page = format!(
            "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{code}</title><link rel=\"stylesheet\" href=\"/static/style.css\"></head><body><main><section class=\"card\"><h1>{reason}</h1><p role=\"alert\">{message}</p></section></main></body></html>",
            code = self.status().as_u16(),
            reason = self.status().canonical_reason().unwrap_or("Error"),
        );
        (self.status(), Html(page)).into_response()
    }
}

pub fn html_escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&#39;")
}
