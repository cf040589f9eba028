//! The design optimizer on the real engine (lavapipe in CI): loss and Adam kernels against their
//! CPU twins, an optimization that lowers the loss and raises SSIM, bit-exact resume, rollback of
//! injected NaNs, and clear errors for bad targets. Every test checks zero validation messages.
use std::path::PathBuf;
use std::sync::Arc;

use scratchart_design::design::run_design;
use scratchart_design::problem::{DesignConfig, DesignReport, Problem};
use scratchart_design::scenes::{orbit_light, random_scratches, ring_views, Rng};
use scratchart_design::targets::{builtin_targets, load_targets, TargetError};
use scratchart_model::scene::Scene;
use scratchart_observe::Silent;
use scratchart_optim::adam::{Adam, AdamConfig, Moments, ParamBlock, StepCheck};
use scratchart_optim::driver::Hooks;
use scratchart_optim::loss::{reference, Loss, LossConfig};
use scratchart_optim::scene_params::{reference_step, SceneParams};
use scratchart_render::layout::ScratchGpu;
use scratchart_render::Renderer;
use scratchart_tests::{assert_no_validation, gpu, plate};
use scratchart_vulkan::{Context, Recorder};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-design-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small design problem: `views` ring views of `res` px, `n` scratches, built-in targets.
fn small_problem(views: usize, res: u32, n: usize, seed: u64) -> Problem {
    let light = orbit_light(300.0, 45.0, 30.0, 1.0e4);
    let mut rng = Rng::new(seed);
    let scene = Scene {
        plate: plate(100.0),
        views: ring_views(views, 45.0, 300.0, 100.0, res, &light),
        scratches: random_scratches(&mut rng, n, 100.0, 2.0, 8.0, 0.05, 0.05, 0.06),
    };
    let targets = builtin_targets(&scene);
    Problem::new(scene, targets)
}

fn quiet_config(out: PathBuf, iters: u32) -> DesignConfig {
    let mut cfg = DesignConfig::new(100.0, out);
    cfg.iters = iters;
    cfg.prune.tol = 0.0;
    cfg
}

fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt();
    let den: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    num / den.max(1e-300)
}

/// GPU loss values and dE/dL against the f64 CPU twin, on views of odd sizes (pyramid levels with
/// unpooled last rows/columns) and a Gram weight large enough that its gradient matters; and the
/// CPU twin's dE/dL against central differences of its own loss.
#[test]
fn loss_and_its_gradient_match_the_cpu_reference() {
    let ctx = gpu();
    let mut p = small_problem(2, 40, 400, 3);
    p.scene.views[1].camera.width = 37;
    p.scene.views[1].camera.height = 29;
    p.scene.views[0].light.intensity = 3.0e4;
    p.scene.views[1].light.intensity = 3.0e4;
    let targets = builtin_targets(&p.scene);
    let cfg = LossConfig {
        lambda_p: 1.0,
        lambda_g: 5.0,
        sigma: 0.8,
        levels: 3,
        crosstalk: 0.0,
    };
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&p.scene).unwrap();
    r.render(&mut gs).unwrap();
    let loss = Loss::new(&ctx, gs.views(), &targets, cfg).unwrap();
    let lv = loss.evaluate(&ctx, gs.image(), Some(gs.dl())).unwrap();
    let image: Vec<f32> = ctx.download(gs.image()).unwrap();
    let dl: Vec<f32> = ctx.download(gs.dl()).unwrap();
    let (per_view, dl_ref) = reference::loss(&image, &targets, &loss.pyr, &cfg);
    for (v, (lp, lg)) in per_view.iter().enumerate() {
        eprintln!(
            "view {v}: pixel gpu {} ref {lp}; gram gpu {} ref {lg}",
            lv.pixel[v], lv.gram[v]
        );
        assert!(
            (lv.pixel[v] as f64 - lp).abs() <= 1e-4 * lp.abs(),
            "view {v}: pixel term gpu {} vs reference {lp}",
            lv.pixel[v]
        );
        assert!(
            (lv.gram[v] as f64 - lg).abs() <= 1e-3 * lg.abs() + 1e-9,
            "view {v}: Gram term gpu {} vs reference {lg}",
            lv.gram[v]
        );
        assert!(
            *lg > 0.01 * lp,
            "the test must exercise the Gram term (gram {lg}, pixel {lp})"
        );
    }
    let total_ref: f64 = per_view.iter().map(|(a, b)| a + b).sum();
    assert!((lv.total as f64 - total_ref).abs() <= 1e-4 * total_ref);
    let dl64: Vec<f64> = dl.iter().map(|&x| x as f64).collect();
    let e = rel_err(&dl64, &dl_ref);
    let worst = dl64
        .iter()
        .zip(&dl_ref)
        .enumerate()
        .max_by(|a, b| (a.1 .0 - a.1 .1).abs().total_cmp(&(b.1 .0 - b.1 .1).abs()))
        .unwrap();
    eprintln!(
        "dE/dL relative error {e:.2e}; worst pixel {} gpu {} ref {}",
        worst.0, worst.1 .0, worst.1 .1
    );
    assert!(
        e <= 1e-4,
        "dE/dL: relative error {e:.3e}; worst pixel {}: gpu {} vs reference {}",
        worst.0,
        worst.1 .0,
        worst.1 .1
    );

    // The CPU twin's analytic gradient against central differences of its own loss, at pixels
    // with L well above the 1e-4 floor of the display slope.
    let s = &loss.pyr.segs[1];
    let (o, n) = (s.off as usize, (s.w * s.h) as usize);
    let l: Vec<f64> = image[o..o + n].iter().map(|&x| x as f64).collect();
    let t: Vec<f64> = targets[1].iter().map(|&x| x as f64).collect();
    let (_, _, d) = reference::view_loss(&l, &t, s.w, s.h, &cfg);
    let mut bright: Vec<usize> = (0..n).filter(|&i| l[i] > 1e-3).collect();
    bright.sort_by(|&a, &b| l[b].total_cmp(&l[a]).then(a.cmp(&b)));
    let mut checked = 0;
    for &i in bright.iter().step_by(3).take(20) {
        let h = 1e-6 * l[i];
        let (mut lp, mut lm) = (l.clone(), l.clone());
        lp[i] += h;
        lm[i] -= h;
        let (a, b, _) = reference::view_loss(&lp, &t, s.w, s.h, &cfg);
        let (c, e2, _) = reference::view_loss(&lm, &t, s.w, s.h, &cfg);
        let fd = ((a + b) - (c + e2)) / (2.0 * h);
        assert!(
            (fd - d[i]).abs() <= 1e-6 * d.iter().fold(0.0f64, |m, x| m.max(x.abs())) + 1e-4 * fd.abs(),
            "pixel {i}: analytic dE/dL {} vs central difference {fd}",
            d[i]
        );
        checked += 1;
    }
    assert!(checked >= 5, "too few bright pixels checked ({checked})");
    assert_no_validation(&ctx);
}

/// One Adam step on the GPU against the CPU twin, including the plate clamp and the minimum length.
#[test]
fn adam_step_matches_the_cpu_reference() {
    let ctx = gpu();
    let mut p = small_problem(1, 16, 5, 9);
    // Scratch 1 near the plate edge (the step pushes it off), scratch 2 nearly zero-length.
    p.scene.scratches[1].p0 = [49.95, 10.0];
    p.scene.scratches[1].p1 = [45.0, 10.0];
    p.scene.scratches[2].p0 = [0.0, 0.0];
    p.scene.scratches[2].p1 = [0.06, 0.0];
    let r = Renderer::new(&ctx).unwrap();
    let gs = r.upload(&p.scene).unwrap();
    let n = gs.n_scratches();
    let mut grads = vec![0f32; 8 * n as usize];
    let mut rng = Rng::new(5);
    for g in grads.iter_mut() {
        *g = rng.range(-1e-3, 1e-3) as f32;
    }
    grads[8] = -1.0; // scratch 1: x0 grows past the edge
    grads[8 * 2] = -1.0; // scratch 2: the ends move together
    grads[8 * 2 + 2] = 1.0;
    let cfg = AdamConfig::for_plate(100.0);
    let mut m0 = vec![0f32; 8 * n as usize];
    let mut v0 = vec![0f32; 8 * n as usize];
    for (k, (m, v)) in m0.iter_mut().zip(v0.iter_mut()).enumerate() {
        *m = 1e-4 * (k % 7) as f32;
        *v = 1e-7 * (k % 5) as f32;
    }
    let mom = Moments {
        m: ctx.upload("m", &m0).unwrap(),
        v: ctx.upload("v", &v0).unwrap(),
    };
    let grad = ctx.upload("grad", &grads).unwrap();
    let lossv = ctx.upload("loss", &[0f32, 0.0, 1.0]).unwrap();
    let stats = ctx.upload("stats", &[0u32; 16]).unwrap();
    let before = ctx
        .upload("before", &ctx.download::<u8>(gs.scratches()).unwrap())
        .unwrap();
    let adam = Adam::new(&ctx).unwrap();
    let params = SceneParams::new(&ctx, &cfg).unwrap();
    let block = ParamBlock {
        name: "scratches",
        params: gs.scratches(),
        grad: &grad,
        len: 8 * n,
        groups: SceneParams::scratch_groups(&cfg, 50.0),
    };
    let groups = Adam::group_buffer(&ctx, &block).unwrap();
    let check = StepCheck {
        objective: &lossv,
        index: 2,
        stats: &stats,
        capacity: 1 << 20,
        limit: f32::INFINITY,
    };
    let step = |rec: &mut Recorder| {
        adam.record(
            rec,
            std::slice::from_ref(&block),
            &[&mom],
            &[&groups],
            &cfg.hyper(),
            3,
            1.0,
            &check,
        )
        .unwrap();
        params.record_projection(rec, &gs, &before, &adam.flags);
    };
    let mut rec = Recorder::new(&ctx).unwrap();
    rec.begin().unwrap();
    step(&mut rec);
    rec.submit_and_wait().unwrap();
    assert!(!adam.read_flags().unwrap().any());
    let got: Vec<ScratchGpu> = ctx.download(gs.scratches()).unwrap();
    for (k, s) in p.scene.scratches.iter().enumerate() {
        let sg = ScratchGpu::from(s);
        let mut x = [
            sg.ends[0],
            sg.ends[1],
            sg.ends[2],
            sg.ends[3],
            sg.shape[0],
            sg.shape[1],
            sg.shape[2],
        ];
        let g: [f32; 7] = grads[8 * k..8 * k + 7].try_into().unwrap();
        let mut m: [f32; 7] = m0[8 * k..8 * k + 7].try_into().unwrap();
        let mut v: [f32; 7] = v0[8 * k..8 * k + 7].try_into().unwrap();
        reference_step(&mut x, &g, &mut m, &mut v, &cfg, 50.0, 3, 1.0);
        let gx = [
            got[k].ends[0],
            got[k].ends[1],
            got[k].ends[2],
            got[k].ends[3],
            got[k].shape[0],
            got[k].shape[1],
            got[k].shape[2],
        ];
        for c in 0..7 {
            assert!(
                (gx[c] - x[c]).abs() <= 1e-5 * (1.0 + x[c].abs()),
                "scratch {k} parameter {c}: gpu {} vs reference {}",
                gx[c],
                x[c]
            );
        }
        let len = ((gx[2] - gx[0]).powi(2) + (gx[3] - gx[1]).powi(2)).sqrt();
        assert!(
            len >= 0.999 * cfg.min_len,
            "scratch {k}: length {len} below the minimum"
        );
        assert!(
            gx[..4].iter().all(|c| c.abs() <= 50.0),
            "scratch {k} left the plate: {gx:?}"
        );
    }
    // A non-finite gradient freezes everything.
    rec.begin().unwrap();
    rec.fill(&grad, f32::NAN.to_bits());
    rec.barrier();
    let before: Vec<u8> = ctx.download(gs.scratches()).unwrap();
    step(&mut rec);
    rec.submit_and_wait().unwrap();
    assert!(adam.read_flags().unwrap().nonfinite_grad);
    assert_eq!(
        before,
        ctx.download::<u8>(gs.scratches()).unwrap(),
        "a NaN gradient must not move anything"
    );
    assert_no_validation(&ctx);
}

fn run(ctx: &Arc<Context>, p: &Problem, cfg: &DesignConfig) -> DesignReport {
    run_design(ctx, p, cfg, &Silent).expect("design run")
}

/// The optimizer lowers the loss at least 2.5x and raises SSIM on every view of a small problem.
#[test]
fn optimization_lowers_loss_and_raises_ssim() {
    let ctx = gpu();
    let p = small_problem(3, 48, 1500, 11);
    let out = tmp_dir("lower");
    let mut cfg = quiet_config(out.clone(), 40);
    cfg.prune.tol = 0.01;
    cfg.prune.max_trials = 3;
    let r = run(&ctx, &p, &cfg);
    let first = r.history.first().unwrap().total;
    let last = r.history.last().unwrap().total;
    eprintln!(
        "loss {first} -> {last} (final design {}), {} rollbacks",
        r.final_loss.total,
        r.rollbacks.len()
    );
    assert!(last * 2.5 <= first, "loss only went from {first} to {last}");
    assert!(r.history.iter().all(|h| h.total.is_finite()));
    for v in 0..3 {
        let s0 = scratchart_design::measure::view_ssim(&p.scene, v, &r.initial_images[v], &p.targets[v], 1.0);
        let s1 = scratchart_design::measure::view_ssim(&p.scene, v, &r.final_images[v], &p.targets[v], 1.0);
        eprintln!("view {v}: SSIM {s0:.3} -> {s1:.3}");
        assert!(s1 >= s0 + 0.05, "view {v}: SSIM {s0:.3} -> {s1:.3}");
    }
    let pr = r.prune.as_ref().unwrap();
    assert!(
        pr.loss_after as f64 <= pr.loss_before as f64 * 1.0100001,
        "pruning exceeded its tolerance: {pr:?}"
    );
    // The written design loads back and is the returned one.
    let loaded = Scene::load(&out.join("design.json")).unwrap();
    assert_eq!(loaded, r.scene);
    for f in [
        "scratches.csv",
        "loss_curve.png",
        "summary.json",
        "v0_compare.png",
        "v2_compare.png",
        "v0_target.png",
        "v2_target.png",
        "checkpoint.bin",
    ] {
        assert!(out.join(f).is_file(), "missing output {f}");
    }
    // The target PNG (what the viewer shows beside the render) holds the target image.
    let (tw, th, t0) = scratchart_render::io::read_image_gray(&out.join("v0_target.png")).unwrap();
    assert_eq!(
        (tw, th),
        (p.scene.views[0].camera.width, p.scene.views[0].camera.height)
    );
    let worst = t0
        .iter()
        .zip(&p.targets[0])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 0.5 / 255.0 + 1e-6,
        "v0_target.png differs from the target by {worst}"
    );
    let _ = std::fs::remove_dir_all(&out);
    assert_no_validation(&ctx);
}

fn bits(s: &Scene) -> Vec<u64> {
    s.scratches
        .iter()
        .flat_map(|x| x.to_row())
        .chain(s.views.iter().map(|v| v.light.intensity))
        .map(f64::to_bits)
        .collect()
}

/// A run stopped after a checkpoint and resumed equals an uninterrupted run bit for bit; so does a
/// finished run resumed with more iterations.
#[test]
fn resume_is_bit_identical() {
    let ctx = gpu();
    let p = small_problem(2, 32, 600, 21);
    let iters = 12;

    let out_a = tmp_dir("resume-a");
    let mut cfg = quiet_config(out_a.clone(), iters);
    cfg.checkpoint_every = 4;
    let a = run(&ctx, &p, &cfg);

    // Killed at iteration 10 (last checkpoint at 8), then resumed.
    let out_b = tmp_dir("resume-b");
    let mut cfg_b = quiet_config(out_b.clone(), iters);
    cfg_b.checkpoint_every = 4;
    cfg_b.hooks.stop_at = Some(10);
    let err = run_design(&ctx, &p, &cfg_b, &Silent).expect_err("the hook stops the run");
    assert!(err.to_string().contains("stopped"), "{err}");
    cfg_b.hooks.stop_at = None;
    cfg_b.resume = true;
    let b = run(&ctx, &p, &cfg_b);
    assert_eq!(b.resumed_from, Some(8));

    // Finished at 6 iterations, then resumed to 12.
    let out_c = tmp_dir("resume-c");
    let mut cfg_c = quiet_config(out_c.clone(), 6);
    cfg_c.checkpoint_every = 0;
    run(&ctx, &p, &cfg_c);
    cfg_c.iters = iters;
    cfg_c.resume = true;
    let c = run(&ctx, &p, &cfg_c);
    assert_eq!(c.resumed_from, Some(6));

    assert_eq!(a.history.len(), iters as usize + 1);
    for (name, x) in [
        ("stopped at 10, resumed from 8", &b),
        ("finished at 6, resumed to 12", &c),
    ] {
        assert_eq!(x.history, a.history, "{name}: loss history differs");
        assert!(
            bits(&x.scene) == bits(&a.scene),
            "{name}: the design differs from the uninterrupted run"
        );
        assert_eq!(
            x.final_loss.total.to_bits(),
            a.final_loss.total.to_bits(),
            "{name}: final loss differs"
        );
    }
    // Resuming with other settings is refused with a clear message.
    let mut cfg_d = quiet_config(out_a.clone(), iters);
    cfg_d.resume = true;
    cfg_d.loss.lambda_g = 0.5;
    let err = run_design(&ctx, &p, &cfg_d, &Silent).expect_err("mismatched resume must fail");
    assert!(
        err.to_string().contains("different settings") && err.to_string().contains("loss"),
        "{err}"
    );
    for d in [out_a, out_b, out_c] {
        let _ = std::fs::remove_dir_all(d);
    }
    assert_no_validation(&ctx);
}

/// A NaN gradient and a NaN image (so a NaN loss) are caught, rolled back (learning rates halved)
/// and never reach the design.
#[test]
fn injected_nans_are_rolled_back() {
    let ctx = gpu();
    let p = small_problem(2, 32, 600, 5);
    let out = tmp_dir("nan");
    let mut cfg = quiet_config(out.clone(), 10);
    cfg.hooks = Hooks {
        nan_grad_at: Some(3),
        nan_image_at: Some(6),
        stop_at: None,
    };
    let r = run(&ctx, &p, &cfg);
    assert_eq!(r.rollbacks.len(), 2, "{:?}", r.rollbacks);
    assert!(
        r.rollbacks[0].reason.contains("non-finite gradient at iteration 3"),
        "{:?}",
        r.rollbacks[0]
    );
    assert!(
        r.rollbacks[1].reason.contains("non-finite loss"),
        "{:?}",
        r.rollbacks[1]
    );
    assert_eq!(r.rollbacks[1].lr_scale, 0.25);
    assert_eq!(r.history.len(), 11);
    assert!(r.history.iter().all(|h| h.total.is_finite()));
    assert!(r.final_loss.total.is_finite());
    r.scene.validate().expect("the design is valid");
    assert!(r.history.last().unwrap().total < r.history[0].total);
    let _ = std::fs::remove_dir_all(&out);
    assert_no_validation(&ctx);
}

/// Missing files, unreadable images and a wrong count give errors that name the file or the counts.
#[test]
fn bad_targets_give_clear_errors() {
    let p = small_problem(3, 16, 10, 1);
    let dir = tmp_dir("targets");
    let good = dir.join("good.png");
    scratchart_render::io::write_png_gray(&good, 4, 3, &[0, 50, 100, 150, 200, 250, 0, 50, 100, 150, 200, 250])
        .unwrap();
    let garbage = dir.join("garbage.png");
    std::fs::write(&garbage, b"this is not an image").unwrap();
    let missing = dir.join("missing.png");

    let e = load_targets(&[good.clone(), missing.clone(), good.clone()], &p.scene).unwrap_err();
    assert!(e.to_string().contains("missing.png"), "{e}");
    let e = load_targets(&[good.clone(), good.clone(), garbage.clone()], &p.scene).unwrap_err();
    assert!(e.to_string().contains("garbage.png"), "{e}");
    let e = load_targets(&[good.clone(), good.clone()], &p.scene).unwrap_err();
    assert!(matches!(e, TargetError::Count { given: 2, views: 3, .. }), "{e}");
    assert!(e.to_string().contains("2 target image(s) given for 3 view(s)"), "{e}");
    // A good set is resized to the view resolution, values in [0, 1].
    let t = load_targets(&[good.clone(), good.clone(), good], &p.scene).unwrap();
    assert!(t
        .iter()
        .all(|img| img.len() == 16 * 16 && img.iter().all(|v| (0.0..=1.0).contains(v))));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Views that share a lamp share its intensity (`--exposure fixed`): the tie kernel gives every
/// view of a lamp one log-space step, so the ratios of their lights (their exposures) stay as
/// they started (here 1, 0.5 and 0.25) while the lamp's intensity moves; without the tie the
/// same run moves each view's light on its own. The saved design has one intensity per lamp
/// either way: the exposures kept, or derived (the brightest view 1).
#[test]
fn a_shared_lamp_has_one_intensity() {
    use scratchart_design::design::Optimizer;
    let ctx = gpu();
    let renderer = Renderer::new(&ctx).unwrap();
    let mut p = small_problem(3, 24, 300, 5);
    for (v, e) in p.scene.views.iter_mut().zip([1.0, 0.5, 0.25]) {
        v.exposure = e;
    }
    let slots = scratchart_render::layout::view_slots(&p.scene);
    let mut ratios = Vec::new();
    for keep in [true, false] {
        let mut cfg = quiet_config(tmp_dir(&format!("tie-{keep}")), 12);
        cfg.write_outputs = false;
        cfg.keep_exposures = keep;
        let loss = Loss::new(&ctx, &slots.views, &p.targets, cfg.loss).unwrap();
        let mut opt = Optimizer::new(&renderer, &loss, &p, &cfg).unwrap();
        opt.calibrate_lights(&p.scene, &p.targets).unwrap();
        let phi0: Vec<f32> = opt.driver.gs.lights().read().unwrap();
        opt.run(&Silent).unwrap();
        let phi: Vec<f32> = opt.driver.gs.lights().read().unwrap();
        let moved = (phi[0] / phi0[0] - 1.0).abs();
        assert!(
            moved > 1e-3,
            "keep {keep}: the lamp did not move ({} -> {})",
            phi0[0],
            phi[0]
        );
        let r = [phi[1] / phi[0], phi[2] / phi[0]];
        eprintln!("keep {keep}: phi {phi0:?} -> {phi:?}, ratios {r:?}");
        if keep {
            assert!(
                (phi0[1] / phi0[0] - 0.5).abs() < 1e-6,
                "calibration keeps the ratios: {phi0:?}"
            );
            assert!((r[0] - 0.5).abs() < 1e-4 && (r[1] - 0.25).abs() < 1e-4, "tied: {r:?}");
        }
        let scene = opt.scene(&p.scene).unwrap();
        let i = scene.views[0].light.intensity;
        assert!(
            scene.views.iter().all(|v| v.light.intensity == i),
            "one intensity per lamp"
        );
        for (v, &ph) in scene.views.iter().zip(&phi) {
            assert!(
                (v.radiance_scale() / ph as f64 - 1.0).abs() < 1e-6,
                "{}: renders as optimized",
                v.name
            );
        }
        if keep {
            let e: Vec<f64> = scene.views.iter().map(|v| v.exposure).collect();
            assert_eq!(e, vec![1.0, 0.5, 0.25]);
        } else {
            assert!(
                scene.views.iter().any(|v| v.exposure == 1.0),
                "the brightest view has exposure 1"
            );
        }
        ratios.push(r);
    }
    // Untied, the views' lights move apart from the ratios they started with.
    let free = ratios[1];
    assert!(
        (free[0] - 0.5).abs() > 1e-3 || (free[1] - 0.25).abs() > 1e-3,
        "free: {free:?}"
    );
    assert_no_validation(&ctx);
}
