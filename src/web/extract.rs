//! Typed pieces of participant URLs, parsed by extractors before a handler runs.
//!
//! In: the path parameters `{token}`, `{position}` and `{part}`. Out: a [`ParticipationToken`]
//! (32 lower-case hex digits, the secret that addresses a participation), a [`TrialPosition`]
//! and a [`MediaPart`].
//! Invariant: a malformed value is a 404, like a token that does not exist, so the answer says
//! nothing about which tokens are real; the database only ever sees a token's SHA-256
//! (`crate::db::token_sha256`).

use std::collections::HashMap;
use std::fmt;

use axum::extract::{FromRequestParts, Path};
use axum::http::request::Parts;

use super::WebError;

/// The secret token of a participation, as it appears in its URLs and its cookie.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParticipationToken(String);

impl ParticipationToken {
    /// A token if `text` has a token's shape (32 lower-case hex digits).
    pub fn parse(text: &str) -> Option<ParticipationToken> {
        let shaped = text.len() == 32 && text.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
        shaped.then(|| ParticipationToken(text.to_string()))
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for ParticipationToken {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl serde::Serialize for ParticipationToken {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.0)
    }
}

/// The value of path parameter `name`, or 404.
async fn path_param<S: Send + Sync>(parts: &mut Parts, state: &S, name: &str) -> Result<String, WebError> {
    let Path(mut params) = Path::<HashMap<String, String>>::from_request_parts(parts, state).await.map_err(|_| WebError::NotFound)?;
    params.remove(name).ok_or(WebError::NotFound)
}

impl<S: Send + Sync> FromRequestParts<S> for ParticipationToken {
    type Rejection = WebError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, WebError> {
        ParticipationToken::parse(&path_param(parts, state, "token").await?).ok_or(WebError::NotFound)
    }
}

/// A trial's position in a participant's plan (0 is the first).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrialPosition(pub i64);

impl<S: Send + Sync> FromRequestParts<S> for TrialPosition {
    type Rejection = WebError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, WebError> {
        path_param(parts, state, "position").await?.parse().ok().filter(|p| (0..1_000_000).contains(p)).map(TrialPosition).ok_or(WebError::NotFound)
    }
}

/// One of the media a trial shows beside its first (`/p/{token}/media/{position}/{part}`,
/// 1-based; the first is `/p/{token}/media/{position}`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MediaPart(pub usize);

impl<S: Send + Sync> FromRequestParts<S> for MediaPart {
    type Rejection = WebError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, WebError> {
        path_param(parts, state, "part").await?.parse().ok().filter(|p| (1..=64).contains(p)).map(MediaPart).ok_or(WebError::NotFound)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_have_one_shape() {
        assert!(ParticipationToken::parse("0123456789abcdef0123456789abcdef").is_some());
        for bad in ["0123456789ABCDEF0123456789abcdef", "0123456789abcdef", "0123456789abcdef0123456789abcdeg", ""] {
            assert!(ParticipationToken::parse(bad).is_none(), "{bad}");
        }
    }
}
