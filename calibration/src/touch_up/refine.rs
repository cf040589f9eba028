//! The touch-up's optimizer: after the width-ratio search of [`super::plan`], the design's own
//! loss (its targets, its blur, each view weighted by how far it falls short) is minimized over
//! what can still be done to the carved plate:
//!
//! - every groove's commanded depth, never shallower than its cut (metal cannot be put back);
//!   the groove at a depth is what the tool as carved cuts there (`inspect`'s tool, sampled as
//!   the design samples its tool: [`ToolTable`]), with the machine's depth scale;
//! - new scratches, seeded where a view is darker than its picture asks: at a plate point seen
//!   by such a pixel, across the half vector of that view's eye and lamp there (so its walls
//!   face that view), the design's median length, never across a registration mark; their
//!   endpoints and depths move, the depths within the design's own range.
//!
//! Adam on the host over the engine's gradients (`scratchart_optim::prune::evaluate`: one render,
//! loss and backward per iteration; dE/dz by the chain rule through the table's slopes). The
//! state with the lowest loss is kept; new scratches that end at their shallowest depth or
//! shorter than the machine cuts are dropped. [`super::plan`] then judges the result by the
//! worst view, as it judges the ratios, and keeps it only where it is better.
use anyhow::{anyhow, Result};
use scratchart_design::scenes::Rng;
use scratchart_design::tolerance::SheetInputs;
use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::{Scene, Scratch};
use scratchart_optim::adam::AdamConfig;
use scratchart_optim::loss::{Loss, LossConfig};
use scratchart_optim::tool_params::table::ToolTable;
use scratchart_render::Renderer;

use super::Carving;

/// How the optimizer runs.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    pub iters: u32,
    /// New scratches tried, as a share of the design's (0: none).
    pub new_share: f64,
    pub seed: u64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            iters: 100,
            new_share: 0.25,
            seed: 1,
        }
    }
}

/// A new scratch: where it runs (the carving's frame) and its commanded depth (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Added {
    pub p0: [f64; 2],
    pub p1: [f64; 2],
    pub z: f64,
}

/// What the optimizer found.
#[derive(Clone, Debug)]
pub struct Refined {
    /// Every design scratch's commanded depth (>= its cut's; not yet on the Z grid).
    pub depths: Vec<f64>,
    pub added: Vec<Added>,
    /// New scratches tried.
    pub tried: usize,
    /// The loss at the start of the last stage (the targets matched last) and at the state kept
    /// (against the same targets).
    pub loss: [f32; 2],
}

/// What the optimizer works on: the carving, the design's inputs, each view's weight.
pub struct Problem<'a> {
    pub carving: &'a Carving<'a>,
    pub inputs: &'a SheetInputs,
    pub weights: &'a [f32],
}

/// Iterations between two matches of the targets to the plate's render ([`matched_targets`]).
const RETARGET: u32 = 20;

/// One parameter of Adam on the host, with its bounds.
#[derive(Clone, Copy)]
struct Param {
    x: f64,
    m: f64,
    v: f64,
    lo: f64,
    hi: f64,
    lr: f64,
}

impl Param {
    fn new(x: f64, lo: f64, hi: f64, lr: f64) -> Param {
        Param {
            x: x.clamp(lo, hi),
            m: 0.0,
            v: 0.0,
            lo,
            hi,
            lr,
        }
    }

    fn step(&mut self, g: f64, t: i32) {
        let (b1, b2) = (0.9f64, 0.999f64);
        self.m = b1 * self.m + (1.0 - b1) * g;
        self.v = b2 * self.v + (1.0 - b2) * g * g;
        let mh = self.m / (1.0 - b1.powi(t));
        let vh = self.v / (1.0 - b2.powi(t));
        self.x = (self.x - self.lr * mh / (vh.sqrt() + 1e-12)).clamp(self.lo, self.hi);
    }
}

/// The state the optimizer moves: one depth per design scratch, then (x0, y0, x1, y1, z) per
/// new scratch.
struct State {
    z: Vec<Param>,
    new: Vec<[Param; 5]>,
}

impl State {
    /// The plate's scene for this state: the design's scratches (where the carving put them)
    /// with the grooves of their depths, then the new ones.
    fn scene(&self, c: &Carving, table: &ToolTable) -> Scene {
        let groove = |z: f64, p0, p1| {
            let [w, d] = table.eval((c.depth_scale * z).clamp(table.z_lo, table.z_hi));
            Scratch {
                p0,
                p1,
                w,
                d,
                alpha: c.alpha,
                bulge: 0.0,
            }
        };
        let mut scratches: Vec<Scratch> = c
            .placed
            .scratches
            .iter()
            .zip(&self.z)
            .map(|(s, z)| groove(z.x, s.p0, s.p1))
            .collect();
        scratches.extend(
            self.new
                .iter()
                .map(|p| groove(p[4].x, [p[0].x, p[1].x], [p[2].x, p[3].x])),
        );
        Scene {
            scratches,
            ..c.placed.clone()
        }
    }

    fn step(&mut self, grads: &[[f32; 8]], c: &Carving, table: &ToolTable, t: i32) {
        let dz = |g: &[f32; 8], z: f64| {
            let zr = c.depth_scale * z;
            if zr <= table.z_lo || zr >= table.z_hi {
                return 0.0;
            }
            let s = table.slope(zr);
            c.depth_scale * (g[4] as f64 * s[0] + g[5] as f64 * s[1])
        };
        for (p, g) in self.z.iter_mut().zip(grads) {
            let d = dz(g, p.x);
            p.step(d, t);
        }
        for (p, g) in self.new.iter_mut().zip(&grads[self.z.len()..]) {
            for i in 0..4 {
                p[i].step(g[i] as f64, t);
            }
            let d = dz(g, p[4].x);
            p[4].step(d, t);
        }
    }
}

/// The design loss of the design's inputs, each view weighted.
fn loss_of(renderer: &Renderer, scene: &Scene, inputs: &SheetInputs, weights: &[f32]) -> Result<Loss> {
    let slots = scratchart_render::layout::view_slots(scene);
    let cfg = LossConfig {
        sigma: inputs.sigma,
        ..LossConfig::default()
    };
    let loss = Loss::new(&renderer.ctx, &slots.views, &inputs.targets, cfg)?;
    loss.set_view_weights(&renderer.ctx, weights)?;
    Ok(loss)
}

/// Each view's target as the optimizer asks for it: within the picture, the design's target
/// taken to the mean and spread of `seen` (the plate's display render now), so that the loss
/// asks for the picture's structure, not for a brightness that the worst view's correlation
/// (the touch-up's judge) does not see; outside it, the target as it is.
fn matched_targets(inputs: &SheetInputs, seen: &[Vec<f32>]) -> Vec<Vec<f32>> {
    let stats = |x: &mut dyn Iterator<Item = f64>| {
        let (mut n, mut s, mut s2) = (0.0, 0.0, 0.0);
        for v in x {
            n += 1.0;
            s += v;
            s2 += v * v;
        }
        let m = s / f64::max(n, 1.0);
        (m, (s2 / f64::max(n, 1.0) - m * m).max(0.0).sqrt())
    };
    inputs
        .targets
        .iter()
        .zip(&inputs.pictures)
        .zip(seen)
        .map(|((t, pic), seen)| {
            let (ms, ss) = stats(
                &mut seen
                    .iter()
                    .zip(pic)
                    .filter(|p| *p.1)
                    .map(|p| p.0.clamp(0.0, 1.0) as f64),
            );
            let (mt, st) = stats(&mut t.iter().zip(pic).filter(|p| *p.1).map(|p| *p.0 as f64));
            if !(st > 1e-6 && ss > 1e-6) {
                return t.clone();
            }
            let b = ss / st;
            t.iter()
                .zip(pic)
                .map(|(&v, &m)| {
                    if m {
                        (ms + b * (v as f64 - mt)).clamp(0.0, 1.0) as f32
                    } else {
                        v
                    }
                })
                .collect()
        })
        .collect()
}

/// Seeds `n` new scratches (see the module doc) from `seen`, each view's display render of the
/// plate now, in proportion to how much light each view lacks (times its weight).
fn seed(p: &Problem, seen: &[Vec<f32>], n: usize, length: f64, rng: &mut Rng) -> Vec<[[f64; 2]; 2]> {
    let scene = p.carving.placed;
    let half = 0.5 * scene.plate.size_mm;
    let lack: Vec<Vec<f64>> = (0..scene.views.len())
        .map(|v| {
            let (t, m) = (&p.inputs.targets[v], &p.inputs.pictures[v]);
            seen[v]
                .iter()
                .zip(t)
                .zip(m)
                .map(|((&s, &t), &m)| {
                    if m {
                        (t - s.clamp(0.0, 1.0)).max(0.0) as f64
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let mass: Vec<f64> = lack
        .iter()
        .zip(p.weights)
        .map(|(l, &w)| l.iter().sum::<f64>() * w as f64)
        .collect();
    let total: f64 = mass.iter().sum();
    if !(total > 0.0) {
        return Vec::new();
    }
    let mut out = Vec::new();
    for (v, view) in scene.views.iter().enumerate() {
        let want = (n as f64 * mass[v] / total).round() as usize;
        let sum: f64 = lack[v].iter().sum();
        if want == 0 || !(sum > 0.0) {
            continue;
        }
        let geom = ViewGeom::of(view, &scene.plate);
        let w = view.camera.width as usize;
        let mut tries = 0;
        let mut got = 0;
        while got < want && tries < 20 * want {
            tries += 1;
            // A pixel drawn in proportion to the light it lacks.
            let mut u = rng.f64() * sum;
            let k = lack[v].iter().position(|&l| {
                u -= l;
                u <= 0.0
            });
            let Some(k) = k else { continue };
            // A point drawn within the pixel: a pixel drawn twice seeds two scratches, not one
            // twice (two identical scratches move as one and cut one groove).
            let (i, j) = ((k % w) as f64 + rng.f64(), (k / w) as f64 + rng.f64());
            let Some(x) = geom.hit(i, j) else {
                continue;
            };
            let (o, i) = (geom.omega_o(x), geom.light_at(x).omega_i);
            let h = [o[0] + i[0], o[1] + i[1]];
            let hn = (h[0] * h[0] + h[1] * h[1]).sqrt();
            if !(hn > 1e-9) {
                continue;
            }
            // Across the half vector: the groove's walls tilt towards it.
            let t = [-h[1] / hn, h[0] / hn];
            let a = [x[0] - 0.5 * length * t[0], x[1] - 0.5 * length * t[1]];
            let b = [x[0] + 0.5 * length * t[0], x[1] + 0.5 * length * t[1]];
            if !usable(p, a, b, half) {
                continue;
            }
            out.push([a, b]);
            got += 1;
        }
    }
    out
}

/// Whether a new scratch from `a` to `b` may be cut: on the plate (a margin of 1% of it), no
/// shorter than the machine cuts, across no registration mark.
fn usable(p: &Problem, a: [f64; 2], b: [f64; 2], half: f64) -> bool {
    let inside = |q: [f64; 2]| q[0].abs() <= 0.98 * half && q[1].abs() <= 0.98 * half;
    let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
    let c = p.carving;
    inside(a) && inside(b) && len >= c.min_length_mm && !c.marks.is_some_and(|m| m.crossed_by(&[a, b]))
}

/// The median length of the design's scratches, mm.
fn median_length(scene: &Scene) -> f64 {
    let mut l: Vec<f64> = scene
        .scratches
        .iter()
        .map(|s| ((s.p1[0] - s.p0[0]).powi(2) + (s.p1[1] - s.p0[1]).powi(2)).sqrt())
        .collect();
    l.sort_by(f64::total_cmp);
    l.get(l.len() / 2).copied().unwrap_or(0.0)
}

/// Runs the optimizer from the commanded depths `start` (>= the cuts).
pub fn refine(
    renderer: &Renderer,
    p: &Problem,
    start: &[f64],
    opts: &Options,
    obs: &dyn scratchart_observe::Observer,
) -> Result<Refined> {
    let c = p.carving;
    let scene = c.placed;
    let adam = AdamConfig::for_plate(scene.plate.size_mm);
    let table = ToolTable::new(c.carved, adam.w_bounds.1 as f64, adam.d_bounds.1 as f64, 256)
        .map_err(|e| anyhow!("the tool as carved cannot be sampled: {e}"))?;
    let a = c.depth_scale;
    let (z_min, z_max) = (table.z_lo / a, table.z_hi / a);
    let lr_z = adam.lr_d as f64;
    let z: Vec<Param> = start
        .iter()
        .zip(c.cut)
        .map(|(&s, &cut)| {
            // Never shallower than the start (the width ratio's plan, itself never shallower
            // than the cut): the loss is not the worst view's correlation, and the ratio was
            // chosen by that.
            let lo = cut.max(s).max(z_min);
            Param::new(s, lo, z_max.max(lo), lr_z)
        })
        .collect();
    let mut state = State { z, new: Vec::new() };
    let loss = loss_of(renderer, &state.scene(c, &table), p.inputs, p.weights)?;
    // The new scratches' grooves: the design's own range of widths, at the depths where the
    // tool as carved cuts them (a carving found shallow cuts the same groove deeper).
    let mut designed: Vec<f64> = c.designed.to_vec();
    designed.sort_by(f64::total_cmp);
    let as_carved = |q: f64| {
        let w = c.calibrated.section(q).map_or(0.0, |s| s.width);
        (super::depth_for_width(c.carved, w, a * z_min) / a).clamp(z_min, z_max)
    };
    let (dlo, dhi, z0) = match (designed.first(), designed.last()) {
        (Some(&l), Some(&h)) => (as_carved(l), as_carved(h), as_carved(designed[designed.len() / 2])),
        _ => (f64::NAN, f64::NAN, f64::NAN),
    };
    let n_new = (opts.new_share * scene.scratches.len() as f64).round() as usize;
    if n_new > 0 && dlo.is_finite() {
        let seen = super::display_renders(renderer, &state.scene(c, &table))?;
        let mut rng = Rng::new(opts.seed);
        let length = median_length(scene);
        let (lo, hi) = (dlo, dhi.max(dlo));
        let lr_end = adam.lr_end as f64;
        let half = 0.5 * scene.plate.size_mm;
        for [p0, p1] in seed(p, &seen, n_new, length, &mut rng) {
            let e = |x: f64| Param::new(x, -0.98 * half, 0.98 * half, lr_end);
            state
                .new
                .push([e(p0[0]), e(p0[1]), e(p1[0]), e(p1[1]), Param::new(z0, lo, hi, lr_z)]);
        }
    }
    let tried = state.new.len();
    let seen = super::display_renders(renderer, &state.scene(c, &table))?;
    loss.set_targets(&renderer.ctx, &matched_targets(p.inputs, &seen))?;
    renderer.prepare_backward()?;
    let mut best: Option<(f32, Vec<f64>, Vec<Added>)> = None;
    let mut first = f32::NAN;
    for t in 0..=opts.iters {
        let (lv, grads) = scratchart_optim::prune::evaluate(renderer, &loss, &state.scene(c, &table))?;
        if first.is_nan() {
            first = lv.total;
        }
        let better = match &best {
            Some(b) => lv.total < b.0,
            None => true,
        };
        if lv.total.is_finite() && better {
            let added = state
                .new
                .iter()
                .map(|q| Added {
                    p0: [q[0].x, q[1].x],
                    p1: [q[2].x, q[3].x],
                    z: q[4].x,
                })
                .collect();
            best = Some((lv.total, state.z.iter().map(|q| q.x).collect(), added));
        }
        if t % 10 == 0 || t == opts.iters {
            obs.info(&format!(
                "touch-up optimizer {t}/{}: loss {:.6} (this stage's start {first:.6}), {tried} new scratches tried",
                opts.iters, lv.total
            ));
        }
        if t < opts.iters {
            state.step(&grads, c, &table, t as i32 + 1);
            // (Not before the last evaluation: the last stage takes RETARGET steps, and the
            // state kept is the best of them.)
            if (t + 1) % RETARGET == 0 && t + 1 < opts.iters {
                let seen = super::display_renders(renderer, &state.scene(c, &table))?;
                loss.set_targets(&renderer.ctx, &matched_targets(p.inputs, &seen))?;
                // The kept state's loss, and the stage's first, were against the old targets.
                best = None;
                first = f32::NAN;
            }
        }
    }
    let (kept, depths, added) = best.ok_or_else(|| anyhow!("the touch-up optimizer found no finite loss"))?;
    let half = 0.5 * scene.plate.size_mm;
    let floor = dlo + 1e-4;
    let added = added
        .into_iter()
        .filter(|s| s.z > floor && usable(p, s.p0, s.p1, half))
        .collect();
    Ok(Refined {
        depths,
        added,
        tried,
        loss: [first, kept],
    })
}
