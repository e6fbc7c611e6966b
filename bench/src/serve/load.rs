//! Impulse-response load: `clients` threads, each with its own blocking
//! agent (one keep-alive connection), posting back to back until the time
//! is up. Threads rather than async tasks: 64 mostly-waiting threads cost
//! little, and each request's latency is then its own wall time.

use std::time::{Duration, Instant};

use super::{positions, Measured, Options, Points};
use crate::rays::SplitMix64;

/// Largest answer read; hall answers at order 2-3 are well below.
pub(crate) const BODY_LIMIT: u64 = 64 << 20;

#[derive(Default)]
struct Client {
    latencies_ms: Vec<f64>,
    requests: usize,
    errors: usize,
    first_error: Option<String>,
}

pub fn run(
    url: &str,
    points: &Points,
    options: &Options,
    clients: usize,
    duration: Duration,
) -> Measured {
    let start = Instant::now();
    let results: Vec<Client> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..clients)
            .map(|i| s.spawn(move || client(url, points, options, i as u64, start + duration)))
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("client thread"))
            .collect()
    });
    // Requests in flight at the deadline are finished and counted.
    let seconds = start.elapsed().as_secs_f64();
    if let Some(e) = results.iter().find_map(|c| c.first_error.as_ref()) {
        eprintln!("first error: {e}");
    }
    Measured {
        requests: results.iter().map(|c| c.requests).sum(),
        errors: results.iter().map(|c| c.errors).sum(),
        seconds,
        latencies_ms: results.into_iter().flat_map(|c| c.latencies_ms).collect(),
        beams_reused: None,
    }
}

/// One keep-alive connection that returns every status as an answer.
pub(crate) fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        // A stuck server fails the request instead of hanging the bench.
        .timeout_global(Some(Duration::from_secs(120)))
        .build()
        .into()
}

fn client(url: &str, points: &Points, options: &Options, seed: u64, end: Instant) -> Client {
    let agent = agent();
    let mut rng = SplitMix64::new(0xB0DE_5EED ^ seed);
    let mut out = Client::default();
    while Instant::now() < end {
        let listener = points.random_listener(&mut rng);
        let mut request = serde_json::to_value(options).expect("options serialize");
        request["sources"] = positions(&[points.source]);
        request["listeners"] = positions(&[listener]);
        let request = request.to_string();
        let t = Instant::now();
        let outcome = agent
            .post(url)
            .header("content-type", "application/json")
            .send(&request)
            .and_then(|mut r| {
                // Read to the end, so the connection is reused.
                let body = r.body_mut().with_config().limit(BODY_LIMIT).read_to_vec()?;
                Ok((r.status(), body))
            });
        let ms = t.elapsed().as_secs_f64() * 1e3;
        out.requests += 1;
        let error = match outcome {
            Ok((status, _)) if status.is_success() => None,
            Ok((status, body)) => Some(format!("{status}: {}", String::from_utf8_lossy(&body))),
            Err(e) => Some(e.to_string()),
        };
        match error {
            None => out.latencies_ms.push(ms),
            Some(e) => {
                out.errors += 1;
                out.first_error.get_or_insert(e);
            }
        }
    }
    out
}
