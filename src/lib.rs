//! twinscope — a workbench for vibration diagnostics of gearboxes and rolling-element bearings.
//!
//! The library is layered the way the analysis is done:
//! - [`signal`]: the [`signal::Signal`] type and file input/output (WAV, CSV, MATLAB v5);
//! - [`dsp`]: one pure function per algorithm (Welch PSD, Hilbert envelope, equiripple FIR,
//!   STSA, DRS, cyclic spectral correlation, ...), each checked against a reference;
//! - [`kinematics`]: bearing fault frequencies and gear mesh frequencies, with a catalogue;
//! - [`chain`]: serialisable processing chains that run DSP stages in order;
//! - [`batch`]: headless jobs (`twinscope --batch JOB.toml`);
//! - `gui` (feature `gui`, on by default): the desktop workbench, which only draws what the
//!   modules above compute.

pub mod batch;
pub mod chain;
pub mod compare;
pub mod dsp;
#[cfg(feature = "gui")]
pub mod gui;
pub mod kinematics;
pub mod model;
pub mod signal;
