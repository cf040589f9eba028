//! Descriptors of the shading kernels: which pair integral ([`Integrator`]) and which pass
//! ([`Mode`]) a pipeline is built for. A descriptor turns into a shader file and its defines;
//! the GLSL side is `shaders/inc/patch_ndf.glsl` (the `SA_INTEGRATOR_*` switch) and
//! `shaders/inc/tile_loop.glsl` (the loop every shading kernel shares).
//!
//! A new integrator is one file under `shaders/inc/integrators/` (defining `pair_integral`, or
//! `edge_integral` plus `green.glsl`), one line in the switch of `patch_ndf.glsl` and one variant
//! here. A new backward mode (say, a reverse-mode adjoint kernel) is one kernel file beside
//! `grad.comp`, defining the hooks of `tile_loop.glsl`, and one variant of [`Mode`].
use crate::vulkan::DeviceInfo;

/// How a shading kernel integrates the patch NDF over footprint ∩ carved rectangle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Integrator {
    /// Green's theorem with the GGX lobe in closed form and Gauss-Legendre for the smooth part
    /// (`inc/integrators/closed_form.glsl`). The default; the one engine/docs/model.md's bars are kept with.
    #[default]
    ClosedForm,
    /// Green's theorem with every edge integral by Gauss-Legendre on panels graded towards the
    /// lobe (`inc/integrators/gauss_panels.glsl`): a numeric cross-check of the closed form,
    /// tens of times slower.
    GaussPanels,
    /// Green's theorem with every edge integral by plain Gauss-Legendre with this many nodes (2,
    /// 4, 8, 16 or 32) over the whole edge (`inc/integrators/gauss_legendre.glsl`). For the
    /// speed-against-accuracy study; forward only (its backward would be the dual-number kernel).
    GaussLegendre(u8),
    /// Globally adaptive quadrature of every edge integral: 5-point Gauss-Legendre panels,
    /// bisected where their error estimate fails (`inc/integrators/adaptive_quadrature.glsl`), what a
    /// generic integrator does without knowing where the lobe is. For the study; forward only.
    AdaptiveQuadrature,
    /// The closed form on the pairs that matter: a pair whose contribution is bounded below
    /// 5e-4 of its pixel's value (its NDF's largest value over the groove's normals and its share
    /// of the coverage, against the integrals the pixel has kept so far) is not integrated
    /// (`SA_CULL_PAIRS`, `inc/tile_queue.glsl`), so every pixel stays within 5e-4 of the closed
    /// form. What "model no more than the scene needs" buys per pair; forward only.
    Adaptive,
    /// The "average" approximation: the GGX integral over the clipped across-range times the
    /// clipped area (`inc/integrators/average.glsl`). For the study; forward only.
    Average,
    /// Stratified Monte Carlo sampling of the footprint with this many points (16, 64 or 256;
    /// `inc/integrators/monte_carlo.glsl`), what a generic renderer does. For the study; forward only.
    MonteCarlo(u16),
}

impl Integrator {
    /// The integrators a shading kernel is built with for rendering and gradients.
    pub const ALL: [Integrator; 2] = [Integrator::ClosedForm, Integrator::GaussPanels];

    /// Every method the speed-against-accuracy study (`scratchart study`) compares.
    pub const STUDY: [Integrator; 13] = [
        Integrator::ClosedForm,
        Integrator::Adaptive,
        Integrator::GaussPanels,
        Integrator::GaussLegendre(2),
        Integrator::GaussLegendre(4),
        Integrator::GaussLegendre(8),
        Integrator::GaussLegendre(16),
        Integrator::GaussLegendre(32),
        Integrator::AdaptiveQuadrature,
        Integrator::Average,
        Integrator::MonteCarlo(16),
        Integrator::MonteCarlo(64),
        Integrator::MonteCarlo(256),
    ];

    /// The define that selects it in `shaders/inc/patch_ndf.glsl`.
    pub fn define(self) -> &'static str {
        match self {
            Integrator::ClosedForm | Integrator::Adaptive => "SA_INTEGRATOR_CLOSED_FORM",
            Integrator::GaussPanels => "SA_INTEGRATOR_GAUSS_PANELS",
            Integrator::GaussLegendre(_) => "SA_INTEGRATOR_GAUSS_LEGENDRE",
            Integrator::AdaptiveQuadrature => "SA_INTEGRATOR_ADAPTIVE_QUADRATURE",
            Integrator::Average => "SA_INTEGRATOR_AVERAGE",
            Integrator::MonteCarlo(_) => "SA_INTEGRATOR_MONTE_CARLO",
        }
    }

    /// Its second define, if it has one: the node or point count, or the pair culling of `adaptive`
    /// (which otherwise compiles as the closed form).
    fn extra_define(self) -> Option<(&'static str, &'static str)> {
        match self {
            Integrator::GaussLegendre(n) => Some(("SA_GL_NODES", count_str(n as u16))),
            Integrator::MonteCarlo(n) => Some(("SA_MC_POINTS", count_str(n))),
            Integrator::Adaptive => Some(("SA_CULL_PAIRS", "1")),
            _ => None,
        }
    }

    /// Whether the kernels can be built with it (the parameterized ones take listed counts).
    pub fn is_valid(self) -> bool {
        match self {
            Integrator::GaussLegendre(n) => [2, 4, 8, 16, 32].contains(&n),
            Integrator::MonteCarlo(n) => [16, 64, 256].contains(&n),
            _ => true,
        }
    }

    /// Whether a backward kernel exists over it (the study's methods are forward only).
    pub fn has_backward(self) -> bool {
        matches!(self, Integrator::ClosedForm | Integrator::GaussPanels)
    }

    pub fn name(self) -> String {
        match self {
            Integrator::ClosedForm => "closed-form".into(),
            Integrator::GaussPanels => "gauss-panels".into(),
            Integrator::GaussLegendre(n) => format!("gauss-legendre-{n}"),
            Integrator::AdaptiveQuadrature => "adaptive-quadrature".into(),
            Integrator::Adaptive => "adaptive".into(),
            Integrator::Average => "average".into(),
            Integrator::MonteCarlo(n) => format!("monte-carlo-{n}"),
        }
    }

    /// The integrator `name` names (as [`name`](Self::name) writes it).
    pub fn from_name(name: &str) -> Option<Integrator> {
        Integrator::STUDY.into_iter().find(|m| m.name() == name)
    }
}

fn count_str(n: u16) -> &'static str {
    match n {
        2 => "2",
        4 => "4",
        8 => "8",
        16 => "16",
        32 => "32",
        64 => "64",
        256 => "256",
        _ => "0", // refused by is_valid before any build
    }
}

/// Which pass a shading kernel computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Pixel values and coverage (`forward.comp`).
    Forward,
    /// Per-(tile, scratch) partial gradients by forward-mode dual numbers through the pair
    /// integral (`grad.comp` with `SA_DUAL`). The test oracle of [`Mode::Backward`].
    BackwardDual,
    /// The default backward: `grad.comp` in reverse mode (`SA_EDGE_ADJOINT`): per pair, one
    /// float forward sweep and one hand-written reverse sweep through the scratch frame, the
    /// clipping and the edge integrals give all 7 gradients at once (`inc/pair_adjoint.glsl`,
    /// `inc/integrators/closed_form_adjoint.glsl`). Integrators without an adjoint edge
    /// integral (Gauss panels) build the dual-number kernel under this mode.
    Backward,
    /// Directional derivatives of the pixel values along up to 7 directions in the scratches'
    /// (w, d, alpha) (`tangent.comp`, the backward's per-pair reverse sweep): the
    /// Jacobian columns of a fit over a few parameters that move many scratches (the tool
    /// calibration). Not part of a [`KernelSet`]: [`super::Renderer::tangents`] builds it.
    Tangent,
}

/// One shading kernel: a pass and the pair integral it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShadeKernel {
    pub integrator: Integrator,
    pub mode: Mode,
}

impl ShadeKernel {
    /// The shader file under `shaders/`.
    pub fn file(&self) -> &'static str {
        match self.mode {
            Mode::Forward => "forward.comp",
            Mode::BackwardDual | Mode::Backward => "grad.comp",
            Mode::Tangent => "tangent.comp",
        }
    }

    /// Whether this is a backward kernel (reads dE/dL, writes partial gradients).
    pub fn is_backward(&self) -> bool {
        matches!(self.mode, Mode::BackwardDual | Mode::Backward)
    }

    /// The pipeline's name (validation messages and debug tools show it).
    pub fn name(&self) -> String {
        match self.mode {
            Mode::Backward => format!("{} [{}, reverse mode]", self.file(), self.integrator.name()),
            _ => format!("{} [{}]", self.file(), self.integrator.name()),
        }
    }

    /// The name of the replay build of this backward kernel (see [`KernelSet::replay`]).
    pub fn replay_name(&self) -> String {
        format!("{} [{}, replay]", self.file(), self.integrator.name())
    }

    /// The defines of the replay build of this backward kernel: [`defines`](Self::defines) and
    /// `SA_REPLAY` (`replay_stream` in `shaders/grad.comp`).
    pub fn replay_defines(&self, info: &DeviceInfo) -> Vec<(&'static str, &'static str)> {
        let mut defs = self.defines(info);
        defs.push(("SA_REPLAY", "1"));
        defs
    }

    /// The defines to compile [`file`](Self::file) with on a device described by `info`.
    pub fn defines(&self, info: &DeviceInfo) -> Vec<(&'static str, &'static str)> {
        let mut defs = vec![(self.integrator.define(), "1")];
        if let Some(d) = self.integrator.extra_define() {
            defs.push(d);
        }
        if self.is_backward() {
            // Reverse mode needs the integrator's adjoint edge integral; others run dual numbers.
            if self.mode == Mode::Backward && self.integrator == Integrator::ClosedForm {
                defs.push(("SA_EDGE_ADJOINT", "1"));
            } else {
                defs.push(("SA_DUAL", "1"));
            }
            // grad.comp needs ~30 KiB of shared memory with a 256-entry queue, ~39 KiB with 512.
            let qcap = if info.max_shared_memory >= 48 * 1024 {
                "512"
            } else {
                "256"
            };
            defs.push(("GRAD_QCAP", qcap));
            // How a round adds each scratch's entries ([`Walk`]): on a GPU split between two
            // threads per scratch; by lists of thread 0 on a CPU driver, where a thread is a SIMD
            // lane.
            defs.extend(Walk::device_default(info).defines());
        }
        if self.mode == Mode::Tangent {
            // The per-pair reverse sweep of the backward, contracted with the directions.
            defs.push(("SA_EDGE_ADJOINT", "1"));
        }
        // Ray hits in float64 where the device has it (see ViewGPU64 in shaders/inc/common.glsl).
        if !info.float64 {
            defs.push(("SA_NO_F64", "1"));
        }
        defs
    }
}

/// Builds of the backward that measure where its time goes, from `SCRATCHART_GRAD_DIAG` (a
/// comma-separated list; `scratchart bench --compare-backward` times them, engine/BENCHMARKS.md):
/// `no-walk` (each round's lists or masks built, not walked), `no-accum` (neither: the pairs
/// evaluated and stored only), `qcap=N` (N queue entries per round, N = 256 or 512).
/// The first two give wrong gradients: timing only, never a design; a process that builds one
/// says so once on stderr. Unknown entries are ignored with a warning. (`scratchart bench
/// --links one|every|split` picks the walk.)
pub fn grad_diagnostics() -> Vec<(&'static str, &'static str)> {
    let Ok(spec) = std::env::var("SCRATCHART_GRAD_DIAG") else {
        return Vec::new();
    };
    static SAID: std::sync::Once = std::sync::Once::new();
    if spec.contains("no-") {
        SAID.call_once(|| {
            eprintln!("warning: SCRATCHART_GRAD_DIAG={spec}: the backward is a timing build, its gradients are wrong")
        });
    }
    let mut out = Vec::new();
    for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        match item {
            "no-walk" => out.push(("SA_DIAG_NO_WALK", "1")),
            "no-accum" => out.push(("SA_DIAG_NO_ACCUM", "1")),
            "qcap=256" => out.push(("GRAD_QCAP", "256")),
            "qcap=512" => out.push(("GRAD_QCAP", "512")),
            other => eprintln!("warning: SCRATCHART_GRAD_DIAG: unknown entry {other:?} ignored (no-walk, no-accum, qcap=256, qcap=512)"),
        }
    }
    out
}

/// The define of `shaders/grad.comp` that marks each round's entries in per-scratch masks on
/// every thread (`round_walk`) rather than linking lists on thread 0 ([`Walk::Every`]).
pub const PARALLEL_LINKS: &str = "SA_PARALLEL_LINKS";
/// The define of `shaders/grad.comp` that walks the masks with two threads per scratch
/// ([`Walk::Split`]; with [`PARALLEL_LINKS`]).
pub const WALK_SPLIT: &str = "SA_WALK_SPLIT";

/// How the backward's rounds add each scratch's pair contributions (`shaders/grad.comp`). A
/// round evaluates up to QCAP queue entries on all 256 threads; each scratch's contributions are
/// then added by one thread (two with `Split`), and a chunk's sum per scratch is one partial
/// gradient.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Walk {
    /// Thread 0 links each scratch's entries into a list in queue order, thread k walks scratch
    /// k's: CPU drivers' default (a thread there is a SIMD lane).
    One,
    /// Every thread marks its entries in per-scratch masks, thread k walks scratch k's in queue
    /// order: the same sums as `One`, bit for bit (`tests/replay.rs`).
    Every,
    /// The masks walked by two threads per scratch (the even and the odd words of the round),
    /// whose shares are added when the chunk closes: GPUs' default, which halves the longest
    /// scratch's walk (engine/BENCHMARKS.md). Other sums than `One`'s: `tests/replay.rs`
    /// bounds the difference.
    Split,
}

impl Walk {
    /// The device's choice: `Split` on a GPU, `One` on a CPU driver.
    pub fn device_default(info: &DeviceInfo) -> Walk {
        if info.kind == "cpu" {
            Walk::One
        } else {
            Walk::Split
        }
    }

    /// Its defines of `shaders/grad.comp`.
    pub fn defines(self) -> Vec<(&'static str, &'static str)> {
        match self {
            Walk::One => vec![],
            Walk::Every => vec![(PARALLEL_LINKS, "1")],
            Walk::Split => vec![(PARALLEL_LINKS, "1"), (WALK_SPLIT, "1")],
        }
    }

    /// Its name on the command line (`scratchart bench --links`) and in pipeline names.
    pub fn name(self) -> &'static str {
        match self {
            Walk::One => "one",
            Walk::Every => "every",
            Walk::Split => "split",
        }
    }

    /// The walk named `s` (`one`, `every`, `split`).
    pub fn parse(s: &str) -> Option<Walk> {
        [Walk::One, Walk::Every, Walk::Split]
            .into_iter()
            .find(|w| w.name() == s)
    }
}

/// The shading kernels a [`super::Renderer`] builds: one forward and one backward kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KernelSet {
    pub forward: ShadeKernel,
    pub backward: ShadeKernel,
    /// Whether the backward replays the forward's pair queues (true for [`Mode::Backward`]):
    /// the forward stores every chunk's queue, and the backward integrates the stored entries
    /// instead of searching the pairs again (block tests, per-pixel candidate tests, queue
    /// slots). Gradients are bit-identical either way (`tests/replay.rs`). The first backward on
    /// a scene searches (the store is sized after it); so does any backward whose scene's store
    /// does not fit the device. The dual-number oracle ([`Mode::BackwardDual`]) always searches.
    pub replay: bool,
    /// How the backward's rounds add each scratch's entries ([`Walk`]); None: the device's
    /// choice ([`Walk::device_default`]).
    pub walk: Option<Walk>,
}

impl KernelSet {
    /// Forward and the default backward kernels over `integrator`.
    pub fn with_integrator(integrator: Integrator) -> KernelSet {
        KernelSet::with_modes(integrator, Mode::Backward)
    }

    /// Forward and the backward kernel of mode `backward` over `integrator`.
    pub fn with_modes(integrator: Integrator, backward: Mode) -> KernelSet {
        KernelSet {
            forward: ShadeKernel {
                integrator,
                mode: Mode::Forward,
            },
            backward: ShadeKernel {
                integrator,
                mode: backward,
            },
            replay: backward == Mode::Backward,
            walk: None,
        }
    }

    /// The same kernels with the backward's rounds adding each scratch's entries by `walk`,
    /// whatever the device.
    pub fn with_walk(self, walk: Walk) -> KernelSet {
        KernelSet {
            walk: Some(walk),
            ..self
        }
    }

    /// The same kernels with the backward searching the pairs itself every time (no replay).
    pub fn without_replay(self) -> KernelSet {
        KernelSet { replay: false, ..self }
    }
}

impl Default for KernelSet {
    /// What [`super::Renderer::new`] builds: the closed form, the reverse-mode backward.
    fn default() -> KernelSet {
        KernelSet::with_integrator(Integrator::ClosedForm)
    }
}
