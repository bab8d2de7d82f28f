//! The SCF view: the cyclic spectral correlation `|S(α, f)|` (or the coherence `|γ(α, f)|`) of
//! the selected signal or of a time-domain chain stage, computed on a worker by
//! `dsp::scf::fast_scf` (or taken from a chain's `scf` stage), shown three ways:
//!
//! - **3D surface**: a projected, shaded surface drawn with the egui painter; drag to rotate,
//!   scroll to zoom, double-click to reset; a colour scale with its values and axis labels.
//! - **2D map**: the (α, f) plane as a heat map in a plot with α and f axes and fault lines.
//! - **α-slices**: `|S(α₀, f)|` at α₀ = 0, the shaft rate or a fault frequency.
//!
//! The map is reduced for drawing by `signal::display::max_pool_map` (block maxima, so a
//! cyclic line is never lost) and coloured with `signal::display::viridis`.

use super::spectra::family_colour;
use super::{Command, View};
use crate::dsp::scf::ScfParams;
use crate::gui::session::{ScfResult, Session};
use crate::gui::settings::Settings;
use crate::signal::display::{max_pool_map, scale_values, viridis, AmplitudeScale, DisplayGrid};
use crate::signal::export::{nice_ticks, tick_label, PlotData, Series};
use egui::{pos2, vec2, Color32, Pos2, RichText, Sense, Stroke};
use egui_plot::{Legend, Line, Plot, PlotImage, PlotPoint, PlotPoints, VLine};

/// How the map is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScfMode {
    /// Rotatable, zoomable 3D surface.
    Surface,
    /// Heat map in the (α, f) plane.
    Map,
    /// α-slices.
    Slices,
}

/// Which quantity is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScfQuantity {
    /// `|S(α, f)|`, unit²/Hz.
    Magnitude,
    /// `|γ(α, f)|`, dimensionless.
    Coherence,
}

#[derive(Debug, Clone, PartialEq)]
struct GridKey {
    signal: String,
    seconds_bits: u64,
    n_alpha: usize,
    quantity: ScfQuantity,
    db: bool,
    alpha_lo_bits: u64,
    alpha_hi_bits: u64,
    rows: usize,
    cols: usize,
}

/// The SCF view.
pub struct ScfView {
    /// Shown as 3D surface, 2D map or α-slices.
    pub mode: ScfMode,
    quantity: ScfQuantity,
    /// dB or linear, per mode (3D surface, 2D map, α-slices).
    db: [bool; 3],
    dynamic_range_db: f64,
    alpha_lo_hz: f64,
    alpha_hi_hz: f64,
    params: ScfParams,
    source: String,
    yaw: f32,
    pitch: f32,
    zoom: f32,
    slice_alpha_hz: f64,
    requested: bool,
    surface: Option<(GridKey, DisplayGrid)>,
    map: Option<(GridKey, DisplayGrid, egui::TextureHandle)>,
}

const DEFAULT_YAW: f32 = -0.65;
const DEFAULT_PITCH: f32 = 0.55;

impl Default for ScfView {
    fn default() -> Self {
        Self {
            mode: ScfMode::Surface,
            quantity: ScfQuantity::Magnitude,
            // Linear in 3D (the cyclic lines stand up as peaks), dB on the map and the slices
            // (the weaker lines stay visible).
            db: [false, true, true],
            dynamic_range_db: 40.0,
            alpha_lo_hz: 5.0,
            alpha_hi_hz: 500.0,
            params: ScfParams { alpha_min_hz: 0.0, alpha_max_hz: 500.0, ..Default::default() },
            source: "raw".into(),
            yaw: DEFAULT_YAW,
            pitch: DEFAULT_PITCH,
            zoom: 1.0,
            slice_alpha_hz: 0.0,
            requested: false,
            surface: None,
            map: None,
        }
    }
}

/// The colour scale of what is drawn: values `lo..hi` in display units.
#[derive(Debug, Clone)]
struct ColourScale {
    lo: f64,
    hi: f64,
    title: String,
    db: bool,
    unit: String,
}

impl ColourScale {
    fn t(&self, v: f64) -> f64 {
        if self.hi > self.lo {
            ((v - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
        } else {
            0.5
        }
    }

    fn text(&self, v: f64) -> String {
        if self.db {
            format!("{v:.1} dB")
        } else if self.unit.is_empty() {
            format!("{v:.3}")
        } else {
            format!("{} {}", tick_label(v), self.unit)
        }
    }
}

fn colour(t: f64, shade: f64) -> Color32 {
    let [r, g, b] = viridis(t);
    let s = shade.clamp(0.0, 1.0);
    Color32::from_rgb((r as f64 * s) as u8, (g as f64 * s) as u8, (b as f64 * s) as u8)
}

impl ScfView {
    fn quantity_unit(&self, r: &ScfResult) -> String {
        match self.quantity {
            ScfQuantity::Coherence => String::new(),
            ScfQuantity::Magnitude if r.unit.is_empty() => "1/Hz".into(),
            ScfQuantity::Magnitude => format!("{}²/Hz", r.unit),
        }
    }

    fn mode_index(&self) -> usize {
        match self.mode {
            ScfMode::Surface => 0,
            ScfMode::Map => 1,
            ScfMode::Slices => 2,
        }
    }

    fn uses_db(&self) -> bool {
        self.db[self.mode_index()] && self.quantity == ScfQuantity::Magnitude
    }

    /// The map pooled to `rows × cols` over the shown α range, in display units (dB when
    /// chosen), cached until something changes.
    fn grid(&self, r: &ScfResult, rows: usize, cols: usize) -> (GridKey, DisplayGrid) {
        let key = self.grid_key_only(r, rows, cols);
        let values = match self.quantity {
            ScfQuantity::Magnitude => r.map.magnitude(),
            ScfQuantity::Coherence => r.map.coherence.clone(),
        };
        let mut g = max_pool_map(&values, &r.map.alpha_hz, &r.map.frequency_hz, (self.alpha_lo_hz, self.alpha_hi_hz), (f64::NEG_INFINITY, f64::INFINITY), rows, cols);
        if key.db {
            // The block maximum commutes with the (monotone) dB scale.
            g.values = scale_values(&g.values, AmplitudeScale::Db, true);
            let finite = g.values.iter().copied().filter(|v| v.is_finite());
            (g.min, g.max) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        }
        (key, g)
    }

    fn scale_of(&self, r: &ScfResult, g: &DisplayGrid) -> ColourScale {
        let unit = self.quantity_unit(r);
        let (lo, hi) = if self.uses_db() { (g.min.max(g.max - self.dynamic_range_db), g.max) } else { (0.0f64.min(g.min), g.max) };
        let title = match (self.quantity, self.uses_db()) {
            (ScfQuantity::Coherence, _) => "|γ(α, f)|".to_string(),
            (_, true) => format!("|S(α, f)| (dB re 1 {unit})"),
            (_, false) => format!("|S(α, f)| ({unit})"),
        };
        ColourScale { lo, hi, title, db: self.uses_db(), unit }
    }

    fn controls(&mut self, ui: &mut egui::Ui, session: &Session, cmd: &mut Option<Command>) {
        let stages = session.time_stages_of_selected();
        if self.source != "raw" && !stages.contains(&self.source) {
            self.source = "raw".into();
        }
        ui.horizontal_wrapped(|ui| {
            egui::ComboBox::from_label("of").selected_text(if self.source == "raw" { "the selected signal".to_string() } else { format!("stage {}", self.source) }).show_ui(ui, |ui| {
                ui.selectable_value(&mut self.source, "raw".to_string(), "the selected signal");
                for s in &stages {
                    ui.selectable_value(&mut self.source, s.clone(), format!("stage {s}"));
                }
            });
            let fs = session.selected_signal().map(|e| e.signal.fs_hz).unwrap_or(1e6);
            ui.label("α up to");
            ui.add(egui::DragValue::new(&mut self.params.alpha_max_hz).range(1.0..=fs / 2.0).speed(1.0).suffix(" Hz"));
            egui::ComboBox::from_label("nperseg").selected_text(self.params.nperseg.to_string()).show_ui(ui, |ui| {
                for n in [128usize, 256, 512, 1024, 2048] {
                    ui.selectable_value(&mut self.params.nperseg, n, n.to_string());
                }
            });
            let can = session.selected_signal().is_some();
            if ui.add_enabled(can, egui::Button::new("Compute SCF")).on_hover_text("Fast-SC (Antoni 2017) of the selected signal on a worker").clicked() {
                *cmd = Some(Command::ComputeScf { source: self.source.clone(), params: self.params.clone() });
            }
        });
        ui.horizontal_wrapped(|ui| {
            for (m, t) in [(ScfMode::Surface, "3D surface"), (ScfMode::Map, "2D map"), (ScfMode::Slices, "α-slices")] {
                ui.selectable_value(&mut self.mode, m, t);
            }
            ui.separator();
            ui.selectable_value(&mut self.quantity, ScfQuantity::Magnitude, "|S|");
            ui.selectable_value(&mut self.quantity, ScfQuantity::Coherence, "coherence |γ|");
            if self.quantity == ScfQuantity::Magnitude {
                let i = self.mode_index();
                ui.checkbox(&mut self.db[i], "dB");
                if self.db[i] && self.mode != ScfMode::Slices {
                    ui.add(egui::DragValue::new(&mut self.dynamic_range_db).range(3.0..=200.0).suffix(" dB range"));
                }
            }
            if self.mode != ScfMode::Slices {
                ui.separator();
                ui.label("α from");
                ui.add(egui::DragValue::new(&mut self.alpha_lo_hz).range(0.0..=1e6).speed(0.5).suffix(" Hz"));
                ui.label("to");
                ui.add(egui::DragValue::new(&mut self.alpha_hi_hz).range(0.0..=1e6).speed(1.0).suffix(" Hz"));
            }
        });
    }

    /// The colour bar: title, max, gradient, min, as real labels (accessible, testable).
    fn colour_bar(ui: &mut egui::Ui, s: &ColourScale, height: f32) {
        ui.vertical(|ui| {
            ui.set_width(110.0);
            ui.add(egui::Label::new(RichText::new(&s.title).small()).wrap());
            ui.label(format!("max {}", s.text(s.hi)));
            let (rect, _) = ui.allocate_exact_size(vec2(22.0, (height - 80.0).max(60.0)), Sense::hover());
            let mut mesh = egui::Mesh::default();
            let n = 64;
            for i in 0..n {
                let t0 = i as f32 / n as f32;
                let t1 = (i + 1) as f32 / n as f32;
                let r = egui::Rect::from_min_max(pos2(rect.left(), rect.bottom() - t1 * rect.height()), pos2(rect.right(), rect.bottom() - t0 * rect.height()));
                mesh.add_colored_rect(r, colour((t0 as f64 + t1 as f64) / 2.0, 1.0));
            }
            ui.painter().add(egui::Shape::mesh(mesh));
            ui.painter().rect_stroke(rect, 0.0, Stroke::new(1.0, ui.visuals().weak_text_color()), egui::StrokeKind::Outside);
            for t in nice_ticks(s.lo, s.hi, 4) {
                let y = rect.bottom() - s.t(t) as f32 * rect.height();
                ui.painter().text(pos2(rect.right() + 4.0, y), egui::Align2::LEFT_CENTER, tick_label(t), egui::FontId::proportional(10.0), ui.visuals().text_color());
            }
            ui.label(format!("min {}", s.text(s.lo)));
        });
    }

    fn surface_ui(&mut self, ui: &mut egui::Ui, r: &ScfResult) {
        let want = (240, 64);
        let stale = self.surface.as_ref().map(|(k, _)| k) != Some(&self.grid_key_only(r, want.0, want.1));
        if stale {
            self.surface = Some(self.grid(r, want.0, want.1));
        }
        let Some((_, g)) = self.surface.as_ref() else { return };
        if g.rows() < 2 || g.cols() < 2 {
            ui.label(format!("Nothing to draw: the α range {:.1}–{:.1} Hz holds fewer than 2 rows of the map (α {:.1}–{:.1} Hz).", self.alpha_lo_hz, self.alpha_hi_hz, r.map.alpha_hz.first().unwrap_or(&0.0), r.map.alpha_hz.last().unwrap_or(&0.0)));
            return;
        }
        let scale = self.scale_of(r, g);
        let [a0, a1] = g.row_extent;
        let [f0, f1] = g.col_extent;
        let avail = ui.available_size();
        let h = (avail.y - 40.0).max(200.0);
        let mut reset = false;
        ui.horizontal_top(|ui| {
            let (resp, painter) = ui.allocate_painter(vec2((avail.x - 130.0).max(200.0), h), Sense::click_and_drag());
            if resp.dragged() {
                let d = resp.drag_delta();
                self.yaw += d.x * 0.01;
                self.pitch = (self.pitch + d.y * 0.01).clamp(0.05, 1.5);
            }
            if resp.hovered() {
                let s = ui.input(|i| i.smooth_scroll_delta.y);
                if s != 0.0 {
                    self.zoom = (self.zoom * (s * 0.002).exp()).clamp(0.3, 6.0);
                }
            }
            if resp.double_clicked() {
                reset = true;
            }
            let rect = resp.rect;
            painter.rect_filled(rect, 4.0, ui.visuals().extreme_bg_color);
            let (cy, sy) = (self.yaw.cos(), self.yaw.sin());
            let (cp, sp) = (self.pitch.cos(), self.pitch.sin());
            // World: x = α (−1..1), y = f (−1..1), z = value (−0.5..0.5). The camera looks
            // down at `pitch`, turned by `yaw`, with a mild perspective; `unit` gives the
            // screen offset per unit of scale and the depth (larger = farther).
            let unit = |x: f32, y: f32, z: f32| -> (egui::Vec2, f32) {
                let x1 = x * cy - y * sy;
                let y1 = x * sy + y * cy;
                let depth = y1 * cp - z * sp;
                let up = z * cp + y1 * sp;
                let k = 4.0 / (4.0 + depth);
                (vec2(x1 * k, -up * k), depth)
            };
            // Fit the box with its axis labels into the rectangle, then apply the zoom.
            let mut lo = vec2(f32::INFINITY, f32::INFINITY);
            let mut hi = vec2(f32::NEG_INFINITY, f32::NEG_INFINITY);
            for (x, y, z) in [(-1.0, -1.0, -0.5), (1.0, -1.0, -0.5), (1.0, 1.0, -0.5), (-1.0, 1.0, -0.5), (-1.0, -1.0, 0.5), (1.0, -1.0, 0.5), (1.0, 1.0, 0.5), (-1.0, 1.0, 0.5), (0.0, -1.6, -0.5), (1.5, 0.0, -0.5), (-1.0, 1.0, 0.7)] {
                let (q, _) = unit(x, y, z);
                lo = lo.min(q);
                hi = hi.max(q);
            }
            let margin = 28.0;
            let span = (hi - lo).max(vec2(1e-3, 1e-3));
            let base = ((rect.width() - 2.0 * margin) / span.x).min((rect.height() - 2.0 * margin) / span.y).max(1.0) * self.zoom;
            let c = rect.center() - base * (lo + hi) / 2.0;
            let project = |x: f32, y: f32, z: f32| -> (Pos2, f32) {
                let (q, depth) = unit(x, y, z);
                (c + base * q, depth)
            };
            let (nr, nc) = (g.rows(), g.cols());
            // cell centres placed by their coordinates, so the axis ticks read true
            let wx = |i: usize| -1.0 + 2.0 * ((g.row_coord[i] - a0) / (a1 - a0).max(1e-12)) as f32;
            let wy = |j: usize| -1.0 + 2.0 * ((g.col_coord[j] - f0) / (f1 - f0).max(1e-12)) as f32;
            let wz = |v: f64| scale.t(v) as f32 - 0.5;
            let z_at = |i: usize, j: usize| wz(g.values[i * nc + j]);
            let text_colour = ui.visuals().text_color();
            let weak = ui.visuals().weak_text_color();
            let font = egui::FontId::proportional(11.0);
            // the floor and the back walls' edges
            let floor = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
            for k in 0..4 {
                let (a, b) = (floor[k], floor[(k + 1) % 4]);
                painter.line_segment([project(a.0, a.1, -0.5).0, project(b.0, b.1, -0.5).0], Stroke::new(1.0, weak));
            }
            painter.line_segment([project(-1.0, 1.0, -0.5).0, project(-1.0, 1.0, 0.5).0], Stroke::new(1.0, weak));

            // the surface: one flat-shaded quad per cell, far to near
            let light = {
                let l = [-0.35f32, -0.45, 1.0];
                let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
                [l[0] / n, l[1] / n, l[2] / n]
            };
            let proj: Vec<(Pos2, f32)> = (0..nr * nc).map(|k| project(wx(k / nc), wy(k % nc), z_at(k / nc, k % nc))).collect();
            let mut quads: Vec<(f32, usize, usize)> = Vec::with_capacity((nr - 1) * (nc - 1));
            for i in 0..nr - 1 {
                for j in 0..nc - 1 {
                    let d = proj[i * nc + j].1 + proj[(i + 1) * nc + j].1 + proj[i * nc + j + 1].1 + proj[(i + 1) * nc + j + 1].1;
                    quads.push((d, i, j));
                }
            }
            quads.sort_by(|a, b| b.0.total_cmp(&a.0));
            let mut mesh = egui::Mesh::default();
            mesh.reserve_vertices(quads.len() * 4);
            mesh.reserve_triangles(quads.len() * 2);
            for (_, i, j) in quads {
                let (dx, dy) = (wx(i + 1) - wx(i), wy(j + 1) - wy(j));
                let (z00, z10, z01, z11) = (z_at(i, j), z_at(i + 1, j), z_at(i, j + 1), z_at(i + 1, j + 1));
                // normal of the cell from its two diagonals
                let u = [dx, dy, z11 - z00];
                let v = [-dx, dy, z01 - z10];
                let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-9);
                let lambert = ((n[0] * light[0] + n[1] * light[1] + n[2] * light[2]) / len).abs();
                let vmax = g.values[i * nc + j].max(g.values[(i + 1) * nc + j]).max(g.values[i * nc + j + 1]).max(g.values[(i + 1) * nc + j + 1]);
                let col = colour(scale.t(vmax), 0.45 + 0.55 * lambert as f64);
                let base_idx = mesh.vertices.len() as u32;
                for k in [i * nc + j, (i + 1) * nc + j, (i + 1) * nc + j + 1, i * nc + j + 1] {
                    mesh.colored_vertex(proj[k].0, col);
                }
                mesh.add_triangle(base_idx, base_idx + 1, base_idx + 2);
                mesh.add_triangle(base_idx, base_idx + 2, base_idx + 3);
            }
            painter.add(egui::Shape::mesh(mesh));
            // the shaft and fault cyclic frequencies: coloured marks just outside the α edge
            for (label, a) in fault_alphas(r, a0, a1) {
                let x = -1.0 + 2.0 * ((a - a0) / (a1 - a0).max(1e-12)) as f32;
                let col = family_colour(&label);
                painter.line_segment([project(x, -1.0, -0.5).0, project(x, -1.07, -0.5).0], Stroke::new(2.0, col));
                painter.text(project(x, -1.1, -0.5).0, egui::Align2::CENTER_TOP, label, egui::FontId::proportional(9.0), col);
            }
            // axes: α along the f = −1 edge, f along the α = +1 edge, value up the back corner
            for t in nice_ticks(a0, a1, 5) {
                let x = -1.0 + 2.0 * ((t - a0) / (a1 - a0).max(1e-12)) as f32;
                let (p, _) = project(x, -1.0, -0.5);
                let (q, _) = project(x, -1.2, -0.5);
                painter.line_segment([p, q], Stroke::new(1.0, weak));
                painter.text(project(x, -1.32, -0.5).0, egui::Align2::CENTER_CENTER, tick_label(t), font.clone(), text_colour);
            }
            painter.text(project(0.0, -1.55, -0.5).0, egui::Align2::CENTER_CENTER, "α (Hz)", egui::FontId::proportional(13.0), text_colour);
            for t in nice_ticks(f0, f1, 5) {
                let y = -1.0 + 2.0 * ((t - f0) / (f1 - f0).max(1e-12)) as f32;
                let (p, _) = project(1.0, y, -0.5);
                let (q, _) = project(1.1, y, -0.5);
                painter.line_segment([p, q], Stroke::new(1.0, weak));
                painter.text(project(1.22, y, -0.5).0, egui::Align2::CENTER_CENTER, tick_label(t), font.clone(), text_colour);
            }
            painter.text(project(1.45, 0.0, -0.5).0, egui::Align2::CENTER_CENTER, "f (Hz)", egui::FontId::proportional(13.0), text_colour);
            for t in nice_ticks(scale.lo, scale.hi, 4) {
                let z = scale.t(t) as f32 - 0.5;
                let (p, _) = project(-1.0, 1.0, z);
                painter.line_segment([p, p + vec2(-5.0, 0.0)], Stroke::new(1.0, weak));
                painter.text(p + vec2(-8.0, 0.0), egui::Align2::RIGHT_CENTER, tick_label(t), font.clone(), text_colour);
            }
            painter.text(project(-1.0, 1.0, 0.62).0, egui::Align2::CENTER_BOTTOM, if scale.db { "|S| (dB)" } else if self.quantity == ScfQuantity::Coherence { "|γ|" } else { "|S|" }, egui::FontId::proportional(13.0), text_colour);
            Self::colour_bar(ui, &scale, h);
        });
        if reset {
            (self.yaw, self.pitch, self.zoom) = (DEFAULT_YAW, DEFAULT_PITCH, 1.0);
        }
        ui.horizontal_wrapped(|ui| {
            ui.label(format!("α (Hz): {a0:.1} – {a1:.1}"));
            ui.label(format!("f (Hz): {f0:.0} – {f1:.0}"));
            ui.weak(format!("{} × {} map cells drawn as {} × {} (block maxima) · drag to rotate, scroll to zoom, double-click to reset", r.map.n_alpha(), r.map.n_frequency(), g.rows(), g.cols()));
        });
    }

    fn grid_key_only(&self, r: &ScfResult, rows: usize, cols: usize) -> GridKey {
        GridKey {
            signal: r.signal_name.clone(),
            seconds_bits: r.seconds.to_bits(),
            n_alpha: r.map.n_alpha(),
            quantity: self.quantity,
            db: self.uses_db(),
            alpha_lo_bits: self.alpha_lo_hz.to_bits(),
            alpha_hi_bits: self.alpha_hi_hz.to_bits(),
            rows,
            cols,
        }
    }

    fn map_ui(&mut self, ui: &mut egui::Ui, r: &ScfResult) {
        let avail = ui.available_size();
        let rows = (avail.x.max(200.0) as usize).min(1200);
        let cols = (avail.y.max(150.0) as usize).min(800);
        let key = self.grid_key_only(r, rows, cols);
        if self.map.as_ref().map(|m| &m.0) != Some(&key) {
            let (key, g) = self.grid(r, rows, cols);
            let scale = self.scale_of(r, &g);
            let (w, h) = (g.rows().max(1), g.cols().max(1));
            let mut pixels = vec![Color32::BLACK; w * h];
            for i in 0..g.rows() {
                for j in 0..g.cols() {
                    pixels[(h - 1 - j) * w + i] = colour(scale.t(g.values[i * g.cols() + j]), 1.0);
                }
            }
            let tex = ui.ctx().load_texture("scf-map", egui::ColorImage::new([w, h], pixels), egui::TextureOptions::NEAREST);
            self.map = Some((key, g, tex));
        }
        let Some((_, g, tex)) = self.map.as_ref() else { return };
        if g.rows() < 1 || g.cols() < 1 {
            ui.label("Nothing to draw in this α range.");
            return;
        }
        let scale = self.scale_of(r, g);
        let half = |c: &[f64]| if c.len() > 1 { 0.5 * (c[1] - c[0]) } else { 0.5 };
        let (ha, hf) = (half(&g.row_coord), half(&g.col_coord));
        let a0 = g.row_coord[0] - ha;
        let a1 = g.row_coord[g.rows() - 1] + ha;
        let f0 = g.col_coord[0] - hf;
        let f1 = g.col_coord[g.cols() - 1] + hf;
        let h = (avail.y - 30.0).max(200.0);
        let lines = fault_alphas(r, a0, a1);
        ui.horizontal_top(|ui| {
            ui.allocate_ui(vec2((avail.x - 130.0).max(200.0), h), |ui| {
                Plot::new("scf-map").height(h).show_grid(false).legend(Legend::default()).x_axis_label("α (Hz)").y_axis_label("f (Hz)").show(ui, |pu| {
                    pu.image(PlotImage::new("SCF", tex.id(), PlotPoint::new((a0 + a1) / 2.0, (f0 + f1) / 2.0), vec2((a1 - a0) as f32, (f1 - f0) as f32)));
                    for (label, a) in &lines {
                        pu.vline(VLine::new(label.clone(), *a).color(family_colour(label.split_whitespace().next().unwrap_or(""))).width(1.0));
                    }
                });
            });
            Self::colour_bar(ui, &scale, h);
        });
        ui.horizontal_wrapped(|ui| {
            ui.label(format!("α (Hz): {:.1} – {:.1}", g.row_extent[0], g.row_extent[1]));
            ui.weak(format!("{} × {} map cells drawn as {} × {} (block maxima)", r.map.n_alpha(), r.map.n_frequency(), g.rows(), g.cols()));
        });
    }

    fn slices_ui(&mut self, ui: &mut egui::Ui, r: &ScfResult) {
        let amax = r.map.alpha_hz.last().copied().unwrap_or(0.0);
        let amin = r.map.alpha_hz.first().copied().unwrap_or(0.0);
        ui.horizontal_wrapped(|ui| {
            ui.label("α =");
            ui.add(egui::DragValue::new(&mut self.slice_alpha_hz).range(amin..=amax).speed(0.1).suffix(" Hz"));
            if ui.button("0 (PSD)").clicked() {
                self.slice_alpha_hz = 0.0_f64.clamp(amin, amax);
            }
            for (label, a) in fault_alphas(r, amin, amax) {
                if ui.button(format!("{label} {a:.2} Hz")).clicked() {
                    self.slice_alpha_hz = a;
                }
            }
        });
        let slice = match self.quantity {
            ScfQuantity::Magnitude => r.map.alpha_slice(self.slice_alpha_hz),
            ScfQuantity::Coherence => r.map.coherence_slice(self.slice_alpha_hz),
        };
        match slice {
            Err(e) => {
                ui.colored_label(ui.visuals().error_fg_color, format!("Error: {e}"));
            }
            Ok((f, v)) => {
                let ia = r.map.alpha_index(self.slice_alpha_hz).unwrap_or(0);
                let y = if self.uses_db() { scale_values(&v, AmplitudeScale::Db, true) } else { v };
                let unit = self.quantity_unit(r);
                let ylab = match (self.quantity, self.uses_db()) {
                    (ScfQuantity::Coherence, _) => "|γ(α, f)|".to_string(),
                    (_, true) => format!("|S(α, f)| (dB re 1 {unit})"),
                    (_, false) => format!("|S(α, f)| ({unit})"),
                };
                let name = format!("α = {:.2} Hz", r.map.alpha_hz[ia]);
                ui.label(format!("slice at the grid α nearest {:.2} Hz: {:.3} Hz (δα = {:.3} Hz)", self.slice_alpha_hz, r.map.alpha_hz[ia], r.map.alpha_resolution_hz));
                let pts: PlotPoints = f.iter().zip(&y).map(|(&a, &b)| [a, b]).collect();
                Plot::new("scf-slice").legend(Legend::default()).x_axis_label("f (Hz)").y_axis_label(ylab).show(ui, |pu| {
                    pu.line(Line::new(name, pts).color(Color32::from_rgb(60, 120, 220)));
                });
            }
        }
    }
}

/// The cyclic frequencies worth a look: the shaft rate and the fault families, within `[lo, hi]`.
fn fault_alphas(r: &ScfResult, lo: f64, hi: f64) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = Vec::new();
    if let Some(fr) = r.shaft_speed_hz {
        v.push(("shaft".into(), fr));
    }
    for f in &r.families {
        if !v.iter().any(|(l, _)| *l == f.label) {
            v.push((f.label.clone(), f.frequency_hz));
        }
    }
    v.retain(|(_, a)| a.is_finite() && *a >= lo && *a <= hi);
    v
}

impl View for ScfView {
    fn title(&self) -> &'static str {
        "SCF"
    }

    fn ui(&mut self, ui: &mut egui::Ui, session: &Session, _settings: &Settings) -> Option<Command> {
        let mut cmd = None;
        self.controls(ui, session, &mut cmd);
        let Some(r) = &session.scf else {
            if !self.requested && session.selected_signal().is_some() {
                self.requested = true;
                cmd = Some(Command::ComputeScf { source: self.source.clone(), params: self.params.clone() });
            }
            ui.label(if session.selected_signal().is_some() { "Computing the SCF of the selected signal…" } else { "No signal selected: open or select one, then Compute SCF." });
            return cmd;
        };
        self.requested = true;
        ui.label(format!(
            "SCF of {} ({}) · {} · α {:.1}–{:.1} Hz, δα {:.3} Hz · Δf {:.1} Hz · nperseg {} · {} segments · {:.2} s",
            r.signal_name,
            r.source,
            match r.map.method {
                crate::dsp::scf::ScfMethod::Fast => "Fast-SC",
                crate::dsp::scf::ScfMethod::CyclicPeriodogram => "averaged cyclic periodogram",
            },
            r.map.alpha_hz.first().unwrap_or(&0.0),
            r.map.alpha_hz.last().unwrap_or(&0.0),
            r.map.alpha_resolution_hz,
            r.map.frequency_resolution_hz,
            r.map.nperseg,
            r.map.n_segments,
            r.seconds
        ));
        match self.mode {
            ScfMode::Surface => self.surface_ui(ui, r),
            ScfMode::Map => self.map_ui(ui, r),
            ScfMode::Slices => self.slices_ui(ui, r),
        }
        cmd
    }

    fn plot_data(&self, session: &Session, _settings: &Settings) -> Option<PlotData> {
        let r = session.scf.as_ref()?;
        let unit = self.quantity_unit(r);
        let what = if self.quantity == ScfQuantity::Coherence { "|γ(α, f)|".to_string() } else if self.uses_db() { format!("|S(α, f)| (dB re 1 {unit})") } else { format!("|S(α, f)| ({unit})") };
        if self.mode == ScfMode::Slices {
            let (f, v) = match self.quantity {
                ScfQuantity::Magnitude => r.map.alpha_slice(self.slice_alpha_hz).ok()?,
                ScfQuantity::Coherence => r.map.coherence_slice(self.slice_alpha_hz).ok()?,
            };
            let y = if self.uses_db() { scale_values(&v, AmplitudeScale::Db, true) } else { v };
            let ia = r.map.alpha_index(self.slice_alpha_hz).ok()?;
            return Some(PlotData { title: format!("SCF α-slice of {}", r.signal_name), x_label: "f (Hz)".into(), y_label: what, series: vec![Series { name: format!("α = {:.3} Hz", r.map.alpha_hz[ia]), x: f, y }] });
        }
        // the map as drawn (block maxima): one series per α row
        let g = match self.mode {
            ScfMode::Map => self.map.as_ref().map(|m| &m.1),
            _ => self.surface.as_ref().map(|s| &s.1),
        }?;
        let series = (0..g.rows()).map(|i| Series { name: format!("α = {:.3} Hz", g.row_coord[i]), x: g.col_coord.clone(), y: g.values[i * g.cols()..(i + 1) * g.cols()].to_vec() }).collect();
        Some(PlotData { title: format!("SCF of {} (block maxima as drawn)", r.signal_name), x_label: "f (Hz)".into(), y_label: what, series })
    }
}
