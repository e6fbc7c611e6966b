//! The listener's head: its orientation and a spherical-head model of what
//! each ear receives.
//!
//! The model is a rigid sphere of radius 8.75 cm with the ears at opposite
//! ends of a diameter. It gives each ear its own delay (the interaural time
//! difference, ITD, by Woodworth's formula) and its own per-band gain (the
//! interaural level difference, ILD, from the head's acoustic shadow). It
//! cannot tell front from back or up from down: only the lateral angle, how
//! far the source is toward one ear, matters.
//!
//! A full head-related transfer function (HRTF) would instead need a measured
//! set of head-related impulse responses (HRIRs, e.g. a SOFA file holding
//! hundreds of directions per ear), interpolation between the measured
//! directions, and either a convolution of every arrival with the
//! interpolated HRIR pair or an encoding of all arrivals into spherical
//! harmonics (ambisonics) decoded once with the HRTF. That captures pinna and
//! torso cues, and with them elevation and front/back, which a sphere cannot.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::scene::{Bands, BAND_COUNT};
use crate::{Error, Result};

/// Radius of the model head, m (a common average adult value).
pub const HEAD_RADIUS_M: f64 = 0.0875;

/// Level cut at the far ear for a source at 90° to the side, dB per octave
/// band (63 Hz to 8 kHz). Low frequencies bend round the head unhindered;
/// from about 1 kHz on the head casts a shadow that deepens with frequency,
/// approximating the spherical-head shadow at the far ear.
const FAR_EAR_SHADOW_DB: Bands = [0.0, 0.5, 1.5, 3.0, 6.0, 10.0, 14.0, 18.0];

/// How the listener's head is oriented in the world (scenes are z-up).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ListenerFrame {
    /// Where the nose points.
    pub forward: Vec3,
    /// Where the top of the head points; need not be exactly perpendicular
    /// to `forward`, only not parallel to it.
    pub up: Vec3,
}

impl Default for ListenerFrame {
    /// Facing +X, upright in a z-up scene, so the left ear points to +Y.
    fn default() -> Self {
        Self {
            forward: Vec3::X,
            up: Vec3::Z,
        }
    }
}

impl ListenerFrame {
    /// Checks that both vectors are finite and non-zero and that they are
    /// not (anti)parallel, so that left and right are defined.
    pub fn validated(self) -> Result<Self> {
        let fail = |reason: &str| {
            Err(Error::InvalidAudio(format!(
                "listener frame (forward {}, up {}): {reason}",
                self.forward, self.up
            )))
        };
        if !self.forward.is_finite() || !self.up.is_finite() {
            return fail("vectors must be finite");
        }
        if self.forward.length() < 1e-6 || self.up.length() < 1e-6 {
            return fail("vectors must be non-zero");
        }
        if self.left().length() < 1e-3 {
            return fail("forward and up must not be parallel");
        }
        Ok(self)
    }

    /// The unit vector toward the left ear.
    fn left(&self) -> Vec3 {
        self.up
            .normalize_or_zero()
            .cross(self.forward.normalize_or_zero())
    }
}

/// What the left and right ears (in that order) receive from a sound
/// arriving from `direction` (world frame, pointing from the listener toward
/// the source; a zero vector counts as straight ahead), with speed of sound
/// `speed_of_sound` m/s: for each ear the extra delay in seconds relative
/// to the centre of the head, and the pressure gain per band.
///
/// Delays follow Woodworth's path around a sphere: the near ear is reached
/// (r/c)·sin θ earlier than the head centre, the far ear (r/c)·θ later, so
/// the ITD is (r/c)(θ + sin θ) for lateral angle θ. The near ear's delay is
/// negative. Gains are a cut on the far ear only (the near ear keeps 0 dB),
/// so a binaural rendering is never louder than the mono one and a source
/// straight ahead gives both ears exactly the mono response.
pub fn ear_responses(
    direction: Vec3,
    frame: &ListenerFrame,
    speed_of_sound: f64,
) -> [(f64, Bands); 2] {
    let toward_left = f64::from(direction.normalize_or_zero().dot(frame.left())).clamp(-1.0, 1.0);
    let lateral = toward_left.abs().asin();
    let scale = HEAD_RADIUS_M / speed_of_sound;
    let near = (-scale * lateral.sin(), [1.0; BAND_COUNT]);
    let mut shadow = [1.0; BAND_COUNT];
    for (gain, db) in shadow.iter_mut().zip(FAR_EAR_SHADOW_DB) {
        *gain = 10f64.powf(-f64::from(db) * toward_left.abs() / 20.0) as f32;
    }
    let far = (scale * lateral, shadow);
    if toward_left >= 0.0 {
        [near, far]
    } else {
        [far, near]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: f64 = 343.0;

    #[test]
    fn a_source_straight_ahead_or_behind_reaches_both_ears_alike() {
        let frame = ListenerFrame::default();
        for direction in [Vec3::X, -Vec3::X, Vec3::Z, Vec3::ZERO] {
            let [left, right] = ear_responses(direction, &frame, C);
            assert_eq!(left, right, "{direction}");
            assert_eq!(left.0, 0.0);
            assert_eq!(left.1, [1.0; BAND_COUNT]);
        }
    }

    #[test]
    fn a_source_on_the_left_is_earlier_and_louder_in_the_left_ear() {
        let [left, right] = ear_responses(Vec3::Y, &ListenerFrame::default(), C);
        assert!(left.0 < right.0);
        assert_eq!(left.1, [1.0; BAND_COUNT]);
        assert!(right.1[7] < 0.15, "18 dB cut at 8 kHz: {}", right.1[7]);
        assert!(right.1.windows(2).all(|w| w[1] <= w[0]));
        let mirrored = ear_responses(-Vec3::Y, &ListenerFrame::default(), C);
        assert_eq!(mirrored, [right, left]);
    }

    #[test]
    fn itd_at_ninety_degrees_is_woodworths() {
        let [left, right] = ear_responses(Vec3::Y, &ListenerFrame::default(), C);
        let itd = right.0 - left.0;
        let expected = HEAD_RADIUS_M / C * (std::f64::consts::FRAC_PI_2 + 1.0);
        assert!((itd - expected).abs() < 1e-9);
        assert!((itd - 0.00066).abs() < 1e-5, "{itd}");
        // Near ear earlier than the head centre by r/c, far ear later by (π/2)·r/c.
        assert!((left.0 + HEAD_RADIUS_M / C).abs() < 1e-9);
    }

    #[test]
    fn the_frame_decides_which_side_is_left() {
        // Facing +Y, upright: the left ear points to −X.
        let frame = ListenerFrame {
            forward: Vec3::Y,
            up: Vec3::Z,
        };
        let [left, right] = ear_responses(-Vec3::X, &frame, C);
        assert!(left.0 < right.0);
        // At 30° to the side the ITD is (r/c)(π/6 + 1/2).
        let direction = Vec3::new(-0.5, 3f32.sqrt() / 2.0, 0.0);
        let [left, right] = ear_responses(direction, &frame, C);
        let expected = HEAD_RADIUS_M / C * (std::f64::consts::FRAC_PI_6 + 0.5);
        assert!((right.0 - left.0 - expected).abs() < 1e-7);
    }

    #[test]
    fn validation_rejects_degenerate_frames() {
        assert!(ListenerFrame::default().validated().is_ok());
        for (forward, up) in [
            (Vec3::X, Vec3::X),
            (Vec3::X, -2.0 * Vec3::X),
            (Vec3::ZERO, Vec3::Z),
            (Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z),
        ] {
            assert!(ListenerFrame { forward, up }.validated().is_err());
        }
    }
}
