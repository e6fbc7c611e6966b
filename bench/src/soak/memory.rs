//! The server's resident set over the run, sampled once a second, and
//! whether it stayed flat. Memory may grow while caches, pools and the
//! allocator's arenas fill (the warm-up); after that a server that frees
//! what it no longer needs stays near one level.

use serde::{Deserialize, Serialize};

/// "Flat": the maximum and the last window's median within this fraction
/// of the reference.
pub const TOLERANCE: f64 = 0.10;

#[derive(Debug, Serialize, Deserialize)]
pub struct Memory {
    /// Samples before this are the warm-up, not judged.
    pub warmup_s: f64,
    /// Length of the reference window (right after the warm-up) and of
    /// the last window (the run's end).
    pub window_s: f64,
    /// Median `VmRSS` over the reference window.
    pub reference_mib: f64,
    /// Largest sample after the warm-up, and when.
    pub max_mib: f64,
    pub max_at_s: f64,
    /// Median over the last window.
    pub last_median_mib: f64,
    /// The last sample (after the clients deleted their scenes).
    pub final_mib: f64,
    /// Least-squares slope after the warm-up: how fast it grows, if it does.
    pub slope_mib_per_min: f64,
    pub flat: bool,
    /// `VmRSS` once a second from the start of the load.
    pub samples_mib: Vec<f64>,
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    (!v.is_empty()).then(|| v[v.len() / 2])
}

/// `samples`: (seconds since the load started, MiB). `None` when a
/// window holds no sample (the run was cut short).
pub fn analyse(samples: &[(f64, f64)], warmup_s: f64, window_s: f64) -> Option<Memory> {
    let (&(end_s, final_mib), _) = samples.split_last()?;
    let between = |lo: f64, hi: f64| -> Vec<f64> {
        samples
            .iter()
            .filter(|&&(t, _)| t >= lo && t < hi)
            .map(|&(_, m)| m)
            .collect()
    };
    let reference_mib = median(between(warmup_s, warmup_s + window_s))?;
    let last_median_mib = median(between(end_s - window_s, f64::INFINITY))?;
    let after: Vec<(f64, f64)> = samples
        .iter()
        .copied()
        .filter(|&(t, _)| t >= warmup_s)
        .collect();
    let &(max_at_s, max_mib) = after.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let n = after.len() as f64;
    let (mt, mm) = (
        after.iter().map(|s| s.0).sum::<f64>() / n,
        after.iter().map(|s| s.1).sum::<f64>() / n,
    );
    let var: f64 = after.iter().map(|s| (s.0 - mt).powi(2)).sum();
    let cov: f64 = after.iter().map(|s| (s.0 - mt) * (s.1 - mm)).sum();
    let slope_mib_per_min = if var > 0.0 { 60.0 * cov / var } else { 0.0 };
    let within = |v: f64| (v / reference_mib - 1.0).abs() <= TOLERANCE;
    Some(Memory {
        warmup_s,
        window_s,
        reference_mib,
        max_mib,
        max_at_s,
        last_median_mib,
        final_mib,
        slope_mib_per_min,
        flat: within(max_mib) && within(last_median_mib),
        samples_mib: samples.iter().map(|s| s.1).collect(),
    })
}

/// `+4.2%` of the reference.
pub fn relative(v: f64, reference: f64) -> String {
    format!("{:+.1}%", 100.0 * (v / reference - 1.0))
}
