//! What `inspect` writes: per photo how the plate compares with the design's render and with
//! its picture, a difference image, and what the carving did differently (inspect.json and
//! tool_as_carved.json), or a refusal naming what the photos do not pin.
use super::*;
use crate::fit_cmd::verdict::{explained, RESIDUAL_MAX};

/// Each photo's numbers.
struct PhotoReport {
    /// Correlation of the photo with the design's render (as designed), with the fitted
    /// carving's render, and with the view's picture as the design measures (`touch_up::Goal`);
    /// the design's own render against the picture, for comparison.
    with_design: f64,
    with_fit: f64,
    with_picture: f64,
    design_with_picture: f64,
}

/// The difference image photo - gain x render, mid grey for 0 and for what the fit left out.
fn difference_png(path: &Path, w: u32, h: u32, photo: &Photo, render: &[f32], gain: f64) -> Result<()> {
    let bytes: Vec<u8> = (0..photo.pixels.len())
        .map(|i| {
            if !photo.used[i] {
                return 128;
            }
            let d = photo.pixels[i] as f64 - gain * render[i] as f64;
            (128.0 + 255.0 * d).round().clamp(0.0, 255.0) as u8
        })
        .collect();
    scratchart_render::io::write_png_gray(path, w, h, &bytes)?;
    Ok(())
}

/// Prints what the fit found: the carving, the machine's Z, the carving's place, the lamp.
fn print_found(found: &Found) {
    println!(
        "  the carving: cuts {:+.1} +- {:.1} um deeper than the tool's calibration, grooves {:.3} +- {:.3} times as wide \
         (correlation {:+.2}; residual {:.4} rms; {} renders)",
        1e3 * found.dz_mm,
        1e3 * found.dz_sd_mm,
        found.width_scale,
        found.width_scale_sd,
        found.correlation,
        found.residual_sd,
        found.renders
    );
    println!(
        "  the machine's Z: {}",
        if found.depth_scale_held {
            "as told (assumed: its depth scale held at 1; --depth-scale fits it)".to_string()
        } else {
            format!(
                "moves {:.4} +- {:.4} times what it is told (1: as its steps per mm say)",
                found.depth_scale, found.depth_scale_sd
            )
        }
    );
    println!(
        "  the carving's place: shifted ({:+.3}, {:+.3}) +- ({:.3}, {:.3}) mm, turned {:+.3} +- {:.3} deg about the plate's \
         centre: {}",
        found.shift_mm[0],
        found.shift_mm[1],
        found.shift_sd_mm[0],
        found.shift_sd_mm[1],
        found.turn_deg,
        found.turn_sd_deg,
        if found.moved() {
            "it sits off the design (the touch-up recuts where the grooves are)"
        } else {
            "where the design puts it"
        }
    );
    println!(
        "  the lamp: {}",
        if found.lamp_held {
            "where the design puts it (held: --lamp-as-designed)".to_string()
        } else {
            format!(
                "{:+.2} +- {:.2} deg further round and {:+.2} +- {:.2} deg higher than the design puts it{}",
                found.lamp_deg[0],
                found.lamp_sd_deg[0],
                found.lamp_deg[1],
                found.lamp_sd_deg[1],
                if (0..2).any(|k| found.lamp_deg[k].abs() > (3.0 * found.lamp_sd_deg[k]).max(0.5)) {
                    " (set it as the set-up sheet says before the touch-up is judged by eye)"
                } else {
                    ""
                }
            )
        }
    );
}

/// Each photo whose residual at the fit is more than the tool fit allows
/// ([`RESIDUAL_MAX`] times what [`explained`] allows: its own pixel noise, floored): what the model
/// does not explain there may be what moved the numbers (a blur, a lamp, a plate not as carved).
fn unexplained(p: &Problem, at: &Eval) -> Vec<String> {
    let mut out = Vec::new();
    let mut off = 0;
    for ph in &p.photos {
        let n = ph.used.iter().filter(|u| **u).count();
        let r = &at.residual[off..(off + n).min(at.residual.len())];
        off += n;
        let rms = (ssr(r) / n.max(1) as f64).sqrt();
        let img = crate::photo::Gray {
            width: ph.camera.camera.width,
            height: ph.camera.camera.height,
            data: ph.pixels.clone(),
        };
        let noise = crate::photo::pixel_noise_in(&img, Some(&ph.used));
        let against = explained(noise, None, None);
        if !(rms <= RESIDUAL_MAX * against) {
            out.push(format!(
                "{} leaves a residual of rms {rms:.4}, {:.1} times what its own noise ({noise:.4}) explains (at most \
                 {RESIDUAL_MAX})",
                ph.file.display(),
                rms / against
            ));
        }
    }
    out
}

/// Writes the difference images, and inspect.json and tool_as_carved.json when the photos pin
/// what the carving did; else a refusal (exit 3).
pub(super) fn write(a: &InspectArgs, p: &Problem, found: &Found, at: &Eval) -> Result<()> {
    let designed = p.images_of(&p.seen_by_photos(p.design.clone(), [0.0; 2]))?;
    let designed_eval = p.compare(designed);
    // The pictures as the design measures them, and the design's own render at its exposure.
    let goal = crate::touch_up::Goal::of(&a.design, &p.design);
    let own = crate::touch_up::display_renders(p.renderer, &p.design)?;
    let mut photos = Vec::new();
    for (k, ph) in p.photos.iter().enumerate() {
        let v = &p.design.views[ph.view];
        let (w, h) = (ph.camera.camera.width as usize, ph.camera.camera.height as usize);
        let r = PhotoReport {
            with_design: correlation(&ph.pixels, &designed_eval.images[k], &ph.used),
            with_fit: correlation(&ph.pixels, &at.images[k], &ph.used),
            with_picture: goal.correlation(&p.design, ph.view, &ph.on_view, &own[ph.view]),
            design_with_picture: goal.correlation(&p.design, ph.view, &own[ph.view], &own[ph.view]),
        };
        let stem = ph
            .file
            .file_stem()
            .map_or("photo".into(), |s| s.to_string_lossy().to_string());
        let diff = a.out.join(format!("{stem}_diff.png"));
        difference_png(
            &diff,
            w as u32,
            h as u32,
            ph,
            &designed_eval.images[k],
            designed_eval.gain[k],
        )?;
        println!(
            "  {} (view {}): correlates {:.3} with the design's render, {:.3} with the carving as fitted, {:.3} with \
             {} (the design: {:.3}); {}",
            ph.file.display(),
            v.name,
            r.with_design,
            r.with_fit,
            r.with_picture,
            goal.against(),
            r.design_with_picture,
            diff.display()
        );
        photos.push((ph, r, at.gain[k], at.shift_px[k]));
    }
    let pinned = found.dz_sd_mm <= DZ_TOLERANCE_MM
        && found.width_scale_sd <= SCALE_TOLERANCE
        && found.depth_scale_sd <= fit::DEPTH_SCALE_TOLERANCE;
    let inside = found.at_edge.is_none();
    print_found(found);
    let unexplained = unexplained(p, at);
    if !unexplained.is_empty() {
        return Err(InputError(format!(
            "the plate as fitted does not explain the photos: {}. No inspect.json written. Give --blur as the \
             photos' blur in pixels of the view (0 for a photo shrunk to the view's size), set the lamp as the \
             set-up sheet says, or check that the photos are of this design's plate as the plans carved it",
            unexplained.join("; ")
        ))
        .into());
    }
    if !(pinned && inside) {
        let mut why = Vec::new();
        if found.dz_sd_mm > DZ_TOLERANCE_MM || !found.dz_sd_mm.is_finite() {
            why.push(format!(
                "the depth change to {:.1} um (needed: {:.1})",
                1e3 * found.dz_sd_mm,
                1e3 * DZ_TOLERANCE_MM
            ));
        }
        if found.width_scale_sd > SCALE_TOLERANCE || !found.width_scale_sd.is_finite() {
            why.push(format!(
                "the width scale to {:.3} (needed: {SCALE_TOLERANCE})",
                found.width_scale_sd
            ));
        }
        if !(found.depth_scale_sd <= fit::DEPTH_SCALE_TOLERANCE) {
            why.push(format!(
                "the machine's depth scale to {:.3} (needed: {}; without --depth-scale it is held at 1)",
                found.depth_scale_sd,
                fit::DEPTH_SCALE_TOLERANCE
            ));
        }
        if let Some(what) = found.at_edge {
            why.push(format!(
                "the {what} inside the range looked at (depth change within +-{} um, width scale {} to {}, shift \
                 within +-{SHIFT_RANGE_MM} mm, turn within +-{TURN_RANGE_DEG} degrees, the lamp within \
                 +-{LAMP_RANGE_DEG} degrees of its place)",
                1e3 * DZ_RANGE_MM,
                SCALE_RANGE.0,
                SCALE_RANGE.1
            ));
        }
        return Err(InputError(format!(
            "the photos do not pin what the carving did: they pin {}. No inspect.json written. Photograph the plate \
             from every view of the design, sharp and not clipped, or check that the photos are of this design's plate",
            why.join(" and ")
        ))
        .into());
    }
    let carved_tool = p.tool.as_carved(found.width_scale, found.dz_mm);
    let tool_file = a.out.join("tool_as_carved.json");
    scratchart_render::io::write_atomic(&tool_file, carved_tool.to_json().as_bytes())?;
    let v = inspect_json(a, p, found, &carved_tool, &tool_file, &photos)?;
    scratchart_render::io::write_atomic(
        &a.out.join("inspect.json"),
        serde_json::to_string_pretty(&v)?.as_bytes(),
    )?;
    println!(
        "wrote {} and {} (for plan --touch-up)",
        a.out.join("inspect.json").display(),
        tool_file.display()
    );
    Ok(())
}

/// inspect.json's contents.
fn inspect_json(
    a: &InspectArgs,
    p: &Problem,
    found: &Found,
    carved_tool: &Tool,
    tool_file: &Path,
    photos: &[(&Photo, PhotoReport, f64, [f64; 2])],
) -> Result<serde_json::Value> {
    Ok(json!({
        "design": a.design.display().to_string(),
        "tool": a.tool.display().to_string(),
        "tool_as_calibrated": serde_json::to_value(&p.tool)?,
        "tool_as_carved": serde_json::to_value(carved_tool)?,
        "tool_as_carved_file": tool_file.display().to_string(),
        "grooves_from": if a.plan.is_empty() { json!("the design's commanded depths (as plan carves them)") }
            else { json!(a.plan.iter().map(|p| p.display().to_string()).collect::<Vec<_>>()) },
        "found": {
            "dz_mm": found.dz_mm, "dz_sd_mm": found.dz_sd_mm,
            "width_scale": found.width_scale, "width_scale_sd": found.width_scale_sd,
            "correlation": found.correlation,
            "shift_mm": found.shift_mm, "shift_sd_mm": found.shift_sd_mm,
            "turn_deg": found.turn_deg, "turn_sd_deg": found.turn_sd_deg,
            "depth_scale": found.depth_scale, "depth_scale_sd": found.depth_scale_sd,
            "depth_scale_held": found.depth_scale_held,
            "lamp_deg": {"turn": found.lamp_deg[0], "tilt": found.lamp_deg[1],
                "turn_sd": found.lamp_sd_deg[0], "tilt_sd": found.lamp_sd_deg[1], "held": found.lamp_held,
                "meaning": "the lamp stood turned this far about the plate's normal (+: counter-clockwise seen from +z) \
                            and raised this far, at its distance, from where the design puts it"},
            "moved": found.moved(),
            "meaning": "every cut reached dz_mm deeper than the calibrated tool's z offset says (+: deeper), and its \
                        groove was width_scale times as wide at that depth (Tool::as_carved)",
            "tolerances": {"dz_sd_mm": DZ_TOLERANCE_MM, "width_scale_sd": SCALE_TOLERANCE},
        },
        "residual_sd": found.residual_sd,
        "renders": found.renders,
        "blur_px": p.blur_px,
        "alpha": p.alpha,
        "photos": photos.iter().map(|(ph, r, gain, shift)| json!({
            "file": ph.file.display().to_string(),
            "view": p.design.views[ph.view].name,
            "placed": ph.how,
            "camera": {"eye": ph.camera.camera.eye, "target": ph.camera.camera.target,
                "fov_y_deg": ph.camera.camera.fov_y_deg, "size": [ph.camera.camera.width, ph.camera.camera.height]},
            "pixels_compared": ph.used.iter().filter(|u| **u).count(),
            "exposure_gain": gain,
            "registration_shift_px": if ph.located { json!(shift) } else { json!(null) },
            "correlation_with_design_render": r.with_design,
            "correlation_with_fitted_carving": r.with_fit,
            "correlation_with_picture": r.with_picture,
            "design_correlation_with_picture": r.design_with_picture,
        })).collect::<Vec<_>>(),
    }))
}
