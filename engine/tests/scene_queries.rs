//! The two-level scene structure answers like one flat mesh in world space,
//! and moves objects by transform alone.

mod common;

use common::{placed, Rng};
use frusta_engine::bvh::{BuildOptions, MeshBvh, UpdateAction, DEFAULT_REBUILD_THRESHOLD};
use frusta_engine::geometry::{shapes, Ray, RigidTransform, TriangleMesh};
use frusta_engine::query::SceneBvh;
use frusta_engine::scene::{Material, Scene, SceneObject};
use std::collections::BTreeSet;
use std::ops::ControlFlow;

use glam::{DQuat, DVec3, Quat, Vec3};

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

/// Corners of every triangle of every object in the frame of object
/// `frame`, in f64: moved to the world and back with f64 rotations.
fn triangles_in_frame_f64(scene: &Scene, frame: usize) -> Vec<Vec<[DVec3; 3]>> {
    let motion = |t: &RigidTransform| {
        let q = t.rotation;
        let rot = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize();
        (rot, t.translation.as_dvec3())
    };
    let (frame_rot, frame_shift) = motion(&scene.objects[frame].transform);
    scene
        .objects
        .iter()
        .map(|obj| {
            let (rot, shift) = motion(&obj.transform);
            let p = obj.mesh.positions();
            obj.mesh
                .triangles()
                .iter()
                .map(|tri| {
                    tri.map(|v| {
                        let world = rot * p[v as usize].as_dvec3() + shift;
                        frame_rot.inverse() * (world - frame_shift)
                    })
                })
                .collect()
        })
        .collect()
}

/// Every object's triangles in world space (frame 0, the room's, must be
/// the world), in f64, with their object and mesh triangle.
fn world_triangles(scene: &Scene) -> Vec<([DVec3; 3], (u32, u32))> {
    assert!(
        scene.objects[0].transform.is_identity(),
        "frame 0 is the world"
    );
    triangles_in_frame_f64(scene, 0)
        .into_iter()
        .enumerate()
        .flat_map(|(o, tris)| {
            tris.into_iter()
                .enumerate()
                .map(move |(t, c)| (c, (o as u32, t as u32)))
        })
        .collect()
}

/// Möller–Trumbore in f64: `(t, u, v)` of the ray's crossing of the
/// triangle's plane, if the plane is crossed.
fn crossing(o: DVec3, d: DVec3, [a, b, c]: [DVec3; 3]) -> Option<(f64, f64, f64)> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-18 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    Some((e2.dot(q) / det, u, v))
}

#[test]
fn all_hits_are_every_triangle_a_ray_crosses() {
    let scene = test_scene();
    let bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let world = world_triangles(&scene);
    let mut rng = Rng(77);
    let mut clear_hits = 0;
    for _ in 0..2_000 {
        let ray = Ray::new(rng.direction() * rng.range(0.0, 9.0), rng.direction());
        let mut found = BTreeSet::new();
        bvh.for_each_hit(&ray, |object, triangle, _| {
            assert!(found.insert((object, triangle)), "reported twice");
        });
        let (o, d) = (
            Vec3::from(ray.origin).as_dvec3(),
            Vec3::from(ray.dir).as_dvec3(),
        );
        // Inside by a margin must be found; found must be inside by a margin.
        for (corners, owner) in &world {
            let Some((t, u, v)) = crossing(o, d, *corners) else {
                continue;
            };
            let inside = |m: f64| t > m && u > m && v > m && u + v < 1.0 - m;
            if inside(1e-4) {
                clear_hits += 1;
                assert!(found.contains(owner), "missed {owner:?} on {ray:?}");
            }
            if found.contains(owner) {
                assert!(inside(-1e-4), "{owner:?} is not on {ray:?}");
            }
        }
    }
    // Every ray leaves through a wall; a few cross an object on the way.
    assert!(clear_hits > 2_050, "{clear_hits}");
}

/// The nearest triangle a ray meets is the nearest crossing found in f64
/// by brute force over every object's triangles in world space, wherever
/// the nearest crossing is clear of edges and of the next one.
#[test]
fn the_nearest_triangle_is_the_nearest_crossing() {
    let scene = test_scene();
    let bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let world = world_triangles(&scene);
    let mut rng = Rng(91);
    let (mut checked, mut on_objects) = (0, 0);
    for _ in 0..2_000 {
        let ray = Ray::new(rng.direction() * rng.range(0.0, 9.0), rng.direction());
        let (o, d) = (
            Vec3::from(ray.origin).as_dvec3(),
            Vec3::from(ray.dir).as_dvec3(),
        );
        let mut crossings: Vec<(f64, (u32, u32), bool)> = world
            .iter()
            .filter_map(|(corners, owner)| {
                let (t, u, v) = crossing(o, d, *corners)?;
                let inside = |m: f64| u > m && v > m && u + v < 1.0 - m;
                (t > 0.0 && inside(-1e-4)).then_some((t, *owner, inside(1e-4)))
            })
            .collect();
        crossings.sort_by(|a, b| a.0.total_cmp(&b.0));
        let [(t, owner, clear), rest @ ..] = &crossings[..] else {
            panic!("every ray leaves the room: {ray:?}");
        };
        // Grazing rays and near ties too: the full hit's distance, object
        // and triangle.
        let full = bvh.closest_hit(&ray).map(|h| (h.t, h.object, h.triangle));
        let lean = bvh
            .closest_triangle(&ray)
            .map(|h| (h.t, h.object, h.triangle));
        assert_eq!(lean, full, "{ray:?}");
        if !clear || rest.first().is_some_and(|next| next.0 - t < 1e-3) {
            continue;
        }
        let found = bvh.closest_triangle(&ray).expect("a hit");
        assert_eq!((found.object, found.triangle), *owner, "{ray:?}");
        assert!(
            (f64::from(found.t) - t).abs() <= 1e-5 * t.max(1.0),
            "{} against {t}",
            found.t
        );
        checked += 1;
        on_objects += usize::from(owner.0 > 0);
    }
    assert!(checked > 1_900 && on_objects > 30, "{checked} {on_objects}");
}

/// Pairs of triangles of different objects whose boxes overlap in the
/// frame of the first object (the frame the pair walk works in), judged in
/// f64, as `((object, triangle), (object, triangle))`.
fn overlapping_triangle_boxes(
    scene: &Scene,
    a: usize,
    b: usize,
) -> BTreeSet<((u32, u32), (u32, u32))> {
    let frame = triangles_in_frame_f64(scene, a);
    let boxes = |tris: &[[DVec3; 3]]| -> Vec<(DVec3, DVec3)> {
        tris.iter()
            .map(|c| (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2])))
            .collect()
    };
    let (ba, bb) = (boxes(&frame[a]), boxes(&frame[b]));
    let mut pairs = BTreeSet::new();
    for (x, (alo, ahi)) in ba.iter().enumerate() {
        for (y, (blo, bhi)) in bb.iter().enumerate() {
            if alo.cmple(*bhi).all() && ahi.cmpge(*blo).all() {
                pairs.insert(((a as u32, x as u32), (b as u32, y as u32)));
            }
        }
    }
    pairs
}

#[test]
fn the_pair_walk_finds_every_overlapping_pair_of_triangles() {
    let mut scene = test_scene();
    // A second ball through the ring and one touching the room's wall.
    let tilt = Quat::from_axis_angle(Vec3::new(0.2, 1.0, -0.4).normalize(), 1.1);
    scene.objects.push(object(
        "ball2",
        shapes::icosphere(0.8, 2),
        1,
        RigidTransform::new(tilt, Vec3::new(-2.2, 0.3, 3.0)).unwrap(),
    ));
    scene.objects.push(object(
        "ball3",
        shapes::icosphere(0.5, 2),
        0,
        RigidTransform::new(tilt.inverse(), Vec3::new(9.7, -2.0, 1.0)).unwrap(),
    ));
    let bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let mut object_pairs = BTreeSet::new();
    bvh.overlapping_objects(|a, b| {
        assert!(object_pairs.insert((a, b)), "({a}, {b}) twice");
        ControlFlow::Continue(())
    });
    let n = scene.objects.len();
    let mut touching = 0;
    for a in 0..n {
        for b in a + 1..n {
            let brute = overlapping_triangle_boxes(&scene, a, b);
            if brute.is_empty() {
                continue;
            }
            touching += 1;
            assert!(object_pairs.contains(&(a as u32, b as u32)), "({a}, {b})");
            let (ids_a, ids_b) = (
                bvh.instances()[a].bvh().prim_ids(),
                bvh.instances()[b].bvh().prim_ids(),
            );
            let mut found = BTreeSet::new();
            bvh.overlapping_leaves(a as u32, b as u32, |la, lb| {
                for x in la.slots() {
                    for y in lb.slots() {
                        let pair = ((a as u32, ids_a[x]), (b as u32, ids_b[y]));
                        if brute.contains(&pair) {
                            found.insert(pair);
                        }
                    }
                }
                ControlFlow::Continue(())
            })
            .unwrap();
            assert_eq!(found, brute, "({a}, {b})");
        }
    }
    // The ring and ball2, the room and ball3.
    assert_eq!(touching, 2);
    assert!(bvh
        .overlapping_leaves(0, 9, |_, _| ControlFlow::Continue(()))
        .is_err());
}

#[test]
fn levels_of_detail_answer_in_each_object_s_frame_and_follow_its_deformation() {
    use frusta_engine::bvh::lod::{Cone, LodOptions};
    let scene = test_scene();
    let mut bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let mut rng = Rng(7);
    // A query that allows no plane walks every object's hook: the exact
    // hits, whatever the transforms.
    let none = LodOptions {
        max_error: f32::INFINITY,
        cone: Some(Cone {
            spread: 0.0,
            angle: 0.0,
        }),
    };
    let rays: Vec<Ray> = (0..5_000)
        .map(|_| Ray::new(rng.direction() * rng.range(0.0, 9.0), rng.direction()))
        .collect();
    let exact = bvh.closest_hits(&rays);
    for ((got, want), ray) in bvh
        .closest_hits_lod(&rays, &none)
        .iter()
        .zip(&exact)
        .zip(&rays)
    {
        assert_eq!(got.map(|(h, e)| (h, e)), want.map(|h| (h, 0.0)), "{ray:?}");
    }
    // Rays converging on the turned, moved ball from 6 m: coarse planes
    // meet it within their error, in the world frame.
    let centre = Vec3::new(3.0, 1.0, -2.0);
    let coarse = LodOptions {
        max_error: 0.5,
        cone: Some(Cone {
            spread: 0.0,
            angle: 0.1,
        }),
    };
    let at_ball: Vec<Ray> = (0..2_000)
        .map(|_| {
            let d = rng.direction();
            Ray::new(centre + d * 6.0, -d)
        })
        .collect();
    let check = |bvh: &SceneBvh, radius: f32| {
        let mut planes = 0;
        for (ray, hit) in at_ball.iter().zip(bvh.closest_hits_lod(&at_ball, &coarse)) {
            let (hit, error) = hit.expect("every ray meets the ball");
            assert_eq!(hit.object, 1);
            let exact = bvh.closest_hit(ray).unwrap();
            assert!(
                (hit.t - exact.t).abs() <= error.max(1e-5),
                "{ray:?}: {hit:?} {error}"
            );
            assert!(
                (hit.t - (6.0 - radius)).abs() <= error + 0.05 * radius,
                "{hit:?}"
            );
            planes += usize::from(error > 0.0);
        }
        assert!(planes > 1_000, "{planes} rays met planes");
    };
    check(&bvh, 1.0);
    // Grown in place by a refit: the planes are fitted again, not reused.
    let ball = &scene.objects[1];
    let grown = placed(&ball.mesh, Quat::IDENTITY, 1.5, Vec3::ZERO);
    bvh.update_mesh(1, &grown, &ball.materials, DEFAULT_REBUILD_THRESHOLD)
        .unwrap();
    check(&bvh, 1.5);
}
