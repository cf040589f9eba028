//! The loss's cross-talk term (`LossConfig::crosstalk`, `Loss::with_crosstalk`): on the GPU
//! against its f64 CPU twin (values and dE/dL), the twin's gradient against central
//! differences, no term (bit for bit the loss without it) where kappa is 0, only views of one
//! size paired, and zero validation messages.
use scratchart_design::scenes::{orbit_light, random_scratches, ring_views, Rng};
use scratchart_design::targets::builtin_targets;
use scratchart_model::scene::Scene;
use scratchart_optim::loss::{reference, Loss, LossConfig};
use scratchart_render::{GpuScene, Renderer};
use scratchart_tests::{assert_no_validation, gpu, plate};

fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt();
    let den: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    num / den.max(1e-300)
}

/// Three views of 41 x 41 px and a fourth of 37 x 29 (not paired: another size); each view's
/// picture a rectangle inside its frame.
fn scene_and_pictures() -> (Scene, Vec<Vec<f32>>, Vec<Vec<bool>>) {
    let light = orbit_light(300.0, 45.0, 30.0, 3.0e4);
    let mut rng = Rng::new(11);
    let mut scene = Scene {
        plate: plate(100.0),
        views: ring_views(4, 45.0, 300.0, 100.0, 41, &light),
        scratches: random_scratches(&mut rng, 500, 100.0, 2.0, 8.0, 0.05, 0.05, 0.06),
    };
    scene.views[3].camera.width = 37;
    scene.views[3].camera.height = 29;
    let targets = builtin_targets(&scene);
    let pictures = scene
        .views
        .iter()
        .enumerate()
        .map(|(v, view)| {
            let (w, h) = (view.camera.width as usize, view.camera.height as usize);
            (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    x >= 3 + v && x + 4 < w && y >= 5 && y + 3 + v < h
                })
                .collect()
        })
        .collect();
    (scene, targets, pictures)
}

/// The scene of [`scene_and_pictures`] uploaded and rendered: the GPU scene, the targets, the
/// pictures and the linear image.
fn rendered(ctx: &std::sync::Arc<scratchart_vulkan::Context>) -> (GpuScene, Vec<Vec<f32>>, Vec<Vec<bool>>, Vec<f32>) {
    let (scene, targets, pictures) = scene_and_pictures();
    let r = Renderer::new(ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    r.render(&mut gs).unwrap();
    let image: Vec<f32> = ctx.download(gs.image()).unwrap();
    (gs, targets, pictures, image)
}

#[test]
fn the_crosstalk_term_matches_its_cpu_twin() {
    let ctx = gpu();
    let (gs, targets, pictures, image) = rendered(&ctx);
    let among = [0usize, 1, 2, 3];
    let plain_cfg = LossConfig::default();
    let plain = Loss::new(&ctx, gs.views(), &targets, plain_cfg).unwrap();
    let lv0 = plain.evaluate(&ctx, gs.image(), Some(gs.dl())).unwrap();
    let dl0: Vec<f32> = ctx.download(gs.dl()).unwrap();

    // kappa 0: no pairs, the loss and its gradient bit for bit the plain loss's.
    let off = Loss::with_crosstalk(&ctx, gs.views(), &targets, plain_cfg, &pictures, &among).unwrap();
    assert!(off.crosstalk_pairs().is_empty());
    assert_eq!(off.evaluate(&ctx, gs.image(), Some(gs.dl())).unwrap(), lv0);
    let dl_off: Vec<f32> = ctx.download(gs.dl()).unwrap();
    assert!(dl_off.iter().zip(&dl0).all(|(a, b)| a.to_bits() == b.to_bits()));

    let cfg = LossConfig {
        crosstalk: 6.0,
        ..plain_cfg
    };
    let loss = Loss::with_crosstalk(&ctx, gs.views(), &targets, cfg, &pictures, &among).unwrap();
    assert_eq!(
        loss.crosstalk_pairs(),
        vec![(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)],
        "only views of one size are paired"
    );
    let lv = loss.evaluate(&ctx, gs.image(), Some(gs.dl())).unwrap();
    let dl: Vec<f32> = ctx.download(gs.dl()).unwrap();
    let (per_view, dl_ref) = reference::loss_crosstalk(&image, &targets, &loss.pyr, &cfg, &pictures, &among);
    for (v, (lp, lg)) in per_view.iter().enumerate() {
        eprintln!(
            "view {v}: pixel gpu {} ref {lp} (without the term {}); gram gpu {} ref {lg}",
            lv.pixel[v], lv0.pixel[v], lv.gram[v]
        );
        assert!(
            (lv.pixel[v] as f64 - lp).abs() <= 1e-4 * lp.abs(),
            "view {v}: pixel term gpu {} vs reference {lp}",
            lv.pixel[v]
        );
        assert_eq!(lv.gram[v], lv0.gram[v], "view {v}: the Gram term does not change");
        if v < 3 {
            assert!(
                lv.pixel[v] > 1.01 * lv0.pixel[v],
                "view {v}: the term must add to the pixel term ({} vs {})",
                lv.pixel[v],
                lv0.pixel[v]
            );
        } else {
            assert_eq!(lv.pixel[v], lv0.pixel[v], "view 3 has no pair");
        }
    }
    let dl64: Vec<f64> = dl.iter().map(|&x| x as f64).collect();
    let e = rel_err(&dl64, &dl_ref);
    let moved = rel_err(&dl64, &dl0.iter().map(|&x| x as f64).collect::<Vec<_>>());
    eprintln!("dE/dL relative error {e:.2e}; the term moves dE/dL by {moved:.2e}");
    assert!(e <= 1e-4, "dE/dL: relative error {e:.3e} against the reference");
    assert!(moved >= 1e-2, "the term must move dE/dL (by {moved:.3e})");
    assert_no_validation(&ctx);
}

#[test]
fn the_cpu_twins_crosstalk_gradient_matches_central_differences() {
    let ctx = gpu();
    let (gs, targets, pictures, image) = rendered(&ctx);
    let cfg = LossConfig {
        crosstalk: 6.0,
        ..LossConfig::default()
    };
    let loss = Loss::new(&ctx, gs.views(), &targets, cfg).unwrap();
    let s = &loss.pyr.segs[1];
    let (o, n) = (s.off as usize, (s.w * s.h) as usize);
    let l: Vec<f64> = image[o..o + n].iter().map(|&x| x as f64).collect();
    let t: Vec<f64> = targets[1].iter().map(|&x| x as f64).collect();
    let dirs: Vec<Vec<f64>> = [0usize, 2]
        .iter()
        .map(|&k| reference::crosstalk_direction(&targets[k], &pictures[1], 6.0))
        .collect();
    for u in &dirs {
        let norm = u.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(
            (norm - 6f64.sqrt()).abs() < 1e-9,
            "a direction has norm sqrt(kappa): {norm}"
        );
    }
    let f = |l: &[f64]| {
        let (a, b, _) = reference::view_loss_crosstalk(l, &t, s.w, s.h, &cfg, &dirs);
        a + b
    };
    let (_, _, d) = reference::view_loss_crosstalk(&l, &t, s.w, s.h, &cfg, &dirs);
    let (_, _, d_plain) = reference::view_loss(&l, &t, s.w, s.h, &cfg);
    let scale = d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut bright: Vec<usize> = (0..n).filter(|&i| l[i] > 1e-3 && pictures[1][i]).collect();
    bright.sort_by(|&a, &b| l[b].total_cmp(&l[a]).then(a.cmp(&b)));
    let mut checked = 0;
    for &i in bright.iter().step_by(3).take(20) {
        let h = 1e-6 * l[i];
        let (mut lp, mut lm) = (l.clone(), l.clone());
        lp[i] += h;
        lm[i] -= h;
        let fd = (f(&lp) - f(&lm)) / (2.0 * h);
        assert!(
            (fd - d[i]).abs() <= 1e-6 * scale + 1e-4 * fd.abs(),
            "pixel {i}: analytic dE/dL {} vs central difference {fd}",
            d[i]
        );
        checked += 1;
    }
    assert!(checked >= 5, "too few bright pixels checked ({checked})");
    assert!(
        rel_err(&d, &d_plain) > 1e-2,
        "the cross-talk term must change the gradient"
    );
    assert_no_validation(&ctx);
}
