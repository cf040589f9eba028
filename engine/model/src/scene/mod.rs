//! Scene types and the scene file (MODEL.md section 6).
//!
//! A scene file is JSON; unknown fields are allowed (the engine may read more than these).
//! `scratches` is either a CSV path relative to the scene file (header `x0,y0,x1,y1,w,d,alpha`)
//! or an inline array of 7-number rows. Everything read is validated; every error names the file,
//! the place (field, or CSV data row and line) and what to fix.
//!
//! - this file: the types ([`Scene`], [`View`], [`Scratch`], ...) and [`SceneError`];
//! - `read.rs`: [`Scene::load`] and [`Scene::from_json_str`] (JSON parsing);
//! - `validate.rs`: the checks of MODEL.md sections 2, 4 and 6 ([`Scene::validate`],
//!   [`camera_sees_plate`]), shared by the reader;
//! - `csv.rs`: the scratch CSV reader ([`read_scratches_csv`]) and writer;
//! - `write.rs`: [`Scene::save`] and [`Scene::to_json_inline`].

use std::path::PathBuf;

mod csv;
mod read;
pub use read::unknown_key_warnings;
mod validate;
mod write;

pub use csv::{read_scratches_csv, read_scratches_csv_lines, read_scratches_csv_table, Extra};
pub use validate::camera_sees_plate;

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

impl Scene {
    /// The lamps a maker sets up: one per distinct light of the views (its kind, place and
    /// intensity), in view order, each named after the first view it lights, with its kind and
    /// intensity. The set-up sheet and the viewer's overlay both list these.
    pub fn lamps(&self) -> Vec<(String, LightKind, f64)> {
        let mut lamps: Vec<(String, LightKind, f64)> = Vec::new();
        for v in &self.views {
            if !lamps
                .iter()
                .any(|(_, k, i)| *k == v.light.kind && *i == v.light.intensity)
            {
                lamps.push((v.name.clone(), v.light.kind.clone(), v.light.intensity));
            }
        }
        lamps
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

fn norm3(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
