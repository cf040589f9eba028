//! A fake GRBL 1.1: the 128-byte receive buffer (127 usable; more is an overflow), `ok` /
//! `error:N`, alarms, `?` status reports, `!` hold (Hold:1 then Hold:0), `~` resume, soft reset,
//! `$C` check mode, `$I`, `$$`, `$X`, `$H`, `$#`, G38.2 probing of a [`Plane`], and an injected
//! error, alarm or disconnect.
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

#[cfg(unix)]
use super::open_wire;
use super::{apply_motion, pipe_wire, spawn, word, Fake, Plane, Shared, Wire};
use crate::transport::PipeEnd;

#[derive(Clone, Debug)]
pub struct GrblConfig {
    /// Receive buffer size (GRBL: 128; 127 bytes usable).
    pub rx_size: usize,
    /// Time to execute one line (so the buffer fills as on a real machine).
    pub line_delay: Duration,
    /// Time from `!` to `Hold:0`.
    pub hold_decel: Duration,
    /// The n-th G-code line (1-based, counted over the fake's life) answers `error:code`.
    pub error_at: Option<(usize, u32)>,
    /// After the n-th motion line, `ALARM:code` (a hard limit, say).
    pub alarm_after: Option<(usize, u32)>,
    /// After the n-th motion line the fake closes its pty (a pulled cable).
    pub disconnect_after: Option<usize>,
    /// Starts in alarm (as after power-up with homing enabled).
    pub start_in_alarm: bool,
    /// The board resets when the port is opened (an Arduino Uno's DTR line): the position starts
    /// at zero, the first input is lost in the bootloader and the start-up banner follows it.
    pub reset_on_open: bool,
    /// With `reset_on_open`: no banner (one lost while the port was closed).
    pub quiet_reset: bool,
    /// `$$` settings (number -> value).
    pub settings: BTreeMap<u32, String>,
    /// The plate surface that G38.2 touches.
    pub plane: Option<Plane>,
}

impl Default for GrblConfig {
    fn default() -> Self {
        let settings = [
            (0, "10"),
            (1, "25"),
            (10, "1"),
            (13, "0"),
            (20, "0"),
            (22, "1"),
            (30, "12000"),
            (32, "0"),
            (110, "1000.000"),
            (111, "1000.000"),
            (112, "600.000"),
            (120, "200.000"),
            (121, "200.000"),
            (122, "50.000"),
            (130, "300.000"),
            (131, "180.000"),
            (132, "45.000"),
        ]
        .into_iter()
        .map(|(k, v)| (k, v.to_string()))
        .collect();
        GrblConfig {
            rx_size: 128,
            line_delay: Duration::from_micros(300),
            hold_decel: Duration::from_millis(30),
            error_at: None,
            alarm_after: None,
            disconnect_after: None,
            start_in_alarm: false,
            reset_on_open: false,
            quiet_reset: false,
            settings,
            plane: None,
        }
    }
}

pub struct FakeGrbl;

#[derive(Clone, Copy, PartialEq, Debug)]
enum St {
    Idle,
    Hold1(Instant),
    Hold0,
    Alarm,
    Check,
}

const BANNER: &str = "\r\nGrbl 1.1h ['$' for help]\r\n";

impl FakeGrbl {
    /// Starts a fake GRBL on a new pty.
    #[cfg(unix)]
    pub fn start(cfg: GrblConfig) -> std::io::Result<Fake> {
        Self::start_with(cfg, Shared::default())
    }

    /// Starts a fake that continues `record` (the machine after a reconnect).
    #[cfg(unix)]
    pub fn start_with(cfg: GrblConfig, record: Shared) -> std::io::Result<Fake> {
        record.lock().unwrap().disconnected = false;
        let (w, path) = open_wire(cfg.rx_size - 1, record.clone())?;
        Ok(Self::run(w, path, cfg, record))
    }

    /// A simulated controller on an in-memory pipe (`carve --port sim`, on every system): the
    /// fake, and the end to give [`crate::transport::Link::over`].
    pub fn simulated(cfg: GrblConfig) -> (Fake, PipeEnd) {
        let record = Shared::default();
        let (w, end) = pipe_wire(cfg.rx_size - 1, record.clone());
        (Self::run(w, "sim".into(), cfg, record), end)
    }

    fn run(mut w: Wire, path: String, cfg: GrblConfig, record: Shared) -> Fake {
        spawn(path, record.clone(), move |stop| {
            let mut m = Machine {
                st: if cfg.start_in_alarm { St::Alarm } else { St::Idle },
                pos: if cfg.reset_on_open {
                    [0.0; 3]
                } else {
                    record.lock().unwrap().pos
                },
                gcode_lines: 0,
                motions: 0,
                busy_until: Instant::now(),
                check_prev: St::Idle,
            };
            let mut booted = !cfg.reset_on_open;
            while !stop.load(Ordering::SeqCst) {
                let mut realtime = Vec::new();
                w.pump(|b| {
                    let rt = matches!(b, b'?' | b'!' | b'~' | 0x18);
                    if rt {
                        realtime.push(b);
                    }
                    rt
                });
                if !booted && (!w.rx.is_empty() || !realtime.is_empty()) {
                    // The reset on open: what came during the bootloader is lost.
                    booted = true;
                    w.rx.clear();
                    if !cfg.quiet_reset {
                        w.say(BANNER);
                    }
                    continue;
                }
                let moving = Instant::now() < m.busy_until || w.rx.contains(&b'\n');
                for b in realtime {
                    m.realtime(&mut w, b, moving);
                }
                if let St::Hold1(t) = m.st {
                    if t.elapsed() >= cfg.hold_decel {
                        m.st = St::Hold0;
                    }
                }
                if matches!(m.st, St::Hold0 | St::Hold1(_)) || Instant::now() < m.busy_until {
                    continue;
                }
                let Some(line) = w.take_line() else { continue };
                let line = line.trim().to_string();
                m.busy_until = Instant::now() + cfg.line_delay;
                if line.is_empty() {
                    w.say("ok\r\n");
                } else if let Some(cmd) = line.strip_prefix('$') {
                    m.dollar(&mut w, cmd, &cfg);
                } else if m.gcode(&mut w, &line, &cfg) == Next::Disconnect {
                    w.record.lock().unwrap().disconnected = true;
                    return; // dropping the wire closes both ends of the pty
                }
            }
        })
    }
}

/// What the fake does after a line of G-code.
#[derive(PartialEq)]
enum Next {
    Go,
    Disconnect,
}

/// The fake machine's state between lines.
struct Machine {
    st: St,
    pos: [f64; 3],
    /// G-code lines and motions executed so far (for `error_at`, `alarm_after`,
    /// `disconnect_after`).
    gcode_lines: usize,
    motions: usize,
    /// Until when the last line keeps the machine busy.
    busy_until: Instant,
    /// The state to return to when check mode ends.
    check_prev: St,
}

impl Machine {
    /// A real-time byte: `?` status, `!` feed hold, `~` resume, Ctrl-X soft reset.
    fn realtime(&mut self, w: &mut super::Wire, b: u8, moving: bool) {
        let pos = self.pos;
        match b {
            b'?' => {
                let name = match self.st {
                    St::Idle if moving => "Run".to_string(),
                    St::Idle => "Idle".into(),
                    St::Hold1(_) => "Hold:1".into(),
                    St::Hold0 => "Hold:0".into(),
                    St::Alarm => "Alarm".into(),
                    St::Check => "Check".into(),
                };
                w.say(&format!(
                    "<{name}|MPos:{:.3},{:.3},{:.3}|FS:0,0|WCO:0.000,0.000,0.000>\r\n",
                    pos[0], pos[1], pos[2]
                ));
            }
            b'!' if self.st == St::Idle => {
                self.st = St::Hold1(Instant::now());
                w.record.lock().unwrap().holds += 1;
            }
            // As GRBL 1.1h: a cycle start only once the hold is complete (`~` during
            // `Hold:1` is dropped).
            b'~' if self.st == St::Hold0 => {
                self.st = St::Idle;
                w.record.lock().unwrap().resumes += 1;
            }
            0x18 => {
                w.rx.clear();
                w.record.lock().unwrap().resets += 1;
                let in_motion = self.st == St::Idle && moving;
                // As GRBL 1.1h: a reset during motion reports ALARM:3 first, then restarts with
                // its banner and, in alarm, the unlock message.
                if in_motion {
                    w.say("ALARM:3\r\n");
                }
                w.say(BANNER);
                self.st = if in_motion || self.st == St::Alarm {
                    w.say("[MSG:'$H'|'$X' to unlock]\r\n");
                    St::Alarm
                } else {
                    St::Idle
                };
                self.busy_until = Instant::now();
            }
            _ => {}
        }
    }

    /// A `$` command (without its `$`).
    fn dollar(&mut self, w: &mut super::Wire, cmd: &str, cfg: &GrblConfig) {
        match cmd {
            "I" => w.say("[VER:1.1h.20190825:]\r\n[OPT:V,15,128]\r\nok\r\n"),
            "$" => {
                let mut s = String::new();
                for (k, v) in &cfg.settings {
                    s.push_str(&format!("${k}={v}\r\n"));
                }
                w.say(&s);
                w.say("ok\r\n");
            }
            "X" => {
                if self.st == St::Alarm {
                    self.st = St::Idle;
                    w.say("[MSG:Caution: Unlocked]\r\n");
                }
                w.say("ok\r\n");
            }
            "H" => {
                self.st = St::Idle;
                self.pos = [0.0, 0.0, 0.0];
                w.say("ok\r\n");
            }
            "C" => {
                if self.st == St::Check {
                    w.say("[MSG:Disabled]\r\nok\r\n");
                    w.say(BANNER);
                    w.rx.clear();
                    self.st = self.check_prev;
                } else if self.st == St::Alarm {
                    w.say("error:8\r\n");
                } else {
                    self.check_prev = self.st;
                    self.st = St::Check;
                    w.say("[MSG:Enabled]\r\nok\r\n");
                }
            }
            "#" => {
                w.say("[G54:0.000,0.000,0.000]\r\n[G92:0.000,0.000,0.000]\r\nok\r\n");
            }
            _ => w.say("ok\r\n"),
        }
    }

    /// A line of G-code (or a Marlin command, which GRBL refuses).
    fn gcode(&mut self, w: &mut super::Wire, line: &str, cfg: &GrblConfig) -> Next {
        if line.starts_with('M') && line.starts_with("M115") {
            w.say("error:20\r\n");
            return Next::Go;
        }
        if self.st == St::Alarm {
            w.say("error:9\r\n");
            return Next::Go;
        }
        self.gcode_lines += 1;
        if cfg.error_at.is_some_and(|(n, _)| n == self.gcode_lines) {
            w.say(&format!("error:{}\r\n", cfg.error_at.unwrap().1));
            return Next::Go;
        }
        if self.st == St::Check {
            w.record.lock().unwrap().checked.push(line.to_string());
            w.say("ok\r\n");
            return Next::Go;
        }
        if line.starts_with("G38.2") {
            let target = word(line, 'Z').unwrap_or(self.pos[2]);
            let contact = cfg.plane.map(|p| p.at(self.pos[0], self.pos[1]));
            match contact {
                Some(z) if z <= self.pos[2] && z >= target => {
                    self.pos[2] = z;
                    w.record.lock().unwrap().probes.push(self.pos);
                    w.say(&format!(
                        "[PRB:{:.3},{:.3},{:.3}:1]\r\nok\r\n",
                        self.pos[0], self.pos[1], self.pos[2]
                    ));
                }
                _ => {
                    // As GRBL 1.1h: the alarm, then the probe report (not touched: 0), then the
                    // line's own `ok`. The tool went down to the target.
                    self.pos[2] = target;
                    self.st = St::Alarm;
                    w.say(&format!(
                        "ALARM:5\r\n[PRB:{:.3},{:.3},{:.3}:0]\r\nok\r\n",
                        self.pos[0], self.pos[1], self.pos[2]
                    ));
                }
            }
            return Next::Go;
        }
        let motion = apply_motion(line, &mut self.pos);
        w.say("ok\r\n");
        if motion {
            self.motions += 1;
            let mut r = w.record.lock().unwrap();
            r.executed.push(line.to_string());
            r.pos = self.pos;
        }
        if let Some((n, code)) = cfg.alarm_after {
            if motion && n == self.motions {
                self.st = St::Alarm;
                w.rx.clear();
                w.say(&format!("ALARM:{code}\r\n"));
            }
        }
        if cfg.disconnect_after == Some(self.motions) && motion {
            return Next::Disconnect;
        }
        Next::Go
    }
}
