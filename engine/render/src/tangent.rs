//! Directional derivatives of the pixel values (`tangent.comp`): Jacobian-vector products for up
//! to 7 directions in the space of every scratch's (w, d, alpha) at once, from one reverse sweep
//! per (pixel, scratch) pair (the backward's hand-written adjoint) contracted with each scratch's
//! tangents.
//! The tool calibration fits a handful of tool parameters that move every groove of its card;
//! its least-squares Jacobian is these directional derivatives (one pass of the engine), where
//! finite differences would need one render per parameter.
use super::kernels::{Integrator, Mode, ShadeKernel};
use super::{GpuScene, Renderer};
use crate::vulkan::{Buffer, GpuError, MemLoc, Recorder, ShaderCompiler};

/// Directions one tangent pass carries (`tangent.comp` sums 7 per pixel).
pub const TANGENT_DIRECTIONS: usize = 7;

/// Per scratch, the tangents of (w, d, alpha) along each direction: `[j]` = (dw, dd, dalpha) / dθ_j.
pub type ScratchTangent = [[f32; 3]; TANGENT_DIRECTIONS];

impl Renderer {
    /// Compiles the tangent kernel (over the closed form's adjoint) if it is not compiled yet.
    fn prepare_tangent(&self) -> Result<(), GpuError> {
        if self.tangent.get().is_some() {
            return Ok(());
        }
        let k = ShadeKernel {
            integrator: Integrator::ClosedForm,
            mode: Mode::Tangent,
        };
        let p = super::shade_pipeline(&self.ctx, &ShaderCompiler::embedded()?, &k, false)?;
        let _ = self.tangent.set(p);
        Ok(())
    }

    /// Renders `gs` and, per view, per pixel, the first moments of its light about its centre,
    /// in the render's pixels (x right, y down): the sums over its pairs of each groove's light,
    /// less the plate light its area covers, times where the covered part of the footprint has
    /// its centroid (`tangent.comp` built with `SA_MOMENTS`; shaders/inc/centroid.glsl). A blur
    /// of the image can then place each pixel's light where it falls within the pixel, to first
    /// order (the calibration's model of a photo renders at twice the photo's resolution, and a
    /// groove a tenth of a pixel wide lands up to a quarter of a photo pixel off without it).
    /// One submission; 0 outside a window and off the plate.
    #[allow(clippy::type_complexity)]
    pub fn moments(&self, gs: &mut GpuScene) -> Result<(Vec<Vec<f32>>, Vec<Vec<[f32; 2]>>), GpuError> {
        gs.refuse_arcs("moments")?;
        if self.moments.get().is_none() {
            let k = ShadeKernel {
                integrator: Integrator::ClosedForm,
                mode: Mode::Tangent,
            };
            let sc = ShaderCompiler::embedded()?;
            let p = super::shade_pipeline_with(&self.ctx, &sc, &k, false, false, None, &[("SA_MOMENTS", "1")])?;
            let _ = self.moments.set(p);
        }
        let out = Buffer::new(
            &self.ctx,
            "moments (2 floats per pixel of every view)",
            gs.slots.n_pixels.div_ceil(2) * 16,
            MemLoc::GpuOnly,
        )?;
        let mut rec = Recorder::new(&self.ctx)?;
        let kernel = self.moments.get().expect("prepared");
        self.submit(&mut rec, gs, |rec, gs| {
            self.record_render(rec, gs);
            // The kernel reads no seeds: the scene's placeholder stands in their slot.
            let seeds = &gs.shading.unbound;
            let role = super::bindings::Role::Tangent { seeds, tangents: &out };
            super::record_passes(rec, kernel, gs, role);
        })?;
        let images = self.download_images(gs)?;
        let all: Vec<[f32; 2]> = self.ctx.download(&out)?;
        let moments = gs
            .slots
            .views
            .iter()
            .map(|v| {
                let n = v.dims[0] as usize * v.dims[1] as usize;
                let win = v.window();
                all[v.base[1] as usize..v.base[1] as usize + n]
                    .iter()
                    .enumerate()
                    .map(|(k, t)| {
                        if win.contains(k as u32 % v.dims[0], k as u32 / v.dims[0]) {
                            [t[0], t[1]]
                        } else {
                            [0.0; 2]
                        }
                    })
                    .collect()
            })
            .collect();
        Ok((images, moments))
    }

    /// Renders `gs` and the derivatives of every pixel value along the directions of `seeds`
    /// (one entry per scratch, in scene order): the images (one per view) and, per view, per
    /// pixel, dL/dθ_j for the 7 directions. One submission: an incomplete render is redone
    /// with its derivatives.
    #[allow(clippy::type_complexity)]
    pub fn tangents(
        &self,
        gs: &mut GpuScene,
        seeds: &[ScratchTangent],
    ) -> Result<(Vec<Vec<f32>>, Vec<Vec<[f32; TANGENT_DIRECTIONS]>>), GpuError> {
        let (images, mut per_group) = self.tangent_groups(gs, &[seeds])?;
        Ok((images, per_group.remove(0)))
    }

    /// [`Renderer::tangents`] for several groups of 7 directions at once: one render and one
    /// tangent pass per group, all in one submission (the same bits as a call per group). Per
    /// group, per view, per pixel, dL/dθ_j.
    #[allow(clippy::type_complexity)]
    pub fn tangent_groups(
        &self,
        gs: &mut GpuScene,
        groups: &[&[ScratchTangent]],
    ) -> Result<(Vec<Vec<f32>>, Vec<Vec<Vec<[f32; TANGENT_DIRECTIONS]>>>), GpuError> {
        gs.refuse_arcs("tangents")?;
        for seeds in groups {
            assert_eq!(
                seeds.len(),
                gs.n_scratches as usize,
                "one tangent per scratch of the uploaded scene"
            );
        }
        self.prepare_tangent()?;
        let mut bufs = Vec::with_capacity(groups.len());
        for &seeds in groups {
            // Per scratch 6 vec4: the 7 directions' tangents of w (and a zero), of d, of alpha.
            let mut flat = Vec::with_capacity(seeds.len() * 24);
            for s in seeds {
                for q in 0..3 {
                    flat.extend(s.iter().map(|dir| dir[q]));
                    flat.push(0.0);
                }
            }
            let seed_buf = self.ctx.upload("tangent seeds (6 vec4 per scratch)", &flat)?;
            let tang = Buffer::new(
                &self.ctx,
                "tangents (2 vec4 per pixel of every view)",
                gs.slots.n_pixels * 32,
                MemLoc::GpuOnly,
            )?;
            bufs.push((seed_buf, tang));
        }
        let mut rec = Recorder::new(&self.ctx)?;
        let kernel = self.tangent.get().expect("prepared");
        self.submit(&mut rec, gs, |rec, gs| {
            self.record_render(rec, gs);
            for (seed_buf, tang) in &bufs {
                let role = super::bindings::Role::Tangent {
                    seeds: seed_buf,
                    tangents: tang,
                };
                super::record_passes(rec, kernel, gs, role);
            }
        })?;
        let images = self.download_images(gs)?;
        let mut per_group = Vec::with_capacity(bufs.len());
        for (_, tang) in &bufs {
            let all: Vec<[f32; 8]> = self.ctx.download(tang)?;
            per_group.push(
                gs.slots
                    .views
                    .iter()
                    .map(|v| {
                        let n = v.dims[0] as usize * v.dims[1] as usize;
                        // A window's pass leaves the pixels outside it unwritten: 0 there.
                        let win = v.window();
                        let whole = win == crate::layout::TileWindow::whole(v.dims[0], v.dims[1]);
                        all[v.base[1] as usize..v.base[1] as usize + n]
                            .iter()
                            .enumerate()
                            .map(|(k, t)| {
                                if whole || win.contains(k as u32 % v.dims[0], k as u32 / v.dims[0]) {
                                    [t[0], t[1], t[2], t[3], t[4], t[5], t[6]]
                                } else {
                                    [0.0; TANGENT_DIRECTIONS]
                                }
                            })
                            .collect()
                    })
                    .collect(),
            );
        }
        Ok((images, per_group))
    }
}
