//! The speed-against-accuracy study (`scratchart study`, `engine/src/study.rs`): every method
//! renders every regime without a NaN or an infinity, the default closed form stays within
//! engine/docs/model.md section 8's bar on every regime while the methods it is charted against do not (so
//! the measure can tell them apart), and the command writes its table, chart and verdict.
use scratchart::study::{self, StudyOptions, BAR};
use scratchart_render::kernels::Integrator;
use scratchart_tests::*;
use std::process::Command;

#[test]
fn every_method_is_finite_and_the_closed_form_meets_the_bar_everywhere() {
    let ctx = gpu();
    let opt = StudyOptions {
        res: 32,
        time_res: 32,
        repeats: 1,
        methods: Integrator::STUDY.to_vec(),
        regimes: None,
    };
    let rows = study::run(&ctx, &opt, &mut |_| {}).unwrap();
    assert_eq!(rows.len(), Integrator::STUDY.len() * study::regimes(32, 1).len());
    for r in &rows {
        assert!(r.finite, "{} on {}: NaN or infinity in the render", r.method, r.regime);
        assert!(
            r.pixels > 100,
            "{} on {}: only {} on-plate pixels",
            r.method,
            r.regime,
            r.pixels
        );
        assert!(r.pairs > 0, "{} on {}: no pairs", r.method, r.regime);
    }
    let get = |m: &str, reg: &str| rows.iter().find(|r| r.method == m && r.regime == reg).unwrap();
    for reg in study::regimes(32, 1) {
        let cf = get("closed-form", reg.name);
        assert!(
            cf.err_p99 <= BAR && cf.err_max.is_finite(),
            "closed form on {}: p99 {:.2e} max {:.2e}",
            reg.name,
            cf.err_p99,
            cf.err_max
        );
        // The numeric cross-check agrees as well (engine/docs/model.md's bar, the same measure).
        assert!(
            get("gauss-panels", reg.name).err_p99 <= BAR,
            "gauss panels on {}",
            reg.name
        );
    }
    // The measure sees failures: a sharp lobe defeats few-node quadrature and sampling, and the
    // average approximation is off wherever the chord varies across the strip.
    for m in ["gauss-legendre-8", "monte-carlo-64", "average"] {
        let r = get(m, "sharp");
        assert!(
            r.err_p99 > 10.0 * BAR,
            "{m} on sharp: p99 {:.2e} should miss the bar",
            r.err_p99
        );
    }
    // Plain Gauss-Legendre converges where the lobe is wide against the edges (h along the axis).
    assert!(get("gauss-legendre-32", "along-axis").err_p99 <= BAR);
    assert!(get("gauss-legendre-2", "along-axis").err_p99 > get("gauss-legendre-32", "along-axis").err_p99);
    let v = study::verdict(&rows);
    assert!(v.contains("The closed form meets the bar on every regime"), "{v}");
    assert_no_validation(&ctx);
}

#[test]
fn the_command_writes_table_chart_and_verdict() {
    let dir = std::env::temp_dir().join(format!("scratchart-study-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let bin = workspace_bin("scratchart", "scratchart");
    let out = Command::new(&bin)
        .args(["study", "--out", dir.to_str().unwrap(), "--regimes", "sharp,dense"])
        .args([
            "--methods",
            "closed-form,average",
            "--res",
            "24",
            "--time-res",
            "32",
            "--repeats",
            "1",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "study failed:\n{err}");
    let csv = std::fs::read_to_string(dir.join("study.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in ["method", "regime", "err_max", "err_p99", "err_median", "ns_per_pair"] {
        assert!(header.contains(&col), "study.csv lacks column {col}: {header:?}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 4, "{csv}");
    for r in &rows {
        let ns: f64 = r[5].parse().unwrap();
        assert!(ns.is_finite() && ns > 0.0, "{csv}");
    }
    let png = image::open(dir.join("study.png")).unwrap();
    assert!(png.width() > 300 && png.height() > 200);
    let verdict = std::fs::read_to_string(dir.join("verdict.txt")).unwrap();
    assert!(
        verdict.contains("sharp: cheapest within the bar: closed-form"),
        "{verdict}"
    );
    // A misspelt method is a command-line error (exit 2) that lists the methods.
    let bad = Command::new(&bin)
        .args(["study", "--out", dir.to_str().unwrap(), "--methods", "closed"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("gauss-legendre-8"));
}

/// The integrator `adaptive` leaves out pairs whose bound is below 5e-4 of what their pixel has
/// kept so far (shaders/inc/tile_queue.glsl, SA_CULL_PAIRS). Checked on the study's regimes and
/// on a scene built to make it cull a lot (sharp lobes in random directions over a plate whose
/// own highlight is far away): every pixel stays within the written bound of the closed form's,
/// the render meets engine/docs/model.md's bar against the float64 reference, and the culling really runs.
#[test]
fn adaptive_keeps_its_written_bound() {
    use scratchart_model::reference::render_view;
    use scratchart_render::kernels::KernelSet;
    use scratchart_render::Renderer;
    let ctx = gpu();
    let cf = Renderer::new(&ctx).unwrap();
    let ad = Renderer::with_kernels(&ctx, KernelSet::with_integrator(Integrator::Adaptive)).unwrap();
    let mut scenes: Vec<(String, scratchart_model::scene::Scene)> = study::regimes(32, 1)
        .into_iter()
        .map(|r| (r.name.to_string(), r.scene))
        .collect();
    // Bright scratches first (their axes across the half vector, which lies on their groove's
    // arc of normals: the GGX peak), then many whose axes run along it (far in the GGX tail), on
    // a plate whose own highlight is elsewhere: the later ones are what culling is for.
    let mut culling = random_scene(
        29,
        0,
        20.0,
        0.3,
        0.2,
        0.004,
        vec![orbit_view("v", 40, 50.0, 0.0, 35.0, 0.0, 20.0)],
    );
    for i in 0..50 {
        let x = -10.0 + 0.4 * (i as f64 + 0.5);
        culling.scratches.push(scratch([x, -9.5], [x, 9.5], 0.4, 0.2, 0.004));
    }
    let mut rng = scratchart_design::scenes::Rng::new(31);
    for _ in 0..600 {
        let (x, y) = (rng.range(-8.0, 8.0), rng.range(-9.0, 9.0));
        let (a, l) = (rng.range(-0.2, 0.2), rng.range(1.0, 4.0));
        culling
            .scratches
            .push(scratch([x, y], [x + l * a.cos(), y + l * a.sin()], 0.3, 0.15, 0.004));
    }
    scenes.push(("culling".into(), culling));
    for (name, scene) in &scenes {
        let mut gc = cf.upload(scene).unwrap();
        let mut ga = ad.upload(scene).unwrap();
        let fc = cf.render(&mut gc).unwrap();
        let fa = ad.render(&mut ga).unwrap();
        assert_eq!(fc.stats.culled, 0, "{name}: the closed form culls nothing");
        // The same pairs, integrated or left out (a left-out candidate may also be one whose
        // footprint box meets the scratch but the footprint does not, counted by neither).
        assert!(
            fa.stats.pairs <= fc.stats.pairs && fa.stats.pairs + fa.stats.culled >= fc.stats.pairs,
            "{name}"
        );
        let share = fa.stats.culled as f64 / fc.stats.pairs.max(1) as f64;
        // The bound against the closed form: culling moves a pixel by at most 5e-4 of its value
        // (plus float32 rounding of the sums, 1e-6 relative).
        for (idx, (&c, &a)) in fc.images[0].iter().zip(&fa.images[0]).enumerate() {
            assert!(a.is_finite(), "{name}: pixel {idx} not finite");
            let d = (c as f64 - a as f64).abs();
            assert!(
                d <= (5e-4 + 1e-6) * c as f64,
                "{name}: pixel {idx} moved by {:.2e} of its value {c:e} ({a:e}); the bound is 5e-4",
                d / c as f64
            );
        }
        let reference = render_view(scene, 0);
        let cmp = compare(scene, 0, &fa.images[0], &reference);
        assert!(
            cmp.fraction() >= 0.99,
            "{name}: adaptive misses engine/docs/model.md's bar: {:.4} within, worst {:?}",
            cmp.fraction(),
            cmp.worst_at
        );
        eprintln!("{name}: {:.2}% of {} pairs left out", 100.0 * share, fc.stats.pairs);
        if name == "culling" {
            assert!(
                share > 0.05,
                "culling scene: only {:.2}% of the pairs left out",
                100.0 * share
            );
        }
    }
    assert_no_validation(&ctx);
}
