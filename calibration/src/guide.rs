//! The capture guide (`capture_guide.png` beside card.json): one page a maker can follow to
//! photograph the cut card. A top view and a side view drawn to scale (a scale bar on each) with
//! the card, its fiducial marks and +x edge, and for each capture view where the camera and the
//! lamp go (azimuth, height above the card, distance along the table from the card's centre);
//! a simulated photo of each view as a good one looks (a typical V-bit's grooves); and what to
//! check before pressing the shutter. `capture_guide.txt` has the same numbers as text.
use std::path::Path;

use anyhow::Result;
use plotters::prelude::*;
use scratchart_model::scene::{LightKind, Scene};

use super::card::Card;

/// Where something stands relative to the card's centre.
#[derive(Clone, Copy, Debug)]
pub struct Place {
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub distance_mm: f64,
    /// Height above the card's surface, and distance along the table (horizontal), mm.
    pub height_mm: f64,
    pub ground_mm: f64,
}

impl Place {
    pub fn of(p: [f64; 3]) -> Place {
        let ground = p[0].hypot(p[1]);
        Place {
            azimuth_deg: p[1].atan2(p[0]).to_degrees(),
            elevation_deg: p[2].atan2(ground).to_degrees(),
            distance_mm: (ground * ground + p[2] * p[2]).sqrt(),
            height_mm: p[2],
            ground_mm: ground,
        }
    }
}

fn lamp_of(scene: &Scene, v: usize) -> [f64; 3] {
    match scene.views[v].light.kind {
        LightKind::Point { position } => position,
        // A direction: drawn 1 m away.
        LightKind::Directional { direction } => {
            let n = (direction[0].powi(2) + direction[1].powi(2) + direction[2].powi(2)).sqrt();
            direction.map(|d| 1000.0 * d / n)
        }
    }
}

/// The guide's text: every position as numbers.
pub fn guide_text(card: &Card, capture: &Scene) -> String {
    let mut s = format!(
        "Capture guide for the {:.0} mm calibration card\n\n\
         Lay the card flat, +x edge to the east (its right-hand key mark then sits on the right \
         edge below the centre, the other key on the top edge left of centre). Darken the room: \
         the lamp is the only light.\n\
         Angles: azimuth from the card's +x axis towards +y; height above the card's surface; \
         ground distance along the table from the card's centre.\n\n",
        card.plate_mm
    );
    for (v, view) in capture.views.iter().enumerate() {
        let c = Place::of(view.camera.eye);
        let l = Place::of(lamp_of(capture, v));
        s.push_str(&format!(
            "{}: camera at azimuth {:.0} deg, {:.0} mm high and {:.0} mm out ({:.0} mm from the centre, \
             {:.0} deg up), aimed at the card's centre; lamp at azimuth {:.0} deg, {:.0} mm high and {:.0} mm out \
             ({:.0} mm, {:.0} deg up), pointed at the card. Save the photo as {}.jpg.\n",
            view.name,
            c.azimuth_deg,
            c.height_mm,
            c.ground_mm,
            c.distance_mm,
            c.elevation_deg,
            l.azimuth_deg,
            l.height_mm,
            l.ground_mm,
            l.distance_mm,
            l.elevation_deg,
            view.name
        ));
    }
    use crate::fit_cmd::inspect::{view_scale, MAX_NOISE, MAX_OFF_DEG, MAX_SATURATED, MIN_JPEG_QUALITY, MIN_SCALE};
    let min_px = capture
        .views
        .iter()
        .map(|v| MIN_SCALE * view_scale(v))
        .fold(0.0f64, f64::max);
    let (noise, jpeg, off, sat) = (100.0 * MAX_NOISE, MIN_JPEG_QUALITY, MAX_OFF_DEG, 100.0 * MAX_SATURATED);
    let share = 100.0 * card_share(card, capture);
    s.push_str(&format!(
        "\nA good photo: all six hatched marks glint as bright squares (one may be covered); the flat \
         card is dark (the lamp's reflection goes away from the camera); some ladder rungs glint; no part \
         of the ladder is pure white (lower the exposure if it is); the card spans about {share:.0}% of the \
         frame's width, as in the example photos (nearer or zoomed in is fine: more pixels per mm); the \
         phone is held still (or on a stand), focused on the card. Any phone, JPEG or PNG.\n\
         \nThe guide's limits (`fit --check` measures each photo against them, and the fit refuses a \
         photo beyond one, naming it): the card at least {min_px:.2} pixels per mm at its centre (any phone \
         photo of a megapixel or more of the card at this distance); noise at most {noise:.0}% per colour \
         channel (more light, a stand, no night mode); JPEG quality {jpeg} or better (as the phone saves it, \
         not a messenger's copy); the camera within {off:.0} degrees of the capture position; at most \
         {sat:.0}% of the ladder's bright pixels full white; the photo as the phone saved it, not enlarged \
         or shrunk by an app. Check the photos with `scratchart-cal fit --check --card card.json PHOTOS` \
         before fitting.\n",
    ));
    s
}

/// How much of the frame's width the card spans in the capture views as the guide places the
/// camera (the widest of them, 0 to 1): what its example photos show.
pub fn card_share(card: &Card, capture: &Scene) -> f64 {
    let h = 0.5 * card.plate_mm;
    capture
        .views
        .iter()
        .map(|v| {
            let g = scratchart_model::camera::ViewGeom::new(v);
            let xs: Vec<f64> = [[-h, -h], [h, -h], [h, h], [-h, h]]
                .iter()
                .filter_map(|c| g.project([c[0], c[1], 0.0]).map(|p| p.0))
                .collect();
            let span = xs.iter().cloned().fold(f64::MIN, f64::max) - xs.iter().cloned().fold(f64::MAX, f64::min);
            (span / v.camera.width as f64).clamp(0.0, 1.0)
        })
        .fold(0.0, f64::max)
}

/// Writes the guide PNG (`examples` are display images of the capture views, as a good photo
/// looks: width x height each as in `capture`).
pub fn write_guide_png(path: &Path, card: &Card, capture: &Scene, examples: &[Vec<f32>]) -> Result<()> {
    let (wpx, hpx) = (1500u32, 1000u32);
    let mut buf = vec![255u8; (wpx * hpx * 3) as usize];
    let thumb = 370i32;
    let thumbs_at: Vec<(i32, i32)> = (0..examples.len())
        .map(|k| (700 + k as i32 * (thumb + 30), 90))
        .collect();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (wpx, hpx)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let sheet = Sheet {
            root: &root,
            font_ok: scratchart_design::report::plot_font().is_some(),
        };
        sheet.text(
            &format!(
                "Capture guide: the {:.0} mm calibration card, photographed from each capture view",
                card.plate_mm
            ),
            (20, 12),
            24,
            &BLACK,
        )?;
        let (reach, bar_mm) = top_view(&sheet, card, capture)?;
        side_view(&sheet, card, capture, reach, bar_mm)?;
        good_photo(&sheet, card, capture, examples.len(), &thumbs_at, thumb)?;
        root.present().map_err(pe)?;
    }
    // The example photos, scaled into their frames (nearest pixel).
    for (k, img) in examples.iter().enumerate() {
        let c = &capture.views[k].camera;
        let (w, h) = (c.width as i32, c.height as i32);
        let (x0, y0) = thumbs_at[k];
        for ty in 0..thumb {
            for tx in 0..thumb {
                let (sx, sy) = (tx * w / thumb, ty * h / thumb);
                let v = (255.0 * img[(sy * w + sx) as usize].clamp(0.0, 1.0)).round() as u8;
                let (px, py) = (x0 + tx, y0 + ty);
                if px >= 0 && py >= 0 && (px as u32) < wpx && (py as u32) < hpx {
                    let i = ((py as u32 * wpx + px as u32) * 3) as usize;
                    buf[i..i + 3].copy_from_slice(&[v, v, v]);
                }
            }
        }
    }
    scratchart_render::io::write_png_rgb(path, wpx, hpx, &buf)?;
    Ok(())
}

/// A drawing error of the guide, as an error.
fn pe<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("capture guide: {e:?}")
}

/// The guide's page being drawn, and whether a font is there for its words.
struct Sheet<'a, 'b> {
    root: &'a DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>,
    font_ok: bool,
}

const CAMERA_COLOUR: RGBColor = RGBColor(30, 80, 200);
const LAMP_COLOUR: RGBColor = RGBColor(210, 130, 0);

impl Sheet<'_, '_> {
    /// Words at `at` (nothing where no font is installed).
    fn text(&self, t: &str, at: (i32, i32), size: i32, c: &RGBColor) -> Result<()> {
        if self.font_ok {
            self.root
                .draw(&Text::new(t.to_string(), at, ("sans-serif", size).into_font().color(c)))
                .map_err(pe)?;
        }
        Ok(())
    }
}

/// The top view, to scale: the card, its marks and +x edge, and each view's camera and lamp
/// with their azimuth and distance; its reach (mm) and the scale bar's length (mm).
fn top_view(sheet: &Sheet, card: &Card, capture: &Scene) -> Result<(f64, f64)> {
    let (cam_col, lamp_col) = (CAMERA_COLOUR, LAMP_COLOUR);
    // Top view, to scale: everything within the largest ground distance.
    let reach = (0..capture.views.len())
        .flat_map(|v| {
            [
                Place::of(capture.views[v].camera.eye).ground_mm,
                Place::of(lamp_of(capture, v)).ground_mm,
            ]
        })
        .fold(card.plate_mm, f64::max)
        * 1.15;
    let (tc, tr) = ((320i32, 330i32), 250.0);
    let s = tr / reach;
    let to = |x: f64, y: f64| (tc.0 + (x * s) as i32, tc.1 - (y * s) as i32);
    sheet.text("Top view (to scale; north = +y up the page)", (20, 50), 18, &BLACK)?;
    let h = 0.5 * card.plate_mm;
    sheet
        .root
        .draw(&Rectangle::new([to(-h, h), to(h, -h)], RGBColor(90, 90, 90).filled()))
        .map_err(pe)?;
    for m in &card.marks {
        sheet
            .root
            .draw(&Rectangle::new(
                [
                    to(m.centre[0] - m.half_mm, m.centre[1] + m.half_mm),
                    to(m.centre[0] + m.half_mm, m.centre[1] - m.half_mm),
                ],
                WHITE.filled(),
            ))
            .map_err(pe)?;
    }
    let xe = to(h, 0.0);
    sheet
        .root
        .draw(&PathElement::new(
            vec![(xe.0 + 4, xe.1), (xe.0 + 24, xe.1)],
            RED.stroke_width(3),
        ))
        .map_err(pe)?;
    sheet.text("+x edge", (xe.0 + 4, xe.1 - 20), 14, &RED)?;
    for (v, view) in capture.views.iter().enumerate() {
        for (p, col, what) in [
            (view.camera.eye, cam_col, "camera"),
            (lamp_of(capture, v), lamp_col, "lamp"),
        ] {
            let q = Place::of(p);
            let at = to(p[0], p[1]);
            sheet
                .root
                .draw(&PathElement::new(vec![tc, at], col.stroke_width(1)))
                .map_err(pe)?;
            sheet.root.draw(&Circle::new(at, 7, col.filled())).map_err(pe)?;
            let label = format!(
                "{} {what}: azimuth {:.0}, {:.0} mm out",
                view.name, q.azimuth_deg, q.ground_mm
            );
            // Beside the marker, away from the card.
            let wlab = 7 * label.len() as i32;
            let (dx, dy) = if p[1] < -1.0 { (12, -6) } else { (-wlab / 2, 12) };
            sheet.text(&label, (at.0 + dx, at.1 + dy), 13, &col)?;
        }
    }
    // Scale bar under the top view.
    let bar_mm = (reach / 3.0 / 50.0).round().max(1.0) * 50.0;
    let (b0, b1) = (
        to(-reach * 0.9, -reach * 0.95),
        to(-reach * 0.9 + bar_mm, -reach * 0.95),
    );
    sheet
        .root
        .draw(&PathElement::new(vec![b0, b1], BLACK.stroke_width(3)))
        .map_err(pe)?;
    sheet.text(&format!("{bar_mm:.0} mm"), (b0.0, b0.1 + 6), 13, &BLACK)?;
    Ok((reach, bar_mm))
}

/// The side view, to scale: height above the card against distance along the table, every
/// camera and lamp.
fn side_view(sheet: &Sheet, card: &Card, capture: &Scene, reach: f64, bar_mm: f64) -> Result<()> {
    let (cam_col, lamp_col) = (CAMERA_COLOUR, LAMP_COLOUR);
    let h = 0.5 * card.plate_mm;
    // Side view, to scale: height against distance along the table, every camera and lamp.
    let top = (0..capture.views.len())
        .flat_map(|v| [capture.views[v].camera.eye[2], lamp_of(capture, v)[2]])
        .fold(0.0, f64::max)
        * 1.15;
    let (sx0, sy0) = (120i32, 940i32);
    let ss = (480.0 / reach).min(250.0 / top);
    let side = |g: f64, z: f64| (sx0 + (g * ss) as i32, sy0 - (z * ss) as i32);
    sheet.text(
        "Side view (to scale): height above the card against distance along the table",
        (20, 640),
        18,
        &BLACK,
    )?;
    sheet
        .root
        .draw(&PathElement::new(
            vec![side(-h, 0.0), side(reach, 0.0)],
            BLACK.stroke_width(1),
        ))
        .map_err(pe)?;
    sheet
        .root
        .draw(&Rectangle::new(
            [side(-h, 2.0), side(h, 0.0)],
            RGBColor(90, 90, 90).filled(),
        ))
        .map_err(pe)?;
    sheet.text("card", (side(-h, 0.0).0, sy0 + 6), 13, &BLACK)?;
    for (v, view) in capture.views.iter().enumerate() {
        for (p, col, what, dy) in [
            (view.camera.eye, cam_col, "camera", -22),
            (lamp_of(capture, v), lamp_col, "lamp", 8),
        ] {
            let q = Place::of(p);
            let at = side(q.ground_mm, q.height_mm);
            sheet
                .root
                .draw(&PathElement::new(vec![side(0.0, 0.0), at], col.stroke_width(1)))
                .map_err(pe)?;
            sheet
                .root
                .draw(&PathElement::new(vec![at, (at.0, sy0)], col.stroke_width(1)))
                .map_err(pe)?;
            sheet.root.draw(&Circle::new(at, 7, col.filled())).map_err(pe)?;
            sheet.text(
                &format!(
                    "{} {what}: {:.0} mm high, {:.0} up ({:.0} mm away)",
                    view.name, q.height_mm, q.elevation_deg, q.distance_mm
                ),
                (at.0 + 12, at.1 + dy + if v == 1 { 14 } else { 0 }),
                13,
                &col,
            )?;
        }
    }
    let bar = side(0.0, 0.0);
    let bar_px = (bar_mm * ss) as i32;
    sheet
        .root
        .draw(&PathElement::new(
            vec![(bar.0 + 200, sy0 + 20), (bar.0 + 200 + bar_px, sy0 + 20)],
            BLACK.stroke_width(3),
        ))
        .map_err(pe)?;
    sheet.text(&format!("{bar_mm:.0} mm"), (bar.0 + 200, sy0 + 26), 13, &BLACK)?;
    Ok(())
}

/// The frames of the example photos (`n` of them, at `thumbs_at`, `thumb` pixels square) and
/// the checklist before each photo.
fn good_photo(
    sheet: &Sheet,
    card: &Card,
    capture: &Scene,
    n: usize,
    thumbs_at: &[(i32, i32)],
    thumb: i32,
) -> Result<()> {
    // What a good photo looks like.
    for (k, view) in capture.views.iter().enumerate().take(n) {
        let (x, y) = thumbs_at[k];
        sheet.text(
            &format!("A good photo of {} (card.json view)", view.name),
            (x, y - 24),
            15,
            &BLACK,
        )?;
        sheet
            .root
            .draw(&Rectangle::new(
                [(x - 2, y - 2), (x + thumb + 1, y + thumb + 1)],
                BLACK.stroke_width(1),
            ))
            .map_err(pe)?;
    }
    let span = format!(
        "- the card spans about {:.0}% of the width (as here), in focus",
        100.0 * card_share(card, capture)
    );
    let notes = [
        "Before each photo:",
        "- room dark, the lamp the only light",
        "- all six hatched marks glint (one may be covered)",
        "- the flat card stays dark",
        "- no part of the ladder is pure white",
        span.as_str(),
        "- name it after its view: cam_south.jpg, cam_west.jpg",
        "- check: scratchart-cal fit --check --card card.json *.jpg",
    ];
    for (i, n) in notes.iter().enumerate() {
        sheet.text(n, (720, 520 + 26 * i as i32), 17, &BLACK)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::card::CardSpec;

    /// The guide's words on framing are the share its own example photos show (the capture
    /// views as the guide places the camera), not "most of the frame".
    #[test]
    fn the_guide_states_the_framing_its_examples_show() {
        for plate in [50.0, 70.0, 120.0] {
            let card = Card::new(&CardSpec {
                plate_mm: plate,
                ..CardSpec::default()
            });
            let dir = std::env::temp_dir().join(format!("scratchart-guide-{}-{plate}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join("card.json");
            std::fs::write(&path, serde_json::to_string(&card.to_json(256)).unwrap()).unwrap();
            let (card, capture) = Card::load(&path).unwrap();
            let share = card_share(&card, &capture);
            assert!(share > 0.2 && share < 0.95, "{plate} mm: {share}");
            // The widest edge of the card in the example, measured on the view's own geometry.
            let v = &capture.views[0];
            let g = scratchart_model::camera::ViewGeom::new(v);
            let h = 0.5 * card.plate_mm;
            let a = g.project([-h, -h, 0.0]).unwrap();
            let b = g.project([h, -h, 0.0]).unwrap();
            let c = g.project([-h, h, 0.0]).unwrap();
            let d = g.project([h, h, 0.0]).unwrap();
            let widest = (b.0 - a.0).abs().max((d.0 - c.0).abs()) / v.camera.width as f64;
            assert!(share + 1e-9 >= widest, "{plate} mm: {share} < {widest}");
            let text = guide_text(&card, &capture);
            assert!(
                text.contains(&format!("spans about {:.0}% of the frame's width", 100.0 * share)),
                "{text}"
            );
            assert!(!text.contains("most of the frame"), "{text}");
        }
    }
}
