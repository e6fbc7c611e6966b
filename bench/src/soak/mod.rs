//! `frusta-bench soak`: the release server as a child process under a
//! long mixed load: `--clients` threads uploading, editing and deleting
//! scenes, asking for impulse responses, rays and occlusion, and
//! streaming, while the server's resident memory is sampled every second.
//! The run passes when no answer was unexpected (only 2xx, or 503 with
//! `Retry-After`) and memory stayed flat after the warm-up; otherwise it
//! exits non-zero.

mod client;
mod memory;
mod report;
mod scenes;
mod server;
mod stream;
mod tally;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::provenance;
use crate::serve;
use client::Client;
use report::Summary;
use tally::{Progress, Tally};

#[derive(clap::Args)]
pub struct Args {
    /// Length of the load.
    #[arg(long, default_value_t = 10.0)]
    pub minutes: f64,
    /// Concurrent clients, each a thread with its own keep-alive connection.
    #[arg(long, default_value_t = 64)]
    pub clients: usize,
    /// A 30 s smoke run (overrides --minutes).
    #[arg(long)]
    pub quick: bool,
    /// Print JSON lines (one per kind, the summary, the provenance)
    /// instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Also write the table and the JSON lines to DIR/soak.txt and
    /// DIR/soak.jsonl.
    #[arg(long, value_name = "DIR")]
    pub save: Option<std::path::PathBuf>,
}

/// A saved run's last line.
#[derive(serde::Serialize)]
struct ProvenanceLine<'a> {
    provenance: &'a provenance::Provenance,
}

#[derive(serde::Serialize)]
struct SummaryLine<'a> {
    summary: &'a Summary,
}

pub fn run(args: Args) -> Result<(), String> {
    let run_s = if args.quick {
        30.0
    } else {
        args.minutes * 60.0
    };
    // Warm-up: the first 20% (at least a minute on a real run); memory is
    // judged against the median of the window after it.
    let warmup_s = if args.quick {
        0.2 * run_s
    } else {
        (0.2 * run_s).max(60.0)
    };
    let window_s = (0.2 * run_s).min(60.0);
    if run_s < warmup_s + window_s {
        return Err(format!(
            "a {run_s} s run leaves no room after the {warmup_s} s warm-up"
        ));
    }
    let mut provenance = provenance::start(rayon::current_num_threads());
    let server = server::Server::start()?;
    let pid = server.pid();
    eprintln!(
        "soak: server pid {pid} at {}; {} clients for {run_s} s",
        server.url, args.clients
    );

    let (stop, done, progress) = (
        AtomicBool::new(false),
        AtomicBool::new(false),
        Progress::default(),
    );
    let agents = (0..args.clients)
        .map(|_| serve::client(&server.url))
        .collect::<Result<Vec<_>, _>>()?;
    let start = Instant::now();
    let end = start + Duration::from_secs_f64(run_s);
    let every = if args.quick { 5 } else { 30 };
    let (tally, seconds, samples) = std::thread::scope(|s| {
        let sampler = s.spawn(|| sample(&pid, start, every, &done, &stop, &progress));
        let clients: Vec<_> = agents
            .into_iter()
            .enumerate()
            .map(|(i, agent)| {
                let (stop, progress) = (&stop, &progress);
                s.spawn(move || Client::new(agent, i, end, stop, progress).run())
            })
            .collect();
        let mut tally = Tally::default();
        for c in clients {
            tally.merge(c.join().expect("client thread"));
        }
        let seconds = start.elapsed().as_secs_f64();
        done.store(true, Ordering::Relaxed);
        (tally, seconds, sampler.join().expect("sampler thread"))
    });

    let scenes_left = scene_count(&server.url);
    let store_mib = server.store_mib();
    let log = server.log.clone();
    let server_exit = server.stop().err();
    let mut summary = Summary {
        clients: args.clients,
        seconds,
        requests: tally.kinds.values().map(|k| k.requests).sum(),
        backpressure: tally.kinds.values().map(|k| k.backpressure).sum(),
        unexpected_errors: tally.kinds.values().map(|k| k.errors).sum(),
        first_errors: tally
            .kinds
            .values()
            .flat_map(|k| k.first_errors.iter().cloned())
            .collect(),
        scenes_left,
        store_mib,
        memory: memory::analyse(&samples, warmup_s, window_s),
        server_log: log.lock().expect("log lock").clone(),
        server_exit,
        failures: Vec::new(),
    };
    summary.failures = report::failures(&summary);
    provenance.finish();

    let rows = report::rows(&tally, seconds);
    let text = format!("{}{}", provenance.header(), report::table(&rows, &summary));
    let mut jsonl = String::new();
    for r in &rows {
        jsonl.push_str(&line(r)?);
    }
    jsonl.push_str(&line(&SummaryLine { summary: &summary })?);
    jsonl.push_str(&line(&ProvenanceLine {
        provenance: &provenance,
    })?);
    print!("{}", if args.json { &jsonl } else { &text });
    if let Some(dir) = &args.save {
        for (name, content) in [("soak.txt", &text), ("soak.jsonl", &jsonl)] {
            let path = dir.join(name);
            std::fs::write(&path, content).map_err(|e| format!("{}: {e}", path.display()))?;
            eprintln!("soak: wrote {}", path.display());
        }
    }
    match summary.failures.as_slice() {
        [] => Ok(()),
        f => Err(format!("soak failed: {}", f.join("; "))),
    }
}

fn line(v: &impl serde::Serialize) -> Result<String, String> {
    serde_json::to_string(v)
        .map(|s| s + "\n")
        .map_err(|e| e.to_string())
}

/// `VmRSS` of `pid` once a second from `start` until `done`, as (seconds,
/// MiB), with a progress line every `every` seconds. A server that is
/// gone (no `VmRSS`) sets `stop`, which ends the clients.
fn sample(
    pid: &str,
    start: Instant,
    every: u64,
    done: &AtomicBool,
    stop: &AtomicBool,
    progress: &Progress,
) -> Vec<(f64, f64)> {
    let mut samples = Vec::new();
    for tick in 0u64.. {
        if done.load(Ordering::Relaxed) {
            break;
        }
        let Some(mib) = serve::server::status_mib(pid, "VmRSS") else {
            eprintln!("soak: the server (pid {pid}) is gone");
            stop.store(true, Ordering::Relaxed);
            break;
        };
        samples.push((start.elapsed().as_secs_f64(), mib));
        if tick > 0 && tick % every == 0 {
            eprintln!(
                "soak: {tick} s, {} requests, {} backpressure, {} unexpected, server RSS {mib:.1} MiB",
                progress.requests.load(Ordering::Relaxed),
                progress.backpressure.load(Ordering::Relaxed),
                progress.errors.load(Ordering::Relaxed),
            );
        }
        // The next whole second, so samples stay one second apart.
        let next = start + Duration::from_secs(tick + 1);
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
    }
    samples
}

/// Scenes the server holds (`GET /v1/scenes`); `None` if it did not answer.
fn scene_count(base: &str) -> Option<usize> {
    let list = serve::client(base).ok()?.scenes().ok()?;
    Some(list.scenes.len())
}
