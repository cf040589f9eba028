//! Streaming to the real GRBL 1.1h firmware, run in the simavr AVR simulator on a pseudo-terminal
//! (`../shared/grbl-sim` beside the project: a test fixture, never linked or shipped). The
//! simulator is built with its own `setup.sh` into this build's temporary folder, run at full
//! speed (`-s 0`), and every instance a test starts is stopped through its pidfile. Where the
//! fixture is absent the tests say so plainly and pass without checking anything else: the fakes
//! of `stream_grbl.rs` cover the protocol there.
#![cfg(unix)]
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::Ordering;
use std::sync::OnceLock;

use common::*;
use scratchart_machine::job::carve;
use scratchart_machine::journal::Journal;
use scratchart_machine::plan::Cut;
use scratchart_machine::stream::Control;
use scratchart_observe::{Observer, Progress};
use scratchart_tool::machine::MachineProfile;

/// The fixture's folder, when it is there.
fn fixture() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/grbl-sim");
    p.join("setup.sh").exists().then(|| p.canonicalize().unwrap())
}

/// Builds the simulator once per test binary (its Makefile skips what is up to date); the build
/// folder, or why there is none.
fn build() -> Result<PathBuf, String> {
    static BUILT: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    BUILT
        .get_or_init(|| {
            let dir = fixture().ok_or("../shared/grbl-sim is absent")?;
            let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("grbl-sim-build");
            let r = Command::new("bash")
                .arg(dir.join("setup.sh"))
                .env("GRBL_SIM_BUILD", &out)
                .output()
                .map_err(|e| format!("cannot run grbl-sim's setup.sh: {e}"))?;
            if !r.status.success() {
                return Err(format!(
                    "grbl-sim's setup.sh failed: {}{}",
                    String::from_utf8_lossy(&r.stdout),
                    String::from_utf8_lossy(&r.stderr)
                ));
            }
            Ok(out)
        })
        .clone()
}

/// A running simulator; dropping it stops it through its pidfile.
struct Sim {
    link: PathBuf,
}

impl Sim {
    /// Starts the firmware on `dir/tag` with grbl-sim's `options`; `None` (said on stderr) when the
    /// fixture is absent. A fixture that is present but does not build or start fails the test.
    fn start(dir: &Path, tag: &str, options: &[&str]) -> Option<Sim> {
        if fixture().is_none() {
            eprintln!("SKIPPED: ../shared/grbl-sim is absent, so nothing ran against the real GRBL firmware");
            return None;
        }
        let build = build().unwrap_or_else(|e| panic!("{e}"));
        let link = dir.join(tag);
        let r = Command::new("bash")
            .arg(fixture().unwrap().join("run.sh"))
            .arg(&link)
            .arg("300")
            .args(["-s", "0"])
            .args(options)
            .env("GRBL_SIM_BUILD", &build)
            .output()
            .expect("run grbl-sim's run.sh");
        assert!(
            r.status.success(),
            "grbl-sim did not start: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        Some(Sim { link })
    }

    fn port(&self) -> String {
        self.link.display().to_string()
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        let pidfile = PathBuf::from(format!("{}.pid", self.link.display()));
        if let Ok(pid) = std::fs::read_to_string(&pidfile) {
            let _ = Command::new("kill").arg(pid.trim()).status();
        }
    }
}

/// A row of cuts 2.5 mm apart from x = `x0`, each from (x, -h) to (x + 1, h), 20 um deep, with
/// the given bulges (0: straight).
fn row_of_cuts(x0: f64, h: f64, bulges: &[f64]) -> Vec<Cut> {
    bulges
        .iter()
        .enumerate()
        .map(|(k, &bulge)| {
            let x = x0 + 2.5 * k as f64;
            Cut {
                a: [x, -h],
                b: [x + 1.0, h],
                z: 0.02,
                scratch: k,
                bulge,
            }
        })
        .collect()
}

/// Six short cuts near the plate centre (a few seconds of machine time).
fn small_plan(dir: &Path) -> PathBuf {
    let cuts = row_of_cuts(-6.0, 3.0, &[0.0; 6]);
    // Hops at the clearance height (2 mm), as plans made before the retract height did: the
    // tests that stop a job after two acknowledged cuts need the rest to take a while (with
    // 0.3 mm hops the simulated board can finish the six cuts before the stop arrives).
    let m = MachineProfile {
        retract_mm: 2.0,
        ..MachineProfile::grbl()
    };
    let g = scratchart_machine::gcode::write(&cuts, &m, 60.0, &["grbl-sim test".into()]);
    let p = dir.join("small.nc");
    std::fs::write(&p, g).unwrap();
    p
}

/// The real firmware carves a plan to the end.
#[test]
fn the_real_firmware_carves_a_plan_to_the_end() {
    let dir = tmpdir("grbl_sim_full");
    let Some(sim) = Sim::start(&dir, "uart", &[]) else {
        return;
    };
    let plan = small_plan(&dir);
    let log = Log::default();
    let s = carve(&options(&plan, &sim.port()), &Control::default(), &log)
        .unwrap_or_else(|e| panic!("{e}\nnotes: {:?}", log.notes.lock().unwrap()));
    assert_eq!((s.from, s.total), (0, 6));
    assert!(s.controller.contains("1.1h"), "{}", s.controller);
    let j = Journal::load(&scratchart_machine::journal::default_path(&plan)).unwrap();
    assert_eq!((j.state.as_str(), j.last_acked), ("done", Some(5)));
}

/// Stopped with Ctrl-C (feed hold, soft reset once held, tool raised), a board that does not
/// reset on open keeps its position: `--rezero keep` resumes and finishes. On a board that resets
/// when the port opens (an Arduino Uno, `-r`), GRBL sets its position to zero: `--rezero keep`
/// stops before any motion, with exit 1, saying why and what this machine (no homing, `$22=0`)
/// allows.
#[test]
fn a_resume_after_a_board_reset_never_cuts_on_with_a_lost_position() {
    for reset_on_open in [false, true] {
        let dir = tmpdir(if reset_on_open {
            "grbl_sim_reset"
        } else {
            "grbl_sim_keep"
        });
        let opts_sim: &[&str] = if reset_on_open { &["-r", "1000"] } else { &[] };
        let Some(sim) = Sim::start(&dir, "uart", opts_sim) else {
            return;
        };
        let plan = small_plan(&dir);
        let control = Control::default();
        // Ctrl-C once 2 scratches are acknowledged.
        let obs = AbortWhen::new(&control, |p: &Progress| p.done >= 2);
        let e = carve(&options(&plan, &sim.port()), &control, &obs).unwrap_err();
        assert_eq!(e.exit_code(), 130, "{e}");
        let j = Journal::load(&scratchart_machine::journal::default_path(&plan)).unwrap();
        assert_eq!(j.position_lost, None, "a controlled stop keeps the position: {j:?}");
        let acked = j.last_acked.expect("some scratches were acknowledged");

        let opts = resume_options(&plan, &sim.port());
        let log = Log::default();
        let r = carve(&opts, &Control::default(), &log);
        if reset_on_open {
            let e = r.expect_err("keep after a reset must stop");
            let msg = e.to_string();
            assert_eq!(e.exit_code(), 1, "{msg}");
            assert!(
                msg.contains("position is lost") && msg.contains("nothing moved") && msg.contains("$22=0"),
                "{msg}"
            );
            assert!(msg.contains("--rezero probe"), "{msg}");
            let j = Journal::load(&opts.journal).unwrap();
            assert!(j.position_lost.is_some() && j.last_acked == Some(acked), "{j:?}");
            // No progress was reported: not one line of the plan was sent.
            assert!(log.progress.lock().unwrap().is_empty());
        } else {
            let s = r.unwrap_or_else(|e| panic!("{e}\nnotes: {:?}", log.notes.lock().unwrap()));
            assert_eq!(s.total, 6);
            assert!(
                log.says("kept the controller's position"),
                "{:?}",
                log.notes.lock().unwrap()
            );
            let j = Journal::load(&opts.journal).unwrap();
            assert_eq!(j.state, "done");
        }
        drop(sim);
    }
}

/// An observer that asks for a feed hold once `after` cuts are acknowledged, and for the resume
/// a moment later (as a maker types `!` and then `~`).
struct HoldAfter<'a> {
    after: usize,
    control: &'a Control,
    log: Log,
    held: std::sync::atomic::AtomicBool,
}

impl Observer for HoldAfter<'_> {
    fn progress(&self, p: &Progress) {
        if p.done >= self.after as u64 && !self.held.swap(true, Ordering::SeqCst) {
            self.control.hold.store(true, Ordering::SeqCst);
        }
        self.log.progress(p);
    }
    fn warn(&self, msg: &str) {
        self.log.warn(msg);
    }
    fn info(&self, msg: &str) {
        if msg.starts_with("feed hold") {
            // Held: resume after a while.
            self.control.resume.store(true, Ordering::SeqCst);
        }
        self.log.info(msg);
    }
}

/// The real firmware's check mode (`$C`, which soft-resets GRBL when it ends) is not taken for a
/// lost position, the job time comes from its own `$$`, and a feed hold in the middle of the
/// job (`!`, then `~`) loses nothing: every cut is made and the job ends.
#[test]
fn the_real_firmware_checks_holds_and_resumes() {
    let dir = tmpdir("grbl_sim_hold");
    let Some(sim) = Sim::start(&dir, "uart", &[]) else {
        return;
    };
    let plan = small_plan(&dir);
    let control = Control::default();
    let obs = HoldAfter {
        after: 2,
        control: &control,
        log: Log::default(),
        held: Default::default(),
    };
    let mut opts = options(&plan, &sim.port());
    opts.check = true;
    let s = carve(&opts, &control, &obs).unwrap_or_else(|e| panic!("{e}\nnotes: {:?}", obs.log.notes.lock().unwrap()));
    assert_eq!((s.from, s.total), (0, 6));
    let notes = obs.log.notes.lock().unwrap().clone();
    assert!(notes.iter().any(|n| n.starts_with("check mode: all")), "{notes:?}");
    assert!(
        notes.iter().any(|n| n.starts_with("feed hold")) && notes.iter().any(|n| n == "resumed"),
        "{notes:?}"
    );
    // GRBL 1.1h's defaults: $110-$112 = 500 mm/min, $120-$122 = 10 mm/s^2.
    let k = scratchart_machine::planner::Kinematics {
        rate_mm_min: [500.0; 3],
        accel_mm_s2: [10.0; 3],
        junction_deviation_mm: 0.01,
        source: String::new(),
    };
    let program = scratchart_machine::program::Program::load(&plan).unwrap();
    let want = scratchart_observe::clock(program.timing(&k).from(0));
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with(&format!("job time on this machine: {want}"))),
        "{want}: {notes:?}"
    );
    let j = Journal::load(&scratchart_machine::journal::default_path(&plan)).unwrap();
    assert_eq!(
        (j.state.as_str(), j.last_acked, j.position_lost.as_deref()),
        ("done", Some(5), None)
    );
    drop(sim);
}

/// Keeps every position the job reports, and its notes.
/// The real firmware traces the frame (the job's box and a 20 mm plate's outline at the
/// clearance height, then back to X0 Y0) without cutting: every position it reports away from
/// X0 Y0 (where the tool first rises from the surface) is at the clearance height, and the
/// trace ends there. Then `carve --frame` traces again and carves every cut on the same
/// connection.
#[test]
fn the_real_firmware_traces_the_frame_without_cutting() {
    let dir = tmpdir("grbl_sim_frame");
    let Some(sim) = Sim::start(&dir, "uart", &[]) else {
        return;
    };
    let cuts: Vec<Cut> = (0..4)
        .map(|k| Cut {
            a: [-4.0 + 2.5 * k as f64, -3.0],
            b: [-3.0 + 2.5 * k as f64, 3.0],
            z: 0.02,
            scratch: k,
            bulge: 0.0,
        })
        .collect();
    let m = MachineProfile::grbl();
    let g = scratchart_machine::gcode::write(&cuts, &m, 20.0, &["grbl-sim frame test".into()]);
    let plan = dir.join("frame.nc");
    std::fs::write(&plan, g).unwrap();
    let clear = m.clearance_mm;

    let obs = Log::default();
    let s = scratchart_machine::job::frame::frame(&options(&plan, &sim.port()), 500.0, &Control::default(), &obs)
        .unwrap_or_else(|e| panic!("{e}\nnotes: {:?}", obs.notes.lock().unwrap()));
    assert!(s.controller.contains("1.1h"), "{}", s.controller);
    let seen = obs.positions();
    assert!(!seen.is_empty(), "the firmware reported no position");
    for (_, q) in &seen {
        let home = q[0].abs() < 1e-3 && q[1].abs() < 1e-3;
        assert!(
            home || q[2] >= clear - 1e-3,
            "below the clearance during the trace: {seen:?}"
        );
    }
    // The status reports caught the tool out on the trace, up at the clearance.
    assert!(
        seen.iter()
            .any(|(_, q)| q[0].abs() > 1.0 && (q[2] - clear).abs() < 1e-3),
        "{seen:?}"
    );
    let p = obs.progress.lock().unwrap();
    assert_eq!(p.last().map(|s| (s.done, s.total)), Some((3, 3)));
    drop(p);
    // Nothing was cut: the job has no journal.
    assert!(!scratchart_machine::journal::default_path(&plan).exists());

    let obs = Log::default();
    let opts = scratchart_machine::job::Options {
        frame: Some(500.0),
        ..options(&plan, &sim.port())
    };
    let s = carve(&opts, &Control::default(), &obs)
        .unwrap_or_else(|e| panic!("{e}\nnotes: {:?}", obs.notes.lock().unwrap()));
    assert_eq!((s.from, s.total), (0, 4));
    let seen = obs.positions();
    for (task, q) in seen.iter().filter(|(t, _)| t == "frame") {
        let home = q[0].abs() < 1e-3 && q[1].abs() < 1e-3;
        assert!(home || q[2] >= clear - 1e-3, "{task} below the clearance: {seen:?}");
    }
    let j = Journal::load(&scratchart_machine::journal::default_path(&plan)).unwrap();
    assert_eq!((j.state.as_str(), j.last_acked), ("done", Some(3)));

    // Ctrl-C while the tool is out on the trace (every line already taken by the firmware's
    // planner): the machine is stopped and nothing is cut.
    let control = Control::default();
    let obs = AbortWhen::new(&control, |p: &Progress| {
        p.machine.as_ref().and_then(|m| m.pos).is_some_and(|q| q[0].abs() > 1.0)
    });
    let e = scratchart_machine::job::frame::frame(&options(&plan, &sim.port()), 500.0, &control, &obs).unwrap_err();
    assert_eq!(e.exit_code(), 130, "{e}");
    assert!(e.to_string().contains("nothing was cut"), "{e}");
    drop(sim);
}

/// Arc scratches are one G2 or G3 move each: the real firmware takes them (an arc whose centre
/// does not fit its ends is GRBL's error:33) and carves the plan to the end.
#[test]
fn the_real_firmware_carves_arcs() {
    let dir = tmpdir("grbl_sim_arcs");
    let Some(sim) = Sim::start(&dir, "uart", &[]) else {
        return;
    };
    let cuts = row_of_cuts(-7.0, 2.0, &[0.3, -0.3, 1.0, -1.0, 2.0, -0.05]);
    let g = scratchart_machine::gcode::write(&cuts, &MachineProfile::grbl(), 60.0, &["grbl-sim arcs".into()]);
    assert_eq!(g.lines().filter(|l| l.starts_with("G3 ")).count(), 3, "{g}");
    assert_eq!(g.lines().filter(|l| l.starts_with("G2 ")).count(), 3, "{g}");
    // The firmware checks arcs: a centre 0.5 mm off is refused.
    let bad = dir.join("bad_arc.nc");
    let first = g.lines().find(|l| l.starts_with("G3 ")).unwrap().to_string();
    let j_word = first.split_whitespace().find(|w| w.starts_with('J')).unwrap();
    let moved = format!("J{:.4}", j_word[1..].parse::<f64>().unwrap() + 0.5);
    std::fs::write(&bad, g.replacen(&first, &first.replace(j_word, &moved), 1)).unwrap();
    let err = carve(&options(&bad, &sim.port()), &Control::default(), &Log::default())
        .expect_err("a bad arc is refused by the firmware")
        .to_string();
    assert!(err.contains("error:33") || err.contains("33"), "{err}");
    let plan = dir.join("arcs.nc");
    std::fs::write(&plan, g).unwrap();
    let log = Log::default();
    let s = carve(&options(&plan, &sim.port()), &Control::default(), &log)
        .unwrap_or_else(|e| panic!("{e}\nnotes: {:?}", log.notes.lock().unwrap()));
    assert_eq!((s.from, s.total), (0, 6));
    let j = Journal::load(&scratchart_machine::journal::default_path(&plan)).unwrap();
    assert_eq!((j.state.as_str(), j.last_acked), ("done", Some(5)));
}
