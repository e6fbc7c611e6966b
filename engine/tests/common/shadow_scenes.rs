//! Scenes for the shadow tests: floors, boxes, a camera.

use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::geometry::shapes::cube;
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::{Material, Scene, SceneObject};
use frusta_engine::shadows::Camera;
use glam::{DVec2, Vec3};

use super::{deformed, grid_triangles, object};

/// A floor `[-h, h]^2` at height `z`, `n x n` quads, facing up.
pub fn floor(h: f32, z: f32, n: usize) -> TriangleMesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let at = |k: usize| -h + 2.0 * h * k as f32 / n as f32;
            positions.push(Vec3::new(at(i), at(j), z));
        }
    }
    TriangleMesh::new(positions, grid_triangles(n, n)).unwrap()
}

/// A box of half sizes `half` centred at `at`, each face `n x n` quads.
pub fn block(half: Vec3, at: Vec3, n: u32) -> TriangleMesh {
    let c = cube(1.0, n);
    deformed(&c, |p| p * half + at)
}

pub fn scene(objects: Vec<SceneObject>) -> SceneBvh {
    let scene = Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects,
    };
    SceneBvh::build(&scene, &BuildOptions::default())
}

pub fn still(name: &str, mesh: TriangleMesh) -> SceneObject {
    object(name, mesh, RigidTransform::IDENTITY)
}

/// A 192 x 144 camera at `at` looking at `look`.
pub fn camera(at: Vec3, look: Vec3) -> Camera {
    Camera::looking_at(at, look, 192, 144)
}

/// The convex hull of `points`, counter-clockwise, by gift wrapping in
/// `f64`.
pub fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    let start = points.iter().copied().fold(
        points[0],
        |a, b| if (b.x, b.y) < (a.x, a.y) { b } else { a },
    );
    let mut hull = vec![start];
    loop {
        let last = *hull.last().unwrap();
        let mut next = points[0];
        for &q in points {
            let cross = (next - last).perp_dot(q - last);
            if next == last
                || cross < 0.0
                || (cross == 0.0 && last.distance(q) > last.distance(next))
            {
                next = q;
            }
        }
        if next == start {
            break;
        }
        hull.push(next);
    }
    hull
}
