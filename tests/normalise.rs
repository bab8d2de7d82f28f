//! Tests of `dsp::normalise`: analytic properties (max |y| = 1, mean 0, std 1), the exact
//! formula on a small case, and bad input.

use twinscope::dsp::normalise::{normalise, Normalisation, NormaliseParams};
use twinscope::dsp::DspError;

fn mean(y: &[f64]) -> f64 {
    y.iter().sum::<f64>() / y.len() as f64
}
fn std(y: &[f64]) -> f64 {
    let m = mean(y);
    (y.iter().map(|v| (v - m).powi(2)).sum::<f64>() / y.len() as f64).sqrt()
}

/// An offset, asymmetric record: 3 + 2 sin + 0.5 sin(3·).
fn record() -> Vec<f64> {
    (0..5000).map(|i| 3.0 + 2.0 * (i as f64 * 0.0123).sin() + 0.5 * (i as f64 * 0.0369).sin().powi(3)).collect()
}

#[test]
fn peak_default_gives_zero_mean_and_unit_peak() {
    let x = record();
    let y = normalise(&x, &NormaliseParams::default()).unwrap();
    assert_eq!(y.len(), x.len());
    assert!(mean(&y).abs() < 1e-14, "mean {}", mean(&y));
    let peak = y.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    assert!((peak - 1.0).abs() < 1e-15, "peak {peak}");
    // Scaling is linear: the shape is kept (y ∝ x − mean).
    let m = mean(&x);
    let ratio = (x[100] - m) / y[100];
    for (a, b) in x.iter().zip(&y) {
        assert!(((a - m) - ratio * b).abs() < 1e-12);
    }
}

#[test]
fn std_gives_unit_standard_deviation() {
    let x = record();
    let p = NormaliseParams { method: Normalisation::Std, remove_mean: true };
    let y = normalise(&x, &p).unwrap();
    assert!(mean(&y).abs() < 1e-14);
    assert!((std(&y) - 1.0).abs() < 1e-12, "std {}", std(&y));
    // Without mean removal the mean is kept (scaled), the std is still 1.
    let y = normalise(&x, &NormaliseParams { remove_mean: false, ..p }).unwrap();
    assert!((std(&y) - 1.0).abs() < 1e-12);
    assert!((mean(&y) - mean(&x) / std(&x)).abs() < 1e-12);
}

#[test]
fn small_case_matches_the_formula_exactly() {
    // x = [1, 2, 6]: mean 3, x − mean = [−2, −1, 3], peak 3, std = sqrt(14/3).
    let x = [1.0, 2.0, 6.0];
    let y = normalise(&x, &NormaliseParams::default()).unwrap();
    assert_eq!(y, vec![-2.0 / 3.0, -1.0 / 3.0, 1.0]);
    let y = normalise(&x, &NormaliseParams { method: Normalisation::Peak, remove_mean: false }).unwrap();
    assert_eq!(y, vec![1.0 / 6.0, 2.0 / 6.0, 1.0]);
    let s = (14.0_f64 / 3.0).sqrt();
    let y = normalise(&x, &NormaliseParams { method: Normalisation::Std, remove_mean: true }).unwrap();
    for (a, b) in y.iter().zip([-2.0 / s, -1.0 / s, 3.0 / s]) {
        assert!((a - b).abs() < 1e-15);
    }
    let y = normalise(&x, &NormaliseParams { method: Normalisation::None, remove_mean: true }).unwrap();
    assert_eq!(y, vec![-2.0, -1.0, 3.0]);
    let y = normalise(&x, &NormaliseParams { method: Normalisation::None, remove_mean: false }).unwrap();
    assert_eq!(y, x.to_vec());
}

#[test]
fn bad_input_is_refused() {
    let p = NormaliseParams::default();
    assert!(matches!(normalise(&[], &p), Err(DspError::TooShort { got: 0, .. })));
    assert_eq!(normalise(&[1.0, f64::NAN, 2.0], &p), Err(DspError::NonFinite { index: 1 }));
    assert_eq!(normalise(&[1.0, f64::INFINITY], &p), Err(DspError::NonFinite { index: 1 }));
    // Constant records: zero peak after mean removal, zero std — an error, never NaN.
    for method in [Normalisation::Peak, Normalisation::Std] {
        for x in [vec![4.2; 100], vec![0.0; 10], vec![-1.0]] {
            let q = NormaliseParams { method, remove_mean: true };
            match normalise(&x, &q) {
                Err(DspError::InvalidParameter { name, .. }) => assert_eq!(name, "x"),
                other => panic!("{method:?} {x:?}: expected an error, got {other:?}"),
            }
        }
    }
    // A constant non-zero record without mean removal has a peak: it normalises to 1.
    let y = normalise(&[4.2; 10], &NormaliseParams { method: Normalisation::Peak, remove_mean: false }).unwrap();
    assert!(y.iter().all(|&v| v == 1.0));
    // An all-zero record with method None is returned as is.
    assert_eq!(
        normalise(&[0.0; 3], &NormaliseParams { method: Normalisation::None, remove_mean: true }).unwrap(),
        vec![0.0; 3]
    );
}

#[test]
fn params_parse_from_toml_with_defaults_and_refuse_unknown_fields() {
    let p: NormaliseParams = toml::from_str("method = \"std\"").unwrap();
    assert_eq!(p, NormaliseParams { method: Normalisation::Std, remove_mean: true });
    let p: NormaliseParams = toml::from_str("").unwrap();
    assert_eq!(p, NormaliseParams::default());
    assert!(toml::from_str::<NormaliseParams>("methd = \"std\"").is_err());
    assert!(toml::from_str::<NormaliseParams>("method = \"rms\"").is_err());
}
