//! The streaming engine, shared by both firmware families: flow control by counting the bytes
//! of unanswered lines against the controller's receive buffer, resends, status, hold and
//! resume, stopping on errors, progress for an observer, and the journal.
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use scratchart_observe::Observer;

use crate::controller::{Controller, Fault, Reply};
use crate::transport::Link;

/// Requests from outside the stream loop (keys, Ctrl-C), checked on every turn of the loop.
#[derive(Default)]
pub struct Control {
    /// Feed hold (GRBL `!`; Marlin: the sender stops sending).
    pub hold: AtomicBool,
    /// Resume after a hold (GRBL `~`).
    pub resume: AtomicBool,
    /// Stop the job now and raise the tool (Ctrl-C).
    pub abort: AtomicBool,
}

/// How a stream ended.
#[derive(Debug)]
pub enum End {
    Done,
    /// The controller refused a line (it is still moving what it took before).
    Refused(String),
    /// The controller stopped on its own (alarm, halt, reset).
    Stopped(String),
    /// The link is gone.
    Lost(String),
    /// A line that cannot be sent (longer than the receive buffer).
    Input(String),
    /// Ctrl-C.
    Abort,
}

struct Flight {
    seq: usize,
    bytes: usize,
    /// Sent before a resend request: answered (or dropped) but never counted as done.
    stale: bool,
}

/// How often GRBL's status is asked for.
const POLL: Duration = Duration::from_millis(200);
/// How long a resend waits for the answers to lines sent before it.
const RESEND_QUIET: Duration = Duration::from_millis(500);

/// The sender's state while it streams (see [`stream`]).
struct Sender<'a> {
    lines: &'a [(String, Option<usize>)],
    /// The controller's receive buffer, bytes.
    window: usize,
    /// The next line to send, and the bytes in the controller's buffer.
    next: usize,
    used: usize,
    /// Lines sent and not yet answered, oldest first.
    fl: VecDeque<Flight>,
    /// A resend under way: the line asked for, and when the last answer came.
    resend: Option<(usize, Instant)>,
    /// The line last asked for again, and how many times in a row.
    repeats: (usize, usize),
    held: bool,
    /// A resume asked for while held, sent once the controller can take it
    /// ([`Controller::ready_to_resume`]).
    resume_wanted: bool,
    last_poll: Instant,
    last_status: Instant,
    last_rx: Instant,
    /// The machine's state and position from its last status report.
    state: String,
    pos: Option<[f64; 3]>,
    /// Every line answered, the machine still moving what it took ([`Drain`]).
    drain: Option<Drain>,
}

/// After the last answer: a controller that reports its status has only planned the last moves,
/// so the stream goes on (holds, Ctrl-C, progress with the position) until a status asked for
/// after the last answer says the machine is idle.
#[derive(Clone, Copy, Default)]
struct Drain {
    polled: bool,
    idle: bool,
}

/// How a step of the sender ends the stream: how it ended and the lines still unanswered.
type Ended = (End, usize);

impl Sender<'_> {
    fn lost(&self, e: impl std::fmt::Display) -> Ended {
        (End::Lost(e.to_string()), self.fl.len())
    }

    /// Whether line `seq` is the last of its plan block.
    fn last_of_block(&self, seq: usize) -> bool {
        match self.lines[seq].1 {
            Some(b) => self.lines.get(seq + 1).is_none_or(|n| n.1 != Some(b)),
            None => false,
        }
    }

    /// Ctrl-C, feed hold and resume, as `control` asks.
    fn controls(
        &mut self,
        link: &mut Link,
        ctl: &mut dyn Controller,
        control: &Control,
        obs: &dyn Observer,
    ) -> Option<Ended> {
        if control.abort.load(Ordering::SeqCst) {
            return Some((End::Abort, self.fl.len()));
        }
        if control.hold.swap(false, Ordering::SeqCst) && !self.held {
            if let Err(e) = ctl.hold(link) {
                return Some(self.lost(e.to_string()));
            }
            self.held = true;
            // (only a report after the hold tells what the machine does now)
            self.state.clear();
            obs.info("feed hold: the machine stops; resume with `~` (or `r`), abort with Ctrl-C");
        }
        if control.resume.swap(false, Ordering::SeqCst) && self.held {
            self.resume_wanted = true;
        }
        if self.resume_wanted && ctl.ready_to_resume(&self.state) {
            if let Err(e) = ctl.resume(link) {
                return Some(self.lost(e.to_string()));
            }
            self.held = false;
            self.resume_wanted = false;
            obs.info("resumed");
        }
        None
    }

    /// Ends a resend once the lines sent before it are answered or given up on: lines the
    /// controller threw away with its receive buffer get no answer.
    fn settle_resend(&mut self) {
        if let Some((_, t)) = self.resend {
            if !self.fl.iter().any(|f| f.stale) || t.elapsed() > RESEND_QUIET {
                let used = &mut self.used;
                self.fl.retain(|f| {
                    if f.stale {
                        *used -= f.bytes;
                    }
                    !f.stale
                });
                self.resend = None;
            }
        }
    }

    /// Sends lines while they fit the controller's receive buffer.
    fn fill(&mut self, link: &mut Link, ctl: &mut dyn Controller) -> Option<Ended> {
        if self.held || self.resend.is_some() {
            return None;
        }
        while self.next < self.lines.len() {
            let bytes = ctl.frame(self.next, &self.lines[self.next].0);
            if bytes.len() > self.window {
                return Some((
                    End::Input(format!(
                        "`{}` takes {} bytes, more than the controller's {}-byte receive buffer",
                        self.lines[self.next].0,
                        bytes.len(),
                        self.window
                    )),
                    self.fl.len(),
                ));
            }
            if self.used + bytes.len() > self.window {
                break;
            }
            if let Err(e) = link.send(&bytes) {
                return Some(self.lost(e));
            }
            self.used += bytes.len();
            self.fl.push_back(Flight {
                seq: self.next,
                bytes: bytes.len(),
                stale: false,
            });
            self.next += 1;
        }
        None
    }

    /// Asks for the status every `POLL` (where the controller answers one), and gives up on a
    /// controller that has been silent too long.
    fn poll(&mut self, link: &mut Link, poll: Option<u8>) -> Option<Ended> {
        if let Some(q) = poll {
            if self.last_poll.elapsed() >= POLL {
                if let Err(e) = link.send(&[q]) {
                    return Some(self.lost(e));
                }
                self.last_poll = Instant::now();
                if let Some(d) = self.drain.as_mut() {
                    d.polled = true;
                }
            }
            if self.last_status.elapsed() > Duration::from_secs(10) && self.last_rx.elapsed() > Duration::from_secs(10)
            {
                return Some(self.lost(format!(
                    "{} answered nothing, not even a status report, for 10 s",
                    link.name()
                )));
            }
        } else if self.last_rx.elapsed() > Duration::from_secs(120) && !self.fl.is_empty() {
            return Some(self.lost(format!("{} answered nothing for 120 s", link.name())));
        }
        None
    }

    /// One line from the controller.
    fn reply(
        &mut self,
        l: &str,
        ctl: &mut dyn Controller,
        obs: &dyn Observer,
        acked: &mut dyn FnMut(usize, &str, Option<[f64; 3]>),
    ) -> Option<Ended> {
        match ctl.classify(l) {
            Reply::Ok => {
                let Some(f) = self.fl.pop_front() else {
                    obs.info(&format!("an answer with no line waiting for it: `{l}`"));
                    return None;
                };
                self.used -= f.bytes;
                if let Some(r) = self.resend.as_mut() {
                    r.1 = Instant::now();
                }
                if !f.stale && self.last_of_block(f.seq) {
                    acked(self.lines[f.seq].1.unwrap(), &self.state, self.pos);
                }
            }
            Reply::Error(e) => {
                let what = match self.fl.pop_front() {
                    Some(f) => format!("`{}`: {e}", self.lines[f.seq].0),
                    None => e,
                };
                return Some((End::Refused(what), self.fl.len()));
            }
            Reply::Stopped(e) => return Some((End::Stopped(e), self.fl.len())),
            Reply::Resend(n) => return self.resend_from(n, ctl, obs),
            Reply::Status(s) => {
                self.last_status = Instant::now();
                if s.state.starts_with("Alarm") {
                    return Some((End::Stopped(format!("the controller is in {}", s.state)), self.fl.len()));
                }
                self.state = s.state;
                self.pos = s.pos.or(self.pos);
                if let Some(d) = self.drain.as_mut() {
                    // (GRBL's check mode reports `Check` where it would be idle)
                    d.idle = d.polled && (self.state == "Idle" || self.state == "Check");
                    // The last block again, with where the machine now is.
                    if let Some(b) = self.lines.iter().rev().find_map(|l| l.1) {
                        acked(b, &self.state, self.pos);
                    }
                }
            }
            Reply::Info(m) => obs.info(&m),
            Reply::Ignore => {}
        }
        None
    }

    /// The controller asks for line `n` again: every line in flight becomes stale and sending
    /// starts again from it (a repeated request for the line being resent is ignored; more
    /// than 10 in a row for one line is a link too noisy to carve over).
    fn resend_from(&mut self, n: u64, ctl: &mut dyn Controller, obs: &dyn Observer) -> Option<Ended> {
        let Some(idx) = ctl.resend_index(n).filter(|&i| i < self.next) else {
            obs.info(&format!("ignored a request for line {n}, which was never sent"));
            return None;
        };
        let pending = self.resend.is_some_and(|r| r.0 == idx) || self.fl.iter().any(|f| !f.stale && f.seq == idx);
        if pending {
            return None;
        }
        self.repeats = if self.repeats.0 == idx {
            (idx, self.repeats.1 + 1)
        } else {
            (idx, 1)
        };
        if self.repeats.1 > 10 {
            return Some(self.lost(format!(
                "line {n} was asked for again {} times: the link is too noisy",
                self.repeats.1
            )));
        }
        for f in self.fl.iter_mut() {
            f.stale = true;
        }
        self.next = idx;
        self.resend = Some((idx, Instant::now()));
        None
    }
}

/// Streams `lines` (each with the plan block it belongs to). `acked(block, progress_state)` is
/// called when the last line of a block is acknowledged (and, once every line is answered, for
/// the last block on each status report until the machine is idle: [`Drain`]). Returns how it
/// ended and how many lines were still unanswered.
pub fn stream(
    link: &mut Link,
    ctl: &mut dyn Controller,
    lines: &[(String, Option<usize>)],
    control: &Control,
    obs: &dyn Observer,
    acked: &mut dyn FnMut(usize, &str, Option<[f64; 3]>),
) -> (End, usize) {
    if let Err(f) = ctl.restart_numbering(link) {
        return (End::from(f), 0);
    }
    let now = Instant::now();
    let mut tx = Sender {
        lines,
        window: ctl.window(),
        next: 0,
        used: 0,
        fl: VecDeque::new(),
        resend: None,
        repeats: (usize::MAX, 0),
        held: false,
        resume_wanted: false,
        last_poll: now - POLL,
        last_status: now,
        last_rx: now,
        state: String::from("Run"),
        pos: None,
        drain: None,
    };
    let poll = ctl.status_request();
    loop {
        if let Some(end) = tx.controls(link, ctl, control, obs) {
            return end;
        }
        tx.settle_resend();
        if let Some(end) = tx.fill(link, ctl) {
            return end;
        }
        if tx.next == lines.len() && tx.fl.is_empty() {
            match (poll, tx.drain) {
                (None, _) => return (End::Done, 0),
                (Some(_), Some(d)) if d.idle => return (End::Done, 0),
                (Some(_), None) => tx.drain = Some(Drain::default()),
                _ => {}
            }
        }
        if let Some(end) = tx.poll(link, poll) {
            return end;
        }
        let l = match link.line(Duration::from_millis(10)) {
            Ok(Some(l)) => l,
            Ok(None) => continue,
            Err(e) => return tx.lost(e),
        };
        tx.last_rx = Instant::now();
        if let Some(end) = tx.reply(&l, ctl, obs, acked) {
            return end;
        }
    }
}

impl From<Fault> for End {
    fn from(f: Fault) -> End {
        match f {
            Fault::Input(m) => End::Input(m),
            Fault::Machine(m) => End::Lost(m),
        }
    }
}
