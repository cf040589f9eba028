//! `scratchart-cal simulate-plate`: a design's plate as plans carve it with a tool, photographed
//! from the design's views. The plans' cuts are read back from their G-code
//! (`scratchart_machine::carved`: a later plan's cut along a groove deepens it), each groove is
//! what the tool cuts at its commanded depth (`Tool::model`, the tool's own z offset), the
//! machine's error optionally added (a normal draw per cut of its depth and of each end), and
//! each view is photographed as `simulate` photographs the card ([`crate::simulate::photos_of`]:
//! rendered at 4 times the view's resolution, blurred, added up over the pixels, exposed,
//! display-encoded, noise). Without photo options the photos are exactly the views' cameras,
//! named after the views (`DIR/v0.png`, ...), the views' size. `DIR/carved.json` is the scene
//! the photos were rendered from (the grooves as carved), for the maker's and the tests' eyes.
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use scratchart_design::scenes::Rng;
use scratchart_exit::{InputError, UsageError};
use scratchart_machine::carved::{self, CarvedCut};
use scratchart_machine::program::Program;
use scratchart_model::scene::{Scene, Scratch};
use scratchart_observe::Observer;
use scratchart_render::Renderer;
use scratchart_tool::Tool;

use crate::simulate::{photos_of, Camera};

/// `scratchart-cal simulate-plate`'s flags.
#[derive(clap::Args, Debug)]
pub struct SimulatePlateArgs {
    /// The plans, in the order they were carved (a later cut along a groove deepens it)
    #[arg(required = true)]
    pub plans: Vec<PathBuf>,
    /// The design the plans carve (design.json): its plate and views
    #[arg(long)]
    pub design: PathBuf,
    /// The tool that really cuts (tool.json; its z offset is where commanded zero really is)
    #[arg(long)]
    pub tool: PathBuf,
    /// Output directory for the photos
    #[arg(long, default_value = "plate_photos")]
    pub out: PathBuf,
    /// Roughness of the groove walls (default: the tool's fitted alpha, else the design's median)
    #[arg(long)]
    pub alpha: Option<f64>,
    /// The machine's depth error: standard deviation of each cut's depth, mm (0: exact)
    #[arg(long, default_value_t = 0.0)]
    pub z_noise: f64,
    /// The machine's position error: standard deviation of each cut end's X and Y, mm (0: exact)
    #[arg(long, default_value_t = 0.0)]
    pub xy_noise: f64,
    /// Exposure factor on the linear image
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f64,
    /// Gaussian blur, pixels
    #[arg(long, default_value_t = 0.0)]
    pub blur: f64,
    /// Gaussian noise on display values (0..1)
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    /// The whole carving shifted by X,Y mm (a work zero set off the plate's centre)
    #[arg(long, value_name = "X,Y", value_parser = parse_pair, allow_hyphen_values = true)]
    pub shift: Option<[f64; 2]>,
    /// The whole carving turned by this many degrees about the plate's centre (a plate clamped
    /// askew), counter-clockwise seen from +z
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub turn: f64,
    /// The machine's Z moving this many times what it is told (its steps per mm off; 1: exact)
    #[arg(long, default_value_t = 1.0)]
    pub z_scale: f64,
    /// The lamp set up this many degrees further round than the design's (about the plate's
    /// normal, counter-clockwise seen from +z)
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_name = "DEG")]
    pub lamp_turn: f64,
    /// The lamp set up this many degrees higher than the design's (at the same distance)
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_name = "DEG")]
    pub lamp_tilt: f64,
    /// Seed of the noise and of the machine's error
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Take the photos as a phone does, this many megapixels each (colour, the noise on each
    /// channel at the photo's own resolution, EXIF; from the views' cameras)
    #[arg(long)]
    pub megapixels: Option<f64>,
    /// Save as JPEG of this quality (1-100), as a phone does, instead of PNG
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=100))]
    pub jpeg: Option<u8>,
}

/// `--shift X,Y`.
fn parse_pair(t: &str) -> Result<[f64; 2], String> {
    let v: Vec<f64> = t
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok([x, y]),
        _ => Err(format!("`{t}`: give X,Y in mm, for example 0.3,-0.2")),
    }
}

/// Plate point `p` moved by the carving's turn (about the centre) and shift.
pub fn moved_point(p: [f64; 2], shift_mm: [f64; 2], turn_deg: f64) -> [f64; 2] {
    let (sn, cs) = turn_deg.to_radians().sin_cos();
    [cs * p[0] - sn * p[1] + shift_mm[0], sn * p[0] + cs * p[1] + shift_mm[1]]
}

/// `view` under its lamp moved: turned `turn_deg` about the plate's normal through its centre
/// (counter-clockwise seen from +z) and raised `tilt_deg` in elevation at the same distance
/// from the centre (a lamp set up off the sheet's place); a directional light's direction the
/// same way.
pub fn lamp_moved(view: &scratchart_model::scene::View, turn_deg: f64, tilt_deg: f64) -> scratchart_model::scene::View {
    use scratchart_model::scene::LightKind;
    let mv = |p: [f64; 3]| {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        if !(r > 0.0) {
            return p;
        }
        let az = p[1].atan2(p[0]) + turn_deg.to_radians();
        // Raised past overhead it comes down on the other side (cos el < 0 turns it round);
        // kept above the plate.
        let el = ((p[2] / r).clamp(-1.0, 1.0).asin() + tilt_deg.to_radians()).clamp(0.01, std::f64::consts::PI - 0.01);
        [r * el.cos() * az.cos(), r * el.cos() * az.sin(), r * el.sin()]
    };
    let mut v = view.clone();
    v.light.kind = match view.light.kind {
        LightKind::Point { position } => LightKind::Point { position: mv(position) },
        LightKind::Directional { direction } => LightKind::Directional {
            direction: mv(direction),
        },
    };
    v
}

/// The machine's error on each cut (normal, one draw per cut end and per depth), and the whole
/// carving's shift (mm) and turn (degrees, about the plate's centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MachineError {
    pub z_mm: f64,
    pub xy_mm: f64,
    pub seed: u64,
    pub shift_mm: [f64; 2],
    pub turn_deg: f64,
    /// The machine's Z moving this many times what it is told (1: exact).
    pub z_scale: f64,
}

impl Default for MachineError {
    fn default() -> MachineError {
        MachineError {
            z_mm: 0.0,
            xy_mm: 0.0,
            seed: 0,
            shift_mm: [0.0; 2],
            turn_deg: 0.0,
            z_scale: 1.0,
        }
    }
}

/// The design's plate with `grooves` cut by `tool` (each at its commanded depth, perturbed by
/// `error`), walls of roughness `alpha`; cuts that do not reach the plate leave no groove. Returns
/// the scene and how many cuts left none.
pub fn carved_scene(
    design: &Scene,
    grooves: &[CarvedCut],
    tool: &Tool,
    alpha: f64,
    error: &MachineError,
) -> (Scene, usize) {
    let mut rng = Rng::new(error.seed ^ 0x5ca1_ab1e);
    let mut missed = 0;
    let half = 0.5 * design.plate.size_mm;
    let mut scratches = Vec::with_capacity(grooves.len());
    // A plan's depths lie on the machine's Z grid: few distinct ones, each fitted once.
    let mut models = std::collections::HashMap::new();
    for g in grooves {
        let c = &g.cut;
        let mut jitter = |v: f64, s: f64| if s > 0.0 { v + s * rng.normal() } else { v };
        let z = jitter(error.z_scale * c.z, error.z_mm);
        let (a, b) = (
            moved_point(c.a, error.shift_mm, error.turn_deg),
            moved_point(c.b, error.shift_mm, error.turn_deg),
        );
        let p0 = [jitter(a[0], error.xy_mm), jitter(a[1], error.xy_mm)].map(|v| v.clamp(-half, half));
        let p1 = [jitter(b[0], error.xy_mm), jitter(b[1], error.xy_mm)].map(|v| v.clamp(-half, half));
        let m = *models.entry(z.to_bits()).or_insert_with(|| tool.model(z));
        match m {
            Some(m) if m.width > 1e-6 && m.w > 0.0 && m.d > 0.0 => scratches.push(Scratch {
                p0,
                p1,
                w: m.w,
                d: m.d,
                alpha,
                bulge: c.bulge,
            }),
            _ => missed += 1,
        }
    }
    let scene = Scene {
        plate: design.plate.clone(),
        views: design.views.clone(),
        scratches,
    };
    (scene, missed)
}

/// The grooves `plans` leave in a plate, carved in turn, and how many cuts deepened a groove.
pub fn plate_grooves(plans: &[PathBuf]) -> Result<(Vec<CarvedCut>, usize)> {
    let mut all = Vec::new();
    for p in plans {
        let program = Program::load(p).map_err(|e| InputError(e.to_string()))?;
        let cuts = carved::cuts(&program);
        if cuts.is_empty() {
            return Err(InputError(format!("{}: the plan cuts nothing (no move below Z0)", p.display())).into());
        }
        all.push(cuts);
    }
    Ok(carved::merge(&all))
}

/// The walls' roughness: `--alpha`, else the tool file's fitted alpha, else the design's median.
pub fn groove_alpha(given: Option<f64>, tool_file: &Path, design: &Scene) -> Result<f64> {
    let a = match given {
        Some(a) => a,
        None => match Tool::load_fitted(tool_file).ok().and_then(|(_, f)| f.alpha) {
            Some(a) => a,
            None => {
                let mut v: Vec<f64> = design.scratches.iter().map(|s| s.alpha).collect();
                v.sort_by(f64::total_cmp);
                v.get(v.len() / 2).copied().unwrap_or(0.1)
            }
        },
    };
    if !(a > 0.0 && a < 1.0) {
        return Err(UsageError(format!(
            "--alpha {a}: the walls' roughness lies strictly between 0 and 1"
        ))
        .into());
    }
    Ok(a)
}

/// `scratchart-cal simulate-plate`.
pub fn run(a: &SimulatePlateArgs, renderer: &Renderer, obs: &dyn Observer) -> Result<()> {
    for (name, v) in [("--z-noise", a.z_noise), ("--xy-noise", a.xy_noise)] {
        if !(0.0..1.0).contains(&v) {
            return Err(UsageError(format!("{name} {v}: a standard deviation in mm, >= 0 and under 1")).into());
        }
    }
    let design = Scene::load(&a.design)?;
    let tool = Tool::load(&a.tool).map_err(|e| InputError(e.to_string()))?;
    let alpha = groove_alpha(a.alpha, &a.tool, &design)?;
    let (grooves, deepened) = plate_grooves(&a.plans)?;
    let error = MachineError {
        z_mm: a.z_noise,
        xy_mm: a.xy_noise,
        seed: a.seed,
        shift_mm: a.shift.unwrap_or([0.0; 2]),
        turn_deg: a.turn,
        z_scale: a.z_scale,
    };
    if !(a.z_scale > 0.5 && a.z_scale < 2.0) {
        return Err(UsageError(format!("--z-scale {}: between 0.5 and 2", a.z_scale)).into());
    }
    if !(a.turn.abs() <= 45.0) || error.shift_mm.iter().any(|v| v.abs() > 0.5 * design.plate.size_mm) {
        return Err(UsageError("--turn is at most 45 degrees and --shift within the plate".into()).into());
    }
    if !(a.lamp_turn.abs() <= 45.0 && a.lamp_tilt.abs() <= 30.0) {
        return Err(UsageError(format!(
            "--lamp-turn {} --lamp-tilt {}: at most 45 and 30 degrees",
            a.lamp_turn, a.lamp_tilt
        ))
        .into());
    }
    let (mut scene, missed) = carved_scene(&design, &grooves, &tool, alpha, &error);
    for v in &mut scene.views {
        *v = lamp_moved(v, a.lamp_turn, a.lamp_tilt);
    }
    obs.info(&format!(
        "{} grooves from {} plan(s) ({deepened} cuts deepened a groove already cut; {missed} did not reach the plate), \
         roughness {alpha}",
        scene.scratches.len(),
        a.plans.len()
    ));
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create output directory {}", a.out.display()))?;
    scene.save(&a.out.join("carved.json"), "carved.csv")?;
    if a.megapixels.is_some() || a.jpeg.is_some() {
        // As a phone takes them (`phone::take_of`), from the views' cameras; the marks as the
        // plan carves them (none covered).
        for (v, view) in scene.views.iter().enumerate() {
            let shot = crate::phone::Shot {
                exposure: a.exposure,
                blur_px: a.blur,
                noise: a.noise,
                megapixels: a
                    .megapixels
                    .unwrap_or(view.camera.width as f64 * view.camera.height as f64 / 1e6),
                jpeg_quality: a.jpeg,
                seed: a.seed.wrapping_add(v as u64),
                ..Default::default()
            };
            let (p, _) = crate::phone::take_of(renderer, &scene, &[], v, &shot, &a.out)?;
            println!("wrote {}", p.display());
        }
        return Ok(());
    }
    let cam = Camera {
        exposure: a.exposure,
        blur_px: a.blur,
        noise: a.noise,
        seed: a.seed,
    };
    let imgs = photos_of(renderer, &scene, &cam)?;
    for (v, img) in scene.views.iter().zip(&imgs) {
        let bytes: Vec<u8> = img.iter().map(|&x| (255.0 * x).round() as u8).collect();
        let p = a.out.join(format!("{}.png", v.name));
        scratchart_render::io::write_png_gray(&p, v.camera.width, v.camera.height, &bytes)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::lamp_moved;
    use scratchart_model::scene::{Light, LightKind, View};

    fn view_lit_from(position: [f64; 3]) -> View {
        View {
            exposure: 1.0,
            name: "v0".into(),
            camera: scratchart_design::scenes::orbit_camera(300.0, 45.0, 0.0, 100.0, 16, 16),
            light: Light {
                kind: LightKind::Point { position },
                intensity: 1.0e4,
            },
        }
    }

    fn at(v: &View) -> [f64; 3] {
        match v.light.kind {
            LightKind::Point { position } => position,
            LightKind::Directional { direction } => direction,
        }
    }

    /// A lamp overhead stays there unmoved (it used to be clamped to 85.9 degrees), is raised
    /// past overhead down the other side, and keeps its distance.
    #[test]
    fn a_lamp_overhead_moves_only_as_told() {
        let top = view_lit_from([0.0, 0.0, 300.0]);
        let p = at(&lamp_moved(&top, 0.0, 0.0));
        assert!(
            p[0].abs() < 1e-9 && p[1].abs() < 1e-9 && (p[2] - 300.0).abs() < 1e-9,
            "{p:?}"
        );
        // From 80 degrees up at azimuth 0, raised 20: 80 degrees up at azimuth 180.
        let el80 = view_lit_from(scratchart_model::camera::spherical(300.0, 0.0, 80.0));
        let q = at(&lamp_moved(&el80, 0.0, 20.0));
        let want = scratchart_model::camera::spherical(300.0, 180.0, 80.0);
        assert!((0..3).all(|k| (q[k] - want[k]).abs() < 1e-9), "{q:?} vs {want:?}");
        // Turned and raised a little from 45 degrees, it keeps its distance.
        let el45 = view_lit_from(scratchart_model::camera::spherical(300.0, 30.0, 45.0));
        let r = at(&lamp_moved(&el45, 3.0, -2.0));
        assert!(((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt() - 300.0).abs() < 1e-9);
    }
}
