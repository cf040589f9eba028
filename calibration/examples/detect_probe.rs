//! Detection of the card's marks on random phone shots, against the truth: `cargo run --release -p scratchart-calibration --example detect_probe -- 20` (20 shots × 3 views).
use scratchart_calibration::card::{Card, CardSpec};
use scratchart_calibration::fiducials::find_marks;
use scratchart_calibration::phone::{random_shot, take};
use scratchart_calibration::photo::{load_photo, resize};
use scratchart_design::scenes::Rng;
use scratchart_model::camera::ViewGeom;
use scratchart_render::Renderer;
use scratchart_tool::Tool;
use scratchart_vulkan::{Context, ContextDesc};

fn main() -> anyhow::Result<()> {
    let n: usize = std::env::args().nth(1).map_or(10, |s| s.parse().unwrap());
    let ctx = Context::new(ContextDesc::default())?;
    let r = Renderer::new(&ctx)?;
    let card = Card::new(&CardSpec::default());
    let dir = std::env::temp_dir().join("detect_probe");
    let p = dir.join("card.json");
    std::fs::create_dir_all(&dir)?;
    std::fs::write(&p, serde_json::to_string(&card.to_json(256))?)?;
    let (card, capture) = Card::load(&p)?;
    let tool = Tool::VBit {
        angle_deg: 70.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.003,
    };
    let mut rng = Rng::new(7);
    let (mut ok, mut worst) = (0, 0.0f64);
    // Every found mark's distance from its true projection, pixels.
    let mut errs: Vec<f64> = Vec::new();
    for t in 0..n {
        let shot = random_shot(&mut rng, card.marks.len(), 20.0);
        for v in 0..capture.views.len() {
            let (path, pv) = take(&r, &card, &capture, v, &tool, &shot, &dir.join(format!("t{t}")))?;
            let img = load_photo(&path).map_err(anyhow::Error::msg)?;
            let mut view = capture.views[v].clone();
            view.camera.height = view.camera.height.min(img.height);
            view.camera.width =
                ((view.camera.height as f64 * img.width as f64 / img.height as f64).round() as u32).max(16);
            let small = resize(&img, view.camera.width, view.camera.height);
            let t0 = std::time::Instant::now();
            let got = find_marks(&small, &card, &view);
            let dt = t0.elapsed().as_secs_f64();
            // truth: the posed camera at the small image's resolution
            let mut tv = pv.clone();
            let k = view.camera.height as f64 / pv.camera.height as f64;
            tv.camera.height = view.camera.height;
            tv.camera.width = view.camera.width;
            let g = ViewGeom::new(&tv);
            match got {
                Ok(f) => {
                    let mut e = 0.0f64;
                    for (q, p) in f.points.iter().enumerate() {
                        if let Some(p) = p {
                            let m = card.marks[q].centre;
                            let tr = g.project([m[0], m[1], 0.0]).unwrap();
                            let d = (p[0] - tr.0).hypot(p[1] - tr.1);
                            e = e.max(d);
                            errs.push(d);
                        }
                    }
                    let cam = scratchart_calibration::fiducials::plausible_camera(
                        &f.plate_to_image,
                        small.width,
                        small.height,
                        &view,
                    );
                    let ce = match &cam {
                        Ok(c) => format!(
                            "eye err {:.1} mm, truth {:.1} mm from the capture position (truth {:?} got {:?})",
                            (0..3)
                                .map(|i| (c.eye[i] - pv.camera.eye[i]).powi(2))
                                .sum::<f64>()
                                .sqrt(),
                            (0..3)
                                .map(|i| (pv.camera.eye[i] - view.camera.eye[i]).powi(2))
                                .sum::<f64>()
                                .sqrt(),
                            pv.camera.eye.map(|x| x.round()),
                            c.eye.map(|x| x.round())
                        ),
                        Err(e) => e.clone(),
                    };
                    println!("   camera: {ce}");
                    let good = e < 1.0;
                    if good {
                        ok += 1;
                    }
                    worst = worst.max(e);
                    println!("t{t} v{v}: {} marks, max err {e:.2} px, rms {:.2}, conf {:?}, cands {}, {dt:.2}s {} (k {k:.2}) {:?}", f.count(), f.rms_px,
                        f.confidence.iter().map(|c| (c * 100.0).round() / 100.0).collect::<Vec<_>>(), f.candidates, if good {""} else {"WRONG"}, shot);
                }
                Err(e) => println!("t{t} v{v}: NOT FOUND {e} {dt:.2}s {:?}", shot),
            }
        }
    }
    println!("{ok} of {} within 1 px; worst {worst:.2}", 2 * n);
    errs.sort_by(f64::total_cmp);
    let at = |q: f64| {
        errs.get(((errs.len() as f64 - 1.0) * q).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    println!(
        "marks' centres against the truth, {} marks: median {:.3} px, 90% {:.3}, 98% {:.3}, rms {:.3}",
        errs.len(),
        at(0.5),
        at(0.9),
        at(0.98),
        (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt()
    );
    Ok(())
}
