//! Hostile inputs, by class: decompression bombs, amplification, nonsense, the memory ceiling.
//! Each test builds its input (nothing large is committed) and reads it through `read_path`,
//! the entry point the CLI uses.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use octowrap_io::{ErrorKind, Location, ReadOptions, read_path};

fn gzip_stream(parts: &mut dyn FnMut(&mut dyn Write)) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    parts(&mut e);
    e.finish().unwrap()
}

fn write(dir: &Path, name: &str, data: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, data).unwrap();
    p
}

fn with_ceiling(bytes: u64) -> ReadOptions {
    let mut o = ReadOptions::default();
    o.limits.max_memory = Some(bytes);
    o
}

const BIN_HEADER: &str = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                          property float z\nend_header\n";

/// A PLY header and three vertices, then `zeros` zero bytes, gzipped.
fn ply_bomb(header: &str, zeros: usize) -> Vec<u8> {
    gzip_stream(&mut |w| {
        w.write_all(header.as_bytes()).unwrap();
        if header.contains("binary") {
            for v in 0..9u8 {
                w.write_all(&f32::from(v).to_le_bytes()).unwrap();
            }
        } else {
            w.write_all(b"0 0 0\n1 0 0\n0 1 0\n").unwrap();
        }
        let chunk = vec![0u8; 1 << 20];
        for _ in 0..zeros >> 20 {
            w.write_all(&chunk).unwrap();
        }
    })
}

#[test]
fn binary_ply_bomb_stops_at_the_end_of_the_declared_body() {
    let dir = tempfile::tempdir().unwrap();
    // 256 MiB of zeros behind a 3-vertex body; a 16 MiB ceiling proves it is never inflated.
    let p = write(dir.path(), "bomb.ply.gz", &ply_bomb(BIN_HEADER, 256 << 20));
    let t = Instant::now();
    let e = read_path(&p, &with_ceiling(16 << 20)).unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    let body_end = (BIN_HEADER.len() + 36) as u64;
    assert_eq!((e.kind, e.location), (ErrorKind::Invalid, Location::Byte(body_end)), "{e}");
    assert!(e.to_string().contains("bomb.ply.gz") && e.message.contains("trailing data"), "{e}");
    // The same bytes in memory, without the stream: the reader refuses them too.
    let mut plain = BIN_HEADER.as_bytes().to_vec();
    plain.extend_from_slice(&[0u8; 36 + 10]);
    let e = octowrap_io::read_bytes(&plain, octowrap_io::Format::Ply, &ReadOptions::default()).unwrap_err();
    assert_eq!(e.location, Location::Byte(body_end), "{e}");
    plain.truncate(plain.len() - 10);
    plain.extend_from_slice(b"\n");
    assert_eq!(
        octowrap_io::read_bytes(&plain, octowrap_io::Format::Ply, &ReadOptions::default()).unwrap().vertices.len(),
        3
    );
}

#[test]
fn text_bombs_stop_at_the_first_nul() {
    let dir = tempfile::tempdir().unwrap();
    let header =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    let p = write(dir.path(), "bomb.ply.gz", &ply_bomb(header, 64 << 20));
    let e = read_path(&p, &with_ceiling(16 << 20)).unwrap_err();
    let at = (header.len() + 18) as u64;
    assert_eq!((e.kind, e.location), (ErrorKind::Invalid, Location::Byte(at)), "{e}");
    assert!(e.message.contains("NUL") && e.message.contains("compressed byte"), "{e}");
    for name in ["bomb.xyz.gz", "bomb.obj.gz", "bomb.off.gz"] {
        let gz = gzip_stream(&mut |w| {
            w.write_all(b"v 1 2 3\n").unwrap();
            w.write_all(&vec![0u8; 32 << 20]).unwrap();
        });
        let e = read_path(&write(dir.path(), name, &gz), &with_ceiling(16 << 20)).unwrap_err();
        assert_eq!((e.kind, e.location), (ErrorKind::Invalid, Location::Byte(8)), "{name}: {e}");
    }
}

#[test]
fn a_dense_text_bomb_meets_the_memory_ceiling() {
    let dir = tempfile::tempdir().unwrap();
    // 8 M valid points from a ~100 kB file: legitimate text, so only the ceiling can stop it.
    let gz = gzip_stream(&mut |w| {
        let chunk = b"0 0 0\n".repeat(1 << 16);
        for _ in 0..128 {
            w.write_all(&chunk).unwrap();
        }
    });
    let p = write(dir.path(), "dense.xyz.gz", &gz);
    let e = read_path(&p, &with_ceiling(64 << 20)).unwrap_err();
    assert_eq!(e.kind, ErrorKind::LimitExceeded, "{e}");
    assert!(e.message.contains("--max-memory") && e.message.contains("64.0 MiB"), "{e}");
    assert_eq!(read_path(&p, &ReadOptions::default()).unwrap().vertices.len(), 8 << 20);
}

#[test]
fn declared_counts_are_checked_against_the_ceiling_before_allocating() {
    let n = 1_000_000usize;
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\n\
         end_header\n"
    )
    .into_bytes();
    ply.resize(ply.len() + 12 * n, 0);
    // 12 MB of input, 24 MB of positions: 30 MB is too little, 40 MB enough.
    let e = octowrap_io::read_bytes(&ply, octowrap_io::Format::Ply, &with_ceiling(30 << 20)).unwrap_err();
    assert_eq!(e.kind, ErrorKind::LimitExceeded, "{e}");
    assert!(e.message.contains("1000000 vertices"), "{e}");
    assert!(octowrap_io::read_bytes(&ply, octowrap_io::Format::Ply, &with_ceiling(40 << 20)).is_ok());
    let mut unlimited = ReadOptions::default();
    unlimited.limits = octowrap_io::Limits::unlimited();
    assert!(octowrap_io::read_bytes(&ply, octowrap_io::Format::Ply, &unlimited).is_ok());
    assert_eq!(octowrap_io::Limits::default().max_memory, Some(8 << 30));
}

#[test]
fn a_conf_naming_one_scan_many_times_is_capped() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "a.xyz", &b"0 0 0\n1 0 0\n0 1 0\n".repeat(300));
    let conf = "bmesh a.xyz 0 0 0 0 0 0 1\n".repeat(60_000);
    let p = write(dir.path(), "many.conf", conf.as_bytes());
    let t = Instant::now();
    let e = read_path(&p, &ReadOptions::default()).unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    assert_eq!((e.kind, e.location), (ErrorKind::LimitExceeded, Location::Line(1001)), "{e}");
    assert!(e.message.contains("1000 scans") && e.message.contains("--max-scans"), "{e}");
    // Under the cap, the ceiling counts the points of every scan together.
    let p = write(dir.path(), "few.conf", "bmesh a.xyz 0 0 0 0 0 0 1\n".repeat(200).as_bytes());
    let e = read_path(&p, &with_ceiling(2 << 20)).unwrap_err();
    assert_eq!(e.kind, ErrorKind::LimitExceeded, "{e}");
    assert_eq!(read_path(&p, &ReadOptions::default()).unwrap().vertices.len(), 200 * 900);
}

#[test]
fn a_point_far_out_is_refused_by_index() {
    let dir = tempfile::tempdir().unwrap();
    let mut xyz = String::new();
    for k in 0..3000 {
        let t = f64::from(k) / 3000.0;
        let _ = writeln!(xyz, "{t} {} {}", 1.0 - t, (t * 7.0).fract());
    }
    let ok = write(dir.path(), "cube.xyz", xyz.as_bytes());
    assert_eq!(read_path(&ok, &ReadOptions::default()).unwrap().vertices.len(), 3000);
    for far in ["1.7e308 -1.7e308 1.7e308", "-1.7e308 0.5 0.5", "inf 0 0", "1e200 1e200 1e200"] {
        let p = write(dir.path(), "far.xyz", format!("{xyz}{far}\n").as_bytes());
        let e = read_path(&p, &ReadOptions::default()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Invalid, "{far}: {e}");
        assert!(e.message.contains("point 3000 ") && e.message.contains("not finite"), "{far}: {e}");
    }
    // 3,000 distinct points within a subnormal extent cannot be normalised.
    let mut tiny = String::new();
    for k in 0..3000 {
        let _ = writeln!(tiny, "{:e} 0 {:e}", f64::from(k) * 1e-312, f64::from(k % 7) * 1e-312);
    }
    let e = read_path(&write(dir.path(), "tiny.xyz", tiny.as_bytes()), &ReadOptions::default()).unwrap_err();
    assert!(e.message.contains("subnormal extent"), "{e}");
    // NaN marks a point without a position: it is passed over.
    let p = write(dir.path(), "nan.xyz", format!("{xyz}nan nan nan\n").as_bytes());
    assert_eq!(read_path(&p, &ReadOptions::default()).unwrap().vertices.len(), 3001);
}

#[test]
fn random_bytes_named_obj_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        r ^= r << 13;
        r ^= r >> 7;
        r ^= r << 17;
        r
    };
    let bytes: Vec<u8> = (0..100_000).map(|_| next() as u8).collect();
    let e = read_path(&write(dir.path(), "random.obj", &bytes), &ReadOptions::default()).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Invalid, "{e}");
    assert!(e.to_string().contains("random.obj") && matches!(e.location, Location::Byte(_)), "{e}");
    // Printable junk (no NUL): nothing parsable, named at its first line.
    let junk: Vec<u8> = (0..100_000).map(|k| if k % 61 == 60 { b'\n' } else { b'!' + (next() % 90) as u8 }).collect();
    let e = read_path(&write(dir.path(), "junk.obj", &junk), &ReadOptions::default()).unwrap_err();
    assert_eq!((e.kind, e.location), (ErrorKind::Invalid, Location::Line(1)), "{e}");
    assert!(e.message.contains("nothing parsable"), "{e}");
    // Unknown statements beside real content are fine.
    let m = read_path(&write(dir.path(), "odd.obj", b"frobnicate 1\nv 0 0 0\n"), &ReadOptions::default()).unwrap();
    assert_eq!(m.vertices.len(), 1);
    assert!(read_path(&write(dir.path(), "empty.obj", b"# nothing\no name\n"), &ReadOptions::default()).is_ok());
}

#[test]
fn gzip_errors_say_where_the_stream_broke() {
    let dir = tempfile::tempdir().unwrap();
    let gz = gzip_stream(&mut |w| w.write_all(&b"1 2 3\n".repeat(50_000)).unwrap());
    let cut = &gz[..gz.len() / 2];
    let e = read_path(&write(dir.path(), "cut.xyz.gz", cut), &ReadOptions::default()).unwrap_err();
    let Location::Byte(at) = e.location else { panic!("{e}") };
    assert_eq!(at, cut.len() as u64, "the whole cut stream is consumed: {e}");
    assert!(e.message.contains("compressed byte") && e.message.contains("decompressed"), "{e}");
    // A corrupt stretch in the middle of a larger stream.
    let mut r = 1u64;
    let noisy: Vec<u8> = (0..400_000)
        .map(|_| {
            r = r.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            b"0123456789 \n"[(r >> 60) as usize % 12]
        })
        .collect();
    let mut gz = gzip_stream(&mut |w| w.write_all(&noisy).unwrap());
    let mid = gz.len() / 2;
    for b in &mut gz[mid..mid + 64] {
        *b = !*b;
    }
    let e = read_path(&write(dir.path(), "corrupt.xyz.gz", &gz), &ReadOptions::default()).unwrap_err();
    let Location::Byte(at) = e.location else { panic!("{e}") };
    // Here the flipped bytes still inflate; the trailer's CRC-32 catches them at the end.
    assert_eq!(at, gz.len() as u64, "{e} (corrupted at {mid})");
    assert!(e.to_string().contains("checksum"), "{e}");
}

#[test]
fn binary_bodies_end_where_the_header_says() {
    // STL: 1 triangle declared, 2 stored.
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&1u32.to_le_bytes());
    stl.extend_from_slice(&[0u8; 100]);
    let e = octowrap_io::read_bytes(&stl, octowrap_io::Format::Stl, &ReadOptions::default()).unwrap_err();
    assert_eq!((e.kind, e.location), (ErrorKind::Invalid, Location::Byte(134)), "{e}");
    // PCD: 1 point declared, garbage after it.
    let mut pcd =
        b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA binary\n"
            .to_vec();
    let start = pcd.len() as u64;
    pcd.extend_from_slice(&[0u8; 12]);
    pcd.extend_from_slice(b"junk");
    let e = octowrap_io::read_bytes(&pcd, octowrap_io::Format::Pcd, &ReadOptions::default()).unwrap_err();
    assert_eq!((e.kind, e.location), (ErrorKind::Invalid, Location::Byte(start + 12)), "{e}");
    // PCD: records of 0 bytes cannot justify 4 billion points.
    let pcd = b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 0 0 0\nWIDTH 65536\nHEIGHT 65536\nDATA binary\n";
    let t = Instant::now();
    assert!(octowrap_io::read_bytes(pcd, octowrap_io::Format::Pcd, &ReadOptions::default()).is_err());
    assert!(t.elapsed() < Duration::from_secs(1));
}

#[test]
fn every_prefix_of_a_gzipped_file_fails_cleanly() {
    let gz = gzip_stream(&mut |w| {
        w.write_all(BIN_HEADER.as_bytes()).unwrap();
        for v in 0..9u8 {
            w.write_all(&f32::from(v).to_le_bytes()).unwrap();
        }
    });
    let path = Path::new("prefix.ply.gz");
    assert_eq!(octowrap_io::read_from(&gz[..], path, &ReadOptions::default()).unwrap().1.vertices.len(), 3);
    for n in 0..gz.len() {
        let e = octowrap_io::read_from(&gz[..n], path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(e.kind, ErrorKind::Invalid | ErrorKind::Unsupported), "prefix {n}: {e}");
    }
}
