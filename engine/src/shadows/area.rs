//! Area lights and the light samples every method shares.
//!
//! A receiver sees the fraction of `S x S` stratified samples of the light
//! it has a clear segment to. The samples are jittered from a random stream
//! named by the receiver's index and the query's seed, so every method (and
//! every run) draws the same samples for the same pixel: selective and
//! full ray tracing are comparable sample for sample.

use glam::{DVec3, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::{Error, Result};

/// The shape of an area light around its centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AreaShape {
    /// The parallelogram `centre + a u + b v`, `a, b` in `[-1, 1]`: `u`
    /// and `v` are half edges.
    Rectangle { u: Vec3, v: Vec3 },
    /// A flat disk facing along `normal`.
    Disk { normal: Vec3, radius: f32 },
    /// A sphere, seen from each receiver as its outline: the disk through
    /// the centre square to the receiver's direction.
    Sphere { radius: f32 },
}

/// A light with extent: it casts penumbrae.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLight {
    pub centre: Vec3,
    pub shape: AreaShape,
}

/// Largest light extent accepted (a half edge or radius), metres.
const MAX_EXTENT: f32 = 1e6;

impl AreaLight {
    pub fn check(&self) -> Result<()> {
        let bad = |reason: &str| {
            Err(Error::InvalidOption {
                field: "light".into(),
                reason: reason.into(),
            })
        };
        if !self.centre.is_finite() || self.centre.abs().max_element() > 1e15 {
            return Err(Error::InvalidPosition {
                what: "light".into(),
                value: format!("{:?}", self.centre),
            });
        }
        let extent_ok = |x: f32| x.is_finite() && x > 0.0 && x <= MAX_EXTENT;
        match self.shape {
            AreaShape::Rectangle { u, v } => {
                let area = u.as_dvec3().cross(v.as_dvec3()).length();
                if !(extent_ok(u.length()) && extent_ok(v.length())) {
                    return bad(
                        "a rectangle's half edges must be finite, non-zero and at most 1e6 m",
                    );
                }
                if area <= 1e-6 * u.length() as f64 * v.length() as f64 {
                    return bad("a rectangle's half edges must not be parallel");
                }
            }
            AreaShape::Disk { normal, radius } => {
                if !normal.is_finite() || normal.length() < 1e-6 {
                    return bad("a disk needs a finite, non-zero normal");
                }
                if !extent_ok(radius) {
                    return bad("a radius must be finite, positive and at most 1e6 m");
                }
            }
            AreaShape::Sphere { radius } => {
                if !extent_ok(radius) {
                    return bad("a radius must be finite, positive and at most 1e6 m");
                }
            }
        }
        Ok(())
    }

    /// The parallelogram holding every sample `receiver` draws: centre and
    /// half edges, in `f64`.
    pub(super) fn frame(&self, receiver: Vec3) -> [DVec3; 3] {
        let c = self.centre.as_dvec3();
        match self.shape {
            AreaShape::Rectangle { u, v } => [c, u.as_dvec3(), v.as_dvec3()],
            AreaShape::Disk { normal, radius } => disk_frame(c, normal.as_dvec3(), radius),
            AreaShape::Sphere { radius } => {
                let to_receiver = receiver.as_dvec3() - c;
                let axis = if to_receiver == DVec3::ZERO {
                    DVec3::Z
                } else {
                    to_receiver
                };
                disk_frame(c, axis, radius)
            }
        }
    }

    /// Writes the `side x side` samples receiver `index` draws under
    /// `seed` into `out` (cleared first).
    pub(super) fn samples(
        &self,
        receiver: Vec3,
        index: u64,
        seed: u64,
        side: u32,
        out: &mut Vec<Vec3>,
    ) {
        out.clear();
        let [c, a, b] = self.frame(receiver);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index);
        let n = side as f64;
        let disk = !matches!(self.shape, AreaShape::Rectangle { .. });
        for i in 0..side {
            for j in 0..side {
                let x = 2.0 * (i as f64 + rng.random::<f64>()) / n - 1.0;
                let y = 2.0 * (j as f64 + rng.random::<f64>()) / n - 1.0;
                let (x, y) = if disk { concentric(x, y) } else { (x, y) };
                out.push((c + a * x + b * y).as_vec3());
            }
        }
    }
}

/// A disk's bounding square: half edges of length `radius` square to
/// `axis`.
fn disk_frame(c: DVec3, axis: DVec3, radius: f32) -> [DVec3; 3] {
    let (a, b) = axis.normalize().any_orthonormal_pair();
    let r = radius as f64;
    [c, a * r, b * r]
}

/// Shirley and Chiu's concentric map of the square `[-1, 1]^2` onto the
/// unit disk: strata stay compact, so stratification survives.
fn concentric(x: f64, y: f64) -> (f64, f64) {
    use std::f64::consts::FRAC_PI_4;
    if x == 0.0 && y == 0.0 {
        return (0.0, 0.0);
    }
    let (r, theta) = if x.abs() > y.abs() {
        (x, FRAC_PI_4 * (y / x))
    } else {
        (y, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (x / y))
    };
    (r * theta.cos(), r * theta.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lights() -> [AreaLight; 3] {
        let centre = Vec3::new(1.0, 2.0, 3.0);
        [
            AreaLight {
                centre,
                shape: AreaShape::Rectangle {
                    u: Vec3::new(0.5, 0.0, 0.0),
                    v: Vec3::new(0.1, 0.25, 0.0),
                },
            },
            AreaLight {
                centre,
                shape: AreaShape::Disk {
                    normal: Vec3::new(0.0, 1.0, 1.0),
                    radius: 0.3,
                },
            },
            AreaLight {
                centre,
                shape: AreaShape::Sphere { radius: 0.3 },
            },
        ]
    }

    #[test]
    fn samples_are_stratified_on_the_shape_and_repeat_per_receiver() {
        let receiver = Vec3::new(-2.0, 0.0, 0.5);
        for light in lights() {
            let mut s = Vec::new();
            light.samples(receiver, 7, 3, 4, &mut s);
            assert_eq!(s.len(), 16);
            let [c, a, b] = light.frame(receiver);
            let normal = a.cross(b).normalize();
            for p in &s {
                let d = p.as_dvec3() - c;
                assert!(d.dot(normal).abs() < 1e-6, "{light:?} off its plane");
                match light.shape {
                    AreaShape::Rectangle { .. } => {
                        // Coordinates in the (a, b) frame lie in [-1, 1].
                        let m =
                            glam::DMat2::from_cols_array(&[a.dot(a), a.dot(b), a.dot(b), b.dot(b)]);
                        let xy = m.inverse() * glam::DVec2::new(d.dot(a), d.dot(b));
                        assert!(xy.abs().max_element() <= 1.0 + 1e-6, "{xy}");
                    }
                    _ => assert!(d.length() <= 0.3 + 1e-6),
                }
            }
            let mut again = Vec::new();
            light.samples(receiver, 7, 3, 4, &mut again);
            assert_eq!(s, again);
            light.samples(receiver, 8, 3, 4, &mut again);
            assert_ne!(s, again);
            light.samples(receiver, 7, 4, 4, &mut again);
            assert_ne!(s, again);
        }
    }

    #[test]
    fn a_sphere_faces_each_receiver() {
        let light = lights()[2];
        for receiver in [
            Vec3::new(9.0, 2.0, 3.0),
            Vec3::new(1.0, 2.0, -5.0),
            light.centre,
        ] {
            let [c, a, b] = light.frame(receiver);
            let axis = receiver.as_dvec3() - c;
            assert!(a.dot(axis).abs() < 1e-9 && b.dot(axis).abs() < 1e-9);
            assert!((a.length() - 0.3).abs() < 1e-7 && a.dot(b).abs() < 1e-9);
        }
    }

    #[test]
    fn bad_lights_are_refused() {
        let centre = Vec3::ZERO;
        let bad = [
            AreaShape::Rectangle {
                u: Vec3::X,
                v: Vec3::X * 2.0,
            },
            AreaShape::Rectangle {
                u: Vec3::ZERO,
                v: Vec3::Y,
            },
            AreaShape::Disk {
                normal: Vec3::ZERO,
                radius: 1.0,
            },
            AreaShape::Disk {
                normal: Vec3::Z,
                radius: f32::NAN,
            },
            AreaShape::Sphere { radius: 0.0 },
            AreaShape::Sphere { radius: 1e7 },
        ];
        for shape in bad {
            assert!(AreaLight { centre, shape }.check().is_err(), "{shape:?}");
        }
        let shape = AreaShape::Sphere { radius: 1.0 };
        assert!(AreaLight {
            centre: Vec3::NAN,
            shape
        }
        .check()
        .is_err());
        for light in lights() {
            light.check().unwrap();
        }
    }
}
