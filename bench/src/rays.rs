//! The ray sets: coherent (a pinhole camera, 8x8 tiles) and incoherent
//! (random origins in the mesh bounds, random directions), both with
//! `t` in `[0, inf)` and unit directions, so `t` is a distance for every
//! implementation.

use frusta_engine::geometry::{Aabb, Ray};
use glam::Vec3;

/// SplitMix64: a tiny deterministic PRNG, enough for benchmark rays.
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// The image size for about `n` camera rays: a square whose side is a
/// multiple of the 8-pixel tile.
pub fn camera_size(n: usize) -> (usize, usize) {
    let side = (((n as f64).sqrt() / 8.0).round() as usize).max(1) * 8;
    (side, side)
}

/// A pinhole camera outside the model looking at its center, the bounding
/// sphere filling the view; `w x h` rays in 8x8 tiles, row-major within a
/// tile and tiles row-major (`w`, `h` multiples of 8).
pub fn coherent(bounds: &Aabb, w: usize, h: usize) -> Vec<Ray> {
    let center = Vec3::from(bounds.center());
    let radius = (0.5 * bounds.extent().length()).max(1e-6);
    let view = Vec3::new(0.35, 0.3, 1.0).normalize();
    let dist = 2.5 * radius;
    let eye = center + view * dist;
    let forward = -view;
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    // Half-angle at which the bounding sphere just fits.
    let tan_half = (radius / dist).asin().tan();
    let mut rays = Vec::with_capacity(w * h);
    for ty in (0..h).step_by(8) {
        for tx in (0..w).step_by(8) {
            for y in ty..ty + 8 {
                for x in tx..tx + 8 {
                    let sx = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * tan_half;
                    let sy = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * tan_half;
                    let dir = (forward + right * sx + up * sy).normalize();
                    rays.push(Ray::new(eye, dir));
                }
            }
        }
    }
    rays
}

/// `n` rays with origins uniform in `bounds` and directions uniform on the
/// unit sphere (fixed seed).
pub fn incoherent(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = SplitMix64::new(seed);
    let (lo, ext) = (Vec3::from(bounds.min), Vec3::from(bounds.extent()));
    (0..n)
        .map(|_| {
            let o = lo + ext * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let z = 2.0 * rng.next_f32() - 1.0;
            let phi = std::f32::consts::TAU * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray::new(o, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}
