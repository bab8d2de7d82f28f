//! Resampling by the Fourier method (as `scipy.signal.resample`).

use super::error::{check_finite, check_fs, DspError};
use super::fft;
use num_complex::Complex64;

/// Resamples `x` from `fs_in_hz` to `fs_out_hz` by the Fourier method: the one-sided spectrum
/// is truncated (down-sampling, an ideal anti-alias filter) or zero-padded (up-sampling) to
/// `m = round(n · fs_out / fs_in)` samples and inverted. The record is treated as periodic, as
/// in `scipy.signal.resample(x, m)`; the even-length Nyquist bin is split/halved as scipy does.
///
/// Returns the resampled record (amplitude preserved: a tone of amplitude A stays A).
pub fn resample(x: &[f64], fs_in_hz: f64, fs_out_hz: f64) -> Result<Vec<f64>, DspError> {
    check_fs(fs_in_hz)?;
    check_fs(fs_out_hz)?;
    check_finite(x)?;
    let n = x.len();
    if n < 2 {
        return Err(DspError::TooShort { what: "resampling", needed: 2, got: n });
    }
    let m = (n as f64 * fs_out_hz / fs_in_hz).round() as usize;
    if m < 2 {
        return Err(DspError::InvalidParameter { name: "fs_out_hz", value: fs_out_hz.to_string(), reason: format!("leaves fewer than 2 samples of {n}") });
    }
    if m == n {
        return Ok(x.to_vec());
    }
    let spec = fft::rfft(x);
    let keep = n.min(m) / 2 + 1;
    let mut out = vec![Complex64::new(0.0, 0.0); m / 2 + 1];
    out[..keep].copy_from_slice(&spec[..keep]);
    // Nyquist handling as scipy: when the shorter length is even, its Nyquist bin is shared
    // between ±f; up-sampling halves it, down-sampling unites the pair, X(f) + X(−f) = 2 Re X(f)
    // for a real record (tests/fixtures/resample). The model's anti-alias decimation uses this
    // function too (`model::simulate`).
    let short = n.min(m);
    if short.is_multiple_of(2) {
        let k = short / 2;
        if m > n {
            out[k] *= 0.5;
        } else {
            out[k] = Complex64::new(2.0 * out[k].re, 0.0);
        }
    }
    let scale = m as f64 / n as f64;
    let y = fft::irfft(&out, m);
    Ok(y.into_iter().map(|v| v * scale).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn tone_keeps_amplitude_and_frequency() {
        let (fs, f0) = (16384.0, 120.0);
        let n = 16384;
        let x: Vec<f64> = (0..n).map(|i| 0.7 * (TAU * f0 * i as f64 / fs).cos()).collect();
        let y = resample(&x, fs, 12000.0).unwrap();
        assert_eq!(y.len(), 12000);
        for (i, v) in y.iter().enumerate() {
            assert!((v - 0.7 * (TAU * f0 * i as f64 / 12000.0).cos()).abs() < 1e-9, "{i}");
        }
        let z = resample(&y, 12000.0, fs).unwrap();
        for (a, b) in z.iter().zip(&x) {
            assert!((a - b).abs() < 1e-9);
        }
    }

    #[test]
    fn bad_input_is_refused() {
        assert!(resample(&[1.0], 10.0, 5.0).is_err());
        assert!(resample(&[1.0, f64::NAN, 2.0], 10.0, 5.0).is_err());
        assert!(resample(&[1.0, 2.0, 3.0], 0.0, 5.0).is_err());
    }
}
