//! Walk-past plates (`scratchart design --walk / --hold / --object`): the arc's cameras where
//! the flags put them, in-between views in the loss and reported apart, renders from between
//! the design views that show the cross-fade of their neighbours' frames, OBJ meshes and their
//! errors, and the flags' checks.
use std::path::{Path, PathBuf};

use scratchart_design::targets::Picture;
use scratchart_design::walk::{arc_views, walk_targets, Frames, Walk, WalkArc};
use scratchart_model::scene::Scene;
use scratchart_tests::{assert_no_validation, gpu, gpu_render, run_scratchart, write_file};

/// A fresh, empty directory for one test.
fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-walk-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes the built-in shape `shape` (white on black, 48 x 48) as a PNG frame.
fn frame(dir: &Path, name: &str, shape: &str) -> String {
    let img = scratchart_design::targets::draw_shape(shape, 48, 48, 24.0, 24.0, 21.0);
    let bytes: Vec<u8> = img.iter().map(|v| (255.0 * v).round() as u8).collect();
    let p = dir.join(name);
    scratchart_render::io::write_png_gray(&p, 48, 48, &bytes).unwrap();
    p.display().to_string()
}

fn summary(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The correlation the report uses: the render blurred as the loss blurs it, against the
/// target over its picture's pixels.
fn corr(display: &[f32], target: &[f32], picture: &[bool], w: u32, h: u32) -> f64 {
    let clamped: Vec<f32> = display.iter().map(|x| x.clamp(0.0, 1.0)).collect();
    let blurred = scratchart_design::measure::blur3(&clamped, w, h, 1.0);
    let t: Vec<f64> = target.iter().map(|&x| x as f64).collect();
    scratchart_design::measure::correlation(&blurred, &t, picture)
}

/// Four unrelated frames along an 18 degree arc: every design view shows its frame, and a
/// render from halfway between two design views (made here from design.json alone, with the
/// camera the arc puts there) shows the cross-fade of their frames, as summary.json says.
#[test]
fn a_small_walk_shows_its_frames_and_their_blends_between_them() {
    let dir = tmp("frames");
    let shapes = ["circle", "triangle", "star", "cross"];
    let frames: Vec<String> = shapes
        .iter()
        .enumerate()
        .map(|(k, s)| frame(&dir, &format!("f{k}.png"), s))
        .collect();
    let out = dir.join("out");
    let mut args = vec!["design", "--walk"];
    args.extend(frames.iter().map(String::as_str));
    let out_s = out.display().to_string();
    args.extend([
        "--arc",
        "18",
        "--res",
        "64",
        "--scratches",
        "2500",
        "--iters",
        "80",
        "--validation",
        "--quiet",
        "--out",
        &out_s,
    ]);
    let o = run_scratchart(&args);
    assert!(o.status.success(), "design --walk failed: {}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("walk (frames): 4 views over 18.0 degrees"), "{text}");

    // design.json holds the design views only, where the flags put them.
    let scene = Scene::load(&out.join("design.json")).unwrap();
    assert_eq!(
        scene.views.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(),
        ["v0", "v1", "v2", "v3"]
    );
    for (k, v) in scene.views.iter().enumerate() {
        let e = v.camera.eye;
        let d = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        let az = e[1].atan2(e[0]).to_degrees();
        let el = (e[2] / d).asin().to_degrees();
        assert!(
            (d - 300.0).abs() < 1e-9 && (el - 45.0).abs() < 1e-9,
            "view {k}: {d} mm, {el} deg"
        );
        assert!((az - (-9.0 + 6.0 * k as f64)).abs() < 1e-9, "view {k}: azimuth {az}");
    }

    // summary.json: each design view with its frame, each in-between view with its blend.
    let s = summary(&out);
    check_walk_summary(&s, &text);
    for f in ["walk.png", "walk_sheet.png"] {
        assert!(std::fs::metadata(out.join(f)).unwrap().len() > 1000, "{f}");
    }
    renders_match_the_reported_correlations(&scene, &frames, &s["walk"]);
}

/// The walk of `a_small_walk_...` in summary.json: four design views each showing its frame,
/// three in-between views showing their neighbours' blend, nine probes (`text`: the run's
/// stdout).
fn check_walk_summary(s: &serde_json::Value, text: &str) {
    let w = &s["walk"];
    assert_eq!(w["source"], "frames");
    assert_eq!(w["design_views"], 4);
    let views = w["views"].as_array().unwrap();
    let between = w["between"].as_array().unwrap();
    assert_eq!(views.len(), 4);
    assert_eq!(between.len(), 3);
    assert_eq!(
        s["per_view"].as_array().unwrap().len(),
        4,
        "in-between views are not design views"
    );
    for v in views {
        let c = v["corr"].as_f64().unwrap();
        assert!(c >= 0.85, "{} shows its frame with correlation {c}", v["name"]);
    }
    for b in between {
        let c = b["corr"].as_f64().unwrap();
        assert!(
            c >= 0.75,
            "{} shows its neighbours' blend with correlation {c}",
            b["name"]
        );
        assert_eq!(b["t"], 0.5);
    }
    // Probes judge the arc between the views without joining the loss: 3 per pair by default.
    let probes = w["probes"].as_array().unwrap();
    assert_eq!(probes.len(), 9);
    assert!(
        probes.iter().all(|p| p["corr"].as_f64().is_some_and(|c| c > 0.3)),
        "{probes:?}"
    );
    assert!(text.contains("9 probes between the views"), "{text}");
}

/// From design.json alone: the in-between cameras the arc puts halfway, rendered on the GPU,
/// against the cross-fades of their neighbours' frames; each correlation as `walk` reports it.
fn renders_match_the_reported_correlations(scene: &Scene, frames: &[String], walk: &serde_json::Value) {
    let views = walk["views"].as_array().unwrap();
    let between = walk["between"].as_array().unwrap();
    let arc = WalkArc {
        arc_deg: 18.0,
        centre_azimuth_deg: 0.0,
        elevation_deg: 45.0,
        distance_mm: 300.0,
        views: 4,
        between: 1,
        res: 64,
    };
    let (all, bviews) = arc_views(&arc, &scene.plate, &scene.views[0].light);
    for (k, v) in scene.views.iter().enumerate() {
        assert_eq!(v.camera, all[k].camera, "view {k}'s camera");
    }
    let mut full = scene.clone();
    full.views = all;
    let walk = Walk {
        arc,
        source: "frames".into(),
        frames: frames.to_vec(),
        between: bviews.clone(),
        probes: vec![],
    };
    let pictures: Vec<Picture> = frames
        .iter()
        .map(|f| {
            let (width, height, data) = scratchart_render::io::read_image_gray(Path::new(f)).unwrap();
            Picture {
                path: f.into(),
                width,
                height,
                data,
            }
        })
        .collect();
    let targets = walk_targets(
        &full,
        &walk,
        &Frames::Pictures(pictures),
        scratchart_design::framing::Fit::Contain,
        0.0,
        1.0,
    );
    let ctx = gpu();
    let images = gpu_render(&ctx, &full);
    assert_no_validation(&ctx);
    for (k, v) in views.iter().enumerate() {
        let display: Vec<f32> = images[k]
            .iter()
            .map(|&l| scratchart_render::io::display_value(l))
            .collect();
        let c = corr(&display, &targets[k].image, &targets[k].picture, 64, 64);
        let reported = v["corr"].as_f64().unwrap();
        assert!(
            (c - reported).abs() < 1e-3,
            "{}: rendered here {c}, reported {reported}",
            v["name"]
        );
    }
    for (i, b) in bviews.iter().enumerate() {
        let display: Vec<f32> = images[b.view]
            .iter()
            .map(|&l| scratchart_render::io::display_value(l))
            .collect();
        let c = corr(&display, &targets[b.view].image, &targets[b.view].picture, 64, 64);
        let reported = between[i]["corr"].as_f64().unwrap();
        assert!(
            (c - reported).abs() < 1e-3,
            "{}: rendered here {c}, reported {reported}",
            between[i]["name"]
        );
    }
}

/// A 3D object seen along an arc: each view's target is the object from there (parallax), and
/// the plate shows it; a held picture is the same picture at every view.
#[test]
fn an_object_walk_and_a_held_picture() {
    let dir = tmp("object");
    let torus = scratchart_tests::workspace_root().join("engine/assets/objects/torus.obj");
    let out = dir.join("obj");
    let out_s = out.display().to_string();
    let o = run_scratchart(&[
        "design",
        "--object",
        torus.to_str().unwrap(),
        "--arc",
        "30",
        "--walk-views",
        "3",
        "--res",
        "48",
        "--scratches",
        "1500",
        "--iters",
        "40",
        "--validation",
        "--quiet",
        "--out",
        &out_s,
    ]);
    assert!(o.status.success(), "design --object failed: {}", stderr(&o));
    let s = summary(&out);
    assert_eq!(s["walk"]["source"], "object");
    assert_eq!(s["walk"]["views"].as_array().unwrap().len(), 3);
    assert_eq!(s["walk"]["between"].as_array().unwrap().len(), 2);
    let c = s["walk"]["min_corr_views"].as_f64().unwrap();
    assert!(c > 0.6, "the object's views correlate {c}");
    // Parallax: the object sits behind the plate, so the views see it differently.
    let t0 = image::open(out.join("v0_target.png")).unwrap().to_luma8();
    let t2 = image::open(out.join("v2_target.png")).unwrap().to_luma8();
    let differ = t0
        .pixels()
        .zip(t2.pixels())
        .filter(|(a, b)| a.0[0].abs_diff(b.0[0]) > 40)
        .count();
    assert!(
        differ > 50,
        "the two ends of the arc see the same object image ({differ} pixels differ)"
    );

    let pic = frame(&dir, "held.png", "star");
    let out = dir.join("hold");
    let out_s = out.display().to_string();
    let o = run_scratchart(&[
        "design",
        "--hold",
        &pic,
        "--arc",
        "10",
        "--res",
        "32",
        "--scratches",
        "300",
        "--iters",
        "2",
        "--prune-tol",
        "0",
        "--quiet",
        "--out",
        &out_s,
    ]);
    assert!(o.status.success(), "design --hold failed: {}", stderr(&o));
    let s = summary(&out);
    // 10 degrees: a view every 5 degrees, so 3 views and 2 in between.
    assert_eq!(s["walk"]["source"], "hold");
    assert_eq!(s["walk"]["views"].as_array().unwrap().len(), 3);
    assert_eq!(s["walk"]["between"].as_array().unwrap().len(), 2);
}

/// Bad walks are refused with exit 2 (flags) or 3 (files), each with a message that names
/// what to change.
#[test]
fn walk_flags_and_bad_files_are_refused_clearly() {
    let dir = tmp("flags");
    let a = frame(&dir, "a.png", "circle");
    let b = frame(&dir, "b.png", "ring");
    let out = dir.join("out").display().to_string();
    let cases: Vec<(Vec<&str>, i32, &str)> = vec![
        (vec!["--arc", "30"], 2, "--arc belongs to a walk"),
        (vec!["--walk", &a, &b], 2, "need --arc"),
        (vec!["--walk", &a, "--arc", "30"], 2, "at least 2 frames"),
        (vec!["--walk", &a, &b, "--arc", "0"], 2, "--arc 0"),
        (
            vec!["--walk", &a, &b, "--arc", "30", "--walk-views", "5"],
            2,
            "--walk-views",
        ),
        (
            vec!["--walk", &a, &b, "--arc", "30", "--targets", &a, &b],
            2,
            "cannot be used with",
        ),
        (
            vec!["--hold", &a, "--arc", "30", "--object-size", "10"],
            2,
            "--object-size belongs to --object",
        ),
    ];
    for (extra, code, msg) in cases {
        let mut args = vec![
            "design",
            "--iters",
            "1",
            "--res",
            "16",
            "--scratches",
            "10",
            "--out",
            &out,
        ];
        args.extend(extra.iter());
        let o = run_scratchart(&args);
        assert_eq!(o.status.code(), Some(code), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(msg), "{extra:?}: {}", stderr(&o));
    }
    // A directory with one frame; a directory of frames is taken in name order.
    let one = dir.join("one");
    std::fs::create_dir_all(&one).unwrap();
    frame(&one, "x.png", "star");
    let one_s = one.display().to_string();
    let o = run_scratchart(&["design", "--walk", &one_s, "--arc", "20", "--out", &out]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("the directory has 1"), "{}", stderr(&o));
    // A broken OBJ names its file and line; a missing one its file.
    let obj = write_file(&dir, "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n");
    let o = run_scratchart(&["design", "--object", &obj, "--arc", "20", "--out", &out]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("bad.obj") && stderr(&o).contains("line 3"),
        "{}",
        stderr(&o)
    );
    let o = run_scratchart(&[
        "design",
        "--object",
        "/nonexistent/model.obj",
        "--arc",
        "20",
        "--out",
        &out,
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("model.obj"), "{}", stderr(&o));
}
