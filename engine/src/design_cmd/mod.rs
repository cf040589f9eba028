//! The `scratchart design` subcommand: its flags ([`DesignArgs`], the typed
//! [`scratchart_design::DesignSpec`] they make), the run, the printed summary and the command
//! that continues a stopped run. The design itself is `scratchart-design`'s; the viewer's live
//! design (`scratchart-view --design`) takes the same flags through [`prepare`].
use std::sync::Arc;

use scratchart_design::design::run_design;
use scratchart_design::problem::DesignConfig;
use scratchart_design::{DesignSpec, Problem};
use scratchart_observe::Observer;
use scratchart_vulkan::Context;

mod args;
mod print;

pub use args::{DesignArgs, ExposureMode};
use print::{arcs_text, job_limit_text, machine_error_text, walk_text};

/// Runs `scratchart design`.
pub fn run(ctx: &Arc<Context>, args: &DesignArgs, obs: &dyn Observer) -> anyhow::Result<()> {
    let (problem, cfg) = prepare(ctx, args, obs)?;
    let result = match args.max_job_min {
        Some(limit) => scratchart_design::job_limit::run_design_within(ctx, &problem, &cfg, limit, obs),
        None => run_design(ctx, &problem, &cfg, obs),
    };
    let summary = finish(result, &cfg)?;
    // A design that shows none of its pictures, or keeps almost none of its scratches, is a
    // failure: written for inspection, exit 1 (a script never carves it by mistake).
    if let Some(why) = summary.as_ref().and_then(scratchart_design::report::verdict) {
        return Err(anyhow::anyhow!(
            "{why}; the design is written to {} for inspection, but it is not worth carving",
            cfg.out.display()
        ));
    }
    Ok(())
}

/// The problem and configuration of `scratchart design ARGS` (every flag checked: see
/// [`scratchart_design::spec::prepare`]), timed from the process's start; `scratchart-view
/// --design` runs the same.
pub fn prepare(ctx: &Arc<Context>, args: &DesignArgs, obs: &dyn Observer) -> anyhow::Result<(Problem, DesignConfig)> {
    let spec: DesignSpec = args.spec();
    // A GPU runs the default size in a blink: say what it can do instead.
    if args.default_size() && matches!(ctx.info().kind.as_str(), "discrete" | "integrated") {
        obs.info(&format!(
            "{} is a GPU: --preset paper designs at the paper's scale (40,000 scratches, 512 px, 300 iterations)",
            ctx.info().name
        ));
    }
    let (problem, mut cfg) = scratchart_design::spec::prepare(ctx, &spec, obs)?;
    cfg.started = Some(crate::exit::process_start());
    Ok((problem, cfg))
}

/// This command line with `--resume` added (what continues an interrupted run).
fn resume_command() -> String {
    let mut args: Vec<String> = std::env::args().collect();
    if let Some(first) = args.first_mut() {
        *first = "scratchart".into();
    }
    // The viewer's live design (`scratchart-view --design ...`): the same run is `scratchart
    // design` with the design's flags (the live view's own left out).
    if let Some(i) = args.iter().position(|a| a == "--design") {
        let mut design = vec!["scratchart".to_string(), "design".to_string()];
        let mut rest = args[1..i].iter().chain(&args[i + 1..]);
        while let Some(a) = rest.next() {
            match a.as_str() {
                "--headless" | "--paused" | "--log-frames" | "--validation" => {}
                "--size" | "--device" | "--exit-after" | "--script" => {
                    rest.next();
                }
                _ if ["--size=", "--device=", "--exit-after=", "--script="]
                    .iter()
                    .any(|p| a.starts_with(p)) => {}
                _ => design.push(a.clone()),
            }
        }
        args = design;
    }
    if !args.iter().any(|a| a == "--resume") {
        args.push("--resume".into());
    }
    args.iter()
        .map(|a| {
            if a.contains(char::is_whitespace) {
                format!("'{a}'")
            } else {
                a.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Prints what a design run made (the summary and its parts), or the error, with the command
/// that continues a stopped run.
pub fn finish(
    result: Result<scratchart_design::DesignReport, scratchart_optim::error::OptimError>,
    cfg: &DesignConfig,
) -> anyhow::Result<Option<serde_json::Value>> {
    let report = match result {
        Ok(r) => r,
        Err(
            e @ scratchart_optim::error::OptimError::Interrupted {
                checkpoint: Some(_), ..
            },
        ) => {
            return Err(anyhow::Error::new(e).context(format!("stopped; continue with `{}`", resume_command())));
        }
        Err(e) => return Err(e.into()),
    };
    if let Some(s) = &report.summary {
        print!("{}", scratchart_design::report::summary_text(s, &cfg.out));
        if let Some(f) = s.get("fabrication") {
            let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
            println!(
                "  fabrication: tool {} ({}), alpha {} from {}; commanded depths z_mm {:.4} .. {:.4} mm (range {:.4} .. {:.4} mm; table error w {:.1e}, d {:.1e}) in scratches.csv",
                f["tool_file"].as_str().unwrap_or("?"),
                f["tool"]["kind"].as_str().unwrap_or("?"),
                n(&f["alpha"]),
                f["alpha_from"].as_str().unwrap_or("?"),
                n(&f["z_written_mm"][0]),
                n(&f["z_written_mm"][1]),
                n(&f["z_range_mm"][0]),
                n(&f["z_range_mm"][1]),
                n(&f["table_max_rel_err_w"]),
                n(&f["table_max_rel_err_d"]),
            );
        }
        if let Some(m) = s.get("machine") {
            let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
            println!(
                "  machine ({}): cuts {:.4} mm or deeper below the surface on a {} mm Z grid, scratches {:.3} mm or longer ({}); \
                 {} of {} scratches at the shallowest cut, {} at the shortest length, {} of the {} optimized moved onto the Z grid (at most {:.2} um); \
                 job about {:.1} min on this machine (the planner's estimate, as `scratchart-cal plan` makes it: {}; \
                 the +x mark and the registration marks included: the registration marks take {:.1} min of it, \
                 `plan --no-marks` leaves them out)",
                m["profile"].as_str().unwrap_or("?"),
                n(&m["min_cut_depth_mm"]),
                n(&m["z_step_mm"]),
                n(&m["min_length_mm"]),
                m["min_length_from"].as_str().unwrap_or("?"),
                m["at_min_cut_depth"],
                m["scratches"],
                m["at_min_length"],
                m["moved_onto_z_grid"],
                m["scratches_optimized"],
                n(&m["largest_z_grid_move_um"]),
                n(&m["job_min"]),
                m["job_time_shares"].as_str().unwrap_or("?"),
                n(&m["registration_marks_min"]),
            );
        }
        if let Some(e) = s.get("machine_error") {
            print!("{}", machine_error_text(e));
        }
        if let Some(j) = s.get("job_limit") {
            print!("{}", job_limit_text(j));
        }
        if let Some(w) = s.get("walk") {
            print!("{}", walk_text(w, &cfg.out));
        }
        if let Some(a) = s.get("arcs") {
            print!("{}", arcs_text(a));
        }
    }
    Ok(report.summary)
}
