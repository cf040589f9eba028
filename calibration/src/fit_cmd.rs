//! `scratchart-cal fit`: photos of the card in, `tool.json` out (with the residual images and the
//! plot of the width law beside it).
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use scratchart_exit::InputError;
use scratchart_observe::Observer;
use scratchart_render::Renderer;
use scratchart_tool::{Fitted, Tool};
use serde_json::json;

use super::card::Card;
use super::fit::{fit_kind, predict, Data, FitConfig, FitError, FitResult, Kind, Start};
pub mod inspect;
pub mod photos;
mod plot;
mod report;
mod resume;
pub(crate) mod verdict;

use inspect::check_photos;
pub use inspect::{fit_mask, inspect_photo, Inspection};
use photos::{all_named, load_photos, order_by_marks, pair_photos};
use plot::{measured_widths, profile_plot};
use report::{fit_record, photo_residuals, print_fit, report_json, write_residual_images};
use resume::{open_resume, ResumeState};
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
    /// Render every view whole rather than the tiles its residuals read (the same fit to the
    /// bit, slower: the check of the windowed renders)
    #[arg(long, hide = true)]
    pub whole_renders: bool,
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
            whole_renders: false,
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
    let (init, kinds) = start_and_kinds(args)?;
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
        "fitted {} to {} photo(s) in {secs:.1} s ({} renders, {} tangent passes; {:.1} s in the engine's calls, {:.1} s of them setting the grooves and uploading): rms residual {:.4} (display units)",
        best.kind.name(),
        files.len(),
        results.iter().map(|r| r.renders).sum::<u32>(),
        results.iter().map(|r| r.tangent_passes).sum::<u32>(),
        results.iter().map(|r| r.engine_seconds).sum::<f64>(),
        results.iter().map(|r| r.engine_sync_seconds).sum::<f64>(),
        best.rms
    ));
    print_fit(&best, &results, obs);
    let residual = photo_residuals(&data, &pred, &registered, &noise);
    for (v, (rms, nz)) in residual.iter().enumerate() {
        obs.result(&format!(
            "  photo {}: residual rms {rms:.4}, its own noise {nz:.4}, the model's own error {:.4} ({:.1} times both)",
            files[v].display(),
            best.model_error_rms.get(v).copied().unwrap_or(0.0),
            rms / verdict::explained(
                *nz,
                best.degraded_rms.get(v).copied().flatten(),
                best.model_error_rms.get(v).copied()
            )
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
    let report = report_json(&best, &reasons, &allowed, &record)?;
    scratchart_render::io::write_atomic(&report_path, serde_json::to_string_pretty(&report)?.as_bytes())?;
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
    scratchart_render::io::write_atomic(&args.out, best.tool.to_json_fitted(&fitted).as_bytes())?;
    obs.result(&format!("wrote {}", args.out.display()));
    for a in &allowed {
        obs.result(&format!("  warning (--allow-unidentified): {a}"));
    }
    Ok(())
}

/// The fit's start (`--init`: a tool.json and its alpha) and the kinds to fit: `--kind`, else
/// the start's kind, else every kind.
fn start_and_kinds(args: &FitArgs) -> Result<(Option<(Tool, Option<f64>)>, Vec<Kind>)> {
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
    Ok((init, kinds))
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
        scratchart_render::io::write_atomic(state_path, serde_json::to_string(st)?.as_bytes())?;
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
            whole_renders: args.whole_renders,
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
                return Err(scratchart_optim::error::OptimError::Interrupted {
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
