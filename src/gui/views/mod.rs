//! Views: each draws library results from the [`Session`] and answers with at most one
//! [`Command`] per frame; the app carries the command out (jobs, session changes). A new tab
//! (3D SCF, model loop, ...) is one more type implementing [`View`], registered in
//! [`super::app::Workbench::new`].

pub mod chain;
pub mod compare;
pub mod filter;
pub mod signals;
pub mod spectra;
pub mod time;

use super::session::Session;
use super::settings::Settings;
use crate::chain::Chain;
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
    /// Simulate a machine preset.
    Simulate(String),
    /// Compare a measured with a simulated signal (indices).
    Compare { measured: usize, simulated: usize },
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
