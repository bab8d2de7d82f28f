//! MATLAB level-5 MAT-file reader (via `matfile`), including the CWRU bearing data files.
//!
//! Variables: every numeric array is listed; real vectors (N×1 or 1×N, N ≥ 2) can be loaded.
//! Complex arrays, matrices, scalars and non-numeric arrays (char, cell, struct, sparse,
//! object) are listed but refused when chosen. Non-numeric variables are named only when stored
//! uncompressed (`save -v6`); inside compressed elements (`-v7`) `matfile` skips them and only
//! their count is reported.
//!
//! Channel (`LoadOptions::channel`): an exact variable name (case-sensitive, then
//! case-insensitive), else a suffix — `"_DE_time"`, `"DE_time"` or `"DE"` all select
//! `X105_DE_time`; a suffix matching several variables is an error listing them. Default: the
//! first variable ending in `_DE_time`, else the first real numeric vector. Selection is by
//! variable name, never by file name (CWRU variable numbers can differ from file numbers).
//!
//! Metadata: a numeric scalar whose name ends in `RPM` gives `meta.shaft_speed_hz = rpm / 60`
//! (preferring the one sharing the chosen variable's prefix, `X105RPM` for `X105_DE_time`).
//! CWRU accelerometer channels (`_DE_time`, `_FE_time`, `_BA_time`) get unit `g`.
//!
//! Sampling rate: `opts.fs_hz` > a scalar variable named `fs`, `Fs`, `fs_hz`, `sampling_rate`,
//! `sample_rate` or `samplerate` (any case) > a `12k` / `48k` token in the file name (CWRU
//! convention: 12000 / 48000 Hz) > error. The source is recorded in `meta.extra["fs_source"]`
//! (`"option"`, `"variable <name>"` or `"file name"`).
//!
//! Robustness: the file structure (header, top-level element tags and sizes) is checked here
//! first, so truncation and trailing garbage are reported (the `matfile` parser would silently
//! drop a truncated last variable). `matfile` then parses the bytes inside
//! `std::panic::catch_unwind`: it indexes and unwraps on some malformed inputs, and a panic in
//! a dependency on a hostile file must become an [`IoError::CorruptMat`], not abort the caller
//! (the default panic hook may still print the message to stderr). MATLAB v7.3 (HDF5) and v4
//! files are recognised and refused with a message.
//!
//! References: The MathWorks, "MAT-File Format", MATLAB documentation (R2024a), chapter 1
//! (Level 5 MAT-files); K. A. Loparo, Case Western Reserve University Bearing Data Center.

use super::{check_samples, stem_of, validate_opts, ChannelInfo, FileFormat, FileInfo, IoError, LoadOptions};
use crate::signal::Signal;
use matfile::{Array, MatFile, NumericData};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const FS_NAMES: [&str; 6] = ["fs", "fs_hz", "sampling_rate", "sample_rate", "samplerate", "srate"];

fn corrupt(file: &str, reason: impl Into<String>) -> IoError {
    IoError::CorruptMat { file: file.into(), reason: reason.into() }
}

fn class_name(class: u32) -> &'static str {
    match class {
        1 => "cell",
        2 => "struct",
        3 => "object",
        4 => "char",
        5 => "sparse",
        6 => "double",
        7 => "single",
        8 => "int8",
        9 => "uint8",
        10 => "int16",
        11 => "uint16",
        12 => "int32",
        13 => "uint32",
        14 => "int64",
        15 => "uint64",
        16 => "function handle",
        17 => "opaque (string/table/class)",
        _ => "unknown-class",
    }
}

/// What the structural walk found.
struct Layout {
    /// Uncompressed non-numeric (or sparse) variables: name and class.
    non_numeric: Vec<(String, &'static str)>,
    /// Number of compressed top-level elements.
    compressed: usize,
    /// Number of uncompressed numeric (non-sparse) variables.
    plain_numeric: usize,
}

fn rd_u32(b: &[u8], off: usize, big: bool) -> Option<u32> {
    let s: [u8; 4] = b.get(off..off.checked_add(4)?)?.try_into().ok()?;
    Some(if big { u32::from_be_bytes(s) } else { u32::from_le_bytes(s) })
}

/// Reads a (possibly small-format) sub-element tag at `off`: (type, nbytes, data offset, next).
fn sub_tag(b: &[u8], off: usize, big: bool) -> Option<(u32, usize, usize, usize)> {
    let first = rd_u32(b, off, big)?;
    if first >> 16 != 0 {
        // Small data element: 2-byte size, 2-byte type, 4 bytes of data.
        Some((first & 0xFFFF, (first >> 16) as usize, off + 4, off + 8))
    } else {
        let n = rd_u32(b, off + 4, big)? as usize;
        let next = (off + 8).checked_add(n.div_ceil(8).checked_mul(8)?)?;
        Some((first, n, off + 8, next))
    }
}

/// Class and name of an uncompressed miMATRIX element whose data starts at `off`.
fn matrix_class_name(b: &[u8], off: usize, big: bool) -> Option<(u32, String)> {
    let (_, _, flags_at, next) = sub_tag(b, off, big)?;
    let class = rd_u32(b, flags_at, big)? & 0xFF;
    let (_, _, _, next) = sub_tag(b, next, big)?; // dimensions
    let (_, n, at, _) = sub_tag(b, next, big)?; // name
    let name = b.get(at..at.checked_add(n)?)?;
    Some((class, String::from_utf8_lossy(name).to_string()))
}

/// Checks the header and walks the top-level element tags.
fn check_structure(bytes: &[u8], file: &str) -> Result<(bool, Layout), IoError> {
    if bytes.is_empty() {
        return Err(IoError::EmptyFile { file: file.into() });
    }
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(116)]).to_string();
    if text.starts_with("MATLAB 7.3") || bytes.get(512..516) == Some(b"\x89HDF") {
        return Err(corrupt(file, "MATLAB v7.3 (HDF5) files are not supported; re-save with `save -v7`"));
    }
    if bytes.len() < 128 {
        return Err(corrupt(file, format!("{} bytes is too short for a MAT v5 header (128 bytes)", bytes.len())));
    }
    let big = match &bytes[126..128] {
        b"IM" => false,
        b"MI" => true,
        _ => return Err(corrupt(file, "not a MATLAB level-5 MAT-file (no MI/IM endian mark at byte 126; v4 files are not supported)")),
    };
    let mut layout = Layout { non_numeric: Vec::new(), compressed: 0, plain_numeric: 0 };
    let mut pos = 128usize;
    let mut k = 0usize;
    while pos < bytes.len() {
        k += 1;
        let (Some(ty), Some(n)) = (rd_u32(bytes, pos, big), rd_u32(bytes, pos + 4, big)) else {
            return Err(corrupt(file, format!("truncated: element {k} at byte {pos} has an incomplete tag (file ends at {})", bytes.len())));
        };
        let n = n as usize;
        let data = pos + 8;
        let end = data.saturating_add(n);
        if end > bytes.len() {
            return Err(corrupt(file, format!("truncated: element {k} at byte {pos} declares {n} bytes but the file ends at byte {}", bytes.len())));
        }
        match ty {
            MI_MATRIX => {
                if let Some((class, name)) = matrix_class_name(&bytes[..end], data, big) {
                    if (6..=15).contains(&class) {
                        layout.plain_numeric += 1;
                    } else {
                        layout.non_numeric.push((name, class_name(class)));
                    }
                }
                pos = data.saturating_add(n.div_ceil(8) * 8).min(bytes.len());
            }
            MI_COMPRESSED => {
                layout.compressed += 1;
                pos = end;
            }
            other => return Err(corrupt(file, format!("element {k} at byte {pos} has type {other}; top-level elements must be miMATRIX (14) or miCOMPRESSED (15)"))),
        }
    }
    Ok((big, layout))
}

fn parse(bytes: &[u8], file: &str) -> Result<(MatFile, Layout), IoError> {
    let (_, layout) = check_structure(bytes, file)?;
    match catch_unwind(AssertUnwindSafe(|| MatFile::parse(bytes))) {
        Ok(Ok(m)) => Ok((m, layout)),
        Ok(Err(e)) => Err(corrupt(file, format!("{e}: malformed variable"))),
        Err(_) => Err(corrupt(file, "the MAT parser panicked on this input")),
    }
}

/// Real samples of a numeric array as f64 (`None` when complex).
fn real_f64(a: &Array) -> Option<Vec<f64>> {
    macro_rules! conv {
        ($real:expr, $imag:expr) => {
            if $imag.is_some() {
                None
            } else {
                Some($real.iter().map(|&v| v as f64).collect())
            }
        };
    }
    match a.data() {
        NumericData::Int8 { real, imag } => conv!(real, imag),
        NumericData::UInt8 { real, imag } => conv!(real, imag),
        NumericData::Int16 { real, imag } => conv!(real, imag),
        NumericData::UInt16 { real, imag } => conv!(real, imag),
        NumericData::Int32 { real, imag } => conv!(real, imag),
        NumericData::UInt32 { real, imag } => conv!(real, imag),
        NumericData::Int64 { real, imag } => conv!(real, imag),
        NumericData::UInt64 { real, imag } => conv!(real, imag),
        NumericData::Single { real, imag } => conv!(real, imag),
        NumericData::Double { real, imag } => conv!(real, imag),
    }
}

fn is_complex(a: &Array) -> bool {
    match a.data() {
        NumericData::Int8 { imag, .. } => imag.is_some(),
        NumericData::UInt8 { imag, .. } => imag.is_some(),
        NumericData::Int16 { imag, .. } => imag.is_some(),
        NumericData::UInt16 { imag, .. } => imag.is_some(),
        NumericData::Int32 { imag, .. } => imag.is_some(),
        NumericData::UInt32 { imag, .. } => imag.is_some(),
        NumericData::Int64 { imag, .. } => imag.is_some(),
        NumericData::UInt64 { imag, .. } => imag.is_some(),
        NumericData::Single { imag, .. } => imag.is_some(),
        NumericData::Double { imag, .. } => imag.is_some(),
    }
}

fn numel(a: &Array) -> usize {
    a.size().iter().try_fold(1usize, |acc, &d| acc.checked_mul(d)).unwrap_or(usize::MAX)
}

fn dims_str(a: &Array) -> String {
    a.size().iter().map(|d| d.to_string()).collect::<Vec<_>>().join("×")
}

/// Why a numeric array cannot be loaded as a signal, if it cannot.
fn refusal(a: &Array) -> Option<String> {
    let n = numel(a);
    if is_complex(a) {
        Some(format!("it is complex ({}); only real vectors can be loaded", dims_str(a)))
    } else if n == 0 {
        Some("it is empty".into())
    } else if n == 1 {
        Some("it is a scalar (1×1); choose a vector".into())
    } else if a.ndims() != 2 || (a.size()[0] != 1 && a.size()[1] != 1) {
        Some(format!("it is a {} array; only vectors (N×1 or 1×N) can be loaded", dims_str(a)))
    } else {
        None
    }
}

fn scalar(a: &Array) -> Option<f64> {
    if numel(a) == 1 {
        real_f64(a).and_then(|v| v.first().copied())
    } else {
        None
    }
}

fn cwru_unit(name: &str) -> Option<&'static str> {
    ["_DE_time", "_FE_time", "_BA_time"].iter().any(|s| name.ends_with(s)).then_some("g")
}

/// Sampling rate in the file: (`fs`, source).
fn file_fs(m: &MatFile, file: &str) -> Result<Option<(f64, String)>, IoError> {
    for a in m.arrays() {
        if FS_NAMES.iter().any(|n| a.name().eq_ignore_ascii_case(n)) {
            return match scalar(a) {
                Some(fs) if fs.is_finite() && fs > 0.0 => Ok(Some((fs, format!("variable {}", a.name())))),
                _ => Err(IoError::Unsupported {
                    file: file.into(),
                    kind: "variable",
                    channel: a.name().into(),
                    reason: "it is named like a sampling rate but is not a positive, finite real scalar; fix it or pass fs_hz".into(),
                }),
            };
        }
    }
    let stem = stem_of(file).to_ascii_lowercase();
    for tok in stem.split(|c: char| !c.is_ascii_alphanumeric()) {
        match tok {
            "12k" => return Ok(Some((12000.0, "file name".into()))),
            "48k" => return Ok(Some((48000.0, "file name".into()))),
            _ => {}
        }
    }
    Ok(None)
}

/// The RPM scalar for variable `chosen` (prefix match preferred), and the shaft speed in Hz.
fn shaft_speed(m: &MatFile, chosen: &str) -> Option<(String, f64)> {
    let rpms: Vec<(&str, f64)> = m
        .arrays()
        .iter()
        .filter(|a| a.name().to_ascii_uppercase().ends_with("RPM"))
        .filter_map(|a| scalar(a).map(|v| (a.name(), v)))
        .collect();
    let pick = rpms
        .iter()
        .find(|(n, _)| {
            let prefix = &n[..n.len() - 3];
            !prefix.is_empty() && chosen.starts_with(prefix)
        })
        .or(rpms.first())?;
    Some((pick.0.to_string(), pick.1))
}

fn all_names(m: &MatFile, layout: &Layout) -> Vec<String> {
    m.arrays().iter().map(|a| a.name().to_string()).chain(layout.non_numeric.iter().map(|(n, _)| n.clone())).collect()
}

/// Resolves `channel` to a numeric array index, or a refusal for a non-numeric variable.
fn select<'m>(m: &'m MatFile, layout: &Layout, file: &str, opts: &LoadOptions) -> Result<&'m Array, IoError> {
    let arrays = m.arrays();
    let names = all_names(m, layout);
    let Some(want) = opts.channel.as_deref().map(str::trim) else {
        let loadable = |a: &&Array| refusal(a).is_none();
        return arrays
            .iter()
            .filter(loadable)
            .find(|a| a.name().ends_with("_DE_time"))
            .or_else(|| arrays.iter().find(loadable))
            .ok_or_else(|| IoError::NothingToLoad {
                file: file.into(),
                reason: format!("no real numeric vector; variables: {}", if names.is_empty() { "(none)".into() } else { names.join(", ") }),
            });
    };
    let lw = want.to_ascii_lowercase();
    let exact = names.iter().position(|n| n == want).or_else(|| names.iter().position(|n| n.eq_ignore_ascii_case(want)));
    let idx = match exact {
        Some(i) => i,
        None => {
            let long = format!("_{}_time", lw.trim_start_matches('_'));
            let hits: Vec<usize> = (0..names.len())
                .filter(|&i| {
                    let n = names[i].to_ascii_lowercase();
                    n.ends_with(&lw) || n.ends_with(&long)
                })
                .collect();
            match hits.as_slice() {
                [i] => *i,
                [] => return Err(IoError::NoChannel { file: file.into(), kind: "variable", wanted: want.into(), available: names }),
                many => {
                    return Err(IoError::Ambiguous { file: file.into(), wanted: want.into(), matches: many.iter().map(|&i| names[i].clone()).collect() })
                }
            }
        }
    };
    if idx >= arrays.len() {
        let (name, class) = &layout.non_numeric[idx - arrays.len()];
        return Err(IoError::Unsupported { file: file.into(), kind: "variable", channel: name.clone(), reason: format!("it is a {class} array, not numeric") });
    }
    Ok(&arrays[idx])
}

/// Reads one variable of MAT v5 bytes into a [`Signal`].
///
/// Arguments: `bytes` (the whole file), `file` (its path: label for errors, `meta.source`, and
/// the `12k`/`48k` rate token), `opts` (`channel` = variable name or suffix, default first
/// `*_DE_time` else first real vector; `fs_hz`, `unit` overrides).
///
/// Returns the variable's samples as f64 (integers converted exactly up to 2^53), name and
/// `meta.channel` = variable name, `fs_hz` and `meta.extra["fs_source"]` per the module doc,
/// `meta.shaft_speed_hz` from an `*RPM` scalar, unit `g` for CWRU channels.
pub fn read_bytes(bytes: &[u8], file: &str, opts: &LoadOptions) -> Result<Signal, IoError> {
    validate_opts(file, opts)?;
    let (m, layout) = parse(bytes, file)?;
    let a = select(&m, &layout, file, opts)?;
    if let Some(reason) = refusal(a) {
        return Err(IoError::Unsupported { file: file.into(), kind: "variable", channel: a.name().into(), reason });
    }
    let samples = real_f64(a).unwrap_or_default();
    check_samples(file, a.name(), &samples)?;
    let (fs_hz, fs_source) = match opts.fs_hz {
        Some(fs) => (fs, "option".to_string()),
        None => file_fs(&m, file)?.ok_or_else(|| IoError::NoSamplingRate { file: file.into() })?,
    };
    let unit = opts.unit.clone().or_else(|| cwru_unit(a.name()).map(String::from)).unwrap_or_default();
    let mut signal = Signal::new(samples, fs_hz, a.name(), unit);
    signal.meta.channel = Some(a.name().to_string());
    signal.meta.source = Some(file.to_string());
    signal.meta.extra.insert("fs_source".into(), fs_source);
    if let Some((rpm_name, rpm)) = shaft_speed(&m, a.name()) {
        if rpm.is_finite() && rpm > 0.0 {
            signal.meta.shaft_speed_hz = Some(rpm / 60.0);
        } else {
            signal.meta.extra.insert("shaft_speed_note".into(), format!("{rpm_name} = {rpm} is not a positive speed; shaft speed unknown"));
        }
    }
    Ok(signal)
}

/// Lists the variables of MAT v5 bytes: loadable vectors as channels (with rate when the file
/// or file name gives one, length, duration, unit), everything else in the notes.
pub fn inspect_bytes(bytes: &[u8], file: &str) -> Result<FileInfo, IoError> {
    let (m, layout) = parse(bytes, file)?;
    let fs = file_fs(&m, file)?;
    let mut notes = Vec::new();
    match &fs {
        Some((v, src)) => notes.push(format!("sampling rate {v} Hz from {src}")),
        None => notes.push("no sampling rate in the file or its name; pass fs_hz".into()),
    }
    let mut channels = Vec::new();
    for a in m.arrays() {
        match refusal(a) {
            None => channels.push(ChannelInfo::new(a.name(), fs.as_ref().map(|f| f.0), numel(a), cwru_unit(a.name()).map(String::from))),
            Some(_) if numel(a) == 1 && !is_complex(a) => {
                notes.push(format!("scalar `{}` = {}", a.name(), scalar(a).unwrap_or(f64::NAN)))
            }
            Some(r) => notes.push(format!("`{}` not loadable: {r}", a.name())),
        }
    }
    for (n, c) in &layout.non_numeric {
        notes.push(format!("`{n}` not loadable: it is a {c} array"));
    }
    let from_compressed = m.arrays().len().saturating_sub(layout.plain_numeric);
    let unknown = layout.compressed.saturating_sub(from_compressed);
    if unknown > 0 {
        notes.push(format!("{unknown} compressed non-numeric variable(s) skipped (names unknown)"));
    }
    let default = select(&m, &layout, file, &LoadOptions::default()).ok().map(|a| a.name().to_string());
    if let Some(d) = &default {
        notes.push(format!("default channel `{d}`"));
    }
    let shaft = shaft_speed(&m, default.as_deref().unwrap_or("")).map(|(_, rpm)| rpm / 60.0).filter(|v| v.is_finite() && *v > 0.0);
    Ok(FileInfo { path: PathBuf::from(file), format: FileFormat::Mat, channels, shaft_speed_hz: shaft, notes })
}
