//! Helpers shared by the streaming tests: plans, options, an observer that keeps what it is told.
#![allow(dead_code)]
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Mutex;
use std::time::Duration;

use scratchart_machine::controller::Rezero;
use scratchart_machine::job::Options;
use scratchart_machine::plan::Cut;
use scratchart_machine::program::Program;
use scratchart_machine::stream::Control;
use scratchart_observe::{Observer, Progress};
use scratchart_tool::machine::MachineProfile;

pub fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart_stream_{}_{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `n` cuts spread over a 100 mm plate, in a fixed pseudo-random order.
pub fn cuts(n: usize) -> Vec<Cut> {
    let mut s: u64 = 12345;
    let mut r = move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) * 80.0 - 40.0
    };
    (0..n)
        .map(|k| Cut {
            a: [r(), r()],
            b: [r(), r()],
            z: 0.01 + 0.0001 * k as f64,
            scratch: k,
            bulge: 0.0,
        })
        .collect()
}

/// Writes a plan of `n` cuts for `m` into `dir/name`, returns its path.
pub fn plan(dir: &Path, name: &str, n: usize, m: &MachineProfile) -> PathBuf {
    let g = scratchart_machine::gcode::write(&cuts(n), m, 100.0, &["test plan".into()]);
    let p = dir.join(name);
    std::fs::write(&p, g).unwrap();
    p
}

pub fn options(plan: &Path, port: &str) -> Options {
    Options {
        plan: plan.to_path_buf(),
        port: port.to_string(),
        baud: 115200,
        journal: scratchart_machine::journal::default_path(plan),
        check: false,
        resume: false,
        restart: false,
        rezero: Rezero::Keep,
        profile: None,
        emergency: false,
        detect_timeout: Duration::from_secs(3),
        resume_command: format!("scratchart-cal carve {} --port {port} --resume", plan.display()),
        frame: None,
    }
}

/// [`options`] for `carve --resume` (the journal of the run before).
pub fn resume_options(plan: &Path, port: &str) -> Options {
    Options {
        resume: true,
        ..options(plan, port)
    }
}

/// The cut lines (`G1 X.. Y..`) of a plan, in order.
pub fn cut_lines(plan: &Path) -> Vec<String> {
    let p = Program::load(plan).unwrap();
    // Each block's cut: its first G1 move in X and Y (after the hop and the plunge).
    p.blocks
        .iter()
        .map(|b| b.lines.iter().find(|l| l.starts_with("G1 X")).expect("a cut").clone())
        .collect()
}

/// A progress report as a test keeps it: cuts done of all, the last cut's name, the ETA.
#[derive(Clone, Debug)]
pub struct Seen {
    /// The job's task (`carve`, `frame`, ...).
    pub task: String,
    pub done: usize,
    pub total: usize,
    pub label: String,
    pub eta_s: Option<f64>,
    pub pos: Option<[f64; 3]>,
}

/// Keeps what a job reports: notes and warnings (warnings as `warning: ...`), and progress.
#[derive(Default)]
pub struct Log {
    pub notes: Mutex<Vec<String>>,
    pub progress: Mutex<Vec<Seen>>,
}

impl Observer for Log {
    fn progress(&self, p: &Progress) {
        let m = p.machine.clone().expect("a machine job reports the machine's state");
        self.progress.lock().unwrap().push(Seen {
            task: p.task.to_string(),
            done: p.done as usize,
            total: p.total as usize,
            label: m.label,
            eta_s: m.eta_s,
            pos: m.pos,
        });
    }
    fn info(&self, msg: &str) {
        self.notes.lock().unwrap().push(msg.to_string());
    }
    fn warn(&self, msg: &str) {
        self.notes.lock().unwrap().push(format!("warning: {msg}"));
    }
}

impl Log {
    pub fn says(&self, what: &str) -> bool {
        self.notes.lock().unwrap().iter().any(|n| n.contains(what))
    }

    /// Every position the job reported, with its task.
    pub fn positions(&self) -> Vec<(String, [f64; 3])> {
        let p = self.progress.lock().unwrap();
        p.iter().filter_map(|s| s.pos.map(|q| (s.task.clone(), q))).collect()
    }
}

/// A [`Log`] that asks for Ctrl-C (`control.abort`) at every progress report for which `when`
/// holds.
pub struct AbortWhen<'a, F: Fn(&Progress) -> bool> {
    pub control: &'a Control,
    pub when: F,
    pub log: Log,
}

impl<'a, F: Fn(&Progress) -> bool> AbortWhen<'a, F> {
    pub fn new(control: &'a Control, when: F) -> Self {
        AbortWhen {
            control,
            when,
            log: Log::default(),
        }
    }
}

impl<F: Fn(&Progress) -> bool> Observer for AbortWhen<'_, F> {
    fn progress(&self, p: &Progress) {
        if (self.when)(p) {
            self.control.abort.store(true, Ordering::SeqCst);
        }
        self.log.progress(p);
    }
    fn info(&self, msg: &str) {
        self.log.info(msg);
    }
    fn warn(&self, msg: &str) {
        self.log.warn(msg);
    }
}

/// Every plan cut executed, in plan order, each at least once; returns the most times any was.
pub fn assert_all_cut(plan: &Path, executed: &[String]) -> usize {
    let cuts = cut_lines(plan);
    let mut worst = 0;
    for c in &cuts {
        let k = executed.iter().filter(|e| *e == c).count();
        assert!(k >= 1, "cut `{c}` was never executed");
        worst = worst.max(k);
    }
    // In order: the first execution of each cut follows the one before.
    let firsts: Vec<usize> = cuts
        .iter()
        .map(|c| executed.iter().position(|e| e == c).unwrap())
        .collect();
    assert!(firsts.windows(2).all(|w| w[0] < w[1]), "cuts executed out of order");
    worst
}
