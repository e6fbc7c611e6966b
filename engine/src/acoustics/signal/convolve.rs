//! FFT convolution, and auralization: playing dry audio through an impulse
//! response.
//!
//! Convolution is overlap-add: the impulse response is transformed once, and
//! the dry signal is cut into blocks about as long as it, each transformed,
//! multiplied and transformed back. Working memory is a few times the
//! impulse response's length however long the dry signal is; only the
//! output grows with it. Transforms run in f64 so that long responses keep
//! their quiet tails.

use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

use super::ImpulseResponse;
use crate::{Error, Result};

/// The smallest transform used, so that short impulse responses are not
/// convolved in needlessly many tiny blocks.
const MIN_FFT_LEN: usize = 4096;

/// The full linear convolution of `dry` with `ir`: `dry.len() + ir.len() − 1`
/// samples, or none if either is empty.
pub fn convolve(dry: &[f32], ir: &[f32]) -> Vec<f32> {
    if dry.is_empty() || ir.is_empty() {
        return Vec::new();
    }
    let out_len = dry.len() + ir.len() - 1;
    let fft_len = (2 * ir.len())
        .next_power_of_two()
        .max(MIN_FFT_LEN)
        .min(out_len.next_power_of_two());
    // A block of this many dry samples convolves without wrapping round.
    let block = fft_len - ir.len() + 1;
    let mut planner = RealFftPlanner::<f64>::new();
    let forward = planner.plan_fft_forward(fft_len);
    let inverse = planner.plan_fft_inverse(fft_len);
    let mut scratch =
        vec![Complex::default(); forward.get_scratch_len().max(inverse.get_scratch_len())];
    let mut time = forward.make_input_vec();
    let mut spectrum = forward.make_output_vec();
    let mut ir_spectrum = forward.make_output_vec();
    for (slot, &s) in time.iter_mut().zip(ir) {
        *slot = f64::from(s);
    }
    forward
        .process_with_scratch(&mut time, &mut ir_spectrum, &mut scratch)
        .expect("buffers are sized by the plan");
    // Fold the inverse transform's 1/N into the response once.
    let scale = 1.0 / fft_len as f64;
    for bin in &mut ir_spectrum {
        *bin *= scale;
    }
    let last = ir_spectrum.len() - 1;

    let mut output = vec![0.0f32; out_len];
    for (index, chunk) in dry.chunks(block).enumerate() {
        time.fill(0.0);
        for (slot, &s) in time.iter_mut().zip(chunk) {
            *slot = f64::from(s);
        }
        forward
            .process_with_scratch(&mut time, &mut spectrum, &mut scratch)
            .expect("buffers are sized by the plan");
        for (bin, &response) in spectrum.iter_mut().zip(&ir_spectrum) {
            *bin *= response;
        }
        // Products of real signals' spectra are real at DC and Nyquist;
        // clear the rounding noise the inverse transform would reject.
        spectrum[0].im = 0.0;
        spectrum[last].im = 0.0;
        inverse
            .process_with_scratch(&mut spectrum, &mut time, &mut scratch)
            .expect("buffers are sized by the plan");
        let start = index * block;
        let len = (chunk.len() + ir.len() - 1).min(out_len - start);
        for (out, &s) in output[start..start + len].iter_mut().zip(&time) {
            *out += s as f32;
        }
    }
    output
}

/// Plays `dry` (one signal per channel, all the same length, at `dry_rate`
/// Hz) through `ir`. A mono dry signal through a multi-channel response
/// gives one output per response channel (mono through binaural gives the
/// two ears); several dry channels through a mono response each go through
/// it; equal channel counts pair up channel by channel.
///
/// Errors: different sample rates, no channels on either side, dry channels
/// of different lengths, or channel counts that fit none of the above.
pub fn auralize(dry: &[Vec<f32>], dry_rate: u32, ir: &ImpulseResponse) -> Result<Vec<Vec<f32>>> {
    if dry_rate != ir.sample_rate {
        return Err(Error::InvalidAudio(format!(
            "the dry audio is at {dry_rate} Hz but the impulse response at {} Hz; resample one of them",
            ir.sample_rate
        )));
    }
    if dry.is_empty() || ir.channels.is_empty() {
        return Err(Error::InvalidAudio(
            "auralization needs at least one dry channel and one impulse response channel".into(),
        ));
    }
    if dry.iter().any(|c| c.len() != dry[0].len()) {
        return Err(Error::InvalidAudio(
            "the dry channels differ in length".into(),
        ));
    }
    let (d, r) = (dry.len(), ir.channels.len());
    let pairs: Vec<(&Vec<f32>, &Vec<f32>)> = if d == 1 {
        ir.channels.iter().map(|c| (&dry[0], c)).collect()
    } else if r == 1 {
        dry.iter().map(|c| (c, &ir.channels[0])).collect()
    } else if d == r {
        dry.iter().zip(&ir.channels).collect()
    } else {
        return Err(Error::InvalidAudio(format!(
            "cannot play {d} dry channels through a {r}-channel impulse response: use one dry channel, a mono response, or equal counts"
        )));
    };
    Ok(pairs
        .into_iter()
        .map(|(dry, ir)| convolve(dry, ir))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic noise in [−1, 1).
    fn noise(len: usize, seed: u64) -> Vec<f32> {
        let mut state = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (0..len)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 40) as f64 / (1u64 << 23) as f64 - 1.0) as f32
            })
            .collect()
    }

    fn direct(a: &[f32], b: &[f32]) -> Vec<f64> {
        let mut out = vec![0.0f64; a.len() + b.len() - 1];
        for (i, &x) in a.iter().enumerate() {
            for (j, &y) in b.iter().enumerate() {
                out[i + j] += f64::from(x) * f64::from(y);
            }
        }
        out
    }

    #[test]
    fn matches_direct_convolution() {
        // One block, two blocks, and many short blocks.
        for (dry_len, ir_len) in [(300, 200), (10_000, 3000), (50_000, 100), (5, 7000)] {
            let dry = noise(dry_len, 1);
            let ir = noise(ir_len, 2);
            let fast = convolve(&dry, &ir);
            let slow = direct(&dry, &ir);
            assert_eq!(fast.len(), slow.len());
            let peak = slow.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (i, (&f, &s)) in fast.iter().zip(&slow).enumerate() {
                assert!(
                    (f64::from(f) - s).abs() < 1e-4 * peak,
                    "{dry_len}×{ir_len} sample {i}: {f} vs {s}"
                );
            }
        }
    }

    #[test]
    fn a_unit_impulse_is_the_identity_and_a_shifted_one_a_delay() {
        let dry = noise(20_000, 3);
        let same = convolve(&dry, &[1.0]);
        assert_eq!(same.len(), dry.len());
        assert!(same.iter().zip(&dry).all(|(a, b)| (a - b).abs() < 1e-6));
        let delayed = convolve(&dry, &[0.0, 0.0, 1.0]);
        assert_eq!(delayed.len(), dry.len() + 2);
        assert!(delayed[..2].iter().all(|s| s.abs() < 1e-6));
        assert!(delayed[2..]
            .iter()
            .zip(&dry)
            .all(|(a, b)| (a - b).abs() < 1e-6));
        assert!(convolve(&[], &[1.0]).is_empty());
        assert!(convolve(&[1.0], &[]).is_empty());
    }

    fn response(channels: Vec<Vec<f32>>) -> ImpulseResponse {
        ImpulseResponse {
            sample_rate: 48_000,
            channels,
        }
    }

    #[test]
    fn auralize_maps_channels() {
        let binaural = response(vec![vec![1.0], vec![0.0, 0.5]]);
        let out = auralize(&[vec![1.0, 2.0]], 48_000, &binaural).unwrap();
        assert_eq!(out.len(), 2);
        assert!(out[0]
            .iter()
            .zip([1.0, 2.0])
            .all(|(a, b)| (a - b).abs() < 1e-6));
        assert!(out[1]
            .iter()
            .zip([0.0, 0.5, 1.0])
            .all(|(a, b)| (a - b).abs() < 1e-6));

        let mono = response(vec![vec![0.0, 2.0]]);
        let stereo = auralize(&[vec![1.0], vec![-1.0]], 48_000, &mono).unwrap();
        assert_eq!(stereo.len(), 2);
        assert!((stereo[0][1] - 2.0).abs() < 1e-6 && (stereo[1][1] + 2.0).abs() < 1e-6);

        let paired = auralize(&[vec![1.0], vec![3.0]], 48_000, &binaural).unwrap();
        assert!((paired[0][0] - 1.0).abs() < 1e-6 && (paired[1][1] - 1.5).abs() < 1e-6);
    }

    #[test]
    fn auralize_rejects_mismatches() {
        let binaural = response(vec![vec![1.0], vec![1.0]]);
        let three = vec![vec![0.0; 4]; 3];
        assert!(auralize(&three, 48_000, &binaural).is_err());
        assert!(auralize(&[vec![0.0; 4]], 44_100, &binaural).is_err());
        assert!(auralize(&[], 48_000, &binaural).is_err());
        assert!(auralize(&[vec![0.0; 4]], 48_000, &response(vec![])).is_err());
        assert!(auralize(&[vec![0.0; 4], vec![0.0; 5]], 48_000, &binaural).is_err());
    }
}
