//! Physics checks of the lumped-parameter model (`twinscope::model`):
//!
//! 1. Linearised natural frequencies = eigenvalues of the assembled M and K: (a) a hand-built
//!    system with a real `BearingElement`, against an independent analytic assembly;
//!    (b) the CWRU preset without fault and damping: peaks of the free vibration after a kick
//!    sit at the computed frequencies.
//! 2. Static deflection under a radial load follows the Hertzian load distribution
//!    (Stribeck/Harris) and Stribeck's 4.37 for zero clearance.
//! 3. With damping off and a still cage, `T + V` is conserved; its drift shrinks ≥ 8× when the
//!    RK4 step is halved. The potential is checked as `−∂V/∂q = F`.
//! 4. Step convergence of the envelope spectrum on the CWRU inner-race preset.
//! 5. A diverging configuration stops with `ModelError::Diverged` naming time and DOF.

use std::f64::consts::TAU;
use twinscope::dsp::envelope::{envelope_spectrum, EnvelopeParams};
use twinscope::dsp::fft;
use twinscope::dsp::remez::{bandpass_zero_phase, BandpassSpec};
use twinscope::dsp::window::Window;
use twinscope::kinematics::lookup_bearing;
use twinscope::model::{self, BearingElement, ContactLaw, Effects, LoadZone, NonlinearContact, Machine, Model, ModelError, ShaftMotion, Simulator, StepResult, System};

/// The CWRU preset with the fault removed, every damping set to zero and only the Hertzian
/// contact among the effects.
fn undamped_healthy_cwru() -> Machine {
    let mut m = model::preset("cwru_6205_inner").unwrap();
    m.effects = Effects { nonlinear_contact: Some(NonlinearContact {}), ..Default::default() };
    m.bearings[0].fault = None;
    m.bearings[0].pedestal_damping_n_s_per_m = 0.0;
    m.bearings[0].resonator_damping_ratio = 0.0;
    m.shafts[0].damping_n_s_per_m = 0.0;
    m
}

/// A deterministic velocity kick of `n` DOFs, |v| ≤ `scale` m/s, every component non-zero.
fn kick(n: usize, scale: f64) -> Vec<f64> {
    (0..n).map(|i| scale * (0.25 + 0.75 * (2.399 * i as f64 + 1.0).sin().abs()) * if i % 3 == 1 { -1.0 } else { 1.0 }).collect()
}

fn dof(model: &Model, name: &str) -> usize {
    model.system.dof(name).unwrap_or_else(|| panic!("no DOF {name}: {:?}", model.system.dof_names))
}

/// Eigen-frequencies (Hz) of the 2-DOF chain ground –k1– m1 –k2– m2 (m2 free otherwise):
/// roots of `m1 m2 λ² − (m1 k2 + m2 (k1 + k2)) λ + k1 k2 = 0`, `λ = ω²`.
fn chain2_hz(m1: f64, m2: f64, k1: f64, k2: f64) -> [f64; 2] {
    let (a, b, c) = (m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2);
    let d = (b * b - 4.0 * a * c).sqrt();
    [((-b - d) / (2.0 * a)).sqrt() / TAU, ((-b + d) / (2.0 * a)).sqrt() / TAU]
}

/// Radial deflection δ_r (m) that carries `w` N on `z` balls at ψ_j = 2πj/z (ball 0 at the load
/// direction), `W = Σ_j K (δ_r cos ψ_j − c)^n cos ψ_j` over the loaded balls (Harris), by
/// bisection. Independent of the model code.
fn harris_deflection(w: f64, z: usize, k: f64, n: f64, c: f64) -> f64 {
    let load = |d: f64| harris_load(d, z, k, n, c);
    let (mut lo, mut hi) = (c.max(0.0), c.max(0.0) + 1e-3);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if load(mid) < w {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
}

fn harris_load(d: f64, z: usize, k: f64, n: f64, c: f64) -> f64 {
    (0..z)
        .map(|j| {
            let psi = TAU * j as f64 / z as f64;
            let delta = d * psi.cos() - c;
            if delta > 0.0 {
                k * delta.powf(n) * psi.cos()
            } else {
                0.0
            }
        })
        .sum()
}

/// 1 (a): a hand-built shaft–bearing–pedestal system: shaft (x, y) of mass m_s on a 9-ball
/// Hertzian bearing (still cage), pedestal (x, y) of mass m_p on springs k_p to ground, radial
/// load W on the shaft. Independent assembly: solve the Harris equilibrium δ_r by bisection,
/// contact stiffness k_xx = Σ n K δ_j^(n−1) sin²ψ_j, k_yy = Σ n K δ_j^(n−1) cos²ψ_j (k_xy = 0
/// by symmetry); x and y are then two 2-DOF chains ground–k_p–m_p–k_c–m_s with analytic roots.
/// `natural_frequencies_hz` must agree to 1e-6 relative.
#[test]
fn natural_frequencies_match_an_independent_assembly() {
    let (ms, mp, kp, w, kh, n, z, c) = (2.0, 5.0, 1.5e8, 500.0, 8.0e9, 1.5, 9usize, 2e-6);
    let mut sys = System::default();
    let sx = sys.add_dof("shaft.x", ms);
    let sy = sys.add_dof("shaft.y", ms);
    let px = sys.add_dof("ped.x", mp);
    let py = sys.add_dof("ped.y", mp);
    sys.add_spring(px, None, kp, 0.0);
    sys.add_spring(py, None, kp, 0.0);
    sys.static_force[sy] = -w;
    sys.elements.push(Box::new(BearingElement {
        name: "b".into(),
        shaft: (sx, sy),
        pedestal: (px, py),
        balls: z,
        ball_diameter_m: 7.94e-3,
        pitch_diameter_m: 39.04e-3,
        ratio: 7.94 / 39.04,
        clearance_m: c,
        law: ContactLaw::Hertz { k: kh, n },
        motion: ShaftMotion::constant(0.0),
        faults: vec![],
        slip: vec![],
        memo: Default::default(),
    }));
    let q = sys.static_equilibrium(0.0, &[0.0, -2e-5, 0.0, 0.0], 1e-9).unwrap();
    let dr = harris_deflection(w, z, kh, n, c);
    assert!(((q[py] - q[sy]) - dr).abs() < 1e-9 * dr, "δ_r {} vs Harris {dr}", q[py] - q[sy]);
    assert!((q[py] + w / kp).abs() < 1e-9 * w / kp, "pedestal deflection {} vs W/k_p", q[py]);

    let (mut kxx, mut kyy) = (0.0, 0.0);
    for j in 0..z {
        let psi = TAU * j as f64 / z as f64;
        let d = dr * psi.cos() - c;
        if d > 0.0 {
            let kj = n * kh * d.powf(n - 1.0);
            kxx += kj * psi.sin().powi(2);
            kyy += kj * psi.cos().powi(2);
        }
    }
    let mut want: Vec<f64> = [chain2_hz(mp, ms, kp, kxx), chain2_hz(mp, ms, kp, kyy)].concat();
    want.sort_by(f64::total_cmp);
    let got = sys.natural_frequencies_hz(0.0, &q);
    eprintln!("natural frequencies: model {got:.3?} Hz, analytic {want:.3?} Hz");
    assert_eq!(got.len(), 4);
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-6 * w, "model {g} Hz vs analytic {w} Hz");
    }
}

/// Local maxima of `s` above `floor`, refined by a parabola through log-amplitudes (bins).
fn peaks(s: &[f64], floor: f64) -> Vec<(f64, f64)> {
    (1..s.len() - 1)
        .filter(|&k| s[k] > floor && s[k] >= s[k - 1] && s[k] > s[k + 1])
        .map(|k| {
            let (a, b, c) = (s[k - 1].ln(), s[k].ln(), s[k + 1].ln());
            let den = a - 2.0 * b + c;
            let p = if den != 0.0 { 0.5 * (a - c) / den } else { 0.0 };
            (k as f64 + p, s[k])
        })
        .collect()
}

/// 1 (b): the CWRU preset without fault and damping (uniform preload, Hertzian contact): kick
/// every DOF from the static equilibrium with a small velocity, integrate the free vibration
/// (2^15 samples at 12 kHz, the preset's 4 sub-steps) and take the Hann spectrum of each DOF's
/// displacement.
/// Every computed natural frequency has a spectral peak within max(one bin, 1 %), and every
/// peak above 1 % of the largest lies at a computed frequency (no spurious mode).
#[test]
fn free_vibration_peaks_at_the_natural_frequencies() {
    let m = undamped_healthy_cwru();
    let model = Model::build(&m).unwrap();
    let mut sim = Simulator::new(&model).unwrap();
    let fn_hz = model.system.natural_frequencies_hz(0.0, &sim.q);
    sim.v = kick(sim.v.len(), 1.3e-4);
    let n = 1 << 15;
    let ndof = sim.q.len();
    let mut rec = vec![Vec::with_capacity(n); ndof];
    for _ in 0..n {
        for (r, q) in rec.iter_mut().zip(&sim.q) {
            r.push(*q);
        }
        assert!(matches!(sim.step(), StepResult::Sample(_)));
    }
    let w = Window::Hann.periodic(n);
    let bin_hz = m.fs_hz / n as f64;
    // Combined spectrum: the largest normalised amplitude over the DOFs at each bin.
    let mut combined = vec![0.0f64; n / 2 + 1];
    for r in &rec {
        let mean = r.iter().sum::<f64>() / n as f64;
        let x: Vec<f64> = r.iter().zip(&w).map(|(v, w)| (v - mean) * w).collect();
        let s: Vec<f64> = fft::rfft(&x).iter().map(|c| c.norm()).collect();
        let max = s.iter().cloned().fold(0.0, f64::max);
        combined.iter_mut().zip(&s).for_each(|(c, v)| *c = c.max(v / max));
    }
    let found = peaks(&combined, 1e-4);
    let mut worst = 0.0f64;
    for &f in &fn_hz {
        let tol = bin_hz.max(0.01 * f);
        let near = found.iter().map(|(k, _)| k * bin_hz).min_by(|a, b| (a - f).abs().total_cmp(&(b - f).abs())).unwrap();
        eprintln!("mode {f:9.3} Hz: spectral peak at {near:9.3} Hz ({:+.4} bins)", (near - f) / bin_hz);
        assert!((near - f).abs() <= tol, "computed {f} Hz, nearest peak {near} Hz");
        worst = worst.max((near - f).abs() / bin_hz);
    }
    for &(k, a) in found.iter().filter(|p| p.1 > 1e-2) {
        let fp = k * bin_hz;
        assert!(fn_hz.iter().any(|&f| (fp - f).abs() <= bin_hz.max(0.01 * f)), "peak at {fp} Hz (rel. amplitude {a:.3}) is no computed mode {fn_hz:?}");
    }
    eprintln!("worst frequency error {worst:.3} bins (bin {bin_hz:.3} Hz)");
}

/// 2: radial load W = 500 N (load_zone), Hertzian contact, still cage at t = 0 (ball 0 at the
/// load direction). The static shaft–pedestal deflection δ_r satisfies Harris' load
/// distribution `W = Σ_j K (δ_r cos ψ_j − c)^1.5 cos ψ_j` to 1e-6 relative for c = 0 and
/// c = 5 µm; for c = 0 it also follows Stribeck, `δ_r = (4.37 W / (Z K))^(2/3)`, within 1 %
/// (Stribeck's 4.37 is for many balls; Z = 9 gives 4.386 exactly).
#[test]
fn static_deflection_follows_the_hertzian_load_distribution() {
    let w = 500.0;
    for c in [0.0, 5e-6] {
        let mut m = undamped_healthy_cwru();
        m.effects.load_zone = Some(LoadZone { radial_load_n: w });
        m.bearings[0].radial_clearance_m = c;
        let model = Model::build(&m).unwrap();
        let sim = Simulator::new(&model).unwrap();
        let (sx, sy, px, py) = (dof(&model, "motor.x"), dof(&model, "motor.y"), dof(&model, "de.pedestal.x"), dof(&model, "de.pedestal.y"));
        let dr = sim.q[py] - sim.q[sy];
        let dx = sim.q[sx] - sim.q[px];
        let (k, z) = (m.bearings[0].hertz_constant_n_per_m_n, 9);
        assert!(dx.abs() < 1e-6 * dr, "lateral deflection {dx} m under a vertical load");
        let carried = harris_load(dr, z, k, 1.5, c);
        eprintln!("c = {c:e} m: δ_r = {dr:.6e} m, Σ K(δ_r cosψ − c)^1.5 cosψ = {carried:.9} N vs W = {w} N");
        assert!((carried - w).abs() < 1e-6 * w, "c = {c}: Harris sum {carried} N vs W = {w} N");
        // The pedestal carries the load into its support spring.
        let kp = m.bearings[0].pedestal_stiffness_n_per_m;
        assert!((sim.q[py] + w / kp).abs() < 1e-6 * w / kp);
        if c == 0.0 {
            let stribeck = (4.37 * w / (z as f64 * k)).powf(2.0 / 3.0);
            eprintln!("Stribeck δ_r = {stribeck:.6e} m ({:+.3} %)", (dr / stribeck - 1.0) * 100.0);
            assert!((dr / stribeck - 1.0).abs() < 0.01, "δ_r {dr} vs Stribeck {stribeck}");
        }
    }
}

/// The potential behind `System::potential_energy` is that of the forces: `−∂V/∂q = F(q, v=0)`
/// by central differences at a state near equilibrium, on the CWRU inner-race preset with the
/// load zone on (Hertzian balls over the spall, springs, static load), to 1e-5 of the largest
/// force.
#[test]
fn potential_energy_is_the_potential_of_the_forces() {
    let mut m = model::preset("cwru_6205_inner").unwrap();
    m.effects.load_zone = Some(LoadZone { radial_load_n: 500.0 });
    let model = Model::build(&m).unwrap();
    let sys = &model.system;
    let sim = Simulator::new(&model).unwrap();
    let n = sys.n();
    let mut q = sim.q.clone();
    for (i, x) in q.iter_mut().enumerate() {
        *x += 0.3e-6 * ((i as f64) * 1.7).sin();
    }
    // At a time when a ball is over the inner-race spall (it rotates with the shaft).
    for t in [0.0, 0.0123, 0.0371] {
        let mut f = vec![0.0; n];
        sys.forces(t, &q, &vec![0.0; n], &mut f);
        let fmax = f.iter().fold(0.0f64, |a, b| a.max(b.abs())).max(1.0);
        let h = 1e-10;
        for j in 0..n {
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[j] += h;
            qm[j] -= h;
            let g = -(sys.potential_energy(t, &qp).unwrap() - sys.potential_energy(t, &qm).unwrap()) / (2.0 * h);
            assert!((g - f[j]).abs() < 1e-5 * fmax, "t = {t}, DOF {}: −∂V/∂q = {g}, F = {}", sys.dof_names[j], f[j]);
        }
    }
}

/// Max |E(t) − E(0)| / (kick energy) over `steps` RK4 steps for the conservative setup.
fn energy_drift(substeps: usize, steps: usize) -> f64 {
    let mut m = undamped_healthy_cwru();
    m.effects.load_zone = Some(LoadZone { radial_load_n: 500.0 });
    m.bearings[0].radial_clearance_m = 0.0;
    // A still cage: the contact potential then has no explicit time dependence.
    m.shafts[0].speed_hz = Some(1e-12);
    m.substeps = substeps;
    let model = Model::build(&m).unwrap();
    let mut sim = Simulator::new(&model).unwrap();
    sim.v = kick(sim.v.len(), 4e-4);
    let e_kick = sim.kinetic_energy();
    let e0 = sim.mechanical_energy().unwrap();
    let mut drift = 0.0f64;
    for _ in 0..steps / substeps {
        assert!(matches!(sim.step(), StepResult::Sample(_)));
        drift = drift.max((sim.mechanical_energy().unwrap() - e0).abs());
    }
    drift / e_kick
}

/// 3: damping off, no fault, a still cage (shaft speed 1e-12 Hz), load zone with zero
/// clearance, Hertzian contact, kicked from equilibrium (small enough that no ball enters or
/// leaves contact). The relative energy drift over 1e5 RK4 steps (substeps 8 at 12 kHz, 1.04 s)
/// is below 5e-3 of the kick energy (it is RK4's numerical dissipation, mostly in the 2.6 kHz
/// resonator mode: per step `(ωh)⁶/72` ≈ 3e-7; as a damping ratio ≈ 1e-7, against the 4 % of
/// the real structure), and it shrinks by ≥ 8× (linear RK4 dissipation: 32×) when the step is
/// halved over the same simulated time.
#[test]
fn energy_is_conserved_without_damping() {
    let d8 = energy_drift(8, 100_000);
    let d16 = energy_drift(16, 200_000);
    eprintln!("energy drift over 1.04 s: substeps 8 → {d8:.3e}, substeps 16 → {d16:.3e} (ratio {:.1})", d8 / d16);
    assert!(d8 < 5e-3, "drift {d8}");
    assert!(d8 / d16 >= 8.0, "drift ratio {} (8: {d8:e}, 16: {d16:e})", d8 / d16);
}

/// The envelope spectrum (0–500 Hz) of the sensor band-passed to 1.8–3 kHz.
fn envelope_0_500(x: &[f64], fs_hz: f64) -> Vec<f64> {
    let spec = BandpassSpec { pass_band_hz: [1800.0, 3000.0], ..Default::default() };
    let (y, _) = bandpass_zero_phase(x, fs_hz, &spec).unwrap();
    envelope_spectrum(&y, fs_hz, &EnvelopeParams { band_hz: Some([0.0, 500.0]), ..Default::default() }).unwrap().values
}

fn rel_l2(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    (num / den).sqrt()
}

/// 4: the CWRU inner-race preset, 1 s, as bundled and with the load zone on (500 N): the
/// envelope spectrum (band 1.8–3 kHz, 0–500 Hz) changes by < 1 % (relative L2 over the
/// 0–500 Hz bins) when the RK4 step is halved (substeps 8 → 16), the BPFI line by < 1 %, and
/// halving again (16 → 32) changes it less.
#[test]
fn envelope_spectrum_converges_with_the_step() {
    let preset = model::preset("cwru_6205_inner").unwrap();
    let catalogue = preset.bearings[0].catalogue.clone().unwrap();
    let bpfi = lookup_bearing(&catalogue).unwrap().fault_frequencies(preset.shafts[0].speed_hz.unwrap()).unwrap().bpfi_hz;
    for load_zone in [false, true] {
        let mut spectra = Vec::new();
        for substeps in [8, 16, 32] {
            let mut m = model::preset("cwru_6205_inner").unwrap();
            m.duration_s = 1.0;
            m.substeps = substeps;
            if load_zone {
                m.effects.load_zone = Some(LoadZone { radial_load_n: 500.0 });
            }
            let t0 = std::time::Instant::now();
            let s = model::simulate(&m).unwrap();
            eprintln!("load zone {load_zone}, substeps {substeps}: simulated 1 s in {:.2} s", t0.elapsed().as_secs_f64());
            spectra.push(envelope_0_500(&s.samples, s.fs_hz));
        }
        let d = rel_l2(&spectra[0], &spectra[1]);
        let d2 = rel_l2(&spectra[1], &spectra[2]);
        // BPFI (6205 at 29.95 Hz: 162.19 Hz); 1 s record → 1 Hz bins.
        let line = |s: &[f64]| s[bpfi.round() as usize - 1..=bpfi.round() as usize + 1].iter().cloned().fold(0.0, f64::max);
        let (a, b) = (line(&spectra[0]), line(&spectra[1]));
        eprintln!(
            "load zone {load_zone}: envelope spectrum 0–500 Hz relative L2 change 8 → 16 substeps = {:.3} %, 16 → 32 = {:.3} %; BPFI line 8 → 16 {:+.4} %",
            d * 100.0,
            d2 * 100.0,
            (a / b - 1.0) * 100.0
        );
        assert!(d < 0.01, "load zone {load_zone}: relative L2 change {d}");
        assert!((a / b - 1.0).abs() < 0.01, "load zone {load_zone}: BPFI line {a} vs {b}");
        assert!(d2 < d, "load zone {load_zone}: 16 → 32 ({d2}) should change less than 8 → 16 ({d})");
    }
}

/// 5: a pedestal stiffness of 1e13 N/m (mode ≈ 225 kHz) with one RK4 step per sample at 12 kHz
/// is far beyond RK4's stability limit: `run` stops with `Diverged` naming a real DOF and a
/// time within the first 10 ms, and `Simulator::step` never returns a non-finite sample.
#[test]
fn divergence_is_reported_not_recorded() {
    let mut m = model::preset("cwru_6205_inner").unwrap();
    m.bearings[0].pedestal_stiffness_n_per_m = 1e13;
    m.substeps = 1;
    let model = Model::build(&m).unwrap();
    match model::run(&model, |_| true) {
        Err(ModelError::Diverged { t_s, dof, what }) => {
            eprintln!("diverged at t = {t_s:e} s in {dof}: {what}");
            assert!(t_s > 0.0 && t_s < 0.01, "t_s = {t_s}");
            assert!(model.system.dof(&dof).is_some(), "`{dof}` is not a DOF");
            let msg = ModelError::Diverged { t_s, dof: dof.clone(), what }.to_string();
            assert!(msg.contains(&dof) && msg.contains("t = "), "{msg}");
        }
        other => panic!("expected Diverged, got {:?}", other.map(|s| s.samples.len())),
    }
    let mut sim = Simulator::new(&model).unwrap();
    let mut samples = 0;
    loop {
        match sim.step() {
            StepResult::Sample(x) => {
                assert!(x.is_finite(), "non-finite sample after {samples}");
                samples += 1;
                assert!(samples < 1000, "did not diverge");
            }
            StepResult::Diverged { dof, .. } => {
                assert!(model.system.dof(&dof).is_some());
                break;
            }
        }
    }
    // The same machine with a step inside the stability limit runs (control).
    let mut ok = model::preset("cwru_6205_inner").unwrap();
    ok.duration_s = 0.05;
    ok.settle_s = 0.0;
    assert!(model::simulate(&ok).unwrap().samples.iter().all(|x| x.is_finite()));
}

/// 6: the equilibrium search crosses the bearing clearance when the static load points away
/// from where the assembly's guess puts the shaft. The MFS preset with a 6 N load zone (the
/// guess: shaft down, in contact) and 3 µm clearance, plus a 20 N belt-pass force whose value
/// at t = 0 lifts the shaft: between the races there is no stiffness and a constant force, so
/// the plain Levenberg–Marquardt step (accepted only if the force residual falls) stalls. Found
/// in the loop: the `belt_drive` trial after `load_zone` failed this way and was dropped.
/// The equilibrium must be found, the shaft must sit on the side the net load pushes it to,
/// beyond the clearance, and the residual must be below the search's 1e-6 N tolerance.
#[test]
fn static_equilibrium_crosses_the_clearance_against_the_guess() {
    let mut m = model::preset("mfs_inner").unwrap();
    m.effects.load_zone = Some(LoadZone { radial_load_n: 6.0 });
    m.bearings[0].radial_clearance_m = 3e-6;
    m.effects.belt_drive = Some(twinscope::model::BeltDrive { force_n: 20.0, ..Default::default() });
    let model = Model::build(&m).unwrap();
    let sys = &model.system;
    let n = sys.n();
    let (sy, py) = (dof(&model, "motor.y"), dof(&model, "test.pedestal.y"));
    // The net external load on the shaft at t = 0: at q = 0 every ball is inside the clearance.
    let mut f0 = vec![0.0; n];
    sys.forces(0.0, &vec![0.0; n], &vec![0.0; n], &mut f0);
    assert!(f0[sy] > 1.0, "the test needs a net upward load at t = 0, got {} N", f0[sy]);
    assert!(model.q_guess[sy] < 0.0, "the guess should put the shaft down, got {}", model.q_guess[sy]);
    let sim = Simulator::new(&model).unwrap_or_else(|e| panic!("{e}"));
    let mut f = vec![0.0; n];
    sys.forces(0.0, &sim.q, &vec![0.0; n], &mut f);
    let residual = f.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let dr = sim.q[sy] - sim.q[py];
    eprintln!("net load {:.2} N up; shaft − pedestal {dr:.3e} m; residual {residual:.2e} N", f0[sy]);
    assert!(residual <= 1e-6, "residual {residual} N");
    assert!(dr > 3e-6, "shaft {dr} m above the pedestal; the clearance is 3e-6 m");
}
