//! The compact tree's triangles: shared vertices, and corners as 16-bit
//! offsets from a base per block of triangles.
//!
//! A closed mesh has about half as many vertices as triangles, so a vertex
//! stored once (12 bytes) and three 16-bit corners (6 bytes) take about 12
//! bytes per triangle where a copy of the corners takes 48. Vertices are
//! stored in the order the triangles (in leaf order) first use them, so a
//! leaf's corners lie close together in memory, and corners that would
//! reach further back than 16 bits allow get a copy of their vertex
//! nearby. Vertices are welded by their exact bits (a mesh that repeats
//! positions along its seams shares them here), so every corner has the
//! bits of the mesh's own vertex and the watertight test answers as on the
//! plain layout.

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use crate::geometry::TriangleMesh;

/// Triangles per corner base.
const BLOCK: usize = 64;
/// How far back (in vertices) a block's base may lie below the next new
/// vertex: a block adds at most `3 * BLOCK` vertices, and every offset
/// must fit 16 bits.
const REACH: usize = u16::MAX as usize - 3 * BLOCK;

#[derive(Clone, Debug, Default)]
pub struct SharedCorners {
    vertices: Vec<[f32; 3]>,
    /// Per triangle slot, its corners' offsets from its block's base.
    corners: Vec<[u16; 3]>,
    /// Per block of [`BLOCK`] triangle slots, the vertices stored before
    /// it: the block's new vertices follow, in the order its corners first
    /// name them, and its offsets count from [`base`].
    starts: Vec<u32>,
}

/// The vertex a block's offsets count from.
#[inline(always)]
fn base(start: u32) -> usize {
    start as usize - (start as usize).min(REACH)
}

impl SharedCorners {
    /// The corners of mesh triangles `order[0], order[1], ...`, in that
    /// order.
    pub fn new(mesh: &TriangleMesh, order: &[u32]) -> Self {
        let weld = weld(mesh.positions());
        let positions = mesh.positions();
        let triangles = mesh.triangles();
        let mut latest = vec![u32::MAX; positions.len()];
        let mut out = Self {
            vertices: Vec::with_capacity(positions.len()),
            corners: Vec::with_capacity(order.len()),
            starts: Vec::with_capacity(order.len().div_ceil(BLOCK)),
        };
        for block in order.chunks(BLOCK) {
            let start = out.vertices.len() as u32;
            let base = base(start);
            out.starts.push(start);
            for &t in block {
                let corners = triangles[t as usize].map(|v| {
                    let w = weld[v as usize] as usize;
                    let mut at = latest[w] as usize;
                    if latest[w] == u32::MAX || at < base {
                        at = out.vertices.len();
                        assert!(
                            at < u32::MAX as usize,
                            "fewer than 2^32 - 1 stored vertices"
                        );
                        out.vertices.push(positions[v as usize].to_array());
                        latest[w] = at as u32;
                    }
                    (at - base) as u16
                });
                out.corners.push(corners);
            }
        }
        out.vertices.shrink_to_fit();
        out
    }

    pub fn len(&self) -> usize {
        self.corners.len()
    }

    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// The corners of triangle slot `slot`.
    #[inline(always)]
    pub fn corners(&self, slot: usize) -> [Vec3A; 3] {
        let base = base(self.starts[slot / BLOCK]);
        self.corners[slot].map(|c| Vec3A::from_array(self.vertices[base + c as usize]))
    }

    /// Takes the vertex positions of `mesh` (the mesh this was made from,
    /// moved). `false` when two mesh vertices welded here have parted:
    /// the triangles then need new corners.
    pub fn refit(&mut self, mesh: &TriangleMesh, order: &[u32]) -> bool {
        let positions = mesh.positions();
        let triangles = mesh.triangles();
        // Each block writes the vertices it added, found again as the
        // corners that name the next new one, in the order it added them.
        let mut rest = &mut self.vertices[..];
        let mut added = Vec::with_capacity(self.starts.len());
        for (b, &start) in self.starts.iter().enumerate() {
            let end = self
                .starts
                .get(b + 1)
                .map_or(rest.len() + start as usize, |&e| e as usize);
            let (mine, later) = rest.split_at_mut(end - start as usize);
            added.push(mine);
            rest = later;
        }
        let (corners, starts) = (&self.corners, &self.starts);
        added
            .into_par_iter()
            .zip(order.par_chunks(BLOCK))
            .enumerate()
            .with_min_len(64)
            .for_each(|(b, (mine, block))| {
                let (start, base) = (starts[b] as usize, base(starts[b]));
                let mut next = start;
                for (i, &t) in block.iter().enumerate() {
                    for (k, &c) in corners[b * BLOCK + i].iter().enumerate() {
                        if base + c as usize == next {
                            mine[next - start] =
                                positions[triangles[t as usize][k] as usize].to_array();
                            next += 1;
                        }
                    }
                }
            });
        let this = &*self;
        order
            .par_chunks(BLOCK)
            .enumerate()
            .with_min_len(64)
            .all(|(b, block)| {
                block.iter().enumerate().all(|(i, &t)| {
                    let ours = this.corners(b * BLOCK + i);
                    let theirs = triangles[t as usize].map(|v| Vec3A::from(positions[v as usize]));
                    same_bits(ours, theirs)
                })
            })
    }

    pub fn memory_bytes(&self) -> usize {
        self.vertices.capacity() * 12 + self.corners.capacity() * 6 + self.starts.capacity() * 4
    }
}

fn same_bits(a: [Vec3A; 3], b: [Vec3A; 3]) -> bool {
    (0..3).all(|k| (0..3).all(|axis| a[k][axis].to_bits() == b[k][axis].to_bits()))
}

/// Per vertex, the first vertex with the same bits.
fn weld(positions: &[Vec3]) -> Vec<u32> {
    let key = |v: u32| positions[v as usize].to_array().map(f32::to_bits);
    let mut sorted: Vec<u32> = (0..positions.len() as u32).collect();
    sorted.par_sort_unstable_by_key(|&v| (key(v), v));
    let mut weld = vec![0u32; positions.len()];
    for run in sorted.chunk_by(|&a, &b| key(a) == key(b)) {
        for &v in run {
            weld[v as usize] = run[0];
        }
    }
    weld
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shapes;

    #[test]
    fn corners_are_the_mesh_corners_bit_for_bit() {
        let mesh = shapes::icosphere(1.0, 3);
        let order: Vec<u32> = (0..mesh.triangle_count() as u32).rev().collect();
        let shared = SharedCorners::new(&mesh, &order);
        assert!(shared.vertex_count() <= mesh.positions().len());
        for (slot, &t) in order.iter().enumerate() {
            assert!(same_bits(shared.corners(slot), mesh.corners(t as usize)));
        }
    }

    #[test]
    fn seams_are_welded_and_far_corners_copied() {
        // Every triangle with its own three vertices, as a mesh split along
        // every edge for flat normals.
        // More welded vertices than 16 bits reach.
        let sphere = shapes::icosphere(1.0, 7);
        let split = shapes::unwelded(&sphere);
        // A scrambled order: neighbours far apart, so corners reach back.
        let n = split.triangle_count() as u32;
        let order: Vec<u32> = (0..n).map(|i| (i * 7919) % n).collect();
        let mut shared = SharedCorners::new(&split, &order);
        assert!(
            shared.vertex_count() > sphere.positions().len(),
            "no far copies"
        );
        // A scrambled order copies many, but welding still saves.
        assert!(shared.vertex_count() < split.positions().len());
        for (slot, &t) in order.iter().enumerate() {
            assert!(same_bits(shared.corners(slot), split.corners(t as usize)));
        }
        // A refit finds every copy again.
        let mut moved = split.clone();
        let scaled = split.positions().iter().map(|p| *p * 3.0 - Vec3::Y);
        moved.set_positions(scaled.collect()).unwrap();
        assert!(shared.refit(&moved, &order));
        for (slot, &t) in order.iter().enumerate() {
            assert!(same_bits(shared.corners(slot), moved.corners(t as usize)));
        }
    }

    #[test]
    fn refit_follows_the_mesh_and_notices_parted_welds() {
        let mesh = shapes::cube(1.0, 4);
        let order: Vec<u32> = (0..mesh.triangle_count() as u32).collect();
        let mut shared = SharedCorners::new(&mesh, &order);
        let mut moved = mesh.clone();
        let scaled: Vec<Vec3> = mesh
            .positions()
            .iter()
            .map(|p| *p * 2.0 + Vec3::X)
            .collect();
        moved.set_positions(scaled.clone()).unwrap();
        assert!(shared.refit(&moved, &order));
        for (slot, &t) in order.iter().enumerate() {
            assert!(same_bits(shared.corners(slot), moved.corners(t as usize)));
        }
        // Two copies of one position, then one of them moves.
        let mut positions = mesh.positions().to_vec();
        positions.push(positions[0]);
        let mut triangles = mesh.triangles().to_vec();
        let first = triangles.iter().position(|t| t.contains(&0)).unwrap();
        triangles[first] = triangles[first].map(|v| {
            if v == 0 {
                positions.len() as u32 - 1
            } else {
                v
            }
        });
        let twins = TriangleMesh::new(positions.clone(), triangles).unwrap();
        let mut shared = SharedCorners::new(&twins, &order);
        let mut parted = twins.clone();
        positions[0] += Vec3::splat(0.5);
        parted.set_positions(positions).unwrap();
        assert!(!shared.refit(&parted, &order));
    }
}
