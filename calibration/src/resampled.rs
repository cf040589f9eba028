//! Whether a photo was enlarged after it was taken (an app, a messenger, a digital zoom): an
//! enlarged photo's pixels between the original ones are interpolated with weights that repeat
//! every k pixels (k the factor), so how sharply each pixel differs from its neighbours (the
//! second difference) rises and falls with period k across the photo. A photo as the camera
//! made it has no such period, beyond the JPEG's 8-pixel blocks and the colour filter's
//! 2-pixel mosaic, which are weak.
//!
//! Why it matters: the fit reads a tool from how the grooves' light grows with depth, in linear
//! light. Enlarging in the display encoding (what image editors and messengers do) changes a
//! thin bright groove's light more than a wide one's, in a way no parameter follows: a 60 degree
//! V-bit's photos enlarged three times with ImageMagick were fitted at 57.3 +- 0.25 degrees,
//! with a residual at the photos' noise.
use crate::photo::Gray;

/// What [`detect`] found: the period (pixels) of the strongest repeating pattern in the
/// sharpness of the photo's pixels, how strong it is against the spectrum's floor, and its
/// amplitude relative to the mean sharpness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Periodicity {
    pub period_px: f64,
    /// Peak power over the median power of the spectrum.
    pub peak_over_floor: f64,
    /// Amplitude of the periodic part over the mean (0: none; 1: it swings by the mean).
    pub modulation: f64,
}

/// A pattern this strong (its weaker peak, rows or columns, over the spectrum's floor) and this
/// deep (modulation) is an enlargement. Measured (`examples/resample_probe`, 36 photos as the
/// simulator and the phone model make them: sharp or blurred, exposures 0.5 to 3, noise 0 to
/// 1%, 0.07 to 4 MP, PNG or JPEG 85 to 92): peaks at most 27 (modulation 0.008 there), and at
/// most 18 where the modulation exceeds 0.025. Enlarged three times by ImageMagick (Mitchell, in
/// the display encoding): 51, 0.061; bilinear by 3: 81, 0.13; bilinear by 2.37: 28, 0.08. Not
/// told apart from a photo's own pixels: Catmull-Rom by 3 (22, 0.031), factors from 1.25 to 2,
/// and factors whose period falls on a JPEG's own (4, 8).
const PEAK_MIN: f64 = 28.0;
const MODULATION_MIN: f64 = 0.05;

/// The strongest periodic pattern of the second differences along rows and along columns,
/// over the middle of the photo (a tenth left out at each edge), at periods from 2 to 8 pixels
/// other than a photo's own (`native_period`).
pub fn periodicity(img: &Gray) -> Option<Periodicity> {
    let (w, h) = (img.width as usize, img.height as usize);
    if w < 64 || h < 64 {
        return None;
    }
    // Per line, each pixel's second difference over the mean of its line's within 8 pixels
    // (so a groove's contrast does not count, only where in the pattern the pixel sits),
    // averaged over the lines.
    let along = |n_line: usize, n_along: usize, at: &dyn Fn(usize, usize) -> f32| -> Vec<f64> {
        let (l0, l1) = (n_line / 10, n_line - n_line / 10);
        let mut acc = vec![0.0f64; n_along];
        let mut e = vec![0.0f64; n_along];
        for l in l0..l1 {
            for i in 1..n_along - 1 {
                e[i] = (at(l, i - 1) - 2.0 * at(l, i) + at(l, i + 1)).abs() as f64;
            }
            // Running sums for the local means.
            let mut cum = vec![0.0f64; n_along + 1];
            for i in 0..n_along {
                cum[i + 1] = cum[i] + e[i];
            }
            for i in 1..n_along - 1 {
                let (a, b) = (i.saturating_sub(8).max(1), (i + 9).min(n_along - 1));
                let local = (cum[b] - cum[a]) / (b - a) as f64;
                if local > 1e-6 {
                    acc[i] += e[i] / local;
                } else {
                    acc[i] += 1.0;
                }
            }
        }
        acc.iter().map(|a| a / (l1 - l0) as f64).collect()
    };
    let rows = spectrum(&along(h, w, &|y, x| img.data[y * w + x]))?;
    let cols = spectrum(&along(w, h, &|x, y| img.data[y * w + x]))?;
    // An enlargement repeats with the same period along rows and columns (one factor, both
    // ways); the card's own regular ladder does not (the camera's perspective gives its rows
    // and columns other spacings in the photo). So the score of a frequency is the weaker of
    // its two peaks. A photo's own periods (JPEG blocks, the colour mosaic) are not tried: a
    // JPEG as a phone saved it swings there by 0.4 of the mean.
    let mut best: Option<Periodicity> = None;
    for i in 0..FREQS {
        let period_px = 1.0 / freq(i);
        if native_period(period_px) {
            continue;
        }
        let score = (rows.power[i] / rows.floor).min(cols.power[i] / cols.floor);
        if best.is_none_or(|b| score > b.peak_over_floor) {
            best = Some(Periodicity {
                period_px,
                peak_over_floor: score,
                modulation: rows.modulation(i).min(cols.modulation(i)),
            });
        }
    }
    best
}

/// Frequencies tried (cycles per pixel), from 1/8 to 1/2.
const FREQS: usize = 1500;
fn freq(i: usize) -> f64 {
    let (lo, hi) = (1.0 / 8.0, 0.5);
    lo + (hi - lo) * i as f64 / (FREQS - 1) as f64
}

/// A profile's power at each of the frequencies tried, its median, and the profile's length
/// and mean (for the modulation).
struct Spectrum {
    power: Vec<f64>,
    floor: f64,
    n: usize,
    mean: f64,
}

impl Spectrum {
    fn modulation(&self, i: usize) -> f64 {
        2.0 * self.power[i].sqrt() / (self.n as f64 * self.mean)
    }
}

/// The spectrum of a profile's middle 80%, less its running mean over 17 pixels (the card's
/// content changes slowly against the periods tried).
fn spectrum(profile: &[f64]) -> Option<Spectrum> {
    let n0 = profile.len() / 10;
    let p = &profile[n0..profile.len() - n0];
    let n = p.len();
    if n < 48 {
        return None;
    }
    let mean = p.iter().sum::<f64>() / n as f64;
    if !(mean > 0.0) {
        return None;
    }
    let half = 8usize;
    let detrended: Vec<f64> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(n));
            p[i] - p[a..b].iter().sum::<f64>() / (b - a) as f64
        })
        .collect();
    let power: Vec<f64> = (0..FREQS)
        .map(|k| {
            let f = freq(k);
            let (mut re, mut im) = (0.0, 0.0);
            for (i, d) in detrended.iter().enumerate() {
                let (s, c) = (std::f64::consts::TAU * f * i as f64).sin_cos();
                re += d * c;
                im -= d * s;
            }
            re * re + im * im
        })
        .collect();
    let mut sorted = power.clone();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 2].max(1e-30);
    Some(Spectrum { power, floor, n, mean })
}

/// Whether a pattern of this period could be a photo's own (JPEG blocks every 8 pixels and
/// their harmonics, the colour mosaic every 2).
fn native_period(period_px: f64) -> bool {
    let f = 1.0 / period_px;
    [0.125, 0.25, 0.375, 0.5].iter().any(|g| (f - g).abs() < 0.01)
}

/// The periodic pattern an enlargement left in a photo, when it shows one (see the module's
/// docs); `None` for a photo whose pixels look as a camera made them.
pub fn enlarged(img: &Gray) -> Option<Periodicity> {
    let p = periodicity(img)?;
    (p.peak_over_floor >= PEAK_MIN && p.modulation >= MODULATION_MIN).then_some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A photo's own noise (white, as a sensor's) has no period; the same enlarged three times
    /// by bilinear interpolation repeats every 3 pixels, and a card-like pattern of bright
    /// lines on a regular grid (the ladder) is not taken for one.
    #[test]
    fn an_enlargement_shows_its_period_and_a_photo_does_not() {
        let mut rng = scratchart_design::scenes::Rng::new(5);
        let (w, h) = (200usize, 200usize);
        let noise: Vec<f32> = (0..w * h).map(|_| (0.5 + 0.1 * rng.normal()) as f32).collect();
        let img = Gray {
            width: w as u32,
            height: h as u32,
            data: noise.clone(),
        };
        assert!(enlarged(&img).is_none(), "{:?}", periodicity(&img));
        let k = 3usize;
        let (bw, bh) = (w * k, h * k);
        let at = |x: usize, y: usize| noise[y.min(h - 1) * w + x.min(w - 1)];
        let big: Vec<f32> = (0..bw * bh)
            .map(|i| {
                let (x, y) = ((i % bw) as f32 / k as f32, (i / bw) as f32 / k as f32);
                let (x0, y0) = (x.floor() as usize, y.floor() as usize);
                let (fx, fy) = (x - x0 as f32, y - y0 as f32);
                let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
                let bot = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
                top * (1.0 - fy) + bot * fy
            })
            .collect();
        let big = Gray {
            width: bw as u32,
            height: bh as u32,
            data: big,
        };
        let p = enlarged(&big).expect("an enlargement by 3");
        assert!((p.period_px - 3.0).abs() < 0.05, "{p:?}");
        // Bright lines every 9.5 pixels across and 11 down, on noise.
        let lines: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let on = (x % 9.5) < 1.0 || (y % 11.0) < 1.0;
                noise[i] * 0.1 + if on { 0.8 } else { 0.0 }
            })
            .collect();
        let grid = Gray {
            width: w as u32,
            height: h as u32,
            data: lines,
        };
        assert!(enlarged(&grid).is_none(), "{:?}", periodicity(&grid));
    }
}
