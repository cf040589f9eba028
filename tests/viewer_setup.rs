//! The viewer's set-up overlay (key S, `--setup`): the lamp and every designed eye drawn where
//! they project in the viewer's camera, an arrow at the frame's edge for a point behind the
//! camera or off-screen, the plate's +x edge, and the numbers, which must equal the set-up
//! sheet's (`scratchart setup`). Positions are checked against a pinhole projection written here
//! from engine/docs/model.md section 4 (not the viewer's code); colours are the overlay's documented ones.
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use scratchart_model::scene::{Camera, LightKind, Scene};
use scratchart_render::Renderer;
use scratchart_tests::{assert_no_validation, gpu, viewer_bin, workspace_bin, XServer};

const LAMP: [u8; 3] = [255, 170, 0];
const EYE: [u8; 3] = [60, 190, 255];
const MARK: [u8; 3] = [255, 40, 40];
const SIZE: (u32, u32) = (320, 240);

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-setup-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A design whose view "top" looks down on the plate from 900 mm: the lamp and the eyes of v1
/// and v2 project inside its frame, the eye of "far" outside it (and behind v1's camera).
fn write_design(dir: &Path) -> PathBuf {
    let view = |name: &str, eye: [f64; 3], up: [f64; 3], fov: f64| {
        format!(
            r#"{{ "name": "{name}", "camera": {{ "eye": {eye:?}, "target": [0, 0, 0], "up": {up:?}, "fov_y_deg": {fov}, "width": 48, "height": 48 }},
  "light": {{ "kind": "point", "position": [-120.25, 180.125, 260.0625], "intensity": 90000 }} }}"#
        )
    };
    let views = [
        view("top", [0.0, 0.0, 900.0], [0.0, 1.0, 0.0], 60.0),
        view("v1", [250.5, -150.25, 200.75], [0.0, 0.0, 1.0], 30.0),
        view("v2", [-200.0, -220.0, 240.0], [0.0, 0.0, 1.0], 30.0),
        view("far", [2500.0, 300.0, 400.0], [0.0, 0.0, 1.0], 5.0),
    ];
    let json = format!(
        r#"{{ "plate": {{ "size_mm": 100.0 }}, "views": [ {} ],
  "scratches": [ [-20, 0, 20, 0, 0.05, 0.05, 0.05], [0, -20, 0, 20, 0.05, 0.05, 0.05], [-30, -30, 30, 30, 0.05, 0.05, 0.05] ] }}"#,
        views.join(",\n")
    );
    let p = dir.join("design.json");
    std::fs::write(&p, json).unwrap();
    p
}

/// (right, up, forward) components of p - eye in the camera frame of engine/docs/model.md section 4.
fn local(c: &Camera, p: [f64; 3]) -> [f64; 3] {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let unit = |a: [f64; 3]| {
        let n = dot(a, a).sqrt();
        [a[0] / n, a[1] / n, a[2] / n]
    };
    let f = unit(sub(c.target, c.eye));
    let r = unit(cross(f, c.up));
    let u = cross(r, f);
    let d = sub(p, c.eye);
    [dot(d, r), dot(d, u), dot(d, f)]
}

/// Pinhole projection to pixel coordinates (x right, y down, pixel (i, j) = [i, i+1] x [j, j+1]).
fn project(c: &Camera, p: [f64; 3]) -> (f64, f64) {
    let l = local(c, p);
    let t = (0.5 * c.fov_y_deg.to_radians()).tan();
    let (w, h) = (c.width as f64, c.height as f64);
    (
        (l[0] / l[2] / (t * w / h) + 1.0) * 0.5 * w,
        (1.0 - l[1] / l[2] / t) * 0.5 * h,
    )
}

fn rgb(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

fn px(img: &image::RgbImage, x: f64, y: f64) -> [u8; 3] {
    img.get_pixel(x.floor() as u32, y.floor() as u32).0
}

/// The numbers after `key` in `line` (e.g. "x" -> the value after " x ").
fn num_after(line: &str, key: &str) -> f64 {
    let toks: Vec<&str> = line.split([' ', ',']).filter(|t| !t.is_empty()).collect();
    let i = toks
        .iter()
        .position(|t| *t == key)
        .unwrap_or_else(|| panic!("no '{key}' in '{line}'"));
    toks[i + 1]
        .parse()
        .unwrap_or_else(|e| panic!("'{}' in '{line}': {e}", toks[i + 1]))
}

fn line_with<'a>(out: &'a str, prefix: &str) -> &'a str {
    out.lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line '{prefix}...' in:\n{out}"))
}

/// Runs the viewer headless on view `view` at SIZE; returns (stdout, stderr).
fn screenshot(design: &Path, view: &str, png: &Path, setup: bool) -> (String, String) {
    let size = format!("{}x{}", SIZE.0, SIZE.1);
    let mut cmd = Command::new(viewer_bin());
    cmd.args([
        "--embedded-shaders",
        "--validation",
        "--view",
        view,
        "--size",
        &size,
        "--screenshot",
    ])
    .arg(png)
    .arg(design)
    .env_remove("DISPLAY");
    if setup {
        cmd.arg("--setup");
    }
    let out = cmd.output().unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert!(out.status.success(), "viewer failed:\n{se}");
    assert!(se.contains("validation messages: 0"), "{se}");
    (so, se)
}

fn camera_of(scene: &Scene, name: &str) -> Camera {
    let mut c = scene.views.iter().find(|v| v.name == name).unwrap().camera.clone();
    (c.width, c.height) = SIZE;
    c
}

/// Every pixel whose centre is within 4 px of (x, y) has colour `c` (the disc has radius 5).
fn assert_disc(img: &image::RgbImage, what: &str, (x, y): (f64, f64), c: [u8; 3]) {
    let mut n = 0;
    for j in (y - 5.0) as i64..=(y + 5.0) as i64 {
        for i in (x - 5.0) as i64..=(x + 5.0) as i64 {
            let (dx, dy) = (i as f64 + 0.5 - x, j as f64 + 0.5 - y);
            if dx * dx + dy * dy <= 16.0 {
                let got = img.get_pixel(i as u32, j as u32).0;
                assert_eq!(got, c, "{what}: pixel ({i}, {j}) near ({x:.2}, {y:.2})");
                n += 1;
            }
        }
    }
    assert!(n >= 45, "{what}: only {n} pixels checked");
}

/// Pixels of colour `c` within `r` px of (x, y).
fn count_near(img: &image::RgbImage, (x, y): (f64, f64), r: f64, c: [u8; 3]) -> usize {
    let mut n = 0;
    for j in 0..img.height() {
        for i in 0..img.width() {
            if (i as f64 + 0.5 - x).hypot(j as f64 + 0.5 - y) <= r && img.get_pixel(i, j).0 == c {
                n += 1;
            }
        }
    }
    n
}

fn grey(p: [u8; 3]) -> bool {
    p[0] == p[1] && p[1] == p[2]
}

/// The edge arrow expected for a point seen in direction (dx, dy) from the frame's centre.
fn edge_tip(dx: f64, dy: f64) -> ((f64, f64), (f64, f64)) {
    let n = dx.hypot(dy);
    let (ux, uy) = (dx / n, dy / n);
    let (cx, cy) = (0.5 * SIZE.0 as f64, 0.5 * SIZE.1 as f64);
    let s = ((cx - 3.0) / ux.abs()).min((cy - 3.0) / uy.abs());
    ((cx + s * ux, cy + s * uy), (ux, uy))
}

/// Tip position and direction printed by the viewer for `label`.
fn printed_arrow(out: &str, label: &str) -> ((f64, f64), (f64, f64)) {
    let l = line_with(out, &format!("set-up overlay {label}: arrow"));
    let v: Vec<f64> = l
        .split_whitespace()
        .filter_map(|t| t.trim_end_matches(',').parse::<f64>().ok())
        .collect();
    assert_eq!(v.len(), 4, "{l}");
    ((v[0], v[1]), (v[2], v[3]))
}

/// The viewer's set-up lines against the sheet (`summary`): x, y, z to the micrometre;
/// azimuth, elevation and distance from those coordinates; the same JSON.
fn set_up_numbers_match(out: &str, summary: &serde_json::Value) {
    let check = |label: &str, want: &[serde_json::Value]| {
        let l = line_with(out, &format!("set-up {label}: "));
        let p: Vec<f64> = want.iter().map(|v| v.as_f64().unwrap()).collect();
        for (k, key) in ["x", "y", "z"].iter().enumerate() {
            let got = num_after(l, key);
            assert!(
                (got - p[k]).abs() <= 1e-3,
                "{label} {key}: {got} vs the sheet's {}",
                p[k]
            );
        }
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        let az = p[1].atan2(p[0]).to_degrees();
        let el = (p[2] / r).asin().to_degrees();
        assert!((num_after(l, "distance") - r).abs() <= 1e-3, "{l}");
        assert!((num_after(l, "azimuth") - az).abs() <= 1e-4, "{l}: azimuth {az}");
        assert!((num_after(l, "elevation") - el).abs() <= 1e-4, "{l}: elevation {el}");
    };
    check("lamp", summary["light"]["position_mm"].as_array().unwrap());
    for v in summary["views"].as_array().unwrap() {
        check(
            &format!("eye {}", v["name"].as_str().unwrap()),
            v["eye_mm"].as_array().unwrap(),
        );
    }
    let printed: serde_json::Value =
        serde_json::from_str(line_with(out, "set-up json: ").trim_start_matches("set-up json: ")).unwrap();
    assert_eq!(&printed, summary, "the viewer's set-up JSON is the sheet's");
}

#[test]
fn overlay_marks_setup_points_and_numbers_match_the_sheet() {
    let tmp = tmp_dir("headless");
    let design = write_design(&tmp);
    let scene = Scene::load(&design).unwrap();

    // The set-up sheet's numbers.
    let sheet = Command::new(workspace_bin("scratchart", "scratchart"))
        .args(["setup"])
        .arg(&design)
        .arg("--out")
        .arg(tmp.join("sheet"))
        .output()
        .unwrap();
    let sheet_out = String::from_utf8_lossy(&sheet.stdout);
    assert!(sheet.status.success(), "{}", String::from_utf8_lossy(&sheet.stderr));
    let summary: serde_json::Value = serde_json::from_str(sheet_out.lines().last().unwrap()).unwrap();

    let (on_png, off_png) = (tmp.join("on.png"), tmp.join("off.png"));
    let (out, _) = screenshot(&design, "top", &on_png, true);
    screenshot(&design, "top", &off_png, false);
    let (on, off) = (rgb(&on_png), rgb(&off_png));
    assert_eq!(on.dimensions(), SIZE);

    set_up_numbers_match(&out, &summary);

    // Markers where the lamp and the eyes project; "top" is the camera itself.
    let cam = camera_of(&scene, "top");
    let LightKind::Point { position } = scene.views[0].light.kind else {
        panic!()
    };
    let mut expect = vec![("lamp".to_string(), position, LAMP)];
    for name in ["v1", "v2"] {
        expect.push((format!("eye {name}"), camera_of(&scene, name).eye, EYE));
    }
    for (label, p, colour) in &expect {
        let (x, y) = project(&cam, *p);
        assert!(
            x > 8.0 && x < SIZE.0 as f64 - 8.0 && y > 8.0 && y < SIZE.1 as f64 - 8.0,
            "{label} ({x}, {y})"
        );
        let l = line_with(&out, &format!("set-up overlay {label}: marker at pixel "));
        let (gx, gy) = (
            num_after(l, "pixel"),
            l.split_whitespace().last().unwrap().parse::<f64>().unwrap(),
        );
        assert!((gx - x).abs() < 1e-3 && (gy - y).abs() < 1e-3, "{l} vs ({x}, {y})");
        assert_disc(&on, label, (x, y), *colour);
        assert!(
            grey(px(&off, x, y)),
            "{label}: the frame without the overlay shows a marker"
        );
    }
    line_with(&out, "set-up overlay eye top: at this camera");
    // The far eye is off-screen to the right: an arrow at the frame's edge, pointing to it.
    let (fx, fy) = project(&cam, camera_of(&scene, "far").eye);
    assert!(fx > SIZE.0 as f64, "{fx}");
    let (tip, dir) = edge_tip(fx - 0.5 * SIZE.0 as f64, fy - 0.5 * SIZE.1 as f64);
    let (ptip, pdir) = printed_arrow(&out, "eye far");
    assert!(
        (ptip.0 - tip.0).abs() < 1e-3 && (ptip.1 - tip.1).abs() < 1e-3,
        "{ptip:?} vs {tip:?}"
    );
    assert!(
        (pdir.0 - dir.0).abs() < 1e-3 && (pdir.1 - dir.1).abs() < 1e-3,
        "{pdir:?} vs {dir:?}"
    );
    assert_eq!(
        px(&on, tip.0 - 4.0 * dir.0, tip.1 - 4.0 * dir.1),
        EYE,
        "arrow near {tip:?}"
    );
    assert!(count_near(&on, tip, 14.0, EYE) >= 40, "arrow near {tip:?}");
    // The plate's +x edge.
    for k in 1..10 {
        let t = k as f64 / 10.0;
        let (x, y) = project(&cam, [50.0, -50.0 + 100.0 * t, 0.0]);
        assert_eq!(px(&on, x, y), MARK, "+x edge at ({x:.1}, {y:.1})");
    }

    // The frame is the render wherever the overlay draws nothing (every overlay colour is
    // non-grey), and the render is what the engine computes for that camera.
    let mut overlay_px = 0;
    for (a, b) in on.pixels().zip(off.pixels()) {
        if grey(a.0) {
            assert_eq!(a.0, b.0, "a grey pixel changed under the overlay");
        } else {
            overlay_px += 1;
        }
        assert!(grey(b.0), "the frame without the overlay has a coloured pixel");
    }
    let frac = overlay_px as f64 / (SIZE.0 * SIZE.1) as f64;
    assert!(
        frac > 0.005 && frac < 0.25,
        "overlay covers {:.1}% of the frame",
        100.0 * frac
    );
    let ctx = gpu();
    let mut s = scene.clone();
    s.views = vec![s.views[0].clone()];
    s.views[0].camera = cam.clone();
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&s).unwrap();
    let reference: Vec<u8> = r.render(&mut gs).unwrap().images[0]
        .iter()
        .map(|&l| scratchart_render::io::display_byte(l))
        .collect();
    let diff = off
        .pixels()
        .zip(&reference)
        .map(|(a, &b)| (a.0[0] as i32 - b as i32).abs())
        .collect::<Vec<_>>();
    assert!(
        diff.iter().all(|&d| d <= 1),
        "the frame without the overlay differs from the engine's render"
    );
    assert!(diff.iter().filter(|&&d| d == 0).count() as f64 >= 0.999 * diff.len() as f64);
    drop(gs);
    assert_no_validation(&ctx);

    // From v1's camera the far eye is behind the camera: an arrow towards where it lies.
    let v1_png = tmp.join("v1.png");
    let (out, _) = screenshot(&design, "v1", &v1_png, true);
    let c1 = camera_of(&scene, "v1");
    let l = local(&c1, camera_of(&scene, "far").eye);
    assert!(l[2] < 0.0, "the far eye should be behind v1's camera");
    let t = (0.5 * c1.fov_y_deg.to_radians()).tan();
    let (w, h) = (SIZE.0 as f64, SIZE.1 as f64);
    let (tip, dir) = edge_tip(l[0] / (t * w / h) * 0.5 * w, -l[1] / t * 0.5 * h);
    let (ptip, pdir) = printed_arrow(&out, "eye far");
    assert!(
        (ptip.0 - tip.0).abs() < 1e-3 && (ptip.1 - tip.1).abs() < 1e-3,
        "{ptip:?} vs {tip:?}"
    );
    assert!(
        (pdir.0 - dir.0).abs() < 1e-3 && (pdir.1 - dir.1).abs() < 1e-3,
        "{pdir:?} vs {dir:?}"
    );
    let v1 = rgb(&v1_png);
    assert!(count_near(&v1, tip, 14.0, EYE) >= 40, "arrow near {tip:?}");
    line_with(&out, "set-up overlay eye v1: at this camera");
    let _ = std::fs::remove_dir_all(&tmp);
}

/// stdout lines of `child` (whose stderr goes to a file) on a channel.
fn lines(child: &mut Child) -> Receiver<String> {
    let (tx, rx) = channel();
    let out = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for l in BufReader::new(out).lines().map_while(Result::ok) {
            if tx.send(l).is_err() {
                break;
            }
        }
    });
    rx
}

/// The next line that `pred` accepts; every line read on the way is kept in `seen`.
fn wait_line(rx: &Receiver<String>, seen: &mut Vec<String>, what: &str, pred: impl Fn(&str) -> bool) -> String {
    let deadline = Instant::now() + Duration::from_secs(90);
    while Instant::now() < deadline {
        if let Ok(l) = rx.recv_timeout(Duration::from_millis(200)) {
            seen.push(l.clone());
            if pred(&l) {
                return l;
            }
        }
    }
    panic!("no {what} within 90 s");
}

/// Colours may differ by one level between the window and the headless frame (the same rounding
/// tolerance as the viewer's other tests); overlay pixels are copied bytes and must be equal.
fn same_frame(what: &str, a: &image::RgbImage, b: &image::RgbImage) -> Result<(), String> {
    if a.dimensions() != b.dimensions() {
        return Err(format!("{what}: sizes {:?} vs {:?}", a.dimensions(), b.dimensions()));
    }
    let mut exact = 0usize;
    for (i, (p, q)) in a.pixels().zip(b.pixels()).enumerate() {
        let d = (0..3).map(|k| (p.0[k] as i32 - q.0[k] as i32).abs()).max().unwrap();
        let (x, y) = (i as u32 % a.width(), i as u32 / a.width());
        if d > 1 {
            return Err(format!("{what}: pixel ({x}, {y}) {:?} vs {:?}", p.0, q.0));
        }
        if !(grey(p.0) || p.0 == q.0) {
            return Err(format!("{what}: overlay pixel ({x}, {y}) {:?} vs {:?}", p.0, q.0));
        }
        exact += (d == 0) as usize;
    }
    if (exact as f64) < 0.999 * (a.width() * a.height()) as f64 {
        return Err(format!("{what}: {exact} exact pixels"));
    }
    Ok(())
}

/// Grabs the window until `check` accepts the picture: the frame logged as full may be one that
/// was in flight when the key arrived, and the X server shows a presented frame a little later
/// on a busy machine. Fails with the last reason after 20 s.
fn grab_until(
    grab: &dyn Fn(&str) -> image::RgbImage,
    name: &str,
    check: &dyn Fn(&image::RgbImage) -> Result<(), String>,
) -> image::RgbImage {
    let t0 = Instant::now();
    loop {
        let img = grab(name);
        match check(&img) {
            Ok(()) => return img,
            Err(e) if t0.elapsed() > Duration::from_secs(20) => panic!("{e} (still after 20 s)"),
            Err(_) => std::thread::sleep(Duration::from_millis(250)),
        }
    }
}

/// Key S in a window: the overlay appears as in the headless frame (colours right on the
/// swapchain's byte order), the numbers go to stdout and the title, and S again restores the
/// frame; zero validation messages.
#[test]
fn key_s_toggles_the_overlay_in_the_window() {
    let x = XServer::start();
    let tmp = tmp_dir("window");
    let design = write_design(&tmp);
    let headless = tmp.join("headless.png");
    screenshot(&design, "top", &headless, true);
    let headless = rgb(&headless);

    let size = format!("{}x{}", SIZE.0, SIZE.1);
    let err = std::fs::File::create(tmp.join("stderr.txt")).unwrap();
    let mut child = Command::new(viewer_bin())
        .args([
            "--embedded-shaders",
            "--validation",
            "--log-frames",
            "--exit-after",
            "120",
        ])
        .args(["--view", "top", "--size", &size])
        .arg(&design)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(err)
        .spawn()
        .unwrap();
    let rx = lines(&mut child);
    let mut seen = Vec::new();
    let id = wait_line(&rx, &mut seen, "window id", |l| l.starts_with("window-id"));
    let id = id.split_whitespace().nth(1).unwrap().to_string();
    let full = |l: &str| l.contains(" full internal=");
    wait_line(&rx, &mut seen, "a full frame", full);
    std::thread::sleep(Duration::from_millis(300));
    let grab = |name: &str| {
        let p = tmp.join(name);
        x.run("/usr/bin/import", &["-window", &id, p.to_str().unwrap()]);
        rgb(&p)
    };
    // The still frame, once two grabs a moment apart agree (the last one presented).
    let mut before = grab("before.png");
    let t0 = Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(250));
        let again = grab("before.png");
        if again.as_raw() == before.as_raw() {
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(20), "the still frame keeps changing");
        before = again;
    }

    x.run("xdotool", &["windowfocus", "--sync", &id]);
    // S held past the keyboard's auto-repeat delay (660 ms) turns the overlay on once: a toggle
    // ignores repeats, and the press winit makes up for a key held as the window gains focus
    // (which turned the overlay straight off again in one of three runs).
    let pressed = seen.len();
    x.run("xdotool", &["keydown", "s"]);
    std::thread::sleep(Duration::from_millis(1500));
    x.run("xdotool", &["keyup", "s"]);
    let lamp = wait_line(&rx, &mut seen, "the lamp's numbers", |l| l.starts_with("set-up lamp: "));
    wait_line(&rx, &mut seen, "a full frame with the overlay", full);
    std::thread::sleep(Duration::from_millis(300));
    grab_until(&grab, "on.png", &|img| {
        same_frame("window with the overlay vs headless", img, &headless)
    });
    seen.extend(rx.try_iter());
    let toggles: Vec<&String> = seen[pressed..]
        .iter()
        .filter(|l| l.starts_with("set-up lamp: ") || *l == "set-up overlay off")
        .collect();
    assert_eq!(toggles.len(), 1, "the held S toggled again on auto-repeat: {toggles:?}");
    let title = x.run("xdotool", &["getwindowname", &id]);
    let az = format!("lamp az {:.1}", num_after(&lamp, "azimuth"));
    assert!(
        title.contains("set-up") && title.contains(&az),
        "title '{title}' lacks '{az}'"
    );

    x.run("xdotool", &["key", "s"]);
    wait_line(&rx, &mut seen, "overlay off", |l| l == "set-up overlay off");
    wait_line(&rx, &mut seen, "a full frame without the overlay", full);
    std::thread::sleep(Duration::from_millis(300));
    grab_until(&grab, "after.png", &|after| {
        if after.as_raw() == before.as_raw() {
            Ok(())
        } else {
            Err("the frame after S, S differs from before".to_string())
        }
    });

    x.run("xdotool", &["key", "q"]);
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "viewer did not exit on Q");
        std::thread::sleep(Duration::from_millis(50));
    };
    let stderr = std::fs::read_to_string(tmp.join("stderr.txt")).unwrap();
    assert!(status.success(), "{stderr}");
    assert!(stderr.contains("validation messages: 0"), "{stderr}");
    let _ = std::fs::remove_dir_all(&tmp);
}

#[test]
fn help_mentions_the_setup_key_and_flag() {
    let out = Command::new(viewer_bin()).arg("--help").output().unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for s in ["  S  ", "set-up overlay on/off", "--setup"] {
        assert!(help.contains(s), "--help does not mention '{s}':\n{help}");
    }
}
