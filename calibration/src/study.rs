//! `scratchart-cal study`: the recovery study of the tool fit. Random tools of all four kinds
//! are "cut" into the card, photographed as a phone would (`crate::phone`: every degradation the
//! fit must take, drawn at random), and fitted as a maker would (`fit --kind` of the tool in the
//! spindle). Each trial ends in one of three ways: recovered (within 1 degree, 5 um of length
//! and 3 um of z offset: what a plate needs), refused (exit 3, with its reason), or wrong but
//! accepted (a tool.json that would ruin a plate: the number that must be 0). It also checks the
//! stated uncertainties: how often the truth lies within one stated standard deviation (about
//! 68% if they mean something).
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result};
use scratchart_design::scenes::Rng;
use scratchart_observe::{Observer, Silent};
use scratchart_render::Renderer;
use scratchart_tool::Tool;
use serde_json::json;

use super::card::{Card, CardSpec};
use super::fit::{Kind, ANGLE_TOL_DEG, LENGTH_TOL_MM, OFFSET_TOL_MM};
use super::fit_cmd::{run as fit, FitArgs};
use super::phone::{random_shot, random_shot_outside, random_shot_within, take, Shot, Violation};

/// Flags of `scratchart-cal study`.
#[derive(clap::Args, Debug)]
pub struct StudyArgs {
    /// Number of random tools (kinds in turn: v-bit, ball, tapered-ball, profile)
    #[arg(long, default_value_t = 24)]
    pub trials: usize,
    /// Seed of the draws (the same seed gives the same tools and photos)
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Largest angle between a photo's camera and its capture view, degrees
    #[arg(long, default_value_t = 20.0)]
    pub max_tilt: f64,
    /// Output directory: study.csv, study.md, and each trial's photos and fit
    #[arg(long, default_value = "study")]
    pub out: PathBuf,
    /// Run only these trials (repeatable: `--only 6 --only 17`), with the same tools and photos
    /// as in the whole study of this seed: a row of the table, reproduced alone
    #[arg(long)]
    pub only: Vec<usize>,
    /// Which captures: `within` the capture guide's limits (tools over the whole range of each
    /// kind: V 20 to 120 degrees, flats to 50 um, balls 0.05 to 1 mm), `outside` them (the same,
    /// each capture beyond one limit in turn: shrunk, noisy, low JPEG quality, off the pose,
    /// saturated, enlarged; it must be refused naming the limit), or `any` (every phone
    /// degradation drawn over its whole range, the studies before the guide's limits)
    #[arg(long, default_value = "within", value_parser = ["within", "outside", "any"])]
    pub group: String,
}

/// How a trial ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Recovered,
    Refused(String),
    WrongButAccepted,
}

impl Outcome {
    pub fn label(&self) -> &'static str {
        match self {
            Outcome::Recovered => "recovered",
            Outcome::Refused(_) => "refused",
            Outcome::WrongButAccepted => "WRONG but accepted",
        }
    }
}

/// A random tool of `kind` over the whole range the calibration issue names: V-bits of 20 to
/// 120 degrees with flats to 50 um, balls of 0.05 to 1 mm, tapered balls, measured profiles.
pub fn random_tool_wide(rng: &mut Rng, kind: Kind, card: &Card) -> Tool {
    let off = rng.range(-0.008, 0.012);
    match kind {
        Kind::VBit => Tool::VBit {
            angle_deg: rng.range(20.0, 120.0),
            tip_flat_mm: rng.range(0.0, 0.05),
            z_offset_mm: off,
        },
        Kind::Ball => Tool::Ball {
            radius_mm: (rng.range(0.05f64.ln(), 1f64.ln())).exp(),
            z_offset_mm: off,
        },
        _ => random_tool(rng, kind, card),
    }
}

/// One trial: the truth, the photos' degradations, the fit and how it ended.
#[derive(Clone, Debug)]
pub struct Trial {
    /// Its number in the study (the draws of the trials before it come first).
    pub number: usize,
    /// The limit of the capture guide its photos are beyond (`--group outside`).
    pub violation: Option<Violation>,
    pub kind: Kind,
    pub truth: Tool,
    pub shots: Vec<Shot>,
    pub fitted: Option<Tool>,
    /// Errors: angle (degrees), length (mm: tip flat, radius or worst profile width), z offset
    /// (mm); None where the kind has none.
    pub errors: [Option<f64>; 3],
    /// (fitted - true) / stated standard deviation, per tool parameter the fit stated one for.
    pub z: Vec<(String, f64)>,
    pub outcome: Outcome,
    pub seconds: f64,
}

/// A random tool of `kind`, in the range a maker's tools span.
pub fn random_tool(rng: &mut Rng, kind: Kind, card: &Card) -> Tool {
    let off = rng.range(-0.008, 0.012);
    match kind {
        Kind::VBit => Tool::VBit {
            angle_deg: rng.range(40.0, 110.0),
            tip_flat_mm: rng.range(0.0, 0.025),
            z_offset_mm: off,
        },
        Kind::Ball => Tool::Ball {
            radius_mm: rng.range(0.03, 0.25),
            z_offset_mm: off,
        },
        Kind::TaperedBall => Tool::TaperedBall {
            radius_mm: rng.range(0.015, 0.08),
            angle_deg: rng.range(30.0, 90.0),
            z_offset_mm: off,
        },
        Kind::Profile => {
            let v = Tool::VBit {
                angle_deg: rng.range(50.0, 100.0),
                tip_flat_mm: rng.range(0.0, 0.02),
                z_offset_mm: off,
            };
            profile_cut_by(&v, card, rng.range(1.2, 2.0))
        }
    }
}

/// A measured profile: the widths `tool` cuts at the card's depths (its z offset is in them: a
/// profile is given in commanded depth), the model's w at `w_over_w` times each width.
pub fn profile_cut_by(tool: &Tool, card: &Card, w_over_w: f64) -> Tool {
    let mut w = 0.0f64;
    let points = card
        .depths_mm
        .iter()
        .map(|&z| {
            w = w.max(tool.section(z).map_or(0.0, |s| s.width));
            [z, w]
        })
        .collect();
    Tool::Profile {
        points,
        w_over_w,
        z_offset_mm: 0.0,
    }
}

/// The errors of `fitted` against `truth` (same kind): angle, length, offset.
pub fn errors(fitted: &Tool, truth: &Tool, card: &Card) -> [Option<f64>; 3] {
    match (fitted, truth) {
        (
            Tool::VBit {
                angle_deg: a,
                tip_flat_mm: f,
                z_offset_mm: o,
            },
            Tool::VBit {
                angle_deg: ta,
                tip_flat_mm: tf,
                z_offset_mm: to,
            },
        ) => [Some((a - ta).abs()), Some((f - tf).abs()), Some((o - to).abs())],
        (
            Tool::Ball {
                radius_mm: r,
                z_offset_mm: o,
            },
            Tool::Ball {
                radius_mm: tr,
                z_offset_mm: to,
            },
        ) => [None, Some((r - tr).abs()), Some((o - to).abs())],
        (
            Tool::TaperedBall {
                radius_mm: r,
                angle_deg: a,
                z_offset_mm: o,
            },
            Tool::TaperedBall {
                radius_mm: tr,
                angle_deg: ta,
                z_offset_mm: to,
            },
        ) => [Some((a - ta).abs()), Some((r - tr).abs()), Some((o - to).abs())],
        (Tool::Profile { .. }, Tool::Profile { .. }) => {
            // The widths it cuts at the card's depths where the true tool leaves a groove.
            let worst = card
                .depths_mm
                .iter()
                .filter_map(|&z| {
                    let t = truth.section(z).map_or(0.0, |s| s.width);
                    (t > 0.0).then(|| (fitted.section(z).map_or(0.0, |s| s.width) - t).abs())
                })
                .fold(0.0, f64::max);
            [None, Some(worst), None]
        }
        _ => [Some(f64::INFINITY), Some(f64::INFINITY), Some(f64::INFINITY)],
    }
}

/// Whether errors are within what a plate needs.
pub fn within(e: &[Option<f64>; 3]) -> bool {
    e[0].is_none_or(|a| a <= ANGLE_TOL_DEG)
        && e[1].is_none_or(|l| l <= LENGTH_TOL_MM)
        && e[2].is_none_or(|o| o <= OFFSET_TOL_MM)
}

/// The true value of a fitted tool parameter, by the fit's name.
fn true_param(truth: &Tool, name: &str) -> Option<f64> {
    match (truth, name) {
        (Tool::VBit { angle_deg, .. }, "angle_deg") | (Tool::TaperedBall { angle_deg, .. }, "angle_deg") => {
            Some(*angle_deg)
        }
        (Tool::VBit { tip_flat_mm, .. }, "tip_flat_mm") => Some(*tip_flat_mm),
        (Tool::Ball { radius_mm, .. }, "radius_mm") | (Tool::TaperedBall { radius_mm, .. }, "radius_mm") => {
            Some(*radius_mm)
        }
        (t, "z_offset_mm") if !matches!(t, Tool::Profile { .. }) => Some(t.z_offset_mm()),
        _ => None,
    }
}

/// Runs the study; writes `study.csv` and `study.md` into `args.out`.
pub fn run(renderer: &Renderer, args: &StudyArgs, obs: &dyn Observer) -> Result<Vec<Trial>> {
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let card = Card::new(&CardSpec::default());
    let card_path = args.out.join("card.json");
    scratchart_render::io::write_atomic(&card_path, serde_json::to_string_pretty(&card.to_json(256))?.as_bytes())?;
    let (card, capture) = Card::load(&card_path)?;
    let mut rng = Rng::new(args.seed);
    let mut trials = Vec::new();
    let last = args.only.iter().max().map_or(args.trials, |m| m + 1);
    for t in 0..last {
        if obs.should_stop() {
            break;
        }
        let kind = Kind::ALL[t % Kind::ALL.len()];
        let violation = (args.group == "outside").then(|| Violation::ALL[t % Violation::ALL.len()]);
        let truth = match args.group.as_str() {
            "any" => random_tool(&mut rng, kind, &card),
            _ => random_tool_wide(&mut rng, kind, &card),
        };
        let shots: Vec<Shot> = (0..capture.views.len())
            .map(|_| match (args.group.as_str(), violation) {
                ("any", _) => random_shot(&mut rng, card.marks.len(), args.max_tilt),
                (_, Some(what)) => random_shot_outside(&mut rng, card.marks.len(), what),
                _ => random_shot_within(&mut rng, card.marks.len()),
            })
            .collect();
        if !args.only.is_empty() && !args.only.contains(&t) {
            continue;
        }
        let dir = args.out.join(format!("trial{t:02}"));
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        // The true tool beside its photos: a trial's fit can be rerun and compared by hand.
        scratchart_model::fsio::write_atomic(&dir.join("truth.json"), truth.to_json().as_bytes())
            .with_context(|| format!("cannot write {}", dir.join("truth.json").display()))?;
        let mut images = Vec::new();
        let mut cameras = Vec::new();
        for (v, shot) in shots.iter().enumerate() {
            let (p, phone) = take(renderer, &card, &capture, v, &truth, shot, &dir)?;
            images.push(p);
            let c = &phone.camera;
            cameras.push(serde_json::json!({
                "view": capture.views[v].name, "eye_mm": c.eye, "target_mm": c.target, "up": c.up,
                "fov_y_deg": c.fov_y_deg, "size": [c.width, c.height],
            }));
        }
        // The phones' true cameras (at the render's resolution), to compare with what the marks gave.
        let truth_cameras = serde_json::to_string_pretty(&cameras)?;
        scratchart_model::fsio::write_atomic(&dir.join("truth_cameras.json"), truth_cameras.as_bytes())
            .with_context(|| format!("cannot write {}", dir.join("truth_cameras.json").display()))?;
        let out = dir.join("fit").join("tool.json");
        let fa = FitArgs::quiet(&card_path, images, Some(kind.name()), &out);
        let t0 = Instant::now();
        let got = fit(renderer, &fa, &Silent);
        let seconds = t0.elapsed().as_secs_f64();
        let (outcome, fitted, errs) = match got {
            Ok(()) => {
                let (tool, _) = Tool::load_fitted(&out).map_err(|e| anyhow::anyhow!("{e}"))?;
                let e = errors(&tool, &truth, &card);
                let o = if within(&e) {
                    Outcome::Recovered
                } else {
                    Outcome::WrongButAccepted
                };
                (o, Some(tool), e)
            }
            Err(e) if scratchart::exit::class(e.as_ref()) == scratchart_exit::Class::Input => {
                let msg = format!("{e:#}");
                let first = msg
                    .lines()
                    .find(|l| l.trim_start().starts_with("- "))
                    .unwrap_or(msg.lines().next().unwrap_or(""))
                    .trim()
                    .trim_start_matches("- ")
                    .to_string();
                // What the refused fit had found, from its report (when it got that far).
                let report = PathBuf::from(format!("{}_report.json", out.with_extension("").display()));
                let fitted = read_report_tool(&report);
                let e = fitted.as_ref().map_or([None; 3], |f| errors(f, &truth, &card));
                (Outcome::Refused(first), fitted, e)
            }
            Err(e) => return Err(e.context(format!("trial {t}"))),
        };
        let z = read_z(
            &PathBuf::from(format!("{}_report.json", out.with_extension("").display())),
            &truth,
        );
        obs.info(&format!(
            "trial {t:2} {:13} {:>18} in {seconds:5.1} s: {}",
            kind.name(),
            outcome.label(),
            describe(&truth)
        ));
        trials.push(Trial {
            number: t,
            violation,
            kind,
            truth,
            shots,
            fitted,
            errors: errs,
            z,
            outcome,
            seconds,
        });
        write_tables(&args.out, &trials, args)?;
    }
    Ok(trials)
}

fn read_report_tool(report: &Path) -> Option<Tool> {
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(report).ok()?).ok()?;
    serde_json::from_value(v["tool"].clone()).ok()
}

/// (fitted - true) / sd for the tool parameters the report states an sd for.
fn read_z(report: &Path, truth: &Tool) -> Vec<(String, f64)> {
    let Some(v) = std::fs::read(report)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
    else {
        return vec![];
    };
    v["params"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|p| {
            let name = p["name"].as_str()?;
            let (val, sd) = (p["value"].as_f64()?, p["sd"].as_f64()?);
            let t = true_param(truth, name)?;
            (sd > 0.0).then(|| (name.to_string(), (val - t) / sd))
        })
        .collect()
}

fn describe(t: &Tool) -> String {
    match t {
        Tool::VBit {
            angle_deg,
            tip_flat_mm,
            z_offset_mm,
        } => format!(
            "V {angle_deg:.1} deg, flat {:.1} um, offset {:+.1} um",
            tip_flat_mm * 1e3,
            z_offset_mm * 1e3
        ),
        Tool::Ball { radius_mm, z_offset_mm } => {
            format!("ball r {:.1} um, offset {:+.1} um", radius_mm * 1e3, z_offset_mm * 1e3)
        }
        Tool::TaperedBall {
            radius_mm,
            angle_deg,
            z_offset_mm,
        } => format!(
            "tapered ball r {:.1} um, {angle_deg:.1} deg, offset {:+.1} um",
            radius_mm * 1e3,
            z_offset_mm * 1e3
        ),
        Tool::Profile { points, w_over_w, .. } => format!(
            "profile, {} widths up to {:.1} um, w/W {w_over_w:.2}",
            points.len(),
            points.iter().map(|p| p[1]).fold(0.0, f64::max) * 1e3
        ),
    }
}

fn describe_shots(shots: &[Shot]) -> String {
    shots
        .iter()
        .map(|s| {
            format!(
                "{:.2} MP {}, tilt {:.0} deg, roll {:.0}, exp {}, blur {:.1} px, noise {:.1}%, vign {:.0}%{}{}",
                s.megapixels,
                s.jpeg_quality.map_or("PNG".to_string(), |q| format!("JPEG {q}")),
                s.pose.tilt_deg,
                s.pose.roll_deg,
                s.auto_exposure
                    .map_or(format!("{:.2}", s.exposure), |a| format!("auto {a:.2}")),
                s.blur_px,
                100.0 * s.noise,
                100.0 * s.vignetting,
                s.cover.map_or(String::new(), |k| format!(", mark {k} covered")),
                if s.enlarge > 1.0 {
                    format!(", enlarged {:.2}x", s.enlarge)
                } else {
                    String::new()
                }
            )
        })
        .collect::<Vec<_>>()
        .join(" / ")
}

/// A refusal's reason short enough for a table row: a photo named by its view (the path is in
/// study.csv), cut at a word boundary after about 150 characters (numbers kept whole).
fn brief(reason: &str) -> String {
    let mut r = reason.to_string();
    if let (Some(a), Some(b)) = (r.find("(view "), r.find("): ")) {
        if r.starts_with("photo `") && a < b {
            r = format!("{}: {}", &r[a + 6..b], &r[b + 3..]);
        }
    }
    if r.chars().count() <= 160 {
        return r;
    }
    let cut: String = r.chars().take(150).collect();
    match cut.rfind(' ') {
        Some(k) => format!("{} ...", &cut[..k]),
        None => format!("{cut} ..."),
    }
}

fn fmt_err(e: Option<f64>, scale: f64, digits: usize) -> String {
    e.map_or("-".into(), |v| {
        if v.is_finite() {
            format!("{:.*}", digits, v * scale)
        } else {
            "kind".into()
        }
    })
}

/// study.csv (one row per trial) and study.md (the table and the summary).
fn write_tables(dir: &Path, trials: &[Trial], args: &StudyArgs) -> Result<()> {
    let mut csv =
        String::from("trial,kind,truth,outcome,reason,angle_err_deg,length_err_um,offset_err_um,seconds,photos\n");
    let mut md = String::new();
    md.push_str(
        "| # | tool | photos (per view) | beyond the guide | outcome | angle err | length err | offset err | time |\n",
    );
    md.push_str("|---|---|---|---|---|---|---|---|---|\n");
    for tr in trials {
        let t = tr.number;
        let reason = match &tr.outcome {
            Outcome::Refused(r) => r.clone(),
            _ => String::new(),
        };
        csv.push_str(&format!(
            "{t},{},\"{}\",{},\"{}\",{},{},{},{:.1},\"{}\"\n",
            tr.kind.name(),
            describe(&tr.truth),
            tr.outcome.label(),
            reason.replace('"', "'"),
            fmt_err(tr.errors[0], 1.0, 2),
            fmt_err(tr.errors[1], 1e3, 2),
            fmt_err(tr.errors[2], 1e3, 2),
            tr.seconds,
            describe_shots(&tr.shots)
        ));
        md.push_str(&format!(
            "| {t} | {} | {} | {} | {}{} | {} | {} | {} | {:.0} s |\n",
            describe(&tr.truth),
            describe_shots(&tr.shots),
            tr.violation.map_or("-", |v| v.label()),
            tr.outcome.label(),
            if reason.is_empty() {
                String::new()
            } else {
                format!(": {}", brief(&reason))
            },
            fmt_err(tr.errors[0], 1.0, 2) + " deg",
            fmt_err(tr.errors[1], 1e3, 2) + " um",
            fmt_err(tr.errors[2], 1e3, 2) + " um",
            tr.seconds
        ));
    }
    let n = trials.len();
    let count = |f: &dyn Fn(&Outcome) -> bool| trials.iter().filter(|t| f(&t.outcome)).count();
    let rec = count(&|o| *o == Outcome::Recovered);
    let wrong = count(&|o| *o == Outcome::WrongButAccepted);
    let refused = n - rec - wrong;
    let zs: Vec<f64> = trials.iter().flat_map(|t| t.z.iter().map(|z| z.1)).collect();
    let zs_acc: Vec<f64> = trials
        .iter()
        .filter(|t| t.outcome != Outcome::WrongButAccepted && !matches!(t.outcome, Outcome::Refused(_)))
        .flat_map(|t| t.z.iter().map(|z| z.1))
        .collect();
    let cover = |v: &[f64]| {
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().filter(|z| z.abs() <= 1.0).count() as f64 / v.len() as f64
        }
    };
    let mut times: Vec<f64> = trials.iter().map(|t| t.seconds).collect();
    times.sort_by(|a, b| a.total_cmp(b));
    // Outside the guide: refused naming the limit the photos are beyond.
    let named = trials
        .iter()
        .filter(|t| match (&t.outcome, t.violation) {
            (Outcome::Refused(r), Some(v)) => v.named_by(r),
            _ => false,
        })
        .count();
    let group = match args.group.as_str() {
        "within" => "captures within the capture guide's limits".to_string(),
        "outside" => format!(
            "captures beyond one of the capture guide's limits each ({named} of {refused} refusals name the limit)"
        ),
        _ => format!(
            "photos up to {} degrees off the capture pose, every degradation over its whole range",
            args.max_tilt
        ),
    };
    let summary = format!(
        "{n} random tools (seed {}, {group}): {rec} recovered within {ANGLE_TOL_DEG} \
         degree, {:.0} um and {:.0} um; {refused} refused; {wrong} wrong but accepted. Fit time: median {:.0} s, \
         longest {:.0} s. {}\n",
        args.seed,
        LENGTH_TOL_MM * 1e3,
        OFFSET_TOL_MM * 1e3,
        times.get(n / 2).copied().unwrap_or(0.0),
        times.last().copied().unwrap_or(0.0),
        if zs.is_empty() {
            "No fit stated an uncertainty to check against the truth.".to_string()
        } else {
            format!(
                "The truth lies within the stated one-sigma in {:.0}% of {} parameter estimates ({} on accepted fits).",
                100.0 * cover(&zs),
                zs.len(),
                if zs_acc.is_empty() {
                    "none".to_string()
                } else {
                    format!("{:.0}% of {}", 100.0 * cover(&zs_acc), zs_acc.len())
                }
            )
        }
    );
    // By kind: where the study's refusals fall.
    let by_kind: Vec<(&str, usize, usize, usize)> = crate::fit::Kind::ALL
        .iter()
        .map(|&kind| {
            let k = kind.name();
            let of: Vec<&Trial> = trials.iter().filter(|t| t.kind == kind).collect();
            let rec = of.iter().filter(|t| t.outcome == Outcome::Recovered).count();
            let wrong = of.iter().filter(|t| t.outcome == Outcome::WrongButAccepted).count();
            (k, of.len(), rec, wrong)
        })
        .filter(|k| k.1 > 0)
        .collect();
    let mut kinds_md =
        String::from("| kind | trials | recovered | refused | wrong but accepted |\n|---|---|---|---|---|\n");
    for (k, n, rec, wrong) in &by_kind {
        kinds_md.push_str(&format!("| {k} | {n} | {rec} | {} | {wrong} |\n", n - rec - wrong));
    }
    let md = format!("{summary}\n{kinds_md}\n{md}");
    scratchart_render::io::write_atomic(&dir.join("study.csv"), csv.as_bytes())?;
    scratchart_render::io::write_atomic(&dir.join("study.md"), md.as_bytes())?;
    scratchart_render::io::write_atomic(
        &dir.join("study.json"),
        serde_json::to_string_pretty(&json!({
            "group": args.group, "trials": n, "recovered": rec, "refused": refused, "wrong_but_accepted": wrong,
            "refused_naming_the_limit": named,
            "by_kind": by_kind.iter().map(|(k, n, rec, wrong)| json!({
                "kind": k, "trials": n, "recovered": rec, "wrong_but_accepted": wrong,
            })).collect::<Vec<_>>(),
            "coverage_1sigma": cover(&zs), "estimates": zs.len(),
            "z": trials.iter().map(|t| t.z.iter().map(|z| json!([z.0, z.1])).collect::<Vec<_>>()).collect::<Vec<_>>(),
        }))?
        .as_bytes(),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::brief;

    /// A table row names the photo's view and keeps the refusal's numbers whole.
    #[test]
    fn a_refusal_is_briefed_with_its_numbers_whole() {
        let r = "photo `study_k/trial03/cam_south.jpg` (view cam_south): the fit leaves a residual of rms \
                 0.0038, 3.0 times what the photo's own noise (0.0007) and the model's own error (0.0004) \
                 explain (at most 3): this is not the card as a profile cuts it (another tool, another card)";
        let b = brief(r);
        assert!(
            b.starts_with("cam_south: the fit leaves a residual of rms 0.0038, 3.0 times"),
            "{b}"
        );
        assert!(b.ends_with(" ...") && b.chars().count() <= 154, "{b}");
        assert_eq!(brief("angle_deg is not identified"), "angle_deg is not identified");
    }
}
