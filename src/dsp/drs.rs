//! Discrete/random separation (DRS): splits a record into its deterministic (discrete-frequency:
//! gear mesh, shaft harmonics) part and its random part (noise, and bearing signals, which are
//! cyclostationary but not periodic because of slip), by a Wiener filter that predicts the
//! record from its own past a delay Δ earlier.

use super::error::{check_finite, DspError};
use super::fft;
use super::window::Window;
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Parameters of [`drs`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DrsParams {
    /// Segment (FFT) length `N` in samples, even, ≥ 4. Sets the frequency resolution `fs/N` of the
    /// transfer function, which must be well finer than the spacing of the discrete lines
    /// (a Hann window spreads a line over ±2 bins). Default 4096 (4 Hz at 16384 Hz).
    pub window_len: usize,
    /// Delay `Δ` in samples between the record and the copy it is predicted from. Must exceed
    /// `N/2` plus the correlation length of the random part, and stay short enough for the
    /// discrete part to remain coherent over `Δ + N/2` (speed fluctuation). Δ ≥ N/2 is enforced.
    /// Default 2048 (= N/2 for the default N; 0.125 s at 16384 Hz).
    pub delay_samples: usize,
    /// Hop between successive segments in samples, 1 ≤ hop ≤ N. Default 1024 (N/4).
    pub hop: usize,
    /// Data window applied to every segment (periodic). Default Hann.
    pub window: Window,
}

impl Default for DrsParams {
    /// `window_len = 4096`, `delay_samples = 2048`, `hop = 1024`, `window = Hann`.
    fn default() -> Self {
        Self { window_len: 4096, delay_samples: 2048, hop: 1024, window: Window::Hann }
    }
}

impl DrsParams {
    /// Checks the parameters against a record of `n` samples: `window_len` even and ≥ 4;
    /// `delay_samples ≥ window_len / 2`; `hop` in `1..=window_len`; and
    /// `delay_samples + window_len ≤ n` (at least one segment pair).
    pub fn validate(&self, n: usize) -> Result<(), DspError> {
        let nw = self.window_len;
        if nw < 4 || !nw.is_multiple_of(2) {
            return Err(DspError::InvalidParameter {
                name: "window_len",
                value: format!("{nw}"),
                reason: "the segment length must be even and at least 4 (a power of two such as 4096 is fastest)"
                    .into(),
            });
        }
        if self.delay_samples < nw / 2 {
            return Err(DspError::InvalidParameter {
                name: "delay_samples",
                value: format!("{}", self.delay_samples),
                reason: format!(
                    "the delay must be at least window_len/2 = {}: the filter reaches ±window_len/2 around the delay, and a shorter delay lets it use the present samples, so the random part leaks into the deterministic estimate; raise delay_samples or lower window_len",
                    nw / 2
                ),
            });
        }
        if self.hop == 0 || self.hop > nw {
            return Err(DspError::InvalidParameter {
                name: "hop",
                value: format!("{}", self.hop),
                reason: format!("the hop must lie in 1..=window_len ({nw}); window_len/4 is the usual choice"),
            });
        }
        let needed = self.delay_samples + nw;
        if needed > n {
            return Err(DspError::InvalidParameter {
                name: "window_len",
                value: format!("{nw}"),
                reason: format!(
                    "window_len + delay_samples = {needed} samples exceeds the record ({n} samples); use a longer record or shorter window_len/delay_samples"
                ),
            });
        }
        Ok(())
    }
}

/// The result of [`drs`].
#[derive(Debug, Clone, PartialEq)]
pub struct DrsResult {
    /// Deterministic (discrete-frequency) part, same length and unit as the input.
    pub deterministic: Vec<f64>,
    /// Random part `x − deterministic`, same length and unit as the input.
    pub residual: Vec<f64>,
    /// Frequencies of the transfer function bins, `m · fs / N`, Hz, `m = 0..=N/2`.
    pub frequency_hz: Vec<f64>,
    /// Magnitude of the filter applied to `x(t − Δ)`, `|G[m]|` with `G = DFT_N{c · h}` (the
    /// lag-windowed transfer function, dimensionless): ≈ 1 on discrete lines, ≈ 0 where the
    /// record is random.
    pub transfer_magnitude: Vec<f64>,
    /// Number of segment pairs averaged.
    pub segments: usize,
}

/// Discrete/random separation (DRS) in the frequency domain.
///
/// Estimates the transfer function from the delayed record `x(t − Δ)` to the record `x(t)` by
/// Welch averaging, turns it into a zero-phase FIR around the delay and filters the delayed
/// record with it: the output is the part of `x` predictable from its own past (the discrete,
/// periodic part); the residual is the random part.
///
/// Parameters
/// ----------
/// * `x` — the record (any unit), finite, at least `delay_samples + window_len` samples.
/// * `fs_hz` — sampling rate in Hz (only labels the frequency axis).
/// * `params` — [`DrsParams`]: `window_len` N (4096), `delay_samples` Δ (2048), `hop` R (1024),
///   `window` (Hann).
///
/// Returns
/// -------
/// [`DrsResult`]: deterministic part and residual (unit of `x`, length of `x`), and the
/// magnitude of the applied filter `|G(f)|` on `N/2 + 1` bins (Hz, dimensionless).
///
/// Notes
/// -----
/// With `w` the periodic window of length `N`, segments start at `b_k = Δ + kR`,
/// `k = 0..K−1`, `K = ⌊(n − Δ − N)/R⌋ + 1`:
///
/// 1. `U_k = DFT_N{w · x[b_k .. b_k+N]}`, `V_k = DFT_N{w · x[b_k−Δ .. b_k−Δ+N]}` (bins `m = 0..=N/2`);
/// 2. `H[m] = Σ_k conj(V_k[m]) U_k[m] / Σ_k |V_k[m]|²` (0 where the denominator is 0) —
///    the Welch estimate of `S_{x_Δ x}/S_{x_Δ x_Δ}`. A line at `f` gives `H = e^{i2πfΔ/fs}`
///    (`|H| = 1`); random content uncorrelated over Δ gives `H ≈ 0`;
/// 3. `h = IDFT_N{H}` (real, `numpy.fft.irfft(H, N)`), read as a non-causal response on lags
///    `l = −N/2 .. N/2−1` (`h[l mod N]`) and tapered by the lag window
///    `c[l] = ½ + ½ cos(2πl/N)`: `g[l] = c[l] · h[l mod N]`; the reported transfer magnitude is
///    `|G[m]|`, `G = DFT_N{g}` (g in circular order), i.e. `H` smoothed by `[−¼, ½, −¼]`;
/// 4. `d[t] = Σ_{l=−N/2}^{N/2−1} g[l] · x[t − Δ − l]` (x = 0 outside the record), computed by
///    FFT overlap-add; residual `r = x − d`.
///
/// Why Δ ≥ N/2: for white noise the segments `U_k` and `V_k` share `N − Δ` samples, so the
/// estimate of step 2 contains a spurious term of size `Σ_j w_j w_{j+Δ} / Σ_j w_j²` at lag −Δ
/// of `h` — the "prediction" of x(t) from x(t) itself. The lag window is zero at `l = −N/2`, so
/// with Δ = N/2 that term is removed exactly; for N/2 < Δ < N it wraps to lag `N − Δ` but its
/// size (the overlap of two Hann windows shifted by more than N/2) is then small, and for Δ ≥ N
/// the segments do not overlap at all. Filtering then only uses `x(t − Δ − l)` with
/// `Δ + l ≥ 0`: a prediction from the past. The lag window also smooths `H` over ±1 bin, which
/// leaves the lines (where `H` is constant over the ±2 bins of the Hann main lobe) untouched.
///
/// Edges: the first `Δ + N/2` and the last `N/2` samples of `deterministic` are computed with
/// part of the filter over the zero extension, so they are biased towards zero (the residual
/// keeps some periodic content there).
///
/// Cost: `2K` real FFTs of length N (in parallel) and an overlap-add convolution with blocks of
/// FFT length `4·2^⌈log₂N⌉`: O(n log N).
///
/// References
/// ----------
/// J. Antoni, R.B. Randall, "Unsupervised noise cancellation for vibration signals: part II —
/// a novel frequency-domain algorithm", Mechanical Systems and Signal Processing 18 (2004)
/// 103–117. R.B. Randall, *Vibration-based Condition Monitoring*, Wiley 2011, §3.6.
/// Used to remove the gear signals before the SCF in Sawalhi, Deshpande & Randall (HUMS 2011).
pub fn drs(x: &[f64], fs_hz: f64, params: &DrsParams) -> Result<DrsResult, DspError> {
    super::error::check_fs(fs_hz)?;
    if x.is_empty() {
        return Err(DspError::TooShort { what: "drs", needed: params.delay_samples + params.window_len, got: 0 });
    }
    params.validate(x.len())?;
    check_finite(x)?;
    let n = x.len();
    let nw = params.window_len;
    let delay = params.delay_samples;
    let hop = params.hop;
    let w = params.window.periodic(nw);
    let segments = (n - delay - nw) / hop + 1;
    let bins = nw / 2 + 1;

    // Step 2: cross and auto spectra, summed in fixed chunks (deterministic result).
    const CHUNK: usize = 16;
    let partials: Vec<(Vec<Complex64>, Vec<f64>)> = (0..segments.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut svu = vec![Complex64::new(0.0, 0.0); bins];
            let mut svv = vec![0.0; bins];
            let plan = fft::r2c(nw);
            let mut buf = plan.make_input_vec();
            let mut u = plan.make_output_vec();
            let mut v = plan.make_output_vec();
            let mut scratch = plan.make_scratch_vec();
            for k in c * CHUNK..((c + 1) * CHUNK).min(segments) {
                let b = delay + k * hop;
                for ((o, &xi), &wi) in buf.iter_mut().zip(&x[b..b + nw]).zip(&w) {
                    *o = xi * wi;
                }
                // Buffer lengths come from the plan itself, so processing cannot fail.
                let _ = plan.process_with_scratch(&mut buf, &mut u, &mut scratch);
                for ((o, &xi), &wi) in buf.iter_mut().zip(&x[b - delay..b - delay + nw]).zip(&w) {
                    *o = xi * wi;
                }
                let _ = plan.process_with_scratch(&mut buf, &mut v, &mut scratch);
                for m in 0..bins {
                    svu[m] += v[m].conj() * u[m];
                    svv[m] += v[m].norm_sqr();
                }
            }
            (svu, svv)
        })
        .collect();
    let mut svu = vec![Complex64::new(0.0, 0.0); bins];
    let mut svv = vec![0.0; bins];
    for (pu, pv) in &partials {
        for m in 0..bins {
            svu[m] += pu[m];
            svv[m] += pv[m];
        }
    }
    let h_f: Vec<Complex64> =
        svu.iter().zip(&svv).map(|(&a, &b)| if b > 0.0 { a / b } else { Complex64::new(0.0, 0.0) }).collect();

    // Step 3: centred, lag-windowed impulse response; g_arr[j] = g[j − N/2].
    let h_t = fft::irfft(&h_f, nw);
    let half = nw / 2;
    let g_arr: Vec<f64> = (0..nw)
        .map(|j| {
            let l = j as isize - half as isize;
            let lag_win = 0.5 + 0.5 * (2.0 * std::f64::consts::PI * l as f64 / nw as f64).cos();
            h_t[l.rem_euclid(nw as isize) as usize] * lag_win
        })
        .collect();

    // Step 4: y = x * g_arr (linear), d[t] = y[t − (Δ − N/2)].
    let shift = delay - half;
    let needed = n - shift; // y[0 .. n − shift) is all that is used
    let y = convolve_prefix(x, &g_arr, needed);
    let mut deterministic = vec![0.0; n];
    deterministic[shift..].copy_from_slice(&y);
    let residual: Vec<f64> = x.iter().zip(&deterministic).map(|(a, b)| a - b).collect();

    let frequency_hz = (0..bins).map(|m| m as f64 * fs_hz / nw as f64).collect();
    // The filter actually applied: DFT of the lag-windowed response in circular order.
    let mut g_circ = vec![0.0; nw];
    for (j, &v) in g_arr.iter().enumerate() {
        g_circ[(j + nw - half) % nw] = v;
    }
    let transfer_magnitude = fft::rfft(&g_circ).iter().map(|c| c.norm()).collect();
    Ok(DrsResult { deterministic, residual, frequency_hz, transfer_magnitude, segments })
}

/// First `len` samples of the linear convolution `x * g`, by FFT overlap-add (blocks in
/// parallel, summed in order).
fn convolve_prefix(x: &[f64], g: &[f64], len: usize) -> Vec<f64> {
    let ng = g.len();
    let f = 4 * fft::next_pow2(ng);
    let block = f - ng + 1;
    let mut gp = vec![0.0; f];
    gp[..ng].copy_from_slice(g);
    let g_spec = fft::rfft(&gp);
    let used = x.len().min(len);
    let blocks = used.div_ceil(block);
    let pieces: Vec<Vec<f64>> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let start = b * block;
            let end = (start + block).min(used);
            let mut xb = vec![0.0; f];
            xb[..end - start].copy_from_slice(&x[start..end]);
            let mut spec = fft::rfft(&xb);
            for (s, gs) in spec.iter_mut().zip(&g_spec) {
                *s *= gs;
            }
            fft::irfft(&spec, f)
        })
        .collect();
    let mut y = vec![0.0; len];
    for (b, piece) in pieces.iter().enumerate() {
        let start = b * block;
        for (yo, &p) in y[start.min(len)..].iter_mut().zip(piece.iter()) {
            *yo += p;
        }
    }
    y
}
