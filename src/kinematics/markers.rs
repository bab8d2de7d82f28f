//! Marker lines and labelled peaks for drawing a spectrum: where the characteristic lines
//! (harmonics and shaft-speed sidebands of BPFO, BPFI, BSF, FTF, GMF, ...) fall, and which of
//! them explains each of the largest peaks.

use super::{nearest_line, CharacteristicFrequency, LineMatch};
use crate::dsp::spectrum::Spectrum;
use crate::dsp::DspError;
use serde::{Deserialize, Serialize};

/// One characteristic line to mark on a spectrum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MarkerLine {
    /// Family label (`BPFI`, `shaft`, `GMF`, ...).
    pub family: String,
    /// Harmonic order `k ≥ 1`.
    pub harmonic: u32,
    /// Shaft-speed sideband order `s` (0 = the harmonic itself).
    pub sideband: i32,
    /// Line frequency `k f + s f_r`, Hz.
    pub frequency_hz: f64,
    /// Text for the marker: `BPFI`, `2xBPFI`, `BPFI+1xshaft`, ...
    pub label: String,
}

/// The text for a line: `F` for the fundamental, `kxF` for harmonic `k`, with `±sxshaft` for a
/// sideband (the same words as the CLI's peak labels).
pub fn line_text(family: &str, harmonic: u32, sideband: i32) -> String {
    let h = if harmonic == 1 { family.to_string() } else { format!("{harmonic}x{family}") };
    match sideband {
        0 => h,
        s => format!("{h}{s:+}xshaft"),
    }
}

/// The label of a [`LineMatch`] (see [`line_text`]).
pub fn match_text(m: &LineMatch) -> String {
    line_text(&m.label, m.harmonic, m.sideband)
}

/// Every harmonic `k = 1..=max_harmonic` of each family and, when `shaft_hz` is given, its
/// shaft sidebands `s = -max_sideband..=max_sideband` (not for the `shaft` family itself), that
/// lies in `(0, f_max_hz]`. Sorted by frequency. Families with a non-positive or non-finite
/// frequency are skipped.
pub fn marker_lines(families: &[CharacteristicFrequency], shaft_hz: Option<f64>, max_harmonic: u32, max_sideband: u32, f_max_hz: f64) -> Vec<MarkerLine> {
    let mut out = Vec::new();
    let fr = shaft_hz.filter(|f| f.is_finite() && *f > 0.0);
    for fam in families.iter().filter(|f| f.frequency_hz.is_finite() && f.frequency_hz > 0.0) {
        let sb = if fr.is_some() && fam.label != "shaft" { max_sideband as i32 } else { 0 };
        for k in 1..=max_harmonic.max(1) {
            for s in -sb..=sb {
                let f = k as f64 * fam.frequency_hz + s as f64 * fr.unwrap_or(0.0);
                if f > 0.0 && f <= f_max_hz {
                    out.push(MarkerLine { family: fam.label.clone(), harmonic: k, sideband: s, frequency_hz: f, label: line_text(&fam.label, k, s) });
                }
            }
        }
    }
    out.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    out
}

/// A spectral peak with the characteristic line that explains it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LabelledPeak {
    /// Peak frequency (parabolic refinement), Hz.
    pub frequency_hz: f64,
    /// Peak value, in the spectrum's unit.
    pub value: f64,
    /// The simplest line within the tolerance (or the nearest, flagged), if any family is known.
    pub nearest: Option<LineMatch>,
}

impl LabelledPeak {
    /// `BPFI (-0.31 %)` when a line lies within the tolerance, `-` otherwise.
    pub fn label(&self) -> String {
        match &self.nearest {
            Some(m) if m.within_tolerance => format!("{} ({:+.2} %)", match_text(m), m.error_percent),
            _ => "-".to_string(),
        }
    }
}

/// Labelling settings for [`labelled_peaks`] (the batch job's defaults).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PeakLabelling {
    /// Peaks to report. Default 10.
    pub peaks: usize,
    /// Minimum spacing between peaks, Hz. Default 1.0.
    pub min_separation_hz: f64,
    /// Harmonics searched. Default 10.
    pub max_harmonic: u32,
    /// Shaft sidebands searched. Default 2.
    pub max_sideband: i32,
    /// Label tolerance, % of the line frequency. Default 1.0.
    pub tolerance_percent: f64,
}

impl Default for PeakLabelling {
    fn default() -> Self {
        Self { peaks: 10, min_separation_hz: 1.0, max_harmonic: 10, max_sideband: 2, tolerance_percent: 1.0 }
    }
}

/// The largest peaks of `spectrum` ([`Spectrum::top_peaks`]), each labelled by
/// [`nearest_line`] against `families` (with shaft sidebands when `shaft_hz` is given).
///
/// # Errors
/// `InvalidParameter` (`min_separation_hz`) as [`Spectrum::top_peaks`].
pub fn labelled_peaks(spectrum: &Spectrum, families: &[CharacteristicFrequency], shaft_hz: Option<f64>, cfg: &PeakLabelling) -> Result<Vec<LabelledPeak>, DspError> {
    Ok(spectrum
        .top_peaks(cfg.peaks, cfg.min_separation_hz)?
        .into_iter()
        .map(|(f, v)| LabelledPeak { frequency_hz: f, value: v, nearest: nearest_line(f, families, shaft_hz, cfg.max_harmonic, cfg.max_sideband, cfg.tolerance_percent) })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fams() -> Vec<CharacteristicFrequency> {
        vec![CharacteristicFrequency { label: "shaft".into(), frequency_hz: 30.0 }, CharacteristicFrequency { label: "BPFI".into(), frequency_hz: 162.0 }]
    }

    #[test]
    fn markers_cover_harmonics_and_sidebands() {
        let m = marker_lines(&fams(), Some(30.0), 3, 1, 400.0);
        let labels: Vec<&str> = m.iter().map(|l| l.label.as_str()).collect();
        assert_eq!(labels, ["shaft", "2xshaft", "3xshaft", "BPFI-1xshaft", "BPFI", "BPFI+1xshaft", "2xBPFI-1xshaft", "2xBPFI", "2xBPFI+1xshaft"]);
        assert!((m[7].frequency_hz - 324.0).abs() < 1e-12);
        assert!(m.windows(2).all(|w| w[0].frequency_hz <= w[1].frequency_hz));
        // no shaft speed → no sidebands; bad families skipped
        let mut f = fams();
        f.push(CharacteristicFrequency { label: "GMF".into(), frequency_hz: f64::NAN });
        assert_eq!(marker_lines(&f, None, 1, 2, 1000.0).len(), 2);
    }

    #[test]
    fn peaks_are_labelled() {
        let df = 0.5;
        let n = 801;
        let freq: Vec<f64> = (0..n).map(|i| i as f64 * df).collect();
        let values: Vec<f64> = freq.iter().map(|&f| if (f - 162.5).abs() < 1e-9 { 1.0 } else if (f - 192.0).abs() < 1e-9 { 0.5 } else { 0.01 }).collect();
        let s = Spectrum { frequency_hz: freq, values, quantity: "envelope spectrum (peak)".into(), unit: "g".into() };
        let p = labelled_peaks(&s, &fams(), Some(30.0), &PeakLabelling { peaks: 2, ..Default::default() }).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].label(), "BPFI (+0.31 %)");
        assert_eq!(p[1].label(), "BPFI+1xshaft (+0.00 %)");
        assert!(labelled_peaks(&s, &fams(), None, &PeakLabelling { min_separation_hz: -1.0, ..Default::default() }).is_err());
    }
}
