//! The model-vs-measurement loop: calibration mechanics, and a hidden-effect case — the
//! "measurement" is the MFS inner-race rig with a load zone the model is not told about
//! (random load, another seed, perturbed baseline, measurement noise); the search must rank
//! load_zone first and applying it must at least halve the envelope NRMSE, and the loop's
//! history must show the error falling.

use twinscope::compare::{fit, hidden, run_loop, LoopOptions, Param, Reference};
use twinscope::model::{self, EffectKind};

#[test]
fn params_read_and_write_the_machine() {
    let mut m = model::preset("mfs_inner").unwrap();
    for p in [Param::ResonanceHz, Param::ResonanceDamping, Param::FaultDepthM, Param::RadialLoadN, Param::RadialClearanceM] {
        let v = p.get(&m).unwrap_or_else(|| panic!("{} missing", p.name()));
        p.set(&mut m, v * 1.1 + 1e-9);
        assert!((p.get(&m).unwrap() - (v * 1.1 + 1e-9)).abs() <= 1e-12 * v.abs().max(1.0), "{}", p.name());
        let (lo, hi, _) = p.bounds(&m);
        assert!(lo < hi);
    }
    // An effect that is off has no parameter to read.
    assert!(Param::SlipPercent.get(&m).is_none());
    m.effects.enable(EffectKind::Slip);
    assert!(Param::SlipPercent.get(&m).is_some());
}

/// 1 s of the CWRU inner-race preset (resonance 2600 Hz) as the measurement, the same machine
/// with its resonance at `resonance_hz` as the model, and quick fit options (no SCF).
fn mistuned_resonance(resonance_hz: f64) -> (model::Machine, Reference, LoopOptions) {
    let truth = model::preset("cwru_6205_inner").unwrap();
    let mut mt = truth.clone();
    mt.duration_s = 1.0;
    let measured = model::simulate(&mt).unwrap();
    let mut wrong = truth;
    Param::ResonanceHz.set(&mut wrong, resonance_hz);
    let opts = LoopOptions { fit_duration_s: 1.0, evaluations_per_parameter: 10, compare: twinscope::compare::CompareOptions { envelope_band_hz: [1800.0, 3000.0], scf: false, ..Default::default() }, ..Default::default() };
    let reference = Reference::new(&measured, &opts.compare).unwrap();
    (wrong, reference, opts)
}

#[test]
fn calibration_recovers_a_mistuned_resonance() {
    // Measurement: the CWRU inner-race model as is. Model: its resonance 15 % off.
    let (wrong, reference, opts) = mistuned_resonance(2600.0 * 1.15);
    let (fitted, report) = fit(&wrong, &reference, &[Param::ResonanceHz], 1, &opts).unwrap();
    let f = Param::ResonanceHz.get(&fitted).unwrap();
    assert!((f - 2600.0).abs() / 2600.0 < 0.03, "fitted resonance {f} Hz, true 2600 Hz");
    assert!(report.objective_after < 0.5 * report.objective_before, "{report:?}");
}

#[test]
fn a_resonance_that_walks_past_its_first_range_is_not_called_pinned() {
    // The resonance's search range is 0.7–1.4 × its current value, so it moves between sweeps.
    // Model at 1430 Hz, truth at 2600 Hz: sweep 1 can reach only 2002 Hz (its edge: pinned),
    // sweep 2 searches 1401–2803 Hz from there and finds the truth inside its range. The flag
    // reads the range each parameter's last search used, not the one of the starting value
    // (from which 2600 Hz lies beyond the edge).
    let (wrong, reference, opts) = mistuned_resonance(1430.0);
    let (one, f1) = fit(&wrong, &reference, &[Param::ResonanceHz], 1, &opts).unwrap();
    let (two, f2) = fit(&wrong, &reference, &[Param::ResonanceHz], 2, &opts).unwrap();
    let (r1, r2) = (Param::ResonanceHz.get(&one).unwrap(), Param::ResonanceHz.get(&two).unwrap());
    assert!(f1.at_bound.iter().any(|b| b.0 == Param::ResonanceHz && (b.2 - 2002.0).abs() < 1.0), "one sweep ends at {r1:.0} Hz, the edge of 1001–2002 Hz: {:?}", f1.at_bound);
    assert!((r2 - 2600.0).abs() / 2600.0 < 0.03, "two sweeps reach {r2:.0} Hz");
    assert!(f2.at_bound.is_empty(), "{r2:.0} Hz lies inside the range its last search used: {:?}", f2.at_bound);
}

#[test]
fn hidden_load_zone_is_found_and_the_error_falls() {
    let base = model::preset("mfs_inner").unwrap();
    let opts = LoopOptions { fit_duration_s: 1.0, evaluations_per_parameter: 7, sweeps: 1, ..Default::default() };
    let (mut truth, model_m, true_param, snr) = hidden::make_case(&base, Some(EffectKind::LoadZone), 7);
    assert!(!model_m.effects.is_on(EffectKind::LoadZone) && truth.effects.is_on(EffectKind::LoadZone));
    truth.duration_s = 2.0;
    let measured = model::simulate(&truth).unwrap();
    let (fin, history, _) = run_loop(&model_m, &measured, 2, &opts, &|_, _| true).unwrap();
    eprintln!("true {true_param:?}, SNR {snr:.1} dB; history {:?}", history.iter().map(|r| (r.envelope_nrmse, r.applied)).collect::<Vec<_>>());
    // The final machine names what the loop fitted, so that a loop going on from its file re-fits it.
    assert!(fin.fitted_effects.contains(&EffectKind::LoadZone), "{:?}", fin.fitted_effects);
    assert_eq!(model::Machine::from_toml(&fin.to_toml(), "saved").unwrap().fitted_effects, fin.fitted_effects);
    // Round 1 ranks load_zone first and applies it ...
    assert_eq!(history[0].applied, Some(EffectKind::LoadZone), "round 1 verdict: {}", history[0].verdict);
    assert!(history[0].verdict.starts_with("load_zone"), "{}", history[0].verdict);
    assert!(history.iter().all(|r| (r.floor_ratio_needed - 1.15).abs() < 1e-12), "each round records the ratio its decision needed (1 + the default margin 0.15)");
    // ... and round 2 starts with it on, the (recalibrated) envelope NRMSE at least halved.
    let r2 = history.get(1).expect("a second round");
    assert!(r2.effects_on.contains(&EffectKind::LoadZone));
    assert!(r2.envelope_nrmse <= 0.5 * history[0].envelope_nrmse, "round 1 {:.2} %, round 2 {:.2} %", history[0].envelope_nrmse, r2.envelope_nrmse);
}

/// The CWRU inner-race preset, 1 s of "measurement" from `seed`, and quick loop options that
/// try only `candidates`.
fn quick_case(seed: u64, candidates: Vec<EffectKind>) -> (model::Machine, twinscope::signal::Signal, LoopOptions) {
    let mut m = model::preset("cwru_6205_inner").unwrap();
    m.effects.enable(EffectKind::Noise);
    let mut truth = m.clone();
    truth.seed = seed;
    truth.duration_s = 1.0;
    let measured = model::simulate(&truth).unwrap();
    // One realisation throughout and no unbent redo: these quick searches test other things
    // than the second look and unbending when stuck (whose tests switch them on).
    let mut opts = LoopOptions { fit_duration_s: 0.8, evaluations_per_parameter: 4, sweeps: 1, candidates, random_effect_realisations: 0, unbend_when_stuck: false, ..Default::default() };
    opts.compare.envelope_band_hz = [1800.0, 3000.0];
    (m, measured, opts)
}

#[test]
fn a_loop_that_adds_nothing_ends_on_its_calibrated_machine() {
    // The model's resonance 12 % high and nothing missing: the one round calibrates it back
    // and applies nothing. The machine the loop returns (the CLI's --save-machine, a batch job's
    // model_loop_final_machine.toml) is that calibrated machine, not the machine it was given.
    let (mut m, measured, opts) = quick_case(16, vec![EffectKind::Slip]);
    let given_hz = 2600.0 * 1.12;
    Param::ResonanceHz.set(&mut m, given_hz);
    let (fin, history, last) = run_loop(&m, &measured, 1, &opts, &|_, _| true).unwrap();
    assert_eq!(history.len(), 1);
    assert_eq!(history[0].applied, None, "{}", history[0].verdict);
    assert!(fin.fitted_effects.is_empty(), "nothing applied, nothing to re-fit: {:?}", fin.fitted_effects);
    assert!(!last.calibration.parameters.is_empty());
    for (p, v) in &last.calibration.parameters {
        assert_eq!(p.get(&fin), Some(*v), "{} of the final machine against its calibration", p.name());
    }
    let f = Param::ResonanceHz.get(&fin).unwrap();
    assert!((f - 2600.0).abs() < (given_hz - 2600.0).abs() / 2.0, "final resonance {f:.0} Hz, given {given_hz:.0} Hz, true 2600 Hz");
}

#[test]
fn progress_counts_every_evaluation_and_cancel_stops_the_search() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let (m, measured, opts) = quick_case(11, vec![EffectKind::Slip, EffectKind::CasingModes]);
    let (calls, last_done, last_expected) = (AtomicUsize::new(0), AtomicUsize::new(0), AtomicUsize::new(0));
    let d = twinscope::compare::diagnose(&m, &measured, &opts, &|done, expected| {
        calls.fetch_add(1, Ordering::SeqCst);
        last_done.fetch_max(done, Ordering::SeqCst);
        last_expected.store(expected, Ordering::SeqCst);
        true
    });
    assert!(d.is_ok(), "{:?}", d.err());
    // Every model evaluation is reported, and the expected total is exact when no trial is
    // skipped: calibration 1 + 3 parameters × 4 (resonance, damping, noise: the 0.178 mm spall's
    // depth does not act, see `calibrate::fault_drop_limit_m`), the calibrated model 1, the
    // floor 2, the seed scatter 2, slip 1 + 4 + noise refit 3, casing_modes re-doing the
    // calibration with the mode 1 + 3 × 4 (grid, then line search) + 3 × 4, then both (the top
    // 3) re-fit the 3 calibrated parameters locally: 2 × (1 + 3 × 3), and each fitted machine is
    // evaluated once more without its effect: 2. The polish (4 sweeps by default) follows the
    // two full-range fits, the calibration's and the casing trial's, with one 3-evaluation local
    // line search per fitted parameter and sweep: 4 × 3 × 3 and 4 × 4 × 3 (the mode's frequency
    // and the three calibrated parameters).
    // With `LoopOptions::uncalibrated_start_top` the slip trial, one of the top three and not
    // re-doing the calibration, also starts once from the uncalibrated values (counted by the
    // library's own function); the casing trial re-does the calibration and gets none.
    assert_eq!(opts.polish_sweeps, 4);
    let top_second_starts = top_second_start_evaluations(&m, EffectKind::Slip, &opts);
    let expected = (1 + 3 * 4) + 1 + 2 + 2 + (1 + 4 + 3) + (1 + 12 + 3 * 4) + 2 * (1 + 3 * 3) + 2 + 4 * 3 * 3 + 4 * 4 * 3 + top_second_starts;
    assert_eq!(last_expected.load(Ordering::SeqCst), expected);
    assert_eq!(last_done.load(Ordering::SeqCst), expected);
    assert_eq!(calls.load(Ordering::SeqCst), expected);

    // Cancel after the fifth evaluation: the search stops with Cancelled, within a few calls.
    let calls = AtomicUsize::new(0);
    let r = twinscope::compare::diagnose(&m, &measured, &opts, &|done, _| {
        calls.fetch_add(1, Ordering::SeqCst);
        done < 5
    });
    assert!(matches!(r, Err(twinscope::compare::LoopError::Cancelled)), "{:?}", r.map(|x| x.1.verdict));
    assert!(calls.load(Ordering::SeqCst) <= 6, "{} evaluations after cancelling", calls.load(Ordering::SeqCst));
}

/// The noise trial fits the noise level over its full range; its local re-fit of the noise
/// level (the refit every trial makes) is the same line search and is not made twice, nor
/// counted twice in the progress total.
#[test]
fn a_noise_trial_expects_exactly_the_evaluations_it_makes() {
    let (mut m, measured, opts) = quick_case(13, vec![EffectKind::Noise]);
    m.effects.disable(EffectKind::Noise);
    let (d, calls, expected) = diagnose_counting(&m, &measured, &opts);
    assert_eq!(d.trials.len(), 1);
    assert_eq!(calls, expected);
}

/// An extra-effect case (`confusion --extra`): the model holds a 300 N load zone the machine
/// lacks (drawn as the hidden-effect case of the same seed is, then moved from the measurement
/// to the model); its removal trial reads it contradicted and the fault needed.
#[test]
fn an_effect_the_machine_lacks_reads_contradicted_in_an_extra_effect_case() {
    use twinscope::compare::hidden::{make_case_set, make_extra_case, run_extra_case, CaseSetting};
    use twinscope::compare::removal::{ModelPart, RemovalReading};
    let base = model::preset("cwru_6205_inner").unwrap();
    let setting = CaseSetting { value: Some(300.0), snr_db: Some(20.0) };
    // The draw is the hidden-effect case's, the load zone moved from the measurement to the model.
    let (truth, model_m, parameter, snr) = make_extra_case(&base, EffectKind::LoadZone, 7401, &setting);
    let (hidden_truth, hidden_model, hidden_parameters, hidden_snr) = make_case_set(&base, &[EffectKind::LoadZone], 7401, &setting);
    assert_eq!((parameter, snr), (hidden_parameters.first().copied(), hidden_snr));
    assert_eq!(parameter, Some((Param::RadialLoadN, 300.0)));
    assert!(!truth.effects.is_on(EffectKind::LoadZone) && model_m.effects.is_on(EffectKind::LoadZone));
    assert_eq!(model_m.effects.load_zone, hidden_truth.effects.load_zone);
    assert_eq!(Param::ResonanceHz.get(&truth), Param::ResonanceHz.get(&hidden_truth), "the same perturbed baseline");
    assert_eq!(model_m.bearings, hidden_model.bearings);
    assert!(model_m.fitted_effects.is_empty(), "the extra effect keeps its drawn strength");

    let (_, _, opts) = quick_case(0, vec![EffectKind::Slip]);
    let r = run_extra_case(&base, EffectKind::LoadZone, 7401, 1.0, 1, &setting, &opts).unwrap();
    for t in &r.removals {
        eprintln!("{:?}: {}", t.reading, t.summary);
    }
    let t = r.extra_trial().expect("the load zone's removal trial");
    assert_eq!(t.part, ModelPart::Effect(EffectKind::LoadZone));
    assert_eq!(t.reading, RemovalReading::Contradicted, "{}", t.summary);
    let fault = r.removals.iter().find(|t| matches!(t.part, ModelPart::Fault { .. })).expect("the fault's trial");
    assert_eq!(fault.reading, RemovalReading::Needed, "{}", fault.summary);
    assert!(run_extra_case(&base, EffectKind::Noise, 7401, 1.0, 1, &setting, &opts).is_err(), "the noise is no part of a model");
}

/// Take out before adding (`LoopOptions::take_out_first`, the default): session 74's extra-effect case
/// 10802, a model holding a 4.5 kHz casing mode the machine lacks (at 1.0 dB), beside which the
/// search chose a misalignment the machine lacks too. The loop takes the casing mode out in
/// round 1, setting the misalignment aside, and then finds nothing missing: no false claim.
#[test]
fn a_loop_takes_a_contradicted_casing_mode_out_before_adding_a_misalignment() {
    use twinscope::compare::hidden::{make_extra_case, CaseSetting};
    use twinscope::compare::removal::ModelPart;
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, model_m, _, _) = make_extra_case(&base, EffectKind::CasingModes, 10802, &CaseSetting::default());
    truth.duration_s = 2.0;
    let measured = model::simulate(&truth).unwrap();
    // The misalignment alone is tried, to keep the test short (the full search chose it too).
    let opts = LoopOptions { candidates: vec![EffectKind::Misalignment], removal_trials: true, ..Default::default() };
    assert!(opts.take_out_first, "the default order since session 75");
    let (fin, history, _) = run_loop(&model_m, &measured, 2, &opts, &|_, _| true).unwrap();
    for r in &history {
        eprintln!("round {}: {}", r.round, r.verdict);
    }
    let r1 = &history[0];
    assert_eq!(r1.set_aside, Some(EffectKind::Misalignment), "the search chose the misalignment: {}", r1.verdict);
    assert_eq!(r1.applied, None);
    assert_eq!(r1.taken_out.as_ref().map(|t| &t.part), Some(&ModelPart::Effect(EffectKind::CasingModes)), "{}", r1.verdict);
    assert!(r1.removals.iter().any(|t| t.part == ModelPart::Effect(EffectKind::CasingModes)), "the round keeps its removal trials");
    assert_eq!(history.len(), 2);
    assert_eq!(history[1].applied, None, "without the casing mode nothing is missing: {}", history[1].verdict);
    assert!(!fin.effects.is_on(EffectKind::CasingModes) && !fin.effects.is_on(EffectKind::Misalignment));
    assert!(twinscope::compare::diagnose::applied_effects(&history).is_empty());
}

/// The healthy 6205 preset with noise on, and the same machine with the inner-race preset's
/// fault: the two sides of the removal trials' tests.
fn healthy_and_faulted_6205() -> (model::Machine, model::Machine) {
    let mut healthy = model::preset("cwru_6205_healthy").unwrap();
    healthy.effects.enable(EffectKind::Noise);
    let mut faulted = healthy.clone();
    faulted.bearings[0].fault = model::preset("cwru_6205_inner").unwrap().bearings[0].fault.clone();
    assert!(faulted.bearings[0].fault.is_some() && healthy.bearings[0].fault.is_none());
    (healthy, faulted)
}

/// Removal trials, the converse of the search (`LoopOptions::removal_trials`): a model
/// holding an inner-race fault that the "measurement" lacks (the healthy 6205 with its load
/// zone, another seed) reads the fault contradicted; the same model against a measurement that
/// has the fault reads the fault and the load zone needed.
/// The search's own answer is the one made without the option, and every evaluation of the
/// trials is counted in the progress total.
#[test]
fn removal_trials_contradict_a_fault_the_measurement_lacks_and_need_one_it_has() {
    use twinscope::compare::removal::{ModelPart, RemovalReading, REMOVAL_REALISATIONS};
    let (healthy, faulted) = healthy_and_faulted_6205();
    let (_, _, mut opts) = quick_case(0, vec![EffectKind::Slip]);
    opts.removal_trials = true;
    let reading = |d: &twinscope::compare::Diagnosis, part: &ModelPart| d.removals.iter().find(|r| &r.part == part).map(|r| r.reading);
    let fault = ModelPart::Fault { bearing: faulted.bearings[0].name.clone() };
    let load_zone = ModelPart::Effect(EffectKind::LoadZone);
    for (truth, fault_reads) in [(&healthy, RemovalReading::Contradicted), (&faulted, RemovalReading::Needed)] {
        let mut truth = truth.clone();
        truth.seed = 73;
        truth.duration_s = 1.0;
        let measured = model::simulate(&truth).unwrap();
        let (d, calls, expected) = diagnose_counting(&faulted, &measured, &opts);
        for r in &d.removals {
            eprintln!("{:?}: {}", r.reading, r.summary);
        }
        let labels: Vec<&String> = d.removals.iter().map(|r| &r.label).collect();
        assert_eq!(labels, ["the inner-race fault of bearing de", "load_zone (with nonlinear_contact, which acts through it)", "nonlinear_contact (alone, load_zone kept)"], "the fault, the load zone with its contact nonlinearity, the contact nonlinearity alone; noise is the record's");
        assert_eq!(reading(&d, &fault), Some(fault_reads), "measured {}", if fault_reads == RemovalReading::Needed { "with the fault" } else { "without it" });
        // Both measurements vibrate through the load zone, so it is never contradicted; it reads
        // needed where the rest of the model is right. Beside a fault the record lacks, a trial
        // that takes out one part at a time judges the load zone against a wrong model: there
        // it may read either way but contradicted.
        let lz = reading(&d, &load_zone);
        if fault_reads == RemovalReading::Needed {
            assert_eq!(lz, Some(RemovalReading::Needed));
        } else {
            assert!(lz.is_some_and(|r| r != RemovalReading::Contradicted), "{lz:?}");
        }
        assert!(d.removals.iter().all(|r| r.realisations == REMOVAL_REALISATIONS));
        assert_eq!(calls, expected);
        let (_, plain) = twinscope::compare::diagnose(&faulted, &measured, &LoopOptions { removal_trials: false, ..opts.clone() }, &|_, _| true).unwrap();
        assert_eq!(plain, twinscope::compare::Diagnosis { removals: Vec::new(), ..d }, "the option adds the removal trials and changes nothing else");
        // A loop takes the contradicted fault out after its first round and goes on from the
        // machine without it, where nothing is contradicted; with nothing contradicted it
        // takes nothing out.
        let (fin, history, last) = run_loop(&faulted, &measured, 3, &opts, &|_, _| true).unwrap();
        let changes: Vec<String> = history.iter().map(|r| r.change_with_values("-")).collect();
        if fault_reads == RemovalReading::Contradicted {
            assert_eq!(history[0].taken_out.as_ref().map(|t| &t.part), Some(&fault), "{changes:?}");
            assert_eq!(changes[0], "took out the inner-race fault of bearing de");
            assert!(history.len() >= 2 && fin.bearings[0].fault.is_none(), "{changes:?}");
            assert!(last.removals.iter().all(|r| r.reading != RemovalReading::Contradicted), "{:?}", last.removals.iter().map(|r| &r.summary).collect::<Vec<_>>());
        } else {
            assert!(history.iter().all(|r| r.taken_out.is_none()), "{changes:?}");
            assert!(fin.bearings[0].fault.is_some());
        }
    }
}

/// Removal trials calibrated on fewer realisations than they are judged on
/// (`LoopOptions::removal_fit_realisations`, experimental): the trial says how many, every
/// evaluation is counted in the progress, the calibration is made anew, and the scatter is
/// taken on the judging realisations. On these simulated records one realisation reads the
/// fault as four do; on CWRU's healthy record 097 it did not (the absent fault read needed,
/// docs/loop-notebook.md "Session 76"), which is why the default calibrates on four.
#[test]
fn removal_trials_can_be_calibrated_on_fewer_realisations_than_judged() {
    use twinscope::compare::removal::{ModelPart, RemovalReading, REMOVAL_REALISATIONS};
    let (healthy, faulted) = healthy_and_faulted_6205();
    let (_, _, mut opts) = quick_case(0, vec![EffectKind::Slip]);
    opts.removal_trials = true;
    let fault = ModelPart::Fault { bearing: faulted.bearings[0].name.clone() };
    for (truth, fault_reads) in [(&healthy, RemovalReading::Contradicted), (&faulted, RemovalReading::Needed)] {
        let mut truth = truth.clone();
        truth.seed = 73;
        truth.duration_s = 1.0;
        let measured = model::simulate(&truth).unwrap();
        let mut by_k = Vec::new();
        for k in [0, 1] {
            let (d, calls, expected) = diagnose_counting(&faulted, &measured, &LoopOptions { removal_fit_realisations: k, ..opts.clone() });
            assert_eq!(calls, expected, "K = {k}: every evaluation counted");
            let r = d.removals.iter().find(|r| r.part == fault).expect("the fault is a part").clone();
            eprintln!("K = {k}: {}", r.summary);
            assert_eq!(r.reading, fault_reads, "K = {k}: {}", r.summary);
            assert_eq!((r.realisations, r.fit_realisations), (REMOVAL_REALISATIONS, if k == 0 { REMOVAL_REALISATIONS } else { k }));
            by_k.push(r);
        }
        // Calibrated on one realisation, the fits differ from those on four, but both are
        // judged on the same held-out realisations with the same yardstick.
        assert_ne!(by_k[0].calibration, by_k[1].calibration, "K = 1 calibrates anew");
        assert!(by_k.iter().all(|r| r.tie_width.is_finite() && r.tie_width > 0.0));
    }
}

/// A model that holds no vibration but its noise (the inner-race preset without its fault: no
/// load zone, every ball on the same preload) has no part to judge: its removal trials read
/// "cannot tell", saying why, and make no evaluation; the healthy preset, whose load zone
/// carries the rotor's weight, is not silent.
#[test]
fn a_silent_model_has_no_part_to_judge() {
    use twinscope::compare::removal::{silent, RemovalReading};
    let (mut m, measured, mut opts) = quick_case(5, vec![EffectKind::Slip]);
    m.bearings[0].fault = None;
    opts.removal_trials = true;
    let reference = Reference::new(&measured, &opts.compare).unwrap();
    let (model_rms, measured_rms) = silent(&m, &reference, &opts).unwrap().expect("silent");
    assert!(model_rms < 1e-12 && measured_rms > 1e-3, "{model_rms:e} against {measured_rms:e}");
    let (healthy, _) = healthy_and_faulted_6205();
    assert_eq!(silent(&healthy, &reference, &opts).unwrap(), None);
    let (d, calls, expected) = diagnose_counting(&m, &measured, &opts);
    assert_eq!(d.removals.len(), 1, "its contact nonlinearity");
    assert!(d.removals.iter().all(|r| r.reading == RemovalReading::CannotTell && r.summary.contains("no vibration but its noise")), "{:?}", d.removals[0].summary);
    assert_eq!(calls, expected, "no evaluation expected that is not made");
    // The diagnosis itself says the model is silent, whatever its options.
    assert_eq!(d.silent_model, Some((model_rms, measured_rms)));
    assert!(d.silent_model_warning("g").is_some_and(|w| w.contains("no vibration but its noise") && w.contains("cwru_6205_healthy")));
    let (_, vibrating) = twinscope::compare::diagnose(&healthy, &measured, &LoopOptions { removal_trials: false, ..opts }, &|_, _| true).unwrap();
    assert_eq!((vibrating.silent_model, vibrating.silent_model_warning("g")), (None, None));
}

/// Diagnoses, counting the progress calls: (diagnosis, calls made, the last expected total).
fn diagnose_counting(m: &model::Machine, measured: &twinscope::signal::Signal, opts: &LoopOptions) -> (twinscope::compare::Diagnosis, usize, usize) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let (calls, last_expected) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let (_, d) = twinscope::compare::diagnose(m, measured, opts, &|_, expected| {
        calls.fetch_add(1, Ordering::SeqCst);
        last_expected.store(expected, Ordering::SeqCst);
        true
    })
    .unwrap();
    (d, calls.into_inner(), last_expected.into_inner())
}

#[test]
fn a_casing_trial_scans_recalibrates_and_expects_exactly_the_evaluations_it_makes() {
    // The casing mode's trial re-does the calibration with it, its frequency scanned on a grid
    // first; a load zone's trial beside it starts from the calibrated model. The progress
    // total counts both exactly.
    use twinscope::compare::diagnose::recalibrates;
    let (m, measured, opts) = quick_case(14, vec![EffectKind::CasingModes, EffectKind::LoadZone]);
    assert!(recalibrates(EffectKind::CasingModes, &opts) && !recalibrates(EffectKind::LoadZone, &opts) && !recalibrates(EffectKind::SensorResponse, &opts));
    let (d, calls, expected) = diagnose_counting(&m, &measured, &opts);
    assert!(!d.unbent, "the calibration pinned {:?}: every trial would start twice", d.calibration.at_bound);
    assert_eq!(d.trials.len(), 2);
    assert_eq!(calls, expected);
    // The mode's fit re-fitted the calibration's parameters too (reported with it).
    let t = d.trials.iter().find(|t| t.effect == EffectKind::CasingModes).unwrap();
    assert!(t.extra_parameters.iter().any(|(p, _)| *p == Param::ResonanceHz), "{:?}", t.extra_parameters);
}

/// With `recalibrate_roll_off` the sensor roll-off's trial re-does the calibration as the
/// casing mode's does (from the uncalibrated values, the bandwidth scanned), and the progress
/// total counts it exactly; without, it starts from the calibrated model and re-fits the
/// calibration only in stage 2, locally.
#[test]
fn a_recalibrating_roll_off_trial_expects_exactly_the_evaluations_it_makes() {
    use twinscope::compare::diagnose::recalibrates;
    let (m, measured, opts) = quick_case(15, vec![EffectKind::SensorResponse, EffectKind::LoadZone]);
    let on = LoopOptions { recalibrate_roll_off: true, uncalibrated_start_top: false, ..opts.clone() };
    let off = LoopOptions { uncalibrated_start_top: false, ..opts };
    assert!(recalibrates(EffectKind::SensorResponse, &on) && !recalibrates(EffectKind::LoadZone, &on));
    let (d_on, calls_on, expected_on) = diagnose_counting(&m, &measured, &on);
    let (d_off, calls_off, expected_off) = diagnose_counting(&m, &measured, &off);
    assert!(!d_on.unbent && !d_off.unbent, "the calibration pinned {:?}", d_on.calibration.at_bound);
    assert_eq!((calls_on, calls_off), (expected_on, expected_off));
    let roll_off = |d: &twinscope::compare::Diagnosis| d.trials.iter().find(|t| t.effect == EffectKind::SensorResponse).unwrap().clone();
    let (t_on, t_off) = (roll_off(&d_on), roll_off(&d_off));
    assert!(t_on.from_uncalibrated && !t_off.from_uncalibrated);
    // Re-doing the calibration costs more than fitting the bandwidth and the noise level.
    let plain = twinscope::compare::diagnose::plain_trial_evaluations(&m, EffectKind::SensorResponse, &off);
    let recal = twinscope::compare::diagnose::plain_trial_evaluations(&m, EffectKind::SensorResponse, &on);
    assert!(recal > plain, "{recal} against {plain}");
    // The load zone's trial is the same with and without.
    let lz = |d: &twinscope::compare::Diagnosis| d.trials.iter().find(|t| t.effect == EffectKind::LoadZone).unwrap().objective_after;
    assert_eq!(lz(&d_on), lz(&d_off));
}

/// With `roll_off_two_starts` the sensor roll-off's trial has both starts, the plain one and
/// the recalibrating one, and keeps the better: its trial is one of the two, the one it
/// started from, and the progress total counts both starts exactly. The load zone's trial is
/// untouched.
#[test]
fn a_roll_off_trial_with_two_starts_is_the_better_of_them_and_expects_its_evaluations() {
    // No second start for the top trials, which a roll-off trial with two starts does not
    // take; the recalibrating start is polished as `recalibrate_roll_off`'s (unlike an unbent
    // trial's second start, `polish_second_starts` off).
    let (m, measured, opts) = quick_case(15, vec![EffectKind::SensorResponse, EffectKind::LoadZone]);
    let base = LoopOptions { uncalibrated_start_top: false, ..opts };
    assert!(!base.polish_second_starts && base.polish_sweeps > 0);
    let (d_off, _, expected_off) = diagnose_counting(&m, &measured, &base);
    let recal_opts = LoopOptions { recalibrate_roll_off: true, ..base.clone() };
    let (d_recal, _, expected_recal) = diagnose_counting(&m, &measured, &recal_opts);
    let (d_two, calls, expected) = diagnose_counting(&m, &measured, &LoopOptions { roll_off_two_starts: true, ..base.clone() });
    assert!(!d_two.unbent && !d_off.unbent, "the calibration pinned {:?}", d_two.calibration.at_bound);
    assert_eq!(calls, expected);
    // Both starts: the search with the (polished) recalibrating trial and the plain trial.
    assert_eq!(expected, expected_recal + twinscope::compare::diagnose::plain_trial_evaluations(&m, EffectKind::SensorResponse, &base));
    assert!(expected > expected_off);
    let roll_off = |d: &twinscope::compare::Diagnosis| d.trials.iter().find(|t| t.effect == EffectKind::SensorResponse).unwrap().clone();
    let (off, recal, two) = (roll_off(&d_off), roll_off(&d_recal), roll_off(&d_two));
    let kept = if two.from_uncalibrated { &recal } else { &off };
    assert_eq!((two.objective_after, two.parameter), (kept.objective_after, kept.parameter), "plain {} / recalibrating {}", off.objective_after, recal.objective_after);
    let lz = |d: &twinscope::compare::Diagnosis| d.trials.iter().find(|t| t.effect == EffectKind::LoadZone).unwrap().objective_after;
    assert_eq!(lz(&d_two), lz(&d_off));
}

/// With `refit_effect_in_stage2`, stage 2 re-fits each top trial's own parameters locally
/// after the calibrated ones: one local line search (3 evaluations here) more per effect
/// parameter, load and clearance for the load zone, the frequency for the casing mode, and the
/// progress total counts them exactly. Nothing before stage 2 changes, and a re-fit can only
/// keep or lower a trial's objective.
#[test]
fn a_stage2_refit_of_the_effect_expects_exactly_the_evaluations_it_makes() {
    let (m, measured, opts) = quick_case(14, vec![EffectKind::CasingModes, EffectKind::LoadZone]);
    let (d_off, calls_off, expected_off) = diagnose_counting(&m, &measured, &opts);
    let on = LoopOptions { refit_effect_in_stage2: true, ..opts.clone() };
    let (d_on, calls_on, expected_on) = diagnose_counting(&m, &measured, &on);
    assert!(!d_off.unbent && !d_on.unbent);
    assert_eq!(calls_off, expected_off);
    assert_eq!(calls_on, expected_on);
    assert_eq!(expected_on, expected_off + 3 * (2 + 1));
    for t in &d_on.trials {
        let off = d_off.trials.iter().find(|x| x.effect == t.effect).unwrap();
        assert!(t.objective_after <= off.objective_after + 1e-12, "{}: {} against {}", t.effect.name(), t.objective_after, off.objective_after);
    }
}

#[test]
fn the_seed_floor_is_what_the_model_scores_against_itself() {
    // A "measurement" from the model itself (another seed): the calibrated objective is at the
    // floor — there is nothing for a missing effect to explain.
    let (m, measured, opts) = quick_case(12, vec![EffectKind::LoadZone]);
    let (_, d) = twinscope::compare::diagnose(&m, &measured, &opts, &|_, _| true).unwrap();
    let j0 = d.calibration.objective_after;
    assert!(d.floor_objective > 0.0 && j0 < 1.5 * d.floor_objective, "objective {j0:.2}, floor {:.2}", d.floor_objective);
    assert_eq!(d.best, None, "{}", d.verdict);

    // The same model against a measurement with a strong load zone: far above its floor.
    let measured = with_load_zone_200_n(&m);
    let (_, d) = twinscope::compare::diagnose(&m, &measured, &opts, &|_, _| true).unwrap();
    let j0 = d.calibration.objective_after;
    assert!(j0 > 2.0 * d.floor_objective, "objective {j0:.2}, floor {:.2}", d.floor_objective);
    let t = &d.trials[0];
    assert_eq!(t.effect, EffectKind::LoadZone);
    assert!(t.explained > 0.5, "load_zone explains {:.0} % of the error above the floor", t.explained * 100.0);
    // The ablation: switched off again in the trial's fitted machine, the load zone's absence
    // costs most of what the trial gained; the re-fitted noise level did not do it.
    let without = t.objective_without_effect.expect("the ablation was evaluated");
    assert!(without > t.objective_after && t.effect_explained.unwrap() > 0.5, "without the load zone {without:.2}, with it {:.2}: {:?}", t.objective_after, t.effect_explained);
}

/// A 1 s "measurement" of `m` (seed 12) with a strong 200 N load zone added.
fn with_load_zone_200_n(m: &model::Machine) -> twinscope::signal::Signal {
    let mut truth = m.clone();
    truth.seed = 12;
    truth.duration_s = 1.0;
    truth.effects.enable(EffectKind::LoadZone);
    Param::RadialLoadN.set(&mut truth, 200.0);
    model::simulate(&truth).unwrap()
}

/// `strength_range`: a strong 200 N load zone the search chooses gets a range of its load
/// that holds the fitted value and the true one, is closed on both sides (the load is
/// well pinned: a factor of 2 either way is far outside the seed scatter), and is built from
/// 7 profile points whose re-fits (and the fitted machine's seed scatter) are all counted in
/// the progress total. The diagnosis
/// itself is the one the search makes without the option.
#[test]
fn a_chosen_load_zone_gets_a_strength_range_that_holds_its_true_load() {
    let (m, _, opts) = quick_case(12, vec![EffectKind::LoadZone, EffectKind::Slip]);
    let measured = with_load_zone_200_n(&m);
    let on = LoopOptions { strength_range: true, ..opts.clone() };
    let (d, calls, expected) = diagnose_counting(&m, &measured, &on);
    assert_eq!(calls, expected);
    assert_eq!(d.best, Some(EffectKind::LoadZone), "{}", d.verdict);
    let r = d.strength_range.as_ref().expect("a chosen load zone gets a range");
    assert_eq!(r.parameter, Param::RadialLoadN);
    assert_eq!(r.profile.len(), 7);
    eprintln!("load range: {}; profile {:?}", r.text(), r.profile);
    let fitted = d.trials[0].parameter.unwrap().1;
    assert_eq!(r.fitted, fitted);
    assert!(!r.low_open && !r.high_open, "{}", r.text());
    assert!(r.low < fitted && fitted < r.high && r.contains(200.0), "{}", r.text());
    assert!(r.high / r.low < 4.0, "{}", r.text());
    // The re-fit at the fitted value can only match or lower the trial's own objective.
    assert!(r.objective_fitted <= d.trials[0].objective_after + 1e-9, "{} against {}", r.objective_fitted, d.trials[0].objective_after);
    // Without the option: the same diagnosis, no range.
    let (d_off, calls_off, _) = diagnose_counting(&m, &measured, &opts);
    assert!(d_off.strength_range.is_none());
    assert_eq!(d_off.verdict, d.verdict);
    // Seven profile points, each the same local re-fit, and the fitted machine's seed
    // scatter (two more seeds).
    assert!(calls > calls_off + 2 && (calls - calls_off - 2) % 7 == 0, "{calls} against {calls_off}");
}

#[test]
fn the_misalignment_trial_scales_its_1x_force_with_the_2x() {
    // A misalignment fitted to a weak 2× must not keep a fixed 1× force and pass for an
    // unbalance: the 1× follows the 2× at the ratio the machine gives (1:4 by default).
    let mut m = model::preset("mfs_inner").unwrap();
    m.effects.enable(EffectKind::Misalignment);
    let mi = m.effects.misalignment.clone().unwrap();
    let ratio = mi.force_1x_n / mi.force_2x_n;
    Param::Misalignment2xN.set(&mut m, 0.1);
    let mi = m.effects.misalignment.as_ref().unwrap();
    assert_eq!(mi.force_2x_n, 0.1);
    assert!((mi.force_1x_n - 0.1 * ratio).abs() < 1e-12, "1× force {} N", mi.force_1x_n);
}

/// A single-effect case of the bearing base (`mfs_inner`): 2 s of "measurement" with `hidden`
/// (case `seed`), diagnosed with default options over `candidates`. Returns the true machine,
/// the true parameter, the SNR, the calibrated machine and the diagnosis.
fn diagnose_hidden(hidden_effect: EffectKind, seed: u64, candidates: Vec<EffectKind>) -> (model::Machine, Option<(Param, f64)>, f64, model::Machine, twinscope::compare::Diagnosis) {
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, model_m, true_param, snr) = hidden::make_case(&base, Some(hidden_effect), seed);
    truth.duration_s = 2.0;
    let measured = model::simulate(&truth).unwrap();
    let opts = LoopOptions { candidates, ..Default::default() };
    let (cal_m, d) = twinscope::compare::diagnose(&model_m, &measured, &opts, &|_, _| true).unwrap();
    (truth, true_param, snr, cal_m, d)
}

#[test]
fn a_hidden_casing_mode_is_found_by_recalibrating_with_it() {
    // The "measurement" has a casing mode at 3.2 kHz (seed 1302 of the bearing-base table); the
    // calibration without it bends the resonance and the fault depth to imitate it. The
    // casing-mode trial re-does the calibration with the mode and must win, and un-bend the
    // resonance towards the truth.
    let (truth, true_param, snr, cal_m, d) = diagnose_hidden(EffectKind::CasingModes, 1302, vec![EffectKind::CasingModes, EffectKind::SensorResponse, EffectKind::Slip]);
    let (_, f_true) = true_param.unwrap();
    eprintln!("true mode {f_true:.0} Hz, SNR {snr:.1} dB; {}", d.verdict);
    assert_eq!(d.best, Some(EffectKind::CasingModes), "{}", d.verdict);
    let t = &d.trials[0];
    let (_, f_fit) = t.parameter.unwrap();
    assert!((f_fit - f_true).abs() < 0.1 * f_true, "fitted mode {f_fit:.0} Hz, true {f_true:.0} Hz");
    let res = |m: &model::Machine| Param::ResonanceHz.get(m).unwrap();
    let res_fit = t.extra_parameters.iter().find(|(p, _)| *p == Param::ResonanceHz).map(|x| x.1).expect("the trial re-fits the resonance");
    assert!((res_fit - res(&truth)).abs() < (res(&cal_m) - res(&truth)).abs(), "resonance: true {:.0}, calibrated {:.0}, trial {res_fit:.0} Hz", res(&truth), res(&cal_m));
}

#[test]
fn a_hidden_unbalance_is_not_taken_for_misalignment() {
    // Seed 1307 of the earlier bearing-base table: with the misalignment's 1× force fixed, its
    // trial fitted the 2× to nothing and passed for the unbalance on the fixed 1× alone. With
    // the 1× scaled with the 2×, the unbalance trial must win.
    let (_, true_param, snr, _, d) = diagnose_hidden(EffectKind::Unbalance, 1307, vec![EffectKind::Unbalance, EffectKind::Misalignment]);
    eprintln!("true {true_param:?}, SNR {snr:.1} dB; {}", d.verdict);
    assert_eq!(d.best, Some(EffectKind::Unbalance), "{}", d.verdict);
}

#[test]
fn two_hidden_effects_draw_the_single_case_first_and_are_both_hidden() {
    // Hiding two effects: both off in the model, both on in the measurement, and the first
    // one's parameter (and the perturbed baseline) drawn exactly as in the single-effect case,
    // so the single-effect tables stay reproducible.
    let base = model::preset("mfs_inner").unwrap();
    let (t1, m1, p1, _) = hidden::make_case(&base, Some(EffectKind::LoadZone), 31);
    let (t2, m2, p2, snr2) = hidden::make_case_hiding(&base, &[EffectKind::LoadZone, EffectKind::Unbalance], 31);
    for k in [EffectKind::LoadZone, EffectKind::Unbalance] {
        assert!(t2.effects.is_on(k) && !m2.effects.is_on(k), "{}", k.name());
    }
    assert_eq!(p2.len(), 2);
    assert_eq!(Some(p2[0]), p1);
    assert_eq!(p2[1].0, Param::UnbalanceKgM);
    assert_eq!(Param::UnbalanceKgM.get(&t2), Some(p2[1].1));
    assert_eq!(Param::ResonanceHz.get(&t1), Param::ResonanceHz.get(&t2));
    assert_eq!(m1, m2, "the base has no unbalance: both models are the base without the hidden effects");
    assert!((0.0..=20.0).contains(&snr2) && t2.effects.is_on(EffectKind::Noise) && m2.effects.is_on(EffectKind::Noise));
}

/// The second two-effect case of the README's table (seed 2301): a 159 N load zone and a
/// 0.86 % speed fluctuation at 11.1 dB SNR.
const TWO_HIDDEN_SEED: u64 = 2301;

#[test]
fn two_hidden_effects_are_found_one_per_round_and_then_nothing_is_missing() {
    // The "measurement" hides a load zone and a speed fluctuation. Round 1 must apply one of
    // them, round 2 the other, and round 3 answer "nothing significant is missing"; the
    // envelope NRMSE falls round by round. Candidates are limited to keep the test short, with
    // misalignment and slip as wrong answers on offer.
    let base = model::preset("mfs_inner").unwrap();
    let hide = [EffectKind::LoadZone, EffectKind::SpeedFluctuation];
    let opts = LoopOptions { fit_duration_s: 1.0, evaluations_per_parameter: 7, sweeps: 1, candidates: vec![EffectKind::LoadZone, EffectKind::SpeedFluctuation, EffectKind::Misalignment, EffectKind::Slip], ..Default::default() };
    let r = hidden::run_multi_case(&base, &hide, TWO_HIDDEN_SEED, 2.0, 3, &opts).unwrap();
    let steps: Vec<_> = r.history.iter().map(|h| (h.envelope_nrmse, h.applied, h.verdict.clone())).collect();
    eprintln!("true {:?}, SNR {:.1} dB; rounds {steps:#?}", r.true_parameters, r.snr_db);
    assert!(r.false_claims.is_empty(), "false claims {:?}", r.false_claims);
    assert!(r.found_all, "applied {:?}", r.applied);
    assert_eq!(r.history.len(), 3);
    assert!(r.ended_clean, "round 3: {}", r.history[2].verdict);
    assert!(r.history[1].envelope_nrmse < r.history[0].envelope_nrmse && r.history[2].envelope_nrmse < r.history[1].envelope_nrmse, "{steps:?}");
    // The yardstick only a hidden-effect case has: the true machine, re-seeded. Round 1's
    // model is measurably worse than it, for want of the hidden effects; by the last round
    // the loop has closed most of that gap (this test's fits are coarse: one sweep, seven
    // evaluations per parameter, 1 s of model).
    let o = &r.oracle;
    assert!(o.recoverable(r.history[0].objective), "round 1 {:.2}, truth {:?}, without the hidden {:?}", r.history[0].objective, o.truth_objective(), o.without_hidden_objective());
    let closed = o.recovered(r.history[0].objective, r.history[2].objective);
    assert!(closed >= 0.8, "rounds 1 / 3: {:.2} / {:.2}, truth {:?}: {:.0} % of the gap closed", r.history[0].objective, r.history[2].objective, o.truth_objective(), closed * 100.0);
}

/// The gear-base path_modulation + misalignment case of the README's table (seed 2402): a
/// 0.34 path-modulation depth and a 42.6 N misalignment at 13.8 dB SNR.
const REPLACEMENT_SEED: u64 = 2402;

#[test]
fn an_effect_standing_in_for_two_is_replaced_when_the_loop_is_stuck() {
    // Both hidden effects put energy at the shaft rate, and round 1 applies an unbalance that
    // takes the place of both. Round 2 finds nothing to add but is far above its floor: the
    // loop must replace the unbalance by the runner-up of round 1 (misalignment), lowering the
    // objective, and must end without the unbalance.
    // The table's options and 10 s record. The candidates leave out casing_modes (the
    // costliest trial), sensor_response and slip, none of which is in the table's top three of
    // round 1 or 2. Cut further, to the four effects that matter, misalignment joins round 2's
    // three stage-2 re-fits, which lower the unbalance to 7.9e-4 kg·m, and is applied beside it:
    // the loop then ends with the unbalance still on (a false claim) but no replacement needed.
    // Unbending is off: round 1's calibration pins a parameter, and trials that also start from
    // the uncalibrated values apply the misalignment at once (42.5 N, envelope NRMSE 13.5 →
    // 1.1 %; README "Two hidden effects"), so no replacement would be needed. This test is about
    // the replacement step. It runs with one model realisation, as the table did: with two,
    // round 1 applies a rough extended fault instead of the unbalance
    // (objective 24.7 → 14.8, 43 %), round 2 replaces it by the misalignment the same way, and
    // the loop ends as here, with the misalignment and no false claim. The force scan and the
    // fine force fit (the defaults since session 40) are off too: with the scan, round 1's
    // plain trial fits the misalignment itself and there is no stand-in to replace (the next
    // test; docs/loop-notebook.md "Scanned forces by default?").
    // The second start for the top trials (the default since session 48) is off too: with it round 1 takes the
    // misalignment (42.47 N for 42.62 N) and round 2 the path modulation (0.307 for 0.342),
    // the pair complete with no stand-in (docs/loop-notebook.md "A second start for the top
    // trials as the default: the suite").
    let r = replacement_pair(LoopOptions { scan_force_amplitudes: false, fine_forces: false, uncalibrated_start_top: false, ..Default::default() });
    let steps: Vec<_> = r.history.iter().map(|h| (h.objective, h.floor_objective, h.change("-"), h.verdict.clone())).collect();
    eprintln!("true {:?}, SNR {:.1} dB; rounds {steps:#?}", r.true_parameters, r.snr_db);
    assert_eq!(r.history[0].applied, Some(EffectKind::Unbalance), "round 1: {}", r.history[0].verdict);
    // The history records that round 1's calibration pinned a parameter (why unbending, off
    // here, changes this case).
    assert!(!r.history[0].pinned.is_empty(), "round 1 pinned nothing");
    let i = r.history.iter().position(|h| h.removed.is_some()).unwrap_or_else(|| panic!("no replacement: {steps:#?}"));
    assert_eq!((r.history[i].removed, r.history[i].applied), (Some(EffectKind::Unbalance), Some(EffectKind::Misalignment)), "{}", r.history[i].verdict);
    assert!(r.history[i + 1].objective < r.history[i].objective, "{steps:#?}");
    // Each round records the values it put in: round 1 the unbalance as its trial fitted it
    // (6.8e-3 kg·m, 7× the hidden range: it stands in for both), the replacement the
    // misalignment force as the calibration fitted it.
    let values: Vec<_> = r.history.iter().map(|h| h.change_with_values("-")).collect();
    eprintln!("{values:#?}");
    match r.history[0].applied_values[..] {
        [(Param::UnbalanceKgM, u)] => assert!(u > 2e-3, "round 1 unbalance {u:.3e} kg·m"),
        ref v => panic!("round 1 values {v:?}"),
    }
    match r.history[i].applied_values[..] {
        [(Param::Misalignment2xN, f)] => assert!(f > 1.0 && f < 1000.0, "replacement force {f} N"),
        ref v => panic!("replacement values {v:?}"),
    }
    assert!(r.false_claims.is_empty(), "false claims {:?}", r.false_claims);
    assert!(r.applied.contains(&EffectKind::Misalignment), "applied {:?}", r.applied);
}

/// The replacement test's pair (seed 2402, path_modulation + misalignment on the gear base, 10
/// s, three rounds) in its setting — one realisation, unbending off, seven candidates
/// (casing_modes, sensor_response and slip left out for time) — over `opts` otherwise.
fn replacement_pair(opts: LoopOptions) -> hidden::MultiCaseResult {
    use EffectKind::*;
    let opts = LoopOptions { realisations: 1, unbend_pinned: false, candidates: vec![Unbalance, Misalignment, PathModulation, ExtendedFault, ToothFault, BeltDrive, SpeedFluctuation], ..opts };
    hidden::run_multi_case(&model::preset("mfs_healthy").unwrap(), &[PathModulation, Misalignment], REPLACEMENT_SEED, 10.0, 3, &opts).unwrap()
}

/// The replacement test's pair and setting (seed 2402, unbending off, seven candidates, one
/// realisation) with the force scan and the fine force fit of the default: round 1's plain
/// trial fits the misalignment itself (a golden section alone closes on the unbalance that
/// stands in for both), and the force, fitted to within about 1 %, leaves no error for a
/// second force to stand in for. With the scan alone, round 2 applied an unbalance never
/// hidden (1.09e-4 kg·m; docs/loop-notebook.md "Scanned forces by default?").
#[test]
fn with_scanned_and_fine_forces_the_pair_needs_no_replacement_and_ends_without_a_false_claim() {
    let opts = LoopOptions::default();
    assert!(opts.scan_force_amplitudes && opts.fine_forces, "the defaults this test is about");
    let r = replacement_pair(opts);
    let steps: Vec<_> = r.history.iter().map(|h| (h.objective, h.floor_objective, h.change_with_values("-"), h.verdict.clone())).collect();
    eprintln!("true {:?}, SNR {:.1} dB; rounds {steps:#?}", r.true_parameters, r.snr_db);
    assert_eq!(r.history[0].applied, Some(EffectKind::Misalignment), "round 1: {}", r.history[0].verdict);
    let true_force = r.true_parameters.iter().find(|t| t.0 == Param::Misalignment2xN).unwrap().1;
    match r.history[0].applied_values[..] {
        [(Param::Misalignment2xN, f)] => assert!((f / true_force - 1.0).abs() < 0.05, "round 1 force {f:.2} N for {true_force:.2}"),
        ref v => panic!("round 1 values {v:?}"),
    }
    assert!(r.history.iter().all(|h| h.removed.is_none()), "a replacement: {steps:#?}");
    assert!(r.false_claims.is_empty(), "false claims {:?}: {steps:#?}", r.false_claims);
}

/// A hidden-effect case on the MFS inner-race rig, as `confusion --hide` draws it, with 10 s
/// of "measurement": (model, measurement, true parameters, SNR dB).
fn ten_second_case(hidden_effects: &[EffectKind], seed: u64) -> (model::Machine, twinscope::signal::Signal, Vec<(Param, f64)>, f64) {
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, model_m, true_params, snr) = hidden::make_case_hiding(&base, hidden_effects, seed);
    truth.duration_s = 10.0;
    (model_m, model::simulate(&truth).unwrap(), true_params, snr)
}

/// Seed 2302 of the pair table (casing_modes + misalignment, 5.6 dB): the calibration drives
/// the fault depth to the floor of its range (5 µm, from 100 µm) and the damping up, and from
/// that bent model no trial explains anything (misalignment: 0 %, README "Two hidden
/// effects"). The calibration flags the pinned depth; with `unbend_pinned` the trials start
/// from the uncalibrated values with a grid scan of their effect, and the misalignment, the
/// larger of the two hidden effects, is found with its force near the truth.
#[test]
fn trials_from_the_uncalibrated_values_find_what_a_bent_calibration_hides() {
    let (model_m, measured, true_params, snr) = ten_second_case(&[EffectKind::CasingModes, EffectKind::Misalignment], 2302);
    let opts = LoopOptions { unbend_pinned: true, candidates: vec![EffectKind::Misalignment, EffectKind::Unbalance, EffectKind::ExtendedFault, EffectKind::CasingModes], ..Default::default() };
    let (_, d) = twinscope::compare::diagnose(&model_m, &measured, &opts, &|_, _| true).unwrap();
    eprintln!("true {true_params:?}, SNR {snr:.1} dB; pinned {:?}; {}", d.calibration.at_bound, d.verdict);
    for t in &d.trials {
        eprintln!("  {:<16} {:.3} ({:.0} %) {:?}", t.effect.name(), t.objective_after, t.explained * 100.0, t.parameter);
    }
    assert!(d.calibration.at_bound.iter().any(|b| b.0 == Param::FaultDepthM), "the bent depth is flagged: {:?}", d.calibration.at_bound);
    assert!(d.unbent);
    assert_eq!(d.best, Some(EffectKind::Misalignment), "{}", d.verdict);
    let force = d.trials[0].parameter.unwrap().1;
    let true_force = true_params.iter().find(|p| p.0 == Param::Misalignment2xN).unwrap().1;
    assert!((force / true_force - 1.0).abs() < 0.25, "fitted {force:.1} N, true {true_force:.1} N");
}

/// A calibration can bend the base parameters toward a missing effect without pinning any:
/// on the belt_drive + load_zone case (seed 2300) the calibration without either puts the
/// resonance damping at 0.0107, 2.1 % of its range above the 0.01 edge (the "pinned" band is
/// 2 %), so no trial is unbent, and the load zone fitted from there takes about 6 N against
/// a true 77 N. With `uncalibrated_start` the trial also starts from the uncalibrated values
/// with the load scanned, and that fit is the better one (README "Two hidden effects").
#[test]
fn an_uncalibrated_start_finds_the_load_a_bent_but_unpinned_calibration_hides() {
    let (model_m, measured, true_params, snr) = ten_second_case(&[EffectKind::BeltDrive, EffectKind::LoadZone], 2300);
    let true_load = true_params.iter().find(|p| p.0 == Param::RadialLoadN).unwrap().1;
    let run = |uncalibrated_start: bool, recalibrate_top: usize| {
        // Without the second start for the top trials, which starts this one trial from the
        // uncalibrated values too (below).
        let opts = LoopOptions { uncalibrated_start, recalibrate_top, candidates: vec![EffectKind::LoadZone], random_effect_realisations: 0, uncalibrated_start_top: false, ..Default::default() };
        let (cal, d) = twinscope::compare::diagnose(&model_m, &measured, &opts, &|_, _| true).unwrap();
        eprintln!("uncalibrated_start {uncalibrated_start}: true load {true_load:.1} N, SNR {snr:.1} dB; pinned {:?}; {}", d.calibration.at_bound, d.verdict);
        assert!(d.calibration.at_bound.is_empty() && !d.unbent, "the calibration pinned {:?}", d.calibration.at_bound);
        // Applied to the calibrated model (what the loop and the app's "Add" do), the trial
        // gives the machine it was scored with, whichever start won.
        let t = d.trials[0].clone();
        let mut added = cal.clone();
        twinscope::compare::apply_trial(&mut added, &t);
        let reference = twinscope::compare::Reference::new(&measured, &opts.compare).unwrap();
        let (c, _) = twinscope::compare::evaluate(&added, &reference, &opts).unwrap();
        let j = twinscope::compare::objective(&c, &opts.weights);
        assert!((j - t.objective_after).abs() <= 1e-9 * t.objective_after, "applied: {j:.4}, the trial scored {:.4} (from the uncalibrated values: {})", t.objective_after, t.from_uncalibrated);
        let reported: Vec<_> = t.parameter.iter().chain(&t.extra_parameters).map(|p| p.0).collect();
        let distinct: std::collections::HashSet<_> = reported.iter().collect();
        assert_eq!(distinct.len(), reported.len(), "each parameter reported once: {reported:?}");
        t
    };
    let top = LoopOptions::default().recalibrate_top;
    let plain = run(false, top);
    let started = run(true, top);
    // Without stage 2's re-fit of every calibrated parameter, too, the trial from the
    // uncalibrated values carries the values it was scored with.
    assert!(run(true, 0).from_uncalibrated);
    let load = |t: &twinscope::compare::EffectTrial| t.parameter.unwrap().1;
    assert!(load(&plain) < 0.3 * true_load, "from the bent calibration the load takes {:.1} N (true {true_load:.1} N)", load(&plain));
    assert!((0.5..2.0).contains(&(load(&started) / true_load)), "from the uncalibrated values {:.1} N, true {true_load:.1} N", load(&started));
    assert!(started.objective_after < 0.8 * plain.objective_after, "{:.2} against {:.2}", started.objective_after, plain.objective_after);
    assert!(!plain.from_uncalibrated && started.from_uncalibrated, "the trial says which start won");
    // The second start for the top trials (`LoopOptions::uncalibrated_start_top`, the
    // default since session 48) gives the top trials alone that start: here the load zone's, which wins
    // (86.5 N for 76.9 N in session 47), in a search that is not unbent.
    let opts = LoopOptions { uncalibrated_start_top: true, candidates: vec![EffectKind::LoadZone], random_effect_realisations: 0, ..Default::default() };
    let (_, d) = twinscope::compare::diagnose(&model_m, &measured, &opts, &|_, _| true).unwrap();
    eprintln!("second start for the top trials: {}", d.verdict);
    assert!(!d.unbent && d.best == Some(EffectKind::LoadZone), "{}", d.verdict);
    assert_eq!(d.top_second_starts_won, vec![EffectKind::LoadZone]);
    assert!(d.trials[0].from_uncalibrated);
    assert!((0.8..1.25).contains(&(load(&d.trials[0]) / true_load)), "with the second start for the top trials {:.1} N, true {true_load:.1} N", load(&d.trials[0]));
}

/// The stuck-round re-fit (`LoopOptions::refit_when_stuck`) on the belt case's round 1: the
/// load zone applied as the bent calibration fitted it (a few newtons) is fitted anew from the
/// uncalibrated values, lands near the true 77 N, and the model scores better; every evaluation
/// it makes is expected.
#[test]
fn a_load_applied_from_a_bent_calibration_is_refitted_from_the_uncalibrated_values() {
    use twinscope::compare::diagnose::refit_from_uncalibrated;
    let (model_m, measured, true_params, _) = ten_second_case(&[EffectKind::BeltDrive, EffectKind::LoadZone], 2300);
    let true_load = true_params.iter().find(|p| p.0 == Param::RadialLoadN).unwrap().1;
    // The search without the second start for the top trials, which fits this load from the
    // uncalibrated values at once (see the test above): the bent fit is what is re-fitted here.
    let opts = LoopOptions { candidates: vec![EffectKind::LoadZone], random_effect_realisations: 0, uncalibrated_start_top: false, ..Default::default() };
    let (cal, d) = twinscope::compare::diagnose(&model_m, &measured, &opts, &|_, _| true).unwrap();
    let mut applied = cal.clone();
    twinscope::compare::apply_trial(&mut applied, &d.trials[0]);
    let load = |m: &model::Machine| Param::RadialLoadN.get(m).unwrap();
    assert!(load(&applied) < 0.3 * true_load, "applied at {:.1} N (true {true_load:.1} N)", load(&applied));
    let reference = twinscope::compare::Reference::new(&measured, &opts.compare).unwrap();
    let score = |m: &model::Machine| twinscope::compare::objective(&twinscope::compare::evaluate(m, &reference, &opts).unwrap().0, &opts.weights);
    let (calls, expected) = (std::sync::atomic::AtomicUsize::new(0), std::sync::atomic::AtomicUsize::new(0));
    let counting = |_done: usize, total: usize| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        expected.store(total, std::sync::atomic::Ordering::Relaxed);
        true
    };
    let refitted = refit_from_uncalibrated(&applied, &model_m, EffectKind::LoadZone, &reference, &opts, &twinscope::compare::LoopProgress::new(&counting)).unwrap();
    eprintln!("load {:.1} N → {:.1} N (true {true_load:.1} N); objective {:.2} → {:.2}", load(&applied), load(&refitted), score(&applied), score(&refitted));
    assert!((0.5..2.0).contains(&(load(&refitted) / true_load)), "re-fitted at {:.1} N, true {true_load:.1} N", load(&refitted));
    assert!(score(&refitted) < score(&applied), "{:.2} against {:.2}", score(&refitted), score(&applied));
    // The base's calibration parameters are back at the first model's values (the re-fit
    // moves only the effect's parameters and the noise level), where the calibration had bent
    // the resonance (README "Two hidden effects": 1300 → 1175 Hz).
    let hz = |m: &model::Machine| Param::ResonanceHz.get(m).unwrap();
    assert_eq!(hz(&refitted), hz(&model_m));
    assert!((hz(&cal) - hz(&model_m)).abs() > 50.0, "calibrated {:.0} Hz, first model {:.0} Hz", hz(&cal), hz(&model_m));
    assert_eq!(calls.into_inner(), expected.into_inner());
}

/// Every evaluation of the second start is expected and reported.
#[test]
fn an_uncalibrated_start_expects_exactly_the_evaluations_it_makes() {
    let (m, measured, mut opts) = quick_case(15, vec![EffectKind::LoadZone, EffectKind::CasingModes]);
    opts.uncalibrated_start = true;
    let (d, calls, expected) = diagnose_counting(&m, &measured, &opts);
    assert!(!d.unbent, "the calibration pinned {:?}: unbending supersedes the lighter start", d.calibration.at_bound);
    assert_eq!(d.trials.len(), 2);
    // Without any second start (the second start for the top trials gives these two trials,
    // both among the top three, the same one).
    let (_, _, plain) = diagnose_counting(&m, &measured, &LoopOptions { uncalibrated_start: false, uncalibrated_start_top: false, ..opts.clone() });
    assert!(expected > plain, "{expected} evaluations with the second start, {plain} without");
    assert_eq!(calls, expected);
}

/// A random effect fitted against one draw of the model is biased low: the error against a
/// single realisation holds the model's own scatter, which grows with the effect, so the fit
/// trades true slip for less scatter. Against the mean spectra of several realisations
/// (`LoopOptions::realisations`), with their own scatter taken out of the error, the fit
/// follows the truth (docs/loop-notebook.md "Detection limits").
#[test]
fn slip_is_fitted_to_its_expected_spectrum_with_several_realisations() {
    let mut truth = model::preset("mfs_inner").unwrap();
    truth.effects.enable(EffectKind::Slip);
    truth.effects.enable(EffectKind::Noise);
    Param::SlipPercent.set(&mut truth, 5.0);
    Param::NoiseSnrDb.set(&mut truth, 10.0);
    truth.duration_s = 2.0;
    truth.seed = 3100;
    let measured = model::simulate(&truth).unwrap();
    let mut start = truth.clone();
    start.seed = 77;
    Param::SlipPercent.set(&mut start, 1.0);
    let fitted = |k: usize| {
        let opts = LoopOptions { realisations: k, ..Default::default() };
        let reference = Reference::new(&measured, &opts.compare).unwrap();
        let (m, f) = fit(&start, &reference, &[Param::SlipPercent], 1, &opts).unwrap();
        let slip = Param::SlipPercent.get(&m).unwrap();
        eprintln!("K = {k}: slip {slip:.2} %, objective {:.2} → {:.2}", f.objective_before, f.objective_after);
        slip
    };
    // On this draw, 2.95, 4.11, 4.45 and 5.30 % for 1, 2, 4 and 8 realisations. Before the
    // objective took the mean's own scatter out (DomainComparison::debiased_nrmse_percent),
    // 2, 4 and 8 gave 3.52, 3.80 and 4.67 %: the bias fell as 1/K; now most of it is gone at
    // K = 2 (one realisation has no scatter estimate and keeps the bias).
    let (one, two, eight) = (fitted(1), fitted(2), fitted(8));
    assert!(one < 3.5, "one realisation: {one} % for a true 5 % (the bias this test documents)");
    assert!(two > one + 0.75 && (two - 5.0).abs() < 1.0, "two realisations: {two} % for a true 5 % (one: {one} %)");
    assert!((eight - 5.0).abs() < 0.75 && eight > one + 1.0, "eight realisations: {eight} % for a true 5 % (one: {one} %)");
}

/// With two or more realisations a diagnosis judges the calibrated model and every trial on
/// realisations no fit used ([`diagnose::HELD_OUT_SALT`]); with one it judges them on the fit.
#[test]
fn with_several_realisations_the_trials_are_judged_on_held_out_realisations() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use twinscope::compare::{calibrate, diagnose};
    let (m, measured, opts1) = quick_case(12, vec![EffectKind::Slip, EffectKind::LoadZone]);
    let (_, d1) = twinscope::compare::diagnose(&m, &measured, &opts1, &|_, _| true).unwrap();
    assert_eq!(d1.held_out_objective, None);
    assert_eq!(d1.judged_objective(), d1.calibration.objective_after);
    for t in &d1.trials {
        assert_eq!(t.objective_fitted, None);
        assert_eq!(t.objective_before, d1.calibration.objective_after, "{}", t.effect.name());
    }

    let opts2 = LoopOptions { realisations: 2, ..opts1.clone() };
    let calls = AtomicUsize::new(0);
    let expected = AtomicUsize::new(0);
    let (cal_m, d2) = twinscope::compare::diagnose(&m, &measured, &opts2, &|_, e| {
        calls.fetch_add(1, Ordering::SeqCst);
        expected.store(e, Ordering::SeqCst);
        true
    })
    .unwrap();
    // One evaluation more for the calibrated model and one per trial, all counted.
    assert_eq!(calls.load(Ordering::SeqCst), expected.load(Ordering::SeqCst));
    // The held-out objective is the calibrated machine evaluated under the held-out salt.
    let reference = Reference::new(&measured, &opts2.compare).unwrap();
    let mut held = cal_m.clone();
    held.seed ^= diagnose::HELD_OUT_SALT;
    let j_held = calibrate::objective(&calibrate::evaluate(&held, &reference, &opts2).unwrap().0, &opts2.weights);
    assert_eq!(d2.held_out_objective, Some(j_held));
    assert_eq!(d2.judged_objective(), j_held);
    assert_ne!(j_held, d2.calibration.objective_after, "other realisations give another objective");
    assert_eq!(d2.trials.len(), 2);
    for t in &d2.trials {
        let fitted = t.objective_fitted.expect("judged on held-out realisations");
        assert_ne!(fitted, t.objective_after, "{}", t.effect.name());
        assert_eq!(t.objective_before, j_held);
        let excess = j_held - d2.floor_objective;
        let explained = if excess > 0.0 { (j_held - t.objective_after) / excess } else { 0.0 };
        assert!((t.explained - explained).abs() < 1e-12, "{} against {explained}", t.explained);
        assert!(t.summary.contains(&format!("objective {j_held:.1} → {:.1}", t.objective_after)), "{}", t.summary);
    }
}

/// The second look for random effects (`LoopOptions::random_effect_realisations`): a search
/// with one realisation that ranks a random effect first is done again with K realisations,
/// and that diagnosis, exactly, is the answer, with the first one's verdict kept; a search led
/// by a deterministic effect, or already with several realisations, is left as it is.
#[test]
fn a_random_effect_that_leads_with_one_realisation_gets_a_second_look_with_several() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use twinscope::compare::diagnose;
    let strip = |mut d: twinscope::compare::Diagnosis| {
        d.second_look = None;
        d.verdict.clear();
        d
    };
    // Slip the only candidate: it leads, so the second look is taken.
    let (m, measured, base) = quick_case(12, vec![EffectKind::Slip]);
    let looked = LoopOptions { random_effect_realisations: 2, ..base.clone() };
    let (calls, expected) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let (cal, d) = diagnose(&m, &measured, &looked, &|_, e| {
        calls.fetch_add(1, Ordering::SeqCst);
        expected.store(e, Ordering::SeqCst);
        true
    })
    .unwrap();
    assert_eq!(calls.load(Ordering::SeqCst), expected.load(Ordering::SeqCst), "both searches are counted");
    let (_, one) = diagnose(&m, &measured, &base, &|_, _| true).unwrap();
    let (cal2, two) = diagnose(&m, &measured, &LoopOptions { realisations: 2, ..base.clone() }, &|_, _| true).unwrap();
    let look = d.second_look.clone().expect("slip led with one realisation");
    assert_eq!((look.realisations, look.leader), (2, EffectKind::Slip));
    assert_eq!(look.verdict_with_one, one.verdict);
    assert!(d.verdict.starts_with(&two.verdict) && d.verdict.contains("second look with 2 realisations"), "{}", d.verdict);
    assert!(d.held_out_objective.is_some(), "judged held out, as any diagnosis with two");
    // Each decision records the floor ratio it needed: 1.15 with one realisation, √1.645 with
    // two (the default margin 0.15).
    assert!((one.floor_ratio_needed - 1.15).abs() < 1e-12, "{}", one.floor_ratio_needed);
    assert!((d.floor_ratio_needed - 1.645f64.sqrt()).abs() < 1e-12, "{}", d.floor_ratio_needed);
    assert_eq!(cal, cal2);
    assert_eq!(strip(d), strip(two));
    // A deterministic leader, or several realisations already: no second look.
    let (m, measured, base) = quick_case(12, vec![EffectKind::LoadZone]);
    let (_, d) = diagnose(&m, &measured, &LoopOptions { random_effect_realisations: 2, ..base.clone() }, &|_, _| true).unwrap();
    let (_, plain) = diagnose(&m, &measured, &base, &|_, _| true).unwrap();
    assert_eq!(d, plain);
    let (m, measured, base) = quick_case(12, vec![EffectKind::Slip]);
    let two = LoopOptions { realisations: 2, ..base };
    let (_, d) = diagnose(&m, &measured, &LoopOptions { random_effect_realisations: 4, ..two.clone() }, &|_, _| true).unwrap();
    assert_eq!(d.second_look, None);
    assert!(EffectKind::Slip.draws_at_random() && EffectKind::ExtendedFault.draws_at_random() && !EffectKind::LoadZone.draws_at_random());
    // Out of range is refused before any simulation.
    assert!(diagnose(&m, &measured, &LoopOptions { random_effect_realisations: 17, ..two }, &|_, _| panic!("no evaluation")).is_err());
}

/// The optimiser's curse that held-out judging answers. With two realisations the objective
/// subtracts their sample variance, an estimate with one degree of freedom per bin, and a fit
/// that moves a random effect can find values where that term happens to be large. On a
/// slip-free case (the held-out pair whose K = 2 loop claimed a slip, docs/loop-notebook.md "Detection
/// limits", with both hidden effects given to the model) the slip fit raises the slip off its
/// minimum and lowers its own objective (0.64 %, 4.15 → 4.03), while on realisations the fit
/// did not use the fitted slip makes the model worse (4.24 → 4.45).
#[test]
fn a_slip_fitted_on_two_realisations_is_exposed_on_held_out_ones() {
    use twinscope::compare::{calibrate, diagnose};
    // The pair's case (seed 2503 of `confusion --hide speed_fluctuation+misalignment`): speed
    // fluctuation 1.64 %, misalignment 41.5 N, 15 dB, perturbed baseline; the model gets both
    // effects at their true values on the unperturbed baseline, and slip at its minimum.
    let case_seed = 2503;
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, mut start, truths, _snr) = hidden::make_case_set(&base, &[EffectKind::SpeedFluctuation, EffectKind::Misalignment], case_seed, &hidden::CaseSetting::default());
    truth.duration_s = 10.0;
    let measured = model::simulate(&truth).unwrap();
    for (p, v) in &truths {
        start.effects.enable(if *p == Param::Misalignment2xN { EffectKind::Misalignment } else { EffectKind::SpeedFluctuation });
        p.set(&mut start, *v);
    }
    start.effects.enable(EffectKind::Slip);
    Param::SlipPercent.set(&mut start, 0.2);
    let opts = LoopOptions { realisations: 2, ..Default::default() };
    let reference = Reference::new(&measured, &opts.compare).unwrap();
    let (fitted, f) = fit(&start, &reference, &[Param::SlipPercent], 2, &opts).unwrap();
    let slip = Param::SlipPercent.get(&fitted).unwrap();
    let held = |m: &model::Machine| {
        let mut h = m.clone();
        h.seed ^= diagnose::HELD_OUT_SALT;
        calibrate::objective(&calibrate::evaluate(&h, &reference, &opts).unwrap().0, &opts.weights)
    };
    let (held_start, held_fitted) = (held(&start), held(&fitted));
    eprintln!("slip {slip:.3} %, fit objective {:.3} → {:.3}, held out {held_start:.3} → {held_fitted:.3}", f.objective_before, f.objective_after);
    assert!(slip > 0.3 && f.objective_after < f.objective_before - 0.03, "the fit adds slip the case does not have: {slip} %, {} → {}", f.objective_before, f.objective_after);
    assert!(held_fitted > held_start, "held out, the fitted slip must not look better: {held_start} → {held_fitted}");
}

/// A periodic force's objective has a narrow minimum among dips decades away (docs/loop-notebook.md "A bent
/// calibration that pins nothing"): the fresh pair unbalance + misalignment (seed 3805) with a
/// strong 120 N misalignment; the true machine without it, re-seeded, gets the misalignment
/// trial's fit. The golden section over the force's four decades closes on a dip near 20 N;
/// scanned on a grid first (`LoopOptions::scan_force_amplitudes`), the force lands within a
/// factor 1.5 of the truth and the objective falls to under half.
#[test]
fn a_scanned_force_finds_the_narrow_minimum_a_line_search_misses() {
    use twinscope::compare::calibrate::{fit_trial, fit_trial_scanning, LoopProgress};
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, _, _, _) = hidden::make_case_hiding(&base, &[EffectKind::Unbalance, EffectKind::Misalignment], 3805);
    truth.duration_s = 2.0;
    let true_force = 120.0;
    Param::Misalignment2xN.set(&mut truth, true_force);
    let measured = model::simulate(&truth).unwrap();
    let opts = LoopOptions { random_effect_realisations: 0, ..Default::default() };
    let reference = Reference::new(&measured, &opts.compare).unwrap();
    let mut start = truth.clone();
    start.seed ^= 7919;
    // The force at the value an enabled effect starts from, as in a trial.
    start.effects.disable(EffectKind::Misalignment);
    start.effects.enable(EffectKind::Misalignment);
    let progress = LoopProgress::new(&|_, _| true);
    let params = [Param::Misalignment2xN];
    let refine = [Param::NoiseSnrDb];
    let (golden_m, golden) = fit_trial(&start, &reference, &params, &refine, &opts, &progress).unwrap();
    let (scanned_m, scanned) = fit_trial_scanning(&start, &reference, &params, &refine, &params, &opts, &progress).unwrap();
    let (g, s) = (Param::Misalignment2xN.get(&golden_m).unwrap(), Param::Misalignment2xN.get(&scanned_m).unwrap());
    eprintln!("true {true_force} N; golden section {g:.1} N ({:.2}); scanned {s:.1} N ({:.2})", golden.objective_after, scanned.objective_after);
    assert!((1.0 / 1.5..1.5).contains(&(s / true_force)), "scanned: {s:.1} N, true {true_force} N");
    assert!(scanned.objective_after < 0.5 * golden.objective_after, "scanned {:.3} against {:.3}", scanned.objective_after, golden.objective_after);
}

#[test]
fn a_scanned_force_trial_expects_exactly_the_evaluations_it_makes() {
    let (m, measured, mut opts) = quick_case(17, vec![EffectKind::Unbalance, EffectKind::LoadZone]);
    opts.scan_force_amplitudes = true;
    let (d, calls, expected) = diagnose_counting(&m, &measured, &opts);
    assert_eq!(d.trials.len(), 2);
    let (_, _, plain) = diagnose_counting(&m, &measured, &LoopOptions { scan_force_amplitudes: false, ..opts.clone() });
    assert!(expected > plain, "{expected} evaluations with the scan, {plain} without");
    assert_eq!(calls, expected);
}

/// A hidden load zone (seed 19) that the only candidate `k` cannot explain: the model
/// without it, the one-second measurement, and [`quick_case`]'s options.
fn hidden_load_zone_case(k: EffectKind) -> (model::Machine, twinscope::signal::Signal, LoopOptions) {
    let (m, _, opts) = quick_case(19, vec![k]);
    let (mut truth, model_m, _, _) = hidden::make_case(&m, Some(EffectKind::LoadZone), 19);
    truth.duration_s = 1.0;
    (model_m, model::simulate(&truth).unwrap(), opts)
}

/// `d` found nothing, is still above its floor margin (stuck), and neither unbent nor pinned
/// anything: only `LoopOptions::unbend_when_stuck` unbends it.
fn assert_stuck_pinning_nothing(d: &twinscope::compare::Diagnosis) {
    assert!(d.best.is_none() && !d.unbent, "{}", d.verdict);
    assert!(d.calibration.at_bound.is_empty(), "the calibration pinned {:?}: unbending would act anyway", d.calibration.at_bound);
    assert!(d.floor_ratio_needed > 1.0 && d.judged_objective() >= d.floor_ratio_needed * d.floor_objective, "not stuck: {:.2} against a floor of {:.2} (ratio needed {:.2})", d.judged_objective(), d.floor_objective, d.floor_ratio_needed);
}

/// `LoopOptions::unbend_when_stuck`: a hidden load zone the only candidate (an unbalance) cannot
/// explain leaves the diagnosis stuck with a calibration that pins nothing; with the option
/// the search is done again with every trial also from the uncalibrated values, says so, and
/// every evaluation of both searches is expected; without it, one search.
#[test]
fn a_stuck_diagnosis_is_done_again_unbent_and_expects_every_evaluation() {
    let (model_m, measured, mut opts) = hidden_load_zone_case(EffectKind::Unbalance);
    let (plain, plain_calls, plain_expected) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("plain: pinned {:?}; {}", plain.calibration.at_bound, plain.verdict);
    assert!(plain.trials.len() == 1, "{}", plain.verdict);
    assert_stuck_pinning_nothing(&plain);
    assert_eq!(plain_calls, plain_expected);
    opts.unbend_when_stuck = true;
    let (again, calls, expected) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("unbend when stuck: {}", again.verdict);
    assert!(again.unbent && again.verdict.contains("started again from the uncalibrated values"), "{}", again.verdict);
    // The JSON says so without parsing the verdict, and keeps the plain search's.
    assert_eq!((plain.stuck_plain_verdict.as_deref(), again.stuck_plain_verdict.as_deref()), (None, Some(plain.verdict.as_str())));
    let round = twinscope::compare::Round::of_diagnosis(1, model_m.effects.enabled(), &again, 0.0);
    assert!(round.unbent_when_stuck && !twinscope::compare::Round::of_diagnosis(1, model_m.effects.enabled(), &plain, 0.0).unbent_when_stuck);
    assert_eq!(calls, expected);
    // The second search: the plain one again without its calibrated start and its plain
    // trial (both taken over from the first), plus the unbalance trial from the uncalibrated
    // values (its force scanned, then one sweep with every calibration parameter).
    let unbent_start = unbent_start_evaluations(&model_m, EffectKind::Unbalance, &opts);
    let calibration = twinscope::compare::diagnose::calibration_evaluations(&model_m, &opts);
    let plain_trial = twinscope::compare::diagnose::plain_trial_evaluations(&model_m, EffectKind::Unbalance, &opts);
    // With `LoopOptions::uncalibrated_start_top` the plain search's unbalance trial also made
    // its second start, which the unbent search (every trial from the uncalibrated values)
    // does not repeat.
    let top = top_second_start_evaluations(&model_m, EffectKind::Unbalance, &opts);
    assert_eq!(
        calls,
        plain_calls + (plain_calls - calibration - plain_trial - top) + unbent_start,
        "the unbent search re-did the calibration ({calibration} evaluations) or the plain trial ({plain_trial}), or missed its second start ({unbent_start})"
    );
}

/// `LoopOptions::polish_second_starts` (experimental): off, the polish leaves an unbent trial's
/// second start (from the uncalibrated values) alone and polishes the calibration only. On
/// the stuck load-zone case unbent (see above), the two searches differ by exactly the polish
/// sweeps of that second start, each of its parameters one local line search per sweep, and
/// each expects exactly the evaluations it makes.
#[test]
fn without_polishing_second_starts_only_the_unbent_start_goes_unpolished() {
    let (model_m, measured, opts) = hidden_load_zone_case(EffectKind::Unbalance);
    let every = LoopOptions { unbend_when_stuck: true, polish_sweeps: 2, polish_second_starts: true, ..opts };
    let baselines = LoopOptions { polish_second_starts: false, ..every.clone() };
    let (a, calls_a, expected_a) = diagnose_counting(&model_m, &measured, &every);
    let (b, calls_b, expected_b) = diagnose_counting(&model_m, &measured, &baselines);
    assert!(a.unbent && b.unbent, "both searches unbent when stuck: {} / {}", a.verdict, b.verdict);
    assert_eq!((calls_a, calls_b), (expected_a, expected_b));
    // The calibration is polished in both: the same calibrated model.
    assert_eq!(a.calibration.objective_after, b.calibration.objective_after);
    let mut t = model_m.clone();
    t.effects.enable(EffectKind::Unbalance);
    let ps = twinscope::compare::diagnose::recalibration_parameters(EffectKind::Unbalance, &t, &every);
    let second_start = |o: &LoopOptions| unbent_start_evaluations(&model_m, EffectKind::Unbalance, o);
    let fitted = ps.iter().filter(|p| p.get(&t).is_some()).count();
    assert!(fitted >= 4, "{ps:?}");
    assert_eq!(second_start(&every) - second_start(&LoopOptions { polish_sweeps: 0, ..every.clone() }), 2 * fitted * 3);
    assert_eq!(calls_a - calls_b, 2 * fitted * 3, "the polish of the unbent start ({fitted} parameters, 2 sweeps, 3 evaluations each)");
}

/// The evaluations of the second start `LoopOptions::uncalibrated_start_top` gives effect `k`'s
/// trial in a plain search on `model_m` when `opts` has it on (the trial one of the top three,
/// not re-doing the calibration), else 0.
fn top_second_start_evaluations(model_m: &model::Machine, k: EffectKind, opts: &LoopOptions) -> usize {
    if opts.uncalibrated_start_top { twinscope::compare::diagnose::scanned_start_evaluations(model_m, k, opts) } else { 0 }
}

/// The evaluations of effect `k`'s trial from the uncalibrated values on `model_m`: its main
/// parameter scanned, then one sweep with every calibration parameter (an unbent search's
/// second start), with `opts`' polish when `opts.polish_second_starts` lets it act there.
fn unbent_start_evaluations(model_m: &model::Machine, k: EffectKind, opts: &LoopOptions) -> usize {
    use twinscope::compare::{calibrate, diagnose};
    let mut t = model_m.clone();
    t.effects.enable(k);
    let scan: Vec<Param> = Param::main_of_effect(k).into_iter().collect();
    let polish_sweeps = if opts.polish_second_starts { opts.polish_sweeps } else { 0 };
    calibrate::fit_evaluations(&t, &diagnose::recalibration_parameters(k, &t, opts), &scan, 1, &LoopOptions { polish_sweeps, ..opts.clone() })
}

/// `LoopOptions::unbend_when_stuck` before the second look (session 31): a hidden load zone
/// that the only candidate, a slip, cannot explain leaves the one-realisation search stuck with
/// the slip leading. Without the option the second look (two realisations) follows it; with
/// the option the stuck search is first done again unbent, and the second look follows that
/// unbent search, unbent too — no plain search with two realisations is made. Every
/// evaluation is counted and expected.
#[test]
fn a_stuck_search_is_unbent_before_its_second_look() {
    use twinscope::compare::diagnose;
    let (model_m, measured, mut opts) = hidden_load_zone_case(EffectKind::Slip);
    // The one-realisation search alone, and the plain search with two.
    let (one, one_calls, _) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("one realisation: {}", one.verdict);
    assert!(one.trials.first().map(|t| t.effect) == Some(EffectKind::Slip), "{}", one.verdict);
    assert_stuck_pinning_nothing(&one);
    let two_opts = LoopOptions { realisations: 2, ..opts.clone() };
    let (_, two_calls, _) = diagnose_counting(&model_m, &measured, &two_opts);
    // Without the option: the second look follows the plain search.
    opts.random_effect_realisations = 2;
    let (looked, _, _) = diagnose_counting(&model_m, &measured, &opts);
    let look = looked.second_look.clone().expect("the slip led: a second look");
    assert!(!looked.unbent && !look.verdict_with_one.contains("uncalibrated"), "{}", looked.verdict);
    // With it: plain, unbent, then the unbent second look.
    opts.unbend_when_stuck = true;
    let (d, calls, expected) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("unbent first: {}", d.verdict);
    assert_eq!(calls, expected);
    let look = d.second_look.clone().expect("the slip led the unbent search too: a second look");
    assert_eq!((look.realisations, look.leader), (2, EffectKind::Slip));
    assert!(d.unbent, "the second look was not unbent: {}", d.verdict);
    assert!(look.verdict_with_one.contains("started again from the uncalibrated values") && look.verdict_with_one.contains(&one.verdict), "the second look did not follow the unbent search: {}", look.verdict_with_one);
    assert_eq!(d.stuck_plain_verdict.as_deref(), Some(one.verdict.as_str()), "the second look lost the plain search's verdict");
    // The count: the plain one-realisation search; the unbent one without the calibrated start
    // and the plain slip trial it takes over, plus the slip trial from the uncalibrated values;
    // the search with two realisations (its own calibrated start and plain trial) plus the
    // same second start with two.
    let unbent_start = |o: &LoopOptions| unbent_start_evaluations(&model_m, EffectKind::Slip, o);
    let calibration = diagnose::calibration_evaluations(&model_m, &opts);
    let plain_trial = diagnose::plain_trial_evaluations(&model_m, EffectKind::Slip, &opts);
    // With `LoopOptions::uncalibrated_start_top` the plain searches (one and two realisations)
    // also made the slip's second start, which neither unbent search makes.
    let top = |o: &LoopOptions| top_second_start_evaluations(&model_m, EffectKind::Slip, o);
    assert_eq!(
        calls,
        one_calls + (one_calls - calibration - plain_trial - top(&opts) + unbent_start(&opts)) + (two_calls - top(&two_opts)) + unbent_start(&two_opts),
        "a plain search with two realisations was made, or an unbent start missed"
    );
}

/// The third path of `LoopOptions::unbend_when_stuck` (`diagnose_with`): a one-realisation
/// search that is *not* stuck (its leading random effect chosen), whose second look with two
/// realisations is stuck, is searched again unbent — the one-realisation search and then its
/// second look, both unbent, each taking over its own calibrated start and plain trial. The
/// hidden-load-zone case with slip the only candidate sits there when the significance is set
/// between what slip explains with one realisation (14 %) and with two (12 %).
#[test]
fn a_stuck_second_look_after_a_search_that_was_not_stuck_is_unbent_both_times() {
    use twinscope::compare::diagnose;
    let (model_m, measured, mut opts) = hidden_load_zone_case(EffectKind::Slip);
    // The search options before session 44 (no polish, each SCF slice by its own range, margin
    // 0.5): the case sits on this path only with them. With today's defaults the polished
    // calibration absorbs part of what slip explains (6 % against the 13 % set below), and the
    // one-realisation search does not choose it (README "Where the issue's acceptance stands").
    opts.polish_sweeps = 0;
    opts.polish_second_starts = true;
    opts.compare.scf_one_normaliser = false;
    opts.floor_margin = 0.5;
    // Nor the second start for the top trials (the default since session 48): with it the
    // two-realisation search chooses slip and is not stuck.
    opts.uncalibrated_start_top = false;
    opts.significance = 0.13;
    // Nor decision (d) (the default since session 57): the slip this path is built on stands
    // in for the hidden load zone, and switching it off again costs only 4 % of the excess;
    // (d) refuses it, so the one-realisation search would be stuck.
    opts.effect_must_work = false;
    let (one, one_calls, _) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("one realisation: {}", one.verdict);
    assert_eq!(one.best, Some(EffectKind::Slip), "the one-realisation search must choose slip (not stuck): {}", one.verdict);
    let two_opts = LoopOptions { realisations: 2, ..opts.clone() };
    let (two, two_calls, _) = diagnose_counting(&model_m, &measured, &two_opts);
    eprintln!("two realisations: {}", two.verdict);
    assert_stuck_pinning_nothing(&two);
    assert!(two.judged_objective() > diagnose::floor_ratio_needed(&two_opts) * two.floor_objective, "the second look must be stuck");
    opts.random_effect_realisations = 2;
    opts.unbend_when_stuck = true;
    let (d, calls, expected) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("unbent after the second look: {}", d.verdict);
    assert_eq!(calls, expected);
    assert!(d.unbent, "{}", d.verdict);
    let look = d.second_look.clone().expect("the unbent search's slip leads: a second look");
    assert_eq!((look.realisations, look.leader), (2, EffectKind::Slip));
    // The verdict is the unbent second look's, saying why it was made, and keeps what the
    // plain second look said (which itself names the plain one-realisation verdict).
    assert!(d.verdict.contains("a second look with 2 realisations: slip led with one"), "{}", d.verdict);
    assert!(d.verdict.contains("started again from the uncalibrated values") && d.verdict.contains(&two.verdict) && d.verdict.contains(&one.verdict), "{}", d.verdict);
    assert!(d.stuck_plain_verdict.as_deref().is_some_and(|v| v.starts_with(&two.verdict) && v.contains(&one.verdict)), "{:?}", d.stuck_plain_verdict);
    // The count: both plain searches (one and two realisations), then both again unbent, each
    // without its calibrated start and plain trial (taken over) but with the slip trial from
    // the uncalibrated values.
    let unbent_start = |o: &LoopOptions| unbent_start_evaluations(&model_m, EffectKind::Slip, o);
    let taken_over = |o: &LoopOptions| diagnose::calibration_evaluations(&model_m, o) + diagnose::plain_trial_evaluations(&model_m, EffectKind::Slip, o);
    assert_eq!(
        calls,
        one_calls + two_calls + (one_calls - taken_over(&opts) + unbent_start(&opts)) + (two_calls - taken_over(&two_opts) + unbent_start(&two_opts)),
        "a search was missed or made twice"
    );
}

/// `LoopOptions::fine_forces` (experimental): the objective's minimum in a periodic force's
/// amplitude is about 1 % wide, and a golden section of 9 evaluations over the force's four
/// decades ends within about ±18 % of it. On the true machine of the hidden pair belt drive +
/// misalignment (seed 4502), re-seeded, with its misalignment started 20 % low, the plain
/// line search leaves the force further off and the objective higher than the fine one (18
/// evaluations), which lands within 1 % of the truth. The evaluation count is exact.
#[test]
fn a_fine_force_search_lands_in_the_narrow_minimum_of_its_amplitude() {
    use twinscope::compare::calibrate::{fit, fit_evaluations};
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, _, truths, _) = hidden::make_case_set(&base, &[EffectKind::BeltDrive, EffectKind::Misalignment], 4502, &hidden::CaseSetting::default());
    truth.duration_s = 2.0;
    let measured = model::simulate(&truth).unwrap();
    let true_force = truths.iter().find(|t| t.0 == Param::Misalignment2xN).unwrap().1;
    let mut start = truth.clone();
    start.seed ^= 7919;
    Param::Misalignment2xN.set(&mut start, 0.8 * true_force);
    // The line search alone, without the experimental calibration polish (which would move
    // the force too), and without the fine force fit (the default since session 40).
    let plain = LoopOptions { random_effect_realisations: 0, polish_sweeps: 0, fine_forces: false, ..Default::default() };
    let fine = LoopOptions { fine_forces: true, ..plain.clone() };
    let reference = Reference::new(&measured, &plain.compare).unwrap();
    let params = [Param::Misalignment2xN];
    let (plain_m, plain_fit) = fit(&start, &reference, &params, 1, &plain).unwrap();
    let (fine_m, fine_fit) = fit(&start, &reference, &params, 1, &fine).unwrap();
    let (p, f) = (Param::Misalignment2xN.get(&plain_m).unwrap() / true_force, Param::Misalignment2xN.get(&fine_m).unwrap() / true_force);
    eprintln!("true {true_force:.2} N; plain {p:.4} × ({:.3}, {} evaluations); fine {f:.4} × ({:.3}, {} evaluations)", plain_fit.objective_after, plain_fit.evaluations, fine_fit.objective_after, fine_fit.evaluations);
    assert!((f - 1.0).abs() < 0.01, "fine: {f:.4} × the true force");
    assert!((p - 1.0).abs() > 2.0 * (f - 1.0).abs() && plain_fit.objective_after > fine_fit.objective_after, "plain {p:.4} × ({:.3}) against fine {f:.4} × ({:.3})", plain_fit.objective_after, fine_fit.objective_after);
    assert_eq!((plain_fit.evaluations, fine_fit.evaluations), (fit_evaluations(&start, &params, &[], 1, &plain), fit_evaluations(&start, &params, &[], 1, &fine)));
    assert_eq!(fine_fit.evaluations - 1, 2 * (plain_fit.evaluations - 1));
}

/// A broken tooth carries nothing: a tooth loss of exactly 1, the top of the loss's range,
/// which no golden-section probe reaches (its last bracket over 0.05–1 is about 6 % wide, and
/// near total loss the response changes fast with the last per cent of stiffness). A
/// full-range line search of a strength whose top is the physics' limit also tries that top
/// (docs/loop-notebook.md "A line search that also tries the physical top of its range").
/// Gear base, seed 9700 at 10 dB: from a loss of 0.5 the fit lands on 1 exactly, its
/// objective a fraction of the one at 0.96 (where the search stopped before); a loss inside
/// the range (0.55) is not pulled to the top. The evaluation count, with the top's
/// evaluation, is exact.
#[test]
fn a_broken_tooth_is_fitted_at_the_top_of_the_loss_range_the_golden_section_never_probes() {
    use twinscope::compare::calibrate::{evaluate, fit, fit_evaluations, objective};
    let base = model::preset("mfs_healthy").unwrap();
    let opts = LoopOptions { random_effect_realisations: 0, ..Default::default() };
    let params = [Param::ToothLoss];
    let fit_from_half = |loss: f64| {
        let setting = hidden::CaseSetting { value: Some(loss), snr_db: Some(10.0) };
        let (mut truth, _, _, _) = hidden::make_case_set(&base, &[EffectKind::ToothFault], 9700, &setting);
        truth.duration_s = 2.0;
        let measured = model::simulate(&truth).unwrap();
        let reference = Reference::new(&measured, &opts.compare).unwrap();
        let mut start = truth.clone();
        start.seed ^= 7919;
        start.duration_s = opts.fit_duration_s;
        Param::ToothLoss.set(&mut start, 0.5);
        let (fitted, report) = fit(&start, &reference, &params, 1, &opts).unwrap();
        assert_eq!(report.evaluations, fit_evaluations(&start, &params, &[], 1, &opts));
        let mut near = fitted.clone();
        Param::ToothLoss.set(&mut near, 0.96);
        let (c, _) = evaluate(&near, &reference, &opts).unwrap();
        (Param::ToothLoss.get(&fitted).unwrap(), report.objective_after, objective(&c, &opts.weights))
    };
    let (broken, j_broken, j_near) = fit_from_half(1.0);
    eprintln!("loss 1: fitted {broken} at {j_broken:.3}; 0.96 gives {j_near:.3}");
    assert_eq!(broken, 1.0, "a broken tooth fitted at a loss of {broken}");
    assert!(j_near > 1.5 * j_broken, "0.96 ({j_near:.3}) hardly worse than 1 ({j_broken:.3}): nothing for the top to find");
    let (inside, _, _) = fit_from_half(0.55);
    eprintln!("loss 0.55: fitted {inside}");
    assert!((inside / 0.55 - 1.0).abs() < 0.1, "a loss of 0.55 fitted at {inside}");
}

/// `LoopOptions::polish_sweeps` (experimental): two sweeps of coordinate descent over the full
/// ranges can stop far from the calibration's optimum, resonance and damping being coupled.
/// Seed 6803 of the bearing base (a hidden gear mesh at 1.0 dB the record does not show): the
/// plain calibration ends well above the model at the true parameters, and four polish sweeps
/// reach it (docs/loop-notebook.md "A calibration polish").
#[test]
fn a_polished_calibration_reaches_the_true_parameters_where_coordinate_descent_stops_short() {
    use twinscope::compare::calibrate::{calibration_parameters, evaluate, fit, fit_evaluations, objective};
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, model_m, _, _) = hidden::make_case(&base, Some(EffectKind::GearMesh), 6803);
    truth.duration_s = 2.0;
    let measured = model::simulate(&truth).unwrap();
    let plain = LoopOptions { random_effect_realisations: 0, polish_sweeps: 0, ..Default::default() };
    let polished = LoopOptions { polish_sweeps: 4, ..plain.clone() };
    let reference = Reference::new(&measured, &plain.compare).unwrap();
    // The model at the true base parameters (the hidden mesh, which the record does not show, off).
    let mut at_truth = truth.clone();
    at_truth.effects.gear_mesh = None;
    at_truth.seed = model_m.seed;
    at_truth.duration_s = model_m.duration_s;
    let (c, _) = evaluate(&at_truth, &reference, &plain).unwrap();
    let j_true = objective(&c, &plain.weights);
    let params = calibration_parameters(&model_m);
    let (plain_m, plain_fit) = fit(&model_m, &reference, &params, plain.sweeps, &plain).unwrap();
    let (polished_m, polished_fit) = fit(&model_m, &reference, &params, polished.sweeps, &polished).unwrap();
    let res = |m: &model::Machine| Param::ResonanceHz.get(m).unwrap();
    eprintln!(
        "true parameters {j_true:.2} (resonance {:.0} Hz); plain {:.2} ({:.0} Hz, {} evaluations); polished {:.2} ({:.0} Hz, {} evaluations)",
        res(&truth),
        plain_fit.objective_after,
        res(&plain_m),
        plain_fit.evaluations,
        polished_fit.objective_after,
        res(&polished_m),
        polished_fit.evaluations
    );
    assert!(plain_fit.objective_after > 1.15 * j_true, "the plain calibration {:.2} against {j_true:.2}: no shortfall to polish", plain_fit.objective_after);
    assert!(polished_fit.objective_after < 1.05 * j_true, "polished {:.2} against {j_true:.2} at the true parameters", polished_fit.objective_after);
    assert!((res(&polished_m) / res(&truth) - 1.0).abs() < 0.5 * (res(&plain_m) / res(&truth) - 1.0).abs(), "resonance: true {:.0}, plain {:.0}, polished {:.0} Hz", res(&truth), res(&plain_m), res(&polished_m));
    assert_eq!(polished_fit.evaluations, fit_evaluations(&model_m, &params, &[], polished.sweeps, &polished));
    assert_eq!(polished_fit.evaluations - plain_fit.evaluations, 4 * params.len() * 6);
}

/// The seed-8508 case of the bearing base (a hidden 46 N misalignment), measured for 2 s: the
/// model without it, the measurement, the true force (N), and options with the two forces as
/// the only candidates and no second look.
fn misalignment_case_8508() -> (model::Machine, twinscope::signal::Signal, f64, LoopOptions) {
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, model_m, true_param, _) = hidden::make_case(&base, Some(EffectKind::Misalignment), 8508);
    let (_, true_force) = true_param.unwrap();
    truth.duration_s = 2.0;
    let measured = model::simulate(&truth).unwrap();
    // Both tests on this case start from the plain search, without the second start for the
    // top trials (the one on that option switches it on itself).
    let opts = LoopOptions { candidates: vec![EffectKind::Unbalance, EffectKind::Misalignment], random_effect_realisations: 0, uncalibrated_start_top: false, ..Default::default() };
    (model_m, measured, true_force, opts)
}

/// `LoopOptions::unbend_when_short` (experimental) on the seed-8508 case of the bearing base
/// (docs/loop-notebook.md "Unbend when short"): a hidden 46 N misalignment the calibration
/// absorbs without pinning anything (it shrinks the fault depth). From that calibration the
/// misalignment's trial stays far from the force and an unbalance, explaining under half the
/// error above the floor, is chosen; with the option the short search is done again unbent,
/// finds the misalignment within 5 % of its force, keeps the plain choice, and expects every
/// evaluation it makes. Candidates: the two forces only.
#[test]
fn a_short_answer_is_searched_again_unbent_and_finds_the_absorbed_force() {
    let (model_m, measured, true_force, opts) = misalignment_case_8508();
    let (plain, plain_calls, plain_expected) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("plain: pinned {:?}; {}", plain.calibration.at_bound, plain.verdict);
    assert_eq!(plain_calls, plain_expected);
    assert!(!plain.unbent && plain.calibration.at_bound.is_empty(), "the calibration pinned {:?}", plain.calibration.at_bound);
    let chosen = plain.trials.iter().find(|t| Some(t.effect) == plain.best).expect("the plain search chose something");
    assert_eq!(chosen.effect, EffectKind::Unbalance, "{}", plain.verdict);
    assert!(chosen.explained < twinscope::compare::SHORT_EXPLAINED, "{}", plain.verdict);
    let opts = LoopOptions { unbend_when_short: true, ..opts };
    let (again, calls, expected) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("unbend when short: {}", again.verdict);
    assert_eq!(calls, expected);
    assert!(again.unbent && again.best == Some(EffectKind::Misalignment), "{}", again.verdict);
    let force = Param::Misalignment2xN;
    let fitted = again.trials[0].parameter.filter(|(p, _)| *p == force).map(|(_, v)| v).unwrap();
    assert!((fitted / true_force - 1.0).abs() < 0.05, "fitted {fitted:.1} N, true {true_force:.1} N");
    assert!(again.trials[0].explained > 0.9, "{}", again.verdict);
    let kept = again.short_plain.as_ref().expect("the plain choice is kept");
    assert_eq!((kept.chosen, kept.verdict.as_str()), (EffectKind::Unbalance, plain.verdict.as_str()));
    assert!(twinscope::compare::Round::of_diagnosis(1, model_m.effects.enabled(), &again, 0.0).unbent_when_short);
    // The unbent search takes over the plain one's calibration and trials and adds each
    // trial's second start from the uncalibrated values.
    let calibration = twinscope::compare::diagnose::calibration_evaluations(&model_m, &opts);
    let plain_trials: usize = opts.candidates.iter().map(|k| twinscope::compare::diagnose::plain_trial_evaluations(&model_m, *k, &opts)).sum();
    let second_starts: usize = opts.candidates.iter().map(|k| unbent_start_evaluations(&model_m, *k, &opts)).sum();
    assert_eq!(calls, 2 * plain_calls - calibration - plain_trials + second_starts);
}

/// `LoopOptions::uncalibrated_start_top` (the default since session 48) on the same seed-8508 case
/// (docs/loop-notebook.md "A second start for the top trials"): the calibration moves the
/// fault depth far to do without the misalignment, pinning nothing, and stage 2's local
/// re-fit cannot move it back. With the option the best trials also start from the
/// uncalibrated values before stage 2; the misalignment's second start wins, the search is
/// not unbent, the misalignment is chosen within 5 % of its force, and the search makes
/// exactly the plain search's evaluations plus each top trial's second start.
#[test]
fn a_second_start_for_the_top_trials_finds_the_force_a_moved_calibration_hides() {
    use twinscope::compare::diagnose::scanned_start_evaluations;
    let (model_m, measured, true_force, opts) = misalignment_case_8508();
    let (plain, plain_calls, _) = diagnose_counting(&model_m, &measured, &opts);
    assert_eq!(plain.best, Some(EffectKind::Unbalance), "{}", plain.verdict);
    assert!(plain.top_second_starts_won.is_empty());
    let opts = LoopOptions { uncalibrated_start_top: true, ..opts };
    let (top, calls, expected) = diagnose_counting(&model_m, &measured, &opts);
    eprintln!("second start for the top trials: {}", top.verdict);
    assert_eq!(calls, expected);
    assert!(!top.unbent && top.calibration.at_bound.is_empty(), "pinned {:?}", top.calibration.at_bound);
    assert_eq!(top.best, Some(EffectKind::Misalignment), "{}", top.verdict);
    assert!(top.top_second_starts_won.contains(&EffectKind::Misalignment), "{:?}", top.top_second_starts_won);
    let t = &top.trials[0];
    assert!(t.from_uncalibrated);
    let fitted = t.parameter.filter(|(p, _)| *p == Param::Misalignment2xN).map(|(_, v)| v).unwrap();
    assert!((fitted / true_force - 1.0).abs() < 0.05, "fitted {fitted:.1} N, true {true_force:.1} N");
    assert!(t.explained > 0.9, "{}", top.verdict);
    // Both candidates are among the top three, and neither started from the uncalibrated
    // values in stage 1: each gets one second start.
    let second_starts: usize = opts.candidates.iter().map(|k| scanned_start_evaluations(&model_m, *k, &opts)).sum();
    assert_eq!(calls, plain_calls + second_starts);
    let round = twinscope::compare::Round::of_diagnosis(1, model_m.effects.enabled(), &top, 0.0);
    assert_eq!(round.top_second_starts_won, top.top_second_starts_won);
}

/// `LoopOptions::fine_force_scan` (experimental) on the misalignment of fresh bearing seed
/// 9208 (41.9 N at 7.1 dB): from the uncalibrated values, as the search's second start does,
/// the force's objective holds its minimum in a notch (40.6–44.5 N) inside the coarse grid's
/// cell 18.6–56.0 N, and the golden section of that cell steps over it to a shoulder at
/// 31 N. The second grid lands in the notch (docs/loop-notebook.md "The short misalignment of
/// 9208: a notch the golden section straddles"). Since session 52 the coarse cell's golden
/// section runs beside the fine cell's and the lower is kept, so the fit can only improve.
#[test]
fn a_second_force_grid_finds_the_notch_the_golden_section_steps_over() {
    use twinscope::compare::calibrate::{fit_trial_scanning, fit_trial_scanning_evaluations, LoopProgress};
    let base = model::preset("mfs_inner").unwrap();
    let (mut truth, mut start, truths, _) = hidden::make_case_set(&base, &[EffectKind::Misalignment], 9208, &hidden::CaseSetting::default());
    truth.duration_s = 2.0;
    let measured = model::simulate(&truth).unwrap();
    let true_force = truths[0].1;
    start.effects.enable(EffectKind::Misalignment);
    let ps = [Param::Misalignment2xN];
    let refine = [Param::NoiseSnrDb];
    let run = |fine_force_scan: bool| {
        let opts = LoopOptions { fine_force_scan, ..Default::default() };
        let reference = Reference::new(&measured, &opts.compare).unwrap();
        let (m, f) = fit_trial_scanning(&start, &reference, &ps, &refine, &ps, &opts, &LoopProgress::new(&|_, _| true)).unwrap();
        assert_eq!(f.evaluations, fit_trial_scanning_evaluations(&start, &ps, &refine, &ps, &opts), "fine_force_scan {fine_force_scan}: the count the progress expects");
        assert_eq!(f.fine_cell_won.is_empty(), !fine_force_scan, "fine_force_scan {fine_force_scan}: the fine cell's start won, and the fit records it");
        (Param::Misalignment2xN.get(&m).unwrap() / true_force, f.objective_after, f.evaluations)
    };
    let (coarse, j_coarse, n_coarse) = run(false);
    let (fine, j_fine, n_fine) = run(true);
    eprintln!("true {true_force:.2} N; one grid {coarse:.4} × ({j_coarse:.3}, {n_coarse} evaluations); two grids {fine:.4} × ({j_fine:.3}, {n_fine} evaluations)");
    assert!(coarse < 0.85, "the premise: one grid stops short of the notch ({coarse:.4} ×)");
    assert!((fine - 1.0).abs() < 0.02, "two grids: {fine:.4} × the true force");
    assert!(j_fine < 0.7 * j_coarse, "the notch is deep: {j_fine:.3} against {j_coarse:.3}");
    // One more grid of 2n points, and the coarse cell's golden section beside the fine
    // cell's (2n with `fine_forces`): the lower of the two is kept (since session 52).
    assert_eq!(n_fine - n_coarse, 4 * LoopOptions::default().evaluations_per_parameter, "one more grid and one more golden section");
}
