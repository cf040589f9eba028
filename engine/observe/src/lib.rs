//! How the libraries talk to a user: they never print. The Vulkan layer, the machine driver, the
//! optimizer, the design job and the tool fit report progress, warnings, notes and results to one
//! [`Observer`] that the binaries implement (a progress bar on a terminal, periodic lines in a
//! log, questions on the terminal); tests and embedders pass [`Silent`], [`Collect`] or their own.
//! It is the lowest crate of the workspace with `scratchart-exit`: it depends on nothing.

/// Progress of a long job.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress<'a> {
    /// What is running ("design", "prune", ...).
    pub task: &'a str,
    /// Steps done and the total (for `design`: iterations evaluated out of iters + 1).
    pub done: u64,
    pub total: u64,
    /// A short status, e.g. the current loss, or a machine's state and place (what
    /// [`MachineState::message`] says).
    pub message: String,
    /// Where a machine is, for a job that drives one (carving, probing); None for other jobs.
    pub machine: Option<MachineState>,
}

impl<'a> Progress<'a> {
    /// Progress of `task`: `done` of `total`, with a short status.
    pub fn new(task: &'a str, done: u64, total: u64, message: impl Into<String>) -> Progress<'a> {
        Progress {
            task,
            done,
            total,
            message: message.into(),
            machine: None,
        }
    }
}

/// A machine's state while it carves or probes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MachineState {
    /// What the last acknowledged cut is, in the design's numbering (`scratch 1234`, `mark +x
    /// edge`); empty where there is none (probing).
    pub label: String,
    /// Estimated seconds left, from this run's pace.
    pub eta_s: Option<f64>,
    /// The machine's state (GRBL's status, or what the sender knows).
    pub state: String,
    /// Work position, mm, when the controller reports it.
    pub pos: Option<[f64; 3]>,
}

impl MachineState {
    /// One line for a progress bar: `cuts, last scratch 1234 | ETA 0:04:05 | Run X1.00 Y2.00 Z-0.050`.
    pub fn message(&self) -> String {
        let mut msg = if self.label.is_empty() {
            String::new()
        } else {
            format!("cuts, last {} | ", self.label)
        };
        msg.push_str(&format!(
            "ETA {} | {}",
            self.eta_s.map_or("?".into(), clock),
            self.state
        ));
        if let Some(q) = self.pos {
            msg.push_str(&format!(" X{:.2} Y{:.2} Z{:.3}", q[0], q[1], q[2]));
        }
        msg
    }
}

/// `h:mm:ss` of a duration in seconds (what a maker reads on a job's ETA and summary).
pub fn clock(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// Receives progress, warnings and notes from the libraries. Every method has a default that
/// does nothing, so an implementation picks what it shows.
pub trait Observer {
    /// A job starts or moves on.
    fn progress(&self, _p: &Progress) {}
    /// The job of `task` is over (clear a bar).
    fn finish(&self, _task: &str) {}
    /// Something the user should know about that does not stop the job (a rolled-back step,
    /// a light below the plate, ...).
    fn warn(&self, _msg: &str) {}
    /// A note about what happens (what was written where).
    fn info(&self, _msg: &str) {}
    /// A line of the job's result (a fit's parameters, its verdict, the files it wrote): what a
    /// binary prints on stdout, where a script reads it.
    fn result(&self, _msg: &str) {}
    /// Whether the user asked the job to stop (Ctrl-C). Long jobs poll it between steps and stop
    /// cleanly: the optimizer writes a checkpoint first.
    fn should_stop(&self) -> bool {
        false
    }
    /// Asks the user a yes/no question before something that cannot be undone (the first motion
    /// of a machine). The default answers yes: an observer that cannot ask (a log, a test, `--yes`)
    /// lets the job go on.
    fn confirm(&self, _question: &str) -> bool {
        true
    }
}

/// An observer shared across threads (the Vulkan layer's validation callback runs on any).
pub type SharedObserver = std::sync::Arc<dyn Observer + Send + Sync>;

/// Shows nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Observer for Silent {}

/// Collects warnings and notes (for tests).
#[derive(Debug, Default)]
pub struct Collect {
    pub warnings: std::sync::Mutex<Vec<String>>,
    pub notes: std::sync::Mutex<Vec<String>>,
}

impl Observer for Collect {
    fn warn(&self, msg: &str) {
        self.warnings.lock().unwrap().push(msg.to_string());
    }
    fn info(&self, msg: &str) {
        self.notes.lock().unwrap().push(msg.to_string());
    }
    fn result(&self, msg: &str) {
        self.notes.lock().unwrap().push(msg.to_string());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_machine_state_reads_as_one_line() {
        let m = MachineState {
            label: "scratch 12".into(),
            eta_s: Some(3725.4),
            state: "Run".into(),
            pos: Some([1.0, 2.0, -0.05]),
        };
        assert_eq!(
            m.message(),
            "cuts, last scratch 12 | ETA 1:02:05 | Run X1.00 Y2.00 Z-0.050"
        );
        let probe = MachineState {
            state: "Z 0.0100 at X1.00 Y2.00".into(),
            ..Default::default()
        };
        assert_eq!(probe.message(), "ETA ? | Z 0.0100 at X1.00 Y2.00");
    }

    #[test]
    fn the_default_observer_shows_nothing_and_lets_the_job_go_on() {
        let s = Silent;
        s.warn("x");
        assert!(s.confirm("carve?"));
        assert!(!s.should_stop());
        let c = Collect::default();
        c.warn("w");
        c.info("i");
        assert_eq!(*c.warnings.lock().unwrap(), vec!["w".to_string()]);
        assert_eq!(*c.notes.lock().unwrap(), vec!["i".to_string()]);
    }
}
