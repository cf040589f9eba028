//! The fit of what the carving did differently (see the module doc of [`super`]): six numbers,
//! each in units whose central-difference step (half a unit) moves the photos a little and
//! smoothly: the depth change in um, the width scale as 100 ln s, the carving's shift in
//! 10 um steps along x and y, its turn about the plate's centre in hundredths of a degree, and
//! the depth scale (the machine's Z moving a times what it is told) as 100 ln a. The depth scale
//! is held at 1 unless asked for (`--depth-scale`, [`fit`]): for a V-bit a deeper cut and a wider
//! bit are nearly one number (their correlation about -0.99). A bit whose angle differs from its
//! calibration but not its flat was explained with the depth scale free as a 1.037 times wider
//! bit in a Z moving 1.085 times too far, +- 0.002 (the truth: 1.10 and 1); a Z moving 1.08 times
//! too far is read with it held as a 1.053 times wider bit, +- 0.003 (the truth: 1); and with
//! the machine's error and 1% photo noise the free fit wandered to 1.38 +- 0.38, the width's
//! uncertainty with it to 0.17. Asked for, it is fitted and stated (or refused when not
//! pinned) with everything else.
use super::*;

/// The fitted parameters' count and names.
pub(super) const N: usize = 8;
const NAMES: [&str; N] = [
    "depth change",
    "width scale",
    "shift along x",
    "shift along y",
    "turn",
    "depth scale",
    "lamp's turn",
    "lamp's tilt",
];
/// Degrees of the lamp's turn and tilt per fit unit.
const LAMP_UNIT_DEG: f64 = 0.2;
/// The largest uncertainty of the depth scale (1 sigma) that `inspect --depth-scale` states.
pub(super) const DEPTH_SCALE_TOLERANCE: f64 = 0.025;

/// The parameters in their fit units.
pub(super) type X = [f64; N];

/// What a parameter vector means.
pub(super) struct Carving {
    pub(super) dz_mm: f64,
    pub(super) width_scale: f64,
    pub(super) shift_mm: [f64; 2],
    pub(super) turn_deg: f64,
    pub(super) depth_scale: f64,
    /// The lamp as it stood: turned about the plate's normal and raised, degrees.
    pub(super) lamp_deg: [f64; 2],
}

pub(super) fn meaning(x: &X) -> Carving {
    Carving {
        dz_mm: x[0] * 1e-3,
        width_scale: (x[1] / 100.0).exp(),
        shift_mm: [x[2] * 0.01, x[3] * 0.01],
        turn_deg: x[4] * 0.01,
        depth_scale: (x[5] / 100.0).exp(),
        lamp_deg: [x[6] * LAMP_UNIT_DEG, x[7] * LAMP_UNIT_DEG],
    }
}

/// Solves a x = b for any size K (Gaussian elimination with partial pivoting); None when
/// singular (also the registration's warp, [`super::photos`]).
pub(super) fn solve<const K: usize>(mut a: [[f64; K]; K], mut b: [f64; K]) -> Option<[f64; K]> {
    for c in 0..K {
        let p = (c..K).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if !(a[p][c].abs() > 1e-300) {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..K {
            let f = a[r][c] / a[c][c];
            for k in c..K {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; K];
    for c in (0..K).rev() {
        let s: f64 = (c + 1..K).map(|k| a[c][k] * x[k]).sum();
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
    x[5] = x[5].clamp(100.0 * DEPTH_SCALE_RANGE.0.ln(), 100.0 * DEPTH_SCALE_RANGE.1.ln());
    for k in 6..8 {
        x[k] = x[k].clamp(-LAMP_RANGE_DEG / LAMP_UNIT_DEG, LAMP_RANGE_DEG / LAMP_UNIT_DEG);
    }
    x
}

/// The parameter at the edge of the range looked at, if one is.
fn at_edge(x: &X) -> Option<&'static str> {
    let out: X = std::array::from_fn(|k| x[k] * (1.0 + 1e-9));
    let c = clamp(out);
    (0..N).find(|&k| x[k] != 0.0 && c[k] != out[k]).map(|k| NAMES[k])
}

/// J^T J and J^T r at x (central differences: 2 N renders, and one at x).
fn normal_equations(
    p: &Problem,
    x: &X,
    free: &[bool; N],
    renders: &mut usize,
) -> Result<([[f64; N]; N], [f64; N], usize)> {
    let h = 0.5;
    let mut cols = Vec::with_capacity(N);
    for k in 0..N {
        if !free[k] {
            cols.push(Vec::new());
            continue;
        }
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
        if !free[i] {
            // A held parameter: its row and column the identity's, its step 0.
            jtj[i][i] = 1.0;
        }
    }
    Ok((jtj, g, r.len()))
}

/// The grid over the depth change and the width scale (the rest as designed): its best point.
fn grid(p: &Problem, renders: &mut usize) -> Result<(X, f64)> {
    let mut best: Option<(X, f64)> = None;
    for dz in [-30.0, -15.0, 0.0, 15.0, 30.0] {
        for ls in [-15.0, 0.0, 15.0] {
            let x = [dz, ls, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            let f = ssr(&p.eval(&x)?.residual);
            *renders += 1;
            if best.is_none_or(|b| f < b.1) {
                best = Some((x, f));
            }
        }
    }
    Ok(best.expect("a grid"))
}

/// One line on x.
fn describe(x: &X, f: f64, n: usize) -> String {
    let c = meaning(x);
    format!(
        "{:+.2} um deeper, width x{:.4}, shifted ({:+.3}, {:+.3}) mm, turned {:+.3} deg, depths x{:.4}, lamp \
         {:+.2} deg round and {:+.2} up; residual {:.5} rms",
        1e3 * c.dz_mm,
        c.width_scale,
        c.shift_mm[0],
        c.shift_mm[1],
        c.turn_deg,
        c.depth_scale,
        c.lamp_deg[0],
        c.lamp_deg[1],
        (f / n.max(1) as f64).sqrt()
    )
}

/// Damped Gauss-Newton over the `free` parameters from (x, f): where it ends, and J^T J there.
fn descend(
    p: &Problem,
    (mut x, mut f): (X, f64),
    free: &[bool; N],
    renders: &mut usize,
    obs: &dyn Observer,
) -> Result<(X, [[f64; N]; N])> {
    let mut lambda = 1e-3;
    let mut jtj = [[0.0; N]; N];
    for it in 0..15 {
        let (a, g, n) = normal_equations(p, &x, free, renders)?;
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
            let y = clamp(std::array::from_fn(|k| if free[k] { x[k] + step[k] } else { x[k] }));
            let fy = ssr(&p.eval(&y)?.residual);
            *renders += 1;
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
    Ok((x, jtj))
}

/// What x means, with the uncertainties of the `free` parameters (the residual's variance at x
/// times (J^T J)^-1).
fn found_at(p: &Problem, x: &X, jtj: &[[f64; N]; N], free: &[bool; N], renders: usize) -> Result<(Found, Eval)> {
    let e = p.eval(x)?;
    let n_free = free.iter().filter(|f| **f).count();
    let dof = e.residual.len().saturating_sub(n_free + p.photos.len()).max(1);
    let s2 = ssr(&e.residual) / dof as f64;
    let cov = inverse(jtj).map(|c| c.map(|row| row.map(|v| v * s2)));
    let sd = |k: usize| {
        if !free[k] {
            return 0.0;
        }
        cov.map_or(f64::INFINITY, |c| c[k][k].max(0.0).sqrt())
    };
    let c = meaning(x);
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
            depth_scale: c.depth_scale,
            depth_scale_sd: c.depth_scale * sd(5) / 100.0,
            depth_scale_held: !free[5],
            lamp_deg: c.lamp_deg,
            lamp_sd_deg: [sd(6) * LAMP_UNIT_DEG, sd(7) * LAMP_UNIT_DEG],
            lamp_held: !free[7],
            correlation: cov.map_or(0.0, |c| c[0][1] / (c[0][0] * c[1][1]).sqrt()),
            residual_sd: s2.sqrt(),
            renders: renders + 1,
            at_edge: at_edge(x),
        },
        e,
    ))
}

/// The grid, then damped Gauss-Newton with the depth scale held at 1: the machine's Z moving as
/// told is assumed (a maker checks it with a known move; see the module doc). Asked for
/// (`--depth-scale`), the fit goes on with it free from there and that is what it found (the
/// report refuses it when the depth scale is not pinned). The lamp's turn and tilt are free
/// with the rest unless held (`--lamp-as-designed`). The carving's shift and turn are held
/// at none where every photo was located by the marks (the marks moved with it).
pub(super) fn fit(p: &Problem, obs: &dyn Observer) -> Result<(Found, Eval)> {
    let mut renders = 0;
    let start = grid(p, &mut renders)?;
    obs.info(&format!(
        "grid: {}",
        describe(&start.0, start.1, p.eval(&start.0)?.residual.len())
    ));
    let mut all = [true; N];
    // A lamp overhead does not move when turned about the plate's normal: its turn is held
    // there (its tilt still moves it).
    all[6] = p.fit_lamp && !p.lamp_overhead();
    all[7] = p.fit_lamp;
    // Photos located by the marks see the marks moved with the carving: its place against them
    // is none, and only a view's own camera sees where it sits.
    let placed_by_marks = p.photos.iter().all(|ph| ph.located);
    for k in 2..5 {
        all[k] = !placed_by_marks;
    }
    let mut held = all;
    held[5] = false;
    let (xh, jh) = descend(p, start, &held, &mut renders, obs)?;
    if !p.fit_depth_scale {
        return found_at(p, &xh, &jh, &held, renders + 1);
    }
    let fh = ssr(&p.eval(&xh)?.residual);
    obs.info("and with the machine's depth scale free:");
    let (xa, ja) = descend(p, (xh, fh), &all, &mut renders, obs)?;
    found_at(p, &xa, &ja, &all, renders + 2)
}
