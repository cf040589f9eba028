//! The job journal: a small JSON file beside the plan (`PLAN.nc.journal.json`), written
//! atomically (temporary file, fsync, rename), that records the last scratch whose lines the
//! controller acknowledged and the plan's checksum, so `carve --resume` continues the same plan
//! and refuses a changed one.
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// How many scratches before the last acknowledged one a resumed job starts: acknowledged lines
/// may still wait in the controller's planner (16 moves, 4 per scratch, in GRBL and Marlin), so
/// the resumed job re-cuts at most these and skips nothing.
pub const RESUME_OVERLAP: usize = 5;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Journal {
    /// The plan's file, as given to `carve`.
    pub plan: String,
    /// FNV-1a 64 of the plan's bytes ([`crate::program::checksum`]).
    pub plan_checksum: String,
    /// "grbl" or "marlin".
    pub firmware: String,
    /// Scratches (blocks) in the plan.
    pub total: usize,
    /// Index, in plan order, of the last block whose every line was acknowledged (None: none yet).
    pub last_acked: Option<usize>,
    /// That block's scratch number in the design (`; scratch N`).
    pub last_acked_scratch: Option<usize>,
    /// "running", "stopped", "interrupted" or "done".
    pub state: String,
    /// What stopped the job, when it stopped.
    pub message: String,
}

/// The journal path for a plan: `PLAN.journal.json` beside it.
pub fn default_path(plan: &Path) -> PathBuf {
    let mut name = plan.file_name().unwrap_or_default().to_os_string();
    name.push(".journal.json");
    plan.with_file_name(name)
}

impl Journal {
    pub fn load(path: &Path) -> Result<Journal, String> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            format!(
                "cannot read the journal {}: {e} (a job that never started has none: run \
                 without --resume)",
                path.display()
            )
        })?;
        serde_json::from_str(&text).map_err(|e| format!("the journal {} is damaged: {e}", path.display()))
    }

    pub fn save(&self, path: &Path) -> Result<(), String> {
        let text = serde_json::to_string_pretty(self).expect("a journal serializes");
        scratchart_model::fsio::write_atomic(path, text.as_bytes()).map_err(|e| e.to_string())
    }

    /// The block a resumed job starts at: [`RESUME_OVERLAP`] before the one after the last
    /// acknowledged block.
    pub fn resume_from(&self) -> usize {
        match self.last_acked {
            None => 0,
            Some(k) => (k + 1).saturating_sub(RESUME_OVERLAP),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_resume_point() {
        let dir = std::env::temp_dir().join(format!("scratchart_journal_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let plan = dir.join("plan.nc");
        let path = default_path(&plan);
        assert_eq!(path, dir.join("plan.nc.journal.json"));
        let mut j = Journal {
            plan: plan.display().to_string(),
            plan_checksum: "00".into(),
            firmware: "grbl".into(),
            total: 40,
            last_acked: None,
            last_acked_scratch: None,
            state: "running".into(),
            message: String::new(),
        };
        assert_eq!(j.resume_from(), 0);
        j.last_acked = Some(2);
        assert_eq!(j.resume_from(), 0);
        j.last_acked = Some(20);
        assert_eq!(j.resume_from(), 21 - RESUME_OVERLAP);
        j.save(&path).unwrap();
        assert_eq!(Journal::load(&path).unwrap(), j);
        std::fs::write(&path, "{").unwrap();
        assert!(Journal::load(&path).unwrap_err().contains("damaged"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
