//! The one machine interface that the streaming engine ([`crate::stream`]) drives, with an
//! implementation per firmware family: [`crate::grbl::Grbl`] and [`crate::marlin::Marlin`].
use std::time::{Duration, Instant};

use crate::planner::Kinematics;
use crate::program::Program;
use crate::transport::{Link, LinkError};
use scratchart_tool::machine::{Firmware, MachineProfile};

/// A line from the controller, as the engine needs to know it.
#[derive(Clone, Debug, PartialEq)]
pub enum Reply {
    /// Answers the oldest unanswered line (GRBL `ok`; Marlin `ok`, also after a rejected line).
    Ok,
    /// The oldest unanswered line was refused and the job must stop (GRBL `error:N`, with the
    /// code's meaning).
    Error(String),
    /// The controller stopped on its own: GRBL `ALARM:N`, Marlin `Error:Printer halted` or
    /// `!!`, an unexpected reset banner.
    Stopped(String),
    /// Marlin asks for the lines from number N again.
    Resend(u64),
    /// A status report: machine state and position.
    Status(Status),
    /// A message worth showing (`[MSG:...]`, `echo:...`).
    Info(String),
    /// Nothing for the engine (temperature reports, `echo:busy: processing`, Marlin's own
    /// transmission errors that a `Resend` follows).
    Ignore,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Status {
    /// GRBL's state (`Idle`, `Run`, `Hold:0`, `Alarm`, ...), or what Marlin last said.
    pub state: String,
    /// Machine or work position (mm) when the report has one.
    pub pos: Option<[f64; 3]>,
}

/// How `carve --resume` re-establishes the position before it cuts again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rezero {
    /// Run the homing cycle (`$H`; Marlin `G28 X Y`): machine position restored, work offsets kept.
    Home,
    /// Touch the plate with the tool (`G38.2`) and set Z0 there.
    Probe,
    /// Trust the controller's work offset as it is (the default).
    Keep,
}

/// Why the job ended early.
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    /// The plan or the machine's settings do not fit each other (exit 3).
    Input(String),
    /// The machine stopped the job or the link was lost (exit 1).
    Machine(String),
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fault::Input(m) | Fault::Machine(m) => f.write_str(m),
        }
    }
}

impl From<LinkError> for Fault {
    fn from(e: LinkError) -> Fault {
        Fault::Machine(e.to_string())
    }
}

/// One firmware family's side of the protocol. The engine owns flow control (the receive-buffer
/// window), the journal, progress and stopping; the controller frames lines, reads replies and
/// knows its own set-up, stop and re-zero sequences.
pub trait Controller {
    fn firmware(&self) -> Firmware;
    /// What the controller said it is (`GRBL 1.1h`, `Marlin 2.1.2`).
    fn describe(&self) -> String;
    /// Bytes the controller's receive buffer holds for unanswered lines (127 of GRBL's 128).
    fn window(&self) -> usize;
    /// Reads the controller's settings and refuses those that contradict the plan or the
    /// machine profile (given with `--machine-file`).
    fn check_settings(
        &mut self,
        link: &mut Link,
        program: &Program,
        profile: Option<&MachineProfile>,
    ) -> Result<Vec<String>, Fault>;
    /// Makes the controller ready to take a job (clears numbering; Marlin `M110 N0`). On a
    /// controller in alarm, says so (or unlocks it when `unlock`).
    fn begin(&mut self, link: &mut Link, unlock: bool) -> Result<(), Fault>;
    /// The bytes for the job's line `seq` (line numbers and checksums where the protocol has them).
    fn frame(&mut self, seq: usize, line: &str) -> Vec<u8>;
    /// Before each stream: where the firmware numbers lines (Marlin), start the numbering again,
    /// so a second stream on the same connection (the cuts after a frame trace) is numbered as
    /// the first.
    fn restart_numbering(&mut self, _link: &mut Link) -> Result<(), Fault> {
        Ok(())
    }
    /// The job line a `Resend: N` asks for.
    fn resend_index(&self, n: u64) -> Option<usize>;
    /// Classifies a line from the controller.
    fn classify(&mut self, line: &str) -> Reply;
    /// The real-time status request, when the firmware has one (GRBL `?`).
    fn status_request(&self) -> Option<u8>;
    /// Feed hold (GRBL `!`); Marlin has none in its protocol: the engine stops sending.
    fn hold(&mut self, link: &mut Link) -> Result<(), Fault>;
    /// Cycle start after a hold (GRBL `~`).
    fn resume(&mut self, link: &mut Link) -> Result<(), Fault>;
    /// Whether a resume sent now would be taken, given the state of the last status report
    /// since the hold (empty: none yet). GRBL ignores `~` until the hold is complete (`Hold:0`).
    fn ready_to_resume(&self, _state: &str) -> bool {
        true
    }
    /// Stops motion now and raises the tool to `safe_z` (GRBL: hold, `Hold:0`, soft reset,
    /// raise; Marlin: M410 quickstop, raise when it answers; M112 when `emergency`). `pending`:
    /// the lines still unanswered. Returns what it did.
    fn stop_and_raise(
        &mut self,
        link: &mut Link,
        pending: usize,
        safe_z: f64,
        emergency: bool,
    ) -> Result<String, Fault>;
    /// Waits until every move has finished (GRBL: `Idle`; Marlin: `M400` answered).
    fn wait_idle(&mut self, link: &mut Link) -> Result<(), Fault>;
    /// Re-establishes the position before a resumed job cuts again, then goes to `safe_z`.
    fn rezero(&mut self, link: &mut Link, how: Rezero, safe_z: f64, plunge: f64) -> Result<String, Fault>;
    /// Why the controller's position can no longer be trusted, where this session saw the cause:
    /// a reset (a start-up banner, also the one a board prints when opening the port resets it),
    /// an alarm that loses the position (GRBL `ALARM:1`, `ALARM:3`, a failed homing), the
    /// controller in alarm when the job began, a quickstop or a halt. `None` while nothing did,
    /// and again after [`rezero`](Self::rezero) homed or probed.
    fn position_lost(&self) -> Option<String>;
    /// Forgets the causes seen so far: a new job starts from the work zero its maker set.
    fn position_set(&mut self);
    /// Whether `--rezero home` can work on this machine (GRBL: `$22`, once the settings were
    /// read; Marlin: yes), `None` when unknown.
    fn can_home(&self) -> Option<bool>;
    /// The machine position of the last status report that had one (GRBL `MPos`).
    fn machine_pos(&self) -> Option<[f64; 3]>;
    /// Enters (`true`) or leaves check mode (GRBL `$C`); other firmware: an error.
    fn check_mode(&mut self, link: &mut Link, on: bool) -> Result<(), Fault>;
    /// The machine's motion limits, once [`Controller::check_settings`] has read them (`$$`;
    /// Marlin's `M503`); `None` where the controller does not report them.
    fn kinematics(&self) -> Option<Kinematics>;
    /// Probes straight down from the current XY to at most `depth` below Z0 at `feed`; returns
    /// the Z of contact (work coordinates).
    fn probe_z(&mut self, link: &mut Link, depth: f64, feed: f64) -> Result<f64, Fault>;
}

/// Sends one unnumbered command and collects the lines up to its answer (`ok`), within
/// `timeout`. A `Reply::Error` or `Reply::Stopped` ends it with that message.
pub fn command(ctl: &mut dyn Controller, link: &mut Link, line: &str, timeout: Duration) -> Result<Vec<String>, Fault> {
    link.send(format!("{line}\n").as_bytes())?;
    let t0 = Instant::now();
    let mut got = Vec::new();
    while t0.elapsed() < timeout {
        let Some(l) = link.line(Duration::from_millis(50))? else {
            continue;
        };
        match ctl.classify(&l) {
            Reply::Ok => return Ok(got),
            Reply::Error(e) => return Err(Fault::Machine(format!("`{line}`: {e}"))),
            Reply::Stopped(e) => return Err(Fault::Machine(format!("after `{line}`: {e}"))),
            _ => got.push(l),
        }
    }
    Err(Fault::Machine(format!(
        "no answer to `{line}` within {:.0} s",
        timeout.as_secs_f64()
    )))
}
