//! Work without a window: `--screenshot` (one frame through the same render + present path as
//! the window, read back and written as a PNG), `--walk --frames DIR` (the walk's frames, each
//! written as `--screenshot` writes its one) and the headless half of `--benchmark`. Also the
//! setup shared with the window: the Vulkan context and the frame renderer with its shaders.
use std::cell::RefCell;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context as _, Result};
use scratchart_model::scene::View;
use scratchart_vulkan::{Context, ContextDesc, GpuError, ShaderCompiler, ValidationLog};

use crate::design::Design;
use crate::frame::{internal_size, FrameInfo, FrameParams, FrameRenderer, Layout};
use crate::setup::SetupInfo;
use crate::state::{LightRig, OrbitCamera};
use crate::walk::Walk;
use crate::Opts;

/// Default window and screenshot size.
pub const DEFAULT_SIZE: (u32, u32) = (1280, 720);
/// Untimed frames before each benchmark row.
pub const BENCH_WARMUP: usize = 3;
/// Levels timed at a fixed internal resolution: full, 1/2, 1/3 and 1/4 per axis.
pub const BENCH_LEVELS: [usize; 4] = [0, 3, 5, 6];

pub fn make_context(
    opts: &Opts,
    instance_extensions: Vec<&'static std::ffi::CStr>,
    device_extensions: Vec<&'static std::ffi::CStr>,
    log: &RefCell<Option<ValidationLog>>,
) -> Result<Arc<Context>> {
    context_for(
        opts.validation,
        opts.device.clone(),
        instance_extensions,
        device_extensions,
        log,
    )
}

/// The context of a session with `--validation` and `--device` as given (the viewer's and the
/// live design's), its validation log kept in `log`.
pub fn context_for(
    validation: bool,
    device: Option<String>,
    instance_extensions: Vec<&'static std::ffi::CStr>,
    device_extensions: Vec<&'static std::ffi::CStr>,
    log: &RefCell<Option<ValidationLog>>,
) -> Result<Arc<Context>> {
    let ctx = Context::new(ContextDesc {
        validation,
        device,
        instance_extensions,
        device_extensions,
        quiet: false,
        notify: Some(scratchart::term::stderr_notices()),
        ..Default::default()
    })?;
    log.replace(Some(ctx.validation_log()));
    Ok(ctx)
}

/// Builds the frame renderer from `shaders` (hot-reload directory) or the embedded copy. When
/// the directory's sources do not compile, says why and falls back to the embedded copy.
pub fn make_frame_renderer(ctx: &Arc<Context>, design: &Design, shaders: Option<&Path>) -> Result<FrameRenderer> {
    ShaderCompiler::override_embedded(shaders.map(Path::to_path_buf));
    let mut fr = match FrameRenderer::new(ctx, &design.scene) {
        Err(e @ GpuError::Shader { .. }) if shaders.is_some() => {
            eprintln!("warning: {e}\nwarning: using the shaders built into the binary instead");
            ShaderCompiler::override_embedded(None);
            FrameRenderer::new(ctx, &design.scene)?
        }
        r => r?,
    };
    if let Some(n) = design.arc_chords {
        eprintln!("arcs rendered as {n} chords each, as the design judged them (its summary.json)");
        fr.set_arc_chords(Some(n));
    }
    Ok(fr)
}

/// The interactive camera and light a session starts with: view `idx`'s, as orbit parameters,
/// with `--light-azimuth` applied.
pub fn initial_state(opts: &Opts, design: &Design, idx: usize) -> (OrbitCamera, LightRig) {
    let v = &design.scene.views[idx];
    let mut light = LightRig::from_light(&v.light);
    if let Some(az) = opts.light_azimuth {
        light.azimuth_deg = az;
    }
    (OrbitCamera::from_camera(&v.camera), light)
}

/// The scripted benchmark path at `t` in [0, 1): the camera swings 90 degrees in azimuth and
/// bobs 8 degrees in elevation while the light makes a full turn.
pub fn bench_path(cam0: &OrbitCamera, light0: &LightRig, t: f64) -> (OrbitCamera, LightRig) {
    let mut cam = cam0.clone();
    cam.azimuth_deg += 90.0 * t;
    cam.elevation_deg = (cam.elevation_deg + 8.0 * (std::f64::consts::TAU * t).sin()).clamp(5.0, 85.0);
    let mut light = light0.clone();
    light.rotate(360.0 * t);
    (cam, light)
}

/// View `base` as `--screenshot --view` renders it: its camera, light and resolution exactly as
/// `scratchart render` has them, with `size` (`--size`) and `--light-azimuth` applied.
pub fn as_rendered(opts: &Opts, base: &View, size: Option<(u32, u32)>) -> View {
    let mut v = base.clone();
    if let Some((w, h)) = size {
        v.camera.width = w;
        v.camera.height = h;
    }
    if let Some(az) = opts.light_azimuth {
        let mut rig = LightRig::from_light(&v.light);
        rig.azimuth_deg = az;
        v.light = rig.light();
    }
    v
}

/// Renders `view` through the window's render and present path (with the target that `fr`
/// holds beside it when `show_target`, and the set-up overlay when `setup`), reads the display
/// image back and writes it to `path` atomically: gray, or RGB with the overlay. The one render
/// path of `--screenshot` and `--walk --frames`. Returns the frame's numbers and the image size.
pub fn write_frame(
    fr: &mut FrameRenderer,
    opts: &Opts,
    view: &View,
    show_target: bool,
    setup: Option<&SetupInfo>,
    path: &Path,
) -> Result<(FrameInfo, (u32, u32))> {
    let (w, h) = (view.camera.width, view.camera.height);
    // With the target the output doubles in width so the render keeps its resolution.
    let layout = if show_target {
        Layout::new((2 * w, h), fr.target_dims())
    } else {
        Layout::new((w, h), None)
    };
    let info = fr.render(
        &FrameParams {
            view,
            layout,
            exposure: opts.exposure as f32,
            nearest: false,
            show_target,
            setup,
        },
        None,
    )?;
    if setup.is_some() {
        let rgb = fr.read_output_rgb(layout.out)?;
        scratchart_render::io::write_png_rgb(path, layout.out.0, layout.out.1, &rgb)?;
    } else {
        let bytes = fr.read_output_gray(layout.out)?;
        scratchart_render::io::write_png_gray(path, layout.out.0, layout.out.1, &bytes)?;
    }
    Ok((info, layout.out))
}

pub fn screenshot(
    opts: &Opts,
    design: &Design,
    shaders: Option<&Path>,
    log: &RefCell<Option<ValidationLog>>,
) -> Result<()> {
    let path = opts.screenshot.as_ref().expect("screenshot mode");
    let idx = opts.view.as_deref().map(|s| design.view_index(s)).transpose()?;
    let base = &design.scene.views[idx.unwrap_or(0)];
    // With --view: that view as `scratchart render` has it. Without: the window's starting
    // state at --size.
    let view = match idx {
        Some(_) => as_rendered(opts, base, opts.size),
        None => {
            let (w, h) = opts.size.unwrap_or(DEFAULT_SIZE);
            let (cam, light) = initial_state(opts, design, 0);
            View {
                exposure: 1.0,
                name: "interactive".into(),
                camera: cam.camera(w, h),
                light: light.light(),
            }
        }
    };
    let ctx = make_context(opts, vec![], vec![], log)?;
    let mut fr = make_frame_renderer(&ctx, design, shaders)?;
    let target = design.targets[idx.unwrap_or(0)].as_ref();
    let show_target = opts.show_target && target.is_some();
    if opts.show_target && target.is_none() {
        eprintln!("warning: view '{}' has no target image", base.name);
    }
    fr.set_target(target.filter(|_| show_target))?;
    let setup = opts.setup.then(|| SetupInfo::of(&design.scene));
    let (info, out) = write_frame(&mut fr, opts, &view, show_target, setup.as_ref(), path)?;
    if let Some(s) = &setup {
        println!("{}", s.report());
        print_marks(&info.marks);
    }
    eprintln!(
        "wrote {} ({}x{}, view '{}', {:.1} ms on the GPU, {} overlapping pairs)",
        path.display(),
        out.0,
        out.1,
        base.name,
        info.timings.total_ms(),
        info.stats.pairs
    );
    Ok(())
}

/// `--walk --frames DIR`: the walk from the first view to the last (one way) rendered without a
/// window, `--walk-steps` frames per gap and then the last view, as DIR/frame_0000.png, ...
/// Frame k x steps is design view k exactly as `--screenshot --view k` renders it; every frame
/// has the first view's resolution (or --size).
pub fn walk_frames(
    opts: &Opts,
    design: &Design,
    shaders: Option<&Path>,
    log: &RefCell<Option<ValidationLog>>,
    dir: &Path,
) -> Result<()> {
    let views = &design.scene.views;
    let walk = Walk::new(views, opts.walk_speed).ok_or_else(|| crate::walk_refused(design))?;
    let steps = opts.walk_steps.max(1) as usize;
    let total = (views.len() - 1) * steps + 1;
    let c0 = &views[0].camera;
    let size = opts.size.unwrap_or((c0.width, c0.height));
    if opts.size.is_none() && views.iter().any(|v| (v.camera.width, v.camera.height) != size) {
        eprintln!(
            "warning: the views differ in resolution: every frame is {}x{} (view '{}'s); --size WxH sets another",
            size.0, size.1, views[0].name
        );
    }
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create the frame directory {}", dir.display()))?;
    let ctx = make_context(opts, vec![], vec![], log)?;
    let mut fr = make_frame_renderer(&ctx, design, shaders)?;
    // A target beside every frame only when every view has one (the frames keep one size).
    let mut show_target = opts.show_target && design.targets.iter().all(Option::is_some);
    if opts.show_target && !show_target {
        eprintln!("warning: not every view has a target image: the frames show none");
    }
    let setup = opts.setup.then(|| SetupInfo::of(&design.scene));
    if let Some(s) = &setup {
        println!("{}", s.report());
    }
    let mut target_of = None;
    let t0 = std::time::Instant::now();
    for j in 0..total {
        let (gap, step) = (j / steps, j % steps);
        // Whole positions are exact: k + 0 / steps, and the last view itself.
        let pos = gap as f64 + step as f64 / steps as f64;
        let view = as_rendered(opts, &walk.view_at(pos), Some(size));
        let near = walk.nearest(pos);
        if show_target && target_of != Some(near) {
            fr.set_target(design.targets[near].as_ref())?;
            target_of = Some(near);
            show_target = fr.target_dims().is_some();
        }
        let path = dir.join(format!("frame_{j:04}.png"));
        let (info, out) = write_frame(&mut fr, opts, &view, show_target, setup.as_ref(), &path)?;
        let orbit = OrbitCamera::from_camera(&view.camera);
        let at = if step == 0 {
            format!("view {}", views[gap].name)
        } else {
            format!(
                "{} -> {} {:.0}%",
                views[gap].name,
                views[gap + 1].name,
                100.0 * step as f64 / steps as f64
            )
        };
        println!(
            "frame {j:04}/{:04} {}: {at}, azimuth {:.3} elevation {:.3} distance {:.2}, light of {} ({}x{}, {:.1} ms on the GPU)",
            total - 1,
            path.display(),
            orbit.azimuth_deg,
            orbit.elevation_deg,
            orbit.distance,
            views[near].name,
            out.0,
            out.1,
            info.timings.total_ms()
        );
    }
    // Older frames past this walk's last would join a GIF made with a wildcard.
    let stale = (total..)
        .take_while(|j| dir.join(format!("frame_{j:04}.png")).exists())
        .count();
    if stale > 0 {
        eprintln!(
            "warning: {} holds {stale} older frame(s) after frame_{:04}.png from an earlier run: remove them before making a GIF",
            dir.display(),
            total - 1
        );
    }
    println!(
        "wrote {total} frames to {} ({} views, {steps} per gap, {:.1} s)",
        dir.display(),
        views.len(),
        t0.elapsed().as_secs_f64()
    );
    println!(
        "make a GIF: ffmpeg -framerate 12 -i {d}/frame_%04d.png walk.gif   (or ImageMagick: convert -delay 8 -loop 0 {d}/frame_*.png walk.gif)",
        d = dir.display()
    );
    Ok(())
}

/// Where the overlay drew each lamp and eye, one stdout line each (pixel coordinates of the
/// render's rectangle, x to the right and y down from its top-left corner).
pub fn print_marks(marks: &[crate::overlay::Mark]) {
    use crate::overlay::Placed;
    for m in marks {
        match m.placed {
            Placed::Marker { x, y } => println!("set-up overlay {}: marker at pixel {x:.4} {y:.4}", m.label),
            Placed::Edge { x, y, dx, dy } => println!(
                "set-up overlay {}: arrow at the frame edge, tip at pixel {x:.4} {y:.4}, pointing {dx:.4} {dy:.4}",
                m.label
            ),
            Placed::AtCamera => println!("set-up overlay {}: at this camera", m.label),
        }
    }
}

/// One row of the benchmark table.
pub struct BenchRow {
    pub mode: String,
    pub internal: (u32, u32),
    pub full: (u32, u32),
    /// Median GPU time of a frame (Vulkan timestamps: binning, shading, present pass, copy).
    pub gpu_ms: f64,
    /// Median time per frame as the user sees it: host time of a frame headless, the interval
    /// between presented frames in a window.
    pub frame_ms: f64,
    /// Median GPU milliseconds per labelled stage (binning, forward, present, copy or blit).
    pub stages: Vec<(String, f64)>,
}

/// Median per label over `frames` (labels in first-seen order).
pub fn stage_medians(frames: &[scratchart_vulkan::Timings]) -> Vec<(String, f64)> {
    let mut labels: Vec<String> = Vec::new();
    for t in frames {
        for (l, _) in &t.entries {
            if !labels.contains(l) {
                labels.push(l.clone());
            }
        }
    }
    labels
        .into_iter()
        .map(|l| {
            let v: Vec<f64> = frames.iter().filter_map(|t| t.get(&l)).collect();
            (l, scratchart::bench::median(v))
        })
        .collect()
}

pub fn print_table(title: &str, device: &str, rows: &[BenchRow]) {
    println!("\n{title} ({device})");
    println!(
        "{:<22} {:>11} {:>7} {:>9} {:>10} {:>7}  gpu ms per stage",
        "mode", "internal", "scale", "gpu ms", "frame ms", "fps"
    );
    for r in rows {
        println!(
            "{:<22} {:>11} {:>7.3} {:>9.1} {:>10.1} {:>7.1}  {}",
            r.mode,
            format!("{}x{}", r.internal.0, r.internal.1),
            r.internal.0 as f64 / r.full.0 as f64,
            r.gpu_ms,
            r.frame_ms,
            1000.0 / r.frame_ms,
            r.stages
                .iter()
                .map(|(l, ms)| format!("{l} {ms:.1}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
}

pub fn benchmark(
    opts: &Opts,
    design: &Design,
    shaders: Option<&Path>,
    log: &RefCell<Option<ValidationLog>>,
) -> Result<()> {
    let full = opts.size.unwrap_or(DEFAULT_SIZE);
    let idx = opts
        .view
        .as_deref()
        .map(|s| design.view_index(s))
        .transpose()?
        .unwrap_or(0);
    let ctx = make_context(opts, vec![], vec![], log)?;
    let mut fr = make_frame_renderer(&ctx, design, shaders)?;
    fr.set_binning(opts.binning);
    let (cam0, light0) = initial_state(opts, design, idx);
    let n = opts.bench_frames.max(1);
    let mut rows = Vec::new();
    let mut binning = Vec::new();
    for level in BENCH_LEVELS {
        let (iw, ih) = internal_size(full, level);
        let (mut gpu, mut wall, mut stages) = (Vec::new(), Vec::new(), Vec::new());
        let mut tests = 0u64;
        for k in 0..BENCH_WARMUP + n {
            let t = k.saturating_sub(BENCH_WARMUP) as f64 / n as f64;
            let (cam, light) = bench_path(&cam0, &light0, t);
            let view = View {
                exposure: 1.0,
                name: "bench".into(),
                camera: cam.camera(iw, ih),
                light: light.light(),
            };
            let info = fr
                .render(
                    &FrameParams {
                        view: &view,
                        layout: Layout::new(full, None),
                        exposure: opts.exposure as f32,
                        nearest: false,
                        show_target: false,
                        setup: None,
                    },
                    None,
                )
                .context("benchmark frame")?;
            tests = tests.max(info.stats.bin_tests_per_thread);
            if k >= BENCH_WARMUP {
                gpu.push(info.timings.total_ms());
                wall.push(info.wall_ms);
                stages.push(info.timings.clone());
            }
        }
        rows.push(BenchRow {
            mode: format!("headless 1/{}", crate::frame::DIVISORS[level]),
            internal: (iw, ih),
            full,
            gpu_ms: scratchart::bench::median(gpu.clone()),
            frame_ms: scratchart::bench::median(wall.clone()),
            stages: stage_medians(&stages),
        });
        if let Some((mode, threads)) = fr.binning_info() {
            binning.push(format!(
                "{iw}x{ih}: {} mode, {threads} threads, at most {tests} tile tests per thread",
                mode.name()
            ));
        }
    }
    print_table(
        &format!(
            "headless, {}x{} output, {} frames per row after {BENCH_WARMUP} warm-up, camera + light moving",
            full.0, full.1, n
        ),
        &ctx.info().name,
        &rows,
    );
    println!("binning (its pass over scratches and tiles):");
    for b in binning {
        println!("  {b}");
    }
    Ok(())
}
