//! Tests of `twinscope::dsp::remez`: Parks–McClellan design against scipy.signal.remez,
//! the spec-driven bandpass design loop, zero-phase filtering against scipy.signal.filtfilt,
//! analytic tone tests and bad input. Fixtures: tests/fixtures/remez (make_remez.py).

use std::f64::consts::PI;
use twinscope::dsp::remez::{
    bandpass_zero_phase, design_bandpass, estimate_numtaps, filtfilt_fir, frequency_response_db, remez, BandpassSpec,
};
use twinscope::dsp::DspError;

const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/remez");
const FS: f64 = 16384.0;

fn load_json(name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(format!("{FIX}/{name}")).expect("fixture readable");
    serde_json::from_str(&text).expect("fixture is JSON")
}

fn f64s(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().expect("number")).collect()
}

struct Design {
    name: String,
    numtaps: usize,
    bands_hz: Vec<(f64, f64)>,
    desired: Vec<f64>,
    weights: Vec<f64>,
    fs_hz: f64,
    taps: Vec<f64>,
    taps_gd16: Vec<f64>,
}

fn designs() -> Vec<Design> {
    let j = load_json("designs.json");
    j["designs"]
        .as_array()
        .expect("designs")
        .iter()
        .map(|d| Design {
            name: d["name"].as_str().expect("name").to_string(),
            numtaps: d["numtaps"].as_u64().expect("numtaps") as usize,
            bands_hz: d["bands_hz"]
                .as_array()
                .expect("bands")
                .iter()
                .map(|b| {
                    let b = f64s(b);
                    (b[0], b[1])
                })
                .collect(),
            desired: f64s(&d["desired"]),
            weights: f64s(&d["weights"]),
            fs_hz: d["fs_hz"].as_f64().expect("fs"),
            taps: f64s(&d["taps"]),
            taps_gd16: f64s(&d["taps_gd16"]),
        })
        .collect()
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

/// Seed-spec bands for a given transition width.
fn seed_bands(tr: f64) -> Vec<(f64, f64)> {
    vec![(0.0, 900.0 - tr), (900.0, 1800.0), (1800.0 + tr, FS / 2.0)]
}

/// |H(f)| by the direct DTFT sum, the naive reference.
fn dtft_mag(taps: &[f64], f_hz: f64, fs: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for (n, &t) in taps.iter().enumerate() {
        let ph = -2.0 * PI * f_hz * n as f64 / fs;
        re += t * ph.cos();
        im += t * ph.sin();
    }
    (re * re + im * im).sqrt()
}

/// (ripple dB, lower attenuation dB, upper attenuation dB) measured independently of the
/// library's own measurement: on a 2^17-point grid (0.0625 Hz at 16384 Hz) by
/// `frequency_response_db`, whose values are checked against the direct DTFT elsewhere.
fn figures(taps: &[f64], bands: &[(f64, f64)], fs: f64) -> (f64, f64, f64) {
    let (f, db) = frequency_response_db(taps, fs, (1 << 17) + 1).expect("response");
    let in_band = |(lo, hi): (f64, f64)| f.iter().zip(&db).filter(move |(fk, _)| **fk >= lo && **fk <= hi).map(|(_, d)| *d);
    let pmax = in_band(bands[1]).fold(f64::NEG_INFINITY, f64::max);
    let pmin = in_band(bands[1]).fold(f64::INFINITY, f64::min);
    let lo = -in_band(bands[0]).fold(f64::NEG_INFINITY, f64::max);
    let hi = -in_band(bands[2]).fold(f64::NEG_INFINITY, f64::max);
    (pmax - pmin, lo, hi)
}

// ---------------------------------------------------------------- remez vs scipy

#[test]
fn remez_matches_scipy_run_to_convergence() {
    // scipy.signal.remez, maxiter=1000, grid_density=512 (within ~1e-7 of gd=1024): the
    // gridless pm-remez solution must agree to 1e-4 of the largest tap.
    let ds = designs();
    assert_eq!(ds.len(), 8);
    for d in &ds {
        let h = remez(d.numtaps, &d.bands_hz, &d.desired, &d.weights, d.fs_hz).expect("design converges");
        assert_eq!(h.len(), d.numtaps);
        let e = max_rel_diff(&h, &d.taps);
        println!("{}: max |h - h_scipy| / max|h_scipy| = {e:.2e}", d.name);
        assert!(e <= 1e-4, "{}: relative tap error {e:.2e} > 1e-4", d.name);
    }
}

#[test]
fn remez_close_to_scipy_default_grid() {
    // On scipy's default grid_density=16 the grid itself moves the taps by up to 4.1e-4
    // (seed_215_tr200) of the largest tap relative to the fine-grid solution; allow 6e-4.
    for d in &designs() {
        let h = remez(d.numtaps, &d.bands_hz, &d.desired, &d.weights, d.fs_hz).expect("design converges");
        let e = max_rel_diff(&h, &d.taps_gd16);
        println!("{}: vs scipy gd=16: {e:.2e}", d.name);
        assert!(e <= 6e-4, "{}: {e:.2e}", d.name);
    }
}

#[test]
fn taps_have_linear_phase_symmetry() {
    for d in &designs() {
        let h = remez(d.numtaps, &d.bands_hz, &d.desired, &d.weights, d.fs_hz).expect("design converges");
        let scale = h.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for n in 0..h.len() / 2 {
            assert!((h[n] - h[h.len() - 1 - n]).abs() <= 1e-12 * scale, "{}: h[{n}] not symmetric", d.name);
        }
    }
}

// ---------------------------------------------------------------- order estimate and design loop

#[test]
fn herrmann_estimate_of_seed_spec() {
    // Hand computation of Herrmann's formula (see the doc comment): 208.09 -> 209 for 200 Hz
    // transitions, 415.4 -> 416 for 100 Hz.
    assert_eq!(estimate_numtaps(&BandpassSpec::default(), FS).unwrap(), 209);
    let spec = BandpassSpec { transition_low_hz: 100.0, transition_high_hz: 100.0, ..Default::default() };
    assert_eq!(estimate_numtaps(&spec, FS).unwrap(), 416);
}

#[test]
fn herrmann_length_falls_short_of_the_seed_spec() {
    // The issue: 209 taps reach only about 58.9 / 78.6 dB. The gridless optimum reaches
    // 58.94 / 78.94 dB (ripple 1.13 dB): short of 60 / 80 dB, and the two stopbands exactly
    // 20 dB apart as the weights ask.
    let spec = BandpassSpec::default();
    let h = remez(209, &seed_bands(200.0), &[0.0, 1.0, 0.0], &spec.weights(), FS).unwrap();
    let (ripple, lo, hi) = figures(&h, &seed_bands(200.0), FS);
    println!("209 taps: ripple {ripple:.3} dB, stopbands {lo:.2} / {hi:.2} dB");
    assert!(ripple > 1.0 && lo < 60.0 && hi < 80.0);
    assert!((lo - 58.94).abs() < 0.02 && (hi - 78.94).abs() < 0.02 && (ripple - 1.130).abs() < 0.002, "{ripple} {lo} {hi}");
}

#[test]
fn scipy_default_grid_explains_the_issue_figures() {
    // The issue's 78.6 dB is scipy's grid_density=16 design measured on a dense grid: it is
    // equiripple on the 16-point grid only and overshoots between grid points. Likewise at
    // 425 taps / 100 Hz transitions scipy's gd=16 design misses 80 dB where the gridless one
    // meets it.
    let ds = designs();
    let get = |name: &str| ds.iter().find(|d| d.name == name).expect("design in fixture");
    let (_, lo, hi) = figures(&get("seed_209_tr200").taps_gd16, &seed_bands(200.0), FS);
    println!("scipy gd=16, 209 taps: {lo:.2} / {hi:.2} dB");
    assert!((lo - 58.90).abs() < 0.02 && (hi - 78.63).abs() < 0.02, "{lo} {hi}");
    let d425 = get("seed_425_tr100");
    let (_, _, hi16) = figures(&d425.taps_gd16, &seed_bands(100.0), FS);
    let h = remez(425, &d425.bands_hz, &d425.desired, &d425.weights, FS).unwrap();
    let (r, lo, hi) = figures(&h, &seed_bands(100.0), FS);
    println!("425 taps, 100 Hz: scipy gd=16 upper {hi16:.2} dB; gridless {r:.3} dB, {lo:.2} / {hi:.2} dB");
    assert!(hi16 < 80.0);
    assert!(r <= 1.0 && lo >= 60.0 && hi >= 80.0);
}

#[test]
fn default_design_meets_spec_with_about_215_taps() {
    let spec = BandpassSpec::default();
    let d = design_bandpass(&spec, FS).expect("seed spec is feasible");
    println!(
        "default: {} taps (estimate {}), ripple {:.4} dB, stopbands {:.3} / {:.3} dB",
        d.numtaps, d.estimated_taps, d.achieved_ripple_db, d.achieved_stopband_low_db, d.achieved_stopband_high_db
    );
    assert_eq!(d.estimated_taps, 209);
    assert_eq!(d.numtaps, 215);
    assert_eq!(d.taps.len(), d.numtaps);
    assert_eq!(d.numtaps % 2, 1, "type I");
    assert_eq!(d.fs_hz, FS);
    assert_eq!(d.bands_hz, seed_bands(200.0));
    assert_eq!(d.spec, spec);
    // Reported figures meet the spec...
    assert!(d.achieved_ripple_db <= 1.0 && d.achieved_stopband_low_db >= 60.0 && d.achieved_stopband_high_db >= 80.0);
    // ...and agree with an independent, 4x denser measurement to 0.01 dB.
    let (ripple, lo, hi) = figures(&d.taps, &d.bands_hz, FS);
    assert!((ripple - d.achieved_ripple_db).abs() < 0.01, "{ripple} vs {}", d.achieved_ripple_db);
    assert!((lo - d.achieved_stopband_low_db).abs() < 0.01 && (hi - d.achieved_stopband_high_db).abs() < 0.01);
    assert!(ripple <= 1.0 + 1e-3 && lo >= 60.0 - 1e-3 && hi >= 80.0 - 1e-3);
    // Minimality: two taps fewer does not meet the spec.
    let h = remez(d.numtaps - 2, &d.bands_hz, &d.desired, &d.weights, FS).unwrap();
    let (r2, lo2, hi2) = figures(&h, &d.bands_hz, FS);
    assert!(r2 > 1.0 || lo2 < 60.0 || hi2 < 80.0, "{} taps would do", d.numtaps - 2);
}

#[test]
fn design_with_100hz_transitions_needs_about_441_taps() {
    let spec = BandpassSpec { transition_low_hz: 100.0, transition_high_hz: 100.0, ..Default::default() };
    let d = design_bandpass(&spec, FS).expect("feasible");
    println!(
        "100 Hz: {} taps (estimate {}), ripple {:.4} dB, stopbands {:.3} / {:.3} dB",
        d.numtaps, d.estimated_taps, d.achieved_ripple_db, d.achieved_stopband_low_db, d.achieved_stopband_high_db
    );
    // The issue says "about 441"; the shortest odd length meeting the spec is 425 (60.16 /
    // 80.15 dB, ripple 0.982 dB; 423 gives 59.91 / 79.91 dB), confirmed on scipy's fine-grid
    // design in make_remez.py. 441 meets the spec with 1.5 dB to spare.
    assert_eq!(d.estimated_taps, 416);
    assert_eq!(d.numtaps, 425);
    let (ripple, lo, hi) = figures(&d.taps, &d.bands_hz, FS);
    assert!(ripple <= 1.0 + 1e-3 && lo >= 60.0 - 1e-3 && hi >= 80.0 - 1e-3, "{ripple} {lo} {hi}");
}

#[test]
fn overestimated_length_is_shrunk() {
    // Tiny ripple, low attenuation: Herrmann overestimates (102; scipy on a fine grid finds
    // 97 the shortest odd length). The loop must shrink to a length meeting the spec whose
    // predecessor does not.
    let spec = BandpassSpec {
        pass_band_hz: [2000.0, 4000.0],
        transition_low_hz: 500.0,
        transition_high_hz: 500.0,
        passband_ripple_db: 0.001,
        stopband_low_db: 30.0,
        stopband_high_db: 30.0,
        ..Default::default()
    };
    let d = design_bandpass(&spec, FS).unwrap();
    println!("overestimated: {} taps (estimate {})", d.numtaps, d.estimated_taps);
    assert_eq!(d.estimated_taps, 102);
    assert!(d.numtaps < 103, "did not shrink: {}", d.numtaps);
    let (r, lo, hi) = figures(&d.taps, &d.bands_hz, FS);
    assert!(r <= 0.001 + 1e-5 && lo >= 30.0 - 1e-3 && hi >= 30.0 - 1e-3, "{r} {lo} {hi}");
    let h = remez(d.numtaps - 2, &d.bands_hz, &d.desired, &d.weights, FS).unwrap();
    let (r2, lo2, hi2) = figures(&h, &d.bands_hz, FS);
    assert!(r2 > 0.001 || lo2 < 30.0 || hi2 < 30.0);
}

#[test]
fn impossible_spec_reports_design_not_met_with_figures() {
    let spec = BandpassSpec { transition_low_hz: 1.0, transition_high_hz: 1.0, max_taps: 101, ..Default::default() };
    match design_bandpass(&spec, FS) {
        Err(DspError::DesignNotMet {
            max_taps, ripple_db, ripple_spec_db, atten_low_db, atten_high_db, atten_low_spec_db, atten_high_spec_db,
        }) => {
            println!("not met: ripple {ripple_db:.2} dB, stopbands {atten_low_db:.2} / {atten_high_db:.2} dB");
            assert_eq!(max_taps, 101);
            assert_eq!((ripple_spec_db, atten_low_spec_db, atten_high_spec_db), (1.0, 60.0, 80.0));
            assert!(ripple_db.is_finite() && atten_low_db.is_finite() && atten_high_db.is_finite());
            assert!(ripple_db > 1.0 || atten_low_db < 60.0 || atten_high_db < 80.0);
        }
        other => panic!("expected DesignNotMet, got {other:?}"),
    }
}

// ---------------------------------------------------------------- frequency response

#[test]
fn frequency_response_matches_direct_dtft() {
    let ds = designs();
    let d = ds.iter().find(|d| d.name == "bandpass_even_64").expect("fixture"); // fs = 1000
    for n_points in [2usize, 17, 513, 1000] {
        let (f, db) = frequency_response_db(&d.taps, d.fs_hz, n_points).unwrap();
        assert_eq!(f.len(), n_points);
        assert_eq!(f[0], 0.0);
        assert!((f[n_points - 1] - d.fs_hz / 2.0).abs() < 1e-9);
        for (fk, dk) in f.iter().zip(&db) {
            let m = dtft_mag(&d.taps, *fk, d.fs_hz);
            assert!((10f64.powf(dk / 20.0) - m).abs() < 1e-12, "n_points {n_points} f {fk}");
        }
    }
}

// ---------------------------------------------------------------- zero-phase filtering

fn read_xy(file: &str) -> (Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(format!("{FIX}/{file}")).expect("fixture readable");
    text.lines()
        .skip(1)
        .map(|l| {
            let mut it = l.split(',').map(|v| v.trim().parse::<f64>().expect("number"));
            (it.next().expect("x"), it.next().expect("y"))
        })
        .unzip()
}

#[test]
fn filtfilt_matches_scipy() {
    let j = load_json("filtfilt.json");
    let cases = j["cases"].as_array().expect("cases");
    assert_eq!(cases.len(), 3);
    for c in cases {
        let taps = f64s(&c["taps"]);
        let (x, y_ref) = read_xy(c["file"].as_str().expect("file"));
        let y = filtfilt_fir(&taps, &x).expect("filtfilt");
        assert_eq!(y.len(), x.len());
        let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
        let err = y.iter().zip(&y_ref).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / rms;
        println!("filtfilt {}: max |y - y_scipy| / rms(x) = {err:.2e}", c["name"]);
        assert!(err <= 1e-9, "{}: {err:.2e}", c["name"]);
    }
}

#[test]
fn filtfilt_identity_and_dc_gain() {
    let x: Vec<f64> = (0..50).map(|i| ((i * 37) % 17) as f64 - 8.0).collect();
    let y = filtfilt_fir(&[1.0], &x).unwrap();
    for (a, b) in x.iter().zip(&y) {
        assert!((a - b).abs() < 1e-12);
    }
    // A constant input comes out scaled by H(0)^2 = (Σb)^2 everywhere (edges included).
    let b = [0.2, 0.5, 0.1];
    let y = filtfilt_fir(&b, &[2.0; 40]).unwrap();
    for v in y {
        assert!((v - 2.0 * 0.8 * 0.8).abs() < 1e-12, "{v}");
    }
}

/// Amplitude of the sinusoid at `f_hz` in `y[range]` by least squares on cos/sin.
fn tone_amplitude(y: &[f64], f_hz: f64, fs: f64, range: std::ops::Range<usize>) -> f64 {
    let (mut cc, mut ss, mut cs, mut yc, mut ys) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for n in range {
        let (s, c) = (2.0 * PI * f_hz * n as f64 / fs).sin_cos();
        cc += c * c;
        ss += s * s;
        cs += c * s;
        yc += y[n] * c;
        ys += y[n] * s;
    }
    let det = cc * ss - cs * cs;
    let a = (yc * ss - ys * cs) / det;
    let b = (ys * cc - yc * cs) / det;
    (a * a + b * b).sqrt()
}

#[test]
fn tones_pass_and_stop_as_specified_after_zero_phase_filtering() {
    let spec = BandpassSpec::default();
    let n = 32768;
    let tone = |f: f64, a: f64| -> Vec<f64> { (0..n).map(|i| a * (2.0 * PI * f * i as f64 / FS + 0.4).sin()).collect() };
    let dp = spec.delta_pass();

    // Passband tone, amplitude 2: gain |H|² within the doubled ripple, and equal to |H(f)|² of
    // the design, and no phase shift.
    let f0 = 1350.0;
    let (y, d) = bandpass_zero_phase(&tone(f0, 2.0), FS, &spec).unwrap();
    let mid = n / 4..3 * n / 4;
    let gain = tone_amplitude(&y, f0, FS, mid.clone()) / 2.0;
    assert!(gain >= (1.0 - dp).powi(2) && gain <= (1.0 + dp).powi(2), "gain {gain}");
    let h = dtft_mag(&d.taps, f0, FS);
    assert!((gain - h * h).abs() < 1e-9, "gain {gain} vs |H|² {}", h * h);
    let x = tone(f0, 2.0 * gain);
    let max_dev = mid.clone().map(|i| (y[i] - x[i]).abs()).fold(0.0, f64::max);
    assert!(max_dev < 1e-9, "zero phase: {max_dev}");

    // Stopband tones: attenuated by at least twice the spec in dB over the whole record.
    for (f, att_db) in [(300.0, 60.0), (650.0, 60.0), (2100.0, 80.0), (5000.0, 80.0), (8000.0, 80.0)] {
        let y = filtfilt_fir(&d.taps, &tone(f, 1.0)).unwrap();
        let peak_mid = mid.clone().map(|i| y[i].abs()).fold(0.0, f64::max);
        let limit = 10f64.powf(-2.0 * att_db / 20.0);
        println!("stopband tone {f} Hz: peak {peak_mid:.2e} (limit {limit:.1e})");
        assert!(peak_mid <= limit, "{f} Hz: {peak_mid:e} > {limit:e}");
    }
}

// ---------------------------------------------------------------- bad input

fn param_name(r: Result<impl std::fmt::Debug, DspError>) -> &'static str {
    match r {
        Err(DspError::InvalidParameter { name, .. }) | Err(DspError::BandOutOfRange { name, .. }) => name,
        other => panic!("expected a parameter error, got {other:?}"),
    }
}

#[test]
fn bad_spec_is_rejected_naming_the_field() {
    let s = BandpassSpec::default;
    let cases: Vec<(BandpassSpec, f64, &str)> = vec![
        (BandpassSpec { pass_band_hz: [900.0, 9000.0], ..s() }, FS, "pass_band_hz"), // above Nyquist
        (BandpassSpec { pass_band_hz: [1800.0, 900.0], ..s() }, FS, "pass_band_hz"), // inverted
        (BandpassSpec { pass_band_hz: [f64::NAN, 900.0], ..s() }, FS, "pass_band_hz"),
        (BandpassSpec { passband_ripple_db: 0.0, ..s() }, FS, "passband_ripple_db"),
        (BandpassSpec { passband_ripple_db: f64::NAN, ..s() }, FS, "passband_ripple_db"),
        (BandpassSpec { stopband_low_db: -60.0, ..s() }, FS, "stopband_low_db"),
        (BandpassSpec { stopband_high_db: 0.0, ..s() }, FS, "stopband_high_db"),
        (BandpassSpec { transition_low_hz: 0.0, ..s() }, FS, "transition_low_hz"),
        (BandpassSpec { transition_low_hz: 900.0, ..s() }, FS, "transition_low_hz"), // stop edge at 0
        (BandpassSpec { transition_high_hz: -5.0, ..s() }, FS, "transition_high_hz"),
        (BandpassSpec { transition_high_hz: 6392.0, ..s() }, FS, "transition_high_hz"), // edge = Nyquist
        (BandpassSpec { max_taps: 1, ..s() }, FS, "max_taps"),
        (BandpassSpec { max_taps: 1_000_000, ..s() }, FS, "max_taps"),
        (BandpassSpec { grid_density: 4, ..s() }, FS, "grid_density"),
        (s(), 0.0, "fs_hz"),
        (s(), f64::NAN, "fs_hz"),
    ];
    for (spec, fs, want) in cases {
        assert_eq!(param_name(spec.validate(fs)), want, "{spec:?}");
        assert_eq!(param_name(design_bandpass(&spec, fs)), want);
        assert_eq!(param_name(bandpass_zero_phase(&[0.0; 5000], fs, &spec)), want);
    }
    assert!(BandpassSpec::default().validate(FS).is_ok());
}

#[test]
fn bad_remez_arguments_are_rejected_naming_the_parameter() {
    let b = seed_bands(200.0);
    let (d, w) = ([0.0, 1.0, 0.0], [1.0, 1.0, 1.0]);
    assert_eq!(param_name(remez(2, &b, &d, &w, FS)), "numtaps");
    assert_eq!(param_name(remez(0, &b, &d, &w, FS)), "numtaps");
    assert_eq!(param_name(remez(99, &[], &[], &[], FS)), "bands_hz");
    assert_eq!(param_name(remez(99, &[(0.0, 700.0), (900.0, 9000.0)], &[0.0, 1.0], &[1.0, 1.0], FS)), "bands_hz");
    assert_eq!(param_name(remez(99, &[(0.0, 700.0), (900.0, 800.0)], &[0.0, 1.0], &[1.0, 1.0], FS)), "bands_hz");
    assert_eq!(param_name(remez(99, &[(0.0, 1000.0), (900.0, 1800.0)], &[0.0, 1.0], &[1.0, 1.0], FS)), "bands_hz");
    assert_eq!(param_name(remez(99, &b, &[0.0, 1.0], &w, FS)), "desired");
    assert_eq!(param_name(remez(99, &b, &[0.0, f64::NAN, 0.0], &w, FS)), "desired");
    assert_eq!(param_name(remez(99, &b, &d, &[1.0, 0.0, 1.0], FS)), "weights");
    assert_eq!(param_name(remez(99, &b, &d, &[1.0, 1.0], FS)), "weights");
    assert_eq!(param_name(remez(99, &b, &d, &w, -1.0)), "fs_hz");
    // Even length (type II) cannot have gain at Nyquist.
    assert_eq!(param_name(remez(50, &[(0.0, 3000.0), (4000.0, FS / 2.0)], &[0.0, 1.0], &[1.0, 1.0], FS)), "numtaps");
    assert!(remez(51, &[(0.0, 3000.0), (4000.0, FS / 2.0)], &[0.0, 1.0], &[1.0, 1.0], FS).is_ok());
}

#[test]
fn bad_signals_and_taps_are_rejected() {
    let taps = [0.25, 0.5, 0.25];
    assert!(matches!(filtfilt_fir(&taps, &[]), Err(DspError::TooShort { needed: 10, got: 0, .. })));
    assert!(matches!(filtfilt_fir(&taps, &[1.0; 9]), Err(DspError::TooShort { needed: 10, got: 9, .. })));
    assert!(filtfilt_fir(&taps, &[1.0; 10]).is_ok());
    let mut x = vec![0.5; 100];
    x[42] = f64::NAN;
    assert_eq!(filtfilt_fir(&taps, &x), Err(DspError::NonFinite { index: 42 }));
    x[42] = f64::INFINITY;
    assert_eq!(filtfilt_fir(&taps, &x), Err(DspError::NonFinite { index: 42 }));
    assert_eq!(param_name(filtfilt_fir(&[], &[1.0; 100])), "taps");
    assert_eq!(param_name(filtfilt_fir(&[0.5, f64::NAN], &[1.0; 100])), "taps");

    let spec = BandpassSpec::default();
    assert!(matches!(bandpass_zero_phase(&[], FS, &spec), Err(DspError::TooShort { got: 0, .. })));
    x[42] = f64::NAN;
    assert_eq!(bandpass_zero_phase(&x, FS, &spec).map(|_| ()), Err(DspError::NonFinite { index: 42 }));
    // Shorter than 3 × 215 taps.
    assert!(matches!(bandpass_zero_phase(&[0.0; 600], FS, &spec), Err(DspError::TooShort { needed: 646, got: 600, .. })));

    assert_eq!(param_name(frequency_response_db(&taps, FS, 1)), "n_points");
    assert_eq!(param_name(frequency_response_db(&taps, FS, 0)), "n_points");
    assert_eq!(param_name(frequency_response_db(&[], FS, 100)), "taps");
    assert_eq!(param_name(frequency_response_db(&taps, 0.0, 100)), "fs_hz");
}

#[test]
fn exchange_breakdown_is_reported_as_remez_failed() {
    // Five bands with 3 taps (2 cosine functions): pm-remez's Chebyshev proxy degenerates.
    let bands = [(0.0, 0.05), (0.1, 0.15), (0.2, 0.25), (0.3, 0.35), (0.4, 0.5)];
    match remez(3, &bands, &[0.0, 1.0, 0.0, 1.0, 0.0], &[1.0; 5], 1.0) {
        Err(DspError::RemezFailed { taps, reason }) => {
            assert_eq!(taps, 3);
            assert!(!reason.is_empty());
        }
        other => panic!("expected RemezFailed, got {other:?}"),
    }
}

// ---------------------------------------------------------------- serialisation

#[test]
fn spec_round_trips_through_toml_and_rejects_unknown_fields() {
    let spec = BandpassSpec::default();
    let text = toml::to_string(&spec).unwrap();
    assert_eq!(toml::from_str::<BandpassSpec>(&text).unwrap(), spec);
    let partial: BandpassSpec = toml::from_str("stopband_high_db = 70.0\npass_band_hz = [1000.0, 2000.0]").unwrap();
    assert_eq!(partial, BandpassSpec { stopband_high_db: 70.0, pass_band_hz: [1000.0, 2000.0], ..spec.clone() });
    assert!(toml::from_str::<BandpassSpec>("ripple_db = 1.0").is_err());
    // The design result serialises (for the GUI / reports).
    let d = design_bandpass(&spec, FS).unwrap();
    let j = serde_json::to_value(&d).unwrap();
    assert_eq!(j["numtaps"], 215);
    assert_eq!(j["taps"].as_array().unwrap().len(), 215);
}
