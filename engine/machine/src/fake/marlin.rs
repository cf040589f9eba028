//! A fake Marlin printer: line numbers and checksums (`Error:checksum mismatch` / `Error:Line
//! Number is not Last Line Number+1` with `Resend: N` and `ok`), lines corrupted in transit,
//! the 127-byte receive buffer, `echo:busy: processing` and temperature reports while it works,
//! M115, M211, M503 (M203, M201), M110, M114, M400, M410, M112, G28, G38.2 / G30 probing of a [`Plane`], and an
//! injected halt or disconnect.
use std::collections::BTreeSet;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

#[cfg(unix)]
use super::open_wire;
use super::{apply_motion, pipe_wire, spawn, word, Fake, Plane, Shared, Wire};
use crate::transport::PipeEnd;

#[derive(Clone, Debug)]
pub struct MarlinConfig {
    /// Receive buffer bytes (Marlin's serial buffer: 127 usable).
    pub rx_capacity: usize,
    /// Time to execute one line.
    pub line_delay: Duration,
    /// Line numbers whose first transmission arrives corrupted (a flipped bit).
    pub corrupt: BTreeSet<u64>,
    /// On a bad line, throw away what waits in the receive buffer (as Marlin's serial flush
    /// does); otherwise every waiting line is refused with its own `Resend` (repeated requests).
    pub flush_on_error: bool,
    /// Print `echo:busy: processing` before each motion line (as while a long move runs).
    pub busy: bool,
    /// Print a temperature report every so often.
    pub temperature_every: Option<Duration>,
    /// After the n-th motion line: `Error:Printer halted. kill() called!` and silence.
    pub halt_after: Option<usize>,
    /// After the n-th motion line the fake closes its pty.
    pub disconnect_after: Option<usize>,
    /// The board restarts when the port is opened: the position starts at zero, the first input
    /// is lost and `start` follows it.
    pub restart_on_open: bool,
    /// Bed size from M211 (`None`: M211 unsupported).
    pub bed: Option<[f64; 3]>,
    /// G38.2 available (else G30 with the bed probe).
    pub g38: bool,
    /// `M203` (mm/s) and `M201` (mm/s^2) of X, Y, Z in `M503`'s report (`None`: M503 unknown).
    pub m503: Option<([f64; 3], [f64; 3])>,
    pub plane: Option<Plane>,
}

impl Default for MarlinConfig {
    fn default() -> Self {
        MarlinConfig {
            rx_capacity: 127,
            line_delay: Duration::from_micros(200),
            corrupt: BTreeSet::new(),
            flush_on_error: false,
            busy: false,
            temperature_every: None,
            halt_after: None,
            disconnect_after: None,
            restart_on_open: false,
            bed: Some([220.0, 220.0, 250.0]),
            g38: true,
            m503: Some(([500.0, 500.0, 5.0], [500.0, 500.0, 100.0])),
            plane: None,
        }
    }
}

pub struct FakeMarlin;

fn checksum(s: &str) -> u8 {
    s.bytes().fold(0, |a, b| a ^ b)
}

impl FakeMarlin {
    #[cfg(unix)]
    pub fn start(cfg: MarlinConfig) -> std::io::Result<Fake> {
        Self::start_with(cfg, Shared::default())
    }

    /// Starts a fake that continues `record` (the printer after a reconnect).
    #[cfg(unix)]
    pub fn start_with(cfg: MarlinConfig, record: Shared) -> std::io::Result<Fake> {
        record.lock().unwrap().disconnected = false;
        let (w, path) = open_wire(cfg.rx_capacity, record.clone())?;
        Ok(Self::run(w, path, cfg, record))
    }

    /// A simulated controller on an in-memory pipe (`carve --port sim`, on every system): the
    /// fake, and the end to give [`crate::transport::Link::over`].
    pub fn simulated(cfg: MarlinConfig) -> (Fake, PipeEnd) {
        let record = Shared::default();
        let (w, end) = pipe_wire(cfg.rx_capacity, record.clone());
        (Self::run(w, "sim".into(), cfg, record), end)
    }

    fn run(mut w: Wire, path: String, cfg: MarlinConfig, record: Shared) -> Fake {
        spawn(path, record.clone(), move |stop| {
            let mut p = Printer {
                last_n: 0,
                corrupt: cfg.corrupt.clone(),
                pos: if cfg.restart_on_open {
                    [0.0; 3]
                } else {
                    record.lock().unwrap().pos
                },
                motions: 0,
                halted: false,
            };
            let mut booted = !cfg.restart_on_open;
            let mut busy_until = Instant::now();
            let mut last_temp = Instant::now();
            while !stop.load(Ordering::SeqCst) {
                w.pump(|_| false);
                if !booted && !w.rx.is_empty() {
                    booted = true;
                    w.rx.clear();
                    w.say("start\necho: External Reset\n");
                    continue;
                }
                if let Some(every) = cfg.temperature_every {
                    if last_temp.elapsed() >= every && !p.halted {
                        w.say(" T:25.00 /0.00 B:24.90 /0.00 @:0 B@:0\n");
                        last_temp = Instant::now();
                    }
                }
                if Instant::now() < busy_until {
                    continue;
                }
                let Some(raw) = w.take_line() else { continue };
                if p.halted {
                    continue;
                }
                busy_until = Instant::now() + cfg.line_delay;
                let Some(line) = p.unwrap_line(&mut w, raw.trim(), &cfg) else {
                    continue;
                };
                if p.command(&mut w, &line, &cfg) == Next::Disconnect {
                    w.record.lock().unwrap().disconnected = true;
                    return;
                }
            }
        })
    }
}

/// What the fake does after a command.
#[derive(PartialEq)]
enum Next {
    Go,
    Disconnect,
}

/// The fake printer's state between lines.
struct Printer {
    /// The last line number accepted.
    last_n: u64,
    /// Line numbers still to be corrupted in transit (each once).
    corrupt: std::collections::BTreeSet<u64>,
    pos: [f64; 3],
    motions: usize,
    /// After M112 or `halt_after`: it answers nothing more.
    halted: bool,
}

impl Printer {
    /// The command of a received line: a numbered line (`N.. cmd *sum`) checked for its
    /// checksum and number (a resend is asked for, and None returned, where either is wrong);
    /// an unnumbered line as it is.
    fn unwrap_line(&mut self, w: &mut super::Wire, raw: &str, cfg: &MarlinConfig) -> Option<String> {
        let mut line = raw.to_string();
        if line.starts_with('N') {
            let n: Option<u64> = line[1..].split(' ').next().and_then(|s| s.parse().ok());
            if n.is_some_and(|n| self.corrupt.remove(&n)) {
                // A bit flipped in transit, somewhere in the command.
                let mut b = line.clone().into_bytes();
                let i = b.len() / 2;
                b[i] ^= 0x04;
                line = String::from_utf8_lossy(&b).into_owned();
                w.record.lock().unwrap().corrupted += 1;
            }
            let star = line.rfind('*');
            let ok_sum = star.is_some_and(|i| line[i + 1..].trim().parse::<u8>().ok() == Some(checksum(&line[..i])));
            let n = line[1..].split(' ').next().and_then(|s| s.parse::<u64>().ok());
            let last_n = self.last_n;
            let fail = if !ok_sum {
                Some("checksum mismatch")
            } else if n != Some(last_n + 1) && !line.contains("M110") {
                Some("Line Number is not Last Line Number+1")
            } else {
                None
            };
            if let Some(why) = fail {
                w.say(&format!(
                    "Error:{why}, Last Line: {last_n}\nResend: {}\nok\n",
                    last_n + 1
                ));
                w.record.lock().unwrap().resends.push(last_n + 1);
                if cfg.flush_on_error {
                    w.rx.clear();
                }
                return None;
            }
            let star = star.unwrap();
            let body = line[..star]
                .split_once(' ')
                .map(|x| x.1)
                .unwrap_or("")
                .trim()
                .to_string();
            self.last_n = n.unwrap();
            Some(body)
        } else if line.contains('*') {
            w.say(&format!(
                "Error:No Line Number with checksum, Last Line: {}\nok\n",
                self.last_n
            ));
            None
        } else {
            Some(line)
        }
    }

    /// One command.
    fn command(&mut self, w: &mut super::Wire, line: &str, cfg: &MarlinConfig) -> Next {
        let pos = &mut self.pos;
        let cmd = line.split_whitespace().next().unwrap_or("");
        match cmd {
            "M110" => {
                self.last_n = word(line, 'N').unwrap_or(0.0) as u64;
                w.say("ok\n");
            }
            "M115" => w.say(
                "FIRMWARE_NAME:Marlin 2.1.2.1 (Jun 24 2023 12:00:00) SOURCE_CODE_URL:github.com/MarlinFirmware/Marlin PROTOCOL_VERSION:1.0 MACHINE_TYPE:Ender-3 EXTRUDER_COUNT:1\nCap:SERIAL_XON_XOFF:0\nCap:EEPROM:1\nok\n",
            ),
            "M211" => match cfg.bed {
                Some(b) => w.say(&format!(
                    "echo:Soft endstops: On   Min:  X0.00 Y0.00 Z0.00   Max:  X{:.2} Y{:.2} Z{:.2}\nok\n",
                    b[0], b[1], b[2]
                )),
                None => w.say("echo:Unknown command: \"M211\"\nok\n"),
            },
            "M503" => match cfg.m503 {
                Some((r, a)) => w.say(&format!(
                    "echo:; Maximum feedrates (units/s):\necho:  M203 X{:.2} Y{:.2} Z{:.2} E25.00\n\
                     echo:; Maximum Acceleration (units/s2):\necho:  M201 X{:.2} Y{:.2} Z{:.2} E5000.00\nok\n",
                    r[0], r[1], r[2], a[0], a[1], a[2]
                )),
                None => w.say("echo:Unknown command: \"M503\"\nok\n"),
            },
            "M114" => w.say(&format!(
                "X:{:.2} Y:{:.2} Z:{:.3} E:0.00 Count X:0 Y:0 Z:0\nok\n",
                pos[0], pos[1], pos[2]
            )),
            "M410" => {
                w.record.lock().unwrap().quickstops += 1;
                w.say("ok\n");
            }
            "M112" => {
                w.record.lock().unwrap().emergency += 1;
                w.say("Error:Printer halted. kill() called!\n");
                self.halted = true;
            }
            "G28" => {
                pos[0] = 0.0;
                pos[1] = 0.0;
                w.say("ok\n");
            }
            "G38.2" if cfg.g38 => {
                let target = word(line, 'Z').unwrap_or(pos[2]);
                match cfg.plane.map(|p| p.at(pos[0], pos[1])) {
                    Some(z) if z <= pos[2] && z >= target => {
                        pos[2] = z;
                        w.record.lock().unwrap().probes.push(*pos);
                        w.say("ok\n");
                    }
                    _ => {
                        pos[2] = target;
                        w.say("Error:Failed to reach target\nok\n");
                    }
                }
            }
            "G30" => match cfg.plane.map(|p| p.at(pos[0], pos[1])) {
                Some(z) => {
                    w.record.lock().unwrap().probes.push([pos[0], pos[1], z]);
                    w.say(&format!("Bed X: {:.3} Y: {:.3} Z: {:.4}\nok\n", pos[0], pos[1], z));
                }
                None => w.say("Error:Probing Failed\nok\n"),
            },
            "G0" | "G1" | "G2" | "G3" => {
                if cfg.busy {
                    w.say("echo:busy: processing\n");
                }
                apply_motion(line, pos);
                self.motions += 1;
                {
                    let mut r = w.record.lock().unwrap();
                    r.executed.push(line.to_string());
                    r.pos = *pos;
                }
                if cfg.halt_after == Some(self.motions) {
                    w.say("Error:Printer halted. kill() called!\n");
                    self.halted = true;
                    return Next::Go;
                }
                w.say("ok\n");
                if cfg.disconnect_after == Some(self.motions) {
                    return Next::Disconnect;
                }
            }
            "G21" | "G90" | "G91" | "G92" | "M400" | "M3" | "M5" | "G4" | "M2" => w.say("ok\n"),
            _ => w.say(&format!("echo:Unknown command: \"{line}\"\nok\n")),
        }
        Next::Go
    }
}
