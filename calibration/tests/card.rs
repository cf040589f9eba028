//! The calibration card and its simulated photos, on the real engine.
use scratchart_calibration::card::{Card, CardSpec, CutRole};
use scratchart_calibration::simulate::{cut_scene, photos, Camera};
use scratchart_render::Renderer;
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
    // Six hatched marks: every fiducial cut inside one mark's square, every mark hatched densely
    // (at least 10 cuts), none overlapping the ladder.
    assert_eq!(card.marks.len(), 6);
    for c in card.cuts.iter().filter(|c| c.role == CutRole::Fiducial) {
        assert!(
            card.marks.iter().any(|m| m.covers(c.p0, 1e-9) && m.covers(c.p1, 1e-9)),
            "a fiducial cut outside every mark: {c:?}"
        );
    }
    for m in &card.marks {
        let n = card
            .cuts
            .iter()
            .filter(|c| c.role == CutRole::Fiducial && m.covers(c.p0, 1e-9))
            .count();
        assert!(n >= 10, "mark {} has {n} cuts", m.label);
        for c in card.cuts.iter().filter(|c| c.role == CutRole::Ladder) {
            assert!(
                !m.covers(c.p0, 1.0) && !m.covers(c.p1, 1.0),
                "mark {} meets the ladder",
                m.label
            );
        }
    }
    // The layout fixes the orientation: turned by 90, 180 or 270 degrees, at most four marks land
    // within a mark's size of a mark (so a wrong turn never matches the five a fit needs).
    for turn in 1..4 {
        let a = (turn as f64 * 90f64).to_radians();
        let landed = card
            .marks
            .iter()
            .filter(|m| {
                let q = [
                    m.centre[0] * a.cos() - m.centre[1] * a.sin(),
                    m.centre[0] * a.sin() + m.centre[1] * a.cos(),
                ];
                card.marks
                    .iter()
                    .any(|o| (o.centre[0] - q[0]).hypot(o.centre[1] - q[1]) < 2.0 * o.half_mm)
            })
            .count();
        assert!(landed <= 4, "turned {}: {landed} marks land on marks", turn * 90);
    }
    // Each depth appears on both sides of the centre (its point mirror), so a brightness
    // gradient across the photo cannot pass for a width law.
    for &z in &card.depths_mm {
        let ys: Vec<f64> = card
            .cuts
            .iter()
            .filter(|c| c.role == CutRole::Ladder && c.z_mm == z)
            .map(|c| 0.5 * (c.p0[1] + c.p1[1]))
            .collect();
        let mean = ys.iter().sum::<f64>() / ys.len() as f64;
        assert!(mean.abs() < 1e-9, "depth {z}: rungs centred at y = {mean}");
    }
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
    let capture = scratchart_model::scene::Scene {
        plate: scratchart_model::scene::Plate {
            size_mm: card.plate_mm,
            roughness: 0.02,
            f0: 0.91,
            shape: Default::default(),
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

/// `card --out DIR` writes the card's G-code through the plan's writer: every cut of card.json
/// once, at its commanded depth (the rungs above zero with the tool above Z0), for GRBL and Marlin.
#[test]
fn the_card_gcode_cuts_the_card() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-cardnc-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str]| {
        std::process::Command::new(&bin)
            .current_dir(&dir)
            .args(args)
            .output()
            .unwrap()
    };
    let o = run(&["card", "--out", "g", "--res", "32"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(&["card", "--out", "m", "--res", "32", "--machine", "marlin"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (file, fw) in [("g/card.nc", "grbl"), ("m/card.gcode", "marlin")] {
        let (card, _) = Card::load(&dir.join(file).with_file_name("card.json")).unwrap();
        let g = std::fs::read_to_string(dir.join(file)).unwrap();
        assert!(g.starts_with(&format!("; scratchart plan machine={fw}\n")));
        assert!(g.lines().all(|l| l.len() < 80) && !g.contains('\r'));
        // Blocks: `; scratch N (cut K of T)`, then the hop (G0 to the start, at the retract or
        // the clearance height), G1 Z down, G1 to the end.
        let mut seen = vec![false; card.cuts.len()];
        let mut above = 0;
        let lines: Vec<&str> = g.lines().collect();
        let word = |l: &str, c: char| -> f64 {
            l.split_whitespace().find(|w| w.starts_with(c)).unwrap()[1..]
                .parse()
                .unwrap()
        };
        for (i, l) in lines.iter().enumerate() {
            let Some(n) = l.strip_prefix("; scratch ") else {
                continue;
            };
            let n = n.split(" (cut ").next().unwrap();
            let k: usize = n.parse::<usize>().unwrap() - 1;
            assert!(!seen[k], "cut {} twice", k + 1);
            seen[k] = true;
            let block: Vec<&str> = lines[i + 1..]
                .iter()
                .take_while(|l| !l.starts_with(';'))
                .copied()
                .collect();
            let find = |p: &str| {
                *block
                    .iter()
                    .find(|l| l.starts_with(p))
                    .unwrap_or_else(|| panic!("{p} in {block:?}"))
            };
            let (start, plunge, end) = (find("G0 X"), find("G1 Z"), find("G1 X"));
            let a = [word(start, 'X'), word(start, 'Y')];
            let b = [word(end, 'X'), word(end, 'Y')];
            let c = &card.cuts[k];
            let near = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).abs() < 5.1e-5 && (p[1] - q[1]).abs() < 5.1e-5;
            assert!(
                (near(a, c.p0) && near(b, c.p1)) || (near(a, c.p1) && near(b, c.p0)),
                "cut {}: {a:?} {b:?} vs {c:?}",
                k + 1
            );
            let z = word(plunge, 'Z');
            assert!((z + c.z_mm).abs() < 5.1e-5, "cut {}: Z {z} for depth {}", k + 1, c.z_mm);
            if c.z_mm < 0.0 {
                assert!(z > 0.0, "a rung above zero keeps the tool above Z0");
                above += 1;
            }
        }
        assert!(seen.iter().all(|s| *s), "every card cut is in {file}");
        assert!(above > 0);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
