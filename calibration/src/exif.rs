//! What a phone's photo says of its own camera: the EXIF focal length in 35 mm film terms
//! (`FocalLengthIn35mmFilm`, tag 0xA405 of the Exif IFD), which gives the field of view of the
//! whole frame: the fit's prior on the camera the card's marks recover (a card small in the
//! frame leaves the focal length and the distance trading). Read from the JPEG's APP1 block (the
//! image crate's decoder hands the TIFF bytes over); a minimal TIFF reader, both byte orders.
//! The simulator writes the same tag (`exif_blob`), as phones do.
//!
//! Also the size the camera saved the photo at (`PixelXDimension`, `PixelYDimension`, tags
//! 0xA002 and 0xA003): an app that enlarges a photo and keeps its EXIF leaves them as they were,
//! which tells an enlargement the photo's own pixels may not show (`resampled`).

/// The diagonal of 35 mm film, mm.
const FILM_DIAGONAL_MM: f64 = 43.267;

/// `FocalLengthIn35mmFilm` of the TIFF bytes of an EXIF block (without the "Exif\0\0" prefix,
/// as the image crate's `exif_metadata` gives them), when present and positive.
pub fn focal_35mm(tiff: &[u8]) -> Option<f64> {
    let v = exif_tag(tiff, 0xA405)?;
    (v > 0.0).then_some(v)
}

/// The width and height the camera saved the photo at (`PixelXDimension`, `PixelYDimension`),
/// as stored (before the orientation tag turns it), when both are present and positive.
pub fn pixel_dimensions(tiff: &[u8]) -> Option<(u32, u32)> {
    let (w, h) = (exif_tag(tiff, 0xA002)?, exif_tag(tiff, 0xA003)?);
    (w >= 1.0 && h >= 1.0).then_some((w as u32, h as u32))
}

/// The value of a SHORT or LONG tag of the Exif IFD.
fn exif_tag(tiff: &[u8], tag: u16) -> Option<f64> {
    let tiff = tiff.strip_prefix(b"Exif\0\0").unwrap_or(tiff);
    let big = match tiff.get(0..2)? {
        b"MM" => true,
        b"II" => false,
        _ => return None,
    };
    let u16_at = |o: usize| -> Option<u16> {
        let b = tiff.get(o..o + 2)?;
        Some(if big {
            u16::from_be_bytes([b[0], b[1]])
        } else {
            u16::from_le_bytes([b[0], b[1]])
        })
    };
    let u32_at = |o: usize| -> Option<u32> {
        let b = tiff.get(o..o + 4)?;
        Some(if big {
            u32::from_be_bytes([b[0], b[1], b[2], b[3]])
        } else {
            u32::from_le_bytes([b[0], b[1], b[2], b[3]])
        })
    };
    if u16_at(2)? != 42 {
        return None;
    }
    // An IFD's entries: (tag, type, count, value offset field's position).
    let entries = |ifd: usize| -> Option<Vec<(u16, u16, u32, usize)>> {
        let n = u16_at(ifd)? as usize;
        if n > 500 {
            return None;
        }
        (0..n)
            .map(|i| {
                let e = ifd + 2 + 12 * i;
                Some((u16_at(e)?, u16_at(e + 2)?, u32_at(e + 4)?, e + 8))
            })
            .collect()
    };
    let ifd0 = entries(u32_at(4)? as usize)?;
    let exif_at = ifd0.iter().find(|e| e.0 == 0x8769).and_then(|e| u32_at(e.3))? as usize;
    let exif = entries(exif_at)?;
    let (_, ty, count, at) = *exif.iter().find(|e| e.0 == tag)?;
    match (ty, count) {
        // SHORT
        (3, 1) => Some(u16_at(at)? as f64),
        // LONG
        (4, 1) => Some(u32_at(at)? as f64),
        _ => None,
    }
}

/// The focal length in pixels of a `w` x `h` photo whose whole frame a 35 mm equivalent focal
/// length `f35` covers (the frame's diagonal against film's).
pub fn focal_px(f35: f64, w: u32, h: u32) -> f64 {
    f35 * (w as f64).hypot(h as f64) / FILM_DIAGONAL_MM
}

/// The 35 mm equivalent focal length of a frame of aspect `aspect` (width over height) whose
/// vertical field of view is `fov_y_deg`.
pub fn focal_35mm_of(fov_y_deg: f64, aspect: f64) -> f64 {
    let half_diag = (0.5 * fov_y_deg).to_radians().tan() * aspect.hypot(1.0);
    0.5 * FILM_DIAGONAL_MM / half_diag
}

/// The TIFF bytes of an EXIF block with `Orientation` (when not 1), `PixelXDimension` and
/// `PixelYDimension` (`size`, as stored) and `FocalLengthIn35mmFilm`, big-endian, as a phone
/// writes them.
pub fn exif_blob(orientation: u8, f35: u16, size: (u32, u32)) -> Vec<u8> {
    let mut b: Vec<u8> = vec![b'M', b'M', 0, 42, 0, 0, 0, 8];
    let with_orientation = orientation != 1;
    let n0: u16 = if with_orientation { 2 } else { 1 };
    // IFD0 at 8: its entries, then the next-IFD offset (0); the Exif IFD right after.
    let exif_ifd = 8 + 2 + 12 * n0 as u32 + 4;
    b.extend(n0.to_be_bytes());
    if with_orientation {
        b.extend([0x01, 0x12, 0, 3, 0, 0, 0, 1, 0, orientation, 0, 0]);
    }
    b.extend([0x87, 0x69, 0, 4, 0, 0, 0, 1]);
    b.extend(exif_ifd.to_be_bytes());
    b.extend([0, 0, 0, 0]);
    b.extend(3u16.to_be_bytes());
    // Entries in ascending tag order, as TIFF asks.
    b.extend([0xA0, 0x02, 0, 4, 0, 0, 0, 1]);
    b.extend(size.0.to_be_bytes());
    b.extend([0xA0, 0x03, 0, 4, 0, 0, 0, 1]);
    b.extend(size.1.to_be_bytes());
    b.extend([0xA4, 0x05, 0, 3, 0, 0, 0, 1]);
    b.extend(f35.to_be_bytes());
    b.extend([0, 0]);
    b.extend([0, 0, 0, 0]);
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_focal_length_reads_back_in_both_byte_orders() {
        assert_eq!(focal_35mm(&exif_blob(6, 26, (4032, 3024))), Some(26.0));
        assert_eq!(focal_35mm(&exif_blob(1, 77, (640, 480))), Some(77.0));
        // Little-endian, as many phones write: IFD0 with the Exif pointer, then the tag as LONG.
        let mut le: Vec<u8> = vec![b'I', b'I', 42, 0, 8, 0, 0, 0];
        le.extend(1u16.to_le_bytes());
        le.extend([0x69, 0x87, 4, 0, 1, 0, 0, 0]);
        le.extend(26u32.to_le_bytes());
        le.extend([0, 0, 0, 0]);
        le.extend(1u16.to_le_bytes());
        le.extend([0x05, 0xA4, 4, 0, 1, 0, 0, 0]);
        le.extend(28u32.to_le_bytes());
        le.extend([0, 0, 0, 0]);
        assert_eq!(focal_35mm(&le), Some(28.0));
        let mut with_prefix = b"Exif\0\0".to_vec();
        with_prefix.extend(exif_blob(1, 24, (640, 480)));
        assert_eq!(focal_35mm(&with_prefix), Some(24.0));
        // No tag, a broken block, a zero focal length: none.
        let orientation_only: Vec<u8> = vec![
            b'M', b'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12, 0, 3, 0, 0, 0, 1, 0, 6, 0, 0, 0, 0, 0, 0,
        ];
        assert_eq!(focal_35mm(&orientation_only), None);
        assert_eq!(focal_35mm(&exif_blob(1, 26, (640, 480))[..20]), None);
        assert_eq!(focal_35mm(&exif_blob(1, 0, (640, 480))), None);
        assert_eq!(focal_35mm(b"junk"), None);
        // The saved size, read back; absent where the block has none.
        assert_eq!(pixel_dimensions(&exif_blob(6, 26, (4032, 3024))), Some((4032, 3024)));
        assert_eq!(pixel_dimensions(&le), None);
        assert_eq!(pixel_dimensions(&orientation_only), None);
    }

    #[test]
    fn a_field_of_view_and_its_focal_length_agree() {
        // A 4:3 frame 26 mm equivalent (a phone's main camera): its diagonal 2 atan(21.6/26) = 79.5
        // degrees, its 4:3 width 34.6 mm of film: 67.3 degrees across.
        let f35 = 26.0;
        let (w, h) = (4032u32, 3024u32);
        let f = focal_px(f35, w, h);
        let fov_y = 2.0 * (0.5 * h as f64 / f).atan().to_degrees();
        assert!((focal_35mm_of(fov_y, w as f64 / h as f64) - f35).abs() < 1e-9);
        let across = 2.0 * (0.5 * w as f64 / f).atan().to_degrees();
        assert!((across - 67.3).abs() < 0.1, "{across}");
    }
}
