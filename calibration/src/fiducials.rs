//! The card's fiducial marks in a photo (see [`scratchart_machine::marks::Mark`];
//! [`crate::register`] uses what is found here).
//!
//! 1. **Candidates.** The marks are bright filled squares on a dark card. A scale space of
//!    differences of Gaussians (scales from 0.4 to 2.5 times the mark's size in the capture view,
//!    factor 1.26 apart) finds bright blobs of any size in that range: a thin lit cut of the
//!    ladder answers a blob-sized kernel far more weakly than a filled square of the same
//!    brightness. Local maxima over position and scale above 4 noise sigmas (the response's MAD)
//!    and above a tenth of the strongest are candidates, the 30 strongest kept.
//! 2. **Which candidate is which mark.** Every ordered triple of candidates is matched to every
//!    triple of marks; the affine map of the triple (a photo taken near a capture view, turned by
//!    any angle, is near-affine over the card) must keep orientation (a camera does not mirror)
//!    and be of plausible scale and shear. The hypothesis whose map brings the most other marks
//!    within a mark's size of a candidate wins (ties: the stronger candidates). The marks are laid
//!    out so that no rotation maps the card onto itself, so the winner also fixes the
//!    orientation. This is a robust fit: a covered mark, a stray glint, a dust speck or a
//!    wrongly placed candidate does not enter it, where taking the first four found would.
//! 3. **The homography** of the plate to the photo is then fitted to the matched marks (at
//!    least 4, least squares), the marks are re-matched through it with a tighter tolerance, and
//!    refitted, three times.
//! 4. **Centres.** Each matched mark's centre is the centroid of its light above the local level
//!    (the median of a ring around it) over its square as the homography projects it, widened by
//!    the blur; the centroid of a uniformly lit projected square differs from the projection of
//!    its centre (perspective), and that known difference is taken off.
//!
//! Each mark found gets a confidence in [0, 1]: its contrast against the photo's noise and its
//! distance from where the homography of the other marks puts it.
use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::View;

use super::card::Card;
use super::photo::{median, pixel_noise, Gray};

mod blobs;
pub(crate) mod homography;
use blobs::{blobs, Blob};
use homography::affine3;
pub use homography::{apply, homography_lsq};

/// Where the card's marks appear in view `view` (image points, in `card.marks` order) and the
/// side of a mark there, pixels (the mean over marks).
pub fn nominal_marks(card: &Card, view: &View) -> (Vec<[f64; 2]>, f64) {
    let g = ViewGeom::new(view);
    let mut side = 0.0;
    let pts = card
        .marks
        .iter()
        .map(|m| {
            let (sx, sy) = g
                .project([m.centre[0], m.centre[1], 0.0])
                .unwrap_or((f64::NAN, f64::NAN));
            let corner = |dx: f64, dy: f64| {
                g.project([m.centre[0] + dx * m.half_mm, m.centre[1] + dy * m.half_mm, 0.0])
                    .unwrap_or((f64::NAN, f64::NAN))
            };
            let (a, b) = (corner(-1.0, -1.0), corner(1.0, 1.0));
            let (c, d) = (corner(1.0, -1.0), corner(-1.0, 1.0));
            side += 0.5 * ((a.0 - b.0).hypot(a.1 - b.1) + (c.0 - d.0).hypot(c.1 - d.1)) / 2f64.sqrt();
            [sx, sy]
        })
        .collect();
    (pts, side / card.marks.len().max(1) as f64)
}

/// What was found of the card's marks in a photo.
#[derive(Clone, Debug)]
pub struct Found {
    /// Per mark of the card (its order): the centre in the photo, or `None` (covered, not lit).
    pub points: Vec<Option<[f64; 2]>>,
    /// Per mark: how sure the detection is, 0 (not found) to 1.
    pub confidence: Vec<f64>,
    /// The homography from plate points (mm) to the photo's image points.
    pub plate_to_image: [f64; 9],
    /// RMS distance of the found centres from the homography's projections, pixels.
    pub rms_px: f64,
    /// How many candidates the photo offered.
    pub candidates: usize,
}

impl Found {
    pub fn count(&self) -> usize {
        self.points.iter().flatten().count()
    }
}

/// Finds the card's marks in `img`, a photo of view `view` (any size: the capture view's
/// image points are taken about the photo's centre, in proportion to its height).
pub fn find_marks(img: &Gray, card: &Card, view: &View) -> Result<Found, String> {
    let (w, h) = (img.width as f64, img.height as f64);
    let (nominal, side) = nominal_marks(card, view);
    // The capture view's points on this photo's raster (same height scale, centred).
    let k = h / view.camera.height as f64;
    let (cw, ch) = (view.camera.width as f64, view.camera.height as f64);
    let nom: Vec<[f64; 2]> = nominal
        .iter()
        .map(|p| [0.5 * w + k * (p[0] - 0.5 * cw), 0.5 * h + k * (p[1] - 0.5 * ch)])
        .collect();
    let side = side * k;
    if !(side > 1.5) {
        return Err(format!(
            "the photo is too small to show the card's marks ({side:.1} px across at this size)"
        ));
    }
    // A filled square of side a answers a difference of Gaussians most at sigma ~ 0.4 a.
    let mut cands = blobs(img, (0.4 * 0.4 * side).max(0.8), 0.4 * 2.5 * side);
    let n_blobs = cands.len();
    cands.truncate(30);
    let m = card.marks.len();
    if cands.len() < 4 {
        return Err(format!(
            "{} bright mark(s) found where the card's {m} hatched marks should glint",
            cands.len()
        ));
    }
    // Hypotheses: triples of marks x ordered triples of candidates, by affine maps, scored by
    // how many other marks they bring near a candidate of the right size (each counted by its
    // closeness); the best go on to a homography.
    // Four points fit any homography exactly, so four marks prove nothing: at least five must
    // agree (a card of four marks, the first cards' crosses, can only ask for four).
    let need = m.min(5);
    let mut hyps = affine_hypotheses(&nom, &cands, side, need);
    if hyps.is_empty() {
        return Err(format!(
            "no {need} of the {n_blobs} bright spots found lie as the card's {m} marks do"
        ));
    }
    hyps.sort_by(|x, y| y.0.total_cmp(&x.0));
    let plate: Vec<[f64; 2]> = card.marks.iter().map(|mk| mk.centre).collect();
    // Each of the best hypotheses refined through homographies (matches from the plate, closer
    // each round); the one with the most marks, then the smallest misfit, wins.
    let noise = pixel_noise(img).max(0.5 / 255.0);
    let mut best: Option<Candidate> = None;
    for (_, _, af) in hyps.iter().take(40) {
        let Some(c) = refine_hypothesis(img, card, view, af, &cands, &plate, &nom, side, need, noise) else {
            continue;
        };
        if best.as_ref().is_none_or(|b| c.0 > b.0 || (c.0 == b.0 && c.1 < b.1)) {
            best = Some(c);
        }
    }
    let Some((_, rms_px, points, contrast, scale)) = best else {
        return Err(format!(
            "no {need} of the {n_blobs} bright spots found fit one view of the flat card's {m} marks \
             from near capture view {}",
            view.name
        ));
    };
    let pairs: Vec<(usize, [f64; 2], [f64; 2])> = points
        .iter()
        .enumerate()
        .filter_map(|(q, p)| p.map(|p| (q, plate[q], p)))
        .collect();
    let (s, d): (Vec<[f64; 2]>, Vec<[f64; 2]>) = pairs.iter().map(|x| (x.1, x.2)).unzip();
    let hm = homography_lsq(&s, &d).ok_or("the marks found are degenerate (collinear)")?;
    let confidence = confidences(&pairs, need, rms_px, &contrast, noise, side * scale, m);
    Ok(Found {
        points,
        confidence,
        plate_to_image: hm,
        rms_px,
        candidates: n_blobs,
    })
}

/// Hypotheses of which blob is which mark: every triple of marks (at `nom`, their capture-view
/// places on this photo) x every ordered triple of candidate blobs, by the affine map between
/// them, kept where it keeps orientation, is of plausible scale and shear, and brings at least
/// `need` marks near a blob of the right size; each with its score (how close those are), how
/// many, and the map.
fn affine_hypotheses(nom: &[[f64; 2]], cands: &[Blob], side: f64, need: usize) -> Vec<(f64, usize, [f64; 6])> {
    let mut hyps: Vec<(f64, usize, [f64; 6])> = Vec::new();
    let (m, nc) = (nom.len(), cands.len());
    let tol = 0.7 * side;
    for i in 0..m {
        for j in i + 1..m {
            for l in j + 1..m {
                let src = [nom[i], nom[j], nom[l]];
                for a in 0..nc {
                    for b in 0..nc {
                        if b == a {
                            continue;
                        }
                        for c in 0..nc {
                            if c == a || c == b {
                                continue;
                            }
                            let Some(af) = affine3(src, [cands[a].at, cands[b].at, cands[c].at]) else {
                                continue;
                            };
                            // Orientation kept, scale 0.3-3, shear and foreshortening below 2.5:1.
                            let det = af[0] * af[4] - af[1] * af[3];
                            if !(det > 0.09 && det < 9.0) {
                                continue;
                            }
                            let fro = af[0] * af[0] + af[1] * af[1] + af[3] * af[3] + af[4] * af[4];
                            // Ratio of singular values s1/s2 from fro = s1^2 + s2^2, det = s1 s2.
                            let disc = (fro * fro - 4.0 * det * det).max(0.0).sqrt();
                            let ratio = ((fro + disc) / (fro - disc).max(1e-12)).sqrt();
                            if ratio > 2.5 {
                                continue;
                            }
                            let scale = det.sqrt();
                            // Blob sizes roughly agree with the map's scale (a mark's blob answers
                            // at about 0.4 of its side; blur, the card's glow and the coarse scale
                            // steps move that, so only what is far off is left out).
                            let fits_size = |b: &Blob| {
                                let s = b.sigma / (0.4 * side * scale);
                                (0.25..4.0).contains(&s)
                            };
                            if !(fits_size(&cands[a]) && fits_size(&cands[b]) && fits_size(&cands[c])) {
                                continue;
                            }
                            let (mut count, mut score) = (3, 3.0);
                            for (q, p) in nom.iter().enumerate() {
                                if q == i || q == j || q == l {
                                    continue;
                                }
                                let pr = [af[0] * p[0] + af[1] * p[1] + af[2], af[3] * p[0] + af[4] * p[1] + af[5]];
                                let t = tol * scale;
                                let near = cands
                                    .iter()
                                    .enumerate()
                                    .filter(|(z, bl)| *z != a && *z != b && *z != c && fits_size(bl))
                                    .map(|(_, bl)| (bl.at[0] - pr[0]).hypot(bl.at[1] - pr[1]))
                                    .filter(|d| *d < t)
                                    .fold(f64::INFINITY, f64::min);
                                if near.is_finite() {
                                    count += 1;
                                    score += 1.0 - (near / t).powi(2);
                                }
                            }
                            if count >= need {
                                hyps.push((score, count, af));
                            }
                        }
                    }
                }
            }
        }
    }
    hyps
}

/// Each of the card's marks (at `plate`) matched to the nearest unused candidate within `t`
/// pixels of where the homography `hm` puts it.
fn rematch(plate: &[[f64; 2]], cands: &[Blob], hm: &[f64; 9], t: f64) -> Vec<Option<usize>> {
    let nc = cands.len();
    let mut used = vec![false; nc];
    plate
        .iter()
        .map(|p| {
            let pr = apply(hm, *p);
            let got = (0..nc)
                .filter(|&z| !used[z])
                .map(|z| (z, (cands[z].at[0] - pr[0]).hypot(cands[z].at[1] - pr[1])))
                .filter(|(_, d)| *d < t)
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .map(|(z, _)| z);
            if let Some(z) = got {
                used[z] = true;
            }
            got
        })
        .collect()
}

/// A hypothesis refined: the marks found, their misfit to one homography (px rms), the
/// sub-pixel centres, each mark's contrast, and the map's scale.
type Candidate = (usize, f64, Vec<Option<[f64; 2]>>, Vec<f64>, f64);

/// One affine hypothesis `af` refined through homographies (matches from the plate, closer each
/// round), its marks' sub-pixel centres found, outliers dropped, and the camera checked; None
/// where fewer than `need` marks remain, they misfit one homography, or no camera near the
/// capture view could have taken them.
#[allow(clippy::too_many_arguments)]
fn refine_hypothesis(
    img: &Gray,
    card: &Card,
    view: &View,
    af: &[f64; 6],
    cands: &[Blob],
    plate: &[[f64; 2]],
    nom: &[[f64; 2]],
    side: f64,
    need: usize,
    noise: f64,
) -> Option<Candidate> {
    let tol = 0.7 * side;
    let scale = (af[0] * af[4] - af[1] * af[3]).sqrt();
    let map = |p: [f64; 2]| [af[0] * p[0] + af[1] * p[1] + af[2], af[3] * p[0] + af[4] * p[1] + af[5]];
    // Start: the affine map from the plate through the capture view's points.
    let (s0, d0): (Vec<[f64; 2]>, Vec<[f64; 2]>) = plate.iter().zip(nom).map(|(p, n)| (*p, map(*n))).unzip();
    let mut hm = homography_lsq(&s0, &d0)?;
    let mut assign = rematch(plate, cands, &hm, tol * scale);
    let mut ok = true;
    for t in [0.5, 0.3, 0.3] {
        let (s, d): (Vec<[f64; 2]>, Vec<[f64; 2]>) = assign
            .iter()
            .enumerate()
            .filter_map(|(q, z)| z.map(|z| (plate[q], cands[z].at)))
            .unzip();
        match homography_lsq(&s, &d) {
            Some(h) => hm = h,
            None => {
                ok = false;
                break;
            }
        }
        assign = rematch(plate, cands, &hm, t * side * scale);
    }
    if !ok || assign.iter().flatten().count() < need {
        return None;
    }
    // Sub-pixel centres of the matched marks; a mark no brighter than its surroundings is
    // not there (covered, or a spot beside it).
    let (mut points, contrast) = centres(img, card, &hm, &assign, noise);
    // Outliers: while a centre lies off the homography of the others (a glint beside a
    // covered mark, a stray spot), the worst goes, down to `need`.
    loop {
        let pairs: Vec<(usize, [f64; 2], [f64; 2])> = points
            .iter()
            .enumerate()
            .filter_map(|(q, p)| p.map(|p| (q, plate[q], p)))
            .collect();
        if pairs.len() <= need {
            break;
        }
        let worst = pairs
            .iter()
            .map(|(q, p, c)| (*q, loo_error(&pairs, *q, *p, *c)))
            .max_by(|x, y| x.1.total_cmp(&y.1))
            .expect("pairs");
        if worst.1 <= (0.15 * side * scale).max(1.5) {
            break;
        }
        points[worst.0] = None;
    }
    let (s, d): (Vec<[f64; 2]>, Vec<[f64; 2]>) = points
        .iter()
        .enumerate()
        .filter_map(|(q, p)| p.map(|p| (plate[q], p)))
        .unzip();
    let n = s.len();
    if n < need {
        return None;
    }
    let h2 = homography_lsq(&s, &d)?;
    // Only a camera looking at the card from near the capture view can have taken it.
    if plausible_camera(&h2, img.width, img.height, view).is_err() {
        return None;
    }
    let misfit = (s
        .iter()
        .zip(&d)
        .map(|(p, c)| {
            let pr = apply(&h2, *p);
            (pr[0] - c[0]).powi(2) + (pr[1] - c[1]).powi(2)
        })
        .sum::<f64>()
        / n as f64)
        .sqrt();
    // The marks' centres fit one homography to about a tenth of a pixel (measured over 160
    // random phone views, `examples/detect_probe`: at most 0.07 px rms with five marks,
    // 0.11 px with six); five spots of something else that happen to lie near the pattern
    // fit to half a pixel and more (0.58 px on a circuit board). Not caught: four marks and
    // one stray spot near a covered mark's place (0.05 and 0.12 px in 2 of 40 views: five
    // marks of this card, two keys on the lines of two corners, constrain the fifth little).
    if misfit > (0.03 * side * scale).max(0.25) {
        return None;
    }
    Some((n, misfit, points, contrast, scale))
}

/// Each mark's confidence: its contrast against the noise, and its agreement with the other
/// marks' homography (with only `need` marks, four of the others can be nearly collinear, so
/// the misfit of all of them to one homography is used).
fn confidences(
    pairs: &[(usize, [f64; 2], [f64; 2])],
    need: usize,
    rms_px: f64,
    contrast: &[f64],
    noise: f64,
    side_px: f64,
    m: usize,
) -> Vec<f64> {
    let mut confidence = vec![0.0; m];
    for &(q, p, c) in pairs {
        // Agreement: where the others put it. With only `need` marks, four of the others can
        // be nearly collinear (a key lies on the line of two corners) and their homography
        // says little of the fifth: the misfit of all of them to one homography is used.
        let off = if pairs.len() > need {
            loo_error(pairs, q, p, c)
        } else {
            rms_px
        };
        let snr = contrast[q] / noise;
        confidence[q] = (1.0 - (-snr / 2.0).exp()) * (-(off / (0.15 * side_px).max(1.0)).powi(2)).exp();
    }
    confidence
}

/// The centres of the marks matched in `assign` (by candidate; the card's order): the centroid
/// of each mark's light above the local level (the median of a ring around it) over its square
/// as the homography `hm` projects it, widened by the blur, less the perspective bias of a
/// uniformly lit projected square's centroid. Marks no brighter than their ring by half the
/// pixel noise are `None`. Also each mark's mean contrast.
fn centres(
    img: &Gray,
    card: &Card,
    hm: &[f64; 9],
    assign: &[Option<usize>],
    noise: f64,
) -> (Vec<Option<[f64; 2]>>, Vec<f64>) {
    let m = card.marks.len();
    let (wi, hi) = (img.width as usize, img.height as usize);
    let mut points: Vec<Option<[f64; 2]>> = vec![None; m];
    let mut contrast = vec![0.0f64; m];
    for (q, z) in assign.iter().enumerate() {
        if z.is_none() {
            continue;
        }
        let mk = &card.marks[q];
        let corners: Vec<[f64; 2]> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|(sx, sy)| apply(hm, [mk.centre[0] + sx * mk.half_mm, mk.centre[1] + sy * mk.half_mm]))
            .collect();
        let centre = apply(hm, mk.centre);
        let (mut ax, mut ay, mut aa) = (0.0, 0.0, 0.0);
        for e in 0..4 {
            let (p, r) = (corners[e], corners[(e + 1) % 4]);
            let cr = p[0] * r[1] - r[0] * p[1];
            aa += cr;
            ax += (p[0] + r[0]) * cr;
            ay += (p[1] + r[1]) * cr;
        }
        let bias = [ax / (3.0 * aa) - centre[0], ay / (3.0 * aa) - centre[1]];
        let half_px = 0.5 * (0.5 * aa.abs()).sqrt();
        let pad = (0.5 * half_px).max(2.0);
        let (r_in, r_out) = (half_px * 2f64.sqrt() + pad, half_px * 2f64.sqrt() + 2.0 * pad + 2.0);
        let mut c = centre;
        let mut ok = true;
        for _ in 0..3 {
            let (x0, x1) = (
                (c[0] - r_out).floor().max(0.0) as usize,
                ((c[0] + r_out).ceil().max(0.0) as usize).min(wi),
            );
            let (y0, y1) = (
                (c[1] - r_out).floor().max(0.0) as usize,
                ((c[1] + r_out).ceil().max(0.0) as usize).min(hi),
            );
            let mut ring = Vec::new();
            let mut inside = Vec::new();
            for y in y0..y1 {
                for x in x0..x1 {
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    let (dx, dy) = ((px - c[0]).abs(), (py - c[1]).abs());
                    let v = img.data[y * wi + x];
                    if dx.max(dy) <= half_px + pad {
                        inside.push((px, py, v));
                    } else if dx.hypot(dy) >= r_in && dx.hypot(dy) <= r_out {
                        ring.push(v);
                    }
                }
            }
            if inside.is_empty() || ring.is_empty() {
                ok = false;
                break;
            }
            let level = median(&mut ring);
            contrast[q] = inside.iter().map(|p| (p.2 - level) as f64).sum::<f64>() / inside.len() as f64;
            let (mut sw, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
            for (px, py, v) in &inside {
                let wt = (v - level).max(0.0) as f64;
                sw += wt;
                sx += wt * px;
                sy += wt * py;
            }
            if sw <= 0.0 {
                ok = false;
                break;
            }
            let next = [sx / sw - bias[0], sy / sw - bias[1]];
            if (next[0] - centre[0]).hypot(next[1] - centre[1]) > half_px + pad {
                ok = false;
                break;
            }
            c = next;
        }
        if ok && contrast[q] > 0.5 * noise {
            points[q] = Some(c);
        }
    }
    (points, contrast)
}

/// How far the found point `c` of mark `q` (plate point `p`) lies from where the homography of
/// the other pairs puts it, pixels.
fn loo_error(pairs: &[(usize, [f64; 2], [f64; 2])], q: usize, p: [f64; 2], c: [f64; 2]) -> f64 {
    let (s2, d2): (Vec<[f64; 2]>, Vec<[f64; 2]>) = pairs.iter().filter(|x| x.0 != q).map(|x| (x.1, x.2)).unzip();
    homography_lsq(&s2, &d2).map_or(f64::INFINITY, |h2| {
        let pr = apply(&h2, p);
        (pr[0] - c[0]).hypot(pr[1] - c[1])
    })
}

/// Whether the homography `hm` from plate points to the image points of a `w` x `h` photo is
/// that of a camera near capture view `view`: a camera (square pixels, centred principal point)
/// above the card, its direction from the card within 35 degrees of the capture view's, its
/// distance within a factor 1.6 of it and its field of view within a factor 3. Says what is
/// wrong otherwise.
pub fn plausible_camera(hm: &[f64; 9], w: u32, h: u32, view: &View) -> Result<scratchart_model::scene::Camera, String> {
    plausible_camera_with_focal(hm, w, h, view, None)
}

/// [`plausible_camera`] with the focal length the photo's EXIF gives (pixels of this raster),
/// taken where it lies within 20% of the one the marks imply (a photo cropped after it was
/// taken keeps its EXIF but not its frame: its EXIF focal length is then ignored).
pub fn plausible_camera_with_focal(
    hm: &[f64; 9],
    w: u32,
    h: u32,
    view: &View,
    exif_focal_px: Option<f64>,
) -> Result<scratchart_model::scene::Camera, String> {
    let c = &view.camera;
    // The capture view's focal length on this photo's raster (same height scale).
    let f_hint = 0.5 * h as f64 / (0.5 * c.fov_y_deg).to_radians().tan();
    let e = c.eye;
    let d_hint = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    let f_marks = super::pose::focal_near(hm, w, h, f_hint, d_hint);
    let f = match exif_focal_px {
        Some(fe) if fe > 0.0 && (fe / f_marks - 1.0).abs() < 0.2 => fe,
        _ => f_marks,
    };
    let cam = super::pose::camera_with_focal(hm, w, h, f)
        .ok_or("the marks do not lie as a camera above the card would see them")?;
    let dir = |e: [f64; 3], t: [f64; 3]| {
        let d = [e[0] - t[0], e[1] - t[1], e[2] - t[2]];
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        ([d[0] / l, d[1] / l, d[2] / l], l)
    };
    let (d0, l0) = dir(c.eye, [0.0; 3]);
    let (d1, l1) = dir(cam.eye, [0.0; 3]);
    let angle = (d0[0] * d1[0] + d0[1] * d1[1] + d0[2] * d1[2])
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees();
    if angle > 35.0 {
        return Err(format!(
            "the camera would have been {angle:.0} degrees away from the capture view's direction (at most 35)"
        ));
    }
    if !(l1 / l0 > 1.0 / 1.6 && l1 / l0 < 1.6) {
        return Err(format!(
            "the camera would have been {l1:.0} mm from the card where the capture view is {l0:.0} mm"
        ));
    }
    let t = |fov: f64| (0.5 * fov).to_radians().tan();
    let fr = t(cam.fov_y_deg) / t(c.fov_y_deg) * c.height as f64 / h as f64;
    if !(fr > 1.0 / 3.0 && fr < 3.0) {
        return Err(format!(
            "the camera's field of view would have been {:.0} degrees (the capture view's is {:.0})",
            cam.fov_y_deg, c.fov_y_deg
        ));
    }
    Ok(cam)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_squares_homography_maps_the_points() {
        let h0 = [1.2, 0.1, 30.0, -0.05, 0.9, 12.0, 1e-4, -2e-4, 1.0];
        let src = [
            [0.0, 0.0],
            [100.0, 5.0],
            [95.0, 80.0],
            [-3.0, 90.0],
            [50.0, 40.0],
            [20.0, 70.0],
        ];
        let dst: Vec<[f64; 2]> = src.iter().map(|p| apply(&h0, *p)).collect();
        let h = homography_lsq(&src, &dst).unwrap();
        for (p, q) in src.iter().zip(&dst) {
            let r = apply(&h, *p);
            assert!(
                (r[0] - q[0]).abs() < 1e-7 && (r[1] - q[1]).abs() < 1e-7,
                "{r:?} vs {q:?}"
            );
        }
        // Collinear points have none.
        let line = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
        assert!(homography_lsq(&line, &line.map(|p| [p[0] + 1.0, p[1]])).is_none());
    }

    #[test]
    fn a_blob_is_found_at_its_centre_and_size() {
        let (w, h) = (96u32, 80u32);
        let mut data = vec![0.05f32; (w * h) as usize];
        for y in 30..40 {
            for x in 50..60 {
                data[(y * w + x) as usize] = 0.8;
            }
        }
        let img = Gray {
            width: w,
            height: h,
            data,
        };
        let b = blobs(&img, 1.5, 10.0);
        assert!(!b.is_empty());
        let top = b[0];
        assert!(
            (top.at[0] - 55.0).abs() < 0.6 && (top.at[1] - 35.0).abs() < 0.6,
            "{top:?}"
        );
        assert!(top.sigma > 2.5 && top.sigma < 6.5, "{top:?}");
    }
}
