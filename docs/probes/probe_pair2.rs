//! Scratch probe (session 57): which fit of the roll-off's trial reaches the true roll-off's level.
use rayon::prelude::*;
use twinscope::compare::{self, calibrate, diagnose, evaluate, hidden, objective, LoopOptions, LoopProgress, Param};
use twinscope::model::{self, EffectKind};

fn main() {
    let fit_s: f64 = std::env::args().nth(1).unwrap().parse().unwrap();
    let seed: u64 = std::env::args().nth(2).map_or(10041, |s| s.parse().unwrap());
    let hid: Vec<EffectKind> = std::env::args().nth(3).map_or(vec![EffectKind::CasingModes, EffectKind::SensorResponse], |s| s.split('+').map(|x| serde_json::from_str(&format!("\"{x}\"")).unwrap()).collect());
    let base = model::preset(&std::env::args().nth(4).unwrap_or("mfs_healthy".into())).unwrap();
    let (mut truth, model_m, tp, snr) = hidden::make_case_hiding(&base, &hid, seed);
    truth.duration_s = 3.0;
    println!("fit {fit_s} s, seed {seed}, true {tp:?}, snr {snr:.1}");
    let measured = model::simulate(&truth).unwrap();
    let opts = LoopOptions { fit_duration_s: fit_s, ..Default::default() };
    let reference = compare::Reference::new(&measured, &opts.compare).unwrap();
    let pr = LoopProgress::new(&|_, _| true);
    let cal_ps = calibrate::calibration_parameters_for(&model_m, &opts);
    let (cal, cf) = calibrate::fit_with_progress(&model_m, &reference, &cal_ps, opts.sweeps, &opts, &pr).unwrap();
    println!("calibrated {:.3}: res {:?} damp {:?}", cf.objective_after, Param::ResonanceHz.get(&cal), Param::ResonanceDamping.get(&cal));
    let k = EffectKind::SensorResponse;
    let bw = Param::SensorBandwidthHz;
    let variants: Vec<(&str, usize, bool)> = vec![("uncal, bw scanned, 1 sweep (casing's trial)", 1, false), ("uncal, bw scanned, 2 sweeps", 2, false), ("cal, bw scanned, 1 sweep", 1, true), ("uncal, bw scanned, calibration's sweeps", opts.sweeps, false)];
    let out: Vec<String> = variants.par_iter().map(|(name, sweeps, from_cal)| {
        let mut t = if *from_cal { cal.clone() } else { model_m.clone() };
        t.effects.enable(k);
        let ps = diagnose::recalibration_parameters(k, &t, &opts);
        let (fm, f) = calibrate::fit_scanning(&t, &reference, &ps, &[bw], *sweeps, &opts, &pr).unwrap();
        let (c, _) = evaluate(&fm, &reference, &opts).unwrap();
        format!("{name}: {:.3} (re-evaluated {:.3}); bw {:.0} res {:.0} damp {:.3} snr {:.1}; evaluations {}", f.objective_after, objective(&c, &opts.weights), bw.get(&fm).unwrap(), Param::ResonanceHz.get(&fm).unwrap(), Param::ResonanceDamping.get(&fm).unwrap(), Param::NoiseSnrDb.get(&fm).unwrap(), f.evaluations)
    }).collect();
    for o in out { println!("{o}"); }
}
