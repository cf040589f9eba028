//! Photos of the card: PNG or JPEG straight from a phone (any size, colour or grey, EXIF
//! orientation applied) as grey display values in [0, 1].
use std::path::Path;

/// A grey image, display values in [0, 1], row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Gray {
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

impl Gray {
    pub(crate) fn at(&self, x: i64, y: i64) -> f32 {
        let xx = x.clamp(0, self.width as i64 - 1) as usize;
        let yy = y.clamp(0, self.height as i64 - 1) as usize;
        self.data[yy * self.width as usize + xx]
    }

    /// Bilinear sample at image point (sx, sy) (pixel (i, j) covers [i, i+1] x [j, j+1]);
    /// `None` outside the image.
    pub fn sample(&self, sx: f64, sy: f64) -> Option<f32> {
        if !(sx >= 0.0 && sy >= 0.0 && sx <= self.width as f64 && sy <= self.height as f64) {
            return None;
        }
        let (x, y) = (sx - 0.5, sy - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.at(x0, y0) * (1.0 - fx) + self.at(x0 + 1, y0) * fx;
        let bot = self.at(x0, y0 + 1) * (1.0 - fx) + self.at(x0 + 1, y0 + 1) * fx;
        Some(top * (1.0 - fy) + bot * fy)
    }
}

impl Gray {
    /// Catmull-Rom (cubic) sample at image point (sx, sy): it smooths far less than bilinear
    /// sampling, whose blur changes with the sub-pixel phase and would bias the fit's groove
    /// shapes. `None` outside the image.
    pub fn sample_cubic(&self, sx: f64, sy: f64) -> Option<f32> {
        if !(sx >= 0.0 && sy >= 0.0 && sx <= self.width as f64 && sy <= self.height as f64) {
            return None;
        }
        let (x, y) = (sx - 0.5, sy - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let k = |t: f64| {
            let (t2, t3) = (t * t, t * t * t);
            [
                -0.5 * t3 + t2 - 0.5 * t,
                1.5 * t3 - 2.5 * t2 + 1.0,
                -1.5 * t3 + 2.0 * t2 + 0.5 * t,
                0.5 * t3 - 0.5 * t2,
            ]
        };
        let (kx, ky) = (k(fx), k(fy));
        let (x0, y0) = (x0 as i64, y0 as i64);
        let mut acc = 0.0f64;
        for (j, wy) in ky.iter().enumerate() {
            let mut row = 0.0f64;
            for (i, wx) in kx.iter().enumerate() {
                row += wx * self.at(x0 - 1 + i as i64, y0 - 1 + j as i64) as f64;
            }
            acc += wy * row;
        }
        Some(acc as f32)
    }
}

/// Reads a photo as grey display values: PNG or JPEG, 8 or 16 bit, colour or grey, with the
/// EXIF orientation applied (a phone stores portrait shots turned).
pub fn load_photo(path: &Path) -> Result<Gray, String> {
    load_photo_with_channels(path).map(|p| p.0)
}

/// How much less noisy a photo's grey is than each of its colour channels, when their noise is
/// independent: the grey is 0.2126 R + 0.7152 G + 0.0722 B (Rec. 709), so its noise is 0.749
/// of theirs. A sensor's noise is clipped at black in each channel before the grey is formed,
/// so the lift of a dark plate follows the channels' noise, not the grey's.
pub const LUMA_NOISE: f64 = 0.749_4;

/// Rec. 709 luma weights of red, green and blue: the grey the fit reads from a colour photo
/// (the `image` crate's).
pub const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// What a colour photo's channels say beyond its grey.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channels {
    /// The grey's noise over its channels' (from [`LUMA_NOISE`] where each channel's noise is
    /// its own, to 1 where they share it).
    pub noise_share: f64,
    /// The white balance: each channel's light over green's where none is clipped (the median
    /// ratio over pixels between 0.1 and 0.9 in every channel; 1 where fewer than 200 are). A
    /// channel with more gain clips at less light, so the grey of a bright groove is not the
    /// grey's light clipped once (`fit::camera`).
    pub gains: [f64; 3],
}

/// The white balance of an RGB photo (see [`Channels::gains`]).
fn channel_gains(rgb: &image::Rgb32FImage) -> [f64; 3] {
    let lin = |d: f32| crate::encoding::decode(d as f64);
    let n = rgb.width() as usize * rgb.height() as usize;
    // At most about 2 million pixels looked at.
    let stride = n.div_ceil(2_000_000).max(1);
    let (mut r, mut b) = (Vec::new(), Vec::new());
    for p in rgb.pixels().step_by(stride) {
        if p.0.iter().all(|c| (0.1..=0.9).contains(c)) {
            let g = lin(p[1]);
            r.push(lin(p[0]) / g);
            b.push(lin(p[2]) / g);
        }
    }
    if r.len() < 200 {
        return [1.0; 3];
    }
    let mid = |v: &mut Vec<f64>| {
        let m = v.len() / 2;
        *v.select_nth_unstable_by(m, |a, b| a.total_cmp(b)).1
    };
    [mid(&mut r), 1.0, mid(&mut b)]
}

/// [`load_photo`], and for a colour photo what its channels say ([`Channels`]); `None` for a
/// grey photo.
pub fn load_photo_with_channels(path: &Path) -> Result<(Gray, Option<Channels>), String> {
    use image::ImageDecoder as _;
    let name = path.display();
    // The bytes once: other kinds (HEIC, raw, WebP) and a JPEG cut short refused, naming it.
    let bytes = scratchart_render::io::read_image_bytes(path).map_err(|e| format!("photo: {e}"))?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read photo `{name}`: {e}"))?;
    let mut decoder = reader
        .into_decoder()
        .map_err(|e| format!("photo `{name}` is not a PNG or JPEG image I can read: {e}"))?;
    let orientation = decoder
        .orientation()
        .unwrap_or(image::metadata::Orientation::NoTransforms);
    let mut img =
        image::DynamicImage::from_decoder(decoder).map_err(|e| format!("photo `{name}` cannot be decoded: {e}"))?;
    img.apply_orientation(orientation);
    let g = img.to_luma32f();
    // The grey's noise over its channels' (each measured as `pixel_noise` measures it): 1 where
    // the channels carry the same noise (a grey photo, or noise added to grey), about 0.75 where
    // each has its own (a sensor's), between where demosaicing shares some.
    let factor = if img.color().has_color() {
        let rgb = img.to_rgb32f();
        let (w, h) = (rgb.width(), rgb.height());
        let channel = |c: usize| Gray {
            width: w,
            height: h,
            data: rgb.pixels().map(|p| p[c]).collect(),
        };
        let grey = Gray {
            width: w,
            height: h,
            data: g.as_raw().clone(),
        };
        let chans: f64 = (0..3).map(|c| crate::photo::pixel_noise(&channel(c))).sum::<f64>() / 3.0;
        let gn = crate::photo::pixel_noise(&grey);
        Some(Channels {
            noise_share: if chans > 0.0 {
                (gn / chans).clamp(LUMA_NOISE, 1.0)
            } else {
                1.0
            },
            gains: channel_gains(&rgb),
        })
    } else {
        None
    };
    if g.width() < 16 || g.height() < 16 {
        return Err(format!(
            "photo `{name}` is {}x{} pixels: too small to show the card",
            g.width(),
            g.height()
        ));
    }
    Ok((
        Gray {
            width: g.width(),
            height: g.height(),
            data: g.into_raw(),
        },
        factor,
    ))
}

/// The EXIF block of a photo (its TIFF bytes), when it has one.
fn exif_block(path: &Path) -> Option<Vec<u8>> {
    use image::ImageDecoder as _;
    let mut decoder = image::ImageReader::open(path)
        .ok()?
        .with_guessed_format()
        .ok()?
        .into_decoder()
        .ok()?;
    decoder.exif_metadata().ok()?
}

/// The 35 mm equivalent focal length a photo's EXIF gives (`crate::exif`), when it has one.
pub fn focal_35mm(path: &Path) -> Option<f64> {
    crate::exif::focal_35mm(&exif_block(path)?)
}

/// How many times larger than the camera saved it a photo is, where its EXIF says the saved
/// size and the photo is that size scaled evenly (an app's resize that kept the EXIF; a crop
/// scales the sides unevenly and gives `None`, as does a photo at its saved size).
pub fn resized_since_saved(path: &Path, width: u32, height: u32) -> Option<(f64, (u32, u32))> {
    let (sw, sh) = crate::exif::pixel_dimensions(&exif_block(path)?)?;
    // Compared as sides, long with long: the orientation tag may turn the photo.
    let (a, b) = (width.max(height) as f64, width.min(height) as f64);
    let (sa, sb) = (sw.max(sh) as f64, sw.min(sh) as f64);
    let (ra, rb) = (a / sa, b / sb);
    // Even to within a pixel of each side (a resize rounds each side on its own).
    let even = (ra - rb).abs() <= 1.0 / sb + 1.0 / sa + 1e-9;
    let resized = (a - sa).abs() > 1.0 || (b - sb).abs() > 1.0;
    (even && resized).then_some((0.5 * (ra + rb), (sw, sh)))
}

/// The middle `w` x `h` pixels of `img` (what is left over split evenly between the sides, the
/// odd one at the right and bottom).
pub fn crop_centre(img: &Gray, w: u32, h: u32) -> Gray {
    let (w, h) = (w.min(img.width), h.min(img.height));
    if (w, h) == (img.width, img.height) {
        return img.clone();
    }
    let (x0, y0) = ((img.width - w) / 2, (img.height - h) / 2);
    let mut data = Vec::with_capacity((w * h) as usize);
    for y in y0..y0 + h {
        let row = (y * img.width) as usize;
        data.extend_from_slice(&img.data[row + x0 as usize..row + (x0 + w) as usize]);
    }
    Gray {
        width: w,
        height: h,
        data,
    }
}

/// The JPEG quality (IJG scale, 1 to 100) that the photo at `path` was saved with, when it is a
/// JPEG whose pixels are stored as shown (no EXIF turn): the quality whose standard luminance
/// table is nearest the file's first quantization table. `None` for a PNG, a turned JPEG or a
/// file without a table. The fit uses it to put the same JPEG round trip on its model where the
/// photo is compared on its own pixel grid (`fit::Data::jpeg`).
pub fn jpeg_quality(path: &Path) -> Option<u8> {
    let bytes = std::fs::read(path).ok()?;
    if bytes.len() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8 {
        return None;
    }
    let turned = image::ImageReader::open(path)
        .ok()?
        .with_guessed_format()
        .ok()?
        .into_decoder()
        .ok()
        .and_then(|mut d| {
            use image::ImageDecoder as _;
            d.orientation().ok()
        })
        .is_some_and(|o| o != image::metadata::Orientation::NoTransforms);
    if turned {
        return None;
    }
    jpeg_table_quality(&bytes)
}

/// The quality (IJG scale) of a JPEG file's bytes, however its pixels are stored: the quality
/// whose standard luminance table is nearest its first quantization table. `None` for what is
/// not a JPEG with a table. What a shrunk photo's JPEG did to its noise follows it
/// (`fit::noise`).
pub fn jpeg_table_quality(bytes: &[u8]) -> Option<u8> {
    if bytes.len() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8 {
        return None;
    }
    let table = luma_table(bytes)?;
    (1..=100u8).min_by_key(|&q| {
        ijg_luma_table(q)
            .iter()
            .zip(&table)
            .map(|(a, b)| (*a as i64 - *b as i64).abs())
            .sum::<i64>()
    })
}

/// The first quantization table of a JPEG file (the luminance one), in zigzag order.
fn luma_table(b: &[u8]) -> Option<[u16; 64]> {
    let mut i = 2;
    while i + 4 <= b.len() {
        if b[i] != 0xFF {
            return None;
        }
        let marker = b[i + 1];
        if marker == 0xD8 || (0xD0..=0xD7).contains(&marker) || marker == 0x01 {
            i += 2;
            continue;
        }
        let len = u16::from_be_bytes([b[i + 2], b[i + 3]]) as usize;
        if marker == 0xDB {
            let seg = b.get(i + 4..i + 2 + len)?;
            let (pq, body) = (seg.first()? >> 4, &seg[1..]);
            let mut t = [0u16; 64];
            for (k, v) in t.iter_mut().enumerate() {
                *v = if pq == 0 {
                    *body.get(k)? as u16
                } else {
                    u16::from_be_bytes([*body.get(2 * k)?, *body.get(2 * k + 1)?])
                };
            }
            return Some(t);
        }
        if marker == 0xDA {
            return None;
        }
        i += 2 + len;
    }
    None
}

/// The IJG (libjpeg) luminance table at quality `q`, in zigzag order, as the `image` crate and
/// most encoders write it.
fn ijg_luma_table(q: u8) -> [u16; 64] {
    const BASE: [u16; 64] = [
        16, 11, 12, 14, 12, 10, 16, 14, 13, 14, 18, 17, 16, 19, 24, 40, 26, 24, 22, 22, 24, 49, 35, 37, 29, 40, 58, 51,
        61, 60, 57, 51, 56, 55, 64, 72, 92, 78, 64, 68, 87, 69, 55, 56, 80, 109, 81, 87, 95, 98, 103, 104, 103, 62, 77,
        113, 121, 112, 100, 120, 92, 101, 103, 99,
    ];
    let q = q.clamp(1, 100) as u32;
    let scale = if q < 50 { 5000 / q } else { 200 - 2 * q };
    BASE.map(|b| ((b as u32 * scale + 50) / 100).clamp(1, 255) as u16)
}

/// `img` (display values, `w` x `h`) through a grey JPEG at quality `q` and back: what a
/// camera's JPEG does to a picture of the card, for the model to do the same.
pub fn jpeg_round_trip(img: &[f32], w: u32, h: u32, q: u8) -> Vec<f32> {
    let bytes: Vec<u8> = img.iter().map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8).collect();
    let mut buf = Vec::new();
    let enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, q);
    if image::ImageEncoder::write_image(enc, &bytes, w, h, image::ExtendedColorType::L8).is_err() {
        return img.to_vec();
    }
    match image::load_from_memory_with_format(&buf, image::ImageFormat::Jpeg) {
        Ok(d) => d.to_luma8().into_raw().into_iter().map(|x| x as f32 / 255.0).collect(),
        Err(_) => img.to_vec(),
    }
}

/// The photo resampled to `w` x `h` as the engine's pixels would see it: each output pixel is the
/// exact area average of the input pixels it covers, taken in linear light (display values are
/// raised to 2.2, averaged, and encoded again), because a pixel of the render integrates light
/// over its footprint. Averaging display values instead would dim thin bright grooves and bias
/// the fit. Enlarging (a photo smaller than the view) uses the same rule: each output pixel takes
/// the input pixels under it.
pub fn resize(img: &Gray, w: u32, h: u32) -> Gray {
    if img.width == w && img.height == h {
        return img.clone();
    }
    let (sx, sy) = (img.width as f64 / w as f64, img.height as f64 / h as f64);
    // Per output column (row): the input columns (rows) it covers and their overlap weights.
    let spans = |n_out: u32, scale: f64, n_in: u32| -> Vec<Vec<(usize, f64)>> {
        (0..n_out)
            .map(|o| {
                let (a, b) = (o as f64 * scale, (o + 1) as f64 * scale);
                let mut v = Vec::new();
                let mut i = a.floor() as i64;
                while (i as f64) < b && i < n_in as i64 {
                    let lo = a.max(i as f64);
                    let hi = b.min(i as f64 + 1.0);
                    if hi > lo && i >= 0 {
                        v.push((i as usize, (hi - lo) / (b - a)));
                    }
                    i += 1;
                }
                v
            })
            .collect()
    };
    let (cols, rows) = (spans(w, sx, img.width), spans(h, sy, img.height));
    let lin: Vec<f64> = img.data.iter().map(|&d| crate::encoding::decode(d as f64)).collect();
    let iw = img.width as usize;
    let mut tmp = vec![0.0f64; w as usize * img.height as usize];
    for y in 0..img.height as usize {
        for (x, span) in cols.iter().enumerate() {
            tmp[y * w as usize + x] = span.iter().map(|&(i, wt)| wt * lin[y * iw + i]).sum();
        }
    }
    let mut data = vec![0f32; (w * h) as usize];
    for (y, span) in rows.iter().enumerate() {
        for x in 0..w as usize {
            let l: f64 = span.iter().map(|&(j, wt)| wt * tmp[j * w as usize + x]).sum();
            data[y * w as usize + x] = crate::encoding::encode(l) as f32;
        }
    }
    Gray {
        width: w,
        height: h,
        data,
    }
}

/// The standard normal distribution function (erf by Abramowitz and Stegun 7.1.26: error
/// below 1.5e-7).
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly =
        t * (0.254_829_592 + t * (-0.284_496_736 + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// The photo's own pixel noise (display units): the robust spread of each pixel less the mean
/// of its four neighbours (sqrt(5/4) sigma for independent noise), over the image.
pub fn pixel_noise(img: &Gray) -> f64 {
    pixel_noise_in(img, None)
}

/// [`pixel_noise`] over the pixels of `mask` only (all when `None`): a photo's dark background
/// clips its noise at black.
pub fn pixel_noise_in(img: &Gray, mask: Option<&[bool]>) -> f64 {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut d = Vec::with_capacity(w * h / 4);
    for y in (1..h.saturating_sub(1)).step_by(2) {
        for x in (1..w.saturating_sub(1)).step_by(2) {
            let i = y * w + x;
            if mask.is_some_and(|m| !m[i]) {
                continue;
            }
            let m = 0.25 * (img.data[i - 1] + img.data[i + 1] + img.data[i - w] + img.data[i + w]);
            d.push((img.data[i] - m).abs());
        }
    }
    1.4826 * median(&mut d) as f64 / 1.25f64.sqrt()
}

/// The middle value of an image's pixels (the upper of the two middles; 0 for none): the one
/// median of the calibration's images (benchmarks use `scratchart::bench::median`).
pub(crate) fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let n = v.len();
    *v.select_nth_unstable_by(n / 2, |a, b| a.total_cmp(b)).1
}

#[cfg(test)]
mod photo_tests {
    use super::*;

    #[test]
    fn the_white_balance_is_read_from_the_channels() {
        // A photo whose red has 1.2 and blue 0.85 times green's light, over a ramp of levels,
        // with dark and clipped pixels that must not count.
        let lin = crate::encoding::decode;
        let disp = |l: f64| crate::encoding::encode(l.min(1.0));
        let img = image::Rgb32FImage::from_fn(64, 64, |x, y| {
            let l = lin(0.05 + 0.9 * (x + 64 * y) as f64 / 4096.0);
            image::Rgb([disp(1.2 * l) as f32, disp(l) as f32, disp(0.85 * l) as f32])
        });
        let g = channel_gains(&img);
        assert!(
            (g[0] - 1.2).abs() < 0.01 && g[1] == 1.0 && (g[2] - 0.85).abs() < 0.01,
            "{g:?}"
        );
        // Too few pixels in range: no cast is claimed.
        let dark = image::Rgb32FImage::from_pixel(64, 64, image::Rgb([0.02, 0.02, 0.02]));
        assert_eq!(channel_gains(&dark), [1.0; 3]);
    }

    /// The quality a JPEG was saved at is read back from its table, for any quality; a PNG has none.
    /// A card photo cut short (an interrupted copy) is refused with its name, not decoded with
    /// grey where its data stops.
    #[test]
    fn a_photo_cut_short_is_refused() {
        let d = std::env::temp_dir().join(format!("scratchart-photo-cut-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let img = image::GrayImage::from_fn(64, 48, |x, y| image::Luma([((x * 3 + y * 2) % 256) as u8]));
        let whole = d.join("whole.jpg");
        img.save(&whole).unwrap();
        assert!(load_photo(&whole).is_ok());
        let bytes = std::fs::read(&whole).unwrap();
        let cut = d.join("card_cut.jpg");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let e = load_photo(&cut).unwrap_err();
        assert!(e.contains("card_cut.jpg") && e.contains("cut short"), "{e}");
    }

    #[test]
    fn reads_the_jpeg_quality_back() {
        let dir = std::env::temp_dir().join(format!("scratchart-jpegq-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let img = image::RgbImage::from_fn(40, 24, |x, y| image::Rgb([(x * 6) as u8, (y * 9) as u8, 128]));
        for q in [35u8, 70, 90, 97] {
            let p = dir.join(format!("q{q}.jpg"));
            let mut f = std::fs::File::create(&p).unwrap();
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut f, q)
                .encode_image(&img)
                .unwrap();
            drop(f);
            assert_eq!(jpeg_quality(&p), Some(q));
        }
        let p = dir.join("a.png");
        img.save(&p).unwrap();
        assert_eq!(jpeg_quality(&p), None);
        // The round trip changes a sharp edge, and leaves a flat grey as it is.
        let edge: Vec<f32> = (0..16 * 16).map(|i| if i % 16 < 7 { 0.1 } else { 0.9 }).collect();
        let back = jpeg_round_trip(&edge, 16, 16, 50);
        assert!(back.iter().zip(&edge).any(|(a, b)| (a - b).abs() > 0.01));
        let flat = vec![0.5f32; 64];
        assert!(jpeg_round_trip(&flat, 8, 8, 50).iter().all(|x| (x - 0.5).abs() < 0.01));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A colour JPEG straight from a phone: stored turned, with the EXIF orientation tag saying
    /// how to show it. It reads back upright and grey.
    #[test]
    fn a_turned_colour_jpeg_reads_back_upright() {
        use image::ImageEncoder as _;
        // Upright: 64 x 32, bright (red) top-left quadrant on a dark background.
        let upright = image::RgbImage::from_fn(64, 32, |x, y| {
            if x < 32 && y < 16 {
                image::Rgb([250, 40, 40])
            } else {
                image::Rgb([20, 20, 20])
            }
        });
        // Stored turned a quarter counter-clockwise; orientation 6 tells a viewer to turn it back.
        let stored = image::imageops::rotate270(&upright);
        // EXIF (TIFF, big-endian): one IFD entry, Orientation (0x0112), SHORT, 1, value 6.
        let exif: Vec<u8> = vec![
            b'M', b'M', 0, 42, 0, 0, 0, 8, // header, IFD at 8
            0, 1, // one entry
            0x01, 0x12, 0, 3, 0, 0, 0, 1, 0, 6, 0, 0, // Orientation = 6
            0, 0, 0, 0, // no next IFD
        ];
        let mut buf = Vec::new();
        let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 95);
        enc.set_exif_metadata(exif).unwrap();
        enc.write_image(
            stored.as_raw(),
            stored.width(),
            stored.height(),
            image::ExtendedColorType::Rgb8,
        )
        .unwrap();
        let dir = std::env::temp_dir().join(format!("scratchart-photo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("phone.jpg");
        std::fs::write(&p, &buf).unwrap();
        let g = load_photo(&p).unwrap();
        assert_eq!((g.width, g.height), (64, 32), "the orientation was not applied");
        let mean = |x0: u32, y0: u32| {
            let mut s = 0.0;
            for y in y0 + 4..y0 + 12 {
                for x in x0 + 8..x0 + 24 {
                    s += g.data[(y * 64 + x) as usize];
                }
            }
            s / (8.0 * 16.0)
        };
        let (tl, tr, bl) = (mean(0, 0), mean(32, 0), mean(0, 16));
        assert!(
            tl > 0.25 && tr < 0.12 && bl < 0.12,
            "top-left {tl}, top-right {tr}, bottom-left {bl}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Shrinking keeps the light (area average in linear light): a one-pixel bright line in a
    /// 4x image keeps its total light in the 1x image.
    #[test]
    fn shrinking_averages_light_not_display_values() {
        let mut data = vec![0.0f32; 16 * 16];
        for y in 0..16 {
            data[y * 16 + 5] = 1.0; // a bright column
        }
        let g = Gray {
            width: 16,
            height: 16,
            data,
        };
        let s = resize(&g, 4, 4);
        // Column 5 falls in output column 1 and covers a quarter of it: linear 0.25.
        let expect = crate::encoding::encode(0.25) as f32;
        for y in 0..4 {
            assert!((s.data[y * 4 + 1] - expect).abs() < 1e-6, "{}", s.data[y * 4 + 1]);
            assert_eq!(s.data[y * 4], 0.0);
        }
        // A non-integer factor keeps the total light too.
        let t = resize(&g, 6, 6);
        let total: f64 = t.data.iter().map(|&d| crate::encoding::decode(d as f64)).sum::<f64>() * (16.0 * 16.0) / 36.0;
        assert!((total - 16.0).abs() < 1e-6, "{total}");
    }
}
