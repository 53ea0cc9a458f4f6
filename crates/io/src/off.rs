//! OFF (Object File Format): reading and writing polygon meshes.
//!
//! Follows Geomview's OFF description (*Geomview Manual*, section "OFF Files"): an optional
//! header keyword `[ST][C][N]OFF`, the counts `vertices faces edges`, one vertex per line, then
//! one face per line as `n i0 .. i(n-1)` with 0-based indices.
//!
//! # Reading
//! * `OFF`, `COFF` (colour per vertex), `NOFF` (normal per vertex), `CNOFF` (both; normal before
//!   colour, as Geomview orders them) and the `ST` texture-coordinate prefix (coordinates
//!   skipped). The 4D (`4OFF`) and n-dimensional (`nOFF`) variants are refused as unsupported.
//! * The counts may follow the keyword on its own line, or be the first line when the keyword
//!   is left out; extra values after the counts (bounding values some writers add) are ignored.
//! * Colours of 3 or 4 components: integers as 0-255, decimals as 0.0-1.0 (Geomview's rule).
//! * Per-face colour values after a face's indices are skipped; faces keep their size.
//! * `#` starts a comment anywhere; blank lines are skipped.
//!
//! # Writing
//! `OFF`, with `C` when the mesh has colours (written `r g b 255`) and `N` when it has normals;
//! positions in shortest round-trip form. Intensities have no place in OFF and are not written.

use std::io::Write;

use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::{FaceList, PointCloud};

use crate::budget::{Budget, Corners, point_bytes};
use crate::text::{
    LineWriter, Lines, color_component, expect_f32, expect_f64, parse_i64, strip_comment, tokens, truncated,
};
use crate::{Error, Mesh, ReadOptions, Result, WriteOptions, justify};

/// The next line with content after removing comments, tokenised.
fn next_tokens<'a>(lines: &mut Lines<'a>) -> Option<Vec<&'a [u8]>> {
    while let Some(l) = lines.next_line() {
        let t: Vec<&[u8]> = tokens(strip_comment(l)).collect();
        if !t.is_empty() {
            return Some(t);
        }
    }
    None
}

fn count(tok: Option<&&[u8]>, what: &str, lines: &Lines<'_>) -> Result<u64> {
    let t = tok.ok_or_else(|| lines.invalid(format!("expected the {what} count, found the end of the line")))?;
    parse_i64(t).and_then(|v| u64::try_from(v).ok()).ok_or_else(|| {
        lines.invalid(format!("expected the {what} count, found '{}'", String::from_utf8_lossy(truncated(t))))
    })
}

/// Reads a whole OFF file held in memory.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    let limits = &opts.limits;
    let mut lines = Lines::new(data);
    let first = next_tokens(&mut lines).ok_or_else(|| lines.invalid("expected 'OFF', found an empty input"))?;
    let (mut st, mut color, mut normal) = (false, false, false);
    let counts_line = if first.first().and_then(|t| parse_i64(t)).is_some() {
        first
    } else {
        let mut k: &[u8] = first.first().copied().unwrap_or_default();
        if let Some(r) = k.strip_prefix(b"ST") {
            (st, k) = (true, r);
        }
        if let Some(r) = k.strip_prefix(b"C") {
            (color, k) = (true, r);
        }
        if let Some(r) = k.strip_prefix(b"N") {
            (normal, k) = (true, r);
        }
        if k == b"4OFF" || k == b"nOFF" {
            return Err(Error::unsupported(lines.location(), "4D and n-dimensional OFF files"));
        }
        if k != b"OFF" {
            return Err(lines.invalid(format!(
                "expected the header keyword OFF, COFF, NOFF or CNOFF, found '{}'",
                String::from_utf8_lossy(truncated(first.first().copied().unwrap_or_default()))
            )));
        }
        if first.len() > 1 {
            first[1..].to_vec()
        } else {
            next_tokens(&mut lines)
                .ok_or_else(|| lines.invalid("expected the counts line, found the end of the input"))?
        }
    };
    let nv = count(counts_line.first(), "vertex", &lines)?;
    let nf = count(counts_line.get(1), "face", &lines)?;
    let at = lines.location();
    let nv = justify(nv, 5, lines.remaining(), limits.max_points, "vertices", at)?;
    let nf = justify(nf, 2, lines.remaining(), limits.max_faces, "faces", at)?;
    let mut budget = Budget::new(limits, data.len());
    budget.charge_n(nv, point_bytes(normal, color, false), "vertices", at)?;
    let mut cloud = PointCloud {
        positions: Vec::with_capacity(nv),
        normals: normal.then(|| Vec::with_capacity(nv)),
        colors: color.then(|| Vec::with_capacity(nv)),
        intensities: None,
    };
    for k in 0..nv {
        let t = next_tokens(&mut lines)
            .ok_or_else(|| lines.invalid(format!("expected vertex {k} of {nv}, found the end of the input")))?;
        let mut it = t.iter().copied();
        let x = expect_f64(&mut it, "x", &lines)?;
        let y = expect_f64(&mut it, "y", &lines)?;
        let z = expect_f64(&mut it, "z", &lines)?;
        cloud.positions.push(DVec3::new(x, y, z));
        if let Some(n) = cloud.normals.as_mut() {
            let a = expect_f32(&mut it, "the normal's x", &lines)?;
            let b = expect_f32(&mut it, "the normal's y", &lines)?;
            let c = expect_f32(&mut it, "the normal's z", &lines)?;
            n.push(Vec3::new(a, b, c));
        }
        if let Some(colors) = cloud.colors.as_mut() {
            let mut c = [0u8; 3];
            for (slot, name) in c.iter_mut().zip(["red", "green", "blue"]) {
                let t = it.next();
                *slot = t.and_then(color_component).ok_or_else(|| {
                    lines.invalid(format!(
                        "expected the {name} component of vertex {k}'s colour, found {}",
                        t.map_or("the end of the line".to_owned(), |t| format!(
                            "'{}'",
                            String::from_utf8_lossy(truncated(t))
                        ))
                    ))
                })?;
            }
            colors.push(c);
        }
        let _ = st;
    }
    let mut meter = Corners::default();
    let mut faces = FaceList::default();
    let mut face = Vec::with_capacity(8);
    for k in 0..nf {
        let t = next_tokens(&mut lines)
            .ok_or_else(|| lines.invalid(format!("expected face {k} of {nf}, found the end of the input")))?;
        let n = count(t.first(), "corner", &lines)?;
        let n = usize::try_from(n).unwrap_or(usize::MAX);
        if t.len() - 1 < n {
            return Err(lines.invalid(format!("expected {n} vertex indices for face {k}, found {}", t.len() - 1)));
        }
        face.clear();
        for tok in t.iter().skip(1).take(n) {
            let i = parse_i64(tok).and_then(|i| u32::try_from(i).ok()).ok_or_else(|| {
                lines.invalid(format!("expected a vertex index, found '{}'", String::from_utf8_lossy(truncated(tok))))
            })?;
            face.push(i);
        }
        meter.room(&mut budget, &faces, n, lines.location())?;
        faces.push(&face);
    }
    Ok(Mesh { vertices: cloud, faces })
}

/// Writes `mesh` as OFF (`COFF`/`NOFF`/`CNOFF` when it has colours or normals).
pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, _opts: &WriteOptions) -> Result<()> {
    use std::fmt::Write as _;
    let v = &mesh.vertices;
    let mut s = LineWriter::new(w);
    let c = if v.colors.is_some() { "C" } else { "" };
    let n = if v.normals.is_some() { "N" } else { "" };
    // Writing to a String cannot fail.
    let _ = write!(s, "{c}{n}OFF\n# written by octowrap\n{} {} 0\n", v.len(), mesh.faces.len());
    for (i, p) in v.positions.iter().enumerate() {
        let _ = write!(s, "{} {} {}", p.x, p.y, p.z);
        if let Some(n) = v.normals.as_ref().and_then(|n| n.get(i)) {
            let _ = write!(s, " {} {} {}", n.x, n.y, n.z);
        }
        if let Some([r, g, b]) = v.colors.as_ref().and_then(|c| c.get(i)) {
            let _ = write!(s, " {r} {g} {b} 255");
        }
        s.end_line()?;
    }
    s.counted_faces(&mesh.faces)?;
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

    const SAMPLE: &[u8] = b"OFF # a quad and a triangle\n\n# counts with bounding values\n4 2 0 -1 -1 -1 1 1 1\n\
        0 0 0\n1 0 0\n1 1 0   # third\n0 1 0\n4 0 1 2 3 255 0 0\n3 0 2 3 0.5 0.5 0.5 1\n";

    #[test]
    fn plain_off_with_comments_extra_counts_and_face_colours() {
        let m = rd(SAMPLE).unwrap();
        assert_eq!(m.vertex_count(), 4);
        assert_eq!(m.vertices.positions[2], DVec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2, 3][..], &[0, 2, 3]]);
    }

    #[test]
    fn coff_noff_cnoff_and_counts_on_the_keyword_line() {
        let m = rd(b"COFF 2 0 0\n0 0 0 255 0 0 255\n1 1 1 0.0 0.5 1.0\n").unwrap();
        assert_eq!(m.vertices.colors.unwrap(), vec![[255, 0, 0], [0, 128, 255]]);
        let m = rd(b"NOFF\n1 0 0\n1 2 3 0 0 1\n").unwrap();
        assert_eq!(m.vertices.normals.unwrap(), vec![Vec3::Z]);
        let m = rd(b"CNOFF\n1 1 0\n1 2 3 0 1 0 10 20 30 40\n1 0\n").unwrap();
        assert_eq!(m.vertices.normals.unwrap(), vec![Vec3::Y]);
        assert_eq!(m.vertices.colors.unwrap(), vec![[10, 20, 30]]);
        assert_eq!(m.faces.face(0), &[0], "short faces are kept for the validator");
        let m = rd(b"3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
        assert_eq!(m.faces.len(), 1, "keyword left out");
        let m = rd(b"STOFF\n1 0 0\n1 2 3 0.5 0.5\n").unwrap();
        assert_eq!(m.vertex_count(), 1);
    }

    #[test]
    fn bad_input_says_where() {
        let cases: [(&[u8], ErrorKind, u64, &str); 6] = [
            (b"OFX\n1 0 0\n", ErrorKind::Invalid, 1, "keyword"),
            (b"4OFF\n", ErrorKind::Unsupported, 1, "4D"),
            (b"OFF\n1 x 0\n", ErrorKind::Invalid, 2, "'x'"),
            (b"OFF\n2 0 0\n0 0 0\n1 1\n", ErrorKind::Invalid, 4, "z"),
            (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", ErrorKind::Invalid, 6, "expected 3"),
            (b"OFF\n99999999999 0 0\n0 0 0\n", ErrorKind::LimitExceeded, 2, "99999999999"),
        ];
        for (data, kind, line, msg) in cases {
            let e = rd(data).unwrap_err();
            assert_eq!((e.kind, e.location), (kind, Location::Line(line)), "{e}");
            assert!(e.message.contains(msg), "{e}");
        }
        assert!(rd(b"OFF\n1 1 0\n0 0 0\n3 0 -1 0\n").unwrap_err().message.contains("'-1'"));
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        every_prefix(SAMPLE, read);
        every_prefix(b"CNOFF 2 1 0\n0 0 0 0 0 1 1 2 3 4\n1 1 1 0 1 0 5 6 7 8\n3 0 1 1\n", read);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1000))]

        #[test]
        fn mutated_samples_never_panic(d in mutated(SAMPLE)) {
            let _ = rd(&d);
        }
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..300)) {
            let _ = rd(&data);
            let mut d = b"COFF\n".to_vec();
            d.extend(&data);
            let _ = rd(&d);
        }

        #[test]
        fn random_meshes_round_trip(m in arb_mesh(true, true)) {
            let mut out = Vec::new();
            write(&mut out, &m, &WriteOptions::default()).unwrap();
            let back = rd(&out).unwrap();
            prop_assert_eq!(&back.vertices.positions, &m.vertices.positions);
            prop_assert_eq!(&back.vertices.normals, &m.vertices.normals);
            prop_assert_eq!(&back.vertices.colors, &m.vertices.colors);
            prop_assert_eq!(&back.faces, &m.faces);
        }
    }
}
