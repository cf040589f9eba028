//! The design job (`scratchart design`): the generic [`Driver`] with the design loss
//! ([`Loss`]) as objective and the scene's scratches and lights ([`SceneParams`]) as parameters
//! (or, in fabrication mode, one carve depth per scratch: [`ToolParams`]), then pruning, a final
//! evaluation and the reports.
use std::sync::Arc;

use serde_json::{json, Value};

use crate::live::{read_design, Live, LiveHook};
use crate::problem::{DesignConfig, DesignReport, Images, IterRecord, Problem, WallTimes};
use scratchart_model::scene::Scene;
use scratchart_observe::Observer;
use scratchart_optim::arc_params::ArcParams;
use scratchart_optim::checkpoint::fnv;
use scratchart_optim::driver::Rollback;
use scratchart_optim::driver::{Driver, DriverConfig};
use scratchart_optim::error::OptimError;
use scratchart_optim::loss::{Loss, LossValues};
use scratchart_optim::scene_params::SceneParams;
use scratchart_optim::tool_params::{depths_of_kept, ToolParams};
use scratchart_render::layout::ViewGpu;
use scratchart_render::{GpuScene, Renderer};
use scratchart_vulkan::{Context, GpuError};

/// The design optimizer: the driver over the design loss and the scene parameters.
pub struct Optimizer<'r> {
    renderer: &'r Renderer,
    pub driver: Driver<'r>,
    cfg: DesignConfig,
    /// Fabrication mode's parameter set (the depths live there).
    pub tool: Option<Arc<ToolParams>>,
    /// The problem's scene (plate, views, first scratches): what a changed number of scratches
    /// is uploaded with.
    template: Scene,
}

impl<'r> Optimizer<'r> {
    /// Uploads the problem and builds the loss and Adam state (moments zero).
    /// `loss` must have been built for the problem's views and targets.
    pub fn new(
        renderer: &'r Renderer,
        loss: &'r Loss,
        problem: &Problem,
        cfg: &DesignConfig,
    ) -> Result<Optimizer<'r>, GpuError> {
        let ctx = renderer.ctx.clone();
        let gs = match &cfg.arcs {
            Some(a) => renderer.upload_bendable(&problem.scene, a.chords, a.weighted)?,
            None => renderer.upload(&problem.scene)?,
        };
        let tool = match &cfg.tool {
            Some(fab) => {
                let mut t = ToolParams::new(&ctx, &cfg.adam, fab, &problem.scene.scratches)?;
                if let Some(a) = cfg.arcs {
                    t = t.with_arcs(a);
                }
                Some(Arc::new(match fab.robust {
                    Some(r) => t.with_robust(&ctx, r)?,
                    None => t,
                }))
            }
            None => None,
        };
        let mut params: Box<dyn scratchart_optim::driver::ParamSet> = match &tool {
            Some(t) => Box::new(t.clone()),
            None => match &cfg.arcs {
                Some(a) => Box::new(ArcParams::new(&ctx, &cfg.adam, a)?),
                None => Box::new(SceneParams::new(&ctx, &cfg.adam)?),
            },
        };
        if cfg.keep_exposures {
            let lamps: Vec<Vec<usize>> = problem.scene.lamps().into_iter().map(|l| l.views).collect();
            params = Box::new(scratchart_optim::light_tie::TiedLights::new(&ctx, params, &lamps)?);
        }
        let mut tbytes = Vec::new();
        for t in &problem.targets {
            tbytes.extend_from_slice(bytemuck::cast_slice(t));
        }
        // What a checkpoint must agree with to be resumed (iters may differ: no schedule depends on it).
        let views: Vec<Value> = gs
            .views()
            .iter()
            .map(|v| json!(bytemuck::cast_slice::<ViewGpu, u32>(&[*v])))
            .collect();
        let mut fingerprint = json!({
            "n_scratches": gs.n_scratches(),
            "views": views,
            "plate": [problem.scene.plate.size_mm, problem.scene.plate.roughness, problem.scene.plate.f0],
            "targets_fnv": format!("{:016x}", fnv(&tbytes)),
            "loss": format!("{:?}", cfg.loss),
            "adam": format!("{:?}", cfg.adam),
            "seed": cfg.seed,
            "exposure": if cfg.keep_exposures { "fixed" } else { "free" },
        });
        if let Some(fab) = &cfg.tool {
            fingerprint["fabrication"] = fab.fingerprint();
        }
        if cfg.aim > 0.0 {
            fingerprint["aim"] = json!(cfg.aim);
        }
        if cfg.lr_final != 1.0 {
            fingerprint["lr_final"] = json!(cfg.lr_final);
        }
        if let Some(a) = &cfg.arcs {
            fingerprint["arcs"] = json!(format!("{a:?}"));
        }
        let dcfg = DriverConfig {
            iters: cfg.iters,
            hyper: cfg.adam.hyper(),
            checkpoint_every: cfg.checkpoint_every,
            checkpoint_dir: cfg.write_outputs.then(|| cfg.out.clone()),
            max_rollbacks: cfg.max_rollbacks,
            hooks: cfg.hooks,
            task: "design",
            lr_final: cfg.lr_final,
        };
        let driver = Driver::new(renderer, gs, Box::new(loss), params, dcfg, fingerprint)?;
        Ok(Optimizer {
            renderer,
            driver,
            cfg: cfg.clone(),
            tool,
            template: problem.scene.clone(),
        })
    }

    /// Renders the current state and returns the display images (and the linear ones), one
    /// per view.
    pub fn render(&mut self) -> Result<(Images, Images), GpuError> {
        if let Some(t) = &self.tool {
            t.apply(&self.renderer.ctx, &self.driver.gs)?;
        }
        let frame = self.renderer.render(&mut self.driver.gs)?;
        let disp = frame
            .images
            .iter()
            .map(|img| img.iter().map(|&l| scratchart_render::io::display_value(l)).collect())
            .collect();
        Ok((disp, frame.images))
    }

    /// Scales each light so that its view's mean L over on-plate pixels equals the mean of the
    /// target's linear values (T^2.2) there: a sensible starting brightness for any target.
    pub fn calibrate_lights(&mut self, scene: &Scene, targets: &[Vec<f32>]) -> Result<(), GpuError> {
        let (_, lin) = self.render()?;
        let gs = &self.driver.gs;
        let mut phi: Vec<f32> = gs.lights().read()?;
        phi.truncate(scene.views.len());
        // Sums of L and of the target's linear values over each view's on-plate pixels.
        let sums: Vec<(f64, f64)> = lin
            .iter()
            .zip(targets)
            .enumerate()
            .map(|(v, (img, t))| {
                let mask = scratchart_model::camera::on_plate_mask(scene, v);
                let (mut sl, mut st) = (0.0f64, 0.0f64);
                for ((&l, &tv), &m) in img.iter().zip(t).zip(&mask) {
                    if m {
                        sl += l as f64;
                        st += scratchart_model::display::linear(tv as f64);
                    }
                }
                (sl, st)
            })
            .collect();
        // Each view on its own, or (exposures kept) each lamp by its views together, by one factor.
        let groups: Vec<Vec<usize>> = if self.cfg.keep_exposures {
            scene.lamps().into_iter().map(|l| l.views).collect()
        } else {
            (0..scene.views.len()).map(|v| vec![v]).collect()
        };
        for g in groups {
            let (sl, st) = g.iter().fold((0.0, 0.0), |(a, b), &v| (a + sums[v].0, b + sums[v].1));
            if sl > 0.0 && st > 0.0 {
                for v in g {
                    phi[v] = ((phi[v] as f64 * st / sl) as f32).max(self.cfg.adam.phi_min);
                }
            }
        }
        gs.lights().write(0, &phi)?;
        Ok(())
    }

    /// The current design as a scene (parameters and light intensities read back).
    pub fn scene(&self, template: &Scene) -> Result<Scene, GpuError> {
        read_design(&self.renderer.ctx, &self.driver.gs, template, self.cfg.keep_exposures)
    }

    pub fn history(&self) -> Vec<IterRecord> {
        self.driver.history().iter().map(IterRecord::from).collect()
    }

    pub fn rollbacks(&self) -> &[Rollback] {
        self.driver.rollbacks()
    }

    pub fn next_iter(&self) -> u32 {
        self.driver.next_iter()
    }

    /// The loss of the last accepted evaluation.
    pub fn loss(&self) -> Result<LossValues, GpuError> {
        Ok(LossValues::from(&self.driver.objective().read()?))
    }

    /// Runs iterations until `cfg.iters` has been evaluated, checkpointing on the way.
    pub fn run(&mut self, obs: &dyn Observer) -> Result<(f64, u32), OptimError> {
        self.driver.run(obs)
    }

    /// [`Optimizer::run`] with a live hook after each accepted iteration (see [`Live`]). `work`
    /// is the problem as the run goes (its targets change when the design is steered); the
    /// `scheduled` steering is applied where due, after the loss's balance and before the user's hook.
    pub fn run_live(
        &mut self,
        obs: &dyn Observer,
        work: &mut Problem,
        loss: &Loss,
        scheduled: &[crate::steer::SteerEvent],
        hook: &mut LiveHook<'_>,
    ) -> Result<(f64, u32), OptimError> {
        let Optimizer {
            renderer,
            driver,
            cfg,
            tool,
            ..
        } = self;
        let resizable = tool.is_none() && cfg.arcs.is_none();
        // Scheduled events that change the scratches and that the state already holds (a
        // resumed run's checkpoint counts them): recorded, not applied again.
        let mut skip = driver.times_resized();
        let mut next = 0usize;
        let env = LiveEnv {
            renderer,
            loss,
            cfg,
            resizable,
        };
        // What was due before the first iteration of this run (all of it up to a resumed
        // run's iteration, so the targets are those of the run that stopped).
        env.live(driver, work).apply_due(scheduled, &mut next, &mut skip)?;
        let balance = cfg.balance.then(|| {
            let out = cfg.write_outputs.then_some(cfg.out.as_path());
            crate::balance::Balance::new(work, &cfg.blank_views, cfg.iters, cfg.loss.sigma, out)
        });
        // A run resumed past the first update takes the stopped run's weights from balance.json
        // (measured at once where there is none: see crate::balance).
        if let Some(b) = balance.as_ref().filter(|b| b.started(driver.next_iter())) {
            match b.resumed(driver.next_iter()) {
                Some(w) => loss.set_view_weights(&renderer.ctx, &w)?,
                None => b.apply(&mut env.live(driver, work), obs, true)?,
            }
        }
        driver.run_with(obs, &mut |d, ev| {
            let mut l = env.live(d, work);
            // The balance first: it measures the render of the iteration just accepted, before
            // any steering (scheduled here, or live in the hook) changes the scratches or the
            // targets, so a live run and its replay weigh alike.
            if let Some(b) = &balance {
                b.apply(&mut l, obs, false)?;
            }
            l.apply_due(scheduled, &mut next, &mut skip)?;
            hook(&mut l, ev)
        })
    }

    /// Continues from the checkpoint in `cfg.out` (with its number of scratches, where a live
    /// design added or removed some before it was saved).
    pub fn resume(&mut self) -> Result<(), OptimError> {
        let (n, _) = self.driver.checkpoint_scratches(&self.cfg.out)?;
        if let Some(n) = n.filter(|&n| n != self.driver.gs.n_scene_scratches()) {
            // Any n scratches: the checkpoint's state replaces them.
            let mut scene = self.template.clone();
            let first = scene.scratches.first().copied().ok_or_else(|| {
                OptimError::Usage("the checkpoint's design has scratches, the problem has none".into())
            })?;
            scene.scratches.resize(n as usize, first);
            let gs = self.renderer.upload(&scene)?;
            self.driver
                .replace_scene(gs, &vec![None; n as usize], ("scratches", 8))?;
        }
        self.driver.load_checkpoint(&self.cfg.out)
    }
}

/// What every [`Live`] of one run shares.
struct LiveEnv<'e, 'r> {
    renderer: &'r Renderer,
    loss: &'e Loss,
    cfg: &'e DesignConfig,
    resizable: bool,
}

impl<'e, 'r> LiveEnv<'e, 'r> {
    fn live<'a>(&'a self, driver: &'a mut Driver<'r>, problem: &'a mut Problem) -> Live<'a, 'r> {
        Live {
            driver,
            renderer: self.renderer,
            problem,
            loss: self.loss,
            keep_exposures: self.cfg.keep_exposures,
            out: &self.cfg.out,
            adam: &self.cfg.adam,
            resizable: self.resizable,
        }
    }
}

/// The design's loss: with its cross-talk term (`cfg.loss.crosstalk`) among the design views
/// (a walk's in-between views judge the arc and are not paired), over each view's picture.
pub fn design_loss(
    ctx: &Arc<Context>,
    views: &[scratchart_render::layout::ViewGpu],
    problem: &Problem,
    cfg: &DesignConfig,
) -> Result<Loss, OptimError> {
    let design_views = problem.scene.views.len() - problem.walk.as_ref().map_or(0, |w| w.between.len());
    let among: Vec<usize> = (0..design_views).collect();
    Ok(Loss::with_crosstalk(
        ctx,
        views,
        &problem.targets,
        cfg.loss,
        &problem.pictures,
        &among,
    )?)
}

/// The whole `design` job: optimize, prune, evaluate and (if configured) write the outputs.
/// Progress and warnings go to `obs`.
pub fn run_design(
    ctx: &Arc<Context>,
    problem: &Problem,
    cfg: &DesignConfig,
    obs: &dyn Observer,
) -> Result<DesignReport, OptimError> {
    run_design_live(ctx, problem, cfg, obs, &mut |_, _| Ok(true))
}

/// [`run_design`] with a live hook after each accepted iteration ([`Live`]).
pub fn run_design_live(
    ctx: &Arc<Context>,
    problem: &Problem,
    cfg: &DesignConfig,
    obs: &dyn Observer,
    hook: &mut LiveHook<'_>,
) -> Result<DesignReport, OptimError> {
    if cfg.write_outputs {
        std::fs::create_dir_all(&cfg.out).map_err(|source| {
            OptimError::Io(scratchart_render::io::IoError::Io {
                action: "create output directory",
                path: cfg.out.clone(),
                cause: source,
            })
        })?;
    }
    let renderer = Renderer::new(ctx)?;
    // A design with arcs renders them at its own chords while it runs (summary.json's `arcs`).
    renderer.set_arc_chords(cfg.arcs.map(|a| a.chords));
    let slots = scratchart_render::layout::view_slots(&problem.scene);
    let loss = design_loss(ctx, &slots.views, problem, cfg)?;
    let mut opt = Optimizer::new(&renderer, &loss, problem, cfg)?;
    let resumed_from = start_or_resume(&mut opt, problem, cfg, obs)?;
    let (initial_images, _) = opt.render()?;
    let t_loop = std::time::Instant::now();
    let mut work = problem.clone();
    let (loop_seconds, iters_run) = opt.run_live(obs, &mut work, &loss, &cfg.steer, hook)?;
    // From here on the problem is the steered one (the targets the loss ended with).
    let problem = &work;
    let t_loop_end = std::time::Instant::now();
    let device_bytes = ctx.allocated_bytes();
    let snap = snap_depths_to_machine(ctx, &opt, cfg)?;
    let unpruned = opt.scene(&problem.scene)?;
    let depths = commanded_depths(ctx, &opt, cfg)?;
    let st = &opt.driver.stats;
    let evals = st.evals.max(1) as f64;
    let mean_pairs = st.pairs_sum / evals;
    let gpu_ms: Vec<(String, f64)> = st.gpu_ms.iter().map(|(l, ms)| (l.clone(), ms / evals)).collect();
    let loop_parts = (st.submit_s, st.checkpoint_s, st.hooks_s);
    let history = opt.history();
    let rollbacks = opt.rollbacks().to_vec();
    drop(opt);

    // ... and is judged at four times as many (at least 32), where renders of designs with arcs
    // agree with 128 chords within 0.002 of correlation (engine/docs/model.md section 11), or
    // at the most of 4N, 2N, N that fits the device with every view of the design at once.
    if let Some(a) = &cfg.arcs {
        let mut n = a.judged_chords();
        loop {
            renderer.set_arc_chords(Some(n));
            if n <= a.chords || renderer.fits(&unpruned) {
                break;
            }
            n = (n / 2).max(a.chords);
        }
    }
    // Pruning judges straight scratches only (scratchart_optim::prune): a design with arcs
    // keeps all of its scratches.
    let (scene, prune) = if cfg.prune.enabled() && cfg.arcs.is_none() {
        let (s, st) = scratchart_optim::prune::prune(&renderer, &loss, &unpruned, &cfg.prune, &cfg.adam)?;
        (s, Some(st))
    } else {
        (unpruned.clone(), None)
    };
    let t_pruned = std::time::Instant::now();
    let depths = depths.map(|z| depths_of_kept(&unpruned.scratches, &z, &scene.scratches));
    // Final evaluation and images of the written design.
    let mut gs: GpuScene = renderer.upload(&scene)?;
    let frame = renderer.render(&mut gs)?;
    let final_loss = loss.evaluate(ctx, gs.image(), None)?;
    let final_images: Vec<Vec<f32>> = frame
        .images
        .iter()
        .map(|img| img.iter().map(|&l| scratchart_render::io::display_value(l)).collect())
        .collect();
    let final_render = t_pruned.elapsed().as_secs_f64();
    let mut report = DesignReport {
        scene,
        unpruned,
        history,
        rollbacks,
        prune,
        final_loss,
        loop_seconds,
        iters_run,
        mean_pairs,
        gpu_ms,
        final_images,
        initial_images,
        resumed_from,
        summary: None,
        depths,
        view_weights: loss.view_weights(),
        wall: WallTimes {
            start_up: cfg.started.map_or(0.0, |s| t_loop.duration_since(s).as_secs_f64()),
            iterations: t_loop_end.duration_since(t_loop).as_secs_f64(),
            pruning: t_pruned.duration_since(t_loop_end).as_secs_f64(),
            reports: 0.0,
            final_render,
            set_up_sheet: 0.0,
            sheet: Default::default(),
            iterations_submissions: loop_parts.0,
            iterations_checkpoints: loop_parts.1,
            iterations_hooks: loop_parts.2,
        },
        device_bytes,
    };
    if cfg.write_outputs {
        write_design_outputs(&renderer, problem, cfg, &mut report, snap, t_pruned)?;
    }
    Ok(report)
}

/// Each scratch's commanded depth (mm) where the design has a tool; within a machine, as the
/// grid's own f64 value (the GPU holds it in f32: 0.02 mm would be written 0.0199999996).
fn commanded_depths(ctx: &Arc<Context>, opt: &Optimizer, cfg: &DesignConfig) -> Result<Option<Vec<f64>>, OptimError> {
    let limits = cfg
        .tool
        .as_ref()
        .and_then(|f| f.machine.as_ref().map(|m| (m, &f.table)));
    Ok(match &opt.tool {
        Some(t) => Some(
            t.depths(ctx)?
                .iter()
                .map(|&z| limits.map_or(z as f64, |(m, table)| m.snap(z as f64, table)))
                .collect::<Vec<f64>>(),
        ),
        None => None,
    })
}

/// A new run's start (the lights calibrated when asked) or a resumed one's: the checkpoint
/// loaded, its iteration checked against `--iters`, and a warning where the saved run changed
/// its scratches more often than `--steer` lists. Returns the iteration resumed from.
fn start_or_resume(
    opt: &mut Optimizer,
    problem: &Problem,
    cfg: &DesignConfig,
    obs: &dyn Observer,
) -> Result<Option<u32>, OptimError> {
    if !cfg.resume {
        if cfg.calibrate_lights {
            opt.calibrate_lights(&problem.scene, &problem.targets)?;
        }
        return Ok(None);
    }
    opt.resume()?;
    if opt.next_iter() > cfg.iters {
        return Err(OptimError::Usage(format!(
            "the checkpoint in `{}` is at iteration {}, beyond --iters {}; resume with --iters {} or more",
            cfg.out.display(),
            opt.next_iter(),
            cfg.iters,
            opt.next_iter()
        )));
    }
    let held = opt.driver.times_resized();
    let listed = cfg.steer.iter().filter(|e| e.resizes()).count() as u32;
    if held > listed {
        obs.warn(&format!(
            "the saved run added or removed scratches {held} time(s) ({} scratches now), and --steer lists {listed} such change(s): the design continues from the checkpoint as it is, but its summary.json will not list them; give --steer with the live design's summary.json to keep the record whole",
            opt.driver.gs.n_scratches()
        ));
    }
    Ok(Some(opt.next_iter()))
}

/// Within a machine (`design --machine`): every commanded depth on its Z grid. The optimizer's
/// range already starts at the shallowest trusted cut and ends on the grid; this moves each
/// depth by at most half a step, before pruning and the final evaluation judge the design.
/// Returns (depths moved, the largest move in mm, the loss before, depths), or `None` without a
/// machine.
fn snap_depths_to_machine(
    ctx: &Arc<Context>,
    opt: &Optimizer,
    cfg: &DesignConfig,
) -> Result<Option<(usize, f64, f32, usize)>, OptimError> {
    if let (Some(t), Some(fab)) = (&opt.tool, &cfg.tool) {
        if let Some(limits) = &fab.machine {
            let before = opt.loss()?.total;
            let z = t.depths(ctx)?;
            let snapped: Vec<f32> = z.iter().map(|&v| limits.snap(v as f64, &fab.table) as f32).collect();
            let moved = z.iter().zip(&snapped).filter(|(a, b)| a != b).count();
            let largest = z
                .iter()
                .zip(&snapped)
                .map(|(a, b)| (*a as f64 - *b as f64).abs())
                .fold(0.0, f64::max);
            t.set_depths(ctx, &snapped)?;
            t.apply(ctx, &opt.driver.gs)?;
            return Ok(Some((moved, largest, before, z.len())));
        }
    }
    Ok(None)
}

/// The design's files: design.json (with each scratch's commanded depth where a tool was
/// given), the reports, the machine's summary and error, the walk's plots, the set-up sheet,
/// and summary.json with the wall times (`reports` counted from `t_pruned`).
fn write_design_outputs(
    renderer: &Renderer,
    problem: &Problem,
    cfg: &DesignConfig,
    report: &mut DesignReport,
    snap: Option<(usize, f64, f32, usize)>,
    t_pruned: std::time::Instant,
) -> Result<(), OptimError> {
    // A walk's in-between views were in the loss; the design's files hold its design views.
    let (wp, wr) = crate::walk_report::design_views_only(problem, report);
    let mut summary = crate::report::write_outputs(&cfg.out, &wp, cfg, &wr)?;
    if let (Some(fab), Some(z)) = (&cfg.tool, &report.depths) {
        // The design again, with each scratch's commanded depth as the CSV's column `z_mm`.
        let mut extra = scratchart_model::scene_file::Extra::default();
        extra.set_column("z_mm", z);
        wr.scene
            .save_extra(&cfg.out.join("design.json"), "scratches.csv", &extra)
            .map_err(|e| OptimError::Report(e.to_string()))?;
        summary["fabrication"] = fab.summary(z);
        if let Some(limits) = &fab.machine {
            summary["machine"] = machine_summary(limits, fab, &wr.scene, z, snap, report.final_loss.total);
            if cfg.carvings > 0 {
                summary["machine_error"] =
                    crate::carving::machine_error(renderer, &wp, cfg, fab, limits, &wr.scene, z)?;
            }
        }
    }
    let probe_corr = match &problem.walk {
        Some(w) => crate::walk::judge_probes(renderer, &report.scene, w, cfg.loss.sigma)?,
        None => Vec::new(),
    };
    if let Some((walk, corr)) =
        crate::walk_report::walk_summary(problem, &report.final_images, &probe_corr, cfg.loss.sigma)
    {
        summary["walk"] = walk;
        crate::walk_report::walk_plot_png(&cfg.out.join("walk.png"), problem, &corr, &probe_corr)?;
        crate::walk_report::walk_sheet_png(&cfg.out.join("walk_sheet.png"), problem, &report.final_images)?;
    }
    // Where the lamp and the viewers go, and how precisely (setup.txt, setup.png).
    // Its inputs go beside the design first, so `scratchart setup` computes the same sheet.
    let inputs = crate::tolerance::SheetInputs {
        targets: wp.targets.clone(),
        pictures: wp.pictures.clone(),
        sigma: cfg.loss.sigma,
        blank_views: cfg.blank_views.clone(),
    };
    inputs.save(&cfg.out, &wr.scene)?;
    let t_sheet = std::time::Instant::now();
    let (setup, sensitivity, advice, sheet) = crate::setup::write_setup(&cfg.out, renderer, &wr.scene, &inputs)?;
    report.wall.set_up_sheet = t_sheet.elapsed().as_secs_f64();
    report.wall.sheet = sheet;
    if !problem.steering.is_empty() {
        summary["steering"] = json!(problem.steering);
        summary["steering_is"] =
            json!("what was changed while the design ran (pictures moved, loss weights, scratches added or removed): `scratchart design [the same flags] --steer summary.json` replays it");
    }
    if let Some(a) = &cfg.arcs {
        summary["arcs"] = crate::arcs::summary(a, renderer.arc_chords().unwrap_or(a.chords), &report.scene);
    }
    summary["blank_views"] = json!(cfg.blank_views);
    if cfg.balance {
        summary["balance"] = json!({
            "view_weights": report.view_weights,
            "rule": "each view's weight follows its shortfall against what its picture allows (clamped to 0.5..3, mean 1), updated every tenth of the run from 30% on (engine/design/src/balance.rs)",
        });
    }
    summary["setup"] = setup;
    summary["sensitivity"] = sensitivity;
    summary["setup_advice"] = json!(advice);
    report.wall.reports = t_pruned.elapsed().as_secs_f64();
    summary["wall_s"] = report.wall.to_json();
    scratchart_render::io::write_atomic(
        &cfg.out.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .expect("the summary always serializes")
            .as_bytes(),
    )?;
    report.summary = Some(summary);
    Ok(())
}

/// `summary.json`'s `machine`: the limits a `design --machine` kept and how many scratches each
/// touched (at the shallowest cut, at the shortest length, moved onto the Z grid).
fn machine_summary(
    limits: &scratchart_optim::tool_params::MachineLimits,
    fab: &scratchart_optim::tool_params::Fabrication,
    scene: &Scene,
    depths: &[f64],
    snap: Option<(usize, f64, f32, usize)>,
    final_loss: f32,
) -> Value {
    let m = &limits.profile;
    let at_min_depth = depths
        .iter()
        .filter(|&&z| (z - fab.table.z_lo).abs() < 0.5 * m.z_step_mm)
        .count();
    let lengths: Vec<f64> = scene
        .scratches
        .iter()
        .map(|s| (s.p1[0] - s.p0[0]).hypot(s.p1[1] - s.p0[1]))
        .collect();
    let at_min_length = lengths.iter().filter(|&&l| l < limits.min_length_mm + 3e-4).count();
    let shortest = lengths.iter().cloned().fold(f64::INFINITY, f64::min);
    let off_grid = depths
        .iter()
        .filter(|&&z| ((z / m.z_step_mm).round() * m.z_step_mm - z).abs() > 1e-6)
        .count();
    let shallowest_cut = depths.iter().cloned().fold(f64::INFINITY, f64::min) + fab.tool.z_offset_mm();
    let (snapped, largest_snap, loss_before, optimized) = snap.unwrap_or((0, 0.0, f32::NAN, depths.len()));
    // The job as `scratchart-cal plan` makes it by default for this machine (the +x mark and
    // the registration marks included): the planner's estimate.
    let t = crate::job_time::job_time(scene, depths, m);
    json!({
        "job_min": t.split.total() / 60.0,
        "job_min_upper_bound": t.upper_s / 60.0,
        "job_time_shares": t.split.shares(),
        "job_includes": "the design's scratches, the +x mark and the registration marks (the calibration card's six \
             hatched squares, by which scratchart-cal inspect finds the plate in photos), as scratchart-cal plan \
             carves them by default; plan --no-marks leaves the registration marks out",
        "registration_marks_min": t.registration_s / 60.0,
        "registration_hatch_cuts": t.hatch_cuts,
        "profile": limits.source,
        "firmware": m.firmware,
        "min_cut_depth_mm": m.min_cut_depth_mm,
        "z_step_mm": m.z_step_mm,
        "z_repeatability_mm": m.z_repeatability_mm,
        "min_length_mm": limits.min_length_mm,
        "min_length_from": limits.min_length_from,
        "z_range_mm": [fab.table.z_lo, fab.table.z_hi],
        "scratches": depths.len(),
        "scratches_optimized": optimized,
        "at_min_cut_depth": at_min_depth,
        "at_min_length": at_min_length,
        "moved_onto_z_grid": snapped,
        "moved_onto_z_grid_counts": "of the scratches optimized, before pruning",
        "largest_z_grid_move_um": 1e3 * largest_snap,
        "loss_before_z_grid": loss_before,
        "loss_final": final_loss,
        "off_z_grid": off_grid,
        "shallowest_cut_below_surface_mm": shallowest_cut,
        "shortest_scratch_mm": shortest,
    })
}
