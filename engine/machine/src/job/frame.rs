//! The frame trace: before a job, the tool traces the job's bounding box and then the plate's
//! outline at the clearance height, and returns to X0 Y0, so the maker sees that the plate sits
//! where the plan expects. It goes through the same sender as the cuts (hold, resume, Ctrl-C),
//! and no line of it goes below the clearance height.
use std::sync::atomic::Ordering;

use scratchart_observe::{MachineState, Observer, Progress};
use scratchart_tool::machine::Firmware;

use super::{CarveError, Options, SIM_PORT};
use crate::controller::Controller;
use crate::program::Program;
use crate::stream::{stream, Control, End};
use crate::transport::Link;

/// The trace's feed where none is given, mm/min: slow enough to watch the tool go round.
pub const DEFAULT_FEED: f64 = 1000.0;

/// The height the trace moves at, mm above Z0: the machine profile's clearance where one was
/// given (`--machine-file`), else the plan's own (its highest Z, where its rapids go).
pub fn clearance(opts: &Options, program: &Program) -> f64 {
    opts.profile.as_ref().map_or(program.max_z, |m| m.clearance_mm)
}

/// What the trace goes round, in order: the job's bounding box, then the plate's outline (where
/// the plan states its plate), then back to X0 Y0. Each is one block of the stream.
pub const PARTS: [&str; 3] = ["the job's bounding box", "the plate's outline", "back to X0 Y0"];

/// The trace's lines, each with the part ([`PARTS`]) it belongs to: the plan's set-up (units,
/// absolute moves, work offset, Marlin's homing where the plan homes) without its spindle
/// commands and its own rise (the plan's clearance), a rise to `clear`, the rectangles at `clear` as feed moves at `feed` mm/min, and the
/// way back to X0 Y0.
pub fn lines(program: &Program, clear: f64, feed: f64) -> Result<Vec<(String, Option<usize>)>, String> {
    if !(clear > 0.0 && clear.is_finite()) {
        return Err(format!(
            "the clearance height is {clear} mm: the trace needs a height above the plate (Z > 0)"
        ));
    }
    if !(feed > 0.0 && feed.is_finite()) {
        return Err(format!("the trace's feed must be > 0 mm/min, not {feed}"));
    }
    let bounds = program
        .xy_bounds()
        .ok_or_else(|| "the plan has no cuts: there is no job to frame".to_string())?;
    let n = |v: f64| format!("{:.4}", v + 0.0);
    let marlin = program.firmware == Firmware::Marlin;
    let mut out: Vec<(String, Option<usize>)> = program
        .preamble
        .iter()
        .filter(|l| !(l.starts_with("M3") || l.starts_with("M4") || l.starts_with("G4") || l.starts_with("G0 Z")))
        .map(|l| (l.clone(), None))
        .collect();
    out.push((
        if marlin {
            format!("G0 Z{} F{}", n(clear), n(feed))
        } else {
            format!("G0 Z{}", n(clear))
        },
        None,
    ));
    let mut rect = |r: [f64; 4], part: usize| {
        let corners = [[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]], [r[0], r[1]]];
        for (k, c) in corners.iter().enumerate() {
            let xy = format!("X{} Y{}", n(c[0]), n(c[1]));
            let line = if k == 0 {
                format!("G1 {xy} Z{} F{}", n(clear), n(feed))
            } else {
                format!("G1 {xy}")
            };
            out.push((line, Some(part)));
        }
    };
    rect(bounds, 0);
    if let Some(p) = program.plate_mm {
        let h = 0.5 * p;
        rect([-h, -h, h, h], 1);
    }
    out.push((format!("G1 X0 Y0 Z{} F{}", n(clear), n(feed)), Some(2)));
    if marlin {
        out.push(("M400".to_string(), Some(2)));
    }
    Ok(out)
}

/// What a frame trace needs beside the connection: the job, its options, the feed.
pub(super) struct Tracer<'a> {
    pub(super) opts: &'a Options,
    pub(super) program: &'a Program,
    pub(super) control: &'a Control,
    pub(super) obs: &'a dyn Observer,
    /// mm/min along the frame
    pub(super) feed: f64,
    /// The simulated controller of a dry run (its own position in the progress).
    pub(super) sim: Option<&'a crate::fake::Fake>,
}

impl Tracer<'_> {
    /// Traces the frame on a connected controller whose position is set (the tool may stand
    /// anywhere; its first move is the rise to the clearance height). Asks first, except on a
    /// dry run. Progress is reported as task `frame`, one step per part. Returns the lines sent.
    pub(super) fn trace(&self, link: &mut Link, ctl: &mut dyn Controller) -> Result<usize, CarveError> {
        let Tracer {
            opts,
            program,
            control,
            obs,
            feed,
            sim,
        } = *self;
        let clear = clearance(opts, program);
        let lines = lines(program, clear, feed).map_err(CarveError::Input)?;
        let b = program.xy_bounds().unwrap_or_default();
        let what = format!(
            "the job's bounding box (X {:.1} to {:.1}, Y {:.1} to {:.1} mm){} at Z{clear:.3} (clearance), \
         at {feed:.0} mm/min, then back to X0 Y0",
            b[0],
            b[2],
            b[1],
            b[3],
            program
                .plate_mm
                .map_or(String::new(), |p| format!(", then the {p} mm plate's outline"))
        );
        if opts.port != SIM_PORT
            && !obs.confirm(&format!(
                "trace {what} on {}? The work zero must be set: X0 Y0 at the plate centre, Z0 on its surface",
                opts.port
            ))
        {
            return Err(CarveError::Stopped("frame not traced: the answer was no".into()));
        }
        obs.info(&format!("frame: tracing {what}"));
        let parts = PARTS.len() as u64;
        let mut on_part = |part: usize, state: &str, pos: Option<[f64; 3]>| {
            let machine = MachineState {
                label: PARTS[part].to_string(),
                eta_s: None,
                state: state.to_string(),
                // A dry run outpaces the status polls: the simulated controller's own position.
                pos: sim.map(|f| f.pos()).or(pos),
            };
            let mut message = format!("parts sent, the last {} | {state}", PARTS[part]);
            if let Some(q) = machine.pos {
                message.push_str(&format!(" X{:.2} Y{:.2} Z{:.3}", q[0], q[1], q[2]));
            }
            obs.progress(&Progress {
                task: "frame",
                done: part as u64 + 1,
                total: parts,
                message,
                machine: Some(machine),
            });
        };
        let (end, pending) = stream(link, ctl, &lines, control, obs, &mut on_part);
        let stop = |ctl: &mut dyn Controller, link: &mut Link| {
            ctl.stop_and_raise(link, pending, clear, opts.emergency)
                .unwrap_or_else(|f| format!("the stop sequence failed ({f}): stop the machine by hand"))
        };
        match end {
            End::Done => ctl
                .wait_idle(link)
                .map(|()| lines.len())
                .map_err(|f| CarveError::Stopped(format!("at the end of the frame trace: {f}"))),
            End::Abort => {
                let did = stop(ctl, link);
                control.abort.store(false, Ordering::SeqCst);
                Err(CarveError::Interrupted(format!(
                    "interrupted while tracing the frame: {did}; nothing was cut"
                )))
            }
            End::Refused(e) => {
                let did = stop(ctl, link);
                Err(CarveError::Stopped(format!(
                    "{} refused {e} while tracing the frame; stopped: {did}; nothing was cut. A soft \
                 limit or a travel error here means the plate, as placed, is outside what the \
                 machine reaches from this work zero",
                    ctl.describe()
                )))
            }
            End::Stopped(e) | End::Lost(e) => Err(CarveError::Stopped(format!(
                "the frame trace stopped: {e}; nothing was cut"
            ))),
            End::Input(e) => Err(CarveError::Input(e)),
        }
    }
}

/// `scratchart-cal frame`: only the trace, on its own connection (the work zero as the maker
/// set it). The summary counts the parts traced.
pub fn frame(opts: &Options, feed: f64, control: &Control, obs: &dyn Observer) -> Result<super::Summary, CarveError> {
    let program = Program::load(&opts.plan).map_err(|e| CarveError::Input(e.0))?;
    let t0 = std::time::Instant::now();
    let (mut link, mut ctl, sim) = super::connect(opts, &program, obs)?;
    ctl.begin(&mut link, false)?;
    ctl.position_set();
    let sent = Tracer {
        opts,
        program: &program,
        control,
        obs,
        feed,
        sim: sim.as_ref(),
    }
    .trace(&mut link, ctl.as_mut())?;
    Ok(super::Summary {
        controller: ctl.describe(),
        dry_run: sim.map(|f| {
            let r = f.record();
            format!(
                "dry run: the simulated {} executed {} motion lines, none below Z{:.3}; it ends at \
                 X{:.3} Y{:.3} Z{:.3}",
                ctl.describe(),
                r.executed.len(),
                lowest_z(&r.executed).unwrap_or(r.pos[2]),
                r.pos[0],
                r.pos[1],
                r.pos[2]
            )
        }),
        from: 0,
        total: PARTS.len(),
        lines: sent,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// The lowest Z that motion lines (absolute, as the trace writes them) command.
pub fn lowest_z(lines: &[String]) -> Option<f64> {
    lines
        .iter()
        .filter_map(|l| {
            l.split_whitespace()
                .find_map(|w| w.strip_prefix('Z')?.parse::<f64>().ok())
        })
        .reduce(f64::min)
}
