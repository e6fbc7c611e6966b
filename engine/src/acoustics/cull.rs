//! Which triangles a frustum may touch: the scene's two-level BVH walked with
//! a frustum-box test instead of a ray-box test.
//!
//! The test is conservative (a box is dropped only when it lies wholly
//! outside one side plane or behind the near plane), which is all
//! correctness needs: the exact work happens per triangle in window space.
//! Children are visited nearest first by the frustum's depth `s`, and a box
//! whose nearest point lies beyond the caller's stop depth is skipped: once
//! every cell is covered (or every sample ray has hit), nothing farther can
//! matter.

use glam::{Vec3A, Vec4};

use super::frustum::Frustum;
use super::surfaces::Surfaces;
use crate::bvh::traverse::STACK_SIZE;
use crate::bvh::wide::Node4;
use crate::geometry::{Aabb, RigidTransform};
use crate::query::SceneBvh;

/// A frustum's bounding planes in single precision: inward normals with
/// offsets, a point `p` being outside plane `i` when
/// `normals[i] · p < offsets[i] - slack`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxCull {
    /// Four side planes, the near plane, then the depth `s` as
    /// `normals[5] · p - offsets[5]` (moved between frames like a plane).
    normals: [Vec3A; 6],
    offsets: [f32; 6],
    planes: usize,
    slack: f32,
}

impl BoxCull {
    pub(crate) fn new(f: &Frustum, slack: f32) -> Self {
        let apex = f.apex.as_vec3a();
        let mut normals = [Vec3A::ZERO; 6];
        let mut offsets = [0.0; 6];
        let depth = f.depth_gradient();
        normals[5] = depth.as_vec3a();
        offsets[5] = depth.dot(f.apex) as f32;
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
        for i in (0..self.planes).chain([5]) {
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

    /// The smallest depth `s` over box `b` (a lower bound, in f32).
    #[inline]
    fn near_depth(&self, b: &Aabb) -> f32 {
        let n = self.normals[5];
        let near = Vec3A::select(n.cmpgt(Vec3A::ZERO), b.min, b.max);
        n.dot(near) - self.offsets[5]
    }

    /// The smallest depth over each of a wide node's four slots.
    #[inline]
    fn near_depth4(&self, node: &Node4) -> Vec4 {
        let n = self.normals[5];
        let mut dot = Vec4::ZERO;
        for axis in 0..3 {
            let near = if n[axis] > 0.0 {
                node.lo[axis]
            } else {
                node.hi[axis]
            };
            dot += near * n[axis];
        }
        dot - Vec4::splat(self.offsets[5])
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

/// Calls `visit(first, count)` with the flat [`Surfaces`] indices of the
/// triangles of every leaf whose box may overlap the frustum and starts
/// nearer than the stop depth, which `visit` returns (infinity: no stop;
/// negative infinity ends the walk).
/// `stack` is scratch space.
pub(crate) fn for_each_leaf(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    cull: &BoxCull,
    stack: &mut Vec<(u32, f32)>,
    mut visit: impl FnMut(usize, usize) -> f64,
) {
    let top = &bvh.top;
    if top.nodes.is_empty() {
        return;
    }
    let mut stop = f32::INFINITY;
    // A binary walk holds at most depth + 1 entries; builders keep the
    // depth within the traversal stack size.
    let mut top_stack = [0u32; STACK_SIZE];
    let mut top_len = 1;
    while top_len > 0 {
        top_len -= 1;
        let i = top_stack[top_len];
        let node = &top.nodes[i as usize];
        if !cull.overlaps(&node.aabb()) || cull.near_depth(&node.aabb()) > stop {
            continue;
        }
        if !node.is_leaf() {
            top_stack[top_len] = node.first();
            top_stack[top_len + 1] = node.first() + 1;
            top_len += 2;
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
            stack.push((0, f32::NEG_INFINITY));
            while let Some((n, depth)) = stack.pop() {
                if depth > stop {
                    continue;
                }
                let node = &nodes[n as usize];
                let depths = local.near_depth4(node);
                let mut mask = local.overlaps4(node);
                // Leaves are visited at once, nearest first; inner nodes are
                // pushed farthest first, so the nearest is taken next.
                let mut slots = [(0usize, 0.0f32); 4];
                let mut k = 0;
                while mask != 0 {
                    let s = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    slots[k] = (s, depths[s]);
                    k += 1;
                }
                let slots = &mut slots[..k];
                slots.sort_unstable_by(|a, b| a.1.total_cmp(&b.1));
                for &(s, d) in slots.iter() {
                    if node.is_leaf_slot(s) && d <= stop {
                        let first = base + node.child[s] as usize;
                        stop = stop_depth(visit(first, node.count[s] as usize));
                    }
                }
                for &(s, d) in slots.iter().rev() {
                    if node.is_inner_slot(s) && d <= stop {
                        stack.push((node.child[s], d));
                    }
                }
            }
        }
    }
}

/// The caller's stop depth as a box bound: rounded up, so that no box that
/// could hold something nearer is skipped.
fn stop_depth(d: f64) -> f32 {
    if d == f64::NEG_INFINITY {
        return f32::NEG_INFINITY;
    }
    let d = d * (1.0 + 1e-6);
    if d.is_finite() {
        d as f32 * (1.0 + 4.0 * f32::EPSILON) + f32::MIN_POSITIVE
    } else {
        f32::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::acoustics::{test_shoebox, AcousticScene};

    /// The sampled cells give up on classification by answering negative
    /// infinity: no leaf may follow.
    #[test]
    fn every_reachable_leaf_is_visited_unless_the_visitor_ends_the_walk() {
        let scene = AcousticScene::new(&test_shoebox(16, 0.3));
        let frustum = Frustum::sphere(DVec3::new(2.0, 3.5, 1.2), 1)[0];
        let cull = BoxCull::new(&frustum, 0.0);
        let mut stack = Vec::new();
        let walk = |stop: f64, stack: &mut Vec<(u32, f32)>| {
            let mut leaves = 0;
            for_each_leaf(scene.bvh(), scene.surfaces(), &cull, stack, |_, _| {
                leaves += 1;
                stop
            });
            leaves
        };
        assert!(walk(f64::INFINITY, &mut stack) > 1);
        assert_eq!(walk(f64::NEG_INFINITY, &mut stack), 1);
    }
}
