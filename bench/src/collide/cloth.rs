//! The procedural cloth: a square sheet draped over a sphere, its skirt
//! folding back up past itself as the frames go on, so that it crosses
//! itself along a curve that moves a little each frame (coherent motion,
//! as a simulation's steps are).

use std::f32::consts::{FRAC_PI_2, PI};

use glam::Vec3;

/// Radius of the sphere the cloth lies on; the sheet is 2 x 2.
const SPHERE: f32 = 0.5;
/// Depth below the equator where the skirt folds.
const FOLD_DEPTH: f32 = 0.2;

/// The sheet's triangles: `n` x `n` quads, two triangles each, on
/// `(n + 1)^2` shared vertices.
pub fn triangles(n: usize) -> Vec<[u32; 3]> {
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut triangles = Vec::with_capacity(2 * n * n);
    for j in 0..n {
        for i in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    triangles
}

/// The vertices at animation time `s` in `[0, 1]`: the part within a
/// quarter circumference of the top wraps the sphere, the rest hangs as a
/// skirt, and the skirt below the fold line turns up by an angle growing
/// from 165 to 195 degrees (through flat against the skirt), waving in and
/// out across it, so the flap crosses the skirt along curves.
pub fn positions(n: usize, s: f32) -> Vec<Vec3> {
    let fold = (165.0 + 30.0 * s).to_radians();
    let mut out = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (
                2.0 * i as f32 / n as f32 - 1.0,
                2.0 * j as f32 / n as f32 - 1.0,
            );
            let (r, phi) = ((u * u + v * v).sqrt(), v.atan2(u));
            let theta = r / SPHERE;
            let (rho, z) = if theta <= FRAC_PI_2 {
                (SPHERE * theta.sin() * 1.01, SPHERE * theta.cos() * 1.01)
            } else {
                let hang = r - SPHERE * FRAC_PI_2;
                let depth = hang - FOLD_DEPTH;
                if depth <= 0.0 {
                    (SPHERE * 1.01, -hang)
                } else {
                    let wave = (8.0 * phi + PI * s).sin() * (PI * depth / 0.15).sin();
                    let ripple = 0.4 * depth * wave;
                    (
                        SPHERE * 1.01 + depth * fold.sin() + ripple,
                        -FOLD_DEPTH - depth * fold.cos(),
                    )
                }
            };
            out.push(Vec3::new(rho * phi.cos(), rho * phi.sin(), z));
        }
    }
    out
}
