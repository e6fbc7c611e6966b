//! `frusta` as a client of `frusta-server`: which server to talk to, and
//! the commands that run there.

pub mod http;
pub mod ir;
mod problem;
pub mod scenes;
pub mod stream;

use std::error::Error;

use glam::Vec3;
use serde_json::{json, Value};

/// A server named by `--server` (or `FRUSTA_SERVER`), with the key that
/// `--api-key` (or `FRUSTA_API_KEY`) gives.
pub struct Server {
    /// `http://host:port` with no trailing `/`, so routes append as-is.
    base: String,
    api_key: Option<String>,
    agent: ureq::Agent,
}

impl Server {
    pub fn new(url: Option<&str>, api_key: Option<&str>) -> Result<Self, Box<dyn Error>> {
        let url =
            url.ok_or("this command runs on a server: give --server URL or set FRUSTA_SERVER")?;
        if !(url.starts_with("http://") || url.starts_with("https://")) {
            return Err(format!("--server {url}: expected an http:// or https:// URL").into());
        }
        Ok(Self {
            base: url.trim_end_matches('/').to_owned(),
            api_key: api_key.map(str::to_owned),
            agent: http::agent(),
        })
    }

    /// The WebSocket URL of `path`: `ws://` for `http://`, `wss://` for `https://`.
    fn ws_url(&self, path: &str) -> String {
        format!("ws{}{path}", self.base.trim_start_matches("http"))
    }

    /// The `Authorization` header value, if a key was given.
    fn bearer(&self) -> Option<String> {
        self.api_key.as_ref().map(|k| format!("Bearer {k}"))
    }
}

/// One point as the server's `sources` and `listeners` lists take it.
fn points(position: Vec3) -> Value {
    json!([{ "position": position.to_array() }])
}

/// `id` as one URL path segment: letters, digits, `-`, `_` and `~` stay,
/// the rest (`.` too, so `..` cannot climb) is percent-encoded, so an id
/// cannot reach another route.
fn segment(id: &str) -> String {
    id.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'~' => {
                char::from(b).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_stay_one_segment() {
        assert_eq!(segment("hall-10k_a"), "hall-10k_a");
        assert_eq!(segment("../x y"), "%2E%2E%2Fx%20y");
    }

    #[test]
    fn websocket_urls_follow_the_scheme() {
        let server = |url| Server::new(Some(url), None).expect("server");
        assert_eq!(server("http://h:1/").ws_url("/s"), "ws://h:1/s");
        assert_eq!(server("https://h").ws_url("/s"), "wss://h/s");
        assert!(Server::new(Some("h:1"), None).is_err());
        assert!(Server::new(None, None).is_err());
    }
}
