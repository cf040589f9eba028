//! The atomic file writer every output of the project goes through (scene files here, images and
//! checkpoints in the engine through `scratchart_render::io`, G-code later in the machine crate): a
//! reader never sees a partially written file, even when the writer is killed mid-way.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A file could not be written. Every variant names the path.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("cannot {action} `{path}`: {cause}")]
    Io {
        action: &'static str,
        path: PathBuf,
        /// The OS error (part of the message, so not repeated as a source).
        cause: std::io::Error,
    },
    /// The destination has no file name (e.g. `..` or `/`); nothing was written.
    #[error("cannot write `{path}`: the path has no file name")]
    NoFileName { path: PathBuf },
}

fn io_err(action: &'static str, path: &Path, source: std::io::Error) -> WriteError {
    WriteError::Io {
        action,
        path: path.to_path_buf(),
        cause: source,
    }
}

/// Makes temporary names unique between threads of one process (the process id separates
/// processes).
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// The temporary file next to `path` that [`write_atomic`] writes first. It lies in the same
/// directory so that the final rename never crosses a file system (a cross-device rename is a
/// copy, and not atomic).
fn temp_path(dir: &Path, file_name: &str) -> PathBuf {
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    dir.join(format!(".{file_name}.tmp.{}.{n}", std::process::id()))
}

/// Removes temporaries of `file_name` left in `dir` by writers that were killed mid-way
/// (`.NAME.tmp.PID.N` whose process no longer runs). Best effort: anything unexpected is left.
fn remove_stale_temporaries(dir: &Path, file_name: &str) {
    let prefix = format!(".{file_name}.tmp.");
    let Ok(entries) = fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let Some(pid) = rest.split('.').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if pid != std::process::id() && !process_alive(pid) {
            let _ = fs::remove_file(e.path());
        }
    }
}

/// Whether process `pid` runs (Linux: /proc/PID exists). Elsewhere every process counts as
/// running, so nothing is removed.
fn process_alive(pid: u32) -> bool {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return true;
    }
    proc.join(pid.to_string()).exists()
}

/// Write `bytes` to `path` atomically: write a temporary file in the same directory, fsync it,
/// then rename it over `path` (and, on Unix, fsync the directory). A reader never sees a
/// partially written file; on error the temporary file is removed, and temporaries that a killed
/// writer left for the same file are removed on the next write.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| WriteError::NoFileName {
            path: path.to_path_buf(),
        })?
        .to_string_lossy()
        .into_owned();
    remove_stale_temporaries(&dir, &file_name);
    let tmp = temp_path(&dir, &file_name);
    let result = (|| {
        // Errors name the file the user asked for, not the temporary one.
        let mut f = fs::File::create(&tmp).map_err(|e| io_err("write", path, e))?;
        f.write_all(bytes).map_err(|e| io_err("write", path, e))?;
        f.sync_all().map_err(|e| io_err("write", path, e))?;
        drop(f);
        fs::rename(&tmp, path).map_err(|e| io_err("write", path, e))?;
        Ok(())
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
        return result;
    }
    #[cfg(unix)]
    {
        // Make the rename durable; failure to open a directory for sync is not an error.
        if let Ok(d) = fs::File::open(&dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("scratchart_fsio_{}_{tag}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn stale_temporaries_of_killed_writers_are_removed() {
        let d = tmpdir("stale");
        let p = d.join("design.json");
        // A temporary of a process that no longer runs (pid 0x7ffffffe is never a live pid on
        // Linux: pid_max is at most 2^22), one of a live process (this one), and an unrelated file.
        let dead = d.join(".design.json.tmp.2147483646.0");
        let live = d.join(format!(".design.json.tmp.{}.99", std::process::id()));
        let other = d.join(".other.json.tmp.2147483646.0");
        for f in [&dead, &live, &other] {
            fs::write(f, b"x").unwrap();
        }
        write_atomic(&p, b"new").unwrap();
        assert!(!dead.exists(), "a dead writer's temporary is removed");
        assert!(live.exists(), "a live writer's temporary is kept");
        assert!(other.exists(), "temporaries of other files are kept");
        // An unwritable destination names the file asked for, not the temporary.
        let err = write_atomic(&d.join("missing-dir/x.json"), b"x")
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing-dir/x.json") && !err.contains(".tmp."), "{err}");
        let _ = fs::remove_dir_all(&d);
    }

    #[test]
    fn replaces_the_file_and_leaves_no_temporary() {
        let d = tmpdir("replace");
        let p = d.join("a.txt");
        write_atomic(&p, b"first").unwrap();
        write_atomic(&p, b"second").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"second");
        let names: Vec<_> = fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(
            names,
            vec![std::ffi::OsString::from("a.txt")],
            "a temporary file was left behind"
        );
    }

    #[test]
    fn errors_name_the_path() {
        let d = tmpdir("errors");
        let p = d.join("missing_dir").join("a.txt");
        let msg = write_atomic(&p, b"x").unwrap_err().to_string();
        assert!(msg.contains("cannot write") && msg.contains("missing_dir"), "{msg}");
        let msg = write_atomic(Path::new("/"), b"x").unwrap_err().to_string();
        assert!(msg.contains("no file name"), "{msg}");
    }
}
