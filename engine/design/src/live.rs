//! A live design (`scratchart-view --design`): what its hook sees after each accepted
//! iteration ([`Live`]: the running optimizer, to read), and the changes it may make between two
//! iterations, each recorded in the problem's `steering` ([`crate::steer`]): a picture moved or
//! scaled, the loss's weights, scratches added or removed.
use scratchart_model::scene::{Scene, Scratch};
use scratchart_render::layout::ScratchGpu;
use scratchart_render::Renderer;
use scratchart_vulkan::GpuError;

use crate::problem::Problem;
use scratchart_optim::driver::Driver;
use scratchart_optim::error::OptimError;
use scratchart_optim::loss::Loss;

/// What a live design's hook sees after each accepted iteration (`scratchart-view --design`):
/// the running optimizer, to read (never to change: a run with a hook gives the same bits).
pub struct Live<'a, 'r> {
    pub driver: &'a mut Driver<'r>,
    pub renderer: &'r Renderer,
    /// The problem as the run goes: its scene (plate, views, lights as they started) and its
    /// targets, steered ones included ([`Live::steer`]).
    pub problem: &'a mut Problem,
    pub loss: &'a Loss,
    pub keep_exposures: bool,
    /// The design's output directory.
    pub out: &'a std::path::Path,
    /// The optimizer's learning rates (what ranks scratches for removal).
    pub adam: &'a scratchart_optim::adam::AdamConfig,
    /// Whether scratches can be added or removed (not in fabrication mode, whose depths are a
    /// parameter set of their own).
    pub resizable: bool,
}

/// Called after each accepted iteration of a live design; `Ok(false)` ends the optimization
/// there (pruning, the final evaluation and the outputs follow as after the last iteration).
pub type LiveHook<'h> = dyn FnMut(&mut Live, &scratchart_optim::driver::Evaluation) -> Result<bool, OptimError> + 'h;

impl Live<'_, '_> {
    /// The next iteration to run (the iterations evaluated so far).
    pub fn iteration(&self) -> u32 {
        self.driver.next_iter()
    }

    /// The design as it stands (parameters and light intensities read back).
    pub fn scene(&self) -> Result<Scene, GpuError> {
        read_design(
            &self.renderer.ctx,
            &self.driver.gs,
            &self.problem.scene,
            self.keep_exposures,
        )
    }

    /// Each view's last render (linear L, the evaluation just accepted).
    pub fn images(&self) -> Result<Vec<Vec<f32>>, GpuError> {
        self.renderer.download_images(&self.driver.gs)
    }

    /// Moves or scales view `view`'s picture from this iteration on (see [`crate::steer`]):
    /// placed again from its file, the loss's targets replaced, the event recorded in the
    /// problem's `steering`. A view that cannot be steered is a [`OptimError::Usage`].
    pub fn steer(&mut self, view: &str, shift_px: [f64; 2], scale: f64) -> Result<(), OptimError> {
        self.steer_event(crate::steer::SteerEvent::picture(
            self.iteration(),
            view,
            shift_px,
            scale,
        ))
    }

    /// Changes the loss's weights (the pixel and Gram terms'; None keeps one) from this
    /// iteration on, recorded in the problem's `steering`.
    pub fn steer_weights(&mut self, lambda_p: Option<f64>, lambda_g: Option<f64>) -> Result<(), OptimError> {
        self.steer_event(crate::steer::SteerEvent::weights(self.iteration(), lambda_p, lambda_g))
    }

    /// The scratches of the design as it stands.
    pub fn n_scratches(&self) -> u32 {
        self.driver.gs.n_scene_scratches()
    }

    /// Removes the `n` scratches that matter least now (the pruning's ranking: how far the
    /// last gradient would move each, ties by index) from this iteration on, recorded in the
    /// problem's `steering` with their indices. At least one scratch stays.
    pub fn remove_scratches(&mut self, n: u32) -> Result<(), OptimError> {
        let have = self.n_scratches();
        let n = n.min(have.saturating_sub(1));
        if n == 0 {
            return Err(OptimError::Usage(format!(
                "cannot remove scratches: the design has {have}, and one must stay"
            )));
        }
        let g: Vec<[f32; 8]> = self.renderer.ctx.download(self.driver.gs.scratch_grad())?;
        let imp = scratchart_optim::prune::importance(&g[..have as usize], self.adam);
        let mut order: Vec<(f64, u32)> = imp.into_iter().zip(0..).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut idx: Vec<u32> = order[..n as usize].iter().map(|o| o.1).collect();
        idx.sort_unstable();
        self.steer_event(crate::steer::SteerEvent::scratches(self.iteration(), idx, 0, 0))
    }

    /// Adds `n` scratches, drawn as the design drew its first ones, from this iteration on,
    /// recorded in the problem's `steering` with the random stream they were drawn from.
    pub fn add_scratches(&mut self, n: u32) -> Result<(), OptimError> {
        // One stream per (iteration, event): a replay draws the same scratches.
        let seed = 0x5eed_0000_0000u64 ^ ((self.iteration() as u64) << 16) ^ self.problem.steering.len() as u64;
        self.steer_event(crate::steer::SteerEvent::scratches(
            self.iteration(),
            Vec::new(),
            n,
            seed,
        ))
    }

    /// Removes and adds scratches as `e` says: the design read back, the removed ones left
    /// out, the new ones drawn after the rest, uploaded again, and the optimizer's state
    /// carried over ([`Driver::replace_scene`]).
    fn resize(&mut self, e: &crate::steer::SteerEvent) -> Result<(), OptimError> {
        if !self.resizable {
            return Err(OptimError::Usage(
                "scratches cannot be added or removed in fabrication mode (--tool: each has a depth of its own) \
                 or with --arcs (each is laid out as its chords on the device)"
                    .into(),
            ));
        }
        let have = self.n_scratches();
        let current = self.scene()?;
        let mut gone = vec![false; have as usize];
        for &i in e.remove.iter().flatten() {
            if i >= have {
                return Err(OptimError::Usage(format!(
                    "steering at iteration {}: there is no scratch {i} to remove (the design has {have})",
                    e.iteration
                )));
            }
            gone[i as usize] = true;
        }
        let mut remap: Vec<Option<u32>> = (0..have).filter(|&i| !gone[i as usize]).map(Some).collect();
        let mut scratches: Vec<Scratch> = remap.iter().map(|i| current.scratches[i.unwrap() as usize]).collect();
        if let Some(n) = e.add {
            let init = self.problem.init.ok_or_else(|| {
                OptimError::Usage(
                    "this design cannot add scratches: it does not say how its first ones were drawn".into(),
                )
            })?;
            if scratches.len() as u64 + n as u64 > crate::steer::MAX_SCRATCHES as u64 {
                return Err(OptimError::Usage(format!(
                    "steering at iteration {}: more than {} scratches",
                    e.iteration,
                    crate::steer::MAX_SCRATCHES
                )));
            }
            let mut rng = crate::scenes::Rng::new(e.seed.unwrap_or(0));
            scratches.extend(crate::scenes::random_scratches(
                &mut rng,
                n as usize,
                self.problem.scene.plate.size_mm,
                init.len_mm.0,
                init.len_mm.1,
                init.w,
                init.d,
                init.alpha,
            ));
            remap.extend(std::iter::repeat_n(None, n as usize));
        }
        if scratches.is_empty() {
            return Err(OptimError::Usage(format!(
                "steering at iteration {}: no scratch would be left",
                e.iteration
            )));
        }
        let mut scene = current;
        scene.scratches = scratches;
        // The device's limits, as for any scene the design uploads: a set that does not fit is
        // refused and the run goes on with the one it has (nothing was changed yet).
        let gs = self.renderer.upload(&scene).map_err(|err| match err {
            GpuError::BufferTooLarge { .. }
            | GpuError::OutOfMemory { .. }
            | GpuError::Allocation { .. }
            | GpuError::Capacity(_) => OptimError::Usage(format!(
                "steering at iteration {}: {} scratches do not fit this device ({err}); the design keeps its {have}",
                e.iteration,
                scene.scratches.len()
            )),
            other => other.into(),
        })?;
        self.driver.replace_scene(gs, &remap, ("scratches", 8))
    }

    /// Applies `e` now, recorded as it is (a replayed event keeps its own iteration, also when
    /// a resumed run applies it before its first iteration).
    fn steer_event(&mut self, e: crate::steer::SteerEvent) -> Result<(), OptimError> {
        self.steer_event_with(e, true)
    }

    /// [`steer_event`](Self::steer_event); `resize` false records a change of the scratches
    /// without making it (the state already holds it: a resumed run).
    fn steer_event_with(&mut self, e: crate::steer::SteerEvent, resize: bool) -> Result<(), OptimError> {
        let view =
            crate::steer::check(&e, &self.problem.scene.views, &self.problem.sources).map_err(OptimError::Usage)?;
        if e.resizes() && resize {
            self.resize(&e)?;
        }
        if let Some(v) = view {
            let src = self.problem.sources[v].as_ref().expect("checked");
            let f = src.place(
                &self.problem.scene.views[v],
                &self.problem.scene.plate,
                e.shift(),
                e.scale(),
            );
            self.problem.targets[v] = f.image;
            self.problem.pictures[v] = f.picture;
            self.problem.picture_rects[v] = f.rect;
            self.loss.set_pictures(&self.renderer.ctx, &self.problem.pictures)?;
            self.loss.set_targets(&self.renderer.ctx, &self.problem.targets)?;
        }
        if e.lambda_p.is_some() || e.lambda_g.is_some() {
            let (p, g) = self.loss.weights();
            self.loss
                .set_weights(e.lambda_p.map_or(p, |x| x as f32), e.lambda_g.map_or(g, |x| x as f32));
        }
        self.problem.steering.push(e);
        Ok(())
    }

    /// Applies the scheduled events from `next` on that are due at this iteration; the first
    /// `skip` that change the scratches are only recorded (the state holds them).
    pub(super) fn apply_due(
        &mut self,
        scheduled: &[crate::steer::SteerEvent],
        next: &mut usize,
        skip: &mut u32,
    ) -> Result<(), OptimError> {
        while let Some(e) = scheduled.get(*next).filter(|e| e.iteration <= self.iteration()) {
            let held = e.resizes() && *skip > 0;
            if held {
                *skip -= 1;
            }
            self.steer_event_with(e.clone(), !held)?;
            *next += 1;
        }
        Ok(())
    }

    /// Saves the run where it stands into the output directory: the checkpoint that `scratchart
    /// design --resume` continues bit for bit, and design.json + scratches.csv of the design as
    /// it is (not pruned).
    pub fn save(&self) -> Result<(), OptimError> {
        std::fs::create_dir_all(self.out).map_err(|source| {
            OptimError::Io(scratchart_render::io::IoError::Io {
                action: "create output directory",
                path: self.out.to_path_buf(),
                cause: source,
            })
        })?;
        self.driver.save_checkpoint(self.out)?;
        self.scene()?
            .save(&self.out.join("design.json"), "scratches.csv")
            .map_err(|e| OptimError::Report(e.to_string()))
    }
}

/// The design on the device as a scene: its scratches (a scene whose scratches bend: the arcs'
/// own, each bulge made legal by [`scratchart_model::scene_file::legal_bulge`]) and its lights, with
/// `template`'s plate and views ([`to_scene`]).
pub fn read_design(
    ctx: &std::sync::Arc<scratchart_vulkan::Context>,
    gs: &scratchart_render::GpuScene,
    template: &Scene,
    keep_exposures: bool,
) -> Result<Scene, GpuError> {
    let phi: Vec<f32> = gs.lights().read()?;
    let n = gs.n_scene_scratches() as usize;
    match gs.arc_params() {
        Some(arcs) => {
            let scr: Vec<ScratchGpu> = ctx.download(arcs)?;
            let mut scene = to_scene(template, &scr[..n], &phi, keep_exposures);
            let plate = scene.plate.size_mm;
            for (s, g) in scene.scratches.iter_mut().zip(&scr) {
                s.bulge = g.shape[3] as f64;
                s.bulge = scratchart_model::scene_file::legal_bulge(s, plate);
            }
            Ok(scene)
        }
        None => {
            let scr: Vec<ScratchGpu> = ctx.download(gs.scratches())?;
            Ok(to_scene(template, &scr[..n], &phi, keep_exposures))
        }
    }
}

/// Builds a scene from GPU parameters: `template`'s plate and views with the lights' optimized
/// radiance scales `phi` (one per view: intensity times exposure), split into one intensity per
/// lamp and an exposure per view ([`Scene::set_radiance`]; `keep_exposures` where the optimizer
/// kept each lamp's views tied).
pub fn to_scene(template: &Scene, scr: &[ScratchGpu], phi: &[f32], keep_exposures: bool) -> Scene {
    let mut scene = template.clone();
    scene.scratches = scr
        .iter()
        .map(|s| Scratch {
            p0: [s.ends[0] as f64, s.ends[1] as f64],
            p1: [s.ends[2] as f64, s.ends[3] as f64],
            w: s.shape[0] as f64,
            d: s.shape[1] as f64,
            alpha: s.shape[2] as f64,
            bulge: 0.0,
        })
        .collect();
    let r: Vec<f64> = phi.iter().map(|&p| p as f64).collect();
    scene.set_radiance(&r, keep_exposures);
    scene
}
