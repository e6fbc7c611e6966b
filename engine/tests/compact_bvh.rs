//! The compact layout answers every ray as the plain one does: the same
//! nearest hit (triangle, distance, barycentrics, normal), the same
//! occlusion and the same set of crossings, on generated shapes, on the
//! standard meshes of `../shared/data/meshes/` (skipped with a message
//! where absent), at extreme scales, after refits and after welded
//! vertices part.

mod common;

use common::{all_methods, standard_meshes, Rng};
use frusta_engine::bvh::{BuildOptions, CompactBvh, MeshBvh};
use frusta_engine::geometry::{shapes, Ray, TriangleMesh, WatertightRay};
use glam::Vec3;

/// Rays from everywhere, and rays aimed exactly at vertices and edge
/// midpoints, and rays lying in triangles' planes along their edges.
fn rays(mesh: &TriangleMesh, count: usize, rng: &mut Rng) -> Vec<Ray> {
    let b = mesh.bounds();
    let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
    let size = (hi - lo).length().max(f32::MIN_POSITIVE);
    let centre = (lo + hi) * 0.5;
    let inside = |rng: &mut Rng| lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
    let mut rays = Vec::with_capacity(count);
    for i in 0..count {
        let t = (rng.next_u64() % mesh.triangle_count() as u64) as usize;
        let [a, b, c] = mesh.corners(t).map(Vec3::from);
        let ray = match i % 4 {
            0 => Ray::new(inside(rng), rng.direction()),
            1 => {
                let origin = centre + rng.direction() * size * 2.0;
                Ray::new(origin, a - origin)
            }
            2 => {
                let origin = centre + rng.direction() * size * 2.0;
                Ray::new(origin, (a + b) * 0.5 - origin)
            }
            _ => Ray::new(a - (c - a), c - a),
        };
        rays.push(ray);
    }
    rays
}

fn crossings(visit: impl FnOnce(&mut dyn FnMut(u32, f32))) -> Vec<(u32, u32)> {
    let mut all = Vec::new();
    visit(&mut |t, d| all.push((t, d.to_bits())));
    all.sort_unstable();
    all
}

/// Asserts the two layouts agree on every ray; returns how many hit.
fn assert_same_hits(plain: &MeshBvh, compact: &CompactBvh, rays: &[Ray], what: &str) -> usize {
    let mut hits = 0;
    for ray in rays {
        let (p, c) = (plain.closest_hit(ray), compact.closest_hit(ray));
        assert_eq!(p, c, "{what}: closest hit of {ray:?}");
        hits += p.is_some() as usize;
        assert_eq!(
            plain.any_hit(ray),
            compact.any_hit(ray),
            "{what}: any hit of {ray:?}"
        );
        let short = ray.with_range(ray.t_min, p.map_or(1.0, |h| h.t * 0.999));
        assert_eq!(
            plain.any_hit(&short),
            compact.any_hit(&short),
            "{what}: {short:?}"
        );
        assert_eq!(
            crossings(|f| plain.for_each_hit(ray, f)),
            crossings(|f| compact.for_each_hit(ray, f)),
            "{what}: crossings of {ray:?}"
        );
    }
    hits
}

fn shapes_under_test() -> Vec<(&'static str, TriangleMesh)> {
    vec![
        ("cube", shapes::cube(1.0, 6)),
        ("icosphere", shapes::icosphere(2.0, 4)),
        ("torus", shapes::torus(3.0, 1.0, 48, 24)),
    ]
}

#[test]
fn generated_shapes_hit_alike_with_every_builder() {
    let mut rng = Rng(5);
    for (name, mesh) in shapes_under_test() {
        let rays = rays(&mesh, 2000, &mut rng);
        for options in all_methods() {
            let plain = MeshBvh::build(&mesh, &options);
            let compact = CompactBvh::build(&mesh, &options);
            let hits = assert_same_hits(&plain, &compact, &rays, name);
            assert!(hits > rays.len() / 3, "{name}: only {hits} rays hit");
            assert_eq!(compact.triangle_count(), mesh.triangle_count());
        }
    }
}

/// The layout's point: on closed meshes it takes under a third of the
/// plain layout's bytes.
#[test]
fn compact_takes_under_a_third_of_the_bytes() {
    for (name, mesh) in shapes_under_test() {
        let plain = MeshBvh::build(&mesh, &BuildOptions::default()).memory_bytes();
        let compact = CompactBvh::build(&mesh, &BuildOptions::default()).memory_bytes();
        assert!(
            3 * compact < plain,
            "{name}: {compact} bytes against {plain}"
        );
    }
}

#[test]
fn hits_alike_at_extreme_scales_and_with_degenerate_triangles() {
    let mut rng = Rng(9);
    let sphere = shapes::icosphere(1.0, 3);
    for (scale, offset) in [(1e-20, 0.0), (1e-2, 1e3), (1e12, -3e14), (1.0, 1e5)] {
        let positions = sphere
            .positions()
            .iter()
            .map(|p| *p * scale + Vec3::splat(offset));
        let mut positions: Vec<Vec3> = positions.collect();
        let mut triangles = sphere.triangles().to_vec();
        // Degenerate triangles on the surface: a sliver and a point.
        let n = positions.len() as u32;
        positions.push((positions[0] + positions[1]) * 0.5);
        triangles.push([0, 1, n]);
        triangles.push([2, 2, 2]);
        let mesh = TriangleMesh::new(positions, triangles).unwrap();
        let plain = MeshBvh::build(&mesh, &BuildOptions::default());
        let compact = CompactBvh::build(&mesh, &BuildOptions::default());
        let rays = rays(&mesh, 1000, &mut rng);
        let hits = assert_same_hits(
            &plain,
            &compact,
            &rays,
            &format!("scale {scale} at {offset}"),
        );
        assert!(hits > 0, "scale {scale}: no hits");
    }
}

/// After a refit to a twisted and moved mesh, both layouts still agree,
/// and the compact one equals brute force.
#[test]
fn refits_keep_the_layouts_alike() {
    let mut rng = Rng(11);
    let mesh = shapes::torus(3.0, 1.0, 40, 20);
    let mut plain = MeshBvh::build(&mesh, &BuildOptions::default());
    let mut compact = CompactBvh::build(&mesh, &BuildOptions::default());
    let mut moved = mesh.clone();
    for step in 1..=3 {
        let angle = 0.3 * step as f32;
        let twisted = mesh.positions().iter().map(|p| {
            let a = angle * p.z;
            Vec3::new(
                p.x * a.cos() - p.y * a.sin(),
                p.x * a.sin() + p.y * a.cos(),
                p.z * 1.5,
            ) + Vec3::X * step as f32
        });
        moved.set_positions(twisted.collect()).unwrap();
        let report = compact.refit(&moved).unwrap();
        let plain_report = plain.refit(&moved).unwrap();
        // The same heuristic on the same topology: within bfloat16's
        // rounding of the plain tree's figure, and clearly above 0.
        assert!(
            (report.degradation - plain_report.degradation).abs()
                < 0.02 + 0.02 * plain_report.degradation.abs(),
            "{report:?} against {plain_report:?}"
        );
        assert!(report.degradation > 0.01, "{report:?}");
        let rays = rays(&moved, 1000, &mut rng);
        assert_same_hits(&plain, &compact, &rays, &format!("refit {step}"));
        for ray in rays.iter().step_by(10) {
            let w = WatertightRay::new(ray);
            // Nearest, and of equal distances the lowest triangle index.
            let brute = (0..moved.triangle_count())
                .filter_map(|t| {
                    let [a, b, c] = moved.corners(t);
                    w.intersect(a, b, c, ray.t_min, ray.t_max)
                        .map(|h| (h.t, t as u32))
                })
                .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            let found = compact.closest_hit(ray).map(|h| (h.t, h.triangle));
            assert_eq!(found, brute, "{ray:?}");
        }
    }
    assert!(compact.refit(&shapes::cube(1.0, 1)).is_err());
    // Moved back in place: nothing grew.
    let report = compact.refit(&mesh).unwrap();
    assert_eq!(report.degradation, 0.0, "{report:?}");
    let shifted: Vec<Vec3> = mesh
        .positions()
        .iter()
        .map(|p| *p + Vec3::new(100.0, -3.0, 7.0))
        .collect();
    moved.set_positions(shifted).unwrap();
    let report = compact.refit(&moved).unwrap();
    assert!(report.degradation.abs() < 0.01, "translation: {report:?}");
}

/// A mesh split along every edge (each triangle its own corners) is welded
/// into shared vertices; when the copies later part, a refit lays the
/// corners out again instead of tracing stale ones.
#[test]
fn welded_seams_that_part_are_laid_out_again() {
    let sphere = shapes::icosphere(1.0, 3);
    let split = shapes::unwelded(&sphere);
    let positions = split.positions().to_vec();
    let mut plain = MeshBvh::build(&split, &BuildOptions::default());
    let mut compact = CompactBvh::build(&split, &BuildOptions::default());
    assert_eq!(compact.vertex_count(), sphere.positions().len());
    let mut rng = Rng(13);
    assert_same_hits(&plain, &compact, &rays(&split, 500, &mut rng), "welded");
    // Every triangle moves out along its own normal: the seams open.
    let mut exploded = split.clone();
    let opened: Vec<Vec3> = positions
        .chunks(3)
        .flat_map(|c| {
            let n = (c[1] - c[0]).cross(c[2] - c[0]).normalize() * 0.05;
            [c[0] + n, c[1] + n, c[2] + n]
        })
        .collect();
    exploded.set_positions(opened).unwrap();
    let plain_report = plain.refit(&exploded).unwrap();
    let report = compact.refit(&exploded).unwrap();
    assert!(compact.vertex_count() > sphere.positions().len());
    assert!(report.degradation > 0.01, "the seams opened: {report:?}");
    assert!(
        (report.degradation - plain_report.degradation).abs() < 0.01,
        "{report:?} {plain_report:?}"
    );
    assert_same_hits(&plain, &compact, &rays(&exploded, 500, &mut rng), "parted");
}

#[test]
fn every_standard_mesh_hits_alike() {
    let mut rng = Rng(17);
    for (name, mesh) in standard_meshes() {
        let plain = MeshBvh::build(&mesh, &BuildOptions::default());
        let compact = CompactBvh::build(&mesh, &BuildOptions::default());
        let rays = rays(&mesh, 3000, &mut rng);
        let hits = assert_same_hits(&plain, &compact, &rays, name);
        assert!(hits > rays.len() / 4, "{name}: only {hits} rays hit");
    }
}

/// Rays walk the compact 8-wide tree where the CPU has AVX, unless a leaf
/// holds more triangles than its links can count (15): then there is none,
/// the 4-wide tree answers, and the hits are still the plain layout's.
#[test]
fn large_leaves_fall_back_to_the_four_wide_walk() {
    let mut rng = Rng(11);
    let mesh = shapes::icosphere(2.0, 4);
    let rays = rays(&mesh, 2000, &mut rng);
    // Nodes cost so much against triangles that SAH keeps large leaves.
    let options = BuildOptions {
        max_leaf_size: 48,
        traversal_cost: 1000.0,
        ..BuildOptions::default()
    };
    let compact = CompactBvh::build(&mesh, &options);
    let largest = compact
        .tree()
        .nodes()
        .iter()
        .flat_map(|n| (0..4).map(|s| n.count(s)))
        .max()
        .unwrap();
    assert!(largest > 15, "the largest leaf holds {largest}");
    assert!(compact.eight().is_none());
    let plain = MeshBvh::build(&mesh, &options);
    assert_same_hits(&plain, &compact, &rays, "large leaves");
    // With the default leaves, AVX machines walk the 8-wide tree.
    let default = CompactBvh::build(&mesh, &BuildOptions::default());
    #[cfg(target_arch = "x86_64")]
    assert_eq!(
        default.eight().is_some(),
        std::arch::is_x86_feature_detected!("avx")
    );
}
