//! Tests of `dsp::stsa`: analytic impulse trains (exact and at −5 dB SNR with slip and a tone),
//! a naive synchronous average as the reference, the envelope spectrum as the physical check,
//! and bad input.

mod common;
use common::{pearson, Rng};
use num_complex::Complex64;
use std::f64::consts::PI;
use twinscope::dsp::stsa::{stsa, Pad, StsaParams};
use twinscope::dsp::{fft, DspError};


/// Decaying resonance `exp(−ζωt) sin(ω_d t)`, `len` samples.
fn impulse_response(fs: f64, fr: f64, zeta: f64, len: usize) -> Vec<f64> {
    let w = 2.0 * PI * fr;
    let wd = w * (1.0 - zeta * zeta).sqrt();
    (0..len).map(|i| i as f64 / fs).map(|t| (-zeta * w * t).exp() * (wd * t).sin()).collect()
}

fn power(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64
}

/// Largest normalised cross-correlation between `a` and `b` over all lags.
fn max_norm_xcorr(a: &[f64], b: &[f64]) -> f64 {
    let na = a.iter().map(|v| v * v).sum::<f64>().sqrt();
    let nb = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut best = 0.0_f64;
    for lag in -(b.len() as isize)..(a.len() as isize) {
        let mut s = 0.0;
        for (j, &bv) in b.iter().enumerate() {
            let i = lag + j as isize;
            if i >= 0 && (i as usize) < a.len() {
                s += a[i as usize] * bv;
            }
        }
        best = best.max(s.abs());
    }
    best / (na * nb)
}

/// Squared-envelope spectrum magnitude (one-sided, bin spacing fs/n) via the analytic signal.
fn squared_envelope_spectrum(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let spec = fft::rfft(x);
    let mut full = vec![Complex64::new(0.0, 0.0); n];
    full[0] = spec[0];
    for k in 1..n.div_ceil(2) {
        full[k] = 2.0 * spec[k];
    }
    if n.is_multiple_of(2) {
        full[n / 2] = spec[n / 2];
    }
    fft::inverse(n).process(&mut full);
    let se: Vec<f64> = full.iter().map(|c| (c / n as f64).norm_sqr()).collect();
    let mean = se.iter().sum::<f64>() / n as f64;
    let centred: Vec<f64> = se.iter().map(|v| v - mean).collect();
    fft::rfft(&centred).iter().map(|c| c.norm() / n as f64).collect()
}

/// Peak of `spec` within ±`half_bins` of `bin`, over the median of `spec[lo..hi]`.
fn line_to_background(spec: &[f64], bin: usize, half_bins: usize, lo: usize, hi: usize) -> f64 {
    let peak = spec[bin - half_bins..=bin + half_bins].iter().cloned().fold(0.0, f64::max);
    let mut bg = spec[lo..hi].to_vec();
    bg.sort_by(|a, b| a.total_cmp(b));
    peak / bg[bg.len() / 2]
}

struct Train {
    x: Vec<f64>,
    clean: Vec<f64>,
    /// Impact sample indices.
    impacts: Vec<usize>,
    /// Interval deviations from T (samples), `deviation[i] = t_i − t_{i−1} − T`.
    deviation: Vec<f64>,
    h: Vec<f64>,
}

/// Impacts at 107.3 Hz with ±1.5 % uniform slip of every interval (a random walk of the impact
/// times), 1400 Hz resonance, white noise at −5 dB SNR and a 377 Hz tone 3 dB above the train.
fn noisy_train(seed: u64, fs: f64, duration_s: f64) -> Train {
    let mut rng = Rng(seed);
    let n = (fs * duration_s) as usize;
    let f = 107.3;
    let t_int = fs / f;
    let h = impulse_response(fs, 1400.0, 0.06, 200);
    let mut clean = vec![0.0; n];
    let mut impacts = Vec::new();
    let mut deviation = Vec::new();
    let mut t = 40.0;
    while t < n as f64 {
        let i = t.round() as usize;
        for (j, &v) in h.iter().enumerate() {
            if i + j < n {
                clean[i + j] += v;
            }
        }
        impacts.push(i);
        let dev = t_int * 0.015 * (2.0 * rng.uniform() - 1.0);
        deviation.push(dev);
        t += t_int + dev;
    }
    let ps = power(&clean);
    let sigma = (ps * 10f64.powf(0.5)).sqrt();
    let tone_amp = (2.0 * 2.0 * ps).sqrt();
    let x = (0..n)
        .map(|i| clean[i] + sigma * rng.gauss() + tone_amp * (2.0 * PI * 377.0 * i as f64 / fs + 0.3).sin())
        .collect();
    // deviation[i] was drawn after impact i: it is the gap to impact i+1.
    let mut dev_before = vec![0.0];
    dev_before.extend_from_slice(&deviation[..deviation.len() - 1]);
    Train { x, clean, impacts, deviation: dev_before, h }
}

#[test]
fn peak_search_recovers_slipping_impacts_at_minus_5_db() {
    let fs = 16384.0;
    let tr = noisy_train(7, fs, 10.0);
    let params = StsaParams { fault_frequency_hz: 107.3, ..StsaParams::default() };
    let r = stsa(&tr.x, fs, &params).unwrap();
    assert_eq!(r.signal.len(), tr.x.len());
    let m = r.segment_starts.len();
    assert!(m > 1000, "{m} intervals");

    // 1. Tracking: each interval's impact sits at a constant offset from its start (±1 sample).
    let offsets: Vec<isize> = r
        .segment_starts
        .iter()
        .map(|&s| {
            let target = s + r.impact_offset;
            let i = tr.impacts.partition_point(|&t| t + 30 < target);
            tr.impacts[i] as isize - s as isize
        })
        .collect();
    let mut sorted = offsets.clone();
    sorted.sort();
    let c0 = sorted[m / 2];
    let locked = offsets.iter().filter(|&&o| (o - c0).abs() <= 1).count() as f64 / m as f64;
    assert!(locked > 0.95, "only {:.1} % of intervals aligned within ±1 sample", 100.0 * locked);

    // 2. The shifts track the injected slip (the gap before each impact, minus T).
    let (mut sx, mut sy, mut abs_err) = (Vec::new(), Vec::new(), 0.0);
    for k in 1..m {
        let target = r.segment_starts[k] as isize + c0;
        let i = tr.impacts.partition_point(|&t| (t as isize) < target - 2);
        let (a, b) = (r.shifts[k] as f64, tr.deviation[i]);
        abs_err += (a - b).abs();
        sx.push(a);
        sy.push(b);
    }
    let corr = pearson(&sx, &sy);
    abs_err /= (m - 1) as f64;
    println!("shift/slip correlation {corr:.3}, mean |shift − slip| {abs_err:.3} samples");
    assert!(corr > 0.8, "shift/slip correlation {corr}");
    assert!(abs_err < 0.8, "mean |shift − slip| = {abs_err} samples");

    // 3. The average shows the impulse response.
    let c_avg = max_norm_xcorr(&r.average_period, &tr.h);
    assert!(c_avg > 0.9, "average vs impulse response correlation {c_avg}");

    // 4. Impact-to-noise ratio: SNR = 10 log10(Σ clean² / Σ (z − clean)²) over the averaged span.
    let (a, b) = (r.segment_starts[0], *r.segment_starts.last().unwrap());
    let snr = |z: &[f64]| {
        let e: f64 = (a..b).map(|i| (z[i] - tr.clean[i]).powi(2)).sum();
        let s: f64 = (a..b).map(|i| tr.clean[i].powi(2)).sum();
        10.0 * (s / e).log10()
    };
    let (snr_in, snr_out) = (snr(&tr.x), snr(&r.signal));
    println!("SNR in {snr_in:.2} dB, out {snr_out:.2} dB");
    assert!(snr_out - snr_in > 15.0, "SNR only {snr_in:.2} → {snr_out:.2} dB");

    // 5. Plain synchronous average (no re-alignment) smears the impulse.
    let plain = stsa(&tr.x, fs, &StsaParams { tolerance_fraction: 0.0, ..params.clone() }).unwrap();
    let peak = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let c_plain = max_norm_xcorr(&plain.average_period, &tr.h);
    println!(
        "peak search: peak {:.3}, corr {c_avg:.3}; plain: peak {:.3}, corr {c_plain:.3}",
        peak(&r.average_period),
        peak(&plain.average_period)
    );
    assert!(peak(&plain.average_period) < 0.5 * peak(&r.average_period));
    assert!(c_plain < c_avg - 0.2, "plain {c_plain} vs peak search {c_avg}");
    assert!(plain.shifts.iter().all(|&d| d == 0));

    // 6. Physical meaning for the chain: the squared-envelope spectrum keeps the fault line, far
    //    cleaner than before; the 377 Hz tone is averaged out of the spectrum.
    let n = tr.x.len();
    let df = fs / n as f64;
    let bin = (107.3 / df).round() as usize;
    let (lo, hi) = ((20.0 / df) as usize, (500.0 / df) as usize);
    let ses_in = squared_envelope_spectrum(&tr.x);
    let ses_out = squared_envelope_spectrum(&r.signal);
    // Slip spreads the line over a few bins (±1.5 % random walk): search ±1 Hz.
    let half = (1.0 / df).ceil() as usize;
    let (lb_in, lb_out) =
        (line_to_background(&ses_in, bin, half, lo, hi), line_to_background(&ses_out, bin, half, lo, hi));
    println!("envelope line/background at 107.3 Hz: in {lb_in:.1}, out {lb_out:.1}");
    assert!(lb_out > 2.0 * lb_in && lb_out > 10.0);
    let spec_in = fft::rfft(&tr.x);
    let spec_out = fft::rfft(&r.signal);
    let tb = (377.0 / df).round() as usize;
    let amp = |s: &[Complex64]| s[tb - 2..=tb + 2].iter().map(|c| c.norm()).fold(0.0, f64::max);
    let atten_db = 20.0 * (amp(&spec_in) / amp(&spec_out)).log10();
    println!("377 Hz tone attenuated by {atten_db:.1} dB");
    assert!(atten_db > 10.0);
}


/// Noiseless train, integer interval T = 160 samples, integer slips in [−3, 3] (= ±D): the peak
/// search must find every slip exactly, the average must be the impulse response and the output
/// must equal the input over the averaged span.
#[test]
fn exact_integer_slips_are_found_exactly() {
    let fs = 16000.0;
    let t_int = 160usize;
    let h = impulse_response(fs, 2000.0, 0.05, 120);
    let n = 48_000;
    let mut rng = Rng(3);
    let mut x = vec![0.0; n];
    let mut impacts = Vec::new();
    let mut slips = Vec::new();
    let mut t = 40usize;
    while t + h.len() < n {
        x[t..t + h.len()].copy_from_slice(&h);
        impacts.push(t);
        let s = (rng.next_u64() % 7) as isize - 3;
        slips.push(s);
        t = (t as isize + t_int as isize + s) as usize;
    }
    let params = StsaParams { fault_frequency_hz: 100.0, ..StsaParams::default() };
    let r = stsa(&x, fs, &params).unwrap();
    assert_eq!(r.interval_samples, 160.0);
    let p_h = h.iter().enumerate().fold((0, 0.0_f64), |b, (i, &v)| if v.abs() > b.1 { (i, v.abs()) } else { b }).0;
    // Average = h, impact peak at impact_offset.
    let onset = r.impact_offset - p_h;
    for (j, &v) in r.average_period.iter().enumerate() {
        let want = if j >= onset && j - onset < h.len() { h[j - onset] } else { 0.0 };
        assert!((v - want).abs() < 1e-12, "average[{j}] = {v}, want {want}");
    }
    // Every start is one impact minus the onset; shifts equal the injected slips.
    for (k, &s) in r.segment_starts.iter().enumerate() {
        let i = impacts.iter().position(|&t| t == s + onset).unwrap_or_else(|| panic!("start {s} is not on an impact"));
        if k > 0 {
            assert_eq!(r.shifts[k], slips[i - 1], "interval {k}");
        }
    }
    // Output = input over the averaged span (every interval is identical).
    let (a, b) = (r.segment_starts[0], *r.segment_starts.last().unwrap());
    for (i, (y, v)) in r.signal[a..b].iter().zip(&x[a..b]).enumerate() {
        assert!((y - v).abs() < 1e-12, "sample {}", a + i);
    }
}

/// With no search (`tolerance_fraction = 0`) the average must equal a naive synchronous average
/// over starts `s₀ + round(kT)`, T fractional.
#[test]
fn plain_average_matches_naive_reference() {
    let fs = 10_000.0;
    let f = 93.7;
    let t_int = fs / f;
    let mut rng = Rng(11);
    let x: Vec<f64> = (0..30_000).map(|i| (2.0 * PI * f * i as f64 / fs).sin().powi(7) + 0.3 * rng.gauss()).collect();
    let p = StsaParams { fault_frequency_hz: f, tolerance_fraction: 0.0, transient_s: 0.05, ..StsaParams::default() };
    let r = stsa(&x, fs, &p).unwrap();
    let s0 = r.segment_starts[0];
    assert!(s0 >= 500, "transient of 0.05 s = 500 samples respected");
    let l = r.average_period.len();
    assert_eq!(l, t_int.ceil() as usize + 1);
    let mut naive = vec![0.0; l];
    let mut count = 0;
    for k in 0.. {
        let s = (s0 as f64 + k as f64 * t_int).round() as usize;
        if s + l > x.len() {
            break;
        }
        assert_eq!(r.segment_starts[k], s);
        for j in 0..l {
            naive[j] += x[s + j];
        }
        count += 1;
    }
    assert_eq!(count, r.segment_starts.len());
    for (a, b) in r.average_period.iter().zip(&naive) {
        assert!((a - b / count as f64).abs() < 1e-12);
    }
    // Periodic average of a periodic signal: the noise is divided by √M.
    let resid = power(
        &r.average_period
            .iter()
            .enumerate()
            .map(|(j, v)| v - ((2.0 * PI * f * (s0 + j) as f64 / fs).sin().powi(7)))
            .collect::<Vec<_>>(),
    );
    assert!(resid < 3.0 * 0.09 / count as f64, "residual noise power {resid}");
}

/// Short-time average: K = 1 gives back the input interval by interval, and K = 5 matches a
/// naive centred moving average of the aligned intervals.
#[test]
fn short_time_average_matches_naive_moving_average() {
    let fs = 16384.0;
    let tr = noisy_train(5, fs, 2.0);
    let base = StsaParams { fault_frequency_hz: 107.3, ..StsaParams::default() };
    let r1 = stsa(&tr.x, fs, &StsaParams { segments_per_average: Some(1), ..base.clone() }).unwrap();
    let s = &r1.segment_starts;
    for i in s[0]..*s.last().unwrap() {
        assert!((r1.signal[i] - tr.x[i]).abs() < 1e-12, "sample {i}");
    }
    let k = 5usize;
    let r5 = stsa(&tr.x, fs, &StsaParams { segments_per_average: Some(k), ..base }).unwrap();
    let s = &r5.segment_starts;
    assert_eq!(s, &r1.segment_starts, "same alignment whatever K");
    let m = s.len();
    for idx in 0..m - 1 {
        let lo = idx.saturating_sub((k - 1) / 2).min(m - k);
        for j in 0..s[idx + 1] - s[idx] {
            let want = (lo..lo + k).map(|q| tr.x[s[q] + j]).sum::<f64>() / k as f64;
            assert!((r5.signal[s[idx] + j] - want).abs() < 1e-12, "interval {idx}, sample {j}");
        }
    }
}

#[test]
fn output_keeps_the_input_length_for_every_option() {
    let fs = 16384.0;
    let tr = noisy_train(9, fs, 1.0);
    for pad in [Pad::Periodic, Pad::Zeros] {
        for spa in [None, Some(3)] {
            for transient_s in [0.0, 0.1] {
                let p = StsaParams {
                    fault_frequency_hz: 107.3,
                    pad,
                    segments_per_average: spa,
                    transient_s,
                    ..StsaParams::default()
                };
                let r = stsa(&tr.x, fs, &p).unwrap();
                assert_eq!(r.signal.len(), tr.x.len());
                assert!(r.signal.iter().all(|v| v.is_finite()));
                assert_eq!(r.shifts.len(), r.segment_starts.len());
                assert!(r.segment_starts[0] as f64 >= transient_s * fs);
                let head_zero = r.signal[..r.segment_starts[0]].iter().all(|&v| v == 0.0);
                // Zero padding leaves the head empty; periodic padding fills it.
                assert_eq!(head_zero, pad == Pad::Zeros || r.segment_starts[0] == 0, "{pad:?}");
            }
        }
    }
}

fn param_error(r: Result<twinscope::dsp::stsa::StsaResult, DspError>) -> (&'static str, String) {
    match r {
        Err(DspError::InvalidParameter { name, reason, .. }) => (name, reason),
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

#[test]
fn bad_input_is_refused_with_the_parameter_named() {
    let fs = 1000.0;
    let x: Vec<f64> = (0..2000).map(|i| (i as f64 * 0.37).sin()).collect(); // 2 s
    let p = |f: f64| StsaParams { fault_frequency_hz: f, ..StsaParams::default() };

    // Interval longer than the record: the message gives the record duration.
    let (name, reason) = param_error(stsa(&x, fs, &p(0.4)));
    assert_eq!(name, "fault_frequency_hz");
    assert!(reason.contains("2 s"), "{reason}");
    // Three intervals needed: 1.2 Hz (0.83 s intervals) is too low for 2 s too.
    assert_eq!(param_error(stsa(&x, fs, &p(1.2))).0, "fault_frequency_hz");
    for f in [0.0, -5.0, 500.1, f64::NAN, f64::INFINITY] {
        assert_eq!(param_error(stsa(&x, fs, &p(f))).0, "fault_frequency_hz", "f = {f}");
    }
    assert!(stsa(&x, fs, &p(500.0)).is_ok(), "Nyquist itself is allowed");
    assert!(StsaParams::default().validate(x.len(), fs).is_err(), "the default frequency is unset");
    for tol in [-0.01, 0.5, 0.7, f64::NAN] {
        let q = StsaParams { tolerance_fraction: tol, ..p(20.0) };
        assert_eq!(param_error(stsa(&x, fs, &q)).0, "tolerance_fraction");
    }
    for tr in [2.0, 5.0, -0.1, f64::NAN] {
        let q = StsaParams { transient_s: tr, ..p(20.0) };
        assert_eq!(param_error(stsa(&x, fs, &q)).0, "transient_s");
    }
    // A transient that leaves less than three intervals is a fault-frequency/record problem.
    let q = StsaParams { transient_s: 1.9, ..p(20.0) };
    assert_eq!(param_error(stsa(&x, fs, &q)).0, "fault_frequency_hz");
    for passes in [0, 17] {
        let q = StsaParams { alignment_passes: passes, ..p(20.0) };
        assert_eq!(param_error(stsa(&x, fs, &q)).0, "alignment_passes");
    }
    let q = StsaParams { segments_per_average: Some(0), ..p(20.0) };
    assert_eq!(param_error(stsa(&x, fs, &q)).0, "segments_per_average");
    let q = StsaParams { segments_per_average: Some(1000), ..p(20.0) };
    assert_eq!(param_error(stsa(&x, fs, &q)).0, "segments_per_average");
    assert_eq!(param_error(stsa(&x, 0.0, &p(20.0))).0, "fs_hz");
    assert_eq!(param_error(stsa(&x, f64::NAN, &p(20.0))).0, "fs_hz");

    let mut bad = x.clone();
    bad[17] = f64::NAN;
    assert_eq!(stsa(&bad, fs, &p(20.0)), Err(DspError::NonFinite { index: 17 }));
    assert!(matches!(stsa(&[], fs, &p(20.0)), Err(DspError::TooShort { got: 0, .. })));
    // A silent record is not an error: the average is zero.
    let r = stsa(&vec![0.0; 2000], fs, &p(20.0)).unwrap();
    assert!(r.signal.iter().all(|&v| v == 0.0));
}

#[test]
fn params_round_trip_through_toml_and_refuse_unknown_fields() {
    let p = StsaParams {
        fault_frequency_hz: 107.0,
        segments_per_average: Some(4),
        pad: Pad::Zeros,
        ..StsaParams::default()
    };
    let s = toml::to_string(&p).unwrap();
    let q: StsaParams = toml::from_str(&s).unwrap();
    assert_eq!(p, q);
    let partial: StsaParams = toml::from_str("fault_frequency_hz = 71.2").unwrap();
    assert_eq!(partial.tolerance_fraction, 0.02);
    assert!(toml::from_str::<StsaParams>("fault_frequency = 71.2").is_err());
}
