//! The tool fit recovers known tools from synthetic photos of the card (rendered by the engine,
//! then degraded as a camera would: exposure, blur, noise, and a photo pose off the capture
//! position), and refuses input it cannot use with a clear message.
use std::path::{Path, PathBuf};

use scratchart_calibration::card::{Card, CardSpec};
use scratchart_calibration::fit_cmd::{run, FitArgs};
use scratchart_calibration::simulate::Camera;
use scratchart_model::scene::View;
use scratchart_observe::Silent;
use scratchart_render::Renderer;
use scratchart_tests::{assert_no_validation, gpu};
use scratchart_tool::Tool;

mod common;
use common::{as_phone_jpegs, card, fit, right_or_refused, shoot, stated, tmp};

/// The capture views as a hand-held camera would take them: moved `shift_mm` sideways and up,
/// aimed a little off centre, zoomed by `zoom`.
fn posed(views: &[View], shift_mm: f64, zoom: f64) -> Vec<View> {
    views
        .iter()
        .map(|v| {
            let mut v = v.clone();
            let e = v.camera.eye;
            v.camera.eye = [e[0] + shift_mm, e[1] - 0.6 * shift_mm, e[2] + 0.8 * shift_mm];
            v.camera.target = [0.02 * shift_mm, -0.03 * shift_mm, 0.0];
            v.camera.fov_y_deg /= zoom;
            v
        })
        .collect()
}

/// A photo taken off the capture pose (moved 6 mm, aimed off centre, zoomed 4%) is registered:
/// the card's marks are found within 0.35 px of where that camera really sees them (the fit then
/// refines the registration photometrically), and the
/// registered photo matches a photo taken from the capture pose.
#[test]
fn registers_off_pose_photos_to_the_capture_views() {
    use scratchart_calibration::fiducials::nominal_marks;
    use scratchart_calibration::photo::load_photo;
    use scratchart_calibration::register::register;
    use scratchart_model::camera::ViewGeom;
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit", "register");
    let (card, capture, _) = card(&dir);
    let tool = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.0,
    };
    let cam = Camera {
        exposure: 3.0,
        noise: 0.005,
        ..Camera::default()
    };
    let posed_views = posed(&capture.views, 6.0, 1.04);
    let off = shoot(&r, &card, &capture, posed_views.clone(), &tool, &cam, &dir);
    let on_dir = dir.join("on");
    std::fs::create_dir_all(&on_dir).unwrap();
    let on = shoot(&r, &card, &capture, capture.views.clone(), &tool, &cam, &on_dir);
    for (v, view) in capture.views.iter().enumerate() {
        let reg = register(&load_photo(&off[v]).unwrap(), &card, view).unwrap();
        // Where the posed camera sees the marks (the photo has the view's size).
        let (truth, _) = nominal_marks(&card, &posed_views[v]);
        assert_eq!(reg.found.count(), card.marks.len(), "every mark is found");
        for k in 0..card.marks.len() {
            let p = reg.found.points[k].unwrap();
            let e = (p[0] - truth[k][0]).hypot(p[1] - truth[k][1]);
            eprintln!("view {v} mark {k}: found {p:?}, truly {:?}, error {e:.3} px", truth[k]);
            assert!(e < 0.35, "view {v} mark {k}: found {p:?}, truly {:?}", truth[k]);
        }
        assert!(
            reg.pose_offset_px > 3.0,
            "the pose really was off: {}",
            reg.pose_offset_px
        );
        // The registered photo against the one from the capture pose, on the card.
        let straight = load_photo(&on[v]).unwrap();
        let mask = ViewGeom::new(view).on_plate_mask(0.5 * card.plate_mm);
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for i in 0..mask.len() {
            if mask[i] && reg.valid[i] {
                num += ((reg.image[i] - straight.data[i]) as f64).powi(2);
                den += 1.0;
            }
        }
        let rms = (num / den).sqrt();
        assert!(
            rms < 0.02,
            "view {v}: registered photo differs from the straight one by rms {rms}"
        );
    }
    assert_no_validation(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Photographs the card cut by `truth` (from the capture views, or off them when `off_pose`; as
/// 640 x 480 colour JPEGs when `phone`) as `cam` would, and fits `kind` to the photos: the fitted
/// tool and the fit record, or the refusal, and the directory (tool.json in `DIR/fit/`). Every
/// test checks validation messages.
fn recover_result(
    tag: &str,
    truth: &Tool,
    cam: &Camera,
    off_pose: bool,
    phone: bool,
    kind: &str,
) -> (anyhow::Result<(Tool, serde_json::Value)>, PathBuf) {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit", tag);
    let (card, capture, card_path) = card(&dir);
    let mut views = if off_pose {
        posed(&capture.views, 6.0, 1.04)
    } else {
        capture.views.clone()
    };
    // As a phone takes them: larger than the views, 4:3, colour JPEGs.
    if phone {
        for view in &mut views {
            (view.camera.width, view.camera.height) = (640, 480);
        }
    }
    let mut imgs = shoot(&r, &card, &capture, views, truth, cam, &dir);
    if phone {
        imgs = as_phone_jpegs(&imgs);
    }
    let got = fit(&r, &card_path, imgs, kind, &dir.join("fit/tool.json"));
    assert_no_validation(&ctx);
    (got, dir)
}

/// [`recover_result`], the fit required to be written.
fn recover(
    tag: &str,
    truth: &Tool,
    cam: &Camera,
    off_pose: bool,
    phone: bool,
    kind: &str,
) -> (Tool, serde_json::Value, PathBuf) {
    let (got, dir) = recover_result(tag, truth, cam, off_pose, phone, kind);
    let (tool, record) = got.unwrap();
    eprintln!("fitted {tool:?}; record {record}");
    (tool, record, dir)
}

/// A V-bit photographed off the capture pose (moved 6 mm, aimed off centre, zoomed 4%) with
/// another exposure, blur and noise: the camera is recovered from the card's hatched marks and its eye
/// refined by the fit, the exposure read to 5% (the truth within three of its stated
/// uncertainties; within 3% while the tone curve was fixed), near the noise floor, the residual images and the
/// plot written; the tool within 1 degree, 5 um and 3 um, or refused as not identified (with
/// each photo's tone curve free the guide's capture reads the angle from the rungs' brightness:
/// 76.37 +- 0.59 degrees here, where 0.5 is allowed; the block sandwich alone said +- 0.35 and
/// the fit wrote it 1.37 degrees off: calibration/docs/fit.md, "The blur kernel").
#[test]
fn a_v_bit_from_degraded_off_pose_photos_is_right_or_refused() {
    let truth = Tool::VBit {
        angle_deg: 75.0,
        tip_flat_mm: 0.012,
        z_offset_mm: 0.0035,
    };
    let cam = Camera {
        exposure: 3.0,
        blur_px: 0.6,
        noise: 0.008,
        seed: 7,
    };
    let (got, dir) = recover_result("vbit", &truth, &cam, true, false, "v-bit");
    right_or_refused(
        &got,
        &dir,
        &[
            ("angle_deg", 75.0, 1.0),
            ("tip_flat_mm", 0.012, 0.005),
            ("z_offset_mm", 0.0035, 0.003),
        ],
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("fit/tool_report.json")).unwrap()).unwrap();
    // The exposure, read to 5%, the truth within three of its stated uncertainties (it trades
    // with the photo's free tone curve: 2.84 +- 2.5% for 3 here).
    for v in 0..2 {
        let e = report["fit"]["exposure"][v].as_f64().unwrap();
        let (ln, sd) = stated(&dir, &format!("ln_exposure[{v}]"));
        assert!((e.ln() - ln).abs() < 1e-9, "exposure {e}, ln_exposure {ln}");
        assert!(sd < 0.05, "exposure {e} read to +- {sd} only");
        assert!((ln - 3f64.ln()).abs() <= 3.0 * sd, "exposure {e} +- {sd} (in ln) for 3");
    }
    let rms = report["fit"]["rms_residual"].as_f64().unwrap();
    assert!(rms < 0.01, "rms residual {rms}");
    for f in [
        "tool_residual_cam_south.png",
        "tool_residual_cam_west.png",
        "tool_profile.png",
    ] {
        assert!(dir.join("fit").join(f).is_file(), "{f} missing");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A perfectly sharp photo (`simulate`'s defaults: no blur, no noise, exposure 1) is its pixels'
/// own footprint, which the fit models (blur from 0, the registration a turn of the camera):
/// fitted sharp, at the noise floor, the README's V-bit recovered and written within 1 degree,
/// 5 um and 3 um and three of its stated uncertainties (75.58 +- 0.30 degrees). With a blur
/// floor of a quarter pixel and the shift in the blur's kernel it was refused, 26.4 +- 7.6
/// degrees, 16.8 times the noise; with each photo's tone curve free and the Gaussian kernel
/// sampled at the subpixels' centres (no blur below half a subpixel), refused at +- 2.05
/// (calibration/docs/fit.md, "The blur kernel").
#[test]
fn a_v_bit_from_perfectly_sharp_photos_is_fitted_sharp() {
    let truth = Tool::VBit {
        angle_deg: 75.0,
        tip_flat_mm: 0.015,
        z_offset_mm: 0.007,
    };
    let (got, dir) = recover_result("sharp", &truth, &Camera::default(), false, false, "v-bit");
    let written = right_or_refused(
        &got,
        &dir,
        &[
            ("angle_deg", 75.0, 1.0),
            ("tip_flat_mm", 0.015, 0.005),
            ("z_offset_mm", 0.007, 0.003),
        ],
    );
    assert!(
        written,
        "the README's V-bit from sharp photos is recovered: {:?}",
        got.err()
    );
    for v in 0..2 {
        let (b, _) = stated(&dir, &format!("blur_px[{v}]"));
        assert!(b < 0.25, "blur {b} px: a sharp photo is fitted sharp");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A V-bit photographed as a phone stores it: 640 x 480 (another size and aspect than the
/// 256 x 256 views, shrunk in linear light), colour JPEG, blurred by 1.2 px, 0.8% noise: never a
/// wrong tool: written within 1 degree, 5 um and 3 um and three of its stated uncertainties, or
/// refused (exit 3, no tool.json) as not identified, the truth within three of its stated
/// uncertainties (with the tone free: 73.40 +- 0.73 degrees, refused). Measured before: the noise's clipping
/// at black lifts the dark plate by 0.001 of display, which moves the angle by 1.8 degrees:
/// without it in the model the fit wrote 74.02 +- 0.14 degrees (7 of its sigmas off); with it,
/// 75.78 +- 0.89 (half the lift's shift is in the uncertainty), refused as not identified.
#[test]
fn a_v_bit_from_larger_colour_jpegs_is_right_or_refused() {
    let truth = Tool::VBit {
        angle_deg: 75.0,
        tip_flat_mm: 0.012,
        z_offset_mm: 0.0035,
    };
    let cam = Camera {
        exposure: 3.0,
        blur_px: 1.2,
        noise: 0.008,
        seed: 5,
    };
    let (got, dir) = recover_result("phone", &truth, &cam, false, true, "v-bit");
    if right_or_refused(
        &got,
        &dir,
        &[
            ("angle_deg", 75.0, 1.0),
            ("tip_flat_mm", 0.012, 0.005),
            ("z_offset_mm", 0.0035, 0.003),
        ],
    ) {
        let record = &got.as_ref().unwrap().1;
        assert!(
            record["photos"][0]["file"].as_str().unwrap().ends_with(".jpg"),
            "{record}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The V-bit of the new user (60 degrees, flat 10 um, offset 5 um; `simulate --exposure
/// 0.8 --blur 0.6`), its photos changed by `change` after they were taken, then fitted: never a
/// wrong tool: written within 1 degree, 5 um and 3 um and three of its stated sigmas, or
/// refused (exit 3, nothing written) by the photo check or as not identified.
fn v60_changed_after(tag: &str, change: impl Fn(&Path)) {
    let truth = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.005,
    };
    let cam = Camera {
        exposure: 0.8,
        blur_px: 0.6,
        noise: 0.0,
        seed: 1,
    };
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit", tag);
    let (card, capture, card_path) = card(&dir);
    let imgs = shoot(&r, &card, &capture, capture.views.clone(), &truth, &cam, &dir);
    for p in &imgs {
        change(p);
    }
    let got = fit(&r, &card_path, imgs, "v-bit", &dir.join("fit/tool.json"));
    assert_no_validation(&ctx);
    match &got {
        // Refused before any fit, as the photo check sees the change (an enlargement's period).
        Err(e) if !dir.join("fit/tool_report.json").exists() => {
            assert_eq!(scratchart::exit::code_of(e), 3, "{e:#}");
            assert!(format!("{e:#}").contains("enlarged"), "{e:#}");
            assert!(!dir.join("fit/tool.json").exists());
        }
        // Refused by the fit: nothing written. (Its stated uncertainty need not hold the truth
        // here: the model has no resampling after the encoding; enlarged, 47.5 +- 1.7 for 60.)
        Err(e) => {
            assert_eq!(scratchart::exit::code_of(e), 3, "{e:#}");
            assert!(format!("{e:#}").contains("not identified"), "{e:#}");
            assert!(!dir.join("fit/tool.json").exists());
        }
        Ok(_) => {
            let truth = [
                ("angle_deg", 60.0, 1.0),
                ("tip_flat_mm", 0.01, 0.005),
                ("z_offset_mm", 0.005, 0.003),
            ];
            right_or_refused(&got, &dir, &truth);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Photos whose tone curve is a tenth steeper than the one the fit assumes (an edit, or a
/// phone's own curve: each value d becomes d^(1/1.1), as ImageMagick's `-gamma 1.1` makes it):
/// never a wrong tool. With each photo's curve fixed, the fit wrote this 60 degree V-bit as
/// 49.43 +- 0.44 degrees with exit 0 (its flat and offset right); with the curve free it is
/// refused, the angle not identified.
#[test]
fn a_steeper_tone_curve_is_never_written_wrong() {
    v60_changed_after("tone", |p| {
        let (w, h, px) = scratchart_render::io::read_image_gray(p).unwrap();
        let bytes: Vec<u8> = px
            .iter()
            .map(|&d| (255.0 * (d as f64).powf(1.0 / 1.1)).round() as u8)
            .collect();
        scratchart_render::io::write_png_gray(p, w, h, &bytes).unwrap();
    });
}

/// Photos enlarged 1.5 times after they were taken, in their encoding, by ImageMagick's default
/// filter, kept as PNG without EXIF (the pixels show no period: `resampled` cannot tell): never
/// a wrong tool. With each photo's curve fixed the fit wrote 56.88 +- 0.19 degrees for 60 with
/// exit 0; with it free, 47.5 +- 1.7, refused.
#[test]
fn photos_enlarged_without_a_trace_are_never_written_wrong() {
    v60_changed_after("enlarged", |p| {
        let st = std::process::Command::new("convert")
            .arg(p)
            .args(["-resize", "150%"])
            .arg(p)
            .status()
            .expect("ImageMagick's convert (bash .ci/setup installs it)");
        assert!(st.success());
    });
}

/// The ball cutter of the ball tests (below commanded zero) and its camera: another exposure,
/// a small blur, noise.
fn ball_case() -> (Tool, Camera) {
    let truth = Tool::Ball {
        radius_mm: 0.08,
        z_offset_mm: -0.002,
    };
    let cam = Camera {
        exposure: 2.0,
        blur_px: 0.5,
        noise: 0.006,
        seed: 3,
    };
    (truth, cam)
}

/// A tapered ball (ball tip on a cone) above commanded zero: tip radius within 5 um, z offset
/// within 3 um, the cone within 1 degree, or refused as not identified (with each photo's tone
/// curve free the cone is +- 0.57 degrees here, where 0.5 is allowed).
#[test]
fn a_tapered_ball_is_right_or_refused() {
    let truth = Tool::TaperedBall {
        radius_mm: 0.03,
        angle_deg: 40.0,
        z_offset_mm: 0.002,
    };
    let cam = Camera {
        exposure: 2.5,
        blur_px: 0.5,
        noise: 0.006,
        seed: 11,
    };
    let (got, dir) = recover_result("tapered", &truth, &cam, false, false, "tapered-ball");
    right_or_refused(
        &got,
        &dir,
        &[
            ("radius_mm", 0.03, 0.005),
            ("angle_deg", 40.0, 1.0),
            ("z_offset_mm", 0.002, 0.003),
        ],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The widths W(z) that `tool` cuts at the card's commanded depths, mm (None: no cut).
fn widths(tool: &Tool, depths: &[f64]) -> Vec<Option<f64>> {
    depths
        .iter()
        .map(|&z| tool.model(z).map(|m| m.width).filter(|w| *w > 1e-6))
        .collect()
}

/// The largest difference of the cut widths of two tools over the depths where `truth` cuts at
/// least `min_depth_mm` deep (commanded depth plus its offset), mm; prints both.
fn width_error(fitted: &Tool, truth: &Tool, depths: &[f64], offset_mm: f64, min_depth_mm: f64) -> f64 {
    let (f, t) = (widths(fitted, depths), widths(truth, depths));
    let mut worst = 0.0f64;
    for ((z, a), b) in depths.iter().zip(&f).zip(&t) {
        eprintln!("z {z:+.4} mm: fitted W {a:?}, true W {b:?}");
        if z + offset_mm >= min_depth_mm {
            let (a, b) = (a.unwrap_or(0.0), b.unwrap_or(0.0));
            worst = worst.max((a - b).abs());
        }
    }
    worst
}

/// A tool that matches no formula (a measured profile, one width per ladder depth, fitted to
/// photos of a V-bit's card): wherever the groove is at least 5 um deep, every recovered width is
/// within 3 of its stated uncertainties of the true width, and the fit says they are not
/// identified to what a plate needs, so that without `--allow-unidentified` it writes nothing.
/// (The profile's free w/W ratio trades against the widths: a groove 20% wider with flatter
/// walls sends nearly the same light. Measured: widths 19% wide at 100 um, stated +- 4 to 29 um.
/// Shallower rungs are a few pixels' worth of light; the profile has no z offset, so they are
/// reported as not identified.)
#[test]
fn recovers_a_measured_profile() {
    let truth = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.004,
    };
    let cam = Camera {
        exposure: 4.0,
        blur_px: 0.7,
        noise: 0.01,
        seed: 9,
    };
    let (tool, record, dir) = recover("profile", &truth, &cam, false, false, "profile");
    assert!(matches!(tool, Tool::Profile { .. }), "{tool:?}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("fit/tool_report.json")).unwrap()).unwrap();
    let sd_of = |name: &str| {
        report["params"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .and_then(|p| p["sd"].as_f64())
    };
    let depths = Card::new(&CardSpec::default()).depths_mm;
    let (fit_w, true_w) = (widths(&tool, &depths), widths(&truth, &depths));
    let mut checked = 0;
    for ((z, f), t) in depths.iter().zip(&fit_w).zip(&true_w) {
        if z + 0.004 < 0.005 {
            continue;
        }
        let (f, t) = (f.expect("a width where the tool cuts"), t.unwrap());
        let name = format!("W_mm@{z}");
        let sigma = sd_of(&name).unwrap_or_else(|| panic!("no uncertainty for W at {z}: {report}"));
        eprintln!(
            "z {z} mm: W {:.1} um, true {:.1} um, stated +- {:.1} um",
            1e3 * f,
            1e3 * t,
            1e3 * sigma
        );
        assert!(
            (f - t).abs() <= 3.0 * sigma,
            "W at {z} mm: {f} against {t} (+- {sigma})"
        );
        if sigma > 0.0025 {
            let listed = record["written_with_unidentified"]
                .as_array()
                .is_some_and(|l| l.iter().any(|m| m.as_str().unwrap_or("").starts_with(&name)));
            assert!(
                listed,
                "{name} +- {sigma} is not marked as written unidentified: {record}"
            );
        }
        checked += 1;
    }
    assert!(checked >= 8, "only {checked} rungs checked");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Without --kind every kind is fitted and the lowest BIC chosen; whichever wins, it cuts the
/// true tool's grooves: widths within 3 um wherever the groove is at least 3 um deep, and every
/// kind is listed among the candidates.
#[test]
fn chooses_a_kind_that_cuts_the_true_grooves() {
    let truth = Tool::Ball {
        radius_mm: 0.06,
        z_offset_mm: 0.003,
    };
    let cam = Camera {
        exposure: 3.0,
        blur_px: 0.6,
        noise: 0.008,
        seed: 13,
    };
    let (tool, record, dir) = recover("auto", &truth, &cam, false, false, "auto");
    let depths = Card::new(&CardSpec::default()).depths_mm;
    let err = width_error(&tool, &truth, &depths, 0.003, 0.003);
    eprintln!("auto: chose {}, worst width error {:.2} um", record["kind"], 1e3 * err);
    assert!(err < 0.003, "chose {tool:?}: widths off by {:.2} um", 1e3 * err);
    let kinds: Vec<&str> = record["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["v-bit", "ball", "tapered-ball", "profile"], "{record}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Stops the fit (as Ctrl-C does) at the first refinement progress, and records every task seen.
struct StopAtRefine {
    seen: std::sync::Mutex<Vec<String>>,
    stop: bool,
}

impl scratchart_observe::Observer for StopAtRefine {
    fn progress(&self, p: &scratchart_observe::Progress) {
        self.seen.lock().unwrap().push(format!("{}: {}", p.task, p.message));
    }
    fn should_stop(&self) -> bool {
        self.stop && self.seen.lock().unwrap().iter().any(|t| t.starts_with("fit:"))
    }
}

/// A fit stopped after its search (Ctrl-C) leaves its resume file; `--resume` then skips the
/// search and ends with exactly the uninterrupted fit's tool, and removes the file; a resume file
/// from other photos is refused.
#[test]
fn an_interrupted_fit_resumes_where_it_stopped() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit", "resume");
    let (card, capture, card_path) = card(&dir);
    let (truth, cam) = ball_case();
    let imgs = shoot(&r, &card, &capture, capture.views.clone(), &truth, &cam, &dir);
    let args = |out: &str, resume: bool| FitArgs {
        card: card_path.clone(),
        images: imgs.clone(),
        kind: Some("ball".into()),
        out: dir.join(out),
        init: None,
        iters: 15,
        resume,
        bootstrap: 0,
        quiet: true,
        allow_unidentified: false,
        check: false,
        whole_renders: false,
    };
    // Uninterrupted.
    run(&r, &args("whole/tool.json", false), &Silent).unwrap();
    let (whole, _) = Tool::load_fitted(&dir.join("whole/tool.json")).unwrap();
    assert!(!dir.join("whole/tool.resume.json").exists(), "resume file left behind");
    // Stopped after the search.
    let stopper = StopAtRefine {
        seen: Default::default(),
        stop: true,
    };
    let e = run(&r, &args("cut/tool.json", false), &stopper).unwrap_err();
    assert_eq!(scratchart::exit::code(&*e), 130, "{e:#}");
    assert!(dir.join("cut/tool.resume.json").is_file(), "no resume file");
    assert!(!dir.join("cut/tool.json").exists());
    // Resumed: no search, the same tool.
    let watcher = StopAtRefine {
        seen: Default::default(),
        stop: false,
    };
    run(&r, &args("cut/tool.json", true), &watcher).unwrap();
    let seen = watcher.seen.lock().unwrap().clone();
    assert!(
        !seen.iter().any(|t| t.starts_with("search")),
        "the search ran again: {seen:?}"
    );
    let (resumed, _) = Tool::load_fitted(&dir.join("cut/tool.json")).unwrap();
    assert_eq!(format!("{resumed:?}"), format!("{whole:?}"));
    assert!(!dir.join("cut/tool.resume.json").exists(), "resume file left behind");
    // A resume file from other photos is refused.
    let stopper = StopAtRefine {
        seen: Default::default(),
        stop: true,
    };
    run(&r, &args("other/tool.json", false), &stopper).unwrap_err();
    assert!(dir.join("other/tool.resume.json").is_file());
    let mut other = args("other/tool.json", true);
    std::fs::create_dir_all(dir.join("changed")).unwrap();
    other.images = imgs
        .iter()
        .map(|p| {
            let mut g = image::open(p).unwrap().to_luma8();
            g.get_pixel_mut(3, 3).0[0] ^= 1; // one grey level in a corner
            let q = dir.join("changed").join(p.file_name().unwrap());
            g.save(&q).unwrap();
            q
        })
        .collect();
    let e = format!("{:#}", run(&r, &other, &Silent).unwrap_err());
    assert!(e.contains("other photos"), "{e}");
    assert_no_validation(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A ball cutter below commanded zero, fitted with `--bootstrap N`: radius within 5 um, z offset
/// within 3 um; block-bootstrap uncertainties beside the curvature's, kept in tool.json, within a
/// factor 4 of the curvature's, and the true radius and offset lie within 4 of them.
#[test]
fn recovers_a_ball_cutter_with_bootstrap_uncertainties() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit", "bootstrap");
    let (card, capture, card_path) = card(&dir);
    let (truth, cam) = ball_case();
    let imgs = shoot(&r, &card, &capture, capture.views.clone(), &truth, &cam, &dir);
    let out = dir.join("fit/tool.json");
    let args = FitArgs {
        card: card_path.clone(),
        images: imgs,
        kind: Some("ball".into()),
        out: out.clone(),
        init: None,
        iters: 15,
        resume: false,
        bootstrap: 6,
        quiet: true,
        allow_unidentified: false,
        check: false,
        whole_renders: false,
    };
    run(&r, &args, &Silent).unwrap();
    let (tool, fitted) = Tool::load_fitted(&out).unwrap();
    let record = fitted.fit.unwrap();
    let Tool::Ball { radius_mm, z_offset_mm } = tool else {
        panic!("{tool:?}")
    };
    assert!((radius_mm - 0.08).abs() < 0.005, "radius {radius_mm}");
    assert!((z_offset_mm + 0.002).abs() < 0.003, "z offset {z_offset_mm}");
    assert_eq!(record["bootstrap"]["replicates"], 6, "{record}");
    for (name, value, truth) in [("radius_mm", radius_mm, 0.08), ("z_offset_mm", z_offset_mm, -0.002)] {
        let boot = record["bootstrap"]["std"][name].as_f64().unwrap();
        let curv = record["uncertainty"][name].as_f64().unwrap();
        eprintln!("{name}: {value} (true {truth}); curvature +- {curv:.2e}, bootstrap +- {boot:.2e}");
        assert!(boot > 0.0 && boot.is_finite(), "{name}: {boot}");
        assert!(
            boot < 4.0 * curv && curv < 4.0 * boot,
            "{name}: curvature {curv} against bootstrap {boot}"
        );
        assert!(
            (value - truth).abs() <= 4.0 * boot.max(curv),
            "{name}: {value} against {truth}"
        );
    }
    assert_no_validation(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
}
