//! `obvhs` (0.4): the CWBVH (8-wide compressed BVH) path its README and
//! `basic_cwbvh`/`obj_cwbvh` examples recommend: the body of
//! `build_cwbvh_from_tris` with `BvhBuildParams::medium_build()` (PLOC,
//! reinsertion, up to 3 triangles per leaf, no pre-splits), rayon enabled
//! (`parallel` feature), then the triangles reordered to the tree's leaf
//! order (as in `obj_cwbvh`) so traversal indexes them directly.
//!
//! - closest hit: `CwBvh::ray_traverse` with `Triangle::intersect`
//!   (double-sided Möller–Trumbore);
//! - any hit: `CwBvh::ray_traverse_miss` (stops at the first hit);
//! - refit: the CWBVH is quantised and has no refit; the intermediate
//!   binary `Bvh2` has `refit_all`. We keep the `Bvh2`, and a refit is: new
//!   leaf boxes, `refit_all`, `bvh2_to_cwbvh` again and the triangles
//!   reordered again (everything the traced structure needs);
//! - memory: `nodes.len() * size_of::<CwBvhNode>()` (80 B) plus
//!   `primitive_indices` plus the reordered triangles (48 B each). The `Bvh2`
//!   kept only for refit is not counted.

use frusta_engine::geometry::Ray as FRay;
use glam::Vec3;
use glam_obvhs::Vec3A;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;
use obvhs::ploc::PlocBuilder;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::{Accel, SahSum};
use crate::mesh::BenchMesh;

const PARAMS: BvhBuildParams = BvhBuildParams::medium_build();

pub struct Obvhs {
    bvh2: Bvh2,
    cw: CwBvh,
    /// Triangles in `cw.primitive_indices` order.
    tris: Vec<Triangle>,
}

fn v(p: Vec3) -> Vec3A {
    Vec3A::new(p.x, p.y, p.z)
}

fn triangles(mesh: &BenchMesh, positions: &[Vec3]) -> Vec<Triangle> {
    mesh.triangles()
        .iter()
        .map(|t| Triangle {
            v0: v(positions[t[0] as usize]),
            v1: v(positions[t[1] as usize]),
            v2: v(positions[t[2] as usize]),
        })
        .collect()
}

fn to_cw(bvh2: &Bvh2, tris: &[Triangle]) -> (CwBvh, Vec<Triangle>) {
    let cw = bvh2_to_cwbvh(bvh2, PARAMS.max_prims_per_leaf.clamp(1, 3), true, false);
    let ordered = cw
        .primitive_indices
        .iter()
        .map(|&i| tris[i as usize])
        .collect();
    (cw, ordered)
}

impl Obvhs {
    fn sah_subtree(&self, node: &CwBvhNode, sum: &mut SahSum) {
        for slot in 0..8 {
            if node.is_child_empty(slot) {
                continue;
            }
            let a = node.child_aabb(slot).surface_area();
            if node.is_leaf(slot) {
                sum.leaf(a, node.child_primitives(slot).1 as usize);
            } else {
                sum.inner(a);
                let child = &self.cw.nodes[node.child_node_index(slot) as usize];
                self.sah_subtree(child, sum);
            }
        }
    }
}

impl Accel for Obvhs {
    const NAME: &'static str = "obvhs";
    const NOTE: &'static str = "PLOC and reinsertion on rayon, serial CWBVH conversion; refit: Bvh2::refit_all and the conversion, one thread";
    type Prepared = Vec<Triangle>;
    type Ray = Ray;
    type RefitInput = Vec<Triangle>;

    fn prepare(mesh: &BenchMesh) -> Vec<Triangle> {
        triangles(mesh, mesh.positions())
    }

    fn build(tris: Vec<Triangle>) -> Self {
        let mut bvh2 = PlocBuilder::with_capacity(tris.len()).build(
            PARAMS.ploc_search_distance,
            &tris,
            (0..tris.len() as u32).collect(),
            PARAMS.sort_precision,
            PARAMS.search_depth_threshold,
        );
        ReinsertionOptimizer::default().run(&mut bvh2, PARAMS.reinsertion_batch_ratio, None);
        let (cw, tris) = to_cw(&bvh2, &tris);
        Self { bvh2, cw, tris }
    }

    fn ray(&self, r: &FRay) -> Ray {
        Ray::new(
            Vec3A::new(r.origin.x, r.origin.y, r.origin.z),
            Vec3A::new(r.dir.x, r.dir.y, r.dir.z),
            r.t_min,
            r.t_max,
        )
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<f32> {
        let mut hit = RayHit::none();
        self.cw
            .ray_traverse(*ray, &mut hit, |r, id| self.tris[id].intersect(r))
            .then_some(hit.t)
    }

    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        !self
            .cw
            .ray_traverse_miss(*ray, |r, id| self.tris[id].intersect(r))
    }

    fn prepare_refit(&self, mesh: &BenchMesh, positions: &[Vec3]) -> Option<Vec<Triangle>> {
        Some(triangles(mesh, positions))
    }

    fn refit(&mut self, tris: &Vec<Triangle>) {
        let bvh2 = &mut self.bvh2;
        bvh2.init_primitives_to_nodes_if_uninit();
        for (prim, tri) in tris.iter().enumerate() {
            let node = bvh2.primitives_to_nodes[prim] as usize;
            bvh2.nodes[node].set_aabb(tri.aabb());
        }
        bvh2.refit_all();
        (self.cw, self.tris) = to_cw(bvh2, tris);
    }

    fn sah_cost(&self) -> Option<f64> {
        let root = self.cw.nodes.first()?;
        let root_area = self.cw.total_aabb.surface_area();
        let mut sum = SahSum::default();
        sum.inner(root_area);
        self.sah_subtree(root, &mut sum);
        Some(sum.cost(root_area))
    }

    fn memory_bytes(&self) -> usize {
        self.cw.nodes.len() * std::mem::size_of::<CwBvhNode>()
            + self.cw.primitive_indices.len() * 4
            + self.tris.len() * std::mem::size_of::<Triangle>()
    }
}
