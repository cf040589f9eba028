//! `scratchart`: render, benchmark and (with `design`) optimize scratched reflector plates.
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context as _, Result};
use clap::{Parser, Subcommand};

use scratchart::design_cmd;
use scratchart::term;

use scratchart::bench;
use scratchart_model::scene::Scene;
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, ContextDesc};

#[derive(Parser)]
#[command(
    name = "scratchart",
    version,
    about = "Design, render and benchmark scratch-based reflection art on any Vulkan device.",
    long_about = "Design, render and benchmark scratch-based reflection art on any Vulkan device.\n\n\
A plate carved with many short straight scratches shows a different image from each of several viewpoints \
under a light. Scenes are JSON files (see engine/docs/model.md section 6) with scratches inline or in a CSV file.\n\n\
Device choice: discrete GPU, then integrated, then CPU (lavapipe); --device or SCRATCHART_DEVICE picks one \
by index or by part of its name. SCRATCHART_VALIDATION=1 (or --validation) turns on the Vulkan validation layer.\n\n\
Exit codes: 0 success, 1 runtime failure, 2 bad command line, 3 bad input file, 4 GPU/device failure."
)]
struct Cli {
    /// Vulkan device to use: index or part of the name (default: best available)
    #[arg(long, global = true)]
    device: Option<String>,
    /// Enable the Vulkan validation layer and report its messages
    #[arg(long, global = true)]
    validation: bool,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Design a plate: optimize scratches (and light intensities) so that each view shows its
    /// target image. Without arguments, designs the built-in 3-view demo into ./out.
    Design(Box<design_cmd::DesignArgs>),
    /// Render every view of a scene to NAME.pfm (linear L) and NAME.png (display value).
    /// Without SCENE, renders the built-in demo plate.
    Render {
        /// Scene file (JSON, engine/docs/model.md section 6)
        scene: Option<PathBuf>,
        /// Output directory (created if missing)
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Render each arc scratch as N chords (default: a design made with --arcs as its
        /// summary.json says it was judged, else the accuracy bar's rule, engine/docs/model.md
        /// section 11)
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=4096))]
        arc_chords: Option<u32>,
    },
    /// Write the check loss E_lin of engine/docs/model.md section 8 and its gradient with respect to every
    /// scratch (grads.csv: x0,y0,x1,y1,w,d,alpha per scratch, in input order) and every view's
    /// light intensity (grads_lights.csv beside it: view,intensity). Targets are DIR/NAME.pfm,
    /// linear values, one per view.
    Grad {
        /// Scene file (JSON, engine/docs/model.md section 6)
        scene: PathBuf,
        /// Directory holding NAME.pfm for every view NAME
        #[arg(long)]
        targets: PathBuf,
        /// Output CSV of scratch gradients (grads_lights.csv is written beside it)
        #[arg(long, default_value = "grads.csv")]
        out: PathBuf,
    },
    /// Write the set-up sheet of a design (setup.txt, setup.png): where the plate's mark, the lamp
    /// and each viewer go, and how precisely the lamp must stand (each view rendered with the
    /// lamp and the eye moved, each tolerance found by search). It reads what the design wrote
    /// beside itself (setup_inputs.json: each view's target as the loss saw it, its picture's
    /// pixels, the blur), so the sheet is the one `scratchart design` wrote, to the digit; for
    /// any other scene it compares with NAME_target.png beside it, else its own renders.
    Setup {
        /// Design file (design.json written by `scratchart design`, or any scene file)
        design: PathBuf,
        /// Output directory (default: the design's directory)
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// List the Vulkan devices (the index and name are what --device takes; * marks the default).
    Devices,
    /// Benchmark the GPU pipeline on the standard scenes (S, M, P) or on a scene file.
    Bench {
        /// Standard scenes to run: S (4,000 scratches, 2x128^2), M (40,000, 3x256^2), P (40,000,
        /// 3x512^2, the paper's scale), L (160,000, 3x1024^2, to fill a big GPU), NxVxR (N
        /// scratches, V views of R x R pixels, e.g. 20000x3x256, for scaling tables), or NxVxRw
        /// (V views, 2 to 64, along a walk's 60 degree arc, e.g. 10000x24x128w)
        #[arg(long, value_delimiter = ',', default_value = "S,M")]
        sizes: Vec<String>,
        /// Time this scene file instead of the standard scenes
        #[arg(long)]
        scene: Option<PathBuf>,
        /// Timed repeats (median reported)
        #[arg(long, default_value_t = 7)]
        repeats: usize,
        /// Untimed warm-up runs (and warm-up iterations of the full-iteration benchmark)
        #[arg(long, default_value_t = 2)]
        warmup: usize,
        /// Also time N full design iterations (pair search + forward + loss + backward + Adam);
        /// 0 skips them
        #[arg(long, default_value_t = 10)]
        iters: u32,
        /// Linear target images DIR/NAME.pfm for --scene (default: the scene's own render,
        /// perturbed by 10% in a fixed pattern)
        #[arg(long, requires = "scene")]
        targets: Option<PathBuf>,
        /// Also time the all-dual-number backward kernel (the default backward's test oracle)
        /// in the same submissions, and print the ratios
        #[arg(long)]
        compare_backward: bool,
        /// How the backward of the forward table adds each scratch's pair contributions: lists
        /// built by thread `one` (CPU drivers' default), masks set by `every` thread (the same
        /// gradients, bit for bit), or the masks walked by two threads per scratch (`split`, GPUs'
        /// default: other sums, within float rounding). Default: the device's choice
        #[arg(long, value_parser = ["one", "every", "split"])]
        links: Option<String>,
        /// Bands of tile rows per view for the pair search of the forward table (0: none, one
        /// thread per scratch group does every view). Default: the device's choice (none on a CPU
        /// driver; on a GPU, enough for about 64k binning threads). For comparing the two
        #[arg(long)]
        binning_bands: Option<u32>,
        /// The pair search's modes, each timed in turn in one run: `groups` (a thread per group
        /// of 64 scratches counts into a tiles x groups histogram: the CPU drivers' default) or
        /// `pairs` (a thread per scratch and view emits its (tile, scratch) pairs, a stable radix
        /// sort orders them: the GPUs' default); e.g. `--binning groups,pairs`. Both give the
        /// same tile lists. Default: the device's choice
        #[arg(long, value_delimiter = ',', value_parser = parse_bin_mode)]
        binning: Vec<scratchart_render::BinMode>,
        /// Print binning's work for each scene instead (no device needed): its threads and the
        /// most tile tests one thread makes, in both modes, with the bands a GPU would take
        #[arg(long)]
        binning_work: bool,
    },
    /// Speed against accuracy of the per-pair integral: writes DIR/study.csv, DIR/study.png and
    /// DIR/verdict.txt.
    ///
    /// Every method (closed form, Gauss panels, plain Gauss-Legendre with 2 to 32 nodes per edge, adaptive quadrature, the
    /// "average" approximation, `adaptive` (the closed form, pairs bounded below 5e-4 of their
    /// pixel left out),
    /// Monte Carlo with 16 to 256 points) renders a small scene per regime (moderate, sharp and
    /// wide lobes, grazing views, footprints much smaller and much larger than a scratch, the half
    /// vector along the scratches, many scratches per footprint); each render is compared with the
    /// float64 reference and timed. Writes DIR/study.csv (method, regime, err_max, err_p99,
    /// err_median, ns_per_pair, pairs, culled, ...), DIR/study.png (error against time per regime, log axes)
    /// and DIR/verdict.txt (per regime the cheapest method within engine/docs/model.md's bar). About two
    /// minutes on a 2-core CPU driver with the defaults.
    Study {
        /// Output directory (created if missing)
        #[arg(long, default_value = "study")]
        out: PathBuf,
        /// View resolution of the regime scenes (square; the footprint is about 30 mm / RES)
        #[arg(long, default_value_t = 48)]
        res: u32,
        /// View resolution of the timed renders (the same regimes drawn finer)
        #[arg(long, default_value_t = 160)]
        time_res: u32,
        /// Timed renders per method and regime (median reported), after one warm-up render
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Methods to compare (default: all), e.g. closed-form,gauss-legendre-8,monte-carlo-64
        #[arg(long, value_delimiter = ',')]
        methods: Vec<String>,
        /// Regimes to run (default: all): moderate, sharp, wide, grazing, small-footprint,
        /// large-footprint, along-axis, dense
        #[arg(long, value_delimiter = ',')]
        regimes: Vec<String>,
    },
}

fn main() -> ExitCode {
    match scratchart::exit::parse_args::<Cli>() {
        Ok(cli) => scratchart::exit::finish(run(cli)),
        Err(code) => code,
    }
}

fn context(cli: &Cli) -> Result<std::sync::Arc<Context>> {
    Ok(Context::new(ContextDesc {
        validation: cli.validation,
        device: cli.device.clone(),
        notify: Some(term::stderr_notices()),
        ..Default::default()
    })?)
}

fn run(cli: Cli) -> Result<()> {
    match &cli.cmd {
        Cmd::Design(args) => {
            let ctx = context(&cli)?;
            term::install_interrupt_handler();
            design_cmd::run(&ctx, args, &term::Terminal::new(args.quiet))?;
            check_validation(&ctx)
        }
        Cmd::Render { scene, out, arc_chords } => {
            let chords = arc_chords.or_else(|| scene.as_deref().and_then(scratchart_design::arcs::judged_arc_chords));
            let scene = match scene {
                Some(p) => load_scene(p)?,
                None => {
                    eprintln!("no scene given: rendering the built-in demo plate");
                    scratchart_design::scenes::demo_scene(256)
                }
            };
            let ctx = context(&cli)?;
            render_to_dir(&ctx, &scene, out, chords)?;
            check_validation(&ctx)
        }
        Cmd::Setup { design, out } => {
            let scene = load_scene(design)?;
            let ctx = context(&cli)?;
            let dir = design
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .map(Path::to_path_buf)
                .unwrap_or_else(|| PathBuf::from("."));
            let out = out.clone().unwrap_or_else(|| dir.clone());
            std::fs::create_dir_all(&out)
                .with_context(|| format!("cannot create output directory {}", out.display()))?;
            setup_command(
                &ctx,
                &scene,
                &dir,
                &out,
                scratchart_design::arcs::judged_arc_chords(design),
            )?;
            check_validation(&ctx)
        }
        Cmd::Devices => devices_cmd(),
        Cmd::Grad { scene, targets, out } => {
            let scene = load_scene(scene)?;
            warn_about(&scene);
            let ctx = context(&cli)?;
            grad_command(&ctx, &scene, targets, out)?;
            check_validation(&ctx)
        }
        Cmd::Study {
            out,
            res,
            time_res,
            repeats,
            methods,
            regimes,
        } => study_cmd(&cli, out, *res, *time_res, *repeats, methods, regimes),
        Cmd::Bench {
            sizes,
            scene,
            repeats,
            warmup,
            iters,
            targets,
            compare_backward,
            links,
            binning_bands,
            binning,
            binning_work,
        } => bench_cmd(
            &cli,
            sizes,
            (scene.as_deref(), *binning_work),
            *repeats,
            *warmup,
            *iters,
            targets.as_deref(),
            (
                *compare_backward,
                links.as_deref().and_then(scratchart_render::kernels::Walk::parse),
            ),
            (binning, *binning_bands),
        ),
    }
}

/// `scratchart devices`: the Vulkan devices, the default marked.
fn devices_cmd() -> Result<()> {
    let devices = scratchart_vulkan::list_devices()?;
    if devices.is_empty() {
        anyhow::bail!("no Vulkan device found (on Debian, `bash .ci/setup` installs Mesa's lavapipe)");
    }
    for d in devices {
        println!(
            "{} {}: {} ({}, Vulkan {}){}",
            if d.default { "*" } else { " " },
            d.index,
            d.name,
            d.kind,
            d.api_version,
            if d.usable {
                ""
            } else {
                " [unusable: needs a compute queue and Vulkan 1.1]"
            }
        );
    }
    Ok(())
}

/// `scratchart study`: the speed-against-accuracy study of the pair integral's methods.
fn study_cmd(
    cli: &Cli,
    out: &Path,
    res: u32,
    time_res: u32,
    repeats: usize,
    methods: &[String],
    regimes: &[String],
) -> Result<()> {
    use scratchart_render::kernels::Integrator;
    let methods: Vec<Integrator> = if methods.is_empty() {
        Integrator::STUDY.to_vec()
    } else {
        methods
            .iter()
            .map(|m| {
                Integrator::from_name(m).ok_or_else(|| {
                    let names: Vec<String> = Integrator::STUDY.iter().map(|i| i.name()).collect();
                    scratchart_exit::UsageError(format!(
                        "--methods: unknown method '{m}' (choose from {})",
                        names.join(", ")
                    ))
                    .into()
                })
            })
            .collect::<Result<_>>()?
    };
    let known: Vec<&str> = scratchart::study::regimes(16, 1).iter().map(|r| r.name).collect();
    if let Some(bad) = regimes.iter().find(|r| !known.contains(&r.as_str())) {
        return Err(scratchart_exit::UsageError(format!(
            "--regimes: unknown regime '{bad}' (choose from {})",
            known.join(", ")
        ))
        .into());
    }
    for (flag, v) in [("--res", res), ("--time-res", time_res)] {
        if !(16..=1024).contains(&v) {
            return Err(scratchart_exit::UsageError(format!("{flag} {v}: choose 16 to 1024")).into());
        }
    }
    let ctx = context(cli)?;
    std::fs::create_dir_all(out).map_err(|e| scratchart_exit::InputError(format!("{}: {e}", out.display())))?;
    let opt = scratchart::study::StudyOptions {
        res,
        time_res,
        repeats,
        methods,
        regimes: (!regimes.is_empty()).then(|| regimes.to_vec()),
    };
    let rows = scratchart::study::run(&ctx, &opt, &mut |line| eprintln!("{line}"))?;
    scratchart_render::io::write_atomic(&out.join("study.csv"), scratchart::study::csv(&rows).as_bytes())?;
    let verdict = scratchart::study::verdict(&rows);
    scratchart_render::io::write_atomic(&out.join("verdict.txt"), verdict.as_bytes())?;
    scratchart::study::chart(&rows, &out.join("study.png"))?;
    print!("{verdict}");
    eprintln!(
        "wrote {}, {} and {}",
        out.join("study.csv").display(),
        out.join("study.png").display(),
        out.join("verdict.txt").display()
    );
    check_validation(&ctx)
}

/// `scratchart bench`: the forward pass on the standard scenes (or a scene file), and full
/// design iterations.
#[allow(clippy::too_many_arguments)]
fn bench_cmd(
    cli: &Cli,
    sizes: &[String],
    (scene, binning_work): (Option<&Path>, bool),
    repeats: usize,
    warmup: usize,
    iters: u32,
    targets: Option<&Path>,
    (compare_backward, links): (bool, Option<scratchart_render::kernels::Walk>),
    (binning, binning_bands): (&[scratchart_render::BinMode], Option<u32>),
) -> Result<()> {
    let scenes: Vec<(String, Scene)> = match scene {
        Some(p) => vec![(p.display().to_string(), load_scene(p)?)],
        None => sizes
            .iter()
            .map(|s| {
                scratchart::bench::bench_scene(s)
                    .map(|sc| (if s.len() == 1 { s.to_uppercase() } else { s.clone() }, sc))
                    .ok_or_else(|| {
                        scratchart_exit::UsageError(format!(
                            "--sizes: unknown standard scene '{s}' (choose S, M, P, L, NxVxR such as 20000x3x256 with 1 to 3 views, or NxVxRw such as 10000x24x128w with 2 to 64 views along a walk)"
                        ))
                        .into()
                    })
            })
            .collect::<Result<_>>()?,
    };
    if binning_work {
        print!("{}", bench::binning_work_table(&scenes));
        return Ok(());
    }
    let ctx = context(cli)?;
    let modes: Vec<Option<scratchart_render::BinMode>> = if binning.is_empty() {
        vec![None]
    } else {
        binning.iter().map(|m| Some(*m)).collect()
    };
    let mut rows = Vec::new();
    for m in &modes {
        rows.extend(bench::run_forward(
            &ctx,
            &scenes,
            warmup,
            repeats.max(1),
            (compare_backward, links),
            *m,
            binning_bands,
        )?);
    }
    if modes.len() > 1 {
        // One scene's modes side by side.
        let n = scenes.len();
        rows = (0..n)
            .flat_map(|i| (0..modes.len()).map(move |k| k * n + i))
            .map(|j| rows[j].clone())
            .collect();
    }
    print!("{}", bench::forward_table(&ctx, &rows));
    if iters > 0 {
        let mut it_rows = Vec::new();
        for (name, sc) in &scenes {
            let linear = match targets {
                Some(dir) => Some(read_linear_targets(sc, dir)?),
                None => None,
            };
            let t = bench::bench_targets(&ctx, sc, linear)?;
            eprintln!("timing {iters} design iterations of {name} ...");
            it_rows.push(bench::run_iterations(&ctx, name, sc, t, warmup as u32, iters)?);
        }
        println!();
        print!("{}", bench::iteration_table(&it_rows));
    }
    check_validation(&ctx)
}

/// Loads a scene file and prints warnings about keys it does not know.
fn load_scene(path: &Path) -> Result<Scene> {
    let (scene, warnings) = Scene::load_with_warnings(path)?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// Prints what in a valid scene will surprise its user (see `limits::scene_warnings`).
fn warn_about(scene: &Scene) {
    for w in scratchart_render::limits::scene_warnings(scene) {
        eprintln!("warning: {w}");
    }
}

fn render_to_dir(ctx: &std::sync::Arc<Context>, scene: &Scene, out: &Path, arc_chords: Option<u32>) -> Result<()> {
    warn_about(scene);
    std::fs::create_dir_all(out).with_context(|| format!("cannot create output directory {}", out.display()))?;
    let renderer = Renderer::new(ctx)?;
    if let Some(n) = arc_chords.filter(|_| scene.scratches.iter().any(|s| s.is_arc())) {
        eprintln!("arcs rendered as {n} chords each");
        renderer.set_arc_chords(Some(n));
    }
    let mut gs = renderer.upload(scene)?;
    let frame = renderer.render(&mut gs)?;
    for (view, img) in scene.views.iter().zip(&frame.images) {
        let (w, h) = (view.camera.width, view.camera.height);
        let pfm = out.join(format!("{}.pfm", view.name));
        let png = out.join(format!("{}.png", view.name));
        scratchart_render::io::write_pfm(&pfm, w, h, img)?;
        scratchart_render::io::write_png_display(&png, w, h, img)?;
        eprintln!("wrote {} and {}", pfm.display(), png.display());
    }
    eprintln!(
        "{} scratches, {} views: {} overlapping (pixel, scratch) pairs, {} candidates tested, {:.1} ms on the GPU",
        scene.scratches.len(),
        scene.views.len(),
        frame.stats.pairs,
        frame.stats.candidates,
        frame.timings.total_ms()
    );
    Ok(())
}

/// Linear target images DIR/NAME.pfm, one per view, checked against the view sizes.
fn read_linear_targets(scene: &Scene, dir: &Path) -> Result<Vec<Vec<f32>>> {
    let mut targets = Vec::new();
    for v in &scene.views {
        let p = dir.join(format!("{}.pfm", v.name));
        let (w, h, data) =
            scratchart_render::io::read_pfm(&p).with_context(|| format!("target for view '{}'", v.name))?;
        if (w, h) != (v.camera.width, v.camera.height) {
            return Err(scratchart_exit::InputError(format!(
                "target {} is {w}x{h} but view '{}' renders {}x{}",
                p.display(),
                v.name,
                v.camera.width,
                v.camera.height
            ))
            .into());
        }
        targets.push(data);
    }
    Ok(targets)
}

fn grad_command(ctx: &std::sync::Arc<Context>, scene: &Scene, dir: &Path, out: &Path) -> Result<()> {
    let targets = read_linear_targets(scene, dir)?;
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    let renderer = Renderer::new(ctx)?;
    let mut gs = renderer.upload(scene)?;
    let r = scratchart_optim::check::check_loss_gradients(&renderer, &mut gs, scene, &targets)?;
    // A scene with arcs gets dE/dbulge too (empty where a scratch is straight).
    let arcs = !r.grads.bulges.is_empty();
    let mut csv = String::from(if arcs {
        "x0,y0,x1,y1,w,d,alpha,bulge\n"
    } else {
        "x0,y0,x1,y1,w,d,alpha\n"
    });
    for (k, g) in r.grads.scratches.iter().enumerate() {
        let mut row: Vec<String> = g.iter().map(|x| format!("{x:e}")).collect();
        if arcs {
            let b = r.grads.bulges[k];
            row.push(if b.is_finite() { format!("{b:e}") } else { String::new() });
        }
        csv += &row.join(",");
        csv.push('\n');
    }
    scratchart_render::io::write_atomic(out, csv.as_bytes())?;
    let mut lights = String::from("view,intensity\n");
    for (v, g) in scene.views.iter().zip(&r.grads.lights) {
        lights += &format!("{},{g:e}\n", v.name);
    }
    let lp = out.with_file_name("grads_lights.csv");
    scratchart_render::io::write_atomic(&lp, lights.as_bytes())?;
    println!("E_lin = {:.9e}", r.e_lin);
    eprintln!("wrote {} and {}", out.display(), lp.display());
    Ok(())
}

fn setup_command(
    ctx: &std::sync::Arc<Context>,
    scene: &Scene,
    dir: &Path,
    out: &Path,
    arc_chords: Option<u32>,
) -> Result<()> {
    use scratchart_design::tolerance::SheetInputs;
    let renderer = Renderer::new(ctx)?;
    // A design with arcs: as its design job judged them.
    renderer.set_arc_chords(arc_chords);
    // The inputs the design wrote beside itself: the sheet is then the design's own, to the digit.
    let inputs = match SheetInputs::load(dir, scene)? {
        Some(inputs) => inputs,
        None => {
            eprintln!(
                "warning: no {} beside the design (made by an older version, or not by `scratchart design`): \
                 the sheet compares with NAME_target.png (8-bit) over the whole plate, so its numbers can differ \
                 from the design's own sheet",
                SheetInputs::FILE
            );
            SheetInputs::approximate(&renderer, scene, dir, &term::Terminal::new(true))?
        }
    };
    let (setup, _, advice, _) = scratchart_design::setup::write_setup(out, &renderer, scene, &inputs)?;
    for a in advice {
        println!("{a}");
    }
    println!("{}", serde_json::to_string(&setup)?);
    eprintln!("wrote {0}/setup.txt and {0}/setup.png", out.display());
    Ok(())
}

fn check_validation(ctx: &Context) -> Result<()> {
    let msgs = ctx.validation_messages();
    if !msgs.is_empty() {
        anyhow::bail!("{} Vulkan validation message(s); first: {}", msgs.len(), msgs[0]);
    }
    Ok(())
}

/// `--binning`'s values.
fn parse_bin_mode(s: &str) -> std::result::Result<scratchart_render::BinMode, String> {
    scratchart_render::BinMode::parse(s).ok_or_else(|| format!("'{s}': choose groups or pairs"))
}
