//! The toolpath picture `plan` writes beside the G-code (`plan.png`): the plate from above to
//! scale (+x to the right, +y up, X0 Y0 at its centre) with a scale bar; each cut coloured by its
//! commanded depth, with the legend; the travel between cuts (faint); the first and the last cut;
//! the +x orientation mark; the registration marks' hatches (orange); and a title with the machine, the tool and the estimated time. A
//! maker reads it without the README.
use std::path::Path;

use anyhow::Result;
use plotters::prelude::*;
use scratchart_machine::plan::{Block, Label};

/// What the title says.
pub struct Caption {
    /// The plan's file name.
    pub plan: String,
    /// The machine ("GRBL router, built-in profile").
    pub machine: String,
    /// The tool, or where the depths came from.
    pub tool: String,
    /// The job time by the profile's rates, s.
    pub seconds: f64,
}

const W: u32 = 1300;
const H: u32 = 980;
/// The plate's square: left, top, side (px).
const PX: i32 = 50;
const PY: i32 = 90;
const SIDE: i32 = 800;

const TRAVEL: RGBColor = RGBColor(200, 200, 200);
const FIRST: RGBColor = RGBColor(0, 150, 60);
const LAST: RGBColor = RGBColor(210, 30, 30);
const INK: RGBColor = RGBColor(40, 40, 40);
/// The registration marks' hatch lines: a colour the depth scale (viridis) never takes.
const REGISTRATION: RGBColor = RGBColor(235, 110, 0);

fn pe<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("toolpath picture: {e:?}")
}

/// A round length for a scale bar about a fifth of `span` (1, 2 or 5 times a power of ten), mm.
pub fn scale_bar_mm(span: f64) -> f64 {
    let target = span / 5.0;
    let p = 10f64.powf(target.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .rfind(|&v| v <= target * 1.0001)
        .unwrap_or(p)
}

/// A block's commanded depth below the surface, mm (its deepest point).
fn depth(b: &Block) -> f64 {
    -b.path.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min)
}

/// Viridis at nine points (dark blue to yellow): readable in grey and by most colour-blind eyes.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 45, 123),
    (59, 82, 139),
    (44, 114, 142),
    (33, 145, 140),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

/// The colour of depth `d` on a range `lo..hi` (viridis: shallow dark blue, deep yellow).
fn colour(d: f64, lo: f64, hi: f64) -> RGBColor {
    let t = if hi - lo < 1e-12 {
        0.5
    } else {
        ((d - lo) / (hi - lo)).clamp(0.0, 1.0)
    };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |p: u8, q: u8| (p as f64 + f * (q as f64 - p as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The picture being drawn: its drawing area, whether a font is at hand (without one, texts
/// are left out), and the plate's side in mm (for the plate-to-pixel map).
struct Picture<'a, 'b> {
    root: &'a DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>,
    font: bool,
    plate_mm: f64,
}

impl Picture<'_, '_> {
    fn text(&self, t: &str, at: (i32, i32), size: i32, c: &RGBColor) -> Result<()> {
        if self.font {
            self.root
                .draw(&Text::new(t.to_string(), at, ("sans-serif", size).into_font().color(c)))
                .map_err(pe)?;
        }
        Ok(())
    }

    /// Words over the drawing, on a white ground so that cuts under them do not hide them.
    fn label(&self, t: &str, at: (i32, i32), c: &RGBColor) -> Result<()> {
        if self.font {
            let w = (t.chars().count() as f64 * 7.6).ceil() as i32;
            self.root
                .draw(&Rectangle::new(
                    [(at.0 - 2, at.1 - 1), (at.0 + w, at.1 + 17)],
                    WHITE.mix(0.85).filled(),
                ))
                .map_err(pe)?;
        }
        self.text(t, at, 15, c)
    }

    /// A point of the plate (mm, +y up) in image pixels.
    fn to(&self, p: [f64; 2]) -> (i32, i32) {
        (
            PX + ((p[0] / self.plate_mm + 0.5) * SIDE as f64).round() as i32,
            PY + ((0.5 - p[1] / self.plate_mm) * SIDE as f64).round() as i32,
        )
    }

    fn line(&self, pts: Vec<(i32, i32)>, style: ShapeStyle) -> Result<()> {
        self.root.draw(&PathElement::new(pts, style)).map_err(pe)
    }
}

fn xy(p: &[f64; 3]) -> [f64; 2] {
    [p[0], p[1]]
}

/// Writes the picture of `blocks` (in cut order) on a `plate_mm` plate.
pub fn write(path: &Path, blocks: &[Block], plate_mm: f64, cap: &Caption) -> Result<()> {
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let pic = Picture {
            root: &root,
            font: scratchart_design::report::plot_font().is_some(),
            plate_mm,
        };
        let cuts: Vec<&Block> = blocks.iter().filter(|b| matches!(b.label, Label::Scratch(_))).collect();
        let (lo, hi) = cuts
            .iter()
            .map(|b| depth(b))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| (a.min(d), b.max(d)));
        let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (0.0, 0.0) };
        draw_title(&pic, cap, cuts.len())?;
        draw_plate(&pic, blocks, &cuts, (lo, hi))?;
        draw_axes_and_scale(&pic)?;
        draw_legend(&pic, cuts.len(), (lo, hi))?;
        root.present().map_err(pe)?;
    }
    scratchart_render::io::write_png_rgb(path, W, H, &buf)?;
    Ok(())
}

/// The title: the plan, the number of cuts, the machine, the tool and the time.
fn draw_title(pic: &Picture, cap: &Caption, cuts: usize) -> Result<()> {
    pic.text(
        &format!(
            "{}: {} cuts on a {} mm plate, seen from above",
            cap.plan, cuts, pic.plate_mm
        ),
        (PX, 12),
        24,
        &BLACK,
    )?;
    pic.text(
        &format!(
            "machine: {}   tool: {}   estimated time: {:.1} min",
            cap.machine,
            cap.tool,
            cap.seconds / 60.0
        ),
        (PX, 46),
        17,
        &INK,
    )
}

/// The plate seen from above: travel between cuts, the cuts coloured by depth (`lo..hi`), the
/// registration marks' hatches, the work zero, the first and the last cut, and the +x mark.
fn draw_plate(pic: &Picture, blocks: &[Block], cuts: &[&Block], (lo, hi): (f64, f64)) -> Result<()> {
    let root = pic.root;
    root.draw(&Rectangle::new(
        [(PX, PY), (PX + SIDE, PY + SIDE)],
        ShapeStyle::from(&INK).stroke_width(1),
    ))
    .map_err(pe)?;
    // Travel between cuts (rapids above the plate), from and back to X0 Y0.
    let mut at = [0.0, 0.0];
    for b in blocks {
        pic.line(vec![pic.to(at), pic.to(xy(&b.path[0]))], TRAVEL.into())?;
        at = xy(&b.path[b.path.len() - 1]);
    }
    pic.line(vec![pic.to(at), pic.to([0.0, 0.0])], TRAVEL.into())?;
    // Cuts by depth.
    for b in cuts {
        let c = colour(depth(b), lo, hi);
        let pts: Vec<(i32, i32)> = b.moves(0.01).iter().map(|p| pic.to(xy(p))).collect();
        pic.line(pts, ShapeStyle::from(&c).stroke_width(2))?;
    }
    for b in blocks.iter().filter(|b| matches!(b.label, Label::Registration { .. })) {
        let pts: Vec<(i32, i32)> = b.moves(0.01).iter().map(|p| pic.to(xy(p))).collect();
        pic.line(pts, ShapeStyle::from(&REGISTRATION).stroke_width(1))?;
    }
    // The work zero.
    let z = pic.to([0.0, 0.0]);
    pic.line(vec![(z.0 - 6, z.1), (z.0 + 6, z.1)], INK.into())?;
    pic.line(vec![(z.0, z.1 - 6), (z.0, z.1 + 6)], INK.into())?;
    // First and last cut.
    if let (Some(f), Some(l)) = (cuts.first(), cuts.last()) {
        let p = pic.to(xy(&f.path[0]));
        root.draw(&Circle::new(p, 7, ShapeStyle::from(&FIRST).stroke_width(3)))
            .map_err(pe)?;
        pic.label(&format!("first ({})", f.label), (p.0 + 10, p.1 - 24), &FIRST)?;
        let q = pic.to(xy(&l.path[l.path.len() - 1]));
        root.draw(&Rectangle::new(
            [(q.0 - 6, q.1 - 6), (q.0 + 6, q.1 + 6)],
            ShapeStyle::from(&LAST).stroke_width(3),
        ))
        .map_err(pe)?;
        pic.label(&format!("last ({})", l.label), (q.0 + 10, q.1 + 6), &LAST)?;
    }
    // The +x mark: thick, with an arrow head pointing +x.
    for b in blocks.iter().filter(|b| b.label == Label::Mark) {
        let (a, e) = (pic.to(xy(&b.path[0])), pic.to(xy(&b.path[b.path.len() - 1])));
        pic.line(vec![a, e], ShapeStyle::from(&BLACK).stroke_width(4))?;
        for dy in [-9, 9] {
            pic.line(vec![e, (e.0 - 9, e.1 + dy)], ShapeStyle::from(&BLACK).stroke_width(3))?;
        }
        pic.label("+x mark", (a.0 - 20, a.1 + 12), &BLACK)?;
    }
    Ok(())
}

/// Axes beside the plate (+x to the right, +y up) and a scale bar under it.
fn draw_axes_and_scale(pic: &Picture) -> Result<()> {
    let (ax, ay) = (PX + SIDE + 12, PY + SIDE);
    pic.line(vec![(ax, ay), (ax + 40, ay)], ShapeStyle::from(&INK).stroke_width(2))?;
    pic.line(vec![(ax, ay), (ax, ay - 40)], ShapeStyle::from(&INK).stroke_width(2))?;
    pic.text("+x", (ax + 44, ay - 8), 15, &INK)?;
    pic.text("+y", (ax - 8, ay - 60), 15, &INK)?;
    let bar = scale_bar_mm(pic.plate_mm);
    let len = (bar / pic.plate_mm * SIDE as f64).round() as i32;
    let (bx, by) = (PX, PY + SIDE + 24);
    pic.root
        .draw(&Rectangle::new([(bx, by), (bx + len, by + 6)], BLACK.filled()))
        .map_err(pe)?;
    pic.text(&format!("{bar} mm"), (bx + len + 10, by - 6), 16, &BLACK)?;
    pic.text(
        "X0 Y0 (cross) at the plate centre; Z0 on its surface",
        (bx + len + 100, by - 6),
        15,
        &INK,
    )
}

/// The legend right of the plate: the depth colours over `lo..hi` with ticks in um, then the
/// keys of travel, first and last cut and the mark.
fn draw_legend(pic: &Picture, cuts: usize, (lo, hi): (f64, f64)) -> Result<()> {
    let root = pic.root;
    let (lx, ly) = (PX + SIDE + 110, PY + 10);
    pic.text("commanded depth", (lx, ly), 17, &BLACK)?;
    pic.text("below the surface", (lx, ly + 20), 15, &INK)?;
    let (cy0, ch, cw) = (ly + 50, 300, 26);
    for k in 0..ch {
        let t = 1.0 - k as f64 / (ch - 1) as f64;
        let c = if hi - lo < 1e-12 {
            colour(lo, lo, hi)
        } else {
            colour(lo + t * (hi - lo), lo, hi)
        };
        pic.line(vec![(lx, cy0 + k), (lx + cw, cy0 + k)], c.into())?;
    }
    root.draw(&Rectangle::new([(lx, cy0), (lx + cw, cy0 + ch)], INK))
        .map_err(pe)?;
    let ticks = if hi - lo < 1e-12 { 1 } else { 5 };
    for i in 0..ticks {
        let t = if ticks == 1 { 0.5 } else { i as f64 / (ticks - 1) as f64 };
        let v = hi - t * (hi - lo);
        let y = cy0 + (t * (ch - 1) as f64).round() as i32;
        pic.line(vec![(lx + cw, y), (lx + cw + 6, y)], INK.into())?;
        pic.text(&format!("{:.1} um", 1000.0 * v), (lx + cw + 10, y - 8), 15, &INK)?;
    }
    // Keys.
    let mut ky = cy0 + ch + 40;
    let key_line =
        |y: i32, c: RGBColor, w: u32| pic.line(vec![(lx, y), (lx + 30, y)], ShapeStyle::from(&c).stroke_width(w));
    key_line(ky, TRAVEL, 1)?;
    pic.text("travel between cuts (above the plate)", (lx + 38, ky - 8), 15, &INK)?;
    ky += 28;
    root.draw(&Circle::new((lx + 15, ky), 7, ShapeStyle::from(&FIRST).stroke_width(3)))
        .map_err(pe)?;
    pic.text("first cut (its start)", (lx + 38, ky - 8), 15, &INK)?;
    ky += 28;
    root.draw(&Rectangle::new(
        [(lx + 9, ky - 6), (lx + 21, ky + 6)],
        ShapeStyle::from(&LAST).stroke_width(3),
    ))
    .map_err(pe)?;
    pic.text("last cut (its end)", (lx + 38, ky - 8), 15, &INK)?;
    ky += 28;
    key_line(ky, BLACK, 4)?;
    pic.text("+x mark: the plate edge facing +x", (lx + 38, ky - 8), 15, &INK)?;
    ky += 28;
    key_line(ky, REGISTRATION, 2)?;
    pic.text("registration marks (hatched squares,", (lx + 38, ky - 8), 15, &INK)?;
    pic.text(
        "cut last): inspect finds the plate by them",
        (lx + 38, ky + 10),
        15,
        &INK,
    )?;
    ky += 48;
    pic.text(&format!("{cuts} scratches in this order;"), (lx, ky), 15, &INK)?;
    pic.text("labels: the design's scratch numbers", (lx, ky + 20), 15, &INK)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depths_run_from_dark_blue_to_yellow() {
        assert_eq!(colour(0.01, 0.01, 0.05), RGBColor(68, 1, 84));
        assert_eq!(colour(0.05, 0.01, 0.05), RGBColor(253, 231, 37));
        // Monotone in lightness (green channel) over the range.
        let g: Vec<u8> = (0..=20).map(|k| colour(k as f64, 0.0, 20.0).1).collect();
        assert!(g.windows(2).all(|w| w[0] <= w[1]), "{g:?}");
        assert_eq!(colour(0.02, 0.02, 0.02), colour(0.5, 0.0, 1.0), "one depth: mid colour");
    }

    #[test]
    fn scale_bars_are_round() {
        assert_eq!(scale_bar_mm(100.0), 20.0);
        assert_eq!(scale_bar_mm(60.0), 10.0);
        assert_eq!(scale_bar_mm(30.0), 5.0);
        assert_eq!(scale_bar_mm(8.0), 1.0);
        assert_eq!(scale_bar_mm(250.0), 50.0);
    }
}
