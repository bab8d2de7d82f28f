//! Errors of the physics model.

use thiserror::Error;

/// What went wrong building or running a model. Every variant names the field or DOF.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ModelError {
    /// A machine-description field has an impossible or inconsistent value.
    #[error("machine `{machine}`: field `{field}` = {value}: {reason}")]
    InvalidField { machine: String, field: String, value: String, reason: String },
    /// A name refers to something the machine does not define.
    #[error("machine `{machine}`: field `{field}`: {reason}")]
    UnknownReference { machine: String, field: String, reason: String },
    /// The machine description could not be parsed.
    #[error("machine description {source_name}: {message}")]
    Parse { source_name: String, message: String },
    /// The integration diverged (NaN/inf or runaway displacement); nothing is written.
    #[error("simulation diverged at t = {t_s:.6} s in DOF `{dof}` ({what}); reduce the time step (raise `substeps`) or check stiffness and damping")]
    Diverged { t_s: f64, dof: String, what: String },
    /// The static equilibrium could not be found.
    #[error("static equilibrium not found: {0}")]
    NoEquilibrium(String),
    /// The recorder's anti-alias filter could not be applied to the simulated record.
    #[error("recorder anti-alias filter (`sensor.antialias`): {0}")]
    AntiAlias(String),
    /// The run was cancelled by the caller.
    #[error("simulation cancelled at t = {t_s:.3} s")]
    Cancelled { t_s: f64 },
}
