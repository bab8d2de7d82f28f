//! The compare view: measured and simulated quantities overlaid (envelope spectrum, PSD in
//! dB, SCF α-slices), their residual, the metrics table of every domain and the residual map
//! that says where the model fails.

use super::{fmt_num, Command, View};
use crate::gui::session::{Origin, Session};
use crate::gui::settings::Settings;
use egui::Color32;
use egui_plot::{Legend, Line, Plot, PlotPoints};

/// The compare view.
#[derive(Default)]
pub struct CompareView {
    domain: String,
    measured: Option<usize>,
    simulated: Option<usize>,
}

impl View for CompareView {
    fn title(&self) -> &'static str {
        "Compare"
    }

    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, _settings: &Settings) -> Option<Command> {
        let mut cmd = None;
        let measured: Vec<usize> = session.signals.iter().enumerate().filter(|(_, s)| s.origin == Origin::Measured).map(|(i, _)| i).collect();
        let simulated: Vec<usize> = session.signals.iter().enumerate().filter(|(_, s)| s.origin != Origin::Measured).map(|(i, _)| i).collect();
        let keep = |sel: &mut Option<usize>, list: &[usize], fallback: Option<usize>| {
            if sel.is_none_or(|i| !list.contains(&i)) {
                *sel = fallback.filter(|i| list.contains(i)).or(list.last().copied());
            }
        };
        keep(&mut self.measured, &measured, session.selected);
        keep(&mut self.simulated, &simulated, None);
        let name = |i: Option<usize>| {
            let n = i.and_then(|i| session.signals.get(i)).map(|e| e.signal.name.clone()).unwrap_or_else(|| "none".into());
            if n.chars().count() > 28 { format!("{}…", n.chars().take(27).collect::<String>()) } else { n }
        };
        // Wrapped: with long signal names the row is wider than the central panel, and a
        // button past its edge could not be clicked.
        ui.horizontal_wrapped(|ui| {
            egui::ComboBox::from_label("measured").selected_text(name(self.measured)).show_ui(ui, |ui| {
                for &i in &measured {
                    ui.selectable_value(&mut self.measured, Some(i), name(Some(i)));
                }
            });
            if let Some(m) = self.measured {
                if ui.button("Band from kurtogram").on_hover_text("set the chain's bandpass stage, the comparison's demodulation band, to the measured signal's most impulsive band (its kurtogram) that holds a resonance of the model: at least twice the envelope spectrum's 200 Hz wide (`--band-from-kurtogram`)").clicked() {
                    cmd = Some(Command::BandFromKurtogram(m));
                }
            }
            egui::ComboBox::from_label("simulated").selected_text(name(self.simulated)).show_ui(ui, |ui| {
                for &i in &simulated {
                    ui.selectable_value(&mut self.simulated, Some(i), name(Some(i)));
                }
            });
            if let (Some(m), Some(s)) = (self.measured, self.simulated) {
                if ui.button("Compare").clicked() {
                    cmd = Some(Command::Compare { measured: m, simulated: s });
                }
            } else {
                ui.weak("load a measured signal and simulate a model to compare");
            }
        });
        let Some(c) = &session.comparison else {
            ui.label("No comparison yet.");
            return cmd;
        };
        let cmp = &c.comparison;
        ui.add(egui::Label::new(format!(
            "{} vs {} · demodulation band {:.0}–{:.0} Hz · {:.2} s compared at {} · simulated/measured RMS {:+.1} dB · speed ratio {:.4} · NRMSE normaliser {}",
            c.measured,
            c.simulated,
            c.options.envelope_band_hz[0],
            c.options.envelope_band_hz[1],
            cmp.alignment.duration_s,
            cmp.alignment.rate_in_words(),
            cmp.alignment.rms_ratio_db,
            cmp.alignment.speed_ratio,
            c.options.normaliser.name()
        )).wrap());
        if self.domain.is_empty() || cmp.domain(&self.domain).is_none() {
            self.domain = cmp.domains.first().map(|d| d.domain.clone()).unwrap_or_default();
        }
        ui.horizontal(|ui| {
            ui.label("domain");
            for d in &cmp.domains {
                ui.selectable_value(&mut self.domain, d.domain.clone(), &d.domain);
            }
        });
        let Some(d) = cmp.domain(&self.domain) else { return cmd };
        ui.strong("Metrics");
        egui::Grid::new("metrics").striped(true).num_columns(6).show(ui, |ui| {
            for hdr in ["domain", "Pearson r", "xcorr", "lag", "RMSE", "NRMSE"] {
                ui.weak(hdr);
            }
            ui.end_row();
            for dd in &cmp.domains {
                let m = &dd.metrics;
                ui.label(&dd.domain);
                ui.label(format!("{:.3}", m.pearson));
                ui.label(format!("{:.3}", m.xcorr_peak));
                ui.label(format!("{}", m.xcorr_lag));
                ui.label(fmt_num(m.rmse));
                ui.label(format!("{:.1} %", m.nrmse_percent));
                ui.end_row();
            }
        });
        ui.separator();
        let h = ui.available_height();
        ui.columns(2, |cols| {
            {
                let ui = &mut cols[0];
                let link = egui::Id::unique("compare-link");
                let line = |v: &[f64]| -> PlotPoints { d.frequency_hz.iter().zip(v).map(|(&f, &y)| [f, y]).collect() };
                ui.add(egui::Label::new(egui::RichText::new(format!("{} — measured and simulated", d.quantity)).strong()).truncate());
                Plot::new("compare-overlay").height(h * 0.5).legend(Legend::default()).link_axis(link, [true, false]).x_axis_label("frequency (Hz)").show(ui, |pu| {
                    pu.line(Line::new("measured", line(&d.measured)).color(Color32::from_rgb(60, 120, 220)).width(1.2));
                    pu.line(Line::new("simulated", line(&d.simulated)).color(Color32::from_rgb(230, 120, 40)).width(1.2));
                });
                ui.strong("residual (measured − simulated)");
                let res: PlotPoints = d.frequency_hz.iter().zip(d.measured.iter().zip(&d.simulated)).map(|(&f, (&m, &s))| [f, m - s]).collect();
                Plot::new("compare-residual").height(h * 0.32).link_axis(link, [true, false]).x_axis_label("frequency (Hz)").show(ui, |pu| {
                    pu.line(Line::new("residual", res).color(Color32::from_rgb(200, 60, 60)));
                });
            }
            {
                let ui = &mut cols[1];
                ui.add_space(6.0);
                ui.strong("Where the envelope error lives");
                egui::Grid::new("families").striped(true).num_columns(2).show(ui, |ui| {
                    for (f, s) in c.residual.envelope_families.iter().take(6) {
                        ui.label(f);
                        ui.label(format!("{s:.1} %"));
                        ui.end_row();
                    }
                });
                ui.add_space(6.0);
                ui.strong("Residual map");
                egui::ScrollArea::both().id_salt("residual-map").show(ui, |ui| {
                    egui::Grid::new("residual-items").striped(true).num_columns(3).show(ui, |ui| {
                        for hdr in ["place", "share", "note"] {
                            ui.weak(hdr);
                        }
                        ui.end_row();
                        for it in c.residual.items.iter().take(30) {
                            ui.label(&it.label).on_hover_text(format!("{} · {:.1} Hz · measured {} · model {}", it.kind, it.frequency_hz, fmt_num(it.measured), fmt_num(it.simulated)));
                            ui.label(format!("{:.1} %", it.share_percent));
                            ui.label(&it.note);
                            ui.end_row();
                        }
                    });
                });
            }
        });
        cmd
    }
}
