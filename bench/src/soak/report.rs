//! The soak's results: one row per kind of request, a summary (memory,
//! errors, what the server logged, how it stopped) and the verdict, as a
//! table and as JSON lines.

use serde::{Deserialize, Serialize};

use super::memory::{relative, Memory, TOLERANCE};
use super::server::Log;
use super::tally::Tally;
use crate::report::aligned;
use crate::serve::Latency;

#[derive(Debug, Serialize, Deserialize)]
pub struct KindRow {
    pub kind: String,
    /// Answered, backpressure and errors included.
    pub requests: usize,
    /// 503 with `Retry-After`.
    pub backpressure: usize,
    /// Everything else that was not 2xx: statuses, transport failures,
    /// stream error frames.
    pub errors: usize,
    pub per_s: f64,
    /// Successful requests only.
    pub latency_ms: Option<Latency>,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct Summary {
    pub clients: usize,
    /// The load, from the first request to the last client's end
    /// (its final deletes included).
    pub seconds: f64,
    pub requests: usize,
    pub backpressure: usize,
    pub unexpected_errors: usize,
    /// The first few of each kind, with the request and the answer.
    pub first_errors: Vec<String>,
    /// Scenes on the server after every client deleted its own (1: the
    /// shoebox).
    pub scenes_left: Option<usize>,
    pub store_mib: f64,
    pub memory: Option<Memory>,
    pub server_log: Log,
    /// How the server ended: `None` if it exited 0 on SIGTERM.
    pub server_exit: Option<String>,
    /// Why this run does not count as passed; empty if it does.
    pub failures: Vec<String>,
}

pub fn rows(tally: &Tally, seconds: f64) -> Vec<KindRow> {
    tally
        .kinds
        .iter()
        .map(|(kind, s)| KindRow {
            kind: (*kind).to_string(),
            requests: s.requests,
            backpressure: s.backpressure,
            errors: s.errors,
            per_s: s.requests as f64 / seconds,
            latency_ms: Latency::of(s.latencies_ms.clone()),
        })
        .collect()
}

/// Reasons to fail the run, so that no figure is claimed silently.
pub fn failures(s: &Summary) -> Vec<String> {
    let mut out = Vec::new();
    if s.unexpected_errors > 0 {
        out.push(format!("{} unexpected errors", s.unexpected_errors));
    }
    match &s.memory {
        None => out.push("memory not measured over the whole run".into()),
        Some(m) if !m.flat => out.push(format!(
            "memory not flat: max {:.1} MiB ({}), last window {:.1} MiB ({}) against {:.1} MiB",
            m.max_mib,
            relative(m.max_mib, m.reference_mib),
            m.last_median_mib,
            relative(m.last_median_mib, m.reference_mib),
            m.reference_mib
        )),
        Some(_) => {}
    }
    if s.scenes_left != Some(1) {
        out.push(format!(
            "{:?} scenes left after the clients deleted theirs (expected 1)",
            s.scenes_left
        ));
    }
    if s.server_log.errors + s.server_log.stderr_lines > 0 {
        out.push("the server logged errors (see server log)".into());
    }
    out.extend(s.server_exit.clone());
    out
}

pub fn table(rows: &[KindRow], s: &Summary) -> String {
    let header = [
        "kind", "requests", "per s", "backpr.", "errors", "p50 ms", "p90 ms", "p99 ms", "max ms",
    ];
    let opt = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.1}"));
    let mut lines = vec![header.map(String::from).to_vec()];
    for r in rows {
        let l = r.latency_ms.as_ref();
        lines.push(vec![
            r.kind.clone(),
            r.requests.to_string(),
            format!("{:.1}", r.per_s),
            r.backpressure.to_string(),
            r.errors.to_string(),
            opt(l.map(|l| l.p50)),
            opt(l.map(|l| l.p90)),
            opt(l.map(|l| l.p99)),
            opt(l.map(|l| l.max)),
        ]);
    }
    lines.push(vec![
        "all".into(),
        s.requests.to_string(),
        format!("{:.1}", s.requests as f64 / s.seconds),
        s.backpressure.to_string(),
        s.unexpected_errors.to_string(),
    ]);
    lines
        .last_mut()
        .expect("pushed")
        .resize(header.len(), String::new());
    let mut out = format!(
        "{} clients for {:.1} s against the release server (child process, loopback)\n{}",
        s.clients,
        s.seconds,
        aligned(&lines, 1)
    );
    out.push_str(&match &s.memory {
        Some(m) => format!(
            "server RSS: reference {:.1} MiB (median of {:.0}-{:.0} s, after a {:.0} s warm-up); \
             max {:.1} MiB ({}, at {:.0} s); last {:.0} s median {:.1} MiB ({}); final {:.1} MiB ({}); \
             slope {:+.2} MiB/min; {} (within {:.0}%)\n",
            m.reference_mib,
            m.warmup_s,
            m.warmup_s + m.window_s,
            m.warmup_s,
            m.max_mib,
            relative(m.max_mib, m.reference_mib),
            m.max_at_s,
            m.window_s,
            m.last_median_mib,
            relative(m.last_median_mib, m.reference_mib),
            m.final_mib,
            relative(m.final_mib, m.reference_mib),
            m.slope_mib_per_min,
            if m.flat { "flat" } else { "NOT flat" },
            100.0 * TOLERANCE
        ),
        None => "server RSS: not measured\n".into(),
    });
    out.push_str(&format!(
        "scenes left: {}; store {:.1} MiB; server log: {} WARN, {} ERROR, {} stderr lines; stop: {}\n",
        s.scenes_left.map_or_else(|| "?".into(), |n| n.to_string()),
        s.store_mib,
        s.server_log.warnings,
        s.server_log.errors,
        s.server_log.stderr_lines,
        s.server_exit.as_deref().unwrap_or("exit 0 on SIGTERM"),
    ));
    for line in &s.server_log.first {
        out.push_str(&format!("  server: {line}\n"));
    }
    for e in &s.first_errors {
        out.push_str(&format!("  error: {e}\n"));
    }
    out.push_str(&match s.failures.as_slice() {
        [] => "verdict: pass (no unexpected errors, memory flat)\n".to_string(),
        f => format!("verdict: FAIL: {}\n", f.join("; ")),
    });
    out
}
