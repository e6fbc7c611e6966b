//! Ray queries on a 4-wide tree and the triangles of its leaves, whatever
//! their layout: [`MeshBvh`](super::MeshBvh) (corner copies) and
//! [`CompactBvh`](super::CompactBvh) (shared vertices) both answer through
//! these, so both give the same hits.

use glam::{Vec3, Vec3A};

use super::traverse::{self, Flow, RayTest, WideTree};
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
}

/// Traces `ray` and calls `on_hit(slot, hit, t_max)` for every triangle it
/// meets within the current range; `on_hit` may shrink `t_max` and breaks
/// to stop. Invalid rays (non-finite or zero direction) meet nothing.
#[inline(always)]
pub(crate) fn walk<M: LeafTriangles>(
    mesh: &M,
    ray: &Ray,
    on_hit: impl FnMut(u32, TriangleHit, &mut f32) -> Flow,
) {
    walk_pruned(mesh, ray, |_, _, _| true, on_hit);
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
        |(first, count), t_max| {
            for slot in first..first + count {
                let [a, b, c] = mesh.corners(slot);
                if let Some(h) = tri_ray.intersect(a, b, c, t_min, *t_max) {
                    on_hit(slot, h, t_max)?;
                }
            }
            Flow::Continue(())
        },
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
    closest_hit_pruned(mesh, ray, |_, _, _| true)
}

/// [`closest_hit`] among the triangles of the subtrees `open` lets the walk
/// into (see [`walk_pruned`]).
#[inline]
pub(crate) fn closest_hit_pruned<M: LeafTriangles>(
    mesh: &M,
    ray: &Ray,
    open: impl FnMut(usize, f32, &mut f32) -> bool,
) -> Option<MeshHit> {
    let mut best: Option<(u32, TriangleHit)> = None;
    walk_pruned(mesh, ray, open, |slot, h, t_max| {
        let better = best
            .is_none_or(|(s, b)| h.t < b.t || (h.t == b.t && mesh.prim_id(slot) < mesh.prim_id(s)));
        if better {
            best = Some((slot, h));
            *t_max = h.t + h.t.abs() * BOUND_SLACK;
        }
        Flow::Continue(())
    });
    best.map(|(slot, h)| mesh_hit(mesh, slot, h))
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
