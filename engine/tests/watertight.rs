//! Rays shot from inside closed meshes never escape, and cross the surface
//! exactly once when the mesh is convex, including rays aimed exactly at
//! vertices and along edges, at tiny and huge scales.

mod common;

use common::{all_methods, placed, Rng};
use frusta_engine::bvh::MeshBvh;
use frusta_engine::geometry::{shapes, Ray, TriangleMesh};
use glam::{Quat, Vec3};

/// Targets on the surface: every vertex, and points along every edge.
fn surface_targets(mesh: &TriangleMesh) -> Vec<Vec3> {
    let p = mesh.positions();
    let mut targets: Vec<Vec3> = p.to_vec();
    for t in mesh.triangles() {
        for k in 0..3 {
            let (a, b) = (p[t[k] as usize], p[t[(k + 1) % 3] as usize]);
            for f in [0.5, 0.25, 1.0 / 3.0] {
                targets.push(a + (b - a) * f);
            }
        }
    }
    targets
}

/// Shoots rays from `origin` at every surface target and in `random` random
/// directions; asserts that each crosses the surface exactly `crossings`
/// times (or an odd number of times when `None`).
fn assert_no_leaks(mesh: &TriangleMesh, origin: Vec3, random: usize, crossings: Option<usize>) {
    let mut rng = Rng(7);
    let mut dirs: Vec<Vec3> = surface_targets(mesh).iter().map(|&t| t - origin).collect();
    dirs.extend((0..random).map(|_| rng.direction()));
    for options in all_methods() {
        let bvh = MeshBvh::build(mesh, &options);
        let rays: Vec<Ray> = dirs.iter().map(|&d| Ray::new(origin, d)).collect();
        let closest = bvh.closest_hits(&rays);
        let escaped = closest.iter().filter(|h| h.is_none()).count();
        assert_eq!(
            escaped,
            0,
            "{:?}: {escaped} of {} rays escaped",
            options.method,
            rays.len()
        );
        let occluded = bvh.any_hits(&rays).iter().filter(|&&h| h).count();
        assert_eq!(occluded, rays.len(), "{:?}: any-hit missed", options.method);
        for ray in &rays {
            let mut n = 0;
            bvh.for_each_hit(ray, |_, _| n += 1);
            match crossings {
                Some(c) => assert_eq!(n, c, "{:?}: ray {ray:?} crossed {n} times", options.method),
                None => assert_eq!(
                    n % 2,
                    1,
                    "{:?}: ray {ray:?} crossed {n} times",
                    options.method
                ),
            }
        }
    }
}

#[test]
fn cube_lets_nothing_out() {
    let cube = shapes::cube(1.0, 4);
    // Dyadic origins: directions to vertices and edge midpoints are exact.
    for origin in [
        Vec3::ZERO,
        Vec3::new(0.25, -0.5, 0.125),
        Vec3::new(0.5, 0.5, 0.5),
    ] {
        assert_no_leaks(&cube, origin, 20_000, Some(1));
    }
}

#[test]
fn icosphere_lets_nothing_out() {
    let sphere = shapes::icosphere(1.0, 3);
    for origin in [
        Vec3::ZERO,
        Vec3::new(0.3, -0.2, 0.1),
        Vec3::new(0.0, 0.0, 0.99),
    ] {
        assert_no_leaks(&sphere, origin, 20_000, Some(1));
    }
}

#[test]
fn torus_lets_nothing_out() {
    let torus = shapes::torus(2.0, 0.5, 32, 16);
    for origin in [Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, -2.1, 0.2)] {
        assert_no_leaks(&torus, origin, 20_000, None);
    }
}

#[test]
fn rotated_meshes_at_tiny_and_huge_scales_let_nothing_out() {
    let rotation = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.61);
    for scale in [0.01, 1.0, 10_000.0] {
        let offset = Vec3::new(3.0, -7.0, 11.0) * scale;
        let sphere = placed(&shapes::icosphere(1.0, 2), rotation, scale, offset);
        assert_no_leaks(
            &sphere,
            offset + Vec3::new(0.1, 0.2, -0.3) * scale,
            5_000,
            Some(1),
        );
        let cube = placed(&shapes::cube(1.0, 3), rotation, scale, offset);
        assert_no_leaks(&cube, offset, 5_000, Some(1));
    }
}

/// A million random rays from random interior points of a finely tessellated
/// sphere, in batches.
#[test]
fn a_million_random_rays_stay_inside() {
    let sphere = shapes::icosphere(1.0, 4);
    let bvh = MeshBvh::build(&sphere, &Default::default());
    let mut rng = Rng(99);
    let mut escaped = 0;
    for _ in 0..10 {
        let rays: Vec<Ray> = (0..100_000)
            .map(|_| Ray::new(rng.direction() * rng.range(0.0, 0.9), rng.direction()))
            .collect();
        escaped += bvh
            .closest_hits(&rays)
            .iter()
            .filter(|h| h.is_none())
            .count();
    }
    assert_eq!(escaped, 0);
}
