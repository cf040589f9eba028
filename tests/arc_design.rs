//! Designs whose scratches bend (`design --arcs`, engine/docs/model.md section 11): every
//! scratch uploaded as a fixed number of chords that follow its bulge on the device
//! (`Renderer::upload_bendable`), so a straight scratch can start to bend; the gradient of its
//! bulge at 0 against central differences of the float64 reference's exact arcs; and the design
//! job end to end: the bulges move, and the written design holds legal arcs that load again.
use scratchart_model::scene::Scene;
use scratchart_tests::*;

/// dE/dbulge of straight scratches (bulge 0, each laid out as n chords) and the rest of their
/// gradients, against central differences of the reference (whose bulge +-h is an exact arc):
/// within the bar at 64 chords; at a design's 8 the chords' own shape is measured (the bulge's
/// error falls about as 1/n: 4.4e-2 at 8, 1.3e-2 at 32 chords).
#[test]
fn straight_scratches_laid_out_to_bend_have_bulge_gradients() {
    let views = vec![
        orbit_view("a", 24, 45.0, 0.0, 45.0, 180.0, 20.0),
        orbit_view("b", 24, 60.0, 120.0, 40.0, 300.0, 20.0),
    ];
    let scene = random_scene(21, 12, 20.0, 0.4, 0.3, 0.2, views);
    assert!(scene.scratches.iter().all(|s| !s.is_arc()));
    // Targets: the reference render of the scene bent a little, either way.
    let mut moved = scene.clone();
    for (k, s) in moved.scratches.iter_mut().enumerate() {
        s.bulge = if k % 2 == 0 { 0.15 } else { -0.1 };
        s.bulge = scratchart_model::scene_file::legal_bulge(s, scene.plate.size_mm);
    }
    assert!(moved.scratches.iter().filter(|s| s.is_arc()).count() >= 8);
    let t: Vec<Vec<f64>> = (0..2)
        .map(|v| scratchart_model::reference::render_view(&moved, v))
        .collect();
    let ctx = gpu();
    let r = scratchart_render::Renderer::new(&ctx).unwrap();
    for (nch, weighted, bar) in [(64u32, true, 1e-2), (8, true, 0.1), (64, false, 0.1)] {
        let mut gs = r.upload_bendable(&scene, nch, weighted).unwrap();
        assert!(gs.has_arcs());
        assert_eq!(gs.n_scratches(), nch * 12);
        assert_eq!(gs.n_scene_scratches(), 12);
        // Rendered as 8 collinear chords each, the scene is the straight one.
        let first = r.render(&mut gs).unwrap().images;
        let mut plain = r.upload(&scene).unwrap();
        let straight = r.render(&mut plain).unwrap().images;
        for (a, b) in first.iter().zip(&straight) {
            let worst = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
            let top = b.iter().fold(1e-6f32, |m, x| m.max(*x));
            assert!(
                worst <= 1e-3 * top,
                "chords of a straight scratch render it: off by {worst} of {top}"
            );
        }
        let (_, g) = r.gradients(&mut gs, &dl_of(&scene, &first, &t)).unwrap();
        let chords: Vec<[f32; 8]> = ctx.download(gs.scratch_grad()).unwrap();
        let (_, host_bulges) = gs.arc_chain_on_host(&chords[..gs.n_scratches() as usize]).unwrap();
        let e = |s: &Scene| scratchart_model::reference::check_loss(s, &t);
        let (mut gpu_b, mut ref_b, mut gpu_e, mut ref_e) = (vec![], vec![], vec![], vec![]);
        for k in 0..scene.scratches.len() {
            let at = |p: usize, delta: f64| {
                let mut sc = scene.clone();
                let x = &mut sc.scratches[k];
                match p {
                    0 => x.p0[0] += delta,
                    1 => x.p1[1] += delta,
                    _ => x.bulge += delta,
                }
                e(&sc)
            };
            let h = 1e-5;
            let (gb, hb) = (g.bulges[k], host_bulges[k]);
            assert!(
                gb.is_finite() && (gb - hb).abs() <= 1e-3 * hb.abs().max(1e-6),
                "scratch {k}: device {gb} host {hb}"
            );
            gpu_b.push(gb as f64);
            ref_b.push((at(2, h) - at(2, -h)) / (2.0 * h));
            for (p, q) in [(0, 0), (1, 3)] {
                gpu_e.push(g.scratches[k][q] as f64);
                ref_e.push((at(p, h) - at(p, -h)) / (2.0 * h));
            }
        }
        for (name, a, b) in [("bulge", &gpu_b, &ref_b), ("endpoints", &gpu_e, &ref_e)] {
            let err = rel(a, b);
            let norm: f64 = b.iter().map(|x| x * x).sum::<f64>().sqrt();
            eprintln!("bendable, {nch} chords, weighted {weighted}: {name}: relative gradient error {err:.3e} (|g_ref| = {norm:.3e})");
            assert!(norm > 0.0, "zero reference gradient for {name}");
            assert!(
                err <= bar,
                "{nch} chords: {name} gradient off by {err:.3e}: gpu {a:?} vs reference {b:?}"
            );
        }
    }
    assert_no_validation(&ctx);
}

/// `design --arcs` from straight scratches: the bulges move, the design written holds legal arcs
/// (on the plate, radii at least the groove's width) that load again, with the `bulge` column,
/// and the flags' mistakes are refused with exit 2.
#[test]
fn a_design_with_arcs_bends_its_scratches() {
    let dir = std::env::temp_dir().join(format!("scratchart_arc_design_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("d");
    let out_s = out.to_str().unwrap();
    let args = [
        "design",
        "--arcs",
        "--views",
        "2",
        "--scratches",
        "400",
        "--iters",
        "30",
        "--res",
        "48",
        "--out",
        out_s,
    ];
    let o = run_scratchart(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(
        printed.contains("of 400 scratches bent") && printed.contains("judged at 32"),
        "{printed}"
    );
    let scene = Scene::load(&out.join("design.json")).unwrap();
    assert_eq!(scene.scratches.len(), 400, "a design with arcs is not pruned");
    let bent = scene.scratches.iter().filter(|s| s.bulge.abs() > 1e-3).count();
    assert!(bent >= 100, "only {bent} of 400 scratches bent");
    assert!(scene.scratches.iter().all(|s| s.bulge.abs() <= 0.5 + 1e-6));
    let csv = std::fs::read_to_string(out.join("scratches.csv")).unwrap();
    assert!(csv.lines().next().unwrap().contains("bulge"), "{}", &csv[..200]);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(
        summary["arcs"]["bent"].as_u64().unwrap() as usize == bent,
        "{}",
        summary["arcs"]
    );
    assert_eq!(summary["arcs"]["judged_chords_per_arc"], 32, "{}", summary["arcs"]);
    // `render` of the design shows its arcs as the design judged them.
    let o = run_scratchart(&[
        "render",
        out.join("design.json").to_str().unwrap(),
        "--out",
        dir.join("r").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && err.contains("arcs rendered as 32 chords each"),
        "{err}"
    );
    for (flags, says) in [
        (vec!["--arcs", "--arc-chords", "0"], "--arc-chords"),
        (vec!["--arcs", "--max-bulge", "3"], "--max-bulge"),
    ] {
        let mut a = vec![
            "design",
            "--views",
            "2",
            "--scratches",
            "50",
            "--iters",
            "2",
            "--res",
            "32",
            "--out",
            out_s,
        ];
        a.extend(flags);
        let o = run_scratchart(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(says), "{err}");
    }
}

/// The whole chain with arcs: `design --arcs --tool --machine grbl` bends scratches and writes
/// each one's commanded depth beside its bulge, and `scratchart-cal plan` carves the bent ones
/// as G2/G3 arcs through their ends (the real firmware carving arcs is tests in
/// engine/machine/tests/grbl_sim.rs).
#[test]
fn a_design_with_arcs_for_a_tool_plans_arcs() {
    let dir = std::env::temp_dir().join(format!("scratchart_arc_tool_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let tool = write_file(&dir, "tool.json", V60_TOOL_JSON);
    let out = dir.join("d");
    let out_s = out.to_str().unwrap();
    let mut args = tool_design_args(&tool, out_s);
    let at = args.iter().position(|a| *a == "--iters").unwrap() + 1;
    args[at] = "25";
    args.extend(["--arcs", "--machine", "grbl"]);
    let o = run_scratchart(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("scratches.csv")).unwrap();
    let head = csv.lines().next().unwrap();
    assert!(head.contains("bulge") && head.contains("z_mm"), "{head}");
    let scene = Scene::load(&out.join("design.json")).unwrap();
    let bent = scene.scratches.iter().filter(|s| s.bulge.abs() > 1e-3).count();
    assert!(bent >= 20, "only {bent} of {} scratches bent", scene.scratches.len());
    let cal = workspace_bin("scratchart-calibration", "scratchart-cal");
    let o = std::process::Command::new(&cal)
        .args([
            "plan",
            out.join("design.json").to_str().unwrap(),
            "--tool",
            &tool,
            "--out",
        ])
        .arg(dir.join("job.nc"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let nc = std::fs::read_to_string(dir.join("job.nc")).unwrap();
    let arcs = nc
        .lines()
        .filter(|l| (l.starts_with("G2 ") || l.starts_with("G3 ")) && l.contains(" I") && l.contains(" J"))
        .count();
    assert!(arcs >= bent.min(20), "{arcs} G2/G3 moves for {bent} bent scratches");
}

/// `Renderer::fits` says what `upload` does, with arcs counted as the renderer lays them out
/// (`set_arc_chords`): the set-up sheet and the walk's probes size their batches of views by it.
#[test]
fn fits_agrees_with_upload() {
    let views: Vec<_> = (0..48)
        .map(|j| orbit_view(&format!("v{j}"), 64, 45.0, 7.5 * j as f64, 45.0, 180.0, 100.0))
        .collect();
    let mut scene = random_scene(5, 3000, 100.0, 0.1, 0.05, 0.05, views);
    for s in &mut scene.scratches {
        s.bulge =
            scratchart_model::scene_file::legal_bulge(&scratchart_model::scene::Scratch { bulge: 0.2, ..*s }, 100.0);
    }
    let ctx = gpu();
    let r = scratchart_render::Renderer::new(&ctx).unwrap();
    let mut seen = [false; 2];
    for n in [1u32, 4, 16, 64] {
        r.set_arc_chords(Some(n));
        let fits = r.fits(&scene);
        let up = r.upload(&scene);
        assert_eq!(
            fits,
            up.is_ok(),
            "{n} chords per arc: fits {fits}, upload {:?}",
            up.err()
        );
        seen[fits as usize] = true;
    }
    assert!(
        seen[0] && seen[1],
        "the scene should fit at 1 chord per arc and not at 64"
    );
    r.set_arc_chords(None);
    assert_eq!(r.arc_chords(), None);
    assert_no_validation(&ctx);
}

/// A design with arcs stopped part way and resumed from its checkpoint writes the same arcs, bit
/// for bit, as the run that was not stopped (the arcs' buffer is the checkpoint's block).
#[test]
fn a_design_with_arcs_resumes_bit_for_bit() {
    let dir = std::env::temp_dir().join(format!("scratchart_arc_resume_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let design = |out: &std::path::Path, extra: &[&str]| {
        let mut a = vec![
            "design",
            "--arcs",
            "--views",
            "2",
            "--scratches",
            "200",
            "--iters",
            "12",
            "--res",
            "32",
            "--checkpoint-every",
            "4",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(extra);
        run_scratchart(&a)
    };
    let whole = dir.join("whole");
    let o = design(&whole, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let part = dir.join("stopped");
    let o = design(&part, &["--inject-stop-at", "6"]);
    assert_ne!(o.status.code(), Some(0), "the hook stops the run");
    let o = design(&part, &["--resume"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = |d: &std::path::Path| std::fs::read_to_string(d.join("scratches.csv")).unwrap();
    assert!(csv(&whole).lines().next().unwrap().contains("bulge"));
    assert!(csv(&part) == csv(&whole), "the resumed design with arcs differs");
}
