//! The real-time viewer (`scratchart-view`) end to end, on the real device (lavapipe here) and a
//! real X server: the tests start their own Xvfb when DISPLAY is unset, drive the window with
//! xdotool and grab it with ImageMagick's `import`.
//!
//! The viewer binary is built (`cargo build -p scratchart-view`, same profile as this test) from
//! the test itself, because cargo only builds a package's own binaries for its tests.
//! The viewer runs use `--embedded-shaders` (the shaders built into the binary), except the
//! hot-reload test (which edits a private copy), so a shader being edited in the source tree
//! cannot make the binary and the library disagree.
//!
//! Tolerances: the viewer maps L to display bytes in float32 GLSL, the engine in float64 Rust; a
//! value within ~1e-6 of a rounding boundary may land one level away. So images must agree to
//! within 1 level of 255 everywhere and exactly on at least 99.9% of pixels.
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use scratchart_render::Renderer;
use scratchart_tests::{viewer_bin, workspace_root, XServer};
use scratchart_vulkan::{Context, ContextDesc};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-view-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Gray bytes of a PNG (any PNG the `image` crate reads; RGB is converted to luma, which for the
/// viewer's gray output gives back the gray value).
fn read_gray(path: &Path) -> (u32, u32, Vec<u8>) {
    let (w, h, d) = scratchart_render::io::read_image_gray(path).unwrap_or_else(|e| panic!("{e}"));
    (w, h, d.iter().map(|v| (v * 255.0).round() as u8).collect())
}

/// Panics unless `a` and `b` agree within 1 level everywhere and exactly on >= 99.9% of pixels;
/// names the first pixel that differs by more.
fn assert_images_match(what: &str, a: &[u8], b: &[u8], width: u32) {
    assert_eq!(a.len(), b.len(), "{what}: sizes differ");
    let mut exact = 0usize;
    for (i, (&x, &y)) in a.iter().zip(b).enumerate() {
        let d = (x as i32 - y as i32).abs();
        assert!(
            d <= 1,
            "{what}: pixel ({}, {}) differs by {d} levels: {x} vs {y}",
            i as u32 % width,
            i as u32 / width
        );
        exact += (d == 0) as usize;
    }
    let frac = exact as f64 / a.len() as f64;
    assert!(
        frac >= 0.999,
        "{what}: only {:.4}% of pixels agree exactly",
        100.0 * frac
    );
}

fn fraction_changed(a: &[u8], b: &[u8]) -> f64 {
    a.iter()
        .zip(b)
        .filter(|(x, y)| (**x as i32 - **y as i32).abs() > 2)
        .count() as f64
        / a.len() as f64
}

/// (a) `--screenshot --view 0` equals the engine's own render of the demo plate's view 0 (the
/// scene `scratchart render` renders without arguments), mapped with `io::display_byte`.
#[test]
fn headless_screenshot_matches_engine_render() {
    let dir = tmp_dir("headless");
    let png = dir.join("v0.png");
    let out = Command::new(viewer_bin())
        .args(["--embedded-shaders", "--validation", "--view", "0", "--screenshot"])
        .arg(&png)
        .env_remove("DISPLAY")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "viewer failed: {stderr}");
    assert!(stderr.contains("validation messages: 0"), "{stderr}");

    let ctx = Context::new(ContextDesc {
        quiet: true,
        ..Default::default()
    })
    .unwrap();
    let scene = scratchart_design::scenes::demo_scene(256);
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let frame = r.render(&mut gs).unwrap();
    let reference: Vec<u8> = frame.images[0]
        .iter()
        .map(|&l| scratchart_render::io::display_byte(l))
        .collect();

    let (w, h, got) = read_gray(&png);
    assert_eq!((w, h), (256, 256));
    assert_images_match("--screenshot --view 0 vs engine render", &got, &reference, w);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn help_explains_keys_and_flags() {
    let out = Command::new(viewer_bin()).arg("--help").output().unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for s in [
        "left drag",
        "shift + left drag",
        "wheel",
        "1 .. 9",
        "E / shift+E",
        " T ",
        " L ",
        " R ",
        " H ",
        "--screenshot",
        "--view",
        "--benchmark",
        "--size",
        "--exposure",
        "--light-azimuth",
        "--frames",
        "--exit-after",
        "--log-frames",
        "--shader-dir",
        "--validation",
    ] {
        assert!(help.contains(s), "--help does not mention '{s}':\n{help}");
    }
}

/// `--frames N` exits after N frames even when nothing moves (a still scene presents once and
/// then waits, so counting only changed frames never ended).
#[test]
fn frames_flag_exits_on_a_still_scene() {
    let x = XServer::start();
    let t0 = Instant::now();
    let out = Command::new(viewer_bin())
        .args(["--frames", "6", "--exit-after", "120", "--log-frames"])
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let took = t0.elapsed();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let frames = stdout.lines().filter(|l| l.starts_with("frame")).count();
    assert!(frames >= 6, "{frames} frames logged:\n{stdout}");
    assert!(
        took < Duration::from_secs(100),
        "--frames 6 took {took:?}: it waited for --exit-after"
    );
}

/// A running viewer window whose stdout lines (`--log-frames`) and stderr lines arrive on channels.
struct Viewer {
    child: Child,
    out: Receiver<String>,
    err: Receiver<String>,
    err_log: Vec<String>,
    display: String,
}

impl Viewer {
    fn spawn(display: &str, args: &[&str]) -> Viewer {
        let mut child = Command::new(viewer_bin())
            .args(["--log-frames", "--exit-after", "90"])
            .args(args)
            .env("DISPLAY", display)
            .env_remove("WAYLAND_DISPLAY")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let pipe = |r: Box<dyn std::io::Read + Send>| {
            let (tx, rx) = channel();
            std::thread::spawn(move || {
                for line in BufReader::new(r).lines().map_while(Result::ok) {
                    if tx.send(line).is_err() {
                        break;
                    }
                }
            });
            rx
        };
        let out = pipe(Box::new(child.stdout.take().unwrap()));
        let err = pipe(Box::new(child.stderr.take().unwrap()));
        Viewer {
            child,
            out,
            err,
            err_log: Vec::new(),
            display: display.into(),
        }
    }

    /// Next stdout line satisfying `pred`, within `secs`.
    fn wait_line(&mut self, what: &str, secs: u64, pred: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + Duration::from_secs(secs);
        loop {
            while let Ok(l) = self.err.try_recv() {
                self.err_log.push(l);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            match self.out.recv_timeout(left.min(Duration::from_millis(200))) {
                Ok(l) if pred(&l) => return l,
                Ok(_) => {}
                Err(_) if Instant::now() >= deadline => {
                    panic!(
                        "no '{what}' within {secs} s; viewer stderr:\n{}",
                        self.err_log.join("\n")
                    )
                }
                Err(_) => {}
            }
        }
    }

    /// Next stderr line containing `s`, within `secs`.
    fn wait_err(&mut self, s: &str, secs: u64) -> String {
        let deadline = Instant::now() + Duration::from_secs(secs);
        while Instant::now() < deadline {
            if let Ok(l) = self.err.recv_timeout(Duration::from_millis(200)) {
                self.err_log.push(l.clone());
                if l.contains(s) {
                    return l;
                }
            }
            while self.out.try_recv().is_ok() {}
        }
        panic!(
            "no stderr line with '{s}' within {secs} s; stderr:\n{}",
            self.err_log.join("\n")
        )
    }

    fn xdotool(&self, args: &[&str]) {
        let st = Command::new("xdotool")
            .args(args)
            .env("DISPLAY", &self.display)
            .status()
            .unwrap();
        assert!(st.success(), "xdotool {args:?} failed");
    }

    fn grab(&self, id: &str, path: &Path) -> (u32, u32, Vec<u8>) {
        let st = Command::new("/usr/bin/import")
            .args(["-window", id])
            .arg(path)
            .env("DISPLAY", &self.display)
            .status()
            .expect("ImageMagick's import (apt install imagemagick)");
        assert!(st.success(), "import -window {id} failed");
        read_gray(path)
    }

    /// Waits for the exit; returns (success, all stderr).
    fn finish(mut self, secs: u64) -> (bool, String) {
        let deadline = Instant::now() + Duration::from_secs(secs);
        let status = loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                break s;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!("viewer did not exit within {secs} s");
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        std::thread::sleep(Duration::from_millis(100));
        while let Ok(l) = self.err.try_recv() {
            self.err_log.push(l);
        }
        (status.success(), self.err_log.join("\n"))
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn field<'a>(line: &'a str, key: &str) -> &'a str {
    line.split_whitespace()
        .find_map(|t| t.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
        .unwrap_or_else(|| panic!("no {key}= in '{line}'"))
}

/// (b) the window shows what the headless path renders for the same camera; (c) a mouse drag
/// moves the camera and the picture changes; a key starts the light; (d) resizing keeps frames
/// coming at the new size; (e) the whole session, with the validation layer on, reports zero
/// validation messages and exits cleanly on Q.
#[test]
fn window_session() {
    let x = XServer::start();
    let dir = tmp_dir("window");
    let (w, h) = (320u32, 240u32);
    let size = format!("{w}x{h}");

    // Headless reference of the window's starting camera.
    let reference = dir.join("headless.png");
    let out = Command::new(viewer_bin())
        .args(["--embedded-shaders", "--size", &size, "--screenshot"])
        .arg(&reference)
        .env_remove("DISPLAY")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (_, _, reference) = read_gray(&reference);

    let mut v = Viewer::spawn(&x.display, &["--embedded-shaders", "--validation", "--size", &size]);
    let id = v.wait_line("window-id", 60, |l| l.starts_with("window-id"));
    let id = id.split_whitespace().nth(1).unwrap().to_string();
    v.wait_line("a full-resolution frame", 60, |l| l.contains(" full internal="));
    std::thread::sleep(Duration::from_millis(300));

    // (b)
    let (gw, gh, before) = v.grab(&id, &dir.join("window0.png"));
    assert_eq!((gw, gh), (w, h), "window size");
    assert_images_match("window vs headless render of the same camera", &before, &reference, w);

    // (c) drag: orbit the camera.
    v.xdotool(&["mousemove", "--window", &id, "100", "100", "mousedown", "1"]);
    for i in 1..=8 {
        v.xdotool(&[
            "mousemove",
            "--window",
            &id,
            &(100 + 10 * i).to_string(),
            &(100 + 2 * i).to_string(),
        ]);
    }
    v.xdotool(&["mouseup", "1"]);
    let moved = v.wait_line("a frame after the drag", 60, |l| {
        l.starts_with("frame") && field(l, "cam_az").parse::<f64>().unwrap().abs() > 1.0
    });
    assert!(
        field(&moved, "cam_az").parse::<f64>().unwrap() < 0.0,
        "drag right turns the scene right: {moved}"
    );
    v.wait_line("a full frame after the drag", 60, |l| l.contains(" full internal="));
    std::thread::sleep(Duration::from_millis(300));
    let (_, _, after) = v.grab(&id, &dir.join("window1.png"));
    let changed = fraction_changed(&before, &after);
    assert!(
        changed > 0.01,
        "only {:.3}% of pixels changed after the drag",
        100.0 * changed
    );

    // Key L: the light starts orbiting on its own, frames keep coming at a reduced resolution.
    v.xdotool(&["windowfocus", "--sync", &id]);
    v.xdotool(&["key", "l"]);
    v.wait_err("light orbit on", 30);
    let first = v.wait_line("a light-orbit frame", 30, |l| l.starts_with("frame"));
    let later = v.wait_line("a later light-orbit frame", 30, |l| {
        l.starts_with("frame") && field(l, "light_az") != field(&first, "light_az")
    });
    assert_ne!(field(&first, "light_az"), field(&later, "light_az"));
    // The camera is still: frames of the moving lamp keep their tile lists (shading only).
    v.wait_line("a light-orbit frame that kept its tile lists", 30, |l| {
        l.starts_with("frame") && field(l, "binned") == "false"
    });
    v.xdotool(&["key", "l"]);
    v.wait_err("light orbit off", 30);

    // (d) resize.
    v.xdotool(&["windowsize", &id, "400", "300"]);
    v.wait_line("a full frame at the new size", 60, |l| {
        l.contains(" full internal=400x300")
    });
    let (gw, gh, _) = v.grab(&id, &dir.join("window2.png"));
    assert_eq!((gw, gh), (400, 300));

    // (e) quit and count validation messages.
    v.xdotool(&["key", "q"]);
    let (ok, stderr) = v.finish(60);
    assert!(ok, "viewer exited with an error:\n{stderr}");
    assert!(
        stderr.contains("validation messages: 0"),
        "expected zero validation messages:\n{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The design file and the shaders are reloaded when they change on disk; a broken design or
/// shader keeps the last good one and the viewer keeps running.
#[test]
fn hot_reload_of_design_and_shaders() {
    let x = XServer::start();
    let dir = tmp_dir("reload");
    let design = dir.join("design.json");
    let write_design = |intensity: f64| {
        let json = format!(
            r#"{{ "plate": {{ "size_mm": 100.0 }},
  "views": [ {{ "name": "v0",
    "camera": {{ "eye": [0, -250, 250], "target": [0, 0, 0], "up": [0, 0, 1], "fov_y_deg": 30.0, "width": 64, "height": 64 }},
    "light": {{ "kind": "point", "position": [0, 250, 250], "intensity": {intensity} }} }} ],
  "scratches": [ [-20, 0, 20, 0, 0.05, 0.05, 0.05], [0, -20, 0, 20, 0.05, 0.05, 0.05] ] }}"#
        );
        std::fs::write(&design, json).unwrap();
    };
    write_design(60000.0);
    // A private copy of the shaders to edit.
    let shaders = dir.join("shaders");
    copy_dir(&workspace_root().join("shaders"), &shaders);

    let mut v = Viewer::spawn(
        &x.display,
        &[
            design.to_str().unwrap(),
            "--size",
            "160x120",
            "--shader-dir",
            shaders.to_str().unwrap(),
        ],
    );
    v.wait_line("a full frame", 60, |l| l.contains(" full internal="));

    // Mtimes have a coarse granularity on some file systems: step past it.
    std::thread::sleep(Duration::from_millis(1100));
    std::fs::write(&design, "{ not json").unwrap();
    v.wait_err("reload failed", 30);
    std::thread::sleep(Duration::from_millis(1100));
    write_design(90000.0);
    v.wait_err("reloaded", 30);

    std::thread::sleep(Duration::from_millis(1100));
    let present = shaders.join("view_present.comp");
    let good = std::fs::read_to_string(&present).unwrap();
    std::fs::write(
        &present,
        good.replace("void main() {", "void main() { syntax error here;"),
    )
    .unwrap();
    v.wait_err("shader reload failed", 60);
    std::thread::sleep(Duration::from_millis(1100));
    std::fs::write(&present, &good).unwrap();
    v.wait_err("shaders recompiled", 60);
    v.wait_line("a frame after the shader reload", 60, |l| l.starts_with("frame"));
    let _ = std::fs::remove_dir_all(&dir);
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}
