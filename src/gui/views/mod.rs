//! Views: each draws library results from the [`Session`] and answers with at most one
//! [`Command`] per frame; the app carries the command out (jobs, session changes). A new tab
//! (3D SCF, model loop, ...) is one more type implementing [`View`], registered in
//! [`super::app::Workbench::new`].

pub mod chain;
pub mod compare;
pub mod filter;
pub mod model_loop;
pub mod scf;
pub mod signals;
pub mod spectra;
pub mod time;

use super::session::{Purpose, Session};
use super::settings::Settings;
use crate::chain::Chain;
use crate::dsp::scf::ScfParams;
use crate::model::{EffectKind, Machine};
use crate::signal::export::PlotData;
use std::path::PathBuf;

/// What a view asks the app to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Open a signal file in a dialog.
    OpenSignalDialog,
    /// Load a signal file (default channel).
    OpenSignal(PathBuf),
    /// Load another channel of the selected signal's file, replacing it.
    LoadChannel { index: usize, channel: String },
    /// Select a signal.
    Select(usize),
    /// Remove a signal from the session.
    Remove(usize),
    /// Set the metadata of a signal.
    SetMetadata { index: usize, fs_hz: f64, shaft_speed_hz: Option<f64>, bearing: Option<String> },
    /// Replace the chain by an edited one.
    SetChain(Chain),
    /// Set the chain's bandpass stage to the most impulsive band of measured signal `index`
    /// that holds a resonance of the model (its kurtogram; `compare::demodulation_band`).
    BandFromKurtogram(usize),
    /// Load a bundled chain preset.
    ChainPreset(String),
    /// Open a chain TOML in a dialog / from a path.
    OpenChainDialog,
    /// Read a chain TOML.
    OpenChain(PathBuf),
    /// Save the chain in a dialog / to a path.
    SaveChainDialog,
    /// Write the chain TOML.
    SaveChain(PathBuf),
    /// Run the chain on the selected signal.
    RunChain,
    /// Compare a measured with a simulated signal (indices).
    Compare { measured: usize, simulated: usize },
    /// Model loop: start again from a bundled machine preset.
    LoadMachinePreset(String),
    /// Model loop: start again from a machine TOML (as `diagnose --machine` reads and
    /// `--save-machine` writes).
    OpenMachine(PathBuf),
    /// Model loop: write the current machine as TOML.
    SaveMachine(PathBuf),
    /// Model loop: take an edited (valid) machine.
    SetMachine(Box<Machine>),
    /// Model loop: whether every search's calibration re-fits `effect`, which the machine has
    /// on, as `diagnose --refit` ([`crate::gui::session::ModelState::refit_given`]).
    SetRefit { effect: EffectKind, refit: bool },
    /// Model loop: take the calibrated machine of the last search.
    UseCalibrated,
    /// Model loop: simulate the current machine, then compare it with a measured signal.
    SimulateModel { measured: Option<usize> },
    /// Model loop: calibrate and rank the missing effects against a measured signal.
    FindMissingEffect { measured: usize },
    /// Model loop: apply a ranked trial (`trial`, its index in the ranking, of `effect`) to the
    /// calibrated machine, re-simulate and re-compare.
    AddTrial { effect: EffectKind, trial: usize, measured: Option<usize> },
    /// Model loop, when stuck: switch `remove` off and `add` on in the calibrated machine and
    /// search again against `measured`.
    ReplaceEffect { remove: EffectKind, add: EffectKind, measured: usize },
    /// Model loop, when stuck: fit the applied `effect` anew from the uncalibrated values and
    /// search again against `measured`.
    RefitEffect { effect: EffectKind, measured: usize },
    /// Compute the SCF of the selected signal (`raw`) or of a time-domain stage of the last run.
    ComputeScf { source: String, params: ScfParams },
    /// Open a file dialog for a purpose (sessions, exports).
    Dialog(Purpose),
    /// Save the session to a path.
    SaveSession(PathBuf),
    /// Reopen a session from a path.
    OpenSession(PathBuf),
    /// Write the shown data of the active view as CSV.
    ExportCsv(PathBuf),
    /// Write the shown plot of the active view as SVG.
    ExportSvg(PathBuf),
    /// Write the window as PNG (on the next rendered frame).
    ExportPng(PathBuf),
    /// Cancel a job.
    Cancel(u64),
    /// Change the persisted preferences.
    SetSettings(Settings),
    /// Clear the status messages.
    ClearMessages,
}

/// A tab of the central area.
pub trait View {
    /// The tab title.
    fn title(&self) -> &'static str;
    /// Draws the session's results; returns what the user asked for.
    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, settings: &Settings) -> Option<Command>;
    /// The data the view shows, for CSV/SVG export (`None`: nothing to export).
    fn plot_data(&self, _session: &Session, _settings: &Settings) -> Option<PlotData> {
        None
    }
}

/// Library text made drawable with egui's bundled fonts, which lack arrows: `→` becomes `->`.
pub fn drawable(s: &str) -> String {
    s.replace('→', "->")
}

/// The unit of a model parameter from its name (units are in the names), for display.
pub fn unit_of(name: &str) -> &'static str {
    let n = name.rsplit('.').next().unwrap_or(name);
    if n.ends_with("_hz") {
        "Hz"
    } else if n.ends_with("_kg_m") {
        "kg·m"
    } else if n.ends_with("_m") {
        "m"
    } else if n.ends_with("_n") {
        "N"
    } else if n.ends_with("_db") {
        "dB"
    } else if n.ends_with("_percent") {
        "%"
    } else {
        ""
    }
}

/// `value` with its unit, or `-`.
pub fn fmt_opt(v: Option<f64>, digits: usize, unit: &str) -> String {
    v.map(|x| format!("{x:.digits$} {unit}").trim_end().to_string()).unwrap_or_else(|| "-".into())
}

/// A compact number for tables (engineering-like: 3 significant digits, exponent when small).
pub fn fmt_num(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}
