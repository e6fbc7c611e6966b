//! Ours: `frusta_engine::bvh::MeshBvh` with the default (SAH) options,
//! through the shim in `crate::frusta_impl`.

use frusta_engine::geometry::{Ray, TriangleMesh};
use glam::Vec3;

use super::Accel;
use crate::frusta_impl as fi;
use crate::mesh::BenchMesh;

pub struct Frusta {
    bvh: fi::Bvh,
}

impl Accel for Frusta {
    const NAME: &'static str = "frusta";
    type Prepared = TriangleMesh;
    type Ray = Ray;
    type RefitInput = TriangleMesh;

    fn prepare(mesh: &BenchMesh) -> TriangleMesh {
        mesh.mesh.clone()
    }

    fn build(mesh: TriangleMesh) -> Self {
        Self {
            bvh: fi::build(&mesh),
        }
    }

    fn ray(&self, ray: &Ray) -> Ray {
        *ray
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<f32> {
        fi::closest_t(&self.bvh, ray)
    }

    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        fi::any_hit(&self.bvh, ray)
    }

    fn prepare_refit(&self, mesh: &BenchMesh, positions: &[Vec3]) -> Option<TriangleMesh> {
        let mut m = mesh.mesh.clone();
        m.set_positions(positions.to_vec()).ok()?;
        Some(m)
    }

    fn refit(&mut self, mesh: &TriangleMesh) {
        std::hint::black_box(fi::refit(&mut self.bvh, mesh));
    }

    /// The engine's own `sah_cost()`, assumed to use the same formula
    /// (`C_t = C_i = 1`, normalised by the root's area).
    fn sah_cost(&self) -> Option<f64> {
        Some(fi::sah_cost(&self.bvh) as f64)
    }

    /// The engine's own `memory_bytes()` (nodes, index and triangle data).
    fn memory_bytes(&self) -> usize {
        fi::memory_bytes(&self.bvh)
    }
}
