//! STL (stereolithography): reading ascii and binary triangle files, writing either.
//!
//! Follows the format as 3D Systems defined it (*`StereoLithography` Interface Specification*,
//! 1989; summarised by Paul Bourke, <https://paulbourke.net/dataformats/stl/>):
//! * binary: an 80-byte header, a little-endian `u32` triangle count, then 50 bytes per
//!   triangle (normal, three vertices as `f32` triples, a 16-bit attribute word);
//! * ascii: `solid name`, then `facet normal nx ny nz` / `outer loop` / three `vertex x y z` /
//!   `endloop` / `endfacet` per triangle, closed by `endsolid name`. Several solids may follow
//!   one another in one file; they are read into one mesh.
//!
//! A binary file may itself start with the word `solid`, so the size decides: a file whose size is
//! exactly `84 + 50 × count` is binary ([`looks_binary`]); otherwise one starting with `solid` and
//! without NUL bytes in its first 512 is read as ascii, and anything else as binary (bytes after
//! the declared triangles are trailing data, an error).
//!
//! # Shared vertices
//! STL stores every triangle's corners separately, and the reader keeps them so: a file of `n`
//! triangles reads as `3n` vertices and `n` faces, exactly as stored (the counts the data sets'
//! PROVENANCE files state). Merging corners at exactly equal positions into an indexed mesh is a
//! separate, explicit step: [`Mesh::weld_exact`](octowrap_mesh::Mesh::weld_exact) (`octowrap
//! convert --weld`). Stored facet normals are ignored (they are recomputed on writing).
//!
//! # Writing
//! Binary by default, ascii with `WriteOptions::ascii`. Triangles as they are; quads split along
//! their shorter diagonal; larger polygons fan-triangulated from their first corner. Each facet
//! normal is computed from its triangle (zero for a degenerate one). Binary STL stores `f32`
//! positions; ascii STL writes them in `f64` shortest round-trip form. A mesh without faces cannot
//! be written (STL holds only triangles).

use std::io::Write;

use octowrap_geom::DVec3;
use octowrap_mesh::{FaceList, PointCloud};

use crate::budget::{Budget, Corners};
use crate::source::Rule;
use crate::text::{LineWriter, Tokens, truncated};
use crate::{Error, Limits, Location, Mesh, ReadOptions, Result, WriteOptions, justify};

/// Whether `data` is a binary STL: an 80-byte header, a triangle count, and exactly 50 bytes per
/// triangle after it. (An ASCII STL starts with `solid`, but so do some binary ones.)
pub(crate) fn looks_binary(data: &[u8]) -> bool {
    if data.len() < 84 {
        return false;
    }
    let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as u64;
    84 + 50 * n == data.len() as u64
}

/// Whether `data` reads as ascii STL: it starts with `solid`, is not an exact-size binary, and
/// its first 512 bytes hold no NUL (binary headers are usually padded with them, and triangle data
/// nearly always has some).
fn looks_ascii(data: &[u8]) -> bool {
    !looks_binary(data)
        && data.trim_ascii_start().starts_with(b"solid")
        && !data.get(..512).unwrap_or(data).contains(&0)
}

/// Collects triangles as stored: three new vertices per triangle.
struct Soup {
    positions: Vec<DVec3>,
    faces: FaceList,
    max_points: u64,
    budget: Budget,
    corners: Corners,
}

impl Soup {
    /// Room for `triangles` (charged to `budget` first).
    fn new(triangles: usize, limits: &Limits, mut budget: Budget, at: Location) -> Result<Self> {
        budget.charge_n(triangles, 3 * 24 + 16, "triangles", at)?;
        Ok(Self {
            positions: Vec::with_capacity(triangles.saturating_mul(3)),
            faces: FaceList::with_capacity(triangles, triangles.saturating_mul(3)),
            max_points: limits.max_points,
            budget,
            corners: Corners { charged: triangles as u64 * 4 + 1 },
        })
    }

    fn vertex(&mut self, p: DVec3, at: Location) -> Result<u32> {
        let next = self.positions.len() as u64;
        if next >= self.max_points || next >= u64::from(u32::MAX) {
            return Err(Error::limit(at, format!("more than {} vertices", self.max_points.min(u64::from(u32::MAX)))));
        }
        self.budget.grow(&mut self.positions, 24, "vertices", at)?;
        self.positions.push(p);
        Ok(next as u32)
    }

    fn face(&mut self, corners: &[u32], at: Location) -> Result<()> {
        self.corners.room(&mut self.budget, &self.faces, corners.len(), at)?;
        self.faces.push(corners);
        Ok(())
    }

    fn finish(self) -> Mesh {
        Mesh { vertices: PointCloud::from_positions(self.positions), faces: self.faces }
    }
}

/// Reads a whole STL file held in memory, ascii or binary.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    let budget = Budget::new(&opts.limits, data.len());
    if looks_ascii(data) { read_ascii(data, &opts.limits, budget) } else { read_binary(data, &opts.limits, budget) }
}

/// What the start of an STL says about the bytes to come: a binary file ends after the
/// triangles its header counts. (One that starts like ascii is left to the reader.)
pub(crate) fn stream_rule(data: &[u8]) -> Option<Rule> {
    let head = data.get(..512)?;
    if data.trim_ascii_start().starts_with(b"solid") && !head.contains(&0) {
        return Some(Rule::Free);
    }
    let n = u32::from_le_bytes([head[80], head[81], head[82], head[83]]);
    let end = 84 + 50 * u64::from(n);
    Some(Rule::EndsBy { end, least: end })
}

fn read_binary(data: &[u8], limits: &Limits, budget: Budget) -> Result<Mesh> {
    let Some(count) = data.get(80..84) else {
        return Err(Error::invalid(
            Location::Byte(0),
            format!("expected an 84-byte binary STL header (or 'solid' for ascii), found {} bytes", data.len()),
        ));
    };
    let count = u32::from_le_bytes([count[0], count[1], count[2], count[3]]);
    let body = data.get(84..).unwrap_or_default();
    let n = justify(u64::from(count), 50, body.len(), limits.max_faces, "triangles", Location::Byte(80))?;
    if body.len() > 50 * n {
        return Err(Error::invalid(
            Location::Byte(84 + 50 * n as u64),
            format!(
                "trailing data: {} bytes follow the {n} triangles the header counts, which end at byte {}",
                body.len() - 50 * n,
                84 + 50 * n
            ),
        ));
    }
    let mut soup = Soup::new(n, limits, budget, Location::Byte(80))?;
    let f =
        |b: &[u8], o: usize| f64::from(b.get(o..o + 4).map_or(0.0, |b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])));
    for (k, t) in body.chunks_exact(50).take(n).enumerate() {
        let at = Location::Byte(84 + 50 * k as u64);
        let mut tri = [0u32; 3];
        for (c, slot) in tri.iter_mut().enumerate() {
            let o = 12 + 12 * c;
            *slot = soup.vertex(DVec3::new(f(t, o), f(t, o + 4), f(t, o + 8)), at)?;
        }
        soup.face(&tri, at)?;
    }
    Ok(soup.finish())
}

fn read_ascii(data: &[u8], limits: &Limits, budget: Budget) -> Result<Mesh> {
    let mut t = Tokens::new(data, 0, 1);
    let mut soup = Soup::new(data.len() / 256, limits, budget, Location::Line(1))?;
    let mut corners: Vec<u32> = Vec::with_capacity(3);
    let expect = |t: &mut Tokens<'_>, word: &[u8]| -> Result<()> {
        match t.next_token() {
            Some(w) if w == word => Ok(()),
            other => Err(Error::invalid(
                t.location(),
                format!(
                    "expected '{}', found {}",
                    String::from_utf8_lossy(word),
                    other.map_or("the end of the input".to_owned(), |w| format!(
                        "'{}'",
                        String::from_utf8_lossy(truncated(w))
                    ))
                ),
            )),
        }
    };
    let mut solids = 0;
    loop {
        // `solid [name]`: the name runs to the end of the line.
        match t.next_token() {
            None if solids > 0 => break,
            Some(b"solid") => t.skip_line(),
            other => {
                return Err(Error::invalid(
                    t.location(),
                    format!(
                        "expected 'solid', found {}",
                        other.map_or("the end of the input".to_owned(), |w| format!(
                            "'{}'",
                            String::from_utf8_lossy(truncated(w))
                        ))
                    ),
                ));
            }
        }
        solids += 1;
        loop {
            match t.next_token() {
                Some(b"endsolid") => {
                    t.skip_line();
                    break;
                }
                Some(b"facet") => {}
                other => {
                    return Err(Error::invalid(
                        t.location(),
                        format!(
                            "expected 'facet' or 'endsolid', found {}",
                            other.map_or("the end of the input".to_owned(), |w| format!(
                                "'{}'",
                                String::from_utf8_lossy(truncated(w))
                            ))
                        ),
                    ));
                }
            }
            expect(&mut t, b"normal")?;
            for c in ["normal x", "normal y", "normal z"] {
                t.f64(c)?;
            }
            expect(&mut t, b"outer")?;
            expect(&mut t, b"loop")?;
            corners.clear();
            loop {
                match t.next_token() {
                    Some(b"vertex") => {
                        let at = t.location();
                        let p = DVec3::new(t.f64("x")?, t.f64("y")?, t.f64("z")?);
                        corners.push(soup.vertex(p, at)?);
                    }
                    Some(b"endloop") => break,
                    other => {
                        return Err(Error::invalid(
                            t.location(),
                            format!(
                                "expected 'vertex' or 'endloop', found {}",
                                other.map_or("the end of the input".to_owned(), |w| format!(
                                    "'{}'",
                                    String::from_utf8_lossy(truncated(w))
                                ))
                            ),
                        ));
                    }
                }
            }
            expect(&mut t, b"endfacet")?;
            if soup.faces.len() as u64 >= limits.max_faces {
                return Err(Error::limit(t.location(), format!("more than {} facets", limits.max_faces)));
            }
            soup.face(&corners, t.location())?;
        }
    }
    Ok(soup.finish())
}

/// Writes `mesh` as STL, binary or (with `opts.ascii`) ascii.
pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, opts: &WriteOptions) -> Result<()> {
    if mesh.faces.is_empty() {
        return Err(Error::unsupported(
            Location::Unknown,
            "STL holds triangles only, and this mesh has no faces (write a point cloud as PLY or XYZ)",
        ));
    }
    let tris = mesh.triangles();
    let p = &mesh.vertices.positions;
    let pos = |i: u32| p.get(i as usize).copied().unwrap_or(DVec3::ZERO);
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(pos);
        (b - a).cross(c - a).normalize_or_zero()
    };
    if opts.ascii {
        use std::fmt::Write as _;
        let mut s = LineWriter::new(w);
        // Writing to the buffer cannot fail.
        let _ = write!(s, "solid octowrap");
        s.end_line()?;
        for t in &tris {
            let n = normal(t).as_vec3();
            let _ = write!(s, "facet normal {} {} {}\nouter loop", n.x, n.y, n.z);
            for &i in t {
                let v = pos(i);
                let _ = write!(s, "\nvertex {} {} {}", v.x, v.y, v.z);
            }
            let _ = write!(s, "\nendloop\nendfacet");
            s.end_line()?;
        }
        let _ = write!(s, "endsolid octowrap");
        s.end_line()?;
        return s.finish();
    }
    let count = u32::try_from(tris.len())
        .map_err(|_| Error::unsupported(Location::Unknown, "binary STL holds at most 2^32-1 triangles"))?;
    let mut b = Vec::with_capacity(1 << 20);
    let mut header = *b"binary STL written by octowrap";
    header.make_ascii_uppercase();
    b.extend_from_slice(&header);
    b.resize(80, b' ');
    b.extend_from_slice(&count.to_le_bytes());
    for t in &tris {
        let n = normal(t).as_vec3();
        for c in n.to_array() {
            b.extend_from_slice(&c.to_le_bytes());
        }
        for &i in t {
            for c in pos(i).to_array() {
                b.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        b.extend_from_slice(&[0, 0]);
        if b.len() >= 1 << 20 {
            w.write_all(&b).map_err(Error::io)?;
            b.clear();
        }
    }
    w.write_all(&b).map_err(Error::io)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::ErrorKind;
    use crate::text::testing::{arb_mesh, every_prefix, mutated};

    fn rd(data: &[u8]) -> Result<Mesh> {
        read(data, &ReadOptions::default())
    }

    const ASCII: &[u8] = b"solid two triangles\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n\
        vertex 1 1 -0\n  endloop\n endfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 1 0\n\
        vertex 0 1 0\nendloop\nendfacet\nendsolid two triangles\r\nsolid second\nfacet normal 0 0 0\nouter loop\n\
        vertex 0 0 0\nvertex 0 1 0\nvertex 0 0 5\nendloop\nendfacet\nendsolid\n";

    #[test]
    fn ascii_several_solids_as_stored() {
        let mut m = rd(ASCII).unwrap();
        assert_eq!(m.vertex_count(), 9, "three vertices per triangle, as stored");
        assert_eq!(m.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2][..], &[3, 4, 5], &[6, 7, 8]]);
        assert_eq!(m.vertices.positions[8], DVec3::new(0.0, 0.0, 5.0));
        assert_eq!(m.weld_exact(), 4, "-0 and 0 weld; repeated corners weld");
        assert_eq!(m.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2][..], &[0, 2, 3], &[0, 3, 4]]);
    }

    fn binary(tris: &[[[f32; 3]; 3]], header: &[u8]) -> Vec<u8> {
        let mut b = header.to_vec();
        b.resize(80, 0);
        b.extend((tris.len() as u32).to_le_bytes());
        for t in tris {
            b.extend([0u8; 12]);
            for v in t {
                for c in v {
                    b.extend(c.to_le_bytes());
                }
            }
            b.extend([0, 0]);
        }
        b
    }

    #[test]
    fn binary_even_when_it_starts_with_solid() {
        let tris =
            [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.5]]];
        for header in [&b"solid but binary"[..], b"\0\0"] {
            let data = binary(&tris, header);
            assert!(looks_binary(&data));
            let m = rd(&data).unwrap();
            assert_eq!(m.vertex_count(), 6);
            assert_eq!(m.vertices.positions[5], DVec3::new(1.0, 1.0, 0.5));
            assert_eq!(m.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2][..], &[3, 4, 5]]);
            every_prefix(&data, read);
        }
    }

    #[test]
    fn bad_input_says_where() {
        let mut data = binary(&[[[0.0; 3]; 3]], b"x");
        data[80] = 0xff;
        let e = rd(&data).unwrap_err();
        assert_eq!((e.kind, e.location), (ErrorKind::LimitExceeded, Location::Byte(80)), "{e}");
        let e = rd(b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zero\n").unwrap_err();
        assert_eq!(e.location, Location::Line(4), "{e}");
        assert!(e.message.contains("'zero'"), "{e}");
        let e = rd(b"solid x\nfacet normal 0 0 1\nouter lop\n").unwrap_err();
        assert!(e.message.contains("expected 'loop', found 'lop'"), "{e}");
        assert!(rd(b"tiny").unwrap_err().message.contains("84-byte"));
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        // Only prefixes that end inside an `endsolid` line parse (as fewer solids).
        let parsed = every_prefix(ASCII, read);
        assert!(parsed <= 30, "{parsed}");
    }

    #[test]
    fn writer_splits_quads_along_the_shorter_diagonal_and_refuses_point_clouds() {
        let mut m = Mesh::from_positions(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(4.0, 0.0, 0.0),
            DVec3::new(4.0, 1.0, 0.0),
            DVec3::new(3.0, 3.0, 0.0),
        ]);
        m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
        assert_eq!(m.triangles(), vec![[0, 1, 3], [1, 2, 3]]);
        let mut out = Vec::new();
        write(&mut out, &m, &WriteOptions::default()).unwrap();
        assert_eq!(out.len(), 84 + 100);
        assert!(!out.starts_with(b"solid"));
        let mut back = rd(&out).unwrap();
        back.weld_exact();
        assert_eq!(back.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2][..], &[1, 3, 2]]);
        assert_eq!(out[84 + 8..84 + 12], 1.0f32.to_le_bytes(), "facet normal +z");
        let e = write(&mut Vec::new(), &Mesh::from_positions(vec![DVec3::ZERO]), &WriteOptions::default()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Unsupported);
    }

    /// The triangles of `m` as position triples, for comparing meshes up to vertex numbering.
    fn soup(m: &Mesh) -> Vec<[DVec3; 3]> {
        m.triangles().iter().map(|t| t.map(|i| m.vertices.positions[i as usize])).collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1000))]

        #[test]
        fn mutated_samples_never_panic(d in mutated(ASCII)) {
            let _ = rd(&d);
        }
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..400)) {
            let _ = rd(&data);
            let mut d = b"solid ".to_vec();
            d.extend(&data);
            let _ = rd(&d);
        }

        #[test]
        fn random_meshes_round_trip(m in arb_mesh(false, true), ascii in any::<bool>()) {
            prop_assume!(!m.faces.is_empty());
            let w = WriteOptions { ascii, ..WriteOptions::default() };
            let mut out = Vec::new();
            write(&mut out, &m, &w).unwrap();
            let back = rd(&out).unwrap();
            let mut want = soup(&m);
            if !ascii {
                want = want.iter().map(|t| t.map(|p| p.as_vec3().as_dvec3())).collect();
            }
            prop_assert_eq!(soup(&back), want);
        }
    }
}
