//! Fabrication mode (`design --tool`, engine/docs/model.md section 7): one commanded carve depth per scratch
//! through a calibrated tool's curve, alpha fixed. Every written groove must be the tool's cut at
//! its written depth (to the table's measured interpolation error), the depth gradient must be
//! the derivative of the GPU loss, resume must be bit-exact, and bad tool files exit with 3.
use std::path::PathBuf;

use scratchart_design::design::run_design;
use scratchart_design::problem::{DesignConfig, DesignReport, Problem};
use scratchart_design::scenes::{orbit_light, random_scratches, ring_views, Rng};
use scratchart_design::targets::builtin_targets;
use scratchart_model::scene::{Scene, Scratch};
use scratchart_observe::Silent;
use scratchart_optim::adam::AdamConfig;
use scratchart_optim::check::CheckObjective;
use scratchart_optim::tool_params::{Fabrication, ToolParams};
use scratchart_render::Renderer;
use scratchart_tests::*;
use scratchart_tool::{Fitted, Tool};

/// Allowance for the GPU's f32 evaluation of the interpolation (rounding of z, of s =
/// sqrt(z - z_first) and of the table), on top of the table's own measured error.
const F32_SLACK: f64 = 1e-5;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-fab-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn v_bit() -> Tool {
    Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.02,
        z_offset_mm: 0.0,
    }
}

fn ball() -> Tool {
    Tool::Ball {
        radius_mm: 0.1,
        z_offset_mm: -0.005,
    }
}

/// Two ring views of `res` px, `n` random scratches (w = d = 0.05 mm), the built-in targets.
fn small_problem(res: u32, n: usize, seed: u64) -> Problem {
    let light = orbit_light(300.0, 45.0, 0.0, 1.0e4);
    let mut rng = Rng::new(seed);
    let scene = Scene {
        plate: plate(100.0),
        views: ring_views(2, 45.0, 300.0, 100.0, res, &light),
        scratches: random_scratches(&mut rng, n, 100.0, 2.0, 8.0, 0.05, 0.05, 0.06),
    };
    let targets = builtin_targets(&scene);
    Problem::new(scene, targets)
}

fn config(out: PathBuf, iters: u32, fab: &Fabrication) -> DesignConfig {
    let mut cfg = DesignConfig::new(100.0, out);
    cfg.iters = iters;
    cfg.prune.tol = 0.0;
    cfg.tool = Some(fab.clone());
    cfg
}

/// Worst relative differences of (w, d) between the written grooves and the tool's cut at the
/// written depths, asserting each within the table's bound plus the f32 allowance.
fn assert_on_curve(label: &str, tool: &Tool, fab_bound: [f64; 2], scratches: &[Scratch], z: &[f64]) -> [f64; 2] {
    assert_eq!(scratches.len(), z.len(), "{label}: one depth per scratch");
    let mut worst = [0.0f64; 2];
    for (k, (s, &z)) in scratches.iter().zip(z).enumerate() {
        let g = tool
            .model(z)
            .unwrap_or_else(|| panic!("{label}: scratch {k}: the tool does not cut at z = {z}"));
        for (c, (got, want)) in [(s.w, g.w), (s.d, g.d)].into_iter().enumerate() {
            let rel = (got - want).abs() / want;
            worst[c] = worst[c].max(rel);
            assert!(
                rel <= fab_bound[c] + F32_SLACK,
                "{label}: scratch {k} at z = {z}: {} = {got} but the tool cuts {want} (relative {rel:.2e}, bound {:.2e} + {F32_SLACK:.0e})",
                ["w", "d"][c],
                fab_bound[c]
            );
        }
    }
    worst
}

fn bits(r: &DesignReport) -> Vec<u64> {
    let s = &r.scene;
    s.scratches
        .iter()
        .flat_map(|x| x.to_row())
        .chain(s.views.iter().map(|v| v.light.intensity))
        .chain(r.depths.iter().flatten().copied())
        .map(f64::to_bits)
        .collect()
}

/// A V-bit design through the library: the loss goes down, every written groove is the tool's
/// cut at its written depth with the tool file's alpha, the CSV carries z_mm, the summary names
/// the tool and the depth range; a run stopped after a checkpoint and resumed is bit-identical.
#[test]
fn v_bit_design_stays_on_the_tool_curve_and_resumes_bit_exactly() {
    let t0 = std::time::Instant::now();
    let ctx = gpu();
    let p = small_problem(48, 300, 5);
    let dir = tmp_dir("vbit");
    let tool_file = dir.join("tool.json");
    let fitted = Fitted {
        alpha: Some(0.1),
        fit: None,
    };
    std::fs::write(&tool_file, v_bit().to_json_fitted(&fitted)).unwrap();
    let adam = AdamConfig::for_plate(100.0);
    let fab = Fabrication::load(&tool_file, 0.06, "--init-alpha", adam.lr_d, &adam).unwrap();
    assert_eq!(fab.alpha, 0.1, "alpha comes from the tool file");
    let tb = fab.table.max_rel_err;
    eprintln!(
        "V-bit table: z in [{:.5}, {:.5}] mm, first contact {:.2e}, max relative error w {:.2e} d {:.2e}",
        fab.table.z_lo, fab.table.z_hi, fab.table.z_first, tb[0], tb[1]
    );
    assert!(tb[0] < 1e-3 && tb[1] < 1e-3, "table error {tb:?}");

    let iters = 8;
    let out_a = dir.join("a");
    let mut cfg = config(out_a.clone(), iters, &fab);
    cfg.checkpoint_every = 3;
    cfg.prune.tol = 0.01;
    cfg.prune.max_trials = 2;
    let a = run_design(&ctx, &p, &cfg, &Silent).expect("design --tool");
    let (first, last) = (a.history[0].total, a.history.last().unwrap().total);
    eprintln!(
        "loss {first} -> {last}, {} of {} scratches kept",
        a.scene.scratches.len(),
        a.unpruned.scratches.len()
    );
    assert!(last < 0.9 * first, "the loss must go down: {first} -> {last}");
    let z = a.depths.clone().expect("fabrication mode reports the depths");
    let worst = assert_on_curve("V-bit design", &v_bit(), tb, &a.scene.scratches, &z);
    eprintln!(
        "written grooves vs Tool::model: worst relative w {:.2e} d {:.2e}",
        worst[0], worst[1]
    );
    let (lo, hi) = (fab.table.z_lo as f32 as f64, fab.table.z_hi as f32 as f64);
    assert!(z.iter().all(|&z| z >= lo && z <= hi), "a depth left [{lo}, {hi}]");
    assert!(
        z.iter().any(|&x| x != z[0]),
        "the depths were not optimized (all equal)"
    );
    assert!(
        a.scene.scratches.iter().all(|s| s.alpha == 0.1f32 as f64),
        "alpha is fixed"
    );

    // The written files: the CSV's z_mm column and the summary.
    let (written, extra) = Scene::load_extra(&out_a.join("design.json")).unwrap();
    assert_eq!(written.scratches, a.scene.scratches);
    assert_eq!(extra.names, vec!["z_mm".to_string()]);
    assert_eq!(extra.column("z_mm").unwrap(), z);
    let header = std::fs::read_to_string(out_a.join("scratches.csv")).unwrap();
    assert!(header.starts_with("x0,y0,x1,y1,w,d,alpha,z_mm"), "{}", &header[..60]);
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_a.join("summary.json")).unwrap()).unwrap();
    let f = &s["fabrication"];
    assert_eq!(f["tool_file"].as_str(), Some(tool_file.to_str().unwrap()));
    assert_eq!(f["tool"]["kind"].as_str(), Some("v-bit"));
    assert_eq!(f["z_range_mm"][0].as_f64(), Some(fab.table.z_lo));
    assert!(f["alpha_from"].as_str().unwrap().contains("tool.json"), "{f}");

    // Stopped at iteration 7 (last checkpoint at 6), resumed: the same design, bit for bit.
    let out_b = dir.join("b");
    let mut cfg_b = config(out_b.clone(), iters, &fab);
    cfg_b.checkpoint_every = 3;
    cfg_b.prune = cfg.prune;
    cfg_b.hooks.stop_at = Some(7);
    let err = run_design(&ctx, &p, &cfg_b, &Silent).expect_err("the hook stops the run");
    assert!(err.to_string().contains("stopped"), "{err}");
    cfg_b.hooks.stop_at = None;
    cfg_b.resume = true;
    let b = run_design(&ctx, &p, &cfg_b, &Silent).expect("resumed design --tool");
    assert_eq!(b.resumed_from, Some(6));
    assert_eq!(b.history, a.history, "resumed loss history differs");
    assert!(bits(&b) == bits(&a), "the resumed design differs");
    assert_no_validation(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("{:.1} s", t0.elapsed().as_secs_f64());
}

/// dE/dz from the GPU chain rule (tool_map.comp's second mode after the renderer's backward)
/// against central differences of the GPU check loss E_lin over the whole chain (map, render,
/// loss), per scratch; the bar of the gradient tests (relative error of the vector <= 1e-2).
/// Depths sit at segment midpoints and steps stay inside the segment, so the differences see
/// one linear piece of the map.
#[test]
fn depth_gradient_matches_central_differences() {
    let t0 = std::time::Instant::now();
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let views = vec![
        orbit_view("a", 48, 50.0, 0.0, 50.0, 180.0, 100.0),
        orbit_view("b", 48, 40.0, 120.0, 55.0, 300.0, 100.0),
    ];
    let scene = random_scene(17, 24, 100.0, 0.05, 0.05, 0.1, views);
    let adam = AdamConfig::for_plate(100.0);
    let fab = Fabrication::new(v_bit(), "v-bit", 0.1, "test", adam.lr_d, &adam).unwrap();
    let t = &fab.table;
    let n = scene.scratches.len();
    let mut z = Vec::new();
    let mut h = Vec::new();
    for i in 0..n {
        let k = 20 + (i * 37) % 450;
        let (za, zb) = (t.sample_z(k), t.sample_z(k + 1));
        let s = 0.5 * ((za - t.z_first).sqrt() + (zb - t.z_first).sqrt());
        z.push((t.z_first + s * s) as f32);
        h.push(0.1 * (zb - za));
    }
    let tp = ToolParams::with_depths(&ctx, &adam, &fab, &z).unwrap();
    // Targets: the render of the scene with moved endpoints and shallower cuts (linear values).
    let mut moved = scene.clone();
    for (k, s) in moved.scratches.iter_mut().enumerate() {
        let [w, d] = t.eval(0.8 * z[k] as f64);
        s.p0[0] += 0.3;
        s.p1[1] -= 0.2;
        (s.w, s.d) = (w, d);
    }
    let targets = gpu_render(&ctx, &moved);
    let obj = CheckObjective::new(&ctx, &scene, &targets).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let (ev, g) = tp.evaluate(&r, &mut gs, &obj, true).unwrap();
    let g = g.unwrap();
    let e = |zz: &[f32], gs: &mut _| -> f64 {
        tp.set_depths(&ctx, zz).unwrap();
        tp.evaluate(&r, gs, &obj, false).unwrap().0.total as f64
    };
    let (mut num, mut den) = (0.0, 0.0);
    let mut shown = Vec::new();
    for i in 0..n {
        let mut zz = z.clone();
        zz[i] = (z[i] as f64 + h[i]) as f32;
        let step_p = zz[i] as f64 - z[i] as f64;
        let ep = e(&zz, &mut gs);
        zz[i] = (z[i] as f64 - h[i]) as f32;
        let step_m = z[i] as f64 - zz[i] as f64;
        let em = e(&zz, &mut gs);
        let fd = (ep - em) / (step_p + step_m);
        num += (g[i] as f64 - fd).powi(2);
        den += fd * fd;
        if shown.len() < 6 && fd != 0.0 {
            shown.push((g[i], fd));
        }
    }
    let err = (num / den).sqrt();
    eprintln!(
        "E_lin {:.6e}: dE/dz relative error {err:.3e} over {n} scratches (|g| = {:.3e}); (gpu, fd): {shown:?}; {:.1} s",
        ev.total,
        den.sqrt(),
        t0.elapsed().as_secs_f64()
    );
    assert!(den > 0.0, "no scratch is visible: the test scene is wrong");
    assert!(err <= 1e-2, "dE/dz off by {err:.3e} (> 1e-2)");
    assert_no_validation(&ctx);
}

/// The table of every tool kind against `Tool::model` (its own measurement at segment midpoints,
/// and an independent one at other points: thirds of every 7th segment), its slopes against
/// differences of the interpolation, and the nearest-depth search of the initial depths.
#[test]
fn table_error_of_every_tool_kind() {
    let adam = AdamConfig::for_plate(100.0);
    let tools = [
        v_bit(),
        Tool::VBit {
            angle_deg: 90.0,
            tip_flat_mm: 0.0,
            z_offset_mm: -0.01,
        },
        ball(),
        Tool::TaperedBall {
            radius_mm: 0.03,
            angle_deg: 30.0,
            z_offset_mm: 0.0,
        },
        Tool::Profile {
            points: vec![[0.01, 0.03], [0.03, 0.08], [0.06, 0.12]],
            w_over_w: 1.3,
            z_offset_mm: 0.0,
        },
    ];
    for tool in tools {
        let fab = Fabrication::new(tool.clone(), "t", 0.1, "test", 1e-3, &adam).unwrap();
        let t = &fab.table;
        let mut worst = [0.0f64; 2];
        for k in (0..t.samples.len() - 1).step_by(7) {
            let (za, zb) = (t.sample_z(k), t.sample_z(k + 1));
            let z = za + (zb - za) / 3.0;
            let (g, e) = (tool.model(z).unwrap(), t.eval(z));
            worst[0] = worst[0].max((e[0] - g.w).abs() / g.w);
            worst[1] = worst[1].max((e[1] - g.d).abs() / g.d);
            let h = 1e-3 * (zb - za);
            let (sp, fd) = (
                t.slope(z),
                [
                    (t.eval(z + h)[0] - t.eval(z - h)[0]) / (2.0 * h),
                    (t.eval(z + h)[1] - t.eval(z - h)[1]) / (2.0 * h),
                ],
            );
            // The initial depths: a groove on the curve maps back to its own depth.
            let [w, d] = t.eval(z);
            let back = t.nearest_depth(w, d);
            assert!(
                (back - z).abs() <= (zb - za) / 32.0,
                "{tool:?}: ({w}, {d}) of z = {z} maps to {back}"
            );
            for c in 0..2 {
                assert!(
                    (sp[c] - fd[c]).abs() <= 1e-6 * fd[c].abs().max(1e-9),
                    "{tool:?} z {z}: slope {sp:?} vs {fd:?}"
                );
            }
        }
        eprintln!(
            "{tool:?}: z in [{:.5}, {:.5}] mm; measured table error w {:.2e} d {:.2e}, at thirds w {:.2e} d {:.2e}",
            t.z_lo, t.z_hi, t.max_rel_err[0], t.max_rel_err[1], worst[0], worst[1]
        );
        for c in 0..2 {
            assert!(t.max_rel_err[c] < 1e-3, "{tool:?}: table error {:?}", t.max_rel_err);
            assert!(
                worst[c] <= t.max_rel_err[c] * 1.01 + 1e-9,
                "{tool:?}: {worst:?} beyond the stated {:?}",
                t.max_rel_err
            );
        }
    }
}

/// `scratchart design --tool` with a ball tool (no alpha in the file: --init-alpha is used): the
/// CSV has z_mm and every groove is the ball's cut there; the summary names the tool. A
/// malformed or unusable tool file exits with 3 and names the file.
#[test]
fn ball_tool_through_the_binary_and_bad_tool_files() {
    let t0 = std::time::Instant::now();
    let dir = tmp_dir("bin");
    let tool = write_file(&dir, "ball.json", &ball().to_json());
    let out = dir.join("out");
    let o = run_scratchart(&tool_design_args(&tool, out.to_str().unwrap()));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "stderr:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        stdout.contains("fabrication: tool") && stdout.contains("ball.json") && stdout.contains("z_mm"),
        "{stdout}"
    );
    let (scene, extra) = Scene::load_extra(&out.join("design.json")).unwrap();
    let z = extra.column("z_mm").expect("the z_mm column");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let f = &s["fabrication"];
    assert_eq!(f["tool"]["kind"].as_str(), Some("ball"));
    assert!(f["alpha_from"].as_str().unwrap().contains("--init-alpha"), "{f}");
    let bound = [
        f["table_max_rel_err_w"].as_f64().unwrap(),
        f["table_max_rel_err_d"].as_f64().unwrap(),
    ];
    eprintln!("ball table error {bound:?}, depths {:?}", f["z_written_mm"]);
    let worst = assert_on_curve("ball design", &ball(), bound, &scene.scratches, &z);
    eprintln!(
        "written grooves vs Tool::model: worst relative w {:.2e} d {:.2e}",
        worst[0], worst[1]
    );
    assert!(scene.scratches.iter().all(|s| s.alpha == 0.06f32 as f64));
    let (lo, hi) = (
        f["z_range_mm"][0].as_f64().unwrap(),
        f["z_range_mm"][1].as_f64().unwrap(),
    );
    assert!(
        lo > 0.005 && hi > lo,
        "the ball reaches the plate at z = 0.005: range [{lo}, {hi}]"
    );

    // Bad tool files: exit 3, the file named.
    for (name, text, needle) in [
        ("broken.json", r#"{ "kind": "ball", "radius_mm": }"#, "broken.json"),
        (
            "typo.json",
            r#"{ "kind": "ball", "radius": 0.1, "z_offset_mm": 0 }"#,
            "radius",
        ),
        (
            "wide.json",
            r#"{ "kind": "v-bit", "angle_deg": 60, "tip_flat_mm": 0.5, "z_offset_mm": 0 }"#,
            "wide.json",
        ),
    ] {
        let p = write_file(&dir, name, text);
        let o = run_scratchart(&tool_design_args(&p, dir.join("bad").to_str().unwrap()));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "{name}: stderr:\n{err}");
        assert!(err.contains(name) && err.contains(needle), "{name}: {err}");
        assert!(!dir.join("bad").join("design.json").exists());
    }
    let o = run_scratchart(&tool_design_args(
        "/nonexistent/tool.json",
        dir.join("bad").to_str().unwrap(),
    ));
    assert_eq!(o.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/tool.json"));
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("{:.1} s", t0.elapsed().as_secs_f64());
}

/// `design --robust` (issue 27 item 3) at the level of the parameter set: an iteration that
/// steps maps a perturbed carving (endpoints moved by about sigma_xy, grooves of perturbed
/// depths), the chain rule puts the exact endpoints back bit for bit, and an iteration that only
/// evaluates (or a set without --robust) maps the exact design.
#[test]
fn a_robust_step_sees_a_perturbed_carving_and_keeps_the_exact_design() {
    use scratchart_optim::driver::ParamSet;
    use scratchart_optim::tool_params::Robust;
    use scratchart_render::layout::ScratchGpu;
    use scratchart_vulkan::Recorder;
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let p = small_problem(16, 2000, 9);
    let adam = AdamConfig::for_plate(100.0);
    let fab = Fabrication::new(v_bit(), "v-bit", 0.1, "test", adam.lr_d, &adam).unwrap();
    let (sz, sxy) = (0.015, 0.01);
    let robust = Robust {
        sigma_z_mm: sz,
        sigma_xy_mm: sxy,
        seed: 3,
    };
    let gs = r.upload(&p.scene).unwrap();
    // Depths in mid-range, where the groove widens with depth both ways of them.
    let z0 = vec![0.08f32; p.scene.scratches.len()];
    let params = ToolParams::with_depths(&ctx, &adam, &fab, &z0)
        .unwrap()
        .with_robust(&ctx, robust)
        .unwrap();
    let read = || -> Vec<ScratchGpu> { ctx.download(gs.scratches()).unwrap() };
    let run = |f: &dyn Fn(&mut Recorder)| {
        let mut rec = Recorder::new(&ctx).unwrap();
        rec.begin().unwrap();
        f(&mut rec);
        rec.submit_and_wait().unwrap();
    };
    params.begin_iteration(0, false);
    run(&|rec| params.record_to_scene(rec, &gs));
    let exact = read();
    let exact_depths = params.depths(&ctx).unwrap();
    let carved = |k: u32| {
        params.begin_iteration(k, true);
        run(&|rec| params.record_to_scene(rec, &gs));
        let c = read();
        run(&|rec| params.record_grad(rec, &gs));
        let back = read();
        (c, back)
    };
    let (c5, back) = carved(5);
    // Endpoints: moved by N(0, sigma_xy) per coordinate.
    let moves: Vec<f64> = c5
        .iter()
        .zip(&exact)
        .flat_map(|(a, b)| (0..4).map(move |i| a.ends[i] as f64 - b.ends[i] as f64))
        .collect();
    let n = moves.len() as f64;
    let mean = moves.iter().sum::<f64>() / n;
    let std = (moves.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / n).sqrt();
    eprintln!("endpoint moves: mean {mean:.2e} mm, std {std:.4e} mm (sigma {sxy})");
    assert!(mean.abs() < 4.0 * sxy / n.sqrt(), "mean move {mean}");
    assert!((std / sxy - 1.0).abs() < 0.05, "std of the moves {std}, sigma {sxy}");
    // Grooves: those of perturbed depths (the width changes with the depth, both ways).
    let (wider, narrower) = c5.iter().zip(&exact).fold((0, 0), |(a, b), (c, e)| {
        (
            a + usize::from(c.shape[0] > e.shape[0]),
            b + usize::from(c.shape[0] < e.shape[0]),
        )
    });
    assert!(
        wider > 900 && narrower > 900,
        "{wider} wider, {narrower} narrower of 2000"
    );
    assert!(
        c5.iter().all(|s| s.shape[0] > 0.0 && s.shape[1] > 0.0),
        "a carved groove with w or d <= 0"
    );
    // The chain rule puts the exact endpoints back, bit for bit, and the depths never move.
    for (a, b) in back.iter().zip(&exact) {
        assert_eq!(a.ends.map(f32::to_bits), b.ends.map(f32::to_bits));
    }
    assert_eq!(params.depths(&ctx).unwrap(), exact_depths);
    // Another iteration, another carving; the same iteration (a redo, a resume), the same one.
    let (c6, _) = carved(6);
    assert!(c6.iter().zip(&c5).filter(|(a, b)| a.ends != b.ends).count() > 1900);
    let (c5b, _) = carved(5);
    assert!(c5b
        .iter()
        .zip(&c5)
        .all(|(a, b)| a.ends.map(f32::to_bits) == b.ends.map(f32::to_bits)
            && a.shape.map(f32::to_bits) == b.shape.map(f32::to_bits)));
    // The evaluation-only iteration maps the exact design.
    params.begin_iteration(7, false);
    run(&|rec| params.record_to_scene(rec, &gs));
    let e = read();
    assert!(e
        .iter()
        .zip(&exact)
        .all(|(a, b)| a.ends.map(f32::to_bits) == b.ends.map(f32::to_bits)
            && a.shape.map(f32::to_bits) == b.shape.map(f32::to_bits)));
    assert_no_validation(&ctx);
}
