//! The display curve of engine/docs/model.md section 5, I = L^(1/2.2), written once for the whole project
//! (the engine's images and PNGs, the reference loss, the calibration's photos; the kernels
//! have their own GLSL copy of `GAMMA`).

/// The display curve's exponent: display = linear^(1/GAMMA).
pub const GAMMA: f64 = 2.2;

/// Display value of a linear value L: L^(1/2.2), unclamped; 0 for L <= 0, NaN stays NaN (a bad
/// render shows up downstream).
pub fn display(l: f64) -> f64 {
    if l > 0.0 {
        l.powf(1.0 / GAMMA)
    } else if l.is_nan() {
        l
    } else {
        0.0
    }
}

/// Linear value of a display value d: d^2.2; 0 for d <= 0 and for NaN.
pub fn linear(d: f64) -> f64 {
    if d > 0.0 {
        d.powf(GAMMA)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_and_linear_invert_each_other() {
        for d in [0.001, 0.02, 0.5, 0.93, 1.0] {
            assert!((display(linear(d)) - d).abs() < 1e-12, "{d}");
        }
        assert_eq!(display(-1.0), 0.0);
        assert!(display(f64::NAN).is_nan());
        assert_eq!(linear(f64::NAN), 0.0);
        assert_eq!(display(0.25), 0.25f64.powf(1.0 / 2.2));
    }
}
