//! The tile points file: the points one input gives one tile (a part), or all of a tile's points
//! (parts merged in the plan's input order).
//!
//! | bytes | field |
//! |---|---|
//! | 8 | magic `OWTPTS\0\x01` (the last byte is the version) |
//! | 8 | `count`, u64 little-endian |
//! | 24 `count` | the points, x y z as f64 little-endian |
//! | 8 | XXH3-64 of the points' bytes, u64 little-endian |
//!
//! Files are written atomically ([`octowrap_fsutil::write_file`]); a reader checks the length
//! against `count` before allocating, and the checksum.

use std::io::{Read, Write};
use std::path::Path;

use octowrap_geom::DVec3;
use xxhash_rust::xxh3::Xxh3;

use crate::Error;

/// The file's first 8 bytes.
pub const MAGIC: [u8; 8] = *b"OWTPTS\0\x01";

/// Bytes around the points: magic, count, checksum.
const FRAME: u64 = 24;

/// Writes `points` to `path` atomically.
pub fn write(path: &Path, points: &[DVec3], opts: &octowrap_fsutil::WriteOptions) -> Result<(), Error> {
    octowrap_fsutil::write_file(path, opts, |w: &mut dyn Write| {
        w.write_all(&MAGIC)?;
        w.write_all(&(points.len() as u64).to_le_bytes())?;
        let mut hash = Xxh3::new();
        let mut buf = Vec::with_capacity(24 * 4096);
        for chunk in points.chunks(4096) {
            buf.clear();
            for p in chunk {
                for v in p.to_array() {
                    buf.extend_from_slice(&v.to_le_bytes());
                }
            }
            hash.update(&buf);
            w.write_all(&buf)?;
        }
        w.write_all(&hash.digest().to_le_bytes())
    })
    .map_err(|e| match e {
        octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e) => Error::io(path, e),
    })
}

/// Reads a points file, refusing one whose length disagrees with its count, whose checksum
/// fails, or whose points are not finite.
pub fn read(path: &Path) -> Result<Vec<DVec3>, Error> {
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut head = [0u8; 16];
    if len < FRAME {
        return Err(Error::invalid(path, len, format!("a points file has at least {FRAME} bytes, found {len}")));
    }
    f.read_exact(&mut head).map_err(|e| Error::io(path, e))?;
    if head[..8] != MAGIC {
        return Err(Error::invalid(path, 0, "not an octowrap tile points file (magic OWTPTS, version 1)"));
    }
    let count = u64::from_le_bytes(head[8..].try_into().expect("8 bytes"));
    let expect = count.checked_mul(24).and_then(|b| b.checked_add(FRAME));
    if expect != Some(len) {
        return Err(Error::invalid(path, 8, format!("count {count} needs {expect:?} bytes, the file has {len}")));
    }
    let mut body = vec![0u8; (len - FRAME) as usize];
    f.read_exact(&mut body).map_err(|e| Error::io(path, e))?;
    let mut tail = [0u8; 8];
    f.read_exact(&mut tail).map_err(|e| Error::io(path, e))?;
    if xxhash_rust::xxh3::xxh3_64(&body) != u64::from_le_bytes(tail) {
        return Err(Error::invalid(path, len - 8, "checksum mismatch"));
    }
    let f64_at = |i: usize| f64::from_le_bytes(body[i..i + 8].try_into().expect("8 bytes"));
    let points: Vec<DVec3> =
        (0..count as usize).map(|i| DVec3::new(f64_at(24 * i), f64_at(24 * i + 8), f64_at(24 * i + 16))).collect();
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(Error::invalid(path, 16 + 24 * i as u64, "point is not finite"));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_every_damage_fails() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.pts");
        let pts = vec![DVec3::new(1.0, -2.5, 3.25), DVec3::new(1e6, 0.0, -7.0)];
        write(&path, &pts, &octowrap_fsutil::WriteOptions::default()).unwrap();
        assert_eq!(read(&path).unwrap(), pts);
        let bytes = std::fs::read(&path).unwrap();
        let bad = dir.path().join("bad.pts");
        for cut in 0..bytes.len() {
            std::fs::write(&bad, &bytes[..cut]).unwrap();
            assert!(read(&bad).is_err(), "prefix {cut}");
        }
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            std::fs::write(&bad, &b).unwrap();
            assert!(read(&bad).is_err(), "flipped byte {i}");
        }
        write(&path, &[], &octowrap_fsutil::WriteOptions::default()).unwrap();
        assert!(read(&path).unwrap().is_empty());
    }
}
