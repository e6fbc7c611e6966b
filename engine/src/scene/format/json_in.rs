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
