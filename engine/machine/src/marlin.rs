//! Marlin: every line numbered and checksummed (`N<n> <code>*<xor>`, numbering set with
//! `M110 N0`), at most 127 bytes unanswered, `Resend: N` honoured, temperature reports and
//! `echo:busy: processing` ignored, `Error:Printer halted` and `!!` stop the job. Ctrl-C sends
//! M410 (quickstop) and raises Z when the printer answers; M112 only when asked.
use std::time::{Duration, Instant};

use crate::controller::{command, Controller, Fault, Reply, Rezero, Status};
use crate::planner::Kinematics;
use crate::program::Program;
use crate::transport::Link;
use scratchart_tool::machine::{Firmware, MachineProfile};

pub struct Marlin {
    name: String,
    z_feed: f64,
    /// Why the position is lost (see [`Controller::position_lost`]).
    lost: Option<String>,
    /// `M203` and `M201` from `M503`, once read.
    kin: Option<Kinematics>,
}

/// XOR of the bytes, as Marlin's checksum.
pub fn checksum(s: &str) -> u8 {
    s.bytes().fold(0, |a, b| a ^ b)
}

/// `N<n> <line>*<checksum>\n`.
pub fn frame_line(n: u64, line: &str) -> String {
    let s = format!("N{n} {line}");
    let c = checksum(&s);
    format!("{s}*{c}\n")
}

fn axis_value(line: &str, key: &str) -> Option<f64> {
    let i = line.find(key)? + key.len();
    let rest = line[i..].trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// The axes' top rates and accelerations from `M503`'s report (`echo:  M203 X500.00 Y500.00
/// Z5.00 E25.00`, mm/s; `echo:  M201 X500.00 Y500.00 Z100.00 E5000.00`, mm/s^2).
pub fn kinematics_of_m503(lines: &[String]) -> Option<Kinematics> {
    let find = |code: &str| -> Option<[f64; 3]> {
        let l = lines.iter().find_map(|l| l.split_once(code).map(|(_, rest)| rest))?;
        let v = [axis_value(l, "X")?, axis_value(l, "Y")?, axis_value(l, "Z")?];
        v.iter().all(|x| *x > 0.0 && x.is_finite()).then_some(v)
    };
    let rate = find("M203 ")?;
    let accel = find("M201 ")?;
    // Junction deviation (M205 J, where the printer plans with it; else the profile's).
    let jd = lines
        .iter()
        .find_map(|l| l.split_once("M205 ").map(|(_, rest)| rest))
        .and_then(|l| axis_value(l, "J"))
        .filter(|j| *j >= 0.0 && j.is_finite());
    Some(Kinematics {
        rate_mm_min: rate.map(|v| 60.0 * v),
        accel_mm_s2: accel,
        junction_deviation_mm: jd.unwrap_or(scratchart_tool::machine::MachineProfile::marlin().junction_deviation_mm),
        source: "the printer's M203 rates and M201 accelerations (M503)".into(),
    })
}

impl Marlin {
    /// A Marlin printer that answered M115 (or printed its start-up lines) with these lines.
    pub fn new(info: &[String]) -> Marlin {
        let mut name = "Marlin".to_string();
        for l in info {
            if let Some(i) = l.find("FIRMWARE_NAME:") {
                let rest = &l[i + 14..];
                let end = [rest.find(" SOURCE_CODE_URL"), rest.find(" (")]
                    .into_iter()
                    .flatten()
                    .min()
                    .unwrap_or(rest.len());
                name = rest[..end].trim().to_string();
            }
        }
        Marlin {
            name,
            z_feed: 300.0,
            lost: None,
            kin: None,
        }
    }

    /// Records the first cause of a lost position.
    fn lose(&mut self, why: &str) {
        self.lost.get_or_insert_with(|| why.to_string());
    }

    /// Waits for `n` answers (`ok`), at most `timeout` without any line from the printer.
    fn wait_oks(&mut self, link: &mut Link, n: usize, timeout: Duration) -> Result<(), Fault> {
        let mut got = 0;
        let mut last = Instant::now();
        while got < n {
            match link.line(Duration::from_millis(50))? {
                Some(l) => {
                    last = Instant::now();
                    match self.classify(&l) {
                        Reply::Ok => got += 1,
                        Reply::Stopped(e) => return Err(Fault::Machine(e)),
                        _ => {}
                    }
                }
                None if last.elapsed() > timeout => {
                    return Err(Fault::Machine(format!(
                        "the printer stopped answering ({got} of {n} answers within {:.0} s)",
                        timeout.as_secs_f64()
                    )))
                }
                None => {}
            }
        }
        Ok(())
    }
}

impl Controller for Marlin {
    fn firmware(&self) -> Firmware {
        Firmware::Marlin
    }

    fn describe(&self) -> String {
        self.name.clone()
    }

    fn window(&self) -> usize {
        127
    }

    fn check_settings(
        &mut self,
        link: &mut Link,
        program: &Program,
        profile: Option<&MachineProfile>,
    ) -> Result<Vec<String>, Fault> {
        let mut notes = Vec::new();
        let mut bad = Vec::new();
        let lines = command(self, link, "M211", Duration::from_secs(3))?;
        let bed = lines.iter().find(|l| l.contains("Max:")).and_then(|l| {
            let (lo, hi) = l.split_once("Max:")?;
            let lo = lo.split_once("Min:")?.1;
            let v = |s: &str, k: &str| axis_value(s, k);
            Some([
                v(hi, "X")? - v(lo, "X")?,
                v(hi, "Y")? - v(lo, "Y")?,
                v(hi, "Z")? - v(lo, "Z")?,
            ])
        });
        let plate = program.plate_mm.unwrap_or(2.0 * program.max_xy);
        match bed {
            Some(b) => {
                if plate > b[0] + 1e-9 || plate > b[1] + 1e-9 {
                    bad.push(format!(
                        "the {plate} mm plate does not fit the printer's {} x {} mm bed (M211)",
                        b[0], b[1]
                    ));
                }
                if let Some(m) = profile {
                    for i in 0..3 {
                        if m.travel_mm[i] > b[i] + 1e-9 {
                            bad.push(format!(
                                "the profile's {} mm travel on {} is more than the printer's {} mm (M211)",
                                m.travel_mm[i],
                                ["X", "Y", "Z"][i],
                                b[i]
                            ));
                        }
                    }
                }
            }
            None => {
                notes.push("the printer does not report its soft endstops (M211): the bed size is not checked".into())
            }
        }
        // The printer's own rates and accelerations (M503 lists M203 in mm/s and M201), for the
        // job time; a printer built without M503 answers `Unknown command`.
        if let Ok(lines) = command(self, link, "M503", Duration::from_secs(3)) {
            self.kin = kinematics_of_m503(&lines);
        }
        if self.kin.is_none() {
            notes.push(
                "the printer does not report its rates (M503 with M203 and M201): the job time is \
                 the machine profile's"
                    .into(),
            );
        }
        if let Some(m) = profile {
            if m.firmware != Firmware::Marlin {
                bad.push("the machine profile is for grbl, the printer runs Marlin".into());
            }
            self.z_feed = m.plunge_mm_min;
        }
        if bad.is_empty() {
            Ok(notes)
        } else {
            Err(Fault::Input(format!(
                "the printer contradicts the plan or the machine profile: {}",
                bad.join("; ")
            )))
        }
    }

    fn begin(&mut self, link: &mut Link, _unlock: bool) -> Result<(), Fault> {
        self.restart_numbering(link)
    }

    fn restart_numbering(&mut self, link: &mut Link) -> Result<(), Fault> {
        // Numbered itself (`N0 M110 N0*..`), as hosts send it: the next line is N1.
        let m110 = frame_line(0, "M110 N0");
        command(self, link, m110.trim_end(), Duration::from_secs(3))?;
        Ok(())
    }

    fn frame(&mut self, seq: usize, line: &str) -> Vec<u8> {
        frame_line(seq as u64 + 1, line).into_bytes()
    }

    fn resend_index(&self, n: u64) -> Option<usize> {
        n.checked_sub(1).map(|k| k as usize)
    }

    fn classify(&mut self, line: &str) -> Reply {
        let l = line.trim();
        if l.starts_with("ok") {
            Reply::Ok
        } else if let Some(n) = l.strip_prefix("Resend:").or(l.strip_prefix("rs ")) {
            match n.trim().parse() {
                Ok(n) => Reply::Resend(n),
                Err(_) => Reply::Info(l.to_string()),
            }
        } else if l == "!!" {
            self.lose("the printer halted (`!!`)");
            Reply::Stopped("the printer halted (`!!`)".into())
        } else if let Some(e) = l.strip_prefix("Error:").or(l.strip_prefix("error:")) {
            let low = e.to_ascii_lowercase();
            if low.contains("halted") || low.contains("kill") {
                self.lose(&format!("the printer halted (`{l}`)"));
                Reply::Stopped(format!("the printer halted (`{l}`)"))
            } else if low.contains("checksum") || low.contains("line number") {
                Reply::Ignore
            } else {
                Reply::Info(l.to_string())
            }
        } else if l.starts_with("echo:busy")
            || l.starts_with("busy:")
            || l.starts_with("T:")
            || l.contains(" T:")
            || l.starts_with("B:")
        {
            // Busy keep-alives and temperature reports.
            Reply::Ignore
        } else if l == "start" {
            self.lose("the printer restarted (it printed `start`; a board resets when the port opens): it set its position to zero where the tool stood");
            Reply::Stopped("the printer restarted (`start`): the position may be lost".into())
        } else {
            Reply::Info(l.to_string())
        }
    }

    fn status_request(&self) -> Option<u8> {
        None
    }

    fn hold(&mut self, _link: &mut Link) -> Result<(), Fault> {
        Ok(())
    }

    fn resume(&mut self, _link: &mut Link) -> Result<(), Fault> {
        Ok(())
    }

    fn stop_and_raise(
        &mut self,
        link: &mut Link,
        pending: usize,
        safe_z: f64,
        emergency: bool,
    ) -> Result<String, Fault> {
        if emergency {
            self.lose("the job was stopped by M112 (emergency stop)");
            link.send(b"M112\n")?;
            let t0 = Instant::now();
            while t0.elapsed() < Duration::from_secs(5) {
                if let Some(l) = link.line(Duration::from_millis(50))? {
                    if let Reply::Stopped(_) = self.classify(&l) {
                        return Ok("M112 emergency stop: the printer halted with the tool where it \
                                   was; reset the printer"
                            .into());
                    }
                }
            }
            return Ok("M112 emergency stop sent, but the printer did not confirm the halt: \
                       switch it off"
                .into());
        }
        // A quickstop halts the steppers without deceleration: steps may be lost.
        self.lose("the job was stopped by M410 (quickstop): steps may be lost");
        link.send(b"M410\n")?;
        self.wait_oks(link, pending + 1, Duration::from_secs(30))?;
        command(self, link, "G90", Duration::from_secs(5))?;
        let raise = format!("G0 Z{safe_z:.3} F{:.0}", self.z_feed);
        command(self, link, &raise, Duration::from_secs(5))?;
        self.wait_idle(link)?;
        Ok(format!("M410 quickstop, tool raised to Z{safe_z:.3}"))
    }

    fn wait_idle(&mut self, link: &mut Link) -> Result<(), Fault> {
        link.send(b"M400\n")?;
        self.wait_oks(link, 1, Duration::from_secs(60))
    }

    fn rezero(&mut self, link: &mut Link, how: Rezero, safe_z: f64, plunge: f64) -> Result<String, Fault> {
        command(self, link, "G21", Duration::from_secs(5))?;
        command(self, link, "G90", Duration::from_secs(5))?;
        let said = match how {
            Rezero::Home => {
                let raise = format!("G0 Z{safe_z:.3} F{:.0}", self.z_feed);
                command(self, link, &raise, Duration::from_secs(30))?;
                command(self, link, "G28 X Y", Duration::from_secs(120))?;
                "homed X and Y (G28 X Y; a G92 work offset is cleared by homing: set it again \
                 if you used one)"
                    .to_string()
            }
            Rezero::Probe => {
                let z = self.probe_z(link, safe_z + 5.0, plunge)?;
                command(self, link, "G92 Z0", Duration::from_secs(5))?;
                format!("touched the plate at Z {z:.4} and set Z0 there (G92 Z0)")
            }
            Rezero::Keep => "kept the printer's position".to_string(),
        };
        let raise = format!("G0 Z{safe_z:.3} F{:.0}", self.z_feed);
        command(self, link, &raise, Duration::from_secs(30))?;
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
        // A printer homes on its endstops (G28).
        Some(true)
    }

    fn machine_pos(&self) -> Option<[f64; 3]> {
        None
    }

    fn kinematics(&self) -> Option<Kinematics> {
        self.kin.clone()
    }

    fn check_mode(&mut self, _link: &mut Link, _on: bool) -> Result<(), Fault> {
        Err(Fault::Input(
            "--check runs GRBL's check mode ($C); Marlin has none".into(),
        ))
    }

    fn probe_z(&mut self, link: &mut Link, depth: f64, feed: f64) -> Result<f64, Fault> {
        let lines = command(
            self,
            link,
            &format!("G38.2 Z{:.3} F{feed:.0}", -depth),
            Duration::from_secs(120),
        )?;
        if lines.iter().any(|l| l.contains("Unknown command")) {
            // No G38 in this build: the bed probe (G30) reports the height it touched.
            let lines = command(self, link, "G30", Duration::from_secs(120))?;
            return lines
                .iter()
                .find(|l| l.contains("Bed X:"))
                .and_then(|l| axis_value(l, "Z:"))
                .ok_or_else(|| Fault::Machine("G30 answered without a `Bed X: Y: Z:` report".into()));
        }
        if let Some(e) = lines.iter().find(|l| l.starts_with("Error:")) {
            return Err(Fault::Machine(format!("probing failed: {e}")));
        }
        let pos = command(self, link, "M114", Duration::from_secs(5))?;
        pos.iter()
            .find_map(|l| axis_value(l.split("Count").next().unwrap_or(l), "Z:"))
            .ok_or_else(|| Fault::Machine("M114 answered without a Z position".into()))
    }
}

/// The state the engine shows for Marlin (it has no status report).
pub fn status(state: &str) -> Status {
    Status {
        state: state.into(),
        pos: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_from_m503() {
        let lines: Vec<String> = [
            "echo:; Maximum feedrates (units/s):",
            "echo:  M203 X500.00 Y500.00 Z5.00 E25.00",
            "echo:; Maximum Acceleration (units/s2):",
            "echo:  M201 X500.00 Y400.00 Z100.00 E5000.00",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let k = kinematics_of_m503(&lines).unwrap();
        assert_eq!(k.rate_mm_min, [30000.0, 30000.0, 300.0]);
        assert_eq!(k.accel_mm_s2, [500.0, 400.0, 100.0]);
        assert_eq!(kinematics_of_m503(&lines[..2]), None, "no M201: not known");
        assert_eq!(
            kinematics_of_m503(&["echo:Unknown command: \"M503\"".to_string()]),
            None
        );
    }

    #[test]
    fn frames_and_checksums() {
        // The checksum of "N1 G0 X1" by hand: XOR of its bytes.
        let s = "N1 G0 X1";
        let x = s.bytes().fold(0u8, |a, b| a ^ b);
        assert_eq!(frame_line(1, "G0 X1"), format!("{s}*{x}\n"));
        let mut m = Marlin::new(&["FIRMWARE_NAME:Marlin 2.1.2 (Jan 1) SOURCE_CODE_URL:x".into()]);
        assert_eq!(m.describe(), "Marlin 2.1.2");
        assert_eq!(m.classify("ok"), Reply::Ok);
        assert_eq!(m.classify("ok T:20.0 /0.0"), Reply::Ok);
        assert_eq!(m.classify("Resend: 7"), Reply::Resend(7));
        assert_eq!(m.classify(" T:25.0 /0.0 B:25.0 /0.0 @:0 B@:0"), Reply::Ignore);
        assert_eq!(m.classify("echo:busy: processing"), Reply::Ignore);
        assert_eq!(m.classify("Error:checksum mismatch, Last Line: 3"), Reply::Ignore);
        assert!(matches!(
            m.classify("Error:Printer halted. kill() called!"),
            Reply::Stopped(_)
        ));
        assert!(matches!(m.classify("!!"), Reply::Stopped(_)));
        assert_eq!(axis_value("X:1.00 Y:2.00 Z:-0.125 E:0.00", "Z:"), Some(-0.125));
    }
}
