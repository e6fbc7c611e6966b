//! Scenes: named objects, each a triangle mesh with one material per
//! triangle, a rigid transform and a static/dynamic flag.

mod material;
mod object;

pub use material::{Bands, Material, MaterialId, BAND_COUNT, OCTAVE_BANDS_HZ};
pub use object::{Scene, SceneObject};
