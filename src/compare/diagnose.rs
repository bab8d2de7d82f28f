//! Finding the missing physical effect: for every effect the current model lacks, combine the
//! evidence in the residual map for that effect's signature with a trial — switch it on, fit
//! its parameter, re-simulate, measure the error — and rank the effects by error reduction.

use super::calibrate::{at_search_bound, calibration_parameters, calibration_parameters_for, evaluate, fit_evaluations, fit_force_pair, fit_scanning, fit_trial, fit_trial_evaluations, fit_trial_scanning, fit_trial_scanning_evaluations, fit_with_progress, force_pair_evaluations, objective, scan_evaluations, scan_minimum, DecisionRule, Fit, LoopError, LoopOptions, LoopProgress, Param, SHORT_EXPLAINED};
use super::residual::{residual_map, ResidualMap};
use super::{Comparison, Reference};
use crate::kinematics::CharacteristicFrequency;
use crate::model::{EffectKind, Effects, Machine};
use crate::signal::Signal;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The trial of one effect.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EffectTrial {
    /// The effect.
    pub effect: EffectKind,
    /// Fitted main parameter and value (None for a pure switch).
    pub parameter: Option<(Param, f64)>,
    /// Other fitted parameters (e.g. the clearance for `load_zone`) and the re-fitted noise level.
    pub extra_parameters: Vec<(Param, f64)>,
    /// Objective (weighted NRMSE, %) without and with the effect.
    pub objective_before: f64,
    pub objective_after: f64,
    /// Envelope NRMSE (%) without and with the effect.
    pub envelope_nrmse_before: f64,
    pub envelope_nrmse_after: f64,
    /// NRMSE (%) per domain without and with the effect: (domain, before, after).
    #[serde(default)]
    pub domains: Vec<(String, f64, f64)>,
    /// Relative objective reduction, 0–1 (negative: worse).
    pub reduction: f64,
    /// Share of the *explainable* error this effect removes: `(before − after) / (before −
    /// floor)`, where the floor is the calibrated model against realisations of itself (see
    /// [`Diagnosis::floor_objective`]). 1 = everything above the floor is explained.
    #[serde(default)]
    pub explained: f64,
    /// Evidence from the residual map for this effect's signature.
    pub evidence: String,
    /// Share (%) of the error its signature carries in the residual map.
    #[serde(default)]
    pub evidence_share: f64,
    /// Within the seed scatter of the best trial's objective: the data cannot tell the two
    /// apart, and the evidence decides between them.
    #[serde(default)]
    pub tied_with_best: bool,
    /// The effect's main parameter places a spectral feature ([`Param::places_a_feature`]) and
    /// was fitted at an edge of its range: the feature lies outside what the data show. Such a
    /// trial is ranked after every other and cannot be chosen ([`OUTSIDE_BAND_NOTE`] says so).
    #[serde(default)]
    pub outside_band: bool,
    /// The effect's main parameter is a strength (it places no feature) and was fitted at an
    /// edge of its range, other than a top that is the physics' own limit
    /// ([`Param::top_is_a_physical_limit`]): the effect is not estimated. At the top, the
    /// effect needs more than is plausible and stands in for something else (on CWRU 234,
    /// with the 0.021 in preset, an unbalance of 8.9e-3 kg·m, a 313 N rotating force on the
    /// rotor's 2 kg share, took up a 1× envelope line as high as BPFO's); at the bottom, it is
    /// switched off in all but name and the trial's re-fit did the work. Ranked and decided
    /// as [`EffectTrial::outside_band`] ([`EffectTrial::pinned_note`]). The range
    /// `(low, high)` it is pinned in; None when it is not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pinned: Option<(f64, f64)>,
    /// One sentence for the user.
    pub summary: String,
    /// The trial's fitted machine evaluated once more with the effect switched off (and its
    /// [`EffectTrial::with_effect`]), everything else as the trial fitted it (an ablation).
    /// None where it could not be evaluated.
    #[serde(default)]
    pub objective_without_effect: Option<f64>,
    /// What switching the effect off again costs, as a share of the error above the floor:
    /// `(objective_without_effect − objective_after) / (objective_before − floor)`. A trial
    /// re-fits other parameters too (the noise level; a re-calibrating trial all of them):
    /// near `explained`, the effect did the work; near 0, the re-fit did; above 1, the
    /// re-fitted parameters lean on the effect (a casing mode the calibration was re-done with:
    /// 276 % on a hidden 2.77 kHz mode).
    #[serde(default)]
    pub effect_explained: Option<f64>,
    /// The objective the trial's fit reached on the realisations it was fitted to, when the
    /// trial was then judged on held-out ones ([`HELD_OUT_SALT`]; with two or more
    /// realisations): `objective_after` and every other number of the trial are then the
    /// held-out ones. None with one realisation, where the trial is judged on its fit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objective_fitted: Option<f64>,
    /// The fit that won started from the round's uncalibrated values, not from the calibrated
    /// model: a trial that re-does the calibration always does; with unbending
    /// ([`Diagnosis::unbent`]) or `LoopOptions::uncalibrated_start` any trial may.
    #[serde(default)]
    pub from_uncalibrated: bool,
    /// Forces whose search ended lower from the fine cell's start ([`Fit::fine_cell_won`],
    /// with `LoopOptions::fine_force_scan`) in the fit that won or in the fit stage 2's local
    /// re-fit started from. A fit that lost is not recorded: without the fine cell it would
    /// end no lower, and lose too. A case none of whose trials records a win is the one the
    /// plain search makes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fine_cell_won: Vec<Param>,
    /// The effect the trial switched on with its own, because its own acts through it and the
    /// model lacked it ([`companion`]: a contact nonlinearity with a load zone); the trial
    /// fitted that effect's parameters too, and applying it switches both on. None for a
    /// trial of one effect.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub with_effect: Option<EffectKind>,
    /// A joint trial of a stuck diagnosis ([`super::joint`], `LoopOptions::joint_trials`): its
    /// effect and [`EffectTrial::with_effect`] are two effects each with a trial of its own,
    /// fitted together here. False for a single trial and for one that brought a companion.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub joint: bool,
    /// Of a [`EffectTrial::joint`] trial: what switching off its effect alone, and its
    /// `with_effect` alone, costs in its fit, as shares of the error above the floor (as
    /// [`EffectTrial::effect_explained`] for both). None for any other trial.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub each_effect_explained: Option<(f64, f64)>,
}

impl EffectTrial {
    /// The trial's name for the user: its effect, and the [`EffectTrial::with_effect`] it
    /// switched on with it (`nonlinear_contact with load_zone`).
    pub fn label(&self) -> String {
        match (self.joint, self.with_effect) {
            (true, Some(b)) => trial_label_joint(self.effect, b),
            _ => trial_label(self.effect, self.with_effect),
        }
    }
}

/// `k`'s name, with ` with c` for an effect `c` switched on with it ([`EffectTrial::label`]).
pub fn trial_label(k: EffectKind, with_effect: Option<EffectKind>) -> String {
    match with_effect {
        Some(c) => format!("{} with {}", k.name(), c.name()),
        None => k.name().to_string(),
    }
}

/// The name of a joint trial of `a` and `b` ([`EffectTrial::joint`]): `a + b`.
pub fn trial_label_joint(a: EffectKind, b: EffectKind) -> String {
    format!("{} + {}", a.name(), b.name())
}

/// What the CLI and the app print when a diagnosis's floor is 0: nothing in the model is
/// random, so [`seed_floor`]'s replicas equal the model, and the decision's floor margin and
/// explained share lose their reference.
pub const ZERO_FLOOR_NOTE: &str = "the model has nothing random in it (no noise, slip or fault roughness), so its replicas under other seeds are identical and its floor is 0: every error counts as explainable; switch on `noise`, as no measurement is noise-free";

/// What the CLI and the app print under a trial that is [`EffectTrial::outside_band`].
pub const OUTSIDE_BAND_NOTE: &str = "its feature was fitted at the edge of the band searched, outside what the data show: not a finding";

impl EffectTrial {
    /// Whether the trial is no finding whatever it explains: its feature lies outside the band
    /// ([`EffectTrial::outside_band`]) or its strength is pinned at an edge of its range
    /// ([`EffectTrial::pinned`]).
    pub fn not_a_finding(&self) -> bool {
        self.outside_band || self.pinned.is_some()
    }

    /// For a [`EffectTrial::pinned`] trial, whether its strength is pinned at the top of its
    /// range (else at the bottom).
    pub fn pinned_at_top(&self) -> Option<bool> {
        let ((_, v), (lo, hi)) = (self.parameter?, self.pinned?);
        Some(in_upper_half(v, lo, hi))
    }

    /// What the CLI and the app print under a trial that is no finding
    /// ([`EffectTrial::not_a_finding`]): [`OUTSIDE_BAND_NOTE`] or [`EffectTrial::pinned_note`].
    pub fn not_a_finding_note(&self) -> Option<&'static str> {
        if self.outside_band {
            Some(OUTSIDE_BAND_NOTE)
        } else {
            self.pinned_note()
        }
    }

    /// The note of a [`EffectTrial::pinned`] trial: pinned at the top or at the bottom.
    pub fn pinned_note(&self) -> Option<&'static str> {
        Some(pinned_note_at(self.pinned_at_top()?))
    }
}

/// What the CLI and the app print under a strength pinned at the top (`true`) or the bottom of
/// its range.
fn pinned_note_at(top: bool) -> &'static str {
    if top {
        "its strength was fitted at the top of its range: not an estimate; it stands in for something its range does not hold: not a finding"
    } else {
        "its strength was fitted at the bottom of its range: the effect is all but off, and what the trial explains its re-fit did: not a finding"
    }
}

/// The answer of [`diagnose`].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Diagnosis {
    /// The calibration done first.
    pub calibration: Fit,
    /// Metrics of the calibrated model per domain: (domain, Pearson, NRMSE %).
    pub domains: Vec<(String, f64, f64)>,
    /// Where the calibrated model fails.
    pub residual_map: ResidualMap,
    /// The objective a perfect model would still show: the calibrated model compared with
    /// realisations of itself under other seeds (random noise, estimator scatter). The error
    /// above this floor is what a missing effect can explain.
    #[serde(default)]
    pub floor_objective: f64,
    /// The floor's NRMSE (%) per domain: (domain, NRMSE).
    #[serde(default)]
    pub floor_domains: Vec<(String, f64)>,
    /// The objective / floor ratio from which the decision saw something to explain
    /// ([`floor_ratio_needed`] of the options it was judged with: 1.3 with one realisation and
    /// the default margin, 1.5 with session 43's). 0 under [`DecisionRule::Scatter`], which
    /// asks no ratio, and in an old JSON.
    #[serde(default)]
    pub floor_ratio_needed: f64,
    /// Standard deviation of the calibrated objective when only the model's seed changes: the
    /// noise on every trial's objective.
    #[serde(default)]
    pub objective_scatter: f64,
    /// Trials, best first.
    pub trials: Vec<EffectTrial>,
    /// The effect to add, if one is significant.
    pub best: Option<EffectKind>,
    /// `"<effect>: <summary>"` or `"nothing significant is missing"`.
    pub verdict: String,
    /// Candidates whose trial could not be run, with the reason (the machine with the effect
    /// on is invalid, or its simulation failed). They are not ranked.
    #[serde(default)]
    pub failed_trials: Vec<(EffectKind, String)>,
    /// Whether the stage-1 trials also started from the uncalibrated values: because the
    /// calibration pinned a parameter (`LoopOptions::unbend_pinned`), or because the plain
    /// search was stuck ([`Diagnosis::stuck_plain_verdict`]).
    #[serde(default)]
    pub unbent: bool,
    /// Set when this diagnosis is the unbent redo of a stuck search
    /// (`LoopOptions::unbend_when_stuck`; see [`diagnose_with`]): the verdict of the plain
    /// search it replaced, whose trials started from the calibrated model only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stuck_plain_verdict: Option<String>,
    /// Set when this diagnosis is the unbent redo of a short search
    /// (`LoopOptions::unbend_when_short`; see [`diagnose_with`]): the plain search's chosen
    /// effect, the share of the error above the floor it explained, and its verdict.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub short_plain: Option<ShortPlain>,
    /// With `LoopOptions::uncalibrated_start_top`: the effects among the best stage-1 trials
    /// whose second start, from the uncalibrated values, fitted better than the plain start
    /// (the trial went on to stage 2 from it), in this search or one it replaced (a stuck or
    /// short plain search, a second look's first). Empty when no second start won, or the
    /// option is off: then the diagnosis is the one it would have been without the option.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub top_second_starts_won: Vec<EffectKind>,
    /// With `LoopOptions::fine_force_scan`: the effects with a trial that records a fine-cell
    /// win ([`EffectTrial::fine_cell_won`]), in this search or one it replaced. Empty when
    /// none did, or the option is off: then the diagnosis is the one the plain search makes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fine_cell_won: Vec<EffectKind>,
    /// The transfer-path correction fitted to the calibrated model
    /// (`CompareOptions::path_correction_bands`); `None` when off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_correction: Option<crate::dsp::path_correction::PathCorrection>,
    /// The calibrated model's objective on held-out realisations, against which the trials
    /// were judged (with two or more realisations, see [`EffectTrial::objective_fitted`]);
    /// None with one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out_objective: Option<f64>,
    /// Set when this diagnosis is the second look of
    /// [`LoopOptions::random_effect_realisations`]: the realisations it used, the random effect
    /// that led the ranking with one, and that ranking's verdict.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub second_look: Option<SecondLook>,
    /// With [`LoopOptions::strength_range`]: the range of the chosen effect's strength that the
    /// data cannot tell from the fitted value (a profile, every other free parameter
    /// re-fitted at each point: [`super::strength_range`]). None when off or nothing was chosen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strength_range: Option<super::strength_range::StrengthRange>,
    /// The best trial when the verdict names it as a lead although nothing is significant
    /// (by `decide`'s own test: it passes every test but the floor's). None when something was chosen
    /// or no trial is a lead.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub near_floor_lead: Option<EffectKind>,
    /// With `LoopOptions::joint_trials`, when the search was stuck: the joint trials of its
    /// best single trials ([`super::joint`]), best first. One that is a finding is also the
    /// head of [`Diagnosis::trials`] and the diagnosis's choice. Empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joint_trials: Vec<EffectTrial>,
    /// With [`LoopOptions::removal_trials`]: each part of the starting model (a bearing's
    /// fault, an effect that is on) taken out and the rest calibrated again, with what the
    /// measurement says of it ([`super::removal`]). Empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub removals: Vec<super::removal::RemovalTrial>,
    /// The sampling rate the measurement was compared at, Hz (the model's when the
    /// measurement was sampled faster: [`super::at_most_rate`]); 0 in an old JSON.
    #[serde(default)]
    pub compared_at_hz: f64,
    /// The measurement's own rate, Hz, when it was resampled down to `compared_at_hz`
    /// ([`super::resampled_from_hz`]); None when it was compared at its own rate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured_resampled_from_hz: Option<f64>,
    /// Set when the starting model holds no vibration but its noise
    /// ([`super::removal::silent`]): `(model rms without its noise, measured rms)`. Its
    /// calibration then scales round-off, and nothing the search says of it means much (the
    /// inner-race preset without its fault: 5.4e-16 g against 097's 0.07 g).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub silent_model: Option<(f64, f64)>,
}

/// A diagnosis redone with several realisations because a random effect led it with one
/// ([`LoopOptions::random_effect_realisations`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SecondLook {
    /// Realisations of the second diagnosis.
    pub realisations: usize,
    /// The random effect ranked first with one realisation.
    pub leader: EffectKind,
    /// The verdict with one realisation.
    pub verdict_with_one: String,
}

/// The plain search a short one's unbent redo replaced ([`LoopOptions::unbend_when_short`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShortPlain {
    /// The effect the plain search chose.
    pub chosen: EffectKind,
    /// The share of the error above the seed floor its trial explained (under
    /// [`SHORT_EXPLAINED`](crate::compare::SHORT_EXPLAINED)).
    pub explained: f64,
    /// The plain search's verdict.
    pub verdict: String,
}

impl Diagnosis {
    /// The calibrated objective the decision used: on held-out realisations when the trials
    /// were judged on them ([`Diagnosis::held_out_objective`]), else the calibration's own.
    /// Compare trials' `objective_after` with this one, not with the calibration's.
    pub fn judged_objective(&self) -> f64 {
        self.held_out_objective.unwrap_or(self.calibration.objective_after)
    }

    /// The warning for a [`Diagnosis::silent_model`], None when the model vibrates.
    pub fn silent_model_warning(&self, unit: &str) -> Option<String> {
        self.silent_model.map(|rms_pair| {
            format!("{}: its calibration scales round-off, so the ranking means little; give it what makes it vibrate (a fault, a load zone carrying the rotor's weight: the preset cwru_6205_healthy for a healthy 6205)", super::removal::silent_model_words(rms_pair, unit))
        })
    }

    /// The rate compared at in words: "12000 Hz (the measurement resampled from 48000 Hz)".
    pub fn rate_in_words(&self) -> String {
        let from = self.measured_resampled_from_hz.map(|hz| format!(" (the measurement resampled from {hz:.0} Hz)")).unwrap_or_default();
        format!("{:.0} Hz{from}", self.compared_at_hz)
    }

    /// The calibrated model's envelope NRMSE (%), None when the envelope was not compared.
    pub fn envelope_nrmse(&self) -> Option<f64> {
        self.domains.iter().find(|x| x.0 == "envelope").map(|x| x.2)
    }
}

/// Characteristic frequencies of a machine at its speed: shaft, bearing fault families of the
/// first bearing, GMF of each gear pair.
pub fn machine_families(m: &Machine) -> (Vec<CharacteristicFrequency>, Option<f64>) {
    let speeds = m.shaft_speeds_hz().unwrap_or_default();
    let mut fams = Vec::new();
    let mut shaft = speeds.first().copied();
    if let Some(b) = m.bearings.first() {
        if let (Ok(g), Some(si)) = (m.bearing_geometry(0), m.shaft_index(&b.shaft)) {
            if let Ok(ff) = g.fault_frequencies(speeds[si]) {
                fams.extend(ff.families());
                shaft = Some(speeds[si]);
            }
        }
    }
    if fams.is_empty() {
        if let Some(fr) = shaft {
            fams.push(CharacteristicFrequency { label: "shaft".into(), frequency_hz: fr });
        }
    }
    for gp in &m.gear_pairs {
        if let Some(pi) = m.shaft_index(&gp.pinion_shaft) {
            fams.push(CharacteristicFrequency { label: "GMF".into(), frequency_hz: speeds[pi] * gp.pinion_teeth as f64 });
        }
    }
    (fams, shaft)
}

/// The fault frequency of `m`'s first faulty bearing — BPFO, BPFI or 2×BSF by the fault's
/// location — on the measured signal's speed axis (times measured / model shaft speed, as the
/// comparison's order normalisation does), for the SCF α-slice at the fault frequency. `None`
/// when no bearing has a localised fault.
pub fn fault_frequency_hz(m: &Machine, measured: &Signal) -> Option<f64> {
    use crate::model::FaultLocation;
    let speeds = m.shaft_speeds_hz().ok()?;
    let (i, b) = m.bearings.iter().enumerate().find(|(_, b)| b.fault.is_some())?;
    let ff = m.bearing_geometry(i).ok()?.fault_frequencies(speeds[m.shaft_index(&b.shaft)?]).ok()?;
    let f = ff.by_name(match b.fault.as_ref()?.location {
        FaultLocation::Outer => "outer",
        FaultLocation::Inner => "inner",
        FaultLocation::Ball => "ball",
    })?;
    let speed_ratio = match (measured.meta.shaft_speed_hz, speeds.first()) {
        (Some(fm), Some(&fs)) if fm > 0.0 && fs > 0.0 => fm / fs,
        _ => 1.0,
    };
    Some(f * speed_ratio)
}

/// What in the residual map speaks for an effect, in words, with the share it carries. For a
/// casing mode, `mode_hz` is the frequency its trial fitted: the evidence is the share of the
/// PSD error in the band at that frequency (the mode cannot explain a band it does not sit in;
/// its level and its shape there both count, since a calibration bent to imitate the mode
/// may already match the band's mean level), or, before a fit, the band where the model is
/// weakest.
fn evidence(k: EffectKind, map: &ResidualMap, mode_hz: Option<f64>) -> (String, f64) {
    if let (EffectKind::CasingModes, Some(f)) = (k, mode_hz) {
        let band = map.items.iter().filter(|i| i.kind == "psd_band").min_by(|a, b| (a.frequency_hz - f).abs().total_cmp(&(b.frequency_hz - f).abs()));
        return match band {
            Some(i) => (
                format!("PSD band {} ({:+.1} dB mean level in the model), where the mode was fitted ({f:.0} Hz); the band carries {:.0} % of the PSD error", i.label, i.simulated - i.measured, i.share_percent),
                i.share_percent,
            ),
            None => ("no PSD bands in the residual map".into(), 0.0),
        };
    }
    let env_items = |pred: &dyn Fn(&str) -> bool| -> (f64, Option<String>) {
        let share: f64 = map.envelope_families.iter().filter(|(f, _)| pred(f)).map(|(_, s)| s).sum();
        let top = map.items.iter().find(|i| i.kind == "envelope_line" && pred(&i.family)).map(|i| format!("{} ({:.1} Hz): {}", i.label, i.frequency_hz, i.note));
        (share, top)
    };
    let psd_top = |want_weak: bool| -> (f64, Option<String>) {
        let mut items: Vec<_> = map.items.iter().filter(|i| i.kind == "psd_band" && (i.simulated < i.measured) == want_weak).collect();
        items.sort_by(|a, b| b.share_percent.total_cmp(&a.share_percent));
        let share = items.iter().map(|i| i.share_percent).sum::<f64>();
        (share, items.first().map(|i| format!("PSD band {} {:+.1} dB in the model", i.label, i.simulated - i.measured)))
    };
    let (share, what, domain) = match k {
        EffectKind::LoadZone => {
            let (s, t) = env_items(&|f| f.ends_with("± shaft") || f == "shaft harmonics");
            (s, t, "envelope")
        }
        EffectKind::Slip | EffectKind::SpeedFluctuation => {
            let (s, t) = env_items(&|f| f == "unlabelled envelope" || (!f.contains('±') && f != "shaft harmonics"));
            (s, t, "envelope")
        }
        EffectKind::GearMesh | EffectKind::ToothFault => {
            let (s, t) = env_items(&|f| f.starts_with("GMF"));
            (s, t, "envelope")
        }
        EffectKind::Unbalance | EffectKind::Misalignment | EffectKind::ExtendedFault | EffectKind::PathModulation => {
            let (s, t) = env_items(&|f| f == "shaft harmonics");
            (s, t, "envelope")
        }
        EffectKind::BeltDrive => {
            let (s, t) = env_items(&|f| f == "unlabelled envelope");
            (s, t, "envelope")
        }
        EffectKind::CasingModes | EffectKind::Noise => {
            let (s, t) = psd_top(true);
            (s, t, "PSD")
        }
        EffectKind::SensorResponse => {
            let (s, t) = psd_top(false);
            (s, t, "PSD")
        }
        EffectKind::NonlinearContact => (0.0, None, "envelope"),
    };
    let text = match what {
        Some(t) => format!("{t}; its signature carries {share:.0} % of the {domain} error"),
        None => format!("no specific signature in the residual map ({share:.0} % of the {domain} error)"),
    };
    (text, share)
}

/// The evidence of a trial of `k` that switched `with_effect` on with it ([`evidence`]), its
/// fitted machine `fm` placing a casing mode: a trial that brings the effect its own acts
/// through shows that effect's signature, the contact nonlinearity having none of its own in
/// the residual map (session 62: a tie on evidence went to a casing mode whose band carried 2 %
/// of the PSD error, where the load zone's lines carried 64 % of the envelope's).
pub(super) fn trial_evidence(k: EffectKind, with_effect: Option<EffectKind>, map: &ResidualMap, fm: &Machine) -> (String, f64) {
    evidence(with_effect.unwrap_or(k), map, if k == EffectKind::CasingModes { Param::CasingModeHz.get(fm) } else { None })
}

/// A trial's fitted machine `fm` with what the trial switched on switched off again, its
/// effect and the one it brought ([`EffectTrial::with_effect`]), everything else as fitted:
/// the ablation behind [`EffectTrial::effect_explained`]. Switching off the contact
/// nonlinearity alone would leave its load zone doing the work (session 62, bearing pair
/// 10300: 12 % where the pair explained 101 %).
fn switched_off(mut fm: Machine, t: &EffectTrial) -> Machine {
    fm.effects.disable(t.effect);
    if let Some(c) = t.with_effect {
        fm.effects.disable(c);
    }
    fm
}

/// Calibrated parameters every trial re-fits locally after fitting its effect (see
/// [`fit_trial`]): the noise level absorbs whatever energy the model lacks.
pub(super) const TRIAL_REFINE: [Param; 1] = [Param::NoiseSnrDb];

/// Seeds of the replicas behind [`seed_floor`].
pub(super) const FLOOR_SEEDS: [u64; 2] = [0x5EED_0001, 0x5EED_0002];

/// The objective (and per-domain NRMSE) of `m` against realisations of itself with other seeds,
/// averaged over [`FLOOR_SEEDS`]: what even a perfect model scores against this measurement's
/// length and options, because noise, slip and the estimators are random. `like` supplies the
/// duration, unit and metadata of the measurement. Each domain's RMSE is normalised by the
/// normaliser of the real comparison `against` (the measurement's range, not the replica's), so
/// floor and objective are on one scale.
pub fn seed_floor(m: &Machine, like: &Signal, against: &Comparison, opts: &LoopOptions) -> Result<(f64, Vec<(String, f64)>), LoopError> {
    let runs: Vec<Result<Comparison, LoopError>> = FLOOR_SEEDS
        .par_iter()
        .map(|&s| {
            let mut twin = reseeded(m, s);
            twin.duration_s = opts.fit_duration_s.min(like.duration_s());
            let mut pseudo = crate::model::simulate_cached(&twin)?;
            pseudo.unit = like.unit.clone();
            pseudo.meta.shaft_speed_hz = like.meta.shaft_speed_hz.or(pseudo.meta.shaft_speed_hz);
            let r = Reference::new(&pseudo, &opts.compare)?;
            Ok(evaluate(m, &r, opts)?.0)
        })
        .collect();
    let runs: Vec<Comparison> = runs.into_iter().collect::<Result<_, _>>()?;
    let n = runs.len() as f64;
    let mut floor = against.clone();
    for d in floor.domains.iter_mut() {
        // The replicas' RMSE with their simulated mean's own scatter out (as in the objective).
        let rmse = runs.iter().filter_map(|c| c.domain(&d.domain)).map(|x| x.debiased_rmse()).sum::<f64>() / n;
        d.metrics.rmse = rmse;
        d.scatter_rmse = 0.0;
        d.metrics.nrmse_percent = crate::compare::metrics::nrmse_percent(rmse, d.metrics.normaliser_value);
    }
    let domains = floor.domains.iter().map(|d| (d.domain.clone(), d.metrics.nrmse_percent)).collect();
    Ok((objective(&floor, &opts.weights), domains))
}

/// `m` with its random seed mixed with `salt`: the same machine, another realisation.
pub(super) fn reseeded(m: &Machine, salt: u64) -> Machine {
    let mut t = m.clone();
    t.seed = m.seed ^ salt;
    t
}

/// Seeds of the re-runs behind [`objective_scatter`].
pub const SCATTER_SEEDS: [u64; 2] = [0x5CA7_0001, 0x5CA7_0002];

/// The standard deviation of the objective of `m` against the measurement over the model's
/// seed (its own and [`SCATTER_SEEDS`]): how much a trial's objective moves by chance alone.
pub fn objective_scatter(m: &Machine, reference: &Reference, j_own_seed: f64, opts: &LoopOptions) -> Result<f64, LoopError> {
    let js: Vec<Result<f64, LoopError>> = SCATTER_SEEDS
        .par_iter()
        .map(|&s| {
            Ok(objective(&evaluate(&reseeded(m, s), reference, opts)?.0, &opts.weights))
        })
        .collect();
    let mut all = vec![j_own_seed];
    for j in js {
        all.push(j?);
    }
    let n = all.len() as f64;
    let mean = all.iter().sum::<f64>() / n;
    Ok((all.iter().map(|j| (j - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
}

/// The decision, from the trials' objectives and the noise around them:
/// 1. rank by objective after the trial (best first), except that a trial that is no finding
///    ([`EffectTrial::not_a_finding`]: its feature fitted at the edge of its band, or its
///    strength pinned at an edge of its range) goes after every other;
/// 2. trials within the seed scatter of the best (difference < 2√2 σ) are tied: the data
///    cannot tell them apart, and the one whose signature carries most of the residual map's
///    error is put first;
/// 3. that effect is significant when (a) the calibrated model is clearly above its floor
///    (objective ≥ [`floor_ratio_needed`] × floor, `1 + floor_margin` with one realisation:
///    there is error a missing effect could explain), (b) it explains at least `significance` of the error above the floor, and (c)
///    its improvement exceeds 2√2 σ (it is not the luck of a seed). With
///    [`DecisionRule::Scatter`], (a) is instead objective − floor > 2√2 σ, and (d) switching
///    the effect off again in the trial's fit must cost at least `significance` too.
///
/// Otherwise the answer is "nothing significant is missing", with the reason.
pub fn decide(mut trials: Vec<EffectTrial>, j0: f64, floor: f64, scatter: f64, opts: &LoopOptions) -> (Vec<EffectTrial>, Option<EffectKind>, String) {
    trials.sort_by(|a, b| a.objective_after.total_cmp(&b.objective_after));
    // A feature fitted outside the band, or a strength pinned at an edge of its range, is no
    // finding: after every other trial (stable).
    trials.sort_by_key(|t| t.not_a_finding());
    let n_findings = trials.iter().filter(|t| !t.not_a_finding()).count();
    let tie = tie_width(scatter);
    if let Some(j_best) = trials.first().filter(|t| !t.not_a_finding()).map(|t| t.objective_after) {
        for t in trials[..n_findings].iter_mut() {
            t.tied_with_best = t.objective_after - j_best < tie;
        }
        let n_tied = trials.iter().filter(|t| t.tied_with_best).count();
        // Among the tied, the strongest evidence first (stable: objective order otherwise).
        trials[..n_tied].sort_by(|a, b| b.evidence_share.total_cmp(&a.evidence_share).then(a.objective_after.total_cmp(&b.objective_after)));
    }
    let Some(first) = trials.first() else {
        return (trials, None, "nothing significant is missing (no effect of the catalogue applies to this machine)".into());
    };
    let improvement = j0 - first.objective_after;
    let (above, near_floor) = something_to_explain(&trials, j0, floor, scatter, opts);
    let reason = if !(above || near_floor) {
        // The best trial is still named when it would pass every other test. On the stored
        // runs such a trial was the missed hidden effect about half the time (README "A
        // second start for every trial"), hence the wording.
        let lead = if names_a_near_floor_lead(first, j0, floor, scatter, opts) { format!("; best trial: {} explains {:.0} % of the error above the floor, beyond the seed scatter, but this near the floor a misfit of the base model can do as much: not a finding", first.label(), first.explained * 100.0) } else { String::new() };
        Some(format!("the calibrated model is within its own scatter: objective {j0:.2} against a floor of {floor:.2} (the model against realisations of itself){lead}"))
    } else if first.outside_band {
        Some(format!("best trial: {} puts its feature at the edge of the band searched{}, outside what the data show", first.label(), first.parameter.map_or(String::new(), |(p, v)| format!(" ({} = {v:.4e})", p.name()))))
    } else if first.pinned.is_some() {
        Some(format!("best trial: {}{}", first.label(), pinned_clause(first)))
    } else if first.explained < opts.significance {
        // A trial that is no finding (pinned, or its feature at the band's edge) and did better
        // is named: the error it took up is real, its cause is not that effect within its range.
        let no_finding_better = trials[n_findings..].iter().filter(|t| t.objective_after < first.objective_after && t.explained >= opts.significance).min_by(|a, b| a.objective_after.total_cmp(&b.objective_after));
        Some(format!(
            "best trial: {} explains {:.0} % of the error above the floor, below the {:.0} % threshold{}",
            first.label(),
            first.explained * 100.0,
            opts.significance * 100.0,
            no_finding_better.map_or(String::new(), |t| format!("; {}{}", t.effect.name(), no_finding_clause(t)))
        ))
    } else if improvement < tie {
        Some(format!("best trial: {} improves the objective by {improvement:.2}, within the seed scatter (±{tie:.2})", first.label()))
    } else if effect_did_not_work(first, opts) {
        Some(format!(
            "best trial: {} explains {:.0} % of the error above the floor, but switching the effect off again in its fit costs only {}: the trial's re-fit did the work",
            first.label(),
            first.explained * 100.0,
            first.effect_explained.map_or("an unknown share".to_string(), |e| format!("{:.0} %", e * 100.0))
        ))
    } else {
        None
    };
    match reason {
        None => {
            let ties: Vec<&str> = trials[1..].iter().filter(|t| t.tied_with_best).map(|t| t.effect.name()).collect();
            let tie_note = if ties.is_empty() { String::new() } else { format!(" [tied within the seed scatter with {}; chosen on the evidence]", ties.join(", ")) };
            let near_note = if near_floor {
                format!(
                    " [near the floor, {:.2} × it: chosen by the near-floor rule (its effect itself {:.0} %, no trial tied)]",
                    j0 / floor,
                    first.effect_explained.unwrap_or(f64::NAN) * 100.0
                )
            } else {
                String::new()
            };
            let v = format!("{}: {} — explains {:.0} % of the error above the floor{tie_note}{near_note}", first.label(), first.summary, first.explained * 100.0);
            let k = first.effect;
            (trials, Some(k), v)
        }
        Some(r) => (trials, None, format!("nothing significant is missing ({r})")),
    }
}

/// Whether switching the best trial's effect off again in its own fit costs less than
/// [`LoopOptions::significance`] of the error above the floor, so that the trial's re-fit of
/// the base, not the effect, lowered the objective: no finding. The scatter rule always asks
/// it, and an unknown ablation fails there; the floor margin with
/// [`LoopOptions::effect_must_work`] (the default), where an unknown one passes.
fn effect_did_not_work(first: &EffectTrial, opts: &LoopOptions) -> bool {
    match opts.decision_rule {
        DecisionRule::Scatter => !first.effect_explained.is_some_and(|e| e >= opts.significance),
        DecisionRule::FloorMargin => opts.effect_must_work && first.effect_explained.is_some_and(|e| e < opts.significance),
    }
}

/// The floor margin below which [`near_floor_finding`] claims nothing: its ratio (1.2 with one
/// realisation) is the lowest the controls of every stored table stayed under (0.80–1.10 ×).
pub const NEAR_FLOOR_MARGIN: f64 = 0.2;
/// The share of the error above the floor a near-floor finding must explain.
pub const NEAR_FLOOR_EXPLAINED: f64 = 0.8;
/// The share switching a near-floor finding's effect off again must cost (its ablation).
pub const NEAR_FLOOR_EFFECT_EXPLAINED: f64 = 0.5;

/// The near-floor rule ([`LoopOptions::near_floor_rule`], experimental): whether the first of
/// the decided `trials` is a finding although the calibrated objective `j0` is under the floor
/// margin's ratio. It must be at least [`NEAR_FLOOR_MARGIN`]'s ratio × `floor`, and the first
/// trial must: be a finding by every other test (not at an edge, ≥ `significance`, an
/// improvement beyond 2√2 σ); explain at least [`NEAR_FLOOR_EXPLAINED`] of the error above
/// the floor; cost at least [`NEAR_FLOOR_EFFECT_EXPLAINED`] when its effect is switched off
/// again in its fit (the effect, not the re-fit, did the work: a seen near-floor unbalance
/// explained 98 % with an ablation of 7 %); have no trial tied with it (a tied misalignment
/// and unbalance at 1.49 × were a false claim at a 0.2 margin); and place no spectral feature
/// ([`Param::places_a_feature`]: near the floor a roll-off took back what a resonance 3 % off
/// costs, README "Two hidden effects", seed 2904). Every threshold was set from seen rounds;
/// docs/loop-notebook.md "A near-floor rule" gives the fresh-seed test written before its runs.
pub fn near_floor_finding(trials: &[EffectTrial], j0: f64, floor: f64, scatter: f64, opts: &LoopOptions) -> bool {
    let Some(first) = trials.first() else { return false };
    let ratio = floor_ratio_needed(&LoopOptions { floor_margin: NEAR_FLOOR_MARGIN, ..opts.clone() });
    floor > 0.0
        && j0 >= ratio * floor
        && !first.not_a_finding()
        && !first.parameter.is_some_and(|(p, _)| p.places_a_feature())
        && first.explained >= NEAR_FLOOR_EXPLAINED.max(opts.significance)
        && first.effect_explained.is_some_and(|e| e >= NEAR_FLOOR_EFFECT_EXPLAINED)
        && j0 - first.objective_after >= tie_width(scatter)
        && !trials[1..].iter().any(|t| t.tied_with_best)
}

/// Where a trial's main parameter `p = v` (fitted in `m`) sits against its range: a feature at
/// an edge ([`EffectTrial::outside_band`]), or a strength pinned at an edge, with that range
/// ([`EffectTrial::pinned`]; not at a top that is the physics' own limit,
/// [`Param::top_is_a_physical_limit`]: the effect is at least that strong, a finding still).
pub(super) fn range_edge(p: Param, v: f64, m: &Machine) -> (bool, Option<(f64, f64)>) {
    let (lo, hi, log) = p.bounds(m);
    if !at_search_bound(v, lo, hi, log) {
        return (false, None);
    }
    if p.places_a_feature() {
        return (true, None);
    }
    (false, (!(in_upper_half(v, lo, hi) && p.top_is_a_physical_limit())).then_some((lo, hi)))
}

/// Which edge a value pinned within 2 % of one ([`at_search_bound`]) is at: the top when it is
/// above the middle of the range.
fn in_upper_half(v: f64, lo: f64, hi: f64) -> bool {
    v > 0.5 * (lo + hi)
}

/// Why a trial that explains a share is no finding: [`pinned_clause`], or its feature at the
/// edge of the band.
fn no_finding_clause(t: &EffectTrial) -> String {
    if t.outside_band {
        let at = t.parameter.map_or(String::new(), |(p, v)| format!(" ({} = {v:.4e})", p.name()));
        return format!(" explains {:.0} % of the error above the floor, but puts its feature at the edge of the band searched{at}, outside what the data show", t.explained * 100.0);
    }
    pinned_clause(t)
}

/// "explains N % …, but only with its strength at the top of its range (…): not an estimate".
fn pinned_clause(t: &EffectTrial) -> String {
    let (Some((p, v)), Some((lo, hi)), Some(top)) = (t.parameter, t.pinned, t.pinned_at_top()) else { return String::new() };
    format!(
        " explains {:.0} % of the error above the floor, but only with {} = {v:.4e} at the {} of its range ({lo:.1e} – {hi:.1e}): not an estimate{}",
        t.explained * 100.0,
        p.name(),
        if top { "top" } else { "bottom" },
        if top { "; it stands in for something its range does not hold" } else { "; the trial's re-fit did the work" }
    )
}

/// Objectives closer than this to each other are tied: `2√2 σ`, the spread of a difference of
/// two objectives that each scatter by σ, doubled.
pub(super) fn tie_width(scatter: f64) -> f64 {
    2.0 * std::f64::consts::SQRT_2 * scatter
}

/// Whether [`decide`], finding nothing to explain, names `first` as a lead: it would pass
/// every other test (above the floor at all, a finding, its share, an improvement beyond the
/// tie width, its effect doing the work: [`effect_did_not_work`]).
fn names_a_near_floor_lead(first: &EffectTrial, j0: f64, floor: f64, scatter: f64, opts: &LoopOptions) -> bool {
    j0 > floor && !first.not_a_finding() && first.explained >= opts.significance && j0 - first.objective_after >= tie_width(scatter) && !effect_did_not_work(first, opts)
}

/// Whether [`decide`] sees error a missing effect could explain in the calibrated objective
/// `j0`, given the decided `trials` (best first), as (the objective is above the floor by the
/// decision rule's test, the near-floor rule makes the first trial a finding).
fn something_to_explain(trials: &[EffectTrial], j0: f64, floor: f64, scatter: f64, opts: &LoopOptions) -> (bool, bool) {
    let above = match opts.decision_rule {
        DecisionRule::FloorMargin => above_floor(j0, floor, opts),
        DecisionRule::Scatter => j0 - floor > tie_width(scatter),
    };
    let near_floor = !above && opts.near_floor_rule && opts.decision_rule == DecisionRule::FloorMargin && near_floor_finding(trials, j0, floor, scatter, opts);
    (above, near_floor)
}

/// The effect [`decide`] names as a lead in a "nothing significant" verdict, given the
/// decided `trials` (best first): it finds nothing to explain, and the first trial would pass
/// every other test ([`names_a_near_floor_lead`]).
fn named_lead(trials: &[EffectTrial], j0: f64, floor: f64, scatter: f64, opts: &LoopOptions) -> Option<EffectKind> {
    let first = trials.first()?;
    let (above, near_floor) = something_to_explain(trials, j0, floor, scatter, opts);
    (!above && !near_floor && names_a_near_floor_lead(first, j0, floor, scatter, opts)).then_some(first.effect)
}

/// The verdict of a search that named a near-floor lead (`lead`), with a note when the
/// comparison spans under half the record: a longer one (`LoopOptions::fit_duration_s`)
/// lowers the seed scatter. On the bearing base a gear mesh at 1.12 × its floor with 1.5 s
/// compared was 1.20 × and found with 6 s, a path modulation 1.13 → 1.19 × (README
/// "Detection limits of the near-floor effects").
fn with_longer_comparison_note(verdict: String, lead: bool, fit_duration_s: f64, record_s: f64) -> String {
    if lead && record_s >= 2.0 * fit_duration_s {
        format!("{verdict}; the comparison spans {fit_duration_s:.1} s of the {record_s:.1} s record: a longer one (the fit duration) lowers the seed scatter and may tell this lead from a misfit")
    } else {
        verdict
    }
}

/// `d`, the answer of a whole search (its unbent redo and second look included), with
/// [`with_longer_comparison_note`] once, at the end of its verdict, when the search that
/// answered named a lead ([`Diagnosis::near_floor_lead`]).
fn noted_once(mut d: Diagnosis, fit_duration_s: f64, record_s: f64) -> Diagnosis {
    d.verdict = with_longer_comparison_note(std::mem::take(&mut d.verdict), d.near_floor_lead.is_some(), fit_duration_s, record_s);
    d
}

/// Whether an objective is far enough above its seed floor for anything to be missing:
/// `j ≥ floor_ratio_needed(opts) × floor` (`1 + floor_margin` with one realisation).
fn above_floor(j: f64, floor: f64, opts: &LoopOptions) -> bool {
    j >= floor_ratio_needed(opts) * floor
}

/// The objective / floor ratio from which something can be missing. `floor_margin` m was set
/// with one realisation (every stored table), whose objective and floor both hold the model's
/// own scatter: per bin, floor² ≈ 2V and j² ≈ b² + 2V (V: a realisation's variance, the
/// measurement's and the model's alike near the floor; b²: the squared distance between their
/// expected spectra), so the ratio 1 + m asks for b² ≥ 2((1 + m)² − 1) V. With K ≥ 2
/// realisations the mean's own scatter is taken out of both
/// ([`DomainComparison::debiased_nrmse_percent`](crate::compare::DomainComparison::debiased_nrmse_percent)):
/// floor² ≈ V, j² ≈ b² + V, and the same b²/V needs the ratio √(1 + 2((1 + m)² − 1)), 1.54
/// for the default 0.3 (1.87 for 0.5). Keeping 1 + m there would ask, whatever m, for half
/// the squared systematic distance b² (b √2 smaller) than with one realisation
/// (docs/loop-notebook.md "Detection limits").
pub fn floor_ratio_needed(opts: &LoopOptions) -> f64 {
    let r1 = 1.0 + opts.floor_margin;
    if opts.realisations <= 1 {
        r1
    } else {
        (1.0 + 2.0 * (r1 * r1 - 1.0)).sqrt()
    }
}

/// Calibrates the model, then tries every applicable effect it lacks (in parallel), and ranks
/// them, comparing at the model's rate at most ([`super::at_most_rate`]: a measurement sampled
/// faster is resampled down to it). Returns the calibrated machine and the diagnosis.
/// `progress(done, expected)` is called after every model evaluation (from worker threads);
/// returning `false` cancels, and the call ends with [`LoopError::Cancelled`].
pub fn diagnose(m: &Machine, measured: &Signal, opts: &LoopOptions, progress: &(dyn Fn(usize, usize) -> bool + Sync)) -> Result<(Machine, Diagnosis), LoopError> {
    let reference = Reference::new(&*super::at_most_rate(measured, m.fs_hz)?, &opts.compare)?;
    diagnose_with(m, &reference, opts, &LoopProgress::new(progress))
}

/// [`diagnose`] against a prepared [`Reference`], which should hold the measurement at the
/// model's rate at most ([`super::at_most_rate`]; a faster one is compared against the
/// up-sampled model, which holds nothing above its own Nyquist frequency). With
/// [`LoopOptions::random_effect_realisations`] K ≥ 2 and one realisation, a diagnosis whose
/// best-ranked trial is a random effect ([`EffectKind::draws_at_random`]) is done again with K
/// realisations, and that one is returned ([`Diagnosis::second_look`]).
///
/// With [`LoopOptions::unbend_when_stuck`], a diagnosis that is stuck (nothing significant,
/// the objective still above the floor margin's ratio) and did not unbend is done again with
/// every trial also started from the uncalibrated values, as when the calibration pins a
/// parameter, and that one is returned. A stuck one-realisation search is unbent *before* any
/// second look (since session 31): a strong force the calibration absorbed can leave a random
/// effect leading it, and the second look, which ends the stuck state, then took that random
/// effect (a 5e-3 kg·m unbalance answered by an extended fault, docs/loop-notebook.md "Unbend when stuck").
/// The second look then follows the unbent search, unbent too. A second look that is stuck
/// after a one-realisation search that was not is unbent as before (both searches again).
///
/// With [`LoopOptions::unbend_when_short`], a diagnosis whose significant best trial is short
/// (explains less than [`SHORT_EXPLAINED`] of the error above the floor and leaves the
/// objective above the floor margin's ratio) is redone unbent in the same places, and the
/// unbent one is returned with the plain one's choice in [`Diagnosis::short_plain`].
///
/// With [`LoopOptions::strength_range`], the answer's chosen effect gets the range of its
/// strength ([`Diagnosis::strength_range`]), judged with the realisations of the search that
/// chose it.
///
/// With [`LoopOptions::removal_trials`], the answer also holds the removal trials of `m`
/// ([`Diagnosis::removals`]), judged with at least [`super::removal::REMOVAL_REALISATIONS`].
pub fn diagnose_with(m: &Machine, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<(Machine, Diagnosis), LoopError> {
    let (cal, d) = diagnose_search(m, reference, opts, progress)?;
    let (cal, mut d) = answer(cal, d, reference, opts, progress)?;
    d.silent_model = super::removal::silent(m, reference, opts)?;
    if opts.removal_trials {
        let judged = super::removal::removal_options(opts);
        d.removals = super::removal::removal_trials(m, reference, &judged, d.silent_model, progress)?;
    }
    Ok((cal, d))
}

/// A whole search's diagnosis `d` of `cal` made the answer: [`noted_once`], then
/// [`with_strength_range`].
fn answer(cal: Machine, d: Diagnosis, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<(Machine, Diagnosis), LoopError> {
    let d = noted_once(d, opts.fit_duration_s, reference.measured().duration_s());
    with_strength_range(cal, d, reference, opts, progress)
}

/// With [`LoopOptions::strength_range`], `d` with the range of its chosen effect's strength,
/// judged with the realisations of the search that chose it; else `d` as it is.
fn with_strength_range(cal: Machine, mut d: Diagnosis, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<(Machine, Diagnosis), LoopError> {
    if opts.strength_range {
        let judged = judged_options(&d, opts);
        progress.expect(super::strength_range::strength_range_evaluations(&cal, &d, &judged));
        d.strength_range = super::strength_range::strength_range(&cal, &d, reference, &judged, progress)?;
    }
    Ok((cal, d))
}

/// [`diagnose_with`] without the strength range: [`diagnose_singles`], and, with
/// [`LoopOptions::joint_trials`] when it is stuck, its joint trials ([`super::joint`]).
fn diagnose_search(m: &Machine, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<(Machine, Diagnosis), LoopError> {
    let (cal, d) = diagnose_singles(m, reference, opts, progress)?;
    if opts.joint_trials && stuck(&d, opts) {
        // Judged as the diagnosis was: a second look's realisations when it is one.
        let judged = judged_options(&d, opts);
        let d = super::joint::with_joint_trials(m, &cal, d, reference, &judged, progress)?;
        return Ok((cal, d));
    }
    Ok((cal, d))
}

/// The search of single effects behind [`diagnose_search`]: the plain search, unbent when it
/// is stuck or short, each with its second look for a random effect.
fn diagnose_singles(m: &Machine, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<(Machine, Diagnosis), LoopError> {
    let mut calibrated = Vec::new();
    let first = diagnose_once(m, reference, opts, false, &mut calibrated, progress)?;
    if unbend_acts(&first.1, opts) {
        // The unbent search starts from the same calibration (deterministic: done again, it
        // would give the same values).
        let (cal, d2) = diagnose_once(m, reference, opts, true, &mut calibrated, progress)?;
        let d2 = unbent_verdict(d2, &first.1, opts);
        return look_twice((cal, d2), m, reference, opts, true, &mut calibrated, progress);
    }
    let (cal, d) = look_twice(first, m, reference, opts, false, &mut calibrated, progress)?;
    if !unbend_acts(&d, opts) {
        return Ok((cal, d));
    }
    let one = diagnose_once(m, reference, opts, true, &mut calibrated, progress)?;
    let (cal, d2) = look_twice(one, m, reference, opts, true, &mut calibrated, progress)?;
    Ok((cal, unbent_verdict(d2, &d, opts)))
}

/// Whether `d`'s machine is searched again unbent: `d` had trials, did not unbend already,
/// and is stuck ([`LoopOptions::unbend_when_stuck`]) or short
/// ([`LoopOptions::unbend_when_short`]); both need [`LoopOptions::unbend_pinned`].
fn unbend_acts(d: &Diagnosis, opts: &LoopOptions) -> bool {
    let stuck_acts = opts.unbend_when_stuck && stuck(d, opts);
    let short_acts = opts.unbend_when_short && short(d, opts).is_some();
    opts.unbend_pinned && !d.unbent && !d.trials.is_empty() && (stuck_acts || short_acts)
}

/// `d`'s chosen effect when its search is short ([`LoopOptions::unbend_when_short`]): the
/// best trial, significant, explains less than [`SHORT_EXPLAINED`] of the error above the
/// seed floor and leaves the objective at or above the floor margin's ratio.
fn short(d: &Diagnosis, opts: &LoopOptions) -> Option<ShortPlain> {
    let chosen = d.best?;
    let t = d.trials.iter().find(|t| t.effect == chosen)?;
    let short = t.explained < SHORT_EXPLAINED && above_floor_of(d, t.objective_after, opts);
    short.then(|| ShortPlain { chosen, explained: t.explained, verdict: d.verdict.clone() })
}

/// The unbent diagnosis `d2` with a verdict that says why it was made (`d` stuck or short)
/// and what the calibrated start alone (`d`) said.
fn unbent_verdict(mut d2: Diagnosis, d: &Diagnosis, opts: &LoopOptions) -> Diagnosis {
    // Stuck (no best) and short (a best) exclude each other.
    let why = match short(d, opts) {
        Some(s) => {
            let text = format!(
                "short with the trials from the calibrated model, which pins nothing: its best, {}, explained {:.0} % of the error above the floor",
                s.chosen.name(),
                100.0 * s.explained
            );
            d2.short_plain = Some(s);
            text
        }
        None => {
            d2.stuck_plain_verdict = Some(d.verdict.clone());
            "stuck with the trials from the calibrated model, which pins nothing".to_string()
        }
    };
    d2.verdict = format!("{} ({why}: every trial started again from the uncalibrated values too; from the calibrated model alone: {})", d2.verdict, d.verdict);
    // `top_second_starts_won` and `fine_cell_won` cover every search of a diagnosis, the
    // one replaced too.
    add_missing(&mut d2.top_second_starts_won, &d.top_second_starts_won);
    add_missing(&mut d2.fine_cell_won, &d.fine_cell_won);
    d2
}

/// Appends to `to` each item of `from` it lacks, in order.
pub(super) fn add_missing<T: PartialEq + Copy>(to: &mut Vec<T>, from: &[T]) {
    for k in from {
        if !to.contains(k) {
            to.push(*k);
        }
    }
}

/// The one-realisation diagnosis `first` of `m` ([`diagnose_once`] with `unbend`), followed by
/// the second look for random effects when one leads (see [`diagnose_with`]).
fn look_twice(first: (Machine, Diagnosis), m: &Machine, reference: &Reference, opts: &LoopOptions, unbend: bool, calibrated: &mut Vec<CalibratedRound>, progress: &LoopProgress) -> Result<(Machine, Diagnosis), LoopError> {
    let (cal, d) = first;
    let k = opts.random_effect_realisations;
    let leader = d.trials.first().map(|t| t.effect).filter(|e| e.draws_at_random());
    let (Some(leader), true) = (leader, opts.realisations == 1 && k >= 2) else {
        return Ok((cal, d));
    };
    let again = LoopOptions { realisations: k, ..opts.clone() };
    let (cal, mut d2) = diagnose_once(m, reference, &again, unbend, calibrated, progress)?;
    d2.verdict = format!("{} (a second look with {k} realisations: {} led with one, where a random effect is fitted to one draw; with one: {})", d2.verdict, leader.name(), d.verdict);
    // A second look after an unbent redo keeps what the plain search said.
    d2.stuck_plain_verdict = d.stuck_plain_verdict.clone();
    d2.short_plain = d.short_plain.clone();
    add_missing(&mut d2.top_second_starts_won, &d.top_second_starts_won);
    add_missing(&mut d2.fine_cell_won, &d.fine_cell_won);
    d2.second_look = Some(SecondLook { realisations: k, leader, verdict_with_one: d.verdict });
    Ok((cal, d2))
}

/// The model evaluations of a diagnosis's calibrated start ([`diagnose`]): the calibration of
/// `m`, the calibrated model's comparison, its seed floor and its scatter.
pub fn calibration_evaluations(m: &Machine, opts: &LoopOptions) -> usize {
    calibrate_round_evaluations(m, opts) + 1 + FLOOR_SEEDS.len() + SCATTER_SEEDS.len()
}

/// The model evaluations of [`calibrate_round`] of `m` over its [`calibration_parameters_for`].
pub(super) fn calibrate_round_evaluations(m: &Machine, opts: &LoopOptions) -> usize {
    let params = calibration_parameters_for(m, opts);
    let pair = if calibrated_force_pair(m, &params, opts).is_some() { force_pair_evaluations() } else { 0 };
    fit_evaluations(m, &params, &[], opts.sweeps, opts) + pair
}

/// A round's calibration of `m` over `cal_params` ([`calibration_parameters_for`]): the fit,
/// then the joint grid of an applied unbalance and misalignment ([`calibrated_force_pair`]).
/// Its evaluations are [`calibration_evaluations`]' but for the comparison, floor and scatter.
pub(super) fn calibrate_round(m: &Machine, reference: &Reference, cal_params: &[Param], opts: &LoopOptions, progress: &LoopProgress) -> Result<(Machine, Fit), LoopError> {
    let (machine, fit) = fit_with_progress(m, reference, cal_params, opts.sweeps, opts, progress)?;
    match calibrated_force_pair(m, cal_params, opts) {
        Some(pair) => fit_force_pair(&machine, reference, fit, pair, opts, progress),
        None => Ok((machine, fit)),
    }
}

/// The unbalance and misalignment amplitudes a round's calibration also fits jointly
/// ([`LoopOptions::force_pair_grid`], [`fit_force_pair`]): both forces on, on one shaft, and
/// both among the calibration's parameters `cal_params` (applied in earlier rounds).
pub fn calibrated_force_pair(m: &Machine, cal_params: &[Param], opts: &LoopOptions) -> Option<(Param, Param)> {
    let pair = (Param::UnbalanceKgM, Param::Misalignment2xN);
    let shaft = shaft_rate_force_shaft(EffectKind::Unbalance, m);
    let shared = shaft.is_some() && shaft == shaft_rate_force_shaft(EffectKind::Misalignment, m);
    (opts.force_pair_grid && shared && cal_params.contains(&pair.0) && cal_params.contains(&pair.1)).then_some(pair)
}

/// The model evaluations of the second start of a trial of effect `k` on machine `m` (without
/// it) that [`LoopOptions::uncalibrated_start`] and [`LoopOptions::uncalibrated_start_top`]
/// add: from `m`'s uncalibrated values, the effect's main parameter scanned, then the plain
/// trial's fit.
pub fn scanned_start_evaluations(m: &Machine, k: EffectKind, opts: &LoopOptions) -> usize {
    let (t, scan) = uncalibrated_start_of(m, k);
    fit_trial_scanning_evaluations(&t, &trial_parameters(k, m), &TRIAL_REFINE, &scan, opts)
}

/// The effect a trial of `k` on `m` (without `k`) switches on with `k`: the one `k` acts
/// through ([`EffectKind::acts_through`]), when `m` lacks it and it applies to `m`. A contact
/// nonlinearity tried alone on a model without a load zone changes nothing (every ball at the
/// preload its linearisation is taken at); where both are missing, only both together show
/// what either does (session 62: a load zone and a contact nonlinearity hidden together were
/// answered by a casing mode, each trial alone explaining nothing). Whatever the candidate
/// list, the trial of `k` brings its companion.
pub fn companion(k: EffectKind, m: &Machine) -> Option<EffectKind> {
    k.acts_through().filter(|c| !m.effects.is_on(*c) && Effects::applicable(*c, m))
}

/// The parameters a trial of `k` on `m` (without `k`) fits: `k`'s ([`Param::of_effect`]),
/// then its [`companion`]'s.
pub fn trial_parameters(k: EffectKind, m: &Machine) -> Vec<Param> {
    let mut ps = Param::of_effect(k);
    if let Some(c) = companion(k, m) {
        ps.extend(Param::of_effect(c).into_iter().filter(|p| !ps.contains(p)).collect::<Vec<_>>());
    }
    ps
}

/// The main parameter of a trial of `k` on `m`: `k`'s, or, when `k` has none (a switch), its
/// [`companion`]'s.
fn trial_main_parameter(k: EffectKind, m: &Machine) -> Option<Param> {
    Param::main_of_effect(k).or_else(|| companion(k, m).and_then(Param::main_of_effect))
}

/// `m` (without `k`) with effect `k` switched on for its trial: with its [`companion`], and a
/// path modulation at the shaft rate.
pub(super) fn switched_on(m: &Machine, k: EffectKind) -> Machine {
    let mut t = m.clone();
    if let Some(c) = companion(k, m) {
        t.effects.enable(c);
    }
    t.effects.enable(k);
    if k == EffectKind::PathModulation {
        set_path_modulation_to_shaft_rate(&mut t);
    }
    t
}

/// A trial's start from the uncalibrated values: `m` with effect `k` on ([`switched_on`]),
/// and the parameter scanned on a grid first (the trial's main one).
fn uncalibrated_start_of(m: &Machine, k: EffectKind) -> (Machine, Vec<Param>) {
    (switched_on(m, k), trial_main_parameter(k, m).into_iter().collect())
}

/// The model evaluations of the plain stage-1 trial of effect `k` on machine `m` (without
/// it): from the calibrated model (at each coupled start with
/// [`LoopOptions::coupled_forces`]), or, for a trial that re-does the calibration with its
/// effect ([`recalibrates`]), from the uncalibrated values.
pub fn plain_trial_evaluations(m: &Machine, k: EffectKind, opts: &LoopOptions) -> usize {
    let t = switched_on(m, k);
    if recalibrates(k, opts) {
        fit_evaluations(&t, &recalibration_parameters(k, m, opts), &[], 1, opts)
    } else {
        let coupled = if opts.coupled_forces { coupled_applied_forces(k, m) } else { Vec::new() };
        let starts = if coupled.is_empty() { 1 } else { 1 + coupled_scales().len() };
        let scan = plain_trial_scan(k, opts);
        let full = fit_trial_scanning_evaluations(&t, &trial_parameters(k, m), &TRIAL_REFINE, &scan, opts);
        match refined_coupled_starts(starts, &scan, opts) {
            Some(refined) => starts * scan_evaluations(opts) + refined * full,
            None => starts * full,
        }
    }
}

/// How many of a coupled trial's `starts` are fitted in full after each start's grid
/// ([`LoopOptions::coupled_refined_starts`]); None when every start is fitted in full without
/// a grid of its own first: the option is 0 or at least `starts`, or the trial scans no
/// force (`scan`, see [`plain_trial_scan`]).
fn refined_coupled_starts(starts: usize, scan: &[Param], opts: &LoopOptions) -> Option<usize> {
    let n = opts.coupled_refined_starts;
    (n > 0 && n < starts && !scan.is_empty()).then_some(n)
}

/// The indices of the `n` lowest of `minima`, in ascending index order (among equals the
/// earlier; a NaN counts as +∞).
fn lowest_indices(minima: &[f64], n: usize) -> Vec<usize> {
    let key = |i: usize| if minima[i].is_nan() { f64::INFINITY } else { minima[i] };
    let mut order: Vec<usize> = (0..minima.len()).collect();
    order.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
    order.truncate(n);
    order.sort_unstable();
    order
}

/// The factors by which [`LoopOptions::coupled_forces`] scales an applied force's amplitude
/// for the extra starts of a trial of a force sharing its harmonic (the applied value itself
/// is the first start). ±12 % covers session 63's 7 % (gear pair 10341) with room; steps of
/// 3 % keep the start inside a valley about ±10 % wide.
pub const COUPLED_SCALES: [f64; 8] = [0.88, 0.91, 0.94, 0.97, 1.03, 1.06, 1.09, 1.12];

/// The factors by which [`LoopOptions::coupled_forces`] also scales an applied force for a
/// coupled trial, beyond [`COUPLED_SCALES`]: applied first without the other force, either
/// takes up part of the other's shared 1× line, adding to it or taking from it. An applied
/// unbalance was fitted 16 %, 55 % and 90 % high and 21 % low (sessions 65–67,
/// docs/loop-notebook.md "the reverse order"; for a misalignment's trial since sessions 66–67),
/// an applied misalignment 97 % high (session 67's drawn machine 6712; for an unbalance's
/// trial since session 68). Steps of 10 % down to half, and up to 1.4.
pub const WIDE_COUPLED_SCALES: [f64; 7] = [0.5, 0.6, 0.7, 0.8, 1.2, 1.3, 1.4];

/// The scales of a coupled trial's extra starts ([`coupled_starts`]): [`COUPLED_SCALES`], then
/// [`WIDE_COUPLED_SCALES`].
fn coupled_scales() -> Vec<f64> {
    COUPLED_SCALES.iter().chain(&WIDE_COUPLED_SCALES).copied().collect()
}

/// The shaft (its index; the first unless one is named) an unbalance or a misalignment that
/// is on in `m` acts on; None for any other effect, or one that is off.
fn shaft_rate_force_shaft(k: EffectKind, m: &Machine) -> Option<usize> {
    let named = match k {
        EffectKind::Unbalance => m.effects.unbalance.as_ref().map(|e| e.shaft.clone()),
        EffectKind::Misalignment => m.effects.misalignment.as_ref().map(|e| e.shaft.clone()),
        _ => None,
    }?;
    Some(named.and_then(|s| m.shaft_index(&s)).unwrap_or(0))
}

/// The amplitudes of the periodic forces applied on `m` that share a harmonic with the force
/// a trial of `k` switches on, on the same shaft: an unbalance (1×) and a misalignment (2×
/// and a weaker 1×). Empty for any other `k`, and where `k` is already on.
/// [`LoopOptions::coupled_forces`] fits them with `k`'s force.
pub fn coupled_applied_forces(k: EffectKind, m: &Machine) -> Vec<Param> {
    if m.effects.is_on(k) {
        return Vec::new();
    }
    let Some(own) = shaft_rate_force_shaft(k, &switched_on(m, k)) else {
        return Vec::new();
    };
    [EffectKind::Unbalance, EffectKind::Misalignment]
        .into_iter()
        .filter(|&a| a != k && shaft_rate_force_shaft(a, m) == Some(own))
        .filter_map(Param::main_of_effect)
        .collect()
}

/// The starts of a coupled trial ([`LoopOptions::coupled_forces`]): `t` as it is, then `t`
/// with every one of `coupled` scaled by each of [`coupled_scales`].
fn coupled_starts(t: &Machine, coupled: &[Param]) -> Vec<Machine> {
    let scaled = coupled_scales().into_iter().map(|s| {
        let mut u = t.clone();
        for p in coupled {
            if let Some(v) = p.get(t) {
                p.set(&mut u, v * s);
            }
        }
        u
    });
    std::iter::once(t.clone()).chain(scaled).collect()
}

/// Of several fits of one trial, the one with the lowest objective (the first among equals);
/// the first error when none succeeded.
fn lowest_outcome(fits: Vec<TrialOutcome>) -> TrialOutcome {
    let mut best: Option<TrialOutcome> = None;
    for f in fits {
        best = match (best, f) {
            (None, f) => Some(f),
            (Some(Ok(b)), Ok(f)) => Some(Ok(if f.0.objective_after < b.0.objective_after { f } else { b })),
            (Some(Err(_)), Ok(f)) => Some(Ok(f)),
            (Some(b), Err(_)) => Some(b),
        };
    }
    best.unwrap_or_else(|| Err("no start to fit from".into()))
}

/// The calibrated start of a diagnosis of one machine, with one number of realisations: the
/// calibrated machine and its fit, its comparison with the measurement, the seed floor and
/// the objective's scatter; and, once a search has made them, its plain stage-1 trials (from
/// the calibrated model; a recalibrating trial's from the uncalibrated values), which an
/// unbent search of the same machine would make again to the same values.
struct CalibratedRound {
    realisations: usize,
    machine: Machine,
    fit: Fit,
    comparison: Comparison,
    floor: (f64, Vec<(String, f64)>),
    scatter: f64,
    plain_trials: Option<Vec<(EffectKind, TrialOutcome)>>,
}

/// One diagnosis with `opts.realisations` realisations (see [`diagnose_with`]); `unbend`
/// starts every trial from the uncalibrated values too, whether or not the calibration pins
/// anything. The calibrated start is taken from `calibrated` when it holds one with as many
/// realisations (of the same machine `m`, made by an earlier call), else made and added.
fn diagnose_once(m: &Machine, reference: &Reference, opts: &LoopOptions, unbend: bool, calibrated: &mut Vec<CalibratedRound>, progress: &LoopProgress) -> Result<(Machine, Diagnosis), LoopError> {
    opts.validate()?;
    let measured = reference;
    let cal_params = calibration_parameters_for(m, opts);
    let candidates: Vec<EffectKind> = EffectKind::ALL.into_iter().filter(|k| !m.effects.is_on(*k) && Effects::applicable(*k, m) && (opts.candidates.is_empty() || opts.candidates.contains(k))).collect();
    let known = calibrated.iter().position(|c| c.realisations == opts.realisations);
    let cached_plain: Option<Vec<(EffectKind, TrialOutcome)>> = known.and_then(|i| calibrated[i].plain_trials.clone());
    progress.expect(
        if known.is_some() { 0 } else { calibration_evaluations(m, opts) }
            + candidates
            .iter()
            .filter(|_| cached_plain.is_none())
            .map(|k| plain_trial_evaluations(m, *k, opts))
            .sum::<usize>()
            + opts.recalibrate_top.min(candidates.len()) * fit_trial_evaluations(m, &[], &cal_params, opts)
            + candidates.len()
            + if opts.realisations >= 2 { 1 + candidates.len() } else { 0 },
    );
    let start_index = match known {
        Some(i) => i,
        None => {
            let (machine, fit) = calibrate_round(m, measured, &cal_params, opts, progress)?;
            let (comparison, _) = evaluate(&machine, measured, opts)?;
            progress.tick();
            let floor = seed_floor(&machine, measured.measured(), &comparison, opts)?;
            for _ in FLOOR_SEEDS {
                progress.tick();
            }
            let scatter = objective_scatter(&machine, measured, objective(&comparison, &opts.weights), opts)?;
            for _ in SCATTER_SEEDS {
                progress.tick();
            }
            calibrated.push(CalibratedRound { realisations: opts.realisations, machine, fit, comparison, floor, scatter, plain_trials: None });
            calibrated.len() - 1
        }
    };
    let start = &calibrated[start_index];
    let (cal_m, cal, comparison) = (start.machine.clone(), start.fit.clone(), start.comparison.clone());
    let c = &comparison;
    let ((floor, floor_domains), scatter) = (start.floor.clone(), start.scatter);
    // A calibration that pinned a parameter may have bent it to stand in for the missing
    // effect; with `unbend_pinned` every trial then starts from the uncalibrated values.
    let unbent = unbend || (opts.unbend_pinned && !cal.at_bound.is_empty());
    // The start of a trial that re-does the calibration with its effect (the casing trial
    // always; every trial when unbent): the round's uncalibrated machine with the effect on,
    // its main parameter scanned on a grid.
    let unbent_start = |k: EffectKind| -> (Machine, Vec<Param>, Vec<Param>) {
        let (t, scan) = uncalibrated_start_of(m, k);
        let ps = recalibration_parameters(k, m, opts);
        (t, ps, scan)
    };
    // The second start of every plain trial: unbending's (with a calibration sweep), or the
    // lighter one of `uncalibrated_start`, which unbending supersedes.
    let scanned_start = opts.uncalibrated_start && !unbent;
    // An unbent second start is polished only with `polish_second_starts`: its plain trial
    // starts from the (polished) calibration, so the trial keeps a polished start either way.
    let second_start_opts = LoopOptions { polish_sweeps: if opts.polish_second_starts { opts.polish_sweeps } else { 0 }, ..opts.clone() };
    // With `roll_off_two_starts`, the roll-off's trial has unbending's two starts in any search.
    let two_starts = |k: EffectKind| opts.roll_off_two_starts && k == EffectKind::SensorResponse && !recalibrates(k, opts);
    // The options of a trial's start from the uncalibrated values with a calibration sweep:
    // unbending's (polished only with `polish_second_starts`), or for the roll-off with two
    // starts the polished one `recalibrate_roll_off` makes. The count and the fit both use it.
    let recalibrating_start_opts = |k: EffectKind| if two_starts(k) { opts } else { &second_start_opts };
    let extra: usize = candidates
        .iter()
        .filter(|k| !recalibrates(**k, opts))
        .map(|&k| {
            if unbent || two_starts(k) {
                let (t, ps, scan) = unbent_start(k);
                fit_evaluations(&t, &ps, &scan, 1, recalibrating_start_opts(k))
            } else if scanned_start {
                scanned_start_evaluations(m, k, opts)
            } else {
                0
            }
        })
        .sum();
    progress.expect(extra);
    let (fams, shaft) = machine_families(&cal_m);
    let map = residual_map(c, &fams, shaft);
    let j0 = objective(c, &opts.weights);
    let env0 = c.envelope_nrmse();
    let excess = j0 - floor;
    // Builds the reported trial from a fitted machine and its comparison numbers.
    let make_trial = |k: EffectKind, fm: &Machine, f: &Fit, released: &[Param]| {
        let j = f.objective_after;
        let env = f.envelope_nrmse_after;
        let after = |d: &str| f.domains.iter().find(|x| x.0 == d).map(|x| x.2).unwrap_or(f64::NAN);
        let domains = c.domains.iter().map(|d| (d.domain.clone(), d.metrics.nrmse_percent, after(&d.domain))).collect();
        let main = trial_main_parameter(k, &cal_m);
        let parameter = main.and_then(|p| p.get(fm).map(|v| (p, v)));
        let extra: Vec<(Param, f64)> = trial_parameters(k, &cal_m).iter().chain(released.iter()).filter(|p| Some(**p) != main).filter_map(|p| p.get(fm).map(|v| (*p, v))).collect();
        let (outside_band, pinned) = parameter.map_or((false, None), |(p, v)| range_edge(p, v, fm));
        let (reduction, explained) = shares(j0, j, floor);
        let with_effect = companion(k, &cal_m);
        let (ev, ev_share) = trial_evidence(k, with_effect, &map, fm);
        let summary = trial_summary(&trial_label(k, with_effect), &ev, parameter, &extra, (env0, env), (j0, j));
        EffectTrial { effect: k, with_effect, parameter, extra_parameters: extra, objective_before: j0, objective_after: j, envelope_nrmse_before: env0, envelope_nrmse_after: env, domains, reduction, explained, evidence: ev, evidence_share: ev_share, tied_with_best: false, outside_band, pinned, summary, objective_without_effect: None, effect_explained: None, objective_fitted: None, from_uncalibrated: false, fine_cell_won: f.fine_cell_won.clone(), joint: false, each_effect_explained: None }
    };
    // The plain trial's fit of `k` from `t` (the effect's parameters, then the noise level
    // refined), each of `scan` first scanned on a grid; `reported` are the parameters besides
    // the effect's that the trial carries (see `from_uncalibrated_scanned`).
    let plain_fit = |k: EffectKind, t: Machine, scan: &[Param], reported: &[Param]| -> TrialOutcome {
        t.validate().map_err(|e| e.to_string())?;
        let (fm, f) = fit_trial_scanning(&t, measured, &trial_parameters(k, m), &TRIAL_REFINE, scan, opts, progress).map_err(|e| e.to_string())?;
        Ok((make_trial(k, &fm, &f, reported), fm))
    };
    // The second start of `uncalibrated_start` (and `uncalibrated_start_top`): from the
    // uncalibrated values, the effect's main parameter scanned, then the plain trial's fit (no
    // calibration sweep). The trial carries the calibration parameters at those values too,
    // so that applying it to the calibrated model ([`apply_trial`]) gives the machine it was
    // scored with.
    let from_uncalibrated_scanned = |k: EffectKind| -> TrialOutcome {
        let (t, _, scan) = unbent_start(k);
        plain_fit(k, t, &scan, &refined_and(&cal_params))
    };
    // Stage 1: every candidate, its own parameters fitted and the noise level re-fitted (a
    // transfer-path effect re-does the calibration with it, see [`recalibrates`]).
    let outcomes: Vec<(EffectKind, TrialOutcome, TrialOutcome)> = candidates
        .par_iter()
        .map(|&k| {
            // From the uncalibrated values, the effect scanned, then one calibration sweep
            // (with `fit_opts`' polish).
            let from_uncalibrated_with = |fit_opts: &LoopOptions| -> TrialOutcome {
                let (t, ps, scan) = unbent_start(k);
                t.validate().map_err(|e| e.to_string())?;
                let (fm, f) = fit_scanning(&t, measured, &ps, &scan, 1, fit_opts, progress).map_err(|e| e.to_string())?;
                let own = trial_parameters(k, m);
                let released: Vec<Param> = ps.into_iter().filter(|p| !own.contains(p)).collect();
                Ok((EffectTrial { from_uncalibrated: true, ..make_trial(k, &fm, &f, &released) }, fm))
            };
            // From the calibrated model, the effect fitted and the noise level re-fitted; with
            // `coupled_forces`, at each of the coupled starts, the lowest kept.
            let from_calibrated = || -> TrialOutcome {
                let coupled = if opts.coupled_forces { coupled_applied_forces(k, &cal_m) } else { Vec::new() };
                let scan = plain_trial_scan(k, opts);
                if coupled.is_empty() {
                    return plain_fit(k, switched_on(&cal_m, k), &scan, &TRIAL_REFINE);
                }
                let reported = refined_and(&coupled);
                let mut starts = coupled_starts(&switched_on(&cal_m, k), &coupled);
                // With `coupled_refined_starts`, each start's grid first, and only the most
                // promising starts fitted in full (their grids then come from the cache).
                if let (Some(n), Some(&force)) = (refined_coupled_starts(starts.len(), &scan, opts), scan.first()) {
                    let minima: Vec<f64> = starts.par_iter().map(|t| scan_minimum(t, measured, force, opts, progress)).collect();
                    let keep = lowest_indices(&minima, n);
                    starts = starts.into_iter().enumerate().filter(|(i, _)| keep.contains(i)).map(|(_, t)| t).collect();
                }
                let fits: Vec<TrialOutcome> = starts.into_par_iter().map(|t| plain_fit(k, t, &scan, &reported)).collect();
                lowest_outcome(fits)
            };
            // The plain trial: a recalibrating one from the uncalibrated values, any other from
            // the calibrated model; taken from an earlier search of this machine when it made
            // it (an unbent search after a plain one, see `diagnose_with`).
            let plain = || -> TrialOutcome {
                match cached_plain.as_ref().and_then(|v| v.iter().find(|(e, _)| *e == k)) {
                    Some((_, o)) => o.clone(),
                    None if recalibrates(k, opts) => from_uncalibrated_with(opts),
                    None => from_calibrated(),
                }
            };
            let (outcome, plain) = if recalibrates(k, opts) {
                let o = plain();
                (o.clone(), o)
            } else if unbent || two_starts(k) {
                // Both starts; the better fit is the trial (a start from the uncalibrated values
                // with one sweep can end worse than the bent calibration's).
                let (a, b) = rayon::join(plain, || from_uncalibrated_with(recalibrating_start_opts(k)));
                (better_start((a.clone(), b)), a)
            } else if scanned_start {
                let (a, b) = rayon::join(plain, || from_uncalibrated_scanned(k));
                (better_start((a.clone(), b)), a)
            } else {
                let o = plain();
                (o.clone(), o)
            };
            (k, outcome, plain)
        })
        .collect();
    let mut stage1: Vec<(EffectTrial, Machine)> = Vec::new();
    let mut failed_trials = Vec::new();
    let mut plain_trials = Vec::with_capacity(outcomes.len());
    for (k, o, p) in outcomes {
        plain_trials.push((k, p));
        match o {
            Ok(x) => stage1.push(x),
            Err(e) => failed_trials.push((k, e)),
        }
    }
    if calibrated[start_index].plain_trials.is_none() && !progress.is_cancelled() {
        calibrated[start_index].plain_trials = Some(plain_trials);
    }
    if progress.is_cancelled() {
        return Err(LoopError::Cancelled);
    }
    // Stage 2: the best `recalibrate_top` trials release every calibrated parameter (locally):
    // calibration without the effect may have bent the resonance or the fault depth to
    // imitate it, and the effect must be judged against a model free to un-bend them.
    stage1.sort_by(|a, b| a.0.objective_after.total_cmp(&b.0.objective_after));
    let n2 = opts.recalibrate_top.min(stage1.len());
    let rest = stage1.split_off(n2);
    let released = calibration_parameters_for(&cal_m, opts);
    // With `uncalibrated_start_top`, the best trials that started from the calibrated model
    // only also start from the uncalibrated values, and the better fit goes on to the re-fit.
    let top_second_start = |t: &EffectTrial| opts.uncalibrated_start_top && !unbent && !scanned_start && !recalibrates(t.effect, opts) && !two_starts(t.effect) && !t.from_uncalibrated;
    progress.expect(stage1.iter().filter(|(t, _)| top_second_start(t)).map(|(t, _)| scanned_start_evaluations(m, t.effect, opts)).sum());
    // With `refit_effect_in_stage2` the re-fit releases the effect's own parameters too, after
    // the calibrated ones (a second start carries the same effect, so the same count).
    let stage2_refine = |k: EffectKind| -> Vec<Param> {
        let effect = if opts.refit_effect_in_stage2 { trial_parameters(k, m) } else { Vec::new() };
        released.iter().copied().chain(effect.into_iter().filter(|p| !released.contains(p))).collect()
    };
    progress.expect(stage1.iter().map(|(t, fm)| fit_trial_evaluations(fm, &[], &stage2_refine(t.effect), opts) - fit_trial_evaluations(fm, &[], &released, opts)).sum());
    let stage2: Vec<((EffectTrial, Machine), bool)> = stage1
        .into_par_iter()
        .map(|(t1, fm)| {
            // As in `better_start`: the second start must fit strictly better to replace it.
            let ((t1, fm), won) = match top_second_start(&t1).then(|| from_uncalibrated_scanned(t1.effect)) {
                Some(Ok((b, bm))) if b.objective_after < t1.objective_after => ((EffectTrial { from_uncalibrated: true, ..b }, bm), true),
                _ => ((t1, fm), false),
            };
            let refitted = match fit_trial(&fm, measured, &[], &stage2_refine(t1.effect), opts, progress) {
                Ok((fm2, f2)) if f2.objective_after < t1.objective_after => {
                    // The re-fit is local (no force grid), and starts where `t1`'s fit ended:
                    // a fine-cell win there is this trial's too.
                    let mut fine_cell_won = t1.fine_cell_won.clone();
                    add_missing(&mut fine_cell_won, &f2.fine_cell_won);
                    // The re-fit carries what the first fit carried as well (a coupled trial's
                    // applied force, at the start it was fitted from), or applying the trial would
                    // leave that force where the model had it.
                    let mut carried = refined_and(&released);
                    let own = trial_parameters(t1.effect, m);
                    add_missing(&mut carried, &t1.extra_parameters.iter().map(|x| x.0).filter(|p| !own.contains(p)).collect::<Vec<_>>());
                    (EffectTrial { from_uncalibrated: t1.from_uncalibrated, fine_cell_won, ..make_trial(t1.effect, &fm2, &f2, &carried) }, fm2)
                }
                _ => (t1, fm),
            };
            (refitted, won)
        })
        .collect();
    let top_second_starts_won: Vec<EffectKind> = stage2.iter().filter(|(_, won)| *won).map(|((t, _), _)| t.effect).collect();
    let stage2: Vec<(EffectTrial, Machine)> = stage2.into_iter().map(|(x, _)| x).collect();
    let fine_cell_won: Vec<EffectKind> = stage2.iter().chain(rest.iter()).filter(|(t, _)| !t.fine_cell_won.is_empty()).map(|(t, _)| t.effect).collect();
    if progress.is_cancelled() {
        return Err(LoopError::Cancelled);
    }
    // With several realisations the trials are judged on realisations no fit has seen: the
    // calibrated model and every fitted machine are evaluated once more under
    // [`HELD_OUT_SALT`], and the decision, the shares and the ablation use those numbers.
    // Fitting a random effect against the debiased objective otherwise finds the values
    // where the subtracted scatter of its own realisations happens to be large (an
    // optimiser's curse: docs/loop-notebook.md "Detection limits").
    let held_out = if opts.realisations >= 2 {
        let (ch, _) = evaluate(&reseeded(&cal_m, HELD_OUT_SALT), measured, opts)?;
        progress.tick();
        Some(ch)
    } else {
        None
    };
    let (j0, excess) = match &held_out {
        Some(ch) => {
            let j = objective(ch, &opts.weights);
            (j, j - floor)
        }
        None => (j0, excess),
    };
    // Ablation: each fitted machine once more without its effect (on the held-out
    // realisations when the trials are judged on them).
    let trials: Vec<Result<EffectTrial, (EffectKind, String)>> = stage2
        .into_par_iter()
        .chain(rest)
        .map(|(mut t, fm)| {
            let judged = if held_out.is_some() { reseeded(&fm, HELD_OUT_SALT) } else { fm };
            if let Some(ch) = &held_out {
                let ct = evaluate(&judged, measured, opts);
                progress.tick();
                let (ct, _) = ct.map_err(|e| (t.effect, format!("its fitted model could not be evaluated on the held-out realisations: {e}")))?;
                rejudge(&mut t, ch, &ct, floor, &opts.weights);
            }
            let off = switched_off(judged, &t);
            t.objective_without_effect = evaluate(&off, measured, opts).ok().map(|(c, _)| objective(&c, &opts.weights));
            progress.tick();
            t.effect_explained = t.objective_without_effect.filter(|_| excess > 0.0).map(|j| (j - t.objective_after) / excess);
            Ok(t)
        })
        .collect();
    let mut judged_trials = Vec::with_capacity(trials.len());
    for t in trials {
        match t {
            Ok(t) => judged_trials.push(t),
            Err(failed) => failed_trials.push(failed),
        }
    }
    let trials = judged_trials;
    if progress.is_cancelled() {
        return Err(LoopError::Cancelled);
    }
    let held_out_objective = held_out.as_ref().map(|_| j0);
    let (trials, best, verdict) = decide(trials, j0, floor, scatter, opts);
    let near_floor_lead = named_lead(&trials, j0, floor, scatter, opts);
    let domains = c.domains.iter().map(|d| (d.domain.clone(), d.metrics.pearson, d.metrics.nrmse_percent)).collect();
    Ok((cal_m, Diagnosis { calibration: cal, domains, residual_map: map, floor_objective: floor, floor_domains, floor_ratio_needed: if opts.decision_rule == DecisionRule::FloorMargin { floor_ratio_needed(opts) } else { 0.0 }, objective_scatter: scatter, trials, best, verdict, failed_trials, unbent, path_correction: c.path_correction.clone(), held_out_objective, second_look: None, stuck_plain_verdict: None, short_plain: None, top_second_starts_won, fine_cell_won, strength_range: None, near_floor_lead, joint_trials: Vec::new(), removals: Vec::new(), compared_at_hz: measured.measured().fs_hz, measured_resampled_from_hz: super::resampled_from_hz(measured.measured()), silent_model: None }))
}

/// The parameters the plain trial of `k` (from the calibrated model) scans on a grid before
/// its line search: a periodic force's amplitude with
/// [`LoopOptions::scan_force_amplitudes`], else none.
fn plain_trial_scan(k: EffectKind, opts: &LoopOptions) -> Vec<Param> {
    Param::main_of_effect(k).filter(|p| opts.scan_force_amplitudes && p.periodic_force_amplitude()).into_iter().collect()
}

/// [`TRIAL_REFINE`] and then each of `others` not already in it: the parameters besides the
/// effect's own that a trial carries.
fn refined_and(others: &[Param]) -> Vec<Param> {
    TRIAL_REFINE.iter().chain(others.iter().filter(|p| !TRIAL_REFINE.contains(p))).copied().collect()
}

/// A stage-1 trial and its fitted machine, or why it could not be run.
type TrialOutcome = Result<(EffectTrial, Machine), String>;

/// Of a trial fitted from the calibrated model (`a`) and from the uncalibrated values (`b`),
/// the one with the lower objective (marked [`EffectTrial::from_uncalibrated`] when it is
/// `b`); either when the other failed.
fn better_start((a, b): (TrialOutcome, TrialOutcome)) -> TrialOutcome {
    lowest_outcome(vec![a, b.map(|(t, m)| (EffectTrial { from_uncalibrated: true, ..t }, m))])
}

/// Seed salt of the held-out realisations on which, with two or more realisations, the
/// calibrated model and every trial are judged ([`Diagnosis::held_out_objective`]). With the
/// realisations' own salts (`REALISATION_SALT + k` in [`evaluate`]) in the low bits, none of
/// the held-out seeds is one a fit used.
pub const HELD_OUT_SALT: u64 = 0x4E1D_0000_0000;

/// A trial's relative reduction of the objective, `(j0 − j) / j0`, and the share of the error
/// above the floor it explains, `(j0 − j) / (j0 − floor)` (0 where the denominator is not
/// positive).
pub(super) fn shares(j0: f64, j: f64, floor: f64) -> (f64, f64) {
    let reduction = if j0 > 0.0 { (j0 - j) / j0 } else { 0.0 };
    let explained = if j0 - floor > 0.0 { (j0 - j) / (j0 - floor) } else { 0.0 };
    (reduction, explained)
}

/// The sentence of a trial: its evidence, the fitted values, and envelope NRMSE and objective
/// before → after.
pub(super) fn trial_summary(name: &str, evidence: &str, parameter: Option<(Param, f64)>, extra: &[(Param, f64)], env: (f64, f64), j: (f64, f64)) -> String {
    let pv = parameter.iter().chain(extra.iter()).map(|(p, v)| format!("{} = {:.4e}", p.name(), v)).collect::<Vec<_>>().join(", ");
    let pv = if pv.is_empty() { String::new() } else { format!(" ({pv})") };
    format!("{evidence}; adding {}{pv} changes envelope NRMSE from {:.1} % to {:.1} % (objective {:.1} → {:.1})", name, env.0, env.1, j.0, j.1)
}

/// Re-states a fitted trial on held-out realisations: `before` is the calibrated model's
/// held-out comparison, `after` the trial's fitted machine's. The fit's own objective is kept
/// in [`EffectTrial::objective_fitted`]; the objectives, envelope NRMSE, per-domain NRMSE, the
/// reduction, the explained share (against `floor`) and the summary become the held-out
/// ones. The ablation is the caller's.
pub(super) fn rejudge(t: &mut EffectTrial, before: &Comparison, after: &Comparison, floor: f64, weights: &[f64; 3]) {
    let (j0, j) = (objective(before, weights), objective(after, weights));
    let (env0, env) = (before.envelope_nrmse(), after.envelope_nrmse());
    t.objective_fitted = Some(t.objective_after);
    t.objective_before = j0;
    t.objective_after = j;
    t.envelope_nrmse_before = env0;
    t.envelope_nrmse_after = env;
    t.domains = before.domains.iter().map(|d| (d.domain.clone(), d.metrics.nrmse_percent, after.domain(&d.domain).map_or(f64::NAN, |x| x.metrics.nrmse_percent))).collect();
    (t.reduction, t.explained) = shares(j0, j, floor);
    t.summary = trial_summary(&t.label(), &t.evidence, t.parameter, &t.extra_parameters, (env0, env), (j0, j));
}

/// Whether the trial of `k` re-does the calibration with the effect on instead of starting
/// from the calibrated model. A casing mode reshapes the transfer path — the spectrum the
/// resonance, damping and fault depth were calibrated on — so calibration without it bends
/// them to imitate the mode (on a hidden 3.2 kHz mode: the resonance 13 % low, the fault depth
/// at its lower bound), and a mode added to that bent model only makes it worse. Its trial
/// therefore starts from the model's own values and fits the mode frequency (grid scan, then
/// golden section), then every calibration parameter over its full range (one sweep). (The
/// sensor roll-off, fitted the same way, found a hidden 811 Hz roll-off better but cost a
/// seen pair its casing find: docs/loop-notebook.md "Moved from the README (session 47)";
/// with [`LoopOptions::recalibrate_roll_off`] it is, experimental since session 57.)
pub fn recalibrates(k: EffectKind, opts: &LoopOptions) -> bool {
    k == EffectKind::CasingModes || (k == EffectKind::SensorResponse && opts.recalibrate_roll_off)
}

/// The parameters a re-calibrating trial of `k` on `m` (without `k`) fits, in order: the
/// trial's ([`trial_parameters`]), then the calibration's of the machine with the trial's
/// effects on.
pub fn recalibration_parameters(k: EffectKind, m: &Machine, opts: &LoopOptions) -> Vec<Param> {
    let mut ps = trial_parameters(k, m);
    for p in calibration_parameters_for(&switched_on(m, k), opts) {
        if !ps.contains(&p) {
            ps.push(p);
        }
    }
    ps
}

/// Applies a trial to `m` the way the loop does: switches the effect on, sets every fitted
/// parameter (the main one, the extra ones and the re-fitted noise level) to its trial value,
/// and, for `path_modulation`, sets the modulation rate to the shaft speed as the trial did.
/// `m` should be the calibrated machine the trial was run on (the first value [`diagnose`]
/// returns).
pub fn apply_trial(m: &mut Machine, t: &EffectTrial) {
    if let Some(c) = t.with_effect {
        m.effects.enable(c);
    }
    m.effects.enable(t.effect);
    for (p, v) in t.parameter.iter().chain(t.extra_parameters.iter()) {
        p.set(m, *v);
    }
    if t.effect == EffectKind::PathModulation {
        set_path_modulation_to_shaft_rate(m);
    }
}

/// A physical default for the unknown rate of a path modulation just switched on: the shaft
/// speed. Does nothing if the machine has no path modulation on.
fn set_path_modulation_to_shaft_rate(m: &mut Machine) {
    let (_, shaft) = machine_families(m);
    if let (Some(pm), Some(fr)) = (m.effects.path_modulation.as_mut(), shaft) {
        pm.frequency_hz = fr;
    }
}

/// One round of the loop.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Round {
    /// Round number (1-based).
    pub round: usize,
    /// Effects on at the start of the round.
    pub effects_on: Vec<EffectKind>,
    /// Metrics of the calibrated model: (domain, Pearson, NRMSE %).
    pub domains: Vec<(String, f64, f64)>,
    /// Envelope NRMSE after calibration, %.
    pub envelope_nrmse: f64,
    /// Objective after calibration: [`Diagnosis::judged_objective`], on held-out realisations
    /// when the round's trials were judged on them.
    pub objective: f64,
    /// The seed floor of that objective (see [`seed_floor`]): objective / floor says whether
    /// anything is left to explain. 0 when not computed (a desktop-app round recorded from a
    /// trial's fit rather than a diagnosis).
    #[serde(default)]
    pub floor_objective: f64,
    /// The objective / floor ratio the round's decision needed to see something to explain
    /// ([`Diagnosis::floor_ratio_needed`]); 0 when not recorded.
    #[serde(default)]
    pub floor_ratio_needed: f64,
    /// The seed scatter σ of that objective (see [`objective_scatter`]), which sizes the tie band
    /// and the improvement test of the round's decision. 0 when not computed.
    #[serde(default)]
    pub objective_scatter: f64,
    /// The verdict.
    pub verdict: String,
    /// The round's ranking, best first: each trial's effect, its objective after the trial and
    /// the share of the error above the floor it explains. Empty when not computed.
    #[serde(default)]
    pub ranking: Vec<(EffectKind, f64, f64)>,
    /// For each trial of `ranking` (same order), the share of the error above the floor that
    /// switching its effect off again costs ([`EffectTrial::effect_explained`]); NaN where not
    /// evaluated.
    #[serde(default)]
    pub ranking_effect_explained: Vec<f64>,
    /// The effect applied at the end of the round.
    pub applied: Option<EffectKind>,
    /// The effect switched on with `applied`, which it acts through
    /// ([`EffectTrial::with_effect`]: a load zone with a contact nonlinearity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub applied_with: Option<EffectKind>,
    /// `applied` and `applied_with` came from a joint trial ([`EffectTrial::joint`]): two
    /// effects each with a trial of its own, not one acting through the other.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub applied_jointly: bool,
    /// The effect taken out at the end of the round, when the loop replaced an applied effect
    /// (see [`run_loop`]); `applied` is then the one put in its place. Both are the same effect
    /// when the loop re-fitted it from the uncalibrated values instead ([`Round::refitted`]).
    #[serde(default)]
    pub removed: Option<EffectKind>,
    /// The applied effect's parameters as they went into the model (see
    /// [`Param::of_effect`]; then those of `applied_with`): the trial's fit, or for a replacement the calibration's fit. The
    /// rounds after re-fit them; the final values are in the last round's calibration.
    #[serde(default)]
    pub applied_values: Vec<(Param, f64)>,
    /// Parameters the round's calibration pinned at the edge of their range (see
    /// [`Fit::at_bound`]); the round's trials then also started from the uncalibrated values
    /// when unbending is on ([`Diagnosis::unbent`]).
    #[serde(default)]
    pub pinned: Vec<Param>,
    /// Whether the round's search was stuck with its trials from the calibrated model and was
    /// searched again unbent (`LoopOptions::unbend_when_stuck`,
    /// [`Diagnosis::stuck_plain_verdict`]).
    #[serde(default)]
    pub unbent_when_stuck: bool,
    /// Whether the round's search was short with its trials from the calibrated model and was
    /// searched again unbent (`LoopOptions::unbend_when_short`, [`Diagnosis::short_plain`]).
    #[serde(default)]
    pub unbent_when_short: bool,
    /// With `LoopOptions::uncalibrated_start_top`: the effects whose second start won in the
    /// round's diagnosis ([`Diagnosis::top_second_starts_won`]) or in a search of a candidate
    /// replacement the stuck round tried. Empty: the round is the one it would have been
    /// without the option.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub top_second_starts_won: Vec<EffectKind>,
    /// With `LoopOptions::strength_range`: the range of the strength of the effect the round's
    /// diagnosis chose ([`Diagnosis::strength_range`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strength_range: Option<super::strength_range::StrengthRange>,
    /// With `LoopOptions::removal_trials`: the part of the model the round took out, its
    /// removal trial contradicted by the measurement ([`super::removal::most_contradicted`]);
    /// the next round starts from the round's machine without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taken_out: Option<super::removal::TakenOut>,
    /// With [`LoopOptions::take_out_first`]: the addition the round's search chose and did not
    /// apply, because the round took out a part the measurement contradicts first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub set_aside: Option<EffectKind>,
    /// With `LoopOptions::removal_trials`: the removal trials of the round's model
    /// ([`Diagnosis::removals`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub removals: Vec<super::removal::RemovalTrial>,
}

impl Round {
    /// Adds the effects whose top second start won in `d`, a search the round made besides its
    /// own diagnosis ([`Round::top_second_starts_won`]).
    fn note_second_starts_won(&mut self, d: &Diagnosis) {
        add_missing(&mut self.top_second_starts_won, &d.top_second_starts_won);
    }

    /// Whether the round re-fitted an applied effect in place (`removed == applied`,
    /// [`LoopOptions::refit_when_stuck`]) rather than replacing it.
    pub fn refitted(&self) -> bool {
        self.removed.is_some() && self.removed == self.applied
    }

    /// The round of a diagnosis of the model with `effects_on`: its calibrated metrics, floor,
    /// scatter, verdict, ranking and pinned parameters; nothing applied yet. `envelope_nrmse` is
    /// the caller's reading of the calibrated envelope NRMSE (what to show when it is missing
    /// differs between the loop and the app).
    pub fn of_diagnosis(round: usize, effects_on: Vec<EffectKind>, d: &Diagnosis, envelope_nrmse: f64) -> Round {
        Round {
            round,
            effects_on,
            domains: d.domains.clone(),
            envelope_nrmse,
            objective: d.judged_objective(),
            floor_objective: d.floor_objective,
            floor_ratio_needed: d.floor_ratio_needed,
            objective_scatter: d.objective_scatter,
            verdict: d.verdict.clone(),
            ranking: ranking_of(d),
            ranking_effect_explained: d.trials.iter().map(|t| t.effect_explained.unwrap_or(f64::NAN)).collect(),
            pinned: d.calibration.pinned(),
            unbent_when_stuck: d.stuck_plain_verdict.is_some(),
            unbent_when_short: d.short_plain.is_some(),
            top_second_starts_won: d.top_second_starts_won.clone(),
            strength_range: d.strength_range.clone(),
            removals: d.removals.clone(),
            ..Default::default()
        }
    }

    /// What the round changed, in words: the effect applied, `"b in place of a"` for a
    /// replacement, or `none` when nothing was applied.
    pub fn change(&self, none: &str) -> String {
        match (self.applied, self.removed) {
            (Some(b), Some(a)) if a == b => format!("{} {REFITTED}", b.name()),
            (Some(b), Some(a)) => format!("{} in place of {}", b.name(), a.name()),
            (Some(_), None) => self.applied_label().unwrap_or_default(),
            _ => self.taken_out_text().unwrap_or_else(|| none.to_string()),
        }
    }

    /// `took out casing_modes`, with `before adding misalignment` when the round set an
    /// addition aside ([`Round::set_aside`]); None when the round took nothing out.
    fn taken_out_text(&self) -> Option<String> {
        let t = self.taken_out.as_ref()?;
        Some(match self.set_aside {
            Some(k) => format!("took out {} before adding {}", t.label, k.name()),
            None => format!("took out {}", t.label),
        })
    }

    /// The applied trial's name ([`EffectTrial::label`]): `a with c` for an effect applied
    /// with the one it acts through, `a + b` for a joint trial; None when nothing was applied.
    pub fn applied_label(&self) -> Option<String> {
        let b = self.applied?;
        Some(match (self.applied_jointly, self.applied_with) {
            (true, Some(c)) => trial_label_joint(b, c),
            _ => trial_label(b, self.applied_with),
        })
    }

    /// [`change`](Self::change) with the applied effect's values, e.g.
    /// `casing_modes (frequency_hz = 3.37e3) in place of sensor_response`.
    pub fn change_with_values(&self, none: &str) -> String {
        let Some(b) = self.applied else {
            return self.taken_out_text().unwrap_or_else(|| none.to_string());
        };
        let values = effect_values_text(&self.applied_values);
        let name = self.applied_label().unwrap_or_default();
        let added = if values.is_empty() { name } else { format!("{name} ({values})") };
        match self.removed {
            Some(a) if a == b => format!("{added} {REFITTED}"),
            Some(a) => format!("{added} in place of {}", a.name()),
            None => added,
        }
    }
}

/// The values of an effect's parameters in a machine, in [`Param::of_effect`] order.
pub fn effect_values(m: &Machine, k: EffectKind) -> Vec<(Param, f64)> {
    Param::of_effect(k).into_iter().filter_map(|p| p.get(m).map(|v| (p, v))).collect()
}

/// [`effect_values`] of an applied effect `k`, then of the effect applied with it
/// ([`Round::applied_with`]).
pub fn applied_values(m: &Machine, k: EffectKind, with_effect: Option<EffectKind>) -> Vec<(Param, f64)> {
    std::iter::once(k).chain(with_effect).flat_map(|e| effect_values(m, e)).collect()
}

/// `name = value, ...` with the last part of each parameter's path, 4 significant digits.
pub fn effect_values_text(values: &[(Param, f64)]) -> String {
    values.iter().map(|(p, v)| format!("{} = {v:.3e}", p.name().rsplit('.').next().unwrap_or(""))).collect::<Vec<_>>().join(", ")
}

/// Whether effect `k`, as fitted in `m`, is no finding by the rule for trials ([`range_edge`]:
/// its feature at the edge of the band, or its strength pinned at an edge of its range): the
/// note to print, or None when it is a finding. The loop keeps no replacement whose added
/// effect the calibration fitted so ([`run_loop`]); a runner-up's trial is not checked, since
/// the swapped model's calibration fits the effect again and may place it well where the
/// trial did not.
pub fn fitted_not_a_finding(k: EffectKind, m: &Machine) -> Option<&'static str> {
    let p = Param::main_of_effect(k)?;
    let v = p.get(m)?;
    match range_edge(p, v, m) {
        (true, _) => Some(OUTSIDE_BAND_NOTE),
        (false, Some((lo, hi))) => Some(pinned_note_at(in_upper_half(v, lo, hi))),
        (false, None) => None,
    }
}

/// A diagnosis's ranking as kept in a [`Round`]: (effect, objective after, explained share).
pub fn ranking_of(d: &Diagnosis) -> Vec<(EffectKind, f64, f64)> {
    d.trials.iter().map(|t| (t.effect, t.objective_after, t.explained)).collect()
}

/// Replacements tried when the loop is stuck (see [`run_loop`]).
pub const REPLACEMENT_TRIALS: usize = 2;

/// Whether a round that found nothing to add is stuck: its objective is still above
/// `(1 + floor_margin) ×` its seed floor, so something is missing that no single addition
/// finds.
fn stuck(d: &Diagnosis, opts: &LoopOptions) -> bool {
    d.best.is_none() && above_floor_of(d, d.judged_objective(), opts)
}

/// Whether objective `j` is at or above `d`'s seed floor times the floor margin's ratio
/// ([`above_floor`]); false without a floor. A second look's floor is of several
/// realisations, with the ratio that goes with them.
fn above_floor_of(d: &Diagnosis, j: f64, opts: &LoopOptions) -> bool {
    d.floor_objective > 0.0 && above_floor(j, d.floor_objective, &judged_options(d, opts))
}

/// The options `d` was judged with: `opts`, with a second look's realisations when `d` is one.
fn judged_options(d: &Diagnosis, opts: &LoopOptions) -> LoopOptions {
    match &d.second_look {
        Some(s) => LoopOptions { realisations: s.realisations, ..opts.clone() },
        None => opts.clone(),
    }
}

/// The replacements worth trying when the loop is stuck, best first, at most
/// [`REPLACEMENT_TRIALS`]: (applied effect `a`, effect `b` to put in its place), where `b` was
/// a runner-up in the round that applied `a` — it explained at least `significance` of the
/// error there — and is neither on nor taken out before. Ranked by how close `b` came to `a`
/// in that round (explained share of `b` / share of `a`).
pub fn replacement_candidates(history: &[Round], current: &Machine, opts: &LoopOptions) -> Vec<(EffectKind, EffectKind)> {
    let removed: Vec<EffectKind> = history.iter().filter(|r| !r.refitted()).filter_map(|r| r.removed).collect();
    let mut pairs: Vec<(f64, EffectKind, EffectKind)> = Vec::new();
    for r in history {
        let Some(a) = r.applied else { continue };
        // An effect applied with the one it acts through is not swapped alone.
        if r.refitted() || r.applied_with.is_some() {
            continue;
        }
        if !current.effects.is_on(a) {
            continue;
        }
        let share_a = r.ranking.iter().find(|x| x.0 == a).map(|x| x.2).unwrap_or(0.0).max(1e-9);
        for &(b, _, share_b) in &r.ranking {
            if b == a || current.effects.is_on(b) || removed.contains(&b) || share_b < opts.significance || pairs.iter().any(|p| p.1 == a && p.2 == b) {
                continue;
            }
            pairs.push((share_b / share_a, a, b));
        }
    }
    pairs.sort_by(|x, y| y.0.total_cmp(&x.0));
    pairs.into_iter().take(REPLACEMENT_TRIALS).map(|p| (p.1, p.2)).collect()
}

/// The replacements to offer after diagnosis `d` of `current` (see [`run_loop`]): when `d` is
/// stuck (nothing significant to add, objective still ≥ `(1 + floor_margin) ×` its floor),
/// [`replacement_candidates`] of the history; otherwise none. The desktop app offers these.
pub fn replacement_proposals(history: &[Round], current: &Machine, d: &Diagnosis, opts: &LoopOptions) -> Vec<(EffectKind, EffectKind)> {
    if stuck(d, opts) {
        replacement_candidates(history, current, opts)
    } else {
        Vec::new()
    }
}

/// The applied effects to offer for a re-fit from the uncalibrated values after diagnosis `d`
/// of `current` ([`refit_from_uncalibrated`]): when `d` is stuck, [`refit_candidates`] of the
/// history; otherwise none. The desktop app offers these beside the replacements.
pub fn refit_proposals(history: &[Round], current: &Machine, d: &Diagnosis, opts: &LoopOptions) -> Vec<EffectKind> {
    if stuck(d, opts) {
        refit_candidates(history, current)
    } else {
        Vec::new()
    }
}

/// `m` with effect `a` switched off and `b` on (with its default parameters, a path
/// modulation at the shaft rate), validated: the model a replacement starts from.
pub fn swap_effect(m: &Machine, a: EffectKind, b: EffectKind) -> Result<Machine, crate::model::ModelError> {
    let mut swapped = m.clone();
    swapped.effects.disable(a);
    swapped.effects.enable(b);
    if b == EffectKind::PathModulation {
        set_path_modulation_to_shaft_rate(&mut swapped);
    }
    swapped.validate()?;
    Ok(swapped)
}

/// Takes `out` from the effects a search of `m` may try: the effects a replacement took out
/// are not tried again ([`run_loop`]; the desktop app does the same). An empty candidate list
/// (every applicable effect) becomes the explicit list without them.
pub fn exclude_candidates(opts: &mut LoopOptions, m: &Machine, out: &[EffectKind]) {
    if out.is_empty() {
        return;
    }
    if opts.candidates.is_empty() {
        opts.candidates = EffectKind::ALL.into_iter().filter(|k| Effects::applicable(*k, m)).collect();
    }
    opts.candidates.retain(|k| !out.contains(k));
}

/// The effects a loop's history leaves applied, in the order applied: every round's `applied`
/// less those a later round `removed` or took out ([`Round::taken_out`]).
pub fn applied_effects(history: &[Round]) -> Vec<EffectKind> {
    let mut on: Vec<EffectKind> = Vec::new();
    for r in history {
        if let Some(k) = r.removed {
            on.retain(|x| *x != k);
        }
        // An effect a removal trial took out goes with those acting through it.
        if let Some(super::removal::TakenOut { part: super::removal::ModelPart::Effect(k), .. }) = &r.taken_out {
            on.retain(|x| x != k && x.acts_through() != Some(*k));
        }
        if let Some(k) = r.applied {
            on.push(k);
        }
        if let Some(c) = r.applied_with {
            on.push(c);
        }
    }
    on
}

/// The effects a loop going on from this loop's final machine re-fits
/// ([`LoopOptions::refit_effects`]): those this loop was told to re-fit (`given`) and those it
/// applied ([`applied_effects`]), once each, less any without a parameter to fit (a contact
/// nonlinearity, applied with the load zone it acts through).
pub fn refit_to_go_on(history: &[Round], given: &[EffectKind]) -> Vec<EffectKind> {
    let mut v: Vec<EffectKind> = Vec::new();
    for k in given.iter().copied().chain(applied_effects(history)) {
        if !v.contains(&k) && !Param::of_effect(k).is_empty() {
            v.push(k);
        }
    }
    v
}

/// The command that goes on from a machine a loop saved: `twinscope diagnose MEASURED
/// --machine MACHINE`, then `args` (how the measurement was read and compared: its channel,
/// its envelope band); every word quoted when it holds a space or a character the shell reads,
/// to be copied. What the loop fitted goes with the machine ([`Machine::fitted_effects`]), so
/// no `--refit` is needed.
pub fn go_on_command(measured: &std::path::Path, machine: &std::path::Path, args: &[String]) -> String {
    let word = |s: &str| shlex::try_quote(s).map_or_else(|_| s.to_string(), |q| q.into_owned());
    let mut line = format!("twinscope diagnose {} --machine {}", word(&measured.to_string_lossy()), word(&machine.to_string_lossy()));
    for a in args {
        line += &format!(" {}", word(a));
    }
    line
}

/// The lowest objective a model reaches with at most one more effect: its calibrated
/// objective `j_cal`, or its best trial's, whether that trial was significant or not. A stuck
/// model and a replacement are compared on this, so both get the same one addition (counting
/// it only where it was significant would give the replacement an effect the stuck model is
/// denied).
pub fn reachable_objective(j_cal: f64, trials: &[EffectTrial]) -> f64 {
    trials.iter().map(|t| t.objective_after).fold(j_cal, f64::min)
}

/// The judgement of one replacement ([`run_loop`]; the desktop app's by-hand replacement
/// uses the same): `added` in place of `removed`, whose model's calibration gave `cal2` and
/// whose diagnosis gave `d2`, against the stuck diagnosis it would replace.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplacementJudgement {
    /// The applied effect taken out.
    pub removed: EffectKind,
    /// The runner-up put in its place.
    pub added: EffectKind,
    /// What the replacement reaches with its best one addition ([`reachable_objective`]).
    pub reaches: f64,
    /// What the stuck model reaches with its own best one addition.
    pub stuck_reaches: f64,
    /// The seed scatter band the replacement must clear (`2√2 σ` of the stuck diagnosis).
    pub tie: f64,
    /// Set when the calibration fitted the added effect at an edge ([`fitted_not_a_finding`]).
    pub edge_note: Option<&'static str>,
}

impl ReplacementJudgement {
    /// Whether the replacement is kept: below the stuck model's reach by more than the seed
    /// scatter, and its added effect not fitted at an edge.
    pub fn kept(&self) -> bool {
        self.edge_note.is_none() && self.reaches < self.stuck_reaches - self.tie
    }

    /// `"<added> in place of <removed> reaches <v>[, but <edge note>]"`.
    pub fn tried_text(&self) -> String {
        let what = if self.removed == self.added { format!("{} {REFITTED}", self.added.name()) } else { format!("{} in place of {}", self.added.name(), self.removed.name()) };
        format!("{what} reaches {:.2}{}", self.reaches, self.edge_note.map_or(String::new(), |n| format!(", but {n}")))
    }

    /// The note a stuck round's verdict gets for a kept replacement.
    pub fn kept_text(&self) -> String {
        if self.removed == self.added {
            return format!("{} {REFITTED} (then by the calibration) reaches objective {:.2} against {:.2}, each with its best one addition", self.added.name(), self.reaches, self.stuck_reaches);
        }
        format!(
            "replacing {} by {} (fitted by the calibration) reaches objective {:.2} against {:.2}, each with its best one addition",
            self.removed.name(),
            self.added.name(),
            self.reaches,
            self.stuck_reaches
        )
    }
}

/// Judges replacing `removed` by `added` in the model of the stuck diagnosis `stuck`: the
/// swapped model calibrated to `cal2` and diagnosed as `d2` (see [`ReplacementJudgement::kept`]).
pub fn judge_replacement(stuck: &Diagnosis, removed: EffectKind, added: EffectKind, cal2: &Machine, d2: &Diagnosis) -> ReplacementJudgement {
    ReplacementJudgement {
        removed,
        added,
        // Adding `removed` back would make the replacement an addition of `added` to the stuck
        // model, which that model's own trial of `added` has already judged.
        reaches: reachable_objective(d2.judged_objective(), &d2.trials.iter().filter(|t| t.effect != removed).cloned().collect::<Vec<_>>()),
        stuck_reaches: reachable_objective(stuck.judged_objective(), &stuck.trials),
        tie: tie_width(stuck.objective_scatter),
        edge_note: fitted_not_a_finding(added, cal2),
    }
}

/// The note a stuck round's verdict gets when none of the replacements `tried` (judged
/// against the same stuck diagnosis) was kept; None when none was tried.
pub fn replacements_refused_text(tried: &[ReplacementJudgement]) -> Option<String> {
    let first = tried.first()?;
    Some(format!(
        "replacements tried, none below {:.2} (this model with its best one addition) by the seed scatter (±{:.2}): {}",
        first.stuck_reaches,
        first.tie,
        tried.iter().map(ReplacementJudgement::tried_text).collect::<Vec<_>>().join(", ")
    ))
}

/// How a round's change reads when the loop re-fitted an applied effect in place
/// ([`LoopOptions::refit_when_stuck`]; the round records it as `removed == applied`).
pub const REFITTED: &str = "re-fitted from the uncalibrated values";

/// The applied effects a stuck round may re-fit from the loop's uncalibrated values
/// ([`LoopOptions::refit_when_stuck`]), in the order applied: those still on that have a main
/// parameter to scan and were not re-fitted before.
pub fn refit_candidates(history: &[Round], current: &Machine) -> Vec<EffectKind> {
    applied_effects(history)
        .into_iter()
        .filter(|k| current.effects.is_on(*k) && Param::main_of_effect(*k).is_some() && !history.iter().any(|r| r.refitted() && r.applied == Some(*k)))
        .collect()
}

/// The stuck calibrated model `cal` with its applied effect `a` fitted anew from the
/// uncalibrated values of `start` (the loop's first model): the base's calibration parameters
/// ([`calibration_parameters`]) are put back to `start`'s, `a`'s main parameter is scanned on a
/// grid, then `a`'s parameters and the noise level are fitted, as a trial's second start does
/// (`LoopOptions::uncalibrated_start`). The other applied effects keep their values. The caller
/// re-calibrates and searches the result ([`run_loop`]).
pub fn refit_from_uncalibrated(cal: &Machine, start: &Machine, a: EffectKind, reference: &Reference, opts: &LoopOptions, progress: &LoopProgress) -> Result<Machine, LoopError> {
    let mut t = cal.clone();
    for p in calibration_parameters(cal) {
        if let Some(v) = p.get(start) {
            p.set(&mut t, v);
        }
    }
    let scan: Vec<Param> = Param::main_of_effect(a).into_iter().collect();
    progress.expect(fit_trial_scanning_evaluations(&t, &Param::of_effect(a), &TRIAL_REFINE, &scan, opts));
    Ok(fit_trial_scanning(&t, reference, &Param::of_effect(a), &TRIAL_REFINE, &scan, opts, progress)?.0)
}

/// The options of the diagnoses a stuck round makes of its replacement and re-fit candidates:
/// those of the loop without [`LoopOptions::unbend_when_stuck`] (nor the joint trials of
/// [`LoopOptions::joint_trials`], for the same reason). The round's own diagnosis
/// has already been searched unbent when the option is on; searching every candidate model
/// unbent as well cost the seen pair 3805 an unbent search per candidate (104 min for one
/// case, docs/loop-notebook.md "Unbend when stuck").
fn searched_plainly(opts: &LoopOptions) -> LoopOptions {
    LoopOptions { unbend_when_stuck: false, unbend_when_short: false, joint_trials: false, ..opts.clone() }
}

/// A replacement the loop keeps: the new machine, its diagnosis (calibrated machine,
/// diagnosis) and the options it was run with.
struct Replacement {
    machine: Machine,
    diagnosed: (Machine, Diagnosis),
    opts: LoopOptions,
}

/// The most rounds a loop may be asked for ([`run_loop`]; `diagnose --rounds`, `confusion
/// --rounds`, a batch job's `model_loop.rounds`): each round is a full search, so more is a typo.
pub const MAX_LOOP_ROUNDS: usize = 20;

/// Refuses a number of loop rounds outside 1 ..= [`MAX_LOOP_ROUNDS`]: [`run_loop`], the CLI
/// and batch jobs share this check.
pub fn check_loop_rounds(n: usize) -> Result<(), super::CompareError> {
    if (1..=MAX_LOOP_ROUNDS).contains(&n) {
        Ok(())
    } else {
        Err(super::CompareError::Parameter { name: "rounds", reason: format!("{n}: give 1 to {MAX_LOOP_ROUNDS} rounds") })
    }
}

/// compare → diagnose → apply the best effect (with its fitted parameter) → repeat, for up to
/// `rounds` rounds or until nothing significant is missing. Returns the final machine, the
/// history, and the last diagnosis. The final machine is the last round's calibrated machine
/// when that round applied nothing (its calibration re-fits every applied effect), and else
/// the machine with the last applied effect (fitted by its trial, not yet re-calibrated).
///
/// **Replacement.** An effect applied while another one was still missing may have taken
/// that one's place (a large unbalance standing in for a misalignment and a path modulation
/// together, both at the shaft rate). Re-fitting its parameters cannot switch it off, and no
/// single addition then helps. So when a round finds nothing to add but the model is still
/// above `(1 + floor_margin) ×` its floor, and a round is left, the loop tries replacing an
/// applied effect by a runner-up of the round that applied it ([`replacement_candidates`]):
/// each candidate model (the applied effect off, the runner-up on and fitted by the
/// calibration) gets a full diagnosis. The replacement is kept if what it reaches with its best
/// one addition is below what the stuck model reaches with its own best one addition
/// ([`reachable_objective`]: significant or not) by more than the seed scatter (`2√2 σ`, as
/// ties in [`decide`]), and if the calibration did not fit the added effect at an edge of its
/// range ([`fitted_not_a_finding`]: that would be a stand-in, as a pinned trial is); the round
/// records it (`removed`, `applied`) and the next round starts from that diagnosis. The effect
/// taken out is no candidate in that diagnosis or after: put back, it would make the
/// replacement an addition of the runner-up to the stuck model, which the stuck round's own
/// trial of the runner-up has judged (on a fresh pair, casing_modes + load_zone, a path
/// modulation at its physical top came in that way "in place of" the load zone, which the
/// next round added back).
///
/// **Re-fit in place** ([`LoopOptions::refit_when_stuck`], on by default). When no
/// replacement is kept, each applied effect ([`refit_candidates`]) is fitted anew from the
/// loop's uncalibrated values ([`refit_from_uncalibrated`]), the model diagnosed again, and the
/// result judged as a replacement of the effect by itself; the best kept one goes on, recorded
/// with `removed == applied`.
///
/// **Taking out** ([`LoopOptions::removal_trials`]). A round that adds nothing and whose
/// removal trials contradict a part of its model ([`super::removal`]) takes out the most
/// contradicted one, before any replacement, when a round is left: the next round starts from
/// the round's uncalibrated machine without it (the model its removal trial calibrated),
/// recorded as [`Round::taken_out`]. With [`LoopOptions::take_out_first`] (the default since
/// session 75) a round that chose an addition does the same, the addition recorded as
/// [`Round::set_aside`] and not applied. A kept replacement's diagnosis, made while judging
/// it, has no removal trials.
///
/// With [`LoopOptions::unbend_when_stuck`] the round's own diagnosis may be searched again
/// unbent (see [`diagnose_with`]); the replacement and re-fit diagnoses of a stuck round are
/// searched plainly ([`searched_plainly`]), so a stuck round pays one unbent search, not one
/// per candidate model. With [`LoopOptions::strength_range`] they get no range while they
/// are judged; the kept one gets it as the next round's diagnosis.
pub fn run_loop(m: &Machine, measured: &Signal, rounds: usize, opts: &LoopOptions, progress: &(dyn Fn(usize, usize) -> bool + Sync)) -> Result<(Machine, Vec<Round>, Diagnosis), LoopError> {
    opts.validate()?;
    check_loop_rounds(rounds)?;
    let reference = Reference::new(&*super::at_most_rate(measured, m.fs_hz)?, &opts.compare)?;
    let progress = &LoopProgress::new(progress);
    let mut current = m.clone();
    let mut history: Vec<Round> = Vec::new();
    let mut last = None;
    // A diagnosis of `current` already made (by a kept replacement).
    let mut pending: Option<(Machine, Diagnosis)> = None;
    // Every applied effect's parameters join the calibration of the rounds after it.
    let given_refit = opts.refit_effects.clone();
    let mut opts = opts.clone();
    for r in 1..=rounds {
        let (cal, d) = match pending.take() {
            // A kept replacement's search got no strength range and no note (most are refused):
            // it gets them now that it is the round's diagnosis.
            Some((cal, d)) => answer(cal, d, &reference, &opts, progress)?,
            None => diagnose_with(&current, &reference, &opts, progress)?,
        };
        let env = d.envelope_nrmse().unwrap_or(f64::INFINITY);
        let mut round = Round { applied: d.best, ..Round::of_diagnosis(r, current.effects.enabled(), &d, env) };
        // A part of the model the measurement contradicts is taken out before any replacement,
        // and with `take_out_first` before any addition: the next round starts from the
        // round's machine without it.
        let contradicted = super::removal::most_contradicted(&d.removals).filter(|_| r < rounds && (d.best.is_none() || opts.take_out_first));
        if let Some((t, next)) = contradicted.and_then(|t| t.part.removed_from(&current).ok().map(|next| (t, next))) {
            round.applied = None;
            round.set_aside = d.best;
            round.taken_out = Some(super::removal::TakenOut { part: t.part.clone(), label: t.label.clone(), explained: t.explained });
            let first = d.best.map_or(String::new(), |k| format!(" before adding {}", k.name()));
            round.verdict = format!("{}; took out {}{first}: {}", d.verdict, t.label, t.summary);
            opts.refit_effects.retain(|k| next.effects.is_on(*k));
            history.push(round);
            current = next;
            last = Some(d);
            continue;
        }
        if let Some(k) = d.best {
            let mut next = cal.clone();
            match d.trials.iter().find(|t| t.effect == k) {
                Some(t) => {
                    apply_trial(&mut next, t);
                    round.applied_with = t.with_effect;
                    round.applied_jointly = t.joint;
                }
                None => next.effects.enable(k),
            }
            round.applied_values = applied_values(&next, k, round.applied_with);
            for e in std::iter::once(k).chain(round.applied_with) {
                if !opts.refit_effects.contains(&e) {
                    opts.refit_effects.push(e);
                }
            }
            history.push(round);
            current = next;
            last = Some(d);
            continue;
        }
        if r < rounds && stuck(&d, &opts) {
            let mut kept: Option<(ReplacementJudgement, Replacement)> = None;
            let mut tried: Vec<ReplacementJudgement> = Vec::new();
            // The stuck round applied nothing, so the history before it holds every candidate.
            for (a, b) in replacement_candidates(&history, &current, &opts) {
                let Ok(swapped) = swap_effect(&cal, a, b) else { continue };
                let mut o = opts.clone();
                o.refit_effects.retain(|k| *k != a);
                o.refit_effects.push(b);
                // The effect taken out is not tried again (see `judge_replacement`).
                exclude_candidates(&mut o, &swapped, &[a]);
                let (cal2, d2) = diagnose_search(&swapped, &reference, &searched_plainly(&o), progress)?;
                round.note_second_starts_won(&d2);
                let j = judge_replacement(&d, a, b, &cal2, &d2);
                if j.kept() && kept.as_ref().is_none_or(|k| j.reaches < k.0.reaches) {
                    kept = Some((j.clone(), Replacement { machine: swapped, diagnosed: (cal2, d2), opts: o }));
                }
                tried.push(j);
            }
            // No runner-up helped: an applied effect may sit where a bent calibration put it.
            if kept.is_none() && opts.refit_when_stuck {
                for a in refit_candidates(&history, &current) {
                    let refitted = refit_from_uncalibrated(&cal, m, a, &reference, &opts, progress)?;
                    let (cal2, d2) = diagnose_search(&refitted, &reference, &searched_plainly(&opts), progress)?;
                    round.note_second_starts_won(&d2);
                    let j = judge_replacement(&d, a, a, &cal2, &d2);
                    if j.kept() && kept.as_ref().is_none_or(|k| j.reaches < k.0.reaches) {
                        kept = Some((j.clone(), Replacement { machine: refitted, diagnosed: (cal2, d2), opts: opts.clone() }));
                    }
                    tried.push(j);
                }
            }
            if let Some((j, Replacement { machine: swapped, diagnosed: (cal2, d2), opts: o })) = kept {
                round.verdict = format!("{}; {}", d.verdict, j.kept_text());
                // What else was tried and refused.
                let refused: Vec<ReplacementJudgement> = tried.into_iter().filter(|t| !t.kept()).collect();
                if let Some(note) = replacements_refused_text(&refused) {
                    round.verdict = format!("{}; {note}", round.verdict);
                }
                round.applied = Some(j.added);
                round.removed = Some(j.removed);
                round.applied_values = effect_values(&cal2, j.added);
                history.push(round);
                current = swapped;
                opts = o;
                pending = Some((cal2, d2));
                last = Some(d);
                continue;
            }
            if let Some(note) = replacements_refused_text(&tried) {
                round.verdict = format!("{}; {note}", d.verdict);
            }
        }
        history.push(round);
        last = Some(d);
        // Nothing applied: the loop ends on this round's calibrated machine, the one its
        // calibration report and objective describe.
        current = cal;
        break;
    }
    let last = last.ok_or(LoopError::Cancelled)?;
    // The final machine records what a loop going on from it re-fits.
    let given: Vec<EffectKind> = m.fitted_effects.iter().chain(&given_refit).copied().collect();
    current.fitted_effects = refit_to_go_on(&history, &given);
    current.fitted_effects.retain(|k| current.effects.is_on(*k));
    Ok((current, history, last))
}

/// The comparison of the calibrated machine (for reports).
pub fn final_comparison(m: &Machine, measured: &Signal, opts: &LoopOptions) -> Result<Comparison, LoopError> {
    Ok(evaluate(m, &Reference::new(&*super::at_most_rate(measured, m.fs_hz)?, &opts.compare)?, opts)?.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trial(k: EffectKind, j0: f64, floor: f64, j: f64, evidence_share: f64) -> EffectTrial {
        EffectTrial {
            effect: k,
            parameter: None,
            extra_parameters: vec![],
            objective_before: j0,
            objective_after: j,
            envelope_nrmse_before: 0.0,
            envelope_nrmse_after: 0.0,
            domains: vec![],
            reduction: (j0 - j) / j0,
            explained: (j0 - j) / (j0 - floor),
            evidence: String::new(),
            evidence_share,
            tied_with_best: false,
            outside_band: false,
            pinned: None,
            summary: String::new(),
            objective_without_effect: None,
            effect_explained: None,
            objective_fitted: None,
            from_uncalibrated: false,
            fine_cell_won: vec![],
            with_effect: None,
            joint: false,
            each_effect_explained: None,
        }
    }

    #[test]
    fn the_better_start_is_kept_and_marked_when_it_is_the_uncalibrated_one() {
        let m = crate::model::preset("cwru_6205_inner").unwrap();
        let out = |j: f64| -> TrialOutcome { Ok((trial(EffectKind::LoadZone, 10.0, 2.0, j, 0.0), m.clone())) };
        let failed = || -> TrialOutcome { Err("invalid machine".into()) };
        let (t, _) = better_start((out(5.0), out(4.0))).unwrap();
        assert_eq!((t.objective_after, t.from_uncalibrated), (4.0, true));
        let (t, _) = better_start((out(4.0), out(5.0))).unwrap();
        assert_eq!((t.objective_after, t.from_uncalibrated), (4.0, false));
        // A tie keeps the calibrated start.
        assert!(!better_start((out(4.0), out(4.0))).unwrap().0.from_uncalibrated);
        assert!(better_start((failed(), out(6.0))).unwrap().0.from_uncalibrated);
        assert!(!better_start((out(6.0), failed())).unwrap().0.from_uncalibrated);
        assert_eq!(better_start((failed(), failed())).unwrap_err(), "invalid machine");
    }

    #[test]
    fn a_feature_fitted_at_the_edge_of_its_band_is_ranked_last_and_never_chosen() {
        // The extended-fault case of the bearing-base table (seed 2109): the casing trial put
        // its mode at 7347 Hz, the top of the 300–7373 Hz range, and had the lowest objective.
        let o = LoopOptions::default();
        let (j0, floor) = (13.41, 1.97);
        let mut casing = trial(EffectKind::CasingModes, j0, floor, 7.99, 1.0);
        casing.parameter = Some((Param::CasingModeHz, 7347.0));
        casing.outside_band = true;
        assert_eq!(casing.not_a_finding_note(), Some(OUTSIDE_BAND_NOTE));
        let ts = vec![casing.clone(), trial(EffectKind::ExtendedFault, j0, floor, 9.19, 30.0), trial(EffectKind::Misalignment, j0, floor, 11.79, 10.0)];
        let (r, best, v) = decide(ts, j0, floor, 0.05, &o);
        assert_eq!(best, Some(EffectKind::ExtendedFault), "{v}");
        assert_eq!(r.iter().map(|t| t.effect).collect::<Vec<_>>(), vec![EffectKind::ExtendedFault, EffectKind::Misalignment, EffectKind::CasingModes]);
        assert!(!r[2].tied_with_best);
        // Behind a finding that explains too little, it is named with the reason it is none
        // (the casing_modes + load_zone pair of the session-26 fresh-seed test, round 4).
        let ts = vec![casing.clone(), trial(EffectKind::Misalignment, j0, floor, 11.79, 10.0)];
        let (_, best, v) = decide(ts, j0, floor, 0.05, &o);
        assert_eq!(best, None, "{v}");
        assert!(v.contains("misalignment explains 14 %") && v.contains("casing_modes explains 47 %") && v.contains("edge of the band searched (effects.casing_modes.modes[0].frequency_hz = 7.3470e3)"), "{v}");
        // Alone, it is no finding, and the verdict says why.
        let (_, best, v) = decide(vec![casing], j0, floor, 0.05, &o);
        assert_eq!(best, None);
        assert!(v.contains("edge of the band") && v.contains("frequency_hz = 7.3470e3"), "{v}");
    }

    #[test]
    fn a_strength_pinned_at_an_edge_of_its_range_is_ranked_last_and_named_in_the_verdict() {
        // CWRU 234 with the 0.021 in preset: the unbalance trial took the top of its range.
        let o = LoopOptions::default();
        let (j0, floor) = (29.3, 4.16);
        let mut unbalance = trial(EffectKind::Unbalance, j0, floor, 22.8, 37.0);
        unbalance.parameter = Some((Param::UnbalanceKgM, 8.86e-3));
        unbalance.pinned = Some((1e-6, 1e-2));
        assert!(unbalance.pinned_note().unwrap().contains("at the top of its range"));
        assert_eq!(unbalance.not_a_finding_note(), unbalance.pinned_note());
        let ts = vec![unbalance.clone(), trial(EffectKind::Misalignment, j0, floor, 25.5, 37.0), trial(EffectKind::PathModulation, j0, floor, 26.0, 20.0)];
        let (r, best, v) = decide(ts, j0, floor, 0.2, &o);
        assert_eq!(r.iter().map(|t| t.effect).collect::<Vec<_>>(), vec![EffectKind::Misalignment, EffectKind::PathModulation, EffectKind::Unbalance]);
        assert_eq!(best, None, "{v}");
        assert!(v.contains("misalignment explains 15 %") && v.contains("unbalance explains 26 %") && v.contains("8.8600e-3 at the top of its range"), "{v}");
        // A finding below it is still chosen when it explains enough on its own.
        let ts = vec![unbalance.clone(), trial(EffectKind::Misalignment, j0, floor, 23.0, 37.0)];
        assert_eq!(decide(ts, j0, floor, 0.2, &o).1, Some(EffectKind::Misalignment));
        // Alone, and at the bottom of its range: the re-fit did the work.
        unbalance.parameter = Some((Param::UnbalanceKgM, 1.1e-6));
        assert!(unbalance.pinned_note().unwrap().contains("at the bottom of its range"));
        let (_, best, v) = decide(vec![unbalance], j0, floor, 0.2, &o);
        assert_eq!(best, None);
        assert!(v.contains("at the bottom of its range") && v.contains("re-fit did the work"), "{v}");
    }

    #[test]
    fn a_strength_is_pinned_at_an_edge_unless_its_range_ends_where_the_physics_does() {
        let m = crate::model::preset("mfs_inner").unwrap();
        // CWRU 234's unbalance; a slip at the top; a load zone at the bottom.
        assert_eq!(range_edge(Param::UnbalanceKgM, 8.86e-3, &m), (false, Some((1e-6, 1e-2))));
        assert_eq!(range_edge(Param::SlipPercent, 7.9, &m), (false, Some((0.2, 8.0))));
        assert_eq!(range_edge(Param::RadialLoadN, 2.05, &m), (false, Some((2.0, 5000.0))));
        // The stored pairs' true finds at the top of a physical range stay findings.
        assert_eq!(range_edge(Param::PathModulationDepth, 0.988, &m), (false, None));
        assert_eq!(range_edge(Param::MeshVariation, 0.76, &m), (false, None));
        // At the bottom of such a range the effect is off: pinned.
        assert_eq!(range_edge(Param::PathModulationDepth, 0.06, &m), (false, Some((0.05, 1.0))));
        // Inside the range nothing; a feature at an edge is outside the band.
        assert_eq!(range_edge(Param::UnbalanceKgM, 3e-4, &m), (false, None));
        assert_eq!(range_edge(Param::CasingModeHz, 0.449 * m.fs_hz, &m), (true, None));
    }

    #[test]
    fn decide_ranks_by_objective_and_breaks_ties_on_the_evidence() {
        let o = LoopOptions::default();
        let (j0, floor) = (20.0, 5.0);
        let ts = vec![trial(EffectKind::Misalignment, j0, floor, 12.0, 10.0), trial(EffectKind::LoadZone, j0, floor, 12.1, 70.0), trial(EffectKind::Slip, j0, floor, 19.0, 90.0)];
        // Scatter 0.1: a 0.1 difference is within 2√2 σ = 0.28 — a tie, decided by the evidence.
        let (r, best, v) = decide(ts.clone(), j0, floor, 0.1, &o);
        assert_eq!(best, Some(EffectKind::LoadZone), "{v}");
        assert_eq!(r.iter().map(|t| t.effect).collect::<Vec<_>>(), vec![EffectKind::LoadZone, EffectKind::Misalignment, EffectKind::Slip]);
        assert!(r[0].tied_with_best && r[1].tied_with_best && !r[2].tied_with_best);
        assert!(v.contains("tied") && v.contains("misalignment"), "{v}");
        // Scatter 0.01: no tie, the lower objective wins.
        let (_, best, _) = decide(ts.clone(), j0, floor, 0.01, &o);
        assert_eq!(best, Some(EffectKind::Misalignment));
        // Scatter 3: even the best improvement (8) is within 2√2 σ = 8.5 — nothing significant.
        // (All three are tied then; slip, with the strongest evidence, would lead.)
        let (r, best, _) = decide(ts.clone(), j0, floor, 3.0, &o);
        assert_eq!(r[0].effect, EffectKind::Slip);
        assert_eq!(best, None);
        let mut ts3 = ts.clone();
        ts3[2].evidence_share = 5.0;
        let (_, best, v) = decide(ts3, j0, floor, 3.0, &o);
        assert_eq!(best, None);
        assert!(v.contains("seed scatter"), "{v}");
    }

    #[test]
    fn the_floor_ratio_asks_for_the_same_distance_over_the_scatter_whatever_k() {
        assert!((floor_ratio_needed(&LoopOptions::default()) - 1.15).abs() < 1e-12, "the default margin 0.15 (since session 54)");
        // The rest with the margin of sessions 44–53, 0.3.
        let one = LoopOptions { floor_margin: 0.3, ..Default::default() };
        assert_eq!(floor_ratio_needed(&LoopOptions { floor_margin: 0.5, ..Default::default() }), 1.5);
        assert!((floor_ratio_needed(&LoopOptions { floor_margin: 0.2, ..Default::default() }) - 1.2).abs() < 1e-12);
        assert!((floor_ratio_needed(&LoopOptions { floor_margin: 0.2, realisations: 4, ..Default::default() }) - 1.88f64.sqrt()).abs() < 1e-12);
        let two = LoopOptions { realisations: 2, ..one.clone() };
        assert!((floor_ratio_needed(&two) - 2.38f64.sqrt()).abs() < 1e-12);
        assert!((floor_ratio_needed(&LoopOptions { floor_margin: 0.5, ..two.clone() }) - 3.5f64.sqrt()).abs() < 1e-12);
        // b²/V at the threshold: j² / floor² − 1 with floor² = 2V (K = 1), V (K ≥ 2).
        let b2_over_v = |r: f64, floor2_over_v: f64| (r * r - 1.0) * floor2_over_v;
        assert!((b2_over_v(floor_ratio_needed(&one), 2.0) - b2_over_v(floor_ratio_needed(&two), 1.0)).abs() < 1e-12);
        // At the threshold ratio of K = 2, a K = 2 diagnosis just below it finds nothing to
        // explain; the same numbers with one realisation would.
        // (1.5 × the floor: under K = 2's 1.54, over K = 1's 1.3.)
        let t = || vec![trial(EffectKind::Slip, 1.5, 1.0, 1.1, 50.0)];
        let (_, best2, v2) = decide(t(), 1.5, 1.0, 0.01, &two);
        assert_eq!(best2, None, "{v2}");
        assert!(v2.contains("within its own scatter"), "{v2}");
        let (_, best1, v1) = decide(t(), 1.5, 1.0, 0.01, &one);
        assert_eq!(best1, Some(EffectKind::Slip), "{v1}");
    }

    #[test]
    fn a_near_floor_lead_on_a_record_longer_than_the_comparison_names_the_longer_comparison() {
        let o = LoopOptions::default();
        // Seed 9700's gear mesh at 0.8 under a spall (session 55): 1.12 × its floor with 1.5 s
        // compared, ranked first, explaining 90 %.
        let (j0, floor, sigma) = (2.85, 2.545, 0.06);
        let (trials, best, v) = decide(vec![trial(EffectKind::GearMesh, j0, floor, 2.57, 10.0)], j0, floor, sigma, &o);
        assert_eq!(best, None, "{v}");
        assert_eq!(named_lead(&trials, j0, floor, sigma, &o), Some(EffectKind::GearMesh));
        assert!(v.contains("best trial: gear_mesh explains"), "{v}");
        let noted = with_longer_comparison_note(v.clone(), true, o.fit_duration_s, 10.0);
        assert!(noted.starts_with(&v) && noted.ends_with("the comparison spans 1.5 s of the 10.0 s record: a longer one (the fit duration) lowers the seed scatter and may tell this lead from a misfit"), "{noted}");
        // No note when the comparison already spans half the record or more, or without a lead.
        assert_eq!(with_longer_comparison_note(v.clone(), true, 1.5, 2.9), v);
        assert_eq!(with_longer_comparison_note(v.clone(), false, 1.5, 10.0), v);
        // Not a lead: an improvement within the tie width (2√2 σ = 0.17 > 0.10).
        let (trials, _, v) = decide(vec![trial(EffectKind::GearMesh, j0, floor, 2.75, 10.0)], j0, floor, sigma, &o);
        assert_eq!(named_lead(&trials, j0, floor, sigma, &o), None);
        assert!(!v.contains("best trial"), "{v}");
        // Nor when it is chosen (1.34 × the floor, over the default 1.15).
        let (trials, best, _) = decide(vec![trial(EffectKind::GearMesh, 3.4, floor, 2.57, 10.0)], 3.4, floor, sigma, &o);
        assert_eq!((best, named_lead(&trials, 3.4, floor, sigma, &o)), (Some(EffectKind::GearMesh), None));
        // Nor when switching its effect off again costs only 5 % (the re-fit did the work,
        // session 57), unless that test is off.
        let idle = EffectTrial { effect_explained: Some(0.05), ..trial(EffectKind::GearMesh, j0, floor, 2.57, 10.0) };
        let (trials, _, v) = decide(vec![idle.clone()], j0, floor, sigma, &o);
        assert_eq!(named_lead(&trials, j0, floor, sigma, &o), None);
        assert!(!v.contains("best trial"), "{v}");
        let lax = LoopOptions { effect_must_work: false, ..o.clone() };
        let (trials, _, _) = decide(vec![idle], j0, floor, sigma, &lax);
        assert_eq!(named_lead(&trials, j0, floor, sigma, &lax), Some(EffectKind::GearMesh));
    }

    /// The note on a longer comparison goes once on the answer of a whole search, however many
    /// searches its verdict quotes (an unbent redo and a second look each embed the verdict they
    /// replaced), and only when the search that answered named a lead.
    #[test]
    fn the_longer_comparison_note_goes_once_on_the_answer_of_a_whole_search() {
        let o = LoopOptions::default();
        let (j0, floor, sigma) = (2.85, 2.545, 0.06);
        let searched = |j_best: f64| {
            let (trials, best, verdict) = decide(vec![trial(EffectKind::GearMesh, j0, floor, j_best, 10.0)], j0, floor, sigma, &o);
            let near_floor_lead = named_lead(&trials, j0, floor, sigma, &o);
            Diagnosis { trials, best, verdict, near_floor_lead, floor_objective: floor, objective_scatter: sigma, ..Default::default() }
        };
        let note = "a longer one (the fit duration) lowers the seed scatter";
        // A stuck plain search and its unbent redo, both naming the lead: one note, at the end.
        let (plain, redo) = (searched(2.57), searched(2.58));
        assert!(plain.near_floor_lead.is_some() && redo.near_floor_lead.is_some());
        let combined = noted_once(unbent_verdict(redo, &plain, &o), o.fit_duration_s, 6.0);
        assert_eq!(combined.verdict.matches(note).count(), 1, "{}", combined.verdict);
        assert!(combined.verdict.ends_with("may tell this lead from a misfit") && combined.verdict.contains("from the calibrated model alone: nothing significant"), "{}", combined.verdict);
        // A redo that names no lead: no note, though the plain search it quotes named one.
        let combined = noted_once(unbent_verdict(searched(2.75), &plain, &o), o.fit_duration_s, 6.0);
        assert_eq!(combined.near_floor_lead, None);
        assert!(!combined.verdict.contains(note), "{}", combined.verdict);
    }

    #[test]
    fn decide_needs_error_above_the_floor_and_a_real_share_of_it() {
        // The margin these cases were written with (the default until session 44); the 1.46 ×
        // case at today's default is checked after them.
        let o = LoopOptions { floor_margin: 0.5, ..Default::default() };
        // At the floor: nothing to explain, however large the relative reduction.
        let (_, best, v) = decide(vec![trial(EffectKind::SensorResponse, 2.7, 2.4, 2.3, 50.0)], 2.7, 2.4, 0.01, &o);
        assert_eq!(best, None);
        assert!(v.contains("within its own scatter"), "{v}");
        // The held-out path_modulation + load_zone pair (seed 2502) with the second start:
        // round 2 at 1.15 × its floor, σ 0.066; the path-modulation trial reaches 2.36 and
        // explains 71 %. No finding, but the verdict names it.
        let (j0, floor, sigma) = (2.60, 2.26, 0.066);
        let (_, best, v) = decide(vec![trial(EffectKind::PathModulation, j0, floor, 2.36, 10.0), trial(EffectKind::ToothFault, j0, floor, 2.58, 5.0)], j0, floor, sigma, &o);
        assert_eq!(best, None);
        assert!(v.contains("within its own scatter") && v.contains("best trial: path_modulation explains 71 %") && v.contains("not a finding"), "{v}");
        // Not named: an improvement within the seed scatter (0.10 < 2√2 σ = 0.19, explaining
        // 29 %), 19 % explained (an improvement of 0.20 at 1.46 × the floor), the model under
        // its floor, or a trial pinned at an edge of its range.
        let pinned = EffectTrial { pinned: Some((0.0, 1.0)), ..trial(EffectKind::PathModulation, j0, floor, 2.36, 10.0) };
        let cases = [(trial(EffectKind::PathModulation, j0, floor, 2.50, 10.0), j0, floor), (trial(EffectKind::PathModulation, 3.30, floor, 3.10, 10.0), 3.30, floor), (trial(EffectKind::PathModulation, 2.20, floor, 2.0, 10.0), 2.20, floor), (pinned, j0, floor)];
        for (t, j0, floor) in cases {
            let (_, best, v) = decide(vec![t], j0, floor, sigma, &o);
            assert_eq!(best, None);
            assert!(v.contains("within its own scatter") && !v.contains("best trial"), "{v}");
        }
        // With a margin of 0.3 (the default of sessions 44–53; 0.15 since) 1.46 × the floor is
        // something to explain, and the trial's 19 % of it is named and is not a finding.
        let (_, best, v) = decide(vec![trial(EffectKind::PathModulation, 3.30, floor, 3.10, 10.0)], 3.30, floor, sigma, &LoopOptions { floor_margin: 0.3, ..LoopOptions::default() });
        assert_eq!(best, None);
        assert!(!v.contains("within its own scatter") && v.contains("explains 19 %"), "{v}");
        // Far above the floor, but the best trial explains only 15 % of it.
        let (_, best, v) = decide(vec![trial(EffectKind::CasingModes, 24.0, 4.0, 21.0, 50.0)], 24.0, 4.0, 0.01, &o);
        assert_eq!(best, None);
        assert!(v.contains("explains 15 %"), "{v}");
        // Explains 40 %: significant.
        let (_, best, _) = decide(vec![trial(EffectKind::LoadZone, 24.0, 4.0, 16.0, 50.0)], 24.0, 4.0, 0.01, &o);
        assert_eq!(best, Some(EffectKind::LoadZone));
        // No candidate at all.
        let (_, best, v) = decide(vec![], 24.0, 4.0, 0.01, &o);
        assert_eq!(best, None);
        assert!(v.starts_with("nothing significant"), "{v}");
    }

    #[test]
    fn the_near_floor_rule_claims_only_a_decisive_untied_effect_between_1_2_and_1_5_times_the_floor() {
        // The rule lives between 1.2 × and the margin's ratio: with the margin of sessions 44–53,
        // 0.3 (since session 54 the default margin 0.15 leaves it no band).
        let off = LoopOptions { floor_margin: 0.3, ..Default::default() };
        let on = LoopOptions { near_floor_rule: true, ..off.clone() };
        let with_ablation = |mut t: EffectTrial, e: f64| {
            t.effect_explained = Some(e);
            t
        };
        // Like round 2 of the fresh bearing pair path_modulation + load_zone (seed 2800): 1.27 ×
        // its floor, the path-modulation trial explains 84 % and its ablation 84 %.
        let (j0, floor, sigma) = (2.54, 2.0, 0.03);
        let pm = || with_ablation(trial(EffectKind::PathModulation, j0, floor, 2.0864, 10.0), 0.84);
        let other = || with_ablation(trial(EffectKind::ToothFault, j0, floor, 2.50, 5.0), 0.05);
        let (_, best, v) = decide(vec![pm(), other()], j0, floor, sigma, &on);
        assert_eq!(best, Some(EffectKind::PathModulation), "{v}");
        assert!(v.contains("near-floor rule") && v.contains("1.27 ×"), "{v}");
        // The margin 0.3 says nothing significant, naming it.
        let (_, best, v) = decide(vec![pm(), other()], j0, floor, sigma, &off);
        assert_eq!(best, None, "{v}");
        // Today's default margin (0.15) claims it without the near-floor rule.
        let (_, best, v) = decide(vec![pm(), other()], j0, floor, sigma, &LoopOptions::default());
        assert_eq!(best, Some(EffectKind::PathModulation), "{v}");
        // Each condition alone refuses it.
        let below = |t: EffectTrial, j0: f64| decide(vec![t, other()], j0, floor, sigma, &on).1;
        // 1.19 × the floor (the bearing-base gear_mesh case's ratio).
        assert_eq!(below(with_ablation(trial(EffectKind::PathModulation, 2.38, floor, 2.05, 10.0), 0.84), 2.38), None);
        // 79 % explained.
        assert_eq!(below(with_ablation(trial(EffectKind::PathModulation, j0, floor, j0 - 0.79 * (j0 - floor), 10.0), 0.84), j0), None);
        // The re-fit did the work: the effect's ablation 49 %; or unknown.
        assert_eq!(below(with_ablation(trial(EffectKind::PathModulation, j0, floor, 2.0864, 10.0), 0.49), j0), None);
        assert_eq!(below(trial(EffectKind::PathModulation, j0, floor, 2.0864, 10.0), j0), None);
        // A spectral feature (a sensor roll-off) is never claimed this near the floor.
        let rolloff = EffectTrial { parameter: Some((Param::SensorBandwidthHz, 2081.0)), ..with_ablation(trial(EffectKind::SensorResponse, j0, floor, 2.0864, 10.0), 0.9) };
        assert_eq!(below(rolloff, j0), None);
        // Pinned at an edge of its range.
        let pinned = EffectTrial { pinned: Some((0.0, 1.0)), ..pm() };
        assert_eq!(below(pinned, j0), None);
        // A tie: a misalignment within 2√2 σ of an unbalance.
        let tied = with_ablation(trial(EffectKind::Misalignment, j0, floor, 2.10, 1.0), 0.8);
        let (_, best, v) = decide(vec![pm(), tied], j0, floor, sigma, &on);
        assert_eq!(best, None, "{v}");
        // An improvement within the seed scatter (σ 0.3: 2√2 σ = 0.85 > 0.45).
        let (_, best, _) = decide(vec![pm(), other()], j0, floor, 0.3, &on);
        assert_eq!(best, None);
        // Above the margin's ratio the rule changes nothing: the default decides (which, since
        // session 57, also asks the effect to do the work: an ablation of 10 % is refused).
        let weak = || with_ablation(trial(EffectKind::Unbalance, 3.2, floor, 2.9, 10.0), 0.1);
        let (_, best, v) = decide(vec![weak()], 3.2, floor, sigma, &LoopOptions { effect_must_work: false, ..on.clone() });
        assert_eq!(best, Some(EffectKind::Unbalance), "{v}");
        assert!(!v.contains("near-floor rule"), "{v}");
        let (_, best, v) = decide(vec![weak()], 3.2, floor, sigma, &on);
        assert_eq!(best, None, "{v}");
        assert!(v.contains("re-fit did the work") && !v.contains("near-floor rule"), "{v}");
        // With several realisations its ratio is that of a 0.2 margin there (√1.88 = 1.37).
        let two = LoopOptions { realisations: 2, ..on.clone() };
        assert_eq!(decide(vec![pm(), other()], j0, floor, sigma, &two).1, None);
        let j2 = 2.8;
        let pm2 = with_ablation(trial(EffectKind::PathModulation, j2, floor, 2.1, 10.0), 0.84);
        assert_eq!(decide(vec![pm2, other()], j2, floor, sigma, &two).1, Some(EffectKind::PathModulation));
    }

    #[test]
    fn the_scatter_rule_asks_for_a_real_excess_and_an_effect_that_did_the_work() {
        let o = LoopOptions { decision_rule: DecisionRule::Scatter, ..Default::default() };
        let with_ablation = |mut t: EffectTrial, e: f64| {
            t.effect_explained = Some(e);
            t
        };
        // The bearing-base gear_mesh case (seed 2100): 1.19 × the floor, σ 0.14. The unbalance
        // trial explains 98 %, but switching the unbalance off costs 7 %: no finding, and the
        // verdict says why. (The floor-margin rule with a margin of 0.3 stops earlier: 1.19 <
        // 1.3; with today's default 0.15 it would claim the unbalance: this round of an older
        // search is a stand-in 0.15 can name. Today's search puts the same case, seed 2103, at
        // 1.00 ×: docs/loop-notebook.md "Session 54".)
        let margin_03 = LoopOptions { floor_margin: 0.3, ..LoopOptions::default() };
        let (j0, floor, sigma) = (5.07, 4.26, 0.14);
        let unbalance = with_ablation(trial(EffectKind::Unbalance, j0, floor, 4.28, 10.0), 0.07);
        let (_, best, v) = decide(vec![unbalance.clone()], j0, floor, sigma, &o);
        assert_eq!(best, None);
        assert!(v.contains("costs only 7 %") && v.contains("re-fit did the work"), "{v}");
        let (_, best, v) = decide(vec![unbalance.clone()], j0, floor, sigma, &margin_03);
        assert_eq!(best, None);
        assert!(v.contains("within its own scatter"), "{v}");
        // Today's default (margin 0.15) is above its ratio here, but asks the effect to do the
        // work too (session 57): no finding, for the same reason; without that it names the
        // stand-in.
        let (_, best, v) = decide(vec![unbalance.clone()], j0, floor, sigma, &LoopOptions::default());
        assert_eq!(best, None);
        assert!(v.contains("costs only 7 %") && v.contains("re-fit did the work"), "{v}");
        let (_, best, _) = decide(vec![unbalance.clone()], j0, floor, sigma, &LoopOptions { effect_must_work: false, ..LoopOptions::default() });
        assert_eq!(best, Some(EffectKind::Unbalance));
        // An ablation that could not be evaluated does not stop the floor margin's finding.
        let (_, best, _) = decide(vec![EffectTrial { effect_explained: None, ..unbalance.clone() }], j0, floor, sigma, &LoopOptions::default());
        assert_eq!(best, Some(EffectKind::Unbalance));
        // The same numbers with the effect doing the work: a finding under the scatter rule
        // (excess 0.81 > 2√2 σ = 0.40), none under the floor margin 0.3.
        let (_, best, _) = decide(vec![with_ablation(unbalance.clone(), 0.9)], j0, floor, sigma, &o);
        assert_eq!(best, Some(EffectKind::Unbalance));
        let (_, best, _) = decide(vec![with_ablation(unbalance.clone(), 0.9)], j0, floor, sigma, &margin_03);
        assert_eq!(best, None);
        // No ablation (it could not be evaluated): no finding under the scatter rule.
        let (_, best, v) = decide(vec![EffectTrial { effect_explained: None, ..unbalance }], j0, floor, sigma, &o);
        assert_eq!(best, None);
        assert!(v.contains("unknown share"), "{v}");
        // A gear-base control (1.02 × the floor, σ 0.22): slip "explains" 339 % and its ablation
        // 405 %, but the excess (0.09) is within 2√2 σ: nothing.
        let (j0, floor) = (4.50, 4.41);
        let slip = with_ablation(trial(EffectKind::Slip, j0, floor, 4.195, 10.0), 4.05);
        let (_, best, v) = decide(vec![slip], j0, floor, 0.22, &o);
        assert_eq!(best, None);
        assert!(v.contains("within its own scatter"), "{v}");
    }

    fn fitted(effect: EffectKind, parameter: Option<(Param, f64)>, extra: Vec<(Param, f64)>) -> EffectTrial {
        EffectTrial { parameter, extra_parameters: extra, ..trial(effect, 10.0, 2.0, 5.0, 0.0) }
    }

    #[test]
    fn apply_trial_switches_the_effect_on_and_sets_every_fitted_parameter() {
        let mut m = crate::model::preset("cwru_6205_inner").unwrap();
        assert!(!m.effects.is_on(EffectKind::LoadZone));
        let t = fitted(EffectKind::LoadZone, Some((Param::RadialLoadN, 345.0)), vec![(Param::RadialClearanceM, -3e-6)]);
        apply_trial(&mut m, &t);
        assert!(m.effects.is_on(EffectKind::LoadZone));
        assert_eq!(Param::RadialLoadN.get(&m), Some(345.0));
        assert_eq!(Param::RadialClearanceM.get(&m), Some(-3e-6));
        m.validate().unwrap();
    }

    /// The MFS gear base without a load zone and without the Hertzian law.
    fn gear_base_without_load_or_nonlinearity() -> Machine {
        let mut m = crate::model::preset("mfs_healthy").unwrap();
        m.effects.disable(EffectKind::LoadZone);
        m.effects.disable(EffectKind::NonlinearContact);
        m
    }

    #[test]
    fn a_contact_nonlinearity_is_tried_with_the_load_zone_it_acts_through() {
        use EffectKind::*;
        let m = gear_base_without_load_or_nonlinearity();
        assert_eq!(companion(NonlinearContact, &m), Some(LoadZone));
        assert_eq!(trial_parameters(NonlinearContact, &m), vec![Param::RadialLoadN, Param::RadialClearanceM]);
        assert_eq!(trial_main_parameter(NonlinearContact, &m), Some(Param::RadialLoadN));
        let t = switched_on(&m, NonlinearContact);
        assert!(t.effects.is_on(NonlinearContact) && t.effects.is_on(LoadZone));
        // The second start scans the load, and a re-calibrating start fits it first.
        assert_eq!(uncalibrated_start_of(&m, NonlinearContact).1, vec![Param::RadialLoadN]);
        assert_eq!(recalibration_parameters(NonlinearContact, &m, &LoopOptions::default())[..2], [Param::RadialLoadN, Param::RadialClearanceM]);
        // The load zone acts without the Hertzian law (on a fault's impacts): tried alone.
        assert_eq!(companion(LoadZone, &m), None);
        assert_eq!(trial_parameters(LoadZone, &m), Param::of_effect(LoadZone));
        // With a load zone on, the nonlinearity is tried alone, as before.
        let mut loaded = m.clone();
        loaded.effects.enable(LoadZone);
        assert_eq!(companion(NonlinearContact, &loaded), None);
        assert!(trial_parameters(NonlinearContact, &loaded).is_empty());
        assert_eq!(trial_main_parameter(NonlinearContact, &loaded), None);
        assert!(!switched_on(&loaded, NonlinearContact).effects.is_on(Slip));
        // A bearing-less machine has no load zone to bring.
        let mut bare = m.clone();
        bare.bearings.clear();
        assert_eq!(companion(NonlinearContact, &bare), None);
    }

    /// The premise of [`companion`]: without a load zone the Hertzian law changes the
    /// response by next to nothing (every ball at the preload its linearisation is taken at);
    /// with one, it changes the bearing's stiffness and so the response.
    #[test]
    fn the_hertzian_law_matters_only_under_a_load_zone() {
        use EffectKind::*;
        let rel_change = |mut m: Machine| {
            m.duration_s = 0.25;
            let linear = crate::model::simulate(&m).unwrap();
            m.effects.enable(NonlinearContact);
            let hertz = crate::model::simulate(&m).unwrap();
            let diff: Vec<f64> = linear.samples.iter().zip(&hertz.samples).map(|(a, b)| a - b).collect();
            crate::dsp::rms(&diff) / crate::dsp::rms(&linear.samples)
        };
        let m = gear_base_without_load_or_nonlinearity();
        let unloaded = rel_change(m.clone());
        let mut loaded = m;
        loaded.effects.enable(LoadZone);
        Param::RadialLoadN.set(&mut loaded, 77.0);
        let loaded = rel_change(loaded);
        // Seen: 6.1e-6 and 0.73.
        assert!(unloaded < 1e-4 && loaded > 0.1, "relative change of the response by the Hertzian law: {unloaded:.2e} without a load zone, {loaded:.2e} under 77 N");
    }

    #[test]
    fn a_trial_with_its_companion_is_applied_and_recorded_with_it() {
        use EffectKind::*;
        let mut m = gear_base_without_load_or_nonlinearity();
        let t = EffectTrial { with_effect: Some(LoadZone), ..fitted(NonlinearContact, Some((Param::RadialLoadN, 80.0)), vec![(Param::RadialClearanceM, 4e-6)]) };
        assert_eq!(t.label(), "nonlinear_contact with load_zone");
        apply_trial(&mut m, &t);
        assert!(m.effects.is_on(NonlinearContact) && m.effects.is_on(LoadZone));
        assert_eq!(Param::RadialLoadN.get(&m), Some(80.0));
        assert_eq!(applied_values(&m, NonlinearContact, t.with_effect), vec![(Param::RadialLoadN, 80.0), (Param::RadialClearanceM, 4e-6)]);
        let mut r1 = round(1, vec![(NonlinearContact, 0.6), (CasingModes, 0.5)], Some(NonlinearContact), None);
        r1.applied_with = Some(LoadZone);
        r1.applied_values = applied_values(&m, NonlinearContact, r1.applied_with);
        assert_eq!(r1.change("-"), "nonlinear_contact with load_zone");
        assert_eq!(r1.change_with_values("-"), "nonlinear_contact with load_zone (radial_load_n = 8.000e1, radial_clearance_m = 4.000e-6)");
        let h = vec![r1.clone(), round(2, vec![], None, None)];
        assert_eq!(applied_effects(&h), vec![NonlinearContact, LoadZone]);
        // Its ablation switches both off again.
        let off = switched_off(m.clone(), &t);
        assert!(!off.effects.is_on(NonlinearContact) && !off.effects.is_on(LoadZone));
        let alone = switched_off(m.clone(), &EffectTrial { with_effect: None, ..t.clone() });
        assert!(!alone.effects.is_on(NonlinearContact) && alone.effects.is_on(LoadZone));
        // The pair is not swapped for a runner-up one effect at a time.
        assert!(replacement_candidates(&h, &m, &LoopOptions::default()).is_empty());
        r1.applied_with = None;
        assert_eq!(replacement_candidates(&[r1, round(2, vec![], None, None)], &m, &LoopOptions::default()), vec![(NonlinearContact, CasingModes)]);
    }

    #[test]
    fn a_joint_trial_is_applied_with_both_effects_and_named_with_a_plus() {
        use EffectKind::*;
        let mut m = crate::model::preset("mfs_inner").unwrap();
        let t = EffectTrial { with_effect: Some(Unbalance), joint: true, ..fitted(CasingModes, Some((Param::CasingModeHz, 3900.0)), vec![(Param::UnbalanceKgM, 2e-4)]) };
        assert_eq!(t.label(), "casing_modes + unbalance");
        apply_trial(&mut m, &t);
        assert!(m.effects.is_on(CasingModes) && m.effects.is_on(Unbalance));
        assert_eq!((Param::CasingModeHz.get(&m), Param::UnbalanceKgM.get(&m)), (Some(3900.0), Some(2e-4)));
        let mut r1 = round(1, vec![], Some(CasingModes), None);
        (r1.applied_with, r1.applied_jointly) = (t.with_effect, t.joint);
        r1.applied_values = applied_values(&m, CasingModes, r1.applied_with);
        assert_eq!(r1.change("-"), "casing_modes + unbalance");
        assert!(r1.change_with_values("-").starts_with("casing_modes + unbalance (frequency_hz = 3.900e3"), "{}", r1.change_with_values("-"));
        assert_eq!(applied_effects(&[r1.clone()]), vec![CasingModes, Unbalance]);
        // Its ablation, as any trial's, switches both off.
        let off = switched_off(m.clone(), &t);
        assert!(!off.effects.is_on(CasingModes) && !off.effects.is_on(Unbalance));
        // A round of a companion trial keeps its name.
        r1.applied_jointly = false;
        assert_eq!(r1.change("-"), "casing_modes with unbalance");
    }

    #[test]
    fn apply_trial_sets_path_modulation_to_the_shaft_rate() {
        let mut m = crate::model::preset("cwru_6205_inner").unwrap();
        let t = fitted(EffectKind::PathModulation, Some((Param::PathModulationDepth, 0.4)), Vec::new());
        apply_trial(&mut m, &t);
        let pm = m.effects.path_modulation.as_ref().unwrap();
        assert_eq!(pm.depth, 0.4);
        assert!((pm.frequency_hz - 29.95).abs() < 1e-9, "rate {} Hz", pm.frequency_hz);
    }

    fn round(n: usize, ranking: Vec<(EffectKind, f64)>, applied: Option<EffectKind>, removed: Option<EffectKind>) -> Round {
        let ranking = ranking.into_iter().map(|(k, e)| (k, 1.0 - e, e)).collect();
        Round { round: n, envelope_nrmse: 1.0, objective: 1.0, floor_objective: 0.5, ranking, applied, removed, ..Default::default() }
    }

    #[test]
    fn a_loop_going_on_re_fits_what_it_was_given_and_what_was_applied_once_each() {
        use EffectKind::*;
        let mut h = vec![round(1, vec![], Some(Unbalance), None), round(2, vec![], Some(Misalignment), Some(Unbalance)), round(3, vec![], Some(NonlinearContact), None), round(4, vec![], None, None)];
        h[2].applied_with = Some(LoadZone);
        assert_eq!(refit_to_go_on(&h, &[Noise, Misalignment]), vec![Noise, Misalignment, LoadZone]);
        assert_eq!(refit_to_go_on(&[], &[]), vec![]);
    }

    #[test]
    fn the_command_to_go_on_quotes_a_path_the_shell_would_split() {
        use std::path::Path;
        let band = ["--band-hz".to_string(), "1800,3000".to_string()];
        let plain = go_on_command(Path::new("data/105.mat"), Path::new("go1.toml"), &band);
        assert!(plain.starts_with("twinscope diagnose data/105.mat --machine go1.toml --band-hz "), "{plain}");
        assert_eq!(shlex::split(&plain).unwrap(), ["twinscope", "diagnose", "data/105.mat", "--machine", "go1.toml", "--band-hz", "1800,3000"]);
        let channel = ["--channel".to_string(), "drive end".to_string()];
        let spaced = go_on_command(Path::new("my data/rec 1.wav"), Path::new("it's.toml"), &channel);
        assert_eq!(shlex::split(&spaced).unwrap(), ["twinscope", "diagnose", "my data/rec 1.wav", "--machine", "it's.toml", "--channel", "drive end"]);
    }

    #[test]
    fn applied_effects_drops_what_a_later_round_replaced() {
        use EffectKind::*;
        let h = vec![round(1, vec![], Some(Unbalance), None), round(2, vec![], Some(Misalignment), Some(Unbalance)), round(3, vec![], Some(PathModulation), None), round(4, vec![], None, None)];
        assert_eq!(applied_effects(&h), vec![Misalignment, PathModulation]);
        assert_eq!(h[1].change("-"), "misalignment in place of unbalance");
        assert_eq!(h[3].change("-"), "-");
    }

    #[test]
    fn applied_effects_drops_what_a_later_round_took_out_with_what_acts_through_it() {
        use super::super::removal::{ModelPart, TakenOut};
        use EffectKind::*;
        let out = |k: EffectKind| Some(TakenOut { part: ModelPart::Effect(k), label: k.name().into(), explained: 0.9 });
        // A load zone applied with its contact nonlinearity, then a misalignment; a round taking
        // the load zone out takes the nonlinearity with it.
        let mut h = vec![round(1, vec![], Some(NonlinearContact), None), round(2, vec![], Some(Misalignment), None), round(3, vec![], None, None)];
        h[0].applied_with = Some(LoadZone);
        h[2].taken_out = out(LoadZone);
        assert_eq!(applied_effects(&h), vec![Misalignment]);
        // Taking out the nonlinearity alone keeps the load zone; a fault taken out is no effect.
        h[2].taken_out = out(NonlinearContact);
        assert_eq!(applied_effects(&h), vec![LoadZone, Misalignment]);
        assert_eq!(h[2].change("-"), "took out nonlinear_contact");
        h[2].set_aside = Some(Unbalance);
        assert_eq!(h[2].change_with_values("-"), "took out nonlinear_contact before adding unbalance");
        h[2].taken_out = Some(TakenOut { part: ModelPart::Fault { bearing: "de".into() }, label: String::new(), explained: 0.9 });
        assert_eq!(applied_effects(&h), vec![NonlinearContact, LoadZone, Misalignment]);
    }

    #[test]
    fn a_round_reports_the_values_it_applied() {
        use EffectKind::*;
        let mut m = crate::model::preset("cwru_6205_inner").unwrap();
        apply_trial(&mut m, &fitted(LoadZone, Some((Param::RadialLoadN, 345.0)), vec![(Param::RadialClearanceM, -3e-6)]));
        let values = effect_values(&m, LoadZone);
        assert_eq!(values, vec![(Param::RadialLoadN, 345.0), (Param::RadialClearanceM, -3e-6)]);
        let mut r = round(2, vec![], Some(LoadZone), Some(PathModulation));
        r.applied_values = values;
        assert_eq!(r.change_with_values("-"), "load_zone (radial_load_n = 3.450e2, radial_clearance_m = -3.000e-6) in place of path_modulation");
        // An effect that is off has no values; a round without values reads as `change`.
        assert!(effect_values(&m, Slip).is_empty());
        r.applied_values.clear();
        assert_eq!(r.change_with_values("-"), r.change("-"));
        assert_eq!(round(3, vec![], None, None).change_with_values("nothing"), "nothing");
    }

    #[test]
    fn a_stuck_rounds_candidate_models_are_searched_without_the_unbent_redo_and_nothing_else_changes() {
        let opts = LoopOptions { unbend_when_stuck: true, scan_force_amplitudes: true, refit_effects: vec![EffectKind::Misalignment], floor_margin: 0.7, ..LoopOptions::default() };
        let plain = searched_plainly(&opts);
        assert!(!plain.unbend_when_stuck);
        assert_eq!(LoopOptions { unbend_when_stuck: true, ..plain }, opts);
    }

    #[test]
    fn replacements_are_runners_up_of_the_round_that_applied_the_effect() {
        use EffectKind::*;
        let mut m = crate::model::preset("mfs_healthy").unwrap();
        m.effects.enable(Unbalance);
        let opts = LoopOptions::default();
        // Round 1 applied unbalance (66 %); misalignment came close (63 %), extended fault
        // further (48 %), path modulation under the 20 % significance; round 2 found nothing.
        let h = vec![
            round(1, vec![(Unbalance, 0.66), (Misalignment, 0.63), (ExtendedFault, 0.48), (PathModulation, 0.15)], Some(Unbalance), None),
            round(2, vec![(ToothFault, 0.06)], None, None),
        ];
        assert_eq!(replacement_candidates(&h, &m, &opts), vec![(Unbalance, Misalignment), (Unbalance, ExtendedFault)]);
        // An effect already on is no replacement, nor is one taken out before.
        m.effects.enable(Misalignment);
        assert_eq!(replacement_candidates(&h, &m, &opts), vec![(Unbalance, ExtendedFault)]);
        let mut h2 = h.clone();
        h2.push(round(3, vec![], Some(Unbalance), Some(ExtendedFault)));
        assert_eq!(replacement_candidates(&h2, &m, &opts), vec![]);
        // Nothing applied: nothing to replace.
        m.effects.disable(Unbalance);
        assert_eq!(replacement_candidates(&h, &m, &opts), vec![]);
    }

    #[test]
    fn a_stuck_round_re_fits_each_applied_effect_once_and_its_runners_up_stay_the_first_rounds() {
        use EffectKind::*;
        let mut m = crate::model::preset("mfs_inner").unwrap();
        for k in [LoadZone, Misalignment, NonlinearContact] {
            m.effects.enable(k);
        }
        let opts = LoopOptions::default();
        // Round 1 applied the load zone (misalignment close behind), round 2 the nonlinear
        // contact (a switch: nothing to scan), round 3 the misalignment, round 4 was stuck.
        let mut h = vec![
            round(1, vec![(LoadZone, 0.7), (Misalignment, 0.5), (Unbalance, 0.4)], Some(LoadZone), None),
            round(2, vec![(NonlinearContact, 0.6)], Some(NonlinearContact), None),
            round(3, vec![(Misalignment, 0.5)], Some(Misalignment), None),
        ];
        assert_eq!(refit_candidates(&h, &m), vec![LoadZone, Misalignment]);
        assert_eq!(replacement_candidates(&h, &m, &opts), vec![(LoadZone, Unbalance)]);
        // Round 4 re-fitted the load zone in place: it is still on, reads as re-fitted, is not
        // re-fitted again, and its stuck round's ranking (where the load zone, being on, had no
        // trial) offers no replacements of it.
        h.push(round(4, vec![(Unbalance, 0.3), (SpeedFluctuation, 0.25)], Some(LoadZone), Some(LoadZone)));
        assert!(h[3].refitted() && !h[0].refitted());
        assert_eq!(h[3].change("-"), format!("load_zone {REFITTED}"));
        assert_eq!(applied_effects(&h), vec![NonlinearContact, Misalignment, LoadZone]);
        assert_eq!(refit_candidates(&h, &m), vec![Misalignment]);
        assert_eq!(replacement_candidates(&h, &m, &opts), vec![(LoadZone, Unbalance)]);
        // An effect switched off is not re-fitted.
        m.effects.disable(Misalignment);
        assert_eq!(refit_candidates(&h, &m), vec![]);
        // The judgement of a re-fit reads as one.
        let mut stuck = Diagnosis { objective_scatter: 0.1, ..Default::default() };
        stuck.calibration.objective_after = 9.0;
        let mut d2 = Diagnosis::default();
        d2.calibration.objective_after = 4.0;
        let j = judge_replacement(&stuck, LoadZone, LoadZone, &m, &d2);
        assert!(j.kept(), "{j:?}");
        assert!(j.tried_text().starts_with(&format!("load_zone {REFITTED} reaches 4.00")), "{}", j.tried_text());
        assert!(j.kept_text().contains(&format!("load_zone {REFITTED}")) && j.kept_text().contains("4.00 against 9.00"), "{}", j.kept_text());
    }

    /// `LoopOptions::unbend_when_short`: a significant best that explains under half the error
    /// above the floor and leaves the objective at or above the margin's ratio is short (seed
    /// 8508's unbalance: 14.86 → 10.96 over a floor of 1.81, 30 %); over half, under the ratio
    /// after it, or no best (stuck) is not. Only the option, with unbending on and the search
    /// not unbent already, redoes it, and the redo keeps the plain choice.
    #[test]
    fn a_significant_best_that_explains_under_half_is_short() {
        use EffectKind::*;
        let opts = LoopOptions { unbend_when_short: true, floor_margin: 0.3, ..LoopOptions::default() };
        let diagnosis = |j0: f64, floor: f64, j_best: f64| {
            let mut d = Diagnosis { floor_objective: floor, best: Some(Unbalance), trials: vec![trial(Unbalance, j0, floor, j_best, 0.06), trial(Misalignment, j0, floor, 12.84, 0.06)], verdict: "unbalance: plain".into(), ..Default::default() };
            d.calibration.objective_after = j0;
            d
        };
        let d = diagnosis(14.86, 1.81, 10.96);
        let s = short(&d, &opts).expect("short");
        assert_eq!((s.chosen, s.verdict.as_str()), (Unbalance, "unbalance: plain"));
        assert!((s.explained - 3.9 / 13.05).abs() < 1e-12, "{}", s.explained);
        assert!(unbend_acts(&d, &opts));
        // Not without the option, without unbending, or when unbent already.
        assert!(!unbend_acts(&d, &LoopOptions { unbend_when_short: false, ..opts.clone() }));
        assert!(!unbend_acts(&d, &LoopOptions { unbend_pinned: false, ..opts.clone() }));
        assert!(!unbend_acts(&Diagnosis { unbent: true, ..d.clone() }, &opts));
        // Over half explained (14.86 → 7.0: 60 %): not short.
        assert!(short(&diagnosis(14.86, 1.81, 7.0), &opts).is_none());
        // Under half (44 %), but the objective after it (2.25) under 1.3 × 1.81 = 2.35: nothing
        // the floor margin would call missing is left.
        assert!(short(&diagnosis(2.6, 1.81, 2.25), &opts).is_none());
        assert!(short(&diagnosis(2.6, 1.81, 2.40), &opts).is_some());
        // No best: stuck, not short (`unbend_when_stuck` is the one that acts).
        let stuck_d = Diagnosis { best: None, ..d.clone() };
        assert!(short(&stuck_d, &opts).is_none());
        assert!(!unbend_acts(&stuck_d, &LoopOptions { unbend_when_stuck: false, ..opts.clone() }));
        // The redo's verdict says why and keeps the plain choice; a stuck redo keeps its own.
        let redo = Diagnosis { verdict: "misalignment: unbent".into(), ..Default::default() };
        let r = unbent_verdict(redo.clone(), &d, &opts);
        assert_eq!(r.short_plain, Some(s));
        assert_eq!(r.stuck_plain_verdict, None);
        assert!(r.verdict.starts_with("misalignment: unbent (short with the trials from the calibrated model, which pins nothing: its best, unbalance, explained 30 % of the error above the floor") && r.verdict.ends_with("from the calibrated model alone: unbalance: plain)"), "{}", r.verdict);
        let r = unbent_verdict(redo, &Diagnosis { verdict: "nothing significant is missing".into(), ..stuck_d }, &opts);
        assert_eq!((r.short_plain, r.stuck_plain_verdict.as_deref()), (None, Some("nothing significant is missing")));
        assert!(r.verdict.contains("(stuck with the trials from the calibrated model, which pins nothing: every trial started again"), "{}", r.verdict);
    }

    #[test]
    fn a_replacement_fitted_at_an_edge_of_its_range_is_no_finding() {
        use EffectKind::*;
        let mut m = crate::model::preset("mfs_inner").unwrap();
        for k in [Unbalance, PathModulation, CasingModes] {
            m.effects.enable(k);
        }
        let set = |m: &mut Machine, p: Param, v: f64| p.set(m, v);
        // CWRU 234's unbalance at the top of its range: a stand-in; inside it: a finding.
        set(&mut m, Param::UnbalanceKgM, 8.86e-3);
        assert!(fitted_not_a_finding(Unbalance, &m).is_some_and(|n| n.contains("top of its range")));
        set(&mut m, Param::UnbalanceKgM, 3e-4);
        assert_eq!(fitted_not_a_finding(Unbalance, &m), None);
        // A path modulation at the physics' own limit stays a finding; all but off it is none.
        set(&mut m, Param::PathModulationDepth, 0.988);
        assert_eq!(fitted_not_a_finding(PathModulation, &m), None);
        set(&mut m, Param::PathModulationDepth, 0.06);
        assert!(fitted_not_a_finding(PathModulation, &m).is_some_and(|n| n.contains("bottom of its range")));
        // A casing mode at the edge of the band is outside what the data show.
        let fs_hz = m.fs_hz;
        set(&mut m, Param::CasingModeHz, 0.449 * fs_hz);
        assert_eq!(fitted_not_a_finding(CasingModes, &m), Some(OUTSIDE_BAND_NOTE));
        // A switch without a parameter is never pinned.
        assert_eq!(fitted_not_a_finding(NonlinearContact, &m), None);
    }

    #[test]
    fn a_replacement_is_kept_only_below_the_stuck_reach_by_the_scatter_and_not_at_an_edge() {
        use EffectKind::*;
        let mut stuck = Diagnosis { objective_scatter: 0.2, trials: vec![trial(CasingModes, 17.9, 3.3, 16.1, 0.5)], ..Default::default() };
        stuck.calibration.objective_after = 17.9;
        // The stuck model reaches 16.1; the tie band is 2√2 × 0.2 = 0.57.
        let swapped = |j_cal: f64, j_best: f64| {
            let mut d = Diagnosis { trials: vec![trial(Slip, j_cal, 3.3, j_best, 0.4)], ..Default::default() };
            d.calibration.objective_after = j_cal;
            d
        };
        let mut m = crate::model::preset("mfs_inner").unwrap();
        m.effects.enable(Unbalance);
        Param::UnbalanceKgM.set(&mut m, 3e-4);
        let j = judge_replacement(&stuck, Misalignment, Unbalance, &m, &swapped(15.8, 15.0));
        assert!((j.stuck_reaches - 16.1).abs() < 1e-12 && (j.reaches - 15.0).abs() < 1e-12 && (j.tie - 0.5657).abs() < 1e-4);
        assert!(j.kept(), "{j:?}");
        assert!(j.kept_text().contains("replacing misalignment by unbalance") && j.kept_text().contains("15.00 against 16.10"), "{}", j.kept_text());
        // The removed effect put back is no addition of the replacement: that is the stuck
        // model plus the runner-up, which the stuck round's own trial judged.
        let mut back = swapped(15.8, 15.7);
        back.trials.insert(0, trial(Misalignment, 15.8, 3.3, 12.0, 0.9));
        let j = judge_replacement(&stuck, Misalignment, Unbalance, &m, &back);
        assert!((j.reaches - 15.7).abs() < 1e-12 && !j.kept(), "{j:?}");
        // Within the seed scatter of the stuck reach: refused, though lower.
        let j = judge_replacement(&stuck, Misalignment, Unbalance, &m, &swapped(15.8, 15.6));
        assert!(!j.kept() && j.reaches < j.stuck_reaches);
        // Its calibrated model, without a better trial, counts too.
        assert!(judge_replacement(&stuck, Misalignment, Unbalance, &m, &swapped(14.0, 14.5)).kept());
        // Far below, but the calibration fitted the added unbalance at the top of its range.
        Param::UnbalanceKgM.set(&mut m, 8.86e-3);
        let j = judge_replacement(&stuck, Misalignment, Unbalance, &m, &swapped(12.0, 11.0));
        assert!(!j.kept());
        let note = replacements_refused_text(std::slice::from_ref(&j)).unwrap();
        assert!(note.contains("none below 16.10") && note.contains("unbalance in place of misalignment reaches 11.00, but its strength was fitted at the top"), "{note}");
    }

    #[test]
    fn effects_taken_out_are_no_candidates() {
        use EffectKind::*;
        let m = crate::model::preset("mfs_inner").unwrap();
        let mut o = LoopOptions::default();
        exclude_candidates(&mut o, &m, &[]);
        assert!(o.candidates.is_empty(), "nothing taken out: every applicable effect, as before");
        exclude_candidates(&mut o, &m, &[LoadZone]);
        assert!(!o.candidates.contains(&LoadZone) && o.candidates.contains(&PathModulation) && o.candidates.contains(&CasingModes));
        assert!(o.candidates.iter().all(|k| Effects::applicable(*k, &m)));
        let mut o = LoopOptions { candidates: vec![LoadZone, Slip], ..Default::default() };
        exclude_candidates(&mut o, &m, &[LoadZone]);
        assert_eq!(o.candidates, vec![Slip]);
    }

    #[test]
    fn a_stuck_model_and_a_replacement_each_get_their_best_one_addition() {
        use EffectKind::*;
        // Nothing significant: the best trial still counts (16.1 < 17.9).
        let stuck = vec![trial(CasingModes, 17.9, 3.3, 16.1, 0.5), trial(Slip, 17.9, 3.3, 17.5, 0.1)];
        assert_eq!(reachable_objective(17.9, &stuck), 16.1);
        // A trial worse than the calibrated model is no addition.
        assert_eq!(reachable_objective(17.9, &[trial(ExtendedFault, 17.9, 3.3, 19.0, 0.2)]), 17.9);
        assert_eq!(reachable_objective(17.9, &[]), 17.9);
    }

    #[test]
    fn a_casing_modes_evidence_is_the_band_its_mode_was_fitted_in() {
        let band = |lo: f64, measured: f64, simulated: f64, share_percent: f64| crate::compare::residual::ResidualItem {
            kind: "psd_band".into(),
            family: "PSD band".into(),
            label: format!("{lo:.0}–{:.0} Hz", lo + 375.0),
            frequency_hz: lo + 187.5,
            share_percent,
            measured,
            simulated,
            note: String::new(),
        };
        let map = ResidualMap { items: vec![band(3000.0, -60.0, -79.4, 56.0), band(375.0, -50.0, -48.0, 3.0), band(750.0, -55.0, -61.0, 9.0)], envelope_families: vec![] };
        // Before a fit: the band where the model is weakest.
        let (text, share) = evidence(EffectKind::CasingModes, &map, None);
        assert!(text.starts_with("PSD band 3000–3375 Hz -19.4 dB"), "{text}");
        assert_eq!(share, 65.0);
        // A mode fitted at 479 Hz: the share of its band (3 %), not the 56 % of a band 2.5 kHz away.
        let (text, share) = evidence(EffectKind::CasingModes, &map, Some(479.0));
        assert!(text.contains("375–750 Hz (+2.0 dB mean level in the model)") && text.contains("(479 Hz)"), "{text}");
        assert_eq!(share, 3.0);
        // A mode fitted at 3.2 kHz: that band's deficit and share.
        let (text, share) = evidence(EffectKind::CasingModes, &map, Some(3200.0));
        assert!(text.contains("3000–3375 Hz (-19.4 dB") && text.contains("(3200 Hz)"), "{text}");
        assert_eq!(share, 56.0);
    }

    #[test]
    fn a_trial_with_a_companion_shows_the_companions_evidence() {
        use EffectKind::*;
        let line = crate::compare::residual::ResidualItem {
            kind: "envelope_line".into(),
            family: "FTF ± shaft".into(),
            label: "6xFTF+1xshaft".into(),
            frequency_hz: 49.3,
            share_percent: 64.0,
            measured: 1.0,
            simulated: 0.5,
            note: "weaker in the model".into(),
        };
        let map = ResidualMap { items: vec![line], envelope_families: vec![("FTF ± shaft".into(), 64.0)] };
        let m = gear_base_without_load_or_nonlinearity();
        // The contact nonlinearity alone has no signature; with its load zone, the load zone's.
        assert_eq!(trial_evidence(NonlinearContact, None, &map, &m).1, 0.0);
        let (text, share) = trial_evidence(NonlinearContact, Some(LoadZone), &map, &m);
        assert_eq!((text.as_str(), share), (evidence(LoadZone, &map, None).0.as_str(), 64.0));
        assert!(text.starts_with("6xFTF+1xshaft (49.3 Hz): weaker in the model"), "{text}");
    }

    #[test]
    fn the_loop_refuses_bad_settings_before_any_simulation() {
        let m = crate::model::preset("cwru_6205_inner").unwrap();
        let measured = Signal::new(vec![0.0; 24_000], 12_000.0, "quiet", "m/s^2");
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let progress = |_: usize, _: usize| {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            true
        };
        let opts = LoopOptions { fit_duration_s: 90.0, ..Default::default() };
        let e = diagnose(&m, &measured, &opts, &progress).unwrap_err().to_string();
        assert!(e.contains("fit_duration_s") && e.contains("90"), "{e}");
        let opts = LoopOptions { realisations: 0, ..Default::default() };
        let e = run_loop(&m, &measured, 2, &opts, &progress).unwrap_err().to_string();
        assert!(e.contains("realisations"), "{e}");
        for rounds in [0, MAX_LOOP_ROUNDS + 1] {
            let e = run_loop(&m, &measured, rounds, &LoopOptions::default(), &progress).unwrap_err().to_string();
            assert!(e.contains("rounds") && e.contains("give 1 to 20"), "{e}");
        }
        assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 0);
    }

    #[test]
    fn a_coupled_trial_fits_a_force_beside_the_applied_force_it_shares_a_line_with() {
        use EffectKind::{BeltDrive, LoadZone, Misalignment, Unbalance};
        let mut m = crate::model::preset("mfs_healthy").unwrap();
        // Nothing applied: nothing to couple.
        assert!(coupled_applied_forces(Unbalance, &m).is_empty());
        m.effects.enable(Misalignment);
        Param::Misalignment2xN.set(&mut m, 27.3);
        // An unbalance on the misalignment's shaft (both on the first by default) shares its 1×.
        assert_eq!(coupled_applied_forces(Unbalance, &m), vec![Param::Misalignment2xN]);
        // Not a force, a force at another frequency, or the applied effect itself.
        assert!(coupled_applied_forces(LoadZone, &m).is_empty() && coupled_applied_forces(BeltDrive, &m).is_empty() && coupled_applied_forces(Misalignment, &m).is_empty());
        // On another shaft: no shared line.
        let mut other = m.clone();
        other.effects.misalignment.as_mut().unwrap().shaft = Some("gear".into());
        assert!(coupled_applied_forces(Unbalance, &other).is_empty());
        // The other way round, an unbalance applied and a misalignment tried.
        let mut u = crate::model::preset("mfs_healthy").unwrap();
        u.effects.enable(Unbalance);
        assert_eq!(coupled_applied_forces(Misalignment, &u), vec![Param::UnbalanceKgM]);
        // There the unbalance also starts at half to 0.8 of its value and at 1.2 to 1.4 (after
        // the nine).
        Param::UnbalanceKgM.set(&mut u, 4.0e-3);
        let reverse: Vec<f64> = coupled_starts(&switched_on(&u, Misalignment), &[Param::UnbalanceKgM]).iter().map(|t| Param::UnbalanceKgM.get(t).unwrap() / 4.0e-3).collect();
        assert_eq!(reverse.len(), 16);
        assert!((reverse[1] - 0.88).abs() < 1e-9 && (reverse[9] - 0.5).abs() < 1e-9 && (reverse[12] - 0.8).abs() < 1e-9 && (reverse[13] - 1.2).abs() < 1e-9 && (reverse[15] - 1.4).abs() < 1e-9, "{reverse:?}");
        let every_start = LoopOptions::default();
        assert_eq!(every_start.coupled_refined_starts, 0);
        let plain = plain_trial_evaluations(&u, Misalignment, &LoopOptions { coupled_forces: false, ..LoopOptions::default() });
        assert_eq!(plain_trial_evaluations(&u, Misalignment, &every_start), 16 * plain);
        // With three chosen by their grids: each start's grid, then three starts in full.
        let chosen = LoopOptions { coupled_refined_starts: 3, ..LoopOptions::default() };
        assert_eq!(plain_trial_evaluations(&u, Misalignment, &chosen), 16 * scan_evaluations(&chosen) + 3 * plain);
        // The starts: the applied value first, then ±3 … 12 %, then 0.5–0.8 and 1.2–1.4 of it
        // (since session 68), the 1× kept at its ratio.
        let starts = coupled_starts(&switched_on(&m, Unbalance), &[Param::Misalignment2xN]);
        let forces: Vec<f64> = starts.iter().map(|t| Param::Misalignment2xN.get(t).unwrap()).collect();
        assert_eq!(forces.len(), 1 + COUPLED_SCALES.len() + WIDE_COUPLED_SCALES.len());
        assert_eq!(forces[0], 27.3);
        assert!((forces[1] - 0.88 * 27.3).abs() < 1e-9 && (forces[8] - 1.12 * 27.3).abs() < 1e-9, "{forces:?}");
        assert!((forces[9] - 0.5 * 27.3).abs() < 1e-9 && (forces[15] - 1.4 * 27.3).abs() < 1e-9, "{forces:?}");
        let mis = |t: &Machine| t.effects.misalignment.clone().unwrap();
        assert!(starts.iter().all(|t| (mis(t).force_1x_n / mis(t).force_2x_n - mis(&m).force_1x_n / mis(&m).force_2x_n).abs() < 1e-12 && t.effects.is_on(Unbalance)));
        // The count: sixteen plain trials with the option (the default, every start in full),
        // one without; sixteen grids and three plain trials with three chosen; sixteen plain
        // trials where the force is not scanned (no grid to choose by) or every start is kept
        // anyway.
        let (on, off) = (LoopOptions::default(), LoopOptions { coupled_forces: false, ..LoopOptions::default() });
        assert!(on.coupled_forces);
        let plain = plain_trial_evaluations(&m, Unbalance, &off);
        assert_eq!(plain_trial_evaluations(&m, Unbalance, &on), 16 * plain);
        assert_eq!(plain_trial_evaluations(&m, Unbalance, &chosen), 16 * scan_evaluations(&chosen) + 3 * plain);
        assert_eq!(plain_trial_evaluations(&m, Unbalance, &LoopOptions { coupled_refined_starts: 16, ..on.clone() }), 16 * plain);
        let unscanned = LoopOptions { scan_force_amplitudes: false, ..chosen.clone() };
        assert_eq!(plain_trial_evaluations(&m, Unbalance, &unscanned), 16 * plain_trial_evaluations(&m, Unbalance, &LoopOptions { coupled_forces: false, ..unscanned.clone() }));
        assert_eq!(plain_trial_evaluations(&m, LoadZone, &on), plain_trial_evaluations(&m, LoadZone, &off));
    }

    #[test]
    fn a_calibration_fits_an_applied_unbalance_and_misalignment_on_one_shaft_jointly() {
        use EffectKind::{Misalignment, Unbalance};
        let mut m = crate::model::preset("mfs_healthy").unwrap();
        m.effects.enable(Unbalance);
        m.effects.enable(Misalignment);
        let on = LoopOptions { refit_effects: vec![Unbalance, Misalignment], ..LoopOptions::default() };
        assert!(on.force_pair_grid, "the default since session 68");
        let pair = Some((Param::UnbalanceKgM, Param::Misalignment2xN));
        assert_eq!(calibrated_force_pair(&m, &calibration_parameters_for(&m, &on), &on), pair);
        // The grid's evaluations are counted in the calibration's.
        let off = LoopOptions { force_pair_grid: false, ..on.clone() };
        assert_eq!(calibrated_force_pair(&m, &calibration_parameters_for(&m, &off), &off), None);
        assert_eq!(calibration_evaluations(&m, &on), calibration_evaluations(&m, &off) + force_pair_evaluations());
        // Not while one of them is not re-fitted by the calibration (not yet applied by the loop).
        let one = LoopOptions { refit_effects: vec![Misalignment], ..on.clone() };
        assert_eq!(calibrated_force_pair(&m, &calibration_parameters_for(&m, &one), &one), None);
        // Nor on two shafts: no shared line.
        let mut apart = m.clone();
        apart.effects.misalignment.as_mut().unwrap().shaft = Some("gear".into());
        assert_eq!(calibrated_force_pair(&apart, &calibration_parameters_for(&apart, &on), &on), None);
        apart.effects.unbalance.as_mut().unwrap().shaft = Some("gear".into());
        assert_eq!(calibrated_force_pair(&apart, &calibration_parameters_for(&apart, &on), &on), pair);
    }

    #[test]
    fn a_coupled_trial_fits_in_full_the_starts_with_the_lowest_grid_minima_in_their_order() {
        assert_eq!(lowest_indices(&[5.0, 1.0, 4.0, 2.0, 3.0], 3), vec![1, 3, 4]);
        // Among equals the earlier start; a NaN (or +∞: no point evaluated) comes last.
        assert_eq!(lowest_indices(&[2.0, f64::NAN, 1.0, 2.0, f64::INFINITY], 2), vec![0, 2]);
        assert_eq!(lowest_indices(&[f64::NAN, f64::INFINITY, 7.0], 2), vec![0, 2]);
        assert_eq!(lowest_indices(&[1.0, 2.0], 3), vec![0, 1]);
        assert!(lowest_indices(&[], 3).is_empty());
        let opts = LoopOptions { coupled_refined_starts: 3, ..LoopOptions::default() };
        assert_eq!(refined_coupled_starts(9, &[Param::UnbalanceKgM], &LoopOptions::default()), None);
        assert_eq!(refined_coupled_starts(9, &[Param::UnbalanceKgM], &opts), Some(3));
        assert_eq!(refined_coupled_starts(3, &[Param::UnbalanceKgM], &opts), None);
        assert_eq!(refined_coupled_starts(9, &[], &opts), None);
        assert_eq!(refined_coupled_starts(9, &[Param::UnbalanceKgM], &LoopOptions { coupled_refined_starts: 0, ..opts }), None);
    }

    #[test]
    fn of_a_coupled_trials_fits_the_lowest_is_kept_and_a_failure_only_when_all_failed() {
        let (j0, floor) = (10.0, 2.0);
        let m = crate::model::preset("mfs_healthy").unwrap();
        let fit = |j: f64| -> TrialOutcome { Ok((trial(EffectKind::Unbalance, j0, floor, j, 50.0), m.clone())) };
        let failed = || -> TrialOutcome { Err("diverged".into()) };
        let kept = |v: Vec<TrialOutcome>| lowest_outcome(v).map(|(t, _)| t.objective_after);
        assert_eq!(kept(vec![fit(6.0), fit(3.0), failed(), fit(4.0)]).unwrap(), 3.0);
        assert_eq!(kept(vec![failed(), fit(5.0)]).unwrap(), 5.0);
        assert_eq!(kept(vec![failed(), failed()]).unwrap_err(), "diverged");
        assert!(kept(vec![]).is_err());
    }
}
