//! The set-up sheet's two charts: how each view's correlation falls as the lamp or the eye
//! turns away from where the design put it.
use plotters::prelude::*;

use crate::setup_sheet::{dashed, view_colour, Placer, Rect};
use crate::tolerance::{Sensitivity, ANGLE_RANGE, KEEP};
use scratchart_model::scene::Scene;

/// One chart: each view's correlation, as a share of the designed one, against how far the
/// lamp or the eye (`moved`) turned in azimuth (solid) and elevation (dashed); the legend below.
pub(super) fn draw_chart(
    pl: &mut Placer,
    scene: &Scene,
    sens: &Sensitivity,
    moved: &str,
    area: Rect,
) -> Result<(), String> {
    let root = pl.root;
    let title = format!(
        "The {moved} moved: correlation as a share of the design's (grey: {:.0}%)",
        100.0 * KEEP
    );
    pl.put(&title, (area[0], area[1] - 26), 13, BLACK)?;
    let legend_h = 48;
    let plot = [area[0], area[1], area[2], area[3] - legend_h];
    pl.block(plot);
    pl.layout.charts.push(plot);
    let sub = root.clone().shrink(
        (plot[0] as u32, plot[1] as u32),
        ((plot[2] - plot[0]) as u32, (plot[3] - plot[1]) as u32),
    );
    let mut ymax: f64 = 1.05;
    for (j, v) in scene.views.iter().enumerate() {
        for s in sens.samples.iter().filter(|s| s.view == v.name && s.moved == moved) {
            if sens.base[j] > 0.0 {
                ymax = ymax.max(s.corr / sens.base[j] + 0.02);
            }
        }
    }
    let mut chart = ChartBuilder::on(&sub)
        .margin(8)
        .x_label_area_size(34)
        .y_label_area_size(48)
        .build_cartesian_2d(-ANGLE_RANGE..ANGLE_RANGE, 0f64..ymax.min(2.0))
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(format!("{moved} moved (degrees)"))
        .y_desc("correlation / designed")
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(DashedLineSeries::new(
            vec![(-ANGLE_RANGE, KEEP), (ANGLE_RANGE, KEEP)],
            4,
            4,
            RGBColor(150, 150, 150).stroke_width(1),
        ))
        .map_err(|e| e.to_string())?;
    for (j, v) in scene.views.iter().enumerate() {
        if sens.of(&v.name).next().is_none() || !(sens.base[j] > 0.0) {
            continue;
        }
        let col = view_colour(j);
        for axis in ["azimuth", "elevation"] {
            let mut pts: Vec<(f64, f64)> = sens
                .samples
                .iter()
                .filter(|s| s.view == v.name && s.moved == moved && s.axis == axis)
                .map(|s| (s.delta, s.corr / sens.base[j]))
                .chain(std::iter::once((0.0, 1.0)))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            if axis == "azimuth" {
                chart
                    .draw_series(LineSeries::new(pts, col.stroke_width(2)))
                    .map_err(|e| e.to_string())?;
            } else {
                chart
                    .draw_series(DashedLineSeries::new(pts, 7, 5, col.stroke_width(2)))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    draw_legend(pl, scene, sens, area, plot[3] + 6)
}

/// A chart's legend at height `ly`, below its plot (never over a curve): the line styles,
/// then the views, on as many as two lines; the views that do not fit are counted.
fn draw_legend(pl: &mut Placer, scene: &Scene, sens: &Sensitivity, area: Rect, ly: i32) -> Result<(), String> {
    let root = pl.root;
    let mut x = area[0] + 48;
    for (txt, dash) in [("azimuth", false), ("elevation", true)] {
        let a = (x, ly + 8);
        let b = (x + 30, ly + 8);
        if dash {
            dashed(root, a, b, BLACK.stroke_width(2))?;
        } else {
            root.draw(&PathElement::new(vec![a, b], BLACK.stroke_width(2)))
                .map_err(|e| e.to_string())?;
        }
        let r = pl.put(txt, (x + 36, ly), 13, BLACK)?;
        x = r[2] + 18;
    }
    let mut y = ly;
    let mut more = 0;
    for (j, v) in scene.views.iter().enumerate() {
        let shown = sens.of(&v.name).next().is_some();
        let txt = if shown {
            v.name.clone()
        } else {
            format!("{} (no curve)", v.name)
        };
        let (w, h) = pl.size(&txt, 13);
        if x + 26 + w > area[2] {
            if y > ly {
                more += 1;
                continue;
            }
            y += h + 6;
            x = area[0] + 48;
        }
        root.draw(&Rectangle::new([(x, y + 4), (x + 20, y + 12)], view_colour(j).filled()))
            .map_err(|e| e.to_string())?;
        let r = pl.put(&txt, (x + 24, y), 13, BLACK)?;
        x = r[2] + 14;
    }
    if more > 0 {
        pl.put(&format!("and {more} more (setup.txt)"), (x, y), 13, BLACK)?;
    }
    Ok(())
}
