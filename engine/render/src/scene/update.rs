//! Parameters and cameras replaced between renders, on the scene already on the device (fits
//! that re-render with new scratches; viewers and lamp searches that move cameras and lights).
use super::*;

impl GpuScene {
    /// Replaces the scratches (same number: the binning's sizes depend on it). Returns false
    /// (and changes nothing) when the number differs, in which case the caller uploads the scene
    /// again. For fits that re-render one scene with new scratch parameters many times.
    /// Arcs count as their chords (`crate::arcs`); scratches with arcs where the upload had none
    /// need a new upload too (its kernel is built then).
    pub fn update_scratches(&mut self, ctx: &std::sync::Arc<Context>, scratches: &[Scratch]) -> Result<bool, GpuError> {
        let arcs = crate::arcs::any_arc(scratches);
        if arcs && self.arcs.is_none() {
            return Ok(false);
        }
        if let Some(layout) = self.arcs.as_mut() {
            // The chords come from the arcs on the device (`shaders/arc_map.comp`).
            return if arcs { layout.update(ctx, scratches) } else { Ok(false) };
        }
        if scratches.len() != self.n_scratches as usize {
            return Ok(false);
        }
        let scr: Vec<ScratchGpu> = scratches.iter().map(ScratchGpu::from).collect();
        self.inputs.scratches = ctx.upload("scratches", &scr)?;
        Ok(true)
    }

    /// Replaces the cameras and lights (same number of views, same image sizes): cheap enough
    /// for every frame of a viewer. Returns false (and changes nothing) when the sizes differ, in
    /// which case the caller uploads the scene again.
    pub fn update_views(&mut self, views: &[View]) -> Result<bool, GpuError> {
        if views.len() != self.slots.views.len() {
            return Ok(false);
        }
        let mut new = Vec::with_capacity(views.len());
        for (v, old) in views.iter().zip(&self.slots.views) {
            if v.camera.width != old.dims[0] || v.camera.height != old.dims[1] {
                return Ok(false);
            }
            // The same window and plate as uploaded.
            new.push(layout::view_gpu_in(
                v,
                &self.shape,
                old.base[0],
                old.base[1],
                Some(old.window()),
            ));
        }
        let new64: Vec<_> = views.iter().map(|v| layout::view_gpu64(v, &self.shape)).collect();
        let phi: Vec<f32> = views.iter().map(|v| v.radiance_scale() as f32).collect();
        self.inputs.views.write(0, &new)?;
        self.inputs.views64.write(0, &new64)?;
        self.inputs.lights.write(0, &phi)?;
        self.slots.views = new;
        self.slots.views64 = new64;
        Ok(true)
    }
}
