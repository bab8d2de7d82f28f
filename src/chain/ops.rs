//! Stage operations: each wraps one `dsp` function and its parameter struct.

use super::{ChainContext, ChainError, Data, StageOutput};
use crate::dsp::{self, spectrum::Spectrum};
use crate::signal::Signal;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which fault interval the STSA stage averages at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FaultRef {
    /// A name resolved from the bearing and shaft speed: `bpfo`, `bpfi`, `bsf`, `2xbsf`, `ftf`,
    /// `shaft`.
    Named(String),
    /// An explicit frequency in Hz.
    Hz(f64),
}

/// One processing operation with its parameters (the TOML `kind` and its keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Op {
    /// Remove the mean and scale (peak, std or none): [`dsp::normalise`].
    Normalise(dsp::normalise::NormaliseParams),
    /// Peak-search short-time synchronous averaging at a fault interval: [`dsp::stsa`].
    /// `fault` (a name or Hz) fills `fault_frequency_hz` from the kinematics.
    Stsa(dsp::stsa::StsaParams),
    /// Parks–McClellan equiripple bandpass applied with zero phase: [`dsp::remez`].
    Bandpass(dsp::remez::BandpassSpec),
    /// Hilbert envelope |x + j H{x}| as a time signal: [`dsp::envelope`].
    HilbertEnvelope(HilbertEnvelopeParams),
    /// Envelope (or squared-envelope) spectrum of the input in one step: [`dsp::envelope`].
    EnvelopeSpectrum(dsp::envelope::EnvelopeParams),
    /// One-sided FFT amplitude spectrum: [`dsp::spectrum`].
    Spectrum(dsp::spectrum::SpectrumParams),
    /// Welch PSD: [`dsp::welch`].
    Welch(dsp::welch::WelchParams),
    /// Discrete/random separation; the primary output is the random residual, the
    /// deterministic part is kept as `<stage>:deterministic`: [`dsp::drs`].
    Drs(dsp::drs::DrsParams),
    /// Cyclic spectral correlation and coherence: [`dsp::scf`]. Extras: `ees` (enhanced
    /// envelope spectrum ∫|S(α,f)|df), `ees_coherence` (mean |γ| over f), and α-slices
    /// `alpha_0`, `alpha_shaft`, `alpha_bpfo`, `alpha_bpfi`, `alpha_2xbsf`, `alpha_ftf` for the
    /// known cyclic frequencies inside the α range.
    Scf(dsp::scf::ScfParams),
    /// Integration (or differentiation) in the frequency domain, e.g. acceleration → velocity:
    /// [`dsp::spectrum::integrate_frequency_domain`].
    Integrate(IntegrateParams),
    /// A spectrum in decibels with a stated reference: [`dsp::spectrum::to_db`].
    Decibel(DecibelParams),
}

/// Parameters of the `integrate` stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IntegrateParams {
    /// Quantity of the input. Default acceleration.
    pub from: dsp::spectrum::Quantity,
    /// Quantity wanted. Default velocity.
    pub to: dsp::spectrum::Quantity,
    /// Bins below this frequency are zeroed (integration blows up near DC), Hz. Default 2.0.
    pub highpass_hz: f64,
    /// Unit of the output (e.g. `mm/s`); default: the input unit with `·s` per integration.
    pub unit: Option<String>,
    /// Scale applied to the output, e.g. 1000 for m/s → mm/s, or 9.80665 for g → m/s². Default 1.
    pub scale: f64,
}

impl Default for IntegrateParams {
    fn default() -> Self {
        Self { from: dsp::spectrum::Quantity::Acceleration, to: dsp::spectrum::Quantity::Velocity, highpass_hz: 2.0, unit: None, scale: 1.0 }
    }
}

/// Parameters of the `decibel` stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DecibelParams {
    /// Reference value in the spectrum's unit (e.g. 1e-6 m/s² for acceleration dB). Default 1.
    pub reference: f64,
    /// `amplitude` (20 log10) or `power` (10 log10). Default amplitude.
    pub kind: dsp::spectrum::DbKind,
}

impl Default for DecibelParams {
    fn default() -> Self {
        Self { reference: 1.0, kind: dsp::spectrum::DbKind::Amplitude }
    }
}

/// Parameters of the Hilbert-envelope stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct HilbertEnvelopeParams {
    /// Square the envelope (the squared envelope, Randall & Antoni 2011). Default false.
    pub squared: bool,
}

impl Op {
    /// The TOML `kind` of this operation.
    pub fn kind(&self) -> &'static str {
        match self {
            Op::Normalise(_) => "normalise",
            Op::Stsa(_) => "stsa",
            Op::Bandpass(_) => "bandpass",
            Op::HilbertEnvelope(_) => "hilbert_envelope",
            Op::EnvelopeSpectrum(_) => "envelope_spectrum",
            Op::Spectrum(_) => "spectrum",
            Op::Welch(_) => "welch",
            Op::Drs(_) => "drs",
            Op::Scf(_) => "scf",
            Op::Integrate(_) => "integrate",
            Op::Decibel(_) => "decibel",
        }
    }

    /// Whether the operation takes a time signal (all but `decibel`, which takes a spectrum).
    pub fn needs_time_input(&self) -> bool {
        !matches!(self, Op::Decibel(_))
    }
}

fn time_input<'a>(data: &'a Data, stage: &str, kind: &str) -> Result<&'a Signal, ChainError> {
    match data {
        Data::Time(s) => Ok(s),
        other => Err(ChainError::Stage {
            stage: stage.to_string(),
            message: format!("`{kind}` needs a time signal as input, got a {}", other.describe()),
        }),
    }
}

/// Runs one operation. `fault` is the STSA fault reference (if any), `band_hz` an optional
/// band to cut a spectrum to.
pub(super) fn run_op(
    op: &Op,
    stage: &str,
    input: &Data,
    ctx: &ChainContext,
    fault: Option<&FaultRef>,
    band_hz: Option<[f64; 2]>,
) -> Result<StageOutput, ChainError> {
    let err = |e: dsp::DspError| ChainError::Stage { stage: stage.to_string(), message: e.to_string() };
    if let Op::Decibel(p) = op {
        let Data::Spectrum(s) = input else {
            return Err(ChainError::Stage { stage: stage.to_string(), message: format!("`decibel` needs a spectrum as input, got a {}", input.describe()) });
        };
        let out = s.to_db(p.reference, p.kind).map_err(err)?;
        return Ok(StageOutput { name: stage.to_string(), kind: op.kind(), data: Data::Spectrum(out), extras: BTreeMap::new(), report: serde_json::Map::new() });
    }
    let x = time_input(input, stage, op.kind())?;
    let fs = x.fs_hz;
    let mut extras = BTreeMap::new();
    let mut report = serde_json::Map::new();
    let data = match op {
        Op::Normalise(p) => Data::Time(x.with_samples(dsp::normalise::normalise(&x.samples, p).map_err(err)?, stage)),
        Op::Stsa(p) => {
            let mut p = p.clone();
            if let Some(f) = fault {
                p.fault_frequency_hz = ctx.resolve_fault(f).map_err(|m| ChainError::Stage { stage: stage.to_string(), message: m })?;
            }
            report.insert("fault_frequency_hz".into(), p.fault_frequency_hz.into());
            if let Some(f) = fault {
                report.insert("fault".into(), serde_json::to_value(f).unwrap_or_default());
            }
            let r = dsp::stsa::stsa(&x.samples, fs, &p).map_err(err)?;
            Data::Time(x.with_samples(r.signal, stage))
        }
        Op::Bandpass(spec) => {
            let (y, design) = dsp::remez::bandpass_zero_phase(&x.samples, fs, spec).map_err(err)?;
            report.insert("numtaps".into(), design.numtaps.into());
            report.insert("estimated_taps".into(), design.estimated_taps.into());
            report.insert("achieved_ripple_db".into(), design.achieved_ripple_db.into());
            report.insert("achieved_stopband_low_db".into(), design.achieved_stopband_low_db.into());
            report.insert("achieved_stopband_high_db".into(), design.achieved_stopband_high_db.into());
            extras.insert("design".to_string(), Data::Fir(design));
            Data::Time(x.with_samples(y, stage))
        }
        Op::HilbertEnvelope(p) => {
            let mut env = dsp::envelope::envelope(&x.samples).map_err(err)?;
            if p.squared {
                env.iter_mut().for_each(|v| *v *= *v);
            }
            Data::Time(x.with_samples(env, stage))
        }
        Op::EnvelopeSpectrum(p) => Data::Spectrum(dsp::envelope::envelope_spectrum(&x.samples, fs, p).map_err(err)?),
        Op::Spectrum(p) => {
            let s = dsp::spectrum::amplitude_spectrum(&x.samples, fs, p).map_err(err)?;
            Data::Spectrum(cut(s, band_hz, stage)?)
        }
        Op::Welch(p) => {
            let psd = dsp::welch::welch_psd(&x.samples, fs, p).map_err(err)?;
            let s = psd.to_spectrum(&x.unit);
            Data::Spectrum(cut(s, band_hz, stage)?)
        }
        Op::Drs(p) => {
            let r = dsp::drs::drs(&x.samples, fs, p).map_err(err)?;
            extras.insert("deterministic".to_string(), Data::Time(x.with_samples(r.deterministic, format!("{stage}:deterministic"))));
            Data::Time(x.with_samples(r.residual, stage))
        }
        Op::Scf(p) => {
            let map = dsp::scf::scf(&x.samples, fs, p).map_err(err)?;
            scf_extras(&map, ctx, &x.unit, &mut extras);
            report.insert("alpha_resolution_hz".into(), map.alpha_resolution_hz.into());
            report.insert("frequency_resolution_hz".into(), map.frequency_resolution_hz.into());
            report.insert("segments".into(), map.n_segments.into());
            Data::Scf(map)
        }
        Op::Integrate(p) => {
            if !(p.scale.is_finite() && p.scale != 0.0) {
                return Err(ChainError::Stage { stage: stage.to_string(), message: format!("parameter `scale` = {}: must be a finite, non-zero factor", p.scale) });
            }
            let mut y = dsp::spectrum::integrate_frequency_domain(&x.samples, fs, p.from, p.to, p.highpass_hz).map_err(err)?;
            y.iter_mut().for_each(|v| *v *= p.scale);
            let steps = p.from.order() - p.to.order();
            let unit = p.unit.clone().unwrap_or_else(|| match steps {
                0 => x.unit.clone(),
                s if s > 0 => format!("{}·s{}", x.unit, if s == 2 { "²" } else { "" }),
                s => format!("{}/s{}", x.unit, if s == -2 { "²" } else { "" }),
            });
            let mut out = x.with_samples(y, stage);
            out.unit = unit;
            Data::Time(out)
        }
        Op::Decibel(_) => unreachable!("handled above"),
    };
    Ok(StageOutput { name: stage.to_string(), kind: op.kind(), data, extras, report })
}

/// Enhanced envelope spectra and α-slices at the known cyclic frequencies.
fn scf_extras(map: &dsp::scf::ScfMap, ctx: &ChainContext, unit: &str, extras: &mut BTreeMap<String, Data>) {
    let sq = dsp::spectrum::squared_unit(unit);
    let (a, v) = map.enhanced_envelope_spectrum();
    extras.insert("ees".into(), Data::Spectrum(Spectrum { frequency_hz: a, values: v, quantity: "enhanced envelope spectrum".into(), unit: sq.clone() }));
    let (a, v) = map.enhanced_envelope_spectrum_coherence();
    extras.insert("ees_coherence".into(), Data::Spectrum(Spectrum { frequency_hz: a, values: v, quantity: "mean spectral coherence".into(), unit: String::new() }));
    let mut alphas = vec![("alpha_0", 0.0)];
    if let Some(fr) = ctx.shaft_speed_hz {
        alphas.push(("alpha_shaft", fr));
    }
    if let Some(ff) = ctx.fault_frequencies() {
        alphas.extend([("alpha_bpfo", ff.bpfo_hz), ("alpha_bpfi", ff.bpfi_hz), ("alpha_2xbsf", 2.0 * ff.bsf_hz), ("alpha_ftf", ff.ftf_hz)]);
    }
    let lo = map.alpha_hz.first().copied().unwrap_or(0.0) - map.alpha_resolution_hz / 2.0;
    let hi = map.alpha_hz.last().copied().unwrap_or(0.0) + map.alpha_resolution_hz / 2.0;
    for (name, alpha) in alphas {
        if alpha < lo || alpha > hi {
            continue;
        }
        if let Ok((f, v)) = map.alpha_slice(alpha) {
            extras.insert(name.into(), Data::Spectrum(Spectrum { frequency_hz: f, values: v, quantity: format!("|S(alpha={alpha:.3} Hz, f)|"), unit: format!("{sq}/Hz") }));
        }
    }
}

fn cut(s: Spectrum, band_hz: Option<[f64; 2]>, stage: &str) -> Result<Spectrum, ChainError> {
    match band_hz {
        None => Ok(s),
        Some([lo, hi]) => {
            let nyq = s.frequency_hz.last().copied().unwrap_or(0.0);
            if !(lo >= 0.0 && lo < hi && lo <= nyq) {
                return Err(ChainError::Stage {
                    stage: stage.to_string(),
                    message: format!("parameter `band_hz` = [{lo}, {hi}]: needs 0 ≤ low < high and low ≤ {nyq} Hz (Nyquist)"),
                });
            }
            s.band(lo, hi).map_err(|e| ChainError::Stage { stage: stage.to_string(), message: format!("parameter `band_hz`: {e}") })
        }
    }
}
