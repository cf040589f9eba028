//! How the libraries talk to a user: they never print. Long jobs report progress and warnings
//! to an [`Observer`] that the binaries implement (a progress bar on a terminal, periodic lines
//! in a log); tests and embedders pass [`Silent`] or their own.

/// Progress of a long job.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress<'a> {
    /// What is running ("design", "prune", ...).
    pub task: &'a str,
    /// Steps done and the total (for `design`: iterations evaluated out of iters + 1).
    pub done: u64,
    pub total: u64,
    /// A short status, e.g. the current loss.
    pub message: String,
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
}

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
