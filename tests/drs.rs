//! Tests of `dsp::drs`: a numpy reference of the same algorithm (tests/fixtures/drs), the
//! analytic separation of harmonics from noise and a slipping bearing signal, physical limits
//! (pure periodic, pure noise), and bad input.

mod common;
use common::{pearson, Rng};
use serde::Deserialize;
use std::f64::consts::PI;
use twinscope::dsp::drs::{drs, DrsParams};
use twinscope::dsp::{DspError, Window};



fn energy(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum()
}

#[derive(Deserialize)]
struct Case {
    window_len: usize,
    delay_samples: usize,
    hop: usize,
    window: String,
    segments: usize,
    deterministic: Vec<f64>,
    transfer_magnitude: Vec<f64>,
}
#[derive(Deserialize)]
struct Reference {
    fs_hz: f64,
    x: Vec<f64>,
    cases: Vec<Case>,
}

/// max |a − b| / max |b|.
fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).fold(0.0_f64, |m, (p, q)| m.max((p - q).abs())) / scale
}

#[test]
fn matches_numpy_reference_to_1e_8() {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/drs/drs_reference.json")).unwrap();
    let r: Reference = serde_json::from_str(&text).unwrap();
    assert_eq!(r.cases.len(), 3);
    for c in &r.cases {
        let p = DrsParams {
            window_len: c.window_len,
            delay_samples: c.delay_samples,
            hop: c.hop,
            window: Window::parse(&c.window).unwrap(),
        };
        let out = drs(&r.x, r.fs_hz, &p).unwrap();
        assert_eq!(out.segments, c.segments);
        let e_d = rel_err(&out.deterministic, &c.deterministic);
        let want_res: Vec<f64> = r.x.iter().zip(&c.deterministic).map(|(a, b)| a - b).collect();
        let e_r = rel_err(&out.residual, &want_res);
        let e_h = rel_err(&out.transfer_magnitude, &c.transfer_magnitude);
        println!(
            "N={} Δ={} R={} {}: rel. error deterministic {e_d:.1e}, residual {e_r:.1e}, |H| {e_h:.1e}",
            c.window_len, c.delay_samples, c.hop, c.window
        );
        assert!(e_d < 1e-8 && e_r < 1e-8 && e_h < 1e-8);
        assert_eq!(out.frequency_hz.len(), c.window_len / 2 + 1);
        assert!((out.frequency_hz[1] - r.fs_hz / c.window_len as f64).abs() < 1e-12);
    }
}

struct Mix {
    x: Vec<f64>,
    periodic: Vec<f64>,
    random: Vec<f64>,
}

/// 10 harmonics of 23.4 Hz (random phases, amplitude 1/√k) + white noise (σ = 0.5) + a bearing
/// signal: 3 kHz resonance excited at 87.7 Hz with ±2 % slip of every interval.
fn mixture(seed: u64, fs: f64, duration_s: f64) -> Mix {
    let mut rng = Rng(seed);
    let n = (fs * duration_s) as usize;
    let phases: Vec<f64> = (0..10).map(|_| 2.0 * PI * rng.uniform()).collect();
    let periodic: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            (1..=10).map(|k| (2.0 * PI * 23.4 * k as f64 * t + phases[k - 1]).cos() / (k as f64).sqrt()).sum()
        })
        .collect();
    let (fr, zeta) = (3000.0, 0.05);
    let h: Vec<f64> = (0..300)
        .map(|i| i as f64 / fs)
        .map(|t| 1.5 * (-zeta * 2.0 * PI * fr * t).exp() * (2.0 * PI * fr * t).sin())
        .collect();
    let mut random: Vec<f64> = (0..n).map(|_| 0.5 * rng.gauss()).collect();
    let t_int = fs / 87.7;
    let mut t = 30.0;
    while t < (n - 1) as f64 {
        let i = t.round() as usize;
        for (j, &v) in h.iter().enumerate().take(n - i) {
            random[i + j] += v;
        }
        t += t_int * (1.0 + 0.02 * (2.0 * rng.uniform() - 1.0));
    }
    let x = periodic.iter().zip(&random).map(|(a, b)| a + b).collect();
    Mix { x, periodic, random }
}

#[test]
fn separates_harmonics_from_noise_and_slipping_bearing_signal() {
    let fs = 16384.0;
    let mix = mixture(42, fs, 8.0);
    let p = DrsParams::default();
    let out = drs(&mix.x, fs, &p).unwrap();
    assert_eq!(out.deterministic.len(), mix.x.len());
    assert_eq!(out.residual.len(), mix.x.len());
    // Away from the ends (the filter needs Δ + N/2 samples of history and N/2 of future).
    let s = p.delay_samples + p.window_len..mix.x.len() - p.window_len;
    let c_det = pearson(&out.deterministic[s.clone()], &mix.periodic[s.clone()]);
    let c_res = pearson(&out.residual[s.clone()], &mix.random[s.clone()]);
    let leak: Vec<f64> = s.clone().map(|i| out.residual[i] - mix.random[i]).collect();
    let leak_ratio = energy(&leak) / energy(&mix.periodic[s.clone()]);
    println!(
        "corr(det, periodic) {c_det:.4}, corr(residual, random) {c_res:.4}, harmonic power left in residual {:.2} %",
        100.0 * leak_ratio
    );
    assert!(c_det > 0.95, "{c_det}");
    assert!(c_res > 0.9, "{c_res}");
    assert!(leak_ratio < 0.05, "{leak_ratio}");
    // The transfer function is ≈ 1 on the harmonics and small elsewhere.
    let df = out.frequency_hz[1];
    for k in 1..=10 {
        let m = (23.4 * k as f64 / df).round() as usize;
        assert!(out.transfer_magnitude[m] > 0.9, "|H| at harmonic {k} = {}", out.transfer_magnitude[m]);
    }
    let mut off: Vec<f64> = (0..out.frequency_hz.len())
        .filter(|&m| {
            let f = out.frequency_hz[m];
            let nearest = (f / 23.4).round() * 23.4;
            (f - nearest).abs() > 8.0 || f > 260.0
        })
        .map(|m| out.transfer_magnitude[m])
        .collect();
    off.sort_by(|a, b| a.total_cmp(b));
    assert!(off[off.len() / 2] < 0.1, "median |H| away from the lines {}", off[off.len() / 2]);
}

#[test]
fn periodic_record_is_all_deterministic_and_noise_all_random() {
    let fs = 16384.0;
    let mix = mixture(1, fs, 4.0);
    let p = DrsParams::default();
    let s = p.delay_samples + p.window_len..mix.periodic.len() - p.window_len;
    let out = drs(&mix.periodic, fs, &p).unwrap();
    let ratio = energy(&out.residual[s.clone()]) / energy(&mix.periodic[s.clone()]);
    assert!(ratio < 1e-3, "periodic power left in residual: {ratio}");
    let mut rng = Rng(5);
    let noise: Vec<f64> = (0..mix.periodic.len()).map(|_| rng.gauss()).collect();
    let out = drs(&noise, fs, &p).unwrap();
    let ratio = energy(&out.deterministic[s.clone()]) / energy(&noise[s.clone()]);
    assert!(ratio < 0.02, "noise power called deterministic: {ratio}");
    // Residual + deterministic = input.
    for ((r, d), v) in out.residual.iter().zip(&out.deterministic).zip(&noise) {
        assert!((r + d - v).abs() < 1e-12);
    }
}

fn param_name(r: Result<twinscope::dsp::drs::DrsResult, DspError>) -> &'static str {
    match r {
        Err(DspError::InvalidParameter { name, .. }) => name,
        other => panic!("expected InvalidParameter, got {:?}", other.map(|o| o.segments)),
    }
}

#[test]
fn bad_input_is_refused_with_the_parameter_named() {
    let x: Vec<f64> = (0..10_000).map(|i| (i as f64 * 0.1).sin()).collect();
    let fs = 1000.0;
    let p = |window_len, delay_samples, hop| DrsParams { window_len, delay_samples, hop, window: Window::Hann };
    assert_eq!(param_name(drs(&x, fs, &p(1023, 600, 256))), "window_len");
    assert_eq!(param_name(drs(&x, fs, &p(2, 1, 1))), "window_len");
    assert_eq!(param_name(drs(&x, fs, &p(0, 0, 1))), "window_len");
    assert_eq!(param_name(drs(&x, fs, &p(1024, 511, 256))), "delay_samples");
    assert_eq!(param_name(drs(&x, fs, &p(1024, 0, 256))), "delay_samples");
    assert_eq!(param_name(drs(&x, fs, &p(1024, 512, 0))), "hop");
    assert_eq!(param_name(drs(&x, fs, &p(1024, 512, 1025))), "hop");
    // Record shorter than window_len + delay_samples.
    assert_eq!(param_name(drs(&x, fs, &p(8192, 4096, 256))), "window_len");
    assert!(drs(&x, fs, &p(4096, 5904, 256)).is_ok(), "exactly one segment pair fits");
    assert_eq!(param_name(drs(&x, 0.0, &p(1024, 512, 256))), "fs_hz");
    let mut bad = x.clone();
    bad[3] = f64::NAN;
    assert_eq!(drs(&bad, fs, &p(1024, 512, 256)).err(), Some(DspError::NonFinite { index: 3 }));
    assert!(matches!(drs(&[], fs, &p(1024, 512, 256)), Err(DspError::TooShort { got: 0, .. })));
    // An all-zero record is not an error: H = 0, both parts zero.
    let out = drs(&vec![0.0; 5000], fs, &p(1024, 512, 256)).unwrap();
    assert!(out.deterministic.iter().chain(&out.residual).all(|&v| v == 0.0));
}

#[test]
fn params_round_trip_through_toml_and_refuse_unknown_fields() {
    let p = DrsParams { window_len: 8192, delay_samples: 4096, hop: 2048, window: Window::Hamming };
    let q: DrsParams = toml::from_str(&toml::to_string(&p).unwrap()).unwrap();
    assert_eq!(p, q);
    let d: DrsParams = toml::from_str("window = \"blackman\"").unwrap();
    assert_eq!(d.window_len, 4096);
    assert!(d.validate(100_000).is_ok());
    assert!(toml::from_str::<DrsParams>("nperseg = 4096").is_err());
}
