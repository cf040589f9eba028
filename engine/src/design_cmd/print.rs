//! The lines `scratchart design` prints for the parts of `summary.json` beyond the views'
//! table: the machine's error, a job limit, a walk, arcs.

/// The lines that say what the machine's error costs each view (summary.json's `machine_error`).
pub(super) fn machine_error_text(e: &serde_json::Value) -> String {
    let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let mut out = format!(
        "  machine error ({} carvings, depth +-{:.1} um, position +-{:.1} um, 1 sigma; {}): correlation as written -> as carved\n",
        e["carvings"],
        1e3 * n(&e["sigma_z_mm"]),
        1e3 * n(&e["sigma_xy_mm"]),
        if e["robust"].as_bool() == Some(true) { "designed with --robust" } else { "without --robust" },
    );
    for v in e["per_view"].as_array().into_iter().flatten() {
        out += &format!(
            "    {}: {:.3} -> {:.3} +- {:.3} (worst {:.3})\n",
            v["name"].as_str().unwrap_or("?"),
            n(&v["corr_exact"]),
            n(&v["corr_carved_mean"]),
            n(&v["corr_carved_std"]),
            n(&v["corr_carved_worst"]),
        );
    }
    out
}

/// The lines that say how a walk shows its frames along its arc (summary.json's `walk`).
pub(super) fn walk_text(w: &serde_json::Value, out: &std::path::Path) -> String {
    let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let corrs = |k: &str| -> Vec<f64> { w[k].as_array().into_iter().flatten().map(|e| n(&e["corr"])).collect() };
    let (views, between) = (corrs("views"), corrs("between"));
    let mean = |c: &[f64]| c.iter().sum::<f64>() / c.len().max(1) as f64;
    let mut text = format!(
        "  walk ({}): {} views over {:.1} degrees ({:.2} apart) about azimuth {:.1}; correlation with {}: min {:.3}, mean {:.3}\n",
        w["source"].as_str().unwrap_or("?"),
        views.len(),
        n(&w["arc_deg"]),
        n(&w["step_deg"]),
        n(&w["centre_azimuth_deg"]),
        if w["source"] == "object" { "the object seen from there" } else { "their frames" },
        n(&w["min_corr_views"]),
        mean(&views),
    );
    let probes = corrs("probes");
    if !between.is_empty() {
        text += &format!(
            "    {} in-between views in the loss ({} per pair), correlation with {}: min {:.3}, mean {:.3}\n",
            between.len(),
            w["between_per_pair"],
            if w["source"] == "object" {
                "the object seen from there"
            } else {
                "their neighbours' cross-fades"
            },
            n(&w["min_corr_between"]),
            mean(&between),
        );
    }
    if !probes.is_empty() {
        text += &format!(
            "    {} probes between the views, judged only (not in the loss): min {:.3}, mean {:.3}\n",
            probes.len(),
            n(&w["min_corr_probes"]),
            mean(&probes),
        );
    }
    text += &format!(
        "    wrote {0}/walk.png (correlation along the arc) and {0}/walk_sheet.png (the renders along the arc above their targets)\n",
        out.display()
    );
    text
}

/// The lines that say what `--max-job-min` did and cost (summary.json's `job_limit`).
pub(super) fn job_limit_text(j: &serde_json::Value) -> String {
    let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let side = |k: &str| {
        format!(
            "{} scratches, {:.1} min ({:.1} at most; {}; the registration marks {:.1} min of it)",
            j[k]["scratches"],
            n(&j[k]["job_min"]),
            n(&j[k]["job_min_upper"]),
            j[k]["shares"].as_str().unwrap_or("?"),
            n(&j[k]["registration_marks_min"]),
        )
    };
    let mut out = format!(
        "  job limit {} min ({:.1} s in all; the lines above are its last stage's): without it {}; within it {}\n",
        n(&j["max_job_min"]),
        n(&j["wall_s"]),
        side("unlimited"),
        side("limited")
    );
    let costs: Vec<String> = j["corr_cost"]
        .as_array()
        .into_iter()
        .flatten()
        .zip(j["limited"]["corr"].as_array().into_iter().flatten())
        .zip(j["unlimited"]["corr"].as_array().into_iter().flatten())
        .enumerate()
        .map(|(v, ((c, l), u))| format!("v{v} {:.3} -> {:.3} ({:+.3})", n(u), n(l), -n(c)))
        .collect();
    out += &format!("    what the limit cost in correlation: {}\n", costs.join(", "));
    out
}

/// The line that says how far a design with arcs bent its scratches (summary.json's `arcs`).
pub(super) fn arcs_text(a: &serde_json::Value) -> String {
    let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    format!(
        "  arcs: {} of {} scratches bent (median turn {:.1} degrees, largest {:.1}; {} at --max-bulge {}), rendered as {} chords each while designing, judged at {}\n",
        a["bent"],
        a["scratches"],
        n(&a["median_turn_deg"]),
        n(&a["largest_turn_deg"]),
        a["at_max_bulge"],
        n(&a["max_bulge"]),
        a["chords_per_arc"],
        a["judged_chords_per_arc"],
    )
}
