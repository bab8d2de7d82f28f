//! Machine kinematics: bearing characteristic frequencies, gear mesh frequencies and a
//! catalogue of the bearings used by the source papers and the bundled data.
//!
//! Frequencies follow the classic rigid-body kinematics of rolling-element bearings without
//! slip (Harris & Kotzalas 2006; Randall & Antoni 2011, "Rolling element bearing diagnostics —
//! a tutorial", MSSP 25, eq. 1–4).

mod bearing;
mod catalogue;
mod gear;

pub use bearing::{BearingGeometry, FaultFrequencies, KinematicsError};
pub use catalogue::{catalogue, lookup_bearing};
pub use gear::{GearPair, MeshFrequencies};

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
}

/// Finds the characteristic line nearest to `peak_hz` among harmonics `1..=max_harmonic` of
/// each family and, if `shaft_hz` is given, their first `max_sideband` shaft-speed sidebands.
///
/// Ties (within 1e-9 relative) prefer the lowest harmonic, then no sideband, then the order of
/// `families`. Returns `None` for an empty family list or a non-positive peak.
pub fn nearest_line(
    peak_hz: f64,
    families: &[CharacteristicFrequency],
    shaft_hz: Option<f64>,
    max_harmonic: u32,
    max_sideband: i32,
) -> Option<LineMatch> {
    if !(peak_hz > 0.0) {
        return None;
    }
    let mut best: Option<(f64, LineMatch)> = None;
    for fam in families.iter().filter(|f| f.frequency_hz > 0.0) {
        for k in 1..=max_harmonic.max(1) {
            let sb_range = if shaft_hz.is_some() && fam.label != "shaft" { -max_sideband..=max_sideband } else { 0..=0 };
            for s in sb_range {
                let line = k as f64 * fam.frequency_hz + s as f64 * shaft_hz.unwrap_or(0.0);
                if line <= 0.0 {
                    continue;
                }
                // Score: absolute distance, with sidebands penalised slightly so an exact
                // harmonic wins over a coincident sideband.
                let dist = (peak_hz - line).abs() * (1.0 + 1e-6 * s.unsigned_abs() as f64);
                let better = match &best {
                    None => true,
                    Some((d, _)) => dist < *d * (1.0 - 1e-9),
                };
                if better {
                    best = Some((
                        dist,
                        LineMatch {
                            label: fam.label.clone(),
                            harmonic: k,
                            sideband: s,
                            line_hz: line,
                            error_percent: (peak_hz - line) / line * 100.0,
                        },
                    ));
                }
            }
        }
    }
    best.map(|(_, m)| m)
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
        let m = nearest_line(324.5, &fams, Some(29.95), 5, 2).unwrap();
        assert_eq!((m.label.as_str(), m.harmonic, m.sideband), ("BPFI", 2, 0));
        let m = nearest_line(162.19 + 29.95, &fams, Some(29.95), 5, 2).unwrap();
        assert_eq!((m.label.as_str(), m.harmonic, m.sideband), ("BPFI", 1, 1));
        let m = nearest_line(59.9, &fams, Some(29.95), 5, 2).unwrap();
        assert_eq!((m.label.as_str(), m.harmonic), ("shaft", 2));
        assert!(nearest_line(-1.0, &fams, None, 5, 0).is_none());
    }
}
