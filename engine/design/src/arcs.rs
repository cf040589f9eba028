//! Designs whose scratches bend (`design --arcs`, engine/docs/model.md section 11): what
//! summary.json says of their arcs, and the chords per arc they were judged at, which the
//! programs that render a design again read back.
use serde_json::{json, Value};

use scratchart_model::scene::Scene;
/// `summary.json`'s `arcs` (`design --arcs`): how many scratches bent and how far.
pub(crate) fn summary(a: &scratchart_optim::arc_params::ArcConfig, judged: u32, scene: &Scene) -> Value {
    let b: Vec<f64> = scene.scratches.iter().map(|s| s.bulge.abs()).collect();
    let bent = b.iter().filter(|&&x| x > 1e-3).count();
    let sweep = |x: f64| 4.0 * x.atan().to_degrees();
    let mut sorted = b.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    json!({
        "bent": bent,
        "scratches": b.len(),
        "at_max_bulge": b.iter().filter(|&&x| x >= a.max_bulge as f64 - 1e-4).count(),
        "max_bulge": a.max_bulge,
        "median_turn_deg": sweep(median),
        "largest_turn_deg": sweep(sorted.last().copied().unwrap_or(0.0)),
        "chords_per_arc": a.chords,
        "judged_chords_per_arc": judged,
        "judged_at": "the optimizer renders each arc as chords_per_arc chords; the final loss, every correlation of this summary, the set-up sheet and the walk's probes render it as judged_chords_per_arc: four times as many, at least 32, or fewer where the device cannot hold every view at once (engine/docs/model.md section 11: the accuracy bar's own rule needs far more chords for long arcs with sharp lobes)",
        "pruning": "off: a design with arcs keeps every scratch",
        "rule": "bulge = tan(included angle / 4), + counter-clockwise from +z (engine/docs/model.md section 11); an arc the optimizer left off the plate or tighter than its groove's width is written with the largest legal bulge of its sense",
    })
}

/// The chords per arc a design with arcs was judged at (`summary.json`'s
/// `arcs.judged_chords_per_arc` beside `design`), for the programs that render it again
/// (`scratchart render`, `scratchart setup`, the viewer) so they show what the design judged;
/// None for a design without arcs, or without its summary.
pub fn judged_arc_chords(design: &std::path::Path) -> Option<u32> {
    let dir = design
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let text = std::fs::read_to_string(dir.join("summary.json")).ok()?;
    let v: Value = serde_json::from_str(&text).ok()?;
    let n = v["arcs"]["judged_chords_per_arc"].as_u64()?;
    u32::try_from(n).ok().filter(|&n| n > 0)
}
