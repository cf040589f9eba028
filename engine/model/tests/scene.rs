//! Scene file reading, validation and writing (engine/docs/model.md section 6).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use scratchart_model::scene::{LightKind, Scene, Scratch};
use serde_json::{json, Value};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

fn tmpdir(tag: &str) -> PathBuf {
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!("scratchart_model_scene_{}_{tag}_{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn base() -> Value {
    json!({
        "plate": { "size_mm": 100.0, "roughness": 0.02, "f0": 0.91 },
        "views": [
            { "name": "v0",
              "camera": { "eye": [0, -250, 250], "target": [0, 0, 0], "up": [0, 0, 1],
                          "fov_y_deg": 28.0, "width": 64, "height": 48 },
              "light": { "kind": "point", "position": [0, 250, 250], "intensity": 60000.0 } }
        ],
        "scratches": [[-10.0, 0.0, 10.0, 5.0, 0.05, 0.01, 0.1]]
    })
}

/// Write `v` as scene.json (plus optional CSV text) into a fresh directory and load it.
fn load_value(tag: &str, v: &Value, csv: Option<&str>) -> (Result<Scene, String>, PathBuf) {
    let d = tmpdir(tag);
    let p = d.join(format!("{tag}.json"));
    std::fs::write(&p, serde_json::to_string_pretty(v).unwrap()).unwrap();
    if let Some(c) = csv {
        std::fs::write(d.join(format!("{tag}.csv")), c).unwrap();
    }
    (Scene::load(&p).map_err(|e| e.to_string()), p)
}

fn set(v: &mut Value, pointer: &str, x: Value) {
    *v.pointer_mut(pointer).unwrap_or_else(|| panic!("no {pointer}")) = x;
}

/// Loading `v` fails with a message naming the file and containing every `needles` string.
fn expect_err(tag: &str, v: &Value, needles: &[&str]) {
    let (r, p) = load_value(tag, v, None);
    let msg = r.expect_err(&format!("{tag}: should fail"));
    eprintln!("{tag}: {msg}");
    let fname = p.file_name().unwrap().to_str().unwrap();
    assert!(msg.contains(fname), "{tag}: message does not name the file: {msg}");
    for n in needles {
        assert!(msg.contains(n), "{tag}: message lacks `{n}`: {msg}");
    }
}

fn expect_csv_err(tag: &str, csv: &str, needles: &[&str]) {
    let mut v = base();
    set(&mut v, "/scratches", json!(format!("{tag}.csv")));
    let (r, _) = load_value(tag, &v, Some(csv));
    let msg = r.expect_err(&format!("{tag}: should fail"));
    eprintln!("{tag}: {msg}");
    assert!(
        msg.contains(&format!("{tag}.csv")),
        "{tag}: message does not name the CSV: {msg}"
    );
    for n in needles {
        assert!(msg.contains(n), "{tag}: message lacks `{n}`: {msg}");
    }
}

#[test]
fn base_scene_loads() {
    let (r, _) = load_value("base", &base(), None);
    let s = r.unwrap();
    assert_eq!(s.views.len(), 1);
    assert_eq!(s.scratches.len(), 1);
    assert_eq!(s.views[0].camera.width, 64);
    assert!(matches!(s.views[0].light.kind, LightKind::Point { .. }));
    s.validate().unwrap();
}

#[test]
fn json_errors() {
    let d = tmpdir("badjson");
    let p = d.join("broken.json");
    std::fs::write(&p, "{\n  \"plate\": { \"size_mm\": 100.0,, }\n}").unwrap();
    let msg = Scene::load(&p).unwrap_err().to_string();
    assert!(
        msg.contains("broken.json") && msg.contains("line 2") && msg.contains("column"),
        "{msg}"
    );

    std::fs::write(&p, "{ \"plate\": { \"size_mm\": NaN } }").unwrap();
    let msg = Scene::load(&p).unwrap_err().to_string();
    assert!(
        msg.contains("broken.json") && msg.contains("NaN") && msg.contains("line 1"),
        "{msg}"
    );

    let msg = Scene::load(&d.join("nope.json")).unwrap_err().to_string();
    assert!(
        msg.contains("nope.json") && msg.contains("cannot read scene file"),
        "{msg}"
    );
}

#[test]
fn missing_csv() {
    let mut v = base();
    set(&mut v, "/scratches", json!("absent.csv"));
    let (r, _) = load_value("missingcsv", &v, None);
    let msg = r.unwrap_err();
    assert!(msg.contains("absent.csv") && msg.contains("scratch CSV file"), "{msg}");
}

#[test]
fn csv_errors() {
    let h = "x0,y0,x1,y1,w,d,alpha\n";
    expect_csv_err(
        "cols",
        &format!("{h}0,0,1,1,0.1,0.1,0.5\n0,0,1,1,0.1,0.1\n"),
        &["data row 2", "line 3", "6 columns", "expected 7"],
    );
    expect_csv_err(
        "nonnum",
        &format!("{h}0,0,1,abc,0.1,0.1,0.5\n"),
        &["data row 1", "line 2", "y1", "`abc` is not a number"],
    );
    expect_csv_err(
        "nan",
        &format!("{h}\n0,0,1,1,0.1,0.1,0.5\n0,0,1,1,nan,0.1,0.5\n"),
        &["data row 2", "line 4", "column w", "not a finite number"],
    );
    expect_csv_err(
        "inf",
        &format!("{h}0,0,1,1,0.1,inf,0.5\n"),
        &["data row 1", "column d", "not a finite"],
    );
    expect_csv_err(
        "header",
        "x0,y0,x1,y1,w,depth,alpha\n0,0,1,1,0.1,0.1,0.5\n",
        &["header", "expected"],
    );
    expect_csv_err(
        "wzero",
        &format!("{h}0,0,1,1,0,0.1,0.5\n"),
        &["data row 1", "line 2", "w = 0", "> 0"],
    );
    expect_csv_err(
        "dneg",
        &format!("{h}0,0,1,1,0.1,-0.1,0.5\n"),
        &["data row 1", "d = -0.1", "> 0"],
    );
    expect_csv_err(
        "alpha1",
        &format!("{h}0,0,1,1,0.1,0.1,1\n"),
        &["alpha = 1", "between 0 and 1"],
    );
    expect_csv_err(
        "alpha0",
        &format!("{h}0,0,1,1,0.1,0.1,0\n"),
        &["alpha = 0", "between 0 and 1"],
    );
    expect_csv_err(
        "zerolen",
        &format!("{h}0,0,1,1,0.1,0.1,0.5\n2,3,2,3,0.1,0.1,0.5\n"),
        &["data row 2", "zero-length"],
    );
    expect_csv_err(
        "offplate",
        &format!("{h}0,0,50.5,1,0.1,0.1,0.5\n"),
        &["p1", "off the plate", "50"],
    );
}

#[test]
fn csv_valid_edge_cases_and_reader() {
    // Headerless, CRLF, comments, blank lines, thin and short scratches, edge endpoints.
    let csv = "# scratches\r\n0,0,1e-4,0,1e-4,1e-6,1e-3\r\n\r\n-50,-50,50,50,0.1,0.1,0.999\r\n";
    let mut v = base();
    set(&mut v, "/scratches", json!("edge.csv"));
    let (r, p) = load_value("edge", &v, Some(csv));
    let s = r.unwrap();
    assert_eq!(s.scratches.len(), 2);
    assert_eq!(s.scratches[0].alpha, 1e-3);
    assert!(s.scratches[0].half_width() > 0.0);
    let direct = scratchart_model::read_scratches_csv(&p.parent().unwrap().join("edge.csv")).unwrap();
    assert_eq!(direct, s.scratches);
}

#[test]
fn inline_scratch_errors() {
    let bad = |tag: &str, row: Value, needles: &[&str]| {
        let mut v = base();
        set(&mut v, "/scratches", json!([[0, 0, 1, 1, 0.1, 0.1, 0.5], row]));
        let mut n = vec!["scratches row 2"];
        n.extend_from_slice(needles);
        expect_err(tag, &v, &n);
    };
    bad("in_w", json!([0, 0, 1, 1, -1, 0.1, 0.5]), &["w = -1"]);
    bad("in_d", json!([0, 0, 1, 1, 0.1, 0, 0.5]), &["d = 0"]);
    bad(
        "in_a",
        json!([0, 0, 1, 1, 0.1, 0.1, 1.5]),
        &["alpha = 1.5", "not clamped"],
    );
    bad("in_len", json!([1, 1, 1, 1, 0.1, 0.1, 0.5]), &["zero-length"]);
    bad("in_off", json!([0, -60, 1, 1, 0.1, 0.1, 0.5]), &["p0", "off the plate"]);
    bad("in_cols", json!([0, 0, 1, 1, 0.1, 0.1]), &["7 numbers"]);
    bad("in_str", json!([0, 0, 1, "x", 0.1, 0.1, 0.5]), &["y1", "not a number"]);
}

#[test]
fn plate_and_view_errors() {
    let cases: Vec<(&str, &str, Value, Vec<&str>)> = vec![
        ("size0", "/plate/size_mm", json!(0.0), vec!["plate.size_mm", "> 0"]),
        ("sizeneg", "/plate/size_mm", json!(-5), vec!["plate.size_mm"]),
        (
            "rough0",
            "/plate/roughness",
            json!(0.0),
            vec!["plate.roughness", "between 0 and 1"],
        ),
        ("rough1", "/plate/roughness", json!(1.0), vec!["plate.roughness"]),
        ("f0big", "/plate/f0", json!(1.5), vec!["plate.f0", "[0, 1]"]),
        ("noviews", "/views", json!([]), vec!["views", "no views"]),
        (
            "width0",
            "/views/0/camera/width",
            json!(0),
            vec!["camera.width", "at least 1"],
        ),
        (
            "height0",
            "/views/0/camera/height",
            json!(0),
            vec!["camera.height", "at least 1"],
        ),
        (
            "fov0",
            "/views/0/camera/fov_y_deg",
            json!(0.0),
            vec!["fov_y_deg", "between 0 and 180"],
        ),
        (
            "fov180",
            "/views/0/camera/fov_y_deg",
            json!(180.0),
            vec!["fov_y_deg", "between 0 and 180"],
        ),
        (
            "eyetarget",
            "/views/0/camera/target",
            json!([0, -250, 250]),
            vec!["v0", "eye and target coincide"],
        ),
        (
            "upparallel",
            "/views/0/camera/up",
            json!([0, 1, -1]),
            vec!["v0", "camera.up", "parallel"],
        ),
        (
            "kind",
            "/views/0/light/kind",
            json!("spot"),
            vec!["light.kind", "unknown light kind", "spot"],
        ),
        (
            "int0",
            "/views/0/light/intensity",
            json!(0.0),
            vec!["light.intensity", "> 0"],
        ),
        (
            "intneg",
            "/views/0/light/intensity",
            json!(-3.0),
            vec!["light.intensity"],
        ),
        ("badname", "/views/0/name", json!("a/b"), vec!["view name", "file name"]),
        ("emptyname", "/views/0/name", json!(""), vec!["view name is empty"]),
        ("dotname", "/views/0/name", json!(".."), vec!["view name", "file name"]),
        (
            "nosee",
            "/views/0/camera/target",
            json!([0, -500, 500]),
            vec!["v0", "does not see the plate", "move the target"],
        ),
    ];
    for (tag, ptr, val, needles) in cases {
        let mut v = base();
        set(&mut v, ptr, val);
        expect_err(tag, &v, &needles);
    }

    // Missing position, missing/zero direction.
    let mut v = base();
    v.pointer_mut("/views/0/light")
        .unwrap()
        .as_object_mut()
        .unwrap()
        .remove("position");
    expect_err("nopos", &v, &["light.position", "missing"]);
    let mut v = base();
    set(
        &mut v,
        "/views/0/light",
        json!({"kind": "directional", "intensity": 1.0}),
    );
    expect_err("nodir", &v, &["light.direction", "missing"]);
    let mut v = base();
    set(
        &mut v,
        "/views/0/light",
        json!({"kind": "directional", "direction": [0, 0, 0], "intensity": 1.0}),
    );
    expect_err("zerodir", &v, &["light.direction", "zero"]);

    // Duplicate names.
    let mut v = base();
    let view = v["views"][0].clone();
    v["views"].as_array_mut().unwrap().push(view);
    expect_err("dup", &v, &["duplicate view name", "v0"]);

    // Missing plate size.
    let mut v = base();
    v["plate"].as_object_mut().unwrap().remove("size_mm");
    expect_err("nosize", &v, &["plate.size_mm", "missing"]);
}

#[test]
fn valid_edge_cases_accepted() {
    let mut v = base();
    // Defaults, unknown fields, directional light normalised, extreme-but-legal scratches.
    v["plate"] = json!({ "size_mm": 100.0, "comment": "hi" });
    v["extra"] = json!({"anything": [1, 2, 3]});
    v["views"][0]["light"] = json!({"kind": "directional", "direction": [0, 3, 4], "intensity": 2.5});
    v["views"][0]["camera"]["notes"] = json!("ignored");
    v["scratches"] = json!([
        [0, 0, 1e-4, 0, 1e-4, 1e-4, 1e-3],
        [-50, -50, 50, 50, 1e-4, 10.0, 0.999],
        [49.9, 0, 50, 0, 3.0, 1e-6, 0.5]
    ]);
    let (r, _) = load_value("edgeok", &v, None);
    let s = r.unwrap();
    assert_eq!(s.plate.roughness, 0.02);
    assert_eq!(s.plate.f0, 0.91);
    match s.views[0].light.kind {
        LightKind::Directional { direction } => {
            assert!((direction[1] - 0.6).abs() < 1e-15 && (direction[2] - 0.8).abs() < 1e-15)
        }
        _ => panic!("directional expected"),
    }
    assert_eq!(s.scratches.len(), 3);
    // f0 bounds are inclusive; a camera straight down with a sideways up works.
    let mut v = base();
    v["plate"]["f0"] = json!(1.0);
    v["views"][0]["camera"] = json!({"eye": [0, 0, 300], "target": [0, 0, 0], "up": [0, 1, 0],
        "fov_y_deg": 170.0, "width": 1, "height": 1});
    let (r, _) = load_value("edgeok2", &v, None);
    r.unwrap();
    // A camera seeing only a corner of the plate is accepted.
    let mut v = base();
    v["views"][0]["camera"] = json!({"eye": [80, 80, 40], "target": [60, 60, 0], "up": [0, 0, 1],
        "fov_y_deg": 30.0, "width": 32, "height": 32});
    let (r, _) = load_value("corner", &v, None);
    r.unwrap();
}

#[test]
fn half_width_is_stable() {
    let s = Scratch {
        p0: [0.0; 2],
        p1: [1.0, 0.0],
        w: 1.0,
        d: 1e-12,
        alpha: 0.5,
        bulge: 0.0,
    };
    // e ~ (w/2) sqrt(2d/w) for d << w.
    let e = s.half_width();
    let approx = 0.5 * (2.0e-12f64).sqrt();
    assert!((e / approx - 1.0).abs() < 1e-9, "{e} vs {approx}");
    let s = Scratch { w: 0.2, d: 0.05, ..s };
    let exact = 0.1 * (1.0 - (-0.5f64).exp()).sqrt();
    assert!((s.half_width() - exact).abs() < 1e-16);
    assert!((Scratch { p1: [3.0, 4.0], ..s }.length() - 5.0).abs() < 1e-15);
}

fn awkward_scene() -> Scene {
    let mut s = Scene::from_json_str(&base().to_string(), Path::new("."), "mem").unwrap();
    s.plate.size_mm = 100.0 / 3.0;
    s.plate.roughness = 0.1 + 0.2;
    s.views[0].camera.fov_y_deg = 27.123456789012345;
    s.views[0].camera.eye = [1e-7, -250.00000000000003, 250.1];
    s.views.push(s.views[0].clone());
    s.views[1].name = "second_view".into();
    s.views[1].light.kind = LightKind::Directional {
        direction: [0.0, 0.6, 0.8],
    };
    s.views[1].light.intensity = 1.0 / 7.0;
    s.views[1].exposure = 0.1 + 0.2;
    s.scratches = (0..50)
        .map(|k| {
            let a = k as f64 * 0.7313;
            Scratch {
                p0: [5.0 * a.sin(), 4.0 * a.cos() + 1e-9],
                p1: [-3.3 * (1.7 * a).cos(), 2.0 / (k as f64 + 3.0)],
                w: 0.01 + 1e-3 / (k as f64 + 1.0),
                d: 1e-5 * (k as f64 + 1.0).sqrt(),
                alpha: 1.0 / (k as f64 + 2.0),
                bulge: 0.0,
            }
        })
        .collect();
    s.validate().unwrap();
    s
}

#[test]
fn save_load_round_trip_is_exact() {
    let s = awkward_scene();
    let d = tmpdir("roundtrip");
    let p = d.join("scene.json");
    s.save(&p, "marks.csv").unwrap();
    let back = Scene::load(&p).unwrap();
    assert_eq!(back, s);
    // Header line present; no temp files left behind.
    let csv = std::fs::read_to_string(d.join("marks.csv")).unwrap();
    assert!(csv.starts_with("x0,y0,x1,y1,w,d,alpha\n"));
    let names: Vec<_> = std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 2, "{names:?}");
    // Overwriting works too.
    s.save(&p, "marks.csv").unwrap();
    assert_eq!(Scene::load(&p).unwrap(), s);
    // Inline JSON round-trips.
    let text = s.to_json_inline();
    let back = Scene::from_json_str(&text, Path::new("/nonexistent"), "inline").unwrap();
    assert_eq!(back, s);
}

#[test]
fn validate_catches_programmatic_errors() {
    let mut s = awkward_scene();
    s.scratches[3].w = f64::NAN;
    let msg = s.validate().unwrap_err().to_string();
    assert!(msg.contains("scratch 4") && msg.contains("not a finite"), "{msg}");
    let mut s = awkward_scene();
    s.views[1].light.intensity = f64::INFINITY;
    let msg = s.validate().unwrap_err().to_string();
    assert!(msg.contains("second_view") && msg.contains("intensity"), "{msg}");
    for bad in [0.0, -1.0, f64::NAN] {
        let mut s = awkward_scene();
        s.views[1].exposure = bad;
        let msg = s.validate().unwrap_err().to_string();
        assert!(msg.contains("second_view") && msg.contains("exposure"), "{bad}: {msg}");
    }
}

/// Views whose lights stand within 1 um (or come from one direction) are one lamp; each view's
/// brightness under it is its intensity times exposure over the brightest's; setting the
/// radiance scales the optimizer moves gives one intensity per lamp, with the exposures kept or
/// derived, and renders the same radiance either way.
#[test]
fn lamps_share_one_intensity_and_views_keep_an_exposure() {
    let mut s = awkward_scene();
    let v = s.views[0].clone();
    s.views = (0..5)
        .map(|k| {
            let mut w = v.clone();
            w.name = format!("v{k}");
            w
        })
        .collect();
    let at = |x: f64| LightKind::Point {
        position: [x, 100.0, 200.0],
    };
    s.views[0].light.kind = at(10.0);
    s.views[1].light.kind = at(10.0 + 0.4e-3); // within 1 um: the same lamp
    s.views[2].light.kind = at(10.0 + 2e-3); // 2 um away: another
    s.views[3].light.kind = LightKind::Directional {
        direction: [0.0, 0.6, 0.8],
    };
    s.views[4].light.kind = LightKind::Directional {
        direction: [0.0, 0.6, 0.8],
    };
    let lamps = s.lamps();
    let members: Vec<Vec<usize>> = lamps.iter().map(|l| l.views.clone()).collect();
    assert_eq!(members, vec![vec![0, 1], vec![2], vec![3, 4]]);
    assert_eq!(lamps[0].name, "v0");
    // Free exposures: the brightest view of a lamp gets 1, the others their share.
    let r = [4.0, 1.0, 3.0, 2.0, 8.0];
    let mut free = s.clone();
    free.set_radiance(&r, false);
    for (j, &want) in r.iter().enumerate() {
        assert!(
            (free.views[j].radiance_scale() - want).abs() <= 1e-12 * want,
            "view {j}"
        );
    }
    assert_eq!(free.views[0].light.intensity, free.views[1].light.intensity);
    assert_eq!(free.views[3].light.intensity, 8.0);
    assert_eq!((free.views[0].exposure, free.views[1].exposure), (1.0, 0.25));
    assert_eq!(free.relative_brightness(), vec![1.0, 0.25, 1.0, 0.25, 1.0]);
    assert_eq!(free.lamps()[0].intensity, 4.0);
    // Kept exposures (tied views): one intensity, exposures as they were.
    let mut tied = s.clone();
    tied.views[1].exposure = 0.5;
    tied.set_radiance(&[4.0, 2.0, 3.0, 2.0, 2.0], true);
    assert_eq!(tied.views[0].light.intensity, 4.0);
    assert_eq!(tied.views[1].light.intensity, 4.0);
    assert_eq!(tied.views[1].exposure, 0.5);
    assert_eq!(tied.relative_brightness()[1], 0.5);
    // The exposure is read and written (only where it is not 1), and round-trips.
    let d = tmpdir("exposure");
    let p = d.join("scene.json");
    free.save(&p, "s.csv").unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert_eq!(text.matches("\"exposure\"").count(), 2, "{text}");
    assert_eq!(Scene::load(&p).unwrap(), free);
    let mut v = base();
    v["views"][0]["exposure"] = json!(0.0);
    expect_err("exposure0", &v, &["exposure", "> 0"]);
    v["views"][0]["exposure"] = json!("x");
    expect_err("exposurex", &v, &["exposure", "not a finite number"]);
}

/// A misspelt key is not silently ignored: a warning names it and the closest known key; known
/// keys and the reserved extension keys give none.
#[test]
fn unknown_keys_are_warned_about_with_the_closest_key() {
    let d = std::env::temp_dir().join(format!("scratchart-keys-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let good = r#"{"plate":{"size_mm":20,"roughness":0.02},"views":[{"name":"v","target":"t.png","camera":{"eye":[0,-40,40],"target":[0,0,0],"up":[0,0,1],"fov_y_deg":30,"width":8,"height":8},"light":{"kind":"point","position":[0,40,40],"intensity":1}}],"scratches":[],"setup":{}}"#;
    let p = d.join("good.json");
    std::fs::write(&p, good).unwrap();
    let (_, w) = scratchart_model::scene::Scene::load_with_warnings(&p).unwrap();
    assert!(w.is_empty(), "{w:?}");
    let bad = good
        .replace("\"roughness\"", "\"roughnes\"")
        .replace("\"fov_y_deg\":30", "\"fov_y_deg\":30,\"fovy\":2");
    let p = d.join("bad.json");
    std::fs::write(&p, bad).unwrap();
    let (scene, w) = scratchart_model::scene::Scene::load_with_warnings(&p).unwrap();
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(w[0].contains("`roughnes`") && w[0].contains("`roughness`"), "{}", w[0]);
    assert!(
        w[1].contains("`fovy`") && w[1].contains("views[0].camera") && w[1].contains("`fov_y_deg`"),
        "{}",
        w[1]
    );
    assert_eq!(scene.plate.roughness, scratchart_model::scene::DEFAULT_ROUGHNESS);
    let _ = std::fs::remove_dir_all(&d);
}

/// Files that start with a UTF-8 byte-order mark (as spreadsheets write them) are read.
#[test]
fn byte_order_marks_are_accepted() {
    let d = std::env::temp_dir().join(format!("scratchart-bom-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("s.csv"), "\u{feff}x0,y0,x1,y1,w,d,alpha\n0,0,1,1,0.1,0.1,0.2\n").unwrap();
    let json = "\u{feff}{\"plate\":{\"size_mm\":20},\"views\":[{\"name\":\"v\",\"camera\":{\"eye\":[0,-40,40],\"target\":[0,0,0],\"up\":[0,0,1],\"fov_y_deg\":30,\"width\":8,\"height\":8},\"light\":{\"kind\":\"point\",\"position\":[0,40,40],\"intensity\":1}}],\"scratches\":\"s.csv\"}";
    std::fs::write(d.join("s.json"), json).unwrap();
    let scene = scratchart_model::scene::Scene::load(&d.join("s.json")).unwrap();
    assert_eq!(scene.scratches.len(), 1);
    // Headerless CSV with a BOM before the first number.
    std::fs::write(d.join("s.csv"), "\u{feff}0,0,1,1,0.1,0.1,0.2\n").unwrap();
    let scene = scratchart_model::scene::Scene::load(&d.join("s.json")).unwrap();
    assert_eq!(scene.scratches.len(), 1);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn extra_named_columns_are_read_kept_and_checked() {
    // `z_mm` after the seven: Scene::load skips it, load_extra returns it, save_extra keeps it.
    let csv = "x0,y0,x1,y1,w,d,alpha,z_mm,band\n0,0,1,1,0.1,0.1,0.5,0.031,2\n-3,1,4,2,0.2,0.05,0.3,0.012,1\n";
    let mut v = base();
    set(&mut v, "/scratches", json!("extra.csv"));
    let (r, p) = load_value("extra", &v, Some(csv));
    let plain = r.unwrap();
    assert_eq!(plain.scratches.len(), 2);
    let (scene, extra) = Scene::load_extra(&p).unwrap();
    assert_eq!(scene, plain);
    assert_eq!(extra.names, vec!["z_mm", "band"]);
    assert_eq!(extra.column("z_mm").unwrap(), vec![0.031, 0.012]);
    assert_eq!(extra.column("band").unwrap(), vec![2.0, 1.0]);
    assert!(extra.column("nope").is_none());
    let d = p.parent().unwrap();
    scene.save_extra(&d.join("again.json"), "again.csv", &extra).unwrap();
    let (back, extra_back) = Scene::load_extra(&d.join("again.json")).unwrap();
    assert_eq!(back, scene);
    assert_eq!(extra_back, extra);
    // Selecting rows keeps each scratch's values; set_column adds or replaces.
    let mut sel = extra.select(&[1]);
    assert_eq!(sel.rows, vec![vec![0.012, 1.0]]);
    sel.set_column("band", &[7.0]);
    sel.set_column("w_cut", &[0.3]);
    assert_eq!(sel.names, vec!["z_mm", "band", "w_cut"]);
    assert_eq!(sel.rows, vec![vec![0.012, 7.0, 0.3]]);
    // A file without extras gives none, and a plain save writes the seven only.
    scene.save(&d.join("plain.json"), "plain.csv").unwrap();
    let (_, none) = Scene::load_extra(&d.join("plain.json")).unwrap();
    assert!(none.names.is_empty() && none.rows.is_empty());

    let h = "x0,y0,x1,y1,w,d,alpha,z_mm\n";
    expect_csv_err(
        "extrashort",
        &format!("{h}0,0,1,1,0.1,0.1,0.5\n"),
        &["data row 1", "7 columns", "expected 8", "z_mm"],
    );
    expect_csv_err(
        "extranan",
        &format!("{h}0,0,1,1,0.1,0.1,0.5,nan\n"),
        &["data row 1", "column z_mm", "not a finite"],
    );
    expect_csv_err(
        "noheader",
        "0,0,1,1,0.1,0.1,0.5,0.02\n",
        &["8 columns", "need a header"],
    );
    expect_csv_err(
        "dupname",
        "x0,y0,x1,y1,w,d,alpha,z_mm,z_mm\n0,0,1,1,0.1,0.1,0.5,0.02,0.03\n",
        &["header", "z_mm"],
    );
}

/// `plate.shape` (engine/docs/model.md section 10): a cylinder reads with its defaults, round-trips
/// exactly, and a wrong shape is refused naming the field and what to write.
#[test]
fn plate_shape_reads_round_trips_and_refuses_what_is_wrong() {
    use scratchart_model::surface::{BendAxis, PlateShape};
    let mut v = base();
    v["plate"]["shape"] = json!({"kind": "cylinder", "radius_mm": 80.0});
    let (s, _) = load_value("shape_ok", &v, None);
    let s = s.unwrap();
    assert_eq!(
        s.plate.shape,
        PlateShape::Cylinder {
            radius_mm: 80.0,
            axis: BendAxis::Y,
            convex: true
        }
    );
    let mut bent = s.clone();
    bent.plate.shape = PlateShape::Cylinder {
        radius_mm: 61.5,
        axis: BendAxis::X,
        convex: false,
    };
    let back = Scene::from_json_str(&bent.to_json_inline(), Path::new("/nonexistent"), "inline").unwrap();
    assert_eq!(back, bent);
    // Flat stays as MODEL.md writes it: no shape key.
    let mut flat = s.clone();
    flat.plate.shape = PlateShape::Flat;
    assert!(!flat.to_json_inline().contains("shape"));
    v["plate"]["shape"] = json!({"kind": "flat"});
    assert_eq!(
        load_value("shape_flat", &v, None).0.unwrap().plate.shape,
        PlateShape::Flat
    );
    for (shape, words) in [
        (
            json!({"kind": "cone", "radius_mm": 80.0}),
            ["plate.shape.kind", "cylinder"],
        ),
        (json!({"kind": "cylinder"}), ["radius_mm", "required"]),
        (
            json!({"kind": "cylinder", "radius_mm": 80.0, "axis": "z"}),
            ["plate.shape.axis", "\"x\" or \"y\""],
        ),
        (
            json!({"kind": "cylinder", "radius_mm": 80.0, "convex": "yes"}),
            ["convex", "true or false"],
        ),
        (
            json!({"kind": "cylinder", "radius_mm": 10.0}),
            ["radius_mm", "at least 19.1"],
        ),
        (
            json!({"kind": "cylinder", "radius_mm": -80.0}),
            ["radius_mm", "too small"],
        ),
        (json!("cylinder"), ["plate.shape", "must be an object"]),
    ] {
        v["plate"]["shape"] = shape.clone();
        let msg = load_value("shape_bad", &v, None).0.unwrap_err();
        for w in words {
            assert!(msg.contains(w), "{shape}: `{w}` not in: {msg}");
        }
    }
    // A misspelt key warns with the closest one.
    v["plate"]["shape"] = json!({"kind": "cylinder", "radius_mm": 80.0, "convx": false});
    let w = scratchart_model::scene_file::unknown_key_warnings(&v, "s.json");
    assert!(w.iter().any(|m| m.contains("convx") && m.contains("`convex`")), "{w:?}");
}
