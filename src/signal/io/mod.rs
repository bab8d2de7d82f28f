//! Signal file input/output: WAV, CSV and MATLAB v5 `.mat`.
//!
//! [`load`] reads one channel of a file into a [`Signal`], [`inspect`] lists what a file holds
//! (for `twinscope info FILE`) and [`save`] writes a signal as `.wav` (plus a JSON sidecar) or
//! `.csv`. The format is chosen from the file extension, case-insensitively ([`FileFormat`]).
//!
//! Byte-level entry points that never touch the disk are provided per format for testing and
//! fuzzing: [`wav::read_bytes`], [`csv::read_bytes`] / [`csv::read_str`], [`mat::read_bytes`],
//! and the matching `inspect_*` functions.
//!
//! Every error names the file (and the line, column, channel or variable where relevant) and
//! what was wrong; no input, however malformed, makes these functions panic.
//!
//! Sampling-rate priority for every format: `LoadOptions::fs_hz` > a rate stored in the file
//! (WAV header / sidecar, CSV time column or metadata comment, MAT `fs` variable) > the CWRU
//! `12k`/`48k` file-name token (MAT only) > error.
//!
//! Provenance: on load, `meta.source` is always the path just read, even when a sidecar or
//! metadata comment recorded another source.

pub mod csv;
pub mod mat;
pub mod sidecar;
pub mod wav;

use crate::dsp::error::{check_fs, DspError};
use crate::signal::Signal;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// What went wrong reading or writing a signal file. Every message starts with the file.
#[derive(Debug, Error)]
pub enum IoError {
    /// The file could not be opened, read or written.
    #[error("{file}: cannot {action} file ({source})")]
    Os { file: String, action: &'static str, source: std::io::Error },

    /// The file holds no bytes.
    #[error("{file}: empty file")]
    EmptyFile { file: String },

    /// The extension does not name a supported format.
    #[error("{file}: unknown file extension `{ext}`; expected .wav, .csv or .mat")]
    UnknownFormat { file: String, ext: String },

    /// The bytes are not a readable WAV file.
    #[error("{file}: truncated or corrupt WAV ({reason})")]
    CorruptWav { file: String, reason: String },

    /// A CSV line could not be read (`column` is 1-based, 0 when the whole line is at fault).
    #[error("{file} line {line}{}: {reason}", if *column > 0 { format!(", column {column}") } else { String::new() })]
    Csv { file: String, line: usize, column: usize, reason: String },

    /// The CSV file as a whole is unusable (no data rows, not UTF-8, ...).
    #[error("{file}: {reason}")]
    CsvFile { file: String, reason: String },

    /// The bytes are not a readable MATLAB v5 file.
    #[error("{file}: truncated, corrupt or unsupported MAT file ({reason})")]
    CorruptMat { file: String, reason: String },

    /// The requested channel or variable does not exist.
    #[error("{file}: no {kind} `{wanted}`; {kind}s: {}", available.join(", "))]
    NoChannel { file: String, kind: &'static str, wanted: String, available: Vec<String> },

    /// The requested channel or variable exists but cannot be read as a real signal.
    #[error("{file}: {kind} `{channel}` cannot be loaded: {reason}")]
    Unsupported { file: String, kind: &'static str, channel: String, reason: String },

    /// A channel given by suffix matches several variables.
    #[error("{file}: `{wanted}` matches several variables ({}); give the full name", matches.join(", "))]
    Ambiguous { file: String, wanted: String, matches: Vec<String> },

    /// The file holds nothing that can be loaded as a signal.
    #[error("{file}: nothing to load: {reason}")]
    NothingToLoad { file: String, reason: String },

    /// No sampling rate can be found in the file and none was given.
    #[error("{file} holds no sampling rate; pass fs_hz")]
    NoSamplingRate { file: String },

    /// A sample is NaN or infinite.
    #[error("{file}, channel `{channel}`: sample {index} is not finite ({value})")]
    NonFinite { file: String, channel: String, index: usize, value: f64 },

    /// The selected channel holds no samples.
    #[error("{file}, channel `{channel}`: no samples")]
    NoSamples { file: String, channel: String },

    /// A load option or a signal to save has an unusable value.
    #[error("{file}: {source}")]
    InvalidParameter { file: String, source: DspError },

    /// The JSON sidecar of a WAV file is malformed or disagrees with the WAV header.
    #[error("{file}: bad sidecar ({reason})")]
    Sidecar { file: String, reason: String },

    /// The signal cannot be written in the requested format.
    #[error("{file}: cannot save: {reason}")]
    Save { file: String, reason: String },
}

/// A supported file format, chosen from the extension (case-insensitive).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FileFormat {
    /// RIFF WAVE (`.wav`).
    Wav,
    /// Delimited text (`.csv`, `.txt`, `.tsv`).
    Csv,
    /// MATLAB level 5 MAT-file (`.mat`).
    Mat,
}

impl FileFormat {
    /// The format named by the extension of `path`.
    ///
    /// `.wav` → Wav; `.csv`, `.tsv`, `.txt` → Csv; `.mat` → Mat (all case-insensitive).
    /// Any other extension, or none, is an [`IoError::UnknownFormat`] naming it.
    pub fn from_path(path: &Path) -> Result<Self, IoError> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_string()).unwrap_or_default();
        match ext.to_ascii_lowercase().as_str() {
            "wav" => Ok(FileFormat::Wav),
            "csv" | "tsv" | "txt" => Ok(FileFormat::Csv),
            "mat" => Ok(FileFormat::Mat),
            _ => Err(IoError::UnknownFormat { file: label(path), ext: if ext.is_empty() { "(none)".into() } else { ext } }),
        }
    }
}

/// How to read a file.
///
/// Embeddable in a TOML processing chain (`serde(default, deny_unknown_fields)`).
///
/// Defaults (all `None`): first/obvious channel, sampling rate from the file, unit from the file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoadOptions {
    /// Channel to read. WAV: 0-based channel index (`"0"`, `"1"`, ...; default `"0"`).
    /// CSV: header name or 0-based column index (default: the last non-time column).
    /// MAT: variable name or suffix (`"X105_DE_time"`, `"_DE_time"`, `"DE"`; default: the
    /// first variable ending in `_DE_time`, else the first numeric vector). Default `None`.
    pub channel: Option<String>,
    /// Sampling rate in Hz; overrides whatever the file says. Default `None`.
    pub fs_hz: Option<f64>,
    /// Physical unit of the samples; overrides whatever the file says. Default `None`.
    pub unit: Option<String>,
}

impl LoadOptions {
    /// Checks the options: `fs_hz` positive and finite, `channel` not blank.
    pub fn validate(&self) -> Result<(), DspError> {
        if let Some(fs) = self.fs_hz {
            check_fs(fs)?;
        }
        if let Some(ch) = &self.channel {
            if ch.trim().is_empty() {
                return Err(DspError::InvalidParameter {
                    name: "channel",
                    value: format!("{ch:?}"),
                    reason: "the channel must be a name or a 0-based index; omit it for the default".into(),
                });
            }
        }
        Ok(())
    }
}

/// One channel or variable of a file, as listed by [`inspect`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelInfo {
    /// Name to pass as `LoadOptions::channel`.
    pub name: String,
    /// Sampling rate in Hz, when the file states it.
    pub fs_hz: Option<f64>,
    /// Number of samples.
    pub len: usize,
    /// Duration in seconds (`len / fs_hz`), when the rate is known.
    pub duration_s: Option<f64>,
    /// Physical unit, when known.
    pub unit: Option<String>,
}

impl ChannelInfo {
    pub(crate) fn new(name: impl Into<String>, fs_hz: Option<f64>, len: usize, unit: Option<String>) -> Self {
        Self { name: name.into(), fs_hz, len, duration_s: fs_hz.map(|fs| len as f64 / fs), unit }
    }
}

/// What a file holds, as listed by [`inspect`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FileInfo {
    /// The file.
    pub path: PathBuf,
    /// Its format.
    pub format: FileFormat,
    /// Readable channels or variables, in file order.
    pub channels: Vec<ChannelInfo>,
    /// Shaft speed in Hz, when the file states it (e.g. CWRU `XNNNRPM` / 60).
    pub shaft_speed_hz: Option<f64>,
    /// Human-readable remarks (sample format, default channel, unreadable variables, ...).
    pub notes: Vec<String>,
}

/// How a path is shown in messages and `meta.source`.
pub(crate) fn label(path: &Path) -> String {
    path.display().to_string()
}

/// The file stem of a label, for default signal names.
pub(crate) fn stem_of(file: &str) -> String {
    Path::new(file).file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_else(|| file.to_string())
}

/// Rejects non-finite samples, naming the first one.
pub(crate) fn check_samples(file: &str, channel: &str, x: &[f64]) -> Result<(), IoError> {
    if x.is_empty() {
        return Err(IoError::NoSamples { file: file.into(), channel: channel.into() });
    }
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(IoError::NonFinite { file: file.into(), channel: channel.into(), index, value: x[index] }),
        None => Ok(()),
    }
}

pub(crate) fn validate_opts(file: &str, opts: &LoadOptions) -> Result<(), IoError> {
    opts.validate().map_err(|source| IoError::InvalidParameter { file: file.into(), source })
}

fn read_file(path: &Path) -> Result<Vec<u8>, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Os { file: label(path), action: "read", source })?;
    if bytes.is_empty() {
        return Err(IoError::EmptyFile { file: label(path) });
    }
    Ok(bytes)
}

/// Loads one channel of a WAV, CSV or MAT file into a [`Signal`].
///
/// Arguments:
/// - `path`: the file; its extension selects the format ([`FileFormat::from_path`]).
/// - `opts`: channel, sampling-rate and unit overrides ([`LoadOptions`], all optional).
///
/// Returns the signal with `samples` in the file's unit (WAV integers scaled to ±1.0 full
/// scale), `fs_hz` in Hz, `name` = channel/variable name (or file stem + channel),
/// `meta.source` = `path`, `meta.channel` = the channel or variable read, and whatever else
/// the file states (shaft speed, unit, sidecar metadata). All samples are finite.
///
/// Notes: a WAV file `x.wav` is read with its sidecar `x.wav.json` when present (written by
/// [`save`]). See the format modules for the details of each reader.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Signal, IoError> {
    let format = FileFormat::from_path(path)?;
    let file = label(path);
    validate_opts(&file, opts)?;
    let bytes = read_file(path)?;
    let mut signal = match format {
        FileFormat::Wav => {
            let side = sidecar::read_for(path)?;
            wav::read_with_sidecar(&bytes, &file, opts, side.as_ref())?
        }
        FileFormat::Csv => csv::read_bytes(&bytes, &file, opts)?,
        FileFormat::Mat => mat::read_bytes(&bytes, &file, opts)?,
    };
    signal.meta.source = Some(file);
    Ok(signal)
}

/// Lists the channels/variables of a file with their sampling rate (when known), length,
/// duration and unit, plus the shaft speed (for `twinscope info FILE`).
///
/// Reads the whole file; a file that [`load`] would reject as corrupt is rejected here too.
pub fn inspect(path: &Path) -> Result<FileInfo, IoError> {
    let format = FileFormat::from_path(path)?;
    let file = label(path);
    let bytes = read_file(path)?;
    let mut info = match format {
        FileFormat::Wav => {
            let side = sidecar::read_for(path)?;
            wav::inspect_with_sidecar(&bytes, &file, side.as_ref())?
        }
        FileFormat::Csv => csv::inspect_bytes(&bytes, &file)?,
        FileFormat::Mat => mat::inspect_bytes(&bytes, &file)?,
    };
    info.path = path.to_path_buf();
    Ok(info)
}

/// Writes a signal by extension: `.wav` (32-bit float samples as-is, no clipping, plus a JSON
/// sidecar `<file>.wav.json` holding name, unit, exact fs and all metadata) or `.csv`
/// (`# twinscope: {json}` comment line, header `time_s,<name>`, rows at full f64 precision).
///
/// Rejects empty signals, non-finite samples or fs, and `.mat` (no MAT writer).
pub fn save(signal: &Signal, path: &Path) -> Result<(), IoError> {
    let format = FileFormat::from_path(path)?;
    let file = label(path);
    check_fs(signal.fs_hz).map_err(|source| IoError::InvalidParameter { file: file.clone(), source })?;
    check_samples(&file, &signal.name, &signal.samples)?;
    let write = |bytes: &[u8], p: &Path| {
        std::fs::write(p, bytes).map_err(|source| IoError::Os { file: label(p), action: "write", source })
    };
    match format {
        FileFormat::Wav => {
            let bytes = wav::write_bytes(signal, &file)?;
            let json = sidecar::to_json(signal, &file)?;
            write(&bytes, path)?;
            write(json.as_bytes(), &sidecar::path_for(path))
        }
        FileFormat::Csv => {
            let text = csv::write_string(signal, &file)?;
            write(text.as_bytes(), path)
        }
        FileFormat::Mat => Err(IoError::Save { file, reason: "there is no MAT writer; save as .wav or .csv".into() }),
    }
}
