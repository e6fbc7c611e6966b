//! `frusta-bench propagation`: frustum-traced specular paths against the
//! exact image-source reference, over sampling `N` and reflection order,
//! with pyroomacoustics' image-source model as a peer on the small rooms.

mod plot;
mod pyroom;
mod scenes;

use std::collections::HashMap;
use std::time::{Duration, Instant};

use frusta_engine::acoustics::path::{Event, ValidPath};
use frusta_engine::acoustics::propagation::arrival;
use frusta_engine::acoustics::reference::image_sources;
use frusta_engine::acoustics::signal::AirConditions;
use frusta_engine::acoustics::{AcousticScene, CellAssignment, TraceOptions};
use frusta_engine::scene::BAND_COUNT;
use glam::DVec3;
use serde::{Deserialize, Serialize};

pub use scenes::NAMES;

/// Reference runs are skipped above this many event sequences
/// (`events ^ order`).
const REFERENCE_LIMIT: f64 = 2e6;
/// A run slower than this skips the larger `N` at its order and those `N`
/// at higher orders.
const SLOW_RUN: Duration = Duration::from_secs(20);
/// Timed repeats (median) for runs under a second.
const REPEATS: usize = 3;

#[derive(clap::Args)]
pub struct Args {
    /// Print JSON lines (one object per run) instead of the table.
    #[arg(long)]
    pub json: bool,
    /// N in {4, 8}, orders {2, 4}, no hall-200k, fewer peer jobs.
    #[arg(long)]
    pub quick: bool,
    /// Write recall against time to this PNG.
    #[arg(long)]
    pub plot: Option<std::path::PathBuf>,
    /// Only these scenes (repeatable).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(NAMES))]
    pub scene: Vec<String>,
    /// Orders to run instead of the sweep's (repeatable).
    #[arg(long = "order")]
    pub orders: Vec<u32>,
    /// Sampling rates N to run instead of the sweep's (repeatable).
    #[arg(long = "sampling")]
    pub samplings: Vec<u32>,
    /// Don't run anything: print the table (and --plot) of JSON lines saved
    /// from earlier `--json` runs (repeatable).
    #[arg(long)]
    pub from_json: Vec<std::path::PathBuf>,
    /// Don't run the pyroomacoustics peer.
    #[arg(long)]
    pub no_peer: bool,
}

/// One run: ours at (order, N), or the peer at an order.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Row {
    pub scene: String,
    #[serde(rename = "impl")]
    pub imp: String,
    pub triangles: usize,
    pub order: u32,
    pub sampling: Option<u32>,
    pub frusta: Option<u64>,
    pub time_ms: f64,
    pub frusta_per_s_per_thread: Option<f64>,
    pub threads: usize,
    pub paths: usize,
    /// Exact path count from the image-source reference, where feasible.
    pub exact: Option<usize>,
    pub recall: Option<f64>,
    pub false_paths: Option<usize>,
    pub max_time_error_s: Option<f64>,
    /// Per band (63 Hz .. 8 kHz), max |dB| over matched paths.
    pub max_energy_error_db: Option<[f64; BAND_COUNT]>,
    /// Per band, 10 log10(sum gain^2 traced / sum gain^2 reference).
    pub total_energy_error_db: Option<[f64; BAND_COUNT]>,
    /// Peer only: paths minus distinct image positions.
    pub duplicates: Option<usize>,
}

struct Reference {
    order: u32,
    paths: Vec<ValidPath>,
}

fn key(p: &ValidPath) -> Vec<Event> {
    p.vertices.iter().map(|v| v.event).collect()
}

fn median_ms(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Compares traced paths with the reference paths of order <= `order`.
fn compare(
    scene: &AcousticScene,
    listener: DVec3,
    traced: &[ValidPath],
    reference: &[ValidPath],
    order: u32,
    row: &mut Row,
) {
    let speed = AirConditions::default().speed_of_sound();
    let gains = |p: &ValidPath| arrival(scene, p, listener, speed, None).pressure_gain;
    let exact: HashMap<Vec<Event>, &ValidPath> = reference
        .iter()
        .filter(|p| p.order() <= order as usize)
        .map(|p| (key(p), p))
        .collect();
    let (mut matched, mut false_paths, mut dt) = (0usize, 0usize, 0.0f64);
    let mut de = [0.0f64; BAND_COUNT];
    let (mut e_traced, mut e_ref) = ([0.0f64; BAND_COUNT], [0.0f64; BAND_COUNT]);
    for p in traced {
        let Some(r) = exact.get(&key(p)) else {
            false_paths += 1;
            continue;
        };
        matched += 1;
        dt = dt.max((p.length - r.length).abs() / speed);
        let (gt, gr) = (gains(p), gains(r));
        for b in 0..BAND_COUNT {
            let (t, r) = (f64::from(gt[b]), f64::from(gr[b]));
            de[b] = de[b].max((20.0 * (t / r).log10()).abs());
            e_traced[b] += t * t;
        }
    }
    for r in exact.values() {
        for (b, g) in gains(r).iter().enumerate() {
            e_ref[b] += f64::from(*g).powi(2);
        }
    }
    row.exact = Some(exact.len());
    row.recall = Some(if exact.is_empty() {
        1.0
    } else {
        matched as f64 / exact.len() as f64
    });
    row.false_paths = Some(false_paths);
    row.max_time_error_s = Some(dt);
    row.max_energy_error_db = Some(de);
    row.total_energy_error_db = Some(std::array::from_fn(|b| {
        10.0 * (e_traced[b] / e_ref[b]).log10()
    }));
}

fn from_json(args: &Args) -> Result<(), String> {
    let mut rows = Vec::new();
    for path in &args.from_json {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        for line in text.lines().filter(|l| l.starts_with('{')) {
            rows.push(
                serde_json::from_str::<Row>(line)
                    .map_err(|e| format!("{}: {e}", path.display()))?,
            );
        }
    }
    let threads = rows
        .iter()
        .find(|r| r.imp == "frusta")
        .map_or(1, |r| r.threads);
    print!("{}", table(&rows, threads));
    if let Some(path) = &args.plot {
        plot::recall_vs_time(&rows, path)?;
        eprintln!("plot written to {}", path.display());
    }
    Ok(())
}

pub fn run(args: Args) -> Result<(), String> {
    if !args.from_json.is_empty() {
        return from_json(&args);
    }
    let threads = rayon::current_num_threads();
    let (ns, orders_quick): (&[u32], &[u32]) = if !args.samplings.is_empty() {
        (&args.samplings, &[2, 4])
    } else if args.quick {
        (&[4, 8], &[2, 4])
    } else {
        (&[2, 4, 8, 16, 32], &[])
    };
    let names: Vec<&'static str> = NAMES
        .iter()
        .copied()
        .filter(|n| args.scene.is_empty() || args.scene.iter().any(|s| s == n))
        .filter(|&n| !(args.quick && n == "hall-200k"))
        .collect();

    let mut rows = Vec::new();
    let mut peer_jobs = Vec::new();
    let mut exact_counts: HashMap<(&str, u32), usize> = HashMap::new();
    for name in names {
        eprintln!("[{name}] loading...");
        let bench = scenes::load(name, args.quick)?;
        let scene = AcousticScene::new(&bench.scene);
        let triangles = scene.surfaces().triangle_count();
        let orders: Vec<u32> = if !args.orders.is_empty() {
            args.orders.clone()
        } else if args.quick {
            orders_quick.to_vec()
        } else {
            (1..=bench.max_order).collect()
        };
        let top = *orders.iter().max().unwrap_or(&1);

        // Events per step: a reflection per group, plus a transmission per
        // transmitting group.
        let events: usize = scene
            .surfaces()
            .groups()
            .iter()
            .map(|g| {
                1 + scene
                    .materials
                    .get(g.material as usize)
                    .is_some_and(|m| m.transmits()) as usize
            })
            .sum();
        let ref_order = (1..=top)
            .rev()
            .find(|&o| (events as f64).powi(o as i32) < REFERENCE_LIMIT);
        let reference = ref_order.map(|o| {
            let t = Instant::now();
            let paths = image_sources(
                scene.bvh(),
                scene.surfaces(),
                &scene.materials,
                bench.source,
                bench.listener,
                o as usize,
            );
            eprintln!(
                "[{name}] reference to order {o} ({events} events per step): {} paths in {:.0} ms",
                paths.len(),
                t.elapsed().as_secs_f64() * 1e3
            );
            Reference { order: o, paths }
        });
        if reference.is_none() {
            eprintln!(
                "[{name}] {events} events per step: no reference (events^1 > {REFERENCE_LIMIT})"
            );
        }

        // Sampling rates too slow at some order are skipped at higher orders.
        for (cells, imp) in CELL_MODES {
            let mut n_limit = u32::MAX;
            for &order in &orders {
                for &n in ns.iter().filter(|&&n| n <= n_limit) {
                    let options = TraceOptions {
                        max_order: order,
                        sampling: n,
                        energy_threshold: 0.0,
                        cells,
                        ..Default::default()
                    };
                    let t = Instant::now();
                    let mut found = scene.find_paths(bench.source, &[bench.listener], &options);
                    let first = t.elapsed();
                    let mut times = vec![first.as_secs_f64() * 1e3];
                    if first < Duration::from_secs(1) {
                        for _ in 1..REPEATS {
                            let t = Instant::now();
                            found = scene.find_paths(bench.source, &[bench.listener], &options);
                            times.push(t.elapsed().as_secs_f64() * 1e3);
                        }
                    }
                    let time_ms = median_ms(times);
                    let frusta = found.stats.frusta;
                    let traced = &found.paths[0];
                    let mut row = Row {
                        scene: name.to_string(),
                        imp: imp.to_string(),
                        triangles,
                        order,
                        sampling: Some(n),
                        frusta: Some(frusta),
                        time_ms,
                        frusta_per_s_per_thread: Some(
                            frusta as f64 / (time_ms * 1e-3) / threads as f64,
                        ),
                        threads,
                        paths: traced.len(),
                        exact: None,
                        recall: None,
                        false_paths: None,
                        max_time_error_s: None,
                        max_energy_error_db: None,
                        total_energy_error_db: None,
                        duplicates: None,
                    };
                    if let Some(r) = reference.as_ref().filter(|r| r.order >= order) {
                        compare(&scene, bench.listener, traced, &r.paths, order, &mut row);
                        exact_counts.insert((name, order), row.exact.unwrap_or(0));
                        if row.false_paths != Some(0) || row.recall != Some(1.0) {
                            eprintln!(
                                "warning: {name} order {order} N={n}: recall {:.4}, {} false paths",
                                row.recall.unwrap_or(f64::NAN),
                                row.false_paths.unwrap_or(0)
                            );
                        }
                    }
                    eprintln!(
                    "[{name}] {imp} order {order} N={n}: {frusta} frusta, {time_ms:.1} ms, {} paths",
                    row.paths
                );
                    if args.json {
                        println!(
                            "{}",
                            serde_json::to_string(&row).map_err(|e| e.to_string())?
                        );
                    }
                    rows.push(row);
                    if first > SLOW_RUN {
                        eprintln!(
                        "[{name}] {imp} order {order} N={n} took {first:.1?}: this N and larger skipped from here on"
                    );
                        n_limit = n.saturating_sub(1);
                        break;
                    }
                }
            }
        }

        if bench.peer && !args.no_peer {
            let (tris, absorption) = pyroom::walls(&bench.scene);
            for &order in orders.iter().filter(|&&o| (2..=4).contains(&o)) {
                // box-192 at order 4 takes ~33 s in pyroomacoustics: full run only.
                if args.quick && name == "box-192" && order == 4 {
                    continue;
                }
                peer_jobs.push(pyroom::Job {
                    scene: name,
                    order,
                    triangles: tris.clone(),
                    absorption,
                    source: bench.source,
                    listener: bench.listener,
                });
            }
        }
    }

    if !peer_jobs.is_empty() {
        eprintln!("[pyroomacoustics] {} jobs...", peer_jobs.len());
        match pyroom::run(&peer_jobs) {
            Ok(outcomes) => {
                for o in outcomes {
                    let row = Row {
                        scene: o.scene.to_string(),
                        imp: "pyroomacoustics".to_string(),
                        triangles: o.walls,
                        order: o.order,
                        sampling: None,
                        frusta: None,
                        time_ms: o.ms,
                        frusta_per_s_per_thread: None,
                        threads: 1,
                        paths: o.paths,
                        exact: exact_counts.get(&(o.scene, o.order)).copied(),
                        recall: None,
                        false_paths: None,
                        max_time_error_s: None,
                        max_energy_error_db: None,
                        total_energy_error_db: None,
                        duplicates: Some(o.duplicates),
                    };
                    if args.json {
                        println!(
                            "{}",
                            serde_json::to_string(&row).map_err(|e| e.to_string())?
                        );
                    }
                    // Beside our rows of the same scene and order.
                    let at = rows
                        .iter()
                        .rposition(|r| r.scene == row.scene && r.order == row.order)
                        .map_or(rows.len(), |i| i + 1);
                    rows.insert(at, row);
                }
            }
            Err(e) => eprintln!("note: pyroomacoustics peer skipped: {e}"),
        }
    }

    if !args.json {
        print!("{}", table(&rows, threads));
    }
    if let Some(path) = &args.plot {
        plot::recall_vs_time(&rows, path)?;
        eprintln!("plot written to {}", path.display());
    }
    Ok(())
}

fn opt<T>(v: Option<T>, f: impl Fn(T) -> String) -> String {
    v.map_or_else(|| "-".to_string(), f)
}

fn max_abs(v: &[f64; BAND_COUNT]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// The fixed-width table; energy columns give the largest band.
/// Both ways of handing cells to triangles, with their `impl` names.
const CELL_MODES: [(CellAssignment, &str); 2] = [
    (CellAssignment::Conservative, "frusta"),
    (CellAssignment::Sampled, "frusta-sampled"),
];

pub fn table(rows: &[Row], threads: usize) -> String {
    let header = [
        "scene",
        "impl",
        "tris",
        "order",
        "N",
        "frusta",
        "ms",
        "fr/s/thr",
        "paths",
        "exact",
        "recall",
        "false",
        "dt_max s",
        "dE_max dB",
        "dEtot dB",
        "dup",
    ];
    let mut cells = vec![header.map(String::from).to_vec()];
    for r in rows {
        cells.push(vec![
            r.scene.to_string(),
            r.imp.to_string(),
            r.triangles.to_string(),
            r.order.to_string(),
            opt(r.sampling, |n| n.to_string()),
            opt(r.frusta, |f| f.to_string()),
            format!("{:.2}", r.time_ms),
            opt(r.frusta_per_s_per_thread, |f| format!("{:.3e}", f)),
            r.paths.to_string(),
            opt(r.exact, |e| e.to_string()),
            opt(r.recall, |x| format!("{x:.4}")),
            opt(r.false_paths, |x| x.to_string()),
            opt(r.max_time_error_s, |x| format!("{x:.1e}")),
            opt(r.max_energy_error_db.as_ref(), |x| {
                format!("{:.1e}", max_abs(x))
            }),
            opt(r.total_energy_error_db.as_ref(), |x| {
                format!("{:.3}", max_abs(x))
            }),
            opt(r.duplicates, |x| x.to_string()),
        ]);
    }
    format!(
        "propagation: {threads} threads (fr/s/thr = frusta / wall time / threads; energy errors: largest |dB| over the 8 bands; peer: single-threaded)\n{}",
        crate::report::aligned(&cells, 2)
    )
}
