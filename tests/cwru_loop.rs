//! The loop on real data (CWRU drive end, 12 kHz, 0 hp), from the 6205 presets without
//! load_zone and with calibrated measurement noise, demodulation band 1.8–3 kHz:
//! - 209 (inner race, 0.021 in): load_zone is ranked first and lowers the envelope NRMSE;
//! - 130 (outer race at 6 o'clock, the centre of the load zone): no shaft-rate modulation is
//!   claimed (load_zone is not chosen).
//!
//! (105, the 0.007 in inner race, does not reach "load_zone first": see README.) On 209,
//! misalignment ties with load_zone on the objective; the residual-map evidence decides.

use std::path::Path;
use twinscope::compare::{diagnose, LoopOptions};
use twinscope::model::{self, EffectKind};
use twinscope::signal::io;

fn run(file: &str, preset: &str) -> twinscope::compare::Diagnosis {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cwru").join(file);
    let measured = io::load(&path, &io::LoadOptions::default()).unwrap();
    let mut m = model::preset(preset).unwrap();
    m.effects.enable(EffectKind::Noise);
    let mut opts = LoopOptions::default();
    opts.compare.envelope_band_hz = [1800.0, 3000.0];
    diagnose(&m, &measured, &opts, &|_, _| true).unwrap().1
}

#[test]
fn inner_race_209_needs_the_load_zone() {
    let d = run("209_de_inner_021_0hp_12k.mat", "cwru_6205_inner");
    let t = &d.trials[0];
    assert_eq!(t.effect, EffectKind::LoadZone, "ranking: {:?}; verdict: {}", d.trials.iter().map(|t| t.effect).collect::<Vec<_>>(), d.verdict);
    assert_eq!(d.best, Some(EffectKind::LoadZone), "{}", d.verdict);
    assert!(t.envelope_nrmse_after < t.envelope_nrmse_before, "{}", t.summary);
    assert!(t.evidence.contains("shaft") || t.evidence.contains("BPFI"), "{}", t.evidence);
}

#[test]
fn outer_race_130_claims_no_shaft_rate_modulation() {
    let d = run("130_de_outer6_007_0hp_12k.mat", "cwru_6205_outer");
    assert_ne!(d.best, Some(EffectKind::LoadZone), "{}", d.verdict);
    assert_ne!(d.best, Some(EffectKind::PathModulation), "{}", d.verdict);
}
