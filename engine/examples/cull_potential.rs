//! How many (pixel, scratch) pairs could a bound-based culling skip without breaking engine/docs/model.md
//! section 8's forward bar? Float64 analysis on the CPU (no GPU), for the study's regimes and for
//! a design (a scene file). For every on-plate pixel and every scratch meeting its footprint:
//! the pair's exact contribution (I_k = ∫ D dA, A_k = area) and the tightest bound a per-pair
//! test could use before integrating, b_k = A_k max(Dmax_k, D_flat), Dmax_k the largest D over
//! the groove's normals (the arc of normals perpendicular to the axis; exact area, so an upper
//! limit on what a test with a bounded area can do). Dropping pair k changes the pixel by at most
//! K b_k / S_P (its NDF and its share of the coverage), K = E Fr / (4 cos_o).
//!
//! Rules, each keeping the total dropped bound within a budget (in the same units as I):
//! - `running`: pairs in scratch order; drop k when the dropped sum so far plus b_k stays within
//!   EPS x the kept pairs' I so far (a lower bound of the pixel's D_P S_P, known while rendering);
//! - `oracle`: drop the smallest bounds while their sum stays within EPS x the pixel's exact
//!   value (D_P S_P + (1 - cov) D_flat S_P), plus 1e-6/2 of the view's largest L: the most any
//!   per-pixel rule with these bounds can drop.
//!
//! `cargo run --release -p scratchart --example cull_potential [SCENE.json]`
use scratchart_model::reference::{ndf, ndf_flat, pixel, scratch_patch_integral};
use scratchart_model::scene::Scene;
use scratchart_model::ViewGeom;

/// Share of engine/docs/model.md's relative bar (1e-3) left to culling.
const EPS: f64 = 2.5e-4;

fn dmax(s: &scratchart_model::scene::Scratch, h: [f64; 3]) -> f64 {
    let l = s.length();
    let t = [(s.p1[0] - s.p0[0]) / l, (s.p1[1] - s.p0[1]) / l];
    let b = [-t[1], t[0]];
    let hb = h[0] * b[0] + h[1] * b[1];
    // n(theta) . h = cos(theta) hz - sin(theta) hb = rho cos(theta + phi)
    let rho = (h[2] * h[2] + hb * hb).sqrt();
    let phi = hb.atan2(h[2]);
    let th_max = 2.0 * (2.0 * s.half_width() / s.w).atan();
    let th = (-phi).clamp(-th_max, th_max);
    let c = rho * (th + phi).cos();
    if c <= 0.0 {
        return 0.0;
    }
    ndf(c, 1.0 - c * c, s.alpha)
}

fn analyse(label: &str, scene: &Scene) {
    let mut pairs = 0usize;
    let (mut running, mut oracle) = (0usize, 0usize);
    for v in 0..scene.views.len() {
        let g = ViewGeom::new(&scene.views[v]);
        let (w, hgt) = (g.width, g.height);
        // Pixels first (the view's largest L for the oracle's floor).
        let px: Vec<_> = (0..hgt).flat_map(|j| (0..w).map(move |i| (i, j))).collect();
        let refs: Vec<_> = px.iter().map(|&(i, j)| pixel(scene, v, i, j)).collect();
        let lmax = refs.iter().map(|r| r.l).fold(0.0, f64::max);
        let boxes: Vec<[f64; 4]> = scene
            .scratches
            .iter()
            .map(|s| {
                let e = s.half_width();
                [
                    s.p0[0].min(s.p1[0]) - e,
                    s.p0[1].min(s.p1[1]) - e,
                    s.p0[0].max(s.p1[0]) + e,
                    s.p0[1].max(s.p1[1]) + e,
                ]
            })
            .collect();
        for (&(i, j), r) in px.iter().zip(&refs) {
            if !r.on_plate || r.l <= 0.0 {
                continue;
            }
            let Some(fp) = g.footprint(i, j) else { continue };
            let bb = fp.iter().fold([f64::MAX, f64::MAX, f64::MIN, f64::MIN], |a, q| {
                [a[0].min(q[0]), a[1].min(q[1]), a[2].max(q[0]), a[3].max(q[1])]
            });
            let dflat = ndf_flat(r.h, scene.plate.roughness);
            let mut list: Vec<(f64, f64)> = Vec::new(); // (I, b)
            for (k, s) in scene.scratches.iter().enumerate() {
                let x = &boxes[k];
                if x[0] > bb[2] || x[2] < bb[0] || x[1] > bb[3] || x[3] < bb[1] {
                    continue;
                }
                let (ik, ak) = scratch_patch_integral(scene, v, i, j, k);
                if ak <= 0.0 {
                    continue;
                }
                list.push((ik, ak * dmax(s, r.h).max(dflat)));
            }
            pairs += list.len();
            // running
            let (mut kept, mut dropped) = (0.0, 0.0);
            for &(ik, bk) in &list {
                if dropped + bk <= EPS * kept {
                    dropped += bk;
                    running += 1;
                } else {
                    kept += ik;
                }
            }
            // oracle: budget in I units; K = L / (D_P + (1 - cov) D_flat)
            let total = r.d_p * r.s_p + (1.0 - r.cov) * dflat * r.s_p;
            let k_pix = r.l / (total / r.s_p);
            let budget = EPS * total + 0.5e-6 * lmax * r.s_p / k_pix;
            let mut bs: Vec<f64> = list.iter().map(|p| p.1).collect();
            bs.sort_by(f64::total_cmp);
            let mut sum = 0.0;
            for b in bs {
                if sum + b > budget {
                    break;
                }
                sum += b;
                oracle += 1;
            }
        }
    }
    println!(
        "{label:<18} {pairs:>9} pairs  running {:>5.1}%  oracle {:>5.1}%",
        100.0 * running as f64 / pairs.max(1) as f64,
        100.0 * oracle as f64 / pairs.max(1) as f64
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(path) = args.first() {
        let scene = Scene::load(std::path::Path::new(path)).expect("scene file");
        analyse(path, &scene);
        return;
    }
    for reg in scratchart::study::regimes(48, 1) {
        analyse(reg.name, &reg.scene);
    }
}
