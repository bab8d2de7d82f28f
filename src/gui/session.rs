//! The runtime session: what is loaded and computed now. Nothing here is persisted (that is
//! [`super::settings::Settings`]); everything here is library data, drawn by the views.

use crate::chain::{Chain, ChainResult};
use crate::compare::{Comparison, CompareOptions, Diagnosis, LoopOptions, ResidualMap, Round};
use crate::dsp::scf::ScfMap;
use crate::model::{EffectKind, Machine};
use crate::dsp::remez::FirDesign;
use crate::dsp::spectrum::Spectrum;
use crate::kinematics::{CharacteristicFrequency, LabelledPeak, MarkerLine};
use crate::signal::io::ChannelInfo;
use crate::signal::Signal;
use std::path::PathBuf;

/// Where a signal came from.
#[derive(Debug, Clone, PartialEq)]
pub enum Origin {
    /// Read from a file.
    Measured,
    /// Simulated from a machine preset.
    Simulated {
        /// Machine preset name.
        preset: String,
    },
}

impl Origin {
    /// `measured` or `simulated`.
    pub fn word(&self) -> &'static str {
        match self {
            Origin::Measured => "measured",
            Origin::Simulated { .. } => "simulated",
        }
    }
}

/// One signal of the session.
#[derive(Debug, Clone)]
pub struct SignalEntry {
    /// Session-unique id.
    pub id: u64,
    /// The signal (samples, fs, unit, metadata).
    pub signal: Signal,
    /// Measured or simulated.
    pub origin: Origin,
    /// The file it was read from (None for simulations and the embedded demo).
    pub file: Option<PathBuf>,
    /// The file's channels/variables, for the channel chooser.
    pub channels: Vec<ChannelInfo>,
    /// Line families known from the machine beyond the bearing (e.g. GMF of a simulated
    /// gearbox), used for markers and peak labels.
    pub machine_families: Vec<CharacteristicFrequency>,
}

impl SignalEntry {
    /// Display name: the signal's name, with its file name when read from a file.
    pub fn title(&self) -> String {
        self.signal.name.clone()
    }
}

/// The FIR of a bandpass stage with its magnitude response.
#[derive(Debug, Clone)]
pub struct FirView {
    /// Stage name.
    pub stage: String,
    /// The design (taps, spec, achieved figures).
    pub design: FirDesign,
    /// Frequencies of the response, Hz.
    pub frequency_hz: Vec<f64>,
    /// Magnitude response, dB.
    pub magnitude_db: Vec<f64>,
}

/// One chain run on one signal, with the spectra the views draw.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// Id of the analysed signal.
    pub signal_id: u64,
    /// Its name.
    pub signal_name: String,
    /// The chain that ran.
    pub chain: Chain,
    /// Every intermediate result.
    pub result: ChainResult,
    /// Amplitude spectrum of the chain input.
    pub spectrum: Option<Spectrum>,
    /// Welch PSD of the chain input.
    pub psd: Option<Spectrum>,
    /// The envelope spectrum (the chain's `envelope_spectrum` stage, else its last spectrum),
    /// with the stage name.
    pub envelope: Option<(String, Spectrum)>,
    /// Largest envelope-spectrum peaks with their labels.
    pub peaks: Vec<LabelledPeak>,
    /// Characteristic lines up to Nyquist.
    pub markers: Vec<MarkerLine>,
    /// Line families used for labels.
    pub families: Vec<CharacteristicFrequency>,
    /// Shaft speed, Hz.
    pub shaft_speed_hz: Option<f64>,
    /// Bandpass designs of the chain.
    pub firs: Vec<FirView>,
    /// Seconds the job took.
    pub seconds: f64,
}

/// A model-vs-measurement comparison.
#[derive(Debug, Clone)]
pub struct CompareResult {
    /// Measured signal name.
    pub measured: String,
    /// Simulated signal name.
    pub simulated: String,
    /// Options used.
    pub options: CompareOptions,
    /// The comparison.
    pub comparison: Comparison,
    /// Where the error lives.
    pub residual: ResidualMap,
}

/// A "Find missing effect" answer: the calibrated machine and the ranked trials.
#[derive(Debug, Clone)]
pub struct LoopResult {
    /// The measured signal it was run against.
    pub measured: String,
    /// The options used.
    pub options: LoopOptions,
    /// The machine the search started from.
    pub started_from: Machine,
    /// The machine after calibration (the trials were run on it; Add applies to it).
    pub calibrated: Machine,
    /// The ranking, evidence and verdict.
    pub diagnosis: Diagnosis,
    /// Effects added from this ranking so far.
    pub added: Vec<EffectKind>,
    /// Seconds the search took.
    pub seconds: f64,
    /// The applied effect re-fitted from the uncalibrated values before this search (a re-fit
    /// by hand, [`ModelState::start_refit`]); None for a plain search.
    pub refitted: Option<EffectKind>,
}

/// The model of the model loop: the machine being edited, its last diagnosis and the history
/// of rounds.
#[derive(Debug, Clone)]
pub struct ModelState {
    /// The preset the machine started from.
    pub preset: String,
    /// The current machine (always valid: edits that fail `validate()` are not taken).
    pub machine: Machine,
    /// Bumped whenever the machine is replaced from outside the editor (preset, Add, calibration).
    pub revision: u64,
    /// The last "Find missing effect" answer.
    pub result: Option<LoopResult>,
    /// Envelope NRMSE and objective over rounds (`compare::Round`, as `run_loop` keeps it).
    pub history: Vec<Round>,
    /// Id of the loop's last simulated signal (replaced by the next simulation).
    pub simulated_id: Option<u64>,
    /// A replacement tried by hand, waiting for the search of its model.
    pub pending_replacement: Option<PendingReplacement>,
    /// Replacements (taken out, put in) tried by hand and not kept: not offered again. A
    /// refused re-fit is recorded as (effect, effect).
    pub refused_replacements: Vec<(EffectKind, EffectKind)>,
    /// The machine the first search of the history started from: the uncalibrated values a
    /// re-fit by hand starts from ([`ModelState::start_refit`]).
    pub loop_start: Option<Machine>,
    /// Effects on in the machine the user asked every search's calibration to re-fit, as
    /// `diagnose --refit` (those the history applied are re-fitted anyway): to go on from a
    /// machine a loop saved. On a new start, the `fitted_effects` its machine file names
    /// (none for a preset).
    pub refit_given: Vec<EffectKind>,
}

/// The loop's replacement step done by hand ([`ModelState::start_replacement`]): `added` in
/// place of `removed` in the calibrated machine of the stuck search, judged when the search
/// of `swapped` comes back, as `compare::run_loop` judges its own. A re-fit by hand
/// ([`ModelState::start_refit`]) has `removed == added` and no `swapped`: its model is fitted
/// on the worker, and the search that comes back says which effect it re-fitted.
#[derive(Debug, Clone)]
pub struct PendingReplacement {
    /// The effect taken out.
    pub removed: EffectKind,
    /// The effect put in its place.
    pub added: EffectKind,
    /// The model the replacement's search runs on (None for a re-fit).
    pub swapped: Option<Machine>,
    /// The stuck search, restored when the replacement is not kept.
    pub stuck: Box<LoopResult>,
    /// Index in the history of the stuck search's round.
    pub stuck_round: usize,
}

impl ModelState {
    /// The model state for a bundled preset.
    pub fn from_preset(name: &str) -> Result<Self, String> {
        let machine = crate::model::preset(name).map_err(|e| e.to_string())?;
        machine.validate().map_err(|e| e.to_string())?;
        Ok(Self::of_machine(name, machine))
    }

    /// A new start from `machine` (checked by the caller), named `label` (a preset's name or a
    /// file's): no search, no rounds.
    /// The effects a loop that saved `machine` fitted ([`Machine::fitted_effects`]) become the
    /// ticked "re-fit" boxes ([`ModelState::refit_given`]), which say from then on what is re-fitted.
    pub fn of_machine(label: &str, mut machine: Machine) -> Self {
        let refit_given = std::mem::take(&mut machine.fitted_effects);
        Self { preset: label.into(), machine, revision: 1, result: None, history: Vec::new(), simulated_id: None, pending_replacement: None, refused_replacements: Vec::new(), loop_start: None, refit_given }
    }

    /// The machine as "Save machine…" writes it: with the effects every search re-fits
    /// ([`ModelState::refit_effects`]) as its `fitted_effects`, so that a loop going on from the
    /// file (`diagnose --machine`, "Open machine…") re-fits them too.
    pub fn machine_to_save(&self) -> Machine {
        let mut m = self.machine.clone();
        m.fitted_effects = self.refit_effects().into_iter().filter(|k| crate::compare::calibrate::refit_refusal(&m, *k).is_none()).collect();
        m
    }

    /// Starts again from `fresh` (a preset's or a file's new start), keeping the revision
    /// counting up and the simulated signal's id; returns how many rounds were cleared.
    pub fn start_again(&mut self, fresh: ModelState) -> usize {
        let cleared = self.history.len();
        *self = ModelState { revision: self.revision + 1, simulated_id: self.simulated_id, ..fresh };
        cleared
    }

    /// The effects a search's calibration re-fits: those the user asked for
    /// ([`ModelState::refit_given`]) that the machine has on, and those the history applied (as
    /// `run_loop` does; `compare::diagnose::refit_to_go_on`), with a pending replacement's swap.
    pub fn refit_effects(&self) -> Vec<EffectKind> {
        let given: Vec<EffectKind> = self.refit_given.iter().copied().filter(|k| self.machine.effects.is_on(*k)).collect();
        let mut on = crate::compare::diagnose::refit_to_go_on(&self.history, &given);
        if let Some(p) = &self.pending_replacement {
            on.retain(|k| *k != p.removed);
            on.push(p.added);
        }
        on
    }

    /// The effects replacements took out (kept ones in the history, and a pending one): a
    /// search does not try them again (`compare::diagnose::exclude_candidates`).
    pub fn taken_out(&self) -> Vec<EffectKind> {
        self.history.iter().filter(|r| !r.refitted()).filter_map(|r| r.removed).chain(self.pending_replacement.as_ref().filter(|p| p.removed != p.added).map(|p| p.removed)).collect()
    }

    /// The replacements to offer under the last search (`compare::diagnose::replacement_proposals`)
    /// when it was run on the current machine, less those already refused.
    pub fn replacement_proposals(&self) -> Vec<(EffectKind, EffectKind)> {
        let Some(r) = self.result.as_ref().filter(|r| r.started_from == self.machine) else { return Vec::new() };
        crate::compare::diagnose::replacement_proposals(&self.history, &self.machine, &r.diagnosis, &r.options).into_iter().filter(|x| !self.refused_replacements.contains(x)).collect()
    }

    /// The applied effects to offer for a re-fit from the uncalibrated values under the last
    /// search (`compare::diagnose::refit_proposals`) when it was run on the current machine,
    /// less those already refused.
    pub fn refit_proposals(&self) -> Vec<EffectKind> {
        let Some(r) = self.result.as_ref().filter(|r| r.started_from == self.machine) else { return Vec::new() };
        crate::compare::diagnose::refit_proposals(&self.history, &self.machine, &r.diagnosis, &r.options).into_iter().filter(|k| !self.refused_replacements.contains(&(*k, *k))).collect()
    }

    /// Starts the re-fit of the applied effect `a` from the uncalibrated values (the loop's
    /// step of `LoopOptions::refit_when_stuck`, by hand): returns the last search's calibrated
    /// machine and the uncalibrated start ([`ModelState::loop_start`], else the preset), which
    /// the caller hands to `compare::diagnose::refit_from_uncalibrated` and then searches; the
    /// answer is judged as a replacement ([`ModelState::take_result`]). Err when there is no
    /// search or no start (nothing changed).
    pub fn start_refit(&mut self, a: EffectKind) -> Result<(Machine, Machine), String> {
        let Some(r) = self.result.as_ref() else { return Err("no ranking yet: run Find missing effect first".into()) };
        if !r.calibrated.effects.is_on(a) {
            return Err(format!("{} is not in the model: nothing to re-fit", a.name()));
        }
        let start = match &self.loop_start {
            Some(m) => m.clone(),
            None => crate::model::preset(&self.preset).map_err(|e| format!("{} not re-fitted: no uncalibrated start ({e})", a.name()))?,
        };
        let stuck_round = self.history.len().saturating_sub(1);
        self.pending_replacement = Some(PendingReplacement { removed: a, added: a, swapped: None, stuck: Box::new(r.clone()), stuck_round });
        Ok((r.calibrated.clone(), start))
    }

    /// Starts the replacement of `removed` by `added` in the last search's calibrated machine:
    /// the machine becomes the swapped one, which the caller then searches. Err when there is
    /// no search or the swapped machine is invalid (nothing changed).
    pub fn start_replacement(&mut self, removed: EffectKind, added: EffectKind) -> Result<(), String> {
        let Some(r) = self.result.as_ref() else { return Err("no ranking yet: run Find missing effect first".into()) };
        let swapped = crate::compare::diagnose::swap_effect(&r.calibrated, removed, added).map_err(|e| format!("{} in place of {} not tried: {e}", added.name(), removed.name()))?;
        let stuck_round = self.history.len().saturating_sub(1);
        self.pending_replacement = Some(PendingReplacement { removed, added, swapped: Some(swapped.clone()), stuck: Box::new(r.clone()), stuck_round });
        self.replace_machine(swapped);
        Ok(())
    }

    /// Takes a search's answer: a pending replacement is judged first
    /// (`compare::diagnose::judge_replacement`, the loop's own rule). Kept, it is recorded on
    /// the stuck round and the answer starts the next round; not kept, the note goes on the
    /// stuck round and the stuck model and its search come back. Otherwise the answer
    /// calibrates the last round (the same model again) or starts a new one. Returns what to
    /// tell the user.
    pub fn take_result(&mut self, r: LoopResult) -> Vec<(Level, String)> {
        use crate::compare::diagnose::{effect_values, judge_replacement, replacements_refused_text};
        let mut said = Vec::new();
        if let Some(p) = self.pending_replacement.take() {
            let refit = p.removed == p.added;
            let ours = match &p.swapped {
                Some(swapped) => r.started_from == *swapped && r.refitted.is_none(),
                None => r.refitted == Some(p.added),
            };
            if !ours {
                let what = if refit { format!("the re-fit of {}", p.added.name()) } else { format!("the replacement of {} by {}", p.removed.name(), p.added.name()) };
                said.push((Level::Info, format!("{what} was not judged: the search ran on another model")));
            } else {
                let j = judge_replacement(&p.stuck.diagnosis, p.removed, p.added, &r.calibrated, &r.diagnosis);
                let stuck = self.history.get_mut(p.stuck_round);
                if !j.kept() {
                    let note = replacements_refused_text(std::slice::from_ref(&j)).unwrap_or_default();
                    said.push((Level::Info, format!("{} not kept ({note}); back to the model before it", if refit { "re-fit" } else { "replacement" })));
                    if let Some(round) = stuck {
                        round.verdict = format!("{}; {note}", round.verdict);
                    }
                    self.refused_replacements.push((p.removed, p.added));
                    self.replace_machine(p.stuck.started_from.clone());
                    self.result = Some(*p.stuck);
                    return said;
                }
                said.push((Level::Info, format!("{} kept: {}", if refit { "re-fit" } else { "replacement" }, j.kept_text())));
                if let Some(round) = stuck {
                    round.verdict = format!("{}; {}", round.verdict, j.kept_text());
                    round.applied = Some(p.added);
                    round.removed = Some(p.removed);
                    round.applied_values = effect_values(&r.calibrated, p.added);
                }
                if refit {
                    // The machine stayed the stuck one while the worker fitted the new one.
                    self.replace_machine(r.started_from.clone());
                }
            }
        }
        let d = &r.diagnosis;
        said.push((Level::Info, format!("find missing effect ({:.0} s): {}", r.seconds, d.verdict)));
        for (k, why) in &d.failed_trials {
            said.push((Level::Error, format!("find missing effect: {} not ranked, its trial failed: {why}", k.name())));
        }
        let env = d.envelope_nrmse().unwrap_or(f64::NAN);
        if self.history.is_empty() {
            self.loop_start = Some(r.started_from.clone());
        }
        let effects_on = r.started_from.effects.enabled();
        let round = Round::of_diagnosis(self.history.len() + 1, effects_on.clone(), d, env);
        match self.history.last_mut() {
            // The same model again (after an Add, or a re-run): this search calibrates it.
            Some(last) if last.applied.is_none() && last.effects_on == effects_on => *last = Round { round: last.round, ..round },
            _ => self.history.push(round),
        }
        self.result = Some(r);
        said
    }

    /// Replaces the machine from outside the editor.
    pub fn replace_machine(&mut self, m: Machine) {
        self.machine = m;
        self.revision += 1;
    }
}

/// A cyclic spectral correlation map with where it came from.
#[derive(Debug, Clone)]
pub struct ScfResult {
    /// Name of the analysed signal.
    pub signal_name: String,
    /// What was analysed (`raw` or `stage <name> of chain <chain>`).
    pub source: String,
    /// Unit of the analysed signal (the SCF is in unit²/Hz).
    pub unit: String,
    /// The map.
    pub map: ScfMap,
    /// Line families for the α picks (shaft, bearing fault lines).
    pub families: Vec<CharacteristicFrequency>,
    /// Shaft speed, Hz.
    pub shaft_speed_hz: Option<f64>,
    /// Seconds the job took.
    pub seconds: f64,
}

/// What jobs send back.
#[derive(Debug)]
pub enum JobOutput {
    /// A signal to add (`replace` = the id of an entry it replaces, e.g. another channel).
    Signal { entry: Box<SignalEntry>, replace: Option<u64>, select: bool },
    /// A finished analysis.
    Analysis(Box<Analysis>),
    /// A finished comparison.
    Comparison(Box<CompareResult>),
    /// A chain read from a file.
    Chain(Chain, String),
    /// A file picked in a dialog, with what it is for.
    Picked(Purpose, PathBuf),
    /// A "Find missing effect" answer.
    Loop(Box<LoopResult>),
    /// A cyclic spectral correlation map.
    Scf(Box<ScfResult>),
    /// A session file read back (applied by the app).
    SessionFile(Box<super::session_file::SessionFile>, PathBuf),
    /// The demodulation band a measured signal's kurtogram chose (the signal's name, the band).
    DemodulationBand(String, crate::dsp::kurtogram::KurtogramBand),

    /// Something worth telling the user that is not an error.
    Info(String),
}

/// Why a file dialog was opened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// Open a signal file.
    OpenSignal,
    /// Open a chain TOML.
    OpenChain,
    /// Save the chain as TOML.
    SaveChain,
    /// Save the session.
    SaveSession,
    /// Open a session.
    OpenSession,
    /// Open a machine TOML for the model loop.
    OpenMachine,
    /// Save the model loop's machine as TOML.
    SaveMachine,
    /// Export the shown data as CSV.
    ExportCsv,
    /// Export the shown plot as SVG.
    ExportSvg,
    /// Export the window as PNG.
    ExportPng,
}

/// Severity of a status message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// Something finished.
    Info,
    /// Something failed; nothing loaded was lost.
    Error,
}

/// A line of the status area.
#[derive(Debug, Clone)]
pub struct StatusMessage {
    /// Severity.
    pub level: Level,
    /// Text, naming the file or parameter.
    pub text: String,
}

/// Everything loaded and computed in this run of the workbench.
#[derive(Debug, Clone)]
pub struct Session {
    /// Measured and simulated signals, in load order.
    pub signals: Vec<SignalEntry>,
    /// Index of the selected signal.
    pub selected: Option<usize>,
    /// The chain being edited and run.
    pub chain: Chain,
    /// Bumped whenever the chain is replaced from outside the editor (preset, file).
    pub chain_revision: u64,
    /// The last analysis.
    pub analysis: Option<Analysis>,
    /// The last comparison.
    pub comparison: Option<CompareResult>,
    /// Status messages, oldest first (the last few are shown).
    pub messages: Vec<StatusMessage>,
    /// The model loop's machine, diagnosis and history.
    pub model: ModelState,
    /// The last SCF map.
    pub scf: Option<ScfResult>,
    /// The results summary of a reopened session (what was computed when it was saved).
    pub restored_summary: Option<super::session_file::ResultsSummary>,
    next_id: u64,
}

impl Session {
    /// An empty session with `chain`.
    pub fn new(chain: Chain, model: ModelState) -> Self {
        Self { signals: Vec::new(), selected: None, chain, chain_revision: 1, analysis: None, comparison: None, messages: Vec::new(), model, scf: None, restored_summary: None, next_id: 1 }
    }

    /// A fresh signal id.
    pub fn next_signal_id(&mut self) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        id
    }

    /// The selected signal.
    pub fn selected_signal(&self) -> Option<&SignalEntry> {
        self.selected.and_then(|i| self.signals.get(i))
    }

    /// Names of the time-domain stages of the last chain run, if it ran on the selected signal
    /// (the views offer them as sources beside the raw signal).
    pub fn time_stages_of_selected(&self) -> Vec<String> {
        self.analysis
            .as_ref()
            .filter(|a| Some(a.signal_id) == self.selected_signal().map(|e| e.id))
            .map(|a| a.result.stages.iter().filter(|s| matches!(s.data, crate::chain::Data::Time(_))).map(|s| s.name.clone()).collect())
            .unwrap_or_default()
    }

    /// Adds a status message.
    pub fn tell(&mut self, level: Level, text: impl Into<String>) {
        self.messages.push(StatusMessage { level, text: text.into() });
        if self.messages.len() > 50 {
            self.messages.remove(0);
        }
    }

    /// The last error message, if the last message is an error.
    pub fn last_error(&self) -> Option<&str> {
        self.messages.iter().rev().find(|m| m.level == Level::Error).map(|m| m.text.as_str())
    }

    /// Indices of the measured signals.
    pub fn measured_indices(&self) -> Vec<usize> {
        self.signals.iter().enumerate().filter(|(_, s)| s.origin == Origin::Measured).map(|(i, _)| i).collect()
    }

    /// Replaces the chain (from a preset or a file).
    pub fn replace_chain(&mut self, chain: Chain) {
        self.chain = chain;
        self.chain_revision += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::EffectKind::{CasingModes, Misalignment, Unbalance};

    /// A search answer on `m` with calibrated objective `j`, floor 3.3 and seed scatter 0.2
    /// (tie band 2√2 × 0.2 = 0.57), no trial significant.
    fn answer(m: &Machine, j: f64) -> LoopResult {
        let mut diagnosis = Diagnosis { floor_objective: 3.3, objective_scatter: 0.2, verdict: "nothing significant is missing".into(), ..Default::default() };
        diagnosis.calibration.objective_after = j;
        LoopResult { measured: "measured".into(), options: LoopOptions::default(), started_from: m.clone(), calibrated: m.clone(), diagnosis, added: vec![], seconds: 1.0, refitted: None }
    }

    #[test]
    fn a_re_fit_asked_for_joins_the_applied_effects_while_its_effect_is_on() {
        use crate::model::EffectKind::Noise;
        let mut m = crate::model::preset("mfs_healthy").unwrap();
        m.effects.enable(Unbalance);
        m.effects.enable(Misalignment);
        let mut s = ModelState::of_machine("go1.toml", m);
        assert!(s.refit_effects().is_empty() && s.refit_given.is_empty(), "a new start re-fits nothing it was not told to");
        s.refit_given = vec![Unbalance, Misalignment];
        assert_eq!(s.refit_effects(), vec![Unbalance, Misalignment]);
        // Switched off in the machine: no longer re-fitted (the calibration would refuse it).
        s.machine.effects.disable(Misalignment);
        assert_eq!(s.refit_effects(), vec![Unbalance]);
        // What the rounds applied comes after, once.
        s.history.push(Round { round: 1, applied: Some(Noise), ..Default::default() });
        s.history.push(Round { round: 2, applied: Some(Unbalance), ..Default::default() });
        assert_eq!(s.refit_effects(), vec![Unbalance, Noise]);
        // Saved, the machine names what every search re-fits and it has on; opened, those are ticked.
        assert_eq!(s.machine_to_save().fitted_effects, vec![Unbalance], "the noise the rounds applied is not on in this machine");
        s.machine.effects.enable(Noise);
        let saved = s.machine_to_save();
        assert_eq!(saved.fitted_effects, vec![Unbalance, Noise]);
        assert!(s.machine.fitted_effects.is_empty(), "the boxes, not the machine, say what is re-fitted");
        let opened = ModelState::of_machine("go2.toml", saved);
        assert_eq!((opened.refit_given.as_slice(), opened.machine.fitted_effects.as_slice()), (&[Unbalance, Noise][..], &[][..]));
        // A new start forgets them.
        let fresh = ModelState::from_preset("mfs_inner").unwrap();
        s.start_again(fresh);
        assert!(s.refit_given.is_empty());
    }

    /// Round 1 applied an unbalance with a misalignment close behind; round 2 is stuck at 17.9.
    fn stuck_state() -> (ModelState, Machine) {
        let mut s = ModelState::from_preset("mfs_inner").unwrap();
        let mut m = s.machine.clone();
        let before = m.effects.enabled();
        m.effects.enable(Unbalance);
        s.history = vec![
            Round { round: 1, effects_on: before, applied: Some(Unbalance), ranking: vec![(Unbalance, 10.0, 0.6), (Misalignment, 10.5, 0.5), (CasingModes, 12.0, 0.1)], ..Default::default() },
            Round { round: 2, effects_on: m.effects.enabled(), verdict: "nothing significant is missing".into(), ..Default::default() },
        ];
        s.replace_machine(m.clone());
        s.result = Some(answer(&m, 17.9));
        (s, m)
    }

    #[test]
    fn a_replacement_by_hand_is_judged_by_the_loop_rule_and_undone_when_not_kept() {
        let (mut s, stuck) = stuck_state();
        assert_eq!(s.replacement_proposals(), vec![(Unbalance, Misalignment)]);
        s.start_replacement(Unbalance, Misalignment).unwrap();
        let swapped = s.machine.clone();
        assert!(swapped.effects.is_on(Misalignment) && !swapped.effects.is_on(Unbalance));
        assert_eq!(s.refit_effects(), vec![Misalignment]);
        assert_eq!(s.taken_out(), vec![Unbalance], "the replacement's search does not try the unbalance again");
        // 17.5 is lower, but within the seed scatter of 17.9: not kept, and everything comes back.
        let said = s.take_result(answer(&swapped, 17.5));
        assert!(said.iter().any(|(_, t)| t.contains("replacement not kept") && t.contains("misalignment in place of unbalance reaches 17.50")), "{said:?}");
        assert_eq!(s.machine, stuck);
        assert_eq!(s.result.as_ref().unwrap().started_from, stuck);
        assert_eq!(s.history.len(), 2);
        assert_eq!((s.history[1].applied, s.history[1].removed), (None, None));
        assert!(s.history[1].verdict.contains("replacements tried, none below 17.90"), "{}", s.history[1].verdict);
        assert_eq!(s.refit_effects(), vec![Unbalance]);
        assert_eq!(s.taken_out(), vec![], "refused, nothing was taken out");
        // Not offered again.
        assert_eq!(s.replacement_proposals(), vec![]);
    }

    #[test]
    fn a_replacement_by_hand_that_clears_the_scatter_is_kept_and_starts_the_next_round() {
        let (mut s, _) = stuck_state();
        s.start_replacement(Unbalance, Misalignment).unwrap();
        let swapped = s.machine.clone();
        let said = s.take_result(answer(&swapped, 15.0));
        assert!(said.iter().any(|(_, t)| t.contains("replacement kept") && t.contains("15.00 against 17.90")), "{said:?}");
        assert_eq!(s.machine, swapped);
        assert_eq!(s.history.len(), 3);
        assert_eq!((s.history[1].applied, s.history[1].removed), (Some(Misalignment), Some(Unbalance)));
        assert!(!s.history[1].applied_values.is_empty());
        assert_eq!(s.history[2].objective, 15.0);
        assert_eq!(s.refit_effects(), vec![Misalignment]);
        assert_eq!(s.taken_out(), vec![Unbalance], "kept: the searches after it do not try the unbalance again");
        // A search on another model does not judge the replacement.
        let (mut s, stuck) = stuck_state();
        s.start_replacement(Unbalance, Misalignment).unwrap();
        let said = s.take_result(answer(&stuck, 15.0));
        assert!(said.iter().any(|(_, t)| t.contains("was not judged")), "{said:?}");
        assert_eq!((s.history[1].applied, s.history[1].removed), (None, None));
    }

    #[test]
    fn a_refit_by_hand_is_judged_as_a_replacement_and_only_on_its_own_search() {
        let (mut s, stuck) = stuck_state();
        assert_eq!(s.refit_proposals(), vec![Unbalance]);
        // No search of the history recorded its start here: the preset is the uncalibrated start.
        let (cal, start) = s.start_refit(Unbalance).unwrap();
        assert_eq!((cal, start.name.clone()), (stuck.clone(), crate::model::preset("mfs_inner").unwrap().name));
        assert_eq!(s.machine, stuck, "the machine changes only when the re-fit is kept");
        assert_eq!(s.taken_out(), vec![], "a re-fit takes nothing out");
        assert_eq!(s.refit_effects(), vec![Unbalance]);
        // Another search (no re-fit) is not judged as the re-fit.
        let said = s.take_result(answer(&stuck, 15.0));
        assert!(said.iter().any(|(_, t)| t.contains("the re-fit of unbalance was not judged")), "{said:?}");
        // Refused: within the scatter of 17.9; the stuck model comes back and it is not offered again.
        let (mut s, stuck) = stuck_state();
        s.start_refit(Unbalance).unwrap();
        let mut refitted = stuck.clone();
        crate::compare::Param::UnbalanceKgM.set(&mut refitted, 2e-4);
        let said = s.take_result(LoopResult { refitted: Some(Unbalance), ..answer(&refitted, 17.5) });
        assert!(said.iter().any(|(_, t)| t.contains("re-fit not kept") && t.contains("unbalance re-fitted from the uncalibrated values reaches 17.50")), "{said:?}");
        assert_eq!(s.machine, stuck);
        assert_eq!(s.history.len(), 2);
        assert_eq!(s.refit_proposals(), vec![]);
        // Kept: the re-fitted model is the machine, the stuck round records the re-fit.
        let (mut s, _) = stuck_state();
        s.start_refit(Unbalance).unwrap();
        let said = s.take_result(LoopResult { refitted: Some(Unbalance), ..answer(&refitted, 15.0) });
        assert!(said.iter().any(|(_, t)| t.contains("re-fit kept") && t.contains("15.00 against 17.90")), "{said:?}");
        assert_eq!(s.machine, refitted);
        assert_eq!(s.history.len(), 3);
        assert!(s.history[1].refitted() && s.history[1].applied == Some(Unbalance));
        assert_eq!(s.history[1].applied_values, vec![(crate::compare::Param::UnbalanceKgM, 2e-4)]);
        assert_eq!(s.taken_out(), vec![]);
        assert_eq!(s.refit_effects(), vec![Unbalance]);
    }

    #[test]
    fn the_first_search_of_a_history_is_the_uncalibrated_start_of_a_refit() {
        let mut s = ModelState::from_preset("mfs_inner").unwrap();
        let mut first = s.machine.clone();
        crate::compare::Param::ResonanceHz.set(&mut first, 1234.0);
        s.take_result(answer(&first, 10.0));
        assert_eq!(s.loop_start.as_ref(), Some(&first));
        let mut second = first.clone();
        second.effects.enable(Unbalance);
        s.take_result(answer(&second, 9.0));
        assert_eq!(s.loop_start.as_ref(), Some(&first), "later searches leave it");
        s.result.as_mut().unwrap().calibrated = second.clone();
        let (_, start) = s.start_refit(Unbalance).unwrap();
        assert_eq!(start, first);
        assert!(s.start_refit(Misalignment).is_err(), "an effect not in the model is no re-fit");
    }
}
