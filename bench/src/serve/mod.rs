//! `frusta-bench serve`: the service under load. Many keep-alive HTTP
//! clients ask for impulse responses for a fixed time, then one WebSocket
//! client streams closed-loop updates, moving first the listener (the
//! traced frusta can be reused) and then the source (every update traces).

// `soak` reuses the client, the proc reader and the options.
pub(crate) mod load;
pub(crate) mod server;
pub(crate) mod stream;

use std::time::Duration;

use frusta_client::{Client, Config};
use frusta_engine::acoustics::{CellAssignment, SimulationOptions, Tail};
use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::rays::SplitMix64;
use crate::report::aligned;

#[derive(clap::Args)]
pub struct Args {
    /// Load this running server (e.g. `http://127.0.0.1:8080`) instead of
    /// one started in-process; its memory is then not reported.
    #[arg(long)]
    pub url: Option<String>,
    /// Scene to load; in-process, the only one the server holds.
    #[arg(long, default_value = "hall-10k", value_parser = ["hall-10k", "hall-200k", "shoebox"])]
    pub scene: String,
    /// Concurrent HTTP clients, each on its own keep-alive connection.
    #[arg(long, default_value_t = 64)]
    pub clients: usize,
    /// Length of the impulse-response load (default 20 s, 3 s with --quick;
    /// 0 skips it).
    #[arg(long)]
    pub seconds: Option<f64>,
    /// Length of each stream phase (default 10 s, 2 s with --quick; 0 skips
    /// the streams).
    #[arg(long)]
    pub stream_seconds: Option<f64>,
    /// Shorter phases, for a smoke test.
    #[arg(long)]
    pub quick: bool,
    /// Reflection order of the HTTP requests.
    #[arg(long, default_value_t = 2)]
    pub max_order: u32,
    /// Sampling N of the HTTP requests.
    #[arg(long, default_value_t = 8)]
    pub sampling: u32,
    /// Cell mode of the HTTP requests (`sampled` or `conservative`).
    #[arg(long, default_value = "sampled", value_parser = ["sampled", "conservative"])]
    pub cells: String,
    /// Sample rate of every impulse response, in Hz.
    #[arg(long, default_value_t = 48_000)]
    pub sample_rate: u32,
    /// Reflection order of the streams.
    #[arg(long, default_value_t = 4)]
    pub stream_order: u32,
    /// Sampling N of the streams.
    #[arg(long, default_value_t = 8)]
    pub stream_sampling: u32,
    /// Cell modes to stream with, each a listener and a source phase.
    #[arg(long, value_delimiter = ',', default_value = "sampled", value_parser = ["sampled", "conservative"])]
    pub stream_cells: Vec<String>,
    /// Print JSON lines (one object per phase) instead of the table.
    /// Simulate without the late reverberation (`"tail": "none"`), as the
    /// rows before the tail existed did.
    #[arg(long)]
    pub no_tail: bool,
    #[arg(long)]
    pub json: bool,
    /// Don't run anything: print the table of JSON lines saved from an
    /// earlier `--json` run.
    #[arg(long)]
    pub from_json: Option<std::path::PathBuf>,
}

/// The simulation options a phase asks for, as its row reports them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Options {
    pub max_order: u32,
    pub sampling: u32,
    pub cells: String,
    pub sample_rate: u32,
    /// Whether the late reverberation (the default tail) is on; rows saved
    /// before it existed had none.
    #[serde(default)]
    pub tail: bool,
}

impl Options {
    /// As both routes take them; `cells` is `sampled` or `conservative`.
    pub fn simulation(&self) -> SimulationOptions {
        SimulationOptions {
            max_order: self.max_order,
            sampling: Some(self.sampling),
            cells: match self.cells.as_str() {
                "conservative" => CellAssignment::Conservative,
                _ => CellAssignment::Sampled,
            },
            sample_rate: self.sample_rate,
            tail: if self.tail {
                Tail::default()
            } else {
                Tail::None
            },
            ..SimulationOptions::default()
        }
    }
}

/// Milliseconds at the nearest-rank percentiles, over successful requests.
#[derive(Debug, Serialize, Deserialize)]
pub struct Latency {
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl Latency {
    pub(crate) fn of(mut ms: Vec<f64>) -> Option<Self> {
        ms.sort_by(f64::total_cmp);
        let at = |q: f64| ms[((q * ms.len() as f64).ceil() as usize).clamp(1, ms.len()) - 1];
        (!ms.is_empty()).then(|| Self {
            p50: at(0.5),
            p90: at(0.9),
            p99: at(0.99),
            max: at(1.0),
        })
    }
}

/// One phase's figures; `kind` says which.
#[derive(Debug, Serialize, Deserialize)]
pub struct Row {
    /// `ir_load`, or `stream` with `moving` set.
    pub kind: String,
    pub scene: String,
    /// `listener` or `source` (streams only).
    pub moving: Option<String>,
    pub clients: usize,
    pub options: Options,
    pub seconds: f64,
    /// Requests (or stream updates) answered, errors included.
    pub requests: usize,
    /// Non-2xx answers, transport failures, error frames.
    pub errors: usize,
    pub per_s: f64,
    pub latency_ms: Option<Latency>,
    /// Stream answers computed without tracing (`stats.beams_reused`).
    pub beams_reused: Option<usize>,
    /// In-process only: the peak resident set so far (`VmHWM`, server and
    /// clients together) and the resident set at the end of the phase.
    pub peak_rss_mib: Option<f64>,
    pub rss_after_mib: Option<f64>,
    /// In-process only: rayon threads, which run the simulations.
    pub threads: Option<usize>,
}

/// What a phase measured, before the memory is added.
pub struct Measured {
    pub requests: usize,
    pub errors: usize,
    pub seconds: f64,
    pub latencies_ms: Vec<f64>,
    pub beams_reused: Option<usize>,
}

/// A source and a box of listener positions in the air of `scene`.
pub(crate) struct Points {
    pub(crate) source: Vec3,
    pub(crate) listeners: (Vec3, Vec3),
}

impl Points {
    pub(crate) fn of(scene: &str) -> Self {
        match scene {
            // 10 x 6 x 3 m: the propagation bench's source, listeners in
            // the far half of the room.
            "shoebox" => Self {
                source: Vec3::new(2.0, 3.0, 1.5),
                listeners: (Vec3::new(5.0, 1.0, 1.2), Vec3::new(9.0, 5.0, 1.8)),
            },
            // The halls: source 1.5 m above the stage, listeners at ear
            // height over the left seat block (x in [10, 38], y in
            // [6, 11.04]), clear of the pillars at y = 4.8.
            _ => Self {
                source: Vec3::new(3.0, 12.0, 2.5),
                listeners: (Vec3::new(12.0, 6.5, 1.7), Vec3::new(36.0, 10.5, 1.7)),
            },
        }
    }

    pub(crate) fn random_listener(&self, rng: &mut SplitMix64) -> Vec3 {
        let (lo, hi) = self.listeners;
        let t = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        lo + (hi - lo) * t
    }
}

fn from_json(path: &std::path::Path) -> Result<(), String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let rows = text
        .lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).map_err(|e| format!("{}: {e}", path.display())))
        .collect::<Result<Vec<Row>, _>>()?;
    if !rows.is_empty() {
        print!("{}", table(&rows));
    }
    Ok(())
}

pub fn run(args: Args) -> Result<(), String> {
    if let Some(path) = &args.from_json {
        return from_json(path);
    }
    let (local, base) = match &args.url {
        Some(url) => (None, url.trim_end_matches('/').to_string()),
        None => {
            let local = server::Local::start(&args.scene)?;
            let base = local.url();
            (Some(local), base)
        }
    };
    let rows = phases(&args, &base, local.is_some());
    if let Some(l) = local {
        l.stop();
    }
    let rows = rows?;
    if !args.json && !rows.is_empty() {
        print!("{}", table(&rows));
    }
    Ok(())
}

/// The load, then the streams; memory and threads are this process's only
/// when the server runs `in_process`.
fn phases(args: &Args, base: &str, in_process: bool) -> Result<Vec<Row>, String> {
    let ir_seconds = args.seconds.unwrap_or(if args.quick { 3.0 } else { 20.0 });
    let stream_seconds = args
        .stream_seconds
        .unwrap_or(if args.quick { 2.0 } else { 10.0 });
    let points = Points::of(&args.scene);
    let mut rows = Vec::new();
    let mut push = |mut row: Row| {
        if in_process {
            // The kernel's RSS counters are per-CPU approximations, so a
            // peak read a moment after the current size was seen below it
            // (in CI): the peak reported is at least the size seen.
            let after = server::status_mib("self", "VmRSS");
            let peak = server::status_mib("self", "VmHWM");
            row.rss_after_mib = after;
            row.peak_rss_mib = match (peak, after) {
                (Some(p), Some(a)) => Some(p.max(a)),
                (p, a) => p.or(a),
            };
            row.threads = Some(rayon::current_num_threads());
        }
        // JSON lines go out as each phase ends; the table waits for all.
        if args.json {
            println!("{}", serde_json::to_string(&row).expect("row serializes"));
        }
        rows.push(row);
    };

    if ir_seconds > 0.0 {
        let options = Options {
            max_order: args.max_order,
            sampling: args.sampling,
            cells: args.cells.clone(),
            sample_rate: args.sample_rate,
            tail: !args.no_tail,
        };
        eprintln!(
            "[{}] {} clients x {ir_seconds} s of impulse responses...",
            args.scene, args.clients
        );
        let measured = load::run(
            base,
            &args.scene,
            &points,
            &options,
            args.clients,
            secs(ir_seconds),
        )?;
        push(row("ir_load", args, None, args.clients, options, measured));
    }
    if stream_seconds > 0.0 {
        for cells in &args.stream_cells {
            let options = Options {
                max_order: args.stream_order,
                sampling: args.stream_sampling,
                cells: cells.clone(),
                sample_rate: args.sample_rate,
                tail: !args.no_tail,
            };
            for moving in ["listener", "source"] {
                eprintln!(
                    "[{}] stream, {cells} cells, moving the {moving}...",
                    args.scene
                );
                let measured = stream::run(
                    base,
                    &args.scene,
                    &points,
                    &options,
                    moving,
                    secs(stream_seconds),
                )?;
                push(row(
                    "stream",
                    args,
                    Some(moving),
                    1,
                    options.clone(),
                    measured,
                ));
            }
        }
    }
    Ok(rows)
}

/// A client of `base` with one keep-alive connection; a stuck server
/// fails the request (or the stream read) instead of hanging the bench.
pub(crate) fn client(base: &str) -> Result<Client, String> {
    let config = Config {
        timeout: Some(Duration::from_secs(120)),
        ..Config::default()
    };
    Client::new(base, config).map_err(|e| e.to_string())
}

fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(s.max(0.0))
}

fn row(
    kind: &'static str,
    args: &Args,
    moving: Option<&'static str>,
    clients: usize,
    options: Options,
    m: Measured,
) -> Row {
    Row {
        kind: kind.into(),
        scene: args.scene.clone(),
        moving: moving.map(Into::into),
        clients,
        options,
        seconds: m.seconds,
        requests: m.requests,
        errors: m.errors,
        per_s: m.requests as f64 / m.seconds,
        latency_ms: Latency::of(m.latencies_ms),
        beams_reused: m.beams_reused,
        peak_rss_mib: None,
        rss_after_mib: None,
        threads: None,
    }
}

fn table(rows: &[Row]) -> String {
    let header = [
        "phase",
        "cells",
        "order",
        "N",
        "tail",
        "clients",
        "s",
        "requests",
        "errors",
        "per s",
        "p50 ms",
        "p90 ms",
        "p99 ms",
        "max ms",
        "reused",
        "peak MiB",
        "after MiB",
    ];
    let opt = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.1}"));
    let mut lines = vec![header.map(String::from).to_vec()];
    for r in rows {
        let l = r.latency_ms.as_ref();
        lines.push(vec![
            r.moving
                .as_ref()
                .map_or_else(|| r.kind.clone(), |m| format!("{} ({m})", r.kind)),
            r.options.cells.clone(),
            r.options.max_order.to_string(),
            r.options.sampling.to_string(),
            if r.options.tail { "yes" } else { "no" }.to_string(),
            r.clients.to_string(),
            format!("{:.1}", r.seconds),
            r.requests.to_string(),
            r.errors.to_string(),
            format!("{:.1}", r.per_s),
            opt(l.map(|l| l.p50)),
            opt(l.map(|l| l.p90)),
            opt(l.map(|l| l.p99)),
            opt(l.map(|l| l.max)),
            r.beams_reused.map_or_else(|| "-".into(), |n| n.to_string()),
            opt(r.peak_rss_mib),
            opt(r.rss_after_mib),
        ]);
    }
    format!(
        "scene {}, {} Hz, {} server threads; memory (in-process only) counts server and clients\n{}",
        rows[0].scene,
        rows[0].options.sample_rate,
        rows[0].threads.map_or_else(|| "?".into(), |t| t.to_string()),
        aligned(&lines, 2)
    )
}
