//! Reading scenes from JSON text and from files on disk.

use std::collections::BTreeMap;
use std::path::Path;

use super::{FileMesh, MeshSpec, ObjectSpec, SceneDocument};
use crate::geometry::RigidTransform;
use crate::scene::Scene;
use crate::{Error, Result};

impl Scene {
    /// Parses a JSON scene; relative mesh files resolve against `base_dir`
    /// (a scene given without one may not refer to files).
    pub fn from_json_str(text: &str, base_dir: Option<&Path>) -> Result<Scene> {
        SceneDocument::parse(text)?.build(base_dir)
    }

    /// Loads a `.json` scene, or a bare `.obj`/`.gltf`/`.glb` file as a
    /// one-object scene named after the file, whose triangles take the
    /// library material of their file material name if there is one and
    /// `"concrete"` otherwise.
    pub fn load(path: &Path) -> Result<Scene> {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let ext = crate::scene::load::extension(path);
        if ext.as_deref() == Some("json") {
            let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
                path: path.display().to_string(),
                reason: e.to_string(),
            })?;
            return Self::from_json_str(&text, Some(dir)).map_err(|e| match e {
                Error::Parse { reason, .. } => Error::Parse {
                    what: path.display().to_string(),
                    reason,
                },
                other => other,
            });
        }
        let file = path.file_name().and_then(|f| f.to_str());
        let stem = path.file_stem().and_then(|f| f.to_str());
        let (Some(file), Some(stem), Some("obj" | "gltf" | "glb")) = (file, stem, ext.as_deref())
        else {
            return Err(Error::Parse {
                what: path.display().to_string(),
                reason: "expected a .json scene or a .obj, .gltf or .glb mesh".into(),
            });
        };
        SceneDocument {
            name: Some(stem.to_owned()),
            description: None,
            materials: Vec::new(),
            objects: vec![ObjectSpec {
                name: stem.to_owned(),
                dynamic: false,
                transform: RigidTransform::IDENTITY,
                material: Some("concrete".into()),
                mesh: MeshSpec::File(FileMesh {
                    file: file.to_owned(),
                    materials: BTreeMap::new(),
                }),
            }],
        }
        .build(Some(dir))
    }
}
