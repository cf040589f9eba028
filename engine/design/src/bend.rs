//! What a bent plate (engine/docs/model.md section 10) asks of a design beyond the flat plate's:
//! a lamp that keeps the sheet's own mirror glint out of the views.
//!
//! A flat plate's polished finish mirrors the lamp only where its one normal bisects lamp and eye,
//! which the default set-up keeps off the plate. A cylinder has every normal of its arc: for each
//! eye, a line across the sheet where the finish mirrors the lamp, a bright band that no scratch
//! pattern can hide (scratches cover only part of it). Where the lamp stands off the plane of
//! the cylinder's normals seen from each eye, the half vector leaves the arc of normals and the
//! band leaves the sheet. [`glint_free_lamp`] searches the lamp's azimuth for that.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::{json, Value};

use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::{Light, LightKind, Plate, Scene, View};
use scratchart_model::surface::{BendAxis, PlateShape};
use scratchart_optim::error::OptimError;
use scratchart_render::Renderer;

use crate::measure::{blur3, correlation};
use crate::tolerance::SheetInputs;

/// The radius errors the set-up sheet reports (a maker bends by hand): factors on the radius.
pub const RADIUS_ERRORS: [f64; 4] = [0.9, 0.95, 1.05, 1.1];

/// Sheet points per side where the glint is sought.
const GRID: usize = 24;

/// The least angle (degrees) between a view's half vector and the sheet's normal, over the
/// sheet's points that view sees: where it is small, the finish mirrors the lamp there.
pub fn glint_margin_deg(view: &View, plate: &Plate) -> f64 {
    let g = ViewGeom::of(view, plate);
    let half = 0.5 * plate.size_mm;
    let mut least = f64::INFINITY;
    for a in 0..GRID {
        for b in 0..GRID {
            let uv = [
                -half + plate.size_mm * (a as f64 + 0.5) / GRID as f64,
                -half + plate.size_mm * (b as f64 + 0.5) / GRID as f64,
            ];
            let q = plate.shape.at_sheet(uv);
            let (o, i) = (g.omega_o_at(q.p), g.light_at_point(q.p).omega_i);
            let (cos_o, cos_i) = (q.local(o)[2], q.local(i)[2]);
            if cos_o <= 0.0 || cos_i <= 0.0 || g.hidden(&q) || g.shaded(&q) {
                continue;
            }
            let h = q.local([o[0] + i[0], o[1] + i[1], o[2] + i[2]]);
            let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            least = least.min((h[2] / n).clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    least
}

/// The azimuth (degrees) of a world point seen from above the plate's centre.
fn azimuth_deg(p: [f64; 3]) -> f64 {
    p[1].atan2(p[0]).to_degrees()
}

/// The glint's least angle from every view's half vector that keeps it dark: the finish's lobe
/// (alpha_s 0.02, 1.1 degrees) is 400 times below its peak at 5 degrees, and a coarse pixel's
/// footprint spans a few tenths of a degree of normals.
pub const GLINT_MARGIN_DEG: f64 = 8.0;

/// The lamp of `views` (all lit by `light`, a point lamp, at its distance from the plate's
/// centre) moved to the nearest place where the least [`glint_margin_deg`] over the views is at
/// least [`GLINT_MARGIN_DEG`] (else where it is largest): its elevation kept first, then 5, 10, ...
/// degrees lower or higher (15 to 85); at each, its azimuth in 5 degree steps alternately either
/// side, at least 10 degrees from every eye's azimuth (a lamp beside the eye is in the viewer's
/// way). Returns the lamp and its margin; the lamp as it was for a flat plate or a directional
/// light.
pub fn glint_free_lamp(views: &[View], plate: &Plate, light: &Light) -> (Light, f64) {
    let margin = |l: &Light| {
        views
            .iter()
            .map(|v| {
                glint_margin_deg(
                    &View {
                        light: l.clone(),
                        ..v.clone()
                    },
                    plate,
                )
            })
            .fold(f64::INFINITY, f64::min)
    };
    let position = match light.kind {
        LightKind::Point { position } if !plate.shape.is_flat() => position,
        _ => return (light.clone(), margin(light)),
    };
    let dist = (position[0] * position[0] + position[1] * position[1] + position[2] * position[2]).sqrt();
    let az0 = azimuth_deg(position);
    let el0 = (position[2] / dist).clamp(-1.0, 1.0).asin().to_degrees();
    let eyes: Vec<f64> = views.iter().map(|v| azimuth_deg(v.camera.eye)).collect();
    let apart = |a: f64, b: f64| ((a - b).rem_euclid(360.0)).min((b - a).rem_euclid(360.0));
    // Nearest first: 0, +5, -5, +10, ...
    let offset = |k: u32| 5.0 * k.div_ceil(2) as f64 * if k % 2 == 1 { 1.0 } else { -1.0 };
    let mut best: Option<(Light, f64)> = None;
    for ke in 0..36u32 {
        let el = el0 + offset(ke);
        if ke > 0 && !(15.0..=85.0).contains(&el) {
            continue;
        }
        for ka in 0..72u32 {
            let az = az0 + offset(ka);
            if (ka > 0 || ke > 0) && eyes.iter().any(|&e| apart(az, e) < 10.0) {
                continue;
            }
            let l = Light {
                kind: LightKind::Point {
                    position: scratchart_model::camera::spherical(dist, az, el),
                },
                intensity: light.intensity,
            };
            let m = margin(&l);
            if m >= GLINT_MARGIN_DEG {
                return (l, m);
            }
            if best.as_ref().is_none_or(|b| m > b.1) {
                best = Some((l, m));
            }
        }
    }
    best.unwrap_or_else(|| (light.clone(), margin(light)))
}

/// Each view's correlation with its picture (blurred as the sheet's searches blur) when the sheet
/// is bent to each of [`RADIUS_ERRORS`] times its radius: (factor, correlation per view). Empty
/// for a flat plate.
pub fn radius_tolerance(
    renderer: &Renderer,
    scene: &Scene,
    inputs: &SheetInputs,
) -> Result<Vec<(f64, Vec<f64>)>, OptimError> {
    let PlateShape::Cylinder {
        radius_mm,
        axis,
        convex,
    } = scene.plate.shape
    else {
        return Ok(Vec::new());
    };
    let masks: Vec<&[bool]> = inputs.pictures.iter().map(|m| m.as_slice()).collect();
    let mut out = Vec::new();
    for f in RADIUS_ERRORS {
        let mut s = scene.clone();
        s.plate.shape = PlateShape::Cylinder {
            radius_mm: radius_mm * f,
            axis,
            convex,
        };
        let images = crate::tolerance::render_views(renderer, &s, s.views.clone(), &masks)?;
        let corr = images
            .iter()
            .enumerate()
            .map(|(j, img)| {
                let v = &scene.views[j].camera;
                let t: Vec<f64> = inputs.targets[j].iter().map(|&x| x as f64).collect();
                correlation(&blur3(img, v.width, v.height, inputs.sigma), &t, &inputs.pictures[j])
            })
            .collect();
        out.push((f, corr));
    }
    Ok(out)
}

/// The sheet's numbers once bent: the angle it spans (degrees), its chord and its depth
/// (sagitta) across the bend, mm.
fn arc_numbers(size_mm: f64, radius_mm: f64) -> (f64, f64, f64) {
    let half = 0.5 * size_mm / radius_mm;
    (
        (2.0 * half).to_degrees(),
        2.0 * radius_mm * half.sin(),
        radius_mm * (1.0 - half.cos()),
    )
}

/// The set-up sheet's bending section (empty for a flat plate): how to bend the carved sheet,
/// the template, the frame the positions are given in, and how exact the radius must be.
pub fn bend_text(scene: &Scene, base: &[f64], tol: &[(f64, Vec<f64>)]) -> String {
    let PlateShape::Cylinder {
        radius_mm,
        axis,
        convex,
    } = scene.plate.shape
    else {
        return String::new();
    };
    let size = scene.plate.size_mm;
    let (span, chord, depth) = arc_numbers(size, radius_mm);
    let (edges, along) = match axis {
        BendAxis::Y => ("-x and +x", "y"),
        BendAxis::X => ("-y and +y", "x"),
    };
    let mut t = String::new();
    let _ = writeln!(
        t,
        "Bending: carve the sheet flat (the plan cuts it as it lies), then bend it into a cylinder of"
    );
    let _ = writeln!(
        t,
        "  radius {radius_mm:.1} mm about an axis along its {along} axis: its {edges} edges curve {}, the scratched face {}.",
        if convex { "down" } else { "up" },
        if convex { "outside (convex, as round a can)" } else { "inside (concave, as in a bowl)" }
    );
    let _ = writeln!(
        t,
        "  Bend it round a form of radius {radius_mm:.1} mm (a can, a pipe, a printed form): bend_template.svg, printed at 100%,"
    );
    let _ = writeln!(
        t,
        "  is that curve at full size (check its 50 mm bar). The sheet spans {span:.0} deg of the cylinder: its {size:.0} mm side"
    );
    let _ = writeln!(t, "  becomes a chord of {chord:.1} mm, {depth:.1} mm deep.");
    let _ = writeln!(
        t,
        "  Positions below are in the bent sheet's frame: its centre at the origin, its normal there straight up"
    );
    let _ = writeln!(
        t,
        "  (elevation 90 deg), the bend's axis along azimuth {}.",
        if along == "y" { "90 deg (+y)" } else { "0 deg (+x)" }
    );
    if !tol.is_empty() {
        let worst = |c: &[f64]| c.iter().cloned().fold(f64::INFINITY, f64::min);
        let _ = writeln!(
            t,
            "  How exact the bend must be (each view's correlation with its picture; as designed {}):",
            fmt_corr(base)
        );
        for (f, c) in tol {
            let _ = writeln!(
                t,
                "    radius {:+.0}% ({:.1} mm): {} (worst {:.3}, {:+.3} from the design's)",
                100.0 * (f - 1.0),
                radius_mm * f,
                fmt_corr(c),
                worst(c),
                worst(c) - worst(base)
            );
        }
    }
    let _ = writeln!(t);
    t
}

fn fmt_corr(c: &[f64]) -> String {
    c.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>().join(" / ")
}

/// `summary.json`'s `setup.bend` (null for a flat plate).
pub fn bend_json(scene: &Scene, base: &[f64], tol: &[(f64, Vec<f64>)]) -> Value {
    let PlateShape::Cylinder {
        radius_mm,
        axis,
        convex,
    } = scene.plate.shape
    else {
        return Value::Null;
    };
    let (span, chord, depth) = arc_numbers(scene.plate.size_mm, radius_mm);
    json!({
        "radius_mm": radius_mm, "axis": axis.name(), "convex": convex,
        "span_deg": span, "chord_mm": chord, "depth_mm": depth,
        "template": "bend_template.svg",
        "corr_designed": base,
        "radius_error": tol.iter().map(|(f, c)| json!({"factor": f, "radius_mm": radius_mm * f, "corr": c})).collect::<Vec<_>>(),
    })
}

/// `bend_template.svg`: the form's curve at full size (mm units: print at 100%), the sheet's
/// arc on it with its ends marked, the centre, and a 50 mm bar to check the print's scale.
pub fn write_template(path: &Path, scene: &Scene) -> Result<(), OptimError> {
    let PlateShape::Cylinder {
        radius_mm: r, convex, ..
    } = scene.plate.shape
    else {
        return Ok(());
    };
    let half = 0.5 * scene.plate.size_mm / r;
    let m = 10.0; // margin, mm
    let (w, h) = (2.0 * r + 2.0 * m, 2.0 * r + 2.0 * m + 25.0);
    let (cx, cy) = (m + r, m + r);
    // The sheet's arc as it stands, scratched face up: over the top of the form for a convex
    // bend, along the bottom of its inside for a concave one.
    let up = if convex { -1.0 } else { 1.0 };
    let p = |a: f64| (cx + r * a.sin(), cy + up * r * a.cos());
    let sweep = i32::from(convex);
    let (x0, y0) = p(-half);
    let (x1, y1) = p(half);
    let large = if 2.0 * half > std::f64::consts::PI { 1 } else { 0 };
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.1}mm" height="{h:.1}mm" viewBox="0 0 {w:.3} {h:.3}">"#
    );
    let _ = writeln!(
        svg,
        r#"<circle cx="{cx:.3}" cy="{cy:.3}" r="{r:.3}" fill="none" stroke="black" stroke-width="0.3" stroke-dasharray="2 2"/>"#
    );
    let _ = writeln!(
        svg,
        r#"<path d="M {x0:.3} {y0:.3} A {r:.3} {r:.3} 0 {large} {sweep} {x1:.3} {y1:.3}" fill="none" stroke="black" stroke-width="0.8"/>"#
    );
    for (x, y) in [(x0, y0), (x1, y1)] {
        let _ = writeln!(
            svg,
            r#"<line x1="{:.3}" y1="{:.3}" x2="{:.3}" y2="{:.3}" stroke="black" stroke-width="0.5"/>"#,
            x + 4.0 * (x - cx) / r,
            y + 4.0 * (y - cy) / r,
            x - 4.0 * (x - cx) / r,
            y - 4.0 * (y - cy) / r
        );
    }
    let _ = writeln!(
        svg,
        r#"<path d="M {:.3} {cy:.3} H {:.3} M {cx:.3} {:.3} V {:.3}" stroke="black" stroke-width="0.3"/>"#,
        cx - 3.0,
        cx + 3.0,
        cy - 3.0,
        cy + 3.0
    );
    let by = 2.0 * r + 2.0 * m + 8.0;
    let _ = writeln!(
        svg,
        r#"<path d="M {m:.3} {by:.3} h 50 M {m:.3} {:.3} v 4 M {:.3} {:.3} v 4" stroke="black" stroke-width="0.5"/>"#,
        by - 2.0,
        m + 50.0,
        by - 2.0
    );
    let _ = writeln!(
        svg,
        r#"<text x="{m:.3}" y="{:.3}" font-size="3.5" font-family="sans-serif">50 mm. Form radius {r:.1} mm; the thick arc is the {:.0} mm sheet, scratched face {}.</text>"#,
        by + 7.0,
        scene.plate.size_mm,
        if convex { "outside" } else { "inside" }
    );
    let _ = writeln!(svg, "</svg>");
    scratchart_render::io::write_atomic(path, svg.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::{framed_ring_views, orbit_light};
    use scratchart_model::surface::{BendAxis, PlateShape};

    /// A convex sheet under the default lamp (above the first eye) mirrors it into that view;
    /// the lamp the search finds keeps every view's glint at least the margin away, and a flat
    /// plate's lamp stays where it was.
    #[test]
    fn the_search_moves_the_lamp_until_no_view_sees_the_sheets_glint() {
        let plate = Plate {
            shape: PlateShape::Cylinder {
                radius_mm: 80.0,
                axis: BendAxis::Y,
                convex: true,
            },
            ..Plate::flat(100.0)
        };
        let light = orbit_light(300.0, 65.0, 0.0, 1.0e4);
        let views = framed_ring_views(3, 45.0, 300.0, &plate, 32, &light, 0.95);
        let before = glint_margin_deg(&views[0], &plate);
        assert!(before < 2.0, "the default lamp's glint in view 0: {before} degrees");
        let (lamp, m) = glint_free_lamp(&views, &plate, &light);
        assert!(m >= GLINT_MARGIN_DEG, "{m}");
        for v in &views {
            let lit = View {
                light: lamp.clone(),
                ..v.clone()
            };
            assert!(glint_margin_deg(&lit, &plate) >= GLINT_MARGIN_DEG);
        }
        let flat = Plate::flat(100.0);
        assert_eq!(glint_free_lamp(&views, &flat, &light).0, light);
    }
}
