//! Discrete collision's hard cases, each with an answer known from the
//! geometry: coplanar overlap and touch, a shared vertex or edge, slivers,
//! identical triangles, a closed mesh moved by one ulp against a copy of
//! itself, and the same at scales 1e-3 and 1e4.

use frusta_engine::bvh::{BuildOptions, MeshBvh};
use frusta_engine::collision::{mesh_contacts, triangles_intersect, Placed};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use glam::{DVec3, Vec3};

fn d(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

/// Both orders, since the test is asymmetric inside.
fn meet(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    let (ab, ba) = (triangles_intersect(&a, &b), triangles_intersect(&b, &a));
    assert_eq!(ab, ba, "{a:?} {b:?}");
    ab
}

#[test]
fn coplanar_triangles_meet_when_they_overlap_or_touch_and_not_a_hair_apart() {
    let t = [d(0.0, 0.0, 0.0), d(2.0, 0.0, 0.0), d(0.0, 2.0, 0.0)];
    assert!(meet(
        t,
        [d(0.5, 0.5, 0.0), d(3.0, 0.5, 0.0), d(0.5, 3.0, 0.0)]
    ));
    // Inside, no edge crossing.
    assert!(meet(
        t,
        [d(0.2, 0.2, 0.0), d(0.6, 0.2, 0.0), d(0.2, 0.6, 0.0)]
    ));
    // Touching the hypotenuse at one point, and along part of it.
    assert!(meet(
        t,
        [d(1.0, 1.0, 0.0), d(2.0, 2.0, 0.0), d(3.0, 1.0, 0.0)]
    ));
    assert!(meet(
        t,
        [d(1.5, 0.5, 0.0), d(0.5, 1.5, 0.0), d(2.0, 2.0, 0.0)]
    ));
    // The same, a hair beyond the hypotenuse (x + y = 2 + 2^-50).
    let e = 2f64.powi(-51);
    assert!(!meet(
        t,
        [d(1.0 + e, 1.0 + e, 0.0), d(2.0, 2.0, 0.0), d(3.0, 1.0, 0.0)]
    ));
}

#[test]
fn triangles_sharing_a_vertex_or_an_edge_meet() {
    let t = [d(0.0, 0.0, 0.0), d(1.0, 0.0, 0.0), d(0.0, 1.0, 0.0)];
    assert!(meet(
        t,
        [d(0.0, 0.0, 0.0), d(-1.0, 0.0, 1.0), d(0.0, -1.0, 1.0)]
    ));
    assert!(meet(
        t,
        [d(1.0, 0.0, 0.0), d(0.0, 1.0, 0.0), d(1.0, 1.0, -1.0)]
    ));
    // The vertex moved off by one ulp of 1: apart.
    let off = [
        d(0.0, 0.0, f64::EPSILON),
        d(-1.0, 0.0, 1.0),
        d(0.0, -1.0, 1.0),
    ];
    assert!(!meet(t, off));
}

#[test]
fn slivers_meet_where_their_segment_does() {
    let t = [d(0.0, 0.0, 0.0), d(1.0, 0.0, 0.0), d(0.0, 1.0, 0.0)];
    // Area about 1e-17: a needle through the face, and one beside it.
    let needle = |x: f64| [d(x, 0.2, -1.0), d(x, 0.2, 1.0), d(x + 1e-17, 0.2, 0.0)];
    assert!(meet(t, needle(0.3)));
    assert!(!meet(t, needle(0.9)));
    // A sliver lying in the face's plane across its edge.
    let flat = [
        d(-0.5, 0.25, 0.0),
        d(0.5, 0.25, 0.0),
        d(0.0, 0.25 + 1e-16, 0.0),
    ];
    assert!(meet(t, flat));
}

#[test]
fn identical_triangles_meet() {
    let t = [d(0.3, -2.0, 7.0), d(1.0, 5.0, -1.0), d(-4.0, 0.5, 2.5)];
    assert!(meet(t, t));
}

/// The unit cube's twelve triangles, scaled.
fn cube(scale: f32, shift_x: impl Fn(f32) -> f32) -> TriangleMesh {
    let positions = (0..8)
        .map(|i| {
            let c = Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) * scale;
            Vec3::new(shift_x(c.x), c.y, c.z)
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, e]| [[a, b, c], [a, c, e]])
        .collect();
    TriangleMesh::new(positions, triangles).unwrap()
}

/// Which faces of the cube (by normal axis and side) meet which faces of
/// its copy moved along +x by one ulp of every coordinate.
fn face_contacts(scale: f32) -> Vec<(u32, u32)> {
    let options = BuildOptions::default();
    let a = MeshBvh::build(&cube(scale, |x| x), &options);
    // The next float up (coordinates here are 0 or positive).
    let next_up = |x: f32| f32::from_bits(x.to_bits() + 1);
    let b = MeshBvh::build(&cube(scale, next_up), &options);
    let at = RigidTransform::default();
    let place = |mesh| Placed {
        mesh,
        to_world: &at,
        obbs: None,
    };
    let mut faces: Vec<(u32, u32)> = mesh_contacts(place(&a), place(&b), None)
        .unwrap()
        .into_iter()
        .map(|(p, q)| (p / 2, q / 2))
        .collect();
    faces.dedup();
    faces
}

#[test]
fn a_cube_moved_by_one_ulp_meets_its_copy_where_the_geometry_says_at_every_scale() {
    // Faces: 0 z=0, 1 z=1, 2 y=0, 3 y=1, 4 x=0, 5 x=1.
    let contacts = face_contacts(1.0);
    // The four faces along x stay coplanar and overlapping with their own
    // copies, and touch their neighbours along shared edges.
    for f in 0..4 {
        assert!(contacts.contains(&(f, f)), "{f} {contacts:?}");
    }
    // The copy's x = ulp face lies inside the cube, across the faces
    // along x; the copy's x = 1 + ulp face lies outside, beyond everything
    // but its own edges' reach, which is none: 1 + ulp is past x = 1.
    for f in 0..4 {
        assert!(contacts.contains(&(f, 4)), "{f} {contacts:?}");
        assert!(!contacts.contains(&(f, 5)), "{f} {contacts:?}");
    }
    // The parallel end faces, one ulp apart, do not meet.
    assert!(!contacts.contains(&(4, 4)) && !contacts.contains(&(5, 5)));
    // The original's x = 1 face meets the copy's faces along x, whose
    // edges cross x = 1; and the copy's x = ulp face is parallel to it.
    for f in 0..4 {
        assert!(contacts.contains(&(5, f)), "{f} {contacts:?}");
    }
    assert!(!contacts.contains(&(5, 4)) && !contacts.contains(&(4, 5)));
    // The same faces at a thousandth and ten thousand times the size.
    assert_eq!(face_contacts(1e-3), contacts);
    assert_eq!(face_contacts(1e4), contacts);
}

/// Objects far from the origin and turned: `b`'s motion into `a`'s frame
/// is composed in f32, whose rounding there (about a millimetre at 1e4 m)
/// must not make the broad phase miss triangles that meet, barely, in the
/// world (decided in f64 on each object's own world transform).
#[test]
fn barely_touching_triangles_far_from_the_origin_are_found() {
    use glam::Quat;
    let mut missed = 0;
    let mut seen = 0;
    for k in 0..200u32 {
        let f = k as f32;
        let far = Vec3::new(1e4 + 37.0 * f, -2e4 + 11.0 * f, 5e3);
        let turn =
            |s: f32| Quat::from_axis_angle(Vec3::new(0.3, 1.0, -0.4 + s).normalize(), 0.5 + s);
        let at_a = RigidTransform::new(turn(0.01 * f), far).unwrap();
        let at_b =
            RigidTransform::new(turn(0.7 + 0.013 * f), far + Vec3::new(0.3, -0.2, 0.1)).unwrap();
        // A triangle of a, in its frame, and one of b (placed through the
        // world in f64) whose tip pokes through it from above by 0.1 mm,
        // less than the f32 rounding of the composed motion.
        let tri_a = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let into_b = |p: Vec3| {
            let (qa, qb) = (at_a.rotation.as_dquat(), at_b.rotation.as_dquat());
            let world = qa * p.as_dvec3() + at_a.translation.as_dvec3();
            (qb.inverse() * (world - at_b.translation.as_dvec3())).as_vec3()
        };
        let tri_b = [
            into_b(Vec3::new(0.3, 0.3, -1e-4)),
            into_b(Vec3::new(0.3, 0.6, 0.5)),
            into_b(Vec3::new(0.6, 0.3, 0.5)),
        ];
        let mesh = |t: [Vec3; 3]| TriangleMesh::new(t.to_vec(), vec![[0, 1, 2]]).unwrap();
        let options = BuildOptions::default();
        let (a, b) = (
            MeshBvh::build(&mesh(tri_a), &options),
            MeshBvh::build(&mesh(tri_b), &options),
        );
        let world = |t: [Vec3; 3], at: &RigidTransform| {
            let q = at.rotation.as_dquat();
            t.map(|p| q * p.as_dvec3() + at.translation.as_dvec3())
        };
        if !triangles_intersect(&world(tri_a, &at_a), &world(tri_b, &at_b)) {
            continue;
        }
        seen += 1;
        let placed = |mesh, to_world| Placed {
            mesh,
            to_world,
            obbs: None,
        };
        if mesh_contacts(placed(&a, &at_a), placed(&b, &at_b), None)
            .unwrap()
            .is_empty()
        {
            missed += 1;
        }
    }
    assert!(seen > 100, "{seen}");
    assert_eq!(missed, 0, "missed {missed} of {seen}");
}
