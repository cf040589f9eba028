//! The two scenes of BENCHMARKS.md's "Arc scratches as chords": 2,000 scratches 3 mm long (w 0.1,
//! d 0.03 mm, alpha 0.1) on a 50 mm plate seen by 3 views of 256^2, straight (`straight.json`)
//! and the same bent into 45 degree arcs of either sense (`arcs.json`). Run:
//!   cargo run --release -p scratchart --example arc_scenes -- DIR
//!   scratchart bench --scene DIR/straight.json --iters 0 --repeats 5   (and DIR/arcs.json)
use scratchart_design::scenes::{orbit_camera, Rng};
use scratchart_model::scene::{Light, LightKind, Plate, Scene, Scratch, View};

fn main() -> anyhow::Result<()> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&dir)?;
    let plate = 50.0;
    let views: Vec<View> = (0..3)
        .map(|j| View {
            name: format!("v{j}"),
            camera: orbit_camera(150.0, 50.0, 120.0 * j as f64, plate, 256, 256),
            light: Light {
                kind: LightKind::Point {
                    position: [0.0, 0.0, 200.0],
                },
                intensity: 1000.0,
            },
            exposure: 1.0,
        })
        .collect();
    for (name, bulge) in [("straight", 0.0), ("arcs", 0.2)] {
        let mut rng = Rng::new(3);
        let h = 0.5 * plate - 3.0;
        let scratches = (0..2000)
            .map(|_| {
                let p0 = [rng.range(-h, h), rng.range(-h, h)];
                let a = rng.range(0.0, std::f64::consts::TAU);
                let sense = if rng.f64() < 0.5 { -1.0 } else { 1.0 };
                Scratch {
                    p0,
                    p1: [p0[0] + 3.0 * a.cos(), p0[1] + 3.0 * a.sin()],
                    w: 0.1,
                    d: 0.03,
                    alpha: 0.1,
                    bulge: bulge * sense,
                }
            })
            .collect();
        let scene = Scene {
            plate: Plate::flat(plate),
            views: views.clone(),
            scratches,
        };
        scene.validate()?;
        scene.save(&dir.join(format!("{name}.json")), &format!("{name}.csv"))?;
        println!("wrote {}", dir.join(format!("{name}.json")).display());
    }
    Ok(())
}
