//! `scratchart-cal fit`: photos of the card in, `tool.json` out (with the residual images and the
//! plot of the width law beside it).
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use scratchart::exit::{InputError, UsageError};
use scratchart::observe::Observer;
use scratchart::render::Renderer;
use scratchart_tool::{Fitted, Tool};
use serde_json::json;

use super::card::Card;
use super::fit::{fit_kind, predict, Data, FitConfig, FitError, FitResult, Kind, Start};
pub mod inspect;
mod plot;
mod verdict;

use inspect::check_photos;
pub use inspect::{fit_mask, inspect_photo, Inspection};
use plot::{measured_widths, profile_plot};
pub use verdict::{verdict, Verdict, RESIDUAL_FLOOR, RESIDUAL_MAX};

/// Flags of `scratchart-cal fit`.
#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// The card (card.json from `scratchart-cal card`)
    #[arg(long)]
    pub card: PathBuf,
    /// Photos of the cut card, one per capture view, named after the views (cam_south.jpg, ...)
    /// or given in the views' order. PNG or JPEG, any size, colour or grey.
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Tool model to fit: v-bit, ball, tapered-ball or profile (default: all, the best by BIC)
    #[arg(long, value_parser = ["v-bit", "ball", "tapered-ball", "profile"])]
    pub kind: Option<String>,
    /// Output tool file; its residual images and profile plot go beside it
    #[arg(long, default_value = "tool.json")]
    pub out: PathBuf,
    /// Start from this tool (a previous fit): re-run on more or new photos without the search
    #[arg(long)]
    pub init: Option<PathBuf>,
    /// Levenberg-Marquardt iterations per refinement
    #[arg(long, default_value_t = 15)]
    pub iters: u32,
    /// Go on with an interrupted fit (Ctrl-C, a crash): the kinds it finished and the start
    /// points it had searched are read from OUT's resume file (OUT with `.resume.json`, written
    /// atomically as the fit goes, removed when it ends), so only the rest is done. The photos,
    /// card and options must be the same
    #[arg(long)]
    pub resume: bool,
    /// Also estimate the uncertainties by a block bootstrap with N refits (about 1 s each here):
    /// they see what the curvature's miss (neighbouring pixels share the blur; parameters that
    /// trade). Printed beside the curvature's and kept in tool.json (`fit.bootstrap`)
    #[arg(long, default_value_t = 0)]
    pub bootstrap: u32,
    /// Write tool.json even when a parameter of the tool is not identified (its uncertainty
    /// is above what a plate needs: 0.5 degrees, 2.5 um of length, 1.5 um of z offset); the
    /// file then lists them under `fit.written_with_unidentified`
    #[arg(long)]
    pub allow_unidentified: bool,
    /// Only say of each photo whether the fit can use it (card found, marks and their
    /// confidence, the camera, saturation, noise), in seconds, without fitting
    #[arg(long)]
    pub check: bool,
    /// No progress bar
    #[arg(long)]
    pub quiet: bool,
}

/// Pairs photos with capture views: by file name (the view's name) when every photo names one,
/// else in order.
fn pair_photos(images: &[PathBuf], names: &[String]) -> Result<Vec<PathBuf>> {
    if images.len() < names.len() {
        return Err(InputError(format!(
            "the fit needs one photo per capture view ({}), got {}; photograph the card from each",
            names.join(", "),
            images.len()
        ))
        .into());
    }
    let stem = |p: &PathBuf| {
        p.file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default()
    };
    let by_name: Vec<Option<&PathBuf>> = names.iter().map(|n| images.iter().find(|p| stem(p) == *n)).collect();
    if by_name.iter().all(|p| p.is_some()) {
        return Ok(by_name.into_iter().map(|p| p.unwrap().clone()).collect());
    }
    if images.len() != names.len() {
        return Err(UsageError(format!(
            "{} photos for {} capture views: name each after its view ({}) or give exactly one per view in order",
            images.len(),
            names.len(),
            names.join(", ")
        ))
        .into());
    }
    Ok(images.to_vec())
}

/// Whether every capture view has a photo named after it.
fn all_named(images: &[PathBuf], names: &[String]) -> bool {
    names.iter().all(|n| {
        images
            .iter()
            .any(|p| p.file_stem().is_some_and(|s| s.to_string_lossy() == *n))
    })
}

/// Photos given in an order that is not the views' (IMG_0001 is the west view): each photo is
/// tried against each capture view, and where the views' order does not register every photo
/// but another order does, that order is taken and said. The card's marks fix which view a
/// photo was taken from: from another view's camera they are not found (the camera they give
/// would stand a quarter turn from it).
pub fn order_by_marks(
    card: &Card,
    capture: &scratchart::model::scene::Scene,
    files: Vec<PathBuf>,
    obs: &dyn Observer,
) -> Vec<PathBuf> {
    let n = files.len();
    if !(2..=6).contains(&n) {
        return files;
    }
    let mut ok: Vec<Vec<Option<bool>>> = vec![vec![None; n]; n];
    let mut fits = |i: usize, v: usize| -> bool {
        *ok[i][v].get_or_insert_with(|| inspect_photo(card, capture, &capture.views[v], &files[i]).is_ok())
    };
    if (0..n).all(|i| fits(i, i)) {
        return files;
    }
    // The order that registers the most photos, the views' own first among equals.
    let mut perm: Vec<usize> = (0..n).collect();
    let mut best: (usize, Vec<usize>) = ((0..n).filter(|&i| fits(i, i)).count(), perm.clone());
    while next_permutation(&mut perm) {
        let good = (0..n).filter(|&i| fits(i, perm[i])).count();
        if good > best.0 {
            best = (good, perm.clone());
        }
    }
    let (good, perm) = best;
    if perm.iter().enumerate().all(|(i, &v)| i == v) {
        return files;
    }
    let mut out = files.clone();
    for (i, &v) in perm.iter().enumerate() {
        out[v] = files[i].clone();
        if i != v {
            obs.info(&format!(
                "photo `{}` is view {} (found by the card's marks; it was given in the place of {})",
                files[i].display(),
                capture.views[v].name,
                capture.views[i].name
            ));
        }
    }
    if good < n {
        obs.info(&format!("{} of {n} photos register in any order of the views", good));
    }
    out
}

/// The next permutation in lexicographic order (false after the last).
fn next_permutation(p: &mut [usize]) -> bool {
    let n = p.len();
    if n < 2 {
        return false;
    }
    let mut i = n - 1;
    while i > 0 && p[i - 1] >= p[i] {
        i -= 1;
    }
    if i == 0 {
        return false;
    }
    let mut j = n - 1;
    while p[j] <= p[i - 1] {
        j -= 1;
    }
    p.swap(i - 1, j);
    p[i..].reverse();
    true
}

impl FitArgs {
    /// The flags of a quiet fit of `kind` (None: every kind) to `images` of `card`, writing
    /// `out`, with the defaults of the command line: what the study, the examples and the tests
    /// run.
    pub fn quiet(card: &Path, images: Vec<PathBuf>, kind: Option<&str>, out: &Path) -> FitArgs {
        FitArgs {
            card: card.to_path_buf(),
            images,
            kind: kind.map(String::from),
            out: out.to_path_buf(),
            init: None,
            iters: 15,
            resume: false,
            bootstrap: 0,
            quiet: true,
            allow_unidentified: false,
            check: false,
        }
    }
}

pub fn run(renderer: &Renderer, args: &FitArgs, obs: &dyn Observer) -> Result<()> {
    let (card, capture) = Card::load(&args.card).map_err(|e| InputError(format!("{e:#}")))?;
    let names: Vec<String> = capture.views.iter().map(|v| v.name.clone()).collect();
    if args.check {
        return check_photos(&card, &capture, &args.images, obs);
    }
    let files = pair_photos(&args.images, &names)?;
    let files = if all_named(&args.images, &names) {
        files
    } else {
        order_by_marks(&card, &capture, files, obs)
    };
    let (capture, data_parts, inspections) = load_photos(&card, &capture, &files, obs)?;
    let noise = data_parts.noise.clone();
    let data = Data {
        card: &card,
        capture: &capture,
        photos: data_parts.photos,
        masks: data_parts.masks,
        refine_shift: true,
        refine_pose: data_parts.refine_pose,
        jpeg: data_parts.jpeg,
        noise: data_parts.noise,
        shrink: data_parts.shrink,
        native_noise: data_parts.native_noise,
        colour: data_parts.colour,
        saved_jpeg: data_parts.saved_jpeg,
        gains: data_parts.gains,
    };
    let init = match &args.init {
        Some(p) => {
            let (t, f) = Tool::load_fitted(p).map_err(|e| InputError(e.to_string()))?;
            Some((t, f.alpha))
        }
        None => None,
    };
    let kinds: Vec<Kind> = match (&args.kind, &init) {
        (Some(k), _) => vec![Kind::parse(k).expect("clap checked")],
        (None, Some((t, _))) => vec![Kind::parse(match t {
            Tool::VBit { .. } => "v-bit",
            Tool::Ball { .. } => "ball",
            Tool::TaperedBall { .. } => "tapered-ball",
            Tool::Profile { .. } => "profile",
        })
        .expect("known kind")],
        (None, None) => Kind::ALL.to_vec(),
    };
    let (state_path, state) = open_resume(args, &files, obs)?;
    let t0 = std::time::Instant::now();
    let results = fit_kinds(renderer, &data, &kinds, &init, args, &state_path, state, obs)?;
    let best = results
        .iter()
        .min_by(|a, b| a.bic.total_cmp(&b.bic))
        .expect("at least one kind")
        .clone();
    let secs = t0.elapsed().as_secs_f64();
    let (pred, registered) = predict(renderer, &data, &best)?;
    // Report.
    obs.result(&format!(
        "fitted {} to {} photo(s) in {secs:.1} s ({} renders, {} tangent passes): rms residual {:.4} (display units)",
        best.kind.name(),
        files.len(),
        results.iter().map(|r| r.renders).sum::<u32>(),
        results.iter().map(|r| r.tangent_passes).sum::<u32>(),
        best.rms
    ));
    print_fit(&best, &results, obs);
    let residual = photo_residuals(&data, &pred, &registered, &noise);
    for (v, (rms, nz)) in residual.iter().enumerate() {
        obs.result(&format!(
            "  photo {}: residual rms {rms:.4}, its own noise {nz:.4} ({:.1} times)",
            files[v].display(),
            rms / nz.max(RESIDUAL_FLOOR)
        ));
    }
    let photo_names: Vec<String> = files
        .iter()
        .zip(&capture.views)
        .map(|(f, v)| format!("photo `{}` (view {})", f.display(), v.name))
        .collect();
    let Verdict {
        reasons,
        allowed,
        unidentified,
    } = verdict(&best, &residual, &photo_names, args.allow_unidentified);
    // Residual images, the plot and the report, whatever the verdict.
    let stem = args.out.with_extension("");
    if let Some(dir) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    write_residual_images(&stem, &capture, &data, &pred, &registered, obs)?;
    let plot = PathBuf::from(format!("{}_profile.png", stem.display()));
    let points = measured_widths(&data, &registered, &best, &pred);
    profile_plot(&plot, &best, &card, &points)?;
    obs.result(&format!(
        "wrote {} (W and w against commanded depth, measured points)",
        plot.display()
    ));
    let record = fit_record(
        &best,
        &results,
        &unidentified,
        &files,
        &inspections,
        &residual,
        args,
        secs,
    );
    let report_path = PathBuf::from(format!("{}_report.json", stem.display()));
    let report = json!({
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
    });
    scratchart::io::write_atomic(&report_path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    obs.result(&format!(
        "wrote {} (the fit, its checks and its verdict)",
        report_path.display()
    ));
    let _ = std::fs::remove_file(&state_path);
    if !reasons.is_empty() {
        return Err(InputError(format!(
            "the fit is refused and no {} was written:\n  - {}",
            args.out.display(),
            reasons.join("\n  - ")
        ))
        .into());
    }
    let mut record = record;
    if !allowed.is_empty() {
        record["written_with_unidentified"] = json!(allowed);
    }
    let fitted = Fitted {
        alpha: Some(best.alpha),
        fit: Some(record),
    };
    scratchart::io::write_atomic(&args.out, best.tool.to_json_fitted(&fitted).as_bytes())?;
    obs.result(&format!("wrote {}", args.out.display()));
    for a in &allowed {
        obs.result(&format!("  warning (--allow-unidentified): {a}"));
    }
    Ok(())
}

/// What the fit takes from each photo (see [`load_photos`]).
struct PhotoData {
    photos: Vec<Vec<f32>>,
    masks: Vec<Vec<bool>>,
    refine_pose: Vec<bool>,
    jpeg: Vec<Option<u8>>,
    noise: Vec<f64>,
    shrink: Vec<u32>,
    native_noise: Vec<f64>,
    colour: Vec<bool>,
    saved_jpeg: Vec<Option<u8>>,
    gains: Vec<[f64; 3]>,
}

/// Per photo, for the report: its size as taken, the marks found and their confidences, the
/// camera's eye and how far it stood from the capture position, the shrink, the sensor's noise
/// per channel at the photo's own resolution, colour or grey, and its JPEG quality.
type PhotoRecord = serde_json::Value;

/// Each photo inspected ([`inspect_photo`]: loaded, shrunk, registered, checked) against its
/// capture view; the scene of the photos' own cameras, what the fit compares, and the report's
/// record of each photo.
fn load_photos(
    card: &Card,
    capture: &scratchart::model::scene::Scene,
    files: &[PathBuf],
    obs: &dyn Observer,
) -> Result<(scratchart::model::scene::Scene, PhotoData, Vec<PhotoRecord>)> {
    let mut photos = Vec::new();
    let mut masks = Vec::new();
    let mut fit_views = Vec::new();
    let mut refine_pose = Vec::new();
    let mut noise = Vec::new();
    let mut shrink = Vec::new();
    let mut native_noise = Vec::new();
    let mut colour = Vec::new();
    let mut saved_jpeg = Vec::new();
    let mut gains = Vec::new();
    let mut jpeg = Vec::new();
    let mut inspections = Vec::new();
    for (v, f) in capture.views.iter().zip(files) {
        let insp = inspect_photo(card, capture, v, f)?;
        obs.info(&insp.summary());
        photos.push(insp.image.data.clone());
        masks.push(insp.mask);
        refine_pose.push(insp.off_pose);
        jpeg.push(insp.jpeg);
        noise.push(insp.noise);
        shrink.push(insp.shrink);
        native_noise.push(insp.native_noise);
        colour.push(insp.colour);
        saved_jpeg.push(insp.saved_jpeg);
        gains.push(insp.gains);
        inspections.push(json!({
            "size": [insp.taken.0, insp.taken.1],
            "marks_found": insp.found.count(),
            "mark_confidence": insp.found.confidence,
            "camera_eye_mm": insp.view.camera.eye,
            "moved_mm": insp.moved_mm,
            "shrunk_by": insp.shrink,
            "sensor_noise": insp.native_noise,
            "colour": insp.colour,
            "jpeg_quality": insp.saved_jpeg,
            "white_balance": insp.gains,
            "px_per_mm": insp.scale.photo_px_per_mm,
            "fit_px_per_mm": insp.scale.fit_px_per_mm,
            "needed_px_per_mm": insp.needed_px_per_mm,
        }));
        fit_views.push(insp.view);
    }
    let fit_scene = scratchart::model::scene::Scene {
        plate: capture.plate.clone(),
        views: fit_views,
        scratches: vec![],
    };
    fit_scene
        .validate()
        .map_err(|e| InputError(format!("the photos' cameras do not make a valid scene: {e}")))?;
    let data = PhotoData {
        photos,
        masks,
        refine_pose,
        jpeg,
        noise,
        shrink,
        native_noise,
        colour,
        saved_jpeg,
        gains,
    };
    Ok((fit_scene, data, inspections))
}

/// The resume file of this fit (`OUT.resume.json`) and what it holds: with `--resume`, the
/// state an interrupted fit of the same photos, card and options left (refused where it is of
/// others); else a fresh state.
fn open_resume(args: &FitArgs, files: &[PathBuf], obs: &dyn Observer) -> Result<(PathBuf, ResumeState)> {
    let state_path = resume_path(&args.out);
    let key = resume_key(args, files)?;
    let mut state = ResumeState {
        key: key.clone(),
        done: Vec::new(),
        current: None,
    };
    if args.resume {
        match std::fs::read(&state_path) {
            Ok(bytes) => {
                let old: ResumeState = serde_json::from_slice(&bytes).map_err(|e| {
                    InputError(format!(
                        "resume file `{}` is unreadable ({e}); remove it and run without --resume",
                        state_path.display()
                    ))
                })?;
                if old.key != key {
                    return Err(InputError(format!(
                        "resume file `{}` is from a fit of other photos, another card or other options; \
                         run with the same ones, or remove it and run without --resume",
                        state_path.display()
                    ))
                    .into());
                }
                obs.info(&format!(
                    "resuming: {} kind(s) done{}",
                    old.done.len(),
                    old.current
                        .as_ref()
                        .map_or(String::new(), |c| format!(", {} searched", c.0))
                ));
                state = old;
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                obs.info(&format!(
                    "no interrupted fit at `{}`: starting afresh",
                    state_path.display()
                ));
            }
            Err(e) => return Err(anyhow::anyhow!("cannot read `{}`: {e}", state_path.display())),
        }
    }
    if let Some(dir) = state_path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    Ok((state_path, state))
}

/// Fits each of `kinds` not yet done in `state`, saving the state as it goes (a kind finished,
/// the start points searched); Ctrl-C leaves it for `--resume`.
#[allow(clippy::too_many_arguments)]
fn fit_kinds(
    renderer: &Renderer,
    data: &Data,
    kinds: &[Kind],
    init: &Option<(Tool, Option<f64>)>,
    args: &FitArgs,
    state_path: &Path,
    mut state: ResumeState,
    obs: &dyn Observer,
) -> Result<Vec<FitResult>> {
    let save = |st: &ResumeState| -> Result<()> {
        scratchart::io::write_atomic(state_path, serde_json::to_string(st)?.as_bytes())?;
        Ok(())
    };
    let mut results: Vec<FitResult> = state.done.clone();
    for &k in kinds {
        if results.iter().any(|r| r.kind == k) {
            continue;
        }
        let cfg = FitConfig {
            iters: args.iters,
            init: init.clone(),
            starts: state.current.as_ref().filter(|c| c.0 == k.name()).map(|c| c.1.clone()),
            bootstrap: args.bootstrap,
        };
        let mut saved: Result<()> = Ok(());
        let got = fit_kind(renderer, data, k, &cfg, obs, &mut |starts: &[Start]| {
            state.current = Some((k.name().to_string(), starts.to_vec()));
            saved = save(&state);
        });
        saved?;
        match got {
            Ok(r) => {
                state.done.push(r.clone());
                state.current = None;
                save(&state)?;
                obs.info(&format!(
                    "{}: loss {:.4e}, rms {:.4}, BIC {:.0} ({} renders, {} tangent passes)",
                    k.name(),
                    r.loss,
                    r.rms,
                    r.bic,
                    r.renders,
                    r.tangent_passes
                ));
                results.push(r);
            }
            Err(FitError::Interrupted) => {
                obs.info(&format!(
                    "stopped; `{}` keeps what is done: run the same command with --resume to go on",
                    state_path.display()
                ));
                return Err(scratchart::optim::OptimError::Interrupted {
                    iter: 0,
                    checkpoint: Some(state_path.to_path_buf()),
                }
                .into());
            }
            Err(e) => return Err(e.into()),
        }
    }
    Ok(results)
}

/// The fitted parameters as the terminal shows them: the kinds compared, each tool parameter
/// with its uncertainty (or why it has none), the exposures and the blur.
fn print_fit(best: &FitResult, results: &[FitResult], obs: &dyn Observer) {
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
    obs.result(&format!(
        "  exposure {:?}, camera blur {:?} px{noise_note}",
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
fn photo_residuals(data: &Data, pred: &[Vec<f32>], registered: &[Vec<f32>], noise: &[f64]) -> Vec<(f64, f64)> {
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
fn write_residual_images(
    stem: &Path,
    capture: &scratchart::model::scene::Scene,
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
        scratchart::io::write_png_gray(&p, view.camera.width, view.camera.height, &bytes)?;
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
fn fit_record(
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
        "uncertainty_method": "block sandwich (16 x 16 pixel blocks) at the optimum, with the model's own error, the photos' degradations and the photos' disagreement in quadrature",
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
        "jacobian": "engine derivatives (tangent passes) for the tool, z offset and alpha; differences for eyes and camera terms",
    })
}

/// What an interrupted fit had done (`--resume`): the kinds it finished, and the start points of
/// the kind it was refining. `key` ties it to the photos, the card and the options.
#[derive(serde::Serialize, serde::Deserialize)]
struct ResumeState {
    key: String,
    done: Vec<FitResult>,
    current: Option<(String, Vec<Start>)>,
}

/// The resume file of a fit writing `out`: `out` with the extension `.resume.json`.
pub fn resume_path(out: &std::path::Path) -> PathBuf {
    out.with_extension("resume.json")
}

/// A digest of what decides a fit: the card file, every photo's bytes, the kind, the start tool
/// and the options (FNV-1a 64 of each part's FNV-1a 64, so concatenations differ).
fn resume_key(args: &FitArgs, files: &[PathBuf]) -> Result<String> {
    use scratchart::optim::checkpoint::fnv;
    let read = |p: &std::path::Path| std::fs::read(p).with_context(|| format!("cannot read {}", p.display()));
    let mut parts = vec![fnv(&read(&args.card)?)];
    for f in files {
        parts.push(fnv(&read(f)?));
    }
    parts.push(fnv(
        format!("{:?}|{}|{}", args.kind, args.iters, args.bootstrap).as_bytes()
    ));
    if let Some(p) = &args.init {
        parts.push(fnv(&read(p)?));
    }
    let bytes: Vec<u8> = parts.iter().flat_map(|h| h.to_le_bytes()).collect();
    Ok(format!("{:016x}", fnv(&bytes)))
}

/// Whether a fitted parameter is the tool's (or alpha) rather than the camera's (exposure,
/// registration shift, an off-pose photo's eye, its noise scale): what the report and tool.json show.
pub(super) fn is_tool_param(name: &str) -> bool {
    !(name.starts_with("ln_exposure")
        || name.starts_with("registration")
        || name.starts_with("eye[")
        || name.starts_with("shade[")
        || name.starts_with("ln_noise[")
        || name.starts_with("tone["))
}

#[cfg(test)]
mod order_tests {
    use super::next_permutation;

    #[test]
    fn permutations_come_in_order_and_end() {
        let mut p = vec![0, 1, 2];
        let mut seen = vec![p.clone()];
        while next_permutation(&mut p) {
            seen.push(p.clone());
        }
        assert_eq!(
            seen,
            vec![
                vec![0, 1, 2],
                vec![0, 2, 1],
                vec![1, 0, 2],
                vec![1, 2, 0],
                vec![2, 0, 1],
                vec![2, 1, 0]
            ]
        );
        assert!(!next_permutation(&mut [0]));
    }
}
