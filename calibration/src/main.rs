//! `scratchart-cal`: calibrate the carving tool before a carving session.
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context as _, Result};
use clap::{Parser, Subcommand};

use scratchart::vulkan::{Context, ContextDesc};
use scratchart_calibration::card::{Card, CardSpec};
use scratchart_calibration::simulate::{photos, Camera};
use scratchart_tool::Tool;

#[derive(Parser)]
#[command(
    name = "scratchart-cal",
    version,
    about = "Calibrate the carving tool: cut a test card, photograph it, fit the tool's profile.",
    long_about = "Calibrate the carving tool before a carving session, in this order:\n\n\
  1. scratchart-cal card --out DIR       writes DIR/card.json: the test card (a ladder of commanded depths\n\
                                         straddling the plate surface, at several orientations, with corner\n\
                                         fiducials) and where the camera and the lamp go to photograph it.\n\
  2. cut the card on the machine, and photograph it from each capture view of card.json.\n\
  3. scratchart-cal simulate --card DIR/card.json --tool tool.json --out IMGDIR\n\
                                         renders the card as a known tool would cut it, as the camera would\n\
                                         see it (for checking a set-up, and for tests).\n\n\
The fit of a tool to the photos (tool.json) is not built yet.\n\n\
Exit codes: 0 success, 1 runtime failure, 2 bad command line, 3 bad input file, 4 GPU/device failure."
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
    },
    /// Plan the carving of a design: one commanded depth per scratch from the tool's profile,
    /// the cut order (nearest neighbour, then 2-opt), bounds against the plate and the machine,
    /// the job time with acceleration; writes G-code (PLAN.nc) and a preview PNG beside it.
    Plan {
        /// The design (design.json from `scratchart design`)
        design: PathBuf,
        /// The tool (tool.json)
        #[arg(long)]
        tool: PathBuf,
        /// Output G-code file
        #[arg(long, default_value = "plan.nc")]
        out: PathBuf,
        /// Firmware of the machine: grbl (a router) or marlin (a printer with an engraving bit)
        #[arg(long, default_value = "grbl", value_parser = ["grbl", "marlin"])]
        machine: String,
        /// Machine profile (JSON: firmware, travel_mm, feeds, accel_mm_s2, safe_z_mm, spindle_rpm);
        /// default: the built-in profile of --machine
        #[arg(long)]
        machine_file: Option<PathBuf>,
    },
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
        Cmd::Card { out, plate, res } => {
            if !(*plate > 0.0) {
                return Err(scratchart::exit::UsageError("--plate must be > 0 mm".into()).into());
            }
            let card = Card::new(&CardSpec {
                plate_mm: *plate,
                res: *res,
                ..CardSpec::default()
            });
            std::fs::create_dir_all(out)
                .with_context(|| format!("cannot create output directory {}", out.display()))?;
            let path = out.join("card.json");
            let text = serde_json::to_string_pretty(&card.to_json(*res))?;
            scratchart::io::write_atomic(&path, text.as_bytes())?;
            println!(
                "wrote {}: {} ladder cuts ({} depths from {} to {} mm, {} orientations x {} repeats) and 4 fiducial crosses",
                path.display(),
                card.cuts.len() - 8,
                card.depths_mm.len(),
                card.depths_mm[0],
                card.depths_mm[card.depths_mm.len() - 1],
                card.orientations_deg.len(),
                card.repeats
            );
            for v in card.views(*res) {
                println!(
                    "  capture view {}: camera at ({:.0}, {:.0}, {:.0}) mm, lamp at {:?} mm, both from the card's centre",
                    v.name, v.camera.eye[0], v.camera.eye[1], v.camera.eye[2], match v.light.kind {
                        scratchart::model::scene::LightKind::Point { position } => position.map(|x| x.round()),
                        scratchart::model::scene::LightKind::Directional { direction } => direction,
                    }
                );
            }
            Ok(())
        }
        Cmd::Plan {
            design,
            tool,
            out,
            machine,
            machine_file,
        } => plan(design, tool, out, machine, machine_file.as_deref()),
        Cmd::Simulate {
            card,
            tool,
            out,
            exposure,
            blur,
            noise,
            seed,
        } => {
            let (card, capture) = Card::load(card)?;
            let tool = Tool::load(tool).map_err(|e| scratchart::exit::InputError(e.to_string()))?;
            let ctx = Context::new(ContextDesc {
                device: cli.device.clone(),
                ..Default::default()
            })?;
            let renderer = scratchart::render::Renderer::new(&ctx)?;
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
                scratchart::io::write_png_gray(&p, v.camera.width, v.camera.height, &bytes)?;
                println!("wrote {}", p.display());
            }
            Ok(())
        }
    }
}

fn plan(
    design: &std::path::Path,
    tool: &std::path::Path,
    out: &std::path::Path,
    machine: &str,
    machine_file: Option<&std::path::Path>,
) -> Result<()> {
    use scratchart_machine::plan::{check_bounds, job_time, nearest_neighbour, travel, two_opt, Cut, MachineProfile};
    let scene = scratchart_machine::load_design(design)?;
    let tool = Tool::load(tool).map_err(|e| scratchart::exit::InputError(e.to_string()))?;
    let mut m = match machine {
        "marlin" => MachineProfile::marlin(),
        _ => MachineProfile::grbl(),
    };
    if let Some(f) = machine_file {
        let text =
            std::fs::read_to_string(f).with_context(|| format!("cannot read machine profile {}", f.display()))?;
        m = serde_json::from_str(&text)
            .map_err(|e| scratchart::exit::InputError(format!("machine profile {} is not valid: {e}", f.display())))?;
    }
    let depths = scratchart_machine::depths::depths(&scene.scratches, &tool, 0.5);
    let worst = depths.iter().map(|d| d.1).fold(0.0f64, f64::max);
    let cuts: Vec<Cut> = scene
        .scratches
        .iter()
        .zip(&depths)
        .enumerate()
        .map(|(k, (s, (z, _)))| Cut {
            a: s.p0,
            b: s.p1,
            z: *z,
            scratch: k,
        })
        .collect();
    check_bounds(&cuts, scene.plate.size_mm, &m)
        .map_err(|e| scratchart::exit::InputError(format!("the plan leaves its bounds: {e}")))?;
    let t0 = travel(&cuts);
    let ordered = two_opt(nearest_neighbour(&cuts), 200);
    let t1 = travel(&ordered);
    let secs = job_time(&ordered, &m);
    let summary = vec![
        format!("tool {}", serde_json::to_string(&tool)?),
        format!(
            "travel {t0:.0} mm in design order, {t1:.0} mm ordered; estimated {:.1} min",
            secs / 60.0
        ),
        format!(
            "worst groove mismatch to the tool's curve: {:.1}% (|dw|/w + |dd|/d)",
            100.0 * worst
        ),
        "groove ends: each cut plunges at its start and lifts at its end; the tapered ends (about half a groove width) are not compensated: cuts keep the designed length".to_string(),
    ];
    let g = scratchart_machine::gcode::write(&ordered, &m, scene.plate.size_mm, &summary);
    if let Some(dir) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
    }
    scratchart::io::write_atomic(out, g.as_bytes())?;
    let preview = out.with_extension("png");
    write_preview(&preview, &ordered, scene.plate.size_mm)?;
    println!(
        "wrote {} ({} cuts) and {}",
        out.display(),
        ordered.len(),
        preview.display()
    );
    println!(
        "  travel: {t0:.0} mm in design order -> {t1:.0} mm ordered; estimated job time {:.1} min",
        secs / 60.0
    );
    println!(
        "  worst mismatch between a designed groove and the tool's: {:.1}%",
        100.0 * worst
    );
    Ok(())
}

/// The tool path from above: cuts black, rapid moves gray, on a white plate (512 px).
fn write_preview(path: &std::path::Path, cuts: &[scratchart_machine::plan::Cut], plate_mm: f64) -> Result<()> {
    let n = 512usize;
    let mut px = vec![255u8; n * n];
    let to = |p: [f64; 2]| {
        (
            (p[0] / plate_mm + 0.5) * (n - 1) as f64,
            (0.5 - p[1] / plate_mm) * (n - 1) as f64,
        )
    };
    let mut line = |a: [f64; 2], b: [f64; 2], v: u8| {
        let ((x0, y0), (x1, y1)) = (to(a), to(b));
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
            if x >= 0.0 && y >= 0.0 && (x as usize) < n && (y as usize) < n {
                let i = y as usize * n + x as usize;
                px[i] = px[i].min(v);
            }
        }
    };
    let mut at = [0.0, 0.0];
    for c in cuts {
        line(at, c.a, 190);
        at = c.b;
    }
    line(at, [0.0, 0.0], 190);
    for c in cuts {
        line(c.a, c.b, 0);
    }
    scratchart::io::write_png_gray(path, n as u32, n as u32, &px)?;
    Ok(())
}
