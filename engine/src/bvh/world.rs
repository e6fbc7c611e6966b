//! The two-level world of a scene: one [`MeshBvh`] per object in the
//! object's own frame, and a small top-level tree over the objects' world
//! boxes. Moving an object rigidly changes only its transform and the top
//! level; deforming it refits only its own tree. Queries walk the top level
//! with [`SceneBvh::walk_objects`] and each object's tree in its frame.

use std::sync::{Arc, Mutex, PoisonError};

use rayon::prelude::*;
use serde::Serialize;

use super::lod::LodTree;
use super::traverse::pair::{leaves_within, Leaf};
use super::traverse::{Flow, NodeTest, OverlapTest};
use crate::bvh::{BuildOptions, Bvh, MeshBvh, UpdateReport};
use crate::geometry::{Aabb, RigidTransform, TriangleMesh};
use crate::scene::{MaterialId, Scene};
use crate::{Error, Result};

/// One object of the scene as the queries see it.
#[derive(Clone, Debug)]
pub struct Instance {
    bvh: MeshBvh,
    materials: Vec<MaterialId>,
    to_world: RigidTransform,
    to_object: RigidTransform,
    /// Identity transforms skip moving the query.
    identity: bool,
    /// Levels of detail, fitted when first asked for (see
    /// [`Instance::lods`]).
    lods: LodCache,
}

/// The levels of detail of one object as last fitted; refitted when its
/// tree has moved since.
#[derive(Debug, Default)]
struct LodCache(Mutex<Option<Arc<LodTree>>>);

impl Clone for LodCache {
    fn clone(&self) -> Self {
        let cached = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        Self(Mutex::new(cached.clone()))
    }
}

impl Instance {
    /// The object's tree, in its own frame.
    #[inline]
    pub fn bvh(&self) -> &MeshBvh {
        &self.bvh
    }

    /// The object's levels of detail ([`super::lod`]), in its own frame:
    /// fitted on first use and again once its mesh has moved, so scenes
    /// that never ask for them never pay for them.
    pub fn lods(&self) -> Arc<LodTree> {
        let mut cached = self.lods.0.lock().unwrap_or_else(PoisonError::into_inner);
        match &*cached {
            Some(lods) if lods.fits(&self.bvh) => lods.clone(),
            _ => {
                let lods = Arc::new(LodTree::fit(&self.bvh));
                *cached = Some(lods.clone());
                lods
            }
        }
    }

    /// Material of each triangle, in mesh order.
    #[inline]
    pub fn materials(&self) -> &[MaterialId] {
        &self.materials
    }

    #[inline]
    pub fn to_world(&self) -> &RigidTransform {
        &self.to_world
    }

    #[inline]
    pub fn to_object(&self) -> &RigidTransform {
        &self.to_object
    }

    /// Whether object and world frames coincide (no query needs moving).
    #[inline]
    pub fn is_identity(&self) -> bool {
        self.identity
    }

    /// The object's box in the world.
    pub fn world_bounds(&self) -> Aabb {
        let b = self.bvh.bounds();
        if self.identity {
            b
        } else {
            b.transformed(&self.to_world)
        }
    }
}

/// The two-level acceleration structure of a scene.
#[derive(Clone, Debug)]
pub struct SceneBvh {
    instances: Vec<Instance>,
    /// Top level over the instances' world boxes; rebuilt whenever an object
    /// moves, which costs microseconds for the tens of objects a scene has.
    top: Bvh,
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
                lods: LodCache::default(),
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
        let boxes: Vec<Aabb> = self.instances.iter().map(Instance::world_bounds).collect();
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

    pub fn instances(&self) -> &[Instance] {
        &self.instances
    }

    /// Triangles over every object.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| i.bvh().triangle_count())
            .sum()
    }

    /// Walks the top level with `test` (in world space) and calls
    /// `visit(object, instance, bound)` for every object whose world box it
    /// reaches, nearest key first; `visit` walks the object's tree in its
    /// frame, may lower the bound and breaks to end the walk.
    #[inline(always)]
    pub fn walk_objects<T: NodeTest>(
        &self,
        test: &T,
        bound: f32,
        mut visit: impl FnMut(u32, &Instance, &mut f32) -> Flow,
    ) {
        self.top.walk(test, bound, |first, count, bound| {
            for slot in first..first + count {
                let object = self.top.prim_ids[slot as usize];
                visit(object, &self.instances[object as usize], bound)?;
            }
            Flow::Continue(())
        });
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

    /// Calls `visit(a, b)` once for every pair of objects `a < b` whose
    /// world boxes overlap: the broad phase between objects.
    pub fn overlapping_objects(&self, mut visit: impl FnMut(u32, u32) -> Flow) {
        for (a, inst) in self.instances.iter().enumerate() {
            let mut flow = Flow::Continue(());
            let test = OverlapTest::new(inst.world_bounds());
            self.top.walk(&test, 0.0, |first, count, _| {
                for slot in first..first + count {
                    let b = self.top.prim_ids[slot as usize];
                    if b as usize > a {
                        flow = visit(a as u32, b);
                        flow?;
                    }
                }
                Flow::Continue(())
            });
            if flow.is_break() {
                return;
            }
        }
    }

    /// Calls `visit(leaf of a, leaf of b)` for every pair of leaves of
    /// objects `a` and `b` whose boxes overlap in the world (leaf slots of
    /// each object's tree; its `prim_ids` name the triangles): the pair walk
    /// of [`super::traverse::pair::overlapping_leaves`] with `b`'s tree
    /// moved into `a`'s frame.
    pub fn overlapping_leaves(
        &self,
        a: u32,
        b: u32,
        visit: impl FnMut(Leaf, Leaf) -> Flow,
    ) -> Result<()> {
        self.leaves_within(a, b, 0.0, visit)
    }

    /// [`Self::overlapping_leaves`] for leaves whose boxes come closer
    /// than `distance`: the broad phase of proximity queries.
    pub fn leaves_within(
        &self,
        a: u32,
        b: u32,
        distance: f32,
        visit: impl FnMut(Leaf, Leaf) -> Flow,
    ) -> Result<()> {
        let count = self.instances.len();
        let get = |o: u32| {
            self.instances
                .get(o as usize)
                .ok_or_else(|| Error::UnknownObject(format!("#{o} (the scene has {count})")))
        };
        let (ia, ib) = (get(a)?, get(b)?);
        let (b_to_a, slack) = if ia.identity && ib.identity {
            (None, 0.0)
        } else {
            let bounds = ib.bvh.bounds();
            let reach = bounds.min.abs().max(bounds.max.abs()).max_element();
            let (motion, slack) = RigidTransform::relative(&ia.to_world, &ib.to_world, reach);
            (Some(motion), slack)
        };
        leaves_within(
            ia.bvh.wide(),
            ib.bvh.wide(),
            b_to_a.as_ref(),
            distance + slack,
            visit,
        );
        Ok(())
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
