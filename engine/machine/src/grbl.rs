//! GRBL 1.1: character counting (at most 127 of the 128-byte receive buffer unanswered), `?`
//! status reports, `!` hold, `~` resume, soft reset (0x18), `$C` check mode, `$I` and `$$` read
//! at the start.
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use crate::controller::{command, Controller, Fault, Reply, Rezero, Status};
use crate::grbl_codes;
use crate::planner::Kinematics;
use crate::program::Program;
use crate::transport::Link;
use scratchart_tool::machine::{Firmware, MachineProfile};

pub struct Grbl {
    version: String,
    rx: usize,
    /// Work coordinate offset from the last report that had one (`WCO:`).
    wco: Option<[f64; 3]>,
    last: Status,
    /// Machine position of the last report that had one.
    mpos: Option<[f64; 3]>,
    /// `$22` (homing cycle enabled), once `$$` was read.
    homing: Option<bool>,
    /// Why the position is lost (see [`Controller::position_lost`]).
    lost: Option<String>,
    /// `$110-$112` and `$120-$122`, once `$$` was read.
    kin: Option<Kinematics>,
}

/// Alarms after which GRBL's position is lost (GRBL 1.1's alarm table): 1 hard limit, 3 reset
/// while in motion, 6-9 a failed homing cycle. A soft limit (2) and a failed probe (4, 5) keep it.
const ALARMS_LOSING_POSITION: [u32; 6] = [1, 3, 6, 7, 8, 9];

fn nums(s: &str) -> Option<[f64; 3]> {
    let v: Vec<f64> = s.split(',').filter_map(|x| x.parse().ok()).collect();
    (v.len() >= 3).then(|| [v[0], v[1], v[2]])
}

/// Parses a status report `<State|MPos:x,y,z|...|WCO:x,y,z>` into the state, the work position
/// when it can be known, and the WCO field when present.
pub fn parse_status(line: &str) -> Option<(Status, Option<[f64; 3]>, Option<[f64; 3]>)> {
    let body = line.strip_prefix('<')?.strip_suffix('>')?;
    let mut fields = body.split('|');
    let state = fields.next()?.to_string();
    let (mut mpos, mut wpos, mut wco) = (None, None, None);
    for f in fields {
        if let Some(v) = f.strip_prefix("MPos:") {
            mpos = nums(v);
        } else if let Some(v) = f.strip_prefix("WPos:") {
            wpos = nums(v);
        } else if let Some(v) = f.strip_prefix("WCO:") {
            wco = nums(v);
        }
    }
    Some((Status { state, pos: wpos }, mpos, wco))
}

impl Grbl {
    /// A GRBL controller that answered `$I` with these lines.
    pub fn new(info: &[String]) -> Grbl {
        let mut g = Grbl {
            version: "GRBL".into(),
            rx: 128,
            wco: None,
            last: Status::default(),
            mpos: None,
            homing: None,
            lost: None,
            kin: None,
        };
        for l in info {
            if let Some(v) = l.strip_prefix("[VER:") {
                g.version = format!("GRBL {}", v.split(':').next().unwrap_or(""));
            } else if let Some(v) = l.strip_prefix("[OPT:") {
                if let Some(n) = v.trim_end_matches(']').split(',').nth(2).and_then(|s| s.parse().ok()) {
                    g.rx = n;
                }
            } else if l.starts_with("Grbl ") {
                g.version = l.split('[').next().unwrap_or(l).trim().to_string();
            }
        }
        g
    }

    /// Asks for a status report and waits for it (at most `timeout`).
    pub fn status(&mut self, link: &mut Link, timeout: Duration) -> Result<Status, Fault> {
        link.send(b"?")?;
        let t0 = Instant::now();
        while t0.elapsed() < timeout {
            if let Some(l) = link.line(Duration::from_millis(20))? {
                if let Reply::Status(s) = self.classify(&l) {
                    return Ok(s);
                }
            }
        }
        Err(Fault::Machine(format!(
            "{} sent no status report within {:.0} s",
            link.name(),
            timeout.as_secs_f64()
        )))
    }

    /// Polls the status until `done(state)` holds, at most `timeout`.
    fn wait_for(
        &mut self,
        link: &mut Link,
        what: &str,
        timeout: Duration,
        done: impl Fn(&str) -> bool,
    ) -> Result<Status, Fault> {
        let t0 = Instant::now();
        loop {
            let s = self.status(link, Duration::from_secs(2))?;
            if done(&s.state) {
                return Ok(s);
            }
            if t0.elapsed() > timeout {
                return Err(Fault::Machine(format!(
                    "the controller did not reach {what} within {:.0} s (state {})",
                    timeout.as_secs_f64(),
                    s.state
                )));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Soft reset (0x18), then waits for the start-up banner.
    fn soft_reset(&mut self, link: &mut Link) -> Result<(), Fault> {
        link.send(&[0x18])?;
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(3) {
            if let Some(l) = link.line(Duration::from_millis(50))? {
                if l.starts_with("Grbl ") {
                    return Ok(());
                }
            }
        }
        Err(Fault::Machine(
            "no start-up banner within 3 s after a soft reset".into(),
        ))
    }

    fn settings(&mut self, link: &mut Link) -> Result<BTreeMap<u32, f64>, Fault> {
        let lines = command(self, link, "$$", Duration::from_secs(3))?;
        let mut s = BTreeMap::new();
        for l in lines {
            if let Some((k, v)) = l.strip_prefix('$').and_then(|r| r.split_once('=')) {
                // `$130=300.000` (GRBL 1.1) or `$130=300.000 (x max travel, mm)` (older).
                let v = v.split_whitespace().next().unwrap_or("");
                if let (Ok(k), Ok(v)) = (k.trim().parse(), v.parse()) {
                    s.insert(k, v);
                }
            }
        }
        Ok(s)
    }
}

impl Controller for Grbl {
    fn firmware(&self) -> Firmware {
        Firmware::Grbl
    }

    fn describe(&self) -> String {
        self.version.clone()
    }

    fn window(&self) -> usize {
        self.rx.saturating_sub(1).min(127)
    }

    fn check_settings(
        &mut self,
        link: &mut Link,
        program: &Program,
        profile: Option<&MachineProfile>,
    ) -> Result<Vec<String>, Fault> {
        let s = self.settings(link)?;
        let get = |k: u32| s.get(&k).copied();
        self.homing = get(22).map(|v| v != 0.0);
        if let (Some(r), Some(a)) = (
            [get(110), get(111), get(112)].into_iter().collect::<Option<Vec<f64>>>(),
            [get(120), get(121), get(122)].into_iter().collect::<Option<Vec<f64>>>(),
        ) {
            if r.iter().chain(&a).all(|v| *v > 0.0 && v.is_finite()) {
                self.kin = Some(Kinematics {
                    rate_mm_min: [r[0], r[1], r[2]],
                    accel_mm_s2: [a[0], a[1], a[2]],
                    junction_deviation_mm: get(11)
                        .filter(|j| *j >= 0.0 && j.is_finite())
                        .unwrap_or(scratchart_tool::machine::MachineProfile::grbl().junction_deviation_mm),
                    source: "the controller's $110-$112 rates, $120-$122 accelerations and $11 junction deviation"
                        .into(),
                });
            }
        }
        let mut bad = Vec::new();
        let mut notes = Vec::new();
        if get(32) == Some(1.0) {
            bad.push(
                "laser mode is on ($32=1): GRBL would stop the spindle on every rapid move; set $32=0".to_string(),
            );
        }
        if get(13) == Some(1.0) {
            bad.push("reports are in inches ($13=1); set $13=0".to_string());
        }
        let plate = program.plate_mm.unwrap_or(2.0 * program.max_xy);
        for (k, axis) in [(130, "X"), (131, "Y")] {
            if let Some(t) = get(k) {
                if t + 1e-9 < plate {
                    bad.push(format!(
                        "{axis} travel ${k}={t} mm is smaller than the {plate} mm plate"
                    ));
                }
            }
        }
        let z_need = program.max_z - program.min_z;
        if let Some(t) = get(132) {
            if t + 1e-9 < z_need {
                bad.push(format!(
                    "Z travel $132={t} mm is smaller than the plan's {z_need} mm of Z"
                ));
            }
        }
        if let Some(m) = profile {
            if m.firmware != Firmware::Grbl {
                bad.push("the machine profile is for marlin, the controller is GRBL".into());
            }
            for (i, k) in [130u32, 131, 132].iter().enumerate() {
                if let Some(t) = get(*k) {
                    if t + 1e-9 < m.travel_mm[i] {
                        bad.push(format!(
                            "the profile's {} mm travel on {} is more than the controller's ${k}={t}",
                            m.travel_mm[i],
                            ["X", "Y", "Z"][i]
                        ));
                    }
                }
            }
            if let (Some(rpm), Some(max)) = (m.spindle_rpm, get(30)) {
                if rpm > max + 1e-9 {
                    bad.push(format!(
                        "the profile's spindle {rpm} rpm is above the controller's $30={max}"
                    ));
                }
            }
            for (k, axis) in [(110u32, "X"), (111, "Y")] {
                if let Some(v) = get(k) {
                    if m.cut_mm_min > v + 1e-9 {
                        bad.push(format!(
                            "the profile's cut feed {} mm/min is above the controller's {axis} rate ${k}={v}",
                            m.cut_mm_min
                        ));
                    }
                }
            }
        }
        // The plan's spindle speed against GRBL's range ($30 max, $31 min): GRBL clamps an S word
        // outside it without a word, so say so.
        if let Some(rpm) = program.spindle_rpm {
            if let Some(max) = get(30).filter(|&m| rpm > m + 1e-9) {
                notes.push(format!(
                    "warning: the plan's spindle speed S{rpm:.0} is above the controller's $30={max:.0}: \
                     GRBL clamps it to $30 (full PWM). If $30 is not your spindle's top speed, set it \
                     ($30=<rpm>) so that S means rpm"
                ));
            }
            if let Some(min) = get(31).filter(|&m| rpm + 1e-9 < m) {
                notes.push(format!(
                    "warning: the plan's spindle speed S{rpm:.0} is below the controller's $31={min:.0}: \
                     GRBL raises it to $31"
                ));
            }
        }
        if get(22) == Some(0.0) {
            notes.push("homing is off ($22=0): `--rezero home` will not work on this machine".into());
        }
        if bad.is_empty() {
            Ok(notes)
        } else {
            Err(Fault::Input(format!(
                "the controller's settings contradict the plan or the machine profile: {}",
                bad.join("; ")
            )))
        }
    }

    fn begin(&mut self, link: &mut Link, unlock: bool) -> Result<(), Fault> {
        let s = self.status(link, Duration::from_secs(2))?;
        if s.state.starts_with("Alarm") {
            self.lost.get_or_insert_with(|| {
                "the controller was in alarm when the job began (after a power-up with homing on, \
                 or an alarm, GRBL does not know where the machine is)"
                    .into()
            });
            if !unlock {
                return Err(Fault::Machine(
                    "the controller is in alarm (position unknown): home it ($H) or unlock it ($X) \
                     and set the work zero before carving"
                        .into(),
                ));
            }
            command(self, link, "$X", Duration::from_secs(2))?;
        } else if s.state == "Check" {
            self.check_mode(link, false)?;
        } else if s.state.starts_with("Hold") || s.state.starts_with("Door") {
            return Err(Fault::Machine(format!(
                "the controller is in {}: resume or reset it first",
                s.state
            )));
        }
        Ok(())
    }

    fn frame(&mut self, _seq: usize, line: &str) -> Vec<u8> {
        format!("{line}\n").into_bytes()
    }

    fn resend_index(&self, _n: u64) -> Option<usize> {
        None
    }

    fn classify(&mut self, line: &str) -> Reply {
        if line == "ok" {
            Reply::Ok
        } else if let Some(n) = line.strip_prefix("error:") {
            let n: u32 = n.trim().parse().unwrap_or(0);
            Reply::Error(format!("error:{n} ({})", grbl_codes::error(n)))
        } else if let Some(n) = line.strip_prefix("ALARM:") {
            let n: u32 = n.trim().parse().unwrap_or(0);
            let what = format!("ALARM:{n} ({})", grbl_codes::alarm(n));
            if ALARMS_LOSING_POSITION.contains(&n) {
                self.lost.get_or_insert_with(|| format!("the controller raised {what}"));
            }
            Reply::Stopped(what)
        } else if line.starts_with('<') {
            match parse_status(line) {
                Some((mut s, mpos, wco)) => {
                    if wco.is_some() {
                        self.wco = wco;
                    }
                    if mpos.is_some() {
                        self.mpos = mpos;
                    } else if let (Some(w), Some(o)) = (s.pos, self.wco) {
                        self.mpos = Some([w[0] + o[0], w[1] + o[1], w[2] + o[2]]);
                    }
                    if s.pos.is_none() {
                        if let (Some(m), Some(o)) = (mpos, self.wco) {
                            s.pos = Some([m[0] - o[0], m[1] - o[1], m[2] - o[2]]);
                        }
                    }
                    self.last = s.clone();
                    Reply::Status(s)
                }
                None => Reply::Info(line.to_string()),
            }
        } else if line.starts_with("Grbl ") {
            self.lost.get_or_insert_with(|| {
                format!(
                    "the controller reset (it printed its start-up banner `{}`; a board such as an \
                     Arduino Uno resets when the port opens): GRBL set its position to zero where \
                     the machine stood",
                    line.trim()
                )
            });
            Reply::Stopped(format!(
                "the controller reset itself (`{line}`): the position may be lost"
            ))
        } else {
            // `[...]` and `$...` reports, and anything else: shown, never acted on.
            Reply::Info(line.to_string())
        }
    }

    fn status_request(&self) -> Option<u8> {
        Some(b'?')
    }

    fn hold(&mut self, link: &mut Link) -> Result<(), Fault> {
        link.send(b"!")?;
        Ok(())
    }

    fn resume(&mut self, link: &mut Link) -> Result<(), Fault> {
        link.send(b"~")?;
        Ok(())
    }

    fn ready_to_resume(&self, state: &str) -> bool {
        // GRBL 1.1 takes a cycle start only once the hold is complete (or the machine idle): a
        // `~` while it still decelerates (`Hold:1`) is dropped and the job would wait for ever.
        state == "Hold:0" || state == "Idle"
    }

    fn stop_and_raise(
        &mut self,
        link: &mut Link,
        _pending: usize,
        safe_z: f64,
        _emergency: bool,
    ) -> Result<String, Fault> {
        link.send(b"!")?;
        let s = self.wait_for(link, "Hold:0", Duration::from_secs(20), |st| {
            st == "Hold:0" || st == "Idle" || st.starts_with("Alarm") || st == "Check"
        })?;
        self.soft_reset(link)?;
        let mut did = format!("feed hold ({}), soft reset", s.state);
        let after = self.status(link, Duration::from_secs(2))?;
        if after.state.starts_with("Alarm") {
            self.lost.get_or_insert_with(|| {
                format!(
                    "the soft reset that stopped the job left GRBL in alarm (the machine was still \
                     moving: {}): steps may be lost",
                    s.state
                )
            });
            command(self, link, "$X", Duration::from_secs(2))?;
            did.push_str(", unlocked ($X) to raise the tool");
        }
        let high = after.pos.or(self.last.pos).is_some_and(|p| p[2] >= safe_z);
        if !high {
            command(self, link, &format!("G21 G90 G0 Z{safe_z:.3}"), Duration::from_secs(5))?;
            self.wait_idle(link)?;
            did.push_str(&format!(", tool raised to Z{safe_z:.3}"));
        } else {
            did.push_str(", the tool was already above the safe height");
        }
        Ok(did)
    }

    fn wait_idle(&mut self, link: &mut Link) -> Result<(), Fault> {
        let s = self.wait_for(link, "Idle", Duration::from_secs(3600), |st| {
            st == "Idle" || st.starts_with("Alarm") || st == "Check"
        })?;
        if s.state.starts_with("Alarm") {
            return Err(Fault::Machine(format!("the controller went into {}", s.state)));
        }
        Ok(())
    }

    fn rezero(&mut self, link: &mut Link, how: Rezero, safe_z: f64, plunge: f64) -> Result<String, Fault> {
        let s = self.status(link, Duration::from_secs(2))?;
        let mut said = match how {
            Rezero::Home => {
                command(self, link, "$H", Duration::from_secs(120))?;
                "homed ($H); the work offset (G54) is kept by the controller".to_string()
            }
            Rezero::Keep | Rezero::Probe if s.state.starts_with("Alarm") => {
                command(self, link, "$X", Duration::from_secs(2))?;
                "unlocked ($X)".to_string()
            }
            Rezero::Keep | Rezero::Probe => "kept the controller's position".to_string(),
        };
        command(self, link, &format!("G21 G90 G0 Z{safe_z:.3}"), Duration::from_secs(5))?;
        if how == Rezero::Probe {
            let z = self.probe_z(link, safe_z + 5.0, plunge)?;
            command(self, link, &format!("G10 L20 P1 Z{:.4}", 0.0), Duration::from_secs(2))?;
            command(self, link, &format!("G0 Z{safe_z:.3}"), Duration::from_secs(5))?;
            said = format!("{said}; touched the plate at work Z {z:.4} and set Z0 there");
        }
        self.wait_idle(link)?;
        if how != Rezero::Keep {
            self.lost = None;
        }
        Ok(said)
    }

    fn position_lost(&self) -> Option<String> {
        self.lost.clone()
    }

    fn position_set(&mut self) {
        self.lost = None;
    }

    fn can_home(&self) -> Option<bool> {
        self.homing
    }

    fn machine_pos(&self) -> Option<[f64; 3]> {
        self.mpos
    }

    fn kinematics(&self) -> Option<Kinematics> {
        self.kin.clone()
    }

    fn check_mode(&mut self, link: &mut Link, on: bool) -> Result<(), Fault> {
        command(self, link, "$C", Duration::from_secs(3))?;
        if !on {
            // Leaving check mode soft-resets GRBL: its banner follows the `ok`.
            let t0 = Instant::now();
            while t0.elapsed() < Duration::from_secs(2) {
                if let Some(l) = link.line(Duration::from_millis(50))? {
                    if l.starts_with("Grbl ") {
                        break;
                    }
                }
            }
        }
        let s = self.status(link, Duration::from_secs(2))?;
        if (s.state == "Check") != on {
            return Err(Fault::Machine(format!(
                "the controller is in state {} after `$C`",
                s.state
            )));
        }
        Ok(())
    }

    fn probe_z(&mut self, link: &mut Link, depth: f64, feed: f64) -> Result<f64, Fault> {
        let probe = format!("G38.2 Z{:.3} F{feed:.0}", -depth);
        let lines = match command(self, link, &probe, Duration::from_secs(120)) {
            Ok(lines) => lines,
            Err(Fault::Machine(m)) if m.contains("ALARM:5") => {
                // GRBL 1.1h: ALARM:5, then `[PRB:...:0]`, then the line's `ok`; read them so
                // nothing of this probe is taken for the answer to a later line.
                let t0 = Instant::now();
                while t0.elapsed() < Duration::from_secs(2) {
                    match link.line(Duration::from_millis(50))? {
                        Some(l) if l == "ok" => break,
                        _ => {}
                    }
                }
                return Err(Fault::Machine(format!(
                    "the probe did not touch the plate within {depth} mm below Z0 (GRBL ALARM:5, \
                     probe fail); GRBL is in alarm and the tool is down there: check that the probe \
                     clip is on the tool and the plate is wired, raise the tool, unlock with `$X`, \
                     and try again (a larger --depth if Z0 is set too high)"
                )));
            }
            Err(f) => return Err(f),
        };
        let prb = lines
            .iter()
            .find_map(|l| l.strip_prefix("[PRB:"))
            .ok_or_else(|| Fault::Machine("G38.2 answered without a [PRB:...] report".into()))?;
        let (xyz, ok) = prb.trim_end_matches(']').rsplit_once(':').unwrap_or((prb, "0"));
        let m = nums(xyz).ok_or_else(|| Fault::Machine(format!("cannot read [PRB:{prb}")))?;
        if ok != "1" {
            return Err(Fault::Machine("the probe did not touch the plate".into()));
        }
        // PRB is in machine coordinates: subtract the G54 and G92 offsets.
        let mut off = [0.0; 3];
        for l in command(self, link, "$#", Duration::from_secs(2))? {
            for key in ["[G54:", "[G92:"] {
                if let Some(v) = l.strip_prefix(key).and_then(|v| nums(v.trim_end_matches(']'))) {
                    for i in 0..3 {
                        off[i] += v[i];
                    }
                }
            }
        }
        Ok(m[2] - off[2])
    }
}
