//! Zero-phase Fourier low-pass with a specified transition band: the magnitude response of a
//! data recorder's digital anti-alias (decimation) filter, which is flat to a passband edge
//! and falls steeply to a stopband floor just below Nyquist (a linear-phase FIR, whose delay
//! does not matter to spectra, envelopes or cyclic spectra).

use super::error::{check_finite, check_fs, DspError};
use super::fft;

/// Gain (linear amplitude) at `f_hz`: 1 up to `passband_hz`, then falling in dB along a
/// half-cosine to `-stopband_db` at `stopband_hz`, and `-stopband_db` above:
/// `G(f) = 10^(-A·(1 − cos(π u))/40)`, `u = (f − f_p)/(f_s − f_p)` clamped to [0, 1].
pub fn lowpass_gain(f_hz: f64, passband_hz: f64, stopband_hz: f64, stopband_db: f64) -> f64 {
    let u = ((f_hz - passband_hz) / (stopband_hz - passband_hz)).clamp(0.0, 1.0);
    let db = stopband_db * (1.0 - (std::f64::consts::PI * u).cos()) / 2.0;
    10f64.powf(-db / 20.0)
}

/// Filters `x` (sampled at `fs_hz`) through [`lowpass_gain`] by one real FFT of the whole
/// record (the record is treated as periodic, as in [`super::resample::resample`]). Zero phase.
///
/// Errors: `0 < passband_hz < stopband_hz`, `stopband_db > 0` finite, `x` finite, ≥ 2 samples.
pub fn fourier_lowpass(x: &[f64], fs_hz: f64, passband_hz: f64, stopband_hz: f64, stopband_db: f64) -> Result<Vec<f64>, DspError> {
    check_fs(fs_hz)?;
    check_finite(x)?;
    if !(passband_hz.is_finite() && passband_hz > 0.0) {
        return Err(DspError::InvalidParameter { name: "passband_hz", value: passband_hz.to_string(), reason: "must be positive".into() });
    }
    if !(stopband_hz.is_finite() && stopband_hz > passband_hz) {
        return Err(DspError::InvalidParameter { name: "stopband_hz", value: stopband_hz.to_string(), reason: format!("must exceed the passband edge {passband_hz} Hz") });
    }
    if !(stopband_db.is_finite() && stopband_db > 0.0) {
        return Err(DspError::InvalidParameter { name: "stopband_db", value: stopband_db.to_string(), reason: "must be a positive attenuation in dB".into() });
    }
    let n = x.len();
    if n < 2 {
        return Err(DspError::TooShort { what: "low-pass filtering", needed: 2, got: n });
    }
    Ok(fft::zero_phase_filter(x, fs_hz, |f| lowpass_gain(f, passband_hz, stopband_hz, stopband_db)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    fn tone(f_hz: f64, fs_hz: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| (TAU * f_hz * i as f64 / fs_hz).sin()).collect()
    }

    use crate::dsp::rms;

    #[test]
    fn tones_in_pass_transition_and_stop_band_get_the_specified_gain() {
        // Integer cycles in the record, so each tone is one FFT bin and the gain is exact.
        let (fs, n) = (12000.0, 12000);
        for (f, want_db) in [(1000.0, 0.0), (5500.0, 0.0), (5700.0, -30.0), (5800.0, -51.2132), (5900.0, -60.0), (5990.0, -60.0)] {
            let y = fourier_lowpass(&tone(f, fs, n), fs, 5500.0, 5900.0, 60.0).unwrap();
            let got_db = 20.0 * (rms(&y) / rms(&tone(f, fs, n))).log10();
            assert!((got_db - want_db).abs() < 1e-3, "{f} Hz: {got_db:.4} dB, want {want_db} dB");
        }
    }

    #[test]
    fn zero_phase_keeps_the_waveform_in_the_passband() {
        let (fs, n) = (12000.0, 6000);
        let x: Vec<f64> = tone(150.0, fs, n).iter().zip(tone(2600.0, fs, n)).map(|(a, b)| a + 0.3 * b).collect();
        let y = fourier_lowpass(&x, fs, 5000.0, 5800.0, 80.0).unwrap();
        let err = x.iter().zip(&y).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1e-12, "max deviation {err}");
    }

    #[test]
    fn bad_parameters_are_refused_with_their_name() {
        let x = tone(100.0, 1000.0, 100);
        for (p, s, a, name) in [(0.0, 400.0, 60.0, "passband_hz"), (300.0, 300.0, 60.0, "stopband_hz"), (300.0, 400.0, -1.0, "stopband_db"), (f64::NAN, 400.0, 60.0, "passband_hz")] {
            let e = fourier_lowpass(&x, 1000.0, p, s, a).unwrap_err().to_string();
            assert!(e.contains(name), "{e}");
        }
        assert!(fourier_lowpass(&[1.0], 1000.0, 100.0, 200.0, 60.0).is_err());
    }
}
