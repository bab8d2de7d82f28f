//! The model loop: the machine (preset and main parameters, validated by
//! `Machine::validate`), the catalogue of effects as toggles with their main parameters,
//! Simulate, "Find missing effect" (`compare::diagnose` on a worker, progress counted in model
//! evaluations, Cancel), the ranked trials with their evidence and before → after numbers, Add
//! (`compare::apply_trial`, then re-simulate and re-compare), and the error over rounds.

use super::{drawable, fmt_num, unit_of, Command, View};
use crate::compare::Param;
use crate::gui::session::{Purpose, Session};
use crate::gui::settings::Settings;
use crate::model::{EffectKind, Effects, Machine, PRESETS};
use crate::signal::export::{PlotData, Series};
use egui::{Color32, RichText};
use egui_plot::{Legend, Line, Plot, PlotPoints, Points};

/// The model-loop view.
#[derive(Default)]
pub struct ModelLoopView {
    /// The machine as edited, with the model revision it was taken from.
    draft: Option<(u64, Machine)>,
    /// The measured signal to compare with (index into the session's signals).
    measured: Option<usize>,
}

/// Colours of the two curves of the rounds chart.
const ENVELOPE: Color32 = Color32::from_rgb(60, 120, 220);
const OBJECTIVE: Color32 = Color32::from_rgb(230, 120, 40);

/// A number editor for a model parameter: SI value, `unit` shown after it, `range` the values
/// the editor accepts (validation against the machine comes after).
fn number(ui: &mut egui::Ui, v: &mut f64, range: std::ops::RangeInclusive<f64>, unit: &str) -> egui::Response {
    let speed = (v.abs() * 0.005).max(1e-9);
    let sci = v.abs() < 1e-2 || v.abs() >= 1e5;
    let mut d = egui::DragValue::new(v).range(range).clamp_existing_to_range(false).speed(speed);
    if sci {
        d = d.custom_formatter(|x, _| format!("{x:.4e}"));
    }
    if !unit.is_empty() {
        d = d.suffix(format!(" {unit}"));
    }
    ui.add(d)
}

impl ModelLoopView {
    /// Index of the measured signal to use: the chosen one, else the selected signal if it is
    /// measured, else the first measured.
    fn measured(&mut self, session: &Session) -> Option<usize> {
        let list = session.measured_indices();
        if self.measured.is_none_or(|i| !list.contains(&i)) {
            self.measured = session.selected.filter(|i| list.contains(i)).or(list.first().copied());
        }
        self.measured
    }

    fn machine_ui(ui: &mut egui::Ui, d: &mut Machine) -> bool {
        let mut changed = false;
        egui::Grid::new("machine-params").num_columns(3).striped(true).show(ui, |ui| {
            if let Some(s) = d.shafts.iter_mut().find(|s| s.speed_hz.is_some()) {
                let name = s.name.clone();
                let mut v = s.speed_hz.unwrap_or(0.0);
                let l = ui.label("shaft speed").on_hover_text(format!("shaft[{name}].speed_hz (other shafts follow through their ratios)"));
                changed |= number(ui, &mut v, 0.01..=2000.0, "Hz").labelled_by(l.id).changed();
                ui.weak(format!("{:.0} rpm", v * 60.0));
                s.speed_hz = Some(v);
                ui.end_row();
            }
            for (label, p, range, note) in [
                ("resonance", Param::ResonanceHz, 1.0..=1.0e6, "structural resonance the impacts ring"),
                ("resonance damping ratio", Param::ResonanceDamping, 0.0..=1.0, "ζ of the resonance"),
                ("fault depth", Param::FaultDepthM, 1e-7..=1e-2, "depth of the localised spall"),
            ] {
                let Some(mut v) = p.get(d) else { continue };
                let l = ui.label(label).on_hover_text(format!("{} — {note}", p.name()));
                if number(ui, &mut v, range, unit_of(p.name())).labelled_by(l.id).changed() {
                    p.set(d, v);
                    changed = true;
                }
                ui.weak(if p == Param::FaultDepthM { format!("{:.3} mm", v * 1e3) } else { String::new() });
                ui.end_row();
            }
            let l = ui.label("simulated duration").on_hover_text("duration_s: length of Simulate's record (the search uses its own fit duration)");
            changed |= number(ui, &mut d.duration_s, 0.05..=600.0, "s").labelled_by(l.id).changed();
            ui.weak(format!("fs {:.0} Hz", d.fs_hz));
            ui.end_row();
        });
        changed
    }

    /// The catalogue's toggles with their main parameters, and beside each effect on with a
    /// parameter to fit a "re-fit" box (`refit`: the effects the calibration re-fits; those in
    /// `applied`, which the loop's rounds applied, always are).
    fn effects_ui(ui: &mut egui::Ui, d: &mut Machine, refit: &[EffectKind], applied: &[EffectKind], cmd: &mut Option<Command>) -> bool {
        let mut changed = false;
        egui::Grid::new("effects").num_columns(3).striped(true).show(ui, |ui| {
            for k in EffectKind::ALL {
                let applicable = Effects::applicable(k, d);
                let mut on = d.effects.is_on(k);
                let r = ui.add_enabled(applicable, egui::Checkbox::new(&mut on, k.name()));
                let r = if applicable { r } else { r.on_disabled_hover_text("does not apply to this machine (e.g. gear effects need a gear pair)") };
                if r.changed() {
                    if on {
                        d.effects.enable(k);
                    } else {
                        d.effects.disable(k);
                    }
                    changed = true;
                }
                match Param::main_of_effect(k).filter(|_| on) {
                    Some(p) => match p.get(d) {
                        Some(mut v) => {
                            let (lo, hi, _) = p.bounds(d);
                            let range = lo.min(v)..=hi.max(v);
                            let r = number(ui, &mut v, range, unit_of(p.name())).on_hover_text(format!("{} (search range {} – {})", p.name(), fmt_num(lo), fmt_num(hi)));
                            if r.changed() {
                                p.set(d, v);
                                changed = true;
                            }
                        }
                        None => {
                            ui.weak("-");
                        }
                    },
                    None => {
                        ui.weak(if on { "switch" } else { "" });
                    }
                }
                if crate::compare::calibrate::refit_refusal(d, k).is_none() {
                    let mut r = refit.contains(&k);
                    let by_loop = applied.contains(&k);
                    let resp = ui.add_enabled(!by_loop, egui::Checkbox::new(&mut r, "re-fit")).on_hover_text(format!("every search's calibration also fits {}'s parameters, as the loop re-fits what it applies (`diagnose --refit {}`): to go on from a machine a loop saved", k.name(), k.name())).on_disabled_hover_text("applied by this loop's rounds: every search re-fits it");
                    if resp.changed() {
                        *cmd = Some(Command::SetRefit { effect: k, refit: r });
                    }
                } else {
                    ui.label("");
                }
                ui.end_row();
            }
        });
        changed
    }

    fn search_settings_ui(ui: &mut egui::Ui, settings: &Settings, machine: &Machine) -> Option<Settings> {
        let mut s = settings.clone();
        egui::CollapsingHeader::new("Search settings").default_open(false).show(ui, |ui| {
            if ui.button("reset search settings to the defaults").on_hover_text("every setting below back to the library's default (the defaults change as the search improves; a settings file keeps the values it was saved with); the effects chosen to try are kept").clicked() {
                s.reset_search_settings();
            }
            egui::Grid::new("search-settings").num_columns(2).show(ui, |ui| {
                let l = ui.label("fit duration").on_hover_text("simulated and compared duration of each model evaluation");
                ui.add(egui::DragValue::new(&mut s.loop_fit_duration_s).range(crate::compare::FIT_DURATION_RANGE_S).speed(0.05).suffix(" s")).labelled_by(l.id);
                ui.end_row();
                ui.label("evaluations per parameter").on_hover_text("golden-section evaluations per parameter and sweep");
                ui.add(egui::DragValue::new(&mut s.loop_evaluations_per_parameter).range(3..=40));
                ui.end_row();
                ui.label("calibration sweeps");
                ui.add(egui::DragValue::new(&mut s.loop_sweeps).range(0..=5));
                ui.end_row();
                let l = ui.label("calibration polish").on_hover_text("after every full-range fit, this many sweeps of local line searches on its parameters, the bracket ± 8 % of each range halved every sweep (0 = off): coordinate descent over the full ranges can stop short of the optimum of coupled parameters (resonance and damping), and a calibration that falls short reads as something missing");
                ui.add(egui::DragValue::new(&mut s.loop_polish_sweeps).range(0..=crate::compare::MAX_POLISH_SWEEPS).suffix(" sweeps")).labelled_by(l.id);
                ui.end_row();
                ui.label("transfer-path correction").on_hover_text("fit a smooth gain curve on this many log-spaced PSD bands to every evaluation before comparing (0 = off): for a real record whose sensor path the model does not describe; spectral-shape effects then compete only on what the bands cannot absorb");
                ui.add(egui::DragValue::new(&mut s.loop_path_correction_bands).range(0..=crate::compare::MAX_PATH_CORRECTION_BANDS).suffix(" bands"));
                ui.end_row();
                let l = ui.label("model realisations").on_hover_text("average the spectra of this many model seeds in every evaluation, so a random effect (slip, a rough fault, noise) is fitted to its expected spectrum, not to one draw of it; with two or more, the trials are judged on as many held-out realisations no fit used; each evaluation costs this many simulations, run in parallel");
                ui.add(egui::DragValue::new(&mut s.loop_realisations).range(1..=crate::compare::MAX_REALISATIONS)).labelled_by(l.id);
                ui.end_row();
                let l = ui.label("second look for random effects").on_hover_text("when a search with one realisation ranks slip or an extended fault first (effects drawn at random, fitted to one draw), do it again with this many realisations, judged held out, and take that answer (0 = off); other searches keep the cost of one realisation");
                ui.add(egui::DragValue::new(&mut s.loop_random_effect_realisations).range(0..=crate::compare::MAX_REALISATIONS).custom_formatter(|v, _| if v < 2.0 { "off".into() } else { format!("{v:.0}") }).custom_parser(|t| if t.trim() == "off" { Some(0.0) } else { t.trim().parse().ok() })).labelled_by(l.id);
                ui.end_row();
                let l = ui.label("floor margin").on_hover_text("something can be missing only when the calibrated model scores at least (1 + margin) × its seed floor, what a perfect model still scores (with several realisations the ratio that asks for the same misfit); lower finds effects nearer the floor and risks claiming a misfit of the base model");
                ui.add(egui::DragValue::new(&mut s.loop_floor_margin).range(0.0..=5.0).speed(0.01)).labelled_by(l.id);
                ui.end_row();
            });
            ui.checkbox(&mut s.loop_unbend_pinned, "unbend: when the calibration pins a parameter, also start the trials from the uncalibrated values")
                .on_hover_text("each trial scans its effect on a grid and re-does the calibration with it (about seven times slower): for a model the calibration bent to stand in for what is missing");
            ui.checkbox(&mut s.loop_uncalibrated_start, "second start: every trial also from the uncalibrated values, pinned or not (experimental)")
                .on_hover_text("each trial also scans its effect on a grid from the uncalibrated values and fits it as usual (about twice a plain trial's cost), and the better fit is kept: for a calibration that bent the model toward what is missing without reaching an edge");
            ui.checkbox(&mut s.loop_near_floor_rule, "near-floor rule: a decisive, untied trial is a finding from 1.2 × the floor (experimental)")
                .on_hover_text("under the floor margin, from 1.2 × the seed floor: the best trial is a finding too when it explains at least 80 % of the error above the floor, switching its effect off again costs at least 50 %, no other trial is tied with it, and it places no spectral feature (a casing mode or roll-off can stand in for a resonance a few percent off)");
            ui.checkbox(&mut s.loop_effect_must_work, "the effect must do the work: a best trial is a finding only when switching its effect off again costs at least 20 % of the error above the floor")
                .on_hover_text("a trial re-fits the base model with its effect, and that re-fit alone can lower the error: a 2.4e-6 kg·m unbalance once \"explained\" 50 % while switching it off cost 0.1 %. On (the default since session 57), such a trial is no finding and no lead");
            ui.checkbox(&mut s.loop_recalibrate_roll_off, "re-calibrate with a roll-off: the sensor roll-off's trial re-does the calibration from the uncalibrated values, as the casing mode's does (experimental)")
                .on_hover_text("a calibration can bend the resonance down to stand in for a sensor low-pass; the roll-off's trial then fits it on the resonance. This trial scans the bandwidth and sweeps it with every calibrated parameter (about a casing trial's cost)");
            ui.checkbox(&mut s.loop_joint_trials, "joint trials: a stuck search tries its three best single trials in pairs (experimental)")
                .on_hover_text("two missing effects can hide each other from every single trial (a missing Hertzian contact bends the fault depth, and a casing mode at the band's edge imitates the rest). When nothing single is significant and the model is still above its floor margin, the three best trials are fitted in pairs; a pair is chosen only when switching off either of its effects alone costs at least 20 % of the error above the floor");
            ui.checkbox(&mut s.loop_coupled_forces, "coupled forces: an unbalance or misalignment trial beside the other, applied, fits the two together")
                .on_hover_text("an unbalance and a misalignment on one shaft share the 1× line, and the force applied first takes up part of the other's: its valley then is gone (a misalignment 7 % high hid a ±10 % unbalance valley). The new force is fitted at the applied one's amplitude and at ±3, 6, 9 and 12 % of it and at 0.5–0.8 and 1.2–1.4 of it (applied without the other, an unbalance was fitted up to 90 % high and 21 % low, a misalignment 97 % high), the lowest kept: fifteen more fits of that trial, in rounds where such a force is applied only");
            ui.checkbox(&mut s.loop_force_pair_grid, "force pair grid: an applied unbalance and misalignment on one shaft are re-fitted jointly on a grid")
                .on_hover_text(format!("the two share the 1× line, so their valley is a narrow diagonal (one up, the other down) that line searches along one amplitude at a time do not cross: a round's calibration also evaluates a grid of {}, in rounds where both are applied only", crate::compare::calibrate::force_pair_grid_in_words()));
            ui.checkbox(&mut s.loop_scan_force_amplitudes, "scan forces: every trial scans an unbalance, misalignment or belt force on a grid")
                .on_hover_text("a periodic force's objective has a narrow minimum among dips decades away: a line search alone can close on the wrong one for a strong force (three times the evaluations for those parameters)");
            ui.checkbox(&mut s.loop_fine_forces, "fine forces: an unbalance, misalignment or belt force gets twice the line-search evaluations")
                .on_hover_text("the objective's minimum in a force is about 1 % wide and a 9-evaluation line search over its four decades ends within about ±18 %: a force left a few percent off leaves error another effect can stand in for");
            ui.add_enabled(s.loop_scan_force_amplitudes, egui::Checkbox::new(&mut s.loop_fine_force_scan, "fine force cell: a scanned force also gets a second, finer grid inside the coarse grid's best cell (experimental)"))
                .on_hover_text("a force's objective can hold its minimum in a notch narrower than the coarse grid's cell, which the golden section steps over (a 41.9 N misalignment fitted at 31 N); the fine cell's golden section runs beside the coarse cell's and the lower is kept, so a fit can only end lower. The evidence list names the forces where the fine cell won");
            ui.add_enabled(s.loop_polish_sweeps > 0, egui::Checkbox::new(&mut s.loop_polish_second_starts, "polish second starts too: the polish also acts on an unbent trial's start from the uncalibrated values"))
                .on_hover_text("off (the default), only the calibration and the casing trial that re-does it are polished; an unbent trial keeps a polished start, the one from the calibrated model. On a real record every trial is unbent, and polishing every second start is most of the polish's cost");
            ui.checkbox(&mut s.loop_scf_one_normaliser, "one SCF normaliser: every SCF slice's error relative to the measured SCF over all slices")
                .on_hover_text("on (the default), a slice holding little but estimator noise (the shaft slice of a healthy gear) is not scaled up to the range of that noise; off, each slice by its own measured range, as the comparison view shows it");
            ui.checkbox(&mut s.loop_unbend_when_stuck, "unbend when stuck: a stuck search whose calibration pins nothing starts every trial again from the uncalibrated values")
                .on_hover_text("a calibration can bend the model to do without what is missing without reaching an edge of any range; this costs a second search, in stuck rounds only");
            ui.checkbox(&mut s.loop_unbend_when_short, "unbend when short: a search whose best explains under half the error starts every trial again from the uncalibrated values (experimental)")
                .on_hover_text("a calibration that absorbed a strong force can leave a stand-in ranked first that explains little (a misalignment answered by an unbalance); this costs a second search, in such rounds only");
            ui.checkbox(&mut s.loop_strength_range, "strength range: the chosen effect's strength with the range the data cannot tell from it")
                .on_hover_text("after the search, the chosen strength is held at 7 points around its fit and every other free parameter re-fitted at each (7 local re-fits, in parallel); the range is where the objective stays within 2√2 × the seed scatter of the fitted one's. A fitted size can be one point of a valley: a mesh variation trades against the resonance frequency by a factor of 1.5");
            ui.checkbox(&mut s.loop_removal_trials, "removal trials: each fault and effect of the model taken out in turn, the rest calibrated again")
                .on_hover_text("the search only adds; a fault the machine does not have is hidden by the calibration (CWRU's healthy record against the inner-race preset: the resonance moved out of the band). Each part is read contradicted (the model does better without it), needed, or cannot tell; one calibration per part, judged on 4 held-out realisations");
            ui.checkbox(&mut s.loop_uncalibrated_start_top, "second start for the top trials: the best three trials also start from the uncalibrated values before their re-fit")
                .on_hover_text("a calibration can move a base parameter far toward a missing force without pinning it, and the re-fit of the best trials is local; this costs about three trials more, in searches that are not unbent");
            let mut all = s.loop_candidates.is_empty();
            if ui.checkbox(&mut all, "try every applicable effect the model lacks").changed() {
                s.loop_candidates = if all { Vec::new() } else { EffectKind::ALL.into_iter().filter(|k| !machine.effects.is_on(*k) && Effects::applicable(*k, machine)).collect() };
            }
            if !all {
                ui.horizontal_wrapped(|ui| {
                    for k in EffectKind::ALL.into_iter().filter(|k| Effects::applicable(*k, machine)) {
                        let mut on = s.loop_candidates.contains(&k);
                        if ui.checkbox(&mut on, format!("try {}", k.name())).changed() {
                            if on {
                                s.loop_candidates.push(k);
                            } else {
                                s.loop_candidates.retain(|x| *x != k);
                            }
                        }
                    }
                });
            }
        });
        (s != *settings).then_some(s)
    }

    fn rounds_ui(ui: &mut egui::Ui, session: &Session) {
        let h = &session.model.history;
        ui.strong("Error over rounds");
        if h.is_empty() {
            ui.weak("No rounds yet: Find missing effect starts round 1.");
            return;
        }
        let env: Vec<[f64; 2]> = h.iter().map(|r| [r.round as f64, r.envelope_nrmse]).collect();
        let obj: Vec<[f64; 2]> = h.iter().map(|r| [r.round as f64, r.objective]).collect();
        // The floor is known for rounds that ran a diagnosis (0: a round recorded from a trial).
        let floor: Vec<[f64; 2]> = h.iter().filter(|r| r.floor_objective > 0.0).map(|r| [r.round as f64, r.floor_objective]).collect();
        Plot::new("rounds-chart").height(170.0).legend(Legend::default()).x_axis_label("round").y_axis_label("NRMSE (%)").include_y(0.0).include_x(0.5).include_x(h.len() as f64 + 0.5).show(ui, |pu| {
            pu.line(Line::new("envelope NRMSE (%)", PlotPoints::from(env.clone())).color(ENVELOPE).width(1.5));
            pu.points(Points::new("envelope NRMSE (%)", PlotPoints::from(env)).color(ENVELOPE).radius(4.0));
            pu.line(Line::new("objective (weighted NRMSE, %)", PlotPoints::from(obj.clone())).color(OBJECTIVE).width(1.5));
            pu.points(Points::new("objective (weighted NRMSE, %)", PlotPoints::from(obj)).color(OBJECTIVE).radius(4.0));
            pu.points(Points::new("floor: the model against itself", PlotPoints::from(floor)).color(OBJECTIVE).shape(egui_plot::MarkerShape::Diamond).filled(false).radius(5.0));
        });
        egui::Grid::new("rounds-table").striped(true).num_columns(6).show(ui, |ui| {
            for hdr in ["round", "envelope NRMSE", "objective", "floor", "effects on", "then changed"] {
                ui.weak(hdr);
            }
            ui.end_row();
            for r in h {
                ui.label(format!("round {}", r.round)).on_hover_text(drawable(&r.verdict));
                ui.label(format!("{:.1} %", r.envelope_nrmse));
                ui.label(format!("{:.1}", r.objective));
                ui.label(if r.floor_objective > 0.0 { format!("{:.1}", r.floor_objective) } else { "-".into() }).on_hover_text("objective of the model against realisations of itself: what a perfect model would still score");
                ui.label(r.effects_on.iter().map(|k| k.name()).collect::<Vec<_>>().join(", "));
                let added = ui.label(r.change("-"));
                if !r.applied_values.is_empty() {
                    added.on_hover_text(r.change_with_values("-"));
                }
                ui.end_row();
            }
        });
    }

    fn ranking_ui(measured: Option<usize>, ui: &mut egui::Ui, session: &Session, cmd: &mut Option<Command>) {
        let Some(r) = &session.model.result else {
            ui.weak("Find missing effect calibrates the model against the measured signal, then tries each missing effect with its parameters fitted, and ranks them.");
            if let Some(saved) = session.restored_summary.as_ref().filter(|x| x.verdict.is_some()) {
                ui.add_space(6.0);
                ui.strong("Saved ranking (from the reopened session; not recomputed)");
                for line in saved.verdict.iter().map(|v| format!("Verdict: {v}")).chain(saved.trials.iter().cloned()) {
                    ui.add(egui::Label::new(drawable(&line)).wrap());
                }
            }
            return;
        };
        let d = &r.diagnosis;
        ui.strong(format!("Missing-effect ranking against {}", r.measured));
        ui.weak(format!(
            "{} trials · demodulation band {:.0}–{:.0} Hz · fit {:.2} s per evaluation · {:.1} s · floor objective {:.1}",
            d.trials.len(),
            r.options.compare.envelope_band_hz[0],
            r.options.compare.envelope_band_hz[1],
            r.options.fit_duration_s,
            r.seconds,
            d.floor_objective
        ))
        .on_hover_text("the envelopes are compared in the chain's bandpass stage (Compare → Band from kurtogram sets it from the measurement); the floor is the model's objective against realisations of itself");
        if d.measured_resampled_from_hz.is_some() {
            ui.weak(format!("compared at {}", d.rate_in_words())).on_hover_text("a measurement sampled faster than the model is brought down to the model's rate (the Fourier method) before anything is compared: the model holds nothing above its own Nyquist frequency");
        }
        if d.floor_objective == 0.0 {
            ui.add(egui::Label::new(RichText::new(format!("Note: {}", drawable(crate::compare::diagnose::ZERO_FLOOR_NOTE))).color(ui.visuals().warn_fg_color)).wrap());
            let machine = &session.model.machine;
            if !machine.effects.is_on(EffectKind::Noise)
                && ui.button("Switch on noise").on_hover_text("switch the model's measurement noise on (its level is calibrated), so the search has a floor; then Find missing effect again").clicked()
            {
                let mut m = machine.clone();
                m.effects.enable(EffectKind::Noise);
                *cmd = Some(Command::SetMachine(Box::new(m)));
            }
        }
        if let Some(look) = &d.second_look {
            ui.add(egui::Label::new(RichText::new(format!("Second look with {} realisations: {} led the search with one, where a random effect is fitted to one draw; that search said: {}", look.realisations, look.leader.name(), drawable(&look.verdict_with_one))).color(ui.visuals().warn_fg_color)).wrap());
        }
        if let Some(jh) = d.held_out_objective {
            ui.weak(format!("Judged on held-out realisations: the calibrated model scores {jh:.2} there ({:.2} on the realisations it was fitted to); the trials' numbers are held-out too", d.calibration.objective_after))
                .on_hover_text("with several model realisations a fit can exploit its own realisations' scatter; every trial is therefore judged on realisations no fit used");
        }
        let unit = measured.and_then(|i| session.signals.get(i)).map_or("", |s| s.signal.unit.as_str());
        if let Some(w) = d.silent_model_warning(unit) {
            ui.add(egui::Label::new(RichText::new(format!("Warning: {}", drawable(&w))).color(ui.visuals().warn_fg_color)).wrap());
        }
        let verdict = RichText::new(format!("Verdict: {}", drawable(&d.verdict)));
        ui.add(egui::Label::new(if d.best.is_some() { verdict.strong() } else { verdict }).wrap());
        if let Some(sr) = &d.strength_range {
            ui.label(format!("Strength range: {}", drawable(&sr.text()))).on_hover_text(format!(
                "the values whose objective, every other free parameter re-fitted, stays within {:.2} (2√2 × the larger seed scatter, the calibrated model's or the fitted machine's) of the fitted value's {:.2}; ≤ / ≥: the profile's last point on that side still passed\nprofile: {}",
                sr.tolerance,
                sr.objective_fitted,
                sr.profile.iter().map(|(v, j)| format!("{} → {j:.2}", fmt_num(*v))).collect::<Vec<_>>().join(", ")
            ));
        }
        if !d.removals.is_empty() {
            ui.label(format!("Removal trials (each part taken out, the rest calibrated again; judged on {} held-out realisations):", d.removals[0].realisations));
            let current = session.model.machine == r.started_from;
            for t in &d.removals {
                ui.horizontal_wrapped(|ui| {
                    let text = format!("{}: {}", t.reading.name(), drawable(&t.summary));
                    match t.reading {
                        crate::compare::removal::RemovalReading::Contradicted => {
                            ui.add(egui::Label::new(RichText::new(text).color(ui.visuals().warn_fg_color)).wrap());
                            let without = t.part.removed_from(&session.model.machine);
                            let hover = match &without {
                                Ok(_) => "the machine without it; then Find missing effect again (the calibration re-fits the rest)".to_string(),
                                Err(e) => format!("the machine without it is not valid: {e}"),
                            };
                            let take_out = ui.add_enabled(current && without.is_ok(), egui::Button::new(format!("Take out {}", t.label))).on_hover_text(hover);
                            if let (true, Ok(m)) = (take_out.clicked(), without) {
                                *cmd = Some(Command::SetMachine(Box::new(m)));
                            }
                        }
                        _ => {
                            ui.add(egui::Label::new(text).wrap());
                        }
                    }
                });
            }
        }
        let cal = &d.calibration;
        ui.horizontal_wrapped(|ui| {
            ui.label(format!(
                "calibration ({} evaluations): envelope NRMSE {:.1} -> {:.1} %, objective {:.1} -> {:.1}",
                cal.evaluations, cal.envelope_nrmse_before, cal.envelope_nrmse_after, cal.objective_before, cal.objective_after
            ))
            .on_hover_text(cal.parameters.iter().map(|(p, v)| format!("{} = {}", p.name(), fmt_num(*v))).collect::<Vec<_>>().join("\n"));
            if ui.add_enabled(session.model.machine != r.calibrated, egui::Button::new("Use calibrated model")).on_hover_text("take the calibrated parameters into the machine without adding an effect").clicked() {
                *cmd = Some(Command::UseCalibrated);
            }
        });
        let current = session.model.machine == r.started_from;
        let proposals = session.model.replacement_proposals();
        let refits = session.model.refit_proposals();
        if !proposals.is_empty() || !refits.is_empty() {
            let reach = crate::compare::diagnose::reachable_objective(d.judged_objective(), &d.trials);
            ui.horizontal_wrapped(|ui| {
                ui.label(format!("Stuck at {:.1} x the floor with nothing significant to add: an effect added earlier may stand in for another.", d.judged_objective() / d.floor_objective));
                for (a, b) in proposals {
                    let button = ui.add_enabled(measured.is_some(), egui::Button::new(format!("Try {} in place of {}", b.name(), a.name())));
                    let hover = format!(
                        "switch {} off and {} on in the calibrated model, then Find missing effect on it; the replacement is better if its objective with its best addition is below {reach:.2} (this model with its best addition) by more than the seed scatter",
                        a.name(),
                        b.name()
                    );
                    if button.on_hover_text(hover).on_disabled_hover_text("choose a measured signal").clicked() {
                        if let Some(m) = measured {
                            *cmd = Some(Command::ReplaceEffect { remove: a, add: b, measured: m });
                        }
                    }
                }
                for a in refits {
                    let button = ui.add_enabled(measured.is_some(), egui::Button::new(format!("Re-fit {} from the uncalibrated values", a.name())));
                    let hover = format!(
                        "fit {} anew from the first model's uncalibrated values (its main parameter scanned on a grid), then Find missing effect on it; kept if its objective with its best addition is below {reach:.2} by more than the seed scatter: a calibration bent toward a missing effect may have put it far from its truth",
                        a.name()
                    );
                    if button.on_hover_text(hover).on_disabled_hover_text("choose a measured signal").clicked() {
                        if let Some(m) = measured {
                            *cmd = Some(Command::RefitEffect { effect: a, measured: m });
                        }
                    }
                }
            });
        }
        if let Some(pc) = &d.path_correction {
            let (lo, hi) = pc.gain_db.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), g| (a.min(*g), b.max(*g)));
            ui.label(format!("transfer-path correction on ({} bands): {lo:+.1} to {hi:+.1} dB applied to the model before comparing", pc.gain_db.len()))
                .on_hover_text(pc.centre_hz.iter().zip(&pc.gain_db).map(|(f, g)| format!("{f:.0} Hz: {g:+.1} dB")).collect::<Vec<_>>().join("\n"));
        }
        if !cal.at_bound.is_empty() {
            let names: Vec<&str> = cal.at_bound.iter().map(|b| b.0.name()).collect();
            let hint = if d.unbent { "the trials also started from the uncalibrated values" } else { "unbend is off in Search settings: the trials started only from this calibration" };
            ui.colored_label(ui.visuals().warn_fg_color, format!("at the edge of its search range (not estimated; may stand in for a missing effect): {}; {hint}", names.join(", ")))
                .on_hover_text(cal.at_bound.iter().map(|(p, lo, hi)| format!("{}: range {} – {}", p.name(), fmt_num(*lo), fmt_num(*hi))).collect::<Vec<_>>().join("\n"));
        }
        egui::ScrollArea::both().id_salt("ranking-scroll").show(ui, |ui| {
            egui::Grid::new("ranking").striped(true).num_columns(5).show(ui, |ui| {
                for hdr in ["effect", "objective", "envelope NRMSE", "reduction", ""] {
                    ui.weak(hdr);
                }
                ui.end_row();
                for (i, t) in d.trials.iter().enumerate() {
                    let name = format!("{}. {}", i + 1, t.label());
                    // The chosen trial heads the ranking (a joint trial shares its effect with a single one).
                    let name = if d.best == Some(t.effect) && i == 0 { RichText::new(name).strong() } else { RichText::new(name) };
                    ui.label(name).on_hover_text(drawable(&t.summary));
                    ui.label(format!("{:.1} -> {:.1}", t.objective_before, t.objective_after));
                    ui.label(format!("{:.1} -> {:.1} %", t.envelope_nrmse_before, t.envelope_nrmse_after));
                    ui.label(format!("{:.0} %", t.reduction * 100.0)).on_hover_text(format!("relative objective reduction; explains {:.0} % of the error above the floor", t.explained * 100.0));
                    let added = r.added.contains(&t.effect);
                    let why = if added {
                        "added"
                    } else if !r.added.is_empty() {
                        "another effect was added: run Find missing effect again for the new model"
                    } else if !current {
                        "the model changed since this search: run it again"
                    } else {
                        ""
                    };
                    let b = ui.add_enabled(why.is_empty(), egui::Button::new(format!("Add {}", t.label())));
                    let b = b.on_hover_text("switch the effect on with its fitted parameters (on the calibrated model), simulate again and compare").on_disabled_hover_text(why);
                    if b.clicked() {
                        *cmd = Some(Command::AddTrial { effect: t.effect, trial: i, measured });
                    }
                    ui.end_row();
                }
            });
            ui.add_space(4.0);
            ui.strong("Fitted parameters and evidence from the residual map");
            for (i, t) in d.trials.iter().enumerate() {
                let fitted: Vec<String> = t.parameter.iter().chain(t.extra_parameters.iter()).map(|(p, v)| format!("{} = {} {}", p.name(), fmt_num(*v), unit_of(p.name())).trim_end().to_string()).collect();
                let fitted = if fitted.is_empty() { "a switch".to_string() } else { fitted.join(", ") };
                let itself = t.effect_explained.map_or(String::new(), |e| format!("; switching it off again in the fitted model costs {:.0} %", e * 100.0));
                let edge = t.not_a_finding_note().map_or(String::new(), |note| format!("; {note}"));
                let start = if t.from_uncalibrated { "; its best fit started from the uncalibrated values" } else { "" };
                let fine = if t.fine_cell_won.is_empty() { String::new() } else { format!("; {} ended lower from the fine grid's cell than from the coarse grid's", t.fine_cell_won.iter().map(|p| p.name()).collect::<Vec<_>>().join(", ")) };
                ui.add(egui::Label::new(format!("{}. {} ({fitted}): {}; explains {:.0} % of the error above the floor{itself}{edge}{start}{fine}", i + 1, t.label(), drawable(&t.evidence), t.explained * 100.0)).wrap());
            }
            // The joint trials of a stuck search that chose none (a chosen one heads the ranking).
            let chosen_jointly = d.trials.first().is_some_and(|t| t.joint) && d.best.is_some();
            if !d.joint_trials.is_empty() && !chosen_jointly {
                ui.add_space(4.0);
                ui.strong("Joint trials of this stuck search (none chosen; the verdict says why)");
                for t in &d.joint_trials {
                    let each = t.each_effect_explained.map_or(String::new(), |(a, b)| format!("; switching off {} alone costs {:.0} %, {} alone {:.0} %", t.effect.name(), a * 100.0, t.with_effect.map_or("", |k| k.name()), b * 100.0));
                    let edge = t.not_a_finding_note().map_or(String::new(), |note| format!("; {note}"));
                    ui.add(egui::Label::new(format!("{}: objective {:.1} -> {:.1}; explains {:.0} % of the error above the floor{each}{edge}", t.label(), t.objective_before, t.objective_after, t.explained * 100.0)).wrap())
                        .on_hover_text(drawable(&t.summary));
                }
            }
        });
    }
}

impl View for ModelLoopView {
    fn title(&self) -> &'static str {
        "Model loop"
    }

    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, settings: &Settings) -> Option<Command> {
        let mut cmd = None;
        let model = &session.model;
        if self.draft.as_ref().map(|d| d.0) != Some(model.revision) {
            self.draft = Some((model.revision, model.machine.clone()));
        }
        let measured = self.measured(session);
        let measured_list = session.measured_indices();
        let name = |i: usize| session.signals.get(i).map(|e| e.signal.name.clone()).unwrap_or_default();
        let (_, draft) = self.draft.as_mut()?;
        let valid = draft.validate();
        ui.horizontal(|ui| {
            egui::ComboBox::from_label("machine preset").selected_text(&model.preset).show_ui(ui, |ui| {
                for (p, _) in PRESETS {
                    if ui.selectable_label(*p == model.preset, p.to_string()).clicked() {
                        cmd = Some(Command::LoadMachinePreset(p.to_string()));
                    }
                }
            });
            if ui.button("Open machine…").on_hover_text("start again from a machine TOML (what `twinscope diagnose --machine` reads and `--save-machine` writes); the history of rounds is cleared").clicked() {
                cmd = Some(Command::Dialog(Purpose::OpenMachine));
            }
            if ui.button("Save machine…").on_hover_text("write the machine as it stands (after \"Use calibrated model\", the calibrated one) as TOML, for `twinscope diagnose --machine`, `simulate` and batch jobs").clicked() {
                cmd = Some(Command::Dialog(Purpose::SaveMachine));
            }
            let mut chosen = measured;
            egui::ComboBox::from_label("measured").selected_text(measured.map(name).unwrap_or_else(|| "none".into())).show_ui(ui, |ui| {
                for &i in &measured_list {
                    ui.selectable_value(&mut chosen, Some(i), name(i));
                }
            });
            self.measured = chosen;
            let ok = valid.is_ok();
            if ui.add_enabled(ok, egui::Button::new("Simulate")).on_hover_text("simulate the machine as edited, list it with the signals and compare it with the measured signal").clicked() {
                cmd = Some(Command::SimulateModel { measured: chosen });
            }
            let find = ui.add_enabled(ok && chosen.is_some(), egui::Button::new("Find missing effect")).on_hover_text("calibrate the model, try every missing effect with its parameters fitted, rank them (runs on a worker; Cancel in the status bar)");
            if find.clicked() {
                if let Some(m) = chosen {
                    cmd = Some(Command::FindMissingEffect { measured: m });
                }
            }
        });
        let measured_now = self.measured;
        let Some((_, draft)) = self.draft.as_mut() else { return cmd };
        ui.weak(format!("{} · fs {:.0} Hz · effects on: {}", draft.name, draft.fs_hz, draft.effects.enabled().iter().map(|k| k.name()).collect::<Vec<_>>().join(", ")));
        let mut changed = false;
        let mut new_settings = None;
        let h = ui.available_height();
        let left_w = (ui.available_width() * 0.4).clamp(300.0, 420.0);
        ui.horizontal_top(|ui| {
            ui.allocate_ui_with_layout(egui::vec2(left_w, h), egui::Layout::top_down(egui::Align::Min), |ui| {
            ui.set_width(left_w);
            egui::ScrollArea::vertical().id_salt("model-left").max_height(h).show(ui, |ui| {
                ui.strong("Machine");
                changed |= Self::machine_ui(ui, draft);
                if let Err(e) = draft.validate() {
                    ui.add(egui::Label::new(RichText::new(format!("Error: {e}")).color(ui.visuals().error_fg_color)).wrap());
                    ui.weak("the last valid machine is kept; Simulate and Find missing effect use it once this is fixed");
                }
                ui.add_space(6.0);
                ui.strong("Effects");
                changed |= Self::effects_ui(ui, draft, &model.refit_effects(), &crate::compare::diagnose::applied_effects(&model.history), &mut cmd);
                ui.add_space(6.0);
                new_settings = Self::search_settings_ui(ui, settings, draft);
            });
            });
            ui.separator();
            ui.vertical(|ui| {
                Self::rounds_ui(ui, session);
                ui.separator();
                Self::ranking_ui(measured_now, ui, session, &mut cmd);
            });
        });
        if let Some(s) = new_settings {
            cmd = cmd.or(Some(Command::SetSettings(s)));
        }
        if let Some((_, draft)) = self.draft.as_ref() {
            if changed && draft.validate().is_ok() && *draft != session.model.machine {
                cmd = cmd.or_else(|| Some(Command::SetMachine(Box::new(draft.clone()))));
            }
        }
        cmd
    }

    fn plot_data(&self, session: &Session, _settings: &Settings) -> Option<PlotData> {
        let h = &session.model.history;
        if h.is_empty() {
            return None;
        }
        let x: Vec<f64> = h.iter().map(|r| r.round as f64).collect();
        Some(PlotData {
            title: format!("Model loop: error over rounds ({})", session.model.preset),
            x_label: "round".into(),
            y_label: "NRMSE (%)".into(),
            series: vec![
                Series { name: "envelope NRMSE (%)".into(), x: x.clone(), y: h.iter().map(|r| r.envelope_nrmse).collect() },
                Series { name: "objective (weighted NRMSE, %)".into(), x, y: h.iter().map(|r| r.objective).collect() },
            ],
        })
    }
}
