//! The generic optimizer for fits of a few parameters to many residuals (the tool calibration,
//! `scratchart-cal fit`): robust Levenberg-Marquardt within bounds. The problem supplies the
//! residuals and their Jacobian ([`LeastSquares`]); with the engine, its columns come from
//! [`crate::render::Renderer::tangents`] (the derivatives of every pixel along the parameters
//! that move the scratches) and from differences where a parameter is cheap to vary.
//!
//! [`super::Driver`] is its first-order, GPU-resident counterpart for thousands to millions of
//! parameters (the design). Here the parameters are few, so the solver works on the host with
//! the Jacobian itself: Gauss-Newton steps converge in tens of evaluations where Adam needs
//! hundreds, and J^T W J at the optimum gives the parameters' uncertainties.
//!
//! Loss ([`Loss`]): Huber at k scales or Cauchy, with the scale s = 1.4826 MAD of the residuals
//! (at least `min_scale`) set at each iteration's start, by iteratively reweighted least squares;
//! outliers (a dust speck, a stray reflection) pull little. Cauchy (0.5 s^2 ln(1 + r^2 / s^2))
//! rejects them best but estimates the mean only of residuals that are symmetric; Huber at 3
//! scales estimates the mean of skewed ones too (noise clipped at black) and bounds an
//! outlier's pull. Steps are clamped to the bounds; the damping is multiplied by 4 after a failed step
//! and divided by 3 after a good one; a run ends after `iters` iterations or when a step gains
//! less than 1e-5 of the loss.
use scratchart_observe::{Observer, Progress};

/// The user asked the run to stop (the observer's `should_stop`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Interrupted;

/// A least-squares problem for [`solve`].
pub trait LeastSquares {
    /// What can stop an evaluation (it must be able to say "interrupted").
    type Error: From<Interrupted>;
    /// Lower and upper bound of each parameter; the solution stays within them.
    fn bounds(&self) -> Vec<(f64, f64)>;
    /// The residuals at `x`.
    fn residuals(&mut self, x: &[f64]) -> Result<Vec<f64>, Self::Error>;
    /// The Jacobian at `x` (where the residuals are `r`), column by column: d r / d x_k.
    fn jacobian(&mut self, x: &[f64], r: &[f64]) -> Result<Vec<Vec<f64>>, Self::Error>;
    /// Per residual, whether its noise is skewed (clipped at a bound, as a photo's noise at
    /// black), `r` the residuals where an iteration starts: those take [`Config::skewed_loss`]
    /// for that iteration (asked with the robust scale, at each iteration's start). None: every
    /// residual takes [`Config::loss`].
    fn skewed(&mut self, _r: &[f64]) -> Option<Vec<bool>> {
        None
    }
}

/// The end of a run.
#[derive(Clone, Debug)]
pub struct Solution {
    pub x: Vec<f64>,
    /// Robust loss at `x` (scale `scale`).
    pub cost: f64,
    /// J^T W J of the last iteration (for uncertainties), and the weights W and scale.
    pub jtj: Vec<Vec<f64>>,
    pub weights: Vec<f64>,
    pub scale: f64,
    pub iterations: u32,
}

/// Robust scale of residuals: 1.4826 times their median absolute value, at least `floor`.
pub fn robust_scale(r: &[f64], floor: f64) -> f64 {
    if r.is_empty() {
        return floor;
    }
    let mut a: Vec<f64> = r.iter().map(|x| x.abs()).collect();
    let n = a.len();
    let mad = *a.select_nth_unstable_by(n / 2, |p, q| p.total_cmp(q)).1;
    (1.4826 * mad).max(floor)
}

/// The robust loss of a run, at the scale `s` the run sets at each iteration's start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Loss {
    /// Cauchy: 0.5 s^2 ln(1 + r^2 / s^2); a residual of twice the scale weighs a fifth. Not
    /// consistent for the mean of a skewed residual (noise clipped at black).
    Cauchy,
    /// Huber at `k` times the scale: least squares within, linear beyond. For k of 3 or more
    /// it estimates the mean of residuals whose tails are light (clipped noise included) and
    /// still bounds what an outlier pulls.
    Huber(f64),
    /// Least squares within `k` times the scale c, and Cauchy's tail beyond:
    /// 0.5 c^2 (1 + ln(r^2 / c^2)), weights c^2 / r^2. For k of 3 it estimates the mean of
    /// the noise, skewed or not, and an outlier weighs as little as under Cauchy at c.
    CauchyTail(f64),
}

impl Loss {
    /// The loss of residuals `r` at scale `s`.
    pub fn cost(self, r: &[f64], s: f64) -> f64 {
        r.iter().map(|e| self.rho(*e, s)).sum()
    }

    /// Each residual's weight in the normal equations (iteratively reweighted least squares).
    pub fn weights(self, r: &[f64], s: f64) -> Vec<f64> {
        r.iter().map(|e| self.weight(*e, s)).collect()
    }

    /// One residual's loss (see [`Self::cost`]).
    pub fn rho(self, e: f64, s: f64) -> f64 {
        match self {
            Loss::Cauchy => 0.5 * s * s * (e * e / (s * s)).ln_1p(),
            Loss::Huber(k) => {
                let (a, c) = (e.abs(), k * s);
                if a <= c {
                    0.5 * a * a
                } else {
                    c * (a - 0.5 * c)
                }
            }
            Loss::CauchyTail(k) => {
                let c = k * s;
                if e.abs() <= c {
                    0.5 * e * e
                } else {
                    0.5 * c * c * (1.0 + (e * e / (c * c)).ln())
                }
            }
        }
    }

    /// One residual's weight (see [`Self::weights`]): rho'(e) / e.
    pub fn weight(self, e: f64, s: f64) -> f64 {
        match self {
            Loss::Cauchy => 1.0 / (1.0 + e * e / (s * s)),
            Loss::Huber(k) => (k * s / e.abs()).min(1.0),
            Loss::CauchyTail(k) => ((k * s) * (k * s) / (e * e)).min(1.0),
        }
    }
}

/// Which loss each residual takes: `loss`, or `skewed_loss` where `skewed` says so.
#[derive(Clone, Debug)]
pub struct Losses {
    pub loss: Loss,
    pub skewed_loss: Loss,
    pub skewed: Option<Vec<bool>>,
}

impl Losses {
    /// Residual i's loss.
    fn of(&self, i: usize) -> Loss {
        match &self.skewed {
            Some(k) if k[i] => self.skewed_loss,
            _ => self.loss,
        }
    }

    /// The loss of residuals `r` at scale `s`.
    pub fn cost(&self, r: &[f64], s: f64) -> f64 {
        match &self.skewed {
            None => self.loss.cost(r, s),
            Some(_) => r.iter().enumerate().map(|(i, e)| self.of(i).rho(*e, s)).sum(),
        }
    }

    /// Each residual's weight in the normal equations.
    pub fn weights(&self, r: &[f64], s: f64) -> Vec<f64> {
        match &self.skewed {
            None => self.loss.weights(r, s),
            Some(_) => r.iter().enumerate().map(|(i, e)| self.of(i).weight(*e, s)).collect(),
        }
    }
}

/// The Cauchy loss of residuals `r` at scale `s`.
pub fn cauchy(r: &[f64], s: f64) -> f64 {
    Loss::Cauchy.cost(r, s)
}

/// The Cauchy loss's weight of each residual at scale `s` (the W of the normal equations).
pub fn cauchy_weights(r: &[f64], s: f64) -> Vec<f64> {
    Loss::Cauchy.weights(r, s)
}

/// J^T W J for the Jacobian's columns `cols` and the residuals' weights `wts` (W diagonal).
pub fn weighted_gram(cols: &[Vec<f64>], wts: &[f64]) -> Vec<Vec<f64>> {
    let np = cols.len();
    let mut a = vec![vec![0.0; np]; np];
    for i in 0..np {
        for j in 0..=i {
            let v: f64 = cols[i].iter().zip(&cols[j]).zip(wts).map(|((a, b), w)| a * b * w).sum();
            a[i][j] = v;
            a[j][i] = v;
        }
    }
    a
}

/// J^T W e for the Jacobian's columns `cols`, residuals (or any per-residual vector) `e` and
/// weights `wts`: the weighted gradient of the solver's steps and of the fit's bias terms.
pub fn weighted_gradient<'c>(cols: impl IntoIterator<Item = &'c Vec<f64>>, e: &[f64], wts: &[f64]) -> Vec<f64> {
    cols.into_iter()
        .map(|c| c.iter().zip(e).zip(wts).map(|((j, e), w)| j * e * w).sum())
        .collect()
}

/// Solves the symmetric positive definite system a x = b (Cholesky); `None` when it is not.
pub fn solve_spd(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let n = b.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
                // (also refuses NaN)
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                if !(s > 0.0) {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut y = vec![0.0; n];
    for i in 0..n {
        y[i] = (b[i] - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>()) / l[i][i];
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        x[i] = (y[i] - (i + 1..n).map(|k| l[k][i] * x[k]).sum::<f64>()) / l[i][i];
    }
    Some(x)
}

/// How a run goes.
#[derive(Clone, Debug)]
pub struct Config {
    /// Iterations at most.
    pub iters: u32,
    /// Smallest robust scale (residual units).
    pub min_scale: f64,
    /// The robust loss.
    pub loss: Loss,
    /// The loss of the residuals the problem calls skewed ([`LeastSquares::skewed`]).
    pub skewed_loss: Loss,
    /// The progress bar's task and label.
    pub task: &'static str,
    pub label: String,
}

/// Robust Levenberg-Marquardt from `x` (clamped to the bounds first). Polls `obs.should_stop()`
/// once per iteration and reports progress (the loss per residual).
pub fn solve<P: LeastSquares>(
    p: &mut P,
    mut x: Vec<f64>,
    cfg: &Config,
    obs: &dyn Observer,
) -> Result<Solution, P::Error> {
    let bounds = p.bounds();
    let np = bounds.len();
    let clamp = |x: &mut Vec<f64>| {
        for (v, (lo, hi)) in x.iter_mut().zip(&bounds) {
            *v = v.clamp(*lo, *hi);
        }
    };
    clamp(&mut x);
    let mut lambda = 1e-3;
    let mut r = p.residuals(&x)?;
    let mut losses = Losses {
        loss: cfg.loss,
        skewed_loss: cfg.skewed_loss,
        skewed: p.skewed(&r),
    };
    let mut s = robust_scale(&r, cfg.min_scale);
    let mut cost = losses.cost(&r, s);
    let mut jtj = vec![vec![0.0; np]; np];
    let mut iterations = 0;
    for it in 0..cfg.iters {
        if obs.should_stop() {
            return Err(Interrupted.into());
        }
        obs.progress(&Progress::new(
            cfg.task,
            it as u64,
            cfg.iters as u64,
            format!("{}: loss {:.3e}", cfg.label, cost / r.len().max(1) as f64),
        ));
        iterations = it + 1;
        s = robust_scale(&r, cfg.min_scale);
        losses.skewed = p.skewed(&r);
        cost = losses.cost(&r, s);
        let wts = losses.weights(&r, s);
        let cols = p.jacobian(&x, &r)?;
        assert_eq!(cols.len(), np, "one Jacobian column per parameter");
        let g = weighted_gradient(&cols, &r, &wts);
        jtj = weighted_gram(&cols, &wts);
        let max_diag = (0..np).map(|i| jtj[i][i]).fold(0.0f64, f64::max);
        let mut improved = false;
        for _ in 0..6 {
            let mut a = jtj.clone();
            for i in 0..np {
                // (a parameter the residuals do not see has a zero column: the floor keeps the
                // system solvable and leaves it in place)
                a[i][i] += lambda * jtj[i][i].max(1e-9 * max_diag).max(1e-300);
            }
            let Some(delta) = solve_spd(&a, &g.iter().map(|v| -v).collect::<Vec<_>>()) else {
                lambda *= 10.0;
                continue;
            };
            let mut xn: Vec<f64> = x.iter().zip(&delta).map(|(a, d)| a + d).collect();
            clamp(&mut xn);
            let rn = p.residuals(&xn)?;
            let cn = losses.cost(&rn, s);
            if cn < cost {
                let rel = (cost - cn) / cost.max(1e-300);
                x = xn;
                r = rn;
                cost = cn;
                lambda = (lambda / 3.0).max(1e-9);
                improved = rel > 1e-5;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    obs.finish(cfg.task);
    let weights = losses.weights(&r, s);
    Ok(Solution {
        x,
        cost,
        jtj,
        weights,
        scale: s,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use scratchart_observe::Silent;

    /// y = a exp(-b t) + c with a few gross outliers, b bounded.
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
        evals: u32,
    }

    impl LeastSquares for Decay {
        type Error = Interrupted;
        fn bounds(&self) -> Vec<(f64, f64)> {
            vec![(-10.0, 10.0), (0.0, 0.5), (-10.0, 10.0)]
        }
        fn residuals(&mut self, x: &[f64]) -> Result<Vec<f64>, Interrupted> {
            self.evals += 1;
            Ok(self
                .t
                .iter()
                .zip(&self.y)
                .map(|(t, y)| x[0] * (-x[1] * t).exp() + x[2] - y)
                .collect())
        }
        fn jacobian(&mut self, x: &[f64], _r: &[f64]) -> Result<Vec<Vec<f64>>, Interrupted> {
            Ok(vec![
                self.t.iter().map(|t| (-x[1] * t).exp()).collect(),
                self.t.iter().map(|t| -x[0] * t * (-x[1] * t).exp()).collect(),
                vec![1.0; self.t.len()],
            ])
        }
    }

    fn decay(b: f64) -> Decay {
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
        let mut y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, t)| 2.0 * (-b * t).exp() + 0.5 + 1e-3 * ((i * 7919 % 101) as f64 / 50.0 - 1.0))
            .collect();
        for i in [10, 50, 120, 180] {
            y[i] += 3.0; // outliers
        }
        Decay { t, y, evals: 0 }
    }

    fn cfg() -> Config {
        Config {
            iters: 50,
            min_scale: 1e-6,
            loss: Loss::Cauchy,
            skewed_loss: Loss::Cauchy,
            task: "test",
            label: "decay".into(),
        }
    }

    #[test]
    fn cauchys_tail_rejects_outliers_as_cauchy_does() {
        let mut p = decay(0.3);
        let cfg = Config {
            loss: Loss::CauchyTail(3.0),
            ..cfg()
        };
        let s = solve(&mut p, vec![1.0, 0.1, 0.0], &cfg, &Silent).unwrap();
        assert!(
            (s.x[0] - 2.0).abs() < 5e-3 && (s.x[1] - 0.3).abs() < 2e-3 && (s.x[2] - 0.5).abs() < 5e-3,
            "{:?}",
            s.x
        );
        for i in [10, 50, 120, 180] {
            assert!(s.weights[i] < 1e-3, "outlier {i} weight {}", s.weights[i]);
        }
    }

    #[test]
    fn recovers_a_decay_despite_outliers() {
        let mut p = decay(0.7);
        let s = solve(&mut p, vec![1.0, 0.2, 0.0], &cfg(), &Silent).unwrap();
        // b = 0.7 is outside its bounds: the solution stops at the bound 0.5.
        assert_eq!(s.x[1], 0.5, "{:?}", s.x);
        let mut p = decay(0.3);
        let s = solve(&mut p, vec![1.0, 0.1, 0.0], &cfg(), &Silent).unwrap();
        assert!(
            (s.x[0] - 2.0).abs() < 5e-3 && (s.x[1] - 0.3).abs() < 2e-3 && (s.x[2] - 0.5).abs() < 5e-3,
            "{:?}",
            s.x
        );
        assert!(p.evals < 60, "{} evaluations", p.evals);
        // A plain least-squares fit would be pulled by the outliers: the robust weights of
        // those points are small.
        for i in [10, 50, 120, 180] {
            assert!(s.weights[i] < 1e-3, "outlier {i} weight {}", s.weights[i]);
        }
    }

    /// The mean of max(0, mu + sigma Z): the model of a pixel whose noise is clipped at black.
    fn clipped_mean(mu: f64, sigma: f64) -> f64 {
        let t = mu / sigma;
        let phi = (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
        // Phi(t) by erf (Abramowitz and Stegun 7.1.26, error under 1.5e-7).
        let x = t.abs() / std::f64::consts::SQRT_2;
        let k = 1.0 / (1.0 + 0.3275911 * x);
        let poly = k * (0.254829592 + k * (-0.284496736 + k * (1.421413741 + k * (-1.453152027 + k * 1.061405429))));
        let erf = 1.0 - poly * (-x * x).exp();
        let cdf = 0.5 * (1.0 + erf.copysign(t));
        mu * cdf + sigma * phi
    }

    /// A level mu seen through noise clipped at black: the residuals are skewed.
    struct Clipped {
        y: Vec<f64>,
        sigma: f64,
        /// Whether the problem calls its residuals skewed.
        flagged: bool,
    }

    impl LeastSquares for Clipped {
        type Error = Interrupted;
        fn bounds(&self) -> Vec<(f64, f64)> {
            vec![(-1.0, 1.0)]
        }
        fn residuals(&mut self, x: &[f64]) -> Result<Vec<f64>, Interrupted> {
            let m = clipped_mean(x[0], self.sigma);
            Ok(self.y.iter().map(|y| m - y).collect())
        }
        fn jacobian(&mut self, x: &[f64], _r: &[f64]) -> Result<Vec<Vec<f64>>, Interrupted> {
            let h = 1e-6;
            let d = (clipped_mean(x[0] + h, self.sigma) - clipped_mean(x[0] - h, self.sigma)) / (2.0 * h);
            Ok(vec![vec![d; self.y.len()]])
        }
        fn skewed(&mut self, _r: &[f64]) -> Option<Vec<bool>> {
            self.flagged.then(|| vec![true; self.y.len()])
        }
    }

    #[test]
    fn a_quadratic_core_estimates_the_mean_of_noise_clipped_at_black_and_cauchy_does_not() {
        // A dark plate at half its noise above black (the flash photos' plate: 1% noise, the
        // plate at a few thousandths), 40,000 pixels; Box-Muller draws of a fixed generator.
        let (mu, sigma, n) = (0.005, 0.01, 40_000);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let y: Vec<f64> = (0..n)
            .map(|_| {
                let (u, v) = (uniform().max(1e-300), uniform());
                let z = (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos();
                (mu + sigma * z).max(0.0)
            })
            .collect();
        // The estimate's own spread: about sigma / sqrt(n) over the clipped mean's slope.
        let se = sigma / (n as f64).sqrt() / (clipped_mean(mu + 1e-6, sigma) - clipped_mean(mu - 1e-6, sigma)) * 2e-6;
        let fit = |loss: Loss, skewed_loss: Loss, flagged: bool| {
            let mut p = Clipped {
                y: y.clone(),
                sigma,
                flagged,
            };
            let cfg = Config {
                loss,
                skewed_loss,
                ..cfg()
            };
            solve(&mut p, vec![0.02], &cfg, &Silent).unwrap().x[0]
        };
        let huber = fit(Loss::Huber(3.0), Loss::Cauchy, false);
        let tail = fit(Loss::CauchyTail(3.0), Loss::Cauchy, false);
        let cauchy = fit(Loss::Cauchy, Loss::CauchyTail(3.0), false);
        // Cauchy for the rest, the quadratic core where the problem says the noise is skewed.
        let split = fit(Loss::Cauchy, Loss::CauchyTail(3.0), true);
        assert_eq!(split, tail, "the skewed residuals take the skewed loss");
        assert!((huber - mu).abs() < 3.0 * se, "Huber at 3: {huber} for {mu} (se {se})");
        assert!(
            (tail - mu).abs() < 3.0 * se,
            "Cauchy's tail at 3: {tail} for {mu} (se {se})"
        );
        assert!((cauchy - mu).abs() > 10.0 * se, "Cauchy: {cauchy} for {mu} (se {se})");
    }

    struct Stop;
    impl Observer for Stop {
        fn should_stop(&self) -> bool {
            true
        }
    }

    #[test]
    fn stops_when_asked() {
        let mut p = decay(0.3);
        assert_eq!(
            solve(&mut p, vec![1.0, 0.1, 0.0], &cfg(), &Stop).unwrap_err(),
            Interrupted
        );
    }

    #[test]
    fn solves_spd_systems_and_refuses_others() {
        let a = vec![vec![4.0, 2.0], vec![2.0, 3.0]];
        let x = solve_spd(&a, &[2.0, 1.0]).unwrap();
        assert!((4.0 * x[0] + 2.0 * x[1] - 2.0).abs() < 1e-12 && (2.0 * x[0] + 3.0 * x[1] - 1.0).abs() < 1e-12);
        assert!(solve_spd(&[vec![1.0, 2.0], vec![2.0, 1.0]], &[1.0, 1.0]).is_none());
    }
}
