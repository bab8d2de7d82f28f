//! Synthetic test signals with deterministic seeds: tones, amplitude modulation, white noise,
//! and bearing-like impulse trains exciting a resonance. Used by tests, demos and benchmarks.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

/// A seeded random generator (ChaCha8): the same seed gives the same numbers on every machine.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// `n` samples of zero-mean Gaussian white noise with standard deviation `std`.
pub fn white_noise(n: usize, std: f64, seed: u64) -> Vec<f64> {
    let mut r = rng(seed);
    (0..n).map(|_| { let z: f64 = StandardNormal.sample(&mut r); std * z }).collect()
}

/// `amplitude · cos(2π f t + phase)` sampled at `fs_hz`.
pub fn tone(n: usize, fs_hz: f64, frequency_hz: f64, amplitude: f64, phase_rad: f64) -> Vec<f64> {
    (0..n).map(|i| amplitude * (2.0 * PI * frequency_hz * i as f64 / fs_hz + phase_rad).cos()).collect()
}

/// Parameters of a bearing-like signal: impacts at a fault rate, each ringing a resonance.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactTrain {
    /// Impact rate (fault frequency), Hz.
    pub fault_frequency_hz: f64,
    /// Resonance excited by each impact, Hz.
    pub resonance_hz: f64,
    /// Damping ratio of the resonance.
    pub damping_ratio: f64,
    /// Random jitter of the impact times, as a fraction of the period (slip), standard deviation.
    pub jitter_fraction: f64,
    /// Amplitude modulation depth at `modulation_hz` (0 = none), e.g. a load zone at shaft speed.
    pub modulation_depth: f64,
    /// Modulation frequency, Hz.
    pub modulation_hz: f64,
    /// Peak amplitude of one impact response.
    pub amplitude: f64,
}

/// A bearing-like signal: impacts at `fault_frequency_hz` with jitter, each a decaying
/// sinusoid at the resonance, optionally amplitude-modulated (load zone).
pub fn impact_train(n: usize, fs_hz: f64, p: &ImpactTrain, seed: u64) -> Vec<f64> {
    let mut r = rng(seed);
    let mut x = vec![0.0; n];
    let period = 1.0 / p.fault_frequency_hz;
    let wn = 2.0 * PI * p.resonance_hz;
    let decay = p.damping_ratio * wn;
    // Ring-down until the envelope falls below 1e-4.
    let ring = ((9.2 / decay.max(1e-9)) * fs_hz).ceil() as usize;
    let mut k = 0usize;
    loop {
        let jitter: f64 = StandardNormal.sample(&mut r);
        let t0 = (k as f64 + 0.5) * period + p.jitter_fraction * period * jitter;
        if t0 >= n as f64 / fs_hz {
            break;
        }
        let gain = p.amplitude * (1.0 + p.modulation_depth * (2.0 * PI * p.modulation_hz * t0).cos());
        let i0 = (t0 * fs_hz).ceil().max(0.0) as usize;
        for (i, xi) in x.iter_mut().enumerate().take((i0 + ring).min(n)).skip(i0) {
            let t = i as f64 / fs_hz - t0;
            *xi += gain * (-decay * t).exp() * (wn * t).sin();
        }
        k += 1;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_deterministic_and_has_the_asked_std() {
        let a = white_noise(100_000, 2.0, 7);
        let b = white_noise(100_000, 2.0, 7);
        assert_eq!(a, b);
        let var = a.iter().map(|v| v * v).sum::<f64>() / a.len() as f64;
        assert!((var.sqrt() - 2.0).abs() < 0.02, "{}", var.sqrt());
        assert_ne!(a, white_noise(100_000, 2.0, 8));
    }

    #[test]
    fn impact_train_has_one_impact_per_period() {
        let fs = 16384.0;
        let p = ImpactTrain { fault_frequency_hz: 100.0, resonance_hz: 3000.0, damping_ratio: 0.05, jitter_fraction: 0.0, modulation_depth: 0.0, modulation_hz: 0.0, amplitude: 1.0 };
        let x = impact_train(16384, fs, &p, 1);
        // Count threshold up-crossings of |x| separated by at least half a period.
        let mut count = 0;
        let mut last = -1_000_000i64;
        for (i, v) in x.iter().enumerate() {
            if v.abs() > 0.5 && (i as i64 - last) > 80 {
                count += 1;
                last = i as i64;
            }
        }
        assert_eq!(count, 100);
    }
}
