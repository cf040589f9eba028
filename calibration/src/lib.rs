//! Carving-tool calibration (see calibration/README.md):
//!
//! - [`card`]: the calibration card: a ladder of commanded depths straddling the plate surface,
//!   each at several orientations and repeated, six fiducial marks, and the capture set-up (camera
//!   and lamp places) as engine/docs/model.md views. `card.json` is a engine/docs/model.md scene (a bare plate) with the
//!   card's own fields under `card`.
//! - [`simulate`]: the card as a given tool would cut it, rendered by the engine from each
//!   capture view as the photos a camera would take (with optional noise, exposure and blur).
//!
//! - [`register`] and [`fiducials`]: photos (PNG/JPEG, EXIF orientation, any size) registered
//!   to the capture views by the card's hatched marks, found robustly with a confidence each.
//! - [`phone`]: photos of the card as a phone takes them (pose, blur, exposure, vignetting,
//!   cast, noise, size, JPEG, EXIF, a covered mark), for the tests and [`study`], the recovery
//!   study of the fit.
//! - [`fit`]: the tool's parameters, z offset, wall roughness, exposures and blur fitted to the
//!   registered photos by rendering the card with the engine; [`fit_cmd`] is `scratchart-cal fit`.
pub mod card;
pub mod encoding;
pub mod exif;
pub mod fiducials;
pub mod fit;
pub mod fit_cmd;
pub mod guide;
pub mod inspect_plate;
pub mod phone;
pub mod photo;
pub mod pose;
pub mod register;
pub mod resampled;
pub mod simulate;
pub mod simulate_plate;
pub mod study;
pub mod touch_up;
