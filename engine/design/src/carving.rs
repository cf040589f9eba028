//! What the machine's error costs a design (`design --machine`, issue 27 item 3): the written
//! design carved many times as the machine would cut it, each carving rendered and compared with
//! the pictures.
//!
//! A carving: every scratch's commanded depth off by a normal error of the profile's
//! `z_repeatability_mm`, each endpoint off by `xy_repeatability_mm` per axis (independent draws;
//! a repeatability is read as one standard deviation). The groove a perturbed depth cuts is the
//! tool's own (`Tool::model`, sampled by [`ToolTable`] from first contact to twice the design's
//! largest groove, so a carving may cut shallower than the design's shallowest cut or deeper
//! than its deepest); a depth that does not reach the plate cuts nothing, and the scratch is
//! gone from that carving. Each carving is rendered by the engine and scored as the design is
//! (each view's correlation with its picture, [`quality`]); the report gives the exact design's
//! correlation, the carvings' mean, spread and worst, per view.
use serde_json::{json, Value};

use crate::measure::quality;
use crate::problem::Problem;
use crate::scenes::Rng;
use scratchart_model::scene::{Scene, Scratch};
use scratchart_optim::tool_params::table::ToolTable;
use scratchart_optim::tool_params::{Fabrication, TABLE_SAMPLES};
use scratchart_render::Renderer;
use scratchart_vulkan::GpuError;

/// The error of a machine, one standard deviation, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MachineError {
    pub sigma_z_mm: f64,
    pub sigma_xy_mm: f64,
}

/// One view's correlation with its picture, exact and over the carvings.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewCarved {
    pub exact: f64,
    pub mean: f64,
    pub std: f64,
    pub worst: f64,
}

/// The design's scratches as one carving cuts them: `depths[i]` is scratch i's commanded
/// depth; the table maps perturbed depths (see the module doc). Scratches whose perturbed depth
/// does not reach the plate are left out.
pub fn perturbed(
    scratches: &[Scratch],
    depths: &[f64],
    table: &ToolTable,
    alpha: f64,
    err: MachineError,
    rng: &mut Rng,
) -> Vec<Scratch> {
    let mut out = Vec::with_capacity(scratches.len());
    for (s, &z) in scratches.iter().zip(depths) {
        let z = z + err.sigma_z_mm * rng.normal();
        let mut n = || err.sigma_xy_mm * rng.normal();
        let (p0, p1) = ([s.p0[0] + n(), s.p0[1] + n()], [s.p1[0] + n(), s.p1[1] + n()]);
        if z < table.z_lo {
            // above the table's first sample (first contact + 1 um): no groove worth a pixel
            continue;
        }
        let [w, d] = table.eval(z);
        out.push(Scratch {
            p0,
            p1,
            w,
            d,
            alpha,
            bulge: 0.0,
        });
    }
    out
}

/// The table a carving's depths are mapped through: the tool from first contact to twice the
/// design's widest and deepest groove.
pub fn carving_table(fab: &Fabrication, w_max: f64, d_max: f64) -> Result<ToolTable, String> {
    ToolTable::new(&fab.tool, 2.0 * w_max, 2.0 * d_max, TABLE_SAMPLES)
}

/// Renders `carvings` perturbed carvings of `scene` (the written design, `depths` its commanded
/// depths) and scores each view against the problem's pictures.
#[allow(clippy::too_many_arguments)]
pub fn carved_quality(
    renderer: &Renderer,
    problem: &Problem,
    scene: &Scene,
    depths: &[f64],
    fab: &Fabrication,
    table: &ToolTable,
    err: MachineError,
    carvings: u32,
    seed: u64,
    sigma: f32,
) -> Result<Vec<ViewCarved>, GpuError> {
    let displays = |s: &Scene| -> Result<Vec<Vec<f32>>, GpuError> {
        let mut gs = renderer.upload(s)?;
        let frame = renderer.render(&mut gs)?;
        Ok(frame
            .images
            .iter()
            .map(|img| img.iter().map(|&l| scratchart_render::io::display_value(l)).collect())
            .collect())
    };
    let score = |s: &Scene| -> Result<Vec<f64>, GpuError> {
        Ok(quality(s, &displays(s)?, &problem.targets, &problem.pictures, sigma)
            .into_iter()
            .map(|q| q.corr)
            .collect())
    };
    let exact = score(scene)?;
    let mut rng = Rng::new(seed ^ 0xC0FF_EE00_D15C_0123);
    let mut runs: Vec<Vec<f64>> = Vec::new();
    for _ in 0..carvings {
        let mut s = scene.clone();
        s.scratches = perturbed(&scene.scratches, depths, table, fab.alpha, err, &mut rng);
        runs.push(score(&s)?);
    }
    Ok((0..exact.len())
        .map(|v| {
            let c: Vec<f64> = runs.iter().map(|r| r[v]).collect();
            let n = c.len().max(1) as f64;
            let mean = c.iter().sum::<f64>() / n;
            let var = c.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
            ViewCarved {
                exact: exact[v],
                mean: if c.is_empty() { exact[v] } else { mean },
                std: var.sqrt(),
                worst: if c.is_empty() {
                    exact[v]
                } else {
                    c.iter().cloned().fold(f64::INFINITY, f64::min)
                },
            }
        })
        .collect())
}

/// `summary.json`'s `machine_error`.
pub fn summary(scene: &Scene, err: MachineError, robust: bool, carvings: u32, views: &[ViewCarved]) -> Value {
    let mean = |f: &dyn Fn(&ViewCarved) -> f64| views.iter().map(f).sum::<f64>() / views.len().max(1) as f64;
    json!({
        "carvings": carvings,
        "sigma_z_mm": err.sigma_z_mm,
        "sigma_xy_mm": err.sigma_xy_mm,
        "robust": robust,
        "what": "each view's correlation with its picture: the design as written (exact) and carved with the machine's error (mean, std and worst over the carvings)",
        "mean_corr_exact": mean(&|v| v.exact),
        "mean_corr_carved": mean(&|v| v.mean),
        "per_view": views.iter().zip(&scene.views).map(|(v, view)| json!({
            "name": view.name,
            "corr_exact": v.exact,
            "corr_carved_mean": v.mean,
            "corr_carved_std": v.std,
            "corr_carved_worst": v.worst,
        })).collect::<Vec<_>>(),
    })
}

/// `summary.json`'s `machine_error`: the written design carved `cfg.carvings` times with the
/// machine's error ([`crate::carving`]).
pub(crate) fn machine_error(
    renderer: &Renderer,
    problem: &Problem,
    cfg: &crate::problem::DesignConfig,
    fab: &scratchart_optim::tool_params::Fabrication,
    limits: &scratchart_optim::tool_params::MachineLimits,
    scene: &Scene,
    depths: &[f64],
) -> Result<Value, scratchart_optim::error::OptimError> {
    let err = MachineError {
        sigma_z_mm: limits.profile.z_repeatability_mm,
        sigma_xy_mm: limits.profile.xy_repeatability_mm,
    };
    let table = carving_table(fab, cfg.adam.w_bounds.1 as f64, cfg.adam.d_bounds.1 as f64)
        .map_err(|e| scratchart_optim::error::OptimError::Report(format!("the carvings' tool table: {e}")))?;
    let views = carved_quality(
        renderer,
        problem,
        scene,
        depths,
        fab,
        &table,
        err,
        cfg.carvings,
        cfg.seed,
        cfg.loss.sigma,
    )?;
    Ok(summary(scene, err, fab.robust.is_some(), cfg.carvings, &views))
}
