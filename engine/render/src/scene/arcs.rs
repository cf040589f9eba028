//! A scene whose scratches include arcs, uploaded as their chords (`crate::arcs`): what may and
//! may not be read of it.
use super::*;

/// The scene's scratches when they include arcs, and how many chords each is uploaded as (in
/// order: scratch k's chords follow scratch k - 1's); on the device, the scratches themselves
/// (`params`, shape.w = bulge), which chord belongs to which (`chord_of`: (arc, j | n << 16);
/// `arc_chords`: (first chord, n)), and the scratches' gradients (`grad`: 8 per scratch, dE/d(x0,
/// y0, x1, y1, w, d, alpha, bulge)). `shaders/arc_map.comp` writes the chords from `params`
/// before every render and `grad` from the chords' after every backward.
pub(crate) struct ArcLayout {
    pub(crate) scratches: Vec<crate::model::scene::Scratch>,
    pub(crate) chords: Vec<u32>,
    pub(crate) params: Buffer,
    pub(crate) chord_of: Buffer,
    pub(crate) arc_chords: Buffer,
    pub(crate) grad: Buffer,
    /// How many chords each scratch is laid out as.
    pub(crate) mode: ChordMode,
    /// Whether the chords are rendered with their area weights (the arc kernels, `SA_ARCS`);
    /// false: the straight kernels, which ignore the weight (`Renderer::upload_bendable`).
    pub(crate) weighted: bool,
}

/// How a scene's scratches are laid out as chords.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum ChordMode {
    /// The accuracy bar's rule ([`crate::arcs::chord_count`]).
    Rule,
    /// Each arc as n chords, straight scratches as one ([`crate::Renderer::set_arc_chords`]).
    PerArc(u32),
    /// Every scratch as n chords whatever its bulge (a scene whose bulges an optimizer moves:
    /// [`GpuScene::new_bendable`]).
    All(u32),
}

impl ChordMode {
    /// The layout of an upload: each arc as `arc_chords` chords, or (None) the rule's.
    pub(crate) fn of(arc_chords: Option<u32>) -> ChordMode {
        arc_chords.map_or(ChordMode::Rule, ChordMode::PerArc)
    }

    /// The chords of each scratch.
    pub(crate) fn counts(self, scratches: &[crate::model::scene::Scratch]) -> Vec<u32> {
        scratches
            .iter()
            .map(|s| match self {
                ChordMode::Rule => crate::arcs::chord_count(s) as u32,
                ChordMode::PerArc(n) => {
                    if s.is_arc() {
                        n
                    } else {
                        1
                    }
                }
                ChordMode::All(n) => n,
            })
            .collect()
    }
}

/// The scratches as the arc map reads them: ScratchGpu with shape.w = bulge.
fn arc_params(scratches: &[crate::model::scene::Scratch]) -> Vec<ScratchGpu> {
    scratches
        .iter()
        .map(|s| {
            let mut g = ScratchGpu::from(s);
            g.shape[3] = s.bulge as f32;
            g
        })
        .collect()
}

impl ArcLayout {
    pub(crate) fn new(
        ctx: &std::sync::Arc<Context>,
        scratches: &[crate::model::scene::Scratch],
        mode: ChordMode,
    ) -> Result<ArcLayout, GpuError> {
        let chords = mode.counts(scratches);
        let mut chord_of = Vec::new();
        let mut arc_chords = Vec::with_capacity(chords.len());
        for (a, &n) in chords.iter().enumerate() {
            arc_chords.push([chord_of.len() as u32, n]);
            chord_of.extend((0..n).map(|j| [a as u32, j | (n << 16)]));
        }
        Ok(ArcLayout {
            scratches: scratches.to_vec(),
            params: ctx.upload("arc scratches", &arc_params(scratches))?,
            chord_of: ctx.upload("arc chords' owners", &chord_of)?,
            arc_chords: ctx.upload("arcs' chords", &arc_chords)?,
            grad: Buffer::new(
                ctx,
                "arc gradients",
                (scratches.len().max(1) * 32) as u64,
                MemLoc::GpuOnly,
            )?,
            chords,
            mode,
            weighted: true,
        })
    }

    /// Replaces the scratches when each keeps its number of chords (else false: upload again).
    pub(crate) fn update(
        &mut self,
        ctx: &std::sync::Arc<Context>,
        scratches: &[crate::model::scene::Scratch],
    ) -> Result<bool, GpuError> {
        let same = scratches.len() == self.chords.len() && self.mode.counts(scratches) == self.chords;
        if !same {
            return Ok(false);
        }
        self.params = ctx.upload("arc scratches", &arc_params(scratches))?;
        self.scratches = scratches.to_vec();
        Ok(true)
    }

    /// Chords in all.
    pub(crate) fn n_chords(&self) -> u32 {
        self.chords.iter().sum()
    }

    /// The scene's scratches' gradients from their chords' (`g`: 8 per chord, dE/d(x0, y0, x1,
    /// y1, w, d, alpha, kappa)): each chord's endpoints and curvature are functions of its arc's
    /// ends and bulge (`scratchart_model::arc::point_and_jacobian`, `chord_weight_and_gradient`;
    /// the weight's dependence on w is in the chord's own dE/dw). Returns dE/d(x0, y0, x1, y1, w,
    /// d, alpha) per scratch and dE/dbulge (NaN for a scratch of one chord: it cannot bend).
    pub fn chain(&self, g: &[[f32; 8]]) -> (Vec<[f32; 7]>, Vec<f32>) {
        use crate::model::arc::{chord_weight_and_gradient, point_and_jacobian};
        let mut out = Vec::with_capacity(self.scratches.len());
        let mut bulges = Vec::with_capacity(self.scratches.len());
        let mut at = 0usize;
        for (s, &n) in self.scratches.iter().zip(&self.chords) {
            let n = n as usize;
            let mut acc = [0.0f64; 8]; // x0, y0, x1, y1, w, d, alpha, bulge
            let dkappa = if n > 1 {
                let (_, dk) = chord_weight_and_gradient(s.p0, s.p1, s.w, s.bulge);
                // kappa = 2 k / w: no w in it.
                [dk[0], dk[1], dk[2], dk[3], 0.0, dk[5]].map(|d| 2.0 * d / s.w)
            } else {
                [0.0; 6]
            };
            for (j, c) in g[at..at + n].iter().enumerate() {
                let c: [f64; 8] = c.map(f64::from);
                for (end, t) in [(0usize, j as f64 / n as f64), (2, (j + 1) as f64 / n as f64)] {
                    let (_, jac) = point_and_jacobian(s.p0, s.p1, s.bulge, t);
                    for v in 0..5 {
                        let d = c[end] * jac[0][v] + c[end + 1] * jac[1][v];
                        acc[if v < 4 { v } else { 7 }] += d;
                    }
                }
                for v in 4..7 {
                    acc[v] += c[v];
                }
                for (v, dk) in [(0, 0), (1, 1), (2, 2), (3, 3), (7, 5)] {
                    acc[v] += c[7] * dkappa[dk];
                }
            }
            at += n;
            out.push([acc[0], acc[1], acc[2], acc[3], acc[4], acc[5], acc[6]].map(|x| x as f32));
            bulges.push(if n > 1 { acc[7] as f32 } else { f32::NAN });
        }
        (out, bulges)
    }
}

impl GpuScene {
    /// A scene whose every scratch may bend (`design --arcs`): each is uploaded as `n` chords
    /// whatever its bulge (straight ones too), so an optimizer can move every bulge without a new
    /// upload (`crate::arcs::expand_bendable`).
    pub(crate) fn new_bendable(ctx: &std::sync::Arc<Context>, scene: &Scene, n: u32) -> Result<GpuScene, GpuError> {
        let mut chords = scene.clone();
        chords.scratches = crate::arcs::expand_bendable(&scene.scratches, n as usize)?;
        GpuScene::new_arcs(ctx, scene, chords, arcs::ChordMode::All(n), &[])
    }

    /// The kernels' scene of `chords` with the arc layout of `scene`'s scratches.
    pub(super) fn new_arcs(
        ctx: &std::sync::Arc<Context>,
        scene: &Scene,
        chords: Scene,
        mode: arcs::ChordMode,
        windows: &[Option<layout::TileWindow>],
    ) -> Result<GpuScene, GpuError> {
        let mut gs = GpuScene::new_kernel_scene(ctx, &chords, windows)
            .map_err(|e| arcs_named(e, scene.scratches.len(), chords.scratches.len()))?;
        gs.arcs = Some(arcs::ArcLayout::new(ctx, &scene.scratches, mode)?);
        Ok(gs)
    }

    /// The layout of a scene with arcs (None for straight scratches only).
    pub(crate) fn arc_layout(&self) -> Option<&ArcLayout> {
        self.arcs.as_ref()
    }

    /// Test hook: the float64 chain rule of the host (`ArcLayout::chain`) over the chords'
    /// gradients `g` (8 per chord), the oracle of `shaders/arc_map.comp`'s mode 1.
    #[doc(hidden)]
    pub fn arc_chain_on_host(&self, g: &[[f32; 8]]) -> Option<(Vec<[f32; 7]>, Vec<f32>)> {
        self.arcs.as_ref().map(|a| a.chain(g))
    }

    /// The scratches of a scene with arcs as the arc map reads them (one [`ScratchGpu`] each,
    /// shape.w = bulge): what an optimizer of arcs moves. None without arcs.
    pub fn arc_params(&self) -> Option<&Buffer> {
        self.arcs.as_ref().map(|a| &a.params)
    }

    /// Per scratch of a scene with arcs: dE/d(x0, y0, x1, y1, w, d, alpha, bulge) after a
    /// backward (8 f32). None without arcs.
    pub fn arc_grad(&self) -> Option<&Buffer> {
        self.arcs.as_ref().map(|a| &a.grad)
    }

    /// The scene's own scratches (an arc counted once; `n_scratches` counts the kernels' chords).
    pub fn n_scene_scratches(&self) -> u32 {
        self.arcs.as_ref().map_or(self.n_scratches, |a| a.chords.len() as u32)
    }

    /// Whether the chords of a scene with arcs are rendered by the arc kernels (with their area
    /// weights); false for a scene without arcs, or one whose weights were switched off.
    pub fn arc_kernels(&self) -> bool {
        self.arcs.as_ref().is_some_and(|a| a.weighted)
    }

    /// Renders the chords with (true) or without their area weights from now on.
    pub(crate) fn weigh_arcs(&mut self, on: bool) {
        if let Some(a) = self.arcs.as_mut() {
            a.weighted = on;
        }
    }

    /// Whether the scene's scratches include arcs (uploaded as chords: the kernels' scratches,
    /// their gradients and tangents are the chords', so nothing may read them as the scene's).
    pub fn has_arcs(&self) -> bool {
        self.arcs.is_some()
    }

    /// An error for work that needs the scene's own scratches on the device (gradients,
    /// tangents, optimization) when they include arcs.
    pub fn refuse_arcs(&self, what: &str) -> Result<(), GpuError> {
        match &self.arcs {
            Some(a) => Err(GpuError::Capacity(format!(
                "{what} of arc scratches is not available yet: the scene's {} scratches include arcs \
                 (a nonzero `bulge`), which render as {} chords; straighten them (bulge 0) for {what}",
                a.scratches.len(),
                self.n_scratches
            ))),
            None => Ok(()),
        }
    }
}

/// A size error of a scene with arcs, saying that its scratches are counted as their chords.
pub(super) fn arcs_named(e: GpuError, scratches: usize, chords: usize) -> GpuError {
    let why = format!(
        "the scene's {scratches} scratches include arcs, uploaded as {chords} chords \
         (engine/docs/model.md section 11): fewer or shorter arcs, or larger alpha, take fewer"
    );
    match e {
        GpuError::BufferTooLarge { name, size, limit } => GpuError::BufferTooLarge {
            name: format!("{name}; {why}"),
            size,
            limit,
        },
        GpuError::Capacity(msg) => GpuError::Capacity(format!("{msg}; {why}")),
        other => other,
    }
}
