//! The cross-talk term's pairs and directions (host side of `XPair` in
//! `shaders/inc/loss_push.glsl`; [`super::Loss::with_crosstalk`]).
use bytemuck::{Pod, Zeroable};

use super::Pyramid;

/// `#[repr(C)]` twin of `XPair` in `shaders/inc/loss_push.glsl`: view v's blurred error
/// projected on u = mask_v (T_k - mu) s.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct XPair {
    pub v: u32,
    pub k: u32,
    /// First of its partial sums (one per 256-pixel block of view v).
    pub part0: u32,
    pub pad: u32,
    pub mu: f32,
    pub s: f32,
    pub pad1: f32,
    pub pad2: f32,
}

/// The cross-talk term's host side: which ordered pairs of views, and what their directions
/// are computed from (kept to compute them again when a steered design moves a picture).
pub(super) struct Cross {
    pub(super) kappa: f32,
    pub(super) pairs: Vec<(usize, usize)>,
    /// Per view, its picture's pixels (level 0, W x H).
    pub(super) pictures: Vec<Vec<bool>>,
    pub(super) targets: Vec<Vec<f32>>,
}

impl Cross {
    /// Each pair's (mu, s): view k's target over view v's picture, centred, scaled to norm
    /// sqrt(kappa) (s = 0 where it is flat there).
    pub(super) fn pair_data(&self, pyr: &Pyramid) -> Vec<XPair> {
        let mut part0 = 0u32;
        self.pairs
            .iter()
            .map(|&(v, k)| {
                let (m, t) = (&self.pictures[v], &self.targets[k]);
                let n = m.iter().filter(|&&b| b).count().max(1) as f64;
                let mu = t.iter().zip(m).filter(|(_, &b)| b).map(|(&x, _)| x as f64).sum::<f64>() / n;
                let ss: f64 = t
                    .iter()
                    .zip(m)
                    .filter(|(_, &b)| b)
                    .map(|(&x, _)| (x as f64 - mu).powi(2))
                    .sum();
                let s = if ss > 0.0 {
                    (self.kappa as f64).sqrt() / ss.sqrt()
                } else {
                    0.0
                };
                let p = XPair {
                    v: v as u32,
                    k: k as u32,
                    part0,
                    mu: mu as f32,
                    s: s as f32,
                    ..Default::default()
                };
                part0 += pyr.segs[v].nblk;
                p
            })
            .collect()
    }

    /// 1 inside each view's picture, level 0 in the image's layout.
    pub(super) fn mask(&self, pyr: &Pyramid) -> Vec<f32> {
        let mut out = vec![0f32; pyr.levels[0].1 as usize];
        for seg in pyr.segs.iter().filter(|s| s.level == 0) {
            for (i, &b) in self.pictures[seg.view as usize].iter().enumerate() {
                out[seg.off as usize + i] = if b { 1.0 } else { 0.0 };
            }
        }
        out
    }
}
