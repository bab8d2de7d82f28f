//! Cyclic spectral correlation (SCF), spectral coherence, α-slices and the enhanced envelope
//! spectrum of a real signal.
//!
//! Two estimators on the same (α, f) grid:
//! - [`cyclic_periodogram`]: the averaged cyclic periodogram (ACP), the slow direct reference;
//! - [`fast_scf`]: a Fast-SC estimator (STFT computed once, cyclic modulation spectrum of
//!   products of STFT bins, window correction) that agrees with the ACP.
//!
//! [`scf`] dispatches on [`ScfParams::method`]. The result, [`ScfMap`], carries the complex SCF,
//! the magnitude of the spectral coherence, and the slices used in diagnostics (α-slices,
//! frequency slices, enhanced envelope spectrum).
//!
//! # Definition and scaling
//!
//! The signal `x[n]`, `n = 0..N-1`, sampled at `fs`, is cut into `K = ⌊(N − Nw)/R⌋ + 1`
//! segments of `Nw = nperseg` samples with hop `R = nperseg − noverlap` (the trailing partial
//! segment is dropped, as in `scipy.signal.welch`). With the periodic window `w`, the local DTFT
//! of segment `k` is
//!
//! ```text
//! Y_k(ν) = Σ_{l=0}^{Nw-1} w[l] x[kR + l] e^{-j2πνl/fs}
//! ```
//!
//! and the estimated spectral correlation (unit²/Hz) is
//!
//! ```text
//! S_x(α, f) = 1/(K · fs · Σw²) · Σ_k e^{-j2παkR/fs} · Y_k(f + α/2) · Y_k*(f − α/2)
//! ```
//!
//! i.e. `E{X_W(f + α/2) X_W*(f − α/2)} / (fs Σw²)` with the segment DFTs taken on the absolute
//! time axis (the factor `e^{-j2παkR/fs}`). At α = 0 it is exactly the two-sided Welch PSD
//! with "density" scaling (`scipy.signal.welch(..., return_onesided=False, detrend=False)`),
//! so `Σ_f S_x(0, f) Δf = mean(x²)`. The spectral coherence is
//!
//! ```text
//! γ_x(α, f) = S_x(α, f) / sqrt(S_x(0, f + α/2) · S_x(0, f − α/2)),   0 ≤ |γ_x| ≤ 1.
//! ```
//!
//! For a stationary signal, `|γ̂(α ≠ 0, f)|²` is about exponential with mean `1/K_eff` (Welch's
//! effective number of averages, ≈ K/1.9 for Hann at 75 % overlap); at `f = 0` and `f = fs/2`
//! the bins `f ± α/2` are mirror images, the product is `Y(ν)²` and that variance doubles.
//!
//! # Grid
//!
//! - `f_j = j · Δf`, `j = 0..=Nw/2`, `Δf = fs/Nw` (so `nperseg` sets the spectral resolution;
//!   512 at 16384 Hz gives Δf = 32 Hz).
//! - `α_m = m · δα`, `δα = fs/(R·L)`, for every integer `m` with
//!   `alpha_min_hz ≤ α_m ≤ alpha_max_hz`, where `L` is the smallest integer `≥ K` whose only prime
//!   factors are 2, 3 and 5. Since `R·K ≈ N`, `δα ≈ fs/N`: the cyclic resolution is about
//!   one over the record length (e.g. 0.1 Hz for 10 s).
//!
//! # References
//!
//! - J. Antoni, "Cyclic spectral analysis in practice", Mechanical Systems and Signal
//!   Processing 21 (2007) 597–630 (the averaged cyclic periodogram, its scaling and coherence).
//! - J. Antoni, G. Xin, N. Hamzaoui, "Fast computation of the spectral correlation",
//!   Mechanical Systems and Signal Processing 92 (2017) 248–277 (the Fast-SC).
//! - J. Antoni, "Cyclic spectral analysis of rolling-element bearing signals: facts and
//!   fictions", Journal of Sound and Vibration 304 (2007) 497–529 (enhanced envelope spectrum).
//! - N. Sawalhi, L. Deshpande, R. B. Randall, "Improved simulations of faults in gearboxes for
//!   diagnostic and prognostic purposes using a reduced finite element model of a gearbox
//!   casing", 2011 (3D SCF and α-slices to compare model and measurement).

use super::error::{check_band, check_finite, check_fs, DspError};
use super::fft;
use super::window::Window;
use num_complex::Complex64;
use rayon::prelude::*;
use serde::ser::SerializeSeq;
use serde::{Deserialize, Serialize, Serializer};
use std::f64::consts::PI;

/// Oversampling of the STFT frequency axis in [`fast_scf`]: the segment FFTs are zero-padded to
/// `FAST_OVERSAMPLING · nperseg`, so the coarse cyclic shifts are spaced `2Δf/4 = Δf/2` apart and
/// the fine part handled by the frame-axis FFT is at most `Δf/4`.
const FAST_OVERSAMPLING: usize = 4;

/// Largest number of (α, f) cells a map may hold (≈ 0.8 GB with the coherence); larger requests
/// are refused rather than aborting on allocation.
const MAX_CELLS: usize = 1 << 25;

/// Which SCF estimator to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ScfMethod {
    /// Averaged cyclic periodogram ([`cyclic_periodogram`]): direct, slow, the reference.
    CyclicPeriodogram,
    /// Fast-SC ([`fast_scf`]): STFT once + FFT over frames + window correction.
    #[default]
    Fast,
}

/// Parameters of the cyclic spectral correlation.
///
/// `Default` (documented per field): α from 0 to 500 Hz, `nperseg = 512`, 75 % overlap,
/// Hann window, [`ScfMethod::Fast`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScfParams {
    /// Lowest cyclic frequency α in Hz (default 0). Must satisfy `0 ≤ alpha_min_hz`.
    pub alpha_min_hz: f64,
    /// Highest cyclic frequency α in Hz (default 500). Must satisfy
    /// `alpha_min_hz < alpha_max_hz ≤ fs/2`.
    pub alpha_max_hz: f64,
    /// Segment (window) length in samples (default 512); sets the spectral resolution
    /// `Δf = fs/nperseg` (32 Hz at 16384 Hz). Must be ≥ 4 and ≤ the signal length.
    pub nperseg: usize,
    /// Overlap between segments in samples; `None` (default) means `⌊3·nperseg/4⌋` (75 %,
    /// right for Hann). Must be `< nperseg`.
    pub noverlap: Option<usize>,
    /// Window applied to each segment (default Hann, periodic).
    pub window: Window,
    /// Estimator (default [`ScfMethod::Fast`]).
    pub method: ScfMethod,
}

impl Default for ScfParams {
    fn default() -> Self {
        Self {
            alpha_min_hz: 0.0,
            alpha_max_hz: 500.0,
            nperseg: 512,
            noverlap: None,
            window: Window::Hann,
            method: ScfMethod::Fast,
        }
    }
}

impl ScfParams {
    /// Overlap in samples actually used: `noverlap`, or `⌊3·nperseg/4⌋` when `None`.
    pub fn noverlap_samples(&self) -> usize {
        self.noverlap.unwrap_or(3 * self.nperseg / 4)
    }

    /// Checks the parameters against a sampling rate `fs_hz` (Hz) and a signal length `n`
    /// (samples).
    ///
    /// # Errors
    /// - [`DspError::InvalidParameter`] `fs_hz` if not positive and finite;
    /// - [`DspError::TooShort`] if `n == 0`;
    /// - [`DspError::BandOutOfRange`] naming `alpha_min_hz` (negative or non-finite) or
    ///   `alpha_max_hz` (above Nyquist, non-finite, or not above `alpha_min_hz`);
    /// - [`DspError::InvalidParameter`] `nperseg` (< 4 or > n), `noverlap` (≥ nperseg), or
    ///   `alpha_max_hz` when the α range holds no grid point or the map would be too large.
    pub fn validate(&self, fs_hz: f64, n: usize) -> Result<(), DspError> {
        Grid::new(self, fs_hz, n).map(|_| ())
    }
}

/// The (α, f) grid and the segmentation, derived from validated parameters.
#[derive(Debug, Clone, Copy)]
struct Grid {
    nperseg: usize,
    hop: usize,
    n_segments: usize,
    /// Length `L ≥ K` of the frame-axis DFT; `δα = fs/(hop·L)`.
    n_alpha_dft: usize,
    m_lo: usize,
    m_hi: usize,
    n_freq: usize,
    fs_hz: f64,
}

impl Grid {
    fn new(p: &ScfParams, fs_hz: f64, n: usize) -> Result<Self, DspError> {
        check_fs(fs_hz)?;
        if n == 0 {
            return Err(DspError::TooShort {
                what: "spectral correlation (empty signal)",
                needed: p.nperseg.max(4),
                got: 0,
            });
        }
        if !(p.alpha_min_hz.is_finite() && p.alpha_min_hz >= 0.0) {
            return Err(DspError::BandOutOfRange {
                name: "alpha_min_hz",
                low_hz: p.alpha_min_hz,
                high_hz: p.alpha_max_hz,
                fs_hz,
            });
        }
        check_band("alpha_max_hz", p.alpha_min_hz, p.alpha_max_hz, fs_hz)?;
        if p.nperseg < 4 {
            return Err(DspError::InvalidParameter {
                name: "nperseg",
                value: p.nperseg.to_string(),
                reason: "the segment length must be at least 4 samples".into(),
            });
        }
        if p.nperseg > n {
            return Err(DspError::InvalidParameter {
                name: "nperseg",
                value: p.nperseg.to_string(),
                reason: format!(
                    "longer than the signal ({n} samples); use nperseg ≤ {n} or a longer record"
                ),
            });
        }
        let noverlap = p.noverlap_samples();
        if noverlap >= p.nperseg {
            return Err(DspError::InvalidParameter {
                name: "noverlap",
                value: noverlap.to_string(),
                reason: format!("must be smaller than nperseg = {}", p.nperseg),
            });
        }
        let hop = p.nperseg - noverlap;
        let n_segments = (n - p.nperseg) / hop + 1;
        let n_alpha_dft = next_smooth_len(n_segments);
        let d_alpha = fs_hz / (hop as f64 * n_alpha_dft as f64);
        // Grid points inside the closed range, with a relative slack for rounding.
        let m_lo = (p.alpha_min_hz / d_alpha - 1e-9).ceil().max(0.0) as usize;
        let m_hi_f = (p.alpha_max_hz / d_alpha + 1e-9).floor();
        if m_hi_f < m_lo as f64 {
            return Err(DspError::InvalidParameter {
                name: "alpha_max_hz",
                value: format!("{}", p.alpha_max_hz),
                reason: format!(
                    "the α range [{}, {}] Hz holds no point of the α grid (resolution δα = {d_alpha} Hz); widen the range",
                    p.alpha_min_hz, p.alpha_max_hz
                ),
            });
        }
        let m_hi = m_hi_f as usize;
        let n_freq = p.nperseg / 2 + 1;
        let cells = (m_hi - m_lo + 1).saturating_mul(n_freq);
        if cells > MAX_CELLS {
            return Err(DspError::InvalidParameter {
                name: "alpha_max_hz",
                value: format!("{}", p.alpha_max_hz),
                reason: format!(
                    "the map would hold {cells} (α, f) cells (> {MAX_CELLS}); narrow the α range, shorten the record or lower nperseg"
                ),
            });
        }
        Ok(Self {
            nperseg: p.nperseg,
            hop,
            n_segments,
            n_alpha_dft,
            m_lo,
            m_hi,
            n_freq,
            fs_hz,
        })
    }

    fn n_alpha(&self) -> usize {
        self.m_hi - self.m_lo + 1
    }

    /// The segment window and the density scaling `1 / (K · fs · Σw²)` of the averaged
    /// segment products (one-sided Welch convention, both estimators).
    fn window_and_density_scale(&self, params: &ScfParams, fs_hz: f64) -> (Vec<f64>, f64) {
        let w = params.window.periodic(self.nperseg);
        let sum_w2: f64 = w.iter().map(|v| v * v).sum();
        (w, 1.0 / (self.n_segments as f64 * fs_hz * sum_w2))
    }

    fn d_alpha(&self) -> f64 {
        self.fs_hz / (self.hop as f64 * self.n_alpha_dft as f64)
    }

    fn alpha_hz(&self) -> Vec<f64> {
        let d = self.d_alpha();
        (self.m_lo..=self.m_hi).map(|m| m as f64 * d).collect()
    }

    fn frequency_hz(&self) -> Vec<f64> {
        let df = self.fs_hz / self.nperseg as f64;
        (0..self.n_freq).map(|j| j as f64 * df).collect()
    }
}

/// Smallest integer ≥ `n` (and ≥ 1) whose prime factors are all 2, 3 or 5.
fn next_smooth_len(n: usize) -> usize {
    let mut m = n.max(1);
    loop {
        let mut r = m;
        for f in [2, 3, 5] {
            while r.is_multiple_of(f) {
                r /= f;
            }
        }
        if r == 1 {
            return m;
        }
        m += 1;
    }
}

fn serialize_complex<S: Serializer>(v: &[Complex64], s: S) -> Result<S::Ok, S::Error> {
    let mut seq = s.serialize_seq(Some(v.len()))?;
    for c in v {
        seq.serialize_element(&[c.re, c.im])?;
    }
    seq.end()
}

/// A cyclic spectral correlation map on the grid (α_m, f_j), stored row-major `[α][f]`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScfMap {
    /// Cyclic frequencies α in Hz (rows), spaced `alpha_resolution_hz`.
    pub alpha_hz: Vec<f64>,
    /// Spectral frequencies f in Hz (columns), `0..=fs/2` spaced `frequency_resolution_hz`.
    pub frequency_hz: Vec<f64>,
    /// Complex SCF `S_x(α, f)` in unit²/Hz, row-major `[α][f]`; serialised as `[re, im]` pairs.
    #[serde(serialize_with = "serialize_complex")]
    pub scf: Vec<Complex64>,
    /// Magnitude of the spectral coherence `|γ_x(α, f)|` (dimensionless), row-major `[α][f]`;
    /// 0 where the PSD in the denominator vanishes.
    pub coherence: Vec<f64>,
    /// Sampling rate of the analysed signal, Hz.
    pub fs_hz: f64,
    /// Cyclic resolution δα = fs/(R·L) in Hz.
    pub alpha_resolution_hz: f64,
    /// Spectral resolution Δf = fs/nperseg in Hz.
    pub frequency_resolution_hz: f64,
    /// Segment length used.
    pub nperseg: usize,
    /// Overlap used, samples.
    pub noverlap: usize,
    /// Number K of averaged segments.
    pub n_segments: usize,
    /// Estimator that produced the map.
    pub method: ScfMethod,
}

impl ScfMap {
    /// Number of α rows.
    pub fn n_alpha(&self) -> usize {
        self.alpha_hz.len()
    }

    /// Number of frequency columns.
    pub fn n_frequency(&self) -> usize {
        self.frequency_hz.len()
    }

    /// `S_x(α_ia, f_jf)` (unit²/Hz), or `None` outside the grid.
    pub fn get(&self, ia: usize, jf: usize) -> Option<Complex64> {
        (ia < self.n_alpha() && jf < self.n_frequency())
            .then(|| self.scf[ia * self.n_frequency() + jf])
    }

    /// `|γ_x(α_ia, f_jf)|`, or `None` outside the grid.
    pub fn coherence_at(&self, ia: usize, jf: usize) -> Option<f64> {
        (ia < self.n_alpha() && jf < self.n_frequency())
            .then(|| self.coherence[ia * self.n_frequency() + jf])
    }

    /// `|S_x(α, f)|` (unit²/Hz), row-major `[α][f]`.
    pub fn magnitude(&self) -> Vec<f64> {
        self.scf.iter().map(|c| c.norm()).collect()
    }

    /// Index of the α row nearest to `alpha_hz`.
    ///
    /// # Errors
    /// [`DspError::InvalidParameter`] `alpha_hz` if it is not finite or lies more than half a
    /// cyclic resolution outside the computed α range.
    pub fn alpha_index(&self, alpha_hz: f64) -> Result<usize, DspError> {
        nearest_index(
            "alpha_hz",
            &self.alpha_hz,
            self.alpha_resolution_hz,
            alpha_hz,
        )
    }

    /// Index of the frequency column nearest to `frequency_hz`.
    ///
    /// # Errors
    /// [`DspError::InvalidParameter`] `frequency_hz` if not finite or outside `0..=fs/2` by more
    /// than half a bin.
    pub fn frequency_index(&self, frequency_hz: f64) -> Result<usize, DspError> {
        nearest_index(
            "frequency_hz",
            &self.frequency_hz,
            self.frequency_resolution_hz,
            frequency_hz,
        )
    }

    /// α-slice at the grid α nearest to `alpha_hz`: `(frequency_hz, |S_x(α, f)|)` with |S| in
    /// unit²/Hz. At α = 0 this is the two-sided PSD.
    ///
    /// # Errors
    /// As [`ScfMap::alpha_index`].
    pub fn alpha_slice(&self, alpha_hz: f64) -> Result<(Vec<f64>, Vec<f64>), DspError> {
        let ia = self.alpha_index(alpha_hz)?;
        let nf = self.n_frequency();
        let mag = self.scf[ia * nf..(ia + 1) * nf]
            .iter()
            .map(|c| c.norm())
            .collect();
        Ok((self.frequency_hz.clone(), mag))
    }

    /// Coherence α-slice at the grid α nearest to `alpha_hz`: `(frequency_hz, |γ_x(α, f)|)`.
    ///
    /// # Errors
    /// As [`ScfMap::alpha_index`].
    pub fn coherence_slice(&self, alpha_hz: f64) -> Result<(Vec<f64>, Vec<f64>), DspError> {
        let ia = self.alpha_index(alpha_hz)?;
        let nf = self.n_frequency();
        Ok((
            self.frequency_hz.clone(),
            self.coherence[ia * nf..(ia + 1) * nf].to_vec(),
        ))
    }

    /// Frequency slice at the grid frequency nearest to `frequency_hz`:
    /// `(alpha_hz, |S_x(α, f)|)` with |S| in unit²/Hz.
    ///
    /// # Errors
    /// As [`ScfMap::frequency_index`].
    pub fn frequency_slice(&self, frequency_hz: f64) -> Result<(Vec<f64>, Vec<f64>), DspError> {
        let jf = self.frequency_index(frequency_hz)?;
        let nf = self.n_frequency();
        let mag = (0..self.n_alpha())
            .map(|ia| self.scf[ia * nf + jf].norm())
            .collect();
        Ok((self.alpha_hz.clone(), mag))
    }

    /// Enhanced envelope spectrum: `EES(α) = ∫_0^{fs/2} |S_x(α, f)| df` (unit²), by the
    /// trapezoidal rule on the f grid (half weight at 0 Hz and, for even nperseg, at Nyquist).
    ///
    /// Returns `(alpha_hz, EES)`. Peaks mark the cyclic frequencies of the signal (bearing
    /// fault frequencies and their harmonics); at α = 0 it is the one-sided integral of the PSD.
    ///
    /// # References
    /// J. Antoni, JSV 304 (2007) 497–529, "Cyclic spectral analysis of rolling-element bearing
    /// signals: facts and fictions".
    pub fn enhanced_envelope_spectrum(&self) -> (Vec<f64>, Vec<f64>) {
        let w = self.trapezoid_weights();
        let nf = self.n_frequency();
        let ees = self
            .scf
            .chunks(nf)
            .map(|row| row.iter().zip(&w).map(|(c, wj)| c.norm() * wj).sum())
            .collect();
        (self.alpha_hz.clone(), ees)
    }

    /// Coherence-based enhanced envelope spectrum: the mean of `|γ_x(α, f)|` over
    /// `0..=fs/2` (trapezoidal weights), dimensionless in `[0, 1]` (the ACP guarantees
    /// `|γ| ≤ 1`; the Fast-SC may exceed it slightly through its window correction).
    ///
    /// Returns `(alpha_hz, mean |γ|)`. It weighs every frequency band equally, so a weak
    /// cyclostationary band stands out against a loud stationary one.
    pub fn enhanced_envelope_spectrum_coherence(&self) -> (Vec<f64>, Vec<f64>) {
        let w = self.trapezoid_weights();
        let total: f64 = w.iter().sum();
        let nf = self.n_frequency();
        let ees = self
            .coherence
            .chunks(nf)
            .map(|row| row.iter().zip(&w).map(|(g, wj)| g * wj).sum::<f64>() / total)
            .collect();
        (self.alpha_hz.clone(), ees)
    }

    /// Enhanced envelope spectrum restricted to a band: `Σ_{f_j ∈ [low, high]} |S_x(α, f_j)| Δf`
    /// (unit²), e.g. the resonance band a bearing fault excites.
    ///
    /// # Errors
    /// [`DspError::BandOutOfRange`] `band_hz` unless `0 ≤ low_hz < high_hz ≤ fs/2`.
    pub fn enhanced_envelope_spectrum_in_band(
        &self,
        low_hz: f64,
        high_hz: f64,
    ) -> Result<(Vec<f64>, Vec<f64>), DspError> {
        check_band("band_hz", low_hz, high_hz, self.fs_hz)?;
        let nf = self.n_frequency();
        let df = self.frequency_resolution_hz;
        let inside: Vec<usize> = (0..nf)
            .filter(|&j| self.frequency_hz[j] >= low_hz && self.frequency_hz[j] <= high_hz)
            .collect();
        if inside.is_empty() {
            return Err(DspError::BandOutOfRange {
                name: "band_hz",
                low_hz,
                high_hz,
                fs_hz: self.fs_hz,
            });
        }
        let ees = self
            .scf
            .chunks(nf)
            .map(|row| inside.iter().map(|&j| row[j].norm() * df).sum())
            .collect();
        Ok((self.alpha_hz.clone(), ees))
    }

    fn trapezoid_weights(&self) -> Vec<f64> {
        let nf = self.n_frequency();
        let df = self.frequency_resolution_hz;
        let mut w = vec![df; nf];
        if let Some(first) = w.first_mut() {
            *first *= 0.5;
        }
        if self.nperseg.is_multiple_of(2) && nf > 1 {
            w[nf - 1] *= 0.5;
        }
        w
    }
}

fn nearest_index(
    name: &'static str,
    grid: &[f64],
    step: f64,
    value: f64,
) -> Result<usize, DspError> {
    let (first, last) = match (grid.first(), grid.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => {
            return Err(DspError::InvalidParameter {
                name,
                value: format!("{value}"),
                reason: "the map is empty".into(),
            })
        }
    };
    if !value.is_finite() || value < first - 0.5 * step || value > last + 0.5 * step {
        return Err(DspError::InvalidParameter {
            name,
            value: format!("{value}"),
            reason: format!("outside the computed range {first}..{last} Hz; recompute the map with a range that holds it"),
        });
    }
    let i = ((value - first) / step).round().max(0.0) as usize;
    Ok(i.min(grid.len() - 1))
}

/// Cyclic spectral correlation with the estimator chosen by `params.method`.
///
/// See [`cyclic_periodogram`] and [`fast_scf`] for arguments, returns and errors.
pub fn scf(x: &[f64], fs_hz: f64, params: &ScfParams) -> Result<ScfMap, DspError> {
    match params.method {
        ScfMethod::CyclicPeriodogram => cyclic_periodogram(x, fs_hz, params),
        ScfMethod::Fast => fast_scf(x, fs_hz, params),
    }
}

fn validate_input(x: &[f64], fs_hz: f64, params: &ScfParams) -> Result<Grid, DspError> {
    let g = Grid::new(params, fs_hz, x.len())?;
    check_finite(x)?;
    Ok(g)
}

fn internal_fft_error(e: impl std::fmt::Display) -> DspError {
    DspError::InvalidParameter {
        name: "nperseg",
        value: String::new(),
        reason: format!("internal FFT buffer mismatch: {e}"),
    }
}

/// Averaged cyclic periodogram: the direct estimate of the cyclic spectral correlation
/// `S_x(α, f)` and spectral coherence `|γ_x(α, f)|` (the reference estimator).
///
/// # Arguments
/// - `x`: real signal, any unit; finite, at least `nperseg` samples.
/// - `fs_hz`: sampling rate in Hz (> 0).
/// - `params`: [`ScfParams`] — α range `alpha_min_hz..=alpha_max_hz` (default 0–500 Hz),
///   `nperseg` (512), `noverlap` (75 %), `window` (Hann); `method` is ignored here.
///
/// # Returns
/// An [`ScfMap`] with `S_x` in unit²/Hz on the grid described in the module docs
/// (`α_m = m·fs/(R·L)`, `f_j = j·fs/nperseg`) and `|γ_x|`.
///
/// # Errors
/// Those of [`ScfParams::validate`], and [`DspError::NonFinite`] if `x` holds NaN or ±inf.
///
/// # Notes
/// For each α on the grid, the signal is frequency-shifted, `x₊(n) = x(n) e^{-jπαn/fs}` and
/// `x₋(n) = x(n) e^{+jπαn/fs}`, cut into segments (absolute time kept), windowed and
/// DFT'd, and the cross-periodograms are averaged:
///
/// ```text
/// S_x(α, f_j) = 1/(K fs Σw²) Σ_k X₊,k[j] · X₋,k[j]*
/// |γ_x(α, f_j)| = |Σ_k X₊,k[j] X₋,k[j]*| / sqrt(Σ_k |X₊,k[j]|² · Σ_k |X₋,k[j]|²)
/// ```
///
/// (`X₊,k[j] = e^{-jπαkR/fs} Y_k(f_j + α/2)`, `X₋,k[j] = e^{+jπαkR/fs} Y_k(f_j − α/2)`; the
/// coherence denominators are the Welch PSDs at `f ± α/2` from the same segments, so
/// `|γ| ≤ 1` by Cauchy–Schwarz). For real `x`, `x₋ = conj(x₊)`, so `X₋,k[j] = X₊,k[−j]*` and one
/// complex FFT per segment and α serves both. The phase `αkR/fs = mk/L` is reduced with
/// integers to keep full precision for long records.
///
/// Cost `O(N_α · K · Nw log Nw)`, parallel over α (rayon). Use it as the reference; for
/// routine work [`fast_scf`] is much faster.
///
/// # References
/// J. Antoni, "Cyclic spectral analysis in practice", MSSP 21 (2007) 597–630, §4 (averaged
/// cyclic periodogram); P. D. Welch, IEEE Trans. Audio Electroacoust. 15 (1967) 70–73.
pub fn cyclic_periodogram(x: &[f64], fs_hz: f64, params: &ScfParams) -> Result<ScfMap, DspError> {
    let g = validate_input(x, fs_hz, params)?;
    let nw = g.nperseg;
    let nf = g.n_freq;
    let hop = g.hop;
    let l_dft = g.n_alpha_dft;
    let (w, norm) = g.window_and_density_scale(params, fs_hz);
    let plan = fft::forward(nw);
    let scratch_len = plan.get_inplace_scratch_len();
    let n_alpha = g.n_alpha();
    let mut scf = vec![Complex64::new(0.0, 0.0); n_alpha * nf];
    let mut coherence = vec![0.0; n_alpha * nf];
    let zero = Complex64::new(0.0, 0.0);
    // π α l / fs = π m l / (R L): reduce m·l modulo 2RL (one full turn).
    let turn_local = (2 * hop * l_dft) as u64;
    let half_turn = (hop * l_dft) as f64;

    scf.par_chunks_mut(nf)
        .zip(coherence.par_chunks_mut(nf))
        .enumerate()
        .for_each_init(
            || {
                (
                    vec![zero; nw],
                    vec![zero; nw],
                    vec![zero; scratch_len],
                    vec![0.0; nf],
                    vec![0.0; nf],
                )
            },
            |(table, buf, scratch, d_plus, d_minus), (ia, (s_row, c_row))| {
                let m = (g.m_lo + ia) as u64;
                for (l, t) in table.iter_mut().enumerate() {
                    let r = (m * l as u64) % turn_local;
                    *t = Complex64::from_polar(w[l], -PI * r as f64 / half_turn);
                }
                s_row.fill(zero);
                d_plus.fill(0.0);
                d_minus.fill(0.0);
                for k in 0..g.n_segments {
                    let seg = &x[k * hop..k * hop + nw];
                    for ((b, t), &v) in buf.iter_mut().zip(table.iter()).zip(seg) {
                        *b = t * v;
                    }
                    plan.process_with_scratch(buf, scratch);
                    // e^{-j2παkR/fs} = e^{-j2π m k / L}
                    let r = (m * k as u64) % l_dft as u64;
                    let ph = Complex64::from_polar(1.0, -2.0 * PI * r as f64 / l_dft as f64);
                    for j in 0..nf {
                        let a = buf[j];
                        let b = buf[(nw - j) % nw];
                        s_row[j] += ph * a * b;
                        d_plus[j] += a.norm_sqr();
                        d_minus[j] += b.norm_sqr();
                    }
                }
                for j in 0..nf {
                    let den = (d_plus[j] * d_minus[j]).sqrt();
                    c_row[j] = if den > 0.0 {
                        s_row[j].norm() / den
                    } else {
                        0.0
                    };
                    s_row[j] *= norm;
                }
            },
        );

    Ok(ScfMap {
        alpha_hz: g.alpha_hz(),
        frequency_hz: g.frequency_hz(),
        scf,
        coherence,
        fs_hz,
        alpha_resolution_hz: g.d_alpha(),
        frequency_resolution_hz: fs_hz / nw as f64,
        nperseg: nw,
        noverlap: nw - hop,
        n_segments: g.n_segments,
        method: ScfMethod::CyclicPeriodogram,
    })
}

/// Fast spectral correlation (Fast-SC): the cyclic spectral correlation `S_x(α, f)` and
/// spectral coherence `|γ_x(α, f)|` on the same grid as [`cyclic_periodogram`], at a small
/// fraction of its cost.
///
/// # Arguments
/// - `x`: real signal, any unit; finite, at least `nperseg` samples.
/// - `fs_hz`: sampling rate in Hz (> 0).
/// - `params`: [`ScfParams`] — α range `alpha_min_hz..=alpha_max_hz` (default 0–500 Hz),
///   `nperseg` (512), `noverlap` (75 %), `window` (Hann); `method` is ignored here.
///
/// # Returns
/// An [`ScfMap`] (unit²/Hz, grid as in the module docs) and `|γ_x|`.
///
/// # Errors
/// Those of [`ScfParams::validate`], and [`DspError::NonFinite`] if `x` holds NaN or ±inf.
///
/// # Notes
/// 1. STFT once: each windowed segment is zero-padded to `Z·Nw` (`Z = 4`) and FFT'd, giving
///    `Y_k(i·fs/(Z·Nw))` exactly (local time origin).
/// 2. Every α_m is split into a coarse shift `α_p = p·2fs/(Z·Nw)` (nearest) and a residue
///    `δ = α_m − α_p`, `|δ| ≤ fs/(Z·Nw) = Δf/4`. For each `p` and `f_j`, the products of STFT
///    bins `c_k = Y_k(f_j + α_p/2) · Y_k*(f_j − α_p/2)` (both exact bins of the padded FFT) are
///    zero-padded to `L` and DFT'd over the frame index: bin `m mod L` is
///    `Σ_k c_k e^{-j2πα_m kR/fs}` — the cyclic modulation spectrum at α_m.
/// 3. Correction: for a (locally) white carrier, `E{c_k}` carries the factor
///    `W(δ) = Σ_l w[l]² e^{+j2πδl/fs} / Σ_l w[l]²` instead of 1, so
///
/// ```text
/// S_x(α_m, f_j) = 1/(K fs Σw² W(δ)) Σ_k c_k e^{-j2πα_m kR/fs}
/// |γ_x(α_m, f_j)| = |S_x(α_m, f_j)| / sqrt(P(f_j + α_p/2) · P(f_j − α_p/2))
/// ```
///
/// with `P` the two-sided Welch PSD on the padded grid. At α_m = α_p (δ = 0) the result equals
/// the ACP exactly; in between it is the same statistic evaluated `δ/2` off in frequency, so the
/// two estimators agree closely where |S| is significant and have the same expectation for
/// white-carrier cyclostationary signals. `|γ|` can exceed 1 slightly through `1/|W(δ)|`.
///
/// Cost `O(K·Z·Nw log(Z·Nw) + N_p·(Nw/2)·L log L)` with `N_p ≈ (α_max − α_min)·Z·Nw/(2fs)`
/// coarse shifts; parallel (rayon) over shifts and frequencies.
///
/// # References
/// J. Antoni, G. Xin, N. Hamzaoui, "Fast computation of the spectral correlation", MSSP 92
/// (2017) 248–277 (Fast-SC and its window correction); J. Antoni, MSSP 21 (2007) 597–630.
pub fn fast_scf(x: &[f64], fs_hz: f64, params: &ScfParams) -> Result<ScfMap, DspError> {
    let g = validate_input(x, fs_hz, params)?;
    let nw = g.nperseg;
    let nf = g.n_freq;
    let hop = g.hop;
    let k_seg = g.n_segments;
    let l_dft = g.n_alpha_dft;
    let z = FAST_OVERSAMPLING;
    let nz = z * nw;
    let nh = nz / 2 + 1;
    let (w, norm) = g.window_and_density_scale(params, fs_hz);
    let zero = Complex64::new(0.0, 0.0);

    // 1. STFT, row-major [k][i], then transposed to [i][k] for contiguous frame sequences.
    let r2c = fft::r2c(nz);
    let mut stft = vec![zero; k_seg * nh];
    stft.par_chunks_mut(nh).enumerate().try_for_each_init(
        || (r2c.make_input_vec(), r2c.make_scratch_vec()),
        |(input, scratch), (k, row)| {
            let seg = &x[k * hop..k * hop + nw];
            for ((d, &s), &wl) in input.iter_mut().zip(seg).zip(&w) {
                *d = s * wl;
            }
            input[nw..].fill(0.0);
            r2c.process_with_scratch(input, row, scratch)
                .map_err(internal_fft_error)
        },
    )?;
    let mut yt = vec![zero; nh * k_seg];
    yt.par_chunks_mut(k_seg).enumerate().for_each(|(i, col)| {
        for (k, c) in col.iter_mut().enumerate() {
            *c = stft[k * nh + i];
        }
    });
    drop(stft);
    let psd: Vec<f64> = yt
        .par_chunks(k_seg)
        .map(|col| norm * col.iter().map(|c| c.norm_sqr()).sum::<f64>())
        .collect();
    // Bin i of the padded grid (any integer) → stored index and whether to conjugate.
    let fold = |i: i64| -> (usize, bool) {
        let r = i.rem_euclid(nz as i64) as usize;
        if r <= nz / 2 {
            (r, false)
        } else {
            (nz - r, true)
        }
    };

    // 2. Coarse shift, residue and window correction of every α_m; blocks of rows per shift.
    let d_alpha = g.d_alpha();
    let coarse_hz = 2.0 * fs_hz / nz as f64;
    let w2: Vec<f64> = w.iter().map(|v| v * v).collect();
    let sum_w2: f64 = w2.iter().sum();
    let n_alpha = g.n_alpha();
    let mut shift = Vec::with_capacity(n_alpha);
    let mut inv_corr = Vec::with_capacity(n_alpha);
    for m in g.m_lo..=g.m_hi {
        // α_m / α_coarse = m·Z·Nw / (2·R·L), rounded exactly with integers.
        let num = m as u128 * nz as u128;
        let den = 2 * hop as u128 * l_dft as u128;
        let p = ((2 * num + den) / (2 * den)) as i64;
        let delta_hz = m as f64 * d_alpha - p as f64 * coarse_hz;
        let corr: Complex64 = w2
            .iter()
            .enumerate()
            .map(|(l, &v)| Complex64::from_polar(v, 2.0 * PI * delta_hz * l as f64 / fs_hz))
            .sum::<Complex64>()
            / sum_w2;
        shift.push(p);
        inv_corr.push(norm / corr);
    }
    let mut scf = vec![zero; n_alpha * nf];
    let mut coherence = vec![0.0; n_alpha * nf];
    let mut blocks: Vec<(i64, usize, &mut [Complex64], &mut [f64])> = Vec::new();
    {
        let mut s_rest: &mut [Complex64] = &mut scf;
        let mut c_rest: &mut [f64] = &mut coherence;
        let mut start = 0;
        while start < n_alpha {
            let p = shift[start];
            let end = start + shift[start..].iter().take_while(|&&q| q == p).count();
            let (s_head, s_tail) = std::mem::take(&mut s_rest).split_at_mut((end - start) * nf);
            let (c_head, c_tail) = std::mem::take(&mut c_rest).split_at_mut((end - start) * nf);
            blocks.push((p, start, s_head, c_head));
            s_rest = s_tail;
            c_rest = c_tail;
            start = end;
        }
    }

    // 3. Cyclic modulation spectrum per (shift, frequency), corrected.
    let plan = fft::forward(l_dft);
    let scratch_len = plan.get_inplace_scratch_len();
    blocks
        .into_par_iter()
        .for_each(|(p, start, s_block, c_block)| {
            let rows = s_block.len() / nf;
            let columns: Vec<Vec<(Complex64, f64)>> = (0..nf)
                .into_par_iter()
                .map_init(
                    || (vec![zero; l_dft], vec![zero; scratch_len]),
                    |(buf, scratch), j| {
                        let (ip, conj_p) = fold((j * z) as i64 + p);
                        let (im, conj_m) = fold((j * z) as i64 - p);
                        let a = &yt[ip * k_seg..(ip + 1) * k_seg];
                        let b = &yt[im * k_seg..(im + 1) * k_seg];
                        for ((d, &ya), &yb) in buf.iter_mut().zip(a).zip(b) {
                            let ya = if conj_p { ya.conj() } else { ya };
                            let yb = if conj_m { yb } else { yb.conj() };
                            *d = ya * yb;
                        }
                        buf[k_seg..].fill(zero);
                        plan.process_with_scratch(buf, scratch);
                        let den = (psd[ip] * psd[im]).sqrt();
                        (0..rows)
                            .map(|r| {
                                let ia = start + r;
                                let m = g.m_lo + ia;
                                let v = buf[m % l_dft] * inv_corr[ia];
                                (v, if den > 0.0 { v.norm() / den } else { 0.0 })
                            })
                            .collect()
                    },
                )
                .collect();
            for (j, col) in columns.iter().enumerate() {
                for (r, &(v, c)) in col.iter().enumerate() {
                    s_block[r * nf + j] = v;
                    c_block[r * nf + j] = c;
                }
            }
        });

    Ok(ScfMap {
        alpha_hz: g.alpha_hz(),
        frequency_hz: g.frequency_hz(),
        scf,
        coherence,
        fs_hz,
        alpha_resolution_hz: d_alpha,
        frequency_resolution_hz: fs_hz / nw as f64,
        nperseg: nw,
        noverlap: nw - hop,
        n_segments: k_seg,
        method: ScfMethod::Fast,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_lengths() {
        assert_eq!(next_smooth_len(0), 1);
        assert_eq!(next_smooth_len(7), 8);
        assert_eq!(next_smooth_len(83), 90);
        assert_eq!(next_smooth_len(1277), 1280);
        assert_eq!(next_smooth_len(125), 125);
    }

    #[test]
    fn default_params_round_trip_through_toml() {
        let p = ScfParams::default();
        let s = toml::to_string(&p).unwrap();
        let q: ScfParams = toml::from_str(&s).unwrap();
        assert_eq!(p, q);
        let r: ScfParams =
            toml::from_str("method = \"cyclic_periodogram\"\nnperseg = 256").unwrap();
        assert_eq!(r.method, ScfMethod::CyclicPeriodogram);
        assert_eq!(r.noverlap_samples(), 192);
        assert!(toml::from_str::<ScfParams>("npersegg = 3").is_err());
    }
}
