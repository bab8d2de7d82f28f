//! Signal file I/O: good files (CWRU MAT, scipy-written MAT/WAV fixtures, hound-written WAVs in
//! every supported format, CSV variants, round trips) and bad files (each rejected with a
//! message naming the file and the fault, never a panic).
//!
//! References: tests/fixtures/io/expected.json, made by tests/fixtures/io/make_io.py with
//! scipy.io.loadmat / scipy.io.wavfile (values compared exactly or at the stated tolerance).

use serde_json::Value;
use std::path::{Path, PathBuf};
use twinscope::signal::io::{self, FileFormat, IoError, LoadOptions};
use twinscope::signal::{Metadata, Signal};

const CWRU: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/cwru");
const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/io");

fn expected() -> Value {
    let text = std::fs::read_to_string(Path::new(FIX).join("expected.json")).expect("fixture expected.json");
    serde_json::from_str(&text).expect("valid json")
}

fn fix(name: &str) -> PathBuf {
    Path::new(FIX).join(name)
}

fn opts_ch(ch: &str) -> LoadOptions {
    LoadOptions { channel: Some(ch.into()), ..Default::default() }
}

fn opts_fs(fs: f64) -> LoadOptions {
    LoadOptions { fs_hz: Some(fs), ..Default::default() }
}

/// The error message of a result that must be an error.
fn err<T: std::fmt::Debug>(r: Result<T, IoError>) -> (IoError, String) {
    match r {
        Ok(v) => panic!("expected an error, got {v:?}"),
        Err(e) => {
            let m = e.to_string();
            (e, m)
        }
    }
}

/// Numbers stored as Python `repr` strings (serde_json's float parser is not always exact).
fn floats(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_str().expect("string").parse::<f64>().expect("number")).collect()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write temp file");
    p
}

// ---------------------------------------------------------------- MAT: CWRU ----------------

#[test]
fn cwru_all_files_load_with_rate_speed_unit_and_scipy_values() {
    let exp = expected();
    let cwru = exp["cwru"].as_object().expect("cwru map");
    assert_eq!(cwru.len(), 7, "expected.json lists the 7 CWRU files");
    for (file, e) in cwru {
        let path = Path::new(CWRU).join(file);
        let s = io::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
        let n = e["len"].as_u64().expect("len") as usize;
        assert_eq!(s.name, e["de_name"].as_str().expect("name"), "{file}");
        assert!(s.name.ends_with("_DE_time"));
        assert_eq!(s.len(), n, "{file}");
        assert!(s.len() > 100_000, "{file}");
        let fs = if file.contains("48k") { 48000.0 } else { 12000.0 };
        assert_eq!(s.fs_hz, fs, "{file}");
        let rpm = e["rpm"].as_f64().expect("rpm");
        assert!(rpm == 1796.0 || rpm == 1797.0);
        let shaft = s.meta.shaft_speed_hz.expect("shaft speed");
        assert!((shaft - rpm / 60.0).abs() < 1e-9, "{file}: {shaft}");
        assert_eq!(s.unit, "g");
        assert_eq!(s.meta.channel.as_deref(), Some(s.name.as_str()));
        assert_eq!(s.meta.source.as_deref(), Some(path.display().to_string().as_str()));
        assert_eq!(s.meta.extra.get("fs_source").map(String::as_str), Some("file name"));
        // Against scipy.io.loadmat: first samples bit-exact, sums to 1e-12 relative.
        assert_eq!(&s.samples[..5], floats(&e["first"]).as_slice(), "{file}");
        let sum: f64 = s.samples.iter().sum();
        let sumsq: f64 = s.samples.iter().map(|x| x * x).sum();
        assert!((sum - e["sum"].as_f64().unwrap_or(f64::NAN)).abs() <= 1e-9 * sumsq.sqrt().max(1.0), "{file}: sum {sum}");
        assert!((sumsq / e["sumsq"].as_f64().unwrap_or(f64::NAN) - 1.0).abs() < 1e-12, "{file}");
    }
}

#[test]
fn cwru_channels_by_suffix_and_name() {
    let p = Path::new(CWRU).join("105_de_inner_007_0hp_12k.mat");
    for (ch, want) in [("FE", "X105_FE_time"), ("_BA_time", "X105_BA_time"), ("BA_time", "X105_BA_time"), ("X105_DE_time", "X105_DE_time"), ("de", "X105_DE_time")] {
        let s = io::load(&p, &opts_ch(ch)).unwrap_or_else(|e| panic!("{ch}: {e}"));
        assert_eq!(s.name, want, "channel {ch}");
        assert_eq!(s.unit, "g");
        assert!((s.meta.shaft_speed_hz.unwrap_or(0.0) - 1797.0 / 60.0).abs() < 1e-9);
    }
    let fe = io::load(&p, &opts_ch("FE")).expect("FE");
    let de = io::load(&p, &LoadOptions::default()).expect("DE");
    assert_ne!(fe.samples, de.samples, "FE and DE are different channels");
    // 097 has no base accelerometer: the error lists what is there.
    let p97 = Path::new(CWRU).join("097_normal_0hp_48k.mat");
    let (e, m) = err(io::load(&p97, &opts_ch("BA")));
    assert!(matches!(e, IoError::NoChannel { .. }), "{m}");
    assert!(m.contains("097_normal_0hp_48k.mat") && m.contains("`BA`") && m.contains("X097_DE_time") && m.contains("X097RPM"), "{m}");
    // The RPM scalar is listed but refused as a signal.
    let (e, m) = err(io::load(&p, &opts_ch("RPM")));
    assert!(matches!(e, IoError::Unsupported { .. }) && m.contains("X105RPM") && m.contains("scalar"), "{m}");
}

#[test]
fn cwru_fs_option_overrides_file_name() {
    let p = Path::new(CWRU).join("130_de_outer6_007_0hp_12k.mat");
    let s = io::load(&p, &LoadOptions { fs_hz: Some(11999.5), unit: Some("m/s^2".into()), ..Default::default() }).expect("load");
    assert_eq!(s.fs_hz, 11999.5);
    assert_eq!(s.unit, "m/s^2");
    assert_eq!(s.meta.extra.get("fs_source").map(String::as_str), Some("option"));
}

#[test]
fn cwru_inspect_lists_channels_rate_length_and_speed() {
    let p = Path::new(CWRU).join("105_de_inner_007_0hp_12k.mat");
    let info = io::inspect(&p).expect("inspect");
    assert_eq!(info.format, FileFormat::Mat);
    assert_eq!(info.path, p);
    let names: Vec<&str> = info.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["X105_DE_time", "X105_FE_time", "X105_BA_time"]);
    for c in &info.channels {
        assert_eq!(c.fs_hz, Some(12000.0));
        assert_eq!(c.len, 121265);
        assert!((c.duration_s.unwrap_or(0.0) - 121265.0 / 12000.0).abs() < 1e-12);
        assert_eq!(c.unit.as_deref(), Some("g"));
    }
    assert!((info.shaft_speed_hz.unwrap_or(0.0) - 1797.0 / 60.0).abs() < 1e-9);
    assert!(info.notes.iter().any(|n| n.contains("X105RPM") && n.contains("1797")), "{:?}", info.notes);
    assert!(info.notes.iter().any(|n| n.contains("default channel `X105_DE_time`")), "{:?}", info.notes);
}

#[test]
fn shipped_sample_data_loads() {
    for f in ["105_de_inner_007_0hp_12k.mat", "130_de_outer6_007_0hp_12k.mat"] {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("sample_data").join(f);
        let s = io::load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.fs_hz, 12000.0);
        assert!(s.len() > 100_000);
    }
}

// ---------------------------------------------------------------- MAT: fixtures ------------

#[test]
fn mat_fixture_variables_types_and_rate_variable() {
    let exp = expected();
    for f in ["mixed_v6.mat", "mixed_v7.mat"] {
        let p = fix(f);
        let s = io::load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(s.name, "X001_DE_time");
        assert_eq!(s.fs_hz, 12800.0, "rate from the `fs` variable beats nothing in the name");
        assert_eq!(s.meta.extra.get("fs_source").map(String::as_str), Some("variable fs"));
        assert!((s.meta.shaft_speed_hz.unwrap_or(0.0) - 1750.0 / 60.0).abs() < 1e-12);
        for var in ["X001_DE_time", "X001_FE_time", "counts"] {
            let s = io::load(&p, &opts_ch(var)).unwrap_or_else(|e| panic!("{f} {var}: {e}"));
            let e = &exp["mixed"][var];
            assert_eq!(s.len() as u64, e["len"].as_u64().unwrap_or(0), "{f} {var}");
            // double, single (exactly representable) and int16 are all converted exactly.
            assert_eq!(&s.samples[..5], floats(&e["first"]).as_slice(), "{f} {var}");
            let sum: f64 = s.samples.iter().sum();
            assert!((sum - e["sum"].as_f64().unwrap_or(f64::NAN)).abs() < 1e-9, "{f} {var} {sum}");
        }
        // Complex, matrix and scalar variables are refused by name.
        let (_, m) = err(io::load(&p, &opts_ch("z")));
        assert!(m.contains(f) && m.contains("`z`") && m.contains("complex"), "{m}");
        let (_, m) = err(io::load(&p, &opts_ch("M")));
        assert!(m.contains("`M`") && m.contains("3×4"), "{m}");
        // A suffix matching two variables is ambiguous.
        let (e, m) = err(io::load(&p, &opts_ch("_time")));
        assert!(matches!(e, IoError::Ambiguous { .. }) && m.contains("X001_DE_time, X001_FE_time"), "{m}");
    }
    // Non-numeric variables are listed and refused when stored uncompressed.
    let p6 = fix("mixed_v6.mat");
    for (v, class) in [("label", "char"), ("c", "cell"), ("s", "struct")] {
        let (e, m) = err(io::load(&p6, &opts_ch(v)));
        assert!(matches!(e, IoError::Unsupported { .. }), "{m}");
        assert!(m.contains("mixed_v6.mat") && m.contains(&format!("`{v}`")) && m.contains(class), "{m}");
    }
    let info = io::inspect(&p6).expect("inspect v6");
    let names: Vec<&str> = info.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["X001_DE_time", "X001_FE_time", "counts"]);
    assert!(info.channels.iter().all(|c| c.fs_hz == Some(12800.0)));
    for v in ["`label`", "`c`", "`s`", "`z`", "`M`"] {
        assert!(info.notes.iter().any(|n| n.contains(v)), "{v} in {:?}", info.notes);
    }
    let info7 = io::inspect(&fix("mixed_v7.mat")).expect("inspect v7");
    assert!(info7.notes.iter().any(|n| n.contains("3 compressed non-numeric")), "{:?}", info7.notes);
}

#[test]
fn mat_without_rate_needs_fs() {
    let p = fix("no_fs.mat");
    let (e, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(matches!(e, IoError::NoSamplingRate { .. }));
    assert!(m.ends_with("no_fs.mat holds no sampling rate; pass fs_hz"), "{m}");
    let s = io::load(&p, &opts_fs(1000.0)).expect("with fs");
    let exp = expected();
    assert_eq!(s.name, "acc");
    assert_eq!(s.len(), 200);
    assert_eq!(&s.samples[..5], floats(&exp["no_fs"]["first"]).as_slice());
    assert_eq!(s.unit, "");
    assert_eq!(s.meta.shaft_speed_hz, None);
}

// ---------------------------------------------------------------- WAV ------------------------

/// Integer codes written to channel `ch` of a `bits`-bit file: both extremes, zero, half scale.
fn codes(bits: u16, ch: usize) -> Vec<i32> {
    let full = 1i64 << (bits - 1);
    let v = [-full, full - 1, 0, full / 2, -(full / 4), ch as i64 + 1, -(ch as i64) - 7];
    v.iter().map(|&x| x as i32).collect()
}

#[test]
fn wav_int_and_float_formats_with_1_to_3_channels() {
    let dir = tempfile::tempdir().expect("tempdir");
    for nch in 1..=3u16 {
        for bits in [8u16, 16, 24, 32] {
            let spec = hound::WavSpec { channels: nch, sample_rate: 22050, bits_per_sample: bits, sample_format: hound::SampleFormat::Int };
            let p = dir.path().join(format!("int{bits}_{nch}ch.wav"));
            let mut w = hound::WavWriter::create(&p, spec).expect("create");
            let per: Vec<Vec<i32>> = (0..nch as usize).map(|c| codes(bits, c)).collect();
            for i in 0..per[0].len() {
                for c in per.iter() {
                    match bits {
                        8 => w.write_sample(c[i] as i8).expect("w8"),
                        16 => w.write_sample(c[i] as i16).expect("w16"),
                        _ => w.write_sample(c[i]).expect("w"),
                    }
                }
            }
            w.finalize().expect("finalize");
            for (c, code) in per.iter().enumerate() {
                let s = io::load(&p, &opts_ch(&c.to_string())).unwrap_or_else(|e| panic!("{e}"));
                let want: Vec<f64> = code.iter().map(|&k| k as f64 / (1u64 << (bits - 1)) as f64).collect();
                assert_eq!(s.samples, want, "{bits}-bit, {nch} ch, channel {c}");
                assert_eq!(s.samples[0], -1.0, "most negative code is -1.0 full scale");
                assert_eq!(s.samples[3], 0.5);
                assert_eq!(s.fs_hz, 22050.0);
                assert_eq!(s.meta.channel.as_deref(), Some(c.to_string().as_str()));
                assert_eq!(s.name, format!("int{bits}_{nch}ch_ch{c}"));
            }
            let (e, m) = err(io::load(&p, &opts_ch(&nch.to_string())));
            assert!(matches!(e, IoError::NoChannel { .. }) && m.contains(&format!("no channel `{nch}`")), "{m}");
            let info = io::inspect(&p).expect("inspect");
            assert_eq!(info.channels.len(), nch as usize);
            assert!(info.channels.iter().all(|c| c.len == 7 && c.fs_hz == Some(22050.0)));
            assert!(info.notes[0].contains(&format!("{bits}-bit integer")), "{:?}", info.notes);
        }
        let spec = hound::WavSpec { channels: nch, sample_rate: 48000, bits_per_sample: 32, sample_format: hound::SampleFormat::Float };
        let p = dir.path().join(format!("float_{nch}ch.wav"));
        let mut w = hound::WavWriter::create(&p, spec).expect("create");
        let vals = [1.5f32, -2.25, 0.1, 1e-30, -7.0];
        for v in vals {
            for c in 0..nch {
                w.write_sample(v * (c + 1) as f32).expect("w");
            }
        }
        w.finalize().expect("finalize");
        for c in 0..nch as usize {
            let s = io::load(&p, &opts_ch(&c.to_string())).expect("load float");
            let want: Vec<f64> = vals.iter().map(|&v| (v * (c + 1) as f32) as f64).collect();
            assert_eq!(s.samples, want, "float, {nch} ch, channel {c}: as-is, no clipping");
        }
    }
}

#[test]
fn wav_written_by_scipy_matches_reference() {
    let exp = expected();
    let p = fix("scipy_pcm16_stereo.wav");
    for c in 0..2 {
        let s = io::load(&p, &opts_ch(&c.to_string())).expect("load");
        assert_eq!(s.fs_hz, 8000.0);
        assert_eq!(s.samples, floats(&exp["wav_pcm16_stereo"][format!("ch{c}")]), "channel {c}");
    }
    let s = io::load(&fix("scipy_float32_mono.wav"), &LoadOptions::default()).expect("float");
    assert_eq!(s.fs_hz, 44100.0);
    assert_eq!(s.samples, floats(&exp["wav_float32_mono"]["ch0"]));
}

#[test]
fn wav_tone_amplitude_and_rms_have_physical_meaning() {
    // A 16-bit tone at half full scale: peak 0.5, rms 0.5/sqrt(2), duration n/fs.
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("tone.wav");
    let spec = hound::WavSpec { channels: 1, sample_rate: 8000, bits_per_sample: 16, sample_format: hound::SampleFormat::Int };
    let mut w = hound::WavWriter::create(&p, spec).expect("create");
    let n = 8000;
    for i in 0..n {
        let x = 16384.0 * (2.0 * std::f64::consts::PI * 1000.0 * i as f64 / 8000.0).sin();
        w.write_sample(x.round() as i16).expect("w");
    }
    w.finalize().expect("finalize");
    let s = io::load(&p, &LoadOptions::default()).expect("load");
    let peak = s.samples.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let rms = (s.samples.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
    assert!((peak - 0.5).abs() < 2e-4, "peak {peak}");
    assert!((rms - 0.5 / 2f64.sqrt()).abs() < 1e-4, "rms {rms}");
    assert_eq!(s.duration_s(), 1.0);
}

fn rich_signal(n: usize, fs: f64, amp: f64) -> Signal {
    let mut seed = 0x9E3779B97F4A7C15u64;
    let samples = (0..n)
        .map(|_| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            amp * ((seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0)
        })
        .collect();
    let mut extra = std::collections::BTreeMap::new();
    extra.insert("load_hp".to_string(), "0".to_string());
    extra.insert("note".to_string(), "comma, \"quote\" and\nnewline".to_string());
    Signal {
        samples,
        fs_hz: fs,
        name: "X105_DE_time".into(),
        unit: "g".into(),
        meta: Metadata {
            shaft_speed_hz: Some(1797.0 / 60.0),
            source: Some("/data/105.mat".into()),
            channel: Some("X105_DE_time".into()),
            bearing: Some("SKF 6205-2RS".into()),
            extra,
        },
    }
}

#[test]
fn wav_round_trip_keeps_f32_values_and_all_metadata() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("rt.wav");
    // Amplitude 5 exceeds ±1 (no clipping); fs not an integer (header rounds, sidecar exact).
    let sig = rich_signal(5000, 12000.5, 5.0);
    io::save(&sig, &p).expect("save");
    assert!(dir.path().join("rt.wav.json").is_file(), "sidecar written");
    let back = io::load(&p, &LoadOptions::default()).expect("load");
    let want: Vec<f64> = sig.samples.iter().map(|&x| x as f32 as f64).collect();
    assert_eq!(back.samples, want, "values equal to f32 precision");
    let max_err = sig.samples.iter().zip(&back.samples).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
    assert!(max_err <= 5.0 * f32::EPSILON as f64, "{max_err}");
    assert_eq!(back.fs_hz, 12000.5);
    assert_eq!(back.name, sig.name);
    assert_eq!(back.unit, sig.unit);
    let mut meta = sig.meta.clone();
    meta.source = Some(p.display().to_string());
    assert_eq!(back.meta, meta, "metadata equal (source = file read)");
    // Without the sidecar: header rate (rounded) and default name.
    std::fs::remove_file(dir.path().join("rt.wav.json")).expect("rm");
    let bare = io::load(&p, &LoadOptions::default()).expect("load bare");
    assert_eq!(bare.fs_hz, 12001.0);
    assert_eq!(bare.name, "rt_ch0");
    assert_eq!(bare.samples, want);
    // A sidecar that contradicts the header is an error naming the sidecar.
    std::fs::write(dir.path().join("rt.wav.json"), r#"{"fs_hz": 44100.0}"#).expect("w");
    let (e, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(matches!(e, IoError::Sidecar { .. }) && m.contains("rt.wav.json") && m.contains("44100"), "{m}");
    std::fs::write(dir.path().join("rt.wav.json"), r#"{"unit": "g", "colour": 1}"#).expect("w");
    let (_, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(m.contains("rt.wav.json") && m.contains("colour"), "{m}");
}

// ---------------------------------------------------------------- CSV ------------------------

#[test]
fn csv_variants_header_delimiters_time_column_and_fs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = [0.5, -1.25, 3.0, 1e-3, -2.5e6];
    let rows = |d: &str, time: bool| -> String {
        x.iter().enumerate().map(|(i, v)| if time { format!("{}{d}{v}\n", i as f64 * 0.001) } else { format!("{v}\n") }).collect()
    };
    for (delim, dname) in [(",", "comma"), (";", "semicolon"), ("\t", "tab")] {
        // Header with a time column: fs = 1000 Hz from the time column.
        let text = format!("# rig 3, sensor A\ntime{delim}accel\n{}", rows(delim, true));
        let p = write(dir.path(), &format!("{dname}_hdr.csv"), text.as_bytes());
        let s = io::load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{dname}: {e}"));
        assert_eq!(s.samples, x, "{dname}");
        assert_eq!(s.fs_hz, 1000.0, "{dname}");
        assert_eq!(s.name, "accel");
        assert_eq!(s.meta.channel.as_deref(), Some("accel"));
        // No header, two columns, no fs: the first column is time.
        let p = write(dir.path(), &format!("{dname}_nohdr.csv"), rows(delim, true).as_bytes());
        let s = io::load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{dname}: {e}"));
        assert_eq!(s.samples, x);
        assert_eq!(s.fs_hz, 1000.0);
        // fs given: two header-less columns are both channels; default the last.
        let s = io::load(&p, &opts_fs(250.0)).expect("fs given");
        assert_eq!(s.samples, x);
        assert_eq!(s.fs_hz, 250.0);
        let s0 = io::load(&p, &LoadOptions { channel: Some("0".into()), fs_hz: Some(250.0), unit: None }).expect("col 0");
        assert_eq!(s0.samples, [0.0, 0.001, 0.002, 0.003, 0.004]);
    }
    // One column without header: fs needed.
    let p = write(dir.path(), "one.csv", rows(",", false).as_bytes());
    let (e, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(matches!(e, IoError::NoSamplingRate { .. }) && m.contains("one.csv"), "{m}");
    let s = io::load(&p, &LoadOptions { fs_hz: Some(51200.0), unit: Some("V".into()), channel: None }).expect("one col");
    assert_eq!((s.samples.as_slice(), s.fs_hz, s.name.as_str(), s.unit.as_str()), (&x[..], 51200.0, "one", "V"));
    // Several columns chosen by name (any case) or index; time header `Time (s)`; CRLF; quotes.
    let text = "\"Time (s)\",\"ax\",ay,az\r\n0,1,2,3\r\n0.5,4,5,6\r\n\r\n1.0,7,8,9\r\n";
    let p = write(dir.path(), "multi.csv", text.as_bytes());
    let s = io::load(&p, &LoadOptions::default()).expect("default");
    assert_eq!((s.name.as_str(), s.samples.as_slice(), s.fs_hz), ("az", &[3.0, 6.0, 9.0][..], 2.0));
    assert_eq!(io::load(&p, &opts_ch("AY")).expect("ay").samples, [2.0, 5.0, 8.0]);
    assert_eq!(io::load(&p, &opts_ch("1")).expect("1").samples, [1.0, 4.0, 7.0]);
    let info = io::inspect(&p).expect("inspect");
    let names: Vec<&str> = info.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["ax", "ay", "az"]);
    assert!(info.channels.iter().all(|c| c.len == 3 && c.fs_hz == Some(2.0) && c.duration_s == Some(1.5)));
    // A time column that does not start at zero is recorded.
    let p = write(dir.path(), "t0.csv", b"t,x\n10.0,1\n10.5,2\n11.0,3\n");
    let s = io::load(&p, &LoadOptions::default()).expect("t0");
    assert_eq!((s.fs_hz, s.meta.extra.get("t0_s").map(String::as_str)), (2.0, Some("10.0")));
}

#[test]
fn csv_time_column_gives_rate_and_duration() {
    // Physical meaning: a 12 kHz time column printed at full precision gives fs = 12000 exactly
    // and duration n/fs; integral of x^2 dt over a unit-amplitude 50 Hz tone over 1 s = 1/2.
    let n = 12000;
    let mut text = String::from("time_s,x\n");
    for i in 0..n {
        let t = i as f64 / 12000.0;
        text.push_str(&format!("{t:?},{:?}\n", (2.0 * std::f64::consts::PI * 50.0 * t).sin()));
    }
    let s = twinscope::signal::io::csv::read_str(&text, "tone.csv", &LoadOptions::default()).expect("read");
    assert_eq!(s.fs_hz, 12000.0);
    assert_eq!(s.duration_s(), 1.0);
    let energy: f64 = s.samples.iter().map(|x| x * x / s.fs_hz).sum();
    assert!((energy - 0.5).abs() < 1e-12, "{energy}");
}

#[test]
fn csv_round_trip_is_exact_with_metadata() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("rt.csv");
    let sig = rich_signal(3000, 25600.0, 1e-3);
    io::save(&sig, &p).expect("save");
    let text = std::fs::read_to_string(&p).expect("read");
    assert!(text.starts_with("# twinscope: {"), "{}", &text[..80]);
    assert!(text.lines().nth(1) == Some("time_s,X105_DE_time"));
    let back = io::load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(back.samples, sig.samples, "bit-exact");
    assert_eq!((back.fs_hz, back.name.as_str(), back.unit.as_str()), (sig.fs_hz, sig.name.as_str(), sig.unit.as_str()));
    let mut meta = sig.meta.clone();
    meta.source = Some(p.display().to_string());
    assert_eq!(back.meta, meta);
    // A non-integer rate and an awkward name survive too.
    let mut odd = rich_signal(50, 1234.567, 10.0);
    odd.name = "a,\"b\" 3".into();
    let p2 = dir.path().join("odd.CSV");
    io::save(&odd, &p2).expect("save odd");
    let back = io::load(&p2, &LoadOptions::default()).expect("load odd");
    assert_eq!((back.samples.as_slice(), back.fs_hz, back.name.as_str()), (odd.samples.as_slice(), 1234.567, odd.name.as_str()));
}

// ---------------------------------------------------------------- bad input ------------------

#[test]
fn corrupt_and_truncated_wav() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = write(dir.path(), "garbage.wav", b"this is not a RIFF file at all, just text bytes....");
    let (e, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(matches!(e, IoError::CorruptWav { .. }), "{m}");
    assert!(m.contains("garbage.wav: truncated or corrupt WAV ("), "{m}");
    assert!(io::inspect(&p).is_err());
    // Valid header, data cut short.
    let sig = Signal::new((0..1000).map(|i| i as f64 / 1000.0).collect(), 8000.0, "x", "");
    let bytes = io::wav::write_bytes(&sig, "mem.wav").expect("encode");
    let data_at = bytes.windows(4).position(|w| w == b"data").expect("data chunk") + 8;
    let p = write(dir.path(), "cut.wav", &bytes[..data_at + 500]);
    let (e, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(matches!(e, IoError::CorruptWav { .. }), "{m}");
    assert!(m.contains("cut.wav: truncated or corrupt WAV") && m.contains("sample 125 of 1000") && m.contains("unexpected end of data"), "{m}");
    // NaN in a float WAV is named by position.
    let mut bytes = io::wav::write_bytes(&sig, "mem.wav").expect("encode");
    bytes[data_at + 4 * 17..data_at + 4 * 18].copy_from_slice(&f32::NAN.to_le_bytes());
    let (e, m) = err(io::wav::read_bytes(&bytes, "nan.wav", &LoadOptions::default()));
    assert!(matches!(e, IoError::NonFinite { index: 17, .. }) && m.contains("nan.wav") && m.contains("sample 17"), "{m}");
    // Channel that is not an index.
    let (_, m) = err(io::wav::read_bytes(&io::wav::write_bytes(&sig, "m.wav").expect("enc"), "m.wav", &opts_ch("left")));
    assert!(m.contains("m.wav: no channel `left`; channels: 0"), "{m}");
}

#[test]
fn truncated_and_foreign_mat() {
    let dir = tempfile::tempdir().expect("tempdir");
    let full = std::fs::read(Path::new(CWRU).join("105_de_inner_007_0hp_12k.mat")).expect("cwru");
    let p = write(dir.path(), "105_cut_12k.mat", &full[..1000]);
    let (e, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(matches!(e, IoError::CorruptMat { .. }), "{m}");
    assert!(m.contains("105_cut_12k.mat") && m.contains("truncated"), "{m}");
    assert!(io::inspect(&p).is_err());
    // Cut inside the last variable: still reported (matfile alone would drop it silently).
    let p = write(dir.path(), "105_end_12k.mat", &full[..full.len() - 3]);
    let (_, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(m.contains("truncated"), "{m}");
    let p = write(dir.path(), "junk.mat", &[0x42u8; 300]);
    let (_, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(m.contains("junk.mat") && m.contains("not a MATLAB level-5 MAT-file"), "{m}");
    let mut h = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon".to_vec();
    h.resize(600, b' ');
    let (_, m) = err(io::mat::read_bytes(&h, "v73.mat", &LoadOptions::default()));
    assert!(m.contains("v73.mat") && m.contains("HDF5"), "{m}");
    let (_, m) = err(io::mat::read_bytes(b"MATLAB 5.0", "short.mat", &LoadOptions::default()));
    assert!(m.contains("short.mat") && m.contains("too short"), "{m}");
}

#[test]
fn empty_files_of_each_format() {
    let dir = tempfile::tempdir().expect("tempdir");
    for f in ["e.wav", "e.csv", "e.mat"] {
        let p = write(dir.path(), f, b"");
        let (e, m) = err(io::load(&p, &LoadOptions::default()));
        assert!(matches!(e, IoError::EmptyFile { .. }), "{m}");
        assert_eq!(m, format!("{}: empty file", p.display()));
        assert!(matches!(io::inspect(&p), Err(IoError::EmptyFile { .. })));
    }
    // Only comments / only a header.
    let p = write(dir.path(), "c.csv", b"# nothing here\n\n");
    let (_, m) = err(io::load(&p, &opts_fs(1.0)));
    assert!(m.contains("c.csv") && m.contains("no data rows"), "{m}");
    let p = write(dir.path(), "h.csv", b"time,x\n");
    let (_, m) = err(io::load(&p, &opts_fs(1.0)));
    assert!(m.contains("h.csv") && m.contains("header on line 1 only"), "{m}");
}

#[test]
fn csv_bad_cells_and_time_columns() {
    let read = |text: &str, opts: &LoadOptions| twinscope::signal::io::csv::read_str(text, "data.csv", opts);
    let o = LoadOptions::default();
    let (e, m) = err(read("time,x\n0,1\n0.1,abc\n0.2,3\n", &o));
    assert!(matches!(e, IoError::Csv { line: 3, column: 2, .. }));
    assert_eq!(m, "data.csv line 3, column 2: `abc` is not a number");
    let (_, m) = err(read("time;x\n0;1\n0.1;2\n0.2;NaN\n", &o));
    assert_eq!(m, "data.csv line 4, column 2: `NaN` is not a finite number");
    let (_, m) = err(read("1\n2\n-inf\n", &opts_fs(10.0)));
    assert_eq!(m, "data.csv line 3, column 1: `-inf` is not a finite number");
    let (_, m) = err(read("t,x\n0,1\n0.1,2\n0.25,3\n0.3,4\n", &o));
    assert!(m.starts_with("data.csv line 4, column 1: time column `t` is not uniformly spaced"), "{m}");
    assert!(m.contains("pass fs_hz"), "{m}");
    let info = io::csv::inspect_bytes(b"t,x\n0,1\n0.1,2\n0.25,3\n0.3,4\n", "data.csv").expect("inspect lists anyway");
    assert_eq!(info.channels[0].fs_hz, None);
    assert!(info.notes.iter().any(|n| n.contains("line 4") && n.contains("not uniformly spaced")), "{:?}", info.notes);
    // Given fs, the time column is not checked.
    assert_eq!(read("t,x\n0,1\n0.1,2\n0.25,3\n0.3,4\n", &opts_fs(10.0)).expect("fs").samples, [1.0, 2.0, 3.0, 4.0]);
    let (_, m) = err(read("t,x\n0,1\n0,2\n", &o));
    assert!(m.contains("line 3") && m.contains("not increasing"), "{m}");
    let (_, m) = err(read("t,x\n0,1\n", &o));
    assert!(m.contains("at least 2 rows"), "{m}");
    let (_, m) = err(read("t,x\n0,1\n1,2,3\n", &o));
    assert!(m.starts_with("data.csv line 3: expected 2 `,`-separated columns (as on line 1), found 3"), "{m}");
    let (_, m) = err(read("t,x\n0,1\n1,\n", &o));
    assert_eq!(m, "data.csv line 3, column 2: empty cell");
    let (_, m) = err(read("# twinscope: {not json\nt,x\n0,1\n1,2\n", &o));
    assert!(m.starts_with("data.csv line 1: malformed `# twinscope:` metadata comment"), "{m}");
    let (_, m) = err(twinscope::signal::io::csv::read_bytes(b"t,x\n0,1\n\xff\xfe,2\n", "bin.csv", &o));
    assert!(m.contains("bin.csv line 3") && m.contains("not UTF-8"), "{m}");
    let (e, m) = err(read("time,a,b\n0,1,2\n1,3,4\n", &opts_ch("c")));
    assert!(matches!(e, IoError::NoChannel { .. }));
    assert_eq!(m, "data.csv: no column `c`; columns: a (1), b (2)");
    let (_, m) = err(read("time,a,b\n0,1,2\n1,3,4\n", &opts_ch("3")));
    assert!(m.contains("no column `3`"), "{m}");
}

#[test]
fn unknown_channel_extension_missing_file_and_bad_options() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = Path::new(CWRU).join("118_de_ball_007_0hp_12k.mat");
    let (e, m) = err(io::load(&p, &opts_ch("foo")));
    assert!(matches!(e, IoError::NoChannel { .. }));
    assert!(m.contains("118_de_ball_007_0hp_12k.mat: no variable `foo`; variables: X118_DE_time, X118_FE_time, X118_BA_time, X118RPM"), "{m}");
    let p = write(dir.path(), "x.foo", b"1,2\n");
    let (e, m) = err(io::load(&p, &LoadOptions::default()));
    assert!(matches!(e, IoError::UnknownFormat { .. }));
    assert!(m.contains("x.foo: unknown file extension `foo`"), "{m}");
    let (_, m) = err(io::load(Path::new("/nonexistent/dir/sig.WAV"), &LoadOptions::default()));
    assert!(m.starts_with("/nonexistent/dir/sig.WAV: cannot read file"), "{m}");
    let (_, m) = err(io::load(Path::new("noext"), &LoadOptions::default()));
    assert!(m.contains("noext: unknown file extension `(none)`"), "{m}");
    let p = Path::new(CWRU).join("105_de_inner_007_0hp_12k.mat");
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let (e, m) = err(io::load(&p, &opts_fs(bad)));
        assert!(matches!(e, IoError::InvalidParameter { .. }) && m.contains("fs_hz"), "{m}");
    }
    let (_, m) = err(io::load(&p, &opts_ch("  ")));
    assert!(m.contains("`channel`"), "{m}");
    // LoadOptions embeds in TOML and rejects unknown keys.
    let o: LoadOptions = toml::from_str("channel = \"DE\"\nfs_hz = 12000.0").expect("toml");
    assert_eq!(o, LoadOptions { channel: Some("DE".into()), fs_hz: Some(12000.0), unit: None });
    assert!(toml::from_str::<LoadOptions>("chanel = \"DE\"").is_err());
}

#[test]
fn save_rejects_what_it_cannot_write() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ok = Signal::new(vec![0.0, 1.0], 100.0, "x", "");
    let (_, m) = err(io::save(&ok, &dir.path().join("x.mat")));
    assert!(m.contains("x.mat") && m.contains("no MAT writer"), "{m}");
    let (_, m) = err(io::save(&ok, &dir.path().join("x.flac")));
    assert!(m.contains("unknown file extension `flac`"), "{m}");
    let mut nan = ok.clone();
    nan.samples[1] = f64::NAN;
    for f in ["n.wav", "n.csv"] {
        let (e, m) = err(io::save(&nan, &dir.path().join(f)));
        assert!(matches!(e, IoError::NonFinite { index: 1, .. }) && m.contains(f), "{m}");
    }
    let empty = Signal::new(vec![], 100.0, "x", "");
    assert!(matches!(io::save(&empty, &dir.path().join("e.csv")), Err(IoError::NoSamples { .. })));
    let bad_fs = Signal::new(vec![1.0], 0.0, "x", "");
    assert!(matches!(io::save(&bad_fs, &dir.path().join("f.wav")), Err(IoError::InvalidParameter { .. })));
    let slow = Signal::new(vec![1.0], 0.2, "x", "");
    let (_, m) = err(io::save(&slow, &dir.path().join("slow.wav")));
    assert!(m.contains("slow.wav") && m.contains("save as .csv"), "{m}");
    io::save(&slow, &dir.path().join("slow.csv")).expect("csv takes any rate");
    let big = Signal::new(vec![1e300], 10.0, "x", "");
    let (_, m) = err(io::save(&big, &dir.path().join("big.wav")));
    assert!(m.contains("32-bit float range"), "{m}");
}
