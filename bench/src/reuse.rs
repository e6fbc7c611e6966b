//! `frusta-bench reuse`: a source moving in small steps, as a stream moves
//! it. Each update reuses the frusta traced within `source_reuse_m` of the
//! source (re-mirrored, every path validated exactly) or traces afresh.
//! Beside every update, a fresh trace at the same position with the same
//! cells and sampling is the reference: recall is the share of its paths
//! the update found, and paths the update found that it did not are real
//! (validated) paths the fresh sampling missed.

use std::path::PathBuf;
use std::time::Instant;

use frusta_engine::acoustics::{
    simulate, simulate_cached, AcousticScene, BeamCache, CellAssignment, SimulationOptions,
    SoundPath, Tail,
};
use glam::{DVec3, Vec3};
use serde::Serialize;

use crate::propagation::scenes;
use crate::provenance::{self, Provenance};
use crate::report::aligned;
use crate::stats::median;

#[derive(clap::Args)]
pub struct Args {
    /// Scenes (repeatable); default: hall-10k, l-room. Halls use sampled
    /// cells, rooms conservative ones.
    #[arg(long = "scene")]
    scenes: Vec<String>,
    /// Reflection order.
    #[arg(long, default_value_t = 4)]
    order: u32,
    /// Sub-frusta per frustum side (N).
    #[arg(long, default_value_t = 8)]
    sampling: u32,
    /// Updates; the source moves `step` metres along a circle before each.
    #[arg(long, default_value_t = 40)]
    updates: usize,
    /// Metres the source moves per update.
    #[arg(long, default_value_t = 0.05)]
    step: f64,
    /// Radius of the source's circle, m, around the scene's source.
    #[arg(long, default_value_t = 0.5)]
    radius: f64,
    /// Reuse distances, m (repeatable); 0 traces every update. Default:
    /// 0, 0.1, 0.25, 0.5.
    #[arg(long = "reuse")]
    reuse: Vec<f64>,
    #[arg(long)]
    json: bool,
    /// Also write `reuse.txt` and `reuse.json` into this directory.
    #[arg(long)]
    save: Option<PathBuf>,
}

#[derive(Clone, Debug, Serialize)]
struct Row {
    scene: String,
    cells: &'static str,
    reuse_m: f64,
    updates: usize,
    /// Updates that reused frusta instead of tracing.
    reused: usize,
    /// Median and mean wall time of an update (the mean counts the
    /// updates that traced), and of a fresh trace at each position.
    update_ms: f64,
    update_mean_ms: f64,
    fresh_ms: f64,
    fresh_mean_ms: f64,
    /// Paths of the fresh traces, and those the updates found.
    fresh_paths: usize,
    found: usize,
    recall: f64,
    /// Validated paths the updates found that the fresh traces missed.
    others: usize,
}

#[derive(Serialize)]
struct Saved<'a> {
    #[serde(flatten)]
    provenance: Provenance,
    order: u32,
    sampling: u32,
    step_m: f64,
    radius_m: f64,
    rows: &'a [Row],
}

pub fn run(args: Args) -> Result<(), String> {
    if args.updates == 0 {
        return Err("--updates must be at least 1".into());
    }
    if !(args.radius > 0.0 && args.radius.is_finite() && args.step.is_finite() && args.step > 0.0) {
        return Err("--radius and --step must be positive and finite".into());
    }
    let max = frusta_engine::acoustics::MAX_SOURCE_REUSE_M;
    if let Some(bad) = args.reuse.iter().find(|r| !(0.0..=max).contains(*r)) {
        return Err(format!("--reuse {bad}: must lie in 0..={max} m"));
    }
    let mut provenance = provenance::start(rayon::current_num_threads());
    let names: Vec<String> = if args.scenes.is_empty() {
        vec!["hall-10k".into(), "l-room".into()]
    } else {
        args.scenes.clone()
    };
    let reuse = if args.reuse.is_empty() {
        vec![0.0, 0.1, 0.25, 0.5]
    } else {
        args.reuse.clone()
    };
    let mut rows = Vec::new();
    for name in &names {
        let name = scenes::NAMES
            .iter()
            .find(|n| **n == name.as_str())
            .ok_or_else(|| format!("unknown scene {name}; one of {:?}", scenes::NAMES))?;
        eprintln!("[{name}]");
        rows.extend(run_scene(name, &reuse, &args)?);
    }
    provenance.finish();
    let text = table(&rows, &provenance, &args);
    let saved = Saved {
        provenance,
        order: args.order,
        sampling: args.sampling,
        step_m: args.step,
        radius_m: args.radius,
        rows: &rows,
    };
    provenance::emit(
        "reuse",
        &rows,
        &saved,
        &text,
        args.json,
        args.save.as_deref(),
    )
}

fn run_scene(name: &'static str, reuse: &[f64], args: &Args) -> Result<Vec<Row>, String> {
    let bench = scenes::load(name, false)?;
    let scene = AcousticScene::new(&bench.scene);
    let hall = name.starts_with("hall");
    let cells = if hall {
        CellAssignment::Sampled
    } else {
        CellAssignment::Conservative
    };
    let options = |reuse_m: f64| SimulationOptions {
        max_order: args.order,
        sampling: Some(args.sampling),
        cells,
        air: None,
        sample_rate: 8_000,
        tail: Tail::None,
        diffraction_order: 0,
        source_reuse_m: reuse_m,
        ..Default::default()
    };
    // The source walks a circle around the scene's source, in the plane.
    let sources: Vec<Vec3> = (0..args.updates)
        .map(|i| {
            let angle = i as f64 * args.step / args.radius;
            let offset = DVec3::new(angle.cos() - 1.0, angle.sin(), 0.0) * args.radius;
            (bench.source + offset).as_vec3()
        })
        .collect();
    let listener = [bench.listener.as_vec3()];
    let trace = |source: Vec3, cache: Option<&mut BeamCache>, o: &SimulationOptions| {
        let start = Instant::now();
        let result = match cache {
            Some(cache) => simulate_cached(&scene, &[source], &listener, o, cache, None, None),
            None => simulate(&scene, &[source], &listener, o),
        };
        let r = result.map_err(|e| e.to_string())?.remove(0);
        Ok::<_, String>((r, start.elapsed().as_secs_f64() * 1e3))
    };
    let fresh: Vec<(Vec<SoundPath>, f64)> = sources
        .iter()
        .map(|&s| trace(s, None, &options(0.0)).map(|(r, ms)| (r.paths, ms)))
        .collect::<Result<_, _>>()?;
    let mut rows = Vec::new();
    for &reuse_m in reuse {
        let o = options(reuse_m);
        let mut cache = BeamCache::default();
        let mut row = Row {
            scene: name.to_string(),
            cells: if hall { "sampled" } else { "conservative" },
            reuse_m,
            updates: sources.len(),
            reused: 0,
            update_ms: 0.0,
            update_mean_ms: 0.0,
            fresh_ms: median(fresh.iter().map(|f| f.1).collect()),
            fresh_mean_ms: mean(fresh.iter().map(|f| f.1)),
            fresh_paths: 0,
            found: 0,
            recall: 0.0,
            others: 0,
        };
        let mut times = Vec::new();
        for (&source, (reference, _)) in sources.iter().zip(&fresh) {
            let (r, ms) = trace(source, Some(&mut cache), &o)?;
            times.push(ms);
            row.reused += usize::from(r.stats.beams_reused);
            row.fresh_paths += reference.len();
            row.found += reference
                .iter()
                .filter(|f| r.paths.iter().any(|p| same(p, f)))
                .count();
            row.others += r
                .paths
                .iter()
                .filter(|p| !reference.iter().any(|f| same(p, f)))
                .count();
        }
        row.update_mean_ms = mean(times.iter().copied());
        row.update_ms = median(times);
        row.recall = row.found as f64 / row.fresh_paths.max(1) as f64;
        rows.push(row);
    }
    Ok(rows)
}

fn mean(v: impl ExactSizeIterator<Item = f64>) -> f64 {
    let n = v.len().max(1) as f64;
    v.sum::<f64>() / n
}

/// The same path: the same reflection points in the same order, within
/// rounding (a re-mirrored frustum's path is validated exactly, as a
/// fresh one's is).
fn same(a: &SoundPath, b: &SoundPath) -> bool {
    let close = |x: [f64; 3], y: [f64; 3]| {
        let (x, y) = (DVec3::from(x), DVec3::from(y));
        x.distance(y) <= 1e-6 * x.length().max(1.0)
    };
    a.order == b.order
        && a.surfaces.len() == b.surfaces.len()
        && a.surfaces
            .iter()
            .zip(&b.surfaces)
            .all(|(x, y)| close(x.point, y.point))
}

fn table(rows: &[Row], provenance: &Provenance, args: &Args) -> String {
    let mut out = provenance.header();
    out += &format!(
        "\na source moving {} m per update along a circle of radius {} m, {} updates; order {}, N = {}, no tail or diffraction; \
         update ms = median and mean wall time of an update (reusing frusta within reuse m, else tracing); fresh ms = median and mean \
         of a fresh trace at each position (same cells and sampling, no cache), the recall's reference, all run before the updates; \
         speed-up = fresh mean over update mean; recall rounded down; others = validated paths the updates found \
         that the fresh traces missed\n\n",
        args.step, args.radius, args.updates, args.order, args.sampling
    );
    let mut cells = vec![[
        "scene",
        "cells",
        "reuse m",
        "updates",
        "reused",
        "update ms",
        "mean ms",
        "fresh ms",
        "fresh mean",
        "speed-up",
        "fresh paths",
        "found",
        "recall",
        "others",
    ]
    .map(String::from)
    .to_vec()];
    for r in rows {
        cells.push(vec![
            r.scene.clone(),
            r.cells.to_string(),
            format!("{}", r.reuse_m),
            r.updates.to_string(),
            r.reused.to_string(),
            format!("{:.2}", r.update_ms),
            format!("{:.2}", r.update_mean_ms),
            format!("{:.2}", r.fresh_ms),
            format!("{:.2}", r.fresh_mean_ms),
            format!("{:.1}x", r.fresh_mean_ms / r.update_mean_ms),
            r.fresh_paths.to_string(),
            r.found.to_string(),
            format!("{:.3}", (r.recall * 1000.0).floor() / 1000.0),
            r.others.to_string(),
        ]);
    }
    out + &aligned(&cells, 2)
}
