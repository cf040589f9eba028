//! Outputs of a design run: the design files, per-view comparison images, the loss curve, SSIM,
//! and the summary (printed and written as `summary.json`). Every file is written atomically.
use std::path::Path;

use serde_json::json;

use crate::measure::{quality, view_ssim};
use crate::problem::{DesignConfig, DesignReport, Problem};
use scratchart_model::scene::Scene;
use scratchart_optim::error::OptimError;

/// A contact sheet: one row per view, `render | target | |render - target|`, 8-bit.
pub fn contact_sheet_png(
    path: &Path,
    scene: &Scene,
    displays: &[Vec<f32>],
    targets: &[Vec<f32>],
) -> Result<(), scratchart_render::io::IoError> {
    const GAP: u32 = 4;
    let w = scene.views.iter().map(|v| v.camera.width).max().unwrap_or(1);
    let cw = 3 * w + 2 * GAP;
    let ch: u32 = scene.views.iter().map(|v| v.camera.height + GAP).sum::<u32>().max(1);
    let mut px = vec![128u8; (cw * ch) as usize];
    let byte = |v: f32| (255.0 * v.clamp(0.0, 1.0)).round() as u8;
    let mut y0 = 0;
    for (v, view) in scene.views.iter().enumerate() {
        let (vw, vh) = (view.camera.width, view.camera.height);
        for y in 0..vh {
            for x in 0..vw {
                let i = (y * vw + x) as usize;
                let (r, t) = (displays[v][i].clamp(0.0, 1.0), targets[v][i]);
                let row = ((y0 + y) * cw) as usize;
                px[row + x as usize] = byte(r);
                px[row + (w + GAP + x) as usize] = byte(t);
                px[row + (2 * (w + GAP) + x) as usize] = byte((r - t).abs());
            }
        }
        y0 += vh + GAP;
    }
    scratchart_render::io::write_png_gray(path, cw, ch, &px)
}

/// `render | target` side by side (4 gray pixels between), 8-bit.
pub fn compare_png(
    path: &Path,
    w: u32,
    h: u32,
    display: &[f32],
    target: &[f32],
) -> Result<(), scratchart_render::io::IoError> {
    const GAP: u32 = 4;
    let cw = 2 * w + GAP;
    let mut px = vec![128u8; (cw * h) as usize];
    let byte = |v: f32| (255.0 * v.clamp(0.0, 1.0)).round() as u8;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            px[(y * cw + x) as usize] = byte(display[i]);
            px[(y * cw + w + GAP + x) as usize] = byte(target[i]);
        }
    }
    scratchart_render::io::write_png_gray(path, cw, h, &px)
}

/// Writes an RGB plot buffer as a PNG, atomically.
pub(crate) fn write_rgb_png(path: &Path, w: u32, h: u32, buf: Vec<u8>) -> Result<(), OptimError> {
    Ok(scratchart_render::io::write_png_rgb(path, w, h, &buf)?)
}

/// DejaVu Sans (Latin, Greek, arrows, mathematical signs; `engine/assets/`), built into the
/// binaries so that every plot has its text, the same on every machine, also where no font is
/// installed (a GPU server, a container).
const PLOT_FONT: &[u8] = include_bytes!("../../assets/DejaVuSans-subset.ttf");

/// The plot font, registered with plotters once as "sans-serif". `None` only if the built-in
/// font could not be parsed (then plots are drawn without text; the text reports have every
/// number).
pub fn plot_font() -> Option<&'static str> {
    static FONT: std::sync::OnceLock<Option<&'static str>> = std::sync::OnceLock::new();
    *FONT.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, PLOT_FONT).ok()?;
        Some("sans-serif")
    })
}

/// The loss curve: log10 of the total loss (white) and of each view's loss, per iteration.
pub fn loss_curve_png(path: &Path, report: &DesignReport) -> Result<(), OptimError> {
    use plotters::prelude::*;
    let (wpx, hpx) = (800u32, 450u32);
    let mut buf = vec![0u8; (wpx * hpx * 3) as usize];
    let hist = &report.history;
    let series: Vec<Vec<f64>> = std::iter::once(hist.iter().map(|r| r.total as f64).collect())
        .chain(
            (0..hist.first().map_or(0, |r| r.pixel.len()))
                .map(|v| hist.iter().map(|r| (r.pixel[v] + r.gram[v]) as f64).collect()),
        )
        .collect();
    let logs: Vec<Vec<f64>> = series
        .iter()
        .map(|s| s.iter().map(|&x| x.max(1e-12).log10()).collect())
        .collect();
    let lo = logs.iter().flatten().cloned().fold(f64::INFINITY, f64::min).floor();
    let hi = logs.iter().flatten().cloned().fold(f64::NEG_INFINITY, f64::max).ceil();
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo, hi)
    } else {
        (-3.0, 0.0)
    };
    let n = hist.len().max(2) as f64 - 1.0;
    let pe = |e: DrawingAreaErrorKind<_>| OptimError::Report(format!("plot: {e}"));
    // white for the total, then distinct hues per view (cycling after eight views)
    const PALETTE: [RGBColor; 8] = [
        RGBColor(255, 160, 60),
        RGBColor(80, 190, 255),
        RGBColor(235, 90, 200),
        RGBColor(120, 220, 110),
        RGBColor(250, 230, 90),
        RGBColor(170, 140, 255),
        RGBColor(255, 110, 110),
        RGBColor(90, 230, 210),
    ];
    let color_of = |i: usize| {
        if i == 0 {
            RGBColor(255, 255, 255)
        } else {
            PALETTE[(i - 1) % PALETTE.len()]
        }
    };
    {
        let root = BitMapBackend::with_buffer(&mut buf, (wpx, hpx)).into_drawing_area();
        root.fill(&RGBColor(20, 20, 24)).map_err(pe)?;
        let grid = RGBColor(70, 70, 80);
        let text = RGBColor(220, 220, 225);
        if let Some(font) = plot_font() {
            let mut chart = ChartBuilder::on(&root)
                .margin(16)
                .caption("design loss (log scale)", (font, 22).into_font().color(&text))
                .x_label_area_size(40)
                .y_label_area_size(64)
                .build_cartesian_2d(0f64..n, lo..hi)
                .map_err(pe)?;
            chart
                .configure_mesh()
                .light_line_style(RGBColor(35, 35, 42))
                .bold_line_style(grid)
                .axis_style(grid)
                .x_desc("iteration")
                .y_desc("loss")
                .y_labels((hi - lo) as usize + 1)
                .y_label_formatter(&|v| format!("1e{}", v.round() as i64))
                .x_label_formatter(&|v| format!("{}", v.round() as i64))
                .label_style((font, 14).into_font().color(&text))
                .axis_desc_style((font, 15).into_font().color(&text))
                .draw()
                .map_err(pe)?;
            for (i, s) in logs.iter().enumerate().rev() {
                let color = color_of(i);
                let name = if i == 0 {
                    "total".to_string()
                } else {
                    format!("view {}", i - 1)
                };
                chart
                    .draw_series(LineSeries::new(
                        s.iter().enumerate().map(|(k, &y)| (k as f64, y)),
                        color.stroke_width(if i == 0 { 2 } else { 1 }),
                    ))
                    .map_err(pe)?
                    .label(name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            }
            chart
                .configure_series_labels()
                .background_style(RGBColor(30, 30, 36))
                .border_style(grid)
                .label_font((font, 14).into_font().color(&text))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(pe)?;
        } else {
            // No font on this system: the same curves with one grid line per decade, no text.
            let mut chart = ChartBuilder::on(&root)
                .margin(16)
                .build_cartesian_2d(0f64..n, lo..hi)
                .map_err(pe)?;
            let mut d = lo;
            while d <= hi + 1e-9 {
                chart
                    .draw_series(LineSeries::new(vec![(0.0, d), (n, d)], &grid))
                    .map_err(pe)?;
                d += 1.0;
            }
            chart
                .draw_series(LineSeries::new(vec![(0.0, lo), (0.0, hi)], &grid))
                .map_err(pe)?;
            for (i, s) in logs.iter().enumerate().rev() {
                chart
                    .draw_series(LineSeries::new(
                        s.iter().enumerate().map(|(k, &y)| (k as f64, y)),
                        color_of(i).stroke_width(if i == 0 { 2 } else { 1 }),
                    ))
                    .map_err(pe)?;
            }
        }
        root.present().map_err(pe)?;
    }
    write_rgb_png(path, wpx, hpx, buf)
}

/// Writes design.json + scratches.csv, NAME_compare.png and NAME_target.png per view, loss_curve.png and
/// summary.json; returns the summary (see [`summary_text`]).
pub fn write_outputs(
    out: &Path,
    problem: &Problem,
    cfg: &DesignConfig,
    r: &DesignReport,
) -> Result<serde_json::Value, OptimError> {
    r.scene
        .save(&out.join("design.json"), "scratches.csv")
        .map_err(|e| OptimError::Report(e.to_string()))?;
    let scene = &r.scene;
    let mut views_json = Vec::new();
    let first = r.history.first();
    let q_final = quality(
        scene,
        &r.final_images,
        &problem.targets,
        &problem.pictures,
        cfg.loss.sigma,
    );
    let q_initial = quality(
        scene,
        &r.initial_images,
        &problem.targets,
        &problem.pictures,
        cfg.loss.sigma,
    );
    // What a render equal to its picture (the pixel term's own optimum) would score: pictures with
    // detail at the scale of one pixel lose correlation to the blur alone.
    let q_perfect = quality(
        scene,
        &problem.targets,
        &problem.targets,
        &problem.pictures,
        cfg.loss.sigma,
    );
    contact_sheet_png(&out.join("contact_sheet.png"), scene, &r.final_images, &problem.targets)?;
    let reach = crate::reach::report(out, scene, &problem.targets, &problem.pictures, cfg.tool.as_ref())?;
    // Each view's images and SSIM: host work of a pixel each, spread over the cores.
    let per_view = scratchart_model::par::par_map(scene.views.len(), |v| -> Result<(f64, f64), OptimError> {
        let view = &scene.views[v];
        let (w, h) = (view.camera.width, view.camera.height);
        compare_png(
            &out.join(format!("{}_compare.png", view.name)),
            w,
            h,
            &r.final_images[v],
            &problem.targets[v],
        )?;
        // The target itself, where `scratchart-view` looks for it (its T key shows it beside
        // the render).
        let bytes: Vec<u8> = problem.targets[v]
            .iter()
            .map(|&t| (255.0 * t.clamp(0.0, 1.0)).round() as u8)
            .collect();
        scratchart_render::io::write_png_gray(&out.join(format!("{}_target.png", view.name)), w, h, &bytes)?;
        Ok((
            view_ssim(scene, v, &r.final_images[v], &problem.targets[v], cfg.loss.sigma),
            view_ssim(scene, v, &r.initial_images[v], &problem.targets[v], cfg.loss.sigma),
        ))
    });
    for ((v, view), ssims) in scene.views.iter().enumerate().zip(per_view) {
        let (w, h) = (view.camera.width, view.camera.height);
        let (ssim_final, ssim_initial) = ssims?;
        views_json.push(json!({
            "name": view.name,
            "loss_initial": first.map(|f| (f.pixel[v] + f.gram[v]) as f64),
            "loss_final": (r.final_loss.pixel[v] + r.final_loss.gram[v]) as f64,
            "pixel_term_final": r.final_loss.pixel[v] as f64,
            "gram_term_final": r.final_loss.gram[v] as f64,
            "ssim_initial": ssim_initial,
            "ssim_final": ssim_final,
            "corr_initial": q_initial[v].corr,
            "corr_final": q_final[v].corr,
            "corr_perfect": q_perfect[v].corr,
            "crosstalk_final": q_final[v].crosstalk.iter().map(|c| c.1).fold(f64::NEG_INFINITY, f64::max).max(0.0),
            "crosstalk": q_final[v].crosstalk.iter().map(|&(k, x, raw)| json!({"other_view": scene.views[k].name, "crosstalk": x, "raw_correlation": raw})).collect::<Vec<_>>(),
            "picture_pixels": problem.pictures[v].iter().filter(|p| **p).count(),
            "picture_rect_px": problem.picture_rects[v].map(|r| [r.x0, r.y0, r.w, r.h]),
            "plate_fills_frame": crate::scenes::silhouette_box(view, &scene.plate)
                .map(|b| ((b[2] - b[0]) / w as f64).max((b[3] - b[1]) / h as f64)),
            "light_intensity": view.light.intensity,
            "reach": reach[v],
        }));
    }
    loss_curve_png(&out.join("loss_curve.png"), r)?;
    let per_iter_ms = 1e3 * r.loop_seconds / r.iters_run.max(1) as f64;
    let summary = json!({
        "views": scene.views.len(),
        "resolution": scene.views.iter().map(|v| [v.camera.width, v.camera.height]).collect::<Vec<_>>(),
        "scratches_optimized": r.unpruned.scratches.len(),
        "scratches_written": scene.scratches.len(),
        "iterations": cfg.iters,
        "iterations_run_now": r.iters_run,
        "resumed_from_iteration": r.resumed_from,
        "loop_seconds": r.loop_seconds,
        "ms_per_iteration": per_iter_ms,
        "gpu_ms_per_iteration": r.gpu_ms.iter().map(|(l, ms)| json!({"phase": l, "ms": ms})).collect::<Vec<_>>(),
        "pairs_per_iteration": r.mean_pairs,
        "device_memory_bytes": r.device_bytes,
        "loss_initial": first.map(|f| f.total as f64),
        "loss_final": r.final_loss.total as f64,
        "per_view": views_json,
        "rollbacks": r.rollbacks.iter().map(|b| json!({"iteration": b.iter, "reason": b.reason, "lr_scale_after": b.lr_scale})).collect::<Vec<_>>(),
        "pruning": r.prune.as_ref().map(|p| json!({
            "before": p.before, "after": p.after, "removed": p.before - p.after,
            "loss_before": p.loss_before as f64, "loss_after": p.loss_after as f64,
            "trials": p.trials, "accepted_batches": p.accepted, "tolerance": cfg.prune.tol,
        })),
        "loss_curve_png": "x: iteration (0 at the left edge); y: log10 of the loss, one grid line per decade; white: total, colours: per view",
        "config": {
            "lambda_p": cfg.loss.lambda_p, "lambda_g": cfg.loss.lambda_g, "blur_sigma": cfg.loss.sigma, "crosstalk_weight": cfg.loss.crosstalk,
            "lr_end_mm": cfg.adam.lr_end, "lr_w_mm": cfg.adam.lr_w, "lr_d_mm": cfg.adam.lr_d,
            "lr_alpha": cfg.adam.lr_alpha, "lr_light_log": cfg.adam.lr_light, "seed": cfg.seed,
            "aim": cfg.aim, "init_w_mm": problem.init.map(|i| i.w), "lr_final": cfg.lr_final,
        },
    });
    scratchart_render::io::write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .expect("the summary always serializes")
            .as_bytes(),
    )?;
    Ok(summary)
}

/// Below this correlation with its picture a view shows nothing a viewer recognizes.
pub const USEFUL_CORRELATION: f64 = 0.1;

/// Why a finished design is a failure, from its summary: every view that is asked to show a
/// picture ends below [`USEFUL_CORRELATION`], or it keeps almost none of its scratches (under 1%
/// of those optimized, and under 10). None for a design worth carving.
pub fn verdict(summary: &serde_json::Value) -> Option<String> {
    let blank: Vec<&str> = summary["blank_views"]
        .as_array()
        .map(|a| a.iter().filter_map(|b| b.as_str()).collect())
        .unwrap_or_default();
    let views: Vec<(&str, f64)> = summary["per_view"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|v| Some((v["name"].as_str()?, v["corr_final"].as_f64().unwrap_or(f64::NAN))))
        .filter(|(n, _)| !blank.contains(n))
        .collect();
    let mut why = Vec::new();
    if !views.is_empty() && views.iter().all(|(_, c)| !(*c >= USEFUL_CORRELATION)) {
        why.push(format!(
            "no view shows its picture: every correlation is below {USEFUL_CORRELATION} ({})",
            views
                .iter()
                .map(|(n, c)| format!("{n} {c:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let (written, optimized) = (
        summary["scratches_written"].as_u64().unwrap_or(0),
        summary["scratches_optimized"].as_u64().unwrap_or(0),
    );
    if optimized > 0 && written < 10 && (written as f64) < 0.01 * optimized as f64 {
        why.push(format!("it keeps {written} of its {optimized} scratches"));
    }
    (!why.is_empty()).then(|| {
        format!(
            "this design failed: {} (a plate too small for its views, too few iterations, or pictures \
             the plate cannot show; see summary.json)",
            why.join("; ")
        )
    })
}

/// The wall-time line of the summary: the phases of summary.json's `wall_s`, and the final
/// render's and set-up sheet's parts of the reports where it has them.
fn wall_line(w: &serde_json::Value) -> String {
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    format!(
        "  wall time {:.1} s: start-up {:.1} s (device, kernels, uploads, first render), iterations {:.1} s{}, pruning {:.1} s, final render and reports {:.1} s{}",
        f(&w["total"]),
        f(&w["start_up"]),
        f(&w["iterations"]),
        match w["iterations_submissions"].as_f64() {
            Some(sub) => format!(
                " (submissions {sub:.2} s, checkpoints {:.2} s, hooks {:.2} s)",
                f(&w["iterations_checkpoints"]),
                f(&w["iterations_hooks"])
            ),
            None => String::new(),
        },
        f(&w["pruning"]),
        f(&w["final_render_and_reports"]),
        match (w["final_render"].as_f64(), w["set_up_sheet"].as_f64()) {
            (Some(r), Some(s)) => match (w["set_up_sheet_searches_engine"].as_f64(), w["set_up_sheet_search_steps"].as_u64()) {
                (Some(e), Some(n)) => format!(
                    " (the final render {r:.2} s, the set-up sheet {s:.2} s: {n} search steps, {e:.2} s of their renders{}, the picture {:.2} s)",
                    sheet_split(w),
                    f(&w["set_up_sheet_png"])
                ),
                _ => format!(" (the final render {r:.2} s, the set-up sheet {s:.2} s)"),
            },
            _ => String::new(),
        }
    )
}

/// The set-up sheet's searches taken apart, where summary.json has them: " (U uploads in a s,
/// S submissions in b s, read-backs c s; on the host: pictures d s, measures e s)".
fn sheet_split(w: &serde_json::Value) -> String {
    let g = |k: &str| w[format!("set_up_sheet_{k}")].as_f64();
    match (
        g("uploads"),
        g("upload_s"),
        g("submissions"),
        g("render_s"),
        g("read_s"),
        g("pictures_s"),
        g("measure_s"),
    ) {
        (Some(u), Some(us), Some(n), Some(rs), Some(rd), Some(p), Some(m)) => format!(
            " ({u:.0} uploads in {us:.2} s, {n:.0} submissions in {rs:.2} s, read-backs {rd:.2} s; on the host: pictures {p:.2} s, measures {m:.2} s)"
        ),
        _ => String::new(),
    }
}

/// The summary of a design run as the `design` command prints it.
pub fn summary_text(s: &serde_json::Value, out: &Path) -> String {
    let mut text = String::new();
    use std::fmt::Write as _;
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let _ = writeln!(
        text,
        "design: {} views, {} scratches written ({} optimized), {} iterations ({} run now) in {:.1} s: {:.0} ms/iteration, {:.3e} (pixel, scratch) pairs/iteration",
        s["views"],
        s["scratches_written"],
        s["scratches_optimized"],
        s["iterations"],
        s["iterations_run_now"],
        f(&s["loop_seconds"]),
        f(&s["ms_per_iteration"]),
        f(&s["pairs_per_iteration"])
    );
    if let Some(phases) = s["gpu_ms_per_iteration"].as_array() {
        let p: Vec<String> = phases
            .iter()
            .map(|p| format!("{} {:.1}", p["phase"].as_str().unwrap_or("?"), f(&p["ms"])))
            .collect();
        let _ = writeln!(text, "  GPU ms per iteration: {}", p.join(", "));
    }
    if let Some(b) = s["device_memory_bytes"].as_u64() {
        let _ = writeln!(
            text,
            "  device memory held at the end of the iterations: {}",
            scratchart_render::limits::mib(b)
        );
    }
    if s["wall_s"].is_object() {
        let _ = writeln!(text, "{}", wall_line(&s["wall_s"]));
    }
    let _ = writeln!(
        text,
        "  loss {:.5} -> {:.5}",
        f(&s["loss_initial"]),
        f(&s["loss_final"])
    );
    let _ = writeln!(
        text,
        "  {:<8} {:>12} {:>12} {:>11} {:>11} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "view",
        "loss start",
        "loss final",
        "pixel",
        "gram",
        "SSIM start",
        "SSIM final",
        "corr start",
        "corr final",
        "crosstalk"
    );
    for v in s["per_view"].as_array().into_iter().flatten() {
        let _ = writeln!(
            text,
            "  {:<8} {:>12.5} {:>12.5} {:>11.5} {:>11.5} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>10.3}",
            v["name"].as_str().unwrap_or("?"),
            f(&v["loss_initial"]),
            f(&v["loss_final"]),
            f(&v["pixel_term_final"]),
            f(&v["gram_term_final"]),
            f(&v["ssim_initial"]),
            f(&v["ssim_final"]),
            f(&v["corr_initial"]),
            f(&v["corr_final"]),
            f(&v["crosstalk_final"])
        );
    }
    for v in s["per_view"].as_array().into_iter().flatten() {
        if let Some(r) = v["picture_rect_px"].as_array() {
            let _ = writeln!(
                text,
                "  {}: picture {:.0} x {:.0} px ({} pixels), plate fills {:.0}% of the frame; a render equal to the picture would correlate {:.3}",
                v["name"].as_str().unwrap_or("?"),
                r[2].as_f64().unwrap_or(0.0),
                r[3].as_f64().unwrap_or(0.0),
                v["picture_pixels"],
                100.0 * v["plate_fills_frame"].as_f64().unwrap_or(f64::NAN),
                f(&v["corr_perfect"])
            );
        }
    }
    if let Some(n) = s["per_view"][0]["reach"]["scratches_facing_no_view"].as_u64() {
        let _ = writeln!(
            text,
            "  {n} of {} scratches face no view anywhere along them (h not within 3 alpha of their walls' normals): their light reaches the views only through their lobes' tails",
            s["scratches_written"]
        );
    }
    for v in s["per_view"].as_array().into_iter().flatten() {
        let r = &v["reach"];
        if r.is_null() {
            continue;
        }
        let (fin, cap) = (f(&v["corr_final"]), f(&v["corr_perfect"]));
        let _ = writeln!(
            text,
            "  {}: ends {:.3} below what its picture allows ({:.3} of {:.3}); {:.0}% of its bright pixels within the walls' reach (up to {:.0} deg{}); the walls of {} scratches face it, {} of them another view's too",
            v["name"].as_str().unwrap_or("?"),
            (cap - fin).max(0.0),
            fin,
            cap,
            100.0 * f(&r["share"]),
            f(&r["steepest_wall_deg"]),
            if f(&r["share"]) < 1.0 {
                format!("; the rest is red in {}", r["map_png"].as_str().unwrap_or("?"))
            } else {
                String::new()
            },
            r["scratches_facing"],
            r["also_facing_another_view"]
        );
    }
    if let Some(p) = s["pruning"].as_object() {
        let _ = writeln!(
            text,
            "  pruning: removed {} of {} scratches, loss {:.5} -> {:.5} ({} trials)",
            p["removed"],
            p["before"],
            f(&p["loss_before"]),
            f(&p["loss_after"]),
            p["trials"]
        );
    }
    for a in s["setup_advice"].as_array().into_iter().flatten() {
        let _ = writeln!(text, "  {}", a.as_str().unwrap_or(""));
    }
    let nrb = s["rollbacks"].as_array().map_or(0, |a| a.len());
    if nrb > 0 {
        let _ = writeln!(text, "  rollbacks: {nrb} (see summary.json)");
    }
    let _ = writeln!(
        text,
        "  wrote {0}/design.json, {0}/scratches.csv, {0}/*_compare.png (render | target), {0}/*_target.png, {0}/loss_curve.png, {0}/contact_sheet.png (render | target | difference), {0}/setup.txt and {0}/setup.png (where the lamp and viewers go, and how far they may move; its inputs: {0}/setup_inputs.json, {0}/*_target.pfm, {0}/*_picture.png), {0}/summary.json",
        out.display()
    );
    if s["setup"]["bend"].is_object() {
        let _ = writeln!(
            text,
            "  bent plate: setup.txt says how to bend the carved sheet; {}/bend_template.svg is the form at 1:1 (print at 100%)",
            out.display()
        );
    }
    text
}

#[cfg(test)]
mod tests {

    /// A design that shows none of its pictures, or keeps almost none of its scratches, is a
    /// failure; a view left blank on purpose does not count.
    #[test]
    fn the_verdict_of_a_design() {
        let summary = |corrs: &[(&str, f64)], blank: &[&str], written: u64| {
            serde_json::json!({
                "per_view": corrs.iter().map(|(n, c)| serde_json::json!({"name": n, "corr_final": c})).collect::<Vec<_>>(),
                "blank_views": blank,
                "scratches_written": written,
                "scratches_optimized": 200,
            })
        };
        assert_eq!(super::verdict(&summary(&[("v0", 0.8), ("v1", 0.05)], &[], 120)), None);
        let v = super::verdict(&summary(&[("v0", -0.2), ("v1", 0.05)], &[], 120)).unwrap();
        assert!(
            v.contains("no view shows its picture") && v.contains("v0 -0.200"),
            "{v}"
        );
        let v = super::verdict(&summary(&[("v0", 0.5)], &[], 1)).unwrap();
        assert!(v.contains("keeps 1 of its 200 scratches"), "{v}");
        // A blank view's correlation is not asked for; NaN is no correlation.
        assert_eq!(super::verdict(&summary(&[("v0", 0.4), ("v1", 0.0)], &["v1"], 50)), None);
        assert!(super::verdict(&summary(&[("v0", f64::NAN)], &[], 50)).is_some());
    }
    /// The built-in font registers and draws text: the plots have their labels on a machine with
    /// no fonts installed (a GPU server had none, and the set-up sheet failed there).
    #[test]
    fn the_built_in_font_draws_text() {
        use plotters::prelude::*;
        assert_eq!(super::plot_font(), Some("sans-serif"));
        let (w, h) = (200u32, 40u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            let font = ("sans-serif", 20).into_font().color(&BLACK);
            root.draw(&Text::new("±5° µm", (5, 5), font)).unwrap();
            root.present().unwrap();
        }
        let dark = buf.chunks(3).filter(|p| p[0] < 128).count();
        assert!(dark > 50, "the text drew {dark} dark pixels");
    }
}
