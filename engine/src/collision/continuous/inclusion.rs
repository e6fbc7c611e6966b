//! Continuous tests of two moving primitives, vertex–face and edge–edge,
//! by inclusion-based root finding (Wang et al. 2021, "A Large-scale
//! Benchmark and an Inclusion-based Algorithm for Continuous Collision
//! Detection").
//!
//! Each vertex moves on a straight line from its position at t = 0 to its
//! position at t = 1. Contact is a root of a function F(t, u, v) that is
//! linear in each of its three parameters: for a vertex p and a face
//! (f0, f1, f2), F = p(t) − f0(t) − u (f1(t) − f0(t)) − v (f2(t) − f0(t))
//! with u, v ≥ 0, u + v ≤ 1; for edges (a0, a1) and (b0, b1),
//! F = a0(t) + u (a1(t) − a0(t)) − b0(t) − v (b1(t) − b0(t)). Such a
//! function is, over a box of parameters, a convex combination of its
//! values at the box's eight corners, so a plane that has every corner
//! value (widened by a bound on its rounding) strictly on one side cannot
//! hold a root. The search bisects parameter boxes, drops those that such a
//! plane separates from the origin (the three axes, and the primitives'
//! normal, along which a near miss shows at once), and stops at the first
//! box, in order of its earliest time, whose values lie within the
//! tolerance of the origin. A root's box is never dropped, so nothing that
//! touches is missed; coplanar, parallel and motionless configurations need
//! no special case. Corners are evaluated in f64 with a forward error
//! bound; where a plane may separate only within that bound (every value
//! on one side of it or within the bound of it), the corners in doubt are
//! evaluated again in double-double arithmetic, whose bound is 2⁻⁵⁰ times
//! smaller, so near misses far below f64's resolution are still told from
//! contacts.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;
use twofloat::TwoFloat;

use super::arithmetic::{
    along, lerp, magnitude, moving, rounding, side_of_axis, side_of_plane, Corners, Real, Side,
};
use super::memo::ExactMemo;

/// How close two primitives must come to count as touching, and how much
/// work one test may do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CcdOptions {
    /// Largest distance, per coordinate, at which the primitives are taken
    /// to touch; the reported time of impact is at most this far (in space)
    /// before the true one.
    pub tolerance: f64,
    /// Parameter boxes examined before the test gives up and reports a
    /// contact at the earliest time still in question (never a miss).
    pub max_boxes: u32,
}

impl Default for CcdOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-6,
            max_boxes: 10_000,
        }
    }
}

/// A vertex against a triangle, each corner at t = 0 and at t = 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexFace {
    pub vertex: [DVec3; 2],
    pub face: [[DVec3; 2]; 3],
}

/// Two edges, each end at t = 0 and at t = 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeEdge {
    pub a: [[DVec3; 2]; 2],
    pub b: [[DVec3; 2]; 2],
}

/// Parameter box: [lo, hi] for t, u and v.
type Domain = [[f64; 2]; 3];

/// F at corner `i`.
#[inline(always)]
fn corner_value(values: &Corners, i: usize) -> DVec3 {
    DVec3::new(values[0][i], values[1][i], values[2][i])
}

/// Relative rounding bound of one corner value, in units of the largest
/// coordinate magnitude times the arithmetic's unit: a forward error count
/// of the corner evaluation gives 22 for edge–edge (three interpolations
/// and a difference) and 52 for vertex–face; the bounds kept are about
/// twice that.
const EDGE_EDGE_ROUNDING: f64 = 48.0;
const VERTEX_FACE_ROUNDING: f64 = 96.0;

/// What a primitive pair gives the search.
pub(super) trait Primitives {
    /// Coordinate `axis` of F at the eight corners of `d`, index
    /// `4 t + 2 u + v` (F is computed coordinate by coordinate, so a
    /// coordinate alone costs a third of the vector).
    fn coordinate<T: Real>(&self, d: &Domain, axis: usize) -> [T; 8];
    /// Coordinate `axis` of F at one point `(t, u, v)`, by the same
    /// operations as [`coordinate`](Self::coordinate).
    fn at<T: Real>(&self, axis: usize, t: f64, u: f64, v: f64) -> T;
    /// F at the eight corners of `d`, in f64.
    #[inline(always)]
    fn corners(&self, d: &Domain) -> Corners {
        [
            self.coordinate::<f64>(d, 0),
            self.coordinate::<f64>(d, 1),
            self.coordinate::<f64>(d, 2),
        ]
    }
    /// A direction along which F's component does not depend on (u, v)
    /// halfway through the box's time.
    fn normal(&self, d: &Domain) -> DVec3;
    /// The forward error count of [`Primitives::corners`].
    const OPERATIONS: f64;
    /// Whether (u, v) is restricted to the triangle u + v ≤ 1.
    const SIMPLEX: bool;
    fn points(&self) -> impl Iterator<Item = &DVec3>;
}

impl Primitives for VertexFace {
    #[inline(always)]
    fn coordinate<T: Real>(&self, d: &Domain, axis: usize) -> [T; 8] {
        let mut out = [T::of(0.0); 8];
        for (i, &t) in d[0].iter().enumerate() {
            let p: T = moving(&self.vertex, axis, t);
            let f0: T = moving(&self.face[0], axis, t);
            let f1: T = moving(&self.face[1], axis, t);
            let f2: T = moving(&self.face[2], axis, t);
            let (e1, e2) = (f1 - f0, f2 - f0);
            for (j, &u) in d[1].iter().enumerate() {
                let fu = f0 + e1.scaled(u);
                for (k, &v) in d[2].iter().enumerate() {
                    out[4 * i + 2 * j + k] = p - (fu + e2.scaled(v));
                }
            }
        }
        out
    }

    #[inline(always)]
    fn at<T: Real>(&self, axis: usize, t: f64, u: f64, v: f64) -> T {
        let p: T = moving(&self.vertex, axis, t);
        let f0: T = moving(&self.face[0], axis, t);
        let f1: T = moving(&self.face[1], axis, t);
        let f2: T = moving(&self.face[2], axis, t);
        let (e1, e2) = (f1 - f0, f2 - f0);
        p - ((f0 + e1.scaled(u)) + e2.scaled(v))
    }

    /// The face's normal: F along it is the vertex's height over the
    /// face's plane.
    #[inline(always)]
    fn normal(&self, d: &Domain) -> DVec3 {
        let mid = 0.5 * (d[0][0] + d[0][1]);
        let at_mid = |p: &[DVec3; 2]| p[0].lerp(p[1], mid);
        let [f0, f1, f2] = &self.face;
        let (f0, f1, f2) = (at_mid(f0), at_mid(f1), at_mid(f2));
        (f1 - f0).cross(f2 - f0)
    }

    const OPERATIONS: f64 = VERTEX_FACE_ROUNDING;
    const SIMPLEX: bool = true;

    fn points(&self) -> impl Iterator<Item = &DVec3> {
        self.vertex.iter().chain(self.face.iter().flatten())
    }
}

impl Primitives for EdgeEdge {
    #[inline(always)]
    fn coordinate<T: Real>(&self, d: &Domain, axis: usize) -> [T; 8] {
        let mut out = [T::of(0.0); 8];
        for (i, &t) in d[0].iter().enumerate() {
            let (a0, a1): (T, T) = (moving(&self.a[0], axis, t), moving(&self.a[1], axis, t));
            let (b0, b1): (T, T) = (moving(&self.b[0], axis, t), moving(&self.b[1], axis, t));
            for (j, &u) in d[1].iter().enumerate() {
                let pa = lerp(a0, a1, u);
                for (k, &v) in d[2].iter().enumerate() {
                    out[4 * i + 2 * j + k] = pa - lerp(b0, b1, v);
                }
            }
        }
        out
    }

    #[inline(always)]
    fn at<T: Real>(&self, axis: usize, t: f64, u: f64, v: f64) -> T {
        let (a0, a1): (T, T) = (moving(&self.a[0], axis, t), moving(&self.a[1], axis, t));
        let (b0, b1): (T, T) = (moving(&self.b[0], axis, t), moving(&self.b[1], axis, t));
        lerp(a0, a1, u) - lerp(b0, b1, v)
    }

    /// The edges' common normal: F along it is the lines' distance.
    #[inline(always)]
    fn normal(&self, d: &Domain) -> DVec3 {
        let mid = 0.5 * (d[0][0] + d[0][1]);
        let at_mid = |p: &[DVec3; 2]| p[0].lerp(p[1], mid);
        let (a0, a1) = (at_mid(&self.a[0]), at_mid(&self.a[1]));
        let (b0, b1) = (at_mid(&self.b[0]), at_mid(&self.b[1]));
        (a1 - a0).cross(b1 - b0)
    }

    const OPERATIONS: f64 = EDGE_EDGE_ROUNDING;
    const SIMPLEX: bool = false;

    fn points(&self) -> impl Iterator<Item = &DVec3> {
        self.a.iter().chain(&self.b).flatten()
    }
}

/// Whether the box surely holds a root, by the Poincaré–Miranda theorem:
/// with F preconditioned by the inverse of its mean differences along the
/// box's edges (G = P F, still linear in each parameter, so its extremes on
/// a face are at the face's corners), each component of G is negative on
/// one face of its parameter and positive on the opposite one, beyond the
/// rounding of F (`rounding`) and of the product.
#[inline(always)]
fn holds_a_root(values: &Corners, rounding: DVec3) -> bool {
    let mean_difference = |bit: usize| {
        let mut sum = [0.0; 3];
        for (s, c) in sum.iter_mut().zip(values) {
            for i in (0..8).filter(|i| i & bit == 0) {
                *s += c[i | bit] - c[i];
            }
        }
        DVec3::from_array(sum) * 0.25
    };
    let jacobian =
        glam::DMat3::from_cols(mean_difference(4), mean_difference(2), mean_difference(1));
    let det = jacobian.determinant();
    if !det.is_normal() {
        return false;
    }
    let p = jacobian.inverse();
    let rows = [p.row(0), p.row(1), p.row(2)];
    (0..3).all(|axis| {
        let bit = 4 >> axis;
        let row = rows[axis];
        let g = |v: &DVec3| {
            let margin = row.abs().dot(rounding) + 4.0 * f64::EPSILON * row.abs().dot(v.abs());
            (row.dot(*v), margin)
        };
        let (mut low_negative, mut high_positive) = (true, true);
        let (mut low_positive, mut high_negative) = (true, true);
        for i in 0..8 {
            let (x, m) = g(&corner_value(values, i));
            if i & bit == 0 {
                low_negative &= x < -m;
                low_positive &= x > m;
            } else {
                high_positive &= x > m;
                high_negative &= x < -m;
            }
        }
        (low_negative && high_positive) || (low_positive && high_negative)
    })
}

/// What the search knows of a query's arithmetic.
struct Exactness {
    /// Rounding bound per coordinate of corner values in f64, then in
    /// double-double.
    rounding: [DVec3; 2],
    /// Coordinates in which every point of the query is the same: there F
    /// is exactly zero everywhere (interpolations between equal numbers and
    /// their differences are exact), so no plane along them is worth
    /// computing again.
    flat: [bool; 3],
}

impl Exactness {
    fn of<P: Primitives>(primitives: &P) -> Self {
        let size = magnitude(primitives.points());
        let first = primitives.points().next().copied().unwrap_or(DVec3::ZERO);
        Self {
            rounding: [
                rounding::<f64>(size, P::OPERATIONS),
                rounding::<TwoFloat>(size, P::OPERATIONS),
            ],
            flat: std::array::from_fn(|axis| primitives.points().all(|p| p[axis] == first[axis])),
        }
    }
}

/// A linear quantity of F whose sign may decide a box: one coordinate, or
/// the component along a plane's normal.
#[derive(Clone, Copy)]
enum Quantity {
    Axis(usize),
    Along(DVec3),
}

/// `quantity` at corner `i` of `d` in double-double, with the bound on its
/// rounding.
#[inline(always)]
fn exact_quantity<P: Primitives>(
    primitives: &P,
    d: &Domain,
    quantity: Quantity,
    exact_rounding: DVec3,
    i: usize,
    memo: &mut ExactMemo,
) -> (TwoFloat, TwoFloat) {
    let (t, u, v) = corner(d, i);
    let mut at = |axis| memo.coordinate(primitives, axis, t, u, v);
    match quantity {
        Quantity::Axis(axis) => (at(axis), TwoFloat::from(exact_rounding[axis])),
        Quantity::Along(normal) => along(&[at(0), at(1), at(2)], normal, exact_rounding),
    }
}

/// Whether `quantity` is, exactly, beyond its double-double rounding on
/// one side at every corner of `d`. `approx` holds each corner's f64 value
/// and its rounding bound. Only the corners that f64 leaves in doubt are
/// computed again, likeliest to fail first, so a true contact (an exact
/// zero) costs one corner.
#[inline(always)]
fn exactly_on_one_side<P: Primitives>(
    primitives: &P,
    d: &Domain,
    quantity: Quantity,
    exact_rounding: DVec3,
    approx: &[(f64, f64); 8],
    memo: &mut ExactMemo,
) -> bool {
    // A corner computed again for one side is kept for the other.
    let mut known: [Option<(TwoFloat, TwoFloat)>; 8] = [None; 8];
    'sides: for sign in [1.0, -1.0] {
        // In doubt: not surely beyond the rounding (NaN included).
        let mut doubt = [(0.0, 0usize); 8];
        let mut n = 0;
        for (i, &(q, m)) in approx.iter().enumerate() {
            let q = sign * q;
            if q < -m {
                continue 'sides;
            }
            if q.partial_cmp(&m) != Some(std::cmp::Ordering::Greater) {
                doubt[n] = (q, i);
                n += 1;
            }
        }
        doubt[..n].sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        for &(_, i) in &doubt[..n] {
            let (q, m) = match known[i] {
                Some(known) => known,
                None => {
                    let exact = exact_quantity(primitives, d, quantity, exact_rounding, i, memo);
                    known[i] = Some(exact);
                    exact
                }
            };
            if !q.scaled(sign).gt(m) {
                continue 'sides;
            }
        }
        return true;
    }
    false
}

/// The parameters of corner `i` of `d`.
#[inline(always)]
fn corner(d: &Domain, i: usize) -> (f64, f64, f64) {
    (d[0][i >> 2], d[1][(i >> 1) & 1], d[2][i & 1])
}

/// Whether some plane separates the box's values from the origin, beyond
/// doubt: decided in f64 where that suffices, else in double-double, for
/// only the coordinates whose f64 values leave a doubt.
#[inline(always)]
fn box_is_apart<P: Primitives>(
    primitives: &P,
    d: &Domain,
    values: &Corners,
    exactness: &Exactness,
    memo: &mut ExactMemo,
) -> bool {
    let [rounding, exact_rounding] = exactness.rounding;
    let axes = [
        side_of_axis(&values[0], rounding.x),
        side_of_axis(&values[1], rounding.y),
        side_of_axis(&values[2], rounding.z),
    ];
    if axes.contains(&Side::Apart) {
        return true;
    }
    let normal = primitives.normal(d);
    let plane = side_of_plane(values, normal, rounding);
    if plane == Side::Apart {
        return true;
    }
    for axis in 0..3 {
        if axes[axis] != Side::InDoubt || exactness.flat[axis] {
            continue;
        }
        let mut approx = [(0.0, 0.0); 8];
        for (a, &x) in approx.iter_mut().zip(&values[axis]) {
            *a = (x, rounding[axis]);
        }
        let quantity = Quantity::Axis(axis);
        if exactly_on_one_side(primitives, d, quantity, exact_rounding, &approx, memo) {
            return true;
        }
    }
    let along_flat = (0..3).all(|axis| exactness.flat[axis] || normal[axis] == 0.0);
    if plane != Side::InDoubt || along_flat {
        return false;
    }
    let mut approx = [(0.0, 0.0); 8];
    for (i, a) in approx.iter_mut().enumerate() {
        *a = along(&corner_value(values, i).to_array(), normal, rounding);
    }
    let quantity = Quantity::Along(normal);
    exactly_on_one_side(primitives, d, quantity, exact_rounding, &approx, memo)
}

/// Whether this CPU runs the search compiled for AVX2 and FMA (std caches
/// the answer).
#[cfg(target_arch = "x86_64")]
fn avx2_fma_available() -> bool {
    std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
}

impl VertexFace {
    /// Earliest time in [0, 1] at which the vertex comes within the
    /// tolerance of the face, or `None` if it never touches it.
    pub fn time_of_impact(&self, options: &CcdOptions, scratch: &mut CcdScratch) -> Option<f64> {
        scratch.search(self, options)
    }
}

impl EdgeEdge {
    /// Earliest time in [0, 1] at which the edges come within the
    /// tolerance of each other, or `None` if they never touch.
    pub fn time_of_impact(&self, options: &CcdOptions, scratch: &mut CcdScratch) -> Option<f64> {
        scratch.search(self, options)
    }
}

/// The search's boxes, kept between tests so that a test allocates
/// nothing once they have grown.
#[derive(Debug, Default)]
pub struct CcdScratch {
    /// Boxes of the first phase, depth first.
    stack: Vec<Domain>,
    /// Boxes of the second phase by earliest time first, then deepest
    /// first; `t ≥ 0`, so the bits of `t` order as the numbers do.
    queue: BinaryHeap<(Reverse<u64>, u32, Boxed)>,
    memo: ExactMemo,
}

/// A parameter box in the queue, with the order the heap needs (ties
/// between equal times are broken arbitrarily but deterministically).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Boxed(Domain);

impl Eq for Boxed {}

impl PartialOrd for Boxed {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Boxed {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        let key = |d: &Domain| d.map(|r| r.map(f64::to_bits));
        key(&self.0).cmp(&key(&other.0))
    }
}

/// What one box of the search comes to.
enum Step {
    /// No root in it.
    Apart,
    /// Within the tolerance (or too small to split): a contact at its
    /// earliest time.
    Contact,
    /// Its two halves, earlier first where it was split in time.
    Split([Domain; 2]),
}

/// Decides one box: apart, a contact, or split along the parameter along
/// which F varies most (time alone once the box surely holds a root: then
/// only the time needs narrowing to the tolerance).
#[inline(always)]
fn step<P: Primitives>(
    primitives: &P,
    d: &Domain,
    exactness: &Exactness,
    options: &CcdOptions,
    memo: &mut ExactMemo,
) -> Step {
    let values = primitives.corners(d);
    if box_is_apart(primitives, d, &values, exactness, memo) {
        return Step::Apart;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for axis in 0..3 {
        for &x in &values[axis] {
            lo[axis] = lo[axis].min(x);
            hi[axis] = hi[axis].max(x);
        }
    }
    let (lo, hi) = (DVec3::from_array(lo), DVec3::from_array(hi));
    let rounding = exactness.rounding[0];
    let tolerance = DVec3::splat(options.tolerance) - rounding;
    if lo.cmpge(-tolerance).all() && hi.cmple(tolerance).all() {
        return Step::Contact;
    }
    let spread = |axis: usize| {
        let bit = 4 >> axis;
        let mut spread: f64 = 0.0;
        for c in &values {
            for i in (0..8).filter(|i| i & bit == 0) {
                spread = spread.max((c[i | bit] - c[i]).abs());
            }
        }
        spread
    };
    let inside = !P::SIMPLEX || d[1][1] + d[2][1] <= 1.0;
    let axis = if inside && holds_a_root(&values, rounding) {
        if spread(0) <= options.tolerance {
            return Step::Contact;
        }
        0
    } else {
        let spreads = [spread(0), spread(1), spread(2)];
        (0..3)
            .max_by(|&x, &y| spreads[x].total_cmp(&spreads[y]))
            .unwrap_or(0)
    };
    let [a, b] = d[axis];
    let mid = 0.5 * (a + b);
    if !(a < mid && mid < b) {
        return Step::Contact;
    }
    let (mut early, mut late) = (*d, *d);
    early[axis] = [a, mid];
    late[axis] = [mid, b];
    Step::Split([early, late])
}

impl CcdScratch {
    /// Finds the earliest contact in two phases. First depth first, earlier
    /// half first, to a first contact: quick, and it does not spread over
    /// a contact set that fills a range of parameters at one time (such as
    /// parallel edges meeting along a segment), as a search by earliest
    /// box does. Its time bounds the answer, but depth first it need not be
    /// the earliest (the earlier half in u can be the later in time), so
    /// the boxes left, cut to end there, are then searched earliest first:
    /// the first contact of that phase is the answer. A box holding a root
    /// is never dropped, so the answer is at most the earliest root's time.
    fn search<P: Primitives>(&mut self, primitives: &P, options: &CcdOptions) -> Option<f64> {
        #[cfg(target_arch = "x86_64")]
        if avx2_fma_available() {
            // SAFETY: the CPU has AVX2 and FMA.
            return unsafe { self.search_avx2(primitives, options) };
        }
        self.search_inlined(primitives, options)
    }

    /// The search compiled for AVX2 with fused multiply-adds: the corner
    /// tests run over eight values in two registers, and double-double
    /// products, built on fused multiply-adds, get them as instructions
    /// instead of calls into a software `fma` (answers are the same to the
    /// bit: a fused multiply-add is exact either way).
    ///
    /// # Safety
    /// The CPU must have AVX2 and FMA ([`avx2_fma_available`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn search_avx2<P: Primitives>(
        &mut self,
        primitives: &P,
        options: &CcdOptions,
    ) -> Option<f64> {
        self.search_inlined(primitives, options)
    }

    /// The search itself, inlined into its callers, and what it calls
    /// inlined into it, so that [`search_avx2`](Self::search_avx2)
    /// compiles all of it with its features. Hence no closures passed
    /// through `array::map` or `Option::get_or_insert_with` on this path:
    /// such a closure is compiled apart, without the features, and its
    /// double-double products went back to calls into a software `fma`.
    #[inline(always)]
    fn search_inlined<P: Primitives>(
        &mut self,
        primitives: &P,
        options: &CcdOptions,
    ) -> Option<f64> {
        let exactness = Exactness::of(primitives);
        self.memo.start();
        let in_domain = |d: &Domain| !P::SIMPLEX || d[1][0] + d[2][0] <= 1.0;
        self.stack.clear();
        self.queue.clear();
        self.stack.push([[0.0, 1.0]; 3]);
        let mut examined = 0u32;
        let mut first = None;
        while let Some(d) = self.stack.pop() {
            examined += 1;
            if examined > options.max_boxes {
                // Out of work: nothing earlier than the earliest box left
                // is excluded.
                return Some(self.stack.iter().map(|d| d[0][0]).fold(d[0][0], f64::min));
            }
            match step(primitives, &d, &exactness, options, &mut self.memo) {
                Step::Apart => {}
                Step::Contact => {
                    first = Some(d[0][0]);
                    break;
                }
                Step::Split([early, late]) => {
                    self.stack
                        .extend([late, early].into_iter().filter(in_domain));
                }
            }
        }
        let best = first?;
        let key = |d: &Domain, depth: u32| (Reverse(d[0][0].to_bits()), depth, Boxed(*d));
        self.queue.extend(self.stack.drain(..).map(|d| key(&d, 0)));
        while let Some((_, depth, Boxed(mut d))) = self.queue.pop() {
            if d[0][0] >= best {
                break;
            }
            examined += 1;
            if examined > options.max_boxes {
                return Some(d[0][0]);
            }
            d[0][1] = d[0][1].min(best);
            match step(primitives, &d, &exactness, options, &mut self.memo) {
                Step::Apart => {}
                Step::Contact => return Some(d[0][0]),
                Step::Split(halves) => {
                    let halves = halves.into_iter().filter(in_domain);
                    self.queue.extend(halves.map(|h| key(&h, depth + 1)));
                }
            }
        }
        Some(best)
    }
}

#[cfg(test)]
mod tests;
