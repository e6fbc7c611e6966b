//! A WebSocket session: open a stream on one scene, send a few updates
//! closed loop (the listener and the source moving, and on a client's own
//! room now and then the door), then close with the handshake, as a
//! well-behaved client does.

use std::time::{Duration, Instant};

use frusta_client::api::objects::ObjectPatch;
use frusta_client::api::stream::{ObjectMove, StreamUpdate};
use frusta_client::{Error, Stream};

use super::client::Client;
use super::tally::{ms_since, Outcome};

/// How long the close handshake may take before it counts as an error.
const CLOSE_LIMIT: Duration = Duration::from_secs(60);

impl Client<'_> {
    pub(super) fn stream(&mut self) {
        let at = self.pick();
        let id = self.id(at);
        let door = at.is_some_and(|i| self.own[i].json);
        let path = format!("/v1/scenes/{id}/stream");
        let what = || format!("GET {path} (upgrade)");
        let t = Instant::now();
        let mut stream = match self.agent.stream(&id) {
            Ok(stream) => {
                self.record("stream_open", what, ms_since(t), &Outcome::Ok);
                stream
            }
            // Refused: a 503 with `Retry-After` (`--max-streams`) is
            // backpressure; any other answer, 2xx included (no upgrade),
            // is not.
            Err(Error::Status(a)) => {
                let outcome = match Outcome::of(a.status, a.retry_after.as_deref(), &a.body) {
                    Outcome::Ok => Outcome::Unexpected(format!("{} without an upgrade", a.status)),
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
            let mut update = StreamUpdate {
                seq: Some(seq),
                sources: Some(vec![self.source(at).into()]),
                listeners: Some(vec![self.listener(at).into()]),
                // Options once: later updates keep them.
                options: (seq == 1).then(|| self.options().simulation()),
                ..Default::default()
            };
            if door && self.below(2) == 0 {
                let patch = ObjectPatch {
                    translation: Some([0.0, 0.3 * self.signed(), 0.0]),
                    ..ObjectPatch::default()
                };
                let object = "door".into();
                update.objects = Some(vec![ObjectMove { object, patch }]);
            }
            let t = Instant::now();
            let answer = stream.send(&update).and_then(|()| stream.answer_to(seq));
            let (outcome, broken) = match answer {
                Ok(_) => (Outcome::Ok, false),
                Err(Error::Frame(problem)) => (
                    Outcome::Unexpected(format!("error frame: {problem}")),
                    false,
                ),
                Err(e) => (Outcome::Unexpected(format!("transport: {e}")), true),
            };
            let what = || format!("stream {path} update {update:?}");
            self.record("stream_update", what, ms_since(t), &outcome);
            if broken {
                return;
            }
        }
        self.close(&path, stream);
    }

    /// Closes with the handshake (the client's read timeout bounds it).
    fn close(&mut self, path: &str, stream: Stream) {
        let t = Instant::now();
        let outcome = match stream.close() {
            Ok(()) if t.elapsed() < CLOSE_LIMIT => Outcome::Ok,
            Ok(()) => Outcome::Unexpected(format!("no Close within {CLOSE_LIMIT:?}")),
            Err(e) => Outcome::Unexpected(format!("closing: {e}")),
        };
        self.record(
            "stream_close",
            || format!("close {path}"),
            ms_since(t),
            &outcome,
        );
    }
}
