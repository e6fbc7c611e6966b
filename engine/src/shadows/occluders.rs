//! The world's triangles as the rasterisers see them: corners in world
//! space in `f64`, and the edges between triangles welded by corner
//! position.
//!
//! Corners come from the traced trees themselves ([`MeshBvh`]'s leaf
//! copies), so rasters and rays see the same numbers. Welding by the exact
//! bits of a corner is what the watertight ray test needs: a ray through an
//! edge shared by two triangles with identical corner values hits one of
//! them, so two such triangles that face the same way cover the edge
//! between them with no gap.

use std::collections::HashMap;

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use crate::bvh::{Instance, SceneBvh};
use crate::collision::world_corners;

/// No triangle on that side of an edge.
pub(super) const NONE: u32 = u32::MAX;

/// An edge between triangles `tris[0]` and `tris[1]` (or a boundary edge,
/// `tris[1] == NONE`), its ends in world space.
#[derive(Clone, Copy, Debug)]
pub(super) struct Edge {
    pub ends: [DVec3; 2],
    pub tris: [u32; 2],
}

/// A connected surface of an object: triangles joined by shared edges.
/// The light map's proofs hold per part, so a seat proves the floor under
/// it shadowed though both are one mesh.
pub(super) struct Part {
    /// Scene-wide number of the part.
    pub id: u32,
    /// Range of [`ObjectTopology::by_part`] holding its triangles.
    pub tris: std::ops::Range<usize>,
    /// Range of [`ObjectTopology::edges`] holding its edges.
    pub edges: std::ops::Range<usize>,
}

/// One object's triangles.
pub(super) struct ObjectOccluders {
    /// World corners in leaf order.
    pub tris: Vec<[DVec3; 3]>,
    /// Mesh triangle index of each entry of `tris`.
    pub mesh_triangle: Vec<u32>,
    /// Largest coordinate magnitude in object and world frames: the scale
    /// of the `f32` rounding a ray in this object suffers.
    pub scale: f64,
}

/// How one object's triangles join: what the light map's proofs need
/// beyond the triangles.
pub(super) struct ObjectTopology {
    /// Edges between two triangles that share two corners with opposite
    /// directions (a consistently wound manifold edge), and every other
    /// edge as a boundary: non-manifold and inconsistently wound edges can
    /// leave gaps, so they are treated as if nothing were across.
    pub edges: Vec<Edge>,
    /// Triangle slots grouped by part.
    pub by_part: Vec<u32>,
    pub parts: Vec<Part>,
    /// Scene-wide part of each triangle.
    pub part: Vec<u32>,
    /// The three [`Self::edges`] of each triangle slot ([`NONE`] for a
    /// zero-area triangle, which has none).
    pub edges_of: Vec<[u32; 3]>,
}

/// Every object of a world.
pub(super) struct Occluders {
    pub objects: Vec<ObjectOccluders>,
    /// Largest coordinate magnitude of any object.
    pub scale: f64,
}

impl Occluders {
    pub fn of(world: &SceneBvh) -> Self {
        let objects: Vec<ObjectOccluders> = world
            .instances()
            .par_iter()
            .map(ObjectOccluders::of)
            .collect();
        let scale = objects.iter().map(|o| o.scale).fold(0.0, f64::max);
        Self { objects, scale }
    }
}

/// Every object's topology, parts numbered over the scene.
pub(super) struct Topology {
    pub objects: Vec<ObjectTopology>,
}

impl Topology {
    pub fn of(world: &SceneBvh, occluders: &Occluders) -> Self {
        let mut objects: Vec<ObjectTopology> = world
            .instances()
            .par_iter()
            .zip(&occluders.objects)
            .map(|(inst, o)| ObjectTopology::of(inst.bvh().leaf_triangles(), &o.tris))
            .collect();
        let mut next = 0;
        for o in &mut objects {
            for p in &mut o.parts {
                p.id += next;
            }
            for p in &mut o.part {
                *p += next;
            }
            next += o.parts.len() as u32;
        }
        Self { objects }
    }
}

/// The bits of a corner, with -0.0 as 0.0 (equal values weld).
fn key(v: Vec3A) -> [u32; 3] {
    let bits = |x: f32| if x == 0.0 { 0 } else { x.to_bits() };
    [bits(v.x), bits(v.y), bits(v.z)]
}

impl ObjectOccluders {
    fn of(inst: &Instance) -> Self {
        let bvh = inst.bvh();
        let leaf = bvh.leaf_triangles();
        let tris: Vec<[DVec3; 3]> = leaf.iter().map(world_corners(inst.to_world())).collect();
        let mut scale = inst.to_world().translation.abs().max_element() as f64;
        for (c, w) in leaf.iter().zip(&tris) {
            for i in 0..3 {
                scale = scale
                    .max(c[i].abs().max_element() as f64)
                    .max(w[i].abs().max_element());
            }
        }
        Self {
            tris,
            mesh_triangle: bvh.prim_ids().to_vec(),
            scale,
        }
    }
}

impl ObjectTopology {
    fn of(leaf: &[[Vec3A; 3]], tris: &[[DVec3; 3]]) -> Self {
        let mut edges = welded_edges(leaf, tris);
        let part = components(tris.len(), &edges);
        edges.sort_unstable_by_key(|e| part[e.tris[0] as usize]);
        let mut by_part: Vec<u32> = (0..tris.len() as u32).collect();
        by_part.sort_unstable_by_key(|&t| part[t as usize]);
        let count = part.iter().map(|&p| p + 1).max().unwrap_or(0) as usize;
        let tri_ranges = ranges(by_part.iter().map(|&t| part[t as usize]), count);
        let edge_ranges = ranges(edges.iter().map(|e| part[e.tris[0] as usize]), count);
        let parts = tri_ranges
            .into_iter()
            .zip(edge_ranges)
            .enumerate()
            .map(|(id, (tris, edges))| Part {
                id: id as u32,
                tris,
                edges,
            })
            .collect();
        let mut edges_of = vec![[NONE; 3]; tris.len()];
        for (i, e) in edges.iter().enumerate() {
            for &t in e.tris.iter().filter(|&&t| t != NONE) {
                if let Some(free) = edges_of[t as usize].iter_mut().find(|e| **e == NONE) {
                    *free = i as u32;
                }
            }
        }
        Self {
            edges,
            by_part,
            parts,
            part,
            edges_of,
        }
    }
}

/// For sorted `keys` below `count`, the range of positions holding each.
fn ranges(keys: impl Iterator<Item = u32>, count: usize) -> Vec<std::ops::Range<usize>> {
    let mut out = vec![0..0; count];
    for (i, k) in keys.enumerate() {
        let r = &mut out[k as usize];
        if r.start == r.end {
            *r = i..i + 1;
        } else {
            r.end = i + 1;
        }
    }
    out
}

/// The part of each triangle: components joined by shared edges, numbered
/// from 0 in order of their first triangle.
fn components(n: usize, edges: &[Edge]) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            let up = parent[parent[i as usize] as usize];
            parent[i as usize] = up;
            i = up;
        }
        i
    }
    for e in edges.iter().filter(|e| e.tris[1] != NONE) {
        let (a, b) = (root(&mut parent, e.tris[0]), root(&mut parent, e.tris[1]));
        parent[a.max(b) as usize] = a.min(b);
    }
    let mut number = vec![NONE; n];
    let mut next = 0;
    (0..n as u32)
        .map(|t| {
            let r = root(&mut parent, t) as usize;
            if number[r] == NONE {
                number[r] = next;
                next += 1;
            }
            number[r]
        })
        .collect()
}

/// A directed edge of triangle `tri` between welded vertices.
struct HalfEdge {
    lo: u32,
    hi: u32,
    /// Whether the triangle runs from `lo` to `hi`.
    forward: bool,
    tri: u32,
}

fn welded_edges(leaf: &[[Vec3A; 3]], tris: &[[DVec3; 3]]) -> Vec<Edge> {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(leaf.len());
    let mut ends: Vec<DVec3> = Vec::new();
    let mut half = Vec::with_capacity(leaf.len() * 3);
    for (t, (c, w)) in leaf.iter().zip(tris).enumerate() {
        // Zero-area triangles are never hit; their neighbours see a
        // boundary there.
        if (c[1] - c[0]).cross(c[2] - c[0]) == Vec3A::ZERO
            && (w[1] - w[0]).cross(w[2] - w[0]) == DVec3::ZERO
        {
            continue;
        }
        let v: [u32; 3] = std::array::from_fn(|i| {
            let next = ends.len() as u32;
            *ids.entry(key(c[i])).or_insert_with(|| {
                ends.push(w[i]);
                next
            })
        });
        if v[0] == v[1] || v[1] == v[2] || v[2] == v[0] {
            continue;
        }
        for i in 0..3 {
            let (a, b) = (v[i], v[(i + 1) % 3]);
            half.push(HalfEdge {
                lo: a.min(b),
                hi: a.max(b),
                forward: a < b,
                tri: t as u32,
            });
        }
    }
    half.sort_unstable_by_key(|h| (h.lo, h.hi, h.tri));
    let mut edges = Vec::with_capacity(half.len() / 2 + 1);
    for group in half.chunk_by(|a, b| (a.lo, a.hi) == (b.lo, b.hi)) {
        let at = [ends[group[0].lo as usize], ends[group[0].hi as usize]];
        if let [a, b] = group {
            if a.forward != b.forward {
                edges.push(Edge {
                    ends: at,
                    tris: [a.tri, b.tri],
                });
                continue;
            }
        }
        edges.extend(group.iter().map(|h| Edge {
            ends: at,
            tris: [h.tri, NONE],
        }));
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::geometry::shapes::cube;
    use crate::scene::{Material, RawMesh, Scene};

    fn topology(world: &SceneBvh) -> Topology {
        Topology::of(world, &Occluders::of(world))
    }

    fn world_of(positions: Vec<glam::Vec3>, triangles: Vec<[u32; 3]>) -> SceneBvh {
        let raw = RawMesh {
            positions,
            triangles,
            ..RawMesh::default()
        };
        let scene = Scene::single_object("o", raw, Material::uniform("m", 0.1).unwrap()).unwrap();
        SceneBvh::build(&scene, &BuildOptions::default())
    }

    #[test]
    fn a_closed_cube_has_only_shared_edges() {
        let c = cube(1.0, 2);
        let world = world_of(c.positions().to_vec(), c.triangles().to_vec());
        let o = &topology(&world).objects[0];
        assert_eq!(o.edges.len(), c.triangle_count() * 3 / 2);
        assert!(o.edges.iter().all(|e| e.tris[1] != NONE));
        assert_eq!(o.parts.len(), 1);
        for (t, edges) in o.edges_of.iter().enumerate() {
            for &e in edges {
                assert!(o.edges[e as usize].tris.contains(&(t as u32)));
            }
        }
    }

    #[test]
    fn parts_are_the_edge_connected_pieces() {
        let c = cube(1.0, 1);
        let mut positions = c.positions().to_vec();
        let mut triangles = c.triangles().to_vec();
        let n = positions.len() as u32;
        positions.extend(c.positions().iter().map(|p| *p + glam::Vec3::X * 3.0));
        triangles.extend(c.triangles().iter().map(|t| t.map(|i| i + n)));
        let world = world_of(positions, triangles);
        let o = &topology(&world).objects[0];
        assert_eq!(o.parts.len(), 2);
        for p in &o.parts {
            assert_eq!(p.tris.len(), 12);
            assert_eq!(p.edges.len(), 18);
            for &t in &o.by_part[p.tris.clone()] {
                assert_eq!(o.part[t as usize], p.id);
            }
            for e in &o.edges[p.edges.clone()] {
                assert_eq!(o.part[e.tris[0] as usize], p.id);
            }
        }
    }

    #[test]
    fn unwelded_copies_weld_and_flipped_neighbours_do_not() {
        use glam::Vec3;
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
        // Two triangles over the same edge, unwelded (corners repeated).
        let positions = vec![p[0], p[1], p[2], p[1], p[3], p[2]];
        let world = world_of(positions.clone(), vec![[0, 1, 2], [3, 4, 5]]);
        let o = &topology(&world).objects[0];
        assert_eq!(o.edges.iter().filter(|e| e.tris[1] != NONE).count(), 1);
        // The second wound the other way: the edge runs the same way in
        // both, so it is a boundary on each side.
        let world = world_of(positions, vec![[0, 1, 2], [3, 5, 4]]);
        let o = &topology(&world).objects[0];
        assert!(o.edges.iter().all(|e| e.tris[1] == NONE));
        assert_eq!(o.edges.len(), 6);
    }
}
