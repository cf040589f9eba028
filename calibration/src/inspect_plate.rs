//! `scratchart-cal inspect`: photos of a carved plate against its design. Each photo is taken
//! from one of the design's views (matched by its file name, else by order); the plate as
//! carved is modelled as the design's cuts (its commanded depths, or the plans given with
//! `--plan`) cut by the calibrated tool *as the carving found it*: every groove `width_scale`
//! times as wide and every cut `dz` deeper (`Tool::as_carved`: a bit that wore or differs from
//! its calibration, a z offset that drifted), the carving shifted and turned, under the lamp
//! turned and raised from the design's place (`simulate_plate::lamp_moved`; see [`fit`]).
//! Those numbers are fitted to the photos, each
//! photo's exposure free (solved in closed form at every step: the display encoding is a power
//! law, so a linear factor on the display values), rendered as `simulate-plate` photographs
//! (`simulate::render_fine` and `develop`), the registration marks and the +x mark masked out.
//! The fit: a coarse grid, then Gauss-Newton with damping on central differences; the
//! uncertainties sqrt(diag(s^2 (J^T J)^-1)) with s^2 the residual's variance (the exposures
//! profiled out, so they count). What the photos do not pin to the tolerances below is refused
//! (exit 3, no inspect.json), as the tool fit refuses.
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use scratchart_exit::{InputError, UsageError};
use scratchart_machine::carved::CarvedCut;
use scratchart_machine::plan::Cut;
use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::Scene;
use scratchart_observe::Observer;
use scratchart_render::Renderer;
use scratchart_tool::Tool;
use serde_json::json;

use crate::simulate::{develop, render_fine};

mod fit;
mod photos;
mod report;

use crate::simulate_plate::{carved_scene, groove_alpha, lamp_moved, moved_point, plate_grooves, MachineError};
use photos::{mark_cuts, photo_views, read_photo_of_any, Photo};

/// The largest uncertainty (1 sigma) of the depth change that `inspect` states, mm: half the
/// 5 um a touch-up needs.
pub const DZ_TOLERANCE_MM: f64 = 0.0025;
/// The largest uncertainty (1 sigma) of the width scale that `inspect` states: half the 5% a
/// touch-up needs.
pub const SCALE_TOLERANCE: f64 = 0.025;
/// How far the fit looks: depth changes within +-this, mm, and width scales within its range.
const DZ_RANGE_MM: f64 = 0.1;
const SCALE_RANGE: (f64, f64) = (0.6, 1.6);
/// The carving's shift (mm, each axis) and turn (degrees) looked at.
const SHIFT_RANGE_MM: f64 = 2.0;
const TURN_RANGE_DEG: f64 = 2.0;
/// The depth scales looked at.
const DEPTH_SCALE_RANGE: (f64, f64) = (0.7, 1.4);
/// The lamp's turn and tilt looked at, degrees each way.
const LAMP_RANGE_DEG: f64 = 10.0;
/// Pixels within this of a mark's square (or the +x mark's cut), mm, are left out of the fit.
const MARK_PAD_MM: f64 = 1.0;

/// `scratchart-cal inspect`'s flags.
#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    /// The design (design.json) the plate was carved from
    pub design: PathBuf,
    /// Photos of the carved plate, one per view, each named after its view (v0.png, ...) or
    /// given in the views' order; PNG or JPEG
    #[arg(required = true)]
    pub photos: Vec<PathBuf>,
    /// The calibrated tool the plate was carved with (tool.json)
    #[arg(long)]
    pub tool: PathBuf,
    /// Output directory: inspect.json, tool_as_carved.json and a difference image per photo
    #[arg(long, default_value = "inspect")]
    pub out: PathBuf,
    /// The plans carved into the plate, in order (default: the design's commanded depths, as
    /// `plan` carves them)
    #[arg(long)]
    pub plan: Vec<PathBuf>,
    /// The photos' optical blur, pixels of the view
    #[arg(long, default_value_t = 0.0)]
    pub blur: f64,
    /// Roughness of the groove walls (default: the tool's fitted alpha, else the design's median)
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Also fit the machine's depth scale (its Z moving more or less than told: steps per mm
    /// off). Off by default: for a V-bit it is nearly the same number as the bit's width, so the
    /// photos tell the two apart only from a carving that matches the model exactly
    #[arg(long)]
    pub depth_scale: bool,
    /// Hold the lamp where the design puts it (by default its turn about the plate's normal and
    /// its height are fitted with the rest: a lamp set up a few degrees off lights other grooves,
    /// which would otherwise read as a deeper or wider carving)
    #[arg(long)]
    pub lamp_as_designed: bool,
}

/// What the photos are compared with: the design, its cuts and the tool.
struct Problem<'a> {
    renderer: &'a Renderer,
    design: Scene,
    grooves: Vec<CarvedCut>,
    tool: Tool,
    alpha: f64,
    blur_px: f64,
    photos: Vec<Photo>,
    /// Whether the depth scale is fitted (`--depth-scale`).
    fit_depth_scale: bool,
    /// Whether the lamp's turn and tilt are fitted (not `--lamp-as-designed`).
    fit_lamp: bool,
}

/// One evaluation: per photo its developed display image (before exposure), the fitted
/// exposure factor and the residual over the used pixels.
struct Eval {
    images: Vec<Vec<f32>>,
    gain: Vec<f64>,
    residual: Vec<f64>,
    /// Per photo the shift its render was moved by onto it, pixels (0 for a view's own camera).
    shift_px: Vec<[f64; 2]>,
}

impl Problem<'_> {
    /// Whether the design's lamp stands within 3 degrees of overhead (of the plate's normal),
    /// where turning it about the normal does not move it.
    fn lamp_overhead(&self) -> bool {
        use scratchart_model::scene::LightKind;
        self.design.views.iter().all(|v| {
            let p = match v.light.kind {
                LightKind::Point { position } => position,
                LightKind::Directional { direction } => direction,
            };
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            r > 0.0 && p[2] / r >= 3f64.to_radians().cos()
        })
    }

    /// The design's plate as carved with width scale `s` and depth change `dz`, as the photos'
    /// cameras record it (display values before each photo's exposure).
    fn images_of(&self, scene: &Scene) -> Result<Vec<Vec<f32>>> {
        let fine = render_fine(self.renderer, scene, self.blur_px)?;
        Ok(fine
            .iter()
            .zip(&scene.views)
            .map(|(img, v)| {
                develop(img, v.camera.width as usize, v.camera.height as usize, self.blur_px)
                    .into_iter()
                    .map(scratchart_render::io::display_value)
                    .collect()
            })
            .collect())
    }

    fn carved(&self, x: &fit::X) -> Scene {
        let c = fit::meaning(x);
        let tool = self.tool.as_carved(c.width_scale, c.dz_mm);
        let moved: Vec<CarvedCut> = self
            .grooves
            .iter()
            .map(|g| {
                let mut g = g.clone();
                g.cut.z *= c.depth_scale;
                g.cut.a = moved_point(g.cut.a, c.shift_mm, c.turn_deg);
                g.cut.b = moved_point(g.cut.b, c.shift_mm, c.turn_deg);
                g
            })
            .collect();
        let scene = carved_scene(&self.design, &moved, &tool, self.alpha, &MachineError::default()).0;
        self.seen_by_photos(scene, c.lamp_deg)
    }

    /// `scene` seen by the photos' cameras (one view per photo), under the lamp turned and
    /// raised by `lamp_deg` from where the design puts it.
    fn seen_by_photos(&self, scene: Scene, lamp_deg: [f64; 2]) -> Scene {
        Scene {
            views: self
                .photos
                .iter()
                .map(|p| lamp_moved(&p.camera, lamp_deg[0], lamp_deg[1]))
                .collect(),
            ..scene
        }
    }

    /// Each photo against `images`: a photo located by the marks with its render moved onto it
    /// ([`photos::registered`]), the exposure in closed form, the residual.
    fn compare(&self, mut images: Vec<Vec<f32>>) -> Eval {
        let mut gain = Vec::new();
        let mut residual = Vec::new();
        let mut shift_px = Vec::new();
        for (k, p) in self.photos.iter().enumerate() {
            let d = if p.located {
                let (w, h) = (p.camera.camera.width as usize, p.camera.camera.height as usize);
                let (m, d) = photos::registered(&images[k], w, h, p);
                images[k] = m;
                d
            } else {
                [0.0; 2]
            };
            shift_px.push(d);
            let m = &images[k];
            let (mut mp, mut mm) = (0.0, 0.0);
            for i in 0..m.len() {
                if p.used[i] {
                    mp += m[i] as f64 * p.pixels[i] as f64;
                    mm += m[i] as f64 * m[i] as f64;
                }
            }
            let c = if mm > 0.0 { mp / mm } else { 0.0 };
            gain.push(c);
            for i in 0..m.len() {
                if p.used[i] {
                    residual.push(c * m[i] as f64 - p.pixels[i] as f64);
                }
            }
        }
        Eval {
            images,
            gain,
            residual,
            shift_px,
        }
    }

    /// The evaluation at x (see [`fit`]).
    fn eval(&self, x: &fit::X) -> Result<Eval> {
        Ok(self.compare(self.images_of(&self.carved(x))?))
    }
}

fn ssr(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// What the fit found.
pub struct Found {
    /// Depth change (mm, + deeper) and width scale, with their 1-sigma uncertainties.
    pub dz_mm: f64,
    pub dz_sd_mm: f64,
    pub width_scale: f64,
    pub width_scale_sd: f64,
    /// The whole carving's shift (mm) and turn about the plate's centre (degrees, + counter-
    /// clockwise seen from +z), with their uncertainties.
    pub shift_mm: [f64; 2],
    pub shift_sd_mm: [f64; 2],
    pub turn_deg: f64,
    pub turn_sd_deg: f64,
    /// The machine's Z moving this many times what it is told (its steps per mm off), and its
    /// uncertainty; held at 1 (uncertainty 0) when the photos do not pin it.
    pub depth_scale: f64,
    pub depth_scale_sd: f64,
    pub depth_scale_held: bool,
    /// The lamp as it stood (turned about the plate's normal, raised; degrees) and the
    /// uncertainties; held where the design puts it (uncertainties 0) with `--lamp-as-designed`.
    pub lamp_deg: [f64; 2],
    pub lamp_sd_deg: [f64; 2],
    pub lamp_held: bool,
    /// The correlation of the depth change and the width scale.
    pub correlation: f64,
    /// Residual's standard deviation (display values).
    pub residual_sd: f64,
    pub renders: usize,
    /// The parameter the fit left at the edge of the range it looks at, if one.
    pub at_edge: Option<&'static str>,
}

impl Found {
    /// Whether the shift or the turn is told apart from none: beyond 3 sigma and beyond what
    /// matters to a groove (20 um, 0.02 degrees).
    pub fn moved(&self) -> bool {
        let shift = (0..2).any(|k| self.shift_mm[k].abs() > (3.0 * self.shift_sd_mm[k]).max(0.02));
        shift || self.turn_deg.abs() > (3.0 * self.turn_sd_deg).max(0.02)
    }
}

/// Pearson's correlation of `a` and `b` over `used` (`scratchart_design::measure::correlation`,
/// the design's own, on these f32 images).
pub fn correlation(a: &[f32], b: &[f32], used: &[bool]) -> f64 {
    let wide = |x: &[f32]| x.iter().map(|&v| v as f64).collect::<Vec<f64>>();
    scratchart_design::measure::correlation(&wide(a), &wide(b), used)
}

/// `scratchart-cal inspect`.
pub fn run(a: &InspectArgs, renderer: &Renderer, obs: &dyn Observer) -> Result<()> {
    if !(a.blur >= 0.0 && a.blur < 20.0) {
        return Err(UsageError(format!("--blur {}: pixels, >= 0 and under 20", a.blur)).into());
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create output directory {}", a.out.display()))?;
    // A refused inspection leaves no inspect.json behind, also none from an earlier run.
    let report = a.out.join("inspect.json");
    let _ = std::fs::remove_file(&report);
    let (design, extra) = Scene::load_extra(&a.design)?;
    if !design.plate.shape.is_flat() {
        return Err(InputError(format!(
            "{}: inspect models a flat plate; photograph a bent plate's design before bending it",
            a.design.display()
        ))
        .into());
    }
    let tool = Tool::load(&a.tool).map_err(|e| InputError(e.to_string()))?;
    let alpha = groove_alpha(a.alpha, &a.tool, &design)?;
    let grooves = if a.plan.is_empty() {
        design_cuts(&a.design, &design, &extra, &tool)?
    } else {
        plate_grooves(&a.plan)?.0
    };
    let marks = mark_cuts(&design, &grooves, !a.plan.is_empty());
    let scratch_grooves: Vec<CarvedCut> = grooves.into_iter().filter(|g| g.label.starts_with("scratch")).collect();
    let (views, by_name) = photo_views(&a.photos, &design)?;
    let photos = a
        .photos
        .iter()
        .zip(&views)
        .map(|(f, &v)| read_photo_of_any(f, v, by_name, &design, &marks, a.blur))
        .collect::<Result<Vec<_>>>()?;
    let p = Problem {
        renderer,
        design,
        grooves: scratch_grooves,
        tool,
        alpha,
        blur_px: a.blur,
        photos,
        fit_depth_scale: a.depth_scale,
        fit_lamp: !a.lamp_as_designed,
    };
    obs.info(&format!(
        "{} photos, {} grooves, {} pixels compared",
        p.photos.len(),
        p.grooves.len(),
        p.photos
            .iter()
            .map(|p| p.used.iter().filter(|u| **u).count())
            .sum::<usize>()
    ));
    let (found, at) = fit::fit(&p, obs)?;
    report::write(a, &p, &found, &at)
}

/// The cuts `plan` makes of the design: its z_mm column, or the tool's curve.
fn design_cuts(
    file: &Path,
    design: &Scene,
    extra: &scratchart_model::scene_file::Extra,
    tool: &Tool,
) -> Result<Vec<CarvedCut>> {
    let z: Vec<f64> = match extra.column("z_mm") {
        Some(z) => z,
        None => scratchart_machine::depths::depths(&design.scratches, tool, 0.5)
            .into_iter()
            .map(|d| d.0)
            .collect(),
    };
    if z.len() != design.scratches.len() {
        return Err(InputError(format!(
            "{}: the z_mm column does not cover every scratch",
            file.display()
        ))
        .into());
    }
    Ok(design
        .scratches
        .iter()
        .zip(&z)
        .enumerate()
        .map(|(k, (s, &z))| CarvedCut {
            cut: Cut {
                a: s.p0,
                b: s.p1,
                z,
                scratch: k + 1,
                bulge: s.bulge,
            },
            label: format!("scratch {}", k + 1),
        })
        .collect())
}
