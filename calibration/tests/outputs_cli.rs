//! Every `scratchart-cal` command that writes a file (and `scratchart setup`) exits 1, naming the
//! path, when it cannot write it (here: a path under a file), as the README's exit codes say.
use std::process::Command;

#[test]
fn an_output_that_cannot_be_written_exits_1() {
    let cal = scratchart_tests::workspace_bin("scratchart-calibration", "scratchart-cal");
    let dir = std::env::temp_dir().join(format!("scratchart-outputs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    scratchart_tests::carvable_design(60.0, 10, &scratchart_tests::v60_tool())
        .save(&dir.join("design.json"), "s.csv")
        .unwrap();
    std::fs::write(dir.join("tool.json"), scratchart_tests::V60_TOOL_JSON).unwrap();
    let run = |args: &[&str]| Command::new(&cal).current_dir(&dir).args(args).output().unwrap();
    let o = run(&["card", "--out", "card", "--res", "48"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A path under a file: no command can make it.
    let blocked = "design.json/out";
    for args in [
        vec!["card", "--out", blocked, "--res", "48"],
        vec![
            "plan",
            "design.json",
            "--tool",
            "tool.json",
            "--out",
            "design.json/out/p.nc",
        ],
        vec!["export", "design.json", "--svg", "design.json/out/e.svg"],
        vec!["export", "design.json", "--dxf", "design.json/out/e.dxf"],
        vec![
            "simulate",
            "--card",
            "card/card.json",
            "--tool",
            "tool.json",
            "--out",
            blocked,
        ],
    ] {
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("design.json"), "{args:?} names the path: {err}");
    }
    // The set-up sheet of the design, likewise.
    let engine = scratchart_tests::workspace_bin("scratchart", "scratchart");
    let o = Command::new(&engine)
        .current_dir(&dir)
        .args(["setup", "design.json", "--out", blocked])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "setup: {err}");
    assert!(err.contains("design.json/out"), "setup names the path: {err}");
}
