//! The frame trace (`scratchart-cal frame`, `carve --frame`) on the simulated controllers of both
//! firmwares: the tool goes round the job's bounding box and the plate's outline at the
//! clearance height and comes back to X0 Y0; no line of it goes lower; with `--frame` the cuts
//! follow on the same connection, and Ctrl-C during the trace stops before any cut.
mod common;

use common::*;
use scratchart_machine::job::frame::{frame, lines, lowest_z};
use scratchart_machine::job::{carve, Options, SIM_PORT};
use scratchart_machine::program::Program;
use scratchart_machine::stream::Control;
use scratchart_observe::Progress;
use scratchart_tool::machine::MachineProfile;

/// Every (X, Y) that the absolute motion lines reach, in order.
fn points(lines: &[String]) -> Vec<[f64; 2]> {
    let w = |l: &str, c: char| {
        l.split_whitespace()
            .find_map(|t| t.strip_prefix(c)?.parse::<f64>().ok())
    };
    let mut at = [0.0, 0.0];
    let mut out = Vec::new();
    for l in lines {
        if let (Some(x), Some(y)) = (w(l, 'X'), w(l, 'Y')) {
            at = [x, y];
            out.push(at);
        } else if l.starts_with("G0") || l.starts_with("G1") {
            out.push(at);
        }
    }
    out
}

fn visits(pts: &[[f64; 2]], p: [f64; 2]) -> bool {
    pts.iter()
        .any(|q| (q[0] - p[0]).abs() < 1e-3 && (q[1] - p[1]).abs() < 1e-3)
}

#[test]
fn the_frame_goes_round_the_job_and_the_plate_at_the_clearance_height() {
    for (m, name) in [(MachineProfile::grbl(), "g.nc"), (MachineProfile::marlin(), "m.gcode")] {
        let dir = tmpdir(&format!("frame_{name}"));
        let plan = plan(&dir, name, 40, &m);
        let program = Program::load(&plan).unwrap();
        let b = program.xy_bounds().unwrap();
        // The job's box is the cuts' own extent, inside the 100 mm plate.
        assert!(b[0] < -30.0 && b[2] > 30.0 && b[0] >= -50.0 && b[2] <= 50.0, "{b:?}");
        let log = Log::default();
        let s = frame(&options(&plan, SIM_PORT), 700.0, &Control::default(), &log)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let d = s.dry_run.expect("a dry run says what the simulated controller did");
        let clear = m.clearance_mm;
        assert!(d.contains(&format!("none below Z{clear:.3}")), "{d}");
        assert!(d.contains(&format!("ends at X0.000 Y0.000 Z{clear:.3}")), "{d}");
        // What the controller was sent: the trace, nothing else (no spindle, no cut).
        let sent: Vec<String> = lines(&program, clear, 700.0)
            .unwrap()
            .into_iter()
            .map(|(l, _)| l)
            .collect();
        assert!(
            sent.iter().all(|l| !l.starts_with("M3") && !l.starts_with("G4")),
            "{sent:?}"
        );
        assert!(lowest_z(&sent).unwrap() >= clear, "{sent:?}");
        let pts = points(&sent);
        for c in [[b[0], b[1]], [b[2], b[1]], [b[2], b[3]], [b[0], b[3]]] {
            assert!(
                visits(&pts, c),
                "{name}: the job's corner {c:?} is not traced: {sent:?}"
            );
        }
        for c in [[-50.0, -50.0], [50.0, -50.0], [50.0, 50.0], [-50.0, 50.0]] {
            assert!(
                visits(&pts, c),
                "{name}: the plate's corner {c:?} is not traced: {sent:?}"
            );
        }
        assert_eq!(*pts.last().unwrap(), [0.0, 0.0]);
        // Progress names each part as it is done, the last back at X0 Y0 at the clearance.
        let p = log.progress.lock().unwrap();
        assert_eq!(p.last().map(|s| (s.done, s.total)), Some((3, 3)), "{name}");
        assert_eq!(p.last().unwrap().label, "back to X0 Y0");
        // A trace leaves no journal: the job has not started.
        assert!(!scratchart_machine::journal::default_path(&plan).exists());
    }
}

#[test]
fn a_machine_profile_sets_the_trace_height_and_a_bad_one_is_refused() {
    let m = MachineProfile::grbl();
    let dir = tmpdir("frame_profile");
    let plan = plan(&dir, "p.nc", 10, &m);
    let program = Program::load(&plan).unwrap();
    let opts = Options {
        profile: Some(MachineProfile {
            clearance_mm: 7.5,
            ..m.clone()
        }),
        ..options(&plan, SIM_PORT)
    };
    let s = frame(&opts, 500.0, &Control::default(), &Log::default()).unwrap();
    assert!(s.dry_run.unwrap().contains("none below Z7.500"));
    // A height at or under the surface, or no feed, is refused before anything is sent.
    assert!(lines(&program, 0.0, 500.0).is_err());
    assert!(lines(&program, 2.0, 0.0).is_err());
}

#[test]
fn carve_with_a_frame_traces_then_cuts_on_one_connection() {
    for (m, name) in [(MachineProfile::grbl(), "g.nc"), (MachineProfile::marlin(), "m.gcode")] {
        let dir = tmpdir(&format!("frame_carve_{name}"));
        let plan = plan(&dir, name, 20, &m);
        let program = Program::load(&plan).unwrap();
        let opts = Options {
            frame: Some(800.0),
            ..options(&plan, SIM_PORT)
        };
        let log = Log::default();
        let s = carve(&opts, &Control::default(), &log).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((s.from, s.total), (0, 20));
        let d = s.dry_run.unwrap();
        let motions = |ls: Vec<(String, Option<usize>)>| {
            ls.iter()
                .filter(|(l, _)| l.starts_with("G0") || l.starts_with("G1"))
                .count()
        };
        let want = motions(lines(&program, program.max_z, 800.0).unwrap()) + motions(program.lines_from(0));
        assert!(
            d.contains(&format!("executed {want} motion lines")),
            "{name}: want {want}: {d}"
        );
        assert!(log.says("frame: tracing the job's bounding box"), "{:?}", log.notes);
        // The frame's three parts come first, then the cuts.
        let p = log.progress.lock().unwrap();
        assert_eq!(p[2].label, "back to X0 Y0");
        assert_eq!((p.last().unwrap().done, p.last().unwrap().total), (20, 20));
    }
}

#[test]
fn ctrl_c_in_the_frame_stops_before_any_cut() {
    let dir = tmpdir("frame_abort");
    let plan = plan(&dir, "p.nc", 30, &MachineProfile::grbl());
    let control = Control::default();
    // Ctrl-C at the first report of the frame trace.
    let obs = AbortWhen::new(&control, |p: &Progress| p.task == "frame");
    let opts = Options {
        frame: Some(600.0),
        ..options(&plan, SIM_PORT)
    };
    let e = carve(&opts, &control, &obs).unwrap_err();
    assert_eq!(e.exit_code(), 130, "{e}");
    assert!(e.to_string().contains("nothing was cut"), "{e}");
    // No cut was reported and no journal was started.
    assert!(obs.log.progress.lock().unwrap().iter().all(|s| s.total == 3));
    assert!(!scratchart_machine::journal::default_path(&plan).exists());
}
