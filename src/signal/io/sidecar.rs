//! JSON metadata carried beside a WAV file (`x.wav.json`) or inside a CSV comment line
//! (`# twinscope: {...}`).
//!
//! WAV headers hold only an integer sampling rate and no names or units, so [`super::save`]
//! writes everything else here and [`super::load`] reads it back.

use super::IoError;
use crate::signal::{Metadata, Signal};
use serde::{Deserialize, Serialize};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The metadata record. Every field is optional so a hand-written `{"unit": "g"}` works.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Sidecar {
    /// Signal name.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Physical unit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// Exact sampling rate in Hz (the WAV header rounds it to an integer).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fs_hz: Option<f64>,
    /// Machine and acquisition metadata.
    pub meta: Metadata,
}

impl Sidecar {
    /// The record of a signal.
    pub fn of(signal: &Signal) -> Self {
        Self { name: Some(signal.name.clone()), unit: Some(signal.unit.clone()), fs_hz: Some(signal.fs_hz), meta: signal.meta.clone() }
    }

    /// Parses a JSON record; `file` names the file in errors.
    pub fn parse(json: &str, file: &str) -> Result<Self, IoError> {
        let s: Sidecar = serde_json::from_str(json).map_err(|e| IoError::Sidecar { file: file.into(), reason: e.to_string() })?;
        if let Some(fs) = s.fs_hz {
            if !(fs.is_finite() && fs > 0.0) {
                return Err(IoError::Sidecar { file: file.into(), reason: format!("fs_hz = {fs} is not a positive, finite rate") });
            }
        }
        Ok(s)
    }
}

/// Serialises the record of `signal` as one-line JSON.
pub fn to_json(signal: &Signal, file: &str) -> Result<String, IoError> {
    serde_json::to_string(&Sidecar::of(signal)).map_err(|e| IoError::Save { file: file.into(), reason: format!("metadata not serialisable: {e}") })
}

/// `x.wav` → `x.wav.json`.
pub fn path_for(path: &Path) -> PathBuf {
    let mut s: OsString = path.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

/// Reads the sidecar of `path` if it exists.
pub fn read_for(path: &Path) -> Result<Option<Sidecar>, IoError> {
    let side = path_for(path);
    if !side.is_file() {
        return Ok(None);
    }
    let file = super::label(&side);
    let text = std::fs::read_to_string(&side).map_err(|source| IoError::Os { file: file.clone(), action: "read", source })?;
    Sidecar::parse(&text, &file).map(Some)
}
