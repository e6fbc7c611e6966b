use crate::geometry::{RigidTransform, TriangleMesh};

use super::{Material, MaterialId};

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
    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.triangle_count()).sum()
    }

    pub fn object(&self, name: &str) -> Option<&SceneObject> {
        self.objects.iter().find(|o| o.name == name)
    }
}
