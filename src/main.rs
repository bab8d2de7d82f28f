//! The `twinscope` command line: a thin shell over the library.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use twinscope::batch::{self, Progress};
use twinscope::compare::LoopOptions;
use twinscope::kinematics::{catalogue, lookup_bearing};
use twinscope::signal::io;

mod bench;

/// twinscope — vibration diagnostics of gearboxes and rolling-element bearings.
#[derive(Parser, Debug)]
#[command(name = "twinscope", version, about, long_about = None)]
struct Cli {
    /// Run a batch job (TOML) headless: inputs, chain, outputs. See README "Batch jobs".
    #[arg(long, value_name = "JOB.toml")]
    batch: Option<PathBuf>,
    /// Output directory for `--batch` (overrides the job's `output.dir`).
    #[arg(long, value_name = "DIR", requires = "batch")]
    out: Option<PathBuf>,
    /// No progress output on stderr.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Desktop workbench: the view to show first (spectra, time, filter, compare, scf, model).
    #[arg(long, value_name = "VIEW")]
    view: Option<String>,
    /// Desktop workbench: open these signal files at start (repeatable).
    #[arg(long = "open", value_name = "FILE")]
    open: Vec<PathBuf>,
    /// Desktop workbench: start without the bundled demo.
    #[arg(long)]
    no_demo: bool,
    /// Desktop workbench: once the demo (or the opened files) is loaded, run "Find missing
    /// effect" against the first measured signal with the saved search settings.
    #[arg(long)]
    find_missing_effect: bool,
    /// Desktop workbench: once the start work is done, save the window as PNG to this path
    /// (the Export → View as PNG path; the window stays open).
    #[arg(long, value_name = "FILE.png")]
    export_png: Option<PathBuf>,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// List a file's channels/variables with fs, length, duration and shaft speed.
    Info {
        /// A .wav, .csv or .mat file.
        file: PathBuf,
    },
    /// Bearing characteristic frequencies (BPFO, BPFI, BSF, 2xBSF, FTF) at a shaft speed.
    Kinematics {
        /// Catalogue bearing (e.g. `6205`, `MB ER-12K`); omit to list the catalogue.
        #[arg(long)]
        bearing: Option<String>,
        /// Shaft speed in rpm.
        #[arg(long, conflicts_with = "shaft_hz")]
        rpm: Option<f64>,
        /// Shaft speed in Hz.
        #[arg(long)]
        shaft_hz: Option<f64>,
    },
    /// List the bundled chain presets and machine presets.
    Presets,
    /// The spectral kurtosis of a signal over frame lengths half an octave apart (Antoni's
    /// kurtogram) and its most impulsive bands: the band to demodulate for an envelope analysis.
    Kurtogram {
        /// A .wav, .csv or .mat file.
        file: PathBuf,
        /// Channel/variable of the file.
        #[arg(long)]
        channel: Option<String>,
        /// Narrowest band, Hz (default: 400, twice the comparison's 0–200 Hz envelope spectrum).
        #[arg(long)]
        min_band_width_hz: Option<f64>,
        /// Bands to print, most impulsive first (each overlapping none printed before it).
        #[arg(long, default_value_t = 5)]
        top: usize,
        /// Write every level's spectral kurtosis and the chosen band as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Compare a simulated signal with a measured one: metrics per domain and the residual map.
    Compare {
        /// Measured signal (.wav, .csv, .mat).
        measured: PathBuf,
        /// Simulated signal, or a machine preset with `--preset`.
        simulated: Option<PathBuf>,
        /// Simulate this machine preset instead of reading a file.
        #[arg(long, conflicts_with = "simulated")]
        preset: Option<String>,
        /// Effects to switch on in the preset before simulating.
        #[arg(long = "with", value_name = "EFFECT")]
        with: Vec<String>,
        /// Channel/variable of the measured file.
        #[arg(long)]
        channel: Option<String>,
        /// Demodulation band, Hz, e.g. `1800,3000`.
        #[arg(long, value_delimiter = ',')]
        band_hz: Option<Vec<f64>>,
        /// Demodulate in the measurement's most impulsive band, from its kurtogram (see
        /// `twinscope kurtogram`), instead of `--band-hz`.
        #[arg(long, conflicts_with = "band_hz")]
        band_from_kurtogram: bool,
        /// Catalogue bearing for line labels (default: from the signal metadata).
        #[arg(long)]
        bearing: Option<String>,
        /// Fault frequency for the SCF α-slice, Hz (default with --preset: the preset's BPFO,
        /// BPFI or 2×BSF by its fault location).
        #[arg(long)]
        fault_hz: Option<f64>,
        /// Correct the simulated signal's transfer path with a smooth gain curve on N
        /// log-spaced PSD bands before comparing (0 = off).
        #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=twinscope::compare::MAX_PATH_CORRECTION_BANDS as i64))]
        path_correction: u16,
        /// Write the full comparison as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Find the physical effect the model lacks: calibrate, try every missing effect, rank them;
    /// with --rounds N apply the best and repeat, keeping the history.
    Diagnose {
        /// Measured signal (.wav, .csv, .mat).
        measured: PathBuf,
        /// Machine description (TOML); or --preset.
        #[arg(long, conflicts_with = "preset")]
        machine: Option<PathBuf>,
        /// A bundled machine preset.
        #[arg(long)]
        preset: Option<String>,
        /// Channel/variable of the measured file.
        #[arg(long)]
        channel: Option<String>,
        /// Demodulation band, Hz, e.g. `1800,3000`.
        #[arg(long, value_delimiter = ',')]
        band_hz: Option<Vec<f64>>,
        /// Demodulate in the measurement's most impulsive band, from its kurtogram (see
        /// `twinscope kurtogram`), instead of `--band-hz`.
        #[arg(long, conflicts_with = "band_hz")]
        band_from_kurtogram: bool,
        /// Effects the starting model has on (default parameters; calibrated where they have a
        /// calibration parameter, e.g. `noise`).
        #[arg(long = "with", value_name = "EFFECT")]
        with: Vec<String>,
        /// Effects on in the machine whose parameters the calibration re-fits, as the loop
        /// re-fits those it applies itself (repeatable). A machine an earlier `--save-machine`
        /// wrote names what that loop fitted (`fitted_effects`), and those are re-fitted anyway.
        #[arg(long = "refit", value_name = "EFFECT")]
        refit: Vec<String>,
        /// Rounds of diagnose → apply best → re-compare (1 to 20).
        #[arg(long, default_value_t = 1, value_parser = parse_rounds)]
        rounds: usize,
        /// Write the ranking, residual map and history as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Write the final machine as TOML: the last round's calibrated machine when that round
        /// applied nothing (every applied effect re-fitted), else the machine with the last
        /// applied effect.
        #[arg(long)]
        save_machine: Option<PathBuf>,
        #[command(flatten)]
        step: StepArgs,
        #[command(flatten)]
        search: SearchArgs,
    },
    /// Hidden-effect evaluation: for each effect, simulate a "measurement" with it hidden
    /// (random parameters, perturbed baseline, SNR 0–20 dB), diagnose the model without it, and
    /// print the confusion table (Markdown). Controls hide nothing.
    Confusion {
        /// Base machine preset (all effects it has on stay on in model and measurement).
        #[arg(long, default_value = "mfs_inner")]
        preset: String,
        /// Effects to hide (default: every applicable effect the preset lacks).
        #[arg(long = "effect")]
        effects: Vec<String>,
        /// Hide several effects together, e.g. `--hide load_zone+unbalance` (repeatable). Each
        /// such case runs the loop (`--rounds`): it must apply every hidden effect, one per
        /// round, and then answer "nothing significant is missing". With `--hide` and no
        /// `--effect`, no single-effect cases run.
        #[arg(long = "hide", value_name = "A+B")]
        hide: Vec<String>,
        /// Rounds of the loop for `--hide` cases (default: the number hidden + 2: one round per
        /// effect, one that may replace a wrongly applied effect, one to answer "nothing missing").
        /// With `--extra`, each case runs as a loop of this many rounds (default 1: one search).
        #[arg(long, value_parser = parse_rounds)]
        rounds: Option<usize>,
        /// Control cases with nothing hidden.
        #[arg(long, default_value_t = 2)]
        controls: usize,
        /// Measured duration, s.
        #[arg(long, default_value_t = 2.0)]
        duration_s: f64,
        /// Seed of the first case (case i uses seed + i): a new seed draws new cases.
        #[arg(long, default_value_t = 100)]
        seed: u64,
        /// Detection-limit sweep: hide the one `--effect` at each of these values of its main
        /// parameter (repeatable; for `noise`, its SNR in dB). Every case of the sweep, and its
        /// controls, uses `--seed`: the same perturbed baseline, so only the value changes.
        #[arg(long = "value", value_name = "X", requires = "effects", conflicts_with = "hide")]
        values: Vec<f64>,
        /// Fix the measurement SNR (dB) instead of drawing it in 0–20 dB.
        #[arg(long, value_name = "DB")]
        snr_db: Option<f64>,
        /// The other way round: each effect (every `--effect`, or every applicable one but the
        /// noise) is put in the model, drawn as a hidden one would be, and left out of the
        /// measurement; the search runs with its removal trials, which should read that effect
        /// contradicted. No controls: a plain table with `--removal-trials` is their control.
        #[arg(long, conflicts_with_all = ["hide", "values"])]
        extra: bool,
        /// Write all case results as JSON (rewritten after every case): an array of single-effect
        /// cases, or, with `--hide`, `{"single": [...], "multi": [...]}`.
        #[arg(long)]
        json: Option<PathBuf>,
        #[command(flatten)]
        step: StepArgs,
        #[command(flatten)]
        search: SearchArgs,
    },
    /// Simulate a machine (TOML, or a bundled preset) and write the sensor signal (.wav or .csv).
    Simulate {
        /// Machine description (TOML); or use --preset.
        #[arg(required_unless_present = "preset")]
        machine: Option<PathBuf>,
        /// A bundled machine preset (see `twinscope presets`).
        #[arg(long, conflicts_with = "machine")]
        preset: Option<String>,
        /// Output file (.wav with a metadata sidecar, or .csv).
        #[arg(short, long)]
        output: PathBuf,
        /// Override the recorded duration, s.
        #[arg(long)]
        duration_s: Option<f64>,
        /// Override the random seed.
        #[arg(long)]
        seed: Option<u64>,
        /// Switch effects on (with default parameters), e.g. `--with load_zone --with slip`.
        #[arg(long = "with", value_name = "EFFECT")]
        with: Vec<String>,
        /// Switch effects off.
        #[arg(long = "without", value_name = "EFFECT")]
        without: Vec<String>,
        #[command(flatten)]
        step: StepArgs,
    },
    /// Time the heavy operations on 10 s of 16384 Hz data (and scipy's, when python3 with
    /// scipy is available) and print a Markdown table.
    Bench(bench::BenchArgs),
}

/// The model's integration step, shared by `simulate`, `diagnose` and `confusion`.
#[derive(clap::Args, Debug, Clone)]
struct StepArgs {
    /// RK4 sub-steps per output sample (1–256), instead of the machine's own `substeps`:
    /// fewer are faster and coarser (the CWRU presets use 4, the MFS and UNSW ones 8; see
    /// assets/machines/README.md).
    #[arg(long, value_name = "N")]
    substeps: Option<usize>,
}

impl StepArgs {
    /// Sets the machine's sub-steps when `--substeps` was given (checked by `Machine::validate`).
    fn apply(&self, m: &mut twinscope::model::Machine) {
        if let Some(n) = self.substeps {
            m.substeps = n;
        }
    }
}

/// Options of the missing-effect search shared by `diagnose` and `confusion`.
#[derive(clap::Args, Debug)]
struct SearchArgs {
    /// Start the trials only from the calibrated model, even when the calibration pins a
    /// parameter at the edge of its range. By default such a round also starts every trial
    /// from the uncalibrated values (grid scan of the effect, then one calibration sweep) and
    /// keeps the better fit: slower, for a model the calibration bent to stand in for what is
    /// missing.
    #[arg(long)]
    no_unbend: bool,
    /// Start every trial also from the uncalibrated values (its effect scanned on a grid,
    /// then the plain trial's fit), pinned or not, and keep the better fit: for a calibration
    /// that bent the model toward what is missing without reaching an edge. About twice the
    /// stage-1 cost. Experimental, off by default.
    #[arg(long)]
    uncalibrated_start: bool,
    /// In a loop (`confusion --hide`, `diagnose --rounds`), do not re-fit the applied effects
    /// from the uncalibrated values when a round is stuck and no replacement helps. By default
    /// such a round fits each applied effect anew (its main parameter scanned on a grid, the
    /// base back at its uncalibrated values), searches again, and keeps that when it reaches
    /// lower by more than the seed scatter.
    #[arg(long)]
    no_refit_when_stuck: bool,
    /// Experimental: when a search is stuck (nothing significant, still above its floor
    /// margin), try its three best single trials in pairs, each pair's effects fitted together;
    /// a pair is chosen only when each of its effects does its own work (README "Joint trials").
    #[arg(long)]
    joint_trials: bool,
    /// Fit the trial of an unbalance or a misalignment where the other is already applied on
    /// the same shaft at the applied force's amplitude only. By default it is also fitted at
    /// ±3–12 % of it and at 0.5–0.8 and 1.2–1.4 of it (16 fits), and the lowest kept (the
    /// two share the 1× line, and the force applied first takes up part of the other's:
    /// README "Coupled forces").
    #[arg(long)]
    no_coupled_forces: bool,
    /// Experimental: of a coupled trial's starts (see --no-coupled-forces), fit only the N
    /// with the lowest grid minima in full (each start scans the new force on its grid
    /// first); 0, the default, fits every start in full. 3 saves about a fifth of such a
    /// round and lost a misalignment's value on a seen machine (README "Coupled forces").
    #[arg(long, value_name = "N", default_value_t = twinscope::compare::LoopOptions::default().coupled_refined_starts)]
    coupled_refined_starts: usize,
    /// Re-fit an unbalance and a misalignment applied on one shaft by line searches only. By
    /// default a round's calibration also fits their two amplitudes jointly on a grid (±30 %
    /// in 3 % steps, then ±2 % in 1 % steps; 464 evaluations): their valley is a narrow
    /// diagonal that line searches do not follow (README "Coupled forces").
    #[arg(long)]
    no_force_pair_grid: bool,
    /// Experimental near-floor rule: between 1.2 × the seed floor and the floor margin's ratio,
    /// the best trial is a finding too when it explains ≥ 80 % of the error above the floor,
    /// switching its effect off costs ≥ 50 %, no trial is tied with it and it places no
    /// spectral feature (docs/loop-notebook.md "A near-floor rule"). Off by default.
    #[arg(long)]
    near_floor_rule: bool,
    /// Do not scan a periodic force's amplitude (unbalance, misalignment, belt force) on a
    /// grid before the plain trial's line search (the default does, as the trials from the
    /// uncalibrated values do: its objective has a narrow minimum and other dips decades away,
    /// docs/loop-notebook.md "A bent calibration that pins nothing" and "Scanned forces by
    /// default?"). Faster, and can close on the wrong dip for a strong force.
    #[arg(long)]
    no_scan_forces: bool,
    /// The default since session 40 (see --no-scan-forces); accepted so that older commands
    /// run unchanged.
    #[arg(long, hide = true, conflicts_with = "no_scan_forces")]
    scan_forces: bool,
    /// Do not search a stuck diagnosis whose calibration pins nothing again with every trial
    /// also started from the uncalibrated values (the default does, a stuck one-realisation
    /// search before any second look: docs/loop-notebook.md "Unbend when stuck"). Faster, and misses strong
    /// forces the calibration absorbs.
    #[arg(long)]
    no_unbend_when_stuck: bool,
    /// The default since session 31 (see --no-unbend-when-stuck); accepted so that older
    /// commands run unchanged.
    #[arg(long, hide = true, conflicts_with = "no_unbend_when_stuck")]
    unbend_when_stuck: bool,
    /// Search a diagnosis again with every trial also started from the uncalibrated values
    /// when its significant best trial is short: it explains less than half the error above
    /// the seed floor and leaves the objective above the floor margin's ratio, with a
    /// calibration that pins nothing (docs/loop-notebook.md "Unbend when short": a strong
    /// misalignment the calibration absorbed, answered by an unbalance explaining 30 %).
    /// Costs the unbent search in such rounds only. Experimental, off by default.
    #[arg(long)]
    unbend_when_short: bool,
    /// Give a scanned force's amplitude (unbalance, misalignment, belt) a second, finer grid
    /// inside the best cell of the first before its golden section: a force can fit in a
    /// notch a few per cent wide that the golden section of a coarse cell steps over
    /// (docs/loop-notebook.md "The short misalignment of 9208: a notch the golden section
    /// straddles"). One more grid per scanned force, evaluated in parallel. Experimental, off
    /// by default.
    #[arg(long)]
    fine_force_scan: bool,
    /// In stage 2 (the best three trials re-fit the calibrated parameters locally) re-fit the
    /// effect's own parameters locally too, after the calibrated ones: its strength was fitted
    /// against a calibration made without it (docs/loop-notebook.md "The effect's strength in
    /// stage 2"). One local line search more per effect parameter of each re-fitted trial.
    /// Experimental, off by default.
    #[arg(long)]
    refit_effect_in_stage2: bool,
    /// The sensor roll-off's trial re-does the calibration with it, as the casing mode's does:
    /// from the uncalibrated values, the bandwidth scanned, then one sweep over it and every
    /// calibrated parameter. For a calibration that bent the resonance to stand in for the
    /// low-pass (docs/loop-notebook.md "Session 57"). Experimental, off by default
    #[arg(long)]
    recalibrate_roll_off: bool,
    /// The sensor roll-off's trial starts both from the calibrated model (the plain trial) and
    /// as `--recalibrate-roll-off` does, and keeps the better fit (docs/loop-notebook.md
    /// "Session 58"). Experimental, off by default
    #[arg(long)]
    roll_off_two_starts: bool,
    /// Under the floor-margin rule, name a best trial even when switching its effect off again
    /// in its own fit costs less than the 20 % significance share (the re-fit, not the effect,
    /// did the work): the default before session 57 (docs/loop-notebook.md "Session 57")
    #[arg(long)]
    no_effect_must_work: bool,
    /// After the search, give the chosen effect's strength the range the data cannot tell from
    /// its fitted value: a profile of 7 points around it, every other free parameter re-fitted
    /// locally at each, within 2√2 × the seed scatter of the fitted objective
    /// (`Diagnosis::strength_range` in the JSON). 7 local re-fits more when something is chosen.
    #[arg(long)]
    strength_range: bool,
    /// After the search, take each part of the starting model out in turn (a bearing's fault,
    /// each effect that is on but the noise), calibrate the rest as the model was, and say
    /// whether the measurement contradicts the part, needs it, or cannot tell
    /// (`Diagnosis::removals` in the JSON). The search only adds effects; a fault the machine
    /// does not have is otherwise hidden by the calibration. One calibration more per part
    #[arg(long)]
    removal_trials: bool,
    /// With removal trials (--removal-trials, `confusion --extra`): calibrate each removal
    /// trial's two models on K realisations (0, the default: on as many as they are judged
    /// on, four). Judged on four held-out realisations either way. Experimental: 1 (the
    /// round's own calibration, a quarter of the calibrations' cost) and 2 read CWRU 097's
    /// absent fault "needed", where four read it contradicted (docs/loop-notebook.md
    /// "Session 76").
    #[arg(long, value_name = "K", default_value_t = LoopOptions::default().removal_fit_realisations as u16, value_parser = clap::value_parser!(u16).range(0..=twinscope::compare::MAX_REALISATIONS as i64))]
    removal_fit_realisations: u16,
    /// With --removal-trials, in a loop: a round that reads a part contradicted applies the
    /// addition its search chose and takes the part out only in a round that adds nothing (the
    /// order before session 75). By default the part is taken out first and the addition set
    /// aside, so nothing is fitted around a part the measurement contradicts.
    #[arg(long, requires = "removal_trials")]
    add_before_taking_out: bool,
    /// Do not start the best three stage-1 trials (those stage 2 re-fits) also from the
    /// uncalibrated values. By default they are (their effect scanned, then the plain trial's
    /// fit) and the better fit goes on to stage 2: for a calibration that moved a base
    /// parameter far toward what is missing without pinning it, which stage 2's local re-fit
    /// cannot undo (docs/loop-notebook.md "A second start for the top trials" and "… as the
    /// default: the suite again"). Saves about three plain trials in searches that are not
    /// unbent, and misses what such a calibration hides.
    #[arg(long)]
    no_uncalibrated_start_top: bool,
    /// The default since session 48 (see --no-uncalibrated-start-top); accepted so that older
    /// commands run unchanged.
    #[arg(long, hide = true, conflicts_with = "no_uncalibrated_start_top")]
    uncalibrated_start_top: bool,
    /// Fit a periodic force's amplitude (unbalance, misalignment, belt) with the plain line
    /// search's evaluations only, not twice them (the default: to about 0.5 % instead of ±18 %,
    /// the objective's minimum in a force being about 1 % wide; docs/loop-notebook.md "Fine
    /// forces" and "Scanned and fine forces together by default?"). Faster, and a force left a
    /// few percent off leaves error another effect can stand in for.
    #[arg(long)]
    no_fine_forces: bool,
    /// The default since session 40 (see --no-fine-forces); accepted so that older commands
    /// run unchanged.
    #[arg(long, hide = true, conflicts_with = "no_fine_forces")]
    fine_forces: bool,
    /// After every full-range fit (the calibration, a trial that re-does it, and with
    /// --polish-second-starts an unbent trial's second start), N sweeps of local line searches
    /// on its parameters, the bracket ± 8 % of each range halved every sweep: coordinate
    /// descent over the full ranges can stop short of the optimum of coupled parameters
    /// (resonance and damping), which reads as something missing (docs/loop-notebook.md "A
    /// calibration polish"). 0 (off) to 8; 4 by default since session 44.
    #[arg(long, value_name = "N", default_value_t = twinscope::compare::LoopOptions::default().polish_sweeps as u8, value_parser = clap::value_parser!(u8).range(0..=twinscope::compare::MAX_POLISH_SWEEPS as i64))]
    polish_sweeps: u8,
    /// Polish also the second start of an unbent trial (from the uncalibrated values), not
    /// only a diagnosis's baselines (the calibration, the casing trial that re-does it): the
    /// default before session 44; on a real record about twice the cost (docs/loop-notebook.md
    /// "A polish of the baselines only").
    #[arg(long)]
    polish_second_starts: bool,
    /// The default since session 44 (see --polish-second-starts); accepted so that older
    /// commands run unchanged.
    #[arg(long, hide = true, conflicts_with = "polish_second_starts")]
    no_polish_second_starts: bool,
    /// Correct the model's transfer path with a smooth gain curve on N log-spaced PSD bands,
    /// fitted to every evaluation before comparing (0 = off): for real records whose sensor
    /// path the model does not describe. Spectral-shape effects (casing modes, sensor
    /// response) then compete only on what N bands cannot absorb.
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=twinscope::compare::MAX_PATH_CORRECTION_BANDS as i64))]
    path_correction: u16,
    /// Normalise every SCF α-slice's NRMSE by that slice's own measured range, not by the
    /// measured SCF over all compared slices (the loop's default since session 44; as
    /// `twinscope compare` does): the default before session 44, where a slice holding little
    /// but estimator noise is scaled up to the range of that noise (docs/loop-notebook.md "One
    /// normaliser for the SCF slices").
    #[arg(long)]
    scf_slice_normalisers: bool,
    /// The default since session 44 (see --scf-slice-normalisers); accepted so that older
    /// commands run unchanged.
    #[arg(long, hide = true, conflicts_with = "scf_slice_normalisers")]
    scf_one_normaliser: bool,
    /// The significance test: `floor_margin` (objective at least 1.15 × its seed floor with one
    /// realisation, 1.28 × with several, with the default margin; the default) or `scatter` (objective above its floor by more than 2√2 σ, and the effect itself
    /// must account for the share: switching it off again in the trial's fit must cost it;
    /// experimental, not adopted: it made a false claim on a fresh pair the default does not).
    #[arg(long, value_name = "RULE", default_value = "floor_margin", value_parser = ["floor_margin", "scatter"])]
    decision_rule: String,
    /// The floor margin m of `floor_margin`: something can be missing only when the calibrated
    /// objective is at least (1 + m) × its seed floor with one realisation (√(1 + 2((1 + m)² − 1))
    /// × with several). Lower finds effects nearer the floor and risks claiming a misfit of the
    /// base model (docs/loop-notebook.md "A second start for every trial").
    #[arg(long, value_name = "M", default_value_t = LoopOptions::default().floor_margin, value_parser = parse_floor_margin)]
    floor_margin: f64,
    /// Model time simulated per evaluation, s (at most the measurement's length). Longer
    /// evaluations lower the seed floor, and every evaluation costs proportionally more.
    #[arg(long, value_name = "S", default_value_t = LoopOptions::default().fit_duration_s, value_parser = parse_fit_duration_s)]
    fit_duration_s: f64,
    /// Model realisations (seeds) per evaluation, their spectra averaged before comparing, so
    /// random effects (slip, a rough fault, noise) are fitted to their expected spectra, not to
    /// one draw; with K ≥ 2 their mean's own scatter is taken out of the error, the floor
    /// ratio rises (to 1.28 with the default margin) to ask for the same systematic misfit, and the calibrated model and
    /// every trial are judged on K held-out realisations no fit used (each evaluation costs K
    /// simulations, run in parallel; not the default: with 2 a random effect's objective
    /// scatters from draw to draw by half its own gain, so a 2 % slip is not found, docs/loop-notebook.md
    /// "Detection limits").
    #[arg(long, value_name = "K", default_value_t = LoopOptions::default().realisations as u16, value_parser = clap::value_parser!(u16).range(1..=twinscope::compare::MAX_REALISATIONS as i64))]
    realisations: u16,
    /// A second look for random effects: when a search with one realisation ranks slip or a
    /// rough extended fault first, the search is done again with K realisations (judged held
    /// out) and that answer is given; other rankings keep the cost of one. 0: off (README
    /// "Detection limits"; the default is 4).
    #[arg(long, value_name = "K", default_value_t = LoopOptions::default().random_effect_realisations as u16, value_parser = clap::value_parser!(u16).range(0..=twinscope::compare::MAX_REALISATIONS as i64))]
    random_effect_realisations: u16,
    /// Experimental: the weights of the objective's domains, envelope, PSD in dB and each SCF
    /// slice, e.g. `1,0,0` for an envelope-only search (default 1,0.5,0.25; docs/loop-notebook.md
    /// "Session 59: an envelope-only objective on the CWRU records").
    #[arg(long, value_name = "E,P,S", value_parser = parse_domain_weights)]
    domain_weights: Option<[f64; 3]>,
}

/// Three domain weights as the library checks them (`LoopOptions::validate`), refused at
/// parse time.
fn parse_domain_weights(s: &str) -> std::result::Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [e, p, c] = parts[..] else { return Err(format!("{s}: give three weights, envelope,psd,scf (e.g. 1,0.5,0.25)")) };
    let mut w = [0.0; 3];
    for (slot, (text, name)) in w.iter_mut().zip([(e, "envelope"), (p, "psd"), (c, "scf")]) {
        *slot = text.parse().map_err(|err| format!("{s}: the {name} weight `{text}`: {err}"))?;
    }
    LoopOptions { weights: w, ..Default::default() }.validate().map_err(|e| e.to_string())?;
    Ok(w)
}

fn parse_rounds(s: &str) -> std::result::Result<usize, String> {
    let n: usize = s.trim().parse().map_err(|_| format!("{s}: give 1 to {} rounds", twinscope::compare::MAX_LOOP_ROUNDS))?;
    twinscope::compare::check_loop_rounds(n).map_err(|e| e.to_string())?;
    Ok(n)
}

fn parse_fit_duration_s(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{s}: {e}"))?;
    let range = twinscope::compare::FIT_DURATION_RANGE_S;
    if !(v.is_finite() && range.contains(&v)) {
        return Err(format!("{s}: give {} to {} s", range.start(), range.end()));
    }
    Ok(v)
}

/// The margin as the library checks it (`LoopOptions::validate`), refused at parse time.
fn parse_floor_margin(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{s}: {e}"))?;
    LoopOptions { floor_margin: v, ..Default::default() }.validate().map_err(|e| e.to_string())?;
    Ok(v)
}

impl SearchArgs {
    fn options(&self) -> LoopOptions {
        use twinscope::compare::DecisionRule;
        let decision_rule = if self.decision_rule == "scatter" { DecisionRule::Scatter } else { DecisionRule::FloorMargin };
        let mut o = LoopOptions { unbend_pinned: !self.no_unbend, uncalibrated_start: self.uncalibrated_start, refit_when_stuck: !self.no_refit_when_stuck, joint_trials: self.joint_trials, coupled_forces: !self.no_coupled_forces, coupled_refined_starts: self.coupled_refined_starts, force_pair_grid: !self.no_force_pair_grid, near_floor_rule: self.near_floor_rule, scan_force_amplitudes: !self.no_scan_forces, unbend_when_stuck: !self.no_unbend_when_stuck, unbend_when_short: self.unbend_when_short, fine_force_scan: self.fine_force_scan, refit_effect_in_stage2: self.refit_effect_in_stage2, recalibrate_roll_off: self.recalibrate_roll_off, roll_off_two_starts: self.roll_off_two_starts, effect_must_work: !self.no_effect_must_work, strength_range: self.strength_range, removal_trials: self.removal_trials, take_out_first: !self.add_before_taking_out, removal_fit_realisations: self.removal_fit_realisations as usize, uncalibrated_start_top: !self.no_uncalibrated_start_top, fine_forces: !self.no_fine_forces, polish_sweeps: self.polish_sweeps as usize, polish_second_starts: self.polish_second_starts, decision_rule, floor_margin: self.floor_margin, fit_duration_s: self.fit_duration_s, realisations: self.realisations as usize, random_effect_realisations: self.random_effect_realisations as usize, ..Default::default() };
        o.compare.path_correction_bands = self.path_correction as usize;
        o.compare.scf_one_normaliser = !self.scf_slice_normalisers;
        if let Some(w) = self.domain_weights {
            o.weights = w;
        }
        o
    }
}

fn main() {
    let mut command = <Cli as clap::CommandFactory>::command();
    let matches = command.get_matches_mut();
    let cli = <Cli as clap::FromArgMatches>::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    if let Err(e) = run(cli, &command, &matches) {
        // One line, naming what was wrong; no backtrace, no panic.
        let msg = format!("{e:#}").replace('\n', " ");
        eprintln!("twinscope: error: {msg}");
        std::process::exit(1);
    }
}

/// The search options (`SearchArgs`) given on the command line to `diagnose`, as the words to
/// repeat in the command that goes on from a saved machine: each flag the user set, with its
/// values as typed, in the order `SearchArgs` declares them. Empty for any other command.
/// `cli` is the command `matches` were parsed with.
fn search_words(cli: &clap::Command, matches: &clap::ArgMatches) -> Vec<String> {
    let Some(("diagnose", sub)) = matches.subcommand() else { return Vec::new() };
    let Some(diagnose) = cli.find_subcommand("diagnose") else { return Vec::new() };
    let Some(group) = diagnose.get_groups().find(|g| g.get_id() == "SearchArgs") else { return Vec::new() };
    let mut words = Vec::new();
    for id in group.get_args() {
        let Some(arg) = diagnose.get_arguments().find(|a| a.get_id() == id) else { continue };
        let (Some(long), Some(clap::parser::ValueSource::CommandLine)) = (arg.get_long(), sub.value_source(id.as_str())) else { continue };
        if matches!(arg.get_action(), clap::ArgAction::SetTrue | clap::ArgAction::SetFalse) {
            words.push(format!("--{long}"));
            continue;
        }
        for occurrence in sub.get_raw_occurrences(id.as_str()).into_iter().flatten() {
            let values: Vec<String> = occurrence.map(|v| v.to_string_lossy().into_owned()).collect();
            words.push(format!("--{long}"));
            match arg.get_value_delimiter() {
                Some(d) => words.push(values.join(&d.to_string())),
                None => words.extend(values),
            }
        }
    }
    words
}

fn run(cli: Cli, command: &clap::Command, matches: &clap::ArgMatches) -> Result<()> {
    if let Some(job) = &cli.batch {
        return run_batch(job, cli.out.as_deref(), cli.quiet);
    }
    match cli.command {
        Some(Command::Info { file }) => info(&file),
        Some(Command::Kinematics { bearing, rpm, shaft_hz }) => kinematics(bearing, rpm.map(|r| r / 60.0).or(shaft_hz)),
        Some(Command::Presets) => {
            for (name, text) in twinscope::chain::PRESETS {
                let c = twinscope::chain::Chain::from_toml(text, name)?;
                let stages: Vec<&str> = c.stages.iter().map(|s| s.name.as_str()).collect();
                println!("{name:15} {}\n{:15} stages: {}", c.description, "", stages.join(" → "));
            }
            println!();
            for (name, text) in twinscope::model::PRESETS {
                let m = twinscope::model::Machine::from_toml(text, name)?;
                let on: Vec<&str> = m.effects.enabled().iter().map(|k| k.name()).collect();
                println!("machine {name:22} {} (effects: {})", m.name, on.join(", "));
            }
            Ok(())
        }
        Some(Command::Kurtogram { file, channel, min_band_width_hz, top, json }) => kurtogram_cmd(&file, channel, min_band_width_hz, top, json.as_deref()),
        Some(Command::Bench(args)) => bench::run(&args),
        Some(Command::Compare { measured, simulated, preset, with, channel, band_hz, band_from_kurtogram, bearing, fault_hz, path_correction, json }) => compare_cmd(&measured, simulated.as_deref(), preset, &with, channel, Band { hz: band_hz, from_kurtogram: band_from_kurtogram }, bearing, fault_hz, path_correction as usize, json.as_deref(), cli.quiet),
        Some(Command::Diagnose { measured, machine, preset, channel, band_hz, band_from_kurtogram, with, refit, rounds, json, save_machine, step, search }) => diagnose_cmd(&measured, machine.as_deref(), preset, channel, Band { hz: band_hz, from_kurtogram: band_from_kurtogram }, &with, &refit, rounds, &step, (search.options(), search_words(command, matches)), json.as_deref(), save_machine.as_deref(), cli.quiet),
        Some(Command::Confusion { preset, effects, hide, rounds, controls, duration_s, seed, values, snr_db, extra, json, step, search }) => {
            let sweep = twinscope::compare::hidden::CaseSetting { value: None, snr_db };
            if extra {
                return extra_confusion_cmd(&preset, &effects, duration_s, seed, rounds.unwrap_or(1), sweep, &step, json.as_deref(), search.options());
            }
            confusion_cmd(&preset, &effects, &hide, rounds, controls, duration_s, seed, &values, sweep, &step, json.as_deref(), search.options())
        }
        Some(Command::Simulate { machine, preset, output, duration_s, seed, with, without, step }) => simulate(machine, preset, &output, duration_s, seed, &with, &without, &step, cli.quiet),
        None => open_workbench(cli.view, cli.open, !cli.no_demo, cli.find_missing_effect, cli.export_png),
    }
}

/// `twinscope` with no command opens the desktop workbench (on the bundled demo by default).
#[cfg(feature = "gui")]
fn open_workbench(view: Option<String>, files: Vec<PathBuf>, demo: bool, find_missing_effect: bool, export_png: Option<PathBuf>) -> Result<()> {
    let opts = twinscope::gui::StartOptions { demo, files, tab: view, find_missing_effect, export_png, settings_path: twinscope::gui::settings::Settings::default_path() };
    twinscope::gui::run(opts).map_err(|e| anyhow::anyhow!("cannot open the desktop workbench: {e} (a display is needed; for headless work use --batch or a subcommand, see --help)"))
}

#[cfg(not(feature = "gui"))]
fn open_workbench(_view: Option<String>, _files: Vec<PathBuf>, _demo: bool, _find_missing_effect: bool, _export_png: Option<PathBuf>) -> Result<()> {
    eprintln!("twinscope: built without the desktop workbench (feature `gui`). Try `twinscope --batch sample_data/demo_envelope.toml` or `twinscope --help`.");
    Ok(())
}

struct CliProgress {
    bar: Option<indicatif::ProgressBar>,
    quiet: bool,
}

impl Progress for CliProgress {
    fn start(&self, total: usize) {
        if let Some(b) = &self.bar {
            b.set_length(total as u64);
        } else if !self.quiet {
            eprintln!("twinscope: {total} input(s)");
        }
    }
    fn input_done(&self, done: usize, total: usize, input: &Path, ok: bool) {
        let status = if ok { "ok" } else { "FAILED" };
        if let Some(b) = &self.bar {
            b.set_position(done as u64);
            b.set_message(format!("{} {status}", input.file_name().map(|f| f.to_string_lossy()).unwrap_or_default()));
        } else if !self.quiet {
            eprintln!("twinscope: [{done}/{total}] {} {status}", input.display());
        }
    }
    fn model_evaluations(&self, input: &str, done: usize, expected: usize) {
        if let Some(b) = &self.bar {
            b.set_message(format!("{input}: model loop, evaluation {done}/{expected}"));
        } else if !self.quiet && (done.is_multiple_of(50) || done == expected) {
            eprintln!("twinscope: {input}: model loop, evaluation {done}/{expected}");
        }
    }
}

fn run_batch(job_path: &Path, out: Option<&Path>, quiet: bool) -> Result<()> {
    let bar = if !quiet && std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed} {msg}").unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()));
        Some(b)
    } else {
        None
    };
    let progress = CliProgress { bar, quiet };
    let summary = batch::Job::from_file(job_path).and_then(|mut job| {
        if let Some(o) = out {
            job.output.dir = Some(std::path::absolute(o).unwrap_or_else(|_| o.to_path_buf()).display().to_string());
        }
        batch::run_job(&job, &progress)
    });
    if let Some(b) = &progress.bar {
        b.finish_and_clear();
    }
    let summary = summary?;
    if !quiet {
        for i in &summary.inputs {
            for o in &i.outputs {
                let top = o.peaks.first().map(|p| {
                    let label = p.nearest.as_ref().map(|m| if m.within_tolerance { format!(" ≈ {} ({:+.2} %)", line_label(m), m.error_percent) } else { " (no characteristic line within tolerance)".to_string() }).unwrap_or_default();
                    format!("; top peak {:.2} Hz{label}", p.frequency_hz)
                });
                eprintln!("twinscope: {} → {}{}", i.file, o.path, top.unwrap_or_default());
            }
            if let Some(l) = &i.model_loop {
                for r in &l.history {
                    eprintln!("twinscope: {} model loop round {}: envelope NRMSE {:.1} %, objective {:.1} (floor {:.1}); then: {}", i.file, r.round, r.envelope_nrmse, r.objective, r.floor_objective, r.change_with_values("-"));
                }
                eprintln!("twinscope: {} model loop verdict: {} → {}", i.file, l.verdict, l.history_csv);
            }
        }
    }
    Ok(())
}

fn line_label(m: &twinscope::kinematics::LineMatch) -> String {
    let h = if m.harmonic == 1 { m.label.clone() } else { format!("{}x{}", m.harmonic, m.label) };
    match m.sideband {
        0 => h,
        s => format!("{h}{s:+}xshaft"),
    }
}

fn kurtogram_cmd(file: &Path, channel: Option<String>, min_band_width_hz: Option<f64>, top: usize, json: Option<&Path>) -> Result<()> {
    use twinscope::compare::demodulation_band::kurtogram_params_for;
    let s = io::load(file, &io::LoadOptions { channel, ..Default::default() })?;
    let mut p = kurtogram_params_for(s.fs_hz, &twinscope::compare::CompareOptions::default());
    if let Some(w) = min_band_width_hz {
        p.min_band_width_hz = w;
    }
    let k = twinscope::dsp::kurtogram::kurtogram(&s.samples, s.fs_hz, &p).context("kurtogram")?;
    let [lo, hi] = p.search_band_hz.unwrap_or([0.0, s.fs_hz / 2.0]);
    println!("{}: {} samples at {} Hz; frames of {} samples (75 % overlap, Hann); bands at least {:.0} Hz wide within {lo:.0}–{hi:.0} Hz", file.display(), s.samples.len(), s.fs_hz, k.levels.iter().map(|l| l.nperseg.to_string()).collect::<Vec<_>>().join(", "), p.min_band_width_hz);
    println!("{:>4} {:>16} {:>10} {:>8} {:>8}", "rank", "band Hz", "centre Hz", "SK", "nperseg");
    let mut shown: Vec<twinscope::dsp::kurtogram::KurtogramBand> = Vec::new();
    for b in k.ranked_bands(s.fs_hz, &p) {
        if shown.len() == top {
            break;
        }
        if shown.iter().any(|x| x.band_hz[0] < b.band_hz[1] && x.band_hz[1] > b.band_hz[0]) {
            continue;
        }
        println!("{:>4} {:>16} {:>10.0} {:>8.3} {:>8}", shown.len() + 1, format!("{:.0}–{:.0}", b.band_hz[0], b.band_hz[1]), b.centre_hz, b.sk, b.nperseg);
        shown.push(b);
    }
    if let Some(path) = json {
        std::fs::write(path, serde_json::to_string_pretty(&k)?).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

fn info(file: &Path) -> Result<()> {
    let fi = io::inspect(file).with_context(|| format!("reading {}", file.display()))?;
    println!("file: {}", fi.path.display());
    println!("format: {:?}", fi.format);
    if let Some(s) = fi.shaft_speed_hz {
        println!("shaft speed: {:.4} Hz ({:.1} rpm)", s, s * 60.0);
    }
    println!("{:<24} {:>12} {:>10} {:>12} {:>6}", "channel", "fs_hz", "samples", "duration_s", "unit");
    for c in &fi.channels {
        let fs = c.fs_hz.map(|f| format!("{f}")).unwrap_or_else(|| "unknown".into());
        let d = c.duration_s.map(|d| format!("{d:.3}")).unwrap_or_else(|| "-".into());
        println!("{:<24} {:>12} {:>10} {:>12} {:>6}", c.name, fs, c.len, d, c.unit.clone().unwrap_or_default());
    }
    for n in &fi.notes {
        println!("note: {n}");
    }
    Ok(())
}

fn kinematics(bearing: Option<String>, shaft_hz: Option<f64>) -> Result<()> {
    let Some(name) = bearing else {
        println!("{:<20} {:>3} {:>8} {:>8} {:>6} {:>4}  source", "bearing", "n", "d_mm", "D_mm", "phi", "rows");
        for b in catalogue() {
            println!("{:<20} {:>3} {:>8.3} {:>8.3} {:>6.1} {:>4}  {}", b.name, b.rolling_elements, b.ball_diameter_mm, b.pitch_diameter_mm, b.contact_angle_deg, b.rows, b.source);
        }
        return Ok(());
    };
    let b = lookup_bearing(&name)?;
    let fr = shaft_hz.context("give the shaft speed with --rpm or --shaft-hz")?;
    let f = b.fault_frequencies(fr)?;
    println!("{} at {:.4} Hz ({:.1} rpm)", b.name, fr, fr * 60.0);
    for (label, v) in [("shaft", f.shaft_hz), ("BPFO", f.bpfo_hz), ("BPFI", f.bpfi_hz), ("BSF", f.bsf_hz), ("2xBSF", 2.0 * f.bsf_hz), ("FTF", f.ftf_hz)] {
        println!("{label:>6} {v:>10.4} Hz  {:>8.5} x shaft", v / fr);
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn simulate(machine: Option<PathBuf>, preset: Option<String>, output: &Path, duration_s: Option<f64>, seed: Option<u64>, with: &[String], without: &[String], step: &StepArgs, quiet: bool) -> Result<()> {
    use twinscope::model::{self, EffectKind, Machine};
    let mut m = match (&machine, &preset) {
        (Some(p), _) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            Machine::from_toml(&text, &p.display().to_string())?
        }
        (None, Some(name)) => model::preset(name)?,
        (None, None) => anyhow::bail!("give a machine file or --preset"),
    };
    if let Some(d) = duration_s {
        m.duration_s = d;
    }
    if let Some(s) = seed {
        m.seed = s;
    }
    step.apply(&mut m);
    for n in with {
        m.effects.enable(EffectKind::parse_named(n).map_err(anyhow::Error::msg)?);
    }
    for n in without {
        m.effects.disable(EffectKind::parse_named(n).map_err(anyhow::Error::msg)?);
    }
    m.validate()?;
    let built = model::Model::build(&m)?;
    let bar = (!quiet && std::io::stderr().is_terminal()).then(|| indicatif::ProgressBar::new(100));
    let started = std::time::Instant::now();
    let signal = model::run(&built, |f| {
        if let Some(b) = &bar {
            b.set_position((f * 100.0) as u64);
        }
        true
    });
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let signal = signal?;
    io::save(&signal, output)?;
    if !quiet {
        eprintln!("twinscope: simulated {:.2} s of `{}` in {:.2} s ({} DOFs) → {}", m.duration_s, m.name, started.elapsed().as_secs_f64(), built.system.n(), output.display());
    }
    Ok(())
}

/// The demodulation band asked for on the command line.
struct Band {
    /// `--band-hz low,high`.
    hz: Option<Vec<f64>>,
    /// `--band-from-kurtogram`.
    from_kurtogram: bool,
}

impl Band {
    /// Sets `opts.envelope_band_hz` from `--band-hz` or the measurement's kurtogram, saying on
    /// stderr which band the kurtogram chose, or, for a band given or the default, when the
    /// kurtogram finds the measurement far more impulsive elsewhere. Returns the band set.
    /// `resonances_hz`: the model's ([`twinscope::model::Machine::structural_resonances_hz`]),
    /// empty when there is no model.
    fn apply(&self, opts: &mut twinscope::compare::CompareOptions, meas: &twinscope::signal::Signal, resonances_hz: &[f64], quiet: bool) -> Result<[f64; 2]> {
        use twinscope::compare::demodulation_band::{band_advice, demodulation_band};
        if let Some(b) = &self.hz {
            anyhow::ensure!(b.len() == 2, "--band-hz takes two numbers, low,high in Hz (got {})", b.len());
            opts.envelope_band_hz = [b[0], b[1]];
        }
        if self.from_kurtogram {
            let best = demodulation_band(meas, opts, resonances_hz).context("--band-from-kurtogram")?.band;
            opts.envelope_band_hz = best.band_hz;
            if !quiet {
                let held = if resonances_hz.is_empty() { String::new() } else { format!(", the most impulsive holding a resonance of the model ({} Hz)", resonances_hz.iter().map(|f| format!("{f:.0}")).collect::<Vec<_>>().join(", ")) };
                eprintln!("twinscope: demodulation band {:.0}–{:.0} Hz from the measurement's kurtogram (spectral kurtosis {:.2}, frames of {} samples{held})", best.band_hz[0], best.band_hz[1], best.sk, best.nperseg);
            }
        } else if let (false, Some(advice)) = (quiet, band_advice(meas, opts, resonances_hz)) {
            eprintln!("twinscope: note: {advice}");
        }
        Ok(opts.envelope_band_hz)
    }
}

/// `meas` at `fs_hz` at most (`compare::at_most_rate`): what it is compared with holds nothing
/// above `fs_hz / 2`. Says so on stderr when it resamples.
fn at_model_rate_noted(meas: twinscope::signal::Signal, fs_hz: f64, of_what: &str, quiet: bool) -> Result<twinscope::signal::Signal> {
    let resampled = match twinscope::compare::at_most_rate(&meas, fs_hz)? {
        std::borrow::Cow::Owned(s) => Some(s),
        std::borrow::Cow::Borrowed(_) => None,
    };
    Ok(match resampled {
        Some(s) => {
            if !quiet {
                eprintln!("twinscope: the measurement, sampled at {} Hz, is compared at {of_what}'s {} Hz (resampled by the Fourier method): {of_what} holds nothing above {} Hz", meas.fs_hz, fs_hz, fs_hz / 2.0);
            }
            s
        }
        None => meas,
    })
}

#[allow(clippy::too_many_arguments)]
fn compare_cmd(measured: &Path, simulated: Option<&Path>, preset: Option<String>, with: &[String], channel: Option<String>, band: Band, bearing: Option<String>, fault_hz: Option<f64>, path_correction_bands: usize, json: Option<&Path>, quiet: bool) -> Result<()> {
    use twinscope::compare::{self, diagnose::fault_frequency_hz, CompareOptions};
    use twinscope::model::{self, EffectKind};
    let meas = io::load(measured, &io::LoadOptions { channel, ..Default::default() })?;
    let mut opts = CompareOptions { fault_frequency_hz: fault_hz, path_correction_bands, ..Default::default() };
    if let Some(f) = fault_hz {
        anyhow::ensure!(f.is_finite() && f > 0.0, "--fault-hz must be a positive frequency in Hz (got {f})");
    }
    let (sim, resonances_hz) = match (simulated, preset) {
        (Some(p), _) => (io::load(p, &io::LoadOptions::default())?, Vec::new()),
        (None, Some(name)) => {
            let mut m = model::preset(&name)?;
            for n in with {
                m.effects.enable(EffectKind::parse_named(n).map_err(anyhow::Error::msg)?);
            }
            opts.fault_frequency_hz = opts.fault_frequency_hz.or_else(|| fault_frequency_hz(&m, &meas));
            (model::simulate(&m)?, m.structural_resonances_hz())
        }
        (None, None) => anyhow::bail!("give a simulated file or --preset"),
    };
    let recorded_fs_hz = meas.fs_hz;
    let meas = at_model_rate_noted(meas, sim.fs_hz, if simulated.is_some() { "the simulated signal" } else { "the model" }, quiet)?;
    band.apply(&mut opts, &meas, &resonances_hz, quiet)?;
    let bearing_name = bearing.or(meas.meta.bearing.clone()).or(sim.meta.bearing.clone());
    let ff = match (bearing_name, meas.meta.shaft_speed_hz) {
        (Some(b), Some(fr)) => Some(lookup_bearing(&b)?.fault_frequencies(fr)?),
        _ => None,
    };
    let mut cmp = compare::compare(&meas, &sim, &opts)?;
    if meas.fs_hz != recorded_fs_hz {
        cmp.alignment.measured_resampled_from_hz = Some(recorded_fs_hz);
    }
    println!("{:<18} {:>9} {:>9} {:>6} {:>12} {:>10}", "domain", "pearson", "xcorr", "lag", "rmse", "nrmse_%");
    for d in &cmp.domains {
        let m = &d.metrics;
        println!("{:<18} {:>9.3} {:>9.3} {:>6} {:>12.4e} {:>10.2}", d.domain, m.pearson, m.xcorr_peak, m.xcorr_lag, m.rmse, m.nrmse_percent);
    }
    println!("NRMSE normaliser: {}; simulated/measured RMS {:+.1} dB; compared at {}", opts.normaliser.name(), cmp.alignment.rms_ratio_db, cmp.alignment.rate_in_words());
    if let Some(pc) = &cmp.path_correction {
        println!("transfer-path correction applied to the simulation (dB at band centres):");
        println!("  {pc}");
    }
    let families = ff.map(|f| f.families()).unwrap_or_default();
    let map = compare::residual_map(&cmp, &families, meas.meta.shaft_speed_hz);
    println!("\nwhere the envelope error lives (share of squared error):");
    for (f, s) in map.envelope_families.iter().take(8) {
        println!("  {f:<22} {s:6.1} %");
    }
    println!("\ntop residual items:");
    for it in map.items.iter().take(12) {
        println!("  {:<14} {:<26} {:6.1} %  measured {:.4} model {:.4}  {}", it.kind, it.label, it.share_percent, it.measured, it.simulated, it.note);
    }
    if let Some(p) = json {
        std::fs::write(p, serde_json::to_string_pretty(&serde_json::json!({ "comparison": cmp, "residual_map": map }))?)?;
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn diagnose_cmd(measured: &Path, machine: Option<&Path>, preset: Option<String>, channel: Option<String>, band: Band, with: &[String], refit: &[String], rounds: usize, step: &StepArgs, (mut opts, search_words): (LoopOptions, Vec<String>), json: Option<&Path>, save_machine: Option<&Path>, quiet: bool) -> Result<()> {
    use twinscope::compare;
    use twinscope::model::{self, Machine};
    // How the measurement is read and compared, for the command that goes on from a saved machine.
    let mut go_on_args: Vec<String> = Vec::new();
    if let Some(c) = &channel {
        go_on_args.extend(["--channel".to_string(), c.clone()]);
    }
    let meas = io::load(measured, &io::LoadOptions { channel, ..Default::default() })?;
    let mut m = match (machine, preset) {
        (Some(p), _) => Machine::from_toml(&std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?, &p.display().to_string())?,
        (None, Some(n)) => model::preset(&n)?,
        (None, None) => anyhow::bail!("give --machine FILE or --preset NAME"),
    };
    for n in with {
        m.effects.enable(twinscope::model::EffectKind::parse_named(n).map_err(anyhow::Error::msg)?);
    }
    step.apply(&mut m);
    m.validate()?;
    let meas = at_model_rate_noted(meas, m.fs_hz, "the model", quiet)?;
    let band_set = band.apply(&mut opts.compare, &meas, &m.structural_resonances_hz(), quiet)?;
    if band.hz.is_some() || band.from_kurtogram {
        go_on_args.extend(["--band-hz".to_string(), band_set.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(",")]);
    }
    // The search as this run was told, so that the loop going on searches the same way.
    go_on_args.extend(search_words);
    opts.refit_effects = refit.iter().map(|n| twinscope::model::EffectKind::parse_named(n).map_err(anyhow::Error::msg)).collect::<Result<_>>()?;
    compare::calibrate::check_refit_effects(&m, &opts.refit_effects).context("--refit")?;
    if let (Some(p), false) = (machine, m.fitted_effects.is_empty()) {
        compare::calibrate::check_refit_effects(&m, &m.fitted_effects).with_context(|| format!("{}: fitted_effects", p.display()))?;
        if !quiet {
            eprintln!("twinscope: {} names fitted_effects = {}: the calibration re-fits them, as the loop that saved it did (take them out of the file to keep them fixed)", p.display(), m.fitted_effects.iter().map(|k| k.name()).collect::<Vec<_>>().join(", "));
        }
    }
    let started = std::time::Instant::now();
    if !quiet {
        eprintln!("twinscope: calibrating the model ({}), then one trial per missing effect; about 15–20 s per round on 2 cores for a CWRU preset, 45–55 s for the MFS rig", compare::calibrate::calibration_parameters_for(&m, &opts).iter().map(|p| p.name()).collect::<Vec<_>>().join(", "));
    }
    let show = !quiet && std::io::stderr().is_terminal();
    let progress = move |done: usize, expected: usize| {
        if show {
            eprint!("\rtwinscope: model evaluations {done}/{expected}   ");
        }
        true
    };
    let (final_m, history, last) = compare::run_loop(&m, &meas, rounds, &opts, &progress)?;
    if show {
        eprintln!();
    }
    let cal = &last.calibration;
    println!("calibration ({} evaluations): envelope NRMSE {:.1} % → {:.1} %; objective {:.1} → {:.1}; gain {:.3}", cal.evaluations, cal.envelope_nrmse_before, cal.envelope_nrmse_after, cal.objective_before, cal.objective_after, cal.gain);
    for (p, v) in &cal.parameters {
        match cal.at_bound.iter().find(|b| b.0 == *p) {
            Some((_, lo, hi)) => println!("  {} = {:.6}   <- at the edge of its range {lo:.3e} – {hi:.3e}: not estimated; a parameter pushed this far may stand in for a missing effect", p.name(), v),
            None => println!("  {} = {:.6}", p.name(), v),
        }
    }
    if let Some(h) = compare::calibrate::fault_drop_limit_m(&final_m).filter(|_| !compare::calibrate::calibration_parameters(&final_m).contains(&compare::Param::FaultDepthM)) {
        println!("  (fault depth not fitted: a ball drops at most {:.2} µm into this spall, below the {:.0} µm floor of the depth range, so every depth gives the same model)", h * 1e6, compare::Param::FaultDepthM.bounds(&final_m).0 * 1e6);
    }
    if let Some(pc) = &last.path_correction {
        println!("  transfer-path correction of the calibrated model (dB at band centres): {pc}");
    }
    if last.unbent {
        println!("  the trials also started from the uncalibrated values, not only from this bent calibration (--no-unbend turns this off)");
    } else if opts.uncalibrated_start {
        println!("  the trials also started from the uncalibrated values, their effect scanned (--uncalibrated-start)");
    } else if opts.uncalibrated_start_top {
        println!("  the best three trials also started from the uncalibrated values, their effect scanned (the default; --no-uncalibrated-start-top turns this off)");
    } else if !cal.at_bound.is_empty() {
        println!("  (the trials started only from this bent calibration: --no-unbend)");
    }
    println!("\nwhere the calibrated model fails (envelope, share of squared error):");
    for (f, s) in last.residual_map.envelope_families.iter().take(6) {
        println!("  {f:<22} {s:6.1} %");
    }
    let needed = if last.floor_ratio_needed > 0.0 { format!(", something can be missing from {:.2} × it", last.floor_ratio_needed) } else { String::new() };
    println!("\nmissing-effect ranking (last round); floor {:.2} (the model against itself){needed}, seed scatter ±{:.2}:", last.floor_objective, last.objective_scatter);
    if last.floor_objective == 0.0 {
        println!("  note: {}", twinscope::compare::diagnose::ZERO_FLOOR_NOTE);
    }
    if let Some(jh) = last.held_out_objective {
        println!("  judged on held-out realisations: the calibrated model scores {jh:.2} there ({:.2} on the realisations it was fitted to); each trial's own fit in brackets", cal.objective_after);
    }
    let n_tied = last.trials.iter().filter(|t| t.tied_with_best).count();
    for (i, t) in last.trials.iter().enumerate() {
        println!(
            "{:>2}. {:<18} objective {:6.1} → {:6.1}{} ({:+4.0} %, explains {:4.0} % above the floor, switched off again {}){}  envelope NRMSE {:5.1} → {:5.1} %",
            i + 1,
            t.label(),
            t.objective_before,
            t.objective_after,
            t.objective_fitted.map_or(String::new(), |j| format!(" [{j:6.1}]")),
            -t.reduction * 100.0,
            t.explained * 100.0,
            t.effect_explained.map_or("–".to_string(), |e| format!("{:4.0} %", e * 100.0)),
            if t.tied_with_best && n_tied > 1 { " tied" } else { "     " },
            t.envelope_nrmse_before,
            t.envelope_nrmse_after
        );
        if let Some(note) = t.not_a_finding_note() {
            println!("    {:<18} {note}", "");
        }
        if t.from_uncalibrated {
            println!("    {:<18} its best fit started from the uncalibrated values, not from the calibration", "");
        }
        if !t.fine_cell_won.is_empty() {
            let names: Vec<&str> = t.fine_cell_won.iter().map(|p| p.name()).collect();
            println!("    {:<18} {} ended lower from the fine grid's cell than from the coarse grid's (--fine-force-scan)", "", names.join(", "));
        }
    }
    for (k, why) in &last.failed_trials {
        println!("    {:<18} not ranked: its trial failed: {why}", k.name());
    }
    if let Some(w) = last.silent_model_warning(&meas.unit) {
        println!("\nwarning: {w}");
    }
    println!("\nverdict: {}", last.verdict);
    if let Some(r) = &last.strength_range {
        println!(
            "strength range: {} — the values whose objective, every other free parameter re-fitted, stays within {:.2} (2√2 × the larger seed scatter, the calibrated model's or the fitted machine's) of the fitted value's {:.2}; profile: {}",
            r.text(),
            r.tolerance,
            r.objective_fitted,
            r.profile.iter().map(|(v, j)| format!("{v:.3e}: {j:.2}")).collect::<Vec<_>>().join(", ")
        );
    }
    if !last.removals.is_empty() {
        println!("\nremoval trials (last round: each part of its starting model taken out and the rest calibrated again on {} realisation{}, both models judged on {} held-out ones):", last.removals[0].fit_realisations, if last.removals[0].fit_realisations == 1 { "" } else { "s" }, last.removals[0].realisations);
        for r in &last.removals {
            println!("  {:<13} {}", r.reading.name(), r.summary);
        }
    }
    if history.len() > 1 || rounds > 1 {
        println!("\nhistory:");
        for r in &history {
            let pinned = if r.pinned.is_empty() { String::new() } else { format!(" (calibration pinned {})", r.pinned.iter().map(|p| p.name()).collect::<Vec<_>>().join(", ")) };
            let redo = if r.unbent_when_stuck {
                " (stuck: searched again unbent)"
            } else if r.unbent_when_short {
                " (short: searched again unbent)"
            } else {
                ""
            };
            // The range of the applied effect's strength, when the round's search made one for it.
            let range = r.strength_range.as_ref().filter(|sr| r.applied.and_then(compare::Param::main_of_effect) == Some(sr.parameter)).map(|sr| format!(", strength range {}", sr.text())).unwrap_or_default();
            println!("  round {}: envelope NRMSE {:.1} %, objective {:.1} (floor {:.1}){pinned}{redo}, then: {}{range}", r.round, r.envelope_nrmse, r.objective, r.floor_objective, r.change_with_values("-"));
        }
    }
    if let Some(p) = json {
        std::fs::write(p, serde_json::to_string_pretty(&serde_json::json!({ "history": history, "diagnosis": last, "final_machine": final_m, "compared_at_hz": meas.fs_hz }))?)?;
    }
    if let Some(p) = save_machine {
        std::fs::write(p, final_m.to_toml()).with_context(|| format!("writing {}", p.display()))?;
        let fitted = match final_m.fitted_effects.as_slice() {
            [] => String::new(),
            ks => format!(" (with fitted_effects = {}, which a calibration from it re-fits)", ks.iter().map(|k| k.name()).collect::<Vec<_>>().join(", ")),
        };
        println!("\nmachine written to {}{fitted}; to go on from it: {}", p.display(), compare::diagnose::go_on_command(measured, p, &go_on_args));
    }
    if !quiet {
        let (reused, integrated) = model::loop_cache_stats();
        eprintln!("twinscope: diagnose took {:.1} s; {integrated} model integrations, {reused} evaluations reused one (the same machine under other measurement effects or another seed it does not draw on)", started.elapsed().as_secs_f64());
    }
    Ok(())
}

/// The yardstick's table cell: a model's objective / the true machine's mean ± sd (its
/// envelope NRMSE %) / the true machine's without the hidden effects.
fn oracle_cell(o: &twinscope::compare::hidden::Oracle, model_objective: f64) -> String {
    let (truth, sd) = o.truth_objective();
    let without = o.without_hidden_objective().map_or("-".into(), |w| format!("{w:.2}"));
    format!("{model_objective:.2} / {truth:.2} ± {sd:.2} ({:.1}) / {without}", o.truth_envelope_nrmse())
}

/// The base machine of a `confusion` table: the preset, with `--substeps` applied and checked.
fn confusion_base(preset: &str, step: &StepArgs) -> Result<twinscope::model::Machine> {
    let mut base = twinscope::model::preset(preset)?;
    if let Some(n) = step.substeps {
        step.apply(&mut base);
        base.validate().with_context(|| format!("--substeps {n}"))?;
    }
    Ok(base)
}

/// `--snr-db` of a `confusion` table, refused before any work when out of range.
fn check_snr_db(snr_db: Option<f64>) -> Result<()> {
    match snr_db {
        Some(snr) if !(snr.is_finite() && (-20.0..=60.0).contains(&snr)) => anyhow::bail!("--snr-db {snr}: give a measurement SNR between -20 and 60 dB"),
        _ => Ok(()),
    }
}

/// `confusion --extra`: each effect put in the model and left out of the measurement, read by
/// the removal trials ([`twinscope::compare::hidden::run_extra_case`]).
#[allow(clippy::too_many_arguments)]
fn extra_confusion_cmd(preset: &str, effects: &[String], duration_s: f64, seed: u64, rounds: usize, setting: twinscope::compare::hidden::CaseSetting, step: &StepArgs, json: Option<&Path>, opts: LoopOptions) -> Result<()> {
    use twinscope::compare::diagnose::effect_values_text;
    use twinscope::compare::hidden;
    use twinscope::compare::removal::RemovalReading;
    use twinscope::model::{EffectKind, Effects};
    let base = confusion_base(preset, step)?;
    let kinds: Vec<EffectKind> = if effects.is_empty() {
        EffectKind::ALL.into_iter().filter(|k| *k != EffectKind::Noise && Effects::applicable(*k, &base)).collect()
    } else {
        effects.iter().map(|n| EffectKind::parse_named(n.trim()).map_err(anyhow::Error::msg)).collect::<Result<_>>()?
    };
    for k in &kinds {
        if *k == EffectKind::Noise {
            anyhow::bail!("--extra --effect noise: the noise is the record's, no part of a model to take out");
        }
        if !Effects::applicable(*k, &base) {
            anyhow::bail!("--extra --effect {}: does not apply to preset {preset}", k.name());
        }
    }
    check_snr_db(setting.snr_db)?;
    let looped = rounds > 1;
    let (loop_head, loop_rule) = if looped { (" the loop: each round's change; the last round's objective / floor (envelope NRMSE %) |", "---|") } else { ("", "") };
    println!("| in the model, not the machine | its parameter | SNR dB | its removal trial (objective with → without; share of the error above the floor) | tie width; floor | the other parts | search's answer |{loop_head} s |");
    println!("|---|---|---:|---|---|---|---|{loop_rule}---:|");
    let mut results: Vec<hidden::ExtraCaseResult> = Vec::new();
    for (i, k) in kinds.iter().enumerate() {
        let r = hidden::run_extra_case(&base, *k, seed + i as u64, duration_s, rounds, &setting, &opts)?;
        let t = r.extra_trial();
        let numbers = t.filter(|t| t.objective_with.is_finite()).map_or("-".to_string(), |t| format!("±{:.2}; {:.2}", t.tie_width, t.floor_objective));
        let reading = t.map_or("no trial".to_string(), |t| t.cell());
        let others = r.removals.iter().filter(|o| Some(*o) != t).map(|o| o.cell()).collect::<Vec<_>>().join("; ");
        let loop_cell = if looped { format!(" {} |", extra_loop_cell(&r.history)) } else { String::new() };
        println!(
            "| {} | {} | {:.1} | {reading} | {numbers} | {} | {} |{loop_cell} {:.0} |",
            k.name(),
            r.parameter.map(|pv| effect_values_text(&[pv])).unwrap_or_else(|| "-".into()),
            r.snr_db,
            if others.is_empty() { "-" } else { &others },
            r.chosen.map(|k| k.name()).unwrap_or("nothing significant"),
            r.seconds
        );
        results.push(r);
        if let Some(p) = json {
            std::fs::write(p, serde_json::to_string_pretty(&results)?)?;
        }
    }
    let count = |want: RemovalReading| results.iter().filter(|r| r.extra_trial().map(|t| t.reading) == Some(want)).count();
    let others_contradicted: Vec<String> = results.iter().flat_map(|r| r.removals.iter().filter(|o| Some(*o) != r.extra_trial() && o.reading == RemovalReading::Contradicted).map(move |o| format!("{} (beside {})", o.cell(), r.extra.name()))).collect();
    println!(
        "\nthe extra effect read contradicted: {}/{}; cannot tell: {}; needed (a false need): {}; other parts read contradicted (false): {}{}",
        count(RemovalReading::Contradicted),
        results.len(),
        count(RemovalReading::CannotTell),
        count(RemovalReading::Needed),
        others_contradicted.len(),
        if others_contradicted.is_empty() { String::new() } else { format!(": {}", others_contradicted.join("; ")) }
    );
    if looped {
        let clean = results.iter().filter(|r| r.extra_taken_out() && r.applied().is_empty()).count();
        let claims: Vec<String> = results.iter().flat_map(|r| r.applied().into_iter().map(move |k| format!("{} (beside {})", k.name(), r.extra.name()))).collect();
        println!(
            "loops that took the extra effect out and end with nothing applied: {clean}/{}; effects left applied (false claims): {}{}",
            results.len(),
            claims.len(),
            if claims.is_empty() { String::new() } else { format!(": {}", claims.join("; ")) }
        );
    }
    Ok(())
}

/// An extra-effect loop in a table cell: each round's change (`r1: took out casing_modes
/// before adding misalignment`), then the last round's objective / floor and envelope NRMSE.
fn extra_loop_cell(history: &[twinscope::compare::diagnose::Round]) -> String {
    let rounds: Vec<String> = history.iter().map(|r| format!("r{}: {}", r.round, r.change_with_values("nothing significant"))).collect();
    let last = history.last().map_or("-".to_string(), |r| format!("{:.2} / {:.2} ({:.1})", r.objective, r.floor_objective, r.envelope_nrmse));
    format!("{}; {last}", rounds.join(", "))
}

#[allow(clippy::too_many_arguments)]
fn confusion_cmd(preset: &str, effects: &[String], hide: &[String], rounds: Option<usize>, controls: usize, duration_s: f64, seed: u64, values: &[f64], setting: twinscope::compare::hidden::CaseSetting, step: &StepArgs, json: Option<&Path>, opts: LoopOptions) -> Result<()> {
    use twinscope::compare::diagnose::effect_values_text;
    use twinscope::compare::hidden;
    use twinscope::model::{EffectKind, Effects};
    let base = confusion_base(preset, step)?;
    let parse = |n: &str| EffectKind::parse_named(n.trim()).map_err(anyhow::Error::msg);
    let kinds: Vec<EffectKind> = if effects.is_empty() && hide.is_empty() {
        EffectKind::ALL.into_iter().filter(|k| Effects::applicable(*k, &base)).collect()
    } else {
        effects.iter().map(|n| parse(n)).collect::<Result<_>>()?
    };
    let groups: Vec<Vec<EffectKind>> = hide
        .iter()
        .map(|g| {
            let ks = g.split('+').map(parse).collect::<Result<Vec<_>>>().with_context(|| format!("--hide {g}"))?;
            for (i, k) in ks.iter().enumerate() {
                if ks[..i].contains(k) {
                    anyhow::bail!("--hide {g}: `{}` is named twice", k.name());
                }
                if !Effects::applicable(*k, &base) {
                    anyhow::bail!("--hide {g}: `{}` does not apply to preset {preset}", k.name());
                }
            }
            Ok(ks)
        })
        .collect::<Result<_>>()?;
    check_snr_db(setting.snr_db)?;
    if setting.snr_db.is_some() && (kinds.contains(&EffectKind::Noise) || groups.iter().flatten().any(|k| *k == EffectKind::Noise)) {
        anyhow::bail!("--snr-db: not with `noise` hidden, whose own value is the SNR (give it with --value)");
    }
    // (hidden effect, fixed value, seed) of each single case: a sweep keeps one seed.
    let mut cases: Vec<(Option<EffectKind>, Option<f64>, u64)> = Vec::new();
    if values.is_empty() {
        cases.extend(kinds.iter().enumerate().map(|(i, k)| (Some(*k), None, seed + i as u64)));
        cases.extend((0..controls).map(|i| (None, None, seed + (kinds.len() + i) as u64)));
    } else {
        let [k] = kinds[..] else { anyhow::bail!("--value sweeps one effect: give exactly one --effect (got {})", kinds.len()) };
        let Some(p) = twinscope::compare::Param::main_of_effect(k) else { anyhow::bail!("--value: `{}` is a switch without a parameter", k.name()) };
        for v in values {
            // Refused here, before any case runs, with the model's own message.
            let (truth, ..) = hidden::make_case_set(&base, &[k], seed, &hidden::CaseSetting { value: Some(*v), ..setting });
            truth.validate().with_context(|| format!("--value {v} for {} ({})", k.name(), p.name()))?;
            cases.push((Some(k), Some(*v), seed));
        }
        cases.extend(std::iter::repeat_n((None, None, seed), controls));
    }
    let mut results = Vec::new();
    let mut multi = Vec::new();
    let write_json = |results: &Vec<hidden::CaseResult>, multi: &Vec<hidden::MultiCaseResult>| -> Result<()> {
        if let Some(p) = json {
            // Written after every case, so a long run can be read while it goes on.
            let v = if multi.is_empty() { serde_json::to_value(results)? } else { serde_json::json!({ "single": results, "multi": multi }) };
            std::fs::write(p, serde_json::to_string_pretty(&v)?)?;
        }
        Ok(())
    };
    // With --removal-trials a last column reads each part of the starting model.
    let (removal_head, removal_rule) = if opts.removal_trials { (" removal trials (objective with → without each part) |", "---|") } else { ("", "") };
    if !cases.is_empty() {
        println!("| hidden | true parameter | SNR dB | objective / floor | chosen | rank of hidden | hidden explains (% above floor) | envelope NRMSE before → after (%) | calibrated objective / true machine's (envelope NRMSE %) / without the hidden | recoverable | hidden's trial recovers (%) | s |{removal_head}");
        println!("|---|---|---:|---:|---|---:|---:|---|---|---|---:|---:|{removal_rule}");
    }
    for (h, value, case_seed) in &cases {
        let r = hidden::run_case_set(&base, *h, *case_seed, duration_s, &hidden::CaseSetting { value: *value, ..setting }, &opts)?;
        let tp = r.true_parameter.map(|pv| effect_values_text(&[pv])).unwrap_or_else(|| "-".into());
        let calibrated = r.calibrated_objective();
        let explains = r.hidden_trial().map_or("-".to_string(), |t| format!("{:.0}", t.explained * 100.0));
        let oracle = oracle_cell(&r.oracle, calibrated);
        let recovers = r.hidden_trial().map(|t| r.oracle.recovered(calibrated, t.objective_after)).filter(|x| x.is_finite()).map_or("-".to_string(), |x| format!("{:.0}", x * 100.0));
        println!(
            "| {} | {} | {:.1} | {:.2} | {} | {} | {} | {:.1} → {:.1} | {} | {} | {} | {:.0} |{}",
            h.map(|k| k.name()).unwrap_or("(control)"),
            tp,
            r.snr_db,
            calibrated / r.floor_objective,
            r.chosen.map(|k| k.name()).unwrap_or("nothing significant"),
            r.rank_of_hidden.map(|x| x.to_string()).unwrap_or_else(|| "-".into()),
            explains,
            r.envelope_nrmse_before,
            r.envelope_nrmse_after,
            oracle,
            r.oracle.reading(calibrated).unwrap_or("-"),
            recovers,
            r.seconds,
            if opts.removal_trials { format!(" {} |", r.removals.iter().map(|t| t.cell()).collect::<Vec<_>>().join("; ")) } else { String::new() }
        );
        results.push(r);
        write_json(&results, &multi)?;
    }
    if !cases.is_empty() {
        let hits = results.iter().filter(|r| r.hidden.is_some() && r.chosen == r.hidden).count();
        let ok_controls = results.iter().filter(|r| r.hidden.is_none() && r.chosen.is_none()).count();
        println!("\nhidden effect ranked first and chosen: {hits}/{}; controls answered nothing significant: {ok_controls}/{controls}", cases.len() - controls);
        if opts.removal_trials {
            // Every part of a starting model is in its true machine: a contradicted one is false.
            let judged: usize = results.iter().map(|r| r.removals.len()).sum();
            use twinscope::compare::removal::RemovalReading;
            let contradicted: Vec<String> = results.iter().flat_map(|r| r.removals.iter().filter(|t| t.reading == RemovalReading::Contradicted).map(move |t| format!("{} ({})", t.cell(), r.hidden.map_or("control", |k| k.name())))).collect();
            let needed = results.iter().flat_map(|r| &r.removals).filter(|t| t.reading == RemovalReading::Needed).count();
            println!("removal trials: {judged} parts judged, {needed} needed, {} contradicted (each part is in the true machine, so a contradiction is false){}", contradicted.len(), if contradicted.is_empty() { String::new() } else { format!(": {}", contradicted.join("; ")) });
        }
        let recoverable: Vec<&hidden::CaseResult> = results.iter().filter(|r| r.recoverable()).collect();
        let found = recoverable.iter().filter(|r| r.chosen == r.hidden).count();
        let halved = recoverable.iter().filter(|r| r.chosen == r.hidden && r.envelope_nrmse_after <= 0.5 * r.envelope_nrmse_before).count();
        let truth_cannot = recoverable.iter().filter(|r| r.chosen == r.hidden && r.envelope_nrmse_after > 0.5 * r.envelope_nrmse_before && r.oracle.truth_envelope_nrmse() > 0.5 * r.envelope_nrmse_before).count();
        println!(
            "recoverable (the true machine, re-seeded, beats the calibrated model, and without its hidden effect it does not): {}; of those found: {found}, with envelope NRMSE at least halved: {halved}, not halved where the true machine itself stays above half: {truth_cannot}",
            recoverable.len()
        );
        let missed: Vec<String> = recoverable.iter().filter_map(|r| Some(format!("{}: {}", r.hidden?.name(), r.miss()?.text()))).collect();
        if !missed.is_empty() {
            println!("recoverable and not chosen: {}", missed.join("; "));
        }
        // With --strength-range: does the chosen hidden effect's range hold its true value?
        let ranged: Vec<(bool, String)> = results
            .iter()
            .filter(|r| r.chosen.is_some() && r.chosen == r.hidden)
            .filter_map(|r| {
                let (range, (p, v), k) = (r.strength_range.as_ref()?, r.true_parameter?, r.hidden?);
                let holds = range.contains(v);
                (range.parameter == p).then(|| (holds, format!("{} {v:.3e}: {} {}", k.name(), range.text(), if holds { "holds it" } else { "misses it" })))
            })
            .collect();
        if !ranged.is_empty() {
            let held = ranged.iter().filter(|(holds, _)| *holds).count();
            println!("strength ranges holding the true value: {held} of {}: {}", ranged.len(), ranged.iter().map(|(_, t)| t.as_str()).collect::<Vec<_>>().join("; "));
        }
    }
    if groups.is_empty() {
        return Ok(());
    }
    println!("\n| hidden | true parameters | SNR dB | each round: envelope NRMSE % (objective / floor) → effect applied | all found | false claims | missed (rank, explains in the last round) | applied, as fitted at the end | last round's objective / true machine's (envelope NRMSE %) / without the hidden |");
    println!("|---|---|---:|---|---|---|---|---|---|");
    for (j, g) in groups.iter().enumerate() {
        let r = hidden::run_multi_case_set(&base, g, seed + (cases.len() + j) as u64, duration_s, rounds.unwrap_or(g.len() + 2), &setting, &opts)?;
        let names = |ks: &[EffectKind]| ks.iter().map(|k| k.name()).collect::<Vec<_>>().join(" + ");
        let tp = effect_values_text(&r.true_parameters);
        let steps = r.history.iter().map(|h| format!("{:.1} ({:.2}) → {}", h.envelope_nrmse, h.objective / h.floor_objective, h.change_with_values("nothing significant"))).collect::<Vec<_>>().join("; ");
        let missed = r.missed.iter().map(|(k, at)| match at {
            Some((i, e)) => format!("{} ({i}, {:.0} %)", k.name(), e * 100.0),
            None => format!("{} (not tried)", k.name()),
        }).collect::<Vec<_>>().join(", ");
        println!(
            "| {} | {} | {:.1} | {} | {} | {} | {} | {} | {} |",
            names(&r.hidden),
            if tp.is_empty() { "-".into() } else { tp },
            r.snr_db,
            steps,
            if r.found_all { "yes" } else { "no" },
            if r.false_claims.is_empty() { "none".into() } else { names(&r.false_claims) },
            if missed.is_empty() { "-".into() } else { missed },
            if r.final_values.is_empty() { "-".into() } else { effect_values_text(&r.final_values) },
            oracle_cell(&r.oracle, r.history.last().map_or(f64::NAN, |h| h.objective))
        );
        multi.push(r);
        write_json(&results, &multi)?;
    }
    let all = multi.iter().filter(|r| r.found_all).count();
    let clean = multi.iter().filter(|r| r.false_claims.is_empty()).count();
    println!("\nevery hidden effect found: {all}/{}; cases without a false claim: {clean}/{}", multi.len(), multi.len());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(args: &[&str]) -> Vec<String> {
        let mut cli = <Cli as clap::CommandFactory>::command();
        let m = cli.try_get_matches_from_mut(args).unwrap();
        search_words(&cli, &m)
    }

    /// The search options a `diagnose` run was given, and only those, come back as typed: flags,
    /// values, a value with its delimiter; defaults, the read and compare options and other
    /// commands give none.
    #[test]
    fn the_search_options_given_are_repeated_as_typed() {
        let w = words(&["twinscope", "diagnose", "m.wav", "--preset", "mfs_healthy", "--rounds", "2", "--with", "noise", "--fit-duration-s", "3", "--no-coupled-forces", "--domain-weights", "1,0,0", "--band-hz", "1800,3000", "--floor-margin=0.2"]);
        assert_eq!(w, ["--no-coupled-forces", "--floor-margin", "0.2", "--fit-duration-s", "3", "--domain-weights", "1,0,0"]);
        // Parsed back, they set the same options.
        let again = <Cli as clap::CommandFactory>::command().try_get_matches_from(["twinscope", "diagnose", "m.wav"].iter().copied().chain(w.iter().map(|s| s.as_str()))).unwrap();
        let (Some(Command::Diagnose { search: a, .. }), Some(Command::Diagnose { search: b, .. })) = (
            <Cli as clap::FromArgMatches>::from_arg_matches(&again).unwrap().command,
            Cli::try_parse_from(["twinscope", "diagnose", "m.wav", "--fit-duration-s", "3", "--no-coupled-forces", "--domain-weights", "1,0,0", "--floor-margin", "0.2"]).unwrap().command,
        ) else {
            panic!("not diagnose")
        };
        assert_eq!(a.options(), b.options());
        assert!(words(&["twinscope", "diagnose", "m.wav", "--preset", "mfs_healthy"]).is_empty());
        assert!(words(&["twinscope", "confusion", "--fit-duration-s", "3"]).is_empty());
    }
}
