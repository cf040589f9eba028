//! The photo model with each render pixel's moments of light (`simulate::render_for_optics_with`,
//! `blur_moments`): the guide's capture of a V-bit blurred by 0.6 px, rendered at 2 times the
//! photo's resolution, against the same at 8 times (a view at a time), rms over the card's
//! pixels relative to the light there. With the moments the model depends less on the render's
//! resolution: measured 0.019 and 0.020 with them, 0.032 and 0.037 without
//! (calibration/docs/fit.md, "Where the light falls within a pixel"); the bar is two thirds.
mod common;

use scratchart_calibration::fit_cmd::fit_mask;
use scratchart_calibration::simulate::{cut_scene, light_at};
use scratchart_render::Renderer;
use scratchart_tests::{assert_no_validation, gpu};
use scratchart_tool::Tool;

use common::{card, tmp};

#[test]
fn moments_make_the_photo_model_depend_less_on_the_render_resolution() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let dir = tmp("moments", "v75");
    let (card, capture, _) = card(&dir);
    let tool = Tool::VBit {
        angle_deg: 75.0,
        tip_flat_mm: 0.015,
        z_offset_mm: 0.007,
    };
    let scene = cut_scene(&card, &capture, &tool);
    let blur_px = 0.6;
    // View 0's photo, its render `k` times finer, with or without the moments.
    let photo = |k: u32, moments: bool| light_at(&r, &scene, 0, k, blur_px, moments).unwrap();
    let mask = fit_mask(&card, &scene.views[0], 0.5 * card.plate_mm);
    let rel = |a: &[f64], t: &[f64]| -> f64 {
        let (mut d, mut n) = (0.0, 0.0);
        for ((x, y), m) in a.iter().zip(t).zip(&mask) {
            if *m {
                d += (x - y).powi(2);
                n += y * y;
            }
        }
        (d / n).sqrt()
    };
    let with = rel(&photo(2, true), &photo(8, true));
    let without = rel(&photo(2, false), &photo(8, false));
    eprintln!("2 times against 8: {with:.4} with the moments, {without:.4} without");
    assert!(
        with < 2.0 / 3.0 * without,
        "{with:.4} with the moments, {without:.4} without"
    );
    assert_no_validation(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
}
