//! `scratchart-view`: a real-time viewer for scratch-art designs. The plate is shaded by the
//! engine's own kernels (`scratchart_render::Renderer`), so what the viewer shows is what
//! `scratchart render` computes; see `viewer/README.md`.
//!
//! - [`app`]: the winit window, input, adaptive resolution, hot reload.
//! - [`frame`]: one frame: engine render at an internal size + the present pass.
//! - [`swapchain`]: surface and swapchain.
//! - [`headless`]: `--screenshot`, `--walk --frames DIR` and `--benchmark` without a window.
//! - [`state`]: the orbit camera and the light rig.
//! - [`walk`]: the walk along the design views (`--walk`, key W): interpolated cameras, timing.
//! - [`design`]: design files, target images, file watching.
//! - [`upscale`]: the blit path that upsamples reduced frames onto the swapchain image.
//! - [`setup`], [`overlay`], [`font`]: the set-up overlay (key S): the lamp and eye positions
//!   with their numbers, drawn over the plate.
mod app;
mod design;
mod font;
mod frame;
mod headless;
mod live;
mod overlay;
mod setup;
mod state;
mod swapchain;
mod upscale;
mod walk;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Parser;

/// The key list, shared by `--help` and the H key.
macro_rules! keys_text {
    () => {
        "Mouse and keys (window):
  left drag          orbit the camera around its target
  right/middle drag  pan the camera
  wheel              zoom
  shift + left drag  move the light (azimuth and elevation)
  L                  light orbits on its own: on/off
  + / -              light orbit speed x1.5 / /1.5
  1 .. 9             jump to design view N's camera and light
  W                  walk: the camera moves along the design views v0 -> v1 -> ... and back
                     (--walk-speed; mouse orbiting stops it): on/off
  T                  show/hide that view's target image beside the render
  S                  set-up overlay on/off: the lamp and every designed eye drawn over the
                     plate (an arrow at the frame's edge when off-screen or behind), the
                     plate's +x edge (orientation mark), their azimuth, elevation, distance
                     and x, y, z in mm (also printed to stdout and shown in the title)
  E / shift+E        exposure x1.25 / /1.25
  N                  upscaling while moving: bilinear / nearest
  A                  adaptive resolution while moving: on/off
  P                  live design (--design): pause / resume the optimizer
  K                  live design: save design.json and the checkpoint in its --out
  V                  live design: the design panel beside the render: every view's render
                     next to its target, the loss curve (log scale) below, as it converges
  arrows, [ / ]      live design: move (shift: 8 px, else 2) or scale (1.05x) the current
                     view's picture on the plate; recorded in summary.json's `steering`, which
                     `scratchart design --steer summary.json` replays
  G / shift+G        live design: the loss's Gram-term weight x2 / /2 (recorded the same way)
  C / shift+C        live design: a tenth more scratches, drawn as the first ones were / the
                     tenth that matter least removed (recorded the same way)
  R                  reset camera, light and exposure
  H                  print this list
  Esc / Q            quit"
    };
}
pub const KEYS: &str = keys_text!();

#[derive(Parser, Debug, Clone)]
#[command(
    name = "scratchart-view",
    version,
    about = "Real-time viewer for scratch-art designs, shaded by the engine's own GPU kernels.",
    long_about = None,
    after_help = concat!(
"Without DESIGN the built-in demo plate is shown (the same scene as `scratchart render` without a scene).\n\n",
"While the camera or light moves, the plate is rendered at a reduced internal resolution chosen so a frame \
takes at most --budget-ms, and upsampled; when everything is still it is refined to full resolution.\n\n",
"Targets: a view's optional \"target\": \"path.png\" field in the design (relative to it), else NAME_target.png \
next to the design.\n\n",
"Hot reload: the design (and its scratch CSV) is re-read when it changes on disk (a parse error keeps the old \
scene); the shaders are recompiled when a file under the shader directory changes (--shader-dir, or the source \
tree's shaders/ when it exists; a compile error keeps the last good pipelines).\n\n",
"Walk: --walk plays the design views' cameras in order, v0 -> v1 -> ... -> the last and back, \
interpolating between neighbours (azimuth the short way round, elevation, distance, field of view, target) at \
--walk-speed degrees of azimuth per second, with the light of the nearest view; key W toggles it. \
--walk --frames DIR renders it without a window, one way, as DIR/frame_0000.png ... (--walk-steps frames per \
gap, then the last view); then e.g. `ffmpeg -framerate 12 -i DIR/frame_%04d.png walk.gif`.\n\n",
"Live design: `scratchart-view --design [scratchart design's flags] [--headless] [--script S]` runs the design \
job in the viewer and shows the plate as it converges (P pause, K save); `scratchart-view --design --help` \
lists its flags.\n\n",
"Exit codes: 0 success, 1 runtime failure, 2 bad command line, 3 bad input file, 4 GPU/device failure \
(including a lost device), 5 Vulkan validation messages were reported (with --validation).\n\n",
keys_text!())
)]
pub struct Opts {
    /// Design file (JSON scene, engine/docs/model.md section 6); default: the built-in demo plate
    pub design: Option<PathBuf>,
    /// Start at (window) or render (screenshot) this view: 0-based index or name. A screenshot
    /// then uses the view's camera, light and resolution, matching `scratchart render`
    #[arg(long)]
    pub view: Option<String>,
    /// Render without a window and write the display image to this PNG
    #[arg(long, value_name = "PNG")]
    pub screenshot: Option<PathBuf>,
    /// Window size, or screenshot size (default: the view's resolution with --view, else 1280x720)
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Put the light at this azimuth (degrees about the plate normal), keeping its elevation
    #[arg(long, value_name = "DEG")]
    pub light_azimuth: Option<f64>,
    /// Exposure multiplier applied to L before the display mapping
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f64,
    /// Show the view's target image beside the render (key T)
    #[arg(long)]
    pub show_target: bool,
    /// Show the set-up overlay (key S): the lamp and eye positions over the plate with their
    /// numbers, which are also printed to stdout. With --screenshot the PNG is RGB
    #[arg(long)]
    pub setup: bool,
    /// Start with the light orbiting (key L)
    #[arg(long)]
    pub light_orbit: bool,
    /// Light orbit speed in degrees per second
    #[arg(long, default_value_t = 30.0)]
    pub light_speed: f64,
    /// Frame-time budget while moving: the internal resolution adapts to stay under it
    #[arg(long, default_value_t = 45.0, value_name = "MS")]
    pub budget_ms: f64,
    /// Always render at full resolution (no reduced resolution while moving)
    #[arg(long)]
    pub no_adaptive: bool,
    /// Present without vsync (MAILBOX or IMMEDIATE when offered)
    #[arg(long)]
    pub no_vsync: bool,
    /// Re-render every frame even when nothing changes (for measurements)
    #[arg(long)]
    pub continuous: bool,
    /// Time a scripted camera + light path at full and reduced resolution, headless and (when a
    /// display exists) in a window, and print a table
    #[arg(long)]
    pub benchmark: bool,
    /// The pair search's mode for --benchmark: `groups` (a thread per group of 64 scratches;
    /// the CPU drivers' default) or `pairs` (a thread per scratch, then a radix sort by tile;
    /// the GPUs' default). The images are the same; default: the device's choice
    #[arg(long, value_parser = parse_bin_mode)]
    pub binning: Option<scratchart_render::BinMode>,
    /// Timed frames per benchmark row (after 3 warm-up frames)
    #[arg(long, default_value_t = 20)]
    pub bench_frames: usize,
    /// Window: draw N frames, then exit (frames are drawn continuously until then, also when
    /// nothing moves). With --walk, a directory instead: render the walk without a window to
    /// DIR/frame_0000.png, frame_0001.png, ... (created if missing). A value of digits only is N:
    /// write a directory named with digits as ./123
    #[arg(long, value_name = "N|DIR", value_parser = parse_frames)]
    pub frames: Option<Frames>,
    /// Play the walk (key W): the camera moves along the design views' cameras in order, v0 ->
    /// v1 -> ... -> the last and back, with the nearest view's light. With --frames DIR: render
    /// it to PNG frames, one way. Needs a design with at least 2 views
    #[arg(long, conflicts_with_all = ["screenshot", "benchmark"])]
    pub walk: bool,
    /// Walk speed (--walk, key W) in degrees of azimuth per second (a gap between views of one
    /// azimuth takes 1 s)
    #[arg(long, default_value_t = 10.0, value_name = "DEG")]
    pub walk_speed: f64,
    /// --walk --frames DIR: frames per gap between neighbouring views (the gap's start and
    /// K - 1 in between); N views give (N - 1) x K + 1 frames
    #[arg(long, default_value_t = 4, value_name = "K", requires = "walk",
          value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub walk_steps: u32,
    /// Exit after this many seconds
    #[arg(long, value_name = "SECS")]
    pub exit_after: Option<f64>,
    /// Print one line per presented frame (and the window id at startup) to stdout
    #[arg(long)]
    pub log_frames: bool,
    /// Read (and hot-reload) shaders from this directory instead of the embedded copy
    #[arg(long, value_name = "DIR")]
    pub shader_dir: Option<PathBuf>,
    /// Use the shaders embedded at build time even when the source tree's shaders/ exists
    #[arg(long, conflicts_with = "shader_dir")]
    pub embedded_shaders: bool,
    /// Vulkan device: index or part of the name (default: best available)
    #[arg(long)]
    pub device: Option<String>,
    /// Enable the Vulkan validation layer; print the message count on exit, exit code 1 if any
    #[arg(long)]
    pub validation: bool,
}

/// `--frames`: a count of window frames, or the directory of a walk's frames.
#[derive(Clone, Debug, PartialEq)]
pub enum Frames {
    Count(u64),
    Dir(PathBuf),
}

/// All digits: a count; anything else: a directory (`./123` for a directory named 123).
fn parse_frames(s: &str) -> Result<Frames, String> {
    if s.is_empty() {
        Err("give a number of frames or, with --walk, a directory".into())
    } else if s.bytes().all(|b| b.is_ascii_digit()) {
        s.parse::<u64>()
            .map(Frames::Count)
            .map_err(|e| format!("'{s}' is not a frame count: {e} (a directory named with digits is written ./{s})"))
    } else {
        Ok(Frames::Dir(PathBuf::from(s)))
    }
}

impl Opts {
    /// `--frames N`: the window's frame count.
    pub fn frame_count(&self) -> Option<u64> {
        match self.frames {
            Some(Frames::Count(n)) => Some(n),
            _ => None,
        }
    }

    /// `--frames DIR`: where the walk's frames go.
    pub fn frames_dir(&self) -> Option<&Path> {
        match &self.frames {
            Some(Frames::Dir(d)) => Some(d),
            _ => None,
        }
    }
}

/// The refusal of `--walk` (or key W's message) for a design with fewer than 2 views.
pub fn walk_refused(design: &design::Design) -> anyhow::Error {
    scratchart_exit::UsageError(format!(
        "--walk needs a design with at least 2 views: {} has {} ({})",
        design.name(),
        design.scene.views.len(),
        design
            .scene
            .views
            .iter()
            .map(|v| v.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    ))
    .into()
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH (e.g. 1280x720)"))?;
    let p = |t: &str| {
        t.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| (1..=16384).contains(&n))
            .ok_or_else(|| format!("'{t}' in '{s}' is not a size between 1 and 16384"))
    };
    Ok((p(w)?, p(h)?))
}

/// The shader directory to read (and watch), if any: `--shader-dir`, else the source tree's.
fn shader_dir(opts: &Opts) -> Option<PathBuf> {
    if opts.embedded_shaders {
        return None;
    }
    if let Some(d) = &opts.shader_dir {
        return Some(d.clone());
    }
    let src = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders"));
    src.join("forward.comp").exists().then_some(src)
}

fn main() -> ExitCode {
    let argv: Vec<String> = std::env::args().collect();
    let log = std::cell::RefCell::new(None);
    // `--design` anywhere: the live design, with `scratchart design`'s flags.
    let (r, validation) = match live::live_args(&argv) {
        Some(largs) => {
            let _ = scratchart::exit::process_start();
            let o = match <live::LiveOpts as clap::Parser>::try_parse_from(largs) {
                Ok(o) => o,
                Err(e) => {
                    let _ = e.print();
                    return if e.use_stderr() {
                        scratchart_exit::Class::Usage.exit_code()
                    } else {
                        ExitCode::SUCCESS
                    };
                }
            };
            (
                if o.headless {
                    live::run_headless(&o, &log)
                } else {
                    app::run_live_window(&o, &log)
                },
                o.validation,
            )
        }
        None => {
            let opts = match scratchart::exit::parse_args::<Opts>() {
                Ok(o) => o,
                Err(code) => return code,
            };
            (run(&opts, &log), opts.validation)
        }
    };
    // Counted after everything Vulkan was dropped, so leaks reported at destruction count too.
    let n_validation = log
        .borrow()
        .as_ref()
        .map(|l: &scratchart_vulkan::ValidationLog| l.messages().len());
    let n_validation = n_validation.filter(|_| validation);
    if let Some(n) = n_validation {
        eprintln!("validation messages: {n}");
    }
    // Validation messages fail a run like any other failure (the contract's runtime class).
    let r = match (r, n_validation) {
        (Ok(()), Some(n)) if n > 0 => Err(anyhow::anyhow!(
            "the Vulkan validation layer reported {n} message(s) (see above)"
        )),
        (r, _) => r,
    };
    scratchart::exit::finish(r)
}

fn run(opts: &Opts, log: &std::cell::RefCell<Option<scratchart_vulkan::ValidationLog>>) -> Result<()> {
    if !(opts.exposure.is_finite() && opts.exposure > 0.0) {
        return Err(scratchart_exit::UsageError(format!("--exposure {}: a positive number", opts.exposure)).into());
    }
    if let Some(p) = &opts.screenshot {
        let png = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !png {
            return Err(scratchart_exit::UsageError(format!(
                "--screenshot {}: a screenshot is written as PNG (lossless, as `scratchart render` writes); \
                 give a name ending in .png",
                p.display()
            ))
            .into());
        }
    }
    if let (Some(d), false) = (opts.frames_dir(), opts.walk) {
        return Err(scratchart_exit::UsageError(format!(
            "--frames {} is a directory, which is where a walk's frames go: add --walk to render \
             the walk there (for a number of window frames give digits, e.g. --frames 10; a \
             directory named only with digits is written ./123)",
            d.display()
        ))
        .into());
    }
    if !(opts.walk_speed.is_finite() && opts.walk_speed > 0.0) {
        return Err(
            scratchart_exit::UsageError("--walk-speed must be a positive number of degrees per second".into()).into(),
        );
    }
    let design = match &opts.design {
        Some(p) => design::Design::load(p)?,
        None => design::Design::demo(),
    };
    if opts.walk && design.scene.views.len() < 2 {
        return Err(walk_refused(&design));
    }
    let shaders = shader_dir(opts);
    if let Some(d) = &shaders {
        eprintln!("shaders: {} (hot reload)", d.display());
    }
    if opts.screenshot.is_some() {
        return headless::screenshot(opts, &design, shaders.as_deref(), log);
    }
    if let Some(dir) = opts.frames_dir() {
        return headless::walk_frames(opts, &design, shaders.as_deref(), log, dir);
    }
    if opts.benchmark {
        headless::benchmark(opts, &design, shaders.as_deref(), log)?;
        if !app::display_available() {
            eprintln!("no display (DISPLAY / WAYLAND_DISPLAY unset): windowed benchmark skipped");
            return Ok(());
        }
    }
    app::run_window(opts, design, shaders, log)
}

/// `--binning`'s values.
fn parse_bin_mode(s: &str) -> std::result::Result<scratchart_render::BinMode, String> {
    scratchart_render::BinMode::parse(s).ok_or_else(|| format!("'{s}': choose groups or pairs"))
}
