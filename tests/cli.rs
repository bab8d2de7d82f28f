//! The command line: every bad input gives a one-line error naming the file or parameter, a
//! non-zero exit and no panic; good jobs write CSV and JSON.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_twinscope"))
}

fn cwru(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cwru").join(name)
}

struct Run {
    code: i32,
    stderr: String,
    stdout: String,
}

fn run(args: &[&str]) -> Run {
    let o = bin().args(args).output().expect("binary runs");
    Run { code: o.status.code().unwrap_or(-1), stderr: String::from_utf8_lossy(&o.stderr).into_owned(), stdout: String::from_utf8_lossy(&o.stdout).into_owned() }
}

/// Asserts a clean failure: non-zero exit, no panic, one error line that contains `needles`.
fn assert_clean_failure(r: &Run, needles: &[&str]) {
    assert_ne!(r.code, 0, "expected failure; stderr: {}", r.stderr);
    assert!(!r.stderr.contains("panicked"), "panic: {}", r.stderr);
    let err_lines: Vec<&str> = r.stderr.lines().filter(|l| l.contains("error")).collect();
    assert_eq!(err_lines.len(), 1, "one error line expected: {}", r.stderr);
    for n in needles {
        assert!(err_lines[0].contains(n), "`{n}` missing from: {}", err_lines[0]);
    }
}

fn write_job(dir: &Path, input: &Path, chain: &str) -> PathBuf {
    let job = format!(
        "[input]\npaths = [{:?}]\n[machine]\nbearing = \"6205\"\nshaft_speed_hz = 29.95\n[chain]\n{chain}\n[output]\ndir = \"out\"\n",
        input.display().to_string()
    );
    let p = dir.join("job.toml");
    std::fs::write(&p, job).unwrap();
    p
}

#[test]
fn info_lists_cwru_variables() {
    let r = run(&["info", cwru("105_de_inner_007_0hp_12k.mat").to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("X105_DE_time") && r.stdout.contains("12000"), "{}", r.stdout);
    assert!(r.stdout.contains("1797"), "shaft speed missing: {}", r.stdout);
}

#[test]
fn kinematics_prints_cwru_ratios() {
    let r = run(&["kinematics", "--bearing", "6205", "--rpm", "1797"]);
    assert_eq!(r.code, 0);
    assert!(r.stdout.contains("5.415") && r.stdout.contains("3.584"), "{}", r.stdout);
}

#[test]
fn bad_files_fail_cleanly() {
    let d = tempfile::tempdir().unwrap();
    let corrupt = d.path().join("corrupt.wav");
    std::fs::write(&corrupt, b"RIFF\x10\x00\x00\x00WAVEjunkjunkjunk").unwrap();
    assert_clean_failure(&run(&["info", corrupt.to_str().unwrap()]), &["corrupt.wav"]);

    let mat = std::fs::read(cwru("130_de_outer6_007_0hp_12k.mat")).unwrap();
    let trunc = d.path().join("trunc_12k.mat");
    std::fs::write(&trunc, &mat[..2000]).unwrap();
    let job = write_job(d.path(), &trunc, "preset = \"welch\"");
    assert_clean_failure(&run(&["--batch", job.to_str().unwrap(), "-q"]), &["trunc_12k.mat"]);

    let empty = d.path().join("empty.csv");
    std::fs::write(&empty, b"").unwrap();
    assert_clean_failure(&run(&["info", empty.to_str().unwrap()]), &["empty.csv"]);

    let text = d.path().join("text.csv");
    std::fs::write(&text, "time_s,x\n0,1\n0.001,abc\n").unwrap();
    assert_clean_failure(&run(&["info", text.to_str().unwrap()]), &["text.csv", "abc"]);

    let nan = d.path().join("nan.csv");
    std::fs::write(&nan, "time_s,x\n0,1\n0.001,NaN\n0.002,3\n").unwrap();
    let job = write_job(d.path(), &nan, "preset = \"welch\"");
    assert_clean_failure(&run(&["--batch", job.to_str().unwrap(), "-q"]), &["nan.csv"]);

    assert_clean_failure(&run(&["--batch", d.path().join("missing.toml").to_str().unwrap()]), &["missing.toml"]);
}

#[test]
fn bad_parameters_fail_cleanly() {
    let d = tempfile::tempdir().unwrap();
    let input = cwru("105_de_inner_007_0hp_12k.mat");
    // A band above Nyquist (fs = 12 kHz).
    let job = write_job(d.path(), &input, "[[chain.stage]]\nkind = \"bandpass\"\npass_band_hz = [5000.0, 7000.0]");
    assert_clean_failure(&run(&["--batch", job.to_str().unwrap(), "-q"]), &["105_de_inner", "bandpass"]);
    // An STSA interval longer than the record.
    let job = write_job(d.path(), &input, "[[chain.stage]]\nkind = \"stsa\"\nfault = 0.01");
    assert_clean_failure(&run(&["--batch", job.to_str().unwrap(), "-q"]), &["stsa", "fault_frequency_hz"]);
    // An unknown stage and an unknown parameter.
    let job = write_job(d.path(), &input, "[[chain.stage]]\nkind = \"wavelet\"");
    assert_clean_failure(&run(&["--batch", job.to_str().unwrap(), "-q"]), &["job.toml", "wavelet"]);
    let job = write_job(d.path(), &input, "[[chain.stage]]\nkind = \"welch\"\nnperseg = 4096\nwindw = \"hann\"");
    assert_clean_failure(&run(&["--batch", job.to_str().unwrap(), "-q"]), &["job.toml", "windw"]);
    // A job key that does not exist.
    std::fs::write(d.path().join("j2.toml"), "[input]\npaths = [\"x.wav\"]\nchanel = \"0\"\n[chain]\npreset = \"welch\"\n").unwrap();
    assert_clean_failure(&run(&["--batch", d.path().join("j2.toml").to_str().unwrap()]), &["j2.toml", "chanel"]);
}

#[test]
fn confusion_refuses_bad_hidden_effect_groups_before_any_work() {
    // An unknown effect, one named twice, one the preset cannot have, and zero rounds: each
    // refused at once, naming the group.
    assert_clean_failure(&run(&["confusion", "--hide", "load_zone+bogus", "--controls", "0"]), &["--hide load_zone+bogus", "bogus", "known:"]);
    assert_clean_failure(&run(&["confusion", "--hide", "slip+slip", "--controls", "0"]), &["slip+slip", "named twice"]);
    assert_clean_failure(&run(&["confusion", "--preset", "cwru_6205_inner", "--hide", "load_zone+gear_mesh", "--controls", "0"]), &["gear_mesh", "does not apply", "cwru_6205_inner"]);
    assert_clean_failure(&run(&["confusion", "--hide", "load_zone+slip", "--rounds", "0", "--controls", "0"]), &["--rounds"]);
}

/// `confusion --extra`: an effect put in the model and left out of the measurement, read by
/// the removal trials; the noise and an effect the preset cannot have are refused at once.
#[test]
fn confusion_extra_reads_an_effect_the_machine_lacks_and_refuses_what_is_no_part() {
    assert_clean_failure(&run(&["confusion", "--extra", "--effect", "noise"]), &["--extra --effect noise", "no part of a model"]);
    assert_clean_failure(&run(&["confusion", "--preset", "cwru_6205_inner", "--extra", "--effect", "gear_mesh"]), &["gear_mesh", "does not apply", "cwru_6205_inner"]);
    assert_clean_failure(&run(&["confusion", "--extra", "--hide", "load_zone+slip"]), &["--extra", "--hide"]);
    let d = tempfile::tempdir().unwrap();
    let json = d.path().join("extra.json");
    let out = run(&["confusion", "--preset", "cwru_6205_inner", "--extra", "--effect", "load_zone", "--seed", "7401", "--snr-db", "20", "--duration-s", "1", "--fit-duration-s", "0.8", "--json", json.to_str().unwrap()]);
    let stdout = &out.stdout;
    assert_eq!(out.code, 0, "{stdout}\n{}", out.stderr);
    let row = stdout.lines().find(|l| l.starts_with("| load_zone |")).unwrap_or_else(|| panic!("{stdout}"));
    assert!(row.contains("| load_zone: contradicted (") && row.contains("fault of de: needed"), "{row}");
    assert!(stdout.contains("the extra effect read contradicted: 1/1;"), "{stdout}");
    let cases: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(cases[0]["extra"], "load_zone");
    assert_eq!(cases[0]["removals"].as_array().map(|a| a.len()), Some(3), "the fault, the load zone, its contact nonlinearity alone: {cases}");
}

#[test]
fn diagnose_refuses_a_round_count_outside_1_to_20_before_any_work() {
    // Zero rounds used to run one silently; 21 or more is refused as a batch job does.
    let input = cwru("105_de_inner_007_0hp_12k.mat");
    for n in ["0", "21", "2.5", "two"] {
        assert_clean_failure(&run(&["diagnose", input.to_str().unwrap(), "--preset", "cwru_6205_inner", "--rounds", n]), &["--rounds", "1 to 20"]);
    }
    assert_clean_failure(&run(&["confusion", "--hide", "load_zone+slip", "--rounds", "21", "--controls", "0"]), &["--rounds", "1 to 20"]);
}

#[test]
fn confusion_refuses_a_bad_detection_sweep_before_any_work() {
    // A value the model refuses (with the model's own reason), a sweep over two effects or over
    // a switch, an SNR out of range or given with noise hidden: each refused at once.
    assert_clean_failure(&run(&["confusion", "--effect", "slip", "--value", "1", "--value", "30", "--controls", "0"]), &["--value 30", "slip", "[0, 20]"]);
    assert_clean_failure(&run(&["confusion", "--effect", "slip", "--effect", "unbalance", "--value", "2"]), &["exactly one --effect", "got 2"]);
    assert_clean_failure(&run(&["confusion", "--effect", "nonlinear_contact", "--value", "1"]), &["nonlinear_contact", "without a parameter"]);
    assert_clean_failure(&run(&["confusion", "--effect", "slip", "--snr-db", "100"]), &["--snr-db 100", "between"]);
    assert_clean_failure(&run(&["confusion", "--effect", "noise", "--value", "3", "--snr-db", "5"]), &["--snr-db", "noise", "--value"]);
    assert_clean_failure(&run(&["confusion", "--effect", "slip", "--fit-duration-s", "0.1"]), &["--fit-duration-s", "0.2 to 60 s"]);
    assert_clean_failure(&run(&["confusion", "--effect", "slip", "--floor-margin=-0.1"]), &["--floor-margin", "-0.1", "margin ≥ 0"]);
    assert_clean_failure(&run(&["diagnose", "nowhere.wav", "--floor-margin", "inf"]), &["--floor-margin", "inf", "finite"]);
    assert_clean_failure(&run(&["diagnose", "nowhere.wav", "--domain-weights", "1,0"]), &["--domain-weights", "three weights"]);
    assert_clean_failure(&run(&["confusion", "--effect", "slip", "--domain-weights", "1,x,0"]), &["--domain-weights", "psd weight `x`"]);
    assert_clean_failure(&run(&["confusion", "--effect", "slip", "--domain-weights", "0,0,0"]), &["--domain-weights", "not all zero"]);
    assert_clean_failure(&run(&["diagnose", "nowhere.wav", "--domain-weights=1,-0.5,0"]), &["--domain-weights", "non-negative"]);
}

#[test]
fn sample_jobs_run_and_write_csv_and_json() {
    let samples = Path::new(env!("CARGO_MANIFEST_DIR")).join("sample_data");
    let mut jobs: Vec<PathBuf> = std::fs::read_dir(&samples).unwrap().filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.extension().is_some_and(|e| e == "toml")).collect();
    jobs.sort();
    assert!(jobs.len() >= 3, "sample jobs: {jobs:?}");
    for job in jobs {
        let out = tempfile::tempdir().unwrap();
        let r = run(&["--batch", job.to_str().unwrap(), "--out", out.path().to_str().unwrap()]);
        assert_eq!(r.code, 0, "{}: {}", job.display(), r.stderr);
        let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
        let inputs = summary["inputs"].as_array().unwrap();
        assert!(!inputs.is_empty());
        for i in inputs {
            for o in i["outputs"].as_array().unwrap() {
                let csv = std::fs::read_to_string(o["path"].as_str().unwrap()).unwrap();
                let header = csv.lines().next().unwrap();
                assert!(header.starts_with("frequency_hz,") || header.starts_with("time_s,") || header.starts_with("alpha_hz,frequency_hz,") || header == "tap_index,coefficient", "{header}");
                assert!(csv.lines().count() > 10);
            }
        }
    }
}

#[test]
fn compare_refuses_signals_with_different_units() {
    let d = tempfile::tempdir().unwrap();
    // A CSV in volts against the CWRU record in g: refused, one line, no panic.
    let csv = d.path().join("volts.csv");
    let mut text = String::from("time_s,v\n");
    for i in 0..12000 {
        text.push_str(&format!("{},{}\n", i as f64 / 12000.0, (i as f64 * 0.1).sin()));
    }
    std::fs::write(&csv, text).unwrap();
    let r = run(&["compare", cwru("105_de_inner_007_0hp_12k.mat").to_str().unwrap(), csv.to_str().unwrap()]);
    assert_clean_failure(&r, &["units differ"]);
}

/// `--substeps N` replaces the machine's RK4 sub-steps: the preset's own count gives the
/// preset's signal to the byte, another count another signal; 0 and 257 are refused by
/// `simulate`, `diagnose` and `confusion` before any work, naming the field.
#[test]
fn substeps_override_the_machine_and_are_checked() {
    let d = tempfile::tempdir().unwrap();
    let sim = |name: &str, extra: &[&str]| {
        let out = d.path().join(name);
        let mut args = vec!["simulate", "--preset", "cwru_6205_inner", "--duration-s", "0.2", "-q", "-o", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let r = run(&args);
        assert_eq!(r.code, 0, "{}", r.stderr);
        std::fs::read(out).unwrap()
    };
    let own = twinscope::model::preset("cwru_6205_inner").unwrap().substeps.to_string();
    let default = sim("default.csv", &[]);
    assert_eq!(default, sim("own.csv", &["--substeps", &own]));
    assert_ne!(default, sim("coarse.csv", &["--substeps", "1"]));
    let out = d.path().join("x.csv");
    let measured = cwru("105_de_inner_007_0hp_12k.mat");
    for bad in ["0", "257"] {
        assert_clean_failure(&run(&["simulate", "--preset", "cwru_6205_inner", "-o", out.to_str().unwrap(), "--substeps", bad]), &["substeps"]);
        assert_clean_failure(&run(&["diagnose", measured.to_str().unwrap(), "--preset", "cwru_6205_inner", "--substeps", bad]), &["substeps"]);
        assert_clean_failure(&run(&["confusion", "--controls", "1", "--substeps", bad]), &["--substeps", "substeps"]);
    }
    assert!(!out.exists());
}

#[test]
fn polish_sweeps_out_of_range_are_refused_before_any_work() {
    let measured = cwru("105_de_inner_007_0hp_12k.mat");
    for bad in ["9", "-1", "x"] {
        let arg = format!("--polish-sweeps={bad}");
        assert_clean_failure(&run(&["diagnose", measured.to_str().unwrap(), "--preset", "cwru_6205_inner", &arg]), &["--polish-sweeps", bad]);
        assert_clean_failure(&run(&["confusion", "--controls", "1", &arg]), &["--polish-sweeps", bad]);
    }
}

/// `--refit` names effects the machine has on and whose parameters can be fitted; anything
/// else is refused before any work, naming the flag and the effect.
#[test]
fn refit_of_an_effect_the_machine_lacks_is_refused_before_any_work() {
    let measured = cwru("105_de_inner_007_0hp_12k.mat");
    let m = measured.to_str().unwrap();
    assert_clean_failure(&run(&["diagnose", m, "--preset", "cwru_6205_inner", "--refit", "load_zone"]), &["--refit", "load_zone", "does not have it on"]);
    assert_clean_failure(&run(&["diagnose", m, "--preset", "cwru_6205_inner", "--refit", "warp_drive"]), &["warp_drive"]);
    // The CWRU preset has the contact nonlinearity on: it has no parameter to fit.
    assert_clean_failure(&run(&["diagnose", m, "--preset", "cwru_6205_inner", "--refit", "nonlinear_contact"]), &["--refit", "nonlinear_contact", "no parameter"]);
    // A machine file naming such an effect among those a loop fitted: refused, naming the file.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("saved.toml");
    let mut saved = twinscope::model::preset("cwru_6205_inner").unwrap();
    saved.fitted_effects = vec![twinscope::model::EffectKind::NonlinearContact];
    std::fs::write(&file, saved.to_toml()).unwrap();
    assert_clean_failure(&run(&["diagnose", m, "--machine", file.to_str().unwrap()]), &["saved.toml", "fitted_effects", "nonlinear_contact", "no parameter"]);
}

/// The defaults of session 44 (one SCF normaliser, the polish of the baselines only) and of
/// session 48 (the second start for the top trials) are switched off by
/// `--scf-slice-normalisers`, `--polish-second-starts` and `--no-uncalibrated-start-top`; the
/// old flags that asked for them are still accepted, and asking for both ways at once is
/// refused by name.
#[test]
fn the_old_search_flags_are_accepted_and_contradictions_refused() {
    let measured = cwru("105_de_inner_007_0hp_12k.mat");
    let m = measured.to_str().unwrap();
    for (new, old) in [("--scf-slice-normalisers", "--scf-one-normaliser"), ("--polish-second-starts", "--no-polish-second-starts"), ("--no-uncalibrated-start-top", "--uncalibrated-start-top")] {
        assert_clean_failure(&run(&["diagnose", m, "--preset", "cwru_6205_inner", new, old]), &[new, old]);
        assert_clean_failure(&run(&["confusion", "--controls", "1", new, old]), &[new, old]);
        // Each alone parses: the run then fails on the preset, after the flags were read.
        for flag in [new, old] {
            assert_clean_failure(&run(&["diagnose", m, "--preset", "no_such_rig", flag]), &["no_such_rig"]);
        }
    }
}

#[test]
fn simulate_writes_a_signal_that_info_reads_back() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("sim.wav");
    let r = run(&["simulate", "--preset", "cwru_6205_inner", "--duration-s", "0.5", "-o", out.to_str().unwrap(), "-q"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let r = run(&["info", out.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("12000") && r.stdout.contains("29.95"), "{}", r.stdout);
    let r = run(&["simulate", "--preset", "no_such_rig", "-o", out.to_str().unwrap()]);
    assert_clean_failure(&r, &["no_such_rig"]);
}

/// CWRU's healthy record is sampled at 48 kHz, the 6205 model at 12 kHz: `compare` and
/// `diagnose` bring the record down to the model's rate, say so, and record it in the JSON.
#[test]
fn compare_and_diagnose_bring_a_faster_record_down_to_the_models_rate_and_say_so() {
    let d = tempfile::tempdir().unwrap();
    let json = d.path().join("cmp.json");
    let rec = cwru("097_normal_0hp_48k.mat");
    let r = run(&["compare", rec.to_str().unwrap(), "--preset", "cwru_6205_inner", "--band-hz", "1800,3000", "--json", json.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.contains("sampled at 48000 Hz, is compared at the model's 12000 Hz"), "{}", r.stderr);
    assert!(r.stdout.contains("compared at 12000 Hz (the measurement resampled from 48000 Hz)"), "{}", r.stdout);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let al = &v["comparison"]["alignment"];
    assert_eq!((al["fs_hz"].as_f64(), al["measured_resampled_from_hz"].as_f64(), al["resampled_from_hz"].as_f64()), (Some(12000.0), Some(48000.0), None), "{al}");
    let psd = v["comparison"]["domains"].as_array().unwrap().iter().find(|d| d["domain"] == "psd_db").unwrap();
    let top_hz = psd["frequency_hz"].as_array().unwrap().last().unwrap().as_f64().unwrap();
    assert!(top_hz <= 6000.0, "PSD compared up to {top_hz} Hz");
    let dj = d.path().join("diagnose.json");
    let r = run(&["diagnose", rec.to_str().unwrap(), "--preset", "cwru_6205_healthy", "--with", "noise", "--band-hz", "1800,3000", "--fit-duration-s", "0.5", "--removal-trials", "--json", dj.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.contains("sampled at 48000 Hz, is compared at the model's 12000 Hz"), "{}", r.stderr);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&dj).unwrap()).unwrap();
    assert_eq!(v["compared_at_hz"], serde_json::json!(12000.0));
    // The healthy preset's parts to take out are its load zone (with the contact nonlinearity
    // acting through it) and that nonlinearity alone (the noise is the record's): two removal
    // trials, printed with their readings and saved.
    assert!(r.stdout.contains("removal trials (last round") && r.stdout.contains("load_zone (with nonlinear_contact, which acts through it)") && r.stdout.contains("nonlinear_contact (alone, load_zone kept)"), "{}", r.stdout);
    let removals = v["diagnosis"]["removals"].as_array().expect("removals in the JSON");
    assert_eq!(removals.len(), 2, "{removals:?}");
    assert_eq!((&removals[0]["part"], &removals[1]["part"]), (&serde_json::json!({ "effect": "load_zone" }), &serde_json::json!({ "effect": "nonlinear_contact" })));
    assert!(removals.iter().all(|t| ["contradicted", "cannot_tell", "needed"].contains(&t["reading"].as_str().unwrap())));
}

#[test]
fn compare_with_a_preset_adds_the_scf_slice_at_its_fault_frequency() {
    let d = tempfile::tempdir().unwrap();
    let json = d.path().join("cmp.json");
    let rec = cwru("105_de_inner_007_0hp_12k.mat");
    let r = run(&["compare", rec.to_str().unwrap(), "--preset", "cwru_6205_inner", "--band-hz", "1800,3000", "--json", json.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    for domain in ["envelope", "psd_db", "scf_alpha_0", "scf_alpha_shaft", "scf_alpha_fault"] {
        assert!(r.stdout.contains(domain), "{domain} missing:\n{}", r.stdout);
    }
    // BPFI of the 6205 at the record's 1797 rpm: 5.4152 × 29.95 Hz = 162.2 Hz.
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let text = v.to_string();
    assert!(text.contains("α = 162.1") || text.contains("α = 162.2"), "no α = BPFI slice in the JSON");
    let r = run(&["compare", rec.to_str().unwrap(), "--preset", "cwru_6205_inner", "--fault-hz=-3"]);
    assert_clean_failure(&r, &["--fault-hz"]);
    // With the transfer-path correction the PSD error falls and the curve is printed and saved.
    let r = run(&["compare", rec.to_str().unwrap(), "--preset", "cwru_6205_inner", "--band-hz", "1800,3000", "--path-correction", "16", "--json", json.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("transfer-path correction applied to the simulation"), "{}", r.stdout);
    let corrected: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(corrected["comparison"]["path_correction"]["gain_db"].as_array().map(|a| a.len()), Some(16), "{}", corrected["comparison"]["path_correction"]);
    let psd_nrmse = |v: &serde_json::Value| v["comparison"]["domains"].as_array().unwrap().iter().find(|d| d["domain"] == "psd_db").unwrap()["metrics"]["nrmse_percent"].as_f64().unwrap();
    assert!(psd_nrmse(&corrected) < psd_nrmse(&v), "PSD NRMSE {:.2} % corrected, {:.2} % plain", psd_nrmse(&corrected), psd_nrmse(&v));
    let r = run(&["compare", rec.to_str().unwrap(), "--preset", "cwru_6205_inner", "--path-correction", "99"]);
    assert_clean_failure(&r, &["--path-correction"]);
}

#[test]
fn a_batch_job_closes_the_loop_and_keeps_every_round() {
    // The "measurement" is the CWRU inner-race model with a load zone; the job's model lacks
    // it. Round 1 must apply load_zone, and the history must show the error falling.
    let d = tempfile::tempdir().unwrap();
    let job = d.path().join("loop.toml");
    std::fs::write(
        &job,
        r#"
[input]
[[input.simulate]]
preset = "cwru_6205_inner"
with = ["load_zone", "noise"]
duration_s = 1.5
seed = 3

[chain]
preset = "welch"

[model_loop]
preset = "cwru_6205_inner"
with = ["noise"]
rounds = 2
candidates = ["load_zone", "slip"]
fit_duration_s = 0.6
band_hz = [1800.0, 3000.0]

[output]
dir = "out"
"#,
    )
    .unwrap();
    let r = run(&["--batch", job.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.path().join("out/summary.json")).unwrap()).unwrap();
    let l = &summary["inputs"][0]["model_loop"];
    let history = l["history"].as_array().expect("a loop history");
    assert_eq!(history[0]["applied"], "load_zone", "round 1: {}", history[0]["verdict"]);
    // The round records the load it applied (with the clearance that sets the zone's extent).
    assert_eq!(history[0]["applied_values"][0][0], "radial_load_n", "{}", history[0]);
    assert!(history[0]["applied_values"][0][1].as_f64().is_some_and(|v| v > 0.0), "{}", history[0]);
    assert!(history[0]["objective_scatter"].as_f64().is_some_and(|s| s > 0.0), "the round keeps its seed scatter: {}", history[0]);
    let nrmse: Vec<f64> = history.iter().map(|r| r["envelope_nrmse"].as_f64().unwrap()).collect();
    assert!(nrmse.len() == 2 && nrmse[1] < nrmse[0], "envelope NRMSE per round {nrmse:?}");
    let csv = std::fs::read_to_string(l["history_csv"].as_str().unwrap()).unwrap();
    assert!(csv.starts_with("round,effects_on,envelope_nrmse_percent,objective,floor_objective,objective_scatter,applied,applied_values,removed,pinned,unbent_when_stuck,verdict"), "{csv}");
    assert_eq!(csv.lines().count(), 1 + history.len());
    assert!(csv.lines().nth(1).is_some_and(|l| l.contains("load_zone,\"radial_load_n = ")), "{csv}");
    let final_machine = std::fs::read_to_string(l["final_machine"].as_str().unwrap()).unwrap();
    assert!(final_machine.contains("[effects.load_zone]"), "{final_machine}");
    // The final machine names what the loop fitted, for a loop going on from it.
    assert!(final_machine.contains("fitted_effects = [\"load_zone\"]"), "{final_machine}");
    assert_eq!(l["demodulation_band_hz"], serde_json::json!([1800.0, 3000.0]));
    assert_eq!(l["compared_at_hz"], serde_json::json!(12000.0));
    assert!(r.stderr.contains("model loop round 1"), "{}", r.stderr);
    // Each input's band from its kurtogram: one holding the machine's 2.6 kHz resonator.
    let text = std::fs::read_to_string(&job).unwrap().replacen("band_hz = [1800.0, 3000.0]", "band_from_kurtogram = true", 1).replacen("rounds = 2", "rounds = 1", 1);
    let jk = d.path().join("kurtogram.toml");
    std::fs::write(&jk, text).unwrap();
    let rk = run(&["--batch", jk.to_str().unwrap(), "--out", d.path().join("out_k").to_str().unwrap()]);
    assert_eq!(rk.code, 0, "{}", rk.stderr);
    let sk: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.path().join("out_k/summary.json")).unwrap()).unwrap();
    let band: Vec<f64> = sk["inputs"][0]["model_loop"]["demodulation_band_hz"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!(band[0] <= 2600.0 && 2600.0 <= band[1] && band[1] - band[0] >= 400.0, "{band:?}");

    // Bad loop settings fail before any work, naming the key.
    for (bad, needle) in [("[model_loop]\npreset = \"cwru_6205_inner\"", "[model_loop]\npreset = \"no_such_rig\""), ("candidates = [\"load_zone\", \"slip\"]", "candidates = [\"warp_drive\"]"), ("rounds = 2", "rounds = 0"), ("rounds = 2", "rounds = 2\npath_correction_bands = 99"), ("rounds = 2", "rounds = 2\nband_from_kurtogram = true")] {
        let text = std::fs::read_to_string(&job).unwrap().replacen(bad, needle, 1);
        let j2 = d.path().join("bad.toml");
        std::fs::write(&j2, text).unwrap();
        let r = run(&["--batch", j2.to_str().unwrap()]);
        assert_clean_failure(&r, &["model_loop"]);
    }
    // An effect to re-fit that the loop's machine does not have on.
    let text = std::fs::read_to_string(&job).unwrap().replacen("rounds = 2", "rounds = 2\nrefit = [\"load_zone\"]", 1);
    let j3 = d.path().join("bad_refit.toml");
    std::fs::write(&j3, text).unwrap();
    assert_clean_failure(&run(&["--batch", j3.to_str().unwrap()]), &["model_loop.refit", "load_zone", "does not have it on"]);
}

/// `kurtogram` ranks a record's most impulsive bands (CWRU 209: 4.9–5.6 kHz, above the presets'
/// resonance); `compare --band-from-kurtogram` demodulates in the most impulsive band that holds
/// a resonance of the model (2.25–3.75 kHz, 2.6 kHz), and without a band says that the default
/// 900–1800 Hz holds none; `--band-hz` and `--band-from-kurtogram` together are refused.
#[test]
fn the_kurtogram_names_the_band_and_compare_demodulates_in_it() {
    let measured = cwru("209_de_inner_021_0hp_12k.mat");
    let m = measured.to_str().unwrap();
    let k = run(&["kurtogram", m, "--top", "3"]);
    assert_eq!(k.code, 0, "{}", k.stderr);
    let first = k.stdout.lines().find(|l| l.trim_start().starts_with("1 ")).unwrap_or_default();
    assert!(first.contains("4875–5625"), "{}", k.stdout);
    assert_eq!(k.stdout.lines().filter(|l| l.trim_start().chars().next().is_some_and(|c| c.is_ascii_digit())).count(), 3, "{}", k.stdout);
    let c = run(&["compare", m, "--preset", "cwru_6205_inner_021", "--with", "noise", "--band-from-kurtogram"]);
    assert_eq!(c.code, 0, "{}", c.stderr);
    assert!(c.stderr.contains("demodulation band 2250–3750 Hz from the measurement's kurtogram") && c.stderr.contains("(2600 Hz)"), "{}", c.stderr);
    let plain = run(&["compare", m, "--preset", "cwru_6205_inner_021", "--with", "noise"]);
    assert!(plain.stderr.contains("900–1800 Hz holds none of the model's resonances (2600 Hz)"), "{}", plain.stderr);
    let both = run(&["compare", m, "--preset", "cwru_6205_inner_021", "--band-hz", "1800,3000", "--band-from-kurtogram"]);
    assert_ne!(both.code, 0);
    assert!(both.stderr.contains("--band-from-kurtogram") && both.stderr.contains("--band-hz"), "{}", both.stderr);
    assert_clean_failure(&run(&["kurtogram", m, "--min-band-width-hz", "9000"]), &["min_band_width_hz"]);
}

/// A batch loop on CWRU's healthy record (48 kHz) with the 12 kHz healthy machine compares at
/// the model's rate and records it.
#[test]
fn a_batch_loop_compares_a_faster_record_at_the_models_rate() {
    let d = tempfile::tempdir().unwrap();
    let job = d.path().join("healthy.toml");
    let text = format!(
        "[input]\npaths = [{:?}]\n[chain]\npreset = \"welch\"\n[model_loop]\npreset = \"cwru_6205_healthy\"\nwith = [\"noise\"]\nrounds = 1\ncandidates = [\"slip\"]\nfit_duration_s = 0.6\nband_hz = [1800.0, 3000.0]\nremoval_trials = true\n[output]\ndir = \"out\"\n",
        cwru("097_normal_0hp_48k.mat").display().to_string()
    );
    std::fs::write(&job, text).unwrap();
    let r = run(&["--batch", job.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.path().join("out/summary.json")).unwrap()).unwrap();
    let l = &summary["inputs"][0]["model_loop"];
    assert_eq!(l["compared_at_hz"], serde_json::json!(12000.0), "{l}");
    let saved: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(l["json"].as_str().unwrap()).unwrap()).unwrap();
    assert_eq!(saved["compared_at_hz"], serde_json::json!(12000.0));
    // `removal_trials = true`: the last diagnosis holds the load zone's removal trial.
    assert_eq!(saved["diagnosis"]["removals"][0]["part"], serde_json::json!({ "effect": "load_zone" }), "{}", saved["diagnosis"]);
}
