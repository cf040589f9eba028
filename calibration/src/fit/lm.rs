//! Levenberg-Marquardt on the fit's robust (Cauchy) loss. The Jacobian: the columns of the
//! parameters that move the grooves (tool, z offset, alpha) from the engine's directional
//! derivatives (`Evaluator::tangent_columns`, one pass per 7 parameters); the eyes of photos
//! taken off the capture pose (they move the camera, not the grooves) by forward differences of
//! renders; exposure, blur and registration by forward differences of the camera model alone.
use scratchart::observe::{Observer, Progress};

use super::layout::Layout;
use super::{Evaluator, FitError};

pub(super) fn robust_scale(r: &[f64]) -> f64 {
    let mut a: Vec<f64> = r.iter().map(|x| x.abs()).collect();
    let n = a.len();
    let mad = *a.select_nth_unstable_by(n / 2, |p, q| p.total_cmp(q)).1;
    (1.4826 * mad).max(0.002)
}

pub(super) fn cauchy(r: &[f64], s: f64) -> f64 {
    r.iter().map(|x| 0.5 * s * s * (x * x / (s * s)).ln_1p()).sum()
}

/// Solves the symmetric positive system a x = b (Cholesky); `None` when not positive definite.
pub(super) fn solve_spd(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let n = b.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
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

/// Levenberg-Marquardt from `x` with the z offset (if any) kept in `off_range`.
pub(super) fn refine(
    ev: &mut Evaluator,
    mut x: Vec<f64>,
    off_range: Option<(f64, f64)>,
    iters: u32,
    obs: &dyn Observer,
    label: &str,
) -> Result<(Vec<f64>, f64, Vec<Vec<f64>>, Vec<f64>, f64), FitError> {
    let np = ev.lay.params.len();
    let clamp = |x: &mut Vec<f64>, lay: &Layout| {
        for (k, q) in lay.params.iter().enumerate() {
            x[k] = x[k].clamp(q.lo, q.hi);
        }
        if let (Some(i), Some((lo, hi))) = (lay.offset, off_range) {
            x[i] = x[i].clamp(lo, hi);
        }
    };
    clamp(&mut x, &ev.lay);
    let mut lambda = 1e-3;
    let (mut r, mut lin) = ev.eval(&x, None)?;
    let mut s = robust_scale(&r);
    let mut cost = cauchy(&r, s);
    let mut jtj = vec![vec![0.0; np]; np];
    for it in 0..iters {
        if obs.should_stop() {
            return Err(FitError::Interrupted);
        }
        obs.progress(&Progress {
            task: "fit",
            done: it as u64,
            total: iters as u64,
            message: format!("{label}: loss {:.3e}", cost / r.len() as f64),
        });
        s = robust_scale(&r);
        cost = cauchy(&r, s);
        let wts: Vec<f64> = r.iter().map(|e| 1.0 / (1.0 + e * e / (s * s))).collect();
        // The grooves' parameters: derivatives from the engine.
        let eyes: Vec<usize> = ev.lay.pose_at.iter().flatten().flat_map(|&i| i..i + 3).collect();
        let grooves: Vec<usize> = (0..np)
            .filter(|k| ev.lay.params[*k].render && !eyes.contains(k))
            .collect();
        let mut tangent = ev.tangent_columns(&x, &grooves)?.into_iter();
        // The rest by forward differences (away from the nearer bound).
        let mut cols: Vec<Vec<f64>> = Vec::with_capacity(np);
        for k in 0..np {
            if grooves.contains(&k) {
                cols.push(tangent.next().expect("one column per groove parameter"));
                continue;
            }
            let q = &ev.lay.params[k];
            let mut xh = x.clone();
            let mut h = q.step;
            let (lo, hi) = match (ev.lay.offset == Some(k), off_range) {
                (true, Some(rg)) => (rg.0.max(q.lo), rg.1.min(q.hi)),
                _ => (q.lo, q.hi),
            };
            if x[k] + h > hi {
                h = -h;
            }
            if x[k] + h < lo {
                h = 0.5 * (hi - lo);
                xh[k] = lo;
                h = (lo + h) - x[k];
            }
            xh[k] = x[k] + h;
            let (rh, _) = if q.render {
                ev.eval(&xh, None)?
            } else {
                ev.eval(&xh, Some(&lin))?
            };
            cols.push(rh.iter().zip(&r).map(|(a, b)| (a - b) / h).collect());
        }
        let mut g = vec![0.0; np];
        for i in 0..np {
            g[i] = cols[i].iter().zip(&r).zip(&wts).map(|((j, e), w)| j * e * w).sum();
            for j in 0..=i {
                let v: f64 = cols[i]
                    .iter()
                    .zip(&cols[j])
                    .zip(&wts)
                    .map(|((a, b), w)| a * b * w)
                    .sum();
                jtj[i][j] = v;
                jtj[j][i] = v;
            }
        }
        let max_diag = (0..np).map(|i| jtj[i][i]).fold(0.0f64, f64::max);
        let mut improved = false;
        for _ in 0..6 {
            let mut a = jtj.clone();
            for i in 0..np {
                // (a parameter the photos do not see, such as a profile width above the surface,
                // has a zero column: the floor keeps the system solvable and leaves it in place)
                a[i][i] += lambda * jtj[i][i].max(1e-9 * max_diag).max(1e-300);
            }
            let Some(delta) = solve_spd(&a, &g.iter().map(|v| -v).collect::<Vec<_>>()) else {
                lambda *= 10.0;
                continue;
            };
            let mut xn: Vec<f64> = x.iter().zip(&delta).map(|(a, d)| a + d).collect();
            clamp(&mut xn, &ev.lay);
            let need_render = (0..np).any(|k| ev.lay.params[k].render && xn[k] != x[k]);
            let (rn, linn) = if need_render {
                ev.eval(&xn, None)?
            } else {
                ev.eval(&xn, Some(&lin))?
            };
            let cn = cauchy(&rn, s);
            if cn < cost {
                let rel = (cost - cn) / cost.max(1e-300);
                x = xn;
                r = rn;
                lin = linn;
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
    obs.finish("fit");
    let wts: Vec<f64> = r.iter().map(|e| 1.0 / (1.0 + e * e / (s * s))).collect();
    Ok((x, cost, jtj, wts, s))
}
