//! Loading benchmark meshes.

use std::path::{Path, PathBuf};

use frusta_engine::geometry::TriangleMesh;
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

/// Loads every model of an OBJ file into one triangle mesh.
pub fn load_obj(path: &Path) -> Result<BenchMesh, String> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) =
        tobj::load_obj(path, &opts).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for m in &models {
        let base = positions.len() as u32;
        positions.extend(
            m.mesh
                .positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        triangles.extend(
            m.mesh
                .indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    let mesh =
        TriangleMesh::new(positions, triangles).map_err(|e| format!("{}: {e}", path.display()))?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok(BenchMesh { name, mesh })
}
