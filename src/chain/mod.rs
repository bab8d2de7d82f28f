//! Processing chains: an ordered, serialisable list of DSP stages.
//!
//! A chain is data (TOML), in the spirit of RustFFT's recipes: each `[[stage]]` names its
//! `kind` and that operation's parameters; the keys `name` (how later stages and outputs
//! address it; default: the kind), `input` (an earlier stage, `raw`, or `stage:extra`, e.g.
//! `drs:deterministic`; default: the previous stage), `fault` (for `stsa`: `bpfo`, `bpfi`,
//! `bsf`, `2xbsf`, `ftf`, `shaft` or a number of Hz) and `band_hz` (for `spectrum` and `welch`:
//! cut the result to a band) are handled by the chain itself. Every intermediate result is kept
//! and addressable by stage name.
//!
//! ```toml
//! name = "envelope"
//! [[stage]]
//! kind = "normalise"
//! method = "peak"
//! [[stage]]
//! kind = "bandpass"
//! pass_band_hz = [900.0, 1800.0]
//! ```

mod ops;

pub use ops::{FaultRef, HilbertEnvelopeParams, Op};

use crate::dsp::{remez::FirDesign, scf::ScfMap, spectrum::Spectrum};
use crate::kinematics::{BearingGeometry, FaultFrequencies};
use crate::signal::Signal;
use std::collections::BTreeMap;
use thiserror::Error;

/// Errors from building or running a chain; each names the stage (and parameter) at fault.
#[derive(Debug, Error)]
pub enum ChainError {
    /// The chain description could not be read.
    #[error("chain {source_name}: {message}")]
    Parse { source_name: String, message: String },
    /// A stage failed while running.
    #[error("stage `{stage}`: {message}")]
    Stage { stage: String, message: String },
    /// A preset name is unknown.
    #[error("unknown chain preset `{0}`; presets: {1}")]
    UnknownPreset(String, String),
}

/// Data passed between stages.
#[derive(Debug, Clone)]
pub enum Data {
    /// A time signal.
    Time(Signal),
    /// A spectrum (amplitude spectrum, PSD, envelope spectrum, ...).
    Spectrum(Spectrum),
    /// A cyclic spectral correlation map.
    Scf(ScfMap),
    /// An FIR design (an extra of the bandpass stage).
    Fir(FirDesign),
}

impl Data {
    /// A short description for messages: `time signal`, `spectrum`, ...
    pub fn describe(&self) -> &'static str {
        match self {
            Data::Time(_) => "time signal",
            Data::Spectrum(_) => "spectrum",
            Data::Scf(_) => "cyclic spectral correlation map",
            Data::Fir(_) => "FIR design",
        }
    }
}

/// One stage: an operation, its name and where its input comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// Unique name within the chain.
    pub name: String,
    /// Input reference: `None` = the previous stage (or the raw signal for the first stage).
    pub input: Option<String>,
    /// STSA fault reference.
    pub fault: Option<FaultRef>,
    /// Band to cut a spectrum to, in Hz.
    pub band_hz: Option<[f64; 2]>,
    /// The operation and its parameters.
    pub op: Op,
}

/// An ordered list of stages.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain {
    /// Chain name.
    pub name: String,
    /// What the chain is for.
    pub description: String,
    /// Stages in execution order.
    pub stages: Vec<Stage>,
}

/// Machine knowledge a chain may need (fault intervals for STSA, peak labels).
#[derive(Debug, Clone, Default)]
pub struct ChainContext {
    /// The bearing under the sensor.
    pub bearing: Option<BearingGeometry>,
    /// Shaft speed in Hz.
    pub shaft_speed_hz: Option<f64>,
}

impl ChainContext {
    /// Fault frequencies of the bearing at the shaft speed, if both are known.
    pub fn fault_frequencies(&self) -> Option<FaultFrequencies> {
        match (&self.bearing, self.shaft_speed_hz) {
            (Some(b), Some(fr)) => b.fault_frequencies(fr).ok(),
            _ => None,
        }
    }

    /// Resolves an STSA fault reference to Hz.
    pub fn resolve_fault(&self, f: &FaultRef) -> Result<f64, String> {
        match f {
            FaultRef::Hz(hz) => Ok(*hz),
            FaultRef::Named(name) => {
                if name.eq_ignore_ascii_case("shaft") {
                    return self.shaft_speed_hz.ok_or_else(|| "parameter `fault` = \"shaft\" needs the shaft speed (set machine.shaft_speed_hz or load a file that carries it)".to_string());
                }
                let ff = match (&self.bearing, self.shaft_speed_hz) {
                    (None, _) => return Err(format!("parameter `fault` = \"{name}\" needs a bearing (set machine.bearing)")),
                    (_, None) => return Err(format!("parameter `fault` = \"{name}\" needs the shaft speed (set machine.shaft_speed_hz or load a file that carries it)")),
                    (Some(b), Some(fr)) => b.fault_frequencies(fr).map_err(|e| e.to_string())?,
                };
                ff.by_name(name).ok_or_else(|| format!("parameter `fault` = \"{name}\": use bpfo, bpfi, bsf, 2xbsf, ftf, shaft or a frequency in Hz"))
            }
        }
    }
}

/// Output of one stage.
#[derive(Debug, Clone)]
pub struct StageOutput {
    /// Stage name.
    pub name: String,
    /// Operation kind.
    pub kind: &'static str,
    /// Primary output.
    pub data: Data,
    /// Named secondary outputs (e.g. `design` of a bandpass, `deterministic` of DRS).
    pub extras: BTreeMap<String, Data>,
    /// Figures worth reporting (achieved filter figures, the STSA interval, ...).
    pub report: serde_json::Map<String, serde_json::Value>,
}

/// Every intermediate result of a chain run, in order.
#[derive(Debug, Clone)]
pub struct ChainResult {
    /// The input signal (always `Data::Time`).
    pub raw: Data,
    /// One entry per stage, in order.
    pub stages: Vec<StageOutput>,
}

impl ChainResult {
    /// Looks up `raw`, a stage name, or `stage:extra`.
    pub fn get(&self, reference: &str) -> Option<&Data> {
        lookup(&self.raw, &self.stages, reference)
    }

    /// The last stage's output (the raw signal for an empty chain).
    pub fn last(&self) -> Option<&StageOutput> {
        self.stages.last()
    }
}

fn lookup<'a>(raw: &'a Data, stages: &'a [StageOutput], reference: &str) -> Option<&'a Data> {
    if reference == "raw" || reference == "input" {
        return Some(raw);
    }
    let (stage, extra) = match reference.split_once(':') {
        Some((s, e)) => (s, Some(e)),
        None => (reference, None),
    };
    let out = stages.iter().find(|s| s.name == stage)?;
    match extra {
        None => Some(&out.data),
        Some(e) => out.extras.get(e),
    }
}


/// The key of a stage table whose value alone (with the stage's `kind`) gives the error
/// `message`: deserialising from a `toml::Value` keeps no spans, so the error would not say which
/// parameter is wrong. `None` when no single key reproduces it (e.g. a combination of values).
fn culprit_key(t: &toml::Table, message: &str) -> Option<String> {
    let kind = t.get("kind")?;
    t.iter()
        .filter(|(k, _)| k.as_str() != "kind")
        .find(|(k, v)| {
            let mut one = toml::Table::new();
            one.insert("kind".into(), kind.clone());
            one.insert((*k).clone(), (*v).clone());
            matches!(toml::Value::Table(one).try_into::<Op>(), Err(e) if e.message().trim() == message)
        })
        .map(|(k, _)| k.clone())
}

impl Chain {
    /// Parses a chain from TOML text; `source_name` names it in errors (a file path or preset).
    pub fn from_toml(text: &str, source_name: &str) -> Result<Chain, ChainError> {
        let perr = |message: String| ChainError::Parse { source_name: source_name.to_string(), message };
        let table: toml::Table = toml::from_str(text).map_err(|e| perr(e.to_string().trim().replace('\n', " ")))?;
        Self::from_table(table, source_name)
    }

    /// Builds a chain from an already parsed TOML table (e.g. `[chain]` inside a batch job).
    pub fn from_table(mut table: toml::Table, source_name: &str) -> Result<Chain, ChainError> {
        let perr = |message: String| ChainError::Parse { source_name: source_name.to_string(), message };
        let name = match table.remove("name") {
            Some(toml::Value::String(s)) => s,
            Some(v) => return Err(perr(format!("`name` must be a string, got {v}"))),
            None => source_name.to_string(),
        };
        let description = match table.remove("description") {
            Some(toml::Value::String(s)) => s,
            Some(v) => return Err(perr(format!("`description` must be a string, got {v}"))),
            None => String::new(),
        };
        let stages_v = table.remove("stage").ok_or_else(|| perr("no `[[stage]]` entries".into()))?;
        if let Some(k) = table.keys().next() {
            return Err(perr(format!("unknown key `{k}` (a chain has `name`, `description` and `[[stage]]` entries)")));
        }
        let arr = match stages_v {
            toml::Value::Array(a) => a,
            _ => return Err(perr("`stage` must be an array of tables (`[[stage]]`)".into())),
        };
        let mut stages = Vec::with_capacity(arr.len());
        for (i, v) in arr.into_iter().enumerate() {
            let mut t = match v {
                toml::Value::Table(t) => t,
                _ => return Err(perr(format!("stage {} is not a table", i + 1))),
            };
            let kind = t.get("kind").and_then(|k| k.as_str()).map(str::to_string).ok_or_else(|| perr(format!("stage {} has no `kind`", i + 1)))?;
            let sname = match t.remove("name") {
                Some(toml::Value::String(s)) => s,
                Some(v) => return Err(perr(format!("stage {} (`{kind}`): `name` must be a string, got {v}", i + 1))),
                None => kind.clone(),
            };
            let at = |m: String| perr(format!("stage {} `{sname}` (kind `{kind}`): {m}", i + 1));
            let input = match t.remove("input") {
                Some(toml::Value::String(s)) => Some(s),
                Some(v) => return Err(at(format!("`input` must be a stage name, got {v}"))),
                None => None,
            };
            let fault = match t.remove("fault") {
                None => None,
                Some(toml::Value::String(s)) => Some(FaultRef::Named(s)),
                Some(toml::Value::Float(f)) => Some(FaultRef::Hz(f)),
                Some(toml::Value::Integer(n)) => Some(FaultRef::Hz(n as f64)),
                Some(v) => return Err(at(format!("`fault` must be bpfo/bpfi/bsf/2xbsf/ftf/shaft or a frequency in Hz, got {v}"))),
            };
            if fault.is_some() && kind != "stsa" {
                return Err(at("`fault` applies only to `stsa` stages".into()));
            }
            let band_hz = match t.remove("band_hz") {
                None => None,
                Some(v) if kind == "spectrum" || kind == "welch" => {
                    let b: [f64; 2] = v.clone().try_into().map_err(|_| at(format!("`band_hz` must be [low, high] in Hz, got {v}")))?;
                    Some(b)
                }
                Some(v) => {
                    // Stages whose own parameters have a `band_hz` (e.g. envelope_spectrum).
                    t.insert("band_hz".into(), v);
                    None
                }
            };
            let op: Op = toml::Value::Table(t.clone()).try_into().map_err(|e: toml::de::Error| {
                let m = e.message().trim().to_string();
                at(match culprit_key(&t, &m) {
                    Some(k) if !m.contains(&format!("`{k}`")) => format!("`{k}`: {m}"),
                    _ => m,
                })
            })?;
            stages.push(Stage { name: sname, input, fault, band_hz, op });
        }
        let chain = Chain { name, description, stages };
        chain.check_references().map_err(perr)?;
        Ok(chain)
    }

    /// Checks unique names and that every `input` names an earlier stage.
    fn check_references(&self) -> Result<(), String> {
        let mut seen: Vec<&str> = vec!["raw", "input"];
        for (i, s) in self.stages.iter().enumerate() {
            if seen.contains(&s.name.as_str()) {
                return Err(format!("stage {} `{}`: the name is used twice (give one of them `name = \"...\"`)", i + 1, s.name));
            }
            if let Some(r) = &s.input {
                let base = r.split(':').next().unwrap_or(r);
                if !seen.contains(&base) {
                    return Err(format!("stage {} `{}`: `input` = \"{r}\" is not an earlier stage (earlier: {})", i + 1, s.name, seen.join(", ")));
                }
            }
            seen.push(&s.name);
        }
        Ok(())
    }

    /// Serialises the chain back to TOML (round-trips through [`Chain::from_toml`]).
    pub fn to_toml(&self) -> String {
        let mut root = toml::Table::new();
        root.insert("name".into(), self.name.clone().into());
        if !self.description.is_empty() {
            root.insert("description".into(), self.description.clone().into());
        }
        let mut arr = Vec::new();
        for s in &self.stages {
            let mut t = match toml::Value::try_from(&s.op) {
                Ok(toml::Value::Table(t)) => t,
                _ => toml::Table::new(),
            };
            t.insert("name".into(), s.name.clone().into());
            if let Some(i) = &s.input {
                t.insert("input".into(), i.clone().into());
            }
            match &s.fault {
                Some(FaultRef::Named(n)) => {
                    t.insert("fault".into(), n.clone().into());
                }
                Some(FaultRef::Hz(h)) => {
                    t.insert("fault".into(), (*h).into());
                }
                None => {}
            }
            if let Some([a, b]) = s.band_hz {
                t.insert("band_hz".into(), toml::Value::Array(vec![a.into(), b.into()]));
            }
            arr.push(toml::Value::Table(t));
        }
        root.insert("stage".into(), toml::Value::Array(arr));
        toml::to_string(&root).unwrap_or_default()
    }

    /// Runs the chain on `signal`. `progress(i, n, name)` is called before each stage.
    pub fn run(&self, signal: &Signal, ctx: &ChainContext, mut progress: impl FnMut(usize, usize, &str)) -> Result<ChainResult, ChainError> {
        let raw = Data::Time(signal.clone());
        let mut outs: Vec<StageOutput> = Vec::with_capacity(self.stages.len());
        for (i, s) in self.stages.iter().enumerate() {
            progress(i, self.stages.len(), &s.name);
            let input = match &s.input {
                Some(r) => lookup(&raw, &outs, r).ok_or_else(|| ChainError::Stage { stage: s.name.clone(), message: format!("input `{r}` does not exist") })?,
                None => outs.last().map(|o| &o.data).unwrap_or(&raw),
            };
            let out = ops::run_op(&s.op, &s.name, input, ctx, s.fault.as_ref(), s.band_hz)?;
            outs.push(out);
        }
        progress(self.stages.len(), self.stages.len(), "done");
        Ok(ChainResult { raw, stages: outs })
    }
}

/// The bundled chain presets (`assets/chains/*.toml`), compiled into the binary.
pub const PRESETS: [(&str, &str); 4] = [
    ("envelope", include_str!("../../assets/chains/envelope.toml")),
    ("envelope_cwru", include_str!("../../assets/chains/envelope_cwru.toml")),
    ("drs_scf", include_str!("../../assets/chains/drs_scf.toml")),
    ("welch", include_str!("../../assets/chains/welch.toml")),
];

/// Loads a bundled preset by name.
pub fn preset(name: &str) -> Result<Chain, ChainError> {
    let (_, text) = PRESETS
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| ChainError::UnknownPreset(name.to_string(), PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", ")))?;
    Chain::from_toml(text, &format!("preset `{name}`"))
}
