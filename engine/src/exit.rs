//! One exit-code contract for every binary of the project (the table is in `scratchart-exit`):
//!
//! | code | meaning |
//! |---|---|
//! | 0 | success |
//! | 1 | runtime failure (the job stopped: divergence, an output that cannot be written, the machine stopped the job, validation messages under `--validation`) |
//! | 2 | bad command line (flags, or flag values that cannot work) |
//! | 3 | bad input file (scene, scratch CSV, target image, checkpoint, plan, tool, profile, photo) |
//! | 4 | GPU or device failure (no device, out of memory, a scene over the device's limits) |
//! | 130 | interrupted (Ctrl-C); long jobs save their state first and say how to resume |
//!
//! Binaries keep `anyhow` with context for their messages and end through [`finish`], which
//! maps the error chain with [`code`]: the one mapping of every binary (engine, viewer,
//! calibration), over the error types of every library (engine, tool, machine).
use std::error::Error;

use scratchart_exit::{Class, InputError, UsageError};

use scratchart_design::targets::TargetError;
use scratchart_model::scene::SceneError;
use scratchart_optim::error::OptimError;
use scratchart_render::io::IoError;
use scratchart_vulkan::GpuError;

/// Every error type of the project's libraries, and clap's.
const KNOWN: &[scratchart_exit::Classifier] = &[
    scratchart_exit::classifier::<UsageError>,
    scratchart_exit::classifier::<InputError>,
    scratchart_exit::classifier::<IoError>,
    scratchart_exit::classifier::<SceneError>,
    scratchart_exit::classifier::<TargetError>,
    scratchart_exit::classifier::<scratchart_design::SpecError>,
    scratchart_exit::classifier::<scratchart_optim::tool_params::FabricationError>,
    scratchart_exit::classifier::<scratchart_model::mesh::MeshError>,
    scratchart_exit::classifier::<GpuError>,
    scratchart_exit::classifier::<OptimError>,
    scratchart_exit::classifier::<scratchart_tool::ToolError>,
    scratchart_exit::classifier::<scratchart_machine::job::CarveError>,
    scratchart_exit::classifier::<scratchart_machine::transport::LinkError>,
    scratchart_exit::classifier::<scratchart_machine::program::ProgramError>,
    scratchart_exit::classifier::<scratchart_machine::journal::JournalError>,
    clap_class,
];

fn clap_class(e: &(dyn Error + 'static)) -> Option<Class> {
    e.is::<clap::Error>().then_some(Class::Usage)
}

/// The class of an error: the first error in its `source()` chain that the contract knows
/// decides; anything else is a runtime failure.
pub fn class(err: &(dyn Error + 'static)) -> Class {
    scratchart_exit::classify(err, KNOWN)
}

/// The exit code of an error (see [`class`]).
pub fn code(err: &(dyn Error + 'static)) -> u8 {
    class(err).code()
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

/// `command` and every subcommand of it taking negative numbers as values (`--plate -5` reaches
/// the range check that says what works, not clap's "unexpected argument '-5'").
pub fn negative_numbers(command: clap::Command) -> clap::Command {
    let names: Vec<String> = command.get_subcommands().map(|s| s.get_name().to_string()).collect();
    let mut command = command.allow_negative_numbers(true);
    for n in names {
        command = command.mut_subcommand(n, negative_numbers);
    }
    command
}

/// Parses the command line (see the contract above) and records the start time.
pub fn parse_args<P: clap::Parser>() -> Result<P, std::process::ExitCode> {
    let _ = PROCESS_START.set(std::time::Instant::now());
    negative_numbers(P::command())
        .try_get_matches()
        .and_then(|m| P::from_arg_matches(&m))
        .map_err(|e| {
            let _ = e.print();
            if e.use_stderr() {
                Class::Usage.exit_code()
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
