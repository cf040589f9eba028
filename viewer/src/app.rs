//! The window: winit 0.30 `ApplicationHandler`, input, the adaptive internal resolution, hot
//! reload of the design and the shaders, and the windowed half of `--benchmark`.
//!
//! Frame policy: a frame is drawn only when something changed (camera, light, exposure, scene,
//! shaders, window size) or when the last frame was drawn at a reduced resolution and the scene
//! has since been still for [`SETTLE`]; then it is refined once at full resolution and the
//! viewer sleeps. While moving, the level of [`DIVISORS`] is chosen from the measured frame
//! times so a frame stays under `--budget-ms`.
use std::cell::RefCell;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime};

use anyhow::{Context as _, Result};
use raw_window_handle::{HasWindowHandle, RawWindowHandle};
use scratchart::model::scene::View;
use scratchart::vulkan::{GpuError, ShaderCompiler, ValidationLog};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::design::{dir_fingerprint, mtimes, Design};
use crate::frame::{internal_size, FrameInfo, FrameParams, FrameRenderer, Layout, SwapImage, DIVISORS};
use crate::headless::{self, bench_path, BenchRow, BENCH_LEVELS, BENCH_WARMUP};
use crate::state::{LightRig, OrbitCamera};
use crate::swapchain::{Acquired, Presented, Presenter};
use crate::Opts;

/// Still for this long after the last change: refine to full resolution.
const SETTLE: Duration = Duration::from_millis(120);
/// How often the design file and the shader directory are polled.
const POLL: Duration = Duration::from_millis(500);

pub fn display_available() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|k| std::env::var_os(k).is_some_and(|v| !v.is_empty()))
}

pub fn run_window(
    opts: &Opts,
    design: Design,
    shaders: Option<PathBuf>,
    log: &RefCell<Option<ValidationLog>>,
) -> Result<()> {
    if !display_available() {
        anyhow::bail!(
            "no display: DISPLAY and WAYLAND_DISPLAY are unset (use --screenshot PNG to render \
             without a window)"
        );
    }
    let event_loop = EventLoop::new().context("cannot connect to the display")?;
    let inst = crate::swapchain::required_instance_extensions(&event_loop)?;
    let ctx = headless::make_context(opts, inst, vec![ash::khr::swapchain::NAME], log)?;
    let fr = headless::make_frame_renderer(&ctx, &design, shaders.as_deref())?;
    let mut app = App::new(opts.clone(), design, shaders, fr)?;
    event_loop.run_app(&mut app)?;
    // Surface before window, everything before the context (dropped with `app`).
    app.presenter = None;
    match app.error.take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// One phase of the windowed benchmark: a fixed level, or `None` for the adaptive choice.
struct WindowBench {
    phases: Vec<Option<usize>>,
    phase: usize,
    k: usize,
    gpu: Vec<f64>,
    interval: Vec<f64>,
    internal: Vec<(u32, u32)>,
    timings: Vec<scratchart::vulkan::Timings>,
    rows: Vec<BenchRow>,
    cam0: OrbitCamera,
    light0: LightRig,
}

struct App {
    opts: Opts,
    design: Design,
    shaders: Option<PathBuf>,
    // Field order is drop order: the surface goes before the window it was made from.
    presenter: Option<Presenter>,
    window: Option<Arc<Window>>,
    fr: FrameRenderer,

    cam: OrbitCamera,
    light: LightRig,
    view_idx: usize,
    exposure: f64,
    show_target: bool,
    light_orbit: bool,
    light_speed: f64,
    nearest: bool,
    adaptive: bool,

    cursor: Option<(f64, f64)>,
    buttons: [bool; 3],
    shift: bool,
    light_drag: bool,

    /// Bumped on every change that alters the image.
    version: u64,
    /// (version, level) of the last presented frame.
    presented: Option<(u64, usize)>,
    last_change: Instant,
    last_tick: Instant,
    swap_dirty: bool,
    /// Level to use while moving (adapted from measured frame times).
    level: usize,
    frames: u64,
    start: Instant,
    last_frame_end: Option<Instant>,
    last_title: Option<Instant>,
    last_poll: Instant,
    design_mtimes: Vec<Option<SystemTime>>,
    shader_fp: Vec<(PathBuf, Option<SystemTime>)>,
    reload_error: Option<String>,
    error: Option<anyhow::Error>,
    bench: Option<WindowBench>,
}

impl App {
    fn new(opts: Opts, design: Design, shaders: Option<PathBuf>, fr: FrameRenderer) -> Result<App> {
        let view_idx = opts
            .view
            .as_deref()
            .map(|s| design.view_index(s))
            .transpose()?
            .unwrap_or(0);
        let (cam, light) = headless::initial_state(&opts, &design, view_idx);
        let now = Instant::now();
        let bench = opts.benchmark.then(|| WindowBench {
            phases: BENCH_LEVELS.iter().map(|&l| Some(l)).chain([None]).collect(),
            phase: 0,
            k: 0,
            gpu: Vec::new(),
            interval: Vec::new(),
            internal: Vec::new(),
            timings: Vec::new(),
            rows: Vec::new(),
            cam0: cam.clone(),
            light0: light.clone(),
        });
        let mut app = App {
            design_mtimes: mtimes(&design.watched),
            shader_fp: shaders.as_deref().map(dir_fingerprint).unwrap_or_default(),
            exposure: opts.exposure,
            show_target: false,
            light_orbit: opts.light_orbit,
            light_speed: opts.light_speed,
            nearest: false,
            adaptive: !opts.no_adaptive,
            design,
            shaders,
            presenter: None,
            window: None,
            fr,
            cam,
            light,
            view_idx,
            cursor: None,
            buttons: [false; 3],
            shift: false,
            light_drag: false,
            version: 0,
            presented: None,
            last_change: now,
            last_tick: now,
            swap_dirty: true,
            level: DIVISORS.len() / 2,
            frames: 0,
            start: now,
            last_frame_end: None,
            last_title: None,
            last_poll: now,
            reload_error: None,
            error: None,
            bench,
            opts,
        };
        if app.opts.show_target {
            app.toggle_target()?;
        }
        Ok(app)
    }

    fn bump(&mut self) {
        self.version += 1;
        self.last_change = Instant::now();
    }

    fn dragging(&self) -> bool {
        self.buttons.iter().any(|&b| b)
    }

    fn still(&self, now: Instant) -> bool {
        !self.dragging() && !self.light_orbit && self.bench.is_none() && now.duration_since(self.last_change) >= SETTLE
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    fn toggle_target(&mut self) -> Result<()> {
        if self.show_target {
            self.show_target = false;
            self.fr.set_target(None)?;
        } else {
            match self.design.targets.get(self.view_idx).and_then(|t| t.as_ref()) {
                Some(t) => {
                    self.fr.set_target(Some(t))?;
                    self.show_target = true;
                    eprintln!("target: {}", t.path.display());
                }
                None => eprintln!(
                    "view '{}' has no target image (add \"target\": \"file.png\" to the view, or \
                     put {}_target.png next to the design)",
                    self.design.scene.views[self.view_idx].name, self.design.scene.views[self.view_idx].name
                ),
            }
        }
        self.bump();
        Ok(())
    }

    fn jump_to_view(&mut self, idx: usize) -> Result<()> {
        let Some(v) = self.design.scene.views.get(idx) else {
            eprintln!("the design has only {} views", self.design.scene.views.len());
            return Ok(());
        };
        eprintln!("view {idx}: '{}'", v.name);
        self.cam = OrbitCamera::from_camera(&v.camera);
        self.light = LightRig::from_light(&v.light);
        self.view_idx = idx;
        if self.show_target {
            // Show the new view's target (or none).
            self.show_target = false;
            self.fr.set_target(None)?;
            self.toggle_target()?;
        }
        self.bump();
        Ok(())
    }

    fn reset(&mut self) -> Result<()> {
        let idx = self
            .opts
            .view
            .as_deref()
            .and_then(|s| self.design.view_index(s).ok())
            .unwrap_or(0);
        let (cam, light) = headless::initial_state(&self.opts, &self.design, idx);
        self.cam = cam;
        self.light = light;
        self.view_idx = idx;
        self.exposure = self.opts.exposure;
        self.light_orbit = false;
        self.light_speed = self.opts.light_speed;
        if self.show_target {
            self.toggle_target()?;
        }
        self.bump();
        Ok(())
    }

    fn on_key(&mut self, key: &Key, event_loop: &ActiveEventLoop) -> Result<()> {
        let ch = match key {
            Key::Named(NamedKey::Escape) => {
                event_loop.exit();
                return Ok(());
            }
            Key::Character(s) => s.to_lowercase(),
            _ => return Ok(()),
        };
        match ch.as_str() {
            "q" => event_loop.exit(),
            "l" => {
                self.light_orbit = !self.light_orbit;
                eprintln!("light orbit {}", if self.light_orbit { "on" } else { "off" });
                self.bump();
            }
            "+" | "=" => {
                self.light_speed *= 1.5;
                eprintln!("light orbit speed {:.1} deg/s", self.light_speed);
            }
            "-" | "_" => {
                self.light_speed /= 1.5;
                eprintln!("light orbit speed {:.1} deg/s", self.light_speed);
            }
            "t" => self.toggle_target()?,
            "e" => {
                if self.shift {
                    self.exposure /= 1.25;
                } else {
                    self.exposure *= 1.25;
                }
                eprintln!("exposure {:.3}", self.exposure);
                self.bump();
            }
            "n" => {
                self.nearest = !self.nearest;
                eprintln!("upscaling: {}", if self.nearest { "nearest" } else { "bilinear" });
                self.bump();
            }
            "a" => {
                self.adaptive = !self.adaptive;
                eprintln!("adaptive resolution {}", if self.adaptive { "on" } else { "off" });
                self.bump();
            }
            "r" => self.reset()?,
            "h" => eprintln!("{}", crate::KEYS),
            d if d.len() == 1 && ("1"..="9").contains(&d) => self.jump_to_view(d.parse::<usize>().unwrap() - 1)?,
            _ => {}
        }
        Ok(())
    }

    fn on_drag(&mut self, dx: f64, dy: f64) {
        let h = self
            .window
            .as_ref()
            .map(|w| w.inner_size().height as f64)
            .unwrap_or(720.0);
        if self.buttons[0] {
            if self.light_drag {
                self.light.drag(dx, dy);
            } else {
                self.cam.orbit(dx, dy);
            }
        } else {
            self.cam.pan(dx, dy, h);
        }
        self.bump();
    }

    /// Polls the design files and the shader directory (every [`POLL`]).
    fn poll_files(&mut self) -> Result<()> {
        let now = Instant::now();
        if now.duration_since(self.last_poll) < POLL {
            return Ok(());
        }
        self.last_poll = now;
        let m = mtimes(&self.design.watched);
        if m != self.design_mtimes {
            self.design_mtimes = m;
            let path = self.design.path.clone().expect("watched files imply a design file");
            match Design::load(&path) {
                Ok(d) => {
                    eprintln!(
                        "reloaded {} ({} scratches, {} views)",
                        path.display(),
                        d.scene.scratches.len(),
                        d.scene.views.len()
                    );
                    self.fr.set_scene(&d.scene);
                    self.design_mtimes = mtimes(&d.watched);
                    self.design = d;
                    self.view_idx = self.view_idx.min(self.design.scene.views.len() - 1);
                    if self.show_target {
                        self.show_target = false;
                        self.fr.set_target(None)?;
                        self.toggle_target()?;
                    }
                    self.reload_error = None;
                    self.bump();
                }
                Err(e) => {
                    eprintln!("reload failed, keeping the previous scene: {e:#}");
                    self.reload_error = Some(format!("{e:#}"));
                    self.last_title = None;
                }
            }
        }
        if let Some(dir) = self.shaders.clone() {
            let fp = dir_fingerprint(&dir);
            if fp != self.shader_fp {
                self.shader_fp = fp;
                ShaderCompiler::override_embedded(Some(dir.clone()));
                match self.fr.reload_shaders() {
                    Ok(()) => {
                        eprintln!("shaders recompiled from {}", dir.display());
                        self.fr.set_scene(&self.design.scene);
                        self.bump();
                    }
                    Err(e @ GpuError::Shader { .. }) => {
                        eprintln!("shader reload failed, keeping the last good pipelines:\n{e}")
                    }
                    Err(e) => return Err(e.into()),
                }
            }
        }
        Ok(())
    }

    fn window_id_text(window: &Window) -> Option<String> {
        match window.window_handle().ok()?.as_raw() {
            RawWindowHandle::Xlib(h) => Some(h.window.to_string()),
            RawWindowHandle::Xcb(h) => Some(h.window.get().to_string()),
            _ => None,
        }
    }

    fn draw(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
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

        let tgt = if self.show_target { self.fr.target_dims() } else { None };
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
                show_target: self.show_target,
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
        if self.opts.log_frames {
            println!(
                "frame {} t={:.3} {} internal={}x{} full={}x{} level={} wall_ms={:.1} gpu_ms={:.1} interval_ms={:.1} cam_az={:.2} cam_el={:.2} light_az={:.2}",
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
                    gpu_ms: headless::median(&mut b.gpu),
                    frame_ms: headless::median(&mut b.interval),
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
        if self.opts.frames.is_some_and(|n| self.frames >= n) {
            event_loop.exit();
        }
    }
}

fn is_surface_lost(e: &anyhow::Error) -> bool {
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

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            let (w, h) = self.opts.size.unwrap_or(headless::DEFAULT_SIZE);
            let attrs = Window::default_attributes()
                .with_title("scratchart-view")
                .with_inner_size(PhysicalSize::new(w, h));
            match event_loop.create_window(attrs) {
                Ok(win) => {
                    if self.opts.log_frames {
                        if let Some(id) = Self::window_id_text(&win) {
                            println!("window-id {id}");
                        }
                    }
                    self.window = Some(Arc::new(win));
                }
                Err(e) => return self.fail(event_loop, anyhow::Error::new(e).context("cannot create the window")),
            }
        }
        let window = self.window.clone().unwrap();
        if self.presenter.is_none() {
            match Presenter::new(self.fr.ctx(), &window, !self.opts.no_vsync) {
                Ok(p) => self.presenter = Some(p),
                Err(e) => return self.fail(event_loop, e),
            }
        }
        self.swap_dirty = true;
        self.presented = None;
        window.request_redraw();
    }

    fn suspended(&mut self, _event_loop: &ActiveEventLoop) {
        // The window's native surface may go away (Android-style lifecycles): drop ours now.
        self.presenter = None;
    }

    fn exiting(&mut self, _event_loop: &ActiveEventLoop) {
        self.presenter = None;
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let r: Result<()> = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::Resized(_) | WindowEvent::ScaleFactorChanged { .. } => {
                self.swap_dirty = true;
                self.presented = None;
                Ok(())
            }
            WindowEvent::RedrawRequested => self.draw(event_loop),
            WindowEvent::ModifiersChanged(m) => {
                self.shift = m.state().shift_key();
                Ok(())
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.on_key(&event.logical_key, event_loop)
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let i = match button {
                    MouseButton::Left => Some(0),
                    MouseButton::Right => Some(1),
                    MouseButton::Middle => Some(2),
                    _ => None,
                };
                if let Some(i) = i {
                    let down = state == ElementState::Pressed;
                    if i == 0 && down {
                        self.light_drag = self.shift;
                    }
                    self.buttons[i] = down;
                    self.last_change = Instant::now();
                }
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                let (x, y) = (position.x, position.y);
                if let (Some((px, py)), true) = (self.cursor, self.dragging()) {
                    self.on_drag(x - px, y - py);
                }
                self.cursor = Some((x, y));
                Ok(())
            }
            WindowEvent::CursorLeft { .. } => {
                self.cursor = None;
                Ok(())
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.cam.zoom(steps);
                self.bump();
                Ok(())
            }
            _ => Ok(()),
        };
        if let Err(e) = r {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        if let Some(limit) = self.opts.exit_after {
            if now.duration_since(self.start).as_secs_f64() >= limit {
                event_loop.exit();
                return;
            }
        }
        let dt = now.duration_since(self.last_tick).as_secs_f64();
        self.last_tick = now;
        if self.light_orbit {
            self.light.rotate(self.light_speed * dt.min(0.25));
            self.bump();
        }
        if let Err(e) = self.poll_files() {
            return self.fail(event_loop, e);
        }
        let still = self.still(now);
        let want_level = if still || !self.adaptive { 0 } else { self.level };
        let stale = match self.presented {
            None => true,
            Some((v, l)) => v != self.version || (still && l != 0 && l != want_level),
        };
        let need = stale || self.swap_dirty || self.opts.continuous || self.bench.is_some();
        let minimized = self
            .window
            .as_ref()
            .is_none_or(|w| w.inner_size().width == 0 || w.inner_size().height == 0);
        let mut wake = self.last_poll + POLL;
        if let Some(limit) = self.opts.exit_after {
            wake = wake.min(self.start + Duration::from_secs_f64(limit));
        }
        if !still {
            wake = wake.min(self.last_change + SETTLE);
        }
        if need && !minimized && self.presenter.is_some() {
            if let Some(w) = &self.window {
                w.request_redraw();
            }
            event_loop.set_control_flow(ControlFlow::Poll);
        } else {
            event_loop.set_control_flow(ControlFlow::WaitUntil(wake.max(now + Duration::from_millis(1))));
        }
    }
}
