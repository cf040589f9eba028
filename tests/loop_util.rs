//! What the closed loop's tests share: a fresh folder, `scratchart-cal`, its output checked,
//! JSON read, a V-bit tool file.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use scratchart_tests::*;

pub fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("scratchart-loop-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn cal(args: &[&str]) -> Output {
    Command::new(workspace_bin("scratchart-calibration", "scratchart-cal"))
        .args(args)
        .output()
        .unwrap()
}

pub fn ok(o: Output, what: &str) -> String {
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{what} failed ({:?}): {text}", o.status.code());
    text
}

pub fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// A V-bit of `angle` degrees with a `flat` mm tip and z offset `off` mm, as a tool file.
pub fn vbit(dir: &Path, name: &str, angle: f64, flat: f64, off: f64) -> String {
    write_file(
        dir,
        name,
        &format!(r#"{{"kind": "v-bit", "angle_deg": {angle}, "tip_flat_mm": {flat}, "z_offset_mm": {off}}}"#),
    )
}

/// A fabrication design for the GRBL router in `dir/d` (`views` views of `res` px, `scratches`
/// scratches, `iters` iterations, no pruning, through `tool`, the lamp 65 degrees up at azimuth
/// 0): its design.json.
pub fn tool_design(dir: &Path, tool: &str, views: u32, res: u32, scratches: u32, iters: u32) -> String {
    let out = dir.join("d").display().to_string();
    let (v, r, s, i) = (
        views.to_string(),
        res.to_string(),
        scratches.to_string(),
        iters.to_string(),
    );
    let o = run_scratchart(&[
        "design",
        "--views",
        &v,
        "--res",
        &r,
        "--scratches",
        &s,
        "--iters",
        &i,
        "--prune-tol",
        "0",
        // The lamp 65 degrees up on view 0's side (not overhead, the default for three views,
        // where turning it about the normal moves nothing): the loop's tests find it turned.
        "--light-elevation",
        "65",
        "--light-azimuth",
        "0",
        // The random start the loop's bars were measured on: from the aimed start (the
        // default since) this 600-scratch design pins the machine's depth scale to 0.027
        // where `inspect` asks for 0.025, and refuses it (engine/docs/worst_view.md).
        "--aim",
        "0",
        "--quiet",
        "--tool",
        tool,
        "--machine",
        "grbl",
        "--out",
        &out,
    ]);
    ok(o, "design");
    format!("{out}/design.json")
}
