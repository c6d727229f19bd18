//! The model file's envelope, whatever model it holds: the header (magic, format version,
//! payload length, FNV-1a hash; see the `io` module docs), and writing a file whole or not at
//! all.

use std::io::Write;
use std::path::Path;

use super::{FORMAT_VERSION, MAGIC};
use crate::error::{Error, Result};
use crate::tempfiles;

/// Bytes of the header before the payload.
pub(crate) const HEADER: usize = 28;

/// The FNV-1a 64-bit hash of `bytes`.
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// `payload` behind a file header of format `version` (magic, version, length, hash).
pub(crate) fn with_header(version: u32, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv1a(payload).to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// The format version and the payload of a model file's `bytes`, after checking the magic,
/// the version (1 to [`FORMAT_VERSION`]), the length and the hash.
pub(crate) fn split_header(bytes: &[u8]) -> Result<(u32, &[u8])> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(Error::BadMagic);
    }
    if bytes.len() < HEADER {
        return Err(Error::Truncated {
            expected: HEADER,
            found: bytes.len(),
        });
    }
    let word = |a: usize, b: usize| -> [u8; 8] {
        let mut w = [0u8; 8];
        w[..b - a].copy_from_slice(&bytes[a..b]);
        w
    };
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version == 0 || version > FORMAT_VERSION {
        return Err(Error::UnsupportedVersion {
            found: version,
            supported: FORMAT_VERSION,
        });
    }
    let len = u64::from_le_bytes(word(12, 20));
    let hash = u64::from_le_bytes(word(20, 28));
    let expected = usize::try_from(len)
        .ok()
        .and_then(|l| l.checked_add(HEADER))
        .ok_or(Error::Corrupt {
            reason: format!("payload length {len} is impossible"),
        })?;
    if bytes.len() < expected {
        return Err(Error::Truncated {
            expected,
            found: bytes.len(),
        });
    }
    if bytes.len() > expected {
        return Err(Error::Corrupt {
            reason: format!(
                "{} trailing bytes after the payload",
                bytes.len() - expected
            ),
        });
    }
    let payload = &bytes[HEADER..];
    if fnv1a(payload) != hash {
        return Err(Error::Corrupt {
            reason: "payload checksum mismatch".into(),
        });
    }
    Ok((version, payload))
}

/// Writes `bytes` to `path` through a temporary file beside it (see [`SharedGplvm::save`]).
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source: std::io::Error| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    if path.file_name().is_none() {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "the path has no file name",
        )));
    }
    tempfiles::remove_stale_temporaries(path);
    let tmp = tempfiles::temporary_path(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp).map_err(io)?;
        f.write_all(bytes).map_err(io)?;
        f.sync_all().map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The bytes of the model file at `path` (an error naming it when it cannot be read).
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// A model file's `bytes` with its JSON payload edited by `edit` and a valid header and hash:
/// what a tampered or buggy writer would produce (for tests of what loading makes of it).
#[cfg(test)]
pub(crate) fn with_payload(bytes: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let mut json: serde_json::Value = serde_json::from_slice(&bytes[HEADER..]).expect("json");
    edit(&mut json);
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    with_header(version, &serde_json::to_vec(&json).expect("json"))
}
