//! [`OptimError`]: what can stop an optimization. The binaries map it to exit codes in one
//! place (`crate::exit`).
use std::path::{Path, PathBuf};

use crate::io::IoError;
use crate::vulkan::GpuError;

#[derive(Debug, thiserror::Error)]
pub enum OptimError {
    #[error(transparent)]
    Gpu(#[from] GpuError),

    /// Writing a checkpoint or an output failed.
    #[error(transparent)]
    Io(#[from] IoError),

    #[error("cannot resume: cannot read checkpoint `{path}`: {cause} (run without --resume to start afresh)")]
    NoCheckpoint {
        path: PathBuf,
        /// The OS error (part of the message, so not repeated as a source).
        cause: std::io::Error,
    },

    #[error("checkpoint `{path}` is damaged: {msg}; run without --resume")]
    Damaged { path: PathBuf, msg: String },

    #[error(
        "checkpoint `{path}` was made with different settings ({what} differ); resume with the same \
         flags and targets, or run without --resume"
    )]
    Mismatch { path: PathBuf, what: String },

    /// Bad steps could not be recovered from.
    #[error("{0}")]
    Diverged(String),

    /// A test hook stopped the run (as a killed run would stop).
    #[error("stopped by the test hook at iteration {0}")]
    Stopped(u32),

    /// A report (plot, summary) could not be made.
    #[error("{0}")]
    Report(String),

    /// The user stopped the run (Ctrl-C); a checkpoint was written first when the run keeps them.
    #[error("interrupted at iteration {iter}{}", match .checkpoint { Some(p) => format!("; the state is saved in `{}`", p.display()), None => String::new() })]
    Interrupted { iter: u32, checkpoint: Option<PathBuf> },

    /// A setting that cannot work (names the flag to change).
    #[error("{0}")]
    Usage(String),
}

impl OptimError {
    pub fn damaged(path: &Path, msg: String) -> OptimError {
        OptimError::Damaged {
            path: path.to_path_buf(),
            msg,
        }
    }
}

/// The exit class of each way an optimization stops (the one contract of `scratchart-exit`).
impl scratchart_exit::ExitClass for OptimError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(match self {
            // transparent wrappers (their `source()` skips the wrapped error): it decides
            OptimError::Gpu(g) => return scratchart_exit::ExitClass::exit_class(g),
            OptimError::Io(i) => return scratchart_exit::ExitClass::exit_class(i),
            OptimError::NoCheckpoint { .. } | OptimError::Damaged { .. } => scratchart_exit::Class::Input,
            OptimError::Mismatch { .. } | OptimError::Usage(_) => scratchart_exit::Class::Usage,
            OptimError::Diverged(_) | OptimError::Stopped(_) | OptimError::Report(_) => scratchart_exit::Class::Runtime,
            OptimError::Interrupted { .. } => scratchart_exit::Class::Interrupted,
        })
    }
}
