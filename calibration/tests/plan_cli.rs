//! `scratchart-cal plan` end to end: a design and a tool in, G-code and a preview out; bad input
//! and plans that leave their bounds are refused with the README's exit codes.
use std::process::Command;

use scratchart_machine::marks::plate_marks;
use scratchart_machine::program::Program;
use scratchart_model::scene::Scene;

/// A design the tests' 60-degree V-bit carves as designed.
fn design(plate: f64) -> Scene {
    scratchart_tests::carvable_design(plate, 40, &scratchart_tests::v60_tool())
}

/// A design made without the tool: every scratch the same (w, d), whatever the depth.
fn toolless_design(plate: f64) -> Scene {
    let mut s = design(plate);
    for sc in &mut s.scratches {
        sc.w = 0.05;
        sc.d = 0.05;
    }
    s
}

#[test]
fn plan_writes_gcode_and_a_preview() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-plan-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    design(100.0).save(&dir.join("design.json"), "s.csv").unwrap();
    std::fs::write(
        dir.join("tool.json"),
        r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.0 }"#,
    )
    .unwrap();
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    let o = run(&["plan", "design.json", "--tool", "tool.json", "--out", "out/plan.nc"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = std::fs::read_to_string(dir.join("out/plan.nc")).unwrap();
    assert!(g.starts_with("; scratchart plan machine=grbl\n"));
    assert_eq!(g.lines().filter(|l| l.starts_with("; scratch ")).count(), 40);
    assert!(dir.join("out/plan.png").exists());
    // The toolpath picture: to scale, cuts coloured from the shallowest (dark blue) to the
    // deepest (yellow), the first (green) and last (red) cut marked.
    let png = image::open(dir.join("out/plan.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (1300, 980));
    let count = |c: [u8; 3], tol: i32| {
        png.pixels()
            .filter(|p| (0..3).all(|i| (p.0[i] as i32 - c[i] as i32).abs() <= tol))
            .count()
    };
    assert!(count([68, 1, 84], 6) > 50, "shallow cuts");
    assert!(count([253, 231, 37], 6) > 50, "deep cuts");
    assert!(
        count([0, 150, 60], 0) > 10 && count([210, 30, 30], 0) > 10,
        "first and last"
    );
    // The whole tool record in the header (folded over comment lines, never cut short).
    let header: Vec<&str> = g.lines().take_while(|l| l.starts_with(';')).map(|l| &l[2..]).collect();
    let joined = header.join(" ");
    let at = joined.find("tool {").expect("a tool record") + "tool ".len();
    let end = at + joined[at..].find('}').unwrap() + 1;
    let record: serde_json::Value = serde_json::from_str(&joined[at..end]).expect(&joined);
    assert_eq!(record["kind"], "v-bit");
    assert_eq!(record["angle_deg"], 60.0);
    assert_eq!(record["tip_flat_mm"], 0.01);
    assert_eq!(record["z_offset_mm"], 0.0);
    let o = run(&[
        "plan",
        "design.json",
        "--tool",
        "tool.json",
        "--out",
        "out/m.gcode",
        "--machine",
        "marlin",
    ]);
    assert!(o.status.success());
    assert!(std::fs::read_to_string(dir.join("out/m.gcode"))
        .unwrap()
        .starts_with("; scratchart plan machine=marlin\n"));
    // A bad tool file: 3, naming it.
    std::fs::write(dir.join("bad.json"), r#"{ "kind": "v-bit", "angle_deg": 0 }"#).unwrap();
    let o = run(&["plan", "design.json", "--tool", "bad.json"]);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.json"));
    // A plate larger than the machine's travel: refused (3), saying so.
    design(250.0).save(&dir.join("big.json"), "b.csv").unwrap();
    let o = run(&["plan", "big.json", "--tool", "tool.json", "--out", "out/big.nc"]);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("does not fit"));
    assert!(
        !dir.join("out/big.nc").exists(),
        "nothing is written for a refused plan"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

fn setup(tag: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-plan-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("tool.json"),
        r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.0 }"#,
    )
    .unwrap();
    (bin, dir)
}

/// Each block of a plan: its comment and the (X, Y, Z) after each move below safe height.
fn blocks_of(g: &str) -> Vec<(String, Vec<[f64; 3]>)> {
    let mut out: Vec<(String, Vec<[f64; 3]>)> = Vec::new();
    let mut pos = [0.0f64; 3];
    for line in g.lines() {
        if let Some(c) = line.strip_prefix("; ") {
            if c.starts_with("scratch ") || c.starts_with("mark ") {
                // `scratch N (cut K of T)`: K counts the blocks in order.
                let (label, cut) = c.split_once(" (cut ").expect("a cut index");
                let k: usize = cut.split(' ').next().unwrap().parse().unwrap();
                assert_eq!(k, out.len() + 1, "{c}");
                out.push((label.to_string(), Vec::new()));
            }
            continue;
        }
        if !(line.starts_with("G0 ") || line.starts_with("G1 ")) {
            continue;
        }
        for w in line.split_whitespace() {
            let i = match w.as_bytes()[0] {
                b'X' => 0,
                b'Y' => 1,
                b'Z' => 2,
                _ => continue,
            };
            pos[i] = w[1..].parse().unwrap();
        }
        if line.starts_with("G1") && pos[2] < 1.0 {
            if let Some(b) = out.last_mut() {
                b.1.push(pos);
            }
        }
    }
    out
}

#[test]
fn marlin_plan_homes_only_when_asked_and_keeps_to_the_bed() {
    let (bin, dir) = setup("marlin");
    design(100.0).save(&dir.join("design.json"), "s.csv").unwrap();
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    let base = ["plan", "design.json", "--tool", "tool.json", "--machine", "marlin"];
    let o = run(&base);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = std::fs::read_to_string(dir.join("plan.gcode")).expect("plan.gcode by default for Marlin");
    assert!(g.starts_with("; scratchart plan machine=marlin\n") && !g.contains('\r'));
    assert!(g.lines().all(|l| l.len() < 80));
    assert_eq!(g.lines().last(), Some("M400"));
    let codes: Vec<&str> = g.lines().filter(|l| !l.starts_with(';')).collect();
    assert!(codes.contains(&"G21") && codes.contains(&"G90"));
    assert!(!codes.iter().any(|l| l.starts_with("G28")), "no homing unless asked");
    for l in &codes {
        let w: Vec<&str> = l.split_whitespace().collect();
        assert!(
            !w.iter().any(|w| ["M3", "M4", "M5"].contains(w) || w.starts_with('S')),
            "{l}"
        );
    }
    assert!(g.contains("groove ends: cuts are not shortened"));
    // --home: G28 X Y, never Z.
    let mut home = base.to_vec();
    home.extend(["--home", "--out", "home.gcode"]);
    let o = run(&home);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = std::fs::read_to_string(dir.join("home.gcode")).unwrap();
    assert_eq!(
        g.lines().filter(|l| l.starts_with("G28")).collect::<Vec<_>>(),
        vec!["G28 X Y"]
    );
    // A bed smaller than the plate: refused (3), nothing written.
    let mut small = base.to_vec();
    small.extend(["--bed", "80x300", "--out", "small.gcode"]);
    let o = run(&small);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("80 x 300"));
    assert!(!dir.join("small.gcode").exists());
    // A bed that fits: fine.
    let mut fits = base.to_vec();
    fits.extend(["--bed", "120x110", "--out", "fits.gcode"]);
    assert!(run(&fits).status.success());
    // Malformed --bed, and --home for GRBL: 2.
    let mut bad = base.to_vec();
    bad.extend(["--bed", "120"]);
    assert_eq!(run(&bad).status.code(), Some(2));
    let o = run(&["plan", "design.json", "--tool", "tool.json", "--home"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_mark_is_cut_at_the_plus_x_edge_unless_turned_off() {
    let (bin, dir) = setup("mark");
    let scene = design(100.0);
    scene.save(&dir.join("design.json"), "s.csv").unwrap();
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    let o = run(&["plan", "design.json", "--tool", "tool.json", "--out", "m.nc"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = std::fs::read_to_string(dir.join("m.nc")).unwrap();
    let blocks = blocks_of(&g);
    let marks: Vec<_> = blocks.iter().filter(|b| b.0 == "mark +x edge").collect();
    assert_eq!(marks.len(), 1, "one mark block");
    assert_eq!(blocks.iter().filter(|b| b.0.starts_with("scratch ")).count(), 40);
    let pts = &marks[0].1;
    assert_eq!(pts.len(), 2, "{pts:?}");
    let (a, b) = (pts[0], pts[1]);
    let h = 0.5 * scene.plate.size_mm;
    assert!(b[0] > a[0] && a[1] == b[1], "it points +x: {pts:?}");
    assert!(
        a[0] > 0.4 * h && b[0] < h && a[1].abs() < h,
        "on the plate at the +x edge: {pts:?}"
    );
    let right = scene
        .scratches
        .iter()
        .map(|s| s.p0[0].max(s.p1[0]))
        .fold(f64::MIN, f64::max);
    assert!(a[0] > right, "outside the scratched area: {} vs {right}", a[0]);
    assert!(a[2] < 0.0, "cut below the surface");
    assert!(dir.join("m.png").exists());
    let o = run(&[
        "plan",
        "design.json",
        "--tool",
        "tool.json",
        "--out",
        "n.nc",
        "--no-mark",
    ]);
    assert!(o.status.success());
    let g = std::fs::read_to_string(dir.join("n.nc")).unwrap();
    assert!(!g.contains("; mark +x edge"));
    assert!(
        g.contains("; mark corner -x -y hatch 1 "),
        "--no-mark leaves the registration marks"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn depths_come_from_the_z_mm_column_and_follow_a_height_map() {
    use scratchart_model::scene_file::Extra;
    let (bin, dir) = setup("zmm");
    let scene = design(100.0);
    let z: Vec<f64> = (0..scene.scratches.len()).map(|k| 0.025 + 0.001 * k as f64).collect();
    let extra = Extra {
        names: vec!["z_mm".into()],
        rows: z.iter().map(|z| vec![*z]).collect(),
    };
    scene.save_extra(&dir.join("design.json"), "s.csv", &extra).unwrap();
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    // No tool needed.
    let o = run(&["plan", "design.json", "--out", "z.nc", "--no-mark", "--no-marks"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = std::fs::read_to_string(dir.join("z.nc")).unwrap();
    assert!(g.contains("depths: the design's z_mm column"));
    let blocks = blocks_of(&g);
    assert_eq!(blocks.len(), 40);
    for (label, pts) in &blocks {
        let k: usize = label["scratch ".len()..].parse::<usize>().unwrap() - 1;
        assert!(
            pts.iter().all(|p| (p[2] + z[k]).abs() < 1e-4),
            "{label}: {pts:?} vs {}",
            z[k]
        );
    }
    // A tilted plate: every point of every cut is its depth below the measured surface.
    let xs: Vec<f64> = (0..5).map(|i| -50.0 + 25.0 * i as f64).collect();
    let plane = |x: f64, y: f64| 0.1 + 0.002 * x + 0.001 * y;
    let rows: Vec<Vec<f64>> = xs.iter().map(|&y| xs.iter().map(|&x| plane(x, y)).collect()).collect();
    let map = serde_json::json!({ "x_mm": xs, "y_mm": xs, "z_mm": rows });
    std::fs::write(dir.join("heightmap.json"), map.to_string()).unwrap();
    let o = run(&["plan", "design.json", "--out", "l.nc", "--heightmap", "heightmap.json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("levelling: correction from"));
    let g = std::fs::read_to_string(dir.join("l.nc")).unwrap();
    let blocks = blocks_of(&g);
    // The 40 scratches, the +x mark and the registration marks' hatch lines, every one levelled:
    // the marks at the deepest depth below the measured surface.
    let hatch: usize = plate_marks(100.0, &scene.views).hatch_cuts();
    assert_eq!(blocks.len(), 41 + hatch);
    let deepest = z.iter().cloned().fold(0.0, f64::max);
    for (label, pts) in &blocks {
        let want = match label.strip_prefix("scratch ") {
            Some(k) => z[k.parse::<usize>().unwrap() - 1],
            None => deepest,
        };
        for p in pts {
            let depth = plane(p[0], p[1]) - p[2];
            // Z is written to 0.1 um (rounding 5e-5 mm), X and Y too (5e-5 mm x slope 0.003).
            assert!((depth - want).abs() < 5.1e-5, "{label}: depth {depth} vs {want}");
        }
    }
    // A malformed height map: 3, saying what is wrong.
    std::fs::write(
        dir.join("bad.json"),
        r#"{"x_mm":[0,10],"y_mm":[5,5],"z_mm":[[0,0],[0,0]]}"#,
    )
    .unwrap();
    let o = run(&["plan", "design.json", "--out", "b.nc", "--heightmap", "bad.json"]);
    assert_eq!(o.status.code(), Some(3));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("bad.json") && e.contains("y_mm must increase strictly"),
        "{e}"
    );
    // Neither z_mm nor a tool: 2.
    design(100.0).save(&dir.join("plain.json"), "p.csv").unwrap();
    let o = run(&["plan", "plain.json"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--tool"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A tool whose z offset puts the plate's surface above commanded zero (tool.json
/// `z_offset_mm` > 0): `design --tool` then writes shallow grooves at negative commanded depths.
/// `plan` with that tool cuts them (at Z = -z_mm, into the plate); a depth above the surface, or
/// the same design without the tool, is refused with exit 3, saying why.
#[test]
fn commanded_depths_start_at_the_tools_surface() {
    use scratchart_model::scene_file::Extra;
    let (bin, dir) = setup("surface");
    std::fs::write(
        dir.join("raised.json"),
        r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.03 }"#,
    )
    .unwrap();
    let raised: scratchart_tool::Tool =
        serde_json::from_str(&std::fs::read_to_string(dir.join("raised.json")).unwrap()).unwrap();
    // The surface at commanded -0.03 mm; the first depths negative, every cut at least 0.022 mm
    // below the surface, each groove the raised tool's own.
    let z: Vec<f64> = (0..40).map(|k| -0.008 + 0.001 * k as f64).collect();
    let mut scene = design(100.0);
    for (s, &z) in scene.scratches.iter_mut().zip(&z) {
        let g = raised.model(z).unwrap();
        (s.w, s.d) = (g.w, g.d);
    }
    let save = |name: &str, z: &[f64]| {
        let extra = Extra {
            names: vec!["z_mm".into()],
            rows: z.iter().map(|z| vec![*z]).collect(),
        };
        scene
            .save_extra(&dir.join(name), &format!("{name}.csv"), &extra)
            .unwrap();
    };
    save("shallow.json", &z);
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    let o = run(&[
        "plan",
        "shallow.json",
        "--tool",
        "raised.json",
        "--out",
        "s.nc",
        "--no-mark",
        "--no-marks",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let blocks = blocks_of(&std::fs::read_to_string(dir.join("s.nc")).unwrap());
    assert_eq!(blocks.len(), 40);
    for (label, pts) in &blocks {
        let k: usize = label["scratch ".len()..].parse::<usize>().unwrap() - 1;
        assert!(pts.iter().all(|p| (p[2] + z[k]).abs() < 1e-4), "{label}: {pts:?}");
    }
    // Without the tool, the surface is at commanded zero: refused, naming the cure.
    let o = run(&["plan", "shallow.json", "--out", "n.nc"]);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("scratch 1 has z_mm = -0.008") && e.contains("--tool"), "{e}");
    // Above the raised surface (-0.03 mm): refused with the tool too.
    let mut above = z.clone();
    above[5] = -0.035;
    save("above.json", &above);
    let o = run(&["plan", "above.json", "--tool", "raised.json", "--out", "a.nc"]);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("scratch 6") && e.contains("-0.03"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A design `plan` cannot carve as designed is refused with exit 2, no G-code written, the
/// message naming what is wrong and the flags that make a carvable design: one made without the
/// tool (its grooves far off the tool's cuts), one with another tool, one whose z_mm column cuts
/// shallower than the machine trusts. `--force` writes it, says so, and the plan's header too.
#[test]
fn a_design_not_made_for_the_tool_and_machine_is_refused_unless_forced() {
    use scratchart_model::scene_file::Extra;
    let (bin, dir) = setup("force");
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    std::fs::write(
        dir.join("ball.json"),
        r#"{ "kind": "ball", "radius_mm": 0.1, "z_offset_mm": 0.0 }"#,
    )
    .unwrap();
    toolless_design(100.0).save(&dir.join("plain.json"), "p.csv").unwrap();
    // The same design checked against the tool it was made for passes (below).
    design(100.0).save(&dir.join("v60.json"), "v.csv").unwrap();
    for (design, tool, machine) in [
        ("plain.json", "tool.json", "grbl"),
        ("v60.json", "ball.json", "grbl"),
        ("plain.json", "tool.json", "marlin"),
    ] {
        let o = run(&["plan", design, "--tool", tool, "--machine", machine, "--out", "r.nc"]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{design} with {tool}: {e}");
        assert!(
            e.contains("cannot be carved as designed")
                && e.contains("not the tool's cut")
                && e.contains(&format!("--tool TOOL.json --machine {machine}"))
                && e.contains("--force"),
            "{e}"
        );
        assert!(!dir.join("r.nc").exists(), "no G-code for a refused design");
    }
    let o = run(&["plan", "v60.json", "--tool", "tool.json", "--out", "ok.nc"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    // Depths shallower than the profile's smallest trusted cut (0.02 mm on GRBL).
    let scene = design(100.0);
    let z: Vec<f64> = (0..40).map(|k| if k == 7 { 0.012 } else { 0.03 }).collect();
    let extra = Extra {
        names: vec!["z_mm".into()],
        rows: z.iter().map(|z| vec![*z]).collect(),
    };
    scene.save_extra(&dir.join("shallow.json"), "s.csv", &extra).unwrap();
    let o = run(&["plan", "shallow.json", "--out", "s.nc"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("1 of 40 cuts are shallower than the machine's smallest trusted cut, 0.02 mm")
            && e.contains("scratch 8"),
        "{e}"
    );
    // The same depths from a design made with a tool whose z offset puts the surface 0.01 mm
    // above commanded zero (its summary.json says so): 0.012 commanded is 0.022 below the
    // surface, and the plan is written, saying where it took the surface from.
    std::fs::create_dir_all(dir.join("made")).unwrap();
    scene
        .save_extra(&dir.join("made/shallow.json"), "s.csv", &extra)
        .unwrap();
    std::fs::write(
        dir.join("made/summary.json"),
        r#"{"fabrication": {"tool": {"kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.01}}}"#,
    )
    .unwrap();
    let o = run(&["plan", "made/shallow.json", "--out", "made/s.nc"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{e}");
    let g = std::fs::read_to_string(dir.join("made/s.nc")).unwrap();
    assert!(
        format!("{e}{g}").contains("the surface at commanded depth -0.0100 mm"),
        "{e}\n{g}"
    );
    // Forced: written, with a warning and the header's record.
    let o = run(&["plan", "plain.json", "--tool", "tool.json", "--out", "f.nc", "--force"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert!(e.contains("warning: --force"), "{e}");
    let g = std::fs::read_to_string(dir.join("f.nc")).unwrap();
    assert!(
        g.contains("forced (--force)") && g.contains("not the tool's cut"),
        "{g}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `plan --print-machine` prints the built-in profile as a machine.json to start from; a file
/// with a few fields plans over the built-in profile (an unknown key warned about, the old
/// `safe_z_mm` read as the clearance), and a bad value is refused with exit 3 naming the field.
#[test]
fn the_machine_profile_is_printed_and_read_back() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-profile-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    for (machine, want) in [
        ("grbl", scratchart_tool::machine::MachineProfile::grbl()),
        ("marlin", scratchart_tool::machine::MachineProfile::marlin()),
    ] {
        let o = run(&["plan", "--print-machine", "--machine", machine]);
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
        let got: scratchart_tool::machine::MachineProfile = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(got, want);
    }
    design(60.0).save(&dir.join("design.json"), "s.csv").unwrap();
    std::fs::write(
        dir.join("tool.json"),
        r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.0 }"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("m.json"),
        r#"{"safe_z_mm": 4, "retract_mm": 0.5, "retrakt": 1}"#,
    )
    .unwrap();
    let o = run(&[
        "plan",
        "design.json",
        "--tool",
        "tool.json",
        "--machine-file",
        "m.json",
        "--out",
        "p.nc",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("unknown key `retrakt`") && err.contains("`retract_mm`"),
        "{err}"
    );
    let g = std::fs::read_to_string(dir.join("p.nc")).unwrap();
    assert!(
        g.contains("G0 Z0.500") && g.contains("G0 Z4.000"),
        "retract and clearance heights:\n{g}"
    );
    std::fs::write(dir.join("bad.json"), r#"{"cut_mm_min": "fast"}"#).unwrap();
    let o = run(&[
        "plan",
        "design.json",
        "--tool",
        "tool.json",
        "--machine-file",
        "bad.json",
        "--out",
        "q.nc",
    ]);
    assert_eq!(o.status.code(), Some(3));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("cut_mm_min"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!dir.join("q.nc").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every plan carves the registration marks (the card's six hatched squares in the plate's
/// corners, by which `inspect` finds the plate in photos) after the scratches: each hatch line a
/// block `; mark LABEL hatch K` inside its mark's square, at least 0.5 mm inside the plate, at the
/// design's deepest depth; the plan reads back for `carve` with them; the header counts them and
/// the scratches that cross a square (which stay in the plan). `--no-marks` leaves them out.
#[test]
fn registration_marks_are_cut_after_the_scratches_unless_turned_off() {
    let (bin, dir) = setup("registration");
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    for plate in [40.0, 100.0] {
        let mut scene = design(plate);
        // One more scratch, across the -x -y corner's mark.
        let mut across = scene.scratches[0];
        (across.p0, across.p1) = ([-0.49 * plate, -0.49 * plate], [-0.4 * plate, -0.43 * plate]);
        scene.scratches.push(across);
        scene.save(&dir.join("design.json"), "s.csv").unwrap();
        let o = run(&["plan", "design.json", "--tool", "tool.json", "--out", "p.nc"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let g = std::fs::read_to_string(dir.join("p.nc")).unwrap();
        let blocks = blocks_of(&g);
        let reg = plate_marks(plate, &scene.views);
        let hatches = reg.hatches();
        assert_eq!(reg.marks.len(), 6);
        let is_hatch = |l: &str| l.starts_with("mark ") && l != "mark +x edge";
        let first = blocks.iter().position(|b| is_hatch(&b.0)).expect("registration marks");
        assert!(
            blocks[..first].iter().filter(|b| b.0.starts_with("scratch ")).count() == 41
                && blocks[first..].iter().all(|b| is_hatch(&b.0)),
            "the marks come after every scratch (and the +x mark)"
        );
        assert_eq!(blocks.len() - first, hatches.iter().map(Vec::len).sum::<usize>());
        let deepest = blocks
            .iter()
            .filter(|b| b.0.starts_with("scratch "))
            .flat_map(|b| b.1.iter().map(|p| -p[2]))
            .fold(0.0, f64::max);
        let h = 0.5 * plate - 0.5;
        for (m, hatch) in reg.marks.iter().zip(&hatches) {
            assert!(
                m.centre[0].abs() + m.half_mm <= h && m.centre[1].abs() + m.half_mm <= h,
                "{plate} mm: {m:?} is not 0.5 mm inside the plate"
            );
            let mine: Vec<_> = blocks[first..]
                .iter()
                .filter(|b| b.0.strip_prefix("mark ").unwrap().rsplit_once(" hatch ").unwrap().0 == m.label)
                .collect();
            assert!(
                hatch.len() >= 10 && mine.len() == hatch.len(),
                "{}: {}",
                m.label,
                mine.len()
            );
            for (k, (label, pts)) in mine.iter().enumerate() {
                assert_eq!(*label, format!("mark {} hatch {}", m.label, k + 1));
                assert_eq!(pts.len(), 2, "{label}: one plunge and one line");
                for p in pts {
                    assert!(m.covers([p[0], p[1]], 1e-4), "{label}: {p:?} outside {m:?}");
                    assert!((p[2] + deepest).abs() < 1e-4, "{label}: at {} mm, not {deepest}", -p[2]);
                }
            }
        }
        // `carve` reads the plan back with every mark's block (and streams each block it reads).
        let p = Program::parse(&g).unwrap();
        assert_eq!(p.blocks.len(), blocks.len());
        let read: Vec<&str> = p.blocks.iter().map(|b| b.label.as_str()).collect();
        assert_eq!(read, blocks.iter().map(|b| b.0.as_str()).collect::<Vec<_>>());
        assert!(p.blocks[first..]
            .iter()
            .all(|b| b.scratch.is_none() && b.lines.iter().any(|l| l.starts_with("G1 X"))));
        let header = g
            .lines()
            .take_while(|l| l.starts_with(';'))
            .map(|l| &l[2..])
            .collect::<Vec<_>>()
            .join(" ");
        let n = blocks.len() - first;
        let side = 2.0 * reg.marks[0].half_mm;
        assert!(
            header.contains(&format!("6 hatched squares of {side:.2} mm"))
                && header.contains(&format!("{n} hatch cuts"))
                && header.contains("1 of the design's 41 scratches cross a square")
                && header.contains("they stay in the plan")
                && header.contains("the registration marks take"),
            "{header}"
        );
        // The preview draws their hatches (orange, a colour the depth scale never takes).
        let png = image::open(dir.join("p.png")).unwrap().to_rgb8();
        assert!(png.pixels().filter(|p| p.0 == [235, 110, 0]).count() > 100);
        let said = String::from_utf8_lossy(&o.stdout);
        assert!(
            said.contains(&format!("the registration marks in {n} hatch cuts")),
            "{said}"
        );
        // --no-marks: the same plan without them; the +x mark stays.
        let o = run(&[
            "plan",
            "design.json",
            "--tool",
            "tool.json",
            "--out",
            "n.nc",
            "--no-marks",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let n = std::fs::read_to_string(dir.join("n.nc")).unwrap();
        let without = blocks_of(&n);
        assert_eq!(without, blocks[..first].to_vec());
        assert!(!n.contains("registration marks"));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
