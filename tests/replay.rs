//! The backward's replay of the forward's pair queues (`KernelSet::replay`, the default): the
//! forward stores every chunk's queue and the backward integrates the stored entries instead of
//! searching the pairs again (`replay_stream` in `shaders/grad.comp`). It must change no
//! bit of the gradients against the backward that searches, whatever the store holds: sized by
//! the host, too small for the scene, left over from other scratches, or split into passes.
use scratchart_render::kernels::{KernelSet, Walk};
use scratchart_render::{GpuScene, Renderer};
use scratchart_tests::*;

/// dE/dL with zeros (a third of the pixels: their pairs are in the forward's queue but not in a
/// searching backward's) and both signs.
fn seeds(n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| {
            if i % 3 == 0 {
                0.0
            } else {
                ((i * 31) % 97) as f32 * 1e-2 - 0.4
            }
        })
        .collect()
}

/// Images (one per view) and gradients of one forward + backward.
type Run = (Vec<Vec<f32>>, scratchart_render::grad::Gradients);

fn assert_same_bits(label: &str, a: &Run, b: &Run) {
    for (v, (x, y)) in a.0.iter().zip(&b.0).enumerate() {
        assert!(
            x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()),
            "{label}: view {v}'s images differ"
        );
    }
    let mut nonzero = 0;
    for (k, (x, y)) in a.1.scratches.iter().zip(&b.1.scratches).enumerate() {
        for p in 0..7 {
            assert_eq!(
                x[p].to_bits(),
                y[p].to_bits(),
                "{label}: scratch {k} parameter {p}: {} vs {}",
                x[p],
                y[p]
            );
        }
        nonzero += x.iter().any(|g| *g != 0.0) as usize;
    }
    assert!(
        nonzero * 2 > a.1.scratches.len(),
        "{label}: only {nonzero} non-zero gradients"
    );
    assert_eq!(a.1.lights, b.1.lights, "{label}: light gradients differ");
}

/// Gradients through the replay (a backward first sizes the store; the second replays).
fn replayed(r: &Renderer, gs: &mut GpuScene, dl: &[f32]) -> Run {
    r.gradients(gs, dl).unwrap();
    assert!(gs.replay_ready(), "the first backward did not size the pair store");
    r.gradients(gs, dl).unwrap()
}

/// On an ordinary two-view scene, in one pass and split into passes of 1 and 2 chunks, the
/// replay's gradients equal those of the backward that searches, bit for bit.
#[test]
fn replay_changes_no_bit() {
    let ctx = gpu();
    let scene = two_view_scene(3, 1500, 40, 33);
    let replay = Renderer::new(&ctx).unwrap();
    assert!(replay.kernels().replay, "the default kernels replay");
    let search = Renderer::with_kernels(&ctx, KernelSet::default().without_replay()).unwrap();
    let mut gs = search.upload(&scene).unwrap();
    let dl = seeds(gs.n_pixels() as usize);
    let a = search.gradients(&mut gs, &dl).unwrap();
    search.gradients(&mut gs, &dl).unwrap();
    assert!(!gs.replay_ready(), "a backward without replay sized a store");
    let mut gr = replay.upload(&scene).unwrap();
    let b = replayed(&replay, &mut gr, &dl);
    assert_same_bits("one pass", &a, &b);
    let max_chunks = replay.render(&mut gr).unwrap().stats.max_tile_chunks as u32;
    assert!(max_chunks >= 2, "{max_chunks}");
    for m in [1, 2] {
        let mut g2 = replay.upload(&scene).unwrap();
        g2.force_chunks_per_pass(&ctx, m, max_chunks).unwrap();
        let c = replayed(&replay, &mut g2, &dl);
        assert!(g2.shading_passes().1 > 1);
        assert_same_bits(&format!("{m} chunks per pass"), &a, &c);
    }
    assert_no_validation(&ctx);
}

/// A store too small for the scene (the forward leaves chunks out) and a store sized for other
/// scratches (longer ones now: more pairs) are found out by the replay and grown: the gradients
/// are still those of the searching backward, bit for bit.
#[test]
fn a_store_that_lacks_chunks_is_grown_not_trusted() {
    let ctx = gpu();
    let mut scene = two_view_scene(5, 800, 36, 40);
    let replay = Renderer::new(&ctx).unwrap();
    let search = Renderer::with_kernels(&ctx, KernelSet::default().without_replay()).unwrap();
    let mut gs = search.upload(&scene).unwrap();
    let dl = seeds(gs.n_pixels() as usize);
    let a = search.gradients(&mut gs, &dl).unwrap();
    let pairs = search.render(&mut gs).unwrap().stats.pairs;

    let mut gr = replay.upload(&scene).unwrap();
    gr.force_store_capacity(&ctx, 1000).unwrap();
    let b = replay.gradients(&mut gr, &dl).unwrap();
    assert!(
        gr.store_capacity() as u64 >= pairs,
        "store of {} entries for {pairs} pairs",
        gr.store_capacity()
    );
    assert_same_bits("a store of 1000 entries", &a, &b);

    // Longer and wider scratches: a store about the size of this scene's queues (grown if the
    // queues hold more than the pairs) is too small for their pairs.
    gr.force_store_capacity(&ctx, pairs as u32 + 16).unwrap();
    let b1 = replay.gradients(&mut gr, &dl).unwrap();
    assert_same_bits("a store of the pairs' size", &a, &b1);
    let before = gr.store_capacity();
    for s in &mut scene.scratches {
        s.w *= 8.0;
        let (dx, dy) = (s.p1[0] - s.p0[0], s.p1[1] - s.p0[1]);
        s.p1 = [
            (s.p0[0] + 1.6 * dx).clamp(-9.5, 9.5),
            (s.p0[1] + 1.6 * dy).clamp(-9.5, 9.5),
        ];
    }
    scene.validate().unwrap();
    assert!(gr.update_scratches(&ctx, &scene.scratches).unwrap());
    assert!(gs.update_scratches(&ctx, &scene.scratches).unwrap());
    let a2 = search.gradients(&mut gs, &dl).unwrap();
    let pairs2 = search.render(&mut gs).unwrap().stats.pairs;
    assert!(
        pairs2 > before as u64,
        "{pairs2} pairs now, {before} stored: the test is vacuous"
    );
    let b2 = replay.gradients(&mut gr, &dl).unwrap();
    assert!(
        gr.store_capacity() > before,
        "the store did not grow ({before} entries)"
    );
    assert_same_bits("a store sized for shorter scratches", &a2, &b2);
    assert_no_validation(&ctx);
}

/// The backward of `walk` on `scene` (searching, or replaying the forward's queues).
fn run_walk(
    ctx: &std::sync::Arc<scratchart_vulkan::Context>,
    scene: &scratchart_model::scene::Scene,
    walk: Walk,
    replay: bool,
) -> Run {
    let mut k = KernelSet::default().with_walk(walk);
    if !replay {
        k = k.without_replay();
    }
    let r = Renderer::with_kernels(ctx, k).unwrap();
    let mut gs = r.upload(scene).unwrap();
    let dl = seeds(gs.n_pixels() as usize);
    if replay {
        replayed(&r, &mut gs, &dl)
    } else {
        r.gradients(&mut gs, &dl).unwrap()
    }
}

/// The backward's rounds walked by masks that every thread sets (`Walk::Every`) or by lists of
/// thread 0 (`Walk::One`, CPU drivers) add each scratch's entries in the same order: gradients
/// equal bit for bit, searching and replaying, on a scene whose tiles hold many scratches (full
/// rounds, scratches far apart in a round) and in passes of one chunk.
#[test]
fn masks_walked_by_one_thread_change_no_bit() {
    let ctx = gpu();
    for (seed, n) in [(3, 1500), (8, 6000)] {
        let scene = two_view_scene(seed, n, 40, 33);
        for replay in [false, true] {
            let label = format!("{n} scratches, replay {replay}");
            assert_same_bits(
                &label,
                &run_walk(&ctx, &scene, Walk::One, replay),
                &run_walk(&ctx, &scene, Walk::Every, replay),
            );
        }
    }
    assert_no_validation(&ctx);
}

/// GPUs' walk (`Walk::Split`: two threads per scratch, whose shares are added when a chunk
/// closes) sums in another order than the CPU's: every gradient within SPLIT_TOL of its
/// parameter's largest gradient over the scene, the images the same bits; its search and its
/// replay give the same bits.
#[test]
fn the_split_walk_differs_only_by_rounding() {
    const SPLIT_TOL: f64 = 1e-6;
    let ctx = gpu();
    for (seed, n) in [(3, 1500), (8, 6000)] {
        let scene = two_view_scene(seed, n, 40, 33);
        for replay in [false, true] {
            let label = format!("{n} scratches, replay {replay}");
            let (a, b) = (
                run_walk(&ctx, &scene, Walk::One, replay),
                run_walk(&ctx, &scene, Walk::Split, replay),
            );
            if replay {
                // Its shares follow the entries' places in their chunk's queue: the search's
                // are the replay's.
                let searched = run_walk(&ctx, &scene, Walk::Split, false);
                assert_same_bits(&format!("{label}, split: search against replay"), &searched, &b);
            }
            for (v, (x, y)) in a.0.iter().zip(&b.0).enumerate() {
                assert!(
                    x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()),
                    "{label}: view {v}'s images differ"
                );
            }
            let (ga, gb) = (&a.1.scratches, &b.1.scratches);
            let (mut worst, mut differ) = (0.0f64, 0usize);
            for p in 0..7 {
                let scale = ga.iter().map(|g| g[p].abs() as f64).fold(0.0, f64::max);
                assert!(scale > 0.0, "{label}: parameter {p} has no gradient");
                for (k, (x, y)) in ga.iter().zip(gb).enumerate() {
                    let d = (x[p] as f64 - y[p] as f64).abs() / scale;
                    assert!(
                        d <= SPLIT_TOL,
                        "{label}: scratch {k} parameter {p}: {} vs {} ({d:.2e} of the largest)",
                        x[p],
                        y[p]
                    );
                    worst = worst.max(d);
                    differ += (x[p] != y[p]) as usize;
                }
            }
            eprintln!("{label}: {differ} gradients differ, the largest by {worst:.2e} of its parameter's largest");
            // Another order of sums shows in some bits: none would mean the split was not built.
            assert!(differ > 0, "{label}: the split walk summed as thread 0's lists do");
            // The lamps' gradients do not go through the walk.
            assert_eq!(a.1.lights, b.1.lights, "{label}: light gradients differ");
        }
    }
    assert_no_validation(&ctx);
}
