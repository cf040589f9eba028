//! What a capture tells of a tool before any photo is taken: the Cramér-Rao bound of every
//! parameter the fit estimates, from the fit's own Jacobian at the truth.
use scratchart_render::Renderer;
use scratchart_tool::Tool;

use super::layout::Layout;
use super::starts::{start_from, OffsetIntervals};
use super::{lm, Data, Evaluator, FitError, Kind};

/// The truth of a capture's photos for [`information`]: the tool, its walls' roughness, and
/// each photo's exposure and blur (pixels).
pub struct Truth<'t> {
    pub tool: &'t Tool,
    pub alpha: f64,
    pub exposure: Vec<f64>,
    pub blur_px: Vec<f64>,
}

/// What one capture tells of a tool: the Cramér-Rao bound of every parameter the fit estimates,
/// for photos at the capture views with Gaussian noise of `noise` (display units) on each pixel,
/// at the truth (`tool`, `alpha`, each photo's exposure and blur), every nuisance term of the
/// fit free beside the tool (exposures, blurs, shading, registration). The standard deviations
/// are sqrt(diag(noise^2 (J^T J)^-1)) with J the fit's own Jacobian there (the engine's
/// tangents for the grooves): the least any fit of such photos can be sure of. With
/// `free_tone` each photo's tone curve is free too (see `Layout`): what is left is what the
/// capture tells by geometry rather than by brightness. A parameter the
/// photos do not see (a zero column) is `None`. `data.photos` only shape the masks' use: the
/// Jacobian does not depend on them.
pub fn information(
    renderer: &Renderer,
    data: &Data,
    truth: &Truth,
    noise: f64,
    free_tone: bool,
) -> Result<Vec<(String, Option<f64>)>, FitError> {
    let Truth {
        tool,
        alpha,
        exposure,
        blur_px,
    } = truth;
    let alpha = *alpha;
    let kind = match tool {
        Tool::VBit { .. } => Kind::VBit,
        Tool::Ball { .. } => Kind::Ball,
        Tool::TaperedBall { .. } => Kind::TaperedBall,
        Tool::Profile { .. } => Kind::Profile,
    };
    let n_views = data.capture.views.len();
    let lay = Layout::new(
        kind,
        data.card,
        n_views,
        data.refine_shift,
        &data.refine_pose,
        &vec![false; n_views],
        free_tone,
    );
    let intervals = OffsetIntervals::of(data.card);
    let (mut x, rg) = match tool {
        Tool::Profile { points, w_over_w, .. } => {
            let mut x = lay.start(0.0, (0.0, 0.0));
            for (k, z) in data.card.depths_mm.iter().enumerate() {
                x[k] = points.iter().find(|p| (p[0] - z).abs() < 1e-9).map_or(0.0, |p| p[1]);
            }
            x[data.card.depths_mm.len()] = *w_over_w;
            x[lay.n_tool] = alpha;
            (x, None)
        }
        _ => start_from(&lay, tool, Some(alpha), &intervals)
            .ok_or_else(|| FitError::Data("the tool's kind has no start".into()))?,
    };
    for v in 0..n_views {
        x[lay.n_tool + 1 + v] = exposure[v].ln();
        x[lay.n_tool + 1 + n_views + v] = blur_px[v];
    }
    // The photos of the analysis are noiseless and grey: no lift, one clip.
    let mut ev = Evaluator {
        transfer: vec![None; n_views],
        clip: vec![None; n_views],
        ..Evaluator::new(renderer, data, lay)
    };
    let (_, cols) = lm::jacobian_at(&mut ev, &x, rg)?;
    let seen: Vec<usize> = (0..cols.len()).filter(|&k| cols[k].iter().any(|c| *c != 0.0)).collect();
    let used: Vec<Vec<f64>> = seen.iter().map(|&k| cols[k].clone()).collect();
    let ones = vec![1.0; used.first().map_or(0, |c| c.len())];
    let a = scratchart_optim::least_squares::weighted_gram(&used, &ones);
    let mut out: Vec<(String, Option<f64>)> = ev.lay.params.iter().map(|p| (p.name.clone(), None)).collect();
    for (j, &k) in seen.iter().enumerate() {
        let mut e = vec![0.0; seen.len()];
        e[j] = 1.0;
        if let Some(col) = scratchart_optim::least_squares::solve_spd(&a, &e) {
            if col[j] > 0.0 {
                out[k].1 = Some(noise * col[j].sqrt());
            }
        }
    }
    Ok(out)
}
