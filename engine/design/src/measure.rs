//! Image measures: Gaussian blur, SSIM, correlation, and each view's quality (its correlation
//! with its target and its cross-talk with the others). The design's reports and its set-up
//! sheet use them; they know nothing of the design job.
use scratchart_model::scene::Scene;

/// The 3x3 clamp-to-edge Gaussian blur of the loss (sigma in pixels).
pub fn blur3(img: &[f32], w: u32, h: u32, sigma: f32) -> Vec<f64> {
    let g = blur3_weights(sigma);
    (0..img.len()).map(|k| blur3_at(img, w, h, &g, k)).collect()
}

/// [`blur3`] at the pixels of `mask` only (the same values there, bit for bit), 0 elsewhere:
/// what a correlation over `mask` reads.
pub fn blur3_within(img: &[f32], w: u32, h: u32, sigma: f32, mask: &[bool]) -> Vec<f64> {
    let g = blur3_weights(sigma);
    let mut out = vec![0.0; img.len()];
    for (k, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
        out[k] = blur3_at(img, w, h, &g, k);
    }
    out
}

/// The 3-tap Gaussian's weights (normalized) for `sigma` pixels.
fn blur3_weights(sigma: f32) -> [f64; 3] {
    let s = (-0.5 / (sigma as f64 * sigma as f64)).exp();
    [s / (1.0 + 2.0 * s), 1.0 / (1.0 + 2.0 * s), s / (1.0 + 2.0 * s)]
}

/// Pixel `k` of [`blur3`] (the image's edge pixels repeated beyond it).
fn blur3_at(img: &[f32], w: u32, h: u32, g: &[f64; 3], k: usize) -> f64 {
    let (wi, hi) = (w as i64, h as i64);
    let (x, y) = (k as i64 % wi, k as i64 / wi);
    let mut acc = 0.0;
    for oy in -1..=1i64 {
        for ox in -1..=1i64 {
            let c = (y + oy).clamp(0, hi - 1) * wi + (x + ox).clamp(0, wi - 1);
            acc += g[(ox + 1) as usize] * g[(oy + 1) as usize] * img[c as usize] as f64;
        }
    }
    acc
}

/// SSIM (Wang et al. 2004: 11x11 Gaussian window, sigma 1.5, K1 = 0.01, K2 = 0.03, range 1) of
/// two images in [0, 1], averaged over the pixels where `mask` is set (the on-plate pixels, so the
/// always-black surroundings do not inflate it). Windows clamp to the image.
pub fn ssim(a: &[f64], b: &[f64], w: u32, h: u32, mask: &[bool]) -> f64 {
    let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
    let r = 5i64;
    let gw: Vec<f64> = (-r..=r).map(|o| (-(o * o) as f64 / (2.0 * 1.5 * 1.5)).exp()).collect();
    let (wi, hi) = (w as i64, h as i64);
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 0..hi {
        for x in 0..wi {
            if !mask[(y * wi + x) as usize] {
                continue;
            }
            let (mut sw, mut ma, mut mb, mut aa, mut bb, mut ab) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            for oy in -r..=r {
                let yy = y + oy;
                if yy < 0 || yy >= hi {
                    continue;
                }
                for ox in -r..=r {
                    let xx = x + ox;
                    if xx < 0 || xx >= wi {
                        continue;
                    }
                    let k = gw[(ox + r) as usize] * gw[(oy + r) as usize];
                    let (va, vb) = (a[(yy * wi + xx) as usize], b[(yy * wi + xx) as usize]);
                    sw += k;
                    ma += k * va;
                    mb += k * vb;
                    aa += k * va * va;
                    bb += k * vb * vb;
                    ab += k * va * vb;
                }
            }
            let (ma, mb) = (ma / sw, mb / sw);
            let va = aa / sw - ma * ma;
            let vb = bb / sw - mb * mb;
            let cov = ab / sw - ma * mb;
            sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            n += 1;
        }
    }
    if n == 0 {
        1.0
    } else {
        sum / n as f64
    }
}

/// SSIM of the blurred display render (clamped to [0, 1]) against the target, over on-plate pixels.
pub fn view_ssim(scene: &Scene, v: usize, display: &[f32], target: &[f32], sigma: f32) -> f64 {
    let (w, h) = (scene.views[v].camera.width, scene.views[v].camera.height);
    let clamped: Vec<f32> = display.iter().map(|x| x.clamp(0.0, 1.0)).collect();
    let a = blur3(&clamped, w, h, sigma);
    let b: Vec<f64> = target.iter().map(|&x| x as f64).collect();
    let mask = scratchart_model::camera::on_plate_mask(scene, v);
    ssim(&a, &b, w, h, &mask)
}

/// Pearson correlation of `a` and `b` over the pixels where `mask` holds (0 when either is flat).
pub fn correlation(a: &[f64], b: &[f64], mask: &[bool]) -> f64 {
    let (mut n, mut sa, mut sb) = (0.0, 0.0, 0.0);
    for ((&x, &y), &m) in a.iter().zip(b).zip(mask) {
        if m {
            n += 1.0;
            sa += x;
            sb += y;
        }
    }
    if n < 2.0 {
        return 0.0;
    }
    let (ma, mb) = (sa / n, sb / n);
    let (mut cab, mut caa, mut cbb) = (0.0, 0.0, 0.0);
    for ((&x, &y), &m) in a.iter().zip(b).zip(mask) {
        if m {
            cab += (x - ma) * (y - mb);
            caa += (x - ma) * (x - ma);
            cbb += (y - mb) * (y - mb);
        }
    }
    if caa <= 0.0 || cbb <= 0.0 {
        0.0
    } else {
        cab / (caa * cbb).sqrt()
    }
}

/// Quality of one view: correlation of the blurred render with its target inside the picture,
/// and cross-talk with every other view's target (DECISIONS: the correlation of this render with
/// view k's target, less the correlation of the two targets; a perfect render has 0). The render
/// is blurred by the loss's Gaussian, so "the two targets" are this view's target blurred alike
/// and view k's: a render equal to its picture then has cross-talk 0 exactly (against the
/// unblurred target, a picture of fine texture would show the blur's own change of correlation
/// as cross-talk: 0.056 for a picture of coins against one of a rocket).
#[derive(Clone, Debug, PartialEq)]
pub struct ViewQuality {
    pub corr: f64,
    /// Per other view k (k != this view; same image size): (k, cross-talk, raw correlation).
    pub crosstalk: Vec<(usize, f64, f64)>,
}

/// [`ViewQuality`] of every view. `pictures[v]`: where view v's picture is (the comparison
/// region); renders are blurred with the loss's Gaussian of `sigma` pixels first.
pub fn quality(
    scene: &Scene,
    displays: &[Vec<f32>],
    targets: &[Vec<f32>],
    pictures: &[Vec<bool>],
    sigma: f32,
) -> Vec<ViewQuality> {
    let n = scene.views.len();
    let blurred: Vec<Vec<f64>> = (0..n)
        .map(|v| {
            let (w, h) = (scene.views[v].camera.width, scene.views[v].camera.height);
            let c: Vec<f32> = displays[v].iter().map(|x| x.clamp(0.0, 1.0)).collect();
            blur3(&c, w, h, sigma)
        })
        .collect();
    let t: Vec<Vec<f64>> = targets.iter().map(|t| t.iter().map(|&x| x as f64).collect()).collect();
    (0..n)
        .map(|j| {
            let corr = correlation(&blurred[j], &t[j], &pictures[j]);
            let pairs: Vec<usize> = (0..n).filter(|&k| k != j && t[k].len() == t[j].len()).collect();
            // A perfect render: the target, clamped and blurred as the render is.
            let perfect = (!pairs.is_empty()).then(|| {
                let (w, h) = (scene.views[j].camera.width, scene.views[j].camera.height);
                let c: Vec<f32> = targets[j].iter().map(|x| x.clamp(0.0, 1.0)).collect();
                blur3(&c, w, h, sigma)
            });
            let crosstalk = pairs
                .into_iter()
                .map(|k| {
                    let raw = correlation(&blurred[j], &t[k], &pictures[j]);
                    let base = correlation(perfect.as_ref().unwrap(), &t[k], &pictures[j]);
                    (k, raw - base, raw)
                })
                .collect();
            ViewQuality { corr, crosstalk }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use scratchart_model::scene::Scene;

    /// A render equal to its picture has cross-talk 0 with every other view, however fine the
    /// picture's texture (the blur changes its correlation with the others; the measure blurs
    /// both sides alike); a render that adds another view's picture shows it.
    #[test]
    fn a_perfect_render_has_no_crosstalk() {
        let light = crate::scenes::orbit_light(300.0, 60.0, 0.0, 1.0e4);
        let scene = Scene {
            plate: scratchart_model::scene::Plate::flat(100.0),
            views: crate::scenes::ring_views(2, 45.0, 300.0, 100.0, 24, &light),
            scratches: Vec::new(),
        };
        let (w, h) = (24usize, 24usize);
        // View 0: a checkerboard of single pixels plus a ramp; view 1: another ramp.
        let t0: Vec<f32> = (0..w * h)
            .map(|i| 0.3 + 0.4 * ((i % w + i / w) % 2) as f32 + 0.01 * (i % w) as f32)
            .collect();
        let t1: Vec<f32> = (0..w * h)
            .map(|i| 0.2 + 0.02 * (i / w) as f32 + 0.005 * (i % w) as f32)
            .collect();
        let pictures = vec![vec![true; w * h]; 2];
        let targets = vec![t0.clone(), t1.clone()];
        let q = quality(&scene, &targets, &targets, &pictures, 1.0);
        for v in &q {
            for &(_, x, _) in &v.crosstalk {
                assert!(x.abs() < 1e-12, "a perfect render's cross-talk: {x}");
            }
        }
        // Against the unblurred target the blur alone would read as cross-talk here.
        let unblurred = correlation(
            &t0.iter().map(|&x| x as f64).collect::<Vec<_>>(),
            &t1.iter().map(|&x| x as f64).collect::<Vec<_>>(),
            &pictures[0],
        );
        assert!(
            (q[0].crosstalk[0].2 - unblurred).abs() > 0.05,
            "the test's picture must be fine enough"
        );
        // View 0 rendered with view 1's picture added leaks it.
        let leaky: Vec<f32> = t0.iter().zip(&t1).map(|(a, b)| 0.7 * a + 0.3 * b).collect();
        let q = quality(&scene, &[leaky, t1.clone()], &targets, &pictures, 1.0);
        assert!(q[0].crosstalk[0].1 > 0.1, "a leak shows: {:?}", q[0].crosstalk);
    }
}
