//! The touch-up of a carved plate (`scratchart-cal plan --touch-up inspect.json`): what can
//! still be done to it with what `inspect` found (the tool as carved). Metal cannot be put
//! back: a groove only deepens along its own path.
//!
//! The design asked for each scratch's groove (its (w, d), what the calibrated tool cuts at its
//! commanded depth); the plate holds what the tool as carved cut there. Under a wall of fixed
//! slopes a groove's light grows with its visible width, so the plate shows the design (up to
//! its exposure) when every groove is c times as wide as designed, for one c for the whole
//! plate. The touch-up recuts each scratch at the depth whose groove (by the tool as carved)
//! is c times the designed width, where that is deeper than its cut (a groove already wider
//! stays: it is what the touch-up cannot fix), on the machine's Z grid. c is searched: each
//! candidate's plate is rendered from every view at the design's own exposure and the one
//! whose worst view correlates best with its picture, as the design measures ([`Goal`]), is
//! kept, "no touch-up" among the candidates, so the touch-up never plans a plate that renders
//! worse than the one it has.
//!
//! Then the optimizer ([`refine`]): from the ratio's depths, the design's loss over every
//! groove's depth (never shallower) and new scratches where a view lacks light; its plan
//! replaces the ratio's only where the worst view, measured the same way, is better.
use anyhow::Result;
use scratchart_model::scene::Scene;
use scratchart_render::Renderer;
use scratchart_tool::Tool;

use scratchart_design::measure::{blur3, correlation as measure_correlation};
use scratchart_design::tolerance::SheetInputs;
use scratchart_model::camera::on_plate_mask;

pub mod refine;
use refine::Added;

/// The width ratios searched (1: the designed widths where the carving left them narrower).
pub const RATIOS: [f64; 9] = [1.0, 1.05, 1.1, 1.15, 1.2, 1.3, 1.4, 1.6, 1.8];

/// The touch-up planned.
#[derive(Clone, Debug)]
pub struct TouchUp {
    /// Every scratch's commanded depth after the touch-up (>= its cut's).
    pub depths: Vec<f64>,
    /// The scratches recut (indices into the design's).
    pub recut: Vec<usize>,
    /// The width ratio kept (None: no touch-up helps).
    pub ratio: Option<f64>,
    /// Grooves already wider than the ratio asks (the touch-up cannot narrow them).
    pub too_wide: usize,
    /// New scratches (the carving's frame; depths on the Z grid), by the optimizer.
    pub added: Vec<Added>,
    /// Whether the optimizer's plan was kept (else the ratio's, or none).
    pub optimized: bool,
    /// Per view, the worst-view measure's correlation before and after.
    pub before: Vec<f64>,
    pub after: Vec<f64>,
    /// What the correlations are measured against.
    pub against: &'static str,
}

/// What the plate is compared with: each view's target and picture as the design's loss saw
/// them (`SheetInputs` beside the design: `<view>_target.pfm`, `<view>_picture.png`), measured
/// as the design measures (`scratchart_design::measure`: the display render clamped to [0, 1],
/// blurred by the loss's Gaussian, correlated with the target over the picture); without them,
/// the design's own render over the plate.
pub struct Goal {
    inputs: Option<SheetInputs>,
}

impl Goal {
    /// The goal of the design in `design_file`.
    pub fn of(design_file: &std::path::Path, design: &Scene) -> Goal {
        let dir = design_file.parent().unwrap_or(std::path::Path::new("."));
        Goal {
            inputs: SheetInputs::load(dir, design).ok().flatten(),
        }
    }

    /// The design's inputs, where it wrote them.
    pub fn inputs(&self) -> Option<&SheetInputs> {
        self.inputs.as_ref()
    }

    /// What the correlations are against.
    pub fn against(&self) -> &'static str {
        match self.inputs {
            Some(_) => "each view's picture, measured as the design measures",
            None => "the design's own render (the design has no set-up inputs beside it)",
        }
    }

    /// View `v`'s correlation of the display image `seen` with its goal (`designed`: the design's
    /// own display render of the view, the goal without inputs).
    pub fn correlation(&self, scene: &Scene, v: usize, seen: &[f32], designed: &[f32]) -> f64 {
        let (w, h) = (scene.views[v].camera.width, scene.views[v].camera.height);
        let prep = |x: &[f32]| -> Vec<f64> {
            let c: Vec<f32> = x.iter().map(|v| v.clamp(0.0, 1.0)).collect();
            blur3(&c, w, h, self.inputs.as_ref().map_or(1.0, |i| i.sigma))
        };
        match &self.inputs {
            Some(i) => {
                let t: Vec<f64> = i.targets[v].iter().map(|&x| x as f64).collect();
                measure_correlation(&prep(seen), &t, &i.pictures[v])
            }
            None => measure_correlation(&prep(seen), &prep(designed), &on_plate_mask(scene, v)),
        }
    }
}

/// The commanded depth at which `tool` cuts a groove `width` wide, at least `from` (bisection;
/// the deepest looked at, `from` + 0.3 mm, when it never gets that wide).
fn depth_for_width(tool: &Tool, width: f64, from: f64) -> f64 {
    let w = |z: f64| tool.section(z).map_or(0.0, |s| s.width);
    if w(from) >= width {
        return from;
    }
    let (mut a, mut b) = (from, from + 0.3);
    if w(b) < width {
        return b;
    }
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if w(m) >= width {
            b = m;
        } else {
            a = m;
        }
    }
    b
}

/// The plate's grooves for depths `z` (as the machine reaches them) cut by `tool`, and the
/// new scratches `added` (their depths likewise); each depth's groove fitted once.
fn plate_with(design: &Scene, z: &[f64], tool: &Tool, alpha: f64, added: &[Added]) -> Scene {
    let mut models = std::collections::HashMap::new();
    let ends = design
        .scratches
        .iter()
        .zip(z)
        .map(|(s, &z)| (s.p0, s.p1, s.bulge, z))
        .chain(added.iter().map(|a| (a.p0, a.p1, 0.0, a.z)));
    let scratches = ends
        .filter_map(|(p0, p1, bulge, z)| {
            let m = (*models.entry(z.to_bits()).or_insert_with(|| tool.model(z)))?;
            Some(scratchart_model::scene::Scratch {
                p0,
                p1,
                w: m.w,
                d: m.d,
                alpha,
                bulge,
            })
        })
        .collect();
    Scene {
        scratches,
        ..design.clone()
    }
}

/// [`plate_with`] without new scratches.
fn plate(design: &Scene, z: &[f64], tool: &Tool, alpha: f64) -> Scene {
    plate_with(design, z, tool, alpha, &[])
}

/// Each view's display render of `scene` (the view's resolution and exposure, as the design
/// renders).
pub fn display_renders(renderer: &Renderer, scene: &Scene) -> Result<Vec<Vec<f32>>> {
    let mut gs = renderer.upload(scene)?;
    Ok(renderer
        .render(&mut gs)?
        .images
        .into_iter()
        .map(|img| img.into_iter().map(scratchart_render::io::display_value).collect())
        .collect())
}

/// Each view's correlation of `scene`'s render with the goal.
fn measure(renderer: &Renderer, scene: &Scene, goal: &Goal, designed: &[Vec<f32>]) -> Result<Vec<f64>> {
    let seen = display_renders(renderer, scene)?;
    Ok((0..scene.views.len())
        .map(|v| goal.correlation(scene, v, &seen[v], &designed[v]))
        .collect())
}

/// The plate as carved: the commanded depths it was cut at, the tool the design assumed, the
/// tool as `inspect` found it, the walls' roughness and the machine's Z grid (mm), and where
/// the carving put the scratches.
#[derive(Clone, Copy)]
pub struct Carving<'a> {
    /// The design's scratches where the carving put them (the design itself unless `inspect`
    /// found the carving shifted or turned).
    pub placed: &'a Scene,
    /// The commanded depths the plate's grooves were cut at (the design's, or deeper where an
    /// earlier touch-up recut them).
    pub cut: &'a [f64],
    /// The design's commanded depths: the grooves it asked for.
    pub designed: &'a [f64],
    pub calibrated: &'a Tool,
    pub carved: &'a Tool,
    pub alpha: f64,
    pub z_step: f64,
    /// The machine's Z moves this many times what it is told (`inspect`'s depth scale).
    pub depth_scale: f64,
    /// The plate's registration marks where the carving put them (new scratches keep off them).
    pub marks: Option<&'a scratchart_machine::marks::PlateMarks>,
    /// The shortest scratch the machine cuts, mm.
    pub min_length_mm: f64,
}

/// Plans the touch-up of the plate `c` carved from `design` (see the module doc): the best width
/// ratio, then the optimizer ([`refine`], with `opts`; not for a design of arcs or without its
/// inputs), each kept only where the worst view gains.
pub fn plan(
    renderer: &Renderer,
    design: &Scene,
    c: &Carving,
    goal: &Goal,
    opts: &refine::Options,
    obs: &dyn scratchart_observe::Observer,
) -> Result<TouchUp> {
    let designed_scene = plate(design, c.designed, c.calibrated, c.alpha);
    let designed = display_renders(renderer, &designed_scene)?;
    let best = ratio_search(renderer, c, goal, &designed, obs)?;
    let arcs = design.scratches.iter().any(|s| s.bulge != 0.0);
    match goal.inputs() {
        Some(inputs) if opts.iters > 0 && !arcs => optimized(renderer, c, goal, inputs, &designed, best, opts, obs),
        _ => {
            obs.info(if arcs {
                "the touch-up's optimizer is not run on a design of arcs: the width ratio alone"
            } else {
                "the touch-up's optimizer needs the design's inputs (setup_inputs.json beside it): the width ratio alone"
            });
            Ok(best)
        }
    }
}

/// The commanded depth `z` on the machine's Z grid of `step`, up (the touch-up never asks for
/// less than it computed).
fn grid_up(z: f64, step: f64) -> f64 {
    if step > 0.0 {
        (z / step - 1e-9).ceil() * step
    } else {
        z
    }
}

/// The depths the machine reaches when told `z`.
fn reached(z: &[f64], depth_scale: f64) -> Vec<f64> {
    z.iter().map(|v| v * depth_scale).collect()
}

fn worst(v: &[f64]) -> f64 {
    v.iter().cloned().fold(f64::INFINITY, f64::min)
}

/// The optimizer's plan from `best` (the ratio's), on the Z grid, kept where its worst view
/// beats `best`'s.
#[allow(clippy::too_many_arguments)]
fn optimized(
    renderer: &Renderer,
    c: &Carving,
    goal: &Goal,
    inputs: &SheetInputs,
    designed: &[Vec<f32>],
    best: TouchUp,
    opts: &refine::Options,
    obs: &dyn scratchart_observe::Observer,
) -> Result<TouchUp> {
    // Each view weighted by how far it falls short, the worst most (as the design's balance).
    let short: Vec<f64> = best.after.iter().map(|v| (1.0 - v).max(1e-3)).collect();
    let mean = short.iter().sum::<f64>() / short.len().max(1) as f64;
    let weights: Vec<f32> = short.iter().map(|s| (s / mean).clamp(0.5, 3.0) as f32).collect();
    let problem = refine::Problem {
        carving: c,
        inputs,
        weights: &weights,
    };
    let r = refine::refine(renderer, &problem, &best.depths, opts, obs)?;
    let step = c.z_step;
    let tol = 0.5 * step.max(1e-4);
    let mut z = c.cut.to_vec();
    let mut recut = Vec::new();
    for (k, &zr) in r.depths.iter().enumerate() {
        let zt = grid_up(zr, step);
        if zt >= c.cut[k] + tol {
            z[k] = zt;
            recut.push(k);
        }
    }
    let added: Vec<Added> = r
        .added
        .iter()
        .map(|a| Added {
            z: grid_up(a.z, step),
            ..*a
        })
        .collect();
    // The new grooves as deep as the machine cuts them (its depth scale), as the recuts.
    let reached_added: Vec<Added> = added
        .iter()
        .map(|a| Added {
            z: a.z * c.depth_scale,
            ..*a
        })
        .collect();
    let after = measure(
        renderer,
        &plate_with(c.placed, &reached(&z, c.depth_scale), c.carved, c.alpha, &reached_added),
        goal,
        designed,
    )?;
    obs.info(&format!(
        "touch-up by the optimizer: {} of {} scratches recut, {} new of {} tried; loss {:.6} -> {:.6} (its last stage, against the \
         targets matched last); worst view {:.4} (the width ratio's {:.4})",
        recut.len(),
        c.cut.len(),
        added.len(),
        r.tried,
        r.loss[0],
        r.loss[1],
        worst(&after),
        worst(&best.after)
    ));
    if worst(&after) > worst(&best.after) + 1e-4 && !(recut.is_empty() && added.is_empty()) {
        let too_wide = best.too_wide;
        return Ok(TouchUp {
            depths: z,
            recut,
            ratio: best.ratio,
            too_wide,
            added,
            optimized: true,
            before: best.before,
            after,
            against: best.against,
        });
    }
    Ok(best)
}

/// The width ratio's touch-up (see the module doc): the best of [`RATIOS`], or none.
fn ratio_search(
    renderer: &Renderer,
    c: &Carving,
    goal: &Goal,
    designed: &[Vec<f32>],
    obs: &dyn scratchart_observe::Observer,
) -> Result<TouchUp> {
    let Carving {
        placed,
        cut,
        designed: designed_z,
        calibrated,
        carved,
        alpha,
        z_step,
        depth_scale,
        ..
    } = *c;
    let against = goal.against();
    let before = measure(
        renderer,
        &plate(placed, &reached(cut, depth_scale), carved, alpha),
        goal,
        designed,
    )?;
    let mut best = TouchUp {
        depths: cut.to_vec(),
        recut: vec![],
        ratio: None,
        too_wide: 0,
        added: vec![],
        optimized: false,
        before: before.clone(),
        after: before.clone(),
        against,
    };
    for &ratio in &RATIOS {
        let mut z = cut.to_vec();
        let (mut recut, mut too_wide) = (Vec::new(), 0);
        for (k, &zc) in cut.iter().enumerate() {
            let Some(want) = calibrated.section(designed_z[k]).map(|s| ratio * s.width) else {
                continue;
            };
            let now = carved.section(depth_scale * zc).map_or(0.0, |s| s.width);
            if now > want * 1.001 {
                too_wide += 1;
                continue;
            }
            let zt = grid_up(depth_for_width(carved, want, depth_scale * zc) / depth_scale, z_step);
            if zt >= zc + 0.5 * z_step.max(1e-4) {
                z[k] = zt;
                recut.push(k);
            }
        }
        if recut.is_empty() {
            continue;
        }
        let after = measure(
            renderer,
            &plate(placed, &reached(&z, depth_scale), carved, alpha),
            goal,
            designed,
        )?;
        obs.info(&format!(
            "touch-up at {ratio:.2} x the designed widths: {} of {} scratches recut, {too_wide} already wider; worst view {:.4} (now {:.4})",
            recut.len(),
            cut.len(),
            worst(&after),
            worst(&before)
        ));
        if worst(&after) > worst(&best.after) + 1e-4 {
            best = TouchUp {
                depths: z,
                recut,
                ratio: Some(ratio),
                too_wide,
                added: vec![],
                optimized: false,
                before: before.clone(),
                after,
                against,
            };
        }
    }
    Ok(best)
}
