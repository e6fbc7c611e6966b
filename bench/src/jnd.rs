//! Just-noticeable differences of room-acoustic parameters (ISO 3382-1
//! Annex A): how differences are reported.

/// Decay times (EDT, T20, T30): 5 % of the reference.
pub const DECAY: f64 = 0.05;
/// Clarity (C50, C80): 1 dB.
pub const CLARITY_DB: f64 = 1.0;
/// Definition (D50): 0.05.
pub const DEFINITION: f64 = 0.05;

/// `value - reference` in steps of `step`, relative to the reference
/// where `relative`; `None` where either is missing.
pub fn jnd(value: Option<f64>, reference: Option<f64>, relative: bool, step: f64) -> Option<f64> {
    let (f, r) = (value?, reference?);
    Some(if relative {
        (f - r) / r / step
    } else {
        (f - r) / step
    })
}
