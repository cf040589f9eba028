//! Benchmarks (not tests): GPU time from Vulkan timestamp queries, median of repeats after warm-up.
use std::fmt::Write as _;
use std::sync::Arc;

use scratchart_design::scenes::{orbit_light, random_scratches, ring_views, Rng};
use scratchart_model::scene::{Plate, Scene};
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, GpuError, Recorder};

/// Floating-point operations of `forward.comp` per candidate (pixel, scratch) test that is culled
/// by the footprint's bounding circle: 2 subtractions, 2 dot products (4 mul + 2 add),
/// 4 compares/adds.
pub const FLOPS_PER_CANDIDATE: f64 = 12.0;
/// Floating-point operations per overlapping pair, counted on the common (fast) path of
/// `forward.comp` + `inc/patch_ndf.glsl` with the default integrator, where the carved strip crosses the footprint: local
/// coordinates of the 4 corners 36, pair constants 40, the chord at s = ±s_e 45, one closed-form
/// edge integral with its 5-point Gauss part 155 (atan, log and sqrt counted as 1 each),
/// accumulation 3. Sum 279, rounded to 300; pairs on the general path cost more.
pub const FLOPS_PER_PAIR: f64 = 300.0;
/// Floating-point operations per overlapping pair of the backward kernel (`grad.comp` in reverse
/// mode, `inc/pair_adjoint.glsl`), counted on the same fast path: the scratch frame with the
/// carved half-width and its partials 75, the pair constants 45, the strip's crossings forward
/// and reverse 120, the edge integral's forward sweep 155 and reverse sweep 200, the reverse of
/// the pair constants 70, the frame's reverse 60, the per-scratch sum 8. Sum 733, rounded to 750
/// (sqrt, atan, log and divisions counted as 1 each, as for the forward).
pub const FLOPS_PER_PAIR_BACKWARD: f64 = 750.0;

/// One benchmark row.
#[derive(Clone, Debug)]
pub struct ForwardRow {
    pub name: String,
    pub scratches: usize,
    pub views: usize,
    pub pixels: u64,
    pub entries: u64,
    pub candidates: u64,
    pub pairs: u64,
    pub bin_ms: f64,
    /// bands of tile rows per view in the pair search (0: none; `GpuScene::binning_bands`)
    pub bands: u32,
    /// the pair search's mode (`GpuScene::binning_mode`)
    pub mode: scratchart_render::BinMode,
    /// threads of its pass over (scratch, tile) work, and the most tile tests one made
    pub bin_threads: u64,
    pub bin_tests_per_thread: u64,
    pub shade_ms: f64,
    /// backward pass (all views) for dE/dL of the check loss against the scene's own render
    /// perturbed by a fixed pattern
    pub backward_ms: f64,
    /// the same backward with the all-dual-number kernel (`Mode::BackwardDual`), timed in the
    /// same submissions (`--compare-backward`), else NaN
    pub backward_dual_ms: f64,
}

/// Median of benchmark samples (NaN for none).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Times binning and shading of each scene: `warmup` untimed runs, then the median of `repeats`.
/// With `compare_backward`, every submission also runs the all-dual-number backward kernel
/// (the oracle of the default one) after the default backward, so the two are timed side by side.
/// `links`: how the default backward's rounds add each scratch's entries (None: the device's
/// choice).
/// `binning_mode` and `binning_bands` override the device's choice of binning mode and of bands
/// of tile rows in the pair search.
pub fn run_forward(
    ctx: &Arc<Context>,
    scenes: &[(String, Scene)],
    warmup: usize,
    repeats: usize,
    (compare_backward, links): (bool, Option<scratchart_render::kernels::Walk>),
    binning_mode: Option<scratchart_render::BinMode>,
    binning_bands: Option<u32>,
) -> Result<Vec<ForwardRow>, GpuError> {
    use scratchart_render::kernels::{Integrator, KernelSet, Mode};
    let renderer = match links {
        Some(walk) => Renderer::with_kernels(ctx, KernelSet::default().with_walk(walk))?,
        None => Renderer::new(ctx)?,
    };
    renderer.prepare_backward()?;
    let oracle = if compare_backward {
        let r = Renderer::with_kernels(ctx, KernelSet::with_modes(Integrator::ClosedForm, Mode::BackwardDual))?;
        r.prepare_backward()?;
        Some(r)
    } else {
        None
    };
    let mut rows = Vec::new();
    for (name, scene) in scenes {
        let mut gs = renderer.upload(scene)?;
        // A scene with arcs takes the backward that weighs chords (both renderers).
        renderer.prepare_backward_of(&gs)?;
        if let Some(o) = &oracle {
            o.prepare_backward_of(&gs)?;
        }
        if let Some(m) = binning_mode {
            gs.force_binning_mode(ctx, m)?;
        }
        if let Some(b) = binning_bands {
            gs.force_binning_bands(ctx, b)?;
        }
        let mut rec = Recorder::new(ctx)?;
        // Size the tile lists, then make dE/dL of E_lin against a perturbed copy of the render.
        let first = renderer.render(&mut gs)?;
        let dl = perturbed_target_dl(&first.images);
        renderer.upload_dl(&mut gs, &dl)?;
        let (mut bins, mut shades, mut backs, mut duals) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut last = first.stats;
        for i in 0..warmup + repeats {
            let (st, t) = renderer.submit(&mut rec, &mut gs, |rec, gs| {
                renderer.record_render(rec, gs);
                renderer.record_backward(rec, gs);
                rec.timestamp("backward");
                if let Some(o) = &oracle {
                    o.record_backward(rec, gs);
                    rec.timestamp("backward dual");
                }
            })?;
            last = st;
            if i >= warmup {
                bins.push(t.get("binning").unwrap_or(f64::NAN));
                shades.push(t.get("forward").unwrap_or(f64::NAN));
                backs.push(t.get("backward").unwrap_or(f64::NAN));
                duals.push(t.get("backward dual").unwrap_or(f64::NAN));
            }
        }
        rows.push(ForwardRow {
            name: name.clone(),
            scratches: scene.scratches.len(),
            views: scene.views.len(),
            pixels: gs.n_pixels(),
            entries: last.entries,
            candidates: last.candidates,
            pairs: last.pairs,
            bin_ms: median(bins),
            bands: gs.binning_bands(),
            mode: gs.binning_mode(),
            bin_threads: gs.binning_threads(),
            bin_tests_per_thread: last.bin_tests_per_thread,
            shade_ms: median(shades),
            backward_ms: median(backs),
            backward_dual_ms: if oracle.is_some() { median(duals) } else { f64::NAN },
        });
    }
    Ok(rows)
}

/// The benchmark target of pixel i whose value is l: the render itself, brightened or dimmed by
/// 10% in a fixed pattern, so every pixel has a residual and a gradient.
fn perturbed(i: usize, l: f32) -> f32 {
    l * if (i / 7) % 2 == 0 { 1.1 } else { 0.9 }
}

/// dE_lin/dL (up to the per-view normalization) for a target that is the render itself,
/// brightened or dimmed by 10% in a fixed checker pattern: every pixel gets a gradient.
pub fn perturbed_target_dl(images: &[Vec<f32>]) -> Vec<f32> {
    images
        .iter()
        .flat_map(|img| {
            let n = img.len().max(1) as f32;
            img.iter()
                .enumerate()
                .map(move |(i, &l)| 2.0 * (l - perturbed(i, l)) / n)
        })
        .collect()
}

/// The arguments of the side-by-side examples (`examples/adaptive_gain.rs`,
/// `examples/replay_gain.rs`): scene names and `--repeats N` (default `repeats`); no names give
/// S and M.
pub fn example_args(repeats: usize) -> anyhow::Result<(Vec<String>, usize)> {
    let (mut names, mut reps) = (Vec::new(), repeats);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--repeats" {
            reps = args
                .next()
                .ok_or_else(|| anyhow::anyhow!("--repeats needs a number"))?
                .parse()?;
        } else {
            names.push(a);
        }
    }
    if names.is_empty() {
        names = vec!["S".into(), "M".into()];
    }
    Ok((names, reps))
}

/// A bench size (`S`, `M`, `P`, `L`, `NxVxR`) or a scene file (a design's `design.json`).
pub fn scene_named(name: &str) -> anyhow::Result<Scene> {
    match bench_scene(name) {
        Some(s) => Ok(s),
        None => Ok(Scene::load(std::path::Path::new(name))?),
    }
}

/// Markdown table of forward rows.
pub fn forward_table(ctx: &Context, rows: &[ForwardRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "device: {} ({})", ctx.info().name, ctx.info().kind);
    let _ = writeln!(
        s,
        "| scene | scratches | views x pixels | tile entries | candidates | pairs | pair search ms/view (mode, bands) | binning threads | tile tests per thread (most) | shading ms/view | backward ms/view | forward Mpairs/s | forward GFLOP/s | backward Mpairs/s | backward GFLOP/s |"
    );
    let _ = writeln!(
        s,
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let mut ratios = String::new();
    for r in rows {
        let v = r.views as f64;
        if r.backward_dual_ms.is_finite() {
            let _ = writeln!(
                ratios,
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
                r.name,
                r.shade_ms / v,
                r.backward_ms / v,
                r.backward_dual_ms / v,
                r.backward_ms / r.shade_ms,
                r.backward_dual_ms / r.backward_ms
            );
        }
        let secs = r.shade_ms * 1e-3;
        let flops = r.pairs as f64 * FLOPS_PER_PAIR + (r.candidates - r.pairs) as f64 * FLOPS_PER_CANDIDATE;
        let _ = writeln!(
            s,
            "| {} | {} | {} x {} | {} | {} | {} | {:.2} ({}, {}) | {} | {} | {:.2} | {:.2} | {:.1} | {:.1} | {:.1} | {:.1} |",
            r.name,
            r.scratches,
            r.views,
            r.pixels / r.views as u64,
            r.entries,
            r.candidates,
            r.pairs,
            r.bin_ms / v,
            r.mode.name(),
            r.bands,
            r.bin_threads,
            r.bin_tests_per_thread,
            r.shade_ms / v,
            r.backward_ms / v,
            r.pairs as f64 / secs * 1e-6,
            flops / secs * 1e-9,
            r.pairs as f64 / (r.backward_ms * 1e-3) * 1e-6,
            r.pairs as f64 * FLOPS_PER_PAIR_BACKWARD / (r.backward_ms * 1e-3) * 1e-9
        );
    }
    if !ratios.is_empty() {
        let _ = writeln!(s, "\nbackward kernels, timed in the same submissions (ms per view):\n");
        let _ = writeln!(
            s,
            "| scene | forward shading | backward (reverse mode) | backward (dual numbers) | backward / forward | dual / reverse |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
        s.push_str(&ratios);
    }
    s
}

/// One row of the full-iteration benchmark: the design loop itself (`optim::design::Optimizer`),
/// GPU stage times as medians over the timed iterations, wall time over all of them.
#[derive(Clone, Debug)]
pub struct IterRow {
    pub name: String,
    pub scratches: usize,
    pub views: usize,
    pub pixels: u64,
    pub iters: u32,
    /// median GPU ms per stage: binning, forward, loss, loss backward, backward, adam
    pub stages: Vec<(String, f64)>,
    /// median of the stage sum
    pub gpu_ms: f64,
    /// wall-clock seconds of the timed iterations (host work and read-backs included)
    pub wall_s: f64,
    pub pairs_per_iter: f64,
    /// Device memory: what the job states before it starts (a lower bound,
    /// `SceneDims::device_bytes`) and what its buffers held after the iterations.
    pub device_bytes: (u64, u64),
}

/// Display-value targets for a benchmark: given linear targets (`--targets`), or the scene's own
/// render brightened/dimmed by 10% in a fixed pattern (so the loss and gradients are not zero).
pub fn bench_targets(
    ctx: &Arc<Context>,
    scene: &Scene,
    linear: Option<Vec<Vec<f32>>>,
) -> Result<Vec<Vec<f32>>, GpuError> {
    let lin = match linear {
        Some(t) => t,
        None => {
            let r = Renderer::new(ctx)?;
            let mut gs = r.upload(scene)?;
            let imgs = r.render(&mut gs)?.images;
            imgs.into_iter()
                .map(|img| img.iter().enumerate().map(|(i, &l)| perturbed(i, l)).collect())
                .collect()
        }
    };
    Ok(lin
        .into_iter()
        .map(|img| {
            img.into_iter()
                .map(|l| scratchart_render::io::display_value(l).min(1.0))
                .collect()
        })
        .collect())
}

/// Runs `warmup + iters` optimizer iterations on `scene` and reports the timed ones.
pub fn run_iterations(
    ctx: &Arc<Context>,
    name: &str,
    scene: &Scene,
    targets: Vec<Vec<f32>>,
    warmup: u32,
    iters: u32,
) -> anyhow::Result<IterRow> {
    use scratchart_design::design::Optimizer;
    use scratchart_design::problem::{DesignConfig, Problem};
    let renderer = Renderer::new(ctx)?;
    let problem = Problem::new(scene.clone(), targets);
    let mut cfg = DesignConfig::new(scene.plate.size_mm, std::env::temp_dir());
    cfg.iters = warmup + iters;
    cfg.write_outputs = false;
    cfg.calibrate_lights = false;
    cfg.checkpoint_every = 0;
    let loss = scratchart_optim::loss::Loss::new(
        ctx,
        &scratchart_render::layout::view_slots(scene).views,
        &problem.targets,
        cfg.loss,
    )?;
    let mut opt = Optimizer::new(&renderer, &loss, &problem, &cfg)?;
    let t0 = std::time::Instant::now();
    let (_, _) = opt.run(&scratchart_observe::Silent)?;
    let wall = t0.elapsed().as_secs_f64();
    let steps: Vec<&Vec<(String, f64)>> = opt
        .driver
        .stats
        .timing_log
        .iter()
        .filter(|t| t.iter().any(|(l, _)| l == "adam"))
        .skip(warmup as usize)
        .collect();
    let labels = ["binning", "forward", "loss", "loss backward", "backward", "adam"];
    let stages: Vec<(String, f64)> = labels
        .iter()
        .map(|l| {
            let v: Vec<f64> = steps
                .iter()
                .filter_map(|t| t.iter().find(|(x, _)| x == l).map(|e| e.1))
                .collect();
            (l.to_string(), if v.is_empty() { f64::NAN } else { median(v) })
        })
        .collect();
    let gpu_ms = median(steps.iter().map(|t| t.iter().map(|e| e.1).sum::<f64>()).collect());
    // Wall time of the timed part: total minus the warm-up share (iterations are alike).
    let n_all = (warmup + iters + 1) as f64;
    let wall_s = wall * (iters as f64 / n_all);
    let report_pairs = opt.driver.gs.stats()?.pairs as f64;
    let sizes: Vec<(u32, u32)> = scene.views.iter().map(|v| (v.camera.width, v.camera.height)).collect();
    let stated = scratchart_render::limits::SceneDims::new(&sizes, scene.scratches.len() as u64, true);
    Ok(IterRow {
        name: name.to_string(),
        scratches: scene.scratches.len(),
        views: scene.views.len(),
        pixels: scene
            .views
            .iter()
            .map(|v| v.camera.width as u64 * v.camera.height as u64)
            .sum(),
        iters,
        stages,
        gpu_ms,
        wall_s,
        pairs_per_iter: report_pairs,
        device_bytes: (stated.device_bytes(ctx.info()), ctx.allocated_bytes()),
    })
}

/// Markdown table of full-iteration rows.
pub fn iteration_table(rows: &[IterRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scene | scratches | views x pixels | pairs/iter | binning | forward | loss | loss bwd | backward | Adam | GPU ms/iter | wall s for iters | device memory stated / held |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let st: Vec<String> = r.stages.iter().map(|(_, ms)| format!("{ms:.1}")).collect();
        let _ = writeln!(
            s,
            "| {} | {} | {} x {} | {:.3e} | {} | {:.1} | {:.2} s for {} | {} / {} |",
            r.name,
            r.scratches,
            r.views,
            r.pixels / r.views as u64,
            r.pairs_per_iter,
            st.join(" | "),
            r.gpu_ms,
            r.wall_s,
            r.iters,
            scratchart_render::limits::mib(r.device_bytes.0),
            scratchart_render::limits::mib(r.device_bytes.1)
        );
    }
    s
}

/// Binning's pass over (scratch, tile) work in `mode` with `bands` bands of tile rows per view
/// (0: none): (threads, the most tile tests one thread makes), counted on the host as
/// `shaders/bin.comp`'s COUNT pass loops (its projected bounding boxes, here in float64: a bound
/// that falls on a tile edge may count a tile more or less). It depends on the scene and the
/// mode only, not on the device; `GpuScene::binning_threads` and `RenderStats::bin_tests_per_thread`
/// give the device's own figures for a render.
pub fn binning_work(scene: &Scene, mode: scratchart_render::BinMode, bands: u32) -> (u64, u64) {
    use scratchart_model::camera::ViewGeom;
    use scratchart_render::layout::TILE;
    let n = scene.scratches.len();
    let nv = scene.views.len();
    let geoms: Vec<ViewGeom> = scene.views.iter().map(ViewGeom::new).collect();
    // Per (scratch, view): tile rows [r0, r1] and columns, or None.
    let boxes: Vec<Option<(u32, u32, u32)>> = scene
        .scratches
        .iter()
        .flat_map(|s| {
            let geoms = &geoms;
            (0..nv).map(move |v| {
                let g = &geoms[v];
                let (tw, th) = (g.width.div_ceil(TILE), g.height.div_ceil(TILE));
                let d = [s.p1[0] - s.p0[0], s.p1[1] - s.p0[1]];
                let l = d[0].hypot(d[1]);
                if l.is_nan() || l <= 0.0 {
                    return None;
                }
                let t = [d[0] / l, d[1] / l];
                let b = [-t[1], t[0]];
                let e = s.half_width();
                let corners = [(s.p0, -e), (s.p1, -e), (s.p1, e), (s.p0, e)];
                let mut lo = [f64::INFINITY; 2];
                let mut hi = [f64::NEG_INFINITY; 2];
                for (p, off) in corners {
                    match g.project([p[0] + off * b[0], p[1] + off * b[1], 0.0]) {
                        Some((x, y)) => {
                            lo = [lo[0].min(x), lo[1].min(y)];
                            hi = [hi[0].max(x), hi[1].max(y)];
                        }
                        // Behind the camera: the whole view (bin.comp's conservative case).
                        None => return Some((0, th - 1, tw)),
                    }
                }
                let (lo, hi) = ([lo[0] - 0.5, lo[1] - 0.5], [hi[0] + 0.5, hi[1] + 0.5]);
                if hi[0] < 0.0 || hi[1] < 0.0 || lo[0] > g.width as f64 || lo[1] > g.height as f64 {
                    return None;
                }
                let tx0 = lo[0].max(0.0) as u32 / TILE;
                let ty0 = lo[1].max(0.0) as u32 / TILE;
                let tx1 = (hi[0].min(g.width as f64) as u32 / TILE).min(tw - 1);
                let ty1 = (hi[1].min(g.height as f64) as u32 / TILE).min(th - 1);
                Some((ty0, ty1, tx1 + 1 - tx0.min(tx1 + 1)))
            })
        })
        .collect();
    let rows_of = |v: usize| geoms[v].height.div_ceil(TILE);
    // Tile tests of scratch k in view v within band `band` of `nb` (nb = 0: every row).
    let tests = |k: usize, v: usize, band: u32, nb: u32| -> u64 {
        let Some((r0, r1, cols)) = boxes[k * nv + v] else {
            return 0;
        };
        let (lo, hi) = match (band * rows_of(v)).checked_div(nb) {
            None => (0, rows_of(v)),
            Some(lo) => (lo, (band + 1) * rows_of(v) / nb),
        };
        let (a, b) = (r0.max(lo), (r1 + 1).min(hi));
        if b > a {
            (b - a) as u64 * cols as u64
        } else {
            0
        }
    };
    let group = match mode {
        scratchart_render::BinMode::Groups => scratchart_render::GROUP_SIZE as usize,
        scratchart_render::BinMode::Pairs => 1,
    };
    let n_groups = n.div_ceil(group).max(1);
    let parts = if bands == 0 { 1 } else { nv as u64 * bands as u64 };
    let mut most = 0u64;
    for g in 0..n_groups {
        let ks = g * group..((g + 1) * group).min(n);
        if bands == 0 {
            let t: u64 = ks
                .clone()
                .flat_map(|k| (0..nv).map(move |v| (k, v)))
                .map(|(k, v)| tests(k, v, 0, 0))
                .sum();
            most = most.max(t);
        } else {
            for v in 0..nv {
                for band in 0..bands {
                    let t: u64 = ks.clone().map(|k| tests(k, v, band, bands)).sum();
                    most = most.max(t);
                }
            }
        }
    }
    (n_groups as u64 * parts, most)
}

/// Markdown table of binning's work for each scene, in both modes, with the bands a GPU
/// chooses and without bands (a CPU driver's choice for groups).
pub fn binning_work_table(scenes: &[(String, Scene)]) -> String {
    use scratchart_render::{bands_on_gpu, BinMode};
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scene | scratches | views x pixels | mode | bands per view | binning threads | tile tests per thread (most) |"
    );
    let _ = writeln!(s, "|---|---:|---:|---|---:|---:|---:|");
    for (name, scene) in scenes {
        let max_rows = scene
            .views
            .iter()
            .map(|v| v.camera.height.div_ceil(scratchart_render::layout::TILE))
            .max()
            .unwrap_or(1);
        let n = scene.scratches.len() as u32;
        let nv = scene.views.len() as u32;
        let rows = [
            (BinMode::Groups, 0, "groups, no bands (CPU drivers)"),
            (
                BinMode::Groups,
                bands_on_gpu(BinMode::Groups, n, nv, max_rows),
                "groups (GPUs before)",
            ),
            (
                BinMode::Pairs,
                bands_on_gpu(BinMode::Pairs, n, nv, max_rows),
                "pairs (GPUs now)",
            ),
        ];
        for (mode, bands, label) in rows {
            let (threads, most) = binning_work(scene, mode, bands);
            let v = &scene.views[0].camera;
            let _ = writeln!(
                s,
                "| {name} | {n} | {nv} x {}x{} | {label} | {bands} | {threads} | {most} |",
                v.width, v.height
            );
        }
    }
    let _ = writeln!(
        s,
        "
The pairs mode's sort adds {} passes of 8 bits per render here at most, each a thread per pair whose longest loop is 46 steps (its rank in a block of 256).",
        scenes
            .iter()
            .map(|(_, sc)| {
                let tiles: u32 = sc
                    .views
                    .iter()
                    .map(|v| v.camera.width.div_ceil(scratchart_render::layout::TILE) * v.camera.height.div_ceil(scratchart_render::layout::TILE))
                    .sum();
                scratchart_render::radix_passes(tiles)
            })
            .max()
            .unwrap_or(1)
    );
    s
}

/// Standard benchmark scenes. S: 4,000 scratches, 2 views of 128x128. M: 40,000 scratches,
/// 3 views of 256x256. P (paper scale): 40,000 scratches, 3 views of 512x512. L (to fill a big
/// GPU): 160,000 scratches, 3 views of 1024x1024. `NxVxR`: N scratches, V views of R x R (for
/// scaling tables). `NxVxRw`: N scratches, V views (2 to 64) of R x R along a walk's 60 degree
/// arc (`design --walk`; for how the cost grows with the views). All: random
/// endpoints over a 100 mm plate, lengths 5-30 mm, w = d = 0.05 mm, alpha 0.04, views at 45
/// degrees elevation and azimuths 0/120/240 (0/180 for S), one point light at 45 degrees.
pub fn bench_scene(name: &str) -> Option<Scene> {
    let (name, walk) = match name.strip_suffix(['w', 'W']) {
        Some(n) => (n, true),
        None => (name, false),
    };
    let (n, views, res) = match name {
        "S" | "s" | "M" | "m" | "P" | "p" | "L" | "l" if walk => return None,
        "S" | "s" => (4_000, 2, 128),
        "M" | "m" => (40_000, 3, 256),
        "P" | "p" => (40_000, 3, 512),
        "L" | "l" => (160_000, 3, 1024),
        _ => {
            // NxVxR: N scratches, V views (1 to 3) of R x R pixels (for scaling tables)
            let p: Vec<u32> = name.split(['x', 'X']).map(|t| t.parse().ok()).collect::<Option<_>>()?;
            match p[..] {
                [n, v, r] if n > 0 && walk && (2..=64).contains(&v) && (16..=8192).contains(&r) => {
                    (n as usize, v as usize, r)
                }
                [n, v, r] if n > 0 && (1..=3).contains(&v) && (16..=8192).contains(&r) => (n as usize, v as usize, r),
                _ => return None,
            }
        }
    };
    let plate = 100.0;
    let mut rng = Rng::new(0x5C2A7C4 + n as u64);
    let light = orbit_light(300.0, 45.0, 60.0, 90_000.0);
    let vs = if walk {
        let arc = scratchart_design::walk::WalkArc {
            arc_deg: 60.0,
            centre_azimuth_deg: 0.0,
            elevation_deg: 45.0,
            distance_mm: 300.0,
            views,
            between: 0,
            res,
        };
        scratchart_design::walk::arc_views(&arc, &scratchart_model::scene::Plate::flat(plate), &light).0
    } else {
        let mut vs = ring_views(3, 45.0, 300.0, plate, res, &light);
        vs.truncate(views);
        vs
    };
    Some(Scene {
        plate: Plate {
            size_mm: plate,
            roughness: 0.02,
            f0: 0.91,
            shape: Default::default(),
        },
        views: vs,
        scratches: random_scratches(&mut rng, n, plate, 5.0, 30.0, 0.05, 0.05, 0.04),
    })
}
