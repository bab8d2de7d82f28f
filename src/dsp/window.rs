//! Window functions (periodic/"DFT-even" as scipy.signal.get_window with `fftbins=True`,
//! or symmetric for filter design).

use super::error::DspError;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Window shapes. The names are scipy.signal's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Window {
    /// Rectangular (no window).
    Boxcar,
    /// Hann (raised cosine).
    #[default]
    Hann,
    /// Hamming.
    Hamming,
    /// Blackman (3-term, a0 = 0.42).
    Blackman,
    /// Flat top (5-term, scipy's coefficients): accurate amplitudes of tones.
    Flattop,
}

impl Window {
    /// Periodic window of length `n` (scipy `get_window(name, n, fftbins=True)`),
    /// the right one for spectral analysis.
    pub fn periodic(self, n: usize) -> Vec<f64> {
        self.build(n, true)
    }

    /// Periodic window of length `n` with its coherent gain `Σw`, the amplitude-spectrum
    /// normaliser. A window that sums to zero (length 1 of a window that is zero at its ends)
    /// is refused rather than dividing by zero.
    pub fn periodic_with_gain(self, n: usize) -> Result<(Vec<f64>, f64), DspError> {
        let win = self.periodic(n);
        let gain: f64 = win.iter().sum();
        if gain > 0.0 {
            Ok((win, gain))
        } else {
            Err(DspError::InvalidParameter {
                name: "window",
                value: format!("{self:?}"),
                reason: format!("the window sums to {gain} at length {n}; use a longer record or the boxcar window"),
            })
        }
    }

    /// Symmetric window of length `n` (scipy `get_window(name, n, fftbins=False)`).
    pub fn symmetric(self, n: usize) -> Vec<f64> {
        self.build(n, false)
    }

    fn build(self, n: usize, periodic: bool) -> Vec<f64> {
        if n == 0 {
            return Vec::new();
        }
        if n == 1 {
            return vec![1.0];
        }
        let denom = if periodic { n as f64 } else { (n - 1) as f64 };
        let cosine_sum = |a: &[f64]| -> Vec<f64> {
            (0..n)
                .map(|i| {
                    let x = 2.0 * PI * i as f64 / denom;
                    a.iter().enumerate().map(|(k, &ak)| if k % 2 == 0 { ak } else { -ak } * (k as f64 * x).cos()).sum()
                })
                .collect()
        };
        match self {
            Window::Boxcar => vec![1.0; n],
            Window::Hann => cosine_sum(&[0.5, 0.5]),
            Window::Hamming => cosine_sum(&[0.54, 0.46]),
            Window::Blackman => cosine_sum(&[0.42, 0.5, 0.08]),
            Window::Flattop => cosine_sum(&[0.21557895, 0.41663158, 0.277263158, 0.083578947, 0.006947368]),
        }
    }

    /// Parses scipy's names (`hann`, `hanning`, `boxcar`, `rectangular`, `hamming`,
    /// `blackman`, `flattop`).
    pub fn parse(name: &str) -> Result<Self, DspError> {
        match name.to_ascii_lowercase().as_str() {
            "boxcar" | "rectangular" | "rect" | "none" => Ok(Window::Boxcar),
            "hann" | "hanning" => Ok(Window::Hann),
            "hamming" => Ok(Window::Hamming),
            "blackman" => Ok(Window::Blackman),
            "flattop" => Ok(Window::Flattop),
            _ => Err(DspError::InvalidParameter {
                name: "window",
                value: name.to_string(),
                reason: "unknown window; use boxcar, hann, hamming, blackman or flattop".into(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hann_matches_closed_form() {
        let w = Window::Hann.periodic(8);
        // scipy.signal.get_window('hann', 8)
        let want = [0.0, 0.14644660940672624, 0.5, 0.8535533905932737, 1.0, 0.8535533905932737, 0.5, 0.14644660940672624];
        for (a, b) in w.iter().zip(want) {
            assert!((a - b).abs() < 1e-15);
        }
        let s = Window::Hann.symmetric(5);
        let want = [0.0, 0.5, 1.0, 0.5, 0.0];
        for (a, b) in s.iter().zip(want) {
            assert!((a - b).abs() < 1e-15);
        }
    }

    #[test]
    fn flattop_peak_is_one_and_blackman_ends_at_zero() {
        let f = Window::Flattop.symmetric(101);
        assert!((f[50] - 1.0).abs() < 1e-6, "{}", f[50]);
        let b = Window::Blackman.symmetric(11);
        assert!(b[0].abs() < 1e-12 && (b[5] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn unknown_window_is_refused() {
        assert!(Window::parse("kaiserx").is_err());
        assert_eq!(Window::parse("Hanning").unwrap(), Window::Hann);
    }
}
