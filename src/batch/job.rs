//! The batch job file (TOML).

use super::BatchError;
use crate::chain::{self, Chain};
use crate::kinematics::{lookup_bearing, BearingGeometry};
use crate::signal::io::LoadOptions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A batch job. See README.md, "Batch jobs".
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Job {
    /// Job name (default: the file stem).
    #[serde(default)]
    pub name: String,
    /// What to read.
    pub input: InputSpec,
    /// Machine knowledge (bearing, shaft speed).
    #[serde(default)]
    pub machine: MachineSpec,
    /// The chain to run.
    pub chain: ChainSpec,
    /// What to write.
    #[serde(default)]
    pub output: OutputSpec,
    /// Close the loop on every input: compare with a model, find the missing effect, apply it,
    /// repeat (`[model_loop]`, optional).
    #[serde(default)]
    pub model_loop: Option<LoopSpec>,
    /// The job file (set when read from disk); relative paths are taken from its directory.
    #[serde(skip)]
    pub path: Option<PathBuf>,
}

/// Inputs: files, directories (every .wav/.csv/.mat inside) or glob patterns, and/or
/// simulated signals.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Paths, directories or globs, relative to the job file.
    #[serde(default)]
    pub paths: Vec<String>,
    /// Simulations whose output is an input like a file (`[[input.simulate]]`).
    #[serde(default)]
    pub simulate: Vec<SimulateSpec>,
    /// Channel or variable (see `twinscope info`).
    #[serde(default)]
    pub channel: Option<String>,
    /// Sampling rate override in Hz.
    #[serde(default)]
    pub fs_hz: Option<f64>,
    /// Physical unit override.
    #[serde(default)]
    pub unit: Option<String>,
}

/// A `simulate` step: a machine (file or preset) with optional overrides.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulateSpec {
    /// Machine description (TOML), relative to the job file.
    #[serde(default)]
    pub machine: Option<String>,
    /// A bundled machine preset (see `twinscope presets`).
    #[serde(default)]
    pub preset: Option<String>,
    /// Duration override, s.
    #[serde(default)]
    pub duration_s: Option<f64>,
    /// Seed override.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Effects to switch on with default parameters.
    #[serde(default)]
    pub with: Vec<String>,
    /// Effects to switch off.
    #[serde(default)]
    pub without: Vec<String>,
    /// Also write the simulated signal (.wav or .csv), relative to the output directory.
    #[serde(default)]
    pub save: Option<String>,
}

/// One input of a job.
#[derive(Debug, Clone)]
pub enum InputSource {
    /// A file.
    File(PathBuf),
    /// A simulated signal (index into `input.simulate`).
    Simulated(usize),
}

impl InputSource {
    /// A name for messages and output directories.
    pub fn display_name(&self, job: &Job) -> String {
        match self {
            InputSource::File(p) => p.display().to_string(),
            InputSource::Simulated(i) => {
                let s = &job.input.simulate[*i];
                format!("simulate[{i}] {}", s.preset.clone().or_else(|| s.machine.clone()).unwrap_or_default())
            }
        }
    }

    /// The output directory stem.
    pub fn stem(&self, job: &Job) -> String {
        match self {
            InputSource::File(p) => p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "input".into()),
            InputSource::Simulated(i) => {
                let s = &job.input.simulate[*i];
                let base = s.preset.clone().or_else(|| s.machine.as_ref().and_then(|m| Path::new(m).file_stem().map(|x| x.to_string_lossy().into_owned()))).unwrap_or_else(|| "machine".into());
                format!("sim_{base}")
            }
        }
    }
}

/// A machine from a TOML file (relative to `base_dir`) or a preset, with effects switched on
/// and off; `at` prefixes every message with the job key at fault.
fn build_machine(machine: &Option<String>, preset: &Option<String>, with: &[String], without: &[String], base_dir: &Path, at: &dyn Fn(String) -> String) -> Result<crate::model::Machine, String> {
    use crate::model::{self, EffectKind, Machine};
    let mut m = match (machine, preset) {
        (Some(f), None) => {
            let path = base_dir.join(f);
            let text = std::fs::read_to_string(&path).map_err(|e| at(format!("`machine` {}: {e}", path.display())))?;
            Machine::from_toml(&text, &path.display().to_string()).map_err(|e| at(e.to_string()))?
        }
        (None, Some(p)) => model::preset(p).map_err(|e| at(e.to_string()))?,
        _ => return Err(at("give exactly one of `machine` and `preset`".into())),
    };
    for (list, on) in [(with, true), (without, false)] {
        for name in list.iter() {
            let k = EffectKind::parse_named(name).map_err(at)?;
            if on {
                m.effects.enable(k)
            } else {
                m.effects.disable(k)
            }
        }
    }
    Ok(m)
}

impl SimulateSpec {
    /// The machine with the overrides applied.
    pub fn machine(&self, base_dir: &Path, index: usize) -> Result<crate::model::Machine, String> {
        let at = |m: String| format!("`input.simulate[{index}]`: {m}");
        let mut m = build_machine(&self.machine, &self.preset, &self.with, &self.without, base_dir, &at)?;
        if let Some(d) = self.duration_s {
            m.duration_s = d;
        }
        if let Some(s) = self.seed {
            m.seed = s;
        }
        m.validate().map_err(|e| at(e.to_string()))?;
        Ok(m)
    }
}

/// `[model_loop]`: every input is compared with a machine model, calibrated, searched for the
/// missing effect, the best effect applied, and again, for up to `rounds` rounds or until
/// nothing significant is missing (`compare::run_loop`); every round's metrics are kept.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoopSpec {
    /// Machine description (TOML), relative to the job file.
    pub machine: Option<String>,
    /// A bundled machine preset (see `twinscope presets`).
    pub preset: Option<String>,
    /// Effects on at the start (e.g. `noise`: every measurement is noisy).
    pub with: Vec<String>,
    /// Effects off at the start.
    pub without: Vec<String>,
    /// Rounds, 1–20. Default 3.
    pub rounds: usize,
    /// Demodulation band of the envelope comparison, Hz. Default: the chain's first bandpass
    /// stage, else 900–1800 Hz.
    pub band_hz: Option<[f64; 2]>,
    /// Demodulate each input in its most impulsive band that holds a resonance of the starting
    /// machine, from its kurtogram (`compare::demodulation_band`; the CLI's
    /// `--band-from-kurtogram`), instead of `band_hz` or the chain's. Default false.
    pub band_from_kurtogram: bool,
    /// Effects the search may try. Default: every applicable effect the model lacks.
    pub candidates: Vec<String>,
    /// Effects on in the starting machine whose parameters the calibration re-fits, as the
    /// loop re-fits those it applies itself: for a machine an earlier loop saved
    /// (`compare::calibrate::check_refit_effects`). Default: none.
    pub refit: Vec<String>,
    /// Model time simulated per evaluation, s (0.2–60, `compare::FIT_DURATION_RANGE_S`).
    /// Default: the library's.
    pub fit_duration_s: f64,
    /// When the calibration pins a parameter, also start the trials from the uncalibrated
    /// values (`LoopOptions::unbend_pinned`). Default: the library's.
    pub unbend_pinned: bool,
    /// Also start every trial from the uncalibrated values, pinned or not
    /// (`LoopOptions::uncalibrated_start`, experimental). Default: the library's.
    pub uncalibrated_start: bool,
    /// A stuck round with no kept replacement also re-fits each applied effect from the
    /// uncalibrated values (`LoopOptions::refit_when_stuck`). Default: the library's.
    pub refit_when_stuck: bool,
    /// The experimental near-floor rule (`LoopOptions::near_floor_rule`). Default: the
    /// library's.
    pub near_floor_rule: bool,
    /// The plain trial scans a periodic force's amplitude on a grid
    /// (`LoopOptions::scan_force_amplitudes`). Default: the library's.
    pub scan_force_amplitudes: bool,
    /// A stuck diagnosis whose calibration pins nothing is done again unbent
    /// (`LoopOptions::unbend_when_stuck`). Default: the library's.
    pub unbend_when_stuck: bool,
    /// A diagnosis whose significant best trial explains under half the error above the floor
    /// is done again unbent (`LoopOptions::unbend_when_short`, experimental). Default: the
    /// library's.
    pub unbend_when_short: bool,
    /// The best three stage-1 trials also start from the uncalibrated values before stage 2
    /// (`LoopOptions::uncalibrated_start_top`). Default: the library's (on since session 48).
    pub uncalibrated_start_top: bool,
    /// A periodic force's amplitude is fitted with twice the line-search evaluations
    /// (`LoopOptions::fine_forces`). Default: the library's.
    pub fine_forces: bool,
    /// Sweeps of local line searches after every full-range fit (`LoopOptions::polish_sweeps`),
    /// 0–8. Default: the library's.
    pub polish_sweeps: usize,
    /// The polish also acts on the second start of an unbent trial
    /// (`LoopOptions::polish_second_starts`). Default: the library's.
    pub polish_second_starts: bool,
    /// Transfer-path correction on this many log-spaced PSD bands, fitted to every evaluation
    /// (`CompareOptions::path_correction_bands`), 0–64 (0 = off). Default: the library's.
    pub path_correction_bands: usize,
    /// Every SCF α-slice normalised by the measured SCF over all compared slices
    /// (`CompareOptions::scf_one_normaliser`); off, each by its own range.
    /// Default: the library's.
    pub scf_one_normaliser: bool,
    /// The significance test (`LoopOptions::decision_rule`): `"floor_margin"` or `"scatter"`
    /// (experimental). Default: the library's.
    pub decision_rule: crate::compare::DecisionRule,
    /// The floor margin of `"floor_margin"` (`LoopOptions::floor_margin`), ≥ 0. Default: the
    /// library's.
    pub floor_margin: f64,
    /// Model realisations averaged per evaluation (`LoopOptions::realisations`), 1–16.
    /// Default: the library's.
    pub realisations: usize,
    /// Realisations of the second look when a random effect leads a one-realisation search
    /// (`LoopOptions::random_effect_realisations`), 0 (off) to 16. Default: the library's.
    pub random_effect_realisations: usize,
    /// The chosen effect's strength gets the range the data cannot tell from its fitted value
    /// (`LoopOptions::strength_range`; in `model_loop.json`). Default: the library's (off).
    pub strength_range: bool,
    /// After the search, each part of the starting model (a bearing's fault, an effect that is
    /// on but the noise) is taken out and the rest calibrated again: contradicted, needed or
    /// cannot tell (`LoopOptions::removal_trials`; in `model_loop.json`). Default: the
    /// library's (off).
    pub removal_trials: bool,
    /// With removal trials, a round that reads a part contradicted takes it out before adding
    /// what its search chose (`LoopOptions::take_out_first`). Default: the library's.
    pub take_out_first: bool,
    /// With removal trials, the realisations each trial's two models are calibrated on, 0 to
    /// 16 (`LoopOptions::removal_fit_realisations`; 0: as many as they are judged on).
    /// Default: the library's.
    pub removal_fit_realisations: usize,
    /// A scanned force's amplitude also gets a second grid inside the coarse grid's best cell,
    /// kept when its golden section ends lower (`LoopOptions::fine_force_scan`,
    /// experimental). Default: the library's (off).
    pub fine_force_scan: bool,
    /// Under the floor-margin rule a best trial is a finding only when switching its effect
    /// off again in its own fit costs at least the significance share
    /// (`LoopOptions::effect_must_work`, decision (d)). Default: the library's (on since
    /// session 57).
    pub effect_must_work: bool,
    /// The sensor roll-off's trial re-does the calibration with it, as the casing mode's does
    /// (`LoopOptions::recalibrate_roll_off`, experimental). Default: the library's (off).
    pub recalibrate_roll_off: bool,
    /// A stuck search tries its three best single trials in pairs
    /// (`LoopOptions::joint_trials`, experimental). Default: the library's (off).
    pub joint_trials: bool,
    /// The trial of an unbalance or a misalignment beside the other, applied on the same
    /// shaft, fits the two together (`LoopOptions::coupled_forces`). Default: the library's
    /// (on since session 64).
    pub coupled_forces: bool,
    /// Of a coupled trial's starts, how many are fitted in full after each start's grid
    /// (`LoopOptions::coupled_refined_starts`, experimental; 0: every start). Default: the
    /// library's (0).
    pub coupled_refined_starts: usize,
    /// A round's calibration also fits an applied unbalance and misalignment on one shaft
    /// jointly on a grid of their amplitudes (`LoopOptions::force_pair_grid`). Default: the
    /// library's (on since session 68).
    pub force_pair_grid: bool,
}

impl Default for LoopSpec {
    /// No machine yet, three rounds, and every search option the library's
    /// (`LoopOptions::default()`), so a job and the command line start from the same search.
    fn default() -> Self {
        let o = crate::compare::LoopOptions::default();
        Self {
            machine: None,
            preset: None,
            with: Vec::new(),
            without: Vec::new(),
            rounds: 3,
            band_hz: None,
            band_from_kurtogram: false,
            candidates: Vec::new(),
            refit: Vec::new(),
            fit_duration_s: o.fit_duration_s,
            unbend_pinned: o.unbend_pinned,
            uncalibrated_start: o.uncalibrated_start,
            refit_when_stuck: o.refit_when_stuck,
            near_floor_rule: o.near_floor_rule,
            scan_force_amplitudes: o.scan_force_amplitudes,
            unbend_when_stuck: o.unbend_when_stuck,
            unbend_when_short: o.unbend_when_short,
            uncalibrated_start_top: o.uncalibrated_start_top,
            fine_forces: o.fine_forces,
            polish_sweeps: o.polish_sweeps,
            polish_second_starts: o.polish_second_starts,
            path_correction_bands: o.compare.path_correction_bands,
            scf_one_normaliser: o.compare.scf_one_normaliser,
            decision_rule: o.decision_rule,
            floor_margin: o.floor_margin,
            realisations: o.realisations,
            random_effect_realisations: o.random_effect_realisations,
            strength_range: o.strength_range,
            removal_trials: o.removal_trials,
            take_out_first: o.take_out_first,
            removal_fit_realisations: o.removal_fit_realisations,
            fine_force_scan: o.fine_force_scan,
            effect_must_work: o.effect_must_work,
            recalibrate_roll_off: o.recalibrate_roll_off,
            joint_trials: o.joint_trials,
            coupled_forces: o.coupled_forces,
            coupled_refined_starts: o.coupled_refined_starts,
            force_pair_grid: o.force_pair_grid,
        }
    }
}

impl LoopSpec {
    /// The starting model.
    pub fn machine(&self, base_dir: &Path) -> Result<crate::model::Machine, String> {
        let at = |m: String| format!("`model_loop`: {m}");
        let m = build_machine(&self.machine, &self.preset, &self.with, &self.without, base_dir, &at)?;
        m.validate().map_err(|e| at(e.to_string()))?;
        Ok(m)
    }

    /// The loop options; the demodulation band defaults to the chain's first bandpass stage.
    pub fn options(&self, chain: &Chain) -> Result<crate::compare::LoopOptions, String> {
        use crate::model::EffectKind;
        crate::compare::check_loop_rounds(self.rounds).map_err(|e| format!("`model_loop`: {e}"))?;
        let mut o = crate::compare::LoopOptions { fit_duration_s: self.fit_duration_s, unbend_pinned: self.unbend_pinned, uncalibrated_start: self.uncalibrated_start, refit_when_stuck: self.refit_when_stuck, near_floor_rule: self.near_floor_rule, scan_force_amplitudes: self.scan_force_amplitudes, unbend_when_stuck: self.unbend_when_stuck, unbend_when_short: self.unbend_when_short, uncalibrated_start_top: self.uncalibrated_start_top, fine_forces: self.fine_forces, polish_sweeps: self.polish_sweeps, polish_second_starts: self.polish_second_starts, decision_rule: self.decision_rule, floor_margin: self.floor_margin, realisations: self.realisations, random_effect_realisations: self.random_effect_realisations, strength_range: self.strength_range, removal_trials: self.removal_trials, take_out_first: self.take_out_first, removal_fit_realisations: self.removal_fit_realisations, fine_force_scan: self.fine_force_scan, effect_must_work: self.effect_must_work, recalibrate_roll_off: self.recalibrate_roll_off, joint_trials: self.joint_trials, coupled_forces: self.coupled_forces, coupled_refined_starts: self.coupled_refined_starts, force_pair_grid: self.force_pair_grid, ..Default::default() };
        o.compare.path_correction_bands = self.path_correction_bands;
        o.compare.scf_one_normaliser = self.scf_one_normaliser;
        o.validate().map_err(|e| format!("`model_loop`: {e}"))?;
        let chain_band = chain.stages.iter().find_map(|s| match &s.op {
            chain::Op::Bandpass(b) => Some(b.pass_band_hz),
            _ => None,
        });
        if self.band_from_kurtogram && self.band_hz.is_some() {
            return Err("`model_loop`: give `band_hz` or `band_from_kurtogram = true`, not both".into());
        }
        if let Some([lo, hi]) = self.band_hz.or(chain_band) {
            if !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo < hi) {
                return Err(format!("`model_loop.band_hz` = [{lo}, {hi}]: must be two frequencies in Hz, 0 < low < high"));
            }
            o.compare.envelope_band_hz = [lo, hi];
        }
        o.candidates = self
            .candidates
            .iter()
            .map(|n| EffectKind::parse_named(n).map_err(|e| format!("`model_loop.candidates`: {e}")))
            .collect::<Result<_, _>>()?;
        o.refit_effects = self.refit.iter().map(|n| EffectKind::parse_named(n).map_err(|e| format!("`model_loop.refit`: {e}"))).collect::<Result<_, _>>()?;
        Ok(o)
    }
}

impl InputSpec {
    /// Loader options for every input.
    pub fn load_options(&self) -> LoadOptions {
        LoadOptions { channel: self.channel.clone(), fs_hz: self.fs_hz, unit: self.unit.clone() }
    }
}

/// Machine knowledge used for fault intervals and peak labels.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineSpec {
    /// A catalogue bearing name (e.g. `SKF 6205-2RS JEM`, or a unique part such as `6205`).
    #[serde(default)]
    pub bearing: Option<String>,
    /// An explicit bearing geometry instead of a catalogue name.
    #[serde(default)]
    pub bearing_geometry: Option<BearingGeometry>,
    /// Shaft speed in Hz; default: from the file (e.g. CWRU `XNNNRPM`).
    #[serde(default)]
    pub shaft_speed_hz: Option<f64>,
}

impl MachineSpec {
    /// The bearing, from the catalogue or the explicit geometry.
    pub fn bearing(&self) -> Result<Option<BearingGeometry>, BatchError> {
        let bad = |m: String| BatchError::Job { path: "machine".into(), message: m };
        match (&self.bearing, &self.bearing_geometry) {
            (Some(_), Some(_)) => Err(bad("give either `bearing` or `bearing_geometry`, not both".into())),
            (Some(name), None) => lookup_bearing(name).map(Some).map_err(|e| bad(format!("`bearing`: {e}"))),
            (None, Some(g)) => {
                g.validate().map_err(|e| bad(format!("`bearing_geometry`: {e}")))?;
                Ok(Some(g.clone()))
            }
            (None, None) => Ok(None),
        }
    }
}

/// The chain: a bundled preset, a chain file, or inline `[[chain.stage]]` entries.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ChainSpec {
    /// A bundled preset (`envelope`, `envelope_cwru`, `drs_scf`, `welch`).
    #[serde(default)]
    pub preset: Option<String>,
    /// A chain TOML file, relative to the job file.
    #[serde(default)]
    pub file: Option<String>,
    /// Sets the fault interval of every `stsa` stage (`bpfo`, `bpfi`, `bsf`, `2xbsf`, `ftf`,
    /// `shaft`, or Hz), so one preset serves every fault hypothesis.
    #[serde(default)]
    pub fault: Option<chain::FaultRef>,
    /// Inline chain: every other key (`name`, `[[chain.stage]]`).
    #[serde(flatten)]
    pub inline: toml::Table,
}

/// Outputs.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    /// Output directory, relative to the job file. Default `out/<job name>`.
    pub dir: Option<String>,
    /// Stage outputs to write as CSV (stage names, `stage:extra`, or `all`). Default: the last.
    pub stages: Vec<String>,
    /// Peaks to report per spectrum in the JSON summary. Default 10.
    pub peaks: usize,
    /// Minimum spacing between reported peaks, Hz. Default 1.0.
    pub peak_min_separation_hz: f64,
    /// Harmonics searched when labelling a peak. Default 10.
    pub max_harmonic: u32,
    /// Shaft-speed sidebands searched when labelling a peak. Default 2.
    pub max_sideband: i32,
    /// A peak is labelled with a line within this relative distance, %. Default 1.0.
    pub label_tolerance_percent: f64,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self { dir: None, stages: Vec::new(), peaks: 10, peak_min_separation_hz: 1.0, max_harmonic: 10, max_sideband: 2, label_tolerance_percent: 1.0 }
    }
}

const INPUT_EXTENSIONS: [&str; 3] = ["wav", "csv", "mat"];

impl Job {
    /// Reads and checks a job file.
    pub fn from_file(path: &Path) -> Result<Job, BatchError> {
        let jerr = |m: String| BatchError::Job { path: path.display().to_string(), message: m };
        let text = std::fs::read_to_string(path).map_err(|e| jerr(e.to_string()))?;
        let mut job: Job = toml::from_str(&text).map_err(|e| jerr(e.to_string().trim().replace('\n', " ")))?;
        if job.name.is_empty() {
            job.name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "job".into());
        }
        job.path = Some(path.to_path_buf());
        job.check().map_err(jerr)?;
        Ok(job)
    }

    fn check(&self) -> Result<(), String> {
        if self.input.paths.is_empty() && self.input.simulate.is_empty() {
            return Err("no inputs: give `input.paths` (files, directories, globs) or `[[input.simulate]]`".into());
        }
        if let Some(fs) = self.input.fs_hz {
            if !(fs.is_finite() && fs > 0.0) {
                return Err(format!("`input.fs_hz` = {fs}: must be a positive number of Hz"));
            }
        }
        if let Some(s) = self.machine.shaft_speed_hz {
            if !(s.is_finite() && s > 0.0) {
                return Err(format!("`machine.shaft_speed_hz` = {s}: must be a positive number of Hz (rpm / 60)"));
            }
        }
        if !(self.output.peak_min_separation_hz.is_finite() && self.output.peak_min_separation_hz >= 0.0) {
            return Err(format!("`output.peak_min_separation_hz` = {}: must be ≥ 0", self.output.peak_min_separation_hz));
        }
        Ok(())
    }

    fn base_dir(&self) -> PathBuf {
        self.path.as_ref().and_then(|p| p.parent()).map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."))
    }

    /// The chain the job asks for.
    pub fn chain(&self) -> Result<Chain, BatchError> {
        let c = &self.chain;
        let given = c.preset.is_some() as u8 + c.file.is_some() as u8 + (!c.inline.is_empty()) as u8;
        if let Some(k) = c.inline.keys().find(|k| !matches!(k.as_str(), "stage" | "name" | "description")) {
            return Err(BatchError::Job { path: self.path_name(), message: format!("unknown key `chain.{k}` (use `preset`, `file`, `fault`, or inline `name`/`description`/`[[chain.stage]]`)") });
        }
        let cerr = |m: String| BatchError::Job { path: self.path_name(), message: m };
        if given != 1 {
            return Err(cerr("`[chain]` needs exactly one of `preset`, `file`, or inline `[[chain.stage]]` entries".into()));
        }
        let chain = if let Some(p) = &c.preset {
            chain::preset(p)
        } else if let Some(f) = &c.file {
            let path = self.base_dir().join(f);
            let text = std::fs::read_to_string(&path).map_err(|e| cerr(format!("`chain.file` {}: {e}", path.display())))?;
            Chain::from_toml(&text, &path.display().to_string())
        } else {
            Chain::from_table(c.inline.clone(), &format!("{} [chain]", self.path_name()))
        };
        let mut chain = chain.map_err(|e| cerr(e.to_string()))?;
        if let Some(f) = &c.fault {
            let mut any = false;
            for st in chain.stages.iter_mut().filter(|s| s.op.kind() == "stsa") {
                st.fault = Some(f.clone());
                any = true;
            }
            if !any {
                return Err(cerr(format!("`chain.fault` is set but chain `{}` has no `stsa` stage", chain.name)));
            }
        }
        Ok(chain)
    }

    fn path_name(&self) -> String {
        self.path.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "job".into())
    }

    /// The output directory.
    pub fn output_dir(&self) -> PathBuf {
        match &self.output.dir {
            Some(d) => self.base_dir().join(d),
            None => self.base_dir().join("out").join(&self.name),
        }
    }

    /// All inputs: the expanded files, then the simulations.
    pub fn sources(&self) -> Result<Vec<InputSource>, BatchError> {
        let mut v: Vec<InputSource> = self.expand_inputs()?.into_iter().map(InputSource::File).collect();
        v.extend((0..self.input.simulate.len()).map(InputSource::Simulated));
        Ok(v)
    }

    /// The directory relative paths are taken from.
    pub fn base(&self) -> PathBuf {
        self.base_dir()
    }

    /// Expands `input.paths` (files, directories, globs) into a sorted list of files.
    pub fn expand_inputs(&self) -> Result<Vec<PathBuf>, BatchError> {
        let base = self.base_dir();
        let ierr = |m: String| BatchError::Job { path: self.path_name(), message: m };
        let mut out = Vec::new();
        for p in &self.input.paths {
            let full = base.join(p);
            let s = full.to_string_lossy().into_owned();
            if s.contains(['*', '?', '[']) {
                let mut hits: Vec<PathBuf> = glob::glob(&s)
                    .map_err(|e| ierr(format!("`input.paths` pattern `{p}`: {e}")))?
                    .filter_map(Result::ok)
                    .filter(|f| f.is_file())
                    .collect();
                if hits.is_empty() {
                    return Err(ierr(format!("`input.paths` pattern `{p}` matches no file")));
                }
                hits.sort();
                out.extend(hits);
            } else if full.is_dir() {
                let mut hits: Vec<PathBuf> = std::fs::read_dir(&full)
                    .map_err(|e| ierr(format!("`input.paths` directory `{p}`: {e}")))?
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|f| {
                        f.is_file() && f.extension().map(|e| INPUT_EXTENSIONS.contains(&e.to_string_lossy().to_ascii_lowercase().as_str())).unwrap_or(false)
                    })
                    .collect();
                if hits.is_empty() {
                    return Err(ierr(format!("`input.paths` directory `{p}` holds no .wav, .csv or .mat file")));
                }
                hits.sort();
                out.extend(hits);
            } else if full.is_file() {
                out.push(full);
            } else {
                return Err(ierr(format!("`input.paths`: `{p}` does not exist (looked for {})", full.display())));
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_model_loop_given_nothing_searches_with_the_librarys_options() {
        // Without a bandpass stage or a band, every option is `LoopOptions::default()`'s, so a
        // changed library default reaches jobs without a second copy here.
        let chain = Chain { name: "none".into(), description: String::new(), stages: Vec::new() };
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert_eq!(spec.options(&chain).unwrap(), crate::compare::LoopOptions::default());
        assert_eq!(spec.rounds, 3);
    }

    #[test]
    fn the_readmes_model_loop_sample_states_the_defaults_a_job_gets() {
        // README "Closing the loop headless" lists the keys of `[model_loop]` with their
        // defaults in comments ("default 4", "default true since session 31"); the doc
        // comments here say "the library's". Each stated default, set explicitly, must give
        // the same spec as leaving the key out, so the README cannot drift from the library.
        let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
        let start = readme.find("```toml\n[model_loop]\n").expect("README has the [model_loop] sample");
        let block = &readme[start + 8..];
        let block = &block[..block.find("```").unwrap()];
        let default = serde_json::to_value(LoopSpec::default()).unwrap();
        let mut checked = Vec::new();
        for line in block.lines().skip(1) {
            let line = line.trim_start_matches('#').trim();
            let Some((key, rest)) = line.split_once('=') else { continue };
            let Some(at) = rest.find("default ") else { continue };
            let stated: String = rest[at + 8..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '.').collect();
            if !(stated == "true" || stated == "false" || stated.starts_with(|c: char| c.is_ascii_digit())) {
                continue;
            }
            let key = key.trim();
            let set: LoopSpec = toml::from_str(&format!("{key} = {stated}")).unwrap_or_else(|e| panic!("README `{key} = {stated}`: {e}"));
            assert_eq!(serde_json::to_value(&set).unwrap(), default, "README says `{key}` defaults to {stated}");
            checked.push(key.to_string());
        }
        // Every search option the sample names with a value: a README line dropping its
        // "default" would otherwise pass silently.
        for key in ["rounds", "fit_duration_s", "unbend_pinned", "uncalibrated_start", "refit_when_stuck", "near_floor_rule", "floor_margin", "path_correction_bands", "realisations", "random_effect_realisations", "unbend_when_stuck", "unbend_when_short", "uncalibrated_start_top", "scan_force_amplitudes", "fine_forces", "polish_sweeps", "polish_second_starts", "strength_range", "removal_trials", "take_out_first", "removal_fit_realisations", "fine_force_scan", "effect_must_work", "recalibrate_roll_off", "joint_trials", "coupled_forces", "coupled_refined_starts", "force_pair_grid"] {
            assert!(checked.iter().any(|k| k == key), "README's [model_loop] sample states no default for `{key}`: {checked:?}");
        }
    }

    #[test]
    fn a_model_loop_takes_decision_d_and_the_roll_off_recalibration_from_the_library_unless_told() {
        let chain = Chain { name: "none".into(), description: String::new(), stages: Vec::new() };
        let lib = crate::compare::LoopOptions::default();
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        let o = spec.options(&chain).unwrap();
        assert_eq!((o.effect_must_work, o.recalibrate_roll_off, o.joint_trials, o.coupled_forces), (lib.effect_must_work, lib.recalibrate_roll_off, lib.joint_trials, lib.coupled_forces));
        let flipped = format!("preset = \"cwru_6205_inner\"\neffect_must_work = {}\nrecalibrate_roll_off = {}\njoint_trials = {}\ncoupled_forces = {}", !lib.effect_must_work, !lib.recalibrate_roll_off, !lib.joint_trials, !lib.coupled_forces);
        let o = toml::from_str::<LoopSpec>(&flipped).unwrap().options(&chain).unwrap();
        assert_eq!((o.effect_must_work, o.recalibrate_roll_off, o.joint_trials, o.coupled_forces), (!lib.effect_must_work, !lib.recalibrate_roll_off, !lib.joint_trials, !lib.coupled_forces));
        let chosen = toml::from_str::<LoopSpec>("preset = \"cwru_6205_inner\"\ncoupled_refined_starts = 3").unwrap().options(&chain).unwrap();
        assert_eq!((lib.coupled_refined_starts, o.coupled_refined_starts, chosen.coupled_refined_starts), (0, 0, 3));
        let no_grid = toml::from_str::<LoopSpec>(&format!("preset = \"cwru_6205_inner\"\nforce_pair_grid = {}", !lib.force_pair_grid)).unwrap().options(&chain).unwrap();
        assert_eq!((o.force_pair_grid, no_grid.force_pair_grid), (lib.force_pair_grid, !lib.force_pair_grid));
        let refit = toml::from_str::<LoopSpec>("preset = \"cwru_6205_inner\"\nrefit = [\"load_zone\", \"noise\"]").unwrap().options(&chain).unwrap();
        assert_eq!((o.refit_effects.as_slice(), refit.refit_effects.as_slice()), (&[][..], &[crate::model::EffectKind::LoadZone, crate::model::EffectKind::Noise][..]));
        let bad = toml::from_str::<LoopSpec>("preset = \"cwru_6205_inner\"\nrefit = [\"warp_drive\"]").unwrap().options(&chain).unwrap_err();
        assert!(bad.contains("model_loop.refit") && bad.contains("warp_drive"), "{bad}");
    }

    #[test]
    fn a_model_loop_gives_forces_a_second_grid_only_when_asked() {
        let chain = Chain { name: "none".into(), description: String::new(), stages: Vec::new() };
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert!(!spec.options(&chain).unwrap().fine_force_scan);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nfine_force_scan = true").unwrap();
        assert!(spec.options(&chain).unwrap().fine_force_scan);
    }

    #[test]
    fn a_model_loop_unbends_pinned_calibrations_unless_told_not_to() {
        let chain = Chain { name: "none".into(), description: String::new(), stages: Vec::new() };
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert!(spec.options(&chain).unwrap().unbend_pinned);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nunbend_pinned = false").unwrap();
        assert!(!spec.options(&chain).unwrap().unbend_pinned);
    }

    #[test]
    fn a_model_loop_starts_trials_from_the_uncalibrated_values_only_when_asked() {
        let chain = Chain { name: "none".into(), description: String::new(), stages: Vec::new() };
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert!(!spec.options(&chain).unwrap().uncalibrated_start);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nuncalibrated_start = true").unwrap();
        assert!(spec.options(&chain).unwrap().uncalibrated_start);
        assert!(spec.options(&chain).unwrap().refit_when_stuck, "on by default");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nrefit_when_stuck = false").unwrap();
        assert!(!spec.options(&chain).unwrap().refit_when_stuck);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert!(!spec.options(&chain).unwrap().near_floor_rule, "off by default");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nnear_floor_rule = true").unwrap();
        assert!(spec.options(&chain).unwrap().near_floor_rule);
        assert!(spec.options(&chain).unwrap().scan_force_amplitudes, "on by default, as in the library");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nscan_force_amplitudes = false").unwrap();
        assert!(!spec.options(&chain).unwrap().scan_force_amplitudes);
        assert!(spec.options(&chain).unwrap().unbend_when_stuck, "on by default");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nunbend_when_stuck = false").unwrap();
        assert!(!spec.options(&chain).unwrap().unbend_when_stuck);
        assert!(!spec.options(&chain).unwrap().unbend_when_short, "off by default, as in the library");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nunbend_when_short = true").unwrap();
        assert!(spec.options(&chain).unwrap().unbend_when_short);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert!(spec.options(&chain).unwrap().uncalibrated_start_top, "on by default, as in the library");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nuncalibrated_start_top = false").unwrap();
        assert!(!spec.options(&chain).unwrap().uncalibrated_start_top);
        assert!(spec.options(&chain).unwrap().fine_forces, "on by default, as in the library");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nfine_forces = false").unwrap();
        assert!(!spec.options(&chain).unwrap().fine_forces);
        assert_eq!(spec.options(&chain).unwrap().polish_sweeps, 4, "four sweeps by default, as in the library");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\npolish_sweeps = 4").unwrap();
        assert_eq!(spec.options(&chain).unwrap().polish_sweeps, 4);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\npolish_sweeps = 9").unwrap();
        let e = spec.options(&chain).unwrap_err();
        assert!(e.contains("polish_sweeps") && e.contains("9"), "{e}");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\npolish_sweeps = 4").unwrap();
        assert!(!spec.options(&chain).unwrap().polish_second_starts, "off by default, as in the library");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\npolish_sweeps = 4\npolish_second_starts = true").unwrap();
        assert!(spec.options(&chain).unwrap().polish_second_starts);
    }

    #[test]
    fn a_model_loop_takes_the_path_correction_and_the_decision_rule_only_when_asked() {
        let chain = Chain { name: "none".into(), description: String::new(), stages: Vec::new() };
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert_eq!(spec.options(&chain).unwrap().compare.path_correction_bands, 0);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\npath_correction_bands = 24").unwrap();
        assert_eq!(spec.options(&chain).unwrap().compare.path_correction_bands, 24);
        assert!(spec.options(&chain).unwrap().compare.scf_one_normaliser, "one SCF normaliser by default, as in the library");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nscf_one_normaliser = false").unwrap();
        assert!(!spec.options(&chain).unwrap().compare.scf_one_normaliser);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\ndecision_rule = \"scatter\"").unwrap();
        assert_eq!(spec.options(&chain).unwrap().decision_rule, crate::compare::DecisionRule::Scatter);
        assert!(toml::from_str::<LoopSpec>("preset = \"cwru_6205_inner\"\ndecision_rule = \"vibes\"").unwrap_err().to_string().contains("vibes"));
        assert_eq!(toml::from_str::<LoopSpec>("preset = \"cwru_6205_inner\"").unwrap().options(&chain).unwrap().floor_margin, 0.15);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nfloor_margin = 0.2").unwrap();
        assert_eq!(spec.options(&chain).unwrap().floor_margin, 0.2);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nfloor_margin = -0.1").unwrap();
        let e = spec.options(&chain).unwrap_err();
        assert!(e.contains("floor_margin") && e.contains("-0.1"), "{e}");
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\npath_correction_bands = 65").unwrap();
        let e = spec.options(&chain).unwrap_err();
        assert!(e.contains("path_correction_bands") && e.contains("65"), "{e}");
        // The fit duration takes the library's range, both ends.
        for bad in ["0.1", "61.0", "nan"] {
            let spec: LoopSpec = toml::from_str(&format!("preset = \"cwru_6205_inner\"\nfit_duration_s = {bad}")).unwrap();
            let e = spec.options(&chain).unwrap_err();
            assert!(e.contains("fit_duration_s") && e.contains("0.2 to 60"), "{bad}: {e}");
        }
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nfit_duration_s = 60.0").unwrap();
        assert_eq!(spec.options(&chain).unwrap().fit_duration_s, 60.0);
        // Realisations: the library's default unless given, and its range.
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"").unwrap();
        assert_eq!(spec.options(&chain).unwrap().realisations, crate::compare::LoopOptions::default().realisations);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nrealisations = 4").unwrap();
        assert_eq!(spec.options(&chain).unwrap().realisations, 4);
        let spec: LoopSpec = toml::from_str("preset = \"cwru_6205_inner\"\nrealisations = 0").unwrap();
        assert!(spec.options(&chain).unwrap_err().contains("realisations"));
    }
}
