//! The fitted numbers of each tool kind: names, bounds, difference steps, limits of
//! identifiability, and the map from the parameter vector to the tool and the camera terms.
use scratchart_tool::Tool;

use super::super::card::Card;
use super::Kind;

/// One fitted number: its name, bounds, the forward-difference step, and the uncertainty above
/// which it counts as not identified.
#[derive(Clone, Debug)]
pub(super) struct Param {
    pub(super) name: String,
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) step: f64,
    /// Needs a new render when it changes.
    pub(super) render: bool,
    pub(super) limit: f64,
}

fn p(name: &str, lo: f64, hi: f64, step: f64, render: bool, limit: f64) -> Param {
    Param {
        name: name.into(),
        lo,
        hi,
        step,
        render,
        limit,
    }
}

/// A start's shape: a V-bit's angle and tip flat, a ball's radius (and 0).
pub(super) type Shape = (f64, f64);

/// What a plate needs of the fit: the tool's angle within 1 degree, its lengths (tip flat,
/// radius, a profile's widths) within 5 um and its z offset within 3 um. A parameter counts as
/// identified when its (block sandwich) standard deviation is at most half of that, so that an
/// accepted tool is within it at about two standard deviations; otherwise the fit refuses
/// (`--allow-unidentified` writes it anyway, marked).
pub const ANGLE_TOL_DEG: f64 = 1.0;
pub const LENGTH_TOL_MM: f64 = 0.005;
pub const OFFSET_TOL_MM: f64 = 0.003;
const ANGLE_LIMIT: f64 = 0.5 * ANGLE_TOL_DEG;
const LENGTH_LIMIT: f64 = 0.5 * LENGTH_TOL_MM;
const OFFSET_LIMIT: f64 = 0.5 * OFFSET_TOL_MM;

/// How far the fit may scale a photo's sensor noise from the one measured, in log (x0.5 to x2).
pub(super) const NOISE_SPAN: f64 = 0.7;

/// Camera terms per photo taken off the capture pose (eye x, y, z; roll; log field of view).
pub(super) const POSE_PARAMS: usize = 5;

/// The parameter layout of a kind: tool parameters, then alpha, the log exposures and the blurs.
pub(super) struct Layout {
    pub(super) kind: Kind,
    /// The last 2 per view are a sub-pixel shift of each view's model (registration).
    pub(super) reg: bool,
    /// Per view, the index of its eye correction (x, y, z in mm), if it is fitted.
    pub(super) pose_at: Vec<Option<usize>>,
    /// Index of the first shading term (3 per view: see [`Layout::shade`]).
    pub(super) shade_at: usize,
    /// Per view, the index of its log noise scale (`ln_noise[v]`), if its photo has noise.
    pub(super) noise_at: Vec<Option<usize>>,
    /// Index of the first tone term (one per view where they are free: see [`Layout::tone`]).
    pub(super) tone_at: usize,
    pub(super) tone_free: bool,
    pub(super) params: Vec<Param>,
    /// Index of the z offset (none for a profile: its points are in commanded depth).
    pub(super) offset: Option<usize>,
    pub(super) n_tool: usize,
    pub(super) n_views: usize,
    /// The card's ladder depths (a profile has one width per depth).
    pub(super) depths: Vec<f64>,
}

impl Layout {
    pub(super) fn new(
        kind: Kind,
        card: &Card,
        n_views: usize,
        refine_registration: bool,
        pose: &[bool],
        noisy: &[bool],
        tone_free: bool,
    ) -> Layout {
        let mut params = match kind {
            Kind::VBit => vec![
                p("angle_deg", 5.0, 175.0, 0.2, true, ANGLE_LIMIT),
                p("tip_flat_mm", 0.0, 0.5, 0.0005, true, LENGTH_LIMIT),
                p("z_offset_mm", -0.3, 0.3, 0.0005, true, OFFSET_LIMIT),
            ],
            Kind::Ball => vec![
                p("radius_mm", 0.002, 3.0, 0.001, true, LENGTH_LIMIT),
                p("z_offset_mm", -0.3, 0.3, 0.0005, true, OFFSET_LIMIT),
            ],
            Kind::TaperedBall => vec![
                p("radius_mm", 0.002, 3.0, 0.001, true, LENGTH_LIMIT),
                p("angle_deg", 5.0, 175.0, 0.2, true, ANGLE_LIMIT),
                p("z_offset_mm", -0.3, 0.3, 0.0005, true, OFFSET_LIMIT),
            ],
            Kind::Profile => {
                let mut v: Vec<Param> = card
                    .depths_mm
                    .iter()
                    .map(|z| p(&format!("W_mm@{z}"), 0.0, 2.0, 0.0005, true, LENGTH_LIMIT))
                    .collect();
                v.push(p("w_over_W", 1.0, 5.0, 0.01, true, 1.0));
                v
            }
        };
        let offset = params.iter().position(|q| q.name == "z_offset_mm");
        let n_tool = params.len();
        params.push(p("alpha", 0.01, 0.6, 0.002, true, 0.1));
        for v in 0..n_views {
            params.push(p(&format!("ln_exposure[{v}]"), -12.0, 12.0, 0.01, false, 1.0));
        }
        // One per photo (two phones, or one held steadier, blur differently: a blur shared by
        // both fitted the sharper photo and left the other a residual of 3 to 7 times its noise).
        // From 0: a sharp photo is its pixels' own footprint, which the render already adds up
        // (the registration shift moves the camera, not a kernel, so no kernel must be wide
        // enough to move: a floor of a quarter pixel refused a perfectly sharp photo with a V
        // angle 49 degrees off).
        for v in 0..n_views {
            params.push(p(&format!("blur_px[{v}]"), 0.0, 4.0, 0.02, false, 1.0));
        }
        let reg = if refine_registration {
            for v in 0..n_views {
                for axis in ["dx", "dy"] {
                    params.push(p(&format!("registration[{v}].{axis}"), -2.0, 2.0, 0.05, true, 2.0));
                }
            }
            true
        } else {
            false
        };
        // The camera of a photo taken off the capture pose comes from the card's marks, found to
        // a tenth or two of a pixel: that leaves the grooves up to half a pixel from where the
        // camera saw them, and a groove is a pixel or two wide, so the fit refines the camera
        // with the rest: its eye (the light on the grooves also tells where it was), its turn
        // about its axis and its field of view (the registration shift moves the image).
        let mut pose_at = vec![None; n_views];
        for (v, &on) in pose.iter().enumerate().take(n_views) {
            if on {
                pose_at[v] = Some(params.len());
                for axis in ["x", "y", "z"] {
                    params.push(p(&format!("eye[{v}].{axis}_mm"), -20.0, 20.0, 0.2, true, 20.0));
                }
                params.push(p(&format!("eye[{v}].roll_deg"), -2.0, 2.0, 0.03, true, 2.0));
                params.push(p(&format!("eye[{v}].ln_fov"), -0.05, 0.05, 0.001, true, 0.05));
            }
        }
        // The light across each photo: vignetting and uneven light, a smooth factor
        // exp(gx x + gy y + q (x^2 + y^2)) on the exposure, x and y from the frame's centre in
        // half heights. The card repeats every depth at its point mirror, so these do not pass
        // for a change of width with depth.
        let shade_at = params.len();
        for v in 0..n_views {
            for term in ["gx", "gy", "q"] {
                params.push(p(&format!("shade[{v}].{term}"), -1.5, 1.5, 0.01, false, 1.5));
            }
        }
        // The size of each noisy photo's lift of clipped noise (`noise::Lift`): the log of its
        // sensor noise against the one measured on the photo. A photo's noise is read to 5 or
        // 10% (`fit_cmd::inspect`), and the lift moves a V angle by 15 degrees at 2% noise: a
        // 6% error in the noise put it 2.8 degrees off. The dark plate, where nothing but the
        // lift brightens the photo, pins it.
        let mut noise_at = vec![None; n_views];
        for (v, &on) in noisy.iter().enumerate().take(n_views) {
            if on {
                noise_at[v] = Some(params.len());
                params.push(p(&format!("ln_noise[{v}]"), -NOISE_SPAN, NOISE_SPAN, 0.01, false, 10.0));
            }
        }
        // The photo's tone curve: its value is the encoding's (`crate::encoding`) of the light
        // to the power e^-t, t free per photo (in the fit; `fit::information` analyses a
        // capture with it fixed or free). No phone encodes exactly as one curve says (its tone
        // mapping, an edit), and an app that resampled a photo in its encoding changed thin
        // grooves' light more than wide ones': with the tone free, what the fit states is what
        // the capture tells by geometry and by the width law's shape rather than by an assumed
        // curve.
        let tone_at = params.len();
        if tone_free {
            for v in 0..n_views {
                params.push(p(&format!("tone[{v}]"), -0.3, 0.3, 0.005, false, 1.0));
            }
        }
        Layout {
            tone_at,
            tone_free,
            pose_at,
            shade_at,
            noise_at,
            reg,
            kind,
            params,
            offset,
            n_tool,
            n_views,
            depths: card.depths_mm.clone(),
        }
    }

    pub(super) fn tool(&self, x: &[f64]) -> Tool {
        match self.kind {
            Kind::VBit => Tool::VBit {
                angle_deg: x[0],
                tip_flat_mm: x[1],
                z_offset_mm: x[2],
            },
            Kind::Ball => Tool::Ball {
                radius_mm: x[0],
                z_offset_mm: x[1],
            },
            Kind::TaperedBall => Tool::TaperedBall {
                radius_mm: x[0],
                angle_deg: x[1],
                z_offset_mm: x[2],
            },
            Kind::Profile => {
                let n = self.depths.len();
                let mut w = 0.0f64;
                let points = (0..n)
                    .map(|k| {
                        w = w.max(x[k]);
                        [self.depths[k], w]
                    })
                    .collect();
                Tool::Profile {
                    points,
                    w_over_w: x[n],
                    z_offset_mm: 0.0,
                }
            }
        }
    }

    pub(super) fn alpha(&self, x: &[f64]) -> f64 {
        x[self.n_tool]
    }
    pub(super) fn exposure(&self, x: &[f64], v: usize) -> f64 {
        x[self.n_tool + 1 + v].exp()
    }
    /// The blur of view v's photo, pixels.
    pub(super) fn blur(&self, x: &[f64], v: usize) -> f64 {
        x[self.n_tool + 1 + self.n_views + v]
    }
    /// The widest blur view v's photo may be fitted with, pixels.
    pub(super) fn blur_max(&self, v: usize) -> f64 {
        self.params[self.n_tool + 1 + self.n_views + v].hi
    }
    /// The registration shift of view v, pixels (zero without refinement).
    pub(super) fn shift(&self, x: &[f64], v: usize) -> (f64, f64) {
        if self.reg {
            let b = self.n_tool + 1 + 2 * self.n_views + 2 * v;
            (x[b], x[b + 1])
        } else {
            (0.0, 0.0)
        }
    }

    /// A starting point: a typical tool of the kind, offset `off`, of `shape` (a V-bit's angle
    /// and tip flat, a ball's radius).
    pub(super) fn start(&self, off: f64, shape: Shape) -> Vec<f64> {
        let (shape, flat) = shape;
        let mut x: Vec<f64> = match self.kind {
            Kind::VBit => vec![shape, flat, off],
            Kind::Ball => vec![shape, off],
            Kind::TaperedBall => vec![0.5 * shape, 60.0, off],
            Kind::Profile => {
                let mut v: Vec<f64> = self.depths.iter().map(|z| (z + 0.01).max(0.0) * 1.2).collect();
                v.push(1.2);
                v
            }
        };
        x.push(0.1);
        x.extend(std::iter::repeat_n(0.0, self.n_views));
        x.extend(std::iter::repeat_n(0.5, self.n_views));
        if self.reg {
            x.extend(std::iter::repeat_n(0.0, 2 * self.n_views));
        }
        x.extend(std::iter::repeat_n(
            0.0,
            POSE_PARAMS * self.pose_at.iter().flatten().count(),
        ));
        x.extend(std::iter::repeat_n(0.0, 3 * self.n_views));
        x.extend(std::iter::repeat_n(0.0, self.noise_at.iter().flatten().count()));
        if self.tone_free {
            x.extend(std::iter::repeat_n(0.0, self.n_views));
        }
        x
    }

    /// The tone term t of view v (0 where it is not free): its value is the encoding's of the
    /// light to the power e^-t.
    pub(super) fn tone(&self, x: &[f64], v: usize) -> f64 {
        if self.tone_free {
            x[self.tone_at + v]
        } else {
            0.0
        }
    }

    /// The view whose camera parameter `k` moves (an off-pose photo's eye, or a view's
    /// registration shift): its Jacobian column comes from the image's motion, not a tangent.
    /// The photo whose camera model alone parameter `k` is a term of (its exposure, blur,
    /// shading, noise scale or tone curve: no render), or None.
    pub(super) fn photo_term(&self, k: usize) -> Option<usize> {
        let n = self.n_views;
        // ln_exposure[v], then blur_px[v], after the tool and alpha.
        let first = self.n_tool + 1;
        if (first..first + 2 * n).contains(&k) {
            return Some((k - first) % n);
        }
        if (self.shade_at..self.shade_at + 3 * n).contains(&k) {
            return Some((k - self.shade_at) / 3);
        }
        if self.tone_free && (self.tone_at..self.tone_at + n).contains(&k) {
            return Some(k - self.tone_at);
        }
        (0..n).find(|&v| self.noise_at[v] == Some(k))
    }

    pub(super) fn camera_view(&self, k: usize) -> Option<usize> {
        if let Some(v) = (0..self.n_views).find(|&v| self.pose_at[v].is_some_and(|i| (i..i + POSE_PARAMS).contains(&k)))
        {
            return Some(v);
        }
        if self.reg {
            let b = self.n_tool + 1 + 2 * self.n_views;
            if (b..b + 2 * self.n_views).contains(&k) {
                return Some((k - b) / 2);
            }
        }
        None
    }

    /// The log scale of view v's sensor noise against the one measured (0 without noise).
    pub(super) fn ln_noise(&self, x: &[f64], v: usize) -> f64 {
        self.noise_at.get(v).copied().flatten().map_or(0.0, |i| x[i])
    }

    /// The shading terms (gx, gy, q) of view v.
    pub(super) fn shade(&self, x: &[f64], v: usize) -> [f64; 3] {
        let b = self.shade_at + 3 * v;
        [x[b], x[b + 1], x[b + 2]]
    }

    /// The camera correction of view v: eye (x, y, z in mm), turn about its axis (degrees) and
    /// log field of view (zero when its camera is not fitted).
    pub(super) fn pose(&self, x: &[f64], v: usize) -> [f64; POSE_PARAMS] {
        match self.pose_at[v] {
            Some(i) => std::array::from_fn(|k| x[i + k]),
            None => [0.0; POSE_PARAMS],
        }
    }

    /// Shapes tried at the start: V angles with narrow and wide tip flats (from 5 um, a V-bit
    /// with a 40 um flat was started at 5 and ended in another offset interval with its flat at
    /// 0), ball radii.
    pub(super) fn shapes(&self) -> Vec<Shape> {
        match self.kind {
            Kind::VBit => [0.005, 0.03]
                .iter()
                .flat_map(|&f| [35.0, 60.0, 85.0, 110.0].map(|a| (a, f)))
                .collect(),
            Kind::Ball | Kind::TaperedBall => [0.02, 0.04, 0.08, 0.16, 0.32, 0.64].map(|r| (r, 0.0)).to_vec(),
            Kind::Profile => vec![(0.0, 0.0)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::card::{Card, CardSpec};

    /// Every per-photo camera-model term (and nothing else) is found with its photo, whatever
    /// the kind and the optional terms: the index of each agrees with the view its name gives.
    #[test]
    fn each_photo_term_names_its_photo() {
        let card = Card::new(&CardSpec::default());
        for kind in [Kind::VBit, Kind::Ball, Kind::TaperedBall, Kind::Profile] {
            for (reg, tone) in [(false, false), (true, true)] {
                let lay = Layout::new(kind, &card, 3, reg, &[true, false, true], &[false, true, true], tone);
                let mut seen = 0;
                for (k, q) in lay.params.iter().enumerate() {
                    let per_photo = ["ln_exposure[", "blur_px[", "shade[", "ln_noise[", "tone["];
                    let named = per_photo.iter().any(|p| q.name.starts_with(p)).then(|| {
                        q.name
                            .split_once('[')
                            .unwrap()
                            .1
                            .split_once(']')
                            .unwrap()
                            .0
                            .parse::<usize>()
                            .unwrap()
                    });
                    assert_eq!(lay.photo_term(k), named, "{kind:?} {}", q.name);
                    seen += usize::from(named.is_some());
                }
                // Exposure, blur and 3 shading terms each, 2 noise scales, the tone curves.
                assert_eq!(seen, 3 * 5 + 2 + if tone { 3 } else { 0 }, "{kind:?}");
            }
        }
    }
}
