//! What the backward's replay of the forward's pair queues (`KernelSet::replay`, the default)
//! gains over a backward that searches the pairs again: two renderers on the same scene, one with
//! the replay and one without, forward + backward submissions alternated, GPU time of each stage
//! (Vulkan timestamps) per repeat; prints the medians, the median of the per-repeat ratios, and
//! whether images and gradients are bit-identical. Run:
//!   cargo run --release -p scratchart --example replay_gain -- [SCENE ...] [--repeats N]
//! SCENE: a bench size (S, M, P) or a scene file (a design's `design.json`); default S M.
use scratchart::bench::{median, perturbed_target_dl};
use scratchart_render::kernels::KernelSet;
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, ContextDesc, Recorder};

fn main() -> anyhow::Result<()> {
    let (names, reps) = scratchart::bench::example_args(5)?;
    let ctx = Context::new(ContextDesc::default())?;
    println!("device: {}", ctx.info().name);
    let replay = Renderer::new(&ctx)?;
    let search = Renderer::with_kernels(&ctx, KernelSet::default().without_replay())?;
    replay.prepare_backward()?;
    search.prepare_backward()?;
    println!("| scene | pairs | store MB | forward ms: search / replay | backward ms: search / replay | backward: search / replay | forward + backward: search / replay | bits |");
    println!("|---|---:|---:|---:|---:|---:|---:|---|");
    for name in &names {
        let scene = scratchart::bench::scene_named(name)?;
        let mut gr = replay.upload(&scene)?;
        let mut gs = search.upload(&scene)?;
        let first = search.render(&mut gs)?;
        let dl = perturbed_target_dl(&first.images);
        // The first backward on a scene searches and sizes the store; the second replays.
        replay.gradients(&mut gr, &dl)?;
        let (ir, dr) = replay.gradients(&mut gr, &dl)?;
        let (is, ds) = search.gradients(&mut gs, &dl)?;
        anyhow::ensure!(gr.replay_ready(), "the scene's pair store was not sized");
        let same = ir == is && dr.scratches == ds.scratches && dr.lights == ds.lights;
        let mut rec = Recorder::new(&ctx)?;
        let mut t = [[Vec::new(), Vec::new()], [Vec::new(), Vec::new()]]; // [renderer][fwd, bwd]
        let (mut rb, mut rt) = (Vec::new(), Vec::new());
        for rep in 0..reps + 1 {
            let mut one = [[0.0f64; 2]; 2];
            for (v, (r, g)) in [(&search, &mut gs), (&replay, &mut gr)].into_iter().enumerate() {
                let (_, tm) = r.submit(&mut rec, g, |rec, g| {
                    r.record_render(rec, g);
                    r.record_backward(rec, g);
                    rec.timestamp("backward");
                })?;
                one[v] = [
                    tm.get("forward").unwrap_or(f64::NAN),
                    tm.get("backward").unwrap_or(f64::NAN),
                ];
            }
            if rep == 0 {
                continue; // warm-up
            }
            for v in 0..2 {
                t[v][0].push(one[v][0]);
                t[v][1].push(one[v][1]);
            }
            rb.push(one[0][1] / one[1][1]);
            rt.push((one[0][0] + one[0][1]) / (one[1][0] + one[1][1]));
        }
        let m = |x: &Vec<f64>| median(x.clone());
        println!(
            "| {name} | {} | {:.1} | {:.1} / {:.1} | {:.1} / {:.1} | {:.3} | {:.3} | {} |",
            first.stats.pairs,
            gr.store_size() as f64 / 1e6,
            m(&t[0][0]),
            m(&t[1][0]),
            m(&t[0][1]),
            m(&t[1][1]),
            median(rb),
            median(rt),
            if same { "identical" } else { "DIFFER" }
        );
    }
    Ok(())
}
