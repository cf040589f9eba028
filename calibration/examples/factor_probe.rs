//! Which of a phone's degradations moves the tool fit, one at a time, against the truth:
//! `cargo run --release -p scratchart-calibration --example factor_probe -- [ball|v-bit|tapered-ball] [variant...]`.
//! Each variant changes one thing of a sharp on-pose PNG shot (the same for both views) and
//! prints the fitted tool beside the true one, the stated uncertainties and the residuals.
//! `-- trialN [change...]` takes the tool and the two shots of trial N of `scratchart-cal study
//! --seed 1` instead, and each change takes one thing out of both shots (`asis`, `novign`,
//! `nojpeg`, `nonoise`, `nopose`, `noblur`, `nolight`, `small`), to find what biases that trial.
use std::path::Path;

use scratchart_calibration::card::{Card, CardSpec};
use scratchart_calibration::fit_cmd::{run, FitArgs};
use scratchart_calibration::phone::{take, Pose, Shot};
use scratchart_model::scene::Scene;
use scratchart_observe::Silent;
use scratchart_render::Renderer;
use scratchart_tool::Tool;
use scratchart_vulkan::{Context, ContextDesc};

fn variant(name: &str) -> Shot {
    let mut s = Shot {
        blur_px: 0.8,
        megapixels: 0.5,
        ..Shot::default()
    };
    match name {
        "base" => {}
        "tilt" => {
            s.pose.tilt_deg = 9.0;
            s.pose.tilt_dir_deg = 30.0;
        }
        "roll" => s.pose.roll_deg = 104.0,
        "shift" => s.pose.shift_mm = [15.0, -15.0, 10.0],
        "fov" => {
            s.pose.fov_scale = 1.25;
            s.pose.aspect = 0.75;
        }
        "big" => s.megapixels = 13.0,
        "light" => {
            s.exposure = 0.5;
            s.vignetting = 0.3;
            s.cast = [1.2, 1.0, 0.8];
        }
        "noise" => s.noise = 0.025,
        "jpeg" => s.jpeg_quality = Some(75),
        "blur" => s.blur_px = 1.8,
        "all" => {
            s.pose = Pose {
                tilt_deg: 9.0,
                tilt_dir_deg: 30.0,
                shift_mm: [15.0, -15.0, 10.0],
                aim_mm: [2.0, -3.0],
                roll_deg: 104.0,
                fov_scale: 1.25,
                aspect: 0.75,
            };
            s.noise = 0.02;
            s.jpeg_quality = Some(80);
            s.blur_px = 1.4;
        }
        // "all" less one of its parts.
        "all-noise" => {
            s = variant("all");
            s.noise = 0.0;
        }
        "all-pose" => {
            s = variant("all");
            s.pose = Pose::default();
        }
        "all-jpeg" => {
            s = variant("all");
            s.jpeg_quality = None;
        }
        "noise-jpeg" => {
            s.noise = 0.02;
            s.jpeg_quality = Some(80);
        }
        "noise2" => s.noise = 0.02,
        "noise-blur" => {
            s.noise = 0.02;
            s.blur_px = 1.4;
        }
        // Any mix: "noise=0.015,jpeg=85,blur=1.2,mp=2,exposure=0.6".
        other if other.contains('=') => {
            for kv in other.split(',') {
                let (k, v) = kv.split_once('=').unwrap_or_else(|| panic!("{kv}: want key=value"));
                let x: f64 = v.parse().unwrap_or_else(|_| panic!("{kv}: not a number"));
                match k {
                    "noise" => s.noise = x,
                    "jpeg" => s.jpeg_quality = Some(x as u8),
                    "blur" => s.blur_px = x,
                    "mp" => s.megapixels = x,
                    "exposure" => s.exposure = x,
                    "tilt" => {
                        s.pose.tilt_deg = x;
                        s.pose.tilt_dir_deg = 30.0;
                    }
                    _ => panic!("{k}: noise, jpeg, blur, mp, exposure or tilt"),
                }
            }
        }
        other => panic!("unknown variant {other}"),
    }
    s
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let kind = args.first().cloned().unwrap_or_else(|| "ball".into());
    let names: Vec<String> = if args.len() > 1 {
        args[1..].to_vec()
    } else {
        [
            "base", "tilt", "roll", "shift", "fov", "big", "light", "noise", "jpeg", "blur",
        ]
        .map(String::from)
        .to_vec()
    };
    let trial: Option<usize> = kind.strip_prefix("trial").and_then(|t| t.parse().ok());
    let ctx = Context::new(ContextDesc::default())?;
    let r = Renderer::new(&ctx)?;
    let card = Card::new(&CardSpec::default());
    let dir = std::env::temp_dir().join("factor_probe");
    std::fs::create_dir_all(&dir)?;
    let p = dir.join("card.json");
    std::fs::write(&p, serde_json::to_string(&card.to_json(256))?)?;
    let (card, capture) = Card::load(&p)?;
    match trial {
        Some(t) => trial_changes(t, &names, &r, &card, &capture, &p, &dir),
        None => variants(&kind, &names, &r, &card, &capture, &p, &dir),
    }
}

/// Trial `t` of `scratchart-cal study --seed 1`, fitted once per change in `names` (each takes
/// one thing out of both shots).
fn trial_changes(
    t: usize,
    names: &[String],
    r: &Renderer,
    card: &Card,
    capture: &Scene,
    p: &Path,
    dir: &Path,
) -> anyhow::Result<()> {
    // The study's draws, in its order, up to trial t.
    let mut rng = scratchart_design::scenes::Rng::new(1);
    let (mut truth, mut shots) = (None, Vec::new());
    for i in 0..=t {
        let kind = scratchart_calibration::fit::Kind::ALL[i % 4];
        truth = Some((kind, scratchart_calibration::study::random_tool(&mut rng, kind, card)));
        shots = (0..capture.views.len())
            .map(|_| scratchart_calibration::phone::random_shot(&mut rng, card.marks.len(), 20.0))
            .collect::<Vec<Shot>>();
    }
    let (kind, truth) = truth.expect("a trial");
    println!("truth {truth:?}");
    for sh in &shots {
        println!("shot {sh:?}");
    }
    for name in names {
        let mut s = shots.clone();
        for (i, sh) in s.iter_mut().enumerate() {
            match name.as_str() {
                "nojpeg0" | "nojpeg1" => {
                    if name.ends_with(&i.to_string()) {
                        sh.jpeg_quality = None
                    }
                }
                "asis" => {}
                "novign" => sh.vignetting = 0.0,
                "nojpeg" => sh.jpeg_quality = None,
                "nonoise" => sh.noise = 0.0,
                "nopose" => sh.pose = Pose::default(),
                "noblur" => sh.blur_px = 0.5,
                "nolight" => {
                    sh.exposure = 1.0;
                    sh.cast = [1.0; 3];
                }
                "small" => sh.megapixels = 0.5,
                "nocast" => sh.cast = [1.0; 3],
                "noexp" => sh.exposure = 1.0,
                other => panic!("unknown change {other}"),
            }
        }
        let d = dir.join(format!("{}-{name}", kind.name()));
        let _ = std::fs::remove_dir_all(&d);
        let mut images = Vec::new();
        for (v, sh) in s.iter().enumerate() {
            images.push(take(r, card, capture, v, &truth, sh, &d)?.0);
        }
        let out = d.join("fit").join("tool.json");
        let fa = FitArgs {
            allow_unidentified: true,
            ..FitArgs::quiet(p, images, Some(kind.name()), &out)
        };
        let got = run(r, &fa, &Silent);
        let rep: serde_json::Value = std::fs::read(d.join("fit").join("tool_report.json"))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default();
        let fitted = Tool::load_fitted(&out).ok().map(|t| t.0);
        let err = fitted
            .as_ref()
            .map(|f| scratchart_calibration::study::errors(f, &truth, card));
        println!(
            "{name:8} {}: errors {err:?} | {}",
            if got.is_ok() { "accepted" } else { "refused" },
            rep["params"]
                .as_array()
                .into_iter()
                .flatten()
                .filter(|q| {
                    let n = q["name"].as_str().unwrap_or("");
                    !(n.starts_with("ln_exp")
                        || n.starts_with("registration")
                        || n.starts_with("eye[")
                        || n.starts_with("shade[")
                        || n.starts_with("blur"))
                        && q["value"].as_f64() != Some(0.0)
                })
                .map(|q| format!(
                    "{} {:.5}+-{:.5}",
                    q["name"].as_str().unwrap_or("?"),
                    q["value"].as_f64().unwrap_or(f64::NAN),
                    q["sd"].as_f64().unwrap_or(f64::NAN)
                ))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}

/// The shot variants `names` (see [`variant`]) of a fixed tool of `kind`, each fitted.
fn variants(
    kind: &str,
    names: &[String],
    r: &Renderer,
    card: &Card,
    capture: &Scene,
    p: &Path,
    dir: &Path,
) -> anyhow::Result<()> {
    let truth = match kind {
        "ball" => Tool::Ball {
            radius_mm: 0.058,
            z_offset_mm: 0.0074,
        },
        "tapered-ball" => Tool::TaperedBall {
            radius_mm: 0.046,
            angle_deg: 35.5,
            z_offset_mm: -0.0002,
        },
        _ => Tool::VBit {
            angle_deg: 78.5,
            tip_flat_mm: 0.0143,
            z_offset_mm: -0.0067,
        },
    };
    println!("truth {truth:?}");
    for name in names {
        let shot = variant(name);
        let d = dir.join(name);
        let _ = std::fs::remove_dir_all(&d);
        let mut images = Vec::new();
        for v in 0..capture.views.len() {
            let mut s = shot.clone();
            s.seed += v as u64;
            images.push(take(r, card, capture, v, &truth, &s, &d)?.0);
        }
        let out = d.join("fit").join("tool.json");
        let fa = FitArgs {
            allow_unidentified: true,
            ..FitArgs::quiet(p, images, Some(kind), &out)
        };
        let t0 = std::time::Instant::now();
        let got = run(r, &fa, &Silent);
        let secs = t0.elapsed().as_secs_f64();
        let report = d.join("fit").join("tool_report.json");
        let rep: serde_json::Value = std::fs::read(&report)
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default();
        let params: Vec<String> = rep["params"]
            .as_array()
            .into_iter()
            .flatten()
            .filter(|q| {
                let n = q["name"].as_str().unwrap_or("");
                !n.starts_with("registration") && !n.starts_with("shade") && !n.starts_with("ln_exp")
            })
            .map(|q| {
                format!(
                    "{} {:.5}+-{:.5}{}",
                    q["name"].as_str().unwrap_or("?"),
                    q["value"].as_f64().unwrap_or(f64::NAN),
                    q["sd"].as_f64().unwrap_or(f64::NAN),
                    q["noise_lift_shift"]
                        .as_f64()
                        .map_or(String::new(), |l| format!(" (lift {l:+.5})"))
                )
            })
            .collect();
        let res: Vec<String> = rep["fit"]["photos"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|ph| {
                format!(
                    "res {:.4}/noise {:.4}",
                    ph["residual_rms"].as_f64().unwrap_or(f64::NAN),
                    ph["noise"].as_f64().unwrap_or(f64::NAN)
                )
            })
            .collect();
        println!(
            "{name:6} {:>6.1} s {}: {} | {}",
            secs,
            match &got {
                Ok(()) => "accepted".to_string(),
                Err(e) => format!(
                    "refused ({})",
                    format!("{e:#}")
                        .lines()
                        .last()
                        .unwrap_or("")
                        .chars()
                        .take(90)
                        .collect::<String>()
                ),
            },
            params.join(", "),
            res.join(", ")
        );
    }
    Ok(())
}
