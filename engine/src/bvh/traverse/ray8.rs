//! The ray's walk over an 8-wide tree with AVX: the slab test of
//! [`RayTest`] on eight boxes at a time, rounding and NaN handling
//! included, so it keeps exactly the boxes the 4-wide test keeps.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, _mm256_cmp_ps, _mm256_load_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
    _mm256_mul_ps, _mm256_set1_ps, _mm256_storeu_ps, _mm256_sub_ps, _CMP_LE_OQ,
};

use super::ray::EXIT_SCALE;
use super::wide::{walk_nodes, WideWalk, LEAF_REF};
use super::{Flow, RayTest, STACK_SIZE};
use crate::bvh::wide::Bvh8;
use crate::geometry::Ray;

/// Whether this CPU can walk the 8-wide tree (std caches the answer).
pub fn avx_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// The per-ray constants of the eight-box test, splatted.
#[cfg(target_arch = "x86_64")]
struct RayWalk8<'a> {
    tree: &'a Bvh8,
    origin: [__m256; 3],
    inv_dir: [__m256; 3],
    near: [usize; 3],
    far: [usize; 3],
    t_min: __m256,
}

#[cfg(target_arch = "x86_64")]
impl WideWalk for RayWalk8<'_> {
    const SLOT_BITS: u32 = 3;
    const ORDERED: bool = true;
    type Keys = [f32; 8];

    #[inline(always)]
    fn node_count(&self) -> usize {
        self.tree.nodes.len()
    }

    /// Inlined into [`walk`], which enables AVX: the intrinsics are
    /// inlined there too.
    #[inline(always)]
    fn test(&self, node: usize, bound: f32) -> ([f32; 8], u32) {
        let planes = &self.tree.nodes[node].planes;
        // SAFETY: only reached from `walk`, which runs where AVX is;
        // every row is 32-byte aligned (the node is 64-byte aligned, rows
        // 32 bytes long).
        unsafe {
            let mut enter = self.t_min;
            let mut exit = _mm256_set1_ps(bound);
            let scale = _mm256_set1_ps(EXIT_SCALE);
            for axis in 0..3 {
                let near = _mm256_load_ps(planes[self.near[axis]].as_ptr());
                let far = _mm256_load_ps(planes[self.far[axis]].as_ptr());
                let (o, inv) = (self.origin[axis], self.inv_dir[axis]);
                let tn = _mm256_mul_ps(_mm256_sub_ps(near, o), inv);
                let tf = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far, o), inv), scale);
                // `max`/`min` return their second operand where the first
                // is NaN: NaN lanes keep the bound, as in the 4-wide test.
                enter = _mm256_max_ps(tn, enter);
                exit = _mm256_min_ps(tf, exit);
            }
            let kept = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(enter, exit)) as u32;
            let mut keys = [0.0; 8];
            _mm256_storeu_ps(keys.as_mut_ptr(), enter);
            (keys, kept)
        }
    }

    /// Leaf or inner picked without a branch: which a kept slot holds
    /// does not predict (a mispredict per node in a hall's incoherent
    /// rays).
    #[inline(always)]
    fn entry(&self, node: usize, slot: usize) -> Option<u32> {
        let n = &self.tree.nodes[node];
        let (child, count) = (n.child[slot], n.count[slot]);
        let leaf = LEAF_REF | (node as u32) << Self::SLOT_BITS | slot as u32;
        // `if count != 0 { leaf } else { child }` by a mask: LLVM keeps
        // the `if` a branch.
        if (child == u32::MAX) & (count == 0) {
            return None;
        }
        let is_leaf = u32::from(count != 0).wrapping_neg();
        Some(child ^ ((child ^ leaf) & is_leaf))
    }

    #[inline(always)]
    fn prefetch(&self, _node: usize) {}
}

/// Visits the leaves of `tree` that `ray` reaches, nearer first, as
/// `leaf(first, count, t_max)`, which may lower `t_max` and breaks to end
/// the walk (as [`walk`](super::walk) with a [`RayTest`]).
///
/// # Safety
/// The CPU must have AVX ([`avx_available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
pub(crate) unsafe fn walk(
    tree: &Bvh8,
    ray: &Ray,
    mut leaf: impl FnMut(u32, u32, &mut f32) -> Flow,
) {
    let test = RayTest::new(ray);
    let walk = RayWalk8 {
        tree,
        origin: test.origin.map(|o| _mm256_set1_ps(o.x)),
        inv_dir: test.inv_dir.map(|d| _mm256_set1_ps(d.x)),
        near: test.near,
        far: test.far,
        t_min: _mm256_set1_ps(test.t_min),
    };
    // Each level pushes at most seven more entries than it pops.
    walk_nodes::<_, { 7 * STACK_SIZE }>(
        &walk,
        ray.t_max,
        |_, _, _| true,
        |node, slot, t_max| {
            let n = &tree.nodes[node];
            leaf(n.child[slot], n.count[slot], t_max)
        },
    );
}
