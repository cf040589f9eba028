//! The viewer's walk (`scratchart-view DESIGN --walk`): the camera along the design views in
//! order and back in the window, and `--walk --frames DIR`, the walk's frames written without a
//! window. The design is written here: three views 20 degrees apart on a horizontal arc (as
//! `scratchart design --walk` places them), one lamp, a few dozen scratches.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use scratchart_tests::{viewer_bin, XServer};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-walk-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A walk design with `n` views at azimuths -20, 0, 20, ... (elevation 35 degrees, 300 mm), 64x48
/// pixels each, sharing one lamp; scratches from a fixed pseudo-random sequence.
fn write_design(dir: &Path, n: usize) -> PathBuf {
    let views: Vec<String> = (0..n)
        .map(|k| {
            let (az, el, d) = ((-20.0 + 20.0 * k as f64).to_radians(), 35f64.to_radians(), 300.0);
            let eye = [d * el.cos() * az.cos(), d * el.cos() * az.sin(), d * el.sin()];
            format!(
                r#"{{ "name": "v{k}", "camera": {{ "eye": {eye:?}, "target": [0, 0, 0], "up": [0, 0, 1], "fov_y_deg": 24, "width": 64, "height": 48 }},
  "light": {{ "kind": "point", "position": [-150.0, 40.0, 260.0], "intensity": 90000 }} }}"#
            )
        })
        .collect();
    let mut seed = 12345u64;
    let mut rnd = |lo: f64, hi: f64| {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    let scratches: Vec<String> = (0..60)
        .map(|_| {
            let (x0, y0) = (rnd(-40.0, 40.0), rnd(-40.0, 40.0));
            let (t, l) = (rnd(0.0, std::f64::consts::PI), rnd(10.0, 30.0));
            let (x1, y1) = (
                (x0 + l * t.cos()).clamp(-45.0, 45.0),
                (y0 + l * t.sin()).clamp(-45.0, 45.0),
            );
            format!("[{x0:.3}, {y0:.3}, {x1:.3}, {y1:.3}, 0.05, 0.05, 0.05]")
        })
        .collect();
    let json = format!(
        r#"{{ "plate": {{ "size_mm": 100.0 }}, "views": [ {} ],
  "scratches": [ {} ] }}"#,
        views.join(",\n"),
        scratches.join(",\n")
    );
    let p = dir.join("design.json");
    std::fs::write(&p, json).unwrap();
    p
}

/// Runs the viewer headless (no display) with the embedded shaders and `args`.
fn view(args: &[&str]) -> Output {
    Command::new(viewer_bin())
        .arg("--embedded-shaders")
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Decoded pixels (and size) of a PNG.
fn pixels(path: &Path) -> (u32, u32, Vec<u8>) {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8();
    (img.width(), img.height(), img.into_raw())
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `--walk --frames DIR --walk-steps 2` on 3 views: frames at 0 and 1/2 of each gap, then the
/// last view: 5 frames. Frame 0, 2 and 4 are views v0, v1 and v2 exactly as `--screenshot
/// --view` renders them; frame 1 (halfway from v0 to v1) is neither.
#[test]
fn walk_frames_are_the_views_and_in_between() {
    let tmp = tmp_dir("frames");
    let design = write_design(&tmp, 3);
    let frames = tmp.join("frames"); // created by the viewer
    let out = view(&[
        s(&design),
        "--validation",
        "--walk",
        "--frames",
        s(&frames),
        "--walk-steps",
        "2",
    ]);
    let (so, se) = (text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "--walk --frames failed:\n{se}");
    assert!(se.contains("validation messages: 0"), "{se}");
    assert!(so.contains(&format!("wrote 5 frames to {}", frames.display())), "{so}");
    assert!(
        so.contains("frame_%04d.png") && so.contains("walk.gif"),
        "no GIF hint:\n{so}"
    );
    let mut names: Vec<String> = std::fs::read_dir(&frames)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let want: Vec<String> = (0..5).map(|j| format!("frame_{j:04}.png")).collect();
    assert_eq!(names, want, "the frame files");

    let frame = |j: usize| pixels(&frames.join(format!("frame_{j:04}.png")));
    for (k, j) in [(0, 0), (1, 2), (2, 4)] {
        let png = tmp.join(format!("v{k}.png"));
        let out = view(&[s(&design), "--view", &format!("v{k}"), "--screenshot", s(&png)]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let shot = pixels(&png);
        assert_eq!((shot.0, shot.1), (64, 48), "the view's own resolution");
        assert!(
            shot.2.iter().any(|&p| p > 20),
            "view v{k} renders black: a bad test design"
        );
        assert!(
            frame(j) == shot,
            "frame {j} is not --screenshot --view v{k} pixel for pixel"
        );
    }
    let between = frame(1);
    assert_eq!((between.0, between.1), (64, 48));
    for j in [0, 2] {
        let other = frame(j);
        let changed = between.2.iter().zip(&other.2).filter(|(a, b)| a != b).count();
        assert!(changed > 20, "frame 1 differs from frame {j} in only {changed} pixels");
    }
    // The frame lines name the gap and the fraction.
    assert!(
        so.lines()
            .any(|l| l.starts_with("frame 0001/0004") && l.contains("v0 -> v1 50%")),
        "{so}"
    );
    let _ = std::fs::remove_dir_all(&tmp);
}

/// `--frames DIR` belongs to --walk; a one-view design has no walk; a directory named only with
/// digits is given as ./123 (plain digits stay the window's frame count).
#[test]
fn walk_refusals_and_digit_directories() {
    let tmp = tmp_dir("refusals");
    let design = write_design(&tmp, 3);
    let dir = tmp.join("frames");
    let out = view(&[s(&design), "--frames", s(&dir)]);
    let se = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "--frames DIR without --walk:\n{se}");
    assert!(se.contains("--walk"), "the refusal does not name --walk:\n{se}");
    assert!(!dir.exists(), "the refused run created {}", dir.display());

    let one = tmp.join("one");
    std::fs::create_dir_all(&one).unwrap();
    let one_design = write_design(&one, 1);
    for args in [vec!["--walk"], vec!["--walk", "--frames", s(&dir)]] {
        let mut a = vec![s(&one_design)];
        a.extend(&args);
        let out = view(&a);
        let se = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?} on one view:\n{se}");
        assert!(se.contains("at least 2 views"), "{se}");
    }
    assert!(!dir.exists());

    // "./12": a directory, not a count.
    let out = Command::new(viewer_bin())
        .current_dir(&tmp)
        .args([
            "--embedded-shaders",
            "design.json",
            "--walk",
            "--walk-steps",
            "1",
            "--frames",
            "./12",
        ])
        .env_remove("DISPLAY")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    let n = std::fs::read_dir(tmp.join("12")).unwrap().count();
    assert_eq!(n, 3, "--walk-steps 1 on 3 views: 3 frames");
    let _ = std::fs::remove_dir_all(&tmp);
}

/// `--walk` in a window: frames keep coming while nothing but the walk moves, the camera's
/// azimuth rises from v0's at 10 degrees per second, and the position is logged.
#[test]
fn walk_plays_in_the_window() {
    let x = XServer::start();
    let tmp = tmp_dir("window");
    let design = write_design(&tmp, 3);
    let out = Command::new(viewer_bin())
        .args(["--embedded-shaders", "--validation", "--size", "320x240"])
        .args(["--walk", "--exit-after", "2", "--log-frames"])
        .arg(&design)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let (so, se) = (text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{se}");
    assert!(se.contains("validation messages: 0"), "{se}");
    let field = |l: &str, key: &str| -> f64 {
        l.split_whitespace()
            .find_map(|t| t.strip_prefix(key))
            .unwrap_or_else(|| panic!("no {key} in '{l}'"))
            .parse()
            .unwrap()
    };
    let frames: Vec<(f64, f64)> = so
        .lines()
        .filter(|l| l.starts_with("frame "))
        .map(|l| (field(l, "walk="), field(l, "cam_az=")))
        .collect();
    assert!(frames.len() >= 5, "{} frames presented in 2 s:\n{so}", frames.len());
    assert!(
        frames[0].0 < 0.2 && (frames[0].1 + 20.0).abs() < 3.0,
        "starts at v0: {:?}",
        frames[0]
    );
    assert!(
        frames.windows(2).all(|p| p[1].0 >= p[0].0),
        "the walk goes back within 2 s:\n{so}"
    );
    let last = frames.last().unwrap();
    // 2 s at 10 degrees per second: 20 degrees, view v1 (less what the start-up took).
    assert!(last.0 > 0.3 && last.0 <= 1.05, "walk position after 2 s: {}", last.0);
    assert!(
        (last.1 - (-20.0 + 20.0 * last.0)).abs() < 0.1,
        "azimuth {} at walk position {}",
        last.1,
        last.0
    );
    let _ = std::fs::remove_dir_all(&tmp);
}

#[test]
fn help_mentions_the_walk() {
    let out = Command::new(viewer_bin()).arg("--help").output().unwrap();
    assert!(out.status.success());
    let help = text(&out.stdout);
    for s in [
        "  W  ",
        "--walk ",
        "--walk-speed",
        "--walk-steps",
        "--frames <N|DIR>",
        "./123",
        "walk.gif",
    ] {
        assert!(help.contains(s), "--help does not mention '{s}':\n{help}");
    }
}
