//! The machine description (TOML): shafts, bearings, faults, gear pairs, couplings, transfer
//! path, sensor, output and physical effects, all in SI units with the unit in the name.

use super::effects::{EffectKind, Effects};
use super::error::ModelError;
use crate::kinematics::{lookup_bearing, BearingGeometry};
use serde::{Deserialize, Serialize};

/// A machine to simulate. See `assets/machines/*.toml` for complete examples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Machine {
    /// Name used in messages and output metadata.
    pub name: String,
    /// Output sampling rate in Hz.
    pub fs_hz: f64,
    /// Recorded duration in s (after `settle_s`).
    pub duration_s: f64,
    /// Time simulated and discarded before recording, s (lets the start-up transient die out).
    #[serde(default = "default_settle_s")]
    pub settle_s: f64,
    /// Integrator sub-steps per output sample: the RK4 step is `1 / (fs_hz · substeps)`.
    #[serde(default = "default_substeps")]
    pub substeps: usize,
    /// Seed for every random quantity (slip, roughness, noise).
    #[serde(default)]
    pub seed: u64,
    /// Effects whose parameters a loop fitted to a measurement, as the machine a loop ends on
    /// records them (`diagnose --save-machine`, a batch job's final machine, the app's "Save
    /// machine…"): a calibration of this machine re-fits them too, as a loop re-fits what it
    /// applies (`compare::calibrate::calibration_parameters_for`). Each must be on in a file
    /// read. Empty for a preset.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fitted_effects: Vec<EffectKind>,
    /// Shafts with their speeds.
    #[serde(default, rename = "shaft")]
    pub shafts: Vec<Shaft>,
    /// Rolling-element bearings.
    #[serde(default, rename = "bearing")]
    pub bearings: Vec<Bearing>,
    /// Gear pairs.
    #[serde(default, rename = "gear_pair")]
    pub gear_pairs: Vec<GearPairSpec>,
    /// Linear spring–dampers between named DOFs (or a DOF and ground): the structure between
    /// components (e.g. a gearbox casing tied to the test-bearing pedestal).
    #[serde(default, rename = "coupling")]
    pub couplings: Vec<Coupling>,
    /// What is measured.
    pub sensor: Sensor,
    /// Physical effects: each present table switches one on.
    #[serde(default)]
    pub effects: Effects,
}

fn default_settle_s() -> f64 {
    0.1
}
fn default_substeps() -> usize {
    8
}

/// A shaft. Its rotation is prescribed (speed, optionally fluctuating); its radial motion (x, y)
/// and, when it carries a gear, torsional vibration are DOFs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shaft {
    /// Name, used by bearings and gears (`shaft = "..."`) and as the DOF prefix
    /// (`<name>.x`, `<name>.y`, `<name>.theta`).
    pub name: String,
    /// Mean speed in Hz. Give it for the driving shaft; a driven shaft may give `driven_by`.
    #[serde(default)]
    pub speed_hz: Option<f64>,
    /// Speed from another shaft through a ratio (belt or gear): `speed = ratio · speed(shaft)`.
    #[serde(default)]
    pub driven_by: Option<DrivenBy>,
    /// Mass lumped at the shaft's bearings (shaft + inner races), kg.
    pub mass_kg: f64,
    /// Damping of the shaft's radial motion to ground (windage, seals), N·s/m. Default 0.
    #[serde(default)]
    pub damping_n_s_per_m: f64,
    /// Polar moment of inertia for torsional vibration (needed when the shaft carries a gear),
    /// kg·m².
    #[serde(default)]
    pub inertia_kg_m2: Option<f64>,
    /// Torsional stiffness to the (prescribed) drive, N·m/rad (needed with `inertia_kg_m2`).
    #[serde(default)]
    pub torsional_stiffness_n_m_per_rad: Option<f64>,
    /// Torsional damping to the drive, N·m·s/rad.
    #[serde(default)]
    pub torsional_damping_n_m_s_per_rad: f64,
    /// Pulley diameter, m (for belt drives and the `belt_drive` effect).
    #[serde(default)]
    pub pulley_diameter_m: Option<f64>,
}

/// How a shaft is driven by another.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrivenBy {
    /// The driving shaft.
    pub shaft: String,
    /// Speed ratio `speed / speed(driver)` (belt: d_driver / d_driven; gears: z_driver / z_driven).
    pub ratio: f64,
}

/// A rolling-element bearing between a shaft and its pedestal, after Sawalhi & Randall (2008):
/// the shaft (x, y), the pedestal (x, y) and a sprung mass (y) carrying the high-frequency
/// structural resonance the sensor sees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bearing {
    /// Name, the DOF prefix (`<name>.pedestal.x`, `<name>.pedestal.y`, `<name>.resonator.y`).
    pub name: String,
    /// The shaft it carries.
    pub shaft: String,
    /// A catalogue bearing (see `twinscope kinematics`), or give `geometry`.
    #[serde(default)]
    pub catalogue: Option<String>,
    /// Explicit geometry.
    #[serde(default)]
    pub geometry: Option<BearingGeometry>,
    /// Radial clearance, m (diametral clearance / 2). Default 5 µm.
    #[serde(default = "default_clearance")]
    pub radial_clearance_m: f64,
    /// Hertzian load–deflection constant `K` in `Q = K δⁿ`, N/mⁿ (ball–race pair, both
    /// contacts in series). Default 8.0e9 (a 6205-size ball bearing, Harris & Kotzalas 2006).
    #[serde(default = "default_hertz")]
    pub hertz_constant_n_per_m_n: f64,
    /// Load–deflection exponent `n`: 1.5 for balls (point contact), 10/9 for rollers.
    #[serde(default = "default_exponent")]
    pub load_exponent: f64,
    /// Pedestal (outer race + housing) mass, kg.
    pub pedestal_mass_kg: f64,
    /// Pedestal support stiffness to ground, N/m.
    pub pedestal_stiffness_n_per_m: f64,
    /// Pedestal support damping to ground, N·s/m.
    pub pedestal_damping_n_s_per_m: f64,
    /// Natural frequency of the sprung mass (the structural resonance excited by impacts), Hz.
    pub resonator_frequency_hz: f64,
    /// Damping ratio of the sprung-mass resonance.
    pub resonator_damping_ratio: f64,
    /// Sprung mass, kg. Default 0.05.
    #[serde(default = "default_resonator_mass")]
    pub resonator_mass_kg: f64,
    /// Per-ball preload used when the `load_zone` effect is off (uniform load on every ball,
    /// no clearance), N. Default 20.
    #[serde(default = "default_uniform_preload")]
    pub uniform_preload_n: f64,
    /// A localised fault, if any.
    #[serde(default)]
    pub fault: Option<LocalFault>,
}

fn default_clearance() -> f64 {
    5e-6
}
fn default_hertz() -> f64 {
    8.0e9
}
fn default_exponent() -> f64 {
    1.5
}
fn default_resonator_mass() -> f64 {
    0.05
}
fn default_uniform_preload() -> f64 {
    20.0
}

/// Where a localised fault is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FaultLocation {
    /// Outer race (fixed).
    Outer,
    /// Inner race (rotates with the shaft).
    Inner,
    /// One rolling element (strikes both races: 2 × BSF).
    Ball,
}

/// A localised spall: while a ball is over it, the contact deflection loses the depth the ball
/// drops into the spall (limited by the ball's curvature, Sawalhi & Randall 2008).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LocalFault {
    /// Outer race, inner race or ball.
    pub location: FaultLocation,
    /// Spall length along the rolling direction, m.
    pub length_m: f64,
    /// Spall depth, m.
    pub depth_m: f64,
    /// Angular position, degrees: for the outer race from the load direction (0° = bottom, the
    /// centre of the load zone: CWRU "6 o'clock"); for the inner race at t = 0; for a ball its
    /// spin angle at t = 0.
    #[serde(default)]
    pub position_deg: f64,
}

/// A gear pair whose mesh couples two shafts (see the `gear_mesh` and `tooth_fault` effects).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearPairSpec {
    /// Name (DOF prefix is not needed: the mesh acts on the shafts' DOFs).
    pub name: String,
    /// Driving shaft (carries the pinion).
    pub pinion_shaft: String,
    /// Driven shaft.
    pub gear_shaft: String,
    /// Pinion teeth.
    pub pinion_teeth: u32,
    /// Gear teeth.
    pub gear_teeth: u32,
    /// Module, m.
    pub module_m: f64,
    /// Pressure angle, degrees. Default 20.
    #[serde(default = "default_pressure_angle")]
    pub pressure_angle_deg: f64,
    /// Face width, m.
    pub face_width_m: f64,
    /// Mean mesh stiffness, N/m.
    pub mean_mesh_stiffness_n_per_m: f64,
    /// Mesh damping, N·s/m.
    pub mesh_damping_n_s_per_m: f64,
    /// Static transmitted load along the line of action, N (preloads the mesh).
    pub transmitted_load_n: f64,
}

fn default_pressure_angle() -> f64 {
    20.0
}

/// A linear spring–damper between two DOFs, or a DOF and ground (`b` omitted).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Coupling {
    /// First DOF, e.g. `pinion.y`.
    pub a: String,
    /// Second DOF; ground when omitted.
    #[serde(default)]
    pub b: Option<String>,
    /// Stiffness, N/m.
    pub stiffness_n_per_m: f64,
    /// Damping, N·s/m.
    #[serde(default)]
    pub damping_n_s_per_m: f64,
}

/// What the simulated accelerometer measures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    /// The DOF whose acceleration is measured, e.g. `test.resonator.y`.
    pub dof: String,
    /// Output unit: `m/s^2` or `g`. Default `m/s^2`.
    #[serde(default = "default_unit")]
    pub unit: String,
    /// Overall gain applied to the output (calibration). Default 1.
    #[serde(default = "one")]
    pub gain: f64,
    /// The recorder's anti-alias (decimation) filter, applied last, to signal and noise alike.
    /// Default: none (the decimation from the integration rate is already an ideal low-pass).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub antialias: Option<AntiAliasFilter>,
}

/// A data recorder's anti-alias filter as its magnitude response: flat to `passband_hz`,
/// falling to `-stopband_db` at `stopband_hz` (see [`crate::dsp::lowpass::lowpass_gain`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AntiAliasFilter {
    /// Passband edge, Hz.
    pub passband_hz: f64,
    /// Stopband edge, Hz (above the passband edge).
    pub stopband_hz: f64,
    /// Attenuation at and above the stopband edge, dB (positive).
    pub stopband_db: f64,
}

fn default_unit() -> String {
    "m/s^2".into()
}
fn one() -> f64 {
    1.0
}

impl Machine {
    /// Parses a machine from TOML text; `source_name` names it in errors.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Machine, ModelError> {
        let m: Machine = toml::from_str(text).map_err(|e| ModelError::Parse { source_name: source_name.to_string(), message: e.to_string().trim().replace('\n', " ") })?;
        m.validate()?;
        // Checked on reading only: a loop may switch off an effect a machine lists, which the
        // calibration then leaves out.
        if let Some(k) = m.fitted_effects.iter().find(|k| !m.effects.is_on(**k)) {
            return Err(m.invalid("fitted_effects", k.name(), "names an effect this machine does not have on: switch it on, or take it out of the list"));
        }
        Ok(m)
    }

    /// Serialises to TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    pub(crate) fn invalid(&self, field: impl Into<String>, value: impl std::fmt::Display, reason: impl Into<String>) -> ModelError {
        ModelError::InvalidField { machine: self.name.clone(), field: field.into(), value: value.to_string(), reason: reason.into() }
    }

    pub(crate) fn unknown(&self, field: impl Into<String>, reason: impl Into<String>) -> ModelError {
        ModelError::UnknownReference { machine: self.name.clone(), field: field.into(), reason: reason.into() }
    }

    /// The geometry of bearing `i` (catalogue or explicit).
    pub fn bearing_geometry(&self, i: usize) -> Result<BearingGeometry, ModelError> {
        let b = &self.bearings[i];
        let field = format!("bearing[{}].catalogue", b.name);
        match (&b.catalogue, &b.geometry) {
            (Some(_), Some(_)) => Err(self.invalid(field, "both", "give either `catalogue` or `geometry`, not both")),
            (None, None) => Err(self.invalid(field, "none", "give `catalogue` (e.g. \"SKF 6205-2RS JEM\") or `geometry`")),
            (Some(name), None) => lookup_bearing(name).map_err(|e| self.invalid(field, name, e.to_string())),
            (None, Some(g)) => {
                g.validate().map_err(|e| self.invalid(format!("bearing[{}].geometry", b.name), &g.name, e.to_string()))?;
                Ok(g.clone())
            }
        }
    }

    /// Index of a shaft by name.
    pub fn shaft_index(&self, name: &str) -> Option<usize> {
        self.shafts.iter().position(|s| s.name == name)
    }

    /// The structural resonances the model's impacts ring, Hz: every bearing's sprung-mass
    /// resonator, then the casing modes when that effect is on.
    pub fn structural_resonances_hz(&self) -> Vec<f64> {
        let casing = self.effects.casing_modes.iter().flat_map(|c| c.modes.iter().map(|m| m.frequency_hz));
        self.bearings.iter().map(|b| b.resonator_frequency_hz).chain(casing).collect()
    }

    /// Mean speed of every shaft in Hz, resolving `driven_by` chains.
    pub fn shaft_speeds_hz(&self) -> Result<Vec<f64>, ModelError> {
        let mut speeds = vec![None; self.shafts.len()];
        for _ in 0..=self.shafts.len() {
            for (i, s) in self.shafts.iter().enumerate() {
                if speeds[i].is_some() {
                    continue;
                }
                match (&s.speed_hz, &s.driven_by) {
                    (Some(v), None) => speeds[i] = Some(*v),
                    (None, Some(d)) => {
                        let j = self.shaft_index(&d.shaft).ok_or_else(|| self.unknown(format!("shaft[{}].driven_by.shaft", s.name), format!("no shaft named `{}`", d.shaft)))?;
                        if let Some(v) = speeds[j] {
                            speeds[i] = Some(v * d.ratio);
                        }
                    }
                    (Some(_), Some(_)) => return Err(self.invalid(format!("shaft[{}].speed_hz", s.name), "both", "give `speed_hz` or `driven_by`, not both")),
                    (None, None) => return Err(self.invalid(format!("shaft[{}].speed_hz", s.name), "none", "give `speed_hz` or `driven_by`")),
                }
            }
        }
        speeds
            .into_iter()
            .enumerate()
            .map(|(i, v)| v.ok_or_else(|| self.invalid(format!("shaft[{}].driven_by", self.shafts[i].name), "cycle", "the `driven_by` chain never reaches a shaft with `speed_hz`")))
            .collect()
    }

    /// Checks every field; errors name the offending field.
    pub fn validate(&self) -> Result<(), ModelError> {
        let pos = |field: String, v: f64| -> Result<(), ModelError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(self.invalid(field, v, "must be a positive, finite number"))
            }
        };
        let nonneg = |field: String, v: f64| -> Result<(), ModelError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(self.invalid(field, v, "must be a finite number ≥ 0"))
            }
        };
        pos("fs_hz".into(), self.fs_hz)?;
        pos("duration_s".into(), self.duration_s)?;
        nonneg("settle_s".into(), self.settle_s)?;
        if self.substeps == 0 || self.substeps > 256 {
            return Err(self.invalid("substeps", self.substeps, "must be in 1..=256"));
        }
        let samples = self.fs_hz * self.duration_s;
        if !(16.0..=1e8).contains(&samples) {
            return Err(self.invalid("duration_s", self.duration_s, format!("gives {samples:.0} samples at fs_hz = {}; need 16 to 1e8", self.fs_hz)));
        }
        if self.shafts.is_empty() {
            return Err(self.invalid("shaft", "[]", "a machine needs at least one shaft"));
        }
        let mut names: Vec<&str> = Vec::new();
        for s in &self.shafts {
            if names.contains(&s.name.as_str()) {
                return Err(self.invalid(format!("shaft[{}].name", s.name), &s.name, "used twice"));
            }
            names.push(&s.name);
            pos(format!("shaft[{}].mass_kg", s.name), s.mass_kg)?;
            nonneg(format!("shaft[{}].damping_n_s_per_m", s.name), s.damping_n_s_per_m)?;
            if let Some(v) = s.speed_hz {
                pos(format!("shaft[{}].speed_hz", s.name), v)?;
            }
            if let Some(d) = &s.driven_by {
                pos(format!("shaft[{}].driven_by.ratio", s.name), d.ratio)?;
            }
            match (s.inertia_kg_m2, s.torsional_stiffness_n_m_per_rad) {
                (Some(j), Some(k)) => {
                    pos(format!("shaft[{}].inertia_kg_m2", s.name), j)?;
                    pos(format!("shaft[{}].torsional_stiffness_n_m_per_rad", s.name), k)?;
                }
                (None, None) => {}
                _ => return Err(self.invalid(format!("shaft[{}].inertia_kg_m2", s.name), "one of two", "give both `inertia_kg_m2` and `torsional_stiffness_n_m_per_rad`, or neither")),
            }
            nonneg(format!("shaft[{}].torsional_damping_n_m_s_per_rad", s.name), s.torsional_damping_n_m_s_per_rad)?;
            if let Some(d) = s.pulley_diameter_m {
                pos(format!("shaft[{}].pulley_diameter_m", s.name), d)?;
            }
        }
        let speeds = self.shaft_speeds_hz()?;
        for (i, b) in self.bearings.iter().enumerate() {
            if names.contains(&b.name.as_str()) {
                return Err(self.invalid(format!("bearing[{}].name", b.name), &b.name, "name already used by another shaft or bearing"));
            }
            names.push(&b.name);
            let si = self.shaft_index(&b.shaft).ok_or_else(|| self.unknown(format!("bearing[{}].shaft", b.name), format!("no shaft named `{}`", b.shaft)))?;
            let g = self.bearing_geometry(i)?;
            if !b.radial_clearance_m.is_finite() || b.radial_clearance_m.abs() > 1e-3 {
                return Err(self.invalid(format!("bearing[{}].radial_clearance_m", b.name), b.radial_clearance_m, "must be finite and within ±1 mm (negative = interference)"));
            }
            pos(format!("bearing[{}].hertz_constant_n_per_m_n", b.name), b.hertz_constant_n_per_m_n)?;
            if !(1.0..=2.0).contains(&b.load_exponent) {
                return Err(self.invalid(format!("bearing[{}].load_exponent", b.name), b.load_exponent, "must be in [1, 2] (1.5 balls, 10/9 rollers)"));
            }
            pos(format!("bearing[{}].pedestal_mass_kg", b.name), b.pedestal_mass_kg)?;
            pos(format!("bearing[{}].pedestal_stiffness_n_per_m", b.name), b.pedestal_stiffness_n_per_m)?;
            nonneg(format!("bearing[{}].pedestal_damping_n_s_per_m", b.name), b.pedestal_damping_n_s_per_m)?;
            pos(format!("bearing[{}].resonator_frequency_hz", b.name), b.resonator_frequency_hz)?;
            pos(format!("bearing[{}].resonator_mass_kg", b.name), b.resonator_mass_kg)?;
            nonneg(format!("bearing[{}].resonator_damping_ratio", b.name), b.resonator_damping_ratio)?;
            if b.resonator_frequency_hz >= self.fs_hz / 2.0 {
                return Err(self.invalid(
                    format!("bearing[{}].resonator_frequency_hz", b.name),
                    b.resonator_frequency_hz,
                    format!("is above the output Nyquist frequency ({} Hz): raise fs_hz to at least twice the highest mode", self.fs_hz / 2.0),
                ));
            }
            pos(format!("bearing[{}].uniform_preload_n", b.name), b.uniform_preload_n)?;
            if let Some(f) = &b.fault {
                let field = |s: &str| format!("bearing[{}].fault.{s}", b.name);
                pos(field("length_m"), f.length_m)?;
                pos(field("depth_m"), f.depth_m)?;
                if !f.position_deg.is_finite() {
                    return Err(self.invalid(field("position_deg"), f.position_deg, "must be finite"));
                }
                let d = g.ball_diameter_mm * 1e-3;
                let spacing = std::f64::consts::PI * g.pitch_diameter_mm * 1e-3 / g.rolling_elements as f64;
                let limit = match f.location {
                    FaultLocation::Ball => std::f64::consts::PI * d / 2.0,
                    _ => spacing,
                };
                if f.length_m >= limit {
                    return Err(self.invalid(
                        field("length_m"),
                        f.length_m,
                        format!(
                            "a localised spall must be shorter than {} ({:.2} mm); use the `extended_fault` effect for longer faults",
                            if f.location == FaultLocation::Ball { "half the ball circumference" } else { "the rolling-element spacing" },
                            limit * 1e3
                        ),
                    ));
                }
                if f.depth_m > d / 2.0 {
                    return Err(self.invalid(field("depth_m"), f.depth_m, format!("deeper than the ball radius ({:.3} mm)", d * 500.0)));
                }
            }
            let _ = speeds[si];
        }
        for (k, c) in self.couplings.iter().enumerate() {
            nonneg(format!("coupling[{k}].stiffness_n_per_m"), c.stiffness_n_per_m)?;
            nonneg(format!("coupling[{k}].damping_n_s_per_m"), c.damping_n_s_per_m)?;
        }
        for g in &self.gear_pairs {
            let field = |s: &str| format!("gear_pair[{}].{s}", g.name);
            let ps = self.shaft_index(&g.pinion_shaft).ok_or_else(|| self.unknown(field("pinion_shaft"), format!("no shaft named `{}`", g.pinion_shaft)))?;
            let gs = self.shaft_index(&g.gear_shaft).ok_or_else(|| self.unknown(field("gear_shaft"), format!("no shaft named `{}`", g.gear_shaft)))?;
            if ps == gs {
                return Err(self.invalid(field("gear_shaft"), &g.gear_shaft, "a gear pair needs two different shafts"));
            }
            for s in [ps, gs] {
                if self.shafts[s].inertia_kg_m2.is_none() {
                    return Err(self.invalid(format!("shaft[{}].inertia_kg_m2", self.shafts[s].name), "none", format!("shaft carries gear pair `{}`: give its inertia and torsional stiffness", g.name)));
                }
            }
            if g.pinion_teeth < 5 || g.gear_teeth < 5 {
                return Err(self.invalid(field("pinion_teeth"), format!("{}/{}", g.pinion_teeth, g.gear_teeth), "a gear needs at least 5 teeth"));
            }
            // The gear shaft's speed must agree with the tooth ratio.
            let want = speeds[ps] * g.pinion_teeth as f64 / g.gear_teeth as f64;
            if (speeds[gs] - want).abs() > 1e-6 * want {
                return Err(self.invalid(
                    format!("shaft[{}].speed_hz", self.shafts[gs].name),
                    speeds[gs],
                    format!("gear pair `{}` ({}:{}) makes it {want:.6} Hz", g.name, g.pinion_teeth, g.gear_teeth),
                ));
            }
            pos(field("module_m"), g.module_m)?;
            pos(field("face_width_m"), g.face_width_m)?;
            pos(field("mean_mesh_stiffness_n_per_m"), g.mean_mesh_stiffness_n_per_m)?;
            nonneg(field("mesh_damping_n_s_per_m"), g.mesh_damping_n_s_per_m)?;
            nonneg(field("transmitted_load_n"), g.transmitted_load_n)?;
            if !(g.pressure_angle_deg > 0.0 && g.pressure_angle_deg < 45.0) {
                return Err(self.invalid(field("pressure_angle_deg"), g.pressure_angle_deg, "must be in (0, 45) degrees"));
            }
        }
        if !(self.sensor.gain.is_finite() && self.sensor.gain != 0.0) {
            return Err(self.invalid("sensor.gain", self.sensor.gain, "must be finite and non-zero"));
        }
        if !matches!(self.sensor.unit.as_str(), "m/s^2" | "g") {
            return Err(self.invalid("sensor.unit", &self.sensor.unit, "use \"m/s^2\" or \"g\""));
        }
        if let Some(a) = &self.sensor.antialias {
            if !(a.passband_hz.is_finite() && a.passband_hz > 0.0 && a.passband_hz < self.fs_hz / 2.0) {
                return Err(self.invalid("sensor.antialias.passband_hz", a.passband_hz, format!("must be in (0, {}) Hz (Nyquist at fs_hz = {})", self.fs_hz / 2.0, self.fs_hz)));
            }
            if !(a.stopband_hz.is_finite() && a.stopband_hz > a.passband_hz) {
                return Err(self.invalid("sensor.antialias.stopband_hz", a.stopband_hz, format!("must exceed passband_hz = {}", a.passband_hz)));
            }
            if !(a.stopband_db.is_finite() && a.stopband_db > 0.0) {
                return Err(self.invalid("sensor.antialias.stopband_db", a.stopband_db, "must be a positive attenuation in dB"));
            }
        }
        self.effects.validate(self)?;
        Ok(())
    }
}
