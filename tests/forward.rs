//! The GPU forward renderer against the float64 reference (engine/docs/model.md section 8 forward bar), on
//! seeded scene families: moderate and sharp alpha, grazing views and lights, directional light,
//! thousands of scratches in one footprint, scratch ends and edges on footprint corners, very
//! thin and very short scratches.
use scratchart_design::scenes::Rng;
use scratchart_model::camera::ViewGeom;
use scratchart_tests::*;

#[test]
fn random_moderate_alpha() {
    let mut views = vec![
        orbit_view("a", 40, 45.0, 0.0, 45.0, 180.0, 20.0),
        orbit_view("b", 40, 45.0, 120.0, 45.0, 300.0, 20.0),
    ];
    // A view's exposure scales what it sees (the reference and the GPU alike).
    views[1].exposure = 0.37;
    let scene = random_scene(1, 300, 20.0, 0.2, 0.15, 0.2, views);
    assert_matches_reference("moderate", &scene);
    let ctx = scratchart_tests::gpu();
    let mut unit = scene.clone();
    unit.views[1].exposure = 1.0;
    let (a, b) = (gpu_render(&ctx, &scene), gpu_render(&ctx, &unit));
    let peak = b[1].iter().cloned().fold(0.0f32, f32::max);
    assert!(peak > 0.0);
    for (x, y) in a[1].iter().zip(&b[1]) {
        assert!((x - 0.37 * y).abs() <= 1e-5 * peak, "{x} against 0.37 x {y}");
    }
    assert_eq!(a[0], b[0], "the other view is untouched");
}

#[test]
fn sharp_alpha_1e3() {
    let views = vec![
        orbit_view("a", 40, 45.0, 0.0, 45.0, 180.0, 20.0),
        orbit_view("b", 40, 60.0, 200.0, 30.0, 10.0, 20.0),
    ];
    let scene = random_scene(2, 300, 20.0, 0.2, 0.2, 1e-3, views);
    assert_matches_reference("alpha 1e-3", &scene);
}

#[test]
fn grazing_camera_and_light_5deg() {
    let views = vec![
        grazing_view("a", 48, 5.0, 0.0, 5.0, 180.0, 20.0),
        grazing_view("b", 48, 5.0, 90.0, 5.0, 90.0, 20.0),
    ];
    let mut scene = random_scene(3, 300, 20.0, 0.2, 0.1, 0.05, views);
    scene
        .scratches
        .iter_mut()
        .enumerate()
        .for_each(|(k, s)| s.alpha = [1e-3, 0.05, 0.5][k % 3]);
    assert_matches_reference("grazing", &scene);
}

#[test]
fn grazing_dense_three_views() {
    // 1,000 scratches under three views and lights 5 degrees above the plate, one third of them
    // with alpha 1e-3: slivers of sharp lobes at footprint corners are where float32 geometry
    // would show (the ray hits are float64 on devices that have it).
    let views = vec![
        grazing_view("a", 48, 5.0, 0.0, 5.0, 180.0, 20.0),
        grazing_view("b", 48, 5.0, 90.0, 5.0, 90.0, 20.0),
        grazing_view("c", 48, 5.0, 200.0, 5.0, 20.0, 20.0),
    ];
    let mut scene = random_scene(31, 1000, 20.0, 0.2, 0.1, 0.05, views);
    scene
        .scratches
        .iter_mut()
        .enumerate()
        .for_each(|(k, s)| s.alpha = [1e-3, 0.05, 0.5][k % 3]);
    assert_matches_reference("grazing dense", &scene);
}

#[test]
fn horizon_in_view() {
    // A low camera with a wide field of view: the top of the image is sky (rays that never meet
    // the plate plane), the bottom is plate, and tiles and blocks straddle the horizon.
    let mut view = orbit_view("a", 64, 12.0, 30.0, 40.0, 210.0, 20.0);
    view.camera.fov_y_deg = 30.0;
    let scene = random_scene(17, 400, 20.0, 0.2, 0.15, 0.05, vec![view]);
    let g = scratchart_model::camera::ViewGeom::new(&scene.views[0]);
    assert!(g.hit(32.0, 0.0).is_none(), "the test view must see the sky");
    assert!(g.hit(32.0, 40.0).is_some(), "the test view must see the plate");
    let on = scratchart_model::camera::on_plate_mask(&scene, 0)
        .iter()
        .filter(|m| **m)
        .count();
    assert!(on > 150, "only {on} pixels on the plate");
    assert_matches_reference("horizon", &scene);
}

#[test]
fn directional_light() {
    let views = vec![
        directional_view("a", 40, 40.0, 30.0, 50.0, 210.0, 20.0),
        directional_view("b", 40, 70.0, 250.0, 20.0, 90.0, 20.0),
    ];
    let scene = random_scene(4, 300, 20.0, 0.2, 0.3, 0.1, views);
    assert_matches_reference("directional", &scene);
}

#[test]
fn thousands_of_scratches_per_footprint() {
    // A coarse view (large footprints) and 3,000 scratches through the plate centre.
    let mut rng = Rng::new(5);
    let mut scratches = Vec::new();
    for _ in 0..3000 {
        let a = rng.range(0.0, std::f64::consts::PI);
        let (l0, l1) = (rng.range(0.5, 4.0), rng.range(0.5, 4.0));
        let (c, s) = (a.cos(), a.sin());
        let o = [rng.range(-0.3, 0.3), rng.range(-0.3, 0.3)];
        let alpha = [1e-3, 0.02, 0.3][scratches.len() % 3];
        scratches.push(scratch(
            [o[0] - l0 * c, o[1] - l0 * s],
            [o[0] + l1 * c, o[1] + l1 * s],
            0.05,
            0.04,
            alpha,
        ));
    }
    let scene = scratchart_model::scene::Scene {
        plate: plate(20.0),
        views: vec![orbit_view("a", 12, 50.0, 30.0, 50.0, 210.0, 20.0)],
        scratches,
    };
    assert_matches_reference("dense", &scene);
}

#[test]
fn ends_and_edges_on_footprint_corners() {
    let view = orbit_view("a", 24, 50.0, 0.0, 50.0, 180.0, 20.0);
    let g = ViewGeom::new(&view);
    // Every footprint corner well inside the plate.
    let mut corners = Vec::new();
    for j in 0..24 {
        for i in 0..24 {
            if let Some(f) = g.footprint(i, j) {
                corners.extend(f.iter().copied().filter(|c| c[0].abs() < 9.0 && c[1].abs() < 9.0));
            }
        }
    }
    assert!(corners.len() > 100, "test view sees too little of the plate");
    let mut rng = Rng::new(6);
    let mut scratches = Vec::new();
    while scratches.len() < 120 {
        let a = corners[(rng.f64() * corners.len() as f64) as usize];
        let b = corners[(rng.f64() * corners.len() as f64) as usize];
        let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        if l < 0.5 {
            continue;
        }
        // Ends exactly on footprint corners; every other scratch is moved across by its
        // half-width so that a carved edge, not the axis, runs through the corners.
        let s = scratch(a, b, 0.1, 0.08, 0.1);
        let e = if scratches.len() % 2 == 0 { 0.0 } else { s.half_width() };
        let n = [-(b[1] - a[1]) / l * e, (b[0] - a[0]) / l * e];
        scratches.push(scratch(
            [a[0] - n[0], a[1] - n[1]],
            [b[0] - n[0], b[1] - n[1]],
            0.1,
            0.08,
            0.1,
        ));
    }
    assert!(scratches.len() > 50);
    let scene = scratchart_model::scene::Scene {
        plate: plate(20.0),
        views: vec![view],
        scratches,
    };
    assert_matches_reference("corners", &scene);
}

#[test]
fn very_thin_and_very_short_scratches() {
    let views = vec![orbit_view("a", 40, 45.0, 0.0, 45.0, 180.0, 20.0)];
    let mut scene = random_scene(7, 400, 20.0, 0.2, 0.2, 0.05, views);
    let mut rng = Rng::new(8);
    for (k, s) in scene.scratches.iter_mut().enumerate() {
        if k % 2 == 0 {
            // very thin
            s.w = 1e-4;
            s.d = 1e-4 * rng.range(0.2, 3.0);
        } else {
            // very short
            let l = rng.range(1e-4, 1e-2);
            let t = [(s.p1[0] - s.p0[0]) / s.length(), (s.p1[1] - s.p0[1]) / s.length()];
            s.p1 = [s.p0[0] + l * t[0], s.p0[1] + l * t[1]];
        }
    }
    // Shorter than float32 resolves at these coordinates (p1 rounds onto p0 on the device):
    // allowed by engine/docs/model.md, and must neither produce NaN nor disturb their pixels.
    for k in 0..20 {
        let s = &mut scene.scratches[k];
        s.p1 = [s.p0[0] + 1e-7 * (1.0 + k as f64), s.p0[1]];
    }
    assert_matches_reference("thin/short", &scene);
}

/// A render that keeps the last render's tile lists (`record_render_with(.., false)`, what the
/// viewer does when only the lamp moved) gives the same bits as one that bins again, and as a
/// fresh upload lit by the new lamp; with a camera that moved, keeping the lists is wrong (the
/// control that shows the comparison can fail).
#[test]
fn a_lamp_that_moves_needs_no_new_tile_lists() {
    let ctx = scratchart_tests::gpu();
    let r = scratchart_render::Renderer::new(&ctx).unwrap();
    let views = vec![orbit_view("a", 48, 45.0, 0.0, 50.0, 20.0, 20.0)];
    let scene = random_scene(7, 600, 20.0, 0.2, 0.15, 0.2, views);
    let mut gs = r.upload(&scene).unwrap();
    let mut rec = scratchart_vulkan::Recorder::new(&ctx).unwrap();
    r.submit(&mut rec, &mut gs, |rec, gs| r.record_render_with(rec, gs, true))
        .unwrap();
    // The lamp moves; the camera stays.
    let mut lit = scene.clone();
    lit.views[0].light = scratchart_design::scenes::orbit_light(60.0, 35.0, 140.0, 2.0e3);
    assert!(gs.update_views(&lit.views).unwrap());
    r.submit(&mut rec, &mut gs, |rec, gs| r.record_render_with(rec, gs, false))
        .unwrap();
    let kept = r.download_images(&gs).unwrap();
    let fresh = gpu_render(&ctx, &lit);
    assert!(kept[0].iter().any(|&l| l > 0.0), "the lit plate is dark");
    assert_eq!(kept, fresh, "the kept lists gave other bits than binning again");
    // The control: the camera moves and the lists are kept: the image is not the right one.
    let mut turned = lit.clone();
    turned.views[0] = orbit_view("a", 48, 40.0, 35.0, 50.0, 20.0, 20.0);
    turned.views[0].light = lit.views[0].light.clone();
    assert!(gs.update_views(&turned.views).unwrap());
    r.submit(&mut rec, &mut gs, |rec, gs| r.record_render_with(rec, gs, false))
        .unwrap();
    let stale = r.download_images(&gs).unwrap();
    assert_ne!(stale, gpu_render(&ctx, &turned), "stale lists went unnoticed");
    assert_no_validation(&ctx);
}
