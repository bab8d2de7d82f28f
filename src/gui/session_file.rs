//! A saved session (`*.twinscope.json`): the measured signals by file path and channel with
//! their metadata edits, the chain as TOML, the model-loop machine as TOML with its history of
//! rounds, and a summary of the last results. Reopening reads the files again, so a session
//! stays small and the data stays where it is.

use super::jobs;
use super::session::{Origin, Session};
use crate::compare::Round;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format tag written into every session file.
pub const FORMAT: &str = "twinscope session 1";

/// A measured signal of a session: where to read it and the metadata as edited.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedSignal {
    /// The file (absent for the bundled demo recording).
    pub file: Option<PathBuf>,
    /// True for the bundled demo recording.
    #[serde(default)]
    pub bundled_demo: bool,
    /// Channel or variable name.
    pub channel: Option<String>,
    /// Sampling rate, Hz (as edited).
    pub fs_hz: f64,
    /// Shaft speed, Hz (as edited).
    pub shaft_speed_hz: Option<f64>,
    /// Catalogue bearing (as edited).
    pub bearing: Option<String>,
}

/// What had been computed when the session was saved (shown after reopening; not recomputed).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ResultsSummary {
    /// `chain <name> on <signal>` of the last analysis.
    pub analysis: Option<String>,
    /// The labelled envelope-spectrum peaks: `<f> Hz <label>`.
    #[serde(default)]
    pub peaks: Vec<String>,
    /// The last comparison: signals and the envelope NRMSE.
    pub comparison: Option<String>,
    /// The last missing-effect verdict.
    pub verdict: Option<String>,
    /// The ranked trials: `<effect>: objective a → b`.
    #[serde(default)]
    pub trials: Vec<String>,
    /// Simulated signals that were listed (not stored; simulate again to recreate them).
    #[serde(default)]
    pub simulated: Vec<String>,
}

/// A session file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionFile {
    /// Always [`FORMAT`].
    pub format: String,
    /// Measured signals in load order.
    pub signals: Vec<SavedSignal>,
    /// Index of the selected signal among them.
    pub selected: Option<usize>,
    /// The chain, as its TOML.
    pub chain_toml: String,
    /// The preset the model started from.
    pub machine_preset: String,
    /// The model-loop machine, as its TOML.
    pub machine_toml: String,
    /// The model loop's rounds.
    #[serde(default)]
    pub history: Vec<Round>,
    /// The effects the user asked the calibration to re-fit (`ModelState::refit_given`).
    #[serde(default)]
    pub refit: Vec<crate::model::EffectKind>,
    /// The last results, in words and numbers.
    #[serde(default)]
    pub results: ResultsSummary,
}

impl SessionFile {
    /// The session's savable part.
    pub fn from_session(s: &Session) -> Self {
        let measured: Vec<usize> = s.measured_indices();
        let signals = measured
            .iter()
            .map(|&i| {
                let e = &s.signals[i];
                let demo = e.file.is_none() && e.signal.meta.source.as_deref().is_some_and(|x| x.contains(jobs::DEMO_FILE));
                SavedSignal { file: e.file.clone(), bundled_demo: demo, channel: e.signal.meta.channel.clone(), fs_hz: e.signal.fs_hz, shaft_speed_hz: e.signal.meta.shaft_speed_hz, bearing: e.signal.meta.bearing.clone() }
            })
            .collect();
        let selected = s.selected.and_then(|sel| measured.iter().position(|&i| i == sel));
        let mut results = ResultsSummary::default();
        if let Some(a) = &s.analysis {
            results.analysis = Some(format!("chain {} on {}", a.chain.name, a.signal_name));
            results.peaks = a.peaks.iter().map(|p| format!("{:.2} Hz {}", p.frequency_hz, p.label())).collect();
        }
        if let Some(c) = &s.comparison {
            results.comparison = Some(format!("{} vs {}: envelope NRMSE {:.1} %", c.measured, c.simulated, c.comparison.envelope_nrmse()));
        }
        if let Some(r) = &s.model.result {
            results.verdict = Some(r.diagnosis.verdict.clone());
            results.trials = r.diagnosis.trials.iter().map(|t| format!("{}: objective {:.1} → {:.1}, envelope NRMSE {:.1} → {:.1} %", t.label(), t.objective_before, t.objective_after, t.envelope_nrmse_before, t.envelope_nrmse_after)).collect();
        }
        results.simulated = s.signals.iter().filter(|e| matches!(e.origin, Origin::Simulated { .. })).map(|e| e.signal.name.clone()).collect();
        SessionFile {
            format: FORMAT.into(),
            signals,
            selected,
            chain_toml: s.chain.to_toml(),
            machine_preset: s.model.preset.clone(),
            machine_toml: s.model.machine.to_toml(),
            history: s.model.history.clone(),
            refit: s.model.refit_given.clone(),
            results,
        }
    }

    /// Writes the session as pretty JSON.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        let text = serde_json::to_string_pretty(self).map_err(|e| format!("{}: cannot encode the session ({e})", path.display()))?;
        std::fs::write(path, text).map_err(|e| format!("{}: cannot write ({e})", path.display()))
    }

    /// Reads and checks a session file: the format tag, the chain TOML and the machine TOML
    /// (errors name the file and the part).
    pub fn load(path: &Path) -> Result<SessionFile, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read ({e})", path.display()))?;
        let f: SessionFile = serde_json::from_str(&text).map_err(|e| format!("{}: not a twinscope session ({e})", path.display()))?;
        if f.format != FORMAT {
            return Err(format!("{}: session format `{}`; this version reads `{FORMAT}`", path.display(), f.format));
        }
        crate::chain::Chain::from_toml(&f.chain_toml, &format!("{} (chain_toml)", path.display())).map_err(|e| e.to_string())?;
        let m = crate::model::Machine::from_toml(&f.machine_toml, &format!("{} (machine_toml)", path.display())).map_err(|e| e.to_string())?;
        m.validate().map_err(|e| format!("{} (machine_toml): {e}", path.display()))?;
        Ok(f)
    }
}
