//! Streaming to a fake GRBL 1.1 over a pty: character counting, errors, alarms, hold/resume,
//! abort, check mode, disconnect and resume, settings, firmware refusal, a silent port.
mod common;

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use common::*;
use scratchart_machine::fake::{FakeGrbl, GrblConfig};
use scratchart_machine::job::{carve, CarveError};
use scratchart_machine::plan::MachineProfile;
use scratchart_machine::stream::Control;

#[test]
fn streams_every_line_in_order_without_overflow() {
    let dir = tmpdir("grbl_all");
    let plan = plan(&dir, "p.nc", 60, &MachineProfile::grbl());
    let fake = FakeGrbl::start(GrblConfig::default()).unwrap();
    let log = Log::default();
    let s = carve(&options(&plan, fake.path()), &Control::default(), &log).unwrap();
    assert_eq!((s.from, s.total), (0, 60));
    let r = fake.record();
    assert!(r.overflows.is_empty(), "{:?}", r.overflows);
    assert!(
        r.max_buffered <= 127 && r.max_buffered > 60,
        "buffer use {}",
        r.max_buffered
    );
    // Every non-comment line of the plan reached the controller, in order, once.
    let program = scratchart_machine::program::Program::load(&plan).unwrap();
    let sent: Vec<String> = program.lines_from(0).into_iter().map(|l| l.0).collect();
    let got: Vec<String> = r
        .received
        .iter()
        .filter(|l| !l.starts_with('$') && *l != "M115")
        .cloned()
        .collect();
    assert_eq!(got, sent);
    assert_eq!(assert_all_cut(&plan, &r.executed), 1);
    let p = log.progress.lock().unwrap();
    assert_eq!(p.last().unwrap().done, 60);
    assert!(p.windows(2).all(|w| w[0].done < w[1].done));
    let j = scratchart_machine::journal::Journal::load(&options(&plan, "").journal).unwrap();
    assert_eq!((j.state.as_str(), j.last_acked), ("done", Some(59)));
}
