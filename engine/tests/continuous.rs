//! Continuous collision over the world against an independent reference:
//! the exact discrete predicate at many instants of the motion. Every pair
//! that intersects at some instant must be reported, no later than that
//! instant; a pair reported must come close at some instant.

mod common;

use std::collections::BTreeMap;

use common::object;
use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::collision::continuous::{
    self_sweep_contacts, sweep_contacts, CcdOptions, EndPose, Sweep,
};
use frusta_engine::collision::{triangle_distance, triangles_intersect};
use frusta_engine::geometry::{shapes, RigidTransform, TriangleMesh};
use frusta_engine::scene::{Material, Scene, SceneObject};
use glam::{DQuat, DVec3, Quat, Vec3};

fn world_of(objects: Vec<SceneObject>) -> (Scene, SceneBvh) {
    let scene = Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects,
    };
    let world = SceneBvh::build(&scene, &BuildOptions::default());
    (scene, world)
}

/// Mesh-order triangles of `mesh` placed by `t`, in f64.
fn placed(mesh: &TriangleMesh, t: &RigidTransform) -> Vec<[DVec3; 3]> {
    let q = t.rotation;
    let rot = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize();
    let shift = t.translation.as_dvec3();
    let p = mesh.positions();
    mesh.triangles()
        .iter()
        .map(|tri| {
            tri.map(|v| {
                let p = p[v as usize].as_dvec3();
                if t.is_identity() {
                    p
                } else {
                    rot * p + shift
                }
            })
        })
        .collect()
}

fn at(s: f64, start: &[DVec3; 3], end: &[DVec3; 3]) -> [DVec3; 3] {
    std::array::from_fn(|i| start[i].lerp(end[i], s))
}

const INSTANTS: usize = 64;

/// Pairs `(x, y)` that intersect at one of the sampled instants, with the
/// first such instant.
fn sampled_contacts(
    a: (&[[DVec3; 3]], &[[DVec3; 3]]),
    b: (&[[DVec3; 3]], &[[DVec3; 3]]),
    skip: impl Fn(usize, usize) -> bool,
) -> BTreeMap<(u32, u32), f64> {
    let mut first = BTreeMap::new();
    for k in 0..=INSTANTS {
        let s = k as f64 / INSTANTS as f64;
        for x in 0..a.0.len() {
            let ta = at(s, &a.0[x], &a.1[x]);
            for y in 0..b.0.len() {
                if skip(x, y) || first.contains_key(&(x as u32, y as u32)) {
                    continue;
                }
                if triangles_intersect(&ta, &at(s, &b.0[y], &b.1[y])) {
                    first.insert((x as u32, y as u32), s);
                }
            }
        }
    }
    first
}

/// Every sampled contact is reported, no later than it was sampled.
fn assert_reported_in_time(found: &BTreeMap<(u32, u32), f64>, sampled: &BTreeMap<(u32, u32), f64>) {
    for (pair, s) in sampled {
        let t = found
            .get(pair)
            .unwrap_or_else(|| panic!("{pair:?} missed (meets at {s})"));
        assert!(*t <= s + 1e-9, "{pair:?} reported at {t}, meets at {s}");
    }
}

/// Closest approach of two moving triangles over fine instants.
fn closest_approach(a: (&[DVec3; 3], &[DVec3; 3]), b: (&[DVec3; 3], &[DVec3; 3])) -> f64 {
    (0..=4096)
        .map(|k| {
            let s = k as f64 / 4096.0;
            triangle_distance(&at(s, a.0, a.1), &at(s, b.0, b.1))
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_falling_cube_meets_the_floor_when_it_reaches_it() {
    let (scene, world) = world_of(vec![
        object("floor", shapes::cube(2.0, 2), RigidTransform::IDENTITY),
        object(
            "box",
            shapes::cube(0.5, 1),
            RigidTransform::from_translation(Vec3::new(0.3, 0.2, 4.0)),
        ),
    ]);
    let options = CcdOptions::default();
    let floor = Sweep::new(&world, 0, EndPose::Stays, &options).unwrap();
    // The box's bottom (z = 3.5) falls to z = −0.5, crossing the floor's
    // top at z = 2 a three-eighths of the way (1.5 of 4).
    let end = RigidTransform::from_translation(Vec3::new(0.3, 0.2, 0.0));
    let falling = Sweep::new(&world, 1, EndPose::Moved(&end), &options).unwrap();
    let contacts = sweep_contacts(&floor, &falling, &options);
    assert!(!contacts.is_empty());
    let first = contacts[0].time;
    assert!(first <= 0.375 && first > 0.375 - 1e-5, "{first}");
    assert!(contacts.windows(2).all(|w| w[0].time <= w[1].time));
    // Reported pairs exist in both meshes; a box that stops short meets
    // nothing.
    assert!(contacts
        .iter()
        .all(|c| (c.contact.a.1 as usize) < scene.objects[0].mesh.triangle_count()));
    let short = RigidTransform::from_translation(Vec3::new(0.3, 0.2, 2.6));
    let stopping = Sweep::new(&world, 1, EndPose::Moved(&short), &options).unwrap();
    assert!(sweep_contacts(&floor, &stopping, &options).is_empty());
}

#[test]
fn swept_contacts_hold_every_sampled_contact_and_no_distant_pair() {
    let tilt = Quat::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 0.7);
    let start_b = RigidTransform::new(tilt, Vec3::new(3.0, 0.4, 0.2)).unwrap();
    let (scene, world) = world_of(vec![
        object("ball", shapes::icosphere(1.0, 1), RigidTransform::IDENTITY),
        object("ring", shapes::torus(0.9, 0.25, 12, 6), start_b),
    ]);
    let options = CcdOptions::default();
    // The ring passes through the ball while turning; the ball swells.
    let end_b = RigidTransform::new(
        Quat::from_rotation_z(1.2) * tilt,
        Vec3::new(-2.5, -0.3, 0.1),
    )
    .unwrap();
    let swollen = TriangleMesh::new(
        scene.objects[0]
            .mesh
            .positions()
            .iter()
            .map(|p| *p * 1.3)
            .collect(),
        scene.objects[0].mesh.triangles().to_vec(),
    )
    .unwrap();
    let id = RigidTransform::IDENTITY;
    let sa = Sweep::new(&world, 0, EndPose::Deformed(&swollen, &id), &options).unwrap();
    let sb = Sweep::new(&world, 1, EndPose::Moved(&end_b), &options).unwrap();
    let found: BTreeMap<(u32, u32), f64> = sweep_contacts(&sa, &sb, &options)
        .into_iter()
        .map(|c| ((c.contact.a.1, c.contact.b.1), c.time))
        .collect();
    let a = (placed(&scene.objects[0].mesh, &id), placed(&swollen, &id));
    let b = (
        placed(&scene.objects[1].mesh, &start_b),
        placed(&scene.objects[1].mesh, &end_b),
    );
    let sampled = sampled_contacts((&a.0, &a.1), (&b.0, &b.1), |_, _| false);
    assert!(sampled.len() > 20, "{} sampled contacts", sampled.len());
    assert_reported_in_time(&found, &sampled);
    for &(x, y) in found.keys() {
        let (x, y) = (x as usize, y as usize);
        let d = closest_approach((&a.0[x], &a.1[x]), (&b.0[y], &b.1[y]));
        // Between instants a pair moves at most about 0.1 m here.
        assert!(d < 0.1, "({x}, {y}) reported, closest {d}");
    }
}

#[test]
fn a_folded_sheet_passing_through_itself_meets_itself_and_a_still_one_does_not() {
    // A strip of 20 × 2 squares, x in [0, 2], whose far half (x > 1) is
    // folded back over the near half, hovering 5 cm above it, and drops to
    // 5 cm below it: each far triangle passes through the near ones under
    // it halfway through the step.
    let (n, w) = (20usize, 2usize);
    let triangles = common::grid_triangles(n, w);
    let sheet = |height: f32| {
        let mut positions = Vec::new();
        for j in 0..=w {
            for i in 0..=n {
                let (x, y) = (i as f32 * 0.1, j as f32 * 0.1);
                positions.push(if x <= 1.0 {
                    Vec3::new(x, y, 0.0)
                } else {
                    let r = x - 1.0;
                    Vec3::new(1.0 - 0.9 * r, y, height * (r / 0.1).min(1.0))
                });
            }
        }
        TriangleMesh::new(positions, triangles.clone()).unwrap()
    };
    let (above, below) = (sheet(0.05), sheet(-0.05));
    let (_, world) = world_of(vec![object(
        "sheet",
        above.clone(),
        RigidTransform::IDENTITY,
    )]);
    let options = CcdOptions::default();
    let id = RigidTransform::IDENTITY;
    let still = Sweep::new(&world, 0, EndPose::Stays, &options).unwrap();
    assert!(
        self_sweep_contacts(&still, &options).is_empty(),
        "neighbours touch only where they share corners"
    );
    let sweep = Sweep::new(&world, 0, EndPose::Deformed(&below, &id), &options).unwrap();
    let found: BTreeMap<(u32, u32), f64> = self_sweep_contacts(&sweep, &options)
        .into_iter()
        .map(|c| ((c.contact.a.1, c.contact.b.1), c.time))
        .collect();
    let (start, end) = (placed(&above, &id), placed(&below, &id));
    let share = |x: usize, y: usize| triangles[x].iter().any(|v| triangles[y].contains(v));
    let sampled = sampled_contacts((&start, &end), (&start, &end), |x, y| x >= y || share(x, y));
    assert!(sampled.len() > 20, "{} sampled contacts", sampled.len());
    assert_reported_in_time(&found, &sampled);
}
