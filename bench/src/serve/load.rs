//! Impulse-response load: `clients` threads, each with its own blocking
//! client (one keep-alive connection), posting back to back until the time
//! is up. Threads rather than async tasks: 64 mostly-waiting threads cost
//! little, and each request's latency is then its own wall time.

use std::time::{Duration, Instant};

use frusta_client::api::impulse_responses::ImpulseResponseRequest;
use frusta_client::{Answer, Client};

use super::{Measured, Options, Points};
use crate::rays::SplitMix64;

#[derive(Default)]
struct Tally {
    latencies_ms: Vec<f64>,
    requests: usize,
    errors: usize,
    first_error: Option<String>,
}

pub fn run(
    base: &str,
    scene: &str,
    points: &Points,
    options: &Options,
    clients: usize,
    duration: Duration,
) -> Result<Measured, String> {
    let path = format!("/v1/scenes/{scene}/impulse-responses");
    let agents = (0..clients)
        .map(|_| super::client(base))
        .collect::<Result<Vec<_>, _>>()?;
    let start = Instant::now();
    let results: Vec<Tally> = std::thread::scope(|s| {
        let path = &path;
        let handles: Vec<_> = agents
            .into_iter()
            .enumerate()
            .map(|(i, agent)| {
                s.spawn(move || requests(&agent, path, points, options, i as u64, start + duration))
            })
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
    Ok(Measured {
        requests: results.iter().map(|c| c.requests).sum(),
        errors: results.iter().map(|c| c.errors).sum(),
        seconds,
        latencies_ms: results.into_iter().flat_map(|c| c.latencies_ms).collect(),
        beams_reused: None,
    })
}

/// One client's requests, back to back until `end`. The answer is read
/// to its last byte (which reuses the connection) but not parsed, so the
/// latency is the server's and the wire's.
fn requests(
    client: &Client,
    path: &str,
    points: &Points,
    options: &Options,
    seed: u64,
    end: Instant,
) -> Tally {
    let mut rng = SplitMix64::new(0xB0DE_5EED ^ seed);
    let mut out = Tally::default();
    while Instant::now() < end {
        let listener = points.random_listener(&mut rng);
        let request = ImpulseResponseRequest::pair(points.source, listener, options.simulation());
        let t = Instant::now();
        let outcome = client.post_json(path, &request).and_then(Answer::ok);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        out.requests += 1;
        let error = outcome.err().map(|e| e.to_string());
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
