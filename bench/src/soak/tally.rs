//! What the clients saw: every answer is a success, backpressure (503 with
//! `Retry-After`: the server asking to come back, which the README
//! promises under load) or an unexpected error (anything else).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Unexpected errors kept with their bodies, per kind (so one frequent
/// failure cannot hide another).
pub const FIRST_ERRORS: usize = 3;

/// Milliseconds since `t`.
pub fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

pub enum Outcome {
    Ok,
    /// Come back after this long.
    Backpressure(Duration),
    Unexpected(String),
}

impl Outcome {
    /// An HTTP answer (or a refused WebSocket upgrade) by status.
    pub fn of(status: u16, retry_after: Option<&str>, body: &[u8]) -> Self {
        match (status, retry_after) {
            (200..=299, _) => Self::Ok,
            (503, Some(after)) => {
                // The server sends whole seconds; a client honours them.
                Self::Backpressure(Duration::from_secs(after.trim().parse().unwrap_or(1)))
            }
            _ => Self::Unexpected(format!("{status}: {}", String::from_utf8_lossy(body))),
        }
    }
}

/// Figures of one kind of request.
#[derive(Default)]
pub struct KindStats {
    pub requests: usize,
    pub backpressure: usize,
    pub errors: usize,
    /// Successful requests only, send to last byte.
    pub latencies_ms: Vec<f64>,
    /// `request: answer`, the first [`FIRST_ERRORS`].
    pub first_errors: Vec<String>,
}

/// Running totals over all clients, for the progress line.
#[derive(Default)]
pub struct Progress {
    pub requests: AtomicUsize,
    pub backpressure: AtomicUsize,
    pub errors: AtomicUsize,
}

/// One client's figures (merged into one at the end).
#[derive(Default)]
pub struct Tally {
    pub kinds: BTreeMap<&'static str, KindStats>,
}

impl Tally {
    /// Counts one answer to `what` (method and path, for the error list).
    pub fn record(
        &mut self,
        progress: &Progress,
        kind: &'static str,
        what: &str,
        ms: f64,
        outcome: &Outcome,
    ) {
        let stats = self.kinds.entry(kind).or_default();
        stats.requests += 1;
        progress.requests.fetch_add(1, Ordering::Relaxed);
        match outcome {
            Outcome::Ok => stats.latencies_ms.push(ms),
            Outcome::Backpressure(_) => {
                stats.backpressure += 1;
                progress.backpressure.fetch_add(1, Ordering::Relaxed);
            }
            Outcome::Unexpected(e) => {
                stats.errors += 1;
                progress.errors.fetch_add(1, Ordering::Relaxed);
                if stats.first_errors.len() < FIRST_ERRORS {
                    // Bodies are problem documents; cap anything larger.
                    let e: String = e.chars().take(600).collect();
                    stats.first_errors.push(format!("{kind} {what}: {e}"));
                }
            }
        }
    }

    pub fn merge(&mut self, other: Tally) {
        for (kind, s) in other.kinds {
            let mine = self.kinds.entry(kind).or_default();
            mine.requests += s.requests;
            mine.backpressure += s.backpressure;
            mine.errors += s.errors;
            mine.latencies_ms.extend(s.latencies_ms);
            let room = FIRST_ERRORS.saturating_sub(mine.first_errors.len());
            mine.first_errors
                .extend(s.first_errors.into_iter().take(room));
        }
    }
}
