//! The BVTT front, the near pairs kept below it and oriented boxes find
//! exactly the intersecting pairs that brute force finds (every pair of triangles, decided by the exact
//! predicate), frame after frame of deforming and moving meshes: a front
//! that failed to descend where volumes came to overlap, or an OBB fitted
//! or tested too tightly, would miss pairs here.

mod common;

use common::{grid_triangles, Rng};
use frusta_engine::bvh::obb::ObbTree;
use frusta_engine::bvh::traverse::front::Front;
use frusta_engine::bvh::{BuildOptions, MeshBvh};
use frusta_engine::collision::{
    mesh_contacts, mesh_self_contacts, triangles_intersect, NearPairs, Placed,
};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use glam::{DVec3, Quat, Vec3};

/// A sheet of `n` x `n` quads folded over itself by `fold` radians about
/// the line x = 0.5, rippled so the flap crosses the base along curves.
fn folded_sheet(n: usize, fold: f32, ripple: f32) -> TriangleMesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
            let z = ripple * (9.0 * u + 7.0 * v).sin();
            let p = if u <= 0.5 {
                Vec3::new(u, v, z)
            } else {
                let (d, (s, c)) = (u - 0.5, fold.sin_cos());
                Vec3::new(0.5 + d * c - z * s, v, d * s + z * c)
            };
            positions.push(p);
        }
    }
    let triangles = grid_triangles(n, n);
    TriangleMesh::new(positions, triangles).unwrap()
}

fn exact(mesh: &TriangleMesh, t: usize) -> [DVec3; 3] {
    mesh.corners(t).map(|p| Vec3::from(p).as_dvec3())
}

fn brute_self(mesh: &TriangleMesh) -> Vec<(u32, u32)> {
    let n = mesh.triangle_count();
    let mut pairs = Vec::new();
    for p in 0..n {
        let tp = exact(mesh, p);
        for q in p + 1..n {
            let tq = exact(mesh, q);
            if !tp.iter().any(|c| tq.contains(c)) && triangles_intersect(&tp, &tq) {
                pairs.push((p as u32, q as u32));
            }
        }
    }
    pairs
}

#[test]
fn self_contacts_from_near_pairs_and_with_obbs_match_brute_force_every_frame() {
    let options = BuildOptions::default();
    let mut mesh_bvh = MeshBvh::build(&folded_sheet(12, 2.0, 0.05), &options);
    let mut obbs = ObbTree::fit(&mesh_bvh);
    let mut near = NearPairs::new(&folded_sheet(12, 2.0, 0.05));
    let mut seen = 0;
    let frames = 16;
    for frame in 0..frames {
        let mesh = folded_sheet(12, 2.0 + 0.06 * frame as f32, 0.05);
        mesh_bvh.refit(&mesh).unwrap();
        obbs.refit(&mesh_bvh);
        let brute = brute_self(&mesh);
        seen += brute.len();
        let full = mesh_self_contacts(&mesh_bvh, None, None).unwrap();
        assert_eq!(full, brute, "frame {frame}: full walk");
        let oriented = mesh_self_contacts(&mesh_bvh, Some(&obbs), None).unwrap();
        assert_eq!(oriented, brute, "frame {frame}: OBBs");
        let listed = mesh_self_contacts(&mesh_bvh, None, Some(&mut near)).unwrap();
        assert_eq!(listed, brute, "frame {frame}: near pairs");
    }
    // The flap passes through the base in the later frames, and the near
    // pairs answered some frames without a walk (the flap's tip moves about
    // a third of a triangle a frame, so the list lasts about two).
    assert!(seen > 50, "{seen} contacts over all frames");
    assert!(near.walks() < frames, "{} walks", near.walks());
}

/// A soup of small triangles in a unit cube.
fn soup(rng: &mut Rng, n: usize) -> TriangleMesh {
    let mut positions = Vec::new();
    for _ in 0..n {
        let a = Vec3::new(rng.f32(), rng.f32(), rng.f32());
        positions.push(a);
        positions.push(a + rng.direction() * 0.15);
        positions.push(a + rng.direction() * 0.15);
    }
    let triangles = (0..n as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    TriangleMesh::new(positions, triangles).unwrap()
}

#[test]
fn moving_pairs_from_a_front_and_with_obbs_match_brute_force_every_frame() {
    let mut rng = Rng(17);
    let options = BuildOptions::default();
    let (ma, mb) = (soup(&mut rng, 300), soup(&mut rng, 300));
    let (ba, bb) = (MeshBvh::build(&ma, &options), MeshBvh::build(&mb, &options));
    let (oa, ob) = (ObbTree::fit(&ba), ObbTree::fit(&bb));
    let at_a = RigidTransform::new(Quat::from_rotation_z(0.3), Vec3::new(0.1, 0.0, 0.0)).unwrap();
    let (mut box_front, mut obb_front) = (Front::new(), Front::new());
    let mut seen = 0;
    for frame in 0..10 {
        // b sweeps through a, turning as it goes.
        let f = frame as f32;
        let rotation = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.2 * f);
        let at_b = RigidTransform::new(rotation, Vec3::new(-1.2 + 0.3 * f, 0.2, 0.0)).unwrap();
        let world = |m: &TriangleMesh, at: &RigidTransform, t: usize| {
            let q = at.rotation.as_dquat();
            exact(m, t).map(|p| q * p + at.translation.as_dvec3())
        };
        let mut brute = Vec::new();
        for p in 0..300 {
            let tp = world(&ma, &at_a, p);
            for q in 0..300 {
                if triangles_intersect(&tp, &world(&mb, &at_b, q)) {
                    brute.push((p as u32, q as u32));
                }
            }
        }
        seen += brute.len();
        let place = |mesh, to_world, obbs| Placed {
            mesh,
            to_world,
            obbs,
        };
        let full = mesh_contacts(place(&ba, &at_a, None), place(&bb, &at_b, None), None).unwrap();
        assert_eq!(full, brute, "frame {frame}: full walk");
        let front = mesh_contacts(
            place(&ba, &at_a, None),
            place(&bb, &at_b, None),
            Some(&mut box_front),
        )
        .unwrap();
        assert_eq!(front, brute, "frame {frame}: box front");
        let oriented = mesh_contacts(
            place(&ba, &at_a, Some(&oa)),
            place(&bb, &at_b, Some(&ob)),
            Some(&mut obb_front),
        )
        .unwrap();
        assert_eq!(oriented, brute, "frame {frame}: OBB front");
    }
    assert!(seen > 100, "{seen} contacts over all frames");
}

#[test]
fn near_pairs_survive_a_rebuild_and_stale_obb_trees_are_refused() {
    let options = BuildOptions::default();
    let mesh = folded_sheet(8, 3.3, 0.05);
    let mut bvh = MeshBvh::build(&mesh, &options);
    let mut near = NearPairs::new(&mesh);
    let before = mesh_self_contacts(&bvh, None, Some(&mut near)).unwrap();
    assert!(!before.is_empty());
    // A rebuild changes the topology (and the leaf order) the list was
    // made on: it is taken again.
    let other = folded_sheet(8, 3.0, 0.05);
    bvh = MeshBvh::build(&other, &options);
    let after = mesh_self_contacts(&bvh, None, Some(&mut near)).unwrap();
    assert_eq!(near.walks(), 2);
    assert_eq!(after, brute_self(&other));
    let stale = ObbTree::fit(&MeshBvh::build(&mesh, &options));
    assert!(mesh_self_contacts(&bvh, Some(&stale), None).is_err());
    // Boxes fitted before the mesh moved are refused too, until refitted.
    let mut obbs = ObbTree::fit(&bvh);
    bvh.refit(&folded_sheet(8, 3.2, 0.05)).unwrap();
    assert!(mesh_self_contacts(&bvh, Some(&obbs), None).is_err());
    obbs.refit(&bvh);
    assert!(mesh_self_contacts(&bvh, Some(&obbs), None).is_ok());
}
