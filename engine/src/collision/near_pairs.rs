//! A self-collision front kept down to the bounding-volume test tree's
//! true leaves, pairs of triangles (the dissertation's section 6.2.3 taken
//! below the trees' leaves): every pair of triangles sharing no vertex
//! whose boxes, each grown by its triangle's own reach, met when the list
//! was taken.
//!
//! A triangle's box moves no farther along an axis than its corners do. A
//! triangle that has moved no farther than its reach since the list was
//! taken is *held*; two held triangles whose boxes overlap now are on the
//! list. So a frame tests the list's pairs of held triangles, and asks the
//! tree for what the boxes of the few others overlap; the walk from the
//! root runs again only when too many have left their reach. Each
//! triangle's reach is what it moved per frame under the last list, times
//! [`SERVE_FRAMES`], up to its box's size: resting parts of a cloth list
//! only the pairs that touch, moving ones their neighbourhood.
//!
//! This is what makes a front pay on the CPU: the pair walk's last levels
//! hold nearly all its nodes, so a BVTT front of tree nodes saves little
//! of it, while the triangle pairs near each other (nine in ten of them
//! neighbours sharing a vertex, left out once, by index) change little
//! from frame to frame.

use glam::Vec3A;
use rayon::prelude::*;

use super::mesh_pairs::{distinct_and_touching, triangle_box};
use crate::bvh::traverse::front::par_leaf_pairs;
use crate::bvh::traverse::pair::{BoxVolumes, Leaf};
use crate::bvh::traverse::{Flow, OverlapTest};
use crate::bvh::MeshBvh;
use crate::deadline::Deadline;
use crate::geometry::{Aabb, TriangleMesh};
use crate::{Error, Result};

/// Frames a triangle's reach is sized to hold it at the speed it moved.
const SERVE_FRAMES: f32 = 4.0;

/// The list is taken again once more than one triangle in this many has
/// left its reach: each costs a query of the tree every frame.
const MOVED_SHARE: usize = 16;

/// Candidate pairs or triangles handled per task.
const CHUNK: usize = 4096;

/// The triangle pairs near each other in a mesh, kept between frames of
/// its self-collision ([`mesh_self_contacts`](super::mesh_self_contacts)).
#[derive(Clone, Debug, Default)]
pub struct NearPairs {
    /// Each mesh triangle's vertex indices: pairs sharing one never count.
    vertices: Vec<[u32; 3]>,
    /// Leaf slots `(x, y)` of the pairs, sharing no vertex, whose boxes
    /// grown by their reaches met when taken.
    pairs: Vec<(u32, u32)>,
    /// Per leaf slot, the triangle when taken and its reach.
    taken: Vec<[Vec3A; 3]>,
    reach: Vec<f32>,
    /// The tree's topology when taken.
    topology: u64,
    /// Frames answered since taken, the one it was taken in included.
    served: u32,
    /// Walks from the root so far.
    walks: u64,
}

impl NearPairs {
    /// An empty list for `mesh`'s triangles: the first frame walks.
    pub fn new(mesh: &TriangleMesh) -> Self {
        Self {
            vertices: mesh.triangles().to_vec(),
            ..Self::default()
        }
    }

    /// Pairs on the list.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// Walks from the root so far (the other frames used the list).
    pub fn walks(&self) -> u64 {
        self.walks
    }

    /// The leaf slots `(x, y)` of every pair of intersecting triangles of
    /// `mesh` that share no corner (as a walk from the root finds them, in
    /// no order), from the list while it still holds them.
    pub(crate) fn contact_slots(
        &mut self,
        mesh: &MeshBvh,
        stop: &Deadline,
    ) -> Result<Vec<(u32, u32)>> {
        if self.vertices.len() != mesh.triangle_count() {
            return Err(Error::TriangleCountMismatch {
                expected: self.vertices.len(),
                actual: mesh.triangle_count(),
            });
        }
        let tris = mesh.leaf_triangles();
        let scale = mesh
            .bounds()
            .min
            .abs()
            .max(mesh.bounds().max.abs())
            .max_element();
        let kept = self.topology == mesh.wide().topology && self.taken.len() == tris.len();
        let moved: Vec<f32> = if kept {
            moves(&self.taken, tris)
        } else {
            vec![f32::INFINITY; tris.len()]
        };
        let mut left: Vec<u32> = match kept {
            true => (0..tris.len() as u32)
                .filter(|&t| !holds(moved[t as usize], self.reach[t as usize], scale))
                .collect(),
            false => Vec::new(),
        };
        let boxes: Vec<Aabb> = tris
            .par_iter()
            .with_min_len(CHUNK)
            .map(triangle_box)
            .collect();
        if !kept || left.len() * MOVED_SHARE > tris.len() {
            self.take(mesh, &boxes, &moved, stop)?;
            left.clear();
        } else {
            self.served += 1;
        }
        let mut gone = vec![false; tris.len()];
        for &t in &left {
            gone[t as usize] = true;
        }
        let ids = mesh.prim_ids();
        let vertices = &self.vertices;
        let touching = |x: usize, y: usize| {
            let (tx, ty) = (&tris[x], &tris[y]);
            boxes[x].overlaps(&boxes[y]) && distinct_and_touching(tx, ty)
        };
        let listed = self.pairs.par_chunks(CHUNK).map(|chunk| {
            stop.check()?;
            Ok(chunk
                .iter()
                .filter(|&&(x, y)| !gone[x as usize] && !gone[y as usize])
                .filter(|&&(x, y)| touching(x as usize, y as usize))
                .copied()
                .collect::<Vec<_>>())
        });
        // What the boxes of the triangles out of reach overlap now: each
        // pair once (of two such triangles, from the lower slot).
        let queried = left.par_chunks(CHUNK / 64).map(|chunk| {
            stop.check()?;
            let mut out = Vec::new();
            for &x in chunk {
                let x = x as usize;
                let vx = &vertices[ids[x] as usize];
                mesh.wide()
                    .walk(&OverlapTest::new(boxes[x]), 0.0, |first, count, _| {
                        for y in first as usize..(first + count) as usize {
                            let other = !gone[y] || x < y;
                            if y != x
                                && other
                                && !vx.iter().any(|v| vertices[ids[y] as usize].contains(v))
                                && touching(x, y)
                            {
                                out.push((x as u32, y as u32));
                            }
                        }
                        Flow::Continue(())
                    });
            }
            Ok(out)
        });
        let found = listed.chain(queried).collect::<Result<Vec<_>>>()?;
        Ok(found.concat())
    }

    /// Takes the list afresh: each triangle's reach from how far it moved
    /// (`moved`) under the last list, then a walk from the root with every
    /// box of the tree grown by the largest.
    fn take(
        &mut self,
        mesh: &MeshBvh,
        boxes: &[Aabb],
        moved: &[f32],
        stop: &Deadline,
    ) -> Result<()> {
        let tris = mesh.leaf_triangles();
        let ids = mesh.prim_ids();
        let served = self.served.max(1) as f32;
        let reach: Vec<f32> = boxes
            .iter()
            .zip(moved)
            .map(|(b, &d)| match d.is_finite() {
                true => (SERVE_FRAMES * d / served).min(0.5 * (b.max - b.min).max_element()),
                // No list before, or a coordinate not finite: no reach.
                false => 0.0,
            })
            .collect();
        // Each box grown by its reach: two overlap where the triangles lay
        // within their two reaches. The tree is refitted over them, so the
        // walk meets just those leaves.
        let grown: Vec<Aabb> = boxes
            .iter()
            .zip(&reach)
            .map(|(b, &r)| Aabb::new(b.min - r, b.max + r))
            .collect();
        let mut tree = mesh.wide().clone();
        tree.refit(|first, count| {
            grown[first as usize..(first + count) as usize]
                .iter()
                .fold(Aabb::EMPTY, |u, b| u.union(*b))
        });
        let vertices = &self.vertices;
        let near = |x: usize, y: usize| {
            let (vx, vy) = (&vertices[ids[x] as usize], &vertices[ids[y] as usize]);
            grown[x].overlaps(&grown[y]) && !vx.iter().any(|v| vy.contains(v))
        };
        let volumes = BoxVolumes {
            a: &tree,
            b: &tree,
            b_to_a: None,
            margin: 0.0,
        };
        let pairs = par_leaf_pairs(&volumes, true, |la: Leaf, lb: Leaf, out| {
            if stop.expired().is_err() {
                return Flow::Break(());
            }
            for x in la.slots() {
                let ys = if la == lb {
                    x + 1..la.slots().end
                } else {
                    lb.slots()
                };
                for y in ys {
                    if near(x, y) {
                        out.push((x as u32, y as u32));
                    }
                }
            }
            Flow::Continue(())
        });
        stop.expired()?;
        *self = Self {
            vertices: std::mem::take(&mut self.vertices),
            pairs,
            taken: tris.to_vec(),
            reach,
            topology: mesh.wide().topology,
            served: 1,
            walks: self.walks + 1,
        };
        Ok(())
    }
}

/// Per triangle, the farthest any corner moved along any axis from `taken`
/// to `now` (infinite where a coordinate is not finite).
fn moves(taken: &[[Vec3A; 3]], now: &[[Vec3A; 3]]) -> Vec<f32> {
    taken
        .par_iter()
        .zip(now)
        .with_min_len(CHUNK)
        .map(|(t, n)| {
            let m = (t[0] - n[0])
                .abs()
                .max((t[1] - n[1]).abs())
                .max((t[2] - n[2]).abs());
            let m = m.max_element();
            if m.is_nan() {
                f32::INFINITY
            } else {
                m
            }
        })
        .collect()
}

/// Whether a triangle whose corners moved at most `moved` along each axis
/// is still within `reach`, in a mesh whose coordinates stay within
/// `scale`. Of two such triangles whose boxes overlap now, the boxes lay
/// at most both moves apart when taken, and the list's test `min - grow <=
/// max` and the moves' own subtractions each round by at most half an ulp
/// of the coordinates, which the slack covers. Not moved: the same box.
fn holds(moved: f32, reach: f32, scale: f32) -> bool {
    let slack = 4.0 * f32::EPSILON * (scale + 2.0 * reach);
    moved == 0.0 || moved * (1.0 + 4.0 * f32::EPSILON) + slack <= reach
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::bvh::BuildOptions;

    /// A flat triangle pointing right and moving right, and an upright one
    /// across its path moving left, at `speed` per frame each, `gap` apart
    /// at frame 0: the flat one's tip meets the other as soon as their
    /// boxes do.
    fn approaching(frame: f32, speed: f32, gap: f32) -> TriangleMesh {
        let (a, b) = (speed * frame, 1.0 + gap - speed * frame);
        TriangleMesh::new(
            vec![
                Vec3::new(a, 0.0, 0.0),
                Vec3::new(a, 1.0, 0.0),
                Vec3::new(a + 1.0, 0.5, 0.0),
                Vec3::new(b, 0.0, -0.5),
                Vec3::new(b, 1.0, -0.5),
                Vec3::new(b, 0.5, 0.5),
            ],
            vec![[0, 1, 2], [3, 4, 5]],
        )
        .unwrap()
    }

    fn sorted(pairs: Vec<(u32, u32)>) -> Vec<(u32, u32)> {
        let mut pairs: Vec<_> = pairs
            .into_iter()
            .map(|(x, y)| (x.min(y), x.max(y)))
            .collect();
        pairs.sort_unstable();
        pairs
    }

    /// Frame by frame the list answers what a walk from the root answers,
    /// while it is retaken only every several frames: a list kept while the
    /// corners moved up to twice their reach (the two triangles closing in
    /// from both sides) misses their first contacts.
    #[test]
    fn the_list_answers_as_the_walk_does_and_is_retaken_only_when_it_must_be() {
        let (speed, gap) = (0.01, 0.6);
        let first = approaching(0.0, speed, gap);
        let mut bvh = MeshBvh::build(&first, &BuildOptions::default());
        let mut near = NearPairs::new(&first);
        let mut contacts = 0;
        let frames = 60;
        for frame in 0..frames {
            let mesh = approaching(frame as f32, speed, gap);
            bvh.refit(&mesh).unwrap();
            let walked =
                super::super::mesh_pairs::self_contact_slots(&bvh, None, &Deadline::none())
                    .unwrap();
            let listed = near.contact_slots(&bvh, &Deadline::none()).unwrap();
            assert_eq!(sorted(listed), sorted(walked.clone()), "frame {frame}");
            contacts += walked.len();
        }
        assert!(contacts > 10, "{contacts}");
        // A reach of SERVE_FRAMES frames' motion holds that many frames.
        let most = frames as f32 / SERVE_FRAMES + 2.0;
        assert!(near.walks() as f32 <= most, "{} walks", near.walks());
    }

    /// Pairs sharing a vertex are never listed; a mesh of another size is
    /// refused.
    #[test]
    fn neighbours_are_left_out_and_another_mesh_is_refused() {
        let mesh = TriangleMesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap();
        let bvh = MeshBvh::build(&mesh, &BuildOptions::default());
        let mut near = NearPairs::new(&mesh);
        assert!(near
            .contact_slots(&bvh, &Deadline::none())
            .unwrap()
            .is_empty());
        assert!(near.is_empty());
        let other = approaching(0.0, 0.0, 0.1);
        let mut wrong = NearPairs::new(
            &TriangleMesh::new(other.positions().to_vec(), vec![[0, 1, 2]]).unwrap(),
        );
        let err = wrong.contact_slots(
            &MeshBvh::build(&other, &BuildOptions::default()),
            &Deadline::none(),
        );
        assert!(matches!(err, Err(Error::TriangleCountMismatch { .. })));
    }
}
