//! Sample rays, the dissertation's way of handing a frustum's cells to
//! triangles ([`CellAssignment::Sampled`](super::tracer::CellAssignment)):
//! every cell corner and every cell centre casts one ray through the
//! scene's BVH, and a cell goes to the plane groups its five rays meet
//! first. The rays are the engine's ordinary nearest-triangle queries
//! (`SceneBvh::closest_triangle`: the 8-wide tree where the CPU has AVX,
//! the watertight test), so a ray through the edge between two triangles
//! meets exactly one of them; the work per frustum is bounded by the ray
//! count however many triangles the frustum covers.

use glam::DVec3;

use super::frustum::Frustum;
use super::path::first_hit;
use super::surfaces::{Surfaces, NO_GROUP};
use crate::geometry::Ray;
use crate::query::SceneBvh;

/// Fills `out` with the plane group each sample ray of `f` meets first
/// beyond the frustum's near plane, other than `skip` (the group the
/// frustum leaves), or [`NO_GROUP`]: the `(n+1)^2` cell corners row by
/// row, then the `n^2` cell centres.
pub(super) fn cast(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    f: &Frustum,
    skip: Option<u32>,
    n: usize,
    out: &mut Vec<u32>,
) {
    out.clear();
    let step = 1.0 / n as f64;
    let first_group = |x: f64, y: f64| {
        let Some(ray) = sample_ray(f, x, y) else {
            return NO_GROUP;
        };
        first_hit(bvh, surfaces, &ray, 0.0, f32::INFINITY, skip)
            .map(|hit| surfaces.group_of(hit.object, hit.triangle))
            .filter(|&g| Some(g) != skip)
            .unwrap_or(NO_GROUP)
    };
    for i in 0..=n {
        for j in 0..=n {
            out.push(first_group(i as f64 * step, j as f64 * step));
        }
    }
    for i in 0..n {
        for j in 0..n {
            out.push(first_group(
                (i as f64 + 0.5) * step,
                (j as f64 + 0.5) * step,
            ));
        }
    }
}

/// The ray through window point `(x, y)`, starting where it enters the
/// valid side of the near plane (at the apex for a frustum without one);
/// `None` when it never does.
fn sample_ray(f: &Frustum, x: f64, y: f64) -> Option<Ray> {
    let d = f.direction(x, y);
    let origin: DVec3 = match &f.near {
        None => f.apex,
        Some(near) => {
            let rate = near.side * near.plane.normal.dot(d);
            let t = -near.distance(f.apex) / rate;
            if !(rate > 0.0 && t.is_finite()) {
                return None;
            }
            f.apex + d * t.max(0.0)
        }
    };
    Some(Ray::new(origin.as_vec3(), d.as_vec3()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acoustics::surfaces::Plane;

    #[test]
    fn a_mirrored_frustum_casts_from_its_mirror_not_from_the_image_source() {
        let f = Frustum::sphere(DVec3::new(1.0, 2.0, 1.5), 1)
            .into_iter()
            .find(|f| f.direction(0.5, 0.5).z < -0.5)
            .expect("a frustum looking down");
        let floor = Plane {
            normal: DVec3::Z,
            offset: 0.0,
        };
        let up = f.reflected(&floor).expect("the source is above the floor");
        assert!(up.apex.z < 0.0, "the image source lies below the floor");
        let ray = sample_ray(&up, 0.5, 0.5).expect("the centre ray leaves the floor");
        assert!(ray.origin.z.abs() < 1e-6, "starts on the floor: {ray:?}");
        assert!(ray.dir.z > 0.0, "and goes up");
        // Continued through the floor, it starts where it crosses it.
        let down = f.transmitted(&floor).expect("transmits");
        let ray = sample_ray(&down, 0.5, 0.5).expect("goes down through the floor");
        assert!(ray.origin.z.abs() < 1e-6 && ray.dir.z < 0.0);
    }
}
