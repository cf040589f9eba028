//! A fit that resumes: the state of the kinds fitted so far, kept beside the output and keyed
//! to the photos and the flags.
use std::path::PathBuf;

use anyhow::{Context as _, Result};
use scratchart_exit::InputError;
use scratchart_observe::Observer;

use super::FitArgs;
use crate::fit::{FitResult, Start};

/// The resume file of this fit (`OUT.resume.json`) and what it holds: with `--resume`, the
/// state an interrupted fit of the same photos, card and options left (refused where it is of
/// others); else a fresh state.
pub(super) fn open_resume(args: &FitArgs, files: &[PathBuf], obs: &dyn Observer) -> Result<(PathBuf, ResumeState)> {
    let state_path = resume_path(&args.out);
    let key = resume_key(args, files)?;
    let mut state = ResumeState {
        key: key.clone(),
        done: Vec::new(),
        current: None,
    };
    if args.resume {
        match std::fs::read(&state_path) {
            Ok(bytes) => {
                let old: ResumeState = serde_json::from_slice(&bytes).map_err(|e| {
                    InputError(format!(
                        "resume file `{}` is unreadable ({e}); remove it and run without --resume",
                        state_path.display()
                    ))
                })?;
                if old.key != key {
                    return Err(InputError(format!(
                        "resume file `{}` is from a fit of other photos, another card or other options; \
                         run with the same ones, or remove it and run without --resume",
                        state_path.display()
                    ))
                    .into());
                }
                obs.info(&format!(
                    "resuming: {} kind(s) done{}",
                    old.done.len(),
                    old.current
                        .as_ref()
                        .map_or(String::new(), |c| format!(", {} searched", c.0))
                ));
                state = old;
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                obs.info(&format!(
                    "no interrupted fit at `{}`: starting afresh",
                    state_path.display()
                ));
            }
            Err(e) => return Err(anyhow::anyhow!("cannot read `{}`: {e}", state_path.display())),
        }
    }
    if let Some(dir) = state_path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    Ok((state_path, state))
}

/// What an interrupted fit had done (`--resume`): the kinds it finished, and the start points of
/// the kind it was refining. `key` ties it to the photos, the card and the options.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct ResumeState {
    pub(super) key: String,
    pub(super) done: Vec<FitResult>,
    pub(super) current: Option<(String, Vec<Start>)>,
}

/// The resume file of a fit writing `out`: `out` with the extension `.resume.json`.
pub fn resume_path(out: &std::path::Path) -> PathBuf {
    out.with_extension("resume.json")
}

/// A digest of what decides a fit: the card file, every photo's bytes, the kind, the start tool
/// and the options (FNV-1a 64 of each part's FNV-1a 64, so concatenations differ).
pub(super) fn resume_key(args: &FitArgs, files: &[PathBuf]) -> Result<String> {
    use scratchart_optim::checkpoint::fnv;
    let read = |p: &std::path::Path| std::fs::read(p).with_context(|| format!("cannot read {}", p.display()));
    let mut parts = vec![fnv(&read(&args.card)?)];
    for f in files {
        parts.push(fnv(&read(f)?));
    }
    parts.push(fnv(
        format!("{:?}|{}|{}", args.kind, args.iters, args.bootstrap).as_bytes()
    ));
    if let Some(p) = &args.init {
        parts.push(fnv(&read(p)?));
    }
    let bytes: Vec<u8> = parts.iter().flat_map(|h| h.to_le_bytes()).collect();
    Ok(format!("{:016x}", fnv(&bytes)))
}
