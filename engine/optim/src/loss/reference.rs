//! Float64 CPU twin of the loss kernels (test oracle, never a fallback).
use super::{LossConfig, Pyramid};

const SMOOTH: [f64; 3] = [0.25, 0.5, 0.25];
const DERIV: [f64; 3] = [-0.5, 0.0, 0.5];

/// Tap (ox, oy) of linear filter k (as `bank_w` in `shaders/inc/loss_bank.glsl`).
pub fn bank_w(k: usize, ox: i32, oy: i32) -> f64 {
    let (x, y) = ((ox + 1) as usize, (oy + 1) as usize);
    match k {
        0 => SMOOTH[x] * SMOOTH[y],
        1 => DERIV[x] * SMOOTH[y],
        2 => SMOOTH[x] * DERIV[y],
        _ => {
            let a = if k == 3 { ox - oy } else { ox + oy };
            if a == 0 {
                0.0
            } else {
                a.signum() as f64 * if a.abs() == 2 { 2.0 } else { 1.0 } / 8.0
            }
        }
    }
}

fn cl(x: i64, n: u32) -> usize {
    x.clamp(0, n as i64 - 1) as usize
}

/// (NaN gives 0 here: the reference loss of a bad pixel is that of a black one.)
fn display(l: f64) -> f64 {
    if l > 0.0 {
        crate::model::display::display(l)
    } else {
        0.0
    }
}

/// Pyramid levels (each W x H, top row first) of one image.
fn levels(img: &[f64], w: u32, h: u32, n: u32) -> Vec<(u32, u32, Vec<f64>)> {
    let mut out = vec![(w, h, img.to_vec())];
    for _ in 1..n.max(1) {
        let (pw, ph, prev) = out.last().unwrap();
        let (w2, h2) = ((pw / 2).max(1), (ph / 2).max(1));
        let mut next = vec![0.0; (w2 * h2) as usize];
        for y in 0..h2 {
            for x in 0..w2 {
                let mut acc = 0.0;
                for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    acc += prev[cl((2 * y + b) as i64, *ph) * *pw as usize + cl((2 * x + a) as i64, *pw)];
                }
                next[(y * w2 + x) as usize] = 0.25 * acc;
            }
        }
        out.push((w2, h2, next));
    }
    out
}

/// The 9 channels of every pixel of one level.
fn features(w: u32, h: u32, x: &[f64]) -> (Vec<[f64; 5]>, Vec<[f64; 9]>) {
    let mut pre = vec![[0.0; 5]; (w * h) as usize];
    let mut ch = vec![[0.0; 9]; (w * h) as usize];
    for py in 0..h as i64 {
        for px in 0..w as i64 {
            let mut r = [0.0; 5];
            for oy in -1..=1 {
                for ox in -1..=1 {
                    let v = x[cl(py + oy as i64, h) * w as usize + cl(px + ox as i64, w)];
                    for (k, rk) in r.iter_mut().enumerate() {
                        *rk += bank_w(k, ox, oy) * v;
                    }
                }
            }
            let i = (py * w as i64 + px) as usize;
            pre[i] = r;
            ch[i][0] = r[0];
            for k in 1..5 {
                ch[i][2 * k - 1] = r[k].max(0.0);
                ch[i][2 * k] = (-r[k]).max(0.0);
            }
        }
    }
    (pre, ch)
}

fn gram(ch: &[[f64; 9]]) -> [[f64; 9]; 9] {
    let mut g = [[0.0; 9]; 9];
    for c in ch {
        for i in 0..9 {
            for j in 0..9 {
                g[i][j] += c[i] * c[j];
            }
        }
    }
    let n = ch.len() as f64;
    g.iter_mut().flatten().for_each(|v| *v /= n);
    g
}

/// Loss of one view and dE/dL of its pixels: (pixel term, Gram term, gradient).
/// `l`: linear render, `t`: target display values, both W x H top row first.
pub fn view_loss(l: &[f64], t: &[f64], w: u32, h: u32, cfg: &LossConfig) -> (f64, f64, Vec<f64>) {
    view_loss_crosstalk(l, t, w, h, cfg, &[])
}

/// [`view_loss`] with the cross-talk term: `dirs` are this view's directions u_vk (W x H each,
/// norm sqrt(kappa)); the pixel term adds lambda_p sum_k (B . u_vk)^2 / N.
pub fn view_loss_crosstalk(
    l: &[f64],
    t: &[f64],
    w: u32,
    h: u32,
    cfg: &LossConfig,
    dirs: &[Vec<f64>],
) -> (f64, f64, Vec<f64>) {
    let (gc, gs) = {
        let s = (-0.5 / (cfg.sigma as f64).powi(2)).exp();
        (1.0 / (1.0 + 2.0 * s), s / (1.0 + 2.0 * s))
    };
    let g1 = [gs, gc, gs];
    let n = (w * h) as usize;
    let img: Vec<f64> = l.iter().map(|&v| display(v)).collect();
    // Pixel term.
    let mut bimg = vec![0.0; n];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let mut acc = 0.0;
            for oy in -1..=1i64 {
                for ox in -1..=1i64 {
                    let c = cl(y + oy, h) * w as usize + cl(x + ox, w);
                    acc += g1[(ox + 1) as usize] * g1[(oy + 1) as usize] * (img[c] - t[c]);
                }
            }
            bimg[(y * w as i64 + x) as usize] = acc;
        }
    }
    let c: Vec<f64> = dirs
        .iter()
        .map(|u| u.iter().zip(&bimg).map(|(a, b)| a * b).sum())
        .collect();
    let lp = cfg.lambda_p as f64 * (bimg.iter().map(|b| b * b).sum::<f64>() + c.iter().map(|c| c * c).sum::<f64>())
        / n as f64;
    // dE/dB = 2 lambda_p / N (B + sum_k c_k u_k)
    let beff: Vec<f64> = (0..n)
        .map(|i| bimg[i] + c.iter().zip(dirs).map(|(c, u)| c * u[i]).sum::<f64>())
        .collect();
    let mut d_img = vec![0.0; n];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let gp = 2.0 * cfg.lambda_p as f64 / n as f64 * beff[(y * w as i64 + x) as usize];
            for oy in -1..=1i64 {
                for ox in -1..=1i64 {
                    let c = cl(y + oy, h) * w as usize + cl(x + ox, w);
                    d_img[c] += g1[(ox + 1) as usize] * g1[(oy + 1) as usize] * gp;
                }
            }
        }
    }
    // Gram term: forward per level, then backward coarse to fine.
    let lv = levels(&img, w, h, cfg.levels);
    let lt = levels(t, w, h, cfg.levels);
    let mut lg = 0.0;
    let mut dpre_levels = Vec::new();
    for ((lw, lh, x), (_, _, tx)) in lv.iter().zip(&lt) {
        let (pre, ch) = features(*lw, *lh, x);
        let (_, cht) = features(*lw, *lh, tx);
        let (g, gt) = (gram(&ch), gram(&cht));
        let mut r = [[0.0; 9]; 9];
        for i in 0..9 {
            for j in 0..9 {
                let d = g[i][j] - gt[i][j];
                lg += d * d;
                r[i][j] = 2.0 * cfg.lambda_g as f64 * d;
            }
        }
        let np = ch.len() as f64;
        let dpre: Vec<[f64; 5]> = pre
            .iter()
            .zip(&ch)
            .map(|(p, c)| {
                let mut dc = [0.0; 9];
                for a in 0..9 {
                    dc[a] = 2.0 / np * (0..9).map(|b| r[a][b] * c[b]).sum::<f64>();
                }
                let mut out = [0.0; 5];
                out[0] = dc[0];
                for k in 1..5 {
                    out[k] = if p[k] > 0.0 {
                        dc[2 * k - 1]
                    } else if p[k] < 0.0 {
                        -dc[2 * k]
                    } else {
                        0.0
                    };
                }
                out
            })
            .collect();
        dpre_levels.push(dpre);
    }
    let lg = cfg.lambda_g as f64 * lg;
    let mut d_up: Vec<f64> = Vec::new();
    for s in (0..lv.len()).rev() {
        let (lw, lh, _) = &lv[s];
        let (lw, lh) = (*lw, *lh);
        let mut dx = vec![0.0; (lw * lh) as usize];
        for py in 0..lh as i64 {
            for px in 0..lw as i64 {
                let gp = dpre_levels[s][(py * lw as i64 + px) as usize];
                for oy in -1..=1 {
                    for ox in -1..=1 {
                        let c = cl(py + oy as i64, lh) * lw as usize + cl(px + ox as i64, lw);
                        for (k, g) in gp.iter().enumerate() {
                            dx[c] += bank_w(k, ox, oy) * g;
                        }
                    }
                }
            }
        }
        if s + 1 < lv.len() {
            let (uw, uh, _) = &lv[s + 1];
            for uy in 0..*uh {
                for ux in 0..*uw {
                    let gu = d_up[(uy * uw + ux) as usize];
                    for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        dx[cl((2 * uy + b) as i64, lh) * lw as usize + cl((2 * ux + a) as i64, lw)] += 0.25 * gu;
                    }
                }
            }
        }
        d_up = dx;
    }
    let dl: Vec<f64> = (0..n)
        .map(|i| {
            let g = crate::model::display::GAMMA;
            let slope = (1.0 / g) * l[i].max(1e-4).powf(1.0 / g - 1.0);
            (d_img[i] + d_up[i]) * slope
        })
        .collect();
    (lp, lg, dl)
}

/// The loss of every view of a render laid out as `pyr` level 0 (the renderer's image).
pub fn loss(image: &[f32], targets: &[Vec<f32>], pyr: &Pyramid, cfg: &LossConfig) -> (Vec<(f64, f64)>, Vec<f64>) {
    loss_crosstalk(image, targets, pyr, cfg, &[], &[])
}

/// View k's target over view v's picture, centred and scaled to norm sqrt(kappa) (0 where flat):
/// the direction u_vk of the cross-talk term.
pub fn crosstalk_direction(t_k: &[f32], picture_v: &[bool], kappa: f64) -> Vec<f64> {
    let n = picture_v.iter().filter(|&&b| b).count().max(1) as f64;
    let mu = t_k
        .iter()
        .zip(picture_v)
        .filter(|(_, &b)| b)
        .map(|(&x, _)| x as f64)
        .sum::<f64>()
        / n;
    let u: Vec<f64> = t_k
        .iter()
        .zip(picture_v)
        .map(|(&x, &b)| if b { x as f64 - mu } else { 0.0 })
        .collect();
    let norm = u.iter().map(|x| x * x).sum::<f64>().sqrt();
    let s = if norm > 0.0 { kappa.sqrt() / norm } else { 0.0 };
    u.iter().map(|x| x * s).collect()
}

/// [`loss`] with the cross-talk term of `cfg.crosstalk` over every ordered pair of `among`
/// (views of the same size), each view's picture in `pictures`.
pub fn loss_crosstalk(
    image: &[f32],
    targets: &[Vec<f32>],
    pyr: &Pyramid,
    cfg: &LossConfig,
    pictures: &[Vec<bool>],
    among: &[usize],
) -> (Vec<(f64, f64)>, Vec<f64>) {
    let mut per_view = Vec::new();
    let mut dl = vec![0.0; image.len()];
    for (v, t) in targets.iter().enumerate() {
        let s = &pyr.segs[v];
        let (o, n) = (s.off as usize, (s.w * s.h) as usize);
        let l: Vec<f64> = image[o..o + n].iter().map(|&x| x as f64).collect();
        let t: Vec<f64> = t.iter().map(|&x| x as f64).collect();
        let dirs: Vec<Vec<f64>> = if cfg.crosstalk > 0.0 && among.contains(&v) {
            among
                .iter()
                .filter(|&&k| k != v && targets[k].len() == n && pyr.segs[k].w == s.w)
                .map(|&k| crosstalk_direction(&targets[k], &pictures[v], cfg.crosstalk as f64))
                .collect()
        } else {
            Vec::new()
        };
        let (lp, lg, d) = view_loss_crosstalk(&l, &t, s.w, s.h, cfg, &dirs);
        dl[o..o + n].copy_from_slice(&d);
        per_view.push((lp, lg));
    }
    (per_view, dl)
}
