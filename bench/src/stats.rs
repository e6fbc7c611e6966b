//! Summaries of repeated timings.

/// The upper median of `v` (the middle sample of an odd count; of an even
/// count, the higher of the two middle ones): a measured value, never an
/// average of two. `v` must not be empty.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
