//! Wavefront OBJ: reading and writing polygon meshes.
//!
//! Follows the geometry part of Wavefront's *Object Files (.obj)* specification (Appendix B1 of
//! the Advanced Visualizer manual; see Paul Bourke's copy, <https://paulbourke.net/dataformats/obj/>).
//!
//! # Reading
//! * `v x y z [w]` positions (kept in `f64`; `w` ignored), with the common `v x y z r g b`
//!   colour extension (components 0.0-1.0, or 0-255 when any exceeds 1 in the file). Colours are
//!   kept only when every vertex has them.
//! * `f` faces in the `v`, `v/vt`, `v//vn` and `v/vt/vn` forms, with positive (1-based) or
//!   negative (relative) indices; quads and n-gons are kept as they are.
//! * `vn` normals become per-vertex normals only when there is one per vertex and every face
//!   corner uses the same index for its position and its normal (a file without faces qualifies
//!   when the counts match); otherwise they are ignored
//!   (octowrap has no per-corner normals).
//! * `vt`, `vp`, `l`, `p`, `o`, `g`, `s`, `usemtl`, `mtllib` and any other statement are
//!   skipped; `#` starts a comment; a trailing `\` continues a statement on the next line.
//! * A file with no `v`, `vn` or `f` statement but some statement that is not OBJ's is refused as
//!   nothing parsable (random bytes named `.obj` are not an empty mesh).
//!
//! # Writing
//! `v x y z` in shortest round-trip form (plus `r g b` as 0.0-1.0 when the mesh has colours),
//! `vn` per vertex when it has normals (faces then as `f a//a b//b c//c`), faces 1-based with
//! their size kept. Intensities have no place in OBJ and are not written.

use std::io::Write;

use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::{FaceList, PointCloud};

use crate::budget::{Budget, Corners};
use crate::text::{LineWriter, Lines, expect_f32, expect_f64, parse_f64, parse_i64, strip_comment, tokens, truncated};
use crate::{Error, Location, Mesh, ReadOptions, Result, WriteOptions};

/// Reads a whole OBJ file held in memory.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    let limits = &opts.limits;
    let mut budget = Budget::new(limits, data.len());
    let mut meter = Corners::default();
    let mut first_unknown: Option<(Location, String)> = None;
    let mut lines = Lines::new(data);
    let mut positions: Vec<DVec3> = Vec::new();
    let mut colors: Vec<[f32; 3]> = Vec::new();
    let mut color_max = 0.0f32;
    let mut normals: Vec<Vec3> = Vec::new();
    let mut faces = FaceList::default();
    let mut normals_map_one_to_one = true;
    let mut joined: Vec<u8> = Vec::new();
    let mut face = Vec::with_capacity(8);
    while let Some(line) = lines.next_line() {
        let line = if line.last() == Some(&b'\\') { continued(line, &mut lines, &mut joined) } else { line };
        let line = strip_comment(line);
        let mut it = tokens(line);
        let Some(keyword) = it.next() else { continue };
        match keyword {
            b"v" => {
                if positions.len() as u64 >= limits.max_points {
                    return Err(Error::limit(lines.location(), format!("more than {} vertices", limits.max_points)));
                }
                let x = expect_f64(&mut it, "x", &lines)?;
                let y = expect_f64(&mut it, "y", &lines)?;
                let z = expect_f64(&mut it, "z", &lines)?;
                budget.grow(&mut positions, 24 + 12, "vertices", lines.location())?;
                positions.push(DVec3::new(x, y, z));
                if let Some(c) = vertex_color(it, &lines)? {
                    color_max = c.iter().fold(color_max, |m, &v| m.max(v));
                    if colors.len() + 1 == positions.len() {
                        colors.push(c);
                    }
                }
            }
            b"vn" => {
                if normals.len() as u64 >= limits.max_points {
                    return Err(Error::limit(lines.location(), format!("more than {} normals", limits.max_points)));
                }
                let x = expect_f32(&mut it, "the normal's x", &lines)?;
                let y = expect_f32(&mut it, "the normal's y", &lines)?;
                let z = expect_f32(&mut it, "the normal's z", &lines)?;
                budget.grow(&mut normals, 12, "normals", lines.location())?;
                normals.push(Vec3::new(x, y, z));
            }
            b"f" => {
                if faces.len() as u64 >= limits.max_faces {
                    return Err(Error::limit(lines.location(), format!("more than {} faces", limits.max_faces)));
                }
                face.clear();
                for corner in it {
                    let mut parts = corner.split(|&c| c == b'/');
                    let v = parts.next().unwrap_or_default();
                    let vi = resolve(v, positions.len(), "vertex", &lines)?;
                    let _vt = parts.next();
                    match parts.next() {
                        Some(n) if !n.is_empty() => {
                            let ni = resolve(n, normals.len(), "normal", &lines)?;
                            normals_map_one_to_one &= ni == vi;
                        }
                        _ => normals_map_one_to_one = false,
                    }
                    face.push(vi);
                }
                if face.is_empty() {
                    return Err(lines.invalid("expected vertex indices after 'f', found the end of the line"));
                }
                meter.room(&mut budget, &faces, face.len(), lines.location())?;
                faces.push(&face);
            }
            k if SKIPPED.contains(&k) => {}
            k => {
                if first_unknown.is_none() {
                    first_unknown = Some((lines.location(), String::from_utf8_lossy(truncated(k)).into_owned()));
                }
            }
        }
    }
    if let (Some((at, word)), true) = (first_unknown, positions.is_empty() && normals.is_empty()) {
        return Err(nothing_parsable(at, &word));
    }
    let n = positions.len();
    let colors = (colors.len() == n && n > 0).then(|| {
        let scale = if color_max > 1.0 { 1.0 } else { 255.0 };
        colors.iter().map(|c| c.map(|v| (f64::from(v) * scale).round().clamp(0.0, 255.0) as u8)).collect()
    });
    let normals = (normals_map_one_to_one && n > 0 && normals.len() == n).then_some(normals);
    Ok(Mesh { vertices: PointCloud { positions, normals, colors, intensities: None }, faces })
}

/// A statement continued with a trailing `\\` onto the following lines, joined into `joined`.
fn continued<'b>(line: &[u8], lines: &mut Lines<'_>, joined: &'b mut Vec<u8>) -> &'b [u8] {
    joined.clear();
    joined.extend_from_slice(line);
    while joined.last() == Some(&b'\\') {
        joined.pop();
        joined.push(b' ');
        let Some(next) = lines.next_line() else { break };
        joined.extend_from_slice(next);
    }
    joined
}

/// The error for an input with no content and a statement that is not OBJ's.
fn nothing_parsable(at: Location, word: &str) -> Error {
    Error::invalid(
        at,
        format!("nothing parsable: no 'v', 'vn' or 'f' statement, and '{word}' (here) is no OBJ statement"),
    )
}

/// The statements read and skipped without a word (any other is skipped too, but a file made of
/// nothing else is refused as unparsable).
const SKIPPED: &[&[u8]] = &[
    b"vt",
    b"vp",
    b"l",
    b"p",
    b"o",
    b"g",
    b"s",
    b"mg",
    b"usemtl",
    b"mtllib",
    b"cstype",
    b"deg",
    b"bmat",
    b"step",
    b"curv",
    b"curv2",
    b"surf",
    b"parm",
    b"trim",
    b"hole",
    b"scrv",
    b"sp",
    b"end",
    b"con",
    b"bevel",
    b"c_interp",
    b"d_interp",
    b"lod",
    b"maplib",
    b"usemap",
    b"shadow_obj",
    b"trace_obj",
    b"ctech",
    b"stech",
];

/// The `r g b` after a vertex's `x y z` (alone, or after `w`), if there is one.
fn vertex_color<'a>(rest: impl Iterator<Item = &'a [u8]>, lines: &Lines<'_>) -> Result<Option<[f32; 3]>> {
    let mut buf: [&[u8]; 4] = [&[]; 4];
    let mut n = 0;
    for t in rest {
        let Some(slot) = buf.get_mut(n) else { return Ok(None) };
        *slot = t;
        n += 1;
    }
    let ((3, [r, g, b, _]) | (4, [_, r, g, b])) = (n, buf) else { return Ok(None) };
    let mut c = [0.0f32; 3];
    for (slot, t) in c.iter_mut().zip([r, g, b]) {
        *slot = parse_f64(t).ok_or_else(|| {
            lines.invalid(format!("expected a colour component, found '{}'", String::from_utf8_lossy(truncated(t))))
        })? as f32;
    }
    Ok(Some(c))
}

/// Resolves a 1-based or negative (relative) OBJ index against `count` elements so far.
fn resolve(tok: &[u8], count: usize, what: &str, lines: &Lines<'_>) -> Result<u32> {
    let i = parse_i64(tok).ok_or_else(|| {
        lines.invalid(format!("expected a {what} index, found '{}'", String::from_utf8_lossy(truncated(tok))))
    })?;
    let r = match i {
        0 => return Err(lines.invalid(format!("expected a {what} index, found 0 (OBJ indices start at 1)"))),
        i if i > 0 => i - 1,
        i => count as i64 + i,
    };
    if r < 0 {
        return Err(lines.invalid(format!("relative {what} index {i} reaches before the first of the {count} so far")));
    }
    u32::try_from(r)
        .ok()
        .filter(|&r| r < u32::MAX)
        .ok_or_else(|| lines.invalid(format!("{what} index {i} is too large")))
}

/// Writes `mesh` as OBJ.
pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, _opts: &WriteOptions) -> Result<()> {
    use std::fmt::Write as _;
    let v = &mesh.vertices;
    let mut s = LineWriter::new(w);
    // Writing to the buffer cannot fail.
    let _ = write!(s, "# written by octowrap");
    s.end_line()?;
    // Writing to a String cannot fail.
    for (i, p) in v.positions.iter().enumerate() {
        let _ = write!(s, "v {} {} {}", p.x, p.y, p.z);
        if let Some(c) = v.colors.as_ref().and_then(|c| c.get(i)) {
            let [r, g, b] = c.map(|c| f64::from(c) / 255.0);
            let _ = write!(s, " {r} {g} {b}");
        }
        s.end_line()?;
    }
    if let Some(normals) = &v.normals {
        for n in normals {
            let _ = write!(s, "vn {} {} {}", n.x, n.y, n.z);
            s.end_line()?;
        }
    }
    let with_normals = v.normals.is_some();
    for f in mesh.faces.iter() {
        let _ = write!(s, "f");
        for &i in f {
            let k = u64::from(i) + 1;
            if with_normals {
                let _ = write!(s, " {k}//{k}");
            } else {
                let _ = write!(s, " {k}");
            }
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

    const SAMPLE: &[u8] = b"# a quad, a triangle and a pentagon\nmtllib a.mtl\no thing\ng group\ns 1\n\
        v 0 0 0\nv 1 0 0 1.0\nv 1 1 0\nv 0 1 0\nv 2 2 \\\n 2\nvt 0 0\nvt 1 0\nvp 0.5\nvn 0 0 1\nusemtl red\n\
        f 1 2 3 4\nf 1/1 2/2 5/1\nf -5//1 -4//1 -3//1 -2//1 -1//1\nl 1 2\n";

    #[test]
    fn every_statement_form() {
        let m = rd(SAMPLE).unwrap();
        assert_eq!(m.vertex_count(), 5);
        assert_eq!(m.vertices.positions[4], DVec3::new(2.0, 2.0, 2.0), "line continuation");
        assert_eq!(m.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2, 3][..], &[0, 1, 4], &[0, 1, 2, 3, 4]]);
        assert!(m.vertices.normals.is_none(), "one normal for five vertices is not per-vertex");
        assert!(m.vertices.colors.is_none());
    }

    #[test]
    fn per_vertex_normals_and_colours() {
        let m = rd(b"v 0 0 0 1 0 0\nv 1 0 0 0 0.5 0\nv 0 1 0 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 1 0\nf 1//1 2//2 3//3\n")
            .unwrap();
        assert_eq!(m.vertices.normals.as_ref().unwrap()[2], Vec3::Y);
        assert_eq!(m.vertices.colors.as_ref().unwrap(), &[[255, 0, 0], [0, 128, 0], [0, 0, 255]]);
        let m = rd(
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 1 0\nf 1/3/1 2/2/2 -1/1/-1\n",
        )
        .unwrap();
        assert_eq!(m.vertices.normals.as_ref().unwrap()[2], Vec3::Y, "v/vt/vn form");
        assert_eq!(m.faces.face(0), &[0, 1, 2]);
        let m =
            rd(b"v 0 0 0 255 0 0\nv 1 0 0 0 7 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 1 0\nf 1//1 2//3 3//2\n").unwrap();
        assert!(m.vertices.normals.is_none(), "mismatched v and vn indices");
        assert!(m.vertices.colors.is_none(), "not every vertex has a colour");
        let m = rd(b"v 0 0 0 255 0 0\nv 1 0 0 0 7 0\n").unwrap();
        assert_eq!(m.vertices.colors.as_ref().unwrap(), &[[255, 0, 0], [0, 7, 0]], "0-255 colours");
    }

    #[test]
    fn bad_indices_say_where() {
        for (data, msg) in [
            (&b"v 0 0 0\nf 1 2 0\n"[..], "found 0"),
            (b"v 0 0 0\n\nf 1 -2 1\n", "before the first"),
            (b"v 0 0 0\nf 1 x 1\n", "'x'"),
            (b"v 0 0\n", "end of the line"),
            (b"v 0 0 0\nf 1 99999999999 1\n", "too large"),
            (b"f\n", "after 'f'"),
        ] {
            let e = rd(data).unwrap_err();
            assert_eq!(e.kind, ErrorKind::Invalid);
            assert!(matches!(e.location, Location::Line(1..=3)), "{e}");
            assert!(e.message.contains(msg), "{e}");
        }
        assert_eq!(rd(b"v 0 0 0\n\nf 1 -2 1\n").unwrap_err().location, Location::Line(3));
        let mut o = ReadOptions::default();
        o.limits.max_points = 1;
        assert_eq!(read(b"v 0 0 0\nv 1 1 1\n", &o).unwrap_err().kind, ErrorKind::LimitExceeded);
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        every_prefix(SAMPLE, read);
    }

    fn roundtrip(m: &Mesh) -> Mesh {
        let mut out = Vec::new();
        write(&mut out, m, &WriteOptions::default()).unwrap();
        rd(&out).unwrap()
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
        }

        #[test]
        fn random_statements_never_panic(s in "([vf] [-0-9/ ]{0,12}\n){0,8}") {
            let _ = rd(s.as_bytes());
        }

        #[test]
        fn random_meshes_round_trip(m in arb_mesh(true, true)) {
            let back = roundtrip(&m);
            prop_assert_eq!(&back.vertices.positions, &m.vertices.positions);
            prop_assert_eq!(&back.faces, &m.faces);
            prop_assert_eq!(&back.vertices.colors, &m.vertices.colors);
            prop_assert_eq!(&back.vertices.normals, &m.vertices.normals);
        }
    }
}
