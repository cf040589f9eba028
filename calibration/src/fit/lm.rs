//! One refinement of the fit as a least-squares problem for the engine's generic solver
//! (`scratchart_optim::least_squares`: robust Levenberg-Marquardt within bounds). The Jacobian:
//! the columns of the parameters that move the grooves (tool, z offset, alpha) from the engine's
//! directional derivatives (`Evaluator::tangent_columns`, one pass per 7 parameters); the eyes of
//! photos taken off the capture pose (they move the camera, not the grooves) by forward
//! differences of renders; exposure, blur and registration by forward differences of the camera
//! model alone (no render).
use scratchart_observe::Observer;
use scratchart_optim::least_squares::{self, Interrupted, LeastSquares, Solution};

use super::{Evaluator, FitError};
use scratchart_model::par::par_map;

/// The smallest robust scale of the residuals (display units).
pub(super) const MIN_SCALE: f64 = 0.002;

/// The fit's robust loss, as `SCRATCHART_FIT_LOSS` says (`docs/fit.md`, "The loss and the
/// noise"; an experiment's switch, as `SCRATCHART_MOMENTS` is):
/// - `cauchy` (the default): Cauchy at the robust scale (1.4826 MAD of the residuals, about the
///   photo's noise), where the model's error at a groove's edge, a speck of dust or a stray
///   reflection pull little. It estimates the mean only of symmetric noise, and the model is
///   the photo's mean (the lift of noise clipped at black is in it: `noise`).
/// - `split`: Cauchy, but least squares within [`CORE_K`] robust scales (Cauchy's tail beyond)
///   where the model is within a few noises of black (`Evaluator::skewed`).
/// - `huber`: Huber at [`CORE_K`] robust scales everywhere.
pub(super) fn loss() -> FitLoss {
    match std::env::var("SCRATCHART_FIT_LOSS").ok().as_deref() {
        Some("split") => FitLoss::Split,
        Some("huber") => FitLoss::Huber,
        _ => FitLoss::Cauchy,
    }
}

/// The fit's robust loss (see [`loss`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum FitLoss {
    Cauchy,
    Split,
    Huber,
}

impl FitLoss {
    /// The loss of the residuals that are not skewed, and of those that are.
    fn pair(self) -> (least_squares::Loss, least_squares::Loss) {
        match self {
            FitLoss::Cauchy => (least_squares::Loss::Cauchy, least_squares::Loss::Cauchy),
            FitLoss::Split => (least_squares::Loss::Cauchy, least_squares::Loss::CauchyTail(CORE_K)),
            FitLoss::Huber => (least_squares::Loss::Huber(CORE_K), least_squares::Loss::Huber(CORE_K)),
        }
    }
}

/// The half-width of a quadratic core, in robust scales.
pub(super) const CORE_K: f64 = 3.0;

/// The losses of residuals `r` of `ev` (see [`loss`]).
pub(super) fn losses(ev: &Evaluator, r: &[f64]) -> least_squares::Losses {
    let fl = loss();
    let (loss, skewed_loss) = fl.pair();
    least_squares::Losses {
        loss,
        skewed_loss,
        skewed: (fl == FitLoss::Split).then(|| ev.skewed(r)),
    }
}

impl From<Interrupted> for FitError {
    fn from(_: Interrupted) -> FitError {
        FitError::Interrupted
    }
}

/// The fit's parameters within their bounds, the z offset (if any) within `off_range`, and the
/// linear renders of the last two render-parameter sets evaluated (a trial point and the
/// current one), so that moving only camera terms renders nothing.
struct Refinement<'x, 'a, 'r> {
    ev: &'x mut Evaluator<'a, 'r>,
    off_range: Option<(f64, f64)>,
    renders: Vec<(Vec<f64>, Vec<Vec<f32>>)>,
}

impl Refinement<'_, '_, '_> {
    /// The values of the parameters that need a render.
    fn render_key(&self, x: &[f64]) -> Vec<f64> {
        self.ev
            .lay
            .params
            .iter()
            .zip(x)
            .filter(|(q, _)| q.render)
            .map(|(_, v)| *v)
            .collect()
    }

    /// Residuals at `x`, rendering only when its render parameters are new.
    fn eval(&mut self, x: &[f64]) -> Result<Vec<f64>, FitError> {
        let key = self.render_key(x);
        if let Some((_, lin)) = self.renders.iter().find(|(k, _)| *k == key) {
            return Ok(self.ev.residuals_at(x, lin));
        }
        let (r, lin) = self.ev.eval(x)?;
        if self.renders.len() == 2 {
            self.renders.remove(0);
        }
        self.renders.push((key, lin));
        Ok(r)
    }
}

impl LeastSquares for Refinement<'_, '_, '_> {
    type Error = FitError;

    fn bounds(&self) -> Vec<(f64, f64)> {
        self.ev
            .lay
            .params
            .iter()
            .enumerate()
            .map(|(k, q)| match (self.ev.lay.offset == Some(k), self.off_range) {
                (true, Some(rg)) => (rg.0.max(q.lo), rg.1.min(q.hi)),
                _ => (q.lo, q.hi),
            })
            .collect()
    }

    fn residuals(&mut self, x: &[f64]) -> Result<Vec<f64>, FitError> {
        self.eval(x)
    }

    fn skewed(&mut self, r: &[f64]) -> Option<Vec<bool>> {
        (loss() == FitLoss::Split).then(|| self.ev.skewed(r))
    }

    fn jacobian(&mut self, x: &[f64], r: &[f64]) -> Result<Vec<Vec<f64>>, FitError> {
        let np = self.ev.lay.params.len();
        let bounds = self.bounds();
        // The grooves' parameters: derivatives from the engine.
        let eyes: Vec<usize> = (0..np).filter(|&k| self.ev.lay.camera_view(k).is_some()).collect();
        let grooves: Vec<usize> = (0..np)
            .filter(|k| self.ev.lay.params[*k].render && !eyes.contains(k))
            .collect();
        let mut tangent = self.ev.tangent_columns(x, &grooves)?.into_iter();
        // The camera terms of off-pose photos: from the image's motion (no render).
        let lin = match self.renders.iter().find(|(k, _)| *k == self.render_key(x)) {
            Some((_, lin)) => lin.clone(),
            None => self.ev.render(x)?,
        };
        // Each photo's blurred light at x, for the camera terms' columns below.
        let blurred: Vec<Vec<f32>> = {
            let ev = &*self.ev;
            par_map(lin.len(), |v| ev.blurred(&lin[v], v, x))
        };
        let mut motion = self.ev.motion_columns(x, &blurred, &eyes).into_iter();
        // A term of one photo's camera model (its exposure, blur, shading, noise, tone curve)
        // changes that photo's residuals alone: the others' differences are 0, and its model
        // photo comes from its blurred light at x unless the term is its blur. The same bits as
        // differencing every residual; the terms side by side on the host's cores.
        let photo_terms: Vec<(usize, usize)> = (0..np)
            .filter_map(|k| self.ev.lay.photo_term(k).map(|v| (k, v)))
            .collect();
        let mut photo_cols = {
            let ev = &*self.ev;
            let masked = |v: usize| ev.data.masks[v].iter().filter(|m| **m).count();
            let starts: Vec<usize> = (0..lin.len())
                .scan(0, |at, v| Some(std::mem::replace(at, *at + masked(v))))
                .collect();
            par_map(photo_terms.len(), |i| {
                let (k, v) = photo_terms[i];
                let (xh, h) = forward_step(x, k, ev.lay.params[k].step, bounds[k]);
                let b = match ev.lay.blur(&xh, v) == ev.lay.blur(x, v) {
                    true => blurred[v].clone(),
                    false => ev.blurred(&lin[v], v, &xh),
                };
                let rv = ev.residuals_of(v, &ev.expose_masked(&b, v, &xh), starts[v]);
                let mut col = vec![0.0 / h; r.len()];
                for (j, e) in rv.iter().enumerate() {
                    col[starts[v] + j] = (e - r[starts[v] + j]) / h;
                }
                col
            })
            .into_iter()
        };
        // The rest by forward differences (away from the nearer bound).
        let mut cols: Vec<Vec<f64>> = Vec::with_capacity(np);
        for k in 0..np {
            if grooves.contains(&k) {
                cols.push(tangent.next().expect("one column per groove parameter"));
                continue;
            }
            if eyes.contains(&k) {
                cols.push(motion.next().expect("one column per camera term"));
                continue;
            }
            if self.ev.lay.photo_term(k).is_some() {
                cols.push(photo_cols.next().expect("one column per photo term"));
                continue;
            }
            let (xh, h) = forward_step(x, k, self.ev.lay.params[k].step, bounds[k]);
            let rh = self.eval(&xh)?;
            cols.push(rh.iter().zip(r).map(|(a, b)| (a - b) / h).collect());
        }
        Ok(cols)
    }
}

/// `x` moved along parameter `k` by its `step` for a forward difference, away from the nearer of
/// `bounds` (the middle of the bounds where there is no room either way), and the step taken.
fn forward_step(x: &[f64], k: usize, step: f64, (lo, hi): (f64, f64)) -> (Vec<f64>, f64) {
    let mut xh = x.to_vec();
    let mut h = step;
    if x[k] + h > hi {
        h = -h;
    }
    if x[k] + h < lo {
        // no room either way: the middle of the bounds
        h = lo + 0.5 * (hi - lo) - x[k];
    }
    xh[k] = x[k] + h;
    (xh, h)
}

/// Robust Levenberg-Marquardt from `x` with the z offset (if any) kept in `off_range`.
pub(super) fn refine(
    ev: &mut Evaluator,
    x: Vec<f64>,
    off_range: Option<(f64, f64)>,
    iters: u32,
    obs: &dyn Observer,
    label: &str,
) -> Result<Solution, FitError> {
    let mut p = Refinement {
        ev,
        off_range,
        renders: Vec::new(),
    };
    let (loss, skewed_loss) = loss().pair();
    let cfg = least_squares::Config {
        iters,
        min_scale: MIN_SCALE,
        loss,
        skewed_loss,
        task: "fit",
        label: label.to_string(),
    };
    least_squares::solve(&mut p, x, &cfg, obs)
}

/// The residuals at `x` and the Jacobian there, column by column (as the refinement computes
/// them), with the z offset (if any) kept in `off_range`.
pub(super) fn jacobian_at(
    ev: &mut Evaluator,
    x: &[f64],
    off_range: Option<(f64, f64)>,
) -> Result<(Vec<f64>, Vec<Vec<f64>>), FitError> {
    let mut p = Refinement {
        ev,
        off_range,
        renders: Vec::new(),
    };
    let r = p.eval(x)?;
    let cols = p.jacobian(x, &r)?;
    Ok((r, cols))
}
