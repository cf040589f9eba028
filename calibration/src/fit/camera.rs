//! The camera part of the fit's model: from the engine's linear render of the card to what the
//! photo shows (the optics' blur and registration shift at the render's resolution, exposure and
//! shading, the sensor's clipping, the pixels adding up their subpixels, the display encoding),
//! and the Jacobian columns of an off-pose photo's camera from the image's motion.
use scratchart_model::camera::ViewGeom;

use super::Evaluator;
use scratchart_optim::least_squares::cauchy;

/// Table points of a [`ChannelClip`].
const CLIP_N: usize = 4096;

/// The grey's light of a colour photo whose channels have their own gains (a white balance):
/// each channel clips at full scale where its own light does, so a bright groove's grey is
/// Rec. 709 of the channels each clipped, not the grey's light clipped once. With a 25% cast and
/// 1.4x exposure the grey's single clip gave a measured profile's wall shape (w/W 2.16 +- 0.07
/// for 1.97) and its widest rung 8 um narrow, both photos agreeing. Scaled so that light below
/// every channel's clip passes as it is (the exposure keeps its meaning); tabulated over light.
#[derive(Clone, Debug)]
pub(crate) struct ChannelClip {
    /// Light at which the last channel clips (the grey is full white beyond it).
    top: f32,
    /// The grey's light at `top` x i / `CLIP_N`.
    table: Vec<f32>,
}

impl ChannelClip {
    /// The clip of channels with `gains` (each channel's light over green's); `None` where they
    /// are within 1% of each other (they clip together: the grey's light clipped at 1).
    pub(crate) fn new(gains: [f64; 3]) -> Option<ChannelClip> {
        use crate::photo::LUMA;
        let (lo, hi) = gains
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, b), g| (a.min(*g), b.max(*g)));
        if !(lo > 0.0) || !hi.is_finite() || hi / lo < 1.01 {
            return None;
        }
        let disp = crate::encoding::encode;
        let lin = crate::encoding::decode;
        let s = Self::gain_scale(gains);
        let top = 1.0 / (s * lo);
        let table = (0..=CLIP_N)
            .map(|i| {
                let l = top * i as f64 / CLIP_N as f64;
                let grey: f64 = LUMA
                    .iter()
                    .zip(&gains)
                    .map(|(w, g)| w * disp((s * g * l).min(1.0)))
                    .sum();
                lin(grey) as f32
            })
            .collect();
        Some(ChannelClip { top: top as f32, table })
    }

    /// The scale s of the channels' gains under which light below every clip passes unchanged in
    /// the mid-tones: sum_c w_c (s g_c l)^(1/2.2) = l^(1/2.2).
    pub(crate) fn gain_scale(gains: [f64; 3]) -> f64 {
        use crate::photo::LUMA;
        LUMA.iter()
            .zip(&gains)
            .map(|(w, g)| w * g.powf(1.0 / 2.2))
            .sum::<f64>()
            .powf(-2.2)
    }

    /// Per view, the clip of its photo's channels (`Data::gains`).
    pub(super) fn for_views(data: &super::Data) -> Vec<Option<ChannelClip>> {
        (0..data.capture.views.len())
            .map(|v| data.gains.get(v).and_then(|g| ChannelClip::new(*g)))
            .collect()
    }

    /// The grey's light for the light `l` (green's scale).
    pub(crate) fn apply(&self, l: f32) -> f32 {
        if !(l > 0.0) {
            return 0.0;
        }
        let u = (l / self.top).min(1.0) * CLIP_N as f32;
        let i = (u.floor() as usize).min(CLIP_N - 1);
        let f = u - i as f32;
        self.table[i] * (1.0 - f) + self.table[i + 1] * f
    }
}

use scratchart_model::par::par_map;

impl Evaluator<'_, '_> {
    /// The Jacobian columns (d residual / d x_k) of the camera terms `ks` of photos taken off
    /// the capture pose, from the image's motion rather than new renders: moving the camera by
    /// dx_k moves the light of each plate point from pixel p to p + F_k(p) dx_k (F_k from the
    /// two cameras' projections), so the blurred supersampled image changes by
    /// -grad(B) . F_k dx_k, which the pixels then add up. What the move does to the light itself
    /// (the half-vector turns by a fraction of a degree per millimetre) is left out of the
    /// derivative; every step is still judged on a real render.
    /// `blurred`: each view's blurred supersampled image at `x` ([`Self::blurred`]; its
    /// gradients move it).
    pub(super) fn motion_columns(&self, x: &[f64], blurred: &[Vec<f32>], ks: &[usize]) -> Vec<Vec<f64>> {
        let k_ss = self.ss as usize;
        let pred0: Vec<Vec<f32>> = par_map(blurred.len(), |v| self.expose_masked(&blurred[v], v, x));
        let base = self.residuals(&pred0);
        par_map(ks.len(), |i| {
            let k = ks[i];
            let v = self.lay.camera_view(k).expect("a camera term");
            let h = self.lay.params[k].step;
            let mut xh = x.to_vec();
            xh[k] += h;
            let (g0, g1) = (
                ViewGeom::new(&self.render_view(x, v)),
                ViewGeom::new(&self.render_view(&xh, v)),
            );
            let c = &self.data.capture.views[v].camera;
            let (w, hh) = (k_ss * c.width as usize, k_ss * c.height as usize);
            let b = &blurred[v];
            let mut moved = b.clone();
            // (Only the subpixels of the mask's pixels: the residuals read no others.)
            let mask = &self.data.masks[v];
            let pw = c.width as usize;
            for yy in 1..hh - 1 {
                for xx in 1..w - 1 {
                    if !mask[(yy / k_ss) * pw + xx / k_ss] {
                        continue;
                    }
                    let (sx, sy) = (xx as f64 + 0.5, yy as f64 + 0.5);
                    let Some(q) = g0.hit(sx, sy) else { continue };
                    let Some(p1) = g1.project([q[0], q[1], 0.0]) else {
                        continue;
                    };
                    let (fx, fy) = (p1.0 - sx, p1.1 - sy);
                    let i = yy * w + xx;
                    let gx = 0.5 * (b[i + 1] - b[i - 1]) as f64;
                    let gy = 0.5 * (b[i + w] - b[i - w]) as f64;
                    moved[i] = (b[i] as f64 - (gx * fx + gy * fy)) as f32;
                }
            }
            let mut pred = pred0.clone();
            pred[v] = self.expose_masked(&moved, v, x);
            let r1 = self.residuals(&pred);
            r1.iter().zip(&base).map(|(a, b)| (a - b) / h).collect()
        })
    }

    /// Model display images from linear renders and the camera part of `x` (see `blurred` and
    /// `expose`), as `simulate` makes photos.
    pub(super) fn predict(&self, lin: &[Vec<f32>], x: &[f64]) -> Vec<Vec<f32>> {
        par_map(lin.len(), |v| self.expose(&self.blurred(&lin[v], v, x), v, x))
    }

    /// [`Self::predict`] at the pixels the residuals read alone (each photo's mask; 0 elsewhere).
    pub(super) fn predict_masked(&self, lin: &[Vec<f32>], x: &[f64]) -> Vec<Vec<f32>> {
        par_map(lin.len(), |v| self.expose_masked(&self.blurred(&lin[v], v, x), v, x))
    }

    /// [`Self::expose`] at the pixels of photo v's mask alone.
    pub(super) fn expose_masked(&self, b: &[f32], v: usize, x: &[f64]) -> Vec<f32> {
        self.expose_where(b, v, x, Some(&self.data.masks[v]))
    }

    /// The light the optics bring to the sensor of view v, from a linear render at `ss` times
    /// the photo's resolution: a Gaussian blur, moved by the registration shift (both in the
    /// photo's pixels), at that resolution. Blurring the render at the photo's own resolution
    /// instead would blur light that the render has already added up over whole pixels, which
    /// is not what a camera does with a groove a pixel wide: against a photo rendered at 4 times
    /// the resolution (a camera's continuous optics) that gave residuals up to 0.08 and biased a
    /// V angle by 4 degrees; twice the resolution leaves 0.016 (examples/cmp_probe).
    pub(super) fn blurred(&self, img: &[f32], v: usize, x: &[f64]) -> Vec<f32> {
        let c = &self.data.capture.views[v].camera;
        let k = self.ss as usize;
        let (w, h) = (c.width as usize, c.height as usize);
        crate::simulate::optics_blur(img, k * w, k * h, k as f64 * self.lay.blur(x, v))
    }

    /// What the sensor of view v makes of the light `b` (at `ss` times its resolution): the
    /// exposure and the shading across the frame scale it, the sensor clips it at full scale
    /// where it falls (at its own fine pixels: a bright groove clips inside a photo's pixel that
    /// the fit then averages, so clipping after the averaging would leave the fit's pixel
    /// brighter than the photo's and bias the widths low), each of the fit's pixels adds up its
    /// subpixels, and the display transform encodes the result.
    pub(super) fn expose(&self, b: &[f32], v: usize, x: &[f64]) -> Vec<f32> {
        self.expose_where(b, v, x, None)
    }

    /// [`Self::expose`] at the pixels of `only` alone (the others 0), the same bits there: what
    /// the residuals read (the photo's mask), a quarter of the photo on the guide's capture.
    pub(super) fn expose_where(&self, b: &[f32], v: usize, x: &[f64], only: Option<&[bool]>) -> Vec<f32> {
        let c = &self.data.capture.views[v].camera;
        let (w, h) = (c.width as usize, c.height as usize);
        let k = self.ss as usize;
        let ws = k * w;
        let u = self.lay.ln_noise(x, v);
        let transfer = self.transfer[v].as_ref().map(|t| t.at_scale(u));
        // Subpixel i's light as the sensor gets it (`sensor`), lifted by a shrunk photo's clipped
        // noise (`noise`).
        let sensor = self.sensor(b, v, x);
        let sub = |i: usize| -> f32 {
            let l = sensor(i);
            match &transfer {
                Some(t) => t.subpixel(l),
                None => l,
            }
        };
        let power = (-self.lay.tone(x, v)).exp() as f32;
        let norm = 1.0 / (k * k) as f32;
        let mut out = vec![0f32; w * h];
        for y in 0..h {
            for xo in 0..w {
                let p = y * w + xo;
                if only.is_some_and(|m| !m[p]) {
                    continue;
                }
                // The pixel adds up its subpixels as `reduce` does (row by row).
                let l = if k == 1 {
                    sub(p)
                } else {
                    let mut o = 0f32;
                    for sy in 0..k {
                        let row = (y * k + sy) * ws + xo * k;
                        let mut acc = 0.0;
                        for sx in 0..k {
                            acc += sub(row + sx);
                        }
                        o += acc * norm;
                    }
                    o
                };
                let l = if power != 1.0 && l > 0.0 { l.powf(power) } else { l };
                let d = crate::encoding::encode_f32(l).min(1.0);
                // A photo used as taken: its pixel's expected value under clipped noise.
                out[p] = match &transfer {
                    Some(t) => t.pixel(d),
                    None => d,
                };
            }
        }
        out
    }

    /// The shading across view v's frame at `ss` times its resolution, as factors per column
    /// and per row of the `n` subpixels: exp(gx px + gy py + q (px^2 + py^2)) = exp(gx px + q
    /// px^2) exp(gy py + q py^2), one exponential per column and per row, not per subpixel.
    fn shading(&self, v: usize, x: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
        let c = &self.data.capture.views[v].camera;
        let [gx, gy, q] = self.lay.shade(x, v);
        let k = self.ss as usize;
        let (w, hh) = (c.width as usize, c.height as f64);
        let ws = k * w;
        let (cx, cy, s) = (0.5 * w as f64, 0.5 * hh, 2.0 / hh);
        let kf = k as f64;
        let along = |n: usize, g: f64, c0: f64| -> Vec<f64> {
            (0..n)
                .map(|j| {
                    let p = ((j as f64 + 0.5) / kf - c0) * s;
                    (g * p + q * p * p).exp()
                })
                .collect()
        };
        (along(ws, gx, cx), along(n / ws.max(1), gy, cy))
    }

    /// The light of view v's subpixels (at `ss` times its resolution) as the sensor gets it:
    /// `b` scaled by the exposure and the shading, clipped at full scale (see `expose`).
    pub(super) fn light(&self, b: &[f32], v: usize, x: &[f64]) -> Vec<f32> {
        (0..b.len()).map(self.sensor(b, v, x)).collect()
    }

    /// Subpixel i's light of `b` as view v's sensor gets it ([`Self::light`]).
    fn sensor<'s>(&'s self, b: &'s [f32], v: usize, x: &[f64]) -> impl Fn(usize) -> f32 + 's {
        let e = self.lay.exposure(x, v);
        let ws = self.ss as usize * self.data.capture.views[v].camera.width as usize;
        let (fx, fy) = self.shading(v, x, b.len());
        let clip = &self.clip[v];
        move |i| {
            let f = fx[i % ws] * fy[i / ws];
            let l = (b[i] as f64 * e * f) as f32;
            match clip {
                Some(c) => c.apply(l),
                None => l.min(1.0),
            }
        }
    }

    /// The log exposure of view `v` that fits its photo best with the rest of `x` (a scan in
    /// steps of 1 over [-10, 10], then golden-section search; no render).
    pub(super) fn best_exposure(&self, v: usize, lin: &[f32], x: &[f64]) -> f64 {
        let b = self.blurred(lin, v, x);
        let k = self.lay.n_tool + 1 + v;
        let cost = |le: f64| {
            let mut xe = x.to_vec();
            xe[k] = le;
            let r: Vec<f64> = self
                .expose_masked(&b, v, &xe)
                .iter()
                .zip(self.photo(v))
                .zip(&self.data.masks[v])
                .filter(|(_, m)| **m)
                .map(|((m, p), _)| (m - p) as f64)
                .collect();
            cauchy(&r, 0.01)
        };
        let mut best = (f64::INFINITY, 0.0);
        for step in -10..=10 {
            let c = cost(step as f64);
            if c < best.0 {
                best = (c, step as f64);
            }
        }
        let (mut a, mut b) = (best.1 - 1.0, best.1 + 1.0);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        // Golden section: each step keeps one of its two inner points (and its cost).
        let (mut m1, mut m2) = (b - g * (b - a), a + g * (b - a));
        let (mut c1, mut c2) = (cost(m1), cost(m2));
        for _ in 0..16 {
            if c1 < c2 {
                (b, m2, c2) = (m2, m1, c1);
                m1 = b - g * (b - a);
                c1 = cost(m1);
            } else {
                (a, m1, c1) = (m1, m2, c2);
                m2 = a + g * (b - a);
                c2 = cost(m2);
            }
        }
        0.5 * (a + b)
    }
}

/// Turns `camera` about its eye so that its image moves by (-dx, -dy) of its pixels (the
/// registration shift: the model's pixel p then shows what was at p + (dx, dy), x to the right,
/// y down), exactly, with nothing resampled: a kernel moved by a sub-pixel amount blurs by an
/// amount that changes with the phase, and needed a blur floor that a sharp photo does not have.
pub(super) fn pan(camera: &mut scratchart_model::scene::Camera, dx: f64, dy: f64) {
    let basis = camera.basis();
    let (f, r, u) = (basis.fwd, basis.right, basis.up);
    let dist = (glam::DVec3::from(camera.target) - glam::DVec3::from(camera.eye)).length();
    // Pixels per unit of the image plane at distance 1: H / (2 tan(fov/2)).
    let f_px = 0.5 * camera.height as f64 / (0.5 * camera.fov_y_deg).to_radians().tan();
    // The new axis points at what pixel centre + (dx, dy) showed: right by dx, down by dy.
    let g = (f + (dx / f_px) * r - (dy / f_px) * u).normalize();
    camera.target = (glam::DVec3::from(camera.eye) + dist * g).to_array();
    // Keep the frame upright as it was: the up vector stays in the plane of the old up and the
    // new axis (the roll is the pose's own term).
    camera.up = u.to_array();
}

#[cfg(test)]
mod tests {
    use super::ChannelClip;

    #[test]
    fn channels_with_their_own_gains_clip_one_after_another() {
        // Equal gains: the grey's light clipped once, as before.
        assert!(ChannelClip::new([1.0, 1.0, 1.0]).is_none());
        assert!(ChannelClip::new([1.004, 1.0, 0.997]).is_none());
        // A warm cast: red 25% over green, blue 20% under.
        let c = ChannelClip::new([1.25, 1.0, 0.8]).unwrap();
        // Mid-tones pass (within the difference of sRGB from a power law).
        for l in [0.05f32, 0.2, 0.4] {
            assert!((c.apply(l) - l).abs() < 0.01 * l, "{l}: {}", c.apply(l));
        }
        // Red clips first, below where the grey's light reaches 1: the grey bends early...
        let s = ChannelClip::gain_scale([1.25, 1.0, 0.8]);
        let red_clip = (1.0 / (s * 1.25)) as f32;
        assert!(red_clip < 1.0);
        let slope = |l: f32| (c.apply(l + 0.01) - c.apply(l)) / 0.01;
        assert!(slope(red_clip + 0.02) < 0.9 * slope(red_clip - 0.05));
        // ...and goes on rising past 1 until blue clips too, at full white.
        assert!(c.apply(1.0) < 1.0 && c.apply(1.05) > c.apply(1.0));
        assert!((c.apply(c.top) - 1.0).abs() < 1e-4 && c.apply(10.0) == c.apply(c.top));
        assert_eq!(c.apply(0.0), 0.0);
    }
}
