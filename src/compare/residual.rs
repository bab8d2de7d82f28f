//! The residual map: where the model fails. The squared error of each domain is split over
//! labelled places — envelope lines by family (shaft harmonics, fault frequencies and their
//! harmonics, shaft-speed sidebands, GMF), PSD bands, cyclic frequencies — each with its share.

use super::Comparison;
use crate::kinematics::CharacteristicFrequency;
use serde::{Deserialize, Serialize};

/// One place that carries part of the error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualItem {
    /// `envelope_line`, `psd_band` or `cyclic`.
    pub kind: String,
    /// The family: `shaft harmonics`, `BPFI`, `BPFI ± shaft`, `GMF`, `PSD band`, `cyclic`, or
    /// `unlabelled envelope` for the rest of the envelope spectrum.
    pub family: String,
    /// Specific label, e.g. `BPFI-1xshaft`, `2xBPFO`, `2000–2500 Hz`, `α = 29.95 Hz`.
    pub label: String,
    /// Centre frequency (Hz) of the line or band.
    pub frequency_hz: f64,
    /// Share of the domain's squared error, %.
    pub share_percent: f64,
    /// Measured value (peak in the line window; mean dB in the band).
    pub measured: f64,
    /// Simulated value at the same place.
    pub simulated: f64,
    /// Plain words: `in the measurement, absent from the model`, `too strong in the model`, ...
    pub note: String,
}

/// The ranked residual map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ResidualMap {
    /// Items, largest share first within each kind, kinds interleaved by share.
    pub items: Vec<ResidualItem>,
    /// Share per envelope family, %, largest first.
    pub envelope_families: Vec<(String, f64)>,
}

impl ResidualMap {
    /// Envelope share of a family (0 when absent).
    pub fn family_share(&self, family: &str) -> f64 {
        self.envelope_families.iter().find(|(f, _)| f == family).map(|(_, s)| *s).unwrap_or(0.0)
    }
}

fn note(measured: f64, simulated: f64) -> String {
    let r = if measured > 0.0 { simulated / measured } else { f64::INFINITY };
    if r < 0.25 {
        "in the measurement, absent from the model".into()
    } else if r < 0.7 {
        "weaker in the model".into()
    } else if r <= 1.4 {
        "similar level, different shape".into()
    } else if r <= 4.0 {
        "stronger in the model".into()
    } else {
        "in the model, absent from the measurement".into()
    }
}

/// A candidate envelope line.
struct Line {
    family: String,
    label: String,
    freq: f64,
    complexity: u32,
}

fn candidate_lines(families: &[CharacteristicFrequency], shaft_hz: Option<f64>, f_max: f64) -> Vec<Line> {
    let mut out = Vec::new();
    for fam in families.iter().filter(|f| f.frequency_hz > 0.0) {
        let is_shaft = fam.label == "shaft";
        let kmax = ((f_max / fam.frequency_hz).floor() as u32).clamp(1, 40);
        for k in 1..=kmax {
            let base = k as f64 * fam.frequency_hz;
            let name = if k == 1 { fam.label.clone() } else { format!("{k}x{}", fam.label) };
            out.push(Line { family: if is_shaft { "shaft harmonics".into() } else { fam.label.clone() }, label: name.clone(), freq: base, complexity: k });
            if let (Some(fr), false) = (shaft_hz, is_shaft) {
                for s in [-2i32, -1, 1, 2] {
                    let f = base + s as f64 * fr;
                    if f > 0.0 {
                        out.push(Line { family: format!("{} ± shaft", fam.label), label: format!("{name}{s:+}xshaft"), freq: f, complexity: k + 2 * s.unsigned_abs() });
                    }
                }
            }
        }
    }
    out
}

/// Builds the residual map of a comparison. `families` are the characteristic frequencies
/// (shaft, BPFO, BPFI, 2xBSF, FTF, GMF, ...), `shaft_hz` the speed for sidebands.
///
/// # Method
/// Envelope: every bin of the compared envelope spectrum is assigned to the simplest line whose
/// window (±max(2 bins, 0.5 %)) contains it (complexity `k + 2|s|`); bins near no line are
/// `unlabelled envelope`. A line's share is the sum of `(measured − simulated)²` over its bins
/// divided by the total. PSD: 16 equal bands over the compared range, share of the squared dB
/// error. Cyclic: each SCF α-slice's squared error, as a share of all slices.
pub fn residual_map(cmp: &Comparison, families: &[CharacteristicFrequency], shaft_hz: Option<f64>) -> ResidualMap {
    let mut items = Vec::new();
    let mut fam_share: Vec<(String, f64)> = Vec::new();
    if let Some(env) = cmp.domain("envelope") {
        let f = &env.frequency_hz;
        let df = if f.len() > 1 { f[1] - f[0] } else { 1.0 };
        let f_max = f.last().copied().unwrap_or(0.0);
        let lines = candidate_lines(families, shaft_hz, f_max);
        let err: Vec<f64> = env.measured.iter().zip(&env.simulated).map(|(a, b)| (a - b).powi(2)).collect();
        let total: f64 = err.iter().sum::<f64>().max(1e-300);
        // Assign each bin to its simplest covering line.
        let mut owner: Vec<Option<usize>> = vec![None; f.len()];
        for (i, &fi) in f.iter().enumerate() {
            if fi < 1.0 {
                continue;
            }
            let mut best: Option<(u32, f64, usize)> = None;
            for (li, l) in lines.iter().enumerate() {
                let w = (2.0 * df).max(0.005 * l.freq);
                let d = (fi - l.freq).abs();
                if d <= w {
                    let key = (l.complexity, d);
                    if best.is_none_or(|b| (key.0, key.1) < (b.0, b.1)) {
                        best = Some((key.0, key.1, li));
                    }
                }
            }
            owner[i] = best.map(|b| b.2);
        }
        let mut per_line: Vec<(f64, f64, f64)> = vec![(0.0, 0.0, 0.0); lines.len()];
        let mut unlabelled = 0.0;
        for i in 0..f.len() {
            match owner[i] {
                Some(li) => {
                    per_line[li].0 += err[i];
                    per_line[li].1 = per_line[li].1.max(env.measured[i]);
                    per_line[li].2 = per_line[li].2.max(env.simulated[i]);
                }
                None => unlabelled += err[i],
            }
        }
        for (li, (e, m, s)) in per_line.into_iter().enumerate() {
            if e <= 0.0 {
                continue;
            }
            let share = e / total * 100.0;
            let l = &lines[li];
            match fam_share.iter_mut().find(|(n, _)| n == &l.family) {
                Some(x) => x.1 += share,
                None => fam_share.push((l.family.clone(), share)),
            }
            if share >= 0.5 {
                items.push(ResidualItem { kind: "envelope_line".into(), family: l.family.clone(), label: l.label.clone(), frequency_hz: l.freq, share_percent: share, measured: m, simulated: s, note: note(m, s) });
            }
        }
        fam_share.push(("unlabelled envelope".into(), unlabelled / total * 100.0));
        fam_share.sort_by(|a, b| b.1.total_cmp(&a.1));
    }
    if let Some(psd) = cmp.domain("psd_db") {
        let f = &psd.frequency_hz;
        if let (Some(&lo), Some(&hi)) = (f.first(), f.last()) {
            let nb = 16;
            let err: Vec<f64> = psd.measured.iter().zip(&psd.simulated).map(|(a, b)| (a - b).powi(2)).collect();
            let total: f64 = err.iter().sum::<f64>().max(1e-300);
            let w = (hi - lo) / nb as f64;
            for b in 0..nb {
                let (a0, a1) = (lo + b as f64 * w, lo + (b + 1) as f64 * w);
                let idx: Vec<usize> = (0..f.len()).filter(|&i| f[i] >= a0 && (f[i] < a1 || (b == nb - 1 && f[i] <= a1))).collect();
                if idx.is_empty() {
                    continue;
                }
                let e: f64 = idx.iter().map(|&i| err[i]).sum();
                let mm = idx.iter().map(|&i| psd.measured[i]).sum::<f64>() / idx.len() as f64;
                let sm = idx.iter().map(|&i| psd.simulated[i]).sum::<f64>() / idx.len() as f64;
                let diff = sm - mm;
                let note = if diff < -6.0 {
                    "band missing or weak in the model".to_string()
                } else if diff > 6.0 {
                    "band too strong in the model".to_string()
                } else {
                    "similar level".to_string()
                };
                items.push(ResidualItem {
                    kind: "psd_band".into(),
                    family: "PSD band".into(),
                    label: format!("{a0:.0}–{a1:.0} Hz"),
                    frequency_hz: 0.5 * (a0 + a1),
                    share_percent: e / total * 100.0,
                    measured: mm,
                    simulated: sm,
                    note,
                });
            }
        }
    }
    let slices: Vec<_> = cmp.domains.iter().filter(|d| d.domain.starts_with("scf_alpha")).collect();
    if !slices.is_empty() {
        let errs: Vec<f64> = slices.iter().map(|d| d.measured.iter().zip(&d.simulated).map(|(a, b)| (a - b).powi(2)).sum::<f64>()).collect();
        let total: f64 = errs.iter().sum::<f64>().max(1e-300);
        for (d, e) in slices.iter().zip(errs) {
            let m = d.measured.iter().cloned().fold(0.0, f64::max);
            let s = d.simulated.iter().cloned().fold(0.0, f64::max);
            items.push(ResidualItem { kind: "cyclic".into(), family: "cyclic".into(), label: d.quantity.clone(), frequency_hz: 0.0, share_percent: e / total * 100.0, measured: m, simulated: s, note: note(m, s) });
        }
    }
    items.sort_by(|a, b| b.share_percent.total_cmp(&a.share_percent));
    ResidualMap { items, envelope_families: fam_share }
}
