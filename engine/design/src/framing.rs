//! Where a target picture goes in a view: the plate covers only part of a camera's frame (a
//! trapezoid, or a diamond for views from a plate corner), and only that part can ever be lit.
//!
//! [`Fit::Contain`] (the default) places the picture upright, with its aspect kept, as large as
//! fits inside the plate's silhouette: the largest axis-aligned rectangle of the picture's aspect
//! inside the projected plate (a small linear programme, solved exactly by enumerating its
//! vertices). The rest of the plate shows a background level; off-plate pixels are 0, as the
//! render is there, so they add nothing to the loss.
//!
//! The other modes: [`Fit::Frame`] stretches the picture over the whole frame (the old
//! behaviour, for views whose frame lies inside the plate); [`Fit::Cover`] fills the silhouette's
//! bounding box with the picture, aspect kept, cropping what overflows; [`Fit::Printed`] lays the
//! picture on the plate itself (upright on the plate's +y axis, aspect kept, centred) and shows it
//! in perspective.
use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::{Plate, View};

/// How a picture is placed in a view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Fit {
    /// Upright, aspect kept, as large as fits inside the plate's silhouette (the default).
    #[default]
    Contain,
    /// Stretched over the whole camera frame.
    Frame,
    /// Aspect kept, filling the silhouette's bounding box (cropping the picture).
    Cover,
    /// Laid on the plate's own coordinates, seen in perspective.
    Printed,
}

impl std::str::FromStr for Fit {
    type Err = String;
    fn from_str(s: &str) -> Result<Fit, String> {
        match s {
            "contain" => Ok(Fit::Contain),
            "frame" => Ok(Fit::Frame),
            "cover" => Ok(Fit::Cover),
            "printed" => Ok(Fit::Printed),
            _ => Err(format!("unknown fit `{s}`: choose contain, frame, cover or printed")),
        }
    }
}

/// An axis-aligned rectangle in image coordinates (pixels; y down).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub w: f64,
    pub h: f64,
}

/// The plate's silhouette in a view: its four corners projected to image coordinates, in order
/// around the plate; `None` when a corner is behind the camera.
pub fn silhouette(view: &View, plate_mm: f64) -> Option<[[f64; 2]; 4]> {
    let g = ViewGeom::new(view);
    let h = 0.5 * plate_mm;
    let mut q = [[0.0; 2]; 4];
    for (k, c) in [[-h, -h], [h, -h], [h, h], [-h, h]].iter().enumerate() {
        let (x, y) = g.project([c[0], c[1], 0.0])?;
        q[k] = [x, y];
    }
    Some(q)
}

/// The largest rectangle of aspect `aspect` (width / height) whose pixels all see the plate, for a
/// bent plate (its silhouette is curved, and a concave sheet's may not be convex): pixel-aligned,
/// the largest height by bisection (a height that fits means every smaller one does), and of the
/// places that fit, the one nearest column `cx` (None: the on-plate pixels' middle) and the
/// on-plate pixels' middle row.
pub fn largest_rect_on_plate(view: &View, plate: &Plate, aspect: f64, cx: Option<f64>) -> Option<Rect> {
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let on = ViewGeom::of(view, plate).on_plate_mask(0.5 * plate.size_mm);
    // Prefix sums of the off-plate pixels: off(x0, y0, x1, y1) counts them in [x0, x1) x [y0, y1).
    let mut sum = vec![0u32; (w + 1) * (h + 1)];
    let (mut n_on, mut mx, mut my) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let o = !on[y * w + x];
            if !o {
                n_on += 1.0;
                mx += x as f64 + 0.5;
                my += y as f64 + 0.5;
            }
            sum[(y + 1) * (w + 1) + x + 1] =
                o as u32 + sum[y * (w + 1) + x + 1] + sum[(y + 1) * (w + 1) + x] - sum[y * (w + 1) + x];
        }
    }
    if n_on == 0.0 {
        return None;
    }
    let (mx, my) = (cx.unwrap_or(mx / n_on), my / n_on);
    let off = |x0: usize, y0: usize, x1: usize, y1: usize| {
        sum[y1 * (w + 1) + x1] + sum[y0 * (w + 1) + x0] - sum[y0 * (w + 1) + x1] - sum[y1 * (w + 1) + x0]
    };
    // The best place for a rectangle of height rh (None: none fits).
    let place = |rh: usize| -> Option<(usize, usize, usize)> {
        let rw = ((rh as f64 * aspect).floor() as usize).max(1);
        if rw > w || rh > h {
            return None;
        }
        let mut best: Option<(f64, usize, usize)> = None;
        for y0 in 0..=h - rh {
            for x0 in 0..=w - rw {
                if off(x0, y0, x0 + rw, y0 + rh) == 0 {
                    let d = (x0 as f64 + 0.5 * rw as f64 - mx).powi(2) + (y0 as f64 + 0.5 * rh as f64 - my).powi(2);
                    if best.is_none_or(|b| d < b.0) {
                        best = Some((d, x0, y0));
                    }
                }
            }
        }
        best.map(|(_, x0, y0)| (x0, y0, rw))
    };
    let (mut lo, mut hi) = (0usize, h + 1); // lo fits (0: trivially), hi does not
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if place(mid).is_some() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (x0, y0, rw) = place(lo.max(1))?;
    Some(Rect {
        x0: x0 as f64,
        y0: y0 as f64,
        w: rw as f64,
        h: lo.max(1) as f64,
    })
}

/// The largest rectangle of aspect `aspect` (width / height) inside the convex quadrilateral
/// `poly` and inside the frame [0, fw] x [0, fh].
///
/// Linear programme in (cx, cy, s) (centre, height): every corner (cx +- s a/2, cy +- s/2) on
/// the inner side of every edge and of the frame; maximize s. The optimum lies on a vertex of the
/// feasible set, where three constraints are active: all triples are solved and the feasible one
/// with the largest s wins (20 constraints, 1,140 triples).
pub fn largest_rect(poly: &[[f64; 2]; 4], aspect: f64, fw: f64, fh: f64) -> Option<Rect> {
    largest_rect_with(poly, aspect, fw, fh, None)
}

/// [`largest_rect`] whose centre's x is `cx` (pixels) when given: the largest rectangle centred
/// on that column. A walk's views use the plate centre's column, so the picture stays on the
/// same part of the plate as the viewer walks: the unconstrained optimum of a near-symmetric
/// silhouette (a trapezoid) slides to one end or the other, and jumps from one to the other
/// where the view passes the symmetric one.
pub fn largest_rect_with(poly: &[[f64; 2]; 4], aspect: f64, fw: f64, fh: f64, cx: Option<f64>) -> Option<Rect> {
    // Constraints a . (cx, cy, s) <= b.
    let mut cons: Vec<([f64; 3], f64)> = Vec::new();
    if let Some(c) = cx {
        cons.push(([1.0, 0.0, 0.0], c));
        cons.push(([-1.0, 0.0, 0.0], -c));
    }
    let area2: f64 = (0..4)
        .map(|i| {
            let (p, q) = (poly[i], poly[(i + 1) % 4]);
            p[0] * q[1] - q[0] * p[1]
        })
        .sum();
    if area2.abs() < 1e-12 {
        return None;
    }
    let sign = area2.signum();
    for i in 0..4 {
        let (p, q) = (poly[i], poly[(i + 1) % 4]);
        // Outward normal of edge p -> q for a polygon of orientation `sign`.
        let n = [sign * (q[1] - p[1]), -sign * (q[0] - p[0])];
        let c = n[0] * p[0] + n[1] * p[1];
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            cons.push(([n[0], n[1], n[0] * sx * aspect / 2.0 + n[1] * sy / 2.0], c));
        }
    }
    // The frame: cx - s a/2 >= 0, cx + s a/2 <= fw, cy - s/2 >= 0, cy + s/2 <= fh.
    cons.push(([-1.0, 0.0, aspect / 2.0], 0.0));
    cons.push(([1.0, 0.0, aspect / 2.0], fw));
    cons.push(([0.0, -1.0, 0.5], 0.0));
    cons.push(([0.0, 1.0, 0.5], fh));
    let feasible = |x: &[f64; 3]| {
        x[2] > 0.0
            && cons
                .iter()
                .all(|(a, b)| a[0] * x[0] + a[1] * x[1] + a[2] * x[2] <= b + 1e-9 * (1.0 + b.abs()))
    };
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let n = cons.len();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let Some(x) = solve3([cons[i].0, cons[j].0, cons[k].0], [cons[i].1, cons[j].1, cons[k].1]) else {
                    continue;
                };
                if feasible(&x) {
                    vertices.push(x);
                }
            }
        }
    }
    let s_max = vertices.iter().map(|x| x[2]).fold(f64::NEG_INFINITY, f64::max);
    // The largest size is often reached along an edge of the feasible set (a trapezoid's long
    // side leaves the square room to slide): the middle of that edge, the mean of the optimal
    // vertices (a convex combination, so feasible), so the picture sits centred in its room and
    // moves smoothly from one view to the next (a walk's views) instead of jumping between ends.
    // (A vertex where more than three constraints meet is found once per triple: each counts once.)
    let mut optimal: Vec<&[f64; 3]> = Vec::new();
    for x in vertices.iter().filter(|x| x[2] >= s_max - 1e-9 * (1.0 + s_max.abs())) {
        if !optimal
            .iter()
            .any(|o| (o[0] - x[0]).abs() + (o[1] - x[1]).abs() < 1e-7 * (1.0 + s_max.abs()))
        {
            optimal.push(x);
        }
    }
    let best = (!optimal.is_empty()).then(|| {
        let m = optimal.len() as f64;
        let cx = optimal.iter().map(|x| x[0]).sum::<f64>() / m;
        let cy = optimal.iter().map(|x| x[1]).sum::<f64>() / m;
        [cx, cy, s_max]
    });
    best.map(|[cx, cy, s]| Rect {
        x0: cx - s * aspect / 2.0,
        y0: cy - s / 2.0,
        w: s * aspect,
        h: s,
    })
}

/// Solves a 3x3 system by Cramer's rule; `None` when it is (nearly) singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    let scale: f64 = a.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max).powi(3);
    if d.abs() <= 1e-12 * scale.max(1e-300) {
        return None;
    }
    let mut x = [0.0; 3];
    for c in 0..3 {
        let mut m = a;
        for r in 0..3 {
            m[r][c] = b[r];
        }
        x[c] = det(m) / d;
    }
    Some(x)
}

/// Bilinear sample of a `sw` x `sh` image at continuous coordinates (u, v) in pixels (pixel
/// centres at +0.5), clamped to the edge.
fn sample(src: &[f32], sw: u32, sh: u32, u: f64, v: f64) -> f32 {
    let x = (u - 0.5).clamp(0.0, sw as f64 - 1.0);
    let y = (v - 0.5).clamp(0.0, sh as f64 - 1.0);
    let (x0, y0) = (x.floor() as u32, y.floor() as u32);
    let (x1, y1) = ((x0 + 1).min(sw - 1), (y0 + 1).min(sh - 1));
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let at = |i: u32, j: u32| src[(j * sw + i) as usize];
    let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
    let bot = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
    top * (1.0 - fy) + bot * fy
}

/// A target as the loss uses it, with where the picture went.
#[derive(Clone, Debug)]
pub struct Fitted {
    /// Display values in [0, 1], W x H of the view, top row first.
    pub image: Vec<f32>,
    /// The picture's rectangle in the view (image pixels), for [`Fit::Contain`] and
    /// [`Fit::Cover`]; the whole frame for [`Fit::Frame`]; `None` for [`Fit::Printed`].
    pub rect: Option<Rect>,
    /// Which pixels show the picture (the rest is background or off the plate).
    pub picture: Vec<bool>,
}

/// Places picture `src` (`sw` x `sh` display values) in `view` of `plate`.
/// `background`: the level of on-plate pixels outside the picture. Off-plate pixels are 0.
/// A picture smaller than the rectangle it fills is scaled up, a larger one down (an area
/// average over the source pixels a target pixel covers, so nothing aliases).
pub fn fit_picture(src: &[f32], sw: u32, sh: u32, view: &View, plate: &Plate, fit: Fit, background: f32) -> Fitted {
    let rect = picture_rect(view, plate, fit, sw as f64 / sh as f64);
    fit_picture_rect(src, sw, sh, view, plate, fit, background, rect)
}

/// [`fit_picture`] for a walk's view: `contain` keeps the picture centred on the column of the
/// plate's centre ([`largest_rect_with`]), so it moves smoothly along the walk; the other modes
/// place it as [`fit_picture`] does.
pub fn fit_picture_walk(
    src: &[f32],
    sw: u32,
    sh: u32,
    view: &View,
    plate: &Plate,
    fit: Fit,
    background: f32,
) -> Fitted {
    let aspect = sw as f64 / sh as f64;
    let cx = ViewGeom::new(view).project([0.0, 0.0, 0.0]).map(|p| p.0);
    let rect = match fit {
        Fit::Contain if !plate.shape.is_flat() => largest_rect_on_plate(view, plate, aspect, cx),
        Fit::Contain => silhouette(view, plate.size_mm).and_then(|q| {
            let (w, h) = (view.camera.width as f64, view.camera.height as f64);
            largest_rect_with(&q, aspect, w, h, cx)
        }),
        _ => picture_rect(view, plate, fit, aspect),
    };
    fit_picture_rect(src, sw, sh, view, plate, fit, background, rect)
}

/// Where a picture of `aspect` (width / height) goes in `view` for `fit` (see [`Fitted::rect`]).
pub fn picture_rect(view: &View, plate: &Plate, fit: Fit, aspect: f64) -> Option<Rect> {
    let (w, h) = (view.camera.width, view.camera.height);
    let plate_mm = plate.size_mm;
    match fit {
        Fit::Frame => Some(Rect {
            x0: 0.0,
            y0: 0.0,
            w: w as f64,
            h: h as f64,
        }),
        Fit::Contain if !plate.shape.is_flat() => largest_rect_on_plate(view, plate, aspect, None),
        Fit::Contain => silhouette(view, plate_mm).and_then(|q| largest_rect(&q, aspect, w as f64, h as f64)),
        Fit::Cover => crate::scenes::silhouette_box(view, plate).map(|b| {
            let (lo, hi) = ([b[0], b[1]], [b[2], b[3]]);
            let (bw, bh) = (hi[0] - lo[0], hi[1] - lo[1]);
            // The smallest rectangle of the picture's aspect that covers the box.
            let (rw, rh) = if bw / bh > aspect {
                (bw, bw / aspect)
            } else {
                (bh * aspect, bh)
            };
            Rect {
                x0: 0.5 * (lo[0] + hi[0]) - rw / 2.0,
                y0: 0.5 * (lo[1] + hi[1]) - rh / 2.0,
                w: rw,
                h: rh,
            }
        }),
        Fit::Printed => None,
    }
}

/// Places picture `src` in `view` in the rectangle `rect` ([`picture_rect`], or one moved or
/// scaled by the design's user, [`crate::steer`]); `rect` None places nothing but for
/// `printed`, which has no rectangle.
#[allow(clippy::too_many_arguments)] // fit_picture's settings and the rectangle
pub fn fit_picture_rect(
    src: &[f32],
    sw: u32,
    sh: u32,
    view: &View,
    plate: &Plate,
    fit: Fit,
    background: f32,
    rect: Option<Rect>,
) -> Fitted {
    let (w, h) = (view.camera.width, view.camera.height);
    let plate_mm = plate.size_mm;
    let g = ViewGeom::of(view, plate);
    let on = g.on_plate_mask(0.5 * plate_mm);
    let aspect = sw as f64 / sh as f64;
    let mut image = vec![0f32; (w * h) as usize];
    let mut picture = vec![false; (w * h) as usize];
    // Supersampling of each target pixel, so a large picture is area-averaged.
    let ss = |extent: f64, n: u32| -> u32 { ((n as f64 / extent).ceil() as u32).clamp(1, 8) };
    for j in 0..h {
        for i in 0..w {
            let idx = (j * w + i) as usize;
            if !on[idx] {
                continue;
            }
            image[idx] = background;
            match fit {
                Fit::Printed => {
                    // The plate point seen at the pixel centre, in the picture laid on the plate
                    // (contained in the plate square, aspect kept, +y of the plate up).
                    let Some(x) = g.shading_point(i, j) else { continue };
                    let (pw, ph) = if aspect >= 1.0 {
                        (plate_mm, plate_mm / aspect)
                    } else {
                        (plate_mm * aspect, plate_mm)
                    };
                    let u = (x[0] + pw / 2.0) / pw;
                    let v = (ph / 2.0 - x[1]) / ph;
                    if (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v) {
                        image[idx] = sample(src, sw, sh, u * sw as f64, v * sh as f64);
                        picture[idx] = true;
                    }
                }
                _ => {
                    let Some(r) = rect else { continue };
                    let (cx, cy) = (i as f64 + 0.5, j as f64 + 0.5);
                    if cx < r.x0 || cx > r.x0 + r.w || cy < r.y0 || cy > r.y0 + r.h {
                        continue;
                    }
                    let (nx, ny) = (ss(r.w, sw), ss(r.h, sh));
                    let mut acc = 0.0f32;
                    for b in 0..ny {
                        for a in 0..nx {
                            let px = i as f64 + (a as f64 + 0.5) / nx as f64;
                            let py = j as f64 + (b as f64 + 0.5) / ny as f64;
                            let u = (px - r.x0) / r.w * sw as f64;
                            let v = (py - r.y0) / r.h * sh as f64;
                            acc += sample(src, sw, sh, u, v);
                        }
                    }
                    image[idx] = acc / (nx * ny) as f32;
                    picture[idx] = true;
                }
            }
        }
    }
    Fitted { image, rect, picture }
}
