//! The fit's inputs as they reach it: photos shrunk, enlarged or given in another order, and
//! inputs it cannot fit (too few photos, no card, saturated): refused or placed, never fitted
//! wrong.
use std::path::Path;

use scratchart_calibration::simulate::Camera;
use scratchart_observe::Silent;
use scratchart_render::Renderer;
use scratchart_tests::{assert_no_validation, gpu};
use scratchart_tool::Tool;

mod common;
use common::{card, fit, shoot, tmp};

/// Photos as they reach the computer, checked before any fit (`inspect_photo`, which `fit` and
/// `fit --check` both run): shrunk to half after they were taken (an app, a messenger), they show
/// the card on fewer pixels per mm than the fit needs and are refused naming both numbers;
/// enlarged three times in their display encoding (ImageMagick's default), refused as enlarged
/// (`resampled`: smaller factors and some filters are not yet told apart);
/// given in another order than the views' and not named after them, each is put in its place
/// by the card's marks. The photos as taken pass. (Fitted, the shrunk pair gave a 60 degree
/// V-bit at 48.5 degrees and the enlarged one at 57.3 +- 0.25, written.)
#[test]
fn photos_shrunk_enlarged_or_reordered_are_refused_or_placed() {
    use scratchart_calibration::fit_cmd::inspect_photo;
    use scratchart_calibration::fit_cmd::photos::order_by_marks;
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit", "resized");
    let (card, capture, _) = card(&dir);
    let tool = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.005,
    };
    let cam = Camera {
        exposure: 0.8,
        blur_px: 0.6,
        ..Camera::default()
    };
    let good = shoot(&r, &card, &capture, capture.views.clone(), &tool, &cam, &dir);
    assert_no_validation(&ctx);
    for (v, p) in good.iter().enumerate() {
        assert!(inspect_photo(&card, &capture, &capture.views[v], p).is_ok());
    }
    // Shrunk in the display encoding, as an image editor does (bilinear).
    let resized = |p: &Path, f: f64, tag: &str| {
        let img = image::open(p).unwrap().to_luma8();
        let (w, h) = (
            (img.width() as f64 * f).round() as u32,
            (img.height() as f64 * f).round() as u32,
        );
        let out = image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle);
        let q = dir.join(format!("{tag}_{}", p.file_name().unwrap().to_string_lossy()));
        out.save(&q).unwrap();
        q
    };
    for (v, p) in good.iter().enumerate() {
        let half = resized(p, 0.5, "half");
        let e = format!(
            "{:#}",
            inspect_photo(&card, &capture, &capture.views[v], &half).err().unwrap()
        );
        assert!(
            e.contains("pixels per mm") && e.contains("the fit needs at least"),
            "{e}"
        );
        // Enlarged as the maker did, with ImageMagick's default (`.ci/setup` installs it).
        let big = dir.join(format!("big_{}", p.file_name().unwrap().to_string_lossy()));
        let st = std::process::Command::new("convert")
            .arg(p)
            .args(["-resize", "300%"])
            .arg(&big)
            .status()
            .expect("ImageMagick's convert (bash .ci/setup installs it)");
        assert!(st.success());
        let e = format!(
            "{:#}",
            inspect_photo(&card, &capture, &capture.views[v], &big).err().unwrap()
        );
        assert!(e.contains("was enlarged after it was taken"), "{e}");
    }
    // The west view first, under names that are not the views'.
    let a = dir.join("IMG_0001.png");
    let b = dir.join("IMG_0002.png");
    std::fs::copy(&good[1], &a).unwrap();
    std::fs::copy(&good[0], &b).unwrap();
    let placed = order_by_marks(&card, &capture, vec![a.clone(), b.clone()], &Silent);
    assert_eq!(placed, vec![b, a]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Too few photos, a photo without the card, saturated photos: clear errors, nothing written.
#[test]
fn refuses_what_it_cannot_fit() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit", "bad");
    let (card, capture, card_path) = card(&dir);
    let tool = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.0,
    };
    let out = dir.join("tool.json");
    let good = shoot(
        &r,
        &card,
        &capture,
        capture.views.clone(),
        &tool,
        &Camera {
            exposure: 3.0,
            ..Camera::default()
        },
        &dir,
    );
    let msg = |e: anyhow::Error| format!("{e:#}");
    // One photo for two capture views.
    let e = msg(fit(&r, &card_path, vec![good[0].clone()], "v-bit", &out).unwrap_err());
    assert!(
        e.contains("one photo per capture view") && e.contains("cam_west"),
        "{e}"
    );
    assert_eq!(
        scratchart::exit::code(&*fit(&r, &card_path, vec![good[0].clone()], "v-bit", &out).unwrap_err()),
        3
    );
    // The west photo as an iPhone keeps it by default (HEIC): named, with how to get a JPEG.
    let heic = dir.join("IMG_0002.HEIC");
    let mut bytes = b"\0\0\0\x18ftypheic\0\0\0\0mif1heic".to_vec();
    bytes.resize(4096, 7);
    std::fs::write(&heic, bytes).unwrap();
    let e = fit(&r, &card_path, vec![good[0].clone(), heic], "v-bit", &out).unwrap_err();
    assert_eq!(scratchart::exit::code(&*e), 3);
    let e = msg(e);
    assert!(
        e.contains("IMG_0002.HEIC") && e.contains("a HEIC (HEIF) photo") && e.contains("Most Compatible"),
        "{e}"
    );
    // A photo of nothing: uniform grey.
    let blank = dir.join("cam_west.png");
    scratchart_render::io::write_png_gray(&blank, 256, 256, &vec![40u8; 256 * 256]).unwrap();
    let e = msg(fit(&r, &card_path, vec![good[0].clone(), blank], "v-bit", &out).unwrap_err());
    assert!(e.contains("card not found") && e.contains("cam_west.png"), "{e}");
    // Saturated: a huge exposure.
    let sat = shoot(
        &r,
        &card,
        &capture,
        capture.views.clone(),
        &tool,
        &Camera {
            exposure: 1e6,
            ..Camera::default()
        },
        &dir,
    );
    let e = msg(fit(&r, &card_path, sat, "v-bit", &out).unwrap_err());
    assert!(e.contains("saturated"), "{e}");
    assert!(!out.exists(), "a failed fit wrote {}", out.display());
    assert_no_validation(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
}
