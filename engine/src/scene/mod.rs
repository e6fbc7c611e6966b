//! Scenes: named objects, each a triangle mesh with one material per
//! triangle, a rigid transform and a static/dynamic flag; the built-in
//! material library; the JSON scene format; OBJ and glTF loaders; and
//! generators for the bundled rooms.

mod format;
pub mod generate;
mod library;
pub mod load;
mod material;
mod object;
mod raw_mesh;

pub use format::{FileMesh, InlineMesh, MaterialSpec, MeshSpec, ObjectSpec, SceneDocument};
pub use library::{builtin_material, builtin_materials};
pub use material::{
    check_material_table, Bands, Material, MaterialId, BAND_COUNT, MAX_MATERIALS, OCTAVE_BANDS_HZ,
};
pub use object::{Scene, SceneObject};
pub use raw_mesh::RawMesh;
