//! A zero-phase octave filter bank, applied in the frequency domain.
//!
//! Each band has a real, non-negative magnitude mask over frequency. The
//! masks are raised-cosine crossovers on a log2 frequency axis: band k is 1
//! at its centre 1000·2^(k−4) Hz and fades as sin² into its neighbours over
//! one octave, crossing over halfway (in octaves) between centres. The lowest
//! band extends flat down to DC and the highest flat up to Nyquist. At every
//! frequency the masks of the two bands around it add up to 1, so the masks
//! are complementary: equal signals in all bands come out unchanged.
//!
//! Real masks have zero phase, so filtering delays nothing; the price is that
//! each band's response rings both before and after an impulse. Signals are
//! therefore zero-padded by [`TAIL_S`] before the FFT so that the ringing
//! after the end of the signal does not wrap round onto its start.

use std::sync::Arc;

use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};

use super::air::band_centre_hz;
use crate::scene::BAND_COUNT;
use crate::{Error, Result};

/// How far, in seconds, a band's response rings on either side of an
/// impulse before it is negligible; the lowest band rings longest.
pub const TAIL_S: f64 = 0.1;

/// The per-band signals `bands` (one per octave band, all the same length,
/// sampled at `sample_rate`), each filtered to its own band and summed:
/// a signal of the same length, with no delay.
pub fn filter_and_sum(bands: &[Vec<f32>], sample_rate: u32) -> Result<Vec<f32>> {
    if bands.len() != BAND_COUNT {
        return Err(Error::InvalidAudio(format!(
            "the filter bank takes {BAND_COUNT} band signals, got {}",
            bands.len()
        )));
    }
    let len = bands[0].len();
    if bands.iter().any(|b| b.len() != len) {
        return Err(Error::InvalidAudio(
            "all band signals must have the same length".into(),
        ));
    }
    let mut bank = OctaveFilterBank::new(len, sample_rate)?;
    for (band, signal) in bands.iter().enumerate() {
        if signal.iter().all(|&s| s == 0.0) {
            continue;
        }
        for (slot, &s) in bank.input().iter_mut().zip(signal) {
            *slot = f64::from(s);
        }
        bank.add(band);
    }
    Ok(bank.finish())
}

/// The filter bank as a one-band-at-a-time accumulator, so that a caller
/// rendering many bands needs memory for one band signal per bank, not
/// eight:
/// write a band's signal into [`input`](Self::input), [`add`](Self::add) it,
/// repeat, then [`finish`](Self::finish).
///
/// Band signals are written in `f64` (many arrivals add up in them) and
/// transformed in `f32`: half the work of `f64` transforms, and their
/// rounding (about 1e-6 of the loudest sample) lies far below what a 32-bit
/// float output or a -60 dB decay can show.
pub(crate) struct OctaveFilterBank {
    len: usize,
    plan: Arc<Plan>,
    input: Vec<f64>,
    time: Vec<f32>,
    spectrum: Vec<Complex<f32>>,
    sum: Vec<Complex<f32>>,
    scratch: Vec<Complex<f32>>,
}

/// The transforms and band masks of one transform length and sample rate:
/// planning a transform computes its twiddles (a sine and cosine per
/// point), and a mask a logarithm and two sines per bin, which for a 3 s
/// response cost more than filtering it. Built once per process and kept.
struct Plan {
    forward: Arc<dyn RealToComplex<f32>>,
    inverse: Arc<dyn ComplexToReal<f32>>,
    /// Per band, its first non-zero bin and the mask from there.
    masks: Vec<(usize, Vec<f32>)>,
}

/// Plans kept at most: responses of many lengths round to a few
/// [`transform_len`]s, and a plan for a 3 s response at 48 kHz holds about
/// 4 MB.
const KEPT_PLANS: usize = 8;

fn plan(fft_len: usize, sample_rate: u32) -> Arc<Plan> {
    use std::sync::{Mutex, PoisonError};
    type Plans = Vec<((usize, u32), Arc<Plan>)>;
    static PLANS: Mutex<Plans> = Mutex::new(Vec::new());
    let key = (fft_len, sample_rate);
    if let Some((_, p)) = PLANS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .iter()
        .find(|(k, _)| *k == key)
    {
        return p.clone();
    }
    let mut planner = RealFftPlanner::<f32>::new();
    let forward = planner.plan_fft_forward(fft_len);
    let inverse = planner.plan_fft_inverse(fft_len);
    let bins = fft_len / 2 + 1;
    let hz_per_bin = f64::from(sample_rate) / fft_len as f64;
    let masks = (0..BAND_COUNT)
        .map(|band| {
            // The mask is zero outside the octave on either side of the
            // centre (the top band runs to Nyquist).
            let low_hz = if band == 0 {
                0.0
            } else {
                band_centre_hz(band) / 2.0
            };
            let first = ((low_hz / hz_per_bin).floor() as usize).min(bins - 1);
            let last = if band == BAND_COUNT - 1 {
                bins - 1
            } else {
                ((band_centre_hz(band) * 2.0 / hz_per_bin).ceil() as usize).min(bins - 1)
            };
            let weights = (first..=last)
                .map(|bin| band_weight(band, bin as f64 * hz_per_bin) as f32)
                .collect();
            (first, weights)
        })
        .collect();
    let plan = Arc::new(Plan {
        forward,
        inverse,
        masks,
    });
    let mut plans = PLANS.lock().unwrap_or_else(PoisonError::into_inner);
    // Another thread may have planned the same length meanwhile.
    if let Some((_, p)) = plans.iter().find(|(k, _)| *k == key) {
        return p.clone();
    }
    if plans.len() >= KEPT_PLANS {
        plans.remove(0);
    }
    plans.push((key, plan.clone()));
    plan
}

impl OctaveFilterBank {
    /// A bank for signals of `len` samples at `sample_rate` Hz.
    pub(crate) fn new(len: usize, sample_rate: u32) -> Result<Self> {
        if sample_rate == 0 {
            return Err(Error::InvalidAudio("sample rate must be positive".into()));
        }
        let fft_len = transform_len(len + tail_samples(sample_rate));
        let plan = plan(fft_len, sample_rate);
        let scratch_len = plan
            .forward
            .get_scratch_len()
            .max(plan.inverse.get_scratch_len());
        Ok(Self {
            len,
            input: vec![0.0; len],
            time: plan.forward.make_input_vec(),
            spectrum: plan.forward.make_output_vec(),
            sum: plan.forward.make_output_vec(),
            scratch: vec![Complex::default(); scratch_len],
            plan,
        })
    }

    /// A zeroed buffer of the signal length to write one band's signal into.
    pub(crate) fn input(&mut self) -> &mut [f64] {
        self.input.fill(0.0);
        &mut self.input
    }

    /// Filters the signal in [`input`](Self::input) to `band` and adds it to
    /// the sum.
    pub(crate) fn add(&mut self, band: usize) {
        if band >= BAND_COUNT {
            return;
        }
        // The transform leaves its input as scratch: pad it again.
        let (signal, padding) = self.time.split_at_mut(self.len);
        for (t, &x) in signal.iter_mut().zip(&self.input) {
            *t = x as f32;
        }
        padding.fill(0.0);
        self.plan
            .forward
            .process_with_scratch(&mut self.time, &mut self.spectrum, &mut self.scratch)
            .expect("buffers are sized by the plan");
        let (first, weights) = &self.plan.masks[band];
        let bins = self.sum[*first..].iter_mut().zip(&self.spectrum[*first..]);
        for ((sum, &spectrum), &weight) in bins.zip(weights) {
            *sum += spectrum * weight;
        }
    }

    /// Adds the bands `other` (of the same length and rate) has summed,
    /// so that halves of the bands can be filtered on two threads.
    pub(crate) fn merge(&mut self, other: &Self) {
        for (sum, &o) in self.sum.iter_mut().zip(&other.sum) {
            *sum += o;
        }
    }

    /// The filtered, summed signal.
    pub(crate) fn finish(mut self) -> Vec<f32> {
        // A real signal's spectrum has no imaginary part at DC or Nyquist;
        // clear the rounding noise the inverse transform would reject.
        let n = self.sum.len();
        self.sum[0].im = 0.0;
        self.sum[n - 1].im = 0.0;
        self.plan
            .inverse
            .process_with_scratch(&mut self.sum, &mut self.time, &mut self.scratch)
            .expect("buffers are sized by the plan");
        let scale = 1.0 / self.time.len() as f32;
        self.time[..self.len].iter().map(|&s| s * scale).collect()
    }
}

/// The shortest even length of at least `n` (and 16) of the form `m · 2^k`
/// with `m` in [`LADDER`]: the transforms run about as fast per point at
/// these lengths as at powers of two, the next power of two is up to twice
/// as long (a 2 s response at 48 kHz: 102,400 points instead of 131,072),
/// and seven lengths an octave keep responses of nearby lengths on one
/// plan.
fn transform_len(n: usize) -> usize {
    // Even lengths only: the last bin is then Nyquist's (see `finish`).
    let mut scale = 1;
    loop {
        if let Some(len) = LADDER
            .iter()
            .map(|m| m * scale)
            .find(|&len| len >= n && len % 2 == 0)
        {
            return len;
        }
        scale *= 2;
    }
}

/// The steps of [`transform_len`] within an octave: every 2-3-5-smooth
/// number in [16, 32), at most 20 % apart (25 % below 32, where the odd
/// ones are skipped).
const LADDER: [usize; 7] = [16, 18, 20, 24, 25, 27, 30];

/// The filter tail [`TAIL_S`] in samples at `sample_rate`.
pub(crate) fn tail_samples(sample_rate: u32) -> usize {
    (TAIL_S * f64::from(sample_rate)).ceil() as usize
}

/// The mask of `band` at `hz`: the rise from the band below minus the rise
/// into the band above, so that the masks of all bands sum to exactly 1.
fn band_weight(band: usize, hz: f64) -> f64 {
    // Octaves above the lowest centre: band k's centre sits at x = k.
    let x = if hz > 0.0 {
        (hz / band_centre_hz(0)).log2()
    } else {
        f64::NEG_INFINITY
    };
    let rise = |crossover: f64| {
        let t = (x - crossover + 0.5).clamp(0.0, 1.0);
        (std::f64::consts::FRAC_PI_2 * t).sin().powi(2)
    };
    let from_below = if band == 0 {
        1.0
    } else {
        rise(band as f64 - 0.5)
    };
    let into_above = if band + 1 == BAND_COUNT {
        0.0
    } else {
        rise(band as f64 + 0.5)
    };
    from_below - into_above
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: u32 = 48_000;

    #[test]
    fn transform_lengths_are_the_next_rungs_of_the_ladder() {
        let rungs: Vec<usize> = (0..20)
            .flat_map(|k| LADDER.map(|m| m << k))
            .filter(|r| r % 2 == 0)
            .collect();
        for n in (0..5000).chain([153_600, 1_000_001]) {
            let want = rungs.iter().copied().filter(|&r| r >= n).min().unwrap();
            assert_eq!(transform_len(n), want, "n = {n}");
        }
        assert_eq!(transform_len(153_600), 163_840);
        assert_eq!(transform_len(100_000), 102_400);
        assert_eq!(transform_len(0), 16);
        assert!((0..5000).all(|n| transform_len(n) % 2 == 0));
    }

    fn energy(signal: &[f32]) -> f64 {
        signal.iter().map(|&s| f64::from(s).powi(2)).sum()
    }

    #[test]
    fn masks_are_complementary_and_non_negative() {
        for rate in [8_000.0, 44_100.0, 48_000.0, 384_000.0] {
            for i in 0..=4096 {
                let hz = rate / 2.0 * i as f64 / 4096.0;
                let weights: Vec<f64> = (0..BAND_COUNT).map(|b| band_weight(b, hz)).collect();
                assert!(weights.iter().all(|&w| (0.0..=1.0).contains(&w)));
                let sum: f64 = weights.iter().sum();
                assert!((sum - 1.0).abs() < 1e-12, "{hz} Hz: {sum}");
            }
        }
        // Each band is exactly 1 at its own centre and 1/2 at the crossovers.
        for band in 0..BAND_COUNT {
            assert!((band_weight(band, band_centre_hz(band)) - 1.0).abs() < 1e-12);
        }
        let crossover = band_centre_hz(3) * 2f64.sqrt();
        assert!((band_weight(3, crossover) - 0.5).abs() < 1e-12);
        assert!((band_weight(4, crossover) - 0.5).abs() < 1e-12);
        assert_eq!(band_weight(0, 0.0), 1.0);
        assert_eq!(band_weight(7, 24_000.0), 1.0);
    }

    #[test]
    fn equal_impulses_in_every_band_reproduce_the_impulse() {
        let mut impulse = vec![0.0f32; 3000];
        impulse[1234] = 1.0;
        let out = filter_and_sum(&vec![impulse.clone(); BAND_COUNT], RATE).unwrap();
        assert_eq!(out.len(), impulse.len());
        for (i, (&o, &e)) in out.iter().zip(&impulse).enumerate() {
            assert!((o - e).abs() < 1e-5, "sample {i}: {o}");
        }
    }

    #[test]
    fn a_sine_passes_its_own_band_and_not_two_bands_away() {
        // 1 kHz (band 4) for half a second under a Hann window.
        let n = RATE as usize / 2;
        let sine: Vec<f32> = (0..n)
            .map(|i| {
                let t = i as f64 / f64::from(RATE);
                let window = (std::f64::consts::PI * i as f64 / n as f64).sin().powi(2);
                (window * (std::f64::consts::TAU * 1000.0 * t).sin()) as f32
            })
            .collect();
        let only = |band: usize| {
            let mut bands = vec![vec![0.0f32; n]; BAND_COUNT];
            bands[band] = sine.clone();
            energy(&filter_and_sum(&bands, RATE).unwrap())
        };
        let input = energy(&sine);
        let db = |e: f64| 10.0 * (e / input).log10();
        assert!(db(only(4)).abs() < 0.01, "own band: {} dB", db(only(4)));
        assert!(db(only(2)) < -20.0, "two below: {} dB", db(only(2)));
        assert!(db(only(6)) < -20.0, "two above: {} dB", db(only(6)));
    }

    #[test]
    fn ringing_stays_within_the_tail() {
        // The lowest band rings longest; TAIL_S must hold all but a tiny
        // fraction of its impulse response's energy.
        let len = 4 * tail_samples(RATE);
        let centre = len / 2;
        let mut bands = vec![vec![0.0f32; len]; BAND_COUNT];
        bands[0][centre] = 1.0;
        let out = filter_and_sum(&bands, RATE).unwrap();
        let tail = tail_samples(RATE);
        let outside = energy(&out[..centre - tail]) + energy(&out[centre + tail..]);
        let ratio_db = 10.0 * (outside / energy(&out)).log10();
        assert!(ratio_db < -60.0, "{ratio_db} dB outside the tail");
    }

    #[test]
    fn ringing_after_the_end_does_not_wrap_onto_the_start() {
        // The start is beyond the impulse's pre-ringing, and the length is a
        // power of two, so without padding the post-ringing would land there.
        let len = 8192;
        assert!(len > tail_samples(RATE) + 100);
        let mut bands = vec![vec![0.0f32; len]; BAND_COUNT];
        bands[0][len - 1] = 1.0;
        let out = filter_and_sum(&bands, RATE).unwrap();
        let peak = out.iter().fold(0.0f32, |m, &s| m.max(s.abs()));
        let start = out[..100].iter().fold(0.0f32, |m, &s| m.max(s.abs()));
        assert!(start < 1e-4 * peak, "start {start}, peak {peak}");
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(filter_and_sum(&vec![vec![0.0; 4]; 3], RATE).is_err());
        let mut ragged = vec![vec![0.0; 4]; BAND_COUNT];
        ragged[5].push(1.0);
        assert!(filter_and_sum(&ragged, RATE).is_err());
        assert!(filter_and_sum(&vec![vec![0.0; 4]; BAND_COUNT], 0).is_err());
        assert_eq!(
            filter_and_sum(&vec![Vec::new(); BAND_COUNT], RATE).unwrap(),
            Vec::<f32>::new()
        );
    }
}
