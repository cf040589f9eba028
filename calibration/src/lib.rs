//! Carving-tool calibration (see calibration/README.md):
//!
//! - [`card`]: the calibration card: a ladder of commanded depths straddling the plate surface,
//!   each at several orientations and repeated, corner fiducials, and the capture set-up (camera
//!   and lamp places) as MODEL.md views. `card.json` is a MODEL.md scene (a bare plate) with the
//!   card's own fields under `card`.
//! - [`simulate`]: the card as a given tool would cut it, rendered by the engine from each
//!   capture view as the photos a camera would take (with optional noise, exposure and blur).
//!
//! - [`register`]: photos (PNG/JPEG, EXIF orientation, any size) registered to the capture views
//!   by the card's corner crosses.
//! - [`fit`]: the tool's parameters, z offset, wall roughness, exposures and blur fitted to the
//!   registered photos by rendering the card with the engine; [`fit_cmd`] is `scratchart-cal fit`.
pub mod card;
pub mod fiducials;
pub mod fit;
pub mod fit_cmd;
pub mod photo;
pub mod register;
pub mod simulate;
