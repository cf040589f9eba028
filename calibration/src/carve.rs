//! `scratchart-cal carve PLAN --port PORT`: streams a plan to a GRBL 1.1 router or a Marlin
//! printer (the firmware is asked, and must be the one the plan names), with a journal beside
//! the plan so `--resume` continues a stopped job. Exit codes: 0 done; 1 the machine stopped the
//! job (the message says what happened and gives the `--resume` command); 2 bad flags; 3 bad
//! plan, profile or journal, or a plan that does not fit the machine; 130 after Ctrl-C, with the
//! machine stopped and the tool raised.
use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Result;
use scratchart_exit::{InputError, UsageError};
use scratchart_machine::controller::Rezero;
use scratchart_machine::job::{carve, Options};
use scratchart_machine::stream::Control;
use scratchart_observe::{Observer, Progress};
use scratchart_tool::machine::MachineProfile;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RezeroArg {
    /// Run the homing cycle ($H; Marlin G28 X Y)
    Home,
    /// Touch the plate with the tool (G38.2) and set Z0 there
    Probe,
    /// Trust the controller's work offset as it is
    Keep,
}

#[derive(clap::Args, Debug)]
pub struct CarveArgs {
    /// The plan (G-code written by `scratchart-cal plan`; its first line names the firmware)
    pub plan: PathBuf,
    /// Serial port of the controller (/dev/ttyUSB0, /dev/ttyACM0, COM3, or a pseudo-terminal's
    /// path); `sim` for a dry run: the whole plan streamed to a built-in simulated controller of
    /// the plan's firmware (GRBL's or Marlin's protocol, at full speed), nothing moves
    #[arg(long)]
    pub port: String,
    /// Baud rate
    #[arg(long, default_value_t = 115200)]
    pub baud: u32,
    /// Ask nothing (there are no questions either when standard input is not a terminal)
    #[arg(long)]
    pub yes: bool,
    /// Run the whole plan in GRBL's check mode ($C) first: every line parsed, nothing moves
    #[arg(long)]
    pub check: bool,
    /// Continue the job recorded in the journal, a few scratches before the last acknowledged one
    #[arg(long, conflicts_with = "restart")]
    pub resume: bool,
    /// Start the plan again from its first cut where the journal records an unfinished job; the
    /// old journal is kept beside the new (PLAN.journal.json.1, .2, ...). Without --resume or
    /// --restart, an unfinished job stops carve before anything is sent
    #[arg(long)]
    pub restart: bool,
    /// With --resume: how to re-establish the position first (default keep)
    #[arg(long, value_enum)]
    pub rezero: Option<RezeroArg>,
    /// The job journal (default: PLAN.journal.json beside the plan)
    #[arg(long)]
    pub journal: Option<PathBuf>,
    /// Machine profile (JSON) to check against the controller's settings ($$, M211)
    #[arg(long)]
    pub machine_file: Option<PathBuf>,
    /// Marlin: Ctrl-C sends M112 (emergency stop: the printer halts where it is and must be
    /// reset) instead of M410 quickstop and a raise
    #[arg(long)]
    pub emergency_stop: bool,
    /// Trace the frame before the first cut, on the same connection: the job's bounding box,
    /// then the plate's outline, at the clearance height (the --machine-file's, else the plan's),
    /// then back to X0 Y0; nothing is cut. It asks before the trace and again before carving
    /// (with --resume: after the re-zero)
    #[arg(long)]
    pub frame: bool,
    /// The frame trace's feed, mm/min
    #[arg(long, default_value_t = scratchart_machine::job::frame::DEFAULT_FEED)]
    pub frame_feed: f64,
}

#[derive(clap::Args, Debug)]
pub struct FrameArgs {
    /// The plan (as for `carve`)
    pub plan: PathBuf,
    /// Serial port of the controller, or `sim` for a dry run
    #[arg(long)]
    pub port: String,
    /// Baud rate
    #[arg(long, default_value_t = 115200)]
    pub baud: u32,
    /// The trace's feed, mm/min
    #[arg(long, default_value_t = scratchart_machine::job::frame::DEFAULT_FEED)]
    pub feed: f64,
    /// Machine profile (JSON): its clearance height is the trace's, and the controller's settings
    /// are checked against it
    #[arg(long)]
    pub machine_file: Option<PathBuf>,
    /// Ask nothing
    #[arg(long)]
    pub yes: bool,
    /// Marlin: Ctrl-C sends M112 instead of M410 quickstop and a raise
    #[arg(long)]
    pub emergency_stop: bool,
}

fn quote(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "/._-+:=,".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// The command that continues this job.
fn resume_command(a: &CarveArgs) -> String {
    let mut c = format!(
        "scratchart-cal carve {} --port {} --resume",
        quote(&a.plan.display().to_string()),
        quote(&a.port)
    );
    if a.baud != 115200 {
        c.push_str(&format!(" --baud {}", a.baud));
    }
    if let Some(j) = &a.journal {
        c.push_str(&format!(" --journal {}", quote(&j.display().to_string())));
    }
    if let Some(m) = &a.machine_file {
        c.push_str(&format!(" --machine-file {}", quote(&m.display().to_string())));
    }
    if a.yes {
        c.push_str(" --yes");
    }
    c
}

/// Progress on a bar (or a line every few seconds in a log), notes on stderr, questions on the
/// terminal.
struct Term {
    out: scratchart::term::Terminal,
    ask: bool,
    answers: Option<Mutex<Receiver<String>>>,
    asking: Arc<AtomicBool>,
}

impl Observer for Term {
    /// "carve: 370/2701 cuts, last scratch 1234 | ETA ...": the cut order and the design's number.
    fn progress(&self, p: &Progress) {
        self.out.progress(p);
    }

    fn finish(&self, task: &str) {
        self.out.finish(task);
    }

    fn warn(&self, msg: &str) {
        self.out.warn(msg);
    }

    fn info(&self, msg: &str) {
        self.out.info(msg);
    }

    fn result(&self, msg: &str) {
        self.out.result(msg);
    }

    fn confirm(&self, question: &str) -> bool {
        let Some(rx) = self.answers.as_ref().filter(|_| self.ask) else {
            return true;
        };
        self.asking.store(true, Ordering::SeqCst);
        eprint!("{question} [y/N] ");
        let _ = std::io::stderr().flush();
        let answer = rx.lock().unwrap().recv().unwrap_or_default();
        self.asking.store(false, Ordering::SeqCst);
        matches!(answer.trim(), "y" | "Y" | "yes" | "Yes")
    }
}

/// Reads the terminal: answers to questions, and keys (each followed by Enter) for hold,
/// resume and abort while the job runs.
fn keys(control: Arc<Control>, asking: Arc<AtomicBool>) -> Receiver<String> {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            if asking.load(Ordering::SeqCst) {
                let _ = tx.send(line);
                continue;
            }
            match line.trim() {
                "!" | "h" => control.hold.store(true, Ordering::SeqCst),
                "~" | "r" => control.resume.store(true, Ordering::SeqCst),
                "a" | "q" => control.abort.store(true, Ordering::SeqCst),
                _ => eprintln!("keys: `!` or `h` hold, `~` or `r` resume, `a` abort (then Enter); Ctrl-C aborts too"),
            }
        }
    });
    rx
}

fn load_profile(path: &Path) -> Result<MachineProfile> {
    // A profile that names no firmware is read over the GRBL one; `carve` checks it against
    // the controller it finds.
    crate::plan_cmd::load_profile(path, scratchart_tool::machine::Firmware::Grbl)
}

pub fn run(a: &CarveArgs) -> Result<()> {
    if a.rezero.is_some() && !a.resume {
        return Err(UsageError("--rezero applies to --resume only".into()).into());
    }
    if a.baud == 0 {
        return Err(UsageError("--baud must be > 0".into()).into());
    }
    let frame = a.frame.then_some(a.frame_feed);
    if a.frame {
        check_feed("--frame-feed", a.frame_feed)?;
    }
    let profile = a.machine_file.as_deref().map(load_profile).transpose()?;
    let opts = Options {
        plan: a.plan.clone(),
        port: a.port.clone(),
        baud: a.baud,
        journal: a
            .journal
            .clone()
            .unwrap_or_else(|| scratchart_machine::journal::default_path(&a.plan)),
        check: a.check,
        resume: a.resume,
        restart: a.restart,
        rezero: match a.rezero.unwrap_or(RezeroArg::Keep) {
            RezeroArg::Home => Rezero::Home,
            RezeroArg::Probe => Rezero::Probe,
            RezeroArg::Keep => Rezero::Keep,
        },
        profile,
        emergency: a.emergency_stop,
        detect_timeout: Duration::from_secs(4),
        resume_command: resume_command(a),
        frame,
    };
    let (control, term) = terminal(a.yes)?;
    let result = carve(&opts, &control, &term);
    term.out.finish("carve");
    match result {
        Ok(s) => {
            if let Some(d) = &s.dry_run {
                println!("{d}");
                return Ok(());
            }
            println!(
                "done: {} scratches of {} carved on {} ({} lines in {:.1} s); journal {}",
                s.total - s.from,
                a.plan.display(),
                if s.controller.is_empty() { "-" } else { &s.controller },
                s.lines,
                s.seconds,
                opts.journal.display()
            );
            Ok(())
        }
        // (its class decides the exit code: `scratchart::exit`)
        Err(e) => Err(e.into()),
    }
}

fn check_feed(name: &str, v: f64) -> Result<()> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(UsageError(format!("{name} must be > 0 mm/min")).into())
    }
}

/// Ctrl-C stops the machine; on a terminal, keys hold and resume and questions are asked
/// (unless `yes`).
fn terminal(yes: bool) -> Result<(Arc<Control>, Term)> {
    let control = Arc::new(Control::default());
    stop_on_ctrl_c(control.clone()).map_err(anyhow::Error::msg)?;
    let tty = std::io::stdin().is_terminal();
    let asking = Arc::new(AtomicBool::new(false));
    let answers = tty.then(|| Mutex::new(keys(control.clone(), asking.clone())));
    if tty {
        eprintln!(
            "while the machine moves: `!` + Enter holds, `~` + Enter resumes, Ctrl-C stops the machine and raises the tool"
        );
    }
    let term = Term {
        out: scratchart::term::Terminal::new(false),
        ask: tty && !yes,
        answers,
        asking,
    };
    Ok((control, term))
}

/// `scratchart-cal frame PLAN --port PORT`: the frame trace alone (nothing is cut).
pub fn frame(a: &FrameArgs) -> Result<()> {
    if a.baud == 0 {
        return Err(UsageError("--baud must be > 0".into()).into());
    }
    check_feed("--feed", a.feed)?;
    let profile = a.machine_file.as_deref().map(load_profile).transpose()?;
    let opts = Options {
        plan: a.plan.clone(),
        port: a.port.clone(),
        baud: a.baud,
        journal: scratchart_machine::journal::default_path(&a.plan),
        check: false,
        resume: false,
        restart: false,
        rezero: Rezero::Keep,
        profile,
        emergency: a.emergency_stop,
        detect_timeout: Duration::from_secs(4),
        resume_command: String::new(),
        frame: Some(a.feed),
    };
    let (control, term) = terminal(a.yes)?;
    let result = scratchart_machine::job::frame::frame(&opts, a.feed, &control, &term);
    term.out.finish("frame");
    let s = result?;
    if let Some(d) = &s.dry_run {
        println!("{d}");
    }
    println!(
        "frame traced on {} ({} lines in {:.1} s); nothing was cut. Carve with: scratchart-cal carve {} --port {}",
        if s.controller.is_empty() { "-" } else { &s.controller },
        s.lines,
        s.seconds,
        quote(&a.plan.display().to_string()),
        quote(&a.port)
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
pub struct ProbeArgs {
    /// Serial port of the controller
    #[arg(long)]
    pub port: String,
    /// Baud rate
    #[arg(long, default_value_t = 115200)]
    pub baud: u32,
    /// Probes along X and Y, as NxM
    #[arg(long, default_value = "5x5")]
    pub grid: String,
    /// Distance of the outer probes from the plate's edges, mm
    #[arg(long, default_value_t = 5.0)]
    pub margin: f64,
    /// Plate side, mm (or give --plan)
    #[arg(long)]
    pub plate: Option<f64>,
    /// A plan whose header gives the plate size
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// Height of the moves between probes, mm above Z0
    #[arg(long, default_value_t = 2.0)]
    pub safe_z: f64,
    /// How far below Z0 each probe searches before it fails, mm
    #[arg(long, default_value_t = 1.0)]
    pub depth: f64,
    /// Probe feed, mm/min
    #[arg(long, default_value_t = 50.0)]
    pub feed: f64,
    /// Output height map (for `plan --heightmap`)
    #[arg(long, default_value = "heightmap.json")]
    pub out: PathBuf,
    /// Ask nothing
    #[arg(long)]
    pub yes: bool,
}

/// `scratchart-cal probe`: the plate's height on a grid, written as `heightmap.json`.
pub fn probe(a: &ProbeArgs) -> Result<()> {
    use scratchart_machine::probe::{parse_grid, probe_grid, ProbeOptions};
    let grid = parse_grid(&a.grid).map_err(UsageError)?;
    let plate = match (a.plate, &a.plan) {
        (Some(p), _) => p,
        (None, Some(plan)) => scratchart_machine::program::Program::load(plan)?
            .plate_mm
            .ok_or_else(|| InputError(format!("{} does not state its plate size", plan.display())))?,
        (None, None) => return Err(UsageError("give the plate size: --plate MM or --plan PLAN".into()).into()),
    };
    for (name, v) in [("--safe-z", a.safe_z), ("--depth", a.depth), ("--feed", a.feed)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(UsageError(format!("{name} must be > 0")).into());
        }
    }
    let (control, term) = terminal(a.yes)?;
    let question = format!(
        "probe {} x {} points on the {plate} mm plate with G38.2? The probe must be wired, X0 Y0 at \
         the plate centre and Z0 near its surface",
        grid.0, grid.1
    );
    if !term.confirm(&question) {
        return Err(anyhow::Error::msg("not started: the answer was no"));
    }
    let o = ProbeOptions {
        port: a.port.clone(),
        baud: a.baud,
        plate_mm: plate,
        grid,
        margin_mm: a.margin,
        safe_z_mm: a.safe_z,
        depth_mm: a.depth,
        feed_mm_min: a.feed,
        detect_timeout: Duration::from_secs(4),
    };
    let result = probe_grid(&o, &control, &term);
    term.out.finish("probe");
    // (its class decides the exit code: `scratchart::exit`)
    let map = result?;
    scratchart_render::io::write_atomic(&a.out, map.to_json().as_bytes())?;
    let (lo, hi) = map.range();
    println!(
        "wrote {}: {} x {} probes, heights {lo:.4} to {hi:.4} mm (use it with `plan --heightmap`)",
        a.out.display(),
        grid.0,
        grid.1
    );
    Ok(())
}

/// Makes Ctrl-C (and SIGTERM where available) ask the running job to stop the machine and raise
/// the tool. Pressing it three times gives up waiting and exits with 130 at once (the machine
/// may then still be moving: use its stop button).
fn stop_on_ctrl_c(control: std::sync::Arc<scratchart_machine::stream::Control>) -> Result<(), String> {
    let presses = std::sync::atomic::AtomicUsize::new(0);
    ctrlc::set_handler(move || {
        let n = presses.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
        control.abort.store(true, std::sync::atomic::Ordering::SeqCst);
        if n == 1 {
            eprintln!("\ninterrupt: stopping the machine and raising the tool (press Ctrl-C twice more to quit without waiting)");
        } else if n >= 3 {
            eprintln!("\nquitting without waiting: the machine may still be moving; use its stop button");
            scratchart_exit::exit_now(scratchart_exit::Class::Interrupted);
        }
    })
    .map_err(|e| format!("cannot install the Ctrl-C handler: {e}"))
}
