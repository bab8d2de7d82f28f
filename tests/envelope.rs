//! Analytic signal against scipy.signal.hilbert; envelope and envelope spectra of AM
//! signals (analytic cases); bad input.

mod common;
use num_complex::Complex64;
use std::f64::consts::PI;
use twinscope::dsp::envelope::*;
use twinscope::dsp::{DspError, Window};

const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/spectral/");

fn read_rows(name: &str) -> Vec<Vec<f64>> {
    common::read_fixture_rows(&format!("{FIX}{name}"))
}

/// scipy.signal.hilbert of x[:512] and x[:511]: |error| ≤ 1e-10 elementwise.
#[test]
fn matches_scipy_hilbert_odd_and_even() {
    let x: Vec<f64> = read_rows("x.csv").into_iter().map(|r| r[0]).collect();
    for n in [512usize, 511] {
        let want = read_rows(&format!("hilbert_{n}.csv"));
        let got = analytic_signal(&x[..n]).unwrap();
        assert_eq!(got.len(), n);
        let mut worst: f64 = 0.0;
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            let err = (g - Complex64::new(w[0], w[1])).norm();
            worst = worst.max(err);
            assert!(err <= 1e-10, "n={n} i={i}: {g} vs {w:?}");
        }
        eprintln!("hilbert n={n}: worst abs error {worst:.2e}");
    }
}

/// Analytic case: the analytic signal of cos(ωt+φ) (bin-centred) is e^{j(ωt+φ)}, for odd
/// and even lengths, to 1e-12; tiny lengths do not panic.
#[test]
fn analytic_signal_of_a_cosine_is_a_phasor() {
    for n in [64usize, 63, 1000, 999] {
        let w = 2.0 * PI * 5.0 / n as f64;
        let x: Vec<f64> = (0..n).map(|i| (w * i as f64 + 0.3).cos()).collect();
        let z = analytic_signal(&x).unwrap();
        for (i, zi) in z.iter().enumerate() {
            let want = Complex64::from_polar(1.0, w * i as f64 + 0.3);
            assert!((zi - want).norm() < 1e-12, "n={n} i={i}");
        }
    }
    assert_eq!(analytic_signal(&[2.0]).unwrap(), vec![Complex64::new(2.0, 0.0)]);
    assert_eq!(analytic_signal(&[1.0, -1.0]).unwrap(), vec![Complex64::new(1.0, 0.0), Complex64::new(-1.0, 0.0)]);
}

fn am(m: f64, fm: f64, fc: f64, fs: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            (1.0 + m * (2.0 * PI * fm * t).cos()) * (2.0 * PI * fc * t).cos()
        })
        .collect()
}

/// Physics: the envelope of (1 + m cos 2πf_m t) cos 2πf_c t is 1 + m cos 2πf_m t, within
/// 1e-3 away from the ends (frequencies not bin-centred, so the ends do show transients:
/// the first and last 10 % are excluded).
#[test]
fn envelope_of_am_signal() {
    let (fs, n, m, fm, fc) = (10_000.0, 10_000, 0.6, 23.3, 1_003.7);
    let x = am(m, fm, fc, fs, n);
    let e = envelope(&x).unwrap();
    let mut worst: f64 = 0.0;
    for (i, &ei) in e.iter().enumerate().take(n - n / 10).skip(n / 10) {
        let want = 1.0 + m * (2.0 * PI * fm * i as f64 / fs).cos();
        worst = worst.max((ei - want).abs());
    }
    assert!(worst <= 1e-3, "worst {worst}");
    let sq = squared_envelope(&x).unwrap();
    for i in (0..n).step_by(97) {
        assert!((sq[i] - e[i] * e[i]).abs() < 1e-12);
    }
}

/// Scaling rule: the envelope spectrum of a bin-centred AM signal reads m at f_m (within
/// 1 %; in fact ~1e-12), for Hann and boxcar; the squared-envelope spectrum reads 2m at
/// f_m and m²/2 at 2f_m. The band keeps the real frequency axis.
#[test]
fn envelope_spectrum_scaling_rule() {
    let (fs, n) = (10_000.0, 10_000); // 1 Hz bins
    for &(m, fm, fc) in &[(0.5, 37.0, 1_000.0), (1.0, 120.0, 2_500.0), (0.2, 7.0, 3_000.0)] {
        let x = am(m, fm, fc, fs, n);
        for window in [Window::Hann, Window::Boxcar] {
            let p = EnvelopeParams { window, band_hz: Some([0.0, 500.0]), ..Default::default() };
            let s = envelope_spectrum(&x, fs, &p).unwrap();
            assert_eq!(s.frequency_hz.len(), 501);
            assert_eq!(s.frequency_hz[fm as usize], fm);
            let v = s.values[fm as usize];
            assert!((v - m).abs() <= 0.01 * m, "{window:?} m={m}: {v}");
            assert!((v - m).abs() <= 1e-9, "{window:?} m={m}: {v}");
            let (pf, pv) = s.peak().unwrap();
            assert!((pf - fm).abs() < 1e-9 && (pv - v).abs() < 1e-15);

            let q = squared_envelope_spectrum(&x, fs, &p).unwrap();
            assert_eq!(q.quantity, "squared envelope spectrum (peak)");
            assert!((q.values[fm as usize] - 2.0 * m).abs() <= 1e-9, "{}", q.values[fm as usize]);
            assert!((q.values[2 * fm as usize] - m * m / 2.0).abs() <= 1e-9);
        }
        // A band that starts above 0 keeps real frequencies.
        let s = envelope_spectrum(&x, fs, &EnvelopeParams { band_hz: Some([fm - 2.0, fm + 10.5]), ..Default::default() }).unwrap();
        assert_eq!(s.frequency_hz.first(), Some(&(fm - 2.0)));
        assert_eq!(s.frequency_hz.last(), Some(&(fm + 10.0)));
        assert!((s.values[2] - m).abs() < 1e-9);
    }
}

/// Without mean removal the Hann-windowed DC leaks into bin 1 (documented); with it, ~0.
#[test]
fn remove_mean_matters() {
    let x = am(0.5, 37.0, 1000.0, 10_000.0, 10_000);
    let with = envelope_spectrum(&x, 10_000.0, &EnvelopeParams::default()).unwrap();
    let without = envelope_spectrum(&x, 10_000.0, &EnvelopeParams { remove_mean: false, ..Default::default() }).unwrap();
    assert!(with.values[0].abs() < 1e-12 && with.values[1].abs() < 1e-12);
    assert!((without.values[0] - 1.0).abs() < 1e-9 && (without.values[1] - 1.0).abs() < 1e-9);
    assert_eq!(with.frequency_hz.len(), 5001);
}

/// Bad input: named errors, no panic.
#[test]
fn rejects_bad_input() {
    let x = am(0.5, 37.0, 1000.0, 10_000.0, 1000);
    let d = EnvelopeParams::default();
    assert!(matches!(analytic_signal(&[]), Err(DspError::TooShort { .. })));
    assert!(matches!(envelope(&[]), Err(DspError::TooShort { .. })));
    assert!(matches!(envelope_spectrum(&[], 1000.0, &d), Err(DspError::TooShort { .. })));
    assert!(matches!(envelope_spectrum(&[1.0], 1000.0, &d), Err(DspError::TooShort { .. })));
    let mut y = x.clone();
    y[5] = f64::NAN;
    assert_eq!(analytic_signal(&y), Err(DspError::NonFinite { index: 5 }));
    assert_eq!(envelope_spectrum(&y, 10_000.0, &d), Err(DspError::NonFinite { index: 5 }));
    let band = |b: [f64; 2]| envelope_spectrum(&x, 10_000.0, &EnvelopeParams { band_hz: Some(b), ..d.clone() });
    assert!(matches!(band([0.0, 6000.0]), Err(DspError::BandOutOfRange { name: "band_hz", .. })));
    assert!(matches!(band([300.0, 200.0]), Err(DspError::BandOutOfRange { name: "band_hz", .. })));
    assert!(matches!(band([-1.0, 200.0]), Err(DspError::BandOutOfRange { name: "band_hz", .. })));
    assert!(matches!(band([f64::NAN, 200.0]), Err(DspError::BandOutOfRange { name: "band_hz", .. })));
    for fs in [0.0, -1.0, f64::INFINITY] {
        assert!(matches!(envelope_spectrum(&x, fs, &d), Err(DspError::InvalidParameter { name: "fs_hz", .. })));
    }
    let p: EnvelopeParams = toml::from_str("band_hz = [0.0, 200.0]\nsquared = true").unwrap();
    assert_eq!(p, EnvelopeParams { band_hz: Some([0.0, 200.0]), squared: true, ..Default::default() });
    assert!(toml::from_str::<EnvelopeParams>("band = [0.0, 200.0]").is_err());
}
