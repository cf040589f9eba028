//! A bent plate end to end (engine/docs/model.md section 10): `design --plate-shape cylinder`
//! writes the bend into design.json, a set-up sheet that says how to bend the sheet (with the
//! radius's tolerance) and a 1:1 template; `plan` carves the flat sheet, the very cuts of the same
//! design unbent; and the flags' mistakes are refused with exit 2, naming what to add.
use scratchart_model::scene::Scene;
use scratchart_model::surface::{BendAxis, PlateShape};
use scratchart_tests::*;

#[test]
fn a_bent_design_says_how_to_bend_and_plans_the_flat_sheet() {
    let dir = std::env::temp_dir().join(format!("scratchart_bent_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let tool = write_file(&dir, "tool.json", V60_TOOL_JSON);
    let out = dir.join("d");
    let out_s = out.to_str().unwrap();
    let mut args = tool_design_args(&tool, out_s);
    args.extend([
        "--machine",
        "grbl",
        "--plate-shape",
        "cylinder",
        "--radius",
        "70",
        "--bend-axis",
        "x",
        "--concave",
    ]);
    let o = run_scratchart(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scene = Scene::load(&out.join("design.json")).unwrap();
    assert_eq!(
        scene.plate.shape,
        PlateShape::Cylinder {
            radius_mm: 70.0,
            axis: BendAxis::X,
            convex: false
        }
    );
    let sheet = std::fs::read_to_string(out.join("setup.txt")).unwrap();
    for words in [
        "Bending:",
        "radius 70.0 mm",
        "-y and +y edges curve up",
        "inside",
        "bend_template.svg",
        "radius -5%",
    ] {
        assert!(sheet.contains(words), "`{words}` not in the set-up sheet:\n{sheet}");
    }
    let svg = std::fs::read_to_string(out.join("bend_template.svg")).unwrap();
    assert!(svg.contains(r#"r="70.000""#) && svg.contains("mm\""), "{svg}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let bend = &summary["setup"]["bend"];
    assert_eq!(bend["radius_mm"], 70.0);
    assert_eq!(bend["radius_error"].as_array().map(|a| a.len()), Some(4), "{bend}");
    for e in bend["radius_error"].as_array().unwrap() {
        assert_eq!(e["corr"].as_array().unwrap().len(), scene.views.len());
    }

    // The plan of the bent design is the flat sheet's: the same cuts as the design unbent.
    // (design.json without its shape, beside it: the same scratch CSV with its depths.)
    let mut flat: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("design.json")).unwrap()).unwrap();
    flat["plate"]
        .as_object_mut()
        .unwrap()
        .remove("shape")
        .expect("the design's shape");
    std::fs::write(out.join("flat.json"), flat.to_string()).unwrap();
    let cal = workspace_bin("scratchart-calibration", "scratchart-cal");
    let plan = |design: &std::path::Path, nc: &str| {
        let o = std::process::Command::new(&cal)
            .args(["plan", design.to_str().unwrap(), "--tool", &tool, "--out"])
            .arg(dir.join(nc))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (
            std::fs::read_to_string(dir.join(nc)).unwrap(),
            String::from_utf8_lossy(&o.stdout).to_string(),
        )
    };
    let ((bent_nc, said), (flat_nc, _)) = (
        plan(&out.join("design.json"), "bent.nc"),
        plan(&out.join("flat.json"), "flat.nc"),
    );
    assert!(
        said.contains("bent plate") && said.contains("carves the flat sheet"),
        "{said}"
    );
    let cuts = |g: &str| {
        g.lines()
            .filter(|l| !l.starts_with(';'))
            .map(String::from)
            .collect::<Vec<_>>()
    };
    assert!(cuts(&bent_nc).len() > 100);
    assert_eq!(cuts(&bent_nc), cuts(&flat_nc));

    // Mistakes in the flags: exit 2, naming what to add or change.
    for (extra, words) in [
        (vec!["--plate-shape", "cylinder"], "needs --radius"),
        (vec!["--radius", "80"], "--plate-shape cylinder"),
        (vec!["--plate-shape", "cylinder", "--radius", "10"], "too small"),
    ] {
        let mut a = tool_design_args(&tool, out_s);
        a.extend(extra.iter().copied());
        let o = run_scratchart(&a);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{extra:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(words),
            "{extra:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
