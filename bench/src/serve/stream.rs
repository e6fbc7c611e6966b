//! One WebSocket stream, closed loop: the next update goes out when the
//! answer to the previous one (a text frame with its `seq`, then the
//! samples) has arrived, so the server never coalesces and every update
//! is timed. One point moves a few centimetres per update, as a head or
//! a player would.

use std::net::TcpStream;
use std::time::{Duration, Instant};

use glam::Vec3;
use serde_json::Value;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

use super::{positions, Measured, Options, Points};

pub(crate) type Socket = WebSocket<MaybeTlsStream<TcpStream>>;

/// The moving point goes round a circle of this radius (m), this far
/// (rad) per update: about 10 cm.
const RADIUS: f32 = 1.0;
const STEP: f32 = 0.1;

pub fn run(
    url: &str,
    points: &Points,
    options: &Options,
    moving: &str,
    duration: Duration,
) -> Result<Measured, String> {
    let mut socket = connect(url).map_err(|e| format!("{url}: {e}"))?;
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
        let update = serde_json::json!({
            "seq": seq,
            "sources": positions(&[source]),
            "listeners": positions(&[listener]),
            "options": options,
        });
        let t = Instant::now();
        socket
            .send(Message::Text(update.to_string().into()))
            .map_err(|e| e.to_string())?;
        let answer = read_answer(&mut socket, seq)?;
        m.requests += 1;
        match answer {
            Ok(reused) => {
                m.latencies_ms.push(t.elapsed().as_secs_f64() * 1e3);
                if reused {
                    *m.beams_reused.as_mut().expect("set above") += 1;
                }
            }
            Err(e) => {
                if m.errors == 0 {
                    eprintln!("first error: {e}");
                }
                m.errors += 1;
            }
        }
        seq += 1;
    }
    m.seconds = start.elapsed().as_secs_f64();
    let _ = socket.close(None);
    Ok(m)
}

/// Opens a stream on `url` (`ws://`).
pub(crate) fn connect(url: &str) -> Result<Socket, tungstenite::Error> {
    let (socket, _) = tungstenite::connect(url)?;
    if let MaybeTlsStream::Plain(tcp) = socket.get_ref() {
        // Updates are small frames: send each at once. A stuck server
        // fails the read instead of hanging the bench.
        tcp.set_nodelay(true)?;
        tcp.set_read_timeout(Some(Duration::from_secs(120)))?;
    }
    Ok(socket)
}

/// Waits for the answer to `seq`: `Ok(beams_reused)`, or the error frame
/// as `Ok(Err(text))`. A closed or broken socket ends the phase.
pub(crate) fn read_answer(socket: &mut Socket, seq: u64) -> Result<Result<bool, String>, String> {
    loop {
        let text = match socket.read().map_err(|e| e.to_string())? {
            Message::Text(text) => text,
            Message::Close(frame) => return Err(format!("stream closed: {frame:?}")),
            _ => continue,
        };
        let meta: Value = serde_json::from_str(text.as_str()).map_err(|e| e.to_string())?;
        // Anything else is a problem document (whose own `type`, a URN,
        // may stand in the place of `"error"`).
        if meta["type"] != "impulse_response" {
            return Ok(Err(meta.to_string()));
        }
        // The samples follow their metadata.
        match socket.read().map_err(|e| e.to_string())? {
            Message::Binary(_) => {}
            other => return Err(format!("expected the samples, got {other:?}")),
        }
        if meta["seq"].as_u64() == Some(seq) {
            return Ok(Ok(meta["stats"]["beams_reused"] == true));
        }
    }
}
