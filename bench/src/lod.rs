//! `frusta-bench lod`: ray queries with cones against the hierarchy's
//! levels of detail (R-LODs, `frusta_engine::bvh::lod`) at growing error
//! bounds, beside the same rays on exact geometry: time, how many rays a
//! plane answered, and how far their hits moved. Rays leave the hall's
//! listener over the whole sphere (a spherical Fibonacci set), each with
//! the cone of one of a stochastic tail's rays (8192 over the sphere).
//! Bounds and exact geometry run in interleaved rounds on all threads;
//! times are medians.
//!
//! Impulse responses with levels of detail (frusta meeting planes) are not
//! in the engine yet: every row is a `"rays"` row and the impulse-response
//! fields are `null`.

use std::path::PathBuf;
use std::time::Instant;

use frusta_engine::bvh::lod::{self, Cone, LodOptions, LodTree};
use frusta_engine::bvh::{BuildOptions, MeshBvh};
use frusta_engine::geometry::Ray;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::mesh;
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

/// One bound on one scene.
#[derive(Clone, Debug, Serialize)]
struct Run {
    scene: String,
    query: &'static str,
    lod_bound: f32,
    ms: f64,
    exact_ms: f64,
    frusta: Option<u64>,
    energy_error_db_max: Option<f64>,
    parameter_error_jnd_max: Option<f64>,
    /// Largest distance between a ray's hit with levels of detail and its
    /// exact hit, metres.
    hit_displacement_max: Option<f64>,
    triangles: usize,
    rays: usize,
    /// Rays answered by a plane.
    plane_hits: usize,
    /// Rays that hit with one and not the other.
    hit_mismatches: usize,
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
    if bounds.iter().any(|b| !(b.is_finite() && *b >= 0.0)) {
        return Err("--bound takes finite non-negative metres".into());
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
            run.ms = median(t);
            run.exact_ms = exact_ms;
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
    let mut run = Run {
        scene: String::new(),
        query: "rays",
        lod_bound: 0.0,
        ms: 0.0,
        exact_ms: 0.0,
        frusta: None,
        energy_error_db_max: None,
        parameter_error_jnd_max: None,
        hit_displacement_max: Some(0.0),
        triangles: 0,
        rays: rays.len(),
        plane_hits: 0,
        hit_mismatches: 0,
    };
    for (answer, exact) in answers.iter().zip(exact) {
        match (answer, exact) {
            (Some((t, error)), Some(e)) => {
                // Unit directions: the distance between the hit points.
                let moved = f64::from((t - e).abs());
                run.hit_displacement_max = run.hit_displacement_max.map(|m| m.max(moved));
                run.plane_hits += usize::from(*error > 0.0);
            }
            (None, None) => {}
            _ => run.hit_mismatches += 1,
        }
    }
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
fn peak_rss_mb() -> Option<f64> {
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
    for r in runs {
        out += &format!(
            "{:<12} {:>8} {:>9.2} {:>9.2} {:>6.2}x {:>10.4} {:>7.1}% {:>11}\n",
            r.scene,
            r.lod_bound,
            r.ms,
            r.exact_ms,
            r.exact_ms / r.ms,
            r.hit_displacement_max.unwrap_or(f64::NAN),
            100.0 * r.plane_hits as f64 / r.rays as f64,
            r.hit_mismatches,
        );
    }
    out
}
