//! The plot beside a fitted tool: W and w against commanded depth, with the widths the photos
//! show.
use std::path::Path;

use anyhow::Result;
use plotters::prelude::*;
use scratchart_model::camera::ViewGeom;

use crate::card::{Card, CutRole};
use crate::fit::{Data, FitResult};

/// Per ladder depth, the visible width the photos show: the model's width scaled by the ratio of
/// the photo's to the model's light (above the plate's background) over that rung's cuts.
pub(super) fn measured_widths(data: &Data, photos: &[Vec<f32>], res: &FitResult, pred: &[Vec<f32>]) -> Vec<(f64, f64)> {
    let lin = |d: f32| crate::encoding::decode(d as f64);
    let mut out = Vec::new();
    for &z in &data.card.depths_mm {
        let Some(m) = res.tool.model(z) else { continue };
        let (mut sp, mut sm) = (0.0, 0.0);
        for (v, view) in data.capture.views.iter().enumerate() {
            let g = ViewGeom::new(view);
            let w = view.camera.width as i64;
            let h = view.camera.height as i64;
            let bg_p = lin(median_masked(&photos[v], &data.masks[v]));
            let bg_m = lin(median_masked(&pred[v], &data.masks[v]));
            for c in data
                .card
                .cuts
                .iter()
                .filter(|c| c.role == CutRole::Ladder && c.z_mm == z)
            {
                let (Some(a), Some(b)) = (g.project([c.p0[0], c.p0[1], 0.0]), g.project([c.p1[0], c.p1[1], 0.0]))
                else {
                    continue;
                };
                let (x0, x1) = ((a.0.min(b.0) - 3.0) as i64, (a.0.max(b.0) + 3.0) as i64);
                let (y0, y1) = ((a.1.min(b.1) - 3.0) as i64, (a.1.max(b.1) + 3.0) as i64);
                for y in y0.max(0)..=y1.min(h - 1) {
                    for x in x0.max(0)..=x1.min(w - 1) {
                        let i = (y * w + x) as usize;
                        if !data.masks[v][i] {
                            continue;
                        }
                        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                        let t = (((px - a.0) * dx + (py - a.1) * dy) / (dx * dx + dy * dy).max(1e-9)).clamp(0.0, 1.0);
                        if (px - a.0 - t * dx).hypot(py - a.1 - t * dy) <= 2.5 {
                            sp += lin(photos[v][i]) - bg_p;
                            sm += lin(pred[v][i]) - bg_m;
                        }
                    }
                }
            }
        }
        if sm > 1e-9 {
            out.push((z, m.width * (sp / sm).max(0.0)));
        }
    }
    out
}

fn median_masked(img: &[f32], mask: &[bool]) -> f32 {
    let mut v: Vec<f32> = img.iter().zip(mask).filter(|(_, m)| **m).map(|(x, _)| *x).collect();
    crate::photo::median(&mut v)
}

/// W(z) and w(z) of the fitted tool against commanded depth, with the measured widths.
pub(super) fn profile_plot(path: &Path, res: &FitResult, card: &Card, points: &[(f64, f64)]) -> Result<()> {
    let (wpx, hpx) = (720u32, 480u32);
    let mut buf = vec![255u8; (wpx * hpx * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (wpx, hpx)).into_drawing_area();
        let pe = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("plot: {e:?}");
        root.fill(&WHITE).map_err(pe)?;
        let z0 = card.depths_mm.iter().cloned().fold(f64::MAX, f64::min);
        let z1 = card.depths_mm.iter().cloned().fold(f64::MIN, f64::max);
        let zs: Vec<f64> = (0..=200).map(|k| z0 + (z1 - z0) * k as f64 / 200.0).collect();
        let curve: Vec<(f64, f64, f64)> = zs
            .iter()
            .map(|&z| {
                res.tool
                    .model(z)
                    .map_or((z * 1e3, 0.0, 0.0), |m| (z * 1e3, m.width * 1e3, m.w * 1e3))
            })
            .collect();
        // The scale of the visible widths (w grows without bound where a flat-bottomed groove
        // starts, so it is clipped to the plot).
        let top = curve
            .iter()
            .map(|c| c.1)
            .chain(points.iter().map(|p| p.1 * 1e3))
            .fold(1.0, f64::max)
            * 1.6;
        let curve: Vec<(f64, f64, f64)> = curve.into_iter().map(|c| (c.0, c.1, c.2.min(top))).collect();
        let font = scratchart_design::report::plot_font();
        let mut cb = ChartBuilder::on(&root);
        cb.margin(12);
        if let Some(f) = font {
            cb.caption(
                format!("{} fit: groove width against commanded depth", res.kind.name()),
                (f, 20),
            )
            .x_label_area_size(40)
            .y_label_area_size(56);
        }
        let mut chart = cb.build_cartesian_2d(z0 * 1e3..z1 * 1e3, 0.0..top).map_err(pe)?;
        if let Some(f) = font {
            chart
                .configure_mesh()
                .x_desc("commanded depth z, um")
                .y_desc("width, um")
                .y_label_formatter(&|v| format!("{v:.0}"))
                .x_label_formatter(&|v| format!("{v:.0}"))
                .label_style((f, 14))
                .draw()
                .map_err(pe)?;
        }
        let w_series = chart
            .draw_series(LineSeries::new(curve.iter().map(|c| (c.0, c.1)), BLUE.stroke_width(2)))
            .map_err(pe)?;
        w_series
            .label("visible width W")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLUE));
        chart
            .draw_series(LineSeries::new(curve.iter().map(|c| (c.0, c.2)), RED.stroke_width(2)))
            .map_err(pe)?
            .label("model width parameter w")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], RED));
        chart
            .draw_series(
                points
                    .iter()
                    .map(|p| Circle::new((p.0 * 1e3, p.1 * 1e3), 4, BLACK.filled())),
            )
            .map_err(pe)?
            .label("W measured per ladder depth")
            .legend(|(x, y)| Circle::new((x + 8, y), 4, BLACK.filled()));
        if let Some(f) = font {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .border_style(BLACK)
                .background_style(WHITE)
                .label_font((f, 14))
                .draw()
                .map_err(pe)?;
        }
        root.present().map_err(pe)?;
    }
    scratchart_render::io::write_png_rgb(path, wpx, hpx, &buf)?;
    Ok(())
}
