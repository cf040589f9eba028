//! Carving-tool calibration and machine driver (not built yet; see calibration/README.md).
