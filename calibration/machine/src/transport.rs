//! The serial link: a port opened with `serialport` (a USB serial adapter: `/dev/ttyUSB0` on
//! Linux, `/dev/cu.usbserial-*` on macOS, `COM3` on Windows; or a pseudo-terminal's path), read
//! line by line with a timeout. A read that fails for any reason but a timeout (the cable
//! pulled, the board reset, the pty closed) is a lost link. [`ports`] lists the ports there are.
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::SerialPort;

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

pub struct Link {
    port: NativePort,
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
        Ok(Link {
            port,
            name: path.to_string(),
            buf: Vec::new(),
            written: 0,
        })
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
        let _ = self.port.clear(serialport::ClearBuffer::Input);
        self.buf.clear();
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        // Leave the port openable by the next program (a pty keeps TIOCEXCL while any side holds
        // it open; Windows gives a COM port to one program at a time by itself).
        #[cfg(unix)]
        let _ = self.port.set_exclusive(false);
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
