//! The set-up overlay (key S, `--setup`): drawn on the host into a sparse layer over the rendered
//! plate and copied into the frame's output buffer by the GPU (see `FrameRenderer::render`).
//!
//! For the viewer's current camera it draws the plate's +x edge (which carries the orientation
//! mark), a disc where each lamp and each designed eye projects, with its numbers beside it, and
//! for a point behind the camera or outside the frame an arrow at the frame's edge pointing
//! towards it. An eye at the camera itself (the view being looked through) is listed at the top
//! left. Every overlay pixel has a colour with R, G and B not all equal, so on the viewer's grey
//! render it is told apart from the plate, and every other pixel is the render, unchanged.
use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::{Camera, Light, LightKind, View};

use crate::font;
use crate::setup::{Kind, SetupInfo};

pub const LAMP: [u8; 3] = [255, 170, 0];
pub const EYE: [u8; 3] = [60, 190, 255];
pub const MARK: [u8; 3] = [255, 40, 40];
pub const TEXT: [u8; 3] = [255, 255, 170];
pub const SHADOW: [u8; 3] = [0, 0, 48];

/// Marker disc radius and arrow size, in pixels.
pub const MARKER_R: f64 = 5.0;
const ARROW_LEN: f64 = 14.0;
/// The arrow's tip stays this far inside the frame.
pub const EDGE_INSET: f64 = 3.0;
/// Points closer to the camera plane than this (mm) are treated as behind it.
const NEAR_MM: f64 = 1.0;

/// Where one lamp or eye went in the frame (pixel coordinates of the render's rectangle; the
/// pixel (i, j) covers [i, i + 1] x [j, j + 1]).
#[derive(Clone, Debug, PartialEq)]
pub enum Placed {
    /// In front of the camera and inside the frame: a disc centred at the projection.
    Marker { x: f64, y: f64 },
    /// Behind the camera or outside the frame: an arrow with its tip at (x, y) pointing along
    /// (dx, dy) (unit, image coordinates: y down).
    Edge { x: f64, y: f64, dx: f64, dy: f64 },
    /// The point is the camera's own eye.
    AtCamera,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Mark {
    pub label: String,
    pub kind: Kind,
    pub placed: Placed,
}

/// The overlay of one frame: RGB per pixel of the render's rectangle (`None`: the render shows).
pub struct Overlay {
    pub w: u32,
    pub h: u32,
    px: Vec<Option<[u8; 3]>>,
    /// Rectangles (x, y, w, h) taken by text, so labels do not overwrite each other.
    taken: Vec<[f64; 4]>,
    pub marks: Vec<Mark>,
}

/// The camera as seen by the overlay: basis, tan(fov/2), frame size.
struct Cam {
    g: ViewGeom,
    w: f64,
    h: f64,
}

impl Cam {
    fn new(camera: &Camera) -> Cam {
        let view = View {
            exposure: 1.0,
            name: "overlay".into(),
            camera: camera.clone(),
            light: Light {
                kind: LightKind::Directional {
                    direction: [0.0, 0.0, 1.0],
                },
                intensity: 1.0,
            },
        };
        Cam {
            g: ViewGeom::new(&view),
            w: camera.width as f64,
            h: camera.height as f64,
        }
    }

    /// (right, up, forward) components of p - eye.
    fn local(&self, p: [f64; 3]) -> [f64; 3] {
        let d = [p[0] - self.g.eye[0], p[1] - self.g.eye[1], p[2] - self.g.eye[2]];
        let dot = |a: [f64; 3]| a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
        [dot(self.g.right), dot(self.g.up), dot(self.g.forward)]
    }

    /// Image point of a camera-space point in front of the camera.
    fn pixel(&self, l: [f64; 3]) -> (f64, f64) {
        let t = self.g.tan_half;
        (
            (l[0] / l[2] / (t * self.w / self.h) + 1.0) * 0.5 * self.w,
            (1.0 - l[1] / l[2] / t) * 0.5 * self.h,
        )
    }
}

impl Overlay {
    fn new(w: u32, h: u32) -> Overlay {
        Overlay {
            w,
            h,
            px: vec![None; w as usize * h as usize],
            taken: Vec::new(),
            marks: Vec::new(),
        }
    }

    #[cfg(test)]
    pub fn get(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        self.px[(y * self.w + x) as usize]
    }

    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.w && (y as u32) < self.h {
            self.px[y as usize * self.w as usize + x as usize] = Some(c);
        }
    }

    /// Every pixel whose centre lies within `r` of (x, y).
    fn disc(&mut self, x: f64, y: f64, r: f64, c: [u8; 3]) {
        for j in (y - r - 1.0).floor() as i64..=(y + r + 1.0).ceil() as i64 {
            for i in (x - r - 1.0).floor() as i64..=(x + r + 1.0).ceil() as i64 {
                let (dx, dy) = (i as f64 + 0.5 - x, j as f64 + 0.5 - y);
                if dx * dx + dy * dy <= r * r {
                    self.set(i, j, c);
                }
            }
        }
    }

    /// A line of discs of radius `r` from a to b, clipped to the frame first.
    fn line(&mut self, a: (f64, f64), b: (f64, f64), r: f64, c: [u8; 3]) {
        let Some((a, b)) = clip(
            a,
            b,
            (-r - 2.0, -r - 2.0),
            (self.w as f64 + r + 2.0, self.h as f64 + r + 2.0),
        ) else {
            return;
        };
        let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            self.disc(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1), r, c);
        }
    }

    /// The pixel size of one line of `text` at `scale`.
    fn text_size(text: &str, scale: u32) -> (f64, f64) {
        (
            (text.chars().count() as u32 * (font::GLYPH_W + 1) * scale) as f64,
            ((font::GLYPH_H + 1) * scale) as f64,
        )
    }

    /// `text` with its top-left corner at (x, y), in TEXT on a one-pixel SHADOW outline.
    fn text(&mut self, x: f64, y: f64, text: &str, scale: u32) {
        let (x0, y0) = (x.round() as i64, y.round() as i64);
        let (tw, th) = Self::text_size(text, scale);
        self.taken.push([x0 as f64 - 1.0, y0 as f64 - 1.0, tw + 2.0, th + 2.0]);
        let s = scale as i64;
        for pass in 0..2 {
            for (k, ch) in text.chars().enumerate() {
                let cx = x0 + k as i64 * (font::GLYPH_W as i64 + 1) * s;
                for gy in 0..font::GLYPH_H {
                    for gx in 0..font::GLYPH_W {
                        if !font::pixel(ch, gx, gy) {
                            continue;
                        }
                        let (px, py) = (cx + gx as i64 * s, y0 + gy as i64 * s);
                        let (grow, c) = if pass == 0 { (1, SHADOW) } else { (0, TEXT) };
                        for j in py - grow..py + s + grow {
                            for i in px - grow..px + s + grow {
                                self.set(i, j, c);
                            }
                        }
                    }
                }
            }
        }
    }

    /// Two lines of text near (x, y), kept inside the frame: to the right of the point when it
    /// fits, else to its left.
    fn label(&mut self, x: f64, y: f64, lines: &[String; 2], scale: u32) {
        let (w0, lh) = Self::text_size(&lines[0], scale);
        let (w1, _) = Self::text_size(&lines[1], scale);
        let (tw, bh) = (w0.max(w1), 2.0 * lh);
        let (fw, fh) = (self.w as f64, self.h as f64);
        let fit = |(lx, ly): (f64, f64)| {
            (
                lx.clamp(2.0, (fw - 2.0 - tw).max(2.0)),
                ly.clamp(2.0, (fh - 2.0 - bh).max(2.0)),
            )
        };
        let hits = |(lx, ly): (f64, f64), r: &[f64; 4]| {
            lx < r[0] + r[2] && r[0] < lx + tw && ly < r[1] + r[3] && r[1] < ly + bh + 2.0
        };
        let gap = MARKER_R + 4.0;
        let marker = [x - gap + 2.0, y - gap + 2.0, 2.0 * gap - 4.0, 2.0 * gap - 4.0];
        let free = |p: (f64, f64)| !hits(p, &marker) && !self.taken.iter().any(|r| hits(p, r));
        // Right of the point, left, below, above; then each of those moved away by one, two, ...
        // label heights, alternately up and down, until one is free (else right of the point).
        let cands = [
            (x + gap, y - lh),
            (x - gap - tw, y - lh),
            (x - 0.5 * tw, y + gap),
            (x - 0.5 * tw, y - gap - bh),
        ]
        .map(fit);
        let step = bh + 3.0;
        let n = (fh / step) as i64 + 1;
        let (lx, ly) = (0..2 * n)
            .flat_map(|k| {
                let dy = if k % 2 == 0 { 1.0 } else { -1.0 } * ((k + 1) / 2) as f64 * step;
                cands.iter().map(move |&(cx, cy)| (cx, cy + dy))
            })
            .find(|&p| p == fit(p) && free(p))
            .unwrap_or(cands[0]);
        self.text(lx, ly, &lines[0], scale);
        self.text(lx, ly + lh, &lines[1], scale);
    }

    /// A filled triangle: tip at (x, y), pointing along the unit (dx, dy).
    fn arrow(&mut self, x: f64, y: f64, dx: f64, dy: f64, c: [u8; 3]) {
        let (bx, by) = (x - ARROW_LEN * dx, y - ARROW_LEN * dy);
        let (nx, ny) = (-dy * 0.5 * ARROW_LEN, dx * 0.5 * ARROW_LEN);
        let tri = [(x, y), (bx + nx, by + ny), (bx - nx, by - ny)];
        let (lo_x, hi_x) = (
            tri.iter().map(|p| p.0).fold(f64::MAX, f64::min),
            tri.iter().map(|p| p.0).fold(f64::MIN, f64::max),
        );
        let (lo_y, hi_y) = (
            tri.iter().map(|p| p.1).fold(f64::MAX, f64::min),
            tri.iter().map(|p| p.1).fold(f64::MIN, f64::max),
        );
        let edge = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0);
        for j in lo_y.floor() as i64 - 1..=hi_y.ceil() as i64 + 1 {
            for i in lo_x.floor() as i64 - 1..=hi_x.ceil() as i64 + 1 {
                let p = (i as f64 + 0.5, j as f64 + 0.5);
                let e = [
                    edge(tri[0], tri[1], p),
                    edge(tri[1], tri[2], p),
                    edge(tri[2], tri[0], p),
                ];
                if e.iter().all(|&v| v >= 0.0) || e.iter().all(|&v| v <= 0.0) {
                    self.set(i, j, c);
                }
            }
        }
    }

    /// The overlay's pixels as copy runs into an output buffer of `out_w` pixels per row, with
    /// the render's rectangle at `origin`: (packed pixels, runs of (first output pixel, first
    /// packed pixel, length)). Pixels are packed RGBA8 (R in the low byte), or BGRA8 when `bgra`.
    pub fn pack(&self, out_w: u32, origin: (u32, u32), bgra: bool) -> (Vec<u32>, Vec<(u64, u64, u64)>) {
        let mut data = Vec::new();
        let mut runs = Vec::new();
        for y in 0..self.h {
            let row = &self.px[(y * self.w) as usize..((y + 1) * self.w) as usize];
            let mut x = 0usize;
            while x < row.len() {
                if row[x].is_none() {
                    x += 1;
                    continue;
                }
                let start = x;
                while x < row.len() && row[x].is_some() {
                    x += 1;
                }
                let dst = (origin.1 + y) as u64 * out_w as u64 + (origin.0 as u64 + start as u64);
                runs.push((dst, data.len() as u64, (x - start) as u64));
                data.extend(row[start..x].iter().map(|c| pack(c.unwrap(), bgra)));
            }
        }
        (data, runs)
    }
}

pub fn pack(c: [u8; 3], bgra: bool) -> u32 {
    let (r, g, b) = (c[0] as u32, c[1] as u32, c[2] as u32);
    let (lo, hi) = if bgra { (b, r) } else { (r, b) };
    lo | (g << 8) | (hi << 16) | (255 << 24)
}

/// The segment a-b clipped to the box [lo, hi] (Liang-Barsky), if any of it is inside.
fn clip(a: (f64, f64), b: (f64, f64), lo: (f64, f64), hi: (f64, f64)) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - lo.0), (dx, hi.0 - a.0), (-dy, a.1 - lo.1), (dy, hi.1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some(((a.0 + t0 * dx, a.1 + t0 * dy), (a.0 + t1 * dx, a.1 + t1 * dy)))
}

/// Where a point goes: a marker inside the frame, an arrow at the edge, or the camera itself.
fn place(cam: &Cam, p: [f64; 3]) -> Placed {
    let l = cam.local(p);
    let dist = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
    if dist < 1e-3 {
        return Placed::AtCamera;
    }
    let (cx, cy) = (0.5 * cam.w, 0.5 * cam.h);
    let t = cam.g.tan_half;
    let (dx, dy) = if l[2] > 1e-9 * dist {
        let (x, y) = cam.pixel(l);
        if x >= 0.0 && x < cam.w && y >= 0.0 && y < cam.h {
            return Placed::Marker { x, y };
        }
        (x - cx, y - cy)
    } else {
        // Behind the camera: the direction it lies in, seen in the image plane.
        (l[0] / (t * cam.w / cam.h) * cx, -l[1] / t * cy)
    };
    let n = (dx * dx + dy * dy).sqrt();
    let (ux, uy) = if n > 0.0 { (dx / n, dy / n) } else { (0.0, 1.0) };
    let sx = if ux != 0.0 {
        (cx - EDGE_INSET) / ux.abs()
    } else {
        f64::MAX
    };
    let sy = if uy != 0.0 {
        (cy - EDGE_INSET) / uy.abs()
    } else {
        f64::MAX
    };
    let s = sx.min(sy).max(0.0);
    Placed::Edge {
        x: cx + s * ux,
        y: cy + s * uy,
        dx: ux,
        dy: uy,
    }
}

/// The set-up overlay of `info` for `camera` (its width and height are the frame's).
pub fn draw(info: &SetupInfo, camera: &Camera) -> Overlay {
    let cam = Cam::new(camera);
    let mut o = Overlay::new(camera.width, camera.height);
    let scale = (camera.height / 500).clamp(1, 4);
    let marks: Vec<Mark> = info
        .points
        .iter()
        .map(|p| {
            let at = if p.directional {
                let q = p.place.xyz;
                let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
                [1e7 * q[0] / n, 1e7 * q[1] / n, 1e7 * q[2] / n]
            } else {
                p.place.xyz
            };
            Mark {
                label: p.label.clone(),
                kind: p.kind,
                placed: place(&cam, at),
            }
        })
        .collect();
    let colour = |k: Kind| if k == Kind::Lamp { LAMP } else { EYE };
    // Labels first, then arrows and discs on top of them.
    let (_, lh) = Overlay::text_size("X", scale);
    o.text(4.0, 4.0, "SET-UP (KEY S): ORIENTATION MARK ON THE +X EDGE", scale);
    let mut legend_y = 4.0 + lh + 2.0;
    for (m, p) in marks.iter().zip(&info.points) {
        if m.placed == Placed::AtCamera {
            let lines = SetupInfo::label_lines(p);
            o.text(4.0, legend_y, &format!("{} (THIS CAMERA)", lines[0]), scale);
            o.text(4.0 + 2.0 * lh, legend_y + lh, &lines[1], scale);
            legend_y += 2.0 * lh + 2.0;
        }
    }
    for (m, p) in marks.iter().zip(&info.points) {
        let lines = SetupInfo::label_lines(p);
        match m.placed {
            Placed::Marker { x, y } => o.label(x, y, &lines, scale),
            Placed::Edge { x, y, dx, dy } => o.label(x - 24.0 * dx, y - 24.0 * dy, &lines, scale),
            Placed::AtCamera => {}
        }
    }
    // The +x edge of the plate (over the labels), clipped to the space in front of the camera,
    // with "+X" beside its middle, on the side away from the plate.
    let hp = info.half_plate_mm;
    let at = |x: f64, y: f64| cam.local(info.shape.to_world([x, y]));
    let (mid, out) = (at(hp, 0.0), at(1.1 * hp, 0.0));
    if mid[2] >= NEAR_MM && out[2] >= NEAR_MM {
        let ((mx, my), (ox, oy)) = (cam.pixel(mid), cam.pixel(out));
        let n = (ox - mx).hypot(oy - my).max(1e-9);
        let (tw, th) = Overlay::text_size("+X", scale);
        let d = 6.0 + 0.5 * tw.hypot(th);
        o.text(
            mx + d * (ox - mx) / n - 0.5 * tw,
            my + d * (oy - my) / n - 0.5 * th,
            "+X",
            scale,
        );
    }
    // (In pieces: on a sheet bent about its x axis the edge is an arc.)
    let pieces = if info.shape.is_flat() { 1 } else { 32 };
    for k in 0..pieces {
        let y = |i: usize| -hp + 2.0 * hp * i as f64 / pieces as f64;
        let (a, b) = (at(hp, y(k)), at(hp, y(k + 1)));
        if a[2] >= NEAR_MM || b[2] >= NEAR_MM {
            let cut = |p: [f64; 3], q: [f64; 3]| {
                if p[2] >= NEAR_MM {
                    p
                } else {
                    let t = (NEAR_MM - p[2]) / (q[2] - p[2]);
                    [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), NEAR_MM]
                }
            };
            o.line(cam.pixel(cut(a, b)), cam.pixel(cut(b, a)), 1.5, MARK);
        }
    }
    for m in &marks {
        match m.placed {
            Placed::Marker { x, y } => {
                o.disc(x, y, MARKER_R + 1.5, SHADOW);
                o.disc(x, y, MARKER_R, colour(m.kind));
            }
            Placed::Edge { x, y, dx, dy } => o.arrow(x, y, dx, dy, colour(m.kind)),
            Placed::AtCamera => {}
        }
    }
    o.marks = marks;
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(eye: [f64; 3], w: u32, h: u32) -> Camera {
        Camera {
            eye,
            target: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            fov_y_deg: 40.0,
            width: w,
            height: h,
        }
    }

    #[test]
    fn every_colour_is_not_grey() {
        for c in [LAMP, EYE, MARK, TEXT, SHADOW] {
            assert!(c[0] != c[1] || c[1] != c[2], "{c:?} is grey");
        }
        assert_eq!(pack([1, 2, 3], false), 0xff03_0201);
        assert_eq!(pack([1, 2, 3], true), 0xff01_0203);
    }

    #[test]
    fn points_in_front_behind_and_outside() {
        let c = Cam::new(&cam([0.0, -300.0, 300.0], 200, 100));
        // The target projects to the frame's centre.
        assert_eq!(place(&c, [0.0; 3]), Placed::Marker { x: 100.0, y: 50.0 });
        // Far to the camera's right: an arrow on the right edge, pointing right.
        match place(&c, [5000.0, 0.0, 0.0]) {
            Placed::Edge { x, dx, .. } => assert!((x - (200.0 - EDGE_INSET)).abs() < 1e-9 && dx > 0.9),
            p => panic!("{p:?}"),
        }
        // Behind the camera and to its left (seen from the camera): arrow on the left edge.
        match place(&c, [-2000.0, -600.0, 600.0]) {
            Placed::Edge { x, dx, .. } => assert!((x - EDGE_INSET).abs() < 1e-9 && dx < -0.9, "{x} {dx}"),
            p => panic!("{p:?}"),
        }
        assert_eq!(place(&c, [0.0, -300.0, 300.0]), Placed::AtCamera);
    }

    #[test]
    fn runs_cover_exactly_the_drawn_pixels() {
        let mut o = Overlay::new(30, 20);
        o.disc(10.0, 10.0, 3.0, LAMP);
        o.text(15.0, 2.0, "AZ 1°", 1);
        let (data, runs) = o.pack(40, (5, 7), true);
        let mut covered = vec![None; 40 * 30];
        for (dst, src, n) in runs {
            for k in 0..n {
                assert!(covered[(dst + k) as usize].is_none());
                covered[(dst + k) as usize] = Some(data[(src + k) as usize]);
            }
        }
        for y in 0..30u32 {
            for x in 0..40u32 {
                let inside = (5..35).contains(&x) && (7..27).contains(&y);
                let want = inside.then(|| o.get(x - 5, y - 7)).flatten().map(|c| pack(c, true));
                assert_eq!(covered[(y * 40 + x) as usize], want, "({x}, {y})");
            }
        }
    }
}
