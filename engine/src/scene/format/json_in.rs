//! The parts of the document serde cannot derive with good errors: the
//! ordered `materials` object, and the number-or-array material and the
//! several mesh forms, each with a message saying what was expected.

use std::collections::HashSet;
use std::fmt;

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer};
use serde_json::Value;

use super::{MaterialSpec, MeshSpec};
use crate::scene::{Bands, BAND_COUNT};

/// Reads the `materials` object keeping document order and refusing
/// duplicate names.
pub(super) fn ordered_materials<'de, D: Deserializer<'de>>(
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
            // A set, not a scan of `out`: documents may declare tens of
            // thousands of materials.
            let mut seen = HashSet::new();
            while let Some((name, spec)) = map.next_entry::<String, MaterialSpec>()? {
                if !seen.insert(name.clone()) {
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
    /// Streams the mesh's fields into their types as they come: an inline
    /// mesh's vertices go straight into a `Vec<Vec3>`, never through a
    /// `serde_json::Value` (about ten times the mesh's memory).
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_map(MeshVisitor)
    }
}

const MESH_FORMS: &str = "a mesh is {\"vertices\", \"triangles\"}, {\"file\"}, or one of \
                          {\"box_room\"}, {\"l_room\"}, {\"two_rooms\"}, {\"hall\"}";

/// An inline mesh's per-triangle names or a file mesh's name map: the two
/// forms share the key `materials`.
#[derive(Deserialize)]
#[serde(untagged)]
enum MeshMaterials {
    PerTriangle(Vec<String>),
    ByName(std::collections::BTreeMap<String, String>),
}

struct MeshVisitor;

impl<'de> Visitor<'de> for MeshVisitor {
    type Value = MeshSpec;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(MESH_FORMS)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> std::result::Result<MeshSpec, A::Error> {
        let mut vertices = None;
        let mut triangles = None;
        let mut file = None;
        let mut materials = None;
        let mut generated: Option<MeshSpec> = None;
        // Distinct keys: a repeated one replaces its value, as serde_json's
        // maps do.
        let mut keys: Vec<String> = Vec::new();
        while let Some(key) = map.next_key::<String>()? {
            if !keys.contains(&key) {
                keys.push(key.clone());
            }
            let with = |what: &str, e: A::Error| de::Error::custom(format!("{what}: {e}"));
            match key.as_str() {
                "vertices" => vertices = Some(map.next_value().map_err(|e| with("inline mesh", e))?),
                "triangles" => {
                    triangles = Some(map.next_value().map_err(|e| with("inline mesh", e))?)
                }
                "file" => file = Some(map.next_value().map_err(|e| with("file mesh", e))?),
                "materials" => materials = map.next_value::<Option<MeshMaterials>>().map_err(|_| {
                    de::Error::custom(
                        "mesh materials: a list of names (inline meshes) or a {file name: material} map (file meshes)",
                    )
                })?,
                "box_room" => generated = Some(MeshSpec::BoxRoom(map.next_value().map_err(|e| with(&key, e))?)),
                "l_room" => generated = Some(MeshSpec::LRoom(map.next_value().map_err(|e| with(&key, e))?)),
                "two_rooms" => generated = Some(MeshSpec::TwoRooms(map.next_value().map_err(|e| with(&key, e))?)),
                "hall" => generated = Some(MeshSpec::Hall(map.next_value().map_err(|e| with(&key, e))?)),
                _ if vertices.is_some() || triangles.is_some() => {
                    return Err(de::Error::custom(format!("inline mesh: unknown field `{key}`")))
                }
                _ if file.is_some() => {
                    return Err(de::Error::custom(format!("file mesh: unknown field `{key}`")))
                }
                _ => {
                    return Err(de::Error::custom(format!(
                        "unknown mesh kind {key:?}; {MESH_FORMS}"
                    )))
                }
            }
        }
        let inline = vertices.is_some() || triangles.is_some();
        let missing =
            |what: &str, field: &str| de::Error::custom(format!("{what}: missing field `{field}`"));
        match (inline, file, generated) {
            (true, None, None) => Ok(MeshSpec::Inline(super::InlineMesh {
                vertices: vertices.ok_or_else(|| missing("inline mesh", "vertices"))?,
                triangles: triangles.ok_or_else(|| missing("inline mesh", "triangles"))?,
                materials: match materials {
                    None => None,
                    Some(MeshMaterials::PerTriangle(names)) => Some(names),
                    Some(MeshMaterials::ByName(_)) => {
                        return Err(de::Error::custom(
                            "inline mesh: `materials` is a list of one name per triangle",
                        ))
                    }
                },
            })),
            (false, Some(file), None) => {
                Ok(MeshSpec::File(super::FileMesh {
                    file,
                    materials: match materials {
                        None => Default::default(),
                        Some(MeshMaterials::ByName(map)) => map,
                        Some(MeshMaterials::PerTriangle(_)) => return Err(de::Error::custom(
                            "file mesh: `materials` maps file material names to scene materials",
                        )),
                    },
                }))
            }
            (false, None, Some(generated)) if keys.len() == 1 => Ok(generated),
            _ => Err(de::Error::custom(MESH_FORMS)),
        }
    }
}
