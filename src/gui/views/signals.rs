//! The signals panel: measured and simulated signals with fs, duration and shaft speed; the
//! channel chooser; the metadata editor (fs, shaft speed, bearing from the catalogue).

use super::{fmt_opt, Command, View};
use crate::gui::session::{Origin, Session};
use crate::gui::settings::Settings;
use crate::kinematics::catalogue;

/// Draft metadata of the selected signal (applied with the Apply button).
#[derive(Debug, Clone, PartialEq)]
struct Draft {
    id: u64,
    fs_hz: f64,
    shaft_speed_hz: f64,
    shaft_known: bool,
    bearing: Option<String>,
}

/// The signals panel.
#[derive(Default)]
pub struct SignalsPanel {
    draft: Option<Draft>,
}

impl View for SignalsPanel {
    fn title(&self) -> &'static str {
        "Signals"
    }

    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, settings: &Settings) -> Option<Command> {
        let mut cmd = None;
        ui.horizontal(|ui| {
            ui.heading("Signals");
            if ui.button("Open…").on_hover_text("Open a .mat, .wav or .csv file (or drop files on the window)").clicked() {
                cmd = Some(Command::OpenSignalDialog);
            }
        });
        if !settings.recent_files.is_empty() {
            egui::ComboBox::from_label("recent").selected_text("files").width(200.0).show_ui(ui, |ui| {
                for p in &settings.recent_files {
                    if ui.selectable_label(false, p.display().to_string()).clicked() {
                        cmd = Some(Command::OpenSignal(p.clone()));
                    }
                }
            });
        }
        if session.signals.is_empty() {
            ui.label("No signal loaded. Open a file or drop one here.");
        }
        for (heading, simulated) in [("Measured", false), ("Simulated", true)] {
            let rows: Vec<usize> = session.signals.iter().enumerate().filter(|(_, s)| matches!(s.origin, Origin::Simulated { .. }) == simulated).map(|(i, _)| i).collect();
            ui.add_space(4.0);
            ui.strong(heading);
            if rows.is_empty() {
                ui.weak("none");
                continue;
            }
            egui::Grid::new(("signals", heading)).striped(true).num_columns(4).show(ui, |ui| {
                ui.weak("name");
                ui.weak("fs");
                ui.weak("duration");
                ui.weak("shaft");
                ui.end_row();
                for i in rows {
                    let e = &session.signals[i];
                    let s = &e.signal;
                    let full = e.title();
                    let short = if full.chars().count() > 20 { format!("{}…", full.chars().take(19).collect::<String>()) } else { full.clone() };
                    if ui.selectable_label(session.selected == Some(i), short).on_hover_text(format!("{full}\n{}", s.meta.source.clone().unwrap_or_default())).clicked() {
                        cmd = Some(Command::Select(i));
                    }
                    ui.label(format!("{:.0} Hz", s.fs_hz));
                    ui.label(format!("{:.2} s", s.duration_s()));
                    ui.label(fmt_opt(s.meta.shaft_speed_hz, 2, "Hz"));
                    ui.end_row();
                }
            });
        }
        ui.separator();
        let Some(index) = session.selected else { return cmd };
        let Some(entry) = session.signals.get(index) else { return cmd };
        let s = &entry.signal;
        ui.strong(format!("Selected: {}", s.name));
        ui.label(format!("{} · {} samples · unit {}", entry.origin.word(), s.len(), if s.unit.is_empty() { "?" } else { &s.unit }));
        if let Origin::Simulated { preset } = &entry.origin {
            ui.label(format!("machine preset {preset}"));
        }
        if entry.channels.len() > 1 {
            let current = s.meta.channel.clone().unwrap_or_default();
            egui::ComboBox::from_label("channel").selected_text(&current).show_ui(ui, |ui| {
                for c in &entry.channels {
                    let text = format!("{} ({} samples)", c.name, c.len);
                    if ui.selectable_label(c.name == current, text).clicked() && c.name != current {
                        cmd = Some(Command::LoadChannel { index, channel: c.name.clone() });
                    }
                }
            });
        }
        let fresh = Draft { id: entry.id, fs_hz: s.fs_hz, shaft_speed_hz: s.meta.shaft_speed_hz.unwrap_or(0.0), shaft_known: s.meta.shaft_speed_hz.is_some(), bearing: s.meta.bearing.clone() };
        if self.draft.as_ref().map(|d| d.id) != Some(entry.id) {
            self.draft = Some(fresh.clone());
        }
        let Some(d) = self.draft.as_mut() else { return cmd };
        egui::Grid::new("metadata").num_columns(2).show(ui, |ui| {
            ui.label("sampling rate");
            ui.add(egui::DragValue::new(&mut d.fs_hz).range(1.0..=10_000_000.0).speed(10.0).suffix(" Hz"));
            ui.end_row();
            ui.checkbox(&mut d.shaft_known, "shaft speed");
            ui.add_enabled(d.shaft_known, egui::DragValue::new(&mut d.shaft_speed_hz).range(0.01..=2000.0).speed(0.01).suffix(" Hz"));
            ui.end_row();
            ui.label("");
            ui.weak(if d.shaft_known { format!("{:.1} rpm", d.shaft_speed_hz * 60.0) } else { "unknown".into() });
            ui.end_row();
            let l = ui.label("bearing");
            egui::ComboBox::from_id_salt("bearing").selected_text(d.bearing.clone().unwrap_or_else(|| "none".into())).width(170.0).show_ui(ui, |ui| {
                ui.selectable_value(&mut d.bearing, None, "none");
                for b in catalogue() {
                    ui.selectable_value(&mut d.bearing, Some(b.name.clone()), &b.name).on_hover_text(&b.source);
                }
            })
            .response
            .labelled_by(l.id);
            ui.end_row();
        });
        let changed = *d != fresh;
        let apply = Command::SetMetadata { index, fs_hz: d.fs_hz, shaft_speed_hz: d.shaft_known.then_some(d.shaft_speed_hz), bearing: d.bearing.clone() };
        let mut reset = false;
        ui.horizontal(|ui| {
            if ui.add_enabled(changed, egui::Button::new("Apply metadata")).clicked() {
                cmd = Some(apply);
            }
            if ui.add_enabled(changed, egui::Button::new("Revert")).clicked() {
                reset = true;
            }
            if ui.button("Remove signal").clicked() {
                cmd = Some(Command::Remove(index));
                reset = true;
            }
        });
        if reset {
            self.draft = None;
        }
        cmd
    }
}
