//! The serial link: a port opened with `serialport` (a USB serial adapter: `/dev/ttyUSB0` on
//! Linux, `/dev/cu.usbserial-*` on macOS, `COM3` on Windows; or a pseudo-terminal's path), read
//! line by line with a timeout. A read that fails for any reason but a timeout (the cable
//! pulled, the board reset, the pty closed) is a lost link. [`ports`] lists the ports there are.
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// The operating system's own port type (`serialport`'s native port on each desktop system).
#[cfg(unix)]
type NativePort = serialport::TTYPort;
#[cfg(windows)]
type NativePort = serialport::COMPort;

/// What went wrong on the link.
#[derive(Debug, Clone, PartialEq)]
pub enum LinkError {
    /// The port could not be opened (named, with the OS's reason).
    Open(String),
    /// The link went away while in use.
    Lost(String),
}

impl std::fmt::Display for LinkError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LinkError::Open(m) | LinkError::Lost(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for LinkError {}

/// A port that cannot be opened or was lost: the job stopped.
impl scratchart_exit::ExitClass for LinkError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(scratchart_exit::Class::Runtime)
    }
}

/// Longest line accepted from a controller; anything longer is cut (and said so in the line).
const MAX_IN_LINE: usize = 4096;

/// What a [`Link`] talks through: a serial port, or one end of an in-memory [`pipe`] (the
/// simulated controller of a dry run). Reads wait a few milliseconds at most and then fail with
/// `TimedOut`; a read of 0 bytes is the end of the link.
pub trait Port: Read + Write + Send {
    /// Throws away what has arrived and not been read.
    fn clear_input(&mut self);
    /// How long a read waits for data (a port that cannot change it keeps its own).
    fn set_read_wait(&mut self, _wait: Duration) {}
}

struct Serial(NativePort);

impl Read for Serial {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(b)
    }
}

impl Write for Serial {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.write(b)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

impl Port for Serial {
    fn clear_input(&mut self) {
        let _ = serialport::SerialPort::clear(&self.0, serialport::ClearBuffer::Input);
    }
}

impl Drop for Serial {
    fn drop(&mut self) {
        // Leave the port openable by the next program (a pty keeps TIOCEXCL while any side holds
        // it open; Windows gives a COM port to one program at a time by itself).
        #[cfg(unix)]
        let _ = self.0.set_exclusive(false);
    }
}

/// One direction of a [`pipe`]: the bytes in flight and whether the writer is gone.
#[derive(Default)]
struct Lane {
    bytes: std::collections::VecDeque<u8>,
    closed: bool,
}

type Shared = std::sync::Arc<(std::sync::Mutex<Lane>, std::sync::Condvar)>;

/// One end of an in-memory [`pipe`].
pub struct PipeEnd {
    rx: Shared,
    tx: Shared,
    timeout: Duration,
}

/// Two connected ends, like the two ends of a serial cable: what one writes the other reads.
/// Reads wait at most `timeout`; when one end is dropped the other reads the end of the link.
pub fn pipe(timeout: Duration) -> (PipeEnd, PipeEnd) {
    let (a, b) = (Shared::default(), Shared::default());
    (
        PipeEnd {
            rx: a.clone(),
            tx: b.clone(),
            timeout,
        },
        PipeEnd { rx: b, tx: a, timeout },
    )
}

impl Read for PipeEnd {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let (lock, cv) = &*self.rx;
        let mut lane = lock.lock().unwrap();
        let t0 = Instant::now();
        while lane.bytes.is_empty() {
            if lane.closed {
                return Ok(0);
            }
            let left = self.timeout.saturating_sub(t0.elapsed());
            if left.is_zero() {
                return Err(std::io::ErrorKind::TimedOut.into());
            }
            lane = cv.wait_timeout(lane, left).unwrap().0;
        }
        let n = out.len().min(lane.bytes.len());
        for (o, b) in out.iter_mut().zip(lane.bytes.drain(..n)) {
            *o = b;
        }
        Ok(n)
    }
}

impl Write for PipeEnd {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        let (lock, cv) = &*self.tx;
        let mut lane = lock.lock().unwrap();
        if lane.closed {
            return Err(std::io::ErrorKind::BrokenPipe.into());
        }
        lane.bytes.extend(b);
        cv.notify_all();
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Port for PipeEnd {
    fn clear_input(&mut self) {
        self.rx.0.lock().unwrap().bytes.clear();
    }
    fn set_read_wait(&mut self, wait: Duration) {
        self.timeout = wait;
    }
}

impl Drop for PipeEnd {
    fn drop(&mut self) {
        // Both lanes end: the other side reads the end and its writes fail.
        for lane in [&self.tx, &self.rx] {
            lane.0.lock().unwrap().closed = true;
            lane.1.notify_all();
        }
    }
}

pub struct Link {
    port: Box<dyn Port>,
    name: String,
    buf: Vec<u8>,
    /// Bytes written, for the benchmark and tests.
    pub written: u64,
}

impl Link {
    /// Opens `path` at `baud` (8N1, no flow control), exclusively, so no second program streams to
    /// the same machine.
    pub fn open(path: &str, baud: u32) -> Result<Link, LinkError> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(5))
            .open_native()
            .map_err(|e| LinkError::Open(format!("cannot open port {path}: {e}")))?;
        Ok(Link::over(Box::new(Serial(port)), path))
    }

    /// A link over any [`Port`] (a [`pipe`]'s end), named `name` in messages.
    pub fn over(port: Box<dyn Port>, name: &str) -> Link {
        Link {
            port,
            name: name.to_string(),
            buf: Vec::new(),
            written: 0,
        }
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// Writes all of `bytes`.
    pub fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        let mut at = 0;
        let t0 = Instant::now();
        while at < bytes.len() {
            match self.port.write(&bytes[at..]) {
                Ok(0) => return Err(self.lost("the port accepts no more data")),
                Ok(n) => at += n,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {
                    if t0.elapsed() > Duration::from_secs(5) {
                        return Err(self.lost("writes stalled for 5 s"));
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.lost(&e.to_string())),
            }
        }
        self.written += bytes.len() as u64;
        Ok(())
    }

    fn lost(&self, why: &str) -> LinkError {
        LinkError::Lost(format!("lost the connection on {}: {why}", self.name))
    }

    /// The next complete line (without its `\r\n`), waiting at most `timeout`; `Ok(None)` when
    /// none came in time. Empty lines are skipped.
    pub fn line(&mut self, timeout: Duration) -> Result<Option<String>, LinkError> {
        let t0 = Instant::now();
        loop {
            if let Some(l) = self.take_line() {
                if l.is_empty() {
                    continue;
                }
                return Ok(Some(l));
            }
            let mut chunk = [0u8; 1024];
            match self.port.read(&mut chunk) {
                Ok(0) => return Err(self.lost("end of file")),
                Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.lost(&e.to_string())),
            }
            if t0.elapsed() >= timeout {
                return Ok(self.take_line().filter(|l| !l.is_empty()));
            }
        }
    }

    fn take_line(&mut self) -> Option<String> {
        let end = self.buf.iter().position(|&b| b == b'\n' || b == b'\r');
        match end {
            Some(i) => {
                let l: Vec<u8> = self.buf.drain(..=i).collect();
                Some(String::from_utf8_lossy(&l[..i]).trim().to_string())
            }
            None if self.buf.len() > MAX_IN_LINE => {
                let l: Vec<u8> = self.buf.drain(..).collect();
                Some(format!("{} [line cut]", String::from_utf8_lossy(&l[..80])))
            }
            None => None,
        }
    }

    /// Throws away everything received so far (and waiting in the OS).
    pub fn discard_input(&mut self) {
        self.port.clear_input();
        self.buf.clear();
    }
}

/// A serial port the system has: its name (what `--port` takes) and what is known of the
/// device behind it.
#[derive(Clone, Debug, PartialEq)]
pub struct PortInfo {
    pub name: String,
    /// "USB", "Bluetooth", "PCI" or "unknown".
    pub kind: &'static str,
    /// For a USB port: vendor and product ids ("1a86:7523") and, where the device gives them,
    /// its maker, product name and serial number (a CH340 or FTDI adapter names itself so).
    pub usb: Option<String>,
}

/// The serial ports the system has, USB ones first (the kind a carving machine's board is).
pub fn ports() -> Result<Vec<PortInfo>, LinkError> {
    let found =
        serialport::available_ports().map_err(|e| LinkError::Open(format!("cannot list the serial ports: {e}")))?;
    let mut out: Vec<PortInfo> = found
        .into_iter()
        .map(|p| {
            let (kind, usb) = match p.port_type {
                serialport::SerialPortType::UsbPort(u) => {
                    let mut d = format!("{:04x}:{:04x}", u.vid, u.pid);
                    for part in [
                        u.manufacturer,
                        u.product,
                        u.serial_number.map(|s| format!("serial {s}")),
                    ]
                    .into_iter()
                    .flatten()
                    {
                        d.push_str(", ");
                        d.push_str(&part);
                    }
                    ("USB", Some(d))
                }
                serialport::SerialPortType::BluetoothPort => ("Bluetooth", None),
                serialport::SerialPortType::PciPort => ("PCI", None),
                serialport::SerialPortType::Unknown => ("unknown", None),
            };
            PortInfo {
                name: p.port_name,
                kind,
                usb,
            }
        })
        .collect();
    out.sort_by_key(|p| (p.kind != "USB", p.name.clone()));
    Ok(out)
}
