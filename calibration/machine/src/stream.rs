//! The streaming engine, shared by both firmware families: flow control by counting the bytes
//! of unanswered lines against the controller's receive buffer, resends, status, hold and
//! resume, stopping on errors, progress for an observer, and the journal.
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

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

/// How far the job is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Progress {
    /// Scratches acknowledged (counting those before a resumed job's start) and in the plan.
    pub done: usize,
    pub total: usize,
    /// Estimated seconds left, from this run's pace.
    pub eta_s: Option<f64>,
    /// The machine's state (GRBL's status, or what the sender knows).
    pub state: String,
    /// Work position, mm, when the controller reports it.
    pub pos: Option<[f64; 3]>,
}

/// What the engine tells the user: progress for a bar, and lines for a log. `confirm` asks
/// before the first motion (the binary answers yes with `--yes` or without a terminal).
pub trait Observer {
    fn progress(&self, p: &Progress);
    fn note(&self, msg: &str);
    fn confirm(&self, _question: &str) -> bool {
        true
    }
}

/// An observer that shows nothing.
pub struct Quiet;
impl Observer for Quiet {
    fn progress(&self, _p: &Progress) {}
    fn note(&self, _msg: &str) {}
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

/// Streams `lines` (each with the plan block it belongs to). `acked(block, progress_state)` is
/// called when the last line of a block is acknowledged. Returns how it ended and how many
/// lines were still unanswered.
pub fn stream(
    link: &mut Link,
    ctl: &mut dyn Controller,
    lines: &[(String, Option<usize>)],
    control: &Control,
    obs: &dyn Observer,
    acked: &mut dyn FnMut(usize, &str, Option<[f64; 3]>),
) -> (End, usize) {
    let window = ctl.window();
    let (mut next, mut used) = (0usize, 0usize);
    let mut fl: VecDeque<Flight> = VecDeque::new();
    let mut resend: Option<(usize, Instant)> = None;
    let mut repeats = (usize::MAX, 0usize);
    let mut held = false;
    let poll = ctl.status_request();
    let mut last_poll = Instant::now() - POLL;
    let mut last_status = Instant::now();
    let mut last_rx = Instant::now();
    let (mut state, mut pos) = (String::from("Run"), None);
    let last_of_block = |seq: usize| match lines[seq].1 {
        Some(b) => lines.get(seq + 1).is_none_or(|n| n.1 != Some(b)),
        None => false,
    };
    macro_rules! link_try {
        ($e:expr) => {
            match $e {
                Ok(v) => v,
                Err(e) => return (End::Lost(e.to_string()), fl.len()),
            }
        };
    }
    loop {
        if control.abort.load(Ordering::SeqCst) {
            return (End::Abort, fl.len());
        }
        if control.hold.swap(false, Ordering::SeqCst) && !held {
            if let Err(e) = ctl.hold(link) {
                return (End::Lost(format!("{e:?}")), fl.len());
            }
            held = true;
            obs.note("feed hold: the machine stops; resume with `~` (or `r`), abort with Ctrl-C");
        }
        if control.resume.swap(false, Ordering::SeqCst) && held {
            if let Err(e) = ctl.resume(link) {
                return (End::Lost(format!("{e:?}")), fl.len());
            }
            held = false;
            obs.note("resumed");
        }
        if let Some((_, t)) = resend {
            if !fl.iter().any(|f| f.stale) || t.elapsed() > RESEND_QUIET {
                // Lines the controller threw away with its receive buffer get no answer.
                fl.retain(|f| {
                    if f.stale {
                        used -= f.bytes;
                    }
                    !f.stale
                });
                resend = None;
            }
        }
        if !held && resend.is_none() {
            while next < lines.len() {
                let bytes = ctl.frame(next, &lines[next].0);
                if bytes.len() > window {
                    return (
                        End::Input(format!(
                            "`{}` takes {} bytes, more than the controller's {window}-byte receive buffer",
                            lines[next].0,
                            bytes.len()
                        )),
                        fl.len(),
                    );
                }
                if used + bytes.len() > window {
                    break;
                }
                link_try!(link.send(&bytes));
                used += bytes.len();
                fl.push_back(Flight {
                    seq: next,
                    bytes: bytes.len(),
                    stale: false,
                });
                next += 1;
            }
        }
        if next == lines.len() && fl.is_empty() {
            return (End::Done, 0);
        }
        if let Some(q) = poll {
            if last_poll.elapsed() >= POLL {
                link_try!(link.send(&[q]));
                last_poll = Instant::now();
            }
            if last_status.elapsed() > Duration::from_secs(10) && last_rx.elapsed() > Duration::from_secs(10) {
                return (
                    End::Lost(format!(
                        "{} answered nothing, not even a status report, for 10 s",
                        link.name()
                    )),
                    fl.len(),
                );
            }
        } else if last_rx.elapsed() > Duration::from_secs(120) && !fl.is_empty() {
            return (
                End::Lost(format!("{} answered nothing for 120 s", link.name())),
                fl.len(),
            );
        }
        let Some(l) = link_try!(link.line(Duration::from_millis(10))) else {
            continue;
        };
        last_rx = Instant::now();
        match ctl.classify(&l) {
            Reply::Ok => {
                let Some(f) = fl.pop_front() else {
                    obs.note(&format!("an answer with no line waiting for it: `{l}`"));
                    continue;
                };
                used -= f.bytes;
                if let Some(r) = resend.as_mut() {
                    r.1 = Instant::now();
                }
                if !f.stale && last_of_block(f.seq) {
                    acked(lines[f.seq].1.unwrap(), &state, pos);
                }
            }
            Reply::Error(e) => {
                let what = match fl.pop_front() {
                    Some(f) => format!("`{}`: {e}", lines[f.seq].0),
                    None => e,
                };
                return (End::Refused(what), fl.len());
            }
            Reply::Stopped(e) => return (End::Stopped(e), fl.len()),
            Reply::Resend(n) => {
                let Some(idx) = ctl.resend_index(n).filter(|&i| i < next) else {
                    obs.note(&format!("ignored a request for line {n}, which was never sent"));
                    continue;
                };
                // A repeated request for the line already being resent is ignored.
                let pending = resend.is_some_and(|r| r.0 == idx) || fl.iter().any(|f| !f.stale && f.seq == idx);
                if pending {
                    continue;
                }
                repeats = if repeats.0 == idx {
                    (idx, repeats.1 + 1)
                } else {
                    (idx, 1)
                };
                if repeats.1 > 10 {
                    return (
                        End::Lost(format!(
                            "line {n} was asked for again {} times: the link is too noisy",
                            repeats.1
                        )),
                        fl.len(),
                    );
                }
                for f in fl.iter_mut() {
                    f.stale = true;
                }
                next = idx;
                resend = Some((idx, Instant::now()));
            }
            Reply::Status(s) => {
                last_status = Instant::now();
                if s.state.starts_with("Alarm") {
                    return (End::Stopped(format!("the controller is in {}", s.state)), fl.len());
                }
                state = s.state;
                pos = s.pos.or(pos);
            }
            Reply::Info(m) => obs.note(&m),
            Reply::Ignore => {}
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
