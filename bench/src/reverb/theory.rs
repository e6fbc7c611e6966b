//! The answers frusta's hybrid impulse response is measured against, none
//! computed by frusta's acoustics: Sabine's and Eyring's diffuse-field
//! decay times from the scene's areas and absorption, and for box rooms
//! the exact image-source echogram, summed in f64 to a given time.

use frusta_engine::acoustics::signal::RoomParameters;
use frusta_engine::scene::{Scene, BAND_COUNT};
use glam::DVec3;

/// Sabine's and Eyring's T60 per band, s: `0.161 V / A` with
/// `A = Σ S_i α_i` and `A = −S ln(1 − ᾱ)`. No air absorption.
pub fn diffuse_field(
    scene: &Scene,
    volume: f64,
    speed: f64,
) -> ([f64; BAND_COUNT], [f64; BAND_COUNT]) {
    let mut area = 0.0;
    let mut absorbing = [0.0; BAND_COUNT];
    for object in &scene.objects {
        for t in 0..object.mesh.triangle_count() {
            let a = f64::from(object.mesh.area(t));
            area += a;
            let m = &scene.materials[object.materials[t] as usize];
            for (sum, alpha) in absorbing.iter_mut().zip(m.absorption) {
                *sum += a * f64::from(alpha);
            }
        }
    }
    let constant = 24.0 * 10f64.ln() / speed;
    let sabine = absorbing.map(|a| constant * volume / a);
    let eyring = absorbing.map(|a| constant * volume / (-area * (1.0 - a / area).ln()));
    (sabine, eyring)
}

/// A box room's walls by axis: the absorption per band of the low
/// (`min`) and high (`max`) wall of each axis.
pub struct BoxWalls {
    pub min: DVec3,
    pub max: DVec3,
    /// `absorption[axis][0 low | 1 high][band]`.
    pub absorption: [[[f64; BAND_COUNT]; 2]; 3],
    /// The same walls' scattering.
    pub scattering: [[[f64; BAND_COUNT]; 2]; 3],
}

impl BoxWalls {
    /// The walls of a scene that is one axis-aligned box, read off its
    /// triangles: `None` if any triangle lies off the box's faces.
    pub fn of(scene: &Scene) -> Option<Self> {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for o in &scene.objects {
            for p in o.mesh.positions() {
                let p = o.transform.transform_point((*p).into()).as_dvec3();
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        let mut absorption = [[[f64::NAN; BAND_COUNT]; 2]; 3];
        let mut scattering = [[[0.0; BAND_COUNT]; 2]; 3];
        for o in &scene.objects {
            for t in 0..o.mesh.triangle_count() {
                let c = o
                    .mesh
                    .corners(t)
                    .map(|p| o.transform.transform_point(p).as_dvec3());
                let tol = 1e-6 * (hi - lo).max_element();
                let (axis, side) = (0..3).find_map(|a| {
                    let on = |v: f64| c.iter().all(|p| (p[a] - v).abs() <= tol);
                    if on(lo[a]) {
                        Some((a, 0))
                    } else if on(hi[a]) {
                        Some((a, 1))
                    } else {
                        None
                    }
                })?;
                let m = &scene.materials[o.materials[t] as usize];
                absorption[axis][side] = m.absorption.map(f64::from);
                scattering[axis][side] = m.scattering.map(f64::from);
            }
        }
        absorption
            .iter()
            .flatten()
            .all(|w| w.iter().all(|a| a.is_finite()))
            .then_some(Self {
                min: lo,
                max: hi,
                absorption,
                scattering,
            })
    }

    /// ISO 3382 parameters per band of the exact image-source echogram, and
    /// the echogram
    /// from `source` to `listener` up to `until_s`, binned at 0.1 ms:
    /// image `m` on an axis of length `L` lies at `m L + (x or L − x)`
    /// after `⌈|m|/2⌉` reflections off one wall and `⌊|m|/2⌋` off the
    /// other.
    pub fn image_sources(
        &self,
        source: DVec3,
        listener: DVec3,
        speed: f64,
        until_s: f64,
    ) -> Vec<(RoomParameters, Vec<(f64, f64)>)> {
        let reach = until_s * speed;
        let size = self.max - self.min;
        let s = source - self.min;
        let l = listener - self.min;
        let step = 1e-4;
        let mut bins = vec![[0.0f64; BAND_COUNT]; (until_s / step) as usize + 1];
        // Per axis and image index: the offset to the listener and the
        // energy factor per band.
        let axis = |a: usize| -> Vec<(f64, [f64; BAND_COUNT])> {
            let n = (reach / size[a]).ceil() as i64 + 1;
            (-n..=n)
                .map(|m| {
                    let x = m as f64 * size[a] + if m % 2 == 0 { s[a] } else { size[a] - s[a] };
                    let (first, second) = (m.unsigned_abs().div_ceil(2), m.unsigned_abs() / 2);
                    // m > 0 meets the high wall first, m < 0 the low one.
                    let (high, low) = if m > 0 {
                        (first, second)
                    } else {
                        (second, first)
                    };
                    let mut factor = [1.0; BAND_COUNT];
                    for (b, f) in factor.iter_mut().enumerate() {
                        *f = (1.0 - self.absorption[a][0][b]).powi(low as i32)
                            * (1.0 - self.absorption[a][1][b]).powi(high as i32);
                    }
                    (x - l[a], factor)
                })
                .collect()
        };
        let (xs, ys, zs) = (axis(0), axis(1), axis(2));
        for (dx, fx) in &xs {
            if dx.abs() > reach {
                continue;
            }
            for (dy, fy) in &ys {
                if dx * dx + dy * dy > reach * reach {
                    continue;
                }
                for (dz, fz) in &zs {
                    let d2 = dx * dx + dy * dy + dz * dz;
                    if d2 > reach * reach {
                        continue;
                    }
                    let bin = &mut bins[(d2.sqrt() / speed / step) as usize];
                    for b in 0..BAND_COUNT {
                        bin[b] += fx[b] * fy[b] * fz[b] / d2;
                    }
                }
            }
        }
        (0..BAND_COUNT)
            .map(|b| {
                let echogram: Vec<(f64, f64)> = bins
                    .iter()
                    .enumerate()
                    .filter(|(_, e)| e[b] > 0.0)
                    .map(|(k, e)| ((k as f64 + 0.5) * step, e[b]))
                    .collect();
                let parameters = RoomParameters::from_energy(&echogram).unwrap_or_default();
                (parameters, echogram)
            })
            .collect()
    }
}
