//! Capacities at and beyond their limits: thousands of scratches per tile, scratches over every
//! tile, every scratch through one pixel. Mesa's llvmpipe (CI's device) ends every loop of a
//! shader invocation after 65535 iterations in all, which silently dropped the pairs of dense
//! tiles (black tiles, exit 0); the kernels now detect it and the host splits the work into
//! passes or smaller binning groups (`shaders/inc/limits.glsl`). These tests check the results
//! against the float64 reference and check that splitting changes no bit. On a device without
//! such a limit nothing is split, and the same comparisons hold.
use scratchart_design::scenes::Rng;
use scratchart_model::reference;
use scratchart_model::scene::Scene;
use scratchart_render::Renderer;
use scratchart_tests::*;

fn is_llvmpipe(ctx: &scratchart_vulkan::Context) -> bool {
    ctx.info().name.contains("llvmpipe")
}

/// `n` scratches packed into a `patch` mm square at the plate centre (100 mm plate), one view.
fn packed(n: usize, patch: f64, res: u32, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let h = 0.5 * patch;
    let mut scratches = Vec::with_capacity(n);
    while scratches.len() < n {
        let p0 = [rng.range(-h, h), rng.range(-h, h)];
        let (l, a) = (rng.range(0.5, 3.0), rng.range(0.0, std::f64::consts::TAU));
        let p1 = [(p0[0] + l * a.cos()).clamp(-h, h), (p0[1] + l * a.sin()).clamp(-h, h)];
        if (p1[0] - p0[0]).hypot(p1[1] - p0[1]) > 0.1 {
            scratches.push(scratch(p0, p1, 0.05, 0.05, 0.2));
        }
    }
    Scene {
        plate: plate(100.0),
        views: vec![orbit_view("a", res, 50.0, 0.0, 50.0, 180.0, 100.0)],
        scratches,
    }
}

/// Compares the listed pixels of view 0 with the float64 reference (engine/docs/model.md section 8 bar,
/// against the view's maximum) and names the worst.
fn assert_pixels_match(label: &str, scene: &Scene, image: &[f32], pixels: &[(u32, u32)], max_l: f64) {
    let w = scene.views[0].camera.width;
    let mut worst = (0.0f64, 0u32, 0u32, 0.0f32, 0.0f64);
    let (mut bad, mut lit) = (0, 0);
    for &(i, j) in pixels {
        let r = reference::pixel(scene, 0, i, j).l;
        let g = image[(j * w + i) as usize];
        if r > 1e-3 * max_l {
            lit += 1;
        }
        let err = (g as f64 - r).abs();
        let rel = if r != 0.0 { err / r.abs() } else { err };
        if !(rel <= 1e-3 || err <= 1e-6 * max_l) {
            bad += 1;
        }
        if rel > worst.0 && err > 1e-6 * max_l {
            worst = (rel, i, j, g, r);
        }
    }
    // The comparison must be about something: most sampled pixels are lit.
    assert!(
        lit * 2 >= pixels.len(),
        "{label}: only {lit} of {} pixels are lit",
        pixels.len()
    );
    eprintln!(
        "{label}: {lit} lit, {} of {} pixels outside the bar; worst relative error {:.3e} at ({}, {}): gpu {} reference {}",
        bad,
        pixels.len(),
        worst.0,
        worst.1,
        worst.2,
        worst.3,
        worst.4
    );
    // engine/docs/model.md: 99% of on-plate pixels within the bar.
    assert!(
        bad * 100 <= pixels.len(),
        "{label}: {bad} of {} pixels outside the bar; worst at ({}, {}): gpu {} reference {}",
        pixels.len(),
        worst.1,
        worst.2,
        worst.3,
        worst.4
    );
}

/// The pixels of view 0 whose footprint centre lies in the `half` mm square at the centre.
fn pixels_near_centre(scene: &Scene, half: f64) -> Vec<(u32, u32)> {
    let g = scratchart_model::camera::ViewGeom::new(&scene.views[0]);
    let c = &scene.views[0].camera;
    let mut v = Vec::new();
    for j in 0..c.height {
        for i in 0..c.width {
            if let Some(x) = g.shading_point(i, j) {
                if x[0].abs() <= half && x[1].abs() <= half {
                    v.push((i, j));
                }
            }
        }
    }
    v
}

/// 84,000 scratches in a 6 mm patch: one tile holds them all (1313 chunks), which is over
/// llvmpipe's loop limit in one forward pass (3 passes; the tile loop's own loops are short, so
/// it takes this many chunks). The render must match the reference there.
#[test]
fn a_tile_with_thousands_of_scratches_is_complete() {
    let ctx = gpu();
    let scene = packed(84_000, 6.0, 112, 7);
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let frame = r.render(&mut gs).unwrap();
    eprintln!(
        "{} pairs, longest tile list {} chunks, forward/backward passes {:?}",
        frame.stats.pairs,
        frame.stats.max_tile_chunks,
        gs.shading_passes()
    );
    assert!(frame.stats.max_tile_chunks >= 200, "the scene must be dense");
    assert!(frame.stats.pairs > 20_000, "pairs were dropped: {}", frame.stats.pairs);
    if is_llvmpipe(&ctx) {
        assert!(gs.shading_passes().0 > 1, "llvmpipe must need more than one pass here");
    }
    let px = pixels_near_centre(&scene, 4.0);
    assert!(px.len() >= 20, "{} pixels", px.len());
    let max_l = frame.images[0].iter().cloned().fold(0.0f32, f32::max) as f64;
    assert_pixels_match("packed patch", &scene, &frame.images[0], &px, max_l);
    assert_no_validation(&ctx);
}

/// The same dense tile through the backward pass: gradients with the passes the device needed
/// equal, bit for bit, those with one chunk per pass (far below any limit), and are not zero.
#[test]
fn dense_tile_gradients_are_complete() {
    let ctx = gpu();
    let scene = packed(84_000, 6.0, 112, 7);
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let n = gs.n_pixels() as usize;
    let dl: Vec<f32> = (0..n).map(|i| ((i * 7919) % 1000) as f32 * 1e-3 - 0.5).collect();
    let (img_a, g_a) = r.gradients(&mut gs, &dl).unwrap();
    let max_chunks = r.render(&mut gs).unwrap().stats.max_tile_chunks as u32;
    let mut gs1 = r.upload(&scene).unwrap();
    gs1.force_chunks_per_pass(&ctx, 1, max_chunks).unwrap();
    let (img_b, g_b) = r.gradients(&mut gs1, &dl).unwrap();
    assert_eq!(gs1.shading_passes().0, max_chunks);
    assert!(
        img_a[0].iter().zip(&img_b[0]).all(|(a, b)| a.to_bits() == b.to_bits()),
        "images differ"
    );
    for (k, (a, b)) in g_a.scratches.iter().zip(&g_b.scratches).enumerate() {
        for p in 0..7 {
            assert_eq!(
                a[p].to_bits(),
                b[p].to_bits(),
                "scratch {k} parameter {p}: {} vs {}",
                a[p],
                b[p]
            );
        }
    }
    let nonzero = g_a.scratches.iter().filter(|g| g.iter().any(|x| *x != 0.0)).count();
    eprintln!(
        "{nonzero} of {} scratches have a non-zero gradient",
        g_a.scratches.len()
    );
    assert!(nonzero * 2 > g_a.scratches.len(), "too few gradients: {nonzero}");
    assert_no_validation(&ctx);
}

/// Splitting a tile into passes changes no bit of images or gradients (an ordinary scene).
#[test]
fn passes_change_no_bit() {
    let ctx = gpu();
    let scene = two_view_scene(3, 1500, 40, 33);
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let n = gs.n_pixels() as usize;
    let dl: Vec<f32> = (0..n).map(|i| ((i * 31) % 97) as f32 * 1e-2 - 0.4).collect();
    let (img_a, g_a) = r.gradients(&mut gs, &dl).unwrap();
    assert_eq!(gs.shading_passes(), (1, 1));
    let max_chunks = r.render(&mut gs).unwrap().stats.max_tile_chunks as u32;
    assert!(max_chunks >= 2, "{max_chunks}");
    for m in [1, 2] {
        let mut g2 = r.upload(&scene).unwrap();
        g2.force_chunks_per_pass(&ctx, m, max_chunks).unwrap();
        let (img_b, g_b) = r.gradients(&mut g2, &dl).unwrap();
        assert!(g2.shading_passes().0 > 1);
        for v in 0..2 {
            assert!(
                img_a[v].iter().zip(&img_b[v]).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{m} chunks per pass: view {v} differs"
            );
        }
        assert!(
            g_a.scratches
                .iter()
                .flatten()
                .zip(g_b.scratches.iter().flatten())
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{m} chunks per pass: gradients differ"
        );
        assert_eq!(g_a.lights, g_b.lights);
    }
    assert_no_validation(&ctx);
}

/// 100 scratches wide enough to cover the whole plate, seen at 512 x 512: every tile lists every
/// scratch, and one binning thread of 64 scratches walks 65,536 tiles, over llvmpipe's loop
/// limit. Every on-plate pixel must overlap every scratch, and sampled pixels match the reference.
#[test]
fn scratches_over_every_tile() {
    let ctx = gpu();
    let mut rng = Rng::new(11);
    let scratches = (0..100)
        .map(|_| {
            // From edge to edge, 186 mm wide: every point of the plate is carved by every one.
            let y = rng.range(-2.0, 2.0);
            scratch([-50.0, y], [50.0, y], 200.0, 200.0, rng.range(0.1, 0.5))
        })
        .collect();
    let scene = Scene {
        plate: plate(100.0),
        views: vec![orbit_view("a", 512, 60.0, 30.0, 50.0, 200.0, 100.0)],
        scratches,
    };
    scene.validate().unwrap();
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let frame = r.render(&mut gs).unwrap();
    let mask = scratchart_model::camera::on_plate_mask(&scene, 0);
    let on = mask.iter().filter(|m| **m).count() as u64;
    eprintln!(
        "{} pairs for {on} on-plate pixels x 100 scratches; binning group size {}",
        frame.stats.pairs,
        gs.binning_group_size()
    );
    if is_llvmpipe(&ctx) {
        assert!(
            gs.binning_group_size() < 64,
            "llvmpipe must need smaller binning groups here"
        );
    }
    assert_eq!(
        frame.stats.pairs,
        on * 100,
        "every on-plate pixel overlaps every scratch"
    );
    let mut rng = Rng::new(5);
    let px: Vec<(u32, u32)> = (0..60)
        .map(|_| (rng.range(0.0, 511.99) as u32, rng.range(0.0, 511.99) as u32))
        .filter(|&(i, j)| mask[(j * 512 + i) as usize])
        .collect();
    let max_l = frame.images[0].iter().cloned().fold(0.0f32, f32::max) as f64;
    assert_pixels_match("wide scratches", &scene, &frame.images[0], &px, max_l);
    assert_no_validation(&ctx);
}

/// 20,000 scratches through one pixel's footprint (313 chunks in its tile).
#[test]
fn all_scratches_through_one_pixel() {
    let ctx = gpu();
    let mut rng = Rng::new(21);
    let mut scratches = Vec::new();
    for _ in 0..20_000 {
        let a = rng.range(0.0, std::f64::consts::PI);
        let (l0, l1) = (rng.range(0.5, 4.0), rng.range(0.5, 4.0));
        let (c, s) = (a.cos(), a.sin());
        let o = [rng.range(-0.3, 0.3), rng.range(-0.3, 0.3)];
        scratches.push(scratch(
            [o[0] - l0 * c, o[1] - l0 * s],
            [o[0] + l1 * c, o[1] + l1 * s],
            0.05,
            0.04,
            0.1,
        ));
    }
    let scene = Scene {
        plate: plate(20.0),
        views: vec![orbit_view("a", 12, 50.0, 30.0, 50.0, 210.0, 20.0)],
        scratches,
    };
    scene.validate().unwrap();
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let frame = r.render(&mut gs).unwrap();
    eprintln!("{} pairs, passes {:?}", frame.stats.pairs, gs.shading_passes());
    let px = pixels_near_centre(&scene, 3.0);
    assert!(!px.is_empty());
    let max_l = frame.images[0].iter().cloned().fold(0.0f32, f32::max) as f64;
    assert_pixels_match("one pixel", &scene, &frame.images[0], &px, max_l);
    assert_no_validation(&ctx);
}

/// The pair search's scan counts (tile, scratch) entries in u32: a total past 2^32 - 1 would
/// wrap and look small. The scan checks every addition; here at, just below and just above the
/// limit, in the last block and across blocks.
#[test]
fn entry_counts_past_u32_are_caught() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    // Below: exact exclusive scan, no flag.
    let data: Vec<u32> = (0..10_000u32).map(|i| (i * 7919) % 1000).collect();
    let (out, wrapped) = r.scan_u32(&data).unwrap();
    let mut run = 0u32;
    for (i, (&o, &d)) in out.iter().zip(&data).enumerate() {
        assert_eq!(o, run, "element {i}");
        run += d;
    }
    assert!(!wrapped);
    // Exactly u32::MAX in all: fits.
    let mut data = vec![0u32; 9000];
    data[10] = u32::MAX - 5;
    data[8999] = 5;
    let (_, wrapped) = r.scan_u32(&data).unwrap();
    assert!(!wrapped, "a total of u32::MAX fits");
    // One more, in another block: wraps, and is caught.
    data[4500] = 1;
    let (_, wrapped) = r.scan_u32(&data).unwrap();
    assert!(wrapped, "a total of 2^32 must be caught");
    // Within one thread's elements.
    let (_, wrapped) = r.scan_u32(&[u32::MAX, 1, 0]).unwrap();
    assert!(wrapped);
    assert_no_validation(&ctx);
}

/// A view whose per-view reductions would run past a loop-capped device's limit is refused up
/// front with a message naming the limit; elsewhere it uploads.
#[test]
fn views_over_the_loop_limit_are_refused_where_loops_are_capped() {
    let ctx = gpu();
    let mut scene = packed(10, 6.0, 16, 1);
    scene.views[0].camera.width = 4000;
    scene.views[0].camera.height = 4000;
    let r = Renderer::new(&ctx).unwrap();
    let up = r.upload(&scene);
    if scratchart_render::limits::caps_loops(ctx.info()) {
        let err = up
            .err()
            .expect("a 4000 x 4000 view is over llvmpipe's per-view limit")
            .to_string();
        assert!(err.contains("loop limit") && err.contains("16000000"), "{err}");
    } else {
        assert!(up.is_ok(), "{:?}", up.err());
    }
    assert_no_validation(&ctx);
}

/// Binning split into bands of tile rows per view (what a GPU gets, for enough threads) lists
/// the same tiles in the same order: images and gradients are bit-identical to one thread per
/// scratch group doing every view (what a CPU driver gets).
#[test]
fn binning_bands_change_no_bit() {
    let ctx = gpu();
    let scene = two_view_scene(4, 1200, 70, 45);
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    assert_eq!(gs.binning_bands(), 0, "a CPU driver bins without bands");
    let n = gs.n_pixels() as usize;
    let dl: Vec<f32> = (0..n).map(|i| ((i * 31) % 97) as f32 * 1e-2 - 0.4).collect();
    let (img_a, g_a) = r.gradients(&mut gs, &dl).unwrap();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    // 1 band: one thread per (group, view); 3 and 7: uneven row ranges; 40: more bands than rows.
    for bands in [1, 3, 7, 40] {
        let mut g2 = r.upload(&scene).unwrap();
        g2.force_binning_bands(&ctx, bands).unwrap();
        let (img_b, g_b) = r.gradients(&mut g2, &dl).unwrap();
        for v in 0..2 {
            assert_eq!(bits(&img_a[v]), bits(&img_b[v]), "{bands} bands: view {v} differs");
        }
        assert_eq!(
            bits(&g_a.scratches.concat()),
            bits(&g_b.scratches.concat()),
            "{bands} bands: gradients differ"
        );
        assert_eq!(g_a.lights, g_b.lights);
    }
    assert_no_validation(&ctx);
}

/// The two binning modes (`BinMode::Groups`: a thread per scratch group, CPU drivers;
/// `BinMode::Pairs`: a thread per scratch and view, then a stable radix sort by tile, GPUs) give
/// the same tile lists word for word (offsets, lists, the entry map of the backward), so the
/// same images and gradients bit for bit, on dense tiles, on scratches over every tile, with
/// more than 256 tiles (two radix passes) and with bands of tile rows.
#[test]
fn binning_modes_give_the_same_tile_lists() {
    use scratchart_render::BinMode;
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    // As in `scratches_over_every_tile`: every tile lists every scratch (more entries than the
    // first capacity: the lists and the sort grow).
    let mut rng = Rng::new(11);
    let wide = Scene {
        plate: plate(100.0),
        views: vec![orbit_view("a", 256, 60.0, 30.0, 50.0, 200.0, 100.0)],
        scratches: (0..400)
            .map(|_| {
                let y = rng.range(-2.0, 2.0);
                scratch([-50.0, y], [50.0, y], 200.0, 200.0, rng.range(0.1, 0.5))
            })
            .collect(),
    };
    let cases: Vec<(&str, Scene, bool)> = vec![
        ("two views, 361 + 9 tiles", two_view_scene(4, 1200, 300, 45), true),
        ("a dense tile", packed(12_000, 6.0, 112, 7), false),
        ("scratches over every tile", wide, false),
        ("no scratches", packed(0, 6.0, 64, 1), false),
    ];
    for (label, scene, grads) in cases {
        let mut a = r.upload(&scene).unwrap();
        a.force_binning_mode(&ctx, BinMode::Groups).unwrap();
        let first_capacity = a.capacity();
        let mut b = r.upload(&scene).unwrap();
        b.force_binning_mode(&ctx, BinMode::Pairs).unwrap();
        assert_eq!(b.binning_mode(), BinMode::Pairs);
        let n = a.n_pixels() as usize;
        let dl: Vec<f32> = (0..n).map(|i| ((i * 31) % 97) as f32 * 1e-2 - 0.4).collect();
        let (img_a, g_a) = r.gradients(&mut a, &dl).unwrap();
        let lists_a = a.tile_lists(&ctx).unwrap();
        for bands in [None, Some(3)] {
            if let Some(k) = bands {
                b.force_binning_bands(&ctx, k).unwrap();
            }
            let (img_b, g_b) = r.gradients(&mut b, &dl).unwrap();
            let lists_b = b.tile_lists(&ctx).unwrap();
            eprintln!(
                "{label} (bands {bands:?}): {} entries over {} tiles, longest list {}",
                lists_a.list.len(),
                lists_a.offsets.len() - 1,
                lists_a.offsets.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0)
            );
            assert_eq!(lists_a.offsets, lists_b.offsets, "{label}: tile offsets differ");
            assert!(lists_a.list == lists_b.list, "{label}: tile lists differ");
            assert!(lists_a.inv == lists_b.inv, "{label}: entry maps differ");
            for v in 0..img_a.len() {
                assert_eq!(bits(&img_a[v]), bits(&img_b[v]), "{label}: view {v} differs");
            }
            if grads {
                assert_eq!(
                    bits(&g_a.scratches.concat()),
                    bits(&g_b.scratches.concat()),
                    "{label}: gradients differ"
                );
                assert_eq!(g_a.lights, g_b.lights);
            }
        }
        if label.starts_with("scratches over") {
            assert!(lists_a.list.len() > first_capacity as usize && b.capacity() > first_capacity);
        }
        if label.starts_with("no") {
            assert!(lists_a.list.is_empty());
        } else {
            assert!(lists_a.list.len() > 1000, "{label}: {} entries", lists_a.list.len());
        }
    }
    assert_no_validation(&ctx);
}

/// `scratchart bench --binning-work` states binning's threads and its longest serial loop (tile
/// tests per thread) from the scene alone; the device's own counters of a render agree, in both
/// modes, with and without bands.
#[test]
fn binning_work_is_what_the_device_does() {
    use scratchart_render::BinMode;
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let scene = two_view_scene(9, 800, 96, 64);
    for (mode, bands) in [
        (BinMode::Groups, 0),
        (BinMode::Groups, 3),
        (BinMode::Pairs, 0),
        (BinMode::Pairs, 2),
    ] {
        let mut gs = r.upload(&scene).unwrap();
        gs.force_binning_mode(&ctx, mode).unwrap();
        gs.force_binning_bands(&ctx, bands).unwrap();
        let frame = r.render(&mut gs).unwrap();
        let (threads, most) = scratchart::bench::binning_work(&scene, mode, bands);
        eprintln!(
            "{mode:?}, {bands} bands: {threads} threads, at most {most} tile tests (device: {} and {})",
            gs.binning_threads(),
            frame.stats.bin_tests_per_thread
        );
        assert_eq!(threads, gs.binning_threads(), "{mode:?} {bands}");
        assert!(most > 0);
        // float64 on the host, float32 on the device: a bound on a tile edge may differ.
        let diff = most.abs_diff(frame.stats.bin_tests_per_thread);
        assert!(
            diff * 50 <= most,
            "{mode:?} {bands}: host {most}, device {}",
            frame.stats.bin_tests_per_thread
        );
    }
    assert_no_validation(&ctx);
}
