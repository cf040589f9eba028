//! `scratchart-cal inspect`: photos of a carved plate against its design. Each photo is taken
//! from one of the design's views (matched by its file name, else by order); the plate as
//! carved is modelled as the design's cuts (its commanded depths, or the plans given with
//! `--plan`) cut by the calibrated tool *as the carving found it*: every groove `width_scale`
//! times as wide and every cut `dz` deeper (`Tool::as_carved`: a bit that wore or differs from
//! its calibration, a z offset that drifted). Those two numbers are fitted to the photos, each
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

mod photos;
mod report;

use crate::simulate_plate::{carved_scene, groove_alpha, plate_grooves, MachineError};
use photos::{mark_cuts, photo_views, read_photo, Photo};

/// The largest uncertainty (1 sigma) of the depth change that `inspect` states, mm: half the
/// 5 um a touch-up needs.
pub const DZ_TOLERANCE_MM: f64 = 0.0025;
/// The largest uncertainty (1 sigma) of the width scale that `inspect` states: half the 5% a
/// touch-up needs.
pub const SCALE_TOLERANCE: f64 = 0.025;
/// How far the fit looks: depth changes within +-this, mm, and width scales within its range.
const DZ_RANGE_MM: f64 = 0.1;
const SCALE_RANGE: (f64, f64) = (0.6, 1.6);
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
}

/// One evaluation: per photo its developed display image (before exposure), the fitted
/// exposure factor and the residual over the used pixels.
struct Eval {
    images: Vec<Vec<f32>>,
    gain: Vec<f64>,
    residual: Vec<f64>,
}

impl Problem<'_> {
    /// The design's plate as carved with width scale `s` and depth change `dz`, as the photos'
    /// cameras record it (display values before each photo's exposure).
    fn images_of(&self, scene: &Scene) -> Result<Vec<Vec<f32>>> {
        let fine = render_fine(self.renderer, scene)?;
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

    fn carved(&self, s: f64, dz: f64) -> Scene {
        let tool = self.tool.as_carved(s, dz);
        self.seen_by_photos(carved_scene(&self.design, &self.grooves, &tool, self.alpha, &MachineError::default()).0)
    }

    /// `scene` seen by the photos' cameras: one view per photo.
    fn seen_by_photos(&self, scene: Scene) -> Scene {
        Scene {
            views: self.photos.iter().map(|p| p.camera.clone()).collect(),
            ..scene
        }
    }

    /// Each photo against `images`: the exposure in closed form, the residual.
    fn compare(&self, images: Vec<Vec<f32>>) -> Eval {
        let mut gain = Vec::new();
        let mut residual = Vec::new();
        for (k, p) in self.photos.iter().enumerate() {
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
        Eval { images, gain, residual }
    }

    /// The evaluation at x = (dz in um, 100 ln s).
    fn eval(&self, x: [f64; 2]) -> Result<Eval> {
        let scene = self.carved((x[1] / 100.0).exp(), x[0] * 1e-3);
        Ok(self.compare(self.images_of(&scene)?))
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
    /// Their correlation.
    pub correlation: f64,
    /// Residual's standard deviation (display values).
    pub residual_sd: f64,
    pub renders: usize,
}

/// The grid, then damped Gauss-Newton on central differences (see the module doc).
fn fit(p: &Problem, obs: &dyn Observer) -> Result<(Found, Eval)> {
    let mut renders = 0;
    let mut best: Option<([f64; 2], f64)> = None;
    for dz in [-30.0, -15.0, 0.0, 15.0, 30.0] {
        for ls in [-15.0, 0.0, 15.0] {
            let e = p.eval([dz, ls])?;
            renders += 1;
            let f = ssr(&e.residual);
            if best.is_none_or(|b| f < b.1) {
                best = Some(([dz, ls], f));
            }
        }
    }
    let (mut x, mut f) = best.expect("a grid");
    obs.info(&format!(
        "grid: best at {:+.0} um deeper, width x{:.3} (residual {:.4} rms)",
        x[0],
        (x[1] / 100.0).exp(),
        (f / p.eval(x)?.residual.len() as f64).sqrt()
    ));
    let h = 0.5;
    let mut lambda = 1e-3;
    let mut jtj = [[0.0; 2]; 2];
    for it in 0..15 {
        let mut cols = Vec::new();
        for k in 0..2 {
            let (mut a, mut b) = (x, x);
            a[k] += h;
            b[k] -= h;
            let (ra, rb) = (p.eval(a)?.residual, p.eval(b)?.residual);
            renders += 2;
            cols.push(
                ra.iter()
                    .zip(&rb)
                    .map(|(u, v)| (u - v) / (2.0 * h))
                    .collect::<Vec<f64>>(),
            );
        }
        let r = p.eval(x)?.residual;
        renders += 1;
        let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        jtj = [
            [dot(&cols[0], &cols[0]), dot(&cols[0], &cols[1])],
            [dot(&cols[1], &cols[0]), dot(&cols[1], &cols[1])],
        ];
        let g = [dot(&cols[0], &r), dot(&cols[1], &r)];
        let mut moved = false;
        for _ in 0..8 {
            let a = [
                [jtj[0][0] * (1.0 + lambda), jtj[0][1]],
                [jtj[1][0], jtj[1][1] * (1.0 + lambda)],
            ];
            let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
            if !(det.abs() > 0.0) {
                break;
            }
            let step = [
                -(a[1][1] * g[0] - a[0][1] * g[1]) / det,
                -(-a[1][0] * g[0] + a[0][0] * g[1]) / det,
            ];
            let mut y = [x[0] + step[0], x[1] + step[1]];
            y[0] = y[0].clamp(-DZ_RANGE_MM * 1e3, DZ_RANGE_MM * 1e3);
            y[1] = y[1].clamp(100.0 * SCALE_RANGE.0.ln(), 100.0 * SCALE_RANGE.1.ln());
            let fy = ssr(&p.eval(y)?.residual);
            renders += 1;
            if fy < f {
                moved = (y[0] - x[0]).abs() > 0.02 || (y[1] - x[1]).abs() > 0.02;
                (x, f) = (y, fy);
                lambda = (lambda * 0.3).max(1e-6);
                break;
            }
            lambda *= 10.0;
        }
        obs.info(&format!(
            "step {}: {:+.2} um deeper, width x{:.4}, residual {:.5} rms",
            it + 1,
            x[0],
            (x[1] / 100.0).exp(),
            (f / r.len() as f64).sqrt()
        ));
        if !moved {
            break;
        }
    }
    let e = p.eval(x)?;
    renders += 1;
    let n = e.residual.len();
    let dof = n.saturating_sub(2 + p.photos.len()).max(1);
    let s2 = ssr(&e.residual) / dof as f64;
    let det = jtj[0][0] * jtj[1][1] - jtj[0][1] * jtj[1][0];
    let cov = if det > 0.0 {
        [jtj[1][1] / det * s2, -jtj[0][1] / det * s2, jtj[0][0] / det * s2]
    } else {
        [f64::INFINITY, 0.0, f64::INFINITY]
    };
    let s = (x[1] / 100.0).exp();
    Ok((
        Found {
            dz_mm: x[0] * 1e-3,
            dz_sd_mm: cov[0].sqrt() * 1e-3,
            width_scale: s,
            // d s = s d(ln s) = s/100 d x1
            width_scale_sd: s * cov[2].sqrt() / 100.0,
            correlation: cov[1] / (cov[0] * cov[2]).sqrt(),
            residual_sd: s2.sqrt(),
            renders,
        },
        e,
    ))
}

/// Pearson's correlation of `a` and `b` over `used`.
pub fn correlation(a: &[f32], b: &[f32], used: &[bool]) -> f64 {
    let (mut n, mut sa, mut sb) = (0.0f64, 0.0, 0.0);
    for i in 0..a.len() {
        if used[i] {
            n += 1.0;
            sa += a[i] as f64;
            sb += b[i] as f64;
        }
    }
    let (ma, mb) = (sa / n.max(1.0), sb / n.max(1.0));
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for i in 0..a.len() {
        if used[i] {
            let (x, y) = (a[i] as f64 - ma, b[i] as f64 - mb);
            ab += x * y;
            aa += x * x;
            bb += y * y;
        }
    }
    ab / (aa * bb).sqrt().max(1e-300)
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
    let views = photo_views(&a.photos, &design)?;
    let photos = a
        .photos
        .iter()
        .zip(&views)
        .map(|(f, &v)| read_photo(f, v, &design, &marks, a.blur))
        .collect::<Result<Vec<_>>>()?;
    let p = Problem {
        renderer,
        design,
        grooves: scratch_grooves,
        tool,
        alpha,
        blur_px: a.blur,
        photos,
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
    let (found, at) = fit(&p, obs)?;
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
