//! Headless jobs: `twinscope --batch JOB.toml`.
//!
//! A job names its inputs (files, directories or globs), the machine (bearing, shaft speed),
//! a chain (a preset, a chain file or inline stages) and what to write. Inputs run in parallel
//! (rayon); each requested stage output is written as CSV, and a JSON summary lists inputs,
//! parameters and the detected peaks labelled with the nearest characteristic frequency.
//! The format is documented in README.md ("Batch jobs").

mod job;
mod output;

pub use job::{ChainSpec, InputSource, InputSpec, Job, LoopSpec, MachineSpec, OutputSpec, SimulateSpec};
pub use output::{InputSummary, JobSummary, LoopReport, PeakReport};

use crate::chain::{ChainContext, ChainError};
use crate::signal::io::{self, IoError};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use thiserror::Error;

/// A batch failure. Each message names the job file, input file or parameter at fault.
#[derive(Debug, Error)]
pub enum BatchError {
    /// The job file could not be read or parsed.
    #[error("job {path}: {message}")]
    Job { path: String, message: String },
    /// An input file failed to load.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A chain failed on an input.
    #[error("{input}: {source}")]
    Chain { input: String, source: ChainError },
    /// A simulation failed.
    #[error("{input}: {message}")]
    Simulate { input: String, message: String },
    /// The model loop failed on an input.
    #[error("{input}: model loop: {message}")]
    Loop { input: String, message: String },
    /// Writing an output failed.
    #[error("writing {path}: {message}")]
    Write { path: String, message: String },
    /// Some inputs failed; the others were written.
    #[error("{failed} of {total} inputs failed; first: {first}")]
    Partial { failed: usize, total: usize, first: String },
}

/// Progress callbacks (the CLI shows them on stderr).
pub trait Progress: Sync {
    /// Called once the input list is known.
    fn start(&self, total_inputs: usize);
    /// Called when an input finishes (ok or not).
    fn input_done(&self, done: usize, total: usize, input: &Path, ok: bool);
    /// Called after each model evaluation of an input's `[model_loop]` (`done` of `expected`
    /// in the current round).
    fn model_evaluations(&self, _input: &str, _done: usize, _expected: usize) {}
}

/// A progress sink that shows nothing.
pub struct Silent;
impl Progress for Silent {
    fn start(&self, _: usize) {}
    fn input_done(&self, _: usize, _: usize, _: &Path, _: bool) {}
}

/// Runs a job file. Relative paths in the job are taken from the job file's directory;
/// outputs are written under `output.dir`. Returns the job summary (also written as
/// `summary.json`).
pub fn run_job_file(path: &Path, progress: &dyn Progress) -> Result<JobSummary, BatchError> {
    let job = Job::from_file(path)?;
    run_job(&job, progress)
}

/// Runs a parsed job.
pub fn run_job(job: &Job, progress: &dyn Progress) -> Result<JobSummary, BatchError> {
    let chain = job.chain()?;
    // The loop's machine and options, resolved once for every input (bad settings fail here,
    // before any output is written).
    let model_loop = match &job.model_loop {
        Some(spec) => {
            let bad = |message: String| BatchError::Job { path: job.path.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "job".into()), message };
            let (m, opts) = (spec.machine(&job.base()).map_err(bad)?, spec.options(&chain).map_err(bad)?);
            crate::compare::calibrate::check_refit_effects(&m, &opts.refit_effects).map_err(|e| bad(format!("`model_loop.refit`: {e}")))?;
            crate::compare::calibrate::check_refit_effects(&m, &m.fitted_effects).map_err(|e| bad(format!("the machine's `fitted_effects`: {e}")))?;
            Some((spec.rounds, m, opts, spec.band_from_kurtogram))
        }
        None => None,
    };
    let inputs = job.sources()?;
    let out_dir = job.output_dir();
    std::fs::create_dir_all(&out_dir).map_err(|e| BatchError::Write { path: out_dir.display().to_string(), message: e.to_string() })?;
    progress.start(inputs.len());
    let done = AtomicUsize::new(0);
    let stems = output::unique_stems(&inputs.iter().map(|i| PathBuf::from(i.stem(job))).collect::<Vec<_>>());
    let results: Vec<Result<InputSummary, BatchError>> = inputs
        .par_iter()
        .zip(stems.par_iter())
        .map(|(input, stem)| {
            let r = run_one(job, &chain, model_loop.as_ref(), input, &out_dir.join(stem), progress);
            let d = done.fetch_add(1, Ordering::SeqCst) + 1;
            progress.input_done(d, inputs.len(), Path::new(&input.display_name(job)), r.is_ok());
            r
        })
        .collect();
    let mut summaries = Vec::new();
    let mut errors = Vec::new();
    for r in results {
        match r {
            Ok(s) => summaries.push(s),
            Err(e) => errors.push(e.to_string()),
        }
    }
    let summary = JobSummary {
        job: job.name.clone(),
        job_file: job.path.as_ref().map(|p| p.display().to_string()),
        chain: chain.name.clone(),
        chain_toml: chain.to_toml(),
        inputs: summaries,
        errors: errors.clone(),
    };
    output::write_json(&out_dir.join("summary.json"), &summary)?;
    if let Some(first) = errors.first() {
        return Err(BatchError::Partial { failed: errors.len(), total: inputs.len(), first: first.clone() });
    }
    Ok(summary)
}

/// A resolved `[model_loop]`: rounds, starting machine, options.
/// A resolved `[model_loop]`: rounds, starting machine, options, and whether each input's
/// demodulation band comes from its kurtogram.
type ModelLoop = (usize, crate::model::Machine, crate::compare::LoopOptions, bool);

fn run_one(job: &Job, chain: &crate::chain::Chain, model_loop: Option<&ModelLoop>, input: &InputSource, dir: &Path, progress: &dyn Progress) -> Result<InputSummary, BatchError> {
    let signal = match input {
        InputSource::File(p) => io::load(p, &job.input.load_options())?,
        InputSource::Simulated(i) => {
            let spec = &job.input.simulate[*i];
            let name = input.display_name(job);
            let machine = spec.machine(&job.base(), *i).map_err(|message| BatchError::Simulate { input: name.clone(), message })?;
            let s = crate::model::simulate(&machine).map_err(|e| BatchError::Simulate { input: name.clone(), message: e.to_string() })?;
            if let Some(save) = &spec.save {
                std::fs::create_dir_all(dir).map_err(|e| BatchError::Write { path: dir.display().to_string(), message: e.to_string() })?;
                io::save(&s, &dir.join(save))?;
            }
            s
        }
    };
    let bearing = match job.machine.bearing()? {
        Some(b) => Some(b),
        // A signal that names its bearing (a simulation, a WAV sidecar) is used as is.
        None => signal.meta.bearing.as_deref().and_then(|n| crate::kinematics::lookup_bearing(n).ok()),
    };
    let ctx = ChainContext {
        bearing,
        shaft_speed_hz: job.machine.shaft_speed_hz.or(signal.meta.shaft_speed_hz),
    };
    let result = chain.run(&signal, &ctx, |_, _, _| {}).map_err(|source| BatchError::Chain { input: input.display_name(job), source })?;
    std::fs::create_dir_all(dir).map_err(|e| BatchError::Write { path: dir.display().to_string(), message: e.to_string() })?;
    let mut summary = output::write_input(job, &signal, &ctx, &result, dir)?;
    if let Some((rounds, m, opts, band_from_kurtogram)) = model_loop {
        let name = input.display_name(job);
        let mut opts = opts.clone();
        // The model holds nothing above its Nyquist frequency: a faster-sampled input is
        // compared at the model's rate (as run_loop would), its band chosen there too.
        let signal = crate::compare::at_most_rate(&signal, m.fs_hz).map_err(|e| BatchError::Loop { input: name.clone(), message: e.to_string() })?;
        if *band_from_kurtogram {
            let best = crate::compare::demodulation_band::demodulation_band(&signal, &opts.compare, &m.structural_resonances_hz()).map_err(|e| BatchError::Loop { input: name.clone(), message: format!("`model_loop.band_from_kurtogram`: {e}") })?.band;
            opts.compare.envelope_band_hz = best.band_hz;
        }
        let (final_m, history, last) = crate::compare::run_loop(m, &signal, *rounds, &opts, &|done, expected| {
            progress.model_evaluations(&name, done, expected);
            true
        })
        .map_err(|e| BatchError::Loop { input: name.clone(), message: e.to_string() })?;
        summary.model_loop = Some(output::write_loop(dir, &history, &last, &final_m, opts.compare.envelope_band_hz)?);
    }
    output::write_json(&dir.join("summary.json"), &summary)?;
    Ok(summary)
}
