//! Scratch probe (session 57): why the casing mode + roll-off pair's trials stop short at 3 s.
use rayon::prelude::*;
use twinscope::compare::{self, calibrate, diagnose_with, evaluate, hidden, objective, LoopOptions, LoopProgress, Param};
use twinscope::model::{self, EffectKind, Machine};

fn j(m: &Machine, r: &compare::Reference, o: &LoopOptions) -> f64 {
    let (c, _) = evaluate(m, r, o).unwrap();
    objective(&c, &o.weights)
}

fn main() {
    let fit_s: f64 = std::env::args().nth(1).unwrap().parse().unwrap();
    let seed: u64 = std::env::args().nth(2).map_or(10041, |s| s.parse().unwrap());
    let base = model::preset("mfs_healthy").unwrap();
    let hid = [EffectKind::CasingModes, EffectKind::SensorResponse];
    let (mut truth, model_m, tp, snr) = hidden::make_case_hiding(&base, &hid, seed);
    truth.duration_s = 3.0;
    println!("fit {fit_s} s, seed {seed}, true {tp:?}, snr {snr:.1}");
    for p in [Param::ResonanceHz, Param::ResonanceDamping, Param::NoiseSnrDb, Param::CasingModeHz, Param::SensorBandwidthHz] {
        println!("  truth {}: {:?}; model {:?}", p.name(), p.get(&truth), p.get(&model_m));
    }
    let measured = model::simulate(&truth).unwrap();
    let opts = LoopOptions { fit_duration_s: fit_s, ..Default::default() };
    let reference = compare::Reference::new(&measured, &opts.compare).unwrap();
    // The true machine with each hidden effect off, two model seeds each.
    for off in [vec![], vec![EffectKind::CasingModes], vec![EffectKind::SensorResponse], hid.to_vec()] {
        let v: Vec<f64> = [11u64, 22].par_iter().map(|s| {
            let mut m = truth.clone();
            for k in &off { m.effects.disable(*k); }
            m.seed ^= s;
            j(&m, &reference, &opts)
        }).collect();
        println!("truth without {off:?}: {v:.3?}");
    }
    let t0 = std::time::Instant::now();
    let (cal, d) = diagnose_with(&model_m, &reference, &opts, &LoopProgress::new(&|_, _| true)).unwrap();
    println!("diagnosis ({:.0} s): j_cal {:.3} floor {:.3} scatter {:.3}\n  {}", t0.elapsed().as_secs_f64(), d.trials.first().map_or(f64::NAN, |t| t.objective_before), d.floor_objective, d.objective_scatter, d.verdict);
    for p in [Param::ResonanceHz, Param::ResonanceDamping, Param::NoiseSnrDb] {
        println!("  cal {}: {:?}", p.name(), p.get(&cal));
    }
    for t in d.trials.iter().take(3) {
        println!("  trial {:?}: {:.3} param {:?} extra {:?} without-effect {:?} uncal {}", t.effect, t.objective_after, t.parameter, t.extra_parameters, t.objective_without_effect, t.from_uncalibrated);
    }
    let j_cal = j(&cal, &reference, &opts);
    println!("cal re-evaluated: {j_cal:.3}");
    // Each hidden effect at its true value on the calibrated model; then the noise re-fitted;
    // then the calibration parameters re-fitted with it (full range, as a trial that recalibrates).
    let cal_ps = calibrate::calibration_parameters_for(&model_m, &opts);
    let setups: Vec<(&str, Vec<EffectKind>)> = vec![("sensor", vec![EffectKind::SensorResponse]), ("casing", vec![EffectKind::CasingModes]), ("both", hid.to_vec())];
    let res: Vec<String> = setups.par_iter().map(|(name, ks)| {
        let mut m = cal.clone();
        for k in ks { m.effects.enable(*k); }
        for (p, v) in &tp { if ks.iter().any(|k| Param::of_effect(*k).contains(p)) { p.set(&mut m, *v); } }
        let j_true = j(&m, &reference, &opts);
        let (_, f_noise) = calibrate::fit(&m, &reference, &[Param::NoiseSnrDb], opts.sweeps, &opts).unwrap();
        let (mc, f_cal) = calibrate::fit(&m, &reference, &cal_ps, opts.sweeps, &opts).unwrap();
        format!("{name} at truth on cal: {j_true:.3}; noise re-fitted {:.3}; calibration re-fitted {:.3} (res {:?}, damp {:?}, snr {:?})", f_noise.objective_after, f_cal.objective_after, Param::ResonanceHz.get(&mc), Param::ResonanceDamping.get(&mc), Param::NoiseSnrDb.get(&mc))
    }).collect();
    for r in res { println!("{r}"); }
    // One-dimensional landscapes on the calibrated model (nothing else re-fitted).
    for (k, p, lo, hi) in [(EffectKind::SensorResponse, Param::SensorBandwidthHz, 300.0f64, 3000.0f64), (EffectKind::CasingModes, Param::CasingModeHz, 1000.0, 6000.0)] {
        let xs: Vec<f64> = (0..=24).map(|i| lo * (hi / lo).powf(i as f64 / 24.0)).collect();
        let js: Vec<f64> = xs.par_iter().map(|x| {
            let mut m = cal.clone();
            m.effects.enable(k);
            p.set(&mut m, *x);
            j(&m, &reference, &opts)
        }).collect();
        println!("landscape {}: {}", p.name(), xs.iter().zip(&js).map(|(x, y)| format!("{x:.0}:{y:.3}")).collect::<Vec<_>>().join(" "));
    }
}
