//! The work the workbench does off the UI thread. Each function only calls the library
//! (`signal::io`, `chain`, `dsp`, `kinematics`, `model`, `compare`) and packs the results for
//! the views.

use super::session::{Analysis, CompareResult, FirView, JobOutput, LoopResult, Origin, ScfResult, SignalEntry};
use super::session_file::SavedSignal;
use super::worker::JobHandle;
use crate::chain::{Chain, ChainContext, Data};
use crate::compare::{self, CompareOptions};
use crate::dsp;
use crate::kinematics::{labelled_peaks, lookup_bearing, marker_lines, CharacteristicFrequency, PeakLabelling};
use crate::model::{self, Machine};
use crate::signal::io::{self, LoadOptions};
use crate::signal::Signal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The bundled demo recording: CWRU 105, drive end, 0.007 in inner-race fault, 0 hp, 12 kHz.
pub const DEMO_FILE: &str = "sample_data/105_de_inner_007_0hp_12k.mat";
/// Its bytes, compiled in so the demo works from any directory.
pub const DEMO_BYTES: &[u8] = include_bytes!("../../sample_data/105_de_inner_007_0hp_12k.mat");
/// The drive-end bearing of the CWRU rig.
pub const DEMO_BEARING: &str = "SKF 6205-2RS JEM";
/// The chain preset of the demo.
pub const DEMO_CHAIN: &str = "envelope_cwru";
/// The machine preset of the demo.
pub const DEMO_MACHINE: &str = "cwru_6205_inner";

/// The demo's measured signal (DE channel, 1797 rpm from the file, 6205 bearing).
pub fn demo_signal(id: u64) -> Result<SignalEntry, String> {
    let opts = LoadOptions { channel: Some("_DE_time".into()), ..Default::default() };
    let mut signal = io::mat::read_bytes(DEMO_BYTES, DEMO_FILE, &opts).map_err(|e| e.to_string())?;
    signal.meta.source = Some(format!("{DEMO_FILE} (bundled)"));
    if signal.meta.bearing.is_none() {
        signal.meta.bearing = Some(DEMO_BEARING.into());
    }
    let channels = io::mat::inspect_bytes(DEMO_BYTES, DEMO_FILE).map(|i| i.channels).unwrap_or_default();
    Ok(SignalEntry { id, signal, origin: Origin::Measured, file: None, channels, machine_families: Vec::new() })
}

/// Reads `channel` (or the default one) of `path`, with the file's channel list.
pub fn load_file(id: u64, path: &Path, channel: Option<String>) -> Result<SignalEntry, String> {
    let info = io::inspect(path).map_err(|e| e.to_string())?;
    let signal = io::load(path, &LoadOptions { channel, ..Default::default() }).map_err(|e| e.to_string())?;
    Ok(SignalEntry { id, signal, origin: Origin::Measured, file: Some(path.to_path_buf()), channels: info.channels, machine_families: Vec::new() })
}

/// Simulates the machine of preset `preset` (already loaded) with progress and cancel.
pub fn simulate_preset(id: u64, machine: &model::Machine, preset: &str, job: &JobHandle) -> Result<SignalEntry, String> {
    machine.validate().map_err(|e| e.to_string())?;
    let built = model::Model::build(machine).map_err(|e| e.to_string())?;
    let signal = model::run(&built, |f| {
        job.set_progress(f);
        !job.cancelled()
    })
    .map_err(|e| e.to_string())?;
    let (families, _) = compare::machine_families(machine);
    let machine_families = families.into_iter().filter(|f| f.label == "GMF").collect();
    Ok(SignalEntry { id, signal, origin: Origin::Simulated { preset: preset.into() }, file: None, channels: Vec::new(), machine_families })
}

/// Simulates an edited machine with progress and cancel; the signal is listed as simulated from
/// `label` (the preset it started from).
pub fn simulate_machine(id: u64, machine: &model::Machine, label: &str, job: &JobHandle) -> Result<SignalEntry, String> {
    machine.validate().map_err(|e| e.to_string())?;
    job.set_step(format!("simulating {:.2} s of {}", machine.duration_s, machine.name));
    let built = model::Model::build(machine).map_err(|e| e.to_string())?;
    let mut signal = model::run(&built, |f| {
        job.set_progress(f);
        !job.cancelled()
    })
    .map_err(|e| e.to_string())?;
    let on: Vec<&str> = machine.effects.enabled().into_iter().map(|k| k.name()).collect();
    signal.name = format!("{label} model ({})", if on.is_empty() { "no effects".to_string() } else { on.join(", ") });
    let (families, _) = compare::machine_families(machine);
    let machine_families = families.into_iter().filter(|f| f.label == "GMF").collect();
    Ok(SignalEntry { id, signal, origin: Origin::Simulated { preset: label.into() }, file: None, channels: Vec::new(), machine_families })
}

/// "Find missing effect": calibrates `machine` against `measured`, tries every candidate
/// effect and ranks them (`compare::diagnose`). The progress bar counts model evaluations;
/// Cancel makes the progress callback answer `false`, which stops the search.
pub fn find_missing_effect(machine: &model::Machine, measured: &SignalEntry, opts: &compare::LoopOptions, job: &JobHandle) -> Result<LoopResult, String> {
    let started = Instant::now();
    machine.validate().map_err(|e| e.to_string())?;
    job.set_step("calibrating, then one trial per candidate effect");
    job.set_progress(0.0);
    let report = |done: usize, expected: usize| {
        job.set_progress(done as f64 / expected.max(1) as f64);
        job.set_step(format!("model evaluation {done} of {expected}"));
        !job.cancelled()
    };
    let (calibrated, diagnosis) = compare::diagnose(machine, &measured.signal, opts, &report).map_err(|e| match e {
        compare::LoopError::Cancelled => "cancelled".to_string(),
        e => format!("find missing effect against `{}`: {e}", measured.signal.name),
    })?;
    Ok(LoopResult { measured: measured.signal.name.clone(), options: opts.clone(), started_from: machine.clone(), calibrated, diagnosis, added: Vec::new(), seconds: started.elapsed().as_secs_f64(), refitted: None })
}

/// The loop's re-fit by hand: the applied effect `a` of the stuck calibrated machine `stuck`
/// fitted anew from the uncalibrated values of `start`
/// (`compare::diagnose::refit_from_uncalibrated`), then [`find_missing_effect`] on the result.
pub fn refit_and_search(stuck: &model::Machine, start: &model::Machine, a: model::EffectKind, measured: &SignalEntry, opts: &compare::LoopOptions, job: &JobHandle) -> Result<LoopResult, String> {
    job.set_step(format!("re-fitting {} from the uncalibrated values", a.name()));
    job.set_progress(0.0);
    let report = |done: usize, expected: usize| {
        job.set_progress(done as f64 / expected.max(1) as f64);
        job.set_step(format!("re-fitting {}: model evaluation {done} of {expected}", a.name()));
        !job.cancelled()
    };
    let failed = |e: compare::LoopError| match e {
        compare::LoopError::Cancelled => "cancelled".to_string(),
        e => format!("re-fit of {} against `{}`: {e}", a.name(), measured.signal.name),
    };
    let at_rate = compare::at_most_rate(&measured.signal, stuck.fs_hz).map_err(|e| failed(e.into()))?;
    let reference = compare::Reference::new(&at_rate, &opts.compare).map_err(|e| failed(e.into()))?;
    let refitted = compare::diagnose::refit_from_uncalibrated(stuck, start, a, &reference, opts, &compare::LoopProgress::new(&report)).map_err(failed)?;
    Ok(LoopResult { refitted: Some(a), ..find_missing_effect(&refitted, measured, opts, job)? })
}

/// The cyclic spectral correlation of `signal` (Fast-SC), with the line families of `entry` for
/// the α picks.
pub fn compute_scf(entry: &SignalEntry, signal: &Signal, source: &str, params: &dsp::scf::ScfParams, job: &JobHandle) -> Result<ScfResult, String> {
    let started = Instant::now();
    job.set_step(format!("fast SCF, α {:.0}–{:.0} Hz, nperseg {}", params.alpha_min_hz, params.alpha_max_hz, params.nperseg));
    params.validate(signal.fs_hz, signal.len()).map_err(|e| format!("SCF of `{}`: {e}", signal.name))?;
    let map = dsp::scf::fast_scf(&signal.samples, signal.fs_hz, params).map_err(|e| format!("SCF of `{}`: {e}", signal.name))?;
    let (families, shaft) = families_of(entry);
    Ok(ScfResult { signal_name: signal.name.clone(), source: source.into(), unit: signal.unit.clone(), map, families, shaft_speed_hz: shaft, seconds: started.elapsed().as_secs_f64() })
}

/// Reads a measured signal of a saved session and applies its metadata edits.
pub fn load_saved(id: u64, saved: &SavedSignal) -> Result<SignalEntry, String> {
    let mut e = match (&saved.file, saved.bundled_demo) {
        (_, true) => {
            let mut e = demo_signal(id)?;
            if let Some(c) = &saved.channel {
                e.signal = io::mat::read_bytes(DEMO_BYTES, DEMO_FILE, &LoadOptions { channel: Some(c.clone()), ..Default::default() }).map_err(|e| e.to_string())?;
                e.signal.meta.source = Some(format!("{DEMO_FILE} (bundled)"));
            }
            e
        }
        (Some(p), false) => load_file(id, p, saved.channel.clone())?,
        (None, false) => return Err("a saved signal has neither a file nor the bundled demo".into()),
    };
    crate::dsp::error::check_fs(saved.fs_hz).map_err(|err| format!("signal `{}`: saved {err}", e.signal.name))?;
    e.signal.fs_hz = saved.fs_hz;
    e.signal.meta.shaft_speed_hz = saved.shaft_speed_hz;
    if let Some(b) = &saved.bearing {
        lookup_bearing(b).map_err(|err| format!("signal `{}`: saved bearing: {err}", e.signal.name))?;
    }
    e.signal.meta.bearing = saved.bearing.clone();
    usable(&e.signal)?;
    Ok(e)
}

/// The line families of a signal: its bearing's at its shaft speed (else the shaft alone),
/// plus the machine families it carries (GMF).
pub fn families_of(entry: &SignalEntry) -> (Vec<CharacteristicFrequency>, Option<f64>) {
    let fr = entry.signal.meta.shaft_speed_hz;
    let bearing = entry.signal.meta.bearing.as_deref().and_then(|b| lookup_bearing(b).ok());
    let mut fams = match (&bearing, fr) {
        (Some(b), Some(fr)) => b.fault_frequencies(fr).map(|f| f.families()).unwrap_or_default(),
        (None, Some(fr)) => vec![CharacteristicFrequency { label: "shaft".into(), frequency_hz: fr }],
        _ => Vec::new(),
    };
    fams.extend(entry.machine_families.iter().cloned());
    (fams, fr)
}

/// Runs `chain` on `entry`, then the amplitude spectrum and Welch PSD of the input, the
/// labelled envelope-spectrum peaks, the marker lines and the FIR responses.
pub fn analyse(entry: &SignalEntry, chain: &Chain, labelling: &PeakLabelling, job: &JobHandle) -> Result<Analysis, String> {
    let started = Instant::now();
    let signal = &entry.signal;
    let bearing = match signal.meta.bearing.as_deref() {
        Some(b) => Some(lookup_bearing(b).map_err(|e| format!("signal `{}`: {e}", signal.name))?),
        None => None,
    };
    let ctx = ChainContext { bearing, shaft_speed_hz: signal.meta.shaft_speed_hz };
    let n = chain.stages.len().max(1) as f64 + 2.0;
    let result = chain
        .run(signal, &ctx, |i, _, name| {
            job.set_step(format!("stage {name}"));
            job.set_progress(i as f64 / n);
        })
        .map_err(|e| format!("chain `{}`: {e}", chain.name))?;
    job.check()?;
    job.set_step("spectrum and PSD of the input");
    job.set_progress((n - 2.0) / n);
    let spectrum = dsp::spectrum::amplitude_spectrum(&signal.samples, signal.fs_hz, &Default::default()).ok().map(|mut s| {
        if s.unit.is_empty() {
            s.unit = signal.unit.clone();
        }
        s
    });
    let welch = dsp::welch::WelchParams { nperseg: 4096.min(signal.len().max(8)), ..Default::default() };
    let psd = dsp::welch::welch_psd(&signal.samples, signal.fs_hz, &welch).ok().map(|p| p.to_spectrum(&signal.unit));
    job.check()?;
    let envelope = result
        .stages
        .iter()
        .rev()
        .find(|s| s.kind == "envelope_spectrum")
        .or_else(|| result.stages.iter().rev().find(|s| matches!(s.data, Data::Spectrum(_))))
        .and_then(|s| match &s.data {
            Data::Spectrum(sp) => Some((s.name.clone(), sp.clone())),
            _ => None,
        });
    let (families, shaft) = families_of(entry);
    let peaks = match &envelope {
        Some((_, sp)) => labelled_peaks(sp, &families, shaft.filter(|_| families.len() > 1), labelling).map_err(|e| e.to_string())?,
        None => Vec::new(),
    };
    let markers = marker_lines(&families, shaft, labelling.max_harmonic, labelling.max_sideband.max(0) as u32, signal.fs_hz / 2.0);
    let mut firs = Vec::new();
    for s in &result.stages {
        if let Some(Data::Fir(d)) = s.extras.get("design") {
            let (f, m) = dsp::remez::frequency_response_db(&d.taps, d.fs_hz, 4096).map_err(|e| format!("stage `{}`: response: {e}", s.name))?;
            firs.push(FirView { stage: s.name.clone(), design: d.clone(), frequency_hz: f, magnitude_db: m });
        }
    }
    job.set_progress(1.0);
    Ok(Analysis {
        signal_id: entry.id,
        signal_name: signal.name.clone(),
        chain: chain.clone(),
        result,
        spectrum,
        psd,
        envelope,
        peaks,
        markers,
        families,
        shaft_speed_hz: shaft,
        firs,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The demodulation band of the chain's first bandpass stage (the analyst's choice), else
/// the comparison default.
pub fn compare_options_for(chain: &Chain) -> CompareOptions {
    let mut o = CompareOptions::default();
    if let Some(spec) = chain.stages.iter().find_map(|s| match &s.op {
        crate::chain::Op::Bandpass(b) => Some(b.clone()),
        _ => None,
    }) {
        o.envelope_band_hz = spec.pass_band_hz;
    }
    o
}

/// Compares a simulated signal with a measured one and maps the residual.
pub fn compare_signals(measured: &SignalEntry, simulated: &SignalEntry, options: &CompareOptions) -> Result<CompareResult, String> {
    let cmp = compare::compare(&measured.signal, &simulated.signal, options).map_err(|e| format!("compare `{}` with `{}`: {e}", measured.signal.name, simulated.signal.name))?;
    let (mut families, mut shaft) = families_of(measured);
    if families.len() <= 1 {
        let (f, s) = families_of(simulated);
        families = f;
        shaft = shaft.or(s);
    }
    let residual = compare::residual_map(&cmp, &families, shaft);
    Ok(CompareResult { measured: measured.signal.name.clone(), simulated: simulated.signal.name.clone(), options: options.clone(), comparison: cmp, residual })
}

/// The demo: the bundled CWRU recording through `envelope_cwru`, then the CWRU inner-race
/// preset simulated and compared. Each result is sent as soon as it exists.
pub fn demo(ids: [u64; 2], labelling: PeakLabelling, job: &JobHandle) -> Result<(), String> {
    job.set_step("loading the bundled CWRU 105 recording");
    let measured = demo_signal(ids[0])?;
    job.send(JobOutput::Signal { entry: Box::new(measured.clone()), replace: None, select: true });
    let chain = crate::chain::preset(DEMO_CHAIN).map_err(|e| e.to_string())?;
    job.check()?;
    let analysis = analyse(&measured, &chain, &labelling, job)?;
    job.send(JobOutput::Analysis(Box::new(analysis)));
    job.check()?;
    job.set_step(format!("simulating machine preset {DEMO_MACHINE}"));
    let machine = model::preset(DEMO_MACHINE).map_err(|e| e.to_string())?;
    let simulated = simulate_preset(ids[1], &machine, DEMO_MACHINE, job)?;
    job.send(JobOutput::Signal { entry: Box::new(simulated.clone()), replace: None, select: false });
    job.check()?;
    job.set_step("comparing model and measurement");
    job.set_progress(f64::NAN);
    let mut opts = compare_options_for(&chain);
    opts.fault_frequency_hz = crate::compare::diagnose::fault_frequency_hz(&machine, &measured.signal);
    let cmp = compare_signals(&measured, &simulated, &opts)?;
    job.send(JobOutput::Comparison(Box::new(cmp)));
    Ok(())
}

/// Reads a TOML file with `parse(text, source name)`.
fn read_toml<T, E: std::fmt::Display>(path: &Path, parse: impl Fn(&str, &str) -> Result<T, E>) -> Result<T, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read ({e})", path.display()))?;
    parse(&text, &path.display().to_string()).map_err(|e| e.to_string())
}

/// Writes `text` to a TOML file after checking that `parse` reads it back, so a file that
/// could not be opened again is never written.
fn write_toml<T, E: std::fmt::Display>(text: String, path: &Path, parse: impl Fn(&str, &str) -> Result<T, E>) -> Result<(), String> {
    parse(&text, &path.display().to_string()).map_err(|e| format!("not saved: {e}"))?;
    std::fs::write(path, text).map_err(|e| format!("{}: cannot write ({e})", path.display()))
}

/// Reads a chain TOML file.
pub fn read_chain(path: &Path) -> Result<Chain, String> {
    read_toml(path, Chain::from_toml)
}

/// Writes a chain TOML file (checked by reading it back first).
pub fn write_chain(chain: &Chain, path: &Path) -> Result<(), String> {
    write_toml(chain.to_toml(), path, Chain::from_toml)
}

/// Reads a machine TOML file (parsed and validated as `diagnose --machine` reads one).
pub fn read_machine(path: &Path) -> Result<Machine, String> {
    read_toml(path, Machine::from_toml)
}

/// Writes a machine TOML file (checked by reading it back first).
pub fn write_machine(m: &Machine, path: &Path) -> Result<(), String> {
    write_toml(m.to_toml(), path, Machine::from_toml)
}

/// Checks an edited chain the way a file would be checked (names, inputs, parameter types).
pub fn check_chain(chain: &Chain) -> Result<Chain, String> {
    Chain::from_toml(&chain.to_toml(), "the edited chain").map_err(|e| e.to_string())
}

/// Checks each stage's parameters against the sampling rate, where the library offers a check.
pub fn check_stage(op: &crate::chain::Op, fs_hz: f64) -> Result<(), String> {
    use crate::chain::Op;
    let r = match op {
        Op::Bandpass(b) => b.validate(fs_hz),
        Op::EnvelopeSpectrum(p) => p.validate(fs_hz),
        _ => Ok(()),
    };
    r.map_err(|e| e.to_string())
}

/// Asks for a file in a native dialog (runs on a job thread; rfd needs D-Bus on Linux).
pub fn pick(purpose: super::session::Purpose, start_dir: Option<PathBuf>) -> Option<PathBuf> {
    use super::session::Purpose;
    let mut d = rfd::FileDialog::new();
    if let Some(dir) = start_dir {
        d = d.set_directory(dir);
    }
    match purpose {
        Purpose::OpenSignal => d.add_filter("signals", &["mat", "wav", "csv", "tsv", "txt"]).pick_file(),
        Purpose::OpenChain => d.add_filter("chain", &["toml"]).pick_file(),
        Purpose::SaveChain => d.add_filter("chain", &["toml"]).set_file_name("chain.toml").save_file(),
        Purpose::OpenSession => d.add_filter("twinscope session", &["json"]).pick_file(),
        Purpose::OpenMachine => d.add_filter("machine", &["toml"]).pick_file(),
        Purpose::SaveMachine => d.add_filter("machine", &["toml"]).set_file_name("machine.toml").save_file(),
        Purpose::SaveSession => d.add_filter("twinscope session", &["json"]).set_file_name("session.twinscope.json").save_file(),
        Purpose::ExportCsv => d.add_filter("CSV", &["csv"]).set_file_name("view.csv").save_file(),
        Purpose::ExportSvg => d.add_filter("SVG", &["svg"]).set_file_name("view.svg").save_file(),
        Purpose::ExportPng => d.add_filter("PNG", &["png"]).set_file_name("view.png").save_file(),
    }
}

/// Whether `s` is a signal the workbench can analyse (non-empty, finite fs).
pub fn usable(s: &Signal) -> Result<(), String> {
    if s.is_empty() {
        return Err(format!("signal `{}` holds no samples", s.name));
    }
    crate::dsp::error::check_fs(s.fs_hz).map_err(|e| format!("signal `{}`: {e}", s.name))
}
