//! What a maker needs beside the plate: where the lamp and each viewer go (`setup.txt`,
//! `setup.png`, `summary.json` under `setup`), and how precisely they must stand: every view
//! rendered with the lamp, then the eye, moved by +-2 and +-5 degrees in azimuth and elevation
//! and by +-10% in distance, and its correlation with its picture (`sensitivity`).
//!
//! Angles: azimuth is measured in the plate's plane from +x towards +y, elevation above the plate;
//! distances from the plate centre, in mm. The plate's +x edge carries the orientation mark.
use std::path::Path;

use serde_json::{json, Value};

use super::error::OptimError;
use super::measure::{blur3, correlation};
use crate::model::scene::{LightKind, Scene, View};
use crate::render::Renderer;

/// A point as a maker measures it from the plate centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Place {
    pub xyz: [f64; 3],
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub distance_mm: f64,
}

impl Place {
    pub fn of(p: [f64; 3]) -> Place {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        Place {
            xyz: p,
            azimuth_deg: p[1].atan2(p[0]).to_degrees(),
            elevation_deg: p[2].atan2(p[0].hypot(p[1])).to_degrees(),
            distance_mm: r,
        }
    }

    /// The point at these spherical coordinates.
    pub fn at(azimuth_deg: f64, elevation_deg: f64, distance_mm: f64) -> [f64; 3] {
        crate::model::camera::spherical(distance_mm, azimuth_deg, elevation_deg)
    }
}

/// One row of the sensitivity table.
#[derive(Clone, Debug, PartialEq)]
pub struct Moved {
    pub view: String,
    /// "light" or "eye"
    pub moved: &'static str,
    /// "azimuth", "elevation" or "distance"
    pub axis: &'static str,
    /// degrees, or a fraction of the distance
    pub delta: f64,
    pub corr: f64,
}

const ANGLES: [f64; 4] = [-5.0, -2.0, 2.0, 5.0];
const DISTANCES: [f64; 2] = [-0.1, 0.1];

/// `p` moved along `axis` by `delta` on the sphere about the plate centre.
fn moved(p: [f64; 3], axis: &str, delta: f64) -> [f64; 3] {
    let q = Place::of(p);
    match axis {
        "azimuth" => Place::at(q.azimuth_deg + delta, q.elevation_deg, q.distance_mm),
        "elevation" => Place::at(q.azimuth_deg, (q.elevation_deg + delta).min(89.9), q.distance_mm),
        _ => Place::at(q.azimuth_deg, q.elevation_deg, q.distance_mm * (1.0 + delta)),
    }
}

/// The variants of view `v` (light, then eye; each axis and delta), for one batched render.
fn variants(v: &View) -> Vec<(&'static str, &'static str, f64, View)> {
    let mut out = Vec::new();
    for moved_what in ["light", "eye"] {
        for axis in ["azimuth", "elevation", "distance"] {
            let deltas: &[f64] = if axis == "distance" { &DISTANCES } else { &ANGLES };
            for &d in deltas {
                let mut w = v.clone();
                w.name = format!("{}~{moved_what}~{axis}~{d}", v.name);
                if moved_what == "light" {
                    w.light.kind = match w.light.kind {
                        LightKind::Point { position } => LightKind::Point {
                            position: moved(position, axis, d),
                        },
                        // A directional light has no distance; its direction moves in angle.
                        LightKind::Directional { direction } => LightKind::Directional {
                            direction: if axis == "distance" {
                                direction
                            } else {
                                moved(direction, axis, d)
                            },
                        },
                    };
                } else {
                    // The eye moves; the camera keeps looking at the same plate point.
                    w.camera.eye = moved(w.camera.eye, axis, d);
                }
                out.push((moved_what, axis, d, w));
            }
        }
    }
    out
}

/// Correlations of every view with its picture as designed and with the lamp or the eye moved
/// (one batched render). Returns (correlation as designed per view, the moved rows).
pub fn sensitivity(
    renderer: &Renderer,
    scene: &Scene,
    targets: &[Vec<f32>],
    pictures: &[Vec<bool>],
    sigma: f32,
) -> Result<(Vec<f64>, Vec<Moved>), OptimError> {
    let mut batch = scene.clone();
    batch.views.clear();
    let mut rows = Vec::new();
    for (j, v) in scene.views.iter().enumerate() {
        batch.views.push(v.clone());
        for (what, axis, d, w) in variants(v) {
            rows.push((j, what, axis, d, batch.views.len()));
            batch.views.push(w);
        }
    }
    let mut gs = renderer.upload(&batch)?;
    let images = renderer.render(&mut gs)?.images;
    let corr_of = |img: &[f32], j: usize| {
        let (w, h) = (scene.views[j].camera.width, scene.views[j].camera.height);
        let disp: Vec<f32> = img
            .iter()
            .map(|&l| crate::io::display_value(l).clamp(0.0, 1.0))
            .collect();
        let t: Vec<f64> = targets[j].iter().map(|&x| x as f64).collect();
        correlation(&blur3(&disp, w, h, sigma), &t, &pictures[j])
    };
    let mut base = Vec::new();
    let mut first = 0;
    for j in 0..scene.views.len() {
        base.push(corr_of(&images[first], j));
        first += 1 + variants(&scene.views[j]).len();
    }
    let moved_rows = rows
        .into_iter()
        .map(|(j, what, axis, d, idx)| Moved {
            view: scene.views[j].name.clone(),
            moved: what,
            axis,
            delta: d,
            corr: corr_of(&images[idx], j),
        })
        .collect();
    Ok((base, moved_rows))
}

/// The largest tested move along (moved, axis) that keeps 90% of the correlation in both
/// directions, for view `view`; 0 when even the smallest does not.
fn tolerance(rows: &[Moved], view: &str, moved: &str, axis: &str, base: f64) -> f64 {
    let mut ok = 0.0f64;
    let deltas: Vec<f64> = rows
        .iter()
        .filter(|r| r.view == view && r.moved == moved && r.axis == axis)
        .map(|r| r.delta.abs())
        .collect();
    let mut sizes: Vec<f64> = deltas.clone();
    sizes.sort_by(|a, b| a.total_cmp(b));
    sizes.dedup();
    for s in sizes {
        let both = rows
            .iter()
            .filter(|r| r.view == view && r.moved == moved && r.axis == axis && (r.delta.abs() - s).abs() < 1e-12)
            .all(|r| r.corr >= 0.9 * base);
        if both {
            ok = s;
        } else {
            break;
        }
    }
    ok
}

/// Below this correlation with its picture a view does not show its picture yet, and how far
/// the lamp may move "to keep 90% of it" says nothing useful (90% of about nothing).
pub const ADVICE_MIN_CORR: f64 = 0.3;

/// One sentence per view: how precisely the lamp must stand to keep 90% of the correlation.
pub fn advice(scene: &Scene, base: &[f64], rows: &[Moved], blank: &[bool]) -> Vec<String> {
    scene
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
            let t = |axis: &str| tolerance(rows, &v.name, "light", axis, base[j]);
            advice_sentence(&v.name, base[j], [t("azimuth"), t("elevation"), t("distance")])
        })
        .collect()
}

/// The sentence for one view with correlation `base` and lamp tolerances (azimuth and elevation
/// in degrees, distance as a fraction; 0 when even the smallest tested move loses 10%).
pub fn advice_sentence(name: &str, base: f64, tol: [f64; 3]) -> String {
    if !(base >= ADVICE_MIN_CORR) {
        return format!(
            "{name}: does not show its picture yet (correlation {base:.2}), so lamp tolerances are not meaningful for it."
        );
    }
    let say = |x: f64, unit: &str, smallest: &str| {
        if x > 0.0 {
            format!("within {x}{unit}")
        } else {
            format!("within less than {smallest}")
        }
    };
    format!(
        "{name}: to keep 90% of its correlation ({base:.2}), the lamp must stand {} in azimuth, {} in elevation and {} in distance.",
        say(tol[0], " degrees", "2 degrees"),
        say(tol[1], " degrees", "2 degrees"),
        say(100.0 * tol[2], "%", "10%")
    )
}

/// `summary.json`'s `setup`: the light and every eye in the plate's frame, and the mark.
pub fn setup_json(scene: &Scene) -> Value {
    let place = |kind: &LightKind| match kind {
        LightKind::Point { position } => json!({"position_mm": position}),
        LightKind::Directional { direction } => json!({"direction": direction}),
    };
    // Every lamp the sheet lists (`Scene::lamps`, as setup.txt and the viewer's overlay do).
    let lamps: Vec<Value> = scene
        .lamps()
        .into_iter()
        .map(|(name, kind, intensity)| {
            let mut o = place(&kind);
            o["for_view"] = json!(name);
            o["intensity"] = json!(intensity);
            o
        })
        .collect();
    json!({
        "light": place(&scene.views[0].light.kind),
        "lamps": lamps,
        "views": scene.views.iter().map(|v| json!({"name": v.name, "eye_mm": v.camera.eye})).collect::<Vec<_>>(),
        "mark": "+x",
    })
}

/// `summary.json`'s `sensitivity` rows.
pub fn sensitivity_json(rows: &[Moved]) -> Value {
    Value::Array(
        rows.iter()
            .map(|r| json!({"view": r.view, "moved": r.moved, "axis": r.axis, "delta": r.delta, "corr": r.corr}))
            .collect(),
    )
}

/// The set-up sheet as text: the plate's orientation, the lamp, each viewer, what kind of lamp,
/// the sensitivity table and the advice.
pub fn setup_text(scene: &Scene, base: &[f64], rows: &[Moved], blank: &[bool]) -> String {
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
        "Plate: flat, scratched face up. Its +x edge carries the orientation mark; azimuths are measured"
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
    for (name, kind, _) in &lights {
        let head = if lights.len() == 1 {
            "Lamp".to_string()
        } else {
            format!("Lamp for {name}")
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
        "How precisely things must stand: correlation of each view with its picture when moved"
    );
    let _ = writeln!(
        t,
        "{:<8} {:<6} {:<10} {:>8} {:>8}",
        "view", "moved", "axis", "delta", "corr"
    );
    for (j, v) in scene.views.iter().enumerate() {
        let _ = writeln!(t, "{:<8} {:<6} {:<10} {:>8} {:>8.3}", v.name, "-", "-", "0", base[j]);
        for r in rows.iter().filter(|r| r.view == v.name) {
            let d = if r.axis == "distance" {
                format!("{:+.0}%", 100.0 * r.delta)
            } else {
                format!("{:+}deg", r.delta)
            };
            let _ = writeln!(
                t,
                "{:<8} {:<6} {:<10} {:>8} {:>8.3}",
                r.view, r.moved, r.axis, d, r.corr
            );
        }
    }
    let _ = writeln!(t);
    for s in advice(scene, base, rows, blank) {
        let _ = writeln!(t, "{s}");
    }
    t
}

/// The set-up sheet as a picture: the plate from above with its mark, the lamp and the eyes (at
/// their azimuths, elevation written beside them), and the sensitivity of each view to the lamp's
/// azimuth and elevation.
pub fn setup_png(path: &Path, scene: &Scene, base: &[f64], rows: &[Moved]) -> Result<(), OptimError> {
    use plotters::prelude::*;
    let (wpx, hpx) = (960u32, 480u32);
    let mut buf = vec![0u8; (wpx * hpx * 3) as usize];
    let pe = |e: DrawingAreaErrorKind<_>| OptimError::Report(format!("set-up sheet: {e}"));
    // The built-in font (report::plot_font); were it unusable, the sheet has no text and
    // setup.txt has every number.
    let text = super::report::plot_font().is_some();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (wpx, hpx)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let (left, right) = root.split_horizontally(480);
        // Top view: the plate square, the +x mark, the lamp and the eyes by azimuth.
        let r = 200.0;
        let c = (240i32, 240i32);
        let half = 70i32;
        left.draw(&Rectangle::new(
            [(c.0 - half, c.1 - half), (c.0 + half, c.1 + half)],
            BLACK.stroke_width(2),
        ))
        .map_err(pe)?;
        left.draw(&Rectangle::new(
            [(c.0 + half - 4, c.1 - 10), (c.0 + half + 4, c.1 + 10)],
            RED.filled(),
        ))
        .map_err(pe)?;
        let font = ("sans-serif", 14).into_font();
        let label = |txt: String, at: (i32, i32), color: &RGBColor| Text::new(txt, at, font.clone().color(color));
        left.draw(&label("+x mark".into(), (c.0 + half + 6, c.1 - 6), &RED))
            .map_err(pe)?;
        let place = |p: [f64; 3]| {
            let q = Place::of(p);
            let a = q.azimuth_deg.to_radians();
            ((c.0 as f64 + r * a.cos()) as i32, (c.1 as f64 - r * a.sin()) as i32, q)
        };
        let lp = match scene.views[0].light.kind {
            LightKind::Point { position } => position,
            LightKind::Directional { direction } => direction,
        };
        let (x, y, q) = place(lp);
        left.draw(&Circle::new((x, y), 8, RGBColor(230, 160, 0).filled()))
            .map_err(pe)?;
        left.draw(&label(
            format!("lamp {:.0} deg up", q.elevation_deg),
            (x - 40, y + 10),
            &RGBColor(160, 100, 0),
        ))
        .map_err(pe)?;
        for v in &scene.views {
            let (x, y, q) = place(v.camera.eye);
            left.draw(&Circle::new((x, y), 6, BLUE.filled())).map_err(pe)?;
            left.draw(&label(
                format!("{} {:.0} deg up", v.name, q.elevation_deg),
                (x - 30, y + 8),
                &BLUE,
            ))
            .map_err(pe)?;
        }
        left.draw(&label("top view (azimuth from +x towards +y)".into(), (10, 10), &BLACK))
            .map_err(pe)?;
        // Sensitivity: correlation against the lamp's azimuth and elevation moves.
        let mut builder = ChartBuilder::on(&right);
        builder.margin(12);
        if text {
            builder.caption("correlation with the lamp moved", ("sans-serif", 16));
            builder.x_label_area_size(30).y_label_area_size(40);
        }
        let mut chart = builder.build_cartesian_2d(-5.5f64..5.5f64, 0f64..1f64).map_err(pe)?;
        if text {
            chart
                .configure_mesh()
                .x_desc("lamp moved (degrees; solid: azimuth, dashed: elevation)")
                .y_desc("correlation")
                .draw()
                .map_err(pe)?;
        }
        let colors = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
        for (j, v) in scene.views.iter().enumerate() {
            let col = colors[j % colors.len()];
            for (axis, dashed) in [("azimuth", false), ("elevation", true)] {
                let mut pts: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| r.view == v.name && r.moved == "light" && r.axis == axis)
                    .map(|r| (r.delta, r.corr))
                    .chain(std::iter::once((0.0, base[j])))
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                let style = col.stroke_width(if dashed { 1 } else { 2 });
                let s = chart.draw_series(LineSeries::new(pts, style)).map_err(pe)?;
                if !dashed {
                    s.label(v.name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], col));
                }
            }
        }
        if text {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(pe)?;
        }
        root.present().map_err(pe)?;
    }
    super::report::write_rgb_png(path, wpx, hpx, buf)
}

/// Writes `setup.txt` and `setup.png` into `out` and returns the `setup` and `sensitivity`
/// values for `summary.json`; `blank_views` are left blank on purpose (no tolerances for them).
pub fn write_setup(
    out: &Path,
    renderer: &Renderer,
    scene: &Scene,
    targets: &[Vec<f32>],
    pictures: &[Vec<bool>],
    sigma: f32,
    blank_views: &[String],
) -> Result<(Value, Value, Vec<String>), OptimError> {
    let (base, rows) = sensitivity(renderer, scene, targets, pictures, sigma)?;
    let blank: Vec<bool> = scene.views.iter().map(|v| blank_views.contains(&v.name)).collect();
    crate::io::write_atomic(
        &out.join("setup.txt"),
        setup_text(scene, &base, &rows, &blank).as_bytes(),
    )?;
    setup_png(&out.join("setup.png"), scene, &base, &rows)?;
    Ok((
        setup_json(scene),
        sensitivity_json(&rows),
        advice(scene, &base, &rows, &blank),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_lists_the_lamps_the_sheet_lists() {
        use crate::model::scene::{Camera, Light, Plate, View};
        let view = |name: &str, kind: LightKind, intensity: f64| View {
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
        for (got, (name, _, intensity)) in l.iter().zip(&want) {
            assert_eq!(got["for_view"], json!(name));
            assert_eq!(got["intensity"], json!(intensity));
        }
        assert_eq!(l[1]["position_mm"], json!([30.0, 100.0, 200.0]));
        assert_eq!(l[2]["direction"], json!([0.0, 1.0, 1.0]));
        // Every lamp the text names, the summary lists.
        let text = setup_text(&scene, &[0.9; 4], &[], &[false; 4]);
        assert_eq!(text.matches("Lamp for ").count(), l.len(), "{text}");
    }

    #[test]
    fn advice_gives_tolerances_for_a_view_that_shows_its_picture() {
        let s = advice_sentence("v0", 0.93, [5.0, 2.0, 0.1]);
        assert_eq!(
            s,
            "v0: to keep 90% of its correlation (0.93), the lamp must stand within 5 degrees in azimuth, \
             within 2 degrees in elevation and within 10% in distance."
        );
        let s = advice_sentence("v1", 0.5, [0.0, 0.0, 0.0]);
        assert!(s.contains("within less than 2 degrees in azimuth"), "{s}");
        assert!(s.contains("within less than 10% in distance"), "{s}");
    }

    #[test]
    fn advice_says_a_view_near_zero_or_negative_does_not_show_its_picture() {
        for (base, shown) in [(-0.02, "-0.02"), (0.0, "0.00"), (0.29, "0.29"), (f64::NAN, "NaN")] {
            let s = advice_sentence("v2", base, [5.0, 5.0, 0.1]);
            assert!(s.starts_with("v2: does not show its picture yet"), "{s}");
            assert!(s.contains(&format!("(correlation {shown})")), "{s}");
            assert!(s.contains("not meaningful"), "{s}");
            assert!(!s.contains("keep 90%"), "{s}");
        }
        assert!(advice_sentence("v2", ADVICE_MIN_CORR, [5.0, 5.0, 0.1]).contains("keep 90%"));
    }
}
