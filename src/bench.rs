//! `twinscope bench`: times the heavy operations on 10 s of 16384 Hz data and, when python3
//! with numpy/scipy is available, the same operations in scipy on the same input in the same
//! run. Prints a Markdown table (the one quoted in README.md).

use anyhow::{Context, Result};
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;
use twinscope::dsp::{self, scf::ScfParams};
use twinscope::signal::synth;

/// Options of `twinscope bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Repetitions per operation (the median is reported).
    #[arg(long, default_value_t = 5)]
    repeat: usize,
    /// Skip the slow rows: the averaged cyclic periodogram (the SCF reference) and the
    /// missing-effect searches (about 5 min).
    #[arg(long)]
    skip_slow: bool,
    /// Do not run the scipy reference even if python3 has scipy.
    #[arg(long)]
    no_scipy: bool,
    /// Python interpreter for the scipy reference.
    #[arg(long, default_value = "python3")]
    python: String,
    /// Only the display rows: per-frame min/max decimation of a 10-minute 48 kHz record and the
    /// SCF map reduction the desktop workbench does while you zoom and pan.
    #[arg(long)]
    display_only: bool,
}

/// The display rows: what the workbench computes per frame for a long record. A 10-minute
/// 48 kHz record (28.8 million samples: a 3 kHz tone, noise, and one-sample spikes) is reduced
/// to 1280 display columns over the whole record and over a 10 s zoom; an SCF-sized map
/// (5121 × 257) is reduced to the 3D surface's 240 × 64 cells.
fn display_rows(repeat: usize) -> Vec<Row> {
    use twinscope::signal::display::{max_pool_map, min_max_decimate, MinMaxPyramid};
    let fs = 48_000.0;
    let n = 600 * 48_000;
    let t0 = std::time::Instant::now();
    let mut x = synth::white_noise(n, 0.1, 7);
    for (i, v) in x.iter_mut().enumerate() {
        *v += (2.0 * std::f64::consts::PI * 3000.0 * i as f64 / fs).sin();
    }
    for k in 1..20 {
        x[k * n / 20 + 17] = 25.0;
    }
    eprintln!("twinscope bench: built 10 min at 48 kHz ({n} samples, {:.0} MB) in {:.1} s", n as f64 * 8.0 / 1e6, t0.elapsed().as_secs_f64());
    let mut rows = Vec::new();
    let full = median_ms(repeat, || {
        let tr = min_max_decimate(&x, fs, 0.0, 600.0, 1280);
        anyhow::ensure!(tr.max.iter().filter(|&&v| v == 25.0).count() == 19, "a spike was lost");
        Ok(())
    });
    if let Ok(ms) = full {
        rows.push(Row { name: "display: min/max decimation, 10 min at 48 kHz (28.8 M samples) → 1280 columns, whole record".into(), ours_ms: ms, reference: "-", reference_key: None });
    }
    if let Ok(ms) = median_ms(repeat, || {
        min_max_decimate(&x, fs, 300.0, 310.0, 1280);
        Ok(())
    }) {
        rows.push(Row { name: "display: the same, zoomed to 10 s (480 k samples) → 1280 columns".into(), ours_ms: ms, reference: "-", reference_key: None });
    }
    let mut pyramid = MinMaxPyramid::default();
    if let Ok(ms) = median_ms(repeat, || {
        pyramid = MinMaxPyramid::new(&x);
        Ok(())
    }) {
        rows.push(Row { name: "display: build the min/max pyramid of the 10-min record (once per signal)".into(), ours_ms: ms, reference: "-", reference_key: None });
    }
    if let Ok(ms) = median_ms(repeat, || {
        let tr = pyramid.decimate(&x, fs, 0.0, 600.0, 1280);
        anyhow::ensure!(tr.max.iter().filter(|&&v| v == 25.0).count() == 19, "a spike was lost");
        Ok(())
    }) {
        rows.push(Row { name: "display: per frame from the pyramid, whole record → 1280 columns (what the time view does)".into(), ours_ms: ms, reference: "-", reference_key: None });
    }
    if let Ok(ms) = median_ms(repeat, || {
        pyramid.decimate(&x, fs, 300.0, 310.0, 1280);
        Ok(())
    }) {
        rows.push(Row { name: "display: per frame from the pyramid, zoomed to 10 s".into(), ours_ms: ms, reference: "-", reference_key: None });
    }
    let (na, nf) = (5121, 257);
    let map: Vec<f64> = (0..na * nf).map(|k| ((k as f64) * 0.37).sin().abs()).collect();
    let alpha: Vec<f64> = (0..na).map(|i| i as f64 * 0.0977).collect();
    let freq: Vec<f64> = (0..nf).map(|j| j as f64 * 23.4).collect();
    if let Ok(ms) = median_ms(repeat, || {
        max_pool_map(&map, &alpha, &freq, (5.0, 500.0), (f64::NEG_INFINITY, f64::INFINITY), 240, 64);
        Ok(())
    }) {
        rows.push(Row { name: "display: SCF map 5121 × 257 → 240 × 64 block maxima (3D surface)".into(), ours_ms: ms, reference: "-", reference_key: None });
    }
    rows
}

fn print_rows(rows: &[Row]) {
    println!("| operation | twinscope (ms) |");
    println!("|---|---:|");
    for row in rows {
        println!("| {} | {:.2} |", row.name, row.ours_ms);
    }
}

struct Row {
    name: String,
    ours_ms: f64,
    reference: &'static str,
    reference_key: Option<&'static str>,
}

fn median_ms(repeat: usize, mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    let mut t = Vec::with_capacity(repeat);
    for _ in 0..repeat.max(1) {
        let s = Instant::now();
        f()?;
        t.push(s.elapsed().as_secs_f64() * 1e3);
    }
    t.sort_by(|a, b| a.total_cmp(b));
    Ok(t[t.len() / 2])
}

/// The benchmark signal: a bearing-like impact train at 107 Hz ringing a 3 kHz resonance, a
/// gear-like tone set, and white noise; 10 s at 16384 Hz, seed 42.
pub fn bench_signal() -> (Vec<f64>, f64) {
    let fs = 16384.0;
    let n = 163_840;
    let p = synth::ImpactTrain {
        fault_frequency_hz: 107.0,
        resonance_hz: 3000.0,
        damping_ratio: 0.05,
        jitter_fraction: 0.01,
        modulation_depth: 0.5,
        modulation_hz: 15.0,
        amplitude: 1.0,
    };
    let mut x = synth::impact_train(n, fs, &p, 42);
    let noise = synth::white_noise(n, 0.3, 43);
    let gear = synth::tone(n, fs, 270.0, 0.5, 0.3);
    for i in 0..n {
        x[i] += noise[i] + gear[i];
    }
    (x, fs)
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.display_only {
        print_rows(&display_rows(args.repeat));
        return Ok(());
    }
    let (x, fs) = bench_signal();
    let r = args.repeat;
    let mut rows = Vec::new();
    eprintln!("twinscope bench: 10 s at {fs} Hz ({} samples), median of {r} runs, {} threads", x.len(), rayon::current_num_threads());

    let welch = dsp::welch::WelchParams { nperseg: 4096, ..Default::default() };
    rows.push(Row { name: "Welch PSD (nperseg 4096, hann, 50 %)".into(), ours_ms: median_ms(r, || Ok(dsp::welch::welch_psd(&x, fs, &welch).map(|_| ())?))?, reference: "scipy.signal.welch", reference_key: Some("welch") });
    rows.push(Row { name: "Hilbert envelope (abs of the analytic signal)".into(), ours_ms: median_ms(r, || Ok(dsp::envelope::envelope(&x).map(|_| ())?))?, reference: "abs(scipy.signal.hilbert)", reference_key: Some("hilbert") });

    let spec = dsp::remez::BandpassSpec::default();
    let design = dsp::remez::design_bandpass(&spec, fs)?;
    let bands = spec.bands_hz(fs);
    let weights = spec.weights();
    let numtaps = design.numtaps;
    rows.push(Row {
        name: "remez, seed bandpass at its final order".into(),
        ours_ms: median_ms(r, || Ok(dsp::remez::remez(numtaps, &bands, &[0.0, 1.0, 0.0], &weights, fs).map(|_| ())?))?,
        reference: "scipy.signal.remez (maxiter=250)",
        reference_key: Some("remez"),
    });
    rows.push(Row {
        name: "equiripple design loop (estimate → grow until spec met)".into(),
        ours_ms: median_ms(r, || Ok(dsp::remez::design_bandpass(&spec, fs).map(|_| ())?))?,
        reference: "-",
        reference_key: None,
    });
    rows.push(Row {
        name: "zero-phase FIR filtering (filtfilt)".into(),
        ours_ms: median_ms(r, || Ok(dsp::remez::filtfilt_fir(&design.taps, &x).map(|_| ())?))?,
        reference: "scipy.signal.filtfilt(b, 1)",
        reference_key: Some("filtfilt"),
    });
    let kurtogram = dsp::kurtogram::KurtogramParams::default();
    rows.push(Row {
        name: "kurtogram (13 frame lengths 16–1024, hann, 75 %)".into(),
        ours_ms: median_ms(r, || Ok(dsp::kurtogram::kurtogram(&x, fs, &kurtogram).map(|_| ())?))?,
        reference: "scipy.signal.stft + numpy moments, per length",
        reference_key: Some("kurtogram"),
    });
    rows.push(Row {
        name: format!("resample 10 s from {fs:.0} Hz to 12000 Hz (Fourier method: a faster measurement brought to a model's rate)"),
        ours_ms: median_ms(r, || Ok(dsp::resample::resample(&x, fs, 12000.0).map(|_| ())?))?,
        reference: "scipy.signal.resample",
        reference_key: Some("resample"),
    });
    let drs = dsp::drs::DrsParams::default();
    rows.push(Row { name: "DRS (defaults)".into(), ours_ms: median_ms(r, || Ok(dsp::drs::drs(&x, fs, &drs).map(|_| ())?))?, reference: "-", reference_key: None });
    let stsa = dsp::stsa::StsaParams { fault_frequency_hz: 107.0, ..Default::default() };
    rows.push(Row { name: "STSA at 107 Hz".into(), ours_ms: median_ms(r, || Ok(dsp::stsa::stsa(&x, fs, &stsa).map(|_| ())?))?, reference: "-", reference_key: None });

    let chain = twinscope::chain::preset("envelope")?;
    let bearing = twinscope::kinematics::lookup_bearing("MB ER-12K")?;
    let ctx = twinscope::chain::ChainContext { bearing: Some(bearing), shaft_speed_hz: Some(15.0) };
    let sig = twinscope::signal::Signal::new(x.clone(), fs, "bench", "");
    rows.push(Row {
        name: "seed envelope chain end to end (normalise → STSA → design + filtfilt → envelope spectrum)".into(),
        ours_ms: median_ms(r, || Ok(chain.run(&sig, &ctx, |_, _, _| {}).map(|_| ())?))?,
        reference: "-",
        reference_key: None,
    });
    let mat = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("sample_data/105_de_inner_007_0hp_12k.mat");
    if mat.exists() {
        let opts = twinscope::signal::io::LoadOptions::default();
        rows.push(Row {
            name: "load a CWRU .mat (2.9 MB, DE channel)".into(),
            ours_ms: median_ms(r, || Ok(twinscope::signal::io::load(&mat, &opts).map(|_| ())?))?,
            reference: "scipy.io.loadmat",
            reference_key: Some("loadmat"),
        });
    }

    // The physics model: 10 s of each bundled rig that exists.
    for (preset, label) in [("mfs_outer", "simulate 10 s of the MFS rig (15-DOF-class, 16384 Hz)"), ("cwru_6205_inner", "simulate 10 s of the CWRU 6205 model (12 kHz)")] {
        if let Ok(mut m) = twinscope::model::preset(preset) {
            m.duration_s = 10.0;
            let built = twinscope::model::Model::build(&m)?;
            let ms = median_ms(r.min(3), || Ok(twinscope::model::run(&built, |_| true).map(|_| ())?))?;
            eprintln!("twinscope bench: {preset}: {} DOFs, {} substeps, step {:.3e} s", built.system.n(), m.substeps, 1.0 / (m.fs_hz * m.substeps as f64));
            rows.push(Row { name: label.into(), ours_ms: ms, reference: "-", reference_key: None });
        }
    }

    let scf_fast = ScfParams { alpha_min_hz: 0.0, alpha_max_hz: 500.0, ..Default::default() };
    let fast_ms = median_ms(r, || Ok(dsp::scf::fast_scf(&x, fs, &scf_fast).map(|_| ())?))?;
    rows.push(Row { name: "fast SCF, α 0–500 Hz (defaults)".into(), ours_ms: fast_ms, reference: "-", reference_key: None });
    let mut slow_ms = None;
    if !args.skip_slow {
        let ms = median_ms(1, || Ok(dsp::scf::cyclic_periodogram(&x, fs, &scf_fast).map(|_| ())?))?;
        slow_ms = Some(ms);
        rows.push(Row { name: "averaged cyclic periodogram (SCF reference), same grid".into(), ours_ms: ms, reference: "-", reference_key: None });
    }

    if !args.skip_slow && mat.exists() {
        // The missing-effect search on a 10 s record (CWRU 105, the inner-race preset without
        // load_zone): calibration, then one trial per candidate, in parallel. Timed for 3, 6 and
        // all candidates to show how it scales with the size of the catalogue.
        use twinscope::compare::{diagnose, LoopOptions};
        use twinscope::model::{EffectKind, Effects};
        let meas = twinscope::signal::io::load(&mat, &twinscope::signal::io::LoadOptions::default())?;
        let mut m = twinscope::model::preset("cwru_6205_inner")?;
        m.effects.enable(EffectKind::Noise);
        let all: Vec<EffectKind> = EffectKind::ALL.into_iter().filter(|k| !m.effects.is_on(*k) && Effects::applicable(*k, &m)).collect();
        // One full search with `opts` (the CWRU demodulation band set here), timed once.
        let mut search_row = |mut opts: LoopOptions, name: String| -> Result<()> {
            opts.compare.envelope_band_hz = [1800.0, 3000.0];
            // Each search starts with nothing integrated: one row's integrations must not
            // speed up the next.
            twinscope::model::clear_loop_cache();
            let ms = median_ms(1, || Ok(diagnose(&m, &meas, &opts, &|_, _| true).map(|_| ())?))?;
            rows.push(Row { name, ours_ms: ms, reference: "-", reference_key: None });
            Ok(())
        };
        for n in [3, 6, all.len()] {
            let opts = LoopOptions { candidates: all[..n.min(all.len())].to_vec(), ..Default::default() };
            search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {n} candidate effects (calibrate + trials)", meas.duration_s()))?;
        }
        // The same full search with every evaluation integrating its machine (no reuse of an
        // integration across measurement effects or seeds: the search before session 50).
        twinscope::model::set_loop_cache_enabled(false);
        let opts = LoopOptions { candidates: all.clone(), ..Default::default() };
        search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {} candidate effects, every evaluation integrated (no reused integration, as before session 50)", meas.duration_s(), all.len()))?;
        twinscope::model::set_loop_cache_enabled(true);
        // The same full search without the unbent redo of a stuck search (the default since
        // session 31; on a real record, far above its floor, it always acts).
        let opts = LoopOptions { candidates: all.clone(), unbend_when_stuck: false, ..Default::default() };
        search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {} candidate effects, without the unbent redo of a stuck search (--no-unbend-when-stuck)", meas.duration_s(), all.len()))?;
        // The same full search without the second start for the top trials (the default since
        // session 48; on 105 it acts in the first, stuck search and never wins).
        let opts = LoopOptions { candidates: all.clone(), uncalibrated_start_top: false, ..Default::default() };
        search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {} candidate effects, without the second start for the top trials (--no-uncalibrated-start-top)", meas.duration_s(), all.len()))?;
        // The same full search followed by the removal trials (`LoopOptions::removal_trials`):
        // the preset's fault and contact nonlinearity taken out in turn, three calibrations on
        // four realisations.
        let opts = LoopOptions { candidates: all.clone(), removal_trials: true, ..Default::default() };
        search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {} candidate effects, then its removal trials (--removal-trials)", meas.duration_s(), all.len()))?;
        // The same full search with the transfer-path correction (16 bands) fitted to every
        // evaluation: one more Welch PSD and one FFT filter per evaluation.
        let mut opts = LoopOptions { candidates: all.clone(), ..Default::default() };
        opts.compare.path_correction_bands = 16;
        search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {} candidate effects, transfer-path correction (16 bands)", meas.duration_s(), all.len()))?;
        // The same full search with every trial started a second time from the uncalibrated
        // values (`LoopOptions::uncalibrated_start`, experimental).
        let opts = LoopOptions { candidates: all.clone(), uncalibrated_start: true, ..Default::default() };
        search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {} candidate effects, every trial also from the uncalibrated values", meas.duration_s(), all.len()))?;
        // The same full search with a force's second grid inside the coarse grid's best cell
        // and its golden section beside the coarse cell's (`LoopOptions::fine_force_scan`).
        let opts = LoopOptions { candidates: all.clone(), fine_force_scan: true, ..Default::default() };
        search_row(opts, format!("missing-effect search, {:.0}-s CWRU record, {} candidate effects, a force's fine cell as a second start (--fine-force-scan)", meas.duration_s(), all.len()))?;
        // The full search on the 15-DOF-class MFS rig, whose integration costs about four times
        // the CWRU model's per simulated second: a 10 s record simulated from `mfs_inner` with
        // a misalignment and noise (fixed seed), searched from the preset with noise on over
        // every applicable effect it lacks, in the seed's 900–1800 Hz band.
        {
            let mut truth = twinscope::model::preset("mfs_inner")?;
            truth.duration_s = 10.0;
            truth.seed = 6001;
            truth.effects.enable(EffectKind::Misalignment);
            truth.effects.enable(EffectKind::Noise);
            let mfs_meas = twinscope::model::simulate(&truth)?;
            let mut mfs = twinscope::model::preset("mfs_inner")?;
            mfs.effects.enable(EffectKind::Noise);
            let mfs_all: Vec<EffectKind> = EffectKind::ALL.into_iter().filter(|k| !mfs.effects.is_on(*k) && Effects::applicable(*k, &mfs)).collect();
            let opts = LoopOptions { candidates: mfs_all.clone(), ..Default::default() };
            twinscope::model::clear_loop_cache();
            let ms = median_ms(1, || Ok(diagnose(&mfs, &mfs_meas, &opts, &|_, _| true).map(|_| ())?))?;
            rows.push(Row { name: format!("missing-effect search, {:.0}-s MFS record (hidden misalignment), all {} candidate effects (calibrate + trials)", mfs_meas.duration_s(), mfs_all.len()), ours_ms: ms, reference: "-", reference_key: None });
            // The same search followed by its removal trials (the fault, the load zone, the
            // gear mesh and the contact nonlinearity alone, each calibrated on four
            // realisations): what making them a default would cost on the 10 s record.
            let opts = LoopOptions { candidates: mfs_all.clone(), removal_trials: true, ..Default::default() };
            twinscope::model::clear_loop_cache();
            let ms = median_ms(1, || Ok(diagnose(&mfs, &mfs_meas, &opts, &|_, _| true).map(|_| ())?))?;
            rows.push(Row { name: format!("missing-effect search, {:.0}-s MFS record (hidden misalignment), all {} candidate effects, then its removal trials (--removal-trials)", mfs_meas.duration_s(), mfs_all.len()), ours_ms: ms, reference: "-", reference_key: None });
        }
    }

    rows.extend(display_rows(r));

    let scipy = if args.no_scipy { None } else { run_scipy(&args.python, &x, fs, &design.taps, &bands, &weights, r) };

    println!("| operation | twinscope (ms) | reference | reference (ms) | speed-up |");
    println!("|---|---:|---|---:|---:|");
    for row in &rows {
        let reference_ms = row.reference_key.and_then(|k| scipy.as_ref().and_then(|s| s.get(k)).and_then(|v| v.as_f64()));
        let (rms, sp) = match reference_ms {
            Some(v) => (format!("{v:.2}"), format!("{:.1}×", v / row.ours_ms)),
            None if row.reference_key.is_some() => ("(scipy not run)".into(), "-".into()),
            None => ("-".into(), "-".into()),
        };
        println!("| {} | {:.2} | {} | {} | {} |", row.name, row.ours_ms, row.reference, rms, sp);
    }
    if let Some(s) = slow_ms {
        println!("\nfast SCF vs averaged cyclic periodogram: {:.1}× faster", s / fast_ms);
    }
    if let Some(v) = scipy.as_ref().and_then(|s| s.get("versions")) {
        println!("reference versions: {v}");
    }
    Ok(())
}

fn run_scipy(python: &str, x: &[f64], fs: f64, taps: &[f64], bands: &[(f64, f64)], weights: &[f64], repeat: usize) -> Option<serde_json::Value> {
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("benches/scipy_reference.py");
    let dir = std::env::temp_dir().join(format!("twinscope-bench-{}", std::process::id()));
    let go = || -> Result<serde_json::Value> {
        std::fs::create_dir_all(&dir)?;
        let to_bytes = |v: &[f64]| v.iter().flat_map(|f| f.to_le_bytes()).collect::<Vec<u8>>();
        std::fs::write(dir.join("x.f64"), to_bytes(x))?;
        std::fs::write(dir.join("taps.f64"), to_bytes(taps))?;
        let mat = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("sample_data/105_de_inner_007_0hp_12k.mat");
        let kurtogram_lengths = dsp::kurtogram::kurtogram_frame_lengths(16, 1024);
        let spec = serde_json::json!({ "fs": fs, "bands": bands, "weights": weights, "numtaps": taps.len(), "repeat": repeat, "mat": mat, "kurtogram_lengths": kurtogram_lengths });
        std::fs::write(dir.join("spec.json"), spec.to_string())?;
        let out = Command::new(python).arg(&script).arg(&dir).output().with_context(|| format!("running {python}"))?;
        if !out.status.success() {
            anyhow::bail!("{}", String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("scipy reference failed"));
        }
        Ok(serde_json::from_slice(&out.stdout)?)
    };
    let r = go();
    let _ = std::fs::remove_dir_all(&dir);
    match r {
        Ok(v) => Some(v),
        Err(e) => {
            eprintln!("twinscope bench: scipy reference not run ({e:#}); install numpy and scipy for python3 to compare");
            None
        }
    }
}
