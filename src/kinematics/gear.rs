//! Gear mesh frequencies and their sidebands.

use super::{CharacteristicFrequency, KinematicsError};
use serde::{Deserialize, Serialize};

/// A pair of meshing gears.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearPair {
    /// Teeth on the driving gear (pinion).
    pub pinion_teeth: u32,
    /// Teeth on the driven gear.
    pub gear_teeth: u32,
}

/// Mesh frequency and shaft speeds of a gear pair.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeshFrequencies {
    /// Pinion shaft speed in Hz.
    pub pinion_shaft_hz: f64,
    /// Gear shaft speed in Hz: `f_p · z_p / z_g`.
    pub gear_shaft_hz: f64,
    /// Gear mesh frequency `GMF = z_p f_p = z_g f_g` in Hz.
    pub gmf_hz: f64,
    /// Hunting-tooth frequency `GMF / lcm(z_p, z_g)·…`: the rate at which the same tooth pair
    /// meets again, `f_p z_p / lcm(z_p, z_g)`.
    pub hunting_tooth_hz: f64,
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

impl GearPair {
    /// Mesh frequencies at pinion shaft speed `pinion_shaft_hz`.
    pub fn mesh_frequencies(&self, pinion_shaft_hz: f64) -> Result<MeshFrequencies, KinematicsError> {
        let bad = |field: &'static str, value: String, reason: &str| KinematicsError::InvalidField {
            bearing: format!("gear pair {}:{}", self.pinion_teeth, self.gear_teeth),
            field,
            value,
            reason: reason.into(),
        };
        if self.pinion_teeth < 5 {
            return Err(bad("pinion_teeth", self.pinion_teeth.to_string(), "a gear needs at least 5 teeth"));
        }
        if self.gear_teeth < 5 {
            return Err(bad("gear_teeth", self.gear_teeth.to_string(), "a gear needs at least 5 teeth"));
        }
        if !(pinion_shaft_hz.is_finite() && pinion_shaft_hz > 0.0) {
            return Err(bad("pinion_shaft_hz", pinion_shaft_hz.to_string(), "must be a positive speed in Hz"));
        }
        let gmf = self.pinion_teeth as f64 * pinion_shaft_hz;
        let lcm = self.pinion_teeth as u64 * self.gear_teeth as u64 / gcd(self.pinion_teeth, self.gear_teeth) as u64;
        Ok(MeshFrequencies {
            pinion_shaft_hz,
            gear_shaft_hz: gmf / self.gear_teeth as f64,
            gmf_hz: gmf,
            hunting_tooth_hz: gmf / lcm as f64,
        })
    }
}

impl MeshFrequencies {
    /// Families for line labelling: `GMF`, `pinion shaft`, `gear shaft`.
    pub fn families(&self) -> Vec<CharacteristicFrequency> {
        vec![
            CharacteristicFrequency { label: "GMF".into(), frequency_hz: self.gmf_hz },
            CharacteristicFrequency { label: "pinion shaft".into(), frequency_hz: self.pinion_shaft_hz },
            CharacteristicFrequency { label: "gear shaft".into(), frequency_hz: self.gear_shaft_hz },
        ]
    }

    /// Lines `k·GMF ± s·f_shaft` for `k = 1..=harmonics`, `s = 1..=sidebands`, for both shafts:
    /// `(label, frequency_hz)`, e.g. `("2xGMF-1xpinion", …)`. Negative frequencies are dropped.
    pub fn sidebands(&self, harmonics: u32, sidebands: u32) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for k in 1..=harmonics {
            let centre = k as f64 * self.gmf_hz;
            out.push((format!("{k}xGMF"), centre));
            for (name, fs) in [("pinion", self.pinion_shaft_hz), ("gear", self.gear_shaft_hz)] {
                for s in 1..=sidebands {
                    for sign in [-1.0, 1.0] {
                        let f = centre + sign * s as f64 * fs;
                        if f > 0.0 {
                            let op = if sign < 0.0 { '-' } else { '+' };
                            out.push((format!("{k}xGMF{op}{s}x{name}"), f));
                        }
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// MFS bevel pair 18/27 on a pinion shaft at 15 × 41.5/102 Hz.
    #[test]
    fn bevel_pair_mesh() {
        let fp = 15.0 * 41.5 / 102.0;
        let m = GearPair { pinion_teeth: 18, gear_teeth: 27 }.mesh_frequencies(fp).unwrap();
        assert!((m.gmf_hz - 18.0 * fp).abs() < 1e-12);
        assert!((m.gear_shaft_hz - fp * 18.0 / 27.0).abs() < 1e-12);
        // lcm(18, 27) = 54: the same pair meets every 3 pinion revolutions.
        assert!((m.hunting_tooth_hz - fp / 3.0).abs() < 1e-12);
        let sb = m.sidebands(2, 1);
        assert_eq!(sb.len(), 2 * 5);
        assert!(sb.iter().any(|(l, f)| l == "2xGMF+1xgear" && (f - (2.0 * m.gmf_hz + m.gear_shaft_hz)).abs() < 1e-12));
    }

    #[test]
    fn bad_gear_is_refused() {
        assert!(GearPair { pinion_teeth: 2, gear_teeth: 30 }.mesh_frequencies(10.0).unwrap_err().to_string().contains("pinion_teeth"));
        assert!(GearPair { pinion_teeth: 32, gear_teeth: 32 }.mesh_frequencies(f64::NAN).is_err());
    }
}
