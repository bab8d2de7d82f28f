//! Hidden-effect cases: the "measurement" is simulated with one or more effects the model is not
//! told about (random parameters, a different seed, perturbed baseline parameters, measurement
//! noise at SNR 0–20 dB); the model starts without them. With one hidden effect the search must
//! rank it first; with two, the loop must find and apply both, one per round, and then answer
//! "nothing significant is missing"; with nothing hidden it must answer that at once.

use super::calibrate::{evaluate, objective, LoopError, LoopOptions, Param};
use super::diagnose::{diagnose_with, run_loop, Round};
use super::Reference;
use crate::model::{self, EffectKind, Machine};
use crate::signal::synth;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// One case's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    /// The hidden effect (None: a control with nothing hidden).
    pub hidden: Option<EffectKind>,
    /// Its true parameter, if any.
    pub true_parameter: Option<(Param, f64)>,
    /// Measurement SNR, dB.
    pub snr_db: f64,
    /// The ranking, best first.
    pub ranking: Vec<EffectKind>,
    /// 1-based rank of the hidden effect (None if not ranked or a control).
    pub rank_of_hidden: Option<usize>,
    /// What the search chose (None: "nothing significant is missing").
    pub chosen: Option<EffectKind>,
    /// Envelope NRMSE of the calibrated model, %.
    pub envelope_nrmse_before: f64,
    /// Envelope NRMSE after applying the chosen effect, %.
    pub envelope_nrmse_after: f64,
    /// The verdict text.
    pub verdict: String,
    /// Relative objective reduction of each trial, in ranking order.
    pub reductions: Vec<f64>,
    /// The seed floor of the objective (see [`super::diagnose::seed_floor`]).
    #[serde(default)]
    pub floor_objective: f64,
    /// The objective / floor ratio the decision needed ([`super::Diagnosis::floor_ratio_needed`]).
    #[serde(default)]
    pub floor_ratio_needed: f64,
    /// The seed scatter of the objective (see [`super::diagnose::objective_scatter`]).
    #[serde(default)]
    pub objective_scatter: f64,
    /// The trials, best first (per-domain NRMSE before and after each).
    #[serde(default)]
    pub trials: Vec<super::diagnose::EffectTrial>,
    /// Calibrated parameters pinned at the edge of their range (`Fit::at_bound`), and whether
    /// the trials therefore started from the uncalibrated values.
    #[serde(default)]
    pub pinned: Vec<Param>,
    #[serde(default)]
    pub unbent: bool,
    /// With `LoopOptions::unbend_when_short`: the effect the plain search chose, when its
    /// short answer was searched again unbent ([`super::diagnose::Diagnosis::short_plain`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub short_plain_chosen: Option<EffectKind>,
    /// With `LoopOptions::uncalibrated_start_top`: the effects whose second start won
    /// ([`super::diagnose::Diagnosis::top_second_starts_won`]); empty, the case is the one
    /// the search without the option gives.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub top_second_starts_won: Vec<EffectKind>,
    /// With `LoopOptions::fine_force_scan`: the effects with a trial that records a fine-cell
    /// win ([`super::diagnose::Diagnosis::fine_cell_won`]); empty, the case is the one the
    /// search without the option gives.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fine_cell_won: Vec<EffectKind>,
    /// What the true machine itself scores against the measurement ([`oracle`]).
    #[serde(default)]
    pub oracle: Oracle,
    /// The chosen effect's strength range ([`LoopOptions::strength_range`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strength_range: Option<super::strength_range::StrengthRange>,
    /// The removal trials of the starting model ([`LoopOptions::removal_trials`];
    /// [`super::Diagnosis::removals`]): every part of it is in the true machine, so a
    /// contradicted one is a false contradiction.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub removals: Vec<super::removal::RemovalTrial>,
    /// Wall time, s.
    pub seconds: f64,
}

/// Seeds of the true machine's re-runs behind [`Oracle`] (salted into the truth's own seed;
/// none is the measurement's).
const ORACLE_SALTS: [u64; 4] = [0x0AC1_E001, 0x0AC1_E002, 0x0AC1_E003, 0x0AC1_E004];

/// What only a hidden-effect case can know: the true machine, re-run with other seeds (its
/// noise, slip and roughness drawn anew), scored against the measurement in the search's own
/// objective; and the same seeds with the hidden effects switched off. Together they say
/// whether any model could have done better than the calibrated one, and whether the hidden
/// effect is what it would take: a case is *recoverable* only when both hold.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Oracle {
    /// (objective, envelope NRMSE %) of the true machine, one per seed.
    pub truth: Vec<(f64, f64)>,
    /// The same with the hidden effects switched off, seed for seed (empty for a control).
    pub without_hidden: Vec<(f64, f64)>,
}

fn mean_sd(x: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = x.clone().count();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = x.clone().sum::<f64>() / n as f64;
    let sd = if n > 1 { (x.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt() } else { 0.0 };
    (mean, sd)
}

impl Oracle {
    /// Mean and standard deviation of the true machine's objective over the seeds.
    pub fn truth_objective(&self) -> (f64, f64) {
        mean_sd(self.truth.iter().map(|t| t.0))
    }

    /// Mean envelope NRMSE (%) of the true machine: the lowest a perfect model can expect.
    pub fn truth_envelope_nrmse(&self) -> f64 {
        mean_sd(self.truth.iter().map(|t| t.1)).0
    }

    /// Mean objective of the true machine without the hidden effects (None for a control).
    pub fn without_hidden_objective(&self) -> Option<f64> {
        (!self.without_hidden.is_empty()).then(|| mean_sd(self.without_hidden.iter().map(|t| t.0)).0)
    }

    /// Whether switching the hidden effects off costs the true machine objective beyond its
    /// scatter: the mean of the paired differences (without − with, seed for seed) above twice
    /// its standard error. None for a control.
    pub fn hidden_is_visible(&self) -> Option<bool> {
        if self.without_hidden.is_empty() || self.without_hidden.len() != self.truth.len() {
            return None;
        }
        let (mean, sd) = mean_sd(self.without_hidden.iter().zip(&self.truth).map(|(w, t)| w.0 - t.0));
        Some(mean > 2.0 * sd / (self.truth.len() as f64).sqrt())
    }

    /// Whether a model scoring `calibrated` is measurably worse than the true machine: above
    /// its mean by more than twice its seed-to-seed standard deviation.
    pub fn has_headroom(&self, calibrated: f64) -> bool {
        let (mean, sd) = self.truth_objective();
        calibrated - mean > 2.0 * sd
    }

    /// Whether a search could find the hidden effect at all: the calibrated model is worse
    /// than the truth ([`Self::has_headroom`]) and the hidden effect carries the difference
    /// ([`Self::hidden_is_visible`]). False for a control.
    pub fn recoverable(&self, calibrated: f64) -> bool {
        self.hidden_is_visible() == Some(true) && self.has_headroom(calibrated)
    }

    /// Why a case is or is not recoverable (None for a control): "yes"; "absorbed" (the
    /// hidden effect costs the truth objective, but the calibrated model already scores like
    /// the truth: its re-fitted parameters stand in for the effect); "invisible" (the hidden
    /// effect changes nothing the objective sees at this SNR); "invisible, the calibration
    /// falls short" (worse than the truth, but not for want of the hidden effect).
    pub fn reading(&self, calibrated: f64) -> Option<&'static str> {
        Some(match (self.hidden_is_visible()?, self.has_headroom(calibrated)) {
            (true, true) => "yes",
            (true, false) => "absorbed",
            (false, false) => "invisible",
            (false, true) => "invisible, the calibration falls short",
        })
    }

    /// The share of the calibrated model's excess over the true machine that a model scoring
    /// `after` recovers: `(calibrated − after) / (calibrated − truth)` (NaN without excess).
    pub fn recovered(&self, calibrated: f64, after: f64) -> f64 {
        let excess = calibrated - self.truth_objective().0;
        if excess > 0.0 {
            (calibrated - after) / excess
        } else {
            f64::NAN
        }
    }
}

/// Scores the true machine `truth`, re-run with the [`ORACLE_SALTS`] seeds, against the
/// measurement, with and without the `hidden` effects (see [`Oracle`]). Eight evaluations,
/// in parallel.
pub fn oracle(truth: &Machine, hidden: &[EffectKind], reference: &Reference, opts: &LoopOptions) -> Result<Oracle, LoopError> {
    use rayon::prelude::*;
    let mut without = truth.clone();
    for k in hidden {
        without.effects.disable(*k);
    }
    let runs: Vec<(bool, u64)> = ORACLE_SALTS.iter().map(|s| (false, *s)).chain(ORACLE_SALTS.iter().filter(|_| !hidden.is_empty()).map(|s| (true, *s))).collect();
    let scores = runs
        .par_iter()
        .map(|(off, salt)| {
            let mut m = if *off { without.clone() } else { truth.clone() };
            m.seed = truth.seed ^ salt;
            let (c, _) = evaluate(&m, reference, opts)?;
            Ok((*off, (objective(&c, &opts.weights), c.envelope_nrmse())))
        })
        .collect::<Result<Vec<_>, LoopError>>()?;
    Ok(Oracle {
        truth: scores.iter().filter(|s| !s.0).map(|s| s.1).collect(),
        without_hidden: scores.iter().filter(|s| s.0).map(|s| s.1).collect(),
    })
}

impl CaseResult {
    /// The calibrated model's objective as the trials were judged against it (on held-out
    /// realisations with several).
    pub fn calibrated_objective(&self) -> f64 {
        self.trials.first().map_or(f64::NAN, |t| t.objective_before)
    }

    /// The hidden effect's trial, if it was tried.
    pub fn hidden_trial(&self) -> Option<&super::diagnose::EffectTrial> {
        self.hidden.and_then(|k| self.trials.iter().find(|t| t.effect == k))
    }

    /// [`Oracle::recoverable`] for this case's calibrated model.
    pub fn recoverable(&self) -> bool {
        self.oracle.recoverable(self.calibrated_objective())
    }

    /// Why a recoverable hidden effect was not chosen; None when it was, when the case is not
    /// recoverable, or for a control. A case that chose nothing with its model under the
    /// decision's floor ratio (the test of `diagnose::above_floor`, read off the recorded
    /// ratio; 0 when the decision used none) was held back by the margin, whatever the trials
    /// showed; a case that chose another effect (also possible under the margin with the
    /// near-floor rule) was missed by the search.
    pub fn miss(&self) -> Option<Miss> {
        if self.hidden.is_none() || self.chosen == self.hidden || !self.recoverable() {
            return None;
        }
        let (j, needed, rank) = (self.calibrated_objective(), self.floor_ratio_needed, self.rank_of_hidden);
        Some(if self.chosen.is_none() && needed > 0.0 && j < needed * self.floor_objective {
            Miss::UnderMargin { ratio: j / self.floor_objective, needed, rank }
        } else {
            Miss::Searched { chosen: self.chosen, rank }
        })
    }
}

/// Why a recoverable hidden effect was not chosen ([`CaseResult::miss`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Miss {
    /// The calibrated model sat at `ratio` × its floor, under the `needed` ratio of the
    /// decision's floor margin, so nothing was judged missing; `rank` is the hidden effect's.
    UnderMargin { ratio: f64, needed: f64, rank: Option<usize> },
    /// Above the margin, the search chose another effect, or nothing (None) because no trial
    /// was significant; `rank` is the hidden effect's.
    Searched { chosen: Option<EffectKind>, rank: Option<usize> },
}

impl Miss {
    /// One line: `"under the floor margin at 1.42 × its floor (needs 1.50 ×), ranked 1"` or
    /// `"ranked 3, unbalance chosen"`.
    pub fn text(&self) -> String {
        let rank = |r: &Option<usize>| r.map_or("not ranked".to_string(), |r| format!("ranked {r}"));
        match self {
            Miss::UnderMargin { ratio, needed, rank: r } => format!("under the floor margin at {ratio:.2} × its floor (needs {needed:.2} ×), {}", rank(r)),
            Miss::Searched { chosen, rank: r } => format!("{}, {}", rank(r), chosen.map_or("no trial significant".to_string(), |k| format!("{} chosen", k.name()))),
        }
    }
}

fn uniform(r: &mut impl rand::Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * r.random::<f64>()
}

/// Switches `k` on in `m` with a random, clearly visible parameter (seeded), returning the
/// parameter drawn.
pub fn hide_effect(m: &mut Machine, k: EffectKind, rng: &mut impl rand::Rng) -> Option<(Param, f64)> {
    m.effects.enable(k);
    let shaft = m.shaft_speeds_hz().ok().and_then(|s| s.first().copied()).unwrap_or(10.0);
    let (p, v) = match k {
        EffectKind::LoadZone => (Param::RadialLoadN, uniform(rng, 30.0, 300.0)),
        EffectKind::Slip => (Param::SlipPercent, uniform(rng, 1.0, 3.0)),
        EffectKind::CasingModes => (Param::CasingModeHz, uniform(rng, 0.15, 0.35) * m.fs_hz),
        EffectKind::GearMesh => (Param::MeshVariation, uniform(rng, 0.2, 0.5)),
        EffectKind::ToothFault => (Param::ToothLoss, uniform(rng, 0.3, 0.8)),
        EffectKind::SpeedFluctuation => (Param::SpeedFluctuationPercent, uniform(rng, 0.5, 2.0)),
        // Below the structural resonance, where the machine's signal is: a roll-off above it
        // acts only on the band the measurement noise fills, and no comparison sees it (README
        // "Detection limits": 2-4.5 kHz on the 1.3 kHz MFS rigs sat at the floor even at 20 dB).
        EffectKind::SensorResponse => {
            let resonance_hz = m.bearings.first().map_or(0.1 * m.fs_hz, |b| b.resonator_frequency_hz);
            (Param::SensorBandwidthHz, (uniform(rng, 0.45, 0.75) * resonance_hz).max(Param::SensorBandwidthHz.bounds(m).0))
        }
        EffectKind::Unbalance => (Param::UnbalanceKgM, 10f64.powf(uniform(rng, -3.7, -3.0))),
        EffectKind::Misalignment => (Param::Misalignment2xN, uniform(rng, 10.0, 50.0)),
        EffectKind::ExtendedFault => (Param::ExtendedFaultDepthM, uniform(rng, 5e-6, 20e-6)),
        EffectKind::PathModulation => {
            if let Some(pm) = m.effects.path_modulation.as_mut() {
                pm.frequency_hz = shaft;
            }
            (Param::PathModulationDepth, uniform(rng, 0.3, 0.7))
        }
        EffectKind::BeltDrive => (Param::BeltForceN, uniform(rng, 5.0, 30.0)),
        EffectKind::Noise => (Param::NoiseSnrDb, uniform(rng, 0.0, 20.0)),
        EffectKind::NonlinearContact => return None,
    };
    p.set(m, v);
    Some((p, v))
}

/// Builds a case: `(measurement machine, model machine, true parameter, snr)` from a base
/// machine. The base must not have `hidden` on (for `nonlinear_contact` the model gets the
/// linearised contact). Every measurement has noise (SNR 0–20 dB); the model has the noise
/// effect on (its level is calibrated) unless the hidden effect is noise itself.
pub fn make_case(base: &Machine, hidden: Option<EffectKind>, seed: u64) -> (Machine, Machine, Option<(Param, f64)>, f64) {
    let (truth, model_m, params, snr) = make_case_hiding(base, hidden.as_slice(), seed);
    (truth, model_m, params.first().copied(), snr)
}

/// What a case fixes instead of drawing it, for a detection-limit sweep: the first hidden
/// effect's main parameter and the measurement SNR. Everything else (seed, perturbed
/// baseline) is drawn as usual, so cases with one seed differ only in what is fixed here.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CaseSetting {
    /// The first hidden effect's main parameter (for `noise`: its SNR, dB).
    pub value: Option<f64>,
    /// Measurement SNR, dB (not with `noise` hidden: its value is the SNR).
    pub snr_db: Option<f64>,
}

/// [`make_case`] with any number of hidden effects: each is switched off in the model and on,
/// with a random parameter, in the measurement. Returns the true parameters in the order of
/// `hidden` (effects without a parameter, such as `nonlinear_contact`, add none). With one
/// effect it draws exactly what [`make_case`] draws, so the single-effect tables stay
/// reproducible.
pub fn make_case_hiding(base: &Machine, hidden: &[EffectKind], seed: u64) -> (Machine, Machine, Vec<(Param, f64)>, f64) {
    make_case_set(base, hidden, seed, &CaseSetting::default())
}

/// [`make_case_hiding`] with what `setting` fixes put in place of the draws. Every number is
/// still drawn, in the same order, so a fixed value changes nothing else in the case.
pub fn make_case_set(base: &Machine, hidden: &[EffectKind], seed: u64, setting: &CaseSetting) -> (Machine, Machine, Vec<(Param, f64)>, f64) {
    let mut rng = synth::rng(seed ^ 0xC0FFEE);
    let mut model_m = base.clone();
    for k in hidden {
        model_m.effects.disable(*k);
    }
    let noise_hidden = hidden.contains(&EffectKind::Noise);
    if !noise_hidden {
        model_m.effects.enable(EffectKind::Noise);
        if let Some(n) = model_m.effects.noise.as_mut() {
            n.snr_db = 10.0;
        }
    } else {
        model_m.effects.disable(EffectKind::Noise);
    }
    let mut truth = base.clone();
    truth.seed = base.seed.wrapping_add(1000 + seed);
    // Perturbed baseline: the model's parameters are not exactly right.
    for (p, rel) in [(Param::ResonanceHz, 0.03), (Param::ResonanceDamping, 0.15), (Param::FaultDepthM, 0.2)] {
        if let Some(v) = p.get(&truth) {
            p.set(&mut truth, v * (1.0 + uniform(&mut rng, -rel, rel)));
        }
    }
    let mut true_parameters: Vec<(Param, f64)> = hidden.iter().filter_map(|k| hide_effect(&mut truth, *k, &mut rng)).collect();
    if let (Some(v), Some(first)) = (setting.value, hidden.first()) {
        if let Some(tp) = true_parameters.iter_mut().find(|(p, _)| Param::main_of_effect(*first) == Some(*p)) {
            tp.1 = v;
            tp.0.set(&mut truth, v);
        }
    }
    let snr = if noise_hidden {
        true_parameters.iter().find(|(p, _)| *p == Param::NoiseSnrDb).map(|(_, v)| *v).unwrap_or(10.0)
    } else {
        // Drawn even when fixed, so the rest of the stream does not move.
        let drawn = uniform(&mut rng, 0.0, 20.0);
        let s = setting.snr_db.unwrap_or(drawn);
        truth.effects.enable(EffectKind::Noise);
        Param::NoiseSnrDb.set(&mut truth, s);
        s
    };
    (truth, model_m, true_parameters, snr)
}

/// Runs one case: simulate the measurement (`duration_s`), diagnose the model against it.
pub fn run_case(base: &Machine, hidden: Option<EffectKind>, seed: u64, duration_s: f64, opts: &LoopOptions) -> Result<CaseResult, LoopError> {
    run_case_set(base, hidden, seed, duration_s, &CaseSetting::default(), opts)
}

/// [`run_case`] with what `setting` fixes (see [`make_case_set`]).
pub fn run_case_set(base: &Machine, hidden: Option<EffectKind>, seed: u64, duration_s: f64, setting: &CaseSetting, opts: &LoopOptions) -> Result<CaseResult, LoopError> {
    let t0 = std::time::Instant::now();
    let (mut truth, model_m, true_parameters, snr_db) = make_case_set(base, hidden.as_slice(), seed, setting);
    let true_parameter = true_parameters.first().copied();
    truth.duration_s = duration_s;
    let measured = model::simulate(&truth)?;
    let reference = Reference::new(&measured, &opts.compare)?;
    let (_, d) = diagnose_with(&model_m, &reference, opts, &super::calibrate::LoopProgress::new(&|_, _| true))?;
    let oracle = oracle(&truth, hidden.as_slice(), &reference, opts)?;
    let ranking: Vec<EffectKind> = d.trials.iter().map(|t| t.effect).collect();
    let rank_of_hidden = hidden.and_then(|k| ranking.iter().position(|x| *x == k).map(|i| i + 1));
    // The trials' own "before" (on the held-out realisations when they were judged on them;
    // with one realisation the calibrated comparison's, as in `d.domains`).
    let env_before = d.trials.first().map(|t| t.envelope_nrmse_before).or_else(|| d.envelope_nrmse()).unwrap_or(f64::NAN);
    let env_after = d.best.and_then(|k| d.trials.iter().find(|t| t.effect == k)).map(|t| t.envelope_nrmse_after).unwrap_or(env_before);
    Ok(CaseResult {
        hidden,
        true_parameter,
        snr_db,
        ranking,
        rank_of_hidden,
        chosen: d.best,
        envelope_nrmse_before: env_before,
        envelope_nrmse_after: env_after,
        verdict: d.verdict,
        reductions: d.trials.iter().map(|t| t.reduction).collect(),
        floor_objective: d.floor_objective,
        floor_ratio_needed: d.floor_ratio_needed,
        objective_scatter: d.objective_scatter,
        trials: d.trials.clone(),
        pinned: d.calibration.pinned(),
        unbent: d.unbent,
        short_plain_chosen: d.short_plain.as_ref().map(|s| s.chosen),
        top_second_starts_won: d.top_second_starts_won.clone(),
        fine_cell_won: d.fine_cell_won.clone(),
        oracle,
        strength_range: d.strength_range.clone(),
        removals: d.removals.clone(),
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// The outcome of a case with several hidden effects, run through the loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MultiCaseResult {
    /// The hidden effects.
    pub hidden: Vec<EffectKind>,
    /// Their true parameters.
    pub true_parameters: Vec<(Param, f64)>,
    /// Measurement SNR, dB.
    pub snr_db: f64,
    /// Every round of the loop: metrics of the calibrated model, verdict, effect applied.
    pub history: Vec<Round>,
    /// The effects applied, in order.
    pub applied: Vec<EffectKind>,
    /// Every hidden effect was applied.
    pub found_all: bool,
    /// Effects applied that were not hidden (false claims).
    pub false_claims: Vec<EffectKind>,
    /// Each hidden effect never applied, with its 1-based rank and explained share in the last
    /// round's ranking (None: not in it).
    pub missed: Vec<(EffectKind, Option<(usize, f64)>)>,
    /// The loop ended on "nothing significant is missing" (and not on the round limit).
    pub ended_clean: bool,
    /// The applied effects' parameters at the end: as the last round's calibration re-fitted
    /// them, or as applied for an effect the last round put in.
    #[serde(default)]
    pub final_values: Vec<(Param, f64)>,
    /// The true machine against the measurement, with and without all hidden effects
    /// ([`oracle`]): how close the last round came to what any model could reach.
    #[serde(default)]
    pub oracle: Oracle,
    /// Wall time, s.
    pub seconds: f64,
}

/// Runs a case with the effects `hidden` (see [`make_case_hiding`]) through [`run_loop`] for up
/// to `rounds` rounds: each round calibrates, diagnoses and applies the effect it chooses.
pub fn run_multi_case(base: &Machine, hidden: &[EffectKind], seed: u64, duration_s: f64, rounds: usize, opts: &LoopOptions) -> Result<MultiCaseResult, LoopError> {
    run_multi_case_set(base, hidden, seed, duration_s, rounds, &CaseSetting::default(), opts)
}

/// [`run_multi_case`] with what `setting` fixes (see [`make_case_set`]).
pub fn run_multi_case_set(base: &Machine, hidden: &[EffectKind], seed: u64, duration_s: f64, rounds: usize, setting: &CaseSetting, opts: &LoopOptions) -> Result<MultiCaseResult, LoopError> {
    let t0 = std::time::Instant::now();
    let (mut truth, model_m, true_parameters, snr_db) = make_case_set(base, hidden, seed, setting);
    truth.duration_s = duration_s;
    let measured = model::simulate(&truth)?;
    let (_, history, last) = run_loop(&model_m, &measured, rounds, opts, &|_, _| true)?;
    let oracle = oracle(&truth, hidden, &Reference::new(&measured, &opts.compare)?, opts)?;
    let applied = super::diagnose::applied_effects(&history);
    let final_values = final_effect_values(&history, &last.calibration.parameters);
    let last_ranking = history.last().map(|r| r.ranking.as_slice()).unwrap_or_default();
    let missed = hidden.iter().filter(|k| !applied.contains(k)).map(|k| (*k, last_ranking.iter().position(|x| x.0 == *k).map(|i| (i + 1, last_ranking[i].2)))).collect();
    Ok(MultiCaseResult {
        missed,
        hidden: hidden.to_vec(),
        true_parameters,
        snr_db,
        found_all: hidden.iter().all(|k| applied.contains(k)),
        false_claims: applied.iter().filter(|k| !hidden.contains(k)).copied().collect(),
        ended_clean: history.last().is_some_and(|r| r.applied.is_none()),
        applied,
        history,
        final_values,
        oracle,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// The parameters of the effects a loop's `history` leaves applied, as the last diagnosed
/// round's calibration (`calibrated`) fitted them; an effect applied by the last round itself
/// was not calibrated again, so it keeps the values it was applied with.
fn final_effect_values(history: &[Round], calibrated: &[(Param, f64)]) -> Vec<(Param, f64)> {
    let last_applied: Vec<EffectKind> = history.last().map(|r| r.applied.into_iter().chain(r.applied_with).collect()).unwrap_or_default();
    super::diagnose::applied_effects(history)
        .into_iter()
        .flat_map(|k| {
            // A round that applied `k` with another effect holds both effects' values.
            let of_k = Param::of_effect(k);
            let applied_with: Vec<(Param, f64)> = history.iter().rev().find(|r| r.applied == Some(k) || r.applied_with == Some(k)).map(|r| r.applied_values.iter().filter(|(p, _)| of_k.contains(p)).copied().collect()).unwrap_or_default();
            if last_applied.contains(&k) {
                return applied_with;
            }
            applied_with.into_iter().map(|(p, v)| (p, calibrated.iter().find(|c| c.0 == p).map_or(v, |c| c.1))).collect()
        })
        .collect()
}

/// A case the other way round: the model holds `extra`, which the machine lacks. The draw is
/// the hidden-effect case's ([`make_case_set`] with `extra` hidden, so seed for seed the same
/// perturbed baseline, strength and SNR); then the effect as drawn is put in the model and
/// taken out of the measurement machine. The model's effect keeps that strength (it is not in
/// [`Machine::fitted_effects`], so no calibration shrinks it): a model given a wrong effect,
/// as a user or a false claim gives one. Returns `(measurement machine, model machine, the
/// effect's drawn parameter, SNR dB)`. Not for `noise`, which is no part of a model
/// ([`super::removal::removable_parts`]).
pub fn make_extra_case(base: &Machine, extra: EffectKind, seed: u64, setting: &CaseSetting) -> (Machine, Machine, Option<(Param, f64)>, f64) {
    let (mut truth, mut model_m, params, snr) = make_case_set(base, &[extra], seed, setting);
    model_m.effects.copy_from(&truth.effects, extra);
    truth.effects.disable(extra);
    (truth, model_m, params.first().copied(), snr)
}

/// The outcome of an extra-effect case ([`run_extra_case`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtraCaseResult {
    /// The effect the model holds and the machine lacks.
    pub extra: EffectKind,
    /// Its drawn parameter, if any.
    pub parameter: Option<(Param, f64)>,
    /// Measurement SNR, dB.
    pub snr_db: f64,
    /// What the search chose (None: "nothing significant is missing").
    pub chosen: Option<EffectKind>,
    /// The search's verdict.
    pub verdict: String,
    /// The removal trials of the model (the extra effect's among them).
    pub removals: Vec<super::removal::RemovalTrial>,
    /// With more than one round: the loop's rounds, the first one's diagnosis being the one
    /// above ([`run_loop`]); empty for a single search.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub history: Vec<Round>,
    /// Wall time, s.
    pub seconds: f64,
}

impl ExtraCaseResult {
    /// The removal trial that takes the extra effect out alone (a contact nonlinearity with its
    /// load zone kept: [`super::removal::removable_parts`]).
    pub fn extra_trial(&self) -> Option<&super::removal::RemovalTrial> {
        self.removals.iter().find(|t| t.part == super::removal::ModelPart::Effect(self.extra))
    }

    /// With a loop: whether a round took the extra effect out (alone, or with what acts
    /// through it) and no later round put it back.
    pub fn extra_taken_out(&self) -> bool {
        let taken_out = self.history.iter().rposition(|r| r.taken_out.as_ref().is_some_and(|t| t.part == super::removal::ModelPart::Effect(self.extra)));
        taken_out.is_some_and(|i| self.history[i + 1..].iter().all(|r| r.applied != Some(self.extra) && r.applied_with != Some(self.extra)))
    }

    /// With a loop: the effects it applied, every one a false claim (the machine has only what
    /// the model had without the extra effect).
    pub fn applied(&self) -> Vec<EffectKind> {
        super::diagnose::applied_effects(&self.history)
    }
}

/// Runs an extra-effect case ([`make_extra_case`]): simulate the measurement (`duration_s`),
/// diagnose the model that holds `extra` with its removal trials
/// ([`LoopOptions::removal_trials`], on whatever `opts` says). The removal trials must read the
/// extra effect contradicted, unless the data cannot tell it (too weak against the noise).
/// With `rounds` above 1 the model goes through [`run_loop`] instead, which should take the
/// extra effect out and apply nothing ([`ExtraCaseResult::history`]).
pub fn run_extra_case(base: &Machine, extra: EffectKind, seed: u64, duration_s: f64, rounds: usize, setting: &CaseSetting, opts: &LoopOptions) -> Result<ExtraCaseResult, LoopError> {
    if extra == EffectKind::Noise {
        return Err(base.invalid("effects.noise", "extra", "an extra-effect case needs an effect that is a part of the model; the noise is the record's").into());
    }
    let t0 = std::time::Instant::now();
    let (mut truth, model_m, parameter, snr_db) = make_extra_case(base, extra, seed, setting);
    truth.duration_s = duration_s;
    let measured = model::simulate(&truth)?;
    let opts = LoopOptions { removal_trials: true, ..opts.clone() };
    if rounds > 1 {
        let (_, history, _) = run_loop(&model_m, &measured, rounds, &opts, &|_, _| true)?;
        let first = history.first().cloned().unwrap_or_default();
        return Ok(ExtraCaseResult { extra, parameter, snr_db, chosen: first.applied.or(first.set_aside), verdict: first.verdict, removals: first.removals, history, seconds: t0.elapsed().as_secs_f64() });
    }
    let reference = Reference::new(&measured, &opts.compare)?;
    let (_, d) = diagnose_with(&model_m, &reference, &opts, &super::calibrate::LoopProgress::new(&|_, _| true))?;
    Ok(ExtraCaseResult { extra, parameter, snr_db, chosen: d.best, verdict: d.verdict, removals: d.removals, history: Vec::new(), seconds: t0.elapsed().as_secs_f64() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round(n: usize, applied: Option<(EffectKind, Param, f64)>, removed: Option<EffectKind>) -> Round {
        Round {
            round: n,
            envelope_nrmse: 1.0,
            objective: 1.0,
            floor_objective: 0.5,
            applied: applied.map(|a| a.0),
            removed,
            applied_values: applied.map(|(_, p, v)| vec![(p, v)]).unwrap_or_default(),
            ..Default::default()
        }
    }

    /// A single case as `confusion --json` writes it: `hidden` hidden, `chosen` chosen, the
    /// calibrated model at `objective` against a floor of 2 with the decision needing 1.5 ×.
    fn case(hidden: Option<&str>, chosen: Option<&str>, rank: Option<usize>, objective: f64, oracle: Oracle) -> CaseResult {
        let trial = serde_json::json!({
            "effect": hidden.unwrap_or("slip"), "parameter": null, "extra_parameters": [],
            "objective_before": objective, "objective_after": objective - 0.5,
            "envelope_nrmse_before": 2.0, "envelope_nrmse_after": 1.0, "reduction": 0.1,
            "evidence": "", "summary": ""
        });
        let mut c: CaseResult = serde_json::from_value(serde_json::json!({
            "hidden": hidden, "true_parameter": null, "snr_db": 10.0, "ranking": [],
            "rank_of_hidden": rank, "chosen": chosen, "envelope_nrmse_before": 2.0,
            "envelope_nrmse_after": 1.0, "verdict": "", "reductions": [], "seconds": 1.0,
            "floor_objective": 2.0, "floor_ratio_needed": 1.5, "trials": [trial]
        }))
        .unwrap();
        c.oracle = oracle;
        c
    }

    #[test]
    fn a_recoverable_miss_says_whether_the_floor_margin_or_the_search_missed_it() {
        // The truth at 2.0 ± 0.05, 4.0 without its hidden effect: visible.
        let o = || oracle_of(&[2.0, 2.05, 1.95, 2.0], &[4.0, 4.1, 3.9, 4.0]);
        // At 2.84 (1.42 × a floor of 2) the model is worse than the truth, under the 1.5 ratio.
        let under = case(Some("unbalance"), None, Some(1), 2.84, o());
        assert!(under.recoverable());
        let Some(Miss::UnderMargin { ratio, needed, rank }) = under.miss() else { panic!("{:?}", under.miss()) };
        assert!((ratio - 1.42).abs() < 1e-12 && needed == 1.5 && rank == Some(1));
        assert_eq!(under.miss().unwrap().text(), "under the floor margin at 1.42 × its floor (needs 1.50 ×), ranked 1");
        // Above the margin with another effect chosen: the search's miss.
        let other = case(Some("unbalance"), Some("misalignment"), Some(2), 4.0, o());
        assert_eq!(other.miss(), Some(Miss::Searched { chosen: Some(EffectKind::Misalignment), rank: Some(2) }));
        assert_eq!(other.miss().unwrap().text(), "ranked 2, misalignment chosen");
        // Another effect chosen under the margin (the near-floor rule): the search's miss too.
        let near = case(Some("unbalance"), Some("misalignment"), Some(2), 2.84, o());
        assert_eq!(near.miss(), Some(Miss::Searched { chosen: Some(EffectKind::Misalignment), rank: Some(2) }));
        assert_eq!(case(Some("unbalance"), None, Some(4), 4.0, o()).miss().unwrap().text(), "ranked 4, no trial significant");
        // Found, not recoverable, or a control: no miss.
        assert_eq!(case(Some("unbalance"), Some("unbalance"), Some(1), 4.0, o()).miss(), None);
        assert_eq!(case(Some("unbalance"), None, Some(1), 2.02, o()).miss(), None, "absorbed: as good as the truth");
        assert_eq!(case(None, None, None, 4.0, oracle_of(&[2.0, 2.1], &[])).miss(), None);
    }

    fn oracle_of(truth: &[f64], without: &[f64]) -> Oracle {
        Oracle { truth: truth.iter().map(|j| (*j, 1.0)).collect(), without_hidden: without.iter().map(|j| (*j, 2.0)).collect() }
    }

    #[test]
    fn the_oracle_reads_visibility_from_paired_seeds_and_headroom_from_the_truths_scatter() {
        // Without the hidden effect the truth scores 3 higher on every seed: visible.
        let o = oracle_of(&[3.0, 3.2, 2.8, 3.0], &[6.1, 6.2, 5.8, 5.9]);
        let (mean, sd) = o.truth_objective();
        assert!((mean - 3.0).abs() < 1e-12 && (sd - (0.08f64 / 3.0).sqrt()).abs() < 1e-12, "{mean} {sd}");
        assert_eq!(o.hidden_is_visible(), Some(true));
        assert_eq!(o.truth_envelope_nrmse(), 1.0);
        assert_eq!(o.without_hidden_objective(), Some(6.0));
        // The calibrated model at 5: worse than the truth beyond 2 sd (0.33): recoverable.
        assert!(o.recoverable(5.0));
        assert_eq!(o.reading(5.0), Some("yes"));
        assert!((o.recovered(5.0, 4.0) - 0.5).abs() < 1e-12);
        // At 3.2 the calibration has absorbed what the effect does.
        assert!(!o.recoverable(3.2));
        assert_eq!(o.reading(3.2), Some("absorbed"));
        assert!(o.recovered(2.9, 2.5).is_nan());
        // Paired differences that scatter about zero: invisible, whatever the calibrated score.
        let flat = oracle_of(&[3.0, 3.2, 2.8, 3.0], &[3.4, 2.9, 2.7, 3.1]);
        assert_eq!(flat.hidden_is_visible(), Some(false));
        assert_eq!(flat.reading(5.0), Some("invisible, the calibration falls short"));
        assert_eq!(flat.reading(3.0), Some("invisible"));
        assert!(!flat.recoverable(5.0));
        // The slip case of the bearing table (seed 2101, one realisation): the truth re-seeded
        // scores worse than without its slip. Not visible.
        assert_eq!(oracle_of(&[3.50, 4.51, 4.64, 3.74], &[3.38, 3.45, 3.40, 3.41]).hidden_is_visible(), Some(false));
        // A control hides nothing: no reading, never recoverable.
        let control = oracle_of(&[3.0, 3.1], &[]);
        assert_eq!(control.hidden_is_visible(), None);
        assert_eq!(control.reading(9.0), None);
        assert!(!control.recoverable(9.0));
    }

    #[test]
    fn the_oracle_sees_a_hidden_load_zone_and_nothing_hidden_in_a_control() {
        let base = crate::model::preset("cwru_6205_inner").unwrap();
        let opts = LoopOptions::default();
        for (hidden, visible) in [(vec![EffectKind::LoadZone], Some(true)), (vec![], None)] {
            let (mut truth, ..) = make_case_hiding(&base, &hidden, 7);
            truth.duration_s = 2.0;
            let reference = Reference::new(&model::simulate(&truth).unwrap(), &opts.compare).unwrap();
            let o = oracle(&truth, &hidden, &reference, &opts).unwrap();
            assert_eq!(o.truth.len(), ORACLE_SALTS.len());
            assert_eq!(o.without_hidden.len(), if hidden.is_empty() { 0 } else { ORACLE_SALTS.len() });
            assert_eq!(o.hidden_is_visible(), visible, "{hidden:?}: {o:?}");
            // Re-seeded, the truth scores like the floor: a few per cent, not the measurement's
            // own seed (which would score 0).
            assert!(o.truth.iter().all(|t| t.0 > 0.1 && t.0 < 20.0), "{o:?}");
        }
    }

    #[test]
    fn a_hidden_sensor_roll_off_is_drawn_below_the_resonance() {
        // Above the resonance it acts only where the measurement noise is (docs/loop-notebook.md "Detection
        // limits"): the draw is 0.45-0.75 x the (perturbed) resonance of the true machine.
        for preset in ["mfs_inner", "mfs_healthy", "cwru_6205_inner"] {
            let base = crate::model::preset(preset).unwrap();
            for seed in 0..20 {
                let (t, _, p, _) = make_case_hiding(&base, &[EffectKind::SensorResponse], seed);
                let f_res = Param::ResonanceHz.get(&t).unwrap();
                let bw = p[0].1;
                assert_eq!(p[0].0, Param::SensorBandwidthHz);
                assert!(bw >= 0.45 * f_res && bw <= 0.75 * f_res && bw >= Param::SensorBandwidthHz.bounds(&t).0, "{preset} seed {seed}: {bw} Hz against a {f_res} Hz resonance");
            }
        }
    }

    #[test]
    fn a_fixed_value_and_snr_change_nothing_else_in_the_case() {
        let base = crate::model::preset("mfs_inner").unwrap();
        let (t_drawn, m_drawn, p_drawn, snr_drawn) = make_case_hiding(&base, &[EffectKind::Slip], 7);
        let setting = CaseSetting { value: Some(2.5), snr_db: Some(12.0) };
        let (t, m, p, snr) = make_case_set(&base, &[EffectKind::Slip], 7, &setting);
        assert_eq!(p, vec![(Param::SlipPercent, 2.5)]);
        assert_ne!(p_drawn[0].1, 2.5);
        assert_eq!(Param::SlipPercent.get(&t), Some(2.5));
        assert_eq!((snr, Param::NoiseSnrDb.get(&t)), (12.0, Some(12.0)));
        assert_ne!(snr_drawn, 12.0);
        // The same seed, the same perturbed baseline, the same model.
        assert_eq!(t.seed, t_drawn.seed);
        for q in [Param::ResonanceHz, Param::ResonanceDamping, Param::FaultDepthM] {
            assert_eq!(q.get(&t), q.get(&t_drawn), "{q:?}");
        }
        assert_eq!(m, m_drawn);
        // Putting the drawn values back gives the drawn case exactly.
        let back = CaseSetting { value: Some(p_drawn[0].1), snr_db: Some(snr_drawn) };
        assert_eq!(make_case_set(&base, &[EffectKind::Slip], 7, &back).0, t_drawn);
        assert_eq!(make_case_set(&base, &[EffectKind::Slip], 7, &CaseSetting::default()).0, t_drawn);
        // With noise hidden the value is the SNR.
        let (_, _, p, snr) = make_case_set(&base, &[EffectKind::Noise], 7, &CaseSetting { value: Some(4.0), snr_db: None });
        assert_eq!((p, snr), (vec![(Param::NoiseSnrDb, 4.0)], 4.0));
    }

    #[test]
    fn an_extra_effect_loop_reads_whether_the_effect_went_out_and_stayed_out() {
        use super::super::removal::{ModelPart, TakenOut};
        use EffectKind::*;
        let out = |k: EffectKind| Some(TakenOut { part: ModelPart::Effect(k), label: k.name().into(), explained: 0.9 });
        let mut r = ExtraCaseResult { extra: CasingModes, parameter: None, snr_db: 1.0, chosen: Some(Misalignment), verdict: String::new(), removals: vec![], history: vec![round(1, None, None), round(2, None, None)], seconds: 0.0 };
        assert!(!r.extra_taken_out(), "nothing taken out");
        // Taken out first, the misalignment set aside: out, nothing applied.
        r.history[0].taken_out = out(CasingModes);
        r.history[0].set_aside = Some(Misalignment);
        assert!(r.extra_taken_out());
        assert!(r.applied().is_empty());
        // Added first, then taken out: out, the misalignment a false claim left applied.
        r.history[0] = round(1, Some((Misalignment, Param::Misalignment2xN, 20.0)), None);
        r.history[1].taken_out = out(CasingModes);
        assert!(r.extra_taken_out());
        assert_eq!(r.applied(), vec![Misalignment]);
        // Another part taken out, or the effect put back after it went: not out.
        r.history[1].taken_out = out(Misalignment);
        assert!(!r.extra_taken_out());
        assert!(r.applied().is_empty());
        r.history[0] = round(1, None, None);
        r.history[0].taken_out = out(CasingModes);
        r.history[1] = round(2, Some((CasingModes, Param::CasingModeHz, 4500.0)), None);
        assert!(!r.extra_taken_out());
    }

    #[test]
    fn final_values_are_the_last_calibration_s_except_for_what_the_last_round_applied() {
        use EffectKind::*;
        // Round 1 applies an unbalance, round 2 replaces it by a misalignment, round 3 (the
        // round limit) applies a path modulation that no calibration has re-fitted since.
        let h = vec![
            round(1, Some((Unbalance, Param::UnbalanceKgM, 6.8e-3)), None),
            round(2, Some((Misalignment, Param::Misalignment2xN, 45.5)), Some(Unbalance)),
            round(3, Some((PathModulation, Param::PathModulationDepth, 0.3)), None),
        ];
        let calibrated = [(Param::ResonanceHz, 1300.0), (Param::Misalignment2xN, 40.0), (Param::PathModulationDepth, 0.9)];
        assert_eq!(final_effect_values(&h, &calibrated), vec![(Param::Misalignment2xN, 40.0), (Param::PathModulationDepth, 0.3)]);
        // A loop that ended clean: every applied effect as the last calibration left it; one the
        // calibration did not re-fit keeps its applied value.
        let mut h2 = h[..2].to_vec();
        h2.push(round(3, None, None));
        assert_eq!(final_effect_values(&h2, &calibrated), vec![(Param::Misalignment2xN, 40.0)]);
        assert_eq!(final_effect_values(&h2, &[]), vec![(Param::Misalignment2xN, 45.5)]);
    }
}
