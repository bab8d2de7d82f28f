//! Comparison: alignment refuses what cannot be compared and resamples what can; metrics on
//! identical and on shifted signals; the residual map puts a missing line's error on its label.

use twinscope::compare::{align, compare, residual_map, CompareOptions, CompareError};
use twinscope::kinematics::lookup_bearing;
use twinscope::signal::{synth, Signal};

fn bearing_signal(fs: f64, seconds: f64, modulation: f64, seed: u64) -> Signal {
    let n = (fs * seconds) as usize;
    let ff = lookup_bearing("6205").unwrap().fault_frequencies(29.95).unwrap();
    let p = synth::ImpactTrain { fault_frequency_hz: ff.bpfi_hz, resonance_hz: 2500.0, damping_ratio: 0.05, jitter_fraction: 0.005, modulation_depth: modulation, modulation_hz: 29.95, amplitude: 1.0 };
    let mut x = synth::impact_train(n, fs, &p, seed);
    for (a, b) in x.iter_mut().zip(synth::white_noise(n, 0.05, seed + 1)) {
        *a += b;
    }
    let mut s = Signal::new(x, fs, "synthetic", "g");
    s.meta.shaft_speed_hz = Some(29.95);
    s
}

fn opts() -> CompareOptions {
    CompareOptions { envelope_band_hz: [1800.0, 3200.0], ..Default::default() }
}

#[test]
fn identical_signals_compare_perfectly() {
    let a = bearing_signal(12000.0, 2.0, 0.5, 1);
    let c = compare(&a, &a, &opts()).unwrap();
    for d in &c.domains {
        assert!(d.metrics.rmse < 1e-12 && (d.metrics.pearson - 1.0).abs() < 1e-9, "{}: {:?}", d.domain, d.metrics);
        assert_eq!(d.metrics.xcorr_lag, 0);
    }
    assert!(c.alignment.rms_ratio_db.abs() < 1e-9);
}

#[test]
fn units_speeds_and_lengths_are_checked() {
    let a = bearing_signal(12000.0, 1.0, 0.5, 1);
    let mut b = a.clone();
    b.unit = "V".into();
    assert!(matches!(align(&a, &b, &opts()), Err(CompareError::Units { .. })));
    // g vs m/s² is converted.
    let mut c = a.clone();
    c.unit = "m/s^2".into();
    c.samples.iter_mut().for_each(|v| *v *= 9.80665);
    let (m, s, al) = align(&a, &c, &opts()).unwrap();
    assert!((al.unit_factor - 1.0 / 9.80665).abs() < 1e-15);
    assert!(m.iter().zip(&s).all(|(x, y)| (x - y).abs() < 1e-12));
    // 10 % speed difference is refused, 1 % is bridged by order normalisation.
    let mut d = a.clone();
    d.meta.shaft_speed_hz = Some(29.95 * 1.1);
    let e = align(&a, &d, &opts()).unwrap_err().to_string();
    assert!(e.contains("shaft speeds differ"), "{e}");
    d.meta.shaft_speed_hz = Some(29.95 * 1.01);
    assert!((align(&a, &d, &opts()).unwrap().2.speed_ratio - 1.0 / 1.01).abs() < 1e-12);
    // Too short.
    let short = Signal::new(vec![0.0; 100], 12000.0, "s", "g");
    assert!(matches!(align(&a, &short, &opts()), Err(CompareError::TooShort(_))));
}

#[test]
fn different_sampling_rates_are_resampled_not_compared_silently_wrong() {
    let a = bearing_signal(12000.0, 2.0, 0.5, 1);
    let b = bearing_signal(16384.0, 2.0, 0.5, 1);
    let c = compare(&a, &b, &opts()).unwrap();
    assert_eq!(c.alignment.resampled_from_hz, Some(16384.0));
    assert_eq!(c.alignment.rate_in_words(), "12000 Hz (the simulation resampled from 16384 Hz)");
    // Same process, different sampling: envelope spectra agree well.
    assert!(c.domain("envelope").unwrap().metrics.pearson > 0.8, "{:?}", c.domain("envelope").unwrap().metrics);
}

/// A measurement sampled faster than the simulated signal is brought down to the simulated
/// rate: content above the lower Nyquist frequency (here a strong 15 kHz tone) is not set
/// against nothing. The up-sampled simulation compared at 48 kHz (what `compare` did before
/// session 72) counts it in the PSD domain.
#[test]
fn a_measurement_sampled_faster_is_compared_at_the_simulated_rate() {
    use twinscope::compare::at_most_rate;
    let mut fast = bearing_signal(48000.0, 2.0, 0.5, 1);
    for (i, v) in fast.samples.iter_mut().enumerate() {
        *v += 2.0 * (2.0 * std::f64::consts::PI * 15000.0 * i as f64 / 48000.0).sin();
    }
    let slow = bearing_signal(12000.0, 2.0, 0.5, 1);
    let c = compare(&fast, &slow, &opts()).unwrap();
    assert_eq!((c.alignment.fs_hz, c.alignment.measured_resampled_from_hz, c.alignment.resampled_from_hz), (12000.0, Some(48000.0), None));
    assert_eq!(c.alignment.rate_in_words(), "12000 Hz (the measurement resampled from 48000 Hz)");
    let psd = c.domain("psd_db").unwrap();
    assert!(*psd.frequency_hz.last().unwrap() <= 6000.0, "PSD up to {} Hz", psd.frequency_hz.last().unwrap());
    // At 48 kHz the simulation has nothing at 6–24 kHz and the tone: a far worse PSD error.
    let up = Signal { samples: twinscope::dsp::resample::resample(&slow.samples, 12000.0, 48000.0).unwrap(), fs_hz: 48000.0, ..slow.clone() };
    let at_48k = compare(&fast, &up, &opts()).unwrap();
    let (nrmse, nrmse_48k) = (psd.metrics.nrmse_percent, at_48k.domain("psd_db").unwrap().metrics.nrmse_percent);
    println!("PSD NRMSE {nrmse:.2} % / {nrmse_48k:.2} %");
    assert!(nrmse < 0.5 * nrmse_48k, "PSD NRMSE {nrmse:.1} % at 12 kHz, {nrmse_48k:.1} % at 48 kHz");
    // At the rate or below, the measurement is borrowed as it is; a bad rate is refused.
    assert!(matches!(at_most_rate(&slow, 12000.0).unwrap(), std::borrow::Cow::Borrowed(_)));
    assert!(matches!(at_most_rate(&slow, 16384.0).unwrap(), std::borrow::Cow::Borrowed(_)));
    let down = at_most_rate(&fast, 12000.0).unwrap();
    assert_eq!((down.fs_hz, down.len(), down.meta.shaft_speed_hz, down.unit.as_str()), (12000.0, 24000, Some(29.95), "g"));
    assert_eq!((twinscope::compare::resampled_from_hz(&down), twinscope::compare::resampled_from_hz(&slow)), (Some(48000.0), None), "a resampled record says where it came from");
    assert!(at_most_rate(&slow, 0.0).unwrap_err().to_string().contains("fs_hz"));
}

/// The loop compares at the model's rate: its final comparison of a 48 kHz record is the one of
/// the record brought down to the model's 12 kHz first, to the bit.
#[test]
fn the_loop_compares_a_faster_measurement_at_the_models_rate() {
    use twinscope::compare::{at_most_rate, diagnose::final_comparison, LoopOptions};
    let mut m = twinscope::model::preset("cwru_6205_inner").unwrap();
    m.effects.enable(twinscope::model::EffectKind::Noise);
    let mut fast = bearing_signal(48000.0, 2.0, 0.5, 3);
    fast.meta.shaft_speed_hz = Some(29.95);
    let opts = LoopOptions::default();
    let c = final_comparison(&m, &fast, &opts).unwrap();
    let c_down = final_comparison(&m, &at_most_rate(&fast, 12000.0).unwrap(), &opts).unwrap();
    assert_eq!(c.alignment.fs_hz, 12000.0);
    assert_eq!(c, c_down);
    // A loop round (`run_loop`, as `diagnose` and the batch call it) resamples the record
    // itself, and its diagnosis says at which rate it compared, and from which.
    let quick = LoopOptions { fit_duration_s: 0.4, evaluations_per_parameter: 3, sweeps: 1, polish_sweeps: 0, candidates: vec![twinscope::model::EffectKind::Slip], random_effect_realisations: 0, unbend_when_stuck: false, ..opts };
    let (_, history, last) = twinscope::compare::run_loop(&m, &fast, 1, &quick, &|_, _| true).unwrap();
    assert_eq!(history.len(), 1);
    assert_eq!((last.compared_at_hz, last.measured_resampled_from_hz), (12000.0, Some(48000.0)));
    assert_eq!(last.rate_in_words(), "12000 Hz (the measurement resampled from 48000 Hz)");
}

#[test]
fn residual_map_puts_missing_sidebands_on_their_label() {
    // "Measurement" has load-zone modulation (BPFI ± shaft sidebands); the "model" has none.
    let meas = bearing_signal(12000.0, 3.0, 0.8, 1);
    let model = bearing_signal(12000.0, 3.0, 0.0, 2);
    let c = compare(&meas, &model, &opts()).unwrap();
    let ff = lookup_bearing("6205").unwrap().fault_frequencies(29.95).unwrap();
    let map = residual_map(&c, &ff.families(), Some(29.95));
    let sb = map.family_share("BPFI ± shaft") + map.family_share("shaft harmonics");
    assert!(sb > 40.0, "sideband + shaft share {sb:.1} %: {:?}", map.envelope_families);
    let top = map.items.iter().find(|i| i.kind == "envelope_line").unwrap();
    assert!(top.family == "BPFI ± shaft" || top.family == "shaft harmonics", "{top:?}");
    assert_eq!(top.note, "in the measurement, absent from the model");
}

#[test]
fn the_fault_slice_is_at_the_fault_frequency_and_a_bad_one_is_refused() {
    let a = bearing_signal(12000.0, 2.0, 0.5, 1);
    let bpfi = lookup_bearing("6205").unwrap().fault_frequencies(29.95).unwrap().bpfi_hz;
    let c = compare(&a, &a, &CompareOptions { fault_frequency_hz: Some(bpfi), ..opts() }).unwrap();
    let d = c.domains.iter().find(|d| d.domain == "scf_alpha_fault").expect("an α = fault slice");
    assert!(d.quantity.contains(&format!("{bpfi:.2}")), "{}", d.quantity);
    for bad in [-3.0, f64::NAN, 6000.0] {
        match compare(&a, &a, &CompareOptions { fault_frequency_hz: Some(bad), ..opts() }) {
            Err(CompareError::Parameter { name: "fault_frequency_hz", .. }) => {}
            other => panic!("fault frequency {bad}: {:?}", other.map(|c| c.domains.len())),
        }
    }
}

/// A transfer path the simulation lacks: a gain rising 12 dB per octave up to 2 kHz and flat
/// above, applied to the measured side.
fn through_path(s: &Signal) -> Signal {
    use twinscope::dsp::path_correction::PathCorrection;
    let path = PathCorrection { centre_hz: vec![250.0, 2000.0], gain_db: vec![-36.0, 0.0], level_db: 0.0 };
    let mut out = s.clone();
    out.samples = path.apply(&s.samples, s.fs_hz, 1.0).unwrap();
    out
}

#[test]
fn the_mean_of_realisations_reports_the_mean_of_their_path_corrections() {
    // Two realisations behind different paths each get their own correction; the comparison
    // of their mean reports the average of the two (it used to report the first one's).
    use twinscope::compare::Reference;
    use twinscope::dsp::path_correction::PathCorrection;
    let o = CompareOptions { path_correction_bands: 12, ..opts() };
    let r = Reference::new(&through_path(&bearing_signal(12000.0, 1.5, 0.5, 1)), &o).unwrap();
    let quieter = |s: Signal| {
        let mut s = s;
        s.samples.iter_mut().for_each(|v| *v *= 0.25);
        s
    };
    let (a, b) = (bearing_signal(12000.0, 1.5, 0.5, 2), quieter(bearing_signal(12000.0, 1.5, 0.5, 3)));
    let (ca, cb) = (r.compare(&a).unwrap().path_correction.unwrap(), r.compare(&b).unwrap().path_correction.unwrap());
    // A quarter of the amplitude is 12 dB more gain.
    assert!((cb.level_db - ca.level_db - 12.04).abs() < 1.0, "levels {:.2} and {:.2} dB", ca.level_db, cb.level_db);
    let mean = r.compare_mean(&[a, b]).unwrap().path_correction.unwrap();
    assert_eq!(mean, PathCorrection::mean(&[ca.clone(), cb]).unwrap());
    assert!((mean.level_db - ca.level_db - 6.02).abs() < 0.5, "mean level {:.2} dB against the first's {:.2}", mean.level_db, ca.level_db);
}

#[test]
fn the_path_correction_takes_the_transfer_path_and_leaves_the_modulation() {
    let with_path = |modulation: f64, seed: u64| through_path(&bearing_signal(12000.0, 2.0, modulation, seed));
    let measured = with_path(0.5, 1);
    let model = bearing_signal(12000.0, 2.0, 0.5, 11);
    let plain = compare(&measured, &model, &opts()).unwrap();
    let corrected = compare(&measured, &model, &CompareOptions { path_correction_bands: 24, ..opts() }).unwrap();
    assert!(plain.path_correction.is_none());
    let pc = corrected.path_correction.as_ref().expect("the correction is reported");
    // The fitted curve follows the path where the signals have energy (impacts ring at 2.5 kHz,
    // noise is white): -24 dB at 500 Hz, 0 dB from 2 kHz.
    assert!((pc.gain_db_at(500.0) + 24.0).abs() < 3.0, "at 500 Hz: {:.1} dB", pc.gain_db_at(500.0));
    assert!(pc.gain_db_at(3000.0).abs() < 1.5, "at 3 kHz: {:.1} dB", pc.gain_db_at(3000.0));
    let nrmse = |c: &twinscope::compare::Comparison, d: &str| c.domain(d).unwrap().metrics.nrmse_percent;
    assert!(nrmse(&corrected, "psd_db") < 0.3 * nrmse(&plain, "psd_db"), "PSD: {:.2} % corrected, {:.2} % plain", nrmse(&corrected, "psd_db"), nrmse(&plain, "psd_db"));
    // A model without the shaft-rate modulation keeps its α = shaft error: a filter cannot make
    // modulation.
    let unmodulated = bearing_signal(12000.0, 2.0, 0.0, 11);
    let right = compare(&measured, &model, &CompareOptions { path_correction_bands: 24, ..opts() }).unwrap();
    let wrong = compare(&measured, &unmodulated, &CompareOptions { path_correction_bands: 24, ..opts() }).unwrap();
    assert!(nrmse(&wrong, "scf_alpha_shaft") > 5.0 * nrmse(&right, "scf_alpha_shaft"), "α = shaft: {:.2} % without modulation, {:.2} % with", nrmse(&wrong, "scf_alpha_shaft"), nrmse(&right, "scf_alpha_shaft"));
    assert!(nrmse(&wrong, "envelope") > 3.0 * nrmse(&right, "envelope"), "envelope: {:.2} % without modulation, {:.2} % with", nrmse(&wrong, "envelope"), nrmse(&right, "envelope"));
}

#[test]
fn an_absurd_number_of_correction_bands_is_refused() {
    let a = bearing_signal(12000.0, 2.0, 0.5, 1);
    match compare(&a, &a, &CompareOptions { path_correction_bands: 100_000, ..opts() }) {
        Err(CompareError::Parameter { name: "path_correction_bands", reason }) => assert!(reason.contains("100000"), "{reason}"),
        other => panic!("{:?}", other.map(|c| c.domains.len())),
    }
}

#[test]
fn a_signal_corrected_against_itself_is_unchanged() {
    let a = bearing_signal(12000.0, 2.0, 0.5, 1);
    let c = compare(&a, &a, &CompareOptions { path_correction_bands: 24, ..opts() }).unwrap();
    let pc = c.path_correction.as_ref().unwrap();
    assert!(pc.gain_db.iter().all(|g| g.abs() < 1e-9), "{:?}", pc.gain_db);
    for d in &c.domains {
        assert!(d.metrics.rmse < 1e-9, "{}: {:?}", d.domain, d.metrics);
    }
}

#[test]
fn the_mean_of_realisations_is_fitted_without_the_model_s_own_scatter() {
    use twinscope::compare::Reference;
    let meas = bearing_signal(12000.0, 1.5, 0.5, 1);
    let r = Reference::new(&meas, &opts()).unwrap();
    let one = bearing_signal(12000.0, 1.5, 0.5, 2);
    // One realisation is the plain comparison, and a realisation averaged with itself too.
    let plain = r.compare(&one).unwrap();
    assert_eq!(r.compare_mean(std::slice::from_ref(&one)).unwrap(), plain);
    assert_eq!(r.compare_mean(&[one.clone(), one.clone()]).unwrap(), plain);
    // Against the mean of eight realisations of the same process (other impact jitter, other
    // noise) every domain's error is smaller than the mean error against single ones: the
    // model's own randomness no longer adds to it.
    let reals: Vec<Signal> = (2..10).map(|s| bearing_signal(12000.0, 1.5, 0.5, s)).collect();
    let mean = r.compare_mean(&reals).unwrap();
    let singles: Vec<_> = reals.iter().map(|s| r.compare(s).unwrap()).collect();
    for d in &mean.domains {
        let single = singles.iter().map(|c| c.domain(&d.domain).unwrap().metrics.nrmse_percent).sum::<f64>() / singles.len() as f64;
        eprintln!("{}: mean of 8 {:.2} %, single {:.2} %", d.domain, d.metrics.nrmse_percent, single);
        assert!(d.metrics.nrmse_percent < 0.9 * single, "{}: {} vs {}", d.domain, d.metrics.nrmse_percent, single);
    }
    // Realisations that leave different common lengths are refused, and so is none.
    let short = bearing_signal(12000.0, 1.0, 0.5, 3);
    assert!(matches!(r.compare_mean(&[one.clone(), short]), Err(CompareError::Parameter { name: "simulated", .. })));
    assert!(matches!(r.compare_mean(&[]), Err(CompareError::Parameter { name: "simulated", .. })));
}

#[test]
fn the_scatter_of_the_mean_is_taken_out_so_the_error_does_not_depend_on_the_number_of_realisations() {
    use twinscope::compare::Reference;
    // The model is the measurement's own process (same impact train, other seeds): its
    // expected spectra are the measurement's, so the distance left is the measurement's own
    // randomness, whatever K. Against the mean of K realisations the plain squared error also
    // holds the mean's variance Var(s)/K; the debiased one takes its estimate s²/K out.
    let meas = bearing_signal(12000.0, 1.5, 0.5, 1);
    let r = Reference::new(&meas, &opts()).unwrap();
    // 96 realisations: the |SCF| slices' per-bin errors are heavy-tailed, and the mean over
    // fewer groups scatters as much as the bias looked for (with 32, the α = 0 slice read
    // 0.052 at K = 2 against 0.040 at K = 8 and 32; with 96: 0.047, 0.042, 0.044 at K = 48).
    let reals: Vec<Signal> = (1..97).map(|s| bearing_signal(12000.0, 1.5, 0.5, 10 * s)).collect();
    // Squared NRMSE of each domain: mean over the disjoint groups of K realisations.
    let sq = |k: usize, debiased: bool| -> Vec<(String, f64)> {
        let groups: Vec<_> = reals.chunks(k).map(|g| r.compare_mean(g).unwrap()).collect();
        groups[0]
            .domains
            .iter()
            .map(|d0| {
                let v = groups.iter().map(|c| {
                    let d = c.domain(&d0.domain).unwrap();
                    if debiased { d.debiased_nrmse_percent() } else { d.metrics.nrmse_percent }.powi(2)
                });
                (d0.domain.clone(), v.sum::<f64>() / groups.len() as f64)
            })
            .collect()
    };
    let (plain2, plain16, deb2, deb16) = (sq(2, false), sq(16, false), sq(2, true), sq(16, true));
    for i in 0..plain2.len() {
        let name = &plain2[i].0;
        eprintln!("{name}: NRMSE² plain K=2 {:.3}, K=16 {:.3}; debiased K=2 {:.3}, K=16 {:.3}", plain2[i].1, plain16[i].1, deb2[i].1, deb16[i].1);
        // The plain error falls with K (the mean's own scatter leaves it) ...
        let gap = plain2[i].1 - plain16[i].1;
        assert!(gap > 0.1 * plain16[i].1, "{name}: plain {} vs {}", plain2[i].1, plain16[i].1);
        // ... and the debiased error is the same at K = 2 as at K = 16, within a quarter of
        // that fall, and below the plain one.
        assert!((deb2[i].1 - deb16[i].1).abs() < 0.25 * gap, "{name}: debiased {} vs {} (plain gap {gap})", deb2[i].1, deb16[i].1);
        assert!(deb2[i].1 < plain2[i].1, "{name}");
    }
    // One realisation has no scatter estimate: the plain comparison, unchanged.
    let one = r.compare(&reals[0]).unwrap();
    assert!(one.domains.iter().all(|d| d.scatter_rmse == 0.0 && d.debiased_nrmse_percent() == d.metrics.nrmse_percent));
}

#[test]
fn one_scf_normaliser_does_not_scale_estimator_noise_up_to_a_slice_s_own_range() {
    // Without shaft-rate modulation (BPFI is no multiple of the shaft speed) the α = shaft slice
    // holds little but the estimator's own error.
    let measured = bearing_signal(12000.0, 2.0, 0.0, 1);
    let model = bearing_signal(12000.0, 2.0, 0.0, 5);
    let one = compare(&measured, &model, &CompareOptions { scf_one_normaliser: true, ..opts() }).unwrap();
    let own = compare(&measured, &model, &opts()).unwrap();
    let slices: Vec<_> = one.domains.iter().filter(|d| d.domain.starts_with("scf_alpha")).collect();
    assert_eq!(slices.len(), 2, "α = 0 and α = shaft");
    // One normaliser: max − min of the measured SCF over both slices.
    let pooled: Vec<f64> = slices.iter().flat_map(|d| d.measured.iter().copied()).collect();
    let (lo, hi) = pooled.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    for d in &slices {
        assert!((d.metrics.normaliser_value - (hi - lo)).abs() <= 1e-12 * hi, "{}: {} against {}", d.domain, d.metrics.normaliser_value, hi - lo);
        assert!((d.metrics.nrmse_percent - d.metrics.rmse / (hi - lo) * 100.0).abs() < 1e-9, "{}", d.domain);
    }
    // |S(α, f)| ≤ √(S(0, f + α/2) S(0, f − α/2)): the α = 0 slice holds the peak, so its NRMSE
    // hardly moves.
    let zero = |c: &twinscope::compare::Comparison| c.domain("scf_alpha_0").unwrap().metrics.clone();
    assert_eq!(zero(&one).rmse, zero(&own).rmse);
    assert!(slices[0].measured.iter().cloned().fold(f64::NEG_INFINITY, f64::max) == hi);
    assert!((zero(&one).nrmse_percent / zero(&own).nrmse_percent - 1.0).abs() < 0.02, "{} against {}", zero(&one).nrmse_percent, zero(&own).nrmse_percent);
    // The shaft slice: the same error, no longer scaled up to the range of its noise.
    let shaft = |c: &twinscope::compare::Comparison| c.domain("scf_alpha_shaft").unwrap().metrics.clone();
    assert_eq!(shaft(&one).rmse, shaft(&own).rmse);
    assert!(shaft(&own).nrmse_percent > 10.0 * shaft(&one).nrmse_percent, "own range {:.2} %, the SCF's {:.3} %", shaft(&own).nrmse_percent, shaft(&one).nrmse_percent);
    // The other domains are not touched.
    for d in ["envelope", "psd_db"] {
        assert_eq!(one.domain(d).unwrap().metrics, own.domain(d).unwrap().metrics, "{d}");
    }
}
