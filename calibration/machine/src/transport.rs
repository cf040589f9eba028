//! The serial link: a port opened with `serialport` (a USB serial adapter or a pseudo-terminal's
//! path), read line by line with a timeout. A read that fails for any reason but a timeout (the
//! cable pulled, the board reset, the pty closed) is a lost link.
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

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

/// Longest line accepted from a controller; anything longer is cut (and said so in the line).
const MAX_IN_LINE: usize = 4096;

pub struct Link {
    port: TTYPort,
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
        // it open).
        let _ = self.port.set_exclusive(false);
    }
}
