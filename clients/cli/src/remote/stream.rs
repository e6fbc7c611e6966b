//! `frusta stream`: a listener walking a straight line while the server
//! streams impulse responses over its WebSocket, in closed loop (each
//! update is sent once the previous one is answered), to measure what a
//! moving listener gets: latency, compute time, and whether beams were
//! reused.

use std::error::Error;
use std::time::Instant;

use clap::Args;
use frusta_client::api::stream::StreamUpdate;
use frusta_client::Client;
use glam::Vec3;
use serde_json::json;

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

pub fn run(client: &Client, args: &StreamArgs) -> Result<(), Box<dyn Error>> {
    let mut stream = client.stream(&args.scene_id)?;
    let sim = &args.simulation;
    let options = sim.options();
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
        let update = StreamUpdate {
            seq: Some(seq.into()),
            sources: Some(vec![sim.source.into()]),
            listeners: Some(vec![sim.listener.lerp(to, t).into()]),
            options: Some(options.clone()),
            lod_error_m: (sim.lod_error > 0.0).then_some(sim.lod_error),
            ..Default::default()
        };
        let sent = Instant::now();
        stream.send(&update)?;
        let (answer, _samples) = stream.answer_to(seq.into())?;
        let latency_ms = sent.elapsed().as_secs_f64() * 1e3;
        latencies.push(latency_ms);
        let s = &answer.pair.stats;
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
    stream.close()?;

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
