//! Checkpoint files: `SACKPT02`, the length of a JSON header, the header, then the chunks' bytes
//! in the header's order. The header (serde) holds the format version, the fingerprint of the
//! settings a resume must agree with, the optimizer's host state, and each chunk's name, length
//! and FNV-1a checksum. Chunks are found by name, so a parameter set adds state without
//! renumbering anything. Files are written atomically.
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::error::OptimError;

const MAGIC: &[u8; 8] = b"SACKPT02";
const FILE: &str = "checkpoint.bin";
const VERSION: u32 = 2;

/// One named piece of device state.
pub struct Chunk {
    pub name: String,
    pub data: Vec<u8>,
}

#[derive(Serialize, Deserialize)]
struct ChunkInfo {
    name: String,
    bytes: u64,
    fnv: String,
}

/// The header of a checkpoint: `state` is the driver's host state (any serde type: this module
/// does not know it).
#[derive(Serialize, Deserialize)]
struct Header<S> {
    version: u32,
    fingerprint: serde_json::Value,
    state: S,
    chunks: Vec<ChunkInfo>,
}

/// The checkpoint file of an output directory.
pub fn path(dir: &Path) -> PathBuf {
    dir.join(FILE)
}

/// FNV-1a 64 of bytes (chunk checksums and target fingerprints).
pub fn fnv(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

pub(super) fn write<S: Serialize>(
    dir: &Path,
    fingerprint: &serde_json::Value,
    state: &S,
    chunks: &[Chunk],
) -> Result<(), OptimError> {
    let header = Header {
        version: VERSION,
        fingerprint: fingerprint.clone(),
        state,
        chunks: chunks
            .iter()
            .map(|c| ChunkInfo {
                name: c.name.clone(),
                bytes: c.data.len() as u64,
                fnv: format!("{:016x}", fnv(&c.data)),
            })
            .collect(),
    };
    let text = serde_json::to_vec(&header).expect("a checkpoint header always serializes");
    let mut file = Vec::with_capacity(16 + text.len() + chunks.iter().map(|c| c.data.len()).sum::<usize>());
    file.extend_from_slice(MAGIC);
    file.extend_from_slice(&(text.len() as u64).to_le_bytes());
    file.extend_from_slice(&text);
    for c in chunks {
        file.extend_from_slice(&c.data);
    }
    crate::io::write_atomic(&path(dir), &file)?;
    Ok(())
}

/// Reads and checks `dir/checkpoint.bin` against `fingerprint`.
pub(super) fn read<S: serde::de::DeserializeOwned>(
    dir: &Path,
    fingerprint: &serde_json::Value,
) -> Result<(S, Vec<Chunk>), OptimError> {
    let path = path(dir);
    let file = std::fs::read(&path).map_err(|source| OptimError::NoCheckpoint {
        path: path.clone(),
        cause: source,
    })?;
    let bad = |msg: &str| OptimError::damaged(&path, msg.to_string());
    if file.len() < 16 || &file[..8] != MAGIC {
        return Err(bad("not a checkpoint of this version (bad magic)"));
    }
    let n = u64::from_le_bytes(file[8..16].try_into().unwrap()) as usize;
    let text = file
        .get(16..16usize.saturating_add(n))
        .ok_or_else(|| bad("truncated header"))?;
    let header: Header<S> = serde_json::from_slice(text).map_err(|e| bad(&format!("bad header ({e})")))?;
    if header.version != VERSION {
        return Err(bad(&format!(
            "format version {} (this build reads {VERSION})",
            header.version
        )));
    }
    if &header.fingerprint != fingerprint {
        let what: Vec<String> = match (fingerprint.as_object(), header.fingerprint.as_object()) {
            // Keys on either side: a setting only the checkpoint or only this run has differs too.
            (Some(a), Some(b)) => {
                let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
                keys.into_iter().filter(|k| a.get(*k) != b.get(*k)).cloned().collect()
            }
            _ => vec!["settings".into()],
        };
        return Err(OptimError::Mismatch {
            path,
            what: what.join(", "),
        });
    }
    let mut pos = 16 + n;
    let mut chunks = Vec::with_capacity(header.chunks.len());
    for c in &header.chunks {
        let end = pos.checked_add(c.bytes as usize).ok_or_else(|| bad("truncated data"))?;
        let data = file.get(pos..end).ok_or_else(|| bad("truncated data"))?;
        if format!("{:016x}", fnv(data)) != c.fnv {
            return Err(bad(&format!("checksum mismatch in chunk `{}`", c.name)));
        }
        chunks.push(Chunk {
            name: c.name.clone(),
            data: data.to_vec(),
        });
        pos = end;
    }
    if pos != file.len() {
        return Err(bad("trailing bytes after the last chunk"));
    }
    Ok((header.state, chunks))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A checkpoint whose settings differ from the run's is refused naming every setting that
    /// differs, also one only the checkpoint has (a schedule the run no longer asks for).
    #[test]
    fn a_mismatch_names_the_settings_on_either_side() {
        let dir = std::env::temp_dir().join(format!("scratchart-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let saved = serde_json::json!({"seed": 1, "lr_final": 0.1, "loss": "a"});
        write(&dir, &saved, &7u32, &[]).unwrap();
        let now = serde_json::json!({"seed": 1, "loss": "b", "aim": 1.0});
        let err = match read::<u32>(&dir, &now) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("a checkpoint of other settings was read"),
        };
        assert!(err.contains("(aim, loss, lr_final differ)"), "{err}");
        assert!(matches!(read::<u32>(&dir, &saved), Ok((7, _))));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
