//! The fit's uncertainties at its optimum: the block sandwich covariance or the curvature's,
//! whichever is larger, and in quadrature the model's own error and what the photo's degradations do (see `at_optimum`); and the bootstrap.
use scratchart_observe::Observer;
use scratchart_optim::least_squares::{solve_spd, weighted_gradient};

use super::{lm, refine, Data, Evaluator, FitError, SUPERSAMPLE};

/// What `at_optimum` finds: per parameter (the layout's order) its name, value and standard
/// deviation where it is identified, the curvature's and the sandwich's standard deviations, the
/// parameters the photos do not see, and the residuals there.
pub(super) struct Uncertainty {
    pub(super) params: Vec<(String, f64, Option<f64>)>,
    pub(super) curvature: Vec<Option<f64>>,
    pub(super) sd: Vec<Option<f64>>,
    /// Per parameter, the largest step any one photo alone takes from the joint optimum beyond
    /// what that photo's noise explains (None where fewer than two photos see it): part of `sd`.
    pub(super) disagreement: Vec<Option<f64>>,
    /// Per parameter, the shift the model's lift of clipped noise makes (the fit with it against
    /// the fit without it, linearized; None where the photos carry no noise or do not see it),
    /// of which [`LIFT_TRUST`] is part of `sd`.
    pub(super) noise_lift: Vec<Option<f64>>,
    /// Per parameter, the shift the model's own error asks for and the mean shift the photos'
    /// degradations make (both in `sd`; None where not measured).
    pub(super) model_error: Vec<Option<f64>>,
    pub(super) degradation: Vec<Option<f64>>,
    /// Per parameter, the shift a shrunk JPEG's simulated change makes (the fit with it against
    /// the fit without it, linearized), of which [`CHANGE_TRUST`] is part of `sd`.
    pub(super) jpeg_change: Vec<Option<f64>>,
    /// Per photo (view), per parameter: where that photo alone puts it (see `disagreement`).
    pub(super) per_photo: Vec<Vec<Option<f64>>>,
    /// Per photo, the RMS of the model's own error over its pixels (see `model_shift`).
    pub(super) model_error_rms: Vec<f64>,
    /// Per photo, the RMS residual that copies of it made as it was (its noise, white balance,
    /// 8-bit steps and JPEG, at its own pixels where it was shrunk) leave against the model
    /// (see `degrade_shift`; None where none was drawn).
    pub(super) degraded_rms: Vec<Option<f64>>,
    pub(super) unseen: Vec<String>,
    pub(super) residuals: Vec<f64>,
    /// Per parameter: it trades with a parameter of the grooves that is not identified (their
    /// correlation at least [`VALLEY_CORRELATION`]): the fit may run along that valley.
    pub(super) in_valley: Vec<bool>,
}

/// How closely a parameter must trade with an unidentified one to share its valley.
pub(super) const VALLEY_CORRELATION: f64 = 0.9;

/// The uncertainties of the fit at `x` (its z offset within `best_rg`): the block sandwich, and
/// in quadrature the model's own error, what the photos' degradations do, and how far the photos
/// disagree.
pub(super) fn at_optimum(
    ev: &mut Evaluator,
    data: &Data,
    x: &[f64],
    best_rg: Option<(f64, f64)>,
) -> Result<Uncertainty, FitError> {
    // Uncertainties: the block sandwich (cluster-robust) covariance A^-1 B A^-1 at the optimum,
    // A = J^T W J and B = sum over blocks of g_b g_b^T, g_b = sum over the block's pixels of
    // w r J (W the robust weights). Unlike the curvature's s^2 A^-1 it holds where neighbouring
    // pixels are not independent (the camera's blur, JPEG's 8 x 8 blocks, a phone's
    // demosaicing: blocks of 16 x 16 pixels at the fit's scale) and where the model misses
    // something the photo has; both are given, and the larger is the one used: the sandwich
    // estimates B from the blocks the grooves cross, few enough to fall short by chance (the
    // tests' V 75 off the pose with 0.8% noise: +- 0.35 degrees by the sandwich, 0.59 by the
    // curvature, written 1.37 degrees off once a change of the blur's kernel moved the noise's
    // draw), and the curvature misses correlated noise.
    let (r, cols) = lm::jacobian_at(ev, x, best_rg)?;
    let n = r.len();
    let np = ev.lay.params.len();
    let s_r = scratchart_optim::least_squares::robust_scale(&r, lm::MIN_SCALE);
    let wts = lm::losses(ev, &r).weights(&r, s_r);
    let jtj = scratchart_optim::least_squares::weighted_gram(&cols, &wts);
    let wsum: f64 = r.iter().zip(&wts).map(|(e, w)| w * e * e).sum();
    let s2 = wsum / (n.saturating_sub(np)).max(1) as f64;
    // Covariance over the parameters the photos see at all (a zero column, such as a profile
    // width above the surface, is not identified and would make the whole matrix singular).
    let (seen, reduced) = seen_part(&jtj, 1e-12);
    let blocks = ev.residual_blocks(16);
    let sandwich = Sandwich::new(&reduced, &cols, &seen, &blocks, &wts, &r);
    let normal = Normal {
        a: &reduced,
        seen: &seen,
        cols: &cols,
        wts: &wts,
    };
    let (model_shift, model_error_rms) = model_shift(ev, x, &r, &normal)?;
    let (degrade_shift, lift_shift, change_shift, degraded_rms) = degrade_shift(ev, data, x, &normal)?;
    // What the photos say each on its own: a bias that one photo's degradations bring (clipped
    // noise averaged by a shrink, JPEG, blur the model does not follow) moves that photo's answer
    // and not the other's, and the joint fit sits between them with a spread no pixel noise
    // shows (the study's trial 6: alone, its photos put a tapered ball's cone at 30.5 and 33.4
    // degrees, where the fit had been accepted at 2.45 degrees off its 35.5 with +- 0.41). The largest
    // step of any photo's own Gauss-Newton step from the joint optimum (`split_estimates`),
    // less what that photo's own noise explains of it (the variance of a photo's estimate about
    // the joint one is its own variance less the joint's), is added in quadrature to each
    // standard deviation: a fit is only as sure as its photos agree.
    let splits = split_estimates(&cols, &r, &wts, &blocks, ev.lay.n_views);
    let per_photo: Vec<Vec<Option<f64>>> = (0..ev.lay.n_views as u64)
        .map(|v| match splits.iter().find(|s| s.view == v) {
            Some(sp) => sp.step.iter().zip(x).map(|(d, x)| d.map(|d| x + d)).collect(),
            None => vec![None; np],
        })
        .collect();
    let mut disagreement: Vec<Option<f64>> = vec![None; np];
    let mut noise_lift: Vec<Option<f64>> = vec![None; np];
    let mut model_error: Vec<Option<f64>> = vec![None; np];
    let mut degradation: Vec<Option<f64>> = vec![None; np];
    let mut jpeg_change: Vec<Option<f64>> = vec![None; np];
    let mut params = Vec::with_capacity(np);
    let mut curvature = Vec::with_capacity(np);
    let mut raw_sd = Vec::with_capacity(np);
    for k in 0..np {
        let q = &ev.lay.params[k];
        let pos = seen.iter().position(|&i| i == k);
        let (sd, sd_curv) = match (pos, &sandwich) {
            (Some(a), Some(sw)) => {
                let var = sw.cov(a, a);
                let vc = s2 * sw.ainv[a][a];
                let base = var.max(vc);
                let m = model_shift.as_ref().map_or(0.0, |d| d[a]);
                let dg = degrade_shift.as_ref().map_or(0.0, |d| d[a]);
                noise_lift[k] = lift_shift.as_ref().map(|d| d[a]);
                model_error[k] = model_shift.as_ref().map(|d| d[a]);
                degradation[k] = degrade_shift.as_ref().map(|d| d[a]);
                jpeg_change[k] = change_shift.as_ref().map(|d| d[a]);
                let ch = CHANGE_TRUST * change_shift.as_ref().map_or(0.0, |d| d[a]);
                let lf = LIFT_TRUST * lift_shift.as_ref().map_or(0.0, |d| d[a]);
                // Each photo's step beyond what its own noise explains; the largest.
                let excess = splits
                    .iter()
                    .filter_map(|sp| Some((sp.step[k]?, sp.var[k]?)))
                    .map(|(d, vg)| (d * d - (vg - var).max(0.0)).max(0.0))
                    .fold(0.0f64, f64::max);
                let seen_by = splits.iter().filter(|sp| sp.step[k].is_some()).count();
                if seen_by > 1 {
                    disagreement[k] = Some(excess.sqrt());
                }
                let var = base + m * m + dg * dg + lf * lf + ch * ch + if seen_by > 1 { excess } else { 0.0 };
                (
                    (var.is_finite() && var >= 0.0).then(|| var.sqrt()),
                    (vc.is_finite() && vc >= 0.0).then(|| vc.sqrt()),
                )
            }
            _ => (None, None),
        };
        curvature.push(sd_curv);
        raw_sd.push(sd);
        params.push((q.name.clone(), x[k], sd.filter(|sd| *sd <= q.limit)));
    }
    let unseen: Vec<String> = (0..np)
        .filter(|k| !seen.contains(k))
        .map(|k| ev.lay.params[k].name.clone())
        .collect();
    let in_valley = valley_flags(ev, &seen, sandwich.as_ref(), &params);
    Ok(Uncertainty {
        params,
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
    })
}

/// The block sandwich A^-1 B A^-1 over the parameters the photos see: A^-1 column by column and
/// B = sum over blocks of g_b g_b^T (with the small-sample correction).
struct Sandwich {
    ainv: Vec<Vec<f64>>,
    bmat: Vec<Vec<f64>>,
}

impl Sandwich {
    /// `None` where A cannot be inverted.
    fn new(
        reduced: &[Vec<f64>],
        cols: &[Vec<f64>],
        seen: &[usize],
        blocks: &[u64],
        wts: &[f64],
        r: &[f64],
    ) -> Option<Sandwich> {
        let n = r.len();
        let ns = seen.len();
        let g = block_scores(cols, seen, blocks, |i| Some(wts[i] * r[i]));
        let nb = g.len() as f64;
        let corr = if nb > 1.0 {
            nb / (nb - 1.0) * (n as f64 - 1.0) / (n as f64 - ns as f64).max(1.0)
        } else {
            1.0
        };
        let mut bmat = vec![vec![0.0f64; ns]; ns];
        for gb in &g {
            for a in 0..ns {
                for c in 0..ns {
                    bmat[a][c] += corr * gb[a] * gb[c];
                }
            }
        }
        let ainv: Option<Vec<Vec<f64>>> = (0..ns)
            .map(|a| {
                let mut e = vec![0.0; ns];
                e[a] = 1.0;
                solve_spd(reduced, &e)
            })
            .collect();
        Some(Sandwich { ainv: ainv?, bmat })
    }

    /// (A^-1 B A^-1)_ad = sum_bc Ai_ba B_bc Ai_cd (A^-1 symmetric), over seen indices.
    fn cov(&self, a: usize, d: usize) -> f64 {
        let (ai, ns) = (&self.ainv, self.ainv.len());
        let mut c = 0.0;
        for b in 0..ns {
            for e in 0..ns {
                c += ai[b][a] * self.bmat[b][e] * ai[e][d];
            }
        }
        c
    }
}

/// Per parameter: whether the sandwich correlates it with one of the grooves' unidentified
/// parameters (no stated uncertainty) by at least [`VALLEY_CORRELATION`].
fn valley_flags(
    ev: &Evaluator,
    seen: &[usize],
    sandwich: Option<&Sandwich>,
    params: &[(String, f64, Option<f64>)],
) -> Vec<bool> {
    let np = ev.lay.params.len();
    let mut in_valley = vec![false; np];
    let Some(sw) = sandwich else {
        return in_valley;
    };
    let ns = seen.len();
    let var: Vec<f64> = (0..ns).map(|a| sw.cov(a, a)).collect();
    let loose: Vec<usize> = (0..ns)
        .filter(|&a| {
            let k = seen[a];
            ev.lay.params[k].render && ev.lay.camera_view(k).is_none() && params[k].2.is_none()
        })
        .collect();
    for a in 0..ns {
        in_valley[seen[a]] = loose.iter().filter(|&&j| j != a).any(|&j| {
            let rho = sw.cov(a, j) / (var[a] * var[j]).sqrt();
            rho.abs() >= VALLEY_CORRELATION
        });
    }
    in_valley
}

/// The normal equations at the optimum over the parameters the photos see: A (`a`, over
/// `seen`), the Jacobian's columns and the robust weights.
struct Normal<'a> {
    a: &'a [Vec<f64>],
    seen: &'a [usize],
    cols: &'a [Vec<f64>],
    wts: &'a [f64],
}

impl Normal<'_> {
    /// The parameter shift A^-1 J^T W e that a change `e` of the residuals asks for (over
    /// `seen`); None where A is singular.
    fn step(&self, e: &[f64]) -> Option<Vec<f64>> {
        solve_spd(
            self.a,
            &weighted_gradient(self.seen.iter().map(|&p| &self.cols[p]), e, self.wts),
        )
    }
}

/// The model's own error: the fit renders at SUPERSAMPLE times the photos' resolution, which
/// is not the camera's continuous optics. The shift of the parameters that the residual
/// change to a render at twice that resolution asks for, A^-1 J^T W (r_fine - r), is added in
/// quadrature to each standard deviation (it is a bias no pixel noise shows).
/// Also returns, per photo, the RMS of that change over the pixels compared (display units,
/// unweighted): how far the model's own approximation leaves it from a finer model of the same
/// tool, a part of the residual that no noise makes.
fn model_shift(
    ev: &mut Evaluator,
    x: &[f64],
    r: &[f64],
    normal: &Normal,
) -> Result<(Option<Vec<f64>>, Vec<f64>), FitError> {
    ev.ss = 2 * SUPERSAMPLE;
    ev.gs = None;
    let fine = ev.eval(x);
    ev.ss = SUPERSAMPLE;
    ev.gs = None;
    let (rf, _) = fine?;
    let shift: Vec<f64> = rf.iter().zip(r).map(|(a, b)| a - b).collect();
    let mut rms = Vec::with_capacity(ev.data.masks.len());
    let mut i = 0;
    for mask in &ev.data.masks {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for _ in mask.iter().filter(|ok| **ok) {
            let w = ev.weights.as_ref().map_or(1.0, |w| w[i]);
            if w > 0.0 {
                sum += shift[i] * shift[i] / w;
                n += 1;
            }
            i += 1;
        }
        rms.push((sum / n.max(1) as f64).sqrt());
    }
    Ok((normal.step(&shift), rms))
}

/// What the photo's own degradations do to the fit beyond what the model expects of them (the
/// lift of clipped noise is in the model: `noise`) and beyond the noise the sandwich sees: a
/// photo used as taken is simulated from the model without that lift, its channels given the
/// photo's noise, clipped, stepped to 8 bits, made grey and (a JPEG on its own grid) put through
/// the same JPEG, four times; the mean parameter shift A^-1 J^T W (degraded - model) is a bias
/// of these steps (JPEG's quantization of a noisy groove is not JPEG's quantization of the
/// groove, and the lift of a single pixel is not the lift of its mean), added in quadrature like
/// the model's own error (it also holds half the noise's own spread over four draws: the sum
/// errs large). A shrunk photo is simulated at its own resolution (`noise::shrunk::shrunk_photo_draw`:
/// the model's light under the photo's white balance, the noise, the JPEG there, the shrink),
/// so the term sees what the JPEG of a coloured groove and of noise does after the model's own
/// JPEG change (a cast of 19% under JPEG had fixed a measured profile's wall shape at 2.16 +-
/// 0.07 for 1.97: with this term it is +- 0.9, not identified).
/// Also returns the parameter shift that the model's lift of clipped noise (`noise`) makes, the
/// fit with it against the fit without it (linearized), of which [`LIFT_TRUST`] goes into the
/// uncertainty, the shift of a shrunk JPEG's simulated change, and per photo the RMS residual
/// its degraded copies leave against the model (what a photo made as this one was would leave
/// were the model right: a JPEG of a low-noise photo rounds the grooves' edges, which the model
/// cannot follow pixel by pixel, where the noise measured on the flat plate is small).
#[allow(clippy::type_complexity)]
fn degrade_shift(
    ev: &mut Evaluator,
    data: &Data,
    x: &[f64],
    normal: &Normal,
) -> Result<(Option<Vec<f64>>, Option<Vec<f64>>, Option<Vec<f64>>, Vec<Option<f64>>), FitError> {
    let lin = ev.render_whole(x)?;
    let pred = ev.predict(&lin, x);
    let base = ev.residuals(&pred);
    let lifts = std::mem::replace(&mut ev.transfer, vec![None; data.capture.views.len()]);
    let raw = ev.predict(&lin, x);
    ev.transfer = lifts;
    let lift = {
        let r_raw = ev.residuals(&raw);
        let e: Vec<f64> = base.iter().zip(&r_raw).map(|(b, a)| b - a).collect();
        if e.iter().all(|v| *v == 0.0) {
            None
        } else {
            normal.step(&e)
        }
    };
    // The change a shrunk JPEG's simulation makes to the model (`Evaluator::simulated_shift`),
    // against the model without it.
    let change = {
        let shrunk: Vec<usize> = (0..data.capture.views.len())
            .filter(|&v| data.shrink.get(v).copied().unwrap_or(1) > 1 && ev.jpeg_shift[v].is_some())
            .collect();
        let kept = ev.jpeg_shift.clone();
        for &v in &shrunk {
            ev.jpeg_shift[v] = None;
        }
        let r_without = ev.residuals(&pred);
        ev.jpeg_shift = kept;
        let e: Vec<f64> = base.iter().zip(&r_without).map(|(b, a)| b - a).collect();
        if shrunk.is_empty() || e.iter().all(|v| *v == 0.0) {
            None
        } else {
            normal.step(&e)
        }
    };
    use crate::photo::LUMA;
    let mut rng = scratchart_design::scenes::Rng::new(0x5eed);
    let reps = 4;
    let mut mean = vec![0.0; normal.seen.len()];
    let mut ok = true;
    // A shrunk photo's light, once for all the draws (`Evaluator::simulated_light`).
    let lights: Vec<Option<super::noise::shrunk::ShrunkLight>> = (0..data.capture.views.len())
        .map(|v| ev.simulated_light(&lin[v], v, x))
        .collect();
    // How many normal draws each photo's degraded copy takes (a shrunk photo: one per channel of
    // each of its own pixels; one as the model has it, none), so that the draws of a repetition
    // come from the one generator in the order they always did, and the photos then degrade
    // side by side on the host's cores (the same bits).
    let chans = |v: usize| {
        if data.colour.get(v).copied().unwrap_or(false) {
            3
        } else {
            1
        }
    };
    let shrunk = |v: usize| data.shrink.get(v).copied().unwrap_or(1) > 1;
    let draws_of = |v: usize| -> usize {
        if !shrunk(v) {
            return raw[v].len() * chans(v);
        }
        let q = data.saved_jpeg.get(v).copied().flatten();
        match &lights[v] {
            Some(_) if ev.sigma(x, v) > 0.0 || q.is_some() => {
                let (c, k) = (&data.capture.views[v].camera, data.shrink[v] as usize);
                k * c.width as usize * k * c.height as usize * chans(v)
            }
            _ => 0,
        }
    };
    let counts: Vec<usize> = (0..raw.len()).map(draws_of).collect();
    let mut squares = vec![0.0f64; raw.len()];
    for _ in 0..reps {
        let noise: Vec<Vec<f64>> = counts.iter().map(|&n| (0..n).map(|_| rng.normal()).collect()).collect();
        let evr = &*ev;
        let deg: Vec<Vec<f32>> = scratchart_model::par::par_map(raw.len(), |v| {
            let (img, lifted) = (&raw[v], &pred[v]);
            let mut draws = noise[v].iter().copied();
            let mut normal = || draws.next().expect("a draw counted for each");
            let sigma = evr.sigma(x, v);
            let colour = chans(v) == 3;
            if shrunk(v) {
                // A shrunk photo as its camera made it, at its own resolution: the noise
                // and its JPEG there, then the shrink (`noise::shrunk::shrunk_photo_draw`). One
                // shrunk by more than `SIMULATED_SHRINK`, or clean and lossless, stays as
                // the model has it.
                let q = data.saved_jpeg.get(v).copied().flatten();
                // Against the model with its change for a shrunk JPEG (what the fit
                // compares): the residuals add that change to whatever they are given.
                return match &lights[v] {
                    Some(lit) if sigma > 0.0 || q.is_some() => {
                        evr.shrunk_draw(lit, v, sigma, q, &mut normal)
                            .map(|d| match &evr.jpeg_shift[v] {
                                Some(sh) => d.iter().zip(sh).map(|(d, s)| d - s).collect(),
                                None => d,
                            })
                    }
                    _ => None,
                }
                .unwrap_or_else(|| lifted.clone());
            }
            let q = |d: f64| (d.clamp(0.0, 1.0) * 255.0).round() / 255.0;
            let noisy: Vec<f32> = img
                .iter()
                .map(|&m| {
                    let m = m as f64;
                    if colour {
                        LUMA.iter().map(|w| w * q(m + sigma * normal())).sum::<f64>() as f32
                    } else {
                        q(m + sigma * normal()) as f32
                    }
                })
                .collect();
            match data.jpeg.get(v).copied().flatten() {
                // Against the model with its JPEG change (what the fit compares).
                Some(qual) => {
                    let c = &data.capture.views[v].camera;
                    let back = crate::photo::jpeg_round_trip(&noisy, c.width, c.height, qual);
                    match &evr.jpeg_shift[v] {
                        Some(sh) => back.iter().zip(sh).map(|(b, s)| b - s).collect(),
                        None => back,
                    }
                }
                None => noisy,
            }
        });
        let rd = ev.residuals(&deg);
        let shift: Vec<f64> = base.iter().zip(&rd).map(|(b, a)| b - a).collect();
        add_squares(&mut squares, &shift, &data.masks, reps);
        match normal.step(&shift) {
            Some(d) => mean.iter_mut().zip(&d).for_each(|(m, d)| *m += d / reps as f64),
            None => ok = false,
        }
    }
    let degraded = squares
        .iter()
        .enumerate()
        .map(|(v, sq)| (counts[v] > 0 || !shrunk(v)).then(|| sq.sqrt()))
        .collect();
    Ok((ok.then_some(mean), lift, change, degraded))
}

/// Adds each photo's mean square of `shift` (the residuals' order: the views in turn, their
/// compared pixels by `masks`) over `reps` repetitions to `squares`.
fn add_squares(squares: &mut [f64], shift: &[f64], masks: &[Vec<bool>], reps: usize) {
    let mut at = 0;
    for (sq, mask) in squares.iter_mut().zip(masks) {
        let n = mask.iter().filter(|m| **m).count();
        if let Some(block) = shift.get(at..at + n) {
            *sq += block.iter().map(|e| e * e).sum::<f64>() / (n.max(1) * reps) as f64;
        }
        at += n;
    }
}

/// How far a shrunk JPEG's simulated change (`Evaluator::simulated_shift`) is trusted: this
/// fraction of the parameter shift it makes is added in quadrature to each uncertainty. The
/// simulation spreads the model's light over the photo's own pixels from the model's
/// subpixels, coarser than a large photo's pixels by up to 16, where JPEG acts, and it misses
/// part of what JPEG does there. Measured (`scratchart-cal study --seed 1 --only 7 --only 8`):
/// a V-bit's change moved its angle 1.97 degrees and the fit was 0.26 off; a measured profile's
/// (21 MP at JPEG 91 and 0.7 MP at JPEG 88, casts of 7 to 19%) moved its widest rung 2.7 um,
/// and the fit was 8 um off. At half the shift the profile was written, 8 um narrow at +- 2.3:
/// the whole shift is counted (+- 3.3, refused).
pub const CHANGE_TRUST: f64 = 1.0;

/// How far the model's lift of clipped noise is trusted: this fraction of the parameter shift
/// it makes is added in quadrature to each uncertainty. The lift grows as about the square of
/// the sensor's noise, which the fit measures on each photo (`fit_cmd::inspect`) or refines
/// (`ln_noise`): over the 40 photos of `scratchart-cal study --group within --seed 1` with 0.9%
/// noise or more, measured within 4.5% rms of the truth (8% at most), so the lift is known to
/// about 2 x 4.5% = 0.1 of itself. Before the lift's size was refined and the JPEG's change
/// simulated with the noise, a 58 um ball at 2% noise and JPEG 80 was fitted at 64.4 um (the
/// lift 40% off) and this was 0.5; now the same photos give 58.44 +- 0.24
/// (`examples/factor_probe -- ball noise=0.02,jpeg=80`). Recounted from that study's reports:
/// 0.5 wrote 7 of 20, 0.1 writes 11, none of them wrong (`docs/fit.md`).
pub const LIFT_TRUST: f64 = 0.1;

/// Bootstrap uncertainties: `reps` refits from the optimum `x` (6 iterations each), every one
/// with the residuals of 8 x 8-pixel blocks weighted by independent Exp(1) weights (the Bayesian
/// bootstrap; blocks, because the camera's blur makes neighbouring pixels agree), and the
/// standard deviation of each parameter over the refits. Unlike the curvature's uncertainties it
/// sees the correlation of neighbouring pixels and the trade-offs the fit's local quadratic
/// misses. Seeded: the same data give the same numbers.
pub(super) fn bootstrap(
    ev: &mut Evaluator,
    x: &[f64],
    rg: Option<(f64, f64)>,
    reps: u32,
    obs: &dyn Observer,
) -> Result<Vec<f64>, FitError> {
    let blocks = ev.residual_blocks(8);
    let mut ids: Vec<u64> = blocks.clone();
    ids.sort_unstable();
    ids.dedup();
    let mut rng = scratchart_design::scenes::Rng::new(0);
    let mut fits: Vec<Vec<f64>> = Vec::new();
    for b in 0..reps {
        let wb: Vec<f64> = ids.iter().map(|_| -(1.0 - rng.f64()).ln()).collect();
        ev.weights = Some(blocks.iter().map(|id| wb[ids.binary_search(id).unwrap()]).collect());
        let label = format!("bootstrap {}/{reps}", b + 1);
        let got = refine(ev, x.to_vec(), rg, 6, obs, &label);
        ev.weights = None;
        fits.push(got?.x);
    }
    let m = fits.len() as f64;
    Ok((0..x.len())
        .map(|k| {
            let mean = fits.iter().map(|f| f[k]).sum::<f64>() / m;
            (fits.iter().map(|f| (f[k] - mean).powi(2)).sum::<f64>() / (m - 1.0).max(1.0)).sqrt()
        })
        .collect())
}

/// What one photo alone says at the joint optimum (see `split_estimates`).
pub(super) struct Split {
    /// The photo (view).
    pub(super) view: u64,
    /// Per parameter, its Gauss-Newton step -A_v^-1 J_v^T W r_v from the joint optimum on this
    /// photo's residuals alone (None where it does not see the parameter, or its normal matrix is
    /// singular).
    pub(super) step: Vec<Option<f64>>,
    /// Per parameter, the block sandwich variance of this photo's own estimate.
    pub(super) var: Vec<Option<f64>>,
}

/// What each photo says on its own: one Gauss-Newton step from the joint optimum on its
/// residuals alone, and that estimate's own block sandwich variance (`blocks`: each residual's
/// block id, the view in its bits from 40 up, as `Evaluator::residual_blocks` gives them; other
/// residuals, such as the marks', are in no photo's share). At the
/// joint optimum the photos' gradients add up to zero; each alone says where its photo puts the
/// parameters.
pub(super) fn split_estimates(cols: &[Vec<f64>], r: &[f64], wts: &[f64], blocks: &[u64], n_views: usize) -> Vec<Split> {
    let np = cols.len();
    (0..n_views as u64)
        .map(|view| {
            let gw: Vec<f64> = wts
                .iter()
                .zip(blocks)
                .map(|(w, b)| if b >> 40 == view { *w } else { 0.0 })
                .collect();
            let gram = scratchart_optim::least_squares::weighted_gram(cols, &gw);
            let (seen, a) = seen_part(&gram, 1e-9);
            let ns = seen.len();
            let grad = weighted_gradient(seen.iter().map(|&p| &cols[p]), r, &gw);
            let mut step = vec![None; np];
            let mut var = vec![None; np];
            if let Some(d) = solve_spd(&a, &grad) {
                for (i, &p) in seen.iter().enumerate() {
                    step[p] = Some(-d[i]);
                }
            }
            // The sandwich A^-1 B A^-1 over this photo's blocks, B = sum of g_b g_b^T with
            // g_b = sum over block b of w r J (the residuals about the photo's own optimum are
            // r + J step: the step's part is taken off).
            let g = block_scores(cols, &seen, blocks, |i| {
                (blocks[i] >> 40 == view).then(|| {
                    let moved: f64 = seen.iter().map(|&p| cols[p][i] * step[p].unwrap_or(0.0)).sum();
                    wts[i] * (r[i] + moved)
                })
            });
            for (c, &p) in seen.iter().enumerate() {
                let mut e = vec![0.0; ns];
                e[c] = 1.0;
                if let Some(col) = solve_spd(&a, &e) {
                    // (A^-1 B A^-1)_cc = sum over blocks of (A^-1 g_b)_c^2.
                    let v: f64 = g
                        .iter()
                        .map(|gb| gb.iter().zip(&col).map(|(x, y)| x * y).sum::<f64>().powi(2))
                        .sum();
                    var[p] = v.is_finite().then_some(v);
                }
            }
            Split { view, step, var }
        })
        .collect()
}

/// The parameters the residuals see (a diagonal of `gram` above `rel` times its largest: a zero
/// column, such as a profile width above the surface, would make the whole matrix singular),
/// and `gram` over them.
fn seen_part(gram: &[Vec<f64>], rel: f64) -> (Vec<usize>, Vec<Vec<f64>>) {
    let np = gram.len();
    let max_diag = (0..np).map(|i| gram[i][i]).fold(0.0f64, f64::max);
    let seen: Vec<usize> = (0..np).filter(|&i| gram[i][i] > rel * max_diag).collect();
    let part = seen
        .iter()
        .map(|&i| seen.iter().map(|&j| gram[i][j]).collect())
        .collect();
    (seen, part)
}

/// The sandwich's block scores: per block (in the order of their ids), the sum over its
/// residuals i of e(i) J_i over the parameters `seen`; residuals whose `e` is None take no part
/// (nor do blocks with none of them).
fn block_scores(cols: &[Vec<f64>], seen: &[usize], blocks: &[u64], e: impl Fn(usize) -> Option<f64>) -> Vec<Vec<f64>> {
    let es: Vec<Option<f64>> = (0..blocks.len()).map(e).collect();
    let mut ids: Vec<u64> = blocks
        .iter()
        .zip(&es)
        .filter(|(_, e)| e.is_some())
        .map(|(b, _)| *b)
        .collect();
    ids.sort_unstable();
    ids.dedup();
    let mut g = vec![vec![0.0f64; seen.len()]; ids.len()];
    for (i, (b, e)) in blocks.iter().zip(&es).enumerate() {
        let Some(e) = e else { continue };
        let k = ids.binary_search(b).expect("block listed");
        for (a, &p) in seen.iter().enumerate() {
            g[k][a] += e * cols[p][i];
        }
    }
    g
}
