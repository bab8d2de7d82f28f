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

/// Block minima and maxima of a record at several resolutions (blocks of 16, 256, 4096 and
/// 65536 samples), built once, so that [`MinMaxPyramid::decimate`] costs O(display columns +
/// blocks in view) instead of O(samples in view): a 10-minute 48 kHz record redraws in well
/// under a millisecond however far it is zoomed out.
///
/// Memory: about one byte per sample (two `f64` per 16 samples, plus the coarser levels).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MinMaxPyramid {
    /// `(samples per block, minima, maxima)`, finest first. A block of NaN only holds
    /// `(+inf, -inf)`.
    levels: Vec<(usize, Vec<f64>, Vec<f64>)>,
    /// Length of the record it was built from.
    n: usize,
}

impl MinMaxPyramid {
    /// Samples per block of the finest level; each level is this many times coarser.
    pub const FACTOR: usize = 16;

    /// Builds the levels of `samples` (one pass over the record, then over each level).
    pub fn new(samples: &[f64]) -> Self {
        let mut levels: Vec<(usize, Vec<f64>, Vec<f64>)> = Vec::new();
        let f = Self::FACTOR;
        if samples.len() >= 2 * f {
            let (mut lo, mut hi) = (Vec::with_capacity(samples.len() / f + 1), Vec::with_capacity(samples.len() / f + 1));
            for c in samples.chunks(f) {
                // f64::min/max ignore NaN: a block of NaN only stays (+inf, -inf).
                let (a, b) = c.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
                lo.push(a);
                hi.push(b);
            }
            levels.push((f, lo, hi));
            while let Some((block, lo, hi)) = levels.last() {
                if lo.len() < 2 * f || levels.len() >= 4 {
                    break;
                }
                let nlo: Vec<f64> = lo.chunks(f).map(|c| c.iter().copied().fold(f64::INFINITY, f64::min)).collect();
                let nhi: Vec<f64> = hi.chunks(f).map(|c| c.iter().copied().fold(f64::NEG_INFINITY, f64::max)).collect();
                let b = block * f;
                levels.push((b, nlo, nhi));
            }
        }
        Self { levels, n: samples.len() }
    }

    /// Whether the pyramid was built from a record of this length.
    pub fn fits(&self, samples: &[f64]) -> bool {
        self.n == samples.len()
    }

    /// Like [`min_max_decimate`] (same arguments and return), from the coarsest level with at
    /// least 8 blocks per display column. The columns are then whole blocks: their
    /// edges snap to the block grid, so a column may also cover up to one block before the
    /// visible range and one after it; every sample in range is still in exactly one column,
    /// so no peak is lost. Falls back to [`min_max_decimate`] when a column holds fewer than 8
    /// finest blocks, or when `samples` is not the record the pyramid was built from.
    pub fn decimate(&self, samples: &[f64], fs_hz: f64, t0_s: f64, t1_s: f64, buckets: usize) -> MinMaxTrace {
        let n = samples.len();
        if !self.fits(samples) || n == 0 || !(fs_hz.is_finite() && fs_hz > 0.0) {
            return min_max_decimate(samples, fs_hz, t0_s, t1_s, buckets);
        }
        let (a, b) = if t0_s <= t1_s { (t0_s, t1_s) } else { (t1_s, t0_s) };
        let start = if a.is_finite() { (a * fs_hz).floor().max(0.0) } else { 0.0 };
        let end = if b.is_finite() { ((b * fs_hz).ceil() + 1.0).max(0.0) } else { n as f64 };
        let (start, end) = ((start.min(n as f64)) as usize, (end.min(n as f64)) as usize);
        if start >= end {
            return MinMaxTrace::default();
        }
        let buckets = buckets.max(1);
        let per = (end - start).div_ceil(buckets).max(1);
        // At least 8 blocks per column, so snapping to whole blocks widens a column by < 12.5 %.
        let Some((block, lo, hi)) = self.levels.iter().rev().find(|(block, _, _)| 8 * *block <= per) else {
            return min_max_decimate(samples, fs_hz, t0_s, t1_s, buckets);
        };
        let per_blocks = per.div_ceil(*block);
        let (first, last) = (start / block, end.div_ceil(*block).min(lo.len()));
        let mut out = MinMaxTrace { samples_per_bucket: per_blocks * block, ..Default::default() };
        let mut i = first;
        while i < last {
            let j = (i + per_blocks).min(last);
            let mn = lo[i..j].iter().copied().fold(f64::INFINITY, f64::min);
            let mx = hi[i..j].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if mn.is_finite() && mx.is_finite() {
                out.time_s.push((i * block) as f64 / fs_hz);
                out.min.push(mn);
                out.max.push(mx);
            }
            i = j;
        }
        out
    }
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

/// A 2-D map (e.g. the SCF `|S(α, f)|`) reduced to a display grid.
///
/// Row-major `[row][col]`: rows are the map's first axis (α for an SCF map), columns its second
/// (f). Each display cell holds the **maximum** of the map cells it covers, so a narrow ridge
/// (a cyclic line at a bearing fault frequency) survives any reduction.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DisplayGrid {
    /// Centre coordinate of each display row (e.g. α in Hz): the mean of the first and last
    /// map row it covers.
    pub row_coord: Vec<f64>,
    /// Centre coordinate of each display column (e.g. f in Hz).
    pub col_coord: Vec<f64>,
    /// Cell values, row-major, `row_coord.len() × col_coord.len()`.
    pub values: Vec<f64>,
    /// Coordinates of the first and last map row covered.
    pub row_extent: [f64; 2],
    /// Coordinates of the first and last map column covered.
    pub col_extent: [f64; 2],
    /// Map rows per display row (the last one may cover fewer).
    pub rows_per_cell: usize,
    /// Map columns per display column.
    pub cols_per_cell: usize,
    /// Smallest and largest finite cell value (`(NaN, NaN)` when there is none).
    pub min: f64,
    pub max: f64,
}

impl DisplayGrid {
    /// Number of display rows.
    pub fn rows(&self) -> usize {
        self.row_coord.len()
    }

    /// Number of display columns.
    pub fn cols(&self) -> usize {
        self.col_coord.len()
    }

    /// Value of display cell `(r, c)`, or `None` outside the grid.
    pub fn get(&self, r: usize, c: usize) -> Option<f64> {
        (r < self.rows() && c < self.cols()).then(|| self.values[r * self.cols() + c])
    }
}

/// Max-pooling of a row-major map `values` (`row_coord.len() × col_coord.len()`) to at most
/// `out_rows × out_cols` display cells, over the rows whose coordinate lies in
/// `[row_lo, row_hi]` and the columns in `[col_lo, col_hi]` (bounds in either order; non-finite
/// bounds mean the whole axis).
///
/// Method: the selected rows are split into runs of `ceil(n_rows / out_rows)` rows, the columns
/// likewise; each display cell is the maximum of its block (NaN cells are ignored; a block of
/// NaN only gives NaN). One pass over the selected cells. With fewer map cells than display
/// cells, the map is returned as is (`rows_per_cell = cols_per_cell = 1`).
///
/// Returns an empty grid when the shapes disagree, nothing lies in the ranges, or `out_rows` or
/// `out_cols` is 0. Never panics.
#[allow(clippy::too_many_arguments)]
pub fn max_pool_map(values: &[f64], row_coord: &[f64], col_coord: &[f64], row_range: (f64, f64), col_range: (f64, f64), out_rows: usize, out_cols: usize) -> DisplayGrid {
    let (nr, nc) = (row_coord.len(), col_coord.len());
    if nr == 0 || nc == 0 || values.len() != nr * nc || out_rows == 0 || out_cols == 0 {
        return DisplayGrid { min: f64::NAN, max: f64::NAN, ..Default::default() };
    }
    let select = |coord: &[f64], (a, b): (f64, f64)| -> Option<(usize, usize)> {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        let lo = if lo.is_finite() { lo } else { f64::NEG_INFINITY };
        let hi = if hi.is_finite() { hi } else { f64::INFINITY };
        let first = coord.iter().position(|&x| x >= lo && x <= hi)?;
        let last = coord.iter().rposition(|&x| x >= lo && x <= hi)?;
        Some((first, last + 1))
    };
    let (Some((r0, r1)), Some((c0, c1))) = (select(row_coord, row_range), select(col_coord, col_range)) else {
        return DisplayGrid { min: f64::NAN, max: f64::NAN, ..Default::default() };
    };
    let rpc = (r1 - r0).div_ceil(out_rows).max(1);
    let cpc = (c1 - c0).div_ceil(out_cols).max(1);
    let gr = (r1 - r0).div_ceil(rpc);
    let gc = (c1 - c0).div_ceil(cpc);
    let mut out = vec![f64::NAN; gr * gc];
    for r in r0..r1 {
        let orow = (r - r0) / rpc;
        let src = &values[r * nc + c0..r * nc + c1];
        let dst = &mut out[orow * gc..(orow + 1) * gc];
        for (j, &v) in src.iter().enumerate() {
            let d = &mut dst[j / cpc];
            // NaN-ignoring maximum: a NaN cell never replaces a number.
            if !v.is_nan() && (d.is_nan() || v > *d) {
                *d = v;
            }
        }
    }
    let centre = |coord: &[f64], start: usize, end: usize, per: usize, k: usize| -> f64 {
        let a = start + k * per;
        let b = (a + per).min(end) - 1;
        0.5 * (coord[a] + coord[b])
    };
    let row_c = (0..gr).map(|k| centre(row_coord, r0, r1, rpc, k)).collect();
    let col_c = (0..gc).map(|k| centre(col_coord, c0, c1, cpc, k)).collect();
    let finite = out.iter().copied().filter(|v| v.is_finite());
    let (min, max) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let (min, max) = if min <= max { (min, max) } else { (f64::NAN, f64::NAN) };
    DisplayGrid { row_coord: row_c, col_coord: col_c, values: out, row_extent: [row_coord[r0], row_coord[r1 - 1]], col_extent: [col_coord[c0], col_coord[c1 - 1]], rows_per_cell: rpc, cols_per_cell: cpc, min, max }
}

/// The perceptually uniform "viridis" colour scale (van der Walt & Smith, matplotlib 2.0) as
/// sRGB bytes for `t` in `[0, 1]` (clamped; NaN gives the bottom colour): dark blue at 0,
/// green at 0.5, yellow at 1. Piecewise-linear between nine samples of the published table;
/// the lightness rises monotonically, so the scale prints readably in grey.
pub fn viridis(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let w = x - i as f64;
    let c = |k: usize| (STOPS[i][k] + w * (STOPS[i + 1][k] - STOPS[i][k])).round().clamp(0.0, 255.0) as u8;
    [c(0), c(1), c(2)]
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
    /// Max-pooling keeps a one-cell ridge at its place and value, however strong the
    /// reduction, and agrees with a naive block maximum everywhere.
    #[test]
    fn max_pool_keeps_a_single_cell_ridge_and_matches_naive_blocks() {
        let (nr, nc) = (5000, 257);
        let rows: Vec<f64> = (0..nr).map(|i| i as f64 * 0.1).collect();
        let cols: Vec<f64> = (0..nc).map(|j| j as f64 * 23.4).collect();
        let mut v: Vec<f64> = (0..nr * nc).map(|k| 1e-3 * ((k as f64) * 0.7).sin().abs()).collect();
        let (ri, cj) = (1623, 101);
        v[ri * nc + cj] = 2.5;
        v[7] = f64::NAN;
        let g = max_pool_map(&v, &rows, &cols, (f64::NEG_INFINITY, f64::INFINITY), (f64::NAN, f64::NAN), 120, 64);
        assert_eq!((g.rows_per_cell, g.cols_per_cell), (42, 5));
        assert_eq!((g.rows(), g.cols()), (120, 52));
        assert_eq!(g.max, 2.5);
        let k = g.values.iter().position(|&x| x == 2.5).unwrap();
        assert_eq!((k / g.cols(), k % g.cols()), (ri / 42, cj / 5));
        // the ridge's display row covers its α
        let (r, c) = (k / g.cols(), k % g.cols());
        assert!((rows[r * 42]..=rows[(r * 42 + 41).min(nr - 1)]).contains(&rows[ri]));
        assert!((g.row_coord[r] - 0.5 * (rows[r * 42] + rows[r * 42 + 41])).abs() < 1e-9);
        assert!((g.col_coord[c] - 0.5 * (cols[c * 5] + cols[c * 5 + 4])).abs() < 1e-9);
        // naive block maximum
        for r in [0usize, 37, 119] {
            for c in [0usize, 20, 51] {
                let mut m = f64::NAN;
                for i in r * 42..((r + 1) * 42).min(nr) {
                    for j in c * 5..((c + 1) * 5).min(nc) {
                        let x = v[i * nc + j];
                        if !x.is_nan() && (m.is_nan() || x > m) {
                            m = x;
                        }
                    }
                }
                assert_eq!(g.get(r, c), Some(m), "cell ({r}, {c})");
            }
        }
        assert!(g.min > 0.0 && g.min < 1e-3);
    }

    /// A coordinate range selects rows and columns; degenerate inputs give an empty grid.
    #[test]
    fn max_pool_ranges_and_degenerate_inputs() {
        let rows = [0.0, 1.0, 2.0, 3.0];
        let cols = [10.0, 20.0, 30.0];
        let v: Vec<f64> = (0..12).map(|k| k as f64).collect();
        let g = max_pool_map(&v, &rows, &cols, (3.0, 1.0), (15.0, 30.0), 10, 10);
        assert_eq!(g.row_coord, vec![1.0, 2.0, 3.0]);
        assert_eq!((g.row_extent, g.col_extent), ([1.0, 3.0], [20.0, 30.0]));
        assert_eq!(g.col_coord, vec![20.0, 30.0]);
        assert_eq!(g.values, vec![4.0, 5.0, 7.0, 8.0, 10.0, 11.0]);
        assert_eq!((g.min, g.max), (4.0, 11.0));
        let g = max_pool_map(&v, &rows, &cols, (0.0, 3.0), (10.0, 30.0), 2, 1);
        assert_eq!(g.values, vec![5.0, 11.0]);
        assert_eq!(g.row_coord, vec![0.5, 2.5]);
        assert!(max_pool_map(&v[..11], &rows, &cols, (0.0, 3.0), (0.0, 1e9), 2, 2).values.is_empty());
        assert!(max_pool_map(&v, &rows, &cols, (5.0, 6.0), (0.0, 1e9), 2, 2).values.is_empty());
        assert!(max_pool_map(&v, &rows, &cols, (0.0, 3.0), (0.0, 1e9), 0, 2).max.is_nan());
    }

    #[test]
    fn viridis_ends_and_rising_lightness() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
        let luma = |c: [u8; 3]| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
        let mut last = -1.0;
        for i in 0..=100 {
            let l = luma(viridis(i as f64 / 100.0));
            assert!(l > last, "lightness falls at {i} %");
            last = l;
        }
    }
    /// The pyramid keeps every spike, matches the direct decimation when the columns fall on
    /// its block grid, and falls back to it for short ranges.
    #[test]
    fn pyramid_keeps_spikes_and_matches_direct_decimation_on_its_grid() {
        let n = 10_000_000;
        let fs = 48_000.0;
        let mut x: Vec<f64> = (0..n).map(|i| 0.01 * ((i as f64) * 0.37).sin()).collect();
        x[7_654_321] = 5.0;
        x[1_234_567] = -3.0;
        x[99] = f64::NAN;
        let p = MinMaxPyramid::new(&x);
        let tr = p.decimate(&x, fs, 0.0, n as f64 / fs, 1000);
        assert_eq!(tr.samples_per_bucket, 10_240, "10 000 per column rounded up to whole 256-sample blocks");
        assert_eq!(tr.max.iter().copied().fold(f64::NEG_INFINITY, f64::max), 5.0);
        assert_eq!(tr.min.iter().copied().fold(f64::INFINITY, f64::min), -3.0);
        let k = tr.max.iter().position(|&v| v == 5.0).unwrap();
        assert!(tr.time_s[k] <= 7_654_321.0 / fs && 7_654_321.0 / fs < tr.time_s[k] + 10_240.0 / fs);
        // 4096 columns of 2048 samples from 0: exactly the direct result
        let m = 4096 * 2048;
        let direct = min_max_decimate(&x[..m], fs, 0.0, (m - 1) as f64 / fs, 4096);
        let q = MinMaxPyramid::new(&x[..m]);
        let fast = q.decimate(&x[..m], fs, 0.0, (m - 1) as f64 / fs, 4096);
        assert_eq!(direct.samples_per_bucket, 2048);
        assert_eq!(fast, direct);
        // a short range: the direct path
        assert_eq!(p.decimate(&x, fs, 1.0, 1.01, 1000), min_max_decimate(&x, fs, 1.0, 1.01, 1000));
        // another record of another length: the direct path
        assert_eq!(p.decimate(&x[..5000], fs, 0.0, 1.0, 10), min_max_decimate(&x[..5000], fs, 0.0, 1.0, 10));
        assert!(MinMaxPyramid::new(&[]).decimate(&[], fs, 0.0, 1.0, 10).is_empty());
    }
}
