//! The JSON scene document: what users write, and how it becomes a
//! [`Scene`]. The format is documented in `scenes/README.md`.
//!
//! Parsing is strict (unknown fields are errors, with the line and column
//! serde reports) because a misspelt field silently ignored would give a
//! wrong simulation rather than an error.

mod json_in;
mod json_out;
mod scene_io;

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use glam::Vec3;
use serde::Deserialize;

use super::generate::{BoxRoom, Hall, LRoom, TwoRooms};
use super::library::builtin_material;
use super::load::{load_mesh_file, resolve_relative};
use super::{Bands, Material, MaterialId, RawMesh, Scene, SceneObject, MAX_MATERIALS};
use crate::geometry::{RigidTransform, TriangleMesh};
use crate::{Error, Result};

/// A parsed scene document, before files are read and names resolved.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDocument {
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub description: Option<String>,
    /// Declared materials in document order (the order fixes material ids).
    #[serde(default, deserialize_with = "json_in::ordered_materials")]
    pub materials: Vec<(String, MaterialSpec)>,
    pub objects: Vec<ObjectSpec>,
}

/// A material value: a library name, or coefficients.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialSpec {
    Library(String),
    Custom {
        absorption: Bands,
        scattering: Bands,
        transmission: Bands,
    },
}

/// One object of the document.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    pub name: String,
    #[serde(default)]
    pub dynamic: bool,
    #[serde(default)]
    pub transform: RigidTransform,
    /// Material of every triangle the mesh does not name one for.
    #[serde(default)]
    pub material: Option<String>,
    pub mesh: MeshSpec,
}

/// Where an object's triangles come from.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSpec {
    Inline(InlineMesh),
    File(FileMesh),
    BoxRoom(BoxRoom),
    LRoom(LRoom),
    TwoRooms(TwoRooms),
    Hall(Hall),
}

/// Triangles written out in the document.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InlineMesh {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// One material name per triangle.
    #[serde(default)]
    pub materials: Option<Vec<String>>,
}

/// A mesh file relative to the scene file's directory.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileMesh {
    pub file: String,
    /// File material name (OBJ `usemtl`, glTF material) to scene material.
    #[serde(default)]
    pub materials: BTreeMap<String, String>,
}

impl SceneDocument {
    /// Parses the JSON text; errors carry serde's line and column.
    pub fn parse(text: &str) -> Result<Self> {
        serde_json::from_str(text).map_err(|e| Error::Parse {
            what: "scene JSON".into(),
            reason: e.to_string(),
        })
    }

    /// Reads files, runs generators and resolves material names. Relative
    /// file paths resolve against `base_dir`.
    pub fn build(&self, base_dir: Option<&Path>) -> Result<Scene> {
        let mut table = MaterialTable::default();
        for (name, spec) in &self.materials {
            table.declare(name, spec)?;
        }
        let mut objects: Vec<SceneObject> = Vec::with_capacity(self.objects.len());
        let mut names = std::collections::HashSet::new();
        for spec in &self.objects {
            if spec.name.is_empty() {
                return Err(Error::InvalidScene("an object has an empty name".into()));
            }
            if !names.insert(spec.name.as_str()) {
                return Err(Error::DuplicateObject(spec.name.clone()));
            }
            let object =
                build_object(spec, &mut table, base_dir).map_err(|e| e.in_object(&spec.name))?;
            objects.push(object);
        }
        Ok(Scene {
            materials: table.materials,
            objects,
        })
    }
}

/// The scene's material table as it fills up: declared materials first, then
/// library materials in order of first use.
#[derive(Default)]
struct MaterialTable {
    materials: Vec<Material>,
    ids: HashMap<String, MaterialId>,
}

impl MaterialTable {
    fn push(&mut self, material: Material) -> Result<MaterialId> {
        let id = MaterialId::try_from(self.materials.len()).map_err(|_| {
            Error::LimitExceeded(format!("a scene holds at most {MAX_MATERIALS} materials"))
        })?;
        self.ids.insert(material.name.clone(), id);
        self.materials.push(material);
        Ok(id)
    }

    fn declare(&mut self, name: &str, spec: &MaterialSpec) -> Result<()> {
        let material = match spec {
            MaterialSpec::Library(lib) => {
                let m = builtin_material(lib).ok_or_else(|| Error::InvalidMaterial {
                    name: name.to_owned(),
                    reason: format!("{lib:?} is not a library material"),
                })?;
                Material {
                    name: name.to_owned(),
                    ..m
                }
            }
            MaterialSpec::Custom {
                absorption,
                scattering,
                transmission,
            } => Material {
                name: name.to_owned(),
                absorption: *absorption,
                scattering: *scattering,
                transmission: *transmission,
            },
        };
        self.push(material.validated()?)?;
        Ok(())
    }

    fn knows(&self, name: &str) -> bool {
        self.ids.contains_key(name) || builtin_material(name).is_some()
    }

    fn id(&mut self, name: &str) -> Result<MaterialId> {
        if let Some(&id) = self.ids.get(name) {
            return Ok(id);
        }
        match builtin_material(name) {
            Some(m) => self.push(m),
            None => Err(Error::UnknownMaterial(name.to_owned())),
        }
    }
}

fn build_object(
    spec: &ObjectSpec,
    table: &mut MaterialTable,
    base_dir: Option<&Path>,
) -> Result<SceneObject> {
    let transform = spec.transform.validated()?;
    let no_map = BTreeMap::new();
    let (raw, map, strict) = match &spec.mesh {
        MeshSpec::Inline(m) => (inline_raw(m)?, &no_map, true),
        MeshSpec::File(f) => {
            let path = resolve_relative(base_dir, &f.file)?;
            (load_mesh_file(&path)?, &f.materials, false)
        }
        MeshSpec::BoxRoom(g) => (g.generate()?, &g.materials, false),
        MeshSpec::LRoom(g) => (g.generate()?, &g.materials, false),
        MeshSpec::TwoRooms(g) => (g.generate()?, &g.materials, false),
        MeshSpec::Hall(g) => (g.generate()?, &g.materials, false),
    };
    let default = spec.material.as_deref().map(|m| table.id(m)).transpose()?;
    // Resolve each distinct mesh material name once: an explicit mapping
    // must name a known material; an unmapped name is used if it is a
    // material (inline meshes: it must be) and otherwise falls back to the
    // object's default.
    let mut by_name = Vec::with_capacity(raw.names.len());
    for n in &raw.names {
        let id = match map.get(n) {
            Some(target) => Some(table.id(target)?),
            None if strict || table.knows(n) => Some(table.id(n)?),
            None => default,
        };
        by_name.push(id);
    }
    let materials = raw
        .triangle_names
        .iter()
        .enumerate()
        .map(|(t, n)| {
            n.map_or(default, |i| by_name[i as usize]).ok_or_else(|| {
                Error::InvalidScene(format!(
                    "triangle {t} has no material; give the object a \"material\""
                ))
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let mesh = TriangleMesh::new(raw.positions, raw.triangles)?;
    Ok(SceneObject {
        name: spec.name.clone(),
        mesh,
        materials,
        transform,
        dynamic: spec.dynamic,
    })
}

fn inline_raw(m: &InlineMesh) -> Result<RawMesh> {
    let mut raw = RawMesh {
        positions: m.vertices.clone(),
        triangles: m.triangles.clone(),
        ..RawMesh::default()
    };
    raw.triangle_names = match &m.materials {
        None => vec![None; m.triangles.len()],
        Some(names) if names.len() != m.triangles.len() => {
            return Err(Error::MaterialCountMismatch {
                expected: m.triangles.len(),
                actual: names.len(),
            })
        }
        Some(names) => names.iter().map(|n| Some(raw.intern(n))).collect(),
    };
    Ok(raw)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::test_dir;
    use crate::scene::BAND_COUNT;

    const EXAMPLE: &str = r#"{
      "name": "shoebox", "description": "doc example",
      "materials": {
        "walls": "concrete",
        "floor": {"absorption": 0.3},
        "curtain": {"absorption": [0.05,0.07,0.31,0.49,0.75,0.7,0.6,0.6], "scattering": 0.1, "transmission": 0.0}
      },
      "objects": [
        {"name": "room", "material": "walls", "mesh": {"box_room": {"min": [0,0,0], "max": [10,6,3]}}},
        {"name": "panel", "dynamic": true,
         "transform": {"rotation": [0,0,0,1], "translation": [1,2,1]},
         "mesh": {"vertices": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]], "triangles": [[0,1,2],[1,3,2]],
                  "materials": ["curtain", "audience"]}}
      ]
    }"#;

    #[test]
    fn builds_the_documented_example() {
        let scene = Scene::from_json_str(EXAMPLE, None).unwrap();
        let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["walls", "floor", "curtain", "audience"]);
        let room = scene.object("room").unwrap();
        assert_eq!(room.mesh.triangle_count(), 12);
        // Box slots pick declared materials of the same name, else the default.
        let floor_tris = room.materials.iter().filter(|&&m| m == 1).count();
        assert_eq!(floor_tris, 2);
        assert_eq!(room.materials.iter().filter(|&&m| m == 0).count(), 10);
        let panel = scene.object("panel").unwrap();
        assert!(panel.dynamic);
        assert_eq!(panel.materials, vec![2, 3]);
        assert_eq!(panel.transform.translation, Vec3::new(1.0, 2.0, 1.0));
        assert_eq!(scene.materials[1].absorption, [0.3; BAND_COUNT]);
    }

    #[test]
    fn to_json_round_trips() {
        let scene = Scene::from_json_str(EXAMPLE, None).unwrap();
        let text = scene.to_json().unwrap();
        assert_eq!(Scene::from_json_str(&text, None).unwrap(), scene);
    }

    fn err(text: &str) -> String {
        Scene::from_json_str(text, None).unwrap_err().to_string()
    }

    #[test]
    fn errors_name_the_problem_and_place() {
        let e = err(r#"{"objects": [], "colour": 1}"#);
        assert!(
            e.contains("unknown field `colour`") && e.contains("line 1"),
            "{e}"
        );
        let e = err(
            r#"{"objects": [{"name": "a", "mesh": {"box_room": {"min": [0,0,0], "max": [1,1,1], "subdivision": 2}}}]}"#,
        );
        assert!(e.contains("subdivision"), "{e}");
        let e = err(
            r#"{"objects": [{"name": "a", "material": "unobtainium", "mesh": {"box_room": {"min": [0,0,0], "max": [1,1,1]}}}]}"#,
        );
        assert!(
            e.contains("object \"a\"") && e.contains("unobtainium"),
            "{e}"
        );
        let e = err(r#"{"materials": {"x": {"absorption": [0.1, 0.2]}}, "objects": []}"#);
        assert!(e.contains("exactly 8"), "{e}");
        let e = err(r#"{"materials": {"x": {"absorption": 1.5}}, "objects": []}"#);
        assert!(e.contains("[0, 1]"), "{e}");
        let e = err(r#"{"materials": {"x": "concrete", "x": "brick"}, "objects": []}"#);
        assert!(e.contains("declared twice"), "{e}");
        let e = err(
            r#"{"objects": [{"name": "a", "mesh": {"box_room": {"min": [0,0,0], "max": [1,1,1]}}}]}"#,
        );
        assert!(e.contains("no material"), "{e}");
        let e = err(r#"{"objects": [{"name": "a", "mesh": {"teapot": {}}}]}"#);
        assert!(e.contains("unknown mesh kind"), "{e}");
        // The mesh forms, read field by field.
        let mesh = |m: &str| {
            err(&format!(
                r#"{{"objects": [{{"name": "a", "material": "rigid", "mesh": {m}}}]}}"#
            ))
        };
        let e = mesh(
            r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]], "materials": {"x": "y"}}"#,
        );
        assert!(e.contains("one name per triangle"), "{e}");
        let e = mesh(r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]]}"#);
        assert!(e.contains("missing field `triangles`"), "{e}");
        let e = mesh(r#"{"vertices": [[0,0,0]], "triangles": [[0,1,2]], "colour": 1}"#);
        assert!(e.contains("unknown field `colour`"), "{e}");
        let e = mesh(r#"{"vertices": [[0,0]], "triangles": [[0,1,2]]}"#);
        assert!(e.contains("inline mesh"), "{e}");
        let e = mesh(r#"{"file": "x.obj", "materials": ["a"]}"#);
        assert!(e.contains("maps file material names"), "{e}");
        let e = mesh(r#"{"file": "x.obj", "scale": 2}"#);
        assert!(e.contains("file mesh: unknown field `scale`"), "{e}");
        let e = mesh(r#"{"box_room": {"min": [0,0,0], "max": [1,1,1]}, "hall": {}}"#);
        assert!(e.contains("a mesh is"), "{e}");
        let e = mesh(r#"{"file": "x.obj", "vertices": [[0,0,0]], "triangles": [[0,0,0]]}"#);
        assert!(e.contains("a mesh is"), "{e}");
        let e = mesh("[1, 2]");
        assert!(e.contains("a mesh is"), "{e}");
        // What the document format always took still loads.
        let ok = |m: &str| {
            let doc =
                format!(r#"{{"objects": [{{"name": "a", "material": "rigid", "mesh": {m}}}]}}"#);
            Scene::from_json_str(&doc, None).unwrap_or_else(|e| panic!("{m}: {e}"))
        };
        ok(r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]], "materials": null}"#);
        ok(
            r#"{"box_room": {"min": [0,0,0], "max": [1,1,1]}, "box_room": {"min": [0,0,0], "max": [2,2,2]}}"#,
        );
        let e = err(
            r#"{"objects": [{"name": "a", "mesh": {"vertices": [[0,0,0]], "triangles": [[0,1,2]]}, "material": "rigid"}]}"#,
        );
        assert!(
            e.contains("object \"a\"") && e.contains("refers to vertex"),
            "{e}"
        );
        let e =
            err(r#"{"objects": [{"name": "a", "material": "rigid", "mesh": {"file": "x.obj"}}]}"#);
        assert!(e.contains("load it from a file"), "{e}");
        let e = err(
            r#"{"objects": [{"name": "a", "material": "rigid", "transform": {"rotation": [0,0,0,0]}, "mesh": {"box_room": {"min": [0,0,0], "max": [1,1,1]}}}]}"#,
        );
        assert!(e.contains("zero length"), "{e}");
        let dup = r#"{"name": "a", "material": "rigid", "mesh": {"box_room": {"min": [0,0,0], "max": [1,1,1]}}}"#;
        let e = err(&format!(r#"{{"objects": [{dup}, {dup}]}}"#));
        assert!(e.contains("duplicate object"), "{e}");
    }

    #[test]
    fn loads_files_relative_to_the_scene_and_maps_usemtl_names() {
        let dir = test_dir("format");
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        std::fs::write(
            dir.join("meshes/wall.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl brick\nf 1 2 3\nusemtl glossy\nf 1 2 4\nusemtl shiny\nf 1 3 4\n",
        )
        .unwrap();
        let scene_path = dir.join("scene.json");
        std::fs::write(
            &scene_path,
            r#"{"objects": [{"name": "wall", "material": "rigid",
                "mesh": {"file": "meshes/wall.obj", "materials": {"shiny": "marble"}}}]}"#,
        )
        .unwrap();
        let scene = Scene::load(&scene_path).unwrap();
        let wall = scene.object("wall").unwrap();
        let names: Vec<&str> = wall
            .materials
            .iter()
            .map(|&m| scene.materials[m as usize].name.as_str())
            .collect();
        assert_eq!(names, ["brick", "rigid", "marble"]);

        let bare = Scene::load(&dir.join("meshes/wall.obj")).unwrap();
        assert_eq!(bare.objects[0].name, "wall");
        assert_eq!(bare.triangle_count(), 3);

        std::fs::write(
            dir.join("evil.json"),
            r#"{"objects": [{"name": "e", "material": "rigid", "mesh": {"file": "../x.obj"}}]}"#,
        )
        .unwrap();
        let e = Scene::load(&dir.join("evil.json")).unwrap_err().to_string();
        assert!(e.contains("object \"e\"") && e.contains(".."), "{e}");
        assert!(Scene::load(&dir.join("missing.json")).is_err());
        assert!(Scene::load(&dir.join("scene.txt")).is_err());
        let _ = std::fs::remove_dir_all(dir);
    }
}
