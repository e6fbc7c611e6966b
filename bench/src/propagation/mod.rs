//! `frusta-bench propagation`: frustum-traced specular paths over sampling
//! `N`, reflection order and cell mode, each case beside the independent
//! reference's time and checked against it (or, where it is infeasible,
//! against the exhaustive solver: see `references`), with pyroomacoustics'
//! image-source model as a peer on the small rooms, given one polygon wall
//! per planar face (and, as a labelled extra row, one wall per triangle).

mod compare;
mod plot;
pub(crate) mod pyroom;
mod references;
mod row;
pub(crate) mod scenes;
mod walls;

use std::collections::HashMap;
use std::time::Duration;

use frusta_engine::acoustics::brute_force::{BruteForce, ReferencePath};
use frusta_engine::acoustics::{AcousticScene, CellAssignment, TraceOptions};

use crate::provenance::{self, Provenance};
use references::AtOrder;
pub use row::{table, Row};
pub use scenes::NAMES;

/// A run slower than this skips the larger `N` at its order and those `N`
/// at higher orders.
const SLOW_RUN: Duration = Duration::from_secs(20);

/// Both ways of handing cells to triangles, with their `impl` names.
const CELL_MODES: [(CellAssignment, &str); 2] = [
    (CellAssignment::Conservative, "frusta"),
    (CellAssignment::Sampled, "frusta-sampled"),
];

#[derive(clap::Args)]
pub struct Args {
    /// Print JSON lines (one object per run, then a provenance line)
    /// instead of the table.
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

/// A saved run's last line (last, so that it has the load at the end).
#[derive(serde::Serialize, serde::Deserialize)]
struct ProvenanceLine {
    provenance: Provenance,
}

fn from_json(args: &Args) -> Result<(), String> {
    let mut rows = Vec::new();
    let mut headers = format!("table: {}\n", provenance::command());
    for path in &args.from_json {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let err = |e: serde_json::Error| format!("{}: {e}", path.display());
        for line in text.lines().filter(|l| l.starts_with('{')) {
            if line.starts_with("{\"provenance\"") {
                let p: ProvenanceLine = serde_json::from_str(line).map_err(err)?;
                headers.push_str(&p.provenance.header());
            } else {
                rows.push(serde_json::from_str::<Row>(line).map_err(err)?);
            }
        }
    }
    let threads = rows
        .iter()
        .find(|r| r.imp == "frusta")
        .map_or(1, |r| r.threads);
    print!("{headers}{}", table(&rows, threads));
    if let Some(path) = &args.plot {
        plot::recall_vs_time(&rows, path)?;
        eprintln!("plot written to {}", path.display());
    }
    Ok(())
}

fn emit(args: &Args, row: &Row) -> Result<(), String> {
    if args.json {
        println!("{}", serde_json::to_string(row).map_err(|e| e.to_string())?);
    }
    Ok(())
}

pub fn run(args: Args) -> Result<(), String> {
    if !args.from_json.is_empty() {
        return from_json(&args);
    }
    let threads = rayon::current_num_threads();
    let mut provenance = provenance::start(threads);
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
    let mut for_peer: HashMap<(&str, u32), PeerCase> = HashMap::new();
    for name in names {
        eprintln!("[{name}] loading...");
        let bench = scenes::load(name, args.quick)?;
        let scene = AcousticScene::new(&bench.scene);
        let triangles = scene.surfaces().triangle_count();
        let mut orders: Vec<u32> = if !args.orders.is_empty() {
            args.orders.clone()
        } else if args.quick {
            orders_quick.to_vec()
        } else {
            (1..=bench.max_order).collect()
        };
        orders.sort_unstable();
        orders.dedup();
        let independent = BruteForce::new(&bench.scene);
        let refs: HashMap<u32, AtOrder> = references::run(
            name,
            &scene,
            &independent,
            bench.source,
            bench.listener,
            &orders,
        )
        .into_iter()
        .collect();

        for (cells, imp) in CELL_MODES {
            // Sampling rates too slow at some order are skipped at higher
            // orders.
            let mut n_limit = u32::MAX;
            for &order in &orders {
                let at = &refs[&order];
                for &n in ns.iter().filter(|&&n| n <= n_limit) {
                    let options = TraceOptions {
                        max_order: order,
                        sampling: n,
                        energy_threshold: 0.0,
                        cells,
                        ..Default::default()
                    };
                    let (found, time_ms, first) = references::timed(|| {
                        scene.find_paths(bench.source, &[bench.listener], &options)
                    });
                    let frusta = found.stats.frusta;
                    let traced = &found.paths[0];
                    let mut row = Row {
                        scene: name.to_string(),
                        imp: imp.to_string(),
                        triangles,
                        walls: None,
                        order,
                        sampling: Some(n),
                        frusta: Some(frusta),
                        time_ms,
                        reference_ms: at.independent.as_ref().map(|r| r.ms),
                        exhaustive_ms: at.exhaustive.as_ref().map(|r| r.ms),
                        frusta_per_s_per_thread: Some(
                            frusta as f64 / (time_ms * 1e-3) / threads as f64,
                        ),
                        threads,
                        paths: traced.len(),
                        ..Row::default()
                    };
                    if let Some(r) = &at.independent {
                        row.set(compare::against_independent(
                            &scene,
                            bench.listener,
                            traced,
                            &r.paths,
                        ));
                    } else if let Some(r) = &at.exhaustive {
                        row.set(compare::against_exhaustive(
                            &scene,
                            bench.listener,
                            traced,
                            &r.paths,
                        ));
                    }
                    if row.false_paths.is_some_and(|f| f > 0) || row.recall.is_some_and(|r| r < 1.0)
                    {
                        eprintln!(
                            "warning: {name} {imp} order {order} N={n}: recall {:.4}, {} false paths ({} reference)",
                            row.recall.unwrap_or(f64::NAN),
                            row.false_paths.unwrap_or(0),
                            row.reference.as_deref().unwrap_or("-")
                        );
                    }
                    eprintln!(
                        "[{name}] {imp} order {order} N={n}: {frusta} frusta, {time_ms:.1} ms, {} paths",
                        row.paths
                    );
                    emit(&args, &row)?;
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
            let polygons = walls::polygons(&bench.scene)?;
            let per_triangle = walls::per_triangle(&bench.scene);
            for &order in orders.iter().filter(|&&o| (2..=4).contains(&o)) {
                let at = &refs[&order];
                for_peer.insert(
                    (name, order),
                    PeerCase {
                        triangles,
                        reference: at.independent.as_ref().map(|r| (r.paths.clone(), r.ms)),
                        exhaustive_ms: at.exhaustive.as_ref().map(|r| r.ms),
                    },
                );
                for (imp, walls) in [
                    ("pyroomacoustics", &polygons),
                    ("pyroomacoustics-triangles", &per_triangle),
                ] {
                    // box-192 in triangles at order 4 takes ~33 s: full run only.
                    if args.quick && walls.len() > 100 && order == 4 {
                        continue;
                    }
                    peer_jobs.push(pyroom::Job {
                        scene: name,
                        imp,
                        order,
                        walls: walls.clone(),
                        source: bench.source,
                        listener: bench.listener,
                    });
                }
            }
        }
    }

    if !peer_jobs.is_empty() {
        eprintln!("[pyroomacoustics] {} jobs...", peer_jobs.len());
        match pyroom::run(&peer_jobs) {
            Ok(outcomes) => {
                for o in outcomes {
                    let row = peer_row(&o, &for_peer[&(o.scene, o.order)]);
                    emit(&args, &row)?;
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

    provenance.finish();
    if args.json {
        let line = ProvenanceLine { provenance };
        println!(
            "{}",
            serde_json::to_string(&line).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}{}", provenance.header(), table(&rows, threads));
    }
    if let Some(path) = &args.plot {
        plot::recall_vs_time(&rows, path)?;
        eprintln!("plot written to {}", path.display());
    }
    Ok(())
}

/// What the peer's row of one scene and order shows beside its own
/// figures.
struct PeerCase {
    triangles: usize,
    /// The independent reference's paths and time.
    reference: Option<(Vec<ReferencePath>, f64)>,
    exhaustive_ms: Option<f64>,
}

/// The peer's row, its image sources matched one to one to the
/// independent reference's where that ran.
fn peer_row(o: &pyroom::Outcome, case: &PeerCase) -> Row {
    let mut row = Row {
        scene: o.scene.to_string(),
        imp: o.imp.to_string(),
        triangles: case.triangles,
        walls: Some(o.walls),
        order: o.order,
        time_ms: o.ms,
        reference_ms: case.reference.as_ref().map(|r| r.1),
        exhaustive_ms: case.exhaustive_ms,
        threads: 1,
        paths: o.paths,
        duplicates: Some(o.duplicates),
        ..Row::default()
    };
    if let Some((paths, _)) = &case.reference {
        let (matched, unmatched) = compare::peer_images(&o.image_sources, paths);
        row.reference = Some("independent".into());
        row.exact = Some(paths.len());
        row.recall = Some(matched as f64 / paths.len().max(1) as f64);
        row.false_paths = Some(unmatched);
    }
    row
}
