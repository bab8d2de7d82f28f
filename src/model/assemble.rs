//! Builds the [`System`] of a [`Machine`]: DOFs, springs, static loads and force elements, with
//! every effect that is on.

use super::bearing::{BearingElement, BearingFault, ContactLaw, DepthProfile, ShaftMotion};
use super::effects::{ExtendedFault, NoiseColour};
use super::error::ModelError;
use super::gear::{GearMeshElement, MeshStiffness, OrderForce};
use super::machine::{AntiAliasFilter, FaultLocation, Machine};
use super::system::System;
use crate::signal::synth;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::TAU;

/// Standard gravity, m/s², for outputs in g.
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// What the sensor reads: a weighted sum of DOF accelerations.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorMix {
    /// (DOF, weight) pairs; the output is `gain · Σ w a_dof` in the output unit.
    pub terms: Vec<(usize, f64)>,
}

/// Post-processing of the sensor signal (effects that act on the measurement, not the physics).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PostProcessing {
    /// Accelerometer low-pass: (bandwidth Hz, damping ratio).
    pub sensor_response: Option<(f64, f64)>,
    /// Transmission-path modulation: (depth, frequency Hz).
    pub path_modulation: Option<(f64, f64)>,
    /// Measurement noise: (SNR dB, colour).
    pub noise: Option<(f64, NoiseColour)>,
    /// The recorder's anti-alias filter, applied last (to signal and noise).
    pub antialias: Option<AntiAliasFilter>,
}

/// An assembled model, ready to integrate.
pub struct Model {
    /// The machine it was built from.
    pub machine: Machine,
    /// DOFs, springs, elements.
    pub system: System,
    /// What the sensor reads.
    pub sensor: SensorMix,
    /// Output post-processing.
    pub post: PostProcessing,
    /// Initial guess for the static equilibrium.
    pub q_guess: Vec<f64>,
    /// Mean speed of each shaft, Hz.
    pub shaft_speeds_hz: Vec<f64>,
    /// Whether assembling drew random numbers from the machine's seed (slip tables, rough
    /// extended faults): only then does the seed shape the integrated signal, not just the
    /// measurement noise added after it.
    pub seeded_assembly: bool,
}

impl Model {
    /// Assembles a validated machine.
    pub fn build(machine: &Machine) -> Result<Model, ModelError> {
        machine.validate()?;
        let m = machine;
        let fx = &m.effects;
        let speeds = m.shaft_speeds_hz()?;
        let (fluct, fluct_hz) = fx.speed_fluctuation.as_ref().map(|s| (s.amplitude_percent / 100.0, s.frequency_hz)).unwrap_or((0.0, 1.0));
        let motions: Vec<ShaftMotion> = speeds.iter().map(|&f| ShaftMotion { mean_hz: f, fluctuation: fluct, fluctuation_hz: fluct_hz }).collect();
        let total_s = m.settle_s + m.duration_s;
        let mut sys = System::default();
        let mut rng = synth::rng(m.seed);

        // Shafts: radial DOFs, torsional DOF when they carry a gear.
        let mut shaft_dofs = Vec::new();
        for s in &m.shafts {
            let x = sys.add_dof(format!("{}.x", s.name), s.mass_kg);
            let y = sys.add_dof(format!("{}.y", s.name), s.mass_kg);
            if s.damping_n_s_per_m > 0.0 {
                sys.add_spring(x, None, 0.0, s.damping_n_s_per_m);
                sys.add_spring(y, None, 0.0, s.damping_n_s_per_m);
            }
            let th = match (s.inertia_kg_m2, s.torsional_stiffness_n_m_per_rad) {
                (Some(j), Some(k)) => {
                    let th = sys.add_dof(format!("{}.theta", s.name), j);
                    sys.add_spring(th, None, k, s.torsional_damping_n_m_s_per_rad);
                    Some(th)
                }
                _ => None,
            };
            shaft_dofs.push((x, y, th));
        }
        let mut q_guess = vec![0.0; sys.n()];

        // Bearings.
        let radial_load = fx.load_zone.as_ref().map(|l| l.radial_load_n);
        let ext_bearing = fx.extended_fault.as_ref().map(|e| e.bearing.clone().unwrap_or_else(|| m.bearings[0].name.clone()));
        for (bi, b) in m.bearings.iter().enumerate() {
            let g = m.bearing_geometry(bi)?;
            let si = m.shaft_index(&b.shaft).ok_or_else(|| m.unknown(format!("bearing[{}].shaft", b.name), "no such shaft"))?;
            let (sx, sy, _) = shaft_dofs[si];
            let px = sys.add_dof(format!("{}.pedestal.x", b.name), b.pedestal_mass_kg);
            let py = sys.add_dof(format!("{}.pedestal.y", b.name), b.pedestal_mass_kg);
            sys.add_spring(px, None, b.pedestal_stiffness_n_per_m, b.pedestal_damping_n_s_per_m);
            sys.add_spring(py, None, b.pedestal_stiffness_n_per_m, b.pedestal_damping_n_s_per_m);
            let wr = TAU * b.resonator_frequency_hz;
            let ry = sys.add_dof(format!("{}.resonator.y", b.name), b.resonator_mass_kg);
            sys.add_spring(ry, Some(py), b.resonator_mass_kg * wr * wr, 2.0 * b.resonator_damping_ratio * b.resonator_mass_kg * wr);

            let n = b.load_exponent;
            let k = b.hertz_constant_n_per_m_n;
            let delta0 = (b.uniform_preload_n / k).powf(1.0 / n);
            let law = if fx.nonlinear_contact.is_some() { ContactLaw::Hertz { k, n } } else { ContactLaw::Linear { k: n * k * delta0.powf(n - 1.0) } };
            let clearance = match radial_load {
                Some(w) => {
                    sys.static_force[sy] -= w;
                    b.radial_clearance_m
                }
                None => -delta0,
            };
            let d = g.ball_diameter_mm * 1e-3;
            let pd = g.pitch_diameter_mm * 1e-3;
            let ratio = d / pd * g.contact_angle_deg.to_radians().cos();
            let mut faults = Vec::new();
            if let Some(f) = &b.fault {
                faults.push(BearingFault {
                    location: f.location,
                    profile: DepthProfile::Spall { length_m: f.length_m, depth_m: f.depth_m, ball_radius_m: d / 2.0 },
                    position_rad: f.position_deg.to_radians(),
                });
            }
            if let (Some(e), Some(name)) = (&fx.extended_fault, &ext_bearing) {
                if name == &b.name {
                    let samples = ((e.length_m / 0.25e-3).ceil() as usize).max(2) + 1;
                    let profiles = if e.roughness_per_pass { ExtendedFault::ROUGHNESS_PROFILES } else { 1 };
                    let roughness: Vec<Vec<f64>> = (0..profiles)
                        .map(|_| {
                            (0..samples)
                                .map(|_| {
                                    let z: f64 = StandardNormal.sample(&mut rng);
                                    e.roughness_m * z
                                })
                                .collect()
                        })
                        .collect();
                    faults.push(BearingFault {
                        location: e.location,
                        profile: DepthProfile::Extended { length_m: e.length_m, depth_m: e.depth_m, ramp_m: e.ramp_m, roughness_m: roughness },
                        position_rad: e.position_deg.to_radians(),
                    });
                }
            }
            let balls = g.rolling_elements as usize;
            let slip = match &fx.slip {
                Some(s) if s.percent > 0.0 => {
                    let cage_hz = 0.5 * (1.0 - ratio) * speeds[si] * (1.0 + fluct);
                    let revs = (cage_hz * total_s).ceil() as usize + 3;
                    let sigma = s.percent / 100.0 * TAU / balls as f64;
                    (0..balls)
                        .map(|_| {
                            (0..revs)
                                .map(|_| {
                                    let z: f64 = StandardNormal.sample(&mut rng);
                                    sigma * z
                                })
                                .collect()
                        })
                        .collect()
                }
                _ => Vec::new(),
            };
            // The shaft sits where its balls carry the load: guess a deflection below the
            // clearance so the equilibrium search starts in contact.
            if let Some(w) = radial_load {
                let per_ball = w / (balls as f64 / 4.0).max(1.0);
                q_guess[sy] = -(clearance.max(0.0) + (per_ball / k).powf(1.0 / n));
            }
            sys.elements.push(Box::new(BearingElement {
                name: format!("bearing {}", b.name),
                shaft: (sx, sy),
                pedestal: (px, py),
                balls,
                ball_diameter_m: d,
                pitch_diameter_m: pd,
                ratio,
                clearance_m: clearance,
                law,
                motion: motions[si],
                faults,
                slip,
                memo: Default::default(),
            }));
            q_guess.resize(sys.n(), 0.0);
        }

        // Gear pairs.
        for gp in &m.gear_pairs {
            let pi = m.shaft_index(&gp.pinion_shaft).ok_or_else(|| m.unknown(format!("gear_pair[{}].pinion_shaft", gp.name), "no such shaft"))?;
            let gi = m.shaft_index(&gp.gear_shaft).ok_or_else(|| m.unknown(format!("gear_pair[{}].gear_shaft", gp.name), "no such shaft"))?;
            let (Some(tp), Some(tg)) = (shaft_dofs[pi].2, shaft_dofs[gi].2) else {
                return Err(m.invalid(format!("gear_pair[{}]", gp.name), "shafts", "both shafts need `inertia_kg_m2` and `torsional_stiffness_n_m_per_rad`"));
            };
            let alpha = gp.pressure_angle_deg.to_radians();
            let rp = gp.module_m * gp.pinion_teeth as f64 * alpha.cos() / 2.0;
            let rg = gp.module_m * gp.gear_teeth as f64 * alpha.cos() / 2.0;
            let tooth_fault = fx.tooth_fault.as_ref().filter(|t| t.gear_pair.as_ref().is_none_or(|n| n == &gp.name)).map(|t| (t.tooth, t.stiffness_loss_fraction));
            let (variation, contact_ratio) = fx.gear_mesh.as_ref().map(|g| (g.variation_fraction, g.contact_ratio)).unwrap_or((0.0, 1.6));
            sys.static_force[tp] += gp.transmitted_load_n * rp;
            sys.static_force[tg] -= gp.transmitted_load_n * rg;
            sys.elements.push(Box::new(GearMeshElement {
                name: format!("gear mesh {}", gp.name),
                theta: (tp, tg),
                line: (shaft_dofs[pi].1, shaft_dofs[gi].1),
                base_radius_m: (rp, rg),
                stiffness: MeshStiffness { mean_n_per_m: gp.mean_mesh_stiffness_n_per_m, variation_fraction: variation, contact_ratio, pinion_teeth: gp.pinion_teeth, tooth_fault },
                damping_n_s_per_m: gp.mesh_damping_n_s_per_m,
                pinion_motion: motions[pi],
                memo: Default::default(),
            }));
        }

        // Couplings between named DOFs.
        for (i, c) in m.couplings.iter().enumerate() {
            let a = sys.dof(&c.a).ok_or_else(|| m.unknown(format!("coupling[{i}].a"), format!("no DOF `{}`; DOFs: {}", c.a, sys.dof_names.join(", "))))?;
            let b = match &c.b {
                Some(n) => Some(sys.dof(n).ok_or_else(|| m.unknown(format!("coupling[{i}].b"), format!("no DOF `{n}`; DOFs: {}", sys.dof_names.join(", "))))?),
                None => None,
            };
            sys.add_spring(a, b, c.stiffness_n_per_m, c.damping_n_s_per_m);
        }

        // Sensor and casing modes.
        let sensor_dof = sys.dof(&m.sensor.dof).ok_or_else(|| m.unknown("sensor.dof", format!("no DOF `{}`; DOFs: {}", m.sensor.dof, sys.dof_names.join(", "))))?;
        let unit_scale = if m.sensor.unit == "g" { 1.0 / STANDARD_GRAVITY } else { 1.0 };
        let mut sensor = SensorMix { terms: vec![(sensor_dof, m.sensor.gain * unit_scale)] };
        if let Some(cm) = &fx.casing_modes {
            let attach_name = cm.attach_dof.clone().unwrap_or_else(|| match m.sensor.dof.split_once('.') {
                Some((bearing, _)) if m.bearings.iter().any(|b| b.name == bearing) => format!("{bearing}.pedestal.y"),
                _ => m.sensor.dof.clone(),
            });
            let attach = sys.dof(&attach_name).ok_or_else(|| m.unknown("effects.casing_modes.attach_dof", format!("no DOF `{attach_name}`")))?;
            for (i, md) in cm.modes.iter().enumerate() {
                let w = TAU * md.frequency_hz;
                let d = sys.add_dof(format!("casing.mode{i}"), md.modal_mass_kg);
                sys.add_spring(d, Some(attach), md.modal_mass_kg * w * w, 2.0 * md.damping_ratio * md.modal_mass_kg * w);
                // The sensor sees the mode's own (fixed-interface) coordinate, the modal mass's
                // motion relative to its attachment: the attachment's rigid motion is already in
                // the sensor DOF, and adding the absolute acceleration would count it twice
                // (+6 dB at every frequency below the mode).
                let g = md.gain * m.sensor.gain * unit_scale;
                sensor.terms.push((d, g));
                sensor.terms.push((attach, -g));
            }
            q_guess.resize(sys.n(), 0.0);
        }

        // Order forces: unbalance, misalignment, belt drive.
        if let Some(u) = &fx.unbalance {
            let si = u.shaft.as_ref().and_then(|s| m.shaft_index(s)).unwrap_or(0);
            let w = TAU * speeds[si];
            sys.elements.push(Box::new(OrderForce {
                name: "unbalance".into(),
                dofs: (shaft_dofs[si].0, Some(shaft_dofs[si].1)),
                motion: motions[si],
                terms: vec![(1.0, u.mass_eccentricity_kg_m * w * w, 0.0, true)],
                memo: Default::default(),
            }));
        }
        if let Some(mi) = &fx.misalignment {
            let si = mi.shaft.as_ref().and_then(|s| m.shaft_index(s)).unwrap_or(0);
            sys.elements.push(Box::new(OrderForce {
                name: "misalignment".into(),
                dofs: (shaft_dofs[si].0, Some(shaft_dofs[si].1)),
                motion: motions[si],
                terms: vec![(2.0, mi.force_2x_n, 0.0, false), (1.0, mi.force_1x_n, 0.3, false)],
                memo: Default::default(),
            }));
        }
        if let Some(bd) = &fx.belt_drive {
            let si = match &bd.shaft {
                Some(s) => m.shaft_index(s).unwrap_or(0),
                None => m.shafts.iter().position(|s| s.pulley_diameter_m.is_some()).unwrap_or(0),
            };
            let d = m.shafts[si].pulley_diameter_m.unwrap_or(0.0);
            // Belt-pass order relative to the shaft: f_b / f_shaft = π d / L.
            let order = std::f64::consts::PI * d / bd.belt_length_m;
            sys.elements.push(Box::new(OrderForce {
                name: "belt drive".into(),
                dofs: (shaft_dofs[si].1, None),
                motion: motions[si],
                terms: (1..=bd.harmonics).map(|k| (order * k as f64, bd.force_n / k as f64, 0.0, false)).collect(),
                memo: Default::default(),
            }));
        }

        let post = PostProcessing {
            sensor_response: fx.sensor_response.as_ref().map(|s| (s.bandwidth_hz, s.damping_ratio)),
            path_modulation: fx.path_modulation.as_ref().map(|p| (p.depth, p.frequency_hz)),
            noise: fx.noise.as_ref().map(|n| (n.snr_db, n.colour)),
            antialias: m.sensor.antialias.clone(),
        };
        q_guess.resize(sys.n(), 0.0);
        // Any draw moves the generator: the word position tells whether one was made.
        let seeded_assembly = rng.get_word_pos() != 0;
        Ok(Model { machine: m.clone(), system: sys, sensor, post, q_guess, shaft_speeds_hz: speeds, seeded_assembly })
    }

    /// The bearing elements' fault locations (for labelling), by bearing name.
    pub fn fault_locations(&self) -> Vec<(String, FaultLocation)> {
        self.machine.bearings.iter().filter_map(|b| b.fault.as_ref().map(|f| (b.name.clone(), f.location))).collect()
    }
}
