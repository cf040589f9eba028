//! Carving-tool models (`tool.json`): the groove a tool cuts at a commanded depth, and the
//! scratch model's (w, d) that stands for it.
//!
//! A tool cut to commanded depth z reaches the real depth z + `z_offset_mm` below the plate
//! surface (the offset is where commanded zero really is). Its groove has a depth profile D(u)
//! across the cut (`section.rs`): a V-bit of included angle phi with tip flat F, a ball of radius
//! r, a tapered ball (a ball tangent to cone flanks), or a measured free profile of widths W(z).
//!
//! engine/docs/model.md's scratch groove is D_m(u) = d + (w/2) ln(1 - 4u^2/w^2) for |u| <= e, visible width
//! W = 2e = w sqrt(1 - exp(-2d/w)). The map from a tool's cut to (w, d) (`fit.rs`): the model
//! keeps the tool's visible width exactly (so the carved region is the real one), which leaves one
//! free parameter, w, chosen to minimize the squared depth difference integrated across the cut.
//! That makes the normals (set by w) match the tool's walls in the least-squares sense.
//!
//! This crate uses serde only: the engine (`design --tool`), the calibration fit and the machine
//! driver all read `tool.json` through it, and the machine profile (`machine.json`, [`machine`])
//! that `plan` cuts by and `design --machine` designs within.
mod fit;
pub mod machine;
mod section;

pub use fit::{model_of_section, ModelGroove};
pub use section::Section;

use std::path::Path;

use serde::{Deserialize, Serialize};

/// A tool model as `tool.json` stores it (`kind` selects the variant).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Tool {
    /// A V-bit: included angle and the width of its flat tip.
    VBit {
        angle_deg: f64,
        tip_flat_mm: f64,
        z_offset_mm: f64,
    },
    /// A ball-end cutter (vertical flanks above the ball's equator).
    Ball { radius_mm: f64, z_offset_mm: f64 },
    /// A ball tip tangent to a cone of the given included angle.
    TaperedBall {
        radius_mm: f64,
        angle_deg: f64,
        z_offset_mm: f64,
    },
    /// A measured profile: cut width W (mm) at commanded depths z (mm), increasing, and the ratio
    /// of the model's w to W (>= 1; at 1 the groove is as deep as the model allows).
    Profile {
        points: Vec<[f64; 2]>,
        #[serde(rename = "w_over_W")]
        w_over_w: f64,
        z_offset_mm: f64,
    },
}

/// What a calibration fit adds to `tool.json` beside the tool.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fitted {
    /// Roughness of the groove walls (engine/docs/model.md alpha), fitted from the card's photos.
    pub alpha: Option<f64>,
    /// The fit's record: uncertainties, residual, parameters it could not identify.
    pub fit: Option<serde_json::Value>,
}

/// A `tool.json` that cannot be used; the message names the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum ToolError {
    #[error("cannot read tool file `{path}`: {cause}")]
    Read { path: String, cause: std::io::Error },
    #[error("tool file `{path}` is not a valid tool: {msg}")]
    Invalid { path: String, msg: String },
}

/// A tool file that cannot be read or is not a tool: a bad input file.
impl scratchart_exit::ExitClass for ToolError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(scratchart_exit::Class::Input)
    }
}

impl Tool {
    /// The z offset: the real depth of a cut commanded to z is z + offset.
    pub fn z_offset_mm(&self) -> f64 {
        match self {
            Tool::VBit { z_offset_mm, .. }
            | Tool::Ball { z_offset_mm, .. }
            | Tool::TaperedBall { z_offset_mm, .. }
            | Tool::Profile { z_offset_mm, .. } => *z_offset_mm,
        }
    }

    /// Checks the parameters: a message naming the bad one.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} = {v} is not a number"))
            }
        };
        finite("z_offset_mm", self.z_offset_mm())?;
        match self {
            Tool::VBit {
                angle_deg, tip_flat_mm, ..
            } => {
                if !(*angle_deg > 0.0 && *angle_deg < 180.0) {
                    return Err(format!("angle_deg = {angle_deg} must lie between 0 and 180"));
                }
                if !(*tip_flat_mm >= 0.0) {
                    return Err(format!("tip_flat_mm = {tip_flat_mm} must be >= 0"));
                }
            }
            Tool::Ball { radius_mm, .. } => {
                if !(*radius_mm > 0.0) {
                    return Err(format!("radius_mm = {radius_mm} must be > 0"));
                }
            }
            Tool::TaperedBall {
                radius_mm, angle_deg, ..
            } => {
                if !(*radius_mm > 0.0) {
                    return Err(format!("radius_mm = {radius_mm} must be > 0"));
                }
                if !(*angle_deg > 0.0 && *angle_deg < 180.0) {
                    return Err(format!("angle_deg = {angle_deg} must lie between 0 and 180"));
                }
            }
            Tool::Profile { points, w_over_w, .. } => {
                if points.is_empty() {
                    return Err("points: give at least one [z, W] pair".into());
                }
                for (k, p) in points.iter().enumerate() {
                    finite(&format!("points[{k}]"), p[0] + p[1])?;
                    if p[1] < 0.0 {
                        return Err(format!("points[{k}]: width {} must be >= 0", p[1]));
                    }
                    if k > 0 && !(p[0] > points[k - 1][0] && p[1] >= points[k - 1][1]) {
                        return Err(format!(
                            "points[{k}]: depths must increase and widths must not decrease (a monotone profile)"
                        ));
                    }
                }
                if !(*w_over_w >= 1.0 && w_over_w.is_finite()) {
                    return Err(format!(
                        "w_over_W = {w_over_w} must be >= 1 (the model's w is at least its width)"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads and checks a `tool.json` (the calibration's extra keys `alpha` and `fit` are
    /// allowed and skipped; [`Tool::load_fitted`] returns them).
    pub fn load(path: &Path) -> Result<Tool, ToolError> {
        Ok(Tool::load_fitted(path)?.0)
    }

    /// Reads a `tool.json` with what the calibration fit wrote beside the tool: the groove
    /// walls' roughness `alpha` (fabrication mode holds it fixed) and the `fit` record
    /// (uncertainties, residual, what could not be identified).
    pub fn load_fitted(path: &Path) -> Result<(Tool, Fitted), ToolError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|cause| ToolError::Read { path: p.clone(), cause })?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let bad = |msg: String| ToolError::Invalid { path: p.clone(), msg };
        let mut v: serde_json::Value = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        let mut fitted = Fitted::default();
        if let Some(o) = v.as_object_mut() {
            if let Some(a) = o.remove("alpha") {
                let a = a
                    .as_f64()
                    .filter(|a| *a > 0.0 && *a < 1.0)
                    .ok_or_else(|| bad(format!("alpha = {a} must be a number between 0 and 1")))?;
                fitted.alpha = Some(a);
            }
            fitted.fit = o.remove("fit");
        }
        let tool: Tool = serde_json::from_value(v).map_err(|e| bad(e.to_string()))?;
        tool.validate().map_err(bad)?;
        Ok((tool, fitted))
    }

    /// The JSON text of `tool.json` (exact numbers: it reads back equal).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a tool always serializes")
    }

    /// The JSON text of `tool.json` with the fit's extra keys (see [`Tool::load_fitted`]).
    pub fn to_json_fitted(&self, fitted: &Fitted) -> String {
        let mut v = serde_json::to_value(self).expect("a tool always serializes");
        let o = v.as_object_mut().expect("a tool is an object");
        if let Some(a) = fitted.alpha {
            o.insert("alpha".into(), serde_json::json!(a));
        }
        if let Some(f) = &fitted.fit {
            o.insert("fit".into(), f.clone());
        }
        serde_json::to_string_pretty(&v).expect("a tool always serializes")
    }

    /// The tool as a carving found it (`scratchart-cal inspect`): its grooves `width_scale` times
    /// as wide at the same depth, and every cut `dz_mm` deeper (its z offset moved by that much).
    /// The width scale is exact where the tool's shape allows: a V-bit's walls and tip flat (its
    /// half angle's tangent scaled), a measured profile's widths; for a ball, the radius
    /// `width_scale^2` times as large (a shallow cut's width grows as the root of the radius, so
    /// shallow grooves are `width_scale` times as wide, the deepest a little less); a tapered
    /// ball both. Scale 1 and offset 0 give the tool itself.
    pub fn as_carved(&self, width_scale: f64, dz_mm: f64) -> Tool {
        let s = width_scale;
        let angle = |a: f64| {
            if s == 1.0 {
                a
            } else {
                (2.0 * (s * (0.5 * a.to_radians()).tan()).atan()).to_degrees()
            }
        };
        match self {
            Tool::VBit {
                angle_deg,
                tip_flat_mm,
                z_offset_mm,
            } => Tool::VBit {
                angle_deg: angle(*angle_deg),
                tip_flat_mm: s * tip_flat_mm,
                z_offset_mm: z_offset_mm + dz_mm,
            },
            Tool::Ball { radius_mm, z_offset_mm } => Tool::Ball {
                radius_mm: s * s * radius_mm,
                z_offset_mm: z_offset_mm + dz_mm,
            },
            Tool::TaperedBall {
                radius_mm,
                angle_deg,
                z_offset_mm,
            } => Tool::TaperedBall {
                radius_mm: s * s * radius_mm,
                angle_deg: angle(*angle_deg),
                z_offset_mm: z_offset_mm + dz_mm,
            },
            Tool::Profile {
                points,
                w_over_w,
                z_offset_mm,
            } => Tool::Profile {
                // A profile's points are at commanded depths: a cut dz deeper reaches at z what
                // the profile lists at z + dz.
                points: points.iter().map(|p| [p[0] - dz_mm, s * p[1]]).collect(),
                w_over_w: *w_over_w,
                z_offset_mm: z_offset_mm + dz_mm,
            },
        }
    }

    /// The groove cut at commanded depth `z_mm`; `None` when the tool does not reach the plate.
    pub fn section(&self, z_mm: f64) -> Option<Section> {
        Section::of(self, z_mm)
    }

    /// The scratch model's (w, d) for a cut at commanded depth `z_mm` (see the crate doc);
    /// `None` when the tool does not reach the plate.
    pub fn model(&self, z_mm: f64) -> Option<ModelGroove> {
        if let Tool::Profile { w_over_w, .. } = self {
            // A measured profile has widths only: w from the stated ratio, d from the width.
            let width = self.section(z_mm)?.width;
            return Some(fit::model_of_width(width, *w_over_w));
        }
        Some(model_of_section(&self.section(z_mm)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A carving `s` times as wide and `dz` deeper: the V-bit's and profile's grooves exactly,
    /// a ball's shallow ones nearly; scale 1 and offset 0 are the tool itself.
    #[test]
    fn as_carved_widens_and_deepens() {
        let (s, dz) = (1.1, 0.015);
        let width = |t: &Tool, z: f64| t.section(z).map_or(0.0, |c| c.width);
        let v = Tool::VBit {
            angle_deg: 60.0,
            tip_flat_mm: 0.01,
            z_offset_mm: -0.002,
        };
        let p = Tool::Profile {
            points: vec![[0.0, 0.02], [0.05, 0.08], [0.1, 0.12]],
            w_over_w: 1.3,
            z_offset_mm: 0.001,
        };
        for t in [&v, &p] {
            let c = t.as_carved(s, dz);
            for z in [0.01, 0.03, 0.06] {
                let (a, b) = (width(&c, z), s * width(t, z + dz));
                assert!((a - b).abs() < 1e-12 * b.max(1.0), "{t:?} at {z}: {a} vs {b}");
                let (da, db) = (c.section(z).unwrap().depth, t.section(z + dz).unwrap().depth);
                assert!((da - db).abs() < 1e-15, "{da} vs {db}");
            }
            assert_eq!(&t.as_carved(1.0, 0.0), t);
        }
        let b = Tool::Ball {
            radius_mm: 0.1,
            z_offset_mm: 0.0,
        };
        let r = width(&b.as_carved(s, 0.0), 0.002) / width(&b, 0.002);
        assert!((r - s).abs() < 0.01 * s, "{r}");
    }

    #[test]
    fn tool_files_round_trip_and_bad_ones_are_named() {
        let tools = [
            Tool::VBit {
                angle_deg: 60.0,
                tip_flat_mm: 0.02,
                z_offset_mm: -0.003,
            },
            Tool::Ball {
                radius_mm: 0.1,
                z_offset_mm: 0.0,
            },
            Tool::TaperedBall {
                radius_mm: 0.05,
                angle_deg: 30.0,
                z_offset_mm: 0.001,
            },
            Tool::Profile {
                points: vec![[0.01, 0.05], [0.02, 0.08]],
                w_over_w: 1.2,
                z_offset_mm: 0.0,
            },
        ];
        let dir = std::env::temp_dir().join(format!("scratchart-tool-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (k, t) in tools.iter().enumerate() {
            let p = dir.join(format!("t{k}.json"));
            std::fs::write(&p, t.to_json()).unwrap();
            assert_eq!(&Tool::load(&p).unwrap(), t);
        }
        // The issue's own examples read.
        let p = dir.join("v.json");
        std::fs::write(
            &p,
            r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.02, "z_offset_mm": 0.0 }"#,
        )
        .unwrap();
        assert!(matches!(Tool::load(&p).unwrap(), Tool::VBit { .. }));
        std::fs::write(
            &p,
            r#"{ "kind": "profile", "points": [[0.01, 0.05], [0.02, 0.08]], "w_over_W": 1.0, "z_offset_mm": 0.0 }"#,
        )
        .unwrap();
        assert!(matches!(Tool::load(&p).unwrap(), Tool::Profile { .. }));
        // The fit's extra keys read back and do not disturb the tool.
        let fitted = Fitted {
            alpha: Some(0.12),
            fit: Some(serde_json::json!({"uncertainty": {"angle_deg": 0.3}})),
        };
        std::fs::write(&p, tools[0].to_json_fitted(&fitted)).unwrap();
        assert_eq!(Tool::load(&p).unwrap(), tools[0]);
        assert_eq!(Tool::load_fitted(&p).unwrap(), (tools[0].clone(), fitted));
        std::fs::write(
            &p,
            r#"{ "kind": "ball", "radius_mm": 0.1, "z_offset_mm": 0, "alpha": 1.5 }"#,
        )
        .unwrap();
        assert!(Tool::load(&p).unwrap_err().to_string().contains("alpha"));
        for (text, needle) in [
            (
                r#"{ "kind": "v-bit", "angle_deg": 200, "tip_flat_mm": 0, "z_offset_mm": 0 }"#,
                "angle_deg",
            ),
            (r#"{ "kind": "drill", "z_offset_mm": 0 }"#, "drill"),
            (
                r#"{ "kind": "ball", "radius_mm": 0.1, "z_offset_mm": 0, "radus": 2 }"#,
                "radus",
            ),
            (
                r#"{ "kind": "profile", "points": [[0.02, 0.05], [0.01, 0.08]], "w_over_W": 1, "z_offset_mm": 0 }"#,
                "points[1]",
            ),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = Tool::load(&p).unwrap_err().to_string();
            assert!(e.contains("v.json") && e.contains(needle), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
