//! The two-level scene structure answers like one flat mesh in world space,
//! and moves objects by transform alone.

mod common;

use common::{placed, Rng};
use frusta_engine::bvh::{BuildOptions, MeshBvh, UpdateAction, DEFAULT_REBUILD_THRESHOLD};
use frusta_engine::geometry::{shapes, Ray, RigidTransform, TriangleMesh};
use frusta_engine::query::SceneBvh;
use frusta_engine::scene::{Material, Scene, SceneObject};
use glam::{Quat, Vec3};

fn object(name: &str, mesh: TriangleMesh, material: u16, transform: RigidTransform) -> SceneObject {
    SceneObject {
        name: name.into(),
        materials: vec![material; mesh.triangle_count()],
        mesh,
        transform,
        dynamic: true,
    }
}

fn test_scene() -> Scene {
    let spin = Quat::from_axis_angle(Vec3::new(1.0, 1.0, 0.0).normalize(), 0.8);
    Scene {
        materials: vec![
            Material::uniform("a", 0.1).unwrap(),
            Material::uniform("b", 0.5).unwrap(),
        ],
        objects: vec![
            object("room", shapes::cube(10.0, 4), 0, RigidTransform::IDENTITY),
            object(
                "ball",
                shapes::icosphere(1.0, 3),
                1,
                RigidTransform::new(spin, Vec3::new(3.0, 1.0, -2.0)).unwrap(),
            ),
            object(
                "ring",
                shapes::torus(2.0, 0.4, 24, 12),
                1,
                RigidTransform::new(spin.inverse(), Vec3::new(-4.0, 0.0, 3.0)).unwrap(),
            ),
        ],
    }
}

/// All objects moved into world space and concatenated.
fn flatten(scene: &Scene) -> (TriangleMesh, Vec<(u32, u32)>) {
    let (mut positions, mut triangles, mut owner) = (Vec::new(), Vec::new(), Vec::new());
    for (o, obj) in scene.objects.iter().enumerate() {
        let base = positions.len() as u32;
        let t = obj.transform;
        positions.extend(
            obj.mesh
                .positions()
                .iter()
                .map(|&p| Vec3::from(t.transform_point(p.into()))),
        );
        for (i, tri) in obj.mesh.triangles().iter().enumerate() {
            triangles.push(tri.map(|v| v + base));
            owner.push((o as u32, i as u32));
        }
    }
    (TriangleMesh::new(positions, triangles).unwrap(), owner)
}

#[test]
fn two_levels_answer_like_one_flat_mesh() {
    let scene = test_scene();
    let bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let (flat, owner) = flatten(&scene);
    let flat_bvh = MeshBvh::build(&flat, &BuildOptions::default());
    let mut rng = Rng(21);
    let rays: Vec<Ray> = (0..20_000)
        .map(|_| Ray::new(rng.direction() * rng.range(0.0, 9.0), rng.direction()))
        .collect();
    let hits = bvh.closest_hits(&rays);
    for (ray, hit) in rays.iter().zip(&hits) {
        let hit = hit.expect("inside the closed room every ray hits");
        let reference = flat_bvh.closest_hit(ray).unwrap();
        assert!(
            (hit.t - reference.t).abs() <= 1e-4 * reference.t.max(1.0),
            "{ray:?}"
        );
        if (hit.t - reference.t).abs() < 1e-6 {
            assert_eq!(
                (hit.object, hit.triangle),
                owner[reference.triangle as usize]
            );
        }
        assert!((hit.point - Vec3::from(ray.at(hit.t))).length() < 1e-3);
        assert!((hit.normal.length() - 1.0).abs() < 1e-4);
        let expected_material = if hit.object == 0 { 0 } else { 1 };
        assert_eq!(hit.material, expected_material);
        // The world normal is the flat mesh's normal.
        assert!(hit.normal.dot(reference.normal) > 0.999 || hit.t != reference.t);
    }
    assert_eq!(
        bvh.any_hits(&rays).iter().filter(|&&h| h).count(),
        rays.len()
    );
}

#[test]
fn moving_an_object_moves_its_hits() {
    let mut bvh = SceneBvh::build(&test_scene(), &BuildOptions::default());
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    let before = bvh.closest_hit(&ray).unwrap();
    assert_eq!(before.object, 0, "nothing but the room on +x at first");
    bvh.set_transform(
        1,
        RigidTransform::from_translation(Vec3::new(5.0, 0.0, 0.0)),
    )
    .unwrap();
    let after = bvh.closest_hit(&ray).unwrap();
    assert_eq!(after.object, 1);
    assert!((after.t - 4.0).abs() < 1e-5);
    assert!((after.normal - Vec3::NEG_X).length() < 0.1);
    // A segment that stops short of the ball is not occluded.
    assert!(!bvh.any_hit(&Ray::segment(Vec3::ZERO, Vec3::new(3.9, 0.0, 0.0))));
    assert!(bvh.any_hit(&Ray::segment(Vec3::ZERO, Vec3::new(4.1, 0.0, 0.0))));
    assert!(bvh.set_transform(9, RigidTransform::IDENTITY).is_err());
}

#[test]
fn deforming_an_object_refits_only_that_object() {
    let scene = test_scene();
    let mut bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let ball = &scene.objects[1];
    let grown = placed(&ball.mesh, Quat::IDENTITY, 1.5, Vec3::ZERO);
    let report = bvh
        .update_mesh(1, &grown, &ball.materials, DEFAULT_REBUILD_THRESHOLD)
        .unwrap();
    assert_eq!(report.action, UpdateAction::Refit);
    let centre = Vec3::new(3.0, 1.0, -2.0);
    let hit = bvh.closest_hit(&Ray::new(centre, Vec3::Y)).unwrap();
    assert_eq!(hit.object, 1);
    assert!((hit.t - 1.5).abs() < 0.05, "t = {}", hit.t);
    assert!(bvh
        .update_mesh(1, &grown, &[0], DEFAULT_REBUILD_THRESHOLD)
        .is_err());
    let stats = bvh.stats();
    assert_eq!(stats.objects.len(), 3);
    assert_eq!(stats.triangles, scene.triangle_count());
}
