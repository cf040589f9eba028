//! `setup.png`, the set-up sheet as a drawing: the plate, the lamps and the eyes from above and
//! from the side at one stated scale, with distances marked, and how each view's correlation
//! falls as the lamp or the eye moves. Labels are placed so that none overlaps another, a mark,
//! a panel's edge or a chart: each tries places around its point and, where none is free, is left
//! to the key below the drawing, which lists every lamp and eye with its numbers.
use std::path::Path;

use plotters::prelude::*;

use crate::tolerance::{Place, Sensitivity};
use scratchart_model::scene::{LightKind, Scene};
use scratchart_model::surface::{BendAxis, PlateShape};
use scratchart_optim::error::OptimError;

/// A placed text's box in image pixels: [x0, y0, x1, y1] (x1, y1 exclusive).
pub type Rect = [i32; 4];

/// Where the drawing put its texts, for tests: every label and key line with its box.
#[derive(Clone, Debug, Default)]
pub struct Layout {
    pub size: (u32, u32),
    pub texts: Vec<(String, Rect)>,
    /// Labels that found no free place (listed in the key instead).
    pub unplaced: Vec<String>,
    /// The scale of both views, millimetres per pixel.
    pub mm_per_px: f64,
    /// The charts' plotting areas (no label may enter them).
    pub charts: Vec<Rect>,
    /// Everything drawn that a text must not cover: marks, the plate, the scale bar, the charts.
    pub obstacles: Vec<Rect>,
    /// Where the side view drew each lamp's and eye's mark (by name): apart even where several
    /// stand at one height and distance (at different azimuths).
    pub side_marks: Vec<(String, (i32, i32))>,
}

fn overlaps(a: &Rect, b: &Rect) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

fn inside(a: &Rect, area: &Rect) -> bool {
    a[0] >= area[0] && a[1] >= area[1] && a[2] <= area[2] && a[3] <= area[3]
}

/// The view colours (cycling).
const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];
const LAMP: RGBColor = RGBColor(230, 150, 0);
const MARK: RGBColor = RGBColor(200, 0, 0);

pub fn view_colour(j: usize) -> RGBColor {
    PALETTE[j % PALETTE.len()]
}

/// A "nice" scale at least `need` mm per pixel.
fn nice_scale(need: f64) -> f64 {
    let mut m = 1e-3;
    loop {
        for k in [1.0, 2.0, 2.5, 5.0] {
            if k * m >= need {
                return k * m;
            }
        }
        m *= 10.0;
    }
}

/// A "nice" length near `about` mm, for the scale bar and the rings.
fn nice_length(about: f64) -> f64 {
    let m = 10f64.powf(about.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|k| k * m)
        .find(|&l| l <= about)
        .unwrap_or(m)
}

/// Text measuring and collision-free placing on the image.
struct Placer<'a, 'b> {
    root: &'a DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>,
    taken: Vec<Rect>,
    layout: Layout,
}

impl<'a, 'b> Placer<'a, 'b> {
    fn size(&self, text: &str, px: u32) -> (i32, i32) {
        let style: TextStyle = ("sans-serif", px).into_font().into();
        self.root
            .estimate_text_size(text, &style)
            .map(|(w, h)| (w as i32, h as i32))
            .unwrap_or((text.len() as i32 * px as i32 / 2, px as i32))
    }

    /// Draws `text` with its top-left corner at `at` unconditionally (titles, key lines) and
    /// records its box.
    fn put(&mut self, text: &str, at: (i32, i32), px: u32, colour: RGBColor) -> Result<Rect, String> {
        let (w, h) = self.size(text, px);
        let r = [at.0, at.1, at.0 + w, at.1 + h];
        self.root
            .draw(&Text::new(
                text.to_string(),
                at,
                ("sans-serif", px).into_font().color(&colour),
            ))
            .map_err(|e| e.to_string())?;
        self.taken.push(r);
        self.layout.texts.push((text.to_string(), r));
        Ok(r)
    }

    /// Places `text` near the point `p` inside `area`, on the first free spot of a ring of
    /// candidates at growing distances; returns false (and draws nothing) where none is free.
    fn label(&mut self, text: &str, p: (i32, i32), px: u32, colour: RGBColor, area: Rect) -> Result<bool, String> {
        let (w, h) = self.size(text, px);
        for gap in [8, 16, 28] {
            let spots = [
                (p.0 + gap, p.1 - h / 2),
                (p.0 - gap - w, p.1 - h / 2),
                (p.0 - w / 2, p.1 - gap - h),
                (p.0 - w / 2, p.1 + gap),
                (p.0 + gap, p.1 - gap - h),
                (p.0 + gap, p.1 + gap),
                (p.0 - gap - w, p.1 - gap - h),
                (p.0 - gap - w, p.1 + gap),
            ];
            for at in spots {
                let r = [at.0, at.1, at.0 + w, at.1 + h];
                if inside(&r, &area) && !self.taken.iter().any(|t| overlaps(t, &r)) {
                    self.put(text, at, px, colour)?;
                    return Ok(true);
                }
            }
        }
        self.layout.unplaced.push(text.to_string());
        Ok(false)
    }

    /// Marks a region as taken (a marker, a chart) without drawing.
    fn block(&mut self, r: Rect) {
        self.taken.push(r);
        self.layout.obstacles.push(r);
    }
}

/// One thing drawn in both views.
struct Item {
    name: String,
    xyz: [f64; 3],
    colour: RGBColor,
    lamp: bool,
    /// A directional lamp: `xyz` is a direction, drawn at the edge of the view.
    direction: bool,
}

fn items(scene: &Scene) -> Vec<Item> {
    let mut out = Vec::new();
    let lamps = scene.lamps();
    for lamp in &lamps {
        let (xyz, direction) = match &lamp.kind {
            LightKind::Point { position } => (*position, false),
            LightKind::Directional { direction } => (*direction, true),
        };
        out.push(Item {
            name: if lamps.len() == 1 {
                "lamp".into()
            } else {
                format!("lamp ({})", lamp.name)
            },
            xyz,
            colour: LAMP,
            lamp: true,
            direction,
        });
    }
    for (j, v) in scene.views.iter().enumerate() {
        out.push(Item {
            name: v.name.clone(),
            xyz: v.camera.eye,
            colour: view_colour(j),
            lamp: false,
            direction: false,
        });
    }
    out
}

fn dashed(
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    a: (i32, i32),
    b: (i32, i32),
    style: ShapeStyle,
) -> Result<(), String> {
    let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
    let len = dx.hypot(dy);
    let n = (len / 6.0).floor() as i32;
    for k in (0..n).step_by(2) {
        let t0 = k as f64 * 6.0 / len;
        let t1 = ((k + 1) as f64 * 6.0 / len).min(1.0);
        let p = |t: f64| (a.0 + (dx * t) as i32, a.1 + (dy * t) as i32);
        root.draw(&PathElement::new(vec![p(t0), p(t1)], style))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Draws the sheet into `path` and returns where its texts went.
pub fn setup_png(path: &Path, scene: &Scene, sens: &Sensitivity) -> Result<Layout, OptimError> {
    let (wpx, hpx) = (1400u32, 940u32);
    let mut buf = vec![255u8; (wpx * hpx * 3) as usize];
    let layout =
        draw(&mut buf, (wpx, hpx), scene, sens).map_err(|e| OptimError::Report(format!("set-up sheet: {e}")))?;
    super::report::write_rgb_png(path, wpx, hpx, buf)?;
    Ok(layout)
}

/// The sheet's panels (image pixels: top view, side view, key; the two charts on the right)
/// and the one scale (mm per pixel) both views are drawn to.
struct Panels {
    top: Rect,
    side: Rect,
    key: Rect,
    charts: [Rect; 2],
    mmpp: f64,
    /// Half the plate's side (mm).
    half: f64,
    /// The furthest lamp or eye from the centre along x or y (mm), at least `half`.
    reach: f64,
    /// The plate's shape: a bent sheet is drawn as it stands.
    shape: PlateShape,
}

impl Panels {
    /// One scale for both views: everything (a directional lamp at the edge) fits either.
    fn new(scene: &Scene, items: &[Item], hpx: u32) -> Panels {
        let half = scene.plate.size_mm / 2.0;
        let top: Rect = [20, 40, 700, 470];
        let side: Rect = [20, 510, 700, 760];
        let key: Rect = [20, 775, 700, hpx as i32 - 5];
        let charts = [[760, 40, 1390, 430], [760, 480, 1390, 870]];
        let points = || items.iter().filter(|i| !i.direction);
        let reach = points()
            .map(|i| i.xyz[0].abs().max(i.xyz[1].abs()))
            .fold(half, f64::max);
        let radial = points().map(|i| i.xyz[0].hypot(i.xyz[1])).fold(half, f64::max);
        let height = points().map(|i| i.xyz[2]).fold(half, f64::max);
        let (tw, th) = ((top[2] - top[0] - 60) as f64, (top[3] - top[1] - 60) as f64);
        let (sw, sh) = ((side[2] - side[0] - 60) as f64, (side[3] - side[1] - 50) as f64);
        let mmpp = nice_scale(
            (2.0 * reach / tw)
                .max(2.0 * reach / th)
                .max((radial + half) / sw)
                .max(height / sh),
        );
        Panels {
            top,
            side,
            key,
            charts,
            mmpp,
            half,
            reach,
            shape: scene.plate.shape,
        }
    }

    /// The plate seen from above, half its extent along x and y in pixels: a bent sheet's
    /// wrapped side is its chord's (or its diameter's, past half a turn).
    fn plate_px_xy(&self) -> (i32, i32) {
        let px = |mm: f64| (mm / self.mmpp).round() as i32;
        match self.shape {
            PlateShape::Flat => (px(self.half), px(self.half)),
            PlateShape::Cylinder { radius_mm, axis, .. } => {
                let wrapped = radius_mm * (self.half / radius_mm).min(0.5 * std::f64::consts::PI).sin();
                match axis {
                    BendAxis::Y => (px(wrapped), px(self.half)),
                    BendAxis::X => (px(self.half), px(wrapped)),
                }
            }
        }
    }

    /// A bent sheet's profile across its bend, as the side view draws it: (distance from the
    /// centre along the wrapped axis, height), mm; None for a flat plate.
    fn bend_profile(&self) -> Option<Vec<(f64, f64)>> {
        let PlateShape::Cylinder {
            radius_mm: r, convex, ..
        } = self.shape
        else {
            return None;
        };
        let s = if convex { 1.0 } else { -1.0 };
        let a = self.half / r;
        Some(
            (0..=64)
                .map(|k| {
                    let t = -a + 2.0 * a * k as f64 / 64.0;
                    (r * t.sin(), -s * r * (1.0 - t.cos()))
                })
                .collect(),
        )
    }

    /// The plate's half side in pixels.
    fn plate_px(&self) -> i32 {
        (self.half / self.mmpp).round() as i32
    }
}

mod charts;
use charts::draw_chart;

fn draw(buf: &mut [u8], (wpx, hpx): (u32, u32), scene: &Scene, sens: &Sensitivity) -> Result<Layout, String> {
    let root = BitMapBackend::with_buffer(buf, (wpx, hpx)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    super::report::plot_font();
    let mut pl = Placer {
        root: &root,
        taken: Vec::new(),
        layout: Layout {
            size: (wpx, hpx),
            ..Layout::default()
        },
    };
    let items = items(scene);
    let panels = Panels::new(scene, &items, hpx);
    pl.layout.mm_per_px = panels.mmpp;
    draw_top_view(&mut pl, &panels, &items)?;
    draw_side_view(&mut pl, &panels, &items)?;
    for (moved, area) in [("lamp", panels.charts[0]), ("eye", panels.charts[1])] {
        draw_chart(&mut pl, scene, sens, moved, area)?;
    }
    draw_key(&mut pl, &panels, &items)?;
    root.present().map_err(|e| e.to_string())?;
    Ok(pl.layout)
}

/// A lamp's or an eye's mark at `p`: lamps larger and outlined.
fn draw_mark(pl: &mut Placer, it: &Item, p: (i32, i32)) -> Result<(), String> {
    let rad = if it.lamp { 8 } else { 6 };
    pl.root
        .draw(&Circle::new(p, rad, it.colour.filled()))
        .map_err(|e| e.to_string())?;
    if it.lamp {
        pl.root
            .draw(&Circle::new(p, rad, BLACK.stroke_width(1)))
            .map_err(|e| e.to_string())?;
    }
    pl.block([p.0 - rad, p.1 - rad, p.0 + rad + 1, p.1 + rad + 1]);
    Ok(())
}

/// The top view: the plate face up with its +x mark, range rings, a scale bar, and every lamp
/// and eye at its place (a directional lamp where its direction crosses the panel's edge).
fn draw_top_view(pl: &mut Placer, panels: &Panels, items: &[Item]) -> Result<(), String> {
    let (top, mmpp, reach) = (panels.top, panels.mmpp, panels.reach);
    let root = pl.root;
    pl.put(
        "Top view (plate face up; azimuth from +x towards +y)",
        (top[0], 12),
        16,
        BLACK,
    )?;
    let c = ((top[0] + top[2]) / 2, (top[1] + top[3]) / 2);
    let to_px = |x: f64, y: f64| (c.0 + (x / mmpp).round() as i32, c.1 - (y / mmpp).round() as i32);
    root.draw(&Rectangle::new([(top[0], top[1]), (top[2], top[3])], BLACK.mix(0.3)))
        .map_err(|e| e.to_string())?;
    // range rings every nice distance, labelled
    let ring = nice_length(reach / 2.0);
    let mut r = ring;
    while r <= reach * 1.5 {
        let rp = (r / mmpp).round() as i32;
        root.draw(&Circle::new(c, rp, RGBColor(200, 200, 200).stroke_width(1)))
            .map_err(|e| e.to_string())?;
        r += ring;
    }
    let (plate_px, plate_py) = panels.plate_px_xy();
    let plate_r = [c.0 - plate_px, c.1 - plate_py, c.0 + plate_px, c.1 + plate_py];
    root.draw(&Rectangle::new(
        [(plate_r[0], plate_r[1]), (plate_r[2], plate_r[3])],
        RGBColor(120, 120, 120).filled(),
    ))
    .map_err(|e| e.to_string())?;
    pl.block(plate_r);
    // the +x mark on the plate's +x edge
    let mark = [plate_r[2] - 2, c.1 - 8, plate_r[2] + 4, c.1 + 8];
    root.draw(&Rectangle::new([(mark[0], mark[1]), (mark[2], mark[3])], MARK.filled()))
        .map_err(|e| e.to_string())?;
    pl.block(mark);
    let top_in = [top[0] + 2, top[1] + 2, top[2] - 2, top[3] - 2];
    // scale bar, bottom left
    let bar_mm = nice_length(reach / 2.0);
    let bar_px = (bar_mm / mmpp).round() as i32;
    let by = top[3] - 14;
    root.draw(&PathElement::new(
        vec![(top[0] + 10, by), (top[0] + 10 + bar_px, by)],
        BLACK.stroke_width(2),
    ))
    .map_err(|e| e.to_string())?;
    for x in [top[0] + 10, top[0] + 10 + bar_px] {
        root.draw(&PathElement::new(vec![(x, by - 4), (x, by + 4)], BLACK.stroke_width(2)))
            .map_err(|e| e.to_string())?;
    }
    pl.block([top[0] + 6, by - 6, top[0] + 14 + bar_px, by + 6]);
    pl.put(
        &format!("{bar_mm} mm; rings every {ring} mm"),
        (top[0] + 16 + bar_px, by - 8),
        13,
        BLACK,
    )?;
    // marks first (so labels avoid all of them), then labels
    let mut marks = Vec::new();
    for it in items {
        let p = if it.direction {
            // a direction: drawn where it crosses the panel's edge
            let (dx, dy) = (it.xyz[0], it.xyz[1]);
            let n = dx.hypot(dy).max(1e-9);
            let rr = ((top[2] - top[0]).min(top[3] - top[1]) / 2 - 20) as f64;
            (c.0 + (dx / n * rr) as i32, c.1 - (dy / n * rr) as i32)
        } else {
            to_px(it.xyz[0], it.xyz[1])
        };
        draw_mark(pl, it, p)?;
        marks.push(p);
    }
    // Labels after every mark, so that none covers one.
    pl.label("+x mark", (mark[2], c.1), 13, MARK, top_in)?;
    for (it, &p) in items.iter().zip(&marks) {
        let q = Place::of(it.xyz);
        let t = format!("{} az {:.0} deg", it.name, q.azimuth_deg);
        pl.label(&t, p, 13, it.colour, top_in)?;
    }
    Ok(())
}

/// The side view: height against horizontal distance from the plate centre, all azimuths, a
/// dashed line from the centre to each lamp and eye.
fn draw_side_view(pl: &mut Placer, panels: &Panels, items: &[Item]) -> Result<(), String> {
    let (side, mmpp, plate_px) = (panels.side, panels.mmpp, panels.plate_px());
    let root = pl.root;
    pl.put(
        "Side view (height against distance from the plate centre, all azimuths; marks at one place side by side)",
        (side[0], side[1] - 26),
        14,
        BLACK,
    )?;
    root.draw(&Rectangle::new(
        [(side[0], side[1]), (side[2], side[3])],
        BLACK.mix(0.3),
    ))
    .map_err(|e| e.to_string())?;
    let o = (side[0] + 30 + plate_px, side[3] - 30);
    let sp = |d: f64, z: f64| (o.0 + (d / mmpp).round() as i32, o.1 - (z / mmpp).round() as i32);
    let plate_s = [o.0 - plate_px, o.1 - 2, o.0 + plate_px, o.1 + 3];
    match panels.bend_profile() {
        // A bent sheet: its profile across the bend, as it stands.
        Some(profile) => {
            let pts: Vec<(i32, i32)> = profile.iter().map(|&(d, z)| sp(d, z)).collect();
            let (lo, hi) = pts.iter().fold((pts[0], pts[0]), |(lo, hi), p| {
                ((lo.0.min(p.0), lo.1.min(p.1)), (hi.0.max(p.0), hi.1.max(p.1)))
            });
            root.draw(&PathElement::new(pts, RGBColor(120, 120, 120).stroke_width(4)))
                .map_err(|e| e.to_string())?;
            pl.block([lo.0 - 2, lo.1 - 2, hi.0 + 2, hi.1 + 2]);
        }
        None => {
            root.draw(&Rectangle::new(
                [(plate_s[0], plate_s[1]), (plate_s[2], plate_s[3])],
                RGBColor(120, 120, 120).filled(),
            ))
            .map_err(|e| e.to_string())?;
            pl.block(plate_s);
        }
    }
    root.draw(&PathElement::new(
        vec![(side[0] + 2, o.1 + 3), (side[2] - 2, o.1 + 3)],
        BLACK.mix(0.4),
    ))
    .map_err(|e| e.to_string())?;
    let side_in = [side[0] + 2, side[1] + 2, side[2] - 2, side[3] - 2];
    let mut smarks = Vec::new();
    for it in items {
        let q = Place::of(it.xyz);
        let p = if it.direction {
            let rr = ((side[3] - side[1]) - 60) as f64;
            let e = q.elevation_deg.to_radians();
            (o.0 + (rr * e.cos()) as i32, o.1 - (rr * e.sin()) as i32)
        } else {
            sp(it.xyz[0].hypot(it.xyz[1]), it.xyz[2])
        };
        dashed(root, o, p, it.colour.mix(0.6).stroke_width(1))?;
        // Marks at one place (eyes at one height and distance, other azimuths) drawn side by
        // side, each joined to the place by a short line.
        let at = apart(p, &smarks, it.direction.then_some(o));
        if at != p {
            root.draw(&PathElement::new(vec![p, at], it.colour.stroke_width(1)))
                .map_err(|e| e.to_string())?;
        }
        draw_mark(pl, it, at)?;
        smarks.push(at);
        pl.layout.side_marks.push((it.name.clone(), at));
    }
    for (it, &p) in items.iter().zip(&smarks) {
        let q = Place::of(it.xyz);
        let t = if it.direction {
            format!("{} from {:.0} deg up", it.name, q.elevation_deg)
        } else {
            format!("{} {:.0} mm, {:.0} deg up", it.name, q.distance_mm, q.elevation_deg)
        };
        pl.label(&t, p, 13, it.colour, side_in)?;
    }
    Ok(())
}

/// Where a mark for `p` goes so that it keeps clear of the marks already drawn (`taken`): `p`
/// itself where it is free, else the nearest free spot on rings around it (away from `from`,
/// the origin of a direction's ray, where it has one).
fn apart(p: (i32, i32), taken: &[(i32, i32)], from: Option<(i32, i32)>) -> (i32, i32) {
    const CLEAR: i32 = 18;
    let free = |q: (i32, i32)| {
        taken
            .iter()
            .all(|t| (t.0 - q.0).abs() >= CLEAR || (t.1 - q.1).abs() >= CLEAR)
    };
    if free(p) {
        return p;
    }
    let away = from.map_or(0.0, |o| ((o.1 - p.1) as f64).atan2((p.0 - o.0) as f64));
    for ring in 1..=6 {
        let r = (CLEAR * ring) as f64;
        let n = 8 * ring;
        for k in 0..n {
            // alternate either side of the first direction: 0, +1, -1, +2, ...
            let step = if k % 2 == 0 {
                (k / 2) as f64
            } else {
                -(((k + 1) / 2) as f64)
            };
            let a = away + step * std::f64::consts::TAU / n as f64;
            let q = (p.0 + (r * a.cos()).round() as i32, p.1 - (r * a.sin()).round() as i32);
            if free(q) {
                return q;
            }
        }
    }
    p
}

/// The key: the scale, then every lamp and eye with its numbers; labels that found no place in
/// the drawing say so, and what does not fit is left to setup.txt.
fn draw_key(pl: &mut Placer, panels: &Panels, items: &[Item]) -> Result<(), String> {
    let key = panels.key;
    let scale_text = format!("scale: 1 px = {} mm (both views)", panels.mmpp);
    pl.put(&scale_text, (key[0], key[1]), 13, BLACK)?;
    let mut y = key[1] + 20;
    let total = items.len();
    for (shown, it) in items.iter().enumerate() {
        let q = Place::of(it.xyz);
        let crowded = pl
            .layout
            .unplaced
            .iter()
            .any(|u| u.starts_with(&format!("{} ", it.name)));
        let line = if it.direction {
            format!(
                "{}: from azimuth {:.1} deg, elevation {:.1} deg (a direction){}",
                it.name,
                q.azimuth_deg,
                q.elevation_deg,
                if crowded { "; not labelled in the drawing" } else { "" }
            )
        } else {
            format!(
                "{}: azimuth {:.1} deg, elevation {:.1} deg, {:.0} mm from the plate centre (x {:.0}, y {:.0}, z {:.0}){}",
                it.name,
                q.azimuth_deg,
                q.elevation_deg,
                q.distance_mm,
                q.xyz[0],
                q.xyz[1],
                q.xyz[2],
                if crowded { "; not labelled in the drawing" } else { "" }
            )
        };
        let (_, h) = pl.size(&line, 12);
        if y + 2 * h + 2 > key[3] && shown + 1 < total {
            pl.put(
                &format!("... and {} more: setup.txt lists every lamp and eye", total - shown),
                (key[0], y),
                12,
                BLACK,
            )?;
            break;
        }
        pl.put(&line, (key[0], y), 12, it.colour)?;
        y += h + 2;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
