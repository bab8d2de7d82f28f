//! Fuzz tests of the byte-level loaders (no disk): arbitrary bytes, and valid files with random
//! bytes flipped or cut at a random point, must give `Ok` or `Err` — never a panic. When `Ok`,
//! the signal must be usable (non-empty, finite samples, positive finite rate); when `Err`, the
//! message must start with the file name. 256 cases per property.

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::Config;
use std::path::Path;
use twinscope::signal::io::{csv, mat, wav, IoError, LoadOptions};
use twinscope::signal::{Metadata, Signal};

const FIX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/io");

fn config() -> Config {
    // 256 cases (override with IO_FUZZ_CASES for a deeper run); no regression files written
    // into the shared tree.
    let cases = std::env::var("IO_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256);
    Config { cases, failure_persistence: None, ..Config::default() }
}

fn check(r: Result<Signal, IoError>, file: &str) -> Result<(), TestCaseError> {
    match r {
        Ok(s) => {
            prop_assert!(!s.samples.is_empty());
            prop_assert!(s.samples.iter().all(|x| x.is_finite()));
            prop_assert!(s.fs_hz.is_finite() && s.fs_hz > 0.0);
        }
        Err(e) => {
            let m = e.to_string();
            prop_assert!(m.starts_with(file), "error does not name the file: {}", m);
        }
    }
    Ok(())
}

fn opts_strategy() -> impl Strategy<Value = LoadOptions> {
    (
        prop::option::of(prop_oneof![Just("0".to_string()), Just("1".to_string()), Just("2".to_string()), Just("DE".to_string()), Just("x".to_string()), Just("_time".to_string())]),
        prop::option::of(prop_oneof![Just(1000.0), Just(12000.0), Just(0.5)]),
    )
        .prop_map(|(channel, fs_hz)| LoadOptions { channel, fs_hz, unit: None })
}

/// Flips the given bytes and optionally truncates.
fn mutate(base: &[u8], flips: &[(Index, u8)], cut: Option<Index>) -> Vec<u8> {
    let mut b = base.to_vec();
    for (i, v) in flips {
        let k = i.index(b.len());
        b[k] ^= v | 1;
    }
    if let Some(c) = cut {
        let n = c.index(b.len() + 1);
        b.truncate(n);
    }
    b
}

fn sample_signal() -> Signal {
    let samples = (0..200).map(|i| (i as f64 * 0.37).sin() * 3.0).collect();
    let mut meta = Metadata { shaft_speed_hz: Some(29.95), ..Default::default() };
    meta.extra.insert("k".into(), "v".into());
    Signal { samples, fs_hz: 12000.0, name: "X105_DE_time".into(), unit: "g".into(), meta }
}

fn int16_stereo_wav() -> Vec<u8> {
    let spec = hound::WavSpec { channels: 2, sample_rate: 8000, bits_per_sample: 16, sample_format: hound::SampleFormat::Int };
    let mut cur = std::io::Cursor::new(Vec::new());
    {
        let mut w = hound::WavWriter::new(&mut cur, spec).expect("writer");
        for i in 0..100i16 {
            w.write_sample(i * 100).expect("s");
            w.write_sample(-i).expect("s");
        }
        w.finalize().expect("finalize");
    }
    cur.into_inner()
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(Path::new(FIX).join(name)).expect("fixture")
}

fn flips() -> impl Strategy<Value = Vec<(Index, u8)>> {
    prop::collection::vec((any::<Index>(), any::<u8>()), 0..8)
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn wav_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..600), riff in any::<bool>(), opts in opts_strategy()) {
        let mut b = bytes;
        if riff {
            // Reach past the magic-number check.
            let mut h = b"RIFF\x00\x10\x00\x00WAVEfmt ".to_vec();
            h.extend_from_slice(&b);
            b = h;
        }
        check(wav::read_bytes(&b, "fz.wav", &opts), "fz.wav")?;
        let _ = wav::inspect_bytes(&b, "fz.wav");
    }

    #[test]
    fn wav_valid_file_flipped_or_cut(fl in flips(), cut in prop::option::of(any::<Index>()), stereo in any::<bool>(), opts in opts_strategy()) {
        let base = if stereo { int16_stereo_wav() } else { wav::write_bytes(&sample_signal(), "base.wav").expect("encode") };
        let b = mutate(&base, &fl, cut);
        check(wav::read_bytes(&b, "fz.wav", &opts), "fz.wav")?;
        let _ = wav::inspect_bytes(&b, "fz.wav");
    }

    #[test]
    fn csv_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..600), opts in opts_strategy()) {
        check(csv::read_bytes(&bytes, "fz.csv", &opts), "fz.csv")?;
        let _ = csv::inspect_bytes(&bytes, "fz.csv");
    }

    #[test]
    fn csv_arbitrary_text(text in "([0-9.eE+-]{0,6}[,;\t\"#\n ]?){0,80}|(# twinscope: \\{[a-z\":,0-9{}]{0,30}\n)?(time|t|x|\"a,b\")[,;\t](x|y)\n([0-9.-]{1,4}[,;\t][0-9.a-z-]{1,4}\n){0,20}", opts in opts_strategy()) {
        check(csv::read_str(&text, "fz.csv", &opts), "fz.csv")?;
        let _ = csv::inspect_bytes(text.as_bytes(), "fz.csv");
    }

    #[test]
    fn csv_valid_file_flipped_or_cut(fl in flips(), cut in prop::option::of(any::<Index>()), opts in opts_strategy()) {
        let base = csv::write_string(&sample_signal(), "base.csv").expect("encode").into_bytes();
        let b = mutate(&base, &fl, cut);
        check(csv::read_bytes(&b, "fz.csv", &opts), "fz.csv")?;
        let _ = csv::inspect_bytes(&b, "fz.csv");
    }

    #[test]
    fn mat_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..800), header in any::<bool>(), opts in opts_strategy()) {
        let mut b = bytes;
        if header {
            // A valid 128-byte v5 header, so the element walk and matfile see the random tail.
            let mut h = b"MATLAB 5.0 MAT-file, fuzz".to_vec();
            h.resize(124, b' ');
            h.extend_from_slice(&[0x00, 0x01, b'I', b'M']);
            h.extend_from_slice(&b);
            b = h;
        }
        check(mat::read_bytes(&b, "fz_12k.mat", &opts), "fz_12k.mat")?;
        let _ = mat::inspect_bytes(&b, "fz_12k.mat");
    }

    #[test]
    fn mat_valid_file_flipped_or_cut(fl in flips(), cut in prop::option::of(any::<Index>()), compressed in any::<bool>(), opts in opts_strategy()) {
        let base = fixture(if compressed { "mixed_v7.mat" } else { "mixed_v6.mat" });
        let b = mutate(&base, &fl, cut);
        check(mat::read_bytes(&b, "fz.mat", &opts), "fz.mat")?;
        let _ = mat::inspect_bytes(&b, "fz.mat");
    }

    #[test]
    fn mat_header_region_flipped(fl in prop::collection::vec((0usize..400, any::<u8>()), 1..6), opts in opts_strategy()) {
        // Concentrate flips on the header and the first element tags, where structure lives.
        let mut b = fixture("mixed_v6.mat");
        for (i, v) in fl {
            b[i] ^= v | 1;
        }
        check(mat::read_bytes(&b, "fz.mat", &opts), "fz.mat")?;
        let _ = mat::inspect_bytes(&b, "fz.mat");
    }
}
