//! The tool fit: the tool's parameters, the z offset, the groove walls' roughness, each photo's
//! exposure and the camera's blur, fitted to registered photos of the card by rendering the card
//! with the engine.
//!
//! Forward model, per capture view v: the engine renders the card as the tool cuts it (every
//! ladder cut and fiducial becomes the scratch model's groove for the tool at its commanded depth),
//! the linear image is blurred by a Gaussian of sigma b px (the optics blur light, before the
//! sensor), scaled by the exposure E_v, clipped at 1 as a sensor clips, raised to the photo's
//! own tone power e^-t_v (free: no phone encodes exactly as one curve says) and encoded
//! (`encoding`), as `scratchart-cal simulate` does with t = 0. The Gaussian's centre is moved by a fitted
//! sub-pixel shift per view: the photometric registration, with no resampling of anything
//! (resampling blurs by an amount that changes with the sub-pixel phase and biased the groove
//! shapes). Each view is the camera that took its photo (`fit_cmd`: the capture view, or the
//! camera recovered from the card's hatched marks when the photo was taken elsewhere), at the photo's
//! size after shrinking in linear light.
//!
//! Loss: a robust (Cauchy) sum over the on-card pixels of the capture views, scale
//! s = 1.4826 MAD of the residuals at the start of each iteration (at least 0.002), so a dust
//! speck, a reflection or a stray scratch does not pull the fit.
//!
//! Optimizer: Levenberg-Marquardt on the few parameters (3 to 8 tool and camera numbers; a
//! measured profile has one width per ladder depth). The Jacobian is differentiable rendering:
//! the columns of the parameters that move the grooves (the tool's, the z offset, alpha) are the
//! engine's derivatives of every pixel along up to 7 of them per pass (`Renderer::tangents`:
//! the backward's reverse sweep through the pair integral and the clipping), seeded with each
//! groove's d(w, d, alpha) through the tool model; the camera terms (exposure, blur, shift) need
//! no render, and the eyes of photos taken off the capture pose, which move the camera rather
//! than the grooves, are differenced over renders. The cost is not smooth in the z offset:
//! a ladder rung appears when its commanded depth plus the offset passes zero (with a tip flat its
//! width jumps from 0). So the offset is searched first on the ladder's thresholds, and each
//! refinement keeps the offset inside one interval between thresholds, where the set of cut
//! rungs is fixed and the cost smooth; the best interval wins.
//!
//! What identifies what (the card's features): the depth at which grooves appear gives the z
//! offset (to the ladder step, and finer through the widths of the rungs just past it); the
//! growth of the brightness down the ladder gives the width law W(z) (the V angle, or the ball
//! radius); the brightness at the first rungs gives the tip flat; the spread of the brightness
//! over the four orientations and two views gives the walls' roughness and slope. Uncertainties
//! are the square roots of the diagonal of s_r^2 (J^T W J)^-1 at the optimum (s_r^2 the weighted
//! residual variance); pixel noise is treated as independent, so blur makes them optimistic by
//! about the blur's width in pixels. A parameter whose uncertainty is larger than its stated
//! limit is reported as not identified, not as a number.
use scratchart_model::scene::{Scene, Scratch};
use scratchart_observe::{Observer, Progress};
use scratchart_render::tangent::{ScratchTangent, TANGENT_DIRECTIONS};
use scratchart_render::Renderer;
use scratchart_tool::Tool;
use serde::{Deserialize, Serialize};

use super::card::{Card, CutRole};

/// The fit renders the card at this many times the photos' resolution (each way) and lets the
/// optics blur and the pixels add up the light as a camera does (see `Evaluator::sensor`).
pub const SUPERSAMPLE: u32 = 2;

/// The tool models the fit knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    VBit,
    Ball,
    TaperedBall,
    Profile,
}

impl Kind {
    pub const ALL: [Kind; 4] = [Kind::VBit, Kind::Ball, Kind::TaperedBall, Kind::Profile];

    pub fn name(self) -> &'static str {
        match self {
            Kind::VBit => "v-bit",
            Kind::Ball => "ball",
            Kind::TaperedBall => "tapered-ball",
            Kind::Profile => "profile",
        }
    }

    pub fn parse(s: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == s)
    }
}

pub mod information;
mod layout;
pub use layout::{ANGLE_TOL_DEG, LENGTH_TOL_MM, OFFSET_TOL_MM};
mod camera;
mod evaluator;
mod lm;
pub(crate) mod noise;
mod starts;
mod uncertainty;
pub use uncertainty::{CHANGE_TRUST, LIFT_TRUST};

use layout::Layout;
use lm::refine;
use scratchart_optim::least_squares::{cauchy, Solution};
use starts::{refine_starts, search_starts, start_from, OffsetIntervals};
use uncertainty::Uncertainty;

/// The fit's data: the card, its capture views and the registered photos.
pub struct Data<'a> {
    pub card: &'a Card,
    pub capture: &'a Scene,
    /// One registered photo per capture view (display values on the view's raster).
    pub photos: Vec<Vec<f32>>,
    /// Pixels that take part: on the card and inside the photo.
    pub masks: Vec<Vec<bool>>,
    /// Refine the registration photometrically: a sub-pixel shift of each view's model, fitted
    /// with the rest (applied as a shifted blur kernel, so nothing is resampled).
    pub refine_shift: bool,
    /// Per view: fit its camera (a photo taken off the capture pose, whose camera came from the
    /// card's marks).
    pub refine_pose: Vec<bool>,
    /// Per view: the JPEG quality of a photo compared on its own pixel grid (`photo::jpeg_quality`;
    /// `None` for a PNG, or a photo shrunk to the view, whose JPEG blocks are averaged away).
    /// JPEG's quantization moves a thin groove's light in a way no parameter can (a quality-90
    /// photo moved a V angle by 1.2 degrees), so the fit corrects for it: after a first
    /// refinement, the model's own JPEG round trip at that quality (its change to the model
    /// image) is added to the model and the refinement runs again, twice (a fixed point of
    /// model + JPEG(model) - model = photo).
    pub jpeg: Vec<Option<u8>>,
    /// Per view: the photo's own pixel noise (display units, `photo::pixel_noise`), for the
    /// check of what noise, 8-bit steps and JPEG do to the fit (see `fit_kind`).
    pub noise: Vec<f64>,
    /// Per view: the whole factor its photo was shrunk by (1: used as taken). A shrink
    /// averages the light of k x k pixels whose noise was clipped at black before: the dark
    /// plate is lifted where no noise shows any more (see `noise`).
    pub shrink: Vec<u32>,
    /// Per view: the sensor's noise at the photo's own resolution, before a shrink, in each
    /// colour channel (display units; `fit_cmd::inspect`).
    pub native_noise: Vec<f64>,
    /// Per view: a colour photo (three channels with their own noise) or a grey one.
    pub colour: Vec<bool>,
    /// Per view: the JPEG quality the photo was saved with, used as taken or shrunk, turned or
    /// not (`photo::jpeg_table_quality`); `None` for a PNG. A shrunk JPEG's noise lost part of
    /// its spread to JPEG before the shrink (see `noise`).
    pub saved_jpeg: Vec<Option<u8>>,
    /// Per view: the photo's white balance, each channel's light over green's
    /// (`photo::Channels::gains`): the channels clip at different light (`camera`).
    pub gains: Vec<[f64; 3]>,
}

/// What a fit found.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitResult {
    pub kind: Kind,
    pub tool: Tool,
    pub alpha: f64,
    pub exposure: Vec<f64>,
    /// The camera's blur of each photo, pixels.
    pub blur_px: Vec<f64>,
    /// Parameter names and values, with their uncertainties (None: not identified).
    pub params: Vec<(String, f64, Option<f64>)>,
    /// Robust loss at the optimum (per pixel), the RMS residual (display units), pixels used.
    pub loss: f64,
    pub rms: f64,
    pub pixels: usize,
    /// Bayesian information criterion of the robust loss: how the kinds are compared.
    pub bic: f64,
    /// Renders of the card, and tangent passes (each gives the derivatives of every pixel along
    /// up to 7 parameters: the Jacobian's columns for the tool, its offset and alpha).
    pub renders: u32,
    #[serde(default)]
    pub tangent_passes: u32,
    /// Wall seconds spent in the engine's calls (uploads, renders, tangent passes and their
    /// read-backs): the rest of the fit's time is the host's.
    #[serde(default)]
    pub engine_seconds: f64,
    /// Of `engine_seconds`: the grooves of each evaluated tool (the tool model on the host) and
    /// the card's uploads (`Evaluator::sync`).
    #[serde(default)]
    pub engine_sync_seconds: f64,
    pub iterations: u32,
    /// Bootstrap standard deviations of every parameter (`--bootstrap N`), in `params`' order.
    #[serde(default)]
    pub bootstrap: Option<Vec<f64>>,
    /// The curvature's standard deviations (s^2 (J^T W J)^-1, pixels taken as independent), in
    /// `params`' order; `sd` is the larger of this and the sandwich's, with the systematic
    /// terms in quadrature.
    #[serde(default)]
    pub curvature: Vec<Option<f64>>,
    /// The standard deviations before the limits (`params` holds `None` above them): the larger
    /// of the block sandwich's and the curvature's, the systematic terms in quadrature.
    #[serde(default)]
    pub sd: Vec<Option<f64>>,
    /// Per parameter, the largest step one photo alone takes from the joint optimum beyond what
    /// that photo's own noise explains (a part of `sd`; None where fewer than two photos see it).
    #[serde(default)]
    pub disagreement: Vec<Option<f64>>,
    /// Per parameter, the shift the model's lift of the photos' clipped noise makes (the fit
    /// with it against the fit without it; `noise`), of which `LIFT_TRUST` is a part of `sd`.
    #[serde(default)]
    pub noise_lift: Vec<Option<f64>>,
    /// Per parameter, the shift the model's own error asks for (a render at four times the
    /// photos' resolution) and the mean shift the photos' simulated degradations make: both
    /// are in the standard deviation.
    pub model_error: Vec<Option<f64>>,
    pub degradation: Vec<Option<f64>>,
    /// Per parameter, the shift a shrunk JPEG's simulated change makes (see
    /// `uncertainty::CHANGE_TRUST`).
    pub jpeg_change: Vec<Option<f64>>,
    /// Per photo, per parameter: where that photo alone puts it (one Gauss-Newton step from the
    /// joint optimum on its residuals; None where it does not see the parameter).
    #[serde(default)]
    pub per_photo: Vec<Vec<Option<f64>>>,
    /// Per photo, the RMS of the model's own error over its pixels (display units): the change
    /// a render at four times the photos' resolution makes to the model image. Part of what
    /// the residual may be (`fit_cmd::verdict`).
    #[serde(default)]
    pub model_error_rms: Vec<f64>,
    /// Per photo, the RMS residual that copies of it made as it was (its noise, white balance,
    /// 8-bit steps and JPEG, at its own pixels where it was shrunk) leave against the fitted
    /// model (display units; None where none was drawn). Part of what the residual may be.
    #[serde(default)]
    pub degraded_rms: Vec<Option<f64>>,
    /// Each parameter's limit of identification (its standard deviation at most this).
    #[serde(default)]
    pub limits: Vec<f64>,
    /// Parameters the photos do not see at all (a zero Jacobian column: a measured profile's
    /// width at a depth where the tool does not reach the plate).
    #[serde(default)]
    pub unseen: Vec<String>,
    /// Parameters of the grooves (tool, z offset, alpha, eyes) that ended at a bound of their
    /// range: the optimum may lie beyond it.
    #[serde(default)]
    pub at_bound: Vec<String>,
}

impl FitResult {
    /// Photo v's noise scale as the fit refined its lift of clipped noise (`ln_noise[v]`: its
    /// sensor noise over the one measured); None where the fit did not refine it.
    pub fn noise_scale(&self, v: usize) -> Option<f64> {
        let name = format!("ln_noise[{v}]");
        self.params.iter().find(|p| p.0 == name).map(|p| p.1.exp())
    }

    /// Parameters the photos do not constrain well enough (their uncertainty is above the
    /// parameter's limit, or undefined), less those they do not see at all.
    pub fn unidentified(&self) -> Vec<String> {
        self.params
            .iter()
            .filter(|p| p.2.is_none() && !self.unseen.contains(&p.0))
            .map(|p| p.0.clone())
            .collect()
    }
}

/// A fit could not be run on the data.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error("{0}")]
    Data(String),
    #[error(transparent)]
    Render(#[from] anyhow::Error),
    #[error("interrupted")]
    Interrupted,
}

struct Evaluator<'a, 'r> {
    renderer: &'r Renderer,
    data: &'a Data<'a>,
    lay: Layout,
    renders: u32,
    /// Tangent passes (`Renderer::tangents`) run for Jacobians.
    tangent_passes: u32,
    /// Wall seconds in the engine's calls ([`FitResult::engine_seconds`]), and of them in
    /// [`Evaluator::sync`].
    engine_s: f64,
    sync_s: f64,
    /// Bootstrap weights of the residuals (None: all 1), applied as sqrt(w) r.
    weights: Option<Vec<f64>>,
    /// The card on the device, re-used with new scratch parameters for every render: the tiles
    /// the residuals read (`Evaluator::window`), or the whole images while `whole`.
    gs: Option<scratchart_render::GpuScene>,
    whole: bool,
    /// Renders at this many times the photos' resolution (`SUPERSAMPLE`; more for the check
    /// of the model's own error).
    ss: u32,
    /// Per view: what JPEG does to the model image (see `Data::jpeg`), added to the model.
    jpeg_shift: Vec<Option<Vec<f32>>>,
    /// Per view: the expected photo of the model under the sensor's clipped noise (see
    /// `noise`), applied in `expose`.
    transfer: Vec<Option<noise::Lift>>,
    /// Per view: how its colour channels clip under the photo's white balance (see
    /// `camera::ChannelClip`); `None` where they clip together.
    clip: Vec<Option<camera::ChannelClip>>,
    /// The photos compared with the model where not the data's own: the search for start
    /// points compares smoothed photos (see `starts::search_starts`).
    compared: Option<Vec<Vec<f32>>>,
}

impl<'a, 'r> Evaluator<'a, 'r> {
    /// The evaluator of `data` in `lay`: nothing rendered yet, at `SUPERSAMPLE`, the photos'
    /// lift of clipped noise and their channels' clip from the data.
    fn new(renderer: &'r Renderer, data: &'a Data<'a>, lay: Layout) -> Evaluator<'a, 'r> {
        let n = data.capture.views.len();
        Evaluator {
            renderer,
            data,
            lay,
            renders: 0,
            tangent_passes: 0,
            engine_s: 0.0,
            sync_s: 0.0,
            weights: None,
            gs: None,
            whole: false,
            ss: SUPERSAMPLE,
            jpeg_shift: vec![None; n],
            transfer: noise::for_views(data),
            clip: camera::ChannelClip::for_views(data),
            compared: None,
        }
    }

    /// The evaluator of a fit of `kind` to `data`: the layout of its parameters with the
    /// photos' registration and pose refined as the data says, the noise's lift where a photo
    /// shows it, and each photo's tone curve free (`Layout::tone`: no phone encodes exactly as
    /// the curve the fit assumes, and an edit or an app changes it; a tool read from how bright the rungs are
    /// under one assumed curve was written 10 degrees off with exit 0 when the curve was a
    /// tenth steeper, calibration/docs/fit.md "The photo's encoding").
    fn of_kind(renderer: &'r Renderer, data: &'a Data<'a>, kind: Kind) -> Evaluator<'a, 'r> {
        let lay = Layout::new(
            kind,
            data.card,
            data.capture.views.len(),
            data.refine_shift,
            &data.refine_pose,
            &noise::lift_seen(data),
            true,
        );
        Evaluator::new(renderer, data, lay)
    }
}

/// A refinement's starting point: the parameter vector and the z offset's interval (if any).
pub type Start = (Vec<f64>, Option<(f64, f64)>);

/// How a fit runs.
#[derive(Clone, Debug)]
pub struct FitConfig {
    /// Levenberg-Marquardt iterations per refinement.
    pub iters: u32,
    /// Starting point (a previous tool.json's tool and alpha): skips the search.
    pub init: Option<(Tool, Option<f64>)>,
    /// The starting points an interrupted fit of this kind had found (its resume file): skips
    /// the search.
    pub starts: Option<Vec<Start>>,
    /// Bootstrap replicates for a second set of uncertainties (0: none).
    pub bootstrap: u32,
    /// Every render of the whole images, not the tiles the residuals read
    /// (`Evaluator::window`): the same fit to the bit, slower.
    pub whole_renders: bool,
}

impl Default for FitConfig {
    fn default() -> FitConfig {
        FitConfig {
            iters: 15,
            init: None,
            starts: None,
            bootstrap: 0,
            whole_renders: false,
        }
    }
}

/// Fits one tool kind to the data.
/// `on_starts` gets the starting points once they are known (after the search), so a caller
/// can keep them for a resumed run ([`FitConfig::starts`]).
pub fn fit_kind(
    renderer: &Renderer,
    data: &Data,
    kind: Kind,
    cfg: &FitConfig,
    obs: &dyn Observer,
    on_starts: &mut dyn FnMut(&[Start]),
) -> Result<FitResult, FitError> {
    let mut ev = Evaluator::of_kind(renderer, data, kind);
    ev.whole = cfg.whole_renders;
    let intervals = OffsetIntervals::of(data.card);
    // Starting points: those of an interrupted fit, the tool given, or a search.
    let mut starts: Vec<Start> = cfg.starts.clone().unwrap_or_default();
    if starts.is_empty() {
        if let Some((tool, alpha)) = &cfg.init {
            starts.extend(start_from(&ev.lay, tool, *alpha, &intervals));
        }
    }
    if starts.is_empty() {
        starts = search_starts(&mut ev, &intervals, kind, obs)?;
    }
    on_starts(&starts);
    let (best, mut iterations) = refine_starts(&mut ev, starts, &intervals, kind, cfg, obs)?;
    let (Solution { mut x, mut cost, .. }, best_rg) = best;
    // JPEG photos: the model takes the JPEG's change to it and is refined again from where it
    // stands. Compared on their own pixel grid (see `Data::jpeg`), or shrunk: simulated photos
    // at the photo's own resolution (the model's light under the photo's white balance, its
    // noise, 8 bits, the JPEG, the shrink), their mean less the model
    // (`Evaluator::simulated_shift`).
    let shrunk_jpeg = |v: usize| {
        data.saved_jpeg.get(v).copied().flatten().filter(|_| {
            let k = data.shrink.get(v).copied().unwrap_or(1);
            k > 1 && k <= noise::shrunk::SIMULATED_SHRINK
        })
    };
    // (`Evaluator::simulated_light` holds the same condition for the views it simulates.)
    if data.jpeg.iter().any(|q| q.is_some()) || (0..data.capture.views.len()).any(|v| shrunk_jpeg(v).is_some()) {
        for pass in 0..2 {
            let lin = ev.render_whole(&x)?;
            let pred = ev.predict(&lin, &x);
            for v in 0..data.capture.views.len() {
                let c = &data.capture.views[v].camera;
                ev.jpeg_shift[v] = if let Some(q) = data.jpeg.get(v).copied().flatten() {
                    let back = super::photo::jpeg_round_trip(&pred[v], c.width, c.height, q);
                    Some(back.iter().zip(&pred[v]).map(|(b, p)| b - p).collect())
                } else if let (Some(_), Some(lit)) = (shrunk_jpeg(v), ev.simulated_light(&lin[v], v, &x)) {
                    ev.simulated_shift(&lit, v, &x, &pred[v])
                } else {
                    None
                };
            }
            let label = format!("{} JPEG pass {}", kind.name(), pass + 1);
            let got = refine(&mut ev, x, best_rg, cfg.iters.min(8), obs, &label)?;
            iterations += cfg.iters.min(8);
            x = got.x;
            cost = got.cost;
        }
    }
    let Uncertainty {
        mut params,
        curvature,
        sd: raw_sd,
        disagreement,
        noise_lift,
        model_error,
        degradation,
        jpeg_change,
        per_photo,
        model_error_rms,
        degraded_rms,
        unseen,
        residuals: r,
        in_valley,
    } = uncertainty::at_optimum(&mut ev, data, &x, best_rg)?;
    let n = r.len();
    let np = ev.lay.params.len();
    let at_bound: Vec<String> = (0..np)
        .filter(|&k| {
            let q = &ev.lay.params[k];
            let span = q.hi - q.lo;
            // (A measured profile's width of 0 is a rung the tool does not reach, not a limit.)
            let no_cut = q.name.starts_with("W_mm@") && x[k] - q.lo < 1e-3 * span;
            // (A photo's noise scale at its bound: its dark plate is brighter or darker than any
            // plausible noise makes it.)
            let checked = (q.render && !q.name.starts_with("registration")) || q.name.starts_with("ln_noise[");
            checked && !no_cut && (x[k] - q.lo < 1e-3 * span || q.hi - x[k] < 1e-3 * span)
        })
        .map(|k| ev.lay.params[k].name.clone())
        .collect();
    // One that stopped at a bound in the valley of an unidentified parameter (a measured
    // profile's w/W trades with its widths) ran along what the photos cannot tell from flat:
    // it is not identified either, whatever its own uncertainty says.
    for (k, p) in params.iter_mut().enumerate() {
        if in_valley[k] && at_bound.contains(&p.0) {
            p.2 = None;
        }
    }
    let bootstrap = if cfg.bootstrap > 0 {
        Some(uncertainty::bootstrap(&mut ev, &x, best_rg, cfg.bootstrap, obs)?)
    } else {
        None
    };
    let rms = (r.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt();
    let loss = cost / n as f64;
    let bic = 2.0 * n as f64 * (loss / 1e-6).ln_1p() + np as f64 * (n as f64).ln();
    let lay = &ev.lay;
    Ok(FitResult {
        kind,
        tool: lay.tool(&x),
        alpha: lay.alpha(&x),
        exposure: (0..lay.n_views).map(|v| lay.exposure(&x, v)).collect(),
        blur_px: (0..lay.n_views).map(|v| lay.blur(&x, v)).collect(),
        params,
        loss,
        rms,
        pixels: n,
        bic,
        renders: ev.renders,
        tangent_passes: ev.tangent_passes,
        engine_seconds: ev.engine_s,
        engine_sync_seconds: ev.sync_s,
        iterations,
        bootstrap,
        curvature,
        sd: raw_sd,
        disagreement,
        noise_lift,
        model_error,
        degradation,
        jpeg_change,
        per_photo,
        model_error_rms,
        degraded_rms,
        limits: ev.lay.params.iter().map(|q| q.limit).collect(),
        unseen,
        at_bound,
    })
}

/// Model display images of a fitted tool and the photos as the fit registered them (for the
/// residual images).
pub fn predict(renderer: &Renderer, data: &Data, res: &FitResult) -> Result<(Vec<Vec<f32>>, Vec<Vec<f32>>), FitError> {
    let mut ev = Evaluator::of_kind(renderer, data, res.kind);
    let x: Vec<f64> = res.params.iter().map(|p| p.1).collect();
    let lin = ev.render_whole(&x)?;
    let photos = (0..data.capture.views.len()).map(|v| data.photos[v].clone()).collect();
    Ok((ev.predict(&lin, &x), photos))
}
