//! Spectral kurtosis and the kurtogram: which frequency band of a signal is the most
//! impulsive, the band to demodulate before an envelope analysis.
//!
//! Over the frames `k` of a short-time Fourier transform `X(k, f)`, the spectral kurtosis is
//! `SK(f) = ⟨|X(k, f)|⁴⟩ / ⟨|X(k, f)|²⟩² − 2` (Antoni, "The spectral kurtosis: a useful tool for
//! characterising non-stationary signals", MSSP 20 (2006) 282–307, the STFT estimator): 0 for
//! stationary Gaussian noise, −1 for a steady tone, large where transients dominate, such as a
//! fault's impacts ringing a resonance. The kurtogram maps it over the frame length (the
//! frequency resolution) and frequency, and its maximum names the band to demodulate (Antoni &
//! Randall, "The spectral kurtosis: application to the vibratory surveillance and diagnostics of
//! rotating machines", MSSP 20 (2006) 308–331; the 15-DOF bearing paper cites it, Antoni 2007,
//! among the field's demodulation methods).

use super::error::{check_finite, check_fs, DspError};
use super::fft;
use super::spectrum::Spectrum;
use super::window::Window;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Parameters of [`spectral_kurtosis`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpectralKurtosisParams {
    /// Window of each frame (periodic). Default: `hann`.
    pub window: Window,
    /// Frame length in samples, ≥ 4. Default: 256.
    pub nperseg: usize,
    /// Samples shared by consecutive frames, `< nperseg`. Default: `None` = `3 · nperseg / 4`.
    pub noverlap: Option<usize>,
}

impl Default for SpectralKurtosisParams {
    fn default() -> Self {
        Self { window: Window::Hann, nperseg: 256, noverlap: None }
    }
}

impl SpectralKurtosisParams {
    /// The overlap used (`noverlap` or `3 · nperseg / 4`).
    pub fn overlap(&self) -> usize {
        self.noverlap.unwrap_or(3 * self.nperseg / 4)
    }

    /// Checks the parameters on their own; the input's length is checked by [`spectral_kurtosis`].
    pub fn validate(&self) -> Result<(), DspError> {
        if self.nperseg < 4 {
            return Err(DspError::InvalidParameter { name: "nperseg", value: self.nperseg.to_string(), reason: "a frame needs at least 4 samples (one bin between DC and Nyquist); use e.g. 256".into() });
        }
        if self.overlap() >= self.nperseg {
            return Err(DspError::InvalidParameter { name: "noverlap", value: self.overlap().to_string(), reason: format!("must be less than nperseg = {}", self.nperseg) });
        }
        Ok(())
    }

    /// Frames of a signal of `n` samples: those that fit whole, starting every `nperseg −
    /// noverlap` samples from the first.
    pub fn frames(&self, n: usize) -> usize {
        if n < self.nperseg {
            0
        } else {
            (n - self.nperseg) / (self.nperseg - self.overlap()) + 1
        }
    }
}

/// The spectral kurtosis of `x` (Antoni 2006's STFT estimator, see the module): over the frames
/// that fit whole (no padding, no detrending), `⟨|X|⁴⟩ / ⟨|X|²⟩² − 2` per bin. Equals
/// `S4 / S2² − 2` of `scipy.signal.stft(x, fs, window, nperseg, noverlap, boundary=None,
/// padded=False)` (`S2`, `S4` the means over frames of `|Z|²`, `|Z|⁴`; tested to 1e-9).
///
/// Returns the one-sided [`Spectrum`] of `nperseg / 2 + 1` bins at `k · fs / nperseg` Hz,
/// dimensionless. For a real signal the DC and Nyquist bins are real, so stationary Gaussian
/// noise gives 1 there rather than 0. A bin with no energy in any frame gives 0.
///
/// # Errors
/// `InvalidParameter` for `fs_hz`, `nperseg` or `noverlap`; `NonFinite`; `TooShort` when fewer
/// than two frames fit.
pub fn spectral_kurtosis(x: &[f64], fs_hz: f64, p: &SpectralKurtosisParams) -> Result<Spectrum, DspError> {
    check_fs(fs_hz)?;
    p.validate()?;
    check_finite(x)?;
    let frames = p.frames(x.len());
    if frames < 2 {
        return Err(DspError::TooShort { what: "spectral kurtosis (two frames)", needed: p.nperseg + (p.nperseg - p.overlap()), got: x.len() });
    }
    let n = p.nperseg;
    let step = n - p.overlap();
    let win = p.window.periodic(n);
    let bins = n / 2 + 1;
    // Sums of |X|² and |X|⁴ per bin, over chunks of frames in parallel.
    let (s2, s4) = (0..frames)
        .into_par_iter()
        .fold(
            || {
                let plan = fft::r2c(n);
                let spec = plan.make_output_vec();
                (vec![0.0; bins], vec![0.0; bins], plan, vec![0.0; n], spec)
            },
            |(mut s2, mut s4, plan, mut buf, mut spec), k| {
                let seg = &x[k * step..k * step + n];
                for ((b, v), w) in buf.iter_mut().zip(seg).zip(&win) {
                    *b = v * w;
                }
                // The plan's lengths match the buffers by construction.
                plan.process(&mut buf, &mut spec).expect("FFT lengths match");
                for ((a2, a4), c) in s2.iter_mut().zip(s4.iter_mut()).zip(&spec) {
                    let m2 = c.norm_sqr();
                    *a2 += m2;
                    *a4 += m2 * m2;
                }
                (s2, s4, plan, buf, spec)
            },
        )
        .map(|(s2, s4, ..)| (s2, s4))
        .reduce(
            || (vec![0.0; bins], vec![0.0; bins]),
            |(mut a2, mut a4), (b2, b4)| {
                a2.iter_mut().zip(&b2).for_each(|(a, b)| *a += b);
                a4.iter_mut().zip(&b4).for_each(|(a, b)| *a += b);
                (a2, a4)
            },
        );
    let kf = frames as f64;
    let values = s2.iter().zip(&s4).map(|(&a2, &a4)| if a2 > 0.0 { (a4 / kf) / (a2 / kf).powi(2) - 2.0 } else { 0.0 }).collect();
    let frequency_hz = (0..bins).map(|k| k as f64 * fs_hz / n as f64).collect();
    Ok(Spectrum { frequency_hz, values, quantity: "spectral kurtosis".into(), unit: String::new() })
}

/// Parameters of [`kurtogram`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KurtogramParams {
    /// Shortest frame in samples (the coarsest resolution, the widest bands), ≥ 4. Default: 16.
    pub min_nperseg: usize,
    /// Longest frame in samples (the finest resolution). Default: 1024.
    pub max_nperseg: usize,
    /// The narrowest band to choose, Hz. A band must pass a fault's sidebands: an envelope
    /// spectrum up to `f` needs a band at least `2 f` wide. Default: 0 (any).
    pub min_band_width_hz: f64,
    /// Where the chosen band must lie, Hz (e.g. above the shaft harmonics and below a
    /// recorder's anti-alias filter). Default: `None` (0 to Nyquist).
    pub search_band_hz: Option<[f64; 2]>,
    /// Levels with fewer frames than this are left out (the estimate's scatter grows as the
    /// frames get fewer: about `2 / √frames` for Gaussian noise). Default: 32.
    pub min_frames: usize,
}

impl Default for KurtogramParams {
    fn default() -> Self {
        Self { min_nperseg: 16, max_nperseg: 1024, min_band_width_hz: 0.0, search_band_hz: None, min_frames: 32 }
    }
}

/// One frame length of a [`Kurtogram`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KurtogramLevel {
    /// Frame length in samples.
    pub nperseg: usize,
    /// Width of a bin's band, Hz: `2 · fs / nperseg` (a Hann window's main lobe at −6 dB).
    pub band_width_hz: f64,
    /// Frames the estimate averaged.
    pub frames: usize,
    /// The spectral kurtosis at this resolution.
    pub sk: Spectrum,
}

/// A band a kurtogram chose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KurtogramBand {
    /// Low and high edges, Hz: the bin's centre ± `fs / nperseg`.
    pub band_hz: [f64; 2],
    /// The bin's centre frequency, Hz.
    pub centre_hz: f64,
    /// Its spectral kurtosis.
    pub sk: f64,
    /// The frame length of its level.
    pub nperseg: usize,
}

/// A kurtogram: the spectral kurtosis at frame lengths half an octave apart, and its largest
/// value over the bands allowed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Kurtogram {
    /// The levels, shortest frame (widest band) first.
    pub levels: Vec<KurtogramLevel>,
    /// The band of the largest spectral kurtosis among the allowed ones.
    pub best: KurtogramBand,
}

impl Kurtogram {
    /// The allowed bands ([`KurtogramParams`]) of every level, largest spectral kurtosis first.
    pub fn ranked_bands(&self, fs_hz: f64, p: &KurtogramParams) -> Vec<KurtogramBand> {
        rank_level_bands(&self.levels, fs_hz, p)
    }

    /// The largest spectral kurtosis of any allowed band overlapping `band_hz` (None when no
    /// allowed band does).
    pub fn sk_within(&self, band_hz: [f64; 2], fs_hz: f64, p: &KurtogramParams) -> Option<f64> {
        self.levels.iter().flat_map(|l| level_bands(l, fs_hz, p)).filter(|b| b.band_hz[0] < band_hz[1] && b.band_hz[1] > band_hz[0]).map(|b| b.sk).reduce(f64::max)
    }
}

/// The allowed bands of `levels`, largest spectral kurtosis first.
fn rank_level_bands(levels: &[KurtogramLevel], fs_hz: f64, p: &KurtogramParams) -> Vec<KurtogramBand> {
    let mut v: Vec<KurtogramBand> = levels.iter().flat_map(|l| level_bands(l, fs_hz, p)).collect();
    v.sort_by(|a, b| b.sk.total_cmp(&a.sk));
    v
}

/// The bands of level `l` that `p` allows: bins between DC and Nyquist, at least
/// `min_band_width_hz` wide, inside `search_band_hz`.
fn level_bands<'a>(l: &'a KurtogramLevel, fs_hz: f64, p: &'a KurtogramParams) -> impl Iterator<Item = KurtogramBand> + 'a {
    let half = fs_hz / l.nperseg as f64;
    let [lo, hi] = p.search_band_hz.unwrap_or([0.0, fs_hz / 2.0]);
    let bins = l.sk.len();
    (1..bins.saturating_sub(1)).filter_map(move |k| {
        let c = l.sk.frequency_hz[k];
        let band_hz = [c - half, c + half];
        (2.0 * half >= p.min_band_width_hz && band_hz[0] >= lo && band_hz[1] <= hi).then_some(KurtogramBand { band_hz, centre_hz: c, sk: l.sk.values[k], nperseg: l.nperseg })
    })
}

/// Frame lengths half an octave apart from `min` to `max` (even, each once).
pub fn kurtogram_frame_lengths(min: usize, max: usize) -> Vec<usize> {
    let mut v: Vec<usize> = Vec::new();
    for j in 0.. {
        let n = (min as f64 * 2f64.powf(j as f64 / 2.0) / 2.0).round() as usize * 2;
        if n > max {
            break;
        }
        if v.last() != Some(&n) {
            v.push(n);
        }
    }
    v
}

/// The kurtogram of `x` (Antoni & Randall 2006, see the module): [`spectral_kurtosis`] with a
/// Hann window and 75 % overlap at frame lengths half an octave apart
/// ([`kurtogram_frame_lengths`]), levels with fewer than `min_frames` frames left out, and the
/// band of the largest value among those `p` allows. A bin `k` of a level with frames of `n`
/// samples stands for the band `(k ± 1) · fs / n`, the −6 dB width of the Hann window's main
/// lobe.
///
/// # Errors
/// `InvalidParameter` for `fs_hz`, `min_nperseg` (< 4, or above `max_nperseg`),
/// `min_band_width_hz` (negative or not finite), `search_band_hz` (not inside 0–Nyquist), or
/// when no allowed band is left (the message says which limit to relax); `TooShort` when no
/// level has `min_frames` frames; `NonFinite`.
pub fn kurtogram(x: &[f64], fs_hz: f64, p: &KurtogramParams) -> Result<Kurtogram, DspError> {
    check_fs(fs_hz)?;
    check_finite(x)?;
    if p.min_nperseg < 4 || p.min_nperseg > p.max_nperseg {
        return Err(DspError::InvalidParameter { name: "min_nperseg", value: p.min_nperseg.to_string(), reason: format!("must be at least 4 and at most max_nperseg = {}", p.max_nperseg) });
    }
    if !(p.min_band_width_hz.is_finite() && p.min_band_width_hz >= 0.0) {
        return Err(DspError::InvalidParameter { name: "min_band_width_hz", value: p.min_band_width_hz.to_string(), reason: "must be a finite width ≥ 0 Hz".into() });
    }
    if let Some([lo, hi]) = p.search_band_hz {
        if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi && hi <= fs_hz / 2.0) {
            return Err(DspError::BandOutOfRange { name: "search_band_hz", low_hz: lo, high_hz: hi, fs_hz });
        }
    }
    let lengths: Vec<usize> = kurtogram_frame_lengths(p.min_nperseg, p.max_nperseg).into_iter().filter(|&n| SpectralKurtosisParams { nperseg: n, ..Default::default() }.frames(x.len()) >= p.min_frames.max(2)).collect();
    if lengths.is_empty() {
        let n = p.min_nperseg;
        return Err(DspError::TooShort { what: "a kurtogram level (min_frames frames of min_nperseg samples)", needed: n + (p.min_frames.max(2) - 1) * (n - 3 * n / 4), got: x.len() });
    }
    let levels: Vec<KurtogramLevel> = lengths
        .par_iter()
        .map(|&n| {
            let sp = SpectralKurtosisParams { window: Window::Hann, nperseg: n, noverlap: None };
            spectral_kurtosis(x, fs_hz, &sp).map(|sk| KurtogramLevel { nperseg: n, band_width_hz: 2.0 * fs_hz / n as f64, frames: sp.frames(x.len()), sk })
        })
        .collect::<Result<_, _>>()?;
    let best = rank_level_bands(&levels, fs_hz, p).into_iter().next().ok_or_else(|| DspError::InvalidParameter {
        name: "min_band_width_hz",
        value: p.min_band_width_hz.to_string(),
        reason: format!(
            "no band of the kurtogram (widest {:.1} Hz, from frames of {} samples) is that wide and inside {:?} Hz: lower min_band_width_hz or min_nperseg, or widen search_band_hz",
            2.0 * fs_hz / levels[0].nperseg as f64,
            levels[0].nperseg,
            p.search_band_hz.unwrap_or([0.0, fs_hz / 2.0])
        ),
    })?;
    Ok(Kurtogram { levels, best })
}
