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
//! A shrunk photo saved as JPEG lost part of its noise to JPEG's quantization at its own
//! resolution before the shrink, so the curve's convexity lifts its light less than the raw
//! noise would (2% noise and JPEG 80 put a 58 um ball at 64.4 um with the raw noise's table):
//! its table is measured by the same JPEG round trip of flat noisy patches, at the quality read
//! from the file's quantization table (`photo::jpeg_table_quality`). The black's lift, clipped
//! before the JPEG, stays in it.
//!
//! sigma is the channels' noise at the photo's own resolution, measured on the photo
//! ([`sensor_noise`], `fit_cmd::inspect`) to 5 or 10%; where the photo shows the lift (its dark
//! plate near black, [`lift_seen`]) the fit refines its size (`ln_noise[v]`: a [`Lift`] holds
//! the tables at noise scales from half to twice the one measured). The expectations are
//! tabulated over d from a fixed set of normal draws, so the model is a smooth, deterministic
//! function of d. What the tables miss of a shrunk JPEG (JPEG's steps on the noisy photo at its
//! own resolution, a groove coloured by the white balance) the fit adds from simulated photos
//! ([`super::Evaluator::simulated_shift`]).

use crate::photo::LUMA;
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
    /// None without noise (the 8-bit steps alone average out). `jpeg`: the quality a shrunk
    /// photo was saved with (a JPEG used as taken gets the JPEG on its model image instead,
    /// `fit::Data::jpeg`).
    pub(crate) fn for_photo(sigma: f64, colour: bool, shrink: u32, jpeg: Option<u8>) -> Option<Transfer> {
        if !(sigma > 0.0) {
            return None;
        }
        if let (true, Some(q)) = (shrink > 1, jpeg) {
            if let Some(t) = shrunk_jpeg_table(sigma, colour, q) {
                return Some(Transfer::Shrunk(t));
            }
        }
        let mut rng = scratchart_design::scenes::Rng::new(0x0c11_9ed0);
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
                    acc += if shrunk { crate::encoding::decode(g) } else { g };
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
        let n = t.len() - 1;
        let u = d.clamp(0.0, 1.0) * n as f32;
        let i = (u.floor() as usize).min(n - 1);
        let f = u - i as f32;
        t[i] * (1.0 - f) + t[i + 1] * f
    }

    /// A shrunk photo's subpixel light `l` (linear) -> its expected light; others unchanged.
    pub(crate) fn subpixel(&self, l: f32) -> f32 {
        match self {
            Transfer::Shrunk(t) => Self::lookup(t, crate::encoding::encode_f32(l)),
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

/// Table points of a shrunk JPEG's transfer over display values [0, 1].
const JPEG_N: usize = 128;
/// The side of each table point's flat patch (whole 16 x 16 blocks of colour JPEG's 4:2:0).
const PATCH: usize = 64;

/// A shrunk JPEG's table: for each display value d, a flat patch whose channels get the noise
/// (the same draws for every d, so the table is smooth in d), clipped and stepped to 8 bits,
/// through a JPEG at quality `q` as the photo was saved (colour or grey), read back as the fit
/// reads a photo (Rec. 709 grey), and the mean of its light. None where the round trip fails.
fn shrunk_jpeg_table(sigma: f64, colour: bool, q: u8) -> Option<Vec<f32>> {
    let mut rng = scratchart_design::scenes::Rng::new(0x0c11_9ed1);
    let px = PATCH * PATCH;
    let z: Vec<[f64; 3]> = (0..px).map(|_| [rng.normal(), rng.normal(), rng.normal()]).collect();
    let chans = if colour { 3 } else { 1 };
    let (w, h) = (PATCH as u32, (PATCH * (JPEG_N + 1)) as u32);
    let mut bytes = Vec::with_capacity(px * (JPEG_N + 1) * chans);
    for i in 0..=JPEG_N {
        let d = i as f64 / JPEG_N as f64;
        for zc in &z {
            for c in 0..chans {
                bytes.push(((d + sigma * zc[c]).clamp(0.0, 1.0) * 255.0).round() as u8);
            }
        }
    }
    let g = jpeg_grey(&bytes, w, h, colour, q)?;
    Some(
        (0..=JPEG_N)
            .map(|i| {
                let sum: f64 = g[i * px..(i + 1) * px]
                    .iter()
                    .map(|&x| crate::encoding::decode(x as f64))
                    .sum();
                (sum / px as f64) as f32
            })
            .collect(),
    )
}

/// 8-bit channels (`colour`: RGB, else grey) `w` x `h` through a JPEG at quality `q` and read
/// back as the fit reads a photo: the Rec. 709 grey of the decoded channels.
fn jpeg_grey(bytes: &[u8], w: u32, h: u32, colour: bool, q: u8) -> Option<Vec<f32>> {
    let mut buf = Vec::new();
    let enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, q);
    let ct = if colour {
        image::ExtendedColorType::Rgb8
    } else {
        image::ExtendedColorType::L8
    };
    image::ImageEncoder::write_image(enc, bytes, w, h, ct).ok()?;
    let back = image::load_from_memory_with_format(&buf, image::ImageFormat::Jpeg).ok()?;
    Some(back.to_luma32f().into_raw())
}

/// 8-bit channels `w` x `h` as the fit reads them from a photo saved as JPEG at `q`
/// ([`jpeg_grey`]) or losslessly: the Rec. 709 grey.
fn saved_grey(bytes: &[u8], w: u32, h: u32, colour: bool, q: Option<u8>) -> Option<Vec<f32>> {
    Some(match q {
        Some(q) => jpeg_grey(bytes, w, h, colour, q)?,
        None if colour => bytes
            .chunks_exact(3)
            .map(|c| (0..3).map(|i| LUMA[i] * c[i] as f64 / 255.0).sum::<f64>() as f32)
            .collect(),
        None => bytes.iter().map(|&b| b as f32 / 255.0).collect(),
    })
}

/// The side of the simulated photo after its shrink, pixels ([`sensor_noise`]):
/// 256, fewer where the photo is shrunk by more than 8, so that the photo before the shrink is
/// at most 2,048 pixels a side (a 50 MP photo is shrunk by about 24 to a 256-pixel view).
fn sense_side(k: u32) -> usize {
    (2048 / k.max(1) as usize).clamp(32, 256)
}

/// The sensor's noise per channel at a photo's own resolution, from the noise `measured`
/// (`photo::pixel_noise`) on the photo shrunk by `k` (1: as taken). The sigma is the one
/// whose simulated photo shows `measured`: a flat patch at the photo's typical display value
/// `level`, noisy channels (`colour`) clipped and stepped to 8 bits, the JPEG at quality `q`
/// where it was one, the grey, the shrink by k in light, and the same measure. JPEG's
/// quantization takes part of the noise (a quality-70 photo with 3% noise per channel read as
/// 1.7% from k times its shrunk noise: the ball's lift corrected by a third too little), and
/// clipping at black another part on a dark plate. Seeded, so the same photo gives the same
/// sigma.
pub(crate) fn sensor_noise(measured: f64, level: f64, colour: bool, k: u32, q: Option<u8>) -> f64 {
    let share = if colour { crate::photo::LUMA_NOISE } else { 1.0 };
    let mut sigma = k as f64 * measured / share;
    if !(measured > 0.0) || k < 1 {
        return sigma.max(0.0);
    }
    let z = draws(0x5e45_0e5e, k, colour);
    // The measure grows about as sigma does: a few fixed-point steps settle it.
    for _ in 0..4 {
        match shown_noise(&z, sigma, level, colour, k, q) {
            Some(s) if s > 0.0 => sigma = (sigma * measured / s).min(0.5),
            _ => break,
        }
    }
    sigma
}

/// Normal draws for a simulated photo of [`sense_side`] k pixels a side.
fn draws(seed: u64, k: u32, colour: bool) -> Vec<f32> {
    let side = sense_side(k) * k as usize;
    let mut rng = scratchart_design::scenes::Rng::new(seed);
    (0..side * side * if colour { 3 } else { 1 })
        .map(|_| rng.normal() as f32)
        .collect()
}

/// The noise `photo::pixel_noise` measures on a flat photo (of [`sense_side`] k pixels a
/// side) at display value `level` whose channels got the noise `sigma` x `z`, clipped and
/// stepped to 8 bits, saved as JPEG at `q` (or losslessly), read back as grey and shrunk by `k`
/// in light.
fn shown_noise(z: &[f32], sigma: f64, level: f64, colour: bool, k: u32, q: Option<u8>) -> Option<f64> {
    let small_side = sense_side(k);
    let side = small_side * k as usize;
    let bytes: Vec<u8> = z
        .iter()
        .map(|&z| ((level + sigma * z as f64).clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    let full = crate::photo::Gray {
        width: side as u32,
        height: side as u32,
        data: saved_grey(&bytes, side as u32, side as u32, colour, q)?,
    };
    let small = crate::photo::resize(&full, small_side as u32, small_side as u32);
    Some(crate::photo::pixel_noise(&small))
}

pub(super) mod shrunk;

impl super::Evaluator<'_, '_> {
    /// Per residual (the order of [`Self::residuals`], `r` its values): whether the model shows
    /// it within [`SKEWED_NOISE`] of its photo's noise of black, where that noise, clipped, is
    /// skewed (where `lm::loss` is `split`, the fit takes a quadratic core there). The model's value is the
    /// residual plus the photo's (less a JPEG's simulated change, over a bootstrap weight).
    pub(super) fn skewed(&self, r: &[f64]) -> Vec<bool> {
        let mut out = Vec::with_capacity(r.len());
        for v in 0..self.data.masks.len() {
            let sigma = self.data.native_noise.get(v).copied().unwrap_or(0.0);
            let photo = self.photo(v);
            let shift = self.jpeg_shift.get(v).and_then(|s| s.as_deref());
            for (i, _) in self.data.masks[v].iter().enumerate().filter(|(_, m)| **m) {
                let k = out.len();
                let Some(&e) = r.get(k) else { break };
                let w = self.weights.as_ref().map_or(1.0, |w| w[k]);
                let model = e / w.sqrt() + photo[i] as f64 - shift.map_or(0.0, |s| s[i] as f64);
                out.push(sigma > 0.0 && model < SKEWED_NOISE * sigma);
            }
        }
        out.resize(r.len(), false);
        out
    }

    /// View v's sensor noise at `x`: the one measured on its photo, scaled as the fit refined it.
    pub(super) fn sigma(&self, x: &[f64], v: usize) -> f64 {
        self.data.native_noise.get(v).copied().unwrap_or(0.0) * self.lay.ln_noise(x, v).exp()
    }
}

/// Per view, the lift of its photo's clipped noise (`fit::noise`), at scales about the noise
/// measured.
pub(super) fn for_views(data: &super::Data) -> Vec<Option<Lift>> {
    let refined = lift_seen(data);
    (0..data.capture.views.len())
        .map(|v| {
            Lift::for_photo(
                data.native_noise.get(v).copied().unwrap_or(0.0),
                data.colour.get(v).copied().unwrap_or(false),
                data.shrink.get(v).copied().unwrap_or(1),
                data.saved_jpeg.get(v).copied().flatten(),
                refined[v],
            )
        })
        .collect()
}

/// Per view, whether the fit refines the size of its photo's lift (`ln_noise[v]`): where the
/// photo has noise and a tenth of the pixels it compares lie within [`LIFT_SEEN`] times that
/// noise of black, where clipping at black is what the photo shows. Elsewhere the lift is a
/// few ten-thousandths, and its size would follow whatever else the model lacks there (a test
/// card lit to 0.05, its noise 0.6%, ran it to the bound at twice the noise measured).
pub(super) fn lift_seen(data: &super::Data) -> Vec<bool> {
    (0..data.capture.views.len())
        .map(|v| {
            let sigma = data.native_noise.get(v).copied().unwrap_or(0.0);
            let (Some(photo), Some(mask)) = (data.photos.get(v), data.masks.get(v)) else {
                return false;
            };
            let (mut n, mut dark) = (0usize, 0usize);
            for (&d, &m) in photo.iter().zip(mask) {
                if m {
                    n += 1;
                    dark += usize::from((d as f64) < LIFT_SEEN * sigma);
                }
            }
            sigma > 0.0 && n > 0 && dark * 10 >= n
        })
        .collect()
}

/// A model's pixel within this many times its photo's sensor noise of black has skewed noise
/// (clipped at black; beyond three, under one part in a thousand is clipped).
pub(super) const SKEWED_NOISE: f64 = 3.0;

/// A pixel within this many times its photo's sensor noise of black shows the lift.
const LIFT_SEEN: f64 = 2.0;

/// Tables of a [`Transfer`] every this much in the log of the noise's scale.
const SCALE_STEP: f64 = 0.175;

/// A photo's [`Transfer`] for its sensor noise scaled by exp(u), |u| up to
/// `layout::NOISE_SPAN`: tables every [`SCALE_STEP`] in u, interpolated, so that the fit can
/// refine the lift's size (`ln_noise[v]`) as it refines the exposure, without a table per step.
#[derive(Clone, Debug)]
pub(crate) struct Lift {
    tables: Vec<Transfer>,
}

impl Lift {
    /// The tables of a photo's noise `sigma`: at every scale where the fit refines the lift's
    /// size (`refined`), else at sigma alone.
    pub(crate) fn for_photo(sigma: f64, colour: bool, shrink: u32, jpeg: Option<u8>, refined: bool) -> Option<Lift> {
        let n = if refined {
            (super::layout::NOISE_SPAN / SCALE_STEP).ceil() as i32
        } else {
            0
        };
        let tables = (-n..=n)
            .map(|i| Transfer::for_photo(sigma * (i as f64 * SCALE_STEP).exp(), colour, shrink, jpeg))
            .collect::<Option<Vec<_>>>()?;
        Some(Lift { tables })
    }

    /// The two tables about scale u and the weight of the second (scale 1 where there is one).
    fn at(&self, u: f64) -> (&Transfer, &Transfer, f32) {
        if self.tables.len() == 1 {
            return (&self.tables[0], &self.tables[0], 0.0);
        }
        let n = (self.tables.len() - 1) as f64;
        let t = (u / SCALE_STEP + n / 2.0).clamp(0.0, n);
        let i = (t.floor() as usize).min(self.tables.len() - 2);
        (&self.tables[i], &self.tables[i + 1], (t - i as f64) as f32)
    }

    /// [`Transfer::subpixel`] at the noise's scale exp(u).
    #[cfg(test)]
    pub(crate) fn subpixel(&self, l: f32, u: f64) -> f32 {
        self.at_scale(u).subpixel(l)
    }

    /// [`Transfer::pixel`] at the noise's scale exp(u).
    #[cfg(test)]
    pub(crate) fn pixel(&self, d: f32, u: f64) -> f32 {
        self.at_scale(u).pixel(d)
    }

    /// The lift at the noise's scale exp(u), for many pixels.
    pub(crate) fn at_scale(&self, u: f64) -> LiftAt<'_> {
        let (a, b, f) = self.at(u);
        LiftAt { a, b, f }
    }
}

/// A [`Lift`] at one noise scale: its two tables about it and the weight of the second.
pub(crate) struct LiftAt<'a> {
    a: &'a Transfer,
    b: &'a Transfer,
    f: f32,
}

impl LiftAt<'_> {
    /// [`Transfer::subpixel`] at this scale.
    pub(crate) fn subpixel(&self, l: f32) -> f32 {
        let (a, b, f) = (self.a, self.b, self.f);
        match (a, b) {
            // (The light encoded once for both tables: the same bits.)
            (Transfer::Shrunk(ta), Transfer::Shrunk(tb)) => {
                let d = crate::encoding::encode_f32(l);
                Transfer::lookup(ta, d) * (1.0 - f) + Transfer::lookup(tb, d) * f
            }
            _ => a.subpixel(l) * (1.0 - f) + b.subpixel(l) * f,
        }
    }

    /// [`Transfer::pixel`] at this scale.
    pub(crate) fn pixel(&self, d: f32) -> f32 {
        self.a.pixel(d) * (1.0 - self.f) + self.b.pixel(d) * self.f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_clipped_at_black_lifts_the_dark_and_leaves_the_middle() {
        let t = Transfer::for_photo(0.025, true, 1, None).unwrap();
        // A black pixel: the mean of three clipped channels, about 0.4 sigma.
        let black = t.pixel(0.0);
        assert!((black - 0.4 * 0.025).abs() < 0.0015, "{black}");
        // Mid-grey: unchanged within the 8-bit steps' and the draws' error.
        assert!((t.pixel(0.5) - 0.5).abs() < 0.002, "{}", t.pixel(0.5));
        // White clips from above.
        assert!(t.pixel(1.0) < 0.995);
        // Shrunk: the light of a black subpixel is that of the clipped noise, a subpixel's light
        // in the middle rises by the curve's convexity (about 1.2 sigma^2 d^0.2 x 2.2 / 2).
        let s = Transfer::for_photo(0.025, true, 3, None).unwrap();
        assert!(s.subpixel(0.0) > 1e-5);
        let mid = s.subpixel(0.2176) as f64; // display 0.5
        assert!(mid > 0.2176 && mid < 0.2176 * 1.01, "{mid}");
        // A grey photo's single channel lifts black more than three averaged ones.
        let g = Transfer::for_photo(0.025, false, 3, None).unwrap();
        assert!(g.subpixel(0.0) > s.subpixel(0.0));
        assert!(Transfer::for_photo(0.0, true, 3, None).is_none());
        // A shrunk JPEG's table: at quality 100 it is the raw noise's; at 70 JPEG took part of
        // the noise, so the middle's convexity lift is smaller (the black's, clipped before the
        // JPEG, stays).
        let j100 = Transfer::for_photo(0.025, true, 3, Some(100)).unwrap();
        let j70 = Transfer::for_photo(0.025, true, 3, Some(70)).unwrap();
        let d01 = crate::encoding::decode(0.1) as f32;
        let lift = |t: &Transfer| t.subpixel(d01) - d01;
        assert!(
            (lift(&j100) - lift(&s)).abs() < 0.1 * lift(&s),
            "{} {}",
            lift(&j100),
            lift(&s)
        );
        assert!(lift(&j70) < 0.8 * lift(&s), "{} {}", lift(&j70), lift(&s));
        assert!(j70.subpixel(0.0) > 0.5 * s.subpixel(0.0));
    }

    #[test]
    fn a_lifts_size_interpolates_between_noise_scales() {
        // At u = 0 the lift is the transfer of the noise measured; at u = ln 1.3 (between two
        // tables) it is within 3% (or 1e-4, where the 8-bit steps ripple a lift a tenth of a
        // step) of the transfer of 1.3 times that noise, for a shrunk photo
        // and one used as taken; beyond its span it stays at the span's end.
        for shrink in [1u32, 3] {
            let lift = Lift::for_photo(0.02, true, shrink, None, true).unwrap();
            let at = |t: &Transfer, d: f32| if shrink > 1 { t.subpixel(d) } else { t.pixel(d) };
            let of = |u: f64, d: f32| {
                if shrink > 1 {
                    lift.subpixel(d, u)
                } else {
                    lift.pixel(d, u)
                }
            };
            let t1 = Transfer::for_photo(0.02, true, shrink, None).unwrap();
            let t13 = Transfer::for_photo(0.026, true, shrink, None).unwrap();
            for d in [0.0f32, 0.002, 0.01, 0.05] {
                assert!((of(0.0, d) - at(&t1, d)).abs() < 1e-6, "{shrink} {d}");
                let (want, got) = (at(&t13, d) - d, of(1.3f64.ln(), d) - d);
                assert!(
                    (got - want).abs() < 0.03 * want.abs() + 1e-4,
                    "{shrink} {d}: {got} for {want}"
                );
            }
            assert_eq!(of(5.0, 0.0), of(super::super::layout::NOISE_SPAN + 0.1, 0.0));
            assert!(of(0.5, 0.0) > of(0.0, 0.0) && of(0.0, 0.0) > of(-0.5, 0.0));
        }
        // Where the size is not refined, one table: the noise measured at any scale.
        let one = Lift::for_photo(0.02, true, 3, None, false).unwrap();
        assert_eq!(one.tables.len(), 1);
        assert_eq!(
            one.subpixel(0.0, 0.5),
            Transfer::for_photo(0.02, true, 3, None).unwrap().subpixel(0.0)
        );
    }

    #[test]
    fn a_shrunk_jpegs_sensor_noise_is_found_through_its_quantization() {
        // Photos of other draws than the search's: 3% and 1.5% per channel, quality 70 to 85,
        // shrunk by 3 and 5, on a dark plate and mid levels. On the dark plate JPEG took a
        // fifth of what the shrunk photo shows: k times it, over the grey's share, is 30% low.
        for (sigma, q, k, level, colour) in [
            (0.03, 70u8, 3u32, 0.02, true),
            (0.015, 85, 5, 0.3, true),
            (0.03, 80, 3, 0.15, false),
            // A 17 MP photo to a 256-pixel view: the simulated photo is 2,048 pixels a side.
            (0.02, 75, 16, 0.04, true),
        ] {
            let z = draws(77, k, colour);
            let measured = shown_noise(&z, sigma, level, colour, k, Some(q)).unwrap();
            let share = if colour { crate::photo::LUMA_NOISE } else { 1.0 };
            let naive = k as f64 * measured / share;
            let found = sensor_noise(measured, level, colour, k, Some(q));
            eprintln!("sigma {sigma} q{q} k{k}: naive {naive:.4}, found {found:.4}");
            assert!((found - sigma).abs() < 0.1 * sigma, "{found} for {sigma}");
            if q == 70 {
                assert!(naive < 0.8 * sigma, "{naive} for {sigma}");
            }
        }
    }
}
