//! The atomic file writer every output of the project goes through (scene files here, images and
//! checkpoints in the engine through `scratchart::io`, G-code later in the machine crate): a
//! reader never sees a partially written file, even when the writer is killed mid-way.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A file could not be written. Every variant names the path.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("cannot {action} `{path}`: {source}")]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The destination has no file name (e.g. `..` or `/`); nothing was written.
    #[error("cannot write `{path}`: the path has no file name")]
    NoFileName { path: PathBuf },
}

fn io_err(action: &'static str, path: &Path, source: std::io::Error) -> WriteError {
    WriteError::Io {
        action,
        path: path.to_path_buf(),
        source,
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

/// Write `bytes` to `path` atomically: write a temporary file in the same directory, fsync it,
/// then rename it over `path` (and, on Unix, fsync the directory). A reader never sees a
/// partially written file; on error the temporary file is removed.
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
    let tmp = temp_path(&dir, &file_name);
    let result = (|| {
        let mut f = fs::File::create(&tmp).map_err(|e| io_err("create", &tmp, e))?;
        f.write_all(bytes).map_err(|e| io_err("write", &tmp, e))?;
        f.sync_all().map_err(|e| io_err("fsync", &tmp, e))?;
        drop(f);
        fs::rename(&tmp, path).map_err(|e| io_err("rename into place", path, e))?;
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
        assert!(msg.contains("cannot create") && msg.contains("missing_dir"), "{msg}");
        let msg = write_atomic(Path::new("/"), b"x").unwrap_err().to_string();
        assert!(msg.contains("no file name"), "{msg}");
    }
}
