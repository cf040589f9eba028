//! What the set-up sheet is computed from, written beside the design and read back.
use std::path::Path;

use serde_json::{json, Value};

use scratchart_model::scene::Scene;
use scratchart_observe::Observer;
use scratchart_optim::error::OptimError;
use scratchart_render::Renderer;
/// What the set-up sheet is computed from: each view's target exactly as the design's loss saw
/// it (display values), where its picture is, the blur of the quality measure, and the views left
/// blank on purpose. `design` writes them beside the design ([`SheetInputs::FILE`],
/// `NAME_target.pfm`, `NAME_picture.png`: lossless) and `scratchart setup` reads them back, so the
/// two build the sheet through [`write_setup`] from the same numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct SheetInputs {
    pub targets: Vec<Vec<f32>>,
    pub pictures: Vec<Vec<bool>>,
    pub sigma: f32,
    pub blank_views: Vec<String>,
}

impl SheetInputs {
    /// The index file beside the design.
    pub const FILE: &'static str = "setup_inputs.json";

    /// Writes the inputs into `dir` (atomically, each file).
    pub fn save(&self, dir: &Path, scene: &Scene) -> Result<(), OptimError> {
        let mut views = Vec::new();
        for (j, v) in scene.views.iter().enumerate() {
            let (w, h) = (v.camera.width, v.camera.height);
            let (t, m) = (format!("{}_target.pfm", v.name), format!("{}_picture.png", v.name));
            scratchart_render::io::write_pfm(&dir.join(&t), w, h, &self.targets[j])?;
            let mask: Vec<u8> = self.pictures[j].iter().map(|&p| if p { 255 } else { 0 }).collect();
            scratchart_render::io::write_png_gray(&dir.join(&m), w, h, &mask)?;
            views.push(json!({"name": v.name, "target": t, "picture": m}));
        }
        let index = json!({
            "what": "the set-up sheet's inputs: each view's target as the design's loss saw it (display values, PFM) and its picture's pixels (PNG, white); `scratchart setup` reads them",
            "sigma_px": self.sigma,
            "blank_views": self.blank_views,
            "views": views,
        });
        let text = serde_json::to_string_pretty(&index).expect("the index always serializes");
        Ok(scratchart_render::io::write_atomic(
            &dir.join(Self::FILE),
            text.as_bytes(),
        )?)
    }

    /// The sheet's inputs of a design in `dir` that wrote none: NAME_target.png beside it (else
    /// the design's own render), the whole plate as each picture, the loss's default blur, and
    /// the views its summary.json lists as blank on purpose.
    pub fn approximate(
        renderer: &Renderer,
        scene: &Scene,
        dir: &Path,
        obs: &dyn Observer,
    ) -> Result<SheetInputs, OptimError> {
        let mut gs = renderer.upload(scene)?;
        let frame = renderer.render(&mut gs)?;
        let mut targets = Vec::new();
        for (v, img) in scene.views.iter().zip(&frame.images) {
            let t = dir.join(format!("{}_target.png", v.name));
            let (w, h) = (v.camera.width, v.camera.height);
            let own = || img.iter().map(|&l| scratchart_render::io::display_value(l)).collect();
            let target = match scratchart_render::io::read_image_gray(&t) {
                Ok((tw, th, data)) if (tw, th) == (w, h) => data,
                Ok((tw, th, _)) => {
                    obs.warn(&format!(
                        "{} is {tw}x{th}, the view {w}x{h}: using the design's own render",
                        t.display()
                    ));
                    own()
                }
                Err(_) => own(),
            };
            targets.push(target);
        }
        let pictures: Vec<Vec<bool>> = (0..scene.views.len())
            .map(|v| scratchart_model::camera::on_plate_mask(scene, v))
            .collect();
        // Views the design left blank on purpose, as its summary.json lists them.
        let blank_views: Vec<String> = std::fs::read_to_string(dir.join("summary.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<Value>(&t).ok())
            .and_then(|v| v["blank_views"].as_array().cloned())
            .map(|a| a.iter().filter_map(|x| x.as_str().map(String::from)).collect())
            .unwrap_or_default();
        Ok(SheetInputs {
            targets,
            pictures,
            sigma: scratchart_optim::loss::LossConfig::default().sigma,
            blank_views,
        })
    }

    /// Reads the inputs a design wrote into `dir`; `Ok(None)` when it wrote none (a design made
    /// before they were written).
    pub fn load(dir: &Path, scene: &Scene) -> Result<Option<SheetInputs>, OptimError> {
        let path = dir.join(Self::FILE);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(cause) => {
                return Err(OptimError::Io(scratchart_render::io::IoError::Io {
                    action: "read",
                    path,
                    cause,
                }))
            }
        };
        let bad = |msg: String| {
            OptimError::Io(scratchart_render::io::IoError::Format {
                kind: "set-up inputs",
                path: path.clone(),
                msg,
            })
        };
        let index: Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        let sigma = index["sigma_px"]
            .as_f64()
            .filter(|s| s.is_finite() && *s >= 0.0)
            .ok_or_else(|| bad("`sigma_px` is not a number >= 0".into()))? as f32;
        let blank_views = index["blank_views"]
            .as_array()
            .map(|a| a.iter().filter_map(|x| x.as_str().map(String::from)).collect())
            .unwrap_or_default();
        let listed = index["views"].as_array().cloned().unwrap_or_default();
        let (mut targets, mut pictures) = (Vec::new(), Vec::new());
        for v in &scene.views {
            let entry = listed
                .iter()
                .find(|e| e["name"].as_str() == Some(v.name.as_str()))
                .ok_or_else(|| bad(format!("it lists no view `{}` (the design has it)", v.name)))?;
            let file = |key: &str| {
                entry[key]
                    .as_str()
                    .map(|f| dir.join(f))
                    .ok_or_else(|| bad(format!("view `{}` has no `{key}` file", v.name)))
            };
            let (w, h) = (v.camera.width, v.camera.height);
            let tp = file("target")?;
            let (tw, th, t) = scratchart_render::io::read_pfm(&tp)?;
            let mp = file("picture")?;
            let (mw, mh, m) = scratchart_render::io::read_image_gray(&mp)?;
            if (tw, th) != (w, h) || (mw, mh) != (w, h) {
                return Err(bad(format!(
                    "view `{}` is {w}x{h}, but `{}` is {tw}x{th} and `{}` {mw}x{mh}",
                    v.name,
                    tp.display(),
                    mp.display()
                )));
            }
            targets.push(t);
            pictures.push(m.iter().map(|&x| x > 0.5).collect());
        }
        Ok(Some(SheetInputs {
            targets,
            pictures,
            sigma,
            blank_views,
        }))
    }
}
