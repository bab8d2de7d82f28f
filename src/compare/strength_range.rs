//! The range of an effect's strength that the data cannot tell from the fitted value.
//!
//! A fitted strength is one point of a valley. On the gear base a 0.5 mesh variation is
//! fitted at 0.72 with the resonance 1.7 % high, and at the true resonance the objective's
//! minimum is at 0.5–0.6: the mesh harmonics reach the sensor through the resonance, so the
//! data see the product of the excitation and the transfer path at a few harmonics, and a
//! shift of one trades against the size of the other (docs/loop-notebook.md "The effect's
//! strength in stage 2"). The range is a profile, as a profile likelihood is built: the
//! strength is held at values on both sides of the fit, every other free parameter (the
//! calibrated ones and the effect's others) is re-fitted locally at each, and the range is
//! where that best objective stays within a tie band (2√2 σ, the band within which
//! [`super::diagnose::decide`] calls two trials tied; σ the larger seed scatter of the
//! calibrated model's objective and of the fitted machine's),
//! interpolated between profile points (a parabola from the fitted point, chords further out).

use super::calibrate::{calibration_parameters_for, fit_trial, fit_trial_evaluations, from_search_scale, to_search_scale, LoopError, LoopOptions, LoopProgress, Param};
use super::diagnose::{apply_trial, objective_scatter, Diagnosis, EffectTrial, SCATTER_SEEDS};
use super::Reference;
use crate::model::Machine;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Steps of the profile on each side of the fit, as shares of the parameter's search range
/// (in log units for a log-scaled one): on a log range of a factor 40 (mesh variation, slip)
/// they are factors of 1.12, 1.34 and 1.80.
pub const PROFILE_STEPS: [f64; 3] = [0.03, 0.08, 0.16];

/// An effect's strength with the range the data cannot tell from it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrengthRange {
    /// The strength (the effect's main parameter).
    pub parameter: Param,
    /// Its fitted value.
    pub fitted: f64,
    /// The lowest and highest values whose re-fitted objective is within `tolerance` of the
    /// fitted one's (interpolated between profile points).
    pub low: f64,
    pub high: f64,
    /// Whether the profile's outermost point on that side was still within the tolerance
    /// (the range reaches at least that far; it may reach farther), or was the search
    /// range's edge.
    pub low_open: bool,
    pub high_open: bool,
    /// The objective of the fitted value, re-fitted the same way as every profile point.
    pub objective_fitted: f64,
    /// The tolerance on the objective: 2√2 σ, σ the larger seed scatter of the calibrated
    /// model's objective and of the fitted machine's.
    pub tolerance: f64,
    /// The profile: (value, best objective with every other free parameter re-fitted), by value.
    pub profile: Vec<(f64, f64)>,
    /// The profile's lowest point (value, objective). Re-fitting every other parameter at
    /// each point walks along a valley the search's one-axis line searches do not, so it can
    /// sit below the fitted value's objective (on the gear base it lies nearer the true mesh
    /// variation in three of four seen cases, within the tolerance of the fitted one).
    #[serde(default)]
    pub lowest: (f64, f64),
}

impl StrengthRange {
    /// `"… = 7.22e-1 (4.00e-1 – 8.00e-1)"`, `≤` / `≥` before an open side's end, and the
    /// profile's lowest point when it is below the fitted one: one line for a verdict or a table.
    pub fn text(&self) -> String {
        let side = |v: f64, open: bool, ge: &str| if open { format!("{ge} {v:.3e}") } else { format!("{v:.3e}") };
        let lowest = if self.lowest.0 != self.fitted && self.lowest.1 < self.objective_fitted { format!("; lowest objective at {:.3e}", self.lowest.0) } else { String::new() };
        format!("{} = {:.3e} ({} – {}{lowest})", self.parameter.name(), self.fitted, side(self.low, self.low_open, "≤"), side(self.high, self.high_open, "≥"))
    }

    /// Whether `v` is inside the range (an open side counts as unbounded).
    pub fn contains(&self, v: f64) -> bool {
        (self.low_open || v >= self.low) && (self.high_open || v <= self.high)
    }
}

/// The profile's points for a strength fitted at `x` with search bounds `(lo, hi, log)`:
/// `x` itself and [`PROFILE_STEPS`] on each side, those beyond the bounds dropped (the bound
/// itself is kept once when a step crosses it), in increasing order.
pub fn profile_points(x: f64, lo: f64, hi: f64, log: bool) -> Vec<f64> {
    let to = |u: f64| from_search_scale(u, log);
    let from = |x: f64| to_search_scale(x, log);
    let (a, b) = (from(lo), from(hi));
    let u0 = from(x).clamp(a, b);
    let w = b - a;
    let mut us: Vec<f64> = vec![u0];
    for s in PROFILE_STEPS {
        for u in [u0 - s * w, u0 + s * w] {
            let u = u.clamp(a, b);
            if !us.iter().any(|v| (v - u).abs() <= 1e-12 * w.max(1.0)) {
                us.push(u);
            }
        }
    }
    us.sort_by(f64::total_cmp);
    us.into_iter().map(to).collect()
}

/// The parameters re-fitted at every profile point of trial `t` on the calibrated machine
/// `cal`, its strength `strength` held: the calibration's and those of every effect the trial
/// switched on (its own, and its [`EffectTrial::with_effect`]: a load zone's clearance under a
/// contact nonlinearity, the other effect of a joint trial), all but the strength (which for
/// `noise` is a calibration parameter itself).
fn released(cal: &Machine, t: &EffectTrial, strength: Param, opts: &LoopOptions) -> Vec<Param> {
    let mut ps = calibration_parameters_for(cal, opts);
    for p in std::iter::once(t.effect).chain(t.with_effect).flat_map(Param::of_effect) {
        if !ps.contains(&p) {
            ps.push(p);
        }
    }
    ps.retain(|p| *p != strength);
    ps
}

/// The model evaluations [`strength_range`] makes for `d`'s chosen effect on `cal`; 0 when it
/// makes none (nothing chosen, or the effect has no strength).
pub fn strength_range_evaluations(cal: &Machine, d: &Diagnosis, opts: &LoopOptions) -> usize {
    let Some((t, fm, p, x)) = chosen_fit(cal, d) else { return 0 };
    let (lo, hi, log) = p.bounds(&fm);
    profile_points(x, lo, hi, log).len() * fit_trial_evaluations(&fm, &[], &released(cal, t, p, opts), opts) + SCATTER_SEEDS.len()
}

/// `d`'s chosen trial, applied to `cal`, with its strength parameter and fitted value.
fn chosen_fit<'d>(cal: &Machine, d: &'d Diagnosis) -> Option<(&'d EffectTrial, Machine, Param, f64)> {
    let k = d.best?;
    let t = d.trials.iter().find(|t| t.effect == k)?;
    let (p, x) = t.parameter?;
    let mut fm = cal.clone();
    apply_trial(&mut fm, t);
    Some((t, fm, p, x))
}

/// The range of the chosen effect's strength of diagnosis `d` made on the calibrated machine
/// `cal` (the pair [`super::diagnose_with`] returns) against `reference`, judged with `opts`
/// (a second look's realisations when `d` is one). `None` when nothing was chosen or the
/// effect has no strength (a contact made nonlinear). Profile points run in parallel; every
/// evaluation is reported to `progress` (expected by the caller: [`strength_range_evaluations`]).
pub fn strength_range(cal: &Machine, d: &Diagnosis, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<Option<StrengthRange>, LoopError> {
    let Some((t, fm, p, x)) = chosen_fit(cal, d) else { return Ok(None) };
    let (lo, hi, log) = p.bounds(&fm);
    let points = profile_points(x, lo, hi, log);
    let refit = released(cal, t, p, opts);
    let profile: Vec<Result<(f64, f64), LoopError>> = points
        .par_iter()
        .map(|&v| {
            let mut held = fm.clone();
            p.set(&mut held, v);
            let (_, f) = fit_trial(&held, reference, &[], &refit, opts, progress)?;
            Ok((v, f.objective_after))
        })
        .collect();
    if progress.is_cancelled() {
        return Err(LoopError::Cancelled);
    }
    let profile: Vec<(f64, f64)> = profile.into_iter().collect::<Result<_, _>>()?;
    // The seed scatter of the fitted machine itself, besides the calibrated model's: with a
    // hidden noise the model without it draws nothing at random (scatter 0), and the range
    // would shrink to a point.
    let own = objective_scatter(&fm, reference, t.objective_fitted.unwrap_or(t.objective_after), opts)?;
    for _ in SCATTER_SEEDS {
        progress.tick();
    }
    let tolerance = 2.0 * std::f64::consts::SQRT_2 * d.objective_scatter.max(own);
    Ok(Some(range_of_profile(p, x, &profile, tolerance, (lo, hi), log)))
}

/// The range from a profile (by value, containing the fitted `x`): from the fitted point
/// outwards on each side, the last value whose objective is within `tolerance` of the fitted
/// point's, extended to where the objective between it and the next point crosses that level
/// (in the search coordinate: log for a log-scaled parameter): a parabola from the fitted
/// point, a chord between two further points. A side whose every point passes is open.
pub fn range_of_profile(p: Param, x: f64, profile: &[(f64, f64)], tolerance: f64, bounds: (f64, f64), log: bool) -> StrengthRange {
    let from = |v: f64| to_search_scale(v, log);
    let to = |u: f64| from_search_scale(u, log);
    let i0 = (0..profile.len()).min_by(|&a, &b| (from(profile[a].0) - from(x)).abs().total_cmp(&(from(profile[b].0) - from(x)).abs())).unwrap_or(0);
    let j_fit = profile.get(i0).map_or(f64::NAN, |q| q.1);
    let level = j_fit + tolerance;
    // Walks from the fitted point by `step` (±1); returns (the range's end, open).
    let walk = |step: isize| -> (f64, bool) {
        let mut i = i0 as isize;
        loop {
            let next = i + step;
            if next < 0 || next >= profile.len() as isize {
                let v = profile[i as usize].0;
                // An end at the search range's bound is closed by the bound itself (a
                // tolerance on the range's width: a noise level's bound is negative).
                let eps = 1e-9 * (bounds.1 - bounds.0).abs();
                let at_bound = (step < 0 && v <= bounds.0 + eps) || (step > 0 && v >= bounds.1 - eps);
                return (v, !at_bound);
            }
            let (a, b) = (profile[i as usize], profile[next as usize]);
            let inside = b.1.is_finite() && b.1 <= level;
            if !inside {
                // Crosses between a (inside) and b (outside, or not finite).
                if !b.1.is_finite() || b.1 <= a.1 {
                    return (a.0, false);
                }
                // From the fitted point the objective rises as the square of the distance
                // (a smooth minimum): a chord there would end the range too early, by far
                // for a sharp minimum whose first profile step is already well outside.
                // Further out, between two points, the chord.
                let share = (level - a.1) / (b.1 - a.1);
                let s = if i as usize == i0 { share.max(0.0).sqrt() } else { share }.clamp(0.0, 1.0);
                return (to(from(a.0) + s * (from(b.0) - from(a.0))), false);
            }
            i = next;
        }
    };
    let (low, low_open) = walk(-1);
    let (high, high_open) = walk(1);
    let lowest = profile.iter().copied().filter(|q| q.1.is_finite()).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap_or((x, j_fit));
    StrengthRange { parameter: p, fitted: x, low, high, low_open, high_open, objective_fitted: j_fit, tolerance, profile: profile.to_vec(), lowest }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::EffectKind;

    #[test]
    fn profile_points_are_symmetric_in_log_and_clipped_at_the_bounds() {
        let v = profile_points(0.2, 0.02, 0.8, true);
        assert_eq!(v.len(), 7);
        let w = (40f64).ln();
        for (i, s) in [-0.16, -0.08, -0.03, 0.0, 0.03, 0.08, 0.16].iter().enumerate() {
            assert!((v[i] - 0.2 * (s * w).exp()).abs() < 1e-12, "{v:?}");
        }
        // Near the top: the steps beyond it collapse onto the bound once.
        let v = profile_points(0.75, 0.02, 0.8, true);
        assert_eq!(v.last().copied(), Some(0.8));
        assert_eq!(v.iter().filter(|x| **x == 0.8).count(), 1);
        assert!(v.windows(2).all(|p| p[0] < p[1]));
        // Linear: steps are shares of the range.
        let v = profile_points(0.5, 0.0, 1.0, false);
        assert!((v[0] - 0.34).abs() < 1e-12 && (v[6] - 0.66).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn every_free_parameter_but_the_held_strength_is_re_fitted() {
        let mut m = crate::model::preset("cwru_6205_inner").unwrap();
        m.effects.enable(EffectKind::Noise);
        let opts = LoopOptions::default();
        // Noise: its strength is the calibration's noise level, held, not re-fitted.
        let trial = |k: EffectKind, with_effect: Option<EffectKind>| -> EffectTrial {
            serde_json::from_value(serde_json::json!({
                "effect": k, "with_effect": with_effect, "parameter": null, "extra_parameters": [], "objective_before": 6.0, "objective_after": 3.0,
                "envelope_nrmse_before": 3.0, "envelope_nrmse_after": 2.0, "reduction": 0.5, "evidence": "", "summary": ""
            }))
            .unwrap()
        };
        let r = released(&m, &trial(EffectKind::Noise, None), Param::NoiseSnrDb, &opts);
        assert!(!r.contains(&Param::NoiseSnrDb) && r.contains(&Param::ResonanceHz), "{r:?}");
        // A load zone: the load held, its clearance re-fitted with the calibration.
        let r = released(&m, &trial(EffectKind::LoadZone, None), Param::RadialLoadN, &opts);
        assert!(!r.contains(&Param::RadialLoadN) && r.contains(&Param::RadialClearanceM) && r.contains(&Param::NoiseSnrDb), "{r:?}");
        // A contact nonlinearity with its load zone: the load held, the clearance re-fitted too.
        let r = released(&m, &trial(EffectKind::NonlinearContact, Some(EffectKind::LoadZone)), Param::RadialLoadN, &opts);
        assert!(!r.contains(&Param::RadialLoadN) && r.contains(&Param::RadialClearanceM), "{r:?}");
        // A joint trial: the other effect's parameters re-fitted, the held one's strength not.
        let r = released(&m, &trial(EffectKind::CasingModes, Some(EffectKind::Unbalance)), Param::CasingModeHz, &opts);
        assert!(!r.contains(&Param::CasingModeHz) && r.contains(&Param::UnbalanceKgM), "{r:?}");
    }

    #[test]
    fn the_range_is_where_a_parabola_stays_within_the_tolerance() {
        // J(u) = 1 + (u − ln 0.5)² in log units; tolerance 0.04: |u − ln 0.5| ≤ 0.2 exactly,
        // and linear interpolation between points places each end within one step.
        let x = 0.5f64;
        let pts = profile_points(x, 0.02, 0.8, true);
        let profile: Vec<(f64, f64)> = pts.iter().map(|&v| (v, 1.0 + (v.ln() - x.ln()).powi(2))).collect();
        let r = range_of_profile(Param::MeshVariation, x, &profile, 0.04, (0.02, 0.8), true);
        assert!(!r.low_open && !r.high_open, "{r:?}");
        assert!((r.low.ln() - (x.ln() - 0.2)).abs() < 0.05 && (r.high.ln() - (x.ln() + 0.2)).abs() < 0.05, "{r:?}");
        assert!(r.contains(0.5) && !r.contains(0.3) && !r.contains(0.75));
        assert_eq!(r.lowest, (x, 1.0));
        assert!(!r.text().contains("lowest"), "{}", r.text());
        // A profile whose minimum is beside the fit: reported, the range still around the fit.
        let shifted: Vec<(f64, f64)> = pts.iter().map(|&v| (v, 1.0 + (v.ln() - 0.45f64.ln()).powi(2))).collect();
        let r = range_of_profile(Param::MeshVariation, x, &shifted, 0.04, (0.02, 0.8), true);
        assert!(r.lowest.0 < x && r.lowest.1 < r.objective_fitted && r.text().contains("lowest objective at"), "{r:?}");
        // A sharp minimum, every step outside: the parabola from the fitted point gives the
        // ends exactly (tolerance 0.004: |u − ln 0.5| ≤ 0.0632), where a chord would stop at
        // a third of the first step.
        let r = range_of_profile(Param::MeshVariation, x, &profile, 0.004, (0.02, 0.8), true);
        assert!((r.low.ln() - (x.ln() - 0.004f64.sqrt())).abs() < 1e-9 && (r.high.ln() - (x.ln() + 0.004f64.sqrt())).abs() < 1e-9, "{r:?}");
        // A flat profile: open on both sides, the range spanning every point (0.2: no step
        // reaches a bound).
        let pts = profile_points(0.2, 0.02, 0.8, true);
        let flat: Vec<(f64, f64)> = pts.iter().map(|&v| (v, 1.0)).collect();
        let r = range_of_profile(Param::MeshVariation, 0.2, &flat, 0.04, (0.02, 0.8), true);
        assert!(r.low_open && r.high_open && r.low == pts[0] && r.high == pts[pts.len() - 1]);
        // At the top bound: that side is closed by the bound.
        let pts = profile_points(0.8, 0.02, 0.8, true);
        let flat: Vec<(f64, f64)> = pts.iter().map(|&v| (v, 1.0)).collect();
        let r = range_of_profile(Param::MeshVariation, 0.8, &flat, 0.04, (0.02, 0.8), true);
        assert!(r.low_open && !r.high_open && r.high == 0.8, "{r:?}");
        // A linear range with a negative bound (a noise level, −10 to 40 dB): a profile
        // reaching −10 is closed there.
        let pts_db = profile_points(-8.0, -10.0, 40.0, false);
        assert_eq!(pts_db[0], -10.0);
        let flat_db: Vec<(f64, f64)> = pts_db.iter().map(|&v| (v, 1.0)).collect();
        let r = range_of_profile(Param::NoiseSnrDb, -8.0, &flat_db, 0.04, (-10.0, 40.0), false);
        assert!(!r.low_open && r.low == -10.0 && r.high_open, "{r:?}");
        // A failed point (not finite) closes the side at the last good one.
        let mut broken = flat.clone();
        broken[0].1 = f64::NAN;
        let r = range_of_profile(Param::MeshVariation, 0.8, &broken, 0.04, (0.02, 0.8), true);
        assert!(!r.low_open && r.low == pts[1], "{r:?}");
    }
}
