//! Short-time synchronous averaging (STSA) at a bearing fault interval, with a peak search that
//! re-aligns every interval on its impact (bearing impacts slip by 1–2 %).

use super::error::{check_finite, check_fs, DspError};
use serde::{Deserialize, Serialize};

/// What fills the output before the first averaged segment (the dropped transient) and after
/// the last one, so that the output keeps the input's length.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Pad {
    /// Continue the averaged waveform periodically at the nominal interval `T` (backwards before
    /// the first segment, forwards after the last). Keeps the impact train unbroken, so the
    /// envelope spectrum gets no extra modulation from the padding.
    #[default]
    Periodic,
    /// Zeros.
    Zeros,
}

/// Parameters of [`stsa`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StsaParams {
    /// Fault frequency `f` in Hz (BPFO, BPFI, BSF, FTF or any user frequency); the fault interval
    /// is `T = fs/f` samples. Default `0.0` = unset: it must be given (a chain fills it from the
    /// bearing kinematics), and [`StsaParams::validate`] refuses 0.
    pub fault_frequency_hz: f64,
    /// Half-width of the peak search as a fraction of `T`: each interval may start up to
    /// `D = floor(tolerance_fraction · T)` samples earlier or later than expected. Default 0.02
    /// (rolling-element slip is 1–2 %). `0` gives the plain synchronous average. Range [0, 0.5).
    pub tolerance_fraction: f64,
    /// Initial transient to drop, in s (the padding replaces it). Default 0.0.
    pub transient_s: f64,
    /// `None` (default): one average over all intervals, laid down at every detected impact.
    /// `Some(K)`: short-time average — each interval is replaced by the average of the `K`
    /// aligned intervals centred on it (keeps slow amplitude modulation, e.g. the load-zone
    /// modulation of an inner-race fault, for `K · T` short against the modulation period).
    pub segments_per_average: Option<usize>,
    /// What fills the output outside the averaged intervals. Default [`Pad::Periodic`].
    pub pad: Pad,
    /// Number of alignment passes, 1–16. Pass 1 aligns on the first interval (the reference);
    /// each later pass re-aligns every interval on the average of the previous pass, which is a
    /// far cleaner template at low SNR. Default 3.
    pub alignment_passes: usize,
}

impl Default for StsaParams {
    /// `fault_frequency_hz = 0` (unset, must be given), `tolerance_fraction = 0.02`,
    /// `transient_s = 0`, `segments_per_average = None`, `pad = Periodic`, `alignment_passes = 3`.
    fn default() -> Self {
        Self {
            fault_frequency_hz: 0.0,
            tolerance_fraction: 0.02,
            transient_s: 0.0,
            segments_per_average: None,
            pad: Pad::Periodic,
            alignment_passes: 3,
        }
    }
}

/// Sizes derived from the parameters for one record.
#[derive(Debug, Clone, Copy)]
struct Plan {
    /// Fault interval `T = fs / f` in samples (fractional).
    interval: f64,
    /// Search half-width `D` in samples.
    search: usize,
    /// Stored segment length `L = ceil(T) + D + 1` (covers the longest slipped interval).
    seg_len: usize,
    /// Samples used for matching: `floor(T)` (one interval).
    match_len: usize,
    /// First usable sample (end of the transient).
    first: usize,
}

impl StsaParams {
    /// Checks the parameters against a record of `n` samples at `fs_hz`.
    ///
    /// Refuses: `fs_hz` not positive/finite; `fault_frequency_hz` not finite, ≤ 0, above the
    /// Nyquist frequency, or so low that fewer than three fault intervals (plus the search
    /// margin) fit in the record after the transient; `tolerance_fraction` outside [0, 0.5);
    /// `transient_s` negative, non-finite or not shorter than the record; `alignment_passes`
    /// outside 1–16; `segments_per_average = Some(0)`.
    pub fn validate(&self, n: usize, fs_hz: f64) -> Result<(), DspError> {
        self.plan(n, fs_hz).map(|_| ())
    }

    fn plan(&self, n: usize, fs_hz: f64) -> Result<Plan, DspError> {
        check_fs(fs_hz)?;
        let f = self.fault_frequency_hz;
        if !(f.is_finite() && f > 0.0 && f <= fs_hz / 2.0) {
            return Err(DspError::InvalidParameter {
                name: "fault_frequency_hz",
                value: format!("{f}"),
                reason: format!(
                    "the fault frequency must lie in (0, fs/2 = {} Hz]; set it to the BPFO, BPFI, BSF or FTF of the bearing",
                    fs_hz / 2.0
                ),
            });
        }
        let tol = self.tolerance_fraction;
        if !(tol.is_finite() && (0.0..0.5).contains(&tol)) {
            return Err(DspError::InvalidParameter {
                name: "tolerance_fraction",
                value: format!("{tol}"),
                reason: "the search half-width must be a fraction of the fault interval in [0, 0.5); use 0.01–0.02 for bearing slip, 0 for a plain synchronous average".into(),
            });
        }
        let duration_s = n as f64 / fs_hz;
        let tr = self.transient_s;
        if !(tr.is_finite() && tr >= 0.0) {
            return Err(DspError::InvalidParameter {
                name: "transient_s",
                value: format!("{tr}"),
                reason: "the transient to drop must be a finite, non-negative time in s".into(),
            });
        }
        let first_f = (tr * fs_hz).round();
        if first_f >= n as f64 {
            return Err(DspError::InvalidParameter {
                name: "transient_s",
                value: format!("{tr}"),
                reason: format!("dropping {tr} s leaves nothing of the {duration_s} s record; use a shorter transient"),
            });
        }
        if !(1..=16).contains(&self.alignment_passes) {
            return Err(DspError::InvalidParameter {
                name: "alignment_passes",
                value: format!("{}", self.alignment_passes),
                reason: "use 1 to 16 passes (3 is plenty: the template stops changing after the second)".into(),
            });
        }
        if self.segments_per_average == Some(0) {
            return Err(DspError::InvalidParameter {
                name: "segments_per_average",
                value: "0".into(),
                reason: "average at least 1 interval, or use None to average all of them".into(),
            });
        }
        let first = first_f as usize;
        let interval = fs_hz / f;
        let search = (tol * interval).floor() as usize;
        let ceil_t = interval.ceil() as usize;
        let seg_len = ceil_t + search + 1;
        let match_len = (interval.floor() as usize).max(1);
        let needed = seg_len + 2 * ceil_t;
        if n - first < needed {
            let min_f = fs_hz * 3.0 * (1.0 + tol) / (n - first) as f64;
            return Err(DspError::InvalidParameter {
                name: "fault_frequency_hz",
                value: format!("{f}"),
                reason: format!(
                    "the fault interval 1/f = {:.6} s needs at least three intervals plus the ±{:.0} % search margin ({} samples) after the transient, but the record is {duration_s} s ({} samples left after dropping {tr} s); use a longer record or a fault frequency above about {min_f:.3} Hz",
                    1.0 / f,
                    tol * 100.0,
                    needed,
                    n - first
                ),
            });
        }
        Ok(Plan { interval, search, seg_len, match_len, first })
    }
}

/// The result of [`stsa`].
#[derive(Debug, Clone, PartialEq)]
pub struct StsaResult {
    /// The STSA signal, same length and unit as the input.
    pub signal: Vec<f64>,
    /// Average of all aligned intervals, `L = ceil(T) + D + 1` samples; the impact sits at
    /// `impact_offset`.
    pub average_period: Vec<f64>,
    /// Start sample of every averaged interval, increasing.
    pub segment_starts: Vec<usize>,
    /// Shift (samples) the peak search applied to each interval relative to its expected start
    /// (previous start + T); `|shift| ≤ D`. The first entry is the first interval's own shift.
    pub shifts: Vec<isize>,
    /// The fault interval `T = fs / f` in samples.
    pub interval_samples: f64,
    /// Offset of the impact within each segment (samples), `round(0.1 · T)`.
    pub impact_offset: usize,
}

/// Short-time synchronous averaging at a fault interval with peak-search re-alignment.
///
/// Averages the record over the intervals between successive bearing impacts, re-aligning each
/// interval on its impact so that the 1–2 % slip of rolling elements does not smear the average.
/// Content not synchronous with the fault interval (noise, gear mesh, shaft harmonics not
/// commensurate with `1/f`) is averaged out; the impacts and their resonance ringing remain.
///
/// Parameters
/// ----------
/// * `x` — the record (any unit; usually normalised first); finite, non-empty.
/// * `fs_hz` — sampling rate in Hz.
/// * `params` — [`StsaParams`]: `fault_frequency_hz` (required), `tolerance_fraction` (0.02),
///   `transient_s` (0 s), `segments_per_average` (None = all), `pad` (Periodic),
///   `alignment_passes` (3).
///
/// Returns
/// -------
/// [`StsaResult`]: the STSA signal (input length and unit), the averaged interval waveform, the
/// interval starts and the shifts found by the peak search (samples).
///
/// Notes
/// -----
/// Let `T = fs/f` (samples, fractional), `D = floor(tol · T)`, `L = ceil(T) + D + 1`,
/// `s₀ = round(transient_s · fs)`.
///
/// *Alignment rule (peak search).* The record is walked one fault interval at a time. Interval
/// `k` is expected to start at `e_k = p_{k−1} + T`, where `p_{k−1}` is the (fractional)
/// aligned start of interval `k−1` (so the walk follows a slow drift of the fault frequency
/// instead of accumulating it). Its start is then moved to `s_k = round(e_k) + d_k`, with the
/// shift `d_k ∈ [−D, D]` that puts the peak of the match between the interval and the template
/// `t` at zero lag:
///
/// `d_k = argmax_{|d| ≤ D} Σ_{j<⌊T⌋} x[round(e_k) + d + j] · (t[j] − mean(t))`,
///
/// ties going to the smallest `|d|`; `p_k = e_k + d_k`. The impact peak therefore falls at the
/// same offset as in the reference. The peak searched is that of the cross-correlation with the
/// template (a matched filter), not the sample maximum `max |x|` nor the envelope maximum: at
/// the SNRs where averaging is needed (−5 dB in the tests) the largest sample of one interval is
/// as often noise, or a strong tone, as the impact, so a `max |x|` search loses the impact train
/// and averages no better than no alignment at all, whereas the matched filter integrates the
/// whole impact response over the interval.
///
/// *Passes.* Pass 1 uses the first interval `x[s₀ .. s₀ + L)` as the template and does not move
/// it. Its average locates the impact (the largest `|value|` of the average in `[0, ⌊T⌋)`);
/// every start is then moved by a constant so that the impact sits `m = round(0.1 · T)` samples
/// into its segment (segments starting before `s₀` are dropped), and the average is recomputed.
/// Each further pass (`alignment_passes − 1`) re-walks the record from the first start,
/// searching every interval (the first one included) against the previous average.
///
/// *Average.* `ā[j] = (1/M) Σ_k x[s_k + j]`, `j < L`, over the `M` intervals with
/// `s_k + L ≤ n`. With `segments_per_average = Some(K)` interval `k` gets instead
/// `a_k = (1/K) Σ_{i∈W_k} x[s_i + j]` over the `K` consecutive intervals `W_k` centred on `k`
/// (shifted inwards at the ends of the record), computed with running sums.
///
/// *Output.* `y[s_k + j] = a_k[j]` for `0 ≤ j < s_{k+1} − s_k` (each interval holds its
/// average up to the next detected impact, so the output keeps the detected impact times and
/// the envelope spectrum keeps the fault line with its slip). Before `s_0` and after the last
/// interval the output is padded (`Pad::Periodic`: the first/last average repeated at the
/// nominal spacing `T`; `Pad::Zeros`: zeros after one interval), so `len(y) = len(x)`.
///
/// Noise of variance σ² not synchronous with `T` is left with variance σ²/M (σ²/K); a tone at
/// `f_g` is scaled by `|(1/M) Σ_k exp(i2π f_g s_k / fs)|`, small unless `f_g` is a multiple of
/// `f`. The global average (`None`) gives every impact the same amplitude: it keeps the fault
/// line and its harmonics in the envelope spectrum but removes the shaft-rate sidebands of an
/// inner-race fault; use `Some(K)` with `K·T` well under a shaft period to keep them.
///
/// Cost: `alignment_passes · M · (2D + 1) · ⌊T⌋ ≈ passes · (2D+1) · n` multiply–adds (the
/// search spans only `2D + 1` lags, so a direct correlation is cheaper than an FFT), plus O(n).
///
/// References
/// ----------
/// C. Mishra, A.K. Samantaray, G. Chakraborty, "Rolling element bearing defect diagnosis under
/// variable speed operation through angle synchronous averaging of wavelet de-noised estimate",
/// Mechanical Systems and Signal Processing 72–73 (2016) 206–222 (peak-search synchronous
/// averaging), as used in the STSA–envelope diagnosis scheme of the 15-DOF bearing–bevel-gear
/// study (papers/bearing_bevel_gear_15dof_stsa_envelope.txt, §4).
/// S. Braun, "The synchronous (time domain) average revisited", MSSP 25 (2011) 1087–1102.
pub fn stsa(x: &[f64], fs_hz: f64, params: &StsaParams) -> Result<StsaResult, DspError> {
    if x.is_empty() {
        return Err(DspError::TooShort { what: "stsa", needed: 1, got: 0 });
    }
    check_finite(x)?;
    let plan = params.plan(x.len(), fs_hz)?;
    let n = x.len();
    let l = plan.seg_len;
    let impact_offset = (0.1 * plan.interval).round() as usize;

    // Pass 1: walk from the reference interval, matched against the reference itself.
    let reference = x[plan.first..plan.first + l].to_vec();
    let (mut starts, mut shifts, _) = walk(x, &plan, plan.first as f64, &reference, false);
    let mut average = mean_segment(x, &starts, l);
    // Re-base so that the impact sits `impact_offset` samples into each segment.
    let peak = average[..plan.match_len]
        .iter()
        .enumerate()
        .fold((0usize, -1.0_f64), |(bi, bv), (i, &v)| if v.abs() > bv { (i, v.abs()) } else { (bi, bv) })
        .0;
    let rebase = peak as isize - impact_offset as isize;
    let (rebased, rebased_shifts): (Vec<usize>, Vec<isize>) = starts
        .iter()
        .zip(&shifts)
        .map(|(&s, &d)| (s as isize + rebase, d))
        .filter(|&(s, _)| s >= plan.first as isize && s as usize + l <= n)
        .map(|(s, d)| (s as usize, d))
        .unzip();
    if rebased.len() >= 2 {
        starts = rebased;
        shifts = rebased_shifts;
        average = mean_segment(x, &starts, l);
    }
    // Further passes: re-walk against the previous average.
    let mut first_pos = starts[0] as f64;
    for _ in 1..params.alignment_passes {
        let (s, d, p0) = walk(x, &plan, first_pos, &average, true);
        if s.len() < 2 {
            break;
        }
        starts = s;
        shifts = d;
        first_pos = p0;
        average = mean_segment(x, &starts, l);
    }
    let m = starts.len();
    if m < 2 {
        return Err(DspError::InvalidParameter {
            name: "fault_frequency_hz",
            value: format!("{}", params.fault_frequency_hz),
            reason: format!(
                "fewer than two fault intervals fit in the {} s record after the transient; use a longer record or a higher fault frequency",
                n as f64 / fs_hz
            ),
        });
    }
    if let Some(k) = params.segments_per_average {
        if k > m {
            return Err(DspError::InvalidParameter {
                name: "segments_per_average",
                value: format!("{k}"),
                reason: format!("only {m} fault intervals fit in the record; use at most {m}, or None to average all"),
            });
        }
    }

    let signal = build_output(x, &plan, &starts, &average, params);
    Ok(StsaResult {
        signal,
        average_period: average,
        segment_starts: starts,
        shifts,
        interval_samples: plan.interval,
        impact_offset,
    })
}

/// Walks the record interval by interval from the fractional start `start_pos`, aligning each
/// interval on `template` within ±D. With `search_first = false` the first interval is taken
/// as is. Returns the starts, the shifts and the fractional aligned position of the first one.
fn walk(x: &[f64], plan: &Plan, start_pos: f64, template: &[f64], search_first: bool) -> (Vec<usize>, Vec<isize>, f64) {
    let n = x.len() as isize;
    let l = plan.seg_len as isize;
    let lc = plan.match_len;
    let d_max = plan.search as isize;
    let tmean = template[..lc].iter().sum::<f64>() / lc as f64;
    let tpl: Vec<f64> = template[..lc].iter().map(|v| v - tmean).collect();
    let lower = plan.first as isize;

    let estimate = ((n as f64 - start_pos) / plan.interval).ceil().max(1.0) as usize + 1;
    let mut starts = Vec::with_capacity(estimate);
    let mut shifts = Vec::with_capacity(estimate);
    let mut pos = start_pos;
    let mut first_pos = start_pos;
    let mut k = 0usize;
    loop {
        let expected = if k == 0 { pos } else { pos + plan.interval };
        let c = expected.round() as isize;
        if c - d_max + l > n {
            break;
        }
        let mut best: Option<(f64, isize)> = None;
        if k == 0 && !search_first {
            if c >= lower && c + l <= n {
                best = Some((0.0, 0));
            }
        } else {
            for d in -d_max..=d_max {
                let cand = c + d;
                if cand < lower || cand + l > n {
                    continue;
                }
                let seg = &x[cand as usize..cand as usize + lc];
                let score: f64 = seg.iter().zip(&tpl).map(|(a, b)| a * b).sum();
                let better = match best {
                    None => true,
                    Some((bs, bd)) => score > bs || (score == bs && d.abs() < bd.abs()),
                };
                if better {
                    best = Some((score, d));
                }
            }
        }
        let Some((_, d)) = best else { break };
        pos = expected + d as f64;
        if k == 0 {
            first_pos = pos;
        }
        starts.push((c + d) as usize);
        shifts.push(d);
        k += 1;
    }
    (starts, shifts, first_pos)
}

/// Mean of `x[s .. s + len]` over the starts.
fn mean_segment(x: &[f64], starts: &[usize], len: usize) -> Vec<f64> {
    let mut acc = vec![0.0; len];
    for &s in starts {
        for (a, &v) in acc.iter_mut().zip(&x[s..s + len]) {
            *a += v;
        }
    }
    let inv = 1.0 / starts.len().max(1) as f64;
    acc.iter_mut().for_each(|a| *a *= inv);
    acc
}

/// Lays the averaged waveforms down at the detected starts and pads the ends.
fn build_output(x: &[f64], plan: &Plan, starts: &[usize], average: &[f64], params: &StsaParams) -> Vec<f64> {
    let n = x.len();
    let l = plan.seg_len;
    let m = starts.len();
    let mut y = vec![0.0; n];

    // Waveform of interval k: the global average, or a moving average of K intervals.
    let write = |y: &mut [f64], from: usize, to: usize, wave: &[f64]| {
        let to = to.min(n).min(from + wave.len());
        if from < to {
            y[from..to].copy_from_slice(&wave[..to - from]);
        }
    };
    let interval_end = |k: usize| -> usize {
        if k + 1 < m {
            starts[k + 1]
        } else {
            starts[k] + (plan.interval.round() as usize).min(l)
        }
    };

    let (first_wave, last_wave) = match params.segments_per_average {
        None => {
            for (k, &s) in starts.iter().enumerate() {
                write(&mut y, s, interval_end(k), average);
            }
            (average.to_vec(), average.to_vec())
        }
        Some(kk) => {
            let half = (kk - 1) / 2;
            let lo_of = |k: usize| k.saturating_sub(half).min(m - kk);
            let mut sum = vec![0.0; l];
            let mut lo = lo_of(0);
            for &s in &starts[lo..lo + kk] {
                for (a, &v) in sum.iter_mut().zip(&x[s..s + l]) {
                    *a += v;
                }
            }
            let inv = 1.0 / kk as f64;
            let mut wave = vec![0.0; l];
            let mut first_wave = Vec::new();
            for k in 0..m {
                let new_lo = lo_of(k);
                while lo < new_lo {
                    let (out, inn) = (starts[lo], starts[lo + kk]);
                    for (j, a) in sum.iter_mut().enumerate() {
                        *a += x[inn + j] - x[out + j];
                    }
                    lo += 1;
                }
                for (w, s) in wave.iter_mut().zip(&sum) {
                    *w = s * inv;
                }
                if k == 0 {
                    first_wave = wave.clone();
                }
                write(&mut y, starts[k], interval_end(k), &wave);
            }
            (first_wave, wave)
        }
    };

    if params.pad == Pad::Periodic {
        // Before the first interval: copies at round(p0 − jT), j = 1, 2, ...
        let p0 = starts[0] as f64;
        let mut next = starts[0];
        let mut j = 1.0;
        while next > 0 {
            let b = (p0 - j * plan.interval).round();
            let from = b.max(0.0) as usize;
            let skip = (from as f64 - b) as usize;
            let len = next - from;
            y[from..next].copy_from_slice(&first_wave[skip..skip + len]);
            next = from;
            j += 1.0;
        }
        // After the last interval: copies at round(p_last + jT), j = 1, 2, ...
        let pl = starts[m - 1] as f64;
        let mut j = 1.0;
        let mut from = interval_end(m - 1);
        while from < n {
            let a_next = ((pl + (j + 1.0) * plan.interval).round() as usize).min(n);
            write(&mut y, from, a_next, &last_wave);
            from = a_next;
            j += 1.0;
        }
    }
    y
}
