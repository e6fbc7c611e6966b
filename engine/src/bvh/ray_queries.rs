//! Ray queries on a wide tree and the triangles of its leaves, whatever
//! their layout: [`MeshBvh`](super::MeshBvh) (corner copies) and
//! [`CompactBvh`](super::CompactBvh) (shared vertices) both answer through
//! these, so both give the same hits. Where a layout has an 8-wide tree
//! over the same leaf slots ([`Tree8`]: the plain [`Bvh8`] or the compact
//! [`CompactBvh8`], built where the CPU has AVX), unpruned rays walk it.
//! Its walk meets the same triangles, and the nearest hit is chosen by
//! distance then mesh index, so the answer does not depend on the walk's
//! order, except in the grazing cases of [`BOUND_SLACK`], where a machine
//! without AVX may answer differently.

use glam::{Vec3, Vec3A};

use super::compact::CompactBvh8;
#[cfg(target_arch = "x86_64")]
use super::traverse::ray8;
use super::traverse::{self, Flow, RayTest, WideTree};
use super::wide::Bvh8;
use super::MeshHit;
use crate::geometry::{Ray, TriangleHit, WatertightRay};

/// A tree whose leaves are ranges of triangle slots, and those triangles.
pub(crate) trait LeafTriangles {
    type Tree: WideTree<Leaf = (u32, u32)>;

    fn tree(&self) -> &Self::Tree;
    /// The corners of the triangle in slot `slot`.
    fn corners(&self, slot: u32) -> [Vec3A; 3];
    /// The mesh's index of the triangle in slot `slot`.
    fn prim_id(&self, slot: u32) -> u32;
    /// The 8-wide tree over the same leaf slots, where there is one (built
    /// only where the CPU has AVX).
    fn tree8(&self) -> Option<Tree8<'_>> {
        None
    }
}

/// An 8-wide tree rays walk: the plain layout's or the compact one's.
#[derive(Clone, Copy)]
pub(crate) enum Tree8<'a> {
    Plain(&'a Bvh8),
    Compact(&'a CompactBvh8),
}

/// Traces `ray` and calls `on_hit(slot, hit, t_max)` for every triangle it
/// meets within the current range; `on_hit` may shrink `t_max` and breaks
/// to stop. Invalid rays (non-finite or zero direction) meet nothing.
#[inline(always)]
pub(crate) fn walk<M: LeafTriangles>(
    mesh: &M,
    ray: &Ray,
    mut on_hit: impl FnMut(u32, TriangleHit, &mut f32) -> Flow,
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(tree) = mesh.tree8() {
        if !ray.is_valid() {
            return;
        }
        let tri_ray = WatertightRay::new(ray);
        // SAFETY: an 8-wide tree is built only where the CPU has AVX.
        unsafe {
            ray8::walk(tree, ray, |first, count, t_max| {
                leaf_hits(mesh, &tri_ray, ray.t_min, first, count, t_max, &mut on_hit)
            })
        };
        return;
    }
    walk_pruned(mesh, ray, |_, _, _| true, on_hit);
}

/// Hands `on_hit` the hits of `tri_ray` on leaf slots `first..first + count`.
#[inline(always)]
fn leaf_hits<M: LeafTriangles>(
    mesh: &M,
    tri_ray: &WatertightRay,
    t_min: f32,
    first: u32,
    count: u32,
    t_max: &mut f32,
    on_hit: &mut impl FnMut(u32, TriangleHit, &mut f32) -> Flow,
) -> Flow {
    for slot in first..first + count {
        let [a, b, c] = mesh.corners(slot);
        if let Some(h) = tri_ray.intersect(a, b, c, t_min, *t_max) {
            on_hit(slot, h, t_max)?;
        }
    }
    Flow::Continue(())
}

/// [`walk`], asking `open(node, entry, t_max)` before entering each inner
/// node below the root (see [`traverse::walk_pruned`]).
#[inline(always)]
pub(crate) fn walk_pruned<M: LeafTriangles>(
    mesh: &M,
    ray: &Ray,
    open: impl FnMut(usize, f32, &mut f32) -> bool,
    mut on_hit: impl FnMut(u32, TriangleHit, &mut f32) -> Flow,
) {
    if !ray.is_valid() {
        return;
    }
    let tri_ray = WatertightRay::new(ray);
    let t_min = ray.t_min;
    traverse::walk_pruned(
        mesh.tree(),
        &RayTest::new(ray),
        ray.t_max,
        open,
        |(first, count), t_max| leaf_hits(mesh, &tri_ray, t_min, first, count, t_max, &mut on_hit),
    );
}

/// The hit `h` on the triangle in slot `slot`.
#[inline]
pub(crate) fn mesh_hit<M: LeafTriangles>(mesh: &M, slot: u32, h: TriangleHit) -> MeshHit {
    let [a, b, c] = mesh.corners(slot);
    MeshHit {
        t: h.t,
        triangle: mesh.prim_id(slot),
        u: h.u,
        v: h.v,
        normal: Vec3::from((b - a).cross(c - a).normalize_or_zero()),
    }
}

/// How far past the best hit so far boxes are still opened, relative to its
/// distance: a box's entry distance is rounded (about 3 ulps) and so is a
/// hit's, so a box holding a hit at the same or a nearer distance may
/// compute an entry just past it. 2^-16 is about 128 ulps: enough unless a
/// hit's own distance carries more (a ray grazing a triangle whose corners
/// lie far beyond the hit, where the watertight test's distance loses
/// about 1e-3 relative), where a nearer hit can still be passed over.
pub(crate) const BOUND_SLACK: f32 = 1.0 / 65536.0;

/// The nearest hit within the ray's range; of hits at the same distance,
/// the one on the triangle of lowest mesh index, so the answer is the
/// brute-force one whatever the tree's order or layout (up to the grazing
/// cases of [`BOUND_SLACK`]).
#[inline]
pub(crate) fn closest_hit<M: LeafTriangles>(mesh: &M, ray: &Ray) -> Option<MeshHit> {
    nearest_on_slot(mesh, ray).map(|(slot, h)| mesh_hit(mesh, slot, h))
}

/// [`closest_hit`]'s distance and leaf slot alone, for callers that know
/// their triangles' planes: no hit point, barycentrics or normal.
#[inline]
pub(crate) fn closest_slot<M: LeafTriangles>(mesh: &M, ray: &Ray) -> Option<(f32, u32)> {
    nearest_on_slot(mesh, ray).map(|(slot, h)| (h.t, slot))
}

/// The nearest hit (see [`closest_hit`]) and its leaf slot.
#[inline(always)]
fn nearest_on_slot<M: LeafTriangles>(mesh: &M, ray: &Ray) -> Option<(u32, TriangleHit)> {
    let mut nearest = Nearest::new(mesh);
    walk(mesh, ray, |slot, h, t_max| nearest.offer(slot, h, t_max));
    nearest.best
}

/// [`closest_hit`] among the triangles of the subtrees `open` lets the walk
/// into (see [`walk_pruned`]).
#[inline]
pub(crate) fn closest_hit_pruned<M: LeafTriangles>(
    mesh: &M,
    ray: &Ray,
    open: impl FnMut(usize, f32, &mut f32) -> bool,
) -> Option<MeshHit> {
    let mut nearest = Nearest::new(mesh);
    walk_pruned(mesh, ray, open, |slot, h, t_max| {
        nearest.offer(slot, h, t_max)
    });
    nearest.hit()
}

/// The nearest of the hits offered; of hits at the same distance, the one
/// on the triangle of lowest mesh index.
struct Nearest<'a, M> {
    mesh: &'a M,
    best: Option<(u32, TriangleHit)>,
}

impl<'a, M: LeafTriangles> Nearest<'a, M> {
    fn new(mesh: &'a M) -> Self {
        Self { mesh, best: None }
    }

    /// Takes `h`, on slot `slot`, if it is nearer; the walk then looks no
    /// farther than it (with [`BOUND_SLACK`]).
    #[inline(always)]
    fn offer(&mut self, slot: u32, h: TriangleHit, t_max: &mut f32) -> Flow {
        let mesh = self.mesh;
        let better = self
            .best
            .is_none_or(|(s, b)| h.t < b.t || (h.t == b.t && mesh.prim_id(slot) < mesh.prim_id(s)));
        if better {
            self.best = Some((slot, h));
            *t_max = h.t + h.t.abs() * BOUND_SLACK;
        }
        Flow::Continue(())
    }

    fn hit(self) -> Option<MeshHit> {
        self.best.map(|(slot, h)| mesh_hit(self.mesh, slot, h))
    }
}

/// Whether anything lies on the ray within its range.
#[inline]
pub(crate) fn any_hit<M: LeafTriangles>(mesh: &M, ray: &Ray) -> bool {
    let mut hit = false;
    walk(mesh, ray, |_, _, _| {
        hit = true;
        Flow::Break(())
    });
    hit
}

/// Calls `visit(triangle, t)` for every triangle the ray crosses within its
/// range, in no particular order.
pub(crate) fn for_each_hit<M: LeafTriangles>(mesh: &M, ray: &Ray, mut visit: impl FnMut(u32, f32)) {
    walk(mesh, ray, |slot, h, _| {
        visit(mesh.prim_id(slot), h.t);
        Flow::Continue(())
    });
}
