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
    assert!(err.iter().any(|e| e.contains("bad_chain.toml") && e.contains("stage 1 `bandpass`") && e.contains("expected an array of length 2")), "errors shown: {err:?}");
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
