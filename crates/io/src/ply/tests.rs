use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::FaceList;
use proptest::prelude::*;

use super::*;
use crate::text::testing::{arb_mesh, every_prefix, mutated};
use crate::{ErrorKind, Location, ReadOptions, WriteOptions};

fn rd(data: &[u8]) -> Result<Mesh> {
    read(data, &ReadOptions::default())
}

const ASCII: &[u8] = b"ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info test\r\n\
element vertex 4\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\nproperty float confidence\r\n\
property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\nproperty float intensity\r\n\
element face 3\r\nproperty list uchar int vertex_indices\r\nend_header\r\n\
0 0 0 0.5 255 0 0 1\n1 0 0 0.5 0 255 0 2\n1 1 0 0.5 0 0 255 3\n0 1 0.25 0.5 1 2 3 4\n\
4 0 1 2 3\n3 0 2 3\n2 0 1\n";

#[test]
fn ascii_with_crlf_header_comments_colours_intensity_and_short_faces() {
    let m = rd(ASCII).unwrap();
    assert_eq!(m.vertices.positions[3], DVec3::new(0.0, 1.0, 0.25));
    assert_eq!(m.vertices.colors.as_ref().unwrap()[1], [0, 255, 0]);
    assert_eq!(m.vertices.intensities.as_ref().unwrap(), &[1.0, 2.0, 3.0, 4.0]);
    assert!(m.vertices.normals.is_none());
    assert_eq!(m.faces.len(), 3);
    assert_eq!(m.faces.face(0), &[0, 1, 2, 3]);
    assert_eq!(m.faces.face(2), &[0, 1], "faces of fewer than 3 corners are kept");
}

/// Builds a binary PLY from a header and body bytes.
fn bin(header: &str, body: &[u8]) -> Vec<u8> {
    let mut v = header.as_bytes().to_vec();
    v.extend_from_slice(body);
    v
}

#[test]
fn binary_any_scalar_type_both_endians() {
    type Enc = fn(f64) -> Vec<u8>;
    let types: [(&str, Enc, Enc); 8] = [
        ("char", |v| vec![v as i8 as u8], |v| vec![v as i8 as u8]),
        ("uint8", |v| vec![v as u8], |v| vec![v as u8]),
        ("short", |v| (v as i16).to_le_bytes().to_vec(), |v| (v as i16).to_be_bytes().to_vec()),
        ("uint16", |v| (v as u16).to_le_bytes().to_vec(), |v| (v as u16).to_be_bytes().to_vec()),
        ("int", |v| (v as i32).to_le_bytes().to_vec(), |v| (v as i32).to_be_bytes().to_vec()),
        ("uint", |v| (v as u32).to_le_bytes().to_vec(), |v| (v as u32).to_be_bytes().to_vec()),
        ("float32", |v| (v as f32).to_le_bytes().to_vec(), |v| (v as f32).to_be_bytes().to_vec()),
        ("double", |v| v.to_le_bytes().to_vec(), |v| v.to_be_bytes().to_vec()),
    ];
    for (ty, le, be) in types {
        for (enc, f) in [("binary_little_endian", le), ("binary_big_endian", be)] {
            let h = format!(
                "ply\nformat {enc} 1.0\nelement vertex 2\nproperty {ty} x\nproperty {ty} y\nproperty {ty} z\n\
                 property uchar flags\nend_header\n"
            );
            let mut body = Vec::new();
            for p in [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]] {
                for c in p {
                    body.extend(f(c));
                }
                body.push(7);
            }
            let m = rd(&bin(&h, &body)).unwrap_or_else(|e| panic!("{ty} {enc}: {e}"));
            assert_eq!(m.vertices.positions, vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 6.0)], "{ty} {enc}");
        }
    }
}

#[test]
fn binary_skips_camera_and_lists_reads_face_flags_and_normals() {
    let h = "ply\nformat binary_little_endian 1.0\ncomment VCGLIB generated\nelement camera 1\n\
             property float view_px\nproperty list uchar float k\nelement vertex 3\nproperty float x\n\
             property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
             property list ushort uchar extra\nelement face 2\nproperty uchar flags0\n\
             property list int uint vertex_index\nproperty float quality\nelement range_grid 2\n\
             property list uchar int vertex_indices\nend_header\n";
    let mut b = Vec::new();
    b.extend(1.5f32.to_le_bytes());
    b.push(2);
    b.extend(9.0f32.to_le_bytes());
    b.extend(9.0f32.to_le_bytes());
    for i in 0..3 {
        for c in [i as f32, 0.0, 1.0, 0.0, 0.0, 1.0] {
            b.extend(c.to_le_bytes());
        }
        b.extend(1u16.to_le_bytes());
        b.push(42);
    }
    for f in [&[0u32, 1, 2][..], &[2, 1, 0, 1][..]] {
        b.push(0);
        b.extend((f.len() as i32).to_le_bytes());
        for i in f {
            b.extend(i.to_le_bytes());
        }
        b.extend(0.5f32.to_le_bytes());
    }
    b.push(1);
    b.extend(7i32.to_le_bytes());
    b.push(0);
    let m = rd(&bin(h, &b)).unwrap();
    assert_eq!(m.vertices.positions[2], DVec3::new(2.0, 0.0, 1.0));
    assert_eq!(m.vertices.normals.as_ref().unwrap()[1], Vec3::Z);
    assert_eq!(m.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2][..], &[2, 1, 0, 1][..]]);
    every_prefix(&bin(h, &b), read);
}

#[test]
fn ascii_skips_other_elements_with_lists_and_scales_colours() {
    let h = b"ply\nformat ascii 1.0\nelement material 1\nproperty list uchar float k\nproperty int id\n\
              element vertex 2\nproperty double x\nproperty double y\nproperty double z\n\
              property ushort red\nproperty ushort green\nproperty ushort blue\nproperty float scalar_intensity\n\
              element edge 1\nproperty int vertex1\nproperty int vertex2\n\
              element face 1\nproperty list ushort uint vertex_index\nend_header\n\
              3 0.1 0.2 0.3 5\n600123.456 1e-3 -2 65535 0 32896 0.25\n0.1 0.2 0.3 0 0 0 -1\n0 1\n3 0 1 1\n";
    let m = rd(h).unwrap();
    assert_eq!(m.vertices.positions[0], DVec3::new(600_123.456, 0.001, -2.0));
    assert_eq!(m.vertices.colors.as_ref().unwrap()[0], [255, 0, 128]);
    assert_eq!(m.vertices.intensities.as_ref().unwrap(), &[0.25, -1.0]);
    assert_eq!(m.faces.face(0), &[0, 1, 1]);
    every_prefix(h, read);
}

#[test]
fn float_colours_are_unit_scaled() {
    let h = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
              property float red\nproperty float green\nproperty float blue\nend_header\n0 0 0 1.0 0.5 0\n";
    assert_eq!(rd(h).unwrap().vertices.colors, Some(vec![[255, 128, 0]]));
}

#[test]
fn every_prefix_of_the_samples_fails_cleanly() {
    let parsed = every_prefix(ASCII, read);
    assert!(parsed < 8, "{parsed} prefixes parsed");
    let mut m = rd(ASCII).unwrap();
    m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
    for ascii in [false, true] {
        let mut out = Vec::new();
        let w = WriteOptions { ascii, ..WriteOptions::default() };
        write(&mut out, &m, &w).unwrap();
        every_prefix(&out, read);
    }
}

#[test]
fn huge_counts_fail_at_once() {
    let h = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n\
              property float y\nproperty float z\nend_header\n\0\0\0\0";
    let e = rd(h).unwrap_err();
    assert_eq!(e.kind, ErrorKind::LimitExceeded, "{e}");
    assert!(matches!(e.location, Location::Byte(_)), "{e}");
    let h = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
              element face 99999999999\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n3 0 0 0\n";
    assert_eq!(rd(h).unwrap_err().kind, ErrorKind::LimitExceeded);
    let h = b"ply\nformat binary_big_endian 1.0\nelement camera 18446744073709551615\nproperty float x\n\
              element vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    assert_eq!(rd(h).unwrap_err().kind, ErrorKind::LimitExceeded);
    // An element without properties costs nothing, whatever its count.
    let h = b"ply\nformat binary_big_endian 1.0\nelement nothing 18446744073709551615\n\
              element vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    assert_eq!(rd(h).unwrap().vertex_count(), 0);
}

#[test]
fn bad_headers_say_where_and_what() {
    let cases: [(&[u8], u64, &str); 7] = [
        (b"plx\n", 1, "signature"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\nend_header\n", 4, "property type"),
        (b"ply\nformat ascii 2.0\nend_header\n", 2, "version"),
        (b"ply\nformat ascii 1.0\nproperty float x\nend_header\n", 3, "before any"),
        (b"ply\nformat ascii 1.0\nelement vertex -1\nend_header\n", 3, "count"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", 4, "end_header"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n", 3, "x, y and z"),
    ];
    for (data, line, msg) in cases {
        let e = rd(data).unwrap_err();
        assert_eq!(e.location, Location::Line(line), "{e}");
        assert!(e.message.contains(msg), "{e}");
    }
    let e = rd(b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
                 end_header\n1 2 3\n4 five 6\n")
    .unwrap_err();
    assert_eq!(e.location, Location::Line(9), "{e}");
    assert!(e.message.contains("'five'"), "{e}");
    let e = rd(b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\x03\xff\xff\xff\xff")
    .unwrap_err();
    assert!(matches!(e.location, Location::Byte(_)), "{e}");
    assert!(e.message.contains("-1") || e.message.contains("bytes"), "{e}");
    let e = rd(b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\x01\xff\xff\xff\xff")
    .unwrap_err();
    assert!(e.message.contains("found -1"), "{e}");
}

fn roundtrip(m: &Mesh, ascii: bool) -> Mesh {
    let mut out = Vec::new();
    let w = WriteOptions { ascii, ..WriteOptions::default() };
    write(&mut out, m, &w).unwrap();
    rd(&out).unwrap_or_else(|e| panic!("{e}\n{}", String::from_utf8_lossy(&out[..out.len().min(600)])))
}

#[test]
fn write_read_keeps_everything() {
    let mut m = rd(ASCII).unwrap();
    m.faces = FaceList::default();
    m.faces.push(&[0, 1, 2, 3]);
    m.faces.push(&[0, 2, 3]);
    m.faces.push_iter(0..300);
    m.vertices.positions.resize(300, DVec3::new(600_000.125, 1.0 / 3.0, -7.0));
    m.vertices.colors.as_mut().unwrap().resize(300, [9, 8, 7]);
    m.vertices.intensities.as_mut().unwrap().resize(300, 0.1);
    m.vertices.normals = Some(vec![Vec3::new(0.1, 0.2, 0.3); 300]);
    for ascii in [false, true] {
        assert_eq!(roundtrip(&m, ascii), m, "ascii={ascii}");
    }
    let mut out = Vec::new();
    write(&mut out, &m, &WriteOptions::default()).unwrap();
    let head = String::from_utf8_lossy(&out[..400]);
    assert!(head.contains("property double x") && head.contains("list int int vertex_indices"), "{head}");
}

#[test]
fn float_positions_are_written_as_float() {
    let m = Mesh::from_positions(vec![DVec3::new(0.1f32 as f64, 2.0, 3.0)]);
    let mut out = Vec::new();
    write(&mut out, &m, &WriteOptions::default()).unwrap();
    assert!(String::from_utf8_lossy(&out).contains("property float x"));
    assert!(!String::from_utf8_lossy(&out).contains("element face"));
    assert_eq!(roundtrip(&m, false), m);
    assert_eq!(roundtrip(&m, true), m);
}

/// A small binary file with every kind of element: a camera with a list, vertices with normals
/// and colours, faces with extra properties.
fn binary_sample() -> &'static [u8] {
    static SAMPLE: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    SAMPLE.get_or_init(|| {
        let mut m = rd(ASCII).unwrap();
        m.vertices.normals = Some(vec![Vec3::X; 4]);
        m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
        let mut out = Vec::new();
        write(&mut out, &m, &WriteOptions::default()).unwrap();
        let at = out.windows(13).position(|w| w == b"element face ").unwrap();
        out.splice(
            at..at,
            b"element camera 1
property list uchar float k
"
            .iter()
            .copied(),
        );
        let body = out
            .windows(11)
            .position(|w| {
                w == b"end_header
"
            })
            .unwrap()
            + 11;
        let vertex_bytes = 4 * (12 + 12 + 3 + 4);
        out.splice(body + vertex_bytes..body + vertex_bytes, [1u8, 0, 0, 128, 63]);
        out
    })
}

#[test]
fn binary_sample_reads_and_every_prefix_fails_cleanly() {
    let m = rd(binary_sample()).unwrap();
    assert_eq!(m.faces.face(0), &[0, 1, 2, 3]);
    assert_eq!(m.vertices.normals.as_ref().unwrap()[3], Vec3::X);
    assert_eq!(every_prefix(binary_sample(), read), 0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn mutated_samples_never_panic(a in mutated(ASCII), b in mutated(binary_sample())) {
        let _ = rd(&a);
        let _ = rd(&b);
    }
}

proptest! {
    #[test]
    fn random_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..400)) {
        let _ = rd(&data);
        let mut with_header = ASCII[..ASCII.len() - 40].to_vec();
        with_header.extend_from_slice(&data);
        let _ = rd(&with_header);
    }

    #[test]
    fn random_headers_never_panic(body in prop::collection::vec(any::<u8>(), 0..200),
                                  idx in 0usize..6, count in any::<u32>()) {
        let ty = ["char", "ushort", "int", "float", "double", "uint64"][idx];
        let h = format!("ply\nformat binary_big_endian 1.0\nelement vertex {count}\nproperty {ty} x\n\
                         property {ty} y\nproperty {ty} z\nproperty list {ty} uchar l\nelement face {count}\n\
                         property list uchar {ty} vertex_indices\nend_header\n");
        let _ = rd(&bin(&h, &body));
        let h = h.replace("list uchar", "list char").replace("binary_big_endian", "ascii");
        let _ = rd(&bin(&h, &body));
    }

    #[test]
    fn random_meshes_round_trip(m in arb_mesh(true, true), ascii in any::<bool>()) {
        prop_assert_eq!(roundtrip(&m, ascii), m);
    }
}
