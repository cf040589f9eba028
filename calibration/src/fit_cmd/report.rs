//! What a fit says: the printed summary, each photo's residual and its image, the record in
//! tool.json and `tool_report.json`.
use std::path::{Path, PathBuf};

use anyhow::Result;
use scratchart_observe::Observer;
use serde_json::json;

use scratchart_tool::Fitted;

use super::photos::PhotoRecord;
use super::{is_tool_param, FitArgs};
use crate::fit::{Data, FitResult};

/// `tool_report.json`: the verdict and its reasons, the tool, the fit's record and every
/// parameter with its uncertainty and the shifts that went into it.
pub(super) fn report_json(
    best: &FitResult,
    reasons: &[String],
    allowed: &[String],
    record: &serde_json::Value,
) -> Result<serde_json::Value> {
    Ok(json!({
        "verdict": if reasons.is_empty() { "accepted" } else { "refused" },
        "reasons": reasons,
        "allowed_unidentified": allowed,
        "tool": serde_json::from_str::<serde_json::Value>(&best.tool.to_json_fitted(&Fitted { alpha: Some(best.alpha), fit: None }))?,
        "fit": record,
        "params": best.params.iter().enumerate().map(|(k, p)| json!({
            "name": p.0, "value": p.1, "sd": best.sd.get(k).copied().flatten(),
            "curvature_sd": best.curvature.get(k).copied().flatten(), "limit": best.limits.get(k),
            "photo_disagreement": best.disagreement.get(k).copied().flatten(),
            "noise_lift_shift": best.noise_lift.get(k).copied().flatten(),
            "model_error_shift": best.model_error.get(k).copied().flatten(),
            "degradation_shift": best.degradation.get(k).copied().flatten(),
            "jpeg_change_shift": best.jpeg_change.get(k).copied().flatten(),
        })).collect::<Vec<_>>(),
    }))
}

/// The fitted parameters as the terminal shows them: the kinds compared, each tool parameter
/// with its uncertainty (or why it has none), the exposures and the blur.
pub(super) fn print_fit(best: &FitResult, results: &[FitResult], obs: &dyn Observer) {
    if results.len() > 1 {
        obs.result("  chosen by the lowest BIC (robust loss, penalized by parameter count):");
        for r in results {
            obs.result(&format!(
                "    {:13} BIC {:>12.0}  loss {:.4e}{}",
                r.kind.name(),
                r.bic,
                r.loss,
                if r.kind == best.kind { "  <- chosen" } else { "" }
            ));
        }
    }
    for (k, (name, v, sd)) in best.params.iter().enumerate() {
        if !is_tool_param(name) {
            continue;
        }
        let boot = best
            .bootstrap
            .as_ref()
            .map_or(String::new(), |b| format!(" (bootstrap +- {:.5})", b[k]));
        let raw = best.sd.get(k).copied().flatten();
        match (sd, raw) {
            (Some(sd), _) => obs.result(&format!("  {name:14} {v:.5} +- {sd:.5}{boot}")),
            _ if best.unseen.contains(name) => obs.result(&format!("  {name:14} no groove at this depth")),
            (None, Some(raw)) => obs.result(&format!(
                "  {name:14} {v:.5} +- {raw:.5}: not identified (more than {:.5}){boot}",
                best.limits[k]
            )),
            (None, None) => obs.result(&format!("  {name:14} not identified: the photos do not constrain it")),
        }
    }
    // Each photo's noise as the fit refined its lift (`ln_noise[v]`), where it did.
    let noise_scale: Vec<String> = (0..best.blur_px.len())
        .map(|v| best.noise_scale(v).map_or("-".to_string(), |s| format!("{s:.2}")))
        .collect();
    let noise_note = if noise_scale.iter().any(|s| s != "-") {
        format!(", noise [{}] x the one measured", noise_scale.join(", "))
    } else {
        String::new()
    };
    // Each photo's tone curve as fitted (`tone[v]`: its value is the encoding of the light to
    // the power e^-t), as that power.
    let tone: Vec<String> = best
        .params
        .iter()
        .filter(|(name, _, _)| name.starts_with("tone["))
        .map(|(_, t, _)| format!("{:.3}", (-t).exp()))
        .collect();
    let tone_note = if tone.is_empty() {
        String::new()
    } else {
        format!(", tone: light to the power [{}] before the encoding", tone.join(", "))
    };
    obs.result(&format!(
        "  exposure {:?}, camera blur {:?} px{noise_note}{tone_note}",
        best.exposure
            .iter()
            .map(|e| (e * 1000.0).round() / 1000.0)
            .collect::<Vec<_>>(),
        best.blur_px
            .iter()
            .map(|b| (b * 100.0).round() / 100.0)
            .collect::<Vec<_>>()
    ));
}

/// Per photo: the RMS residual over the pixels the fit compares, and the photo's own noise.
pub(super) fn photo_residuals(
    data: &Data,
    pred: &[Vec<f32>],
    registered: &[Vec<f32>],
    noise: &[f64],
) -> Vec<(f64, f64)> {
    (0..data.capture.views.len())
        .map(|v| {
            let (mut sum, mut n) = (0.0f64, 0usize);
            for ((m, p), ok) in pred[v].iter().zip(&registered[v]).zip(&data.masks[v]) {
                if *ok {
                    sum += ((m - p) as f64).powi(2);
                    n += 1;
                }
            }
            ((sum / n.max(1) as f64).sqrt(), noise[v])
        })
        .collect()
}

/// The residual image of each photo (`OUT_residual_VIEW.png`: mid grey is no residual).
pub(super) fn write_residual_images(
    stem: &Path,
    capture: &scratchart_model::scene::Scene,
    data: &Data,
    pred: &[Vec<f32>],
    registered: &[Vec<f32>],
    obs: &dyn Observer,
) -> Result<()> {
    for (v, view) in capture.views.iter().enumerate() {
        let bytes: Vec<u8> = pred[v]
            .iter()
            .zip(&registered[v])
            .zip(&data.masks[v])
            .map(|((m, p), ok)| {
                if *ok {
                    (127.5 + 510.0 * (m - p)).clamp(0.0, 255.0) as u8
                } else {
                    0
                }
            })
            .collect();
        let p = PathBuf::from(format!("{}_residual_{}.png", stem.display(), view.name));
        scratchart_render::io::write_png_gray(&p, view.camera.width, view.camera.height, &bytes)?;
        obs.result(&format!(
            "wrote {} (mid grey: no residual; 1 grey level = 1/510 of full scale)",
            p.display()
        ));
    }
    Ok(())
}

/// The fit's record in tool.json and the report: the kinds compared, the loss, the
/// uncertainties and how they were found, each photo, the time and the work.
#[allow(clippy::too_many_arguments)]
pub(super) fn fit_record(
    best: &FitResult,
    results: &[FitResult],
    unidentified: &[String],
    files: &[PathBuf],
    inspections: &[PhotoRecord],
    residual: &[(f64, f64)],
    args: &FitArgs,
    secs: f64,
) -> serde_json::Value {
    json!({
        "kind": best.kind.name(),
        "criterion": "lowest BIC of the robust loss among the fitted kinds",
        "candidates": results.iter().map(|r| json!({"kind": r.kind.name(), "bic": r.bic, "loss": r.loss})).collect::<Vec<_>>(),
        "loss": best.loss,
        "rms_residual": best.rms,
        "pixels": best.pixels,
        "uncertainty": best.params.iter().filter(|p| is_tool_param(&p.0))
            .map(|p| (p.0.clone(), p.2.map_or(json!("not identified"), |s| json!(s)))).collect::<serde_json::Map<_, _>>(),
        "uncertainty_method": "the larger of the block sandwich (16 x 16 pixel blocks) and the curvature at the optimum, with the model's own error, the photos' degradations and the photos' disagreement in quadrature",
        "curvature_uncertainty": best.params.iter().zip(&best.curvature).filter(|(p, _)| is_tool_param(&p.0))
            .map(|(p, s)| (p.0.clone(), json!(s))).collect::<serde_json::Map<_, _>>(),
        "not_identified": unidentified,
        "no_groove": best.unseen,
        "exposure": best.exposure,
        "blur_px": best.blur_px,
        "photos": files.iter().zip(inspections).zip(residual).enumerate().map(|(v, ((f, insp), (rms, nz)))| {
            let mut p = insp.clone();
            p["file"] = json!(f.display().to_string());
            // The sensor noise whose lift the fit found in the photo (`fit::noise::Lift`).
            if let Some(s) = best.noise_scale(v) {
                p["sensor_noise_fitted"] = json!(insp["sensor_noise"].as_f64().unwrap_or(0.0) * s);
            }
            p["noise"] = json!(nz);
            p["residual_rms"] = json!(rms);
            p["model_error_rms"] = json!(best.model_error_rms.get(v));
            p["degraded_rms"] = json!(best.degraded_rms.get(v).copied().flatten());
            p
        }).collect::<Vec<_>>(),
        "card": args.card.display().to_string(),
        "seconds": secs,
        "bootstrap": best.bootstrap.as_ref().map(|b| json!({
            "replicates": args.bootstrap,
            "std": best.params.iter().zip(b).filter(|(p, _)| is_tool_param(&p.0))
                .map(|(p, s)| (p.0.clone(), json!(s))).collect::<serde_json::Map<_, _>>(),
        })),
        "renders": results.iter().map(|r| r.renders).sum::<u32>(),
        "tangent_passes": results.iter().map(|r| r.tangent_passes).sum::<u32>(),
        "engine_seconds": results.iter().map(|r| r.engine_seconds).sum::<f64>(),
        "jacobian": "engine derivatives (tangent passes) for the tool, z offset and alpha; differences for eyes and camera terms",
    })
}
