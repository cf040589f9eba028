//! The journal a run starts with: resumed, new, or new beside an unfinished one kept
//! (`--restart`); never an unfinished job overwritten without consent.
use std::path::{Path, PathBuf};

use scratchart_observe::Observer;

use super::{CarveError, Options};
use crate::journal::Journal;
use crate::program::Program;

/// The journal of this run: the one `--resume` continues (refused where the plan changed since;
/// None where it says the job is finished), or a new one (refused where the journal records an
/// unfinished job, unless `--restart`, which keeps that journal beside the new).
pub(super) fn open_journal(
    opts: &Options,
    program: &Program,
    obs: &dyn Observer,
) -> Result<Option<Journal>, CarveError> {
    let fw = Program::firmware_name(program.firmware);
    let total = program.blocks.len();
    Ok(Some(if opts.resume {
        let j = Journal::load(&opts.journal).map_err(|e| CarveError::Usage(e.to_string()))?;
        if j.plan_checksum != program.checksum {
            return Err(CarveError::Input(format!(
                "{} changed since the job in {} started (checksum {} then, {} now): a changed plan \
                 cannot be resumed; carve it anew without --resume",
                opts.plan.display(),
                opts.journal.display(),
                j.plan_checksum,
                program.checksum
            )));
        }
        if j.state == "done" {
            obs.info(&format!(
                "the journal {} says the job is finished: nothing to do",
                opts.journal.display()
            ));
            return Ok(None);
        }
        j
    } else {
        if opts.journal.exists() {
            let unfinished = match Journal::load(&opts.journal) {
                Ok(j) if j.state == "done" => None,
                Ok(j) => Some(if j.plan_checksum == program.checksum {
                    format!(
                        "an unfinished job of this plan is recorded in {} ({} of {} cuts acknowledged). \
                         Continue it with `{}`",
                        opts.journal.display(),
                        j.last_acked.map_or(0, |k| k + 1),
                        j.total,
                        opts.resume_command
                    )
                } else {
                    format!(
                        "an unfinished job of an earlier version of this plan is recorded in {} ({} of {} cuts \
                         acknowledged; it cannot be resumed: the plan changed)",
                        opts.journal.display(),
                        j.last_acked.map_or(0, |k| k + 1),
                        j.total
                    )
                }),
                Err(e) => Some(format!("the journal {} cannot be read ({e})", opts.journal.display())),
            };
            if let Some(what) = unfinished {
                if !opts.restart {
                    return Err(CarveError::Usage(format!(
                        "{what}, or start the job again from its first cut with --restart (the old journal is \
                         kept beside the new). Nothing was sent"
                    )));
                }
                let kept = keep_beside(&opts.journal).map_err(CarveError::Stopped)?;
                obs.info(&format!(
                    "--restart: starting the job again from its first cut; the old journal is kept as {}",
                    kept.display()
                ));
            }
        }
        Journal::new(&opts.plan.display().to_string(), &program.checksum, fw, total)
    }))
}

/// Moves `journal` to the first free `JOURNAL.N` beside it (N = 1, 2, ...); the new name.
fn keep_beside(journal: &Path) -> Result<PathBuf, String> {
    let name = journal.file_name().unwrap_or_default().to_string_lossy().to_string();
    let kept = (1..)
        .map(|n| journal.with_file_name(format!("{name}.{n}")))
        .find(|p| !p.exists())
        .expect("a free name");
    std::fs::rename(journal, &kept).map_err(|e| {
        format!(
            "cannot keep the old journal {} as {}: {e}",
            journal.display(),
            kept.display()
        )
    })?;
    Ok(kept)
}
