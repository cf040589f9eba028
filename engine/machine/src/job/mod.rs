//! A carving job from start to end: read the plan, open the port, ask what answers, refuse a
//! plan for the other firmware or settings that contradict it, re-establish the position on
//! resume, run check mode when asked, stream with the journal, and leave the machine stopped with
//! the tool raised whenever the job ends early.
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use crate::controller::{Controller, Fault, Rezero};
use crate::journal::{Journal, RESUME_OVERLAP};
use crate::planner::Kinematics;
use crate::program::Program;
use scratchart_observe::{clock, MachineState, Observer, Progress};

use crate::stream::{stream, Control, End};

mod dry_run;
pub mod frame;
mod open;
use crate::transport::{Link, LinkError};
use dry_run::{dry_run_note, simulated};
use open::open_journal;
use scratchart_tool::machine::MachineProfile;

#[derive(Clone, Debug)]
pub struct Options {
    pub plan: PathBuf,
    pub port: String,
    pub baud: u32,
    pub journal: PathBuf,
    /// Run the plan in GRBL's check mode (`$C`) first.
    pub check: bool,
    pub resume: bool,
    /// Start again where the journal records an unfinished job, keeping that journal beside
    /// the new one (without it, or `resume`, such a job is refused before anything is sent).
    pub restart: bool,
    pub rezero: Rezero,
    /// The machine profile to check the controller against (`--machine-file`).
    pub profile: Option<MachineProfile>,
    /// Ctrl-C sends Marlin's M112 emergency stop instead of M410.
    pub emergency: bool,
    /// How long firmware detection waits in all.
    pub detect_timeout: Duration,
    /// The command that continues this job, printed when it stops.
    pub resume_command: String,
    /// Trace the frame ([`frame`]) at this feed (mm/min) before the first cut, on the same
    /// connection (`--frame`); `None`: no trace.
    pub frame: Option<f64>,
}

/// Why `carve` failed, with the exit code DECISIONS.md gives it.
#[derive(Debug, Clone, PartialEq)]
pub enum CarveError {
    /// 2: a flag that cannot work.
    Usage(String),
    /// 3: a bad plan, profile or journal, or a plan that does not fit the controller.
    Input(String),
    /// 1: the machine stopped the job or the link was lost; the message has the resume command.
    Stopped(String),
    /// 130: Ctrl-C; the machine is stopped with the tool raised.
    Interrupted(String),
}

impl CarveError {
    pub fn exit_code(&self) -> u8 {
        scratchart_exit::ExitClass::exit_class(self).map_or(1, scratchart_exit::Class::code)
    }
}

impl scratchart_exit::ExitClass for CarveError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        use scratchart_exit::Class;
        Some(match self {
            CarveError::Usage(_) => Class::Usage,
            CarveError::Input(_) => Class::Input,
            CarveError::Stopped(_) => Class::Runtime,
            CarveError::Interrupted(_) => Class::Interrupted,
        })
    }
}

impl std::fmt::Display for CarveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CarveError::Usage(m) | CarveError::Input(m) | CarveError::Stopped(m) | CarveError::Interrupted(m) => {
                f.write_str(m)
            }
        }
    }
}

impl std::error::Error for CarveError {}

/// A controller's fault as the job's error: bad input is 3, the machine's or the link's is 1.
impl From<Fault> for CarveError {
    fn from(f: Fault) -> CarveError {
        match f {
            Fault::Input(m) => CarveError::Input(m),
            Fault::Machine(m) => CarveError::Stopped(m),
        }
    }
}

/// What a finished job did.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    pub controller: String,
    /// A dry run (`--port sim`): what the simulated controller did, for the user.
    pub dry_run: Option<String>,
    /// The block (in plan order) this run started at, and the blocks in the plan.
    pub from: usize,
    pub total: usize,
    pub lines: usize,
    pub seconds: f64,
}

fn feed_of(program: &Program) -> f64 {
    program
        .blocks
        .iter()
        .flat_map(|b| &b.lines)
        .find(|l| l.starts_with("G1 Z"))
        .and_then(|l| l.split_whitespace().find_map(|w| w.strip_prefix('F')?.parse().ok()))
        .unwrap_or(100.0)
}

/// The `--port` of the built-in simulated controller (a dry run).
pub const SIM_PORT: &str = "sim";

/// Runs a carving job; with `--port sim` ([`SIM_PORT`]) a dry run against a simulated
/// controller of the plan's firmware, with its journal in a temporary file (a rehearsal leaves
/// no job to resume).
pub fn carve(opts: &Options, control: &Control, obs: &dyn Observer) -> Result<Summary, CarveError> {
    if opts.port != SIM_PORT {
        return carve_on(opts, control, obs);
    }
    if opts.resume {
        return Err(CarveError::Usage(
            "--port sim is a dry run of the whole plan: it cannot --resume a job".into(),
        ));
    }
    // One per run: dry runs at once in one process (a program's threads, tests) never share it.
    static RUNS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let journal = std::env::temp_dir().join(format!(
        "scratchart-dry-run-{}-{}.journal.json",
        std::process::id(),
        RUNS.fetch_add(1, Ordering::SeqCst)
    ));
    let dry = Options {
        journal: journal.clone(),
        ..opts.clone()
    };
    let result = carve_on(&dry, control, obs);
    let _ = std::fs::remove_file(&journal);
    result
}

/// Runs a carving job on `opts.port` (or the simulated controller).
fn carve_on(opts: &Options, control: &Control, obs: &dyn Observer) -> Result<Summary, CarveError> {
    let program = Program::load(&opts.plan).map_err(|e| CarveError::Input(e.0))?;
    let total = program.blocks.len();
    let Some(mut journal) = open_journal(opts, &program, obs)? else {
        return Ok(Summary {
            dry_run: None,
            controller: String::new(),
            from: total,
            total,
            lines: 0,
            seconds: 0.0,
        });
    };
    let from = if opts.resume { journal.resume_from() } else { 0 };

    let (mut link, mut ctl, sim) = connect(opts, &program, obs)?;
    let stopped = |m: String| CarveError::Stopped(m);
    if opts.check && opts.resume {
        return Err(CarveError::Usage(
            "--check and --resume together: check the plan in a run of its own".into(),
        ));
    }
    ctl.begin(&mut link, opts.resume)?;
    check_position(opts, &mut journal, ctl.as_mut())?;
    let safe_z = program.max_z;
    if opts.check {
        check_run(&mut link, ctl.as_mut(), &program, control, obs)?;
    }
    let timing = job_time(opts, ctl.as_ref(), &program, from, obs);
    // The frame is traced where the position is the job's: before the question for a new job
    // (the maker answers having seen it), after the re-zero for a resumed one (which asks again).
    let tracer = opts.frame.map(|feed| frame::Tracer {
        opts,
        program: &program,
        control,
        obs,
        feed,
        sim: sim.as_ref(),
    });
    if let (Some(t), false) = (&tracer, opts.resume) {
        t.trace(&mut link, ctl.as_mut())?;
    }
    ask_to_start(opts, &program, from, obs)?;
    if opts.resume {
        rezero_for_resume(opts, &mut link, ctl.as_mut(), &mut journal, &program, from, obs)?;
        if let Some(t) = &tracer {
            t.trace(&mut link, ctl.as_mut())?;
            if opts.port != SIM_PORT && !obs.confirm("the frame is traced: go on cutting?") {
                return Err(CarveError::Stopped(format!(
                    "not resumed after the frame trace: the answer was no; to continue: {}",
                    opts.resume_command
                )));
            }
        }
    }

    let lines = program.lines_from(from);
    journal.state = "running".into();
    journal.message.clear();
    journal.save(&opts.journal).map_err(|e| stopped(e.to_string()))?;
    let t0 = Instant::now();
    let mut last_save = Instant::now();
    let mut save_err: Option<String> = None;
    let (end, pending) = {
        let journal = &mut journal;
        let blocks = &program.blocks;
        let jpath = &opts.journal;
        let mut on_block = |b: usize, state: &str, pos: Option<[f64; 3]>| {
            journal.acked(b, blocks[b].scratch);
            if last_save.elapsed() > Duration::from_millis(200) {
                if let Err(e) = journal.save(jpath) {
                    save_err.get_or_insert(e.to_string());
                }
                last_save = Instant::now();
            }
            let elapsed = t0.elapsed().as_secs_f64();
            let eta = eta_s(timing.as_ref().map(|(t, _)| t), from, b, total, elapsed);
            let machine = MachineState {
                label: blocks[b].label.clone(),
                eta_s: Some(eta),
                state: state.to_string(),
                // A dry run outpaces the status polls: the simulated controller's own position.
                pos: sim.as_ref().map(|f| f.pos()).or(pos),
            };
            obs.progress(&Progress {
                task: "carve",
                done: (b + 1) as u64,
                total: total as u64,
                message: machine.message(),
                machine: Some(machine),
            });
        };
        stream(&mut link, ctl.as_mut(), &lines, control, obs, &mut on_block)
    };
    let outcome = outcome(end, pending, &mut link, ctl.as_mut(), &mut journal, opts, safe_z);
    // What this run saw (a reset, an alarm, its own quickstop) stays in the journal for the
    // next resume, with where the machine last stood.
    journal.position_lost = ctl.position_lost();
    journal.machine_pos = ctl.machine_pos().or(journal.machine_pos);
    if let Some(e) = save_err {
        obs.warn(&format!("the journal could not be written: {e}"));
    }
    match outcome {
        None => {
            journal.state = "done".into();
            journal.save(&opts.journal).map_err(|e| stopped(e.to_string()))?;
            let dry_run = sim.map(|fake| dry_run_note(&fake, ctl.as_ref(), timing.as_ref().map(|(t, _)| t), from));
            Ok(Summary {
                dry_run,
                controller: ctl.describe(),
                from,
                total,
                lines: lines.len(),
                seconds: t0.elapsed().as_secs_f64(),
            })
        }
        Some(e) => {
            if journal.state == "running" {
                journal.state = "stopped".into();
            }
            journal.message = e.to_string();
            let _ = journal.save(&opts.journal);
            Err(e)
        }
    }
}

/// The job's time on this machine, by its own rates (the controller's, else the profile's),
/// noted before anything moves; `None` where neither gives rates.
fn job_time(
    opts: &Options,
    ctl: &dyn Controller,
    program: &Program,
    from: usize,
    obs: &dyn Observer,
) -> Option<(crate::program::Timing, String)> {
    let total = program.blocks.len();
    let timing = ctl
        .kinematics()
        .or_else(|| opts.profile.as_ref().map(Kinematics::of_profile))
        .map(|k| (program.timing(&k), k.source));
    match &timing {
        Some((t, source)) => obs.info(&format!(
            "job time on this machine: {} for cuts {} to {total} (by {source}, at the feeds the \
             plan commands{})",
            clock(t.from(from)),
            from + 1,
            program.estimate_min.map_or(String::new(), |m| format!(
                "; the plan's own estimate, for its profile, was {m} min"
            ))
        )),
        None => obs.info(
            "job time: the controller does not report its rates and no --machine-file was given; \
             the progress estimates it from the pace",
        ),
    }
    timing
}

/// Asks the maker to start (or resume) the job; a dry run moves nothing and asks nothing.
fn ask_to_start(opts: &Options, program: &Program, from: usize, obs: &dyn Observer) -> Result<(), CarveError> {
    let total = program.blocks.len();
    let question = if opts.resume {
        format!(
            "resume {} at cut {} of {total} ({}) on {}?",
            opts.plan.display(),
            from + 1,
            program.blocks[from.min(total.saturating_sub(1))].label,
            opts.port
        )
    } else {
        format!(
            "carve {} ({total} scratches) on {}? The work zero must be set: X0 Y0 at the plate \
             centre, Z0 on its surface",
            opts.plan.display(),
            opts.port
        )
    };
    // (a dry run moves nothing: no question)
    if opts.port != SIM_PORT && !obs.confirm(&question) {
        return Err(CarveError::Stopped("not started: the answer was no".into()));
    }
    Ok(())
}

/// Before a resumed job: the position re-established as `--rezero` says, and what was done and
/// from which cut the job goes on noted for the maker.
fn rezero_for_resume(
    opts: &Options,
    link: &mut Link,
    ctl: &mut dyn Controller,
    journal: &mut Journal,
    program: &Program,
    from: usize,
    obs: &dyn Observer,
) -> Result<(), Fault> {
    let total = program.blocks.len();
    let did = ctl.rezero(link, opts.rezero, program.max_z, feed_of(program))?;
    obs.info(&format!("re-established the position: {did}"));
    if opts.rezero == Rezero::Keep {
        let cmd = &opts.resume_command;
        let instead = if ctl.can_home() == Some(false) {
            format!(
                "set the work zero by hand over the plate's centre (this machine cannot home) and run: {cmd} \
                 --rezero probe"
            )
        } else {
            format!("run: {cmd} --rezero home")
        };
        obs.info(&format!(
            "--rezero keep: no reset, alarm or quickstop was seen since the last acknowledged \
             line, so the controller's work offset is trusted. If the machine lost its position \
             all the same (a power cut while the port was closed), stop now (Ctrl-C) and {instead}"
        ));
    } else {
        journal.position_lost = None;
    }
    obs.info(&format!(
        "resuming at cut {} of {total} ({}; the last acknowledged was cut {}{}; up to \
         {RESUME_OVERLAP} cuts before it are cut again so that none is skipped)",
        from + 1,
        program.blocks[from.min(total.saturating_sub(1))].label,
        journal.last_acked.map_or(0, |k| k + 1),
        journal
            .last_acked_scratch
            .map_or(String::new(), |n| format!(", scratch {n}"))
    ));
    Ok(())
}

/// Seconds left after block `b` of a job run from block `from`, `elapsed` seconds in: the
/// machine's model for what is left scaled by how the job keeps to it, or without a model the
/// pace so far.
fn eta_s(timing: Option<&crate::program::Timing>, from: usize, b: usize, total: usize, elapsed: f64) -> f64 {
    let run = (b + 1 - from) as f64;
    match timing {
        // The machine's model for what is left, scaled by how the job keeps to it.
        Some(t) => {
            let left = t.blocks[b + 1..].iter().sum::<f64>() + t.postamble;
            let done = t.preamble + t.blocks[from..=b].iter().sum::<f64>();
            let pace = if elapsed > 5.0 && done > 0.0 {
                (elapsed / done).clamp(0.2, 5.0)
            } else {
                1.0
            };
            left * pace
        }
        None => elapsed / run * (total - b - 1) as f64,
    }
}

/// Before anything moves: on resume, whether the position was lost since the last acknowledged
/// line (the journal's record, what the controller saw on connecting, a controller back at
/// machine zero), recorded in the journal; `--rezero keep` then stops here. A new job forgets
/// what came before: its maker set the work zero.
fn check_position(opts: &Options, journal: &mut Journal, ctl: &mut dyn Controller) -> Result<(), CarveError> {
    if opts.resume && opts.rezero == Rezero::Home && ctl.can_home() == Some(false) {
        return Err(CarveError::Usage(format!(
            "--rezero home: this machine cannot home ($22=0, no homing cycle), so nothing was sent. \
             Set the work zero by hand (jog the tool over the plate's centre, G10 L20 P1 X0 Y0), then \
             run {} --rezero probe",
            opts.resume_command
        )));
    }
    if opts.resume {
        let lost = journal
            .position_lost
            .clone()
            .or_else(|| ctl.position_lost())
            .or_else(|| reset_to_origin(journal.machine_pos, ctl.machine_pos()));
        if let Some(why) = lost {
            journal.position_lost = Some(why.clone());
            journal.message = why.clone();
            let _ = journal.save(&opts.journal);
            if opts.rezero == Rezero::Keep {
                return Err(CarveError::Stopped(lost_position(&why, ctl, opts)));
            }
        }
    } else {
        ctl.position_set();
    }
    journal.machine_pos = ctl.machine_pos().or(journal.machine_pos);
    Ok(())
}

/// A controller at machine position (0, 0, 0) where the journal last saw it elsewhere: GRBL
/// starts there after a power-up or a reset, so it was reset while the port was closed (or its
/// banner was lost).
fn reset_to_origin(before: Option<[f64; 3]>, now: Option<[f64; 3]>) -> Option<String> {
    let (b, n) = (before?, now?);
    let away = b.iter().any(|v| v.abs() > 0.01);
    let origin = n.iter().all(|v| v.abs() < 1e-4);
    (away && origin).then(|| {
        format!(
            "the controller's machine position is 0, 0, 0, where GRBL starts after a reset or a \
             power-up, but the job last stood at {:.3}, {:.3}, {:.3}",
            b[0], b[1], b[2]
        )
    })
}

/// The refusal of `--rezero keep` after the position was lost: why, and what this machine allows.
fn lost_position(why: &str, ctl: &dyn Controller, opts: &Options) -> String {
    let cmd = &opts.resume_command;
    let allows = match (ctl.firmware(), ctl.can_home()) {
        (scratchart_tool::machine::Firmware::Grbl, Some(false)) => format!(
            "this machine cannot home ($22=0), so nothing restores X and Y by itself: jog the tool \
             over the plate's centre (the plan's X0 Y0) and set the work zero there (G10 L20 P1 X0 \
             Y0), then run {cmd} --rezero probe (it touches the plate and sets Z0)"
        ),
        (scratchart_tool::machine::Firmware::Grbl, _) => format!(
            "run {cmd} --rezero home (homing, $H: the controller's work offset G54 puts the plate \
             back where it was), or set the work zero by hand and run {cmd} --rezero probe"
        ),
        (scratchart_tool::machine::Firmware::Marlin, _) => format!(
            "run {cmd} --rezero home (G28 X Y; where the plate's X0 Y0 was a G92 offset, set it \
             again after homing), or set X0 Y0 by hand and run {cmd} --rezero probe (it touches \
             the plate and sets Z0)"
        ),
    };
    format!(
        "the position is lost: {why}. Resuming with --rezero keep would cut on at the wrong place, \
         so nothing moved (--yes does not change this). To continue: {allows}"
    )
}

/// Opens the port, finds out which controller answers (refusing one of the other firmware than
/// the plan's), and checks its settings against the plan and the machine profile.
/// The link and the controller that answers on it; for a dry run also the simulated controller
/// (kept until the job ends).
type Connected = (Link, Box<dyn Controller>, Option<crate::fake::Fake>);

fn connect(opts: &Options, program: &Program, obs: &dyn Observer) -> Result<Connected, CarveError> {
    let fw = Program::firmware_name(program.firmware);
    let (mut link, sim) = if opts.port == SIM_PORT {
        let (fake, end) = simulated(program, opts.profile.as_ref());
        obs.info(
            "dry run: a simulated controller of the plan's firmware, with the machine profile's \
             travel, rates and accelerations; nothing moves",
        );
        (Link::over(Box::new(end), SIM_PORT), Some(fake))
    } else {
        let link = Link::open(&opts.port, opts.baud).map_err(|e| match e {
            LinkError::Open(m) if !std::path::Path::new(&opts.port).exists() => {
                CarveError::Usage(format!("{m} (no such port: check --port, or --port sim for a dry run)"))
            }
            e => CarveError::Stopped(e.to_string()),
        })?;
        (link, None)
    };
    let stopped = |m: String| CarveError::Stopped(m);
    let mut ctl = crate::detect::detect(&mut link, opts.detect_timeout).map_err(|f| match f {
        Fault::Input(m) | Fault::Machine(m) => stopped(m),
    })?;
    obs.info(&format!("{} answers on {}", ctl.describe(), opts.port));
    if ctl.firmware() != program.firmware {
        let other = Program::firmware_name(ctl.firmware());
        // A calibration card says so in its header; it is made again with `card`, not `plan`.
        let card = std::fs::read_to_string(&opts.plan).is_ok_and(|t| {
            t.lines()
                .take_while(|l| l.starts_with(';'))
                .any(|l| l.starts_with("; calibration card"))
        });
        let again = if card {
            format!("write the card again for it with `scratchart-cal card --out DIR --machine {other}`")
        } else {
            format!("plan it again with `scratchart-cal plan ... --machine {other}`")
        };
        return Err(CarveError::Input(format!(
            "{} was {} for {fw} (its first line), but {} answers on {}: {again}",
            opts.plan.display(),
            if card { "written" } else { "planned" },
            ctl.describe(),
            opts.port,
        )));
    }
    for n in ctl.check_settings(&mut link, program, opts.profile.as_ref())? {
        obs.info(&n);
    }
    Ok((link, ctl, sim))
}

/// What the end of the stream means: None for a finished job (the controller idle), else the
/// error to return, after the stop sequence where the job was aborted or refused (the journal
/// says where it stands and how to resume).
fn outcome(
    end: End,
    pending: usize,
    link: &mut Link,
    ctl: &mut dyn Controller,
    journal: &mut Journal,
    opts: &Options,
    safe_z: f64,
) -> Option<CarveError> {
    let total = journal.total;
    let where_ = |j: &Journal| {
        format!(
            "{} of {total} cuts acknowledged{} (journal {})",
            j.last_acked.map_or(0, |k| k + 1),
            j.last_acked_scratch
                .map_or(String::new(), |n| format!(", the last scratch {n} of the design")),
            opts.journal.display()
        )
    };
    let resume_hint = format!("to continue: {}", opts.resume_command);
    match end {
        End::Done => match ctl.wait_idle(link) {
            Ok(()) => None,
            Err(f) => Some(CarveError::Stopped(format!("at the end of the job: {f}"))),
        },
        End::Abort => {
            let did = ctl
                .stop_and_raise(link, pending, safe_z, opts.emergency)
                .unwrap_or_else(|f| format!("the stop sequence failed: {f}: stop the machine by hand"));
            journal.state = "interrupted".into();
            Some(CarveError::Interrupted(format!(
                "interrupted: {did}; {}; {resume_hint}",
                where_(journal)
            )))
        }
        End::Refused(e) => {
            let did = ctl
                .stop_and_raise(link, pending, safe_z, false)
                .unwrap_or_else(|f| format!("the stop sequence failed ({f}): stop the machine by hand"));
            Some(CarveError::Stopped(format!(
                "{} refused {e}; stopped: {did}; {}; {resume_hint}",
                ctl.describe(),
                where_(journal)
            )))
        }
        End::Stopped(e) => Some(CarveError::Stopped(format!(
            "the machine stopped the job: {e}; the tool may still be down: clear the cause, \
             raise it, then {}; {}; {resume_hint}",
            if ctl.firmware() == scratchart_tool::machine::Firmware::Grbl {
                "unlock ($X) or home ($H)"
            } else {
                "reset the printer"
            },
            where_(journal)
        ))),
        End::Lost(e) => Some(CarveError::Stopped(format!(
            "{e}; {}; reconnect, then {resume_hint}",
            where_(journal)
        ))),
        End::Input(e) => Some(CarveError::Input(e)),
    }
}

/// The whole plan in GRBL's check mode: every line parsed, nothing moves.
fn check_run(
    link: &mut Link,
    ctl: &mut dyn Controller,
    program: &Program,
    control: &Control,
    obs: &dyn Observer,
) -> Result<(), CarveError> {
    let fault = |f: Fault| match f {
        Fault::Input(m) => CarveError::Usage(m),
        Fault::Machine(m) => CarveError::Stopped(m),
    };
    ctl.check_mode(link, true).map_err(fault)?;
    let lines = program.lines_from(0);
    let (end, _) = stream(link, ctl, &lines, control, obs, &mut |_, _, _| {});
    let leave = ctl.check_mode(link, false);
    match end {
        End::Done => {
            leave.map_err(fault)?;
            obs.info(&format!("check mode: all {} lines accepted", lines.len()));
            Ok(())
        }
        End::Refused(e) => Err(CarveError::Stopped(format!(
            "check mode: {} refused {e}; nothing was cut",
            ctl.describe()
        ))),
        End::Abort => {
            control.abort.store(false, Ordering::SeqCst);
            Err(CarveError::Interrupted(
                "interrupted in check mode; nothing was cut".into(),
            ))
        }
        End::Input(e) => Err(CarveError::Input(e)),
        End::Stopped(e) | End::Lost(e) => Err(CarveError::Stopped(format!("check mode: {e}"))),
    }
}
