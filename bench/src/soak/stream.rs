//! A WebSocket session: open a stream on one scene, send a few updates
//! closed loop (the listener and the source moving, and on a client's own
//! room now and then the door), then close with the handshake, as a
//! well-behaved client does.

use std::time::{Duration, Instant};

use tungstenite::Message;

use super::client::Client;
use super::tally::{ms_since, Outcome};
use crate::serve::positions;
use crate::serve::stream::{connect, read_answer, Socket};

/// How long the close handshake may take before it counts as an error.
const CLOSE_LIMIT: Duration = Duration::from_secs(60);

impl Client<'_> {
    pub(super) fn stream(&mut self) {
        let at = self.pick();
        let id = self.id(at);
        let door = at.is_some_and(|i| self.own[i].json);
        let ws = self.base.replacen("http", "ws", 1);
        let path = format!("/v1/scenes/{id}/stream");
        let what = || format!("GET {path} (upgrade)");
        let t = Instant::now();
        let mut socket = match connect(&format!("{ws}{path}")) {
            Ok(socket) => {
                self.record("stream_open", what, ms_since(t), &Outcome::Ok);
                socket
            }
            // Refused: a 503 with `Retry-After` (`--max-streams`) is
            // backpressure; any other answer, 2xx included (no upgrade),
            // is not.
            Err(tungstenite::Error::Http(r)) => {
                let status = r.status().as_u16();
                let after = r.headers().get("retry-after").and_then(|v| v.to_str().ok());
                let body = r.body().as_deref().unwrap_or_default();
                let outcome = match Outcome::of(status, after, body) {
                    Outcome::Ok => Outcome::Unexpected(format!("{status} without an upgrade")),
                    outcome => outcome,
                };
                self.record("stream_open", what, ms_since(t), &outcome);
                return;
            }
            Err(e) => {
                let outcome = Outcome::Unexpected(format!("transport: {e}"));
                self.record("stream_open", what, ms_since(t), &outcome);
                return;
            }
        };
        for seq in 1..=2 + self.below(4) as u64 {
            if Instant::now() >= self.end {
                break;
            }
            let mut update = serde_json::json!({
                "seq": seq,
                "sources": positions(&[self.source(at)]),
                "listeners": positions(&[self.listener(at)]),
            });
            // Options once: later updates keep them.
            if seq == 1 {
                update["options"] = serde_json::to_value(self.options()).expect("options");
            }
            if door && self.below(2) == 0 {
                let y = 0.3 * self.signed();
                update["objects"] =
                    serde_json::json!([{ "object": "door", "translation": [0, y, 0] }]);
            }
            let text = update.to_string();
            let t = Instant::now();
            let answer = socket
                .send(Message::Text(text.clone().into()))
                .map_err(|e| e.to_string())
                .and_then(|()| read_answer(&mut socket, seq));
            let (outcome, broken) = match answer {
                Ok(Ok(_reused)) => (Outcome::Ok, false),
                Ok(Err(frame)) => (Outcome::Unexpected(format!("error frame: {frame}")), false),
                Err(e) => (Outcome::Unexpected(format!("transport: {e}")), true),
            };
            let what = || format!("stream {path} update {text}");
            self.record("stream_update", what, ms_since(t), &outcome);
            if broken {
                return;
            }
        }
        self.close(&path, socket);
    }

    /// Sends Close and reads what is still in flight until the server's
    /// Close ends the connection (`ConnectionClosed`).
    fn close(&mut self, path: &str, mut socket: Socket) {
        let t = Instant::now();
        let mut result = socket.close(None);
        while result.is_ok() && t.elapsed() < CLOSE_LIMIT {
            result = socket.read().map(drop);
        }
        let outcome = match result {
            Err(tungstenite::Error::ConnectionClosed) => Outcome::Ok,
            Err(e) => Outcome::Unexpected(format!("closing: {e}")),
            Ok(()) => Outcome::Unexpected(format!("no Close within {CLOSE_LIMIT:?}")),
        };
        self.record(
            "stream_close",
            || format!("close {path}"),
            ms_since(t),
            &outcome,
        );
    }
}
