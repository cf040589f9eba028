//! The tool's curve z -> (w, d) as a table for linear interpolation in s = sqrt(z - z_first)
//! (see [`super`]'s module doc: the depth range and the table's measured error).
use super::*;

/// The tool's curve z -> (w, d) on [z_lo, z_hi], sampled for linear interpolation in
/// s = sqrt(z - z_first) (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct ToolTable {
    /// Where the tool first reaches the plate (an f32 value, as the GPU sees it), mm.
    pub z_first: f64,
    pub z_lo: f64,
    pub z_hi: f64,
    pub(super) s_lo: f64,
    pub(super) ds: f64,
    /// (w, d) at the samples, mm.
    pub samples: Vec<[f64; 2]>,
    /// Largest relative error of the interpolated w and d against `Tool::model`, measured at
    /// every segment's midpoint.
    pub max_rel_err: [f64; 2],
}

/// Finds the boundary of a monotone predicate between `a` (false) and `b` (true).
fn bisect(mut a: f64, mut b: f64, pred: impl Fn(f64) -> bool) -> (f64, f64) {
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            break;
        }
        if pred(m) {
            b = m;
        } else {
            a = m;
        }
    }
    (a, b)
}

/// `Tool::model` at every z, in parallel on the host's cores (order kept).
fn models(tool: &Tool, zs: &[f64]) -> Vec<Option<[f64; 2]>> {
    scratchart_model::par::par_map(zs.len(), |i| tool.model(zs[i]).map(|g| [g.w, g.d]))
}

impl ToolTable {
    /// Samples `tool` over its useful range: up to where the groove's visible width reaches
    /// `w_max` or its real depth `depth_max` (mm). An error names what makes the tool unusable.
    pub fn new(tool: &Tool, w_max: f64, depth_max: f64, n: usize) -> Result<ToolTable, String> {
        ToolTable::within(tool, w_max, depth_max, n, None)
    }

    /// [`ToolTable::new`] within a machine's limits: no cut shallower than `min_cut_depth_mm`
    /// below the plate surface, and the range's ends on the Z step's grid (commanded depths are
    /// multiples of `z_step_mm`).
    pub fn within(
        tool: &Tool,
        w_max: f64,
        depth_max: f64,
        n: usize,
        machine: Option<&MachineProfile>,
    ) -> Result<ToolTable, String> {
        assert!(n >= 2, "a table needs at least 2 samples");
        let cuts = |z: f64| tool.model(z).is_some();
        let z0 = -tool.z_offset_mm();
        let mut b = z0 + 1e-3;
        while !cuts(b) {
            if b - z0 > 20.0 {
                return Err(format!(
                    "the tool cuts no groove down to a commanded depth of {b:.1} mm (z_offset_mm = {})",
                    tool.z_offset_mm()
                ));
            }
            b = z0 + 2.0 * (b - z0);
        }
        let (_, first) = bisect(z0, b, cuts);
        let z_first = first as f32 as f64;
        let mut z_lo = z_first + FIRST_CUT_MM;
        if let Some(m) = machine {
            // The surface lies at commanded depth z0; a cut's depth below it is z - z0.
            z_lo = z_lo.max(z0 + m.min_cut_depth_mm);
            z_lo = (z_lo / m.z_step_mm - 1e-9).ceil() * m.z_step_mm;
        }
        let deep = |z: f64| {
            tool.section(z)
                .is_some_and(|s| s.width >= w_max || s.depth >= depth_max)
        };
        if deep(z_lo) {
            let w = tool.section(z_lo).map_or(f64::NAN, |s| s.width);
            return Err(format!(
                "its shallowest cut (commanded depth {z_lo:.4} mm) is already {w:.4} mm wide or {depth_max} mm deep: \
                 beyond the design's widest groove ({w_max} mm)"
            ));
        }
        let mut step = 1e-3;
        while !deep(z_lo + step) {
            step *= 2.0;
        }
        let (mut z_hi, _) = bisect(z_lo, z_lo + step, deep);
        if let Tool::Profile { points, .. } = tool {
            z_hi = z_hi.min(points[points.len() - 1][0]);
        }
        if let Some(m) = machine {
            z_hi = (z_hi / m.z_step_mm + 1e-9).floor() * m.z_step_mm;
        }
        if !(z_hi > z_lo + 1e-6) {
            return Err(format!(
                "its useful depth range [{z_lo:.4}, {z_hi:.4}] mm is empty (the profile ends where the tool first cuts)"
            ));
        }
        let (s_lo, s_hi) = ((z_lo - z_first).sqrt(), (z_hi - z_first).sqrt());
        let ds = (s_hi - s_lo) / (n - 1) as f64;
        let z_of = |s: f64| z_first + s * s;
        let mut zs: Vec<f64> = (0..n).map(|k| z_of(s_lo + k as f64 * ds)).collect();
        zs[0] = z_lo;
        zs[n - 1] = z_hi;
        zs.extend((0..n - 1).map(|k| z_of(s_lo + (k as f64 + 0.5) * ds)));
        // A measured profile's corners: there, not at the midpoint, a segment's error peaks.
        if let Tool::Profile { points, .. } = tool {
            zs.extend(points.iter().map(|p| p[0]).filter(|&z| z > z_lo && z < z_hi));
        }
        let all = models(tool, &zs);
        let mut got = Vec::with_capacity(all.len());
        for (z, m) in zs.iter().zip(all) {
            match m {
                Some(g) if g[0] > 0.0 && g[1] > 0.0 && g[0].is_finite() && g[1].is_finite() => got.push(g),
                _ => {
                    return Err(format!(
                        "the tool's groove at commanded depth {z} mm has no valid (w, d)"
                    ))
                }
            }
        }
        let mut table = ToolTable {
            z_first,
            z_lo,
            z_hi,
            s_lo,
            ds,
            samples: got[..n].to_vec(),
            max_rel_err: [0.0; 2],
        };
        for (z, truth) in zs[n..].iter().zip(&got[n..]) {
            let e = table.eval(*z);
            for c in 0..2 {
                table.max_rel_err[c] = table.max_rel_err[c].max((e[c] - truth[c]).abs() / truth[c]);
            }
        }
        Ok(table)
    }

    /// The segment and the fraction along it of depth `z` (clamped to the end segments).
    fn locate(&self, z: f64) -> (usize, f64, f64) {
        let s = (z - self.z_first).max(0.0).sqrt();
        let u = (s - self.s_lo) / self.ds;
        let k = u.floor().clamp(0.0, (self.samples.len() - 2) as f64);
        (k as usize, u - k, s)
    }

    /// The interpolated (w, d) at commanded depth `z` (f64 twin of `tool_map.comp`).
    pub fn eval(&self, z: f64) -> [f64; 2] {
        let (k, f, _) = self.locate(z);
        let (a, b) = (self.samples[k], self.samples[k + 1]);
        [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
    }

    /// (dw/dz, dd/dz) of the interpolation at `z` (the derivative `tool_map.comp` uses).
    pub fn slope(&self, z: f64) -> [f64; 2] {
        let (k, _, s) = self.locate(z);
        let (a, b) = (self.samples[k], self.samples[k + 1]);
        let c = 1.0 / (self.ds * 2.0 * s);
        [(b[0] - a[0]) * c, (b[1] - a[1]) * c]
    }

    /// The commanded depth of sample `k`.
    pub fn sample_z(&self, k: usize) -> f64 {
        let s = self.s_lo + k as f64 * self.ds;
        (self.z_first + s * s).clamp(self.z_lo, self.z_hi)
    }

    /// The depth whose groove is nearest to (w, d) by the relative error |dw|/w + |dd|/d: the
    /// best sample, refined on the segments beside it (64 steps each).
    pub fn nearest_depth(&self, w: f64, d: f64) -> f64 {
        let err = |g: [f64; 2]| (g[0] - w).abs() / w + (g[1] - d).abs() / d;
        let n = self.samples.len();
        let best = (0..n)
            .min_by(|&a, &b| err(self.samples[a]).total_cmp(&err(self.samples[b])))
            .expect("a table has samples");
        let (lo, hi) = (
            self.sample_z(best.saturating_sub(1)),
            self.sample_z((best + 1).min(n - 1)),
        );
        let (mut zb, mut eb) = (self.sample_z(best), err(self.samples[best]));
        let (slo, shi) = ((lo - self.z_first).sqrt(), (hi - self.z_first).sqrt());
        for i in 0..=128 {
            let s = slo + (shi - slo) * i as f64 / 128.0;
            let z = (self.z_first + s * s).clamp(self.z_lo, self.z_hi);
            let e = err(self.eval(z));
            if e < eb {
                (zb, eb) = (z, e);
            }
        }
        zb
    }
}
