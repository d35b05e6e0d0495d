//! The server's log: one line per request, and warnings and errors, on stderr.
//!
//! In: requests and responses passing the router's `TraceLayer`. Out: `tracing` events whose
//! span names the request by its id (`x-request-id`, made here or kept from the client), its
//! method and its route template (`/p/{token}/trial`), then the status and the latency in
//! milliseconds. Invariant: a request's path and query are never logged, only the template
//! axum matched, so participation tokens and other secrets in URLs stay out of the log;
//! cookies and headers are not logged either.
//!
//! [`install`] writes the events to stderr, filtered by `RUST_LOG` (`tracing-subscriber`'s
//! `EnvFilter` syntax), by default `facslab=info`.

use std::time::Duration;

use axum::extract::{MatchedPath, Request};
use axum::response::Response;
use tower_http::request_id::RequestId;
use tracing::Span;

/// The filter used when `RUST_LOG` is not set.
pub const DEFAULT_FILTER: &str = "facslab=info";

/// Sends the log to stderr (ANSI colours only on a terminal). Does nothing when a subscriber is
/// installed already.
pub fn install() {
    use std::io::IsTerminal;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(DEFAULT_FILTER));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_ansi(std::io::stderr().is_terminal()).try_init();
}

/// The span of one request: its id, method and route template (never its path).
pub fn request_span(request: &Request) -> Span {
    let id = request.extensions().get::<RequestId>().and_then(|id| id.header_value().to_str().ok()).unwrap_or("-");
    let route = request.extensions().get::<MatchedPath>().map_or("(no route)", MatchedPath::as_str);
    tracing::info_span!("request", id = %id, method = %request.method(), route = %route)
}

/// The line that ends a request: its status and how long the answer took.
pub fn response_line(response: &Response, latency: Duration, _span: &Span) {
    let status = response.status().as_u16();
    let latency_ms = latency.as_secs_f64() * 1000.0;
    if response.status().is_server_error() {
        tracing::warn!(status, latency_ms = format_args!("{latency_ms:.1}"), "answered");
    } else {
        tracing::info!(status, latency_ms = format_args!("{latency_ms:.1}"), "answered");
    }
}
