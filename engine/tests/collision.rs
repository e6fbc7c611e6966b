//! Discrete collision over the world against brute force: every pair of
//! triangles of different objects tested, without any hierarchy.

mod common;

use std::collections::BTreeSet;

use common::object;
use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::collision::{
    object_contacts, object_proximity, self_contacts, triangle_distance, triangles_intersect,
    world_contacts, Contact,
};
use frusta_engine::geometry::{shapes, RigidTransform, TriangleMesh};
use frusta_engine::scene::{Material, Scene, SceneObject};
use glam::{DQuat, DVec3, Quat, Vec3};

/// A room, two balls through each other, a ring around one of them, a
/// cube resting exactly on the floor (touching, which counts) and a ball
/// clear of everything.
fn scene() -> Scene {
    let tilt = Quat::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 0.7);
    let at = |r: Quat, t: Vec3| RigidTransform::new(r, t).unwrap();
    Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects: vec![
            object("room", shapes::cube(5.0, 3), RigidTransform::IDENTITY),
            object(
                "ball",
                shapes::icosphere(1.0, 2),
                at(tilt, Vec3::new(0.5, 0.2, 0.0)),
            ),
            object(
                "ball2",
                shapes::icosphere(0.8, 2),
                at(tilt.inverse(), Vec3::new(1.6, 0.4, 0.3)),
            ),
            object(
                "ring",
                shapes::torus(1.1, 0.2, 24, 8),
                at(tilt, Vec3::new(0.5, 0.2, 0.1)),
            ),
            object(
                "crate",
                shapes::cube(0.5, 1),
                RigidTransform::from_translation(Vec3::new(-3.0, -3.0, -4.5)),
            ),
            object(
                "lone",
                shapes::icosphere(0.5, 1),
                at(Quat::IDENTITY, Vec3::new(-3.0, 3.0, 3.0)),
            ),
        ],
    }
}

fn world_triangles(o: &SceneObject) -> Vec<[DVec3; 3]> {
    let q = o.transform.rotation;
    let rot = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize();
    let shift = o.transform.translation.as_dvec3();
    let identity = o.transform.is_identity();
    let p = o.mesh.positions();
    o.mesh
        .triangles()
        .iter()
        .map(|t| {
            t.map(|v| {
                let p = p[v as usize].as_dvec3();
                if identity {
                    p
                } else {
                    rot * p + shift
                }
            })
        })
        .collect()
}

#[test]
fn world_contacts_are_every_intersecting_pair_brute_force_finds() {
    let scene = scene();
    let world = SceneBvh::build(&scene, &BuildOptions::default());
    let tris: Vec<Vec<[DVec3; 3]>> = scene.objects.iter().map(world_triangles).collect();
    let mut brute = BTreeSet::new();
    for a in 0..tris.len() {
        for b in a + 1..tris.len() {
            for (x, ta) in tris[a].iter().enumerate() {
                for (y, tb) in tris[b].iter().enumerate() {
                    if triangles_intersect(ta, tb) {
                        brute.insert(Contact {
                            a: (a as u32, x as u32),
                            b: (b as u32, y as u32),
                        });
                    }
                }
            }
        }
    }
    let found: BTreeSet<Contact> = world_contacts(&world).into_iter().collect();
    let touching: BTreeSet<(u32, u32)> = brute.iter().map(|c| (c.a.0, c.b.0)).collect();
    // ball-ball2, ball-ring, ball2-ring, room-crate (resting on the floor).
    assert_eq!(
        touching,
        [(0, 4), (1, 2), (1, 3), (2, 3)].into_iter().collect()
    );
    assert_eq!(found, brute);
    assert!(object_contacts(&world, 1, 5).unwrap().is_empty());
    assert!(object_contacts(&world, 1, 9).is_err());
}

/// One mesh of two interpenetrating balls and a fold: self-contacts are
/// every intersecting pair of triangles that share no corner, brute force.
#[test]
fn self_contacts_are_every_intersecting_pair_of_non_adjacent_triangles() {
    let ball = shapes::icosphere(1.0, 2);
    let mut positions = ball.positions().to_vec();
    let mut triangles = ball.triangles().to_vec();
    let n = positions.len() as u32;
    positions.extend(
        ball.positions()
            .iter()
            .map(|p| *p * 0.7 + Vec3::new(0.9, 0.3, 0.0)),
    );
    triangles.extend(ball.triangles().iter().map(|t| t.map(|v| v + n)));
    let mesh = TriangleMesh::new(positions, triangles).unwrap();
    let spin = Quat::from_axis_angle(Vec3::new(1.0, 0.2, 0.0).normalize(), 1.3);
    let scene = Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects: vec![
            object(
                "pair",
                mesh.clone(),
                RigidTransform::new(spin, Vec3::splat(3.0)).unwrap(),
            ),
            object(
                "single",
                shapes::icosphere(1.0, 3),
                RigidTransform::IDENTITY,
            ),
        ],
    };
    let world = SceneBvh::build(&scene, &BuildOptions::default());
    let p = mesh.positions();
    let tris: Vec<[DVec3; 3]> = mesh
        .triangles()
        .iter()
        .map(|t| t.map(|v| p[v as usize].as_dvec3()))
        .collect();
    let mut brute = BTreeSet::new();
    for x in 0..tris.len() {
        for y in x + 1..tris.len() {
            let shared = tris[x].iter().any(|c| tris[y].contains(c));
            if !shared && triangles_intersect(&tris[x], &tris[y]) {
                brute.insert(Contact {
                    a: (0, x as u32),
                    b: (0, y as u32),
                });
            }
        }
    }
    assert!(brute.len() > 20, "{}", brute.len());
    let found: BTreeSet<Contact> = self_contacts(&world, 0).unwrap().into_iter().collect();
    assert_eq!(found, brute);
    assert!(
        self_contacts(&world, 1).unwrap().is_empty(),
        "a closed ball does not cross itself"
    );
    assert!(self_contacts(&world, 2).is_err());
}

/// Proximity against brute force: the lone ball is 1.5 m from three walls
/// of the room; every triangle pair within 1.6 m (and none beyond) is
/// reported with its distance, and a negative or NaN distance is refused.
#[test]
fn proximity_reports_every_pair_within_the_distance() {
    let scene = scene();
    let world = SceneBvh::build(&scene, &BuildOptions::default());
    let (room, lone) = (
        world_triangles(&scene.objects[0]),
        world_triangles(&scene.objects[5]),
    );
    for distance in [1.49, 1.6, 2.5] {
        let mut brute = BTreeSet::new();
        for (x, ta) in room.iter().enumerate() {
            for (y, tb) in lone.iter().enumerate() {
                if triangle_distance(ta, tb) <= distance {
                    brute.insert((x as u32, y as u32));
                }
            }
        }
        let near = object_proximity(&world, 0, 5, distance).unwrap();
        let found: BTreeSet<(u32, u32)> = near.iter().map(|(c, _)| (c.a.1, c.b.1)).collect();
        assert_eq!(found, brute, "within {distance}");
        assert_eq!(brute.is_empty(), distance < 1.5, "within {distance}");
        for (c, d) in &near {
            assert!(*d <= distance && *d >= 1.5 - 1e-6, "{c:?} at {d}");
        }
    }
    assert!(object_proximity(&world, 0, 5, -1.0).is_err());
    assert!(object_proximity(&world, 0, 5, f64::NAN).is_err());
}
