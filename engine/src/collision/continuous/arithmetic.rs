//! The arithmetic of the inclusion-based search: corner values in f64 or
//! double-double, bounds on their rounding, and on which side of a plane
//! a box's values lie once that rounding is counted.

use std::ops::{Add, Mul, Sub};

use glam::DVec3;
use twofloat::TwoFloat;

/// The arithmetic corners are evaluated in: f64, or double-double where
/// f64 cannot decide.
pub(super) trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self>
{
    /// Bound on the relative error of one operation: 2⁻⁵³ for f64; for
    /// double-double, Joldes, Muller and Popescu (2017) bound addition by
    /// 3u² + 13u³ and multiplication by 5u², rounded up here to 8u².
    const UNIT: f64;
    fn of(x: f64) -> Self;
    /// `self * s`: for double-double, a product by a double, which is
    /// cheaper than by a double-double (two fused multiply-adds, not three)
    /// and within the same bound.
    fn scaled(self, s: f64) -> Self;
    fn abs(self) -> Self;
    /// `self > other`; false where either is NaN.
    fn gt(self, other: Self) -> bool;
}

impl Real for f64 {
    const UNIT: f64 = f64::EPSILON / 2.0;
    fn of(x: f64) -> Self {
        x
    }
    #[inline]
    fn scaled(self, s: f64) -> Self {
        self * s
    }
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline]
    fn gt(self, other: Self) -> bool {
        self > other
    }
}

impl Real for TwoFloat {
    const UNIT: f64 = 8.0 * (f64::EPSILON / 2.0) * (f64::EPSILON / 2.0);
    fn of(x: f64) -> Self {
        TwoFloat::from(x)
    }
    #[inline]
    fn scaled(self, s: f64) -> Self {
        self * s
    }
    fn abs(self) -> Self {
        TwoFloat::abs(&self)
    }
    /// By the words, high first: the arithmetic's results are normalised
    /// (the high word is the sum rounded), where that is the numbers'
    /// order. `TwoFloat`'s own comparison checks both operands' validity
    /// first, which calls `exp2`: 8% of the sample queries' time.
    #[inline]
    fn gt(self, other: Self) -> bool {
        let (a, b) = ((self.hi(), self.lo()), (other.hi(), other.lo()));
        a.0 > b.0 || (a.0 == b.0 && a.1 > b.1)
    }
}

pub(super) type V<T> = [T; 3];

/// F at a box's eight corners, coordinate by coordinate (`[axis][corner]`):
/// every test runs over eight contiguous numbers, two AVX registers.
pub(super) type Corners = [[f64; 8]; 3];

/// `a + s (b − a)`, the form whose rounding the bounds below count.
#[inline(always)]
pub(super) fn lerp<T: Real>(a: T, b: T, s: f64) -> T {
    a + (b - a).scaled(s)
}

/// Coordinate `axis` of a point moving from `p[0]` to `p[1]`, at time `t`.
#[inline(always)]
pub(super) fn moving<T: Real>(p: &[DVec3; 2], axis: usize, t: f64) -> T {
    lerp(T::of(p[0][axis]), T::of(p[1][axis]), t)
}

/// Largest coordinate magnitude per axis over the given points.
pub(super) fn magnitude<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> DVec3 {
    points.into_iter().fold(DVec3::ZERO, |m, p| m.max(p.abs()))
}

/// The rounding bound per coordinate of corner values computed in `T`.
pub(super) fn rounding<T: Real>(magnitude: DVec3, operations: f64) -> DVec3 {
    magnitude * (operations * T::UNIT) + DVec3::splat(operations * f64::MIN_POSITIVE)
}

/// Where a plane through the origin lies against a box's eight values,
/// given a bound on their rounding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Side {
    /// Every value beyond its rounding on one side: no root in the box.
    Apart,
    /// Every value on one side or within its rounding of the plane: the
    /// exact values may be apart (a value rounded to zero may be a near
    /// miss of 1e-17, as in the benchmark's cliff edges).
    InDoubt,
    /// Values at or beyond their rounding on both sides.
    Straddles,
}

/// `v`'s component along `n` (unnormalised), and the bound on its
/// rounding: `v`'s coordinates are within `rounding` of exact, and the
/// product's own rounding is added.
#[inline(always)]
pub(super) fn along<T: Real>(v: &V<T>, n: DVec3, rounding: DVec3) -> (T, T) {
    let an = n.abs();
    let dot = v[0].scaled(n.x) + v[1].scaled(n.y) + v[2].scaled(n.z);
    let size = v[0].abs().scaled(an.x) + v[1].abs().scaled(an.y) + v[2].abs().scaled(an.z);
    // Three products and two sums, each within UNIT of its result.
    (dot, T::of(rounding.dot(an)) + size * T::of(6.0 * T::UNIT))
}

/// Where the plane with normal `n` lies against eight values given
/// coordinate by coordinate (`[axis][corner]`), whose coordinates are
/// within `rounding` of exact; the dot products' own rounding is added.
#[inline(always)]
pub(super) fn side_of_plane(values: &Corners, n: DVec3, rounding: DVec3) -> Side {
    let (mut above, mut below, mut clear) = (true, true, true);
    let [xs, ys, zs] = values;
    for (i, &x) in xs.iter().enumerate() {
        let (dot, margin) = along(&[x, ys[i], zs[i]], n, rounding);
        above &= -dot < margin;
        below &= dot < margin;
        clear &= dot > margin || -dot > margin;
    }
    if clear && (above || below) {
        Side::Apart
    } else if above || below {
        Side::InDoubt
    } else {
        Side::Straddles
    }
}

/// The same for a coordinate plane, given that coordinate's values.
#[inline(always)]
pub(super) fn side_of_axis(values: &[f64; 8], rounding: f64) -> Side {
    let (mut lo, mut hi) = (values[0], values[0]);
    for &v in &values[1..] {
        if v < lo {
            lo = v;
        }
        if v > hi {
            hi = v;
        }
    }
    if lo > rounding || 0.0 - hi > rounding {
        Side::Apart
    } else if 0.0 - lo < rounding || hi < rounding {
        Side::InDoubt
    } else {
        Side::Straddles
    }
}
