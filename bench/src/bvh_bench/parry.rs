//! `parry3d` (0.31, `parallel` feature): a `TriMesh` (default flags) and its
//! BVH ray casts through the `RayCast` trait.
//!
//! - threads: the `parallel` feature is on, but parry 0.31 parallelises
//!   neither its BVH builders (its own docs: "Neither strategy is currently
//!   parallelized") nor `TriMesh::set_vertices`, whose refit is a serial
//!   loop (the parallel `Bvh::refit_parallel` is not reachable through a
//!   `TriMesh`). Build and refit are therefore single-threaded and labelled
//!   so; rays run on every thread like everyone's;
//! - closest hit: `RayCast::cast_local_ray(ray, inf, solid = true)`;
//! - any hit: `RayCast::intersects_local_ray`. parry has no early-exit
//!   any-hit for triangle meshes: the default method runs the closest-hit
//!   cast, so any-hit rates match closest-hit rates;
//! - refit: `TriMesh::set_vertices`, which updates every leaf box and refits
//!   the BVH in place (keeping its structure);
//! - SAH: the tree is walked with `Bvh::traverse`; every node there has a
//!   public `aabb()` and `is_leaf()` (one triangle per leaf);
//! - memory: `TriMesh::total_memory_size()` (parry's own estimate: BVH,
//!   vertices, indices and the struct).

use frusta_engine::geometry::Ray as FRay;
use glam::Vec3;
use parry3d::bounding_volume::Aabb;
use parry3d::math::Vector;
use parry3d::partitioning::TraversalAction;
use parry3d::query::{Ray, RayCast};
use parry3d::shape::TriMesh;

use super::{area, Accel, SahSum};
use crate::mesh::BenchMesh;

pub struct Parry {
    mesh: TriMesh,
}

fn v(p: Vec3) -> Vector {
    Vector::new(p.x, p.y, p.z)
}

fn aabb_area(b: &Aabb) -> f32 {
    area(
        Vec3::new(b.mins.x, b.mins.y, b.mins.z),
        Vec3::new(b.maxs.x, b.maxs.y, b.maxs.z),
    )
}

impl Accel for Parry {
    const NAME: &'static str = "parry3d";
    const PARALLEL_BUILD: bool = false;
    const NOTE: &'static str = "TriMesh::new (binned, one thread: parry 0.31 has no parallel build); refit: TriMesh::set_vertices, one thread";
    type Prepared = (Vec<Vector>, Vec<[u32; 3]>);
    type Ray = Ray;
    type RefitInput = Vec<Vector>;

    fn prepare(mesh: &BenchMesh) -> Self::Prepared {
        (
            mesh.positions().iter().map(|&p| v(p)).collect(),
            mesh.triangles().to_vec(),
        )
    }

    fn build((vertices, indices): Self::Prepared) -> Self {
        Self {
            mesh: TriMesh::new(vertices, indices).expect("parry3d rejected the mesh"),
        }
    }

    fn ray(&self, r: &FRay) -> Ray {
        Ray::new(
            Vector::new(r.origin.x, r.origin.y, r.origin.z),
            Vector::new(r.dir.x, r.dir.y, r.dir.z),
        )
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<f32> {
        self.mesh.cast_local_ray(ray, f32::INFINITY, true)
    }

    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        self.mesh.intersects_local_ray(ray, f32::INFINITY)
    }

    fn prepare_refit(&self, _: &BenchMesh, positions: &[Vec3]) -> Option<Vec<Vector>> {
        Some(positions.iter().map(|&p| v(p)).collect())
    }

    fn refit(&mut self, vertices: &Vec<Vector>) {
        self.mesh.set_vertices(vertices);
    }

    fn sah_cost(&self) -> Option<f64> {
        let bvh = self.mesh.bvh();
        let root_area = aabb_area(&bvh.root_aabb());
        let mut sum = SahSum::default();
        let mut visited = 0usize;
        bvh.traverse(|node| {
            visited += 1;
            let a = aabb_area(&node.aabb());
            if node.is_leaf() {
                sum.leaf(a, 1);
            } else {
                sum.inner(a);
            }
            TraversalAction::Continue
        });
        // A binary tree over n leaves has 2n - 1 nodes; parry's root is
        // implicit (a pair of children) when the walk shows one fewer.
        let leaves = bvh.leaf_count() as usize;
        if leaves > 1 && visited + 2 == 2 * leaves {
            sum.inner(root_area);
        }
        Some(sum.cost(root_area))
    }

    fn memory_bytes(&self) -> usize {
        self.mesh.total_memory_size()
    }
}
