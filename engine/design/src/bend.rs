//! What a bent plate (engine/docs/model.md section 10) asks of a design beyond the flat plate's:
//! a lamp that keeps the sheet's own mirror glint out of the views.
//!
//! A flat plate's polished finish mirrors the lamp only where its one normal bisects lamp and eye,
//! which the default set-up keeps off the plate. A cylinder has every normal of its arc: for each
//! eye, a line across the sheet where the finish mirrors the lamp, a bright band that no scratch
//! pattern can hide (scratches cover only part of it). Where the lamp stands off the plane of
//! the cylinder's normals seen from each eye, the half vector leaves the arc of normals and the
//! band leaves the sheet. [`glint_free_lamp`] searches the lamp's azimuth for that.

use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::{Light, LightKind, Plate, View};

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
