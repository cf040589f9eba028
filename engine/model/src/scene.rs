//! Scene types and the scene file (MODEL.md section 6).
//!
//! A scene file is JSON; unknown fields are allowed (the engine may read more than these).
//! `scratches` is either a CSV path relative to the scene file (header `x0,y0,x1,y1,w,d,alpha`)
//! or an inline array of 7-number rows. Everything read is validated; every error names the file,
//! the place (field, or CSV data row and line) and what to fix.

use std::path::{Path, PathBuf};

use serde_json::{json, Map, Value};

use super::camera::ViewGeom;

/// Default plate roughness alpha_s (MODEL.md section 6).
pub const DEFAULT_ROUGHNESS: f64 = 0.02;
/// Default plate Fresnel f0 (aluminium, MODEL.md section 5).
pub const DEFAULT_F0: f64 = 0.91;
/// The CSV header line.
pub const CSV_HEADER: &str = "x0,y0,x1,y1,w,d,alpha";

#[derive(Clone, Debug, PartialEq)]
pub struct Plate {
    pub size_mm: f64,
    pub roughness: f64,
    pub f0: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    pub fov_y_deg: f64,
    pub width: u32,
    pub height: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    Point {
        position: [f64; 3],
    },
    /// `direction`: unit vector towards the light (normalized on reading).
    Directional {
        direction: [f64; 3],
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub kind: LightKind,
    pub intensity: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct View {
    pub name: String,
    pub camera: Camera,
    pub light: Light,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scratch {
    pub p0: [f64; 2],
    pub p1: [f64; 2],
    pub w: f64,
    pub d: f64,
    pub alpha: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub plate: Plate,
    pub views: Vec<View>,
    pub scratches: Vec<Scratch>,
}

/// A scene could not be read, validated or written.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("cannot read {what} `{path}`: {source} (check that the file exists and is readable)")]
    Read {
        what: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write scene: {0}")]
    Write(#[from] crate::fsio::WriteError),
    #[error(
        "`{file}` is not valid JSON: {msg} (line {line}, column {column}); fix the syntax there \
         (note: NaN and Infinity are not JSON numbers, every number must be finite)"
    )]
    Json {
        file: String,
        line: usize,
        column: usize,
        msg: String,
    },
    #[error("`{file}`: {field}: {msg}")]
    Invalid { file: String, field: String, msg: String },
    #[error("`{file}`, scratch data row {row} (line {line}): {msg}")]
    Csv {
        file: String,
        row: usize,
        line: usize,
        msg: String,
    },
}

fn invalid(file: &str, field: impl Into<String>, msg: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        file: file.to_string(),
        field: field.into(),
        msg: msg.into(),
    }
}

impl Scratch {
    /// Half-width of the carved region, e = (w/2) sqrt(1 - exp(-2d/w)) (MODEL.md section 2),
    /// computed as (w/2) sqrt(-expm1(-2d/w)) so that it stays accurate for d << w.
    pub fn half_width(&self) -> f64 {
        0.5 * self.w * (-(-2.0 * self.d / self.w).exp_m1()).sqrt()
    }

    /// Length l = |p1 - p0|.
    pub fn length(&self) -> f64 {
        (self.p1[0] - self.p0[0]).hypot(self.p1[1] - self.p0[1])
    }

    /// The row as written in files: [x0, y0, x1, y1, w, d, alpha].
    pub fn to_row(&self) -> [f64; 7] {
        [
            self.p0[0], self.p0[1], self.p1[0], self.p1[1], self.w, self.d, self.alpha,
        ]
    }

    /// Build from a row [x0, y0, x1, y1, w, d, alpha] (no validation).
    pub fn from_row(r: [f64; 7]) -> Scratch {
        Scratch {
            p0: [r[0], r[1]],
            p1: [r[2], r[3]],
            w: r[4],
            d: r[5],
            alpha: r[6],
        }
    }
}

const COLS: [&str; 7] = ["x0", "y0", "x1", "y1", "w", "d", "alpha"];

/// Check one scratch against MODEL.md section 2 and the plate; returns what is wrong.
fn check_scratch(s: &Scratch, plate_size: f64) -> Result<(), String> {
    for (name, v) in COLS.iter().zip(s.to_row()) {
        if !v.is_finite() {
            return Err(format!("{name} = {v} is not a finite number"));
        }
    }
    if s.w <= 0.0 {
        return Err(format!("width parameter w = {} must be > 0 mm", s.w));
    }
    if s.d <= 0.0 {
        return Err(format!("depth d = {} must be > 0 mm", s.d));
    }
    if !(s.alpha > 0.0 && s.alpha < 1.0) {
        return Err(format!(
            "roughness alpha = {} must lie strictly between 0 and 1 (it is not clamped)",
            s.alpha
        ));
    }
    if !(s.length() > 0.0) {
        return Err(format!(
            "zero-length scratch: p0 = p1 = ({}, {}); give two distinct endpoints or remove the row",
            s.p0[0], s.p0[1]
        ));
    }
    let half = 0.5 * plate_size;
    for (name, p) in [("p0", s.p0), ("p1", s.p1)] {
        if p[0].abs() > half || p[1].abs() > half {
            return Err(format!(
                "endpoint {name} = ({}, {}) is off the plate: |x| and |y| must be <= {half} \
                 (half the plate size {plate_size} mm)",
                p[0], p[1]
            ));
        }
    }
    let e = s.half_width();
    if !(e > 0.0 && e.is_finite()) {
        return Err(format!(
            "carved half-width e = {e} is not positive (w = {}, d = {} underflow); increase d",
            s.w, s.d
        ));
    }
    Ok(())
}

fn check_plate(p: &Plate) -> Result<(), (&'static str, String)> {
    if !(p.size_mm.is_finite() && p.size_mm > 0.0) {
        return Err((
            "plate.size_mm",
            format!("plate size {} must be a finite number > 0 (mm)", p.size_mm),
        ));
    }
    if !(p.roughness.is_finite() && p.roughness > 0.0 && p.roughness < 1.0) {
        return Err((
            "plate.roughness",
            format!(
                "plate roughness {} must lie strictly between 0 and 1 (default {DEFAULT_ROUGHNESS})",
                p.roughness
            ),
        ));
    }
    if !(p.f0.is_finite() && (0.0..=1.0).contains(&p.f0)) {
        return Err((
            "plate.f0",
            format!("Fresnel f0 {} must lie in [0, 1] (default {DEFAULT_F0})", p.f0),
        ));
    }
    Ok(())
}

/// Whether a view name can be used as a file name (NAME.pfm, NAME.png) on common systems.
fn check_view_name(name: &str) -> Result<(), String> {
    if name.is_empty() {
        return Err("view name is empty; give every view a name (used for NAME.pfm / NAME.png)".into());
    }
    if name == "." || name == ".." {
        return Err(format!("view name `{name}` cannot be a file name; choose e.g. `v0`"));
    }
    if name.len() > 200 {
        return Err("view name is longer than 200 bytes; use a shorter name".into());
    }
    if let Some(c) = name
        .chars()
        .find(|c| c.is_control() || matches!(c, '/' | '\\' | ':' | '*' | '?' | '"' | '<' | '>' | '|'))
    {
        return Err(format!(
            "view name `{}` contains {:?}, which cannot appear in a file name; use letters, \
             digits, `-`, `_` or `.`",
            name.escape_debug(),
            c
        ));
    }
    if name.starts_with(char::is_whitespace) || name.ends_with(char::is_whitespace) || name.ends_with('.') {
        return Err(format!(
            "view name `{name}` begins or ends with a space or ends with `.`, which file systems \
             mangle; trim it"
        ));
    }
    Ok(())
}

fn norm3(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn check_view(v: &View) -> Result<(), (String, String)> {
    let name = &v.name;
    let f = |field: &str| field.to_string();
    check_view_name(name).map_err(|m| ("name".to_string(), m))?;
    let c = &v.camera;
    for (field, val) in [("camera.eye", c.eye), ("camera.target", c.target), ("camera.up", c.up)] {
        if val.iter().any(|x| !x.is_finite()) {
            return Err((f(field), format!("{val:?} has a non-finite component")));
        }
    }
    if c.width == 0 || c.height == 0 {
        return Err((
            f("camera.width/height"),
            format!("image size {}x{} must be at least 1x1", c.width, c.height),
        ));
    }
    if !(c.fov_y_deg.is_finite() && c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err((
            f("camera.fov_y_deg"),
            format!(
                "vertical field of view {} must lie strictly between 0 and 180 degrees",
                c.fov_y_deg
            ),
        ));
    }
    let dir = [c.target[0] - c.eye[0], c.target[1] - c.eye[1], c.target[2] - c.eye[2]];
    let dn = norm3(dir);
    if !(dn > 0.0 && dn.is_finite()) {
        return Err((
            f("camera.target"),
            "eye and target coincide; move the target to where the camera looks".into(),
        ));
    }
    let un = norm3(c.up);
    if !(un > 0.0 && un.is_finite()) {
        return Err((f("camera.up"), "up vector is zero; use e.g. [0, 0, 1]".into()));
    }
    let fw = [dir[0] / dn, dir[1] / dn, dir[2] / dn];
    let up = [c.up[0] / un, c.up[1] / un, c.up[2] / un];
    let cross = [
        fw[1] * up[2] - fw[2] * up[1],
        fw[2] * up[0] - fw[0] * up[2],
        fw[0] * up[1] - fw[1] * up[0],
    ];
    if norm3(cross) < 1e-9 {
        return Err((
            f("camera.up"),
            format!(
                "up {:?} is parallel to the viewing direction (target - eye); choose an up vector \
                 across it, e.g. [0, 1, 0] for a camera looking straight down",
                c.up
            ),
        ));
    }
    let l = &v.light;
    match l.kind {
        LightKind::Point { position } => {
            if position.iter().any(|x| !x.is_finite()) {
                return Err((f("light.position"), format!("{position:?} has a non-finite component")));
            }
        }
        LightKind::Directional { direction } => {
            if direction.iter().any(|x| !x.is_finite()) {
                return Err((
                    f("light.direction"),
                    format!("{direction:?} has a non-finite component"),
                ));
            }
            let n = norm3(direction);
            if !(n > 0.0) {
                return Err((
                    f("light.direction"),
                    "direction is zero; give the vector towards the light, e.g. [0, 1, 1]".into(),
                ));
            }
        }
    }
    if !(l.intensity.is_finite() && l.intensity > 0.0) {
        return Err((
            f("light.intensity"),
            format!("light intensity {} must be a finite number > 0", l.intensity),
        ));
    }
    Ok(())
}

/// Whether at least one pixel-centre ray of the view hits the plate square. Samples a grid of
/// up to 64x64 pixel centres, plus the pixels that the plate corners and centre project into.
pub fn camera_sees_plate(view: &View, plate_size: f64) -> bool {
    let g = ViewGeom::new(view);
    let half = 0.5 * plate_size;
    let (w, h) = (view.camera.width, view.camera.height);
    let on = |i: u32, j: u32| -> bool {
        match g.shading_point(i, j) {
            Some(x) => x[0].abs() <= half && x[1].abs() <= half,
            None => false,
        }
    };
    let nx = w.min(64);
    let ny = h.min(64);
    for b in 0..ny {
        let j = ((b as f64 + 0.5) * h as f64 / ny as f64) as u32;
        for a in 0..nx {
            let i = ((a as f64 + 0.5) * w as f64 / nx as f64) as u32;
            if on(i.min(w - 1), j.min(h - 1)) {
                return true;
            }
        }
    }
    // Exact projections of the plate corners (pulled slightly inwards) and centre.
    let pull = 1.0 - 1e-9;
    let pts = [
        [0.0, 0.0],
        [-half * pull, -half * pull],
        [half * pull, -half * pull],
        [half * pull, half * pull],
        [-half * pull, half * pull],
    ];
    for p in pts {
        if let Some((sx, sy)) = g.project([p[0], p[1], 0.0]) {
            if sx >= 0.0 && sy >= 0.0 && sx < w as f64 && sy < h as f64 {
                for (di, dj) in [(0i64, 0i64), (-1, 0), (1, 0), (0, -1), (0, 1)] {
                    let i = sx.floor() as i64 + di;
                    let j = sy.floor() as i64 + dj;
                    if i >= 0 && j >= 0 && i < w as i64 && j < h as i64 && on(i as u32, j as u32) {
                        return true;
                    }
                }
            }
        }
    }
    false
}

/// Validate plate and views (everything but scratches) with errors naming `file`.
fn validate_header(plate: &Plate, views: &[View], file: &str) -> Result<(), SceneError> {
    check_plate(plate).map_err(|(field, msg)| invalid(file, field, msg))?;
    if views.is_empty() {
        return Err(invalid(
            file,
            "views",
            "the scene has no views; add at least one view (camera + light)",
        ));
    }
    let mut seen: Vec<String> = Vec::new();
    for (k, v) in views.iter().enumerate() {
        check_view(v).map_err(|(field, msg)| invalid(file, format!("views[{k}] (`{}`).{field}", v.name), msg))?;
        let low = v.name.to_lowercase();
        if let Some(p) = seen.iter().position(|s| *s == low) {
            return Err(invalid(
                file,
                format!("views[{k}] name"),
                format!(
                    "duplicate view name `{}` (also views[{p}]; names become file names and must \
                     differ, ignoring case); rename one",
                    v.name
                ),
            ));
        }
        seen.push(low);
        if !camera_sees_plate(v, plate.size_mm) {
            return Err(invalid(
                file,
                format!("views[{k}] (`{}`) camera", v.name),
                format!(
                    "the camera does not see the plate (no pixel-centre ray hits the {} mm plate \
                     square); move the target towards the plate centre [0, 0, 0] or the eye \
                     further away / above the plate, or widen fov_y_deg",
                    plate.size_mm
                ),
            ));
        }
    }
    Ok(())
}

impl Scene {
    /// Load and validate a scene file (JSON; scratches inline or in a CSV file next to it).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            what: "scene file",
            path: path.to_path_buf(),
            source,
        })?;
        let base = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Scene::from_json_str(&text, &base, &path.display().to_string())
    }

    /// Parse and validate a scene from JSON text. A scratch CSV path is resolved against
    /// `base_dir`; `source_name` names the JSON text in error messages.
    pub fn from_json_str(text: &str, base_dir: &Path, source_name: &str) -> Result<Scene, SceneError> {
        let file = source_name;
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
                let list = read_scratches_csv_lines(&path)?;
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
                    let arr = r.as_array().filter(|a| a.len() == 7).ok_or_else(|| {
                        invalid(file, &field, format!("must be an array of 7 numbers [{CSV_HEADER}]"))
                    })?;
                    let mut row = [0.0; 7];
                    for (c, x) in arr.iter().enumerate() {
                        row[c] = x
                            .as_f64()
                            .ok_or_else(|| invalid(file, &field, format!("{} = {x} is not a number", COLS[c])))?;
                    }
                    let s = Scratch::from_row(row);
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
        Ok(Scene {
            plate,
            views,
            scratches,
        })
    }

    /// Validate everything (load does the same checks with file names and CSV rows).
    pub fn validate(&self) -> Result<(), SceneError> {
        validate_header(&self.plate, &self.views, "scene")?;
        for (k, s) in self.scratches.iter().enumerate() {
            check_scratch(s, self.plate.size_mm)
                .map_err(|msg| invalid("scene", format!("scratch {} (1-based)", k + 1), msg))?;
        }
        Ok(())
    }

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
                json!({
                    "name": v.name,
                    "camera": {
                        "eye": c.eye, "target": c.target, "up": c.up,
                        "fov_y_deg": c.fov_y_deg, "width": c.width, "height": c.height
                    },
                    "light": light
                })
            })
            .collect();
        json!({
            "plate": {
                "size_mm": self.plate.size_mm,
                "roughness": self.plate.roughness,
                "f0": self.plate.f0
            },
            "views": views,
            "scratches": scratches
        })
    }

    /// The scene as JSON with the scratches inline (numbers round-trip exactly).
    pub fn to_json_inline(&self) -> String {
        let rows: Vec<Value> = self.scratches.iter().map(|s| json!(s.to_row())).collect();
        serde_json::to_string_pretty(&self.to_value(Value::Array(rows))).expect("serialize scene")
    }

    /// Write the scene as `json_path` plus the CSV `csv_name` (relative to the JSON's directory),
    /// both atomically; the CSV first, so the JSON never points to a missing or partial CSV.
    /// Numbers are written in shortest round-trip form, so `load` gives back exactly `self`.
    pub fn save(&self, json_path: &Path, csv_name: &str) -> Result<(), SceneError> {
        let dir = match json_path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let mut csv = String::with_capacity(32 + self.scratches.len() * 80);
        csv.push_str(CSV_HEADER);
        csv.push('\n');
        for s in &self.scratches {
            let r = s.to_row();
            let cells: Vec<String> = r.iter().map(|x| format!("{x}")).collect();
            csv.push_str(&cells.join(","));
            csv.push('\n');
        }
        crate::fsio::write_atomic(&dir.join(csv_name), csv.as_bytes())?;
        let mut text =
            serde_json::to_string_pretty(&self.to_value(Value::String(csv_name.to_string()))).expect("serialize scene");
        text.push('\n');
        crate::fsio::write_atomic(json_path, text.as_bytes())?;
        Ok(())
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
    Ok(View {
        name,
        camera,
        light: Light { kind, intensity },
    })
}

/// Read a scratch CSV (header `x0,y0,x1,y1,w,d,alpha`; blank lines and `#` comments skipped).
/// Checks the syntax and that every number is finite; MODEL.md's range checks against the plate
/// are done by [`Scene::load`] / [`Scene::validate`], which know the plate.
pub fn read_scratches_csv(path: &Path) -> Result<Vec<Scratch>, SceneError> {
    let list = read_scratches_csv_lines(path)?;
    Ok(list.into_iter().map(|(s, _)| s).collect())
}

/// As [`read_scratches_csv`], with each scratch's 1-based line number.
pub fn read_scratches_csv_lines(path: &Path) -> Result<Vec<(Scratch, usize)>, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        what: "scratch CSV file",
        path: path.to_path_buf(),
        source,
    })?;
    let file = path.display().to_string();
    let mut out = Vec::new();
    let mut header_seen = false;
    let mut row = 0usize;
    for (ln, raw) in text.lines().enumerate() {
        let line_no = ln + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(|c| c.trim()).collect();
        let numeric = cells.iter().all(|c| c.parse::<f64>().is_ok());
        if !header_seen && out.is_empty() && !numeric {
            header_seen = true;
            let norm: Vec<String> = cells.iter().map(|c| c.to_ascii_lowercase()).collect();
            if norm != COLS {
                return Err(invalid(
                    &file,
                    format!("header (line {line_no})"),
                    format!("found `{line}`, expected `{CSV_HEADER}`"),
                ));
            }
            continue;
        }
        row += 1;
        let err = |msg: String| SceneError::Csv {
            file: file.clone(),
            row,
            line: line_no,
            msg,
        };
        if cells.len() != 7 {
            return Err(err(format!("found {} columns, expected 7 ({CSV_HEADER})", cells.len())));
        }
        let mut r = [0.0; 7];
        for (c, cell) in cells.iter().enumerate() {
            let x: f64 = cell
                .parse()
                .map_err(|_| err(format!("column {} `{cell}` is not a number", COLS[c])))?;
            if !x.is_finite() {
                return Err(err(format!(
                    "column {} `{cell}` is not a finite number (NaN and infinity are not allowed)",
                    COLS[c]
                )));
            }
            r[c] = x;
        }
        out.push((Scratch::from_row(r), line_no));
    }
    Ok(out)
}
