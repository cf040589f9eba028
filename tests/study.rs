//! The speed-against-accuracy study (`scratchart study`, `engine/src/study.rs`): every method
//! renders every regime without a NaN or an infinity, the default closed form stays within
//! MODEL.md section 8's bar on every regime while the methods it is charted against do not (so
//! the measure can tell them apart), and the command writes its table, chart and verdict.
use scratchart::render::kernels::Integrator;
use scratchart::study::{self, StudyOptions, BAR};
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
        // The numeric cross-check agrees as well (MODEL.md's bar, the same measure).
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
