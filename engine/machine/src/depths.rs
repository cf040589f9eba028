//! One commanded depth per scratch. A design made without a tool has free (w, d) per scratch; the
//! tool can only cut the grooves on its curve z -> (w(z), d(z)) (`scratchart_tool::Tool::model`).
//! Each scratch gets the z whose groove is nearest to its (w, d) in relative terms
//! (|dw| / w + |dd| / d, searched on a 1 um grid up to the deepest useful depth, then refined),
//! and the worst mismatch is reported, so a maker sees when a design asks for grooves the tool
//! cannot cut.
use scratchart_model::scene::Scratch;
use scratchart_tool::Tool;

/// The commanded depth for each scratch and the relative mismatch of its groove.
///
/// The tool's curve is evaluated once, on a 1 um grid up to `max_z_mm` (`Tool::model` is a small
/// least-squares fit, so it is never called per scratch); each scratch takes the nearest grid
/// point, then is refined by golden section between its grid neighbours on the curve
/// interpolated linearly in z (w and d are smooth in z: the interpolation error at 1 um steps is
/// far below the refinement's resolution).
pub fn depths(scratches: &[Scratch], tool: &Tool, max_z_mm: f64) -> Vec<(f64, f64)> {
    let step = 0.001;
    let n = (max_z_mm / step).ceil() as usize;
    let curve: Vec<(f64, f64, f64)> = (1..=n)
        .filter_map(|k| {
            let z = k as f64 * step - tool.z_offset_mm().min(0.0);
            tool.model(z).map(|m| (z, m.w, m.d))
        })
        .collect();
    // The curve at any z between its grid points (linear), None outside it.
    let at = |z: f64| -> Option<(f64, f64)> {
        let i = curve.partition_point(|c| c.0 <= z);
        if i == 0 || i >= curve.len() {
            return curve.iter().find(|c| (c.0 - z).abs() < 1e-12).map(|c| (c.1, c.2));
        }
        let (a, b) = (curve[i - 1], curve[i]);
        if b.0 - a.0 > 1.5 * step {
            return None; // a gap where the tool cuts no groove
        }
        let t = (z - a.0) / (b.0 - a.0);
        Some((a.1 + t * (b.1 - a.1), a.2 + t * (b.2 - a.2)))
    };
    scratches
        .iter()
        .map(|s| {
            let err = |w: f64, d: f64| (w - s.w).abs() / s.w + (d - s.d).abs() / s.d;
            let best = curve
                .iter()
                .min_by(|a, b| err(a.1, a.2).total_cmp(&err(b.1, b.2)))
                .copied();
            match best {
                Some((z, w, d)) => {
                    let f = |z: f64| at(z).map_or(f64::INFINITY, |(w, d)| err(w, d));
                    let (mut lo, mut hi) = (z - step, z + step);
                    for _ in 0..40 {
                        let (m1, m2) = (lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo));
                        if f(m1) <= f(m2) {
                            hi = m2;
                        } else {
                            lo = m1;
                        }
                    }
                    let zr = 0.5 * (lo + hi);
                    let e = f(zr);
                    if e <= err(w, d) {
                        (zr, e)
                    } else {
                        (z, err(w, d))
                    }
                }
                None => (0.0, f64::INFINITY),
            }
        })
        .collect()
}
