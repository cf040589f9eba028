//! `scratchart-cal carve` end to end: a plan from `scratchart-cal plan` streams to a fake GRBL and
//! to a fake Marlin on a pseudo-terminal; a disconnect gives exit 1 with the `--resume` command,
//! and that command (on the reconnected port) finishes the job without skipping a scratch.
// The fakes sit behind pseudo-terminals, which only Unix has.
#![cfg(unix)]
use std::path::Path;
use std::process::{Command, Output, Stdio};

use scratchart_machine::fake::{FakeGrbl, FakeMarlin, GrblConfig, MarlinConfig};
use scratchart_machine::program::Program;
use scratchart_model::scene::Scene;

/// A design the tests' 60-degree V-bit carves as designed.
fn design(plate: f64, n: usize) -> Scene {
    scratchart_tests::carvable_design(plate, n, &scratchart_tests::v60_tool())
}

fn run(bin: &Path, dir: &Path, args: &[&str]) -> Output {
    Command::new(bin)
        .current_dir(dir)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

/// Each block's cut lines (`G1 X.. Y..`) executed at least once, in plan order (the plan's cut
/// lines, in order, are found in turn among the executed lines); returns the most times any one
/// was executed (for a line the plan has more than once, as the registration marks' hatch lines
/// that end at one corner of their square: its executions per copy, rounded up).
fn all_cut(plan: &Path, executed: &[String]) -> usize {
    let p = Program::load(plan).unwrap();
    let mut copies: std::collections::HashMap<&str, usize> = Default::default();
    let mut next = 0;
    for b in &p.blocks {
        for c in b.lines.iter().filter(|l| l.starts_with("G1 X")) {
            let c = c.split(" F").next().unwrap();
            *copies.entry(c).or_default() += 1;
            let at = executed[next..]
                .iter()
                .position(|e| e.starts_with(c))
                .unwrap_or_else(|| panic!("`{c}` ({}) was never cut, or cut out of order", b.label));
            next += at + 1;
        }
    }
    copies
        .iter()
        .map(|(c, n)| executed.iter().filter(|e| e.starts_with(c)).count().div_ceil(*n))
        .max()
        .unwrap_or(0)
}

#[test]
fn carve_streams_a_plan_to_grbl_and_marlin_and_resumes_after_a_disconnect() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-carve-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    design(100.0, 40).save(&dir.join("design.json"), "s.csv").unwrap();
    std::fs::write(
        dir.join("tool.json"),
        r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.0 }"#,
    )
    .unwrap();
    for (out, machine) in [("plan.nc", "grbl"), ("plan.gcode", "marlin")] {
        let o = run(
            &bin,
            &dir,
            &[
                "plan",
                "design.json",
                "--tool",
                "tool.json",
                "--out",
                out,
                "--machine",
                machine,
            ],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }

    // A dry run of each: the whole plan, the job time, progress in the design's numbering
    // (in a log: no terminal), exit 0, no journal left.
    for plan in ["plan.nc", "plan.gcode"] {
        let o = run(&bin, &dir, &["carve", plan, "--port", "sim"]);
        let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        assert_eq!(o.status.code(), Some(0), "{err}");
        let p = Program::load(&dir.join(plan)).unwrap();
        let n = p.blocks.len();
        assert!(
            out.starts_with("dry run: the simulated ") && out.contains("never overflowed"),
            "{out}"
        );
        assert!(err.contains("job time on this machine: "), "{err}");
        assert!(
            err.contains(&format!("carve: {n}/{n} cuts, last {}", p.blocks[n - 1].label)),
            "{err}"
        );
        assert!(!dir.join(format!("{plan}.journal.json")).exists());
    }

    // GRBL, with check mode first.
    let fake = FakeGrbl::start(GrblConfig::default()).unwrap();
    let o = run(&bin, &dir, &["carve", "plan.nc", "--port", fake.path(), "--check"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("done"));
    let r = fake.record();
    assert!(r.overflows.is_empty() && !r.checked.is_empty());
    assert_eq!(all_cut(&dir.join("plan.nc"), &r.executed), 1);

    // Marlin.
    let fake = FakeMarlin::start(MarlinConfig::default()).unwrap();
    let o = run(&bin, &dir, &["carve", "plan.gcode", "--port", fake.path(), "--yes"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(all_cut(&dir.join("plan.gcode"), &fake.record().executed), 1);

    // The other firmware's plan: 3, told to plan again for this machine.
    let o = run(&bin, &dir, &["carve", "plan.nc", "--port", fake.path()]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(e.contains("scratchart-cal plan ... --machine marlin"), "{e}");
    // A GRBL test card on the Marlin printer: made again with `card`, not `plan`.
    let o = run(&bin, &dir, &["card", "--out", "card", "--machine", "grbl"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(&bin, &dir, &["carve", "card/card.nc", "--port", fake.path()]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(
        e.contains("was written for grbl") && e.contains("scratchart-cal card --out DIR --machine marlin"),
        "{e}"
    );
    drop(fake);

    // A disconnect: 1 and the resume command; that command on the new port finishes the job.
    let fake = FakeGrbl::start(GrblConfig {
        disconnect_after: Some(70),
        ..GrblConfig::default()
    })
    .unwrap();
    let o = run(&bin, &dir, &["carve", "plan.nc", "--port", fake.path()]);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(1), "{err}");
    let cmd = err
        .split("to continue: ")
        .nth(1)
        .unwrap_or_else(|| panic!("no resume command in: {err}"))
        .lines()
        .next()
        .unwrap()
        .to_string();
    assert!(
        cmd.starts_with("scratchart-cal carve plan.nc --port ") && cmd.contains("--resume"),
        "{cmd}"
    );
    let shared = fake.shared();
    let old = fake.path().to_string();
    drop(fake);
    let fake = FakeGrbl::start_with(GrblConfig::default(), shared).unwrap();
    let args: Vec<String> = cmd
        .split_whitespace()
        .skip(1)
        .map(|a| {
            if a == old {
                fake.path().to_string()
            } else {
                a.to_string()
            }
        })
        .collect();
    let args: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    let o = run(&bin, &dir, &args);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--rezero home"));
    assert!(all_cut(&dir.join("plan.nc"), &fake.record().executed) <= 2);
    // Bad flags: 2.
    let o = run(&bin, &dir, &["carve", "plan.nc", "--port", "/dev/nonexistent-port"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn probe_writes_the_height_map_of_a_tilted_plate() {
    use scratchart_machine::fake::Plane;
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-probe-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let plane = Plane {
        z0: -0.02,
        dzdx: 0.001,
        dzdy: 0.0025,
    };
    let fake = FakeGrbl::start(GrblConfig {
        plane: Some(plane),
        ..GrblConfig::default()
    })
    .unwrap();
    let o = run(
        &bin,
        &dir,
        &[
            "probe",
            "--port",
            fake.path(),
            "--grid",
            "3x4",
            "--plate",
            "80",
            "--margin",
            "4",
            "--out",
            "hm.json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let map = scratchart_machine::level::HeightMap::load(&dir.join("hm.json")).unwrap();
    assert_eq!(map.x_mm, vec![-36.0, 0.0, 36.0]);
    assert_eq!(map.y_mm.len(), 4);
    for (x, y) in [(-36.0, -36.0), (10.0, 5.0), (36.0, 36.0)] {
        assert!((map.at(x, y) - plane.at(x, y)).abs() < 1e-4, "({x}, {y})");
    }
    // Without a plate size: a bad command line.
    let o = run(&bin, &dir, &["probe", "--port", fake.path()]);
    assert_eq!(o.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ctrl_c_stops_the_machine_raises_the_tool_and_exits_130() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-carve-int-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    design(100.0, 40).save(&dir.join("design.json"), "s.csv").unwrap();
    std::fs::write(
        dir.join("tool.json"),
        r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.0 }"#,
    )
    .unwrap();
    let o = run(
        &bin,
        &dir,
        &["plan", "design.json", "--tool", "tool.json", "--out", "plan.nc"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fake = FakeGrbl::start(GrblConfig {
        line_delay: std::time::Duration::from_millis(5),
        ..GrblConfig::default()
    })
    .unwrap();
    let child = Command::new(&bin)
        .current_dir(&dir)
        .args(["carve", "plan.nc", "--port", fake.path()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while fake.record().executed.len() < 40 {
        assert!(t0.elapsed().as_secs() < 20, "the job did not start");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let st = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("--resume"), "{err}");
    let r = fake.record();
    assert_eq!((r.holds, r.resets), (1, 1));
    assert_eq!(r.pos[2], 2.0, "the tool ends at the safe height");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `ports` lists the system's serial ports, each a name `carve --port` can open (a device file
/// on Unix), or says that there are none; exit 0 either way.
#[test]
fn ports_lists_the_serial_ports_by_name() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let out = run(&bin, &std::env::temp_dir(), &["ports"]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(!lines.is_empty(), "ports printed nothing");
    if lines[0].starts_with("no serial ports found") {
        return;
    }
    for l in lines {
        let (name, kind) = l.split_once('\t').unwrap_or_else(|| panic!("not `NAME\\tKIND`: {l}"));
        assert!(Path::new(name).exists(), "listed port {name} is not a device file");
        assert!(
            ["USB", "Bluetooth", "PCI", "unknown"]
                .iter()
                .any(|k| kind.starts_with(k)),
            "{l}"
        );
    }
}

/// `frame` traces the plan's frame on the machine and cuts nothing (every Z it is sent at the
/// clearance height, none below); `carve --frame` traces and then carves; bad values exit 2.
#[test]
fn frame_traces_the_outline_at_the_clearance_and_cuts_nothing() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-frame-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    design(60.0, 12).save(&dir.join("design.json"), "s.csv").unwrap();
    std::fs::write(dir.join("tool.json"), scratchart_tests::V60_TOOL_JSON).unwrap();
    let o = run(
        &bin,
        &dir,
        &["plan", "design.json", "--tool", "tool.json", "--out", "plan.nc"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let fake = FakeGrbl::start(GrblConfig::default()).unwrap();
    let o = run(&bin, &dir, &["frame", "plan.nc", "--port", fake.path()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("nothing was cut"));
    assert!(err.contains("frame: tracing the job's bounding box"), "{err}");
    let r = fake.record();
    let zs: Vec<f64> = r
        .executed
        .iter()
        .filter_map(|l| l.split_whitespace().find_map(|w| w.strip_prefix('Z')?.parse().ok()))
        .collect();
    assert!(!zs.is_empty() && zs.iter().all(|&z| z >= 2.0), "{:?}", r.executed);
    assert!(r.received.iter().all(|l| !l.starts_with("M3")), "{:?}", r.received);
    assert_eq!((r.pos[0], r.pos[1]), (0.0, 0.0));
    assert!(!dir.join("plan.nc.journal.json").exists());

    let o = run(&bin, &dir, &["carve", "plan.nc", "--port", "sim", "--frame"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("frame: tracing") && err.contains("carve: "), "{err}");

    for bad in [
        &["frame", "plan.nc", "--port", "sim", "--feed", "0"][..],
        &["frame", "plan.nc", "--port", "sim", "--feed", "-5"],
        &["carve", "plan.nc", "--port", "sim", "--frame", "--frame-feed", "0"],
    ] {
        let o = run(&bin, &dir, bad);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{bad:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}
