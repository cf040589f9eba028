//! Where the fit starts: the z offset's intervals (a groove appears or vanishes where the offset
//! crosses a ladder depth), start points from a given tool or a search, and the refinement of
//! each start inside its interval.
use super::*;

/// The z offset's range, mm.
const OFFSET_RANGE: (f64, f64) = (-0.3, 0.3);

/// The z offset's intervals: between consecutive thresholds -z_k of the ladder (a groove appears
/// or vanishes where the offset crosses one, so each refinement stays inside one interval).
pub(super) struct OffsetIntervals {
    list: Vec<(f64, f64)>,
}

impl OffsetIntervals {
    pub(super) fn of(card: &Card) -> OffsetIntervals {
        let mut th: Vec<f64> = card.depths_mm.iter().map(|z| -z).collect();
        th.sort_by(|a, b| a.total_cmp(b));
        let mut list: Vec<(f64, f64)> = Vec::new();
        let mut prev = OFFSET_RANGE.0;
        for &t in &th {
            if t > prev {
                list.push((prev, t));
            }
            prev = t;
        }
        list.push((prev, OFFSET_RANGE.1));
        OffsetIntervals { list }
    }

    /// The interval that holds the offset `off` (the whole range where none does).
    fn of_offset(&self, off: f64) -> (f64, f64) {
        self.list
            .iter()
            .copied()
            .find(|(a, b)| off >= *a && off < *b)
            .unwrap_or(OFFSET_RANGE)
    }
}

/// How much the search for start points smooths the photos and the model (pixels).
pub(super) const SEARCH_BLUR_PX: f64 = 1.5;
/// Start points rendered before their exposure searches run side by side (bounds the renders
/// held at once).
const SEARCH_BATCH: usize = 16;
/// The blur a refinement starts from (pixels).
const START_BLUR_PX: f64 = 0.5;

/// Photo v of `data` blurred by `sigma` pixels in linear light (its display values decoded,
/// blurred, encoded again), off-card pixels as they are.
fn smoothed_photo(data: &Data, v: usize, sigma: f64) -> Vec<f32> {
    let c = &data.capture.views[v].camera;
    let (w, h) = (c.width as usize, c.height as usize);
    let lin: Vec<f32> = data.photos[v]
        .iter()
        .map(|d| crate::encoding::decode(*d as f64) as f32)
        .collect();
    crate::simulate::blur(&lin, w, h, sigma)
        .into_iter()
        .map(|l| crate::encoding::encode_f32(l).min(1.0))
        .collect()
}

/// The start point of a tool given (`--init`), where it is of this layout's kind; a profile
/// starts from the widths any tool cuts at the card's depths (a profile's own, a V-bit's).
pub(super) fn start_from(lay: &Layout, tool: &Tool, alpha: Option<f64>, intervals: &OffsetIntervals) -> Option<Start> {
    let mut x = lay.start(tool.z_offset_mm(), (60.0, 0.005));
    let t = lay.tool(&x);
    if matches!(t, Tool::Profile { .. }) {
        let n = lay.depths.len();
        for (k, z) in lay.depths.iter().enumerate() {
            x[k] = tool.section(*z).map_or(0.0, |s| s.width);
        }
        if let Tool::Profile { w_over_w, .. } = tool {
            x[n] = *w_over_w;
        }
        if let Some(a) = alpha {
            x[lay.n_tool] = a;
        }
        return Some((x, None));
    }
    if std::mem::discriminant(&t) == std::mem::discriminant(tool) {
        match tool {
            Tool::VBit {
                angle_deg, tip_flat_mm, ..
            } => {
                x[0] = *angle_deg;
                x[1] = *tip_flat_mm;
            }
            Tool::Ball { radius_mm, .. } => x[0] = *radius_mm,
            Tool::TaperedBall {
                radius_mm, angle_deg, ..
            } => {
                x[0] = *radius_mm;
                x[1] = *angle_deg;
            }
            Tool::Profile { .. } => {} // (a profile layout returned above)
        }
        if let Some(a) = alpha {
            x[lay.n_tool] = a;
        }
        let rg = lay.offset.map(|_| intervals.of_offset(tool.z_offset_mm()));
        return Some((x, rg));
    }
    None
}

/// The search for start points: each offset interval's middle x each typical shape, exposure
/// set per view by a 1-D search (no render); the best two go on to refinement. Coarse, so
/// rendered at the photos' own resolution (a quarter of the refinement's pixels).
pub(super) fn search_starts(
    ev: &mut Evaluator,
    intervals: &OffsetIntervals,
    kind: Kind,
    obs: &dyn Observer,
) -> Result<Vec<Start>, FitError> {
    ev.ss = 1;
    ev.gs = None;
    // Compared smoothed: both the photos and the model through a blur of SEARCH_BLUR_PX more.
    // A sharp photo's grooves are a pixel wide, and a start whose grooves are not quite where
    // the photo's are scores worse than one with no grooves at all (a sharp photo was started
    // with every rung above the plate, its z offset 90 um off).
    ev.compared = Some(
        (0..ev.lay.n_views)
            .map(|v| smoothed_photo(ev.data, v, SEARCH_BLUR_PX))
            .collect(),
    );
    let blur_at = ev.lay.n_tool + 1 + ev.lay.n_views;
    let offs: Vec<Option<(f64, f64)>> = if ev.lay.offset.is_some() {
        intervals
            .list
            .iter()
            .copied()
            .filter(|(a, b)| *a > OFFSET_RANGE.0 && *b < OFFSET_RANGE.1)
            .map(Some)
            .collect()
    } else {
        vec![None]
    };
    let mut scored: Vec<(f64, Vec<f64>, Option<(f64, f64)>)> = Vec::new();
    let total = (offs.len() * ev.lay.shapes().len()) as u64;
    let points: Vec<(Option<(f64, f64)>, Vec<f64>)> = offs
        .iter()
        .flat_map(|rg| ev.lay.shapes().into_iter().map(move |shape| (*rg, shape)))
        .map(|(rg, shape)| {
            let off = rg.map_or(0.0, |(a, b)| 0.5 * (a + b));
            let mut x = ev.lay.start(off, shape);
            for v in 0..ev.lay.n_views {
                x[blur_at + v] = x[blur_at + v].hypot(SEARCH_BLUR_PX);
            }
            (rg, x)
        })
        .collect();
    // A batch of start points rendered one after another, then their exposure searches (no
    // render) side by side on the host's cores, each (start point, view) its own.
    for batch in points.chunks(SEARCH_BATCH) {
        let mut lins = Vec::with_capacity(batch.len());
        for (rg, x) in batch {
            if obs.should_stop() {
                return Err(FitError::Interrupted);
            }
            obs.progress(&Progress::new(
                "search",
                scored.len() as u64 + lins.len() as u64,
                total,
                format!("{} start points", kind.name()),
            ));
            lins.push((ev.render_plain(x)?, *rg));
        }
        let this = &*ev;
        let nv = this.lay.n_views;
        let exposures = scratchart_model::par::par_map(batch.len() * nv, |i| {
            let (s, v) = (i / nv, i % nv);
            this.best_exposure(v, &lins[s].0[v], &batch[s].1)
        });
        let got = scratchart_model::par::par_map(batch.len(), |s| {
            let mut x = batch[s].1.clone();
            for v in 0..nv {
                x[this.lay.n_tool + 1 + v] = exposures[s * nv + v];
            }
            let r = this.residuals_at(&x, &lins[s].0);
            for v in 0..nv {
                x[blur_at + v] = START_BLUR_PX;
            }
            (cauchy(&r, 0.01), x, lins[s].1)
        });
        scored.extend(got);
    }
    obs.finish("search");
    ev.compared = None;
    ev.ss = SUPERSAMPLE;
    ev.gs = None;
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(scored.into_iter().take(2).map(|s| (s.1, s.2)).collect())
}

/// Refines each start point, and where one ends on its offset interval's edge, the next
/// interval too (it may hold the optimum); the best and its interval, and the iterations run.
pub(super) fn refine_starts(
    ev: &mut Evaluator,
    starts: Vec<Start>,
    intervals: &OffsetIntervals,
    kind: Kind,
    cfg: &FitConfig,
    obs: &dyn Observer,
) -> Result<((Solution, Option<(f64, f64)>), u32), FitError> {
    let mut best: Option<(Solution, Option<(f64, f64)>)> = None;
    let mut iterations = 0;
    for (n, (x0, rg)) in starts.into_iter().enumerate() {
        let label = format!("{} start {}", kind.name(), n + 1);
        let got = refine(ev, x0, rg, cfg.iters, obs, &label)?;
        iterations += cfg.iters;
        // The refinement may have ended on its interval's edge: then the next interval may hold
        // the optimum, so it is refined there too.
        let mut cand = vec![(got, rg)];
        if let (Some(i), Some((a, b))) = (ev.lay.offset, rg) {
            let x = &cand[0].0.x;
            let edge = if (x[i] - a).abs() < 2e-4 {
                Some(intervals.of_offset(a - 1e-6))
            } else if (x[i] - b).abs() < 2e-4 {
                Some(intervals.of_offset(b + 1e-6))
            } else {
                None
            };
            if let Some(rg2) = edge.filter(|r| *r != (a, b)) {
                let mut x2 = x.clone();
                x2[i] = 0.5 * (rg2.0 + rg2.1);
                cand.push((refine(ev, x2, Some(rg2), cfg.iters, obs, &label)?, Some(rg2)));
                iterations += cfg.iters;
            }
        }
        for c in cand {
            if best.as_ref().is_none_or(|b| c.0.cost < b.0.cost) {
                best = Some(c);
            }
        }
    }
    // The best refinement, where it used all its iterations, was still gaining (it stops once a
    // step gains under 1e-5 of the loss): it goes on from where it ended. Where the residuals
    // are small (a sharp, noiseless photo) the steps along a narrow valley gain little each:
    // four flash photos of a V 60 ended 0.64 degrees off at 15 iterations, at a higher loss than
    // the truth's, and at 59.95 +- 0.08 after 40 (`docs/fit.md`, "The loss and the noise").
    let (mut sol, rg) = best.expect("at least one start");
    for round in 0..MORE_ROUNDS {
        if sol.iterations < cfg.iters {
            break;
        }
        let label = format!("{} going on ({})", kind.name(), round + 1);
        sol = refine(ev, sol.x, rg, cfg.iters, obs, &label)?;
        iterations += cfg.iters;
    }
    Ok(((sol, rg), iterations))
}

/// How many more times the best refinement goes on where it used all its iterations.
const MORE_ROUNDS: u32 = 3;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::card::CardSpec;

    /// A profile fit given a tool (`--init`) starts from the widths that tool cuts at the card's
    /// depths and, where it is a profile, its w/W: a previous profile fit re-run on new photos
    /// starts where it ended (it started from a typical profile before, whatever was given).
    #[test]
    fn a_profile_starts_from_the_widths_of_the_tool_given() {
        let card = Card::new(&CardSpec::default());
        let lay = Layout::new(Kind::Profile, &card, 2, false, &[false, false], &[false, false], true);
        let intervals = OffsetIntervals::of(&card);
        let n = card.depths_mm.len();
        let v = Tool::VBit {
            angle_deg: 70.0,
            tip_flat_mm: 0.012,
            z_offset_mm: 0.004,
        };
        let profile = crate::study::profile_cut_by(&v, &card, 1.7);
        for (tool, ratio) in [(&v, None), (&profile, Some(1.7))] {
            let (x, rg) = start_from(&lay, tool, Some(0.07), &intervals).expect("a profile starts from any tool");
            assert!(rg.is_none());
            for (k, z) in card.depths_mm.iter().enumerate() {
                let want = v.section(*z).map_or(0.0, |s| s.width);
                assert!((x[k] - want).abs() < 1e-12, "{tool:?} at {z}: {} for {want}", x[k]);
            }
            if let Some(r) = ratio {
                assert_eq!(x[n], r);
            }
            assert_eq!(lay.alpha(&x), 0.07);
            // And the layout reads back the tool it started from.
            if let Tool::Profile { points, .. } = lay.tool(&x) {
                assert!(points.iter().zip(&card.depths_mm).all(|(p, z)| p[0] == *z));
            } else {
                panic!("not a profile");
            }
        }
        // A kind's own layout still takes only its own kind.
        let vlay = Layout::new(Kind::VBit, &card, 2, false, &[false, false], &[false, false], true);
        assert!(start_from(&vlay, &profile, None, &intervals).is_none());
        assert!(start_from(&vlay, &v, None, &intervals).is_some());
    }
}
