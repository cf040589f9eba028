//! Per-pixel culling of scratches: a uniform grid over the plate holding each carved rectangle's
//! axis-aligned bounding box. Exact: it only skips pairs whose footprint and carved rectangle
//! cannot meet.

use super::Prep;

/// Uniform grid of scratch bounding boxes.
pub(super) struct Grid {
    min: [f64; 2],
    cell: [f64; 2],
    n: usize,
    cells: Vec<Vec<u32>>,
}

impl Grid {
    pub(super) fn new(preps: &[Prep]) -> Grid {
        if preps.is_empty() {
            return Grid {
                min: [0.0; 2],
                cell: [1.0; 2],
                n: 0,
                cells: Vec::new(),
            };
        }
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in preps {
            lo[0] = lo[0].min(p.bbox[0]);
            lo[1] = lo[1].min(p.bbox[1]);
            hi[0] = hi[0].max(p.bbox[2]);
            hi[1] = hi[1].max(p.bbox[3]);
        }
        let n = ((preps.len() as f64).sqrt().ceil() as usize).clamp(1, 128);
        let cell = [
            ((hi[0] - lo[0]) / n as f64).max(1e-300),
            ((hi[1] - lo[1]) / n as f64).max(1e-300),
        ];
        let mut g = Grid {
            min: lo,
            cell,
            n,
            cells: vec![Vec::new(); n * n],
        };
        for (k, p) in preps.iter().enumerate() {
            let (i0, j0, i1, j1) = g.range(p.bbox).expect("scratch inside its own grid");
            for j in j0..=j1 {
                for i in i0..=i1 {
                    g.cells[j * n + i].push(k as u32);
                }
            }
        }
        g
    }

    /// Cell index range overlapped by a bbox, or None when it misses the grid.
    fn range(&self, bb: [f64; 4]) -> Option<(usize, usize, usize, usize)> {
        if self.n == 0 {
            return None;
        }
        let top = [
            self.min[0] + self.cell[0] * self.n as f64,
            self.min[1] + self.cell[1] * self.n as f64,
        ];
        if bb[2] < self.min[0] || bb[3] < self.min[1] || bb[0] > top[0] || bb[1] > top[1] {
            return None;
        }
        let idx = |x: f64, a: usize| -> usize {
            let f = ((x - self.min[a]) / self.cell[a]).floor();
            if f < 0.0 {
                0
            } else {
                (f as usize).min(self.n - 1)
            }
        };
        Some((idx(bb[0], 0), idx(bb[1], 1), idx(bb[2], 0), idx(bb[3], 1)))
    }

    pub(super) fn candidates(&self, bb: [f64; 4], preps: &[Prep], out: &mut Vec<u32>) {
        out.clear();
        if let Some((i0, j0, i1, j1)) = self.range(bb) {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    for &k in &self.cells[j * self.n + i] {
                        let p = &preps[k as usize].bbox;
                        if p[0] <= bb[2] && p[2] >= bb[0] && p[1] <= bb[3] && p[3] >= bb[1] {
                            out.push(k);
                        }
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}
