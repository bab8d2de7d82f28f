//! The demodulation band of a comparison chosen from the measurement's kurtogram
//! ([`crate::dsp::kurtogram`]): the most impulsive band that is wide enough for the envelope
//! spectrum the comparison reads, and that its equiripple bandpass can be designed for.

use super::{dsp_err, CompareError, CompareOptions};
use crate::dsp::kurtogram::{kurtogram, Kurtogram, KurtogramBand, KurtogramParams};
use crate::signal::Signal;

/// The kurtogram's limits for a comparison under `opts` at `fs_hz`: a band at least twice the
/// envelope spectrum's upper edge wide (it must pass a line's sidebands up to that edge, 400
/// Hz for the default 0–200 Hz), lying above that width (the demodulated content must not fold
/// onto the shaft harmonics the envelope reads) and below 95 % of Nyquist (room for the
/// bandpass's upper transition).
pub fn kurtogram_params_for(fs_hz: f64, opts: &CompareOptions) -> KurtogramParams {
    let width = 2.0 * opts.envelope_spectrum_band_hz[1];
    KurtogramParams { min_band_width_hz: width, search_band_hz: Some([width.min(0.25 * fs_hz), 0.475 * fs_hz]), ..KurtogramParams::default() }
}

/// The measurement's kurtogram under [`kurtogram_params_for`] and the band it chooses: what
/// `--band-from-kurtogram` sets as `envelope_band_hz`.
pub fn demodulation_band(measured: &Signal, opts: &CompareOptions) -> Result<(Kurtogram, KurtogramBand), CompareError> {
    let p = kurtogram_params_for(measured.fs_hz, opts);
    let k = kurtogram(&measured.samples, measured.fs_hz, &p).map_err(dsp_err("kurtogram of the measurement"))?;
    let best = k.best.clone();
    Ok((k, best))
}

/// A note when the demodulation band `opts.envelope_band_hz` misses the measurement's most
/// impulsive band by far: its largest spectral kurtosis under half the kurtogram's best (or it
/// overlaps no allowed band). `None` when the band is reasonable or the kurtogram cannot be
/// made (too short a record).
pub fn band_advice(measured: &Signal, opts: &CompareOptions) -> Option<String> {
    let (k, best) = demodulation_band(measured, opts).ok()?;
    let p = kurtogram_params_for(measured.fs_hz, opts);
    let [lo, hi] = opts.envelope_band_hz;
    let within = k.sk_within([lo, hi], measured.fs_hz, &p);
    if best.sk <= 0.0 || within.is_some_and(|s| s >= 0.5 * best.sk) {
        return None;
    }
    let here = within.map_or("no band the kurtogram allows".to_string(), |s| format!("a spectral kurtosis of at most {s:.2}"));
    Some(format!(
        "the demodulation band {lo:.0}–{hi:.0} Hz has {here}, while the measurement's kurtogram finds {:.0}–{:.0} Hz at {:.2} (frames of {} samples): impacts ring there; consider --band-hz {:.0},{:.0} or --band-from-kurtogram",
        best.band_hz[0], best.band_hz[1], best.sk, best.nperseg, best.band_hz[0], best.band_hz[1]
    ))
}
