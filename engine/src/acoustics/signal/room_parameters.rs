//! Room-acoustic parameters of ISO 3382-1 from an energy impulse response.
//!
//! The input is an echogram: (time s, energy) samples. That is either the
//! exact per-band echogram of a list of arrivals (energy = gain², see
//! [`per_band`]) or a sampled impulse response (time = i / rate, energy =
//! sample², see [`RoomParameters::from_signal`]); both are handled alike.
//!
//! Decay times come from the Schroeder curve S(t), the energy still to arrive
//! at or after t (backward integration), in dB relative to the total. S is a
//! step function that drops at each sample. ISO 3382-1 fits a least-squares
//! line to it over a level range; here the step curve is evaluated on a
//! uniform grid of 1/48000 s from the direct sound (coarser only for
//! echograms longer than about 87 s, to stay within 2^22 grid points), so a
//! sparse echogram and its 48 kHz rendering are fitted on the same points.
//! A decay time is the time the fitted line takes to fall 60 dB.
//!
//! Times for the early/late splits and the centre time are measured from the
//! direct sound, taken to be the first sample with any energy. No noise
//! compensation is applied: the input is assumed noise-free, so a decay cut
//! short by a truncated echogram is fitted as it is.

use rayon::prelude::*;
use serde::Serialize;

use super::histogram::EnergyHistogram;
use super::Arrival;
use crate::scene::{BAND_COUNT, OCTAVE_BANDS_HZ};
use crate::{Error, Result};

/// Grid step on which the Schroeder curve is fitted, s.
const GRID_STEP_S: f64 = 1.0 / 48_000.0;
/// The most grid points one fit walks.
const MAX_GRID_POINTS: f64 = (1u64 << 22) as f64;

/// ISO 3382-1 parameters of one echogram. `None` means the echogram cannot
/// give the value: no energy at all; for a decay time, a Schroeder curve
/// that never reaches the end of the fitting range while energy remains,
/// fewer than two grid points within it (as for a single arrival), or a
/// fitted line that does not fall (all points at one level); for
/// C50 and C80, no late energy, i.e. an infinite clarity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RoomParameters {
    /// Early decay time: fit from 0 to −10 dB, ×6.
    pub edt_s: Option<f64>,
    /// Reverberation time from the fit from −5 to −25 dB, ×3.
    pub t20_s: Option<f64>,
    /// Reverberation time from the fit from −5 to −35 dB, ×2.
    pub t30_s: Option<f64>,
    /// Clarity for speech: early (first 50 ms) over late energy, dB.
    pub c50_db: Option<f64>,
    /// Clarity for music: early (first 80 ms) over late energy, dB.
    pub c80_db: Option<f64>,
    /// Definition: the fraction of the energy in the first 50 ms.
    pub d50: Option<f64>,
    /// Centre time: the energy-weighted mean time after the direct sound, s.
    pub ts_s: Option<f64>,
}

impl RoomParameters {
    /// Parameters of the echogram `echogram` of (time s, energy) samples, in
    /// any order. An empty or all-zero echogram gives all `None`.
    ///
    /// Errors: a negative or non-finite time or energy.
    pub fn from_energy(echogram: &[(f64, f64)]) -> Result<Self> {
        if let Some((i, (t, e))) = echogram
            .iter()
            .enumerate()
            .find(|(_, (t, e))| !(t.is_finite() && *t >= 0.0 && e.is_finite() && *e >= 0.0))
        {
            return Err(Error::InvalidAudio(format!(
                "echogram sample {i} (time {t} s, energy {e}): times and energies must be finite and non-negative"
            )));
        }
        let mut samples: Vec<(f64, f64)> =
            echogram.iter().copied().filter(|&(_, e)| e > 0.0).collect();
        if samples.is_empty() {
            return Ok(Self::default());
        }
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        let decay = Decay::new(&samples);
        let direct = samples[0].0;
        let total = decay.remaining[0];
        let early = |split_s: f64| -> f64 {
            samples
                .iter()
                .take_while(|(t, _)| t - direct < split_s - 1e-9)
                .map(|(_, e)| e)
                .sum()
        };
        let clarity = |split_s: f64| {
            let early = early(split_s);
            let late = total - early;
            (late > 0.0).then(|| 10.0 * (early / late).log10())
        };
        let centre: f64 = samples.iter().map(|(t, e)| (t - direct) * e).sum();
        Ok(Self {
            edt_s: decay.time(0.0, -10.0),
            t20_s: decay.time(-5.0, -25.0),
            t30_s: decay.time(-5.0, -35.0),
            c50_db: clarity(0.050),
            c80_db: clarity(0.080),
            d50: Some(early(0.050) / total),
            ts_s: Some(centre / total),
        })
    }

    /// Parameters of a sampled impulse response (energy = sample²).
    ///
    /// Errors: a zero sample rate or a non-finite sample.
    pub fn from_signal(signal: &[f32], sample_rate: u32) -> Result<Self> {
        if sample_rate == 0 {
            return Err(Error::InvalidAudio("sample rate must be positive".into()));
        }
        let rate = f64::from(sample_rate);
        let echogram: Vec<(f64, f64)> = signal
            .iter()
            .enumerate()
            .map(|(i, &s)| (i as f64 / rate, f64::from(s).powi(2)))
            .collect();
        Self::from_energy(&echogram)
    }
}

/// The parameters of each band in `bands` (indices into
/// [`OCTAVE_BANDS_HZ`]) of the echogram of `arrivals`, with the band's
/// centre frequency.
///
/// Errors: a band index out of range, or an arrival with a negative or
/// non-finite delay or a non-finite gain.
pub fn per_band(arrivals: &[Arrival], bands: &[usize]) -> Result<Vec<(f32, RoomParameters)>> {
    per_band_with_tail(arrivals, None, bands)
}

/// [`per_band`] of the arrivals and, when given, the late energy of `tail`
/// (each bin at its centre).
pub fn per_band_with_tail(
    arrivals: &[Arrival],
    tail: Option<&EnergyHistogram>,
    bands: &[usize],
) -> Result<Vec<(f32, RoomParameters)>> {
    if let Some(&band) = bands.iter().find(|&&b| b >= BAND_COUNT) {
        return Err(Error::InvalidAudio(format!(
            "band index {band} is out of range: bands are 0 to {}",
            BAND_COUNT - 1
        )));
    }
    // Bands in parallel: a long tail's decay fits are a few milliseconds
    // each.
    bands
        .par_iter()
        .map(|&band| {
            let mut echogram = Vec::with_capacity(arrivals.len());
            echogram.extend(
                arrivals
                    .iter()
                    .map(|a| (a.delay_s, f64::from(a.pressure_gain[band]).powi(2))),
            );
            if let Some(tail) = tail {
                echogram.extend(tail.echogram(band));
            }
            Ok((
                OCTAVE_BANDS_HZ[band],
                RoomParameters::from_energy(&echogram)?,
            ))
        })
        .collect()
}

/// The Schroeder curve of a time-sorted echogram with no zero samples.
struct Decay<'a> {
    samples: &'a [(f64, f64)],
    /// remaining[i]: the energy of samples i.. (so remaining[0] is the total
    /// and the last entry is zero), summed from the end as Schroeder's
    /// backward integration does.
    remaining: Vec<f64>,
    step: f64,
    grid_points: usize,
}

impl<'a> Decay<'a> {
    fn new(samples: &'a [(f64, f64)]) -> Self {
        let mut remaining = vec![0.0; samples.len() + 1];
        for i in (0..samples.len()).rev() {
            remaining[i] = remaining[i + 1] + samples[i].1;
        }
        let span = samples[samples.len() - 1].0 - samples[0].0;
        let step = GRID_STEP_S.max(span / MAX_GRID_POINTS);
        Self {
            samples,
            remaining,
            step,
            grid_points: (span / step).floor() as usize + 1,
        }
    }

    /// The decay time (s per 60 dB) of the least-squares line through the
    /// grid points of the Schroeder curve between `start_db` and `end_db`,
    /// or `None` if the curve never reaches `end_db` while energy remains
    /// fewer than two points lie in the range, or the line does not fall.
    ///
    /// The curve is constant between samples, so each run of grid points
    /// between two sample times enters the fit at once (one logarithm per
    /// sample, not per grid point: a 3 s tail has 144,000 grid points).
    fn time(&self, start_db: f64, end_db: f64) -> Option<f64> {
        let total = self.remaining[0];
        let direct = self.samples[0].0;
        let tolerance = self.step * 1e-6;
        let x = |j: usize| j as f64 * self.step;
        let mut fit = LineFit::default();
        let mut next = 0;
        let mut j = 0;
        while j < self.grid_points {
            while next < self.samples.len() && self.samples[next].0 - direct < x(j) - tolerance {
                next += 1;
            }
            let left = self.remaining[next];
            if left <= 0.0 {
                return None;
            }
            let level = 10.0 * (left / total).log10();
            if level <= end_db {
                if level >= end_db && level <= start_db {
                    fit.add_run(x(j), self.step, 1, level);
                }
                let slope = fit.slope()?;
                return (slope < 0.0).then(|| -60.0 / slope);
            }
            // Grid points keep this level while the next sample is ahead.
            let shares = |k: usize| {
                self.samples
                    .get(next)
                    .is_none_or(|s| s.0 - direct >= x(k) - tolerance)
            };
            let mut end = match self.samples.get(next) {
                Some(s) => (((s.0 - direct + tolerance) / self.step).floor() as usize + 1)
                    .clamp(j + 1, self.grid_points),
                None => self.grid_points,
            };
            while end < self.grid_points && shares(end) {
                end += 1;
            }
            while end > j + 1 && !shares(end - 1) {
                end -= 1;
            }
            if level <= start_db {
                fit.add_run(x(j), self.step, end - j, level);
            }
            j = end;
        }
        None
    }
}

/// A running least-squares line fit (moments merged batch by batch,
/// stable over millions of points).
#[derive(Default)]
struct LineFit {
    n: f64,
    mean_x: f64,
    mean_y: f64,
    co_moment: f64,
    x_moment: f64,
}

impl LineFit {
    /// Adds `count` points `(x0 + k step, y)`: a batch whose own moments
    /// are known in closed form, merged as Chan et al. merge two sets.
    fn add_run(&mut self, x0: f64, step: f64, count: usize, y: f64) {
        let nb = count as f64;
        let n = self.n + nb;
        let dx = x0 + step * (nb - 1.0) / 2.0 - self.mean_x;
        let dy = y - self.mean_y;
        let w = self.n * nb / n;
        self.co_moment += dx * dy * w;
        self.x_moment += step * step * nb * (nb * nb - 1.0) / 12.0 + dx * dx * w;
        self.mean_x += dx * nb / n;
        self.mean_y += dy * nb / n;
        self.n = n;
    }

    fn slope(&self) -> Option<f64> {
        (self.n >= 2.0 && self.x_moment > 0.0).then(|| self.co_moment / self.x_moment)
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// The decay times of a sparse echogram (few samples, long runs of
    /// grid points between them) equal a plain fit written here: every
    /// grid point's level from a direct sum, the textbook least-squares
    /// slope. Failed with the runs' x moment left out.
    #[test]
    fn run_fits_equal_a_point_by_point_fit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut echogram: Vec<(f64, f64)> = (0..400)
            .map(|_| {
                let t = 0.01 + rng.random::<f64>() * 1.5;
                (t, (-6.9 * t / 0.9).exp() * (0.5 + rng.random::<f64>()))
            })
            .collect();
        echogram.push((0.01, 1.0));
        echogram.sort_by(|a, b| a.0.total_cmp(&b.0));
        let plain = |start_db: f64, end_db: f64| -> Option<f64> {
            let total: f64 = echogram.iter().map(|e| e.1).sum();
            let direct = echogram[0].0;
            let step = GRID_STEP_S;
            let (mut xs, mut ys) = (Vec::new(), Vec::new());
            for j in 0.. {
                let x = j as f64 * step;
                let left: f64 = echogram
                    .iter()
                    .filter(|e| e.0 - direct >= x - step * 1e-6)
                    .map(|e| e.1)
                    .sum();
                if left <= 0.0 {
                    return None;
                }
                let level = 10.0 * (left / total).log10();
                if level <= start_db && level >= end_db {
                    xs.push(x);
                    ys.push(level);
                }
                if level <= end_db {
                    break;
                }
            }
            let n = xs.len() as f64;
            let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
            let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
            let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
            Some(-60.0 / (sxy / sxx))
        };
        let got = RoomParameters::from_energy(&echogram).unwrap();
        for (got, want) in [
            (got.edt_s, plain(0.0, -10.0)),
            (got.t20_s, plain(-5.0, -25.0)),
        ] {
            let (got, want) = (got.unwrap(), want.unwrap());
            assert!((got / want - 1.0).abs() < 1e-9, "{got} {want}");
        }
    }

    /// Energy falling 60 dB in `t60` s, sampled at 48 kHz for `length` s,
    /// starting after `onset` s of silence.
    fn exponential(t60: f64, onset: f64, length: f64) -> Vec<(f64, f64)> {
        let k = 6.0 * std::f64::consts::LN_10 / t60;
        let rate = 48_000.0;
        let start = (onset * rate) as usize;
        (0..(length * rate) as usize)
            .map(|i| {
                let t = i as f64 / rate;
                let e = if i < start {
                    0.0
                } else {
                    (-k * (t - onset)).exp()
                };
                (t, e)
            })
            .collect()
    }

    fn close(value: Option<f64>, expected: f64, relative: f64) -> bool {
        value.is_some_and(|v| ((v - expected) / expected).abs() < relative)
    }

    #[test]
    fn an_exponential_decay_gives_its_reverberation_time() {
        let p = RoomParameters::from_energy(&exponential(1.2, 0.01, 3.0)).unwrap();
        for (what, value) in [("EDT", p.edt_s), ("T20", p.t20_s), ("T30", p.t30_s)] {
            assert!(close(value, 1.2, 0.01), "{what}: {value:?}");
        }
        // C80 of an exponential decay: 10·log10(e^{k·0.08} − 1).
        let k = 6.0 * std::f64::consts::LN_10 / 1.2;
        let c80 = 10.0 * ((k * 0.08).exp() - 1.0).log10();
        assert!(
            (p.c80_db.unwrap() - c80).abs() < 0.01,
            "{:?} vs {c80}",
            p.c80_db
        );
        // Centre time of an exponential: 1/k.
        assert!(close(p.ts_s, 1.0 / k, 0.001), "{:?}", p.ts_s);
    }

    #[test]
    fn a_sparse_echogram_gives_the_same_decay_as_a_dense_one() {
        // One arrival per millisecond, decaying with T60 = 0.8 s.
        let k = 6.0 * std::f64::consts::LN_10 / 0.8;
        let arrivals: Vec<Arrival> = (0..2000)
            .map(|i| {
                let t = 0.005 + i as f64 * 0.001;
                Arrival {
                    delay_s: t,
                    direction: Vec3::X,
                    pressure_gain: [(-k * (t - 0.005) / 2.0).exp() as f32; BAND_COUNT],
                }
            })
            .collect();
        let bands = per_band(&arrivals, &[0, 4]).unwrap();
        assert_eq!(bands.len(), 2);
        assert_eq!(bands[1].0, 1000.0);
        let p = bands[1].1;
        for (what, value) in [("EDT", p.edt_s), ("T20", p.t20_s), ("T30", p.t30_s)] {
            assert!(close(value, 0.8, 0.01), "{what}: {value:?}");
        }
    }

    #[test]
    fn clarity_definition_and_centre_time_of_a_known_echogram() {
        // Direct sound at 10 ms; the 70 ms arrival is late for C50 but
        // early for C80.
        let echogram = [(0.2, 0.5), (0.01, 1.0), (0.03, 1.0), (0.07, 2.0)];
        let p = RoomParameters::from_energy(&echogram).unwrap();
        assert!((p.c50_db.unwrap() - 10.0 * (2.0f64 / 2.5).log10()).abs() < 1e-12);
        assert!((p.c80_db.unwrap() - 10.0 * 8f64.log10()).abs() < 1e-12);
        assert_eq!(p.d50, Some(2.0 / 4.5));
        let ts = (0.02 + 0.06 * 2.0 + 0.19 * 0.5) / 4.5;
        assert!((p.ts_s.unwrap() - ts).abs() < 1e-12);
    }

    #[test]
    fn a_single_arrival_has_infinite_clarity_and_no_decay() {
        let p = RoomParameters::from_energy(&[(0.02, 0.3)]).unwrap();
        assert_eq!(
            p,
            RoomParameters {
                d50: Some(1.0),
                ts_s: Some(0.0),
                ..RoomParameters::default()
            }
        );
    }

    #[test]
    fn a_decay_that_stops_short_of_the_range_has_no_time() {
        // 0 dB then a step to −20 dB: EDT and T20 see points, T30 ends at
        // −20 dB and then the energy runs out.
        let echogram = [(0.0, 1.0), (0.1, 0.01), (0.2, 0.0)];
        let p = RoomParameters::from_energy(&echogram).unwrap();
        assert_eq!(p.t30_s, None);
        // Silence gives nothing at all.
        let silent = RoomParameters::from_energy(&[(0.0, 0.0), (1.0, 0.0)]).unwrap();
        assert_eq!(silent, RoomParameters::default());
        assert_eq!(
            RoomParameters::from_energy(&[]).unwrap(),
            RoomParameters::default()
        );
    }

    #[test]
    fn a_sampled_signal_matches_its_energy_echogram() {
        let rate = 48_000;
        let k = 6.0 * std::f64::consts::LN_10 / 0.5;
        let signal: Vec<f32> = (0..rate)
            .map(|i| (-k * f64::from(i) / f64::from(rate) / 2.0).exp() as f32)
            .collect();
        let p = RoomParameters::from_signal(&signal, rate).unwrap();
        assert!(close(p.t30_s, 0.5, 0.01), "{:?}", p.t30_s);
        assert!(RoomParameters::from_signal(&signal, 0).is_err());
    }

    #[test]
    fn parameters_serialize_with_snake_case_names() {
        let p = RoomParameters::from_energy(&[(0.0, 1.0)]).unwrap();
        let json = serde_json::to_value(p).unwrap();
        assert_eq!(json["d50"], 1.0);
        assert!(json["c50_db"].is_null());
        for key in ["edt_s", "t20_s", "t30_s", "c80_db", "ts_s"] {
            assert!(json.get(key).is_some(), "{key}");
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        for bad in [
            (f64::NAN, 1.0),
            (-1.0, 1.0),
            (0.0, -1.0),
            (0.0, f64::INFINITY),
        ] {
            assert!(RoomParameters::from_energy(&[(0.0, 1.0), bad]).is_err());
        }
        assert!(per_band(&[], &[8]).is_err());
    }
}
