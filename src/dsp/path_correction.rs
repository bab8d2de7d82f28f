//! Data-driven transfer-path correction: a smooth gain curve G(f) that brings the broad shape of
//! a simulated spectrum onto a measured one. The planetary-gearbox paper corrects its dynamic
//! model's spectra toward the measurement with a learned network, because the sensor's transfer
//! path is hard to model; here the correction is the plainest version of that idea, a level per
//! frequency band:
//!
//! `G_k = mean over the PSD bins in band k of (10·log10 P_meas − 10·log10 P_sim)` (dB),
//!
//! on bands of equal width on a logarithmic axis, interpolated linearly in dB against
//! log-frequency between band centres (held flat beyond the outer centres), and applied as a
//! zero-phase Fourier filter (the record treated as periodic, as in [`super::lowpass`]).
//!
//! A linear filter acts on signal and noise alike: it reshapes the spectrum but cannot create
//! or remove modulation, so it leaves cyclic content and the envelope's line pattern to the
//! model, while it takes over whatever a smooth transfer path (or a band-limited mode wider
//! than a band) would explain.

use super::error::{check_finite, check_fs, DspError};
use super::fft;
use serde::{Deserialize, Serialize};

/// A fitted correction: gain in dB at band centres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathCorrection {
    /// Geometric centre of each band that held PSD bins, Hz (ascending).
    pub centre_hz: Vec<f64>,
    /// Gain at each centre, dB (measured over simulated power).
    pub gain_db: Vec<f64>,
    /// Mean dB difference over every bin used: the level a single overall gain would take.
    pub level_db: f64,
}

/// `n_bands` bands of equal width on a log axis from `low_hz` to `high_hz`: `(low, high)` edges.
///
/// Errors: `0 < low_hz < high_hz` finite, `n_bands ≥ 1`.
pub fn log_bands(low_hz: f64, high_hz: f64, n_bands: usize) -> Result<Vec<(f64, f64)>, DspError> {
    if !(low_hz.is_finite() && high_hz.is_finite() && low_hz > 0.0 && high_hz > low_hz) {
        return Err(DspError::InvalidParameter { name: "band_hz", value: format!("{low_hz}–{high_hz}"), reason: "must satisfy 0 < low < high".into() });
    }
    if n_bands == 0 {
        return Err(DspError::InvalidParameter { name: "n_bands", value: "0".into(), reason: "at least one band".into() });
    }
    let r = (high_hz / low_hz).ln() / n_bands as f64;
    Ok((0..n_bands).map(|k| (low_hz * (r * k as f64).exp(), low_hz * (r * (k + 1) as f64).exp())).collect())
}

/// Fits the correction from two PSDs in dB on one frequency axis. Bins outside every band are
/// ignored; a band without bins gets no centre. A bin belongs to the band `[low, high)` (the last
/// band also takes its upper edge).
///
/// Errors: lengths differ, non-finite values, no bin in any band.
pub fn fit_path_correction(frequency_hz: &[f64], measured_db: &[f64], simulated_db: &[f64], bands: &[(f64, f64)]) -> Result<PathCorrection, DspError> {
    if measured_db.len() != frequency_hz.len() || simulated_db.len() != frequency_hz.len() {
        return Err(DspError::InvalidParameter {
            name: "measured_db / simulated_db",
            value: format!("{} / {} values", measured_db.len(), simulated_db.len()),
            reason: format!("must match the {} frequencies", frequency_hz.len()),
        });
    }
    check_finite(measured_db)?;
    check_finite(simulated_db)?;
    let (mut centre_hz, mut gain_db) = (Vec::new(), Vec::new());
    let (mut total, mut count) = (0.0, 0usize);
    for (k, &(lo, hi)) in bands.iter().enumerate() {
        let last = k + 1 == bands.len();
        let (mut s, mut n) = (0.0, 0usize);
        for ((f, m), x) in frequency_hz.iter().zip(measured_db).zip(simulated_db) {
            if *f >= lo && (*f < hi || (last && *f <= hi)) {
                s += m - x;
                n += 1;
            }
        }
        if n > 0 {
            centre_hz.push((lo * hi).sqrt());
            gain_db.push(s / n as f64);
            total += s;
            count += n;
        }
    }
    if count == 0 {
        return Err(DspError::InvalidParameter { name: "bands", value: format!("{} bands", bands.len()), reason: "no PSD bin falls in any band".into() });
    }
    Ok(PathCorrection { centre_hz, gain_db, level_db: total / count as f64 })
}

impl std::fmt::Display for PathCorrection {
    /// `"500 Hz -12.5, 3000 Hz +3.0"`: each band centre with its gain in dB.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, (c, g)) in self.centre_hz.iter().zip(&self.gain_db).enumerate() {
            write!(f, "{}{c:.0} Hz {g:+.1}", if i == 0 { "" } else { ", " })?;
        }
        Ok(())
    }
}

impl PathCorrection {
    /// The mean of corrections fitted on the same bands (one per model realisation): the gain
    /// at each centre and the level averaged in dB. `None` if `each` is empty or its members
    /// have different centres.
    pub fn mean(each: &[PathCorrection]) -> Option<PathCorrection> {
        let first = each.first()?;
        if each.iter().any(|c| c.centre_hz != first.centre_hz || c.gain_db.len() != first.gain_db.len()) {
            return None;
        }
        let k = each.len() as f64;
        let gain_db = (0..first.gain_db.len()).map(|i| each.iter().map(|c| c.gain_db[i]).sum::<f64>() / k).collect();
        let level_db = each.iter().map(|c| c.level_db).sum::<f64>() / k;
        Some(PathCorrection { centre_hz: first.centre_hz.clone(), gain_db, level_db })
    }

    /// Gain in dB at `f_hz`: linear in dB against log-frequency between centres, flat beyond.
    pub fn gain_db_at(&self, f_hz: f64) -> f64 {
        let (c, g) = (&self.centre_hz, &self.gain_db);
        match c.len() {
            0 => 0.0,
            _ if f_hz <= c[0] => g[0],
            n if f_hz >= c[n - 1] => g[n - 1],
            _ => {
                let i = c.partition_point(|v| *v < f_hz);
                let w = (f_hz / c[i - 1]).ln() / (c[i] / c[i - 1]).ln();
                g[i - 1] * (1.0 - w) + g[i] * w
            }
        }
    }

    /// Filters `x` (sampled at `fs_hz`) through the gain curve, zero phase, by one real FFT of the
    /// whole record. `frequency_scale` maps the signal's frequencies onto the axis the correction
    /// was fitted on (the speed ratio of an order-normalised comparison; 1 otherwise).
    ///
    /// Errors: bad `fs_hz` or scale, non-finite `x`, fewer than 2 samples.
    pub fn apply(&self, x: &[f64], fs_hz: f64, frequency_scale: f64) -> Result<Vec<f64>, DspError> {
        check_fs(fs_hz)?;
        check_finite(x)?;
        if !(frequency_scale.is_finite() && frequency_scale > 0.0) {
            return Err(DspError::InvalidParameter { name: "frequency_scale", value: frequency_scale.to_string(), reason: "must be positive".into() });
        }
        let n = x.len();
        if n < 2 {
            return Err(DspError::TooShort { what: "path correction", needed: 2, got: n });
        }
        Ok(fft::zero_phase_filter(x, fs_hz, |f| 10f64.powf(self.gain_db_at(f * frequency_scale) / 20.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dsp::welch::{welch_psd, WelchParams};

    fn white(n: usize, seed: u64) -> Vec<f64> {
        crate::signal::synth::white_noise(n, 1.0, seed)
    }

    fn psd_db(x: &[f64], fs: f64) -> (Vec<f64>, Vec<f64>) {
        let p = welch_psd(x, fs, &WelchParams { nperseg: 1024, ..Default::default() }).unwrap();
        (p.frequency_hz.clone(), p.values.iter().map(|v| 10.0 * v.max(1e-30).log10()).collect())
    }

    /// |H(f)| of a first-order low-pass at `fc`, in dB.
    fn first_order_db(f: f64, fc: f64) -> f64 {
        -10.0 * (1.0 + (f / fc).powi(2)).log10()
    }

    #[test]
    fn bands_are_equal_on_a_log_axis_and_tile_the_range() {
        let b = log_bands(100.0, 6400.0, 6).unwrap();
        assert_eq!(b.len(), 6);
        assert!((b[0].0 - 100.0).abs() < 1e-9 && (b[5].1 - 6400.0).abs() < 1e-6);
        for (k, (lo, hi)) in b.iter().enumerate() {
            assert!((hi / lo - 2.0).abs() < 1e-12, "band {k}: one octave each");
        }
        assert!(log_bands(0.0, 10.0, 3).is_err() && log_bands(10.0, 5.0, 3).is_err() && log_bands(1.0, 10.0, 0).is_err());
    }

    #[test]
    fn the_mean_correction_averages_gains_and_levels_in_db() {
        let a = PathCorrection { centre_hz: vec![100.0, 1000.0], gain_db: vec![1.0, -3.0], level_db: 0.5 };
        let b = PathCorrection { centre_hz: vec![100.0, 1000.0], gain_db: vec![3.0, -1.0], level_db: 1.5 };
        let m = PathCorrection::mean(&[a.clone(), b]).unwrap();
        assert_eq!((m.gain_db, m.level_db), (vec![2.0, -2.0], 1.0));
        assert_eq!(PathCorrection::mean(std::slice::from_ref(&a)), Some(a.clone()));
        let other = PathCorrection { centre_hz: vec![100.0, 2000.0], ..a.clone() };
        assert_eq!(PathCorrection::mean(&[a, other]), None);
        assert_eq!(PathCorrection::mean(&[]), None);
    }

    #[test]
    fn a_constant_level_difference_is_one_flat_gain() {
        // Amplitude × 3 is +9.542 dB in every band, whatever the spectrum's shape.
        let f: Vec<f64> = (1..500).map(|k| k as f64 * 10.0).collect();
        let sim: Vec<f64> = f.iter().map(|v| -40.0 - 0.01 * v).collect();
        let meas: Vec<f64> = sim.iter().map(|v| v + 20.0 * 3f64.log10()).collect();
        let c = fit_path_correction(&f, &meas, &sim, &log_bands(20.0, 5000.0, 8).unwrap()).unwrap();
        for g in c.gain_db.iter().chain([&c.level_db]) {
            assert!((g - 9.5424).abs() < 1e-3, "{g}");
        }
        assert!((c.gain_db_at(3.0) - 9.5424).abs() < 1e-3 && (c.gain_db_at(9000.0) - 9.5424).abs() < 1e-3);
    }

    #[test]
    fn a_known_transfer_path_is_recovered_and_removed() {
        // "Measured": white noise through a first-order low-pass at 800 Hz (applied exactly,
        // in the Fourier domain); "simulated": other white noise. The fitted correction must
        // follow |H| band by band, and the corrected simulation's PSD must match the
        // measurement's within the Welch estimate's scatter.
        let (fs, n) = (12000.0, 120_000);
        let fc = 800.0;
        let path = PathCorrection { centre_hz: (0..600).map(|k| 1.0 + k as f64 * 10.0).collect(), gain_db: (0..600).map(|k| first_order_db(1.0 + k as f64 * 10.0, fc)).collect(), level_db: 0.0 };
        let meas = path.apply(&white(n, 1), fs, 1.0).unwrap();
        let sim = white(n, 2);
        let (f, pm) = psd_db(&meas, fs);
        let (_, ps) = psd_db(&sim, fs);
        let bands = log_bands(50.0, 6000.0, 14).unwrap();
        let c = fit_path_correction(&f, &pm, &ps, &bands).unwrap();
        assert_eq!(c.centre_hz.len(), 14);
        for ((&(lo, hi), fc_k), g) in bands.iter().zip(&c.centre_hz).zip(&c.gain_db) {
            // Expected: the band mean of |H|² in dB over the Welch bins of the band.
            let inband: Vec<f64> = f.iter().copied().filter(|v| *v >= lo && *v < hi).collect();
            let want = inband.iter().map(|v| first_order_db(*v, fc)).sum::<f64>() / inband.len() as f64;
            // A Welch bin of 233 averages scatters by 4.34/√233 = 0.28 dB, a difference of two
            // by 0.40 dB: allow 3σ of the band mean, plus 0.2 dB of bias.
            let tol = 0.2 + 1.2 / (inband.len() as f64).sqrt();
            assert!((g - want).abs() < tol, "band at {fc_k:.0} Hz: {g:.2} dB, |H| {want:.2} dB (±{tol:.2}, {} bins)", inband.len());
        }
        let corrected = c.apply(&sim, fs, 1.0).unwrap();
        let (_, pc) = psd_db(&corrected, fs);
        let before = rms_db_error(&f, &pm, &ps);
        let after = rms_db_error(&f, &pm, &pc);
        assert!(before > 8.0, "the path must matter: {before:.2} dB");
        assert!(after < 1.0, "corrected PSD off by {after:.2} dB rms (before {before:.2})");
    }

    fn rms_db_error(f: &[f64], a: &[f64], b: &[f64]) -> f64 {
        let d: Vec<f64> = f.iter().zip(a).zip(b).filter(|((f, _), _)| **f >= 50.0 && **f <= 5900.0).map(|((_, x), y)| (x - y).powi(2)).collect();
        (d.iter().sum::<f64>() / d.len() as f64).sqrt()
    }

    #[test]
    fn the_speed_scale_reads_the_curve_at_the_stretched_frequency() {
        // A step curve: 0 dB at 1 kHz, -20 dB at 4 kHz. A 2 kHz tone of a signal whose
        // frequencies are stretched by 2 is read at 4 kHz.
        let c = PathCorrection { centre_hz: vec![1000.0, 4000.0], gain_db: vec![0.0, -20.0], level_db: -10.0 };
        assert!((c.gain_db_at(2000.0) + 10.0).abs() < 1e-12, "midway on the log axis");
        assert_eq!(c.to_string(), "1000 Hz +0.0, 4000 Hz -20.0");
        let (fs, n) = (12000.0, 12000);
        let x: Vec<f64> = (0..n).map(|i| (std::f64::consts::TAU * 2000.0 * i as f64 / fs).sin()).collect();
        let y = c.apply(&x, fs, 2.0).unwrap();
        let r = (y.iter().map(|v| v * v).sum::<f64>() / (x.iter().map(|v| v * v).sum::<f64>())).sqrt();
        assert!((20.0 * r.log10() + 20.0).abs() < 1e-6, "{}", 20.0 * r.log10());
    }

    #[test]
    fn bad_input_is_refused_with_its_name() {
        let f = vec![10.0, 20.0];
        assert!(fit_path_correction(&f, &[1.0], &[1.0, 2.0], &[(5.0, 30.0)]).is_err());
        assert!(fit_path_correction(&f, &[1.0, f64::NAN], &[1.0, 2.0], &[(5.0, 30.0)]).is_err());
        let e = fit_path_correction(&f, &[1.0, 2.0], &[1.0, 2.0], &[(100.0, 300.0)]).unwrap_err();
        assert!(e.to_string().contains("no PSD bin"), "{e}");
        let c = PathCorrection { centre_hz: vec![100.0], gain_db: vec![0.0], level_db: 0.0 };
        assert!(c.apply(&[1.0], 100.0, 1.0).is_err() && c.apply(&[1.0, 2.0], 100.0, f64::NAN).is_err() && c.apply(&[1.0, 2.0], -1.0, 1.0).is_err());
    }
}
