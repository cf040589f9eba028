//! `scratchart-cal`: calibrate the carving tool before a carving session.
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context as _, Result};
use clap::{Parser, Subcommand};

use scratchart_calibration::card::{Card, CardSpec};
use scratchart_calibration::simulate::{photos, Camera};
use scratchart_tool::Tool;
use scratchart_vulkan::{Context, ContextDesc};

mod carve;
mod plan_cmd;
mod toolpath;
mod touch_up_cmd;

#[derive(Parser)]
#[command(
    name = "scratchart-cal",
    version,
    about = "Calibrate the carving tool: cut a test card, photograph it, fit the tool's profile.",
    long_about = r#"Calibrate the carving tool before a carving session, in this order:

  1. scratchart-cal card --out DIR       writes DIR/card.json: the test card (a ladder of commanded depths
                                         straddling the plate surface, at several orientations, with six
                                         fiducial marks) and where the camera and the lamp go to photograph it,
                                         and its G-code DIR/card.nc (card.gcode with --machine marlin).
  2. cut the card on the machine, and photograph it from each capture view of card.json.
  3. scratchart-cal simulate --card DIR/card.json --tool tool.json --out IMGDIR
                                         renders the card as a known tool would cut it, as the camera would
                                         see it (for checking a set-up, and for tests).
  4. scratchart-cal fit --card DIR/card.json cam_south.jpg cam_west.jpg --out tool.json
                                         registers the photos by the card's hatched marks and fits the tool
                                         (v-bit, ball, tapered-ball or a measured profile; --kind picks one),
                                         its z offset, the walls' roughness, exposure and blur: tool.json with
                                         uncertainties, residual images and a plot of width against depth;
                                         after Ctrl-C, the same command with --resume goes on.
  5. scratchart-cal plan DESIGN.json --tool tool.json --out plan.nc, then scratchart-cal carve plan.nc
                                         --port PORT (see calibration/README.md).
  6. scratchart-cal inspect DESIGN.json v0.jpg v1.jpg ... --tool tool.json --out DIR
                                         compares photos of the carved plate with the design and finds what the
                                         carving did differently; scratchart-cal plan DESIGN.json --tool tool.json
                                         --touch-up DIR/inspect.json --out touch.nc plans what can still be done
                                         (simulate-plate tries the loop in simulation; calibration/docs/closed_loop.md).

Exit codes: 0 success, 1 runtime failure, 2 bad command line, 3 bad input file, 4 GPU/device failure."#
)]
struct Cli {
    /// Vulkan device to use: index or part of the name (default: best available)
    #[arg(long, global = true)]
    device: Option<String>,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Fit the tool to photos of the cut card: writes tool.json (the tool, its uncertainties, the
    /// walls' roughness), residual images and a plot of the width against depth beside it.
    Fit(scratchart_calibration::fit_cmd::FitArgs),
    /// Stream a plan to the machine (GRBL 1.1 or Marlin, asked on the port) with a journal beside
    /// the plan; --resume continues a stopped job. Exit 1 when the machine stops the job (with the
    /// --resume command), 130 after Ctrl-C (machine stopped, tool raised).
    Carve(carve::CarveArgs),
    /// Trace a plan's frame on the machine without cutting: the job's bounding box, then the
    /// plate's outline, at the clearance height, then back to X0 Y0, to see that the plate sits
    /// where the plan expects (`carve --frame` does the same before carving, on one connection).
    /// Exit 1 when the machine stops it, 130 after Ctrl-C.
    Frame(carve::FrameArgs),
    /// List the serial ports this computer has (USB ones first, with their USB ids and names):
    /// what `carve --port` and `probe --port` take. Exit 1 when the system cannot list them.
    Ports,
    /// Probe the plate's height on a grid with the tool (G38.2; Marlin G38.2 or G30) and write
    /// heightmap.json for `plan --heightmap`.
    Probe(carve::ProbeArgs),
    /// The recovery study of the fit: random tools of all four kinds cut into the card,
    /// photographed as a phone would (pose, blur, exposure, vignetting, cast, noise, size, JPEG,
    /// EXIF, a covered mark, drawn at random) and fitted; writes study.md and study.csv:
    /// recovered, refused and wrong-but-accepted counts, errors, times, and how often the
    /// stated uncertainties cover the truth. About a minute or two per trial on a CPU.
    Study(scratchart_calibration::study::StudyArgs),
    /// Write the calibration card (card.json) into DIR.
    Card {
        /// Output directory
        #[arg(long, default_value = "card")]
        out: PathBuf,
        /// Card plate size, mm
        #[arg(long, default_value_t = 70.0)]
        plate: f64,
        /// Resolution of the capture views (square), pixels
        #[arg(long, default_value_t = 256)]
        res: u32,
        /// The machine the card's G-code (card.nc, or card.gcode for Marlin) is written for
        #[command(flatten)]
        machine: plan_cmd::MachineArgs,
    },
    /// Plan the carving of a design: one commanded depth per scratch (the design's z_mm column, or
    /// the tool's profile), the cut order (nearest neighbour, then 2-opt), the +x orientation mark,
    /// levelling by a height map, bounds against the plate and the machine, the job time with
    /// acceleration; writes G-code (PLAN.nc) and a preview PNG beside it.
    Plan(plan_cmd::PlanArgs),
    /// Export a design as a drawing for other toolchains: SVG and/or DXF, true size in mm, one
    /// group or layer per depth band, the plate outline on its own.
    Export(plan_cmd::ExportArgs),
    /// Carve a design's plans in simulation with TOOL (the tool that really cuts: a mismatch with
    /// the calibrated one is what `inspect` finds) and photograph the plate from each of the
    /// design's views under its lamp: DIR/<view>.png (exactly the views' cameras and size) and
    /// DIR/carved.json, the grooves as carved. Plans carve in the order given; a later cut along
    /// a groove deepens it.
    SimulatePlate(scratchart_calibration::simulate_plate::SimulatePlateArgs),
    /// Compare photos of a carved plate (one per design view, as simulate-plate names them) with
    /// its design: per photo its correlation with the design's render and picture and a
    /// difference image, and what the carving did differently from the calibrated tool (a
    /// depth change and a width scale, with uncertainties): DIR/inspect.json and
    /// DIR/tool_as_carved.json for `plan --touch-up`. Exit 3 (no inspect.json) when the photos
    /// do not pin them.
    Inspect(scratchart_calibration::inspect_plate::InspectArgs),
    /// Render the card as TOOL cuts it, from every capture view, as PNG photos named after the views.
    Simulate {
        /// The card (card.json from `scratchart-cal card`)
        #[arg(long)]
        card: PathBuf,
        /// The tool (tool.json)
        #[arg(long)]
        tool: PathBuf,
        /// Output directory for the photos
        #[arg(long, default_value = "photos")]
        out: PathBuf,
        /// Exposure factor on the linear image
        #[arg(long, default_value_t = 1.0)]
        exposure: f64,
        /// Gaussian blur, pixels
        #[arg(long, default_value_t = 0.0)]
        blur: f64,
        /// Gaussian noise on display values (0..1)
        #[arg(long, default_value_t = 0.0)]
        noise: f64,
        /// Seed of the noise
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Take the photos as a phone does, this many megapixels each (colour, the noise on each
        /// channel at the photo's own resolution; the blur stays in the capture view's pixels)
        #[arg(long)]
        megapixels: Option<f64>,
        /// Save as JPEG of this quality (1-100), as a phone does, instead of PNG
        #[arg(long, value_parser = clap::value_parser!(u8).range(1..=100))]
        jpeg: Option<u8>,
    },
}

fn main() -> ExitCode {
    match scratchart::exit::parse_args::<Cli>() {
        Ok(cli) => scratchart::exit::finish(run(cli)),
        Err(code) => code,
    }
}

fn run(cli: Cli) -> Result<()> {
    match &cli.cmd {
        Cmd::Carve(args) => carve::run(args),
        Cmd::Probe(args) => carve::probe(args),
        Cmd::Frame(args) => carve::frame(args),
        Cmd::Ports => ports_cmd(),
        Cmd::Fit(args) => {
            let (_ctx, renderer) = renderer(cli.device.as_deref())?;
            scratchart::term::install_interrupt_handler();
            scratchart_calibration::fit_cmd::run(&renderer, args, &scratchart::term::Terminal::new(args.quiet))
        }
        Cmd::Card {
            out,
            plate,
            res,
            machine,
        } => card_cmd(cli.device.as_deref(), out, *plate, *res, machine),
        Cmd::Study(args) => {
            let (_ctx, renderer) = renderer(cli.device.as_deref())?;
            scratchart::term::install_interrupt_handler();
            let trials = scratchart_calibration::study::run(&renderer, args, &scratchart::term::Terminal::new(false))?;
            let summary = std::fs::read_to_string(args.out.join("study.md"))?;
            println!("{}", summary.lines().next().unwrap_or(""));
            println!(
                "wrote {} and study.csv ({} trials)",
                args.out.join("study.md").display(),
                trials.len()
            );
            Ok(())
        }
        Cmd::Plan(args) => plan_cmd::plan(args),
        Cmd::Inspect(args) => {
            let (_ctx, renderer) = renderer(cli.device.as_deref())?;
            scratchart_calibration::inspect_plate::run(args, &renderer, &scratchart::term::Terminal::new(false))
        }
        Cmd::SimulatePlate(args) => {
            check_camera_flags(args.exposure, args.blur, args.noise, args.megapixels)?;
            let (_ctx, renderer) = renderer(cli.device.as_deref())?;
            scratchart_calibration::simulate_plate::run(args, &renderer, &scratchart::term::Terminal::new(false))
        }
        Cmd::Export(args) => plan_cmd::export(args),
        Cmd::Simulate {
            card,
            tool,
            out,
            exposure,
            blur,
            noise,
            seed,
            megapixels,
            jpeg,
        } => {
            check_camera_flags(*exposure, *blur, *noise, *megapixels)?;
            let (card, capture) = Card::load(card)?;
            let tool = Tool::load(tool).map_err(|e| scratchart_exit::InputError(e.to_string()))?;
            let (_ctx, renderer) = renderer(cli.device.as_deref())?;
            if megapixels.is_some() || jpeg.is_some() {
                // As a phone takes them (`phone::take`), from the capture pose.
                for (v, view) in capture.views.iter().enumerate() {
                    let shot = scratchart_calibration::phone::Shot {
                        exposure: *exposure,
                        blur_px: *blur,
                        noise: *noise,
                        megapixels: megapixels.unwrap_or(view.camera.width as f64 * view.camera.height as f64 / 1e6),
                        jpeg_quality: *jpeg,
                        seed: seed.wrapping_add(v as u64),
                        ..Default::default()
                    };
                    let (p, _) = scratchart_calibration::phone::take(&renderer, &card, &capture, v, &tool, &shot, out)?;
                    println!("wrote {}", p.display());
                }
                return Ok(());
            }
            let cam = Camera {
                exposure: *exposure,
                blur_px: *blur,
                noise: *noise,
                seed: *seed,
            };
            let imgs = photos(&renderer, &card, &capture, &tool, &cam)?;
            std::fs::create_dir_all(out)
                .with_context(|| format!("cannot create output directory {}", out.display()))?;
            for (v, img) in capture.views.iter().zip(&imgs) {
                let bytes: Vec<u8> = img.iter().map(|&x| (255.0 * x).round() as u8).collect();
                let p = out.join(format!("{}.png", v.name));
                scratchart_render::io::write_png_gray(&p, v.camera.width, v.camera.height, &bytes)?;
                println!("wrote {}", p.display());
            }
            Ok(())
        }
    }
}

/// The device (`--device`) and a renderer on it (the context first: the renderer holds it).
fn renderer(device: Option<&str>) -> Result<(std::sync::Arc<Context>, scratchart_render::Renderer)> {
    let ctx = Context::new(ContextDesc {
        device: device.map(String::from),
        notify: Some(scratchart::term::stderr_notices()),
        ..Default::default()
    })?;
    let renderer = scratchart_render::Renderer::new(&ctx)?;
    Ok((ctx, renderer))
}

/// `scratchart-cal ports`: the serial ports, with their USB names.
fn ports_cmd() -> Result<()> {
    let ports = scratchart_machine::transport::ports()?;
    if ports.is_empty() {
        println!(
            "no serial ports found: plug the machine's USB cable in (and on Linux, check that you are in \
             the `dialout` group)"
        );
    }
    for p in &ports {
        match &p.usb {
            Some(u) => println!("{}\t{} ({u})", p.name, p.kind),
            None => println!("{}\t{}", p.name, p.kind),
        }
    }
    Ok(())
}

/// `scratchart-cal card`: the card, its G-code, and the capture guide (PNG and text) with each
/// view as a good photo of a typical V-bit's card looks.
fn card_cmd(
    device: Option<&str>,
    out: &std::path::Path,
    plate: f64,
    res: u32,
    machine: &plan_cmd::MachineArgs,
) -> Result<()> {
    if !(plate > 0.0) {
        return Err(scratchart_exit::UsageError("--plate must be > 0 mm".into()).into());
    }
    let card = Card::new(&CardSpec {
        plate_mm: plate,
        res,
        ..CardSpec::default()
    });
    std::fs::create_dir_all(out).with_context(|| format!("cannot create output directory {}", out.display()))?;
    let path = out.join("card.json");
    let text = serde_json::to_string_pretty(&card.to_json(res))?;
    scratchart_render::io::write_atomic(&path, text.as_bytes())?;
    println!(
        "wrote {}: {} ladder cuts ({} depths from {} to {} mm, {} orientations x {} repeats) and {} fiducial marks ({} cuts)",
        path.display(),
        card.cuts.iter().filter(|c| c.role == scratchart_calibration::card::CutRole::Ladder).count(),
        card.depths_mm.len(),
        card.depths_mm[0],
        card.depths_mm[card.depths_mm.len() - 1],
        card.orientations_deg.len(),
        card.repeats,
        card.marks.len(),
        card.cuts.iter().filter(|c| c.role == scratchart_calibration::card::CutRole::Fiducial).count()
    );
    println!("wrote {}", plan_cmd::write_card_gcode(&card, out, machine)?.display());
    // The capture guide, with each view as a good photo of a typical V-bit's card looks.
    let (card, capture) = Card::load(&path)?;
    let (_ctx, renderer) = renderer(device)?;
    let typical = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.0,
    };
    let lin = photos(&renderer, &card, &capture, &typical, &Camera::default())?;
    // Exposed so the brightest ladder rungs sit near 0.8 of full scale.
    let mut peak = 1e-6f64;
    for (v, img) in capture.views.iter().zip(&lin) {
        let mask = scratchart_calibration::fit_cmd::fit_mask(&card, v, 0.5 * card.plate_mm);
        let mut on: Vec<f64> = img
            .iter()
            .zip(&mask)
            .filter(|(_, m)| **m)
            .map(|(x, _)| scratchart_calibration::encoding::decode(*x as f64))
            .collect();
        on.sort_by(|a, b| a.total_cmp(b));
        peak = peak.max(on.get(on.len() * 998 / 1000).copied().unwrap_or(1e-6));
    }
    let cam = Camera {
        exposure: scratchart_calibration::encoding::decode(0.8) / peak,
        blur_px: 0.5,
        noise: 0.004,
        seed: 1,
    };
    let examples = photos(&renderer, &card, &capture, &typical, &cam)?;
    let gp = out.join("capture_guide.png");
    scratchart_calibration::guide::write_guide_png(&gp, &card, &capture, &examples)?;
    let gt = out.join("capture_guide.txt");
    scratchart_render::io::write_atomic(
        &gt,
        scratchart_calibration::guide::guide_text(&card, &capture).as_bytes(),
    )?;
    println!(
        "wrote {} and {} (where the camera and the lamp go, and a good photo)",
        gp.display(),
        gt.display()
    );
    for v in card.views(res) {
        let lamp = match v.light.kind {
            scratchart_model::scene::LightKind::Point { position } => {
                // Rounded first, so that a coordinate just below zero reads 0, not -0.
                let mm = |x: f64| x.round() + 0.0;
                format!(
                    "lamp at ({:.0}, {:.0}, {:.0}) mm",
                    mm(position[0]),
                    mm(position[1]),
                    mm(position[2])
                )
            }
            scratchart_model::scene::LightKind::Directional { direction } => format!(
                "lamp far away towards ({:.2}, {:.2}, {:.2})",
                direction[0], direction[1], direction[2]
            ),
        };
        let e = v.camera.eye;
        println!(
            "  capture view {}: camera at ({:.0}, {:.0}, {:.0}) mm, {lamp}, both from the card's centre",
            v.name, e[0], e[1], e[2]
        );
    }
    Ok(())
}

/// The camera flags of `simulate`, each within what a camera can be (exit 2 otherwise).
fn check_camera_flags(exposure: f64, blur: f64, noise: f64, megapixels: Option<f64>) -> Result<()> {
    let usage = |m: String| Err(scratchart_exit::UsageError(m).into());
    if !(exposure.is_finite() && exposure > 0.0) {
        return usage(format!(
            "--exposure {exposure}: a factor above 0 on the linear image (1 as rendered, 2 one stop brighter)"
        ));
    }
    if !(blur.is_finite() && (0.0..=20.0).contains(&blur)) {
        return usage(format!("--blur {blur}: a Gaussian blur of 0 to 20 pixels (0: sharp)"));
    }
    if !(noise.is_finite() && (0.0..=0.5).contains(&noise)) {
        return usage(format!(
            "--noise {noise}: a standard deviation of 0 to 0.5 in display values (0 black .. 1 white; 0.01 is a phone's)"
        ));
    }
    if let Some(mp) = megapixels {
        if !(mp.is_finite() && mp > 0.0 && mp <= 200.0) {
            return usage(format!(
                "--megapixels {mp}: a photo of more than 0 and at most 200 megapixels"
            ));
        }
    }
    Ok(())
}
