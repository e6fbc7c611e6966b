//! A self-collision front kept down to the bounding-volume test tree's
//! true leaves, pairs of triangles (the dissertation's section 6.2.3 taken
//! below the trees' leaves): every pair of triangles sharing no vertex
//! whose boxes, each grown by its triangle's own reach around where the
//! triangle was when last taken, meet.
//!
//! A triangle's box moves no farther along an axis than its corners do. A
//! triangle that has moved no farther than its reach since it was taken
//! is *held*; two held triangles whose boxes overlap now are on the list.
//! A triangle that leaves its reach is taken again alone: where it is
//! now, a reach from how fast it moved, and its pairs from a query of the
//! tree refitted on the grown boxes, in place of its old ones. So every
//! triangle is held when a frame tests the list's pairs, and the walk from
//! the root runs again only when the tree's topology changes, more than
//! one triangle in [`RETAKE_SHARE`] leaves at once, or a retake was cut
//! short by the deadline. Each triangle's reach
//! is what it moved per frame since it was taken, times [`SERVE_FRAMES`],
//! up to half its box's size: resting parts of a cloth list only the
//! pairs that touch, moving ones their neighbourhood.
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
use crate::bvh::wide::Bvh4;
use crate::bvh::MeshBvh;
use crate::deadline::Deadline;
use crate::geometry::{Aabb, TriangleMesh};
use crate::{Error, Result};

/// Frames a triangle's reach is sized to hold it at the speed it moved.
const SERVE_FRAMES: f32 = 4.0;

/// The whole list is taken again, by a walk from the root, once more than
/// one triangle in this many leaves its reach in one frame: each costs a
/// query of the tree, and on the 50k cloth a walk (10-17 ms) cost about
/// as much as queries (about 1 µs each) for a quarter of the triangles.
const RETAKE_SHARE: usize = 4;

/// Candidate pairs or triangles handled per task.
const CHUNK: usize = 4096;

/// The triangle pairs near each other in a mesh, kept between frames of
/// its self-collision ([`mesh_self_contacts`](super::mesh_self_contacts)).
#[derive(Clone, Debug, Default)]
pub struct NearPairs {
    /// Each mesh triangle's vertex indices: pairs sharing one never count.
    vertices: Vec<[u32; 3]>,
    /// Leaf slots `(x, y)` of the pairs, sharing no vertex, whose grown
    /// boxes meet.
    pairs: Vec<(u32, u32)>,
    /// Per leaf slot, the triangle when taken, its reach, its box grown by
    /// the reach, and the frames since it was taken.
    taken: Vec<[Vec3A; 3]>,
    reach: Vec<f32>,
    grown: Vec<Aabb>,
    age: Vec<u32>,
    /// The mesh's tree refitted on the grown boxes.
    grown_tree: Bvh4,
    /// The tree's topology when taken.
    topology: u64,
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
        let boxes: Vec<Aabb> = tris
            .par_iter()
            .with_min_len(CHUNK)
            .map(triangle_box)
            .collect();
        let left: Vec<u32> = match kept {
            true => {
                self.age.par_iter_mut().for_each(|a| *a += 1);
                (0..tris.len() as u32)
                    .filter(|&t| !holds(moved[t as usize], self.reach[t as usize], scale))
                    .collect()
            }
            false => Vec::new(),
        };
        if !kept || left.len() * RETAKE_SHARE > tris.len() {
            self.take(mesh, &boxes, &moved, stop)?;
        } else if !left.is_empty() {
            self.retake(mesh, &left, &boxes, &moved, stop)?;
        }
        let touching = |&(x, y): &(u32, u32)| {
            let (x, y) = (x as usize, y as usize);
            boxes[x].overlaps(&boxes[y]) && distinct_and_touching(&tris[x], &tris[y])
        };
        let found = self
            .pairs
            .par_chunks(CHUNK)
            .map(|chunk| {
                stop.check()?;
                Ok(chunk.iter().filter(|p| touching(p)).copied().collect())
            })
            .collect::<Result<Vec<Vec<_>>>>()?;
        Ok(found.concat())
    }

    /// A triangle's reach, from how far it moved (`moved`) in the `age`
    /// frames since it was last taken: [`SERVE_FRAMES`] frames' worth of
    /// its speed, at most half its box now (`now`).
    fn reach_of(now: &Aabb, moved: f32, age: u32) -> f32 {
        match moved.is_finite() {
            true => (SERVE_FRAMES * moved / age.max(1) as f32)
                .min(0.5 * (now.max - now.min).max_element()),
            // Never taken before, or a coordinate not finite: no reach.
            false => 0.0,
        }
    }

    /// Takes the list afresh: every triangle where it is now with its
    /// reach, and the pairs by a walk from the root over the tree refitted
    /// on the grown boxes, so the walk meets just those leaves.
    fn take(
        &mut self,
        mesh: &MeshBvh,
        boxes: &[Aabb],
        moved: &[f32],
        stop: &Deadline,
    ) -> Result<()> {
        let tris = mesh.leaf_triangles();
        let ids = mesh.prim_ids();
        let reach: Vec<f32> = boxes
            .iter()
            .zip(moved)
            .zip(self.age.iter().chain(std::iter::repeat(&0)))
            .map(|((b, &d), &age)| Self::reach_of(b, d, age))
            .collect();
        let grown: Vec<Aabb> = boxes
            .iter()
            .zip(&reach)
            .map(|(b, &r)| Aabb::new(b.min - r, b.max + r))
            .collect();
        let mut tree = mesh.wide().clone();
        refit_on(&mut tree, &grown);
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
            grown,
            age: vec![0; tris.len()],
            grown_tree: tree,
            topology: mesh.wide().topology,
            walks: self.walks + 1,
        };
        Ok(())
    }

    /// Takes triangles `left` again where they are now, each with a new
    /// reach, and puts their pairs, from a query of the tree refitted on
    /// the grown boxes, in place of their old ones. The others' pairs
    /// stand: their grown boxes have not changed.
    fn retake(
        &mut self,
        mesh: &MeshBvh,
        left: &[u32],
        boxes: &[Aabb],
        moved: &[f32],
        stop: &Deadline,
    ) -> Result<()> {
        let tris = mesh.leaf_triangles();
        let mut again = vec![false; tris.len()];
        for &x in left {
            let x = x as usize;
            again[x] = true;
            let r = Self::reach_of(&boxes[x], moved[x], self.age[x]);
            self.reach[x] = r;
            self.grown[x] = Aabb::new(boxes[x].min - r, boxes[x].max + r);
            self.taken[x] = tris[x];
            self.age[x] = 0;
        }
        refit_on(&mut self.grown_tree, &self.grown);
        let (ids, vertices, grown) = (mesh.prim_ids(), &self.vertices, &self.grown);
        let tree = &self.grown_tree;
        // Each new pair once: of two triangles taken again, from the lower
        // slot.
        let found = left
            .par_chunks(CHUNK / 64)
            .map(|chunk| {
                stop.check()?;
                let mut out = Vec::new();
                for &x in chunk {
                    let x = x as usize;
                    let vx = &vertices[ids[x] as usize];
                    tree.walk(&OverlapTest::new(grown[x]), 0.0, |first, count, _| {
                        for y in first as usize..(first + count) as usize {
                            if y != x
                                && (!again[y] || x < y)
                                && grown[x].overlaps(&grown[y])
                                && !vx.iter().any(|v| vertices[ids[y] as usize].contains(v))
                            {
                                out.push((x as u32, y as u32));
                            }
                        }
                        Flow::Continue(())
                    });
                }
                Ok(out)
            })
            .collect::<Result<Vec<Vec<_>>>>();
        let found = match found {
            Ok(found) => found,
            Err(e) => {
                // Cut short, the triangles are taken but their pairs are
                // not: the next frame takes the whole list again.
                self.taken.clear();
                return Err(e);
            }
        };
        self.pairs
            .retain(|&(x, y)| !again[x as usize] && !again[y as usize]);
        self.pairs.extend(found.into_iter().flatten());
        Ok(())
    }
}

/// Refits `tree` (the mesh's topology) on `grown`, each leaf slot's box.
fn refit_on(tree: &mut Bvh4, grown: &[Aabb]) {
    tree.refit(|first, count| {
        grown[first as usize..(first + count) as usize]
            .iter()
            .fold(Aabb::EMPTY, |u, b| u.union(*b))
    });
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

    /// Frames `0..frames` of `mesh`, each answered by a list kept over them
    /// and checked against a walk from the root; the list, and the
    /// contacts over all frames.
    fn list_against_walk(frames: u32, mesh: impl Fn(u32) -> TriangleMesh) -> (NearPairs, usize) {
        list_against_walk_cut(frames, mesh, false)
    }

    /// [`list_against_walk`], every frame first asked with a deadline
    /// already past when `cut` (an error or an answer, either is fine, but
    /// the list must answer right after).
    fn list_against_walk_cut(
        frames: u32,
        mesh: impl Fn(u32) -> TriangleMesh,
        cut: bool,
    ) -> (NearPairs, usize) {
        let mut bvh = MeshBvh::build(&mesh(0), &BuildOptions::default());
        let mut near = NearPairs::new(&mesh(0));
        let mut contacts = 0;
        for frame in 0..frames {
            bvh.refit(&mesh(frame)).unwrap();
            if cut {
                let past =
                    Deadline::new(Some(std::time::Instant::now()), std::time::Instant::now());
                let _ = near.contact_slots(&bvh, &past);
            }
            let walked =
                super::super::mesh_pairs::self_contact_slots(&bvh, None, &Deadline::none())
                    .unwrap();
            let listed = near.contact_slots(&bvh, &Deadline::none()).unwrap();
            assert_eq!(sorted(listed), sorted(walked.clone()), "frame {frame}");
            contacts += walked.len();
        }
        (near, contacts)
    }

    /// Frame by frame the list answers what a walk from the root answers,
    /// while it is retaken only every several frames: a list kept while the
    /// corners moved up to twice their reach (the two triangles closing in
    /// from both sides) misses their first contacts.
    #[test]
    fn the_list_answers_as_the_walk_does_and_is_retaken_only_when_it_must_be() {
        let (speed, gap) = (0.01, 0.6);
        let frames = 60;
        let (near, contacts) = list_against_walk(frames, |f| approaching(f as f32, speed, gap));
        assert!(contacts > 10, "{contacts}");
        // A reach of SERVE_FRAMES frames' motion holds that many frames.
        let most = frames as f32 / SERVE_FRAMES + 2.0;
        assert!(near.walks() as f32 <= most, "{} walks", near.walks());
    }

    /// A resting sheet of 512 triangles and two blades of two triangles
    /// each cutting through it and then through each other, speeding up at
    /// different rates: the blades' triangles leave their reach again and
    /// again, at different frames, and are taken again alone, and frame by
    /// frame the list answers what a walk from the root answers, with one
    /// walk in all; and so it does when every frame is first cut short by
    /// its deadline.
    #[test]
    fn triangles_that_leave_their_reach_are_taken_again_alone() {
        let side = 16;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for j in 0..=side {
            for i in 0..=side {
                positions.push(Vec3::new(i as f32, j as f32, 0.0) / side as f32);
            }
        }
        let at = |i: u32, j: u32| j * (side + 1) + i;
        for j in 0..side {
            for i in 0..side {
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        for first in [positions.len() as u32, positions.len() as u32 + 4] {
            triangles.push([first, first + 1, first + 2]);
            triangles.push([first + 1, first + 3, first + 2]);
        }
        let corners = [(0.0, -0.1), (0.0, 0.1), (1.0, -0.1), (1.0, 0.1)];
        let blade = |frame: u32| {
            let f2 = (frame * frame) as f32;
            let (x, y) = (0.05 + 0.0004 * f2, 0.2 + 0.00025 * f2);
            let mut p = positions.clone();
            // One across the sheet's y, moving along x; one along x,
            // moving along y.
            for (s, z) in corners {
                p.push(Vec3::new(x + 0.04 * s, 0.4 + 0.13 * s, z));
            }
            for (s, z) in corners {
                p.push(Vec3::new(0.2 + 0.6 * s, y + 0.05 * s, z));
            }
            TriangleMesh::new(p, triangles.clone()).unwrap()
        };
        let (near, contacts) = list_against_walk(45, blade);
        assert!(contacts > 100, "{contacts}");
        assert_eq!(near.walks(), 1);
        // Cut short every frame, retakes included, it still answers right.
        list_against_walk_cut(45, blade, true);
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
