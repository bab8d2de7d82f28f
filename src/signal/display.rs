//! Display helpers: reduce a long record to what a screen can show without losing its peaks,
//! and rescale spectrum values for a linear, logarithmic or decibel axis.
//!
//! These are pure functions with no GUI dependency, so the desktop workbench (`src/gui`) only
//! draws their results and the reductions are unit-tested here.

use serde::{Deserialize, Serialize};

/// A min/max envelope of a signal: one `(time, min, max)` triple per display bucket.
///
/// Drawing the band between `min` and `max` (or a line through min, max, min, max, ...) keeps
/// every extreme of the record visible, however many samples fall into one pixel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MinMaxTrace {
    /// Start time of each bucket, s.
    pub time_s: Vec<f64>,
    /// Smallest sample in each bucket.
    pub min: Vec<f64>,
    /// Largest sample in each bucket.
    pub max: Vec<f64>,
    /// Samples per bucket (1 when the visible range holds fewer samples than buckets, in which
    /// case `min == max` = the samples themselves).
    pub samples_per_bucket: usize,
}

impl MinMaxTrace {
    /// Number of buckets.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// True when the trace holds no bucket.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// Min/max decimation of `samples` (sampled at `fs_hz`) over the time range `[t0_s, t1_s]` into
/// at most `buckets` buckets, for display.
///
/// Method: the sample indices covering the range (clamped to the record) are split into
/// `buckets` contiguous runs of `ceil(n / buckets)` samples; each run gives its minimum and
/// maximum. With at most `buckets` samples in range, each sample is its own bucket. One pass,
/// O(n) in the samples in range; no sample is skipped, so a single-sample spike always appears
/// as the `max` (or `min`) of its bucket.
///
/// Arguments: `samples` (any unit), `fs_hz` sampling rate in Hz, `t0_s`/`t1_s` the visible time
/// range in s (any order; non-finite bounds mean the whole record), `buckets` the number of
/// display columns (typically the plot width in pixels; 0 is treated as 1).
///
/// Returns an empty trace for an empty record, a non-positive or non-finite `fs_hz`, or a range
/// that misses the record. Never panics.
pub fn min_max_decimate(samples: &[f64], fs_hz: f64, t0_s: f64, t1_s: f64, buckets: usize) -> MinMaxTrace {
    let n = samples.len();
    if n == 0 || !(fs_hz.is_finite() && fs_hz > 0.0) {
        return MinMaxTrace::default();
    }
    let (a, b) = if t0_s <= t1_s { (t0_s, t1_s) } else { (t1_s, t0_s) };
    let start = if a.is_finite() { (a * fs_hz).floor().max(0.0) } else { 0.0 };
    let end = if b.is_finite() { ((b * fs_hz).ceil() + 1.0).max(0.0) } else { n as f64 };
    let start = (start.min(n as f64)) as usize;
    let end = (end.min(n as f64)) as usize;
    if start >= end {
        return MinMaxTrace::default();
    }
    let buckets = buckets.max(1);
    let count = end - start;
    let per = count.div_ceil(buckets).max(1);
    let nb = count.div_ceil(per);
    let mut out = MinMaxTrace { time_s: Vec::with_capacity(nb), min: Vec::with_capacity(nb), max: Vec::with_capacity(nb), samples_per_bucket: per };
    for (k, chunk) in samples[start..end].chunks(per).enumerate() {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &v in chunk {
            if v < lo {
                lo = v;
            }
            if v > hi {
                hi = v;
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            // A bucket of NaN only: show nothing rather than a fake zero.
            continue;
        }
        out.time_s.push((start + k * per) as f64 / fs_hz);
        out.min.push(lo);
        out.max.push(hi);
    }
    out
}

/// How spectrum values are shown on the vertical axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum AmplitudeScale {
    /// The values as they are.
    #[default]
    Linear,
    /// `log10(value)` (values ≤ 0 are floored at the smallest positive value / 1e6).
    Log10,
    /// Decibels re 1 unit: `20 log10` for amplitudes, `10 log10` for powers and PSDs (same
    /// floor as `Log10`).
    Db,
}

impl AmplitudeScale {
    /// A short axis word: `lin`, `log10`, `dB`.
    pub fn name(self) -> &'static str {
        match self {
            AmplitudeScale::Linear => "lin",
            AmplitudeScale::Log10 => "log10",
            AmplitudeScale::Db => "dB",
        }
    }
}

/// Rescales `values` for display. `power` selects `10 log10` (power, PSD) rather than
/// `20 log10` (amplitude) for [`AmplitudeScale::Db`].
///
/// Values ≤ 0 or non-finite have no logarithm: they are floored at `floor = min_positive / 1e6`
/// (or 1e-300 when nothing is positive), so a zero bin shows as a deep notch instead of a gap.
pub fn scale_values(values: &[f64], scale: AmplitudeScale, power: bool) -> Vec<f64> {
    if scale == AmplitudeScale::Linear {
        return values.to_vec();
    }
    let min_pos = values.iter().copied().filter(|v| v.is_finite() && *v > 0.0).fold(f64::INFINITY, f64::min);
    let floor = if min_pos.is_finite() { min_pos * 1e-6 } else { 1e-300 };
    let factor = match (scale, power) {
        (AmplitudeScale::Db, true) => 10.0,
        (AmplitudeScale::Db, false) => 20.0,
        _ => 1.0,
    };
    values.iter().map(|&v| factor * if v.is_finite() && v > 0.0 { v } else { floor }.log10()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A single-sample spike in 10 million samples survives decimation to 1000 buckets, and so
    /// does a single-sample dip; every other bucket stays within the noise amplitude.
    #[test]
    fn single_sample_spike_in_ten_million_survives() {
        let n = 10_000_000;
        let fs = 48_000.0;
        let mut x: Vec<f64> = (0..n).map(|i| 0.01 * ((i as f64) * 0.37).sin()).collect();
        let spike_at = 7_654_321;
        let dip_at = 1_234_567;
        x[spike_at] = 5.0;
        x[dip_at] = -3.0;
        let tr = min_max_decimate(&x, fs, 0.0, n as f64 / fs, 1000);
        assert_eq!(tr.len(), 1000);
        assert_eq!(tr.samples_per_bucket, 10_000);
        let max = tr.max.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = tr.min.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(max, 5.0);
        assert_eq!(min, -3.0);
        let k = tr.max.iter().position(|&v| v == 5.0).unwrap();
        assert_eq!(k, spike_at / 10_000);
        assert!((tr.time_s[k] - (k * 10_000) as f64 / fs).abs() < 1e-12);
        assert_eq!(tr.max.iter().filter(|&&v| v > 0.011).count(), 1);
        assert_eq!(tr.min.iter().filter(|&&v| v < -0.011).count(), 1);
    }

    /// A zoomed range decimates only the samples inside it, and few samples are kept as is.
    #[test]
    fn range_and_identity() {
        let x: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let tr = min_max_decimate(&x, 10.0, 2.0, 3.0, 1000);
        assert_eq!(tr.samples_per_bucket, 1);
        assert_eq!(tr.min, (20..=30).map(|i| i as f64).collect::<Vec<_>>());
        assert_eq!(tr.min, tr.max);
        let tr = min_max_decimate(&x, 10.0, 0.0, 9.9, 10);
        assert_eq!(tr.len(), 10);
        assert_eq!((tr.min[3], tr.max[3]), (30.0, 39.0));
        // reversed bounds, out of range, degenerate inputs
        assert_eq!(min_max_decimate(&x, 10.0, 9.9, 0.0, 10), tr);
        assert!(min_max_decimate(&x, 10.0, 20.0, 30.0, 10).is_empty());
        assert!(min_max_decimate(&[], 10.0, 0.0, 1.0, 10).is_empty());
        assert!(min_max_decimate(&x, 0.0, 0.0, 1.0, 10).is_empty());
        assert_eq!(min_max_decimate(&x, 10.0, f64::NAN, f64::INFINITY, 0).len(), 1);
    }

    #[test]
    fn scales() {
        let v = [1.0, 10.0, 100.0, 0.0];
        assert_eq!(scale_values(&v, AmplitudeScale::Linear, false), v.to_vec());
        let l = scale_values(&v, AmplitudeScale::Log10, false);
        assert_eq!(&l[..3], &[0.0, 1.0, 2.0]);
        assert!((l[3] + 6.0).abs() < 1e-12, "zero floored at min/1e6: {}", l[3]);
        let a = scale_values(&v, AmplitudeScale::Db, false);
        assert!((a[2] - 40.0).abs() < 1e-12);
        let p = scale_values(&v, AmplitudeScale::Db, true);
        assert!((p[2] - 20.0).abs() < 1e-12);
    }
}
