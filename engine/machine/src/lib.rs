//! `scratchart-machine`: the machine driver of the chain design -> calibration -> carving.
//!
//! - [`plan`]: machine profiles (GRBL router, Marlin printer), the cut order (nearest neighbour
//!   with reversal, then 2-opt), travel, bounds and the job time with acceleration.
//! - [`gcode`]: the one G-code writer (GRBL and Marlin flavours).
//! - [`depths`]: one commanded depth per scratch from the tool profile.
//! - [`marks`]: the marks `scratchart-cal plan` carves after a design's scratches (the +x mark and
//!   the calibration card's hatched squares as registration marks), and the design's job time
//!   with them.
//!
//! Streaming a plan to the controller (`scratchart-cal carve`):
//! - [`program`]: a plan read back: firmware, preamble, one block per scratch, postamble.
//! - [`transport`]: the serial port (`serialport`; a pty's path works too), read by lines.
//! - [`controller`]: the one machine interface; [`grbl`] (with [`grbl_codes`]) and [`marlin`]
//!   implement it; [`detect`] asks the port which one answers.
//! - [`stream`]: the streaming engine (receive-buffer flow control, resends, hold, progress);
//!   [`job`]: a whole job (settings check, check mode, resume and re-zero, stopping safely);
//!   [`journal`]: the resumable job's record beside the plan.
//! - [`fake`]: fake GRBL and Marlin controllers on pseudo-terminals, for tests (Unix), and on an
//!   in-memory pipe: the simulated controller of a dry run (`carve --port sim`).
//! - [`probe`]: levelling: the plate probed on a grid with the tool, as a [`level::HeightMap`].
//!
//! It depends on the scene model (`scratchart-model`) only, never on the engine, so it builds and
//! tests without Vulkan, shaderc or a GPU: `cargo build -p scratchart-machine` pulls no Vulkan
//! crate (check with `cargo tree -p scratchart-machine`).

pub mod carved;
pub mod controller;
pub mod depths;
pub mod detect;
pub mod export;
/// (on pseudo-terminals for tests: Unix only; on an in-memory pipe for `carve --port sim`)
pub mod fake;
pub mod gcode;
pub mod grbl;
pub mod grbl_codes;
pub mod job;
pub mod journal;
pub mod level;
pub mod marks;
pub mod marlin;
pub mod plan;
pub mod planner;
pub mod probe;
pub mod program;
pub mod stream;
pub mod transport;

use std::path::Path;

use scratchart_model::scene::{Scene, SceneError};

/// Loads a design (the `design.json` that `scratchart design` writes, with its scratch CSV, or
/// any scene file) with the model's reader, which validates every scratch and view against
/// engine/docs/model.md. Errors name the file and the place, as the engine's do.
pub fn load_design(path: &Path) -> Result<Scene, SceneError> {
    Scene::load(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use scratchart_model::scene::Scratch;

    fn tmpdir(tag: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("scratchart_machine_{}_{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn design() -> Scene {
        Scene::bare(
            100.0,
            vec![
                Scratch::from_row([-10.0, 0.0, 10.0, 5.0, 0.05, 0.01, 0.1]),
                Scratch::from_row([1.0 / 3.0, -2.0, 4.5, 0.1, 0.07, 0.02, 0.3]),
            ],
        )
    }

    #[test]
    fn loads_a_saved_design_exactly() {
        let d = tmpdir("roundtrip");
        let scene = design();
        scene.save(&d.join("design.json"), "scratches.csv").unwrap();
        assert_eq!(load_design(&d.join("design.json")).unwrap(), scene);
    }

    #[test]
    fn errors_name_the_file() {
        let d = tmpdir("errors");
        let missing = d.join("nothere.json");
        let msg = load_design(&missing).unwrap_err().to_string();
        assert!(msg.contains("nothere.json"), "{msg}");
        // A scratch off the plate is refused by the model's validation, naming the CSV row.
        let mut scene = design();
        scene.scratches[1].p1 = [60.0, 0.0];
        scene.save(&d.join("bad.json"), "bad.csv").unwrap();
        match load_design(&d.join("bad.json")) {
            Err(SceneError::Csv { file, row, .. }) => {
                assert!(file.ends_with("bad.csv"), "{file}");
                assert_eq!(row, 2);
            }
            other => panic!("expected a CSV error for row 2, got {other:?}"),
        }
    }
}
