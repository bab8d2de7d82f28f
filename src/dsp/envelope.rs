//! The analytic signal (Hilbert transform), the envelope, and envelope spectra — the
//! classic demodulation for rolling-element bearing faults.

use super::error::{check_band, check_finite, check_fs, DspError};
use super::fft;
use super::spectrum::Spectrum;
use super::window::Window;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// The Hilbert transform `H{x}` of a real record (the imaginary part of the analytic
/// signal), computed with one real FFT and one inverse real FFT.
fn hilbert_transform(x: &[f64]) -> Result<Vec<f64>, DspError> {
    if x.is_empty() {
        return Err(DspError::TooShort { what: "analytic signal (x is empty)", needed: 1, got: 0 });
    }
    check_finite(x)?;
    let n = x.len();
    let r2c = fft::r2c(n);
    let c2r = fft::c2r(n);
    let mut buf = x.to_vec();
    let mut spec = r2c.make_output_vec();
    let mut scratch = vec![Complex64::new(0.0, 0.0); r2c.get_scratch_len().max(c2r.get_scratch_len())];
    let fft_err = |e: realfft::FftError| DspError::InvalidParameter { name: "x", value: format!("{n} samples"), reason: format!("FFT failed: {e}") };
    r2c.process_with_scratch(&mut buf, &mut spec, &mut scratch).map_err(fft_err)?;
    // H{x} has spectrum −j·sgn(f)·X: multiply the positive-frequency bins by −j/n (the 1/n
    // normalises the inverse FFT); DC and, for even n, Nyquist are zeroed.
    let scale = 1.0 / n as f64;
    let last = spec.len() - 1;
    for (k, z) in spec.iter_mut().enumerate() {
        if k == 0 || (n.is_multiple_of(2) && k == last) {
            *z = Complex64::new(0.0, 0.0);
        } else {
            *z = Complex64::new(z.im * scale, -z.re * scale);
        }
    }
    // buf is free again (the forward transform used it as scratch): reuse it as output.
    c2r.process_with_scratch(&mut spec, &mut buf, &mut scratch).map_err(fft_err)?;
    Ok(buf)
}

/// The analytic signal `x + j·H{x}` of a real record, equal to `scipy.signal.hilbert(x)`.
///
/// # Arguments
/// * `x` — real record, at least 1 finite sample (any length, odd or even).
///
/// # Returns
/// Complex samples, same length as `x`; the real part is `x` itself.
///
/// # Notes
/// `Z[k] = X[k] · h[k]` with `h[0] = 1`, `h[k] = 2` for `0 < k < n/2`, `h[n/2] = 1` (even
/// `n`) and 0 for negative frequencies, `z = IDFT(Z)`. Computed as `x + j·irfft(−j·X·u)`
/// with `u` = 1 on the strictly positive, non-Nyquist bins: one real FFT and one inverse
/// real FFT of length `n` instead of two complex FFTs. The DFT treats `x` as periodic, so
/// the envelope shows transients at the ends of a record that does not hold whole periods.
///
/// # Errors
/// `TooShort` for empty `x`, `NonFinite` for NaN/inf.
///
/// # References
/// * S. L. Marple, "Computing the discrete-time analytic signal via FFT", IEEE Trans.
///   Signal Process. 47(9), 2600–2603, 1999.
/// * SciPy, `scipy.signal.hilbert`, the numerical reference.
pub fn analytic_signal(x: &[f64]) -> Result<Vec<Complex64>, DspError> {
    let h = hilbert_transform(x)?;
    Ok(x.iter().zip(&h).map(|(&re, &im)| Complex64::new(re, im)).collect())
}

/// The envelope `|x + j·H{x}|` of a real record (see [`analytic_signal`]).
///
/// For `x(t) = a(t) cos(2πf_c t)` with `a ≥ 0` band-limited below `f_c`, this is `a(t)`.
///
/// # Errors
/// `TooShort` for empty `x`, `NonFinite` for NaN/inf.
pub fn envelope(x: &[f64]) -> Result<Vec<f64>, DspError> {
    let mut h = hilbert_transform(x)?;
    for (e, &v) in h.iter_mut().zip(x) {
        *e = (v * v + *e * *e).sqrt();
    }
    Ok(h)
}

/// The squared envelope `|x + j·H{x}|²` (see [`analytic_signal`]).
///
/// # Errors
/// `TooShort` for empty `x`, `NonFinite` for NaN/inf.
pub fn squared_envelope(x: &[f64]) -> Result<Vec<f64>, DspError> {
    let mut h = hilbert_transform(x)?;
    for (e, &v) in h.iter_mut().zip(x) {
        *e = v * v + *e * *e;
    }
    Ok(h)
}

/// Parameters of [`envelope_spectrum`] and [`squared_envelope_spectrum`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EnvelopeParams {
    /// Band `[low, high]` in Hz of the envelope SPECTRUM to return (e.g. `[0, 200]` to see
    /// fault frequencies and a few harmonics), `0 ≤ low < high ≤ fs/2`.
    /// Default: `None` = 0..Nyquist. (Band-pass the signal around the resonance before
    /// calling; this does not filter the signal.)
    pub band_hz: Option<[f64; 2]>,
    /// Use the squared envelope. Default: `false`.
    pub squared: bool,
    /// Window applied to the (mean-removed) envelope before its FFT. Default: `hann`
    /// (low leakage; its coherent gain is divided out, so a bin-centred modulation of
    /// amplitude `m` still reads `m`).
    pub window: Window,
    /// Subtract the envelope's mean before windowing, so the large DC term does not leak
    /// into the lowest bins (with Hann a DC of 1 would read 1 at bin 1). Default: `true`.
    pub remove_mean: bool,
}

impl Default for EnvelopeParams {
    /// Whole band, plain (not squared) envelope, Hann window, mean removed.
    fn default() -> Self {
        Self { band_hz: None, squared: false, window: Window::Hann, remove_mean: true }
    }
}

impl EnvelopeParams {
    /// Checks the band against `0 ≤ low < high ≤ fs/2`.
    pub fn validate(&self, fs_hz: f64) -> Result<(), DspError> {
        check_fs(fs_hz)?;
        if let Some([lo, hi]) = self.band_hz {
            check_band("band_hz", lo, hi, fs_hz)?;
        }
        Ok(())
    }
}

/// Spectrum of the envelope (or, with `params.squared`, of the squared envelope).
///
/// # Arguments
/// * `x` — the record (usually band-passed around a structural resonance), at least 2
///   finite samples.
/// * `fs_hz` — sampling rate in Hz, positive.
/// * `params` — [`EnvelopeParams`]: `band_hz` (None = 0..Nyquist), `squared` (false),
///   `window` (hann), `remove_mean` (true).
///
/// # Returns
/// [`Spectrum`] with the bins of `band_hz` on their real frequency axis `k·fs/n` Hz,
/// `quantity` `"envelope spectrum (peak)"` or `"squared envelope spectrum (peak)"`,
/// unit empty (the envelope is in the unit of `x`, the squared envelope in its square).
///
/// # Notes
/// Scaling (peak): with `e[n]` the envelope (or squared envelope), `ē` its mean,
/// `E[k] = c_k |Σ_n w[n] (e[n] − ē) e^{−j2πkn/n}| / Σ_n w[n]`, `c_k = 2` except at DC
/// and the even-length Nyquist bin. So for `x(t) = (1 + m cos 2πf_m t) cos 2πf_c t`
/// (`f_m < f_c`), whose envelope is `1 + m cos 2πf_m t`, the envelope spectrum reads `m`
/// at a bin-centred `f_m` (a unit-amplitude modulation reads its amplitude). The squared
/// envelope `(1 + m cos)² = 1 + m²/2 + 2m cos 2πf_m t + (m²/2) cos 2π(2f_m) t` reads `2m`
/// at `f_m` and `m²/2` at `2f_m`.
///
/// # Errors
/// `InvalidParameter` (`fs_hz`), `BandOutOfRange` (`band_hz`), `TooShort`, `NonFinite`.
///
/// # References
/// * R. B. Randall, J. Antoni, "Rolling element bearing diagnostics — A tutorial",
///   Mech. Syst. Signal Process. 25(2), 485–520, 2011.
pub fn envelope_spectrum(x: &[f64], fs_hz: f64, params: &EnvelopeParams) -> Result<Spectrum, DspError> {
    params.validate(fs_hz)?;
    if x.len() < 2 {
        return Err(DspError::TooShort { what: "envelope spectrum", needed: 2, got: x.len() });
    }
    let mut e = if params.squared { squared_envelope(x)? } else { envelope(x)? };
    let n = e.len();
    if params.remove_mean {
        let mean = e.iter().sum::<f64>() / n as f64;
        e.iter_mut().for_each(|v| *v -= mean);
    }
    let (win, gain) = params.window.periodic_with_gain(n)?;
    e.iter_mut().zip(&win).for_each(|(v, w)| *v *= w);
    let plan = fft::r2c(n);
    let mut spec = plan.make_output_vec();
    plan.process(&mut e, &mut spec).map_err(|err| DspError::InvalidParameter {
        name: "x",
        value: format!("{n} samples"),
        reason: format!("FFT failed: {err}"),
    })?;
    let df = fs_hz / n as f64;
    let (k0, k1) = match params.band_hz {
        Some([lo, hi]) => {
            // Bins with lo ≤ k·df ≤ hi (a tiny tolerance keeps bins that sit on the edges).
            let tol = 1e-9;
            let k0 = (lo / df - tol).ceil().max(0.0) as usize;
            let k1 = ((hi / df + tol).floor() as usize).min(spec.len() - 1);
            (k0, k1)
        }
        None => (0, spec.len() - 1),
    };
    let nyq = if n.is_multiple_of(2) { Some(n / 2) } else { None };
    let inv_gain = 1.0 / gain;
    let (frequency_hz, values) = if k0 <= k1 {
        (
            (k0..=k1).map(|k| k as f64 * df).collect(),
            (k0..=k1)
                .map(|k| {
                    let c = if k == 0 || Some(k) == nyq { 1.0 } else { 2.0 };
                    c * spec[k].norm() * inv_gain
                })
                .collect(),
        )
    } else {
        (Vec::new(), Vec::new())
    };
    let quantity = if params.squared { "squared envelope spectrum (peak)" } else { "envelope spectrum (peak)" };
    Ok(Spectrum { frequency_hz, values, quantity: quantity.into(), unit: String::new() })
}

/// [`envelope_spectrum`] of the squared envelope, whatever `params.squared` says.
///
/// For `x(t) = (1 + m cos 2πf_m t) cos 2πf_c t` it reads `2m` at `f_m` and `m²/2` at
/// `2f_m` (bin-centred). Squaring weights impulsive content more and is the
/// spectral-kurtosis-friendly form (Randall & Antoni 2011, §4).
///
/// # Errors
/// As [`envelope_spectrum`].
pub fn squared_envelope_spectrum(x: &[f64], fs_hz: f64, params: &EnvelopeParams) -> Result<Spectrum, DspError> {
    let p = EnvelopeParams { squared: true, ..params.clone() };
    envelope_spectrum(x, fs_hz, &p)
}
