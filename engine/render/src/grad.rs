//! The backward pass: gradients of a loss with respect to every scratch's parameters and every
//! view's light intensity, from dE/dL per pixel. Kernels: `grad.comp` (per tile-list entry, the
//! pair's reverse sweep; over the pair queues the forward stored when the scene has a pair
//! store, see [`super::kernels::KernelSet::replay`]), `grad_reduce.comp` (per scratch, in a fixed
//! order) and `grad_light.comp`. Reuses the tile lists of the forward pass.
use super::layout::ReducePush;
use super::{GpuScene, Renderer};
use crate::vulkan::{GpuError, Recorder};

/// Gradients downloaded to the host.
#[derive(Clone, Debug)]
pub struct Gradients {
    /// per scratch: dE/d(x0, y0, x1, y1, w, d, alpha)
    pub scratches: Vec<[f32; 7]>,
    /// per scratch of a scene with arcs: dE/dbulge (NaN for its straight scratches, whose one
    /// chord cannot bend); empty for a scene without arcs
    pub bulges: Vec<f32>,
    /// per view: dE/dPhi
    pub lights: Vec<f32>,
}

impl Renderer {
    /// Replaces dE/dL (one value per pixel of every view, laid out like the image) by `dl`.
    pub fn upload_dl(&self, gs: &mut GpuScene, dl: &[f32]) -> Result<(), GpuError> {
        assert_eq!(
            dl.len() as u64,
            gs.slots.n_pixels,
            "dE/dL needs one value per pixel of every view"
        );
        gs.backward.dl = self.ctx.upload("dE/dL", dl)?;
        Ok(())
    }

    /// Records the backward pass for the forward pass just recorded on `gs` (same tile lists):
    /// reads `gs.backward.dl`, `gs.shading.image`, `gs.shading.cov_raw`; writes `gs.backward.grad` and `gs.backward.grad_light`.
    /// Needs `prepare_backward` first (a contract: it panics otherwise).
    pub fn record_backward(&self, rec: &mut Recorder, gs: &GpuScene) {
        let grad = self
            .grad
            .get()
            .expect("Renderer::prepare_backward() must be called before record_backward");
        // Replay the forward's pair queues where the scene has them; else search the pairs (and,
        // if the kernels replay, have the next complete submission size the store).
        let kernel = match self.grad_replay.get() {
            // Arcs: the dual-number build that weighs chords and gives dE/dkappa (no replay).
            _ if gs.arc_kernels() => self
                .grad_arcs
                .get()
                .expect("Renderer::prepare_backward_of(gs) must be called before record_backward on arcs"),
            Some(replay) if gs.replay_ready() => replay,
            Some(_) => {
                gs.want_store();
                grad
            }
            None => grad,
        };
        let role = super::bindings::Role::Backward {
            dl: &gs.backward.dl,
            partials: &gs.backward.partials,
        };
        super::record_passes(rec, kernel, gs, role);
        let push = ReducePush {
            n_scratches: gs.n_scratches,
            capacity: gs.bin.capacity,
            n_parts: gs.n_parts(),
            pad: 0,
        };
        rec.dispatch_1d(
            &self.grad_reduce,
            &[&gs.backward.partials, &gs.bin.sbase, &gs.bin.inv, &gs.backward.grad],
            bytemuck::bytes_of(&push),
            gs.n_scratches.div_ceil(64),
        );
        rec.dispatch(
            &self.grad_light,
            &[
                &gs.inputs.views,
                &gs.shading.image,
                &gs.backward.dl,
                &gs.backward.grad_light,
                &gs.inputs.lights,
            ],
            &[],
            [gs.shading.shade.n_views, 1, 1],
        );
        rec.barrier();
        if let Some(a) = gs.arc_layout() {
            // The chords' gradients into their arcs' (`shaders/arc_map.comp`).
            self.record_arc_map(rec, gs, a, 1);
        }
    }

    /// Forward + backward for given dE/dL (one value per pixel of every view, concatenated like
    /// `gs.shading.image`), with results downloaded. For checks and the `grad` command; the optimizer
    /// keeps everything on the device.
    pub fn gradients(&self, gs: &mut GpuScene, dl: &[f32]) -> Result<(Vec<Vec<f32>>, Gradients), GpuError> {
        self.prepare_backward_of(gs)?;
        self.upload_dl(gs, dl)?;
        let mut rec = Recorder::new(&self.ctx)?;
        // One submission, so an incomplete render or backward is redone as a whole.
        self.submit(&mut rec, gs, |rec, gs| {
            self.record_render(rec, gs);
            self.record_backward(rec, gs);
        })?;
        let images = self.download_images(gs)?;
        Ok((images, self.download_gradients(gs)?))
    }

    /// The gradients of the last backward pass.
    pub fn download_gradients(&self, gs: &GpuScene) -> Result<Gradients, GpuError> {
        let (scratches, bulges) = match gs.arc_layout() {
            // The arcs' own, chained from their chords' on the device.
            Some(layout) => {
                let g: Vec<[f32; 8]> = self.ctx.download(&layout.grad)?;
                let n = layout.scratches.len();
                let bulges = g[..n]
                    .iter()
                    .zip(&layout.chords)
                    .map(|(r, &c)| if c > 1 { r[7] } else { f32::NAN })
                    .collect();
                (
                    g[..n]
                        .iter()
                        .map(|r| [r[0], r[1], r[2], r[3], r[4], r[5], r[6]])
                        .collect(),
                    bulges,
                )
            }
            None => {
                let g: Vec<[f32; 8]> = self.ctx.download(&gs.backward.grad)?;
                (
                    g[..gs.n_scratches as usize]
                        .iter()
                        .map(|r| [r[0], r[1], r[2], r[3], r[4], r[5], r[6]])
                        .collect(),
                    Vec::new(),
                )
            }
        };
        let mut lights: Vec<f32> = self.ctx.download(&gs.backward.grad_light)?;
        // (buffers may be allocated larger than asked)
        lights.truncate(gs.shading.shade.n_views as usize);
        Ok(Gradients {
            scratches,
            bulges,
            lights,
        })
    }
}
