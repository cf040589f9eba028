//! The fit of what the carving did differently (see the module doc of [`super`]): five numbers,
//! each in units whose central-difference step (half a unit) moves the photos a little and
//! smoothly: the depth change in um, the width scale as 100 ln s, the carving's shift in
//! 10 um steps along x and y, and its turn about the plate's centre in hundredths of a degree.
use super::*;

/// The fitted parameters' count and names.
pub(super) const N: usize = 5;
const NAMES: [&str; N] = ["depth change", "width scale", "shift along x", "shift along y", "turn"];

/// The parameters in their fit units.
pub(super) type X = [f64; N];

/// What a parameter vector means.
pub(super) struct Carving {
    pub(super) dz_mm: f64,
    pub(super) width_scale: f64,
    pub(super) shift_mm: [f64; 2],
    pub(super) turn_deg: f64,
}

pub(super) fn meaning(x: &X) -> Carving {
    Carving {
        dz_mm: x[0] * 1e-3,
        width_scale: (x[1] / 100.0).exp(),
        shift_mm: [x[2] * 0.01, x[3] * 0.01],
        turn_deg: x[4] * 0.01,
    }
}

/// Solves a x = b (Gaussian elimination with partial pivoting); None when singular.
fn solve(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for c in 0..N {
        let p = (c..N).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if !(a[p][c].abs() > 1e-300) {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..N {
            let f = a[r][c] / a[c][c];
            for k in c..N {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; N];
    for c in (0..N).rev() {
        let s: f64 = (c + 1..N).map(|k| a[c][k] * x[k]).sum();
        x[c] = (b[c] - s) / a[c][c];
    }
    Some(x)
}

/// The inverse of `a` (None when singular).
fn inverse(a: &[[f64; N]; N]) -> Option<[[f64; N]; N]> {
    let mut inv = [[0.0; N]; N];
    for c in 0..N {
        let mut e = [0.0; N];
        e[c] = 1.0;
        let col = solve(*a, e)?;
        for r in 0..N {
            inv[r][c] = col[r];
        }
    }
    Some(inv)
}

/// x kept within the range looked at.
fn clamp(mut x: X) -> X {
    x[0] = x[0].clamp(-DZ_RANGE_MM * 1e3, DZ_RANGE_MM * 1e3);
    x[1] = x[1].clamp(100.0 * SCALE_RANGE.0.ln(), 100.0 * SCALE_RANGE.1.ln());
    for k in 2..4 {
        x[k] = x[k].clamp(-100.0 * SHIFT_RANGE_MM, 100.0 * SHIFT_RANGE_MM);
    }
    x[4] = x[4].clamp(-100.0 * TURN_RANGE_DEG, 100.0 * TURN_RANGE_DEG);
    x
}

/// The parameter at the edge of the range looked at, if one is.
fn at_edge(x: &X) -> Option<&'static str> {
    let out: X = std::array::from_fn(|k| x[k] * (1.0 + 1e-9));
    let c = clamp(out);
    (0..N).find(|&k| x[k] != 0.0 && c[k] != out[k]).map(|k| NAMES[k])
}

/// J^T J and J^T r at x (central differences: 2 N renders, and one at x).
fn normal_equations(p: &Problem, x: &X, renders: &mut usize) -> Result<([[f64; N]; N], [f64; N], usize)> {
    let h = 0.5;
    let mut cols = Vec::with_capacity(N);
    for k in 0..N {
        let (mut a, mut b) = (*x, *x);
        a[k] += h;
        b[k] -= h;
        let (ra, rb) = (p.eval(&a)?.residual, p.eval(&b)?.residual);
        *renders += 2;
        cols.push(
            ra.iter()
                .zip(&rb)
                .map(|(u, v)| (u - v) / (2.0 * h))
                .collect::<Vec<f64>>(),
        );
    }
    let r = p.eval(x)?.residual;
    *renders += 1;
    let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
    let mut jtj = [[0.0; N]; N];
    let mut g = [0.0; N];
    for i in 0..N {
        for j in 0..N {
            jtj[i][j] = dot(&cols[i], &cols[j]);
        }
        g[i] = dot(&cols[i], &r);
    }
    Ok((jtj, g, r.len()))
}

/// The grid over the depth change and the width scale, then damped Gauss-Newton over all five.
pub(super) fn fit(p: &Problem, obs: &dyn Observer) -> Result<(Found, Eval)> {
    let mut renders = 0;
    let mut best: Option<(X, f64)> = None;
    for dz in [-30.0, -15.0, 0.0, 15.0, 30.0] {
        for ls in [-15.0, 0.0, 15.0] {
            let x = [dz, ls, 0.0, 0.0, 0.0];
            let f = ssr(&p.eval(&x)?.residual);
            renders += 1;
            if best.is_none_or(|b| f < b.1) {
                best = Some((x, f));
            }
        }
    }
    let (mut x, mut f) = best.expect("a grid");
    let describe = |x: &X, f: f64, n: usize| {
        let c = meaning(x);
        format!(
            "{:+.2} um deeper, width x{:.4}, shifted ({:+.3}, {:+.3}) mm, turned {:+.3} deg; residual {:.5} rms",
            1e3 * c.dz_mm,
            c.width_scale,
            c.shift_mm[0],
            c.shift_mm[1],
            c.turn_deg,
            (f / n.max(1) as f64).sqrt()
        )
    };
    let mut lambda = 1e-3;
    let mut jtj = [[0.0; N]; N];
    obs.info(&format!("grid: {}", describe(&x, f, p.eval(&x)?.residual.len())));
    for it in 0..15 {
        let (a, g, n) = normal_equations(p, &x, &mut renders)?;
        jtj = a;
        let mut moved = false;
        for _ in 0..8 {
            let mut d = jtj;
            for k in 0..N {
                d[k][k] *= 1.0 + lambda;
            }
            let Some(step) = solve(d, g.map(|v| -v)) else {
                break;
            };
            let y = clamp(std::array::from_fn(|k| x[k] + step[k]));
            let fy = ssr(&p.eval(&y)?.residual);
            renders += 1;
            if fy < f {
                moved = (0..N).any(|k| (y[k] - x[k]).abs() > 0.02);
                (x, f) = (y, fy);
                lambda = (lambda * 0.3).max(1e-6);
                break;
            }
            lambda *= 10.0;
        }
        obs.info(&format!("step {}: {}", it + 1, describe(&x, f, n)));
        if !moved {
            break;
        }
    }
    let e = p.eval(&x)?;
    renders += 1;
    let dof = e.residual.len().saturating_sub(N + p.photos.len()).max(1);
    let s2 = ssr(&e.residual) / dof as f64;
    let cov = inverse(&jtj).map(|c| c.map(|row| row.map(|v| v * s2)));
    let sd = |k: usize| cov.map_or(f64::INFINITY, |c| c[k][k].max(0.0).sqrt());
    let c = meaning(&x);
    let edge = at_edge(&x);
    Ok((
        Found {
            dz_mm: c.dz_mm,
            dz_sd_mm: sd(0) * 1e-3,
            width_scale: c.width_scale,
            width_scale_sd: c.width_scale * sd(1) / 100.0,
            shift_mm: c.shift_mm,
            shift_sd_mm: [sd(2) * 0.01, sd(3) * 0.01],
            turn_deg: c.turn_deg,
            turn_sd_deg: sd(4) * 0.01,
            correlation: cov.map_or(0.0, |c| c[0][1] / (c[0][0] * c[1][1]).sqrt()),
            residual_sd: s2.sqrt(),
            renders,
            at_edge: edge,
        },
        e,
    ))
}
