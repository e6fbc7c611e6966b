//! A BVH bound to one triangle mesh, with the mesh's triangles copied in
//! leaf order so that a leaf's triangles are contiguous in memory.

use std::time::Instant;

use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use serde::Serialize;

use super::ray_queries::{self, LeafTriangles, Tree8};
use super::traverse::ray8::avx_available;
use super::wide::{Bvh4, Bvh8};
use super::{BuildOptions, Bvh, Node};
use crate::geometry::{trace_batch, Aabb, Ray, TriangleMesh};
use crate::{Error, Result};

/// A ray's nearest hit on a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshHit {
    /// Distance along the ray, in units of the ray direction's length.
    pub t: f32,
    /// Index of the triangle in the mesh.
    pub triangle: u32,
    /// Barycentric weight of the triangle's second corner.
    pub u: f32,
    /// Barycentric weight of the triangle's third corner.
    pub v: f32,
    /// Unit geometric normal `(b - a) x (c - a)`, in the mesh's frame.
    pub normal: Vec3,
}

/// What a refit measured.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RefitReport {
    /// The rebuild heuristic's measure (see [`quality`]); 0 right after a build.
    pub degradation: f32,
}

/// What [`MeshBvh::update`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum UpdateAction {
    Refit,
    Rebuild,
}

/// The outcome of [`MeshBvh::update`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct UpdateReport {
    pub action: UpdateAction,
    /// Degradation measured after refitting; `None` when the triangle count
    /// changed and the tree was rebuilt without refitting.
    pub degradation: Option<f32>,
    pub elapsed_ms: f64,
}

/// A BVH over one triangle mesh.
#[derive(Clone, Debug)]
pub struct MeshBvh {
    bvh: Bvh4,
    /// Leaf order to mesh order: leaf slot `i` holds triangle `prim_ids[i]`.
    prim_ids: Vec<u32>,
    /// Triangle corners in leaf order, so a leaf's triangles are contiguous.
    /// 48 bytes each, aligned for SIMD loads.
    triangles: Vec<[Vec3A; 3]>,
    /// The tree rays walk where the CPU has AVX, over the same slots.
    bvh8: Option<Bvh8>,
    options: BuildOptions,
}

impl MeshBvh {
    /// Builds the hierarchy of `mesh`.
    pub fn build(mesh: &TriangleMesh, options: &BuildOptions) -> Self {
        let (mut bvh, bvh8, prim_ids) = wide_tree(mesh, options);
        let triangles: Vec<[Vec3A; 3]> = prim_ids
            .par_iter()
            .with_min_len(4096)
            .map(|&t| mesh.corners(t as usize))
            .collect();
        bvh.record_build_ratios(|f, c| leaf_box_and_area(|s| triangles[s as usize], f, c).1);
        Self {
            bvh,
            prim_ids,
            triangles,
            bvh8,
            options: options.clone(),
        }
    }

    /// The 4-wide tree every query walks (rays walk the 8-wide one where
    /// the CPU has AVX).
    pub fn wide(&self) -> &Bvh4 {
        &self.bvh
    }

    /// Leaf order to mesh order.
    pub fn prim_ids(&self) -> &[u32] {
        &self.prim_ids
    }

    /// Triangle corners in leaf order (slot `i` is triangle `prim_ids()[i]`).
    pub(crate) fn leaf_triangles(&self) -> &[[Vec3A; 3]] {
        &self.triangles
    }

    pub fn options(&self) -> &BuildOptions {
        &self.options
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    pub fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    /// SAH cost of the 4-wide tree, unit costs per node and per triangle.
    pub fn sah_cost(&self) -> f32 {
        self.bvh.sah_cost()
    }

    /// Bytes held: nodes, build ratios, leaf order and triangle copies.
    pub fn memory_bytes(&self) -> usize {
        self.bvh.memory_bytes()
            + self.bvh8.as_ref().map_or(0, Bvh8::memory_bytes)
            + self.prim_ids.capacity() * 4
            + self.triangles.capacity() * std::mem::size_of::<[Vec3A; 3]>()
    }

    /// Refits to new vertex positions of the same mesh (same triangles).
    /// O(n): triangle copies and leaves update in parallel, inner nodes in
    /// one reverse sweep.
    pub fn refit(&mut self, mesh: &TriangleMesh) -> Result<RefitReport> {
        if mesh.triangle_count() != self.triangles.len() {
            return Err(Error::TriangleCountMismatch {
                expected: self.triangles.len(),
                actual: mesh.triangle_count(),
            });
        }
        Ok(self.refit_same_count(mesh))
    }

    /// [`refit`](Self::refit) for a mesh whose triangle count was checked.
    fn refit_same_count(&mut self, mesh: &TriangleMesh) -> RefitReport {
        let ids = &self.prim_ids;
        self.triangles
            .par_iter_mut()
            .with_min_len(4096)
            .zip(ids.par_iter())
            .for_each(|(tri, &t)| *tri = mesh.corners(t as usize));
        let triangles = &self.triangles;
        // The 8-wide tree copies the boxes.
        let degradation = self
            .bvh
            .refit_measured(|f, c| leaf_box_and_area(|s| triangles[s as usize], f, c));
        if let Some(bvh8) = &mut self.bvh8 {
            bvh8.refit_from(&self.bvh);
        }
        RefitReport { degradation }
    }

    /// Brings the hierarchy up to date with `mesh`: refits, and rebuilds when
    /// the rebuild heuristic's degradation exceeds `threshold` or when the
    /// triangle count changed.
    pub fn update(&mut self, mesh: &TriangleMesh, threshold: f32) -> UpdateReport {
        let start = Instant::now();
        let elapsed = || start.elapsed().as_secs_f64() * 1e3;
        if mesh.triangle_count() != self.triangles.len() {
            *self = Self::build(mesh, &self.options);
            return UpdateReport {
                action: UpdateAction::Rebuild,
                degradation: None,
                elapsed_ms: elapsed(),
            };
        }
        let degradation = self.refit_same_count(mesh).degradation;
        let action = if degradation <= threshold {
            UpdateAction::Refit
        } else {
            *self = Self::build(mesh, &self.options);
            UpdateAction::Rebuild
        };
        UpdateReport {
            action,
            degradation: Some(degradation),
            elapsed_ms: elapsed(),
        }
    }

    /// The nearest hit within the ray's range.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Option<MeshHit> {
        ray_queries::closest_hit(self, ray)
    }

    /// The nearest hit's distance and mesh triangle: [`Self::closest_hit`]
    /// without the hit point, barycentrics and normal.
    #[inline]
    pub fn closest_triangle(&self, ray: &Ray) -> Option<(f32, u32)> {
        ray_queries::closest_slot(self, ray).map(|(t, slot)| (t, self.prim_id(slot)))
    }

    /// Whether anything lies on the ray within its range (occlusion).
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        ray_queries::any_hit(self, ray)
    }

    /// Calls `visit(triangle, t)` for every triangle the ray crosses within
    /// its range, in no particular order. A ray through a shared edge or
    /// vertex of a closed mesh reports exactly one of the triangles there.
    pub fn for_each_hit(&self, ray: &Ray, visit: impl FnMut(u32, f32)) {
        ray_queries::for_each_hit(self, ray, visit)
    }

    /// [`closest_hit`](Self::closest_hit) for many rays, in parallel.
    pub fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<MeshHit>> {
        trace_batch(rays, |r| self.closest_hit(r))
    }

    /// [`any_hit`](Self::any_hit) for many rays, in parallel.
    pub fn any_hits(&self, rays: &[Ray]) -> Vec<bool> {
        trace_batch(rays, |r| self.any_hit(r))
    }
}

impl LeafTriangles for MeshBvh {
    type Tree = Bvh4;

    #[inline(always)]
    fn tree(&self) -> &Bvh4 {
        &self.bvh
    }

    #[inline(always)]
    fn corners(&self, slot: u32) -> [Vec3A; 3] {
        self.triangles[slot as usize]
    }

    #[inline(always)]
    fn prim_id(&self, slot: u32) -> u32 {
        self.prim_ids[slot as usize]
    }

    #[inline(always)]
    fn tree8(&self) -> Option<Tree8<'_>> {
        self.bvh8.as_ref().map(Tree8::Plain)
    }
}

/// The 4-wide tree of `mesh` (without build ratios), the 8-wide one over
/// the same leaves where the CPU has AVX (and its stack entries can name
/// every leaf), and their leaf order: leaf slot `i` holds triangle
/// `prim_ids[i]`.
pub(crate) fn wide_tree(
    mesh: &TriangleMesh,
    options: &BuildOptions,
) -> (Bvh4, Option<Bvh8>, Vec<u32>) {
    let (nodes, prim_ids) = binary_tree(mesh, options);
    let binary = Bvh {
        nodes,
        prim_ids: Vec::new(),
    };
    let four = Bvh4::from_binary(&binary);
    let eight = avx_available()
        .then(|| Bvh8::from_binary(&binary.nodes, &four))
        .filter(Bvh8::addressable);
    (four, eight, prim_ids)
}

/// The binary tree of `mesh` and its leaf order.
fn binary_tree(mesh: &TriangleMesh, options: &BuildOptions) -> (Vec<Node>, Vec<u32>) {
    let boxes: Vec<Aabb> = (0..mesh.triangle_count())
        .into_par_iter()
        .with_min_len(4096)
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            Aabb::of_triangle(a, b, c)
        })
        .collect();
    let Bvh { nodes, prim_ids } = Bvh::build(&boxes, options);
    (nodes, prim_ids)
}

/// The box of slots `first..first + count` and the sum of their boxes'
/// areas, from one read of their triangles (`corners(slot)`): what a refit
/// and the rebuild heuristic need of a leaf, for either layout. The build's
/// ratios are taken from the same sums, so an unchanged mesh measures
/// exactly 0.
pub(crate) fn leaf_box_and_area(
    corners: impl Fn(u32) -> [Vec3A; 3],
    first: u32,
    count: u32,
) -> (Aabb, f32) {
    (first..first + count).fold((Aabb::EMPTY, 0.0), |(b, area), s| {
        let [p, q, r] = corners(s);
        let t = Aabb::of_triangle(p, q, r);
        (b.union(t), area + t.half_area())
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::bvh::traverse::Slot;
    use crate::bvh::wide::refit::PARALLEL_NODES;
    use crate::geometry::shapes;

    /// Random rays from inside and outside, rays at the cube's grid
    /// vertices and along its faces and edges, and invalid ones.
    fn rays(rng: &mut ChaCha8Rng) -> Vec<Ray> {
        let mut rays: Vec<Ray> = (0..20_000)
            .map(|_| {
                let p = Vec3::new(rng.random(), rng.random(), rng.random()) * 6.0 - 3.0;
                let d = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
                Ray::new(p, d)
            })
            .collect();
        // The cube spans [-1, 1] in steps of 0.25: grid vertices and edges.
        let grid: Vec<f32> = (0..=8).map(|i| -1.0 + 0.25 * i as f32).collect();
        for &x in &grid {
            for &y in &grid {
                rays.push(Ray::new(Vec3::new(x, y, 3.0), -Vec3::Z));
                rays.push(Ray::new(Vec3::new(x, -3.0, y), Vec3::Y));
                // In the plane of a face, along a grid line.
                rays.push(Ray::new(Vec3::new(x, 1.0, -3.0), Vec3::Z));
                rays.push(Ray::new(Vec3::new(-3.0, x, y), Vec3::new(1.0, 0.0, 1e-7)));
            }
        }
        rays.push(Ray::new(Vec3::NAN, Vec3::X));
        rays.push(Ray::new(Vec3::ZERO, Vec3::ZERO));
        rays.push(Ray::new(Vec3::splat(f32::INFINITY), -Vec3::X));
        rays
    }

    /// Closest, any and all hits agree, over the whole ray and over a
    /// range that starts and ends inside the scene.
    fn assert_same_hits(eight: &MeshBvh, four: &MeshBvh, rays: &[Ray]) {
        let all = |bvh: &MeshBvh, ray: &Ray| {
            let mut hits = Vec::new();
            bvh.for_each_hit(ray, |triangle, t| hits.push((triangle, t.to_bits())));
            hits.sort_unstable();
            hits
        };
        for ray in rays.iter().flat_map(|r| [*r, r.with_range(0.5, 3.5)]) {
            let (a, b) = (eight.closest_hit(&ray), four.closest_hit(&ray));
            assert_eq!(a, b, "{ray:?}");
            assert_eq!(eight.any_hit(&ray), four.any_hit(&ray), "{ray:?}");
            assert_eq!(all(eight, &ray), all(four, &ray), "{ray:?}");
        }
    }

    /// Where the CPU has AVX, rays walk the 8-wide tree; they must meet
    /// what the 4-wide walk meets (itself checked against brute force in
    /// `tests/bvh_build.rs`), built and after a refit.
    #[test]
    fn the_eight_wide_walk_hits_what_the_four_wide_walk_hits() {
        if !avx_available() {
            eprintln!("skipped: this CPU has no AVX, so rays walk the 4-wide tree only");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let rays = rays(&mut rng);
        let cube = shapes::cube(1.0, 8);
        // One and two triangles: the root is a leaf, or holds two.
        let few = |n: usize| {
            TriangleMesh::new(cube.positions().to_vec(), cube.triangles()[..n].to_vec()).unwrap()
        };
        for mesh in [few(1), few(2), cube.clone(), shapes::icosphere(1.5, 3)] {
            let mut eight = MeshBvh::build(&mesh, &BuildOptions::default());
            assert!(eight.bvh8.is_some());
            let mut four = eight.clone();
            four.bvh8 = None;
            assert_same_hits(&eight, &four, &rays);
            let wobbled = TriangleMesh::new(
                mesh.positions()
                    .iter()
                    .map(|&p| p * (1.0 + 0.4 * (4.0 * p.x).sin()) + Vec3::Z * p.y * p.y)
                    .collect(),
                mesh.triangles().to_vec(),
            )
            .unwrap();
            eight.refit(&wobbled).unwrap();
            four.refit(&wobbled).unwrap();
            assert_same_hits(&eight, &four, &rays);
        }
    }

    /// `mesh` bent out of shape: neighbouring triangles part, leaves grow.
    fn bent(mesh: &TriangleMesh) -> TriangleMesh {
        let bend = |p: Vec3| p * (1.0 + 0.3 * (5.0 * p.x).sin()) + Vec3::Z * p.y * p.y;
        TriangleMesh::new(
            mesh.positions().iter().map(|&p| bend(p)).collect(),
            mesh.triangles().to_vec(),
        )
        .unwrap()
    }

    /// An icosphere of `levels`, it bent, and its tree refitted to the bend.
    fn refitted_to_bent(levels: u32) -> (TriangleMesh, TriangleMesh, MeshBvh, RefitReport) {
        let mesh = shapes::icosphere(1.0, levels);
        let moved = bent(&mesh);
        let mut bvh = MeshBvh::build(&mesh, &BuildOptions::default());
        let report = bvh.refit(&moved).unwrap();
        (mesh, moved, bvh, report)
    }

    /// Half the area of the box of `corners`, in `f64`.
    fn half_area_f64(corners: impl Iterator<Item = Vec3A>) -> f64 {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in corners {
            for a in 0..3 {
                lo[a] = lo[a].min(f64::from(p[a]));
                hi[a] = hi[a].max(f64::from(p[a]));
            }
        }
        let e = std::array::from_fn::<f64, 3, _>(|a| (hi[a] - lo[a]).max(0.0));
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    }

    /// The mesh triangles below slot `slot` of node `node`.
    fn triangles_below(bvh: &MeshBvh, node: usize, slot: usize, out: &mut Vec<u32>) {
        let n = &bvh.bvh.nodes[node];
        if n.is_leaf_slot(slot) {
            let (first, count) = (n.child[slot] as usize, n.count[slot] as usize);
            out.extend(&bvh.prim_ids[first..first + count]);
        } else if n.is_inner_slot(slot) {
            for s in 0..4 {
                triangles_below(bvh, n.child[slot] as usize, s, out);
            }
        }
    }

    /// The rebuild heuristic from first principles, in `f64`: per node, the
    /// area of the box of all its triangles over the sum of its slots'; per
    /// leaf slot of several triangles, its box's area over the sum of its
    /// triangles' boxes'; the mean growth of these from `built` to `moved`.
    /// Only the tree's topology is shared with the code under test.
    fn degradation_from_scratch(bvh: &MeshBvh, built: &TriangleMesh, moved: &TriangleMesh) -> f64 {
        // Capped at 1e6, and 1 for nothing over nothing.
        let ratio = |area: f64, parts: f64| match (parts > 0.0, area > 0.0) {
            (true, _) => (area / parts).min(1e6),
            (false, true) => 1e6,
            (false, false) => 1.0,
        };
        let corners = |mesh: &TriangleMesh, ts: &[u32]| -> Vec<Vec3A> {
            ts.iter().flat_map(|&t| mesh.corners(t as usize)).collect()
        };
        let (mut sum, mut terms) = (0.0, 0usize);
        for node in 0..bvh.bvh.nodes.len() {
            let below: Vec<Vec<u32>> = (0..4)
                .map(|s| {
                    let mut ts = Vec::new();
                    triangles_below(bvh, node, s, &mut ts);
                    ts
                })
                .collect();
            let ratios = |mesh: &TriangleMesh| {
                let slots: Vec<f64> = below
                    .iter()
                    .map(|ts| half_area_f64(corners(mesh, ts).into_iter()))
                    .collect();
                let own = half_area_f64(below.iter().flat_map(|ts| corners(mesh, ts)));
                let mut r = vec![ratio(own, slots.iter().sum())];
                for (s, ts) in below.iter().enumerate() {
                    if bvh.bvh.nodes[node].is_leaf_slot(s) && ts.len() > 1 {
                        let parts = ts
                            .iter()
                            .map(|&t| half_area_f64(mesh.corners(t as usize).into_iter()))
                            .sum();
                        r.push(ratio(slots[s], parts));
                    }
                }
                r
            };
            for (now, then) in ratios(moved).into_iter().zip(ratios(built)) {
                sum += now - then;
                terms += 1;
            }
        }
        sum / terms as f64
    }

    /// The degradation a refit reports, from boxes and leaf areas computed
    /// in one pass, is the one recomputed from scratch; on a tree small
    /// enough to be measured on one thread and on one measured on rayon.
    #[test]
    fn refit_degradation_is_the_mean_growth_of_area_ratios_from_scratch() {
        for levels in [3, 6] {
            let (mesh, moved, mut bvh, report) = refitted_to_bent(levels);
            let on_rayon = bvh.bvh.nodes.len() >= PARALLEL_NODES;
            assert_eq!(on_rayon, levels == 6, "{} nodes", bvh.bvh.nodes.len());
            let expected = degradation_from_scratch(&bvh, &mesh, &moved);
            assert!(
                expected > 0.05,
                "the wobble must part neighbours: {expected}"
            );
            let error = (f64::from(report.degradation) - expected).abs();
            assert!(
                error < 1e-4 * expected,
                "{} vs {expected}",
                report.degradation
            );
            // And back: every ratio as built, to the bit.
            assert_eq!(bvh.refit(&mesh).unwrap().degradation, 0.0);
        }
    }

    /// After a refit every leaf slot of both trees bounds exactly its own
    /// triangles, taken from the moved mesh: the 8-wide tree (where the CPU
    /// has AVX) copies its leaf boxes from the 4-wide one, and a copy from
    /// the wrong leaf shows; on a tree copied on one thread and on one
    /// copied on rayon.
    #[test]
    fn after_a_refit_every_leaf_box_is_its_triangles_box() {
        for levels in [2, 7] {
            let (_, moved, bvh, _) = refitted_to_bent(levels);
            let expected = |first: u32, count: u32| {
                bvh.prim_ids[first as usize..(first + count) as usize]
                    .iter()
                    .fold(Aabb::EMPTY, |b, &t| {
                        let [p, q, r] = moved.corners(t as usize);
                        b.union(Aabb::of_triangle(p, q, r))
                    })
            };
            let mut leaves = 0;
            for n in &bvh.bvh.nodes {
                for s in (0..4).filter(|&s| n.is_leaf_slot(s)) {
                    assert_eq!(n.slot_aabb(s), expected(n.child[s], n.count[s]));
                    leaves += 1;
                }
            }
            let Some(eight) = &bvh.bvh8 else {
                eprintln!("this CPU has no AVX: no 8-wide tree to check");
                continue;
            };
            let on_rayon = eight.nodes().len() >= PARALLEL_NODES;
            assert_eq!(on_rayon, levels == 7, "{} nodes", eight.nodes().len());
            for n in eight.nodes() {
                for s in (0..8).filter(|&s| n.slot(s) == Slot::Leaf) {
                    assert_eq!(n.slot_aabb(s), expected(n.child[s], n.count[s]));
                    leaves -= 1;
                }
            }
            assert_eq!(leaves, 0, "both trees hold the same leaves");
        }
    }
}
