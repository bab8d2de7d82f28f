//! The loop on real data (CWRU drive end, 12 kHz, 0 hp), from the 6205 presets of each record's
//! fault size without load_zone and with calibrated measurement noise, demodulation band
//! 1.8–3 kHz:
//! - 209 (inner race, 0.021 in): load_zone is ranked first and lowers the envelope NRMSE;
//! - 130 and 234 (outer race at 6 o'clock, the centre of the load zone, 0.007 and 0.021 in):
//!   no shaft-rate modulation is claimed (no load zone, path modulation, unbalance or
//!   misalignment is chosen). On 234 an unbalance trial explains 26 % of the error above the
//!   floor, but only at the top of its range (8.9e-3 kg·m, a 313 N rotating force on the
//!   rotor's 2 kg share): not an estimate, and the verdict names it.
//!
//! - 097 (healthy, recorded at 48 kHz), from the healthy preset (its load zone carries the
//!   rotor's weight): nothing significant is missing, compared at the model's 12 kHz. From the
//!   inner-race preset the search misses nothing either (the calibration moves the resonance
//!   out of the band), but its removal trial reads the fault contradicted, where on 209 the
//!   real fault reads needed.
//!
//! (105, the 0.007 in inner race, does not reach "load_zone first": see README.)

use std::path::Path;
use twinscope::compare::removal::{ModelPart, RemovalReading};
use twinscope::compare::{diagnose, LoopOptions};
use twinscope::model::{self, EffectKind};
use twinscope::signal::io;

fn run(file: &str, preset: &str) -> twinscope::compare::Diagnosis {
    run_with(file, preset, false)
}

/// [`run`], with the removal trials when `removal_trials`.
fn run_with(file: &str, preset: &str, removal_trials: bool) -> twinscope::compare::Diagnosis {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cwru").join(file);
    let measured = io::load(&path, &io::LoadOptions::default()).unwrap();
    let mut m = model::preset(preset).unwrap();
    m.effects.enable(EffectKind::Noise);
    let mut opts = LoopOptions { removal_trials, ..Default::default() };
    opts.compare.envelope_band_hz = [1800.0, 3000.0];
    diagnose(&m, &measured, &opts, &|_, _| true).unwrap().1
}

#[test]
fn inner_race_209_needs_the_load_zone() {
    let d = run_with("209_de_inner_021_0hp_12k.mat", "cwru_6205_inner_021", true);
    assert_eq!(fault_reading(&d), Some(RemovalReading::Needed), "{:?}", d.removals.iter().map(|r| &r.summary).collect::<Vec<_>>());
    let t = &d.trials[0];
    assert_eq!(t.effect, EffectKind::LoadZone, "ranking: {:?}; verdict: {}", d.trials.iter().map(|t| t.effect).collect::<Vec<_>>(), d.verdict);
    assert_eq!(d.best, Some(EffectKind::LoadZone), "{}", d.verdict);
    assert!(t.envelope_nrmse_after < t.envelope_nrmse_before, "{}", t.summary);
    assert!(t.evidence.contains("shaft") || t.evidence.contains("BPFI"), "{}", t.evidence);
}

/// The effects that would modulate the impacts at shaft rate.
const SHAFT_RATE: [EffectKind; 4] = [EffectKind::LoadZone, EffectKind::PathModulation, EffectKind::Unbalance, EffectKind::Misalignment];

#[test]
fn outer_race_130_claims_no_shaft_rate_modulation() {
    let d = run("130_de_outer6_007_0hp_12k.mat", "cwru_6205_outer");
    assert!(!d.best.is_some_and(|k| SHAFT_RATE.contains(&k)), "{}", d.verdict);
}

#[test]
fn outer_race_234_claims_no_shaft_rate_modulation_and_names_the_pinned_unbalance() {
    let d = run("234_de_outer6_021_0hp_12k.mat", "cwru_6205_outer_021");
    assert!(!d.best.is_some_and(|k| SHAFT_RATE.contains(&k)), "{}", d.verdict);
    let unbalance = d.trials.iter().find(|t| t.effect == EffectKind::Unbalance).unwrap();
    assert_eq!(unbalance.pinned_at_top(), Some(true), "{}", unbalance.summary);
    assert!(d.verdict.contains("unbalance explains") && d.verdict.contains("top of its range"), "{}", d.verdict);
}

/// The real-data control: the healthy record against the healthy machine. The record is sampled
/// at 48 kHz and compared at the model's 12 kHz (`compare::at_most_rate`); at 48 kHz, with the
/// fault-free machine without its load zone, the loop claimed a load zone (docs/loop-notebook.md
/// "Session 72").
#[test]
fn healthy_record_097_misses_nothing_significant() {
    let d = run("097_normal_0hp_48k.mat", "cwru_6205_healthy");
    assert_eq!(d.best, None, "{}", d.verdict);
    assert!(d.verdict.starts_with("nothing significant is missing"), "{}", d.verdict);
}

/// What the removal trial of the bearing's fault read.
fn fault_reading(d: &twinscope::compare::Diagnosis) -> Option<RemovalReading> {
    d.removals.iter().find(|r| matches!(r.part, ModelPart::Fault { .. })).map(|r| r.reading)
}

#[test]
fn healthy_record_097_contradicts_the_inner_race_presets_fault() {
    let d = run_with("097_normal_0hp_48k.mat", "cwru_6205_inner", true);
    assert_eq!(d.best, None, "{}", d.verdict);
    assert_eq!(fault_reading(&d), Some(RemovalReading::Contradicted), "{:?}", d.removals.iter().map(|r| &r.summary).collect::<Vec<_>>());
}
