//! Tests of `twinscope::dsp::scf`: numpy fixture of the averaged cyclic periodogram, analytic
//! cyclostationary signals, Fast-SC vs reference agreement, physical meaning, bad input.

use num_complex::Complex64;
use std::f64::consts::PI;
use twinscope::dsp::scf::{cyclic_periodogram, fast_scf, scf, ScfMap, ScfMethod, ScfParams};
use twinscope::dsp::{DspError, Window};

// ---------------------------------------------------------------- helpers

/// SplitMix64 + Box–Muller: a small, seeded Gaussian generator (no extra dependency).
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
    }
    fn normals(&mut self, n: usize, sigma: f64) -> Vec<f64> {
        (0..n).map(|_| sigma * self.normal()).collect()
    }
}

fn params(alpha_max_hz: f64, nperseg: usize, method: ScfMethod) -> ScfParams {
    ScfParams {
        alpha_min_hz: 0.0,
        alpha_max_hz,
        nperseg,
        noverlap: None,
        window: Window::Hann,
        method,
    }
}

/// Mean over f of |γ(α_ia, f)|.
fn mean_coherence_row(map: &ScfMap, ia: usize) -> f64 {
    let nf = map.n_frequency();
    map.coherence[ia * nf..(ia + 1) * nf].iter().sum::<f64>() / nf as f64
}

/// Index of the maximum of `v[range]`.
fn argmax_in(v: &[f64], lo: usize, hi: usize) -> usize {
    (lo..hi).fold(lo, |b, i| if v[i] > v[b] { i } else { b })
}

/// Hann window statistics: K_eff = K / (1 + 2 Σ_l (1 − l/K) ρ(lR)), ρ(s) = (Σ w w_s)² / (Σ w²)²
/// (Welch 1967): the effective number of independent averages.
fn effective_averages(nperseg: usize, hop: usize, k: usize) -> f64 {
    let w = Window::Hann.periodic(nperseg);
    let w2: f64 = w.iter().map(|v| v * v).sum();
    let mut denom = 1.0;
    let mut l = 1;
    while l * hop < nperseg && l < k {
        let s = l * hop;
        let c: f64 = (0..nperseg - s).map(|i| w[i] * w[i + s]).sum::<f64>() / w2;
        denom += 2.0 * (1.0 - l as f64 / k as f64) * c * c;
        l += 1;
    }
    k as f64 / denom
}

// ---------------------------------------------------------------- fixture (numpy ACP)

#[derive(serde::Deserialize)]
struct Fixture {
    fs_hz: f64,
    nperseg: usize,
    noverlap: usize,
    alpha_min_hz: f64,
    alpha_max_hz: f64,
    n_segments: usize,
    x: Vec<f64>,
    alpha_hz: Vec<f64>,
    frequency_hz: Vec<f64>,
    scf_re: Vec<f64>,
    scf_im: Vec<f64>,
    coherence: Vec<f64>,
    welch_two_sided_psd: Vec<f64>,
}

fn load_fixture() -> Fixture {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/scf/acp_fixture.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).expect("fixture readable"))
        .expect("fixture parses")
}

fn fixture_params(fx: &Fixture, method: ScfMethod) -> ScfParams {
    ScfParams {
        alpha_min_hz: fx.alpha_min_hz,
        alpha_max_hz: fx.alpha_max_hz,
        nperseg: fx.nperseg,
        noverlap: Some(fx.noverlap),
        window: Window::Hann,
        method,
    }
}

/// The ACP equals an independent vectorised numpy ACP (both frequency shifts computed, whole
/// signal modulated) to 1e-9 relative; S(0, f) equals scipy's two-sided Welch PSD.
#[test]
fn cyclic_periodogram_matches_numpy_fixture() {
    let fx = load_fixture();
    let map = cyclic_periodogram(
        &fx.x,
        fx.fs_hz,
        &fixture_params(&fx, ScfMethod::CyclicPeriodogram),
    )
    .unwrap();
    assert_eq!(map.n_segments, fx.n_segments);
    assert_eq!(map.alpha_hz.len(), fx.alpha_hz.len());
    assert_eq!(map.frequency_hz.len(), fx.frequency_hz.len());
    for (a, b) in map.alpha_hz.iter().zip(&fx.alpha_hz) {
        assert!((a - b).abs() < 1e-12, "alpha grid {a} vs {b}");
    }
    for (a, b) in map.frequency_hz.iter().zip(&fx.frequency_hz) {
        assert!((a - b).abs() < 1e-12);
    }
    let want: Vec<Complex64> = fx
        .scf_re
        .iter()
        .zip(&fx.scf_im)
        .map(|(&r, &i)| Complex64::new(r, i))
        .collect();
    let smax = want.iter().map(|c| c.norm()).fold(0.0, f64::max);
    let mut worst_rel: f64 = 0.0;
    for (got, w) in map.scf.iter().zip(&want) {
        assert!(
            (got - w).norm() <= 1e-9 * smax,
            "abs error {} vs max {smax}",
            (got - w).norm()
        );
        if w.norm() > 1e-3 * smax {
            worst_rel = worst_rel.max((got - w).norm() / w.norm());
        }
    }
    assert!(worst_rel <= 1e-9, "worst relative error {worst_rel:e}");
    for (g, w) in map.coherence.iter().zip(&fx.coherence) {
        assert!((g - w).abs() <= 1e-9, "coherence {g} vs {w}");
    }
    for (j, w) in fx.welch_two_sided_psd.iter().enumerate() {
        let s0 = map.get(0, j).unwrap();
        assert!(
            (s0.re - w).abs() <= 1e-9 * w.abs() && s0.im.abs() <= 1e-12 * w.abs(),
            "PSD bin {j}: {s0} vs {w}"
        );
    }
}

// ---------------------------------------------------------------- analytic cases

/// Stationary white noise: S(0, f) = σ²/fs (two-sided PSD), ∫ S(0, f) df over ±fs/2 = σ², and
/// |γ(α ≠ 0, f)|² behaves as an exponential with mean 1/K_eff (Welch's effective number of
/// averages), so max |γ|² over M cells stays below ln(1000·M)/K_eff (failure probability ≤ 1e-3
/// for independent cells); twice that at f = 0 and fs/2.
#[test]
fn white_noise_psd_and_incoherence() {
    let fs = 4096.0;
    let sigma = 2.0;
    let x = Rng(7).normals(32768, sigma);
    for method in [ScfMethod::CyclicPeriodogram, ScfMethod::Fast] {
        let map = scf(&x, fs, &params(200.0, 256, method)).unwrap();
        assert_eq!(map.method, method);
        let nf = map.n_frequency();
        let (_, psd) = map.alpha_slice(0.0).unwrap();
        let mean_psd = psd.iter().sum::<f64>() / nf as f64;
        let want = sigma * sigma / fs;
        assert!(
            (mean_psd / want - 1.0).abs() < 0.03,
            "{method:?}: mean S(0,f) = {mean_psd}, want {want}"
        );
        // Two-sided integral: 2 × one-sided trapezoid (EES at α = 0) = mean square.
        let (_, ees) = map.enhanced_envelope_spectrum();
        let ms = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
        assert!(
            (2.0 * ees[0] / ms - 1.0).abs() < 0.02,
            "{method:?}: ∫PSD = {}, rms² = {ms}",
            2.0 * ees[0]
        );
        // Coherence at α = 0 is 1 by definition.
        assert!(map.coherence[..nf].iter().all(|g| (g - 1.0).abs() < 1e-9));
        // Interior cells: |γ|² ≈ Exp(mean 1/K_eff). Edge columns f = 0 and fs/2: f ± α/2 are
        // mirror bins, the product is Y(ν)², improper, and the variance doubles (mean 2/K_eff).
        let k_eff = effective_averages(256, 64, map.n_segments);
        let (mut interior, mut edge) = (Vec::new(), Vec::new());
        for ia in 1..map.n_alpha() {
            for jf in 0..nf {
                let g2 = map.coherence_at(ia, jf).unwrap().powi(2);
                if jf == 0 || jf == nf - 1 {
                    edge.push(g2)
                } else {
                    interior.push(g2)
                }
            }
        }
        for (what, cells, scale) in [("interior", &interior, 1.0), ("edge", &edge, 2.0)] {
            let m = cells.len() as f64;
            let max_g2 = cells.iter().fold(0.0f64, |a, &b| a.max(b));
            let bound = scale * (1000.0 * m).ln() / k_eff;
            assert!(
                max_g2 < bound,
                "{method:?} {what}: max |γ|² = {max_g2}, bound {bound}"
            );
            let mean_g2 = cells.iter().sum::<f64>() / m;
            assert!(
                mean_g2 > 0.8 * scale / k_eff && mean_g2 < 1.25 * scale / k_eff,
                "{method:?} {what}: mean |γ|² = {mean_g2}, expected {}",
                scale / k_eff
            );
        }
    }
}

/// AM white noise x = (1 + m cos 2πα0 t) n(t): R_x(α0) = σ² m, R_x(0) = σ²(1 + m²/2),
/// R_x(2α0) = σ² m²/4, hence S(α0, f) = σ² m / fs and |γ(α0)| = m/(1 + m²/2) = 2/3 for m = 1,
/// |γ(2α0)| = (m²/4)/(1 + m²/2) = 1/6, and γ ≈ 0 elsewhere. Tolerances: f-averaged |S(α0)|
/// within 8 % (its spread over seeds is ≈ 2 %), f-averaged |γ| within 0.04 (includes the
/// positive bias of |γ̂| ≈ 1/(2|γ|K_eff)).
#[test]
fn am_noise_coherence_peak_at_modulation_frequency() {
    let fs = 4096.0;
    let (alpha0, depth, sigma) = (37.0, 1.0, 1.5);
    let n = 32768;
    let noise = Rng(11).normals(n, sigma);
    let x: Vec<f64> = noise
        .iter()
        .enumerate()
        .map(|(i, v)| (1.0 + depth * (2.0 * PI * alpha0 * i as f64 / fs).cos()) * v)
        .collect();
    for method in [ScfMethod::CyclicPeriodogram, ScfMethod::Fast] {
        let map = scf(&x, fs, &params(200.0, 256, method)).unwrap();
        assert!((map.alpha_resolution_hz - 0.125).abs() < 1e-12);
        let ia0 = map.alpha_index(alpha0).unwrap();
        assert!((map.alpha_hz[ia0] - alpha0).abs() < 1e-9);
        let g0 = mean_coherence_row(&map, ia0);
        assert!(
            (g0 - 2.0 / 3.0).abs() < 0.04,
            "{method:?}: mean |γ(α0)| = {g0}, theory 2/3"
        );
        let ia2 = map.alpha_index(2.0 * alpha0).unwrap();
        let g2 = mean_coherence_row(&map, ia2);
        assert!(
            (g2 - 1.0 / 6.0).abs() < 0.04,
            "{method:?}: mean |γ(2α0)| = {g2}, theory 1/6"
        );
        let (_, s_slice) = map.alpha_slice(alpha0).unwrap();
        let mean_s = s_slice.iter().sum::<f64>() / s_slice.len() as f64;
        let want = sigma * sigma * depth / fs;
        assert!(
            (mean_s / want - 1.0).abs() < 0.08,
            "{method:?}: mean |S(α0,f)| = {mean_s}, theory {want}"
        );
        // Peak at α0 and nowhere else (outside 0, α0, 2α0).
        let (alpha, ees_g) = map.enhanced_envelope_spectrum_coherence();
        let lo = map.alpha_index(1.0).unwrap();
        assert_eq!(argmax_in(&ees_g, lo, alpha.len()), ia0, "{method:?}");
        for (ia, &a) in alpha.iter().enumerate().skip(lo) {
            if (a - alpha0).abs() > 0.2 && (a - 2.0 * alpha0).abs() > 0.2 {
                assert!(
                    ees_g[ia] < 0.1,
                    "{method:?}: mean |γ| = {} at α = {a}",
                    ees_g[ia]
                );
            }
        }
    }
}

/// Tones at 400, 496, 560 Hz (on bins of Δf = 16 Hz): S(α, f) is non-zero at the difference
/// frequencies α = 64, 96, 160 Hz, at f = the tones' midpoints, with
/// |S| = (A_a A_b / 4) (Σw)² / (fs Σw²) and |γ| = 1; S(0, f_a) gives back A_a.
#[test]
fn tones_correlate_at_difference_frequencies() {
    let fs = 4096.0;
    let tones = [(400.0, 1.0, 0.3), (496.0, 0.7, -1.1), (560.0, 0.5, 2.0)];
    let x: Vec<f64> = (0..32768)
        .map(|i| {
            let t = i as f64 / fs;
            tones
                .iter()
                .map(|&(f, a, ph)| a * (2.0 * PI * f * t + ph).cos())
                .sum()
        })
        .collect();
    let w = Window::Hann.periodic(256);
    let gain = w.iter().sum::<f64>().powi(2) / (fs * w.iter().map(|v| v * v).sum::<f64>());
    for method in [ScfMethod::CyclicPeriodogram, ScfMethod::Fast] {
        let map = scf(&x, fs, &params(200.0, 256, method)).unwrap();
        // Physical meaning: tone amplitude from the PSD peak.
        for &(f, a, _) in &tones {
            let s0 = map.get(0, map.frequency_index(f).unwrap()).unwrap().re;
            assert!(
                ((4.0 * s0 / gain).sqrt() - a).abs() < 1e-9 * a,
                "{method:?}: amplitude at {f} Hz"
            );
        }
        let pairs = [(0usize, 1usize), (1, 2), (0, 2)];
        let mut want_alpha = Vec::new();
        for &(p, q) in &pairs {
            let (fa, aa, _) = tones[p];
            let (fb, ab, _) = tones[q];
            let ia = map.alpha_index(fb - fa).unwrap();
            let jf = map.frequency_index(0.5 * (fa + fb)).unwrap();
            let s = map.get(ia, jf).unwrap().norm();
            let want = aa * ab / 4.0 * gain;
            assert!(
                (s / want - 1.0).abs() < 1e-9,
                "{method:?}: |S({}, {})| = {s}, want {want}",
                fb - fa,
                0.5 * (fa + fb)
            );
            assert!(
                (map.coherence_at(ia, jf).unwrap() - 1.0).abs() < 1e-9,
                "{method:?}: |γ| at the pair"
            );
            want_alpha.push(ia);
        }
        // The three largest rows (α > 1 Hz, by max_f |S|) are exactly the difference frequencies.
        let nf = map.n_frequency();
        let row_max: Vec<f64> = map
            .scf
            .chunks(nf)
            .map(|r| r.iter().map(|c| c.norm()).fold(0.0, f64::max))
            .collect();
        let lo = map.alpha_index(1.0).unwrap();
        let mut order: Vec<usize> = (lo..map.n_alpha()).collect();
        order.sort_by(|&a, &b| row_max[b].total_cmp(&row_max[a]));
        let mut top: Vec<usize> = order[..3].to_vec();
        top.sort();
        want_alpha.sort();
        assert_eq!(top, want_alpha, "{method:?}");
        assert!(
            row_max[order[3]] < 0.02 * row_max[order[2]],
            "{method:?}: 4th row {}",
            row_max[order[3]]
        );
    }
}

/// Bearing-like signal: impulses at 107 Hz with random amplitudes, ringing a 1.8 kHz resonance,
/// plus white noise; the enhanced envelope spectrum peaks at 107 Hz and shows its harmonics.
fn bearing_signal(fs: f64, n: usize, fault_hz: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng(seed);
    let (fr, zeta) = (1800.0, 0.05);
    let h: Vec<f64> = (0..(0.02 * fs) as usize)
        .map(|i| {
            let t = i as f64 / fs;
            (-zeta * 2.0 * PI * fr * t).exp()
                * (2.0 * PI * fr * (1.0 - zeta * zeta).sqrt() * t).sin()
        })
        .collect();
    let mut x = rng.normals(n, 0.2);
    let mut i = 0;
    loop {
        let pos = (i as f64 * fs / fault_hz).round() as usize;
        if pos >= n {
            break;
        }
        let amp = 1.0 + 0.5 * rng.normal();
        for (l, &hv) in h.iter().enumerate() {
            if pos + l < n {
                x[pos + l] += amp * hv;
            }
        }
        i += 1;
    }
    x
}

#[test]
fn bearing_signal_enhanced_envelope_spectrum_peaks_at_fault_frequency() {
    let fs = 8192.0;
    let fault = 107.0;
    let x = bearing_signal(fs, 8 * 8192, fault, 3);
    let map = fast_scf(&x, fs, &params(400.0, 256, ScfMethod::Fast)).unwrap();
    for (name, (alpha, ees)) in [
        ("EES |S|", map.enhanced_envelope_spectrum()),
        ("EES |γ|", map.enhanced_envelope_spectrum_coherence()),
        (
            "EES band",
            map.enhanced_envelope_spectrum_in_band(1000.0, 2600.0)
                .unwrap(),
        ),
    ] {
        let lo = map.alpha_index(5.0).unwrap();
        let ipk = argmax_in(&ees, lo, alpha.len());
        assert!(
            (alpha[ipk] - fault).abs() <= map.alpha_resolution_hz + 1e-9,
            "{name}: peak at {} Hz",
            alpha[ipk]
        );
        let mut sorted = ees[lo..].to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        for h in 1..=3 {
            let c = map.alpha_index(h as f64 * fault).unwrap();
            let local = argmax_in(&ees, c - 8, c + 9);
            assert!(
                (alpha[local] - h as f64 * fault).abs() <= map.alpha_resolution_hz + 1e-9,
                "{name}: harmonic {h} at {}",
                alpha[local]
            );
            assert!(
                ees[local] > 5.0 * median,
                "{name}: harmonic {h}: {} vs median {median}",
                ees[local]
            );
        }
    }
}

// ---------------------------------------------------------------- Fast-SC vs reference

/// Fast-SC agrees with the averaged cyclic periodogram on AM noise (37 Hz) + a bearing-like
/// signal (107 Hz): exact (1e-9) on the coarse-shift rows (δ = 0), relative error of |S| ≤ 3 %
/// (0.5 % on average) where |S| ≥ 20 % of the largest |S| at α ≥ 1 Hz, Frobenius error ≤ 2 %,
/// EES within 2 %, and the same EES peaks (measured: 1.1 %, 0.13 %, 0.46 %, 0.42 %).
#[test]
fn fast_scf_agrees_with_cyclic_periodogram() {
    let fs = 4096.0;
    let n = 32768;
    let noise = Rng(5).normals(n, 1.0);
    let bearing = bearing_signal(fs, n, 107.0, 9);
    let x: Vec<f64> = (0..n)
        .map(|i| (1.0 + 0.8 * (2.0 * PI * 37.0 * i as f64 / fs).cos()) * noise[i] + bearing[i])
        .collect();
    let p = params(250.0, 256, ScfMethod::Fast);
    let fast = fast_scf(&x, fs, &p).unwrap();
    let slow = cyclic_periodogram(&x, fs, &p).unwrap();
    assert_eq!(fast.alpha_hz, slow.alpha_hz);
    assert_eq!(fast.frequency_hz, slow.frequency_hz);
    let nf = fast.n_frequency();
    let coarse = 2.0 * fs / (4.0 * 256.0);
    let lo = slow.alpha_index(1.0).unwrap();
    let smax = slow.scf[lo * nf..]
        .iter()
        .map(|c| c.norm())
        .fold(0.0, f64::max);
    let (mut worst, mut sum_rel, mut count) = (0.0f64, 0.0, 0usize);
    let (mut err2, mut ref2) = (0.0, 0.0);
    for ia in 0..fast.n_alpha() {
        let on_coarse =
            ((fast.alpha_hz[ia] / coarse).round() * coarse - fast.alpha_hz[ia]).abs() < 1e-9;
        for jf in 0..nf {
            let (a, b) = (fast.get(ia, jf).unwrap(), slow.get(ia, jf).unwrap());
            err2 += (a - b).norm_sqr();
            ref2 += b.norm_sqr();
            if on_coarse {
                assert!(
                    (a - b).norm() <= 1e-9 * b.norm().max(1e-3 * smax),
                    "coarse row α = {}",
                    fast.alpha_hz[ia]
                );
            }
            if ia >= lo && b.norm() >= 0.2 * smax {
                let rel = (a.norm() - b.norm()).abs() / b.norm();
                worst = worst.max(rel);
                sum_rel += rel;
                count += 1;
            }
        }
    }
    let frob = (err2 / ref2).sqrt();
    let mean_rel = sum_rel / count as f64;
    assert!(count > 50, "too few significant cells: {count}");
    assert!(
        worst <= 0.03 && mean_rel <= 0.005,
        "worst {worst}, mean {mean_rel} over {count} cells"
    );
    assert!(frob <= 0.02, "Frobenius relative error {frob}");
    for (ees_f, ees_s) in [
        (
            fast.enhanced_envelope_spectrum().1,
            slow.enhanced_envelope_spectrum().1,
        ),
        (
            fast.enhanced_envelope_spectrum_coherence().1,
            slow.enhanced_envelope_spectrum_coherence().1,
        ),
    ] {
        let lo5 = slow.alpha_index(5.0).unwrap();
        assert_eq!(
            argmax_in(&ees_f, lo5, ees_f.len()),
            argmax_in(&ees_s, lo5, ees_s.len())
        );
        for target in [37.0, 107.0, 214.0] {
            let c = slow.alpha_index(target).unwrap();
            assert_eq!(
                argmax_in(&ees_f, c - 8, c + 9),
                argmax_in(&ees_s, c - 8, c + 9),
                "peak near {target} Hz"
            );
        }
        let e = ees_f
            .iter()
            .zip(&ees_s)
            .map(|(a, b)| (a - b).abs() / b.abs())
            .fold(0.0, f64::max);
        assert!(e < 0.02, "EES relative difference {e}");
    }
}

/// Same agreement with an odd segment length, a Hamming window, a non-default overlap and
/// α_min > 0: the grids coincide, coarse-shift rows agree to 1e-9, Frobenius error ≤ 2 %.
#[test]
fn fast_scf_agrees_with_reference_for_odd_nperseg_and_hamming() {
    let fs = 2000.0;
    let n = 12000;
    let noise = Rng(21).normals(n, 1.0);
    let x: Vec<f64> = (0..n)
        .map(|i| (1.0 + 0.6 * (2.0 * PI * 23.0 * i as f64 / fs).cos()) * noise[i])
        .collect();
    let p = ScfParams {
        alpha_min_hz: 5.0,
        alpha_max_hz: 120.0,
        nperseg: 99,
        noverlap: Some(66),
        window: Window::Hamming,
        method: ScfMethod::Fast,
    };
    let fast = fast_scf(&x, fs, &p).unwrap();
    let slow = cyclic_periodogram(&x, fs, &p).unwrap();
    assert_eq!(fast.alpha_hz, slow.alpha_hz);
    assert_eq!(fast.frequency_hz.len(), 50);
    assert!(fast.alpha_hz[0] >= 5.0 && *fast.alpha_hz.last().unwrap() <= 120.0);
    let coarse = 2.0 * fs / (4.0 * 99.0);
    let (mut err2, mut ref2, mut coarse_rows) = (0.0, 0.0, 0);
    for ia in 0..fast.n_alpha() {
        let on_coarse =
            ((fast.alpha_hz[ia] / coarse).round() * coarse - fast.alpha_hz[ia]).abs() < 1e-9;
        coarse_rows += on_coarse as usize;
        for jf in 0..fast.n_frequency() {
            let (a, b) = (fast.get(ia, jf).unwrap(), slow.get(ia, jf).unwrap());
            err2 += (a - b).norm_sqr();
            ref2 += b.norm_sqr();
            if on_coarse {
                assert!(
                    (a - b).norm() <= 1e-9 * b.norm().max(1e-12),
                    "coarse row α = {}",
                    fast.alpha_hz[ia]
                );
            }
        }
    }
    assert!(coarse_rows >= 1);
    let frob = (err2 / ref2).sqrt();
    assert!(frob <= 0.02, "Frobenius relative error {frob}");
    let ia = slow.alpha_index(23.0).unwrap();
    let lo = slow.alpha_index(10.0).unwrap();
    let (_, eg) = fast.enhanced_envelope_spectrum_coherence();
    assert_eq!(argmax_in(&eg, lo, eg.len()), ia);
}

// ---------------------------------------------------------------- slices and serialisation

#[test]
fn slices_and_serialisation() {
    let fs = 1024.0;
    let x = Rng(1).normals(4096, 1.0);
    let map = fast_scf(
        &x,
        fs,
        &ScfParams {
            alpha_min_hz: 10.0,
            alpha_max_hz: 20.0,
            nperseg: 64,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(map.alpha_hz[0] >= 10.0 && *map.alpha_hz.last().unwrap() <= 20.0);
    let (f, s) = map.alpha_slice(15.0).unwrap();
    assert_eq!(f.len(), 33);
    let ia = map.alpha_index(15.0).unwrap();
    assert_eq!(s[5], map.get(ia, 5).unwrap().norm());
    let (a, s) = map.frequency_slice(100.0).unwrap();
    assert_eq!(a, map.alpha_hz);
    assert_eq!(
        s[3],
        map.get(3, map.frequency_index(100.0).unwrap())
            .unwrap()
            .norm()
    );
    assert_eq!(map.get(map.n_alpha(), 0), None);
    assert_eq!(map.magnitude().len(), map.n_alpha() * 33);
    let json = serde_json::to_value(&map).unwrap();
    assert_eq!(json["scf"][0][0].as_f64().unwrap(), map.scf[0].re);
    assert_eq!(json["scf"][0][1].as_f64().unwrap(), map.scf[0].im);
}

// ---------------------------------------------------------------- bad input

fn param_name(e: &DspError) -> &'static str {
    match e {
        DspError::InvalidParameter { name, .. } | DspError::BandOutOfRange { name, .. } => name,
        DspError::TooShort { .. } => "<too short>",
        DspError::NonFinite { .. } => "<non-finite>",
        _ => "<other>",
    }
}

#[test]
fn bad_input_is_rejected_with_the_parameter_named() {
    let fs = 1000.0;
    let x = Rng(2).normals(2000, 1.0);
    let ok = ScfParams {
        alpha_max_hz: 100.0,
        nperseg: 64,
        ..Default::default()
    };
    let mut nan = x.clone();
    nan[17] = f64::NAN;
    let cases: Vec<(&str, Vec<f64>, f64, ScfParams, &str)> = vec![
        (
            "alpha above Nyquist",
            x.clone(),
            fs,
            ScfParams {
                alpha_max_hz: 600.0,
                ..ok.clone()
            },
            "alpha_max_hz",
        ),
        (
            "alpha_max NaN",
            x.clone(),
            fs,
            ScfParams {
                alpha_max_hz: f64::NAN,
                ..ok.clone()
            },
            "alpha_max_hz",
        ),
        (
            "alpha_max ≤ alpha_min",
            x.clone(),
            fs,
            ScfParams {
                alpha_min_hz: 50.0,
                alpha_max_hz: 40.0,
                ..ok.clone()
            },
            "alpha_max_hz",
        ),
        (
            "alpha_min negative",
            x.clone(),
            fs,
            ScfParams {
                alpha_min_hz: -1.0,
                ..ok.clone()
            },
            "alpha_min_hz",
        ),
        (
            "empty α grid",
            x.clone(),
            fs,
            ScfParams {
                alpha_min_hz: 10.01,
                alpha_max_hz: 10.02,
                ..ok.clone()
            },
            "alpha_max_hz",
        ),
        ("empty x", vec![], fs, ok.clone(), "<too short>"),
        ("NaN in x", nan, fs, ok.clone(), "<non-finite>"),
        ("nperseg > n", x[..50].to_vec(), fs, ok.clone(), "nperseg"),
        (
            "nperseg too small",
            x.clone(),
            fs,
            ScfParams {
                nperseg: 2,
                noverlap: Some(0),
                ..ok.clone()
            },
            "nperseg",
        ),
        (
            "noverlap = nperseg",
            x.clone(),
            fs,
            ScfParams {
                noverlap: Some(64),
                ..ok.clone()
            },
            "noverlap",
        ),
        (
            "noverlap > nperseg",
            x.clone(),
            fs,
            ScfParams {
                noverlap: Some(100),
                ..ok.clone()
            },
            "noverlap",
        ),
        ("fs zero", x.clone(), 0.0, ok.clone(), "fs_hz"),
        ("fs NaN", x.clone(), f64::NAN, ok.clone(), "fs_hz"),
    ];
    for (what, xs, f, p, want) in cases {
        for method in [ScfMethod::CyclicPeriodogram, ScfMethod::Fast] {
            let p = ScfParams {
                method,
                ..p.clone()
            };
            let e = scf(&xs, f, &p).expect_err(what);
            assert_eq!(param_name(&e), want, "{what} ({method:?}): {e}");
            assert!(
                p.validate(f, xs.len()).is_err() || want == "<non-finite>",
                "{what}: validate"
            );
        }
    }
    if let Err(DspError::NonFinite { index }) = scf(
        &{
            let mut v = x.clone();
            v[17] = f64::NAN;
            v
        },
        fs,
        &ok,
    ) {
        assert_eq!(index, 17);
    } else {
        panic!("NaN not reported at its index");
    }
    // Slices out of range.
    let map = scf(&x, fs, &ok).unwrap();
    assert_eq!(param_name(&map.alpha_slice(150.0).unwrap_err()), "alpha_hz");
    assert_eq!(
        param_name(&map.alpha_slice(f64::NAN).unwrap_err()),
        "alpha_hz"
    );
    assert_eq!(
        param_name(&map.frequency_slice(-20.0).unwrap_err()),
        "frequency_hz"
    );
    assert_eq!(
        param_name(
            &map.enhanced_envelope_spectrum_in_band(300.0, 200.0)
                .unwrap_err()
        ),
        "band_hz"
    );
    assert!(ok.validate(fs, x.len()).is_ok());
}
