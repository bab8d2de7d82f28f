//! The spectra view: the envelope spectrum with characteristic-frequency markers
//! (BPFO/BPFI/BSF/FTF/GMF harmonics and ± shaft sidebands, labelled from
//! [`crate::kinematics`]) and the labelled peak table; below, the amplitude spectrum and the
//! Welch PSD of the chain input with linked zoom and pan; lin/log/dB toggles.

use super::{fmt_num, Command, View};
use crate::dsp::spectrum::Spectrum;
use crate::gui::session::{Analysis, Session};
use crate::gui::settings::Settings;
use crate::kinematics::MarkerLine;
use crate::signal::display::{scale_values, AmplitudeScale};
use egui::Color32;
use egui_plot::{Line, Plot, PlotPoint, PlotPoints, Text, VLine};

/// The marker colour of a family.
pub fn family_colour(family: &str) -> Color32 {
    match family {
        "BPFO" => Color32::from_rgb(230, 120, 40),
        "BPFI" => Color32::from_rgb(220, 60, 60),
        "BSF" | "2xBSF" => Color32::from_rgb(170, 90, 210),
        "FTF" => Color32::from_rgb(60, 170, 90),
        "GMF" => Color32::from_rgb(40, 160, 200),
        _ => Color32::from_rgb(150, 150, 150),
    }
}

/// The spectra view.
pub struct SpectraView {
    hidden_families: Vec<String>,
    link_id: egui::Id,
}

impl Default for SpectraView {
    fn default() -> Self {
        Self { hidden_families: vec!["BSF".into(), "FTF".into(), "shaft".into()], link_id: egui::Id::unique("spectra-link") }
    }
}

fn is_power(s: &Spectrum) -> bool {
    s.quantity.contains("power") || s.quantity.contains("PSD") || s.unit.contains("^2")
}

fn axis_label(s: &Spectrum, scale: AmplitudeScale) -> String {
    let q = s.quantity.replace("power spectral density", "PSD");
    let u = if s.unit.is_empty() { String::new() } else { format!(" ({})", s.unit) };
    match scale {
        AmplitudeScale::Linear => format!("{q}{u}"),
        AmplitudeScale::Log10 => format!("log10 {q}{u}"),
        AmplitudeScale::Db if s.unit.is_empty() => format!("{q} (dB re 1)"),
        AmplitudeScale::Db => format!("{q} (dB re 1 {})", s.unit),
    }
}

/// Draws `s` with `markers` in the visible band; returns nothing.
#[allow(clippy::too_many_arguments)]
fn spectrum_plot(ui: &mut egui::Ui, id: &str, s: &Spectrum, scale: AmplitudeScale, markers: &[&MarkerLine], link: Option<egui::Id>, height: f32, peaks: &[(f64, f64, String)]) {
    let y = scale_values(&s.values, scale, is_power(s));
    let pts: PlotPoints = s.frequency_hz.iter().zip(&y).map(|(&f, &v)| [f, v]).collect();
    let ymax = y.iter().copied().filter(|v| v.is_finite()).fold(f64::NEG_INFINITY, f64::max);
    let mut plot = Plot::new(id).height(height).x_axis_label("frequency (Hz)").y_axis_label(axis_label(s, scale));
    if let Some(l) = link {
        plot = plot.link_axis(l, [true, false]).link_cursor(l, [true, false]);
    }
    plot.show(ui, |pu| {
        pu.line(Line::new(s.quantity.clone(), pts).width(1.0));
        let b = pu.plot_bounds();
        let (lo, hi) = (b.min()[0], b.max()[0]);
        let visible: Vec<&&MarkerLine> = markers.iter().filter(|m| m.frequency_hz >= lo && m.frequency_hz <= hi).collect();
        // Too many lines in view hide the spectrum: draw markers only when they can be read,
        // and a label only where it does not overlap the previous one.
        let px_per_hz = pu.transform().frame().width() as f64 / (hi - lo).max(1e-9);
        let mut last_label_px = f64::NEG_INFINITY;
        if visible.len() <= 120 {
            for m in &visible {
                let c = family_colour(&m.family);
                let c = if m.sideband != 0 { c.gamma_multiply(0.45) } else { c };
                pu.vline(VLine::new("", m.frequency_hz).color(c).width(if m.sideband == 0 { 1.2 } else { 0.8 }).style(if m.sideband == 0 { egui_plot::LineStyle::Solid } else { egui_plot::LineStyle::dashed_dense() }));
                let x_px = (m.frequency_hz - lo) * px_per_hz;
                if m.sideband == 0 && ymax.is_finite() && x_px - last_label_px >= 60.0 {
                    last_label_px = x_px;
                    pu.text(Text::new("", PlotPoint::new(m.frequency_hz, ymax), egui::RichText::new(&m.label).small().color(c)).anchor(egui::Align2::LEFT_TOP));
                }
            }
        }
        for (f, v, label) in peaks {
            let yv = scale_values(&[*v], scale, is_power(s))[0];
            pu.text(Text::new("", PlotPoint::new(*f, yv), egui::RichText::new(label.as_str()).small().strong()).anchor(egui::Align2::LEFT_BOTTOM));
        }
    });
}

impl SpectraView {
    fn markers<'a>(&self, a: &'a Analysis, settings: &Settings) -> Vec<&'a MarkerLine> {
        if !settings.show_markers {
            return Vec::new();
        }
        a.markers
            .iter()
            .filter(|m| m.harmonic <= settings.marker_harmonics && (settings.show_sidebands || m.sideband == 0) && !self.hidden_families.contains(&m.family))
            .collect()
    }
}

impl View for SpectraView {
    fn title(&self) -> &'static str {
        "Spectra"
    }

    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, settings: &Settings) -> Option<Command> {
        let mut cmd = None;
        let Some(a) = &session.analysis else {
            ui.label("No analysis yet: select a signal and run the chain.");
            return None;
        };
        let mut s = settings.clone();
        ui.horizontal_wrapped(|ui| {
            ui.label("scale");
            for sc in [AmplitudeScale::Linear, AmplitudeScale::Log10, AmplitudeScale::Db] {
                ui.selectable_value(&mut s.spectrum_scale, sc, sc.name());
            }
            ui.separator();
            ui.checkbox(&mut s.show_markers, "markers");
            ui.checkbox(&mut s.show_sidebands, "± shaft sidebands");
            ui.add(egui::DragValue::new(&mut s.marker_harmonics).range(1..=20).prefix("harmonics "));
            ui.separator();
            for f in &a.families {
                let mut shown = !self.hidden_families.contains(&f.label);
                if ui.checkbox(&mut shown, egui::RichText::new(&f.label).color(family_colour(&f.label))).on_hover_text(format!("{:.3} Hz", f.frequency_hz)).changed() {
                    if shown {
                        self.hidden_families.retain(|x| x != &f.label);
                    } else {
                        self.hidden_families.push(f.label.clone());
                    }
                }
            }
        });
        if s != *settings {
            cmd = Some(Command::SetSettings(s.clone()));
        }
        let scale = s.spectrum_scale;
        let markers = self.markers(a, &s);
        let h = ui.available_height();
        if let Some((stage, env)) = &a.envelope {
            let w = ui.available_width();
            let shaft = a.shaft_speed_hz.map(|fr| format!(" · shaft {:.3} Hz ({:.0} rpm)", fr, fr * 60.0)).unwrap_or_default();
            ui.add(egui::Label::new(egui::RichText::new(format!("Envelope spectrum — stage `{stage}` of chain `{}` on {}{shaft}", a.chain.name, a.signal_name)).strong()).truncate());
            ui.horizontal_top(|ui| {
                ui.allocate_ui_with_layout(egui::vec2((w - 310.0).max(200.0), h * 0.5), egui::Layout::top_down(egui::Align::Min), |ui| {
                    // Annotate the strong labelled peaks (at least a quarter of the largest).
                    let top = a.peaks.first().map(|p| p.value).unwrap_or(0.0);
                    let labelled: Vec<(f64, f64, String)> = a.peaks.iter().take(5).filter(|p| p.label() != "-" && p.value >= 0.25 * top).map(|p| (p.frequency_hz, p.value, p.label())).collect();
                    spectrum_plot(ui, "envelope-plot", env, scale, &markers, Some(egui::Id::unique("envelope-link")), h * 0.5 - 10.0, &labelled);
                });
                ui.vertical(|ui| {
                    ui.strong("Peaks");
                    egui::ScrollArea::vertical().id_salt("peaks").max_height(h * 0.5 - 20.0).show(ui, |ui| {
                        egui::Grid::new("peak-table").striped(true).num_columns(4).show(ui, |ui| {
                            ui.weak("#");
                            ui.weak("frequency");
                            ui.weak(if env.unit.is_empty() { "value".to_string() } else { format!("value ({})", env.unit) });
                            ui.weak("line");
                            ui.end_row();
                            for (i, p) in a.peaks.iter().enumerate() {
                                ui.label(format!("{}", i + 1));
                                ui.label(format!("{:.2} Hz", p.frequency_hz));
                                ui.label(fmt_num(p.value));
                                ui.label(p.label());
                                ui.end_row();
                            }
                        });
                    });
                });
            });
        } else {
            ui.label("The chain has no spectrum stage.");
        }
        ui.separator();
        let rest = ui.available_height();
        let each = ((rest - 40.0) / 2.0).max(80.0);
        if let Some(sp) = &a.spectrum {
            ui.add(egui::Label::new(egui::RichText::new(format!("Amplitude spectrum of {}", a.signal_name)).strong()).truncate());
            spectrum_plot(ui, "spectrum-plot", sp, scale, &markers, Some(self.link_id), each - 14.0, &[]);
        }
        if let Some(psd) = &a.psd {
            ui.add(egui::Label::new(egui::RichText::new(format!("Welch PSD of {}", a.signal_name)).strong()).truncate());
            spectrum_plot(ui, "psd-plot", psd, scale, &markers, Some(self.link_id), each - 14.0, &[]);
        }
        cmd
    }
}
