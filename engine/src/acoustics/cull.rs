//! Which triangles a frustum may touch: the scene's world walked with a
//! frustum's node test ([`FrustumTest`]) instead of a ray's.
//!
//! The test is conservative, which is all correctness needs: the exact work
//! happens per triangle in window space. Boxes are visited nearest first by
//! the frustum's depth `s`, and a box whose nearest point lies beyond the
//! caller's stop depth is skipped: once every cell is covered (or every
//! sample ray has hit), nothing farther can matter.

use glam::Vec3A;

use super::frustum::Frustum;
use super::surfaces::Surfaces;
use crate::bvh::traverse::{Flow, FrustumTest};
use crate::bvh::SceneBvh;

/// A frustum's bounding planes in single precision (four sides and, past
/// the first reflection, the near plane), keyed by the depth `s`, with
/// `slack` metres of tolerance.
pub(crate) fn box_cull(f: &Frustum, slack: f32) -> FrustumTest {
    let apex = f.apex.as_vec3a();
    let mut planes = [(Vec3A::ZERO, 0.0); 5];
    for (plane, n) in planes.iter_mut().zip(f.side_normals()) {
        let n = n.normalize().as_vec3a();
        *plane = (n, n.dot(apex));
    }
    let mut count = 4;
    if let Some(near) = &f.near {
        planes[4] = (
            (near.plane.normal * near.side).as_vec3a(),
            (near.plane.offset * near.side) as f32,
        );
        count = 5;
    }
    let depth = f.depth_gradient();
    let depth: (Vec3A, f32) = (depth.as_vec3a(), depth.dot(f.apex) as f32);
    FrustumTest::new(&planes[..count], depth, slack)
}

/// Calls `visit(first, count)` with the flat [`Surfaces`] indices of the
/// triangles of every leaf whose box may overlap the frustum and starts
/// nearer than the stop depth, which `visit` returns (infinity: no stop;
/// negative infinity ends the walk).
pub(crate) fn for_each_leaf(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    cull: &FrustumTest,
    mut visit: impl FnMut(usize, usize) -> f64,
) {
    bvh.walk_objects(cull, f32::INFINITY, |object, inst, stop| {
        let local = if inst.is_identity() {
            *cull
        } else {
            cull.in_frame(inst.to_object())
        };
        let base = surfaces.object_base(object as usize);
        inst.bvh()
            .wide()
            .walk(&local, *stop, |first, count, object_stop| {
                *object_stop = stop_depth(visit(base + first as usize, count as usize));
                *stop = *object_stop;
                if *stop == f32::NEG_INFINITY {
                    Flow::Break(())
                } else {
                    Flow::Continue(())
                }
            });
        if *stop == f32::NEG_INFINITY {
            Flow::Break(())
        } else {
            Flow::Continue(())
        }
    });
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
        let cull = box_cull(&frustum, 0.0);
        let walk = |stop: f64| {
            let mut leaves = 0;
            for_each_leaf(scene.bvh(), scene.surfaces(), &cull, |_, _| {
                leaves += 1;
                stop
            });
            leaves
        };
        assert!(walk(f64::INFINITY) > 1);
        assert_eq!(walk(f64::NEG_INFINITY), 1);
    }
}
