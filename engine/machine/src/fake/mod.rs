//! Fake controllers for tests, each on a thread behind a pseudo-terminal
//! (`serialport::TTYPort::pair`): [`FakeGrbl`] and [`FakeMarlin`]. `carve --port` takes the
//! pty's path like a real port. They model the receive buffer (an overflow is recorded and
//! printed, never hidden), the protocol's answers and faults, and record every motion line they
//! execute so a test can prove each scratch was cut, and how often.
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

#[cfg(unix)]
use serialport::{SerialPort, TTYPort};

use crate::transport::{pipe, PipeEnd, Port};

mod grbl;
mod marlin;

pub use grbl::{FakeGrbl, GrblConfig};
pub use marlin::{FakeMarlin, MarlinConfig};

/// A tilted plate surface for probing: z = z0 + dzdx x + dzdy y (work coordinates, mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub z0: f64,
    pub dzdx: f64,
    pub dzdy: f64,
}

impl Plane {
    pub fn at(&self, x: f64, y: f64) -> f64 {
        self.z0 + self.dzdx * x + self.dzdy * y
    }
}

/// What a fake saw and did. Shared between a fake and the one that replaces it after a
/// disconnect, so a test sees the whole job.
#[derive(Clone, Debug, Default)]
pub struct Record {
    /// Motion lines executed (G0/G1/G2/G3), in order, without line numbers or checksums.
    pub executed: Vec<String>,
    /// Every line taken from the receive buffer, as received.
    pub received: Vec<String>,
    /// Lines accepted in check mode (GRBL `$C`).
    pub checked: Vec<String>,
    /// Receive-buffer overflows: what arrived beyond the buffer. Must stay empty.
    pub overflows: Vec<String>,
    /// The most bytes ever waiting in the receive buffer.
    pub max_buffered: usize,
    /// Soft resets (GRBL), feed holds and resumes.
    pub resets: usize,
    pub holds: usize,
    pub resumes: usize,
    /// Marlin: resend requests sent, corrupted lines, M410 / M112 received.
    pub resends: Vec<u64>,
    pub corrupted: usize,
    pub quickstops: usize,
    pub emergency: usize,
    /// Probe contacts (x, y, z).
    pub probes: Vec<[f64; 3]>,
    /// Position after the last executed move (work coordinates).
    pub pos: [f64; 3],
    /// The fake closed its pty (an injected disconnect).
    pub disconnected: bool,
}

pub type Shared = Arc<Mutex<Record>>;

/// A running fake: its pty path, its record, and its thread (stopped on drop).
pub struct Fake {
    path: String,
    record: Shared,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Fake {
    /// The pty path to give `carve --port`.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// A copy of the record so far.
    pub fn record(&self) -> Record {
        self.record.lock().unwrap().clone()
    }

    /// Where the tool stands now (work coordinates), without copying the record.
    pub fn pos(&self) -> [f64; 3] {
        self.record.lock().unwrap().pos
    }

    /// The shared record, to hand to the fake that replaces this one.
    pub fn shared(&self) -> Shared {
        self.record.clone()
    }
}

impl Drop for Fake {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The fake's end of the pty (or of the in-memory pipe of a dry run), with the modelled
/// receive buffer.
pub(crate) struct Wire {
    master: Box<dyn Port>,
    /// Kept open so the master never sees a hang-up while no client holds the port.
    _slave: Option<Box<dyn Send>>,
    pub rx: Vec<u8>,
    pub capacity: usize,
    pub record: Shared,
}

impl Wire {
    /// Reads what has arrived (at most ~1 ms wait); `filter` takes real-time bytes out of the
    /// stream (GRBL) before they reach the buffer. Returns false when the link is gone.
    pub fn pump(&mut self, mut filter: impl FnMut(u8) -> bool) -> bool {
        // With a line already waiting, only take what has arrived (no wait): the fake then
        // answers as fast as it can (a dry run at full speed).
        let wait = if self.rx.contains(&b'\n') { 0 } else { 1 };
        self.master.set_read_wait(Duration::from_millis(wait));
        let mut chunk = [0u8; 512];
        match self.master.read(&mut chunk) {
            Ok(n) => {
                for &b in &chunk[..n] {
                    if filter(b) {
                        continue;
                    }
                    self.rx.push(b);
                    let mut r = self.record.lock().unwrap();
                    r.max_buffered = r.max_buffered.max(self.rx.len());
                    if self.rx.len() > self.capacity {
                        let msg = format!(
                            "receive buffer overflow: {} bytes waiting, capacity {}",
                            self.rx.len(),
                            self.capacity
                        );
                        // (recorded: the tests read `overflows`; a library does not print)
                        r.overflows.push(msg);
                    }
                }
                true
            }
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => true,
            Err(_) => true,
        }
    }

    /// Takes the next complete line from the receive buffer.
    pub fn take_line(&mut self) -> Option<String> {
        let i = self.rx.iter().position(|&b| b == b'\n')?;
        let l: Vec<u8> = self.rx.drain(..=i).collect();
        let s = String::from_utf8_lossy(&l[..i]).trim_end_matches('\r').to_string();
        self.record.lock().unwrap().received.push(s.clone());
        Some(s)
    }

    pub fn say(&mut self, text: &str) {
        let _ = self.master.write_all(text.as_bytes());
    }
}

/// The pty master as a [`Port`].
#[cfg(unix)]
struct Master(TTYPort);

#[cfg(unix)]
impl Read for Master {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(b)
    }
}

#[cfg(unix)]
impl Write for Master {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.write(b)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

#[cfg(unix)]
impl Port for Master {
    fn clear_input(&mut self) {
        let _ = self.0.clear(serialport::ClearBuffer::Input);
    }
    fn set_read_wait(&mut self, wait: Duration) {
        let _ = self.0.set_timeout(wait);
    }
}

/// Opens a pty pair for a fake: (wire, slave path).
#[cfg(unix)]
pub(crate) fn open_wire(capacity: usize, record: Shared) -> std::io::Result<(Wire, String)> {
    let (mut master, slave) = TTYPort::pair().map_err(std::io::Error::other)?;
    master
        .set_timeout(Duration::from_millis(1))
        .map_err(std::io::Error::other)?;
    let path = slave
        .name()
        .ok_or_else(|| std::io::Error::other("the pty has no path"))?;
    Ok((
        Wire {
            master: Box::new(Master(master)),
            _slave: Some(Box::new(slave)),
            rx: Vec::new(),
            capacity,
            record,
        },
        path,
    ))
}

/// An in-memory pipe for a fake (a dry run, on every system): (wire, the sender's end). Reads
/// wait at most 1 ms, as the pty's do.
pub(crate) fn pipe_wire(capacity: usize, record: Shared) -> (Wire, PipeEnd) {
    let (fake, sender) = pipe(Duration::from_millis(1));
    let w = Wire {
        master: Box::new(fake),
        _slave: None,
        rx: Vec::new(),
        capacity,
        record,
    };
    (w, sender)
}

pub(crate) fn spawn(path: String, record: Shared, body: impl FnOnce(Arc<AtomicBool>) + Send + 'static) -> Fake {
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let thread = std::thread::spawn(move || body(s));
    Fake {
        path,
        record,
        stop,
        thread: Some(thread),
    }
}

/// A word's value in a G-code line (`X1.5` -> 1.5).
pub(crate) fn word(line: &str, letter: char) -> Option<f64> {
    line.split_whitespace()
        .find(|w| w.starts_with(letter) && w.len() > 1)
        .and_then(|w| w[1..].parse().ok())
}

/// Applies a G0/G1 line (or a G2/G3 arc, to its end) to the position; true when it is a motion
/// line.
pub(crate) fn apply_motion(line: &str, pos: &mut [f64; 3]) -> bool {
    let motion = line
        .split_whitespace()
        .any(|w| matches!(w, "G0" | "G1" | "G00" | "G01" | "G2" | "G3" | "G02" | "G03"));
    if !motion {
        return false;
    }
    for (i, c) in ['X', 'Y', 'Z'].iter().enumerate() {
        if let Some(v) = word(line, *c) {
            pos[i] = v;
        }
    }
    true
}
