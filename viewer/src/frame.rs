//! [`FrameRenderer`]: one interactive view rendered by the engine's own [`Renderer`] (the same
//! binning and shading kernels as `scratchart render`), then mapped to display bytes by
//! `shaders/view_present.comp` into a buffer the size of the output, which is copied to the
//! swapchain image in the same submission (or read back for a screenshot).
//!
//! Why a buffer and not a storage image: many drivers do not offer STORAGE on the swapchain's
//! BGRA8 formats, while TRANSFER_DST is offered nearly everywhere; the extra copy of one frame
//! is negligible next to the shading. The output is gray, so RGBA and BGRA pack the same.
//!
//! Reduced resolution: the engine renders at an internal size (see [`internal_size`]) and the
//! present pass upsamples, or, in a window without a target, a blit does (`upscale.rs`). One [`GpuScene`] is kept per internal size, so moving the camera only
//! rewrites the views buffer (`GpuScene::update_views`) and changing the level re-uploads nothing.
use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use scratchart_model::scene::{Scene, View};
use scratchart_render::present::PresentPush;
use scratchart_render::{GpuScene, RenderStats, Renderer};
use scratchart_vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler, Timings};

use crate::design::Target;
use crate::overlay::{self, Mark};
use crate::setup::SetupInfo;
use crate::upscale::{blit_supported, record_blit, StagingImage};

/// The swapchain image a frame goes to.
#[derive(Clone, Copy, Debug)]
pub struct SwapImage {
    pub image: vk::Image,
    pub format: vk::Format,
    /// Must equal the frame layout's output size.
    pub extent: (u32, u32),
}

/// Divisors of the full resolution, finest first; level i renders at full / DIVISORS[i].
pub const DIVISORS: [f64; 9] = [1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0];

/// Internal render size at `level` for a viewport of `full` pixels.
pub fn internal_size(full: (u32, u32), level: usize) -> (u32, u32) {
    let d = DIVISORS[level.min(DIVISORS.len() - 1)];
    let f = |n: u32| ((n as f64 / d).round() as u32).clamp(1, n.max(1));
    (f(full.0), f(full.1))
}

/// Where the render and the (optional) target go in an output of `out` pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub out: (u32, u32),
    pub view_rect: [u32; 4],
    pub tgt_rect: [u32; 4],
}

impl Layout {
    /// Without a target the render fills the output; with one, the render takes the left half
    /// and the target is fitted (aspect kept) and centred in the right half.
    pub fn new(out: (u32, u32), target: Option<(u32, u32)>) -> Layout {
        let (w, h) = out;
        match target {
            None => Layout {
                out,
                view_rect: [0, 0, w, h],
                tgt_rect: [0; 4],
            },
            Some((tw, th)) => {
                let half = (w / 2).max(1);
                let s = (half as f64 / tw as f64).min(h as f64 / th as f64);
                let rw = ((tw as f64 * s).round() as u32).clamp(1, half);
                let rh = ((th as f64 * s).round() as u32).clamp(1, h.max(1));
                Layout {
                    out,
                    view_rect: [0, 0, half, h],
                    tgt_rect: [half + (w - half - rw) / 2, (h - rh) / 2, rw, rh],
                }
            }
        }
    }

    pub fn viewport(&self) -> (u32, u32) {
        (self.view_rect[2], self.view_rect[3])
    }
}

/// What one frame cost and what it drew.
#[derive(Clone, Debug, Default)]
pub struct FrameInfo {
    pub internal: (u32, u32),
    pub timings: Timings,
    /// Host time of the whole frame: recording, submission and the wait.
    pub wall_ms: f64,
    pub stats: RenderStats,
    /// Where the set-up overlay put each lamp and eye (empty without the overlay).
    pub marks: Vec<Mark>,
    /// Whether the frame binned its tile lists (false: the last frame's camera and scratches,
    /// lists kept).
    pub binned: bool,
}

/// How to draw one frame.
pub struct FrameParams<'a> {
    /// The view to render; its camera's width/height is the internal resolution.
    pub view: &'a View,
    pub layout: Layout,
    pub exposure: f32,
    pub nearest: bool,
    /// The target to show (must match the layout's target rectangle being non-empty).
    pub show_target: bool,
    /// Draw the set-up overlay (lamp, eyes, +x edge, numbers) over the render.
    pub setup: Option<&'a SetupInfo>,
}

struct Pipelines {
    renderer: Renderer,
    present: ComputePipeline,
}

fn build_pipelines(ctx: &Arc<Context>) -> Result<Pipelines, GpuError> {
    // `embedded()` honours ShaderCompiler::override_embedded, i.e. the hot-reload directory.
    let sc = ShaderCompiler::embedded()?;
    let present = ComputePipeline::new(
        ctx,
        &sc,
        "view_present.comp",
        &[],
        3,
        std::mem::size_of::<PresentPush>() as u32,
    )?;
    Ok(Pipelines {
        renderer: Renderer::new(ctx)?,
        present,
    })
}

pub struct FrameRenderer {
    ctx: Arc<Context>,
    pipes: Pipelines,
    /// The design with its views replaced by the one interactive view (plate and scratches kept).
    scene: Scene,
    /// One uploaded scene per internal size, most recently used last, with the camera its tile
    /// lists were binned for (a frame from the same camera with the same scratches keeps them:
    /// a lamp that moves needs the shading only).
    cache: Vec<((u32, u32), GpuScene, Option<scratchart_model::scene::Camera>)>,
    out: Option<Buffer>,
    target: Buffer,
    target_dims: Option<(u32, u32)>,
    rec: Recorder,
    /// Blit sources for the upscaling copy path, one per internal size in use.
    staging: Vec<StagingImage>,
    /// Whether a swapchain format supports the blit path (asked once per format).
    blit_ok: Vec<(vk::Format, bool)>,
    /// The set-up overlay's pixels, written by the host and copied into the output (grows).
    overlay: Option<Buffer>,
    /// The pair search's mode when not the device's (`--binning`)
    binning: Option<scratchart_render::BinMode>,
}

/// Uploaded scenes kept at once (each holds the scratches and the binning buffers).
const CACHE_LIMIT: usize = 10;

impl FrameRenderer {
    pub fn new(ctx: &Arc<Context>, scene: &Scene) -> Result<FrameRenderer, GpuError> {
        Ok(FrameRenderer {
            ctx: ctx.clone(),
            pipes: build_pipelines(ctx)?,
            scene: single_view_template(scene),
            cache: Vec::new(),
            out: None,
            target: Buffer::new(ctx, "view target", 16, MemLoc::GpuOnly)?,
            target_dims: None,
            rec: Recorder::new(ctx)?,
            staging: Vec::new(),
            blit_ok: Vec::new(),
            overlay: None,
            binning: None,
        })
    }

    /// The binning mode and threads of the scene rendered last.
    pub fn binning_info(&self) -> Option<(scratchart_render::BinMode, u64)> {
        self.cache
            .last()
            .map(|(_, gs, _)| (gs.binning_mode(), gs.binning_threads()))
    }

    /// Renders each arc as `n` chords from now on (None: the accuracy bar's rule; see
    /// `Renderer::set_arc_chords`).
    pub fn set_arc_chords(&mut self, n: Option<u32>) {
        self.pipes.renderer.set_arc_chords(n);
        self.cache.clear();
    }

    /// Bins every scene uploaded from now on in `mode` (the same images; for measurements).
    pub fn set_binning(&mut self, mode: Option<scratchart_render::BinMode>) {
        self.binning = mode;
        self.cache.clear();
    }

    pub fn ctx(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Replaces the plate and scratches (design reload); uploaded scenes are dropped.
    pub fn set_scene(&mut self, scene: &Scene) {
        self.scene = single_view_template(scene);
        self.cache.clear();
    }

    /// Recompiles every kernel from the current shader sources. On failure the old pipelines
    /// stay in use and the error (with the compiler log) is returned.
    pub fn reload_shaders(&mut self) -> Result<(), GpuError> {
        self.pipes = build_pipelines(&self.ctx)?;
        // New kernels bin anew.
        for c in &mut self.cache {
            c.2 = None;
        }
        Ok(())
    }

    /// Uploads `t` as the target shown beside the render (`None`: no target).
    pub fn set_target(&mut self, t: Option<&Target>) -> Result<(), GpuError> {
        match t {
            Some(t) => {
                self.target = self.ctx.upload("view target", &t.data)?;
                self.target_dims = Some((t.width, t.height));
            }
            None => {
                self.target = Buffer::new(&self.ctx, "view target", 16, MemLoc::GpuOnly)?;
                self.target_dims = None;
            }
        }
        Ok(())
    }

    pub fn target_dims(&self) -> Option<(u32, u32)> {
        self.target_dims
    }

    /// Drops the uploaded scenes whose size is not `keep` (after a resize).
    pub fn trim_cache(&mut self, keep: &[(u32, u32)]) {
        self.cache.retain(|(s, _, _)| keep.contains(s));
        self.staging.retain(|s| keep.contains(&s.size));
    }

    /// The uploaded scene for `size`, uploading (and evicting the oldest) when needed.
    fn scene_for(&mut self, view: &View) -> Result<usize, GpuError> {
        let size = (view.camera.width, view.camera.height);
        if let Some(i) = self.cache.iter().position(|(s, _, _)| *s == size) {
            let entry = self.cache.remove(i);
            self.cache.push(entry);
        } else {
            if self.cache.len() >= CACHE_LIMIT {
                self.cache.remove(0);
            }
            let mut scene = self.scene.clone();
            scene.views = vec![view.clone()];
            let mut gs = self.pipes.renderer.upload(&scene)?;
            if let Some(m) = self.binning {
                gs.force_binning_mode(&self.ctx, m)?;
            }
            self.cache.push((size, gs, None));
        }
        Ok(self.cache.len() - 1)
    }

    /// Renders one frame into the output buffer and, when `swap` is given, copies it to that
    /// swapchain image and leaves the image in PRESENT_SRC layout. Waits for completion.
    ///
    /// Hazard: `swap` must be an image the presentation engine has released (its acquire fence
    /// waited on): the copy is not ordered against presentation by a semaphore.
    pub fn render(&mut self, p: &FrameParams, swap: Option<SwapImage>) -> Result<FrameInfo, GpuError> {
        let t0 = Instant::now();
        let idx = self.scene_for(p.view)?;
        let (iw, ih) = (p.view.camera.width, p.view.camera.height);
        let show_target = p.show_target && self.target_dims.is_some() && p.layout.tgt_rect[2] > 0;
        // Upscale with a blit when the image is reduced and fills the window alone.
        let blit = match swap {
            Some(s) if !show_target && (iw, ih) != p.layout.viewport() => {
                let ok = match self.blit_ok.iter().find(|(f, _)| *f == s.format) {
                    Some(&(_, ok)) => ok,
                    None => {
                        let ok = blit_supported(&self.ctx, s.format);
                        self.blit_ok.push((s.format, ok));
                        ok
                    }
                };
                ok.then_some(s)
            }
            _ => None,
        };
        let layout = match blit {
            Some(_) => Layout::new((iw, ih), None),
            None => p.layout,
        };
        let staging_idx = match blit {
            Some(s) => Some(
                match self
                    .staging
                    .iter()
                    .position(|i| i.size == (iw, ih) && i.format == s.format)
                {
                    Some(i) => i,
                    None => {
                        self.staging.push(StagingImage::new(&self.ctx, s.format, (iw, ih))?);
                        self.staging.len() - 1
                    }
                },
            ),
            None => None,
        };
        let (out_w, out_h) = layout.out;
        // The output buffer only grows (frames alternate between internal and window sizes).
        let need = out_w as u64 * out_h as u64 * 4;
        if self.out.as_ref().is_none_or(|b| b.size() < need) {
            self.out = Some(Buffer::new(&self.ctx, "view output", need, MemLoc::GpuOnly)?);
        }
        // The set-up overlay, drawn for the render's rectangle of the output actually written
        // (the reduced image on the blit path), in the swapchain's byte order.
        let mut marks = Vec::new();
        let mut regions = Vec::new();
        if let Some(info) = p.setup {
            let [rx, ry, rw, rh] = layout.view_rect;
            let mut cam = p.view.camera.clone();
            (cam.width, cam.height) = (rw, rh);
            let ov = overlay::draw(info, &cam);
            let bgra = swap.is_some_and(|s| is_bgra(s.format));
            let (data, runs) = ov.pack(out_w, (rx, ry), bgra);
            let bytes = (data.len().max(1) * 4) as u64;
            if self.overlay.as_ref().is_none_or(|b| b.size() < bytes) {
                self.overlay = Some(Buffer::new(&self.ctx, "set-up overlay", bytes, MemLoc::CpuToGpu)?);
            }
            self.overlay.as_ref().unwrap().write(0, &data)?;
            regions = runs
                .into_iter()
                .map(|(dst, src, n)| vk::BufferCopy {
                    src_offset: 4 * src,
                    dst_offset: 4 * dst,
                    size: 4 * n,
                })
                .collect::<Vec<_>>();
            marks = ov.marks;
        }
        let (tw, th) = self.target_dims.unwrap_or((0, 0));
        // The tile lists depend on the camera and the scratches only: the same camera over the
        // same uploaded scratches keeps them.
        let bin = self.cache[idx].2.as_ref() != Some(&p.view.camera);
        let gs = &mut self.cache[idx].1;
        let ok = gs.update_views(std::slice::from_ref(p.view))?;
        assert!(ok, "cached scene for {iw}x{ih} has another size");
        let push = PresentPush {
            dims: [out_w, out_h, iw, ih],
            view_rect: layout.view_rect,
            tgt_rect: if show_target { layout.tgt_rect } else { [0; 4] },
            misc: [gs.views()[0].base[1], tw, th, p.nearest as u32],
            params: [p.exposure, 0.1, 0.0, 0.0],
        };
        let out = self.out.as_ref().unwrap();
        let (pipes, ctx, target, staging) = (&self.pipes, &self.ctx, &self.target, &self.staging);
        let overlay_buf = self.overlay.as_ref();
        // Pair search, shading, present and the copy to the window in one submission; redone
        // (with larger tile lists) when a view sees more scratches per tile than the first guess.
        // (A render redone for larger lists or more passes bins again.)
        let mut first = true;
        let (stats, timings) = pipes.renderer.submit(&mut self.rec, gs, |rec, gs| {
            pipes.renderer.record_render_with(rec, gs, bin || !first);
            first = false;
            rec.dispatch(
                &pipes.present,
                &[gs.image(), target, out],
                bytemuck::bytes_of(&push),
                [out_w.div_ceil(16), out_h.div_ceil(16), 1],
            );
            rec.barrier();
            rec.timestamp("present");
            if let (false, Some(src)) = (regions.is_empty(), overlay_buf) {
                // Over the present pass's bytes; the barrier above ordered the two writes.
                unsafe {
                    ctx.device
                        .cmd_copy_buffer(rec.raw_cmd(), src.raw(), out.raw(), &regions)
                };
                rec.barrier();
                rec.timestamp("overlay");
            }
            match (swap, blit, staging_idx) {
                (Some(s), Some(_), Some(i)) => {
                    record_blit(ctx, rec.raw_cmd(), out.raw(), &staging[i], s.image, s.extent, p.nearest);
                    rec.timestamp("blit");
                }
                (Some(s), _, _) => {
                    assert_eq!(
                        s.extent,
                        (out_w, out_h),
                        "swapchain extent differs from the frame layout"
                    );
                    record_copy_to_swapchain(ctx, rec.raw_cmd(), out, s.image, (out_w, out_h));
                    rec.timestamp("copy");
                }
                _ => {}
            }
        })?;
        self.cache[idx].2 = Some(p.view.camera.clone());
        Ok(FrameInfo {
            internal: (iw, ih),
            timings,
            wall_ms: t0.elapsed().as_secs_f64() * 1e3,
            stats,
            marks,
            binned: bin,
        })
    }

    /// The last frame's display bytes (gray), top row first, for an output of `out` pixels.
    pub fn read_output_gray(&self, out: (u32, u32)) -> Result<Vec<u8>, GpuError> {
        let buf = self.out.as_ref().expect("read_output_gray before any frame");
        let px: Vec<u32> = self.ctx.download(buf)?;
        let n = out.0 as usize * out.1 as usize;
        Ok(px[..n].iter().map(|p| (p & 0xff) as u8).collect())
    }
}

impl FrameRenderer {
    /// The last frame as RGB bytes, top row first (for a screenshot with the coloured overlay).
    pub fn read_output_rgb(&self, out: (u32, u32)) -> Result<Vec<u8>, GpuError> {
        let buf = self.out.as_ref().expect("read_output_rgb before any frame");
        let px: Vec<u32> = self.ctx.download(buf)?;
        let n = out.0 as usize * out.1 as usize;
        Ok(px[..n]
            .iter()
            .flat_map(|p| [(p & 0xff) as u8, (p >> 8) as u8, (p >> 16) as u8])
            .collect())
    }
}

/// Swapchain formats that store blue in the lowest byte.
fn is_bgra(f: vk::Format) -> bool {
    matches!(
        f,
        vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB | vk::Format::B8G8R8A8_SNORM
    )
}

fn single_view_template(scene: &Scene) -> Scene {
    Scene {
        plate: scene.plate.clone(),
        views: Vec::new(),
        scratches: scene.scratches.clone(),
    }
}

/// UNDEFINED -> TRANSFER_DST, copy the output buffer, -> PRESENT_SRC. The output buffer was
/// written by the present pass; the recorder's barrier before this made it TRANSFER_READ-able.
fn record_copy_to_swapchain(ctx: &Context, cmd: vk::CommandBuffer, out: &Buffer, image: vk::Image, (w, h): (u32, u32)) {
    let range = vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .level_count(1)
        .layer_count(1);
    let to_dst = [vk::ImageMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::empty())
        .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .old_layout(vk::ImageLayout::UNDEFINED)
        .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range)];
    let to_present = [vk::ImageMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::empty())
        .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
        .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range)];
    let region = [vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .layer_count(1),
        )
        .image_extent(vk::Extent3D {
            width: w,
            height: h,
            depth: 1,
        })];
    let d = &ctx.device;
    unsafe {
        d.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TOP_OF_PIPE,
            vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &to_dst,
        );
        d.cmd_copy_buffer_to_image(cmd, out.raw(), image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &region);
        d.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::BOTTOM_OF_PIPE,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &to_present,
        );
    }
}
