//! The workbench: panels around a tabbed central area, a status bar with the running jobs
//! (progress, Cancel) and the messages. It owns the [`Settings`], the [`Session`] and the
//! [`Worker`], and carries out the views' [`Command`]s.

use super::jobs;
use super::session::{JobOutput, Level, ModelState, Purpose, ScfResult, Session};
use super::session_file::SessionFile;
use super::settings::Settings;
use super::views::{chain::ChainPanel, compare::CompareView, filter::FilterView, model_loop::ModelLoopView, scf::ScfView, signals::SignalsPanel, spectra::SpectraView, time::TimeView, Command, View};
use super::worker::{Event, Worker};
use crate::chain::Data;
use crate::compare::Round;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::time::Duration;

/// How the workbench starts.
#[derive(Debug, Clone, Default)]
pub struct StartOptions {
    /// Load the bundled demo (CWRU 105 + envelope chain + simulated model, compared).
    pub demo: bool,
    /// Files to open at start.
    pub files: Vec<PathBuf>,
    /// The tab to show first (`spectra`/`envelope`, `time`, `filter`, `compare`, `scf`, `model`).
    pub tab: Option<String>,
    /// Once the start work is done, run "Find missing effect" once (against the first measured
    /// signal, with the settings' search options): for screenshots and demonstrations.
    pub find_missing_effect: bool,
    /// Once the start work (and the search, if asked) is done, save the window as PNG here.
    pub export_png: Option<PathBuf>,
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
    /// Run "Find missing effect" once the start work is done.
    pending_loop: bool,
    /// A PNG export waiting for the next frame's context.
    pending_png: Option<PathBuf>,
    /// A PNG export to do once the start work is done.
    start_png: Option<PathBuf>,
    /// Results of PNG exports, written from the screenshot callback.
    png_tx: Sender<Result<String, String>>,
    png_rx: Receiver<Result<String, String>>,
}

/// Index of a tab by a name given on the command line.
pub fn tab_index(name: &str) -> Option<usize> {
    match name.to_ascii_lowercase().as_str() {
        "spectra" | "spectrum" | "envelope" | "psd" => Some(0),
        "time" => Some(1),
        "filter" | "fir" => Some(2),
        "compare" => Some(3),
        "scf" | "scf3d" | "cyclic" => Some(4),
        "model" | "loop" | "model_loop" | "model-loop" => Some(5),
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
        let preset = if opts.demo { jobs::DEMO_MACHINE.to_string() } else { settings.machine_preset.clone() };
        let (model, model_problem) = match ModelState::from_preset(&preset) {
            Ok(m) => (m, None),
            Err(e) => (ModelState::from_preset(jobs::DEMO_MACHINE).expect("the bundled demo machine preset is valid (tested)"), Some(format!("machine preset {preset}: {e}; using {}", jobs::DEMO_MACHINE))),
        };
        let mut session = Session::new(chain.unwrap_or_else(|_| crate::chain::Chain { name: "empty".into(), description: String::new(), stages: Vec::new() }), model);
        for p in problem.into_iter().chain(model_problem) {
            session.tell(Level::Error, p);
        }
        let views: Vec<Box<dyn View>> = vec![
            Box::new(SpectraView::default()),
            Box::new(TimeView::default()),
            Box::new(FilterView::default()),
            Box::new(CompareView::default()),
            Box::new(ScfView::default()),
            Box::new(ModelLoopView::default()),
        ];
        let active = opts.tab.as_deref().and_then(tab_index).unwrap_or(0);
        if let Some(t) = opts.tab.as_deref().filter(|t| tab_index(t).is_none()) {
            session.tell(Level::Error, format!("unknown view `{t}`; views: spectra, time, filter, compare, scf, model"));
        }
        let (png_tx, png_rx) = channel();
        Self {
            settings,
            session,
            worker: Worker::default(),
            signals: SignalsPanel::default(),
            chain: ChainPanel::default(),
            views,
            active,
            settings_path: opts.settings_path.clone(),
            pending_loop: opts.find_missing_effect,
            pending_png: None,
            start_png: opts.export_png.clone(),
            start: Some(opts),
            png_tx,
            png_rx,
        }
    }

    /// Titles of the tabs, in order.
    pub fn tab_titles(&self) -> Vec<&'static str> {
        self.views.iter().map(|v| v.title()).collect()
    }

    /// The index of the tab shown.
    pub fn active_tab(&self) -> usize {
        self.active
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
            Command::BandFromKurtogram(i) => {
                let Some(e) = self.session.signals.get(i).cloned() else {
                    return self.session.tell(Level::Error, "choose a measured signal for its kurtogram");
                };
                let opts = jobs::compare_options_for(&self.session.chain);
                let resonances_hz = self.session.model.machine.structural_resonances_hz();
                let model_fs_hz = self.session.model.machine.fs_hz;
                self.worker.spawn(format!("kurtogram of {}", e.signal.name), move |job| {
                    job.set_step("spectral kurtosis at 13 frame lengths");
                    // At the model's rate at most, as the loop compares: the band must be one the model holds.
                    let at_rate = crate::compare::at_most_rate(&e.signal, model_fs_hz).map_err(|err| err.to_string())?;
                    let best = crate::compare::demodulation_band::demodulation_band(&at_rate, &opts, &resonances_hz).map_err(|err| err.to_string())?.band;
                    job.check()?;
                    job.send(JobOutput::DemodulationBand(e.signal.name.clone(), best));
                    Ok(())
                });
            }
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
            Command::LoadMachinePreset(name) => match ModelState::from_preset(&name) {
                Ok(m) => {
                    let cleared = self.session.model.start_again(m);
                    self.settings.machine_preset = name.clone();
                    self.session.tell(Level::Info, format!("machine preset {name} loaded; the history of rounds ({cleared} rounds) was cleared"));
                }
                Err(e) => self.session.tell(Level::Error, e),
            },
            Command::OpenMachine(p) => match jobs::read_machine(&p).and_then(|m| crate::compare::calibrate::check_refit_effects(&m, &m.fitted_effects).map(|()| m).map_err(|e| format!("{}: fitted_effects: {e}", p.display()))) {
                Ok(machine) => {
                    let label = p.file_name().map_or_else(|| p.display().to_string(), |f| f.to_string_lossy().into_owned());
                    let names = |ks: Vec<crate::model::EffectKind>| ks.into_iter().map(|k| k.name()).collect::<Vec<_>>().join(", ");
                    let hint = match (machine.fitted_effects.is_empty(), crate::compare::calibrate::refittable_effects(&machine)) {
                        (false, _) => format!("; its fitted_effects ({}) are ticked \"re-fit\": every search's calibration fits them again", names(machine.fitted_effects.clone())),
                        (true, on) if !on.is_empty() => format!("; it has {} on: tick \"re-fit\" beside those a loop applied, so that the calibration fits them again (as `diagnose --refit`)", names(on)),
                        _ => String::new(),
                    };
                    let cleared = self.session.model.start_again(ModelState::of_machine(&label, machine));
                    self.session.tell(Level::Info, format!("machine read from {}; the history of rounds ({cleared} rounds) was cleared{hint}", p.display()));
                }
                Err(e) => self.session.tell(Level::Error, format!("machine not changed: {e}")),
            },
            Command::SaveMachine(p) => match jobs::write_machine(&self.session.model.machine_to_save(), &p) {
                Ok(()) => self.session.tell(Level::Info, format!("machine written to {}", p.display())),
                Err(e) => self.session.tell(Level::Error, e),
            },
            Command::SetRefit { effect, refit } => {
                let model = &mut self.session.model;
                model.refit_given.retain(|k| *k != effect);
                if refit {
                    match crate::compare::calibrate::check_refit_effects(&model.machine, &[effect]) {
                        Ok(()) => model.refit_given.push(effect),
                        Err(e) => self.session.tell(Level::Error, format!("not re-fitted: {e}")),
                    }
                }
            }
            Command::SetMachine(m) => match m.validate() {
                Ok(()) => self.session.model.machine = *m,
                Err(e) => self.session.tell(Level::Error, format!("machine not changed: {e}")),
            },
            Command::UseCalibrated => {
                if let Some(r) = &self.session.model.result {
                    let cal = r.calibrated.clone();
                    self.session.model.replace_machine(cal);
                    self.session.tell(Level::Info, "the calibrated parameters are now the machine's");
                }
            }
            Command::SimulateModel { measured } => self.simulate_model(measured),
            Command::FindMissingEffect { measured } => self.find_missing_effect(measured),
            Command::AddTrial { effect, trial, measured } => self.add_trial(effect, trial, measured),
            Command::ReplaceEffect { remove, add, measured } => self.replace_effect(remove, add, measured),
            Command::RefitEffect { effect, measured } => self.refit_effect(effect, measured),
            Command::ComputeScf { source, params } => self.compute_scf(source, params),
            Command::Dialog(purpose) => self.dialog(purpose),
            Command::SaveSession(p) => match SessionFile::from_session(&self.session).save(&p) {
                Ok(()) => self.session.tell(Level::Info, format!("session saved to {}", p.display())),
                Err(e) => self.session.tell(Level::Error, e),
            },
            Command::OpenSession(p) => {
                self.worker.spawn(format!("reading session {}", p.display()), move |job| {
                    let f = SessionFile::load(&p)?;
                    job.send(JobOutput::SessionFile(Box::new(f), p));
                    Ok(())
                });
            }
            Command::ExportCsv(p) => match self.views.get(self.active).and_then(|v| v.plot_data(&self.session, &self.settings)) {
                Some(d) => match std::fs::write(&p, crate::signal::export::to_csv(&d)) {
                    Ok(()) => self.session.tell(Level::Info, format!("{} written to {} ({} series)", d.title, p.display(), d.series.len())),
                    Err(e) => self.session.tell(Level::Error, format!("{}: cannot write ({e})", p.display())),
                },
                None => self.session.tell(Level::Error, format!("the {} view shows no data to export yet", self.views.get(self.active).map(|v| v.title()).unwrap_or("?"))),
            },
            Command::ExportSvg(p) => {
                let title = self.views.get(self.active).map(|v| v.title()).unwrap_or("?");
                match self.views.get(self.active).and_then(|v| v.plot_data(&self.session, &self.settings)) {
                    Some(d) if d.series.len() > 12 => self.session.tell(Level::Error, format!("SVG export draws line plots; the {title} view shows a map ({} rows): export it as PNG or CSV, or switch to α-slices", d.series.len())),
                    Some(d) => match std::fs::write(&p, crate::signal::export::to_svg(&d, 900, 500)) {
                        Ok(()) => self.session.tell(Level::Info, format!("{} drawn to {}", d.title, p.display())),
                        Err(e) => self.session.tell(Level::Error, format!("{}: cannot write ({e})", p.display())),
                    },
                    None => self.session.tell(Level::Error, format!("the {title} view shows no data to export yet")),
                }
            }
            Command::ExportPng(p) => self.pending_png = Some(p),
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

    fn measured_entry(&mut self, measured: Option<usize>) -> Option<crate::gui::session::SignalEntry> {
        let e = measured.and_then(|i| self.session.signals.get(i)).filter(|e| e.origin == crate::gui::session::Origin::Measured).cloned();
        if measured.is_some() && e.is_none() {
            self.session.tell(Level::Error, "the chosen measured signal is no longer loaded");
        }
        e
    }

    fn simulate_model(&mut self, measured: Option<usize>) {
        let machine = self.session.model.machine.clone();
        if let Err(e) = machine.validate() {
            self.session.tell(Level::Error, format!("not simulated: {e}"));
            return;
        }
        let meas = self.measured_entry(measured);
        let replace = self.session.model.simulated_id.filter(|id| self.session.signals.iter().any(|s| s.id == *id));
        let id = replace.unwrap_or_else(|| self.session.next_signal_id());
        self.session.model.simulated_id = Some(id);
        let label = self.session.model.preset.clone();
        let mut opts = jobs::compare_options_for(&self.session.chain);
        // The SCF slice at the model's fault frequency, on the measurement's speed axis.
        opts.fault_frequency_hz = meas.as_ref().and_then(|m| crate::compare::diagnose::fault_frequency_hz(&machine, &m.signal));
        self.worker.spawn(format!("simulating {label} ({} s)", machine.duration_s), move |job| {
            let sim = jobs::simulate_machine(id, &machine, &label, job)?;
            job.send(JobOutput::Signal { entry: Box::new(sim.clone()), replace, select: false });
            job.check()?;
            if let Some(m) = meas {
                job.set_step("comparing model and measurement");
                job.set_progress(f64::NAN);
                let r = jobs::compare_signals(&m, &sim, &opts)?;
                job.check()?;
                job.send(JobOutput::Comparison(Box::new(r)));
            }
            Ok(())
        });
    }

    /// The options of the model loop's next search of `machine`: the settings, the effects added
    /// in earlier rounds re-fitted by the calibration (as `run_loop` does), the effects taken
    /// out by replacements left out. None (and the user told) when the settings are invalid.
    fn search_options(&mut self, machine: &crate::model::Machine) -> Option<crate::compare::LoopOptions> {
        let mut opts = self.settings.loop_options(jobs::compare_options_for(&self.session.chain));
        opts.refit_effects = self.session.model.refit_effects();
        crate::compare::diagnose::exclude_candidates(&mut opts, machine, &self.session.model.taken_out());
        if let Err(e) = opts.validate() {
            self.session.tell(Level::Error, format!("model loop settings: {e}"));
            return None;
        }
        Some(opts)
    }

    fn find_missing_effect(&mut self, measured: usize) {
        let Some(meas) = self.measured_entry(Some(measured)) else { return };
        let machine = self.session.model.machine.clone();
        let Some(opts) = self.search_options(&machine) else { return };
        let n = if opts.candidates.is_empty() { "every missing effect".to_string() } else { format!("{} candidate effects", opts.candidates.len()) };
        self.worker.spawn(format!("find missing effect: {} against {} ({n})", machine.name, meas.signal.name), move |job| {
            let r = jobs::find_missing_effect(&machine, &meas, &opts, job)?;
            job.send(JobOutput::Loop(Box::new(r)));
            Ok(())
        });
    }

    /// The loop's replacement step, by hand: `add` in place of `remove` in the calibrated
    /// machine of the last search, then a new search, judged by the loop's rule when it
    /// comes back ([`ModelState::take_result`]).
    fn replace_effect(&mut self, remove: crate::model::EffectKind, add: crate::model::EffectKind, measured: usize) {
        if let Err(e) = self.session.model.start_replacement(remove, add) {
            self.session.tell(Level::Error, e);
            return;
        }
        self.session.tell(Level::Info, format!("{} in place of {}: searching the new model; it is kept if it reaches below the stuck model by more than the seed scatter", add.name(), remove.name()));
        self.find_missing_effect(measured);
    }

    /// The loop's re-fit step, by hand: the applied `effect` fitted anew from the uncalibrated
    /// values on the worker, the result searched, and the answer judged as a replacement
    /// ([`ModelState::take_result`]).
    fn refit_effect(&mut self, effect: crate::model::EffectKind, measured: usize) {
        let Some(meas) = self.measured_entry(Some(measured)) else { return };
        let Some(opts) = self.search_options(&self.session.model.machine.clone()) else { return };
        let (stuck, start) = match self.session.model.start_refit(effect) {
            Ok(x) => x,
            Err(e) => {
                self.session.tell(Level::Error, e);
                return;
            }
        };
        self.session.tell(Level::Info, format!("re-fitting {} from the uncalibrated values, then searching; kept if it reaches below the stuck model by more than the seed scatter", effect.name()));
        self.worker.spawn(format!("re-fit {} and find missing effect against {}", effect.name(), meas.signal.name), move |job| {
            let r = jobs::refit_and_search(&stuck, &start, effect, &meas, &opts, job)?;
            job.send(JobOutput::Loop(Box::new(r)));
            Ok(())
        });
    }

    fn add_trial(&mut self, effect: crate::model::EffectKind, trial: usize, measured: Option<usize>) {
        let Some(r) = self.session.model.result.as_mut() else {
            self.session.tell(Level::Error, "no ranking yet: run Find missing effect first");
            return;
        };
        // The ranking's entry clicked: a joint trial and the single trial of its effect share it.
        let Some(t) = r.diagnosis.trials.get(trial).filter(|t| t.effect == effect).cloned() else {
            self.session.tell(Level::Error, format!("{} is not in the ranking", effect.name()));
            return;
        };
        let mut m = r.calibrated.clone();
        crate::compare::apply_trial(&mut m, &t);
        if let Err(e) = m.validate() {
            self.session.tell(Level::Error, format!("{} not added: {e}", effect.name()));
            return;
        }
        r.added.push(effect);
        let model = &mut self.session.model;
        let n = model.history.len();
        if let Some(last) = model.history.last_mut() {
            last.applied = Some(effect);
            last.applied_with = t.with_effect;
            last.applied_jointly = t.joint;
            last.applied_values = crate::compare::diagnose::applied_values(&m, effect, t.with_effect);
        }
        model.history.push(Round {
            round: n + 1,
            effects_on: m.effects.enabled(),
            domains: t.domains.iter().map(|(d, _, after)| (d.clone(), f64::NAN, *after)).collect(),
            envelope_nrmse: t.envelope_nrmse_after,
            objective: t.objective_after,
            verdict: format!("after adding {} (the trial's fit; Find missing effect again recalibrates)", t.label()),
            ..Default::default()
        });
        model.replace_machine(m);
        self.session.tell(Level::Info, format!("{} added: envelope NRMSE {:.1} -> {:.1} % in the trial; simulating the new model", t.label(), t.envelope_nrmse_before, t.envelope_nrmse_after));
        self.simulate_model(measured);
    }

    fn compute_scf(&mut self, source: String, params: crate::dsp::scf::ScfParams) {
        let Some(entry) = self.session.selected_signal().cloned() else {
            self.session.tell(Level::Error, "select a signal first");
            return;
        };
        let signal = if source == "raw" {
            entry.signal.clone()
        } else {
            match self.session.analysis.as_ref().filter(|a| a.signal_id == entry.id).and_then(|a| a.result.get(&source)) {
                Some(Data::Time(s)) => s.clone(),
                _ => {
                    self.session.tell(Level::Error, format!("stage `{source}` of the last chain run is not a time signal of the selected signal"));
                    return;
                }
            }
        };
        let label = if source == "raw" { "raw".to_string() } else { format!("stage {source}") };
        self.worker.spawn(format!("SCF of {}", signal.name), move |job| {
            let r = jobs::compute_scf(&entry, &signal, &label, &params, job)?;
            job.check()?;
            job.send(JobOutput::Scf(Box::new(r)));
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
                if let Some(st) = a.result.stages.iter().rev().find(|s| matches!(s.data, Data::Scf(_))) {
                    if let Data::Scf(map) = &st.data {
                        let unit = a.result.stages.iter().rev().find_map(|s| match &s.data {
                            Data::Time(t) => Some(t.unit.clone()),
                            _ => None,
                        });
                        self.session.scf = Some(ScfResult {
                            signal_name: a.signal_name.clone(),
                            source: format!("stage {} of chain {}", st.name, a.chain.name),
                            unit: unit.unwrap_or_default(),
                            map: map.clone(),
                            families: a.families.clone(),
                            shaft_speed_hz: a.shaft_speed_hz,
                            seconds: a.seconds,
                        });
                    }
                }
                self.session.analysis = Some(*a);
            }
            Event::Output(JobOutput::Scf(r)) => {
                self.session.tell(Level::Info, format!("SCF of {} ({}): {} × {} (α × f) in {:.2} s", r.signal_name, r.source, r.map.n_alpha(), r.map.n_frequency(), r.seconds));
                self.session.scf = Some(*r);
            }
            Event::Output(JobOutput::Loop(r)) => {
                for (level, text) in self.session.model.take_result(*r) {
                    self.session.tell(level, text);
                }
            }
            Event::Output(JobOutput::SessionFile(f, from)) => self.restore(*f, &from),
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
                    Purpose::SaveSession => self.execute(Command::SaveSession(p)),
                    Purpose::OpenSession => self.execute(Command::OpenSession(p)),
                    Purpose::OpenMachine => self.execute(Command::OpenMachine(p)),
                    Purpose::SaveMachine => self.execute(Command::SaveMachine(p)),
                    Purpose::ExportCsv => self.execute(Command::ExportCsv(p)),
                    Purpose::ExportSvg => self.execute(Command::ExportSvg(p)),
                    Purpose::ExportPng => self.execute(Command::ExportPng(p)),
                }
            }
            Event::Output(JobOutput::Info(s)) => self.session.tell(Level::Info, s),
            Event::Output(JobOutput::DemodulationBand(name, b)) => {
                let mut chain = self.session.chain.clone();
                let Some((stage, spec)) = chain.stages.iter_mut().find_map(|s| match &mut s.op {
                    crate::chain::Op::Bandpass(spec) => Some((s.name.clone(), spec)),
                    _ => None,
                }) else {
                    return self.session.tell(Level::Error, format!("the kurtogram of {name} chose {:.0}–{:.0} Hz, but the chain has no bandpass stage to set: add one (or load the `envelope` chain)", b.band_hz[0], b.band_hz[1]));
                };
                spec.pass_band_hz = b.band_hz;
                self.session.replace_chain(chain);
                self.session.tell(Level::Info, format!("demodulation band {:.0}–{:.0} Hz from the kurtogram of {name} (spectral kurtosis {:.2}, frames of {} samples): the chain's bandpass stage `{stage}` now passes it; compare or run the chain again", b.band_hz[0], b.band_hz[1], b.sk, b.nperseg));
            }
            Event::Finished(Ok(_)) => {}
            Event::Finished(Err((label, e))) => {
                let level = if e == "cancelled" { Level::Info } else { Level::Error };
                self.session.tell(level, format!("{label}: {e}"));
            }
        }
    }

    /// Applies a session file read back: the chain, the machine and its history at once; the
    /// measured signals are read again on workers (with their metadata edits). What was loaded
    /// before is replaced.
    fn restore(&mut self, f: SessionFile, from: &Path) {
        let chain = match crate::chain::Chain::from_toml(&f.chain_toml, &format!("{} (chain_toml)", from.display())) {
            Ok(c) => c,
            Err(e) => return self.session.tell(Level::Error, e.to_string()),
        };
        let machine = match crate::model::Machine::from_toml(&f.machine_toml, &format!("{} (machine_toml)", from.display())) {
            Ok(m) => m,
            Err(e) => return self.session.tell(Level::Error, e.to_string()),
        };
        self.session.signals.clear();
        self.session.selected = None;
        self.session.analysis = None;
        self.session.comparison = None;
        self.session.scf = None;
        self.session.replace_chain(chain);
        let model = &mut self.session.model;
        model.preset = f.machine_preset.clone();
        model.replace_machine(machine);
        model.history = f.history.clone();
        model.refit_given = f.refit.clone();
        // A machine_toml that names fitted_effects (a file edited by hand): its boxes ticked.
        for k in std::mem::take(&mut model.machine.fitted_effects) {
            if !model.refit_given.contains(&k) {
                model.refit_given.push(k);
            }
        }
        model.result = None;
        model.simulated_id = None;
        model.pending_replacement = None;
        model.refused_replacements.clear();
        // The file keeps no start of its history: a re-fit by hand then starts from the preset.
        model.loop_start = None;
        let ids: Vec<u64> = f.signals.iter().map(|_| self.session.next_signal_id()).collect();
        let saved = f.signals.clone();
        let selected = f.selected;
        let n = saved.len();
        self.worker.spawn(format!("reading the {n} signals of the session"), move |job| {
            // One job, in order, so the signals keep their saved order.
            let mut errors = Vec::new();
            for (k, (s, id)) in saved.iter().zip(ids).enumerate() {
                job.set_progress(k as f64 / n.max(1) as f64);
                job.check()?;
                match jobs::load_saved(id, s) {
                    Ok(e) => job.send(JobOutput::Signal { entry: Box::new(e), replace: None, select: selected == Some(k) }),
                    Err(e) => errors.push(e),
                }
            }
            if errors.is_empty() {
                Ok(())
            } else {
                Err(errors.join("; "))
            }
        });
        self.session.tell(Level::Info, format!("session {} reopened: {n} signals, chain {}, machine {}, {} rounds", from.display(), self.session.chain.name, self.session.model.machine.name, self.session.model.history.len()));
        let r = &f.results;
        let mut saved: Vec<String> = Vec::new();
        saved.extend(r.analysis.iter().map(|a| format!("{a}, top peak {}", r.peaks.first().map(String::as_str).unwrap_or("-"))));
        saved.extend(r.comparison.clone());
        saved.extend(r.verdict.iter().map(|v| format!("verdict: {v}")));
        if !saved.is_empty() {
            self.session.tell(Level::Info, format!("saved results (not recomputed): {}", saved.join(" · ")));
        }
        self.session.restored_summary = Some(f.results);
    }

    /// One frame of the workbench inside `ui` (the eframe app and the tests call this).
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        self.worker.set_context(ui.ctx());
        self.start_work();
        for ev in self.worker.poll(Duration::from_millis(8)) {
            self.absorb(ev);
        }
        while let Ok(r) = self.png_rx.try_recv() {
            match r {
                Ok(m) => self.session.tell(Level::Info, m),
                Err(e) => self.session.tell(Level::Error, e),
            }
        }
        if let Some(path) = self.pending_png.take() {
            let tx = self.png_tx.clone();
            let ctx = ui.ctx().clone();
            ui.ctx().request_screenshot(move |img| {
                let _ = tx.send(super::export::write_png(&path, &img));
                ctx.request_repaint();
            });
        }
        if self.pending_loop && self.start.is_none() && !self.worker.busy() {
            self.pending_loop = false;
            match self.session.measured_indices().first() {
                Some(&m) => self.execute(Command::FindMissingEffect { measured: m }),
                None => self.session.tell(Level::Error, "find missing effect at start: no measured signal loaded"),
            }
        }
        if self.start_png.is_some() && !self.pending_loop && self.start.is_none() && !self.worker.busy() {
            if let Some(p) = self.start_png.take() {
                self.execute(Command::ExportPng(p));
            }
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
                ui.menu_button("Session", |ui| {
                    if ui.button("Open session…").clicked() {
                        commands.push(Command::Dialog(Purpose::OpenSession));
                    }
                    if ui.button("Save session…").on_hover_text("file paths, channels, metadata edits, chain, machine, rounds and a summary of the results").clicked() {
                        commands.push(Command::Dialog(Purpose::SaveSession));
                    }
                });
                ui.menu_button("Export", |ui| {
                    if ui.button("View as PNG…").clicked() {
                        commands.push(Command::Dialog(Purpose::ExportPng));
                    }
                    if ui.button("Plot as SVG…").clicked() {
                        commands.push(Command::Dialog(Purpose::ExportSvg));
                    }
                    if ui.button("Shown data as CSV…").clicked() {
                        commands.push(Command::Dialog(Purpose::ExportCsv));
                    }
                });
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
        // The chain panel goes with the views that show chain results; the SCF and model-loop
        // views take the width.
        if self.active < 4 {
            egui::Panel::right("chain").default_size(300.0).size_range(220.0..=480.0).show(ui, |ui| {
                if let Some(c) = self.chain.ui(ui, &self.session, &self.settings) {
                    commands.push(c);
                }
            });
        }
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
                            Level::Error => egui::RichText::new(format!("Error: {}", super::views::drawable(&m.text))).color(ui.visuals().error_fg_color),
                            Level::Info => egui::RichText::new(super::views::drawable(&m.text)),
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
