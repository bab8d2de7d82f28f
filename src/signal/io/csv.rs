//! Delimited-text (CSV) reader and writer.
//!
//! Reading:
//! - one or more columns, delimiter `,`, `;` or tab, sniffed from the first non-comment line
//!   (tab if it holds a tab, else `;` if it holds a `;`, else `,`); blank lines and `#` comment
//!   lines are skipped; fields may be double-quoted (RFC 4180, no embedded line breaks);
//! - the first non-comment line is a header when none of its cells is an unquoted number (so a
//!   quoted cell is always text);
//! - the first column is a time column when its header reads like time (`time`, `t`, `time_s`,
//!   `seconds`, `sec`, `time (s)`, ...), or when the file has exactly two columns, no
//!   time-like header and no `fs_hz` was given;
//! - channel: header name (exact, then case-insensitive) or 0-based column index; default the
//!   last column that is not the time column;
//! - every cell must be a finite number: text, NaN or inf is an error naming line and column.
//!
//! Sampling rate: `opts.fs_hz` > the `# twinscope: {json}` metadata comment (checked against
//! the time column when there is one) > the time column > error. From a time column `t`,
//! `dt = (t[n-1] - t[0]) / (n-1)`, every step must satisfy `|t[i] - t[i-1] - dt| <= 1e-6 dt`
//! (else an error names the line), and `fs = 1/dt`; when `1/dt` is within `1e-9` relative of an
//! integer it is taken as that integer (removes float noise of printed time stamps, far below
//! the 1e-6 spacing tolerance). A non-zero start time is recorded as `meta.extra["t0_s"]`.
//!
//! Writing: a `# twinscope: {json}` comment line holding name, unit, fs and all metadata (the
//! same record as the WAV sidecar), a header `time_s,<name>` and one row per sample with
//! `time_s = i / fs`, every value printed as the shortest string that parses back to the same
//! f64 (exact round trip).
//!
//! References: Y. Shafranovich, "Common Format and MIME Type for Comma-Separated Values (CSV)
//! Files", RFC 4180 (2005).

use super::sidecar::Sidecar;
use super::{check_samples, stem_of, validate_opts, ChannelInfo, FileFormat, FileInfo, IoError, LoadOptions};
use crate::signal::Signal;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Relative tolerance on the spacing of a time column.
pub const TIME_SPACING_RTOL: f64 = 1e-6;

/// A parsed delimited file.
struct Table {
    names: Vec<String>,
    has_header: bool,
    columns: Vec<Vec<f64>>,
    /// 1-based file line of each data row.
    row_lines: Vec<usize>,
    delim: char,
    /// The `# twinscope:` metadata record and its line.
    meta: Option<(usize, Sidecar)>,
}

fn line_err(file: &str, line: usize, column: usize, reason: impl Into<String>) -> IoError {
    IoError::Csv { file: file.into(), line, column, reason: reason.into() }
}

/// Splits one line into trimmed cells; the flag is true when the cell was quoted.
fn split_line(line: &str, delim: char, file: &str, lineno: usize) -> Result<Vec<(String, bool)>, IoError> {
    if !line.contains('"') {
        return Ok(line.split(delim).map(|c| (c.trim().to_string(), false)).collect());
    }
    let mut cells = Vec::new();
    let mut chars = line.chars().peekable();
    loop {
        while chars.peek().is_some_and(|c| *c != delim && c.is_whitespace()) {
            chars.next();
        }
        let mut cell = String::new();
        let mut quoted = false;
        if chars.peek() == Some(&'"') {
            quoted = true;
            chars.next();
            let mut closed = false;
            while let Some(c) = chars.next() {
                if c == '"' {
                    if chars.peek() == Some(&'"') {
                        cell.push('"');
                        chars.next();
                    } else {
                        closed = true;
                        break;
                    }
                } else {
                    cell.push(c);
                }
            }
            if !closed {
                return Err(line_err(file, lineno, cells.len() + 1, "unterminated quoted field"));
            }
            while chars.peek().is_some_and(|c| *c != delim && c.is_whitespace()) {
                chars.next();
            }
            if chars.peek().is_some_and(|c| *c != delim) {
                return Err(line_err(file, lineno, cells.len() + 1, "text after the closing quote"));
            }
        } else {
            while let Some(&c) = chars.peek() {
                if c == delim {
                    break;
                }
                cell.push(c);
                chars.next();
            }
            cell = cell.trim().to_string();
        }
        cells.push((cell, quoted));
        match chars.next() {
            Some(_) => continue, // the delimiter
            None => break,
        }
    }
    Ok(cells)
}

fn parse_cell(cell: &str, file: &str, line: usize, column: usize) -> Result<f64, IoError> {
    if cell.is_empty() {
        return Err(line_err(file, line, column, "empty cell"));
    }
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(line_err(file, line, column, format!("`{cell}` is not a finite number"))),
        Err(_) => Err(line_err(file, line, column, format!("`{cell}` is not a number"))),
    }
}

fn comment_meta(rest: &str, file: &str, line: usize) -> Result<Option<Sidecar>, IoError> {
    let body = rest.trim_start();
    match body.strip_prefix("twinscope:") {
        None => Ok(None),
        Some(json) => Sidecar::parse(json.trim(), file)
            .map(Some)
            .map_err(|e| line_err(file, line, 0, format!("malformed `# twinscope:` metadata comment: {e}"))),
    }
}

fn delim_name(delim: char) -> &'static str {
    match delim {
        '\t' => "tab",
        ';' => "`;`",
        _ => "`,`",
    }
}

fn count_err(file: &str, line: usize, delim: char, ncols: usize, first_line: usize, found: usize) -> IoError {
    line_err(file, line, 0, format!("expected {ncols} {}-separated columns (as on line {first_line}), found {found}", delim_name(delim)))
}

fn parse_table(text: &str, file: &str) -> Result<Table, IoError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if text.is_empty() {
        return Err(IoError::EmptyFile { file: file.into() });
    }
    let mut meta = None;
    let mut delim = ',';
    let mut names: Vec<String> = Vec::new();
    let mut has_header = false;
    let mut ncols = 0usize;
    let mut first_line = 0usize;
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let mut row_lines = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let lineno = i + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(rest) = line.strip_prefix('#') {
            if meta.is_none() {
                if let Some(m) = comment_meta(rest, file, lineno)? {
                    meta = Some((lineno, m));
                }
            }
            continue;
        }
        if ncols == 0 {
            delim = if line.contains('\t') {
                '\t'
            } else if line.contains(';') {
                ';'
            } else {
                ','
            };
            let cells = split_line(line, delim, file, lineno)?;
            ncols = cells.len();
            first_line = lineno;
            columns = vec![Vec::with_capacity(text.len() / (line.len() + 1) + 1); ncols];
            let numeric = cells.iter().any(|(c, q)| !q && c.parse::<f64>().is_ok());
            if !numeric {
                has_header = true;
                names = cells.into_iter().map(|(c, _)| c).collect();
                continue;
            }
            names = (0..ncols).map(|j| j.to_string()).collect();
            for (j, (c, _)) in cells.iter().enumerate() {
                columns[j].push(parse_cell(c, file, lineno, j + 1)?);
            }
            row_lines.push(lineno);
            continue;
        }
        if !line.contains('"') {
            // Fast path: no quoting, no per-cell allocation.
            let found = line.matches(delim).count() + 1;
            if found != ncols {
                return Err(count_err(file, lineno, delim, ncols, first_line, found));
            }
            for (j, c) in line.split(delim).enumerate() {
                columns[j].push(parse_cell(c.trim(), file, lineno, j + 1)?);
            }
            row_lines.push(lineno);
            continue;
        }
        let cells = split_line(line, delim, file, lineno)?;
        if cells.len() != ncols {
            return Err(count_err(file, lineno, delim, ncols, first_line, cells.len()));
        }
        for (j, (c, _)) in cells.iter().enumerate() {
            columns[j].push(parse_cell(c, file, lineno, j + 1)?);
        }
        row_lines.push(lineno);
    }
    if ncols == 0 {
        return Err(IoError::CsvFile { file: file.into(), reason: "no data rows (only blank or comment lines)".into() });
    }
    if row_lines.is_empty() {
        return Err(IoError::CsvFile { file: file.into(), reason: format!("no data rows (header on line {first_line} only)") });
    }
    Ok(Table { names, has_header, columns, row_lines, delim, meta })
}

/// True for headers such as `time`, `t`, `time_s`, `Time (s)`, `seconds`, `sec`, `t[s]`.
pub fn is_time_name(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    let base = lower.split(['(', '[']).next().unwrap_or("").trim().replace([' ', '-'], "_");
    matches!(
        base.as_str(),
        "time" | "t" | "time_s" | "times" | "t_s" | "time_sec" | "time_seconds" | "seconds" | "second" | "sec" | "secs" | "s" | "elapsed_s"
    )
}

fn time_column(t: &Table, opts_fs: Option<f64>) -> Option<usize> {
    let ncols = t.columns.len();
    let named_time = ncols >= 2 && t.has_header && is_time_name(&t.names[0]);
    let two_columns_no_fs = ncols == 2 && opts_fs.is_none();
    (named_time || two_columns_no_fs).then_some(0)
}

fn select_channel(t: &Table, file: &str, opts: &LoadOptions, time: Option<usize>) -> Result<usize, IoError> {
    let ncols = t.columns.len();
    match &opts.channel {
        None => Ok(ncols - 1),
        Some(c) => {
            let c = c.trim();
            if t.has_header {
                if let Some(j) = t.names.iter().position(|n| n == c) {
                    return Ok(j);
                }
                if let Some(j) = t.names.iter().position(|n| n.eq_ignore_ascii_case(c)) {
                    return Ok(j);
                }
            }
            match c.parse::<usize>() {
                Ok(j) if j < ncols => Ok(j),
                _ => {
                    let available = (0..ncols)
                        .filter(|j| Some(*j) != time)
                        .map(|j| if t.has_header { format!("{} ({j})", t.names[j]) } else { j.to_string() })
                        .collect();
                    Err(IoError::NoChannel { file: file.into(), kind: "column", wanted: c.to_string(), available })
                }
            }
        }
    }
}

/// Sampling rate from a time column, checking uniform spacing.
fn fs_from_time(t: &Table, file: &str, col: usize) -> Result<f64, IoError> {
    let x = &t.columns[col];
    let n = x.len();
    let cname = &t.names[col];
    if n < 2 {
        return Err(IoError::CsvFile {
            file: file.into(),
            reason: format!("the time column `{cname}` needs at least 2 rows to give a sampling rate; pass fs_hz"),
        });
    }
    let dt = (x[n - 1] - x[0]) / (n - 1) as f64;
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(line_err(file, t.row_lines[1], col + 1, format!("time column `{cname}` is not increasing; pass fs_hz to ignore it")));
    }
    for i in 1..n {
        let step = x[i] - x[i - 1];
        if (step - dt).abs() > TIME_SPACING_RTOL * dt {
            return Err(line_err(
                file,
                t.row_lines[i],
                col + 1,
                format!(
                    "time column `{cname}` is not uniformly spaced: step {step} s vs mean {dt} s (tolerance {TIME_SPACING_RTOL} relative); pass fs_hz to ignore it"
                ),
            ));
        }
    }
    let fs = 1.0 / dt;
    let r = fs.round();
    Ok(if r > 0.0 && (fs - r).abs() <= 1e-9 * fs { r } else { fs })
}

/// Decodes bytes as UTF-8 (with or without BOM) and reads one column. See [`read_str`].
pub fn read_bytes(bytes: &[u8], file: &str, opts: &LoadOptions) -> Result<Signal, IoError> {
    read_str(decode(bytes, file)?, file, opts)
}

fn decode<'a>(bytes: &'a [u8], file: &str) -> Result<&'a str, IoError> {
    if bytes.is_empty() {
        return Err(IoError::EmptyFile { file: file.into() });
    }
    std::str::from_utf8(bytes).map_err(|e| {
        let ok = e.valid_up_to();
        let line = bytes[..ok].iter().filter(|b| **b == b'\n').count() + 1;
        line_err(file, line, 0, "not UTF-8 text (is this a binary file?)")
    })
}

/// Reads one column of delimited text into a [`Signal`].
///
/// Arguments: `text` (the whole file), `file` (label for errors and `meta.source`), `opts`
/// (`channel` = header name or 0-based column index, default the last non-time column;
/// `fs_hz`, `unit` overrides).
///
/// Returns the column's samples, `fs_hz` per the priority in the module doc, name = header
/// name (or metadata name; `<stem>` / `<stem>_col<j>` without header), `meta.channel` = header
/// name or column index, metadata from the `# twinscope:` comment when it describes this
/// column (its name equals the column header, or the file has a single value column).
pub fn read_str(text: &str, file: &str, opts: &LoadOptions) -> Result<Signal, IoError> {
    validate_opts(file, opts)?;
    let mut t = parse_table(text, file)?;
    let time = time_column(&t, opts.fs_hz);
    let j = select_channel(&t, file, opts, time)?;
    let value_cols = t.columns.len() - time.map_or(0, |_| 1);
    let col_name = if t.has_header && !t.names[j].is_empty() { t.names[j].clone() } else { j.to_string() };
    let meta = t.meta.take().filter(|(_, m)| value_cols == 1 || (t.has_header && m.name.as_deref() == Some(t.names[j].as_str())));
    let fs_time = match (opts.fs_hz, time) {
        (None, Some(c)) => Some(fs_from_time(&t, file, c)?),
        _ => None,
    };
    let fs_meta = meta.as_ref().and_then(|(_, m)| m.fs_hz);
    let fs_hz = match (opts.fs_hz, fs_meta, fs_time) {
        (Some(fs), _, _) => fs,
        (None, Some(fm), Some(ft)) => {
            if (fm - ft).abs() > TIME_SPACING_RTOL * fm {
                let line = meta.as_ref().map_or(0, |(l, _)| *l);
                return Err(line_err(file, line, 0, format!("metadata fs_hz = {fm} disagrees with the time column ({ft} Hz); fix the comment or pass fs_hz")));
            }
            fm
        }
        (None, Some(fm), None) => fm,
        (None, None, Some(ft)) => ft,
        (None, None, None) => return Err(IoError::NoSamplingRate { file: file.into() }),
    };
    let t0 = time.map(|c| t.columns[c][0]).filter(|v| *v != 0.0);
    let samples = std::mem::take(&mut t.columns[j]);
    check_samples(file, &col_name, &samples)?;
    let name = if t.has_header && !t.names[j].is_empty() {
        t.names[j].clone()
    } else if value_cols == 1 {
        stem_of(file)
    } else {
        format!("{}_col{j}", stem_of(file))
    };
    let mut signal = Signal::new(samples, fs_hz, name, "");
    signal.meta.channel = Some(col_name);
    if let Some((_, m)) = meta {
        let channel = signal.meta.channel.take();
        signal.meta = m.meta;
        if signal.meta.channel.is_none() {
            signal.meta.channel = channel;
        }
        if let Some(n) = m.name {
            signal.name = n;
        }
        if let Some(u) = m.unit {
            signal.unit = u;
        }
    }
    if let Some(t0) = t0 {
        signal.meta.extra.insert("t0_s".into(), format!("{t0:?}"));
    }
    if let Some(u) = &opts.unit {
        signal.unit = u.clone();
    }
    signal.meta.source = Some(file.to_string());
    Ok(signal)
}

/// Lists the value columns of delimited-text bytes with their rate (from the time column or
/// metadata comment, when present) and length.
pub fn inspect_bytes(bytes: &[u8], file: &str) -> Result<FileInfo, IoError> {
    let text = decode(bytes, file)?;
    let t = parse_table(text, file)?;
    let time = time_column(&t, None);
    let mut time_problem = None;
    let fs = match time.map(|c| fs_from_time(&t, file, c)) {
        Some(Ok(fs)) => Some(fs),
        // Listing still works; `load` reports the same problem unless fs_hz is given.
        Some(Err(e)) => {
            time_problem = Some(e.to_string());
            None
        }
        None => t.meta.as_ref().and_then(|(_, m)| m.fs_hz),
    };
    let n = t.row_lines.len();
    let unit = t.meta.as_ref().and_then(|(_, m)| m.unit.clone());
    let value_cols: Vec<usize> = (0..t.columns.len()).filter(|j| Some(*j) != time).collect();
    let channels = value_cols
        .iter()
        .map(|&j| {
            let u = if value_cols.len() == 1 { unit.clone() } else { None };
            ChannelInfo::new(if t.has_header { t.names[j].clone() } else { j.to_string() }, fs, n, u)
        })
        .collect();
    let mut notes = vec![format!("{}-delimited, {}", delim_name(t.delim), if t.has_header { "with header" } else { "no header" })];
    if let Some(p) = time_problem {
        notes.push(format!("no rate from the time column: {p}"));
    }
    match time {
        Some(c) => notes.push(format!("time column `{}` (column {})", t.names[c], c)),
        None if fs.is_none() => notes.push("no time column and no rate; pass fs_hz".into()),
        None => {}
    }
    if let Some(&last) = value_cols.last() {
        notes.push(format!("default channel `{}`", if t.has_header { t.names[last].clone() } else { last.to_string() }));
    }
    let shaft = t.meta.as_ref().and_then(|(_, m)| m.meta.shaft_speed_hz);
    if let Some((l, _)) = &t.meta {
        notes.push(format!("twinscope metadata on line {l}"));
    }
    Ok(FileInfo { path: PathBuf::from(file), format: FileFormat::Csv, channels, shaft_speed_hz: shaft, notes })
}

fn quote_header(name: &str) -> String {
    let name = if name.is_empty() { "value" } else { name };
    let needs = name.contains([',', ';', '\t', '"', '\n', '\r', '#'])
        || name.trim() != name
        || name.parse::<f64>().is_ok();
    if needs {
        format!("\"{}\"", name.replace(['\n', '\r'], " ").replace('"', "\"\""))
    } else {
        name.to_string()
    }
}

/// Formats a signal as CSV text (see the module doc). Rejects empty or non-finite signals and
/// non-positive rates; `file` names the file in errors.
pub fn write_string(signal: &Signal, file: &str) -> Result<String, IoError> {
    crate::dsp::error::check_fs(signal.fs_hz).map_err(|source| IoError::InvalidParameter { file: file.into(), source })?;
    check_samples(file, &signal.name, &signal.samples)?;
    let json = super::sidecar::to_json(signal, file)?;
    let mut out = String::with_capacity(json.len() + 64 + signal.samples.len() * 44);
    let fmt_err = |_| IoError::Save { file: file.into(), reason: "formatting failed".into() };
    writeln!(out, "# twinscope: {json}").map_err(fmt_err)?;
    writeln!(out, "time_s,{}", quote_header(&signal.name)).map_err(fmt_err)?;
    for (i, x) in signal.samples.iter().enumerate() {
        writeln!(out, "{:?},{:?}", i as f64 / signal.fs_hz, x).map_err(fmt_err)?;
    }
    Ok(out)
}
