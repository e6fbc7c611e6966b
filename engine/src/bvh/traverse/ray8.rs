//! The ray's walk over an 8-wide tree with AVX: the slab test of
//! [`RayTest`] on eight boxes at a time, rounding and NaN handling
//! included, so it keeps exactly the boxes the 4-wide test keeps.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m128i, __m256, _mm256_add_ps, _mm256_castsi128_si256, _mm256_cmp_ps, _mm256_cvtepi32_ps,
    _mm256_insertf128_si256, _mm256_load_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
    _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps, _mm256_sub_ps,
    _mm_cvtepu8_epi32, _mm_loadl_epi64, _mm_srli_si128, _CMP_LE_OQ,
};

use super::ray::EXIT_SCALE;
use super::wide::{walk_nodes, WideWalk, LEAF_REF};
use super::{Flow, RayTest, STACK_SIZE};
use crate::bvh::compact::eight::COUNT_SHIFT;
use crate::bvh::compact::node::step;
use crate::bvh::compact::CompactBvh8;
use crate::bvh::ray_queries::Tree8;
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

/// The per-ray constants of the eight-box test, splatted, and the tree.
#[cfg(target_arch = "x86_64")]
struct RayWalk8<T> {
    tree: T,
    origin: [__m256; 3],
    inv_dir: [__m256; 3],
    near: [usize; 3],
    far: [usize; 3],
    t_min: __m256,
}

#[cfg(target_arch = "x86_64")]
impl<T> RayWalk8<T> {
    /// # Safety
    /// Only from a function that enables AVX.
    #[inline(always)]
    unsafe fn new(tree: T, test: &RayTest) -> Self {
        Self {
            tree,
            origin: test.origin.map(|o| _mm256_set1_ps(o.x)),
            inv_dir: test.inv_dir.map(|d| _mm256_set1_ps(d.x)),
            near: test.near,
            far: test.far,
            t_min: _mm256_set1_ps(test.t_min),
        }
    }

    /// The slab test of eight boxes given by their `near` and `far` planes
    /// per axis: keys and the mask of boxes kept under `bound`.
    ///
    /// # Safety
    /// Only from a function that enables AVX.
    #[inline(always)]
    unsafe fn slabs(&self, near: [__m256; 3], far: [__m256; 3], bound: f32) -> ([f32; 8], u32) {
        let mut enter = self.t_min;
        let mut exit = _mm256_set1_ps(bound);
        let scale = _mm256_set1_ps(EXIT_SCALE);
        for axis in 0..3 {
            let (o, inv) = (self.origin[axis], self.inv_dir[axis]);
            let tn = _mm256_mul_ps(_mm256_sub_ps(near[axis], o), inv);
            let tf = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far[axis], o), inv), scale);
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

/// The stack entry of a slot (see [`WideWalk::entry`]) that is `empty`,
/// or holds a leaf, or the inner node `child`: leaf or inner picked
/// without a branch, since which a kept slot holds does not predict (a
/// mispredict per node in a hall's incoherent rays).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn entry8(node: usize, slot: usize, empty: bool, leaf: bool, child: u32) -> Option<u32> {
    if empty {
        return None;
    }
    let leaf_ref = LEAF_REF | (node as u32) << 3 | slot as u32;
    // `if leaf { leaf_ref } else { child }` by a mask: LLVM keeps the
    // `if` a branch.
    let is_leaf = u32::from(leaf).wrapping_neg();
    Some(child ^ ((child ^ leaf_ref) & is_leaf))
}

/// What the walk reads of an 8-wide tree, plain or compact: everything
/// else, the slab test included, is the same walk.
#[cfg(target_arch = "x86_64")]
trait EightWide {
    fn node_count(&self) -> usize;
    /// Node `node`'s planes in rows `near` and `far` per axis.
    ///
    /// # Safety
    /// Only from a function that enables AVX.
    unsafe fn planes(
        &self,
        node: usize,
        near: [usize; 3],
        far: [usize; 3],
    ) -> ([__m256; 3], [__m256; 3]);
    /// See [`WideWalk::entry`].
    fn entry(&self, node: usize, slot: usize) -> Option<u32>;
    /// Leaf slot `slot`'s first triangle and count.
    fn leaf(&self, node: usize, slot: usize) -> (u32, u32);
    fn prefetch(&self, node: usize);
}

#[cfg(target_arch = "x86_64")]
impl EightWide for Bvh8 {
    #[inline(always)]
    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Every row is 32-byte aligned (the node is 64-byte aligned, rows 32
    /// bytes long).
    #[inline(always)]
    unsafe fn planes(
        &self,
        node: usize,
        near: [usize; 3],
        far: [usize; 3],
    ) -> ([__m256; 3], [__m256; 3]) {
        let planes = &self.nodes[node].planes;
        let (mut n, mut f) = ([_mm256_setzero_ps(); 3], [_mm256_setzero_ps(); 3]);
        for axis in 0..3 {
            n[axis] = _mm256_load_ps(planes[near[axis]].as_ptr());
            f[axis] = _mm256_load_ps(planes[far[axis]].as_ptr());
        }
        (n, f)
    }

    #[inline(always)]
    fn entry(&self, node: usize, slot: usize) -> Option<u32> {
        let n = &self.nodes[node];
        let (child, count) = (n.child[slot], n.count[slot]);
        entry8(
            node,
            slot,
            (child == u32::MAX) & (count == 0),
            count != 0,
            child,
        )
    }

    #[inline(always)]
    fn leaf(&self, node: usize, slot: usize) -> (u32, u32) {
        let n = &self.nodes[node];
        (n.child[slot], n.count[slot])
    }

    #[inline(always)]
    fn prefetch(&self, _node: usize) {}
}

/// Eight grid bytes decoded as planes, `origin + q · step`.
///
/// # Safety
/// Only from a function that enables AVX. Closures and array maps are
/// avoided on this path: they are compiled without the caller's AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn decode8(q: &[u8; 8], origin: __m256, step: __m256) -> __m256 {
    let bytes = _mm_loadl_epi64(q.as_ptr() as *const __m128i);
    let low = _mm_cvtepu8_epi32(bytes);
    let high = _mm_cvtepu8_epi32(_mm_srli_si128::<4>(bytes));
    let q = _mm256_cvtepi32_ps(_mm256_insertf128_si256::<1>(
        _mm256_castsi128_si256(low),
        high,
    ));
    _mm256_add_ps(origin, _mm256_mul_ps(q, step))
}

#[cfg(target_arch = "x86_64")]
impl EightWide for CompactBvh8 {
    #[inline(always)]
    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Decoded as [`CompactNode8::slot_aabb`] decodes them (`origin +
    /// q · step`, the product exact), so the test sees the same boxes;
    /// AVX implies the SSE4.1 of the byte widening.
    ///
    /// [`CompactNode8::slot_aabb`]: crate::bvh::compact::CompactNode8::slot_aabb
    #[inline(always)]
    unsafe fn planes(
        &self,
        node: usize,
        near: [usize; 3],
        far: [usize; 3],
    ) -> ([__m256; 3], [__m256; 3]) {
        let n = &self.nodes[node];
        let (mut lo, mut hi) = ([_mm256_setzero_ps(); 3], [_mm256_setzero_ps(); 3]);
        for axis in 0..3 {
            let origin = _mm256_set1_ps(n.origin[axis]);
            let step = _mm256_set1_ps(step(n.exponent[axis]));
            lo[axis] = decode8(&n.q[near[axis]], origin, step);
            hi[axis] = decode8(&n.q[far[axis]], origin, step);
        }
        (lo, hi)
    }

    #[inline(always)]
    fn entry(&self, node: usize, slot: usize) -> Option<u32> {
        let link = self.nodes[node].link[slot];
        entry8(node, slot, link == u32::MAX, link >> COUNT_SHIFT != 0, link)
    }

    #[inline(always)]
    fn leaf(&self, node: usize, slot: usize) -> (u32, u32) {
        self.nodes[node].leaf(slot)
    }

    /// Kept children are asked for as they are pushed, as in the compact
    /// 4-wide walk (which took a 2M hall from 0.7x the plain tree's
    /// incoherent rate to 1x).
    #[inline(always)]
    fn prefetch(&self, node: usize) {
        super::wide::prefetch(&self.nodes[node]);
    }
}

#[cfg(target_arch = "x86_64")]
impl<T: EightWide> WideWalk for RayWalk8<&T> {
    const SLOT_BITS: u32 = 3;
    const ORDERED: bool = true;
    type Keys = [f32; 8];

    #[inline(always)]
    fn node_count(&self) -> usize {
        self.tree.node_count()
    }

    /// Inlined into [`walk`], which enables AVX: the intrinsics are
    /// inlined there too.
    #[inline(always)]
    fn test(&self, node: usize, bound: f32) -> ([f32; 8], u32) {
        // SAFETY: only reached from `walk`, which runs where AVX is.
        unsafe {
            let (near, far) = self.tree.planes(node, self.near, self.far);
            self.slabs(near, far, bound)
        }
    }

    #[inline(always)]
    fn entry(&self, node: usize, slot: usize) -> Option<u32> {
        self.tree.entry(node, slot)
    }

    #[inline(always)]
    fn prefetch(&self, node: usize) {
        self.tree.prefetch(node)
    }
}

/// Visits the leaves of `tree` that `ray` reaches, nearer first, as
/// `leaf(first, count, t_max)`, which may lower `t_max` and breaks to end
/// the walk (as [`walk`](super::walk) with a [`RayTest`]).
///
/// # Safety
/// The CPU must have AVX ([`avx_available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
pub(crate) unsafe fn walk(tree: Tree8, ray: &Ray, leaf: impl FnMut(u32, u32, &mut f32) -> Flow) {
    match tree {
        Tree8::Plain(tree) => walk_tree(tree, ray, leaf),
        Tree8::Compact(tree) => walk_tree(tree, ray, leaf),
    }
}

/// [`walk`] on one kind of tree.
///
/// # Safety
/// Only from a function that enables AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn walk_tree<T: EightWide>(
    tree: &T,
    ray: &Ray,
    mut leaf: impl FnMut(u32, u32, &mut f32) -> Flow,
) {
    let test = RayTest::new(ray);
    // Each level pushes at most seven more entries than it pops.
    walk_nodes::<_, { 7 * STACK_SIZE }>(
        &RayWalk8::new(tree, &test),
        ray.t_max,
        |_, _, _| true,
        |node, slot, t_max| {
            let (first, count) = tree.leaf(node, slot);
            leaf(first, count, t_max)
        },
    );
}
