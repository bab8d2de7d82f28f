//! Welch PSD against scipy.signal.welch fixtures, Parseval, tone power, and bad input.

mod common;
use std::f64::consts::PI;
use twinscope::dsp::welch::{welch_psd, Average, Detrend, Scaling, WelchParams};
use twinscope::dsp::{DspError, Window};

const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/spectral/");
const FS: f64 = 2048.0;

fn read_column(name: &str) -> Vec<f64> {
    common::read_fixture_column(&format!("{FIX}{name}"))
}

/// Every scipy.signal.welch case of make_spectral.py: elementwise relative error ≤ 1e-9
/// wherever the value is above 1e-12 × the maximum (the others must agree in absolute
/// terms within 1e-12 × max).
#[test]
fn matches_scipy_welch_fixtures() {
    let x = read_column("x.csv");
    assert_eq!(x.len(), 4096);
    let mut n_cases = 0;
    for row in common::read_fixture_table(&format!("{FIX}welch_cases.csv")) {
        let f: Vec<&str> = row.iter().map(String::as_str).collect();
        let opt = |s: &str| -> Option<usize> {
            let v: i64 = s.parse().unwrap();
            (v >= 0).then_some(v as usize)
        };
        let params = WelchParams {
            window: Window::parse(f[1]).unwrap(),
            nperseg: f[2].parse().unwrap(),
            noverlap: opt(f[3]),
            nfft: opt(f[4]),
            detrend: match f[5] {
                "none" => Detrend::None,
                "constant" => Detrend::Constant,
                "linear" => Detrend::Linear,
                other => panic!("{other}"),
            },
            scaling: match f[6] {
                "density" => Scaling::Density,
                "spectrum" => Scaling::Spectrum,
                other => panic!("{other}"),
            },
            average: match f[7] {
                "mean" => Average::Mean,
                "median" => Average::Median,
                other => panic!("{other}"),
            },
        };
        let want = read_column(&format!("welch_{}.csv", f[0]));
        let got = welch_psd(&x, FS, &params).unwrap();
        let nfft = params.nfft.unwrap_or(params.nperseg);
        assert_eq!(got.values.len(), want.len(), "case {}", f[0]);
        assert_eq!(got.frequency_hz.len(), nfft / 2 + 1);
        let max = want.iter().cloned().fold(0.0, f64::max);
        let mut worst: f64 = 0.0;
        for (k, (&g, &w)) in got.values.iter().zip(&want).enumerate() {
            let fk = k as f64 * FS / nfft as f64;
            assert!((got.frequency_hz[k] - fk).abs() <= 1e-12 * FS, "case {} bin {k} frequency", f[0]);
            if w.abs() > 1e-12 * max {
                let rel = (g - w).abs() / w.abs();
                worst = worst.max(rel);
                assert!(rel <= 1e-9, "case {} ({:?}) bin {k}: got {g}, scipy {w}, rel {rel}", f[0], params);
            } else {
                assert!((g - w).abs() <= 1e-12 * max, "case {} bin {k}: got {g}, scipy {w}", f[0]);
            }
        }
        eprintln!("welch case {}: worst relative error {worst:.2e}", f[0]);
        n_cases += 1;
    }
    assert_eq!(n_cases, 8);
}

fn noise(n: usize, seed: u64) -> Vec<f64> {
    // xorshift64* + Box–Muller: a fixed, dependency-free Gaussian sequence.
    let mut s = seed;
    let mut u = || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        ((s.wrapping_mul(0x2545F4914F6CDD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..n).map(|_| (-2.0 * u().ln()).sqrt() * (2.0 * PI * u()).cos()).collect()
}

/// Physics: ∫PSD df = mean square (density scaling, Hann, zero-mean signal), within 1 %.
#[test]
fn integral_of_density_is_mean_square() {
    let fs = 10_000.0;
    let n = 100_000;
    let mut x = noise(n, 7);
    for (i, v) in x.iter_mut().enumerate() {
        *v += 2.0 * (2.0 * PI * 1234.5 * i as f64 / fs).sin();
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let ms: f64 = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
    let psd = welch_psd(&x, fs, &WelchParams { nperseg: 1024, ..Default::default() }).unwrap();
    assert_eq!(psd.unit_suffix, "/Hz");
    let integral: f64 = psd.values.iter().sum::<f64>() * psd.resolution_hz();
    assert!((integral / ms - 1.0).abs() < 0.01, "∫PSD = {integral}, rms² = {ms}");
}

/// Physics: a bin-centred tone of amplitude A with scaling = spectrum reads A²/2 (Hann and
/// boxcar), at its frequency; the rest of the spectrum is ≈ 0.
#[test]
fn tone_power_spectrum_reads_half_a_squared() {
    let fs = 8192.0;
    let a = 3.0;
    let f0 = 1000.0; // bin 125 at nperseg = 1024
    let x: Vec<f64> = (0..16384).map(|i| a * (2.0 * PI * f0 * i as f64 / fs + 0.4).cos()).collect();
    for window in [Window::Hann, Window::Boxcar, Window::Flattop] {
        let p = WelchParams { nperseg: 1024, window, scaling: Scaling::Spectrum, ..Default::default() };
        let psd = welch_psd(&x, fs, &p).unwrap();
        let (k, &peak) = psd.values.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
        assert!((psd.frequency_hz[k] - f0).abs() < 1e-9, "{window:?}");
        assert!((peak - a * a / 2.0).abs() < 1e-9 * a * a, "{window:?}: {peak}");
        assert_eq!(psd.unit_suffix, "");
    }
}

/// A single segment with no detrend equals the directly computed periodogram
/// (naive DFT reference), odd nfft > nperseg.
#[test]
fn single_segment_equals_direct_dft_periodogram() {
    let x = noise(100, 3);
    let nfft = 151;
    let fs = 50.0;
    let p = WelchParams { nperseg: 100, noverlap: Some(0), nfft: Some(nfft), detrend: Detrend::None, window: Window::Hamming, ..Default::default() };
    let psd = welch_psd(&x, fs, &p).unwrap();
    let w = Window::Hamming.periodic(100);
    let s2: f64 = w.iter().map(|v| v * v).sum();
    for k in 0..=nfft / 2 {
        let (mut re, mut im) = (0.0, 0.0);
        for (i, (&v, &wi)) in x.iter().zip(&w).enumerate() {
            let ph = -2.0 * PI * (k * i) as f64 / nfft as f64;
            re += v * wi * ph.cos();
            im += v * wi * ph.sin();
        }
        let c = if k == 0 { 1.0 } else { 2.0 };
        let want = c * (re * re + im * im) / (fs * s2);
        assert!((psd.values[k] - want).abs() <= 1e-10 * want.max(1e-6), "bin {k}: {} vs {want}", psd.values[k]);
    }
}

/// Bad input: each case gives its own error naming the parameter, and never panics.
#[test]
fn rejects_bad_input_with_named_errors() {
    let x = noise(1000, 1);
    let d = WelchParams::default();
    assert!(matches!(welch_psd(&[], 1.0, &d), Err(DspError::TooShort { got: 0, .. })));
    let mut y = x.clone();
    y[17] = f64::NAN;
    assert_eq!(welch_psd(&y, 1.0, &d), Err(DspError::NonFinite { index: 17 }));
    let name = |r: Result<_, DspError>| match r {
        Err(DspError::InvalidParameter { name, .. }) => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    };
    assert_eq!(name(welch_psd(&x, 1.0, &WelchParams { nperseg: 1001, ..d.clone() })), "nperseg");
    assert_eq!(name(welch_psd(&x, 1.0, &WelchParams { nperseg: 0, ..d.clone() })), "nperseg");
    assert_eq!(name(welch_psd(&x, 1.0, &WelchParams { noverlap: Some(256), ..d.clone() })), "noverlap");
    assert_eq!(name(welch_psd(&x, 1.0, &WelchParams { nfft: Some(255), ..d.clone() })), "nfft");
    assert_eq!(name(welch_psd(&x, 0.0, &d)), "fs_hz");
    assert_eq!(name(welch_psd(&x, -5.0, &d)), "fs_hz");
    assert_eq!(name(welch_psd(&x, f64::NAN, &d)), "fs_hz");
    // The message says what to do.
    let msg = welch_psd(&x, 1.0, &WelchParams { noverlap: Some(300), ..d.clone() }).unwrap_err().to_string();
    assert!(msg.contains("noverlap too large"), "{msg}");
    // Edge cases that are valid: nperseg = len, nperseg = 1.
    assert_eq!(welch_psd(&x, 1.0, &WelchParams { nperseg: 1000, ..d.clone() }).unwrap().values.len(), 501);
    assert_eq!(welch_psd(&x, 1.0, &WelchParams { nperseg: 1, noverlap: Some(0), ..d.clone() }).unwrap().values.len(), 1);
}

/// The parameters round-trip through TOML, defaults fill missing fields, unknown fields
/// are refused.
#[test]
fn params_serde() {
    let p: WelchParams = toml::from_str("nperseg = 4096\naverage = \"median\"\ndetrend = \"linear\"").unwrap();
    assert_eq!(p, WelchParams { nperseg: 4096, average: Average::Median, detrend: Detrend::Linear, ..Default::default() });
    let back: WelchParams = toml::from_str(&toml::to_string(&p).unwrap()).unwrap();
    assert_eq!(back, p);
    assert!(toml::from_str::<WelchParams>("npersegg = 3").is_err());
}
