//! `carve --port sim`: the dry run streams any plan to the end through the built-in simulated
//! controller of the plan's firmware (an in-memory link: every system), states the job time,
//! reports progress in the design's numbering, and leaves no journal to resume.
mod common;

use common::*;
use scratchart_machine::job::{carve, CarveError, SIM_PORT};
use scratchart_machine::program::Program;
use scratchart_machine::stream::Control;
use scratchart_tool::machine::MachineProfile;

#[test]
fn a_dry_run_streams_the_whole_plan_on_either_firmware() {
    for (m, name) in [(MachineProfile::grbl(), "g.nc"), (MachineProfile::marlin(), "m.gcode")] {
        let dir = tmpdir(&format!("dry_{name}"));
        let plan = plan(&dir, name, 300, &m);
        let program = Program::load(&plan).unwrap();
        let log = Log::default();
        let s = carve(&options(&plan, SIM_PORT), &Control::default(), &log).unwrap();
        assert_eq!((s.from, s.total), (0, 300));
        let d = s.dry_run.expect("a dry run says what the simulated controller did");
        // Every motion line of the plan ran: 4 per cut, and the rapids of preamble and end.
        let motions = program
            .lines_from(0)
            .iter()
            .filter(|(l, _)| l.starts_with("G0") || l.starts_with("G1"))
            .count();
        assert!(d.contains(&format!("executed {motions} motion lines")), "{d}");
        assert!(
            d.contains("never overflowed") && d.contains("ends at X0.000 Y0.000"),
            "{d}"
        );
        // The job time, stated before the start, is the plan's by the profile's rates.
        let k = scratchart_machine::planner::Kinematics::of_profile(&m);
        let want = scratchart_observe::clock(program.timing(&k).from(0));
        assert!(
            log.says(&format!("job time on this machine: {want}")),
            "{want}: {:?}",
            log.notes
        );
        // Progress counts cuts and names each by the design's number.
        let p = log.progress.lock().unwrap();
        let last = p.last().unwrap();
        assert_eq!((last.done, last.total), (300, 300));
        assert_eq!(last.label, program.blocks[299].label);
        // Each cut once, in order; the last may repeat (with the position) while the machine
        // finishes the moves it has taken.
        assert!(p.windows(2).all(|w| w[0].done < w[1].done || w[0].done == 300));
        assert_eq!(p.iter().filter(|s| s.done < 300).count(), 299);
        // The position shown is the simulated machine's, out over the plate (not X0 Y0 Z0).
        let away = p.iter().filter(|s| s.pos.is_some_and(|q| q[0].abs() > 1.0)).count();
        assert!(away > 250, "{away} of 300 reports show the tool away from X0");
        // A rehearsal leaves nothing to resume beside the plan.
        assert!(!scratchart_machine::journal::default_path(&plan).exists());
    }
}

#[test]
fn a_dry_run_cannot_resume() {
    let dir = tmpdir("dry_resume");
    let plan = plan(&dir, "p.nc", 5, &MachineProfile::grbl());
    let e = carve(&resume_options(&plan, SIM_PORT), &Control::default(), &Log::default()).unwrap_err();
    assert!(matches!(e, CarveError::Usage(_)) && e.exit_code() == 2, "{e}");
}
