//! How a photo's pixels encode light, in one place for the whole photo pipeline (`simulate`
//! and the study's phone, shrinking a photo in linear light, the fit's model of the sensor and
//! its noise, the white balance, the registration's shrink, `inspect`).
//!
//! Today that is the engine's display curve, L^(1/2.2) (engine/docs/model.md section 5), and
//! every figure of calibration/docs/fit.md was measured with it. Phones and cameras write the
//! sRGB curve (IEC 61966-2-1), which agrees with it in the mid-tones but is linear near black
//! (12.92 L below L = 0.0031308), where a dark-field card's plate and the faint glint of its
//! shallow rungs sit. Measured (calibration/docs/fit.md, "The photo's encoding"): a V60 card
//! photographed as an sRGB camera encodes it is refused (a residual 10 times the noise, or
//! nothing identified), never written; with sRGB in the simulator and the fit alike the fits
//! end in the wrong z offset interval, and noiseless photos leave a valley along sRGB's coarse
//! steps near black, though the information analysis (`examples/capture_info` with `srgb`) says
//! noisy photos hold the tool. [`Encoding::Srgb`] is that curve, used by the analysis ([`set`],
//! or `SCRATCHART_PHOTO_ENCODING=srgb` for a whole run); switching the pipeline to it waits on
//! those two.

use std::sync::atomic::{AtomicBool, Ordering};

/// A transfer curve from light to the value a photo's pixel holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// The engine's display curve, L^(1/2.2).
    Engine,
    /// sRGB (IEC 61966-2-1): 12.92 L below L = 0.0031308, 1.055 L^(1/2.4) - 0.055 above.
    Srgb,
}

static SRGB: AtomicBool = AtomicBool::new(false);

/// Sets the pipeline's encoding for this process (the analysis of `examples/capture_info`).
pub fn set(e: Encoding) {
    SRGB.store(e == Encoding::Srgb, Ordering::Relaxed);
}

/// The pipeline's encoding now: [`Encoding::Engine`] unless [`set`], or unless the environment
/// variable `SCRATCHART_PHOTO_ENCODING` is `srgb` (for measuring the pipeline on sRGB photos
/// before it switches; calibration/docs/fit.md, "The photo's encoding").
pub fn current() -> Encoding {
    static FROM_ENV: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let env = *FROM_ENV.get_or_init(|| std::env::var("SCRATCHART_PHOTO_ENCODING").is_ok_and(|v| v == "srgb"));
    if env || SRGB.load(Ordering::Relaxed) {
        Encoding::Srgb
    } else {
        Encoding::Engine
    }
}

/// Below this light sRGB is linear.
const LINEAR_BELOW: f64 = 0.003_130_8;
/// Below this encoded value sRGB is linear (12.92 x [`LINEAR_BELOW`]).
const ENCODED_BELOW: f64 = 0.040_45;

/// The encoded value of light `l` in the pipeline's encoding (0 for l <= 0, NaN stays NaN); not
/// clamped at 1.
pub fn encode(l: f64) -> f64 {
    match current() {
        Encoding::Engine => scratchart_model::display::display(l),
        Encoding::Srgb => srgb_encode(l),
    }
}

/// The light of encoded value `d` in the pipeline's encoding (0 for d <= 0 and for NaN).
pub fn decode(d: f64) -> f64 {
    match current() {
        Encoding::Engine => scratchart_model::display::linear(d),
        Encoding::Srgb => srgb_decode(d),
    }
}

/// [`encode`] in f32 (the engine's curve as the engine computes it, to the bit).
pub fn encode_f32(l: f32) -> f32 {
    match current() {
        Encoding::Engine => scratchart_render::io::display_value(l),
        Encoding::Srgb => srgb_encode(l as f64) as f32,
    }
}

/// sRGB's encoded value of light `l` (0 for l <= 0, NaN stays NaN); not clamped at 1.
pub fn srgb_encode(l: f64) -> f64 {
    if l.is_nan() {
        l
    } else if l <= 0.0 {
        0.0
    } else if l <= LINEAR_BELOW {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB's light of encoded value `d` (0 for d <= 0 and for NaN).
pub fn srgb_decode(d: f64) -> f64 {
    if !(d > 0.0) {
        0.0
    } else if d <= ENCODED_BELOW {
        d / 12.92
    } else {
        ((d + 0.055) / 1.055).powf(2.4)
    }
}

/// A photo's encoded value as the engine's display value of the same light: what the closed
/// loop's `inspect` compares its renders with.
pub fn to_display(d: f32) -> f32 {
    match current() {
        Encoding::Engine => d,
        Encoding::Srgb => scratchart_model::display::display(srgb_decode(d as f64)) as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encodes_and_decodes_and_meets_at_the_knee() {
        for l in [1e-5, 0.001, LINEAR_BELOW, 0.004, 0.05, 0.18, 0.5, 1.0] {
            assert!((srgb_decode(srgb_encode(l)) - l).abs() < 1e-12 * l.max(1e-3), "{l}");
        }
        // Continuous at the knee, to the standard's rounding of its constants.
        let below = 12.92 * LINEAR_BELOW;
        let above = 1.055 * LINEAR_BELOW.powf(1.0 / 2.4) - 0.055;
        assert!((below - above).abs() < 1e-6, "{below} {above}");
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-12);
        // 18% light encodes to about 0.46 in both curves, while near black sRGB is far darker
        // than L^(1/2.2): 1e-4 encodes to 0.0013, not 0.015.
        assert!((srgb_encode(0.18) - 0.4614).abs() < 1e-3);
        assert!((scratchart_model::display::display(0.18) - 0.4586).abs() < 1e-3);
        assert!((srgb_encode(1e-4) - 0.001292).abs() < 1e-6);
        assert_eq!(srgb_encode(-1.0), 0.0);
        assert!(srgb_encode(f64::NAN).is_nan());
        assert_eq!(srgb_decode(f64::NAN), 0.0);
    }

    #[test]
    fn the_pipeline_encodes_with_the_engine_curve_unless_set() {
        assert_eq!(current(), Encoding::Engine);
        for l in [0.0, 1e-4, 0.18, 1.0] {
            assert_eq!(encode(l), scratchart_model::display::display(l));
            assert!((decode(encode(l)) - l).abs() < 1e-12);
            assert_eq!(to_display(0.25), 0.25);
        }
    }
}
