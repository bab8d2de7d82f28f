//! Signals and their files.
//!
//! A [`Signal`] is a uniformly sampled real record with its sampling rate, name, physical unit
//! and the machine metadata known for it. [`io`] reads and writes it.

pub mod display;
pub mod export;
pub mod io;
pub mod synth;

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Machine and acquisition metadata attached to a signal.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    /// Shaft speed in Hz (revolutions per second), when known (e.g. CWRU `XNNNRPM` / 60).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shaft_speed_hz: Option<f64>,
    /// File the signal was read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Channel or variable within the source file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel: Option<String>,
    /// Catalogue name of the bearing the sensor watches, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bearing: Option<String>,
    /// Free key/value pairs carried through writers and readers.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub extra: BTreeMap<String, String>,
}

/// A uniformly sampled real signal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Signal {
    /// Sample values in `unit`.
    pub samples: Vec<f64>,
    /// Sampling rate in Hz.
    pub fs_hz: f64,
    /// Human-readable name (e.g. `X105_DE_time`).
    pub name: String,
    /// Physical unit of the samples (e.g. `g`, `m/s^2`, `V`); empty if unknown.
    pub unit: String,
    /// Machine and acquisition metadata.
    pub meta: Metadata,
}

impl Signal {
    /// A signal with no metadata.
    pub fn new(samples: Vec<f64>, fs_hz: f64, name: impl Into<String>, unit: impl Into<String>) -> Self {
        Self { samples, fs_hz, name: name.into(), unit: unit.into(), meta: Metadata::default() }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True when the signal holds no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Duration in seconds (`len / fs`).
    pub fn duration_s(&self) -> f64 {
        self.samples.len() as f64 / self.fs_hz
    }

    /// Time of sample `i` in seconds.
    pub fn time_s(&self, i: usize) -> f64 {
        i as f64 / self.fs_hz
    }

    /// The same metadata with new samples (e.g. the output of a time-domain stage).
    pub fn with_samples(&self, samples: Vec<f64>, name: impl Into<String>) -> Self {
        Self { samples, fs_hz: self.fs_hz, name: name.into(), unit: self.unit.clone(), meta: self.meta.clone() }
    }
}
