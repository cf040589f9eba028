//! Which firmware answers on the port: `carve` asks (`$I` for GRBL, `M115` for Marlin, in turn)
//! instead of waiting for a banner that may never come, and gives up with a clear error within a
//! few seconds.
use std::time::{Duration, Instant};

use crate::controller::{Controller, Fault};
use crate::grbl::Grbl;
use crate::marlin::Marlin;
use crate::transport::Link;

/// Asks the controller on `link` what it is, for at most `timeout`.
pub fn detect(link: &mut Link, timeout: Duration) -> Result<Box<dyn Controller>, Fault> {
    link.discard_input();
    let t0 = Instant::now();
    // Questions, in turn, about every 0.8 s: each is answered by exactly one `ok` or `error:`.
    let asks = ["$I", "M115"];
    let mut asked = 0usize;
    let mut answered = 0usize;
    let mut next_ask = Duration::ZERO;
    let mut seen: Vec<String> = Vec::new();
    let mut found: Option<Box<dyn Controller>> = None;
    while t0.elapsed() < timeout {
        if found.is_none() && t0.elapsed() >= next_ask {
            link.send(format!("{}\n", asks[asked % 2]).as_bytes())?;
            asked += 1;
            next_ask = t0.elapsed() + Duration::from_millis(800);
        }
        let Some(l) = link.line(Duration::from_millis(20))? else {
            if found.is_some() && t0.elapsed() > next_ask {
                // Questions sent before the board was up are never answered.
                break;
            }
            continue;
        };
        if l.starts_with("ok") || l.starts_with("error:") {
            answered += 1;
            // An answer that did not say what answers: ask the other question now.
            next_ask = next_ask.min(t0.elapsed());
        }
        seen.push(l.clone());
        if found.is_none() {
            let grbl = seen.iter().any(|s| s.starts_with("[VER:"));
            let marlin = seen.iter().any(|s| s.contains("FIRMWARE_NAME:"));
            let done = l.starts_with("ok") || l.starts_with("error:");
            if grbl && done {
                found = Some(Box::new(Grbl::new(&seen)));
            } else if marlin && done {
                found = Some(Box::new(Marlin::new(&seen)));
            } else if l.starts_with("Grbl ") || l == "start" || l.starts_with("echo:Marlin") {
                // A start-up banner: ask the matching question at once.
                let q = if l.starts_with("Grbl ") { 0 } else { 1 };
                link.send(format!("{}\n", asks[q]).as_bytes())?;
                asked += 1;
                next_ask = t0.elapsed() + Duration::from_millis(800);
            }
            if found.is_some() {
                next_ask = t0.elapsed() + Duration::from_millis(300);
            }
        }
        if found.is_some() && answered >= asked {
            break;
        }
    }
    if let Some(ctl) = found.as_mut() {
        // A start-up banner heard here means the board reset (when the port opened, say): the
        // controller records that its position is lost.
        for l in seen.iter().filter(|l| l.starts_with("Grbl ") || l.as_str() == "start") {
            let _ = ctl.classify(l);
        }
    }
    found.ok_or_else(|| {
        Fault::Machine(format!(
            "no GRBL or Marlin controller answered on {} within {:.0} s (asked `$I` and `M115`{}): \
             is the machine on, is this its port, and is --baud (default 115200) its speed?",
            link.name(),
            timeout.as_secs_f64(),
            if seen.is_empty() {
                ", heard nothing".to_string()
            } else {
                format!(", heard `{}`", seen[..seen.len().min(3)].join("` `"))
            }
        ))
    })
}
