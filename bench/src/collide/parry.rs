//! The same discrete queries through `parry3d` (0.31, `parallel` feature),
//! as a parry user would put them together, since parry has no
//! triangle-pairs query of its own for meshes:
//!
//! - self: `TriMesh::set_vertices` (refit, one thread in parry 0.31), then
//!   `Bvh::traverse_bvtt_single_tree_parallel` (its parallel self-walk:
//!   leaf pairs whose boxes overlap), pairs sharing a vertex index dropped,
//!   and `query::intersection_test` (GJK) on each remaining pair of
//!   `Triangle`s, on every thread with rayon;
//! - pair: `Bvh::leaf_pairs` of the two meshes' trees with the second
//!   tree's boxes moved by the relative pose (`Aabb::transform_by`, as
//!   parry's own composite-shape queries do; one thread: it is an
//!   iterator), then `intersection_test(pos12, …)` on every thread.

use glam::{Quat, Vec3};
use parry3d::bounding_volume::BoundingVolume;
use parry3d::math::{Pose, Rotation, Vector};
use parry3d::query::intersection_test;
use parry3d::shape::{TriMesh, Triangle};
use rayon::prelude::*;

fn v(p: Vec3) -> Vector {
    Vector::new(p.x, p.y, p.z)
}

fn triangle(mesh: &TriMesh, t: u32) -> Triangle {
    let [a, b, c] = mesh.indices()[t as usize].map(|i| mesh.vertices()[i as usize]);
    Triangle::new(a, b, c)
}

/// Whether the triangles meet, `b` at `pos12` in `a`'s frame.
fn meet(pos12: &Pose, a: &Triangle, b: &Triangle) -> bool {
    intersection_test(&Pose::IDENTITY, a, pos12, b).is_ok_and(|r| r.intersecting)
}

/// A parry mesh from positions and triangles.
pub fn mesh(positions: &[Vec3], triangles: &[[u32; 3]]) -> TriMesh {
    TriMesh::new(
        positions.iter().map(|&p| v(p)).collect(),
        triangles.to_vec(),
    )
    .expect("parry3d rejected the mesh")
}

/// Moves the vertices and refits.
pub fn refit(mesh: &mut TriMesh, positions: &[Vec3]) {
    let moved: Vec<Vector> = positions.iter().map(|&p| v(p)).collect();
    mesh.set_vertices(&moved);
}

/// Intersecting pairs `(p, q)`, `p < q`, of triangles sharing no vertex,
/// sorted.
pub fn self_pairs(mesh: &TriMesh) -> Vec<(u32, u32)> {
    let candidates = mesh.bvh().traverse_bvtt_single_tree_parallel::<false>();
    let indices = mesh.indices();
    let mut pairs: Vec<(u32, u32)> = candidates
        .par_iter()
        .filter(|&&(p, q)| {
            let (a, b) = (indices[p as usize], indices[q as usize]);
            p != q && !a.iter().any(|i| b.contains(i))
        })
        .filter(|&&(p, q)| meet(&Pose::IDENTITY, &triangle(mesh, p), &triangle(mesh, q)))
        .map(|&(p, q)| (p.min(q), p.max(q)))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// Intersecting pairs `(of a, of b)` with `b` at `pose_b` relative to `a`,
/// sorted.
pub fn pairs(a: &TriMesh, b: &TriMesh, rotation: Quat, translation: Vec3) -> Vec<(u32, u32)> {
    let r = Rotation::from_xyzw(rotation.x, rotation.y, rotation.z, rotation.w);
    let pos12 = Pose::from_parts(v(translation), r);
    let candidates: Vec<(u32, u32)> = a
        .bvh()
        .leaf_pairs(b.bvh(), |n1, n2| {
            n1.aabb().intersects(&n2.aabb().transform_by(&pos12))
        })
        .collect();
    let mut pairs: Vec<(u32, u32)> = candidates
        .into_par_iter()
        .filter(|&(p, q)| meet(&pos12, &triangle(a, p), &triangle(b, q)))
        .collect();
    pairs.sort_unstable();
    pairs
}
