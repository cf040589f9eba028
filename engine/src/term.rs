//! The terminal side of [`scratchart_observe::Observer`] for the `scratchart` binary: a progress
//! bar when stderr is a terminal, otherwise a plain progress line every few seconds (so logs and
//! CI show how far a job is); warnings and notes on stderr.
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use scratchart_observe::{Observer, Progress};

/// How often a plain progress line is printed when stderr is not a terminal.
const LOG_EVERY: Duration = Duration::from_secs(5);

/// Set by the first Ctrl-C; a second one exits at once.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C handler: the first press asks the running job to stop cleanly (the
/// optimizer saves a checkpoint), a second exits at once with code 130.
pub fn install_interrupt_handler() {
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted again: exiting without saving");
            scratchart_exit::exit_now(scratchart_exit::Class::Interrupted);
        }
        eprintln!("\ninterrupt: stopping after this iteration and saving a checkpoint (Ctrl-C again to quit at once)");
    });
}

/// The binaries' observer of the Vulkan layer's notices (`ContextDesc::notify`): each on its
/// own line of stderr, warnings as `warning: ...` (quiet: it shows no progress).
pub fn stderr_notices() -> scratchart_observe::SharedObserver {
    std::sync::Arc::new(Terminal::new(true))
}

pub struct Terminal {
    quiet: bool,
    tty: bool,
    bar: Mutex<Option<indicatif::ProgressBar>>,
    last_line: Mutex<Option<Instant>>,
}

impl Terminal {
    /// `quiet`: no progress (warnings still show).
    pub fn new(quiet: bool) -> Terminal {
        Terminal {
            quiet,
            tty: std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
            last_line: Mutex::new(None),
        }
    }
}

impl Terminal {
    /// Prints with `print`, above the progress bar when one is shown.
    fn above_bar(&self, print: impl FnOnce()) {
        match self.bar.lock().unwrap().as_ref() {
            Some(b) => b.suspend(print),
            None => print(),
        }
    }
}

impl Observer for Terminal {
    fn progress(&self, p: &Progress) {
        if self.quiet {
            return;
        }
        if self.tty {
            let mut bar = self.bar.lock().unwrap();
            let b = bar.get_or_insert_with(|| {
                let b = indicatif::ProgressBar::new(p.total);
                b.set_style(
                    indicatif::ProgressStyle::with_template(&format!(
                        "{{spinner}} {} [{{bar:30}}] {{pos}}/{{len}}, {{elapsed}} elapsed, ETA {{eta}} | {{msg}}",
                        p.task
                    ))
                    .expect("a valid template")
                    .progress_chars("=> "),
                );
                b
            });
            b.set_length(p.total);
            b.set_position(p.done);
            b.set_message(p.message.clone());
        } else {
            let mut last = self.last_line.lock().unwrap();
            let due = last.is_none_or(|t| t.elapsed() >= LOG_EVERY) || p.done == p.total;
            if due {
                *last = Some(Instant::now());
                eprintln!("{}: {}/{} {}", p.task, p.done, p.total, p.message);
            }
        }
    }

    fn finish(&self, _task: &str) {
        if let Some(b) = self.bar.lock().unwrap().take() {
            b.finish_and_clear();
        }
        *self.last_line.lock().unwrap() = None;
    }

    fn warn(&self, msg: &str) {
        self.above_bar(|| eprintln!("warning: {msg}"));
    }

    fn info(&self, msg: &str) {
        self.above_bar(|| eprintln!("{msg}"));
    }

    fn result(&self, msg: &str) {
        self.above_bar(|| println!("{msg}"));
    }

    fn should_stop(&self) -> bool {
        INTERRUPTED.load(Ordering::SeqCst)
    }
}
