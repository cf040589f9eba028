//! What a walk reports: the design's files cut down to its walk views, `summary.json`'s `walk`
//! (every view's correlation along the arc), `walk.png` and `walk_sheet.png`.
use std::path::Path;

use serde_json::{json, Value};

use crate::problem::{DesignReport, IterRecord, Problem};
use crate::walk::corr_of;

/// The problem and report of a walk cut down to its design views, for the outputs every design
/// writes (design.json, the per-view images and summary, the set-up sheet): the in-between
/// views were in the loss and are reported apart ([`walk_summary`]).
pub fn design_views_only(problem: &Problem, report: &DesignReport) -> (Problem, DesignReport) {
    let Some(walk) = &problem.walk else {
        return (problem.clone(), report.clone());
    };
    let n = walk.design_views();
    let mut p = problem.clone();
    p.scene.views.truncate(n);
    p.targets.truncate(n);
    p.pictures.truncate(n);
    p.picture_rects.truncate(n);
    let mut r = report.clone();
    r.scene.views.truncate(n);
    r.unpruned.views.truncate(n);
    let cut = |x: &IterRecord| IterRecord {
        pixel: x.pixel[..n].to_vec(),
        gram: x.gram[..n].to_vec(),
        total: x.total,
    };
    r.history = r.history.iter().map(cut).collect();
    r.final_loss.pixel.truncate(n);
    r.final_loss.gram.truncate(n);
    r.final_images.truncate(n);
    r.initial_images.truncate(n);
    (p, r)
}

/// `summary.json`'s `walk`: the arc, and every view's correlation with its frame (design
/// views) or its neighbours' blend (in-between views), in arc order; with the smallest of each.
pub fn walk_summary(
    problem: &Problem,
    final_images: &[Vec<f32>],
    probe_corr: &[f64],
    sigma: f32,
) -> Option<(Value, Vec<f64>)> {
    let walk = problem.walk.as_ref()?;
    let scene = &problem.scene;
    let corr: Vec<f64> = (0..scene.views.len())
        .map(|v| {
            let (w, h) = (scene.views[v].camera.width, scene.views[v].camera.height);
            corr_of(&final_images[v], &problem.targets[v], &problem.pictures[v], w, h, sigma)
        })
        .collect();
    let n = walk.design_views();
    let entry = |v: usize| {
        let mut e = json!({
            "name": scene.views[v].name,
            "azimuth_deg": walk.arc.azimuth_at(walk.position(v)),
            "position": walk.position(v),
            "corr": corr[v],
        });
        if v < n {
            e["frame"] = json!(walk.frames.get(v).or(walk.frames.first()));
        } else {
            let b = &walk.between[v - n];
            e["between"] = json!([scene.views[b.left].name, scene.views[b.left + 1].name]);
            e["t"] = json!(b.t);
            e["target"] = json!(if walk.source == "object" {
                "the object seen from this view"
            } else {
                "the cross-fade (1 - t) left + t right of its neighbours' frames"
            });
        }
        e
    };
    let probes: Vec<Value> = walk
        .probes
        .iter()
        .zip(probe_corr)
        .map(|(p, c)| {
            json!({
                "name": p.view.name,
                "azimuth_deg": walk.arc.azimuth_at(p.left as f64 + p.t),
                "position": p.left as f64 + p.t,
                "between": [scene.views[p.left].name, scene.views[p.left + 1].name],
                "t": p.t,
                "corr": c,
            })
        })
        .collect();
    let min = |r: std::ops::Range<usize>| r.map(|v| corr[v]).fold(f64::INFINITY, f64::min);
    let min_probe = probe_corr.iter().cloned().fold(f64::INFINITY, f64::min);
    let a = &walk.arc;
    let value = json!({
        "source": walk.source,
        "arc_deg": a.arc_deg,
        "centre_azimuth_deg": a.centre_azimuth_deg,
        "elevation_deg": a.elevation_deg,
        "distance_mm": a.distance_mm,
        "step_deg": a.step_deg(),
        "design_views": n,
        "between_per_pair": a.between,
        "frames": walk.frames,
        "views": (0..n).map(entry).collect::<Vec<_>>(),
        "between": (n..scene.views.len()).map(entry).collect::<Vec<_>>(),
        "min_corr_views": min(0..n),
        "min_corr_between": if scene.views.len() > n { json!(min(n..scene.views.len())) } else { Value::Null },
        "probes": probes,
        "probes_are": "views between the design views that are not in the loss: the finished design rendered from there, against the same kind of target as an in-between view's",
        "min_corr_probes": if probe_corr.is_empty() { Value::Null } else { json!(min_probe) },
        "corr": "correlation of the render (blurred as the loss blurs it) with the view's target over its picture's pixels",
        "walk_png": "x: azimuth along the arc, degrees; y: correlation; filled: design views, hollow: in-between views (in the loss), grey crosses: probes (judged only)",
    });
    Some((value, corr))
}

/// `walk.png`: each view's correlation along the arc (design views filled, in-between views
/// hollow, probes grey crosses), with the bars 0.9 and 0.8 dashed.
pub fn walk_plot_png(
    path: &Path,
    problem: &Problem,
    corr: &[f64],
    probe_corr: &[f64],
) -> Result<(), scratchart_optim::error::OptimError> {
    use plotters::prelude::*;
    let Some(walk) = &problem.walk else { return Ok(()) };
    let (wpx, hpx) = (900u32, 420u32);
    let mut buf = vec![0u8; (wpx * hpx * 3) as usize];
    let order = walk.arc_order();
    let az = |v: usize| walk.arc.azimuth_at(walk.position(v));
    let (x0, x1) = (az(order[0]), az(*order.last().expect("a walk has views")));
    let pad = 0.04 * (x1 - x0).max(1.0);
    let lo = corr
        .iter()
        .chain(probe_corr)
        .cloned()
        .fold(0.5f64, f64::min)
        .clamp(-1.0, 0.5);
    // Every point along the arc (views and probes), for the line through them.
    let mut line: Vec<(f64, f64)> = order
        .iter()
        .map(|&v| (az(v), corr[v]))
        .chain(
            walk.probes
                .iter()
                .zip(probe_corr)
                .map(|(p, &c)| (walk.arc.azimuth_at(p.left as f64 + p.t), c)),
        )
        .collect();
    line.sort_by(|a, b| a.0.total_cmp(&b.0));
    let pe = |e: DrawingAreaErrorKind<_>| scratchart_optim::error::OptimError::Report(format!("plot: {e}"));
    let n = walk.design_views();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (wpx, hpx)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let blue = RGBColor(30, 90, 200);
        let orange = RGBColor(230, 120, 20);
        let mut builder = ChartBuilder::on(&root);
        builder.margin(16).x_label_area_size(40).y_label_area_size(56);
        let font = crate::report::plot_font();
        if let Some(f) = font {
            builder.caption(
                format!(
                    "correlation along the walk ({} views, {:.1} deg apart; hollow: in between, x: probes)",
                    n,
                    walk.arc.step_deg()
                ),
                (f, 18),
            );
        }
        let mut chart = builder
            .build_cartesian_2d((x0 - pad)..(x1 + pad), lo..1.0)
            .map_err(pe)?;
        if let Some(f) = font {
            chart
                .configure_mesh()
                .x_desc("azimuth (degrees)")
                .y_desc("correlation with the frame / blend")
                .label_style((f, 13))
                .axis_desc_style((f, 14))
                .draw()
                .map_err(pe)?;
        }
        for (bar, c) in [(0.9, blue), (0.8, orange)] {
            let mut x = x0 - pad;
            let dash = (x1 - x0 + 2.0 * pad) / 80.0;
            while x < x1 + pad {
                chart
                    .draw_series(LineSeries::new(
                        vec![(x, bar), ((x + dash).min(x1 + pad), bar)],
                        c.mix(0.5),
                    ))
                    .map_err(pe)?;
                x += 2.0 * dash;
            }
        }
        chart
            .draw_series(LineSeries::new(line.iter().copied(), RGBColor(90, 90, 90)))
            .map_err(pe)?;
        chart
            .draw_series(walk.probes.iter().zip(probe_corr).map(|(p, &c)| {
                Cross::new(
                    (walk.arc.azimuth_at(p.left as f64 + p.t), c),
                    4,
                    RGBColor(120, 120, 120),
                )
            }))
            .map_err(pe)?;
        chart
            .draw_series(
                order
                    .iter()
                    .filter(|&&v| v < n)
                    .map(|&v| Circle::new((az(v), corr[v]), 5, blue.filled())),
            )
            .map_err(pe)?;
        chart
            .draw_series(
                order
                    .iter()
                    .filter(|&&v| v >= n)
                    .map(|&v| Circle::new((az(v), corr[v]), 5, orange.stroke_width(2))),
            )
            .map_err(pe)?;
        root.present().map_err(pe)?;
    }
    crate::report::write_rgb_png(path, wpx, hpx, buf)
}

/// `walk_sheet.png`: the walk's contact sheet, in arc order, up to 12 views a row: each view's
/// render above its target, framed blue for a design view and orange for an in-between view.
pub fn walk_sheet_png(
    path: &Path,
    problem: &Problem,
    displays: &[Vec<f32>],
) -> Result<(), scratchart_optim::error::OptimError> {
    let Some(walk) = &problem.walk else { return Ok(()) };
    const GAP: u32 = 6;
    const BORDER: u32 = 2;
    const PER_ROW: usize = 12;
    let scene = &problem.scene;
    let order = walk.arc_order();
    let cw = scene.views.iter().map(|v| v.camera.width).max().unwrap_or(1) + 2 * BORDER;
    let ch = scene.views.iter().map(|v| v.camera.height).max().unwrap_or(1) + 2 * BORDER;
    let cols = order.len().min(PER_ROW) as u32;
    let rows = order.len().div_ceil(PER_ROW) as u32;
    let (w, h) = (cols * (cw + GAP) + GAP, rows * (2 * ch + 2 * GAP) + GAP);
    let mut px = vec![255u8; (w * h * 3) as usize];
    let n = walk.design_views();
    let mut put = |x: u32, y: u32, c: [u8; 3]| {
        let i = 3 * (y * w + x) as usize;
        px[i..i + 3].copy_from_slice(&c);
    };
    for (slot, &v) in order.iter().enumerate() {
        let (cx, cy) = ((slot % PER_ROW) as u32, (slot / PER_ROW) as u32);
        let frame = if v < n { [30, 90, 200] } else { [230, 120, 20] };
        let (vw, vh) = (scene.views[v].camera.width, scene.views[v].camera.height);
        for (k, img) in [&displays[v], &problem.targets[v]].into_iter().enumerate() {
            let x0 = GAP + cx * (cw + GAP);
            let y0 = GAP + cy * (2 * ch + 2 * GAP) + k as u32 * (ch + GAP / 2);
            for y in 0..vh + 2 * BORDER {
                for x in 0..vw + 2 * BORDER {
                    let inside = x >= BORDER && y >= BORDER && x < vw + BORDER && y < vh + BORDER;
                    let c = if inside {
                        let g = (255.0 * img[((y - BORDER) * vw + x - BORDER) as usize].clamp(0.0, 1.0)).round() as u8;
                        [g, g, g]
                    } else {
                        frame
                    };
                    put(x0 + x, y0 + y, c);
                }
            }
        }
    }
    crate::report::write_rgb_png(path, w, h, px)
}
