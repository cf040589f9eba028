//! Image files: PFM (linear float images), PNG (display images), PNG/JPEG targets, resizing,
//! and the atomic file writer every writer in the engine goes through.
//!
//! Conventions (engine/docs/model.md section 6):
//! - In memory, images are row-major with row 0 the TOP image row (sy = 0).
//! - PFM files store rows BOTTOM row first, as the PFM format orders them. [`write_pfm`] writes
//!   grayscale `Pf` with scale -1.0 (little endian); [`read_pfm`] reads `Pf` and `PF` (colour,
//!   converted to Rec. 709 luma) in either byte order and returns top-row-first data.
//! - Display PNGs store round(255 min(1, L^(1/2.2))) as 8-bit gray.
//! - Every file is written atomically: a temporary file in the same directory, fsync, rename.

use std::fs;
use std::path::{Path, PathBuf};

use scratchart_model::fsio::WriteError;

/// An image file could not be read or written. Every variant names the path.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    #[error("cannot {action} `{path}`: {cause}")]
    Io {
        action: &'static str,
        path: PathBuf,
        /// The OS error (part of the message, so not repeated as a source).
        cause: std::io::Error,
    },
    #[error("`{path}` is not a valid {kind} file: {msg}")]
    Format {
        kind: &'static str,
        path: PathBuf,
        msg: String,
    },
    #[error("cannot decode or encode image `{path}`: {cause}")]
    Image { path: PathBuf, cause: image::ImageError },
    #[error("bad image arguments for `{path}`: {msg}")]
    Args { path: PathBuf, msg: String },
    /// A file of a kind this does not read (a phone's HEIC, a raw DNG, a messenger's WebP),
    /// named with what to do instead ([`unread_format`]).
    #[error("`{path}` is {what}: {advice}")]
    Unread {
        what: &'static str,
        path: PathBuf,
        advice: &'static str,
    },
}

impl IoError {
    /// Whether this is a failure to write an output (as opposed to reading an input).
    pub fn is_output(&self) -> bool {
        matches!(self, IoError::Io { action, .. } if *action != "read")
    }
}

fn io_err(action: &'static str, path: &Path, source: std::io::Error) -> IoError {
    IoError::Io {
        action,
        path: path.to_path_buf(),
        cause: source,
    }
}

fn check_dims(path: &Path, width: u32, height: u32, len: usize) -> Result<(), IoError> {
    let expect = width as usize * height as usize;
    if width == 0 || height == 0 || expect != len {
        return Err(IoError::Args {
            path: path.to_path_buf(),
            msg: format!("{width}x{height} image needs {expect} values (width and height > 0), got {len}"),
        });
    }
    Ok(())
}

/// Write `bytes` to `path` atomically: write a temporary file in the same directory, fsync it,
/// then rename it over `path` (and, on Unix, fsync the directory). A reader never sees a
/// partially written file; on error the temporary file is removed. The writer itself is
/// [`scratchart_model::fsio::write_atomic`], shared with the crates that build without the GPU.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    Ok(scratchart_model::fsio::write_atomic(path, bytes)?)
}

impl From<WriteError> for IoError {
    fn from(e: WriteError) -> IoError {
        match e {
            WriteError::Io { action, path, cause } => IoError::Io { action, path, cause },
            WriteError::NoFileName { path } => IoError::Args {
                path,
                msg: "the path has no file name".into(),
            },
        }
    }
}

/// Encode a grayscale PFM (`Pf`, scale -1.0 = little endian). `data` is top row first; the file
/// stores the bottom row first.
pub fn encode_pfm(width: u32, height: u32, data_top_row_first: &[f32]) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let header = format!("Pf\n{width} {height}\n-1.0\n");
    let mut out = Vec::with_capacity(header.len() + 4 * w * h);
    out.extend_from_slice(header.as_bytes());
    for row in (0..h).rev() {
        for v in &data_top_row_first[row * w..(row + 1) * w] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// Write a grayscale PFM file atomically (see [`encode_pfm`]).
pub fn write_pfm(path: &Path, width: u32, height: u32, data_top_row_first: &[f32]) -> Result<(), IoError> {
    check_dims(path, width, height, data_top_row_first.len())?;
    write_atomic(path, &encode_pfm(width, height, data_top_row_first))
}

/// Read a PFM file (`Pf` grayscale or `PF` colour, converted to Rec. 709 luma; either byte
/// order). Returns (width, height, data) with data top row first.
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<f32>), IoError> {
    let bytes = fs::read(path).map_err(|e| io_err("read", path, e))?;
    decode_pfm(&bytes).map_err(|msg| IoError::Format {
        kind: "PFM",
        path: path.to_path_buf(),
        msg,
    })
}

/// Decode PFM bytes; see [`read_pfm`].
pub fn decode_pfm(bytes: &[u8]) -> Result<(u32, u32, Vec<f32>), String> {
    // Header: three whitespace-separated tokens, then exactly one whitespace byte before data.
    let mut pos = 0usize;
    let mut tokens: Vec<String> = Vec::new();
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if pos >= bytes.len() {
            return Err(format!(
                "the header ends early (found {} of 4 fields: magic, width, height, scale)",
                tokens.len()
            ));
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
            if pos - start > 64 {
                return Err("a header field is too long; is this a PFM file?".into());
            }
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
        if tokens.len() == 1 && tokens[0] != "Pf" && tokens[0] != "PF" {
            return Err(format!(
                "magic is `{}`, expected `Pf` (gray) or `PF` (colour)",
                tokens[0]
            ));
        }
    }
    if pos >= bytes.len() || !bytes[pos].is_ascii_whitespace() {
        return Err("no whitespace byte after the scale field".into());
    }
    pos += 1;
    let channels = if tokens[0] == "PF" { 3 } else { 1 };
    let width: u32 = tokens[1]
        .parse()
        .map_err(|_| format!("width `{}` is not a positive integer", tokens[1]))?;
    let height: u32 = tokens[2]
        .parse()
        .map_err(|_| format!("height `{}` is not a positive integer", tokens[2]))?;
    if width == 0 || height == 0 {
        return Err(format!("size {width}x{height} is empty"));
    }
    let scale: f64 = tokens[3]
        .parse()
        .map_err(|_| format!("scale `{}` is not a number", tokens[3]))?;
    if !scale.is_finite() || scale == 0.0 {
        return Err(format!("scale `{}` must be a non-zero finite number", tokens[3]));
    }
    let little = scale < 0.0;
    let (w, h) = (width as usize, height as usize);
    let need = w
        .checked_mul(h)
        .and_then(|n| n.checked_mul(4 * channels))
        .ok_or("size overflows")?;
    let data = &bytes[pos..];
    if data.len() < need {
        return Err(format!(
            "{width}x{height}x{channels} image needs {need} data bytes, file has {}",
            data.len()
        ));
    }
    let read = |k: usize| -> f32 {
        let b = [data[4 * k], data[4 * k + 1], data[4 * k + 2], data[4 * k + 3]];
        if little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let mut out = vec![0f32; w * h];
    for file_row in 0..h {
        let row = h - 1 - file_row;
        for i in 0..w {
            let k = (file_row * w + i) * channels;
            out[row * w + i] = if channels == 1 {
                read(k)
            } else {
                0.2126 * read(k) + 0.7152 * read(k + 1) + 0.0722 * read(k + 2)
            };
        }
    }
    Ok((width, height, out))
}

/// Display value of a linear pixel: round(255 min(1, L^(1/2.2))) (engine/docs/model.md section 5).
/// Negative and NaN inputs give 0.
/// Display value of engine/docs/model.md section 5, I = L^(1/2.2), unclamped (0 for L <= 0; NaN stays NaN
/// so that a bad render shows up downstream).
pub fn display_value(l: f32) -> f32 {
    if l > 0.0 {
        l.powf(1.0 / crate::model::display::GAMMA as f32)
    } else if l.is_nan() {
        l
    } else {
        0.0
    }
}

pub fn display_byte(l: f32) -> u8 {
    if l.is_nan() || l <= 0.0 {
        return 0;
    }
    let i = crate::model::display::display(l as f64).min(1.0);
    (255.0 * i).round() as u8
}

/// Write the display PNG of a linear image (see [`display_byte`]). `linear` is top row first.
pub fn write_png_display(path: &Path, width: u32, height: u32, linear: &[f32]) -> Result<(), IoError> {
    check_dims(path, width, height, linear.len())?;
    let bytes: Vec<u8> = linear.iter().map(|&l| display_byte(l)).collect();
    write_png_gray(path, width, height, &bytes)
}

/// Write an 8-bit grayscale PNG atomically. `data` is top row first.
pub fn write_png_gray(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<(), IoError> {
    write_png(path, width, height, data, image::ExtendedColorType::L8)
}

/// Write an 8-bit RGB PNG atomically (plots). `data` is top row first, 3 bytes per pixel.
pub fn write_png_rgb(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<(), IoError> {
    write_png(path, width, height, data, image::ExtendedColorType::Rgb8)
}

/// An 8-bit PNG of `color` (L8 or Rgb8), encoded in memory and written atomically.
fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    data: &[u8],
    color: image::ExtendedColorType,
) -> Result<(), IoError> {
    use image::ImageEncoder;
    check_dims(path, width, height, data.len() / color.channel_count() as usize)?;
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(data, width, height, color)
        .map_err(|source| IoError::Image {
            path: path.to_path_buf(),
            cause: source,
        })?;
    write_atomic(path, &buf)
}

/// What a file that is not a PNG or JPEG is, by its first bytes, with what to do instead, for
/// the kinds a phone, a camera or a messenger gives: HEIF (an iPhone's photos by default, and
/// AVIF), a TIFF (a raw DNG from a phone's RAW mode, most cameras' raw files, or a scan), WebP
/// (what some messengers and web pages keep), GIF and BMP. `None` for anything else (a PNG, a
/// JPEG, or bytes this does not know, which the decoder then names).
///
/// Raw files are not read on purpose: the photo pipeline models a photo as the camera app
/// develops it (its tone curve, JPEG's blocks, the noise after demosaicing; the design's
/// pictures as display values), and a raw file is the sensor's mosaic before any of that.
pub fn unread_format(bytes: &[u8]) -> Option<(&'static str, &'static str)> {
    const EXPORT: &str = "this reads PNG or JPEG only; export the photo as a JPEG at its full size";
    let at = |i: usize, m: &[u8]| bytes.get(i..i + m.len()) == Some(m);
    if at(4, b"ftyp") {
        let brand = bytes.get(8..12).unwrap_or(&[]);
        let heif = [
            &b"heic"[..],
            b"heix",
            b"hevc",
            b"hevx",
            b"heim",
            b"heis",
            b"mif1",
            b"msf1",
        ];
        if brand == b"avif" || brand == b"avis" {
            return Some(("an AVIF image", EXPORT));
        }
        if heif.contains(&brand) {
            return Some((
                "a HEIC (HEIF) photo, an iPhone's default",
                "this reads PNG or JPEG only; export it as a JPEG at its full size (on the phone, \
                 Settings > Photos > Transfer to Mac or PC: Automatic, or Settings > Camera > Formats: \
                 Most Compatible before taking it; on a computer, any photo app's export as JPEG)",
            ));
        }
    }
    if at(0, b"II*\0") || at(0, b"MM\0*") {
        return Some((
            "a TIFF file (a phone's raw DNG, a camera's raw file, or a scan)",
            "this reads PNG or JPEG only, as the camera app develops a photo (a raw file is the \
             sensor's data before its tone curve and colour); take the photo with RAW off, or \
             export it as a JPEG at its full size",
        ));
    }
    if at(0, b"RIFF") && at(8, b"WEBP") {
        return Some((
            "a WebP image (as some messengers and web pages keep photos)",
            "this reads PNG or JPEG only; use the original photo from the phone (a messenger \
             also shrinks it), or export it as a JPEG at its full size",
        ));
    }
    if at(0, b"GIF8") {
        return Some(("a GIF image", EXPORT));
    }
    if at(0, b"BM") && bytes.len() >= 26 && at(6, &[0, 0, 0, 0]) {
        return Some(("a BMP image", EXPORT));
    }
    None
}

/// The bytes of an image file that its decoder may be given: a file of a kind this does not read
/// ([`unread_format`]) and a JPEG cut short ([`jpeg_cut_short`]) are refused, naming the file.
pub fn read_image_bytes(path: &Path) -> Result<Vec<u8>, IoError> {
    let bytes = fs::read(path).map_err(|e| io_err("read", path, e))?;
    if let Some((what, advice)) = unread_format(&bytes) {
        return Err(IoError::Unread {
            what,
            path: path.to_path_buf(),
            advice,
        });
    }
    if jpeg_cut_short(&bytes) {
        // The JPEG decoder fills what a cut-short file lacks with grey and reports nothing.
        return Err(IoError::Format {
            kind: "JPEG",
            path: path.to_path_buf(),
            msg: "it ends inside its image data (no end-of-image marker after the last scan): the file \
                  was cut short, by an interrupted copy or download; copy it again"
                .into(),
        });
    }
    Ok(bytes)
}

/// Read a PNG or JPEG image as gray values in [0, 1] (colour is converted to luma by the
/// `image` crate's Rec. 709 weights on the stored, display-encoded values; alpha is composited over black; any bit depth;
/// the EXIF orientation applied; other kinds and a JPEG cut short refused: [`read_image_bytes`]).
/// Returns (width, height, data) top row first.
pub fn read_image_gray(path: &Path) -> Result<(u32, u32, Vec<f32>), IoError> {
    let bytes = read_image_bytes(path)?;
    let img_err = |cause| IoError::Image {
        path: path.to_path_buf(),
        cause,
    };
    // With the EXIF orientation applied: a phone stores a portrait shot turned and says so there.
    let mut decoder = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| io_err("read", path, e))?
        .into_decoder()
        .map_err(img_err)?;
    let orientation =
        image::ImageDecoder::orientation(&mut decoder).unwrap_or(image::metadata::Orientation::NoTransforms);
    let mut img = image::DynamicImage::from_decoder(decoder).map_err(img_err)?;
    img.apply_orientation(orientation);
    // Any bit depth and colour type; an alpha channel is composited over black (a transparent
    // pixel asks for no light).
    let la = img.to_luma_alpha32f();
    let (w, h) = la.dimensions();
    let data: Vec<f32> = la
        .into_raw()
        .chunks_exact(2)
        .map(|p| (p[0] * p[1]).clamp(0.0, 1.0))
        .collect();
    Ok((w, h, data))
}

/// Whether `bytes` are a JPEG whose last scan (start-of-scan marker FF DA) is not followed by an
/// end-of-image marker (FF D9). Inside a scan's entropy-coded data every FF byte is followed by 00
/// or a restart marker, so FF D9 there is the image's end; an embedded thumbnail's end comes
/// before the main image's scan and does not count.
pub fn jpeg_cut_short(bytes: &[u8]) -> bool {
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return false;
    }
    let last_scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]);
    match last_scan {
        None => true,
        Some(s) => !bytes[s..].windows(2).any(|w| w == [0xFF, 0xD9]),
    }
}

/// Resize a one-channel image (top row first) with a separable tent filter aligned on pixel
/// centres. When enlarging this is plain bilinear interpolation; when shrinking by a factor k
/// the tent is widened k times (antialiased bilinear, as PIL's BILINEAR), so no detail aliases.
/// Edges are handled by renormalising the weights inside the image.
pub fn resize_bilinear(src: &[f32], sw: u32, sh: u32, dw: u32, dh: u32) -> Vec<f32> {
    assert_eq!(src.len(), sw as usize * sh as usize, "resize_bilinear: bad source size");
    assert!(sw > 0 && sh > 0 && dw > 0 && dh > 0, "resize_bilinear: empty image");
    let wx = tent_weights(sw as usize, dw as usize);
    let wy = tent_weights(sh as usize, dh as usize);
    let (sw, dw, dh) = (sw as usize, dw as usize, dh as usize);
    // Horizontal pass: sh x dw.
    let mut tmp = vec![0f32; sh as usize * dw];
    for y in 0..sh as usize {
        for (x, (start, ws)) in wx.iter().enumerate() {
            let row = &src[y * sw..(y + 1) * sw];
            let acc: f64 = ws.iter().enumerate().map(|(k, w)| w * row[start + k] as f64).sum();
            tmp[y * dw + x] = acc as f32;
        }
    }
    let mut out = vec![0f32; dh * dw];
    for (y, (start, ws)) in wy.iter().enumerate() {
        for x in 0..dw {
            let acc: f64 = ws
                .iter()
                .enumerate()
                .map(|(k, w)| w * tmp[(start + k) * dw + x] as f64)
                .sum();
            out[y * dw + x] = acc as f32;
        }
    }
    out
}

/// For each destination index: (first source index, normalised weights).
fn tent_weights(src_n: usize, dst_n: usize) -> Vec<(usize, Vec<f64>)> {
    let scale = src_n as f64 / dst_n as f64;
    let support = scale.max(1.0); // tent half-width in source pixels
    (0..dst_n)
        .map(|d| {
            let centre = (d as f64 + 0.5) * scale - 0.5; // in source pixel-centre coordinates
            let lo = ((centre - support).floor() as i64 + 1).max(0) as usize;
            let hi = ((centre + support).ceil() as i64 - 1).min(src_n as i64 - 1).max(0) as usize;
            let lo = lo.min(hi);
            let mut ws: Vec<f64> = (lo..=hi)
                .map(|s| (1.0 - ((s as f64 - centre) / support).abs()).max(0.0))
                .collect();
            let sum: f64 = ws.iter().sum();
            if sum > 0.0 {
                ws.iter_mut().for_each(|w| *w /= sum);
            } else {
                // Centre exactly between samples with zero weights cannot happen for support >= 1,
                // but keep a safe nearest-neighbour fallback.
                ws.iter_mut().for_each(|w| *w = 0.0);
                let nearest = (centre.round().max(0.0) as usize).clamp(lo, hi);
                ws[nearest - lo] = 1.0;
            }
            (lo, ws)
        })
        .collect()
}

/// A file that cannot be read or decoded is bad input (exit 3); one that cannot be written is a
/// runtime failure (exit 1).
impl scratchart_exit::ExitClass for IoError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(if self.is_output() {
            scratchart_exit::Class::Runtime
        } else {
            scratchart_exit::Class::Input
        })
    }
}
