//! The scene file (engine/docs/model.md section 6): reading, validation and writing of the
//! types of `crate::scene`, with the view geometry of `crate::camera` (a view whose camera does
//! not see the plate is refused).
//!
//! A scene file is JSON; unknown fields are allowed (the engine may read more than these).
//! `scratches` is either a CSV path relative to the scene file (header `x0,y0,x1,y1,w,d,alpha`)
//! or an inline array of 7-number rows. Everything read is validated; every error names the file,
//! the place (field, or CSV data row and line) and what to fix.
//!
//! - `read.rs`: `Scene::load` and `Scene::from_json_str` (JSON parsing);
//! - `validate.rs`: the checks of engine/docs/model.md sections 2, 4 and 6 (`Scene::validate`,
//!   [`camera_sees_plate`]), shared by the reader;
//! - `csv.rs`: the scratch CSV reader ([`read_scratches_csv`]) and writer;
//! - `write.rs`: `Scene::save` and `Scene::to_json_inline`.
mod csv;
mod read;
mod validate;
mod write;

pub use csv::{read_scratches_csv, read_scratches_csv_lines, read_scratches_csv_table, Extra};
pub use read::unknown_key_warnings;
pub use validate::{camera_sees_plate, legal_bulge};
