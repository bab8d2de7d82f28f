//! Chains: parsing, round trips, addressable intermediates, errors naming stage and parameter,
//! and the seed envelope chain on a bearing-like signal with a known fault frequency.

use twinscope::chain::{preset, Chain, ChainContext, Data, PRESETS};
use twinscope::kinematics::lookup_bearing;
use twinscope::signal::{synth, Signal};

#[test]
fn every_preset_parses_and_round_trips() {
    for (name, text) in PRESETS {
        let c = Chain::from_toml(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!c.stages.is_empty());
        let back = Chain::from_toml(&c.to_toml(), name).unwrap();
        assert_eq!(c, back, "{name} does not round-trip:\n{}", c.to_toml());
    }
}

fn err_of(text: &str) -> String {
    Chain::from_toml(text, "t.toml").unwrap_err().to_string()
}

#[test]
fn bad_chains_name_the_stage_and_parameter() {
    let e = err_of("[[stage]]\nkind = \"wavelet\"\n");
    assert!(e.contains("t.toml") && e.contains("wavelet"), "{e}");
    let e = err_of("[[stage]]\nkind = \"welch\"\nnpersegg = 4\n");
    assert!(e.contains("npersegg") && e.contains("stage 1"), "{e}");
    let e = err_of("[[stage]]\nkind = \"welch\"\ninput = \"later\"\n[[stage]]\nkind = \"normalise\"\nname = \"later\"\n");
    assert!(e.contains("later") && e.contains("earlier"), "{e}");
    let e = err_of("[[stage]]\nkind = \"welch\"\n[[stage]]\nkind = \"welch\"\n");
    assert!(e.contains("used twice"), "{e}");
    let e = err_of("[[stage]]\nkind = \"welch\"\nfault = \"bpfo\"\n");
    assert!(e.contains("fault"), "{e}");
    let e = err_of("name = 3\n[[stage]]\nkind = \"welch\"\n");
    assert!(e.contains("name"), "{e}");
    // a parameter of the wrong type is named, with the stage
    let e = err_of("[[stage]]\nkind = \"bandpass\"\npass_band_hz = \"wide\"\n");
    assert!(e.contains("stage 1 `bandpass`") && e.contains("`pass_band_hz`: ") && e.contains("expected an array of length 2"), "{e}");
    let e = err_of("[[stage]]\nkind = \"normalise\"\n[[stage]]\nkind = \"welch\"\nnperseg = 4096\nnoverlap = \"half\"\n");
    assert!(e.contains("stage 2 `welch`") && e.contains("`noverlap`: "), "{e}");
    let e = err_of("[[stage]]\nkind = \"scf\"\nalpha_max_hz = [1, 2]\nnperseg = 256\n");
    assert!(e.contains("`alpha_max_hz`: ") && !e.contains("`nperseg`"), "{e}");
    let e = err_of("[[stage]]\nmethod = \"peak\"\n");
    assert!(e.contains("kind"), "{e}");
    assert!(preset("nope").unwrap_err().to_string().contains("envelope"));
}

/// A bearing-like signal at 16384 Hz: impacts at the MB ER-12K BPFO (15 Hz shaft) ringing a
/// 1300 Hz resonance (inside the seed's 900–1800 Hz band), 1 % jitter, noise, and a strong
/// low-frequency gear tone outside the band.
fn mfs_outer_race(seconds: f64) -> (Signal, ChainContext) {
    let fs = 16384.0;
    let n = (seconds * fs) as usize;
    let bearing = lookup_bearing("MB ER-12K").unwrap();
    let ff = bearing.fault_frequencies(15.0).unwrap();
    let p = synth::ImpactTrain {
        fault_frequency_hz: ff.bpfo_hz,
        resonance_hz: 1300.0,
        damping_ratio: 0.03,
        jitter_fraction: 0.01,
        modulation_depth: 0.0,
        modulation_hz: 0.0,
        amplitude: 1.0,
    };
    let mut x = synth::impact_train(n, fs, &p, 11);
    let noise = synth::white_noise(n, 0.2, 12);
    let gear = synth::tone(n, fs, 18.0 * 15.0 * 41.5 / 102.0, 2.0, 0.0);
    for i in 0..n {
        x[i] += noise[i] + gear[i];
    }
    let mut s = Signal::new(x, fs, "synthetic MFS", "m/s^2");
    s.meta.shaft_speed_hz = Some(15.0);
    (s, ChainContext { bearing: Some(bearing), shaft_speed_hz: Some(15.0) })
}

#[test]
fn seed_envelope_chain_finds_bpfo_and_keeps_every_intermediate() {
    let (s, ctx) = mfs_outer_race(4.0);
    let bpfo = ctx.fault_frequencies().unwrap().bpfo_hz;
    let chain = preset("envelope").unwrap();
    let mut seen = Vec::new();
    let r = chain.run(&s, &ctx, |i, _, name| seen.push((i, name.to_string()))).unwrap();
    assert_eq!(seen.len(), chain.stages.len() + 1, "progress is reported per stage");
    for st in &chain.stages {
        assert!(r.get(&st.name).is_some(), "stage {} not addressable", st.name);
    }
    assert!(matches!(r.get("raw"), Some(Data::Time(_))));
    assert!(matches!(r.get("bandpass:design"), Some(Data::Fir(_))));
    let Some(Data::Spectrum(es)) = r.get("envelope_spectrum") else { panic!("no envelope spectrum") };
    assert!(es.frequency_hz.last().copied().unwrap() <= 200.0 + es.resolution_hz());
    let (f, _) = es.top_peaks(1, 1.0).unwrap()[0];
    assert!((f - bpfo).abs() / bpfo < 0.01, "top envelope peak {f} Hz, BPFO {bpfo} Hz");
    // The report carries the achieved filter figures and the STSA interval.
    let bp = r.stages.iter().find(|s| s.name == "bandpass").unwrap();
    assert!(bp.report["achieved_stopband_low_db"].as_f64().unwrap() >= 60.0);
    assert!(bp.report["achieved_stopband_high_db"].as_f64().unwrap() >= 80.0);
    let st = r.stages.iter().find(|s| s.name == "stsa").unwrap();
    assert!((st.report["fault_frequency_hz"].as_f64().unwrap() - bpfo).abs() < 1e-9);
}

#[test]
fn stsa_fault_needs_machine_knowledge() {
    let (s, _) = mfs_outer_race(1.0);
    let chain = preset("envelope").unwrap();
    let e = chain.run(&s, &ChainContext::default(), |_, _, _| {}).unwrap_err().to_string();
    assert!(e.contains("stsa") && e.contains("bearing"), "{e}");
}

#[test]
fn wrong_input_type_is_refused() {
    let c = Chain::from_toml("[[stage]]\nkind = \"welch\"\n[[stage]]\nkind = \"normalise\"\n", "t").unwrap();
    let (s, ctx) = mfs_outer_race(1.0);
    let e = c.run(&s, &ctx, |_, _, _| {}).unwrap_err().to_string();
    assert!(e.contains("normalise") && e.contains("time signal"), "{e}");
}

#[test]
fn drs_then_scf_runs_on_the_residual() {
    let (s, ctx) = mfs_outer_race(2.0);
    let c = preset("drs_scf").unwrap();
    let r = c.run(&s, &ctx, |_, _, _| {}).unwrap();
    assert!(matches!(r.get("drs:deterministic"), Some(Data::Time(_))));
    let Some(Data::Scf(m)) = r.get("scf") else { panic!("no scf") };
    assert!(m.alpha_hz.last().copied().unwrap() <= 500.0 + m.alpha_resolution_hz);
}

#[test]
fn scf_stage_gives_enhanced_envelope_spectrum_and_alpha_slices() {
    let (s, ctx) = mfs_outer_race(2.0);
    let bpfo = ctx.fault_frequencies().unwrap().bpfo_hz;
    // DRS first (Sawalhi et al.): the strong gear tone at 109.9 Hz is itself cyclostationary at
    // α = 2 × 109.9 Hz and would dominate the enhanced envelope spectrum of the raw signal.
    let c = Chain::from_toml("[[stage]]\nkind = \"drs\"\n[[stage]]\nkind = \"scf\"\nalpha_max_hz = 300.0\nnperseg = 256\n", "t").unwrap();
    let r = c.run(&s, &ctx, |_, _, _| {}).unwrap();
    for extra in ["ees", "ees_coherence", "alpha_0", "alpha_shaft", "alpha_bpfo", "alpha_bpfi", "alpha_2xbsf", "alpha_ftf"] {
        assert!(matches!(r.get(&format!("scf:{extra}")), Some(Data::Spectrum(_))), "missing scf:{extra}");
    }
    // With α up to 60 Hz, BPFI (74.2 Hz at 15 Hz shaft) is outside the map: no slice for it.
    let narrow = Chain::from_toml("[[stage]]\nkind = \"scf\"\nalpha_max_hz = 60.0\nnperseg = 256\n", "t").unwrap();
    let rn = narrow.run(&s, &ctx, |_, _, _| {}).unwrap();
    assert!(rn.get("scf:alpha_bpfo").is_some() && rn.get("scf:alpha_bpfi").is_none());
    // The α = BPFO slice shows where the impacts put their energy: the 1300 Hz resonance.
    let Some(Data::Spectrum(sl)) = r.get("scf:alpha_bpfo") else { unreachable!() };
    let (f, _) = sl.peak().unwrap();
    assert!((f - 1300.0).abs() <= 2.0 * 64.0, "α = BPFO slice peaks at {f} Hz, resonance 1300 Hz");
    // ... and the enhanced envelope spectrum over that band peaks on a BPFO harmonic (k ≤ 3:
    // a sharp impulse train puts comparable energy in its first harmonics).
    let Some(Data::Scf(map)) = r.get("scf") else { unreachable!() };
    let (a, v) = map.enhanced_envelope_spectrum_in_band(1000.0, 1600.0).unwrap();
    let (ia, _) = a.iter().zip(&v).enumerate().filter(|(_, (a, _))| **a > 5.0).max_by(|x, y| (x.1).1.total_cmp((y.1).1)).map(|(i, (_, v))| (i, *v)).unwrap();
    let k = (a[ia] / bpfo).round();
    assert!((1.0..=3.0).contains(&k) && (a[ia] - k * bpfo).abs() / (k * bpfo) < 0.01, "band EES peak {}, BPFO {bpfo}", a[ia]);
}

#[test]
fn integrate_and_decibel_stages() {
    // 100 Hz acceleration tone of 9.81 m/s² → velocity amplitude 9.81/(2π·100) m/s → in mm/s.
    let fs = 8192.0;
    let x = synth::tone(8192, fs, 100.0, 9.81, 0.0);
    let s = Signal::new(x, fs, "acc", "m/s^2");
    let c = Chain::from_toml(
        "[[stage]]\nkind = \"integrate\"\nscale = 1000.0\nunit = \"mm/s\"\n[[stage]]\nkind = \"spectrum\"\nwindow = \"flattop\"\n[[stage]]\nkind = \"decibel\"\nreference = 1e-6\n",
        "t",
    )
    .unwrap();
    let r = c.run(&s, &ChainContext::default(), |_, _, _| {}).unwrap();
    let Some(Data::Time(v)) = r.get("integrate") else { panic!() };
    assert_eq!(v.unit, "mm/s");
    let Some(Data::Spectrum(sp)) = r.get("spectrum") else { panic!() };
    let want = 9.81 / (2.0 * std::f64::consts::PI * 100.0) * 1000.0;
    let (f, a) = sp.peak().unwrap();
    assert!((f - 100.0).abs() < 0.5 && (a - want).abs() / want < 1e-3, "{f} {a} {want}");
    let Some(Data::Spectrum(db)) = r.get("decibel") else { panic!() };
    let k = sp.values.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0;
    assert!((db.values[k] - 20.0 * (sp.values[k] / 1e-6).log10()).abs() < 1e-9);
    assert!(db.unit.contains("dB re 0.000001") || db.unit.contains("dB re 1e-6"), "{}", db.unit);
    // decibel on a time signal is refused with the stage named.
    let bad = Chain::from_toml("[[stage]]\nkind = \"decibel\"\n", "t").unwrap();
    let e = bad.run(&s, &ChainContext::default(), |_, _, _| {}).unwrap_err().to_string();
    assert!(e.contains("decibel") && e.contains("spectrum"), "{e}");
}
