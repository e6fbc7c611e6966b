//! The late part of an impulse response as an energy histogram, and the
//! Dirac sequence that renders it.
//!
//! Stochastic tracing yields, per listener, the energy arriving in each
//! band within consecutive time bins. Parameters (EDT, T20, …) read the
//! histogram itself, whose expected value is the room's energy decay. The
//! signal needs a fine structure the histogram does not have: as in
//! Schröder's hybrid method (RAVEN), each bin is rendered as Dirac
//! impulses of random sign at random sample positions, their count
//! following the reflection density of a room of the histogram's volume
//! (4πc³t²/V, capped at [`MAX_DENSITY_PER_S`]) and never below one per
//! non-empty bin, each impulse carrying an equal share of the bin's energy
//! per band. The rendering then treats them like any arrival: each band's
//! impulses pass through its octave filter, so band energies are kept.
//! Every channel draws its own sequence (binaural ears decorrelate); a
//! sequence depends only on its seed, channel and bin, so a tail whose
//! envelope is unchanged renders to the same samples.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::scene::{Bands, BAND_COUNT};

/// The highest density of the Dirac sequence, impulses per second: above
/// about 10⁴ per second reflections are heard as a continuum, and the cap
/// bounds the work per second of tail.
pub const MAX_DENSITY_PER_S: f64 = 20_000.0;

/// Energy arriving at one listener per band in consecutive bins of
/// `bin_s` seconds from the emission of the sound, in the unit of an
/// arrival's squared pressure gain (1 at 1 m from the source).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EnergyHistogram {
    pub bin_s: f64,
    /// `bins[k][b]`: the energy of band `b` arriving in `[k, k + 1) · bin_s`.
    pub bins: Vec<Bands>,
    /// The room volume the reflection density is taken from, m³.
    pub volume_m3: f64,
    pub speed_of_sound: f64,
    /// Seed of the Dirac sequences.
    pub seed: u64,
}

impl EnergyHistogram {
    /// Total energy of band `b`.
    pub fn energy(&self, band: usize) -> f64 {
        self.bins.iter().map(|e| f64::from(e[band])).sum()
    }

    /// The end of the last non-empty bin, s (0 for an empty histogram).
    pub fn duration_s(&self) -> f64 {
        let last = self
            .bins
            .iter()
            .rposition(|e| e.iter().any(|&v| v > 0.0))
            .map_or(0, |k| k + 1);
        last as f64 * self.bin_s
    }

    /// Band `band` as an echogram: (bin centre, energy) of each non-empty
    /// bin.
    pub fn echogram(&self, band: usize) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.bins
            .iter()
            .enumerate()
            .filter(move |(_, e)| e[band] > 0.0)
            .map(move |(k, e)| ((k as f64 + 0.5) * self.bin_s, f64::from(e[band])))
    }

    /// Impulses per second expected at time `t_s` in a room of this volume.
    fn density_per_s(&self, t_s: f64) -> f64 {
        let c = self.speed_of_sound;
        (4.0 * std::f64::consts::PI * c.powi(3) * t_s * t_s / self.volume_m3.max(1e-9))
            .min(MAX_DENSITY_PER_S)
    }

    /// The Dirac sequence of channel `channel` at `sample_rate`: (sample
    /// index, pressure gain per band) of each impulse, in time order. The
    /// squared gains of a bin's impulses sum to the bin's energy.
    pub fn dirac_sequence(&self, channel: u64, sample_rate: u32) -> Vec<(usize, Bands)> {
        let rate = f64::from(sample_rate);
        let mut out = Vec::new();
        for (k, energy) in self.bins.iter().enumerate() {
            if energy.iter().all(|&e| e <= 0.0) {
                continue;
            }
            let start = k as f64 * self.bin_s;
            let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
            rng.set_stream(channel << 32 | k as u64);
            let expected = self.density_per_s(start + 0.5 * self.bin_s) * self.bin_s;
            // Rounded at random so the mean count is the expected one.
            let count = (expected.floor() as usize
                + usize::from(rng.random::<f64>() < expected.fract()))
            .max(1);
            let mut gains: Bands = [0.0; BAND_COUNT];
            for (g, &e) in gains.iter_mut().zip(energy) {
                *g = (f64::from(e) / count as f64).sqrt() as f32;
            }
            let first = out.len();
            for _ in 0..count {
                let t = start + rng.random::<f64>() * self.bin_s;
                let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
                out.push(((t * rate) as usize, gains.map(|g| g * sign)));
            }
            out[first..].sort_by_key(|&(i, _)| i);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn histogram(bins: Vec<Bands>) -> EnergyHistogram {
        EnergyHistogram {
            bin_s: 1e-3,
            bins,
            volume_m3: 180.0,
            speed_of_sound: 343.0,
            seed: 7,
        }
    }

    #[test]
    fn each_bins_impulses_carry_its_energy_per_band() {
        let mut bins = vec![[0.0; BAND_COUNT]; 400];
        for (k, bin) in bins.iter_mut().enumerate().skip(3) {
            for (b, e) in bin.iter_mut().enumerate() {
                *e = (k as f32 + 1.0) * 1e-3 / (b as f32 + 1.0);
            }
        }
        let h = histogram(bins);
        let rate = 48_000;
        let diracs = h.dirac_sequence(0, rate);
        let mut sums = vec![[0.0f64; BAND_COUNT]; h.bins.len()];
        for &(i, g) in &diracs {
            let k = i * 1000 / rate as usize;
            for b in 0..BAND_COUNT {
                sums[k][b] += f64::from(g[b]).powi(2);
            }
        }
        for (k, (sum, bin)) in sums.iter().zip(&h.bins).enumerate() {
            for b in 0..BAND_COUNT {
                let want = f64::from(bin[b]);
                assert!(
                    (sum[b] - want).abs() <= 1e-5 * want.max(1e-12),
                    "bin {k} band {b}: {} vs {want}",
                    sum[b]
                );
            }
        }
        // The density grows as t²: late bins hold many more impulses.
        let count_in = |k: usize| diracs.iter().filter(|(i, _)| i / 48 == k).count();
        assert_eq!(count_in(3), 1);
        assert!(count_in(399) > 10, "{}", count_in(399));
    }

    #[test]
    fn sequences_repeat_per_seed_and_differ_per_channel() {
        let h = histogram(vec![[1e-3; BAND_COUNT]; 200]);
        assert_eq!(h.dirac_sequence(0, 48_000), h.dirac_sequence(0, 48_000));
        assert_ne!(h.dirac_sequence(0, 48_000), h.dirac_sequence(1, 48_000));
        let other = EnergyHistogram {
            seed: 8,
            ..h.clone()
        };
        assert_ne!(h.dirac_sequence(0, 48_000), other.dirac_sequence(0, 48_000));
    }

    #[test]
    fn empty_bins_and_histograms_give_no_impulses() {
        assert!(histogram(vec![]).dirac_sequence(0, 48_000).is_empty());
        let h = histogram(vec![[0.0; BAND_COUNT]; 50]);
        assert!(h.dirac_sequence(0, 48_000).is_empty());
        assert_eq!(h.duration_s(), 0.0);
    }
}
