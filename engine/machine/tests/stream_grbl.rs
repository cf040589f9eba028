//! Streaming to a fake GRBL 1.1 over a pty: character counting, errors, alarms, hold/resume,
//! abort, check mode, disconnect and resume, settings, firmware refusal, a silent port.
// The fakes sit behind pseudo-terminals, which only Unix has.
#![cfg(unix)]
mod common;

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use common::*;
use scratchart_machine::fake::{FakeGrbl, GrblConfig};
use scratchart_machine::job::{carve, CarveError, Options};
use scratchart_machine::journal::Journal;
use scratchart_machine::stream::Control;
use scratchart_tool::machine::MachineProfile;

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
    // Each cut once, in order; the last may repeat while the machine finishes its moves.
    assert!(p.windows(2).all(|w| w[0].done < w[1].done || w[0].done == 60));
    assert_eq!(p.iter().filter(|s| s.done < 60).count(), 59);
    let j = scratchart_machine::journal::Journal::load(&options(&plan, "").journal).unwrap();
    assert_eq!((j.state.as_str(), j.last_acked), ("done", Some(59)));
}

fn slow() -> GrblConfig {
    GrblConfig {
        line_delay: Duration::from_millis(2),
        ..GrblConfig::default()
    }
}

#[test]
fn error_stops_the_stream_and_says_what_it_means() {
    let dir = tmpdir("grbl_error");
    let plan = plan(&dir, "p.nc", 30, &MachineProfile::grbl());
    let fake = FakeGrbl::start(GrblConfig {
        error_at: Some((40, 20)),
        ..slow()
    })
    .unwrap();
    let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 1, "{msg}");
    assert!(
        msg.contains("error:20") && msg.contains("unsupported or invalid G-code"),
        "{msg}"
    );
    assert!(msg.contains("--resume"), "{msg}");
    let r = fake.record();
    // The 40th G-code line was refused; nothing after the in-flight lines was executed, the
    // buffer was flushed by a soft reset after a hold, and the tool went up.
    assert_eq!(r.holds, 1);
    assert_eq!(r.resets, 1);
    assert!(r.executed.len() < 39 + 127 / 10, "{} lines ran", r.executed.len());
    assert_eq!(r.executed.last().unwrap(), "G21 G90 G0 Z2.000");
    let j = scratchart_machine::journal::Journal::load(&options(&plan, "").journal).unwrap();
    assert_eq!(j.state, "stopped");
    assert!(j.last_acked.unwrap() < 10);
}

#[test]
fn alarm_stops_the_stream() {
    let dir = tmpdir("grbl_alarm");
    let plan = plan(&dir, "p.nc", 30, &MachineProfile::grbl());
    let fake = FakeGrbl::start(GrblConfig {
        alarm_after: Some((25, 1)),
        ..slow()
    })
    .unwrap();
    let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 1, "{msg}");
    assert!(msg.contains("ALARM:1") && msg.contains("hard limit"), "{msg}");
    assert_eq!(fake.record().executed.len(), 25);
}

#[test]
fn hold_stops_motion_and_resume_finishes() {
    let dir = tmpdir("grbl_hold");
    let plan = plan(&dir, "p.nc", 40, &MachineProfile::grbl());
    let fake = FakeGrbl::start(slow()).unwrap();
    let control = Control::default();
    let opts = options(&plan, fake.path());
    std::thread::scope(|s| {
        let job = s.spawn(|| carve(&opts, &control, &Log::default()));
        while fake.record().executed.len() < 20 {
            std::thread::sleep(Duration::from_millis(5));
        }
        control.hold.store(true, Ordering::SeqCst);
        std::thread::sleep(Duration::from_millis(100));
        let during = fake.record().executed.len();
        std::thread::sleep(Duration::from_millis(150));
        assert_eq!(fake.record().executed.len(), during, "motion during a hold");
        assert_eq!(fake.record().holds, 1);
        control.resume.store(true, Ordering::SeqCst);
        job.join().unwrap().unwrap();
    });
    let r = fake.record();
    assert_eq!(r.resumes, 1);
    assert_eq!(assert_all_cut(&plan, &r.executed), 1);
}

#[test]
fn abort_holds_resets_and_raises_the_tool() {
    let dir = tmpdir("grbl_abort");
    let plan = plan(&dir, "p.nc", 40, &MachineProfile::grbl());
    let fake = FakeGrbl::start(slow()).unwrap();
    let control = Control::default();
    let opts = options(&plan, fake.path());
    let e = std::thread::scope(|s| {
        let job = s.spawn(|| carve(&opts, &control, &Log::default()));
        while fake.record().executed.len() < 30 {
            std::thread::sleep(Duration::from_millis(5));
        }
        control.abort.store(true, Ordering::SeqCst);
        job.join().unwrap().unwrap_err()
    });
    assert!(matches!(e, CarveError::Interrupted(_)), "{e:?}");
    assert_eq!(e.exit_code(), 130);
    assert!(e.to_string().contains("--resume"), "{e}");
    let r = fake.record();
    assert_eq!((r.holds, r.resets), (1, 1));
    assert_eq!(r.pos[2], 2.0, "the tool ends at the safe height");
    let j = scratchart_machine::journal::Journal::load(&opts.journal).unwrap();
    assert_eq!(j.state, "interrupted");
}

#[test]
fn check_mode_runs_the_whole_plan_first() {
    let dir = tmpdir("grbl_check");
    let plan = plan(&dir, "p.nc", 20, &MachineProfile::grbl());
    let fake = FakeGrbl::start(GrblConfig::default()).unwrap();
    let mut opts = options(&plan, fake.path());
    opts.check = true;
    let log = Log::default();
    carve(&opts, &Control::default(), &log).unwrap();
    let r = fake.record();
    let lines = scratchart_machine::program::Program::load(&plan).unwrap().lines_from(0);
    assert_eq!(r.checked.len(), lines.len());
    assert_eq!(assert_all_cut(&plan, &r.executed), 1);
    assert!(log.says("check mode: all"));
    // A line GRBL refuses in check mode: nothing moves at all.
    let fake = FakeGrbl::start(GrblConfig {
        error_at: Some((30, 33)),
        ..GrblConfig::default()
    })
    .unwrap();
    opts.port = fake.path().to_string();
    let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    assert!(
        e.to_string().contains("check mode") && e.to_string().contains("error:33"),
        "{e}"
    );
    assert_eq!(e.exit_code(), 1);
    assert!(fake.record().executed.is_empty());
}

#[test]
fn disconnect_then_resume_skips_nothing() {
    let dir = tmpdir("grbl_resume");
    let plan = plan(&dir, "p.nc", 50, &MachineProfile::grbl());
    let fake = FakeGrbl::start(GrblConfig {
        disconnect_after: Some(90),
        ..GrblConfig::default()
    })
    .unwrap();
    let opts = options(&plan, fake.path());
    let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(
        e.to_string().contains("lost the connection") && e.to_string().contains("--resume"),
        "{e}"
    );
    assert!(fake.record().disconnected);
    let shared = fake.shared();
    drop(fake);
    let fake = FakeGrbl::start_with(GrblConfig::default(), shared).unwrap();
    let opts = resume_options(&plan, fake.path());
    let log = Log::default();
    let s = carve(&opts, &Control::default(), &log).unwrap();
    assert!(s.from > 0 && s.from <= 22, "resumed at {}", s.from);
    assert!(log.says("--rezero keep") && log.says("--rezero home"));
    let r = fake.record();
    assert!(r.overflows.is_empty());
    assert!(assert_all_cut(&plan, &r.executed) <= 2);
    let twice = cut_lines(&plan)
        .iter()
        .filter(|c| r.executed.iter().filter(|e| e == c).count() == 2)
        .count();
    assert!(
        twice <= scratchart_machine::journal::RESUME_OVERLAP + 1,
        "{twice} cut twice"
    );
    // A changed plan is refused on resume (exit 3).
    std::fs::write(&plan, std::fs::read_to_string(&plan).unwrap() + "G0 X0 Y0\n").unwrap();
    let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 3, "{e}");
    assert!(e.to_string().contains("changed"), "{e}");
}

/// An unfinished job is never started again silently: without `--resume` or `--restart`, carve
/// stops before anything is sent (exit 2), naming both and leaving the journal as it was; the
/// resume advice on a machine that cannot home ($22=0) names `--rezero probe`, never `home`;
/// `--restart` runs the plan from its first cut and keeps the old journal beside the new.
#[test]
fn an_unfinished_job_is_resumed_or_restarted_never_overwritten() {
    let dir = tmpdir("grbl_restart");
    let plan = plan(&dir, "p.nc", 20, &MachineProfile::grbl());
    let mut cfg = GrblConfig {
        disconnect_after: Some(30),
        ..GrblConfig::default()
    };
    cfg.settings.insert(22, "0".into());
    let fake = FakeGrbl::start(cfg.clone()).unwrap();
    carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    let journal = options(&plan, "").journal;
    let text = std::fs::read_to_string(&journal).unwrap();
    let before = Journal::load(&journal).unwrap();
    assert!(before.state != "done" && before.last_acked.is_some(), "{text}");
    let (shared, sent) = (fake.shared(), fake.record().executed.len());
    drop(fake);
    cfg.disconnect_after = None;
    let fake = FakeGrbl::start_with(cfg.clone(), shared).unwrap();
    let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2, "{msg}");
    assert!(
        msg.contains("unfinished job")
            && msg.contains("--resume")
            && msg.contains("--restart")
            && msg.contains("Nothing was sent"),
        "{msg}"
    );
    assert_eq!(fake.record().executed.len(), sent, "nothing moved");
    assert_eq!(
        std::fs::read_to_string(&journal).unwrap(),
        text,
        "the journal is as it was"
    );
    // Resumed with the default --rezero keep: the advice names what this machine can do.
    let log = Log::default();
    carve(&resume_options(&plan, fake.path()), &Control::default(), &log).unwrap();
    let notes = log.notes.lock().unwrap().clone();
    let keep = notes
        .iter()
        .find(|n| n.starts_with("--rezero keep"))
        .expect("the keep note");
    assert!(
        keep.contains("--rezero probe") && !keep.contains("--rezero home"),
        "{keep}"
    );
    // Finished: a new run starts afresh without asking (nothing is lost).
    assert_eq!(Journal::load(&journal).unwrap().state, "done");
    let shared = fake.shared();
    drop(fake);
    // An unfinished journal again, then --restart: from the first cut, the old journal kept.
    cfg.disconnect_after = Some(30);
    let fake = FakeGrbl::start_with(cfg.clone(), shared).unwrap();
    carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    let unfinished = std::fs::read_to_string(&journal).unwrap();
    let (shared, sent) = (fake.shared(), fake.record().executed.len());
    drop(fake);
    cfg.disconnect_after = None;
    let fake = FakeGrbl::start_with(cfg, shared).unwrap();
    let log = Log::default();
    let opts = Options {
        restart: true,
        ..options(&plan, fake.path())
    };
    let s = carve(&opts, &Control::default(), &log).unwrap();
    assert_eq!(s.from, 0, "from the first cut");
    assert!(log.says("--restart"), "{:?}", log.notes);
    let kept = journal.with_file_name(format!("{}.1", journal.file_name().unwrap().to_string_lossy()));
    assert_eq!(
        std::fs::read_to_string(&kept).unwrap(),
        unfinished,
        "the old journal kept beside"
    );
    assert_eq!(Journal::load(&journal).unwrap().state, "done");
    let executed = &fake.record().executed[sent..];
    assert_eq!(assert_all_cut(&plan, executed), 1, "every cut once more");
}

/// A board that resets when the port opens (an Arduino Uno's DTR line) has lost its position:
/// a resume with the default `--rezero keep` stops before any motion (exit 1, saying why and
/// which `--rezero` this machine allows), also on a later port that does not reset (the journal
/// remembers), and also where the reset's banner was never heard (the machine position is back
/// at zero); `--rezero home` then finishes the job.
#[test]
fn a_reset_since_the_last_line_stops_keep_before_any_motion() {
    for quiet in [false, true] {
        let dir = tmpdir(if quiet { "grbl_reset_quiet" } else { "grbl_reset" });
        let plan = plan(&dir, "p.nc", 30, &MachineProfile::grbl());
        // At a pace where status reports come (every 200 ms), as on a machine.
        let fake = FakeGrbl::start(GrblConfig {
            disconnect_after: Some(60),
            line_delay: Duration::from_millis(10),
            ..GrblConfig::default()
        })
        .unwrap();
        let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
        assert_eq!(e.exit_code(), 1, "{e}");
        let shared = fake.shared();
        let cut_before = fake.record().executed.len();
        drop(fake);
        let fake = FakeGrbl::start_with(
            GrblConfig {
                reset_on_open: true,
                quiet_reset: quiet,
                ..GrblConfig::default()
            },
            shared,
        )
        .unwrap();
        let opts = resume_options(&plan, fake.path());
        let e = carve(&opts, &Control::default(), &Log::default())
            .expect_err(&format!("quiet {quiet}: {:?}", Journal::load(&opts.journal)));
        let msg = e.to_string();
        assert_eq!(e.exit_code(), 1, "{msg}");
        assert!(
            msg.contains("position is lost") && msg.contains("nothing moved") && msg.contains("--rezero home"),
            "{msg}"
        );
        assert!(msg.contains(if quiet { "0, 0, 0" } else { "start-up banner" }), "{msg}");
        assert_eq!(
            fake.record().executed.len(),
            cut_before,
            "nothing moved after the reset"
        );
        let journal = Journal::load(&opts.journal).unwrap();
        assert!(journal.position_lost.is_some(), "{journal:?}");
        assert!(journal.last_acked.is_some());
        let shared = fake.shared();
        drop(fake);

        // The next port does not reset, but the journal remembers.
        let fake = FakeGrbl::start_with(GrblConfig::default(), shared).unwrap();
        let mut opts = resume_options(&plan, fake.path());
        let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
        assert!(e.to_string().contains("position is lost"), "{e}");
        assert_eq!(fake.record().executed.len(), cut_before);

        // Homing restores it: the job finishes, every cut made.
        opts.rezero = scratchart_machine::controller::Rezero::Home;
        let log = Log::default();
        carve(&opts, &Control::default(), &log).unwrap();
        assert!(log.says("homed ($H)"));
        assert_all_cut(&plan, &fake.record().executed);
        let journal = Journal::load(&opts.journal).unwrap();
        assert_eq!((journal.state.as_str(), journal.position_lost), ("done", None));
    }
}

/// `--rezero home` on a machine without homing (`$22=0`) is a flag that cannot work: exit 2
/// before anything is sent, naming what to do instead.
#[test]
fn rezero_home_without_homing_is_refused_before_anything_moves() {
    let dir = tmpdir("grbl_no_homing");
    let plan = plan(&dir, "p.nc", 20, &MachineProfile::grbl());
    let mut cfg = GrblConfig {
        disconnect_after: Some(30),
        ..GrblConfig::default()
    };
    cfg.settings.insert(22, "0".into());
    let fake = FakeGrbl::start(cfg.clone()).unwrap();
    carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    let (shared, before) = (fake.shared(), fake.record().executed.len());
    drop(fake);
    cfg.disconnect_after = None;
    let fake = FakeGrbl::start_with(cfg, shared).unwrap();
    let opts = Options {
        rezero: scratchart_machine::controller::Rezero::Home,
        ..resume_options(&plan, fake.path())
    };
    let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
    assert!(
        e.to_string().contains("$22=0") && e.to_string().contains("--rezero probe"),
        "{e}"
    );
    assert_eq!(fake.record().executed.len(), before, "nothing moved");
}

/// A resumed run re-sends a few scratches before the last acknowledged one: the journal never
/// goes back to them, even when the resumed run stops early.
#[test]
fn the_journal_never_goes_backwards() {
    let dir = tmpdir("grbl_journal_monotone");
    let plan = plan(&dir, "p.nc", 40, &MachineProfile::grbl());
    let fake = FakeGrbl::start(GrblConfig {
        disconnect_after: Some(80),
        ..GrblConfig::default()
    })
    .unwrap();
    let opts = options(&plan, fake.path());
    carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    let first = Journal::load(&opts.journal).unwrap().last_acked.unwrap();
    assert!(first >= scratchart_machine::journal::RESUME_OVERLAP, "{first}");
    let shared = fake.shared();
    drop(fake);
    // The resumed run loses the link again after ten motions (two or three scratches): within
    // the overlap.
    let fake = FakeGrbl::start_with(
        GrblConfig {
            disconnect_after: Some(10),
            ..GrblConfig::default()
        },
        shared,
    )
    .unwrap();
    let opts = resume_options(&plan, fake.path());
    carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    let second = Journal::load(&opts.journal).unwrap().last_acked.unwrap();
    assert!(second >= first, "the journal went from {first} back to {second}");
}

/// GRBL clamps a spindle speed outside `$30`/`$31` without a word: `carve` says so before it
/// starts (the plan's `M3 S10000` against the firmware's default `$30=1000`).
#[test]
fn a_spindle_speed_outside_the_controllers_range_is_named() {
    let dir = tmpdir("grbl_spindle");
    let plan = plan(&dir, "p.nc", 3, &MachineProfile::grbl());
    let mut cfg = GrblConfig::default();
    cfg.settings.insert(30, "1000".into());
    let fake = FakeGrbl::start(cfg).unwrap();
    let log = Log::default();
    carve(&options(&plan, fake.path()), &Control::default(), &log).unwrap();
    assert!(
        log.says("S10000 is above the controller's $30=1000"),
        "{:?}",
        log.notes.lock().unwrap()
    );
    let fake = FakeGrbl::start(GrblConfig::default()).unwrap();
    let log = Log::default();
    carve(&options(&plan, fake.path()), &Control::default(), &log).unwrap();
    assert!(!log.says("$30"), "{:?}", log.notes.lock().unwrap());
}

#[test]
fn settings_that_contradict_the_plan_are_refused() {
    let dir = tmpdir("grbl_settings");
    let plan = plan(&dir, "p.nc", 5, &MachineProfile::grbl());
    for (k, v, what) in [(131, "80.000", "$131=80"), (32, "1", "laser mode")] {
        let mut cfg = GrblConfig::default();
        cfg.settings.insert(k, v.into());
        let fake = FakeGrbl::start(cfg).unwrap();
        let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
        assert_eq!(e.exit_code(), 3, "{e}");
        assert!(e.to_string().contains(what), "{e}");
        assert!(fake.record().executed.is_empty());
    }
    // A profile with more travel than the controller has.
    let fake = FakeGrbl::start(GrblConfig::default()).unwrap();
    let mut opts = options(&plan, fake.path());
    let mut m = MachineProfile::grbl();
    m.travel_mm[0] = 400.0;
    opts.profile = Some(m);
    let e = carve(&opts, &Control::default(), &Log::default()).unwrap_err();
    assert!(e.to_string().contains("$130"), "{e}");
}

#[test]
fn a_plan_for_marlin_is_refused() {
    let dir = tmpdir("grbl_refuse");
    let plan = plan(&dir, "p.gcode", 5, &MachineProfile::marlin());
    let fake = FakeGrbl::start(GrblConfig::default()).unwrap();
    let e = carve(&options(&plan, fake.path()), &Control::default(), &Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 3, "{e}");
    assert!(
        e.to_string().contains("planned for marlin") && e.to_string().contains("--machine grbl"),
        "{e}"
    );
    assert!(fake.record().executed.is_empty());
}

#[test]
fn a_silent_port_gives_a_clear_error_within_seconds() {
    let dir = tmpdir("silent");
    let plan = plan(&dir, "p.nc", 5, &MachineProfile::grbl());
    let (_master, slave) = serialport::TTYPort::pair().unwrap();
    let path = serialport::SerialPort::name(&slave).unwrap();
    let t0 = Instant::now();
    let e = carve(&options(&plan, &path), &Control::default(), &Log::default()).unwrap_err();
    let took = t0.elapsed();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(e.to_string().contains("no GRBL or Marlin controller answered"), "{e}");
    assert!(took < Duration::from_secs(5), "took {took:?}");
    // A port that does not exist is a bad flag.
    let e = carve(
        &options(&plan, "/dev/nonexistent-port"),
        &Control::default(),
        &Log::default(),
    )
    .unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
}

#[test]
fn the_fake_records_an_overflow() {
    // The overflow check of the fake itself: a sender that ignores the buffer is caught.
    use std::io::Write;
    let fake = FakeGrbl::start(GrblConfig {
        line_delay: Duration::from_secs(1),
        ..GrblConfig::default()
    })
    .unwrap();
    let mut port = serialport::new(fake.path(), 115200).open_native().unwrap();
    // Six lines of 63 bytes in one write: even if the fake takes the first line on its own
    // before the rest arrive (a loaded machine splits the stream), it executes one line a
    // second, and the other five (315 bytes) overflow its 128-byte buffer.
    let line = format!("G1 X{} Y1 F100\n", "1".repeat(50));
    port.write_all(line.repeat(6).as_bytes()).unwrap();
    // (waits for the fake's thread to read it, up to 5 s on a loaded machine)
    let t0 = std::time::Instant::now();
    while fake.record().overflows.is_empty() && t0.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(!fake.record().overflows.is_empty());
}

#[test]
fn the_job_time_is_the_machines_own() {
    // `carve` states the job time from the controller's $110-$112 and $120-$122 before it
    // starts: the same plan on a machine half as fast takes longer, and the estimate is the
    // plan's timing by those rates.
    let dir = tmpdir("grbl_time");
    let plan = plan(&dir, "p.nc", 20, &MachineProfile::grbl());
    let program = scratchart_machine::program::Program::load(&plan).unwrap();
    let stated = |rates: [&str; 6]| -> String {
        let mut cfg = GrblConfig::default();
        for (k, v) in [110u32, 111, 112, 120, 121, 122].into_iter().zip(rates) {
            cfg.settings.insert(k, v.to_string());
        }
        let fake = FakeGrbl::start(cfg).unwrap();
        let log = Log::default();
        carve(&options(&plan, fake.path()), &Control::default(), &log).unwrap();
        let notes = log.notes.lock().unwrap().clone();
        let note = notes
            .iter()
            .find(|n| n.starts_with("job time on this machine: "))
            .unwrap_or_else(|| panic!("no job time in {notes:?}"))
            .clone();
        assert!(
            note.contains("$110-$112") && note.contains("for cuts 1 to 20"),
            "{note}"
        );
        // The progress's ETA comes from the same model: at the start, about the whole job.
        let p = log.progress.lock().unwrap();
        assert!(p.first().unwrap().eta_s.unwrap() > 0.0);
        note["job time on this machine: ".len()..]
            .split(' ')
            .next()
            .unwrap()
            .to_string()
    };
    let secs = |c: &str| -> f64 {
        let v: Vec<f64> = c.split(':').map(|x| x.parse().unwrap()).collect();
        v[0] * 3600.0 + v[1] * 60.0 + v[2]
    };
    let fast = stated(["1000", "1000", "600", "200", "200", "50"]);
    let slow = stated(["500", "500", "300", "100", "100", "25"]);
    let want = |r: [f64; 3], a: [f64; 3]| {
        program
            .timing(&scratchart_machine::planner::Kinematics {
                rate_mm_min: r,
                accel_mm_s2: a,
                junction_deviation_mm: 0.01,
                source: String::new(),
            })
            .from(0)
    };
    let w_fast = want([1000.0, 1000.0, 600.0], [200.0, 200.0, 50.0]);
    assert!((secs(&fast) - w_fast).abs() <= 0.5, "{fast} vs {w_fast} s");
    let w_slow = want([500.0, 500.0, 300.0], [100.0, 100.0, 25.0]);
    assert!((secs(&slow) - w_slow).abs() <= 0.5, "{slow} vs {w_slow} s");
    // (the cuts and plunges run at the plan's feeds on both: the rapids make the difference)
    assert!(secs(&slow) > secs(&fast) + 30.0, "{slow} vs {fast}");
}
