//! The live design (`scratchart-view --design [design flags]`): the design job run in the
//! viewer, driven by script (run, pause, move the lamp, save, resume, stop), headless and in a
//! window; a design it saves is one `scratchart design --resume` continues to the same bits as
//! an uninterrupted `scratchart design`.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use scratchart_tests::{run_scratchart, viewer_bin, XServer};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-live-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small design's flags (2 views of 32 px, 300 scratches, no pruning, quiet).
const FLAGS: [&str; 11] = [
    "--views",
    "2",
    "--res",
    "32",
    "--scratches",
    "300",
    "--checkpoint-every",
    "0",
    "--prune-tol",
    "0",
    "--quiet",
];

fn live(display: Option<&str>, args: &[&str]) -> Output {
    let mut c = Command::new(viewer_bin());
    c.arg("--design").args(FLAGS).args(args);
    match display {
        Some(d) => c.env("DISPLAY", d),
        None => c.env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY"),
    };
    c.output().unwrap()
}

fn design(args: &[&str]) -> Output {
    let mut a = vec!["design"];
    a.extend(FLAGS);
    a.extend(args);
    run_scratchart(&a)
}

fn summary(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Headless, by script: run to iteration 5, pause, move the lamp, save, resume and stop there.
/// `scratchart design --resume` continues the saved run to iteration 12, and its scratches are
/// the same bits as an uninterrupted `scratchart design --iters 12`'s.
#[test]
fn a_live_design_saved_mid_run_continues_bit_for_bit() {
    let dir = tmp_dir("headless");
    let (a, b) = (dir.join("live"), dir.join("plain"));
    let (a_s, b_s) = (a.display().to_string(), b.display().to_string());
    let o = live(
        None,
        &[
            "--iters",
            "12",
            "--out",
            &a_s,
            "--headless",
            "--validation",
            "--script",
            "5:pause;5:lamp 30 60;5:save;5:resume;5:stop",
        ],
    );
    assert!(o.status.success(), "live design failed: {}", text(&o));
    let t = text(&o);
    assert!(t.contains("saved at iteration 5"), "{t}");
    assert!(t.contains("validation messages: 0"), "{t}");
    // Stopped at 5: the design written there is 5 iterations in.
    assert_eq!(summary(&a)["iterations_run_now"], 5, "{t}");
    let o = design(&["--iters", "12", "--out", &a_s, "--resume"]);
    assert!(o.status.success(), "resume failed: {}", text(&o));
    assert_eq!(summary(&a)["resumed_from_iteration"], 5);
    let o = design(&["--iters", "12", "--out", &b_s]);
    assert!(o.status.success(), "design failed: {}", text(&o));
    let (ca, cb) = (
        std::fs::read(a.join("scratches.csv")).unwrap(),
        std::fs::read(b.join("scratches.csv")).unwrap(),
    );
    assert!(ca == cb, "the continued live design differs from the uninterrupted one");
    assert_eq!(summary(&a)["loss_final"], summary(&b)["loss_final"]);
}

/// Steering by script (40 iterations; view v0's picture moved and scaled at iteration 3, v1's at 5, the Gram
/// term's weight changed at 6) is
/// recorded in summary.json, and `scratchart design --steer summary.json` replays it to the
/// same bits; the steering changed the design; steering that cannot apply is refused.
#[test]
fn a_steered_live_design_is_replayed_from_the_command_line() {
    let dir = tmp_dir("steer");
    let data = scratchart_tests::workspace_root().join("tests/data");
    let pics: Vec<String> = ["astronaut.png", "chelsea.png"]
        .iter()
        .map(|f| data.join(f).display().to_string())
        .collect();
    let (a, b, c) = (dir.join("live"), dir.join("replay"), dir.join("plain"));
    let (a_s, b_s, c_s) = (
        a.display().to_string(),
        b.display().to_string(),
        c.display().to_string(),
    );
    let base = |out: &str| -> Vec<String> {
        let mut v: Vec<String> = ["--targets", &pics[0], &pics[1], "--iters", "40", "--out", out]
            .iter()
            .map(|s| s.to_string())
            .collect();
        v.extend(FLAGS.iter().map(|s| s.to_string()));
        v
    };
    let mut args = base(&a_s);
    args.extend(
        [
            "--headless",
            "--script",
            "3:steer v0 3 -2 1.1;5:steer v1 -2 1 0.9;6:weight 1 0.04",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    let o = Command::new(viewer_bin()).arg("--design").args(&args).output().unwrap();
    assert!(o.status.success(), "steered live design failed: {}", text(&o));
    let steering = summary(&a)["steering"].clone();
    assert_eq!(steering.as_array().map(|a| a.len()), Some(3), "{steering}");
    assert_eq!(steering[0]["iteration"], 3);
    assert_eq!(steering[0]["view"], "v0");
    assert_eq!(steering[1]["iteration"], 5);
    assert_eq!(steering[2]["iteration"], 6);
    assert!(
        (steering[2]["lambda_g"].as_f64().unwrap() - 0.04).abs() < 1e-6,
        "{steering}"
    );
    let summary_a = a.join("summary.json").display().to_string();
    let mut args = vec!["design".to_string()];
    args.extend(base(&b_s));
    args.extend(["--steer".to_string(), summary_a.clone()]);
    let o = run_scratchart(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "replay failed: {}", text(&o));
    assert_eq!(summary(&b)["steering"], steering);
    let same = |x: &Path, y: &Path| {
        std::fs::read(x.join("scratches.csv")).unwrap() == std::fs::read(y.join("scratches.csv")).unwrap()
    };
    assert!(same(&a, &b), "the replayed design differs from the steered live one");
    assert!(
        std::fs::read(a.join("v0_target.png")).unwrap() == std::fs::read(b.join("v0_target.png")).unwrap(),
        "the steered targets differ"
    );
    let mut args = vec!["design".to_string()];
    args.extend(base(&c_s));
    let o = run_scratchart(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", text(&o));
    assert!(!same(&a, &c), "steering changed nothing");
    // A view that does not exist, and steering without pictures, are refused before any work.
    let bad = write_steer(
        &dir,
        r#"[{"iteration": 2, "view": "v7", "shift_px": [0, 0], "scale": 1}]"#,
    );
    let mut args = vec!["design".to_string()];
    args.extend(base(&c_s));
    args.extend(["--steer".to_string(), bad.clone()]);
    let o = run_scratchart(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("no view is named `v7`"), "{}", text(&o));
    // The built-in shapes are not pictures from files: they cannot be moved (the weights can).
    let shapes = write_steer(&dir, r#"[{"iteration": 1, "view": "v0", "shift_px": [1, 0]}]"#);
    let o = design(&["--iters", "2", "--out", &c_s, "--steer", &shapes]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("cannot be moved"), "{}", text(&o));
    let weights = write_steer(&dir, r#"[{"iteration": 1, "lambda_g": 0.1}]"#);
    let o = design(&["--iters", "2", "--out", &c_s, "--steer", &weights]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(summary(&c)["steering"][0]["lambda_g"], 0.1);
}

fn write_steer(dir: &Path, json: &str) -> String {
    let p = dir.join("steer.json");
    std::fs::write(&p, json).unwrap();
    p.display().to_string()
}

/// In a window: the plate is shown as it converges (frames report rising iterations) with the
/// design panel beside it (every view's render and target, the loss curve), the script pauses it (frames drawn while paused), moves the window's lamp, saves and resumes;
/// closing the window stops the optimization and the design is finished and written, and
/// `scratchart design --resume` takes it on.
#[test]
fn a_live_design_runs_in_the_window_and_obeys_pause_lamp_and_save() {
    let x = XServer::start();
    let dir = tmp_dir("window");
    let out = dir.join("live");
    let out_s = out.display().to_string();
    let o = live(
        Some(&x.display),
        &[
            "--iters",
            "100000",
            "--out",
            &out_s,
            "--validation",
            "--log-frames",
            "--panel",
            "--size",
            "320x240",
            "--exit-after",
            "6",
            "--script",
            "3:pause;3:lamp 40 70;3:save;3:steer v0 2 0 1;3:wait 1.5;3:resume",
        ],
    );
    let t = text(&o);
    assert!(o.status.success(), "live window failed: {t}");
    assert!(t.contains("validation messages: 0"), "{t}");
    assert!(t.contains("saved at iteration 3"), "{t}");
    // The built-in shapes are not pictures from files: steering them is refused, the run goes on.
    assert!(t.contains("cannot be moved"), "{t}");
    let frames: Vec<&str> = t.lines().filter(|l| l.starts_with("frame ")).collect();
    assert!(frames.len() >= 5, "{} frames: {t}", frames.len());
    let iter_of = |l: &str| -> u32 {
        l.split_whitespace()
            .find_map(|w| w.strip_prefix("live_iter="))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no live_iter in {l}"))
    };
    let last = iter_of(frames.last().unwrap());
    assert!(last > 3, "the window saw the design only up to iteration {last}");
    assert!(
        frames.iter().any(|l| l.contains("live_paused=true")),
        "no frame while paused"
    );
    assert!(
        frames.iter().any(|l| l.contains("light_az=40.00")),
        "the lamp did not move"
    );
    assert!(
        frames.iter().any(|l| l.contains("panel=true")),
        "the design panel was never shown"
    );
    // The window closed: the design was finished and written where it stood.
    let s = summary(&out);
    let run = s["iterations_run_now"].as_u64().unwrap() as u32;
    assert!(run >= last, "{run} iterations written, the window saw {last}");
    let resume_to = (run + 3).to_string();
    let o = design(&["--iters", &resume_to, "--out", &out_s, "--resume"]);
    assert!(o.status.success(), "resume failed: {}", text(&o));
    assert!(summary(&out)["resumed_from_iteration"].as_u64().is_some());
}

/// Bad live flags exit 2 with a message: a malformed script, a paused headless run, and no
/// display without --headless.
#[test]
fn live_flags_are_checked() {
    let dir = tmp_dir("flags");
    let out = dir.join("o").display().to_string();
    for (args, msg) in [
        (
            vec!["--headless", "--script", "5:jump", "--out", &out],
            "unknown command",
        ),
        (
            vec!["--headless", "--script", "9:pause;2:resume", "--out", &out],
            "in order",
        ),
        (
            vec!["--headless", "--paused", "--out", &out],
            "--paused needs the window",
        ),
        (
            vec!["--headless", "--script", "2:pause;3:resume", "--out", &out],
            "never resumed",
        ),
        (vec!["--iters", "2", "--out", &out], "add --headless"),
    ] {
        let o = live(None, &args);
        assert_ne!(o.status.code(), Some(0), "{args:?}: {}", text(&o));
        assert!(text(&o).contains(msg), "{args:?}: {}", text(&o));
    }
    let o = live(None, &["--headless", "--script", "x", "--out", &out]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

/// Scratches added and removed while the design runs (by script: 40 added at iteration 3, the
/// 60 that matter least removed at 5) are recorded in summary.json with the removed indices and
/// the added ones' random stream; `scratchart design --steer summary.json` replays them to the
/// same bits; a run saved after them is continued by `scratchart design --resume` with its
/// number of scratches (a warning says the record is not whole without --steer), and with
/// --steer across the resume, later changes included, to the same bits; changes that cannot
/// apply are refused.
#[test]
fn scratches_added_and_removed_live_are_replayed_and_resumed() {
    let dir = tmp_dir("resize");
    let p = |n: &str| dir.join(n);
    let s = |n: &str| dir.join(n).display().to_string();
    let o = live(
        None,
        &[
            "--iters",
            "12",
            "--out",
            &s("live"),
            "--headless",
            "--validation",
            "--script",
            "3:add 40;5:remove 60;6:add 5000000;9:add 7",
        ],
    );
    assert!(o.status.success(), "live design failed: {}", text(&o));
    let t = text(&o);
    assert!(t.contains("300 -> 340 scratches from iteration 3"), "{t}");
    assert!(t.contains("340 -> 280 scratches from iteration 5"), "{t}");
    // More than the device holds (lavapipe binds 128 MiB per buffer; a GPU may hold them, and
    // then they are added): refused with the limit named, not recorded, and the run goes on
    // with what it has.
    let huge_refused = t.contains("5000280 scratches do not fit this device");
    assert!(huge_refused || t.contains("280 -> 5000280"), "{t}");
    let last = if huge_refused { 2 } else { 3 };
    assert!(t.contains("validation messages: 0"), "{t}");
    let steering = summary(&p("live"))["steering"].clone();
    assert_eq!(steering[0]["add"], 40, "{steering}");
    assert!(steering[0]["seed"].is_u64(), "{steering}");
    assert_eq!(
        steering[1]["remove"].as_array().map(|r| r.len()),
        Some(60),
        "{steering}"
    );
    assert_eq!(steering[last]["add"], 7, "{steering}");
    assert_eq!(steering.as_array().map(|a| a.len()), Some(last + 1), "{steering}");
    let rows = |d: &str| {
        std::fs::read_to_string(p(d).join("scratches.csv"))
            .unwrap()
            .lines()
            .count()
            - 1
    };
    assert_eq!(rows("live"), if huge_refused { 287 } else { 5_000_287 });
    let same = |x: &str, y: &str| {
        std::fs::read(p(x).join("scratches.csv")).unwrap() == std::fs::read(p(y).join("scratches.csv")).unwrap()
    };
    // Replayed from the command line.
    let record = s("live/summary.json");
    let o = design(&["--iters", "12", "--out", &s("replay"), "--steer", &record]);
    assert!(o.status.success(), "replay failed: {}", text(&o));
    assert!(same("live", "replay"), "the replayed design differs from the live one");
    assert_eq!(summary(&p("replay"))["steering"], steering);
    // Saved at 7 (after two changes), continued with --steer: the first two are in the
    // checkpoint, the third is applied at 9.
    let o = live(
        None,
        &[
            "--iters",
            "12",
            "--out",
            &s("saved"),
            "--headless",
            "--script",
            "3:add 40;5:remove 60;7:save;7:stop",
        ],
    );
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(rows("saved"), 280);
    std::fs::copy(p("saved").join("checkpoint.bin"), dir.join("checkpoint_at_7.bin")).unwrap();
    let o = design(&["--iters", "12", "--out", &s("saved"), "--resume", "--steer", &record]);
    assert!(o.status.success(), "resume failed: {}", text(&o));
    assert_eq!(summary(&p("saved"))["resumed_from_iteration"], 7);
    assert!(same("live", "saved"), "the resumed design differs from the live one");
    assert_eq!(summary(&p("saved"))["steering"], steering);
    // Without --steer: the checkpoint's 280 scratches go on, and a warning says so.
    std::fs::copy(dir.join("checkpoint_at_7.bin"), p("saved").join("checkpoint.bin")).unwrap();
    let o = design(&["--iters", "12", "--out", &s("saved"), "--resume"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("added or removed scratches 2 time(s) (280 scratches now)"),
        "{}",
        text(&o)
    );
    assert_eq!(rows("saved"), 280);
    // Refused: a scratch that is not there, an addition without its stream.
    for (json, what) in [
        (r#"[{"iteration": 2, "remove": [5000]}]"#, "no scratch 5000"),
        (r#"[{"iteration": 2, "add": 5}]"#, "seed"),
    ] {
        let f = write_steer(&dir, json);
        let o = design(&["--iters", "4", "--out", &s("bad"), "--steer", &f]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(what), "{}", text(&o));
    }
}
