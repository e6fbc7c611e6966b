//! Helpers shared by the engine's integration tests.
#![allow(dead_code)]

pub mod shadow_scenes;

use frusta_engine::bvh::{BuildMethod, BuildOptions};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::SceneObject;
use glam::{DVec3, Quat, Vec3};

/// `../shared/data/meshes` (or `$FRUSTA_SHARED_DIR/data/meshes`); `None`,
/// with a message, where it is absent.
pub fn meshes_dir() -> Option<std::path::PathBuf> {
    let shared = std::env::var_os("FRUSTA_SHARED_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared")
        });
    let dir = shared.join("data/meshes");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "skipped: {} not found (set FRUSTA_SHARED_DIR)",
            dir.display()
        );
        None
    }
}

/// The standard meshes of [`meshes_dir`] by file name, flattened; empty
/// (with a message) where the folder is absent.
pub fn standard_meshes() -> Vec<(&'static str, TriangleMesh)> {
    let Some(dir) = meshes_dir() else {
        return Vec::new();
    };
    [
        "stanford-bunny.obj",
        "nefertiti.obj",
        "fandisk.obj",
        "teapot.obj",
        "spot.obj",
    ]
    .into_iter()
    .map(|name| {
        let scene = frusta_engine::scene::Scene::load(&dir.join(name)).unwrap();
        (name, scene.world_mesh().unwrap())
    })
    .collect()
}

/// A small deterministic generator (SplitMix64), so tests need no crate.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// Uniform on the unit sphere.
    pub fn direction(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let a = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * a.cos(), r * a.sin(), z)
    }
}

/// Every builder, so that each property is checked on each.
pub fn all_methods() -> [BuildOptions; 3] {
    [BuildMethod::Sah, BuildMethod::Lbvh, BuildMethod::Hybrid].map(|m| BuildOptions {
        // Small thresholds so that the parallel and hybrid paths run on
        // test-sized meshes too (a range's own binning from 16 x 128).
        parallel_threshold: 128,
        hybrid_sah_size: 64,
        ..BuildOptions::with_method(m)
    })
}

/// `mesh` with every vertex moved by `f`.
pub fn deformed(mesh: &TriangleMesh, f: impl Fn(Vec3) -> Vec3) -> TriangleMesh {
    let positions = mesh.positions().iter().map(|&p| f(p)).collect();
    TriangleMesh::new(positions, mesh.triangles().to_vec()).unwrap()
}

/// `mesh` rotated, scaled and moved.
pub fn placed(mesh: &TriangleMesh, rotation: Quat, scale: f32, offset: Vec3) -> TriangleMesh {
    deformed(mesh, |p| rotation * (p * scale) + offset)
}

/// A dynamic object of `mesh` placed by `transform`, every triangle of
/// material 0.
pub fn object(name: &str, mesh: TriangleMesh, transform: RigidTransform) -> SceneObject {
    SceneObject {
        name: name.into(),
        materials: vec![0; mesh.triangle_count()],
        mesh,
        transform,
        dynamic: true,
    }
}

/// The triangles of a grid of `n` x `m` quads on `(n + 1) x (m + 1)`
/// vertices numbered row by row, two triangles per quad.
pub fn grid_triangles(n: usize, m: usize) -> Vec<[u32; 3]> {
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut triangles = Vec::with_capacity(2 * n * m);
    for j in 0..m {
        for i in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    triangles
}

/// The closed form of a box `[0, size]`: per axis `n` reflections put the
/// image at `2qL + x` (|q| reflections off each wall, n = 2q) or `2qL - x`
/// (|q| off the wall at L and |q - 1| off the wall at 0, n = 2q - 1), and
/// the gain is the product of the walls' factors over the distance.
/// Returns (image, reflections per wall `2 axis + (wall at L)`), by
/// distance to `l`.
pub fn box_images(size: DVec3, s: DVec3, l: DVec3, order: i32) -> Vec<(DVec3, [i32; 6])> {
    let mut out = Vec::new();
    for i in -order..=order {
        for j in -order..=order {
            for k in -order..=order {
                if i.abs() + j.abs() + k.abs() > order {
                    continue;
                }
                let mut image = DVec3::ZERO;
                let mut counts = [0; 6];
                for (axis, n) in [i, j, k].into_iter().enumerate() {
                    let q = (n + 1).div_euclid(2);
                    if n % 2 == 0 {
                        image[axis] = 2.0 * f64::from(q) * size[axis] + s[axis];
                        counts[2 * axis] = q.abs();
                    } else {
                        image[axis] = 2.0 * f64::from(q) * size[axis] - s[axis];
                        counts[2 * axis] = (q - 1).abs();
                    }
                    counts[2 * axis + 1] = q.abs();
                }
                out.push((image, counts));
            }
        }
    }
    out.sort_by(|a, b| a.0.distance(l).total_cmp(&b.0.distance(l)));
    out
}
