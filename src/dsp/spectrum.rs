//! FFT amplitude spectra, the generic [`Spectrum`] type (band slicing, peak finding, dB),
//! and conversion between acceleration, velocity and displacement in the frequency domain.

use super::error::{check_finite, check_fs, DspError};
use super::fft;
use super::window::Window;
use crate::signal::Signal;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A one-sided spectrum on a real frequency axis: what every spectral stage returns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Frequencies in Hz, increasing.
    pub frequency_hz: Vec<f64>,
    /// Values at `frequency_hz`, in `unit`.
    pub values: Vec<f64>,
    /// What the values are, e.g. `"amplitude (peak)"`, `"power spectral density"`,
    /// `"envelope spectrum (peak)"`, `"velocity amplitude (peak)"`.
    pub quantity: String,
    /// Unit of `values` (e.g. `"g"`, `"g^2/Hz"`, `"dB re 1 g"`); empty when unknown.
    pub unit: String,
}

impl Spectrum {
    /// Number of bins.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True when the spectrum has no bins.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Bin spacing in Hz (from the first two bins; 0 for fewer than two bins).
    pub fn resolution_hz(&self) -> f64 {
        if self.frequency_hz.len() > 1 {
            self.frequency_hz[1] - self.frequency_hz[0]
        } else {
            0.0
        }
    }

    /// The bins with `lo_hz ≤ f ≤ hi_hz`, on their real frequency axis.
    ///
    /// # Errors
    /// `InvalidParameter` (`band_hz`) when a bound is not finite or `lo_hz ≥ hi_hz`.
    /// A band that holds no bin gives an empty spectrum (not an error).
    pub fn band(&self, lo_hz: f64, hi_hz: f64) -> Result<Spectrum, DspError> {
        if !(lo_hz.is_finite() && hi_hz.is_finite() && lo_hz < hi_hz) {
            return Err(DspError::InvalidParameter {
                name: "band_hz",
                value: format!("[{lo_hz}, {hi_hz}]"),
                reason: "the band must be two finite frequencies with low < high (Hz)".into(),
            });
        }
        let start = self.frequency_hz.partition_point(|&f| f < lo_hz);
        let end = self.frequency_hz.partition_point(|&f| f <= hi_hz).max(start);
        let end_v = end.min(self.values.len());
        let start_v = start.min(end_v);
        Ok(Spectrum {
            frequency_hz: self.frequency_hz[start_v..end_v].to_vec(),
            values: self.values[start_v..end_v].to_vec(),
            quantity: self.quantity.clone(),
            unit: self.unit.clone(),
        })
    }

    /// The largest value and its frequency, `None` for an empty spectrum (or all-NaN
    /// values). Interior maxima get the parabolic frequency refinement of
    /// [`top_peaks`](Self::top_peaks); a maximum on the first or last bin is returned as is.
    pub fn peak(&self) -> Option<(f64, f64)> {
        let n = self.values.len().min(self.frequency_hz.len());
        let (i, &v) = self.values[..n]
            .iter()
            .enumerate()
            .filter(|(_, v)| !v.is_nan())
            .max_by(|a, b| a.1.total_cmp(b.1))?;
        if i > 0 && i + 1 < n {
            Some((self.interpolated_frequency(i), v))
        } else {
            Some((self.frequency_hz[i], v))
        }
    }

    /// The `n` largest local maxima, as `(frequency_hz, value)` sorted by decreasing value,
    /// at least `min_separation_hz` apart.
    ///
    /// A local maximum is an interior bin `i` with `v[i−1] < v[i] ≥ v[i+1]` (the first bin
    /// of a plateau); end bins are not candidates. Peaks are taken greedily from the
    /// largest down, skipping any closer than `min_separation_hz` to one already taken.
    /// The frequency is refined by fitting a parabola through the three bins around the
    /// maximum: `δ = ½ (v[i−1] − v[i+1]) / (v[i−1] − 2v[i] + v[i+1])`,
    /// `f = f[i] + δ · Δf`, `|δ| ≤ ½`; the value returned is the bin value `v[i]` itself.
    ///
    /// # Errors
    /// `InvalidParameter` (`min_separation_hz`) when it is negative or not finite.
    pub fn top_peaks(&self, n: usize, min_separation_hz: f64) -> Result<Vec<(f64, f64)>, DspError> {
        if !(min_separation_hz.is_finite() && min_separation_hz >= 0.0) {
            return Err(DspError::InvalidParameter {
                name: "min_separation_hz",
                value: format!("{min_separation_hz}"),
                reason: "the minimum peak separation must be a finite number of Hz ≥ 0".into(),
            });
        }
        let m = self.values.len().min(self.frequency_hz.len());
        let v = &self.values[..m];
        let mut cand: Vec<usize> =
            (1..m.saturating_sub(1)).filter(|&i| v[i] > v[i - 1] && v[i] >= v[i + 1]).collect();
        cand.sort_by(|&a, &b| v[b].total_cmp(&v[a]));
        let mut out: Vec<(f64, f64)> = Vec::with_capacity(n.min(cand.len()));
        for i in cand {
            if out.len() >= n {
                break;
            }
            let f = self.interpolated_frequency(i);
            if out.iter().all(|&(g, _)| (g - f).abs() >= min_separation_hz) {
                out.push((f, v[i]));
            }
        }
        Ok(out)
    }

    /// Parabolic refinement of the frequency of interior bin `i`.
    fn interpolated_frequency(&self, i: usize) -> f64 {
        let (a, b, c) = (self.values[i - 1], self.values[i], self.values[i + 1]);
        let denom = a - 2.0 * b + c;
        let delta = if denom != 0.0 && denom.is_finite() { (0.5 * (a - c) / denom).clamp(-0.5, 0.5) } else { 0.0 };
        let df = 0.5 * (self.frequency_hz[i + 1] - self.frequency_hz[i - 1]);
        self.frequency_hz[i] + delta * df
    }

    /// The same spectrum in decibels, see [`to_db`]; the unit becomes
    /// `"dB re {reference} {unit}"`, e.g. `"dB re 1 g"` or `"dB re 1e-12 g^2/Hz"`.
    pub fn to_db(&self, reference: f64, kind: DbKind) -> Result<Spectrum, DspError> {
        let values = to_db(&self.values, reference, kind)?;
        let unit = if self.unit.is_empty() { format!("dB re {reference}") } else { format!("dB re {reference} {}", self.unit) };
        Ok(Spectrum { frequency_hz: self.frequency_hz.clone(), values, quantity: self.quantity.clone(), unit })
    }
}

/// The square of a unit for power quantities: `"g"` → `"g^2"`, `"m/s^2"` → `"(m/s^2)^2"`,
/// `""` → `""`.
pub fn squared_unit(unit: &str) -> String {
    if unit.is_empty() {
        String::new()
    } else if unit.chars().all(|c| c.is_alphanumeric() || c == 'µ') {
        format!("{unit}^2")
    } else {
        format!("({unit})^2")
    }
}

/// Scaling of [`amplitude_spectrum`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum AmplitudeScaling {
    /// Peak amplitude: a tone `A cos(2πft)` at a bin centre reads `A`.
    #[default]
    Peak,
    /// RMS amplitude: the same tone reads `A/√2` (DC and Nyquist bins read their value).
    Rms,
    /// Power spectrum (RMS²): the tone reads `A²/2`; equal to a one-segment
    /// `welch_psd(.., scaling = Spectrum, detrend = None)`.
    PowerSpectrum,
}

/// Parameters of [`amplitude_spectrum`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpectrumParams {
    /// Window over the whole record (periodic). Default: `hann`.
    pub window: Window,
    /// Peak, RMS or power spectrum. Default: `peak`.
    pub scaling: AmplitudeScaling,
    /// FFT length, ≥ the record length (zero padding). Default: `None` = record length.
    pub nfft: Option<usize>,
}

impl Default for SpectrumParams {
    /// Hann window, peak scaling, no zero padding.
    fn default() -> Self {
        Self { window: Window::Hann, scaling: AmplitudeScaling::Peak, nfft: None }
    }
}

impl SpectrumParams {
    /// Checks `nfft ≥ n_samples` (when set) and `n_samples ≥ 1`.
    pub fn validate(&self, n_samples: usize) -> Result<(), DspError> {
        if n_samples == 0 {
            return Err(DspError::TooShort { what: "amplitude_spectrum (x is empty)", needed: 1, got: 0 });
        }
        if let Some(nfft) = self.nfft {
            if nfft < n_samples {
                return Err(DspError::InvalidParameter {
                    name: "nfft",
                    value: nfft.to_string(),
                    reason: format!("nfft must be ≥ the record length {n_samples}; leave it unset to use the record length"),
                });
            }
        }
        Ok(())
    }
}

/// One-sided amplitude spectrum of a windowed record.
///
/// # Arguments
/// * `x` — the record, in its unit; at least 1 finite sample.
/// * `fs_hz` — sampling rate in Hz, positive.
/// * `params` — [`SpectrumParams`]: `window` (hann), `scaling` (peak), `nfft`
///   (None = `len(x)`; larger values zero-pad).
///
/// # Returns
/// [`Spectrum`] with `nfft/2 + 1` bins at `k·fs/nfft` Hz, `quantity` `"amplitude (peak)"`,
/// `"amplitude (rms)"` or `"power spectrum (rms^2)"`, `unit` empty (see
/// [`amplitude_spectrum_of`] for a [`Signal`] with its unit).
///
/// # Notes
/// With `X[k] = Σ_n w[n] x[n] e^{−j2πkn/nfft}`, the peak scaling is
/// `A[k] = c_k |X[k]| / Σ_n w[n]`, `c_k = 2` except `c_0 = 1` and, for even `nfft`,
/// `c_{nfft/2} = 1`: dividing by the coherent gain `Σw` makes a tone of amplitude `A`
/// read `A` at its bin (exactly at a bin centre; off-centre the Hann window's scalloping
/// loss is up to 1.42 dB — use `flattop` for accurate amplitudes). RMS divides the
/// doubled bins by `√2`; the power spectrum is RMS².
///
/// # References
/// * F. J. Harris, "On the use of windows for harmonic analysis with the discrete Fourier
///   transform", Proc. IEEE 66(1), 51–83, 1978.
/// * R. B. Randall, *Vibration-based Condition Monitoring*, Wiley, 2011, ch. 3.
pub fn amplitude_spectrum(x: &[f64], fs_hz: f64, params: &SpectrumParams) -> Result<Spectrum, DspError> {
    check_fs(fs_hz)?;
    params.validate(x.len())?;
    check_finite(x)?;
    let n = x.len();
    let nfft = params.nfft.unwrap_or(n);
    let (win, gain) = params.window.periodic_with_gain(n)?;
    let plan = fft::r2c(nfft);
    let mut input = plan.make_input_vec();
    for ((b, &v), &w) in input.iter_mut().zip(x).zip(&win) {
        *b = v * w;
    }
    let mut out = plan.make_output_vec();
    plan.process(&mut input, &mut out).map_err(|e| DspError::InvalidParameter {
        name: "nfft",
        value: nfft.to_string(),
        reason: format!("FFT failed: {e}"),
    })?;
    let nyq = if nfft.is_multiple_of(2) { Some(nfft / 2) } else { None };
    let values = out
        .iter()
        .enumerate()
        .map(|(k, z)| {
            let unpaired = k == 0 || Some(k) == nyq;
            let a = z.norm() / gain;
            match params.scaling {
                AmplitudeScaling::Peak => {
                    if unpaired {
                        a
                    } else {
                        2.0 * a
                    }
                }
                AmplitudeScaling::Rms => {
                    if unpaired {
                        a
                    } else {
                        std::f64::consts::SQRT_2 * a
                    }
                }
                AmplitudeScaling::PowerSpectrum => {
                    if unpaired {
                        a * a
                    } else {
                        2.0 * a * a
                    }
                }
            }
        })
        .collect();
    let df = fs_hz / nfft as f64;
    let quantity = match params.scaling {
        AmplitudeScaling::Peak => "amplitude (peak)",
        AmplitudeScaling::Rms => "amplitude (rms)",
        AmplitudeScaling::PowerSpectrum => "power spectrum (rms^2)",
    };
    Ok(Spectrum { frequency_hz: (0..out.len()).map(|k| k as f64 * df).collect(), values, quantity: quantity.into(), unit: String::new() })
}

/// [`amplitude_spectrum`] of a [`Signal`], with the unit filled in from `signal.unit`
/// (squared for the power spectrum).
pub fn amplitude_spectrum_of(signal: &Signal, params: &SpectrumParams) -> Result<Spectrum, DspError> {
    let mut s = amplitude_spectrum(&signal.samples, signal.fs_hz, params)?;
    s.unit = match params.scaling {
        AmplitudeScaling::PowerSpectrum => squared_unit(&signal.unit),
        _ => signal.unit.clone(),
    };
    Ok(s)
}

/// Vibration quantities related by time integration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    /// Acceleration (e.g. m/s²).
    Acceleration,
    /// Velocity (e.g. m/s).
    Velocity,
    /// Displacement (e.g. m).
    Displacement,
}

impl Quantity {
    /// Number of time derivatives of displacement.
    pub fn order(self) -> i32 {
        match self {
            Quantity::Displacement => 0,
            Quantity::Velocity => 1,
            Quantity::Acceleration => 2,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Quantity::Displacement => "displacement",
            Quantity::Velocity => "velocity",
            Quantity::Acceleration => "acceleration",
        }
    }
}

/// Whether a spectrum holds amplitudes (unit) or powers (unit², unit²/Hz).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SpectrumKind {
    /// Magnitudes: amplitude spectra, envelope spectra.
    Amplitude,
    /// Squared magnitudes: PSDs, power spectra.
    Power,
}

/// Converts a spectrum between acceleration, velocity and displacement.
///
/// Each integration step divides the complex spectrum by `j2πf`, so magnitudes
/// ([`SpectrumKind::Amplitude`]) are divided by `2πf` and powers ([`SpectrumKind::Power`])
/// by `(2πf)²`; each differentiation step multiplies by the same factors.
/// `values[k] · (2π f_k)^(−p·s)` with `s = order(from) − order(to)` integration steps
/// (displacement 0, velocity 1, acceleration 2) and `p = 1` (amplitude) or `2` (power).
/// **The bins at `f ≤ 0` (DC) are set to 0**, since integration is undefined there.
///
/// The unit follows when it is one of `m/s^2, m/s, m`, `mm/s^2, mm/s, mm` (or the square
/// of one, optionally `/Hz`); any other non-empty unit gets `·s^s` (amplitude) or
/// `·s^(2s)` (power) appended — a spectrum in `g` becomes `g·s` (multiply by 9.80665 for
/// m/s); no gravity factor is applied silently. `quantity` becomes e.g. `"velocity ..."`.
///
/// # Errors
/// `InvalidParameter` (`spectrum`) when the frequency and value vectors differ in length.
///
/// # References
/// * R. B. Randall, *Vibration-based Condition Monitoring*, Wiley, 2011, §3.6.
pub fn convert_units(spectrum: &Spectrum, from: Quantity, to: Quantity, kind: SpectrumKind) -> Result<Spectrum, DspError> {
    if spectrum.frequency_hz.len() != spectrum.values.len() {
        return Err(DspError::InvalidParameter {
            name: "spectrum",
            value: format!("{} frequencies, {} values", spectrum.frequency_hz.len(), spectrum.values.len()),
            reason: "frequency_hz and values must have the same length".into(),
        });
    }
    let steps = from.order() - to.order();
    let p = match kind {
        SpectrumKind::Amplitude => 1,
        SpectrumKind::Power => 2,
    };
    let values = spectrum
        .frequency_hz
        .iter()
        .zip(&spectrum.values)
        .map(|(&f, &v)| if f > 0.0 { v * (2.0 * PI * f).powi(-p * steps) } else { 0.0 })
        .collect();
    let quantity = if from == to {
        spectrum.quantity.clone()
    } else {
        let q = spectrum.quantity.trim_start_matches(from.name()).trim_start();
        format!("{} {}", to.name(), q).trim_end().to_string()
    };
    Ok(Spectrum {
        frequency_hz: spectrum.frequency_hz.clone(),
        values,
        quantity,
        unit: convert_unit_string(&spectrum.unit, from, to, kind),
    })
}

/// Unit of a quantity after integration (see [`convert_units`]).
fn convert_unit_string(unit: &str, from: Quantity, to: Quantity, kind: SpectrumKind) -> String {
    if unit.is_empty() || from == to {
        return unit.to_string();
    }
    let families: [[&str; 3]; 3] = [["m", "m/s", "m/s^2"], ["mm", "mm/s", "mm/s^2"], ["m", "m/s", "m/s²"]];
    let lookup = |u: &str| -> Option<String> {
        families.iter().find_map(|fam| {
            (fam[from.order() as usize] == u).then(|| fam[to.order() as usize].to_string())
        })
    };
    let steps = from.order() - to.order();
    match kind {
        SpectrumKind::Amplitude => {
            if let Some(u) = lookup(unit) {
                return u;
            }
            append_seconds(unit, steps)
        }
        SpectrumKind::Power => {
            let (base, suffix) = match unit.strip_suffix("/Hz") {
                Some(b) => (b, "/Hz"),
                None => (unit, ""),
            };
            let inner = base.strip_suffix("^2").map(|b| b.strip_prefix('(').and_then(|b| b.strip_suffix(')')).unwrap_or(b));
            if let Some(new) = inner.and_then(lookup) {
                return format!("{}{}", squared_unit(&new), suffix);
            }
            append_seconds(unit, 2 * steps)
        }
    }
}

fn append_seconds(unit: &str, e: i32) -> String {
    match e {
        0 => unit.to_string(),
        1 => format!("{unit}·s"),
        _ => format!("{unit}·s^{e}"),
    }
}

/// Integrates (or differentiates) a record in the frequency domain.
///
/// # Arguments
/// * `x` — the record in the `from` quantity; at least 2 finite samples.
/// * `fs_hz` — sampling rate in Hz, positive.
/// * `from`, `to` — quantities (acceleration → velocity is one integration).
/// * `highpass_hz` — bins below this frequency are set to 0, `0 ≤ highpass_hz < fs/2`
///   (0 keeps everything but DC). Integration amplifies low-frequency noise by `1/(2πf)`
///   per step; 2–10 Hz is a usual choice for accelerometers.
///
/// # Returns
/// The record in the `to` quantity, same length, e.g. m/s from m/s².
///
/// # Notes
/// `y = irfft(H · rfft(x))` with `H[k] = (j2πf_k)^(−s)`, `s = order(from) − order(to)`,
/// `H = 0` at DC, for `f_k < highpass_hz`, and (when `s ≠ 0`) at the Nyquist bin of an
/// even length, whose phase is undefined. The DFT treats the record as periodic: a record
/// that does not hold whole periods shows wrap-around transients at its ends; taper or
/// band-limit beforehand when that matters. A tone `A cos(2πf t)` of acceleration becomes
/// the velocity `A/(2πf) sin(2πf t)`.
///
/// # Errors
/// `InvalidParameter` for `fs_hz` or `highpass_hz`; `TooShort`; `NonFinite`.
///
/// # References
/// * R. B. Randall, *Vibration-based Condition Monitoring*, Wiley, 2011, §3.6.
pub fn integrate_frequency_domain(x: &[f64], fs_hz: f64, from: Quantity, to: Quantity, highpass_hz: f64) -> Result<Vec<f64>, DspError> {
    check_fs(fs_hz)?;
    if !(highpass_hz.is_finite() && highpass_hz >= 0.0 && highpass_hz < fs_hz / 2.0) {
        return Err(DspError::InvalidParameter {
            name: "highpass_hz",
            value: format!("{highpass_hz}"),
            reason: format!("must satisfy 0 ≤ highpass_hz < Nyquist = {} Hz", fs_hz / 2.0),
        });
    }
    if x.len() < 2 {
        return Err(DspError::TooShort { what: "integrate_frequency_domain", needed: 2, got: x.len() });
    }
    check_finite(x)?;
    let n = x.len();
    let r2c = fft::r2c(n);
    let c2r = fft::c2r(n);
    let mut input = x.to_vec();
    let mut spec = r2c.make_output_vec();
    let fft_err = |e: realfft::FftError| DspError::InvalidParameter { name: "x", value: format!("{n} samples"), reason: format!("FFT failed: {e}") };
    r2c.process(&mut input, &mut spec).map_err(fft_err)?;
    let steps = from.order() - to.order();
    let df = fs_hz / n as f64;
    let scale = 1.0 / n as f64;
    for (k, z) in spec.iter_mut().enumerate() {
        let f = k as f64 * df;
        let nyquist = n.is_multiple_of(2) && k == n / 2;
        if k == 0 || f < highpass_hz || (nyquist && steps != 0) {
            *z = Complex64::new(0.0, 0.0);
        } else {
            let jw = Complex64::new(0.0, 2.0 * PI * f);
            *z *= jw.powi(-steps) * scale;
        }
    }
    let mut out = c2r.make_output_vec();
    c2r.process(&mut spec, &mut out).map_err(fft_err)?;
    Ok(out)
}

/// Amplitude or power decibels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DbKind {
    /// Amplitudes: `20 log10(|v| / reference)`.
    Amplitude,
    /// Powers (unit², unit²/Hz): `10 log10(v / reference)`.
    Power,
}

/// The floor of [`to_db`] in dB relative to the reference: −300 dB.
pub const DB_FLOOR_DB: f64 = -300.0;

/// Converts values to decibels relative to `reference`.
///
/// `20 log10(|v|/ref)` ([`DbKind::Amplitude`]) or `10 log10(v/ref)` ([`DbKind::Power`]).
/// Values whose level is below [`DB_FLOOR_DB`] = −300 dB (including 0) read −300 dB, so no
/// −inf appears. The reference is in the values' unit (e.g. 1 g, 1e-6 m/s, 1 (m/s²)²/Hz);
/// [`Spectrum::to_db`] writes it into the unit string (`"dB re 1 g"`).
///
/// # Errors
/// `InvalidParameter` (`reference`) unless it is finite and > 0; `NonFinite` for NaN/inf
/// values; `InvalidParameter` (`values`) for a negative power.
pub fn to_db(values: &[f64], reference: f64, kind: DbKind) -> Result<Vec<f64>, DspError> {
    if !(reference.is_finite() && reference > 0.0) {
        return Err(DspError::InvalidParameter {
            name: "reference",
            value: format!("{reference}"),
            reason: "the dB reference must be a positive, finite value in the unit of the values (e.g. 1.0)".into(),
        });
    }
    check_finite(values)?;
    let (mult, floor_ratio) = match kind {
        DbKind::Amplitude => (20.0, 10f64.powf(DB_FLOOR_DB / 20.0)),
        DbKind::Power => (10.0, 10f64.powf(DB_FLOOR_DB / 10.0)),
    };
    values
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let r = match kind {
                DbKind::Amplitude => v.abs() / reference,
                DbKind::Power => {
                    if v < 0.0 {
                        return Err(DspError::InvalidParameter {
                            name: "values",
                            value: format!("values[{i}] = {v}"),
                            reason: "a power cannot be negative; use DbKind::Amplitude for signed amplitudes".into(),
                        });
                    }
                    v / reference
                }
            };
            Ok(if r > floor_ratio { mult * r.log10() } else { DB_FLOOR_DB })
        })
        .collect()
}
