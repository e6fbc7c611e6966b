//! Sound propagation by frustum tracing: specular paths from sources to
//! listeners, validated exactly, and the exact image-source reference they
//! are measured against.
//!
//! - [`surfaces`]: world triangles grouped into planes;
//! - [`frustum`]: the frustum and its window space;
//! - [`tracer`]: frustum tracing with per-cell classification, merging and
//!   secondary frusta;
//! - [`beams`]: the traced frusta of one source, answering any listeners;
//! - [`path`]: event sequences, image sources and exact validation;
//! - [`reference`]: the exhaustive image-source solver, fast, sharing the
//!   tracer's validation;
//! - [`brute_force`]: the independent reference, sharing nothing with the
//!   tracer: what accuracy is measured against;
//! - [`scene`]: [`AcousticScene`], what propagation reads of a scene;
//! - [`propagation`]: paths with per-band gains, impulse responses and room
//!   parameters for sources and listeners;
//! - [`diffraction`]: paths around edges (UTD), for the early part;
//! - [`tail`]: late reverberation by stochastic ray tracing (diffuse rain
//!   and receiver spheres), counting nothing the exact paths hold;
//! - [`signal`]: arrivals to impulse responses, ISO 3382-1 parameters, WAV
//!   files and auralization.

pub mod beams;
pub mod brute_force;
mod cache;
mod classify;
mod cull;
pub mod diffraction;

pub mod frustum;
mod merge;
pub mod path;
pub mod propagation;
pub mod reference;
mod sample_rays;
pub mod scene;
pub mod signal;
pub mod surfaces;
pub mod tail;
pub mod tracer;

pub use crate::deadline::Cancel;
pub use beams::Beams;
pub use cache::BeamCache;
pub use propagation::{
    simulate, simulate_cached, simulate_until, Response, SimulationOptions, SoundPath,
    SurfaceShare, MAX_SOURCE_REUSE_M,
};
pub use scene::{AcousticScene, FoundPaths, Lod};
pub use tail::{Tail, TailOptions};
pub use tracer::{CellAssignment, TraceOptions, TraceStats};

/// The 10 x 6 x 3 m box room the unit tests trace in, each wall split
/// `subdivisions` times each way.
#[cfg(test)]
pub(crate) fn test_shoebox(subdivisions: u32, absorption: f32) -> crate::scene::Scene {
    let mut room =
        crate::scene::generate::BoxRoom::new(glam::Vec3::ZERO, glam::Vec3::new(10.0, 6.0, 3.0));
    room.subdivisions = subdivisions;
    crate::scene::Scene::single_object(
        "room",
        room.generate().unwrap(),
        crate::scene::Material::uniform("walls", absorption).unwrap(),
    )
    .unwrap()
}
