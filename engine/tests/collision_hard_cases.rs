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
