//! Writing batch outputs: CSV per requested stage, JSON summaries.

use super::{BatchError, Job};
use crate::chain::{ChainContext, ChainResult, Data};
use crate::kinematics::{nearest_line, CharacteristicFrequency, FaultFrequencies, LineMatch};
use crate::signal::Signal;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A detected spectral peak and the characteristic line nearest to it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeakReport {
    /// Peak frequency in Hz (parabolic interpolation).
    pub frequency_hz: f64,
    /// Peak value in the spectrum's unit.
    pub value: f64,
    /// Nearest characteristic line (harmonic and shaft sideband), when the machine is known.
    pub nearest: Option<LineMatch>,
}

/// One written output.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct OutputReport {
    /// Stage reference (`name` or `name:extra`).
    pub stage: String,
    /// What it holds (`time signal`, `spectrum`, ...).
    pub data: String,
    /// CSV file written.
    pub path: String,
    /// Top peaks (spectra only), strongest first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub peaks: Vec<PeakReport>,
}

/// The summary of one input.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct InputSummary {
    /// Input file.
    pub file: String,
    /// Channel or variable read.
    pub channel: Option<String>,
    /// Sampling rate, Hz.
    pub fs_hz: f64,
    /// Samples.
    pub samples: usize,
    /// Duration, s.
    pub duration_s: f64,
    /// Unit of the samples.
    pub unit: String,
    /// Shaft speed used, Hz.
    pub shaft_speed_hz: Option<f64>,
    /// Bearing used.
    pub bearing: Option<String>,
    /// Characteristic frequencies at that speed.
    pub fault_frequencies: Option<FaultFrequencies>,
    /// Per-stage parameters (as run) and reported figures.
    pub stages: Vec<BTreeMap<String, serde_json::Value>>,
    /// CSV outputs with their peaks.
    pub outputs: Vec<OutputReport>,
    /// What `[model_loop]` did on this input.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_loop: Option<LoopReport>,
}

/// What `[model_loop]` did on one input: the error of every round, so it is seen falling.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopReport {
    /// Every round: effects on at its start, metrics of the calibrated model, the verdict and
    /// the effect applied.
    pub history: Vec<crate::compare::Round>,
    /// Effects applied, in order.
    pub applied: Vec<String>,
    /// The last round's verdict.
    pub verdict: String,
    /// The demodulation band the comparison used, Hz (`band_hz`, the chain's, or the input's
    /// kurtogram's with `band_from_kurtogram`).
    pub demodulation_band_hz: [f64; 2],
    /// The sampling rate the loop compared at, Hz: the input's, or the model's when the input
    /// was sampled faster (resampled down to it: `compare::at_most_rate`).
    pub compared_at_hz: f64,
    /// `model_loop.json`: the history, the last diagnosis (ranking, fitted parameters, floor,
    /// residual map) and the final machine.
    pub json: String,
    /// `model_loop_history.csv`: one row per round.
    pub history_csv: String,
    /// `model_loop_final_machine.toml`: the last round's calibrated machine when that round
    /// applied nothing, else the machine with the last applied effect.
    pub final_machine: String,
}

/// Writes the loop's outputs into `dir`.
pub(super) fn write_loop(dir: &Path, history: &[crate::compare::Round], last: &crate::compare::Diagnosis, final_machine: &crate::model::Machine, demodulation_band_hz: [f64; 2]) -> Result<LoopReport, BatchError> {
    let compared_at_hz = last.compared_at_hz;
    let json = dir.join("model_loop.json");
    write_json(&json, &serde_json::json!({ "history": history, "diagnosis": last, "final_machine": final_machine, "demodulation_band_hz": demodulation_band_hz, "compared_at_hz": compared_at_hz }))?;
    let csv_path = dir.join("model_loop_history.csv");
    let werr = |m: String| BatchError::Write { path: csv_path.display().to_string(), message: m };
    let mut w = csv::Writer::from_path(&csv_path).map_err(|e| werr(e.to_string()))?;
    w.write_record(["round", "effects_on", "envelope_nrmse_percent", "objective", "floor_objective", "objective_scatter", "applied", "applied_values", "removed", "pinned", "unbent_when_stuck", "verdict"]).map_err(|e| werr(e.to_string()))?;
    for r in history {
        let on = r.effects_on.iter().map(|k| k.name()).collect::<Vec<_>>().join(" ");
        w.write_record([r.round.to_string(), on, format!("{:.4}", r.envelope_nrmse), format!("{:.4}", r.objective), format!("{:.4}", r.floor_objective), format!("{:.4}", r.objective_scatter), r.applied_label().unwrap_or_default(), crate::compare::diagnose::effect_values_text(&r.applied_values), r.removed.map(|k| k.name().to_string()).or_else(|| r.taken_out.as_ref().map(|t| t.label.clone())).unwrap_or_default(), r.pinned.iter().map(|p| p.name()).collect::<Vec<_>>().join(" "), r.unbent_when_stuck.to_string(), r.verdict.clone()]).map_err(|e| werr(e.to_string()))?;
    }
    w.flush().map_err(|e| werr(e.to_string()))?;
    let toml_path = dir.join("model_loop_final_machine.toml");
    std::fs::write(&toml_path, final_machine.to_toml()).map_err(|e| BatchError::Write { path: toml_path.display().to_string(), message: e.to_string() })?;
    Ok(LoopReport {
        history: history.to_vec(),
        applied: crate::compare::diagnose::applied_effects(history).iter().map(|k| k.name().to_string()).collect(),
        verdict: last.verdict.clone(),
        demodulation_band_hz,
        compared_at_hz,
        json: json.display().to_string(),
        history_csv: csv_path.display().to_string(),
        final_machine: toml_path.display().to_string(),
    })
}

/// The summary of a whole job (`summary.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JobSummary {
    /// Job name.
    pub job: String,
    /// Job file.
    pub job_file: Option<String>,
    /// Chain name.
    pub chain: String,
    /// The chain as run, in TOML.
    pub chain_toml: String,
    /// One entry per input that succeeded.
    pub inputs: Vec<InputSummary>,
    /// One line per input that failed.
    pub errors: Vec<String>,
}

/// File stems made unique (`a`, `a_2`, ...) so outputs never collide.
pub fn unique_stems(inputs: &[PathBuf]) -> Vec<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    inputs
        .iter()
        .map(|p| {
            let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "input".into());
            let n = seen.entry(stem.clone()).or_insert(0);
            *n += 1;
            if *n == 1 { stem } else { format!("{stem}_{n}") }
        })
        .collect()
}

pub(super) fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), BatchError> {
    let werr = |m: String| BatchError::Write { path: path.display().to_string(), message: m };
    let text = serde_json::to_string_pretty(value).map_err(|e| werr(e.to_string()))?;
    std::fs::write(path, text).map_err(|e| werr(e.to_string()))
}

fn csv_name(reference: &str) -> String {
    reference.replace([':', '/', '\\'], "_") + ".csv"
}

/// Writes `data` as CSV: `time_s,<q>`, `frequency_hz,<q>`, or for the SCF a long table
/// `alpha_hz,frequency_hz,scf_magnitude,coherence`.
pub fn write_data_csv(path: &Path, data: &Data) -> Result<(), BatchError> {
    let werr = |e: std::io::Error| BatchError::Write { path: path.display().to_string(), message: e.to_string() };
    let f = std::fs::File::create(path).map_err(werr)?;
    let mut w = std::io::BufWriter::new(f);
    match data {
        Data::Time(s) => {
            writeln!(w, "time_s,{}", quantity_name(&s.name, &s.unit)).map_err(werr)?;
            for (i, v) in s.samples.iter().enumerate() {
                writeln!(w, "{},{}", s.time_s(i), v).map_err(werr)?;
            }
        }
        Data::Spectrum(sp) => {
            writeln!(w, "frequency_hz,{}", quantity_name(&sp.quantity, &sp.unit)).map_err(werr)?;
            for (f, v) in sp.frequency_hz.iter().zip(&sp.values) {
                writeln!(w, "{f},{v}").map_err(werr)?;
            }
        }
        Data::Scf(m) => {
            writeln!(w, "alpha_hz,frequency_hz,scf_magnitude,coherence").map_err(werr)?;
            let mag = m.magnitude();
            let nf = m.frequency_hz.len();
            for (ia, a) in m.alpha_hz.iter().enumerate() {
                for (jf, f) in m.frequency_hz.iter().enumerate() {
                    let k = ia * nf + jf;
                    writeln!(w, "{a},{f},{},{}", mag[k], m.coherence[k]).map_err(werr)?;
                }
            }
        }
        Data::Fir(d) => {
            writeln!(w, "tap_index,coefficient").map_err(werr)?;
            for (i, t) in d.taps.iter().enumerate() {
                writeln!(w, "{i},{t}").map_err(werr)?;
            }
        }
    }
    w.flush().map_err(werr)
}

/// A CSV column name: the quantity, with its unit in brackets when known.
fn quantity_name(q: &str, unit: &str) -> String {
    let q: String = q.chars().map(|c| if c == ',' || c == '\n' { '_' } else { c }).collect();
    if unit.is_empty() { q } else { format!("{q} [{unit}]") }
}

/// Writes the requested stage outputs of one input as CSV and returns its summary; the caller
/// writes that as the input's `summary.json` once the model loop, if any, has added to it.
pub(super) fn write_input(job: &Job, signal: &Signal, ctx: &ChainContext, result: &ChainResult, dir: &Path) -> Result<InputSummary, BatchError> {
    let ff = ctx.fault_frequencies();
    let families: Vec<CharacteristicFrequency> = match (&ff, ctx.shaft_speed_hz) {
        (Some(f), _) => f.families(),
        (None, Some(fr)) => vec![CharacteristicFrequency { label: "shaft".into(), frequency_hz: fr }],
        _ => Vec::new(),
    };
    let wanted: Vec<String> = if job.output.stages.is_empty() {
        result.last().map(|s| vec![s.name.clone()]).unwrap_or_default()
    } else if job.output.stages.iter().any(|s| s == "all") {
        result.stages.iter().map(|s| s.name.clone()).collect()
    } else {
        job.output.stages.clone()
    };
    let mut outputs = Vec::new();
    for r in &wanted {
        let data = result.get(r).ok_or_else(|| BatchError::Job {
            path: "output.stages".into(),
            message: format!("`{r}` is not a stage of chain `{}` (stages: {})", "run", result.stages.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ")),
        })?;
        let path = dir.join(csv_name(r));
        write_data_csv(&path, data)?;
        let peaks = match data {
            Data::Spectrum(sp) => sp
                .top_peaks(job.output.peaks, job.output.peak_min_separation_hz)
                .map_err(|e| BatchError::Job { path: "output".into(), message: format!("peak search on `{r}`: {e}") })?
                .into_iter()
                .map(|(f, v)| PeakReport {
                    frequency_hz: f,
                    value: v,
                    nearest: nearest_line(f, &families, ctx.shaft_speed_hz.filter(|_| ff.is_some()), job.output.max_harmonic, job.output.max_sideband, job.output.label_tolerance_percent),
                })
                .collect(),
            _ => Vec::new(),
        };
        outputs.push(OutputReport { stage: r.clone(), data: data.describe().into(), path: path.display().to_string(), peaks });
    }
    let stages = result
        .stages
        .iter()
        .map(|s| {
            let mut m = BTreeMap::new();
            m.insert("name".to_string(), serde_json::Value::from(s.name.clone()));
            m.insert("kind".to_string(), serde_json::Value::from(s.kind));
            for (k, v) in &s.report {
                m.insert(k.clone(), v.clone());
            }
            m
        })
        .collect();
    let summary = InputSummary {
        file: signal.meta.source.clone().unwrap_or_default(),
        channel: signal.meta.channel.clone(),
        fs_hz: signal.fs_hz,
        samples: signal.len(),
        duration_s: signal.duration_s(),
        unit: signal.unit.clone(),
        shaft_speed_hz: ctx.shaft_speed_hz,
        bearing: ctx.bearing.as_ref().map(|b| b.name.clone()),
        fault_frequencies: ff,
        stages,
        outputs,
        model_loop: None,
    };
    Ok(summary)
}
