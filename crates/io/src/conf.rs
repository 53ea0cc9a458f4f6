//! Stanford `.conf` scan sets: several range scans, each with the rigid pose that brings it
//! into a common frame, merged into one cloud.
//!
//! Follows the format written by Stanford's `scanalyze` and shipped with the Stanford 3D Scanning
//! Repository (e.g. `bunny/data/bun.conf`; Turk & Levoy, "Zippered Polygon Meshes from Range
//! Images", SIGGRAPH 94). One command per line:
//!
//! * `camera tx ty tz qi qj qk qr`: the viewing camera of the session; ignored.
//! * `bmesh FILE tx ty tz qi qj qk qr` (or `mesh FILE ...`): a scan and its pose, a translation
//!   `t` and a unit quaternion `q = qr + qi i + qj j + qk k` (real part last). A point `p` of the
//!   scan lies at `R(q)ᵀ p + t` in the common frame: rotation first, then translation, where the
//!   rotation is that of the *conjugate* quaternion (scanalyze builds the matrix of `q` and applies
//!   it to row vectors, `pᵀ R(q)`). Normals are rotated likewise.
//!
//! The convention was settled on the data, not guessed: of the four readings (`R p + t`,
//! `Rᵀ p + t`, `R (p + t)`, `Rᵀ (p − t)`), only `Rᵀ p + t` puts the ten bunny scans inside the
//! bounding box of Stanford's zippered reconstruction (all but one stray point within 3 mm), with
//! overlapping scans a third of a millimetre apart (median nearest-neighbour distance to `bun000`);
//! the others leave scans centimetres off. This module's tests check it.
//!
//! Blank lines and lines starting with `#` are skipped; any other command is an error.
//! `FILE` is relative to the `.conf` file's folder; when it is absent, `FILE.gz` is tried (the
//! copies in `../shared/data` are gzipped). Each scan is read with [`crate::read_path`], so it may
//! be in any format octowrap reads (its extension must name one; a `.conf` cannot include another),
//! and an error in it names that file. Faces are kept, re-indexed; an attribute survives only if
//! every scan has it ([`PointCloud::append`](octowrap_mesh::PointCloud::append)).
//!
//! A `.conf` read from standard input is refused: its file names would have no folder to be
//! relative to.

use std::path::{Path, PathBuf};

use octowrap_geom::DVec3;
use octowrap_geom::glam::DQuat;

use crate::budget::{Budget, point_bytes};
use crate::text::{Lines, parse_f64, tokens};
use crate::{Error, Format, Location, Mesh, ReadOptions, Result};

/// One `bmesh` line.
#[derive(Clone, Debug, PartialEq)]
struct Scan {
    file: String,
    translation: DVec3,
    rotation: DQuat,
    line: Location,
}

/// Reads the scan set `path`, whose (decompressed) content is `data`.
pub(crate) fn read(path: &Path, data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    if path == Path::new("-") {
        return Err(Error::unsupported(
            Location::Unknown,
            "a .conf scan set names its scans relative to its own folder: read it from a file, not standard input",
        ));
    }
    let scans = parse(data, opts.limits.max_scans)?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut merged = Mesh::default();
    let mut budget = Budget::new(&opts.limits, data.len());
    for scan in scans {
        let file = resolve(&dir, &scan)?;
        let mut inner = opts.clone();
        inner.format = None;
        inner.limits.max_points = opts.limits.max_points.saturating_sub(merged.vertices.len() as u64);
        inner.limits.max_memory = opts.limits.max_memory.map(|m| m.saturating_sub(budget.spent()));
        let mut mesh = crate::read_path(&file, &inner)?;
        let v = &mesh.vertices;
        let each = point_bytes(v.normals.is_some(), v.colors.is_some(), v.intensities.is_some());
        let kept = (v.len() * each + 4 * (mesh.faces.len() + mesh.faces.corner_count())) as u64;
        budget.charge(
            kept,
            &|| format!("the {} points of scan '{}' and those before", v.len(), scan.file),
            scan.line,
        )?;
        transform(&mut mesh, scan.rotation, scan.translation);
        append(&mut merged, mesh, &scan, &file)?;
    }
    Ok(merged)
}

/// Parses the commands; returns the scans in file order, refusing more than `max_scans`.
fn parse(data: &[u8], max_scans: u64) -> Result<Vec<Scan>> {
    let mut lines = Lines::new(data);
    let mut scans = Vec::new();
    while let Some(line) = lines.next_content_line(b'#') {
        let mut it = tokens(line);
        let Some(word) = it.next() else { continue };
        match word {
            b"camera" => {}
            b"bmesh" | b"mesh" => {
                if scans.len() as u64 >= max_scans {
                    return Err(Error::limit(
                        lines.location(),
                        format!(
                            "more than {max_scans} scans in one set, the limit (raise it with --max-scans, or \
                             Limits::max_scans)"
                        ),
                    ));
                }
                let file = it.next().ok_or_else(|| lines.invalid("expected a file name after 'bmesh'"))?;
                let file = std::str::from_utf8(file).map_err(|_| lines.invalid("the scan's file name is not UTF-8"))?;
                let mut v = [0f64; 7];
                for (k, slot) in v.iter_mut().enumerate() {
                    let what = ["tx", "ty", "tz", "qi", "qj", "qk", "qr"][k];
                    let tok = it.next().ok_or_else(|| {
                        lines.invalid(format!("expected 'bmesh FILE tx ty tz qi qj qk qr', found no {what}"))
                    })?;
                    *slot = parse_f64(tok).filter(|x| x.is_finite()).ok_or_else(|| {
                        lines.invalid(format!(
                            "expected a finite number for {what}, found '{}'",
                            String::from_utf8_lossy(tok)
                        ))
                    })?;
                }
                let q = DQuat::from_xyzw(v[3], v[4], v[5], v[6]);
                let len = q.length();
                if len.is_nan() || len <= 1e-9 {
                    return Err(lines.invalid("the pose quaternion has zero length"));
                }
                scans.push(Scan {
                    file: file.to_owned(),
                    translation: DVec3::new(v[0], v[1], v[2]),
                    // The conjugate: see the module docs.
                    rotation: (q / len).conjugate(),
                    line: lines.location(),
                });
            }
            other => {
                return Err(
                    lines.invalid(format!("expected 'camera' or 'bmesh', found '{}'", String::from_utf8_lossy(other)))
                );
            }
        }
    }
    Ok(scans)
}

/// The scan's file, or its `.gz` twin when the plain file is absent.
fn resolve(dir: &Path, scan: &Scan) -> Result<PathBuf> {
    let plain = dir.join(&scan.file);
    let format = Format::from_path(&plain);
    if format.is_none() || format == Some(Format::Conf) {
        return Err(Error::unsupported(
            scan.line,
            format!("scan '{}' must be a point or mesh file with a known extension (not a .conf)", scan.file),
        ));
    }
    if plain.exists() {
        return Ok(plain);
    }
    let mut gz = plain.clone().into_os_string();
    gz.push(".gz");
    let gz = PathBuf::from(gz);
    if gz.exists() {
        return Ok(gz);
    }
    let mut e = Error::io(std::io::Error::new(
        std::io::ErrorKind::NotFound,
        format!("scan '{}' not found (nor '{}')", plain.display(), gz.display()),
    ));
    e.location = scan.line;
    Err(e)
}

/// Applies the pose: `p ↦ R(q) p + t`, normals `n ↦ R(q) n`.
fn transform(mesh: &mut Mesh, q: DQuat, t: DVec3) {
    for p in &mut mesh.vertices.positions {
        *p = q * *p + t;
    }
    if let Some(normals) = &mut mesh.vertices.normals {
        let qf = q.as_quat();
        for n in normals {
            *n = qf * *n;
        }
    }
}

/// Appends `mesh` (vertices and re-indexed faces) to `merged`.
fn append(merged: &mut Mesh, mesh: Mesh, scan: &Scan, file: &Path) -> Result<()> {
    let base = u32::try_from(merged.vertices.len())
        .ok()
        .filter(|b| u32::try_from(mesh.vertices.len()).is_ok_and(|n| b.checked_add(n).is_some()))
        .ok_or_else(|| {
            Error::limit(scan.line, format!("{}: more than 2^32 vertices in all the scans", file.display()))
        })?;
    for face in mesh.faces.iter() {
        merged.faces.push_iter(face.iter().map(|&i| i.saturating_add(base)));
    }
    merged.vertices.append(mesh.vertices);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;

    fn opts() -> ReadOptions {
        ReadOptions::default()
    }

    fn parse_all(data: &[u8]) -> Result<Vec<Scan>> {
        parse(data, u64::MAX)
    }

    fn ply(points: &[[f64; 3]]) -> String {
        let mut s = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            points.len()
        );
        for p in points {
            use std::fmt::Write;
            let _ = writeln!(s, "{} {} {}", p[0], p[1], p[2]);
        }
        s
    }

    fn gzip(data: &[u8]) -> Vec<u8> {
        use std::io::Write;
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    /// A folder with `a.ply` (plain) and `b.ply.gz`, and the `.conf` text given.
    fn scan_set(conf: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.ply"), ply(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])).unwrap();
        std::fs::write(dir.path().join("b.ply.gz"), gzip(ply(&[[1.0, 2.0, 3.0]]).as_bytes())).unwrap();
        let conf_path = dir.path().join("set.conf");
        std::fs::write(&conf_path, conf).unwrap();
        (dir, conf_path)
    }

    #[test]
    fn parses_commands_and_rejects_junk() {
        let s = parse_all(b"camera 0 0 0 0 0 0 1\n\n# note\nbmesh a.ply 1 2 3 0 0 0 2\n").unwrap();
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].rotation, DQuat::IDENTITY, "normalised");
        assert_eq!(s[0].line, Location::Line(4));
        let s = parse_all(b"bmesh a.ply 0 0 0 0 0 1 0\n").unwrap();
        assert_eq!(s[0].rotation, DQuat::from_xyzw(0.0, 0.0, -1.0, 0.0), "conjugated");
        let e = parse_all(b"bmesh a.ply 1 2 3 0 0 0\n").unwrap_err();
        assert!(e.to_string().contains("no qr"), "{e}");
        assert_eq!(parse_all(b"bmesh a.ply 1 2 3 0 0 0 0\n").unwrap_err().location, Location::Line(1));
        assert!(parse_all(b"bmesh a.ply 1 2 nan 0 0 0 1\n").is_err());
        assert!(parse_all(b"camera 1\nscale 2\n").unwrap_err().to_string().contains("line 2"));
    }

    #[test]
    fn every_prefix_is_clean() {
        let text = b"camera 0 0 0 0 0 0 1\nbmesh a.ply 1 2 3 0 0 0.7071 0.7071\nbmesh b.ply 0 0 0 0 0 0 1\n";
        for n in 0..=text.len() {
            let _ = parse_all(&text[..n]);
        }
    }

    #[test]
    fn merges_scans_with_poses_and_finds_gz() {
        // a.ply rotated 90° about z then shifted by (10, 0, 0); b.ply (gzipped) as is.
        // The quaternion written is -90° about z; its conjugate, +90°, is applied.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let (_dir, conf) =
            scan_set(&format!("camera 0 0 0 0 0 0 1\nbmesh a.ply 10 0 0 0 0 -{h} {h}\nbmesh b.ply 0 0 0 0 0 0 1\n"));
        let m = crate::read_path(&conf, &opts()).unwrap_or_else(|e| panic!("{e}"));
        let want = [DVec3::new(10.0, 1.0, 0.0), DVec3::new(9.0, 0.0, 0.0), DVec3::new(1.0, 2.0, 3.0)];
        assert_eq!(m.vertices.len(), 3);
        for (p, w) in m.vertices.positions.iter().zip(want) {
            assert!((*p - w).length() < 1e-6, "{p} vs {w}");
        }
    }

    #[test]
    fn errors_name_the_right_file_and_line() {
        let (dir, conf) =
            scan_set("camera 0 0 0 0 0 0 1\nbmesh missing.ply 0 0 0 0 0 0 1\nbmesh a.ply 0 0 0 0 0 0 1\n");
        let e = crate::read_path(&conf, &opts()).unwrap_err();
        assert!(e.to_string().contains("missing.ply"), "{e}");
        assert_eq!(e.kind, ErrorKind::Io, "{e}");
        assert_eq!(e.location, Location::Line(2), "{e}");
        assert!(e.file.ends_with("set.conf"), "{e}");
        std::fs::write(dir.path().join("bad.ply"), "ply\nformat ascii 1.0\nelement vertex 5\nend_header\n").unwrap();
        std::fs::write(&conf, "bmesh bad.ply 0 0 0 0 0 0 1\n").unwrap();
        let e = crate::read_path(&conf, &opts()).unwrap_err();
        assert!(e.file.ends_with("bad.ply"), "inner errors keep their file: {e}");
        std::fs::write(&conf, "bmesh other.conf 0 0 0 0 0 0 1\n").unwrap();
        assert_eq!(crate::read_path(&conf, &opts()).unwrap_err().kind, ErrorKind::Unsupported);
        let e = read(Path::new("-"), b"bmesh a.ply 0 0 0 0 0 0 1\n", &opts()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Unsupported);
    }

    /// A uniform grid over points for nearest-neighbour distances in the tests.
    struct Grid {
        cell: f64,
        map: std::collections::HashMap<[i64; 3], Vec<DVec3>>,
    }

    impl Grid {
        fn new(points: &[DVec3], cell: f64) -> Self {
            let mut map = std::collections::HashMap::<[i64; 3], Vec<DVec3>>::new();
            for &p in points {
                map.entry(Self::key(p, cell)).or_default().push(p);
            }
            Self { cell, map }
        }

        fn key(p: DVec3, cell: f64) -> [i64; 3] {
            (p / cell).floor().as_i64vec3().to_array()
        }

        /// Distance to the nearest point within one cell, if any.
        fn nearest(&self, p: DVec3) -> Option<f64> {
            let k = Self::key(p, self.cell);
            let mut best: Option<f64> = None;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        for q in self.map.get(&[k[0] + dx, k[1] + dy, k[2] + dz]).into_iter().flatten() {
                            let d = p.distance(*q);
                            best = Some(best.map_or(d, |b| b.min(d)));
                        }
                    }
                }
            }
            best.filter(|&d| d <= self.cell)
        }
    }

    #[test]
    fn stanford_bunny_scans_line_up() {
        let Some(root) = octowrap_testdata::dir("stanford-bunny") else { return };
        let m = crate::read_path(&root.join("data/bun.conf"), &opts()).unwrap_or_else(|e| panic!("{e}"));
        // PROVENANCE.md's per-scan counts (bun000 40,256 + bun045 40,097 + bun090 30,379 + bun180
        // 40,251 + bun270 31,701 + bun315 35,336 + chin 37,738 + ear_back 32,193 + top2 38,298 +
        // top3 36,023) add up to 362,272; its "Total 362,872" is a typo.
        assert_eq!(m.vertices.len(), 362_272);
        let zipper = crate::read_path(&root.join("reconstruction/bun_zipper.ply"), &opts()).unwrap();
        let z = zipper.vertices.bounds();
        // One stray point of ear_back lies 19 mm outside; every other point is within 3 mm of the
        // reconstruction's box, and the box of those points matches it within 3 mm.
        let (inside, outside): (Vec<DVec3>, Vec<DVec3>) =
            m.vertices.positions.iter().partition(|p| !(p.cmplt(z.min - 0.003) | p.cmpgt(z.max + 0.003)).any());
        assert!(outside.len() <= 3, "{} points outside bun_zipper's box: {outside:?}", outside.len());
        let a = octowrap_geom::Aabb::from_points(&inside);
        let off = (a.min - z.min).abs().max((a.max - z.max).abs()).max_element();
        assert!(off < 0.003, "merged scans' box {a:?} vs bun_zipper's {z:?}: off by {off} m");
        // Overlap: scans that see much of bun000's side lie within a fraction of a millimetre of it.
        let mut start = 0;
        let counts = [40_256, 40_097, 30_379, 40_251, 31_701, 38_298, 36_023, 35_336, 37_738, 32_193];
        let grid = Grid::new(&m.vertices.positions[..counts[0]], 0.002);
        for (k, n) in counts.into_iter().enumerate() {
            let scan = &m.vertices.positions[start..start + n];
            start += n;
            let mut d: Vec<f64> = scan.iter().filter_map(|&p| grid.nearest(p)).collect();
            if k == 0 || d.len() < 5_000 {
                continue;
            }
            d.sort_by(f64::total_cmp);
            let median = d[d.len() / 2];
            assert!(median < 0.0005, "scan {k}: median nearest-neighbour distance to bun000 {median} m");
        }
    }
}
