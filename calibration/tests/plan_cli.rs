//! `scratchart-cal plan` end to end: a design and a tool in, G-code and a preview out; bad input
//! and plans that leave their bounds are refused with the README's exit codes.
use std::process::Command;

use scratchart::model::scene::{Camera, Light, LightKind, Plate, Scene, Scratch, View};

fn design(plate: f64) -> Scene {
    let h = 0.4 * plate;
    Scene {
        plate: Plate {
            size_mm: plate,
            roughness: 0.02,
            f0: 0.91,
        },
        views: vec![View {
            name: "v".into(),
            camera: Camera {
                eye: [0.0, -3.0 * plate, 3.0 * plate],
                target: [0.0; 3],
                up: [0.0, 0.0, 1.0],
                fov_y_deg: 30.0,
                width: 8,
                height: 8,
            },
            light: Light {
                kind: LightKind::Point {
                    position: [0.0, 3.0 * plate, 3.0 * plate],
                },
                intensity: 1.0,
            },
        }],
        scratches: (0..40)
            .map(|k| {
                let t = k as f64 / 40.0;
                Scratch {
                    p0: [-h + 2.0 * h * t, -h],
                    p1: [-h + 2.0 * h * t, h * t],
                    w: 0.05,
                    d: 0.05,
                    alpha: 0.1,
                }
            })
            .collect(),
    }
}

#[test]
fn plan_writes_gcode_and_a_preview() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-plan-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    design(100.0).save(&dir.join("design.json"), "s.csv").unwrap();
    std::fs::write(
        dir.join("tool.json"),
        r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.0 }"#,
    )
    .unwrap();
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    let o = run(&["plan", "design.json", "--tool", "tool.json", "--out", "out/plan.nc"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = std::fs::read_to_string(dir.join("out/plan.nc")).unwrap();
    assert!(g.starts_with("; scratchart plan machine=grbl\n"));
    assert_eq!(g.lines().filter(|l| l.starts_with("; scratch ")).count(), 40);
    assert!(dir.join("out/plan.png").exists());
    let o = run(&[
        "plan",
        "design.json",
        "--tool",
        "tool.json",
        "--out",
        "out/m.gcode",
        "--machine",
        "marlin",
    ]);
    assert!(o.status.success());
    assert!(std::fs::read_to_string(dir.join("out/m.gcode"))
        .unwrap()
        .starts_with("; scratchart plan machine=marlin\n"));
    // A bad tool file: 3, naming it.
    std::fs::write(dir.join("bad.json"), r#"{ "kind": "v-bit", "angle_deg": 0 }"#).unwrap();
    let o = run(&["plan", "design.json", "--tool", "bad.json"]);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.json"));
    // A plate larger than the machine's travel: refused (3), saying so.
    design(250.0).save(&dir.join("big.json"), "b.csv").unwrap();
    let o = run(&["plan", "big.json", "--tool", "tool.json", "--out", "out/big.nc"]);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("does not fit"));
    assert!(
        !dir.join("out/big.nc").exists(),
        "nothing is written for a refused plan"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
