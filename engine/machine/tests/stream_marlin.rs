//! Streaming to a fake Marlin over a pty: line numbers and checksums, corrupted lines and
//! resends (repeated requests ignored), busy and temperature messages, a halt, a disconnect and
//! resume, Ctrl-C (M410 then raise; M112 only when asked), the bed check and firmware refusal.
// The fakes sit behind pseudo-terminals, which only Unix has.
#![cfg(unix)]
mod common;

use std::collections::BTreeSet;
use std::sync::atomic::Ordering;
use std::time::Duration;

use common::*;
use scratchart_machine::fake::{FakeMarlin, MarlinConfig};
use scratchart_machine::job::{carve, CarveError};
use scratchart_machine::program::Program;
use scratchart_machine::stream::Control;
use scratchart_tool::machine::MachineProfile;

/// The plan's motion lines in order, as the printer should execute them.
fn motions(plan: &std::path::Path) -> Vec<String> {
    Program::load(plan)
        .unwrap()
        .lines_from(0)
        .into_iter()
        .map(|l| l.0)
        .filter(|l| l.starts_with("G0") || l.starts_with("G1"))
        .collect()
}

#[test]
fn every_line_numbered_and_checksummed() {
    let dir = tmpdir("marlin_all");
    let plan = plan(&dir, "p.gcode", 60, &MachineProfile::marlin());
    let fake = FakeMarlin::start(MarlinConfig::default()).unwrap();
    let log = Log::default();
    carve(&options(&plan, fake.path()), &Control::default(), &log).unwrap();
    let r = fake.record();
    assert!(r.overflows.is_empty(), "{:?}", r.overflows);
    assert!(
        r.max_buffered <= 127 && r.max_buffered > 60,
        "buffer use {}",
        r.max_buffered
    );
    assert!(r.received.iter().any(|l| l.starts_with("N0 M110 N0*")));
    let numbered: Vec<&String> = r
        .received
        .iter()
        .filter(|l| l.starts_with('N') && !l.contains("M110"))
        .collect();
    let n = Program::load(&plan).unwrap().lines_from(0).len();
    assert_eq!(numbered.len(), n);
    for (k, l) in numbered.iter().enumerate() {
        assert!(l.starts_with(&format!("N{} ", k + 1)), "{l}");
        let (body, sum) = l.rsplit_once('*').unwrap();
        assert_eq!(sum.parse::<u8>().unwrap(), body.bytes().fold(0, |a, b| a ^ b));
    }
    assert_eq!(r.executed, motions(&plan));
    assert!(r.resends.is_empty());
}

fn corrupted(flush: bool) {
    let dir = tmpdir(&format!("marlin_corrupt_{flush}"));
    let plan = plan(&dir, "p.gcode", 40, &MachineProfile::marlin());
    let fake = FakeMarlin::start(MarlinConfig {
        corrupt: BTreeSet::from([9, 50, 51, 120]),
        flush_on_error: flush,
        ..MarlinConfig::default()
    })
    .unwrap();
    carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap();
    let r = fake.record();
    assert_eq!(r.corrupted, 4);
    assert!(r.overflows.is_empty(), "{:?}", r.overflows);
    // Every motion executed exactly once, in order: nothing lost, nothing doubled.
    assert_eq!(r.executed, motions(&plan));
    if !flush {
        // Lines behind a bad one are refused with their own (repeated) Resend: ignored.
        assert!(r.resends.len() > 4, "{:?}", r.resends);
    }
}

#[test]
fn corrupted_lines_are_resent_and_repeated_requests_ignored() {
    corrupted(false);
}

#[test]
fn corrupted_lines_are_resent_when_the_printer_flushes_its_buffer() {
    corrupted(true);
}

#[test]
fn busy_and_temperature_reports_are_ignored() {
    let dir = tmpdir("marlin_busy");
    let plan = plan(&dir, "p.gcode", 30, &MachineProfile::marlin());
    let fake = FakeMarlin::start(MarlinConfig {
        busy: true,
        temperature_every: Some(Duration::from_millis(3)),
        line_delay: Duration::from_millis(1),
        ..MarlinConfig::default()
    })
    .unwrap();
    let log = Log::default();
    carve(&options(&plan, fake.path()), &Control::default(), &log).unwrap();
    assert_eq!(fake.record().executed, motions(&plan));
    assert!(!log.says("busy") && !log.says("T:"));
}

#[test]
fn a_halt_stops_the_job() {
    let dir = tmpdir("marlin_halt");
    let plan = plan(&dir, "p.gcode", 30, &MachineProfile::marlin());
    let fake = FakeMarlin::start(MarlinConfig {
        halt_after: Some(33),
        ..MarlinConfig::default()
    })
    .unwrap();
    let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(
        e.to_string().contains("halted") && e.to_string().contains("--resume"),
        "{e}"
    );
    assert_eq!(fake.record().executed.len(), 33);
    // The halt lost the position: a resume that keeps it is refused before any motion, also on
    // a printer that restarts when the port opens; homing then finishes the job.
    let shared = fake.shared();
    drop(fake);
    for restart_on_open in [false, true] {
        let fake = FakeMarlin::start_with(
            MarlinConfig {
                restart_on_open,
                ..MarlinConfig::default()
            },
            shared.clone(),
        )
        .unwrap();
        let opts = resume_options(&plan, fake.path());
        let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
        let msg = e.to_string();
        assert_eq!(e.exit_code(), 1, "{msg}");
        assert!(
            msg.contains("position is lost") && msg.contains("halted") && msg.contains("--rezero home"),
            "{msg}"
        );
        assert_eq!(fake.record().executed.len(), 33, "nothing moved");
        drop(fake);
    }
    let fake = FakeMarlin::start_with(MarlinConfig::default(), shared).unwrap();
    let mut opts = resume_options(&plan, fake.path());
    opts.rezero = scratchart_machine::controller::Rezero::Home;
    carve(&opts, &Control::default(), &Log::default()).unwrap();
    assert_all_cut(&plan, &fake.record().executed);
}

/// A printer that restarts when the port opens (`start`) has lost its position since the last
/// acknowledged line: `--rezero keep` stops before any motion.
#[test]
fn a_restart_on_reconnect_stops_keep_before_any_motion() {
    let dir = tmpdir("marlin_restart");
    let plan = plan(&dir, "p.gcode", 30, &MachineProfile::marlin());
    let fake = FakeMarlin::start(MarlinConfig {
        disconnect_after: Some(41),
        ..MarlinConfig::default()
    })
    .unwrap();
    carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    let shared = fake.shared();
    let before = fake.record().executed.len();
    drop(fake);
    let fake = FakeMarlin::start_with(
        MarlinConfig {
            restart_on_open: true,
            ..MarlinConfig::default()
        },
        shared,
    )
    .unwrap();
    let opts = resume_options(&plan, fake.path());
    let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 1, "{msg}");
    assert!(msg.contains("restarted") && msg.contains("nothing moved"), "{msg}");
    assert_eq!(fake.record().executed.len(), before, "nothing moved");
}

#[test]
fn disconnect_then_resume_skips_nothing() {
    let dir = tmpdir("marlin_resume");
    let plan = plan(&dir, "p.gcode", 50, &MachineProfile::marlin());
    let fake = FakeMarlin::start(MarlinConfig {
        disconnect_after: Some(101),
        corrupt: BTreeSet::from([30]),
        ..MarlinConfig::default()
    })
    .unwrap();
    let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(e.to_string().contains("--resume"), "{e}");
    let shared = fake.shared();
    drop(fake);
    let fake = FakeMarlin::start_with(MarlinConfig::default(), shared).unwrap();
    let opts = resume_options(&plan, fake.path());
    let s = carve(&opts, &Control::default(), &Log::default()).unwrap();
    assert!(s.from > 0, "resumed at {}", s.from);
    let r = fake.record();
    assert!(assert_all_cut(&plan, &r.executed) <= 2);
    let twice = cut_lines(&plan)
        .iter()
        .filter(|c| r.executed.iter().filter(|e| e == c).count() == 2)
        .count();
    assert!(
        twice <= scratchart_machine::journal::RESUME_OVERLAP + 1,
        "{twice} cut twice"
    );
}

#[test]
fn ctrl_c_quickstops_and_raises_m112_only_when_asked() {
    for emergency in [false, true] {
        let dir = tmpdir(&format!("marlin_abort_{emergency}"));
        let plan = plan(&dir, "p.gcode", 40, &MachineProfile::marlin());
        let fake = FakeMarlin::start(MarlinConfig {
            line_delay: Duration::from_millis(2),
            ..MarlinConfig::default()
        })
        .unwrap();
        let control = Control::default();
        let mut opts = options(&plan, fake.path());
        opts.emergency = emergency;
        let e = std::thread::scope(|s| {
            let job = s.spawn(|| carve(&opts, &control, &Log::default()));
            while fake.record().executed.len() < 30 {
                std::thread::sleep(Duration::from_millis(5));
            }
            control.abort.store(true, Ordering::SeqCst);
            job.join().unwrap().unwrap_err()
        });
        assert!(matches!(e, CarveError::Interrupted(_)), "{e:?}");
        let r = fake.record();
        if emergency {
            assert_eq!((r.quickstops, r.emergency), (0, 1));
        } else {
            assert_eq!((r.quickstops, r.emergency), (1, 0));
            assert_eq!(r.pos[2], 2.0, "the tool ends at the safe height");
            assert!(r.executed.last().unwrap().starts_with("G0 Z2.000"));
        }
    }
}

#[test]
fn plate_larger_than_the_bed_and_grbl_plans_are_refused() {
    let dir = tmpdir("marlin_refuse");
    let plan_m = plan(&dir, "p.gcode", 5, &MachineProfile::marlin());
    let fake = FakeMarlin::start(MarlinConfig {
        bed: Some([80.0, 80.0, 100.0]),
        ..MarlinConfig::default()
    })
    .unwrap();
    let e = carve(&options(&plan_m, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 3, "{e}");
    assert!(e.to_string().contains("does not fit"), "{e}");
    let plan_g = plan(&dir, "p.nc", 5, &MachineProfile::grbl());
    let fake = FakeMarlin::start(MarlinConfig::default()).unwrap();
    let e = carve(&options(&plan_g, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 3, "{e}");
    assert!(e.to_string().contains("planned for grbl"), "{e}");
    // GRBL's check mode does not exist on Marlin: a bad flag.
    let mut opts = options(&plan_m, fake.path());
    opts.check = true;
    let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
    assert!(fake.record().executed.is_empty());
}
