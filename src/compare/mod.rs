//! Model-vs-measurement comparison: aligned quantities in several domains (envelope spectrum,
//! Welch PSD in dB, SCF α-slices, time RMS), their metrics, and a residual map that says where
//! the model fails.

pub mod calibrate;
pub mod demodulation_band;
pub mod diagnose;
pub mod hidden;
pub mod joint;
pub mod metrics;
pub mod removal;
pub mod residual;
pub mod strength_range;

pub use metrics::{metrics, metrics_normalised_by, pearson, xcorr_peak, Metrics, Normaliser};
pub use calibrate::{evaluate, fit, fit_with_progress, objective, DecisionRule, Fit, LoopError, LoopOptions, LoopProgress, Param, FIT_DURATION_RANGE_S, MAX_POLISH_SWEEPS, MAX_REALISATIONS, SHORT_EXPLAINED};
pub use diagnose::{apply_trial, diagnose, diagnose_with, machine_families, run_loop, seed_floor, Diagnosis, EffectTrial, Round, SecondLook, MAX_LOOP_ROUNDS, check_loop_rounds};
pub use residual::{residual_map, ResidualItem, ResidualMap};

use crate::dsp::{self, remez::BandpassSpec, spectrum::Spectrum};
use crate::model::STANDARD_GRAVITY;
use crate::signal::Signal;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why two signals cannot be compared.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CompareError {
    /// Units that cannot be converted into each other.
    #[error("units differ: measured `{measured}`, simulated `{simulated}`; convert one (only g ↔ m/s^2 is converted automatically)")]
    Units { measured: String, simulated: String },
    /// Shaft speeds too far apart for order normalisation.
    #[error("shaft speeds differ by {percent:.1} % (measured {measured_hz:.3} Hz, simulated {simulated_hz:.3} Hz), more than the {limit_percent} % that order normalisation may bridge; set the model's speed")]
    Speed { measured_hz: f64, simulated_hz: f64, percent: f64, limit_percent: f64 },
    /// Too little common data.
    #[error("too little common data: {0}")]
    TooShort(String),
    /// A DSP step failed.
    #[error("{domain}: {message}")]
    Dsp { domain: String, message: String },
    /// A parameter is unusable.
    #[error("parameter `{name}`: {reason}")]
    Parameter { name: &'static str, reason: String },
}

/// The most bands a transfer-path correction may have ([`CompareOptions::path_correction_bands`]);
/// the CLI, batch jobs and the app share the limit.
pub const MAX_PATH_CORRECTION_BANDS: usize = 64;

/// Refuses more than [`MAX_PATH_CORRECTION_BANDS`] correction bands: [`Reference::new`] and
/// [`LoopOptions::validate`] share this check.
pub(crate) fn check_path_correction_bands(n: usize) -> Result<(), CompareError> {
    if n > MAX_PATH_CORRECTION_BANDS {
        return Err(CompareError::Parameter { name: "path_correction_bands", reason: format!("{n}: at most {MAX_PATH_CORRECTION_BANDS} bands (0 = off)") });
    }
    Ok(())
}

/// Comparison settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CompareOptions {
    /// Demodulation band of the envelope analysis, Hz (equiripple bandpass, seed spec figures).
    pub envelope_band_hz: [f64; 2],
    /// Band of the envelope spectrum compared, Hz. Default 0–200 (the seed's).
    pub envelope_spectrum_band_hz: [f64; 2],
    /// Band of the PSD compared, Hz; `None` = 0 to the lower Nyquist.
    pub psd_band_hz: Option<[f64; 2]>,
    /// Welch segment length. Default 2048.
    pub psd_nperseg: usize,
    /// Also compare SCF α-slices (cost ≈ 0.1 s per signal). Default true.
    pub scf: bool,
    /// Segment length of the SCF. Default 256.
    pub scf_nperseg: usize,
    /// Normalise every SCF α-slice's NRMSE by the measured SCF over all compared slices
    /// instead of by that slice's own measured values (the seed's max − min, taken per slice).
    /// The SCF is one quantity, S(α, f), and |S(α, f)| ≤ √(S(0, f + α/2) S(0, f − α/2)) bounds
    /// every slice by the α = 0 one: with one normaliser a slice of strong cyclostationarity
    /// (an inner-race fault's shaft-rate modulation) keeps most of its weight, while a slice
    /// holding little but estimator noise (the shaft slice of a healthy gear) is no longer
    /// scaled up to the range of that noise, whose seed-to-seed scatter hides weak effects
    /// from the objective. Default false: tried on fresh seeds in session 36 and not adopted by
    /// its rule (one find fewer on the gear base, a seen casing mode under the floor margin;
    /// docs/loop-notebook.md "One normaliser for the SCF slices").
    pub scf_one_normaliser: bool,
    /// NRMSE normaliser. Default range (the seed's).
    pub normaliser: Normaliser,
    /// Largest speed mismatch bridged by order normalisation, %. Default 5.
    pub max_speed_mismatch_percent: f64,
    /// Fault frequency for the SCF α-slice (Hz); `None` = only α = 0 and shaft speed.
    pub fault_frequency_hz: Option<f64>,
    /// Transfer-path correction ([`dsp::path_correction`]): before comparing, the simulated
    /// signal is filtered by a gain curve fitted on this many log-spaced bands of the PSD band
    /// (from 4 Welch bins up), so the comparison judges the model on what a smooth transfer
    /// path cannot give (lines, modulation, cyclic content, narrow resonances). 0 (the default):
    /// off, only the overall gain is solved (by the loop).
    pub path_correction_bands: usize,
}

impl Default for CompareOptions {
    fn default() -> Self {
        Self {
            envelope_band_hz: [900.0, 1800.0],
            envelope_spectrum_band_hz: [0.0, 200.0],
            psd_band_hz: None,
            psd_nperseg: 2048,
            scf: true,
            scf_nperseg: 256,
            scf_one_normaliser: false,
            normaliser: Normaliser::Range,
            max_speed_mismatch_percent: 5.0,
            fault_frequency_hz: None,
            path_correction_bands: 0,
        }
    }
}

/// One compared quantity on a common axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DomainComparison {
    /// `envelope`, `psd_db`, `scf_alpha_0`, `scf_alpha_shaft`, `scf_alpha_fault`.
    pub domain: String,
    /// What the values are, with unit.
    pub quantity: String,
    /// Common axis (Hz).
    pub frequency_hz: Vec<f64>,
    /// Measured values.
    pub measured: Vec<f64>,
    /// Simulated values (on the measured axis).
    pub simulated: Vec<f64>,
    /// Metrics of simulated against measured.
    pub metrics: Metrics,
    /// The simulated mean's own scatter, in the quantity's unit: the RMS over the axis of the
    /// standard error s/√K of the mean of K realisations ([`Reference::compare_mean`]); 0 with
    /// one realisation, where it cannot be estimated.
    #[serde(default)]
    pub scatter_rmse: f64,
}

impl DomainComparison {
    /// NRMSE (%) with the simulated mean's own scatter taken out:
    /// `√max(RMSE² − scatter², 0) / normaliser × 100`. The measured quantity m and the mean
    /// s̄ of K independent realisations give `E[(m − s̄)²] = E[(m − μ)²] + Var(s)/K` per bin
    /// (μ the model's expected quantity), and the sample variance s² of the realisations is
    /// an unbiased estimate of Var(s): so `RMSE² − scatter²` estimates the squared distance of
    /// the measurement to the model's *expected* quantity without the model's own randomness
    /// in it, which otherwise penalises random effects (slip) the more the fewer realisations.
    /// Equal to `metrics.nrmse_percent` when the scatter is 0.
    pub fn debiased_nrmse_percent(&self) -> f64 {
        if self.scatter_rmse == 0.0 {
            return self.metrics.nrmse_percent;
        }
        metrics::nrmse_percent(self.debiased_rmse(), self.metrics.normaliser_value)
    }

    /// The RMSE with the simulated mean's own scatter taken out, `√max(RMSE² − scatter², 0)`
    /// (see [`Self::debiased_nrmse_percent`]); the RMSE itself when the scatter is 0.
    pub fn debiased_rmse(&self) -> f64 {
        if self.scatter_rmse == 0.0 {
            return self.metrics.rmse;
        }
        (self.metrics.rmse.powi(2) - self.scatter_rmse.powi(2)).max(0.0).sqrt()
    }
}

/// How the two signals were brought together.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Alignment {
    /// Common sampling rate, Hz: the lower of the two signals' ([`compare`]), or the
    /// measurement's when the simulated signal is compared with it as it is ([`align`]).
    pub fs_hz: f64,
    /// The simulated signal's own rate when it was resampled to `fs_hz`; `None` (JSON null)
    /// when compared at its own.
    pub resampled_from_hz: Option<f64>,
    /// The measurement's own rate when it was brought down to the simulated signal's
    /// ([`at_most_rate`]); `None` (JSON null, as `resampled_from_hz`) when compared at its own.
    #[serde(default)]
    pub measured_resampled_from_hz: Option<f64>,
    /// Factor applied to the simulated signal's unit (e.g. 1/9.80665 for m/s² → g).
    pub unit_factor: f64,
    /// Measured / simulated shaft speed applied to the simulated frequency axes (order
    /// normalisation); 1 when equal or unknown.
    pub speed_ratio: f64,
    /// Duration compared, s (the shorter record).
    pub duration_s: f64,
    /// Simulated/measured RMS in dB over the compared duration.
    pub rms_ratio_db: f64,
}

impl Alignment {
    /// The common rate in words, naming the signal resampled to it: "12000 Hz (the measurement
    /// resampled from 48000 Hz)".
    pub fn rate_in_words(&self) -> String {
        let from = |what: &str, hz: Option<f64>| hz.map(|hz| format!(" ({what} resampled from {hz:.0} Hz)")).unwrap_or_default();
        format!("{:.0} Hz{}{}", self.fs_hz, from("the measurement", self.measured_resampled_from_hz), from("the simulation", self.resampled_from_hz))
    }
}

/// The result of [`compare`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Alignment applied.
    pub alignment: Alignment,
    /// One entry per domain.
    pub domains: Vec<DomainComparison>,
    /// The transfer-path correction applied to the simulated signal before comparing
    /// ([`CompareOptions::path_correction_bands`]); `None` when off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_correction: Option<dsp::path_correction::PathCorrection>,
}

impl Comparison {
    /// The comparison of one domain.
    pub fn domain(&self, name: &str) -> Option<&DomainComparison> {
        self.domains.iter().find(|d| d.domain == name)
    }

    /// Envelope NRMSE in percent (the loop's headline error).
    pub fn envelope_nrmse(&self) -> f64 {
        self.domain("envelope").map(|d| d.metrics.nrmse_percent).unwrap_or(f64::INFINITY)
    }
}

/// `measured` at a sampling rate of at most `fs_hz`: resampled down (by the Fourier method,
/// [`dsp::resample::resample`], an ideal anti-alias filter at the new Nyquist frequency) when
/// its own rate is higher, borrowed as it is otherwise. A model sampled at `fs_hz` holds
/// nothing above `fs_hz / 2`, so a comparison at a measurement's higher rate would set the
/// measured content there against nothing: the PSD domain would count bands the model cannot
/// have, and the loop would fit noise levels and effects to them (CWRU's healthy record 097,
/// sampled at 48 kHz, against the 12 kHz 6205 model: a load zone claimed, where at 12 kHz
/// nothing is missing; docs/loop-notebook.md "Session 72"). [`compare`], [`diagnose`],
/// [`run_loop`] and the loop's other entry points call it with the model's rate. A resampled
/// signal records the rate it came from ([`resampled_from_hz`]), which a
/// [`Diagnosis`](diagnose::Diagnosis) reports.
///
/// # Errors
/// [`CompareError::Dsp`] when the record cannot be resampled (too short, not finite).
/// The key of `meta.extra` where [`at_most_rate`] records the rate, Hz, a measurement was
/// resampled from (its `fs_source` still says where that first rate came from).
pub const RESAMPLED_FROM_KEY: &str = "resampled_from_hz";

/// The rate `s` was resampled from by [`at_most_rate`], Hz; None when it was not.
pub fn resampled_from_hz(s: &Signal) -> Option<f64> {
    s.meta.extra.get(RESAMPLED_FROM_KEY)?.parse().ok()
}

pub fn at_most_rate(measured: &Signal, fs_hz: f64) -> Result<std::borrow::Cow<'_, Signal>, CompareError> {
    if !(fs_hz.is_finite() && fs_hz > 0.0) {
        return Err(CompareError::Parameter { name: "fs_hz", reason: format!("{fs_hz}: the rate to compare at must be a positive frequency") });
    }
    if measured.fs_hz <= fs_hz * (1.0 + 1e-9) {
        return Ok(std::borrow::Cow::Borrowed(measured));
    }
    let samples = dsp::resample::resample(&measured.samples, measured.fs_hz, fs_hz).map_err(|e| CompareError::Dsp { domain: "resampling the measurement".into(), message: e.to_string() })?;
    let mut meta = measured.meta.clone();
    meta.extra.entry(RESAMPLED_FROM_KEY.into()).or_insert_with(|| format!("{}", measured.fs_hz));
    Ok(std::borrow::Cow::Owned(Signal { samples, fs_hz, name: measured.name.clone(), unit: measured.unit.clone(), meta }))
}

/// Brings `simulated` onto `measured`'s unit, sampling rate and length; refuses what cannot be
/// compared (different units, speeds beyond the order-normalisation limit).
pub fn align(measured: &Signal, simulated: &Signal, opts: &CompareOptions) -> Result<(Vec<f64>, Vec<f64>, Alignment), CompareError> {
    let unit_factor = match (measured.unit.as_str(), simulated.unit.as_str()) {
        (a, b) if a == b => 1.0,
        ("g", "m/s^2") => 1.0 / STANDARD_GRAVITY,
        ("m/s^2", "g") => STANDARD_GRAVITY,
        (a, b) => return Err(CompareError::Units { measured: a.to_string(), simulated: b.to_string() }),
    };
    let speed_ratio = match (measured.meta.shaft_speed_hz, simulated.meta.shaft_speed_hz) {
        (Some(m), Some(s)) if m > 0.0 && s > 0.0 => {
            let pct = (m - s).abs() / m * 100.0;
            if pct > opts.max_speed_mismatch_percent {
                return Err(CompareError::Speed { measured_hz: m, simulated_hz: s, percent: pct, limit_percent: opts.max_speed_mismatch_percent });
            }
            m / s
        }
        _ => 1.0,
    };
    let mut sim: Vec<f64> = simulated.samples.iter().map(|v| v * unit_factor).collect();
    let resampled_from_hz = if (simulated.fs_hz - measured.fs_hz).abs() > 1e-9 * measured.fs_hz {
        sim = dsp::resample::resample(&sim, simulated.fs_hz, measured.fs_hz).map_err(|e| CompareError::Dsp { domain: "resampling".into(), message: e.to_string() })?;
        Some(simulated.fs_hz)
    } else {
        None
    };
    let n = measured.len().min(sim.len());
    if n < 1024 {
        return Err(CompareError::TooShort(format!("{n} common samples at {} Hz; need at least 1024", measured.fs_hz)));
    }
    let meas = measured.samples[..n].to_vec();
    sim.truncate(n);
    let rms_ratio_db = 20.0 * (dsp::rms(&sim) / dsp::rms(&meas).max(1e-300)).log10();
    Ok((meas, sim, Alignment { fs_hz: measured.fs_hz, resampled_from_hz, measured_resampled_from_hz: None, unit_factor, speed_ratio, duration_s: n as f64 / measured.fs_hz, rms_ratio_db }))
}

fn dsp_err(domain: &str) -> impl Fn(dsp::DspError) -> CompareError + '_ {
    move |e| CompareError::Dsp { domain: domain.to_string(), message: e.to_string() }
}

/// Linear interpolation of `(x, y)` at `at` (clamped at the ends).
fn interp(x: &[f64], y: &[f64], at: f64) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let i = x.partition_point(|v| *v < at);
    if i == 0 {
        return y[0];
    }
    if i >= x.len() {
        return y[x.len() - 1];
    }
    let (x0, x1) = (x[i - 1], x[i]);
    let w = if x1 > x0 { (at - x0) / (x1 - x0) } else { 0.0 };
    y[i - 1] * (1.0 - w) + y[i] * w
}

/// Puts a simulated spectrum on the measured axis, stretching its frequencies by the speed
/// ratio (order normalisation).
fn onto_axis(meas: &Spectrum, sim: &Spectrum, speed_ratio: f64) -> Vec<f64> {
    let xs: Vec<f64> = sim.frequency_hz.iter().map(|f| f * speed_ratio).collect();
    meas.frequency_hz.iter().map(|&f| interp(&xs, &sim.values, f)).collect()
}

fn unit_rms(x: &[f64]) -> Vec<f64> {
    let rms = dsp::rms(x);
    if rms > 0.0 {
        x.iter().map(|v| v / rms).collect()
    } else {
        x.to_vec()
    }
}

/// The envelope spectrum the comparison uses: the signal scaled to unit RMS, bandpassed by the
/// equiripple filter over `envelope_band_hz` (seed figures: 1 dB ripple, 60/80 dB stopbands,
/// transitions of 10 % of the band or 200 Hz, whichever is smaller), then the envelope spectrum
/// over `envelope_spectrum_band_hz`.
pub fn envelope_spectrum_for_compare(x: &[f64], fs_hz: f64, opts: &CompareOptions) -> Result<Spectrum, CompareError> {
    let taps = envelope_filter(fs_hz, opts)?;
    envelope_with_taps(x, fs_hz, &taps, opts)
}

fn envelope_filter(fs_hz: f64, opts: &CompareOptions) -> Result<Vec<f64>, CompareError> {
    let [lo, hi] = opts.envelope_band_hz;
    let tw = (0.1 * (hi - lo)).clamp(1.0, 200.0);
    let spec = BandpassSpec { pass_band_hz: [lo, hi], transition_low_hz: tw, transition_high_hz: tw, ..BandpassSpec::default() };
    Ok(dsp::remez::design_bandpass(&spec, fs_hz).map_err(dsp_err("envelope bandpass"))?.taps)
}

fn envelope_with_taps(x: &[f64], fs_hz: f64, taps: &[f64], opts: &CompareOptions) -> Result<Spectrum, CompareError> {
    let y = dsp::remez::filtfilt_fir(taps, &unit_rms(x)).map_err(dsp_err("envelope bandpass"))?;
    let p = dsp::envelope::EnvelopeParams { band_hz: Some(opts.envelope_spectrum_band_hz), ..Default::default() };
    dsp::envelope::envelope_spectrum(&y, fs_hz, &p).map_err(dsp_err("envelope spectrum"))
}

/// The measured side of a comparison, computed once per common length and reused for every
/// simulated candidate (the loop compares hundreds of simulations with one measurement).
pub struct Reference {
    measured: Signal,
    opts: CompareOptions,
    taps: Vec<f64>,
    cache: std::sync::Mutex<Vec<(usize, std::sync::Arc<MeasuredDomains>)>>,
}

struct MeasuredDomains {
    envelope: Spectrum,
    psd: Spectrum,
    psd_db: Vec<f64>,
    scf_params: Option<dsp::scf::ScfParams>,
    slices: Vec<(&'static str, f64, Vec<f64>, Vec<f64>)>,
}

impl Reference {
    /// Prepares the measured side (designs the envelope filter).
    pub fn new(measured: &Signal, opts: &CompareOptions) -> Result<Self, CompareError> {
        if let Some(f) = opts.fault_frequency_hz {
            if !(f.is_finite() && f > 0.0 && f < measured.fs_hz / 2.0) {
                return Err(CompareError::Parameter { name: "fault_frequency_hz", reason: format!("{f} Hz: must be a frequency between 0 and the Nyquist frequency ({} Hz)", measured.fs_hz / 2.0) });
            }
        }
        check_path_correction_bands(opts.path_correction_bands)?;
        let taps = envelope_filter(measured.fs_hz, opts)?;
        Ok(Self { measured: measured.clone(), opts: opts.clone(), taps, cache: std::sync::Mutex::new(Vec::new()) })
    }

    /// The measured signal.
    pub fn measured(&self) -> &Signal {
        &self.measured
    }

    /// The options.
    pub fn options(&self) -> &CompareOptions {
        &self.opts
    }

    fn domains(&self, meas: &[f64]) -> Result<std::sync::Arc<MeasuredDomains>, CompareError> {
        let n = meas.len();
        if let Some((_, d)) = self.cache.lock().unwrap_or_else(|e| e.into_inner()).iter().find(|(k, _)| *k == n) {
            return Ok(d.clone());
        }
        let fs = self.measured.fs_hz;
        let opts = &self.opts;
        let envelope = envelope_with_taps(meas, fs, &self.taps, opts)?;
        let wp = dsp::welch::WelchParams { nperseg: opts.psd_nperseg.min(n), ..Default::default() };
        let pm = dsp::welch::welch_psd(meas, fs, &wp).map_err(dsp_err("psd"))?.to_spectrum(&self.measured.unit);
        let [plo, phi] = opts.psd_band_hz.unwrap_or([0.0, fs / 2.0]);
        let psd = pm.band(plo, phi).map_err(dsp_err("psd band"))?;
        let psd_db = psd.values.iter().map(|v| db(*v)).collect();
        let (mut scf_params, mut slices) = (None, Vec::new());
        if opts.scf {
            let mut alphas = vec![("scf_alpha_0", 0.0)];
            if let Some(fr) = self.measured.meta.shaft_speed_hz {
                alphas.push(("scf_alpha_shaft", fr));
            }
            if let Some(ff) = opts.fault_frequency_hz {
                alphas.push(("scf_alpha_fault", ff));
            }
            let amax = alphas.iter().map(|a| a.1).fold(0.0f64, f64::max) * 1.02 + 1.0;
            let p = dsp::scf::ScfParams { alpha_min_hz: 0.0, alpha_max_hz: amax.min(fs / 2.0), nperseg: opts.scf_nperseg, ..Default::default() };
            let sm = dsp::scf::fast_scf(&unit_rms(meas), fs, &p).map_err(dsp_err("scf"))?;
            for (name, alpha) in alphas {
                let (f, a) = sm.alpha_slice(alpha).map_err(dsp_err(name))?;
                slices.push((name, alpha, f, a));
            }
            scf_params = Some(p);
        }
        let d = std::sync::Arc::new(MeasuredDomains { envelope, psd, psd_db, scf_params, slices });
        self.cache.lock().unwrap_or_else(|e| e.into_inner()).push((n, d.clone()));
        Ok(d)
    }

    /// Compares a simulated signal with the measurement.
    pub fn compare(&self, simulated: &Signal) -> Result<Comparison, CompareError> {
        self.compare_mean(std::slice::from_ref(simulated))
    }

    /// Compares the mean of several simulated realisations (one model, other seeds) with the
    /// measurement: each domain's simulated quantity (envelope spectrum, PSD, |SCF| slice) is
    /// averaged over them before the metrics, and the mean's own scatter (standard error) is
    /// kept per domain ([`DomainComparison::scatter_rmse`], used by the loop's objective through
    /// [`DomainComparison::debiased_nrmse_percent`]); a transfer-path correction is fitted to each
    /// (the first one's is reported). The measurement is one realisation of the machine, and
    /// the model's *expected* spectra are what it should be fitted to: against a single model
    /// realisation the model's own randomness adds to the error, the more the more random the
    /// model, which biases a random effect's fit low (a hidden 5 % slip was fitted at 1.6 %).
    /// With one signal this is [`Reference::compare`], bit for bit.
    pub fn compare_mean(&self, simulated: &[Signal]) -> Result<Comparison, CompareError> {
        let opts = &self.opts;
        let max_lag = 20;
        // (alignment, measured domains, common length) of the first realisation, and every
        // realisation's simulated domains.
        let mut first: Option<(Alignment, std::sync::Arc<MeasuredDomains>, usize)> = None;
        let mut each = Vec::with_capacity(simulated.len());
        for (i, one) in simulated.iter().enumerate() {
            let (meas, sim, al) = align(&self.measured, one, opts)?;
            match &first {
                None => {
                    let md = self.domains(&meas)?;
                    each.push(self.simulated_domains(&md, &sim, &al)?);
                    first = Some((al, md, meas.len()));
                }
                Some((_, md, n0)) => {
                    if meas.len() != *n0 {
                        return Err(CompareError::Parameter { name: "simulated", reason: format!("realisation {} leaves another common length ({} samples against {n0})", i + 1, meas.len()) });
                    }
                    each.push(self.simulated_domains(md, &sim, &al)?);
                }
            }
        }
        let Some((al, md, _)) = first else {
            return Err(CompareError::Parameter { name: "simulated", reason: "no simulated signal to compare".into() });
        };
        let (sim_d, scatter) = SimulatedDomains::mean_and_scatter(each);
        let SimulatedDomains { envelope: es_on, psd: ps_sum, slices: slice_sums, path_correction } = sim_d;
        let mut scatter = scatter.into_iter();
        let mut next_scatter = || scatter.next().unwrap_or(0.0);
        let mut domains = Vec::new();
        domains.push(DomainComparison {
            domain: "envelope".into(),
            quantity: "envelope spectrum of the unit-RMS signal".into(),
            metrics: metrics(&md.envelope.values, &es_on, opts.normaliser, max_lag),
            frequency_hz: md.envelope.frequency_hz.clone(),
            measured: md.envelope.values.clone(),
            simulated: es_on,
            scatter_rmse: next_scatter(),
        });

        let ps_db: Vec<f64> = ps_sum.iter().map(|v| db(*v)).collect();
        domains.push(DomainComparison {
            domain: "psd_db".into(),
            quantity: format!("Welch PSD, dB re 1 {}²/Hz", self.measured.unit),
            metrics: metrics(&md.psd_db, &ps_db, opts.normaliser, max_lag),
            frequency_hz: md.psd.frequency_hz.clone(),
            measured: md.psd_db.clone(),
            simulated: ps_db,
            scatter_rmse: next_scatter(),
        });

        if md.scf_params.is_some() {
            // One normaliser for the SCF, over every compared slice, when asked (see
            // `CompareOptions::scf_one_normaliser`).
            let scf_normaliser = opts.scf_one_normaliser.then(|| {
                let pooled: Vec<f64> = md.slices.iter().flat_map(|s| s.3.iter().copied()).collect();
                opts.normaliser.value(&pooled)
            });
            for ((name, alpha, f, a), b) in md.slices.iter().zip(slice_sums) {
                let (m, over) = match scf_normaliser {
                    Some(v) => (metrics_normalised_by(a, &b, opts.normaliser, v, 0), "NRMSE over the measured SCF on every compared slice"),
                    None => (metrics(a, &b, opts.normaliser, 0), "NRMSE over this slice"),
                };
                domains.push(DomainComparison {
                    domain: (*name).into(),
                    quantity: format!("|S(α = {alpha:.2} Hz, f)| of the unit-RMS signal ({over})"),
                    metrics: m,
                    frequency_hz: f.clone(),
                    measured: a.clone(),
                    simulated: b,
                    scatter_rmse: next_scatter(),
                });
            }
        }
        Ok(Comparison { alignment: al, domains, path_correction })
    }

    /// One aligned simulated signal's quantities on the measured axes, after its own
    /// transfer-path correction if any.
    fn simulated_domains(&self, md: &MeasuredDomains, sim: &[f64], al: &Alignment) -> Result<SimulatedDomains, CompareError> {
        let opts = &self.opts;
        let fs = al.fs_hz;
        let corrected;
        let (sim, path_correction) = match opts.path_correction_bands {
            0 => (sim, None),
            n_bands => {
                let c = self.fit_path_correction(md, sim, fs, al.speed_ratio, n_bands)?;
                corrected = c.apply(sim, fs, al.speed_ratio).map_err(dsp_err("path correction"))?;
                (corrected.as_slice(), Some(c))
            }
        };
        let es = envelope_with_taps(sim, fs, &self.taps, opts)?;
        let es_on = onto_axis(&md.envelope, &es, al.speed_ratio);
        let wp = dsp::welch::WelchParams { nperseg: opts.psd_nperseg.min(sim.len()), ..Default::default() };
        let ps = dsp::welch::welch_psd(sim, fs, &wp).map_err(dsp_err("psd"))?.to_spectrum(&self.measured.unit);
        let ps_on = onto_axis(&md.psd, &ps, al.speed_ratio);
        let mut slices = Vec::new();
        if let Some(p) = &md.scf_params {
            let ss = dsp::scf::fast_scf(&unit_rms(sim), fs, p).map_err(dsp_err("scf"))?;
            for (name, alpha, _, _) in &md.slices {
                slices.push(ss.alpha_slice(alpha / al.speed_ratio).map_err(dsp_err(name))?.1);
            }
        }
        Ok(SimulatedDomains { envelope: es_on, psd: ps_on, slices, path_correction })
    }

    /// The transfer-path correction of an aligned simulated signal: its Welch PSD on the
    /// measured axis against the measured one, on `n_bands` log-spaced bands of the PSD band.
    fn fit_path_correction(&self, md: &MeasuredDomains, sim: &[f64], fs: f64, speed_ratio: f64, n_bands: usize) -> Result<dsp::path_correction::PathCorrection, CompareError> {
        let opts = &self.opts;
        let nperseg = opts.psd_nperseg.min(sim.len());
        let wp = dsp::welch::WelchParams { nperseg, ..Default::default() };
        let ps = dsp::welch::welch_psd(sim, fs, &wp).map_err(dsp_err("psd"))?.to_spectrum(&self.measured.unit);
        let ps_db: Vec<f64> = onto_axis(&md.psd, &ps, speed_ratio).iter().map(|v| db(*v)).collect();
        let (plo, phi) = (md.psd.frequency_hz.first().copied().unwrap_or(0.0), md.psd.frequency_hz.last().copied().unwrap_or(fs / 2.0));
        let lo = plo.max(4.0 * fs / nperseg as f64);
        let bands = dsp::path_correction::log_bands(lo, phi, n_bands).map_err(|e| CompareError::Parameter { name: "path_correction_bands", reason: format!("PSD band {plo:.0}–{phi:.0} Hz: {e}") })?;
        dsp::path_correction::fit_path_correction(&md.psd.frequency_hz, &md.psd_db, &ps_db, &bands).map_err(dsp_err("path correction"))
    }
}

/// A simulated signal's quantities on the measured axes (see [`Reference::compare_mean`]).
struct SimulatedDomains {
    /// Envelope spectrum.
    envelope: Vec<f64>,
    /// Welch PSD, linear.
    psd: Vec<f64>,
    /// |SCF| at each of the measured side's α-slices.
    slices: Vec<Vec<f64>>,
    /// The transfer-path correction applied first, if any.
    path_correction: Option<dsp::path_correction::PathCorrection>,
}

impl SimulatedDomains {
    /// The PSD's place in [`Self::quantities`].
    const PSD_INDEX: usize = 1;

    /// The quantities in the order of the comparison's domains: envelope, PSD (linear),
    /// slices.
    fn quantities(&self) -> impl Iterator<Item = &Vec<f64>> {
        std::iter::once(&self.envelope).chain(std::iter::once(&self.psd)).chain(self.slices.iter())
    }

    /// The per-bin mean of the realisations (and of their path corrections), and for each
    /// domain in comparison order the RMS over bins of the mean's standard error s/√K (s² the
    /// per-bin sample variance; for the PSD, compared in dB, carried to dB by the delta method:
    /// s_dB = 10/ln 10 · s / mean). With one realisation: that one, unchanged, and zeros.
    fn mean_and_scatter(mut each: Vec<Self>) -> (Self, Vec<f64>) {
        let k = each.len();
        let rest = each.split_off(1.min(k));
        let mut mean = each.pop().expect("compare_mean checks for at least one realisation");
        let n_domains = mean.quantities().count();
        if rest.is_empty() {
            return (mean, vec![0.0; n_domains]);
        }
        // Each realisation was compared after its own correction; the one reported (and the
        // level the calibration's gain reads from it) is their mean.
        if let Some(first) = &mean.path_correction {
            let all: Vec<_> = std::iter::once(first).chain(rest.iter().filter_map(|r| r.path_correction.as_ref())).cloned().collect();
            mean.path_correction = dsp::path_correction::PathCorrection::mean(&all).or(mean.path_correction);
        }
        let kf = k as f64;
        let per_realisation: Vec<Vec<&Vec<f64>>> = std::iter::once(&mean).chain(rest.iter()).map(|r| r.quantities().collect()).collect();
        let mut means: Vec<Vec<f64>> = Vec::with_capacity(n_domains);
        let mut scatter = Vec::with_capacity(n_domains);
        for d in 0..n_domains {
            let bins = per_realisation[0][d].len();
            let (mut m, mut se2_sum) = (Vec::with_capacity(bins), 0.0);
            for i in 0..bins {
                let x = |r: &Vec<&Vec<f64>>| r[d].get(i).copied().unwrap_or(0.0);
                let mu = per_realisation.iter().map(x).sum::<f64>() / kf;
                let var = per_realisation.iter().map(|r| (x(r) - mu).powi(2)).sum::<f64>() / (kf - 1.0);
                // The PSD is compared in dB.
                let var = match d {
                    Self::PSD_INDEX if mu > 0.0 => (10.0 / std::f64::consts::LN_10).powi(2) * var / (mu * mu),
                    Self::PSD_INDEX => 0.0,
                    _ => var,
                };
                se2_sum += var / kf;
                m.push(mu);
            }
            scatter.push((se2_sum / bins.max(1) as f64).sqrt());
            means.push(m);
        }
        let mut means = means.into_iter();
        mean.envelope = means.next().unwrap_or_default();
        mean.psd = means.next().unwrap_or_default();
        for (s, m) in mean.slices.iter_mut().zip(means) {
            *s = m;
        }
        (mean, scatter)
    }
}

fn db(v: f64) -> f64 {
    10.0 * v.max(1e-30).log10()
}

/// Applies a gain of `offset_db` to the simulated signal of a comparison after the fact: only
/// the PSD (absolute level) changes; the envelope and SCF domains use unit-RMS signals.
pub fn apply_gain_db(c: &mut Comparison, offset_db: f64, opts: &CompareOptions) {
    for d in c.domains.iter_mut().filter(|d| d.domain == "psd_db") {
        d.simulated.iter_mut().for_each(|v| *v += offset_db);
        d.metrics = metrics(&d.measured, &d.simulated, opts.normaliser, 20);
    }
    c.alignment.rms_ratio_db += offset_db;
}

/// Compares `simulated` with `measured` in every domain, at the lower of their two sampling
/// rates ([`at_most_rate`]; [`Alignment`] says which was resampled).
pub fn compare(measured: &Signal, simulated: &Signal, opts: &CompareOptions) -> Result<Comparison, CompareError> {
    let at_rate = at_most_rate(measured, simulated.fs_hz)?;
    let mut c = Reference::new(&at_rate, opts)?.compare(simulated)?;
    if at_rate.fs_hz != measured.fs_hz {
        c.alignment.measured_resampled_from_hz = Some(measured.fs_hz);
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn domains(envelope: [f64; 2], psd: [f64; 2], slice: [f64; 2]) -> SimulatedDomains {
        SimulatedDomains { envelope: envelope.to_vec(), psd: psd.to_vec(), slices: vec![slice.to_vec()], path_correction: None }
    }

    #[test]
    fn mean_and_scatter_of_hand_made_realisations() {
        // Two realisations: per-bin means, and s² = Σ(x − x̄)²/(K − 1), standard error² s²/K.
        let (m, se) = SimulatedDomains::mean_and_scatter(vec![domains([1.0, 3.0], [2.0, 4.0], [0.0, 10.0]), domains([3.0, 5.0], [2.0, 8.0], [0.0, 10.0])]);
        assert_eq!((m.envelope, m.psd, m.slices), (vec![2.0, 4.0], vec![2.0, 6.0], vec![vec![0.0, 10.0]]));
        // Envelope: s² = 2 in both bins, s²/K = 1, RMS 1.
        assert!((se[0] - 1.0).abs() < 1e-15, "{se:?}");
        // PSD, in dB by the delta method: bin 1 has no spread; bin 2 s² = 8, mean 6:
        // (10/ln 10)² · 8 / 36 / 2, RMS over the two bins.
        let c = 10.0 / std::f64::consts::LN_10;
        assert!((se[1] - (c * c * 8.0 / 36.0 / 2.0 / 2.0).sqrt()).abs() < 1e-12, "{se:?}");
        // Identical realisations: no scatter.
        assert_eq!(se[2], 0.0);
        // One realisation: itself, and zeros.
        let (one, z) = SimulatedDomains::mean_and_scatter(vec![domains([1.0, 3.0], [2.0, 4.0], [5.0, 6.0])]);
        assert_eq!((one.envelope, z), (vec![1.0, 3.0], vec![0.0; 3]));
    }

    #[test]
    fn the_debiased_error_uses_the_metrics_normalisation() {
        // A PSD in dB normalised by its mean has a negative normaliser: |normaliser|, as
        // `metrics` does, not a missing domain.
        let m = metrics(&[-10.0, -20.0], &[-12.0, -24.0], Normaliser::Mean, 0);
        assert!(m.normaliser_value < 0.0);
        let d = DomainComparison { domain: "psd_db".into(), quantity: String::new(), frequency_hz: vec![0.0, 1.0], measured: vec![], simulated: vec![], metrics: m.clone(), scatter_rmse: 1.0 };
        let expected = (m.rmse.powi(2) - 1.0).sqrt() / 15.0 * 100.0;
        assert!((d.debiased_nrmse_percent() - expected).abs() < 1e-12, "{} vs {expected}", d.debiased_nrmse_percent());
        // Scatter above the error: 0, not NaN.
        let big = DomainComparison { scatter_rmse: 10.0, ..d };
        assert_eq!(big.debiased_nrmse_percent(), 0.0);
    }
}
