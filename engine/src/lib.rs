//! `frusta-engine`: triangle scenes, bounding volume hierarchies that build,
//! refit and rebuild, robust ray queries, and sound propagation.
//!
//! The crate is organised by concept:
//! - [`geometry`]: boxes, rays, the watertight ray/triangle test, meshes and
//!   rigid transforms;
//! - [`bvh`]: the binary BVH (node layout, SAH / Morton / hybrid builders,
//!   refit, the rebuild heuristic and traversal) and [`bvh::MeshBvh`], a BVH
//!   bound to one triangle mesh;
//! - [`scene`]: objects, materials, the JSON scene format, OBJ/glTF loaders
//!   and generators for the bundled scenes;
//! - [`query`]: the two-level scene acceleration structure and the ray
//!   queries (closest hit, any hit, batched) answered on it;
//! - [`acoustics`]: sound propagation by frustum tracing (specular paths
//!   validated exactly, the image-source reference) and the impulse
//!   responses, room-acoustic parameters, WAV files and auralized audio
//!   built from them.
//!
//! ```
//! use frusta_engine::geometry::{Ray, TriangleMesh};
//! use frusta_engine::bvh::{BuildOptions, MeshBvh};
//! use glam::Vec3;
//!
//! let mesh = TriangleMesh::new(
//!     vec![Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, -1.0, 2.0), Vec3::new(0.0, 1.0, 2.0)],
//!     vec![[0, 1, 2]],
//! )
//! .unwrap();
//! let bvh = MeshBvh::build(&mesh, &BuildOptions::default());
//! let hit = bvh.closest_hit(&Ray::new(Vec3::ZERO, Vec3::Z)).unwrap();
//! assert!((hit.t - 2.0).abs() < 1e-6);
//! ```

pub mod acoustics;
pub mod bvh;
pub mod collision;
mod deadline;
pub mod error;
pub mod geometry;
pub mod query;
pub mod scene;
pub mod shadows;

pub use deadline::Cancel;
pub use error::{Cause, Error, Result};
