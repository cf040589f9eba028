//! Fabrication mode (`scratchart design --tool tool.json`, engine/docs/model.md section 7): every scratch
//! gets one commanded carve depth z in place of (w, d, alpha); its groove is what the calibrated
//! tool cuts at z (`scratchart_tool::Tool::model`), with alpha fixed.
//!
//! The parameter set's blocks: the scratches (endpoints optimized as in [`SceneParams`]; w, d
//! and alpha frozen in Adam, since the map writes them), the depths (one f32 per scratch, its own
//! buffer and checkpoint chunk `depths`, bounded to [z_lo, z_hi]) and the lights (as in
//! [`SceneParams`]). `record_to_scene` runs `shaders/tool_map.comp`, which writes each scratch's
//! (w, d, alpha) from its z; `record_grad` runs it in its second mode, the chain rule
//! dE/dz = dE/dw dw/dz + dE/dd dd/dz with the slopes of the table segment used (the exact
//! derivative of the piecewise-linear map). After each step the minimum-length projection of
//! [`SceneParams`] runs, and the map again, so the scene always holds the grooves of the current
//! depths.
//!
//! **The depth range.** z_first is where the tool first reaches the plate (found by bisection on
//! `Tool::model`, to 1e-15 mm, then rounded to f32); z_lo = z_first + 1 um; z_hi is where the
//! groove's visible width W reaches the design's largest w (0.2 mm), or the real depth reaches the
//! design's largest d (0.2 mm), whichever comes first (for a measured profile, at most its last
//! point: beyond it the width no longer changes).
//!
//! **The table.** `Tool::model` is a least-squares fit (about 1 ms on a CPU core), so the curve is
//! sampled once on the host at [`TABLE_SAMPLES`] points equally spaced in s = sqrt(z - z_first)
//! (dense near first contact, where a ball's width grows like sqrt(z) and a flat-tipped V-bit's
//! fitted w changes fastest) and interpolated linearly in s. Its error against `Tool::model` is
//! measured when the table is built, at the midpoint of every segment (and at a measured
//! profile's corners, where a segment's error peaks), and reported
//! ([`ToolTable::max_rel_err`], in `summary.json`). Measured (`tests/fabrication.rs`,
//! `table_error_of_every_tool_kind`, which also checks other points against it), relative to
//! `Tool::model`'s w and d: V-bit 60 degrees with a 0.02 mm flat: w 3.3e-4, d 1.2e-4; V-bit 90
//! degrees, no flat, offset -0.01 mm: 7.6e-5 (w and d); ball of radius 0.1 mm: w 4.1e-6, d 1.6e-4;
//! tapered ball 0.03 mm, 30 degrees: w 1.4e-5, d 1.6e-4; a 3-point measured profile: 2.6e-4 (at
//! a corner). The GPU evaluates the same interpolation in f32 (the tests allow 1e-5 relative
//! for its rounding on top of the bound). A grid uniform in z was worse near first contact
//! (1.5e-2 for the flat-tipped V-bit).
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use serde_json::{json, Value};

use scratchart_tool::machine::MachineProfile;
use scratchart_tool::{Tool, ToolError};

use super::adam::{AdamConfig, AdamGroup, ParamBlock};
use super::driver::{Evaluation, Objective, ParamSet};
use super::scene_params::SceneParams;
use crate::model::scene::Scratch;
use crate::render::{GpuScene, Renderer};
use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler};

pub mod table;
use table::ToolTable;

/// Samples of the tool's curve in the table.
pub const TABLE_SAMPLES: usize = 512;
/// z_lo - z_first: the shallowest cut used, mm (1 um).
pub const FIRST_CUT_MM: f64 = 1e-3;

/// `#[repr(C)]` twin of the push block in `shaders/inc/tool_map_push.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ToolMapPush {
    pub n_scratches: u32,
    pub n_table: u32,
    pub mode: u32,
    pub seed: u32,
    pub z_first: f32,
    pub s_lo: f32,
    pub inv_ds: f32,
    pub alpha: f32,
    pub sigma_z: f32,
    pub sigma_xy: f32,
    pub pad0: u32,
    pub pad1: u32,
}

/// A design that survives the machine's error (`design --robust`): every step's gradient is
/// taken on a carving perturbed as the machine would cut it (each scratch's commanded depth
/// off by a normal error of `sigma_z_mm`, each endpoint by `sigma_xy_mm` per axis; a new
/// carving each iteration, drawn from `seed` and the iteration's number, so a resumed run draws
/// the same ones). The last iteration (the evaluation the design is judged by) is exact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Robust {
    pub sigma_z_mm: f64,
    pub sigma_xy_mm: f64,
    pub seed: u32,
}

/// What fabrication mode needs: the tool, where it came from, the fixed alpha, the depth's
/// learning rate and the sampled curve.
#[derive(Clone, Debug)]
pub struct Fabrication {
    pub tool: Tool,
    /// The tool file, as given.
    pub source: String,
    pub alpha: f64,
    /// Where alpha came from (for the summary).
    pub alpha_from: String,
    /// Learning rate of z, mm per step.
    pub lr_z: f32,
    pub table: ToolTable,
    /// The machine the design is carved on (`design --machine`), when given.
    pub machine: Option<MachineLimits>,
    /// Trains on carvings perturbed by the machine's repeatability (`design --robust`).
    pub robust: Option<Robust>,
}

/// Why a tool makes no fabrication-mode design.
#[derive(Debug, thiserror::Error)]
pub enum FabricationError {
    /// The tool file cannot be read or holds no tool.
    #[error(transparent)]
    Tool(#[from] ToolError),
    /// The tool (or the tool within the machine's limits) cuts no groove the design can use, or
    /// its roughness is out of range: the message names the file and the value.
    #[error("{0}")]
    Unusable(String),
    /// A combination the design cannot make (a robust design without the machine).
    #[error("{0}")]
    Usage(String),
}

impl scratchart_exit::ExitClass for FabricationError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        match self {
            FabricationError::Tool(e) => e.exit_class(),
            FabricationError::Unusable(_) => Some(scratchart_exit::Class::Input),
            FabricationError::Usage(_) => Some(scratchart_exit::Class::Usage),
        }
    }
}

/// What `design --machine` keeps every scratch within.
#[derive(Clone, Debug)]
pub struct MachineLimits {
    pub profile: MachineProfile,
    /// Where the profile came from (the built-in one's name, or the file).
    pub source: String,
    /// The shortest scratch, mm, and where that number came from.
    pub min_length_mm: f64,
    pub min_length_from: String,
}

impl MachineLimits {
    /// `z` on the machine's Z grid and inside the table's range (whose ends lie on it).
    pub fn snap(&self, z: f64, table: &ToolTable) -> f64 {
        let step = self.profile.z_step_mm;
        ((z / step).round() * step).clamp(table.z_lo, table.z_hi)
    }
}

impl Fabrication {
    /// Samples `tool` for a design whose scratch bounds are `adam`'s (largest w and d).
    pub fn new(
        tool: Tool,
        source: &str,
        alpha: f64,
        alpha_from: &str,
        lr_z: f32,
        adam: &AdamConfig,
    ) -> Result<Fabrication, FabricationError> {
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(FabricationError::Unusable(format!(
                "the groove roughness alpha = {alpha} must lie strictly between 0 and 1"
            )));
        }
        let table = ToolTable::new(&tool, adam.w_bounds.1 as f64, adam.d_bounds.1 as f64, TABLE_SAMPLES)
            .map_err(FabricationError::Unusable)?;
        Ok(Fabrication {
            tool,
            source: source.to_string(),
            alpha,
            alpha_from: alpha_from.to_string(),
            lr_z,
            table,
            machine: None,
            robust: None,
        })
    }

    /// The same tool within a machine's limits: the depth range starts at the machine's
    /// shallowest trusted cut and both its ends lie on the Z grid.
    pub fn with_machine(mut self, limits: MachineLimits, adam: &AdamConfig) -> Result<Fabrication, FabricationError> {
        self.table = ToolTable::within(
            &self.tool,
            adam.w_bounds.1 as f64,
            adam.d_bounds.1 as f64,
            TABLE_SAMPLES,
            Some(&limits.profile),
        )
        .map_err(|e| FabricationError::Unusable(format!("within the machine's limits ({}): {e}", limits.source)))?;
        self.machine = Some(limits);
        Ok(self)
    }

    /// Trains on carvings perturbed by the machine's repeatability (its profile's
    /// `z_repeatability_mm` and `xy_repeatability_mm`); needs [`with_machine`](Self::with_machine).
    pub fn with_robust(mut self, seed: u32) -> Result<Fabrication, FabricationError> {
        let m = self.machine.as_ref().ok_or_else(|| {
            FabricationError::Usage("a robust design needs the machine whose error it survives (--machine)".into())
        })?;
        self.robust = Some(Robust {
            sigma_z_mm: m.profile.z_repeatability_mm,
            sigma_xy_mm: m.profile.xy_repeatability_mm,
            seed,
        });
        Ok(self)
    }

    /// The widest groove the tool cuts in the design's depth range (its visible width), mm.
    pub fn widest_groove_mm(&self) -> f64 {
        self.tool.section(self.table.z_hi).map_or(0.0, |s| s.width)
    }

    /// Reads `tool.json` and samples it; alpha is the file's `alpha` when it has one, else
    /// `default_alpha` (named by `default_from`). The error names the file.
    pub fn load(
        path: &Path,
        default_alpha: f64,
        default_from: &str,
        lr_z: f32,
        adam: &AdamConfig,
    ) -> Result<Fabrication, FabricationError> {
        let (tool, fitted) = Tool::load_fitted(path)?;
        let (alpha, from) = match fitted.alpha {
            Some(a) => (a, format!("{} (fitted)", path.display())),
            None => (default_alpha, default_from.to_string()),
        };
        Fabrication::new(tool, &path.display().to_string(), alpha, &from, lr_z, adam)
            .map_err(|e| FabricationError::Unusable(format!("tool file `{}` cannot be used: {e}", path.display())))
    }

    /// What a checkpoint must agree with.
    pub fn fingerprint(&self) -> Value {
        let mut f = json!({
            "tool": self.tool.to_json(), "alpha": self.alpha, "lr_z": self.lr_z,
            "z_range": [self.table.z_lo, self.table.z_hi], "samples": self.table.samples.len(),
            "machine": self.machine.as_ref().map(|m| json!({"profile": m.profile.to_json(), "min_length_mm": m.min_length_mm})),
        });
        // (only where set: checkpoints of designs without it stay valid)
        if let Some(r) = self.robust {
            f["robust"] = json!([r.sigma_z_mm, r.sigma_xy_mm, r.seed]);
        }
        f
    }

    /// The `fabrication` entry of `summary.json`; `depths` are the written scratches' z.
    pub fn summary(&self, depths: &[f64]) -> Value {
        let (lo, hi) = depths
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| (a.min(z), b.max(z)));
        json!({
            "tool_file": self.source,
            "tool": serde_json::from_str::<Value>(&self.tool.to_json()).unwrap_or(Value::Null),
            "alpha": self.alpha,
            "alpha_from": self.alpha_from,
            "z_first_contact_mm": self.table.z_first,
            "z_range_mm": [self.table.z_lo, self.table.z_hi],
            "z_written_mm": [lo, hi],
            "lr_z_mm": self.lr_z,
            "table_samples": self.table.samples.len(),
            "table_max_rel_err_w": self.table.max_rel_err[0],
            "table_max_rel_err_d": self.table.max_rel_err[1],
        })
    }
}

/// Scratches with one carve depth each, and lights, as a parameter set (see the module doc).
pub struct ToolParams {
    scene: SceneParams,
    cfg: AdamConfig,
    fab: Fabrication,
    map: ComputePipeline,
    table: Buffer,
    depths: Buffer,
    depth_grad: Buffer,
    /// The exact endpoints while a perturbed carving is in the scene (`--robust`).
    saved: Buffer,
    robust: Option<Robust>,
    /// The perturbed carving of this iteration: its seed + 1, or 0 for the exact one (set by
    /// [`ParamSet::begin_iteration`]; atomic so that a shared set stays `Sync`).
    carving: AtomicU32,
    n: u32,
    /// Scratches may bend (`design --arcs --tool`): the scene was uploaded with
    /// `Renderer::upload_bendable`, and the bulge moves as in [`ArcParams`](super::arc_params::ArcParams).
    arcs: Option<super::arc_params::ArcConfig>,
}

/// The scratches the set moves and their gradients in `gs` (a scene whose scratches bend: the
/// arcs' own buffers), and how many.
fn scratch_buffers(gs: &GpuScene) -> (&Buffer, &Buffer, u32) {
    match (gs.arc_params(), gs.arc_grad()) {
        (Some(p), Some(g)) => (p, g, gs.n_scene_scratches()),
        _ => (gs.scratches(), gs.scratch_grad(), gs.n_scratches()),
    }
}

impl ToolParams {
    /// Uploads the table and the initial depths: each scratch's (w, d) mapped to the nearest
    /// point of the curve ([`ToolTable::nearest_depth`]).
    pub fn new(
        ctx: &Arc<Context>,
        cfg: &AdamConfig,
        fab: &Fabrication,
        scratches: &[Scratch],
    ) -> Result<ToolParams, GpuError> {
        let mut cache: Vec<([u64; 2], f32)> = Vec::new();
        let mut z = Vec::with_capacity(scratches.len());
        for s in scratches {
            let key = [s.w.to_bits(), s.d.to_bits()];
            let v = match cache.iter().find(|c| c.0 == key) {
                Some(c) => c.1,
                None => {
                    let v = fab.table.nearest_depth(s.w, s.d) as f32;
                    if cache.len() < 64 {
                        cache.push((key, v));
                    }
                    v
                }
            };
            z.push(v);
        }
        Self::with_depths(ctx, cfg, fab, &z)
    }

    /// As [`new`](Self::new) with the given initial depths (mm).
    pub fn with_depths(
        ctx: &Arc<Context>,
        cfg: &AdamConfig,
        fab: &Fabrication,
        depths: &[f32],
    ) -> Result<ToolParams, GpuError> {
        let n = depths.len() as u32;
        let tab: Vec<[f32; 2]> = fab.table.samples.iter().map(|g| [g[0] as f32, g[1] as f32]).collect();
        let push = std::mem::size_of::<ToolMapPush>() as u32;
        let sc = ShaderCompiler::embedded()?;
        let zeros = vec![0f32; depths.len().max(1)];
        let mut z = depths.to_vec();
        z.resize(depths.len().max(1), fab.table.z_lo as f32);
        Ok(ToolParams {
            scene: SceneParams::new(ctx, cfg)?,
            cfg: *cfg,
            fab: fab.clone(),
            map: ComputePipeline::new(ctx, &sc, "tool_map.comp", &[], 6, push)?,
            table: ctx.upload("tool table", &tab)?,
            depths: ctx.upload("depths", &z)?,
            depth_grad: ctx.upload("depth gradient", &zeros)?,
            saved: Buffer::new(ctx, "exact endpoints", 16, MemLoc::GpuOnly)?,
            robust: None,
            carving: AtomicU32::new(0),
            n,
            arcs: None,
        })
    }

    /// Lets the scratches bend: for a scene uploaded with `Renderer::upload_bendable`.
    pub fn with_arcs(mut self, arcs: super::arc_params::ArcConfig) -> ToolParams {
        self.arcs = Some(arcs);
        self
    }

    /// Trains on perturbed carvings (see [`Robust`]).
    pub fn with_robust(mut self, ctx: &Arc<Context>, robust: Robust) -> Result<ToolParams, GpuError> {
        self.saved = Buffer::new(ctx, "exact endpoints", 16 * self.n.max(1) as u64, MemLoc::GpuOnly)?;
        self.robust = Some(robust);
        Ok(self)
    }

    pub fn fabrication(&self) -> &Fabrication {
        &self.fab
    }

    pub fn depths_buffer(&self) -> &Buffer {
        &self.depths
    }

    /// The current depths (mm), one per scratch.
    pub fn depths(&self, ctx: &Arc<Context>) -> Result<Vec<f32>, GpuError> {
        let mut z: Vec<f32> = ctx.download(&self.depths)?;
        z.truncate(self.n as usize);
        Ok(z)
    }

    /// Replaces the depths (mm), one per scratch.
    pub fn set_depths(&self, ctx: &Arc<Context>, z: &[f32]) -> Result<(), GpuError> {
        assert_eq!(z.len(), self.n as usize, "one depth per scratch");
        let tmp = ctx.upload("depths (new)", z)?;
        let mut rec = Recorder::new(ctx)?;
        rec.begin()?;
        rec.copy(&tmp, &self.depths, tmp.size());
        rec.barrier();
        rec.submit_and_wait()?;
        Ok(())
    }

    /// The push block of `mode`; `perturbed` draws this iteration's carving (when there is one).
    fn push(&self, mode: u32, perturbed: bool) -> ToolMapPush {
        let t = &self.fab.table;
        let carving = self.carving.load(Ordering::Relaxed);
        let (sigma_z, sigma_xy) = match self.robust {
            Some(r) if perturbed && carving > 0 => (r.sigma_z_mm as f32, r.sigma_xy_mm as f32),
            _ => (0.0, 0.0),
        };
        ToolMapPush {
            n_scratches: self.n,
            n_table: t.samples.len() as u32,
            mode,
            seed: carving.wrapping_sub(1),
            z_first: t.z_first as f32,
            s_lo: t.s_lo as f32,
            inv_ds: (1.0 / t.ds) as f32,
            alpha: self.fab.alpha as f32,
            sigma_z,
            sigma_xy,
            pad0: 0,
            pad1: 0,
        }
    }

    /// The seed of the perturbed carving of iteration `k` of a run drawn from `seed`.
    pub fn carving_seed(seed: u32, k: u32) -> u32 {
        seed.wrapping_mul(0x9E37_79B9) ^ k.wrapping_mul(0x85EB_CA6B) ^ 0x5bd1_e995
    }

    fn record_map(&self, rec: &mut Recorder, gs: &GpuScene, mode: u32) {
        self.record_map_as(rec, gs, mode, false)
    }

    fn record_map_as(&self, rec: &mut Recorder, gs: &GpuScene, mode: u32, perturbed: bool) {
        let (scratches, grad, n) = scratch_buffers(gs);
        assert_eq!(n, self.n, "the depths belong to another scene");
        let bufs = [
            scratches,
            &self.depths,
            &self.table,
            grad,
            &self.depth_grad,
            &self.saved,
        ];
        rec.dispatch_1d(
            &self.map,
            &bufs,
            bytemuck::bytes_of(&self.push(mode, perturbed)),
            self.n.div_ceil(256),
        );
        rec.barrier();
    }

    /// Writes the grooves of the current depths into `gs` (one submission).
    pub fn apply(&self, ctx: &Arc<Context>, gs: &GpuScene) -> Result<(), GpuError> {
        let mut rec = Recorder::new(ctx)?;
        rec.begin()?;
        self.record_map(&mut rec, gs, 0);
        rec.submit_and_wait()?;
        Ok(())
    }

    /// Maps the depths, renders `gs` and evaluates `objective`; with `grad`, also dE/dz per
    /// scratch (the renderer's backward and the chain rule), downloaded.
    pub fn evaluate(
        &self,
        renderer: &Renderer,
        gs: &mut GpuScene,
        objective: &dyn Objective,
        grad: bool,
    ) -> Result<(Evaluation, Option<Vec<f32>>), GpuError> {
        renderer.prepare_backward_of(gs)?;
        let mut rec = Recorder::new(&renderer.ctx)?;
        renderer.submit(&mut rec, gs, |rec, gs| {
            self.record_map(rec, gs, 0);
            renderer.record_render(rec, gs);
            objective.record_forward(rec, gs);
            if grad {
                objective.record_backward(rec, gs);
                renderer.record_backward(rec, gs);
                self.record_map(rec, gs, 1);
            }
        })?;
        let ev = objective.read()?;
        let g = if grad {
            let mut g: Vec<f32> = renderer.ctx.download(&self.depth_grad)?;
            g.truncate(self.n as usize);
            Some(g)
        } else {
            None
        };
        Ok((ev, g))
    }
}

impl ParamSet for ToolParams {
    fn blocks<'a>(&'a self, gs: &'a GpuScene) -> Vec<ParamBlock<'a>> {
        let mut groups = match &self.arcs {
            Some(a) => super::arc_params::ArcParams::scratch_groups(&self.cfg, a, gs.half_plate()),
            None => SceneParams::scratch_groups(&self.cfg, gs.half_plate()),
        };
        for g in &mut groups[4..7] {
            *g = AdamGroup::frozen();
        }
        let (lo, hi) = (self.fab.table.z_lo as f32, self.fab.table.z_hi as f32);
        let (params, grad, n) = scratch_buffers(gs);
        vec![
            ParamBlock {
                name: "scratches",
                params,
                grad,
                len: 8 * n,
                groups,
            },
            ParamBlock {
                name: "depths",
                params: &self.depths,
                grad: &self.depth_grad,
                len: self.n,
                groups: vec![AdamGroup::linear(self.fab.lr_z, (lo, hi))],
            },
            SceneParams::light_block(&self.cfg, gs),
        ]
    }

    fn begin_iteration(&self, k: u32, step: bool) {
        let carving = match self.robust {
            Some(r) if step => ToolParams::carving_seed(r.seed, k).wrapping_add(1).max(1),
            _ => 0,
        };
        self.carving.store(carving, Ordering::Relaxed);
    }

    fn record_to_scene(&self, rec: &mut Recorder, gs: &GpuScene) {
        self.record_map_as(rec, gs, 0, true);
    }

    fn record_grad(&self, rec: &mut Recorder, gs: &GpuScene) {
        self.record_map_as(rec, gs, 1, true);
    }

    fn moves_arcs(&self) -> bool {
        self.arcs.is_some()
    }

    fn record_project(&self, rec: &mut Recorder, gs: &GpuScene, before: &[&Buffer], flags: &Buffer) {
        let (scratches, _, n) = scratch_buffers(gs);
        self.scene
            .record_projection_of(rec, scratches, n, gs.half_plate(), before[0], flags);
        // The scene keeps the grooves of the depths just stepped to (a refused step rewrites
        // the same values), so every saved state is consistent.
        self.record_map(rec, gs, 0);
    }
}

/// A shared parameter set is a parameter set (the design keeps it to read the depths after the
/// run).
impl ParamSet for Arc<ToolParams> {
    fn blocks<'a>(&'a self, gs: &'a GpuScene) -> Vec<ParamBlock<'a>> {
        (**self).blocks(gs)
    }
    fn begin_iteration(&self, k: u32, step: bool) {
        (**self).begin_iteration(k, step)
    }
    fn moves_arcs(&self) -> bool {
        (**self).moves_arcs()
    }
    fn record_to_scene(&self, rec: &mut Recorder, gs: &GpuScene) {
        (**self).record_to_scene(rec, gs)
    }
    fn record_grad(&self, rec: &mut Recorder, gs: &GpuScene) {
        (**self).record_grad(rec, gs)
    }
    fn record_project(&self, rec: &mut Recorder, gs: &GpuScene, before: &[&Buffer], flags: &Buffer) {
        (**self).record_project(rec, gs, before, flags)
    }
}

/// The depth of each scratch of `kept` (a subsequence of `all`, in order, as pruning leaves
/// it), from `depths` (one per scratch of `all`).
pub fn depths_of_kept(all: &[Scratch], depths: &[f64], kept: &[Scratch]) -> Vec<f64> {
    let mut out = Vec::with_capacity(kept.len());
    let mut i = 0;
    for s in kept {
        while all.get(i).is_some_and(|a| a != s) {
            i += 1;
        }
        assert!(
            i < all.len(),
            "the kept scratches are not a subsequence of the optimized ones"
        );
        out.push(depths[i]);
        i += 1;
    }
    out
}
