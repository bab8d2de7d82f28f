//! The bundled machine presets (`assets/machines/*.toml`, `model::PRESETS`).
//!
//! * every preset parses, validates, assembles and simulates (0.5 s), and round-trips
//!   through TOML;
//! * the presets' kinematics agree with the papers (belt and gear ratios, shaft speeds,
//!   resonances inside the envelope bands, casing modes below Nyquist);
//! * **kinematics check**: on each localised-fault preset (slip off) the envelope-spectrum
//!   fault line sits within 0.5 % of the catalogue's BPFO / BPFI / 2×BSF at the preset's
//!   shaft speed, and it is the strongest line among the fault families;
//! * the UNSW extended inner-race fault modulates the gear signal at the shaft rate and shows
//!   BPFI (paper: 71.2 Hz), against the same gearbox without the fault;
//! * the MFS gear mesh reaches the test-bearing sensor (GMF harmonics in the seed band vanish
//!   when `gear_mesh` is off);
//! * a broken preset is refused with an error naming the field.
//!
//! Run the kinematics lines with `--nocapture` to see the measured errors.

use twinscope::dsp::envelope::{envelope_spectrum, EnvelopeParams};
use twinscope::dsp::remez::{bandpass_zero_phase, BandpassSpec};
use twinscope::dsp::spectrum::{amplitude_spectrum, Spectrum, SpectrumParams};
use twinscope::kinematics::{lookup_bearing, GearPair};
use twinscope::model::{preset, simulate, EffectKind, FaultLocation, Machine, Model, ModelError, PRESETS};

/// Envelope spectrum (peak scaling, Hann, mean removed) of `x` band-passed to `band_hz` with
/// the seed's equiripple FIR (200 Hz transitions, 1 dB ripple, 60/80 dB), up to 500 Hz.
fn envelope_lines(x: &[f64], fs_hz: f64, band_hz: [f64; 2]) -> Spectrum {
    let spec = BandpassSpec { pass_band_hz: band_hz, ..Default::default() };
    let (y, _) = bandpass_zero_phase(x, fs_hz, &spec).expect("band-pass");
    envelope_spectrum(&y, fs_hz, &EnvelopeParams { band_hz: Some([0.0, 500.0]), ..Default::default() }).expect("envelope spectrum")
}

/// Every local maximum of `s` above 3 Hz, `(interpolated frequency Hz, value)`.
fn lines(s: &Spectrum) -> Vec<(f64, f64)> {
    let s = s.band(3.0, f64::MAX).expect("band");
    s.top_peaks(100_000, 0.0).expect("peaks")
}

/// The strongest line within `±rel · f` of `f`, if any.
fn strongest_near(lines: &[(f64, f64)], f: f64, rel: f64) -> Option<(f64, f64)> {
    lines.iter().copied().filter(|(g, _)| (g - f).abs() <= rel * f).max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Largest spectrum value (any bin, peak or not) within `±rel · f` of `f`.
fn max_near(s: &Spectrum, f: f64, rel: f64) -> f64 {
    s.frequency_hz.iter().zip(&s.values).filter(|(g, _)| (*g - f).abs() <= rel * f).map(|(_, v)| *v).fold(0.0, f64::max)
}

fn machine(name: &str, duration_s: f64) -> Machine {
    let mut m = preset(name).unwrap_or_else(|e| panic!("preset {name}: {e}"));
    m.duration_s = duration_s;
    m
}

#[test]
fn every_preset_parses_simulates_and_round_trips() {
    let mut names = Vec::new();
    for (name, text) in PRESETS {
        let m = Machine::from_toml(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!names.contains(&m.name), "{name}: machine name `{}` used twice", m.name);
        names.push(m.name.clone());
        // Serialising and re-reading gives the same machine (the loop edits presets this way).
        let again = Machine::from_toml(&m.to_toml(), name).unwrap_or_else(|e| panic!("{name} round trip: {e}"));
        assert_eq!(again, m, "{name}: TOML round trip changed the machine");
        // No preset has slip on: fault lines must sit exactly on the kinematic frequencies.
        assert!(!m.effects.is_on(EffectKind::Slip), "{name}: slip must be off in presets");

        let mut short = m.clone();
        short.duration_s = 0.5;
        let model = Model::build(&short).unwrap_or_else(|e| panic!("{name}: build: {e}"));
        assert!(model.system.n() >= 5, "{name}: {} DOFs", model.system.n());
        let s = simulate(&short).unwrap_or_else(|e| panic!("{name}: simulate: {e}"));
        assert_eq!(s.samples.len(), (0.5 * m.fs_hz).round() as usize, "{name}");
        assert_eq!(s.fs_hz, m.fs_hz);
        assert!(s.samples.iter().all(|v| v.is_finite()), "{name}: non-finite sample");
        let rms = (s.samples.iter().map(|v| v * v).sum::<f64>() / s.samples.len() as f64).sqrt();
        assert!(rms > 1e-6 && rms < 1e4, "{name}: rms {rms} {}", s.unit);
        let speeds = m.shaft_speeds_hz().unwrap();
        assert_eq!(s.meta.shaft_speed_hz, Some(speeds[0]), "{name}");
    }
}

#[test]
fn assets_directory_and_presets_list_agree() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/machines");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".toml"))
        .map(|f| f.trim_end_matches(".toml").to_string())
        .collect();
    files.sort();
    let mut listed: Vec<String> = PRESETS.iter().map(|p| p.0.to_string()).collect();
    listed.sort();
    assert_eq!(files, listed, "every assets/machines/*.toml must be in model::PRESETS and vice versa");
    for (name, text) in PRESETS {
        assert_eq!(std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap(), text, "{name}");
    }
}

/// MFS: belt 41.5/102 from the pulley diameters, bevel 18/27, 15 Hz, fs 16384 Hz for 10 s,
/// MB ER-12K, resonance in the seed band, loader on the load zone.
#[test]
fn mfs_presets_follow_the_rig() {
    for (name, loc) in [("mfs_outer", FaultLocation::Outer), ("mfs_inner", FaultLocation::Inner), ("mfs_ball", FaultLocation::Ball)] {
        let m = preset(name).unwrap();
        assert_eq!((m.fs_hz, m.duration_s), (16384.0, 10.0), "{name}");
        let speeds = m.shaft_speeds_hz().unwrap();
        let idx = |s: &str| m.shaft_index(s).unwrap();
        assert_eq!(speeds[idx("motor")], 15.0);
        let d_motor = m.shafts[idx("motor")].pulley_diameter_m.unwrap();
        let d_pinion = m.shafts[idx("pinion")].pulley_diameter_m.unwrap();
        assert_eq!((d_motor, d_pinion), (0.0415, 0.102), "{name}");
        let fp = speeds[idx("pinion")];
        assert!((fp - 15.0 * d_motor / d_pinion).abs() < 1e-12, "{name}: pinion {fp} Hz");
        let gp = &m.gear_pairs[0];
        assert_eq!((gp.pinion_teeth, gp.gear_teeth), (18, 27));
        let mesh = GearPair { pinion_teeth: 18, gear_teeth: 27 }.mesh_frequencies(fp).unwrap();
        assert!((speeds[idx("gear")] - mesh.gear_shaft_hz).abs() < 1e-9, "{name}");
        let b = &m.bearings[0];
        assert_eq!(b.catalogue.as_deref(), Some("MB ER-12K"));
        assert_eq!(b.fault.as_ref().map(|f| f.location), Some(loc), "{name}");
        assert!((900.0..1800.0).contains(&b.resonator_frequency_hz), "{name}: resonance outside the seed band");
        assert_eq!(m.sensor.dof, "test.resonator.y");
        let lz = m.effects.load_zone.as_ref().expect("load_zone on in MFS presets");
        assert!(lz.radial_load_n >= 5.0 * 9.81, "{name}: the 5 kg loader alone gives 49 N");
        for k in [EffectKind::NonlinearContact, EffectKind::GearMesh] {
            assert!(m.effects.is_on(k), "{name}: {} should be on", k.name());
        }
    }
}

/// CWRU: 1797 rpm, 12 kHz, SKF 6205 drive end, resonance in 1.8–3 kHz, load_zone OFF (the loop
/// starts without it), outer fault at 6 o'clock.
#[test]
fn cwru_presets_follow_the_data_center() {
    for (name, loc) in [("cwru_6205_inner", FaultLocation::Inner), ("cwru_6205_outer", FaultLocation::Outer), ("cwru_6205_ball", FaultLocation::Ball)] {
        let m = preset(name).unwrap();
        assert_eq!(m.fs_hz, 12000.0);
        assert!((m.shaft_speeds_hz().unwrap()[0] * 60.0 - 1797.0).abs() < 1e-9);
        let b = &m.bearings[0];
        assert_eq!(b.catalogue.as_deref(), Some("SKF 6205-2RS JEM"));
        let f = b.fault.as_ref().unwrap();
        assert_eq!(f.location, loc, "{name}");
        assert_eq!(f.position_deg, 0.0, "{name}: 6 o'clock / t = 0");
        assert!((f.length_m - 0.007 * 0.0254).abs() < 1e-6, "{name}: 0.007 in fault");
        assert!((1800.0..3000.0).contains(&b.resonator_frequency_hz));
        assert!(!m.effects.is_on(EffectKind::LoadZone), "{name}: load_zone must be off");
    }
}

/// The healthy CWRU preset is the inner-race one without its fault, at record 097's 1796 rpm,
/// with a load zone carrying the rotor's weight (without it the fault-free model is silent) and
/// without the 12 kHz recorder's roll-off (097 was recorded at 48 kHz).
#[test]
fn cwru_healthy_preset_is_the_drive_end_without_a_fault_and_with_its_load_zone() {
    let healthy = preset("cwru_6205_healthy").unwrap();
    let mut inner = preset("cwru_6205_inner").unwrap();
    assert!(healthy.bearings[0].fault.is_none());
    assert_eq!(healthy.effects.load_zone.as_ref().map(|lz| lz.radial_load_n), Some(2.0 * 9.8));
    assert!((healthy.shafts[0].speed_hz.unwrap() - 1796.0 / 60.0).abs() < 0.01);
    inner.bearings[0].fault = None;
    inner.shafts[0].speed_hz = healthy.shafts[0].speed_hz;
    inner.effects.load_zone = healthy.effects.load_zone.clone();
    inner.sensor.antialias = None;
    inner.name = healthy.name.clone();
    assert_eq!(inner, healthy);
    let rms = |m: &Machine| {
        let mut short = m.clone();
        short.duration_s = 0.5;
        let s = simulate(&short).unwrap();
        (s.samples.iter().map(|v| v * v).sum::<f64>() / s.samples.len() as f64).sqrt()
    };
    let mut silent = healthy.clone();
    silent.effects.load_zone = None;
    let (on, off) = (rms(&healthy), rms(&silent));
    assert!(on > 1e-3 && off < 1e-12, "rms {on:.3e} g with the load zone, {off:.3e} g without");
}

/// The `_021` presets (records 209, 234, 222) are their 0.007 in presets with the 0.021 in
/// (0.533 mm) fault and nothing else changed; over it the 7.94 mm ball drops 9.0 µm (1.0 µm
/// over 0.007 in).
#[test]
fn cwru_021_presets_differ_only_in_the_fault_size() {
    for name in ["cwru_6205_inner", "cwru_6205_outer", "cwru_6205_ball"] {
        let small = preset(name).unwrap();
        let mut large = preset(&format!("{name}_021")).unwrap();
        let f = large.bearings[0].fault.as_ref().unwrap();
        assert!((f.length_m - 0.021 * 0.0254).abs() < 1e-6, "{name}_021: 0.021 in fault");
        let drop_um = 1e6 * twinscope::compare::calibrate::fault_drop_limit_m(&large).unwrap();
        assert!((drop_um - 9.0).abs() < 0.1, "{name}_021: {drop_um} µm");
        large.bearings[0].fault.as_mut().unwrap().length_m = small.bearings[0].fault.as_ref().unwrap().length_m;
        large.name = small.name.clone();
        assert_eq!(large, small, "{name}_021");
    }
}

/// The CWRU presets carry the 12 kHz recorder's anti-alias roll-off (fitted by
/// `assets/machines/cwru_antialias.py` to the six 12k records, whose PSD falls 50–60 dB from
/// 5.4 to 6 kHz): with white measurement noise the simulated PSD falls by as much, and by
/// nothing without the filter. The filter acts on signal and noise alike.
#[test]
fn cwru_presets_roll_off_like_the_recorder() {
    use twinscope::dsp::welch::{welch_psd, WelchParams};
    let band_db = |x: &[f64], lo: f64, hi: f64| {
        let p = welch_psd(x, 12000.0, &WelchParams { nperseg: 4096, ..Default::default() }).unwrap();
        let v: Vec<f64> = p.frequency_hz.iter().zip(&p.values).filter(|(f, _)| (lo..=hi).contains(*f)).map(|(_, v)| 10.0 * v.log10()).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    for name in ["cwru_6205_inner", "cwru_6205_outer", "cwru_6205_ball"] {
        let mut m = machine(name, 1.0);
        m.effects.enable(EffectKind::Noise);
        let with = simulate(&m).unwrap().samples;
        let drop_with = band_db(&with, 5000.0, 5400.0) - band_db(&with, 5900.0, 6000.0);
        m.sensor.antialias = None;
        let without = simulate(&m).unwrap().samples;
        let drop_without = band_db(&without, 5000.0, 5400.0) - band_db(&without, 5900.0, 6000.0);
        println!("{name}: 5.0–5.4 kHz over 5.9–6.0 kHz: {drop_with:.1} dB with the filter, {drop_without:.1} dB without");
        assert!((40.0..60.0).contains(&drop_with), "{name}: {drop_with} dB");
        assert!(drop_without.abs() < 10.0, "{name}: {drop_without} dB");
    }
}

/// The CWRU presets' RK4 step (`substeps` per sample) is fine enough for the loop: in the
/// loop's own objective (band 1.8–3 kHz, one evaluation of `fit_duration_s`, noise on), the
/// preset scores against the same model integrated with four times the sub-steps, same
/// seed, under a fifth of what a second seed of the model scores against it (the floor the
/// loop judges every effect by). One sub-step per sample must fail that (or the check could
/// not tell a coarse step from a fine one). README "Speed".
#[test]
fn cwru_presets_integrate_finely_enough_for_the_loop() {
    use twinscope::compare::calibrate::{evaluate, objective};
    use twinscope::compare::{LoopOptions, Reference};
    let mut opts = LoopOptions::default();
    opts.compare.envelope_band_hz = [1800.0, 3000.0];
    for name in PRESETS.iter().map(|p| p.0).filter(|n| n.starts_with("cwru_")) {
        let mut m = machine(name, opts.fit_duration_s);
        m.effects.enable(EffectKind::Noise);
        let score = |m: &Machine, reference: &Reference| objective(&evaluate(m, reference, &opts).unwrap().0, &opts.weights);
        let mut fine = m.clone();
        fine.substeps = 4 * m.substeps;
        let reference = Reference::new(&simulate(&fine).unwrap(), &opts.compare).unwrap();
        let own = score(&m, &reference);
        let mut other_seed = m.clone();
        other_seed.seed ^= 0x5EED;
        let floor = score(&other_seed, &reference);
        let mut coarse = m.clone();
        coarse.substeps = 1;
        let coarse_own = score(&coarse, &reference);
        println!("{name}: {} sub-steps score {own:.3} against {}, {} score {coarse_own:.3}; a second seed {floor:.3}", m.substeps, fine.substeps, coarse.substeps);
        assert!(own < floor / 5.0, "{name}: {own} against the floor {floor}");
        assert!(coarse_own > floor / 5.0, "{name}: {coarse_own} against the floor {floor}");
    }
}

/// UNSW: 32:32 spur pair, module 3 mm, 20°, 10 Hz, Koyo 1205, 15 mm extended inner-race
/// fault, casing modes up to 4 kHz at 4 % below Nyquist, BPFI within 0.5 % of the paper's.
#[test]
fn unsw_preset_follows_the_paper() {
    let m = preset("unsw_extended_inner").unwrap();
    assert_eq!(m.shaft_speeds_hz().unwrap(), vec![10.0, 10.0]);
    let gp = &m.gear_pairs[0];
    assert_eq!((gp.pinion_teeth, gp.gear_teeth, gp.module_m, gp.pressure_angle_deg), (32, 32, 0.003, 20.0));
    assert!(m.bearings.iter().all(|b| b.catalogue.as_deref() == Some("Koyo 1205")));
    let e = m.effects.extended_fault.as_ref().expect("extended_fault on");
    assert_eq!((e.location, e.length_m), (FaultLocation::Inner, 0.015));
    let cm = m.effects.casing_modes.as_ref().expect("casing_modes on");
    assert!(cm.modes.len() >= 3);
    for md in &cm.modes {
        assert!(md.frequency_hz <= 4000.0 && md.damping_ratio == 0.04, "{md:?}");
        assert!(m.fs_hz > 2.0 * md.frequency_hz);
    }
    assert!(m.effects.is_on(EffectKind::GearMesh));
    let bpfi = lookup_bearing("Koyo 1205").unwrap().fault_frequencies(10.0).unwrap().bpfi_hz;
    assert!((bpfi - 71.2).abs() / 71.2 < 0.005, "BPFI {bpfi} Hz vs the paper's 71.2 Hz");
}

/// What the kinematics check measured on one preset.
struct FaultLine {
    expected_hz: f64,
    found_hz: f64,
    amplitude: f64,
    rival: (&'static str, f64),
}

/// Simulates `name` for `duration_s`, takes the envelope spectrum of `band_hz`, and finds the
/// strongest line within ±3 % of the expected fault frequency (BPFO, BPFI or 2×BSF from the
/// catalogue at the bearing's shaft speed). The ±3 % window holds the nearest shaft harmonic
/// on every preset (MFS: 45, 75 and 60 Hz are 1.7 %, 1.1 % and 0.4 % away), so a model that
/// rang at shaft orders instead of the fault frequency would be caught. Also returns the
/// strongest line within ±0.5 % of the two other fault families.
fn fault_line(name: &str, duration_s: f64, band_hz: [f64; 2]) -> FaultLine {
    let m = machine(name, duration_s);
    let b = &m.bearings[0];
    assert!(b.resonator_frequency_hz > band_hz[0] && b.resonator_frequency_hz < band_hz[1], "{name}: resonance outside {band_hz:?}");
    let shaft_hz = m.shaft_speeds_hz().unwrap()[m.shaft_index(&b.shaft).unwrap()];
    let ff = m.bearing_geometry(0).unwrap().fault_frequencies(shaft_hz).unwrap();
    let families = [("BPFO", ff.bpfo_hz, FaultLocation::Outer), ("BPFI", ff.bpfi_hz, FaultLocation::Inner), ("2xBSF", 2.0 * ff.bsf_hz, FaultLocation::Ball)];
    let loc = b.fault.as_ref().expect("a localised fault").location;
    let expected_hz = families.iter().find(|f| f.2 == loc).unwrap().1;

    let s = simulate(&m).unwrap();
    let es = envelope_lines(&s.samples, s.fs_hz, band_hz);
    // 0.5 % of the lowest line (MFS BPFO 45.8 Hz) is 0.23 Hz: the bins must be finer.
    assert!(es.resolution_hz() <= 0.5, "{name}: resolution {} Hz", es.resolution_hz());
    let ls = lines(&es);
    let (found_hz, amplitude) = strongest_near(&ls, expected_hz, 0.03).unwrap_or_else(|| panic!("{name}: no line near {expected_hz} Hz"));
    let rival = families
        .iter()
        .filter(|f| f.2 != loc)
        .map(|f| (f.0, strongest_near(&ls, f.1, 0.005).map_or(0.0, |p| p.1)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let err = 100.0 * (found_hz - expected_hz) / expected_hz;
    eprintln!("{name:16} expected {expected_hz:9.4} Hz  found {found_hz:9.4} Hz  error {err:+.3} %  line {amplitude:.4e}  strongest other family {} {:.3e}", rival.0, rival.1);
    FaultLine { expected_hz, found_hz, amplitude, rival }
}

fn assert_kinematics(name: &str, duration_s: f64, band_hz: [f64; 2]) {
    let l = fault_line(name, duration_s, band_hz);
    let rel = (l.found_hz - l.expected_hz).abs() / l.expected_hz;
    assert!(rel < 0.005, "{name}: envelope line at {:.4} Hz, expected {:.4} Hz ({:.3} % off)", l.found_hz, l.expected_hz, 100.0 * rel);
    assert!(l.amplitude > 2.0 * l.rival.1, "{name}: fault line {:.3e} not above the {} line {:.3e}", l.amplitude, l.rival.0, l.rival.1);
}

// MFS: the seed band 900–1800 Hz; 4 s gives 0.25 Hz bins (BPFI 74.22 Hz must stand apart from
// 5 × 15 Hz = 75 Hz, three bins away).
#[test]
fn mfs_outer_envelope_line_is_bpfo() {
    assert_kinematics("mfs_outer", 4.0, [900.0, 1800.0]);
}

#[test]
fn mfs_inner_envelope_line_is_bpfi() {
    assert_kinematics("mfs_inner", 4.0, [900.0, 1800.0]);
}

/// A ball spall strikes the outer and the inner race once per spin revolution: 2 × BSF.
#[test]
fn mfs_ball_envelope_line_is_twice_bsf() {
    assert_kinematics("mfs_ball", 4.0, [900.0, 1800.0]);
}

// CWRU: the 1.8–3 kHz band of the `envelope_cwru` chain; 2 s (0.5 Hz bins, 0.5 % of BPFO is
// 0.54 Hz).
#[test]
fn cwru_outer_envelope_line_is_bpfo() {
    assert_kinematics("cwru_6205_outer", 2.0, [1800.0, 3000.0]);
}

#[test]
fn cwru_inner_envelope_line_is_bpfi() {
    assert_kinematics("cwru_6205_inner", 2.0, [1800.0, 3000.0]);
}

#[test]
fn cwru_ball_envelope_line_is_twice_bsf() {
    assert_kinematics("cwru_6205_ball", 2.0, [1800.0, 3000.0]);
}

/// The extended fault is multiplicative (Sawalhi, Deshpande & Randall 2011): while it passes
/// the load zone the bearing's stiffness drops and the gear-mesh vibration reaching the sensor
/// is modulated at the shaft speed. The envelope of the band holding GMF × 1..5 (250–1700 Hz)
/// must show the shaft rate as its strongest line and a BPFI line (balls entering and leaving
/// the fault), both far above the same gearbox without the fault.
#[test]
fn unsw_extended_fault_modulates_the_gear_signal_at_shaft_rate() {
    let m = machine("unsw_extended_inner", 2.0);
    let mut healthy = m.clone();
    healthy.effects.disable(EffectKind::ExtendedFault);
    let shaft_hz = m.shaft_speeds_hz().unwrap()[0];
    let gmf = GearPair { pinion_teeth: 32, gear_teeth: 32 }.mesh_frequencies(shaft_hz).unwrap().gmf_hz;
    let band = [250.0, 1700.0];
    assert!(band[0] < gmf && 5.0 * gmf < band[1]);
    let bpfi = m.bearing_geometry(0).unwrap().fault_frequencies(shaft_hz).unwrap().bpfi_hz;

    let faulty = simulate(&m).unwrap();
    let good = simulate(&healthy).unwrap();
    let ef = envelope_lines(&faulty.samples, faulty.fs_hz, band);
    let eg = envelope_lines(&good.samples, good.fs_hz, band);
    let lf = lines(&ef.band(3.0, 200.0).unwrap());

    // The shaft rate is the strongest modulation below 200 Hz.
    let (f1, a1) = lf[0];
    eprintln!("unsw: strongest envelope line {f1:.4} Hz ({a1:.3e}); healthy at 10 Hz {:.3e}", max_near(&eg, shaft_hz, 0.005));
    assert!((f1 - shaft_hz).abs() / shaft_hz < 0.005, "strongest envelope line at {f1} Hz, expected the shaft rate {shaft_hz} Hz");
    assert!(a1 > 100.0 * max_near(&eg, shaft_hz, 0.005), "10 Hz modulation {a1:.3e} not ≫ healthy");
    // A BPFI line, the strongest within ±4 Hz (so not 7 × shaft = 70 Hz), within 0.5 % of the
    // catalogue's BPFI and of the paper's 71.2 Hz, far above the healthy gearbox.
    let (fb, ab) = strongest_near(&lf, bpfi, 4.0 / bpfi).expect("a line near BPFI");
    eprintln!("unsw: BPFI line {fb:.4} Hz ({ab:.3e}), catalogue {bpfi:.4} Hz, paper 71.2 Hz; healthy {:.3e}", max_near(&eg, bpfi, 0.005));
    assert!((fb - bpfi).abs() / bpfi < 0.005, "BPFI line at {fb} Hz, expected {bpfi} Hz");
    assert!((fb - 71.2).abs() / 71.2 < 0.005, "BPFI line at {fb} Hz, paper 71.2 Hz");
    assert!(ab > 20.0 * max_near(&eg, bpfi, 0.005), "BPFI line {ab:.3e} not ≫ healthy");
}

/// The MFS gear mesh reaches the test-bearing sensor through the bed-plate coupling: with the
/// bearing fault removed, the strongest GMF harmonic inside the seed band (900–1800 Hz) stands
/// ≥ 100× above the same machine with constant mesh stiffness (`gear_mesh` off).
#[test]
fn mfs_gear_mesh_reaches_the_sensor() {
    let mut m = machine("mfs_outer", 1.0);
    m.bearings[0].fault = None;
    let mut flat = m.clone();
    flat.effects.disable(EffectKind::GearMesh);
    let fp = m.shaft_speeds_hz().unwrap()[m.shaft_index("pinion").unwrap()];
    let gmf = GearPair { pinion_teeth: 18, gear_teeth: 27 }.mesh_frequencies(fp).unwrap().gmf_hz;
    let amp = |mm: &Machine| {
        let s = simulate(mm).unwrap();
        amplitude_spectrum(&s.samples, s.fs_hz, &SpectrumParams::default()).unwrap()
    };
    let (a, b) = (amp(&m), amp(&flat));
    let harmonics: Vec<f64> = (1..40).map(|k| k as f64 * gmf).filter(|f| (900.0..1800.0).contains(f)).collect();
    let (k_best, on) = harmonics.iter().map(|&f| (f, max_near(&a, f, 0.002))).max_by(|x, y| x.1.total_cmp(&y.1)).unwrap();
    let off = max_near(&b, k_best, 0.002);
    eprintln!("mfs gear: {:.1} Hz line {on:.3e} m/s^2 with gear_mesh, {off:.3e} without", k_best);
    assert!(on > 100.0 * off && on > 1e-3, "GMF harmonic {k_best} Hz: {on:.3e} with gear_mesh vs {off:.3e} without");
}

#[test]
fn broken_presets_are_refused_naming_the_field() {
    // Unknown preset: a parse error listing the presets.
    match preset("mfs_cage") {
        Err(ModelError::Parse { message, .. }) => {
            for (name, _) in PRESETS {
                assert!(message.contains(name), "{message}");
            }
        }
        other => panic!("{other:?}"),
    }
    let field_of = |m: &Machine| match m.validate() {
        Err(ModelError::InvalidField { field, .. }) => field,
        other => panic!("{other:?}"),
    };
    // A localised spall as long as the MB ER-12K ball spacing (π·33.5/8 = 13.2 mm).
    let mut m = preset("mfs_outer").unwrap();
    m.bearings[0].fault.as_mut().unwrap().length_m = 14e-3;
    assert_eq!(field_of(&m), "bearing[test].fault.length_m");
    // A ball spall longer than half the ball circumference (π·7.94/2 = 12.5 mm).
    let mut m = preset("mfs_ball").unwrap();
    m.bearings[0].fault.as_mut().unwrap().length_m = 12.6e-3;
    assert_eq!(field_of(&m), "bearing[test].fault.length_m");
    // A gear shaft speed that disagrees with 18/27.
    let mut m = preset("mfs_inner").unwrap();
    let g = m.shaft_index("gear").unwrap();
    m.shafts[g].driven_by.as_mut().unwrap().ratio = 0.7;
    assert_eq!(field_of(&m), "shaft[gear].speed_hz");
    // A casing mode above Nyquist.
    let mut m = preset("unsw_extended_inner").unwrap();
    m.effects.casing_modes.as_mut().unwrap().modes[0].frequency_hz = 12_000.0;
    assert_eq!(field_of(&m), "effects.casing_modes.modes[0].frequency_hz");
    // A resonance above Nyquist after lowering fs.
    let mut m = preset("cwru_6205_outer").unwrap();
    m.fs_hz = 5000.0;
    assert_eq!(field_of(&m), "bearing[de].resonator_frequency_hz");
    // The recorder's anti-alias filter: edges out of order, passband above Nyquist, no attenuation.
    for (edit, field) in [
        ((5425.0, 5000.0, 50.0), "sensor.antialias.stopband_hz"),
        ((6500.0, 7000.0, 50.0), "sensor.antialias.passband_hz"),
        ((5425.0, 6000.0, 0.0), "sensor.antialias.stopband_db"),
        ((f64::NAN, 6000.0, 50.0), "sensor.antialias.passband_hz"),
    ] {
        let mut m = preset("cwru_6205_inner").unwrap();
        let a = m.sensor.antialias.as_mut().unwrap();
        (a.passband_hz, a.stopband_hz, a.stopband_db) = edit;
        assert_eq!(field_of(&m), field, "{edit:?}");
        assert!(simulate(&m).is_err());
    }
    // None of these panicked, and the untouched presets still validate.
    for (name, _) in PRESETS {
        preset(name).unwrap().validate().unwrap();
    }
}
