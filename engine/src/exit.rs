//! One exit-code contract for every binary of the project, in one place:
//!
//! | code | meaning |
//! |---|---|
//! | 0 | success |
//! | 1 | runtime failure (the job stopped: divergence, an output that cannot be written, ...) |
//! | 2 | bad command line (flags, or flag values that cannot work) |
//! | 3 | bad input file (scene, scratch CSV, target image, checkpoint) |
//! | 4 | GPU or device failure (no device, out of memory, a scene over the device's limits) |
//! | 130 | interrupted (Ctrl-C); long jobs save their state first and say how to resume |
//!
//! Binaries keep `anyhow` with context for their messages and call [`code`] on the error.
use std::error::Error;

use crate::io::IoError;
use crate::model::scene::SceneError;
use crate::optim::targets::TargetError;
use crate::optim::OptimError;
use crate::vulkan::GpuError;

pub const SUCCESS: u8 = 0;
pub const RUNTIME: u8 = 1;
pub const USAGE: u8 = 2;
pub const INPUT: u8 = 3;
pub const GPU: u8 = 4;
pub const INTERRUPTED: u8 = 130;

/// A flag or flag value that cannot work; the message names the flag and what to give instead.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// An input file that is readable but wrong for the job (a target of the wrong size, ...); the
/// message names the file and what was expected.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InputError(pub String);

/// The exit code of an error: the first error in its `source()` chain that the contract knows
/// decides; anything else is a runtime failure.
pub fn code(err: &(dyn Error + 'static)) -> u8 {
    let mut cur: Option<&(dyn Error + 'static)> = Some(err);
    while let Some(e) = cur {
        if let Some(c) = known(e) {
            return c;
        }
        cur = e.source();
    }
    RUNTIME
}

fn known(e: &(dyn Error + 'static)) -> Option<u8> {
    if e.is::<UsageError>() || e.is::<clap::Error>() {
        return Some(USAGE);
    }
    if let Some(io) = e.downcast_ref::<IoError>() {
        return Some(if io.is_output() { RUNTIME } else { INPUT });
    }
    if let Some(SceneError::Write(_)) = e.downcast_ref::<SceneError>() {
        return Some(RUNTIME);
    }
    if let Some(TargetError::Image(io)) = e.downcast_ref::<TargetError>() {
        return known(io);
    }
    if e.is::<InputError>() || e.is::<SceneError>() || e.is::<TargetError>() {
        return Some(INPUT);
    }
    if e.is::<GpuError>() {
        return Some(GPU);
    }
    if let Some(o) = e.downcast_ref::<OptimError>() {
        return match o {
            // transparent wrappers (their `source()` skips the wrapped error): it decides
            OptimError::Gpu(g) => known(g),
            OptimError::Io(i) => known(i),
            OptimError::NoCheckpoint { .. } | OptimError::Damaged { .. } => Some(INPUT),
            OptimError::Mismatch { .. } | OptimError::Usage(_) => Some(USAGE),
            OptimError::Diverged(_) | OptimError::Stopped(_) | OptimError::Report(_) => Some(RUNTIME),
            OptimError::Interrupted { .. } => Some(INTERRUPTED),
        };
    }
    None
}

/// Exit code of an `anyhow` error (what the binaries hold).
pub fn code_of(err: &anyhow::Error) -> u8 {
    code(err.as_ref())
}

/// Parses the command line of a binary: a clap error (or `--help`, `--version`) is printed and
/// becomes the exit code (2, or success for help) in `Err`.
/// When the binary started (the first thing every binary's `main` does is [`parse_args`]); for
/// wall-time reports that include start-up.
static PROCESS_START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();

/// The start of this process as recorded by [`parse_args`] (or the first call, when a library
/// user never called it).
pub fn process_start() -> std::time::Instant {
    *PROCESS_START.get_or_init(std::time::Instant::now)
}

/// Parses the command line (see the contract above) and records the start time.
pub fn parse_args<P: clap::Parser>() -> Result<P, std::process::ExitCode> {
    let _ = PROCESS_START.set(std::time::Instant::now());
    P::try_parse().map_err(|e| {
        let _ = e.print();
        if e.use_stderr() {
            std::process::ExitCode::from(USAGE)
        } else {
            std::process::ExitCode::SUCCESS
        }
    })
}

/// The end of a binary's `main`: success, or the error printed (with its causes) and its code.
pub fn finish(result: anyhow::Result<()>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(code_of(&e))
        }
    }
}
