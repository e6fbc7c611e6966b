//! Loading benchmark meshes.

use std::path::{Path, PathBuf};

use frusta_engine::geometry::TriangleMesh;
use frusta_engine::scene::Scene;
use glam::Vec3;

/// A mesh under test: its name (file stem) and the validated engine mesh.
pub struct BenchMesh {
    pub name: String,
    pub mesh: TriangleMesh,
}

impl BenchMesh {
    pub fn positions(&self) -> &[Vec3] {
        self.mesh.positions()
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        self.mesh.triangles()
    }

    /// The vertices moved slightly (a smooth wobble of 0.5% of the bounding
    /// box diagonal): the input of the refit measurement.
    pub fn deformed_positions(&self) -> Vec<Vec3> {
        let b = self.mesh.bounds();
        let diag = b.extent().length();
        let k = 6.0 / diag.max(f32::MIN_POSITIVE);
        self.positions()
            .iter()
            .map(|&p| {
                let w = Vec3::new((p.y * k).sin(), (p.z * k).sin(), (p.x * k).sin());
                p + w * (0.005 * diag)
            })
            .collect()
    }
}

/// The shared data directory: `$FRUSTA_SHARED_DIR`, else `<workspace>/../shared`.
pub fn shared_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("FRUSTA_SHARED_DIR") {
        return PathBuf::from(dir);
    }
    // bench/ lives one level below the workspace root.
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared")
}

/// Resolves a `--mesh` argument: an existing path as given, else a file (with
/// or without `.obj`) in `<shared>/data/meshes/`.
pub fn resolve(arg: &str) -> PathBuf {
    let p = PathBuf::from(arg);
    if p.exists() {
        return p;
    }
    let dir = shared_dir().join("data/meshes");
    let named = dir.join(arg);
    if named.exists() {
        return named;
    }
    dir.join(format!("{arg}.obj"))
}

/// Loads an OBJ, glTF or JSON scene file and flattens it into one
/// world-space mesh.
pub fn load(path: &Path) -> Result<BenchMesh, String> {
    let scene = Scene::load(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mesh = scene
        .world_mesh()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok(BenchMesh { name, mesh })
}
