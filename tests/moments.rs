//! Each pixel's first moments of light (`Renderer::moments`, `tangent.comp` built with
//! `SA_MOMENTS`): where within the pixel its grooves' light falls. Checked against a render of
//! the same view at 8 times the resolution, whose fine pixels place the light to an eighth of a
//! coarse pixel: per coarse pixel, the mean over its 64 fine pixels of the grooves' light (the
//! render less the bare plate's) times each fine pixel's offset from the coarse pixel's centre.
//! Without moments every pixel's light sits at its centre (relative error 1); the bar is 0.1
//! (measured 0.044 and 0.045 on lavapipe: the area's centroid stands for the light's, and the
//! fine pixels place it to an eighth). With a near camera and lamp the finer render also sees the
//! half vector turn within a coarse pixel, which the engine's footprint holds constant (model.md
//! section 4): 0.88 there, the same light rearranged, so the test looks from afar.
use scratchart_design::scenes::orbit_camera;
use scratchart_model::scene::{Scene, View};
use scratchart_render::Renderer;
use scratchart_tests::*;

const FINE: usize = 8;

/// Grooves narrower than a pixel, seen from afar under a directional light: the half vector
/// hardly changes across a coarse pixel, as the engine's model of a footprint holds it constant
/// (a finer render would otherwise see light that model does not have).
fn scene(res: u32) -> Scene {
    let far = |mut v: View, elev: f64, az: f64| {
        v.camera = orbit_camera(600.0, elev, az, 20.0, res, res);
        v
    };
    random_scene(
        17,
        60,
        20.0,
        0.1,
        0.05,
        0.1,
        vec![
            far(directional_view("a", res, 45.0, 0.0, 45.0, 150.0, 20.0), 45.0, 0.0),
            far(directional_view("b", res, 60.0, 120.0, 35.0, 270.0, 20.0), 60.0, 120.0),
        ],
    )
}

/// The moments of each coarse pixel of a `res` view, from a render at `FINE` times `res`: the
/// grooves' light (the render less the bare plate's) times each fine pixel's offset.
fn fine_moments(r: &Renderer, res: u32) -> (Vec<Vec<[f64; 2]>>, Vec<Vec<f64>>) {
    let fine = scene(res * FINE as u32);
    let bare = Scene {
        scratches: vec![],
        ..fine.clone()
    };
    let lit = r.render(&mut r.upload(&fine).unwrap()).unwrap().images;
    let plate = r.render(&mut r.upload(&bare).unwrap()).unwrap().images;
    let (n, fw) = (res as usize, res as usize * FINE);
    let mut moments = Vec::new();
    let mut light = Vec::new();
    for (img, base) in lit.iter().zip(&plate) {
        let mut m = vec![[0.0f64; 2]; n * n];
        let mut l = vec![0.0f64; n * n];
        for y in 0..fw {
            for x in 0..fw {
                let g = (img[y * fw + x] - base[y * fw + x]) as f64 / (FINE * FINE) as f64;
                let k = (y / FINE) * n + x / FINE;
                let off = |i: usize| ((i % FINE) as f64 + 0.5) / FINE as f64 - 0.5;
                m[k][0] += g * off(x);
                m[k][1] += g * off(y);
                l[k] += g;
            }
        }
        moments.push(m);
        light.push(l);
    }
    (moments, light)
}

#[test]
fn moments_place_the_light_as_a_finer_render_does() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let res = 24;
    let coarse = scene(res);
    let mut gs = r.upload(&coarse).unwrap();
    let (images, moments) = r.moments(&mut gs).unwrap();
    let plain = r.render(&mut gs).unwrap().images;
    assert_eq!(images, plain, "the moments' pass changed the images");
    let (want, light) = fine_moments(&r, res);
    for v in 0..coarse.views.len() {
        let (mut num, mut den) = (0.0, 0.0);
        for (got, want) in moments[v].iter().zip(&want[v]) {
            for a in 0..2 {
                num += (got[a] as f64 - want[a]).powi(2);
                den += want[a].powi(2);
            }
        }
        let (num, den) = (num.sqrt(), den.sqrt());
        let total: f64 = light[v].iter().map(|l| l.abs()).sum();
        eprintln!(
            "view {v}: |M - M_fine| / |M_fine| = {:.3} (|M_fine| {den:.3e}, grooves' light {total:.3e})",
            num / den
        );
        assert!(
            den > 1e-3 * total,
            "view {v}: the grooves' light has no moments to check"
        );
        assert!(num <= 0.1 * den, "view {v}: |M - M_fine| / |M_fine| = {:.3}", num / den);
    }
    assert_no_validation(&ctx);
}

/// Tiles split into passes carry the moments' sums from pass to pass: the same bits.
#[test]
fn passes_change_no_bit_of_the_moments() {
    let ctx = gpu();
    let scene = two_view_scene(3, 1500, 40, 33);
    let r = Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let (_, one) = r.moments(&mut gs).unwrap();
    let max_chunks = r.render(&mut gs).unwrap().stats.max_tile_chunks as u32;
    assert!(max_chunks >= 2, "{max_chunks}");
    let bits = |m: &[Vec<[f32; 2]>]| -> Vec<u32> { m.iter().flatten().flat_map(|d| d.map(f32::to_bits)).collect() };
    assert!(one.iter().flatten().any(|m| m[0] != 0.0), "no moment");
    for m in [1, 2] {
        let mut g2 = r.upload(&scene).unwrap();
        g2.force_chunks_per_pass(&ctx, m, max_chunks).unwrap();
        let (_, split) = r.moments(&mut g2).unwrap();
        assert!(g2.shading_passes().1 > 1);
        assert_eq!(bits(&split), bits(&one), "{m} chunks per pass: the moments differ");
    }
    assert_no_validation(&ctx);
}
