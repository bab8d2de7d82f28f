//! Joint trials of a stuck diagnosis (experimental, [`LoopOptions::joint_trials`]): when no
//! single effect is significant but the calibrated model is still above its floor margin, the
//! best single trials are tried in pairs, each pair's two effects fitted together.
//!
//! Two missing effects can hide each other from every single trial: a missing Hertzian contact
//! bends the fault depth, and a casing mode placed at the band's edge then imitates the rest
//! better than at its true frequency (session 62, bearing pair 10243: with the linearised
//! contact the edge re-calibrates to 5.58 against 5.93 at the true 3905 Hz; with the Hertzian
//! law the true frequency wins and reaches the true machine, 3.99 against 4.02;
//! docs/loop-notebook.md "Session 62: why bearing pair 10243 stops"). Only a trial of the two
//! together shows the pair. A pair is a finding only when each of its effects does its own
//! work: switching either off alone in the pair's fit must cost `significance` of the error
//! above the floor, so an effect that only rides along with a real one is refused.

use super::calibrate::{calibration_parameters_for, evaluate, fit_evaluations, fit_scanning, fit_trial, fit_trial_evaluations, objective, Fit, LoopError, LoopOptions, LoopProgress, Param};
use super::diagnose::{self, add_missing, Diagnosis, EffectTrial, HELD_OUT_SALT};
use super::residual::ResidualMap;
use super::{Comparison, Reference};
use crate::model::{EffectKind, Machine};
use rayon::prelude::*;

/// How many of a stuck diagnosis's best single trials are tried in pairs: three, three pairs.
pub const JOINT_TRIAL_TOP: usize = 3;

/// The pairs of `d`'s [`JOINT_TRIAL_TOP`] best single trials by objective (findings or not,
/// none that brought a companion or is joint already), each ordered best first.
pub fn joint_pairs(d: &Diagnosis) -> Vec<(EffectTrial, EffectTrial)> {
    let mut singles: Vec<&EffectTrial> = d.trials.iter().filter(|t| t.with_effect.is_none() && !t.joint).collect();
    singles.sort_by(|a, b| a.objective_after.total_cmp(&b.objective_after));
    singles.truncate(JOINT_TRIAL_TOP);
    let mut pairs = Vec::new();
    for i in 0..singles.len() {
        for j in i + 1..singles.len() {
            pairs.push((singles[i].clone(), singles[j].clone()));
        }
    }
    pairs
}

/// The value trial `t` fitted for `p`, if it fitted it.
fn trial_value(t: &EffectTrial, p: Param) -> Option<f64> {
    t.parameter.iter().chain(t.extra_parameters.iter()).find(|(q, _)| *q == p).map(|(_, v)| *v)
}

/// Where the joint trial of `a` and `b` starts and what it fits: (start, parameters fitted,
/// parameters scanned first, whether it re-does the calibration). With a re-calibrating effect
/// ([`diagnose::recalibrates`]: the casing mode), from `m`'s uncalibrated values, the other
/// effect at its single trial's values, the re-calibrating one's main parameter scanned, then
/// one sweep over both effects' and the calibration's parameters; otherwise from the calibrated
/// `cal` with both effects at their single trials' values, and a local re-fit of both effects'
/// parameters, the noise level and the calibration's parameters.
pub fn joint_start(m: &Machine, cal: &Machine, a: &EffectTrial, b: &EffectTrial, opts: &LoopOptions) -> (Machine, Vec<Param>, Vec<Param>, bool) {
    let recal: Vec<EffectKind> = [a.effect, b.effect].into_iter().filter(|k| diagnose::recalibrates(*k, opts)).collect();
    let base = if recal.is_empty() { cal } else { m };
    let mut t = diagnose::switched_on(&diagnose::switched_on(base, a.effect), b.effect);
    let mut own = diagnose::trial_parameters(a.effect, base);
    add_missing(&mut own, &diagnose::trial_parameters(b.effect, base));
    for trial in [a, b] {
        if recal.contains(&trial.effect) {
            continue;
        }
        for p in diagnose::trial_parameters(trial.effect, base) {
            if let Some(v) = trial_value(trial, p) {
                p.set(&mut t, v);
            }
        }
    }
    let mut fitted = own;
    if recal.is_empty() {
        add_missing(&mut fitted, &diagnose::TRIAL_REFINE);
    }
    add_missing(&mut fitted, &calibration_parameters_for(&t, opts));
    let scan: Vec<Param> = recal.iter().filter_map(|k| Param::main_of_effect(*k)).collect();
    (t, fitted, scan, !recal.is_empty())
}

/// The model evaluations of the joint trial of `a` and `b` ([`joint_start`]'s fit, then on
/// held-out realisations with two or more, then three ablations).
pub fn joint_trial_evaluations(m: &Machine, cal: &Machine, a: &EffectTrial, b: &EffectTrial, opts: &LoopOptions) -> usize {
    let (t, fitted, scan, recal) = joint_start(m, cal, a, b, opts);
    let fit = if recal { fit_evaluations(&t, &fitted, &scan, 1, opts) } else { fit_trial_evaluations(&t, &[], &fitted, opts) };
    fit + usize::from(opts.realisations >= 2) + 3
}

/// The joint trial of `a` and `b`: its fit ([`joint_start`]), reported as a trial of `a`'s
/// effect with `b`'s ([`EffectTrial::with_effect`], [`EffectTrial::joint`]), judged against
/// `before` (the calibrated model's comparison: on held-out realisations, `held_out`, with two
/// or more), with its ablations.
#[allow(clippy::too_many_arguments)]
fn joint_trial(m: &Machine, cal: &Machine, a: &EffectTrial, b: &EffectTrial, reference: &Reference, (before, map): (&Comparison, &ResidualMap), held_out: Option<&Comparison>, floor: f64, opts: &LoopOptions, progress: &LoopProgress) -> Result<EffectTrial, String> {
    let (t, fitted, scan, recal) = joint_start(m, cal, a, b, opts);
    t.validate().map_err(|e| e.to_string())?;
    let (fm, f) = if recal { fit_scanning(&t, reference, &fitted, &scan, 1, opts, progress) } else { fit_trial(&t, reference, &[], &fitted, opts, progress) }.map_err(|e| e.to_string())?;
    let mut trial = reported(a, b, &fm, &f, &fitted, (before, map), floor, recal);
    let judged = match held_out {
        Some(ch) => {
            let judged = diagnose::reseeded(&fm, HELD_OUT_SALT);
            let (ct, _) = evaluate(&judged, reference, opts).map_err(|e| format!("its fitted model could not be evaluated on the held-out realisations: {e}"))?;
            progress.tick();
            diagnose::rejudge(&mut trial, ch, &ct, floor, &opts.weights);
            judged
        }
        None => fm,
    };
    // Ablations: the fitted machine without both effects, and without each alone.
    let without = |off: &[EffectKind]| -> Option<f64> {
        let mut x = judged.clone();
        for k in off {
            x.effects.disable(*k);
        }
        let j = evaluate(&x, reference, opts).ok().map(|(c, _)| objective(&c, &opts.weights));
        progress.tick();
        j
    };
    let excess = trial.objective_before - floor;
    let cost = |j: Option<f64>| j.filter(|_| excess > 0.0).map(|j| (j - trial.objective_after) / excess);
    trial.objective_without_effect = without(&[a.effect, b.effect]);
    trial.effect_explained = cost(trial.objective_without_effect);
    trial.each_effect_explained = cost(without(&[a.effect])).zip(cost(without(&[b.effect])));
    Ok(trial)
}

/// The reported trial of a joint fit `fm` (its fit `f` of `fitted`): `a`'s main parameter,
/// every other fitted value, the shares against `before` and `floor`, and the evidence of both
/// in `map` (the diagnosis's residual map of `before`, as a single trial's).
#[allow(clippy::too_many_arguments)]
fn reported(a: &EffectTrial, b: &EffectTrial, fm: &Machine, f: &Fit, fitted: &[Param], (before, map): (&Comparison, &ResidualMap), floor: f64, recal: bool) -> EffectTrial {
    let j0 = a.objective_before;
    let j = f.objective_after;
    let after = |d: &str| f.domains.iter().find(|x| x.0 == d).map(|x| x.2).unwrap_or(f64::NAN);
    let domains = before.domains.iter().map(|d| (d.domain.clone(), d.metrics.nrmse_percent, after(&d.domain))).collect();
    let main = Param::main_of_effect(a.effect);
    let parameter = main.and_then(|p| p.get(fm).map(|v| (p, v)));
    let extra: Vec<(Param, f64)> = fitted.iter().filter(|p| Some(**p) != main).filter_map(|p| p.get(fm).map(|v| (*p, v))).collect();
    let (outside_band, pinned) = parameter.map_or((false, None), |(p, v)| diagnose::range_edge(p, v, fm));
    let (reduction, explained) = diagnose::shares(j0, j, floor);
    let (ev_a, share_a) = diagnose::trial_evidence(a.effect, None, map, fm);
    let (ev_b, share_b) = diagnose::trial_evidence(b.effect, None, map, fm);
    let evidence = format!("{}: {ev_a}; {}: {ev_b}", a.effect.name(), b.effect.name());
    let label = diagnose::trial_label_joint(a.effect, b.effect);
    let env0 = before.envelope_nrmse();
    let summary = diagnose::trial_summary(&label, &evidence, parameter, &extra, (env0, f.envelope_nrmse_after), (j0, j));
    EffectTrial {
        effect: a.effect,
        with_effect: Some(b.effect),
        joint: true,
        parameter,
        extra_parameters: extra,
        objective_before: j0,
        objective_after: j,
        envelope_nrmse_before: env0,
        envelope_nrmse_after: f.envelope_nrmse_after,
        domains,
        reduction,
        explained,
        evidence,
        evidence_share: share_a.max(share_b),
        tied_with_best: false,
        outside_band,
        pinned,
        summary,
        objective_without_effect: None,
        effect_explained: None,
        each_effect_explained: None,
        objective_fitted: None,
        from_uncalibrated: recal,
        fine_cell_won: f.fine_cell_won.clone(),
    }
}

/// Why joint trial `t` is no finding, or None when it is one: it must explain `significance`
/// of the error above the floor, improve on the calibrated objective `j0` beyond the tie width
/// and on the best single trial's `best_single` by more than it, have neither effect's main
/// parameter at an edge of its range (in its fitted machine's values, `t`'s own), and cost
/// `significance` when either effect alone is switched off in its fit.
pub fn joint_refusal(t: &EffectTrial, j0: f64, best_single: f64, scatter: f64, opts: &LoopOptions, b_at_edge: bool) -> Option<String> {
    let tie = diagnose::tie_width(scatter);
    let pct = |x: f64| format!("{:.0} %", 100.0 * x);
    if t.not_a_finding() || b_at_edge {
        return Some("an effect's parameter was fitted at an edge of its range".into());
    }
    if t.explained < opts.significance {
        return Some(format!("explains {} of the error above the floor", pct(t.explained)));
    }
    if j0 - t.objective_after < tie {
        return Some(format!("improves the objective by {:.2}, within the seed scatter (±{tie:.2})", j0 - t.objective_after));
    }
    if best_single - t.objective_after <= tie {
        return Some(format!("objective {:.2}, not below the best single trial's {best_single:.2} by more than the seed scatter (±{tie:.2})", t.objective_after));
    }
    match t.each_effect_explained {
        Some((ea, eb)) if ea >= opts.significance && eb >= opts.significance => None,
        Some((ea, eb)) => Some(format!("switching off {} alone costs {}, {} alone {}: one effect rides along", t.effect.name(), pct(ea), t.with_effect.map_or("", |k| k.name()), pct(eb))),
        None => Some("its ablations could not be evaluated".into()),
    }
}

/// Whether `b`'s main parameter sits at an edge of its range in joint trial `t`'s values.
fn with_effect_at_edge(t: &EffectTrial, fm_like: &Machine) -> bool {
    let Some(k) = t.with_effect else { return false };
    let Some(p) = Param::main_of_effect(k) else { return false };
    let Some(v) = t.extra_parameters.iter().find(|(q, _)| *q == p).map(|(_, v)| *v) else { return false };
    let (outside, pinned) = diagnose::range_edge(p, v, fm_like);
    outside || pinned.is_some()
}

/// `d`, the stuck final diagnosis of `m` calibrated to `cal` (judged with `opts`: its own
/// realisations), with its joint trials ([`Diagnosis::joint_trials`]); when one is a finding
/// ([`joint_refusal`]), the best such is chosen: it heads `d.trials`, `d.best` is its effect,
/// and applying it switches both on. Otherwise the verdict says why none is a finding.
pub fn with_joint_trials(m: &Machine, cal: &Machine, mut d: Diagnosis, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<Diagnosis, LoopError> {
    let pairs = joint_pairs(&d);
    if pairs.is_empty() {
        return Ok(d);
    }
    progress.expect(pairs.iter().map(|(a, b)| joint_trial_evaluations(m, cal, a, b, opts)).sum::<usize>() + 1 + usize::from(opts.realisations >= 2));
    let (before, _) = evaluate(cal, reference, opts)?;
    progress.tick();
    let held_out = if opts.realisations >= 2 {
        let (ch, _) = evaluate(&diagnose::reseeded(cal, HELD_OUT_SALT), reference, opts)?;
        progress.tick();
        Some(ch)
    } else {
        None
    };
    let floor = d.floor_objective;
    let outcomes: Vec<Result<EffectTrial, String>> = pairs.par_iter().map(|(a, b)| joint_trial(m, cal, a, b, reference, (&before, &d.residual_map), held_out.as_ref(), floor, opts, progress)).collect();
    if progress.is_cancelled() {
        return Err(LoopError::Cancelled);
    }
    let j0 = d.judged_objective();
    let best_single = d.trials.iter().map(|t| t.objective_after).fold(f64::INFINITY, f64::min);
    let mut judged: Vec<(EffectTrial, Option<String>)> = Vec::new();
    let mut failed = Vec::new();
    for ((a, b), o) in pairs.iter().zip(outcomes) {
        match o {
            Ok(t) => {
                let refusal = joint_refusal(&t, j0, best_single, d.objective_scatter, opts, with_effect_at_edge(&t, cal));
                judged.push((t, refusal));
            }
            Err(e) => failed.push(format!("{}: {e}", diagnose::trial_label_joint(a.effect, b.effect))),
        }
    }
    judged.sort_by(|x, y| x.0.objective_after.total_cmp(&y.0.objective_after));
    let chosen = judged.iter().find(|(_, r)| r.is_none()).map(|(t, _)| t.clone());
    let stuck_verdict = d.verdict.clone();
    d.joint_trials = judged.iter().map(|(t, _)| t.clone()).collect();
    match chosen {
        Some(t) => {
            let (ea, eb) = t.each_effect_explained.unwrap_or((f64::NAN, f64::NAN));
            d.verdict = format!(
                "{}: {} — explains {:.0} % of the error above the floor [a joint trial: with single effects the search was stuck ({stuck_verdict}); switching off {} alone costs {:.0} %, {} alone {:.0} %]",
                t.label(),
                t.summary,
                100.0 * t.explained,
                t.effect.name(),
                100.0 * ea,
                t.with_effect.map_or("", |k| k.name()),
                100.0 * eb
            );
            d.best = Some(t.effect);
            d.near_floor_lead = None;
            d.trials.insert(0, t);
        }
        None => {
            let why: Vec<String> = judged.iter().map(|(t, r)| format!("{}: {}", t.label(), r.as_deref().unwrap_or(""))).chain(failed).collect();
            d.verdict = format!("{stuck_verdict}; joint trials of its {} best: none is a finding ({})", JOINT_TRIAL_TOP, why.join("; "));
        }
    }
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::EffectKind::*;

    /// A single trial of `k` that reached objective `j` from 6.0 against a floor of 2.0.
    fn single(k: EffectKind, j: f64) -> EffectTrial {
        serde_json::from_value(serde_json::json!({
            "effect": k, "parameter": null, "extra_parameters": [], "objective_before": 6.0, "objective_after": j,
            "envelope_nrmse_before": 3.0, "envelope_nrmse_after": 2.0, "reduction": (6.0 - j) / 6.0,
            "explained": (6.0 - j) / 4.0, "evidence": "", "summary": ""
        }))
        .unwrap()
    }

    #[test]
    fn the_three_best_single_trials_are_paired_best_first() {
        let mut companion = single(NonlinearContact, 3.0);
        companion.with_effect = Some(LoadZone);
        let d = Diagnosis { trials: vec![single(GearMesh, 5.5), single(CasingModes, 4.0), companion, single(Unbalance, 5.0), single(Slip, 4.5)], ..Default::default() };
        let pairs: Vec<(EffectKind, EffectKind)> = joint_pairs(&d).iter().map(|(a, b)| (a.effect, b.effect)).collect();
        // The companion trial is no single effect; gear mesh is fourth.
        assert_eq!(pairs, vec![(CasingModes, Slip), (CasingModes, Unbalance), (Slip, Unbalance)]);
        assert!(joint_pairs(&Diagnosis { trials: vec![single(Slip, 4.5)], ..Default::default() }).is_empty());
    }

    #[test]
    fn a_joint_trial_is_a_finding_only_when_each_effect_does_its_own_work() {
        let opts = LoopOptions::default();
        let (j0, scatter) = (6.0, 0.1);
        let joint = |j: f64, each: (f64, f64)| EffectTrial { with_effect: Some(NonlinearContact), joint: true, each_effect_explained: Some(each), ..single(CasingModes, j) };
        // 3.0 from 6.0 above a floor of 2.0: 75 % explained, below the best single's 4.0.
        assert_eq!(joint_refusal(&joint(3.0, (0.5, 0.3)), j0, 4.0, scatter, &opts, false), None);
        // A passenger: switching the contact nonlinearity off alone costs 5 %.
        let r = joint_refusal(&joint(3.0, (0.5, 0.05)), j0, 4.0, scatter, &opts, false).unwrap();
        assert!(r.contains("rides along") && r.contains("nonlinear_contact alone 5 %"), "{r}");
        // No better than the best single trial beyond the tie width (2√2 × 0.1 = 0.28).
        let r = joint_refusal(&joint(3.8, (0.5, 0.3)), j0, 4.0, scatter, &opts, false).unwrap();
        assert!(r.contains("not below the best single trial's 4.00"), "{r}");
        // Below the significance share: 5.5 explains 12.5 %.
        assert!(joint_refusal(&joint(5.5, (0.5, 0.3)), j0, 9.0, scatter, &opts, false).unwrap().contains("explains 12 %"));
        // Either effect at an edge of its range.
        assert!(joint_refusal(&EffectTrial { outside_band: true, ..joint(3.0, (0.5, 0.3)) }, j0, 4.0, scatter, &opts, false).is_some());
        assert!(joint_refusal(&joint(3.0, (0.5, 0.3)), j0, 4.0, scatter, &opts, true).is_some());
        // Unknown ablations are no finding.
        assert!(joint_refusal(&EffectTrial { each_effect_explained: None, ..joint(3.0, (0.5, 0.3)) }, j0, 4.0, scatter, &opts, false).is_some());
    }

    #[test]
    fn a_joint_trial_with_a_casing_mode_recalibrates_from_the_uncalibrated_values() {
        let mut m = crate::model::preset("mfs_inner").unwrap();
        m.effects.enable(Noise);
        let mut cal = m.clone();
        Param::NoiseSnrDb.set(&mut cal, 3.0);
        let mut casing = single(CasingModes, 4.0);
        casing.parameter = Some((Param::CasingModeHz, 7000.0));
        let mut unbalance = single(Unbalance, 4.5);
        unbalance.parameter = Some((Param::UnbalanceKgM, 2.5e-4));
        let opts = LoopOptions::default();
        let (t, fitted, scan, recal) = joint_start(&m, &cal, &casing, &unbalance, &opts);
        assert!(recal && t.effects.is_on(CasingModes) && t.effects.is_on(Unbalance));
        assert_eq!(scan, vec![Param::CasingModeHz]);
        // The other effect starts at its trial's value, the base at the uncalibrated one.
        assert_eq!(Param::UnbalanceKgM.get(&t), Some(2.5e-4));
        assert_eq!(Param::NoiseSnrDb.get(&t), Param::NoiseSnrDb.get(&m));
        assert!(fitted.contains(&Param::CasingModeHz) && fitted.contains(&Param::UnbalanceKgM) && fitted.contains(&Param::NoiseSnrDb));
        // Two plain effects: from the calibrated model, both at their trials' values.
        let mut slip = single(Slip, 4.2);
        slip.parameter = Some((Param::SlipPercent, 1.5));
        let (t, fitted, scan, recal) = joint_start(&m, &cal, &unbalance, &slip, &opts);
        assert!(!recal && scan.is_empty());
        assert_eq!(Param::NoiseSnrDb.get(&t), Some(3.0));
        assert_eq!((Param::UnbalanceKgM.get(&t), Param::SlipPercent.get(&t)), (Some(2.5e-4), Some(1.5)));
        assert!(fitted.contains(&Param::UnbalanceKgM) && fitted.contains(&Param::SlipPercent) && fitted.contains(&Param::NoiseSnrDb));
    }
}
