//! The hidden-effect acceptance, one case per effect of the catalogue: the
//! "measurement" is simulated with one effect the model is not told about (its parameter drawn,
//! another seed, a perturbed baseline, measurement noise), and today's default search, over
//! every applicable candidate, must rank the hidden effect first and choose it; applying it must
//! at least halve the envelope NRMSE, or, for a random effect whose own realisation no model can
//! reproduce, bring it to the true machine's level. Controls, with nothing hidden, must answer
//! "nothing significant is missing".
//!
//! Each case is a stored case of a fresh `twinscope confusion` table (the seed is the one that
//! table gave it), chosen before it was run here by the rule in docs/loop-notebook.md
//! ("Session 59: one case per effect of the catalogue, as a test"). `confusion --preset P
//! --effect E --controls 0 --seed S` prints the same case. These are draws above the detection
//! limits the README states; the limits themselves are in README "Detection limits".

use twinscope::compare::hidden::{self, CaseResult, CaseSetting};
use twinscope::compare::LoopOptions;
use twinscope::model::{self, EffectKind, Effects};

/// `confusion`'s record length, s.
const RECORD_S: f64 = 2.0;

/// What applying the chosen effect must do to the envelope NRMSE.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Envelope {
    /// At most half the calibrated model's.
    Halved,
    /// No higher than the worst of the true machine's re-seeded runs
    /// ([`hidden::Oracle::truth`]): the best a model can do when the hidden effect is random.
    TruthLevel,
}

/// One stored case: the base preset, the hidden effect, `confusion`'s seed for it, what the
/// case fixes instead of drawing it, and what applying the effect must do to the envelope.
struct Case {
    preset: &'static str,
    effect: EffectKind,
    seed: u64,
    setting: CaseSetting,
    envelope: Envelope,
}

const BEARING: &str = "mfs_inner";
const GEAR: &str = "mfs_healthy";
const DRAWN: CaseSetting = CaseSetting { value: None, snr_db: None };

const fn case(preset: &'static str, effect: EffectKind, seed: u64, envelope: Envelope) -> Case {
    Case { preset, effect, seed, setting: DRAWN, envelope }
}

/// The cases, one per effect of the catalogue (notebook "Session 59": each a stored case of a
/// fresh table, or for slip of its strength sweep, with its alternate named there).
const CASES: [Case; 14] = [
    case(BEARING, EffectKind::LoadZone, 9900, Envelope::Halved),
    // Slip's drawn range (1–3 %) sits at its detection limit with one realisation; this is the
    // case of its strength sweep (README "Detection limits: slip and sensor_response"), chosen
    // by the second look with four realisations.
    Case { preset: BEARING, effect: EffectKind::Slip, seed: 3100, setting: CaseSetting { value: Some(3.0), snr_db: Some(10.0) }, envelope: Envelope::TruthLevel },
    case(BEARING, EffectKind::CasingModes, 9202, Envelope::Halved),
    case(GEAR, EffectKind::GearMesh, 9923, Envelope::Halved),
    case(GEAR, EffectKind::ToothFault, 9924, Envelope::Halved),
    case(BEARING, EffectKind::SpeedFluctuation, 9905, Envelope::Halved),
    case(BEARING, EffectKind::SensorResponse, 9906, Envelope::Halved),
    case(BEARING, EffectKind::Unbalance, 9207, Envelope::Halved),
    case(GEAR, EffectKind::Misalignment, 9928, Envelope::Halved),
    case(GEAR, EffectKind::ExtendedFault, 9929, Envelope::Halved),
    case(GEAR, EffectKind::PathModulation, 9930, Envelope::Halved),
    case(BEARING, EffectKind::BeltDrive, 9911, Envelope::Halved),
    case(BEARING, EffectKind::NonlinearContact, 9912, Envelope::Halved),
    case(BEARING, EffectKind::Noise, 9913, Envelope::Halved),
];

fn run(preset: &str, hidden_effect: Option<EffectKind>, seed: u64, setting: CaseSetting) -> CaseResult {
    let base = model::preset(preset).unwrap();
    hidden::run_case_set(&base, hidden_effect, seed, RECORD_S, &setting, &LoopOptions::default()).unwrap()
}

/// The worst envelope NRMSE (%) of the true machine's re-seeded runs against the measurement.
fn truth_envelope_worst(r: &CaseResult) -> f64 {
    r.oracle.truth.iter().map(|t| t.1).fold(f64::NEG_INFINITY, f64::max)
}

/// Runs the case of `k` and asserts what the issue asks of it.
fn assert_found(k: EffectKind) {
    let c = CASES.iter().find(|c| c.effect == k).expect("a case for every effect");
    let (preset, seed) = (c.preset, c.seed);
    let r = run(preset, Some(k), seed, c.setting);
    let (before, after, truth) = (r.envelope_nrmse_before, r.envelope_nrmse_after, truth_envelope_worst(&r));
    eprintln!(
        "{} on {preset}, seed {seed}: true {:?}, SNR {:.1} dB; ranking {:?}; chosen {:?}; objective / floor {:.2}; envelope NRMSE {before:.2} → {after:.2} % (true machine at worst {truth:.2} %); {:.0} s\n{}",
        k.name(),
        r.true_parameter,
        r.snr_db,
        r.ranking.iter().map(|e| e.name()).collect::<Vec<_>>(),
        r.chosen.map(|e| e.name()),
        r.calibrated_objective() / r.floor_objective,
        r.seconds,
        r.verdict
    );
    assert_eq!(r.rank_of_hidden, Some(1), "{} must be ranked first: {}", k.name(), r.verdict);
    assert_eq!(r.chosen, Some(k), "{} must be chosen: {}", k.name(), r.verdict);
    match c.envelope {
        Envelope::Halved => assert!(after <= 0.5 * before, "{}: envelope NRMSE {before:.2} → {after:.2} %, not halved", k.name()),
        Envelope::TruthLevel => {
            assert!(truth.is_finite() && after <= truth, "{}: envelope NRMSE {before:.2} → {after:.2} %, above the true machine's worst {truth:.2} %", k.name());
            // Not halved: else the case would be stated as `Halved`.
            assert!(after > 0.5 * before, "{}: {before:.2} → {after:.2} % is halved now: state it as Halved", k.name());
        }
    }
}

/// A load zone and the contact nonlinearity hidden together on the gear base: each acts only
/// with the other (no fault for the load zone's impacts to modulate; every ball at the
/// linearisation's preload without a load), so neither's trial alone explains anything. The
/// case is session 61's false claim (its fresh random gear pairs, seed 10260's second pair, at
/// 0.4 dB: a casing mode chosen), which the contact nonlinearity's trial with its load zone
/// (docs/loop-notebook.md "Session 62") finds in one round.
#[test]
fn a_load_zone_and_contact_nonlinearity_hidden_together_are_found_together() {
    use EffectKind::{LoadZone, NonlinearContact};
    let base = model::preset(GEAR).unwrap();
    let r = hidden::run_multi_case(&base, &[NonlinearContact, LoadZone], 10261, RECORD_S, 4, &LoopOptions::default()).unwrap();
    let rounds: Vec<String> = r.history.iter().map(|h| format!("{:.2} ({:.2}) → {}", h.envelope_nrmse, h.objective / h.floor_objective, h.change_with_values("nothing"))).collect();
    eprintln!("load zone + contact nonlinearity on {GEAR}, seed 10261: true {:?}, SNR {:.1} dB; {}; {:.0} s", r.true_parameters, r.snr_db, rounds.join("; "), r.seconds);
    assert!(r.false_claims.is_empty(), "false claims {:?}: {}", r.false_claims, rounds.join("; "));
    assert!(r.found_all && r.ended_clean, "{}", rounds.join("; "));
    assert_eq!((r.history[0].applied, r.history[0].applied_with), (Some(NonlinearContact), Some(LoadZone)), "both in the first round");
    let true_load = r.true_parameters.iter().find(|p| p.0 == twinscope::compare::Param::RadialLoadN).unwrap().1;
    let fitted = r.final_values.iter().find(|p| p.0 == twinscope::compare::Param::RadialLoadN).expect("the load zone's load among the final values").1;
    assert!((fitted / true_load - 1.0).abs() < 0.15, "load {fitted:.1} N for {true_load:.1} N");
    // At 0.4 dB the envelope is not halved; the loop ends at the true machine's level.
    let last = r.history.last().unwrap().envelope_nrmse;
    let truth_worst = r.oracle.truth.iter().map(|t| t.1).fold(f64::NEG_INFINITY, f64::max);
    assert!(last <= truth_worst, "envelope NRMSE {last:.2} % above the true machine's worst {truth_worst:.2} %");
}

/// A contact nonlinearity and a 3.9 kHz casing mode hidden together on the bearing base, each
/// hiding the other from its single trial: without the Hertzian law the fault depth is bent
/// and a mode at the band's edge imitates the rest better than at its true frequency, so the
/// single search is stuck (session 61's pair 10243, 1.7 dB: both missed). The joint trials of
/// the experimental `joint_trials` (docs/loop-notebook.md "Session 63") find the two together
/// in one round, each effect doing its own work.
#[test]
fn two_effects_hidden_from_every_single_trial_are_found_by_a_joint_trial() {
    use EffectKind::{CasingModes, NonlinearContact};
    let base = model::preset(BEARING).unwrap();
    let opts = LoopOptions { joint_trials: true, ..LoopOptions::default() };
    let r = hidden::run_multi_case(&base, &[NonlinearContact, CasingModes], 10243, RECORD_S, 4, &opts).unwrap();
    let rounds: Vec<String> = r.history.iter().map(|h| format!("{:.2} ({:.2}) → {}", h.envelope_nrmse, h.objective / h.floor_objective, h.change_with_values("nothing"))).collect();
    eprintln!("contact nonlinearity + casing mode on {BEARING}, seed 10243: true {:?}, SNR {:.1} dB; {}; {:.0} s", r.true_parameters, r.snr_db, rounds.join("; "), r.seconds);
    assert!(r.false_claims.is_empty(), "false claims {:?}: {}", r.false_claims, rounds.join("; "));
    assert!(r.found_all && r.ended_clean, "{}", rounds.join("; "));
    let first = &r.history[0];
    assert!(first.applied_jointly, "a joint trial in the first round: {}", rounds.join("; "));
    let mut applied = [first.applied, first.applied_with];
    applied.sort();
    let mut hidden = [Some(NonlinearContact), Some(CasingModes)];
    hidden.sort();
    assert_eq!(applied, hidden, "{}", rounds.join("; "));
    let true_hz = r.true_parameters.iter().find(|p| p.0 == twinscope::compare::Param::CasingModeHz).unwrap().1;
    let fitted = r.final_values.iter().find(|p| p.0 == twinscope::compare::Param::CasingModeHz).expect("the mode among the final values").1;
    assert!((fitted / true_hz - 1.0).abs() < 0.05, "mode at {fitted:.0} Hz for {true_hz:.0} Hz");
    let last = r.history.last().unwrap().objective;
    let truth: Vec<f64> = r.oracle.truth.iter().map(|t| t.0).collect();
    let mean = truth.iter().sum::<f64>() / truth.len() as f64;
    let sd = (truth.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (truth.len() - 1) as f64).sqrt();
    assert!(last <= mean + 2.0 * sd, "the last round's objective {last:.2} above the true machine's {mean:.2} + 2 × {sd:.2}");
}

/// A misalignment and an unbalance hidden together on the gear base (session 62's pair 10341,
/// 14.9 dB): applied first, the misalignment is fitted 7 % high, taking up part of the
/// unbalance's share of the 1× line, and the unbalance's valley, about ±10 % wide, is gone,
/// so the search before session 64 ended stuck at 6.47 against the true machine's 2.43. With
/// `coupled_forces` (the default since session 64, docs/loop-notebook.md "Session 64") the
/// unbalance's trial is fitted at the misalignment's amplitude and ±3–12 % of it, and the
/// loop finds both.
#[test]
fn an_unbalance_is_found_beside_a_misalignment_fitted_high_when_the_forces_are_fitted_together() {
    use twinscope::compare::Param;
    use EffectKind::{Misalignment, Unbalance};
    let base = model::preset(GEAR).unwrap();
    let opts = LoopOptions::default();
    assert!(opts.coupled_forces, "the default since session 64");
    let r = hidden::run_multi_case(&base, &[Misalignment, Unbalance], 10341, RECORD_S, 4, &opts).unwrap();
    let rounds: Vec<String> = r.history.iter().map(|h| format!("{:.2} ({:.2}) → {}", h.envelope_nrmse, h.objective / h.floor_objective, h.change_with_values("nothing"))).collect();
    eprintln!("misalignment + unbalance on {GEAR}, seed 10341: true {:?}, SNR {:.1} dB; {}; {:.0} s", r.true_parameters, r.snr_db, rounds.join("; "), r.seconds);
    assert!(r.false_claims.is_empty(), "false claims {:?}: {}", r.false_claims, rounds.join("; "));
    assert!(r.found_all && r.ended_clean, "{}", rounds.join("; "));
    let value = |v: &[(Param, f64)], p: Param| v.iter().find(|x| x.0 == p).map(|x| x.1);
    for p in [Param::UnbalanceKgM, Param::Misalignment2xN] {
        let (truth, fitted) = (value(&r.true_parameters, p).unwrap(), value(&r.final_values, p).expect("among the final values"));
        assert!((fitted / truth - 1.0).abs() < 0.15, "{} {fitted:.4e} for {truth:.4e}", p.name());
    }
    let last = r.history.last().unwrap().objective;
    let truth: Vec<f64> = r.oracle.truth.iter().map(|t| t.0).collect();
    let mean = truth.iter().sum::<f64>() / truth.len() as f64;
    let sd = (truth.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (truth.len() - 1) as f64).sqrt();
    assert!(last <= mean + 2.0 * sd, "the last round's objective {last:.2} above the true machine's {mean:.2} + 2 × {sd:.2}");
}

/// The reverse order (session 65): an unbalance applied first, without the weaker misalignment
/// beside it, takes up the shaft-rate modulation the misalignment makes and is fitted far high;
/// one of session 65's machines (gear base, unbalance 3.0e-3 kg·m, misalignment 10 / 2.5 N,
/// 12 dB, seed 6503) had it at 4.642e-3 (55 % high) after the loop's first round, and the round
/// after, whose coupled trial started the unbalance at ±12 % of that only, answered "nothing
/// significant". Since session 66 the misalignment's trial also starts the applied unbalance at
/// 0.5–0.8 of it (docs/loop-notebook.md "Session 66"): that round, from the model with the
/// unbalance on (not applied by the loop, so not calibrated), finds the misalignment and carries
/// the unbalance back near its truth, through stage 2's re-fit, for applying the trial.
#[test]
fn a_misalignment_is_found_beside_an_unbalance_fitted_high_without_it() {
    assert_shaft_forces_round(ShaftForcesRound { base: GEAR, unbalance_kg_m: 3.0e-3, misalignment_n: (10.0, 2.5), snr_db: 12.0, seed: 6503, applied: (EffectKind::Unbalance, 4.642e-3), model_snr_db: 12.0 });
}

/// The reverse order with the unbalance applied *low* (session 67): the misalignment's own 1×
/// can take from the unbalance's line too, and session 66's drawn machine 6613 (gear base,
/// unbalance 3.52e-3 kg·m, misalignment 10.88 / 2.72 N, 8.7 dB) had it at 2.783e-3 (21 % low)
/// after the loop's first round; the round after, whose coupled starts all sat at or below
/// 1.12 × that, fitted the misalignment 17 % low beside an unbalance 26 % low, and the loop
/// stuck. Since session 67 the trial also starts the applied unbalance at 1.2–1.4 of it.
#[test]
fn a_misalignment_is_found_beside_an_unbalance_fitted_low_without_it() {
    assert_shaft_forces_round(ShaftForcesRound { base: GEAR, unbalance_kg_m: 3.52e-3, misalignment_n: (10.88, 2.72), snr_db: 8.7, seed: 6613, applied: (EffectKind::Unbalance, 2.783e-3), model_snr_db: 20.0 });
}

/// The forward order with the misalignment applied *far high* (session 68): without the
/// unbalance, the misalignment's own 1× (a quarter of its 2×) takes up the 1× line, and under a
/// spall the weak 2× evidence lets its 2× follow. Session 67's drawn machine 6712 (bearing
/// base, unbalance 1.873e-3 kg·m, misalignment 13.61 / 3.402 N, 7.4 dB) had it at 26.83 N (97 %
/// high) after the loop's first round; the round after, whose coupled starts sat within ±12 %
/// of that, explained 14 % with the unbalance and the loop stuck. Since session 68 the
/// unbalance's trial also starts the applied misalignment at 0.5–0.8 and 1.2–1.4 of it.
#[test]
fn an_unbalance_is_found_beside_a_misalignment_fitted_twice_its_truth_without_it() {
    assert_shaft_forces_round(ShaftForcesRound { base: BEARING, unbalance_kg_m: 1.873e-3, misalignment_n: (13.61, 3.402), snr_db: 7.4, seed: 6712, applied: (EffectKind::Misalignment, 26.826479182830138), model_snr_db: 20.0 });
}

/// A round with one of a pair of shaft-rate forces applied: the truth (`base`) with an
/// unbalance, a misalignment (2×, 1×) and noise, a 2 s record; the model with `applied` on at
/// the value the loop's first round gave it (a misalignment's 1× a quarter of its 2×), and
/// noise.
struct ShaftForcesRound {
    base: &'static str,
    unbalance_kg_m: f64,
    misalignment_n: (f64, f64),
    snr_db: f64,
    seed: u64,
    applied: (EffectKind, f64),
    model_snr_db: f64,
}

/// The "measurement" of a shaft-force case: `base` with an unbalance (kg·m), a misalignment
/// (2×, 1× in N) and noise at `snr_db`, a [`RECORD_S`] record simulated with `seed`.
fn shaft_forces_record(base: &model::Machine, unbalance_kg_m: f64, misalignment_n: (f64, f64), snr_db: f64, seed: u64) -> twinscope::signal::Signal {
    use twinscope::compare::Param;
    use EffectKind::{Misalignment, Noise, Unbalance};
    let mut truth = base.clone();
    for k in [Unbalance, Misalignment, Noise] {
        truth.effects.enable(k);
    }
    Param::UnbalanceKgM.set(&mut truth, unbalance_kg_m);
    let mis = truth.effects.misalignment.as_mut().unwrap();
    (mis.force_2x_n, mis.force_1x_n) = misalignment_n;
    truth.effects.noise.as_mut().unwrap().snr_db = snr_db;
    (truth.seed, truth.duration_s) = (seed, RECORD_S);
    model::simulate(&truth).unwrap()
}

/// One round of the default search on `r` chooses the other force, its amplitude within 15 %
/// of the truth and the applied force the trial carries (for applying it) within 15 % too.
fn assert_shaft_forces_round(r: ShaftForcesRound) {
    use twinscope::compare::{run_loop, Param};
    use EffectKind::{Misalignment, Noise, Unbalance};
    let main = |k: EffectKind| Param::main_of_effect(k).unwrap();
    let truth_value = |k: EffectKind| if k == Unbalance { r.unbalance_kg_m } else { r.misalignment_n.0 };
    let (applied, applied_value) = r.applied;
    let missing = if applied == Unbalance { Misalignment } else { Unbalance };
    let base = model::preset(r.base).unwrap();
    let measured = shaft_forces_record(&base, r.unbalance_kg_m, r.misalignment_n, r.snr_db, r.seed);
    let mut model_m = base.clone();
    for k in [applied, Noise] {
        model_m.effects.enable(k);
    }
    if let Some(m) = model_m.effects.misalignment.as_mut() {
        (m.force_2x_n, m.force_1x_n) = (applied_value, applied_value / 4.0);
    }
    main(applied).set(&mut model_m, applied_value);
    model_m.effects.noise.as_mut().unwrap().snr_db = r.model_snr_db;
    let opts = LoopOptions::default();
    assert!(opts.coupled_forces, "the default since session 64");
    let (_, history, d) = run_loop(&model_m, &measured, 1, &opts, &|_, _| true).unwrap();
    eprintln!("{} applied first on {}, seed {}: {}", applied.name(), r.base, r.seed, history[0].verdict);
    assert_eq!(d.best, Some(missing), "{}", history[0].verdict);
    let t = d.trials.iter().find(|t| t.effect == missing).unwrap();
    let value = |p: Param| t.parameter.iter().chain(t.extra_parameters.iter()).find(|x| x.0 == p).map(|x| x.1);
    let found = value(main(missing)).unwrap();
    let carried = value(main(applied)).expect("the trial carries the applied force it was fitted with");
    for (k, v) in [(missing, found), (applied, carried)] {
        assert!((v / truth_value(k) - 1.0).abs() < 0.15, "{} {v:.4e} for {:.4e}", k.name(), truth_value(k));
    }
}

/// A round's diagnosis with both shaft-rate forces applied: the truth (gear base) with an
/// unbalance, a misalignment (2×, 1×) and noise; the model with both on at the values the
/// loop's last round gave them (a misalignment's 1× a quarter of its 2×) and its noise.
struct ForcePairRound {
    unbalance_kg_m: f64,
    misalignment_n: (f64, f64),
    snr_db: f64,
    seed: u64,
    start_unbalance_kg_m: f64,
    start_misalignment_2x_n: f64,
    model_snr_db: f64,
}

/// Re-fitting both forces as the loop's round after both were applied does: both calibrated
/// within 3 % of their truths, and nothing missing.
fn assert_force_pair_calibrated(r: ForcePairRound) {
    use twinscope::compare::{diagnose, Param};
    use EffectKind::{Misalignment, Noise, Unbalance};
    let base = model::preset(GEAR).unwrap();
    let measured = shaft_forces_record(&base, r.unbalance_kg_m, r.misalignment_n, r.snr_db, r.seed);
    let mut model_m = base.clone();
    for k in [Unbalance, Misalignment, Noise] {
        model_m.effects.enable(k);
    }
    Param::UnbalanceKgM.set(&mut model_m, r.start_unbalance_kg_m);
    let mis = model_m.effects.misalignment.as_mut().unwrap();
    (mis.force_2x_n, mis.force_1x_n) = (r.start_misalignment_2x_n, r.start_misalignment_2x_n / 4.0);
    model_m.effects.noise.as_mut().unwrap().snr_db = r.model_snr_db;
    let opts = LoopOptions { refit_effects: vec![Unbalance, Misalignment], ..LoopOptions::default() };
    assert!(opts.force_pair_grid, "the default since session 68");
    let (_, d) = diagnose(&model_m, &measured, &opts, &|_, _| true).unwrap();
    eprintln!("both forces applied, seed {}: calibration {:?}, objective {:.2}; {}", r.seed, d.calibration.parameters, d.calibration.objective_after, d.verdict);
    let value = |p: Param| d.calibration.parameters.iter().find(|x| x.0 == p).map(|x| x.1).unwrap();
    for (p, t) in [(Param::UnbalanceKgM, r.unbalance_kg_m), (Param::Misalignment2xN, r.misalignment_n.0)] {
        assert!((value(p) / t - 1.0).abs() < 0.03, "{} {:.4e} for {t:.4e}", p.name(), value(p));
    }
    assert_eq!(d.best, None, "{}", d.verdict);
}

/// Both shaft-rate forces applied, each a few per cent off (session 67's drawn machine 6711,
/// gear base, unbalance 3.408e-3 kg·m, misalignment 11.27 / 2.817 N, 12.9 dB; the loop applied
/// the unbalance at 2.783e-3, then the misalignment at 10.41 N with the unbalance at
/// 3.543e-3): the calibration's line searches, one amplitude at a time, ended at 3.577e-3 and
/// 10.24 N (+5 %, −9 %) and the loop stuck at 4.38 against the true structure's 2.70. The two
/// share the 1× line and their valley is a narrow diagonal; since session 68 the calibration
/// also fits them jointly on a grid ([`LoopOptions::force_pair_grid`]), and this round,
/// from the model with both applied, calibrates both within 3 % and finds nothing missing.
#[test]
fn the_calibration_fits_an_applied_unbalance_and_misalignment_together_to_their_truth() {
    assert_force_pair_calibrated(ForcePairRound { unbalance_kg_m: 3.408e-3, misalignment_n: (11.27, 2.817), snr_db: 12.9, seed: 6711, start_unbalance_kg_m: 3.543e-3, start_misalignment_2x_n: 10.41, model_snr_db: 20.0 });
}

/// The same pair farther off (session 69's never-run machine 6911, gear base, unbalance
/// 2.706e-3 kg·m, misalignment 14.16 / 3.539 N, 10.0 dB; the loop applied the unbalance at
/// 2.783e-3, then the misalignment at 11.30 N with the unbalance at 3.288e-3): with session
/// 68's ±12 % grid the calibration ended at +20 % / −19 % and the loop stuck at 5.02 against
/// the true machine's 3.12, the pit of the diagonal valley 16–23 % away. The grid's ±30 %
/// coarse stage ([`twinscope::compare::calibrate::FORCE_PAIR_COARSE`], since session 70)
/// reaches it: both within 3 % and nothing missing.
#[test]
fn the_joint_grid_reaches_a_pair_of_forces_a_fifth_off_their_truth() {
    assert_force_pair_calibrated(ForcePairRound { unbalance_kg_m: 2.706e-3, misalignment_n: (14.16, 3.539), snr_db: 10.0, seed: 6911, start_unbalance_kg_m: 3.288e-3, start_misalignment_2x_n: 11.30, model_snr_db: 10.25 });
}

fn assert_control(preset: &str, seed: u64) {
    let r = run(preset, None, seed, DRAWN);
    eprintln!("control on {preset}, seed {seed}: SNR {:.1} dB; objective / floor {:.2}; {}", r.snr_db, r.calibrated_objective() / r.floor_objective, r.verdict);
    assert_eq!(r.chosen, None, "a control must answer nothing significant: {}", r.verdict);
    assert!(r.verdict.starts_with("nothing significant"), "{}", r.verdict);
}

#[test]
fn every_effect_of_the_catalogue_has_one_case_on_a_base_it_applies_to() {
    for k in EffectKind::ALL {
        let cases: Vec<&Case> = CASES.iter().filter(|c| c.effect == k).collect();
        assert_eq!(cases.len(), 1, "{}: one case", k.name());
        let base = model::preset(cases[0].preset).unwrap();
        assert!(Effects::applicable(k, &base), "{} does not apply to {}", k.name(), cases[0].preset);
    }
}

#[test]
fn a_hidden_load_zone_is_ranked_first_and_chosen() {
    assert_found(EffectKind::LoadZone);
}

#[test]
fn a_hidden_slip_is_ranked_first_and_chosen() {
    assert_found(EffectKind::Slip);
}

#[test]
fn a_hidden_casing_mode_is_ranked_first_and_chosen() {
    assert_found(EffectKind::CasingModes);
}

#[test]
fn a_hidden_gear_mesh_variation_is_ranked_first_and_chosen() {
    assert_found(EffectKind::GearMesh);
}

#[test]
fn a_hidden_tooth_fault_is_ranked_first_and_chosen() {
    assert_found(EffectKind::ToothFault);
}

#[test]
fn a_hidden_speed_fluctuation_is_ranked_first_and_chosen() {
    assert_found(EffectKind::SpeedFluctuation);
}

#[test]
fn a_hidden_sensor_roll_off_is_ranked_first_and_chosen() {
    assert_found(EffectKind::SensorResponse);
}

#[test]
fn a_hidden_unbalance_is_ranked_first_and_chosen() {
    assert_found(EffectKind::Unbalance);
}

#[test]
fn a_hidden_misalignment_is_ranked_first_and_chosen() {
    assert_found(EffectKind::Misalignment);
}

#[test]
fn a_hidden_extended_fault_is_ranked_first_and_chosen() {
    assert_found(EffectKind::ExtendedFault);
}

#[test]
fn a_hidden_path_modulation_is_ranked_first_and_chosen() {
    assert_found(EffectKind::PathModulation);
}

#[test]
fn a_hidden_belt_drive_is_ranked_first_and_chosen() {
    assert_found(EffectKind::BeltDrive);
}

#[test]
fn a_hidden_contact_nonlinearity_is_ranked_first_and_chosen() {
    assert_found(EffectKind::NonlinearContact);
}

#[test]
fn a_hidden_noise_level_is_ranked_first_and_chosen() {
    assert_found(EffectKind::Noise);
}

#[test]
fn a_bearing_base_control_answers_nothing_significant() {
    assert_control(BEARING, 9914);
}

#[test]
fn a_gear_base_control_answers_nothing_significant() {
    assert_control(GEAR, 9934);
}
