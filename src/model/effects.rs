//! The catalogue of physical effects. Each effect is a switch: present (with its physical
//! parameters) means the model has that physics; absent means it lacks it. The model-vs-
//! measurement loop switches them on one at a time to find what a measurement needs.

use super::error::ModelError;
use super::machine::Machine;
use serde::{Deserialize, Serialize};

/// Names of the effects, in catalogue order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    LoadZone,
    Slip,
    CasingModes,
    GearMesh,
    ToothFault,
    SpeedFluctuation,
    SensorResponse,
    Unbalance,
    Misalignment,
    ExtendedFault,
    PathModulation,
    BeltDrive,
    NonlinearContact,
    Noise,
}

impl EffectKind {

    /// Whether the effect's signature is drawn at random when the model is built (the slip
    /// table's ball jitter, an extended fault's roughness), so that one realisation of the
    /// model shows one draw of it, not its expected spectrum.
    pub fn draws_at_random(self) -> bool {
        matches!(self, EffectKind::Slip | EffectKind::ExtendedFault)
    }
    /// The effect this one acts through, which a trial of it on a model without that effect
    /// switches on with it ([`crate::compare::diagnose::companion`]): the Hertzian contact law
    /// (`nonlinear_contact`) differs from its linearisation only under a load that moves the
    /// balls away from the preload it is linearised at, and without a load zone every ball
    /// carries that uniform preload, so the two laws give nearly the same model (session 62:
    /// such a trial explained 6e-6 of the error where both were hidden, and a casing mode stood
    /// in).
    pub fn acts_through(self) -> Option<EffectKind> {
        match self {
            EffectKind::NonlinearContact => Some(EffectKind::LoadZone),
            _ => None,
        }
    }

    /// Every effect, in catalogue order.
    pub const ALL: [EffectKind; 14] = [
        EffectKind::LoadZone,
        EffectKind::Slip,
        EffectKind::CasingModes,
        EffectKind::GearMesh,
        EffectKind::ToothFault,
        EffectKind::SpeedFluctuation,
        EffectKind::SensorResponse,
        EffectKind::Unbalance,
        EffectKind::Misalignment,
        EffectKind::ExtendedFault,
        EffectKind::PathModulation,
        EffectKind::BeltDrive,
        EffectKind::NonlinearContact,
        EffectKind::Noise,
    ];

    /// The TOML name (`load_zone`, ...).
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::LoadZone => "load_zone",
            EffectKind::Slip => "slip",
            EffectKind::CasingModes => "casing_modes",
            EffectKind::GearMesh => "gear_mesh",
            EffectKind::ToothFault => "tooth_fault",
            EffectKind::SpeedFluctuation => "speed_fluctuation",
            EffectKind::SensorResponse => "sensor_response",
            EffectKind::Unbalance => "unbalance",
            EffectKind::Misalignment => "misalignment",
            EffectKind::ExtendedFault => "extended_fault",
            EffectKind::PathModulation => "path_modulation",
            EffectKind::BeltDrive => "belt_drive",
            EffectKind::NonlinearContact => "nonlinear_contact",
            EffectKind::Noise => "noise",
        }
    }

    /// Parses a TOML name.
    pub fn parse(name: &str) -> Option<EffectKind> {
        EffectKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// [`EffectKind::parse`] for user input: an unknown name gives a message that lists the
    /// known ones.
    pub fn parse_named(name: &str) -> Result<EffectKind, String> {
        Self::parse(name).ok_or_else(|| format!("unknown effect `{name}` (known: {})", EffectKind::ALL.iter().map(|k| k.name()).collect::<Vec<_>>().join(", ")))
    }
}

/// Radial load on the shaft: only the balls in the load zone carry load, so impacts of an
/// inner-race (or ball) fault are modulated at the shaft (or cage) rate — BPFI ± shaft-speed
/// sidebands in the envelope spectrum. Off: every ball carries the same preload
/// (`bearing.uniform_preload_n`), no clearance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoadZone {
    /// Static radial load on each bearing's shaft, N, acting towards 0° (the bottom). Default 500.
    pub radial_load_n: f64,
}
impl Default for LoadZone {
    fn default() -> Self {
        Self { radial_load_n: 500.0 }
    }
}

/// Random rolling-element slip: each ball's angular position departs from the cage kinematics
/// by a random amount, redrawn every cage revolution (Sawalhi & Randall 2008: 1–2 %). The
/// fault period jitters, so higher envelope harmonics smear.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Slip {
    /// Standard deviation of each ball's position error, % of the ball spacing. Default 1.5.
    pub percent: f64,
}
impl Default for Slip {
    fn default() -> Self {
        Self { percent: 1.5 }
    }
}

/// One structural mode of the casing / transfer path.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CasingMode {
    /// Natural frequency, Hz.
    pub frequency_hz: f64,
    /// Damping ratio (Sawalhi et al. used 4 % modal damping).
    pub damping_ratio: f64,
    /// Modal mass, kg.
    pub modal_mass_kg: f64,
    /// Contribution of the mode's modal acceleration (relative to the DOF it hangs on) to the
    /// sensor signal: the mode shape at the sensor.
    pub gain: f64,
}

/// Extra structural modes on the transfer path — what a Craig–Bampton casing adds to an LPM
/// (Sawalhi, Deshpande & Randall 2011). Each mode is a modal mass sprung to the sensor bearing's
/// pedestal; its modal acceleration (relative to that pedestal, the fixed-interface mode's
/// coordinate) adds to the sensor, times `gain`. A PSD band appears at each mode; well below
/// it the sensor is unchanged. Well above it the modal coordinate tends to minus the
/// pedestal's motion, so a mode passes `−gain ×` the pedestal acceleration there (the
/// truncation residual of any modal superposition).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CasingModes {
    /// Modes. Default: one at 4500 Hz, 4 %.
    pub modes: Vec<CasingMode>,
    /// The DOF the modes hang on; default: the sensor DOF's pedestal (`<bearing>.pedestal.y`).
    pub attach_dof: Option<String>,
}
impl Default for CasingModes {
    fn default() -> Self {
        Self { modes: vec![CasingMode { frequency_hz: 4500.0, damping_ratio: 0.04, modal_mass_kg: 0.5, gain: 1.0 }], attach_dof: None }
    }
}

/// Time-varying mesh stiffness: the contact ratio alternates single and double tooth pairs, so
/// the stiffness varies at the gear-mesh frequency (GMF lines and harmonics). Off: constant
/// mean stiffness.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GearMesh {
    /// Peak-to-peak stiffness variation as a fraction of the mean. Default 0.3.
    pub variation_fraction: f64,
    /// Contact ratio (1–2): the fraction of each mesh period with two pairs in contact is
    /// `contact_ratio − 1`. Default 1.6.
    pub contact_ratio: f64,
}
impl Default for GearMesh {
    fn default() -> Self {
        Self { variation_fraction: 0.3, contact_ratio: 1.6 }
    }
}

/// A local loss of mesh stiffness on one pinion tooth (crack, chip or missing tooth): once per
/// pinion revolution, sidebands at the pinion shaft speed around the GMF harmonics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ToothFault {
    /// Which tooth (0-based) of the pinion. Default 0.
    pub tooth: u32,
    /// Fraction of the tooth-pair stiffness lost (1 = missing tooth). Default 0.5.
    pub stiffness_loss_fraction: f64,
    /// Gear pair name; default: the first.
    pub gear_pair: Option<String>,
}
impl Default for ToothFault {
    fn default() -> Self {
        Self { tooth: 0, stiffness_loss_fraction: 0.5, gear_pair: None }
    }
}

/// Sinusoidal fluctuation of every shaft speed: lines smear in proportion to their order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpeedFluctuation {
    /// Peak speed deviation, % of the mean. Default 1.0.
    pub amplitude_percent: f64,
    /// Fluctuation frequency, Hz. Default 1.0.
    pub frequency_hz: f64,
}
impl Default for SpeedFluctuation {
    fn default() -> Self {
        Self { amplitude_percent: 1.0, frequency_hz: 1.0 }
    }
}

/// Accelerometer response: a 2nd-order low-pass roll-off applied to the output; with
/// `damping_ratio` below 1/√2 it shows a mounted-resonance peak near the bandwidth, at the
/// default 0.707 (Butterworth) it has none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorResponse {
    /// −3 dB bandwidth of the low-pass, Hz. Default 5000.
    pub bandwidth_hz: f64,
    /// Damping ratio of the roll-off (0.707 = Butterworth). Default 0.707.
    pub damping_ratio: f64,
}
impl Default for SensorResponse {
    fn default() -> Self {
        Self { bandwidth_hz: 5000.0, damping_ratio: 0.707 }
    }
}

/// Mass unbalance: a rotating force `m e ω²` on each shaft at 1× its speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Unbalance {
    /// Unbalance `m·e`, kg·m. Default 1e-4 (10 g at 10 mm).
    pub mass_eccentricity_kg_m: f64,
    /// Shaft; default: the first.
    pub shaft: Option<String>,
}
impl Default for Unbalance {
    fn default() -> Self {
        Self { mass_eccentricity_kg_m: 1e-4, shaft: None }
    }
}

/// Shaft misalignment: a radial force at 2× shaft speed (and a weaker 1×).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Misalignment {
    /// Amplitude of the 2× force, N. Default 20.
    pub force_2x_n: f64,
    /// Amplitude of the 1× force, N. Default 5.
    pub force_1x_n: f64,
    /// Shaft; default: the first.
    pub shaft: Option<String>,
}
impl Default for Misalignment {
    fn default() -> Self {
        Self { force_2x_n: 20.0, force_1x_n: 5.0, shaft: None }
    }
}

/// An extended raceway fault (the seed's 15 mm inner-race case): longer than the ball spacing,
/// with entry/exit ramps and random roughness. While the fault is in the load zone the bearing
/// stiffness drops, modulating everything that passes the bearing (gear mesh) — a multiplicative
/// effect at the fault's rotation rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExtendedFault {
    /// Bearing name; default: the first bearing.
    pub bearing: Option<String>,
    /// Inner or outer race.
    pub location: super::machine::FaultLocation,
    /// Length along the race, m. Default 0.015.
    pub length_m: f64,
    /// Depth, m. Default 20 µm.
    pub depth_m: f64,
    /// Length of the entry and of the exit ramp, m. Default 2 mm.
    pub ramp_m: f64,
    /// RMS roughness of the fault bottom, m. Default 2 µm.
    pub roughness_m: f64,
    /// Whether each pass of a ball over the fault meets another roughness profile (one of
    /// [`ExtendedFault::ROUGHNESS_PROFILES`] drawn from the seed, picked per ball and pass),
    /// so the roughness response is random from pass to pass, as a real ball's contact path
    /// and slip make it; false: one profile, met the same on every pass. Default true.
    pub roughness_per_pass: bool,
    /// Position, degrees (as for a localised fault).
    pub position_deg: f64,
}
impl ExtendedFault {
    /// Roughness profiles drawn when they vary by pass.
    pub const ROUGHNESS_PROFILES: usize = 128;
}

impl Default for ExtendedFault {
    fn default() -> Self {
        Self { bearing: None, location: super::machine::FaultLocation::Inner, length_m: 0.015, depth_m: 20e-6, ramp_m: 2e-3, roughness_m: 2e-6, roughness_per_pass: true, position_deg: 0.0 }
    }
}

/// A time-varying transmission path (e.g. planets passing the sensor on a rotating carrier):
/// the output is multiplied by `1 + depth · cos 2π f t`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PathModulation {
    /// Modulation depth, 0–1. Default 0.5.
    pub depth: f64,
    /// Modulation frequency, Hz. Default: 1 (set it to the carrier or shaft rate).
    pub frequency_hz: f64,
}
impl Default for PathModulation {
    fn default() -> Self {
        Self { depth: 0.5, frequency_hz: 1.0 }
    }
}

/// Belt-pass excitation: a radial force on the belt-driven shaft at the belt-pass frequency
/// `π d f / L` and its harmonics (belt joint, uneven belt stiffness).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BeltDrive {
    /// Shaft carrying the driving pulley; default: the first shaft with a pulley diameter.
    pub shaft: Option<String>,
    /// Belt length, m. Default 0.8.
    pub belt_length_m: f64,
    /// Force amplitude of the fundamental, N. Default 10.
    pub force_n: f64,
    /// Harmonics included (each 1/k of the fundamental). Default 3.
    pub harmonics: u32,
}
impl Default for BeltDrive {
    fn default() -> Self {
        Self { shaft: None, belt_length_m: 0.8, force_n: 10.0, harmonics: 3 }
    }
}

/// Hertzian (nonlinear) ball–race contact, `Q = K δ^n`. Off: a linearised contact
/// `Q = k_lin δ` with `k_lin = n K δ₀^(n−1)` at the nominal deflection `δ₀` under
/// `bearing.uniform_preload_n`; the response to large loads then differs. Without a load zone
/// every ball sits at that preload and the two laws give nearly the same response (6e-6 of its
/// RMS on the MFS gear rig, against 0.73 under a 77 N load zone): the law acts through the
/// load ([`EffectKind::acts_through`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct NonlinearContact {}

/// Measurement noise added to the output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Noise {
    /// Signal-to-noise ratio in dB relative to the clean output's RMS. Default 20.
    pub snr_db: f64,
    /// `white` or `pink` (1/f power). Default white.
    pub colour: NoiseColour,
}
impl Default for Noise {
    fn default() -> Self {
        Self { snr_db: 20.0, colour: NoiseColour::White }
    }
}

/// Noise colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum NoiseColour {
    #[default]
    White,
    Pink,
}

/// The switches. A present table turns the effect on with those parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Effects {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub load_zone: Option<LoadZone>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slip: Option<Slip>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub casing_modes: Option<CasingModes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gear_mesh: Option<GearMesh>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth_fault: Option<ToothFault>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_fluctuation: Option<SpeedFluctuation>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_response: Option<SensorResponse>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unbalance: Option<Unbalance>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub misalignment: Option<Misalignment>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extended_fault: Option<ExtendedFault>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub path_modulation: Option<PathModulation>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub belt_drive: Option<BeltDrive>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nonlinear_contact: Option<NonlinearContact>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise: Option<Noise>,
}

impl Effects {
    /// Whether an effect is on.
    pub fn is_on(&self, k: EffectKind) -> bool {
        match k {
            EffectKind::LoadZone => self.load_zone.is_some(),
            EffectKind::Slip => self.slip.is_some(),
            EffectKind::CasingModes => self.casing_modes.is_some(),
            EffectKind::GearMesh => self.gear_mesh.is_some(),
            EffectKind::ToothFault => self.tooth_fault.is_some(),
            EffectKind::SpeedFluctuation => self.speed_fluctuation.is_some(),
            EffectKind::SensorResponse => self.sensor_response.is_some(),
            EffectKind::Unbalance => self.unbalance.is_some(),
            EffectKind::Misalignment => self.misalignment.is_some(),
            EffectKind::ExtendedFault => self.extended_fault.is_some(),
            EffectKind::PathModulation => self.path_modulation.is_some(),
            EffectKind::BeltDrive => self.belt_drive.is_some(),
            EffectKind::NonlinearContact => self.nonlinear_contact.is_some(),
            EffectKind::Noise => self.noise.is_some(),
        }
    }

    /// Switches an effect on with its default parameters (keeps existing parameters if on).
    pub fn enable(&mut self, k: EffectKind) {
        match k {
            EffectKind::LoadZone => drop(self.load_zone.get_or_insert_with(Default::default)),
            EffectKind::Slip => drop(self.slip.get_or_insert_with(Default::default)),
            EffectKind::CasingModes => drop(self.casing_modes.get_or_insert_with(Default::default)),
            EffectKind::GearMesh => drop(self.gear_mesh.get_or_insert_with(Default::default)),
            EffectKind::ToothFault => drop(self.tooth_fault.get_or_insert_with(Default::default)),
            EffectKind::SpeedFluctuation => drop(self.speed_fluctuation.get_or_insert_with(Default::default)),
            EffectKind::SensorResponse => drop(self.sensor_response.get_or_insert_with(Default::default)),
            EffectKind::Unbalance => drop(self.unbalance.get_or_insert_with(Default::default)),
            EffectKind::Misalignment => drop(self.misalignment.get_or_insert_with(Default::default)),
            EffectKind::ExtendedFault => drop(self.extended_fault.get_or_insert_with(Default::default)),
            EffectKind::PathModulation => drop(self.path_modulation.get_or_insert_with(Default::default)),
            EffectKind::BeltDrive => drop(self.belt_drive.get_or_insert_with(Default::default)),
            EffectKind::NonlinearContact => drop(self.nonlinear_contact.get_or_insert_with(Default::default)),
            EffectKind::Noise => drop(self.noise.get_or_insert_with(Default::default)),
        }
    }

    /// Switches an effect off.
    pub fn disable(&mut self, k: EffectKind) {
        match k {
            EffectKind::LoadZone => self.load_zone = None,
            EffectKind::Slip => self.slip = None,
            EffectKind::CasingModes => self.casing_modes = None,
            EffectKind::GearMesh => self.gear_mesh = None,
            EffectKind::ToothFault => self.tooth_fault = None,
            EffectKind::SpeedFluctuation => self.speed_fluctuation = None,
            EffectKind::SensorResponse => self.sensor_response = None,
            EffectKind::Unbalance => self.unbalance = None,
            EffectKind::Misalignment => self.misalignment = None,
            EffectKind::ExtendedFault => self.extended_fault = None,
            EffectKind::PathModulation => self.path_modulation = None,
            EffectKind::BeltDrive => self.belt_drive = None,
            EffectKind::NonlinearContact => self.nonlinear_contact = None,
            EffectKind::Noise => self.noise = None,
        }
    }

    /// Sets effect `k` as it is in `other`: on with `other`'s parameters, or off.
    pub fn copy_from(&mut self, other: &Effects, k: EffectKind) {
        match k {
            EffectKind::LoadZone => self.load_zone = other.load_zone.clone(),
            EffectKind::Slip => self.slip = other.slip.clone(),
            EffectKind::CasingModes => self.casing_modes = other.casing_modes.clone(),
            EffectKind::GearMesh => self.gear_mesh = other.gear_mesh.clone(),
            EffectKind::ToothFault => self.tooth_fault = other.tooth_fault.clone(),
            EffectKind::SpeedFluctuation => self.speed_fluctuation = other.speed_fluctuation.clone(),
            EffectKind::SensorResponse => self.sensor_response = other.sensor_response.clone(),
            EffectKind::Unbalance => self.unbalance = other.unbalance.clone(),
            EffectKind::Misalignment => self.misalignment = other.misalignment.clone(),
            EffectKind::ExtendedFault => self.extended_fault = other.extended_fault.clone(),
            EffectKind::PathModulation => self.path_modulation = other.path_modulation.clone(),
            EffectKind::BeltDrive => self.belt_drive = other.belt_drive.clone(),
            EffectKind::NonlinearContact => self.nonlinear_contact = other.nonlinear_contact.clone(),
            EffectKind::Noise => self.noise = other.noise.clone(),
        }
    }

    /// The effects that are on.
    pub fn enabled(&self) -> Vec<EffectKind> {
        EffectKind::ALL.into_iter().filter(|k| self.is_on(*k)).collect()
    }

    /// Whether an effect can act on this machine (e.g. `gear_mesh` needs a gear pair).
    pub fn applicable(k: EffectKind, m: &Machine) -> bool {
        match k {
            EffectKind::GearMesh | EffectKind::ToothFault => !m.gear_pairs.is_empty(),
            EffectKind::BeltDrive => m.shafts.iter().any(|s| s.pulley_diameter_m.is_some()),
            EffectKind::LoadZone | EffectKind::Slip | EffectKind::ExtendedFault | EffectKind::NonlinearContact => !m.bearings.is_empty(),
            EffectKind::CasingModes => !m.bearings.is_empty() || m.effects.casing_modes.as_ref().is_some_and(|c| c.attach_dof.is_some()),
            _ => true,
        }
    }

    /// Checks the parameters of every effect that is on; errors name the field.
    pub fn validate(&self, m: &Machine) -> Result<(), ModelError> {
        let bad = |field: &str, v: &dyn std::fmt::Display, reason: &str| m.invalid(format!("effects.{field}"), v, reason);
        let pos = |field: &str, v: f64| if v.is_finite() && v > 0.0 { Ok(()) } else { Err(bad(field, &v, "must be a positive, finite number")) };
        let nonneg = |field: &str, v: f64| if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(bad(field, &v, "must be a finite number ≥ 0")) };
        for k in self.enabled() {
            if !Effects::applicable(k, m) {
                return Err(bad(k.name(), &"on", "this machine has nothing it can act on (e.g. no gear pair, no pulley, no bearing)"));
            }
        }
        if let Some(e) = &self.load_zone {
            nonneg("load_zone.radial_load_n", e.radial_load_n)?;
        }
        if let Some(e) = &self.slip {
            if !(e.percent.is_finite() && (0.0..=20.0).contains(&e.percent)) {
                return Err(bad("slip.percent", &e.percent, "must be in [0, 20] % of the ball spacing"));
            }
        }
        if let Some(e) = &self.casing_modes {
            if e.modes.is_empty() {
                return Err(bad("casing_modes.modes", &"[]", "give at least one mode"));
            }
            for (i, md) in e.modes.iter().enumerate() {
                pos(&format!("casing_modes.modes[{i}].frequency_hz"), md.frequency_hz)?;
                nonneg(&format!("casing_modes.modes[{i}].damping_ratio"), md.damping_ratio)?;
                pos(&format!("casing_modes.modes[{i}].modal_mass_kg"), md.modal_mass_kg)?;
                if !md.gain.is_finite() {
                    return Err(bad(&format!("casing_modes.modes[{i}].gain"), &md.gain, "must be finite"));
                }
                if md.frequency_hz >= m.fs_hz / 2.0 {
                    return Err(bad(&format!("casing_modes.modes[{i}].frequency_hz"), &md.frequency_hz, &format!("is above the output Nyquist frequency ({} Hz): raise fs_hz to at least twice the highest mode", m.fs_hz / 2.0)));
                }
            }
        }
        if let Some(e) = &self.gear_mesh {
            if !(e.variation_fraction.is_finite() && (0.0..1.0).contains(&e.variation_fraction)) {
                return Err(bad("gear_mesh.variation_fraction", &e.variation_fraction, "must be in [0, 1)"));
            }
            if !(e.contact_ratio > 1.0 && e.contact_ratio < 2.0) {
                return Err(bad("gear_mesh.contact_ratio", &e.contact_ratio, "must be in (1, 2)"));
            }
        }
        if let Some(e) = &self.tooth_fault {
            if !(e.stiffness_loss_fraction.is_finite() && (0.0..=1.0).contains(&e.stiffness_loss_fraction)) {
                return Err(bad("tooth_fault.stiffness_loss_fraction", &e.stiffness_loss_fraction, "must be in [0, 1]"));
            }
            let gp = match &e.gear_pair {
                Some(n) => m.gear_pairs.iter().find(|g| &g.name == n).ok_or_else(|| bad("tooth_fault.gear_pair", n, "no such gear pair"))?,
                None => &m.gear_pairs[0],
            };
            if e.tooth >= gp.pinion_teeth {
                return Err(bad("tooth_fault.tooth", &e.tooth, &format!("the pinion of `{}` has {} teeth (0-based)", gp.name, gp.pinion_teeth)));
            }
        }
        if let Some(e) = &self.speed_fluctuation {
            if !(e.amplitude_percent.is_finite() && (0.0..50.0).contains(&e.amplitude_percent)) {
                return Err(bad("speed_fluctuation.amplitude_percent", &e.amplitude_percent, "must be in [0, 50)"));
            }
            pos("speed_fluctuation.frequency_hz", e.frequency_hz)?;
        }
        if let Some(e) = &self.sensor_response {
            pos("sensor_response.bandwidth_hz", e.bandwidth_hz)?;
            pos("sensor_response.damping_ratio", e.damping_ratio)?;
        }
        if let Some(e) = &self.unbalance {
            nonneg("unbalance.mass_eccentricity_kg_m", e.mass_eccentricity_kg_m)?;
            if let Some(s) = &e.shaft {
                m.shaft_index(s).ok_or_else(|| bad("unbalance.shaft", s, "no such shaft"))?;
            }
        }
        if let Some(e) = &self.misalignment {
            nonneg("misalignment.force_2x_n", e.force_2x_n)?;
            nonneg("misalignment.force_1x_n", e.force_1x_n)?;
            if let Some(s) = &e.shaft {
                m.shaft_index(s).ok_or_else(|| bad("misalignment.shaft", s, "no such shaft"))?;
            }
        }
        if let Some(e) = &self.extended_fault {
            pos("extended_fault.length_m", e.length_m)?;
            pos("extended_fault.depth_m", e.depth_m)?;
            nonneg("extended_fault.ramp_m", e.ramp_m)?;
            nonneg("extended_fault.roughness_m", e.roughness_m)?;
            if 2.0 * e.ramp_m >= e.length_m {
                return Err(bad("extended_fault.ramp_m", &e.ramp_m, "the two ramps must be shorter than the fault"));
            }
            if e.location == super::machine::FaultLocation::Ball {
                return Err(bad("extended_fault.location", &"ball", "an extended fault is on a race: inner or outer"));
            }
            if let Some(b) = &e.bearing {
                m.bearings.iter().find(|x| &x.name == b).ok_or_else(|| bad("extended_fault.bearing", b, "no such bearing"))?;
            }
        }
        if let Some(e) = &self.path_modulation {
            if !(e.depth.is_finite() && (0.0..=1.0).contains(&e.depth)) {
                return Err(bad("path_modulation.depth", &e.depth, "must be in [0, 1]"));
            }
            pos("path_modulation.frequency_hz", e.frequency_hz)?;
        }
        if let Some(e) = &self.belt_drive {
            pos("belt_drive.belt_length_m", e.belt_length_m)?;
            nonneg("belt_drive.force_n", e.force_n)?;
            if e.harmonics == 0 || e.harmonics > 20 {
                return Err(bad("belt_drive.harmonics", &e.harmonics, "must be in 1..=20"));
            }
            if let Some(s) = &e.shaft {
                let i = m.shaft_index(s).ok_or_else(|| bad("belt_drive.shaft", s, "no such shaft"))?;
                if m.shafts[i].pulley_diameter_m.is_none() {
                    return Err(bad("belt_drive.shaft", s, "that shaft has no `pulley_diameter_m`"));
                }
            }
        }
        if let Some(e) = &self.noise {
            if !e.snr_db.is_finite() || e.snr_db < -40.0 {
                return Err(bad("noise.snr_db", &e.snr_db, "must be a finite number ≥ −40 dB"));
            }
        }
        Ok(())
    }
}
