//! The `bvh` crate (0.13): `Bvh::build_par` (binned SAH, one triangle per
//! leaf, rayon) and its ray queries.
//!
//! - closest hit: `nearest_traverse_iterator` yields leaves in order of
//!   their box's entry distance, so the loop stops once that distance passes
//!   the best hit (the crate's rays carry no `t_max` to prune nodes with);
//! - any hit: `traverse_iterator`, stopping at the first triangle hit;
//! - the triangle test is ours (double-sided Möller–Trumbore): the crate's
//!   `Ray::intersects_triangle` culls back faces;
//! - refit: none. `Bvh::update_shapes` removes and re-inserts each changed
//!   shape (tree rotations), which is not a refit: reported as null;
//! - memory: `nodes.len() * size_of::<BvhNode>()` plus the shape array
//!   (`size_of::<Tri>()` per triangle: three `Vec3A` corners and the node
//!   index the crate requires every shape to store).

use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::{BHShape, BoundingHierarchy};
use bvh::bvh::{Bvh, BvhNode};
use frusta_engine::geometry::Ray;
use glam::{Vec3, Vec3A};
use nalgebra::{Point3, Vector3};

use super::{area, moller_trumbore, Accel, SahSum};
use crate::mesh::BenchMesh;

#[derive(Clone, Copy)]
pub struct Tri {
    v: [Vec3A; 3],
    node_index: usize,
}

impl Bounded<f32, 3> for Tri {
    fn aabb(&self) -> Aabb<f32, 3> {
        let [a, b, c] = self.v;
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        Aabb::with_bounds(Point3::new(lo.x, lo.y, lo.z), Point3::new(hi.x, hi.y, hi.z))
    }
}

impl BHShape<f32, 3> for Tri {
    fn set_bh_node_index(&mut self, index: usize) {
        self.node_index = index;
    }

    fn bh_node_index(&self) -> usize {
        self.node_index
    }
}

pub struct BvhCrate {
    bvh: Bvh<f32, 3>,
    tris: Vec<Tri>,
}

pub struct BRay {
    ray: bvh::ray::Ray<f32, 3>,
    o: Vec3A,
    d: Vec3A,
}

fn to_tris(mesh: &BenchMesh) -> Vec<Tri> {
    (0..mesh.mesh.triangle_count())
        .map(|t| Tri {
            v: mesh.mesh.corners(t),
            node_index: 0,
        })
        .collect()
}

fn na_area(b: &Aabb<f32, 3>) -> f32 {
    area(
        Vec3::new(b.min.x, b.min.y, b.min.z),
        Vec3::new(b.max.x, b.max.y, b.max.z),
    )
}

impl Accel for BvhCrate {
    const NAME: &'static str = "bvh";
    const NOTE: &'static str = "Bvh::build_par (binned SAH on rayon); no refit";
    type Prepared = Vec<Tri>;
    type Ray = BRay;
    type RefitInput = ();

    fn prepare(mesh: &BenchMesh) -> Vec<Tri> {
        to_tris(mesh)
    }

    fn build(mut tris: Vec<Tri>) -> Self {
        let bvh = Bvh::build_par(&mut tris);
        Self { bvh, tris }
    }

    fn ray(&self, r: &Ray) -> BRay {
        BRay {
            ray: bvh::ray::Ray::new(
                Point3::new(r.origin.x, r.origin.y, r.origin.z),
                Vector3::new(r.dir.x, r.dir.y, r.dir.z),
            ),
            o: r.origin,
            d: r.dir,
        }
    }

    fn closest(&self, r: &BRay) -> Option<f32> {
        let mut best = f32::INFINITY;
        for tri in self.bvh.nearest_traverse_iterator(&r.ray, &self.tris) {
            if best.is_finite() {
                match r.ray.intersection_slice_for_aabb(&tri.aabb()) {
                    Some((entry, _)) if entry <= best => {}
                    _ => break,
                }
            }
            if let Some(t) = moller_trumbore(r.o, r.d, &tri.v, best) {
                best = t;
            }
        }
        best.is_finite().then_some(best)
    }

    fn any(&self, r: &BRay) -> bool {
        self.bvh
            .traverse_iterator(&r.ray, &self.tris)
            .any(|tri| moller_trumbore(r.o, r.d, &tri.v, f32::INFINITY).is_some())
    }

    fn prepare_refit(&self, _: &BenchMesh, _: &[Vec3]) -> Option<()> {
        None
    }

    fn refit(&mut self, _: &()) {}

    fn sah_cost(&self) -> Option<f64> {
        let mut sum = SahSum::default();
        let mut root = None;
        for node in &self.bvh.nodes {
            if let BvhNode::Node {
                child_l_index,
                child_l_aabb,
                child_r_index,
                child_r_aabb,
                ..
            } = node
            {
                let whole = child_l_aabb.join(child_r_aabb);
                root.get_or_insert(na_area(&whole));
                sum.inner(na_area(&whole));
                for (i, b) in [(child_l_index, child_l_aabb), (child_r_index, child_r_aabb)] {
                    if let BvhNode::Leaf { .. } = self.bvh.nodes[*i] {
                        sum.leaf(na_area(b), 1);
                    }
                }
            }
        }
        // A single-triangle tree is one leaf: cost 1.
        Some(root.map_or(1.0, |r| sum.cost(r)))
    }

    fn memory_bytes(&self) -> usize {
        self.bvh.nodes.len() * std::mem::size_of::<BvhNode<f32, 3>>()
            + self.tris.len() * std::mem::size_of::<Tri>()
    }
}
