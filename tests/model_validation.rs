//! Bad machine descriptions: each fails before any integration with an error naming the field
//! (or the DOF), never a panic; the CLI exits non-zero with one error line and writes no file.
//! Controls: the unmodified base machines pass the same path.

#[macro_use]
mod common;

use std::path::Path;
use std::process::Command;
use twinscope::model::{Machine, Model, ModelError, Simulator};

/// A copy of the CWRU inner-race preset as committed with the model (kept here so edits of the
/// bundled preset do not move these tests).
const CWRU: &str = concat!(
    r#"
name = "CWRU 6205 drive end, inner-race fault"
fs_hz = 12000.0
duration_s = 2.0
settle_s = 0.1
substeps = 8
seed = 1

[[shaft]]
name = "motor"
speed_hz = 29.95
mass_kg = 2.0
damping_n_s_per_m = 200.0

"#,
    cwru_de_bearing_toml!(),
    r#"
[bearing.fault]
location = "inner"
length_m = 0.178e-3
depth_m = 0.1e-3

[sensor]
dof = "de.resonator.y"
unit = "g"

[effects.nonlinear_contact]
"#
);

/// A valid two-shaft gearbox: 20:40 spur pair, one bearing per shaft.
const GEARBOX: &str = r#"
name = "gearbox"
fs_hz = 20000.0
duration_s = 0.1
settle_s = 0.0

[[shaft]]
name = "input"
speed_hz = 25.0
mass_kg = 3.0
inertia_kg_m2 = 0.002
torsional_stiffness_n_m_per_rad = 1e4

[[shaft]]
name = "output"
driven_by = { shaft = "input", ratio = 0.5 }
mass_kg = 4.0
inertia_kg_m2 = 0.01
torsional_stiffness_n_m_per_rad = 2e4

[[bearing]]
name = "b_in"
shaft = "input"
catalogue = "SKF 6205-2RS JEM"
pedestal_mass_kg = 5.0
pedestal_stiffness_n_per_m = 1.5e8
pedestal_damping_n_s_per_m = 3000.0
resonator_frequency_hz = 3000.0
resonator_damping_ratio = 0.04

[[bearing]]
name = "b_out"
shaft = "output"
catalogue = "SKF 6205-2RS JEM"
pedestal_mass_kg = 5.0
pedestal_stiffness_n_per_m = 1.5e8
pedestal_damping_n_s_per_m = 3000.0
resonator_frequency_hz = 3500.0
resonator_damping_ratio = 0.04

[[gear_pair]]
name = "stage1"
pinion_shaft = "input"
gear_shaft = "output"
pinion_teeth = 20
gear_teeth = 40
module_m = 0.003
face_width_m = 0.02
mean_mesh_stiffness_n_per_m = 2e8
mesh_damping_n_s_per_m = 500.0
transmitted_load_n = 1000.0

[sensor]
dof = "b_in.resonator.y"

[effects.gear_mesh]
"#;

/// Parses, validates, assembles and finds the static equilibrium (everything before the
/// integration).
fn prepare(text: &str) -> Result<(), ModelError> {
    let m = Machine::from_toml(text, "test.toml")?;
    let model = Model::build(&m)?;
    Simulator::new(&model).map(|_| ())
}

/// `base` with `from` replaced by `to` (which must occur).
fn edit(base: &str, from: &str, to: &str) -> String {
    assert!(base.contains(from), "`{from}` not in the base machine");
    base.replacen(from, to, 1)
}

enum Want {
    /// `InvalidField` with exactly this field.
    Invalid(&'static str),
    /// `UnknownReference` with exactly this field.
    Unknown(&'static str),
    /// `Parse` whose message contains this.
    Parse(&'static str),
    /// `NoEquilibrium` whose message names this DOF.
    Dof(&'static str),
}

fn expect(case: &str, text: &str, want: Want) {
    let r = std::panic::catch_unwind(|| prepare(text));
    let err = match r {
        Err(_) => panic!("{case}: panicked"),
        Ok(Ok(())) => panic!("{case}: accepted"),
        Ok(Err(e)) => e,
    };
    let msg = err.to_string();
    match (&want, &err) {
        (Want::Invalid(f), ModelError::InvalidField { field, .. }) => assert_eq!(field, f, "{case}: {msg}"),
        (Want::Unknown(f), ModelError::UnknownReference { field, .. }) => assert_eq!(field, f, "{case}: {msg}"),
        (Want::Parse(s), ModelError::Parse { message, .. }) => assert!(message.contains(s), "{case}: `{s}` not in {msg}"),
        (Want::Dof(d), ModelError::NoEquilibrium(m)) => assert!(m.contains(&format!("`{d}`")), "{case}: DOF `{d}` not named in {msg}"),
        _ => panic!("{case}: wrong error kind: {msg}"),
    }
    // Every message is one line and names the field or the DOF.
    assert!(!msg.contains('\n'), "{case}: multi-line message {msg}");
    let named = match want {
        Want::Invalid(f) | Want::Unknown(f) | Want::Dof(f) => f,
        Want::Parse(s) => s,
    };
    assert!(msg.contains(named), "{case}: `{named}` not in {msg}");
}

#[test]
fn base_machines_are_valid() {
    prepare(CWRU).unwrap();
    prepare(GEARBOX).unwrap();
    for (name, text) in twinscope::model::PRESETS {
        prepare(text).unwrap_or_else(|e| panic!("preset {name}: {e}"));
    }
}

#[test]
fn missing_fields_are_named() {
    expect("no sensor", &edit(CWRU, "[sensor]\ndof = \"de.resonator.y\"\nunit = \"g\"\n", ""), Want::Parse("missing field `sensor`"));
    expect("no mass_kg", &edit(CWRU, "mass_kg = 2.0", ""), Want::Parse("missing field `mass_kg`"));
    expect("no pedestal mass", &edit(CWRU, "pedestal_mass_kg = 5.0", ""), Want::Parse("missing field `pedestal_mass_kg`"));
    expect("no speed", &edit(CWRU, "speed_hz = 29.95", ""), Want::Invalid("shaft[motor].speed_hz"));
    expect("no catalogue nor geometry", &edit(CWRU, "catalogue = \"SKF 6205-2RS JEM\"", ""), Want::Invalid("bearing[de].catalogue"));
}

#[test]
fn negative_or_non_finite_masses_and_stiffnesses_are_rejected() {
    expect("negative shaft mass", &edit(CWRU, "mass_kg = 2.0", "mass_kg = -2.0"), Want::Invalid("shaft[motor].mass_kg"));
    expect("NaN shaft mass", &edit(CWRU, "mass_kg = 2.0", "mass_kg = nan"), Want::Invalid("shaft[motor].mass_kg"));
    expect("negative pedestal mass", &edit(CWRU, "pedestal_mass_kg = 5.0", "pedestal_mass_kg = -5.0"), Want::Invalid("bearing[de].pedestal_mass_kg"));
    expect("zero resonator mass", &edit(CWRU, "resonator_mass_kg = 0.05", "resonator_mass_kg = 0.0"), Want::Invalid("bearing[de].resonator_mass_kg"));
    expect("negative pedestal stiffness", &edit(CWRU, "pedestal_stiffness_n_per_m = 1.5e8", "pedestal_stiffness_n_per_m = -1.5e8"), Want::Invalid("bearing[de].pedestal_stiffness_n_per_m"));
    expect("infinite pedestal stiffness", &edit(CWRU, "pedestal_stiffness_n_per_m = 1.5e8", "pedestal_stiffness_n_per_m = inf"), Want::Invalid("bearing[de].pedestal_stiffness_n_per_m"));
    expect("negative Hertz constant", &edit(CWRU, "hertz_constant_n_per_m_n = 8.0e9", "hertz_constant_n_per_m_n = -8.0e9"), Want::Invalid("bearing[de].hertz_constant_n_per_m_n"));
    expect("negative damping", &edit(CWRU, "pedestal_damping_n_s_per_m = 3000.0", "pedestal_damping_n_s_per_m = -3000.0"), Want::Invalid("bearing[de].pedestal_damping_n_s_per_m"));
    let coupling = format!("{CWRU}\n[[coupling]]\na = \"motor.x\"\nstiffness_n_per_m = -1e6\n");
    expect("negative coupling stiffness", &coupling, Want::Invalid("coupling[0].stiffness_n_per_m"));
    expect("negative torsional stiffness", &edit(GEARBOX, "torsional_stiffness_n_m_per_rad = 1e4", "torsional_stiffness_n_m_per_rad = -1e4"), Want::Invalid("shaft[input].torsional_stiffness_n_m_per_rad"));
    expect("negative inertia", &edit(GEARBOX, "inertia_kg_m2 = 0.01", "inertia_kg_m2 = -0.01"), Want::Invalid("shaft[output].inertia_kg_m2"));
    expect("negative mesh stiffness", &edit(GEARBOX, "mean_mesh_stiffness_n_per_m = 2e8", "mean_mesh_stiffness_n_per_m = -2e8"), Want::Invalid("gear_pair[stage1].mean_mesh_stiffness_n_per_m"));
}

#[test]
fn impossible_geometry_and_faults_are_rejected() {
    let geometry = |d: f64| edit(CWRU, "catalogue = \"SKF 6205-2RS JEM\"", &format!("geometry = {{ name = \"custom\", rolling_elements = 9, ball_diameter_mm = {d}, pitch_diameter_mm = 39.04 }}"));
    prepare(&geometry(7.94)).unwrap(); // control: the 6205 written out
    for d in [39.04, 45.0] {
        expect("ball ≥ pitch diameter", &geometry(d), Want::Invalid("bearing[de].geometry"));
        let msg = prepare(&geometry(d)).unwrap_err().to_string();
        assert!(msg.contains("ball_diameter_mm") && msg.contains("pitch diameter"), "{msg}");
    }
    // Ball spacing of the 6205: π · 39.04 mm / 9 = 13.6 mm.
    expect("spall wider than the ball spacing", &edit(CWRU, "length_m = 0.178e-3", "length_m = 0.014"), Want::Invalid("bearing[de].fault.length_m"));
    expect("spall deeper than the ball radius", &edit(CWRU, "depth_m = 0.1e-3", "depth_m = 0.005"), Want::Invalid("bearing[de].fault.depth_m"));
    expect("negative spall length", &edit(CWRU, "length_m = 0.178e-3", "length_m = -0.178e-3"), Want::Invalid("bearing[de].fault.length_m"));
    expect("clearance beyond 1 mm", &edit(CWRU, "radial_clearance_m = 5e-6", "radial_clearance_m = 2e-3"), Want::Invalid("bearing[de].radial_clearance_m"));
    expect("load exponent", &edit(CWRU, "hertz_constant_n_per_m_n = 8.0e9", "hertz_constant_n_per_m_n = 8.0e9\nload_exponent = 3.0"), Want::Invalid("bearing[de].load_exponent"));
}

#[test]
fn sampling_rate_below_twice_the_highest_mode_is_rejected() {
    expect("resonator above Nyquist", &edit(CWRU, "resonator_frequency_hz = 2600.0", "resonator_frequency_hz = 6500.0"), Want::Invalid("bearing[de].resonator_frequency_hz"));
    expect("fs too low for the resonator", &edit(CWRU, "fs_hz = 12000.0", "fs_hz = 5000.0"), Want::Invalid("bearing[de].resonator_frequency_hz"));
    let casing = |f: f64| format!("{CWRU}\n[effects.casing_modes]\nmodes = [{{ frequency_hz = 4000.0, damping_ratio = 0.04, modal_mass_kg = 0.5, gain = 1.0 }}, {{ frequency_hz = {f}, damping_ratio = 0.04, modal_mass_kg = 0.5, gain = 1.0 }}]\n");
    prepare(&casing(5900.0)).unwrap();
    expect("casing mode above Nyquist", &casing(6000.0), Want::Invalid("effects.casing_modes.modes[1].frequency_hz"));
    let msg = prepare(&casing(7000.0)).unwrap_err().to_string();
    assert!(msg.contains("fs_hz") && msg.contains("twice"), "{msg}");
}

#[test]
fn unknown_references_are_named() {
    expect("bearing on an unknown shaft", &edit(CWRU, "shaft = \"motor\"", "shaft = \"rotor\""), Want::Unknown("bearing[de].shaft"));
    expect("unknown sensor DOF", &edit(CWRU, "dof = \"de.resonator.y\"", "dof = \"de.resonator.z\""), Want::Unknown("sensor.dof"));
    expect("unknown coupling DOF", &format!("{CWRU}\n[[coupling]]\na = \"motor.z\"\nstiffness_n_per_m = 1e6\n"), Want::Unknown("coupling[0].a"));
    expect("unknown coupling DOF b", &format!("{CWRU}\n[[coupling]]\na = \"motor.x\"\nb = \"nope.y\"\nstiffness_n_per_m = 1e6\n"), Want::Unknown("coupling[0].b"));
    expect("unknown casing attach DOF", &format!("{CWRU}\n[effects.casing_modes]\nattach_dof = \"housing.y\"\n"), Want::Unknown("effects.casing_modes.attach_dof"));
    expect("unknown catalogue bearing", &edit(CWRU, "catalogue = \"SKF 6205-2RS JEM\"", "catalogue = \"XYZ 9999\""), Want::Invalid("bearing[de].catalogue"));
    expect("unknown driving shaft", &edit(GEARBOX, "driven_by = { shaft = \"input\"", "driven_by = { shaft = \"motor\""), Want::Unknown("shaft[output].driven_by.shaft"));
    expect("unknown gear shaft", &edit(GEARBOX, "gear_shaft = \"output\"", "gear_shaft = \"spindle\""), Want::Unknown("gear_pair[stage1].gear_shaft"));
    expect("unknown extended-fault bearing", &format!("{CWRU}\n[effects.extended_fault]\nbearing = \"nde\"\n"), Want::Invalid("effects.extended_fault.bearing"));
}

#[test]
fn gear_ratio_must_match_the_teeth() {
    expect("driven_by ratio ≠ 20/40", &edit(GEARBOX, "ratio = 0.5", "ratio = 0.4"), Want::Invalid("shaft[output].speed_hz"));
    expect("speed_hz ≠ 25·20/40", &edit(GEARBOX, "driven_by = { shaft = \"input\", ratio = 0.5 }", "speed_hz = 13.0"), Want::Invalid("shaft[output].speed_hz"));
    prepare(&edit(GEARBOX, "driven_by = { shaft = \"input\", ratio = 0.5 }", "speed_hz = 12.5")).unwrap();
    expect("gear shaft without inertia", &edit(GEARBOX, "inertia_kg_m2 = 0.01\ntorsional_stiffness_n_m_per_rad = 2e4\n", ""), Want::Invalid("shaft[output].inertia_kg_m2"));
    expect("tooth out of range", &format!("{GEARBOX}\n[effects.tooth_fault]\ntooth = 20\n"), Want::Invalid("effects.tooth_fault.tooth"));
}

#[test]
fn unknown_parameters_and_effects_are_rejected() {
    expect("unknown effect parameter", &format!("{CWRU}\n[effects.load_zone]\nradial_load = 500.0\n"), Want::Parse("unknown field `radial_load`"));
    expect("unknown effect", &format!("{CWRU}\n[effects.spalling]\n"), Want::Parse("unknown field `spalling`"));
    expect("unknown machine field", &edit(CWRU, "seed = 1", "seed = 1\nsub_steps = 4"), Want::Parse("unknown field `sub_steps`"));
    expect("unknown bearing field", &edit(CWRU, "pedestal_mass_kg = 5.0", "pedestal_mass_kg = 5.0\npedestal_mass = 5.0"), Want::Parse("unknown field `pedestal_mass`"));
    expect("effect with nothing to act on", &format!("{CWRU}\n[effects.gear_mesh]\n"), Want::Invalid("effects.gear_mesh"));
    expect("bad slip percent", &format!("{CWRU}\n[effects.slip]\npercent = -1.0\n"), Want::Invalid("effects.slip.percent"));
    expect("zero substeps", &edit(CWRU, "substeps = 8", "substeps = 0"), Want::Invalid("substeps"));
    expect("negative fs", &edit(CWRU, "fs_hz = 12000.0", "fs_hz = -12000.0"), Want::Invalid("fs_hz"));
    expect("too short", &edit(CWRU, "duration_s = 2.0", "duration_s = 1e-4"), Want::Invalid("duration_s"));
    // What a saved loop fitted must be an effect the machine has on, and a known one.
    expect("fitted effect off", &edit(CWRU, "seed = 1", "seed = 1\nfitted_effects = [\"load_zone\"]"), Want::Invalid("fitted_effects"));
    expect("unknown fitted effect", &edit(CWRU, "seed = 1", "seed = 1\nfitted_effects = [\"warp_drive\"]"), Want::Parse("warp_drive"));
    prepare(&format!("{}\n[effects.load_zone]\n", edit(CWRU, "seed = 1", "seed = 1\nfitted_effects = [\"load_zone\"]"))).unwrap();
}

#[test]
fn a_shaft_without_support_names_its_dof() {
    let free = edit(CWRU, "[[bearing]]", "[[shaft]]\nname = \"idler\"\nspeed_hz = 10.0\nmass_kg = 1.0\n\n[[bearing]]");
    expect("shaft with no bearing", &free, Want::Dof("idler.x"));
    // Also when the free shaft carries a static load (a gear's transmitted torque on a shaft
    // that has no bearing): the unsupported DOF is named, not the residual.
    let free_gear = edit(GEARBOX, "[[bearing]]\nname = \"b_out\"\nshaft = \"output\"", "[[bearing]]\nname = \"b_out\"\nshaft = \"input\"");
    let err = prepare(&free_gear).unwrap_err().to_string();
    assert!(err.contains("output.x") || err.contains("output.y"), "{err}");
    // A coupling to ground supports it.
    prepare(&format!("{free}\n[[coupling]]\na = \"idler.x\"\nstiffness_n_per_m = 1e6\n[[coupling]]\na = \"idler.y\"\nstiffness_n_per_m = 1e6\n")).unwrap();
}

// ---- CLI ----

struct Run {
    code: i32,
    stderr: String,
}

fn simulate_cli(dir: &Path, machine_text: &str, extra: &[&str]) -> Run {
    let file = dir.join("bad.toml");
    std::fs::write(&file, machine_text).unwrap();
    let out = dir.join("x.wav");
    let o = Command::new(env!("CARGO_BIN_EXE_twinscope")).arg("simulate").arg(&file).arg("-o").arg(&out).args(extra).output().expect("binary runs");
    Run { code: o.status.code().unwrap_or(-1), stderr: String::from_utf8_lossy(&o.stderr).into_owned() }
}

/// Non-zero exit, no panic, exactly one error line containing every needle, nothing written
/// besides the machine file.
fn assert_clean_failure(dir: &Path, r: &Run, needles: &[&str]) {
    assert_ne!(r.code, 0, "expected failure; stderr: {}", r.stderr);
    assert!(!r.stderr.contains("panicked"), "panic: {}", r.stderr);
    let lines: Vec<&str> = r.stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line expected: {}", r.stderr);
    assert!(lines[0].contains("error"), "{}", lines[0]);
    for n in needles {
        assert!(lines[0].contains(n), "`{n}` missing from: {}", lines[0]);
    }
    let files: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(files, vec!["bad.toml".to_string()], "files written: {files:?}");
}

#[test]
fn cli_rejects_bad_machines_with_one_line_and_no_file() {
    let cases: [(String, &[&str]); 5] = [
        (edit(CWRU, "mass_kg = 2.0", "mass_kg = -2.0"), &["shaft[motor].mass_kg"]),
        (edit(CWRU, "[sensor]\ndof = \"de.resonator.y\"\nunit = \"g\"\n", ""), &["bad.toml", "missing field `sensor`"]),
        (edit(CWRU, "dof = \"de.resonator.y\"", "dof = \"de.resonator.z\""), &["sensor.dof", "de.resonator.z"]),
        (edit(CWRU, "resonator_frequency_hz = 2600.0", "resonator_frequency_hz = 6500.0"), &["bearing[de].resonator_frequency_hz"]),
        (edit(CWRU, "[[bearing]]", "[[shaft]]\nname = \"idler\"\nspeed_hz = 10.0\nmass_kg = 1.0\n\n[[bearing]]"), &["idler.x"]),
    ];
    for (text, needles) in cases.iter() {
        let dir = tempfile::tempdir().unwrap();
        let r = simulate_cli(dir.path(), text, &[]);
        assert_clean_failure(dir.path(), &r, needles);
    }
    let dir = tempfile::tempdir().unwrap();
    let r = simulate_cli(dir.path(), CWRU, &["--with", "spalling"]);
    assert_clean_failure(dir.path(), &r, &["spalling"]);
}

/// A diverging machine (pedestal mode ≈ 225 kHz, one RK4 step per 12 kHz sample): the CLI
/// exits non-zero with one line naming the divergence, its time and DOF, and writes nothing.
#[test]
fn cli_reports_divergence_with_one_line_and_no_file() {
    let text = edit(edit(CWRU, "substeps = 8", "substeps = 1").as_str(), "pedestal_stiffness_n_per_m = 1.5e8", "pedestal_stiffness_n_per_m = 1e13");
    let dir = tempfile::tempdir().unwrap();
    let r = simulate_cli(dir.path(), &text, &["--duration-s", "0.1"]);
    assert_clean_failure(dir.path(), &r, &["diverged", "t = ", "de.pedestal", "substeps"]);
}
