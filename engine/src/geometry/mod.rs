//! Geometric primitives: boxes, rays, the watertight ray/triangle test,
//! triangle meshes and rigid transforms.

mod aabb;
mod mesh;
mod ray;
pub mod shapes;
mod transform;
pub mod triangle;

pub use aabb::{Aabb, BoxMotion};
pub use mesh::{check_mesh, check_positions, TriangleMesh, MAX_COORDINATE};
pub use ray::{trace_batch, Ray};
pub use transform::RigidTransform;
pub use triangle::{TriangleHit, WatertightRay};
