//! What the model holds that the measurement does not support: removal trials.
//!
//! The search of [`super::diagnose`] only adds: every trial switches on an effect the model
//! lacks. A model can be wrong the other way, holding a fault or an effect the machine does
//! not have, and the search then answers "nothing significant is missing" with the calibration
//! bending to hide it. On CWRU's healthy record 097 (compared at 12 kHz) the inner-race preset
//! is calibrated with its resonance moved out of the demodulation band and its damping at the
//! range's floor, so the BPFI impacts ring where the comparison does not look
//! (docs/loop-notebook.md "Session 72"). A removal trial asks the converse question of a
//! trial: each part of the starting model in turn (a bearing's localised fault, each effect
//! that is on but the measurement noise) is taken out, the model without it is calibrated
//! exactly as the round's model was, and its objective is set against the calibrated one.
//!
//! Both models are judged with [`REMOVAL_REALISATIONS`] realisations at least, on held-out
//! ones, their mean's own scatter taken out of the error
//! ([`crate::compare::DomainComparison::debiased_nrmse_percent`]): with one realisation an
//! objective holds the model's own variance, and a model whose only vibration is its noise
//! scatters more than one with a fault. On 097 the inner-race preset without its fault (noise
//! only, no load zone) scored 51.5 against 38.6 with one realisation, and 29.3 against 32.6
//! with four (docs/loop-notebook.md "Session 73"). They are calibrated on as many, or on
//! [`LoopOptions::removal_fit_realisations`] (docs/loop-notebook.md "Session 76").
//!
//! The reading uses the diagnosis's yardsticks: the tie width 2√2 σ of the larger seed scatter
//! σ of the two calibrated models, within which [`super::diagnose::decide`] calls two trials
//! tied, and the significance share of the error above the seed floor of the model with the
//! part. Removing a part that lowers the objective beyond
//! the tie width and by at least that share is **contradicted** by the measurement; one whose
//! removal raises it beyond the tie width is **needed**; anything between, the data **cannot
//! tell** with or without it.

use super::calibrate::{calibration_parameters_for, evaluate, objective, Fit, LoopError, LoopOptions, LoopProgress};
use super::diagnose::{calibrate_round, calibrate_round_evaluations, objective_scatter, reseeded, seed_floor, tie_width, FLOOR_SEEDS, HELD_OUT_SALT, SCATTER_SEEDS};
use super::Reference;
use crate::dsp::rms;
use crate::model::{EffectKind, Machine};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A part of a machine a removal trial takes out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelPart {
    /// The localised fault of the bearing of this name.
    Fault { bearing: String },
    /// An effect that is on (and every effect on that acts through it: a contact nonlinearity
    /// goes with its load zone; it is also a part of its own, taken out alone).
    Effect(EffectKind),
}

impl ModelPart {
    /// The part in words: `the inner-race fault of bearing de`, `load_zone`.
    pub fn label(&self, m: &Machine) -> String {
        match self {
            ModelPart::Fault { bearing } => {
                let race = m.bearings.iter().find(|b| &b.name == bearing).and_then(|b| b.fault.as_ref()).map_or("localised", |f| match f.location {
                    crate::model::FaultLocation::Outer => "outer-race",
                    crate::model::FaultLocation::Inner => "inner-race",
                    crate::model::FaultLocation::Ball => "ball",
                });
                format!("the {race} fault of bearing {bearing}")
            }
            ModelPart::Effect(k) => {
                let riders = riders(*k, m);
                match k.acts_through().filter(|c| m.effects.is_on(*c)) {
                    Some(carrier) => format!("{} (alone, {} kept)", k.name(), carrier.name()),
                    None if riders.is_empty() => k.name().to_string(),
                    None => format!("{} (with {}, which acts through it)", k.name(), riders.iter().map(|r| r.name()).collect::<Vec<_>>().join(", ")),
                }
            }
        }
    }

    /// The part in a few words, for a table cell: `fault of de`, `load_zone`.
    pub fn short_label(&self) -> String {
        match self {
            ModelPart::Fault { bearing } => format!("fault of {bearing}"),
            ModelPart::Effect(k) => k.name().to_string(),
        }
    }

    /// `m` without the part (a fitted effect taken out of [`Machine::fitted_effects`] too), validated.
    pub fn removed_from(&self, m: &Machine) -> Result<Machine, crate::model::ModelError> {
        let mut out = m.clone();
        match self {
            ModelPart::Fault { bearing } => {
                if let Some(b) = out.bearings.iter_mut().find(|b| &b.name == bearing) {
                    b.fault = None;
                }
            }
            ModelPart::Effect(k) => {
                for r in std::iter::once(*k).chain(riders(*k, m)) {
                    out.effects.disable(r);
                    out.fitted_effects.retain(|f| *f != r);
                }
            }
        }
        out.validate()?;
        Ok(out)
    }
}

/// The effects on in `m` that act through `k` ([`EffectKind::acts_through`]).
fn riders(k: EffectKind, m: &Machine) -> Vec<EffectKind> {
    EffectKind::ALL.into_iter().filter(|r| r.acts_through() == Some(k) && m.effects.is_on(*r)).collect()
}

/// The parts of `m` a removal trial takes out, in order: each bearing's localised fault, then
/// every effect that is on in catalogue order, but the measurement noise (a property of the
/// record, whose level the calibration fits). An effect that acts through another goes with
/// that one when it is taken out, and is also a part of its own, taken out alone with the
/// other kept: a model can hold a contact nonlinearity the machine lacks beside a load zone it
/// has (session 74's extra-effect table: with the two only taken out together, the load zone
/// the machine has read the pair "needed").
pub fn removable_parts(m: &Machine) -> Vec<ModelPart> {
    let faults = m.bearings.iter().filter(|b| b.fault.is_some()).map(|b| ModelPart::Fault { bearing: b.name.clone() });
    let effects = EffectKind::ALL.into_iter().filter(|k| m.effects.is_on(*k) && *k != EffectKind::Noise).map(ModelPart::Effect);
    faults.chain(effects).collect()
}

/// What a removal trial says of its part.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RemovalReading {
    /// Without it the calibrated objective falls beyond the tie width and by at least the
    /// significance share of the error above the floor: the measurement does not support it.
    Contradicted,
    /// Within the tie width, or lower by less than the significance share: the data cannot
    /// tell the model with it from the model without it.
    CannotTell,
    /// Without it the calibrated objective rises beyond the tie width.
    Needed,
}

impl RemovalReading {
    /// `contradicted`, `cannot tell`, `needed`.
    pub fn name(self) -> &'static str {
        match self {
            RemovalReading::Contradicted => "contradicted",
            RemovalReading::CannotTell => "cannot tell",
            RemovalReading::Needed => "needed",
        }
    }
}

/// One removal trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RemovalTrial {
    /// The part taken out.
    pub part: ModelPart,
    /// The part in words ([`ModelPart::label`]).
    pub label: String,
    /// The objective of the calibrated model with the part and of the one without it, on
    /// held-out realisations ([`removal_options`]).
    pub objective_with: f64,
    pub objective_without: f64,
    /// Their envelope NRMSE (%), on the same realisations.
    pub envelope_nrmse_with: f64,
    pub envelope_nrmse_without: f64,
    /// The seed floor of the model with the part, with the same realisations.
    pub floor_objective: f64,
    /// The tie width 2√2 σ, σ the larger seed scatter of the two calibrated models' objectives.
    pub tie_width: f64,
    /// Realisations both models were judged with.
    pub realisations: usize,
    /// Realisations both models were calibrated on ([`LoopOptions::removal_fit_realisations`];
    /// 0 in answers written before session 76, where they were `realisations`).
    #[serde(default)]
    pub fit_realisations: usize,
    /// `(objective_with − objective_without) / (objective_with − floor)`: the share of the
    /// error above the seed floor that taking the part out removes (negative: it adds error).
    pub explained: f64,
    /// The reading.
    pub reading: RemovalReading,
    /// The calibration of the model without the part.
    pub calibration: Fit,
    /// One sentence for the user.
    pub summary: String,
}

/// Realisations a removal trial is judged with at least (the second look's default): see the
/// module's documentation.
pub const REMOVAL_REALISATIONS: usize = 4;

/// The options removal trials calibrate and judge with: `opts` with at least
/// [`REMOVAL_REALISATIONS`] realisations.
pub fn removal_options(opts: &LoopOptions) -> LoopOptions {
    LoopOptions { realisations: opts.realisations.max(REMOVAL_REALISATIONS), removal_trials: false, ..opts.clone() }
}

/// A model is silent when the rms of its simulation without noise is below this share of the
/// measurement's: round-off (the inner-race preset without its fault: 5.4e-16 g against 097's
/// 0.07 g, a share of 1e-14), where a physical model is within a few decades of the record
/// (the healthy preset's 19.6 N load zone: 2.7e-3 g).
pub const SILENT_RMS_SHARE: f64 = 1e-8;

/// `Some((model rms, measured rms))` when `m` without its noise, simulated for the fit's
/// duration, is silent ([`SILENT_RMS_SHARE`] of the measurement's rms); None otherwise.
pub fn silent(m: &Machine, reference: &Reference, opts: &LoopOptions) -> Result<Option<(f64, f64)>, LoopError> {
    let measured = reference.measured();
    let mut quiet = m.clone();
    quiet.effects.disable(EffectKind::Noise);
    quiet.duration_s = opts.fit_duration_s.min(measured.duration_s());
    let model_rms = rms(&crate::model::simulate(&quiet)?.samples);
    let measured_rms = rms(&measured.samples);
    Ok((model_rms < SILENT_RMS_SHARE * measured_rms).then_some((model_rms, measured_rms)))
}

/// What a silent model is, in words (the one source of the sentence the removal trials and
/// [`super::Diagnosis::silent_model_warning`] give): `(model_rms, measured_rms)` as
/// [`silent`] returns them, in `unit`.
pub fn silent_model_words((model_rms, measured_rms): (f64, f64), unit: &str) -> String {
    format!("the model holds no vibration but its noise (rms {model_rms:.1e} {unit} without its noise, against the measurement's {measured_rms:.2e} {unit})")
}

/// The options a removal trial calibrates its models with: `opts` (the judging options,
/// [`removal_options`]) on [`LoopOptions::removal_fit_realisations`] realisations, or on as
/// many as they are judged on when that is 0.
pub fn removal_fit_options(opts: &LoopOptions) -> LoopOptions {
    match opts.removal_fit_realisations {
        0 => opts.clone(),
        k => LoopOptions { realisations: k, ..opts.clone() },
    }
}

/// Whether [`calibrated_and_judged`] evaluates the calibrated model on its own seed with the
/// judging options: for its floor, or because its fit's objective was not taken on them.
fn evaluates_own_seed(opts: &LoopOptions, with_floor: bool) -> bool {
    with_floor || removal_fit_options(opts).realisations != opts.realisations
}

/// Model evaluations of [`calibrated_and_judged`] of `m`, with its floor or without.
fn judged_evaluations(m: &Machine, opts: &LoopOptions, with_floor: bool) -> usize {
    calibrate_round_evaluations(m, &removal_fit_options(opts)) + 1 + SCATTER_SEEDS.len() + usize::from(evaluates_own_seed(opts, with_floor)) + if with_floor { FLOOR_SEEDS.len() } else { 0 }
}

/// Model evaluations [`removal_trials`] makes on the round's starting model `m` with the
/// options `opts` ([`removal_options`]), unless `m` is [`silent`] (then none); it adds them to
/// the progress total itself.
pub fn removal_trial_evaluations(m: &Machine, opts: &LoopOptions) -> usize {
    judged_evaluations(m, opts, true) + removable_parts(m).iter().filter_map(|p| p.removed_from(m).ok()).map(|w| judged_evaluations(&w, opts, false)).sum::<usize>()
}

/// A model calibrated for a removal trial and judged on held-out realisations.
struct Judged {
    fit: Fit,
    objective: f64,
    envelope_nrmse: f64,
    scatter: f64,
    /// The seed floor, when asked for.
    floor: Option<f64>,
}

/// `m` calibrated as a round's model is ([`calibrate_round`] over
/// [`calibration_parameters_for`], on [`removal_fit_options`]' realisations), then judged
/// with `opts` on held-out realisations ([`HELD_OUT_SALT`]), with its seed scatter (its own
/// seed's objective taken with `opts` too) and, `with_floor`, its seed floor.
fn calibrated_and_judged(m: &Machine, reference: &Reference, opts: &LoopOptions, with_floor: bool, progress: &LoopProgress) -> Result<Judged, LoopError> {
    let fit_opts = removal_fit_options(opts);
    let params = calibration_parameters_for(m, &fit_opts);
    let (fm, fit) = calibrate_round(m, reference, &params, &fit_opts, progress)?;
    let (held_out, _) = evaluate(&reseeded(&fm, HELD_OUT_SALT), reference, opts)?;
    progress.tick();
    let own = if evaluates_own_seed(opts, with_floor) {
        let (own, _) = evaluate(&fm, reference, opts)?;
        progress.tick();
        Some(own)
    } else {
        None
    };
    // The fit's own objective when it was taken on the judging realisations (the form of
    // session 73, unchanged); else the own seed's on them, so that the scatter is of one kind.
    let own_objective = match &own {
        Some(c) if fit_opts.realisations != opts.realisations => objective(c, &opts.weights),
        _ => fit.objective_after,
    };
    let scatter = objective_scatter(&fm, reference, own_objective, opts)?;
    for _ in SCATTER_SEEDS {
        progress.tick();
    }
    let floor = if let (true, Some(own)) = (with_floor, &own) {
        let (floor, _) = seed_floor(&fm, reference.measured(), own, opts)?;
        for _ in FLOOR_SEEDS {
            progress.tick();
        }
        Some(floor)
    } else {
        None
    };
    Ok(Judged { objective: objective(&held_out, &opts.weights), envelope_nrmse: held_out.envelope_nrmse(), fit, scatter, floor })
}

/// The removal trials of the round's starting (uncalibrated) model `m` against `reference`,
/// with the options `opts` ([`removal_options`]): `m` and `m` without each part of
/// [`removable_parts`] calibrated as a round's model is and judged on held-out realisations,
/// in parallel. A part whose removal leaves an invalid machine (none of the presets has one),
/// or whose model's calibration fails, reads "cannot tell" with the reason. Its evaluations ([`removal_trial_evaluations`]) are added to `progress`'s
/// total here.
///
/// A starting model that holds no vibration but its noise ([`silent`]) has no part to judge:
/// its calibration scales round-off, and taking out a part changes only that round-off (on 097,
/// the inner-race preset without its fault read its contact nonlinearity "contradicted",
/// 29.02 → 26.24). Each part then reads [`RemovalReading::CannotTell`], saying why, and no
/// calibration is made.
///
/// `silent_model` is [`silent`]'s answer for `m` (the diagnosis holds it:
/// [`super::Diagnosis::silent_model`]), passed in so that the noise-free simulation is made once.
pub fn removal_trials(m: &Machine, reference: &Reference, opts: &LoopOptions, silent_model: Option<(f64, f64)>, progress: &LoopProgress) -> Result<Vec<RemovalTrial>, LoopError> {
    let parts: Vec<(ModelPart, Result<Machine, String>)> = removable_parts(m).into_iter().map(|p| {
        let w = p.removed_from(m).map_err(|e| format!("the machine without it is not valid: {e}"));
        (p, w)
    }).collect();
    if parts.is_empty() {
        return Ok(Vec::new());
    }
    if let Some(rms_pair) = silent_model {
        let why = format!("{}, so no part of it can be judged", silent_model_words(rms_pair, &reference.measured().unit));
        return Ok(parts.into_iter().map(|(part, _)| not_judged(part, m, &why, opts)).collect());
    }
    progress.expect(removal_trial_evaluations(m, opts));
    // The model with every part is the round's own: its failure is the round's. A part whose
    // model is invalid or whose calibration fails is reported with the reason.
    let (with, without): (_, Vec<Result<Judged, String>>) = rayon::join(
        || calibrated_and_judged(m, reference, opts, true, progress),
        || {
            parts
                .par_iter()
                .map(|(_, w)| match w {
                    Ok(w) => calibrated_and_judged(w, reference, opts, false, progress).map_err(|e| format!("its calibration failed: {e}")),
                    Err(why) => Err(why.clone()),
                })
                .collect()
        },
    );
    if progress.is_cancelled() {
        return Err(LoopError::Cancelled);
    }
    let with = with?;
    let (j0, env0) = (with.objective, with.envelope_nrmse);
    let floor = with.floor.unwrap_or(f64::NAN);
    let excess = j0 - floor;
    Ok(parts
        .into_iter()
        .zip(without)
        .map(|((part, _), w)| {
            let w = match w {
                Ok(w) => w,
                Err(why) => return not_judged(part, m, &why, opts),
            };
            let tie = tie_width(with.scatter.max(w.scatter));
            let (j, env) = (w.objective, w.envelope_nrmse);
            let gain = j0 - j;
            let explained = if excess > 0.0 { gain / excess } else { f64::NAN };
            // At or under the floor (no share to take), a gain beyond the tie width is enough.
            let reading = if gain >= tie && (explained.is_nan() || explained >= opts.significance) {
                RemovalReading::Contradicted
            } else if -gain >= tie {
                RemovalReading::Needed
            } else {
                RemovalReading::CannotTell
            };
            let label = part.label(m);
            let summary = match reading {
                RemovalReading::Contradicted => format!(
                    "the measurement does not support {label}: calibrated without it the objective falls from {j0:.2} to {j:.2}, {:.0} % of the error above the floor {floor:.2} (envelope NRMSE {env0:.1} → {env:.1} %)",
                    explained * 100.0
                ),
                RemovalReading::Needed => format!("{label} is needed: calibrated without it the objective rises from {j0:.2} to {j:.2} (tie width ±{tie:.2}; envelope NRMSE {env0:.1} → {env:.1} %)"),
                RemovalReading::CannotTell => format!("the data cannot tell whether {label} is there: calibrated without it the objective is {j:.2} against {j0:.2} (tie width ±{tie:.2}, floor {floor:.2}; envelope NRMSE {env0:.1} → {env:.1} %)"),
            };
            RemovalTrial { part, label, objective_with: j0, objective_without: j, envelope_nrmse_with: env0, envelope_nrmse_without: env, floor_objective: floor, tie_width: tie, realisations: opts.realisations, fit_realisations: removal_fit_options(opts).realisations, explained, reading, calibration: w.fit, summary }
        })
        .collect())
}

impl RemovalTrial {
    /// The trial in a few words, for a table cell: `fault of de: needed (17.64 → 22.77)`, the
    /// objective with the part and without it, and for a contradicted part the share of the
    /// error above the floor its removal takes (a share means little near the floor, where it
    /// divides by almost nothing); `not judged` when it was not.
    pub fn cell(&self) -> String {
        let (part, reading) = (self.part.short_label(), self.reading.name());
        if !self.objective_without.is_finite() {
            return format!("{part}: {reading} (not judged)");
        }
        let objectives = format!("{:.2} → {:.2}", self.objective_with, self.objective_without);
        match self.reading {
            RemovalReading::Contradicted => format!("{part}: {reading} ({objectives}, {:.0} %)", self.explained * 100.0),
            _ => format!("{part}: {reading} ({objectives})"),
        }
    }
}

/// The trial of a part that was not judged, `why` saying why: "cannot tell", every number NaN.
fn not_judged(part: ModelPart, m: &Machine, why: &str, opts: &LoopOptions) -> RemovalTrial {
    let label = part.label(m);
    let summary = format!("the data cannot tell whether {label} is there: {why}");
    RemovalTrial { part, label, objective_with: f64::NAN, objective_without: f64::NAN, envelope_nrmse_with: f64::NAN, envelope_nrmse_without: f64::NAN, floor_objective: f64::NAN, tie_width: f64::NAN, realisations: opts.realisations, fit_realisations: removal_fit_options(opts).realisations, explained: f64::NAN, reading: RemovalReading::CannotTell, calibration: Fit::default(), summary }
}

/// A part a loop round took out ([`crate::compare::run_loop`] with
/// [`LoopOptions::removal_trials`]): the round's most contradicted part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TakenOut {
    /// The part.
    pub part: ModelPart,
    /// The part in words ([`ModelPart::label`]).
    pub label: String,
    /// The share of the error above the floor its removal took ([`RemovalTrial::explained`]).
    pub explained: f64,
}

/// The contradicted removal trial of `removals` whose model without its part scores lowest
/// (the first of equals); None when none is contradicted. Every trial shares the objective
/// with the part and its floor, so this is also the one that takes the largest share of the
/// error above the floor.
pub fn most_contradicted(removals: &[RemovalTrial]) -> Option<&RemovalTrial> {
    removals.iter().filter(|t| t.reading == RemovalReading::Contradicted).fold(None, |best: Option<&RemovalTrial>, t| match best {
        Some(b) if b.objective_without <= t.objective_without => Some(b),
        _ => Some(t),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trial_in_a_table_cell_names_its_part_reading_and_share() {
        let trial = |part: ModelPart, reading: RemovalReading, objective_without: f64, explained: f64| RemovalTrial { label: String::new(), part, objective_with: 31.65, objective_without, envelope_nrmse_with: 1.0, envelope_nrmse_without: 1.0, floor_objective: 21.43, tie_width: 2.3, realisations: 4, fit_realisations: 4, explained, reading, calibration: Fit::default(), summary: String::new() };
        assert_eq!(trial(ModelPart::Fault { bearing: "de".into() }, RemovalReading::Needed, 35.1, -0.338).cell(), "fault of de: needed (31.65 → 35.10)");
        assert_eq!(trial(ModelPart::Effect(EffectKind::LoadZone), RemovalReading::Contradicted, 29.02, 0.2574).cell(), "load_zone: contradicted (31.65 → 29.02, 26 %)");
        assert_eq!(trial(ModelPart::Effect(EffectKind::GearMesh), RemovalReading::CannotTell, f64::NAN, f64::NAN).cell(), "gear_mesh: cannot tell (not judged)");
    }
}
