//! Resampling by the Fourier method against scipy.signal.resample fixtures (make_resample.py):
//! down and up, integer and non-integer ratios, odd and even lengths; and what the comparison
//! relies on: a measurement brought down to a model's rate keeps what lies below the new
//! Nyquist frequency and drops what lies above it.

mod common;
use twinscope::dsp::resample::resample;

const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/resample/");

fn read_column(name: &str) -> Vec<f64> {
    common::read_fixture_column(&format!("{FIX}{name}"))
}

/// Every case: each sample within 1e-10 of scipy's (the values are of order 1).
#[test]
fn matches_scipy_resample_fixtures() {
    let x = read_column("x.csv");
    assert_eq!(x.len(), 4801);
    let rows: Vec<Vec<f64>> = common::read_fixture_table(&format!("{FIX}cases.csv")).into_iter().map(|r| r.iter().map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 7);
    for row in rows {
        let [id, n_in, fs_in, fs_out, n_out] = row[..] else { panic!("{row:?}") };
        let y = resample(&x[..n_in as usize], fs_in, fs_out).unwrap();
        let want = read_column(&format!("y_{id}.csv"));
        assert_eq!((y.len(), want.len()), (n_out as usize, n_out as usize), "case {id}");
        for (k, (a, b)) in y.iter().zip(&want).enumerate() {
            assert!((a - b).abs() <= 1e-10, "case {id} sample {k}: {a} against scipy's {b}");
        }
    }
}

/// 48 kHz → 12 kHz (the CWRU healthy record brought to the models' rate): the 1 kHz tone keeps
/// its amplitude, the 15 kHz one is gone (an ideal anti-alias filter, nothing folded to 3 kHz).
#[test]
fn a_tone_above_the_new_nyquist_frequency_is_removed_not_folded() {
    let (fs, n) = (48000.0, 48000);
    let x: Vec<f64> = (0..n).map(|i| (2.0 * std::f64::consts::PI * 1000.0 * i as f64 / fs).sin() + 0.5 * (2.0 * std::f64::consts::PI * 15000.0 * i as f64 / fs).sin()).collect();
    let y = resample(&x, fs, 12000.0).unwrap();
    assert_eq!(y.len(), 12000);
    let amp = |f: f64| {
        let (re, im) = y.iter().enumerate().fold((0.0, 0.0), |(re, im), (i, v)| {
            let ph = 2.0 * std::f64::consts::PI * f * i as f64 / 12000.0;
            (re + v * ph.cos(), im + v * ph.sin())
        });
        2.0 * (re * re + im * im).sqrt() / y.len() as f64
    };
    assert!((amp(1000.0) - 1.0).abs() < 1e-9, "1 kHz at {}", amp(1000.0));
    // 15 kHz would fold to 3 kHz at 12 kHz.
    assert!(amp(3000.0) < 1e-9, "3 kHz (15 kHz folded) at {}", amp(3000.0));
}
