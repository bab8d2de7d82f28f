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

/// A demodulation band chosen from a measurement's kurtogram, with the kurtogram and the limits
/// it was searched under.
#[derive(Debug, Clone)]
pub struct DemodulationBand {
    /// The band chosen: what `--band-from-kurtogram` sets as `envelope_band_hz`.
    pub band: KurtogramBand,
    /// The measurement's kurtogram.
    pub kurtogram: Kurtogram,
    /// The limits it was searched under ([`kurtogram_params_for`]).
    pub params: KurtogramParams,
}

/// The measurement's kurtogram under [`kurtogram_params_for`] and the band it chooses: what
/// `--band-from-kurtogram` sets as `envelope_band_hz`. With `resonances_hz` (a model's
/// [`crate::model::Machine::structural_resonances_hz`]), only bands that hold one of them are
/// chosen from: a model reproduces impacts ringing the resonances it has, so a band where the
/// measurement rings and the model has none compares ringing with noise (on CWRU 209, 234 and
/// 118 the unrestricted band, 3.8–5.6 kHz above the presets' 2.6 kHz resonator, led the search
/// to false claims: docs/loop-notebook.md "Session 71").
///
/// # Errors
/// The kurtogram's, and [`CompareError::Parameter`] when no allowed band holds a resonance.
pub fn demodulation_band(measured: &Signal, opts: &CompareOptions, resonances_hz: &[f64]) -> Result<DemodulationBand, CompareError> {
    let p = kurtogram_params_for(measured.fs_hz, opts);
    let k = kurtogram(&measured.samples, measured.fs_hz, &p).map_err(dsp_err("kurtogram of the measurement"))?;
    let band = holding_a_resonance(&k, measured.fs_hz, &p, resonances_hz).next().ok_or_else(|| CompareError::Parameter {
        name: "band_from_kurtogram",
        reason: format!(
            "no band of the kurtogram ({:.0}–{:.0} Hz, at least {:.0} Hz wide) holds a resonance of the model ({} Hz): give the demodulation band",
            p.search_band_hz.map_or(0.0, |b| b[0]),
            p.search_band_hz.map_or(measured.fs_hz / 2.0, |b| b[1]),
            p.min_band_width_hz,
            resonances_hz.iter().map(|f| format!("{f:.0}")).collect::<Vec<_>>().join(", ")
        ),
    })?;
    Ok(DemodulationBand { band, kurtogram: k, params: p })
}

/// The allowed bands of `k`, most impulsive first, that hold one of `resonances_hz` (all of
/// them when it is empty).
fn holding_a_resonance<'a>(k: &Kurtogram, fs_hz: f64, p: &KurtogramParams, resonances_hz: &'a [f64]) -> impl Iterator<Item = KurtogramBand> + 'a {
    k.ranked_bands(fs_hz, p).into_iter().filter(move |b| resonances_hz.is_empty() || resonances_hz.iter().any(|f| b.band_hz[0] <= *f && *f <= b.band_hz[1]))
}

/// A note when the demodulation band `opts.envelope_band_hz` is a poor one for comparing
/// with a model whose resonances are `resonances_hz`: it holds none of them, or its largest
/// spectral kurtosis is under half that of [`demodulation_band`]'s choice. `None` when the
/// band is reasonable or the kurtogram cannot be made (too short a record).
pub fn band_advice(measured: &Signal, opts: &CompareOptions, resonances_hz: &[f64]) -> Option<String> {
    let DemodulationBand { band: best, kurtogram: k, params: p } = demodulation_band(measured, opts, resonances_hz).ok()?;
    let [lo, hi] = opts.envelope_band_hz;
    let holds = resonances_hz.is_empty() || resonances_hz.iter().any(|f| lo <= *f && *f <= hi);
    let within = k.sk_within([lo, hi], measured.fs_hz, &p);
    let why = if !holds {
        format!("holds none of the model's resonances ({} Hz)", resonances_hz.iter().map(|f| format!("{f:.0}")).collect::<Vec<_>>().join(", "))
    } else if best.sk > 0.0 && within.is_none_or(|s| s < 0.5 * best.sk) {
        within.map_or("overlaps no band the kurtogram allows".to_string(), |s| format!("has a spectral kurtosis of at most {s:.2}"))
    } else {
        return None;
    };
    Some(format!(
        "the demodulation band {lo:.0}–{hi:.0} Hz {why}; the measurement's kurtogram finds {:.0}–{:.0} Hz at {:.2} (frames of {} samples){}: consider --band-from-kurtogram",
        best.band_hz[0],
        best.band_hz[1],
        best.sk,
        best.nperseg,
        if resonances_hz.is_empty() { "" } else { " holding one" }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::synth::{impact_train, white_noise, ImpactTrain};

    /// 10 s at 12 kHz: noise, impacts at 107.3 Hz ringing 2.6 kHz, and stronger, sparser
    /// impacts ringing 5 kHz (a band the model below has no resonance in).
    fn two_ringing_bands() -> Signal {
        let (fs, n) = (12000.0, 120_000);
        let ring = |fault_frequency_hz: f64, resonance_hz: f64, amplitude: f64, seed: u64| {
            impact_train(n, fs, &ImpactTrain { fault_frequency_hz, resonance_hz, damping_ratio: 0.05, jitter_fraction: 0.0, modulation_depth: 0.0, modulation_hz: 0.0, amplitude }, seed)
        };
        let (a, b, noise) = (ring(107.3, 2600.0, 1.0, 1), ring(9.7, 5000.0, 6.0, 2), white_noise(n, 0.3, 71));
        let x = a.iter().zip(&b).zip(&noise).map(|((a, b), w)| a + b + w).collect();
        Signal::new(x, fs, "two ringing bands", "g")
    }

    #[test]
    fn the_band_holds_a_resonance_of_the_model_when_given_one() {
        let s = two_ringing_bands();
        let opts = CompareOptions::default();
        let free = demodulation_band(&s, &opts, &[]).unwrap().band;
        assert!(free.band_hz[0] < 5000.0 && 5000.0 < free.band_hz[1], "{free:?}");
        let held = demodulation_band(&s, &opts, &[2600.0]).unwrap().band;
        assert!(held.band_hz[0] <= 2600.0 && 2600.0 <= held.band_hz[1] && held.band_hz[1] - held.band_hz[0] >= 400.0, "{held:?}");
        assert!(held.sk < free.sk);
        // A resonance no allowed band can hold: refused, naming it.
        let e = demodulation_band(&s, &opts, &[100.0]).unwrap_err().to_string();
        assert!(e.contains("band_from_kurtogram") && e.contains("100 Hz"), "{e}");
        // The note: the default 900–1800 Hz band holds no resonance of the model; the chosen one is fine.
        let note = band_advice(&s, &opts, &[2600.0]).expect("a note on 900–1800 Hz");
        assert!(note.contains("900–1800 Hz holds none of the model's resonances (2600 Hz)"), "{note}");
        let good = CompareOptions { envelope_band_hz: held.band_hz, ..opts.clone() };
        assert_eq!(band_advice(&s, &good, &[2600.0]), None);
        // Without a model, a band far from the impulsive one is named as such.
        let low = CompareOptions { envelope_band_hz: [500.0, 1500.0], ..opts };
        let note = band_advice(&s, &low, &[]).expect("a note on 500–1500 Hz");
        assert!(note.contains("has a spectral kurtosis of at most"), "{note}");
    }
}
