//! XYZ, PTS and PWN point files: whitespace (or comma) separated columns, one point per line.
//!
//! These formats have no specification; this module follows what their writers produce:
//! * `x y z` (XYZ);
//! * `x y z nx ny nz` (XYZ with normals; CGAL's `.pwn` "points with normals");
//! * `x y z intensity` (4 columns);
//! * `x y z intensity r g b` (Leica/Faro `.pts`, colours 0-255), and a `.pts` file's first line
//!   holding just the point count (used only as a size hint, after checking it against the input
//!   size like any declared count);
//! * any other count of 3 or more columns: `x y z`, the rest ignored.
//!
//! The layout is fixed by the first data line; every later line must have as many columns.
//! `#` starts a comment; blank lines are skipped; commas count as separators.
//!
//! # Writing
//! `x y z`, or `x y z nx ny nz` when the mesh has normals; positions in shortest round-trip form.
//! Faces, colours and intensities are not written.

use std::io::Write;

use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::PointCloud;

use crate::budget::{Budget, point_bytes};
use crate::text::{LineWriter, Lines, parse_f32, parse_f64, parse_i64, strip_comment, truncated};
use crate::{Error, Mesh, ReadOptions, Result, WriteOptions, justify};

/// The columns of a line: split at whitespace and commas.
fn columns(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|&c| c.is_ascii_whitespace() || c == b',').filter(|t| !t.is_empty())
}

/// Reads a whole XYZ/PTS/PWN file held in memory.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    let limits = &opts.limits;
    let mut budget = Budget::new(limits, data.len());
    let mut lines = Lines::new(data);
    let mut cloud = PointCloud::default();
    let mut layout: Option<usize> = None;
    let mut first = true;
    let mut cols: Vec<&[u8]> = Vec::with_capacity(8);
    while let Some(line) = lines.next_line() {
        cols.clear();
        cols.extend(columns(strip_comment(line)));
        if cols.is_empty() {
            continue;
        }
        if std::mem::take(&mut first) && cols.len() == 1 {
            // A PTS point count.
            let declared = parse_i64(cols[0]).and_then(|c| u64::try_from(c).ok()).ok_or_else(|| {
                lines.invalid(format!(
                    "expected a point count or 3 or more columns, found '{}'",
                    String::from_utf8_lossy(truncated(cols[0]))
                ))
            })?;
            let n = justify(declared, 6, lines.remaining() + 1, limits.max_points, "points", lines.location())?;
            budget.charge_n(n, 24, "points", lines.location())?;
            cloud.positions.reserve_exact(n);
            continue;
        }
        let n = *layout.get_or_insert_with(|| {
            let n = cols.len();
            if matches!(n, 6 | 7) {
                cloud.normals = (n == 6).then(Vec::new);
                cloud.colors = (n == 7).then(Vec::new);
            }
            cloud.intensities = matches!(n, 4 | 7).then(Vec::new);
            n
        });
        if cols.len() != n || n < 3 {
            return Err(lines.invalid(if n < 3 {
                format!("expected x y z columns, found {} column(s)", cols.len())
            } else {
                format!("expected {n} columns as on the first data line, found {}", cols.len())
            }));
        }
        if cloud.positions.len() as u64 >= limits.max_points {
            return Err(Error::limit(lines.location(), format!("more than {} points", limits.max_points)));
        }
        let each = point_bytes(cloud.normals.is_some(), cloud.colors.is_some(), cloud.intensities.is_some());
        budget.grow(&mut cloud.positions, each, "points", lines.location())?;
        let num = |k: usize, what: &str| -> Result<f64> {
            parse_f64(cols[k]).ok_or_else(|| {
                lines.invalid(format!(
                    "expected a number for {what} in column {}, found '{}'",
                    k + 1,
                    String::from_utf8_lossy(truncated(cols[k]))
                ))
            })
        };
        let num32 = |k: usize, what: &str| -> Result<f32> {
            parse_f32(cols[k]).ok_or_else(|| {
                lines.invalid(format!(
                    "expected a number for {what} in column {}, found '{}'",
                    k + 1,
                    String::from_utf8_lossy(truncated(cols[k]))
                ))
            })
        };
        cloud.positions.push(DVec3::new(num(0, "x")?, num(1, "y")?, num(2, "z")?));
        if let Some(normals) = cloud.normals.as_mut() {
            normals.push(Vec3::new(num32(3, "nx")?, num32(4, "ny")?, num32(5, "nz")?));
        }
        if let Some(i) = cloud.intensities.as_mut() {
            i.push(num32(3, "intensity")?);
        }
        if let Some(colors) = cloud.colors.as_mut() {
            let c = |k| num(k, "a colour component").map(|v| v.round().clamp(0.0, 255.0) as u8);
            colors.push([c(4)?, c(5)?, c(6)?]);
        }
    }
    Ok(Mesh { vertices: cloud, faces: octowrap_mesh::FaceList::default() })
}

/// Writes `mesh`'s points as XYZ (`x y z`, or `x y z nx ny nz` with normals).
pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, _opts: &WriteOptions) -> Result<()> {
    use std::fmt::Write as _;
    let v = &mesh.vertices;
    let mut s = LineWriter::new(w);
    for (i, p) in v.positions.iter().enumerate() {
        // Writing to a String cannot fail.
        let _ = write!(s, "{} {} {}", p.x, p.y, p.z);
        if let Some(n) = v.normals.as_ref().and_then(|n| n.get(i)) {
            let _ = write!(s, " {} {} {}", n.x, n.y, n.z);
        }
        s.end_line()?;
    }
    s.finish()
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::text::testing::{arb_mesh, every_prefix, mutated};
    use crate::{ErrorKind, Location};

    fn rd(data: &[u8]) -> Result<Mesh> {
        read(data, &ReadOptions::default())
    }

    #[test]
    fn every_column_layout() {
        let m = rd(b"# points\n1 2 3\n\n4,5,6 # trailing\n").unwrap();
        assert_eq!(m.vertices.positions, vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 6.0)]);
        assert!(m.vertices.normals.is_none() && m.vertices.intensities.is_none());
        let m = rd(b"1 2 3 0 0 1\n4 5 6 0 1 0\n").unwrap();
        assert_eq!(m.vertices.normals.unwrap(), vec![Vec3::Z, Vec3::Y]);
        let m = rd(b"1 2 3 -120\n").unwrap();
        assert_eq!(m.vertices.intensities.unwrap(), vec![-120.0]);
        let m = rd(b"2\r\n1 2 3 -120 10 20 30\r\n4 5 6 7 255 0 1\r\n").unwrap();
        assert_eq!(m.vertices.intensities.unwrap(), vec![-120.0, 7.0]);
        assert_eq!(m.vertices.colors.unwrap(), vec![[10, 20, 30], [255, 0, 1]]);
        let m = rd(b"1 2 3 4 5\n").unwrap();
        assert_eq!(m.vertex_count(), 1);
        assert!(m.vertices.attribute_names().is_empty());
    }

    #[test]
    fn bad_input_says_where() {
        let cases: [(&[u8], ErrorKind, u64, &str); 5] = [
            (b"1 2 3\n4 5\n", ErrorKind::Invalid, 2, "expected 3 columns"),
            (b"1 2\n", ErrorKind::Invalid, 1, "x y z"),
            (b"\n\n1 2 x\n", ErrorKind::Invalid, 3, "column 3, found 'x'"),
            (b"pts\n", ErrorKind::Invalid, 1, "point count"),
            (b"1000000000\n1 2 3\n", ErrorKind::LimitExceeded, 1, "1000000000"),
        ];
        for (data, kind, line, msg) in cases {
            let e = rd(data).unwrap_err();
            assert_eq!((e.kind, e.location), (kind, Location::Line(line)), "{e}");
            assert!(e.message.contains(msg), "{e}");
        }
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        every_prefix(b"2\n1 2 3 -120 10 20 30\n4 5 6 7 255 0 1\n", read);
        every_prefix(b"1.5 2 3 0 0 1\n4 5 6e-3 0 1 0\n", read);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1000))]

        #[test]
        fn mutated_samples_never_panic(d in mutated(b"3\n1 2 3 -120 10 20 30\n4 5 6 7 255 0 1\n1,2,3,4,5,6,7\n")) {
            let _ = rd(&d);
        }
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..300)) {
            let _ = rd(&data);
        }

        #[test]
        fn random_clouds_round_trip(mut m in arb_mesh(true, false)) {
            m.vertices.colors = None;
            m.vertices.intensities = None;
            let mut out = Vec::new();
            write(&mut out, &m, &WriteOptions::default()).unwrap();
            prop_assert_eq!(rd(&out).unwrap(), m);
        }
    }
}
