//! Rate limits kept in memory: fixed windows of counted events per key (an account, a client
//! address).
//!
//! In: a key per event. Out: `Ok`, or how long until the key may try again (a 429's
//! `Retry-After`). Invariants: memory is bounded ([`MAX_KEYS`] keys; expired windows are
//! dropped first, and when every key is still live a new key is refused rather than let in
//! unlimited); a key's window starts at its first counted event.

use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use axum::extract::{ConnectInfo, FromRequestParts};
use axum::http::HeaderMap;
use axum::http::request::Parts;

use super::AppState;

/// Most keys one limiter tracks.
pub const MAX_KEYS: usize = 100_000;

#[derive(Debug, Clone, Copy)]
struct Window {
    started: Instant,
    count: u32,
}

/// At most `max` events per key in each window of length `window`.
#[derive(Debug)]
pub struct Limiter {
    max: u32,
    window: Duration,
    keys: Mutex<HashMap<String, Window>>,
}

impl Limiter {
    pub fn new(max: u32, window: Duration) -> Limiter {
        Limiter { max, window, keys: Mutex::default() }
    }

    /// How long `key` must wait before its next event counts, if it is at its limit now.
    pub fn check(&self, key: &str) -> Result<(), Duration> {
        let now = Instant::now();
        let keys = self.keys.lock().map_err(|_| self.window)?;
        match keys.get(key) {
            Some(w) if now.duration_since(w.started) < self.window && w.count >= self.max => Err(self.window - now.duration_since(w.started)),
            _ => Ok(()),
        }
    }

    /// Counts one event for `key`; `Err` (the wait) when this event is over the limit.
    pub fn hit(&self, key: &str) -> Result<(), Duration> {
        let now = Instant::now();
        let mut keys = self.keys.lock().map_err(|_| self.window)?;
        if keys.len() >= MAX_KEYS && !keys.contains_key(key) {
            keys.retain(|_, w| now.duration_since(w.started) < self.window);
            if keys.len() >= MAX_KEYS {
                return Err(self.window);
            }
        }
        let w = keys.entry(key.to_string()).or_insert(Window { started: now, count: 0 });
        if now.duration_since(w.started) >= self.window {
            *w = Window { started: now, count: 0 };
        }
        if w.count >= self.max {
            return Err(self.window - now.duration_since(w.started));
        }
        w.count += 1;
        Ok(())
    }

    /// Takes one counted event of `key` off again (a successful login from an address).
    pub fn forgive(&self, key: &str) {
        if let Ok(mut keys) = self.keys.lock()
            && let Some(w) = keys.get_mut(key)
        {
            w.count = w.count.saturating_sub(1);
        }
    }

    /// Forgets `key`'s events (a successful login clears the account's failures).
    pub fn clear(&self, key: &str) {
        if let Ok(mut keys) = self.keys.lock() {
            keys.remove(key);
        }
    }
}

/// The client's address, as an extractor ([`client_address`]); `None` when the app runs
/// without connection info (as the load benchmark's in-process server does), and then no
/// per-address limit applies.
#[derive(Debug, Clone, Copy)]
pub struct ClientAddress(pub Option<IpAddr>);

impl FromRequestParts<AppState> for ClientAddress {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Self::Rejection> {
        Ok(ClientAddress(client_address(&parts.headers, parts.extensions.get::<ConnectInfo<SocketAddr>>(), state.edge.config.trusted_proxy)))
    }
}

impl ClientAddress {
    /// The key of this address in a limiter (`None` without an address).
    pub fn key(&self) -> Option<String> {
        self.0.map(|a| a.to_string())
    }
}

/// The client's address: the connection's peer, or with `trusted_proxy` the address the proxy
/// put last in `X-Forwarded-For`. `None` when the server was started without connection info.
pub fn client_address(headers: &HeaderMap, connection: Option<&ConnectInfo<SocketAddr>>, trusted_proxy: bool) -> Option<IpAddr> {
    if trusted_proxy {
        let forwarded = headers.get_all("x-forwarded-for").iter().filter_map(|v| v.to_str().ok()).flat_map(|v| v.split(',')).last();
        if let Some(address) = forwarded.and_then(|a| a.trim().parse().ok()) {
            return Some(address);
        }
    }
    connection.map(|c| c.0.ip())
}

/// Whole seconds to wait, at least one (the value of `Retry-After`).
pub fn retry_after(wait: Duration) -> String {
    wait.as_secs().max(1).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_is_limited_within_its_window_and_others_are_not() {
        let limiter = Limiter::new(3, Duration::from_secs(60));
        for _ in 0..3 {
            assert!(limiter.hit("a").is_ok());
        }
        let wait = limiter.hit("a").unwrap_err();
        assert!(wait > Duration::from_secs(58) && wait <= Duration::from_secs(60));
        assert!(limiter.check("a").is_err() && limiter.check("b").is_ok() && limiter.hit("b").is_ok());
        limiter.clear("a");
        assert!(limiter.hit("a").is_ok());
        let short = Limiter::new(1, Duration::from_millis(20));
        assert!(short.hit("k").is_ok() && short.hit("k").is_err());
        std::thread::sleep(Duration::from_millis(30));
        assert!(short.hit("k").is_ok(), "a new window");
    }
}
