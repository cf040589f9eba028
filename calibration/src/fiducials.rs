//! The card's four corner crosses in a photo (see [`crate::register`] for how they are used):
//!
//! 1. Bright marks: the image is smoothed (Gaussian, 1 px) and its white top-hat taken (less its
//!    opening by a 7 x 7 square: thin bright cuts stay, the plate's glow and its edges go); the
//!    noise is estimated robustly (median, MAD), and connected pixels above both 5 noise sigmas
//!    and 3% of the brightest mark form marks (at least 2.5 arm lengths of pixels each).
//!    Marks that are not point-symmetric (the corner of the card's glow, stray light) are dropped.
//! 2. Corners: the mark nearest each cross's place in the capture view, within a tenth of the
//!    frame (a photo taken near the capture pose); failing that, the crosses are the card's
//!    outermost marks, so for each diagonal direction the mark farthest along it is taken, and
//!    matched to the fiducial the capture view shows in that direction (a photo may be turned by
//!    less than 45 degrees).
//! 3. Centres: the centroid of the top-hat above its local level (the median in a ring around
//!    the cross) over a disc of 1.15 arm lengths, iterated (no threshold, so no truncation bias),
//!    then the intersection of the two arms' fitted lines: a brightness gradient along an arm
//!    moves its centroid along its line, not the line. About 0.3 px on simulated photos.
use scratchart::model::camera::ViewGeom;
use scratchart::model::scene::View;

use super::card::{Card, CutRole};
use super::photo::Gray;

/// Where the card's four fiducial crosses appear in capture view `view` (image points), in the
/// card's order, and half the length of a cross's arm there, pixels.
pub fn nominal_fiducials(card: &Card, view: &View) -> ([[f64; 2]; 4], f64) {
    let g = ViewGeom::new(view);
    let fid: Vec<_> = card.cuts.iter().filter(|c| c.role == CutRole::Fiducial).collect();
    let mut out = [[0.0; 2]; 4];
    let mut arm = 0.0f64;
    for (k, pair) in fid.chunks(2).take(4).enumerate() {
        let c = pair[0];
        let centre = [0.5 * (c.p0[0] + c.p1[0]), 0.5 * (c.p0[1] + c.p1[1]), 0.0];
        let (sx, sy) = g.project(centre).unwrap_or((f64::NAN, f64::NAN));
        out[k] = [sx, sy];
        for cut in pair {
            if let (Some(a), Some(b)) = (
                g.project([cut.p0[0], cut.p0[1], 0.0]),
                g.project([cut.p1[0], cut.p1[1], 0.0]),
            ) {
                arm = arm.max(0.5 * (a.0 - b.0).hypot(a.1 - b.1));
            }
        }
    }
    (out, arm)
}

/// The image directions of the two arms of each fiducial cross in capture view `view` (unit
/// vectors, in the card's order).
pub fn arm_directions(card: &Card, view: &View) -> [[[f64; 2]; 2]; 4] {
    let g = ViewGeom::new(view);
    let fid: Vec<_> = card.cuts.iter().filter(|c| c.role == CutRole::Fiducial).collect();
    let mut out = [[[1.0, 0.0], [0.0, 1.0]]; 4];
    for (k, pair) in fid.chunks(2).take(4).enumerate() {
        for (a, cut) in pair.iter().enumerate() {
            if let (Some(p), Some(q)) = (
                g.project([cut.p0[0], cut.p0[1], 0.0]),
                g.project([cut.p1[0], cut.p1[1], 0.0]),
            ) {
                let l = (q.0 - p.0).hypot(q.1 - p.1).max(1e-12);
                out[k][a] = [(q.0 - p.0) / l, (q.1 - p.1) / l];
            }
        }
    }
    out
}

fn median(v: &mut [f32]) -> f32 {
    let n = v.len();
    *v.select_nth_unstable_by(n / 2, |a, b| a.total_cmp(b)).1
}

/// Gaussian smoothing with sigma 1 px (5-tap binomial-like kernel), clamped edges.
fn smooth(img: &Gray) -> Gray {
    let k = [0.054, 0.244, 0.403, 0.244, 0.054];
    let (w, h) = (img.width as i64, img.height as i64);
    let mut tmp = vec![0f32; img.data.len()];
    for y in 0..h {
        for x in 0..w {
            let s: f32 = (0..5).map(|i| k[i] * img.at(x + i as i64 - 2, y)).sum();
            tmp[(y * w + x) as usize] = s;
        }
    }
    let t = Gray {
        width: img.width,
        height: img.height,
        data: tmp,
    };
    let mut out = vec![0f32; img.data.len()];
    for y in 0..h {
        for x in 0..w {
            out[(y * w + x) as usize] = (0..5).map(|i| k[i] * t.at(x, y + i as i64 - 2)).sum();
        }
    }
    Gray {
        width: img.width,
        height: img.height,
        data: out,
    }
}

/// Separable square min or max filter of radius `r` (clamped edges).
fn filter(img: &Gray, r: i64, f: fn(f32, f32) -> f32) -> Gray {
    let (w, h) = (img.width as i64, img.height as i64);
    let mut tmp = vec![0f32; img.data.len()];
    for y in 0..h {
        for x in 0..w {
            tmp[(y * w + x) as usize] = (-r..=r).map(|o| img.at(x + o, y)).reduce(f).unwrap();
        }
    }
    let t = Gray {
        width: img.width,
        height: img.height,
        data: tmp,
    };
    let mut out = vec![0f32; img.data.len()];
    for y in 0..h {
        for x in 0..w {
            out[(y * w + x) as usize] = (-r..=r).map(|o| t.at(x, y + o)).reduce(f).unwrap();
        }
    }
    Gray {
        width: img.width,
        height: img.height,
        data: out,
    }
}

/// Finds the four corner crosses in `img` (already at the capture view's size): image points in
/// the order of `nominal` (the capture view's), `arm` the arm's half length there, px.
pub fn find_fiducials(
    img: &Gray,
    nominal: &[[f64; 2]; 4],
    dirs: &[[[f64; 2]; 2]; 4],
    arm: f64,
) -> Result<[[f64; 2]; 4], String> {
    let sm = smooth(img);
    // White top-hat: the smoothed image less its opening by a 7 x 7 square, which keeps thin
    // bright lines (the cuts) and removes the plate's even glow and the steps at its edges.
    let open = filter(&filter(&sm, 3, f32::min), 3, f32::max);
    let s = Gray {
        width: sm.width,
        height: sm.height,
        data: sm.data.iter().zip(&open.data).map(|(a, b)| a - b).collect(),
    };
    let (w, h) = (s.width as usize, s.height as usize);
    let bg = median(&mut s.data.clone());
    let mut dev: Vec<f32> = s.data.iter().map(|v| (v - bg).abs()).collect();
    let sigma = 1.4826 * median(&mut dev);
    let peak = s.data.iter().cloned().fold(bg, f32::max);
    let thr = bg + (5.0 * sigma).max(0.03 * (peak - bg));
    if !(peak - bg > 5.0 * sigma.max(1e-4)) {
        return Err("no bright marks at all: the photo is uniform (is the lamp on, and the card in view?)".into());
    }
    // Connected marks (4-neighbour flood fill).
    let mut label = vec![u32::MAX; w * h];
    let mut marks: Vec<([f64; 2], usize)> = Vec::new();
    for start in 0..w * h {
        if label[start] != u32::MAX || s.data[start] <= thr {
            continue;
        }
        let id = marks.len() as u32;
        let mut stack = vec![start];
        label[start] = id;
        let (mut sw, mut sx, mut sy, mut n) = (0.0f64, 0.0f64, 0.0f64, 0usize);
        while let Some(p) = stack.pop() {
            let (x, y) = (p % w, p / w);
            let wt = (s.data[p] - bg) as f64;
            sw += wt;
            sx += wt * (x as f64 + 0.5);
            sy += wt * (y as f64 + 0.5);
            n += 1;
            let mut push = |q: usize| {
                if label[q] == u32::MAX && s.data[q] > thr {
                    label[q] = id;
                    stack.push(q);
                }
            };
            if x > 0 {
                push(p - 1);
            }
            if x + 1 < w {
                push(p + 1);
            }
            if y > 0 {
                push(p - w);
            }
            if y + 1 < h {
                push(p + w);
            }
        }
        marks.push(([sx / sw, sy / sw], n));
    }
    // A cross shows at least one whole arm: 2.5 arm lengths of pixels (one arm of two
    // arm lengths, over a pixel wide after smoothing).
    marks.retain(|m| m.1 as f64 >= (2.5 * arm).max(3.0));
    // Crosses are point-symmetric about their centre; the corner of the card's glow (an L where
    // two edges meet) and other stray marks are not: keep marks whose top-hat, mirrored through
    // their centroid, overlaps itself by at least 40%.
    let rad = (1.15 * arm).max(3.0);
    let value = |x: f64, y: f64| -> f32 {
        let (xi, yi) = (x.floor() as i64, y.floor() as i64);
        if xi < 0 || yi < 0 || xi >= w as i64 || yi >= h as i64 {
            0.0
        } else {
            s.data[yi as usize * w + xi as usize]
        }
    };
    marks.retain(|m| {
        let c = m.0;
        let (mut both, mut all) = (0.0f64, 0.0f64);
        let n = rad.ceil() as i64;
        for dy in -n..=n {
            for dx in -n..=n {
                let (ox, oy) = (dx as f64, dy as f64);
                if ox.hypot(oy) > rad {
                    continue;
                }
                let a = (value(c[0] + ox, c[1] + oy) - thr).max(0.0) as f64;
                let b = (value(c[0] - ox, c[1] - oy) - thr).max(0.0) as f64;
                both += a.min(b);
                all += a;
            }
        }
        all > 0.0 && both >= 0.4 * all
    });
    if std::env::var_os("SCRATCHART_DEBUG_MARKS").is_some() {
        eprintln!("marks (centroid, pixels): {marks:?}");
    }
    if marks.len() < 4 {
        return Err(format!(
            "found {} bright mark(s), expected at least the 4 corner crosses",
            marks.len()
        ));
    }
    // The corner-most mark along each nominal fiducial's diagonal.
    let cn = [
        0.25 * nominal.iter().map(|p| p[0]).sum::<f64>(),
        0.25 * nominal.iter().map(|p| p[1]).sum::<f64>(),
    ];
    let (lo, hi) = marks.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), m| {
        (
            [lo[0].min(m.0[0]), lo[1].min(m.0[1])],
            [hi[0].max(m.0[0]), hi[1].max(m.0[1])],
        )
    });
    let cf = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let mut found = [[0.0; 2]; 4];
    let mut levels = [0f32; 4];
    for k in 0..4 {
        let d = [(nominal[k][0] - cn[0]).signum(), (nominal[k][1] - cn[1]).signum()];
        // A photo near the capture pose has the cross near its nominal place: the nearest mark
        // within a tenth of the frame; otherwise the corner-most mark along the diagonal.
        let near = 0.1 * w.min(h) as f64;
        let dist = |m: &([f64; 2], usize)| (m.0[0] - nominal[k][0]).hypot(m.0[1] - nominal[k][1]);
        let best = marks
            .iter()
            .filter(|m| dist(m) <= near)
            .min_by(|a, b| dist(a).total_cmp(&dist(b)))
            .or_else(|| {
                marks.iter().max_by(|a, b| {
                    let fa = d[0] * (a.0[0] - cf[0]) + d[1] * (a.0[1] - cf[1]);
                    let fb = d[0] * (b.0[0] - cf[0]) + d[1] * (b.0[1] - cf[1]);
                    fa.total_cmp(&fb)
                })
            })
            .expect("at least 4 marks");
        // Refine: centroid of the top-hat above its local level (the median in a ring around
        // the cross), over every pixel of the disc: no threshold, so no truncation bias.
        // (The disc and ring stay inside 1.45 arm lengths: the card's edge is 1.67 arm lengths
        // from a cross's centre, and its corner would pull the centroid.)
        let mut c = best.0;
        let (r, r2) = ((1.15 * arm).max(3.0), (1.45 * arm).max(4.0));
        for _ in 0..5 {
            let (x0, x1) = (
                (c[0] - r2).floor().max(0.0) as usize,
                ((c[0] + r2).ceil() as usize).min(w),
            );
            let (y0, y1) = (
                (c[1] - r2).floor().max(0.0) as usize,
                ((c[1] + r2).ceil() as usize).min(h),
            );
            let mut ring = Vec::new();
            let mut disc = Vec::new();
            for y in y0..y1 {
                for x in x0..x1 {
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    let dist = (px - c[0]).hypot(py - c[1]);
                    let v = s.data[y * w + x];
                    if dist <= r {
                        disc.push((px, py, v));
                    } else if dist <= r2 {
                        ring.push(v);
                    }
                }
            }
            let level = if ring.is_empty() { 0.0 } else { median(&mut ring) };
            levels[k] = level;
            let (mut sw, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
            for (px, py, v) in disc {
                let wt = (v - level).max(0.0) as f64;
                sw += wt;
                sx += wt * px;
                sy += wt * py;
            }
            if sw > 0.0 {
                c = [sx / sw, sy / sw];
            }
        }
        // Then the intersection of the two arms' lines: each arm's pixels (within 25 degrees of
        // its axis as the capture view shows it) get a weighted total-least-squares line. A
        // brightness gradient along an arm (the lamp's angle changes across the card) moves an
        // arm's centroid along its line, not the line, so the intersection is unbiased.
        for _ in 0..3 {
            let mut lines = Vec::new();
            for d in dirs[k] {
                let (mut sw, mut mx, mut my) = (0.0f64, 0.0f64, 0.0f64);
                let mut pts = Vec::new();
                let (x0, x1) = (
                    (c[0] - r).floor().max(0.0) as usize,
                    ((c[0] + r).ceil() as usize).min(w),
                );
                let (y0, y1) = (
                    (c[1] - r).floor().max(0.0) as usize,
                    ((c[1] + r).ceil() as usize).min(h),
                );
                for y in y0..y1 {
                    for x in x0..x1 {
                        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                        let (dx, dy) = (px - c[0], py - c[1]);
                        let dist = dx.hypot(dy);
                        if dist > r || dist < 1.0 {
                            continue;
                        }
                        let along = (dx * d[0] + dy * d[1]).abs() / dist;
                        if along < 25f64.to_radians().cos() {
                            continue;
                        }
                        let wt = (s.data[y * w + x] - levels[k]).max(0.0) as f64;
                        sw += wt;
                        mx += wt * px;
                        my += wt * py;
                        pts.push((px, py, wt));
                    }
                }
                if sw <= 0.0 {
                    break;
                }
                let (mx, my) = (mx / sw, my / sw);
                let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
                for (px, py, wt) in pts {
                    sxx += wt * (px - mx) * (px - mx);
                    sxy += wt * (px - mx) * (py - my);
                    syy += wt * (py - my) * (py - my);
                }
                // Principal direction of the 2x2 scatter matrix.
                let ang = 0.5 * (2.0 * sxy).atan2(sxx - syy);
                lines.push(([mx, my], [ang.cos(), ang.sin()], sw));
            }
            if lines.len() < 2 || lines[0].2.min(lines[1].2) < 0.2 * lines[0].2.max(lines[1].2) {
                break;
            }
            let ((p, u), (q, v)) = ((lines[0].0, lines[0].1), (lines[1].0, lines[1].1));
            let det = u[0] * (-v[1]) - u[1] * (-v[0]);
            if det.abs() < 0.2 {
                break;
            }
            // p + t u = q + s v
            let (bx, by) = (q[0] - p[0], q[1] - p[1]);
            let t = (bx * (-v[1]) - by * (-v[0])) / det;
            let next = [p[0] + t * u[0], p[1] + t * u[1]];
            if (next[0] - c[0]).hypot(next[1] - c[1]) > 0.5 * r {
                break;
            }
            c = next;
        }
        found[k] = c;
    }
    // Sanity: a convex quadrilateral in the nominal orientation, of a plausible size.
    let area = |q: &[[f64; 2]; 4]| {
        0.5 * (0..4)
            .map(|i| {
                let (a, b) = (q[i], q[(i + 1) % 4]);
                a[0] * b[1] - a[1] * b[0]
            })
            .sum::<f64>()
    };
    let (an, af) = (area(nominal), area(&found));
    let convex = (0..4).all(|i| {
        let (a, b, c) = (found[i], found[(i + 1) % 4], found[(i + 2) % 4]);
        let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
        cross * an > 0.0
    });
    let distinct =
        (0..4).all(|i| (i + 1..4).all(|j| (found[i][0] - found[j][0]).hypot(found[i][1] - found[j][1]) > 2.0 * arm));
    let plausible_area = af / an > 0.3 && af / an < 3.0; // false for NaN too
    if !convex || !distinct || !plausible_area {
        return Err(format!(
            "the corner crosses do not form the card's quadrilateral (found at {:?}, expected near {:?})",
            found.map(|p| [p[0].round(), p[1].round()]),
            nominal.map(|p| [p[0].round(), p[1].round()])
        ));
    }
    Ok(found)
}
