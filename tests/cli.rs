//! The command lines as a user meets them: one exit-code contract for every binary (0 success,
//! 1 runtime failure, 2 bad command line, 3 bad input file, 4 GPU/device, 130 interrupted), sizes
//! checked before any work, warnings for scenes that must render black, Ctrl-C during `design`.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn bin(name: &str) -> PathBuf {
    let package = match name {
        "scratchart-view" => "scratchart-view",
        "scratchart-cal" => "scratchart-calibration",
        _ => "scratchart",
    };
    scratchart_tests::workspace_bin(package, name)
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(bin_name: &str, args: &[&str]) -> Output {
    Command::new(bin(bin_name)).args(args).output().unwrap()
}

fn expect(out: &Output, code: i32, needle: &str, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{what}: exit code; stderr:\n{err}");
    assert!(err.contains(needle), "{what}: stderr should mention '{needle}':\n{err}");
}

const SCENE: &str = r#"{"plate":{"size_mm":20},"views":[{"name":"v","camera":{"eye":[0,-40,40],"target":[0,0,0],"up":[0,0,1],"fov_y_deg":30,"width":16,"height":16},"light":{"kind":"point","position":[0,40,40],"intensity":1000}}],"scratches":[[0,0,5,1,0.1,0.1,0.1]]}"#;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn scratchart_exit_codes() {
    let d = tmp("codes");
    let scene = write(&d, "scene.json", SCENE);
    let out = d.join("out");
    let out = out.to_str().unwrap();
    // 0
    let o = run("scratchart", &["render", &scene, "--out", out]);
    expect(&o, 0, "wrote", "render of a valid scene");
    // 2: unknown flag, and flag values that cannot work
    expect(
        &run("scratchart", &["render", "--no-such-flag"]),
        2,
        "no-such-flag",
        "unknown flag",
    );
    expect(
        &run("scratchart", &["design", "--scratches", "0", "--out", out]),
        2,
        "--scratches",
        "--scratches 0",
    );
    expect(
        &run("scratchart", &["design", "--elevation", "95", "--out", out]),
        2,
        "--elevation",
        "--elevation 95",
    );
    expect(
        &run("scratchart", &["design", "--gamma", "0", "--out", out]),
        2,
        "--gamma",
        "--gamma 0",
    );
    expect(
        &run("scratchart", &["design", "--fit", "stretch", "--out", out]),
        2,
        "contain, frame, cover or printed",
        "--fit stretch",
    );
    expect(
        &run("scratchart", &["design", "--init-alpha", "1.5", "--out", out]),
        2,
        "--init-alpha",
        "--init-alpha 1.5",
    );
    // 1: an output that cannot be written (/dev/null is a file, not a directory)
    expect(
        &run("scratchart", &["render", &scene, "--out", "/dev/null/out"]),
        1,
        "/dev/null/out",
        "render to an unwritable directory",
    );
    expect(
        &run(
            "scratchart",
            &[
                "design",
                "--scratches",
                "50",
                "--res",
                "16",
                "--iters",
                "1",
                "--out",
                "/dev/null/out",
            ],
        ),
        1,
        "/dev/null/out",
        "design to an unwritable directory",
    );
    // 3: a missing scene file, named once with its OS error once
    let o = run("scratchart", &["render", "/nonexistent/scene.json", "--out", out]);
    expect(&o, 3, "/nonexistent/scene.json", "missing scene");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.matches("os error").count(), 1, "the OS error is said once: {err}");
    // 3: a bad scene file
    let bad = write(&d, "bad.json", "{ \"plate\": ");
    expect(
        &run("scratchart", &["render", &bad, "--out", out]),
        3,
        "bad.json",
        "malformed scene",
    );
    // 3: a target of the wrong size for `grad`
    let tdir = d.join("targets");
    std::fs::create_dir_all(&tdir).unwrap();
    scratchart_render::io::write_pfm(&tdir.join("v.pfm"), 8, 8, &[0.5; 64]).unwrap();
    expect(
        &run(
            "scratchart",
            &[
                "grad",
                &scene,
                "--targets",
                tdir.to_str().unwrap(),
                "--out",
                d.join("g.csv").to_str().unwrap(),
            ],
        ),
        3,
        "8x8",
        "grad target of the wrong size",
    );
    // 1: an output that cannot be written, the same for every command (its parent is a file)
    let blocked = format!("{scene}/out");
    let tdir_ok = d.join("targets_ok");
    std::fs::create_dir_all(&tdir_ok).unwrap();
    std::fs::copy(d.join("out").join("v.pfm"), tdir_ok.join("v.pfm")).unwrap();
    for args in [
        vec!["render", &scene, "--out", &blocked],
        vec![
            "grad",
            &scene,
            "--targets",
            tdir_ok.to_str().unwrap(),
            "--out",
            &format!("{blocked}/g.csv"),
        ],
    ] {
        expect(
            &run("scratchart", &args),
            1,
            "cannot create",
            &format!("{} to an unwritable output", args[0]),
        );
    }
    // 2: an unknown standard benchmark scene
    expect(
        &run("scratchart", &["bench", "--sizes", "XL"]),
        2,
        "XL",
        "bench --sizes XL",
    );
    // 4: no such device
    expect(
        &run(
            "scratchart",
            &["render", &scene, "--out", out, "--device", "no-such-device-xyz"],
        ),
        4,
        "no-such-device-xyz",
        "unknown device",
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn viewer_exit_codes() {
    let d = tmp("view-codes");
    let scene = write(&d, "scene.json", SCENE);
    let png = d.join("s.png");
    let png = png.to_str().unwrap();
    expect(
        &run("scratchart-view", &[&scene, "--view", "0", "--screenshot", png]),
        0,
        "wrote",
        "viewer screenshot",
    );
    expect(
        &run("scratchart-view", &[&scene, "--view", "7", "--screenshot", png]),
        2,
        "no view '7'",
        "viewer --view 7 of a one-view scene",
    );
    expect(
        &run("scratchart-view", &["--no-such-flag"]),
        2,
        "no-such-flag",
        "viewer unknown flag",
    );
    // A screenshot is a PNG: another name is refused before anything renders.
    let jpg = d.join("y.jpg");
    expect(
        &run(
            "scratchart-view",
            &[&scene, "--view", "0", "--screenshot", jpg.to_str().unwrap()],
        ),
        2,
        "ending in .png",
        "viewer --screenshot y.jpg",
    );
    assert!(!jpg.exists(), "nothing written under a .jpg name");
    expect(
        &run(
            "scratchart-view",
            &[&scene, "--view", "0", "--screenshot", png, "--exposure", "-1"],
        ),
        2,
        "--exposure -1",
        "viewer --exposure -1",
    );
    expect(
        &run(
            "scratchart-view",
            &[&scene, "--view", "0", "--screenshot", "/dev/null/s.png"],
        ),
        1,
        "/dev/null/s.png",
        "viewer screenshot to an unwritable path",
    );
    let bad = write(&d, "bad.json", "{ \"plate\": ");
    expect(
        &run("scratchart-view", &[&bad, "--view", "0", "--screenshot", png]),
        3,
        "bad.json",
        "viewer bad design",
    );
    expect(
        &run(
            "scratchart-view",
            &[
                &scene,
                "--view",
                "0",
                "--screenshot",
                png,
                "--device",
                "no-such-device-xyz",
            ],
        ),
        4,
        "no-such-device-xyz",
        "viewer unknown device",
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `--res 100000` and `--res 6000` fail at once (not after minutes and gigabytes), naming the
/// flag and the largest value that fits; the largest value reported does fit.
#[test]
fn design_sizes_are_checked_before_any_work() {
    let d = tmp("sizes");
    let out = d.join("out");
    let out = out.to_str().unwrap();
    for res in ["100000", "6000"] {
        let t0 = Instant::now();
        let o = run("scratchart", &["design", "--res", res, "--out", out]);
        expect(&o, 2, "the largest that fits", &format!("--res {res}"));
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "--res {res} took {:?}",
            t0.elapsed()
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("--res"), "{err}");
        assert!(!std::path::Path::new(out).join("design.json").exists());
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn views_that_must_render_black_are_warned_about() {
    let d = tmp("black");
    let below = SCENE.replace("\"position\":[0,40,40]", "\"position\":[0,40,-5]");
    let scene = write(&d, "below.json", &below);
    let o = run(
        "scratchart",
        &["render", &scene, "--out", d.join("o").to_str().unwrap()],
    );
    expect(&o, 0, "the light is below the plate", "light below the plate");
    let empty = SCENE.replace("[[0,0,5,1,0.1,0.1,0.1]]", "[]");
    let scene = write(&d, "empty.json", &empty);
    let o = run(
        "scratchart",
        &["render", &scene, "--out", d.join("o").to_str().unwrap()],
    );
    expect(&o, 0, "0 scratches", "no scratches");
    let _ = std::fs::remove_dir_all(&d);
}

/// Ctrl-C during `design` saves a checkpoint, says how to resume and exits with 130; the
/// resumed run finishes.
#[test]
fn design_interrupted_by_ctrl_c_saves_and_resumes() {
    let d = tmp("sigint");
    let out = d.join("out");
    let out_s = out.to_str().unwrap().to_string();
    let args = [
        "design",
        "--scratches",
        "300",
        "--res",
        "24",
        "--iters",
        "100000",
        "--out",
        &out_s,
        "--prune-tol",
        "0",
    ];
    let mut child = Command::new(bin("scratchart"))
        .args(args)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the optimization runs (its first progress line), then interrupt.
    std::thread::sleep(Duration::from_secs(4));
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "design did not stop after Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "stderr:\n{err}");
    assert!(err.contains("--resume"), "the message gives the resume command:\n{err}");
    assert!(
        out.join("checkpoint.bin").exists(),
        "a checkpoint is written at the interrupt"
    );
    let at: u32 = err
        .split("interrupted at iteration ")
        .nth(1)
        .and_then(|t| t.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("expected the iteration of the interrupt in:\n{err}"));
    // The resumed run continues from there to a few more iterations and finishes.
    let iters = (at + 2).to_string();
    let o = run(
        "scratchart",
        &[
            "design",
            "--scratches",
            "300",
            "--res",
            "24",
            "--iters",
            &iters,
            "--out",
            &out_s,
            "--prune-tol",
            "0",
            "--resume",
        ],
    );
    expect(&o, 0, "", "resumed run");
    assert!(out.join("design.json").exists());
    let _ = std::fs::remove_dir_all(&d);
}

/// With stderr in a log (not a terminal), `design` prints plain progress lines that end at
/// N/N for `--iters N`, and its summary says how many scratches pruning kept.
#[test]
fn design_progress_in_a_log_and_the_count_kept() {
    let d = tmp("progress");
    let out = d.join("out");
    let o = run(
        "scratchart",
        &[
            "design",
            "--scratches",
            "200",
            "--res",
            "16",
            "--iters",
            "4",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    expect(&o, 0, "design: 4/4", "progress lines in a log");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("design:"))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(line.contains("scratches written (200 optimized)"), "{line}");
    let _ = std::fs::remove_dir_all(&d);
}

/// Every binary ends through the one contract: no `process::exit` anywhere in the workspace's
/// sources but `scratchart_exit::exit_now` (for a signal handler that cannot return to main).
#[test]
fn no_process_exit_outside_the_exit_contract() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let mut stack = vec![root.clone()];
    let mut offenders = Vec::new();
    let mut seen = 0;
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if p.is_dir() {
                if !name.starts_with('.') && name != "target" {
                    stack.push(p);
                }
                continue;
            }
            if p.extension().is_some_and(|x| x == "rs") {
                seen += 1;
                let text = std::fs::read_to_string(&p).unwrap();
                if !p.ends_with("engine/exit/src/lib.rs") && text.contains(concat!("process::", "exit(")) {
                    offenders.push(p.strip_prefix(&root).unwrap().display().to_string());
                }
            }
        }
    }
    assert!(seen > 100, "only {seen} Rust files found under {}", root.display());
    assert!(
        offenders.is_empty(),
        "process::exit outside scratchart_exit::exit_now: {offenders:?}"
    );
}

/// A uniform picture (a 1 x 1 image, a blank frame) has nothing for its view to show: `design`
/// refuses it with exit 3, naming the picture, its view and `--blank-view`; with
/// `--blank-view NAME` the view is blank on purpose, `summary.json` lists it, and both paths
/// to the set-up sheet (`design` and `setup`) say so instead of giving tolerances.
#[test]
fn a_uniform_picture_is_refused_unless_its_view_is_blank_on_purpose() {
    let dir = tmp("blank");
    let one = dir.join("one.png");
    image::GrayImage::from_raw(1, 1, vec![200]).unwrap().save(&one).unwrap();
    let data = |f: &str| Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(f);
    let (a, c) = (data("astronaut.png"), data("coffee.png"));
    let out = dir.join("d");
    let args = |extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = ["design", "--targets"].iter().map(|s| s.to_string()).collect();
        for p in [&a, &one, &c] {
            v.push(p.display().to_string());
        }
        // (200 scratches and 30 iterations: enough for a view to show its picture under the
        // lamp overhead (60 were, barely, under the lamp 65 degrees up); a design that shows
        // none fails)
        for s in ["--scratches", "200", "--iters", "30", "--res", "32", "--out"] {
            v.push(s.into());
        }
        v.push(out.display().to_string());
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let o = Command::new(bin("scratchart")).args(args(&[])).output().unwrap();
    expect(&o, 3, "one.png (the picture of view v1) is uniform", "a 1x1 target");
    expect(&o, 3, "--blank-view v1", "the flag that allows it");
    assert!(!out.join("design.json").exists(), "nothing designed");
    let o = Command::new(bin("scratchart"))
        .args(args(&["--blank-view", "v7"]))
        .output()
        .unwrap();
    expect(&o, 2, "--blank-view v7: no view is named so", "an unknown view");
    let o = Command::new(bin("scratchart"))
        .args(args(&["--blank-view", "v1"]))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["blank_views"], serde_json::json!(["v1"]));
    let sheet = std::fs::read_to_string(out.join("setup.txt")).unwrap();
    assert!(sheet.contains("v1: blank on purpose"), "{sheet}");
    assert!(!sheet.contains("v1: does not show its picture yet"), "{sheet}");
    let again = dir.join("s");
    let o = run(
        "scratchart",
        &[
            "setup",
            out.join("design.json").to_str().unwrap(),
            "--out",
            again.to_str().unwrap(),
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let sheet2 = std::fs::read_to_string(again.join("setup.txt")).unwrap();
    assert!(sheet2.contains("v1: blank on purpose"), "{sheet2}");
}

/// `design` and `setup` build the set-up sheet through one function from the same inputs (the
/// targets as the loss saw them, the pictures' pixels, the blur, written beside the design): on a
/// photo design the two sheets are the same to the last digit, text, drawing and summary. A
/// design without those inputs still gets a sheet, with a warning that it is approximate.
#[test]
fn design_and_setup_write_the_same_sheet() {
    let dir = tmp("sheet");
    let out = dir.join("d");
    photo_design(&out);
    let again = dir.join("s");
    let o = setup_of(&out, &again);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("warning"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let read = |p: PathBuf| std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let (t1, t2) = (read(out.join("setup.txt")), read(again.join("setup.txt")));
    assert!(
        t1 == t2,
        "design's sheet:\n{}\nsetup's sheet:\n{}",
        String::from_utf8_lossy(&t1),
        String::from_utf8_lossy(&t2)
    );
    assert!(
        read(out.join("setup.png")) == read(again.join("setup.png")),
        "the drawings differ"
    );
    one_lamp_as_printed(&out, &String::from_utf8_lossy(&o.stdout));
    // The sheet names tolerances found for the lamp and the eye, and the tightest of all.
    let text = String::from_utf8_lossy(&t1);
    assert_eq!(text.matches("\nLamp: ").count(), 1, "{text}");
    assert!(text.contains("Most sensitive: "), "{text}");
    assert!(text.contains("the eye may move"), "{text}");
    older_and_damaged_inputs(&dir, &out);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The summary's setup, as `setup` printed it (`printed`), is the design's in `out`: one lamp with
/// one intensity (the default `--exposure fixed`: the views keep exposure 1) for all three views.
fn one_lamp_as_printed(out: &Path, printed: &str) {
    let read = |p: PathBuf| std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let summary: serde_json::Value = serde_json::from_slice(&read(out.join("summary.json"))).unwrap();
    let line = printed
        .lines()
        .find(|l| l.trim_start().starts_with("{\""))
        .expect("setup prints its JSON");
    let setup_json: serde_json::Value = serde_json::from_str(line).unwrap();
    assert_eq!(setup_json, summary["setup"]);
    let design: serde_json::Value = serde_json::from_slice(&read(out.join("design.json"))).unwrap();
    let views = design["views"].as_array().unwrap();
    assert!(
        views
            .iter()
            .all(|v| v["light"] == views[0]["light"] && v.get("exposure").is_none()),
        "{views:?}"
    );
    assert_eq!(summary["setup"]["lamps"].as_array().unwrap().len(), 1);
    assert_eq!(
        summary["setup"]["lamps"][0]["views"],
        serde_json::json!(["v0", "v1", "v2"])
    );
}

/// A 3-view design of the test photos into `out` (30 iterations at 48 px).
fn photo_design(out: &Path) {
    let data = |f: &str| Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(f);
    let mut args: Vec<String> = vec!["design".into(), "--targets".into()];
    for f in ["astronaut.png", "chelsea.png", "coffee.png"] {
        args.push(data(f).display().to_string());
    }
    for s in [
        "--scratches",
        "1500",
        "--iters",
        "30",
        "--res",
        "48",
        "--quiet",
        "--out",
    ] {
        args.push(s.into());
    }
    args.push(out.display().to_string());
    let o = Command::new(bin("scratchart")).args(&args).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `scratchart setup OUT/design.json --out DIR`.
fn setup_of(out: &Path, dir: &Path) -> Output {
    run(
        "scratchart",
        &[
            "setup",
            out.join("design.json").to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
        ],
    )
}

/// The design in `out` without the sheet's inputs (a design of an older version): a sheet with
/// a warning; with damaged inputs: a clear error (exit 3) naming the file.
fn older_and_damaged_inputs(dir: &Path, out: &Path) {
    std::fs::remove_file(out.join("setup_inputs.json")).unwrap();
    let third = dir.join("t");
    let o = setup_of(out, &third);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    expect(
        &o,
        0,
        "warning: no setup_inputs.json beside the design",
        "an older design",
    );
    assert!(third.join("setup.txt").exists());
    std::fs::write(out.join("setup_inputs.json"), "{\"sigma_px\": \"x\"}").unwrap();
    let o = setup_of(out, &dir.join("u"));
    expect(&o, 3, "setup_inputs.json", "damaged inputs");
}

/// A negative number reaches the range check that says what works (not clap's "unexpected
/// argument '-5'").
#[test]
fn negative_numbers_reach_the_range_checks() {
    let d = tmp("negative");
    let out = d.join("out");
    expect(
        &run(
            "scratchart",
            &["design", "--plate", "-5", "--out", out.to_str().unwrap()],
        ),
        2,
        "--plate must be > 0 mm",
        "--plate -5",
    );
    for (flag, share) in ["--aim", "--lr-final"]
        .iter()
        .flat_map(|f| ["-0.5", "1.5", "NaN"].map(|s| (*f, s)))
    {
        let o = run("scratchart", &["design", flag, share, "--out", out.to_str().unwrap()]);
        expect(&o, 2, &format!("{flag} must be a share between 0 and 1"), share);
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// The calibration's camera flags out of what a camera can be, negative ones included, are
/// refused with exit 2 before any work, naming the range; the card's set-up lines never print -0.
#[test]
fn calibration_flags_out_of_range_and_the_cards_numbers() {
    let d = tmp("cal-flags");
    for (flag, value, says) in [
        ("--blur", "-1", "--blur -1: a Gaussian blur of 0 to 20 pixels"),
        ("--noise", "5", "--noise 5: a standard deviation of 0 to 0.5"),
        ("--exposure", "0", "--exposure 0: a factor above 0"),
        ("--megapixels", "-3", "--megapixels -3"),
    ] {
        let o = run(
            "scratchart-cal",
            &[
                "simulate",
                "--card",
                "no-card.json",
                "--tool",
                "no-tool.json",
                flag,
                value,
            ],
        );
        expect(&o, 2, says, &format!("simulate {flag} {value}"));
    }
    let out = d.join("card");
    let o = run("scratchart-cal", &["card", "--out", out.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("lamp at ("), "{text}");
    assert!(
        !text.contains("(-0,") && !text.contains(" -0,") && !text.contains(" -0)"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
