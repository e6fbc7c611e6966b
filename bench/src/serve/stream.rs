//! One WebSocket stream, closed loop: the next update goes out when the
//! answer to the previous one (a text frame with its `seq`, then the
//! samples) has arrived, so the server never coalesces and every update
//! is timed. One point moves a few centimetres per update, as a head or
//! a player would.

use std::time::{Duration, Instant};

use frusta_client::api::stream::StreamUpdate;
use frusta_client::Error;
use glam::Vec3;

use super::{Measured, Options, Points};

/// The moving point goes round a circle of this radius (m), this far
/// (rad) per update: about 10 cm.
const RADIUS: f32 = 1.0;
const STEP: f32 = 0.1;

pub fn run(
    base: &str,
    scene: &str,
    points: &Points,
    options: &Options,
    moving: &str,
    duration: Duration,
) -> Result<Measured, String> {
    let mut stream = super::client(base)?
        .stream(scene)
        .map_err(|e| format!("{base} {scene}: {e}"))?;
    let (lo, hi) = points.listeners;
    let listener = (lo + hi) * 0.5;
    let start = Instant::now();
    let mut m = Measured {
        requests: 0,
        errors: 0,
        seconds: 0.0,
        latencies_ms: Vec::new(),
        beams_reused: Some(0),
    };
    let mut seq = 0u64;
    while start.elapsed() < duration {
        let angle = STEP * seq as f32;
        let offset = RADIUS * Vec3::new(angle.cos(), angle.sin(), 0.0);
        let (source, listener) = match moving {
            "source" => (points.source + 0.5 * offset, listener),
            _ => (points.source, listener + offset),
        };
        let update = StreamUpdate {
            seq: Some(seq),
            sources: Some(vec![source.into()]),
            listeners: Some(vec![listener.into()]),
            options: Some(options.simulation()),
            ..Default::default()
        };
        let t = Instant::now();
        stream.send(&update).map_err(|e| e.to_string())?;
        m.requests += 1;
        match stream.answer_to(seq) {
            Ok((answer, _)) => {
                m.latencies_ms.push(t.elapsed().as_secs_f64() * 1e3);
                if answer.pair.stats.beams_reused {
                    *m.beams_reused.as_mut().expect("set above") += 1;
                }
            }
            // An error frame is the server refusing this update; anything
            // else (a closed or broken socket) ends the phase.
            Err(Error::Frame(problem)) => {
                if m.errors == 0 {
                    eprintln!("first error: {problem}");
                }
                m.errors += 1;
            }
            Err(e) => return Err(e.to_string()),
        }
        seq += 1;
    }
    m.seconds = start.elapsed().as_secs_f64();
    let _ = stream.close();
    Ok(m)
}
