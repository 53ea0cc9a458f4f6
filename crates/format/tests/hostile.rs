//! Hostile input: every prefix of a valid file fails cleanly, every single-bit flip is caught by a
//! checksum (or decodes identically), and random garbage never panics.

use octowrap_format::synthetic::{Edits, Rng, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::{DecodeOptions, EncodeOptions, Error, Limits, Quantization, decode, encode};
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
    ]
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
                Err(Error::Truncated { .. }) => {}
                Err(e) if n < 8 => assert!(matches!(e, Error::BadMagic { .. }) || n == 0, "{n}: {e}"),
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
                        Error::ChecksumMismatch { .. }
                        | Error::BadMagic { .. }
                        | Error::UnsupportedVersion { .. }
                        | Error::Invalid { .. }
                        | Error::LimitExceeded { .. }
                        | Error::Truncated { .. },
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
        let good = payloads(&bytes).unwrap();
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
