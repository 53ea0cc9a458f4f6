//! The LAS/LAZ public header block (ASPRS LAS 1.4 R15, table 3): bounds and point count without
//! reading a point. A LAZ file's header is the same uncompressed block.

use std::io::Read;
use std::path::Path;

use octowrap_geom::{Aabb, DVec3};

use crate::Error;

/// What the plan takes from a LAS/LAZ header.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LasHeader {
    /// The header's version, (major, minor).
    pub version: (u8, u8),
    /// Number of point records (the 64-bit count of LAS 1.4 when present, else the legacy one).
    pub points: u64,
    /// The header's bounds of the points (world units, after scale and offset).
    pub bounds: Aabb,
}

/// Offsets into the public header block.
const VERSION: usize = 24;
const HEADER_SIZE: usize = 94;
const LEGACY_COUNT: usize = 107;
const MAX_X: usize = 179;
const COUNT_14: usize = 247;
/// Bytes of the LAS 1.0-1.2 header block; 1.4 has 375.
const SHORT_HEADER: usize = 227;
const LONG_HEADER: usize = 375;

/// Reads the public header block of `path`, or `None` when the file does not start with `LASF`.
/// Errors when the block is truncated, or its bounds are not finite or inverted.
pub fn read_las_header(path: &Path) -> Result<Option<LasHeader>, Error> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut d = Vec::with_capacity(LONG_HEADER);
    file.take(LONG_HEADER as u64).read_to_end(&mut d).map_err(|e| Error::io(path, e))?;
    parse(path, &d)
}

fn f64_at(d: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(d[at..at + 8].try_into().expect("8 bytes"))
}

fn parse(path: &Path, d: &[u8]) -> Result<Option<LasHeader>, Error> {
    if d.len() < 4 || &d[..4] != b"LASF" {
        return Ok(None);
    }
    if d.len() < SHORT_HEADER {
        return Err(Error::invalid(path, d.len() as u64, format!("LAS header block cut at {} bytes", d.len())));
    }
    let version = (d[VERSION], d[VERSION + 1]);
    let size = usize::from(u16::from_le_bytes([d[HEADER_SIZE], d[HEADER_SIZE + 1]]));
    let legacy = u64::from(u32::from_le_bytes(d[LEGACY_COUNT..LEGACY_COUNT + 4].try_into().expect("4 bytes")));
    let points = if version >= (1, 4) {
        if d.len() < LONG_HEADER || size < LONG_HEADER {
            return Err(Error::invalid(
                path,
                HEADER_SIZE as u64,
                format!("LAS 1.4 header of {size} bytes, 375 needed"),
            ));
        }
        u64::from_le_bytes(d[COUNT_14..COUNT_14 + 8].try_into().expect("8 bytes"))
    } else {
        legacy
    };
    // Max X, min X, max Y, min Y, max Z, min Z.
    let v: Vec<f64> = (0..6).map(|i| f64_at(d, MAX_X + 8 * i)).collect();
    let bounds = Aabb { min: DVec3::new(v[1], v[3], v[5]), max: DVec3::new(v[0], v[2], v[4]) };
    if !(bounds.min.is_finite() && bounds.max.is_finite()) || bounds.min.cmpgt(bounds.max).any() {
        return Err(Error::invalid(
            path,
            MAX_X as u64,
            format!("LAS header bounds {:?} .. {:?}", bounds.min, bounds.max),
        ));
    }
    Ok(Some(LasHeader { version, points, bounds }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(version: (u8, u8), count: u32, bounds: [f64; 6]) -> Vec<u8> {
        let mut d = vec![0u8; LONG_HEADER];
        d[..4].copy_from_slice(b"LASF");
        d[VERSION] = version.0;
        d[VERSION + 1] = version.1;
        d[HEADER_SIZE..HEADER_SIZE + 2].copy_from_slice(&(LONG_HEADER as u16).to_le_bytes());
        d[LEGACY_COUNT..LEGACY_COUNT + 4].copy_from_slice(&count.to_le_bytes());
        d[COUNT_14..COUNT_14 + 8].copy_from_slice(&u64::from(count).to_le_bytes());
        for (i, b) in bounds.iter().enumerate() {
            d[MAX_X + 8 * i..MAX_X + 8 * i + 8].copy_from_slice(&b.to_le_bytes());
        }
        d
    }

    #[test]
    fn bounds_and_counts() {
        let d = header((1, 2), 7, [3.0, 1.0, 5.0, 2.0, 9.0, -1.0]);
        let h = parse(Path::new("t.las"), &d).unwrap().unwrap();
        assert_eq!(h.points, 7);
        assert_eq!(h.bounds.min, DVec3::new(1.0, 2.0, -1.0));
        assert_eq!(h.bounds.max, DVec3::new(3.0, 5.0, 9.0));
        assert_eq!(parse(Path::new("t.ply"), b"ply\n").unwrap(), None);
    }

    #[test]
    fn hostile_headers_fail_cleanly() {
        let d = header((1, 4), 7, [0.0, 1.0, 5.0, 2.0, 9.0, -1.0]);
        assert!(matches!(parse(Path::new("t.las"), &d), Err(Error::Invalid { .. })), "inverted x");
        let d = header((1, 2), 7, [f64::NAN, 1.0, 5.0, 2.0, 9.0, -1.0]);
        assert!(parse(Path::new("t.las"), &d).is_err());
        let d = header((1, 4), 7, [3.0, 1.0, 5.0, 2.0, 9.0, -1.0]);
        for cut in 4..LONG_HEADER {
            assert!(parse(Path::new("t.las"), &d[..cut]).is_err(), "prefix {cut}");
        }
    }

    #[test]
    fn real_laz_header_matches_its_points() {
        let Some(path) = octowrap_testdata::file("lidar-las/autzen_trim.laz") else { return };
        let h = read_las_header(&path).unwrap().unwrap();
        let mesh = octowrap_io::read_path(&path, &octowrap_io::ReadOptions::default()).unwrap();
        assert_eq!(h.points, mesh.vertices.len() as u64);
        // The header stores its bounds as doubles; the points are integers times a scale plus an
        // offset, so the two agree to the last bits of a double, not always exactly.
        let b = mesh.vertices.bounds();
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * x.abs().max(1.0);
        for (p, q) in [(h.bounds.min, b.min), (h.bounds.max, b.max)] {
            assert!(close(p.x, q.x) && close(p.y, q.y) && close(p.z, q.z), "{:?} vs {b:?}", h.bounds);
        }
    }
}
