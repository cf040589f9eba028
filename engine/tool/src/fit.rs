//! The scratch model's (w, d) for a tool's groove.
//!
//! Rule: the model keeps the groove's visible width W exactly (its carved region is the real
//! one), so with rho = W / w in (0, 1) the depth parameter is d = -(w/2) ln(1 - rho^2) and the
//! model groove is D_m(u) = d + (w/2) ln(1 - 4u^2/w^2), zero at |u| = W/2. The one free parameter
//! is chosen to minimize E(w) = integral over [-W/2, W/2] of (D_m(u) - D(u))^2 du: the model's
//! walls (its normals, which decide where light goes) match the tool's in the least-squares sense.
//! E is evaluated with 64-point composite Gauss-Legendre; the minimum over rho is bracketed on a
//! grid of 400 values and refined by golden-section search to 1e-12 in rho.
use super::Section;

/// The model's groove for a cut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelGroove {
    /// Width parameter w, mm.
    pub w: f64,
    /// Depth parameter d, mm.
    pub d: f64,
    /// Visible width W = w sqrt(1 - exp(-2d/w)), mm (the cut's).
    pub width: f64,
    /// Root-mean-square depth difference between the model and the cut across the groove, mm
    /// (0 for a measured profile, which has no depth profile).
    pub rms_mm: f64,
}

/// The model groove (w, d) of visible width `width` for the ratio rho = W / w.
fn groove(width: f64, rho: f64) -> (f64, f64) {
    let w = width / rho;
    (w, -0.5 * w * (-rho * rho).ln_1p())
}

fn model_depth(w: f64, d: f64, u: f64) -> f64 {
    let x = 2.0 * u / w;
    (d + 0.5 * w * (-x * x).ln_1p()).max(0.0)
}

/// Gauss-Legendre nodes and weights on [-1, 1], 8 points.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// The quadrature of [`misfit`] over [0, W/2] for a groove of visible width `width`: per node,
/// its position u, its weight and the profile's depth there (the same for every rho: computed
/// once per profile, not once per rho tried).
fn nodes(width: f64, depth: &dyn Fn(f64) -> f64) -> Vec<(f64, f64, f64)> {
    let half = 0.5 * width;
    let panels = 8;
    let mut out = Vec::with_capacity(panels * GL8.len());
    for p in 0..panels {
        let (a, b) = (half * p as f64 / panels as f64, half * (p + 1) as f64 / panels as f64);
        for (x, wt) in GL8 {
            let u = 0.5 * (a + b) + 0.5 * (b - a) * x;
            out.push((u, 0.5 * (b - a) * wt, depth(u)));
        }
    }
    out
}

/// Mean squared depth difference over [0, W/2] (the profiles are symmetric), on the profile's
/// [`nodes`].
fn misfit(width: f64, rho: f64, nodes: &[(f64, f64, f64)]) -> f64 {
    let (w, d) = groove(width, rho);
    let half = 0.5 * width;
    let mut acc = 0.0;
    for &(u, weight, depth) in nodes {
        let e = model_depth(w, d, u) - depth;
        acc += weight * e * e;
    }
    acc / half
}

/// The least-squares model groove of a profile `depth(u)` of visible width `width` (see the
/// module doc).
pub fn fit_profile(width: f64, depth: &dyn Fn(f64) -> f64) -> ModelGroove {
    let at = nodes(width, depth);
    let f = |rho: f64| misfit(width, rho, &at);
    let n = 400;
    // The grid's first least misfit (each value computed once).
    let grid: Vec<(f64, f64)> = (1..n).map(|k| k as f64 / n as f64).map(|r| (r, f(r))).collect();
    let best = grid
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("a non-empty grid")
        .0;
    let (mut lo, mut hi) = (
        (best - 1.0 / n as f64).max(1e-9),
        (best + 1.0 / n as f64).min(1.0 - 1e-12),
    );
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    while hi - lo > 1e-12 {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    let rho = 0.5 * (lo + hi);
    let (w, d) = groove(width, rho);
    ModelGroove {
        w,
        d,
        width,
        rms_mm: f(rho).sqrt(),
    }
}

/// The model groove of a tool's cut.
pub fn model_of_section(s: &Section) -> ModelGroove {
    fit_profile(s.width, &|u| s.depth_at(u))
}

/// The model groove of a measured width with the stated w / W ratio (>= 1). At a ratio of 1
/// the model needs an infinite d; d = 5 w is used (its width is then w within 5e-5).
pub fn model_of_width(width: f64, w_over_w: f64) -> ModelGroove {
    let w = width * w_over_w;
    let d = if w_over_w <= 1.0 + 1e-12 {
        5.0 * w
    } else {
        -0.5 * w * (-(1.0 / (w_over_w * w_over_w))).ln_1p()
    };
    ModelGroove {
        w,
        d,
        width,
        rms_mm: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Tool;

    /// The model's own groove maps back to itself: w to 1e-6, d to 1e-5 (a very deep groove,
    /// d = 10 w, has W within 2e-9 of w, and there d barely changes the profile).
    #[test]
    fn a_log_profile_is_recovered() {
        for (w0, d0) in [(0.05f64, 0.05f64), (0.2, 0.01), (0.03, 0.3)] {
            let width = w0 * (1.0 - (-2.0 * d0 / w0).exp()).sqrt();
            let g = fit_profile(width, &|u| model_depth(w0, d0, u));
            assert!(
                (g.w - w0).abs() < 1e-6 * w0 && (g.d - d0).abs() < 1e-5 * d0,
                "{g:?} vs ({w0}, {d0})"
            );
            assert!(g.rms_mm < 1e-6, "{g:?}: over a nanometre from its own groove");
        }
    }

    /// Tool grooves keep their width, and the model's walls follow theirs closely.
    #[test]
    fn tool_grooves_map_to_models_of_the_same_width() {
        let tools = [
            Tool::VBit {
                angle_deg: 60.0,
                tip_flat_mm: 0.01,
                z_offset_mm: 0.0,
            },
            Tool::VBit {
                angle_deg: 120.0,
                tip_flat_mm: 0.0,
                z_offset_mm: 0.0,
            },
            Tool::Ball {
                radius_mm: 0.1,
                z_offset_mm: 0.0,
            },
            Tool::TaperedBall {
                radius_mm: 0.03,
                angle_deg: 30.0,
                z_offset_mm: 0.0,
            },
        ];
        for t in &tools {
            for z in [0.005, 0.02, 0.05] {
                let s = t.section(z).unwrap();
                let g = t.model(z).unwrap();
                let w_model = g.w * (1.0 - (-2.0 * g.d / g.w).exp()).sqrt();
                assert!(
                    (w_model - s.width).abs() < 1e-9 * s.width,
                    "{t:?} z {z}: {w_model} vs {}",
                    s.width
                );
                assert!(
                    g.rms_mm < 0.2 * s.depth,
                    "{t:?} z {z}: rms {} for depth {}",
                    g.rms_mm,
                    s.depth
                );
                // Deeper cuts make wider, deeper model grooves.
                let deeper = t.model(2.0 * z).unwrap();
                assert!(deeper.width > g.width && deeper.d > g.d, "{t:?} z {z}");
            }
        }
        let p = Tool::Profile {
            points: vec![[0.01, 0.05], [0.03, 0.09]],
            w_over_w: 1.5,
            z_offset_mm: 0.0,
        };
        let g = p.model(0.02).unwrap();
        assert!((g.w - 0.105).abs() < 1e-12);
        assert!((g.w * (1.0 - (-2.0 * g.d / g.w).exp()).sqrt() - 0.07).abs() < 1e-12);
    }

    /// The misfit as first written (the profile's depth computed at every node for every rho
    /// tried): the misfit on precomputed nodes must give the same bits, so the fit, a
    /// deterministic search over misfit values, gives the same (w, d).
    fn misfit_per_rho(width: f64, rho: f64, depth: &dyn Fn(f64) -> f64) -> f64 {
        let (w, d) = groove(width, rho);
        let half = 0.5 * width;
        let mut acc = 0.0;
        for p in 0..8 {
            let (a, b) = (half * p as f64 / 8.0, half * (p + 1) as f64 / 8.0);
            for (x, wt) in GL8 {
                let u = 0.5 * (a + b) + 0.5 * (b - a) * x;
                let e = model_depth(w, d, u) - depth(u);
                acc += 0.5 * (b - a) * wt * e * e;
            }
        }
        acc / half
    }

    #[test]
    fn the_misfit_on_precomputed_nodes_is_the_misfit_per_rho_to_the_bit() {
        let tools = [
            Tool::VBit {
                angle_deg: 75.0,
                tip_flat_mm: 0.015,
                z_offset_mm: 0.007,
            },
            Tool::VBit {
                angle_deg: 23.0,
                tip_flat_mm: 0.0,
                z_offset_mm: -0.003,
            },
            Tool::Ball {
                radius_mm: 0.1,
                z_offset_mm: 0.0,
            },
            Tool::TaperedBall {
                radius_mm: 0.03,
                angle_deg: 40.0,
                z_offset_mm: 0.002,
            },
        ];
        let mut n = 0;
        for t in &tools {
            for z in [0.004, 0.01, 0.03, 0.08] {
                let Some(s) = t.section(z) else { continue };
                let depth = |u: f64| s.depth_at(u);
                let at = nodes(s.width, &depth);
                // The grid of the search, and the optimum it refines to.
                let best = model_of_section(&s).width / model_of_section(&s).w;
                for rho in (1..400).map(|k| k as f64 / 400.0).chain([best]) {
                    assert_eq!(
                        misfit(s.width, rho, &at).to_bits(),
                        misfit_per_rho(s.width, rho, &depth).to_bits(),
                        "{t:?} at {z}, rho {rho}"
                    );
                }
                n += 1;
            }
        }
        assert!(n >= 12, "{n} sections");
    }
}
