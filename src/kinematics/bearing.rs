//! Rolling-element bearing characteristic frequencies.

use super::CharacteristicFrequency;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Invalid bearing geometry or speed; names the field.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum KinematicsError {
    /// A field has an impossible value.
    #[error("bearing `{bearing}`: field `{field}` = {value}: {reason}")]
    InvalidField { bearing: String, field: &'static str, value: String, reason: String },
    /// The name is not in the catalogue.
    #[error("unknown bearing `{name}`; the catalogue has: {known}")]
    UnknownBearing { name: String, known: String },
}

/// Geometry of a rolling-element bearing (one row; double-row bearings give the balls per row
/// and the row count).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BearingGeometry {
    /// Designation, e.g. `SKF 6205-2RS JEM`.
    pub name: String,
    /// Rolling elements per row, `n`.
    pub rolling_elements: u32,
    /// Rolling-element (ball) diameter `d` in mm.
    pub ball_diameter_mm: f64,
    /// Pitch diameter `D` in mm.
    pub pitch_diameter_mm: f64,
    /// Contact angle `φ` in degrees.
    #[serde(default)]
    pub contact_angle_deg: f64,
    /// Number of rows (1 for deep-groove bearings). Fault frequencies are per row.
    #[serde(default = "one")]
    pub rows: u32,
    /// Where the numbers come from.
    #[serde(default)]
    pub source: String,
}

fn one() -> u32 {
    1
}

/// Characteristic frequencies of a bearing at one shaft speed (inner race rotating, outer race
/// fixed), in Hz.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FaultFrequencies {
    /// Shaft (inner-race) speed `f_r` in Hz.
    pub shaft_hz: f64,
    /// Ball-pass frequency, outer race: `n f_r / 2 · (1 − d/D cos φ)`.
    pub bpfo_hz: f64,
    /// Ball-pass frequency, inner race: `n f_r / 2 · (1 + d/D cos φ)`.
    pub bpfi_hz: f64,
    /// Ball spin frequency: `D f_r / (2d) · (1 − (d/D cos φ)²)`. A ball defect strikes the
    /// races at `2 × BSF` (labelled `2xBSF`).
    pub bsf_hz: f64,
    /// Fundamental train (cage) frequency: `f_r / 2 · (1 − d/D cos φ)`.
    pub ftf_hz: f64,
}

impl FaultFrequencies {
    /// The families used to label spectral lines: shaft, BPFO, BPFI, BSF, 2xBSF, FTF.
    pub fn families(&self) -> Vec<CharacteristicFrequency> {
        [
            ("shaft", self.shaft_hz),
            ("BPFO", self.bpfo_hz),
            ("BPFI", self.bpfi_hz),
            ("BSF", self.bsf_hz),
            ("2xBSF", 2.0 * self.bsf_hz),
            ("FTF", self.ftf_hz),
        ]
        .into_iter()
        .map(|(l, f)| CharacteristicFrequency { label: l.to_string(), frequency_hz: f })
        .collect()
    }

    /// Looks a fault name up: `bpfo`, `bpfi`, `bsf`, `2xbsf`, `ftf`, `shaft` (case-insensitive).
    pub fn by_name(&self, name: &str) -> Option<f64> {
        match name.to_ascii_lowercase().as_str() {
            "bpfo" | "outer" => Some(self.bpfo_hz),
            "bpfi" | "inner" => Some(self.bpfi_hz),
            "bsf" => Some(self.bsf_hz),
            "2xbsf" | "ball" => Some(2.0 * self.bsf_hz),
            "ftf" | "cage" => Some(self.ftf_hz),
            "shaft" | "1x" => Some(self.shaft_hz),
            _ => None,
        }
    }
}

impl BearingGeometry {
    /// Checks the geometry; errors name the field.
    pub fn validate(&self) -> Result<(), KinematicsError> {
        let bad = |field: &'static str, value: String, reason: &str| KinematicsError::InvalidField {
            bearing: self.name.clone(),
            field,
            value,
            reason: reason.to_string(),
        };
        if self.rolling_elements < 3 {
            return Err(bad("rolling_elements", self.rolling_elements.to_string(), "a bearing needs at least 3 rolling elements"));
        }
        if !(self.ball_diameter_mm.is_finite() && self.ball_diameter_mm > 0.0) {
            return Err(bad("ball_diameter_mm", self.ball_diameter_mm.to_string(), "must be a positive length in mm"));
        }
        if !(self.pitch_diameter_mm.is_finite() && self.pitch_diameter_mm > 0.0) {
            return Err(bad("pitch_diameter_mm", self.pitch_diameter_mm.to_string(), "must be a positive length in mm"));
        }
        if self.ball_diameter_mm >= self.pitch_diameter_mm {
            return Err(bad(
                "ball_diameter_mm",
                self.ball_diameter_mm.to_string(),
                &format!("must be smaller than the pitch diameter ({} mm)", self.pitch_diameter_mm),
            ));
        }
        // The balls must fit around the pitch circle: n d < π D.
        if self.rolling_elements as f64 * self.ball_diameter_mm >= std::f64::consts::PI * self.pitch_diameter_mm {
            return Err(bad(
                "rolling_elements",
                self.rolling_elements.to_string(),
                &format!("{} balls of {} mm do not fit on a {} mm pitch circle", self.rolling_elements, self.ball_diameter_mm, self.pitch_diameter_mm),
            ));
        }
        if !(self.contact_angle_deg.is_finite() && (0.0..90.0).contains(&self.contact_angle_deg)) {
            return Err(bad("contact_angle_deg", self.contact_angle_deg.to_string(), "must be in [0, 90) degrees"));
        }
        if self.rows == 0 {
            return Err(bad("rows", "0".into(), "must be at least 1"));
        }
        Ok(())
    }

    /// Characteristic frequencies at shaft speed `shaft_hz` (Hz, not rpm).
    ///
    /// # Notes
    /// With `r = d/D cos φ`: FTF = f_r(1 − r)/2, BPFO = n·FTF, BPFI = n f_r(1 + r)/2,
    /// BSF = D f_r (1 − r²)/(2d). Rigid-body kinematics without slip; real bearings run
    /// 1–2 % slower (Randall & Antoni 2011).
    pub fn fault_frequencies(&self, shaft_hz: f64) -> Result<FaultFrequencies, KinematicsError> {
        self.validate()?;
        if !(shaft_hz.is_finite() && shaft_hz > 0.0) {
            return Err(KinematicsError::InvalidField {
                bearing: self.name.clone(),
                field: "shaft_speed_hz",
                value: shaft_hz.to_string(),
                reason: "the shaft speed must be a positive number of Hz (rpm / 60)".into(),
            });
        }
        let n = self.rolling_elements as f64;
        let r = self.ball_diameter_mm / self.pitch_diameter_mm * self.contact_angle_deg.to_radians().cos();
        Ok(FaultFrequencies {
            shaft_hz,
            bpfo_hz: n * shaft_hz / 2.0 * (1.0 - r),
            bpfi_hz: n * shaft_hz / 2.0 * (1.0 + r),
            bsf_hz: self.pitch_diameter_mm * shaft_hz / (2.0 * self.ball_diameter_mm) * (1.0 - r * r),
            ftf_hz: shaft_hz / 2.0 * (1.0 - r),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::lookup_bearing;

    /// CWRU data center table for the drive-end 6205-2RS JEM, as multiples of shaft speed.
    #[test]
    fn skf_6205_matches_cwru_table() {
        let b = lookup_bearing("SKF 6205-2RS JEM").unwrap();
        let f = b.fault_frequencies(1.0).unwrap();
        assert!((f.bpfi_hz - 5.4152).abs() < 5e-4, "{}", f.bpfi_hz);
        assert!((f.bpfo_hz - 3.5848).abs() < 5e-4, "{}", f.bpfo_hz);
        assert!((f.bsf_hz - 2.3567).abs() < 5e-4, "{}", f.bsf_hz);
        assert!((2.0 * f.bsf_hz - 4.7135).abs() < 1e-3);
        assert!((f.ftf_hz - 0.39828).abs() < 5e-4, "{}", f.ftf_hz);
    }

    /// CWRU fan-end 6203-2RS JEM table: BPFI 4.9469, BPFO 3.0530, FTF 0.3817, 2xBSF 3.9874.
    #[test]
    fn skf_6203_matches_cwru_table() {
        let f = lookup_bearing("6203").unwrap().fault_frequencies(1.0).unwrap();
        assert!((f.bpfi_hz - 4.9469).abs() < 5e-4, "{}", f.bpfi_hz);
        assert!((f.bpfo_hz - 3.0530).abs() < 5e-4);
        assert!((f.ftf_hz - 0.3817).abs() < 5e-4);
        assert!((2.0 * f.bsf_hz - 3.9874).abs() < 1e-3, "{}", 2.0 * f.bsf_hz);
    }

    /// Identities that hold for any geometry: BPFO + BPFI = n f_r; BPFO = n FTF.
    #[test]
    fn kinematic_identities() {
        for b in super::super::catalogue() {
            let f = b.fault_frequencies(17.3).unwrap();
            let n = b.rolling_elements as f64;
            assert!((f.bpfo_hz + f.bpfi_hz - n * 17.3).abs() < 1e-9, "{}", b.name);
            assert!((f.bpfo_hz - n * f.ftf_hz).abs() < 1e-9);
        }
    }

    #[test]
    fn bad_geometry_names_the_field() {
        let mut b = lookup_bearing("6205").unwrap();
        b.ball_diameter_mm = 50.0;
        let e = b.validate().unwrap_err().to_string();
        assert!(e.contains("ball_diameter_mm") && e.contains("pitch diameter"), "{e}");
        let b = lookup_bearing("6205").unwrap();
        let e = b.fault_frequencies(-3.0).unwrap_err().to_string();
        assert!(e.contains("shaft_speed_hz"), "{e}");
        let mut b = lookup_bearing("6205").unwrap();
        b.rolling_elements = 40;
        assert!(b.validate().unwrap_err().to_string().contains("do not fit"));
    }
}
