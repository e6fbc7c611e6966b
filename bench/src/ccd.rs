//! `frusta-bench ccd`: the continuous vertex–face and edge–edge tests on
//! the sample queries of Wang et al. 2021, whose exact answers come with
//! them: false negatives (a miss, which must never happen), false positives
//! and nanoseconds per query on one core, per folder and in total.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use frusta_engine::collision::continuous::{read_sample_queries, CcdOptions, CcdScratch};
use serde::Serialize;

use crate::provenance::{self, Provenance};
use crate::stats::median;

#[derive(clap::Args)]
pub struct Args {
    /// The benchmark's folder (one subfolder per scene, each with
    /// `edge-edge/` and `vertex-face/`).
    #[arg(long, default_value_os_t = crate::mesh::shared_dir().join("data/ccd-sample-queries"))]
    queries: PathBuf,
    /// Timing rounds over the whole set; the time per query is the median.
    #[arg(long, default_value_t = 5)]
    rounds: usize,
    /// Distance at which primitives count as touching.
    #[arg(long, default_value_t = CcdOptions::default().tolerance)]
    tolerance: f64,
    /// Parameter boxes one test may examine before it reports a contact.
    #[arg(long, default_value_t = CcdOptions::default().max_boxes)]
    max_boxes: u32,
    /// Print the counts as JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Also write `ccd.txt` and `ccd.json` (with provenance) into this
    /// directory.
    #[arg(long)]
    save: Option<PathBuf>,
}

#[derive(Clone, Debug, Default, Serialize)]
struct Counts {
    queries: usize,
    false_negatives: usize,
    false_positives: usize,
    ns_per_query: f64,
}

#[derive(Serialize)]
struct Counted {
    total: Counts,
    folders: BTreeMap<String, Counts>,
}

#[derive(Serialize)]
struct Saved<'a> {
    #[serde(flatten)]
    provenance: Provenance,
    tolerance: f64,
    rounds: usize,
    #[serde(flatten)]
    counted: &'a Counted,
}

pub fn run(args: Args) -> Result<(), String> {
    let mut provenance = provenance::start(1);
    let folders = read_sample_queries(&args.queries).map_err(|e| e.to_string())?;
    if folders.iter().all(|(_, q)| q.is_empty()) {
        return Err(format!("no queries under {}", args.queries.display()));
    }
    let options = CcdOptions {
        tolerance: args.tolerance,
        max_boxes: args.max_boxes,
    };
    let mut scratch = CcdScratch::default();
    let mut counted = Counted {
        total: Counts::default(),
        folders: BTreeMap::new(),
    };
    // Answers once, then time: rounds interleave the folders.
    for (name, queries) in &folders {
        let c = counted.folders.entry(name.clone()).or_default();
        c.queries = queries.len();
        for q in queries {
            let hit = q.time_of_impact(&options, &mut scratch).is_some();
            c.false_negatives += usize::from(q.collides() && !hit);
            c.false_positives += usize::from(!q.collides() && hit);
        }
    }
    let mut times: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    let mut total_times = Vec::new();
    for _ in 0..args.rounds.max(1) {
        let mut round = 0.0;
        for (name, queries) in &folders {
            let start = Instant::now();
            let hits = queries
                .iter()
                .filter(|q| q.time_of_impact(&options, &mut scratch).is_some())
                .count();
            let ns = start.elapsed().as_nanos() as f64;
            std::hint::black_box(hits);
            round += ns;
            times
                .entry(name)
                .or_default()
                .push(ns / queries.len().max(1) as f64);
        }
        total_times.push(round);
    }
    provenance.finish();
    for (name, c) in &mut counted.folders {
        c.ns_per_query = median(times.remove(name.as_str()).unwrap_or_default());
        counted.total.queries += c.queries;
        counted.total.false_negatives += c.false_negatives;
        counted.total.false_positives += c.false_positives;
    }
    counted.total.ns_per_query = median(total_times) / counted.total.queries as f64;
    let text = table(&counted, &provenance, &args);
    let saved = Saved {
        provenance,
        tolerance: args.tolerance,
        rounds: args.rounds,
        counted: &counted,
    };
    provenance::emit(
        "ccd",
        &counted,
        &saved,
        &text,
        args.json,
        args.save.as_deref(),
    )
}

fn table(counted: &Counted, provenance: &Provenance, args: &Args) -> String {
    let mut out = provenance.header();
    out += &format!(
        "\n{}: tolerance {:e}, at most {} boxes per test, one thread, median of {} rounds\n\n",
        args.queries.display(),
        args.tolerance,
        args.max_boxes,
        args.rounds
    );
    out += "folder                        queries  false neg  false pos   ns/query\n";
    out += "-----------------------------------------------------------------------\n";
    let row = |name: &str, c: &Counts| {
        format!(
            "{:<28} {:>8} {:>10} {:>10} {:>10.0}\n",
            name, c.queries, c.false_negatives, c.false_positives, c.ns_per_query
        )
    };
    for (name, c) in &counted.folders {
        out += &row(name, c);
    }
    out += &row("total", &counted.total);
    out
}
