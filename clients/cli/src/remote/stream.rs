//! `frusta stream`: a listener walking a straight line while the server
//! streams impulse responses over its WebSocket, in closed loop (each
//! update is sent once the previous one is answered), to measure what a
//! moving listener gets: latency, compute time, and whether beams were
//! reused.

use std::error::Error;
use std::net::TcpStream;
use std::time::Instant;

use clap::Args;
use glam::Vec3;
use serde::Deserialize;
use serde_json::json;
use tungstenite::client::IntoClientRequest;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

use super::problem::{self, Problem};
use super::{points, segment, Server};
use crate::progress;
use crate::simulation_args::SimulationArgs;
use crate::vec3;

#[derive(Args)]
pub struct StreamArgs {
    /// The scene on the server.
    #[arg(long)]
    scene_id: String,
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Where the listener ends up: it moves in a straight line from
    /// `--listener` to here over the updates (without it, it stays).
    #[arg(long, value_parser = vec3::parse, allow_hyphen_values = true)]
    to: Option<Vec3>,
    /// Updates to send.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    updates: u32,
    /// Print one JSON object per update, then one for the summary.
    #[arg(long)]
    json: bool,
}

type Socket = WebSocket<MaybeTlsStream<TcpStream>>;

/// A text frame from the server.
#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
enum Frame {
    ImpulseResponse(Answer),
    /// Another client's object move answered without samples.
    ObjectsUpdated {},
    Error {
        problem: Problem,
    },
}

#[derive(Deserialize)]
struct Answer {
    seq: Option<u64>,
    revision: u64,
    compute_ms: f64,
    frames: usize,
    channels: usize,
    stats: AnswerStats,
}

#[derive(Deserialize)]
struct AnswerStats {
    paths: usize,
    beams_reused: bool,
}

pub fn run(server: &Server, args: &StreamArgs) -> Result<(), Box<dyn Error>> {
    let mut socket = connect(server, &args.scene_id)?;
    let sim = &args.simulation;
    let options = serde_json::to_value(sim.options())?;
    let to = args.to.unwrap_or(sim.listener);
    let n = args.updates;
    let bar = progress::steps(n.into(), progress::shown(args.json));
    bar.set_message("streaming");
    if !args.json {
        bar.suspend(|| println!("  seq  latency ms  compute ms  paths  beams reused"));
    }
    let mut latencies = Vec::with_capacity(n as usize);
    let start = Instant::now();
    for seq in 0..n {
        let t = if n > 1 {
            seq as f32 / (n - 1) as f32
        } else {
            0.0
        };
        let update = json!({
            "seq": seq,
            "sources": points(sim.source),
            "listeners": points(sim.listener.lerp(to, t)),
            "options": options,
        });
        let sent = Instant::now();
        socket.send(Message::text(update.to_string()))?;
        let answer = answer_to(&mut socket, seq.into())?;
        let latency_ms = sent.elapsed().as_secs_f64() * 1e3;
        latencies.push(latency_ms);
        let s = &answer.stats;
        bar.suspend(|| {
            if args.json {
                let line = json!({
                    "seq": seq, "revision": answer.revision, "latency_ms": latency_ms,
                    "compute_ms": answer.compute_ms, "paths": s.paths,
                    "beams_reused": s.beams_reused,
                });
                println!("{line}");
            } else {
                let reused = if s.beams_reused { "yes" } else { "no" };
                println!(
                    "{seq:>5}  {latency_ms:>10.2}  {:>10.2}  {:>5}  {reused}",
                    answer.compute_ms, s.paths
                );
            }
        });
        bar.inc(1);
    }
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    // Complete the closing handshake; the server answers a close at once.
    socket.close(None)?;
    while socket.read().is_ok() {}

    latencies.sort_by(f64::total_cmp);
    let (p50, p99) = (percentile(&latencies, 0.5), percentile(&latencies, 0.99));
    let rate = f64::from(n) / seconds;
    if args.json {
        let summary = json!({
            "updates": n, "seconds": seconds, "updates_per_s": rate,
            "latency_p50_ms": p50, "latency_p99_ms": p99,
        });
        println!("{summary}");
    } else {
        println!(
            "{n} updates in {seconds:.2} s: {rate:.1} updates/s, latency p50 {p50:.2} ms, p99 {p99:.2} ms"
        );
    }
    Ok(())
}

/// Opens the scene's stream; a refused upgrade is reported by its problem
/// document, as an HTTP error is.
fn connect(server: &Server, scene_id: &str) -> Result<Socket, Box<dyn Error>> {
    let url = server.ws_url(&format!("/v1/scenes/{}/stream", segment(scene_id)));
    let mut request = url.as_str().into_client_request()?;
    if let Some(bearer) = server.bearer() {
        request
            .headers_mut()
            .insert("authorization", bearer.parse()?);
    }
    match tungstenite::connect(request) {
        Ok((socket, _)) => Ok(socket),
        Err(tungstenite::Error::Http(response)) => Err(problem::from_answer(
            response.status().as_u16(),
            response.body().as_deref().unwrap_or_default(),
        )),
        Err(e) => Err(format!("cannot open {url}: {e}").into()),
    }
}

/// Reads frames until the answer to update `seq`. Answers to older updates
/// (or to another client's edit of the scene) are skipped with their
/// samples; an error frame ends the run.
fn answer_to(socket: &mut Socket, seq: u64) -> Result<Answer, Box<dyn Error>> {
    loop {
        let text = match socket.read()? {
            Message::Text(text) => text,
            Message::Close(frame) => {
                let reason = frame.map(|f| f.reason.to_string()).unwrap_or_default();
                return Err(format!("the server closed the stream: {reason}").into());
            }
            _ => continue,
        };
        let answer = match serde_json::from_str(&text)? {
            Frame::ImpulseResponse(answer) => answer,
            Frame::ObjectsUpdated {} => continue,
            Frame::Error { problem } => return Err(problem.into()),
        };
        let expected = answer.frames * answer.channels * 4;
        let got = match socket.read()? {
            Message::Binary(samples) => samples.len(),
            _ => return Err("the answer's samples did not follow it".into()),
        };
        if got != expected {
            return Err(format!("expected {expected} bytes of samples, got {got}").into());
        }
        if answer.seq == Some(seq) {
            return Ok(answer);
        }
    }
}

/// The `p` quantile of `sorted` by nearest rank.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    let rank = (p * sorted.len() as f64).ceil() as usize;
    let last = sorted.len().saturating_sub(1);
    sorted
        .get(rank.saturating_sub(1).min(last))
        .copied()
        .unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::percentile;

    #[test]
    fn percentiles_by_nearest_rank() {
        let values: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&values, 0.5), 50.0);
        assert_eq!(percentile(&values, 0.99), 99.0);
        assert_eq!(percentile(&[7.0], 0.99), 7.0);
        assert!(percentile(&[], 0.5).is_nan());
    }
}
