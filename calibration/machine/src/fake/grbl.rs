//! A fake GRBL 1.1: the 128-byte receive buffer (127 usable; more is an overflow), `ok` /
//! `error:N`, alarms, `?` status reports, `!` hold (Hold:1 then Hold:0), `~` resume, soft reset,
//! `$C` check mode, `$I`, `$$`, `$X`, `$H`, `$#`, G38.2 probing of a [`Plane`], and an injected
//! error, alarm or disconnect.
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use super::{apply_motion, open_wire, spawn, word, Fake, Plane, Shared};

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
    pub fn start(cfg: GrblConfig) -> std::io::Result<Fake> {
        Self::start_with(cfg, Shared::default())
    }

    /// Starts a fake that continues `record` (the machine after a reconnect).
    pub fn start_with(cfg: GrblConfig, record: Shared) -> std::io::Result<Fake> {
        record.lock().unwrap().disconnected = false;
        let (mut w, path) = open_wire(cfg.rx_size - 1, record.clone())?;
        Ok(spawn(path, record.clone(), move |stop| {
            let mut st = if cfg.start_in_alarm { St::Alarm } else { St::Idle };
            let mut pos = record.lock().unwrap().pos;
            let (mut gcode_lines, mut motions) = (0usize, 0usize);
            let mut busy_until = Instant::now();
            let mut check_prev = St::Idle;
            while !stop.load(Ordering::SeqCst) {
                let mut realtime = Vec::new();
                w.pump(|b| {
                    let rt = matches!(b, b'?' | b'!' | b'~' | 0x18);
                    if rt {
                        realtime.push(b);
                    }
                    rt
                });
                let moving = Instant::now() < busy_until || w.rx.contains(&b'\n');
                for b in realtime {
                    match b {
                        b'?' => {
                            let name = match st {
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
                        b'!' if st == St::Idle => {
                            st = St::Hold1(Instant::now());
                            w.record.lock().unwrap().holds += 1;
                        }
                        b'~' if matches!(st, St::Hold0 | St::Hold1(_)) => {
                            st = St::Idle;
                            w.record.lock().unwrap().resumes += 1;
                        }
                        0x18 => {
                            w.rx.clear();
                            w.record.lock().unwrap().resets += 1;
                            let in_motion = st == St::Idle && moving;
                            w.say(BANNER);
                            st = if in_motion || st == St::Alarm {
                                w.say("[MSG:'$H'|'$X' to unlock]\r\n");
                                if in_motion {
                                    w.say("ALARM:3\r\n");
                                }
                                St::Alarm
                            } else {
                                St::Idle
                            };
                            busy_until = Instant::now();
                        }
                        _ => {}
                    }
                }
                if let St::Hold1(t) = st {
                    if t.elapsed() >= cfg.hold_decel {
                        st = St::Hold0;
                    }
                }
                if matches!(st, St::Hold0 | St::Hold1(_)) || Instant::now() < busy_until {
                    continue;
                }
                let Some(line) = w.take_line() else { continue };
                let line = line.trim().to_string();
                busy_until = Instant::now() + cfg.line_delay;
                if line.is_empty() {
                    w.say("ok\r\n");
                    continue;
                }
                if let Some(cmd) = line.strip_prefix('$') {
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
                            if st == St::Alarm {
                                st = St::Idle;
                                w.say("[MSG:Caution: Unlocked]\r\n");
                            }
                            w.say("ok\r\n");
                        }
                        "H" => {
                            st = St::Idle;
                            pos = [0.0, 0.0, 0.0];
                            w.say("ok\r\n");
                        }
                        "C" => {
                            if st == St::Check {
                                w.say("[MSG:Disabled]\r\nok\r\n");
                                w.say(BANNER);
                                w.rx.clear();
                                st = check_prev;
                            } else if st == St::Alarm {
                                w.say("error:8\r\n");
                            } else {
                                check_prev = st;
                                st = St::Check;
                                w.say("[MSG:Enabled]\r\nok\r\n");
                            }
                        }
                        "#" => {
                            w.say("[G54:0.000,0.000,0.000]\r\n[G92:0.000,0.000,0.000]\r\nok\r\n");
                        }
                        _ => w.say("ok\r\n"),
                    }
                    continue;
                }
                if line.starts_with('M') && line.starts_with("M115") {
                    w.say("error:20\r\n");
                    continue;
                }
                if st == St::Alarm {
                    w.say("error:9\r\n");
                    continue;
                }
                gcode_lines += 1;
                if cfg.error_at.is_some_and(|(n, _)| n == gcode_lines) {
                    w.say(&format!("error:{}\r\n", cfg.error_at.unwrap().1));
                    continue;
                }
                if st == St::Check {
                    w.record.lock().unwrap().checked.push(line.clone());
                    w.say("ok\r\n");
                    continue;
                }
                if line.starts_with("G38.2") {
                    let target = word(&line, 'Z').unwrap_or(pos[2]);
                    let contact = cfg.plane.map(|p| p.at(pos[0], pos[1]));
                    match contact {
                        Some(z) if z <= pos[2] && z >= target => {
                            pos[2] = z;
                            w.record.lock().unwrap().probes.push(pos);
                            w.say(&format!("[PRB:{:.3},{:.3},{:.4}:1]\r\nok\r\n", pos[0], pos[1], pos[2]));
                        }
                        _ => {
                            st = St::Alarm;
                            w.say("ALARM:5\r\n");
                        }
                    }
                    continue;
                }
                let motion = apply_motion(&line, &mut pos);
                w.say("ok\r\n");
                if motion {
                    motions += 1;
                    let mut r = w.record.lock().unwrap();
                    r.executed.push(line.clone());
                    r.pos = pos;
                }
                if let Some((n, code)) = cfg.alarm_after {
                    if motion && n == motions {
                        st = St::Alarm;
                        w.rx.clear();
                        w.say(&format!("ALARM:{code}\r\n"));
                    }
                }
                if cfg.disconnect_after == Some(motions) && motion {
                    w.record.lock().unwrap().disconnected = true;
                    return; // dropping the wire closes both ends of the pty
                }
            }
        }))
    }
}
