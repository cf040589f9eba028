//! What a maker needs beside the plate: where the lamp and each viewer go (`setup.txt`,
//! `setup.png`, `summary.json` under `setup`), and how far the lamp and each eye may move (the
//! search is [`crate::tolerance`], the drawing [`crate::setup_sheet`]). Its inputs
//! ([`SheetInputs`]) are written beside the design, so `design` and `setup` give one sheet.
//!
//! Angles: azimuth is measured in the plate's plane from +x towards +y, elevation above the plate;
//! distances from the plate centre, in mm. The plate's +x edge carries the orientation mark.
use std::path::Path;

use serde_json::{json, Value};

use scratchart_model::scene::{LightKind, Scene};
use scratchart_optim::error::OptimError;
use scratchart_render::Renderer;

use crate::tolerance::{
    sensitivity, Place, Sensitivity, SheetInputs, Tolerance, ADVICE_MIN_CORR, ANGLE_RANGE, DISTANCE_RANGE, KEEP,
};

/// One sentence per view: how far the lamp and the eye may move and keep 90% of its correlation;
/// then the tightest of all.
pub fn advice(scene: &Scene, sens: &Sensitivity, blank: &[bool]) -> Vec<String> {
    let mut out: Vec<String> = scene
        .views
        .iter()
        .enumerate()
        .map(|(j, v)| {
            if blank.get(j).copied().unwrap_or(false) {
                return format!(
                    "{}: blank on purpose (a uniform picture, --blank-view): it has no picture to keep, so no tolerances.",
                    v.name
                );
            }
            let tols: Vec<&Tolerance> = sens.of(&v.name).collect();
            advice_sentence(&v.name, sens.base[j], &tols)
        })
        .collect();
    if let Some(t) = sens.most_sensitive() {
        out.push(format!(
            "Most sensitive: {}'s {} {} (it may move {}, of the {} searched): set it first and most carefully.",
            t.view,
            t.moved,
            t.axis,
            t.phrase(),
            if t.axis == "distance" {
                format!("+-{:.0}%", 100.0 * DISTANCE_RANGE)
            } else {
                format!("+-{ANGLE_RANGE:.0} deg")
            }
        ));
    }
    out
}

/// The sentence for one view with correlation `base` and its tolerances.
pub fn advice_sentence(name: &str, base: f64, tols: &[&Tolerance]) -> String {
    if !(base >= ADVICE_MIN_CORR) {
        return format!(
            "{name}: does not show its picture yet (correlation {base:.2}), so lamp and eye tolerances are not meaningful for it."
        );
    }
    let part = |moved: &str| {
        let items: Vec<String> = tols
            .iter()
            .filter(|t| t.moved == moved)
            .map(|t| format!("{} in {}", t.phrase(), t.axis))
            .collect();
        match items.len() {
            0 => String::new(),
            1 => format!("the {moved} may move {}", items[0]),
            n => format!(
                "the {moved} may move {} and {}",
                items[..n - 1].join(", "),
                items[n - 1]
            ),
        }
    };
    format!(
        "{name}: to keep 90% of its correlation ({base:.2}), {}; {}.",
        part("lamp"),
        part("eye")
    )
}

/// `summary.json`'s `setup`: the light and every eye in the plate's frame, and the mark.
pub fn setup_json(scene: &Scene) -> Value {
    let place = |kind: &LightKind| match kind {
        LightKind::Point { position } => json!({"position_mm": position}),
        LightKind::Directional { direction } => json!({"direction": direction}),
    };
    // Every lamp the sheet lists (`Scene::lamps`, as setup.txt and the viewer's overlay do),
    // with the views it lights and how bright each looks under it (its exposure).
    let rel = scene.relative_brightness();
    let lamps: Vec<Value> = scene
        .lamps()
        .into_iter()
        .map(|l| {
            let mut o = place(&l.kind);
            o["for_view"] = json!(l.name);
            o["intensity"] = json!(l.intensity);
            o["views"] = json!(l.views.iter().map(|&j| scene.views[j].name.clone()).collect::<Vec<_>>());
            o["brightness"] = json!(l
                .views
                .iter()
                .map(|&j| json!({"view": scene.views[j].name, "relative": rel[j], "stops": rel[j].log2(), "exposure": scene.views[j].exposure}))
                .collect::<Vec<_>>());
            o
        })
        .collect();
    json!({
        "light": place(&scene.views[0].light.kind),
        "lamps": lamps,
        "views": scene.views.iter().map(|v| json!({"name": v.name, "eye_mm": v.camera.eye, "exposure": v.exposure})).collect::<Vec<_>>(),
        "mark": "+x",
    })
}

/// What the lamp's views look like under it, for the sheet: one line, or none when they all look
/// equally bright (within 1%).
pub fn brightness_line(scene: &Scene, lamp: &scratchart_model::scene::Lamp) -> Option<String> {
    let rel = scene.relative_brightness();
    if lamp.views.len() < 2 || lamp.views.iter().all(|&j| rel[j] > 0.99) {
        return None;
    }
    let parts: Vec<String> = lamp
        .views
        .iter()
        .map(|&j| {
            let r = rel[j];
            if r > 0.99 {
                format!("{} 1.00", scene.views[j].name)
            } else {
                format!("{} {r:.2} ({:.1} stops darker)", scene.views[j].name, -r.log2())
            }
        })
        .collect();
    Some(format!(
        "  Under it the views look: {}. These are the design's exposures: an eye adapts to such \
         differences as it moves between the views, a camera needs that much more exposure; \
         `design --exposure fixed` (the default) makes a plate whose views look as rendered under one lamp.",
        parts.join(", ")
    ))
}

/// `summary.json`'s `sensitivity`: each view's correlation as designed, the tolerances found
/// (and the tightest), and every render of the search.
pub fn sensitivity_json(scene: &Scene, sens: &Sensitivity) -> Value {
    json!({
        "keep": KEEP,
        "range": {"angle_deg": ANGLE_RANGE, "distance_fraction": DISTANCE_RANGE},
        "corr": scene.views.iter().zip(&sens.base).map(|(v, c)| json!({"view": v.name, "corr": c})).collect::<Vec<_>>(),
        "tolerances": sens.tolerances.iter().map(Tolerance::to_json).collect::<Vec<_>>(),
        "most_sensitive": sens.most_sensitive().map(Tolerance::to_json),
        "samples": sens.samples.iter()
            .map(|r| json!({"view": r.view, "moved": r.moved, "axis": r.axis, "delta": r.delta, "corr": r.corr}))
            .collect::<Vec<_>>(),
    })
}

/// Eyes within this angle of a lamp, seen from the plate centre, get the torch advice.
pub const NEAR_EYE_DEG: f64 = 5.0;

/// The angle between two points seen from the plate centre (a directional light by its
/// direction), degrees.
fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let n = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    (dot / (n(a) * n(b))).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The set-up sheet as text: the plate's orientation, the lamp, each viewer, what kind of lamp,
/// the sensitivity table and the advice.
pub fn setup_text(scene: &Scene, sens: &Sensitivity, blank: &[bool]) -> String {
    use std::fmt::Write as _;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "Set-up sheet: {} mm plate, {} view(s)",
        scene.plate.size_mm,
        scene.views.len()
    );
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "Plate: {}, scratched face up. Its +x edge carries the orientation mark; azimuths are measured",
        if scene.plate.shape.is_flat() {
            "flat"
        } else {
            "bent (see Bending below)"
        }
    );
    let _ = writeln!(
        t,
        "from +x towards +y, elevations above the plate, distances from the plate centre."
    );
    let v0 = Place::of(scene.views[0].camera.eye);
    let edge = match ((v0.azimuth_deg + 360.0 + 45.0) % 360.0 / 90.0) as u32 {
        0 => "+x",
        1 => "+y",
        2 => "-x",
        _ => "-y",
    };
    let _ = writeln!(t, "The {edge} edge faces the first viewer ({}).", scene.views[0].name);
    let _ = writeln!(t);
    let lights = scene.lamps();
    for lamp in &lights {
        let kind = &lamp.kind;
        let names: Vec<&str> = lamp.views.iter().map(|&j| scene.views[j].name.as_str()).collect();
        let head = if lights.len() == 1 {
            "Lamp".to_string()
        } else {
            format!("Lamp for {}", names.join(", "))
        };
        match kind {
            LightKind::Point { position } => {
                let p = Place::of(*position);
                let _ = writeln!(
                    t,
                    "{head}: azimuth {:.1} deg, elevation {:.1} deg, {:.0} mm from the plate centre (x {:.1}, y {:.1}, z {:.1} mm).",
                    p.azimuth_deg, p.elevation_deg, p.distance_mm, p.xyz[0], p.xyz[1], p.xyz[2]
                );
                let _ = writeln!(
                    t,
                    "  A small, bright LED (a point light) at that distance: a larger lamp blurs the picture."
                );
            }
            LightKind::Directional { direction } => {
                let p = Place::of(*direction);
                let _ = writeln!(
                    t,
                    "{head}: from azimuth {:.1} deg, elevation {:.1} deg (a direction, x {:.3}, y {:.3}, z {:.3}).",
                    p.azimuth_deg, p.elevation_deg, p.xyz[0], p.xyz[1], p.xyz[2]
                );
                let _ = writeln!(t, "  A distant lamp or the sun at that elevation (parallel light).");
            }
        }
        if let Some(line) = brightness_line(scene, lamp) {
            let _ = writeln!(t, "{line}");
        }
        // A lamp (nearly) in a viewer's eye: how a person does that.
        let at = match kind {
            LightKind::Point { position } => *position,
            LightKind::Directional { direction } => *direction,
        };
        for v in &scene.views {
            let a = angle_between(at, v.camera.eye);
            if a <= NEAR_EYE_DEG {
                let _ = writeln!(
                    t,
                    "  It stands {a:.1} deg from viewer {}'s eye, seen from the plate: hold a small torch right beside that eye \
                     (against the temple), pointed at the plate, or place the lamp and look past its side.",
                    v.name
                );
            }
        }
    }
    let _ = writeln!(t);
    for v in &scene.views {
        let p = Place::of(v.camera.eye);
        let _ = writeln!(
            t,
            "Viewer {}: eye at azimuth {:.1} deg, elevation {:.1} deg, {:.0} mm (x {:.1}, y {:.1}, z {:.1} mm), looking at ({:.1}, {:.1}) on the plate.",
            v.name, p.azimuth_deg, p.elevation_deg, p.distance_mm, p.xyz[0], p.xyz[1], p.xyz[2], v.camera.target[0], v.camera.target[1]
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "How far each may move and keep {:.0}% of the view's correlation with its picture (found by",
        100.0 * KEEP
    );
    let _ = writeln!(
        t,
        "search, both ways, up to {ANGLE_RANGE:.0} deg and {:.0}% of the distance; the smaller way is given):",
        100.0 * DISTANCE_RANGE
    );
    let cols = [
        ("lamp", "azimuth"),
        ("lamp", "elevation"),
        ("lamp", "distance"),
        ("eye", "azimuth"),
        ("eye", "elevation"),
        ("eye", "distance"),
    ];
    let _ = write!(t, "{:<8} {:>6}", "view", "corr");
    for (m, a) in cols {
        let _ = write!(t, " {:>16}", format!("{m} {a}"));
    }
    let _ = writeln!(t);
    for (j, v) in scene.views.iter().enumerate() {
        let _ = write!(t, "{:<8} {:>6.3}", v.name, sens.base[j]);
        for (m, a) in cols {
            let cell = sens
                .of(&v.name)
                .find(|x| x.moved == m && x.axis == a)
                .map_or_else(|| "-".to_string(), |x| x.phrase().replace("up to ", ""));
            let _ = write!(t, " {cell:>16}");
        }
        let _ = writeln!(t);
    }
    let _ = writeln!(t);
    for s in advice(scene, sens, blank) {
        let _ = writeln!(t, "{s}");
    }
    t
}

/// Writes `setup.txt` and `setup.png` into `out` and returns the `setup` and `sensitivity`
/// values for `summary.json` and the advice; the inputs' blank views get no tolerances.
pub fn write_setup(
    out: &Path,
    renderer: &Renderer,
    scene: &Scene,
    inputs: &SheetInputs,
) -> Result<(Value, Value, Vec<String>, crate::problem::SheetWall), OptimError> {
    let t0 = std::time::Instant::now();
    let sens = sensitivity(renderer, scene, inputs)?;
    let searches = t0.elapsed().as_secs_f64();
    let blank: Vec<bool> = scene
        .views
        .iter()
        .map(|v| inputs.blank_views.contains(&v.name))
        .collect();
    // A bent plate: how to bend it, its template, and how exact the radius must be.
    let bend = crate::bend::radius_tolerance(renderer, scene, inputs)?;
    let mut text = setup_text(scene, &sens, &blank);
    let at = text
        .find("faces the first viewer")
        .and_then(|k| text[k..].find("\n\n").map(|e| k + e + 2))
        .unwrap_or(text.len());
    text.insert_str(at, &crate::bend::bend_text(scene, &sens.base, &bend));
    scratchart_render::io::write_atomic(&out.join("setup.txt"), text.as_bytes())?;
    crate::bend::write_template(&out.join("bend_template.svg"), scene)?;
    let t_png = std::time::Instant::now();
    crate::setup_sheet::setup_png(&out.join("setup.png"), scene, &sens)?;
    let png = t_png.elapsed().as_secs_f64();
    let mut setup = setup_json(scene);
    // (Only for a bent plate: a flat plate's set-up is what the viewer prints, unchanged.)
    if !scene.plate.shape.is_flat() {
        setup["bend"] = crate::bend::bend_json(scene, &sens.base, &bend);
    }
    let wall = crate::problem::SheetWall {
        searches,
        search_steps: sens.steps,
        png,
        clock: sens.clock,
    };
    Ok((
        setup,
        sensitivity_json(scene, &sens),
        advice(scene, &sens, &blank),
        wall,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_lists_the_lamps_the_sheet_lists() {
        use scratchart_model::scene::{Camera, Light, Plate, View};
        let view = |name: &str, kind: LightKind, intensity: f64| View {
            exposure: 1.0,
            name: name.into(),
            camera: Camera {
                eye: [0.0, -200.0, 200.0],
                target: [0.0; 3],
                up: [0.0, 0.0, 1.0],
                fov_y_deg: 30.0,
                width: 8,
                height: 8,
            },
            light: Light { kind, intensity },
        };
        let at = |x: f64| LightKind::Point {
            position: [x, 100.0, 200.0],
        };
        let scene = Scene {
            plate: Plate {
                size_mm: 50.0,
                roughness: 0.02,
                f0: 0.9,
                shape: Default::default(),
            },
            views: vec![
                view("a", at(10.0), 1.0e6),
                view("b", at(30.0), 2.0e5),
                view("c", at(10.0), 1.0e6),
                view(
                    "d",
                    LightKind::Directional {
                        direction: [0.0, 1.0, 1.0],
                    },
                    3.0,
                ),
            ],
            scratches: vec![],
        };
        let j = setup_json(&scene);
        let l = j["lamps"].as_array().unwrap();
        let want = scene.lamps();
        assert_eq!(l.len(), 3, "{l:?}");
        assert_eq!(l.len(), want.len());
        for (got, lamp) in l.iter().zip(&want) {
            assert_eq!(got["for_view"], json!(lamp.name));
            assert_eq!(got["intensity"], json!(lamp.intensity));
        }
        assert_eq!(l[0]["views"], json!(["a", "c"]));
        assert_eq!(l[1]["position_mm"], json!([30.0, 100.0, 200.0]));
        assert_eq!(l[2]["direction"], json!([0.0, 1.0, 1.0]));
        // Every lamp the text names, the summary lists.
        let sens = Sensitivity {
            base: vec![0.9; 4],
            ..Sensitivity::default()
        };
        let text = setup_text(&scene, &sens, &[false; 4]);
        assert_eq!(text.matches("Lamp for ").count(), l.len(), "{text}");
    }

    fn tol(moved: &'static str, axis: &'static str, safe: [f64; 2], lost: [Option<f64>; 2]) -> Tolerance {
        Tolerance {
            view: "v0".into(),
            moved,
            axis,
            safe,
            lost,
        }
    }

    #[test]
    fn tolerances_are_stated_as_found() {
        assert_eq!(
            tol("lamp", "azimuth", [3.5, 6.0], [Some(3.75), Some(6.5)]).phrase(),
            "up to 3.5 deg"
        );
        assert_eq!(
            tol("eye", "elevation", [20.0, 20.0], [None, None]).phrase(),
            "more than 20 deg"
        );
        assert_eq!(
            tol("eye", "distance", [0.5, 0.5], [None, None]).phrase(),
            "more than 50%"
        );
        assert_eq!(
            tol("eye", "distance", [0.12, 0.3], [Some(0.13), Some(0.31)]).phrase(),
            "up to 12%"
        );
        assert_eq!(
            tol("eye", "distance", [0.0, 0.2], [Some(0.01), None]).phrase(),
            "less than 1.0%"
        );
        assert_eq!(
            tol("lamp", "azimuth", [0.0, 0.0], [Some(0.25), Some(0.5)]).phrase(),
            "less than 0.25 deg"
        );
        // one way never lost, the other did: the smaller way is the tolerance
        assert_eq!(
            tol("lamp", "elevation", [20.0, 4.0], [None, Some(4.4)]).phrase(),
            "up to 4.0 deg"
        );
    }

    #[test]
    fn advice_gives_tolerances_for_a_view_that_shows_its_picture() {
        let t = [
            tol("lamp", "azimuth", [5.0, 6.0], [Some(5.5), Some(7.0)]),
            tol("lamp", "elevation", [2.0, 2.0], [Some(2.25), Some(2.25)]),
            tol("eye", "distance", [0.5, 0.5], [None, None]),
        ];
        let refs: Vec<&Tolerance> = t.iter().collect();
        let s = advice_sentence("v0", 0.93, &refs);
        assert_eq!(
            s,
            "v0: to keep 90% of its correlation (0.93), the lamp may move up to 5.0 deg in azimuth and up to 2.0 deg \
             in elevation; the eye may move more than 50% in distance."
        );
    }

    #[test]
    fn advice_says_a_view_near_zero_or_negative_does_not_show_its_picture() {
        for (base, shown) in [(-0.02, "-0.02"), (0.0, "0.00"), (0.29, "0.29"), (f64::NAN, "NaN")] {
            let s = advice_sentence("v2", base, &[]);
            assert!(s.starts_with("v2: does not show its picture yet"), "{s}");
            assert!(s.contains(&format!("(correlation {shown})")), "{s}");
            assert!(s.contains("not meaningful"), "{s}");
            assert!(!s.contains("keep 90%"), "{s}");
        }
        assert!(advice_sentence("v2", ADVICE_MIN_CORR, &[]).contains("keep 90%"));
    }
}
