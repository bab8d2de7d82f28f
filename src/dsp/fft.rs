//! Shared FFT plans.
//!
//! Plans are built once per length and shared through `Arc`, as RustFFT's and realfft's
//! planners intend; every DSP function takes its plans from here.

use num_complex::Complex64;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use std::sync::{Arc, Mutex, OnceLock};

struct Planners {
    real: RealFftPlanner<f64>,
    complex: FftPlanner<f64>,
}

fn planners() -> &'static Mutex<Planners> {
    static P: OnceLock<Mutex<Planners>> = OnceLock::new();
    P.get_or_init(|| Mutex::new(Planners { real: RealFftPlanner::new(), complex: FftPlanner::new() }))
}

fn lock() -> std::sync::MutexGuard<'static, Planners> {
    // A panic while holding the lock cannot leave a planner half-built in a way that matters
    // (plans are immutable once made), so a poisoned lock is safe to reuse.
    planners().lock().unwrap_or_else(|e| e.into_inner())
}

/// Forward real-to-complex plan of length `n` (output has `n/2 + 1` bins).
pub fn r2c(n: usize) -> Arc<dyn RealToComplex<f64>> {
    lock().real.plan_fft_forward(n)
}

/// Inverse complex-to-real plan of length `n` (unnormalised: divide by `n`).
pub fn c2r(n: usize) -> Arc<dyn ComplexToReal<f64>> {
    lock().real.plan_fft_inverse(n)
}

/// Forward complex plan of length `n`.
pub fn forward(n: usize) -> Arc<dyn Fft<f64>> {
    lock().complex.plan_fft_forward(n)
}

/// Inverse complex plan of length `n` (unnormalised: divide by `n`).
pub fn inverse(n: usize) -> Arc<dyn Fft<f64>> {
    lock().complex.plan_fft_inverse(n)
}

/// One-sided spectrum of a real sequence: `X[k]`, `k = 0..=n/2`, unnormalised.
pub fn rfft(x: &[f64]) -> Vec<Complex64> {
    let n = x.len();
    let plan = r2c(n);
    let mut input = x.to_vec();
    let mut out = plan.make_output_vec();
    // Lengths match the plan by construction, so this cannot fail.
    plan.process(&mut input, &mut out).expect("rfft: buffer lengths match the plan");
    out
}

/// Zero-phase filtering of a real record by a real gain per frequency: every bin `k` of the
/// record's one real FFT is scaled by `gain(k · fs / n)` and transformed back (the record is
/// treated as periodic). The caller checks its inputs.
pub fn zero_phase_filter(x: &[f64], fs_hz: f64, gain: impl Fn(f64) -> f64) -> Vec<f64> {
    let n = x.len();
    let mut spec = rfft(x);
    let df = fs_hz / n as f64;
    for (k, c) in spec.iter_mut().enumerate() {
        *c *= gain(k as f64 * df);
    }
    irfft(&spec, n)
}

/// Inverse of [`rfft`] for a length-`n` real sequence, normalised by `1/n`.
///
/// The imaginary parts of the DC and (for even `n`) Nyquist bins are ignored.
pub fn irfft(spec: &[Complex64], n: usize) -> Vec<f64> {
    let plan = c2r(n);
    let mut input = spec.to_vec();
    input[0].im = 0.0;
    if n.is_multiple_of(2) {
        if let Some(last) = input.last_mut() {
            last.im = 0.0;
        }
    }
    let mut out = plan.make_output_vec();
    plan.process(&mut input, &mut out).expect("irfft: buffer lengths match the plan");
    let scale = 1.0 / n as f64;
    out.iter_mut().for_each(|v| *v *= scale);
    out
}

/// Smallest power of two ≥ `n` (and ≥ 1).
pub fn next_pow2(n: usize) -> usize {
    n.max(1).next_power_of_two()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct DFT, the naive reference.
    fn dft(x: &[f64]) -> Vec<Complex64> {
        let n = x.len();
        (0..=n / 2)
            .map(|k| {
                x.iter().enumerate().fold(Complex64::new(0.0, 0.0), |acc, (t, &v)| {
                    let ph = -2.0 * std::f64::consts::PI * (k * t) as f64 / n as f64;
                    acc + Complex64::from_polar(v, ph)
                })
            })
            .collect()
    }

    #[test]
    fn rfft_matches_direct_dft_and_round_trips() {
        for n in [1usize, 2, 7, 16, 45, 128] {
            let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
            let a = rfft(&x);
            let b = dft(&x);
            for (p, q) in a.iter().zip(&b) {
                assert!((p - q).norm() < 1e-9 * n as f64, "n={n}");
            }
            let y = irfft(&a, n);
            for (p, q) in x.iter().zip(&y) {
                assert!((p - q).abs() < 1e-12 * n as f64);
            }
        }
    }
}
