//! Ours: `frusta_engine::bvh::MeshBvh` with the default (SAH) options.

use frusta_engine::bvh::{BuildOptions, MeshBvh};
use frusta_engine::geometry::{Ray, TriangleMesh};
use glam::Vec3;

use super::Accel;
use crate::mesh::BenchMesh;

pub struct Frusta {
    bvh: MeshBvh,
}

impl Accel for Frusta {
    const NAME: &'static str = "frusta";
    const NOTE: &'static str = "binned SAH on rayon, collapsed to 4-wide; refit: leaves on rayon, inner nodes in one serial sweep";
    type Prepared = TriangleMesh;
    type Ray = Ray;
    type RefitInput = TriangleMesh;

    fn prepare(mesh: &BenchMesh) -> TriangleMesh {
        mesh.mesh.clone()
    }

    fn build(mesh: TriangleMesh) -> Self {
        Self {
            bvh: MeshBvh::build(&mesh, &BuildOptions::default()),
        }
    }

    fn ray(&self, ray: &Ray) -> Ray {
        *ray
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<f32> {
        self.bvh.closest_hit(ray).map(|h| h.t)
    }

    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        self.bvh.any_hit(ray)
    }

    fn prepare_refit(&self, mesh: &BenchMesh, positions: &[Vec3]) -> Option<TriangleMesh> {
        let mut m = mesh.mesh.clone();
        m.set_positions(positions.to_vec()).ok()?;
        Some(m)
    }

    fn refit(&mut self, mesh: &TriangleMesh) {
        std::hint::black_box(self.bvh.refit(mesh).ok());
    }

    /// The engine's own `sah_cost()`: the same formula (`C_t = C_i = 1`,
    /// normalised by the root's area).
    fn sah_cost(&self) -> Option<f64> {
        Some(self.bvh.sah_cost() as f64)
    }

    /// The engine's own `memory_bytes()` (nodes, index and triangle data).
    fn memory_bytes(&self) -> usize {
        self.bvh.memory_bytes()
    }
}
