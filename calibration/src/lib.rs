//! Carving-tool calibration (see calibration/README.md):
//!
//! - [`card`]: the calibration card: a ladder of commanded depths straddling the plate surface,
//!   each at several orientations and repeated, corner fiducials, and the capture set-up (camera
//!   and lamp places) as MODEL.md views. `card.json` is a MODEL.md scene (a bare plate) with the
//!   card's own fields under `card`.
//! - [`simulate`]: the card as a given tool would cut it, rendered by the engine from each
//!   capture view as the photos a camera would take (with optional noise, exposure and blur).
//!
//! The fit of a tool to photos (by the engine's differentiable renderer, on the generic optimizer
//! with a tool-profile parameter set) builds on these; it is not built yet.
pub mod card;
pub mod simulate;
