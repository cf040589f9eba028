//! A shrunk photo simulated at its own resolution: what its JPEG and its noise do there that the
//! noise tables ([`super::Transfer`]) do not follow, drawn from the model's light
//! ([`shrunk_photo_draw`]) and added to the fit's model as a shift
//! ([`super::super::Evaluator::simulated_shift`]).
use super::saved_grey;

/// Photos shrunk by more than this are left as the model has them in the fit's degradation
/// term (`uncertainty`): a 50 MP photo is shrunk by about 24 to a 256-pixel view, and beyond 32
/// the simulated photo would take more than 200 MB. JPEG still matters at 16: a 21 MP quality-91
/// photo's JPEG moved a measured profile's widest rung by 5 um.
pub(in crate::fit) const SIMULATED_SHRINK: u32 = 32;

/// The model's light of a photo simulated at its own resolution, once for all its draws: its
/// light at the photo's own pixels (k times the view's `w` x `h`), interpolated (bilinear, in
/// light: the optics spread it smoothly over them), and per view pixel what that interpolation
/// alone moves between the view's pixels (display units), which each draw takes off. Blocks of
/// k / ss pixels with sharp edges gave the JPEG edges no photo has: a noiseless 20 MP JPEG's
/// grooves were left 2.5 to 3 times the model's error, where the same photo as a PNG fitted to
/// its floor.
pub(in crate::fit) struct ShrunkLight {
    native: Vec<f32>,
    spread: Vec<f32>,
    w: u32,
    h: u32,
    k: u32,
}

impl ShrunkLight {
    /// From the model's subpixel light `lit` (`ss` times the view's `w` x `h`), for a photo
    /// shrunk by `k`.
    pub(in crate::fit) fn of(lit: &[f32], ss: u32, (w, h): (u32, u32), k: u32) -> ShrunkLight {
        let native = scratchart_render::io::resize_bilinear(lit, ss * w, ss * h, k * w, k * h);
        let shown = |light: &[f32], (sw, sh): (u32, u32)| {
            let g = crate::photo::Gray {
                width: sw,
                height: sh,
                data: light.iter().map(|&l| crate::encoding::encode_f32(l)).collect(),
            };
            crate::photo::resize(&g, w, h).data
        };
        let spread = shown(&native, (k * w, k * h))
            .iter()
            .zip(shown(lit, (ss * w, ss * h)))
            .map(|(s, kept)| s - kept)
            .collect();
        ShrunkLight {
            native,
            spread,
            w,
            h,
            k,
        }
    }
}

/// One draw of a shrunk photo as its camera made it, from the model's `light`: each of the
/// photo's own pixels' channels' share of it under the photo's white balance `gains` (as
/// `camera::ChannelClip` scales them) display-encoded, each channel's noise `sigma` (`colour`:
/// three channels, each its own) clipped and stepped to 8 bits, the JPEG at `q` where the photo
/// was one, read back as grey and shrunk by k in light as the fit shrank the photo, less what
/// the interpolation alone moved (so that without noise or JPEG the draw is the model's light
/// shrunk, within the 8-bit steps). What JPEG at the photo's own resolution and the noise do to
/// the fit, where no model term follows them: a JPEG keeps its colour at half the resolution
/// and in coarse steps, and where a cast colours the grooves that leaks into the grey (a
/// measured profile's widest rung 8 um narrow under a 19% cast).
pub(in crate::fit) fn shrunk_photo_draw(
    light: &ShrunkLight,
    sigma: f64,
    colour: bool,
    gains: [f64; 3],
    q: Option<u8>,
    normal: &mut dyn FnMut() -> f64,
) -> Option<Vec<f32>> {
    let ShrunkLight {
        native,
        spread,
        w,
        h,
        k,
    } = light;
    let (w, h, k) = (*w, *h, *k);
    let chans = if colour { 3 } else { 1 };
    // Each channel's light: the grey's light times its gain, scaled as `ChannelClip` does.
    let scale = super::super::camera::ChannelClip::gain_scale(gains);
    let g: [f64; 3] = if colour { gains.map(|g| g * scale) } else { [1.0; 3] };
    let mut bytes = Vec::with_capacity(native.len() * chans);
    for &l in native {
        let l = (l as f64).max(0.0);
        for gc in g.iter().take(chans) {
            let dc = crate::encoding::encode((l * gc).min(1.0));
            bytes.push(((dc + sigma * normal()).clamp(0.0, 1.0) * 255.0).round() as u8);
        }
    }
    let full = crate::photo::Gray {
        width: k * w,
        height: k * h,
        data: saved_grey(&bytes, k * w, k * h, colour, q)?,
    };
    let drawn = crate::photo::resize(&full, w, h).data;
    Some(drawn.iter().zip(spread).map(|(d, s)| d - s).collect())
}

impl super::super::Evaluator<'_, '_> {
    /// View v's photo, when it is simulated at its own resolution (shrunk by 2 to
    /// [`SIMULATED_SHRINK`]): the light at `x` from the render `lin` ([`shrunk_photo_draw`]'s
    /// input), computed once for all the draws.
    pub(in crate::fit) fn simulated_light(&self, lin: &[f32], v: usize, x: &[f64]) -> Option<ShrunkLight> {
        let k = self.data.shrink.get(v).copied().unwrap_or(1);
        let c = &self.data.capture.views[v].camera;
        (k > 1 && k <= SIMULATED_SHRINK).then(|| {
            ShrunkLight::of(
                &self.light(&self.blurred(lin, v, x), v, x),
                self.ss,
                (c.width, c.height),
                k,
            )
        })
    }

    /// One [`shrunk_photo_draw`] of view v's photo from its light `lit`
    /// ([`Self::simulated_light`]), with the photo's shrink, colour and white balance, the noise
    /// `sigma` and the JPEG `q`.
    pub(in crate::fit) fn shrunk_draw(
        &self,
        lit: &ShrunkLight,
        v: usize,
        sigma: f64,
        q: Option<u8>,
        normal: &mut dyn FnMut() -> f64,
    ) -> Option<Vec<f32>> {
        let d = self.data;
        shrunk_photo_draw(
            lit,
            sigma,
            d.colour.get(v).copied().unwrap_or(false),
            d.gains.get(v).copied().unwrap_or([1.0; 3]),
            q,
            normal,
        )
    }

    /// View v's expected shrunk photo less the model's prediction `model` (with its lift, no
    /// JPEG change): the mean of [`Self::shrunk_draw`]s with the photo's noise and JPEG, in
    /// antithetic pairs (each draw's noise and its negative, so that the noise's linear part
    /// cancels and only what clipping, the 8-bit steps and JPEG make of it stays), less `model`.
    /// What the model then lacks of a shrunk JPEG: JPEG's quantization of the noisy photo at its
    /// own resolution, which takes part of the noise and of its lift, and of a groove coloured by
    /// the photo's white balance. A JPEG's change taken without the noise (the model's light
    /// alone through the JPEG) put the ringing by bright grooves below black, clipped there, and
    /// lifted the dark plate a second time. Seeded by view: the same fit gives the same shift.
    pub(in crate::fit) fn simulated_shift(
        &self,
        lit: &ShrunkLight,
        v: usize,
        x: &[f64],
        model: &[f32],
    ) -> Option<Vec<f32>> {
        let d = self.data;
        let sigma = self.sigma(x, v);
        let q = d.saved_jpeg.get(v).copied().flatten();
        let k = d.shrink.get(v).copied().unwrap_or(1);
        // A photo shrunk by k averages k^2 of its pixels' noise: fewer pairs as k grows.
        // Without noise one draw is the photo's expectation.
        let (pairs, signs): (u32, &[f64]) = if sigma > 0.0 {
            ((8 / k.max(1)).clamp(1, 4), &[1.0, -1.0])
        } else {
            (1, &[1.0])
        };
        // Each draw its own seed: side by side on the host's cores, added up in order.
        let n_signs = signs.len();
        let draws = scratchart_model::par::par_map(pairs as usize * n_signs, |i| {
            let (p, sign) = (i / n_signs, signs[i % n_signs]);
            let mut rng = scratchart_design::scenes::Rng::new(0x5111_f7ed ^ ((v as u64) << 8) ^ p as u64);
            self.shrunk_draw(lit, v, sigma, q, &mut || sign * rng.normal())
        });
        let mut mean = vec![0.0f64; model.len()];
        for draw in draws {
            let draw = draw?;
            if draw.len() != mean.len() {
                return None;
            }
            mean.iter_mut().zip(&draw).for_each(|(m, x)| *m += *x as f64);
        }
        let n = (pairs as usize * signs.len()) as f64;
        Some(mean.iter().zip(model).map(|(m, p)| (m / n) as f32 - p).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_jpeg_of_coloured_grooves_leaks_its_colour_into_the_grey() {
        // Thin bright grooves on a dark plate, a view 48 x 48 rendered at twice that, its photo
        // shrunk by 4: without noise, PNG, the draw is the model's light shrunk (within 8-bit
        // steps), with a cast or not (light below the channels' clips passes); through JPEG 70
        // the grey moves, and otherwise where a cast colours the grooves (JPEG keeps colour at
        // half the resolution, and the grey is not JPEG's own luma).
        let (w, h, ss, k) = (48u32, 48u32, 2u32, 4u32);
        let lit: Vec<f32> = (0..(ss * w * ss * h) as usize)
            .map(|i| if (i % (ss * w) as usize) % 7 == 3 { 0.6 } else { 0.004 })
            .collect();
        let light = ShrunkLight::of(&lit, ss, (w, h), k);
        let mut rng = scratchart_design::scenes::Rng::new(3);
        let mut draw = |gains: [f64; 3], q: Option<u8>| {
            shrunk_photo_draw(&light, 0.0, true, gains, q, &mut || rng.normal()).unwrap()
        };
        let model: Vec<f32> = {
            let sub = crate::photo::Gray {
                width: ss * w,
                height: ss * h,
                data: lit.iter().map(|&l| crate::encoding::encode_f32(l)).collect(),
            };
            crate::photo::resize(&sub, w, h).data
        };
        let dist = |a: &[f32], b: &[f32]| {
            (a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
        };
        let cast = [1.25, 1.0, 0.8];
        let plain = draw([1.0; 3], None);
        let plain_cast = draw(cast, None);
        assert!(dist(&plain, &model) < 0.003, "{}", dist(&plain, &model));
        assert!(dist(&plain_cast, &model) < 0.01, "{}", dist(&plain_cast, &model));
        let change = |a: Vec<f32>, b: &[f32]| -> Vec<f32> { a.iter().zip(b).map(|(x, y)| x - y).collect() };
        let grey_jpeg = change(draw([1.0; 3], Some(70)), &plain);
        let cast_jpeg = change(draw(cast, Some(70)), &plain_cast);
        let none = vec![0.0; grey_jpeg.len()];
        assert!(dist(&grey_jpeg, &none) > 0.0005, "{}", dist(&grey_jpeg, &none));
        assert!(
            dist(&cast_jpeg, &grey_jpeg) > 0.2 * dist(&grey_jpeg, &none),
            "{} against {}",
            dist(&cast_jpeg, &grey_jpeg),
            dist(&grey_jpeg, &none)
        );
    }

    /// The fit's JPEG change of a shrunk photo is as large as the photo's: the model's light at
    /// its subpixels, spread smoothly over the photo's own pixels, through the photo's JPEG and
    /// shrink, changes by as much as a photo of the same light made four times finer and resized
    /// (as `phone::take_of` makes it): rms 0.00059 against 0.00060 here. Blocks of the model's
    /// subpixels with sharp edges (before) changed by 0.00074, a quarter more. Pixel by pixel a
    /// noiseless photo's change is not followed (the miss is about the two changes added in
    /// quadrature, 0.00083, with or without a dither of 0.25 to 2 steps in the draws): which
    /// way JPEG rounds a block depends on light the model has only approximately.
    #[test]
    fn a_shrunk_jpegs_change_is_that_of_a_photo_of_the_same_light() {
        let (w, h, ss, k, q) = (32u32, 32u32, 2u32, 8u32, 86u8);
        let fine = 4u32;
        // Thin bright grooves of two turns on a dark plate, a groove about a subpixel wide.
        let light = |x: f64, y: f64| {
            let a = ((x * 0.37 + y * 0.11).sin() * 6.0).cos();
            let b = (0.5 * (x + y) / 1.7).sin();
            0.01 + 0.4 * (-(1.0 - a) * 8.0).exp() + 0.2 * (-(1.0 - b * b) * 30.0).exp()
        };
        let field = |s: u32| -> Vec<f32> {
            (0..h * s)
                .flat_map(|j| (0..w * s).map(move |i| (i, j)))
                .map(|(i, j)| light((i as f64 + 0.5) / s as f64, (j as f64 + 0.5) / s as f64) as f32)
                .collect()
        };
        // The photo: its light at four times the view, resized to its own pixels, 8 bits,
        // with and without the JPEG, shrunk by k in light.
        let native = scratchart_render::io::resize_bilinear(&field(fine), fine * w, fine * h, k * w, k * h);
        let bytes: Vec<u8> = native
            .iter()
            .map(|&l| (crate::encoding::encode(l as f64).clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        let shrunk = |q: Option<u8>| {
            let full = crate::photo::Gray {
                width: k * w,
                height: k * h,
                data: saved_grey(&bytes, k * w, k * h, false, q).unwrap(),
            };
            crate::photo::resize(&full, w, h).data
        };
        let photo_change: Vec<f64> = shrunk(Some(q))
            .iter()
            .zip(shrunk(None))
            .map(|(a, b)| (a - b) as f64)
            .collect();
        // The fit's: its light at ss times the view (the fine light averaged there).
        let sub = crate::photo::resize(
            &crate::photo::Gray {
                width: fine * w,
                height: fine * h,
                data: field(fine).iter().map(|&l| crate::encoding::encode_f32(l)).collect(),
            },
            ss * w,
            ss * h,
        );
        let lit: Vec<f32> = sub
            .data
            .iter()
            .map(|&d| crate::encoding::decode(d as f64) as f32)
            .collect();
        let light = ShrunkLight::of(&lit, ss, (w, h), k);
        let draw = |q: Option<u8>| shrunk_photo_draw(&light, 0.0, false, [1.0; 3], q, &mut || 0.0).unwrap();
        let fit_change: Vec<f64> = draw(Some(q))
            .iter()
            .zip(draw(None))
            .map(|(a, b)| (a - b) as f64)
            .collect();
        let rms = |v: &mut dyn Iterator<Item = f64>| {
            let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
            (s / n as f64).sqrt()
        };
        let shown = rms(&mut photo_change.iter().copied());
        let miss = rms(&mut photo_change.iter().zip(&fit_change).map(|(a, b)| a - b));
        let fit_rms = rms(&mut fit_change.iter().copied());
        eprintln!("the photo's JPEG change rms {shown:.5}, the fit's {fit_rms:.5}, the fit's miss of it {miss:.5}");
        assert!(shown > 2e-4, "the JPEG changed the shrunk photo by {shown}: no test");
        assert!(
            (fit_rms - shown).abs() < 0.1 * shown,
            "the fit's JPEG change is {fit_rms} where the photo's is {shown}"
        );
    }
}
