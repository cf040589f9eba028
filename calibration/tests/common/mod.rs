//! What the calibration's fit tests share: a scratch folder, the card, photos simulated from
//! given views, a fit run as the command runs it, and the exit code of an error.
#![allow(dead_code)] // each test file uses its own share of these

use std::path::{Path, PathBuf};

use scratchart_calibration::card::{Card, CardSpec};
use scratchart_calibration::fit_cmd::{run, FitArgs};
use scratchart_calibration::simulate::{photos, Camera};
use scratchart_model::scene::{Plate, Scene, View};
use scratchart_observe::Silent;
use scratchart_render::Renderer;
use scratchart_tool::Tool;

/// An empty scratch folder `scratchart-{group}-{pid}-{tag}` in the system's temp folder.
pub fn tmp(group: &str, tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-{group}-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes card.json (256 px capture views) into `dir`.
pub fn card(dir: &Path) -> (Card, Scene, PathBuf) {
    let card = Card::new(&CardSpec::default());
    let p = dir.join("card.json");
    std::fs::write(&p, serde_json::to_string_pretty(&card.to_json(256)).unwrap()).unwrap();
    let (card, capture) = Card::load(&p).unwrap();
    (card, capture, p)
}

/// Photos of the card cut by `tool`, taken from `views`, written as PNGs named after the views.
pub fn shoot(
    r: &Renderer,
    card: &Card,
    capture: &Scene,
    views: Vec<View>,
    tool: &Tool,
    cam: &Camera,
    dir: &Path,
) -> Vec<PathBuf> {
    let scene = Scene {
        plate: Plate {
            ..capture.plate.clone()
        },
        views,
        scratches: vec![],
    };
    let imgs = photos(r, card, &scene, tool, cam).unwrap();
    scene
        .views
        .iter()
        .zip(&imgs)
        .map(|(v, img)| {
            let bytes: Vec<u8> = img.iter().map(|&x| (255.0 * x).round() as u8).collect();
            let p = dir.join(format!("{}.png", v.name));
            scratchart_render::io::write_png_gray(&p, v.camera.width, v.camera.height, &bytes).unwrap();
            p
        })
        .collect()
}

/// A fit as `scratchart-cal fit` runs it (profiles and `auto` written with their unidentified
/// widths); the tool written and its fit record.
pub fn fit(
    r: &Renderer,
    card: &Path,
    images: Vec<PathBuf>,
    kind: &str,
    out: &Path,
) -> anyhow::Result<(Tool, serde_json::Value)> {
    let args = FitArgs {
        // A measured profile's deep widths trade with the exposure (about 7%, more than the
        // 2.5 um a plate's lengths need): the profile tests check them against their stated
        // uncertainties instead, so they write them anyway.
        allow_unidentified: kind == "profile" || kind == "auto",
        // "auto": no --kind, every kind fitted and the best chosen
        ..FitArgs::quiet(card, images, (kind != "auto").then_some(kind), out)
    };
    run(r, &args, &Silent)?;
    let (tool, fitted) = Tool::load_fitted(out).unwrap();
    Ok((tool, fitted.fit.unwrap()))
}

/// The exit code the binaries give an error.
pub fn code(e: &anyhow::Error) -> u8 {
    scratchart::exit::code_of(e)
}

/// `scratchart-cal fit`'s flags for these photos, quiet.
pub fn args(card: &Path, images: Vec<PathBuf>, kind: &str, out: &Path) -> FitArgs {
    FitArgs::quiet(card, images, Some(kind), out)
}

/// The fit's stated value and standard deviation of parameter `name` (tool_report.json, written
/// whether the fit is accepted or refused).
pub fn stated(dir: &Path, name: &str) -> (f64, f64) {
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("fit/tool_report.json")).unwrap()).unwrap();
    let p = report["params"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap_or_else(|| panic!("{name} in {report}"))
        .clone();
    (p["value"].as_f64().unwrap(), p["sd"].as_f64().unwrap_or(f64::INFINITY))
}

/// Never a wrong tool: for each (parameter, truth, window), a written fit holds it within the
/// window and within three of its stated standard deviations; a refused one exits 3 as not
/// identified, writes no tool.json, and states the truth within three of its standard
/// deviations. Returns whether the tool was written.
pub fn right_or_refused(
    got: &anyhow::Result<(Tool, serde_json::Value)>,
    dir: &Path,
    truth: &[(&str, f64, f64)],
) -> bool {
    for &(name, t, window) in truth {
        let (v, sd) = stated(dir, name);
        eprintln!("{name}: {v} +- {sd} (truth {t})");
        assert!(
            (v - t).abs() <= 3.0 * sd,
            "{name} {v} +- {sd}: the truth {t} lies outside three sigmas"
        );
        if got.is_ok() {
            assert!((v - t).abs() < window, "{name} written as {v} for {t}");
        }
    }
    if let Err(e) = got {
        assert_eq!(scratchart::exit::code_of(e), 3, "{e:#}");
        assert!(format!("{e:#}").contains("not identified"), "{e:#}");
        assert!(!dir.join("fit/tool.json").exists());
    }
    got.is_ok()
}

/// As a phone stores them: colour JPEGs (quality 92) of the grey photos, named after the views.
pub fn as_phone_jpegs(pngs: &[PathBuf]) -> Vec<PathBuf> {
    use image::ImageEncoder as _;
    pngs.iter()
        .map(|p| {
            let g = image::open(p).unwrap().to_luma8();
            let rgb = image::DynamicImage::ImageLuma8(g).to_rgb8();
            let mut buf = Vec::new();
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 92)
                .write_image(rgb.as_raw(), rgb.width(), rgb.height(), image::ExtendedColorType::Rgb8)
                .unwrap();
            let j = p.with_extension("jpg");
            std::fs::write(&j, buf).unwrap();
            std::fs::remove_file(p).unwrap();
            j
        })
        .collect()
}
