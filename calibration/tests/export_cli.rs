//! `scratchart-cal export` end to end: the files are written (either or both), banded by depth
//! when the design has its z_mm column, and the command line is checked. The drawings' contents
//! are read back by independent parsers in the machine crate's tests (tests/export.rs).
use std::process::Command;

use scratchart_model::scene::{Scene, Scratch};
use scratchart_model::scene_file::Extra;

fn design() -> Scene {
    Scene::bare(
        60.0,
        (0..30)
            .map(|k| {
                let t = k as f64 / 30.0;
                Scratch {
                    p0: [-25.0 + 50.0 * t, -20.0],
                    p1: [-25.0 + 50.0 * t, 20.0 * t],
                    w: 0.04 + 0.002 * k as f64,
                    d: 0.03,
                    alpha: 0.1,
                    bulge: 0.0,
                }
            })
            .collect(),
    )
}

#[test]
fn export_writes_svg_and_dxf() {
    let bin = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-export-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str]| Command::new(&bin).current_dir(&dir).args(args).output().unwrap();
    design().save(&dir.join("design.json"), "s.csv").unwrap();
    // Neither --svg nor --dxf: a usage error.
    let o = run(&["export", "design.json"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--svg"));
    // Both.
    let o = run(&["export", "design.json", "--svg", "out/a.svg", "--dxf", "out/a.dxf"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("by visible width"));
    let svg = std::fs::read_to_string(dir.join("out/a.svg")).unwrap();
    assert!(svg.contains(r#"width="60mm" height="60mm" viewBox="0 0 60 60""#));
    assert_eq!(svg.matches("<line ").count(), 31, "30 scratches and the +x mark");
    assert!(svg.contains(r#"<g id="mark_plus_x_edge""#));
    let dxf = std::fs::read_to_string(dir.join("out/a.dxf")).unwrap();
    assert!(dxf.contains("$INSUNITS\n 70\n4\n") && dxf.contains("AC1015"));
    assert_eq!(
        dxf.matches("\nLINE\n").count(),
        35,
        "30 scratches, 4 plate edges and the +x mark"
    );
    // --no-mark leaves it out, as `plan --no-mark` does.
    let o = run(&["export", "design.json", "--no-mark", "--svg", "out/b.svg"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(dir.join("out/b.svg")).unwrap();
    assert!(svg.matches("<line ").count() == 30 && !svg.contains("mark_plus_x_edge"));
    // Either alone; with z_mm the bands are by commanded depth.
    let extra = Extra {
        names: vec!["z_mm".into()],
        rows: (0..30).map(|k| vec![[0.02, 0.04][k % 2]]).collect(),
    };
    design().save_extra(&dir.join("z.json"), "z.csv", &extra).unwrap();
    let o = run(&["export", "z.json", "--dxf", "z.dxf"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("z.dxf").exists() && !dir.join("z.svg").exists());
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        out.contains("2 bands by commanded depth") && out.contains("band2_depth_40um"),
        "{out}"
    );
    let o = run(&["export", "z.json", "--svg", "z.svg"]);
    assert!(o.status.success() && dir.join("z.svg").exists());
    // A design that cannot be read: 3.
    let o = run(&["export", "missing.json", "--svg", "m.svg"]);
    assert_eq!(o.status.code(), Some(3));
    let _ = std::fs::remove_dir_all(&dir);
}
