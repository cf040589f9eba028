//! Photos of the card, registered to its capture views.
//!
//! A photo (PNG or JPEG straight from a phone: any size, colour or grey, EXIF orientation
//! applied) is turned into grey display values in [0, 1] and resampled to its capture view's
//! raster. The card is flat, so a photo taken from near (not exactly at) the capture position is
//! related to the capture view by a homography of the plate plane. It is found from the card's
//! four corner crosses:
//!
//! 1. Bright marks: the image is smoothed (Gaussian, 1 px) and its white top-hat taken (less its
//!    opening by a 7 x 7 square: thin bright cuts stay, the plate's glow and its edges go); the
//!    noise is estimated robustly (median, MAD), and connected pixels above both 5 noise sigmas
//!    and 3% of the brightest mark form marks (at least 2.5 arm lengths of pixels each).
//!    Marks that are not point-symmetric (the corner of the card's glow, stray light) are dropped.
//! 2. Corners: the mark nearest each cross's place in the capture view, within a tenth of the
//!    frame (a photo taken near the capture pose); failing that, the crosses are the card's outermost marks, so for each diagonal direction the mark
//!    farthest along it is taken, and matched to the fiducial the capture view shows in that
//!    direction (a photo may be turned by less than 45 degrees).
//! 3. Centres: the centroid of the top-hat above its local level (the median in a ring around
//!    the cross) over a disc of 1.15 arm lengths, iterated; no threshold, so no truncation bias. Both arms of a cross are centred on it, so the centroid is its centre even when
//!    the dark-field lighting shows one arm only.
//! 4. The homography maps the capture view's fiducials onto the found ones (4 points, exact);
//!    a quadrilateral that is not convex, or much smaller than expected, means the card was not
//!    found, and says so.
use std::path::Path;

use scratchart::model::camera::ViewGeom;
use scratchart::model::scene::View;

use super::card::{Card, CutRole};

/// A grey image, display values in [0, 1], row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Gray {
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

impl Gray {
    fn at(&self, x: i64, y: i64) -> f32 {
        let xx = x.clamp(0, self.width as i64 - 1) as usize;
        let yy = y.clamp(0, self.height as i64 - 1) as usize;
        self.data[yy * self.width as usize + xx]
    }

    /// Bilinear sample at image point (sx, sy) (pixel (i, j) covers [i, i+1] x [j, j+1]);
    /// `None` outside the image.
    pub fn sample(&self, sx: f64, sy: f64) -> Option<f32> {
        if !(sx >= 0.0 && sy >= 0.0 && sx <= self.width as f64 && sy <= self.height as f64) {
            return None;
        }
        let (x, y) = (sx - 0.5, sy - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.at(x0, y0) * (1.0 - fx) + self.at(x0 + 1, y0) * fx;
        let bot = self.at(x0, y0 + 1) * (1.0 - fx) + self.at(x0 + 1, y0 + 1) * fx;
        Some(top * (1.0 - fy) + bot * fy)
    }
}

impl Gray {
    /// Catmull-Rom (cubic) sample at image point (sx, sy): it smooths far less than bilinear
    /// sampling, whose blur changes with the sub-pixel phase and would bias the fit's groove
    /// shapes. `None` outside the image.
    pub fn sample_cubic(&self, sx: f64, sy: f64) -> Option<f32> {
        if !(sx >= 0.0 && sy >= 0.0 && sx <= self.width as f64 && sy <= self.height as f64) {
            return None;
        }
        let (x, y) = (sx - 0.5, sy - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let k = |t: f64| {
            let (t2, t3) = (t * t, t * t * t);
            [
                -0.5 * t3 + t2 - 0.5 * t,
                1.5 * t3 - 2.5 * t2 + 1.0,
                -1.5 * t3 + 2.0 * t2 + 0.5 * t,
                0.5 * t3 - 0.5 * t2,
            ]
        };
        let (kx, ky) = (k(fx), k(fy));
        let (x0, y0) = (x0 as i64, y0 as i64);
        let mut acc = 0.0f64;
        for (j, wy) in ky.iter().enumerate() {
            let mut row = 0.0f64;
            for (i, wx) in kx.iter().enumerate() {
                row += wx * self.at(x0 - 1 + i as i64, y0 - 1 + j as i64) as f64;
            }
            acc += wy * row;
        }
        Some(acc as f32)
    }
}

/// Reads a photo as grey display values: PNG or JPEG, 8 or 16 bit, colour or grey, with the
/// EXIF orientation applied (a phone stores portrait shots turned).
pub fn load_photo(path: &Path) -> Result<Gray, String> {
    use image::ImageDecoder as _;
    let name = path.display();
    let reader = image::ImageReader::open(path)
        .map_err(|e| format!("cannot read photo `{name}`: {e}"))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read photo `{name}`: {e}"))?;
    let mut decoder = reader
        .into_decoder()
        .map_err(|e| format!("photo `{name}` is not a PNG or JPEG image I can read: {e}"))?;
    let orientation = decoder
        .orientation()
        .unwrap_or(image::metadata::Orientation::NoTransforms);
    let mut img =
        image::DynamicImage::from_decoder(decoder).map_err(|e| format!("photo `{name}` cannot be decoded: {e}"))?;
    img.apply_orientation(orientation);
    let g = img.to_luma32f();
    if g.width() < 16 || g.height() < 16 {
        return Err(format!(
            "photo `{name}` is {}x{} pixels: too small to show the card",
            g.width(),
            g.height()
        ));
    }
    Ok(Gray {
        width: g.width(),
        height: g.height(),
        data: g.into_raw(),
    })
}

/// The photo resampled to `w` x `h` (area-weighted when shrinking).
pub fn resize(img: &Gray, w: u32, h: u32) -> Gray {
    if img.width == w && img.height == h {
        return img.clone();
    }
    let buf = image::ImageBuffer::<image::Luma<f32>, Vec<f32>>::from_raw(img.width, img.height, img.data.clone())
        .expect("sizes match");
    let out = image::imageops::resize(&buf, w, h, image::imageops::FilterType::Triangle);
    Gray {
        width: w,
        height: h,
        data: out.into_raw(),
    }
}

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
    if !convex || !distinct || !(af / an > 0.3 && af / an < 3.0) {
        return Err(format!(
            "the corner crosses do not form the card's quadrilateral (found at {:?}, expected near {:?})",
            found.map(|p| [p[0].round(), p[1].round()]),
            nominal.map(|p| [p[0].round(), p[1].round()])
        ));
    }
    Ok(found)
}

/// The homography H (row-major 3x3, H[8] = 1) with H src[k] ~ dst[k] for the four pairs.
pub fn homography(src: &[[f64; 2]; 4], dst: &[[f64; 2]; 4]) -> Option<[f64; 9]> {
    let mut a = [[0.0f64; 9]; 8];
    for k in 0..4 {
        let ([x, y], [u, v]) = (src[k], dst[k]);
        a[2 * k] = [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, u];
        a[2 * k + 1] = [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, v];
    }
    // Gaussian elimination with partial pivoting on the 8x8 system (last column: right side).
    for col in 0..8 {
        let piv = (col..8).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, piv);
        for r in 0..8 {
            if r != col {
                let f = a[r][col] / a[col][col];
                for c in col..9 {
                    a[r][c] -= f * a[col][c];
                }
            }
        }
    }
    let mut h = [0.0; 9];
    for k in 0..8 {
        h[k] = a[k][8] / a[k][k];
    }
    h[8] = 1.0;
    Some(h)
}

/// Applies H to the image point p.
pub fn apply(h: &[f64; 9], p: [f64; 2]) -> [f64; 2] {
    let z = h[6] * p[0] + h[7] * p[1] + h[8];
    [
        (h[0] * p[0] + h[1] * p[1] + h[2]) / z,
        (h[3] * p[0] + h[4] * p[1] + h[5]) / z,
    ]
}

/// A photo registered to a capture view: its values on the view's raster and where they are
/// valid (inside the photo).
#[derive(Clone, Debug)]
pub struct Registered {
    /// The photo resized to the view's raster (before the homography).
    pub photo: Gray,
    /// The homography from the view's image points to the resized photo's.
    pub h: [f64; 9],
    pub image: Vec<f32>,
    pub valid: Vec<bool>,
    /// The fiducials found in the (resized) photo.
    pub fiducials: [[f64; 2]; 4],
    /// Largest distance between a found fiducial and the capture view's, pixels (how far the
    /// photo's pose was from the capture position).
    pub pose_offset_px: f64,
}

/// Samples `photo` at H(A(p)) for every pixel centre p of a `w` x `h` raster, where A is the
/// affine correction p + (a0 + a2 x' + a3 y', a1 + a4 x' + a5 y') about the raster's centre
/// (x' = x - w/2, y' = y - h/2). Pixels outside the photo are 0 and invalid.
pub fn warp(photo: &Gray, hm: &[f64; 9], a: &[f64; 6], w: u32, h: u32) -> (Vec<f32>, Vec<bool>) {
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    let mut image = Vec::with_capacity((w * h) as usize);
    let mut valid = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        for i in 0..w {
            let (x, y) = (i as f64 + 0.5, j as f64 + 0.5);
            let p = [
                x + a[0] + a[2] * (x - cx) + a[3] * (y - cy),
                y + a[1] + a[4] * (x - cx) + a[5] * (y - cy),
            ];
            let q = apply(hm, p);
            match photo.sample_cubic(q[0], q[1]) {
                Some(v) => {
                    image.push(v);
                    valid.push(true);
                }
                None => {
                    image.push(0.0);
                    valid.push(false);
                }
            }
        }
    }
    (image, valid)
}

/// The camera that took a photo of `w` x `h` pixels (square pixels, principal point at the
/// centre, MODEL.md's pinhole) from the homography `g` that maps plate points (x, y) in mm to
/// its image points: with u = sx - w/2, v = h/2 - sy, g ~ K [r1 r2 t] with K = diag(f, f, 1),
/// and the two rotation columns r1, r2 being orthogonal and of equal length gives f (least
/// squares over both conditions); the rest follows. `None` when the homography is not that of
/// a camera looking down at the plate.
pub fn camera_from_homography(g: &[f64; 9], w: u32, h: u32) -> Option<scratchart::model::scene::Camera> {
    // M = diag(1, -1, 1) T^-1 g: plate -> (u, v, 1).
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    let row = |r: usize| [g[3 * r], g[3 * r + 1], g[3 * r + 2]];
    let (r0, r1, r2) = (row(0), row(1), row(2));
    let m0: [f64; 3] = std::array::from_fn(|c| r0[c] - cx * r2[c]);
    let m1: [f64; 3] = std::array::from_fn(|c| -(r1[c] - cy * r2[c]));
    let m = [m0, m1, r2]; // rows of M
    let col = |c: usize| [m[0][c], m[1][c], m[2][c]];
    let (a, b, t) = (col(0), col(1), col(2));
    // Orthogonality: (a0 b0 + a1 b1) q + a2 b2 = 0; equal norms:
    // (a0^2 + a1^2 - b0^2 - b1^2) q + a2^2 - b2^2 = 0, with q = 1 / f^2.
    let (p1, s1) = (a[0] * b[0] + a[1] * b[1], a[2] * b[2]);
    let (p2, s2) = (
        a[0] * a[0] + a[1] * a[1] - b[0] * b[0] - b[1] * b[1],
        a[2] * a[2] - b[2] * b[2],
    );
    let q = -(p1 * s1 + p2 * s2) / (p1 * p1 + p2 * p2);
    if !(q > 0.0 && q.is_finite()) {
        return None;
    }
    let f = 1.0 / q.sqrt();
    let kinv = |v: [f64; 3]| [v[0] / f, v[1] / f, v[2]];
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let (ka, kb, kt) = (kinv(a), kinv(b), kinv(t));
    let mut lambda = 2.0 / (norm(ka) + norm(kb));
    if kt[2] * lambda < 0.0 {
        lambda = -lambda; // the plate lies in front of the camera
    }
    let c0: Vec<f64> = ka.iter().map(|x| x * lambda).collect();
    let c1: Vec<f64> = kb.iter().map(|x| x * lambda).collect();
    let tt: Vec<f64> = kt.iter().map(|x| x * lambda).collect();
    // Gram-Schmidt on the two columns, the third by the cross product.
    let n0 = norm([c0[0], c0[1], c0[2]]);
    let e0 = [c0[0] / n0, c0[1] / n0, c0[2] / n0];
    let d = c1[0] * e0[0] + c1[1] * e0[1] + c1[2] * e0[2];
    let c1o = [c1[0] - d * e0[0], c1[1] - d * e0[1], c1[2] - d * e0[2]];
    let n1 = norm(c1o);
    let e1 = [c1o[0] / n1, c1o[1] / n1, c1o[2] / n1];
    // MODEL.md's frame (right = forward x up) is left-handed as rows, so det R = -1 and the
    // third column is -(e0 x e1).
    let e2 = [
        -(e0[1] * e1[2] - e0[2] * e1[1]),
        -(e0[2] * e1[0] - e0[0] * e1[2]),
        -(e0[0] * e1[1] - e0[1] * e1[0]),
    ];
    // R has columns e0, e1, e2; its rows are the camera's right, up and forward in world axes.
    let right = [e0[0], e1[0], e2[0]];
    let up = [e0[1], e1[1], e2[1]];
    let forward = [e0[2], e1[2], e2[2]];
    // MODEL.md's camera: right = forward x up. A mirrored solution is not a camera.
    let fx = [
        forward[1] * up[2] - forward[2] * up[1],
        forward[2] * up[0] - forward[0] * up[2],
        forward[0] * up[1] - forward[1] * up[0],
    ];
    if fx[0] * right[0] + fx[1] * right[1] + fx[2] * right[2] < 0.5 {
        return None;
    }
    // eye = -R^T t
    let eye: [f64; 3] = std::array::from_fn(|i| -(right[i] * tt[0] + up[i] * tt[1] + forward[i] * tt[2]));
    if !(eye[2] > 0.0) {
        return None;
    }
    let dist = tt[2];
    Some(scratchart::model::scene::Camera {
        eye,
        target: std::array::from_fn(|i| eye[i] + dist * forward[i]),
        up,
        fov_y_deg: 2.0 * (0.5 * h as f64 / f).atan().to_degrees(),
        width: w,
        height: h,
    })
}

/// The homography from plate points (mm) to the photo's image points, from the fiducials found
/// in it.
pub fn plate_homography(card: &Card, found: &[[f64; 2]; 4]) -> Option<[f64; 9]> {
    let fid: Vec<_> = card.cuts.iter().filter(|c| c.role == CutRole::Fiducial).collect();
    let mut plate = [[0.0; 2]; 4];
    for (k, pair) in fid.chunks(2).take(4).enumerate() {
        let c = pair[0];
        plate[k] = [0.5 * (c.p0[0] + c.p1[0]), 0.5 * (c.p0[1] + c.p1[1])];
    }
    homography(&plate, found)
}

/// Registers `photo` to capture view `view` of `card`.
pub fn register(photo: &Gray, card: &Card, view: &View) -> Result<Registered, String> {
    let (w, h) = (view.camera.width, view.camera.height);
    let img = resize(photo, w, h);
    let (nominal, arm) = nominal_fiducials(card, view);
    let found = find_fiducials(&img, &nominal, &arm_directions(card, view), arm)?;
    let hm = homography(&nominal, &found).ok_or("the corner crosses are degenerate (collinear)")?;
    let (image, valid) = warp(&img, &hm, &[0.0; 6], w, h);
    let pose_offset_px = (0..4)
        .map(|k| (found[k][0] - nominal[k][0]).hypot(found[k][1] - nominal[k][1]))
        .fold(0.0, f64::max);
    Ok(Registered {
        photo: img,
        h: hm,
        image,
        valid,
        fiducials: found,
        pose_offset_px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homography_maps_the_four_points_and_between() {
        let src = [[10.0, 10.0], [200.0, 12.0], [210.0, 190.0], [5.0, 180.0]];
        let dst = [[20.0, 30.0], [190.0, 25.0], [230.0, 210.0], [15.0, 170.0]];
        let h = homography(&src, &dst).unwrap();
        for k in 0..4 {
            let q = apply(&h, src[k]);
            assert!(
                (q[0] - dst[k][0]).abs() < 1e-9 && (q[1] - dst[k][1]).abs() < 1e-9,
                "{q:?}"
            );
        }
        // The identity maps to itself.
        let id = homography(&src, &src).unwrap();
        let q = apply(&id, [77.0, 33.0]);
        assert!((q[0] - 77.0).abs() < 1e-9 && (q[1] - 33.0).abs() < 1e-9);
        // Collinear points have none.
        assert!(homography(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]], &dst).is_none());
    }

    #[test]
    fn bilinear_sample_is_exact_at_centres_and_between() {
        let g = Gray {
            width: 2,
            height: 1,
            data: vec![0.0, 1.0],
        };
        assert_eq!(g.sample(0.5, 0.5), Some(0.0));
        assert_eq!(g.sample(1.5, 0.5), Some(1.0));
        assert_eq!(g.sample(1.0, 0.5), Some(0.5));
        assert_eq!(g.sample(2.5, 0.5), None);
    }
}

#[cfg(test)]
mod camera_tests {
    use super::*;
    use crate::card::CardSpec;

    /// The camera of a capture view comes back from the homography of its own projections.
    #[test]
    fn a_camera_is_recovered_from_its_plate_homography() {
        let card = Card::new(&CardSpec::default());
        for view in card.views(256) {
            let g = ViewGeom::new(&view);
            let (nominal, _) = nominal_fiducials(&card, &view);
            let hp = plate_homography(&card, &nominal).unwrap();
            let cam = camera_from_homography(&hp, 256, 256).expect("a camera");
            for k in 0..3 {
                assert!(
                    (cam.eye[k] - view.camera.eye[k]).abs() < 1e-6,
                    "{:?} vs {:?}",
                    cam.eye,
                    view.camera.eye
                );
            }
            assert!((cam.fov_y_deg - view.camera.fov_y_deg).abs() < 1e-9);
            // It projects plate points where the view does.
            let back = ViewGeom::new(&View {
                camera: cam,
                ..view.clone()
            });
            for p in [[10.0, -7.0, 0.0], [-30.0, 25.0, 0.0]] {
                let (a, b) = (g.project(p).unwrap(), back.project(p).unwrap());
                assert!((a.0 - b.0).abs() < 1e-6 && (a.1 - b.1).abs() < 1e-6, "{a:?} vs {b:?}");
            }
        }
    }
}

#[cfg(test)]
mod photo_tests {
    use super::*;

    /// A colour JPEG straight from a phone: stored turned, with the EXIF orientation tag saying
    /// how to show it. It reads back upright and grey.
    #[test]
    fn a_turned_colour_jpeg_reads_back_upright() {
        use image::ImageEncoder as _;
        // Upright: 64 x 32, bright (red) top-left quadrant on a dark background.
        let upright = image::RgbImage::from_fn(64, 32, |x, y| {
            if x < 32 && y < 16 {
                image::Rgb([250, 40, 40])
            } else {
                image::Rgb([20, 20, 20])
            }
        });
        // Stored turned a quarter counter-clockwise; orientation 6 tells a viewer to turn it back.
        let stored = image::imageops::rotate270(&upright);
        // EXIF (TIFF, big-endian): one IFD entry, Orientation (0x0112), SHORT, 1, value 6.
        let exif: Vec<u8> = vec![
            b'M', b'M', 0, 42, 0, 0, 0, 8, // header, IFD at 8
            0, 1, // one entry
            0x01, 0x12, 0, 3, 0, 0, 0, 1, 0, 6, 0, 0, // Orientation = 6
            0, 0, 0, 0, // no next IFD
        ];
        let mut buf = Vec::new();
        let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 95);
        enc.set_exif_metadata(exif).unwrap();
        enc.write_image(
            stored.as_raw(),
            stored.width(),
            stored.height(),
            image::ExtendedColorType::Rgb8,
        )
        .unwrap();
        let dir = std::env::temp_dir().join(format!("scratchart-photo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("phone.jpg");
        std::fs::write(&p, &buf).unwrap();
        let g = load_photo(&p).unwrap();
        assert_eq!((g.width, g.height), (64, 32), "the orientation was not applied");
        let mean = |x0: u32, y0: u32| {
            let mut s = 0.0;
            for y in y0 + 4..y0 + 12 {
                for x in x0 + 8..x0 + 24 {
                    s += g.data[(y * 64 + x) as usize];
                }
            }
            s / (8.0 * 16.0)
        };
        let (tl, tr, bl) = (mean(0, 0), mean(32, 0), mean(0, 16));
        assert!(
            tl > 0.25 && tr < 0.12 && bl < 0.12,
            "top-left {tl}, top-right {tr}, bottom-left {bl}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
