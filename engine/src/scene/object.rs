use glam::Vec3;

use crate::geometry::{RigidTransform, TriangleMesh};
use crate::{Error, Result};

use super::{Material, MaterialId, RawMesh};

/// One named object of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneObject {
    pub name: String,
    /// Geometry in the object's own frame.
    pub mesh: TriangleMesh,
    /// One entry per triangle, indexing [`Scene::materials`].
    pub materials: Vec<MaterialId>,
    /// Object frame to world frame.
    pub transform: RigidTransform,
    /// Dynamic objects may move or deform after the scene is built.
    pub dynamic: bool,
}

/// A scene: a material table and the objects that use it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    pub materials: Vec<Material>,
    pub objects: Vec<SceneObject>,
}

impl Scene {
    /// A scene of one object whose every triangle has `material`: for
    /// generated rooms and quick studies.
    pub fn single_object(name: &str, mesh: RawMesh, material: Material) -> Result<Self> {
        if name.is_empty() {
            return Err(Error::InvalidScene("an object has an empty name".into()));
        }
        let mesh =
            TriangleMesh::new(mesh.positions, mesh.triangles).map_err(|e| e.in_object(name))?;
        Ok(Self {
            objects: vec![SceneObject {
                name: name.to_owned(),
                materials: vec![0; mesh.triangle_count()],
                mesh,
                transform: RigidTransform::IDENTITY,
                dynamic: false,
            }],
            materials: vec![material.validated()?],
        })
    }

    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.triangle_count()).sum()
    }

    pub fn object(&self, name: &str) -> Option<&SceneObject> {
        self.objects.iter().find(|o| o.name == name)
    }

    /// All objects moved into world space as one mesh, in object order:
    /// for exports and for comparing against single-mesh tools.
    pub fn world_mesh(&self) -> Result<TriangleMesh> {
        let (mut positions, mut triangles) = (Vec::new(), Vec::new());
        for o in &self.objects {
            let base = u32::try_from(positions.len()).map_err(|_| {
                Error::LimitExceeded("a scene holds at most 4 billion vertices".into())
            })?;
            positions.extend(
                o.mesh
                    .positions()
                    .iter()
                    .map(|&p| Vec3::from(o.transform.transform_point(p.into()))),
            );
            triangles.extend(o.mesh.triangles().iter().map(|t| t.map(|v| v + base)));
        }
        TriangleMesh::new(positions, triangles)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shapes;

    #[test]
    fn world_mesh_applies_transforms_and_offsets_indices() {
        let cube = shapes::cube(1.0, 1);
        let object = |name: &str, x: f32| SceneObject {
            name: name.into(),
            materials: vec![0; cube.triangle_count()],
            mesh: cube.clone(),
            transform: RigidTransform::from_translation(Vec3::new(x, 0.0, 0.0)),
            dynamic: false,
        };
        let scene = Scene {
            materials: vec![],
            objects: vec![object("a", 0.0), object("b", 10.0)],
        };
        let world = scene.world_mesh().unwrap();
        assert_eq!(world.triangle_count(), 2 * cube.triangle_count());
        assert_eq!(world.bounds().max.x, 11.0);
        assert_eq!(
            world.triangles()[12][0] as usize,
            cube.triangles()[0][0] as usize + cube.vertex_count()
        );
        assert!(Scene::default().world_mesh().is_err());
    }
}
