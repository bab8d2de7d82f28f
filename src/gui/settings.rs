//! Persisted preferences (a small TOML file), kept apart from the runtime
//! [`Session`](super::session::Session): what the analyst chose last time, not what is loaded.

use crate::compare::{CompareOptions, LoopOptions};
use crate::kinematics::PeakLabelling;
use crate::model::EffectKind;
use crate::signal::display::AmplitudeScale;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The workbench's preferences.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    /// Chain preset loaded at start when there is no demo.
    pub chain_preset: String,
    /// Machine preset offered for simulation.
    pub machine_preset: String,
    /// Vertical scale of the spectra.
    pub spectrum_scale: AmplitudeScale,
    /// Draw characteristic-frequency markers.
    pub show_markers: bool,
    /// Draw the ± shaft sidebands of the markers.
    pub show_sidebands: bool,
    /// Harmonics drawn per family.
    pub marker_harmonics: u32,
    /// Peaks listed in the peak table.
    pub peak_count: usize,
    /// Label tolerance, % of the line frequency.
    pub label_tolerance_percent: f64,
    /// Files opened recently, newest first.
    pub recent_files: Vec<PathBuf>,
    /// Directory of the last file dialog.
    pub last_dir: Option<PathBuf>,
    /// Model loop: simulated (and compared) duration of each model evaluation, s.
    pub loop_fit_duration_s: f64,
    /// Model loop: golden-section evaluations per parameter and sweep.
    pub loop_evaluations_per_parameter: usize,
    /// Model loop: coordinate-descent sweeps of the calibration.
    pub loop_sweeps: usize,
    /// Model loop: the effects the search may try; empty = every applicable effect the model lacks.
    pub loop_candidates: Vec<EffectKind>,
    /// Model loop: also start the trials from the uncalibrated values when the calibration pins
    /// a parameter at the edge of its range (`LoopOptions::unbend_pinned`).
    pub loop_unbend_pinned: bool,
    /// Model loop: also start every trial from the uncalibrated values, pinned or not
    /// (`LoopOptions::uncalibrated_start`, experimental).
    pub loop_uncalibrated_start: bool,
    /// Model loop: transfer-path correction bands (`CompareOptions::path_correction_bands`;
    /// 0 = off).
    pub loop_path_correction_bands: usize,
    /// Model loop: model realisations averaged per evaluation (`LoopOptions::realisations`).
    pub loop_realisations: usize,
    /// Model loop: realisations of the second look when a random effect leads a search with one
    /// (`LoopOptions::random_effect_realisations`; 0 = off).
    pub loop_random_effect_realisations: usize,
    /// Model loop: the floor margin of the decision (`LoopOptions::floor_margin`).
    pub loop_floor_margin: f64,
    /// Model loop: the near-floor rule of the decision (`LoopOptions::near_floor_rule`,
    /// experimental).
    pub loop_near_floor_rule: bool,
    /// Model loop: the plain trial scans a periodic force's amplitude on a grid
    /// (`LoopOptions::scan_force_amplitudes`, on by default).
    pub loop_scan_force_amplitudes: bool,
    /// Model loop: a stuck diagnosis is done again unbent (`LoopOptions::unbend_when_stuck`,
    /// on by default since session 31).
    pub loop_unbend_when_stuck: bool,
    /// Model loop: a diagnosis whose best trial explains under half the error above the floor
    /// is done again unbent (`LoopOptions::unbend_when_short`, experimental).
    pub loop_unbend_when_short: bool,
    /// Model loop: the chosen effect's strength gets the range the data cannot tell from it
    /// (`LoopOptions::strength_range`, off by default).
    pub loop_strength_range: bool,
    /// Model loop: after the search, each part of the starting model is taken out and the rest
    /// calibrated again (`LoopOptions::removal_trials`, off by default).
    pub loop_removal_trials: bool,
    /// Model loop: the best three stage-1 trials also start from the uncalibrated values
    /// before stage 2 (`LoopOptions::uncalibrated_start_top`, on by default since session 48).
    pub loop_uncalibrated_start_top: bool,
    /// Model loop: a periodic force's amplitude is fitted with twice the line-search
    /// evaluations (`LoopOptions::fine_forces`, on by default).
    pub loop_fine_forces: bool,
    /// Model loop: a scanned force's amplitude also gets a second grid inside the coarse
    /// grid's best cell, kept when it ends lower (`LoopOptions::fine_force_scan`,
    /// experimental).
    pub loop_fine_force_scan: bool,
    /// Model loop: under the floor margin, a best trial is a finding only when switching its
    /// effect off again in its own fit costs at least the significance share
    /// (`LoopOptions::effect_must_work`, decision (d), on by default since session 57).
    pub loop_effect_must_work: bool,
    /// Model loop: the sensor roll-off's trial re-does the calibration with it, as the casing
    /// mode's does (`LoopOptions::recalibrate_roll_off`, experimental).
    pub loop_recalibrate_roll_off: bool,
    /// Model loop: a stuck search tries its three best single trials in pairs
    /// (`LoopOptions::joint_trials`, experimental).
    pub loop_joint_trials: bool,
    /// Model loop: an unbalance or misalignment trial beside the other, applied on its shaft,
    /// fits the two together (`LoopOptions::coupled_forces`, on since session 64).
    pub loop_coupled_forces: bool,
    /// Model loop: a round's calibration also fits an applied unbalance and misalignment on one
    /// shaft jointly on a grid of their amplitudes (`LoopOptions::force_pair_grid`, on since
    /// session 68).
    pub loop_force_pair_grid: bool,
    /// Model loop: sweeps of local line searches after every full-range fit
    /// (`LoopOptions::polish_sweeps`; 0 = off, 4 by default since session 44).
    pub loop_polish_sweeps: usize,
    /// Model loop: the polish also acts on an unbent trial's second start
    /// (`LoopOptions::polish_second_starts`; off by default since session 44).
    pub loop_polish_second_starts: bool,
    /// Model loop: every SCF α-slice normalised by the measured SCF over all compared slices
    /// (`CompareOptions::scf_one_normaliser` of the loop; on by default since session 44).
    pub loop_scf_one_normaliser: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            chain_preset: "envelope_cwru".into(),
            machine_preset: "cwru_6205_inner".into(),
            spectrum_scale: AmplitudeScale::Linear,
            show_markers: true,
            show_sidebands: true,
            marker_harmonics: 5,
            peak_count: 10,
            label_tolerance_percent: 1.0,
            recent_files: Vec::new(),
            last_dir: None,
            loop_fit_duration_s: LoopOptions::default().fit_duration_s,
            loop_evaluations_per_parameter: LoopOptions::default().evaluations_per_parameter,
            loop_sweeps: LoopOptions::default().sweeps,
            loop_candidates: Vec::new(),
            loop_unbend_pinned: true,
            loop_uncalibrated_start: LoopOptions::default().uncalibrated_start,
            loop_path_correction_bands: 0,
            loop_realisations: LoopOptions::default().realisations,
            loop_random_effect_realisations: LoopOptions::default().random_effect_realisations,
            loop_floor_margin: LoopOptions::default().floor_margin,
            loop_near_floor_rule: LoopOptions::default().near_floor_rule,
            loop_scan_force_amplitudes: LoopOptions::default().scan_force_amplitudes,
            loop_unbend_when_stuck: LoopOptions::default().unbend_when_stuck,
            loop_unbend_when_short: LoopOptions::default().unbend_when_short,
            loop_strength_range: LoopOptions::default().strength_range,
            loop_removal_trials: LoopOptions::default().removal_trials,
            loop_uncalibrated_start_top: LoopOptions::default().uncalibrated_start_top,
            loop_fine_forces: LoopOptions::default().fine_forces,
            loop_fine_force_scan: LoopOptions::default().fine_force_scan,
            loop_effect_must_work: LoopOptions::default().effect_must_work,
            loop_recalibrate_roll_off: LoopOptions::default().recalibrate_roll_off,
            loop_joint_trials: LoopOptions::default().joint_trials,
            loop_coupled_forces: LoopOptions::default().coupled_forces,
            loop_force_pair_grid: LoopOptions::default().force_pair_grid,
            loop_polish_sweeps: LoopOptions::default().polish_sweeps,
            loop_polish_second_starts: LoopOptions::default().polish_second_starts,
            loop_scf_one_normaliser: LoopOptions::default().compare.scf_one_normaliser,
        }
    }
}

impl Settings {
    /// The default settings file: `$XDG_CONFIG_HOME/twinscope/settings.toml`, else
    /// `$HOME/.config/twinscope/settings.toml`.
    pub fn default_path() -> Option<PathBuf> {
        let base = std::env::var_os("XDG_CONFIG_HOME").map(PathBuf::from).or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config")))?;
        Some(base.join("twinscope").join("settings.toml"))
    }

    /// Reads the settings; a missing file gives the defaults, a broken one the defaults and
    /// a message naming the file.
    pub fn load(path: &Path) -> (Settings, Option<String>) {
        match std::fs::read_to_string(path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => (Settings::default(), None),
            Err(e) => (Settings::default(), Some(format!("{}: cannot read settings ({e}); using defaults", path.display()))),
            Ok(text) => match toml::from_str(&text) {
                Ok(s) => (s, None),
                Err(e) => (Settings::default(), Some(format!("{}: bad settings ({}); using defaults", path.display(), e.message()))),
            },
        }
    }

    /// Writes the settings, creating the directory.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let text = toml::to_string(self).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Remembers a file as recently opened (newest first, at most 10).
    pub fn remember(&mut self, path: &Path) {
        self.recent_files.retain(|p| p != path);
        self.recent_files.insert(0, path.to_path_buf());
        self.recent_files.truncate(10);
        if let Some(d) = path.parent() {
            self.last_dir = Some(d.to_path_buf());
        }
    }

    /// The loop options from these settings, comparing with `compare` (the chain's band), as
    /// they are: [`LoopOptions::validate`] refuses a value out of range (a stale stored one),
    /// naming it, before any work.
    pub fn loop_options(&self, compare: CompareOptions) -> LoopOptions {
        LoopOptions {
            compare: CompareOptions { path_correction_bands: self.loop_path_correction_bands, scf_one_normaliser: self.loop_scf_one_normaliser, ..compare },
            fit_duration_s: self.loop_fit_duration_s,
            evaluations_per_parameter: self.loop_evaluations_per_parameter,
            sweeps: self.loop_sweeps,
            candidates: self.loop_candidates.clone(),
            unbend_pinned: self.loop_unbend_pinned,
            uncalibrated_start: self.loop_uncalibrated_start,
            realisations: self.loop_realisations,
            random_effect_realisations: self.loop_random_effect_realisations,
            floor_margin: self.loop_floor_margin,
            near_floor_rule: self.loop_near_floor_rule,
            scan_force_amplitudes: self.loop_scan_force_amplitudes,
            unbend_when_stuck: self.loop_unbend_when_stuck,
            unbend_when_short: self.loop_unbend_when_short,
            strength_range: self.loop_strength_range,
            removal_trials: self.loop_removal_trials,
            uncalibrated_start_top: self.loop_uncalibrated_start_top,
            fine_forces: self.loop_fine_forces,
            fine_force_scan: self.loop_fine_force_scan,
            effect_must_work: self.loop_effect_must_work,
            recalibrate_roll_off: self.loop_recalibrate_roll_off,
            joint_trials: self.loop_joint_trials,
            coupled_forces: self.loop_coupled_forces,
            force_pair_grid: self.loop_force_pair_grid,
            polish_sweeps: self.loop_polish_sweeps,
            polish_second_starts: self.loop_polish_second_starts,
            ..Default::default()
        }
    }

    /// Puts every search setting of the model loop (`loop_*`) back to its default, the
    /// library's, keeping the effects chosen to try (`loop_candidates`) and everything
    /// else: a settings file saved under an older default keeps its values until then.
    pub fn reset_search_settings(&mut self) {
        let kept = std::mem::take(self);
        *self = Settings {
            chain_preset: kept.chain_preset,
            machine_preset: kept.machine_preset,
            spectrum_scale: kept.spectrum_scale,
            show_markers: kept.show_markers,
            show_sidebands: kept.show_sidebands,
            marker_harmonics: kept.marker_harmonics,
            peak_count: kept.peak_count,
            label_tolerance_percent: kept.label_tolerance_percent,
            recent_files: kept.recent_files,
            last_dir: kept.last_dir,
            loop_candidates: kept.loop_candidates,
            ..Settings::default()
        };
    }

    /// The peak-labelling settings (batch defaults, with the table size and tolerance).
    pub fn labelling(&self) -> PeakLabelling {
        PeakLabelling { peaks: self.peak_count.max(1), tolerance_percent: self.label_tolerance_percent, ..Default::default() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A settings value with every field away from its default (the test below checks that,
    /// so a new field must be set here too).
    fn everything_changed() -> Settings {
        Settings {
            chain_preset: "other_chain".into(),
            machine_preset: "mfs_inner".into(),
            spectrum_scale: AmplitudeScale::Log10,
            show_markers: false,
            show_sidebands: false,
            marker_harmonics: 3,
            peak_count: 7,
            label_tolerance_percent: 2.5,
            recent_files: vec![PathBuf::from("/data/105.mat")],
            last_dir: Some(PathBuf::from("/data")),
            loop_fit_duration_s: 0.7,
            loop_evaluations_per_parameter: 5,
            loop_sweeps: 1,
            loop_candidates: vec![EffectKind::LoadZone],
            loop_unbend_pinned: false,
            loop_uncalibrated_start: true,
            loop_path_correction_bands: 16,
            loop_realisations: 2,
            loop_random_effect_realisations: 0,
            loop_floor_margin: 0.5,
            loop_near_floor_rule: true,
            loop_scan_force_amplitudes: false,
            loop_unbend_when_stuck: false,
            loop_unbend_when_short: true,
            loop_strength_range: true,
            loop_removal_trials: true,
            loop_uncalibrated_start_top: false,
            loop_fine_forces: false,
            loop_fine_force_scan: true,
            loop_effect_must_work: !LoopOptions::default().effect_must_work,
            loop_recalibrate_roll_off: !LoopOptions::default().recalibrate_roll_off,
            loop_joint_trials: !LoopOptions::default().joint_trials,
            loop_coupled_forces: !LoopOptions::default().coupled_forces,
            loop_force_pair_grid: !LoopOptions::default().force_pair_grid,
            loop_polish_sweeps: 0,
            loop_polish_second_starts: true,
            loop_scf_one_normaliser: false,
        }
    }

    #[test]
    fn resetting_the_search_settings_restores_every_loop_default_and_keeps_the_rest() {
        let fields = |s: &Settings| match serde_json::to_value(s).unwrap() {
            serde_json::Value::Object(m) => m,
            _ => unreachable!(),
        };
        let (before, default) = (fields(&everything_changed()), fields(&Settings::default()));
        for (k, v) in &before {
            assert_ne!(Some(v), default.get(k), "`{k}` is at its default in the changed settings");
        }
        let mut s = everything_changed();
        s.reset_search_settings();
        let after = fields(&s);
        for (k, v) in &after {
            let expected = if k.starts_with("loop_") && k != "loop_candidates" { &default[k] } else { &before[k] };
            assert_eq!(v, expected, "`{k}` after the reset");
        }
        // What the search is given: the library's options, the candidates kept.
        let compare = CompareOptions::default();
        assert_eq!(s.loop_options(compare.clone()), LoopOptions { candidates: vec![EffectKind::LoadZone], ..Settings::default().loop_options(compare) });
        assert_eq!(Settings::default().loop_options(LoopOptions::default().compare), LoopOptions::default());
        // The decision switches reach the search (they are not in `LoopOptions::validate`'s way).
        let changed = everything_changed().loop_options(CompareOptions::default());
        assert_ne!(changed.effect_must_work, LoopOptions::default().effect_must_work);
        assert_ne!(changed.recalibrate_roll_off, LoopOptions::default().recalibrate_roll_off);
        assert_ne!(changed.joint_trials, LoopOptions::default().joint_trials);
        assert_ne!(changed.coupled_forces, LoopOptions::default().coupled_forces);
        assert_ne!(changed.force_pair_grid, LoopOptions::default().force_pair_grid);
    }
}
