//! Rendering arrivals into a sampled impulse response.
//!
//! Every arrival is an impulse with its own gain in each octave band. For each
//! rendered band, the arrivals are written into one band signal at their exact
//! (fractional) delays with that band's gain, and the octave filter bank then
//! filters each band signal to its band and sums them. The result is the
//! response of a smooth, zero-phase filter per arrival whose magnitude passes
//! through the arrival's band gains at the band centres.
//!
//! Fractional delays use a 64-tap Hann-windowed sinc, tabulated at 1/1024
//! sample steps. It is flat up to the top octave; at half-sample delays it
//! loses up to 2.5 % of a broadband impulse's energy close to Nyquist, as
//! every finite fractional-delay filter must.

use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use super::air::AirConditions;
use super::filter_bank::{tail_samples, OctaveFilterBank};
use super::head::{ear_responses, ListenerFrame};
use super::histogram::EnergyHistogram;
use super::Arrival;
use crate::scene::{Bands, BAND_COUNT, OCTAVE_BANDS_HZ};
use crate::{Error, Result};

/// The longest impulse response [`synthesize`] renders, s.
pub const MAX_DURATION_S: f64 = 60.0;
/// The highest sample rate [`synthesize`] accepts, Hz.
pub const MAX_SAMPLE_RATE: u32 = 384_000;

/// Half the length of the fractional-delay kernel, in samples.
const KERNEL_HALF: usize = 32;
/// Taps of the fractional-delay kernel.
const KERNEL_TAPS: usize = 2 * KERNEL_HALF;
/// Fractional delays the kernel table holds per sample; delays round to the
/// nearest, an error of at most 1/2048 sample.
const KERNEL_PHASES: usize = 1024;

/// Which signals the impulse response has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Channels {
    /// One channel: an omnidirectional microphone at the listener.
    #[default]
    Mono,
    /// Left and right ears of the spherical head model in [`super::head`].
    Binaural,
}

/// How to render an impulse response.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ImpulseResponseOptions {
    /// Samples per second.
    pub sample_rate: u32,
    pub channels: Channels,
    /// Indices into [`OCTAVE_BANDS_HZ`] of the bands to render; the others
    /// are silent. Each index may appear once.
    pub bands: Vec<usize>,
    /// The head's orientation (used for [`Channels::Binaural`]).
    pub listener: ListenerFrame,
}

impl Default for ImpulseResponseOptions {
    /// 48 kHz mono with all eight bands, facing +X.
    fn default() -> Self {
        Self {
            sample_rate: 48_000,
            channels: Channels::Mono,
            bands: (0..BAND_COUNT).collect(),
            listener: ListenerFrame::default(),
        }
    }
}

impl ImpulseResponseOptions {
    /// Checks the sample rate, the band list and the listener frame.
    pub fn validated(self) -> Result<Self> {
        if self.sample_rate == 0 || self.sample_rate > MAX_SAMPLE_RATE {
            return Err(Error::InvalidAudio(format!(
                "sample rate {} Hz must lie in [1, {MAX_SAMPLE_RATE}]",
                self.sample_rate
            )));
        }
        if self.bands.is_empty() {
            return Err(Error::InvalidAudio(
                "no bands to render: list at least one band index".into(),
            ));
        }
        for (i, &band) in self.bands.iter().enumerate() {
            if band >= BAND_COUNT {
                return Err(Error::InvalidAudio(format!(
                    "band index {band} is out of range: bands are 0 ({} Hz) to {} ({} Hz)",
                    OCTAVE_BANDS_HZ[0],
                    BAND_COUNT - 1,
                    OCTAVE_BANDS_HZ[BAND_COUNT - 1]
                )));
            }
            if self.bands[..i].contains(&band) {
                return Err(Error::InvalidAudio(format!(
                    "band index {band} is listed twice"
                )));
            }
        }
        let listener = self.listener.validated()?;
        Ok(Self { listener, ..self })
    }
}

/// A sampled impulse response: one signal per channel (left then right for
/// binaural), all the same length.
#[derive(Clone, Debug, PartialEq)]
pub struct ImpulseResponse {
    pub sample_rate: u32,
    pub channels: Vec<Vec<f32>>,
}

impl ImpulseResponse {
    /// Length in seconds.
    pub fn duration_s(&self) -> f64 {
        let len = self.channels.first().map_or(0, Vec::len);
        if self.sample_rate == 0 {
            0.0
        } else {
            len as f64 / f64::from(self.sample_rate)
        }
    }
}

/// Renders `arrivals` into an impulse response. Its length is the last
/// arrival plus the fractional-delay kernel and the filter bank's ringing
/// ([`super::filter_bank::TAIL_S`]), so no arrivals give a short silent
/// response. Time zero is the emission of the sound; binaural ears are timed
/// relative to the head centre, so a near ear hears slightly before the
/// mono delay, and anything falling before time zero is dropped.
///
/// Errors: invalid options, an arrival with a negative or non-finite delay,
/// a non-finite direction or gain, or a response longer than
/// [`MAX_DURATION_S`].
pub fn synthesize(
    arrivals: &[Arrival],
    options: &ImpulseResponseOptions,
) -> Result<ImpulseResponse> {
    synthesize_with_tail(arrivals, None, options)
}

/// [`synthesize`] with a late part: `tail`'s Dirac sequence (one per
/// channel, see [`EnergyHistogram::dirac_sequence`]) added to the
/// arrivals before the filter bank, so the response lasts at least as
/// long as the histogram.
pub fn synthesize_with_tail(
    arrivals: &[Arrival],
    tail: Option<&EnergyHistogram>,
    options: &ImpulseResponseOptions,
) -> Result<ImpulseResponse> {
    let options = options.clone().validated()?;
    validate_arrivals(arrivals)?;
    let rate = f64::from(options.sample_rate);
    let speed_of_sound = AirConditions::default().speed_of_sound();
    let channels: Vec<Vec<Placement>> = match options.channels {
        Channels::Mono => vec![arrivals
            .iter()
            .map(|a| Placement {
                position: a.delay_s * rate,
                gains: a.pressure_gain,
            })
            .collect()],
        Channels::Binaural => (0..2)
            .map(|ear| {
                arrivals
                    .iter()
                    .map(|a| {
                        let (delay, gains) =
                            ear_responses(a.direction, &options.listener, speed_of_sound)[ear];
                        let mut combined = a.pressure_gain;
                        for (g, e) in combined.iter_mut().zip(gains) {
                            *g *= e;
                        }
                        Placement {
                            position: (a.delay_s + delay) * rate,
                            gains: combined,
                        }
                    })
                    .collect()
            })
            .collect(),
    };
    let last = channels
        .iter()
        .flatten()
        .map(|p| p.position)
        .fold(tail.map_or(0.0, |t| t.duration_s() * rate), f64::max);
    let len_f = last.ceil() + (KERNEL_HALF + tail_samples(options.sample_rate)) as f64;
    if len_f / rate > MAX_DURATION_S {
        return Err(Error::InvalidAudio(format!(
            "the impulse response would last {:.1} s; the limit is {MAX_DURATION_S} s",
            len_f / rate
        )));
    }
    let len = len_f as usize;
    let rendered = channels
        .iter()
        .enumerate()
        .map(|(channel, placements)| {
            let diracs = tail.map_or_else(Vec::new, |t| {
                t.dirac_sequence(channel as u64, options.sample_rate)
            });
            render_channel(
                placements,
                &diracs,
                &options.bands,
                len,
                options.sample_rate,
            )
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(ImpulseResponse {
        sample_rate: options.sample_rate,
        channels: rendered,
    })
}

/// One arrival as one channel hears it: where it lands, in samples, and its
/// gain per band.
struct Placement {
    position: f64,
    gains: Bands,
}

fn validate_arrivals(arrivals: &[Arrival]) -> Result<()> {
    for (i, a) in arrivals.iter().enumerate() {
        let problem = if !a.delay_s.is_finite() || a.delay_s < 0.0 {
            format!("delay {} s must be finite and non-negative", a.delay_s)
        } else if !a.direction.is_finite() {
            format!("direction {} must be finite", a.direction)
        } else if a.pressure_gain.iter().any(|g| !g.is_finite()) {
            format!("gains {:?} must be finite", a.pressure_gain)
        } else {
            continue;
        };
        return Err(Error::InvalidAudio(format!("arrival {i}: {problem}")));
    }
    Ok(())
}

/// One channel: each band's arrivals written with the fractional-delay
/// kernel and its tail impulses `diracs` (sample, gains) on their samples,
/// then filtered and summed by the octave filter bank.
fn render_channel(
    placements: &[Placement],
    diracs: &[(usize, Bands)],
    bands: &[usize],
    len: usize,
    sample_rate: u32,
) -> Result<Vec<f32>> {
    // Two halves of the bands on two threads (the transforms are most of
    // the work); the halves are fixed, so the sum is the same on any
    // thread count.
    let (low, high) = bands.split_at(bands.len() / 2);
    let render = |bands: &[usize]| -> Result<OctaveFilterBank> {
        let mut bank = OctaveFilterBank::new(len, sample_rate)?;
        for &band in bands {
            render_band(bank.input(), placements, diracs, band);
            bank.add(band);
        }
        Ok(bank)
    };
    let (low, high) = rayon::join(|| render(low), || render(high));
    let mut bank = low?;
    bank.merge(&high?);
    Ok(bank.finish())
}

/// Writes band `band` of the arrivals (band-limited by the fractional-delay
/// kernels) and of the tail's Dirac sequence into `signal`.
fn render_band(
    signal: &mut [f64],
    placements: &[Placement],
    diracs: &[(usize, Bands)],
    band: usize,
) {
    let kernels = kernel_table();
    let len = signal.len();
    for placement in placements {
        let gain = f64::from(placement.gains[band]);
        if gain == 0.0 {
            continue;
        }
        let whole = placement.position.floor();
        let phase = ((placement.position - whole) * KERNEL_PHASES as f64).round() as usize;
        let kernel = &kernels[phase * KERNEL_TAPS..(phase + 1) * KERNEL_TAPS];
        // Tap j lands on sample whole + j − (KERNEL_HALF − 1).
        let first = whole as i64 - (KERNEL_HALF as i64 - 1);
        let skip = (-first).max(0) as usize;
        let start = first.max(0) as usize;
        if skip >= KERNEL_TAPS || start >= len {
            continue;
        }
        let taps = &kernel[skip..];
        let end = (start + taps.len()).min(len);
        for (out, &tap) in signal[start..end].iter_mut().zip(taps) {
            *out += gain * tap;
        }
    }
    for &(i, gains) in diracs {
        if let Some(out) = signal.get_mut(i) {
            *out += f64::from(gains[band]);
        }
    }
}

/// Hann-windowed sinc kernels for fractional delays 0, 1/P, …, 1 sample
/// (P = [`KERNEL_PHASES`]), row after row, each scaled to unit DC gain so
/// that low frequencies keep their level at every fractional delay. Built
/// once per process.
fn kernel_table() -> &'static [f64] {
    static TABLE: OnceLock<Vec<f64>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut table = Vec::with_capacity((KERNEL_PHASES + 1) * KERNEL_TAPS);
        for phase in 0..=KERNEL_PHASES {
            let frac = phase as f64 / KERNEL_PHASES as f64;
            let row_start = table.len();
            for j in 0..KERNEL_TAPS {
                // Distance from the arrival to this tap, in samples.
                let u = j as f64 - (KERNEL_HALF as f64 - 1.0) - frac;
                let sinc = if u == 0.0 {
                    1.0
                } else {
                    let x = std::f64::consts::PI * u;
                    x.sin() / x
                };
                let window = 0.5 * (1.0 + (std::f64::consts::PI * u / KERNEL_HALF as f64).cos());
                table.push(sinc * window);
            }
            let sum: f64 = table[row_start..].iter().sum();
            for tap in &mut table[row_start..] {
                *tap /= sum;
            }
        }
        table
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    const RATE: f64 = 48_000.0;

    fn arrival(delay_samples: f64, gain: f32) -> Arrival {
        Arrival {
            delay_s: delay_samples / RATE,
            direction: Vec3::X,
            pressure_gain: [gain; BAND_COUNT],
        }
    }

    fn mono(arrivals: &[Arrival]) -> Vec<f32> {
        let ir = synthesize(arrivals, &ImpulseResponseOptions::default()).unwrap();
        assert_eq!(ir.channels.len(), 1);
        ir.channels.into_iter().next().unwrap()
    }

    fn energy(signal: &[f32]) -> f64 {
        signal.iter().map(|&s| f64::from(s).powi(2)).sum()
    }

    fn peak(signal: &[f32]) -> (usize, f32) {
        signal.iter().enumerate().fold(
            (0, 0.0),
            |(bi, bv), (i, &v)| {
                if v.abs() > bv {
                    (i, v.abs())
                } else {
                    (bi, bv)
                }
            },
        )
    }

    #[test]
    fn a_fractional_delay_lands_at_the_right_sample_with_its_energy() {
        for delay in [1000.3, 1000.45, 1000.7, 2345.0] {
            let ir = mono(&[arrival(delay, 1.0)]);
            let (at, _) = peak(&ir);
            assert_eq!(at, delay.round() as usize, "delay {delay}");
            // A unit impulse has unit energy at any delay, less what the
            // finite kernel cannot pass near Nyquist: none at whole samples,
            // at most 2.5 % (half a sample), all of it in the top band.
            let e = energy(&ir);
            assert!(e <= 1.0 + 1e-6 && e > 0.97, "delay {delay}: energy {e}");
            // Below the top band the kernel is flat: the energy is exactly
            // that of the same bands at a whole-sample delay.
            let mut below_top = arrival(delay, 1.0);
            below_top.pressure_gain[BAND_COUNT - 1] = 0.0;
            let mut whole = below_top;
            whole.delay_s = delay.floor() / RATE;
            let (e, e_whole) = (energy(&mono(&[below_top])), energy(&mono(&[whole])));
            assert!(
                (e / e_whole - 1.0).abs() < 1e-4,
                "delay {delay}: {e} vs {e_whole}"
            );
            // Its centre of gravity sits at the fractional delay.
            let centre: f64 = ir
                .iter()
                .enumerate()
                .map(|(i, &s)| i as f64 * f64::from(s))
                .sum::<f64>()
                / ir.iter().map(|&s| f64::from(s)).sum::<f64>();
            assert!(
                (centre - delay).abs() < 0.01,
                "delay {delay}: centre {centre}"
            );
        }
    }

    #[test]
    fn equal_gains_in_all_bands_give_a_broadband_pulse_of_that_amplitude() {
        let ir = mono(&[arrival(480.0, 0.5)]);
        for (i, &s) in ir.iter().enumerate() {
            let expected = if i == 480 { 0.5 } else { 0.0 };
            assert!((s - expected).abs() < 1e-5, "sample {i}: {s}");
        }
    }

    #[test]
    fn arrivals_sum_linearly() {
        let a = arrival(700.25, 0.8);
        let mut b = arrival(1500.6, 0.3);
        b.pressure_gain[2] = -0.4;
        b.pressure_gain[6] = 0.05;
        let both = mono(&[a, b]);
        let (ia, ib) = (mono(&[a]), mono(&[b]));
        assert_eq!(both.len(), ib.len());
        for i in 0..both.len() {
            let separate = ia.get(i).copied().unwrap_or(0.0) + ib[i];
            assert!((both[i] - separate).abs() < 1e-6, "sample {i}");
        }
    }

    #[test]
    fn rendering_some_bands_silences_the_others() {
        let mut only_band_4 = arrival(900.0, 0.0);
        only_band_4.pressure_gain[4] = 1.0;
        let options = ImpulseResponseOptions {
            bands: vec![4],
            ..ImpulseResponseOptions::default()
        };
        let subset = synthesize(&[arrival(900.0, 1.0)], &options).unwrap();
        let expected = mono(&[only_band_4]);
        assert_eq!(subset.channels[0].len(), expected.len());
        for (a, b) in subset.channels[0].iter().zip(&expected) {
            assert!((a - b).abs() < 1e-6);
        }
        // One octave band holds about a tenth of a broadband impulse's energy.
        let e = energy(&expected);
        assert!(e > 0.005 && e < 0.2, "{e}");
    }

    #[test]
    fn no_arrivals_give_a_short_silent_response() {
        let ir = synthesize(&[], &ImpulseResponseOptions::default()).unwrap();
        assert_eq!(ir.sample_rate, 48_000);
        assert!(ir.duration_s() > 0.0 && ir.duration_s() <= 0.2);
        assert!(ir.channels[0].iter().all(|&s| s == 0.0));
    }

    #[test]
    fn length_covers_the_last_arrival_and_the_tail() {
        let ir = mono(&[arrival(RATE * 0.5, 1.0)]);
        let expected = 24_000 + KERNEL_HALF + tail_samples(48_000);
        assert_eq!(ir.len(), expected);
    }

    #[test]
    fn binaural_ears_follow_the_head_model() {
        let options = ImpulseResponseOptions {
            channels: Channels::Binaural,
            ..ImpulseResponseOptions::default()
        };
        let mut from_left = arrival(4800.0, 1.0);
        from_left.direction = Vec3::Y;
        let ir = synthesize(&[from_left], &options).unwrap();
        let [left, right] = [&ir.channels[0], &ir.channels[1]];
        let (left_at, _) = peak(left);
        let (right_at, _) = peak(right);
        // ITD of about 0.66 ms is 31 samples; the left ear is early by r/c.
        assert!(left_at < 4800 && right_at > 4800, "{left_at} {right_at}");
        assert!(((right_at - left_at) as i64 - 31).abs() <= 1);
        assert!(energy(left) > 2.0 * energy(right));
        // Straight ahead, both ears hear the mono response.
        let ahead = synthesize(&[arrival(4800.0, 1.0)], &options).unwrap();
        assert_eq!(ahead.channels[0], ahead.channels[1]);
        assert_eq!(ahead.channels[0], mono(&[arrival(4800.0, 1.0)]));
    }

    #[test]
    fn bad_options_and_arrivals_are_errors() {
        let bad_options = [
            ImpulseResponseOptions {
                sample_rate: 0,
                ..Default::default()
            },
            ImpulseResponseOptions {
                sample_rate: 400_000,
                ..Default::default()
            },
            ImpulseResponseOptions {
                bands: vec![],
                ..Default::default()
            },
            ImpulseResponseOptions {
                bands: vec![3, 8],
                ..Default::default()
            },
            ImpulseResponseOptions {
                bands: vec![3, 3],
                ..Default::default()
            },
            ImpulseResponseOptions {
                listener: ListenerFrame {
                    forward: Vec3::Z,
                    up: Vec3::Z,
                },
                ..Default::default()
            },
        ];
        for options in bad_options {
            assert!(synthesize(&[], &options).is_err(), "{options:?}");
        }
        let default = ImpulseResponseOptions::default();
        let mut nan_gain = arrival(10.0, 1.0);
        nan_gain.pressure_gain[3] = f32::NAN;
        let mut bad_direction = arrival(10.0, 1.0);
        bad_direction.direction = Vec3::splat(f32::INFINITY);
        for bad in [
            arrival(f64::NAN, 1.0),
            arrival(-5.0, 1.0),
            arrival(RATE * 100.0, 1.0),
            nan_gain,
            bad_direction,
        ] {
            let err = synthesize(&[arrival(1.0, 1.0), bad], &default).unwrap_err();
            assert!(matches!(err, Error::InvalidAudio(_)), "{err}");
        }
    }
}
