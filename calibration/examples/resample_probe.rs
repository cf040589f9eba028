//! The periodicity of each photo's pixel sharpness (`resampled::periodicity`): what tells an
//! enlarged photo from one as the camera made it.
//! `cargo run --release -p scratchart-calibration --example resample_probe -- PHOTO...`
fn main() {
    for f in std::env::args().skip(1) {
        let img = match scratchart_calibration::photo::load_photo(std::path::Path::new(&f)) {
            Ok(i) => i,
            Err(e) => {
                println!("{f}: {e}");
                continue;
            }
        };
        let p = scratchart_calibration::resampled::periodicity(&img);
        let e = scratchart_calibration::resampled::enlarged(&img).is_some();
        match p {
            Some(p) => println!(
                "{f} {}x{}: period {:.2} px, peak/floor {:.1}, modulation {:.3}{}",
                img.width,
                img.height,
                p.period_px,
                p.peak_over_floor,
                p.modulation,
                if e { "  ENLARGED" } else { "" }
            ),
            None => println!("{f}: too small"),
        }
    }
}
