//! One round of one implementation: build, trace every ray set once, refit,
//! check the refit. [`super::rounds`] interleaves these so that every ratio
//! compares measurements taken minutes, not runs, apart.

use std::hint::black_box;
use std::time::Instant;

use frusta_engine::geometry::Ray;
use glam::Vec3;
use rayon::prelude::*;

use super::check::{Reference, RefitCheck};
use super::Accel;
use crate::mesh::BenchMesh;
use crate::report::{MraysPerS, Round};

/// Rays per rayon task.
const CHUNK: usize = 1024;

/// What every implementation is measured on.
pub struct Input<'a> {
    pub mesh: &'a BenchMesh,
    pub coherent: &'a [Ray],
    pub incoherent: &'a [Ray],
    /// The refit target ([`BenchMesh::deformed_positions`]).
    pub deformed: &'a [Vec3],
    /// Brute-force closest hits of sampled rays on `deformed`.
    pub refit_reference: &'a Reference,
    /// Timed builds per round (median); refits: twice this many.
    pub build_runs: usize,
}

/// What a tree is, as opposed to how fast it was made: taken in the first
/// round only.
pub struct Structure {
    pub sah_cost: Option<f64>,
    pub bytes_per_triangle: f64,
    /// Closest-hit distances, coherent then incoherent (the mismatch
    /// cross-check against ours).
    pub distances: Vec<Option<f32>>,
}

pub struct Measured {
    pub round: Round,
    /// `Some` in the first round.
    pub structure: Option<Structure>,
}

pub fn median(mut v: Vec<f64>) -> f64 {
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

/// Million rays per second of one pass of `query` over `rays`.
fn rate<R: Sync>(rays: &[R], query: impl Fn(&R) -> bool + Sync) -> f64 {
    let t = Instant::now();
    let hits: usize = rays
        .par_chunks(CHUNK)
        .map(|c| c.iter().filter(|r| query(r)).count())
        .sum();
    black_box(hits);
    rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6
}

fn build<A: Accel>(mesh: &BenchMesh, runs: usize, warm_up: bool) -> (A, f64) {
    if warm_up {
        drop(black_box(A::build(A::prepare(mesh))));
    }
    let mut times = Vec::new();
    let mut built = None;
    for _ in 0..runs.max(1) {
        drop(built.take());
        let prepared = A::prepare(mesh);
        let t = Instant::now();
        let a = A::build(prepared);
        times.push(ms_since(t));
        built = Some(a);
    }
    (built.expect("at least one build"), median(times))
}

/// Median time of refits alternating between the deformed and the original
/// positions, then one more (untimed) to the deformed ones and the check.
/// `None` when the peer has no refit.
fn refit<A: Accel>(a: &mut A, input: &Input, warm_up: bool) -> Option<(f64, RefitCheck)> {
    let mesh = input.mesh;
    let moved = a.prepare_refit(mesh, input.deformed)?;
    let original = a.prepare_refit(mesh, mesh.positions())?;
    if warm_up {
        a.refit(&original);
    }
    let times = (0..input.build_runs.max(1) * 2)
        .map(|i| {
            let target = if i % 2 == 0 { &moved } else { &original };
            let t = Instant::now();
            a.refit(target);
            ms_since(t)
        })
        .collect();
    a.refit(&moved);
    let rays: Vec<A::Ray> = input
        .refit_reference
        .rays()
        .iter()
        .map(|r| a.ray(r))
        .collect();
    let check = input.refit_reference.check(&closest_all(a, &rays));
    Some((median(times), check))
}

/// One round of `A`; `first` adds warm-ups and the structure.
pub fn measure<A: Accel>(input: &Input, first: bool) -> Measured {
    let mesh = input.mesh;
    let (mut accel, build_ms) = build::<A>(mesh, input.build_runs, first);
    let coherent: Vec<A::Ray> = input.coherent.iter().map(|r| accel.ray(r)).collect();
    let incoherent: Vec<A::Ray> = input.incoherent.iter().map(|r| accel.ray(r)).collect();
    // The first round's warm-up passes give the distances for the mismatch.
    let structure = first.then(|| {
        let mut distances = closest_all(&accel, &coherent);
        distances.extend(closest_all(&accel, &incoherent));
        Structure {
            sah_cost: accel.sah_cost(),
            bytes_per_triangle: accel.memory_bytes() as f64 / mesh.mesh.triangle_count() as f64,
            distances,
        }
    });
    let a = &accel;
    let mrays_per_s = MraysPerS {
        coherent_closest: rate(&coherent, |r| a.closest(r).is_some()),
        incoherent_closest: rate(&incoherent, |r| a.closest(r).is_some()),
        coherent_any: rate(&coherent, |r| a.any(r)),
        incoherent_any: rate(&incoherent, |r| a.any(r)),
    };
    let refitted = refit(&mut accel, input, first);
    Measured {
        round: Round {
            build_ms,
            refit_ms: refitted.map(|r| r.0),
            mrays_per_s,
            refit_check: refitted.map(|r| r.1),
        },
        structure,
    }
}
