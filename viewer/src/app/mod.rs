//! The window: winit 0.30 `ApplicationHandler`, input, the adaptive internal resolution, hot
//! reload of the design and the shaders, and the windowed half of `--benchmark`.
//!
//! Frame policy: a frame is drawn only when something changed (camera, light, exposure, scene,
//! shaders, window size) or when the last frame was drawn at a reduced resolution and the scene
//! has since been still for [`SETTLE`]; then it is refined once at full resolution and the
//! viewer sleeps. While moving, the level of [`DIVISORS`] is chosen from the measured frame
//! times so a frame stays under `--budget-ms`.
//!
//! Files: this one holds the [`App`] state and [`run_window`]; `lifecycle.rs` the winit
//! callbacks (window and surface created on `Resumed`, dropped on `Suspended`, the wake-up
//! policy); `input.rs` keys and mouse; `reload.rs` the polling of the design and shader files;
//! `draw.rs` the per-frame render, the adaptive level and the windowed benchmark's bookkeeping.
use std::cell::RefCell;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime};

use anyhow::{Context as _, Result};
use scratchart_vulkan::ValidationLog;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::window::Window;

use crate::design::{dir_fingerprint, mtimes, Design};
use crate::frame::{FrameRenderer, DIVISORS};
use crate::headless::{self, BenchRow, BENCH_LEVELS};
use crate::setup::SetupInfo;
use crate::state::{LightRig, OrbitCamera};
use crate::swapchain::Presenter;
use crate::walk::Walk;
use crate::Opts;

mod draw;
mod input;
mod lifecycle;
mod reload;

/// Still for this long after the last change: refine to full resolution.
const SETTLE: Duration = Duration::from_millis(120);
/// How often the design file and the shader directory are polled.
const POLL: Duration = Duration::from_millis(500);

pub fn display_available() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|k| std::env::var_os(k).is_some_and(|v| !v.is_empty()))
}

/// The window of a live design (`scratchart-view --design ...`): the design job's optimizer
/// runs in its own thread ([`crate::live::Session`]) and the window shows the design as it
/// stands, with the viewer's camera and lamp.
pub fn run_live_window(o: &crate::live::LiveOpts, log: &RefCell<Option<ValidationLog>>) -> Result<()> {
    if !display_available() {
        anyhow::bail!(
            "no display: DISPLAY and WAYLAND_DISPLAY are unset (add --headless to run the live design without a window)"
        );
    }
    let script = match &o.script {
        Some(s) => crate::live::parse_script(s).map_err(scratchart_exit::UsageError)?,
        None => Vec::new(),
    };
    let event_loop = EventLoop::new().context("cannot connect to the display")?;
    let inst = crate::swapchain::required_instance_extensions(&event_loop)?;
    let ctx = crate::live::context(o, inst, vec![ash::khr::swapchain::NAME], log)?;
    let obs = scratchart::term::Terminal::new(o.design.quiet);
    let (problem, cfg) = scratchart::design_cmd::prepare(&ctx, &o.design, &obs)?;
    let design = Design::live(&problem);
    let mut opts = <Opts as clap::Parser>::parse_from(["scratchart-view"]);
    opts.size = o.size;
    opts.device = o.device.clone();
    opts.validation = o.validation;
    opts.exit_after = o.exit_after;
    opts.log_frames = o.log_frames;
    let fr = headless::make_frame_renderer(&ctx, &design, None)?;
    let session = crate::live::Session::start(ctx.clone(), problem, cfg, script, o.design.quiet, o.paused, true);
    let mut app = App::new(opts, design, None, fr)?;
    app.live = Some(session);
    app.panel = o.panel;
    // (as the flags were written: 0.01, not the f32 0.0099999998)
    app.weights = (
        o.design.lambda_p.to_string().parse().unwrap_or(1.0),
        o.design.lambda_g.to_string().parse().unwrap_or(0.01),
    );
    event_loop.run_app(&mut app)?;
    app.presenter = None;
    // The window closed: the optimization stops at the next iteration boundary, and the
    // design is finished and written as after its last iteration.
    let mut live = app.live.take().expect("a live session");
    if live.done.is_none() {
        eprintln!(
            "live design: stopping at iteration {} and finishing the design ...",
            live.last_iteration
        );
    }
    live.join();
    let err = live.error.take();
    match (app.error.take(), err) {
        (Some(e), _) | (None, Some(e)) => Err(e),
        (None, None) => Ok(()),
    }
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
    timings: Vec<scratchart_vulkan::Timings>,
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
    /// The set-up overlay (key S) when on.
    setup: Option<SetupInfo>,
    light_orbit: bool,
    light_speed: f64,
    /// The walk along the design's views (`None` with fewer than 2 views) and whether it plays.
    walk: Option<Walk>,
    walking: bool,
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
    /// A live design's optimizer (`--design`).
    live: Option<crate::live::Session>,
    /// The design panel (key V, live design): every view's render beside its target and the
    /// loss curve, shown in the target's place.
    panel: bool,
    /// The latest renders for the panel.
    panel_data: Option<crate::live::ViewsUpdate>,
    /// Per view, where the live design's picture is asked to be (shift in pixels, scale),
    /// from where the design placed it (arrows, [ and ]).
    steer: Vec<([f64; 2], f64)>,
    /// The live design's loss weights as last asked (lambda_p, lambda_g; key G).
    weights: (f64, f64),
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
        let mut walk = Walk::new(&design.scene.views, opts.walk_speed);
        if let Some(w) = walk.as_mut() {
            w.start_at(view_idx);
        }
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
            setup: None,
            light_orbit: opts.light_orbit,
            light_speed: opts.light_speed,
            walking: opts.walk && walk.is_some(),
            walk,
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
            live: None,
            panel: false,
            panel_data: None,
            steer: Vec::new(),
            weights: (1.0, 0.01),
            opts,
        };
        if app.opts.show_target {
            app.toggle_target()?;
        }
        if app.opts.setup {
            app.toggle_setup();
        }
        Ok(app)
    }

    /// Takes a live design's news: the design as it stands (shown at once), a script's lamp,
    /// saves, and the end (then the written, pruned design is shown).
    fn poll_live(&mut self) -> Result<()> {
        let Some(l) = self.live.as_mut() else { return Ok(()) };
        let (scene, updates) = l.poll();
        let out = l.out.clone();
        let done = l.done.clone();
        if let Some(sc) = scene {
            // The lamp's intensity is the optimizer's (it calibrates and optimizes it); where the
            // lamp stands stays the window's.
            if let Some(v) = sc.views.get(self.view_idx) {
                self.light.intensity = v.light.intensity * v.exposure;
            }
            self.fr.set_scene(&sc);
            self.design.scene = sc;
            self.bump();
        }
        for u in updates {
            match u {
                crate::live::Update::Lamp(az, el) => {
                    self.light.azimuth_deg = az;
                    self.light.elevation_deg = el;
                    eprintln!("live design: lamp at azimuth {az}, elevation {el}");
                    self.bump();
                }
                crate::live::Update::Saved(Ok(k)) => {
                    eprintln!("live design: saved at iteration {k} in {}", out.display())
                }
                crate::live::Update::Saved(Err(e)) => eprintln!("warning: live design: the save failed: {e}"),
                crate::live::Update::Done(_) => match &done {
                    Some(Ok(())) => {
                        let path = out.join("design.json");
                        match Design::load(&path) {
                            Ok(d) => {
                                self.fr.set_scene(&d.scene);
                                self.design.scene = d.scene;
                                eprintln!("live design: finished; showing {}", path.display());
                            }
                            Err(e) => eprintln!("warning: live design: cannot show {}: {e:#}", path.display()),
                        }
                        self.bump();
                    }
                    Some(Err(e)) => eprintln!("error: live design: {e}"),
                    None => {}
                },
                crate::live::Update::Steered(Ok((v, k, target))) => {
                    if let Some(Some(t)) = self.design.targets.get_mut(v) {
                        t.data = target;
                    }
                    eprintln!(
                        "live design: {}'s picture moved at iteration {k}",
                        self.design.scene.views[v].name
                    );
                    if self.show_target && v == self.view_idx {
                        self.show_target = false;
                        self.toggle_target()?;
                    }
                }
                crate::live::Update::Steered(Err(e)) | crate::live::Update::Note(Err(e)) => {
                    eprintln!("warning: live design: {e}")
                }
                crate::live::Update::Note(Ok(m)) => eprintln!("live design: {m}"),
                crate::live::Update::Views(v) => {
                    self.panel_data = Some(*v);
                    if self.panel {
                        self.upload_panel()?;
                        self.bump();
                    }
                }
                crate::live::Update::Step { .. } => {}
            }
        }
        Ok(())
    }

    /// Puts the design panel in the target's place.
    fn upload_panel(&mut self) -> Result<()> {
        if let Some(v) = &self.panel_data {
            let t = crate::live::panel(v, &self.design.targets);
            self.fr.set_target(Some(&t))?;
        }
        Ok(())
    }

    /// Arrows and [ ]: move or scale the current view's picture (a live design only): the
    /// optimizer takes it at its next iteration, and records it in summary.json.
    fn steer_picture(&mut self, dx: f64, dy: f64, factor: f64) {
        let Some(l) = &self.live else {
            return;
        };
        if self.steer.len() < self.design.scene.views.len() {
            self.steer.resize(self.design.scene.views.len(), ([0.0, 0.0], 1.0));
        }
        let s = &mut self.steer[self.view_idx];
        s.0[0] += dx;
        s.0[1] += dy;
        s.1 = (s.1 * factor).clamp(0.1, 10.0);
        let name = &self.design.scene.views[self.view_idx].name;
        eprintln!(
            "live design: {name}'s picture to shift ({:+.0}, {:+.0}) px, scale {:.3}",
            s.0[0], s.0[1], s.1
        );
        l.request_steer(name, s.0, s.1);
    }

    /// Key G (shift: down): the live design's Gram-term weight x2 (/2) from its next iteration.
    fn steer_gram(&mut self, factor: f64) {
        let Some(l) = &self.live else {
            return;
        };
        self.weights.1 = (self.weights.1 * factor).clamp(1e-6, 1e3);
        eprintln!(
            "live design: the Gram term's weight to {} (the pixel term's {})",
            self.weights.1, self.weights.0
        );
        l.request_weights(self.weights.0, self.weights.1);
    }

    /// Key C (shift: remove): the live design gets a tenth more scratches (at least one),
    /// drawn as its first ones were, or loses the tenth that matter least.
    fn steer_count(&mut self, add: bool) {
        let Some(l) = &self.live else {
            return;
        };
        let n = (self.design.scene.scratches.len() as i64 / 10).max(1);
        eprintln!(
            "live design: {} {n} scratches at the next iteration boundary",
            if add { "adding" } else { "removing" }
        );
        l.request_scratches(if add { n } else { -n });
    }

    /// Key V: the design panel on or off (a live design only).
    fn toggle_panel(&mut self) -> Result<()> {
        if self.live.is_none() {
            eprintln!("V: the design panel belongs to a live design (scratchart-view --design ...)");
            return Ok(());
        }
        self.panel = !self.panel;
        if self.panel {
            self.show_target = false;
            self.upload_panel()?;
            eprintln!("design panel on: every view's render beside its target, the loss curve below");
        } else {
            self.fr.set_target(None)?;
        }
        self.bump();
        Ok(())
    }

    fn bump(&mut self) {
        self.version += 1;
        self.last_change = Instant::now();
    }

    fn dragging(&self) -> bool {
        self.buttons.iter().any(|&b| b)
    }

    fn still(&self, now: Instant) -> bool {
        !self.dragging()
            && !self.light_orbit
            && !self.walking
            && self.bench.is_none()
            && now.duration_since(self.last_change) >= SETTLE
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }
}
