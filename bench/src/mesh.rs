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

/// The hall of `scenes/hall-<size>.json` where that file is bundled (10k,
/// 200k); otherwise the same hall generated at `size` triangles (`20m`,
/// `5m`, `750k`): the massive scenes, made in code, never stored.
pub fn hall(size: &str) -> Result<BenchMesh, String> {
    let name = format!("hall-{size}");
    let mesh = hall_scene(size)?
        .world_mesh()
        .map_err(|e| format!("{name}: {e}"))?;
    Ok(BenchMesh { name, mesh })
}

/// [`hall`] as a scene, with its materials.
pub fn hall_scene(size: &str) -> Result<Scene, String> {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let bundled = scenes.join(format!("hall-{size}.json"));
    if bundled.exists() {
        return Scene::load(&bundled).map_err(|e| format!("{}: {e}", bundled.display()));
    }
    let (digits, scale) = match size.to_ascii_lowercase() {
        s if s.ends_with('k') => (s[..s.len() - 1].to_string(), 1e3),
        s if s.ends_with('m') => (s[..s.len() - 1].to_string(), 1e6),
        s => (s, 1.0),
    };
    let triangles = digits
        .parse::<f64>()
        .map(|n| (n * scale) as u64)
        .map_err(|_| format!("--hall {size}: give a size such as 10k, 200k or 20m"))?;
    // The bundled hall's document with its name and triangle target set.
    let base = std::fs::read_to_string(scenes.join("hall-200k.json")).map_err(|e| e.to_string())?;
    let mut doc: serde_json::Value = serde_json::from_str(&base).map_err(|e| e.to_string())?;
    doc["name"] = format!("hall-{size}").into();
    let target = doc
        .pointer_mut("/objects/0/mesh/hall/target_triangles")
        .ok_or("scenes/hall-200k.json: no objects[0].mesh.hall.target_triangles")?;
    *target = triangles.into();
    Scene::from_json_str(&doc.to_string(), None).map_err(|e| format!("hall-{size}: {e}"))
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
