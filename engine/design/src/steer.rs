//! Steering a design while it runs: a view's picture moved or scaled on the plate at a given
//! iteration (`scratchart-view --design`, keys or `--script`), and the same changes replayed from
//! the command line (`scratchart design --steer FILE`), so a steered design can be reproduced.
//!
//! An event states where the picture is from that iteration on, relative to where the design
//! placed it at the start: shifted by `shift_px` (image pixels, x right, y down) and scaled by
//! `scale` about its centre. The picture is placed again from its file exactly as at the start
//! ([`crate::framing::fit_picture_rect`], the same tone curve), the loss's targets are replaced
//! between two iterations ([`scratchart_optim::loss::Loss::set_targets`]), and `summary.json`'s `steering`
//! lists every event applied. Only designs from `--targets` pictures placed in a rectangle
//! (`--fit contain`, `cover` or `frame`) can be steered.
use serde::{Deserialize, Serialize};

use crate::framing::{Fit, Fitted, Rect};

/// One change, applied before iteration `iteration` runs: a view's picture moved and scaled
/// (`view`, with `shift_px` [0, 0] and `scale` 1 when absent), the loss's weights changed
/// (`lambda_p`, `lambda_g`: the pixel and Gram terms'; an absent one keeps its value), or both.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SteerEvent {
    pub iteration: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub view: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shift_px: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lambda_p: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lambda_g: Option<f64>,
    /// Scratches removed: their indices in the design as it stood before this event (each
    /// once). Applied before `add`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub remove: Option<Vec<u32>>,
    /// Scratches added after the others, drawn as the design drew its first ones
    /// ([`ScratchInit`]) from the random stream `seed`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub add: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

/// How a design drew its first scratches ([`crate::scenes::random_scratches`]): scratches
/// added while it runs are drawn the same way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScratchInit {
    pub len_mm: (f64, f64),
    pub w: f64,
    pub d: f64,
    pub alpha: f64,
}

/// The most scratches one event may add or a design may reach by adding.
pub const MAX_SCRATCHES: u32 = 10_000_000;

impl SteerEvent {
    /// A picture's move.
    pub fn picture(iteration: u32, view: &str, shift_px: [f64; 2], scale: f64) -> SteerEvent {
        SteerEvent {
            iteration,
            view: Some(view.to_string()),
            shift_px: Some(shift_px),
            scale: Some(scale),
            ..Default::default()
        }
    }

    /// A change of the loss's weights.
    pub fn weights(iteration: u32, lambda_p: Option<f64>, lambda_g: Option<f64>) -> SteerEvent {
        SteerEvent {
            iteration,
            lambda_p,
            lambda_g,
            ..Default::default()
        }
    }

    /// Scratches removed and added.
    pub fn scratches(iteration: u32, remove: Vec<u32>, add: u32, seed: u64) -> SteerEvent {
        SteerEvent {
            iteration,
            remove: (!remove.is_empty()).then_some(remove),
            add: (add > 0).then_some(add),
            seed: (add > 0).then_some(seed),
            ..Default::default()
        }
    }

    /// Whether the event changes the number of scratches (or which they are).
    pub fn resizes(&self) -> bool {
        self.remove.is_some() || self.add.is_some()
    }

    pub fn shift(&self) -> [f64; 2] {
        self.shift_px.unwrap_or([0.0, 0.0])
    }

    pub fn scale(&self) -> f64 {
        self.scale.unwrap_or(1.0)
    }
}

/// A view's picture as read from its file, with how it was placed, for placing it again.
#[derive(Clone, Debug)]
pub struct Source {
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
    pub fit: Fit,
    pub background: f32,
    pub gamma: f32,
    /// Where the design placed it at the start.
    pub rect: Rect,
}

impl Source {
    /// The picture placed in `view` (of `plate`) as `event` says.
    pub fn place(
        &self,
        view: &scratchart_model::scene::View,
        plate: &scratchart_model::scene::Plate,
        shift: [f64; 2],
        scale: f64,
    ) -> Fitted {
        let r = self.rect;
        let (w, h) = (r.w * scale, r.h * scale);
        let rect = Rect {
            x0: r.x0 + 0.5 * (r.w - w) + shift[0],
            y0: r.y0 + 0.5 * (r.h - h) + shift[1],
            w,
            h,
        };
        let mut f = crate::framing::fit_picture_rect(
            &self.data,
            self.width,
            self.height,
            view,
            plate,
            self.fit,
            self.background,
            Some(rect),
        );
        if self.gamma != 1.0 {
            for (v, p) in f.image.iter_mut().zip(&f.picture) {
                if *p {
                    *v = v.powf(self.gamma);
                }
            }
        }
        f
    }
}

/// Checks an event against the problem's views: something to change; weights finite and >= 0;
/// a known view with a steerable picture, a finite shift, a scale in (0.05, 20]. Returns the
/// view's index, if the event moves a picture.
pub fn check(
    e: &SteerEvent,
    views: &[scratchart_model::scene::View],
    sources: &[Option<Source>],
) -> Result<Option<usize>, String> {
    for (name, w) in [("lambda_p", e.lambda_p), ("lambda_g", e.lambda_g)] {
        if let Some(w) = w {
            if !(w.is_finite() && w >= 0.0) {
                return Err(format!(
                    "steering at iteration {}: {name} must be a weight >= 0 (it is {w})",
                    e.iteration
                ));
            }
        }
    }
    if let Some(r) = &e.remove {
        let mut seen = std::collections::HashSet::new();
        if r.is_empty() {
            return Err(format!(
                "steering at iteration {}: `remove` lists no scratch",
                e.iteration
            ));
        }
        if let Some(d) = r.iter().find(|&&i| !seen.insert(i)) {
            return Err(format!(
                "steering at iteration {}: scratch {d} is removed twice",
                e.iteration
            ));
        }
    }
    if let Some(a) = e.add {
        if a == 0 || a > MAX_SCRATCHES {
            return Err(format!(
                "steering at iteration {}: `add` must be 1 to {MAX_SCRATCHES} scratches (it is {a})",
                e.iteration
            ));
        }
        if e.seed.is_none() {
            return Err(format!(
                "steering at iteration {}: `add` needs the `seed` its scratches were drawn from",
                e.iteration
            ));
        }
    }
    let Some(view) = &e.view else {
        if e.lambda_p.is_none() && e.lambda_g.is_none() && !e.resizes() {
            return Err(format!(
                "steering at iteration {}: the event changes nothing (give a view, lambda_p, lambda_g, add or remove)",
                e.iteration
            ));
        }
        if e.shift_px.is_some() || e.scale.is_some() {
            return Err(format!(
                "steering at iteration {}: a shift or scale needs the view it moves",
                e.iteration
            ));
        }
        return Ok(None);
    };
    let v = views.iter().position(|v| &v.name == view).ok_or_else(|| {
        format!(
            "steering at iteration {}: no view is named `{view}` (the views: {})",
            e.iteration,
            views.iter().map(|v| v.name.as_str()).collect::<Vec<_>>().join(", ")
        )
    })?;
    if sources.get(v).is_none_or(|s| s.is_none()) {
        return Err(format!(
            "steering at iteration {}: view {view}'s picture cannot be moved (only pictures given with --targets and \
             placed in a rectangle, --fit contain, cover or frame)",
            e.iteration
        ));
    }
    let (shift, scale) = (e.shift(), e.scale());
    if !(shift.iter().all(|x| x.is_finite()) && scale > 0.05 && scale <= 20.0) {
        return Err(format!(
            "steering at iteration {} of view {view}: the shift must be finite and the scale in (0.05, 20] (it is {shift:?}, {scale})",
            e.iteration
        ));
    }
    Ok(Some(v))
}

/// Reads steering events: a JSON array of them, or a design's `summary.json` (its `steering`).
/// They must come in the order of their iterations.
pub fn read(path: &std::path::Path) -> Result<Vec<SteerEvent>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{} is not valid JSON: {e}", path.display()))?;
    let list = match v.get("steering") {
        Some(s) => s.clone(),
        None => v,
    };
    let events: Vec<SteerEvent> = serde_json::from_value(list).map_err(|e| {
        format!(
            "{}: not a list of steering events ({{\"iteration\", \"view\", \"shift_px\": [x, y], \"scale\", \"lambda_p\", \"lambda_g\", \"remove\": [indices], \"add\", \"seed\"}}) nor a summary.json with one: {e}",
            path.display()
        )
    })?;
    if let Some(w) = events.windows(2).find(|w| w[1].iteration < w[0].iteration) {
        return Err(format!(
            "{}: the steering events must come in the order of their iterations ({} after {})",
            path.display(),
            w[1].iteration,
            w[0].iteration
        ));
    }
    Ok(events)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_read_from_a_list_or_a_summary_in_order() {
        let dir = std::env::temp_dir().join(format!("scratchart-steer-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let e = r#"[{"iteration": 3, "view": "v0", "shift_px": [2.0, -1.0], "scale": 1.1}]"#;
        std::fs::write(dir.join("a.json"), e).unwrap();
        std::fs::write(dir.join("s.json"), format!(r#"{{"views": 2, "steering": {e}}}"#)).unwrap();
        for f in ["a.json", "s.json"] {
            let got = read(&dir.join(f)).unwrap();
            assert_eq!(got, vec![SteerEvent::picture(3, "v0", [2.0, -1.0], 1.1)]);
        }
        std::fs::write(
            dir.join("b.json"),
            r#"[{"iteration": 5, "view": "v0", "shift_px": [0, 0], "scale": 1}, {"iteration": 2, "view": "v0", "shift_px": [0, 0], "scale": 1}]"#,
        )
        .unwrap();
        assert!(read(&dir.join("b.json")).unwrap_err().contains("order"));
        std::fs::write(dir.join("c.json"), r#"{"x": 1}"#).unwrap();
        assert!(read(&dir.join("c.json")).unwrap_err().contains("steering events"));
    }

    #[test]
    fn scratches_added_and_removed_are_checked() {
        let ok = SteerEvent::scratches(4, vec![1, 5], 10, 77);
        assert!(ok.resizes());
        assert_eq!(check(&ok, &[], &[]), Ok(None));
        let json = serde_json::to_string(&ok).unwrap();
        assert_eq!(serde_json::from_str::<SteerEvent>(&json).unwrap(), ok);
        let bad = |e: SteerEvent, what: &str| {
            let err = check(&e, &[], &[]).unwrap_err();
            assert!(err.contains(what), "{err}");
        };
        bad(SteerEvent::scratches(4, vec![1, 5, 1], 0, 0), "removed twice");
        bad(
            SteerEvent {
                remove: Some(vec![]),
                ..Default::default()
            },
            "no scratch",
        );
        bad(
            SteerEvent {
                add: Some(3),
                ..Default::default()
            },
            "seed",
        );
        bad(
            SteerEvent {
                add: Some(0),
                seed: Some(1),
                ..Default::default()
            },
            "1 to",
        );
        bad(SteerEvent::default(), "changes nothing");
    }
}
