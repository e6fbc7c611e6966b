//! `frusta-bench lod`: ray queries with cones against the hierarchy's
//! levels of detail (R-LODs, `frusta_engine::bvh::lod`) at growing error
//! bounds, beside the same rays on exact geometry: time, how many rays a
//! plane answered, and how far their hits moved. Rays leave the hall's
//! listener over the whole sphere (a spherical Fibonacci set), each with
//! the cone of one of a stochastic tail's rays (8192 over the sphere).
//! Bounds and exact geometry run in interleaved rounds on all threads;
//! times are medians.
//!
//! Impulse responses run on the hall simplified at each bound (see
//! [`ir`]), beside exact geometry; their rows are `"ir"` rows.

mod ir;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use frusta_engine::acoustics::CellAssignment;
use frusta_engine::bvh::lod::{self, Cone, LodOptions, LodTree};
use frusta_engine::bvh::{BuildOptions, MeshBvh};
use frusta_engine::geometry::Ray;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::mesh;
use crate::propagation::scenes;
use crate::provenance::{self, Provenance};
use crate::stats::median;

#[derive(clap::Args)]
pub struct Args {
    /// A hall: `scenes/hall-<SIZE>.json` where bundled (10k, 200k), else
    /// that hall generated at SIZE triangles (e.g. 20m) (repeatable;
    /// default 200k).
    #[arg(long)]
    hall: Vec<String>,
    /// Rays per set, from the listener over the sphere.
    #[arg(long, default_value_t = 1 << 18)]
    rays: usize,
    /// Each ray's cone is that of one of this many rays over the sphere
    /// (the default, a stochastic tail's rays).
    #[arg(long, default_value_t = 8192)]
    cone_rays: usize,
    /// Error bounds in metres (repeatable; default 0.01 to 0.5); exact
    /// geometry is always run beside them.
    #[arg(long = "bound")]
    bounds: Vec<f32>,
    /// Error bounds in metres of the impulse responses (repeatable;
    /// default 0.5, 1 and 2: a wavelength at about 700, 340 and 170 Hz).
    #[arg(long = "ir-bound")]
    ir_bounds: Vec<f32>,
    /// Reflection order of the impulse responses' exact paths.
    #[arg(long, default_value_t = 4)]
    order: u32,
    /// Cells per frustum side (N) of the impulse responses.
    #[arg(long, default_value_t = 8)]
    sampling: u32,
    /// An impulse response still running after this many seconds is
    /// stopped and reported as not finished.
    #[arg(long, default_value_t = 60.0)]
    ir_limit_s: f64,
    /// Halls of the impulse responses, as `--hall` (repeatable; default
    /// 200k).
    #[arg(long)]
    ir_hall: Vec<String>,
    /// Ray queries only.
    #[arg(long)]
    no_ir: bool,
    /// Timed rounds; the median is reported.
    #[arg(long, default_value_t = 5)]
    rounds: usize,
    /// Print the runs as JSON instead of the table.
    #[arg(long)]
    json: bool,
    /// Also write `lod.txt` and `lod.json` (with provenance) into this
    /// directory.
    #[arg(long)]
    save: Option<PathBuf>,
}

/// The listener of the propagation benchmark's halls: ear height over the
/// left seat block.
const LISTENER: Vec3 = Vec3::new(22.0, 9.0, 1.7);

/// One bound on one scene: a set of rays, or an impulse response.
#[derive(Clone, Debug, Serialize)]
struct Run {
    scene: String,
    query: &'static str,
    lod_bound: f32,
    /// `None` where it did not finish within the limit.
    ms: Option<f64>,
    exact_ms: Option<f64>,
    frusta: Option<u64>,
    energy_error_db_max: Option<f64>,
    parameter_error_jnd_max: Option<f64>,
    /// Largest distance between a ray's hit with levels of detail and its
    /// exact hit, metres.
    hit_displacement_max: Option<f64>,
    /// Triangles queried: the simplified scene's for impulse responses.
    triangles: usize,
    rays: Option<usize>,
    /// Rays answered by a plane.
    plane_hits: Option<usize>,
    /// Rays that hit with one and not the other.
    hit_mismatches: Option<usize>,
    /// Impulse responses: the cells, the exact geometry's cells compared
    /// against, the nodes that became polygons, and the time to simplify
    /// the scene and build it.
    cells: Option<CellAssignment>,
    reference_cells: Option<CellAssignment>,
    polygons: Option<usize>,
    setup_ms: Option<f64>,
    /// Of the first run: its paths, and the time of its exact part and of
    /// its tail (the rest is diffraction, beside the tail, and synthesis).
    paths: Option<usize>,
    trace_ms: Option<f64>,
    tail_ms: Option<f64>,
    /// The errors of exact geometry with the tail's next seed: the tail's
    /// own noise, below which a difference says nothing of the bound.
    tail_noise_db: Option<f64>,
    tail_noise_jnd: Option<f64>,
    /// Building exact geometry's acoustic scene, and the process's peak
    /// resident memory once the hall's impulse responses have all run
    /// (including the scenes run before).
    exact_setup_ms: Option<f64>,
    peak_rss_mb: Option<f64>,
}

impl Run {
    fn new(scene: &str, query: &'static str, lod_bound: f32) -> Self {
        Self {
            scene: scene.to_string(),
            query,
            lod_bound,
            ms: None,
            exact_ms: None,
            frusta: None,
            energy_error_db_max: None,
            parameter_error_jnd_max: None,
            hit_displacement_max: None,
            triangles: 0,
            rays: None,
            plane_hits: None,
            hit_mismatches: None,
            cells: None,
            reference_cells: None,
            polygons: None,
            setup_ms: None,
            paths: None,
            trace_ms: None,
            tail_ms: None,
            tail_noise_db: None,
            tail_noise_jnd: None,
            exact_setup_ms: None,
            peak_rss_mb: None,
        }
    }
}

/// A scene's setup: what it took to have the queries ready.
#[derive(Clone, Debug, Serialize)]
struct Setup {
    scene: String,
    triangles: usize,
    build_ms: f64,
    fit_ms: f64,
    bvh_bytes: usize,
    lod_bytes: usize,
    /// The process's peak resident memory so far, after this scene ran
    /// (VmHWM): it includes the scenes run before it.
    peak_rss_mb: Option<f64>,
}

#[derive(Serialize)]
struct Printed<'a> {
    runs: &'a [Run],
    scenes: &'a [Setup],
}

#[derive(Serialize)]
struct Saved<'a> {
    #[serde(flatten)]
    provenance: Provenance,
    rounds: usize,
    #[serde(flatten)]
    printed: Printed<'a>,
}

pub fn run(args: Args) -> Result<(), String> {
    let mut provenance = provenance::start(rayon::current_num_threads());
    let halls = if args.hall.is_empty() {
        vec!["200k".to_string()]
    } else {
        args.hall.clone()
    };
    let bounds = if args.bounds.is_empty() {
        vec![0.01, 0.02, 0.05, 0.1, 0.2, 0.5]
    } else {
        args.bounds.clone()
    };
    let ir_bounds = if args.ir_bounds.is_empty() {
        vec![0.5, 1.0, 2.0]
    } else {
        args.ir_bounds.clone()
    };
    if bounds
        .iter()
        .chain(&ir_bounds)
        .any(|b| !(b.is_finite() && *b >= 0.0))
    {
        return Err("--bound takes finite non-negative metres".into());
    }
    if !(args.ir_limit_s.is_finite() && args.ir_limit_s > 0.0) {
        return Err("--ir-limit-s takes a finite number of seconds above 0".into());
    }
    let rays = sphere_rays(LISTENER, args.rays.max(1));
    let cone = Cone {
        spread: 0.0,
        angle: 2.0 / (args.cone_rays.max(1) as f32).sqrt(),
    };
    let (mut runs, mut scenes) = (Vec::new(), Vec::new());
    for size in &halls {
        let hall = mesh::hall(size)?;
        eprintln!("{}: {} triangles", hall.name, hall.mesh.triangle_count());
        let start = Instant::now();
        let bvh = MeshBvh::build(&hall.mesh, &BuildOptions::default());
        let build_ms = ms_since(start);
        let start = Instant::now();
        let lods = LodTree::fit(&bvh);
        let fit_ms = ms_since(start);
        let options: Vec<LodOptions> = bounds
            .iter()
            .map(|&max_error| LodOptions {
                max_error,
                cone: Some(cone),
            })
            .collect();
        let exact: Vec<Option<f32>> = rays
            .par_iter()
            .map(|r| bvh.closest_hit(r).map(|h| h.t))
            .collect();
        let mut times = vec![Vec::new(); options.len()];
        let mut exact_times = Vec::new();
        // Each round starts one set later, so no set always runs first.
        let sets = options.len() + 1;
        for round in 0..args.rounds.max(1) {
            for k in (0..sets).map(|k| (k + round) % sets) {
                let start = Instant::now();
                let hits = match options.get(k) {
                    None => rays
                        .par_iter()
                        .filter(|r| bvh.closest_hit(r).is_some())
                        .count(),
                    Some(o) => rays
                        .par_iter()
                        .filter(|r| matches!(lod::closest_hit(&bvh, &lods, r, o), Ok(Some(_))))
                        .count(),
                };
                std::hint::black_box(hits);
                match times.get_mut(k) {
                    None => exact_times.push(ms_since(start)),
                    Some(t) => t.push(ms_since(start)),
                }
            }
        }
        let exact_ms = median(exact_times);
        for ((o, t), &bound) in options.iter().zip(times).zip(&bounds) {
            let mut run = compare(&bvh, &lods, &rays, &exact, o)?;
            run.scene = hall.name.clone();
            run.lod_bound = bound;
            run.ms = Some(median(t));
            run.exact_ms = Some(exact_ms);
            run.triangles = hall.mesh.triangle_count();
            runs.push(run);
        }

        scenes.push(Setup {
            scene: hall.name.clone(),
            triangles: hall.mesh.triangle_count(),
            build_ms,
            fit_ms,
            bvh_bytes: bvh.memory_bytes(),
            lod_bytes: lods.memory_bytes(),
            peak_rss_mb: peak_rss_mb(),
        });
    }
    let ir_halls = match (args.no_ir, args.ir_hall.is_empty()) {
        (true, _) => Vec::new(),
        (false, true) => vec!["200k".to_string()],
        (false, false) => args.ir_hall.clone(),
    };
    let setup = ir::IrSetup {
        order: args.order,
        sampling: args.sampling,
        limit: Duration::from_secs_f64(args.ir_limit_s),
        rounds: args.rounds,
    };
    for size in &ir_halls {
        let name = format!("hall-{size}");
        let scene = mesh::hall_scene(size)?;
        runs.extend(ir::runs(
            &name,
            &scene,
            scenes::points(&name),
            &ir_bounds,
            &setup,
        )?);
    }
    provenance.finish();
    let text = format!(
        "{}\n{}",
        provenance.header(),
        table(&runs, &scenes, &args, cone)
    );
    let printed = Printed {
        runs: &runs,
        scenes: &scenes,
    };
    let saved = Saved {
        provenance,
        rounds: args.rounds.max(1),
        printed: Printed {
            runs: &runs,
            scenes: &scenes,
        },
    };
    provenance::emit(
        "lod",
        &printed,
        &saved,
        &text,
        args.json,
        args.save.as_deref(),
    )
}

/// The bound's answers against the exact ones, ray by ray.
fn compare(
    bvh: &MeshBvh,
    lods: &LodTree,
    rays: &[Ray],
    exact: &[Option<f32>],
    options: &LodOptions,
) -> Result<Run, String> {
    let answers: Vec<Option<(f32, f32)>> = rays
        .par_iter()
        .map(|r| lod::closest_hit(bvh, lods, r, options).map(|h| h.map(|h| (h.hit.t, h.error))))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    let mut run = Run::new("", "rays", 0.0);
    let (mut moved_max, mut plane_hits, mut mismatches) = (0.0f64, 0, 0);
    for (answer, exact) in answers.iter().zip(exact) {
        match (answer, exact) {
            (Some((t, error)), Some(e)) => {
                // Unit directions: the distance between the hit points.
                moved_max = moved_max.max(f64::from((t - e).abs()));
                plane_hits += usize::from(*error > 0.0);
            }
            (None, None) => {}
            _ => mismatches += 1,
        }
    }
    run.hit_displacement_max = Some(moved_max);
    run.rays = Some(rays.len());
    run.plane_hits = Some(plane_hits);
    run.hit_mismatches = Some(mismatches);
    Ok(run)
}

/// `n` unit rays from `origin` over the sphere (spherical Fibonacci).
fn sphere_rays(origin: Vec3, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let phi = k as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let s = (1.0 - z * z).sqrt();
            let dir = glam::DVec3::new(s * phi.cos(), s * phi.sin(), z).as_vec3();
            Ray::new(origin, dir)
        })
        .collect()
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// VmHWM of this process, MB (Linux).
pub(super) fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn table(runs: &[Run], scenes: &[Setup], args: &Args, cone: Cone) -> String {
    let mut out = format!(
        "ray queries with levels of detail: {} rays from the listener {LISTENER} over the sphere, \
         cone angle {:.4} (the share of the sphere of one of {} rays); ms = median of {} interleaved rounds \
         on all threads; exact = the same rays on the triangles; moved = largest distance between \
         a ray's hit and its exact hit; planes = rays a plane answered; mismatched = rays that hit \
         with one and not the other\n\n",
        args.rays.max(1),
        cone.angle,
        args.cone_rays,
        args.rounds.max(1),
    );
    for s in scenes {
        out += &format!(
            "{}: {} triangles, BVH {:.0} ms and {:.1} MB, planes fitted in {:.0} ms, {:.1} MB; \
             peak RSS {}\n",
            s.scene,
            s.triangles,
            s.build_ms,
            s.bvh_bytes as f64 / 1e6,
            s.fit_ms,
            s.lod_bytes as f64 / 1e6,
            s.peak_rss_mb.map_or("-".into(), |m| format!("{m:.0} MB")),
        );
    }
    out += &format!(
        "\n{:<12} {:>8} {:>9} {:>9} {:>7} {:>10} {:>8} {:>11}\n",
        "scene", "bound m", "ms", "exact ms", "speed", "moved m", "planes", "mismatched"
    );
    out += &"-".repeat(82);
    out.push('\n');
    let fmt = |x: Option<f64>, digits: usize| x.map_or("-".into(), |x| format!("{x:.digits$}"));
    for r in runs.iter().filter(|r| r.query == "rays") {
        let (ms, exact_ms) = (r.ms.unwrap_or(f64::NAN), r.exact_ms.unwrap_or(f64::NAN));
        out += &format!(
            "{:<12} {:>8} {:>9.2} {:>9.2} {:>6.2}x {:>10} {:>7.1}% {:>11}\n",
            r.scene,
            r.lod_bound,
            ms,
            exact_ms,
            exact_ms / ms,
            fmt(r.hit_displacement_max, 4),
            100.0 * r.plane_hits.unwrap_or(0) as f64 / r.rays.unwrap_or(1).max(1) as f64,
            r.hit_mismatches.unwrap_or(0),
        );
    }
    if runs.iter().any(|r| r.query == "ir") {
        out += &format!(
            "\nimpulse responses with levels of detail: the hall simplified at each bound (every \
             highest node of error below it one polygon; setup = simplifying and building), exact \
             paths to order {} (N = {}) then the default tail, air and diffraction, source {:?} and \
             listener {:?}; ms = median of {} interleaved rounds, - = not finished within {} s; \
             errors against exact geometry with the cells in `against`: the largest band energy \
             difference (dB) and the largest EDT, T30, C80 or D50 difference in any band (JND: 5 %, \
             5 %, 1 dB, 0.05)\n\n",
            args.order,
            args.sampling,
            scenes::points("hall").0.to_array(),
            scenes::points("hall").1.to_array(),
            args.rounds.max(1),
            args.ir_limit_s,
        );
        out += &format!(
            "{:<12} {:<13} {:>7} {:>9} {:>8} {:>8} {:>9} {:>9} {:>7} {:>8} {:>8} {:>8} {:>6} {:>9} {:>6} {:<13}\n",
            "scene", "cells", "bound m", "triangles", "polygons", "setup ms", "ms", "exact ms",
            "speed", "trace ms", "tail ms", "frusta", "paths", "energy dB", "JND", "against"
        );
        out += &"-".repeat(152);
        out.push('\n');
        let mut noise = Vec::new();
        for r in runs.iter().filter(|r| r.query == "ir") {
            let name = |c: Option<CellAssignment>| match c {
                Some(CellAssignment::Sampled) => "sampled",
                Some(CellAssignment::Conservative) => "conservative",
                None => "-",
            };
            let speed = r.ms.zip(r.exact_ms).map(|(m, e)| e / m);
            out += &format!(
                "{:<12} {:<13} {:>7} {:>9} {:>8} {:>8} {:>9} {:>9} {:>6}x {:>8} {:>8} {:>8} {:>6} {:>9} {:>6} {:<13}\n",
                r.scene,
                name(r.cells),
                r.lod_bound,
                r.triangles,
                r.polygons.unwrap_or(0),
                fmt(r.setup_ms, 0),
                fmt(r.ms, 1),
                fmt(r.exact_ms, 1),
                fmt(speed, 2),
                fmt(r.trace_ms, 1),
                fmt(r.tail_ms, 1),
                r.frusta.map_or("-".into(), |f| f.to_string()),
                r.paths.map_or("-".into(), |f| f.to_string()),
                fmt(r.energy_error_db_max, 2),
                fmt(r.parameter_error_jnd_max, 2),
                name(r.reference_cells),
            );
            noise.push(r);
        }
        noise.dedup_by(|a, b| a.scene == b.scene);
        for r in noise {
            out += &format!(
                "{}: exact geometry built in {} ms; tail noise (exact geometry, sampled cells, the \
                 tail's next seed against its first) {} dB, {} JND; peak RSS {} MB\n",
                r.scene,
                fmt(r.exact_setup_ms, 0),
                fmt(r.tail_noise_db, 2),
                fmt(r.tail_noise_jnd, 2),
                fmt(r.peak_rss_mb, 0),
            );
        }
    }
    out
}
