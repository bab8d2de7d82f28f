//! The desktop workbench driven without a display (egui_kittest, no GPU): the demo's envelope
//! spectrum, running the envelope chain on a file, the filter view, and bad input (a corrupt
//! file, a broken chain file) that shows an error while everything loaded stays.

use egui::accesskit::Role;
use egui_kittest::kittest::{NodeT, Queryable};
use egui_kittest::Harness;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use twinscope::gui::views::Command;
use twinscope::gui::{StartOptions, Workbench};

fn sample(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("sample_data").join(name)
}

fn harness(opts: StartOptions) -> Harness<'static, Workbench> {
    Harness::builder().with_size(egui::vec2(1280.0, 800.0)).build_ui_state(|ui, app: &mut Workbench| app.ui(ui), Workbench::new(opts))
}

/// Steps the app until `done` holds, at most `secs` seconds (the worker threads run meanwhile).
fn wait_for(h: &mut Harness<'static, Workbench>, what: &str, secs: u64, done: impl Fn(&Workbench) -> bool) {
    let t0 = Instant::now();
    loop {
        h.step();
        if done(h.state()) {
            break;
        }
        let msgs: Vec<String> = h.state().session.messages.iter().map(|m| m.text.clone()).collect();
        assert!(t0.elapsed() < Duration::from_secs(secs), "timed out after {secs} s waiting for {what}; messages: {msgs:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
    h.run_steps(4);
}

fn idle(h: &mut Harness<'static, Workbench>, what: &str, secs: u64) {
    wait_for(h, what, secs, |a| !a.worker.busy());
}

fn labels_containing(h: &Harness<'static, Workbench>, text: &str) -> Vec<String> {
    h.query_all_by_label_contains(text).map(|n| n.accesskit_node().label().or_else(|| n.accesskit_node().value()).unwrap_or_default()).collect()
}

/// `X.XX Hz` labels of the peak table's frequency column, as numbers.
fn hz_labels(h: &Harness<'static, Workbench>) -> Vec<f64> {
    h.query_all_by_label_contains(" Hz").filter_map(|n| n.accesskit_node().label().or_else(|| n.accesskit_node().value())).filter_map(|l| l.strip_suffix(" Hz").and_then(|x| x.parse::<f64>().ok())).collect()
}

/// First start: the demo runs the envelope chain on CWRU 105; the peak table labels the top
/// line BPFI near 162 Hz; the model is simulated and compared; the Compare tab shows metrics.
#[test]
fn demo_envelope_peak_is_bpfi_near_162_hz_and_model_is_compared() {
    let mut h = harness(StartOptions { demo: true, ..Default::default() });
    wait_for(&mut h, "the demo analysis", 120, |a| a.session.analysis.is_some());
    // the window shows progress while the demo simulates, or is done
    let bpfi = labels_containing(&h, "BPFI (");
    assert!(!bpfi.is_empty(), "no peak labelled BPFI in the peak table");
    let a = h.state().session.analysis.as_ref().unwrap();
    let top = &a.peaks[0];
    assert!(top.label().starts_with("BPFI ("), "top peak label {}", top.label());
    assert!((top.frequency_hz - 162.0).abs() < 1.5, "top peak at {} Hz", top.frequency_hz);
    assert!(bpfi.contains(&top.label()), "table shows {bpfi:?}, top peak {}", top.label());
    let shown = format!("{:.2}", top.frequency_hz).parse::<f64>().unwrap();
    assert!(hz_labels(&h).contains(&shown), "the table shows {shown} Hz");
    assert!(!labels_containing(&h, "Envelope spectrum — stage `envelope_spectrum` of chain `envelope_cwru`").is_empty());

    idle(&mut h, "the demo simulation and comparison", 300);
    let s = h.state();
    assert_eq!(s.session.signals.len(), 2, "measured + simulated");
    assert!(s.session.comparison.is_some(), "messages: {:?}", s.session.messages.iter().map(|m| &m.text).collect::<Vec<_>>());
    h.get_by_label("Compare").click();
    h.run_steps(4);
    assert!(h.query_by_label("Pearson r").is_some());
    assert!(h.query_by_label("Residual map").is_some());
    let env_nrmse = h.state().session.comparison.as_ref().unwrap().comparison.envelope_nrmse();
    assert!(!labels_containing(&h, &format!("{env_nrmse:.1} %")).is_empty(), "envelope NRMSE {env_nrmse:.1} % shown");
    // the filter view shows the designed bandpass and its spec
    h.get_by_label("Filter").click();
    h.run_steps(4);
    assert!(h.query_by_label("passband ripple").is_some());
    assert!(!labels_containing(&h, "1800–3000 Hz").is_empty());
}

/// Load a file by path, run the envelope chain: first without a bearing (the STSA fault needs
/// one: an error is shown, nothing is lost), then with the bearing chosen in the metadata
/// editor; the outer-race recording 130 shows a BPFO line.
#[test]
fn envelope_chain_runs_on_a_loaded_file() {
    let mut h = harness(StartOptions { files: vec![sample("130_de_outer6_007_0hp_12k.mat")], ..Default::default() });
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    idle(&mut h, "loading", 60);
    assert!(h.query_by_label("X130_DE_time").is_some(), "signal listed");
    assert!(h.query_by_label("12000 Hz").is_some(), "fs listed");
    h.get_by_label("Run chain").click();
    h.run_steps(2);
    idle(&mut h, "the chain", 60);
    let err = labels_containing(&h, "Error:");
    assert!(err.iter().any(|e| e.contains("needs a bearing")), "errors shown: {err:?}");
    assert!(h.state().session.analysis.is_none());
    assert_eq!(h.state().session.signals.len(), 1);

    // choose the bearing in the metadata editor and apply it
    h.get_all_by_role(Role::ComboBox).find(|n| n.value().as_deref() == Some("none")).expect("bearing combo box").click();
    h.run_steps(2);
    h.get_by_label("SKF 6205-2RS JEM").click();
    h.run_steps(2);
    h.get_by_label("Apply metadata").click();
    h.run_steps(2);
    assert_eq!(h.state().session.signals[0].signal.meta.bearing.as_deref(), Some("SKF 6205-2RS JEM"));
    h.get_by_label("Run chain").click();
    h.run_steps(2);
    wait_for(&mut h, "the chain", 60, |a| a.session.analysis.is_some());
    let bpfo = labels_containing(&h, "BPFO (");
    assert!(!bpfo.is_empty(), "peak table: {:?}", h.state().session.analysis.as_ref().unwrap().peaks);
    let a = h.state().session.analysis.as_ref().unwrap();
    assert_eq!(a.chain.name, "envelope_cwru");
    let p = a.peaks.iter().find(|p| p.label().starts_with("BPFO (")).unwrap();
    assert!((p.frequency_hz - 107.4).abs() < 1.5, "BPFO line at {} Hz", p.frequency_hz);
}

/// A corrupt file shows the loader's error in the UI; the loaded signal stays listed and
/// selected. A broken chain file shows its error and the chain stays as it was.
#[test]
fn corrupt_file_shows_error_and_keeps_loaded_signal() {
    let mut h = harness(StartOptions { files: vec![sample("105_de_inner_007_0hp_12k.mat")], ..Default::default() });
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    idle(&mut h, "loading", 60);
    assert!(h.query_by_label("X105_DE_time").is_some());

    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.mat");
    std::fs::write(&bad, b"MATLAB 5.0 MAT-file, this is not really one").unwrap();
    h.state_mut().execute(Command::OpenSignal(bad.clone()));
    h.run_steps(2);
    idle(&mut h, "the corrupt file", 60);
    let err = labels_containing(&h, "Error:");
    assert!(err.iter().any(|e| e.contains("broken.mat") && e.contains("MAT")), "errors shown: {err:?}");
    assert!(h.query_by_label("X105_DE_time").is_some(), "the loaded signal is still listed");
    assert_eq!(h.state().session.signals.len(), 1);
    assert_eq!(h.state().session.selected, Some(0));

    let stages = h.state().session.chain.stages.len();
    let bad_chain = dir.path().join("bad_chain.toml");
    std::fs::write(&bad_chain, "name = \"x\"\n[[stage]]\nkind = \"bandpass\"\npass_band_hz = \"wide\"\n").unwrap();
    h.state_mut().execute(Command::OpenChain(bad_chain));
    h.run_steps(3);
    let err = labels_containing(&h, "Error:");
    assert!(err.iter().any(|e| e.contains("bad_chain.toml") && e.contains("stage 1 `bandpass`") && e.contains("`pass_band_hz`: ") && e.contains("expected an array of length 2")), "errors shown: {err:?}");
    assert_eq!(h.state().session.chain.stages.len(), stages, "the chain is kept");

    // and the app still works: the chain runs on the kept signal
    h.state_mut().session.signals[0].signal.meta.bearing = Some("SKF 6205-2RS JEM".into());
    h.run_steps(2);
    h.get_by_label("Run chain").click();
    h.run_steps(2);
    wait_for(&mut h, "the chain", 60, |a| a.session.analysis.is_some());
    assert!(!labels_containing(&h, "BPFI (").is_empty());
}

/// The chain editor: add a stage, reorder it, remove it; a save/load round trip keeps it.
#[test]
fn chain_editor_adds_reorders_removes_and_round_trips() {
    let mut h = harness(StartOptions::default());
    h.run_steps(3);
    let n0 = h.state().session.chain.stages.len();
    assert_eq!(n0, 5, "envelope_cwru has 5 stages");
    h.get_by_label("Add stage").click();
    h.run_steps(3);
    let names: Vec<String> = h.state().session.chain.stages.iter().map(|s| s.name.clone()).collect();
    assert_eq!(names.len(), 6);
    assert_eq!(names[5], "normalise_2");
    assert!(h.query_by_label("6. normalise_2 (normalise)").is_some());
    // open its header and move it up
    h.get_by_label("6. normalise_2 (normalise)").click();
    h.run_steps(3);
    h.get_all_by_label("Up").last().unwrap().click();
    h.run_steps(3);
    assert_eq!(h.state().session.chain.stages[4].name, "normalise_2");
    assert!(h.query_by_label("5. normalise_2 (normalise)").is_some());
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("edited.toml");
    h.state_mut().execute(Command::SaveChain(p.clone()));
    h.state_mut().execute(Command::ChainPreset("welch".into()));
    h.run_steps(3);
    assert_eq!(h.state().session.chain.name, "welch");
    h.state_mut().execute(Command::OpenChain(p));
    h.run_steps(3);
    assert_eq!(h.state().session.chain.stages.len(), 6);
    assert_eq!(h.state().session.chain.stages[4].name, "normalise_2");
    h.get_by_label("5. normalise_2 (normalise)").click();
    h.run_steps(3);
    h.get_all_by_label("Remove").last().unwrap().click();
    h.run_steps(3);
    assert_eq!(h.state().session.chain.stages.len(), 5);
}

/// The SCF view computes the Fast-SC of the selected signal on a worker and draws the 3D
/// surface with its colour scale and axis labels: the scale's maximum is the largest |S| over
/// the shown α range (in dB, from the map itself), the α axis label names the range. The 2D
/// map and the α-slices (at BPFI) show too.
#[test]
fn scf_view_shows_surface_colour_scale_and_slices() {
    let mut h = harness(StartOptions { files: vec![sample("105_de_inner_007_0hp_12k.mat")], tab: Some("scf".into()), ..Default::default() });
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    wait_for(&mut h, "the SCF", 120, |a| a.session.scf.is_some());
    idle(&mut h, "the SCF job", 60);
    assert_eq!(h.state().active_tab(), 4);
    let r = h.state().session.scf.as_ref().unwrap();
    assert_eq!(r.signal_name, "X105_DE_time");
    // the largest |S| with 5 Hz ≤ α ≤ 500 Hz, straight from the map
    let nf = r.map.n_frequency();
    let mut max = 0.0f64;
    for (ia, a) in r.map.alpha_hz.iter().enumerate() {
        if (5.0..=500.0).contains(a) {
            for jf in 0..nf {
                max = max.max(r.map.scf[ia * nf + jf].norm());
            }
        }
    }
    // 3D surface, linear: the colour scale's maximum is that |S|, in g²/Hz, to its 3 digits
    let shown = labels_containing(&h, "max ");
    assert_eq!(shown.len(), 1, "{shown:?}");
    let v: f64 = shown[0].trim_start_matches("max ").trim_end_matches(" g²/Hz").parse().unwrap();
    assert!((v / max - 1.0).abs() < 0.01, "colour scale max {v} vs |S| max {max}");
    assert!(h.query_by_label("|S(α, f)| (g²/Hz)").is_some(), "colour scale title");
    let want = format!("max {:.1} dB", 10.0 * max.log10());
    let alpha = labels_containing(&h, "α (Hz): ");
    assert_eq!(alpha.len(), 1, "{alpha:?}");
    let (lo, hi) = alpha[0].trim_start_matches("α (Hz): ").split_once(" – ").map(|(a, b)| (a.parse::<f64>().unwrap(), b.parse::<f64>().unwrap())).unwrap();
    assert!((5.0..6.0).contains(&lo) && (490.0..=500.0).contains(&hi), "α range {lo}–{hi}");
    assert!(!labels_containing(&h, "f (Hz): 0 – 6000").is_empty(), "{:?}", labels_containing(&h, "f (Hz)"));

    h.get_by_label("2D map").click();
    h.run_steps(3);
    assert!(h.query_by_label(&want).is_some(), "the 2D map (dB) shows {want}: {:?}", labels_containing(&h, "max "));
    assert!(h.query_by_label("|S(α, f)| (dB re 1 g²/Hz)").is_some(), "colour scale title in dB");
    // with the bearing known, Compute SCF again: the α picks include the fault frequencies
    assert!(h.query_all_by_label_contains("BPFI ").next().is_none());
    h.state_mut().execute(Command::SetMetadata { index: 0, fs_hz: 12000.0, shaft_speed_hz: Some(1797.0 / 60.0), bearing: Some("SKF 6205-2RS JEM".into()) });
    h.get_by_label("Compute SCF").click();
    h.run_steps(2);
    wait_for(&mut h, "the SCF with fault lines", 120, |a| a.session.scf.as_ref().is_some_and(|r| r.families.iter().any(|f| f.label == "BPFI")));
    idle(&mut h, "the SCF job", 60);
    h.get_by_label("α-slices").click();
    h.run_steps(3);
    let bpfi = h.query_all_by_label_contains("BPFI ").next().expect("an α pick at BPFI").accesskit_node().label().unwrap_or_default();
    let a: f64 = bpfi.trim_start_matches("BPFI ").trim_end_matches(" Hz").parse().unwrap();
    assert!((a - 162.19).abs() < 0.5, "BPFI pick at {a} Hz");
    h.get_by_label(&bpfi).click();
    h.run_steps(3);
    assert!(!labels_containing(&h, "slice at the grid α nearest 162.").is_empty(), "{:?}", labels_containing(&h, "slice at"));
}

/// The workbench on the model view with CWRU 105 loaded and quick search settings (0.3 s fits,
/// 3 evaluations per parameter, one sweep, the given candidates).
fn model_loop_on_105(candidates: Vec<twinscope::model::EffectKind>) -> Harness<'static, Workbench> {
    let mut h = harness(StartOptions { files: vec![sample("105_de_inner_007_0hp_12k.mat")], tab: Some("model".into()), ..Default::default() });
    {
        let s = &mut h.state_mut().settings;
        s.loop_fit_duration_s = 0.3;
        s.loop_evaluations_per_parameter = 3;
        s.loop_sweeps = 1;
        s.loop_candidates = candidates;
    }
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    idle(&mut h, "loading", 60);
    h
}

/// Puts `diagnosis` in the model view as the result of a search made with `options` on the
/// first signal, from the view's machine as it is (started from and calibrated to it).
fn show_diagnosis(h: &mut Harness<'static, Workbench>, diagnosis: twinscope::compare::Diagnosis, options: twinscope::compare::LoopOptions) {
    let m = h.state().session.model.machine.clone();
    let measured = h.state().session.signals[0].signal.name.clone();
    h.state_mut().session.model.result = Some(twinscope::gui::session::LoopResult { measured, options, started_from: m.clone(), calibrated: m, diagnosis, added: vec![], seconds: 1.0, refitted: None });
}

/// The model loop with a fast search (0.3 s fits, 3 evaluations per parameter, one sweep, two
/// candidate effects): Find missing effect ranks both with before → after numbers and a
/// verdict; Add switches the ranked effect on with its fitted parameters, re-simulates and
/// re-compares, and the rounds chart gets its second point. The rounds export as CSV and SVG.
#[test]
fn model_loop_finds_ranks_and_adds_an_effect() {
    use twinscope::model::EffectKind;
    let mut h = model_loop_on_105(vec![EffectKind::LoadZone, EffectKind::Slip]);
    assert_eq!(h.state().session.model.preset, "cwru_6205_inner");
    assert!(h.query_by_label("Find missing effect").is_some());
    assert!(h.query_by_label("No rounds yet: Find missing effect starts round 1.").is_some());
    assert!(!h.state().session.model.machine.effects.is_on(EffectKind::LoadZone));
    h.get_by_label("Find missing effect").click();
    h.run_steps(2);
    assert!(h.state().worker.busy(), "the search runs on a worker");
    wait_for(&mut h, "the missing-effect search", 600, |a| a.session.model.result.is_some() || (!a.worker.busy() && a.session.last_error().is_some()));
    idle(&mut h, "the search", 60);
    let r = h.state().session.model.result.clone().expect("a ranking");
    assert_eq!(r.diagnosis.trials.len(), 2, "two candidates tried");
    let first = r.diagnosis.trials[0].clone();
    let label = format!("1. {}", first.effect.name());
    assert!(h.query_by_label(&label).is_some(), "ranked label {label}");
    assert!(h.query_by_label(&format!("{:.1} -> {:.1} %", first.envelope_nrmse_before, first.envelope_nrmse_after)).is_some(), "envelope NRMSE before → after shown");
    assert!(!labels_containing(&h, "Verdict: ").is_empty());
    // The band the search compared in, from the demo chain's bandpass stage.
    let [lo, hi] = r.options.compare.envelope_band_hz;
    assert!(!labels_containing(&h, &format!("demodulation band {lo:.0}–{hi:.0} Hz")).is_empty(), "band shown");
    // The preset has no noise: nothing random, a zero floor, and the view says what that means.
    assert_eq!(r.diagnosis.floor_objective, 0.0);
    assert!(!labels_containing(&h, "Note: the model has nothing random in it").is_empty(), "zero-floor note shown");
    assert_eq!(h.state().session.model.history.len(), 1);
    assert!(h.query_by_label("round 1").is_some());

    let add_label = format!("Add {}", first.effect.name());
    let add = h.get_by_label(&add_label);
    assert!(!add.accesskit_node().is_disabled(), "Add is enabled");
    add.click();
    h.run_steps(2);
    let m = &h.state().session.model;
    assert!(m.machine.effects.is_on(first.effect), "{} is on; messages {:?}; button at {:?}", first.effect.name(), h.state().session.messages.iter().map(|m| &m.text).collect::<Vec<_>>(), h.get_by_label(&add_label).rect());
    for (p, v) in first.parameter.iter().chain(first.extra_parameters.iter()) {
        assert_eq!(p.get(&m.machine), Some(*v), "{} set to its fitted value", p.name());
    }
    assert_eq!(m.history.len(), 2, "the rounds chart has 2 points");
    assert_eq!(m.history[0].applied, Some(first.effect));
    assert_eq!(m.history[1].envelope_nrmse, first.envelope_nrmse_after);
    assert!(h.query_by_label("round 2").is_some());
    assert!(h.state().worker.busy(), "re-simulating");
    wait_for(&mut h, "the new model simulated and compared", 300, |a| !a.worker.busy());
    let s = h.state();
    assert!(s.session.last_error().is_none(), "errors: {:?}", s.session.last_error());
    let sim = s.session.signals.iter().find(|e| e.signal.name.contains(first.effect.name())).expect("the new model is listed");
    assert!(sim.signal.name.starts_with("cwru_6205_inner model ("));
    let c = s.session.comparison.as_ref().expect("re-compared");
    assert_eq!(c.simulated, sim.signal.name);
    // the Add button is done, the others wait for a new search
    assert!(h.query_by_label(&format!("Add {}", r.diagnosis.trials[1].effect.name())).is_some());

    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rounds.csv");
    h.state_mut().execute(Command::ExportCsv(csv.clone()));
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "round,envelope NRMSE (%),\"objective (weighted NRMSE, %)\"");
    assert_eq!(lines.len(), 3);
    assert_eq!(lines[2].split(',').nth(1).unwrap().parse::<f64>().unwrap(), first.envelope_nrmse_after);
    let svg = dir.path().join("rounds.svg");
    h.state_mut().execute(Command::ExportSvg(svg.clone()));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains(">round</text>") && text.matches("<polyline").count() == 2);
}

/// A machine parameter out of range (resonance above Nyquist) shows the validation error in
/// the view; the machine keeps its last valid value.
#[test]
fn model_loop_refuses_an_invalid_parameter() {
    use twinscope::compare::Param;
    let mut h = harness(StartOptions { tab: Some("model".into()), ..Default::default() });
    h.run_steps(3);
    let before = Param::ResonanceHz.get(&h.state().session.model.machine).unwrap();
    // set 9000 Hz in the resonance editor (fs is 12 kHz)
    let spin = |h: &Harness<'static, Workbench>| h.get_all_by_role(Role::SpinButton).find(|n| n.accesskit_node().label().as_deref() == Some("resonance")).expect("resonance editor").value();
    assert_eq!(spin(&h).as_deref(), Some("2600 Hz"));
    h.get_all_by_role(Role::SpinButton).find(|n| n.accesskit_node().label().as_deref() == Some("resonance")).unwrap().set_value_accesskit(9000.0);
    h.run_steps(3);
    assert_eq!(spin(&h).as_deref(), Some("9000 Hz"), "the editor shows what was typed");
    let err = labels_containing(&h, "Error: ");
    assert!(err.iter().any(|e| e.contains("resonator_frequency_hz") && e.contains("Nyquist")), "errors: {err:?}");
    assert_eq!(Param::ResonanceHz.get(&h.state().session.model.machine), Some(before), "the machine keeps its valid resonance");
    assert!(h.get_by_label("Simulate").accesskit_node().is_disabled(), "Simulate waits for a valid machine");
    // back in range: taken
    h.get_all_by_role(Role::SpinButton).find(|n| n.accesskit_node().label().as_deref() == Some("resonance")).unwrap().set_value_accesskit(2800.0);
    h.run_steps(3);
    assert_eq!(Param::ResonanceHz.get(&h.state().session.model.machine), Some(2800.0));
    assert!(labels_containing(&h, "Error: ").is_empty());
}

/// The model loop's machine saved as TOML and opened again (what `diagnose --machine` reads and
/// `--save-machine` writes): the same machine back, a new start; a broken file, or one that
/// cannot be written, gives an error and keeps the machine.
#[test]
fn model_loop_saves_and_opens_a_machine_file() {
    use twinscope::compare::Param;
    let mut h = harness(StartOptions { tab: Some("model".into()), ..Default::default() });
    h.run_steps(3);
    assert!(h.query_by_label("Open machine…").is_some() && h.query_by_label("Save machine…").is_some());
    let mut edited = h.state().session.model.machine.clone();
    Param::ResonanceHz.set(&mut edited, 2750.0);
    h.state_mut().execute(Command::SetMachine(Box::new(edited.clone())));
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("edited_machine.toml");
    h.state_mut().execute(Command::SaveMachine(p.clone()));
    assert!(p.exists(), "messages: {:?}", h.state().session.messages.iter().map(|m| m.text.clone()).collect::<Vec<_>>());
    // The file is what the CLI reads.
    assert_eq!(twinscope::model::Machine::from_toml(&std::fs::read_to_string(&p).unwrap(), "saved").unwrap(), edited);
    h.state_mut().execute(Command::LoadMachinePreset("mfs_inner".into()));
    h.run_steps(3);
    assert_ne!(h.state().session.model.machine, edited);
    h.state_mut().execute(Command::OpenMachine(p.clone()));
    h.run_steps(3);
    assert_eq!(h.state().session.model.machine, edited);
    assert_eq!(h.state().session.model.preset, "edited_machine.toml");
    assert!(h.state().session.model.history.is_empty() && h.state().session.model.result.is_none());
    let shown: Vec<String> = h.query_all_by_label("machine preset").map(|n| format!("{:?}", n.accesskit_node().value())).collect();
    assert!(shown.iter().any(|v| v.contains("edited_machine.toml")), "the machine's file names it in the preset box: {shown:?}");
    // A broken file: an error naming it, the machine kept.
    let bad = dir.path().join("broken.toml");
    std::fs::write(&bad, "name = \"x\"\nfs_hz = -3\n").unwrap();
    h.state_mut().execute(Command::OpenMachine(bad));
    h.run_steps(3);
    assert_eq!(h.state().session.model.machine, edited);
    let last = h.state().session.messages.last().map(|m| m.text.clone()).unwrap_or_default();
    assert!(last.starts_with("machine not changed") && last.contains("broken.toml"), "{last}");
    // A path that cannot be written: an error, nothing lost.
    h.state_mut().execute(Command::SaveMachine(dir.path().join("no_such_dir").join("m.toml")));
    let last = h.state().session.messages.last().map(|m| m.text.clone()).unwrap_or_default();
    assert!(last.contains("cannot write"), "{last}");
    assert_eq!(h.state().session.model.machine, edited);
}

/// A machine opened from a file keeps the effects it has on; the calibration re-fits those the
/// user ticks "re-fit" for (as `diagnose --refit`), "Save machine…" names them in the file
/// (`fitted_effects`) and opening it ticks them again; an effect the machine lacks is refused.
#[test]
fn model_loop_re_fits_an_opened_machines_effect_when_ticked() {
    use twinscope::model::EffectKind::{GearMesh, LoadZone, Unbalance};
    let mut h = harness(StartOptions { tab: Some("model".into()), ..Default::default() });
    h.run_steps(3);
    let mut m = twinscope::model::preset("mfs_healthy").unwrap();
    m.effects.enable(Unbalance);
    m.effects.disable(LoadZone);
    m.effects.disable(GearMesh);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("go on.toml");
    std::fs::write(&p, m.to_toml()).unwrap();
    h.state_mut().execute(Command::OpenMachine(p));
    h.run_steps(3);
    let last = h.state().session.messages.last().map(|m| m.text.clone()).unwrap_or_default();
    assert!(last.contains("unbalance") && last.contains("re-fit"), "{last}");
    assert!(h.state().session.model.refit_effects().is_empty(), "nothing re-fitted until asked");
    // One box: the unbalance is the only effect on with a parameter (the contact nonlinearity has none).
    let boxes: Vec<_> = h.get_all_by_label("re-fit").collect();
    assert_eq!(boxes.len(), 1);
    boxes[0].click();
    h.run_steps(3);
    assert_eq!(h.state().session.model.refit_given, vec![Unbalance]);
    assert_eq!(h.state().session.model.refit_effects(), vec![Unbalance]);
    // Saved, the file names it as fitted; opened again, its box is ticked from the file.
    let saved = dir.path().join("go on 2.toml");
    h.state_mut().execute(Command::SaveMachine(saved.clone()));
    let text = std::fs::read_to_string(&saved).unwrap();
    assert!(text.contains("fitted_effects = [\"unbalance\"]"), "{text}");
    h.state_mut().execute(Command::LoadMachinePreset("mfs_inner".into()));
    h.state_mut().execute(Command::OpenMachine(saved));
    h.run_steps(3);
    let last = h.state().session.messages.last().map(|m| m.text.clone()).unwrap_or_default();
    assert!(last.contains("fitted_effects (unbalance) are ticked"), "{last}");
    assert_eq!(h.state().session.model.refit_effects(), vec![Unbalance]);
    assert!(h.state().session.model.machine.fitted_effects.is_empty(), "the box, not the machine, says what is re-fitted");
    h.get_by_label("re-fit").click();
    h.run_steps(3);
    assert!(h.state().session.model.refit_effects().is_empty());
    // An effect the machine does not have on: refused, with the reason.
    h.state_mut().execute(Command::SetRefit { effect: LoadZone, refit: true });
    let last = h.state().session.messages.last().map(|m| m.text.clone()).unwrap_or_default();
    assert!(last.contains("not re-fitted") && last.contains("load_zone"), "{last}");
    assert!(h.state().session.model.refit_given.is_empty());
}

/// A session saved with a loaded file, a metadata edit, another chain and another machine
/// reopens with the same file and channel, metadata, chain, machine and rounds.
#[test]
fn session_round_trips() {
    let mut h = harness(StartOptions { files: vec![sample("130_de_outer6_007_0hp_12k.mat")], ..Default::default() });
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    idle(&mut h, "loading", 60);
    h.state_mut().execute(Command::LoadChannel { index: 0, channel: "X130_FE_time".into() });
    h.run_steps(2);
    idle(&mut h, "the FE channel", 60);
    h.state_mut().execute(Command::SetMetadata { index: 0, fs_hz: 12000.0, shaft_speed_hz: Some(29.5), bearing: Some("SKF 6205-2RS JEM".into()) });
    h.state_mut().execute(Command::ChainPreset("welch".into()));
    h.state_mut().execute(Command::LoadMachinePreset("cwru_6205_outer".into()));
    h.state_mut().session.model.history.push(twinscope::compare::Round { round: 1, effects_on: vec![], domains: vec![], envelope_nrmse: 42.5, objective: 61.25, floor_objective: 3.5, verdict: "v".into(), ..Default::default() });
    h.run_steps(2);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.twinscope.json");
    h.state_mut().execute(Command::SaveSession(p.clone()));
    assert!(h.state().session.last_error().is_none(), "{:?}", h.state().session.last_error());
    let saved = twinscope::gui::session_file::SessionFile::load(&p).unwrap();
    assert_eq!(saved.signals.len(), 1);
    assert_eq!(saved.signals[0].channel.as_deref(), Some("X130_FE_time"));

    let mut g = harness(StartOptions::default());
    g.run_steps(2);
    // A start of an earlier history does not outlive it: the reopened history has none.
    let earlier = g.state().session.model.machine.clone();
    g.state_mut().session.model.loop_start = Some(earlier);
    g.state_mut().execute(Command::OpenSession(p));
    wait_for(&mut g, "the session's signals", 60, |a| !a.session.signals.is_empty() && !a.worker.busy());
    let (a, b) = (&g.state().session, &h.state().session);
    assert_eq!(a.signals.len(), 1);
    let (sa, sb) = (&a.signals[0].signal, &b.signals[0].signal);
    assert_eq!(sa.name, "X130_FE_time");
    assert_eq!(sa.samples, sb.samples);
    assert_eq!((sa.fs_hz, sa.meta.shaft_speed_hz, sa.meta.bearing.as_deref()), (12000.0, Some(29.5), Some("SKF 6205-2RS JEM")));
    assert_eq!(a.signals[0].file, b.signals[0].file);
    assert_eq!(a.chain, b.chain);
    assert_eq!(a.model.preset, "cwru_6205_outer");
    assert_eq!(a.model.machine, b.model.machine);
    assert_eq!(a.model.history, b.model.history);
    assert!(a.model.loop_start.is_none(), "a re-fit by hand after reopening starts from the preset");
    assert!(g.query_by_label("X130_FE_time").is_some());
    // a broken session file shows an error and keeps what is loaded
    let bad = dir.path().join("bad.twinscope.json");
    std::fs::write(&bad, "{\"format\": \"twinscope session 1\", \"signals\": 3}").unwrap();
    g.state_mut().execute(Command::OpenSession(bad));
    idle(&mut g, "the bad session", 30);
    let err = labels_containing(&g, "Error:");
    assert!(err.iter().any(|e| e.contains("bad.twinscope.json") && e.contains("not a twinscope session")), "{err:?}");
    assert_eq!(g.state().session.signals.len(), 1);
}

/// Find missing effect reports its progress in model evaluations and stops on Cancel: the
/// job ends as cancelled, no ranking or round is recorded, and the app goes on.
#[test]
fn model_loop_search_shows_progress_and_cancels() {
    let mut h = harness(StartOptions { files: vec![sample("105_de_inner_007_0hp_12k.mat")], tab: Some("model".into()), ..Default::default() });
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    idle(&mut h, "loading", 60);
    // the default (full) search: every missing effect, 1.5 s fits
    h.get_by_label("Find missing effect").click();
    h.run_steps(2);
    wait_for(&mut h, "the first model evaluations", 120, |a| a.worker.jobs().first().and_then(|j| j.progress()).is_some_and(|p| p > 0.0));
    let (p, step) = {
        let j = &h.state().worker.jobs()[0];
        (j.progress().unwrap(), j.step())
    };
    assert!(p > 0.0 && p < 0.5, "progress {p}");
    assert!(step.starts_with("model evaluation ") && step.contains(" of "), "step `{step}`");
    let shown = labels_containing(&h, "model evaluation ");
    assert!(!shown.is_empty(), "the status bar shows the evaluation count");
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    let t0 = Instant::now();
    idle(&mut h, "the cancelled search", 120);
    assert!(t0.elapsed() < Duration::from_secs(60), "cancel took {:?}", t0.elapsed());
    let s = h.state();
    assert!(s.session.model.result.is_none() && s.session.model.history.is_empty());
    assert!(s.session.messages.iter().any(|m| m.text.ends_with(": cancelled")), "{:?}", s.session.messages.iter().map(|m| &m.text).collect::<Vec<_>>());
    assert_eq!(s.session.signals.len(), 1, "nothing loaded is lost");
}

/// The search settings take the number of model realisations (and the fit duration) from
/// their editors into the loop options, within the library's ranges.
#[test]
fn search_settings_set_the_realisations_and_fit_duration() {
    let mut h = harness(StartOptions { tab: Some("model".into()), ..Default::default() });
    h.run_steps(2);
    h.get_by_label("Search settings").click();
    h.run_steps(2);
    let set = |h: &mut Harness<'static, Workbench>, label: &str, v: f64| {
        h.get_all_by_role(Role::SpinButton).find(|n| n.accesskit_node().label().as_deref() == Some(label)).unwrap_or_else(|| panic!("{label} editor")).set_value_accesskit(v);
        h.run_steps(3);
    };
    set(&mut h, "model realisations", 3.0);
    set(&mut h, "fit duration", 0.7);
    let o = h.state().settings.loop_options(Default::default());
    assert_eq!((o.realisations, o.fit_duration_s), (3, 0.7));
    assert_eq!(o.random_effect_realisations, 4, "the second look is on by default, with four realisations");
    set(&mut h, "second look for random effects", 0.0);
    assert_eq!(h.state().settings.loop_options(Default::default()).random_effect_realisations, 0);
    // The experimental second start from the uncalibrated values: off until ticked.
    assert!(!o.uncalibrated_start);
    h.get_by_label("second start: every trial also from the uncalibrated values, pinned or not (experimental)").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).uncalibrated_start);
    // The experimental near-floor rule: off until ticked.
    assert!(!o.near_floor_rule);
    h.get_by_label("near-floor rule: a decisive, untied trial is a finding from 1.2 × the floor (experimental)").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).near_floor_rule);
    // The experimental fine force cell: off until ticked (while forces are scanned).
    assert!(!o.fine_force_scan);
    h.get_by_label("fine force cell: a scanned force also gets a second, finer grid inside the coarse grid's best cell (experimental)").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).fine_force_scan);
    // Decision (d) and the roll-off's re-calibration: the library's defaults until clicked.
    let lib = twinscope::compare::LoopOptions::default();
    assert_eq!((o.effect_must_work, o.recalibrate_roll_off), (lib.effect_must_work, lib.recalibrate_roll_off));
    h.get_by_label("the effect must do the work: a best trial is a finding only when switching its effect off again costs at least 20 % of the error above the floor").click_accesskit();
    h.run_steps(3);
    assert_eq!(h.state().settings.loop_options(Default::default()).effect_must_work, !lib.effect_must_work);
    h.get_by_label("re-calibrate with a roll-off: the sensor roll-off's trial re-does the calibration from the uncalibrated values, as the casing mode's does (experimental)").click_accesskit();
    h.run_steps(3);
    assert_eq!(h.state().settings.loop_options(Default::default()).recalibrate_roll_off, !lib.recalibrate_roll_off);
    // The experimental joint trials: off until ticked.
    assert!(!o.joint_trials);
    h.get_by_label("joint trials: a stuck search tries its three best single trials in pairs (experimental)").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).joint_trials);
    // The coupled forces: on by default (since session 64) until unticked.
    assert!(o.coupled_forces, "on by default");
    h.get_by_label("coupled forces: an unbalance or misalignment trial beside the other, applied, fits the two together").click_accesskit();
    h.run_steps(3);
    assert!(!h.state().settings.loop_options(Default::default()).coupled_forces);
    // The joint grid of an applied force pair: on by default (since session 68) until unticked.
    assert!(o.force_pair_grid, "on by default");
    h.get_by_label("force pair grid: an applied unbalance and misalignment on one shaft are re-fitted jointly on a grid").click_accesskit();
    h.run_steps(3);
    assert!(!h.state().settings.loop_options(Default::default()).force_pair_grid);
    // The scan of periodic forces: on by default (since session 40) until unticked.
    assert!(o.scan_force_amplitudes);
    h.get_by_label("scan forces: every trial scans an unbalance, misalignment or belt force on a grid").click_accesskit();
    h.run_steps(3);
    assert!(!h.state().settings.loop_options(Default::default()).scan_force_amplitudes);
    // The fine force fit: on by default (since session 40) until unticked.
    assert!(o.fine_forces);
    h.get_by_label("fine forces: an unbalance, misalignment or belt force gets twice the line-search evaluations").click_accesskit();
    h.run_steps(3);
    assert!(!h.state().settings.loop_options(Default::default()).fine_forces);
    assert!(o.unbend_when_stuck, "on by default");
    h.get_by_label("unbend when stuck: a stuck search whose calibration pins nothing starts every trial again from the uncalibrated values").click_accesskit();
    h.run_steps(3);
    assert!(!h.state().settings.loop_options(Default::default()).unbend_when_stuck);
    // The experimental unbend when short: off until ticked.
    assert!(!o.unbend_when_short);
    h.get_by_label("unbend when short: a search whose best explains under half the error starts every trial again from the uncalibrated values (experimental)").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).unbend_when_short);
    // The second start for the top trials: on by default (since session 48) until unticked.
    assert!(o.uncalibrated_start_top, "on by default");
    h.get_by_label("second start for the top trials: the best three trials also start from the uncalibrated values before their re-fit").click_accesskit();
    h.run_steps(3);
    assert!(!h.state().settings.loop_options(Default::default()).uncalibrated_start_top);
    // The floor margin of the decision: the library's default until changed.
    assert_eq!(o.floor_margin, 0.15);
    set(&mut h, "floor margin", 0.2);
    assert_eq!(h.state().settings.loop_options(Default::default()).floor_margin, 0.2);
    // The calibration polish: four sweeps by default (since session 44) until set.
    assert_eq!(o.polish_sweeps, 4);
    set(&mut h, "calibration polish", 0.0);
    assert_eq!(h.state().settings.loop_options(Default::default()).polish_sweeps, 0);
    set(&mut h, "calibration polish", 2.0);
    assert_eq!(h.state().settings.loop_options(Default::default()).polish_sweeps, 2);
    // Whether the polish acts on an unbent trial's second start: off until ticked.
    assert!(!o.polish_second_starts);
    h.get_by_label("polish second starts too: the polish also acts on an unbent trial's start from the uncalibrated values").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).polish_second_starts);
    // The loop's one SCF normaliser: on by default (since session 44) until unticked, whatever
    // the comparison options it is given.
    assert!(o.compare.scf_one_normaliser);
    h.get_by_label("one SCF normaliser: every SCF slice's error relative to the measured SCF over all slices").click_accesskit();
    h.run_steps(3);
    assert!(!h.state().settings.loop_options(Default::default()).compare.scf_one_normaliser);
    // Beyond the range: the editor clamps to the library's limit.
    set(&mut h, "model realisations", 99.0);
    assert_eq!(h.state().settings.loop_options(Default::default()).realisations, twinscope::compare::MAX_REALISATIONS);
    assert!(h.state().settings.loop_options(Default::default()).validate().is_ok());
    // A stale stored value outside the range is passed on as it is and refused by the
    // library's check, which names the field (the app shows that message, runs nothing).
    h.state_mut().settings.loop_realisations = 0;
    let e = h.state().settings.loop_options(Default::default()).validate().unwrap_err().to_string();
    assert!(e.contains("realisations"), "{e}");
    h.state_mut().settings.loop_realisations = 1;
    h.state_mut().settings.loop_random_effect_realisations = 17;
    let e = h.state().settings.loop_options(Default::default()).validate().unwrap_err().to_string();
    assert!(e.contains("random_effect_realisations"), "{e}");
    // The reset button puts every search setting back to the library's default (a settings
    // file saved under older defaults keeps its values until then).
    h.get_by_label("reset search settings to the defaults").click();
    h.run_steps(3);
    assert_eq!(h.state().settings.loop_options(Default::default()), twinscope::gui::settings::Settings::default().loop_options(Default::default()));
}

/// A diagnosis that is a second look (a random effect led the search with one realisation)
/// says so, with the realisations, the leader and the first search's verdict.
#[test]
fn model_loop_says_when_a_diagnosis_is_a_second_look() {
    use twinscope::compare::{Diagnosis, Fit, LoopOptions, SecondLook};
    let mut h = model_loop_on_105(vec![twinscope::model::EffectKind::Slip]);
    {
        let second_look = Some(SecondLook { realisations: 4, leader: twinscope::model::EffectKind::Slip, verdict_with_one: "nothing significant is missing (best trial: slip explains 12 %)".into() });
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 2.0, held_out_objective: Some(8.4), second_look, verdict: "slip: ...".into(), ..Default::default() };
        show_diagnosis(&mut h, diagnosis, LoopOptions { random_effect_realisations: 4, ..Default::default() });
    }
    h.run_steps(3);
    assert!(h.query_by_label_contains("Second look with 4 realisations: slip led the search with one").is_some(), "the second look is shown");
    assert!(h.query_by_label_contains("that search said: nothing significant is missing (best trial: slip explains 12 %)").is_some());
}

/// The strength-range setting reaches the search's options, and a diagnosis with a range
/// shows it under the verdict, with the open side marked.
#[test]
fn model_loop_shows_the_strength_range_of_the_chosen_effect() {
    use twinscope::compare::strength_range::StrengthRange;
    use twinscope::compare::{Diagnosis, Fit, LoopOptions, Param};
    let mut h = model_loop_on_105(vec![twinscope::model::EffectKind::GearMesh]);
    assert!(!h.state().settings.loop_options(Default::default()).strength_range, "off by default");
    h.get_by_label("Search settings").click();
    h.run_steps(2);
    h.get_by_label("strength range: the chosen effect's strength with the range the data cannot tell from it").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).strength_range);
    {
        let profile = vec![(0.4, 2.33), (0.646, 2.318), (0.722, 2.357), (0.8, 2.394)];
        let range = StrengthRange { parameter: Param::MeshVariation, fitted: 0.722, low: 0.4, high: 0.8, low_open: true, high_open: false, objective_fitted: 2.357, tolerance: 0.29, profile, lowest: (0.646, 2.318) };
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 2.0, verdict: "gear_mesh: ...".into(), strength_range: Some(range), ..Default::default() };
        show_diagnosis(&mut h, diagnosis, LoopOptions::default());
    }
    h.run_steps(3);
    let shown = labels_containing(&h, "Strength range:");
    assert_eq!(shown.len(), 1, "{shown:?}");
    assert!(shown[0].contains("effects.gear_mesh.variation_fraction = 7.220e-1") && shown[0].contains("4.000e-1") && shown[0].contains("8.000e-1") && shown[0].contains("lowest objective at 6.460e-1"), "{}", shown[0]);
}

/// A ranking whose measurement was resampled down to the model's rate says so in its header;
/// one compared at the measurement's own rate does not.
#[test]
fn model_loop_names_the_rate_a_faster_measurement_was_compared_at() {
    use twinscope::compare::{Diagnosis, Fit, LoopOptions};
    let mut h = model_loop_on_105(vec![twinscope::model::EffectKind::Slip]);
    for (from, shown) in [(Some(48000.0), 1), (None, 0)] {
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 2.0, verdict: "nothing significant is missing (...)".into(), compared_at_hz: 12000.0, measured_resampled_from_hz: from, ..Default::default() };
        show_diagnosis(&mut h, diagnosis, LoopOptions::default());
        h.run_steps(3);
        assert_eq!(labels_containing(&h, "compared at 12000 Hz (the measurement resampled from 48000 Hz)").len(), shown, "resampled from {from:?}");
    }
}

/// Removal trials in the app: the setting switches `LoopOptions::removal_trials` on; a
/// diagnosis that holds them lists each part with its reading, and a contradicted part gets
/// a button that takes it out of the machine.
#[test]
fn model_loop_lists_the_removal_trials_and_takes_out_a_contradicted_fault() {
    use twinscope::compare::removal::{ModelPart, RemovalReading, RemovalTrial};
    use twinscope::compare::{Diagnosis, Fit, LoopOptions};
    let mut h = model_loop_on_105(vec![twinscope::model::EffectKind::Slip]);
    assert!(!h.state().settings.loop_options(Default::default()).removal_trials, "off by default");
    h.get_by_label("Search settings").click();
    h.run_steps(2);
    h.get_by_label("removal trials: each fault and effect of the model taken out in turn, the rest calibrated again").click_accesskit();
    h.run_steps(3);
    assert!(h.state().settings.loop_options(Default::default()).removal_trials);
    let m = h.state().session.model.machine.clone();
    assert!(m.bearings[0].fault.is_some());
    {
        let fault = ModelPart::Fault { bearing: m.bearings[0].name.clone() };
        let trial = |part: ModelPart, reading: RemovalReading, summary: &str| RemovalTrial { label: part.label(&m), part, objective_with: 31.65, objective_without: 29.02, envelope_nrmse_with: 21.0, envelope_nrmse_without: 19.6, floor_objective: 21.43, tie_width: 2.3, realisations: 4, fit_realisations: 4, explained: 0.26, reading, calibration: Fit::default(), summary: summary.into() };
        let removals = vec![
            trial(fault, RemovalReading::Contradicted, "the measurement does not support the inner-race fault of bearing de: ..."),
            trial(ModelPart::Effect(twinscope::model::EffectKind::NonlinearContact), RemovalReading::CannotTell, "the data cannot tell whether nonlinear_contact is there: ..."),
        ];
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 31.65, ..Default::default() }, floor_objective: 21.43, verdict: "nothing significant is missing (...)".into(), removals, ..Default::default() };
        show_diagnosis(&mut h, diagnosis, LoopOptions::default());
    }
    h.run_steps(3);
    assert_eq!(labels_containing(&h, "contradicted: the measurement does not support the inner-race fault").len(), 1);
    assert_eq!(labels_containing(&h, "cannot tell: the data cannot tell whether nonlinear_contact").len(), 1);
    assert!(h.query_by_label("Take out nonlinear_contact").is_none(), "only a contradicted part gets the button");
    h.get_by_label("Take out the inner-race fault of bearing de").click();
    h.run_steps(3);
    let after = &h.state().session.model.machine;
    assert!(after.bearings[0].fault.is_none(), "the fault taken out");
    assert_eq!(after.effects, m.effects, "nothing else changed");
}

/// The evidence list says which trial's best fit started from the uncalibrated values (the
/// second start of unbending or of `LoopOptions::uncalibrated_start`), and which force ended
/// lower from the fine grid's cell (`LoopOptions::fine_force_scan`), and no more.
#[test]
fn model_loop_says_which_trials_started_from_the_uncalibrated_values() {
    use twinscope::compare::{Diagnosis, EffectTrial, Fit, LoopOptions, Param};
    use twinscope::model::EffectKind::{self, *};
    let mut h = model_loop_on_105(vec![LoadZone, Unbalance]);
    let trial = |effect: EffectKind, parameter: (Param, f64), objective_after: f64, from_uncalibrated: bool| EffectTrial {
        effect,
        parameter: Some(parameter),
        extra_parameters: vec![],
        objective_before: 8.0,
        objective_after,
        envelope_nrmse_before: 4.0,
        envelope_nrmse_after: 2.0,
        domains: vec![],
        reduction: (8.0 - objective_after) / 8.0,
        explained: (8.0 - objective_after) / 6.0,
        evidence: "shaft (30.0 Hz) in the measurement".into(),
        evidence_share: 40.0,
        tied_with_best: false,
        outside_band: false,
        pinned: None,
        summary: String::new(),
        objective_without_effect: None,
        effect_explained: None,
        objective_fitted: None,
        from_uncalibrated,
        // The unbalance's fit ended lower from the fine force cell (`--fine-force-scan`).
        fine_cell_won: if from_uncalibrated { vec![] } else { vec![Param::UnbalanceKgM] },
        with_effect: None,
        joint: false,
        each_effect_explained: None,
    };
    {
        let trials = vec![trial(LoadZone, (Param::RadialLoadN, 86.0), 3.0, true), trial(Unbalance, (Param::UnbalanceKgM, 3e-4), 7.0, false)];
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 2.0, trials, best: Some(LoadZone), verdict: "load_zone: ...".into(), ..Default::default() };
        show_diagnosis(&mut h, diagnosis, LoopOptions { uncalibrated_start: true, ..Default::default() });
    }
    h.run_steps(3);
    let marked = labels_containing(&h, "its best fit started from the uncalibrated values");
    assert_eq!(marked.len(), 1, "{marked:?}");
    assert!(marked[0].starts_with("1. load_zone"), "{marked:?}");
    let fine = labels_containing(&h, "ended lower from the fine grid's cell");
    assert_eq!(fine.len(), 1, "{fine:?}");
    assert!(fine[0].starts_with("2. unbalance") && fine[0].contains("effects.unbalance.mass_eccentricity_kg_m ended lower"), "{fine:?}");
}

/// A stuck search's refused joint trials are listed under the evidence with their shares and
/// what switching off each effect alone costs; a chosen one heads the ranking instead.
#[test]
fn model_loop_lists_the_refused_joint_trials_of_a_stuck_search() {
    use twinscope::compare::{Diagnosis, EffectTrial, Fit, LoopOptions, Param};
    use twinscope::model::EffectKind::*;
    let mut h = model_loop_on_105(vec![LoadZone]);
    let joint = |effect, with, objective_after: f64, each: (f64, f64)| EffectTrial {
        effect,
        with_effect: Some(with),
        joint: true,
        parameter: Some((Param::CasingModeHz, 3827.0)),
        objective_before: 8.0,
        objective_after,
        explained: (8.0 - objective_after) / 6.0,
        each_effect_explained: Some(each),
        summary: "joint".into(),
        extra_parameters: vec![],
        reduction: (8.0 - objective_after) / 8.0,
        envelope_nrmse_before: 4.0,
        envelope_nrmse_after: 3.0,
        domains: vec![],
        evidence: String::new(),
        evidence_share: 0.0,
        tied_with_best: false,
        outside_band: false,
        pinned: None,
        objective_without_effect: None,
        effect_explained: None,
        objective_fitted: None,
        from_uncalibrated: false,
        fine_cell_won: vec![],
    };
    let joint_trials = vec![joint(SensorResponse, PathModulation, 7.4, (0.06, 0.04)), joint(Slip, PathModulation, 7.7, (0.02, 0.03))];
    let put = |h: &mut Harness<'static, Workbench>, best: Option<twinscope::model::EffectKind>, trials: Vec<EffectTrial>| {
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 2.0, trials, best, joint_trials: joint_trials.clone(), verdict: "nothing significant is missing".into(), ..Default::default() };
        show_diagnosis(h, diagnosis, LoopOptions { joint_trials: true, ..Default::default() });
        h.run_steps(3);
    };
    put(&mut h, None, vec![]);
    assert!(h.query_by_label_contains("Joint trials of this stuck search").is_some());
    let rows = labels_containing(&h, "alone costs");
    assert_eq!(rows.len(), 2, "{rows:?}");
    assert!(rows[0].starts_with("sensor_response + path_modulation: objective 8.0 -> 7.4; explains 10 %") && rows[0].contains("switching off sensor_response alone costs 6 %, path_modulation alone 4 %"), "{rows:?}");
    // Chosen: it heads the ranking and is not listed again as refused.
    let chosen = joint(CasingModes, NonlinearContact, 2.1, (0.9, 0.5));
    put(&mut h, Some(CasingModes), vec![chosen]);
    assert!(h.query_by_label_contains("Joint trials of this stuck search").is_none());
}

/// The model-loop view's history shows each round's seed floor next to its objective (what a
/// perfect model would still score), and "-" for a round recorded from a trial's fit.
#[test]
fn model_loop_history_shows_the_floor() {
    let mut h = harness(StartOptions { tab: Some("model".into()), ..Default::default() });
    h.run_steps(2);
    let round = |n: usize, objective: f64, floor_objective: f64| twinscope::compare::Round { round: n, effects_on: vec![], domains: vec![], envelope_nrmse: 9.5, objective, floor_objective, verdict: "v".into(), ..Default::default() };
    h.state_mut().session.model.history.push(round(1, 61.25, 7.25));
    h.state_mut().session.model.history.push(round(2, 12.75, 0.0));
    h.run_steps(3);
    assert!(h.query_by_label("floor").is_some(), "the history table has a floor column");
    assert!(h.query_by_label("7.2").is_some(), "round 1's floor is shown");
    assert!(h.query_by_label("61.2").is_some() && h.query_by_label("12.8").is_some(), "both objectives are shown");
    assert!(h.query_all_by_label("-").count() >= 2, "round 2 has no floor (and nothing applied)");
}

/// When a search finds nothing significant while the model is still well above its floor, the
/// view offers to replace an effect added earlier by a runner-up of the round that added it
/// (the loop's replacement step, by hand); the click swaps them in the calibrated machine and
/// searches the new model, and the answer is judged by the loop's rule. Here the stuck
/// round's objective (8.0) is made up, far below what any model of 105 reaches, so the real
/// search of the swapped model must be refused: the stuck model and its search come back,
/// the stuck round says what was tried, and the replacement is not offered again.
#[test]
fn model_loop_offers_a_replacement_when_stuck() {
    use twinscope::compare::{Diagnosis, Fit, LoopOptions, Round};
    use twinscope::gui::session::LoopResult;
    use twinscope::model::EffectKind::{self, *};
    let mut h = model_loop_on_105(vec![LoadZone]);
    // Round 1 added an unbalance (66 % explained; misalignment 63 %, slip 10 %); round 2's
    // search on the model with it found nothing significant at 4 x its floor.
    let mut m = h.state().session.model.machine.clone();
    m.effects.enable(Unbalance);
    let round = |n: usize, ranking: Vec<(EffectKind, f64, f64)>, applied: Option<EffectKind>| Round { round: n, envelope_nrmse: 5.0, objective: 8.0, floor_objective: 2.0, verdict: "v".into(), ranking, applied, ..Default::default() };
    let name = h.state().session.signals[0].signal.name.clone();
    {
        let model = &mut h.state_mut().session.model;
        model.replace_machine(m.clone());
        model.history = vec![round(1, vec![(Unbalance, 9.0, 0.66), (Misalignment, 9.2, 0.63), (Slip, 11.0, 0.10)], Some(Unbalance)), round(2, vec![], None)];
        // The search ran with a transfer-path correction; the view says so.
        let path_correction = Some(twinscope::dsp::path_correction::PathCorrection { centre_hz: vec![500.0, 3000.0], gain_db: vec![-12.5, 3.0], level_db: -4.0 });
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 2.0, verdict: "nothing significant is missing".into(), path_correction, ..Default::default() };
        model.result = Some(LoopResult { measured: name, options: LoopOptions::default(), started_from: m.clone(), calibrated: m.clone(), diagnosis, added: vec![], seconds: 1.0, refitted: None });
    }
    h.run_steps(3);
    assert!(h.query_by_label_contains("transfer-path correction on (2 bands): -12.5 to +3.0 dB").is_some(), "the correction is shown");
    assert!(h.query_by_label("Try slip in place of unbalance").is_none(), "slip explained 10 %, under the significance threshold");
    let button = h.get_by_label("Try misalignment in place of unbalance");
    assert!(!button.accesskit_node().is_disabled());
    button.click();
    h.run_steps(2);
    let model = &h.state().session.model;
    assert!(!model.machine.effects.is_on(Unbalance) && model.machine.effects.is_on(Misalignment), "swapped: {:?}", model.machine.effects.enabled());
    assert!(model.pending_replacement.is_some(), "judged when the search comes back");
    assert!(h.state().worker.busy(), "the new model is searched");
    wait_for(&mut h, "the search of the swapped model", 600, |a| !a.worker.busy());
    h.run_steps(2);
    let s = h.state();
    assert!(s.session.last_error().is_none(), "errors: {:?}", s.session.last_error());
    let model = &s.session.model;
    assert!(model.pending_replacement.is_none());
    assert_eq!(model.machine, m, "the stuck model is back");
    assert_eq!(model.result.as_ref().map(|r| r.started_from == m), Some(true), "and its search");
    assert_eq!(model.history.len(), 2, "no round for a refused replacement");
    assert_eq!((model.history[1].removed, model.history[1].applied), (None, None));
    assert!(model.history[1].verdict.contains("replacements tried, none below 8.00") && model.history[1].verdict.contains("misalignment in place of unbalance reaches"), "{}", model.history[1].verdict);
    assert_eq!(model.refused_replacements, vec![(Unbalance, Misalignment)]);
    assert!(h.query_by_label("Try misalignment in place of unbalance").is_none(), "a refused replacement is not offered again");
    // The re-fit of the unbalance from the uncalibrated values is still offered: the same
    // stuck round, judged by the same rule, on a model the worker fits first.
    let button = h.get_by_label("Re-fit unbalance from the uncalibrated values");
    assert!(!button.accesskit_node().is_disabled());
    button.click();
    h.run_steps(2);
    let model = &h.state().session.model;
    assert!(model.pending_replacement.as_ref().is_some_and(|p| p.removed == Unbalance && p.added == Unbalance && p.swapped.is_none()), "judged when the search comes back");
    assert_eq!(model.machine, m, "the machine stays until the re-fit is kept");
    assert!(h.state().worker.busy(), "the re-fit and its search run on the worker");
    wait_for(&mut h, "the re-fit and its search", 600, |a| !a.worker.busy());
    h.run_steps(2);
    let s = h.state();
    assert!(s.session.last_error().is_none(), "errors: {:?}", s.session.last_error());
    let model = &s.session.model;
    assert!(model.pending_replacement.is_none());
    assert_eq!(model.machine, m, "refused against the made-up 8.0: the stuck model stays");
    assert_eq!(model.history.len(), 2);
    assert!(model.history[1].verdict.contains("unbalance re-fitted from the uncalibrated values reaches"), "{}", model.history[1].verdict);
    assert!(model.refused_replacements.contains(&(Unbalance, Unbalance)));
    assert!(h.query_by_label("Re-fit unbalance from the uncalibrated values").is_none(), "a refused re-fit is not offered again");
}

/// A search with several model realisations judged its trials on held-out realisations: the
/// view says so, with both calibrated objectives, and the stuck test reads the held-out one.
#[test]
fn model_loop_says_when_trials_were_judged_on_held_out_realisations() {
    use twinscope::compare::{Diagnosis, Fit, LoopOptions};
    use twinscope::gui::session::LoopResult;
    let mut h = model_loop_on_105(vec![twinscope::model::EffectKind::LoadZone]);
    let m = h.state().session.model.machine.clone();
    let name = h.state().session.signals[0].signal.name.clone();
    {
        let model = &mut h.state_mut().session.model;
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 2.0, held_out_objective: Some(8.75), verdict: "nothing significant is missing".into(), ..Default::default() };
        model.result = Some(LoopResult { measured: name, options: LoopOptions { realisations: 2, ..Default::default() }, started_from: m.clone(), calibrated: m, diagnosis, added: vec![], seconds: 1.0, refitted: None });
    }
    h.run_steps(3);
    assert!(h.query_by_label_contains("Judged on held-out realisations: the calibrated model scores 8.75 there (8.00 on the realisations it was fitted to)").is_some(), "the held-out judgement is shown");
}

/// A search of a model with nothing random in it has a zero floor: the view says what that
/// means and offers to switch the noise on, which changes the model (its level is then
/// calibrated by the next search). A model with noise on is not offered it.
#[test]
fn model_loop_offers_to_switch_on_noise_when_the_floor_is_zero() {
    use twinscope::compare::{Diagnosis, Fit, LoopOptions};
    use twinscope::gui::session::LoopResult;
    use twinscope::model::EffectKind;
    let mut h = model_loop_on_105(vec![EffectKind::LoadZone]);
    let m = h.state().session.model.machine.clone();
    assert!(!m.effects.is_on(EffectKind::Noise), "the preset has no noise");
    let name = h.state().session.signals[0].signal.name.clone();
    let result = |m: &twinscope::model::Machine| {
        let diagnosis = Diagnosis { calibration: Fit { objective_after: 8.0, ..Default::default() }, floor_objective: 0.0, verdict: "nothing significant is missing".into(), ..Default::default() };
        LoopResult { measured: name.clone(), options: LoopOptions::default(), started_from: m.clone(), calibrated: m.clone(), diagnosis, added: vec![], seconds: 1.0, refitted: None }
    };
    h.state_mut().session.model.result = Some(result(&m));
    h.run_steps(3);
    assert!(!labels_containing(&h, "Note: the model has nothing random in it").is_empty(), "zero-floor note shown");
    h.get_by_label("Switch on noise").click();
    h.run_steps(3);
    let machine = h.state().session.model.machine.clone();
    assert!(machine.effects.is_on(EffectKind::Noise), "noise switched on: {:?}", machine.effects.enabled());
    let mut expected = m.clone();
    expected.effects.enable(EffectKind::Noise);
    assert_eq!(machine, expected, "nothing else changed");
    // With noise on, a zero floor (not reachable by a search, set here) offers no button.
    h.state_mut().session.model.result = Some(result(&machine));
    h.run_steps(3);
    assert!(h.query_by_label("Switch on noise").is_none());
}

/// "Band from kurtogram" in the compare view sets the chain's bandpass stage to the measured
/// record's most impulsive band that holds a resonance of the model (CWRU 209 with the
/// 0.021" preset: 2250–3750 Hz, holding the 2.6 kHz resonator); a chain without a bandpass
/// stage is refused with the reason and left as it was.
#[test]
fn compare_view_sets_the_band_from_the_kurtogram() {
    let mut h = harness(StartOptions { tab: Some("compare".into()), files: vec![sample("209_de_inner_021_0hp_12k.mat")], ..Default::default() });
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    idle(&mut h, "loading", 60);
    h.state_mut().execute(Command::LoadMachinePreset("cwru_6205_inner_021".into()));
    h.state_mut().execute(Command::ChainPreset("envelope".into()));
    h.run_steps(3);
    h.get_by_label("Band from kurtogram").click();
    h.run_steps(2);
    idle(&mut h, "the kurtogram", 60);
    let band = h.state().session.chain.stages.iter().find_map(|s| match &s.op {
        twinscope::chain::Op::Bandpass(b) => Some(b.pass_band_hz),
        _ => None,
    });
    assert_eq!(band, Some([2250.0, 3750.0]), "messages: {:?}", h.state().session.messages.iter().map(|m| m.text.clone()).collect::<Vec<_>>());
    // The loop compares in the chain's band, and says so.
    assert_eq!(twinscope::gui::jobs::compare_options_for(&h.state().session.chain).envelope_band_hz, [2250.0, 3750.0]);
    let last = h.state().session.messages.last().map(|m| m.text.clone()).unwrap_or_default();
    assert!(last.contains("2250–3750 Hz from the kurtogram") && last.contains("bandpass stage"), "{last}");
    h.state_mut().execute(Command::ChainPreset("welch".into()));
    let before = h.state().session.chain.clone();
    h.state_mut().execute(Command::BandFromKurtogram(0));
    h.run_steps(2);
    idle(&mut h, "the kurtogram", 60);
    let last = h.state().session.messages.last().map(|m| m.text.clone()).unwrap_or_default();
    assert!(last.contains("no bandpass stage"), "{last}");
    assert_eq!(h.state().session.chain, before);
}

/// CWRU's healthy record (48 kHz) against the healthy 6205 model (12 kHz): the model is
/// simulated and compared at its own rate, and the compare view says the measurement was
/// resampled (`compare::at_most_rate`).
#[test]
fn compare_view_names_the_measurement_resampled_to_the_models_rate() {
    let record = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cwru/097_normal_0hp_48k.mat");
    let mut h = harness(StartOptions { tab: Some("compare".into()), files: vec![record], ..Default::default() });
    wait_for(&mut h, "the file to load", 60, |a| !a.session.signals.is_empty());
    idle(&mut h, "loading", 60);
    h.state_mut().execute(Command::LoadMachinePreset("cwru_6205_healthy".into()));
    h.state_mut().execute(Command::SimulateModel { measured: Some(0) });
    h.run_steps(2);
    idle(&mut h, "the simulation and comparison", 120);
    let c = h.state().session.comparison.as_ref().expect("a comparison");
    assert_eq!((c.comparison.alignment.fs_hz, c.comparison.alignment.measured_resampled_from_hz), (12000.0, Some(48000.0)));
    h.run_steps(2);
    assert!(!labels_containing(&h, "compared at 12000 Hz (the measurement resampled from 48000 Hz)").is_empty(), "messages: {:?}", h.state().session.messages.iter().map(|m| m.text.clone()).collect::<Vec<_>>());
}
