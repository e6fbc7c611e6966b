//! Edge diffraction for the early part of a response: sound heard around
//! the edges of walls, door jambs and objects, by the uniform theory of
//! diffraction.
//!
//! - [`edges`]: the scene's diffracting edges (wedges and free edges),
//!   kept per object;
//! - [`utd`]: the diffraction coefficient of a hard wedge and its band
//!   gains;
//! - [`paths`]: paths around one or two edges, their legs checked with
//!   ray queries.
//!
//! Diffraction is checked against the exact solution for a half-plane
//! (Biot–Tolstoy–Medwin, in `engine/tests/diffraction.rs`).

pub mod edges;
pub mod paths;
pub mod utd;

pub use edges::{Edge, Edges};
pub(crate) use paths::diffracted_paths_until;
pub use paths::{diffracted_paths, DiffractedPath, DiffractionSearch, EdgePoint, EdgeScene};

/// Most edges a diffracted path may bend around.
pub const MAX_DIFFRACTION_ORDER: u32 = 2;
