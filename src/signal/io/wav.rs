//! WAV (RIFF WAVE) reader and writer, via `hound`.
//!
//! Reading: 8/16/24/32-bit integer PCM and 32-bit IEEE float, any number of channels
//! (interleaved). Integer samples are scaled to ±1.0 full scale: `x = k / 2^(b-1)` for a `b`-bit
//! sample `k` (8-bit files are unsigned on disk; hound re-centres them to −128..127 first), so
//! a 16-bit sample of 16384 reads as 0.5 and the most negative code reads as exactly −1.0.
//! Float samples are returned as-is (no clipping). The channel is a 0-based index.
//!
//! Writing: mono 32-bit float, samples as-is (no scaling, no clipping; values are rounded to
//! f32), sampling rate rounded to an integer in the header; the exact rate, name, unit and all
//! metadata go to the JSON sidecar written by [`super::save`].
//!
//! `hound` parses untrusted bytes; its decode is wrapped in `std::panic::catch_unwind` so that
//! a panic inside the dependency on a hostile file becomes an [`IoError::CorruptWav`] instead of
//! aborting the caller (the default panic hook may still print the message to stderr).
//!
//! References: Microsoft/IBM, "Multimedia Programming Interface and Data Specifications 1.0"
//! (1991), RIFF WAVE chapter; Microsoft, "WAVEFORMATEXTENSIBLE" documentation.

use super::sidecar::Sidecar;
use super::{check_samples, stem_of, validate_opts, ChannelInfo, FileFormat, FileInfo, IoError, LoadOptions};
use crate::signal::Signal;
use hound::{SampleFormat, WavReader, WavSpec};
use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

fn corrupt(file: &str, reason: impl Into<String>) -> IoError {
    IoError::CorruptWav { file: file.into(), reason: reason.into() }
}

fn describe(e: &hound::Error) -> String {
    match e {
        hound::Error::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof || io.to_string().contains("read enough bytes") => {
            "unexpected end of data: the file is shorter than its header says".into()
        }
        other => other.to_string(),
    }
}

fn header(bytes: &[u8], file: &str) -> Result<WavSpec, IoError> {
    if bytes.is_empty() {
        return Err(IoError::EmptyFile { file: file.into() });
    }
    let r = catch_unwind(AssertUnwindSafe(|| WavReader::new(Cursor::new(bytes)).map(|r| (r.spec(), r.duration()))));
    match r {
        Ok(Ok((spec, _))) => Ok(spec),
        Ok(Err(e)) => Err(corrupt(file, describe(&e))),
        Err(_) => Err(corrupt(file, "the WAV parser panicked on this input")),
    }
}

fn format_name(spec: &WavSpec) -> String {
    match spec.sample_format {
        SampleFormat::Int => format!("{}-bit integer PCM, scaled to ±1.0 full scale", spec.bits_per_sample),
        SampleFormat::Float => format!("{}-bit float", spec.bits_per_sample),
    }
}

/// Decodes channel `ch` of an interleaved WAV; errors name the file and the sample reached.
fn decode(bytes: &[u8], file: &str, ch: usize) -> Result<(WavSpec, Vec<f64>), IoError> {
    let r = catch_unwind(AssertUnwindSafe(|| -> Result<(WavSpec, Vec<f64>), IoError> {
        let mut reader = WavReader::new(Cursor::new(bytes)).map_err(|e| corrupt(file, describe(&e)))?;
        let spec = reader.spec();
        let nch = spec.channels as usize;
        let frames = reader.duration() as usize;
        let bytes_per = (spec.bits_per_sample as usize).div_ceil(8).max(1);
        // The header may claim more data than the file holds: bound the allocation by the bytes.
        let mut out = Vec::with_capacity(frames.min(bytes.len() / (bytes_per * nch.max(1))));
        let total = reader.len() as usize;
        match (spec.sample_format, spec.bits_per_sample) {
            (SampleFormat::Int, b @ (8 | 16 | 24 | 32)) => {
                let scale = 1.0 / (1u64 << (b - 1)) as f64;
                for (i, s) in reader.samples::<i32>().enumerate() {
                    let v = s.map_err(|e| corrupt(file, format!("sample {i} of {total}: {}", describe(&e))))?;
                    if i % nch == ch {
                        out.push(v as f64 * scale);
                    }
                }
            }
            (SampleFormat::Float, 32) => {
                for (i, s) in reader.samples::<f32>().enumerate() {
                    let v = s.map_err(|e| corrupt(file, format!("sample {i} of {total}: {}", describe(&e))))?;
                    if i % nch == ch {
                        out.push(v as f64);
                    }
                }
            }
            (_, b) => {
                return Err(corrupt(
                    file,
                    format!("unsupported sample format {} ({b} bits); supported: 8/16/24/32-bit integer, 32-bit float", format_name(&spec)),
                ))
            }
        }
        Ok((spec, out))
    }));
    match r {
        Ok(res) => res,
        Err(_) => Err(corrupt(file, "the WAV parser panicked on this input")),
    }
}

fn parse_channel(file: &str, opts: &LoadOptions, nch: usize) -> Result<usize, IoError> {
    let available = || (0..nch).map(|i| i.to_string()).collect::<Vec<_>>();
    match &opts.channel {
        None => Ok(0),
        Some(c) => match c.trim().parse::<usize>() {
            Ok(i) if i < nch => Ok(i),
            _ => Err(IoError::NoChannel { file: file.into(), kind: "channel", wanted: c.clone(), available: available() }),
        },
    }
}

fn sidecar_fs(file: &str, spec: &WavSpec, side: Option<&Sidecar>) -> Result<Option<f64>, IoError> {
    match side.and_then(|s| s.fs_hz) {
        None => Ok(None),
        Some(fs) if (fs - spec.sample_rate as f64).abs() <= 0.5 => Ok(Some(fs)),
        Some(fs) => Err(IoError::Sidecar {
            file: format!("{file}.json"),
            reason: format!("fs_hz = {fs} disagrees with the WAV header rate {} Hz; fix or delete the sidecar", spec.sample_rate),
        }),
    }
}

/// Reads one channel of WAV bytes (no sidecar). `file` names the file in errors and in
/// `meta.source`. See [`read_with_sidecar`].
pub fn read_bytes(bytes: &[u8], file: &str, opts: &LoadOptions) -> Result<Signal, IoError> {
    read_with_sidecar(bytes, file, opts, None)
}

/// Reads one channel of WAV bytes, applying a sidecar record when given.
///
/// Arguments: `bytes` (the whole file), `file` (label for errors and `meta.source`), `opts`
/// (`channel` = 0-based index, default 0; `fs_hz`/`unit` overrides), `side` (sidecar).
///
/// Returns samples scaled to ±1.0 full scale (integer formats) or as stored (float), `fs_hz`
/// = `opts.fs_hz` > sidecar `fs_hz` (must agree with the header within 0.5 Hz) > header rate.
/// Name: sidecar name (mono files) else `<stem>_ch<i>`; unit: `opts.unit` > sidecar > "".
pub fn read_with_sidecar(bytes: &[u8], file: &str, opts: &LoadOptions, side: Option<&Sidecar>) -> Result<Signal, IoError> {
    validate_opts(file, opts)?;
    let spec = header(bytes, file)?;
    let nch = spec.channels as usize;
    let ch = parse_channel(file, opts, nch)?;
    let (spec, samples) = decode(bytes, file, ch)?;
    let chan_name = ch.to_string();
    check_samples(file, &chan_name, &samples)?;
    let fs_side = sidecar_fs(file, &spec, side)?;
    let fs_hz = match (opts.fs_hz, fs_side) {
        (Some(fs), _) | (None, Some(fs)) => fs,
        (None, None) => {
            if spec.sample_rate == 0 {
                return Err(corrupt(file, "the header sampling rate is 0 Hz; pass fs_hz"));
            }
            spec.sample_rate as f64
        }
    };
    let mut signal = Signal::new(samples, fs_hz, format!("{}_ch{ch}", stem_of(file)), "");
    signal.meta.channel = Some(chan_name);
    if let Some(s) = side {
        let channel = signal.meta.channel.take();
        signal.meta = s.meta.clone();
        if nch == 1 {
            if let Some(n) = &s.name {
                signal.name = n.clone();
            }
            if signal.meta.channel.is_none() {
                signal.meta.channel = channel;
            }
        } else {
            signal.meta.channel = channel;
        }
        if let Some(u) = &s.unit {
            signal.unit = u.clone();
        }
    }
    if let Some(u) = &opts.unit {
        signal.unit = u.clone();
    }
    signal.meta.source = Some(file.to_string());
    Ok(signal)
}

/// Lists the channels of WAV bytes (no sidecar).
pub fn inspect_bytes(bytes: &[u8], file: &str) -> Result<FileInfo, IoError> {
    inspect_with_sidecar(bytes, file, None)
}

/// Lists the channels of WAV bytes, with the sidecar's rate, unit and shaft speed if given.
/// Decodes channel 0 fully so that truncated data is reported.
pub fn inspect_with_sidecar(bytes: &[u8], file: &str, side: Option<&Sidecar>) -> Result<FileInfo, IoError> {
    let spec = header(bytes, file)?;
    let (_, ch0) = decode(bytes, file, 0)?;
    let fs = sidecar_fs(file, &spec, side)?.or(if spec.sample_rate > 0 { Some(spec.sample_rate as f64) } else { None });
    let unit = side.and_then(|s| s.unit.clone());
    let channels = (0..spec.channels as usize).map(|i| ChannelInfo::new(i.to_string(), fs, ch0.len(), unit.clone())).collect();
    let mut notes = vec![format!("{}, {} channel(s); default channel 0", format_name(&spec), spec.channels)];
    if let Some(n) = side.and_then(|s| s.name.clone()) {
        notes.push(format!("sidecar name `{n}`"));
    }
    Ok(FileInfo { path: PathBuf::from(file), format: FileFormat::Wav, channels, shaft_speed_hz: side.and_then(|s| s.meta.shaft_speed_hz), notes })
}

/// Encodes a signal as a mono 32-bit float WAV (samples as-is, rate rounded to an integer).
///
/// Rejects empty or non-finite signals, samples beyond the f32 range, and rates that do not
/// round to 1..=u32::MAX Hz. `file` names the file in errors.
pub fn write_bytes(signal: &Signal, file: &str) -> Result<Vec<u8>, IoError> {
    check_samples(file, &signal.name, &signal.samples)?;
    let rate = signal.fs_hz.round();
    if !(rate >= 1.0 && rate <= u32::MAX as f64) {
        return Err(IoError::Save {
            file: file.into(),
            reason: format!("fs_hz = {} cannot be stored in a WAV header (1..4294967295 Hz); save as .csv", signal.fs_hz),
        });
    }
    if let Some(i) = signal.samples.iter().position(|v| v.abs() > f32::MAX as f64) {
        return Err(IoError::Save { file: file.into(), reason: format!("sample {i} = {} exceeds the 32-bit float range; save as .csv", signal.samples[i]) });
    }
    let spec = WavSpec { channels: 1, sample_rate: rate as u32, bits_per_sample: 32, sample_format: SampleFormat::Float };
    let mut cursor = Cursor::new(Vec::with_capacity(44 + 4 * signal.samples.len()));
    let err = |e: hound::Error| IoError::Save { file: file.into(), reason: e.to_string() };
    {
        let mut w = hound::WavWriter::new(&mut cursor, spec).map_err(err)?;
        for &x in &signal.samples {
            w.write_sample(x as f32).map_err(err)?;
        }
        w.finalize().map_err(err)?;
    }
    Ok(cursor.into_inner())
}
