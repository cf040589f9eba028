//! The calibration card and its simulated photos, on the real engine.
use scratchart::render::Renderer;
use scratchart_calibration::card::{Card, CardSpec, CutRole};
use scratchart_calibration::simulate::{cut_scene, photos, Camera};
use scratchart_tests::{assert_no_validation, gpu};
use scratchart_tool::Tool;

#[test]
fn the_card_straddles_the_surface_and_reads_back() {
    let card = Card::new(&CardSpec::default());
    let d = &card.depths_mm;
    assert!(d[0] < 0.0, "the ladder starts above commanded zero");
    assert!(d.windows(2).all(|w| w[1] > w[0]), "depths increase");
    let near: Vec<f64> = d
        .windows(2)
        .filter(|w| w[0].abs() <= 0.02 && w[1].abs() <= 0.02)
        .map(|w| w[1] - w[0])
        .collect();
    assert!(
        near.iter().all(|s| *s <= 0.005 + 1e-12),
        "fine steps near zero: {near:?}"
    );
    let half = 0.5 * card.plate_mm;
    for c in &card.cuts {
        for p in [c.p0, c.p1] {
            assert!(p[0].abs() < half && p[1].abs() < half, "a cut leaves the card: {c:?}");
        }
    }
    assert_eq!(card.cuts.iter().filter(|c| c.role == CutRole::Fiducial).count(), 8);
    let dir = std::env::temp_dir().join(format!("scratchart-card-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("card.json");
    std::fs::write(&p, serde_json::to_string_pretty(&card.to_json(64)).unwrap()).unwrap();
    let (back, scene) = Card::load(&p).unwrap();
    assert_eq!(back, card);
    assert_eq!(scene.views.len(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Cuts above the real surface leave no groove; different tools give different photos; the
/// photos are reproducible and degraded as asked.
#[test]
fn simulated_photos_depend_on_the_tool() {
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    let card = Card::new(&CardSpec::default());
    let capture = scratchart::model::scene::Scene {
        plate: scratchart::model::scene::Plate {
            size_mm: card.plate_mm,
            roughness: 0.02,
            f0: 0.91,
        },
        views: card.views(96),
        scratches: vec![],
    };
    capture.validate().unwrap();
    let v60 = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.02,
        z_offset_mm: 0.003,
    };
    let cut = cut_scene(&card, &capture, &v60);
    let reaching = card.cuts.iter().filter(|c| c.z_mm + 0.003 > 0.0).count();
    assert_eq!(
        cut.scratches.len(),
        reaching,
        "only cuts below the real surface make grooves"
    );
    let a = photos(&r, &card, &capture, &v60, &Camera::default()).unwrap();
    let v90 = Tool::VBit {
        angle_deg: 90.0,
        tip_flat_mm: 0.02,
        z_offset_mm: 0.003,
    };
    let b = photos(&r, &card, &capture, &v90, &Camera::default()).unwrap();
    let diff: f32 = a[0].iter().zip(&b[0]).map(|(x, y)| (x - y).abs()).sum();
    assert!(diff > 1.0, "a 60 and a 90 degree V-bit look alike: {diff}");
    let noisy = Camera {
        noise: 0.02,
        blur_px: 0.7,
        exposure: 2.0,
        seed: 3,
    };
    let c1 = photos(&r, &card, &capture, &v60, &noisy).unwrap();
    let c2 = photos(&r, &card, &capture, &v60, &noisy).unwrap();
    assert_eq!(c1, c2, "photos are reproducible");
    assert!(c1[0].iter().all(|x| (0.0..=1.0).contains(x)));
    assert_ne!(c1[0], a[0]);
    assert_no_validation(&ctx);
}
