//! `scratchart-view`: a real-time viewer for scratch-art designs. The plate is shaded by the
//! engine's own kernels (`scratchart::render::Renderer`), so what the viewer shows is what
//! `scratchart render` computes; see `viewer/README.md`.
//!
//! - [`app`]: the winit window, input, adaptive resolution, hot reload.
//! - [`frame`]: one frame: engine render at an internal size + the present pass.
//! - [`swapchain`]: surface and swapchain.
//! - [`headless`]: `--screenshot` and `--benchmark` without a window.
//! - [`state`]: the orbit camera and the light rig.
//! - [`design`]: design files, target images, file watching.
//! - [`upscale`]: the blit path that upsamples reduced frames onto the swapchain image.
//! - [`setup`], [`overlay`], [`font`]: the set-up overlay (key S): the lamp and eye positions
//!   with their numbers, drawn over the plate.
mod app;
mod design;
mod font;
mod frame;
mod headless;
mod overlay;
mod setup;
mod state;
mod swapchain;
mod upscale;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Result};
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
  T                  show/hide that view's target image beside the render
  S                  set-up overlay on/off: the lamp and every designed eye drawn over the
                     plate (an arrow at the frame's edge when off-screen or behind), the
                     plate's +x edge (orientation mark), their azimuth, elevation, distance
                     and x, y, z in mm (also printed to stdout and shown in the title)
  E / shift+E        exposure x1.25 / /1.25
  N                  upscaling while moving: bilinear / nearest
  A                  adaptive resolution while moving: on/off
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
"Exit codes: 0 success, 1 runtime failure, 2 bad command line, 3 bad input file, 4 GPU/device failure \
(including a lost device), 5 Vulkan validation messages were reported (with --validation).\n\n",
keys_text!())
)]
pub struct Opts {
    /// Design file (JSON scene, MODEL.md section 6); default: the built-in demo plate
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
    /// Timed frames per benchmark row (after 3 warm-up frames)
    #[arg(long, default_value_t = 20)]
    pub bench_frames: usize,
    /// Draw this many frames, then exit (frames are drawn continuously until then, also when
    /// nothing moves)
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
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
    let opts = match scratchart::exit::parse_args::<Opts>() {
        Ok(o) => o,
        Err(code) => return code,
    };
    let log = std::cell::RefCell::new(None);
    let r = run(&opts, &log);
    // Counted after everything Vulkan was dropped, so leaks reported at destruction count too.
    let n_validation = log
        .borrow()
        .as_ref()
        .map(|l: &scratchart::vulkan::ValidationLog| l.messages().len());
    match r {
        Ok(()) => {
            if let Some(n) = n_validation.filter(|_| opts.validation) {
                eprintln!("validation messages: {n}");
                if n > 0 {
                    // (a failure of the run like any other: the contract's runtime class)
                    eprintln!("error: the Vulkan validation layer reported {n} message(s) (see above)");
                    return scratchart::exit::Class::Runtime.exit_code();
                }
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            if let Some(n) = n_validation.filter(|_| opts.validation) {
                eprintln!("validation messages: {n}");
            }
            ExitCode::from(scratchart::exit::code_of(&e))
        }
    }
}

fn run(opts: &Opts, log: &std::cell::RefCell<Option<scratchart::vulkan::ValidationLog>>) -> Result<()> {
    if opts.exposure.is_nan() || opts.exposure <= 0.0 {
        bail!("--exposure must be a positive number");
    }
    let design = match &opts.design {
        Some(p) => design::Design::load(p)?,
        None => design::Design::demo(),
    };
    let shaders = shader_dir(opts);
    if let Some(d) = &shaders {
        eprintln!("shaders: {} (hot reload)", d.display());
    }
    if opts.screenshot.is_some() {
        return headless::screenshot(opts, &design, shaders.as_deref(), log);
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
