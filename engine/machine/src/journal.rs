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
    /// Index, in plan order, of the last block whose every line was acknowledged (None: none yet);
    /// the plan comment's `(cut K of T)` has K = this + 1.
    pub last_acked: Option<usize>,
    /// That block's scratch number in the design (`; scratch N`).
    pub last_acked_scratch: Option<usize>,
    /// "running", "stopped", "interrupted" or "done".
    pub state: String,
    /// What stopped the job, when it stopped.
    pub message: String,
    /// Why the controller's position can no longer be trusted (a reset, an alarm, a quickstop
    /// seen since the last acknowledged line), until a resume homes or probes; `carve --resume
    /// --rezero keep` refuses to move while it is set.
    #[serde(default)]
    pub position_lost: Option<String>,
    /// The controller's machine position when the journal was last written with one (GRBL
    /// `MPos`): a controller found at (0, 0, 0) after it was elsewhere has been reset.
    #[serde(default)]
    pub machine_pos: Option<[f64; 3]>,
}

/// The journal path for a plan: `PLAN.journal.json` beside it.
pub fn default_path(plan: &Path) -> PathBuf {
    let mut name = plan.file_name().unwrap_or_default().to_os_string();
    name.push(".journal.json");
    plan.with_file_name(name)
}

/// A journal that cannot be read (or is damaged: the user's input, exit 3) or written (the
/// job's failure, exit 1). `carve --resume` treats a journal it cannot read as a flag that cannot
/// work (exit 2: resume without `--resume`), before this class is asked.
#[derive(Clone, Debug, PartialEq)]
pub enum JournalError {
    Read(String),
    Write(String),
}

impl std::fmt::Display for JournalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JournalError::Read(m) | JournalError::Write(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for JournalError {}

impl scratchart_exit::ExitClass for JournalError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(match self {
            JournalError::Read(_) => scratchart_exit::Class::Input,
            JournalError::Write(_) => scratchart_exit::Class::Runtime,
        })
    }
}

impl Journal {
    /// The journal of a job starting now: nothing acknowledged yet, "running".
    pub fn new(plan: &str, plan_checksum: &str, firmware: &str, total: usize) -> Journal {
        Journal {
            plan: plan.to_string(),
            plan_checksum: plan_checksum.to_string(),
            firmware: firmware.to_string(),
            total,
            last_acked: None,
            last_acked_scratch: None,
            state: "running".into(),
            message: String::new(),
            position_lost: None,
            machine_pos: None,
        }
    }

    pub fn load(path: &Path) -> Result<Journal, JournalError> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            JournalError::Read(format!(
                "cannot read the journal {}: {e} (a job that never started has none: run \
                 without --resume)",
                path.display()
            ))
        })?;
        serde_json::from_str(&text)
            .map_err(|e| JournalError::Read(format!("the journal {} is damaged: {e}", path.display())))
    }

    pub fn save(&self, path: &Path) -> Result<(), JournalError> {
        let text = serde_json::to_string_pretty(self).expect("a journal serializes");
        scratchart_model::fsio::write_atomic(path, text.as_bytes()).map_err(|e| JournalError::Write(e.to_string()))
    }

    /// Records that block `b` (scratch `scratch` of the design) was acknowledged. The journal
    /// never goes backwards: a resumed run re-sends a few blocks before the last acknowledged one.
    pub fn acked(&mut self, b: usize, scratch: Option<usize>) {
        if !matches!(self.last_acked, Some(k) if k >= b) {
            self.last_acked = Some(b);
            self.last_acked_scratch = scratch;
        }
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
        let mut j = Journal::new(&plan.display().to_string(), "00", "grbl", 40);
        assert_eq!(j.resume_from(), 0);
        j.last_acked = Some(2);
        assert_eq!(j.resume_from(), 0);
        j.last_acked = Some(20);
        assert_eq!(j.resume_from(), 21 - RESUME_OVERLAP);
        // A resumed run acknowledges blocks before 20 again: the journal stays at 20.
        j.acked(17, Some(3));
        assert_eq!((j.last_acked, j.last_acked_scratch), (Some(20), None));
        j.acked(21, Some(9));
        assert_eq!((j.last_acked, j.last_acked_scratch), (Some(21), Some(9)));
        j.save(&path).unwrap();
        assert_eq!(Journal::load(&path).unwrap(), j);
        // Journals written before the position fields still load.
        let old = serde_json::to_string(&j)
            .unwrap()
            .replace(",\"position_lost\":null,\"machine_pos\":null", "");
        assert!(!old.contains("position_lost"), "{old}");
        assert_eq!(serde_json::from_str::<Journal>(&old).unwrap(), j);
        std::fs::write(&path, "{").unwrap();
        assert!(Journal::load(&path).unwrap_err().to_string().contains("damaged"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
