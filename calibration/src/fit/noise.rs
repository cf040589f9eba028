//! What a phone's sensor noise does to the mean of what a photo shows, put into the fit's model.
//!
//! Each colour channel of each pixel gets the sensor's noise and is clipped to [0, 1] and stepped
//! to 8 bits before the grey is formed (Rec. 709 luma of the channels). Noise clipped at black
//! lifts whatever is dark: at 2.5% noise a black plate reads 0.01, and where a photo larger than
//! the capture view is shrunk by averaging k x k pixels' light, that lift stays while the noise
//! itself averages away (a 2.5%-noise photo put a 58 um ball at 39.5 um +- 0.3, accepted,
//! before the lift was in the model). The fit's model therefore shows the *expected* photo:
//! - a photo used as taken ([`Transfer::Taken`]): each pixel's display value d becomes
//!   E[grey(q(clip(d + sigma Z_c)))];
//! - a photo shrunk by k > 1 ([`Transfer::Shrunk`]): each of the model's subpixels (the nearest
//!   the model has to the photo's own pixels) gets the light E[linear(grey(...))], which the
//!   pixels then average as the shrink did.
//!
//! sigma is the channels' noise at the photo's own resolution (`fit_cmd::inspect`: the shrunk
//! photo's noise times k, over the grey's share of independent channel noise for a colour
//! photo). The expectations are tabulated over d from a fixed set of normal draws, so the model
//! is a smooth, deterministic function of d.

/// Rec. 709 luma weights (the `image` crate's grey).
const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];
/// Table points over display values [0, 1].
const N: usize = 1024;
/// Normal draws per table point (the same for every point).
const DRAWS: usize = 4096;

/// The expected photo of a model value, for one photo.
#[derive(Clone, Debug)]
pub(crate) enum Transfer {
    /// Used as taken: display value -> expected display value.
    Taken(Vec<f32>),
    /// Shrunk: a subpixel's display value -> its expected light (linear).
    Shrunk(Vec<f32>),
}

impl Transfer {
    /// The transfer of a photo whose channels have noise `sigma` (display units), a colour
    /// photo (`colour`: three independently noisy channels) or a grey one, shrunk by `shrink`.
    /// None without noise (the 8-bit steps alone average out).
    pub(crate) fn for_photo(sigma: f64, colour: bool, shrink: u32) -> Option<Transfer> {
        if !(sigma > 0.0) {
            return None;
        }
        let mut rng = scratchart::scenes::Rng::new(0x0c11_9ed0);
        let z: Vec<[f64; 3]> = (0..DRAWS).map(|_| [rng.normal(), rng.normal(), rng.normal()]).collect();
        let q = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() / 255.0;
        let shrunk = shrink > 1;
        let table: Vec<f32> = (0..=N)
            .map(|i| {
                let d = i as f64 / N as f64;
                let mut acc = 0.0;
                for zc in &z {
                    let g = if colour {
                        (0..3).map(|c| LUMA[c] * q(d + sigma * zc[c])).sum::<f64>()
                    } else {
                        q(d + sigma * zc[0])
                    };
                    acc += if shrunk {
                        scratchart::model::display::linear(g)
                    } else {
                        g
                    };
                }
                (acc / DRAWS as f64) as f32
            })
            .collect();
        Some(if shrunk {
            Transfer::Shrunk(table)
        } else {
            Transfer::Taken(table)
        })
    }

    fn lookup(t: &[f32], d: f32) -> f32 {
        let u = d.clamp(0.0, 1.0) * N as f32;
        let i = (u.floor() as usize).min(N - 1);
        let f = u - i as f32;
        t[i] * (1.0 - f) + t[i + 1] * f
    }

    /// A shrunk photo's subpixel light `l` (linear) -> its expected light; others unchanged.
    pub(crate) fn subpixel(&self, l: f32) -> f32 {
        match self {
            Transfer::Shrunk(t) => Self::lookup(t, scratchart::io::display_value(l)),
            Transfer::Taken(_) => l,
        }
    }

    /// A photo used as taken: the pixel's display value `d` -> its expected display value;
    /// others unchanged.
    pub(crate) fn pixel(&self, d: f32) -> f32 {
        match self {
            Transfer::Taken(t) => Self::lookup(t, d),
            Transfer::Shrunk(_) => d,
        }
    }
}

/// Per view, the transfer of its photo's clipped noise (`fit::noise`).
pub(super) fn for_views(data: &super::Data) -> Vec<Option<Transfer>> {
    (0..data.capture.views.len())
        .map(|v| {
            Transfer::for_photo(
                data.native_noise.get(v).copied().unwrap_or(0.0),
                data.colour.get(v).copied().unwrap_or(false),
                data.shrink.get(v).copied().unwrap_or(1),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_clipped_at_black_lifts_the_dark_and_leaves_the_middle() {
        let t = Transfer::for_photo(0.025, true, 1).unwrap();
        // A black pixel: the mean of three clipped channels, about 0.4 sigma.
        let black = t.pixel(0.0);
        assert!((black - 0.4 * 0.025).abs() < 0.0015, "{black}");
        // Mid-grey: unchanged within the 8-bit steps' and the draws' error.
        assert!((t.pixel(0.5) - 0.5).abs() < 0.002, "{}", t.pixel(0.5));
        // White clips from above.
        assert!(t.pixel(1.0) < 0.995);
        // Shrunk: the light of a black subpixel is that of the clipped noise, a subpixel's light
        // in the middle rises by the curve's convexity (about 1.2 sigma^2 d^0.2 x 2.2 / 2).
        let s = Transfer::for_photo(0.025, true, 3).unwrap();
        assert!(s.subpixel(0.0) > 1e-5);
        let mid = s.subpixel(0.2176) as f64; // display 0.5
        assert!(mid > 0.2176 && mid < 0.2176 * 1.01, "{mid}");
        // A grey photo's single channel lifts black more than three averaged ones.
        let g = Transfer::for_photo(0.025, false, 3).unwrap();
        assert!(g.subpixel(0.0) > s.subpixel(0.0));
        assert!(Transfer::for_photo(0.0, true, 3).is_none());
    }
}
