//! Spectral kurtosis against scipy.signal.stft fixtures (make_kurtogram.py), its analytic
//! values (Gaussian noise 0, a tone −1, real DC and Nyquist bins 1), the kurtogram's band on
//! impacts ringing a resonance, and bad input.

mod common;
use std::f64::consts::PI;
use twinscope::dsp::kurtogram::{kurtogram, kurtogram_frame_lengths, spectral_kurtosis, KurtogramParams, SpectralKurtosisParams};
use twinscope::dsp::{DspError, Window};

const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/kurtogram/");
const FS: f64 = 12000.0;

fn read_column(name: &str) -> Vec<f64> {
    common::read_fixture_column(&format!("{FIX}{name}"))
}

fn noise(n: usize, seed: u64) -> Vec<f64> {
    twinscope::signal::synth::white_noise(n, 1.0, seed)
}

/// Every case of make_kurtogram.py: each bin within 1e-9 of scipy's (the values are of order 1).
#[test]
fn matches_scipy_stft_fixtures() {
    let x = read_column("x.csv");
    assert_eq!(x.len(), 8192);
    let mut n_cases = 0;
    for row in common::read_fixture_table(&format!("{FIX}sk_cases.csv")) {
        let f: Vec<&str> = row.iter().map(String::as_str).collect();
        let nov: i64 = f[3].parse().unwrap();
        let p = SpectralKurtosisParams { window: Window::parse(f[1]).unwrap(), nperseg: f[2].parse().unwrap(), noverlap: (nov >= 0).then_some(nov as usize) };
        let sk = spectral_kurtosis(&x, FS, &p).unwrap();
        let want = read_column(&format!("sk_{}.csv", f[0]));
        assert_eq!(sk.len(), want.len(), "case {}", f[0]);
        assert_eq!(sk.len(), p.nperseg / 2 + 1);
        for (k, (a, b)) in sk.values.iter().zip(&want).enumerate() {
            assert!((a - b).abs() <= 1e-9, "case {} bin {k}: {a} against scipy's {b}", f[0]);
        }
        assert!((sk.frequency_hz[1] - FS / p.nperseg as f64).abs() < 1e-9);
        n_cases += 1;
    }
    assert_eq!(n_cases, 4);
}

/// Stationary Gaussian noise: 0 between DC and Nyquist (within 4 scatter widths of the
/// estimate, 2/√frames each), 1 at the real DC and Nyquist bins; a steady tone: −1 at its bin.
#[test]
fn gaussian_noise_reads_zero_and_a_tone_minus_one() {
    let x = noise(200_000, 3);
    let p = SpectralKurtosisParams { nperseg: 128, ..Default::default() };
    let frames = p.frames(x.len());
    assert_eq!(frames, (200_000 - 128) / 32 + 1);
    let sk = spectral_kurtosis(&x, FS, &p).unwrap();
    // Overlapping frames are not independent: allow twice the scatter of independent ones.
    let tol = 4.0 * 2.0 * 2.0 / (frames as f64 / 4.0).sqrt();
    for (k, v) in sk.values.iter().enumerate().take(64).skip(1) {
        assert!(v.abs() < tol, "bin {k}: {v} (tolerance {tol:.3})");
    }
    assert!((sk.values[0] - 1.0).abs() < 2.0 * tol && (sk.values[64] - 1.0).abs() < 2.0 * tol, "DC {} Nyquist {}", sk.values[0], sk.values[64]);
    let tone: Vec<f64> = (0..20_000).map(|i| 2.0 * (2.0 * PI * 1234.5 * i as f64 / FS + 0.4).cos()).collect();
    let sk = spectral_kurtosis(&tone, FS, &p).unwrap();
    let k = (1234.5 / (FS / 128.0)).round() as usize;
    assert!((sk.values[k] + 1.0).abs() < 1e-9, "the tone's bin {k}: {}", sk.values[k]);
}

/// Impacts at a bearing-fault rate ringing a 3 kHz resonance, in noise and under a stronger
/// tone at 440 Hz: the kurtogram's band holds 3 kHz and is as wide as asked, the tone's band
/// reads about −1, and a search band that leaves the resonance out finds a weaker band.
#[test]
fn the_kurtogram_finds_the_band_of_the_ringing_impacts() {
    use twinscope::signal::synth::{impact_train, tone, white_noise, ImpactTrain};
    let (n, fr) = (120_000, 3000.0);
    let impacts = impact_train(n, FS, &ImpactTrain { fault_frequency_hz: 107.3, resonance_hz: fr, damping_ratio: 0.05, jitter_fraction: 0.0, modulation_depth: 0.0, modulation_hz: 0.0, amplitude: 2.0 }, 11);
    let (noise, hum) = (white_noise(n, 0.3, 12), tone(n, FS, 440.0, 3.0, 0.0));
    let x: Vec<f64> = impacts.iter().zip(&noise).zip(&hum).map(|((a, w), h)| a + w + h).collect();
    let p = KurtogramParams { min_band_width_hz: 400.0, ..Default::default() };
    let k = kurtogram(&x, FS, &p).unwrap();
    assert_eq!(k.levels.iter().map(|l| l.nperseg).collect::<Vec<_>>(), kurtogram_frame_lengths(16, 1024));
    let [lo, hi] = k.best.band_hz;
    assert!(lo < fr && fr < hi && hi - lo >= 400.0, "best band {lo:.0}–{hi:.0} Hz, SK {:.2}", k.best.sk);
    assert!(k.best.sk > 1.0, "{:?}", k.best);
    // The tone's band at a fine resolution reads about −1: it is steady, not impulsive.
    let fine = k.levels.iter().find(|l| l.nperseg == 512).unwrap();
    let bin = (440.0 / (FS / 512.0)).round() as usize;
    assert!((fine.sk.values[bin] + 1.0).abs() < 0.1, "440 Hz at 512 samples: {}", fine.sk.values[bin]);
    // Below 2 kHz the best band is far weaker.
    let low = kurtogram(&x, FS, &KurtogramParams { search_band_hz: Some([0.0, 2000.0]), ..p.clone() }).unwrap();
    assert!(low.best.band_hz[1] <= 2000.0 && low.best.sk < 0.2 * k.best.sk, "{:?} against {:?}", low.best, k.best);
    assert_eq!(k.sk_within([2800.0, 3200.0], FS, &p), Some(k.best.sk));
    let ranked = k.ranked_bands(FS, &p);
    assert_eq!(ranked[0], k.best);
    assert!(ranked.windows(2).all(|w| w[0].sk >= w[1].sk));
}

#[test]
fn frame_lengths_are_half_an_octave_apart_and_even() {
    assert_eq!(kurtogram_frame_lengths(16, 128), vec![16, 22, 32, 46, 64, 90, 128]);
    assert_eq!(kurtogram_frame_lengths(16, 16), vec![16]);
}

/// Bad parameters and input: an error naming what is wrong, never a panic.
#[test]
fn bad_input_is_refused_with_the_reason() {
    let x = noise(4096, 5);
    fn named<T>(r: Result<T, DspError>, name: &str) {
        let e = r.err().unwrap_or_else(|| panic!("{name}: accepted"));
        assert!(e.to_string().contains(name), "{name} not in {e}");
    }
    named(spectral_kurtosis(&x, FS, &SpectralKurtosisParams { nperseg: 2, ..Default::default() }), "nperseg");
    named(spectral_kurtosis(&x, FS, &SpectralKurtosisParams { nperseg: 64, noverlap: Some(64), ..Default::default() }), "noverlap");
    named(spectral_kurtosis(&x[..70], FS, &SpectralKurtosisParams { nperseg: 64, ..Default::default() }), "two frames");
    named(spectral_kurtosis(&x, -1.0, &SpectralKurtosisParams::default()), "fs");
    let mut bad = x.clone();
    bad[7] = f64::NAN;
    named(spectral_kurtosis(&bad, FS, &SpectralKurtosisParams::default()), "sample 7");
    named(kurtogram(&x, FS, &KurtogramParams { min_nperseg: 2, ..Default::default() }), "min_nperseg");
    named(kurtogram(&x, FS, &KurtogramParams { min_band_width_hz: -1.0, ..Default::default() }), "min_band_width_hz");
    named(kurtogram(&x, FS, &KurtogramParams { min_band_width_hz: 5000.0, ..Default::default() }), "min_band_width_hz");
    named(kurtogram(&x, FS, &KurtogramParams { search_band_hz: Some([100.0, 7000.0]), ..Default::default() }), "search_band_hz");
    named(kurtogram(&x[..100], FS, &KurtogramParams::default()), "kurtogram level");
}
