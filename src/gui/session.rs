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
}

impl ModelState {
    /// The model state for a bundled preset.
    pub fn from_preset(name: &str) -> Result<Self, String> {
        let machine = crate::model::preset(name).map_err(|e| e.to_string())?;
        machine.validate().map_err(|e| e.to_string())?;
        Ok(Self { preset: name.into(), machine, revision: 1, result: None, history: Vec::new(), simulated_id: None })
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
