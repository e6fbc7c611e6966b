//! `frusta-bench bvh`: our BVH against peer libraries, side by side on the
//! same mesh and the same rays.
//!
//! Every implementation is one small [`Accel`] impl in its own file; the
//! driver [`run`] measures all of them the same way:
//! - build: the mesh is converted to the peer's input outside the timer
//!   ([`Accel::prepare`], before each build); one warm-up build, then the median of
//!   `build_runs` timed [`Accel::build`] calls;
//! - trace: rays are converted to the peer's ray type outside the timer; one
//!   warm-up pass (which also records closest-hit distances for the
//!   cross-check), then the best of `trace_runs` timed passes. Every pass is
//!   `par_chunks` over rayon's pool, so all implementations use the same
//!   threads;
//! - refit: after tracing, the vertices are moved slightly
//!   ([`crate::mesh::BenchMesh::deformed_positions`]) and back, alternately;
//!   the median of the timed refits.

pub mod bvh_crate;
#[cfg(feature = "embree")]
pub mod embree;
pub mod frusta;
pub mod obvhs;
pub mod parry;

use std::hint::black_box;
use std::time::Instant;

use frusta_engine::geometry::Ray;
use glam::Vec3;
use rayon::prelude::*;

use crate::mesh::BenchMesh;
use crate::report::{ImplResult, MraysPerS};

/// Rays per rayon task.
const CHUNK: usize = 1024;

/// One acceleration structure under test. Plain functions around a built
/// structure; conversions (`prepare`, `ray`, `prepare_refit`) are untimed.
pub trait Accel: Sized + Sync {
    const NAME: &'static str;
    /// The mesh in the peer's input format.
    type Prepared;
    /// The peer's ray type (with any per-ray precomputation it wants).
    type Ray: Sync;
    /// New vertex positions in the form the peer's refit takes.
    type RefitInput;

    fn prepare(mesh: &BenchMesh) -> Self::Prepared;
    fn build(prepared: Self::Prepared) -> Self;
    fn ray(&self, ray: &Ray) -> Self::Ray;
    /// The closest hit's `t` (unit directions: a distance).
    fn closest(&self, ray: &Self::Ray) -> Option<f32>;
    fn any(&self, ray: &Self::Ray) -> bool;
    /// `None` when the peer has no refit.
    fn prepare_refit(&self, mesh: &BenchMesh, positions: &[Vec3]) -> Option<Self::RefitInput>;
    fn refit(&mut self, input: &Self::RefitInput);
    /// The SAH cost (`C_t = C_i = 1`, see the README); `None` when the tree
    /// cannot be inspected.
    fn sah_cost(&self) -> Option<f64>;
    /// Bytes of the structure including the triangle data it traces against.
    fn memory_bytes(&self) -> usize;
}

/// What every implementation is measured on.
pub struct Input<'a> {
    pub mesh: &'a BenchMesh,
    pub coherent: &'a [Ray],
    pub incoherent: &'a [Ray],
    /// Our closest-hit distances on `coherent` then `incoherent`; `None`
    /// while measuring ourselves.
    pub reference: Option<&'a [Option<f32>]>,
    pub build_runs: usize,
    pub trace_runs: usize,
}

/// The measurements plus the closest-hit distances (coherent then
/// incoherent) for the cross-check.
pub struct Measured {
    pub result: ImplResult,
    pub distances: Vec<Option<f32>>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn closest_all<A: Accel>(a: &A, rays: &[A::Ray]) -> Vec<Option<f32>> {
    let mut out = vec![None; rays.len()];
    out.par_chunks_mut(CHUNK)
        .zip(rays.par_chunks(CHUNK))
        .for_each(|(o, r)| {
            for (o, r) in o.iter_mut().zip(r) {
                *o = a.closest(r);
            }
        });
    out
}

/// Million rays per second, best of `runs` timed passes.
fn rate(rays: usize, runs: usize, mut pass: impl FnMut()) -> f64 {
    let best = (0..runs.max(1))
        .map(|_| {
            let t = Instant::now();
            pass();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    rays as f64 / best / 1e6
}

fn closest_rate<A: Accel>(a: &A, rays: &[A::Ray], runs: usize) -> f64 {
    rate(rays.len(), runs, || {
        let hits: usize = rays
            .par_chunks(CHUNK)
            .map(|c| c.iter().filter(|r| a.closest(r).is_some()).count())
            .sum();
        black_box(hits);
    })
}

fn any_rate<A: Accel>(a: &A, rays: &[A::Ray], runs: usize) -> f64 {
    let warm: usize = rays
        .par_chunks(CHUNK)
        .map(|c| c.iter().filter(|r| a.any(r)).count())
        .sum();
    black_box(warm);
    rate(rays.len(), runs, || {
        let hits: usize = rays
            .par_chunks(CHUNK)
            .map(|c| c.iter().filter(|r| a.any(r)).count())
            .sum();
        black_box(hits);
    })
}

/// The fraction of rays whose closest hit differs from ours: hit vs miss, or
/// distances more than 1e-4 apart relative to ours.
pub fn mismatch(ours: &[Option<f32>], theirs: &[Option<f32>]) -> f64 {
    let bad = ours
        .iter()
        .zip(theirs)
        .filter(|(a, b)| match (a, b) {
            (Some(a), Some(b)) => (a - b).abs() > 1e-4 * a.abs().max(1e-30),
            (None, None) => false,
            _ => true,
        })
        .count();
    bad as f64 / ours.len().max(1) as f64
}

/// Measures one implementation.
pub fn run<A: Accel>(input: &Input) -> Measured {
    let mesh = input.mesh;
    drop(black_box(A::build(A::prepare(mesh))));
    let mut times = Vec::new();
    let mut built = None;
    for _ in 0..input.build_runs.max(1) {
        drop(built.take());
        let prepared = A::prepare(mesh);
        let t = Instant::now();
        let a = A::build(prepared);
        times.push(ms_since(t));
        built = Some(a);
    }
    let build_ms = median(times);
    let mut accel = built.expect("at least one build");
    let sah_cost = accel.sah_cost();
    let bytes = accel.memory_bytes();

    let coherent: Vec<A::Ray> = input.coherent.iter().map(|r| accel.ray(r)).collect();
    let incoherent: Vec<A::Ray> = input.incoherent.iter().map(|r| accel.ray(r)).collect();

    // Warm-up passes that also give the distances for the cross-check.
    let mut distances = closest_all(&accel, &coherent);
    distances.extend(closest_all(&accel, &incoherent));
    let runs = input.trace_runs;
    let mrays_per_s = MraysPerS {
        coherent_closest: closest_rate(&accel, &coherent, runs),
        incoherent_closest: closest_rate(&accel, &incoherent, runs),
        coherent_any: any_rate(&accel, &coherent, runs),
        incoherent_any: any_rate(&accel, &incoherent, runs),
    };
    let mismatch_fraction = input.reference.map_or(0.0, |r| mismatch(r, &distances));

    let deformed = mesh.deformed_positions();
    let refit_ms = accel
        .prepare_refit(mesh, &deformed)
        .zip(accel.prepare_refit(mesh, mesh.positions()))
        .map(|(moved, original)| {
            accel.refit(&original); // warm-up
            let times = (0..input.build_runs.max(1) * 2)
                .map(|i| {
                    let target = if i % 2 == 0 { &moved } else { &original };
                    let t = Instant::now();
                    accel.refit(target);
                    ms_since(t)
                })
                .collect();
            median(times)
        });

    Measured {
        result: ImplResult {
            name: A::NAME,
            build_ms,
            refit_ms,
            sah_cost,
            mrays_per_s,
            bytes_per_triangle: bytes as f64 / mesh.mesh.triangle_count() as f64,
            mismatch_fraction,
        },
        distances,
    }
}

/// Which implementations to run, in report order.
pub const IMPLS: &[&str] = &["frusta", "bvh", "obvhs", "parry3d", "embree"];

/// Runs implementation `name`; `None` if it is not compiled in.
pub fn run_named(name: &str, input: &Input) -> Option<Measured> {
    Some(match name {
        "frusta" => run::<frusta::Frusta>(input),
        "bvh" => run::<bvh_crate::BvhCrate>(input),
        "obvhs" => run::<obvhs::Obvhs>(input),
        "parry3d" => run::<parry::Parry>(input),
        #[cfg(feature = "embree")]
        "embree" => run::<embree::Embree>(input),
        _ => return None,
    })
}

/// Sum of `SA(node)` over inner nodes plus `SA(leaf) * tris` over leaves,
/// over `SA(root)`: the helper every inspectable tree reports through.
#[derive(Default)]
pub struct SahSum {
    pub total: f64,
}

impl SahSum {
    pub fn inner(&mut self, area: f32) {
        self.total += area as f64;
    }

    pub fn leaf(&mut self, area: f32, tris: usize) {
        self.total += area as f64 * tris as f64;
    }

    pub fn cost(&self, root_area: f32) -> f64 {
        self.total / root_area as f64
    }
}

/// Surface area of a box given by its corners.
pub fn area(min: Vec3, max: Vec3) -> f32 {
    let e = (max - min).max(Vec3::ZERO);
    2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
}

/// Double-sided Möller–Trumbore: the hit `t` in `(0, t_max)`. Used for
/// peers that leave the primitive test to the caller (the `bvh` crate's own
/// test culls back faces).
#[inline(always)]
pub fn moller_trumbore(
    o: glam::Vec3A,
    d: glam::Vec3A,
    [a, b, c]: &[glam::Vec3A; 3],
    t_max: f32,
) -> Option<f32> {
    let e1 = *b - *a;
    let e2 = *c - *a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - *a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0 && t < t_max).then_some(t)
}
