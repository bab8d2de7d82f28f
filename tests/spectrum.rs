//! Amplitude spectrum against a numpy fixture and tones, peak finding, unit conversion, dB.

mod common;
use std::f64::consts::PI;
use twinscope::dsp::spectrum::*;
use twinscope::dsp::welch::{welch_psd, Detrend, Scaling, WelchParams};
use twinscope::dsp::{DspError, Window};
use twinscope::signal::Signal;

const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/spectral/");

fn read_column(name: &str) -> Vec<f64> {
    common::read_fixture_column(&format!("{FIX}{name}"))
}

fn tone(a: f64, f: f64, fs: f64, n: usize, phase: f64) -> Vec<f64> {
    (0..n).map(|i| a * (2.0 * PI * f * i as f64 / fs + phase).cos()).collect()
}

/// numpy rfft amplitude spectrum (hann, zero padded to 2048, peak scaling): rel ≤ 1e-10
/// where the value is above 1e-9 × max.
#[test]
fn matches_numpy_amplitude_fixture() {
    let x = read_column("tone.csv");
    let want = read_column("amplitude.csv");
    let s = amplitude_spectrum(&x, 1000.0, &SpectrumParams { nfft: Some(2048), ..Default::default() }).unwrap();
    assert_eq!(s.values.len(), want.len());
    let max = want.iter().cloned().fold(0.0, f64::max);
    for (k, (&g, &w)) in s.values.iter().zip(&want).enumerate() {
        if w > 1e-9 * max {
            assert!((g - w).abs() <= 1e-10 * w, "bin {k}: {g} vs {w}");
        } else {
            assert!((g - w).abs() <= 1e-12 * max, "bin {k}: {g} vs {w}");
        }
    }
    // The off-bin 123.4 Hz tone is found near its frequency by parabolic interpolation.
    let (f, _) = s.peak().unwrap();
    assert!((f - 123.4).abs() < 0.1, "{f}");
}

/// Physics: a bin-centred tone of amplitude A reads A (peak), A/√2 (rms), A²/2 (power)
/// — for every window (coherent gain corrected); DC reads its value.
#[test]
fn tone_reads_its_amplitude() {
    let fs = 1000.0;
    let mut x = tone(2.5, 125.0, fs, 1000, 0.7);
    x.iter_mut().for_each(|v| *v += 0.0); // no DC: keep it clean
    for window in [Window::Hann, Window::Boxcar, Window::Hamming, Window::Blackman, Window::Flattop] {
        let p = SpectrumParams { window, ..Default::default() };
        let s = amplitude_spectrum(&x, fs, &p).unwrap();
        assert_eq!(s.quantity, "amplitude (peak)");
        assert!((s.values[125] - 2.5).abs() < 1e-12, "{window:?}: {}", s.values[125]);
        let (f, v) = s.peak().unwrap();
        assert!((f - 125.0).abs() < 1e-9 && (v - 2.5).abs() < 1e-12);
        let r = amplitude_spectrum(&x, fs, &SpectrumParams { scaling: AmplitudeScaling::Rms, ..p.clone() }).unwrap();
        assert!((r.values[125] - 2.5 / 2f64.sqrt()).abs() < 1e-12);
        let q = amplitude_spectrum(&x, fs, &SpectrumParams { scaling: AmplitudeScaling::PowerSpectrum, ..p }).unwrap();
        assert!((q.values[125] - 2.5 * 2.5 / 2.0).abs() < 1e-12);
    }
    let dc = vec![0.75; 64];
    let s = amplitude_spectrum(&dc, 64.0, &SpectrumParams::default()).unwrap();
    assert!((s.values[0] - 0.75).abs() < 1e-14);
}

/// The power-spectrum scaling equals a one-segment Welch estimate (scaling = spectrum,
/// no detrend), an independent code path: rel ≤ 1e-12.
#[test]
fn power_spectrum_equals_one_segment_welch() {
    let x = read_column("tone.csv");
    let s = amplitude_spectrum(&x, 1000.0, &SpectrumParams { scaling: AmplitudeScaling::PowerSpectrum, nfft: Some(1500), window: Window::Hamming }).unwrap();
    let w = welch_psd(&x, 1000.0, &WelchParams { nperseg: 1000, nfft: Some(1500), window: Window::Hamming, detrend: Detrend::None, scaling: Scaling::Spectrum, ..Default::default() }).unwrap();
    for (a, b) in s.values.iter().zip(&w.values) {
        assert!((a - b).abs() <= 1e-12 * b.max(1e-12), "{a} vs {b}");
    }
}

/// Physics: acceleration tone A at 100 Hz → velocity A/(2π·100) (amplitude) and
/// (A/(2π·100))² (power), DC set to 0; the unit follows m/s^2 → m/s → m.
#[test]
fn unit_conversion_in_the_frequency_domain() {
    let fs = 2000.0;
    let a = 9.81;
    let sig = Signal::new(tone(a, 100.0, fs, 2000, 0.0).iter().map(|v| v + 1.0).collect(), fs, "acc", "m/s^2");
    let s = amplitude_spectrum_of(&sig, &SpectrumParams::default()).unwrap();
    assert_eq!(s.unit, "m/s^2");
    let v = convert_units(&s, Quantity::Acceleration, Quantity::Velocity, SpectrumKind::Amplitude).unwrap();
    let want = a / (2.0 * PI * 100.0);
    assert!((v.values[100] - want).abs() < 1e-12 * want, "{} vs {want}", v.values[100]);
    assert_eq!(v.values[0], 0.0);
    assert_eq!(v.unit, "m/s");
    assert_eq!(v.quantity, "velocity amplitude (peak)");
    let d = convert_units(&s, Quantity::Acceleration, Quantity::Displacement, SpectrumKind::Amplitude).unwrap();
    assert!((d.values[100] - a / (2.0 * PI * 100.0).powi(2)).abs() < 1e-15);
    assert_eq!(d.unit, "m");
    // Back again: differentiation undoes integration (except DC).
    let back = convert_units(&v, Quantity::Velocity, Quantity::Acceleration, SpectrumKind::Amplitude).unwrap();
    assert!((back.values[100] - a).abs() < 1e-12);
    // Power: ÷ (2πf)².
    let pw = amplitude_spectrum_of(&sig, &SpectrumParams { scaling: AmplitudeScaling::PowerSpectrum, ..Default::default() }).unwrap();
    assert_eq!(pw.unit, "(m/s^2)^2");
    let pv = convert_units(&pw, Quantity::Acceleration, Quantity::Velocity, SpectrumKind::Power).unwrap();
    assert!((pv.values[100] - want * want / 2.0).abs() < 1e-12 * want * want);
    assert_eq!(pv.unit, "(m/s)^2");
    // An unknown unit gets seconds appended, never a silent gravity factor.
    let g = Spectrum { unit: "g".into(), ..s.clone() };
    assert_eq!(convert_units(&g, Quantity::Acceleration, Quantity::Velocity, SpectrumKind::Amplitude).unwrap().unit, "g·s");
}

/// Time-domain integration via FFT: a 100 Hz acceleration tone gives the velocity
/// (A/(2π·100)) sin(...) to 1e-12 (whole periods), bins below highpass_hz removed.
#[test]
fn integrate_tone_in_time_domain() {
    let fs = 2000.0;
    let n = 4000;
    let a = 3.0;
    let mut x = tone(a, 100.0, fs, n, 0.0);
    let low = tone(1.0, 2.0, fs, n, 0.0); // a 2 Hz component the high-pass removes
    x.iter_mut().zip(&low).for_each(|(v, l)| *v += l + 0.3);
    let v = integrate_frequency_domain(&x, fs, Quantity::Acceleration, Quantity::Velocity, 5.0).unwrap();
    let w = 2.0 * PI * 100.0;
    for (i, &vi) in v.iter().enumerate() {
        let want = a / w * (w * i as f64 / fs).sin();
        assert!((vi - want).abs() < 1e-12, "{i}: {vi} vs {want}");
    }
    let d = integrate_frequency_domain(&x, fs, Quantity::Acceleration, Quantity::Displacement, 5.0).unwrap();
    for (i, &di) in d.iter().enumerate() {
        let want = -a / (w * w) * (w * i as f64 / fs).cos();
        assert!((di - want).abs() < 1e-12, "{i}");
    }
}

/// Peak finding: two tones found, sorted by value, separation honoured, parabolic
/// refinement exact for a parabola.
#[test]
fn peaks_band_and_interpolation() {
    let fs = 1000.0;
    let x: Vec<f64> = tone(1.0, 100.0, fs, 1000, 0.0).iter().zip(tone(0.5, 250.0, fs, 1000, 0.2)).map(|(a, b)| a + b).collect();
    let s = amplitude_spectrum(&x, fs, &SpectrumParams::default()).unwrap();
    let p = s.top_peaks(5, 10.0).unwrap();
    assert!(p.len() >= 2);
    assert!((p[0].0 - 100.0).abs() < 1e-9 && (p[0].1 - 1.0).abs() < 1e-12);
    assert!((p[1].0 - 250.0).abs() < 1e-9 && (p[1].1 - 0.5).abs() < 1e-12);
    // Only the top one within its band.
    let b = s.band(200.0, 300.0).unwrap();
    assert_eq!(b.frequency_hz.first(), Some(&200.0));
    assert_eq!(b.frequency_hz.last(), Some(&300.0));
    assert!((b.peak().unwrap().0 - 250.0).abs() < 1e-9);
    // Parabola y = 10 − (f − 3.3)² sampled at integers: vertex exactly at 3.3.
    let para = Spectrum { frequency_hz: (0..8).map(|i| i as f64).collect(), values: (0..8).map(|i| 10.0 - (i as f64 - 3.3).powi(2)).collect(), quantity: "x".into(), unit: "".into() };
    let (f, v) = para.top_peaks(1, 0.0).unwrap()[0];
    assert!((f - 3.3).abs() < 1e-12 && v == para.values[3], "{f}");
    // Separation: two maxima 2 Hz apart, min separation 3 Hz keeps one.
    let two = Spectrum { frequency_hz: (0..7).map(|i| i as f64).collect(), values: vec![0.0, 5.0, 0.0, 4.0, 0.0, 0.0, 0.0], quantity: "".into(), unit: "".into() };
    assert_eq!(two.top_peaks(5, 3.0).unwrap().len(), 1);
    assert_eq!(two.top_peaks(5, 1.0).unwrap().len(), 2);
    assert_eq!(two.top_peaks(0, 1.0).unwrap().len(), 0);
    let empty = Spectrum { frequency_hz: vec![], values: vec![], quantity: "".into(), unit: "".into() };
    assert_eq!(empty.peak(), None);
    assert!(empty.top_peaks(3, 0.0).unwrap().is_empty());
}

/// dB: 20 log10 for amplitudes, 10 log10 for powers, floor at −300 dB, reference in unit.
#[test]
fn decibels() {
    let d = to_db(&[1.0, 10.0, 0.1, 0.0, -10.0], 1.0, DbKind::Amplitude).unwrap();
    assert_eq!(d, vec![0.0, 20.0, -20.0, DB_FLOOR_DB, 20.0]);
    let p = to_db(&[2e-6, 2e-7, 0.0], 2e-6, DbKind::Power).unwrap();
    assert!((p[0]).abs() < 1e-12 && (p[1] + 10.0).abs() < 1e-12 && p[2] == DB_FLOOR_DB);
    assert!(d.iter().chain(&p).all(|v| v.is_finite()));
    let s = Spectrum { frequency_hz: vec![0.0, 1.0], values: vec![1.0, 0.5], quantity: "amplitude (peak)".into(), unit: "g".into() };
    let sd = s.to_db(1.0, DbKind::Amplitude).unwrap();
    assert_eq!(sd.unit, "dB re 1 g");
    assert!((sd.values[1] + 6.020599913279624).abs() < 1e-12);
}

/// Bad input: named errors, no panic.
#[test]
fn rejects_bad_input() {
    let name = |e: DspError| match e {
        DspError::InvalidParameter { name, .. } => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    };
    let d = SpectrumParams::default();
    assert!(matches!(amplitude_spectrum(&[], 1.0, &d), Err(DspError::TooShort { .. })));
    assert_eq!(amplitude_spectrum(&[1.0, f64::NAN], 1.0, &d), Err(DspError::NonFinite { index: 1 }));
    assert_eq!(name(amplitude_spectrum(&[1.0; 8], 0.0, &d).unwrap_err()), "fs_hz");
    assert_eq!(name(amplitude_spectrum(&[1.0; 8], 1.0, &SpectrumParams { nfft: Some(7), ..d.clone() }).unwrap_err()), "nfft");
    // A one-sample Hann window is [1]: valid, and a DC reads its value.
    assert_eq!(amplitude_spectrum(&[2.0], 1.0, &d).unwrap().values, vec![2.0]);
    let s = amplitude_spectrum(&[1.0; 8], 8.0, &d).unwrap();
    assert_eq!(name(s.band(3.0, 1.0).unwrap_err()), "band_hz");
    assert_eq!(name(s.band(f64::NAN, 1.0).unwrap_err()), "band_hz");
    assert!(s.band(100.0, 200.0).unwrap().is_empty());
    assert_eq!(name(s.top_peaks(3, -1.0).unwrap_err()), "min_separation_hz");
    assert_eq!(name(to_db(&[1.0], 0.0, DbKind::Power).unwrap_err()), "reference");
    assert_eq!(name(to_db(&[-1.0], 1.0, DbKind::Power).unwrap_err()), "values");
    assert_eq!(to_db(&[f64::INFINITY], 1.0, DbKind::Power), Err(DspError::NonFinite { index: 0 }));
    let x = vec![0.0; 100];
    assert_eq!(name(integrate_frequency_domain(&x, 100.0, Quantity::Acceleration, Quantity::Velocity, 50.0).unwrap_err()), "highpass_hz");
    assert_eq!(name(integrate_frequency_domain(&x, 100.0, Quantity::Acceleration, Quantity::Velocity, -1.0).unwrap_err()), "highpass_hz");
    assert!(matches!(integrate_frequency_domain(&[1.0], 100.0, Quantity::Acceleration, Quantity::Velocity, 0.0), Err(DspError::TooShort { .. })));
    let bad = Spectrum { frequency_hz: vec![0.0], values: vec![], quantity: "".into(), unit: "".into() };
    assert_eq!(name(convert_units(&bad, Quantity::Acceleration, Quantity::Velocity, SpectrumKind::Amplitude).unwrap_err()), "spectrum");
    assert!(toml::from_str::<SpectrumParams>("scaling = \"rms\"\nnfft = 4096").is_ok());
    assert!(toml::from_str::<SpectrumParams>("scale = \"rms\"").is_err());
}
