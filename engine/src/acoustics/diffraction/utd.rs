//! The uniform theory of diffraction (Kouyoumjian & Pathak 1974) for an
//! acoustically hard wedge: the diffraction coefficient of one edge event
//! and its octave-band gains.
//!
//! Uniform means the coefficient stays finite at the shadow and
//! reflection boundaries, where its jump cancels the geometric field's:
//! a listener walking out of a wall's shadow hears the sum change
//! smoothly. Time convention `e^{iωt}`, so waves travel as `e^{-iks}`.

use std::f64::consts::{FRAC_PI_4, PI, TAU};

use errorfunctions::ComplexErrorFunctions;
use num_complex::Complex64;

use crate::scene::{Bands, BAND_COUNT, OCTAVE_BANDS_HZ};

/// One diffraction at an edge, as the coefficient sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WedgeEvent {
    /// The air's angle over π (`2` for a half-plane).
    pub n: f64,
    /// Angle of the incoming leg's origin from face 0, radians.
    pub incidence: f64,
    /// Angle of the outgoing leg's end from face 0.
    pub exit: f64,
    /// The distance parameter `L` of the wave front at the edge, m.
    pub distance: f64,
    /// Sine of the angle between the legs and the edge (Keller's cone).
    pub sin_skew: f64,
    /// `1/2` where a leg runs along a face (the incident and the face's
    /// reflected waves are one there), else 1.
    pub grazing: f64,
}

/// The transition function `F(X) = 2i √X e^{iX} ∫_{√X}^∞ e^{-iτ²} dτ`,
/// written with the scaled complementary error function, which is stable
/// for every `X ≥ 0`: `F(X) = √π a e^{iπ/4} erfcx(e^{iπ/4} a)`, `a = √X`.
pub fn transition(x: f64) -> Complex64 {
    let a = x.max(0.0).sqrt();
    let rot = Complex64::from_polar(1.0, FRAC_PI_4);
    (rot * a).erfcx() * rot * (PI.sqrt() * a)
}

/// `cot((π ± β)/2n) F(kL a±(β))` for the sign `s`, written with
/// `ε = π + s(β − 2πnN)`, `N` the integer nearest `(β + sπ)/2πn`: then
/// the cotangent is `cot(ε/2n)` and `a± = 2 sin²(ε/2)`, both small at a
/// boundary, where the product tends to a finite value (zero exactly on
/// it: the mean of its two sides' limits).
fn term(k_l: f64, n: f64, beta: f64, s: f64) -> Complex64 {
    let big_n = ((beta + s * PI) / (TAU * n)).round();
    let eps = PI + s * (beta - TAU * n * big_n);
    if eps == 0.0 {
        return Complex64::new(0.0, 0.0);
    }
    let half = 0.5 * eps;
    transition(2.0 * k_l * half.sin().powi(2)) / (eps / (2.0 * n)).tan()
}

/// The diffraction coefficient of a hard wedge at wave number `k`.
pub fn coefficient(e: &WedgeEvent, k: f64) -> Complex64 {
    let k_l = k * e.distance;
    let minus = e.exit - e.incidence;
    let plus = e.exit + e.incidence;
    let sum = term(k_l, e.n, minus, 1.0)
        + term(k_l, e.n, minus, -1.0)
        + term(k_l, e.n, plus, 1.0)
        + term(k_l, e.n, plus, -1.0);
    let scale = -Complex64::from_polar(1.0, -FRAC_PI_4) * e.grazing
        / (2.0 * e.n * (TAU * k).sqrt() * e.sin_skew);
    sum * scale
}

/// Third-octave centres within each octave band: the band's gain is the
/// root mean square of the coefficient at them, its energy average.
const THIRDS: [f64; 3] = [0.793_700_525_984_099_8, 1.0, 1.259_921_049_894_873_2];

/// Per band, the product of the events' coefficients as a pressure factor
/// (spreading not included): its root mean square over the band, signed
/// by the real part of the product turned by `e^{iπ/4}` per event at the
/// band's centre, so that beside a shadow boundary the diffracted wave
/// adds to the direct one on the shadow side and subtracts on the lit
/// side, as it does. Bands not `active` are zero.
pub fn band_gains(events: &[WedgeEvent], speed: f64, active: &[bool; BAND_COUNT]) -> Bands {
    let mut out = [0.0; BAND_COUNT];
    for (b, g) in out.iter_mut().enumerate() {
        if !active[b] {
            continue;
        }
        let mut energy = 0.0;
        let mut sign = 1.0;
        for (i, third) in THIRDS.iter().enumerate() {
            let k = TAU * f64::from(OCTAVE_BANDS_HZ[b]) * third / speed;
            let d: Complex64 = events.iter().map(|e| coefficient(e, k)).product();
            energy += d.norm_sqr();
            if i == 1 {
                let turned = d * Complex64::from_polar(1.0, FRAC_PI_4 * events.len() as f64);
                sign = if turned.re < 0.0 { -1.0 } else { 1.0 };
            }
        }
        *g = (sign * (energy / THIRDS.len() as f64).sqrt()) as f32;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// F against its series for small X (`√(πX) e^{iπ/4} - 2X e^{iπ/2}`)
    /// and its asymptote for large X (`1 + i/2X - 3/4X²`).
    #[test]
    fn transition_function_matches_its_limits() {
        let x = 1e-6;
        let small =
            Complex64::from_polar((PI * x).sqrt(), FRAC_PI_4) - Complex64::new(0.0, 2.0 * x);
        assert!((transition(x) - small).norm() < 1e-8, "{}", transition(x));
        for x in [50.0, 500.0] {
            let large = Complex64::new(1.0 - 0.75 / (x * x), 0.5 / x);
            assert!((transition(x) - large).norm() < 2.0 / x.powi(3), "{x}");
        }
        assert_eq!(transition(0.0), Complex64::new(0.0, 0.0));
    }

    /// Beside a shadow boundary the coefficient tends to a finite,
    /// side-dependent value, and is continuous through the boundary once
    /// the geometric wave's jump is added.
    #[test]
    fn the_coefficient_is_finite_beside_boundaries() {
        let e = |exit: f64| WedgeEvent {
            n: 1.5,
            incidence: 0.4,
            exit,
            distance: 2.0,
            sin_skew: 1.0,
            grazing: 1.0,
        };
        // The shadow boundary of incidence 0.4 lies at exit 0.4 + π.
        let k = 10.0;
        let at = PI + 0.4;
        let lit = coefficient(&e(at - 1e-9), k);
        let shadow = coefficient(&e(at + 1e-9), k);
        assert!(lit.norm().is_finite() && shadow.norm().is_finite());
        // The jump equals the geometric wave's relative amplitude, 1, over
        // the spreading factor sqrt(L): D/sqrt(L) jumps by 1.
        let jump = (shadow - lit) / 2.0_f64.sqrt();
        assert!((jump.norm() - 1.0).abs() < 1e-6, "{jump}");
    }
}
