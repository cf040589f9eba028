//! Directional derivatives of the pixel values (`Renderer::tangents`, `shaders/tangent.comp`)
//! against central differences of the float64 reference: for each of 7 directions in the
//! scratches' (w, d, alpha) (each scratch's own w, each d, each alpha, a random mix, half the
//! scratches, w against d, and the zero direction), per view,
//! ||dL - dL_ref|| / ||dL_ref|| <= 1e-2 (engine/docs/model.md section 8's gradient bar, here per direction);
//! the zero direction is exactly zero; the images are the forward's; two runs are bit-identical.
use scratchart_design::scenes::Rng;
use scratchart_model::reference::render_view;
use scratchart_model::scene::Scene;
use scratchart_render::tangent::{ScratchTangent, TANGENT_DIRECTIONS};
use scratchart_render::Renderer;
use scratchart_tests::*;

fn seeds(scene: &Scene) -> Vec<ScratchTangent> {
    let mut rng = Rng::new(5);
    scene
        .scratches
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (w, d, a) = (s.w as f32, s.d as f32, s.alpha as f32);
            let r = |rng: &mut Rng| (2.0 * rng.f64() - 1.0) as f32;
            [
                [w, 0.0, 0.0],
                [0.0, d, 0.0],
                [0.0, 0.0, a],
                [r(&mut rng) * w, r(&mut rng) * d, r(&mut rng) * a],
                if k % 2 == 0 { [w, 0.0, 0.0] } else { [0.0; 3] },
                [w, -d, 0.0],
                [0.0; 3],
            ]
        })
        .collect()
}

/// The scene moved by `h` along direction `j` of `seeds`.
fn moved(scene: &Scene, seeds: &[ScratchTangent], j: usize, h: f64) -> Scene {
    let mut s = scene.clone();
    for (sc, t) in s.scratches.iter_mut().zip(seeds) {
        sc.w += h * t[j][0] as f64;
        sc.d += h * t[j][1] as f64;
        sc.alpha += h * t[j][2] as f64;
    }
    s
}

fn check(label: &str, scene: &Scene) {
    scene.validate().expect("valid test scene");
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let sd = seeds(scene);
    let mut gs = r.upload(scene).unwrap();
    let (images, tang) = r.tangents(&mut gs, &sd).unwrap();
    let plain = r.render(&mut gs).unwrap().images;
    assert_eq!(images, plain, "{label}: the tangent pass changed the images");
    let (_, again) = r.tangents(&mut gs, &sd).unwrap();
    assert!(
        tang.iter()
            .flatten()
            .zip(again.iter().flatten())
            .all(|(a, b)| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())),
        "{label}: two runs differ"
    );
    let h = 1e-4;
    for j in 0..TANGENT_DIRECTIONS {
        let (plus, minus) = (moved(scene, &sd, j, h), moved(scene, &sd, j, -h));
        for (v, tv) in tang.iter().enumerate() {
            let got: Vec<f64> = tv.iter().map(|t| t[j] as f64).collect();
            if j == 6 {
                assert!(
                    got.iter().all(|g| *g == 0.0),
                    "{label}: the zero direction moved a pixel"
                );
                continue;
            }
            let (lp, lm) = (render_view(&plus, v), render_view(&minus, v));
            let want: Vec<f64> = lp.iter().zip(&lm).map(|(a, b)| (a - b) / (2.0 * h)).collect();
            let num: f64 = got
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            let den: f64 = want.iter().map(|b| b * b).sum::<f64>().sqrt();
            eprintln!(
                "{label}: direction {j}, view {v}: relative error {:.2e} (|dL| {den:.3e})",
                num / den
            );
            assert!(den > 0.0, "{label}: direction {j} moves nothing in view {v}");
            assert!(
                num <= 1e-2 * den,
                "{label}: direction {j}, view {v}: ||dL - dL_ref|| / ||dL_ref|| = {:.3e}",
                num / den
            );
        }
    }
    assert_no_validation(&ctx);
}

#[test]
fn directional_derivatives_match_the_reference() {
    let mut scene = random_scene(
        21,
        200,
        20.0,
        0.2,
        0.1,
        0.05,
        vec![
            orbit_view("a", 32, 45.0, 0.0, 45.0, 180.0, 20.0),
            orbit_view("b", 32, 60.0, 120.0, 30.0, 300.0, 20.0),
        ],
    );
    for (k, s) in scene.scratches.iter_mut().enumerate() {
        s.alpha = [0.01, 0.05, 0.3][k % 3];
        s.d = s.w * [0.05, 0.5, 2.0][(k / 3) % 3];
    }
    check("random", &scene);
}

/// Splitting tiles into passes (as llvmpipe's loop limit makes the engine do on dense tiles)
/// changes no bit of the derivatives: the per-pixel sums carry from pass to pass.
#[test]
fn passes_change_no_bit() {
    let ctx = gpu();
    let scene = two_view_scene(3, 1500, 40, 33);
    let r = Renderer::new(&ctx).unwrap();
    let sd = seeds(&scene);
    let mut gs = r.upload(&scene).unwrap();
    let (_, one) = r.tangents(&mut gs, &sd).unwrap();
    assert_eq!(gs.shading_passes(), (1, 1));
    let max_chunks = r.render(&mut gs).unwrap().stats.max_tile_chunks as u32;
    assert!(max_chunks >= 2, "{max_chunks}");
    for m in [1, 2] {
        let mut g2 = r.upload(&scene).unwrap();
        g2.force_chunks_per_pass(&ctx, m, max_chunks).unwrap();
        let (_, split) = r.tangents(&mut g2, &sd).unwrap();
        assert!(g2.shading_passes().1 > 1);
        let same = one
            .iter()
            .flatten()
            .zip(split.iter().flatten())
            .all(|(a, b)| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert!(same, "{m} chunks per pass: the derivatives differ");
        assert!(one.iter().flatten().any(|t| t[0] != 0.0), "nothing moved");
    }
    assert_no_validation(&ctx);
}

/// Several groups of directions in one submission (`tangent_groups`: one render, a tangent pass
/// per group) give each group's derivatives and the images to the bit of a call per group.
#[test]
fn groups_in_one_submission_change_no_bit() {
    let ctx = gpu();
    let scene = two_view_scene(3, 400, 40, 21);
    let r = Renderer::new(&ctx).unwrap();
    let a = seeds(&scene);
    // A second group: the first's directions in reverse order, halved.
    let b: Vec<ScratchTangent> = a
        .iter()
        .map(|t| std::array::from_fn(|j| t[TANGENT_DIRECTIONS - 1 - j].map(|x| 0.5 * x)))
        .collect();
    let mut gs = r.upload(&scene).unwrap();
    let (img_a, ta) = r.tangents(&mut gs, &a).unwrap();
    let (_, tb) = r.tangents(&mut gs, &b).unwrap();
    let (img, groups) = r.tangent_groups(&mut gs, &[&a, &b]).unwrap();
    let bits = |t: &[Vec<[f32; TANGENT_DIRECTIONS]>]| -> Vec<u32> {
        t.iter().flatten().flat_map(|d| d.map(f32::to_bits)).collect()
    };
    assert_eq!(groups.len(), 2);
    assert_eq!(bits(&groups[0]), bits(&ta));
    assert_eq!(bits(&groups[1]), bits(&tb));
    assert_ne!(bits(&ta), bits(&tb), "the two groups must differ");
    let img_bits = |i: &[Vec<f32>]| -> Vec<u32> { i.iter().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(img_bits(&img), img_bits(&img_a));
    assert_no_validation(&ctx);
}
