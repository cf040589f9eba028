//! Designs within a machine (`scratchart design --tool T --machine grbl|marlin`, issue 27):
//! the machine's limits kept, what its error costs (`--carvings`, `--robust`), a job time the
//! maker chooses (`--max-job-min`). Each test reads what it checks back independently: the
//! scratch CSV, and the G-code `scratchart-cal plan` writes, line by line.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use scratchart_machine::marks::plate_marks;
use scratchart_model::scene::Scene;
use scratchart_tests::*;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-machine-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A 75-degree V-bit with a 0.01 mm flat and a 0.007 mm z offset, written to `dir/tool.json`.
fn vbit75(dir: &Path) -> String {
    write_file(
        dir,
        "tool.json",
        r#"{"kind": "v-bit", "angle_deg": 75.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.007}"#,
    )
}

/// The small design of [`tool_design_args`] without the validation layer (the CLI runs are the
/// longest here; the library tests keep it on), with `extra` flags: a flag it already has gets
/// the new value, others are added.
fn design(tool: &str, out: &str, extra: &[&str]) -> Output {
    let mut args = tool_design_args(tool, out);
    args.retain(|a| *a != "--validation");
    let mut i = 0;
    while i < extra.len() {
        let value = extra.get(i + 1).filter(|v| !v.starts_with("--"));
        match (args.iter().position(|a| *a == extra[i]), value) {
            (Some(at), Some(v)) => args[at + 1] = v,
            _ => {
                args.push(extra[i]);
                args.extend(value);
            }
        }
        i += 1 + usize::from(value.is_some());
    }
    run_scratchart(&args)
}

fn summary(out: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(format!("{out}/summary.json")).unwrap()).unwrap()
}

/// `scratchart-cal plan OUT/design.json EXTRA... --out OUT/plan.nc`; the G-code.
fn plan(out: &str, extra: &[&str]) -> String {
    let nc = format!("{out}/plan.nc");
    let design = format!("{out}/design.json");
    let mut args = vec!["plan", design.as_str()];
    args.extend(extra);
    args.extend(["--out", nc.as_str()]);
    let o = Command::new(workspace_bin("scratchart-calibration", "scratchart-cal"))
        .args(&args)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read_to_string(&nc).unwrap()
}

/// The value of word `c` (`X`, `Z`, `F`, ...) on a G-code line.
fn word(l: &str, c: char) -> Option<f64> {
    l.split_whitespace()
        .find(|w| w.starts_with(c))
        .and_then(|w| w[1..].parse().ok())
}

/// `design --tool --machine`: every commanded depth lies at least the profile's shallowest cut
/// below the surface (the tool's z offset moves the surface) and on its Z grid, every scratch is
/// at least --min-length-mm long, and summary.json counts what each limit touched. Read back from
/// the CSV, and from the G-code `scratchart-cal plan` writes for it, independently.
#[test]
fn a_machine_design_keeps_the_machines_limits() {
    let dir = tmp_dir("machine");
    let d = dir.to_str().unwrap();
    let tool = vbit75(&dir);
    let machine = write_file(&dir, "machine.json", r#"{"min_cut_depth_mm": 0.1, "z_step_mm": 0.005}"#);
    let out = format!("{d}/out");
    // Limits the design must meet: a third of the initial scratches (2 to 8 mm) are shorter than
    // 4 mm, and the shallowest cut (0.1 mm) is deeper than the initial grooves (0.092 mm).
    let o = design(
        &tool,
        &out,
        &[
            "--scratches",
            "300",
            "--iters",
            "15",
            "--machine-file",
            &machine,
            "--min-length-mm",
            "4",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let (scene, extra) = Scene::load_extra(Path::new(&format!("{out}/design.json"))).unwrap();
    let z = extra.column("z_mm").unwrap();
    let (min_cut, step, offset, min_len) = (0.1, 0.005, 0.007, 4.0);
    let mut at_floor = 0;
    for (k, (&z, s)) in z.iter().zip(&scene.scratches).enumerate() {
        assert!(
            z + offset >= min_cut - 1e-12,
            "scratch {}: cut {} mm below the surface",
            k + 1,
            z + offset
        );
        assert!(
            ((z / step).round() * step - z).abs() < 1e-12,
            "scratch {}: z {z} is off the grid",
            k + 1
        );
        let len = (s.p1[0] - s.p0[0]).hypot(s.p1[1] - s.p0[1]);
        assert!(len >= min_len, "scratch {}: {len} mm long", k + 1);
        if z + offset < min_cut + 0.5 * step {
            at_floor += 1;
        }
    }
    let summary = summary(&out);
    let m = &summary["machine"];
    assert_eq!(m["at_min_cut_depth"], serde_json::json!(at_floor), "{m}");
    assert_eq!(m["off_z_grid"], 0);
    assert_eq!(m["min_length_mm"], min_len);
    assert!(
        at_floor > 0,
        "no scratch reached the shallowest cut: the test does not test it"
    );
    let shortest = scene
        .scratches
        .iter()
        .map(|s| (s.p1[0] - s.p0[0]).hypot(s.p1[1] - s.p0[1]))
        .fold(f64::INFINITY, f64::min);
    assert!(
        shortest < min_len + 1e-3,
        "no scratch at the shortest length ({shortest}): the test does not test it"
    );
    assert!(m["at_min_length"].as_u64().unwrap() > 0, "{m}");
    assert!(m["scratches"].as_u64() == Some(z.len() as u64));
    eprintln!("{m}");
    // The plan's G-code, read line by line: each plunge's depth below the surface (the
    // registration marks' too) and each scratch's length.
    let g = plan(&out, &["--tool", &tool, "--no-mark"]);
    let (mut at, mut cuts) = ([0.0f64; 2], 0);
    let (mut depth, mut scratch, mut marks) = (0.0, false, 0);
    for l in g.lines() {
        if let Some(c) = l.strip_prefix("; ") {
            (scratch, marks) = (c.starts_with("scratch "), marks + usize::from(c.starts_with("mark ")));
            continue;
        }
        let (x, y) = (word(l, 'X'), word(l, 'Y'));
        if l.starts_with("G1 Z") {
            depth = -word(l, 'Z').unwrap();
            assert!(
                depth + offset >= min_cut - 1e-9,
                "`{l}`: {} mm below the surface",
                depth + offset
            );
        } else if l.starts_with("G1 X") && scratch {
            let b = [x.unwrap(), y.unwrap()];
            let len = (b[0] - at[0]).hypot(b[1] - at[1]);
            assert!(len >= min_len, "`{l}`: a cut {len} mm long at depth {depth}");
            cuts += 1;
        }
        if let (Some(x), Some(y)) = (x, y) {
            at = [x, y];
        }
    }
    assert_eq!(cuts, z.len());
    assert!(marks > 6, "the registration marks' hatch lines: {marks}");
    // The job time the design states is the one `plan` states for the same machine by default:
    // the +x mark and the registration marks included, whose share both state. `--no-marks`
    // leaves theirs out: the plan without them takes that much less.
    let stated = |g: &str| -> (f64, f64) {
        let header = g
            .lines()
            .filter_map(|l| l.strip_prefix("; "))
            .collect::<Vec<_>>()
            .join(" ");
        let after = |key: &str| {
            header
                .split(key)
                .nth(1)
                .and_then(|r| r.split(' ').next())
                .and_then(|v| v.parse().ok())
        };
        (
            after("estimated job time ").expect("the plan states its job time"),
            after("the registration marks take ").unwrap_or(0.0),
        )
    };
    let (with, share) = stated(&plan(&out, &["--tool", &tool]));
    let job_min = m["job_min"].as_f64().unwrap();
    let marks_min = m["registration_marks_min"].as_f64().unwrap();
    assert!(
        job_min > 0.0 && (job_min - with).abs() <= 0.051 + 0.01 * with,
        "design says {job_min} min, plan {with} min"
    );
    assert!(
        share > 0.0 && (marks_min - share).abs() <= 0.051 + 0.01 * share,
        "the registration marks: design says {marks_min} min, plan {share} min"
    );
    let (bare, none) = stated(&plan(&out, &["--tool", &tool, "--no-marks"]));
    assert!(
        none == 0.0 && (with - share - bare).abs() <= 0.16,
        "the plan with the registration marks: {with} min, {share} min of it theirs; {bare} min without"
    );
    assert!(m["job_min_upper_bound"].as_f64().unwrap() >= job_min, "{m}");
}

/// `design --robust` through the command line: a design trained on carvings with the
/// machine's error, stopped and resumed bit for bit (each iteration's carving comes from its
/// number), whose summary reports each view's correlation as written and as carved, and which
/// differs from the same design without --robust; --robust without --machine is a usage error.
#[test]
fn a_robust_design_reports_what_the_machines_error_costs_and_resumes_bit_exactly() {
    let dir = tmp_dir("robust");
    let d = dir.to_str().unwrap();
    let tool = vbit75(&dir);
    let run = |name: &str, extra: &[&str]| -> (std::process::Output, String) {
        let out = format!("{d}/{name}");
        let mut args = vec!["--machine", "grbl", "--carvings", "3", "--checkpoint-every", "1"];
        args.extend(extra);
        (design(&tool, &out, &args), out)
    };
    let (o, plain) = run("plain", &[]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let (o, robust) = run("robust", &["--robust"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("designed with --robust") && stdout.contains("as carved"),
        "{stdout}"
    );
    let (sp, sr) = (summary(&plain), summary(&robust));
    for (s, robust) in [(&sp, false), (&sr, true)] {
        let e = &s["machine_error"];
        assert_eq!(e["robust"], robust, "{e}");
        assert_eq!(e["carvings"], 3);
        assert_eq!(e["sigma_z_mm"], 0.015);
        let views = e["per_view"].as_array().unwrap();
        assert_eq!(views.len(), 2);
        for v in views {
            let (exact, mean, worst) = (
                v["corr_exact"].as_f64().unwrap(),
                v["corr_carved_mean"].as_f64().unwrap(),
                v["corr_carved_worst"].as_f64().unwrap(),
            );
            assert!(exact.is_finite() && mean.is_finite() && worst <= mean + 1e-12, "{v}");
            assert!(
                v["corr_carved_std"].as_f64().unwrap() > 0.0,
                "carvings that all look the same: {v}"
            );
        }
    }
    let csv = |out: &str| std::fs::read_to_string(format!("{out}/scratches.csv")).unwrap();
    assert_ne!(csv(&plain), csv(&robust), "--robust changed nothing");
    // Stopped after iteration 2's checkpoint and resumed: the same design as the robust run.
    let (o, _) = run("stopped", &["--robust", "--inject-stop-at", "2"]);
    assert_ne!(o.status.code(), Some(0));
    let (o, stopped) = run("stopped", &["--robust", "--resume"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(csv(&stopped), csv(&robust), "the resumed robust design differs");
    // --robust needs the machine.
    let o = design(&tool, &stopped, &["--robust"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--machine"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `design --max-job-min` (issue 27 item 4): a limit the design meets as asked costs nothing;
/// a limit of half its job trims the design until the G-code `scratchart-cal plan` writes for
/// it, summed here move by move from rest at the profile's feeds, fits; the summary says what
/// the limit cost each view.
#[test]
fn a_job_limit_design_fits_its_plan_and_says_what_it_cost() {
    let dir = tmp_dir("joblimit");
    let d = dir.to_str().unwrap();
    let tool = vbit75(&dir);
    let run = |name: &str, limit: &str| -> (String, serde_json::Value) {
        let out = format!("{d}/{name}");
        let args = [
            "--iters",
            "6",
            "--machine",
            "grbl",
            "--carvings",
            "0",
            "--max-job-min",
            limit,
        ];
        let o = design(&tool, &out, &args);
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
        let j = summary(&out)["job_limit"].clone();
        (out, j)
    };
    // A limit shorter than one scratch's job is refused before any work, saying so.
    let o = design(
        &tool,
        &format!("{d}/short"),
        &["--machine", "grbl", "--max-job-min", "0.001"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("shorter than a job of one scratch"));
    assert!(!Path::new(&format!("{d}/short/unlimited")).exists());
    let (_, j) = run("loose", "1000");
    assert_eq!(j["fits_without_trimming"], true, "{j}");
    assert_eq!(j["limited"]["scratches"], j["unlimited"]["scratches"]);
    assert!(
        j["corr_cost"]
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c.as_f64().unwrap().abs() < 1e-3),
        "{j}"
    );
    let full = j["unlimited"]["job_min_upper"].as_f64().unwrap();
    let limit = 0.5 * full;
    let (out, j) = run("tight", &format!("{limit:.3}"));
    eprintln!("{j}");
    let n = j["limited"]["scratches"].as_u64().unwrap();
    assert!(n < j["unlimited"]["scratches"].as_u64().unwrap());
    assert!(j["limited"]["job_min_upper"].as_f64().unwrap() <= limit + 1e-6);
    assert_eq!(j["corr_cost"].as_array().unwrap().len(), 2);
    // The plan, read back and timed move by move from rest at the profile's feeds.
    let g = plan(&out, &["--machine", "grbl"]);
    // GRBL's built-in profile: rapids 1000 mm/min, 200 mm/s^2.
    let (rapid, accel) = (1000.0f64, 200.0f64);
    let move_secs = |len: f64, v_mm_min: f64| {
        let v = v_mm_min / 60.0;
        if len >= v * v / accel {
            len / v + v / accel
        } else {
            2.0 * (len / accel).sqrt()
        }
    };
    let (mut at, mut feed, mut secs, mut cuts) = ([0.0f64, 0.0, 2.0], rapid, 0.0, 0);
    for l in g.lines().filter(|l| !l.starts_with(';')) {
        if let Some(f) = word(l, 'F') {
            feed = f;
        }
        if l.starts_with("G4") {
            secs += word(l, 'P').unwrap();
        }
        if !(l.starts_with("G0") || l.starts_with("G1")) {
            continue;
        }
        let mut to = at;
        for (i, c) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            if let Some(v) = word(l, c) {
                to[i] = v;
            }
        }
        let len = ((to[0] - at[0]).powi(2) + (to[1] - at[1]).powi(2) + (to[2] - at[2]).powi(2)).sqrt();
        if len > 0.0 {
            secs += move_secs(len, if l.starts_with("G0") { rapid } else { feed });
        }
        if l.starts_with("G1 X") {
            cuts += 1;
        }
        at = to;
    }
    // The design's cuts, the +x mark and the registration marks' hatch lines (as the machine
    // crate lays them out for the design's plate and views), the limit holding them all.
    let scene = Scene::load(Path::new(&format!("{out}/design.json"))).unwrap();
    let hatch = plate_marks(scene.plate.size_mm, &scene.views).hatch_cuts();
    let said = summary(&out)["machine"]["registration_hatch_cuts"].as_u64();
    assert!(
        hatch > 0 && said == Some(hatch as u64),
        "{hatch} hatch cuts, the summary says {said:?}"
    );
    assert_eq!(
        cuts as u64,
        n + 1 + hatch as u64,
        "the design's cuts, the +x mark and the registration marks"
    );
    let mins = secs / 60.0; // (the spindle's dwell included)
    eprintln!("limit {limit:.3} min; the plan summed move by move: {mins:.3} min");
    assert!(
        mins <= limit,
        "the plan takes {mins} min by a move-by-move sum, over the limit of {limit}"
    );
    let stated = g
        .lines()
        .find_map(|l| l.strip_prefix("; estimated job time "))
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap();
    assert!(stated <= limit + 0.05 && stated <= mins + 0.05, "stated {stated} min");
    let _ = std::fs::remove_dir_all(&dir);
}
