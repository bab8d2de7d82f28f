//! Amplitude normalisation of a record (the first stage of the STSA–envelope diagnosis scheme).

use super::error::{check_finite, DspError};
use serde::{Deserialize, Serialize};

/// How the record is scaled after the optional mean removal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Normalisation {
    /// Divide by the peak absolute value, so that `max |y| = 1` (the diagnosis scheme's choice).
    #[default]
    Peak,
    /// Divide by the population standard deviation (ddof = 0), so that `std(y) = 1`.
    Std,
    /// No scaling (only the mean removal, if asked).
    None,
}

/// Parameters of [`normalise`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NormaliseParams {
    /// Scaling rule. Default [`Normalisation::Peak`].
    pub method: Normalisation,
    /// Subtract the arithmetic mean (DC bias) before scaling. Default `true`.
    pub remove_mean: bool,
}

impl Default for NormaliseParams {
    /// `method = Peak`, `remove_mean = true`: remove the DC bias, then divide by the peak
    /// absolute value, as in the diagnosis scheme of the bearing–bevel-gear study.
    fn default() -> Self {
        Self { method: Normalisation::Peak, remove_mean: true }
    }
}

impl NormaliseParams {
    /// Checks the parameters. Every combination of `method` and `remove_mean` is valid; the
    /// function exists so that a processing chain can validate all its stages the same way.
    pub fn validate(&self) -> Result<(), DspError> {
        Ok(())
    }
}

/// Root mean square of a record, `sqrt((1/n) Σ x[i]²)` (not about the mean); 0 for an empty one.
pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Normalise a record: optional mean removal, then scaling by the peak or the standard deviation.
///
/// Parameters
/// ----------
/// * `x` — the record (any unit, e.g. m/s²); at least one sample, all finite.
/// * `params` — [`NormaliseParams`]; default: remove the mean, then divide by the peak.
///
/// Returns
/// -------
/// The normalised record, same length as `x`, dimensionless for `Peak` and `Std` (unit of `x`
/// for `None`).
///
/// Errors: [`DspError::TooShort`] for an empty record, [`DspError::NonFinite`] for NaN/inf,
/// [`DspError::InvalidParameter`] (naming `x`) when the divisor is zero — a constant record
/// (all samples equal: zero peak after mean removal, or zero standard deviation; or an all-zero
/// record) cannot be normalised and is refused rather than turned into NaN or rounding noise.
///
/// Notes
/// -----
/// With `m = (1/n) Σ x[i]` and `x'[i] = x[i] − m` if `remove_mean` else `x[i]`:
///
/// * `Peak`: `y[i] = x'[i] / max_j |x'[j]|` — `max |y| = 1`;
/// * `Std`:  `y[i] = x'[i] / σ`, `σ = sqrt((1/n) Σ (x[i] − m)²)` (population standard deviation,
///   always taken about the mean, numpy `std(ddof=0)`) — `std(y) = 1`;
/// * `None`: `y = x'`.
///
/// Peak normalisation makes records of different gain comparable sample by sample (the scheme
/// compares simulated and measured envelope spectra); it is sensitive to a single spike, for
/// which `Std` is the robust alternative. O(n).
///
/// References
/// ----------
/// Diagnosis scheme (normalise → STSA → band-pass → Hilbert envelope → FFT) of the 15-DOF
/// bearing–bevel-gear study (papers/bearing_bevel_gear_15dof_stsa_envelope.txt, §4).
pub fn normalise(x: &[f64], params: &NormaliseParams) -> Result<Vec<f64>, DspError> {
    params.validate()?;
    if x.is_empty() {
        return Err(DspError::TooShort { what: "normalise", needed: 1, got: 0 });
    }
    check_finite(x)?;
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let offset = if params.remove_mean { mean } else { 0.0 };
    let divisor = match params.method {
        Normalisation::Peak => x.iter().fold(0.0_f64, |m, &v| m.max((v - offset).abs())),
        Normalisation::Std => (x.iter().map(|&v| (v - mean) * (v - mean)).sum::<f64>() / n).sqrt(),
        Normalisation::None => 1.0,
    };
    // A constant record is detected exactly: its mean carries a rounding error, so `x − mean`
    // would be ±1 ulp rather than 0 and would "normalise" to garbage of magnitude 1.
    let constant = x.iter().all(|&v| v == x[0]);
    let centred_or_std = params.remove_mean || params.method == Normalisation::Std;
    let degenerate = match params.method {
        Normalisation::None => false,
        _ => (constant && centred_or_std) || !(divisor.is_finite() && divisor > 0.0),
    };
    if degenerate {
        let divisor = if constant && centred_or_std { 0.0 } else { divisor };
        let what = match params.method {
            Normalisation::Peak => "peak absolute value",
            _ => "standard deviation",
        };
        return Err(DspError::InvalidParameter {
            name: "x",
            value: format!("constant record ({what} = {divisor:e})"),
            reason: format!(
                "a record whose {what} is zero cannot be scaled; check the channel (dead sensor?) or use method = \"none\""
            ),
        });
    }
    let y: Vec<f64> = x.iter().map(|&v| (v - offset) / divisor).collect();
    check_finite(&y)?;
    Ok(y)
}
