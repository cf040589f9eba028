//! Bent plates (engine/docs/model.md section 10): the GPU renderer against the float64 reference
//! on sheets bent into cylinders about either axis, convex and concave, at radii from a bracelet's
//! to a lamp shade's (scaled to the 20 mm test plate: a 100 mm sheet at 60 to 300 mm), with eyes
//! and lamps low enough that a concave sheet's edges hide and shade part of it; and the plane
//! limit: a very large radius renders as the flat plate.
use scratchart_model::scene::Scene;
use scratchart_model::surface::{BendAxis, PlateShape};
use scratchart_tests::*;

fn bent(scene: &Scene, radius_mm: f64, axis: BendAxis, convex: bool) -> Scene {
    let mut s = scene.clone();
    s.plate.shape = PlateShape::Cylinder {
        radius_mm,
        axis,
        convex,
    };
    s
}

fn views() -> Vec<scratchart_model::scene::View> {
    vec![
        orbit_view("a", 40, 45.0, 0.0, 45.0, 180.0, 20.0),
        orbit_view("b", 40, 60.0, 110.0, 30.0, 300.0, 20.0),
        // Low, along the wrapped axis: a concave sheet's edge hides part of its inside.
        orbit_view("c", 40, 18.0, 10.0, 70.0, 200.0, 20.0),
    ]
}

#[test]
fn convex_and_concave_about_either_axis_match_the_reference() {
    let flat = random_scene(51, 300, 20.0, 0.2, 0.15, 0.1, views());
    for (radius, axis, convex) in [
        (12.0, BendAxis::Y, true),
        (12.0, BendAxis::Y, false),
        (12.0, BendAxis::X, true),
        (60.0, BendAxis::X, false),
    ] {
        let scene = bent(&flat, radius, axis, convex);
        let label = format!(
            "R {radius} about {} {}",
            axis.name(),
            if convex { "convex" } else { "concave" }
        );
        assert_matches_reference(&label, &scene);
    }
}

/// The sizes a maker bends: a 100 mm sheet at 60 mm (a vase band, nearly a half turn) and at
/// 300 mm (a lamp shade), about either axis, either way.
#[test]
fn a_100_mm_sheet_at_60_and_300_mm() {
    let views = vec![
        orbit_view("a", 40, 45.0, 0.0, 45.0, 180.0, 100.0),
        orbit_view("b", 40, 30.0, 200.0, 60.0, 40.0, 100.0),
    ];
    let flat = random_scene(54, 300, 100.0, 0.15, 0.08, 0.05, views);
    for (radius, axis, convex) in [
        (60.0, BendAxis::Y, true),
        (60.0, BendAxis::X, false),
        (300.0, BendAxis::X, true),
        (300.0, BendAxis::Y, false),
    ] {
        let scene = bent(&flat, radius, axis, convex);
        let label = format!(
            "100 mm at R {radius} about {} {}",
            axis.name(),
            if convex { "convex" } else { "concave" }
        );
        assert_matches_reference(&label, &scene);
    }
}

#[test]
fn sharp_lobes_and_a_directional_lamp_on_a_bent_sheet() {
    let mut scene = random_scene(
        52,
        300,
        20.0,
        0.2,
        0.2,
        1e-3,
        vec![
            directional_view("d", 40, 50.0, 200.0, 40.0, 20.0, 20.0),
            orbit_view("e", 40, 35.0, 90.0, 25.0, 250.0, 20.0),
        ],
    );
    for (k, s) in scene.scratches.iter_mut().enumerate() {
        s.alpha = [1e-3, 0.05, 0.5][k % 3];
    }
    assert_matches_reference("sharp, concave R 15", &bent(&scene, 15.0, BendAxis::Y, false));
    assert_matches_reference("sharp, convex R 15", &bent(&scene, 15.0, BendAxis::X, true));
}

/// What the bend changes, it changes measurably: a strongly bent sheet's render differs from the
/// flat one's, and a very large radius (a 20 mm sheet at 200 m: its edges 0.25 um off the plane)
/// renders as the flat plate to within the accuracy bar.
#[test]
fn a_large_radius_is_the_flat_plate_and_a_small_one_is_not() {
    let flat = random_scene(53, 200, 20.0, 0.2, 0.15, 0.1, views()[..2].to_vec());
    let ctx = gpu();
    let f = gpu_render(&ctx, &flat);
    let near = gpu_render(&ctx, &bent(&flat, 2.0e5, BendAxis::Y, true));
    let strong = gpu_render(&ctx, &bent(&flat, 12.0, BendAxis::Y, true));
    for v in 0..2 {
        let peak = f[v].iter().cloned().fold(0.0f32, f32::max) as f64;
        let diff = |a: &[f32], b: &[f32]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (*x as f64 - *y as f64).abs())
                .fold(0.0, f64::max)
                / peak
        };
        let (d_near, d_strong) = (diff(&f[v], &near[v]), diff(&f[v], &strong[v]));
        eprintln!(
            "view {v}: largest change against the flat plate / peak: R 200 m {d_near:.2e}, R 12 mm {d_strong:.2e}"
        );
        assert!(
            d_near < 2e-3,
            "view {v}: R 200 m differs from flat by {d_near:e} of the peak"
        );
        assert!(
            d_strong > 0.1,
            "view {v}: R 12 mm differs from flat by only {d_strong:e} of the peak"
        );
    }
    assert_no_validation(&ctx);
}
