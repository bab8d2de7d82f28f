//! The filter view: the designed equiripple FIR's magnitude response in dB with its spec
//! overlaid (passband ripple limits, stopband attenuation limits) and the achieved figures.

use super::{Command, View};
use crate::gui::session::Session;
use crate::gui::settings::Settings;
use egui::Color32;
use egui_plot::{Legend, Line, Plot, PlotPoints};

/// The filter view.
#[derive(Default)]
pub struct FilterView {
    selected: usize,
}

impl View for FilterView {
    fn title(&self) -> &'static str {
        "Filter"
    }

    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, _settings: &Settings) -> Option<Command> {
        let Some(a) = &session.analysis else {
            ui.label("No analysis yet: run a chain with a bandpass stage.");
            return None;
        };
        if a.firs.is_empty() {
            ui.label(format!("Chain `{}` has no bandpass stage.", a.chain.name));
            return None;
        }
        if self.selected >= a.firs.len() {
            self.selected = 0;
        }
        if a.firs.len() > 1 {
            ui.horizontal(|ui| {
                for (i, f) in a.firs.iter().enumerate() {
                    ui.selectable_value(&mut self.selected, i, &f.stage);
                }
            });
        }
        let f = &a.firs[self.selected];
        let d = &f.design;
        let spec = &d.spec;
        let met = |ok: bool| if ok { "met" } else { "NOT met" };
        egui::Grid::new("fir-figures").num_columns(4).striped(true).show(ui, |ui| {
            ui.weak("figure");
            ui.weak("spec");
            ui.weak("achieved");
            ui.weak("");
            ui.end_row();
            ui.label("passband");
            ui.label(format!("{:.0}–{:.0} Hz", spec.pass_band_hz[0], spec.pass_band_hz[1]));
            ui.label(format!("{} taps (Herrmann estimate {})", d.numtaps, d.estimated_taps));
            ui.label(format!("fs {:.0} Hz", d.fs_hz));
            ui.end_row();
            ui.label("passband ripple");
            ui.label(format!("≤ {:.2} dB", spec.passband_ripple_db));
            ui.label(format!("{:.3} dB", d.achieved_ripple_db));
            ui.label(met(d.achieved_ripple_db <= spec.passband_ripple_db + 1e-9));
            ui.end_row();
            ui.label("lower stopband");
            ui.label(format!("≥ {:.1} dB below {:.0} Hz", spec.stopband_low_db, spec.pass_band_hz[0] - spec.transition_low_hz));
            ui.label(format!("{:.2} dB", d.achieved_stopband_low_db));
            ui.label(met(d.achieved_stopband_low_db >= spec.stopband_low_db - 1e-9));
            ui.end_row();
            ui.label("upper stopband");
            ui.label(format!("≥ {:.1} dB above {:.0} Hz", spec.stopband_high_db, spec.pass_band_hz[1] + spec.transition_high_hz));
            ui.label(format!("{:.2} dB", d.achieved_stopband_high_db));
            ui.label(met(d.achieved_stopband_high_db >= spec.stopband_high_db - 1e-9));
            ui.end_row();
        });
        let pts: PlotPoints = f.frequency_hz.iter().zip(&f.magnitude_db).map(|(&x, &y)| [x, y.max(-200.0)]).collect();
        let spec_colour = Color32::from_rgb(220, 60, 60);
        let nyq = d.fs_hz / 2.0;
        let [pl, ph] = spec.pass_band_hz;
        let s_lo = pl - spec.transition_low_hz;
        let s_hi = ph + spec.transition_high_hz;
        Plot::new("fir-plot").x_axis_label("frequency (Hz)").y_axis_label("magnitude (dB)").legend(Legend::default()).include_y(-(spec.stopband_high_db.max(spec.stopband_low_db) + 30.0)).include_y(5.0).show(ui, |pu| {
            pu.line(Line::new(format!("response ({} taps)", d.numtaps), pts).color(Color32::from_rgb(70, 140, 230)).width(1.2));
            let seg = |name: &str, x0: f64, x1: f64, y: f64| Line::new(name.to_string(), vec![[x0, y], [x1, y]]).color(spec_colour).width(2.0);
            if s_lo > 0.0 {
                pu.line(seg("spec", 0.0, s_lo, -spec.stopband_low_db));
            }
            if s_hi < nyq {
                pu.line(seg("spec", s_hi, nyq, -spec.stopband_high_db));
            }
            // Passband limits 1 ± δp (the spec's peak-to-peak ripple about the unit gain), in dB.
            let dp = spec.delta_pass();
            if let Ok(lim) = crate::dsp::spectrum::to_db(&[1.0 + dp, 1.0 - dp], 1.0, crate::dsp::spectrum::DbKind::Amplitude) {
                pu.line(seg("spec", pl, ph, lim[0]));
                pu.line(seg("spec", pl, ph, lim[1]));
            }
        });
        None
    }
}
