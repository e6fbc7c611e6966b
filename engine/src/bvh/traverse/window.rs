//! The window's node test and walk: boxes projected through a frustum's
//! window, for packets of rays that share an apex (see
//! [`crate::query::packet`]).
//!
//! A point `p` has window coordinates `(x, y, s) = M (p - apex)`; the rays
//! of a packet run from the apex through window points `(u, v)` and a
//! point on one of them has `(u, v) = (x / s, y / s)`, with `s` growing
//! along it. A box wholly in front of the apex (`s > 0`) maps onto the hull
//! of its corners' images, so only rays inside the bounding rectangle of
//! those can meet it, and only at depths in its range of `s`. Where a box
//! reaches behind the apex plane no rectangle bounds it and the parent's is
//! kept.
//!
//! Everything is widened by what single precision costs: `slack`, a length
//! the caller chooses above both the rays' own rounding (origins and
//! directions in `f32`) and the rounding of `M (p - apex)`, moves any point
//! that far, which moves `(u, v)` by at most `slack (|m_x| + |m_y| + 2 |m_s|)
//! / s` inside the window and `s` by `slack |m_s|`. Nothing a ray can hit is
//! ever culled; a rectangle a little too large costs a few tests.

use std::mem::MaybeUninit;

use glam::{DMat3, DVec3, Vec3A, Vec4};

use super::wide::{child_ref, LEAF_REF};
use super::{Flow, NodeTest, STACK_SIZE};
use crate::bvh::wide::{Bvh4, Node4};
use crate::geometry::{Aabb, RigidTransform};

/// A rectangle of window coordinates, bounds inclusive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowRect {
    pub u: [f32; 2],
    pub v: [f32; 2],
}

impl WindowRect {
    /// The whole plane: every ray of a packet.
    pub const ALL: Self = Self {
        u: [f32::NEG_INFINITY, f32::INFINITY],
        v: [f32::NEG_INFINITY, f32::INFINITY],
    };

    #[inline]
    pub fn intersect(&self, o: &Self) -> Self {
        Self {
            u: [self.u[0].max(o.u[0]), self.u[1].min(o.u[1])],
            v: [self.v[0].max(o.v[0]), self.v[1].min(o.v[1])],
        }
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        !(self.u[0] <= self.u[1] && self.v[0] <= self.v[1])
    }

    #[inline]
    pub fn contains(&self, u: f32, v: f32) -> bool {
        (self.u[0]..=self.u[1]).contains(&u) && (self.v[0]..=self.v[1]).contains(&v)
    }
}

/// Where a box or triangle lies in the window: the rays that can meet it
/// and the depths `s` it spans, both widened by the slack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    pub rect: WindowRect,
    pub depth: [f32; 2],
}

/// The projective map of a window in single precision, with its slack.
#[derive(Clone, Copy, Debug)]
pub struct WindowTest {
    apex: Vec3A,
    /// Rows of `M`: `x`, `y` and `s`.
    rows: [Vec3A; 3],
    /// `2 slack (|m_x| + |m_y| + 2 |m_s|)`: a rectangle's pad times `s`.
    pad_scale: f32,
    /// `2 slack |m_s|`, the pad of depths.
    depth_pad: f32,
}

impl WindowTest {
    /// The window `(x, y, s) = to_window (p - apex)` with points allowed to
    /// be `slack` off (see the module docs).
    pub fn new(apex: DVec3, to_window: DMat3, slack: f32) -> Self {
        let rows = [0, 1, 2].map(|i| to_window.row(i).as_vec3a());
        let norm = |r: Vec3A| r.length();
        let slack = slack.max(0.0);
        Self {
            apex: apex.as_vec3a(),
            rows,
            pad_scale: 2.0 * slack * (norm(rows[0]) + norm(rows[1]) + 2.0 * norm(rows[2])),
            depth_pad: 2.0 * slack * norm(rows[2]),
        }
    }

    /// The same window seen from an object's frame, given the object's
    /// object-to-world transform: `M (R p + T - apex) = (M R)(p - apex')`.
    pub fn in_frame(&self, to_world: &RigidTransform, to_object: &RigidTransform) -> Self {
        let inverse = to_world.rotation.inverse();
        Self {
            apex: to_object.transform_point(self.apex),
            rows: self.rows.map(|r| inverse * r),
            ..*self
        }
    }

    /// The projection of points whose depths span `s` and whose window
    /// coordinates span `uv`, `None` when they lie wholly behind the apex.
    #[inline(always)]
    fn bound(&self, s: [f32; 2], uv: [[f32; 2]; 2]) -> Option<Projection> {
        let depth = [s[0] - self.depth_pad, s[1] + self.depth_pad];
        if depth[1].is_nan() || depth[1] < 0.0 {
            return None;
        }
        let pad = self.pad_scale / depth[0] + 1e-6;
        let rect = if depth[0] > 0.0 && pad < 1.0 {
            WindowRect {
                u: [uv[0][0] - pad, uv[0][1] + pad],
                v: [uv[1][0] - pad, uv[1][1] + pad],
            }
        } else {
            WindowRect::ALL
        };
        Some(Projection { rect, depth })
    }

    /// Projects points given in the test's frame.
    #[inline]
    fn project_points(&self, points: impl Iterator<Item = Vec3A>) -> Option<Projection> {
        let mut s = [f32::INFINITY, f32::NEG_INFINITY];
        let mut uv = [[f32::INFINITY, f32::NEG_INFINITY]; 2];
        for p in points {
            let d = p - self.apex;
            let (x, y, z) = (
                self.rows[0].dot(d),
                self.rows[1].dot(d),
                self.rows[2].dot(d),
            );
            s = [s[0].min(z), s[1].max(z)];
            let (u, v) = (x / z, y / z);
            uv = [
                [uv[0][0].min(u), uv[0][1].max(u)],
                [uv[1][0].min(v), uv[1][1].max(v)],
            ];
        }
        // NaN corners (a point on the apex plane) leave the rectangle
        // unbounded rather than empty.
        if uv.iter().flatten().any(|c| c.is_nan()) {
            uv = [[f32::NEG_INFINITY, f32::INFINITY]; 2];
        }
        self.bound(s, uv)
    }

    /// The projection of a box, `None` when it lies wholly behind the apex
    /// or is empty.
    pub fn project_box(&self, b: &Aabb) -> Option<Projection> {
        if b.is_empty() {
            return None;
        }
        self.project_points((0..8).map(|c| {
            Vec3A::new(
                if c & 1 == 0 { b.min.x } else { b.max.x },
                if c & 2 == 0 { b.min.y } else { b.max.y },
                if c & 4 == 0 { b.min.z } else { b.max.z },
            )
        }))
    }

    /// The projection of triangle `(a, b, c)`.
    #[inline]
    pub fn project_triangle(&self, a: Vec3A, b: Vec3A, c: Vec3A) -> Option<Projection> {
        self.project_points([a, b, c].into_iter())
    }

    /// [`project_box`](Self::project_box) for the four slots of a wide
    /// node at once; empty slots come back as `None`.
    #[inline]
    pub fn project4(&self, n: &Node4) -> [Option<Projection>; 4] {
        // Each of x, y, s is linear in the corner, so every corner's value
        // is a sum of one term per axis, taken from the minimum or maximum.
        let mut terms = [[[Vec4::ZERO; 2]; 3]; 3];
        for axis in 0..3 {
            let lo = n.boxes.lo[axis] - Vec4::splat(self.apex[axis]);
            let hi = n.boxes.hi[axis] - Vec4::splat(self.apex[axis]);
            for (row, t) in self.rows.iter().zip(terms.iter_mut()) {
                t[axis] = [lo * row[axis], hi * row[axis]];
            }
        }
        let mut s_lo = Vec4::INFINITY;
        let mut s_hi = Vec4::NEG_INFINITY;
        let mut u = [Vec4::INFINITY, Vec4::NEG_INFINITY];
        let mut v = [Vec4::INFINITY, Vec4::NEG_INFINITY];
        let mut nan = Vec4::ZERO;
        for c in 0..8 {
            let pick = |t: &[[Vec4; 2]; 3]| t[0][c & 1] + t[1][(c >> 1) & 1] + t[2][(c >> 2) & 1];
            let (x, y, s) = (pick(&terms[0]), pick(&terms[1]), pick(&terms[2]));
            s_lo = s_lo.min(s);
            s_hi = s_hi.max(s);
            let (cu, cv) = (x / s, y / s);
            nan += cu + cv;
            u = [u[0].min(cu), u[1].max(cu)];
            v = [v[0].min(cv), v[1].max(cv)];
        }
        std::array::from_fn(|slot| {
            let (lo, hi) = (n.boxes.lo[0][slot], n.boxes.hi[0][slot]);
            if n.child[slot] == u32::MAX || lo.is_nan() || lo > hi {
                return None;
            }
            let uv = if nan[slot].is_nan() {
                [[f32::NEG_INFINITY, f32::INFINITY]; 2]
            } else {
                [[u[0][slot], u[1][slot]], [v[0][slot], v[1][slot]]]
            };
            self.bound([s_lo[slot], s_hi[slot]], uv)
        })
    }
}

/// The top level's test: a box's key is its nearest depth.
impl NodeTest for WindowTest {
    #[inline]
    fn test(&self, b: &Aabb, bound: f32) -> Option<f32> {
        self.project_box(b)
            .map(|p| p.depth[0])
            .filter(|&d| d <= bound)
    }
}

/// What a packet does during [`Bvh4::walk_window`].
pub trait WindowVisitor {
    /// Whether any ray of the packet can still meet what `p` bounds; asked
    /// when a box is reached, so that hits found since it was queued count.
    fn keep(&mut self, p: &Projection) -> bool;

    /// Leaf slots `first..first + count`, met only by rays in `rect`;
    /// breaks to end the walk.
    fn leaf(&mut self, first: u32, count: u32, rect: &WindowRect) -> Flow;
}

impl Bvh4 {
    /// Visits the leaves that rays of a packet inside `rect` can reach,
    /// nearer boxes first, each with the rectangle of rays that can meet it.
    pub fn walk_window(
        &self,
        test: &WindowTest,
        rect: WindowRect,
        visitor: &mut impl WindowVisitor,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [MaybeUninit::<(u32, Projection)>::uninit(); 3 * STACK_SIZE];
        let mut top = 0usize;
        let mut node = 0usize;
        let mut node_rect = rect;
        loop {
            let n = &self.nodes[node];
            let projected = test.project4(n);
            let mut kept: [(u32, Projection); 4] = [(
                0,
                Projection {
                    rect,
                    depth: [0.0; 2],
                },
            ); 4];
            let mut k = 0;
            for (slot, p) in projected.iter().enumerate() {
                let Some(mut p) = *p else { continue };
                p.rect = p.rect.intersect(&node_rect);
                if p.rect.is_empty() {
                    continue;
                }
                let index = child_ref(n, node, slot);
                kept[k] = (index, p);
                k += 1;
            }
            // Farthest first onto the stack, so the nearest comes off next.
            kept[..k].sort_unstable_by(|a, b| b.1.depth[0].total_cmp(&a.1.depth[0]));
            for &entry in &kept[..k] {
                stack[top] = MaybeUninit::new(entry);
                top += 1;
            }
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                // SAFETY: entries below the old `top` were written above.
                let (index, p) = unsafe { stack[top].assume_init() };
                if !visitor.keep(&p) {
                    continue;
                }
                if index & LEAF_REF == 0 {
                    node = index as usize;
                    node_rect = p.rect;
                    break;
                }
                let (n, s) = ((index & !LEAF_REF) >> 2, index & 3);
                let n = &self.nodes[n as usize];
                if visitor
                    .leaf(n.child[s as usize], n.count[s as usize], &p.rect)
                    .is_break()
                {
                    return;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::wide::EMPTY_NODE;
    use glam::Vec3;

    /// The window of the frustum from the origin through `z = 1`,
    /// `x, y` in `[0, 1]`: `(u, v) = (x / z, y / z)`, `s = z`.
    fn window() -> WindowTest {
        WindowTest::new(DVec3::ZERO, DMat3::IDENTITY, 1e-6)
    }

    #[test]
    fn a_box_in_front_bounds_the_rays_through_it() {
        let b = Aabb::new(Vec3A::new(0.5, 0.5, 2.0), Vec3A::new(1.0, 1.0, 4.0));
        let p = window().project_box(&b).unwrap();
        // Corners' (u, v): x / z in [0.125, 0.5].
        assert!((p.rect.u[0] - 0.125).abs() < 1e-4 && (p.rect.u[1] - 0.5).abs() < 1e-4);
        assert!(p.rect.u[0] < 0.125 && p.rect.u[1] > 0.5, "widened");
        assert!(p.depth[0] < 2.0 && p.depth[1] > 4.0);
    }

    #[test]
    fn boxes_behind_the_apex_are_culled_and_straddling_ones_keep_every_ray() {
        let w = window();
        let behind = Aabb::new(Vec3A::new(-1.0, -1.0, -3.0), Vec3A::new(1.0, 1.0, -1.0));
        assert_eq!(w.project_box(&behind), None);
        let straddling = Aabb::new(Vec3A::new(-1.0, -1.0, -1.0), Vec3A::new(1.0, 1.0, 1.0));
        assert_eq!(w.project_box(&straddling).unwrap().rect, WindowRect::ALL);
        // A box touching the apex plane: corners at s = 0 give NaN or
        // infinite (u, v); every ray is kept.
        let touching = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
        assert_eq!(w.project_box(&touching).unwrap().rect, WindowRect::ALL);
        assert_eq!(w.project_box(&Aabb::EMPTY), None);
    }

    #[test]
    fn four_slots_agree_with_one_box_projections() {
        let w = WindowTest::new(
            DVec3::new(0.3, -0.2, 0.1),
            DMat3::from_cols(
                DVec3::new(1.0, 0.2, 0.0),
                DVec3::new(-0.1, 0.9, 0.3),
                DVec3::new(0.0, 0.1, 1.1),
            ),
            1e-5,
        );
        let boxes = [
            Aabb::new(Vec3A::new(0.5, 0.5, 2.0), Vec3A::new(1.0, 1.0, 4.0)),
            Aabb::new(Vec3A::new(-1.0, -1.0, -3.0), Vec3A::new(1.0, 1.0, -1.0)),
            Aabb::new(Vec3A::new(-1.0, 0.0, -0.5), Vec3A::new(1.0, 2.0, 3.0)),
        ];
        let mut node = EMPTY_NODE;
        for (s, b) in boxes.iter().enumerate() {
            node.set_slot_aabb(s, *b);
            node.child[s] = s as u32;
        }
        let four = w.project4(&node);
        for (s, b) in boxes.iter().enumerate() {
            let one = w.project_box(b);
            match (one, four[s]) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    let close = |x: f32, y: f32| x == y || (x - y).abs() <= 1e-5 * x.abs().max(1.0);
                    let (ra, rb) = (a.rect, b.rect);
                    for (x, y) in [ra.u, ra.v, a.depth]
                        .iter()
                        .flatten()
                        .zip([rb.u, rb.v, b.depth].iter().flatten())
                    {
                        assert!(close(*x, *y), "slot {s}: {a:?} vs {b:?}");
                    }
                }
                other => panic!("slot {s}: {other:?}"),
            }
        }
        assert_eq!(four[3], None, "the empty slot");
    }

    #[test]
    fn a_moved_object_sees_the_same_window() {
        let w = window();
        let to_world =
            RigidTransform::new(glam::Quat::from_rotation_y(0.7), Vec3::new(0.5, -1.0, 2.0))
                .unwrap();
        let local = w.in_frame(&to_world, &to_world.inverse());
        let p = Vec3A::new(0.2, 0.3, 0.4);
        let world = to_world.transform_point(p);
        let a = w.project_triangle(world, world, world).unwrap();
        let b = local.project_triangle(p, p, p).unwrap();
        assert!((a.rect.u[0] - b.rect.u[0]).abs() < 1e-5);
        assert!((a.depth[0] - b.depth[0]).abs() < 1e-5);
    }
}
