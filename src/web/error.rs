//! Errors at the HTTP edge: each becomes a status code and a clear message (HTML for pages,
//! JSON for the save API and the export API).
//!
//! Statuses: 404 not found, 400 a malformed request, 422 content that fails validation (an
//! answer, a design, a password), 409 a clash with what is stored, 401/403 authentication and
//! roles, 503 (with `Retry-After`) when nothing was stored and the same request may be sent
//! again, 500 otherwise. An internal error keeps its source for the server log; people see a
//! fixed message.

use axum::Json;
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Response};

use crate::db::DbError;
use crate::study::AnswerError;

/// The source of an internal error.
pub type Source = Box<dyn std::error::Error + Send + Sync + 'static>;

#[derive(Debug, thiserror::Error)]
pub enum WebError {
    #[error("not found")]
    NotFound,
    #[error("{0}")]
    BadRequest(String),
    /// An answer that fails its checks (names the field).
    #[error("{0}")]
    Invalid(AnswerError),
    /// Other content that fails validation.
    #[error("{0}")]
    Unprocessable(String),
    #[error("{0}")]
    Conflict(String),
    #[error("please log in")]
    Unauthorized,
    #[error("{0}")]
    Forbidden(String),
    /// Nothing was done; the same request may be sent again shortly.
    #[error("{0}")]
    Unavailable(String),
    #[error("internal error: {context}")]
    Internal {
        context: String,
        #[source]
        source: Option<Source>,
    },
}

impl WebError {
    /// An internal error with what was being done and why it failed.
    pub fn internal(context: impl Into<String>, source: impl Into<Source>) -> WebError {
        WebError::Internal { context: context.into(), source: Some(source.into()) }
    }

    pub fn status(&self) -> StatusCode {
        match self {
            WebError::NotFound => StatusCode::NOT_FOUND,
            WebError::BadRequest(_) => StatusCode::BAD_REQUEST,
            WebError::Invalid(_) | WebError::Unprocessable(_) => StatusCode::UNPROCESSABLE_ENTITY,
            WebError::Conflict(_) => StatusCode::CONFLICT,
            WebError::Unauthorized => StatusCode::UNAUTHORIZED,
            WebError::Forbidden(_) => StatusCode::FORBIDDEN,
            WebError::Unavailable(_) => StatusCode::SERVICE_UNAVAILABLE,
            WebError::Internal { .. } => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// The message shown to people (internal details stay in the server log).
    pub fn public_message(&self) -> String {
        match self {
            WebError::Internal { .. } => "Something went wrong on our side. Please try again in a moment.".into(),
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
        let body = (self.status(), Json(serde_json::json!({ "error": self.public_message(), "field": field })));
        self.with_retry(body.into_response())
    }

    /// A 503 tells when to try again.
    fn with_retry(&self, mut response: Response) -> Response {
        if matches!(self, WebError::Unavailable(_)) {
            response.headers_mut().insert(header::RETRY_AFTER, header::HeaderValue::from_static("1"));
        }
        response
    }

    /// Internal errors go to the server log with their chain of causes.
    fn log(&self) {
        if let WebError::Internal { context, source } = self {
            let mut causes = String::new();
            let mut cause: Option<&(dyn std::error::Error + 'static)> = source.as_deref().map(|s| s as _);
            while let Some(c) = cause {
                causes.push_str(&format!(": {c}"));
                cause = c.source();
            }
            tracing::error!("{context}{causes}");
        }
    }
}

impl From<DbError> for WebError {
    fn from(e: DbError) -> WebError {
        match e {
            DbError::NotFound(_) => WebError::NotFound,
            DbError::Conflict(m) => WebError::Conflict(m),
            DbError::Invalid(m) => WebError::Unprocessable(m),
            DbError::Design(e) => WebError::Unprocessable(e.to_string()),
            DbError::Unavailable(m) => WebError::Unavailable(m),
            other => WebError::internal("database", other),
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
        self.with_retry((self.status(), Html(page)).into_response())
    }
}

pub fn html_escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&#39;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_follow_the_kind_of_failure() {
        assert_eq!(WebError::from(DbError::Unavailable("closing".into())).status(), StatusCode::SERVICE_UNAVAILABLE);
        assert_eq!(WebError::from(DbError::Invalid("weak".into())).status(), StatusCode::UNPROCESSABLE_ENTITY);
        assert_eq!(WebError::from(DbError::Conflict("answered".into())).status(), StatusCode::CONFLICT);
        let internal = WebError::from(DbError::Internal("unreadable".into()));
        assert_eq!(internal.status(), StatusCode::INTERNAL_SERVER_ERROR);
        assert_eq!(std::error::Error::source(&internal).map(|s| s.to_string()).as_deref(), Some("unreadable"), "the cause is kept");
        assert!(!internal.public_message().contains("unreadable"));
        let response = WebError::Unavailable("busy".into()).json();
        assert_eq!(response.headers()[header::RETRY_AFTER], "1");
    }
}
