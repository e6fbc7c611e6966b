use glam::{Vec3, Vec3A};

use super::RigidTransform;

/// An axis-aligned bounding box. The empty box has `min = +inf`, `max = -inf`
/// so that growing it by any point gives that point's box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3A,
    pub max: Vec3A,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3A, max: Vec3A) -> Self {
        Self { min, max }
    }

    /// The box of a triangle.
    #[inline]
    pub fn of_triangle(a: Vec3A, b: Vec3A, c: Vec3A) -> Self {
        Self {
            min: a.min(b).min(c),
            max: a.max(b).max(c),
        }
    }

    /// The box of a set of points.
    pub fn of_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points
            .into_iter()
            .fold(Self::EMPTY, |b, p| b.grow(p.into()))
    }

    #[inline]
    pub fn grow(self, p: Vec3A) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    #[inline]
    pub fn extent(&self) -> Vec3A {
        (self.max - self.min).max(Vec3A::ZERO)
    }

    #[inline]
    pub fn center(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    /// Surface area; zero for an empty box.
    #[inline]
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Half the surface area: what the SAH compares, one multiply cheaper.
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    pub fn contains_point(&self, p: Vec3A) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    pub fn contains(&self, o: &Aabb) -> bool {
        o.min.cmpge(self.min).all() && o.max.cmple(self.max).all()
    }

    /// Whether the boxes overlap or touch.
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && self.max.cmpge(o.min).all()
    }

    /// The box of this box moved by `t`: it surely contains the moved
    /// contents, widened by a few ulps of its magnitude since rotation
    /// rounds. An empty box stays empty.
    pub fn transformed(&self, t: &RigidTransform) -> Aabb {
        if self.is_empty() {
            return Aabb::EMPTY;
        }
        let moved = self
            .corners()
            .iter()
            .fold(Aabb::EMPTY, |acc, &c| acc.grow(t.transform_point(c)));
        let m = moved.min.abs().max(moved.max.abs()).max_element();
        let pad = Vec3A::splat(m * 4.0 * f32::EPSILON);
        Aabb::new(moved.min - pad, moved.max + pad)
    }

    /// The eight corners, for transforming a box.
    pub fn corners(&self) -> [Vec3A; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3A::new(a.x, a.y, a.z),
            Vec3A::new(b.x, a.y, a.z),
            Vec3A::new(a.x, b.y, a.z),
            Vec3A::new(b.x, b.y, a.z),
            Vec3A::new(a.x, a.y, b.z),
            Vec3A::new(b.x, a.y, b.z),
            Vec3A::new(a.x, b.y, b.z),
            Vec3A::new(b.x, b.y, b.z),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_box_grows_to_a_point() {
        let b = Aabb::EMPTY.grow(Vec3A::new(1.0, 2.0, 3.0));
        assert_eq!(b.min, b.max);
        assert_eq!(b.surface_area(), 0.0);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
    }

    #[test]
    fn unit_cube_area() {
        let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
        assert_eq!(b.surface_area(), 6.0);
        assert_eq!(b.half_area(), 3.0);
        assert!(b.contains_point(Vec3A::splat(0.5)));
        assert!(b.contains_point(Vec3A::ONE));
        assert!(!b.contains_point(Vec3A::splat(1.1)));
    }
}
