//! The error type shared by the DSP functions.

use thiserror::Error;

/// What went wrong in a DSP function. Every variant names the offending parameter and, where
/// there is one, the fix. Bad values are rejected, never silently repaired.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DspError {
    /// A parameter has a value the algorithm cannot use.
    #[error("parameter `{name}` = {value}: {reason}")]
    InvalidParameter { name: &'static str, value: String, reason: String },

    /// The input is too short for the requested analysis.
    #[error("input too short for {what}: needs at least {needed} samples, got {got}")]
    TooShort { what: &'static str, needed: usize, got: usize },

    /// A frequency band lies outside 0..Nyquist or is empty.
    #[error("parameter `{name}`: band {low_hz}–{high_hz} Hz is invalid at fs = {fs_hz} Hz (must satisfy 0 ≤ low < high ≤ Nyquist = {} Hz)", fs_hz / 2.0)]
    BandOutOfRange { name: &'static str, low_hz: f64, high_hz: f64, fs_hz: f64 },

    /// The input holds NaN or ±inf.
    #[error("input holds a non-finite value (NaN or inf) at sample {index}")]
    NonFinite { index: usize },

    /// An FIR design did not meet its specification within the allowed number of taps.
    #[error("equiripple design did not meet the spec with up to {max_taps} taps: achieved passband ripple {ripple_db:.3} dB (asked {ripple_spec_db} dB), stopband attenuation {atten_low_db:.2}/{atten_high_db:.2} dB (asked {atten_low_spec_db}/{atten_high_spec_db} dB); widen the transitions or relax the spec")]
    DesignNotMet {
        max_taps: usize,
        ripple_db: f64,
        ripple_spec_db: f64,
        atten_low_db: f64,
        atten_high_db: f64,
        atten_low_spec_db: f64,
        atten_high_spec_db: f64,
    },

    /// The Remez exchange itself failed (e.g. did not converge).
    #[error("Parks–McClellan design failed with {taps} taps: {reason}")]
    RemezFailed { taps: usize, reason: String },
}

/// Checks that every sample is finite.
pub fn check_finite(x: &[f64]) -> Result<(), DspError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(DspError::NonFinite { index }),
        None => Ok(()),
    }
}

/// Checks that a sampling rate is positive and finite.
pub fn check_fs(fs_hz: f64) -> Result<(), DspError> {
    if fs_hz.is_finite() && fs_hz > 0.0 {
        Ok(())
    } else {
        Err(DspError::InvalidParameter {
            name: "fs_hz",
            value: format!("{fs_hz}"),
            reason: "the sampling rate must be a positive, finite number of Hz".into(),
        })
    }
}

/// Checks a band `[low_hz, high_hz]` against `0 ≤ low < high ≤ fs/2`.
pub fn check_band(name: &'static str, low_hz: f64, high_hz: f64, fs_hz: f64) -> Result<(), DspError> {
    if low_hz.is_finite() && high_hz.is_finite() && low_hz >= 0.0 && low_hz < high_hz && high_hz <= fs_hz / 2.0 {
        Ok(())
    } else {
        Err(DspError::BandOutOfRange { name, low_hz, high_hz, fs_hz })
    }
}
