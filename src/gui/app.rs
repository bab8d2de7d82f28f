//! The workbench: panels around a tabbed central area, a status bar with the running jobs
//! (progress, Cancel) and the messages. It owns the [`Settings`], the [`Session`] and the
//! [`Worker`], and carries out the views' [`Command`]s.

use super::jobs;
use super::session::{JobOutput, Level, Purpose, Session};
use super::settings::Settings;
use super::views::{chain::ChainPanel, compare::CompareView, filter::FilterView, signals::SignalsPanel, spectra::SpectraView, time::TimeView, Command, View};
use super::worker::{Event, Worker};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How the workbench starts.
#[derive(Debug, Clone, Default)]
pub struct StartOptions {
    /// Load the bundled demo (CWRU 105 + envelope chain + simulated model, compared).
    pub demo: bool,
    /// Files to open at start.
    pub files: Vec<PathBuf>,
    /// The tab to show first (`time`, `spectra`/`envelope`, `filter`, `compare`).
    pub tab: Option<String>,
    /// Where settings are read from and written to; `None` = defaults, not persisted (tests).
    pub settings_path: Option<PathBuf>,
}

/// The desktop workbench.
pub struct Workbench {
    /// Persisted preferences.
    pub settings: Settings,
    /// What is loaded and computed.
    pub session: Session,
    /// Background jobs.
    pub worker: Worker,
    signals: SignalsPanel,
    chain: ChainPanel,
    views: Vec<Box<dyn View>>,
    active: usize,
    start: Option<StartOptions>,
    settings_path: Option<PathBuf>,
}

/// Index of a tab by a name given on the command line.
pub fn tab_index(name: &str) -> Option<usize> {
    match name.to_ascii_lowercase().as_str() {
        "spectra" | "spectrum" | "envelope" | "psd" => Some(0),
        "time" => Some(1),
        "filter" | "fir" => Some(2),
        "compare" => Some(3),
        _ => None,
    }
}

impl Workbench {
    /// A workbench; the start work (demo, files) is queued for the first frame.
    pub fn new(opts: StartOptions) -> Self {
        let (settings, problem) = match &opts.settings_path {
            Some(p) => Settings::load(p),
            None => (Settings::default(), None),
        };
        let chain = crate::chain::preset(if opts.demo { jobs::DEMO_CHAIN } else { &settings.chain_preset }).or_else(|_| crate::chain::preset(jobs::DEMO_CHAIN));
        let mut session = Session::new(chain.unwrap_or_else(|_| crate::chain::Chain { name: "empty".into(), description: String::new(), stages: Vec::new() }));
        if let Some(p) = problem {
            session.tell(Level::Error, p);
        }
        let views: Vec<Box<dyn View>> = vec![Box::new(SpectraView::default()), Box::new(TimeView::default()), Box::new(FilterView::default()), Box::new(CompareView::default())];
        let active = opts.tab.as_deref().and_then(tab_index).unwrap_or(0);
        if let Some(t) = opts.tab.as_deref().filter(|t| tab_index(t).is_none()) {
            session.tell(Level::Error, format!("unknown view `{t}`; views: spectra, time, filter, compare"));
        }
        Self { settings, session, worker: Worker::default(), signals: SignalsPanel::default(), chain: ChainPanel::default(), views, active, settings_path: opts.settings_path.clone(), start: Some(opts) }
    }

    /// Titles of the tabs, in order.
    pub fn tab_titles(&self) -> Vec<&'static str> {
        self.views.iter().map(|v| v.title()).collect()
    }

    /// Shows tab `i`.
    pub fn show_tab(&mut self, i: usize) {
        if i < self.views.len() {
            self.active = i;
        }
    }

    /// Saves the settings (when a path was given).
    pub fn save_settings(&self) {
        if let Some(p) = &self.settings_path {
            if let Err(e) = self.settings.save(p) {
                eprintln!("twinscope: settings not saved: {e}");
            }
        }
    }

    fn start_work(&mut self) {
        let Some(opts) = self.start.take() else { return };
        if opts.demo {
            let ids = [self.session.next_signal_id(), self.session.next_signal_id()];
            let labelling = self.settings.labelling();
            self.worker.spawn("demo: CWRU 105 envelope analysis, cwru_6205_inner simulated and compared", move |job| jobs::demo(ids, labelling, job));
        }
        for f in opts.files {
            self.execute(Command::OpenSignal(f));
        }
    }

    /// Carries out a command.
    pub fn execute(&mut self, cmd: Command) {
        match cmd {
            Command::OpenSignalDialog => self.dialog(Purpose::OpenSignal),
            Command::OpenChainDialog => self.dialog(Purpose::OpenChain),
            Command::SaveChainDialog => self.dialog(Purpose::SaveChain),
            Command::OpenSignal(path) => self.open_signal(path, None, None),
            Command::LoadChannel { index, channel } => {
                let Some(e) = self.session.signals.get(index) else { return };
                match e.file.clone() {
                    Some(p) => self.open_signal(p, Some(channel), Some(e.id)),
                    None if e.signal.meta.source.as_deref().is_some_and(|s| s.contains(jobs::DEMO_FILE)) => {
                        let id = e.id;
                        self.worker.spawn(format!("loading channel {channel} of the demo file"), move |job| {
                            let mut entry = jobs::demo_signal(id)?;
                            entry.signal = crate::signal::io::mat::read_bytes(jobs::DEMO_BYTES, jobs::DEMO_FILE, &crate::signal::io::LoadOptions { channel: Some(channel), ..Default::default() }).map_err(|e| e.to_string())?;
                            entry.signal.meta.bearing.get_or_insert_with(|| jobs::DEMO_BEARING.into());
                            job.send(JobOutput::Signal { entry: Box::new(entry), replace: Some(id), select: true });
                            Ok(())
                        });
                    }
                    None => self.session.tell(Level::Error, "this signal has no file to read another channel from"),
                }
            }
            Command::Select(i) => {
                if i < self.session.signals.len() {
                    self.session.selected = Some(i);
                }
            }
            Command::Remove(i) => {
                if i < self.session.signals.len() {
                    let e = self.session.signals.remove(i);
                    self.session.tell(Level::Info, format!("removed {}", e.signal.name));
                    self.session.selected = if self.session.signals.is_empty() { None } else { Some(i.min(self.session.signals.len() - 1)) };
                }
            }
            Command::SetMetadata { index, fs_hz, shaft_speed_hz, bearing } => self.set_metadata(index, fs_hz, shaft_speed_hz, bearing),
            Command::SetChain(c) => self.session.chain = c,
            Command::ChainPreset(name) => match crate::chain::preset(&name) {
                Ok(c) => {
                    self.session.replace_chain(c);
                    self.settings.chain_preset = name.clone();
                    self.session.tell(Level::Info, format!("chain preset {name} loaded"));
                }
                Err(e) => self.session.tell(Level::Error, e.to_string()),
            },
            Command::OpenChain(p) => match jobs::read_chain(&p) {
                Ok(c) => {
                    self.session.replace_chain(c);
                    self.session.tell(Level::Info, format!("chain read from {}", p.display()));
                }
                Err(e) => self.session.tell(Level::Error, e),
            },
            Command::SaveChain(p) => match jobs::write_chain(&self.session.chain, &p) {
                Ok(()) => self.session.tell(Level::Info, format!("chain written to {}", p.display())),
                Err(e) => self.session.tell(Level::Error, e),
            },
            Command::RunChain => self.run_chain(),
            Command::Simulate(preset) => {
                let id = self.session.next_signal_id();
                self.worker.spawn(format!("simulating machine preset {preset}"), move |job| {
                    let e = jobs::simulate_preset(id, &preset, job)?;
                    job.send(JobOutput::Signal { entry: Box::new(e), replace: None, select: false });
                    Ok(())
                });
            }
            Command::Compare { measured, simulated } => {
                let (Some(m), Some(s)) = (self.session.signals.get(measured).cloned(), self.session.signals.get(simulated).cloned()) else {
                    self.session.tell(Level::Error, "choose a measured and a simulated signal to compare");
                    return;
                };
                let opts = jobs::compare_options_for(&self.session.chain);
                self.worker.spawn(format!("comparing {} with {}", m.signal.name, s.signal.name), move |job| {
                    job.set_step("aligning, envelope, PSD and SCF slices");
                    let r = jobs::compare_signals(&m, &s, &opts)?;
                    job.check()?;
                    job.send(JobOutput::Comparison(Box::new(r)));
                    Ok(())
                });
            }
            Command::Cancel(id) => self.worker.cancel(id),
            Command::SetSettings(s) => self.settings = s,
            Command::ClearMessages => self.session.messages.clear(),
        }
    }

    fn dialog(&mut self, purpose: Purpose) {
        let dir = self.settings.last_dir.clone();
        self.worker.spawn("waiting for the file dialog", move |job| {
            match jobs::pick(purpose, dir) {
                Some(p) => job.send(JobOutput::Picked(purpose, p)),
                None => job.send(JobOutput::Info("no file chosen".into())),
            }
            Ok(())
        });
    }

    fn open_signal(&mut self, path: PathBuf, channel: Option<String>, replace: Option<u64>) {
        let id = replace.unwrap_or_else(|| self.session.next_signal_id());
        let label = format!("loading {}", path.display());
        self.worker.spawn(label, move |job| {
            job.set_step("reading");
            let e = jobs::load_file(id, &path, channel)?;
            jobs::usable(&e.signal)?;
            job.send(JobOutput::Signal { entry: Box::new(e), replace, select: true });
            Ok(())
        });
    }

    fn set_metadata(&mut self, index: usize, fs_hz: f64, shaft: Option<f64>, bearing: Option<String>) {
        let Some(e) = self.session.signals.get_mut(index) else { return };
        if let Err(err) = crate::dsp::error::check_fs(fs_hz) {
            self.session.tell(Level::Error, format!("metadata not changed: {err}"));
            return;
        }
        if let Some(fr) = shaft {
            if !(fr.is_finite() && fr > 0.0) {
                self.session.tell(Level::Error, format!("metadata not changed: shaft speed {fr} Hz must be positive"));
                return;
            }
        }
        if let Some(b) = &bearing {
            if let Err(err) = crate::kinematics::lookup_bearing(b) {
                self.session.tell(Level::Error, format!("metadata not changed: {err}"));
                return;
            }
        }
        e.signal.fs_hz = fs_hz;
        e.signal.meta.shaft_speed_hz = shaft;
        e.signal.meta.bearing = bearing;
        let name = e.signal.name.clone();
        self.session.tell(Level::Info, format!("metadata of {name} updated; run the chain again to see its effect"));
    }

    fn run_chain(&mut self) {
        let Some(entry) = self.session.selected_signal().cloned() else {
            self.session.tell(Level::Error, "select a signal first");
            return;
        };
        if let Err(e) = jobs::check_chain(&self.session.chain) {
            self.session.tell(Level::Error, e);
            return;
        }
        let chain = self.session.chain.clone();
        let labelling = self.settings.labelling();
        self.worker.spawn(format!("chain {} on {}", chain.name, entry.signal.name), move |job| {
            let a = jobs::analyse(&entry, &chain, &labelling, job)?;
            job.check()?;
            job.send(JobOutput::Analysis(Box::new(a)));
            Ok(())
        });
    }

    fn absorb(&mut self, ev: Event) {
        match ev {
            Event::Output(JobOutput::Signal { entry, replace, select }) => {
                let name = entry.signal.name.clone();
                if let Some(p) = &entry.file {
                    self.settings.remember(p);
                }
                let pos = replace.and_then(|id| self.session.signals.iter().position(|s| s.id == id));
                let i = match pos {
                    Some(i) => {
                        self.session.signals[i] = *entry;
                        i
                    }
                    None => {
                        self.session.signals.push(*entry);
                        self.session.signals.len() - 1
                    }
                };
                if select || self.session.selected.is_none() {
                    self.session.selected = Some(i);
                }
                self.session.tell(Level::Info, format!("loaded {name}"));
            }
            Event::Output(JobOutput::Analysis(a)) => {
                self.session.tell(Level::Info, format!("chain {} on {} took {:.2} s", a.chain.name, a.signal_name, a.seconds));
                self.session.analysis = Some(*a);
            }
            Event::Output(JobOutput::Comparison(c)) => {
                self.session.tell(Level::Info, format!("compared {} with {}: envelope NRMSE {:.1} %", c.measured, c.simulated, c.comparison.envelope_nrmse()));
                self.session.comparison = Some(*c);
            }
            Event::Output(JobOutput::Chain(c, from)) => {
                self.session.replace_chain(c);
                self.session.tell(Level::Info, format!("chain read from {from}"));
            }
            Event::Output(JobOutput::Picked(purpose, p)) => {
                self.settings.last_dir = p.parent().map(Path::to_path_buf);
                match purpose {
                    Purpose::OpenSignal => self.execute(Command::OpenSignal(p)),
                    Purpose::OpenChain => self.execute(Command::OpenChain(p)),
                    Purpose::SaveChain => self.execute(Command::SaveChain(p)),
                }
            }
            Event::Output(JobOutput::Info(s)) => self.session.tell(Level::Info, s),
            Event::Finished(Ok(_)) => {}
            Event::Finished(Err((label, e))) => {
                let level = if e == "cancelled" { Level::Info } else { Level::Error };
                self.session.tell(level, format!("{label}: {e}"));
            }
        }
    }

    /// One frame of the workbench inside `ui` (the eframe app and the tests call this).
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        self.worker.set_context(ui.ctx());
        self.start_work();
        for ev in self.worker.poll(Duration::from_millis(8)) {
            self.absorb(ev);
        }
        let dropped: Vec<PathBuf> = ui.ctx().input(|i| i.raw.dropped_files.iter().map(|f| f.path().to_path_buf()).filter(|p| !p.as_os_str().is_empty()).collect());
        for p in dropped {
            self.execute(Command::OpenSignal(p));
        }
        let mut commands: Vec<Command> = Vec::new();
        egui::Panel::top("top").show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.heading("twinscope");
                ui.separator();
                for (i, v) in self.views.iter().enumerate() {
                    if ui.selectable_label(self.active == i, v.title()).clicked() {
                        self.active = i;
                    }
                }
                ui.separator();
                egui::ComboBox::from_label("machine").selected_text(&self.settings.machine_preset).show_ui(ui, |ui| {
                    for (name, _) in crate::model::PRESETS {
                        ui.selectable_value(&mut self.settings.machine_preset, name.to_string(), name);
                    }
                });
                if ui.button("Simulate").on_hover_text("simulate the machine preset and list it beside the measured signals").clicked() {
                    commands.push(Command::Simulate(self.settings.machine_preset.clone()));
                }
            });
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status_ui(ui, &mut commands));
        egui::Panel::left("signals").default_size(270.0).size_range(200.0..=420.0).show(ui, |ui| {
            egui::ScrollArea::vertical().id_salt("signals-scroll").show(ui, |ui| {
                if let Some(c) = self.signals.ui(ui, &self.session, &self.settings) {
                    commands.push(c);
                }
            });
        });
        egui::Panel::right("chain").default_size(300.0).size_range(220.0..=480.0).show(ui, |ui| {
            if let Some(c) = self.chain.ui(ui, &self.session, &self.settings) {
                commands.push(c);
            }
        });
        egui::CentralPanel::default_margins().show(ui, |ui| {
            if let Some(v) = self.views.get_mut(self.active) {
                if let Some(c) = v.ui(ui, &self.session, &self.settings) {
                    commands.push(c);
                }
            }
        });
        for c in commands {
            self.execute(c);
        }
        if self.worker.busy() {
            ui.ctx().request_repaint_after(Duration::from_millis(100));
        }
    }

    fn status_ui(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
        for j in self.worker.jobs() {
            ui.horizontal(|ui| {
                match j.progress() {
                    Some(p) => {
                        ui.add(egui::ProgressBar::new(p).desired_width(220.0).show_percentage());
                    }
                    None => {
                        ui.spinner();
                    }
                }
                let step = j.step();
                ui.label(if step.is_empty() { j.label.clone() } else { format!("{} — {step}", j.label) });
                ui.weak(format!("{:.1} s", j.started.elapsed().as_secs_f64()));
                if j.is_cancelled() {
                    ui.weak("cancelling…");
                } else if ui.button("Cancel").clicked() {
                    commands.push(Command::Cancel(j.id));
                }
            });
        }
        let shown: Vec<_> = self.session.messages.iter().rev().take(3).cloned().collect();
        if !shown.is_empty() {
            ui.horizontal_top(|ui| {
                if ui.small_button("Clear").clicked() {
                    commands.push(Command::ClearMessages);
                }
                ui.vertical(|ui| {
                    for m in shown.iter().rev() {
                        let text = match m.level {
                            Level::Error => egui::RichText::new(format!("Error: {}", m.text)).color(ui.visuals().error_fg_color),
                            Level::Info => egui::RichText::new(&m.text),
                        };
                        ui.add(egui::Label::new(text).wrap());
                    }
                });
            });
        } else if self.worker.jobs().is_empty() {
            ui.weak("ready");
        }
    }
}

impl eframe::App for Workbench {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        Workbench::ui(self, ui);
    }

    fn on_exit(&mut self, _gl: Option<&eframe::glow::Context>) {
        self.save_settings();
    }
}

/// Opens the workbench window (blocks until it is closed).
pub fn run(opts: StartOptions) -> Result<(), String> {
    let native = eframe::NativeOptions { viewport: egui::ViewportBuilder::default().with_title("twinscope").with_inner_size([1280.0, 800.0]).with_drag_and_drop(true), ..Default::default() };
    eframe::run_native("twinscope", native, Box::new(move |_cc| Ok(Box::new(Workbench::new(opts))))).map_err(|e| e.to_string())
}
