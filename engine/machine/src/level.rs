//! Levelling compensation: the plate surface's measured height (a probed grid, `heightmap.json`)
//! and each cut's commanded Z through it, so that every groove is cut to its designed depth below
//! the real surface, not below a flat Z0.
//!
//! `heightmap.json`: `{"x_mm": [...], "y_mm": [...], "z_mm": [[...], ...]}` in work coordinates
//! (X0 Y0 at the plate centre, Z0 where the tool was zeroed): strictly increasing axes, one row
//! of `z_mm` per y, each with one height per x, all finite. Between probes the height is bilinear;
//! outside the probed rectangle it is clamped to the nearest edge.
//!
//! Compensation: a cut is one straight G1 line at commanded depth `depth` below the surface. Its
//! commanded Z at a point (x, y) is `at(x, y) - depth`. A G1 move interpolates Z linearly, so a
//! cut is split into segments (each a G1 with its own end Z) until the surface departs from each
//! segment's straight line by at most the tolerance; a plane needs no split at all. Along a
//! straight line the bilinear surface is a quadratic between grid-line crossings, so the largest
//! departure is found exactly (ends and the parabola's stationary point of every piece).
use serde::{Deserialize, Serialize};

/// A probed height map of the plate surface, mm. `z_mm[j][i]` is the height at `(x_mm[i], y_mm[j])`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawHeightMap")]
pub struct HeightMap {
    pub x_mm: Vec<f64>,
    pub y_mm: Vec<f64>,
    /// One row per y, one height per x.
    pub z_mm: Vec<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHeightMap {
    x_mm: Vec<f64>,
    y_mm: Vec<f64>,
    z_mm: Vec<Vec<f64>>,
}

impl TryFrom<RawHeightMap> for HeightMap {
    type Error = LevelError;
    fn try_from(r: RawHeightMap) -> Result<HeightMap, LevelError> {
        HeightMap::new(r.x_mm, r.y_mm, r.z_mm)
    }
}

/// A height map that cannot be used, or a compensation that cannot be made.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelError(pub String);

impl std::fmt::Display for LevelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for LevelError {}

/// The most probes along one axis (a finer grid than this is not a probed plate).
pub const MAX_PROBES_PER_AXIS: usize = 1000;

fn check_axis(name: &str, v: &[f64]) -> Result<(), LevelError> {
    if v.is_empty() {
        return Err(LevelError(format!("{name} is empty: at least one probe is needed")));
    }
    if v.len() > MAX_PROBES_PER_AXIS {
        return Err(LevelError(format!(
            "{name} has {} probes, more than the {MAX_PROBES_PER_AXIS} allowed",
            v.len()
        )));
    }
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(LevelError(format!("{name}[{i}] is not a finite number")));
    }
    if let Some(i) = v.windows(2).position(|w| !(w[1] > w[0])) {
        return Err(LevelError(format!(
            "{name} must increase strictly: {name}[{}] = {} is not above {name}[{i}] = {}",
            i + 1,
            v[i + 1],
            v[i]
        )));
    }
    Ok(())
}

impl HeightMap {
    /// A validated height map: increasing finite axes, one finite row per y with one height per x.
    pub fn new(x_mm: Vec<f64>, y_mm: Vec<f64>, z_mm: Vec<Vec<f64>>) -> Result<HeightMap, LevelError> {
        let h = HeightMap { x_mm, y_mm, z_mm };
        h.validate()?;
        Ok(h)
    }

    /// Checks the map (what [`HeightMap::new`] and reading a file check).
    pub fn validate(&self) -> Result<(), LevelError> {
        check_axis("x_mm", &self.x_mm)?;
        check_axis("y_mm", &self.y_mm)?;
        if self.z_mm.len() != self.y_mm.len() {
            return Err(LevelError(format!(
                "z_mm has {} rows but y_mm has {} values (one row per y)",
                self.z_mm.len(),
                self.y_mm.len()
            )));
        }
        for (j, row) in self.z_mm.iter().enumerate() {
            if row.len() != self.x_mm.len() {
                return Err(LevelError(format!(
                    "z_mm row {j} has {} heights but x_mm has {} values",
                    row.len(),
                    self.x_mm.len()
                )));
            }
            if let Some(i) = row.iter().position(|z| !z.is_finite()) {
                return Err(LevelError(format!("z_mm[{j}][{i}] is not a finite number")));
            }
        }
        Ok(())
    }

    /// Reads and validates `heightmap.json`; errors name the file.
    pub fn load(path: &std::path::Path) -> Result<HeightMap, LevelError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| LevelError(format!("cannot read height map {}: {e}", path.display())))?;
        serde_json::from_str(&text).map_err(|e| LevelError(format!("height map {} is not valid: {e}", path.display())))
    }

    /// The map as `heightmap.json` text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a height map serializes")
    }

    /// Lowest and highest probed height, mm.
    pub fn range(&self) -> (f64, f64) {
        self.z_mm
            .iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &z| {
                (lo.min(z), hi.max(z))
            })
    }

    /// Whether (x, y) lies inside the probed rectangle (where [`HeightMap::at`] is not clamped).
    pub fn covers(&self, x: f64, y: f64) -> bool {
        let (xs, ys) = (&self.x_mm, &self.y_mm);
        x >= xs[0] && x <= xs[xs.len() - 1] && y >= ys[0] && y <= ys[ys.len() - 1]
    }

    /// The surface height at (x, y): bilinear between probes, clamped at the edges.
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let (i, tx) = cell(&self.x_mm, x);
        let (j, ty) = cell(&self.y_mm, y);
        let z = |j: usize, i: usize| self.z_mm[j][i];
        let (i1, j1) = ((i + 1).min(self.x_mm.len() - 1), (j + 1).min(self.y_mm.len() - 1));
        let lo = z(j, i) + tx * (z(j, i1) - z(j, i));
        let hi = z(j1, i) + tx * (z(j1, i1) - z(j1, i));
        lo + ty * (hi - lo)
    }
}

/// The grid cell of `v` on `axis` and the fraction across it, clamped to the axis.
fn cell(axis: &[f64], v: f64) -> (usize, f64) {
    let n = axis.len();
    if n == 1 || v <= axis[0] {
        return (0, 0.0);
    }
    if v >= axis[n - 1] {
        return (n - 2, 1.0);
    }
    let i = axis.partition_point(|&a| a <= v) - 1;
    (i, (v - axis[i]) / (axis[i + 1] - axis[i]))
}

/// The commanded path of one cut from `a` to `b`, `depth` mm below the measured surface: points
/// (x, y, Z) with Z = at(x, y) - depth at every point, joined by straight G1 moves, such that the
/// surface departs from each move's straight line by at most `tol_mm`.
pub fn compensate(
    map: &HeightMap,
    a: [f64; 2],
    b: [f64; 2],
    depth: f64,
    tol_mm: f64,
) -> Result<Vec<[f64; 3]>, LevelError> {
    if !(tol_mm > 0.0 && tol_mm.is_finite()) {
        return Err(LevelError(format!(
            "the levelling tolerance must be > 0 mm, not {tol_mm}"
        )));
    }
    let p = |t: f64| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    let h = |t: f64| {
        let q = p(t);
        map.at(q[0], q[1])
    };
    // Where the line crosses a grid line (the surface's slope may change there).
    let mut ts = vec![0.0, 1.0];
    for (axis, k) in [(&map.x_mm, 0usize), (&map.y_mm, 1usize)] {
        let d = b[k] - a[k];
        if d != 0.0 {
            for &g in axis.iter() {
                let t = (g - a[k]) / d;
                if t > 0.0 && t < 1.0 {
                    ts.push(t);
                }
            }
        }
    }
    ts.sort_by(f64::total_cmp);
    ts.dedup_by(|x, y| (*x - *y).abs() < 1e-12);
    // Within each piece the surface is a quadratic; split the pieces that bend more than tol
    // against their own chord (departure at the midpoint = |c2| L^2 / 4, exactly).
    let mut knots = vec![0.0];
    for w in ts.windows(2) {
        let (t0, t1) = (w[0], w[1]);
        let dev = (h(0.5 * (t0 + t1)) - 0.5 * (h(t0) + h(t1))).abs();
        let n = ((dev / tol_mm).sqrt().ceil() as usize).max(1);
        if n > 100_000 {
            return Err(LevelError(format!(
                "the surface bends {dev:.4} mm along one stretch of a cut: more than 100000 segments \
                 for a {tol_mm} mm tolerance (is the height map in mm?)"
            )));
        }
        for k in 1..=n {
            knots.push(t0 + (t1 - t0) * k as f64 / n as f64);
        }
    }
    // Keep only the knots the tolerance needs: extend each segment as far as every piece inside
    // it stays within tol of the segment's line.
    let within = |i: usize, j: usize| {
        let (ti, tj) = (knots[i], knots[j]);
        let (hi, hj) = (h(ti), h(tj));
        let line = |t: f64| hi + (hj - hi) * (t - ti) / (tj - ti);
        (i..j).all(|k| {
            let (s0, s1) = (knots[k], knots[k + 1]);
            let sm = 0.5 * (s0 + s1);
            let (e0, em, e1) = (h(s0) - line(s0), h(sm) - line(sm), h(s1) - line(s1));
            // e(s) is a quadratic on [s0, s1]: through (0, e0), (1/2, em), (1, e1) in u.
            let c2 = 2.0 * (e0 + e1) - 4.0 * em;
            let c1 = e1 - e0 - c2;
            let mut worst = e0.abs().max(e1.abs());
            if c2 != 0.0 {
                let u = -c1 / (2.0 * c2);
                if u > 0.0 && u < 1.0 {
                    worst = worst.max((e0 + c1 * u + c2 * u * u).abs());
                }
            }
            worst <= tol_mm
        })
    };
    let mut keep = vec![0usize];
    let last = knots.len() - 1;
    let mut i = 0;
    while i < last {
        let mut j = i + 1;
        while j < last && within(i, j + 1) {
            j += 1;
        }
        keep.push(j);
        i = j;
    }
    Ok(keep
        .into_iter()
        .map(|k| {
            let q = p(knots[k]);
            [q[0], q[1], h(knots[k]) - depth]
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tilted() -> HeightMap {
        let xs: Vec<f64> = (0..5).map(|i| -40.0 + 20.0 * i as f64).collect();
        let ys: Vec<f64> = (0..4).map(|j| -30.0 + 20.0 * j as f64).collect();
        let z = ys
            .iter()
            .map(|&y| xs.iter().map(|&x| 0.01 + 0.002 * x - 0.001 * y).collect())
            .collect();
        HeightMap::new(xs, ys, z).unwrap()
    }

    #[test]
    fn bilinear_and_clamped() {
        let m = tilted();
        assert!((m.at(3.0, -7.0) - (0.01 + 0.006 + 0.007)).abs() < 1e-15);
        // Clamped beyond the probes.
        assert!((m.at(100.0, 0.0) - m.at(40.0, 0.0)).abs() < 1e-15);
        assert!((m.at(0.0, -100.0) - m.at(0.0, -30.0)).abs() < 1e-15);
        assert!(m.covers(0.0, 0.0) && !m.covers(41.0, 0.0));
        let one = HeightMap::new(vec![0.0], vec![0.0], vec![vec![0.25]]).unwrap();
        assert_eq!(one.at(5.0, -3.0), 0.25);
    }

    #[test]
    fn a_plane_needs_no_split() {
        let m = tilted();
        let path = compensate(&m, [-35.0, -25.0], [38.0, 27.0], 0.05, 1e-3).unwrap();
        assert_eq!(path.len(), 2, "{path:?}");
    }
}
