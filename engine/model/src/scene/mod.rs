//! The scene's types (engine/docs/model.md section 6): [`Scene`], [`Plate`], [`View`],
//! [`Camera`], [`Light`], [`Scratch`], and [`SceneError`]. Their geometry is `crate::camera`'s;
//! the scene file (reading, validation, the scratch CSV, writing) is `crate::scene_file`'s,
//! which uses both.

use std::path::PathBuf;

use crate::surface::PlateShape;

/// Default plate roughness alpha_s (engine/docs/model.md section 6).
pub const DEFAULT_ROUGHNESS: f64 = 0.02;
/// Default plate Fresnel f0 (aluminium, engine/docs/model.md section 5).
pub const DEFAULT_F0: f64 = 0.91;
/// The CSV header line.
pub const CSV_HEADER: &str = "x0,y0,x1,y1,w,d,alpha";

#[derive(Clone, Debug, PartialEq)]
pub struct Plate {
    pub size_mm: f64,
    pub roughness: f64,
    pub f0: f64,
    /// Flat, or the sheet bent into a cylinder after carving (engine/docs/model.md section 10).
    pub shape: PlateShape,
}

impl Plate {
    /// A flat plate of side `size_mm` with the default roughness and Fresnel f0.
    pub fn flat(size_mm: f64) -> Plate {
        Plate {
            size_mm,
            roughness: DEFAULT_ROUGHNESS,
            f0: DEFAULT_F0,
            shape: PlateShape::Flat,
        }
    }
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
    /// What the eye's adaptation or a camera's exposure does to this view: a factor on the
    /// radiance it sees (the scene file's optional `exposure`, default 1). Views that share a
    /// lamp share its intensity; their exposures say how bright each looks relative to the
    /// others under that lamp.
    pub exposure: f64,
}

impl View {
    /// The factor the renderer applies to this view's light: intensity times exposure.
    pub fn radiance_scale(&self) -> f64 {
        self.light.intensity * self.exposure
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scratch {
    pub p0: [f64; 2],
    pub p1: [f64; 2],
    pub w: f64,
    pub d: f64,
    pub alpha: f64,
    /// 0 for a straight scratch; else an arc from p0 to p1 with DXF's bulge tan(included angle
    /// / 4), positive counter-clockwise seen from +z (crate::arc, engine/docs/model.md section
    /// 11). Written as the scratch CSV's optional `bulge` column.
    pub bulge: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub plate: Plate,
    pub views: Vec<View>,
    pub scratches: Vec<Scratch>,
}

/// One lamp a maker sets up: the light of one or more views, at one place (within 1 um) or from
/// one direction.
#[derive(Clone, Debug, PartialEq)]
pub struct Lamp {
    /// The first view it lights (names the lamp where there are several).
    pub name: String,
    pub kind: LightKind,
    /// Its intensity: the largest of its views' (one value where the design shares it).
    pub intensity: f64,
    /// The views it lights (indices, in view order).
    pub views: Vec<usize>,
}

/// Whether two lights are one lamp: points within 1 um, or one direction.
pub fn same_lamp(a: &LightKind, b: &LightKind) -> bool {
    match (a, b) {
        (LightKind::Point { position: p }, LightKind::Point { position: q }) => {
            let d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() <= 1e-3
        }
        (LightKind::Directional { direction: p }, LightKind::Directional { direction: q }) => {
            let dot = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
            dot >= 1.0 - 1e-12
        }
        _ => false,
    }
}

impl Scene {
    /// A minimal valid design over a `plate_mm` plate: `scratches` and one view ("v", 8 x 8
    /// pixels) looking down at 45 degrees from three plate widths away, lit by a point lamp
    /// opposite it. What the machine's tools read of a design (plan, export, carve) is the plate
    /// and the scratches; the view makes it a scene file every tool of the project loads.
    pub fn bare(plate_mm: f64, scratches: Vec<Scratch>) -> Scene {
        let r = 3.0 * plate_mm;
        Scene {
            plate: Plate {
                size_mm: plate_mm,
                roughness: DEFAULT_ROUGHNESS,
                f0: DEFAULT_F0,
                shape: Default::default(),
            },
            views: vec![View {
                exposure: 1.0,
                name: "v".into(),
                camera: Camera {
                    eye: [0.0, -r, r],
                    target: [0.0; 3],
                    up: [0.0, 0.0, 1.0],
                    fov_y_deg: 30.0,
                    width: 8,
                    height: 8,
                },
                light: Light {
                    kind: LightKind::Point { position: [0.0, r, r] },
                    intensity: 1.0,
                },
            }],
            scratches,
        }
    }

    /// The lamps a maker sets up: views whose lights stand at one place (within 1 um) or come
    /// from one direction share one lamp, named after the first view it lights. The set-up
    /// sheet, `summary.json` and the viewer's overlay all list these.
    pub fn lamps(&self) -> Vec<Lamp> {
        let mut lamps: Vec<Lamp> = Vec::new();
        for (j, v) in self.views.iter().enumerate() {
            match lamps.iter_mut().find(|l| same_lamp(&l.kind, &v.light.kind)) {
                Some(l) => {
                    l.views.push(j);
                    l.intensity = l.intensity.max(v.light.intensity);
                }
                None => lamps.push(Lamp {
                    name: v.name.clone(),
                    kind: v.light.kind.clone(),
                    intensity: v.light.intensity,
                    views: vec![j],
                }),
            }
        }
        lamps
    }

    /// Each view's brightness relative to the brightest view under the same lamp (its
    /// intensity times exposure over the largest such product of the lamp's views): what the
    /// set-up sheet reports as each view's exposure.
    pub fn relative_brightness(&self) -> Vec<f64> {
        let mut out = vec![1.0; self.views.len()];
        for lamp in self.lamps() {
            let top = lamp
                .views
                .iter()
                .map(|&j| self.views[j].radiance_scale())
                .fold(0.0, f64::max);
            for &j in &lamp.views {
                out[j] = self.views[j].radiance_scale() / top;
            }
        }
        out
    }

    /// Sets every view's light from the radiance scale `r[j]` it renders with (intensity times
    /// exposure, what the optimizer moves per view): views that share a lamp get one intensity.
    /// With `keep_exposures` the exposures stay as they are and the lamp's intensity is the
    /// geometric mean of r / exposure over its views (equal where the optimizer kept them tied);
    /// otherwise the brightest view of each lamp gets exposure 1, the others less.
    pub fn set_radiance(&mut self, r: &[f64], keep_exposures: bool) {
        for lamp in self.lamps() {
            let intensity = if keep_exposures {
                let each: Vec<f64> = lamp.views.iter().map(|&j| r[j] / self.views[j].exposure).collect();
                if each.iter().all(|&x| x == each[0]) {
                    each[0]
                } else {
                    (each.iter().map(|x| x.ln()).sum::<f64>() / each.len() as f64).exp()
                }
            } else {
                lamp.views.iter().map(|&j| r[j]).fold(0.0, f64::max)
            };
            for &j in &lamp.views {
                let v = &mut self.views[j];
                v.light.intensity = intensity;
                if !keep_exposures {
                    v.exposure = r[j] / intensity;
                }
            }
        }
    }
}

/// A scene could not be read, validated or written.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("cannot read {what} `{path}`: {cause} (check that the file exists and is readable)")]
    Read {
        what: &'static str,
        path: PathBuf,
        /// The OS error (part of the message, so not repeated as a source).
        cause: std::io::Error,
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

/// A scene that cannot be read or is not valid is a bad input file; one that cannot be written
/// is a failure of the job.
impl scratchart_exit::ExitClass for SceneError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(match self {
            SceneError::Write(_) => scratchart_exit::Class::Runtime,
            _ => scratchart_exit::Class::Input,
        })
    }
}

pub(crate) fn invalid(file: &str, field: impl Into<String>, msg: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        file: file.to_string(),
        field: field.into(),
        msg: msg.into(),
    }
}

impl Scratch {
    /// Half-width of the carved region, e = (w/2) sqrt(1 - exp(-2d/w)) (engine/docs/model.md section 2),
    /// computed as (w/2) sqrt(-expm1(-2d/w)) so that it stays accurate for d << w.
    pub fn half_width(&self) -> f64 {
        0.5 * self.w * (-(-2.0 * self.d / self.w).exp_m1()).sqrt()
    }

    /// Length l = |p1 - p0| (the chord of an arc: `path_length` is the arc's).
    pub fn length(&self) -> f64 {
        (self.p1[0] - self.p0[0]).hypot(self.p1[1] - self.p0[1])
    }

    /// The row as written in files: [x0, y0, x1, y1, w, d, alpha] (an arc's bulge is the
    /// optional `bulge` column after them).
    pub fn to_row(&self) -> [f64; 7] {
        [
            self.p0[0], self.p0[1], self.p1[0], self.p1[1], self.w, self.d, self.alpha,
        ]
    }

    /// Build a straight scratch from a row [x0, y0, x1, y1, w, d, alpha] (no validation).
    pub fn from_row(r: [f64; 7]) -> Scratch {
        Scratch {
            p0: [r[0], r[1]],
            p1: [r[2], r[3]],
            w: r[4],
            d: r[5],
            alpha: r[6],
            bulge: 0.0,
        }
    }
}

pub(crate) const COLS: [&str; 7] = ["x0", "y0", "x1", "y1", "w", "d", "alpha"];
/// The optional column of an arc's bulge (crate::arc), after the seven.
pub const BULGE_COL: &str = "bulge";

pub(crate) fn norm3(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
