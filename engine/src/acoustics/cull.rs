//! Which triangles a frustum may touch: the scene's two-level BVH walked with
//! a frustum-box test instead of a ray-box test.
//!
//! The test is conservative (a box is dropped only when it lies wholly
//! outside one side plane or behind the near plane), which is all
//! correctness needs: the exact work happens per triangle in window space.

use glam::{Vec3A, Vec4};

use super::frustum::Frustum;
use super::surfaces::Surfaces;
use crate::bvh::wide::Node4;
use crate::geometry::{Aabb, RigidTransform};
use crate::query::SceneBvh;

/// A frustum's bounding planes in single precision: inward normals with
/// offsets, a point `p` being outside plane `i` when
/// `normals[i] · p < offsets[i] - slack`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxCull {
    normals: [Vec3A; 5],
    offsets: [f32; 5],
    planes: usize,
    slack: f32,
}

impl BoxCull {
    pub(crate) fn new(f: &Frustum, slack: f32) -> Self {
        let apex = f.apex.as_vec3a();
        let mut normals = [Vec3A::ZERO; 5];
        let mut offsets = [0.0; 5];
        for (i, n) in f.side_normals().iter().enumerate() {
            normals[i] = n.normalize().as_vec3a();
            offsets[i] = normals[i].dot(apex);
        }
        let mut planes = 4;
        if let Some(near) = &f.near {
            normals[4] = (near.plane.normal * near.side).as_vec3a();
            offsets[4] = (near.plane.offset * near.side) as f32;
            planes = 5;
        }
        Self {
            normals,
            offsets,
            planes,
            slack,
        }
    }

    /// The same planes in an object's frame, given the world-to-object
    /// transform.
    fn in_frame(&self, to_object: &RigidTransform) -> Self {
        let to_world = to_object.inverse();
        let mut out = *self;
        for i in 0..self.planes {
            let n = to_object.transform_vector(self.normals[i]);
            // A point p' in the object frame is to_world(p') in the world.
            out.offsets[i] = self.offsets[i] - self.normals[i].dot(to_world.translation.into());
            out.normals[i] = n;
        }
        out
    }

    /// Whether `b` may overlap the frustum.
    #[inline]
    pub(crate) fn overlaps(&self, b: &Aabb) -> bool {
        (0..self.planes).all(|i| {
            let n = self.normals[i];
            let far = Vec3A::select(n.cmpgt(Vec3A::ZERO), b.max, b.min);
            n.dot(far) >= self.offsets[i] - self.slack
        })
    }

    /// Which of a wide node's four slots may overlap the frustum, as a
    /// bit mask.
    #[inline]
    fn overlaps4(&self, node: &Node4) -> u32 {
        let mut keep = glam::BVec4A::splat(true);
        for i in 0..self.planes {
            let n = self.normals[i];
            let mut dot = Vec4::ZERO;
            for axis in 0..3 {
                let far = if n[axis] > 0.0 {
                    node.hi[axis]
                } else {
                    node.lo[axis]
                };
                dot += far * n[axis];
            }
            keep &= dot.cmpge(Vec4::splat(self.offsets[i] - self.slack));
        }
        keep.bitmask()
    }
}

/// Calls `visit(i)` with the flat [`Surfaces`] index of every triangle in a
/// leaf whose box may overlap the frustum. `stack` is scratch space.
pub(crate) fn for_each_triangle(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    cull: &BoxCull,
    stack: &mut Vec<u32>,
    mut visit: impl FnMut(usize),
) {
    let top = &bvh.top;
    if top.nodes.is_empty() {
        return;
    }
    let mut top_stack = vec![0u32];
    while let Some(i) = top_stack.pop() {
        let node = &top.nodes[i as usize];
        if !cull.overlaps(&node.aabb()) {
            continue;
        }
        if !node.is_leaf() {
            top_stack.extend([node.first(), node.first() + 1]);
            continue;
        }
        for slot in node.first()..node.first() + node.count() {
            let object = top.prim_ids[slot as usize] as usize;
            let inst = &bvh.instances[object];
            let local = if inst.identity {
                *cull
            } else {
                cull.in_frame(&inst.to_object)
            };
            let base = surfaces.object_base(object);
            let nodes = inst.bvh.wide().nodes();
            if nodes.is_empty() {
                continue;
            }
            stack.clear();
            stack.push(0);
            while let Some(n) = stack.pop() {
                let node = &nodes[n as usize];
                let mut mask = local.overlaps4(node);
                while mask != 0 {
                    let s = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if node.is_leaf_slot(s) {
                        let first = base + node.child[s] as usize;
                        (first..first + node.count[s] as usize).for_each(&mut visit);
                    } else if node.is_inner_slot(s) {
                        stack.push(node.child[s]);
                    }
                }
            }
        }
    }
}
