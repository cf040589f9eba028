//! A design sized to the job time the maker has (`design --machine ... --max-job-min N`, issue 27
//! item 4).
//!
//! 1. The design as asked, without the limit, in `OUT/unlimited/` (its own checkpoints and
//!    reports): what the limit is measured against.
//! 2. Its job time as `plan` would make it by default for the same machine ([`job_time`]: the
//!    cuts ordered as `plan` orders them, the +x mark and the registration marks, the
//!    controller's planner). The limit holds the move-by-move sum from rest to rest, an upper
//!    bound of the planner's estimate that a maker's own sum of the G-code will not exceed
//!    either; a plan with `--no-marks` takes less.
//! 3. Over the limit: the scratches that matter least (the pruning's ranking: how far each one's
//!    gradient would move it) go until the job fits in [`TRIM_TARGET`] of it (the registration
//!    marks' time is the same whatever is left: only the rest shrinks), and the rest is
//!    optimized again for half the iterations (lengths may grow while it is); still over, the
//!    least important go again until it fits, with a final evaluation. Within the limit from
//!    the start: the same design, evaluated again.
//! 4. The result goes to `OUT/` as any design does, and its `summary.json` gains `job_limit`:
//!    both designs' scratches, job times and correlations, and what the limit cost each view.
//!
//! `--resume` continues whichever stage was stopped (each has its checkpoints; the stages are
//! deterministic, so a resumed run equals an uninterrupted one).
use serde_json::{json, Value};

use scratchart_machine::marks::JobTime;

use crate::job_time::job_time;
use scratchart_tool::machine::MachineProfile;

use crate::design::run_design;
use crate::problem::{DesignConfig, DesignReport, Problem};
use scratchart_model::scene::Scene;
use scratchart_observe::Observer;
use scratchart_optim::error::OptimError;
use scratchart_optim::loss::Loss;
use scratchart_render::Renderer;
use scratchart_vulkan::Context;

/// Before re-optimizing, the job is trimmed to this share of the limit (the re-optimization may
/// lengthen scratches).
pub const TRIM_TARGET: f64 = 0.92;

/// Each scratch's importance (the pruning's ranking) in `scene`.
fn importance(renderer: &Renderer, loss: &Loss, scene: &Scene, cfg: &DesignConfig) -> Result<Vec<f64>, OptimError> {
    renderer.prepare_backward()?;
    let (_, grads) = scratchart_optim::prune::evaluate(renderer, loss, scene)?;
    Ok(scratchart_optim::prune::importance(&grads, &cfg.adam))
}

/// The most important scratches of `scene` (kept in order) whose job (with its marks) fits in
/// `secs`; with their depths and the job's times. An error when not even one scratch fits.
fn trim(
    scene: &Scene,
    depths: &[f64],
    rank: &[f64],
    m: &MachineProfile,
    secs: f64,
) -> Result<(Scene, Vec<f64>, JobTime), OptimError> {
    let mut order: Vec<usize> = (0..scene.scratches.len()).collect();
    order.sort_by(|&a, &b| rank[b].total_cmp(&rank[a]).then(a.cmp(&b)));
    let keep = |n: usize| -> (Scene, Vec<f64>) {
        let mut idx: Vec<usize> = order[..n].to_vec();
        idx.sort_unstable();
        let mut s = scene.clone();
        s.scratches = idx.iter().map(|&i| scene.scratches[i]).collect();
        (s, idx.iter().map(|&i| depths[i]).collect())
    };
    let (mut n, mut t) = (scene.scratches.len(), job_time(scene, depths, m));
    for _ in 0..12 {
        if t.upper_s <= secs {
            break;
        }
        // Past the registration marks' time (the same whatever is left), the time is about
        // proportional to the scratches left (a few percent of it is the start, the end and the
        // +x mark): shrink by the ratio, and by at least one.
        let fixed = t.registration_upper_s;
        let ratio = ((secs - fixed) / (t.upper_s - fixed)).max(0.0);
        let next = ((n as f64 * ratio).floor() as usize).min(n - 1);
        if next == 0 {
            break;
        }
        n = next;
        let (s, z) = keep(n);
        t = job_time(&s, &z, m);
    }
    if t.upper_s > secs {
        let (s, z) = keep(1);
        return Err(too_short(secs, job_time(&s, &z, m).upper_s));
    }
    let (s, z) = keep(n);
    Ok((s, z, t))
}

/// One design's entry in `job_limit`.
fn side(scene: &Scene, t: &JobTime, corr: &[f64]) -> Value {
    json!({
        "scratches": scene.scratches.len(),
        "job_min": t.split.total() / 60.0,
        "job_min_upper": t.upper_s / 60.0,
        "registration_marks_min": t.registration_s / 60.0,
        "shares": t.split.shares(),
        "corr": corr,
    })
}

fn too_short(limit_s: f64, one_s: f64) -> OptimError {
    OptimError::Usage(format!(
        "the job limit ({} min) is shorter than a job of one scratch ({:.2} min on this machine with the marks \
         `scratchart-cal plan` carves after it): give a longer --max-job-min",
        limit_s / 60.0,
        one_s / 60.0
    ))
}

fn corr(summary: &Option<Value>) -> Vec<f64> {
    summary
        .as_ref()
        .and_then(|s| s["per_view"].as_array().cloned())
        .unwrap_or_default()
        .iter()
        .map(|v| v["corr_final"].as_f64().unwrap_or(f64::NAN))
        .collect()
}

/// The design of `problem` within `max_min` minutes of machine time (see the module doc).
pub fn run_design_within(
    ctx: &std::sync::Arc<Context>,
    problem: &Problem,
    cfg: &DesignConfig,
    max_min: f64,
    obs: &dyn Observer,
) -> Result<DesignReport, OptimError> {
    let m = match cfg.tool.as_ref().and_then(|f| f.machine.as_ref()) {
        Some(l) => l.profile.clone(),
        None => return Err(OptimError::Usage("--max-job-min needs --machine (and --tool)".into())),
    };
    if !(max_min > 0.0 && max_min.is_finite()) {
        return Err(OptimError::Usage(format!(
            "--max-job-min {max_min}: a time > 0 minutes"
        )));
    }
    let limit = 60.0 * max_min;
    let started = std::time::Instant::now();
    // A limit shorter than the job of the shortest initial scratch at the shallowest cut is
    // refused before any work.
    if let (Some(fab), Some(s)) = (
        &cfg.tool,
        problem.scene.scratches.iter().min_by(|a, b| {
            let len = |s: &scratchart_model::scene::Scratch| (s.p1[0] - s.p0[0]).hypot(s.p1[1] - s.p0[1]);
            len(a).total_cmp(&len(b))
        }),
    ) {
        let mut one = problem.scene.clone();
        one.scratches = vec![*s];
        let t = job_time(&one, &[fab.table.z_lo], &m).upper_s;
        if t > limit {
            return Err(too_short(limit, t));
        }
    }
    let has_checkpoint = |dir: &std::path::Path| scratchart_optim::checkpoint::path(dir).exists();
    // 1. Without the limit.
    let mut c1 = cfg.clone();
    c1.out = cfg.out.join("unlimited");
    c1.carvings = 0;
    c1.resume = cfg.resume && has_checkpoint(&c1.out);
    obs.info(&format!(
        "job limit {max_min} min: the design without it first (in {})",
        c1.out.display()
    ));
    let a = run_design(ctx, problem, &c1, obs)?;
    let za = a.depths.clone().expect("a machine design has depths");
    let ta = job_time(&a.scene, &za, &m);
    // 2. Trimmed to fit, optimized again.
    let renderer = Renderer::new(ctx)?;
    let slots = scratchart_render::layout::view_slots(&problem.scene);
    let loss = crate::design::design_loss(ctx, &slots.views, problem, cfg)?;
    let fits = ta.upper_s <= limit;
    let (start, refine_iters, trimmed_to) = if fits {
        (a.scene.clone(), 0, None)
    } else {
        let rank = importance(&renderer, &loss, &a.scene, cfg)?;
        let (s, _, t) = trim(&a.scene, &za, &rank, &m, TRIM_TARGET * limit)?;
        let n = s.scratches.len();
        (s, (cfg.iters / 2).max(10), Some((n, t.upper_s)))
    };
    obs.info(&format!(
        "job limit {max_min} min: without it {} scratches, {:.1} min (at most {:.1}); {}",
        a.scene.scratches.len(),
        ta.split.total() / 60.0,
        ta.upper_s / 60.0,
        match trimmed_to {
            None => "it fits".to_string(),
            Some((n, t)) => format!(
                "trimmed to the {n} that matter most ({:.1} min at most), optimized again for {refine_iters} iterations",
                t / 60.0
            ),
        }
    ));
    let run_stage = |scene: Scene, iters: u32| -> Result<DesignReport, OptimError> {
        let mut p = problem.clone();
        p.scene = scene;
        let mut c = cfg.clone();
        c.iters = iters;
        c.calibrate_lights = false;
        // (the start-up of the whole job is counted once, in the first stage's wall times)
        c.started = None;
        // (an evaluation only has no checkpoint of its own: one in OUT is the stage before)
        c.resume = iters > 0 && cfg.resume && has_checkpoint(&cfg.out);
        if iters == 0 {
            c.prune.tol = 0.0;
        }
        run_design(ctx, &p, &c, obs)
    };
    let mut b = run_stage(start, refine_iters)?;
    let mut zb = b.depths.clone().expect("a machine design has depths");
    let mut tb = job_time(&b.scene, &zb, &m);
    let mut final_trim = None;
    if tb.upper_s > limit {
        // 3. Lengthened past the limit while it was optimized: the least important go again.
        let rank = importance(&renderer, &loss, &b.scene, cfg)?;
        let (s, _, _) = trim(&b.scene, &zb, &rank, &m, limit)?;
        final_trim = Some((b.scene.scratches.len(), s.scratches.len()));
        b = run_stage(s, 0)?;
        zb = b.depths.clone().expect("a machine design has depths");
        tb = job_time(&b.scene, &zb, &m);
    }
    let (ca, cb) = (corr(&a.summary), corr(&b.summary));
    let entry = json!({
        "max_job_min": max_min,
        "what": "the design without the limit (in unlimited/) and within it: scratches, job time as plan makes it for this machine by default, the +x mark and the registration marks included (the planner's estimate, and the move-by-move sum from rest that the limit holds; registration_marks_min: the registration marks' part of the estimate, which plan --no-marks leaves out), each view's correlation with its picture",
        "fits_without_trimming": fits,
        "refine_iterations": refine_iters,
        "final_trim": final_trim.map(|(from, to)| json!({"from": from, "to": to})),
        "unlimited": side(&a.scene, &ta, &ca),
        "limited": side(&b.scene, &tb, &cb),
        "corr_cost": ca.iter().zip(&cb).map(|(x, y)| x - y).collect::<Vec<_>>(),
        "wall_s": started.elapsed().as_secs_f64(),
    });
    if let Some(s) = b.summary.as_mut() {
        s["job_limit"] = entry;
        scratchart_render::io::write_atomic(
            &cfg.out.join("summary.json"),
            serde_json::to_string_pretty(s)
                .expect("the summary always serializes")
                .as_bytes(),
        )?;
    }
    Ok(b)
}
