//! Oriented bounding boxes on a mesh tree's own topology (the
//! dissertation's section 6.2.4): the same tree, refitted with boxes
//! aligned to the principal axes of the triangles below each slot, for
//! collision walks where tighter volumes cull more than they cost.
//!
//! Fitting is a refit: per slot, area-weighted moments of its triangles
//! (first and second, summed bottom-up, so the whole tree costs one pass),
//! their covariance's eigenvectors as axes (Gottschalk et al.'s OBB-tree),
//! and extents from the triangles' corners at a leaf or the children's
//! boxes above one. Both the extents and the separating-axis test carry a
//! rounding slack, so a pair of boxes reported apart never holds touching
//! triangles.

use glam::Vec3A;
use rayon::prelude::*;

use super::moments::Moments;
use super::traverse::pair::{PairVolumes, Slot};
use super::wide::{Bvh4, Node4};
use super::MeshBvh;
use crate::geometry::RigidTransform;
use crate::{Error, Result};

/// Relative slack on extents and on the separating-axis test: about eight
/// f32 ulps, several times the rounding of a projection or a rigid motion.
const SLACK: f32 = 1e-6;

/// An oriented box: `center`, orthonormal `axes`, and half extents along
/// them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obb {
    pub center: Vec3A,
    pub axes: [Vec3A; 3],
    pub half: Vec3A,
}

impl Default for Obb {
    fn default() -> Self {
        Self {
            center: Vec3A::ZERO,
            axes: [Vec3A::X, Vec3A::Y, Vec3A::Z],
            half: Vec3A::ZERO,
        }
    }
}

impl Obb {
    /// The box on `axes` around points whose projections on them span
    /// `lo..hi`, padded by the slack.
    fn spanning(axes: [Vec3A; 3], lo: Vec3A, hi: Vec3A) -> Self {
        let mid = (lo + hi) * 0.5;
        let half = (hi - lo) * 0.5;
        let pad = SLACK * (mid.abs().max_element() + half.max_element()) + f32::MIN_POSITIVE;
        Self {
            center: axes[0] * mid.x + axes[1] * mid.y + axes[2] * mid.z,
            axes,
            half: half + Vec3A::splat(pad),
        }
    }

    /// Its extent projected on unit vector `u`: `(centre, radius)`.
    #[inline]
    fn project(&self, u: Vec3A) -> (f32, f32) {
        let r = self.half.x * u.dot(self.axes[0]).abs()
            + self.half.y * u.dot(self.axes[1]).abs()
            + self.half.z * u.dot(self.axes[2]).abs();
        (u.dot(self.center), r)
    }

    /// This box moved rigidly.
    pub fn transformed(&self, t: &RigidTransform) -> Self {
        Self {
            center: t.transform_point(self.center),
            axes: self.axes.map(|a| t.transform_vector(a)),
            half: self.half * (1.0 + SLACK),
        }
    }

    /// Whether the boxes may overlap: no separating axis among the fifteen
    /// candidates (three face normals each, nine edge cross products).
    /// Conservative: touching boxes, and boxes apart by less than the
    /// rounding slack, overlap.
    pub fn overlaps(&self, other: &Obb) -> bool {
        let (a, b) = (self, other);
        let t = b.center - a.center;
        let scale = a.center.abs().max_element() + b.center.abs().max_element();
        let apart =
            |d: f32, ra: f32, rb: f32| d.abs() > (ra + rb) * (1.0 + 4.0 * SLACK) + SLACK * scale;
        // r[i][j] = a_i . b_j, with slack for near-parallel edges, whose
        // cross products are near zero and would otherwise decide on noise.
        let mut r = [[0.0f32; 3]; 3];
        let mut abs = [[0.0f32; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = a.axes[i].dot(b.axes[j]);
                abs[i][j] = r[i][j].abs() + SLACK;
            }
        }
        let (ea, eb) = (a.half.to_array(), b.half.to_array());
        let ta = [t.dot(a.axes[0]), t.dot(a.axes[1]), t.dot(a.axes[2])];
        for i in 0..3 {
            let rb = eb[0] * abs[i][0] + eb[1] * abs[i][1] + eb[2] * abs[i][2];
            if apart(ta[i], ea[i], rb) {
                return false;
            }
        }
        for j in 0..3 {
            let ra = ea[0] * abs[0][j] + ea[1] * abs[1][j] + ea[2] * abs[2][j];
            let d = ta[0] * r[0][j] + ta[1] * r[1][j] + ta[2] * r[2][j];
            if apart(d, ra, eb[j]) {
                return false;
            }
        }
        for i in 0..3 {
            let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
            for j in 0..3 {
                let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
                let ra = ea[i1] * abs[i2][j] + ea[i2] * abs[i1][j];
                let rb = eb[j1] * abs[i][j2] + eb[j2] * abs[i][j1];
                let d = ta[i2] * r[i1][j] - ta[i1] * r[i2][j];
                if apart(d, ra, rb) {
                    return false;
                }
            }
        }
        true
    }
}

/// An oriented box for every used slot of a mesh tree, in the tree's own
/// layout (node, slot), fitted to the triangles below the slot.
#[derive(Clone, Debug, Default)]
pub struct ObbTree {
    boxes: Vec<[Obb; 4]>,
    /// Per node, the moments of everything below it (refit scratch).
    moments: Vec<Moments>,
    /// The tree's topology and pose the boxes were fitted to.
    fitted: (u64, u64),
}

impl ObbTree {
    /// The boxes of `mesh`'s tree, fitted to its triangles.
    pub fn fit(mesh: &MeshBvh) -> Self {
        let mut tree = Self::default();
        tree.refit(mesh);
        tree
    }

    /// Fits the boxes again to `mesh`'s current triangles: after a refit of
    /// the mesh tree, or for another tree (then the layout changes too).
    pub fn refit(&mut self, mesh: &MeshBvh) {
        let nodes = &mesh.wide().nodes;
        let triangles = mesh.leaf_triangles();
        self.fitted = (mesh.wide().topology, mesh.wide().pose);
        self.boxes.resize(nodes.len(), [Obb::default(); 4]);
        self.moments.resize(nodes.len(), Moments::default());
        let leaves = |(node, (boxes, moments)): (&Node4, (&mut [Obb; 4], &mut Moments))| {
            *moments = Moments::default();
            for s in (0..4).filter(|&s| node.is_leaf_slot(s)) {
                let leaf =
                    &triangles[node.child[s] as usize..(node.child[s] + node.count[s]) as usize];
                let mut m = Moments::default();
                leaf.iter().for_each(|t| m.add(&Moments::triangle(t)));
                let axes = m.axes();
                let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
                for p in leaf.iter().flatten() {
                    let d = Vec3A::new(p.dot(axes[0]), p.dot(axes[1]), p.dot(axes[2]));
                    (lo, hi) = (lo.min(d), hi.max(d));
                }
                boxes[s] = Obb::spanning(axes, lo, hi);
                moments.add(&m);
            }
        };
        nodes
            .par_iter()
            .zip(self.boxes.par_iter_mut().zip(self.moments.par_iter_mut()))
            .with_min_len(256)
            .for_each(leaves);
        // Children come after their parent: one reverse sweep fits every
        // inner slot after the node below it is complete.
        for i in (0..nodes.len()).rev() {
            for s in (0..4).filter(|&s| nodes[i].is_inner_slot(s)) {
                let c = nodes[i].child[s] as usize;
                let m = self.moments[c];
                let axes = m.axes();
                let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
                for k in (0..4).filter(|&k| nodes[c].is_leaf_slot(k) || nodes[c].is_inner_slot(k)) {
                    let b = &self.boxes[c][k];
                    let [(c0, r0), (c1, r1), (c2, r2)] = axes.map(|u| b.project(u));
                    let (mid, r) = (Vec3A::new(c0, c1, c2), Vec3A::new(r0, r1, r2));
                    (lo, hi) = (lo.min(mid - r), hi.max(mid + r));
                }
                self.boxes[i][s] = Obb::spanning(axes, lo, hi);
                self.moments[i].add(&m);
            }
        }
    }

    /// The box of a slot.
    pub fn slot_obb(&self, slot: Slot) -> &Obb {
        &self.boxes[slot.node()][slot.slot()]
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.boxes.capacity() * std::mem::size_of::<[Obb; 4]>()
            + self.moments.capacity() * std::mem::size_of::<Moments>()
    }
}

/// Two mesh trees' oriented boxes for the pair walk, `b`'s moved into `a`'s
/// frame by `b_to_a` when given (a rigid motion keeps an OBB as tight as
/// it was, where an AABB grows).
pub struct ObbVolumes<'t> {
    a: (&'t Bvh4, &'t ObbTree),
    b: (&'t Bvh4, &'t ObbTree),
    b_to_a: Option<RigidTransform>,
    /// Grows `b`'s boxes: the rounding of `b_to_a`.
    pad: f32,
}

impl<'t> ObbVolumes<'t> {
    /// `b`'s boxes moved by `b_to_a` and grown by `pad` (its rounding, see
    /// [`RigidTransform::relative`]). Fails when an OBB tree was fitted to
    /// another tree than its mesh's, or to an earlier pose of it.
    pub fn new(
        a: (&'t MeshBvh, &'t ObbTree),
        b: (&'t MeshBvh, &'t ObbTree),
        b_to_a: Option<RigidTransform>,
        pad: f32,
    ) -> Result<Self> {
        for (mesh, obbs) in [a, b] {
            if (mesh.wide().topology, mesh.wide().pose) != obbs.fitted {
                return Err(Error::InvalidOption {
                    field: "obb".into(),
                    reason: "was fitted to another tree than this mesh's, or before it moved; \
                             refit it first"
                        .into(),
                });
            }
        }
        Ok(Self {
            a: (a.0.wide(), a.1),
            b: (b.0.wide(), b.1),
            b_to_a,
            pad,
        })
    }
}

impl PairVolumes for ObbVolumes<'_> {
    type A = Obb;
    type B = Obb;

    fn tree_a(&self) -> &Bvh4 {
        self.a.0
    }

    fn tree_b(&self) -> &Bvh4 {
        self.b.0
    }

    #[inline]
    fn volume_a(&self, s: Slot) -> Obb {
        *self.a.1.slot_obb(s)
    }

    #[inline]
    fn volume_b(&self, s: Slot) -> Obb {
        let b = self.b.1.slot_obb(s);
        let mut moved = match &self.b_to_a {
            Some(t) => b.transformed(t),
            None => *b,
        };
        moved.half += Vec3A::splat(self.pad);
        moved
    }

    #[inline]
    fn overlap(&self, a: &Obb, b: &Obb) -> bool {
        a.overlaps(b)
    }
}
