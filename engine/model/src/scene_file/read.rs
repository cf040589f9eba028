//! Reading a scene file: JSON parsing into the types of this module, then validation
//! (`validate.rs`); scratches inline or from a CSV file (`csv.rs`).

use std::path::{Path, PathBuf};

use serde_json::{Map, Value};

use super::csv::{read_scratches_csv_table, Extra};
use super::validate::{check_scratch, validate_header};
use crate::scene::{
    invalid, norm3, Camera, Light, LightKind, Plate, Scene, SceneError, Scratch, View, BULGE_COL, COLS, CSV_HEADER,
    DEFAULT_F0, DEFAULT_ROUGHNESS,
};
use crate::surface::{BendAxis, PlateShape};

/// The keys the reader knows, per object. Keys elsewhere get a warning naming the closest known
/// key (a typo such as `roughnes` would otherwise be ignored silently). `card` and `setup` are
/// reserved for the project's own extensions (calibration cards, set-up data); a view's `target`
/// names its target image (read by the viewer).
const TOP_KEYS: &[&str] = &["plate", "views", "scratches", "card", "setup"];
const PLATE_KEYS: &[&str] = &["size_mm", "roughness", "f0", "shape"];
const SHAPE_KEYS: &[&str] = &["kind", "radius_mm", "axis", "convex"];
const VIEW_KEYS: &[&str] = &["name", "camera", "light", "target", "exposure"];
const CAMERA_KEYS: &[&str] = &["eye", "target", "up", "fov_y_deg", "width", "height"];
const LIGHT_KEYS: &[&str] = &["kind", "position", "direction", "intensity"];

/// Levenshtein distance (for "did you mean").
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + (ca != *cb) as usize).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// How far a key is from a known one: edit distance, ignoring case and underscores, where a
/// prefix of the known key counts almost as a match (`fovy` is closest to `fov_y_deg`).
fn key_distance(key: &str, known: &str) -> usize {
    let norm = |s: &str| s.to_lowercase().replace('_', "");
    let (a, b) = (norm(key), norm(known));
    let prefix: String = b.chars().take(a.chars().count()).collect();
    edit_distance(&a, &b).min(edit_distance(&a, &prefix) + 1)
}

fn check_keys(o: &Map<String, Value>, known: &[&str], place: &str, file: &str, out: &mut Vec<String>) {
    for key in o.keys() {
        if known.contains(&key.as_str()) {
            continue;
        }
        let closest = known.iter().min_by_key(|k| key_distance(key, k)).copied().unwrap_or("");
        out.push(format!(
            "`{file}`: unknown key `{key}` in {place} is ignored (the closest known key is `{closest}`)"
        ));
    }
}

/// Warnings for keys of a scene document that the reader does not know.
pub fn unknown_key_warnings(root: &Value, file: &str) -> Vec<String> {
    let mut out = Vec::new();
    let Some(o) = root.as_object() else { return out };
    check_keys(o, TOP_KEYS, "the top level", file, &mut out);
    if let Some(p) = o.get("plate").and_then(|p| p.as_object()) {
        check_keys(p, PLATE_KEYS, "plate", file, &mut out);
        if let Some(sh) = p.get("shape").and_then(|s| s.as_object()) {
            check_keys(sh, SHAPE_KEYS, "plate.shape", file, &mut out);
        }
    }
    if let Some(views) = o.get("views").and_then(|v| v.as_array()) {
        for (k, v) in views.iter().enumerate() {
            let Some(vo) = v.as_object() else { continue };
            check_keys(vo, VIEW_KEYS, &format!("views[{k}]"), file, &mut out);
            if let Some(c) = vo.get("camera").and_then(|c| c.as_object()) {
                check_keys(c, CAMERA_KEYS, &format!("views[{k}].camera"), file, &mut out);
            }
            if let Some(l) = vo.get("light").and_then(|l| l.as_object()) {
                check_keys(l, LIGHT_KEYS, &format!("views[{k}].light"), file, &mut out);
            }
        }
    }
    out
}

impl Scene {
    /// [`Scene::load`], also returning warnings about what the file holds but the reader does not
    /// know (misspelt keys). Binaries print them.
    pub fn load_with_warnings(path: &Path) -> Result<(Scene, Vec<String>), SceneError> {
        let scene = Scene::load(path)?;
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let warnings = serde_json::from_str::<Value>(&text)
            .map(|root| unknown_key_warnings(&root, &path.display().to_string()))
            .unwrap_or_default();
        Ok((scene, warnings))
    }

    /// Load and validate a scene file (JSON; scratches inline or in a CSV file next to it).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Ok(Scene::load_extra(path)?.0)
    }

    /// [`Scene::load`], also returning the scratch CSV's extra named columns (such as `z_mm`);
    /// empty for inline scratches or a CSV with only the seven.
    pub fn load_extra(path: &Path) -> Result<(Scene, Extra), SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            what: "scene file",
            path: path.to_path_buf(),
            cause: source,
        })?;
        let base = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Scene::from_json_str_extra(&text, &base, &path.display().to_string())
    }

    /// Parse and validate a scene from JSON text. A scratch CSV path is resolved against
    /// `base_dir`; `source_name` names the JSON text in error messages.
    pub fn from_json_str(text: &str, base_dir: &Path, source_name: &str) -> Result<Scene, SceneError> {
        Ok(Scene::from_json_str_extra(text, base_dir, source_name)?.0)
    }

    /// As [`Scene::from_json_str`], also returning the scratch CSV's extra named columns.
    pub fn from_json_str_extra(text: &str, base_dir: &Path, source_name: &str) -> Result<(Scene, Extra), SceneError> {
        let mut extra = Extra::default();
        let file = source_name;
        // (a spreadsheet or editor may put a UTF-8 byte-order mark first)
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let root: Value = serde_json::from_str(text).map_err(|e| SceneError::Json {
            file: file.to_string(),
            line: e.line(),
            column: e.column(),
            msg: e.to_string(),
        })?;
        let root = root
            .as_object()
            .ok_or_else(|| invalid(file, "top level", "must be a JSON object with plate, views, scratches"))?;

        // Plate.
        let pv = root
            .get("plate")
            .ok_or_else(|| invalid(file, "plate", "missing; add \"plate\": {\"size_mm\": 100.0}"))?;
        let po = pv
            .as_object()
            .ok_or_else(|| invalid(file, "plate", "must be an object"))?;
        let plate = Plate {
            size_mm: req_num(po, "size_mm", "plate", file)?,
            roughness: opt_num(po, "roughness", "plate", file)?.unwrap_or(DEFAULT_ROUGHNESS),
            f0: opt_num(po, "f0", "plate", file)?.unwrap_or(DEFAULT_F0),
            shape: parse_shape(po.get("shape"), file)?,
        };

        // Views.
        let vv = root
            .get("views")
            .ok_or_else(|| invalid(file, "views", "missing; add a \"views\" array"))?;
        let va = vv
            .as_array()
            .ok_or_else(|| invalid(file, "views", "must be an array of views"))?;
        let mut views = Vec::with_capacity(va.len());
        for (k, v) in va.iter().enumerate() {
            views.push(parse_view(v, k, file)?);
        }
        validate_header(&plate, &views, file)?;

        // Scratches.
        let sv = root.get("scratches").ok_or_else(|| {
            invalid(
                file,
                "scratches",
                "missing; give a CSV path (\"scratches.csv\") or an inline array ([] for a bare plate)",
            )
        })?;
        let scratches = match sv {
            Value::String(rel) => {
                let path = base_dir.join(rel);
                let (list, ex) = read_scratches_csv_table(&path)?;
                extra = ex;
                let csv_name = path.display().to_string();
                for (k, (s, line)) in list.iter().enumerate() {
                    check_scratch(s, plate.size_mm).map_err(|msg| SceneError::Csv {
                        file: csv_name.clone(),
                        row: k + 1,
                        line: *line,
                        msg,
                    })?;
                }
                list.into_iter().map(|(s, _)| s).collect()
            }
            Value::Array(rows) => {
                let mut out = Vec::with_capacity(rows.len());
                for (k, r) in rows.iter().enumerate() {
                    let field = format!("scratches row {} (1-based)", k + 1);
                    let arr = r.as_array().filter(|a| a.len() == 7 || a.len() == 8).ok_or_else(|| {
                        invalid(
                            file,
                            &field,
                            format!("must be an array of 7 numbers [{CSV_HEADER}], or 8 with an arc's bulge last"),
                        )
                    })?;
                    let mut row = [0.0; 8];
                    for (c, x) in arr.iter().enumerate() {
                        let name = COLS.get(c).copied().unwrap_or(BULGE_COL);
                        row[c] = x
                            .as_f64()
                            .ok_or_else(|| invalid(file, &field, format!("{name} = {x} is not a number")))?;
                    }
                    let mut s = Scratch::from_row([row[0], row[1], row[2], row[3], row[4], row[5], row[6]]);
                    s.bulge = row[7];
                    check_scratch(&s, plate.size_mm).map_err(|msg| invalid(file, &field, msg))?;
                    out.push(s);
                }
                out
            }
            _ => {
                return Err(invalid(
                    file,
                    "scratches",
                    "must be a CSV path string or an array of [x0, y0, x1, y1, w, d, alpha] rows",
                ))
            }
        };
        Ok((
            Scene {
                plate,
                views,
                scratches,
            },
            extra,
        ))
    }
}

/// `plate.shape` (engine/docs/model.md section 10): absent or `{"kind": "flat"}`, or
/// `{"kind": "cylinder", "radius_mm": R, "axis": "x" | "y", "convex": true | false}` (the axis
/// defaults to "y", convex to true).
fn parse_shape(v: Option<&Value>, file: &str) -> Result<PlateShape, SceneError> {
    let Some(v) = v.filter(|v| !v.is_null()) else {
        return Ok(PlateShape::Flat);
    };
    let o = v.as_object().ok_or_else(|| {
        invalid(
            file,
            "plate.shape",
            format!("`{v}` must be an object such as {{\"kind\": \"cylinder\", \"radius_mm\": 80, \"axis\": \"y\"}}"),
        )
    })?;
    let kind = o.get("kind").and_then(|k| k.as_str()).unwrap_or("");
    match kind {
        "flat" => Ok(PlateShape::Flat),
        "cylinder" => {
            let radius_mm = req_num(o, "radius_mm", "plate.shape", file)?;
            let axis = match o.get("axis") {
                None | Some(Value::Null) => BendAxis::Y,
                Some(a) => match a.as_str() {
                    Some("x") => BendAxis::X,
                    Some("y") => BendAxis::Y,
                    _ => {
                        return Err(invalid(
                            file,
                            "plate.shape.axis",
                            format!("`{a}` must be \"x\" or \"y\" (the sheet's axis the bend runs along)"),
                        ))
                    }
                },
            };
            let convex = match o.get("convex") {
                None | Some(Value::Null) => true,
                Some(c) => c
                    .as_bool()
                    .ok_or_else(|| invalid(file, "plate.shape.convex", format!("`{c}` must be true or false")))?,
            };
            Ok(PlateShape::Cylinder {
                radius_mm,
                axis,
                convex,
            })
        }
        _ => Err(invalid(
            file,
            "plate.shape.kind",
            format!(
                "`{}` is not a plate shape: use \"flat\" or \"cylinder\"",
                o.get("kind").map_or("(missing)".to_string(), |k| k.to_string())
            ),
        )),
    }
}

fn req_num(o: &Map<String, Value>, key: &str, ctx: &str, file: &str) -> Result<f64, SceneError> {
    opt_num(o, key, ctx, file)?.ok_or_else(|| invalid(file, format!("{ctx}.{key}"), "missing; this number is required"))
}

fn opt_num(o: &Map<String, Value>, key: &str, ctx: &str, file: &str) -> Result<Option<f64>, SceneError> {
    match o.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_f64()
            .filter(|x| x.is_finite())
            .map(Some)
            .ok_or_else(|| invalid(file, format!("{ctx}.{key}"), format!("`{v}` is not a finite number"))),
    }
}

fn vec3(o: &Map<String, Value>, key: &str, ctx: &str, file: &str) -> Result<[f64; 3], SceneError> {
    let field = format!("{ctx}.{key}");
    let v = o
        .get(key)
        .ok_or_else(|| invalid(file, &field, "missing; give an array of 3 numbers [x, y, z]"))?;
    let a = v
        .as_array()
        .filter(|a| a.len() == 3)
        .ok_or_else(|| invalid(file, &field, format!("`{v}` must be an array of 3 numbers [x, y, z]")))?;
    let mut out = [0.0; 3];
    for (k, x) in a.iter().enumerate() {
        out[k] = x
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| invalid(file, &field, format!("component {k} `{x}` is not a finite number")))?;
    }
    Ok(out)
}

fn dim(o: &Map<String, Value>, key: &str, ctx: &str, file: &str) -> Result<u32, SceneError> {
    let field = format!("{ctx}.{key}");
    let v = o
        .get(key)
        .ok_or_else(|| invalid(file, &field, "missing; give the image size in pixels"))?;
    let x = v
        .as_f64()
        .ok_or_else(|| invalid(file, &field, format!("`{v}` is not a number")))?;
    if x.fract() != 0.0 || x < 0.0 || x > u32::MAX as f64 {
        return Err(invalid(file, &field, format!("`{v}` must be a whole number of pixels")));
    }
    if x == 0.0 {
        return Err(invalid(file, &field, "image size 0; must be at least 1 pixel"));
    }
    Ok(x as u32)
}

fn parse_view(v: &Value, k: usize, file: &str) -> Result<View, SceneError> {
    let ctx = format!("views[{k}]");
    let o = v
        .as_object()
        .ok_or_else(|| invalid(file, &ctx, "must be an object with name, camera, light"))?;
    let name = match o.get("name") {
        Some(Value::String(s)) => s.clone(),
        Some(other) => {
            return Err(invalid(
                file,
                format!("{ctx}.name"),
                format!("`{other}` must be a string"),
            ))
        }
        None => return Err(invalid(file, format!("{ctx}.name"), "missing; give the view a name")),
    };
    let ctx = format!("views[{k}] (`{name}`)");
    let cam_ctx = format!("{ctx}.camera");
    let co = o
        .get("camera")
        .and_then(|c| c.as_object())
        .ok_or_else(|| invalid(file, &cam_ctx, "missing or not an object"))?;
    let camera = Camera {
        eye: vec3(co, "eye", &cam_ctx, file)?,
        target: vec3(co, "target", &cam_ctx, file)?,
        up: vec3(co, "up", &cam_ctx, file)?,
        fov_y_deg: req_num(co, "fov_y_deg", &cam_ctx, file)?,
        width: dim(co, "width", &cam_ctx, file)?,
        height: dim(co, "height", &cam_ctx, file)?,
    };
    let light_ctx = format!("{ctx}.light");
    let lo = o
        .get("light")
        .and_then(|c| c.as_object())
        .ok_or_else(|| invalid(file, &light_ctx, "missing or not an object"))?;
    let kind = match lo.get("kind") {
        Some(Value::String(s)) if s == "point" => LightKind::Point {
            position: vec3(lo, "position", &light_ctx, file)?,
        },
        Some(Value::String(s)) if s == "directional" => {
            let d = vec3(lo, "direction", &light_ctx, file)?;
            let n = norm3(d);
            if !(n > 0.0) {
                return Err(invalid(
                    file,
                    format!("{light_ctx}.direction"),
                    "direction is zero; give the vector towards the light, e.g. [0, 1, 1]",
                ));
            }
            // Normalize; a vector already unit to rounding is kept bit-exact so that
            // save/load round-trips exactly.
            let direction = if (n - 1.0).abs() <= 4.0 * f64::EPSILON {
                d
            } else {
                [d[0] / n, d[1] / n, d[2] / n]
            };
            LightKind::Directional { direction }
        }
        Some(other) => {
            return Err(invalid(
                file,
                format!("{light_ctx}.kind"),
                format!(
                    "unknown light kind {other}; use \"point\" (with position) or \"directional\" (with direction)"
                ),
            ))
        }
        None => {
            return Err(invalid(
                file,
                format!("{light_ctx}.kind"),
                "missing; use \"point\" (with position) or \"directional\" (with direction)",
            ))
        }
    };
    let intensity = req_num(lo, "intensity", &light_ctx, file)?;
    let exposure = opt_num(o, "exposure", &ctx, file)?.unwrap_or(1.0);
    Ok(View {
        exposure,
        name,
        camera,
        light: Light { kind, intensity },
    })
}
