//! Writing a scene back as a self-contained JSON document.

use glam::Vec3;
use serde::{Serialize, Serializer};

use crate::geometry::RigidTransform;
use crate::scene::{Bands, Material, Scene};
use crate::{Error, Result};

impl Scene {
    /// The scene as a self-contained JSON document (inline meshes, every
    /// material spelt out), which [`Scene::from_json_str`] reads back to an
    /// equal scene. Material names must be unique.
    pub fn to_json(&self) -> Result<String> {
        let mut names = std::collections::HashSet::new();
        for m in &self.materials {
            if !names.insert(m.name.as_str()) {
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
