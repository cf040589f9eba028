//! The lamp searches' renders: a lamp that moves changes neither the cameras nor the scratches,
//! so the tile lists of the designed views stay valid (`Renderer::record_render_with`, bin =
//! false): the scenes of the active lamp searches are uploaded and binned once, and each later
//! step moves their lamps and shades again, the same bits as binning again
//! (`tests/forward.rs`, `a_lamp_that_moves_needs_no_new_tile_lists`). A new upload happens only
//! when the set of active searches changes (a search ends).
use scratchart_model::scene::{Scene, View};
use scratchart_optim::error::OptimError;
use scratchart_render::GpuScene;
use scratchart_render::Renderer;
use scratchart_vulkan::Recorder;

use super::{batch_views, display_images, mask_window, SearchClock};

#[derive(Default)]
pub(super) struct LampRenders {
    /// The searches (indices) the scenes hold, in slot order.
    slots: Vec<usize>,
    /// The scenes, [`batch_views`] slots each.
    scenes: Vec<GpuScene>,
    /// One recorder for every step.
    rec: Option<Recorder>,
}

impl LampRenders {
    /// Display images of `views` (each the designed view of search `searches[k]` with its lamp
    /// moved), compared over `masks`.
    pub(super) fn render(
        &mut self,
        renderer: &Renderer,
        scene: &Scene,
        searches: &[usize],
        views: Vec<View>,
        masks: &[&[bool]],
        clock: &mut SearchClock,
    ) -> Result<Vec<Vec<f32>>, OptimError> {
        let mut keep = self.slots == searches;
        let batch = batch_views(renderer, scene, &views);
        if keep {
            // The same cameras and windows: only the lamps move.
            for (gs, chunk) in self.scenes.iter_mut().zip(views.chunks(batch)) {
                keep = keep && clock.time(|c| &mut c.upload_s, || gs.update_views(chunk))?;
            }
        }
        if !keep {
            self.scenes.clear();
            for (chunk, masks) in views.chunks(batch).zip(masks.chunks(batch)) {
                let mut batch = scene.clone();
                batch.views = chunk.to_vec();
                let windows: Vec<_> = chunk.iter().zip(masks).map(|(v, m)| mask_window(v, m)).collect();
                self.scenes
                    .push(clock.time(|c| &mut c.upload_s, || renderer.upload_windowed(&batch, &windows))?);
                clock.uploads += 1;
            }
            self.slots = searches.to_vec();
        }
        let mut out = Vec::with_capacity(views.len());
        if self.rec.is_none() {
            self.rec = Some(Recorder::new(&renderer.ctx)?);
        }
        let rec = self.rec.as_mut().expect("made above");
        for gs in self.scenes.iter_mut() {
            // Bin on a fresh upload, and on any retry (a retry may have changed the lists).
            let mut first = keep;
            clock.time(
                |c| &mut c.render_s,
                || {
                    renderer.submit(rec, gs, |rec, gs| {
                        renderer.record_render_with(rec, gs, !first);
                        first = false;
                    })
                },
            )?;
            clock.submissions += 1;
            out.extend(clock.time(|c| &mut c.read_s, || renderer.download_images(gs).map(display_images))?);
        }
        Ok(out)
    }
}
