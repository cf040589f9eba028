//! What a view can show at all, by the geometry of reflection: a groove's walls reflect the lamp
//! into an eye where their normal meets the half vector h between the two, and a groove's
//! normals lie in the plane of the plate's normal and its across-axis, tilted at most by its
//! steepest wall (engine/docs/model.md section 2: theta = 2 atan(2u/w), steepest at the visible
//! edge). So a pixel of a picture can be lit only where h tilts no more than the steepest wall
//! the scratches may have (the tool's range in fabrication mode; any tilt for free grooves), and
//! a scratch faces a view where h lies in its normal plane, within its roughness lobe (a
//! geometric test: the far tails of a sharp lobe still send some light elsewhere, which the
//! renders count and this does not).
//!
//! The reach map (per view: the picture's bright pixels no scratch can light from that eye and
//! lamp) and the scratches' service (which views each scratch's walls face) are
//! what `design` reports beside the correlations (`summary.json` `per_view[].reach`,
//! `NAME_reach.png`), so a maker sees before carving which part of which picture the plate cannot
//! show, and how the scratches are shared among the views.
use std::path::Path;

use serde_json::{json, Value};

use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::Scene;
use scratchart_optim::error::OptimError;
use scratchart_optim::tool_params::Fabrication;

/// Points along a scratch, less one, at which its service is judged.
pub const SAMPLES: usize = 16;

/// A target value (display, 0..1) at or above which a picture's pixel is bright: one the plate
/// must light.
pub const BRIGHT: f32 = 0.25;

/// The steepest wall of a groove of width `w` and depth `d` (mm), radians: at its visible edge,
/// theta = 2 atan(sqrt(1 - exp(-2 d / w))) (model.md section 2).
pub fn steepest_wall(w: f64, d: f64) -> f64 {
    2.0 * (-(-2.0 * d / w).exp_m1()).max(0.0).sqrt().atan()
}

/// The half-width of a wall's reflection lobe of roughness `alpha`, radians: where GGX falls to
/// 1% of its peak (tan = 3 alpha), which the display's 1/2.2 power still shows at 12% of the
/// peak's brightness.
pub fn lobe(alpha: f64) -> f64 {
    (3.0 * alpha).atan()
}

/// The half vector at plate point `x` of view `g`.
pub(crate) fn half_vector(g: &ViewGeom, x: [f64; 2]) -> [f64; 3] {
    // In the surface frame at x (the world's on a flat plate): what the grooves there see.
    let q = g.shape.at_sheet(x);
    let (o, i) = (g.omega_o_at(q.p), g.light_at_point(q.p).omega_i);
    let h = [o[0] + i[0], o[1] + i[1], o[2] + i[2]];
    let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt().max(1e-300);
    q.local([h[0] / n, h[1] / n, h[2] / n])
}

/// One view's reach: each pixel's state and the counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Reach {
    /// Per pixel: 0 off the picture, 1 a dark pixel of the picture, 2 a bright one some wall
    /// can light, 3 a bright one none can.
    pub map: Vec<u8>,
    pub bright: usize,
    pub unreachable: usize,
}

impl Reach {
    /// The share of the picture's bright pixels that some wall can light (1 where it has none).
    pub fn share(&self) -> f64 {
        if self.bright == 0 {
            1.0
        } else {
            1.0 - self.unreachable as f64 / self.bright as f64
        }
    }
}

/// View `j`'s reach map: where its picture (`target`, display values; `picture`, its pixels)
/// is bright, whether h tilts from the plate's normal by no more than `max_tilt` (radians) plus
/// the roughness lobe's half-width ([`lobe`]).
pub fn reach_map(scene: &Scene, j: usize, target: &[f32], picture: &[bool], max_tilt: f64, alpha: f64) -> Reach {
    let v = &scene.views[j];
    let g = ViewGeom::of(v, &scene.plate);
    let half = 0.5 * scene.plate.size_mm;
    let limit = max_tilt + lobe(alpha);
    let (w, h) = (v.camera.width, v.camera.height);
    let mut map = vec![0u8; (w * h) as usize];
    let (mut bright, mut unreachable) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let k = (y * w + x) as usize;
            if !picture[k] {
                continue;
            }
            if target[k] < BRIGHT {
                map[k] = 1;
                continue;
            }
            bright += 1;
            let lit = g
                .shading_point(x, y)
                .filter(|p| p[0].abs() <= half && p[1].abs() <= half)
                .is_some_and(|p| half_vector(&g, p)[2].clamp(-1.0, 1.0).acos() <= limit);
            map[k] = if lit { 2 } else { 3 };
            unreachable += usize::from(!lit);
        }
    }
    Reach {
        map,
        bright,
        unreachable,
    }
}

/// Which views each scratch of `scene` can light, anywhere along it ([`SAMPLES`] + 1 points, and
/// where h . t changes sign between two): h of the view lies within the
/// scratch's roughness lobe of its normal plane (|h . t| <= sin [`lobe`]) and tilts in that
/// plane by no more than its steepest wall plus the lobe. One bit per view (at most 64 views
/// counted; later views are left out).
pub fn service(scene: &Scene) -> Vec<u64> {
    let geoms: Vec<ViewGeom> = scene
        .views
        .iter()
        .take(64)
        .map(|v| ViewGeom::of(v, &scene.plate))
        .collect();
    scene
        .scratches
        .iter()
        .map(|s| {
            let (dx, dy) = (s.p1[0] - s.p0[0], s.p1[1] - s.p0[1]);
            let l = dx.hypot(dy).max(1e-300);
            let (t, b) = ([dx / l, dy / l], [-dy / l, dx / l]);
            let lobe = lobe(s.alpha);
            let wall = steepest_wall(s.w, s.d);
            let mut bits = 0u64;
            for (j, g) in geoms.iter().enumerate() {
                // Anywhere along it: h turns along a scratch under a near lamp or eye, so a
                // sharp wall lights a view where h . t passes through 0 (a glint), which the
                // samples bracket.
                let mut prev: Option<f64> = None;
                let lights = (0..=SAMPLES).any(|k| {
                    let f = k as f64 / SAMPLES as f64;
                    let x = [s.p0[0] + f * (s.p1[0] - s.p0[0]), s.p0[1] + f * (s.p1[1] - s.p0[1])];
                    let h = half_vector(g, x);
                    let along = h[0] * t[0] + h[1] * t[1];
                    let across = (h[0] * b[0] + h[1] * b[1]).abs();
                    let crossed = prev.is_some_and(|p| p * along <= 0.0);
                    prev = Some(along);
                    (along.abs().asin() <= lobe || crossed) && across.atan2(h[2]) <= wall + lobe
                });
                if lights {
                    bits |= 1 << j;
                }
            }
            bits
        })
        .collect()
}

/// Per view: how many scratches can light it, and how many of those light another view too.
pub fn shares(bits: &[u64], views: usize) -> Vec<(usize, usize)> {
    (0..views.min(64))
        .map(|j| {
            let mine = bits.iter().filter(|b| *b & (1 << j) != 0);
            let n = mine.clone().count();
            let shared = mine.filter(|b| b.count_ones() > 1).count();
            (n, shared)
        })
        .collect()
}

/// The reach map as an RGB image: the picture in grey, its bright pixels that no wall can light
/// in red, pixels off the picture dark blue-grey.
pub fn reach_rgb(r: &Reach, target: &[f32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(3 * r.map.len());
    for (k, &m) in r.map.iter().enumerate() {
        let g = (255.0 * target[k].clamp(0.0, 1.0)).round() as u8;
        out.extend_from_slice(&match m {
            0 => [30, 34, 44],
            3 => [230, 30, 30],
            _ => [g, g, g],
        });
    }
    out
}

/// The steepest wall the design's scratches may have, radians: through the tool, the steepest
/// of its grooves over the depths it may cut; free grooves may take any (90 degrees).
pub fn max_wall(tool: Option<&Fabrication>) -> f64 {
    tool.map_or(std::f64::consts::FRAC_PI_2, |f| {
        f.table
            .samples
            .iter()
            .map(|s| steepest_wall(s[0], s[1]))
            .fold(0.0, f64::max)
    })
}

/// Every view's reach map (written as `out/NAME_reach.png`) and the scratches' service, as
/// `summary.json`'s `per_view[].reach`, in view order.
pub fn report(
    out: &Path,
    scene: &Scene,
    targets: &[Vec<f32>],
    pictures: &[Vec<bool>],
    tool: Option<&Fabrication>,
) -> Result<Vec<Value>, OptimError> {
    let wall = max_wall(tool);
    // The lobe: the tool's roughness, else the scratches' median (the plate's without any).
    let mut alphas: Vec<f64> = scene.scratches.iter().map(|s| s.alpha).collect();
    alphas.sort_by(f64::total_cmp);
    let alpha = tool
        .map(|f| f.alpha)
        .or_else(|| alphas.get(alphas.len() / 2).copied())
        .unwrap_or(scene.plate.roughness);
    let bits = service(scene);
    let served = shares(&bits, scene.views.len());
    let mut all = Vec::new();
    for (j, v) in scene.views.iter().enumerate() {
        let r = reach_map(scene, j, &targets[j], &pictures[j], wall, alpha);
        let (w, h) = (v.camera.width, v.camera.height);
        scratchart_render::io::write_png_rgb(
            &out.join(format!("{}_reach.png", v.name)),
            w,
            h,
            &reach_rgb(&r, &targets[j]),
        )?;
        let (n, shared) = served.get(j).copied().unwrap_or((0, 0));
        all.push(json!({
            "bright_pixels": r.bright,
            "unreachable_pixels": r.unreachable,
            "share": r.share(),
            "steepest_wall_deg": wall.to_degrees(),
            "lobe_alpha": alpha,
            "scratches_facing": n,
            "also_facing_another_view": shared,
            "map_png": format!("{}_reach.png", v.name),
            "scratches_facing_no_view": bits.iter().filter(|b| **b == 0).count(),
        }));
    }
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;
    use scratchart_model::scene::{Plate, Scratch, View};

    /// One 32-px view of a 100 mm plate: the eye and a point lamp at (azimuth, elevation) in
    /// degrees, 300 mm from the centre.
    fn scene(eye: [f64; 2], lamp: [f64; 2], scratches: Vec<Scratch>) -> Scene {
        Scene {
            plate: Plate {
                size_mm: 100.0,
                roughness: 0.02,
                f0: 0.9,
                shape: Default::default(),
            },
            views: vec![View {
                exposure: 1.0,
                name: "v0".into(),
                camera: crate::scenes::orbit_camera(300.0, eye[1], eye[0], 100.0, 32, 32),
                light: crate::scenes::orbit_light(300.0, lamp[1], lamp[0], 1.0e5),
            }],
            scratches,
        }
    }

    #[test]
    fn the_steepest_wall_follows_depth_over_width() {
        assert!(steepest_wall(0.1, 1e-9) < 1e-3);
        // d = w/2: 2 atan(sqrt(1 - e^-1)) = 2 atan(0.79506) = 76.99 degrees.
        let x = steepest_wall(0.1, 0.05).to_degrees();
        assert!((x - 2.0 * 0.79506f64.atan().to_degrees()).abs() < 1e-3, "{x}");
        assert!(steepest_wall(0.1, 10.0).to_degrees() > 89.9);
    }

    /// A lamp in the mirror image of the eye (h along the normal): walls of 10 degrees reach the
    /// whole picture. A lamp beside the eye, 30 degrees from the normal: h tilts by 30 degrees,
    /// out of reach of walls of 10 degrees and within reach of 45; a scratch lights that view
    /// only across the plane of eye and lamp, and only with walls steep enough.
    #[test]
    fn reach_and_service_follow_the_half_vector() {
        // The eye 30 degrees from the normal (60 up), its mirror image across it.
        let (eye, mirror) = ([0.0, 60.0], [180.0, 60.0]);
        let t = vec![1.0f32; 32 * 32];
        let s = scene(eye, mirror, vec![]);
        let p = ViewGeom::new(&s.views[0]).on_plate_mask(50.0);
        assert!(p.iter().filter(|&&o| o).count() > 300);
        assert_eq!(reach_map(&s, 0, &t, &p, 15f64.to_radians(), 0.05).unreachable, 0);
        let s = scene(eye, eye, vec![]);
        let shallow = reach_map(&s, 0, &t, &p, 10f64.to_radians(), 0.05);
        let steep = reach_map(&s, 0, &t, &p, 45f64.to_radians(), 0.05);
        assert!(shallow.share() < 0.05, "{}", shallow.share());
        assert!(steep.share() > 0.99, "{}", steep.share());
        // Dark pixels are never out of reach.
        let dark = reach_map(&s, 0, &[0.0f32; 32 * 32], &p, 0.0, 0.05);
        assert_eq!((dark.bright, dark.share()), (0, 1.0));
        // h lies in the x-z plane: a scratch along y (across x) lights it with steep walls, one
        // along x does not, nor a shallow one.
        let sc = |p0: [f64; 2], p1: [f64; 2], d: f64| Scratch {
            p0,
            p1,
            w: 0.1,
            d,
            alpha: 0.05,
            bulge: 0.0,
        };
        let s = scene(
            eye,
            eye,
            vec![
                sc([0.0, -1.0], [0.0, 1.0], 0.05),
                sc([-1.0, 0.0], [1.0, 0.0], 0.05),
                sc([0.0, -1.0], [0.0, 1.0], 0.001),
            ],
        );
        assert_eq!(service(&s), vec![1, 0, 0]);
        assert_eq!(shares(&service(&s), 1), vec![(1, 0)]);
    }
}
