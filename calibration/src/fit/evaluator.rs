//! The fit's evaluator at work: the card rendered as a tool cuts it, the model photo made of
//! the render (exposure, blur, shading, the photo's clipped noise, JPEG) and compared with
//! each photo.
use super::camera::pan;
use super::*;

impl Evaluator<'_, '_> {
    /// Photo v as the model is compared with it now.
    pub(super) fn photo(&self, v: usize) -> &[f32] {
        match &self.compared {
            Some(p) => &p[v],
            None => &self.data.photos[v],
        }
    }

    /// The card's ladder as `tool` cuts it (the fiducial marks are left out of the render and
    /// their squares out of the loss: they are for registration, and their crossing hatches are
    /// what the scratch model represents least well): every cut keeps its place, so the device
    /// scene is re-used;
    /// a cut that does not reach the plate gets a groove far below a pixel's resolution
    /// (w = d = 1e-6 mm: its light is below 1e-5 of a visible groove's).
    pub(super) fn scratches(&self, tool: &Tool, alpha: f64) -> Vec<Scratch> {
        // The tool model is a small least-squares fit: once per commanded depth, not per cut
        // (the ladder's cuts share a few depths).
        let mut models: Vec<(f64, (f64, f64))> = Vec::new();
        self.data
            .card
            .cuts
            .iter()
            .filter(|c| c.role == CutRole::Ladder)
            .map(|c| {
                let (w, d) = match models.iter().find(|m| m.0 == c.z_mm) {
                    Some(m) => m.1,
                    None => {
                        let wd = match tool.model(c.z_mm) {
                            Some(m) if m.width > 1e-6 && m.w > 0.0 && m.d > 0.0 => (m.w, m.d),
                            _ => (1e-6, 1e-6),
                        };
                        models.push((c.z_mm, wd));
                        wd
                    }
                };
                Scratch {
                    p0: c.p0,
                    p1: c.p1,
                    w,
                    d,
                    alpha,
                    bulge: 0.0,
                }
            })
            .collect()
    }

    /// View v as the fit renders it for `x`: its camera corrected by the pose terms (for a photo
    /// taken off the capture pose), at `SUPERSAMPLE` times the photo's resolution.
    pub(super) fn render_view(&self, x: &[f64], v: usize) -> scratchart_model::scene::View {
        let mut view = self.data.capture.views[v].clone();
        view.camera.width *= self.ss;
        view.camera.height *= self.ss;
        let d = self.lay.pose(x, v);
        if d != [0.0; layout::POSE_PARAMS] {
            let c = &mut view.camera;
            for k in 0..3 {
                c.eye[k] += d[k];
            }
            // Turn the up vector about the (new) axis, and scale the field of view.
            let f = [c.target[0] - c.eye[0], c.target[1] - c.eye[1], c.target[2] - c.eye[2]];
            let n = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
            let k = [f[0] / n, f[1] / n, f[2] / n];
            let u = c.up;
            let (sn, cs) = d[3].to_radians().sin_cos();
            let kxu = [
                k[1] * u[2] - k[2] * u[1],
                k[2] * u[0] - k[0] * u[2],
                k[0] * u[1] - k[1] * u[0],
            ];
            let ku = k[0] * u[0] + k[1] * u[1] + k[2] * u[2];
            c.up = std::array::from_fn(|i| u[i] * cs + kxu[i] * sn + k[i] * ku * (1.0 - cs));
            c.fov_y_deg = 2.0
                * ((0.5 * c.fov_y_deg).to_radians().tan() * d[4].exp())
                    .atan()
                    .to_degrees();
        }
        let (dx, dy) = self.lay.shift(x, v);
        if dx != 0.0 || dy != 0.0 {
            // (In the render's pixels: `ss` to each of the photo's.)
            pan(&mut view.camera, self.ss as f64 * dx, self.ss as f64 * dy);
        }
        view
    }

    /// The card for `x`: its grooves, and the eyes of photos taken off the capture pose.
    fn scene_at(&self, x: &[f64]) -> Scene {
        Scene {
            plate: self.data.capture.plate.clone(),
            views: (0..self.data.capture.views.len())
                .map(|v| self.render_view(x, v))
                .collect(),
            scratches: self.scratches(&self.lay.tool(x), self.lay.alpha(x)),
        }
    }

    /// Puts the card for `x` on the device ([`Self::scene_at`]), uploading it the first time,
    /// each view windowed ([`Self::window`]) unless every render is whole.
    pub(super) fn sync(&mut self, x: &[f64]) -> Result<(), FitError> {
        let t = std::time::Instant::now();
        let r = self.sync_now(x);
        self.sync_s += t.elapsed().as_secs_f64();
        r
    }

    /// [`Self::sync`]'s work.
    fn sync_now(&mut self, x: &[f64]) -> Result<(), FitError> {
        let scene = self.scene_at(x);
        let ctx = self.renderer.ctx.clone();
        let reuse = match &mut self.gs {
            Some(gs) => {
                gs.update_scratches(&ctx, &scene.scratches)
                    .map_err(anyhow::Error::from)?
                    && gs.update_views(&scene.views).map_err(anyhow::Error::from)?
            }
            None => false,
        };
        if !reuse {
            let windows: Vec<_> = (0..scene.views.len())
                .map(|v| if self.whole { None } else { self.window(v) })
                .collect();
            self.gs = Some(
                self.renderer
                    .upload_windowed(&scene, &windows)
                    .map_err(anyhow::Error::from)?,
            );
        }
        Ok(())
    }

    /// The tiles of view v's render that its residuals read ([`render_window`]), for the widest
    /// blur the fit gives the photo (the layout's bound, the start search's smoothing on top).
    fn window(&self, v: usize) -> Option<scratchart_render::layout::TileWindow> {
        let c = &self.data.capture.views[v].camera;
        let widest = self.lay.blur_max(v).hypot(starts::SEARCH_BLUR_PX);
        render_window(&self.data.masks[v], c.width, c.height, self.ss, widest)
    }

    /// Linear renders of the card for the tool part of `x`: the tiles of each view's [`Self::window`]
    /// (0 outside them), each followed by its pixels' moments of light where they are on
    /// (`simulate::render_for_optics`: the blur places the light within each subpixel).
    pub(super) fn render(&mut self, x: &[f64]) -> Result<Vec<Vec<f32>>, FitError> {
        let t = std::time::Instant::now();
        self.sync(x)?;
        let sigma = self.optics_sigma(x);
        let gs = self.gs.as_mut().expect("uploaded");
        let images = crate::simulate::render_for_optics(self.renderer, gs, sigma)?;
        self.renders += 1;
        self.engine_s += t.elapsed().as_secs_f64();
        Ok(images)
    }

    /// [`Self::render`] without the moments of light, whatever the blur: the start search's
    /// renders, which it smooths by [`starts::SEARCH_BLUR_PX`] on top (a coarse look at many
    /// start points: the same renders as before the moments).
    pub(super) fn render_plain(&mut self, x: &[f64]) -> Result<Vec<Vec<f32>>, FitError> {
        let t = std::time::Instant::now();
        self.sync(x)?;
        let gs = self.gs.as_mut().expect("uploaded");
        let frame = self.renderer.render(gs).map_err(anyhow::Error::from)?;
        self.renders += 1;
        self.engine_s += t.elapsed().as_secs_f64();
        Ok(frame.images)
    }

    /// The widest blur of `x`'s photos, in the render's pixels (whether a render takes the
    /// moments of light: `simulate::render_for_optics`).
    fn optics_sigma(&self, x: &[f64]) -> f64 {
        (0..self.lay.n_views)
            .map(|v| self.ss as f64 * self.lay.blur(x, v))
            .fold(0.0, f64::max)
    }

    /// [`Self::render`] of the whole images, for what reads beyond the residuals' pixels (a
    /// JPEG's blocks and a shrink straddle the mask's edge; the residual images): a few per fit,
    /// each its own upload, the windowed scene kept for the iterations.
    pub(super) fn render_whole(&mut self, x: &[f64]) -> Result<Vec<Vec<f32>>, FitError> {
        if self.whole {
            return self.render(x);
        }
        let t = std::time::Instant::now();
        let mut gs = self.renderer.upload(&self.scene_at(x)).map_err(anyhow::Error::from)?;
        let images = crate::simulate::render_for_optics(self.renderer, &mut gs, self.optics_sigma(x))?;
        self.renders += 1;
        self.engine_s += t.elapsed().as_secs_f64();
        Ok(images)
    }

    /// The Jacobian columns (d residual / d x_k) of the parameters `ks`, each of which moves only
    /// the grooves' (w, d, alpha): the tool's parameters, its z offset, alpha. Differentiable
    /// rendering: the engine gives the pixel values' derivatives along up to 7 parameters per
    /// pass (`Renderer::tangent_groups`, the reverse sweep of the pair integral, every pass after
    /// one render in one submission), seeded
    /// with each groove's d(w, d, alpha)/dx_k (central differences of the tool model on the host,
    /// no render); the camera model (blur, exposure, display encoding, clipping) is then
    /// differenced around that linearized render, over the parameter's own step.
    pub(super) fn tangent_columns(&mut self, x: &[f64], ks: &[usize]) -> Result<Vec<Vec<f64>>, FitError> {
        // A cut that does not reach the plate is a placeholder groove (see `scratches`).
        let reaches = |s: &Scratch| !(s.w == 1e-6 && s.d == 1e-6);
        if ks.is_empty() {
            return Ok(Vec::new());
        }
        let base = self.scratches(&self.lay.tool(x), self.lay.alpha(x));
        let mut groups: Vec<Vec<ScratchTangent>> = Vec::new();
        for group in ks.chunks(TANGENT_DIRECTIONS) {
            let mut seeds: Vec<ScratchTangent> = vec![[[0.0; 3]; TANGENT_DIRECTIONS]; base.len()];
            // The grooves a step up and a step down each parameter cut (each its own fit of
            // the tool's sections: on the host's threads).
            let this = &*self;
            let stepped = scratchart_model::par::par_map(2 * group.len(), |i| {
                let k = group[i / 2];
                let q = &this.lay.params[k];
                let mut xx = x.to_vec();
                xx[k] = if i % 2 == 0 {
                    (x[k] + q.step).min(q.hi)
                } else {
                    (x[k] - q.step).max(q.lo)
                };
                this.scratches(&this.lay.tool(&xx), this.lay.alpha(&xx))
            });
            for (j, &k) in group.iter().enumerate() {
                let q = &self.lay.params[k];
                let (up, dn) = ((x[k] + q.step).min(q.hi), (x[k] - q.step).max(q.lo));
                let (sp, sm) = (&stepped[2 * j], &stepped[2 * j + 1]);
                for (c, t) in seeds.iter_mut().enumerate() {
                    // A groove that starts or stops cutting within the step jumps there: take the
                    // side that keeps its state.
                    let state = reaches(&base[c]);
                    let (a, b, span) = match (reaches(&sp[c]) == state, reaches(&sm[c]) == state) {
                        (true, true) => (&sp[c], &sm[c], up - dn),
                        (true, false) => (&sp[c], &base[c], up - x[k]),
                        (false, true) => (&base[c], &sm[c], x[k] - dn),
                        (false, false) => continue,
                    };
                    if span > 0.0 {
                        t[j] = [
                            ((a.w - b.w) / span) as f32,
                            ((a.d - b.d) / span) as f32,
                            ((a.alpha - b.alpha) / span) as f32,
                        ];
                    }
                }
            }
            groups.push(seeds);
        }
        // Every group's tangent pass after one render, in one submission.
        let t = std::time::Instant::now();
        self.sync(x)?;
        let gs = self.gs.as_mut().expect("uploaded");
        let seeds: Vec<&[ScratchTangent]> = groups.iter().map(Vec::as_slice).collect();
        let (lin, tangs) = self.renderer.tangent_groups(gs, &seeds).map_err(anyhow::Error::from)?;
        self.tangent_passes += groups.len() as u32;
        self.engine_s += t.elapsed().as_secs_f64();
        let this = &*self;
        let cols = scratchart_model::par::par_map(ks.len(), |i| {
            let (tang, j) = (&tangs[i / TANGENT_DIRECTIONS], i % TANGENT_DIRECTIONS);
            let h = this.lay.params[ks[i]].step;
            let moved = |sign: f64| -> Vec<Vec<f32>> {
                lin.iter()
                    .zip(tang)
                    .map(|(l, t)| l.iter().zip(t).map(|(a, d)| a + (sign * h) as f32 * d[j]).collect())
                    .collect()
            };
            let rp = this.residuals(&this.predict_masked(&moved(1.0), x));
            let rm = this.residuals(&this.predict_masked(&moved(-1.0), x));
            rp.iter()
                .zip(&rm)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect::<Vec<f64>>()
        });
        Ok(cols)
    }

    /// Residuals (model - photo) over the masked pixels, all views in order (times the square
    /// roots of the bootstrap weights, when set).
    pub(super) fn residuals(&self, pred: &[Vec<f32>]) -> Vec<f64> {
        let mut r = Vec::new();
        for (v, img) in pred.iter().enumerate() {
            r.extend(self.residuals_of(v, img, r.len()));
        }
        r
    }

    /// Photo v's block of [`Self::residuals`] for its model photo `img`, the block starting at
    /// `at` in the whole (where its bootstrap weights start).
    pub(super) fn residuals_of(&self, v: usize, img: &[f32], at: usize) -> Vec<f64> {
        let photo = self.photo(v);
        let shift = self.jpeg_shift.get(v).and_then(|s| s.as_deref());
        let mut r = Vec::new();
        for (i, ((m, &ph), &ok)) in img.iter().zip(photo.iter()).zip(&self.data.masks[v]).enumerate() {
            if ok {
                let j = shift.map_or(0.0, |s| s[i]);
                r.push((*m + j - ph) as f64);
            }
        }
        if let Some(w) = &self.weights {
            for (e, w) in r.iter_mut().zip(&w[at..]) {
                *e *= w.sqrt();
            }
        }
        r
    }

    /// The block (view, 8 x 8 pixels) of every residual, in the residuals' order: neighbouring
    /// pixels share the camera's blur, so the bootstrap resamples blocks, not pixels.
    pub(super) fn residual_blocks(&self, size: usize) -> Vec<u64> {
        let mut b = Vec::new();
        for (v, mask) in self.data.masks.iter().enumerate() {
            let w = self.data.capture.views[v].camera.width as usize;
            for (i, &ok) in mask.iter().enumerate() {
                if ok {
                    let (x, y) = ((i % w) / size, (i / w) / size);
                    b.push(((v as u64) << 40) | ((y as u64) << 20) | x as u64);
                }
            }
        }
        b
    }

    /// Residuals at `x` from linear renders `lin` already made for its tool part.
    pub(super) fn residuals_at(&self, x: &[f64], lin: &[Vec<f32>]) -> Vec<f64> {
        self.residuals(&self.predict_masked(lin, x))
    }

    /// Renders for `x`: the residuals and the linear renders.
    pub(super) fn eval(&mut self, x: &[f64]) -> Result<(Vec<f64>, Vec<Vec<f32>>), FitError> {
        let lin = self.render(x)?;
        Ok((self.residuals_at(x, &lin), lin))
    }
}

/// The tiles of a render at `ss` times a `width` x `height` photo's resolution that the
/// residuals at `mask`'s pixels read: its subpixels and those a blur of up to `blur_px` (the
/// photo's pixels) and the image's motion (a subpixel either side) reach from them. Inside, a
/// windowed render is the whole render's, bit for bit, so the blurred light at the mask is too
/// (None: an empty mask, the whole image).
fn render_window(
    mask: &[bool],
    width: u32,
    height: u32,
    ss: u32,
    blur_px: f64,
) -> Option<scratchart_render::layout::TileWindow> {
    let reach = crate::simulate::blur_reach(ss as f64 * blur_px) + 1;
    scratchart_render::layout::TileWindow::covering_mask(mask, width, height, ss, reach as u32)
}

#[cfg(test)]
mod tests {
    use super::render_window;
    use crate::simulate::blur_reach;

    #[test]
    fn the_window_holds_every_subpixel_the_residuals_read() {
        let (w, h) = (80u32, 60u32);
        for (ss, blur) in [(1u32, 0.0), (2, 0.6), (2, 4.0), (4, 1.5)] {
            let mut mask = vec![false; (w * h) as usize];
            for (x, y) in [(3, 4), (12, 9), (20, 17)] {
                mask[(y * w + x) as usize] = true;
            }
            let win = render_window(&mask, w, h, ss, blur).unwrap();
            let reach = blur_reach(ss as f64 * blur) as i64 + 1;
            let (ws, hs) = ((ss * w) as i64, (ss * h) as i64);
            let mut inside = 0;
            for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
                let (px, py) = ((i as u32 % w) as i64, (i as u32 / w) as i64);
                for sy in ss as i64 * py - reach..ss as i64 * (py + 1) + reach {
                    for sx in ss as i64 * px - reach..ss as i64 * (px + 1) + reach {
                        if (0..ws).contains(&sx) && (0..hs).contains(&sy) {
                            assert!(win.contains(sx as u32, sy as u32), "ss {ss} blur {blur}: ({sx}, {sy})");
                            inside += 1;
                        }
                    }
                }
            }
            assert!(inside > 0);
            // And no more than the tiles about them: the far corner is left out.
            assert!(!win.contains(ws as u32 - 1, hs as u32 - 1), "ss {ss}: {win:?}");
        }
        assert!(render_window(&[false; 12], 4, 3, 2, 1.0).is_none());
    }
}
