//! Writing a scene: JSON with the scratches inline, or JSON plus a scratch CSV, both through the
//! atomic writer. Numbers are written in shortest round-trip form, so reading gives back exactly
//! the scene that was written.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::csv::{scratches_csv_text, Extra};
use crate::scene::{LightKind, Plate, Scene, SceneError};
use crate::surface::PlateShape;

impl Scene {
    fn to_value(&self, scratches: Value) -> Value {
        let views: Vec<Value> = self
            .views
            .iter()
            .map(|v| {
                let c = &v.camera;
                let light = match v.light.kind {
                    LightKind::Point { position } => json!({
                        "kind": "point", "position": position, "intensity": v.light.intensity }),
                    LightKind::Directional { direction } => json!({
                        "kind": "directional", "direction": direction, "intensity": v.light.intensity }),
                };
                let mut o = json!({
                    "name": v.name,
                    "camera": {
                        "eye": c.eye, "target": c.target, "up": c.up,
                        "fov_y_deg": c.fov_y_deg, "width": c.width, "height": c.height
                    },
                    "light": light
                });
                // engine/docs/model.md's view has no exposure: written only where it is not 1.
                if v.exposure != 1.0 {
                    o["exposure"] = json!(v.exposure);
                }
                o
            })
            .collect();
        let plate = self.plate.to_value();
        json!({
            "plate": plate,
            "views": views,
            "scratches": scratches
        })
    }

    /// The scene as JSON with the scratches inline (numbers round-trip exactly).
    pub fn to_json_inline(&self) -> String {
        let rows: Vec<Value> = self
            .scratches
            .iter()
            .map(|s| {
                let r = s.to_row();
                if s.is_arc() {
                    json!([r[0], r[1], r[2], r[3], r[4], r[5], r[6], s.bulge])
                } else {
                    json!(r)
                }
            })
            .collect();
        serde_json::to_string_pretty(&self.to_value(Value::Array(rows))).expect("serialize scene")
    }

    /// Write the scene as `json_path` plus the CSV `csv_name` (relative to the JSON's directory),
    /// both atomically; the CSV first, so the JSON never points to a missing or partial CSV.
    /// Numbers are written in shortest round-trip form, so `load` gives back exactly `self`.
    pub fn save(&self, json_path: &Path, csv_name: &str) -> Result<(), SceneError> {
        self.save_extra(json_path, csv_name, &Extra::default())
    }

    /// As [`Scene::save`], with extra named CSV columns after the seven (one row per scratch).
    pub fn save_extra(&self, json_path: &Path, csv_name: &str, extra: &Extra) -> Result<(), SceneError> {
        assert!(
            extra.names.is_empty() || extra.rows.len() == self.scratches.len(),
            "extra columns: {} rows for {} scratches",
            extra.rows.len(),
            self.scratches.len()
        );
        let dir = match json_path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let csv = scratches_csv_text(&self.scratches, extra);
        crate::fsio::write_atomic(&dir.join(csv_name), csv.as_bytes())?;
        let mut text =
            serde_json::to_string_pretty(&self.to_value(Value::String(csv_name.to_string()))).expect("serialize scene");
        text.push('\n');
        crate::fsio::write_atomic(json_path, text.as_bytes())?;
        Ok(())
    }
}

impl Plate {
    /// The scene file's `plate` object (`shape` only where the plate is bent: engine/docs/model.md's
    /// plate has none).
    pub fn to_value(&self) -> Value {
        let mut plate = json!({
            "size_mm": self.size_mm,
            "roughness": self.roughness,
            "f0": self.f0
        });
        // engine/docs/model.md's plate has no shape: written only where it is not flat.
        if let PlateShape::Cylinder {
            radius_mm,
            axis,
            convex,
        } = self.shape
        {
            plate["shape"] = json!({"kind": "cylinder", "radius_mm": radius_mm, "axis": axis.name(), "convex": convex});
        }
        plate
    }
}
