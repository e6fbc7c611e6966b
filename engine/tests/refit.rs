//! Refitting keeps the hierarchy exact, and the rebuild heuristic fires when
//! primitives fly apart but stays quiet under rigid motion.

mod common;

use common::{all_methods, deformed, placed, Rng};
use frusta_engine::bvh::{MeshBvh, UpdateAction, DEFAULT_REBUILD_THRESHOLD};
use frusta_engine::geometry::{shapes, Aabb, Ray, TriangleMesh};
use glam::{Quat, Vec3};

/// Every slot's box contains its child's slots, or its triangles.
fn assert_boxes_contain_geometry(bvh: &MeshBvh, mesh: &TriangleMesh) {
    let nodes = bvh.wide().nodes();
    for node in nodes {
        for slot in 0..4 {
            let b = node.slot_aabb(slot);
            if node.is_leaf_slot(slot) {
                let (first, count) = (node.child[slot], node.count[slot]);
                for leaf_slot in first..first + count {
                    let [p, q, r] = mesh.corners(bvh.prim_ids()[leaf_slot as usize] as usize);
                    assert!(b.contains(&Aabb::of_triangle(p, q, r)));
                }
            } else if node.is_inner_slot(slot) {
                assert!(b.contains(&nodes[node.child[slot] as usize].aabb()));
            }
        }
    }
}

fn random_rays(rng: &mut Rng, n: usize, spread: f32) -> Vec<Ray> {
    (0..n)
        .map(|_| Ray::new(rng.direction() * spread * rng.f32(), rng.direction()))
        .collect()
}

#[test]
fn refit_after_deformation_hits_like_a_fresh_build() {
    let sphere = shapes::icosphere(1.0, 4);
    let wobble =
        |p: Vec3| p * (1.0 + 0.3 * (5.0 * p.x).sin() * (3.0 * p.y).cos()) + Vec3::Z * p.x * p.x;
    let moved = deformed(&sphere, wobble);
    let mut rng = Rng(3);
    let rays = random_rays(&mut rng, 50_000, 2.0);
    for options in all_methods() {
        let mut refitted = MeshBvh::build(&sphere, &options);
        refitted.refit(&moved).unwrap();
        assert_boxes_contain_geometry(&refitted, &moved);
        let fresh = MeshBvh::build(&moved, &options);
        let (a, b) = (refitted.closest_hits(&rays), fresh.closest_hits(&rays));
        for (ray, (x, y)) in rays.iter().zip(a.iter().zip(&b)) {
            match (x, y) {
                (Some(x), Some(y)) => {
                    assert_eq!(x.t, y.t, "{ray:?}");
                    if x.triangle != y.triangle {
                        // Only two triangles at exactly the same distance may differ.
                        assert_eq!(x.t, y.t);
                    }
                }
                (None, None) => {}
                _ => panic!(
                    "{:?}: refit and fresh build disagree on {ray:?}",
                    options.method
                ),
            }
        }
        let occluded_refit = refitted.any_hits(&rays);
        assert_eq!(occluded_refit, fresh.any_hits(&rays));
    }
}

/// The BART-like case: a cloud of small triangles whose members fly apart
/// in random directions.
#[test]
fn rebuild_heuristic_fires_when_primitives_fly_apart() {
    let mut rng = Rng(11);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut velocity = Vec::new();
    for i in 0..4000u32 {
        let c = rng.direction() * rng.f32() * 10.0;
        let v = rng.direction() * 20.0;
        for _ in 0..3 {
            positions.push(c + rng.direction() * 0.1);
            velocity.push(v);
        }
        triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let cloud = TriangleMesh::new(positions.clone(), triangles.clone()).unwrap();
    for options in all_methods() {
        let mut bvh = MeshBvh::build(&cloud, &options);
        let mut fired_at = None;
        for frame in 1..=10 {
            let t = frame as f32 * 0.1;
            let p = positions
                .iter()
                .zip(&velocity)
                .map(|(&p, &v)| p + v * t)
                .collect();
            let mesh = TriangleMesh::new(p, triangles.clone()).unwrap();
            let report = bvh.update(&mesh, DEFAULT_REBUILD_THRESHOLD);
            if report.action == UpdateAction::Rebuild {
                fired_at = Some(frame);
                assert!(report.degradation.unwrap() > DEFAULT_REBUILD_THRESHOLD);
                break;
            }
        }
        assert!(
            fired_at.is_some(),
            "{:?}: no rebuild in 10 frames",
            options.method
        );
    }
}

#[test]
fn rebuild_heuristic_stays_quiet_under_rigid_motion() {
    let shapes = [shapes::torus(2.0, 0.5, 48, 24), shapes::icosphere(1.0, 4)];
    for mesh in &shapes {
        for options in all_methods() {
            let mut bvh = MeshBvh::build(mesh, &options);
            for frame in 1..=20 {
                let f = frame as f32;
                let moved = placed(
                    mesh,
                    Quat::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.05 * f),
                    1.0,
                    Vec3::new(f, -2.0 * f, 0.5 * f),
                );
                let report = bvh.update(&moved, DEFAULT_REBUILD_THRESHOLD);
                assert_eq!(
                    report.action,
                    UpdateAction::Refit,
                    "{:?} frame {frame}: {report:?}",
                    options.method
                );
                assert!(report.degradation.unwrap() < 0.15, "{report:?}");
            }
            // Pure translation leaves every area ratio unchanged.
            let mut bvh = MeshBvh::build(mesh, &options);
            let shifted = placed(mesh, Quat::IDENTITY, 1.0, Vec3::new(0.5, 0.25, -0.75));
            assert!(bvh.refit(&shifted).unwrap().degradation.abs() < 1e-3);
        }
    }
}

#[test]
fn changed_triangle_count_always_rebuilds() {
    let mut bvh = MeshBvh::build(&shapes::icosphere(1.0, 2), &Default::default());
    let bigger = shapes::icosphere(1.0, 3);
    assert!(
        bvh.refit(&bigger).is_err(),
        "refit must refuse another topology"
    );
    let report = bvh.update(&bigger, DEFAULT_REBUILD_THRESHOLD);
    assert_eq!(report.action, UpdateAction::Rebuild);
    assert_eq!(bvh.triangle_count(), bigger.triangle_count());
    assert!(bvh.closest_hit(&Ray::new(Vec3::ZERO, Vec3::X)).is_some());
}
