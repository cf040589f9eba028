//! Arc scratches (engine/docs/model.md section 11): the GPU renderer (each arc uploaded as its
//! chords, engine/render/src/arcs.rs) against the float64 reference's exact arc, on plates of
//! arcs of either sense from a few degrees to 180, with straight scratches among them; the
//! scene file and CSV round trip; and the refusals (gradients of arcs, bad bulges).
use scratchart_design::scenes::Rng;
use scratchart_model::scene::{Scene, Scratch};
use scratchart_tests::*;

/// Bends a share of `scene`'s scratches into arcs with |bulge| in [lo, hi] (either sense),
/// keeping those the plate and the groove's width allow.
fn with_arcs(scene: &Scene, seed: u64, share: f64, lo: f64, hi: f64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut out = scene.clone();
    for s in &mut out.scratches {
        if rng.f64() >= share {
            continue;
        }
        let b = rng.range(lo, hi) * if rng.f64() < 0.5 { -1.0 } else { 1.0 };
        let mut t: Scratch = *s;
        t.bulge = b;
        if let Some(a) = t.arc() {
            let bb = a.band_bbox(t.half_width());
            let h = 0.5 * scene.plate.size_mm;
            if a.radius >= t.w && bb[0] >= -h && bb[1] >= -h && bb[2] <= h && bb[3] <= h {
                *s = t;
            }
        }
    }
    out
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart_arcs_{name}_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn views() -> Vec<scratchart_model::scene::View> {
    vec![
        orbit_view("a", 40, 45.0, 0.0, 45.0, 180.0, 20.0),
        orbit_view("b", 40, 60.0, 110.0, 30.0, 300.0, 20.0),
    ]
}

/// Within the bar in every view: thin grooves (w 0.05, d 0.02 mm: e 0.02 mm) on arcs of 2 to 45
/// degrees per 3 mm with sharp to broad lobes (alpha 1e-3 to 0.3), and wide deep grooves (e 0.09
/// mm) on arcs up to half circles with radii down to 1 mm, where the chords' area weight
/// matters (without it 61% of a view's pixels were within the bar).
#[test]
fn arcs_match_the_reference() {
    for (w, d, alpha, lo, hi) in [
        (0.05, 0.02, 0.03, 0.02, 0.2),
        (0.05, 0.02, 0.1, 0.02, 0.2),
        (0.05, 0.02, 0.3, 0.02, 0.2),
        (0.05, 0.02, 3e-3, 0.02, 0.1),
        (0.05, 0.02, 1e-3, 0.02, 0.05),
        (0.2, 0.15, 0.1, 0.05, 1.0),
        (0.2, 0.15, 0.5, 0.3, 1.0),
    ] {
        let straight = random_scene(61, 120, 20.0, w, d, alpha, views());
        let scene = with_arcs(&straight, 5, 0.8, lo, hi);
        let arcs = scene.scratches.iter().filter(|s| s.is_arc()).count();
        assert!(arcs >= 80, "only {arcs} arcs");
        assert_matches_reference(&format!("w {w} d {d} alpha {alpha}, bulges {lo} to {hi}"), &scene);
    }
}

/// Arcs on a sheet bent after carving (engine/docs/model.md section 10): the arc is in the
/// sheet's own coordinates, as a straight scratch is.
#[test]
fn arcs_on_a_bent_sheet_match_the_reference() {
    let straight = random_scene(65, 120, 20.0, 0.2, 0.15, 0.1, views());
    let mut scene = with_arcs(&straight, 8, 0.8, 0.05, 1.0);
    scene.plate.shape = scratchart_model::surface::PlateShape::Cylinder {
        radius_mm: 12.0,
        axis: scratchart_model::surface::BendAxis::Y,
        convex: true,
    };
    assert_matches_reference("arcs on a sheet bent at R 12 about y", &scene);
}

/// A scene file with arcs (CSV `bulge` column, and inline rows of 8) reads back exactly, and
/// straight scenes keep the seven columns.
#[test]
fn scene_files_keep_the_bulge() {
    let dir = tmp("files");
    let straight = random_scene(62, 20, 20.0, 0.05, 0.02, 0.1, views());
    let scene = with_arcs(&straight, 6, 0.5, 0.02, 0.5);
    assert!(scene.scratches.iter().any(|s| s.is_arc()));
    let json = dir.join("s.json");
    scene.save(&json, "s.csv").unwrap();
    let csv = std::fs::read_to_string(dir.join("s.csv")).unwrap();
    assert!(csv.starts_with("x0,y0,x1,y1,w,d,alpha,bulge\n"), "{}", &csv[..60]);
    assert_eq!(Scene::load(&json).unwrap(), scene);
    let inline = dir.join("inline.json");
    std::fs::write(&inline, scene.to_json_inline()).unwrap();
    assert_eq!(Scene::load(&inline).unwrap(), scene);
    straight.save(&json, "s.csv").unwrap();
    let csv = std::fs::read_to_string(dir.join("s.csv")).unwrap();
    assert!(csv.starts_with("x0,y0,x1,y1,w,d,alpha\n"));
}

/// Bulges the tool cannot carve or the plate cannot hold are refused, naming the row and why.
#[test]
fn bad_bulges_are_refused() {
    let dir = tmp("bad");
    let scene = random_scene(63, 1, 20.0, 0.05, 0.02, 0.1, views());
    let json = dir.join("s.json");
    scene.save(&json, "s.csv").unwrap();
    let csv_path = dir.join("s.csv");
    for (row, want) in [
        ("-9,5,9,5,0.05,0.02,0.1,-1", "runs off the plate"),
        ("0,0,0.06,0,0.05,0.02,0.1,2.4", "under the groove's width"),
        ("0,0,1,0,0.05,0.02,0.1,3", "270 degrees"),
        ("0,0,1,0,0.05,0.02,0.1,nan", "not a finite number"),
    ] {
        std::fs::write(&csv_path, format!("x0,y0,x1,y1,w,d,alpha,bulge\n{row}\n")).unwrap();
        let err = Scene::load(&json).unwrap_err().to_string();
        assert!(err.contains(want), "{row}: {err}");
        assert!(err.contains("row 1"), "{row}: {err}");
    }
}

/// What the device cannot do yet with arcs is refused, not done wrong: tangents (the kernels see
/// chords), and an arc that needs more chords than the renderer cuts.
#[test]
fn arcs_refuse_what_they_cannot_do_yet() {
    let ctx = gpu();
    let r = scratchart_render::Renderer::new(&ctx).unwrap();
    let straight = random_scene(64, 10, 20.0, 0.05, 0.02, 0.1, views());
    let scene = with_arcs(&straight, 7, 1.0, 0.1, 0.3);
    let mut gs = r.upload(&scene).unwrap();
    assert!(gs.has_arcs());
    assert!(gs.n_scratches() as usize > scene.scratches.len());
    let seeds: Vec<scratchart_render::tangent::ScratchTangent> = vec![Default::default(); gs.n_scratches() as usize];
    let err = r.tangents(&mut gs, &seeds).unwrap_err().to_string();
    assert!(err.contains("arc"), "{err}");
    // Replacing the arcs by straight scratches of another count asks for a new upload; the
    // same arcs update in place.
    assert!(gs.update_scratches(&ctx, &scene.scratches).unwrap());
    assert!(!gs.update_scratches(&ctx, &straight.scratches).unwrap());
    // A half circle of 18 mm at alpha 1e-4 turns by at most 1e-4 rad per chord: 31416 chords,
    // over the 4096 per arc: refused.
    let mut sharp = straight.clone();
    sharp.scratches = vec![Scratch {
        p0: [-9.0, 0.0],
        p1: [9.0, 0.0],
        w: 0.05,
        d: 0.02,
        alpha: 1e-4,
        bulge: 1.0,
    }];
    let err = r.upload(&sharp).err().expect("refused").to_string();
    assert!(err.contains("chords") && err.contains("4096"), "{err}");
    assert_no_validation(&ctx);
}

/// Gradients of arcs (engine/docs/model.md section 8's bar, extended to the bulge): the chords'
/// dual-number backward chained to each arc's ends, width, depth, roughness and bulge, against
/// central differences of the float64 reference's exact arcs, for wide grooves on tight arcs
/// (where the chords' area weight matters) among straight scratches.
#[test]
fn arc_gradients_match_central_differences() {
    let views = vec![
        orbit_view("a", 24, 45.0, 0.0, 45.0, 180.0, 20.0),
        orbit_view("b", 24, 60.0, 120.0, 40.0, 300.0, 20.0),
    ];
    let straight = random_scene(11, 16, 20.0, 0.4, 0.3, 0.2, views);
    let scene = with_arcs(&straight, 12, 0.75, 0.1, 0.6);
    scene.validate().unwrap();
    assert!(scene.scratches.iter().filter(|s| s.is_arc()).count() >= 8);
    // Targets: the reference render of the scene with its arcs bent and moved.
    let mut moved = scene.clone();
    for (k, s) in moved.scratches.iter_mut().enumerate() {
        let d = if k % 2 == 0 { 0.15 } else { -0.1 };
        s.p0[0] += d;
        s.p1[1] -= d;
        s.w *= 1.1;
        s.bulge *= 0.8;
    }
    let t: Vec<Vec<f64>> = (0..2)
        .map(|v| scratchart_model::reference::render_view(&moved, v))
        .collect();
    let ctx = gpu();
    let r = scratchart_render::Renderer::new(&ctx).unwrap();
    let mut gs = r.upload(&scene).unwrap();
    let first = r.render(&mut gs).unwrap().images;
    let (_, g) = r.gradients(&mut gs, &dl_of(&scene, &first, &t)).unwrap();
    // The device's chain rule (shaders/arc_map.comp) against the host's in float64, on the same
    // chord gradients.
    let chords: Vec<[f32; 8]> = ctx.download(gs.scratch_grad()).unwrap();
    let (host, host_bulges) = gs.arc_chain_on_host(&chords[..gs.n_scratches() as usize]).unwrap();
    for (k, (a, b)) in g.scratches.iter().zip(&host).enumerate() {
        let scale = b.iter().fold(1e-12f32, |m, x| m.max(x.abs()));
        for p in 0..7 {
            assert!(
                (a[p] - b[p]).abs() <= 1e-4 * scale,
                "scratch {k} parameter {p}: device {} host {}",
                a[p],
                b[p]
            );
        }
        let (gb, hb) = (g.bulges[k], host_bulges[k]);
        assert!(
            gb.is_nan() == hb.is_nan() && (gb.is_nan() || (gb - hb).abs() <= 1e-4 * hb.abs().max(scale)),
            "scratch {k} bulge: device {gb} host {hb}"
        );
    }
    let e = |s: &Scene| scratchart_model::reference::check_loss(s, &t);
    let names = ["endpoints", "w", "d", "alpha", "bulge"];
    let mut gpu_kind: [Vec<f64>; 5] = Default::default();
    let mut ref_kind: [Vec<f64>; 5] = Default::default();
    for (k, s) in scene.scratches.iter().enumerate() {
        let params = if s.is_arc() { 8 } else { 7 };
        for p in 0..params {
            let at = |delta: f64| {
                let mut sc = scene.clone();
                let x = &mut sc.scratches[k];
                match p {
                    0 => x.p0[0] += delta,
                    1 => x.p0[1] += delta,
                    2 => x.p1[0] += delta,
                    3 => x.p1[1] += delta,
                    4 => x.w += delta,
                    5 => x.d += delta,
                    6 => x.alpha += delta,
                    _ => x.bulge += delta,
                }
                e(&sc)
            };
            let base = [s.p0[0], s.p0[1], s.p1[0], s.p1[1], s.w, s.d, s.alpha, s.bulge][p];
            let h = if p < 4 || p == 7 { 1e-5 } else { 1e-5 * base };
            let fd = (at(h) - at(-h)) / (2.0 * h);
            let kind = [0, 0, 0, 0, 1, 2, 3, 4][p];
            gpu_kind[kind].push(if p < 7 { g.scratches[k][p] } else { g.bulges[k] } as f64);
            ref_kind[kind].push(fd);
        }
        assert_eq!(
            s.is_arc(),
            g.bulges[k].is_finite(),
            "scratch {k}: dE/dbulge only for arcs"
        );
    }
    for i in 0..5 {
        let err = rel(&gpu_kind[i], &ref_kind[i]);
        let norm: f64 = ref_kind[i].iter().map(|x| x * x).sum::<f64>().sqrt();
        eprintln!(
            "arcs: {}: relative gradient error {err:.3e} (|g_ref| = {norm:.3e})",
            names[i]
        );
        assert!(norm > 0.0, "zero reference gradient for {}", names[i]);
        assert!(
            err <= 1e-2,
            "{} gradient off by {err:.3e}: gpu {:?} vs reference {:?}",
            names[i],
            &gpu_kind[i][..6.min(gpu_kind[i].len())],
            &ref_kind[i][..6.min(ref_kind[i].len())]
        );
    }
    assert_no_validation(&ctx);
}
