//! Machine kinematics: bearing characteristic frequencies, gear mesh frequencies and a
//! catalogue of the bearings used by the source papers and the bundled data.
//!
//! Frequencies follow the classic rigid-body kinematics of rolling-element bearings without
//! slip (Harris & Kotzalas 2006; Randall & Antoni 2011, "Rolling element bearing diagnostics —
//! a tutorial", MSSP 25, eq. 1–4).

mod bearing;
mod catalogue;
mod gear;
pub mod markers;

pub use bearing::{BearingGeometry, FaultFrequencies, KinematicsError};
pub use catalogue::{catalogue, lookup_bearing};
pub use gear::{GearPair, MeshFrequencies};
pub use markers::{labelled_peaks, marker_lines, LabelledPeak, MarkerLine, PeakLabelling};

use serde::{Deserialize, Serialize};

/// A named characteristic frequency (a line family's fundamental).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharacteristicFrequency {
    /// Label in the field's words: `shaft`, `BPFO`, `BPFI`, `BSF`, `2xBSF`, `FTF`, `GMF`, ...
    pub label: String,
    /// Fundamental in Hz.
    pub frequency_hz: f64,
}

/// The nearest characteristic line to a measured peak.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LineMatch {
    /// Family label of the match (e.g. `BPFI`).
    pub label: String,
    /// Harmonic order `k` (the line is `k × fundamental`, plus `sideband × shaft` if present).
    pub harmonic: u32,
    /// Sideband order `s` in multiples of the shaft speed (0 = the harmonic itself).
    pub sideband: i32,
    /// Theoretical line frequency in Hz.
    pub line_hz: f64,
    /// Relative error `(peak − line) / line` in percent.
    pub error_percent: f64,
    /// Whether the line lies within the tolerance asked for.
    pub within_tolerance: bool,
}

/// Explains a spectral peak by the simplest characteristic line within a tolerance.
///
/// Candidates are harmonics `k = 1..=max_harmonic` of each family and, if `shaft_hz` is given,
/// their shaft-speed sidebands `s = -max_sideband..=max_sideband` (lines `k f + s f_r`). Among
/// the lines within `tolerance_percent` of the peak, the simplest wins: lowest complexity
/// `k + 2|s|` (a sideband is a weaker explanation than a harmonic), then the earlier family in
/// `families`, then the smaller error. This is how an analyst reads a spectrum: a peak 0.3 %
/// from BPFO is BPFO, not `4×FTF + 2×shaft` that happens to lie closer. With no line inside
/// the tolerance, the nearest line is returned with `within_tolerance = false`. Returns `None`
/// for an empty family list or a non-positive peak.
pub fn nearest_line(
    peak_hz: f64,
    families: &[CharacteristicFrequency],
    shaft_hz: Option<f64>,
    max_harmonic: u32,
    max_sideband: i32,
    tolerance_percent: f64,
) -> Option<LineMatch> {
    if !(peak_hz > 0.0 && peak_hz.is_finite()) {
        return None;
    }
    let mut candidates: Vec<(u32, usize, LineMatch)> = Vec::new();
    for (fi, fam) in families.iter().enumerate().filter(|(_, f)| f.frequency_hz > 0.0) {
        for k in 1..=max_harmonic.max(1) {
            let sb = if shaft_hz.is_some() && fam.label != "shaft" { max_sideband.max(0) } else { 0 };
            for s in -sb..=sb {
                let line = k as f64 * fam.frequency_hz + s as f64 * shaft_hz.unwrap_or(0.0);
                if line <= 0.0 {
                    continue;
                }
                let error_percent = (peak_hz - line) / line * 100.0;
                let m = LineMatch { label: fam.label.clone(), harmonic: k, sideband: s, line_hz: line, error_percent, within_tolerance: error_percent.abs() <= tolerance_percent };
                candidates.push((k + 2 * s.unsigned_abs(), fi, m));
            }
        }
    }
    let inside = candidates.iter().filter(|c| c.2.within_tolerance).min_by(|a, b| {
        (a.0, a.1).cmp(&(b.0, b.1)).then(a.2.error_percent.abs().total_cmp(&b.2.error_percent.abs()))
    });
    match inside {
        Some(c) => Some(c.2.clone()),
        None => candidates.into_iter().map(|c| c.2).min_by(|a, b| (peak_hz - a.line_hz).abs().total_cmp(&(peak_hz - b.line_hz).abs())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_line_finds_harmonic_and_sideband() {
        let fams = vec![
            CharacteristicFrequency { label: "shaft".into(), frequency_hz: 29.95 },
            CharacteristicFrequency { label: "BPFI".into(), frequency_hz: 162.19 },
        ];
        let m = nearest_line(324.5, &fams, Some(29.95), 5, 2, 1.0).unwrap();
        assert_eq!((m.label.as_str(), m.harmonic, m.sideband), ("BPFI", 2, 0));
        let m = nearest_line(162.19 + 29.95, &fams, Some(29.95), 5, 2, 1.0).unwrap();
        assert_eq!((m.label.as_str(), m.harmonic, m.sideband), ("BPFI", 1, 1));
        let m = nearest_line(59.9, &fams, Some(29.95), 5, 2, 1.0).unwrap();
        assert_eq!((m.label.as_str(), m.harmonic), ("shaft", 2));
        assert!(nearest_line(-1.0, &fams, None, 5, 0, 1.0).is_none());
        let far = nearest_line(1000.0 / 7.0, &fams, None, 1, 0, 1.0).unwrap();
        assert!(!far.within_tolerance);
    }

    /// CWRU 130: a peak at 107.64 Hz is BPFO (+0.31 %), not 4×FTF + 2×shaft (+0.08 %).
    #[test]
    fn simplest_explanation_wins_within_tolerance() {
        let ff = crate::kinematics::lookup_bearing("6205").unwrap().fault_frequencies(29.9333).unwrap();
        let m = nearest_line(107.64, &ff.families(), Some(29.9333), 10, 2, 1.0).unwrap();
        assert_eq!((m.label.as_str(), m.harmonic, m.sideband), ("BPFO", 1, 0), "{m:?}");
        assert!(m.within_tolerance && (m.error_percent - 0.31).abs() < 0.02);
    }
}
