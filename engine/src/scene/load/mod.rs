//! Mesh file loaders (OBJ, glTF) and the safe resolution of the file paths a
//! scene refers to.

mod gltf;
mod obj;
mod path;

pub use self::gltf::{load_gltf, parse_gltf};
pub use obj::{load_obj, parse_obj};
pub use path::resolve_relative;

use std::path::Path;

use super::RawMesh;
use crate::{Error, Result};

/// Loads a mesh file, choosing the format by extension (`.obj`, `.gltf`,
/// `.glb`, case-insensitive).
pub fn load_mesh_file(path: &Path) -> Result<RawMesh> {
    match extension(path).as_deref() {
        Some("obj") => load_obj(path),
        Some("gltf" | "glb") => load_gltf(path),
        _ => Err(Error::Parse {
            what: path.display().to_string(),
            reason: "unsupported mesh format; expected .obj, .gltf or .glb".into(),
        }),
    }
}

/// The lower-case extension of `path`.
pub fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// Reads a whole file, mapping failure to [`Error::Io`].
fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    })
}

/// A fresh, empty directory for a test's files.
#[cfg(test)]
pub(crate) fn test_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("frusta-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
