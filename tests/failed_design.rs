//! A design that fails is said to fail: written for inspection, exit 1.
use scratchart_tests::run_scratchart;

/// A design that shows none of its pictures (one iteration from a random start, `--aim 0`: an
/// aimed start shows its pictures from the first iteration) is written for
/// inspection but exits 1, saying why: a script that carves what `design` made never carves it.
#[test]
fn a_design_that_shows_no_picture_exits_1() {
    let out = std::env::temp_dir().join(format!("scratchart-failed-design-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = run_scratchart(&[
        "design",
        "--scratches",
        "60",
        "--iters",
        "1",
        "--res",
        "32",
        "--aim",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("this design failed: no view shows its picture"), "{err}");
    assert!(err.contains("not worth carving"), "{err}");
    assert!(out.join("design.json").exists() && out.join("summary.json").exists());
    // The same job with enough iterations shows its pictures and exits 0.
    let o = run_scratchart(&[
        "design",
        "--scratches",
        "60",
        "--iters",
        "30",
        "--res",
        "32",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    // The report says how far each view is from what its picture allows, and what the walls can
    // reach, with the reach map beside it.
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        said.contains("below what its picture allows") && said.contains("within the walls' reach"),
        "{said}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let lighting: u64 = summary["per_view"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["reach"]["scratches_facing"].as_u64().unwrap())
        .sum();
    assert!(lighting > 0, "no scratch faces any view: {summary}");
    for v in summary["per_view"].as_array().unwrap() {
        let r = &v["reach"];
        let share = r["share"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&share), "{r}");
        // Free grooves may take any wall: every bright pixel is within reach.
        assert_eq!(r["unreachable_pixels"], 0, "{r}");
        assert!(out.join(r["map_png"].as_str().unwrap()).exists());
    }
}
