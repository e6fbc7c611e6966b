//! `frusta-bench bvh`: our BVH against peer libraries, side by side on the
//! same mesh and the same rays.
//!
//! Every implementation is one small [`Accel`] impl in its own file; all of
//! them are measured the same way, in interleaved rounds
//! ([`rounds`]: medians over rounds, ratios to ours within a round). A
//! round of one implementation ([`measure`]):
//! - build: the mesh is converted to the peer's input outside the timer
//!   ([`Accel::prepare`], before each build); the median of `build_runs`
//!   timed [`Accel::build`] calls (one untimed warm-up in the first round);
//! - trace: rays are converted to the peer's ray type outside the timer;
//!   one timed pass per ray set (in the first round after an untimed pass
//!   that records closest-hit distances for the cross-check with ours).
//!   Every pass is `par_chunks` over rayon's pool, so all implementations
//!   trace on the same threads;
//! - refit: the vertices are moved slightly
//!   ([`crate::mesh::BenchMesh::deformed_positions`]) and back, alternately,
//!   median of the timed refits; then a last refit to the moved vertices and
//!   [`check`]: sampled rays against brute force on the moved mesh.

pub mod bvh_crate;
pub mod check;
pub mod cli;
#[cfg(feature = "embree")]
pub mod embree;
pub mod frusta;
pub mod measure;
pub mod obvhs;
pub mod parry;
pub mod rounds;

use frusta_engine::geometry::Ray;
use glam::Vec3;

use crate::mesh::BenchMesh;
use measure::{Input, Measured};

/// One acceleration structure under test. Plain functions around a built
/// structure; conversions (`prepare`, `ray`, `prepare_refit`) are untimed.
pub trait Accel: Sized + Sync {
    const NAME: &'static str;
    /// Whether the build runs on every thread (rayon's, or Embree's own
    /// pool of the same size); `false` labels a single-threaded builder.
    const PARALLEL_BUILD: bool = true;
    /// One line for the report: what the build and refit are, on how many
    /// threads.
    const NOTE: &'static str;
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

/// An implementation as the driver sees it: its labels and one round.
pub struct Impl {
    pub name: &'static str,
    pub parallel_build: bool,
    pub note: &'static str,
    pub measure: fn(&Input, bool) -> Measured,
}

fn entry<A: Accel>() -> Impl {
    Impl {
        name: A::NAME,
        parallel_build: A::PARALLEL_BUILD,
        note: A::NOTE,
        measure: measure::measure::<A>,
    }
}

/// Every implementation compiled in, in report order (ours first).
pub fn impls() -> Vec<Impl> {
    vec![
        entry::<frusta::Frusta<false>>(),
        entry::<frusta::Frusta<true>>(),
        entry::<bvh_crate::BvhCrate>(),
        entry::<obvhs::Obvhs>(),
        entry::<parry::Parry>(),
        #[cfg(feature = "embree")]
        entry::<embree::Embree<false>>(),
        #[cfg(feature = "embree")]
        entry::<embree::Embree<true>>(),
    ]
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
