//! `design --balance`: each view's weight in the loss (`Loss::set_view_weights`) scales that
//! view's terms and its share of dE/dL exactly, weights of 1 are the loss as before, the command
//! line records the weights it ended with, and a stopped balanced run resumes bit for bit.
use scratchart_design::scenes::{orbit_light, random_scratches, ring_views, Rng};
use scratchart_design::targets::builtin_targets;
use scratchart_model::scene::Scene;
use scratchart_optim::loss::{Loss, LossConfig};
use scratchart_render::Renderer;
use scratchart_tests::{assert_no_validation, gpu, plate, run_scratchart};

#[test]
fn a_view_weight_scales_its_terms_and_its_gradient() {
    let ctx = gpu();
    let light = orbit_light(300.0, 45.0, 30.0, 3.0e4);
    let mut rng = Rng::new(5);
    let scene = Scene {
        plate: plate(100.0),
        views: ring_views(3, 45.0, 300.0, 100.0, 36, &light),
        scratches: random_scratches(&mut rng, 300, 100.0, 2.0, 8.0, 0.05, 0.05, 0.06),
    };
    let targets = builtin_targets(&scene);
    let cfg = LossConfig {
        lambda_g: 5.0,
        ..LossConfig::default()
    };
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    r.render(&mut gs).unwrap();
    let loss = Loss::new(&ctx, gs.views(), &targets, cfg).unwrap();
    let eval = |w: &[f32]| {
        loss.set_view_weights(&ctx, w).unwrap();
        let lv = loss.evaluate(&ctx, gs.image(), Some(gs.dl())).unwrap();
        let dl: Vec<f32> = ctx.download(gs.dl()).unwrap();
        (lv, dl)
    };
    let (a, dla) = eval(&[1.0, 1.0, 1.0]);
    let (b, dlb) = eval(&[2.0, 0.5, 1.0]);
    for (v, k) in [(0, 2.0f32), (1, 0.5), (2, 1.0)] {
        assert!(
            (b.pixel[v] - k * a.pixel[v]).abs() <= 1e-6 * a.pixel[v].abs(),
            "view {v} pixel"
        );
        assert!(
            (b.gram[v] - k * a.gram[v]).abs() <= 1e-5 * a.gram[v].abs() + 1e-12,
            "view {v} gram"
        );
        assert!(a.gram[v] > 0.0 && a.pixel[v] > 0.0);
        // dE/dL of the view's pixels (level 0 holds view v at its base).
        let base = gs.views()[v].base[1] as usize;
        let n = (gs.views()[v].dims[0] * gs.views()[v].dims[1]) as usize;
        for p in base..base + n {
            assert!(
                (dlb[p] - k * dla[p]).abs() <= 1e-5 * dla[p].abs() + 1e-12,
                "view {v} pixel {p}"
            );
        }
    }
    // Back to 1: the bits of the unweighted loss.
    let (c, dlc) = eval(&[1.0, 1.0, 1.0]);
    assert_eq!((c.total.to_bits(), dlc), (a.total.to_bits(), dla));
    assert_no_validation(&ctx);
}

#[test]
fn design_balance_records_the_weights_it_ended_with() {
    let out = std::env::temp_dir().join(format!("scratchart-balance-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    // The default (no flag) balances; --no-balance does not.
    let run = |extra: &[&str]| {
        let mut a = vec!["design", "--scratches", "300", "--iters", "40", "--res", "32"];
        a.extend(extra);
        a.extend(["--out", out.to_str().unwrap()]);
        let o = run_scratchart(&a);
        let said = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(o.status.code(), Some(0), "{said}");
        said
    };
    let said = run(&["--no-balance"]);
    assert!(!said.contains("balance at iteration"), "{said}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(s.get("balance").is_none(), "{s}");
    let said = run(&[]);
    assert!(said.contains("balance at iteration 12: view weights"), "{said}");
    // Each update says where every view stands against its cap.
    let line = said.lines().find(|l| l.contains("balance at iteration 12")).unwrap();
    let stands: Vec<&str> = line
        .rsplit(": ")
        .next()
        .unwrap()
        .trim_end_matches(')')
        .split(", ")
        .collect();
    assert_eq!(stands.len(), 3, "{line}");
    for s in stands {
        let (c, cap) = s.split_once(" of ").expect(line);
        let (c, cap): (f64, f64) = (c.parse().expect(line), cap.parse().expect(line));
        assert!((-1.0..=1.0).contains(&c) && cap > 0.9 && cap <= 1.0, "{line}");
    }
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let w: Vec<f64> = s["balance"]["view_weights"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(w.len(), 3);
    assert!((w.iter().sum::<f64>() / 3.0 - 1.0).abs() < 1e-4, "{w:?}");
    assert!(w.iter().all(|&x| (0.5 / 3.0..=3.0).contains(&x)), "{w:?}");
    assert!(w.iter().any(|&x| (x - 1.0).abs() > 1e-3), "the weights moved: {w:?}");
}

/// Stopped between two updates and at one (checkpoints every 6 iterations; updates at 12, 17,
/// 22, ...), a balanced run resumed with `--resume` writes the scratches of an uninterrupted one,
/// byte for byte (the weights come back from balance.json).
#[test]
fn a_balanced_run_resumes_bit_for_bit() {
    let dir = std::env::temp_dir().join(format!("scratchart-balance-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let design = |out: &std::path::Path, extra: &[&str]| {
        let mut a = vec![
            "design",
            "--balance",
            "--scratches",
            "300",
            "--iters",
            "40",
            "--res",
            "32",
            "--checkpoint-every",
            "6",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(extra);
        run_scratchart(&a)
    };
    let whole = dir.join("whole");
    assert_eq!(design(&whole, &[]).status.code(), Some(0));
    let csv = |d: &std::path::Path| std::fs::read(d.join("scratches.csv")).unwrap();
    for stop in ["13", "20"] {
        let part = dir.join(format!("stopped{stop}"));
        let o = design(&part, &["--inject-stop-at", stop]);
        assert_ne!(o.status.code(), Some(0), "the hook stops the run");
        assert!(part.join("balance.json").exists());
        let o = design(&part, &["--resume"]);
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(
            csv(&part) == csv(&whole),
            "stopped at {stop}: the resumed design differs"
        );
    }
}
