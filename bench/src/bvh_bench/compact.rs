//! Ours, compact: `frusta_engine::bvh::CompactBvh` (quantised 64-byte
//! nodes, shared vertices) on the same build as [`super::frusta`].

use frusta_engine::bvh::{BuildOptions, CompactBvh};
use frusta_engine::geometry::{Ray, TriangleMesh};
use glam::Vec3;

use super::Accel;
use crate::mesh::BenchMesh;

pub struct FrustaCompact {
    bvh: CompactBvh,
}

impl Accel for FrustaCompact {
    const NAME: &'static str = "frusta-compact";
    const NOTE: &'static str = "the frusta build re-encoded: 8-bit child boxes in 64-byte nodes, 16-bit corners into welded vertices; refit: vertices and leaf boxes on rayon, nodes re-encoded in one serial sweep";
    type Prepared = TriangleMesh;
    type Ray = Ray;
    type RefitInput = TriangleMesh;

    fn prepare(mesh: &BenchMesh) -> TriangleMesh {
        mesh.mesh.clone()
    }

    fn build(mesh: TriangleMesh) -> Self {
        Self {
            bvh: CompactBvh::build(&mesh, &BuildOptions::default()),
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

    /// The engine's own `sah_cost()` on the decoded boxes.
    fn sah_cost(&self) -> Option<f64> {
        Some(self.bvh.sah_cost() as f64)
    }

    /// The engine's own `memory_bytes()`: nodes, slot order, vertices and
    /// corners, everything a query reads.
    fn memory_bytes(&self) -> usize {
        self.bvh.memory_bytes()
    }
}
