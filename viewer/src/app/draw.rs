//! The per-frame render of the window: acquire a swapchain image, render the view at the
//! chosen internal resolution and present it, then adapt the level to the frame budget, update
//! the title and, under `--benchmark`, record the frame.
use std::time::{Duration, Instant};

use anyhow::Result;
use scratchart_model::scene::View;
use scratchart_vulkan::GpuError;
use winit::event_loop::ActiveEventLoop;
use winit::window::Window;

use super::App;
use crate::frame::{internal_size, FrameInfo, FrameParams, Layout, SwapImage, DIVISORS};
use crate::headless::{self, bench_path, BenchRow, BENCH_WARMUP};
use crate::swapchain::{Acquired, Presented};

impl App {
    pub(super) fn draw(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let Some(window) = self.window.clone() else {
            return Ok(());
        };
        let size = window.inner_size();
        if size.width == 0 || size.height == 0 {
            return Ok(()); // minimized: nothing to draw until restored
        }
        let still = self.still(Instant::now());
        let Some(p) = self.presenter.as_mut() else {
            return Ok(());
        };
        if self.swap_dirty || !p.has_swapchain() {
            match p.rebuild((size.width, size.height)) {
                Ok(true) => self.swap_dirty = false,
                Ok(false) => return Ok(()),
                Err(e) if is_surface_lost(&e) => {
                    eprintln!("surface lost: recreating it");
                    p.recreate_surface(&window)?;
                    window.request_redraw();
                    return Ok(());
                }
                Err(e) => return Err(e),
            }
        }
        let (index, suboptimal) = match p.acquire()? {
            Acquired::Image(i, s) => (i, s),
            Acquired::OutOfDate => {
                self.swap_dirty = true;
                window.request_redraw();
                return Ok(());
            }
            Acquired::SurfaceLost => {
                eprintln!("surface lost: recreating it");
                p.recreate_surface(&window)?;
                self.swap_dirty = true;
                window.request_redraw();
                return Ok(());
            }
            Acquired::Timeout => {
                window.request_redraw();
                return Ok(());
            }
        };
        let extent = (p.extent.width, p.extent.height);
        let image = p.image(index);
        let format = p.format;

        // Benchmark: the scripted path decides camera, light and level.
        let mut forced_level = None;
        if let Some(b) = &self.bench {
            let n = self.opts.bench_frames.max(1);
            let t = b.k.saturating_sub(BENCH_WARMUP) as f64 / n as f64;
            let (cam, light) = bench_path(&b.cam0, &b.light0, t);
            self.cam = cam;
            self.light = light;
            forced_level = Some(b.phases[b.phase]);
            self.version += 1;
        }

        let tgt = if self.show_target || self.panel {
            self.fr.target_dims()
        } else {
            None
        };
        let layout = Layout::new(extent, tgt);
        let full = layout.viewport();
        let keep: Vec<_> = (0..DIVISORS.len()).map(|l| internal_size(full, l)).collect();
        self.fr.trim_cache(&keep);
        let level = match forced_level {
            Some(Some(l)) => l,
            Some(None) => self.level,
            None if still || !self.adaptive => 0,
            None => self.level,
        };
        let (iw, ih) = internal_size(full, level);
        let view = View {
            exposure: 1.0,
            name: "interactive".into(),
            camera: self.cam.camera(iw, ih),
            light: self.light.light(),
        };
        let drawn_version = self.version;
        let info = self.fr.render(
            &FrameParams {
                view: &view,
                layout,
                exposure: self.exposure as f32,
                nearest: self.nearest,
                show_target: self.show_target || self.panel,
                setup: self.setup.as_ref(),
            },
            Some(SwapImage { image, format, extent }),
        )?;
        match p.present(index)? {
            Presented::Ok => {}
            Presented::Rebuild => self.swap_dirty = true,
            Presented::SurfaceLost => {
                eprintln!("surface lost: recreating it");
                p.recreate_surface(&window)?;
                self.swap_dirty = true;
            }
        }
        if suboptimal {
            self.swap_dirty = true;
        }
        let end = Instant::now();
        let interval_ms = self.last_frame_end.map(|t| end.duration_since(t).as_secs_f64() * 1e3);
        self.last_frame_end = Some(end);
        self.presented = Some((drawn_version, level));
        self.frames += 1;
        if self.adaptive {
            self.level = self.adapt(level, info.wall_ms, full);
        }
        self.after_frame(&window, event_loop, &info, level, full, interval_ms, still);
        Ok(())
    }

    /// The level to use for the next moving frame, from this frame's time at `used`. Model:
    /// time proportional to internal pixels, which overstates the saving of coarse levels (the
    /// binning and the present pass do not shrink); the next frame's measurement corrects it.
    fn adapt(&self, used: usize, ms: f64, full: (u32, u32)) -> usize {
        let budget = self.opts.budget_ms;
        let px = |l: usize| {
            let (w, h) = internal_size(full, l);
            w as f64 * h as f64
        };
        let per_px = ms / px(used);
        let fits = (0..DIVISORS.len())
            .find(|&l| per_px * px(l) <= 0.8 * budget)
            .unwrap_or(DIVISORS.len() - 1);
        if used == 0 {
            fits
        } else if ms > budget {
            fits.max(used + 1).min(DIVISORS.len() - 1)
        } else if fits < used {
            used - 1 // refine one step at a time
        } else {
            used
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn after_frame(
        &mut self,
        window: &Window,
        event_loop: &ActiveEventLoop,
        info: &FrameInfo,
        level: usize,
        full: (u32, u32),
        interval_ms: Option<f64>,
        still: bool,
    ) {
        let gpu_ms = info.timings.total_ms();
        let walk = self
            .walk
            .as_ref()
            .filter(|_| self.walking)
            .map(|w| (w.position(), w.label()));
        if self.opts.log_frames {
            println!(
                "frame {} t={:.3} {} internal={}x{} full={}x{} level={} wall_ms={:.1} gpu_ms={:.1} interval_ms={:.1} cam_az={:.2} cam_el={:.2} light_az={:.2} binned={} binning_ms={:.2}{}",
                self.frames,
                self.start.elapsed().as_secs_f64(),
                if level == 0 { "full" } else { "reduced" },
                info.internal.0,
                info.internal.1,
                full.0,
                full.1,
                level,
                info.wall_ms,
                gpu_ms,
                interval_ms.unwrap_or(f64::NAN),
                self.cam.azimuth_deg,
                self.cam.elevation_deg,
                self.light.azimuth_deg,
                info.binned,
                info.timings.get("binning").unwrap_or(f64::NAN),
                walk.as_ref().map(|(p, _)| format!(" walk={p:.4}")).unwrap_or_default()
                    + &self
                        .live
                        .as_ref()
                        .map(|l| {
                            format!(
                                " live_iter={} live_paused={} panel={}",
                                l.last_iteration,
                                l.paused(),
                                self.panel && self.panel_data.is_some()
                            )
                        })
                        .unwrap_or_default(),
            );
        }
        let now = Instant::now();
        if self
            .last_title
            .is_none_or(|t| now.duration_since(t) > Duration::from_millis(250))
            || still
        {
            self.last_title = Some(now);
            let ms = interval_ms.unwrap_or(info.wall_ms).max(info.wall_ms);
            let mut title = format!(
                "scratchart-view: {} | {:.1} ms ({:.1} fps) | internal {}x{} / full {}x{} | exposure {:.2}{} | H: keys",
                self.design.name(),
                ms,
                1000.0 / ms,
                info.internal.0,
                info.internal.1,
                full.0,
                full.1,
                self.exposure,
                if self.light_orbit { " | light orbiting" } else { "" }
            );
            if let Some((_, label)) = &walk {
                title += &format!(" | {label}");
            }
            if let Some(l) = &self.live {
                title += &format!(" | {} | P pause, K save", l.status());
            }
            if let Some(s) = &self.setup {
                title += &format!(" | {}", s.title());
            }
            if let Some(e) = &self.reload_error {
                title += &format!(" | RELOAD ERROR: {}", e.lines().next().unwrap_or(""));
            }
            window.set_title(&title);
        }
        if let Some(b) = self.bench.as_mut() {
            if b.k >= BENCH_WARMUP {
                b.gpu.push(gpu_ms);
                // The first timed interval includes the warm-up frame's tail: it is a real
                // frame-to-frame time all the same.
                b.interval.push(interval_ms.unwrap_or(info.wall_ms));
                b.internal.push(info.internal);
                b.timings.push(info.timings.clone());
            }
            b.k += 1;
            if b.k >= BENCH_WARMUP + self.opts.bench_frames.max(1) {
                let mut internal = b.internal.clone();
                internal.sort();
                b.rows.push(BenchRow {
                    mode: match b.phases[b.phase] {
                        Some(l) => format!("window 1/{}", DIVISORS[l]),
                        None => format!("window adaptive {:.0}ms", self.opts.budget_ms),
                    },
                    internal: internal[internal.len() / 2],
                    full,
                    gpu_ms: scratchart::bench::median(b.gpu.clone()),
                    frame_ms: scratchart::bench::median(b.interval.clone()),
                    stages: headless::stage_medians(&b.timings),
                });
                b.timings.clear();
                b.gpu.clear();
                b.interval.clear();
                b.internal.clear();
                b.k = 0;
                b.phase += 1;
                if b.phase == b.phases.len() {
                    headless::print_table(
                        &format!(
                            "window, {}x{}, {} frames per row after {BENCH_WARMUP} warm-up, camera + light moving, {}",
                            full.0,
                            full.1,
                            self.opts.bench_frames,
                            if self.opts.no_vsync { "no vsync" } else { "vsync (FIFO)" }
                        ),
                        &self.fr.ctx().info().name,
                        &b.rows,
                    );
                    event_loop.exit();
                }
            }
        }
        if self.opts.frame_count().is_some_and(|n| self.frames >= n) {
            event_loop.exit();
        }
    }
}

pub(super) fn is_surface_lost(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        matches!(
            c.downcast_ref::<GpuError>(),
            Some(GpuError::Vk {
                result: ash::vk::Result::ERROR_SURFACE_LOST_KHR,
                ..
            })
        )
    })
}
