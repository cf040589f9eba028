//! Bright blobs in a photo, at any scale of a range: the candidates for the card's marks (step
//! 1 of [`super`]).
use crate::photo::median;
use crate::photo::pixel_noise;
use crate::photo::Gray;

/// A bright blob: a candidate for a mark.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blob {
    pub at: [f64; 2],
    /// The Gaussian scale it answered most at, pixels.
    pub sigma: f64,
    /// Its response in noise sigmas of that scale.
    pub snr: f64,
}

/// Separable Gaussian blur (clamped edges), kernel to 3 sigma.
pub(crate) fn gauss(img: &[f32], w: usize, h: usize, sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 {
        return img.to_vec();
    }
    let r = (3.0 * sigma).ceil() as i64;
    let k: Vec<f32> = (-r..=r)
        .map(|x| (-((x * x) as f64) / (2.0 * sigma * sigma)).exp() as f32)
        .collect();
    let s: f32 = k.iter().sum();
    let k: Vec<f32> = k.iter().map(|v| v / s).collect();
    let mut tmp = vec![0f32; img.len()];
    for y in 0..h {
        let row = &img[y * w..(y + 1) * w];
        for x in 0..w {
            let mut acc = 0.0;
            for (i, kv) in k.iter().enumerate() {
                let xx = (x as i64 + i as i64 - r).clamp(0, w as i64 - 1) as usize;
                acc += kv * row[xx];
            }
            tmp[y * w + x] = acc;
        }
    }
    let mut out = vec![0f32; img.len()];
    for y in 0..h {
        for (i, kv) in k.iter().enumerate() {
            let yy = (y as i64 + i as i64 - r).clamp(0, h as i64 - 1) as usize;
            let src = &tmp[yy * w..(yy + 1) * w];
            let dst = &mut out[y * w..(y + 1) * w];
            for x in 0..w {
                dst[x] += kv * src[x];
            }
        }
    }
    out
}

/// Bright blobs of Gaussian scale `sigma_lo` to `sigma_hi` in `img` (display values).
pub fn blobs(img: &Gray, sigma_lo: f64, sigma_hi: f64) -> Vec<Blob> {
    let (w, h) = (img.width as usize, img.height as usize);
    let step = 1.26f64;
    let n = ((sigma_hi / sigma_lo).ln() / step.ln()).ceil().max(1.0) as usize + 1;
    let sigmas: Vec<f64> = (0..=n + 1).map(|k| sigma_lo * step.powi(k as i32 - 1)).collect();
    let g: Vec<Vec<f32>> = sigmas.iter().map(|&s| gauss(&img.data, w, h, s)).collect();
    // Scale-normalized difference of Gaussians, and its noise (MAD over the image).
    let mut dog: Vec<Vec<f32>> = Vec::with_capacity(g.len() - 1);
    let mut noise = Vec::with_capacity(g.len() - 1);
    // The response's noise: its robust spread over the image, and at least what the photo's
    // pixel noise (or 8-bit quantization) gives through the kernel: for independent pixel
    // noise s, var(G1 - G2) = s^2 (1/(4 pi s1^2) + 1/(4 pi s2^2) - 1/(pi (s1^2 + s2^2))).
    let pn = pixel_noise(img).max(0.5 / 255.0);
    for k in 0..g.len() - 1 {
        let d: Vec<f32> = g[k].iter().zip(&g[k + 1]).map(|(a, b)| a - b).collect();
        let mut sample: Vec<f32> = d.iter().step_by(3).map(|v| v.abs()).collect();
        let (s1, s2) = (sigmas[k] * sigmas[k], sigmas[k + 1] * sigmas[k + 1]);
        let pi = std::f64::consts::PI;
        let floor = pn
            * (1.0 / (4.0 * pi * s1) + 1.0 / (4.0 * pi * s2) - 1.0 / (pi * (s1 + s2)))
                .max(0.0)
                .sqrt();
        noise.push((1.4826 * median(&mut sample)).max(floor as f32).max(1e-6));
        dog.push(d);
    }
    let strongest = (1..dog.len() - 1)
        .map(|k| dog[k].iter().cloned().fold(0.0f32, f32::max) / noise[k])
        .fold(0.0f32, f32::max);
    let mut out = Vec::new();
    for k in 1..dog.len() - 1 {
        let thr = (4.0f32).max(0.1 * strongest);
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let v = dog[k][y * w + x];
                if v / noise[k] < thr {
                    continue;
                }
                // A maximum over its own scale's neighbours (not over the next scales: two
                // marks close together merge at a larger scale, whose response can then exceed
                // each mark's own; the same blob at several scales is merged below).
                let mut is_max = true;
                'nb: for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        if dx == 0 && dy == 0 {
                            continue;
                        }
                        let q = ((y as i64 + dy) as usize) * w + (x as i64 + dx) as usize;
                        if dog[k][q] > v {
                            is_max = false;
                            break 'nb;
                        }
                    }
                }
                if is_max {
                    // Sub-pixel: the parabola through the neighbours on each axis.
                    let c = |q: usize| dog[k][q] as f64;
                    let i = y * w + x;
                    let fx = {
                        let (a, b, cc) = (c(i - 1), c(i), c(i + 1));
                        let den = a - 2.0 * b + cc;
                        if den < 0.0 {
                            (0.5 * (a - cc) / den).clamp(-0.5, 0.5)
                        } else {
                            0.0
                        }
                    };
                    let fy = {
                        let (a, b, cc) = (c(i - w), c(i), c(i + w));
                        let den = a - 2.0 * b + cc;
                        if den < 0.0 {
                            (0.5 * (a - cc) / den).clamp(-0.5, 0.5)
                        } else {
                            0.0
                        }
                    };
                    out.push(Blob {
                        at: [x as f64 + 0.5 + fx, y as f64 + 0.5 + fy],
                        sigma: sigmas[k] * step.sqrt(),
                        snr: (v / noise[k]) as f64,
                    });
                }
            }
        }
    }
    // The same blob answers at neighbouring scales: keep the strongest within its own size.
    out.sort_by(|a, b| b.snr.total_cmp(&a.snr));
    let mut kept: Vec<Blob> = Vec::new();
    for b in out {
        if kept
            .iter()
            .all(|k| (k.at[0] - b.at[0]).hypot(k.at[1] - b.at[1]) > 1.5 * k.sigma.min(b.sigma))
        {
            kept.push(b);
        }
    }
    kept
}
