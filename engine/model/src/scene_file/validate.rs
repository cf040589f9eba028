//! The checks of a scene against engine/docs/model.md (scratch parameters, plate, cameras, lights, view
//! names): used by the JSON reader, with file and field names in every message, and by
//! [`Scene::validate`] for scenes built in code.

use crate::arc::MAX_BULGE;
use crate::camera::ViewGeom;
use crate::scene::{
    invalid, norm3, LightKind, Plate, Scene, SceneError, Scratch, View, COLS, DEFAULT_F0, DEFAULT_ROUGHNESS,
};
use crate::surface::{PlateShape, MAX_WRAP_RAD};

/// Check one scratch against engine/docs/model.md section 2 and the plate; returns what is wrong.
pub(super) fn check_scratch(s: &Scratch, plate_size: f64) -> Result<(), String> {
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
    check_arc(s, plate_size)
}

/// The bulge of `s` if it is a legal arc on a plate of side `plate_size` (finite, at most
/// [`crate::arc::MAX_BULGE`], a radius no less than w, the whole arc on the plate); otherwise the largest
/// |bulge| of the same sign that is (bisection to 1e-6 of the bulge; 0, straight, is always
/// legal where the endpoints are on the plate). What an optimizer that moved bulges writes.
pub fn legal_bulge(s: &Scratch, plate_size: f64) -> f64 {
    let with = |b: f64| Scratch { bulge: b, ..*s };
    if !s.bulge.is_finite() {
        return 0.0;
    }
    if check_arc(s, plate_size).is_ok() {
        return s.bulge;
    }
    let (mut lo, mut hi) = (0.0f64, s.bulge.abs().min(crate::arc::MAX_BULGE));
    if check_arc(&with(hi.copysign(s.bulge)), plate_size).is_ok() {
        return hi.copysign(s.bulge);
    }
    while hi - lo > 1e-6 * hi.max(1e-3) {
        let mid = 0.5 * (lo + hi);
        if check_arc(&with(mid.copysign(s.bulge)), plate_size).is_ok() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo.copysign(s.bulge)
}

/// An arc's bulge (crate::arc): finite, at most MAX_BULGE, a radius no less than the groove's
/// width, and the whole arc on the plate.
fn check_arc(s: &Scratch, plate_size: f64) -> Result<(), String> {
    if !s.bulge.is_finite() {
        return Err(format!("bulge = {} is not a finite number", s.bulge));
    }
    if s.bulge.abs() > MAX_BULGE {
        return Err(format!(
            "bulge = {} is beyond +-{MAX_BULGE:.4} (an arc of at most 270 degrees); split a longer arc in two",
            s.bulge
        ));
    }
    let Some(a) = s.arc() else { return Ok(()) };
    if a.radius < s.w {
        return Err(format!(
            "the arc's radius {:.4} mm (bulge {}) is under the groove's width w = {} mm: the tool \
             cannot turn that tightly; use a smaller |bulge| or a longer chord",
            a.radius, s.bulge, s.w
        ));
    }
    let half = 0.5 * plate_size;
    let bb = a.band_bbox(0.0);
    if bb[0] < -half || bb[1] < -half || bb[2] > half || bb[3] > half {
        return Err(format!(
            "the arc (bulge {}) runs off the plate: it reaches x {:.3} to {:.3}, y {:.3} to {:.3} mm, \
             and |x| and |y| must be <= {half}; use a smaller |bulge|",
            s.bulge, bb[0], bb[2], bb[1], bb[3]
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
    if let PlateShape::Cylinder { radius_mm, .. } = p.shape {
        let least = p.size_mm / MAX_WRAP_RAD;
        if !(radius_mm.is_finite() && radius_mm >= least) {
            return Err((
                "plate.shape.radius_mm",
                format!(
                    "bend radius {radius_mm} mm is too small for a {} mm sheet: at least {least:.1} mm, \
                     where the sheet spans {:.0} degrees about the axis",
                    p.size_mm,
                    MAX_WRAP_RAD.to_degrees()
                ),
            ));
        }
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
    if !(v.exposure.is_finite() && v.exposure > 0.0) {
        return Err((
            f("exposure"),
            format!(
                "exposure {} must be a finite number > 0 (1: as the lamp gives it)",
                v.exposure
            ),
        ));
    }
    Ok(())
}

/// Whether at least one pixel-centre ray of the view hits the plate square. Samples a grid of
/// up to 64x64 pixel centres, plus the pixels that the plate corners and centre project into.
pub fn camera_sees_plate(view: &View, plate: &Plate) -> bool {
    let g = ViewGeom::of(view, plate);
    let half = 0.5 * plate.size_mm;
    let (w, h) = (view.camera.width, view.camera.height);
    let on = |i: u32, j: u32| -> bool {
        match g.surface_hit(i as f64 + 0.5, j as f64 + 0.5) {
            Some(x) => x.uv[0].abs() <= half && x.uv[1].abs() <= half && !g.hidden(&x),
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
        if let Some((sx, sy)) = g.project(plate.shape.to_world(p)) {
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
pub(super) fn validate_header(plate: &Plate, views: &[View], file: &str) -> Result<(), SceneError> {
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
        if !camera_sees_plate(v, plate) {
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
    /// Validate everything (load does the same checks with file names and CSV rows).
    pub fn validate(&self) -> Result<(), SceneError> {
        validate_header(&self.plate, &self.views, "scene")?;
        for (k, s) in self.scratches.iter().enumerate() {
            check_scratch(s, self.plate.size_mm)
                .map_err(|msg| invalid("scene", format!("scratch {} (1-based)", k + 1), msg))?;
        }
        Ok(())
    }
}
