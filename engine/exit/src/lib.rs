//! The exit-code contract of every binary of the project, in one place:
//!
//! | code | class | meaning |
//! |---|---|---|
//! | 0 | | success |
//! | 1 | [`Class::Runtime`] | the job stopped: divergence, an output that cannot be written, the machine stopped the job (`error:N`, `ALARM`, a halt, a lost port), validation-layer messages under `--validation` |
//! | 2 | [`Class::Usage`] | bad command line (flags, or flag values that cannot work) |
//! | 3 | [`Class::Input`] | bad input file (scene, scratch CSV, target image, checkpoint, plan, tool, machine profile, photo) |
//! | 4 | [`Class::Device`] | GPU or device failure (no device, out of memory, a scene over the device's limits) |
//! | 130 | [`Class::Interrupted`] | interrupted (Ctrl-C); long jobs save their state first and say how to resume |
//!
//! Each library's error implements [`ExitClass`]; the application maps an error chain to its
//! code in one function (`scratchart::exit::code`) and ends through [`ExitCode`]s built by
//! [`Class::exit_code`]. [`exit_now`] is the one `process::exit` of the project, for a signal
//! handler that cannot return to `main` (a third Ctrl-C).

/// What kind of failure an error is, and so the process's exit code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    Runtime,
    Usage,
    Input,
    Device,
    Interrupted,
}

impl Class {
    /// The exit code of the contract.
    pub const fn code(self) -> u8 {
        match self {
            Class::Runtime => 1,
            Class::Usage => 2,
            Class::Input => 3,
            Class::Device => 4,
            Class::Interrupted => 130,
        }
    }

    pub fn exit_code(self) -> std::process::ExitCode {
        std::process::ExitCode::from(self.code())
    }
}

/// An error's class in the contract. `None`: this error does not decide; its `source()` does
/// (a wrapper that adds context only).
pub trait ExitClass {
    fn exit_class(&self) -> Option<Class>;
}

/// A flag or flag value that cannot work; the message names the flag and what to give instead.
#[derive(Debug)]
pub struct UsageError(pub String);

/// An input file that is readable but wrong for the job (a target of the wrong size, ...); the
/// message names the file and what was expected.
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}
impl std::error::Error for InputError {}

impl ExitClass for UsageError {
    fn exit_class(&self) -> Option<Class> {
        Some(Class::Usage)
    }
}

impl ExitClass for InputError {
    fn exit_class(&self) -> Option<Class> {
        Some(Class::Input)
    }
}

/// One way to ask an error of a known type for its class (see [`classify`]).
pub type Classifier = fn(&(dyn std::error::Error + 'static)) -> Option<Class>;

/// The classifier of error type `T`.
pub fn classifier<T: ExitClass + std::error::Error + 'static>(e: &(dyn std::error::Error + 'static)) -> Option<Class> {
    e.downcast_ref::<T>().and_then(ExitClass::exit_class)
}

/// The class of an error chain: the first error in its `source()` chain that one of `known`
/// classifies decides; anything else is a runtime failure.
pub fn classify(err: &(dyn std::error::Error + 'static), known: &[Classifier]) -> Class {
    let mut cur: Option<&(dyn std::error::Error + 'static)> = Some(err);
    while let Some(e) = cur {
        if let Some(c) = known.iter().find_map(|k| k(e)) {
            return c;
        }
        cur = e.source();
    }
    Class::Runtime
}

/// Ends the process at once with `class`'s code: for a signal handler that cannot return to
/// `main` (the project's only `process::exit`).
pub fn exit_now(class: Class) -> ! {
    std::process::exit(class.code() as i32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug)]
    struct Wrapper(InputError);
    impl std::fmt::Display for Wrapper {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("reading the plan")
        }
    }
    impl std::error::Error for Wrapper {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn the_first_known_error_in_the_chain_decides() {
        let known: &[Classifier] = &[classifier::<UsageError>, classifier::<InputError>];
        assert_eq!(classify(&UsageError("--x".into()), known), Class::Usage);
        assert_eq!(classify(&Wrapper(InputError("plan".into())), known), Class::Input);
        assert_eq!(classify(&std::io::Error::other("disk"), known), Class::Runtime);
        assert_eq!(
            [
                Class::Runtime,
                Class::Usage,
                Class::Input,
                Class::Device,
                Class::Interrupted
            ]
            .map(Class::code),
            [1, 2, 3, 4, 130]
        );
    }
}
