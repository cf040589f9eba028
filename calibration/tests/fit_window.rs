//! The fit renders only the tiles its residuals read (each photo's mask, and what the widest
//! blur reaches from it), and the whole images where more is read (a JPEG's blocks, a shrink,
//! the residual images): the same fit, to the bit, as rendering the whole images throughout.
mod common;

use scratchart_calibration::fit_cmd::{run, FitArgs};
use scratchart_calibration::simulate::Camera;
use scratchart_observe::Silent;
use scratchart_render::Renderer;
use scratchart_tests::{assert_no_validation, gpu};
use scratchart_tool::Tool;

use common::{as_phone_jpegs, card, shoot, tmp};

/// tool.json without the fit's wall times (its seconds, and those in the engine's calls: the
/// things allowed to differ).
fn fitted(path: &std::path::Path) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let fit = v["fit"].as_object_mut().unwrap();
    fit.remove("seconds");
    assert!(fit
        .remove("engine_seconds")
        .is_some_and(|s| s.as_f64().is_some_and(|s| s > 0.0)));
    v
}

/// A ball photographed blurred and noisy as a phone stores it (640 x 480 colour JPEGs, shrunk to
/// the capture views: the JPEG's and the shrink's terms read the whole images), fitted from the
/// truth: every number of tool.json is the same with windowed and with whole renders, and so
/// are the residual images.
#[test]
fn windowed_renders_change_no_bit_of_the_fit() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("fit-window", "ball");
    let (card, capture, card_path) = card(&dir);
    let truth = Tool::Ball {
        radius_mm: 0.08,
        z_offset_mm: -0.002,
    };
    let cam = Camera {
        exposure: 2.0,
        blur_px: 0.8,
        noise: 0.006,
        seed: 5,
    };
    let mut views = capture.views.clone();
    for view in &mut views {
        (view.camera.width, view.camera.height) = (640, 480);
    }
    let imgs = as_phone_jpegs(&shoot(&r, &card, &capture, views, &truth, &cam, &dir));
    let init = dir.join("truth.json");
    std::fs::write(&init, serde_json::to_string(&truth).unwrap()).unwrap();
    let mut got = Vec::new();
    for whole in [false, true] {
        let out = dir.join(if whole { "whole" } else { "windowed" }).join("tool.json");
        let args = FitArgs {
            init: Some(init.clone()),
            iters: 4,
            allow_unidentified: true,
            whole_renders: whole,
            ..FitArgs::quiet(&card_path, imgs.clone(), Some("ball"), &out)
        };
        run(&r, &args, &Silent).unwrap();
        let residuals: Vec<Vec<u8>> = capture
            .views
            .iter()
            .map(|v| std::fs::read(out.with_file_name(format!("tool_residual_{}.png", v.name))).unwrap())
            .collect();
        got.push((fitted(&out), residuals));
    }
    assert!(got[0].0["fit"]["renders"].as_u64().unwrap() > 4, "{}", got[0].0);
    assert_eq!(got[0].0, got[1].0, "windowed against whole renders");
    assert!(got[0].1 == got[1].1, "the residual images differ");
    assert_no_validation(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
}
