//! The JSON scene document: what users write, and how it becomes a
//! [`Scene`]. The format is documented in `scenes/README.md`.
//!
//! Parsing is strict (unknown fields are errors, with the line and column
//! serde reports) because a misspelt field silently ignored would give a
//! wrong simulation rather than an error.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::Path;

use glam::Vec3;
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::Value;

use super::generate::{BoxRoom, Hall, LRoom, TwoRooms};
use super::library::builtin_material;
use super::load::{load_mesh_file, resolve_relative};
use super::{Bands, Material, MaterialId, RawMesh, Scene, SceneObject, BAND_COUNT};
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
    #[serde(default, deserialize_with = "ordered_materials")]
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
        for spec in &self.objects {
            if spec.name.is_empty() {
                return Err(Error::InvalidScene("an object has an empty name".into()));
            }
            if objects.iter().any(|o| o.name == spec.name) {
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
            Error::InvalidScene(format!(
                "more than {} materials",
                MaterialId::MAX as usize + 1
            ))
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
        let ext = super::load::extension(path);
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

    /// The scene as a self-contained JSON document (inline meshes, every
    /// material spelt out), which [`Scene::from_json_str`] reads back to an
    /// equal scene. Material names must be unique.
    pub fn to_json(&self) -> Result<String> {
        for (i, m) in self.materials.iter().enumerate() {
            if self.materials[..i].iter().any(|o| o.name == m.name) {
                return Err(Error::InvalidScene(format!(
                    "material name {:?} is used twice",
                    m.name
                )));
            }
        }
        let objects = self
            .objects
            .iter()
            .map(|o| {
                let materials = o
                    .materials
                    .iter()
                    .map(|&id| {
                        self.materials
                            .get(usize::from(id))
                            .map(|m| m.name.as_str())
                            .ok_or_else(|| {
                                Error::InvalidScene(format!("material id {id} is out of range"))
                                    .in_object(&o.name)
                            })
                    })
                    .collect::<Result<Vec<_>>>()?;
                Ok(OutObject {
                    name: &o.name,
                    dynamic: o.dynamic,
                    transform: &o.transform,
                    mesh: OutMesh {
                        vertices: o.mesh.positions(),
                        triangles: o.mesh.triangles(),
                        materials,
                    },
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let doc = OutDocument {
            materials: OutMaterials(&self.materials),
            objects,
        };
        serde_json::to_string(&doc).map_err(|e| Error::InvalidScene(e.to_string()))
    }
}

#[derive(Serialize)]
struct OutDocument<'a> {
    materials: OutMaterials<'a>,
    objects: Vec<OutObject<'a>>,
}

/// Materials as a JSON object in table order, so ids survive a round trip.
struct OutMaterials<'a>(&'a [Material]);

impl Serialize for OutMaterials<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Coefficients<'a> {
            absorption: &'a Bands,
            scattering: &'a Bands,
            transmission: &'a Bands,
        }
        s.collect_map(self.0.iter().map(|m| {
            let c = Coefficients {
                absorption: &m.absorption,
                scattering: &m.scattering,
                transmission: &m.transmission,
            };
            (&m.name, c)
        }))
    }
}

#[derive(Serialize)]
struct OutObject<'a> {
    name: &'a str,
    dynamic: bool,
    transform: &'a RigidTransform,
    mesh: OutMesh<'a>,
}

#[derive(Serialize)]
struct OutMesh<'a> {
    vertices: &'a [Vec3],
    triangles: &'a [[u32; 3]],
    materials: Vec<&'a str>,
}

/// Reads the `materials` object keeping document order and refusing
/// duplicate names.
fn ordered_materials<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<(String, MaterialSpec)>, D::Error> {
    struct Ordered;
    impl<'de> Visitor<'de> for Ordered {
        type Value = Vec<(String, MaterialSpec)>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("an object mapping material names to materials")
        }
        fn visit_map<A: MapAccess<'de>>(
            self,
            mut map: A,
        ) -> std::result::Result<Self::Value, A::Error> {
            let mut out: Self::Value = Vec::new();
            while let Some((name, spec)) = map.next_entry::<String, MaterialSpec>()? {
                if out.iter().any(|(n, _)| *n == name) {
                    return Err(de::Error::custom(format!(
                        "material {name:?} is declared twice"
                    )));
                }
                out.push((name, spec));
            }
            Ok(out)
        }
    }
    d.deserialize_map(Ordered)
}

impl<'de> Deserialize<'de> for MaterialSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        material_spec(Value::deserialize(d)?).map_err(de::Error::custom)
    }
}

fn material_spec(v: Value) -> std::result::Result<MaterialSpec, String> {
    let obj = match v {
        Value::String(s) => return Ok(MaterialSpec::Library(s)),
        Value::Object(o) => o,
        _ => {
            return Err(
                "a material is a library name or an object with absorption, scattering and transmission"
                    .into(),
            )
        }
    };
    if let Some(k) = obj
        .keys()
        .find(|k| !["absorption", "scattering", "transmission"].contains(&k.as_str()))
    {
        return Err(format!(
            "unknown material field {k:?}; expected absorption, scattering or transmission"
        ));
    }
    let bands = |key: &str, required: bool| -> std::result::Result<Bands, String> {
        match obj.get(key) {
            None if required => Err(format!("material needs \"{key}\"")),
            None => Ok([0.0; BAND_COUNT]),
            Some(Value::Number(n)) => Ok([n.as_f64().unwrap_or(f64::NAN) as f32; BAND_COUNT]),
            Some(Value::Array(a)) if a.len() == BAND_COUNT => {
                let mut out = [0.0; BAND_COUNT];
                for (o, x) in out.iter_mut().zip(a) {
                    *o = x.as_f64().ok_or_else(|| format!("{key} holds a non-number {x}"))? as f32;
                }
                Ok(out)
            }
            Some(other) => Err(format!(
                "{key} must be one number or exactly {BAND_COUNT} numbers (63 Hz to 8 kHz), got {other}"
            )),
        }
    };
    Ok(MaterialSpec::Custom {
        absorption: bands("absorption", true)?,
        scattering: bands("scattering", false)?,
        transmission: bands("transmission", false)?,
    })
}

impl<'de> Deserialize<'de> for MeshSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        mesh_spec(Value::deserialize(d)?).map_err(de::Error::custom)
    }
}

const MESH_FORMS: &str = "a mesh is {\"vertices\", \"triangles\"}, {\"file\"}, or one of \
                          {\"box_room\"}, {\"l_room\"}, {\"two_rooms\"}, {\"hall\"}";

fn mesh_spec(v: Value) -> std::result::Result<MeshSpec, String> {
    fn parse<T: de::DeserializeOwned>(what: &str, v: Value) -> std::result::Result<T, String> {
        serde_json::from_value(v).map_err(|e| format!("{what}: {e}"))
    }
    let Value::Object(mut obj) = v else {
        return Err(MESH_FORMS.into());
    };
    if obj.contains_key("vertices") || obj.contains_key("triangles") {
        return parse("inline mesh", Value::Object(obj)).map(MeshSpec::Inline);
    }
    if obj.contains_key("file") {
        return parse("file mesh", Value::Object(obj)).map(MeshSpec::File);
    }
    if obj.len() != 1 {
        return Err(MESH_FORMS.into());
    }
    let (kind, params) = obj
        .iter_mut()
        .next()
        .map(|(k, v)| (k.clone(), v.take()))
        .ok_or(MESH_FORMS)?;
    match kind.as_str() {
        "box_room" => parse(&kind, params).map(MeshSpec::BoxRoom),
        "l_room" => parse(&kind, params).map(MeshSpec::LRoom),
        "two_rooms" => parse(&kind, params).map(MeshSpec::TwoRooms),
        "hall" => parse(&kind, params).map(MeshSpec::Hall),
        _ => Err(format!("unknown mesh kind {kind:?}; {MESH_FORMS}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::test_dir;

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
