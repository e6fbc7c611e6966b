use glam::{Vec3, Vec3A};
use rayon::prelude::*;

/// A ray `origin + t * dir` for `t` in `[t_min, t_max]`.
///
/// The direction need not be normalised; `t` is measured in units of its
/// length. Zero components are fine: traversal treats them exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3A,
    pub dir: Vec3A,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    /// A ray from `origin` along `dir` for `t` in `[0, inf)`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin: origin.into(),
            dir: dir.into(),
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// The segment from `a` to `b`: `t` runs over `[0, 1]`.
    pub fn segment(a: Vec3, b: Vec3) -> Self {
        Self {
            origin: a.into(),
            dir: (b - a).into(),
            t_min: 0.0,
            t_max: 1.0,
        }
    }

    pub fn with_range(mut self, t_min: f32, t_max: f32) -> Self {
        self.t_min = t_min;
        self.t_max = t_max;
        self
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.dir * t
    }

    /// A ray can be traced when its origin and direction are finite, its
    /// direction is not zero and its range is not NaN. Rays that fail this
    /// hit nothing.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.dir != Vec3A::ZERO
            && !self.t_min.is_nan()
            && !self.t_max.is_nan()
    }
}

/// Answers a query for many rays in parallel, in chunks large enough that
/// scheduling costs less than tracing.
pub fn trace_batch<T: Send>(rays: &[Ray], query: impl Fn(&Ray) -> T + Sync + Send) -> Vec<T> {
    rays.par_iter().with_min_len(256).map(query).collect()
}
