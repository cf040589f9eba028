//! `design --balance`: each view's weight in the loss follows how far it stands below what its
//! picture allows (its cap: the correlation a render equal to the picture would have), so the
//! views that lag get more of the scratches' attention (issue 50's lever "weights that follow
//! each view's shortfall against its own cap").
//!
//! From [`START`] of the run on, every [`every`] iterations: each view's correlation with its
//! picture is measured on the render just accepted, its shortfall s_v = max(cap_v - corr_v, 0),
//! and its weight w_v = clamp(s_v / mean s, [`MIN_WEIGHT`], [`MAX_WEIGHT`]), scaled to a mean of
//! 1 (views blank on purpose, or with no shortfall to share, keep 1). Every update is written to
//! `balance.json` beside the checkpoint (atomically), and a resumed run takes the weights of the
//! last update at or before its iteration from it, so it continues bit for bit; without the
//! file (a run made before it) the weights are measured at once from the resumed state.
use crate::live::Live;
use crate::measure::quality;
use scratchart_observe::Observer;
use scratchart_optim::error::OptimError;

/// The share of the run after which the weights start to move (before it every view is far from
/// its cap and the shortfalls say little).
pub const START: f64 = 0.3;
pub const MIN_WEIGHT: f64 = 0.5;
pub const MAX_WEIGHT: f64 = 3.0;

/// Iterations between two updates in a run of `iters`.
pub fn every(iters: u32) -> u32 {
    (iters / 10).max(5)
}

/// Weights from shortfalls (see the module's rule); `None` entries (blank views) keep 1.
pub fn weights(shortfalls: &[Option<f64>]) -> Vec<f32> {
    let used: Vec<f64> = shortfalls.iter().flatten().copied().collect();
    let mean = used.iter().sum::<f64>() / used.len().max(1) as f64;
    if !(mean > 1e-6) {
        return vec![1.0; shortfalls.len()];
    }
    let raw: Vec<Option<f64>> = shortfalls
        .iter()
        .map(|s| s.map(|s| (s / mean).clamp(MIN_WEIGHT, MAX_WEIGHT)))
        .collect();
    let n = raw.iter().flatten().count().max(1) as f64;
    let scale = n / raw.iter().flatten().sum::<f64>();
    raw.iter().map(|w| w.map_or(1.0, |w| (w * scale) as f32)).collect()
}

/// The balancing of one run: each view's cap, once, and the updates so far.
pub struct Balance {
    caps: Vec<f64>,
    blank: Vec<bool>,
    iters: u32,
    sigma: f32,
    /// Where `balance.json` goes (None: nowhere, a run that writes no files).
    file: Option<std::path::PathBuf>,
    /// (iteration, weights) of every update, in order.
    updates: std::sync::Mutex<Vec<(u32, Vec<f32>)>>,
}

/// The record of the updates beside the checkpoint.
pub const FILE: &str = "balance.json";

impl Balance {
    pub fn new(
        problem: &crate::problem::Problem,
        blank_views: &[String],
        iters: u32,
        sigma: f32,
        out: Option<&std::path::Path>,
    ) -> Balance {
        let caps = quality(
            &problem.scene,
            &problem.targets,
            &problem.targets,
            &problem.pictures,
            sigma,
        )
        .iter()
        .map(|q| q.corr)
        .collect();
        Balance {
            caps,
            blank: problem
                .scene
                .views
                .iter()
                .map(|v| blank_views.contains(&v.name))
                .collect(),
            iters,
            sigma,
            file: out.map(|d| d.join(FILE)),
            updates: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// A resumed run at iteration `k`: the updates the stopped run made up to `k`, read back
    /// from `balance.json`, and the weights of the last of them (None without the file or an
    /// update).
    pub fn resumed(&self, k: u32) -> Option<Vec<f32>> {
        let text = std::fs::read_to_string(self.file.as_ref()?).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        let updates: Vec<(u32, Vec<f32>)> = v["updates"]
            .as_array()?
            .iter()
            .filter_map(|u| {
                let i = u["iteration"].as_u64()? as u32;
                let w: Option<Vec<f32>> = u["weights"]
                    .as_array()?
                    .iter()
                    .map(|x| x.as_f64().map(|x| x as f32))
                    .collect();
                Some((i, w?))
            })
            .filter(|(i, _)| *i <= k)
            .collect();
        let last = updates.last()?.1.clone();
        *self.updates.lock().unwrap() = updates;
        Some(last)
    }

    /// Records an update and writes `balance.json` (atomically).
    fn record(&self, k: u32, w: &[f32]) -> Result<(), OptimError> {
        let mut u = self.updates.lock().unwrap();
        u.push((k, w.to_vec()));
        if let Some(f) = &self.file {
            let doc = serde_json::json!({
                "what": "design --balance: each view's loss weight from each update on (engine/design/src/balance.rs); a resumed run reads it",
                "updates": u.iter().map(|(i, w)| serde_json::json!({"iteration": i, "weights": w})).collect::<Vec<_>>(),
            });
            scratchart_render::io::write_atomic(f, doc.to_string().as_bytes())?;
        }
        Ok(())
    }

    /// Whether the weights are updated before iteration `k`.
    pub fn due(&self, k: u32) -> bool {
        let start = (START * self.iters as f64).ceil() as u32;
        k >= start && k < self.iters && (k - start) % every(self.iters) == 0
    }

    /// Whether a run resumed at iteration `k` (to evaluate it next) runs on weights of an update
    /// at or before it.
    pub fn started(&self, k: u32) -> bool {
        k >= (START * self.iters as f64).ceil() as u32 && k < self.iters
    }

    /// Updates the loss's view weights where due, or at once with `now` (see the module's rule).
    pub fn apply(&self, live: &mut Live, obs: &dyn Observer, now: bool) -> Result<(), OptimError> {
        let k = live.iteration();
        if !(now || self.due(k)) {
            return Ok(());
        }
        let displays: Vec<Vec<f32>> = live
            .images()?
            .iter()
            .map(|img| {
                img.iter()
                    .map(|&l| scratchart_render::io::display_value(l).clamp(0.0, 1.0))
                    .collect()
            })
            .collect();
        let p = &*live.problem;
        let q = quality(&p.scene, &displays, &p.targets, &p.pictures, self.sigma);
        let short: Vec<Option<f64>> = q
            .iter()
            .zip(&self.caps)
            .zip(&self.blank)
            .map(|((q, cap), blank)| (!blank && q.corr.is_finite() && cap.is_finite()).then(|| (cap - q.corr).max(0.0)))
            .collect();
        let w = weights(&short);
        live.loss.set_view_weights(&live.renderer.ctx, &w)?;
        self.record(k, &w)?;
        obs.info(&format!(
            "balance at iteration {k}: view weights {} (each view's correlation with its picture, of what the picture allows: {})",
            w.iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(" "),
            q.iter()
                .zip(&self.caps)
                .map(|(q, cap)| format!("{:.3} of {cap:.3}", q.corr))
                .collect::<Vec<_>>()
                .join(", ")
        ));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_follow_the_shortfalls() {
        // Equal shortfalls, or none: all 1.
        assert_eq!(weights(&[Some(0.02), Some(0.02), Some(0.02)]), vec![1.0; 3]);
        assert_eq!(weights(&[Some(0.0), Some(0.0)]), vec![1.0; 2]);
        // The lagging view gets more, within the bounds, the mean stays 1, blank views keep 1.
        let w = weights(&[Some(0.001), Some(0.03), None, Some(0.01)]);
        assert_eq!(w[2], 1.0);
        let used = [w[0], w[1], w[3]];
        assert!((used.iter().sum::<f32>() / 3.0 - 1.0).abs() < 1e-5, "{w:?}");
        assert!(w[1] > w[3] && w[3] > w[0], "{w:?}");
        assert!(w[1] / w[0] <= (MAX_WEIGHT / MIN_WEIGHT) as f32 + 1e-4, "{w:?}");
    }

    #[test]
    fn updates_start_late_and_come_regularly() {
        let b = Balance {
            caps: vec![],
            blank: vec![],
            iters: 100,
            sigma: 1.0,
            file: None,
            updates: Default::default(),
        };
        let due: Vec<u32> = (0..=100).filter(|&k| b.due(k)).collect();
        assert_eq!(due, vec![30, 40, 50, 60, 70, 80, 90]);
    }
}
