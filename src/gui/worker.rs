//! Background jobs: every piece of heavy work (loading, chains, simulation, comparison, file
//! dialogs) runs on its own thread, reports progress through atomics, can be cancelled, and
//! sends its results through a channel. The UI thread only polls, in a time-boxed loop.

use super::session::JobOutput;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What a job sees of itself: progress, the current step, cancellation, and a way to send
/// partial results (e.g. the demo sends the measured envelope spectrum before it simulates).
#[derive(Clone)]
pub struct JobHandle {
    id: u64,
    progress_bits: Arc<AtomicU64>,
    cancel: Arc<AtomicBool>,
    step: Arc<Mutex<String>>,
    tx: Sender<Message>,
    ctx: Option<egui::Context>,
}

impl JobHandle {
    /// Sets the progress fraction (0–1; NaN = indeterminate).
    pub fn set_progress(&self, fraction: f64) {
        self.progress_bits.store(fraction.to_bits(), Ordering::Relaxed);
        self.repaint();
    }

    /// Names the current step (shown beside the progress bar).
    pub fn set_step(&self, step: impl Into<String>) {
        if let Ok(mut s) = self.step.lock() {
            *s = step.into();
        }
        self.repaint();
    }

    /// True once Cancel was pressed for this job.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// `Err("cancelled")` once Cancel was pressed: use with `?` between steps.
    pub fn check(&self) -> Result<(), String> {
        if self.cancelled() {
            Err("cancelled".into())
        } else {
            Ok(())
        }
    }

    /// Sends a (partial) result to the UI thread.
    pub fn send(&self, output: JobOutput) {
        let _ = self.tx.send(Message::Output(self.id, Box::new(output)));
        self.repaint();
    }

    fn repaint(&self) {
        if let Some(c) = &self.ctx {
            c.request_repaint();
        }
    }
}

enum Message {
    Output(u64, Box<JobOutput>),
    Finished(u64, Result<(), String>),
}

/// A job the UI shows in the status bar.
pub struct RunningJob {
    /// Job id.
    pub id: u64,
    /// What it does, e.g. `chain envelope_cwru on X105_DE_time`.
    pub label: String,
    /// When it started.
    pub started: Instant,
    progress_bits: Arc<AtomicU64>,
    cancel: Arc<AtomicBool>,
    step: Arc<Mutex<String>>,
}

impl RunningJob {
    /// Progress fraction 0–1, or `None` while indeterminate.
    pub fn progress(&self) -> Option<f32> {
        let f = f64::from_bits(self.progress_bits.load(Ordering::Relaxed));
        f.is_finite().then_some(f.clamp(0.0, 1.0) as f32)
    }

    /// The step the job reported last.
    pub fn step(&self) -> String {
        self.step.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// Whether Cancel was pressed.
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// What polling returns.
pub enum Event {
    /// A result (possibly partial) of a job that was not cancelled.
    Output(JobOutput),
    /// A job ended: `Ok(label)` or `Err((label, message))`; cancelled jobs end with
    /// `Err((label, "cancelled"))`.
    Finished(Result<String, (String, String)>),
}

/// The job runner.
pub struct Worker {
    tx: Sender<Message>,
    rx: Receiver<Message>,
    jobs: Vec<RunningJob>,
    next_id: u64,
    ctx: Option<egui::Context>,
}

impl Default for Worker {
    fn default() -> Self {
        let (tx, rx) = channel();
        Self { tx, rx, jobs: Vec::new(), next_id: 1, ctx: None }
    }
}

impl Worker {
    /// Gives the worker the context to wake when a job reports.
    pub fn set_context(&mut self, ctx: &egui::Context) {
        if self.ctx.is_none() {
            self.ctx = Some(ctx.clone());
        }
    }

    /// Starts `work` on a new thread. A panic inside the job is caught and reported as an
    /// error, so a library bug cannot take the workbench down.
    pub fn spawn(&mut self, label: impl Into<String>, work: impl FnOnce(&JobHandle) -> Result<(), String> + Send + 'static) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        let job = RunningJob {
            id,
            label: label.into(),
            started: Instant::now(),
            progress_bits: Arc::new(AtomicU64::new(f64::NAN.to_bits())),
            cancel: Arc::new(AtomicBool::new(false)),
            step: Arc::new(Mutex::new(String::new())),
        };
        let handle = JobHandle { id, progress_bits: job.progress_bits.clone(), cancel: job.cancel.clone(), step: job.step.clone(), tx: self.tx.clone(), ctx: self.ctx.clone() };
        self.jobs.push(job);
        let spawned = std::thread::Builder::new().name(format!("twinscope-job-{id}")).spawn(move || {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&handle)))
                .unwrap_or_else(|p| Err(format!("internal error: {}", p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned()).unwrap_or_else(|| "a job panicked".into()))));
            let _ = handle.tx.send(Message::Finished(handle.id, r));
            handle.repaint();
        });
        if let Err(e) = spawned {
            let _ = self.tx.send(Message::Finished(id, Err(format!("cannot start a thread: {e}"))));
        }
        id
    }

    /// Jobs still running.
    pub fn jobs(&self) -> &[RunningJob] {
        &self.jobs
    }

    /// True while any job runs.
    pub fn busy(&self) -> bool {
        !self.jobs.is_empty()
    }

    /// Asks job `id` to stop; its later results are dropped.
    pub fn cancel(&self, id: u64) {
        if let Some(j) = self.jobs.iter().find(|j| j.id == id) {
            j.cancel.store(true, Ordering::Relaxed);
        }
    }

    /// Takes what the jobs reported, for at most `budget` (the UI stays responsive even when a
    /// job floods the channel).
    pub fn poll(&mut self, budget: Duration) -> Vec<Event> {
        let t0 = Instant::now();
        let mut out = Vec::new();
        while t0.elapsed() < budget {
            let Ok(m) = self.rx.try_recv() else { break };
            match m {
                Message::Output(id, o) => {
                    if self.jobs.iter().any(|j| j.id == id && !j.is_cancelled()) {
                        out.push(Event::Output(*o));
                    }
                }
                Message::Finished(id, r) => {
                    let Some(pos) = self.jobs.iter().position(|j| j.id == id) else { continue };
                    let job = self.jobs.remove(pos);
                    out.push(Event::Finished(match r {
                        _ if job.is_cancelled() => Err((job.label, "cancelled".into())),
                        Ok(()) => Ok(job.label),
                        Err(e) => Err((job.label, e)),
                    }));
                }
            }
        }
        out
    }
}
