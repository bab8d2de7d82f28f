//! Fixed-step explicit integration (classical RK4 with sub-steps per output sample) and the
//! measurement post-processing.

use super::assemble::{Model, PostProcessing};
use super::effects::NoiseColour;
use super::error::ModelError;
use crate::dsp::fft;
use crate::signal::{synth, Signal};
use num_complex::Complex64;
use std::f64::consts::{PI, TAU};

/// Why [`Simulator::step`] stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum StepResult {
    /// One output sample was produced (the sensor reading at the start of the interval).
    Sample(f64),
    /// The state became non-finite or ran away; the DOF and time are named.
    Diverged { t_s: f64, dof: String, what: String },
}

/// Integrates a [`Model`]. Owns only the state and scratch memory.
pub struct Simulator<'a> {
    model: &'a Model,
    /// Time, s.
    pub t: f64,
    /// Displacements.
    pub q: Vec<f64>,
    /// Velocities.
    pub v: Vec<f64>,
    dt: f64,
    substeps: usize,
    k: [Vec<f64>; 7],
    tmp_q: Vec<f64>,
    tmp_v: Vec<f64>,
    /// Sensor reading at the start of the last RK4 step (from its first stage).
    k1_reading: f64,
}

/// Displacement beyond which a DOF is taken as run away (a bearing model moves microns).
const RUNAWAY_M: f64 = 0.05;

impl<'a> Simulator<'a> {
    /// Starts from the static equilibrium at t = 0 (found by Levenberg–Marquardt), at rest.
    pub fn new(model: &'a Model) -> Result<Self, ModelError> {
        let sys = &model.system;
        let q = match sys.static_equilibrium(0.0, &model.q_guess, 1e-6) {
            Ok(q) => q,
            Err(e) => {
                // A free DOF is the usual cause: name it rather than the worst residual.
                sys.check_supported(&model.q_guess)?;
                return Err(e);
            }
        };
        sys.check_supported(&q)?;
        let n = sys.n();
        let m = &model.machine;
        Ok(Self {
            model,
            t: 0.0,
            q,
            v: vec![0.0; n],
            dt: 1.0 / (m.fs_hz * m.substeps as f64),
            substeps: m.substeps,
            k: std::array::from_fn(|_| vec![0.0; n]),
            tmp_q: vec![0.0; n],
            tmp_v: vec![0.0; n],
            k1_reading: 0.0,
        })
    }

    /// The integrator step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Sensor reading at the current state.
    pub fn sensor(&mut self) -> f64 {
        let sys = &self.model.system;
        sys.accelerations(self.t, &self.q, &self.v, &mut self.tmp_v);
        self.model.sensor.terms.iter().map(|(d, w)| w * self.tmp_v[*d]).sum()
    }

    /// One RK4 step of `dt`. The stage slopes of the displacements are the stage velocities
    /// themselves (`v`, then `k[4..7]`), so they are read in place rather than copied.
    fn rk4(&mut self) {
        self.rk4_first_slope();
        self.rk4_finish();
    }

    /// The first stage of [`Simulator::rk4`]: the accelerations at the current state, and the
    /// sensor reading they give (`k1_reading`, which is [`Simulator::sensor`]'s value here).
    /// The state is not changed.
    fn rk4_first_slope(&mut self) {
        let sys = &self.model.system;
        let k1v = &mut self.k[0];
        sys.accelerations(self.t, &self.q, &self.v, k1v);
        self.k1_reading = self.model.sensor.terms.iter().map(|(d, w)| w * k1v[*d]).sum();
    }

    /// The rest of [`Simulator::rk4`], after [`Simulator::rk4_first_slope`].
    fn rk4_finish(&mut self) {
        let sys = &self.model.system;
        let (h, t) = (self.dt, self.t);
        let n = self.q.len();
        let [k1v, k2v, k3v, k4v, v2, v3, v4] = &mut self.k;
        for i in 0..n {
            self.tmp_q[i] = self.q[i] + 0.5 * h * self.v[i];
            v2[i] = self.v[i] + 0.5 * h * k1v[i];
        }
        sys.accelerations(t + 0.5 * h, &self.tmp_q, v2, k2v);
        for i in 0..n {
            self.tmp_q[i] = self.q[i] + 0.5 * h * v2[i];
            v3[i] = self.v[i] + 0.5 * h * k2v[i];
        }
        sys.accelerations(t + 0.5 * h, &self.tmp_q, v3, k3v);
        for i in 0..n {
            self.tmp_q[i] = self.q[i] + h * v3[i];
            v4[i] = self.v[i] + h * k3v[i];
        }
        sys.accelerations(t + h, &self.tmp_q, v4, k4v);
        for i in 0..n {
            self.q[i] += h / 6.0 * (self.v[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]);
            self.v[i] += h / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]);
        }
        self.t += h;
    }

    /// Advances one output interval (`substeps` RK4 steps) and returns the sensor reading at its
    /// start. The reading is checked before it is returned and the state after every RK4 step,
    /// so a divergence is reported at the first sub-step where it shows (time and DOF) and no
    /// non-finite value is ever returned as a sample.
    pub fn step(&mut self) -> StepResult {
        self.step_recording(None)
    }

    /// [`Simulator::step`], also appending the sensor reading at every sub-step (the internal
    /// rate `fs · substeps`) to `fine`, for anti-alias decimation.
    pub fn step_recording(&mut self, mut fine: Option<&mut Vec<f64>>) -> StepResult {
        // The reading at the start is the first RK4 stage's: one force evaluation, not two
        // (the same accelerations at the same state, so the same value to the bit).
        self.rk4_first_slope();
        let reading = self.k1_reading;
        if !reading.is_finite() {
            return StepResult::Diverged { t_s: self.t, dof: self.model.machine.sensor.dof.clone(), what: "non-finite sensor reading".into() };
        }
        for sub in 0..self.substeps {
            if sub == 0 {
                self.rk4_finish();
            } else {
                self.rk4();
            }
            if let Some(f) = fine.as_deref_mut() {
                f.push(self.k1_reading);
            }
            if let Some((i, what)) = self.divergence() {
                return StepResult::Diverged { t_s: self.t, dof: self.model.system.dof_names[i].clone(), what };
            }
        }
        StepResult::Sample(reading)
    }

    /// The DOF that diverged, if any: the first with a non-finite displacement or velocity, else
    /// the one furthest beyond the runaway displacement.
    fn divergence(&self) -> Option<(usize, String)> {
        let mut worst: Option<(usize, f64)> = None;
        for (i, (q, v)) in self.q.iter().zip(&self.v).enumerate() {
            if !q.is_finite() || !v.is_finite() {
                let what = if q.is_finite() { "non-finite velocity" } else { "non-finite displacement" };
                return Some((i, what.to_string()));
            }
            if q.abs() > RUNAWAY_M && worst.is_none_or(|(_, w)| q.abs() > w) {
                worst = Some((i, q.abs()));
            }
        }
        worst.map(|(i, _)| (i, format!("displacement {:.3e} beyond the runaway limit {RUNAWAY_M} m", self.q[i])))
    }

    /// Kinetic energy `½ Σ m v²` of the current state, J.
    pub fn kinetic_energy(&self) -> f64 {
        self.model.system.kinetic_energy(&self.v)
    }

    /// Total mechanical energy `T + V` of the current state, J, or `None` if an element has no
    /// potential (see [`System::potential_energy`](super::System::potential_energy)). Constant
    /// along the trajectory (up to the integration error) when the model has no damping and no
    /// explicit time dependence.
    pub fn mechanical_energy(&self) -> Option<f64> {
        self.model.system.mechanical_energy(self.t, &self.q, &self.v)
    }
}

/// Runs a model: settles for `settle_s`, records `duration_s` of the sensor at `fs_hz`, then
/// applies the measurement effects. `progress(fraction)` is called about 100 times; returning
/// `false` cancels. A divergence stops with an error; no NaN is ever returned.
pub fn run(model: &Model, progress: impl FnMut(f64) -> bool) -> Result<Signal, ModelError> {
    let raw = run_raw(model, progress)?;
    finish(model, &raw)
}

/// The integration part of [`run`]: the sensor signal at `fs_hz` after settling, decimated
/// through the anti-alias low-pass, before the measurement effects
/// ([`PostProcessing`]). `progress` as in [`run`].
pub fn run_raw(model: &Model, mut progress: impl FnMut(f64) -> bool) -> Result<Vec<f64>, ModelError> {
    let m = &model.machine;
    let mut sim = Simulator::new(model)?;
    let settle = (m.settle_s * m.fs_hz).round() as usize;
    let n = (m.duration_s * m.fs_hz).round() as usize;
    let total = settle + n;
    let every = (total / 100).max(1);
    // The sensor is recorded at the internal rate fs·substeps and decimated to fs through an
    // ideal (Fourier) low-pass, as a data-acquisition front end's anti-alias filter would, so
    // content above fs/2 (sprung-mass ringing, contact transients) does not fold back.
    let sub = m.substeps;
    let mut fine = Vec::with_capacity(n * sub);
    for i in 0..total {
        let recording = i >= settle && sub > 1;
        match sim.step_recording(if recording { Some(&mut fine) } else { None }) {
            StepResult::Sample(x) => {
                if i >= settle && sub == 1 {
                    fine.push(x);
                }
            }
            StepResult::Diverged { t_s, dof, what } => return Err(ModelError::Diverged { t_s, dof, what }),
        }
        if i % every == 0 && !progress(i as f64 / total as f64) {
            return Err(ModelError::Cancelled { t_s: sim.t });
        }
    }
    progress(1.0);
    let out = if sub > 1 {
        crate::dsp::resample::resample(&fine, m.fs_hz * sub as f64, m.fs_hz).map_err(|e| ModelError::Diverged { t_s: sim.t, dof: m.sensor.dof.clone(), what: format!("anti-alias decimation failed: {e}") })?
    } else {
        fine
    };
    Ok(out)
}

/// The measurement part of [`run`]: applies the model's measurement effects to a signal from
/// [`run_raw`] and labels it.
pub fn finish(model: &Model, raw: &[f64]) -> Result<Signal, ModelError> {
    let m = &model.machine;
    let y = post_process(raw, m.fs_hz, &model.post, m.seed)?;
    let mut s = Signal::new(y, m.fs_hz, format!("{} (simulated)", m.name), m.sensor.unit.clone());
    s.meta.shaft_speed_hz = model.shaft_speeds_hz.first().copied();
    s.meta.source = Some(format!("twinscope model `{}`", m.name));
    s.meta.channel = Some(m.sensor.dof.clone());
    s.meta.bearing = m.bearings.first().and_then(|b| b.catalogue.clone().or_else(|| b.geometry.as_ref().map(|g| g.name.clone())));
    let on: Vec<&str> = m.effects.enabled().iter().map(|k| k.name()).collect();
    s.meta.extra.insert("effects".into(), on.join(","));
    s.meta.extra.insert("seed".into(), m.seed.to_string());
    Ok(s)
}

/// Applies the measurement effects in physical order: accelerometer response, then the
/// transmission-path modulation, then additive noise, then the recorder's anti-alias filter.
///
/// Errors: the anti-alias filter's (its parameters are validated with the machine, so in
/// practice a record shorter than 2 samples).
pub fn post_process(x: &[f64], fs_hz: f64, post: &PostProcessing, seed: u64) -> Result<Vec<f64>, ModelError> {
    let mut y = x.to_vec();
    if let Some((bw, zeta)) = post.sensor_response {
        y = sensor_lowpass(&y, fs_hz, bw, zeta);
    }
    if let Some((depth, f)) = post.path_modulation {
        for (i, v) in y.iter_mut().enumerate() {
            *v *= 1.0 + depth * (TAU * f * i as f64 / fs_hz).cos();
        }
    }
    if let Some((snr_db, colour)) = post.noise {
        let rms = crate::dsp::rms(&y);
        let std = rms * 10f64.powf(-snr_db / 20.0);
        let noise = coloured_noise(y.len(), std, colour, seed.wrapping_add(0x5EED));
        y.iter_mut().zip(noise).for_each(|(a, b)| *a += b);
    }
    if let Some(a) = &post.antialias {
        y = crate::dsp::lowpass::fourier_lowpass(&y, fs_hz, a.passband_hz, a.stopband_hz, a.stopband_db).map_err(|e| ModelError::AntiAlias(e.to_string()))?;
    }
    Ok(y)
}

/// Second-order low-pass `ω²/(s² + 2ζωs + ω²)` discretised by the bilinear transform with
/// frequency pre-warping at `bandwidth_hz` (a causal biquad, as an accelerometer's roll-off).
pub fn sensor_lowpass(x: &[f64], fs_hz: f64, bandwidth_hz: f64, zeta: f64) -> Vec<f64> {
    let wc = (PI * bandwidth_hz.min(0.49 * fs_hz) / fs_hz).tan();
    let (w2, a1c) = (wc * wc, 2.0 * zeta * wc);
    let a0 = 1.0 + a1c + w2;
    let (b0, b1, b2) = (w2 / a0, 2.0 * w2 / a0, w2 / a0);
    let (a1, a2) = (2.0 * (w2 - 1.0) / a0, (1.0 - a1c + w2) / a0);
    let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
    x.iter()
        .map(|&x0| {
            let y0 = b0 * x0 + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
            x2 = x1;
            x1 = x0;
            y2 = y1;
            y1 = y0;
            y0
        })
        .collect()
}

/// White or pink (power ∝ 1/f) Gaussian noise with standard deviation `std`, seeded.
pub fn coloured_noise(n: usize, std: f64, colour: NoiseColour, seed: u64) -> Vec<f64> {
    let white = synth::white_noise(n, 1.0, seed);
    let shaped = match colour {
        NoiseColour::White => white,
        NoiseColour::Pink => {
            if n < 4 {
                white
            } else {
                let mut spec: Vec<Complex64> = fft::rfft(&white);
                spec[0] = Complex64::new(0.0, 0.0);
                for (k, c) in spec.iter_mut().enumerate().skip(1) {
                    *c /= (k as f64).sqrt();
                }
                fft::irfft(&spec, n)
            }
        }
    };
    let rms = crate::dsp::rms(&shaped);
    if rms > 0.0 {
        shaped.into_iter().map(|v| v * std / rms).collect()
    } else {
        shaped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::AntiAliasFilter;

    use crate::dsp::rms;

    #[test]
    fn the_antialias_filter_acts_and_a_record_it_cannot_filter_is_an_error() {
        let post = PostProcessing { antialias: Some(AntiAliasFilter { passband_hz: 100.0, stopband_hz: 200.0, stopband_db: 40.0 }), ..Default::default() };
        let fs_hz = 1000.0;
        let tone = |f: f64| -> Vec<f64> { (0..1000).map(|i| (TAU * f * i as f64 / fs_hz).sin()).collect() };
        let stop = post_process(&tone(400.0), fs_hz, &post, 1).unwrap();
        assert!((20.0 * (rms(&stop) / rms(&tone(400.0))).log10() + 40.0).abs() < 1e-6, "a stop-band tone falls 40 dB: {}", rms(&stop));
        let pass = post_process(&tone(50.0), fs_hz, &post, 1).unwrap();
        assert!((rms(&pass) / rms(&tone(50.0)) - 1.0).abs() < 1e-9);
        // Before, a record the filter could not take came back unfiltered without a word.
        let e = post_process(&[1.0], fs_hz, &post, 1).unwrap_err();
        assert!(matches!(e, ModelError::AntiAlias(_)) && e.to_string().contains("sensor.antialias") && e.to_string().contains('2'), "{e}");
    }
}
