//! The chains panel: the chain's stages in order; add, remove and reorder them; edit each
//! stage's parameters with their units and valid ranges; presets; open/save TOML; Run.
//!
//! Parameters are edited through the stage's serde form (the same keys as the chain TOML), so
//! every stage kind the library has is editable, and an edit the library refuses is shown as an
//! error while the last valid chain stays in place.

use super::{Command, View};
use crate::chain::{Chain, FaultRef, Op, Stage, PRESETS};
use crate::gui::jobs;
use crate::gui::session::Session;
use crate::gui::settings::Settings;
use crate::kinematics::lookup_bearing;

/// Kinds a stage can have (the `kind` of a `[[stage]]`).
pub const STAGE_KINDS: [&str; 11] = ["normalise", "stsa", "bandpass", "hilbert_envelope", "envelope_spectrum", "spectrum", "welch", "drs", "scf", "integrate", "decibel"];

/// The chains panel.
pub struct ChainPanel {
    draft: Chain,
    revision: u64,
    add_kind: usize,
    preset: usize,
    error: Option<String>,
    path_text: String,
}

impl Default for ChainPanel {
    fn default() -> Self {
        Self { draft: Chain { name: String::new(), description: String::new(), stages: Vec::new() }, revision: 0, add_kind: 0, preset: 1, error: None, path_text: "chain.toml".into() }
    }
}

/// Choices of an enum-valued parameter, by key (and stage kind where keys collide).
fn choices(kind: &str, key: &str) -> Option<&'static [&'static str]> {
    Some(match (kind, key) {
        (_, "window") => &["boxcar", "hann", "hamming", "blackman", "flattop"],
        ("normalise", "method") => &["peak", "std", "none"],
        ("scf", "method") => &["fast", "cyclic_periodogram"],
        (_, "pad") => &["periodic", "zeros"],
        ("spectrum", "scaling") => &["peak", "rms", "power_spectrum"],
        ("welch", "scaling") => &["density", "spectrum"],
        (_, "detrend") => &["none", "constant", "linear"],
        (_, "average") => &["mean", "median"],
        (_, "from") | (_, "to") => &["acceleration", "velocity", "displacement"],
        _ => return None,
    })
}

/// Valid range and unit suffix of a numeric parameter, from its name (units are in the names).
fn range_of(key: &str, fs_hz: f64, integer: bool) -> (f64, f64, &'static str) {
    let nyq = fs_hz / 2.0;
    match key {
        "max_taps" => (3.0, crate::dsp::remez::MAX_NUMTAPS as f64, ""),
        "grid_density" => (16.0, 128.0, ""),
        "passband_ripple_db" => (0.001, 20.0, " dB"),
        "tolerance_fraction" => (0.0, 0.5, ""),
        "scale" | "reference" => (1e-12, 1e12, ""),
        k if k.ends_with("_hz") => (0.0, nyq, " Hz"),
        k if k.ends_with("_db") => (0.0, 200.0, " dB"),
        k if k.ends_with("_s") => (0.0, 3600.0, " s"),
        k if k.ends_with("_fraction") => (0.0, 1.0, ""),
        _ if integer => (0.0, 16_777_216.0, ""),
        _ => (-1e12, 1e12, ""),
    }
}

/// Optional parameters a stage kind accepts but the TOML omits when unset, with a starting value.
fn optional_keys(kind: &str) -> Vec<(&'static str, toml::Value)> {
    let pair = |a: f64, b: f64| toml::Value::Array(vec![a.into(), b.into()]);
    match kind {
        "stsa" => vec![("segments_per_average", 10.into())],
        "envelope_spectrum" => vec![("band_hz", pair(0.0, 200.0))],
        "spectrum" => vec![("nfft", 16384.into())],
        "welch" => vec![("noverlap", 1024.into()), ("nfft", 4096.into())],
        "scf" => vec![("noverlap", 192.into())],
        "integrate" => vec![("unit", "mm/s".into())],
        _ => Vec::new(),
    }
}

/// A number editor with the parameter's range and unit.
fn number(ui: &mut egui::Ui, v: &mut toml::Value, key: &str, fs: f64, label: egui::Id) -> bool {
    match v {
        toml::Value::Float(f) => {
            let (lo, hi, suffix) = range_of(key, fs, false);
            let speed = ((hi - lo).abs() / 1000.0).clamp(1e-3, 10.0);
            ui.add(egui::DragValue::new(f).range(lo..=hi).speed(speed).suffix(suffix)).labelled_by(label).changed()
        }
        toml::Value::Integer(n) => {
            let (lo, hi, suffix) = range_of(key, fs, true);
            let mut x = *n as f64;
            let ch = ui.add(egui::DragValue::new(&mut x).range(lo..=hi).speed(1.0).fixed_decimals(0).suffix(suffix)).labelled_by(label).changed();
            if ch {
                *n = x.round() as i64;
            }
            ch
        }
        _ => false,
    }
}

/// Edits one parameter value; returns whether it changed.
fn value_ui(ui: &mut egui::Ui, kind: &str, key: &str, v: &mut toml::Value, fs: f64, label: egui::Id) -> bool {
    if let (Some(opts), toml::Value::String(s)) = (choices(kind, key), &mut *v) {
        let mut changed = false;
        egui::ComboBox::from_id_salt(("choice", kind, key, ui.next_auto_id()))
            .selected_text(s.as_str())
            .show_ui(ui, |ui| {
                for o in opts {
                    if ui.selectable_label(s == o, *o).clicked() && s != o {
                        *s = o.to_string();
                        changed = true;
                    }
                }
            })
            .response
            .labelled_by(label);
        return changed;
    }
    match v {
        toml::Value::Boolean(b) => ui.checkbox(b, "").labelled_by(label).changed(),
        toml::Value::String(s) => ui.add(egui::TextEdit::singleline(s).desired_width(120.0)).labelled_by(label).changed(),
        toml::Value::Array(a) => {
            let mut ch = false;
            ui.horizontal(|ui| {
                for x in a.iter_mut() {
                    ch |= number(ui, x, key, fs, label);
                }
            });
            ch
        }
        other => number(ui, other, key, fs, label),
    }
}

/// Edits a stage's operation through its TOML table; returns the new operation when an edit
/// parses, or the library's message when it does not.
fn op_ui(ui: &mut egui::Ui, op: &Op, fs: f64) -> Option<Result<Op, String>> {
    let kind = op.kind();
    let Ok(toml::Value::Table(mut t)) = toml::Value::try_from(op) else {
        ui.weak("(parameters not editable)");
        return None;
    };
    t.remove("kind");
    let mut changed = false;
    let keys: Vec<String> = t.keys().cloned().collect();
    egui::Grid::new(ui.next_auto_id()).num_columns(2).show(ui, |ui| {
        for key in keys {
            let optional = optional_keys(kind).iter().any(|(k, _)| *k == key);
            let label = if optional {
                let mut on = true;
                let r = ui.checkbox(&mut on, key.as_str()).on_hover_text("untick: use the default");
                if r.changed() && !on {
                    t.remove(&key);
                    changed = true;
                }
                r.id
            } else {
                ui.label(&key).id
            };
            if let Some(v) = t.get_mut(&key) {
                changed |= value_ui(ui, kind, &key, v, fs, label);
            } else {
                ui.label("");
            }
            ui.end_row();
        }
        for (key, default) in optional_keys(kind) {
            if t.contains_key(key) {
                continue;
            }
            let mut on = false;
            if ui.checkbox(&mut on, key).on_hover_text("tick to set this parameter").changed() && on {
                t.insert(key.to_string(), default.clone());
                changed = true;
            }
            ui.weak("default");
            ui.end_row();
        }
    });
    if !changed {
        return None;
    }
    t.insert("kind".into(), kind.into());
    Some(toml::Value::Table(t).try_into::<Op>().map_err(|e| e.message().trim().to_string()))
}

/// A new stage of `kind` with default parameters and a name unique in `chain`.
pub fn new_stage(chain: &Chain, kind: &str) -> Result<Stage, String> {
    let mut t = toml::Table::new();
    t.insert("kind".into(), kind.into());
    let op: Op = toml::Value::Table(t).try_into().map_err(|e: toml::de::Error| e.message().to_string())?;
    let mut name = kind.to_string();
    let mut k = 2;
    while chain.stages.iter().any(|s| s.name == name) {
        name = format!("{kind}_{k}");
        k += 1;
    }
    let fault = (kind == "stsa").then(|| FaultRef::Named("bpfi".into()));
    Ok(Stage { name, input: None, fault, band_hz: None, op })
}

impl View for ChainPanel {
    fn title(&self) -> &'static str {
        "Chain"
    }

    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, _settings: &Settings) -> Option<Command> {
        if self.revision != session.chain_revision {
            self.draft = session.chain.clone();
            self.revision = session.chain_revision;
            self.error = None;
        }
        let fs = session.selected_signal().map(|e| e.signal.fs_hz).unwrap_or(48_000.0);
        let bearing_ok = session.selected_signal().and_then(|e| e.signal.meta.bearing.as_deref()).map(|b| lookup_bearing(b).is_ok()).unwrap_or(false);
        let mut cmd = None;
        let mut edited = false;
        ui.heading("Chain");
        ui.horizontal(|ui| {
            egui::ComboBox::from_label("preset").selected_text(PRESETS.get(self.preset).map(|p| p.0).unwrap_or("?")).show_ui(ui, |ui| {
                for (i, (name, _)) in PRESETS.iter().enumerate() {
                    ui.selectable_value(&mut self.preset, i, *name);
                }
            });
            if ui.button("Load preset").clicked() {
                if let Some((name, _)) = PRESETS.get(self.preset) {
                    cmd = Some(Command::ChainPreset(name.to_string()));
                }
            }
        });
        ui.horizontal(|ui| {
            if ui.button("Open TOML…").clicked() {
                cmd = Some(Command::OpenChainDialog);
            }
            if ui.button("Save TOML…").clicked() {
                cmd = Some(Command::SaveChainDialog);
            }
        });
        ui.horizontal(|ui| {
            let l = ui.label("file");
            ui.add(egui::TextEdit::singleline(&mut self.path_text).desired_width(130.0).hint_text("path.toml")).labelled_by(l.id);
            if ui.button("Read").on_hover_text("read a chain TOML from this path").clicked() {
                cmd = Some(Command::OpenChain(self.path_text.trim().into()));
            }
            if ui.button("Write").on_hover_text("write the chain TOML to this path").clicked() {
                cmd = Some(Command::SaveChain(self.path_text.trim().into()));
            }
        });
        ui.horizontal(|ui| {
            let l = ui.label("name");
            edited |= ui.add(egui::TextEdit::singleline(&mut self.draft.name).desired_width(180.0)).labelled_by(l.id).changed();
        });
        if !self.draft.description.is_empty() {
            ui.add(egui::Label::new(egui::RichText::new(self.draft.description.replace('→', "->")).small().weak()).wrap());
        }
        ui.separator();
        let n = self.draft.stages.len();
        let mut action: Option<(usize, i32)> = None; // (index, -1 up, +1 down, 0 remove)
        let earlier_names: Vec<String> = self.draft.stages.iter().map(|s| s.name.clone()).collect();
        egui::ScrollArea::vertical().id_salt("stages").max_height(ui.available_height() - 90.0).show(ui, |ui| {
            for i in 0..n {
                let stage = &mut self.draft.stages[i];
                let problem = jobs::check_stage(&stage.op, fs).err();
                let head = format!("{}. {} ({})", i + 1, stage.name, stage.op.kind());
                let header = egui::CollapsingHeader::new(egui::RichText::new(head).color(if problem.is_some() { ui.visuals().error_fg_color } else { ui.visuals().text_color() })).id_salt(("stage", i)).default_open(false);
                let resp = header.show(ui, |ui| {
                    ui.horizontal(|ui| {
                        if ui.add_enabled(i > 0, egui::Button::new("Up")).on_hover_text("move up").clicked() {
                            action = Some((i, -1));
                        }
                        if ui.add_enabled(i + 1 < n, egui::Button::new("Down")).on_hover_text("move down").clicked() {
                            action = Some((i, 1));
                        }
                        if ui.button("Remove").clicked() {
                            action = Some((i, 0));
                        }
                    });
                    egui::Grid::new(("stage-head", i)).num_columns(2).show(ui, |ui| {
                        let l = ui.label("name");
                        edited |= ui.add(egui::TextEdit::singleline(&mut stage.name).desired_width(140.0)).labelled_by(l.id).changed();
                        ui.end_row();
                        let l = ui.label("input");
                        let current = stage.input.clone().unwrap_or_else(|| "previous stage".into());
                        egui::ComboBox::from_id_salt(("input", i)).selected_text(current).show_ui(ui, |ui| {
                            edited |= ui.selectable_value(&mut stage.input, None, "previous stage").changed();
                            edited |= ui.selectable_value(&mut stage.input, Some("raw".into()), "raw").changed();
                            for e in earlier_names.iter().take(i) {
                                edited |= ui.selectable_value(&mut stage.input, Some(e.clone()), e).changed();
                            }
                        })
                        .response
                        .labelled_by(l.id);
                        ui.end_row();
                        if stage.op.kind() == "stsa" {
                            let l = ui.label("fault");
                            let current = match &stage.fault {
                                Some(FaultRef::Named(n)) => n.clone(),
                                Some(FaultRef::Hz(h)) => format!("{h} Hz"),
                                None => "fault_frequency_hz".into(),
                            };
                            egui::ComboBox::from_id_salt(("fault", i)).selected_text(current).show_ui(ui, |ui| {
                                edited |= ui.selectable_value(&mut stage.fault, None, "fault_frequency_hz").changed();
                                for f in ["bpfo", "bpfi", "bsf", "2xbsf", "ftf", "shaft"] {
                                    edited |= ui.selectable_value(&mut stage.fault, Some(FaultRef::Named(f.into())), f).changed();
                                }
                            })
                            .response
                            .labelled_by(l.id);
                            ui.end_row();
                        }
                        if matches!(stage.op.kind(), "spectrum" | "welch") {
                            let mut on = stage.band_hz.is_some();
                            if ui.checkbox(&mut on, "band_hz").changed() {
                                stage.band_hz = on.then_some([0.0, fs / 2.0]);
                                edited = true;
                            }
                            if let Some(b) = stage.band_hz.as_mut() {
                                ui.horizontal(|ui| {
                                    edited |= ui.add(egui::DragValue::new(&mut b[0]).range(0.0..=fs / 2.0).suffix(" Hz")).changed();
                                    edited |= ui.add(egui::DragValue::new(&mut b[1]).range(0.0..=fs / 2.0).suffix(" Hz")).changed();
                                });
                            } else {
                                ui.weak("whole spectrum");
                            }
                            ui.end_row();
                        }
                    });
                    match op_ui(ui, &stage.op, fs) {
                        Some(Ok(op)) => {
                            stage.op = op;
                            edited = true;
                        }
                        Some(Err(e)) => self.error = Some(format!("stage `{}`: {e}", stage.name)),
                        None => {}
                    }
                    if let Some(p) = &problem {
                        ui.colored_label(ui.visuals().error_fg_color, p);
                    }
                });
                if let Some(p) = &problem {
                    resp.header_response.on_hover_text(p);
                }
            }
        });
        if let Some((i, dir)) = action {
            match dir {
                0 => {
                    self.draft.stages.remove(i);
                }
                d => {
                    let j = (i as i64 + d as i64) as usize;
                    self.draft.stages.swap(i, j);
                }
            }
            edited = true;
        }
        ui.horizontal(|ui| {
            egui::ComboBox::from_label("kind").selected_text(STAGE_KINDS[self.add_kind]).show_ui(ui, |ui| {
                for (i, k) in STAGE_KINDS.iter().enumerate() {
                    ui.selectable_value(&mut self.add_kind, i, *k);
                }
            });
            if ui.button("Add stage").clicked() {
                match new_stage(&self.draft, STAGE_KINDS[self.add_kind]) {
                    Ok(s) => {
                        self.draft.stages.push(s);
                        edited = true;
                    }
                    Err(e) => self.error = Some(e),
                }
            }
        });
        if edited {
            match jobs::check_chain(&self.draft) {
                Ok(_) => {
                    self.error = None;
                    cmd = Some(Command::SetChain(self.draft.clone()));
                }
                Err(e) => self.error = Some(format!("{e} (the last valid chain is kept)")),
            }
        }
        if let Some(e) = &self.error {
            ui.colored_label(ui.visuals().error_fg_color, e);
        }
        if self.draft.stages.iter().any(|s| s.fault.as_ref().is_some_and(|f| matches!(f, FaultRef::Named(n) if n != "shaft"))) && !bearing_ok {
            ui.colored_label(ui.visuals().warn_fg_color, "the STSA fault needs a bearing: set it in the signal's metadata");
        }
        ui.separator();
        ui.horizontal(|ui| {
            let can_run = session.selected.is_some() && self.error.is_none();
            if ui.add_enabled(can_run, egui::Button::new("Run chain")).clicked() {
                cmd = Some(Command::RunChain);
            }
        });
        cmd
    }
}
