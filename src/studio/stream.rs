//! The live stream: an application sends expression updates over a WebSocket and gets a frame
//! back for each, as fast as they render.
//!
//! Protocol (`GET /api/v1/stream`, upgraded to a WebSocket):
//! - client → server, text: `{"seq": 7, "expression": "6+12C", "identity": "wf1", "size": "485x480"}`
//!   (`seq` is the client's number for the update; `identity` and `size` as in `POST /api/v1/render`);
//! - server → client, binary: the 8-byte big-endian `seq` followed by the PNG of that update, the
//!   same bytes `POST /api/v1/render` gives; or text `{"seq": 7, "error": "…", "field": "…", …}`
//!   when the update is refused.
//!
//! Invariant: every update gets exactly one answer, in the order the updates arrived; an update is
//! read only once the previous one is answered, so a fast sender is slowed by the socket, never
//! by a growing queue in the server.

use axum::extract::State;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::response::Response;
use serde::Deserialize;

use super::{RenderRequest, RequestError, StudioState};

/// Largest update message.
pub const MAX_UPDATE_BYTES: usize = 16 * 1024;

/// One expression update.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Update {
    seq: u64,
    expression: String,
    #[serde(default)]
    identity: Option<String>,
    #[serde(default)]
    size: Option<String>,
}

/// Upgrades the connection and runs the session.
pub async fn upgrade(ws: WebSocketUpgrade, State(state): State<StudioState>) -> Response {
    ws.max_message_size(MAX_UPDATE_BYTES).max_frame_size(MAX_UPDATE_BYTES).on_upgrade(move |socket| session(socket, state))
}

async fn session(mut socket: WebSocket, state: StudioState) {
    while let Some(Ok(message)) = socket.recv().await {
        let reply = match message {
            Message::Text(text) => answer(&state, text.as_str()).await,
            Message::Close(_) => break,
            _ => continue,
        };
        if socket.send(reply).await.is_err() {
            break;
        }
    }
}

/// Renders one update: the frame, or the error as JSON text.
async fn answer(state: &StudioState, text: &str) -> Message {
    let update: Update = match serde_json::from_str(text) {
        Ok(update) => update,
        Err(e) => {
            let seq = serde_json::from_str::<serde_json::Value>(text).ok().and_then(|v| v["seq"].as_u64());
            return refusal(seq, &RequestError::Json(e.to_string()));
        }
    };
    let request = RenderRequest { expression: Some(update.expression), identity: update.identity, size: update.size, ..RenderRequest::default() };
    match state.render(request).await {
        Ok(rendered) => {
            let mut frame = Vec::with_capacity(8 + rendered.bytes.len());
            frame.extend_from_slice(&update.seq.to_be_bytes());
            frame.extend_from_slice(&rendered.bytes);
            Message::Binary(frame.into())
        }
        Err(e) => refusal(Some(update.seq), &e),
    }
}

fn refusal(seq: Option<u64>, error: &RequestError) -> Message {
    let mut json = error.to_json();
    json["seq"] = seq.map_or(serde_json::Value::Null, Into::into);
    Message::Text(json.to_string().into())
}
