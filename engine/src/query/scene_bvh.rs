use glam::Vec3A;
use rayon::prelude::*;
use serde::Serialize;

use crate::bvh::{BuildOptions, Bvh, MeshBvh, UpdateReport};
use crate::geometry::{Aabb, RigidTransform, TriangleMesh};
use crate::scene::{MaterialId, Scene};
use crate::{Error, Result};

/// One object of the scene as the queries see it.
#[derive(Clone, Debug)]
pub(crate) struct Instance {
    pub(crate) bvh: MeshBvh,
    pub(crate) materials: Vec<MaterialId>,
    pub(crate) to_world: RigidTransform,
    pub(crate) to_object: RigidTransform,
    /// Identity transforms skip moving the ray.
    pub(crate) identity: bool,
}

/// The two-level acceleration structure of a scene.
#[derive(Clone, Debug)]
pub struct SceneBvh {
    pub(crate) instances: Vec<Instance>,
    /// Top level over the instances' world boxes; rebuilt whenever an object
    /// moves, which costs microseconds for the tens of objects a scene has.
    pub(crate) top: Bvh,
    options: BuildOptions,
}

/// Statistics of one object's hierarchy.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ObjectStats {
    pub triangles: usize,
    pub nodes: usize,
    pub depth: usize,
    pub sah_cost: f32,
    pub memory_bytes: usize,
}

/// Statistics of a whole scene's hierarchies.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SceneBvhStats {
    pub objects: Vec<ObjectStats>,
    pub triangles: usize,
    pub memory_bytes: usize,
}

impl SceneBvh {
    /// Builds every object's hierarchy (in parallel) and the top level.
    pub fn build(scene: &Scene, options: &BuildOptions) -> Self {
        let instances = scene
            .objects
            .par_iter()
            .map(|o| Instance {
                bvh: MeshBvh::build(&o.mesh, options),
                materials: o.materials.clone(),
                to_world: o.transform,
                to_object: o.transform.inverse(),
                identity: o.transform.is_identity(),
            })
            .collect();
        let mut s = Self {
            instances,
            top: Bvh::default(),
            options: options.clone(),
        };
        s.rebuild_top();
        s
    }

    fn rebuild_top(&mut self) {
        let boxes: Vec<Aabb> = self.instances.iter().map(world_bounds).collect();
        self.top = Bvh::build(
            &boxes,
            &BuildOptions {
                max_leaf_size: 1,
                ..self.options.clone()
            },
        );
    }

    pub fn object_count(&self) -> usize {
        self.instances.len()
    }

    /// The world box of the whole scene.
    pub fn bounds(&self) -> Aabb {
        self.top.bounds()
    }

    fn instance_mut(&mut self, object: usize) -> Result<&mut Instance> {
        let count = self.instances.len();
        self.instances
            .get_mut(object)
            .ok_or_else(|| Error::UnknownObject(format!("#{object} (the scene has {count})")))
    }

    /// Moves an object rigidly: only the top level changes.
    pub fn set_transform(&mut self, object: usize, transform: RigidTransform) -> Result<()> {
        let transform = transform.validated()?;
        let inst = self.instance_mut(object)?;
        inst.to_world = transform;
        inst.to_object = transform.inverse();
        inst.identity = transform.is_identity();
        self.rebuild_top();
        Ok(())
    }

    /// Gives an object new geometry (in its own frame): refits its tree, or
    /// rebuilds it when the rebuild heuristic says so or the triangle count
    /// changed. `materials` must have one entry per triangle.
    pub fn update_mesh(
        &mut self,
        object: usize,
        mesh: &TriangleMesh,
        materials: &[MaterialId],
        threshold: f32,
    ) -> Result<UpdateReport> {
        if materials.len() != mesh.triangle_count() {
            return Err(Error::MaterialCountMismatch {
                expected: mesh.triangle_count(),
                actual: materials.len(),
            });
        }
        let inst = self.instance_mut(object)?;
        let report = inst.bvh.update(mesh, threshold);
        inst.materials.clear();
        inst.materials.extend_from_slice(materials);
        self.rebuild_top();
        Ok(report)
    }

    pub fn stats(&self) -> SceneBvhStats {
        let objects: Vec<ObjectStats> = self
            .instances
            .iter()
            .map(|i| ObjectStats {
                triangles: i.bvh.triangle_count(),
                nodes: i.bvh.wide().nodes().len(),
                depth: i.bvh.wide().depth(),
                sah_cost: i.bvh.sah_cost(),
                memory_bytes: i.bvh.memory_bytes() + i.materials.capacity() * 2,
            })
            .collect();
        SceneBvhStats {
            triangles: objects.iter().map(|o| o.triangles).sum(),
            memory_bytes: objects.iter().map(|o| o.memory_bytes).sum::<usize>()
                + self.top.memory_bytes(),
            objects,
        }
    }
}

/// The world box of an instance: its tree's box moved by its transform.
fn world_bounds(i: &Instance) -> Aabb {
    let b = i.bvh.bounds();
    if i.identity {
        return b;
    }
    b.corners()
        .iter()
        .fold(Aabb::EMPTY, |acc, &c| {
            acc.grow(i.to_world.transform_point(c))
        })
        // Rotation rounds; widen by a few ulps of the box's magnitude so
        // that the world box surely contains the moved geometry.
        .padded()
}

impl Aabb {
    fn padded(self) -> Aabb {
        let m = self.min.abs().max(self.max.abs()).max_element();
        let pad = Vec3A::splat(m * 4.0 * f32::EPSILON);
        Aabb::new(self.min - pad, self.max + pad)
    }
}
