//! Similarity and error metrics between a measured and a simulated quantity, as used by the
//! 15-DOF bearing–gear paper to validate envelope spectra: Pearson's r, the peak of the
//! normalised cross-correlation with its lag, RMSE and NRMSE.

use serde::{Deserialize, Serialize};

/// How the RMSE is normalised into NRMSE (%).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Normaliser {
    /// `max − min` of the measured quantity (the seed's definition). Default.
    #[default]
    Range,
    /// Mean of the measured quantity.
    Mean,
    /// Standard deviation of the measured quantity.
    Std,
}

impl Normaliser {
    /// The normalising value for `measured`.
    pub fn value(self, measured: &[f64]) -> f64 {
        let n = measured.len().max(1) as f64;
        match self {
            Normaliser::Range => {
                let (lo, hi) = measured.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
                hi - lo
            }
            Normaliser::Mean => measured.iter().sum::<f64>() / n,
            Normaliser::Std => {
                let m = measured.iter().sum::<f64>() / n;
                (measured.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt()
            }
        }
    }

    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Normaliser::Range => "max - min of measured",
            Normaliser::Mean => "mean of measured",
            Normaliser::Std => "std of measured",
        }
    }
}

/// The metrics of one comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Pearson correlation coefficient r ∈ [−1, 1].
    pub pearson: f64,
    /// Peak of the normalised cross-correlation ∈ [−1, 1].
    pub xcorr_peak: f64,
    /// Lag of that peak in samples (positive: the simulated quantity lags the measured one).
    pub xcorr_lag: i64,
    /// Root-mean-square error, in the quantity's unit.
    pub rmse: f64,
    /// RMSE / normaliser × 100.
    pub nrmse_percent: f64,
    /// The normaliser used.
    pub normaliser: Normaliser,
    /// Its value.
    pub normaliser_value: f64,
    /// Number of points compared.
    pub points: usize,
}

/// Pearson's correlation coefficient of two equal-length sequences (0 if either is constant).
///
/// `r = Σ(a−ā)(b−b̄) / √(Σ(a−ā)² Σ(b−b̄)²)`.
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 0.0;
    }
    let (a, b) = (&a[..n], &b[..n]);
    let ma = a.iter().sum::<f64>() / n as f64;
    let mb = b.iter().sum::<f64>() / n as f64;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// Peak of the normalised cross-correlation `ρ(k) = Σ (a_i − ā)(b_{i+k} − b̄) / (N σ_a σ_b)`
/// over lags `|k| ≤ max_lag`, computed by FFT; returns `(ρ_peak, k)` with the largest |ρ|,
/// sign kept. Both sequences are truncated to the shorter length.
pub fn xcorr_peak(a: &[f64], b: &[f64], max_lag: usize) -> (f64, i64) {
    use crate::dsp::fft;
    use num_complex::Complex64;
    let n = a.len().min(b.len());
    if n < 2 {
        return (0.0, 0);
    }
    let ma = a[..n].iter().sum::<f64>() / n as f64;
    let mb = b[..n].iter().sum::<f64>() / n as f64;
    let sa = (a[..n].iter().map(|x| (x - ma).powi(2)).sum::<f64>()).sqrt();
    let sb = (b[..n].iter().map(|x| (x - mb).powi(2)).sum::<f64>()).sqrt();
    if sa == 0.0 || sb == 0.0 {
        return (0.0, 0);
    }
    let m = fft::next_pow2(2 * n);
    let mut pa = vec![0.0; m];
    let mut pb = vec![0.0; m];
    for i in 0..n {
        pa[i] = a[i] - ma;
        pb[i] = b[i] - mb;
    }
    let fa = fft::rfft(&pa);
    let fb = fft::rfft(&pb);
    let prod: Vec<Complex64> = fa.iter().zip(&fb).map(|(x, y)| x.conj() * y).collect();
    let r = fft::irfft(&prod, m);
    let max_lag = max_lag.min(n - 1);
    let mut best = (0.0f64, 0i64);
    for k in 0..=max_lag {
        for (lag, idx) in [(k as i64, k), (-(k as i64), (m - k) % m)] {
            let v = r[idx] / (sa * sb);
            if v.abs() > best.0.abs() + 1e-15 || (k == 0 && lag == 0) && best.0 == 0.0 {
                best = (v, lag);
            }
        }
    }
    best
}

/// NRMSE (%) of an RMSE for a normaliser value: `RMSE / |normaliser| × 100` (∞ for a zero
/// normaliser). The one definition [`metrics`], the seed floor and the debiased error use.
pub fn nrmse_percent(rmse: f64, normaliser_value: f64) -> f64 {
    if normaliser_value.abs() > 0.0 {
        rmse / normaliser_value.abs() * 100.0
    } else {
        f64::INFINITY
    }
}

/// All metrics of `simulated` against `measured` (equal lengths; the shorter length is used).
pub fn metrics(measured: &[f64], simulated: &[f64], normaliser: Normaliser, max_lag: usize) -> Metrics {
    let n = measured.len().min(simulated.len());
    metrics_normalised_by(measured, simulated, normaliser, normaliser.value(&measured[..n]), max_lag)
}

/// [`metrics`] with the normalising value given: `normaliser` taken over a larger measured
/// quantity than the part compared here (every SCF α-slice is normalised by the measured SCF
/// over all compared slices, see [`super::CompareOptions::scf_one_normaliser`]).
pub fn metrics_normalised_by(measured: &[f64], simulated: &[f64], normaliser: Normaliser, normaliser_value: f64, max_lag: usize) -> Metrics {
    let n = measured.len().min(simulated.len());
    let (a, b) = (&measured[..n], &simulated[..n]);
    let rmse = if n == 0 { 0.0 } else { (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n as f64).sqrt() };
    let nv = normaliser_value;
    let (xp, lag) = xcorr_peak(a, b, max_lag);
    Metrics {
        pearson: pearson(a, b),
        xcorr_peak: xp,
        xcorr_lag: lag,
        rmse,
        nrmse_percent: nrmse_percent(rmse, nv),
        normaliser,
        normaliser_value: nv,
        points: n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pearson_of_known_cases() {
        let a: Vec<f64> = (0..100).map(|i| (i as f64 * 0.1).sin()).collect();
        let b: Vec<f64> = a.iter().map(|x| 3.0 * x + 2.0).collect();
        assert!((pearson(&a, &b) - 1.0).abs() < 1e-12);
        let c: Vec<f64> = a.iter().map(|x| -x).collect();
        assert!((pearson(&a, &c) + 1.0).abs() < 1e-12);
        assert_eq!(pearson(&a, &vec![1.0; 100]), 0.0);
    }

    /// Direct O(n²) cross-correlation, the naive reference.
    fn xcorr_direct(a: &[f64], b: &[f64], k: i64) -> f64 {
        let n = a.len();
        let ma = a.iter().sum::<f64>() / n as f64;
        let mb = b.iter().sum::<f64>() / n as f64;
        let sa = a.iter().map(|x| (x - ma).powi(2)).sum::<f64>().sqrt();
        let sb = b.iter().map(|x| (x - mb).powi(2)).sum::<f64>().sqrt();
        let mut s = 0.0;
        for i in 0..n as i64 {
            let j = i + k;
            if j >= 0 && j < n as i64 {
                s += (a[i as usize] - ma) * (b[j as usize] - mb);
            }
        }
        s / (sa * sb)
    }

    #[test]
    fn xcorr_finds_a_known_lag_and_matches_direct() {
        let x = crate::signal::synth::white_noise(500, 1.0, 3);
        let lag = 17usize;
        let mut y = vec![0.0; 500];
        y[lag..].copy_from_slice(&x[..500 - lag]);
        let (p, k) = xcorr_peak(&x, &y, 50);
        assert_eq!(k, lag as i64);
        assert!((p - xcorr_direct(&x, &y, lag as i64)).abs() < 1e-12);
        assert!(p > 0.9);
        let (p2, k2) = xcorr_peak(&y, &x, 50);
        assert_eq!(k2, -(lag as i64));
        assert!((p2 - p).abs() < 1e-12);
    }

    #[test]
    fn nrmse_uses_the_stated_normaliser() {
        let m = [0.0, 1.0, 2.0, 3.0, 4.0];
        let s = [0.0, 1.0, 2.0, 3.0, 5.0];
        let r = metrics(&m, &s, Normaliser::Range, 0);
        assert!((r.rmse - (1.0f64 / 5.0).sqrt()).abs() < 1e-12);
        assert!((r.nrmse_percent - r.rmse / 4.0 * 100.0).abs() < 1e-12);
        let r = metrics(&m, &s, Normaliser::Mean, 0);
        assert!((r.nrmse_percent - r.rmse / 2.0 * 100.0).abs() < 1e-12);
        let r = metrics(&m, &s, Normaliser::Std, 0);
        assert!((r.normaliser_value - 2.0f64.sqrt()).abs() < 1e-12);
    }
}
