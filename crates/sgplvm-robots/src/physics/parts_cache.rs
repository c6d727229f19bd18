//! The convex parts of collision meshes kept on disk between runs: splitting a mesh (V-HACD) is
//! most of a robot's start (EngineAI's PM01, 36 MB of meshes: about 60 % of its 4–6 s), and a
//! live node should answer within the first frames. Each mesh's parts are kept under a key
//! made of everything they come from (the scaled vertices and triangles, the split's settings
//! and this format's version), so a changed mesh, scale or setting is split afresh; a file that
//! is not whole (a run stopped while writing, another version's) is split afresh and written
//! again. Where: `SGPLVM_CACHE_DIR` (`off` for none), else `$XDG_CACHE_HOME/sgplvm`, else
//! `~/.cache/sgplvm`, in `convex-parts/`, at most 256 MiB (the oldest files go first). Nothing
//! is said when it cannot be written: it only ever saves time.

use std::io::Write;
use std::path::{Path, PathBuf};

use rapier3d::math::{Real, Vector};

/// The first bytes of a parts file, with this format's version.
const MAGIC: &[u8; 8] = b"SGPARTS1";

/// The folder parts files are kept in, if any (see the module docs).
pub(super) fn folder() -> Option<PathBuf> {
    let base = match std::env::var_os("SGPLVM_CACHE_DIR") {
        Some(dir) if dir == "off" || dir.is_empty() => return None,
        Some(dir) => PathBuf::from(dir),
        None => match std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
            Some(dir) => PathBuf::from(dir).join("sgplvm"),
            None => PathBuf::from(std::env::var_os("HOME")?).join(".cache/sgplvm"),
        },
    };
    Some(base.join("convex-parts"))
}

/// The key of a mesh's parts: an FNV-1a hash of the split's `settings` and the mesh.
pub(super) fn key(settings: &[u8], vertices: &[Vector], triangles: &[[u32; 3]]) -> String {
    let mut h = Fnv::new();
    h.add(MAGIC);
    h.add(settings);
    h.add(&(vertices.len() as u64).to_le_bytes());
    for v in vertices {
        for c in [v.x, v.y, v.z] {
            h.add(&c.to_le_bytes());
        }
    }
    h.add(&(triangles.len() as u64).to_le_bytes());
    for t in triangles {
        for i in t {
            h.add(&i.to_le_bytes());
        }
    }
    format!("{:016x}.parts", h.0)
}

/// The parts (each its points) kept in `dir` under `key`, if a whole file is there.
pub(super) fn read(dir: &Path, key: &str) -> Option<Vec<Vec<Vector>>> {
    let bytes = std::fs::read(dir.join(key)).ok()?;
    let (payload, sum) = bytes.split_at_checked(bytes.len().checked_sub(8)?)?;
    if payload.get(..8)? != MAGIC || Fnv::of(payload).to_le_bytes() != sum {
        return None;
    }
    let mut words = payload[8..]
        .chunks_exact(4)
        .map(|w| <[u8; 4]>::try_from(w).ok());
    let mut next = || words.next().flatten();
    let parts = u32::from_le_bytes(next()?) as usize;
    let mut out = Vec::with_capacity(parts.min(4096));
    for _ in 0..parts {
        let n = u32::from_le_bytes(next()?) as usize;
        let mut points = Vec::with_capacity(n.min(1 << 20));
        for _ in 0..n {
            let mut c: [Real; 3] = [0.0; 3];
            for x in &mut c {
                *x = Real::from_le_bytes(next()?);
            }
            points.push(Vector::new(c[0], c[1], c[2]));
        }
        out.push(points);
    }
    next().is_none().then_some(out)
}

/// Keeps `parts` in `dir` under `key`, whole or not at all (written beside, then renamed);
/// nothing is said where it cannot be.
pub(super) fn write(dir: &Path, key: &str, parts: &[Vec<Vector>]) {
    let mut payload = MAGIC.to_vec();
    payload.extend((parts.len() as u32).to_le_bytes());
    for points in parts {
        payload.extend((points.len() as u32).to_le_bytes());
        for p in points {
            for c in [p.x, p.y, p.z] {
                payload.extend(c.to_le_bytes());
            }
        }
    }
    let sum = Fnv::of(&payload).to_le_bytes();
    let tmp = dir.join(format!("{key}.{}.tmp", std::process::id()));
    let written = std::fs::create_dir_all(dir)
        .and_then(|()| std::fs::File::create(&tmp))
        .and_then(|mut f| {
            f.write_all(&payload)?;
            f.write_all(&sum)
        })
        .and_then(|()| std::fs::rename(&tmp, dir.join(key)));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    prune(dir, MAX_BYTES);
}

/// The most the folder holds: 256 MiB, the parts of about 500 robots.
const MAX_BYTES: u64 = 256 << 20;

/// Removes the oldest parts files of `dir` (by modification) until it holds at most three
/// quarters of `max` bytes, where it holds more than `max`.
fn prune(dir: &Path, max: u64) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut files: Vec<(std::time::SystemTime, u64, PathBuf)> = entries
        .filter_map(|e| {
            let e = e.ok()?;
            let meta = e.metadata().ok()?;
            let path = e.path();
            (meta.is_file() && path.extension().is_some_and(|x| x == "parts"))
                .then(|| Some((meta.modified().ok()?, meta.len(), path)))?
        })
        .collect();
    let mut total: u64 = files.iter().map(|f| f.1).sum();
    if total <= max {
        return;
    }
    files.sort();
    for (_, len, path) in files {
        if total <= max / 4 * 3 {
            break;
        }
        if std::fs::remove_file(&path).is_ok() {
            total -= len;
        }
    }
}

/// FNV-1a, 64 bits.
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn add(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    fn of(bytes: &[u8]) -> u64 {
        let mut h = Fnv::new();
        h.add(bytes);
        h.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_round_trip_and_a_file_not_whole_is_not_read() {
        let dir = std::env::temp_dir().join(format!("sgplvm-parts-{}", std::process::id()));
        let parts = vec![
            vec![Vector::new(0.0, 1.0, 2.0), Vector::new(-1.5, 0.25, 3.0)],
            vec![Vector::new(7.0, 8.0, 9.0)],
        ];
        let k = key(b"24 0.03", &parts[0], &[[0, 1, 0]]);
        assert_ne!(
            k,
            key(b"32 0.03", &parts[0], &[[0, 1, 0]]),
            "settings are in the key"
        );
        assert_ne!(
            k,
            key(b"24 0.03", &parts[1], &[[0, 1, 0]]),
            "the mesh is in the key"
        );
        assert!(read(&dir, &k).is_none());
        write(&dir, &k, &parts);
        assert_eq!(read(&dir, &k).as_ref(), Some(&parts));
        // Cut short, or one byte changed: not read.
        let bytes = std::fs::read(dir.join(&k)).unwrap();
        std::fs::write(dir.join(&k), &bytes[..bytes.len() - 3]).unwrap();
        assert!(read(&dir, &k).is_none());
        let mut changed = bytes.clone();
        changed[12] ^= 1;
        std::fs::write(dir.join(&k), &changed).unwrap();
        assert!(read(&dir, &k).is_none());
        // A folder over its size loses its oldest files.
        write(&dir, &k, &parts);
        let newer = key(b"other", &parts[1], &[]);
        std::thread::sleep(std::time::Duration::from_millis(20));
        write(&dir, &newer, &parts);
        let one = std::fs::metadata(dir.join(&k)).unwrap().len();
        prune(&dir, 2 * one - 1);
        assert!(!dir.join(&k).exists() && dir.join(&newer).exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
