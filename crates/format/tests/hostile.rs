//! Hostile input: every prefix of a valid file fails cleanly, every single-bit flip is caught by a
//! checksum (or decodes identically), and random garbage never panics.

use octowrap_format::synthetic::{Edits, Rng, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::{DecodeError, DecodeOptions, EncodeOptions, Limits, Quantization, decode, encode};
use octowrap_mesh::Hierarchy;

fn strict() -> DecodeOptions {
    let mut o = DecodeOptions::default();
    o.limits = Limits::strict();
    o
}

fn samples() -> Vec<Vec<u8>> {
    // Version 2 (mode 2), then version 3 (mode 3) below.
    let mut q12 = EncodeOptions::with_quantization(Quantization::Bits(12));
    q12.version = 2;
    let mut exact2 = EncodeOptions::with_quantization(Quantization::Exact);
    exact2.version = 2;
    vec![
        encode(&cube_hierarchy(3, Edits::default(), 1), &q12).unwrap(),
        encode(&without_lattice(cube_hierarchy(3, Edits::default(), 2)), &q12).unwrap(),
        encode(&Hierarchy::single(polygon_mesh(20, 12, 3)), &exact2).unwrap(),
        // Line geometry (spec §6.6), lattice and generic.
        encode(&placed(cube_hierarchy(3, Edits::default(), 4), &q12), &q12).unwrap(),
        encode(&placed(without_lattice(cube_hierarchy(3, Edits::default(), 5)), &q12), &q12).unwrap(),
        // Format version 3 (spec §5.9, §6.8): mode 3 levels, with and without lines, and exact.
        encode(&cube_hierarchy(3, Edits { split: 0.1, join: 0.1, ..Edits::default() }, 6), &v3(Quantization::Bits(12)))
            .unwrap(),
        encode(
            &placed(cube_hierarchy(3, Edits::default(), 7), &v3(Quantization::Bits(12))),
            &v3(Quantization::Bits(12)),
        )
        .unwrap(),
        encode(&cube_hierarchy(2, Edits::default(), 8), &v3(Quantization::Exact)).unwrap(),
        // Format version 5 (spec §11): levels in chunks (a chunk shift of 1 splits levels 2 and 3),
        // and one chunk per level (joined vertices off the cell boundaries keep a file whole).
        encode(&cube_hierarchy(4, Edits::default(), 9), &v5(Quantization::Bits(12))).unwrap(),
        encode(&cube_hierarchy(4, Edits { split: 0.1, join: 0.1, ..Edits::default() }, 9), &v5(Quantization::Bits(12)))
            .unwrap(),
    ]
}

fn v5(q: Quantization) -> EncodeOptions {
    let mut o = EncodeOptions::with_quantization(q);
    o.version = 5;
    o.chunk_shift = 1;
    o
}

/// Version 4 options: one zstd frame per level, which the frame surgery below edits.
fn v4() -> EncodeOptions {
    let mut o = EncodeOptions::default();
    o.version = 4;
    o
}

fn v3(q: Quantization) -> EncodeOptions {
    let mut o = EncodeOptions::with_quantization(q);
    o.version = 3;
    o
}

fn placed(mut h: Hierarchy, opts: &EncodeOptions) -> Hierarchy {
    octowrap_format::place_on_prediction_lines(&mut h, opts).unwrap();
    h
}

#[test]
fn every_prefix_fails_cleanly() {
    for bytes in samples() {
        for n in 0..bytes.len() {
            match decode(&bytes[..n], &strict()) {
                Err(DecodeError::Truncated { .. }) => {}
                Err(e) if n < 8 => assert!(matches!(e, DecodeError::BadMagic { .. }) || n == 0, "{n}: {e}"),
                other => panic!("prefix of {n} bytes: expected Truncated, got {other:?}"),
            }
        }
    }
}

#[test]
fn every_bit_flip_is_caught_or_harmless() {
    for bytes in samples() {
        let good = decode(&bytes[..], &strict()).unwrap();
        let mut flipped = bytes.clone();
        for i in 0..bytes.len() {
            for bit in 0..8 {
                flipped[i] ^= 1 << bit;
                match decode(&flipped[..], &strict()) {
                    Ok(f) => assert_eq!(f.hierarchy, good.hierarchy, "byte {i} bit {bit}: decoded differently"),
                    Err(
                        DecodeError::ChecksumMismatch { .. }
                        | DecodeError::BadMagic { .. }
                        | DecodeError::UnsupportedVersion { .. }
                        | DecodeError::Invalid { .. }
                        | DecodeError::LimitExceeded { .. }
                        | DecodeError::Truncated { .. },
                    ) => {}
                    Err(e) => panic!("byte {i} bit {bit}: unexpected {e}"),
                }
                flipped[i] ^= 1 << bit;
            }
        }
    }
}

#[test]
fn garbage_and_mutations_never_panic() {
    let mut rng = Rng::new(7);
    for bytes in samples() {
        for _ in 0..2000 {
            let mut b = bytes.clone();
            for _ in 0..=rng.below(4) {
                let i = rng.below(b.len());
                b[i] = rng.next_u64() as u8;
            }
            let _ = decode(&b[..], &strict());
        }
    }
    for n in 0..300 {
        let b: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
        assert!(decode(&b[..], &strict()).is_err());
    }
}

#[test]
fn mutated_payloads_never_panic() {
    use octowrap_format::fuzzing::{payloads, reseal};
    let mut rng = Rng::new(11);
    let mut caught = 0usize;
    for bytes in samples() {
        let Some(good) = payloads(&bytes) else { continue };
        for _ in 0..3000 {
            let mut p = good.clone();
            let k = rng.below(p.len());
            match rng.below(3) {
                0 => {
                    for _ in 0..=rng.below(3) {
                        let i = rng.below(p[k].len());
                        p[k][i] ^= 1 << rng.below(8);
                    }
                }
                1 => {
                    let i = rng.below(p[k].len());
                    p[k][i] = rng.next_u64() as u8;
                }
                _ => {
                    let n = rng.below(p[k].len());
                    p[k].truncate(n);
                }
            }
            let file = reseal(&bytes, &p, None).unwrap();
            if decode(&file[..], &strict()).is_err() {
                caught += 1;
            }
        }
    }
    assert!(caught > 0);
}

/// Runs the calling test again in a child process whose address space is capped at `mib` MiB, so
/// that an allocation the input cannot justify aborts the child and fails the test. Returns `true`
/// in the child (run the body), `false` in the parent (done).
fn in_capped_child(test: &str, mib: u64) -> bool {
    if std::env::var_os("OCTOWRAP_CAPPED_CHILD").is_some() {
        return true;
    }
    let exe = std::env::current_exe().expect("test binary");
    let script = format!("ulimit -v {} && exec \"$0\" --exact {test} --test-threads 1 --nocapture", mib * 1024);
    match std::process::Command::new("sh").arg("-c").arg(script).arg(exe).env("OCTOWRAP_CAPPED_CHILD", "1").output() {
        Ok(out) => assert!(
            out.status.success(),
            "{test} under a {mib} MiB address-space cap: {}\n{}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
        #[allow(clippy::print_stderr)] // a test that cannot run says so
        Err(e) => eprintln!("SKIPPED {test}: cannot run sh to cap memory ({e})"),
    }
    false
}

/// Offset of a level block header's `vertex_count`, `face_count` and `corner_count` (spec §4.1).
const COUNT_AT: [usize; 3] = [4, 8, 12];

#[test]
fn counts_beyond_what_the_streams_hold_fail_at_the_count() {
    use octowrap_format::Where;
    use octowrap_format::fuzzing::{payloads, reseal};
    if !in_capped_child("counts_beyond_what_the_streams_hold_fail_at_the_count", 1024) {
        return;
    }
    // 2^28 is within the default limits: only the streams can tell that the count is a lie.
    let huge = 1u32 << 28;
    // Files of one frame per level (a chunked level's frames are checked in the chunk tests).
    for bytes in samples() {
        let Some(good) = payloads(&bytes) else { continue };
        let table: Vec<(u32, u32, u32)> = decode(&bytes[..], &DecodeOptions::default())
            .unwrap()
            .info
            .levels
            .iter()
            .map(|l| (l.vertex_count, l.face_count, l.corner_count))
            .collect();
        for k in 0..good.len() {
            for (i, at) in COUNT_AT.into_iter().enumerate() {
                let mut p = good.clone();
                p[k][at..at + 4].copy_from_slice(&huge.to_le_bytes());
                let mut counts = table.clone();
                let c = &mut counts[k];
                *[&mut c.0, &mut c.1, &mut c.2][i] = huge;
                let file = reseal(&bytes, &p, Some(&counts)).unwrap();
                let start = std::time::Instant::now();
                match decode(&file[..], &DecodeOptions::default()) {
                    Err(DecodeError::Invalid {
                        place: Where::Payload(kk) | Where::ChunkPayload(kk, _),
                        offset,
                        ..
                    }) => {
                        assert_eq!((kk, offset), (k as u32, at as u64), "level {k} count {i}");
                    }
                    other => panic!("level {k} count {i}: expected Invalid at payload byte {at}, got {other:?}"),
                }
                assert!(start.elapsed().as_secs() < 5, "level {k} count {i}: took {:?}", start.elapsed());
            }
        }
    }
}

#[test]
fn a_frame_that_expands_hugely_fails_at_its_block_header() {
    use octowrap_format::Where;
    use octowrap_format::tamper::replace_stored;
    use std::io::Write;
    if !in_capped_child("a_frame_that_expands_hugely_fails_at_its_block_header", 768) {
        return;
    }
    // One GiB of zeros (within the default 4 GiB per level) in a frame of a few tens of KB: its
    // block header says every stream is empty, so 64 decompressed bytes suffice to reject it.
    let raw = 1u64 << 30;
    let mut enc = zstd::stream::Encoder::new(Vec::new(), 1).unwrap();
    enc.include_contentsize(true).unwrap();
    enc.set_pledged_src_size(Some(raw)).unwrap();
    let zeros = vec![0u8; 1 << 20];
    for _ in 0..raw >> 20 {
        enc.write_all(&zeros).unwrap();
    }
    let frame = enc.finish().unwrap();
    assert!(frame.len() < 200_000, "{} bytes", frame.len());
    let base = encode(&Hierarchy::single(polygon_mesh(0, 0, 1)), &v4()).unwrap();
    let file = replace_stored(&base, 0, &frame, raw).unwrap();
    let start = std::time::Instant::now();
    match decode(&file[..], &DecodeOptions::default()) {
        Err(DecodeError::Invalid { place: Where::Payload(0), offset: 16, .. }) => {}
        other => panic!("expected Invalid at the block header's stream sizes, got {other:?}"),
    }
    assert!(start.elapsed().as_secs() < 2, "took {:?}", start.elapsed());
}

#[test]
fn bytes_after_a_frame_or_after_the_last_level_are_rejected() {
    use octowrap_format::tamper::replace_stored;
    for bytes in samples() {
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(
            matches!(
                decode(&longer[..], &DecodeOptions::default()),
                Err(DecodeError::Invalid { what: "end of file", .. })
            ),
            "a byte after the last level: {:?}",
            decode(&longer[..], &DecodeOptions::default()).map(drop)
        );
        // A skippable zstd frame after level 0's frame, inside its stored bytes.
        let info = decode(&bytes[..], &DecodeOptions::default()).unwrap().info;
        let l0 = &info.levels[0];
        let mut stored = bytes[l0.offset as usize..(l0.offset + l0.stored_size) as usize].to_vec();
        stored.extend(0x184D_2A50u32.to_le_bytes());
        stored.extend(0u32.to_le_bytes());
        // Files of one frame per level (a chunk's frame goes through the same check).
        let Some(file) = replace_stored(&bytes, 0, &stored, l0.raw_size) else { continue };
        assert!(
            matches!(decode(&file[..], &DecodeOptions::default()), Err(DecodeError::Zstd { level: 0, .. })),
            "a skippable frame after level 0's frame"
        );
    }
}

#[test]
fn vertices_that_cost_no_bytes_are_bounded_by_the_limits() {
    use octowrap_format::fuzzing::reseal;
    // A base level of 2^21 vertices at the origin and no faces: three zero-plane blocks (spec
    // §6.1) hold them all, so only `Limits` can refuse them.
    let nv = 1u32 << 21;
    let mut payload = vec![0u8; 64];
    payload[4..8].copy_from_slice(&nv.to_le_bytes());
    payload[16 + 4 * 11..20 + 4 * 11].copy_from_slice(&3u32.to_le_bytes());
    payload.extend([0, 0, 0]);
    let base = encode(&Hierarchy::single(polygon_mesh(3, 1, 1)), &v4()).unwrap();
    let file = reseal(&base, &[payload], Some(&[(nv, 0, 0)])).unwrap();
    match decode(&file[..], &strict()) {
        Err(DecodeError::LimitExceeded { what: "vertex_count", value, .. }) => assert_eq!(value, u64::from(nv)),
        other => panic!("expected LimitExceeded, got {other:?}"),
    }
    let f = decode(&file[..], &DecodeOptions::default()).unwrap();
    assert_eq!(f.hierarchy.levels[0].mesh.vertices.len(), nv as usize);
}
