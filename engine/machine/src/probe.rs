//! Levelling: probe the plate surface on a grid with the tool (`G38.2`; Marlin `G38.2`, or `G30`
//! without it) and return the [`HeightMap`] that `plan --heightmap` compensates.
use std::sync::atomic::Ordering;
use std::time::Duration;

use crate::controller::{command, Controller, Fault};
use crate::job::CarveError;
use crate::level::HeightMap;
use scratchart_observe::{MachineState, Observer, Progress};

use crate::stream::Control;
use crate::transport::{Link, LinkError};
use scratchart_tool::machine::Firmware;

pub struct ProbeOptions {
    pub port: String,
    pub baud: u32,
    /// Plate side, mm (work X0 Y0 at its centre).
    pub plate_mm: f64,
    /// Probes along X and Y.
    pub grid: (usize, usize),
    /// Distance of the outer probes from the plate's edges, mm.
    pub margin_mm: f64,
    /// Height of moves between probes, mm above Z0.
    pub safe_z_mm: f64,
    /// How far below Z0 a probe searches before it fails, mm.
    pub depth_mm: f64,
    /// Probe feed, mm/min.
    pub feed_mm_min: f64,
    pub detect_timeout: Duration,
}

/// The most probes along one axis.
pub const MAX_GRID: usize = 50;

/// Parses `NxM` (probes along X and Y), each 2..=[`MAX_GRID`].
pub fn parse_grid(s: &str) -> Result<(usize, usize), String> {
    let (a, b) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("--grid `{s}`: give it as NxM, e.g. 5x5"))?;
    let n = |t: &str| -> Result<usize, String> {
        let v: usize = t
            .trim()
            .parse()
            .map_err(|_| format!("--grid `{s}`: `{t}` is not a count"))?;
        if !(2..=MAX_GRID).contains(&v) {
            return Err(format!("--grid `{s}`: each count must be 2 to {MAX_GRID}"));
        }
        Ok(v)
    };
    Ok((n(a)?, n(b)?))
}

/// The probe positions along one axis: `n` evenly from `-h + margin` to `h - margin`.
pub fn axis(n: usize, plate: f64, margin: f64) -> Vec<f64> {
    let (a, b) = (-0.5 * plate + margin, 0.5 * plate - margin);
    (0..n).map(|k| a + (b - a) * k as f64 / (n - 1) as f64).collect()
}

fn moveto(ctl: &mut dyn Controller, link: &mut Link, words: &str) -> Result<(), Fault> {
    let feed = if ctl.firmware() == Firmware::Marlin {
        " F1500"
    } else {
        ""
    };
    command(ctl, link, &format!("G0 {words}{feed}"), Duration::from_secs(60)).map(|_| ())
}

/// Probes the grid and returns the height map (work coordinates). Ctrl-C raises the tool and
/// stops.
pub fn probe_grid(o: &ProbeOptions, control: &Control, obs: &dyn Observer) -> Result<HeightMap, CarveError> {
    if !(o.plate_mm > 0.0) || !(o.margin_mm >= 0.0) || 2.0 * o.margin_mm >= o.plate_mm {
        return Err(CarveError::Usage(format!(
            "--margin {} leaves nothing of the {} mm plate to probe",
            o.margin_mm, o.plate_mm
        )));
    }
    let mut link = Link::open(&o.port, o.baud).map_err(|e| match e {
        LinkError::Open(m) if !std::path::Path::new(&o.port).exists() => {
            CarveError::Usage(format!("{m} (no such port: check --port)"))
        }
        e => CarveError::Stopped(e.to_string()),
    })?;
    let fault = |f: Fault| match f {
        Fault::Input(m) => CarveError::Input(m),
        Fault::Machine(m) => CarveError::Stopped(format!("probing stopped: {m}")),
    };
    let mut ctl = crate::detect::detect(&mut link, o.detect_timeout).map_err(fault)?;
    obs.info(&format!("{} answers on {}", ctl.describe(), o.port));
    if ctl.firmware() == Firmware::Grbl {
        ctl.begin(&mut link, false).map_err(fault)?;
    }
    let (xs, ys) = (
        axis(o.grid.0, o.plate_mm, o.margin_mm),
        axis(o.grid.1, o.plate_mm, o.margin_mm),
    );
    let safe = format!("Z{:.3}", o.safe_z_mm);
    for c in ["G21", "G90"] {
        command(ctl.as_mut(), &mut link, c, Duration::from_secs(5)).map_err(fault)?;
    }
    moveto(ctl.as_mut(), &mut link, &safe).map_err(fault)?;
    let mut z = vec![vec![0.0; xs.len()]; ys.len()];
    let total = xs.len() * ys.len();
    for (j, &y) in ys.iter().enumerate() {
        for k in 0..xs.len() {
            // Serpentine rows: each row starts where the last ended.
            let i = if j % 2 == 0 { k } else { xs.len() - 1 - k };
            if control.abort.load(Ordering::SeqCst) {
                let _ = moveto(ctl.as_mut(), &mut link, &safe);
                return Err(CarveError::Interrupted(
                    "probing interrupted; the tool is raised".into(),
                ));
            }
            moveto(ctl.as_mut(), &mut link, &format!("X{:.4} Y{y:.4}", xs[i])).map_err(fault)?;
            z[j][i] = ctl
                .probe_z(&mut link, o.depth_mm, o.feed_mm_min)
                .map_err(|f| fault(Fault::Machine(format!("at X{:.3} Y{y:.3}: {f}", xs[i]))))?;
            moveto(ctl.as_mut(), &mut link, &safe).map_err(fault)?;
            let machine = MachineState {
                state: format!("Z {:.4} at X{:.2} Y{y:.2}", z[j][i], xs[i]),
                ..Default::default()
            };
            obs.progress(&Progress {
                task: "probe",
                done: (j * xs.len() + k + 1) as u64,
                total: total as u64,
                message: machine.message(),
                machine: Some(machine),
            });
        }
    }
    moveto(ctl.as_mut(), &mut link, "X0 Y0").map_err(fault)?;
    ctl.wait_idle(&mut link).map_err(fault)?;
    HeightMap::new(xs, ys, z).map_err(|e| CarveError::Stopped(format!("the probes make no height map: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_and_axes() {
        assert_eq!(parse_grid("5x3"), Ok((5, 3)));
        assert!(parse_grid("5").is_err());
        assert!(parse_grid("1x5").is_err());
        assert!(parse_grid("51x5").unwrap_err().contains("2 to 50"));
        assert_eq!(axis(3, 100.0, 10.0), vec![-40.0, 0.0, 40.0]);
    }
}
