//! The fit's verdict: the checks that refuse a fit (exit 3, no tool.json) or write it.
use super::is_tool_param;
use crate::fit::FitResult;

/// What the fit's checks found: reasons to refuse (no tool.json, exit 3), the unidentified
/// parameters written anyway (`--allow-unidentified`), and the tool parameters not identified.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Verdict {
    pub reasons: Vec<String>,
    pub allowed: Vec<String>,
    pub unidentified: Vec<String>,
}

/// The checks that keep a wrong tool.json from being written: each photo's residual against
/// its own noise (`residual`: per photo, the RMS residual and the noise; `photos`: how to name
/// each), a parameter of the grooves at a bound of its range, and a tool parameter whose
/// uncertainty is above what a plate needs (refused unless `allow_unidentified`).
pub fn verdict(best: &FitResult, residual: &[(f64, f64)], photos: &[String], allow_unidentified: bool) -> Verdict {
    let mut reasons = residual_reasons(best, residual, photos);
    if let Some(msg) = shrinking_profile(best) {
        reasons.push(msg);
    }
    let unidentified: Vec<String> = best
        .unidentified()
        .into_iter()
        .filter(|n| is_tool_param(n) && n != "alpha")
        .collect();
    let mut allowed = Vec::new();
    // A parameter the photos identify, run to a bound, says the tool lies outside this kind. One
    // they do not identify ran along a valley the photos cannot tell from flat (a measured
    // profile's wall shape on saturated grooves: its w/W trades with its widths) and stopped
    // where its range ends: it is said once, as not identified.
    for name in best.at_bound.iter().filter(|n| !unidentified.contains(n)) {
        reasons.push(at_bound_reason(best, name, photos));
    }
    for name in &unidentified {
        let msg = unidentified_reason(best, name, photos);
        if allow_unidentified {
            allowed.push(msg);
        } else {
            reasons.push(msg);
        }
    }
    Verdict {
        reasons,
        allowed,
        unidentified,
    }
}

/// What a photo's residual may be: its own noise (at least [`RESIDUAL_FLOOR`]), or where larger
/// the residual its degraded copies leave against the model (`FitResult::degraded_rms`: a JPEG
/// of a low-noise photo rounds the bright grooves' edges where the noise measured on the flat
/// plate is small), and the model's own error on it (`FitResult::model_error_rms`: a render at
/// four times the photo's resolution against the fit's twice; a low-noise photo of wide grooves
/// shows it), in quadrature.
pub fn explained(nz: f64, degraded_rms: Option<f64>, model_error_rms: Option<f64>) -> f64 {
    nz.max(RESIDUAL_FLOOR)
        .max(degraded_rms.unwrap_or(0.0))
        .hypot(model_error_rms.unwrap_or(0.0))
}

/// Each photo whose residual is above [`RESIDUAL_MAX`] times what [`explained`] allows.
fn residual_reasons(best: &FitResult, residual: &[(f64, f64)], photos: &[String]) -> Vec<String> {
    let mut reasons: Vec<String> = Vec::new();
    for (v, (rms, nz)) in residual.iter().enumerate() {
        let me = best.model_error_rms.get(v).copied();
        let dg = best.degraded_rms.get(v).copied().flatten();
        let floor = explained(*nz, dg, me);
        if !(rms / floor <= RESIDUAL_MAX) {
            let copies = dg.map_or(String::new(), |d| format!(", copies of it made as it was ({d:.4})"));
            reasons.push(format!(
                "{}: the fit leaves a residual of rms {rms:.4}, {:.1} times what the photo's own noise ({nz:.4}){copies} \
                 and the model's own error ({:.4}) explain (at most {RESIDUAL_MAX}): this is not the card as a {} \
                 cuts it (another tool, another card, not a card), or the photo has what the model lacks (glare, a \
                 smudge, a card that is not flat); see the residual image",
                photos[v],
                rms / floor,
                me.unwrap_or(0.0),
                best.kind.name()
            ));
        }
    }
    reasons
}

/// Why a parameter the photos identify ended at a bound of its range: a photo's noise scale
/// (its dark plate), a photo's camera (its marks), or the tool (another kind).
fn at_bound_reason(best: &FitResult, name: &str, photos: &[String]) -> String {
    let k = best.params.iter().position(|p| p.0 == name).expect("a parameter");
    // A photo's camera (`eye[v]....`) is refined only a little from the one its marks gave:
    // at a bound, that camera was off, not the tool.
    let camera_of = name
        .strip_prefix("eye[")
        .and_then(|r| r.split(']').next())
        .and_then(|v| v.parse::<usize>().ok());
    // A photo's noise scale (`ln_noise[v]`): its dark plate is not what its noise makes it.
    let noise_of = name
        .strip_prefix("ln_noise[")
        .and_then(|r| r.split(']').next())
        .and_then(|v| v.parse::<usize>().ok());
    if let Some(v) = noise_of {
        let brighter = best.params[k].1 > 0.0;
        // Light the model lacks brightens a dark plate; a darker one is a camera or an app
        // that took light away or read the noise high (an unedited photo is no glare).
        let why = if brighter {
            "light the model lacks (glare, a lamp in view, a room light) or a photo brightened after it was \
             taken; photograph again with the lamp of the capture guide, the room dark"
        } else {
            "a camera that sets its black above the sensor's (phones with a dark-scene mode, a raised \
             contrast or a \"vivid\" filter), noise reduction or sharpening that makes the noise read higher \
             than it is, or a photo darkened or resized after it was taken; photograph again without filters \
             or night mode"
        };
        return format!(
            "{}: its dark plate is {} than the noise measured on the photo makes it, even with that noise \
             {} ({name} at {:.2}): {why}, and use the photo as the phone saved it",
            photos.get(v).map_or("a photo", |p| p.as_str()),
            if brighter { "brighter" } else { "darker" },
            if brighter { "doubled" } else { "halved" },
            best.params[k].1
        );
    }
    match camera_of {
        Some(v) => format!(
            "{}: its camera's {} ended at the bound of how far the fit may move it from the camera the card's \
             marks gave ({:.5}): the marks placed that camera poorly (a mark covered or in glare, the card seen \
             at a slant); photograph again from nearer the capture position with every mark in view",
            photos.get(v).map_or("a photo", |p| p.as_str()),
            name.split("].").nth(1).unwrap_or(name),
            best.params[k].1
        ),
        None => format!(
            "{name} ended at a bound of its range ({:.5}): the tool that fits best lies outside what this kind of \
             tool can be; try another --kind or check the photos",
            best.params[k].1
        ),
    }
}

/// Why a tool parameter is not identified, naming the largest cause (the photos' disagreement,
/// the noise's lift, a large photo's JPEG) and whether it ran to a bound.
fn unidentified_reason(best: &FitResult, name: &str, photos: &[String]) -> String {
    let k = best.params.iter().position(|p| p.0 == name).expect("a parameter");
    let sd = best.sd.get(k).copied().flatten();
    // Where the photos' disagreement is most of the uncertainty, that is the cause given:
    // each photo's own answer.
    let cause = match best
        .disagreement
        .get(k)
        .copied()
        .flatten()
        .filter(|d| sd.is_some_and(|sd| *d > 0.5 * sd))
    {
        Some(d) => {
            let each: Vec<String> = best
                .per_photo
                .iter()
                .zip(photos)
                .filter_map(|(pp, name)| {
                    pp.get(k)
                        .copied()
                        .flatten()
                        .map(|v| format!("{name} alone puts it at {v:.5}"))
                })
                .collect();
            format!(
                "the photos disagree by up to {d:.5} about it ({}; together {:.5}): one of them shows what the \
                 model lacks (noise averaged by a shrink, JPEG, glare; see the residual images)",
                each.join(", "),
                best.params[k].1
            )
        }
        None => {
            // A shift of which the fit counts `trust` in the uncertainty, where that part is
            // most of it.
            let most = |shifts: &[Option<f64>], trust: f64| {
                shifts
                    .get(k)
                    .copied()
                    .flatten()
                    .filter(|l| sd.is_some_and(|sd| trust * l.abs() > 0.5 * sd))
            };
            if let Some(l) = most(&best.noise_lift, crate::fit::LIFT_TRUST) {
                format!(
                    "the photos' noise, clipped at black, brightens the dark plate; the fit corrects for it \
                     (a shift of {l:.5}), but trusts that correction only in part. Photograph with more light \
                     and less noise (a lower ISO, a steady phone)"
                )
            } else if let Some(c) = most(&best.jpeg_change, crate::fit::CHANGE_TRUST) {
                // What a large photo's JPEG did, simulated from light coarser than its pixels.
                format!(
                    "a large photo's JPEG changed the grooves at its own pixels; the fit simulates that (a \
                     shift of {c:.5}) but cannot follow it closely. Save the photo as PNG or at the highest \
                     JPEG quality"
                )
            } else if let Some(m) = most(&best.model_error, 1.0) {
                // The model's own error, where the tone curve is free: a capture that reads the
                // parameter from the rungs' brightness (calibration/docs/fit.md, "The photo's
                // encoding"). Another photo of the same capture tells the same.
                format!(
                    "the capture tells it by how bright the rungs are, which the phone's own tone curve changes \
                     as well (the fit leaves each photo's curve free: no phone encodes exactly as one curve says), and \
                     the model's own approximation then moves it by {m:.5}; photographing the card again the same \
                     way will not pin it ({TONE_DOC})"
                )
            } else {
                "the grooves that tell it are too dim, saturated, noisy or compressed in the photos, or missing"
                    .to_string()
            }
        }
    };
    let mut msg = format!(
        "{name} is not identified: +- {} where a plate needs at most {:.5}: {cause}",
        sd.map_or("undefined".to_string(), |s| format!("{s:.5}")),
        best.limits.get(k).copied().unwrap_or(f64::NAN)
    );
    if !cause.contains(TONE_DOC) {
        msg += ". Photograph again with the lamp and exposure of the capture guide, the phone steady (less noise), \
                saved at full size as PNG or the highest JPEG quality";
    }
    if best.at_bound.iter().any(|n| n == name) {
        msg += &format!(
            " (it ran to a bound of its range, {:.5}: the value written is where its range ends, not what the \
             photos show)",
            best.params[k].1
        );
    }
    msg
}

/// A measured profile whose width shrinks as the cut goes deeper is no tool: a cutter plunged
/// deeper cuts at least as wide (a groove at one depth and none, or a narrower one, deeper down
/// is a fit that traded the widths with something else). The study's trial 7 was written with
/// 15.0 +- 0.2 um at -0.005 mm and no groove at +0.005 mm, 10.5 um off its truth. Widths are
/// compared with 3 standard deviations of slack (an unstated one counts as none). A width the
/// photos do not see (`FitResult::unseen`: its rung cuts no groove) is no groove: 0 where it
/// is the deeper one, and nothing to compare where it is the shallower (its value is where the
/// search left it: two studies' profiles were refused as narrowing from a start value of 6 um
/// at -0.005 mm).
fn shrinking_profile(best: &FitResult) -> Option<String> {
    if best.kind != crate::fit::Kind::Profile {
        return None;
    }
    // (depth, width, sd, seen)
    let mut w: Vec<(f64, f64, f64, bool)> = best
        .params
        .iter()
        .zip(&best.sd)
        .filter_map(|((name, v, _), sd)| {
            let z: f64 = name.strip_prefix("W_mm@")?.parse().ok()?;
            let seen = !best.unseen.contains(name);
            Some((z, if seen { *v } else { 0.0 }, sd.unwrap_or(0.0), seen))
        })
        .collect();
    w.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (i, a) in w.iter().enumerate() {
        if !a.3 {
            continue;
        }
        for b in &w[i + 1..] {
            if a.1 > b.1 + 3.0 * a.2.hypot(b.2) {
                return Some(format!(
                    "the measured profile narrows as the cut goes deeper: {:.1} um wide at {} mm but {:.1} um at {} mm \
                     (a deeper cut is at least as wide): the photos do not tell this tool's widths; photograph again \
                     (sharper, less noise, the capture guide's exposure) or fit a --kind with a shape",
                    1e3 * a.1,
                    a.0,
                    1e3 * b.1,
                    b.0
                ));
            }
        }
    }
    None
}

/// The residual's RMS may be at most this many times the photo's own pixel noise (or
/// `RESIDUAL_FLOOR`, whichever is larger): beyond it the model does not explain the photo.
/// Where the docs say why the guide's capture reads some parameters from the rungs' brightness.
const TONE_DOC: &str = "calibration/docs/fit.md, \"The photo's encoding\"";

pub const RESIDUAL_MAX: f64 = 3.0;
/// The smallest noise the residual is compared with (display units): 8-bit steps, JPEG and the
/// model's own error leave about this much even in a clean photo (a clean PNG: 0.0012 rms; a
/// clean quality-90 JPEG at the view's size: 0.0022). At 0.004 a tapered ball 14 um off whose
/// residual was 5 times its photo's noise (0.0073 against 0.0014, a 19-megapixel photo shrunk)
/// was accepted, at 0.002 a V-bit 3.6 degrees off (0.0051 against 0.0014).
pub const RESIDUAL_FLOOR: f64 = 0.0012;

#[cfg(test)]
mod verdict_tests {
    use super::*;
    use crate::fit::Kind;
    use scratchart_tool::Tool;

    /// A V-bit fit whose tool parameters have the given standard deviations.
    fn result(sd: [f64; 3], at_bound: &[&str]) -> FitResult {
        let names = ["angle_deg", "tip_flat_mm", "z_offset_mm", "alpha", "blur_px"];
        let values = [75.0, 0.015, 0.007, 0.1, 0.6];
        let limits = [0.5, 0.0025, 0.0015, 0.1, 1.0];
        let sds = [sd[0], sd[1], sd[2], 0.001, 0.01];
        FitResult {
            kind: Kind::VBit,
            tool: Tool::VBit {
                angle_deg: 75.0,
                tip_flat_mm: 0.015,
                z_offset_mm: 0.007,
            },
            alpha: 0.1,
            exposure: vec![1.0, 1.0],
            blur_px: vec![0.6, 0.6],
            params: (0..5)
                .map(|k| (names[k].to_string(), values[k], (sds[k] <= limits[k]).then_some(sds[k])))
                .collect(),
            loss: 1e-6,
            rms: 0.004,
            pixels: 50_000,
            bic: 0.0,
            renders: 0,
            tangent_passes: 0,
            engine_seconds: 0.0,
            engine_sync_seconds: 0.0,
            iterations: 0,
            bootstrap: None,
            curvature: vec![None; 5],
            sd: sds.iter().map(|s| Some(*s)).collect(),
            disagreement: vec![None; 5],
            noise_lift: vec![None; 5],
            model_error: vec![None; 5],
            degradation: vec![None; 5],
            jpeg_change: vec![None; 5],
            per_photo: vec![],
            model_error_rms: vec![],
            degraded_rms: vec![],
            limits: limits.to_vec(),
            unseen: vec![],
            at_bound: at_bound.iter().map(|s| s.to_string()).collect(),
        }
    }

    fn photos() -> Vec<String> {
        vec![
            "photo `a.jpg` (view cam_south)".into(),
            "photo `b.jpg` (view cam_west)".into(),
        ]
    }

    #[test]
    fn a_good_fit_is_accepted() {
        let v = verdict(
            &result([0.1, 0.001, 0.0005], &[]),
            &[(0.006, 0.005), (0.003, 0.0)],
            &photos(),
            false,
        );
        assert_eq!(v, Verdict::default());
    }

    #[test]
    fn a_residual_the_noise_does_not_explain_is_refused_naming_the_photo() {
        // 0.03 against noise 0.005: 6 times.
        let v = verdict(
            &result([0.1, 0.001, 0.0005], &[]),
            &[(0.006, 0.005), (0.03, 0.005)],
            &photos(),
            false,
        );
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].contains("b.jpg") && v.reasons[0].contains("6.0 times"),
            "{v:?}"
        );
        // A clean photo's noise is floored (quantization, JPEG, the model's own error): 0.003
        // against 0 is 2.5 times, 0.007 against 0 is 5.8 times.
        let v = verdict(
            &result([0.1, 0.001, 0.0005], &[]),
            &[(0.003, 0.0), (0.0025, 0.0)],
            &photos(),
            false,
        );
        assert!(v.reasons.is_empty(), "{v:?}");
        let v = verdict(
            &result([0.1, 0.001, 0.0005], &[]),
            &[(0.007, 0.0), (0.003, 0.0)],
            &photos(),
            false,
        );
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        // The model's own error is part of what a residual may be: 0.007 against a clean
        // photo whose model moves by 0.004 at four times the resolution is 1.7 times both, and
        // the same with 0.0005 of the model's error is 5.4 times.
        let mut fine = result([0.1, 0.001, 0.0005], &[]);
        fine.model_error_rms = vec![0.004, 0.0005];
        let v = verdict(&fine, &[(0.007, 0.0), (0.007, 0.0)], &photos(), false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].contains("b.jpg") && v.reasons[0].contains("5.4 times") && v.reasons[0].contains("0.0005"),
            "{v:?}"
        );
        // So is what copies of the photo made as it was leave against the model (a low-noise
        // JPEG's rounding of bright grooves): 0.0061 against a photo whose noise is 0.0001 and
        // whose copies leave 0.0035 is 1.7 times (study seed 1, trial 21's west photo, a right
        // ball); without the copies, 4.9 times. A photo whose copies leave less than its noise
        // is held to its noise.
        let mut copies = result([0.1, 0.001, 0.0005], &[]);
        copies.model_error_rms = vec![0.0003, 0.0003];
        copies.degraded_rms = vec![Some(0.0035), None];
        let v = verdict(&copies, &[(0.0061, 0.0001), (0.0061, 0.0001)], &photos(), false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].contains("b.jpg") && v.reasons[0].contains("4.9 times"),
            "{v:?}"
        );
        copies.degraded_rms = vec![Some(0.0035), Some(0.0001)];
        let v = verdict(&copies, &[(0.0061, 0.0001), (0.02, 0.005)], &photos(), false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].contains("b.jpg") && v.reasons[0].contains("4.0 times") && v.reasons[0].contains("(0.0001)"),
            "{v:?}"
        );
        // NaN is refused, not passed.
        let v = verdict(
            &result([0.1, 0.001, 0.0005], &[]),
            &[(f64::NAN, 0.005), (0.003, 0.0)],
            &photos(),
            false,
        );
        assert_eq!(v.reasons.len(), 1, "{v:?}");
    }

    #[test]
    fn a_parameter_at_its_bound_is_refused() {
        let check = |sd: [f64; 3], bound: &str, allow: bool| {
            verdict(&result(sd, &[bound]), &[(0.004, 0.004); 2], &photos(), allow)
        };
        let v = check([0.1, 0.001, 0.0005], "tip_flat_mm", false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(v.reasons[0].starts_with("tip_flat_mm ended at a bound"), "{v:?}");
        // --allow-unidentified does not let a parameter at its bound through.
        let v = check([0.1, 0.001, 0.0005], "angle_deg", true);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        // One the photos do not identify is refused once, as not identified, and with
        // --allow-unidentified written with a warning that its value is its bound.
        let v = check([3.0, 0.001, 0.0005], "angle_deg", false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(v.reasons[0].starts_with("angle_deg is not identified"), "{v:?}");
        assert!(v.reasons[0].contains("ran to a bound"), "{v:?}");
        let v = check([3.0, 0.001, 0.0005], "angle_deg", true);
        assert!(v.reasons.is_empty(), "{v:?}");
        assert_eq!(v.allowed.len(), 1, "{v:?}");
        assert!(v.allowed[0].contains("ran to a bound"), "{v:?}");
        // A photo's camera at its bound names the photo and its camera, not the tool's kind.
        let mut r = result([0.1, 0.001, 0.0005], &["eye[1].ln_fov"]);
        r.params.push(("eye[1].ln_fov".into(), 0.05, Some(0.01)));
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].starts_with("photo `b.jpg` (view cam_west): its camera's ln_fov ended at the bound")
                && !v.reasons[0].contains("--kind"),
            "{v:?}"
        );
        // A photo's noise scale at its bound names the photo and what brightens its dark plate,
        // once: not also as a tool parameter not identified (it stopped in a valley).
        let mut r = result([0.1, 0.001, 0.0005], &["ln_noise[0]"]);
        r.params.push(("ln_noise[0]".into(), 0.7, None));
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].starts_with("photo `a.jpg` (view cam_south): its dark plate is brighter")
                && v.reasons[0].contains("glare")
                && !v.reasons[0].contains("--kind"),
            "{v:?}"
        );
        // Darker: not glare (glare brightens), but a camera or an app that took light away.
        let mut r = result([0.1, 0.001, 0.0005], &["ln_noise[1]"]);
        r.params.push(("ln_noise[1]".into(), -0.7, None));
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].starts_with("photo `b.jpg` (view cam_west): its dark plate is darker")
                && !v.reasons[0].contains("glare")
                && v.reasons[0].contains("black"),
            "{v:?}"
        );
    }

    #[test]
    fn a_profile_that_narrows_deeper_is_refused() {
        let profile = |w: [f64; 3], sd: [Option<f64>; 3]| {
            let mut r = result([0.1, 0.001, 0.0005], &[]);
            r.kind = Kind::Profile;
            r.params = ["W_mm@-0.005", "W_mm@0.005", "W_mm@0.02"]
                .iter()
                .zip(w)
                .zip(sd)
                .map(|((n, v), s)| (n.to_string(), v, s))
                .collect();
            r.sd = sd.to_vec();
            r.limits = vec![0.0025; 3];
            r.curvature = vec![None; 3];
            r
        };
        // 15 um at -0.005 mm and no groove at +0.005 mm (the study's trial 7).
        let v = verdict(
            &profile([0.015, 0.0, 0.025], [Some(0.0002), None, Some(0.0003)]),
            &[(0.004, 0.004); 2],
            &photos(),
            true,
        );
        assert!(v.reasons.iter().any(|m| m.contains("narrows")), "{v:?}");
        // Widening with depth, or narrowing within the uncertainties, is a tool.
        for (w, sd) in [
            ([0.006, 0.012, 0.03], [Some(0.0002); 3]),
            ([0.0121, 0.012, 0.03], [Some(0.0002); 3]),
        ] {
            let v = verdict(&profile(w, sd), &[(0.004, 0.004); 2], &photos(), true);
            assert!(!v.reasons.iter().any(|m| m.contains("narrows")), "{v:?}");
        }
        // A width the photos do not see is no groove: a start value of 6 um left at -0.005 mm
        // over a seen 5.2 um deeper is no narrowing (the study's trial 15)...
        let mut r = profile([0.006, 0.0052, 0.03], [None, Some(0.0002), Some(0.0002)]);
        r.unseen = vec!["W_mm@-0.005".into()];
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), true);
        assert!(!v.reasons.iter().any(|m| m.contains("narrows")), "{v:?}");
        // ...while a seen groove over an unseen one deeper (left at 12 um) narrows to nothing.
        let mut r = profile([0.0099, 0.012, 0.03], [Some(0.0002), None, Some(0.0002)]);
        r.unseen = vec!["W_mm@0.005".into()];
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), true);
        assert!(
            v.reasons
                .iter()
                .any(|m| m.contains("9.9 um wide at -0.005 mm but 0.0 um at 0.005 mm")),
            "{v:?}"
        );
    }

    #[test]
    fn photos_that_disagree_are_named_as_the_cause() {
        // The angle +- 3.3 degrees, 3.27 of it the two photos' disagreement.
        let mut r = result([3.3, 0.001, 0.0005], &[]);
        r.disagreement = vec![Some(3.27), None, None, None, None];
        r.per_photo = vec![vec![Some(71.73), None], vec![Some(75.42), None]];
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        let m = &v.reasons[0];
        assert!(m.starts_with("angle_deg is not identified: +- 3.30000"), "{m}");
        assert!(
            m.contains("(view cam_south) alone puts it at 71.73000")
                && m.contains("(view cam_west) alone puts it at 75.42000"),
            "{m}"
        );
        // Where the disagreement is the lesser part, the grooves are the cause given.
        r.disagreement = vec![Some(0.2), None, None, None, None];
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert!(
            v.reasons[0].contains("too dim") && !v.reasons[0].contains("alone"),
            "{v:?}"
        );
        // Where the noise's lift, in the part not trusted, is most of it: the noise is named.
        // The angle +- 3.0 degrees, 2.9 of it the part of the lift's 5.8-degree shift not trusted.
        let mut r = result([3.0, 0.001, 0.0005], &[]);
        r.noise_lift = vec![Some(-2.9 / crate::fit::LIFT_TRUST), None, None, None, None];
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert!(
            v.reasons[0].starts_with("angle_deg is not identified") && v.reasons[0].contains("clipped at black"),
            "{v:?}"
        );
        r.noise_lift = vec![Some(0.001), None, None, None, None];
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert!(v.reasons[0].contains("too dim"), "{v:?}");
        // A large photo's JPEG, simulated but not followed closely, named as the cause.
        let mut r = result([2.0, 0.001, 0.0005], &[]);
        r.jpeg_change = vec![Some(1.9 / crate::fit::CHANGE_TRUST), None, None, None, None];
        let v = verdict(&r, &[(0.004, 0.004); 2], &photos(), false);
        assert!(v.reasons[0].contains("a large photo's JPEG"), "{v:?}");
    }

    #[test]
    fn an_unidentified_tool_parameter_is_refused_unless_allowed() {
        // The angle +- 0.8 degrees where a plate needs 0.5.
        let v = verdict(
            &result([0.8, 0.001, 0.0005], &[]),
            &[(0.004, 0.004); 2],
            &photos(),
            false,
        );
        assert_eq!(v.unidentified, vec!["angle_deg".to_string()]);
        assert_eq!(v.reasons.len(), 1, "{v:?}");
        assert!(
            v.reasons[0].contains("angle_deg is not identified: +- 0.80000"),
            "{v:?}"
        );
        let v = verdict(
            &result([0.8, 0.001, 0.0005], &[]),
            &[(0.004, 0.004); 2],
            &photos(),
            true,
        );
        assert!(v.reasons.is_empty(), "{v:?}");
        assert_eq!(v.allowed.len(), 1, "{v:?}");
    }
}
