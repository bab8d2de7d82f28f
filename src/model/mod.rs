//! The physics model: a lumped-parameter gear–bearing simulator with switchable physical effects.
//!
//! A [`Machine`] (TOML, SI units) is assembled into a [`System`] of named degrees of freedom —
//! shafts (x, y, and θ when they carry a gear), bearing pedestals (x, y) with a sprung mass (y)
//! for the high-frequency structural response (Sawalhi & Randall 2008), casing modes — joined by
//! linear springs and nonlinear force elements (Hertzian ball contacts with spalls, the gear
//! mesh, order forces). A fixed-step RK4 integrator records the sensor acceleration; measurement
//! effects (sensor response, path modulation, noise) are applied to the output.
//!
//! New components (a Craig–Bampton-reduced casing, a planetary set) join through named DOFs:
//! they add DOFs, springs and [`ForceElement`]s to the [`System`].

mod assemble;
mod bearing;
mod cache;
mod effects;
mod error;
mod gear;
mod machine;
mod memo;
mod simulate;
mod system;

pub use assemble::{Model, PostProcessing, SensorMix, STANDARD_GRAVITY};
pub use cache::{clear_loop_cache, integration_key, loop_cache_stats, set_loop_cache_enabled, simulate_cached, SimulationCache};
pub use bearing::{BearingElement, BearingFault, ContactLaw, DepthProfile, ShaftMotion};
pub use effects::*;
pub use error::ModelError;
pub use gear::{GearMeshElement, MeshStiffness, OrderForce};
pub use memo::MemoId;
pub use machine::{AntiAliasFilter, Bearing, Coupling, DrivenBy, FaultLocation, GearPairSpec, LocalFault, Machine, Sensor, Shaft};
pub use simulate::{coloured_noise, finish, post_process, run, run_raw, sensor_lowpass, Simulator, StepResult};
pub use system::{ForceElement, Spring, System};

use crate::signal::Signal;

/// Simulates a machine: validate, assemble, integrate, post-process.
pub fn simulate(machine: &Machine) -> Result<Signal, ModelError> {
    let model = Model::build(machine)?;
    run(&model, |_| true)
}

/// The bundled machine presets (`assets/machines/*.toml`), compiled into the binary.
pub const PRESETS: [(&str, &str); 12] = [
    ("cwru_6205_inner", include_str!("../../assets/machines/cwru_6205_inner.toml")),
    ("cwru_6205_outer", include_str!("../../assets/machines/cwru_6205_outer.toml")),
    ("cwru_6205_ball", include_str!("../../assets/machines/cwru_6205_ball.toml")),
    ("cwru_6205_inner_021", include_str!("../../assets/machines/cwru_6205_inner_021.toml")),
    ("cwru_6205_outer_021", include_str!("../../assets/machines/cwru_6205_outer_021.toml")),
    ("cwru_6205_ball_021", include_str!("../../assets/machines/cwru_6205_ball_021.toml")),
    ("cwru_6205_healthy", include_str!("../../assets/machines/cwru_6205_healthy.toml")),
    ("mfs_outer", include_str!("../../assets/machines/mfs_outer.toml")),
    ("mfs_inner", include_str!("../../assets/machines/mfs_inner.toml")),
    ("mfs_ball", include_str!("../../assets/machines/mfs_ball.toml")),
    ("mfs_healthy", include_str!("../../assets/machines/mfs_healthy.toml")),
    ("unsw_extended_inner", include_str!("../../assets/machines/unsw_extended_inner.toml")),
];

/// Loads a bundled machine preset by name.
pub fn preset(name: &str) -> Result<Machine, ModelError> {
    let (_, text) = PRESETS.iter().find(|(n, _)| *n == name).ok_or_else(|| ModelError::Parse {
        source_name: format!("preset `{name}`"),
        message: format!("unknown machine preset; presets: {}", PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", ")),
    })?;
    Machine::from_toml(text, &format!("preset `{name}`"))
}
