//! Ordered traversal of the wide tree with the robust slab test of
//! [`crate::bvh::traverse`], four boxes at a time.

use std::mem::MaybeUninit;

use glam::{BVec4A, Vec4};

use super::{Bvh4, Node4};
use crate::bvh::traverse::{EXIT_SCALE, STACK_SIZE};
use crate::geometry::Ray;

/// Per-ray constants of the four-box slab test.
#[derive(Clone, Copy, Debug)]
pub struct WideRay {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    /// Per axis, whether the direction is negative (then the near plane is
    /// the box maximum).
    negative: [bool; 3],
}

impl WideRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv = ray.dir.recip();
        let neg = |d: f32| d < 0.0 || (d == 0.0 && d.is_sign_negative());
        Self {
            origin: [0, 1, 2].map(|a| Vec4::splat(ray.origin[a])),
            inv_dir: [0, 1, 2].map(|a| Vec4::splat(inv[a])),
            negative: [neg(ray.dir.x), neg(ray.dir.y), neg(ray.dir.z)],
        }
    }
}

/// Lane-wise `if x > acc { x } else { acc }`: NaN lanes of `x` keep `acc`.
/// On x86-64 this is exactly `maxps(x, acc)`, one instruction.
#[inline(always)]
fn max_keep(x: Vec4, acc: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::_mm_max_ps;
        // SAFETY: SSE is part of the x86-64 baseline.
        Vec4::from(unsafe { _mm_max_ps(x.into(), acc.into()) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    Vec4::select(x.cmpgt(acc), x, acc)
}

/// Lane-wise `if x < acc { x } else { acc }`: NaN lanes of `x` keep `acc`.
#[inline(always)]
fn min_keep(x: Vec4, acc: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::_mm_min_ps;
        // SAFETY: SSE is part of the x86-64 baseline.
        Vec4::from(unsafe { _mm_min_ps(x.into(), acc.into()) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    Vec4::select(x.cmplt(acc), x, acc)
}

/// Stack entries name an inner node by its index and a leaf by this bit
/// with its node's index and slot, so leaves are visited in distance order
/// with the rest.
const LEAF_REF: u32 = 1 << 31;

#[inline(always)]
fn child_ref(n: &Node4, node: usize, slot: usize) -> u32 {
    if n.count[slot] != 0 {
        LEAF_REF | (node as u32) << 2 | slot as u32
    } else {
        n.child[slot]
    }
}

impl Bvh4 {
    /// Entry distances of the ray into the four slots of `node`, and which
    /// slots it hits within `[t_min, t_max]`. NaN lanes (origin exactly on
    /// a plane the ray runs along) take the bound, as in the binary test.
    #[inline(always)]
    fn slab4(&self, ray: &WideRay, node: usize, t_min: f32, t_max: f32) -> (Vec4, BVec4A) {
        let n = &self.nodes[node];
        let mut enter = Vec4::splat(t_min);
        let mut exit = Vec4::splat(t_max);
        for axis in 0..3 {
            let (near, far) = if ray.negative[axis] {
                (n.hi[axis], n.lo[axis])
            } else {
                (n.lo[axis], n.hi[axis])
            };
            let tn = (near - ray.origin[axis]) * ray.inv_dir[axis];
            let tf = (far - ray.origin[axis]) * ray.inv_dir[axis] * EXIT_SCALE;
            enter = max_keep(tn, enter);
            exit = min_keep(tf, exit);
        }
        (enter, enter.cmple(exit))
    }

    /// Visits the leaves the ray reaches, nearer boxes first, skipping boxes
    /// that start beyond the current `t_max`. `leaf(first, count, t_max)`
    /// tests leaf slots `first..first + count`, may shrink `t_max` and
    /// returns `true` to stop.
    #[inline(always)]
    pub fn traverse(
        &self,
        ray: &WideRay,
        t_min: f32,
        mut t_max: f32,
        mut leaf: impl FnMut(u32, u32, &mut f32) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        // Each level pushes at most three more entries than it pops.
        // Uninitialised: zeroing it would cost more than a shallow traversal.
        let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); 3 * STACK_SIZE];
        let mut top = 0usize;
        let mut node = 0usize;
        loop {
            let (enter, hits) = self.slab4(ray, node, t_min, t_max);
            let mut mask = hits.bitmask();
            // Children hit, sorted farthest first and pushed, so that the
            // nearest, leaf or not, is handled next.
            let mut hit = [(0u32, 0.0f32); 4];
            let mut k = 0;
            while mask != 0 {
                let s = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                hit[k] = (child_ref(&self.nodes[node], node, s), enter[s]);
                k += 1;
            }
            for i in 1..k {
                let mut j = i;
                while j > 0 && hit[j - 1].1 < hit[j].1 {
                    hit.swap(j - 1, j);
                    j -= 1;
                }
            }
            for &entry in &hit[..k] {
                stack[top] = MaybeUninit::new(entry);
                top += 1;
            }
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                // SAFETY: entries below the old `top` were written above.
                let (index, t_enter) = unsafe { stack[top].assume_init() };
                if t_enter > t_max {
                    continue;
                }
                if index & LEAF_REF == 0 {
                    node = index as usize;
                    break;
                }
                let (n, s) = ((index & !LEAF_REF) >> 2, index & 3);
                let n = &self.nodes[n as usize];
                if leaf(n.child[s as usize], n.count[s as usize], &mut t_max) {
                    return;
                }
            }
        }
    }
}
