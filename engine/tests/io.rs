//! Image files: PFM byte layout and round trip, PNG display values, resizing, errors.

use std::path::PathBuf;

use scratchart_render::io;

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart_io_{}_{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn pfm_bytes_are_bottom_row_first_little_endian() {
    let d = tmpdir("pfmbytes");
    let p = d.join("a.pfm");
    // 3 wide, 2 high; top row = 1, 2, 3; bottom row = 4, 5, 6.
    let data = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0];
    io::write_pfm(&p, 3, 2, &data).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let header = b"Pf\n3 2\n-1.0\n";
    assert_eq!(&bytes[..header.len()], header);
    let body = &bytes[header.len()..];
    assert_eq!(body.len(), 24);
    let vals: Vec<f32> = body
        .chunks(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(vals, vec![4.0, 5.0, 6.0, 1.0, 2.0, 3.0]);
    let (w, h, back) = io::read_pfm(&p).unwrap();
    assert_eq!((w, h), (3, 2));
    assert_eq!(back, data);
    // No temp file left.
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
}

#[test]
fn pfm_round_trip_exact_and_big_endian() {
    let d = tmpdir("pfmrt");
    let (w, h) = (7u32, 5u32);
    let data: Vec<f32> = (0..w * h)
        .map(|k| (k as f32 * 0.37).sin() * 1e-3 + f32::MIN_POSITIVE * k as f32)
        .collect();
    let p = d.join("x.pfm");
    io::write_pfm(&p, w, h, &data).unwrap();
    let (w2, h2, back) = io::read_pfm(&p).unwrap();
    assert_eq!((w2, h2), (w, h));
    assert_eq!(
        back.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        data.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    // Big-endian file with a different header layout.
    let mut be = b"Pf 2 1 1.0\n".to_vec();
    be.extend_from_slice(&1.5f32.to_be_bytes());
    be.extend_from_slice(&(-2.25f32).to_be_bytes());
    let p = d.join("be.pfm");
    std::fs::write(&p, &be).unwrap();
    assert_eq!(io::read_pfm(&p).unwrap(), (2, 1, vec![1.5, -2.25]));
}

#[test]
fn pfm_errors_name_the_file() {
    let d = tmpdir("pfmerr");
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("magic.pfm", b"P6\n1 1\n-1.0\n\0\0\0\0".to_vec(), "magic"),
        ("short.pfm", b"Pf\n2 2\n-1.0\n\0\0\0\0".to_vec(), "needs 16 data bytes"),
        ("width.pfm", b"Pf\nx 2\n-1.0\n".to_vec(), "width"),
        ("scale.pfm", b"Pf\n1 1\n0\n\0\0\0\0".to_vec(), "scale"),
        ("trunc.pfm", b"Pf\n1".to_vec(), "header ends early"),
    ];
    for (name, bytes, needle) in cases {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        let msg = io::read_pfm(&p).unwrap_err().to_string();
        assert!(msg.contains(name) && msg.contains(needle), "{msg}");
    }
    let msg = io::read_pfm(&d.join("missing.pfm")).unwrap_err().to_string();
    assert!(msg.contains("missing.pfm"), "{msg}");
    let msg = io::write_pfm(&d.join("bad.pfm"), 2, 2, &[0.0; 3])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("bad.pfm"), "{msg}");
}

#[test]
fn png_display_values() {
    let d = tmpdir("png");
    let p = d.join("disp.png");
    let lin = [0.0f32, 1.0, 2.0, 0.5, -1.0, f32::NAN];
    io::write_png_display(&p, 3, 2, &lin).unwrap();
    let img = image::open(&p).unwrap();
    assert_eq!(img.color(), image::ColorType::L8);
    let raw = img.to_luma8().into_raw();
    let half = (255.0 * 0.5f64.powf(1.0 / 2.2)).round() as u8;
    assert_eq!(raw, vec![0, 255, 255, half, 0, 0]);
    let (w, h, g) = io::read_image_gray(&p).unwrap();
    assert_eq!((w, h), (3, 2));
    assert!((g[3] - half as f32 / 255.0).abs() < 1e-6);
    // Colour JPEG -> luma in [0, 1].
    let rgb = image::RgbImage::from_fn(8, 4, |x, _| image::Rgb([(x * 30) as u8, 128, 200]));
    let pj = d.join("c.jpg");
    rgb.save(&pj).unwrap();
    let (w, h, g) = io::read_image_gray(&pj).unwrap();
    assert_eq!((w, h, g.len()), (8, 4, 32));
    assert!(g.iter().all(|v| (0.0..=1.0).contains(v)));
    let msg = io::read_image_gray(&d.join("nothere.png")).unwrap_err().to_string();
    assert!(msg.contains("nothere.png"), "{msg}");
    // A JPEG cut short (an interrupted copy) is refused: its decoder would fill the rest with
    // grey and say nothing. Bytes after its end (a phone's appended data) are fine.
    let big = image::RgbImage::from_fn(64, 48, |x, y| image::Rgb([(x * 4) as u8, (y * 5) as u8, 90]));
    let pj = d.join("whole.jpg");
    big.save(&pj).unwrap();
    let whole = std::fs::read(&pj).unwrap();
    for cut in [whole.len() / 2, whole.len() - 3] {
        let pc = d.join("cut.jpg");
        std::fs::write(&pc, &whole[..cut]).unwrap();
        let msg = io::read_image_gray(&pc).unwrap_err().to_string();
        assert!(msg.contains("cut.jpg") && msg.contains("cut short"), "{cut}: {msg}");
    }
    let mut padded = whole.clone();
    padded.extend_from_slice(b"trailing data a phone appended");
    let pp = d.join("padded.jpg");
    std::fs::write(&pp, &padded).unwrap();
    assert_eq!(io::read_image_gray(&pp).unwrap().0, 64);
    // A phone's portrait: stored turned, with EXIF orientation 6 (turn 90 degrees clockwise to
    // show). Stored 16 x 8 with its left half white: shown 8 x 16 with its top half white.
    let stored = image::GrayImage::from_fn(16, 8, |x, _| image::Luma([if x < 8 { 255 } else { 0 }]));
    let ps = d.join("stored.jpg");
    stored.save(&ps).unwrap();
    let j = std::fs::read(&ps).unwrap();
    let mut tiff = b"MM\x00\x2a\x00\x00\x00\x08\x00\x01".to_vec();
    tiff.extend_from_slice(&[0x01, 0x12, 0x00, 0x03, 0x00, 0x00, 0x00, 0x01, 0x00, 0x06, 0x00, 0x00]);
    tiff.extend_from_slice(&[0, 0, 0, 0]);
    let mut app1 = b"Exif\x00\x00".to_vec();
    app1.extend_from_slice(&tiff);
    let mut turned = j[..2].to_vec();
    turned.extend_from_slice(&[0xFF, 0xE1]);
    turned.extend_from_slice(&((app1.len() + 2) as u16).to_be_bytes());
    turned.extend_from_slice(&app1);
    turned.extend_from_slice(&j[2..]);
    let pt = d.join("portrait.jpg");
    std::fs::write(&pt, &turned).unwrap();
    let (w, h, g) = io::read_image_gray(&pt).unwrap();
    assert_eq!((w, h), (8, 16), "the EXIF orientation was not applied");
    let mean = |rows: std::ops::Range<usize>| {
        rows.clone()
            .map(|y| g[y * 8..y * 8 + 8].iter().sum::<f32>())
            .sum::<f32>()
            / (8 * rows.len()) as f32
    };
    assert!(
        mean(0..7) > 0.8 && mean(9..16) < 0.2,
        "top {} bottom {}",
        mean(0..7),
        mean(9..16)
    );
    // A PNG cut short is refused by its decoder.
    let pn = d.join("whole.png");
    big.save(&pn).unwrap();
    let png = std::fs::read(&pn).unwrap();
    std::fs::write(d.join("cut.png"), &png[..png.len() / 2]).unwrap();
    assert!(io::read_image_gray(&d.join("cut.png")).is_err());
}

#[test]
fn resize() {
    // Identity.
    let src: Vec<f32> = (0..12).map(|k| k as f32).collect();
    assert_eq!(io::resize_bilinear(&src, 4, 3, 4, 3), src);
    // Constant stays constant; linear ramps stay linear in the interior when enlarging.
    let c = vec![0.25f32; 20];
    assert!(io::resize_bilinear(&c, 5, 4, 13, 7)
        .iter()
        .all(|v| (v - 0.25).abs() < 1e-6));
    let ramp: Vec<f32> = (0..4).map(|k| k as f32).collect();
    let up = io::resize_bilinear(&ramp, 4, 1, 8, 1);
    // Destination centre x maps to source (x + 0.5)/2 - 0.5.
    for (x, v) in up.iter().enumerate().skip(1).take(6) {
        let s = (x as f32 + 0.5) / 2.0 - 0.5;
        assert!((v - s).abs() < 1e-6, "{x}: {v} vs {s}");
    }
    // Downscale by 2 of a checkerboard averages to ~0.5.
    let cb: Vec<f32> = (0..64).map(|k| ((k % 8 + k / 8) % 2) as f32).collect();
    let down = io::resize_bilinear(&cb, 8, 8, 4, 4);
    assert!(down.iter().all(|v| (v - 0.5).abs() < 0.2), "{down:?}");
}
