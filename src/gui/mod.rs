//! The desktop workbench (feature `gui`): an eframe/egui app over the library.
//!
//! Nothing numeric lives here: the [`jobs`] call the library (`signal::io`, `chain`, `dsp`,
//! `kinematics`, `model`, `compare`) on worker threads ([`worker`]); the [`views`] draw the
//! results kept in the runtime [`session::Session`]; preferences persist in
//! [`settings::Settings`]. `twinscope` with no arguments opens it on the bundled demo.

pub mod app;
pub mod export;
pub mod jobs;
pub mod session;
pub mod session_file;
pub mod settings;
pub mod views;
pub mod worker;

pub use app::{run, StartOptions, Workbench};
