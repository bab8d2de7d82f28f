//! Bearings of the source papers and the bundled data.

use super::bearing::{BearingGeometry, KinematicsError};

fn b(name: &str, n: u32, d_mm: f64, pd_mm: f64, angle_deg: f64, rows: u32, source: &str) -> BearingGeometry {
    BearingGeometry {
        name: name.into(),
        rolling_elements: n,
        ball_diameter_mm: d_mm,
        pitch_diameter_mm: pd_mm,
        contact_angle_deg: angle_deg,
        rows,
        source: source.into(),
    }
}

/// The built-in bearing catalogue.
///
/// | bearing | n | d (mm) | D (mm) | φ | source |
/// |---|---|---|---|---|---|
/// | SKF 6205-2RS JEM | 9 | 7.94 | 39.04 | 0° | CWRU data center (drive end) |
/// | SKF 6203-2RS JEM | 8 | 6.746 | 28.50 | 0° | CWRU data center (fan end) |
/// | NSK 6202 | 8 | 5.953 | 25.0 | 0° | nominal 6202 geometry (15/64" balls); MFS gear shafts |
/// | MB ER-12K | 8 | 7.94 | 33.5 | 0° | SpectraQuest MFS test bearing (15-DOF paper) |
/// | Koyo 1205 | 12 per row, 2 rows | 7.12 | 38.5 | 0° | UNSW gearbox (Sawalhi & Randall 2008); BPFI 7.11 × shaft (paper: 71.2 Hz at 10 Hz) |
pub fn catalogue() -> Vec<BearingGeometry> {
    vec![
        b("SKF 6205-2RS JEM", 9, 7.94, 39.04, 0.0, 1, "CWRU Bearing Data Center, drive-end bearing (0.3126 in balls, 1.537 in pitch)"),
        b("SKF 6203-2RS JEM", 8, 6.7462, 28.4988, 0.0, 1, "CWRU Bearing Data Center, fan-end bearing (0.2656 in balls, 1.122 in pitch)"),
        b("NSK 6202", 8, 5.953, 25.0, 0.0, 1, "nominal 6202 deep-groove geometry (15/64 in balls); SpectraQuest MFS pinion/gear shafts"),
        b("MB ER-12K", 8, 7.94, 33.5, 0.0, 1, "SpectraQuest MFS test bearing: 8 balls of 7.94 mm on a 33.5 mm pitch diameter"),
        b("Koyo 1205", 12, 7.12, 38.5, 0.0, 2, "UNSW spur gearbox (Sawalhi & Randall 2008): self-aligning double-row, 12 balls per row"),
    ]
}

/// Finds a catalogue bearing by full name or a unique part of it (case-insensitive), e.g.
/// `6205`, `er-12k`, `koyo 1205`.
pub fn lookup_bearing(name: &str) -> Result<BearingGeometry, KinematicsError> {
    let key = name.trim().to_ascii_lowercase();
    let all = catalogue();
    if let Some(b) = all.iter().find(|b| b.name.to_ascii_lowercase() == key) {
        return Ok(b.clone());
    }
    let hits: Vec<&BearingGeometry> = all.iter().filter(|b| !key.is_empty() && b.name.to_ascii_lowercase().contains(&key)).collect();
    match hits.as_slice() {
        [one] => Ok((*one).clone()),
        _ => Err(KinematicsError::UnknownBearing {
            name: name.to_string(),
            known: all.iter().map(|b| b.name.as_str()).collect::<Vec<_>>().join(", "),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catalogue_is_valid_and_lookup_works() {
        for b in catalogue() {
            b.validate().unwrap();
        }
        assert_eq!(lookup_bearing("er-12k").unwrap().rolling_elements, 8);
        assert!(lookup_bearing("62").is_err(), "ambiguous part must be refused");
        let e = lookup_bearing("6309").unwrap_err().to_string();
        assert!(e.contains("6309") && e.contains("SKF 6205-2RS JEM"), "{e}");
    }

    /// MFS test bearing: BPFO 3.052 × shaft, BPFI 4.948 × shaft (SpectraQuest data sheet).
    #[test]
    fn mb_er12k_ratios() {
        let f = lookup_bearing("MB ER-12K").unwrap().fault_frequencies(1.0).unwrap();
        assert!((f.bpfo_hz - 3.052).abs() < 2e-3, "{}", f.bpfo_hz);
        assert!((f.bpfi_hz - 4.948).abs() < 2e-3, "{}", f.bpfi_hz);
    }

    /// UNSW gearbox: the paper quotes BPFI 71.2 Hz at a 10 Hz shaft.
    #[test]
    fn koyo_1205_bpfi_near_paper() {
        let f = lookup_bearing("Koyo 1205").unwrap().fault_frequencies(10.0).unwrap();
        assert!((f.bpfi_hz - 71.2).abs() / 71.2 < 0.005, "{}", f.bpfi_hz);
    }
}
