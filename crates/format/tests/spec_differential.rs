//! The spec decoder (`tests/spec_decoder/`, written from `spec/FORMAT.md` alone) against the
//! reference decoder beyond the conformance files: hierarchies the reference encoder writes in
//! every mode, version and quantization, and mutants of them. Both decoders must accept the same
//! files, decode them to the same hierarchy, and reject the others with the same error class of
//! spec §7.3. (This harness uses the reference crate's encoder and test helpers to make inputs;
//! the spec decoder's own modules use none of it.)

#[path = "spec_decoder/block.rs"]
mod block;
#[path = "spec_decoder/chunks.rs"]
mod chunks;
#[path = "spec_decoder/compare.rs"]
mod compare;
#[path = "spec_decoder/container.rs"]
mod container;
#[path = "spec_decoder/file.rs"]
mod file;
#[path = "spec_decoder/geometry.rs"]
mod geometry;
#[path = "spec_decoder/geometry3.rs"]
mod geometry3;
#[path = "spec_decoder/primitives.rs"]
mod primitives;
#[path = "spec_decoder/topology.rs"]
mod topology;
#[path = "spec_decoder/values.rs"]
mod values;

use std::path::Path;

use octowrap_format::fuzzing::{payloads, reseal};
use octowrap_format::synthetic::{Edits, Rng, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::tamper::fix_preamble_checksum;
use octowrap_format::{
    DecodeError as Error, DecodeOptions, EncodeOptions, Quantization, encode, place_on_prediction_lines,
};
use octowrap_mesh::Hierarchy;

/// A hierarchy of every kind the seed selects: lattice or not, edited heavily or lightly, placed
/// on its prediction lines or not.
fn hierarchy(seed: u64, opts: &EncodeOptions) -> Hierarchy {
    let edits =
        if seed % 3 == 0 { Edits { join: 0.3, split: 0.2, create: 0.2, ..Edits::default() } } else { Edits::default() };
    let mut h = cube_hierarchy(3 + (seed % 2) as usize, edits, seed);
    if seed % 4 == 1 {
        h = without_lattice(h);
    }
    if seed % 5 == 2 && !matches!(opts.quantization, Quantization::Exact) {
        place_on_prediction_lines(&mut h, opts).expect("placement");
    }
    h
}

fn options(version: u16, quantization: Quantization) -> EncodeOptions {
    let mut o = EncodeOptions::with_quantization(quantization);
    o.version = version;
    o
}

/// The error class of spec §7.3 of a reference decoder error.
fn class(e: &Error) -> &'static str {
    match e {
        Error::BadMagic { .. } => "not-mrq",
        Error::UnsupportedVersion { .. } => "unsupported-version",
        Error::Truncated { .. } => "truncated",
        Error::ChecksumMismatch { .. } => "checksum",
        Error::LimitExceeded { .. } => "limit",
        Error::Invalid { .. } | Error::Zstd { .. } => "invalid",
        _ => "other",
    }
}

#[test]
fn encoder_outputs_decode_alike() {
    let mut n = 0;
    for seed in 1..=12u64 {
        for version in [2u16, 3, 4] {
            for q in [Quantization::Bits(10), Quantization::Bits(24), Quantization::Exact] {
                let opts = options(version, q);
                let bytes = encode(&hierarchy(seed, &opts), &opts).expect("encode");
                let name = format!("seed {seed}, version {version}, {q:?}");
                let ours = file::decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
                compare::compare_with_reference(Path::new(&name), &bytes, &ours);
                n += 1;
            }
        }
        let soup = Hierarchy::single(polygon_mesh(40, 30, seed));
        let bytes = encode(&soup, &options(3, Quantization::Bits(12))).expect("encode");
        let ours = file::decode(&bytes).expect("a polygon soup");
        compare::compare_with_reference(Path::new("soup"), &bytes, &ours);
    }
    assert_eq!(n, 108);
}

#[test]
fn mutants_are_accepted_and_rejected_alike() {
    let mut rng = Rng::new(17);
    let (mut accepted, mut rejected) = (0, 0);
    for seed in 1..=8u64 {
        for version in [2u16, 3, 4] {
            let q = if seed % 3 == 0 { Quantization::Exact } else { Quantization::Bits(12) };
            let opts = options(version, q);
            let bytes = encode(&hierarchy(seed, &opts), &opts).expect("encode");
            let good = payloads(&bytes).expect("payloads");
            for _ in 0..150 {
                // One to three bytes of one level's payload changed, the file resealed; now and
                // then a preamble byte instead, its checksum fixed.
                let mut p = good.clone();
                let k = rng.below(p.len());
                for _ in 0..=rng.below(3) {
                    let i = rng.below(p[k].len());
                    p[k][i] = match rng.below(3) {
                        0 => p[k][i] ^ (1 << rng.below(8)),
                        1 => p[k][i].wrapping_add(1),
                        _ => p[k][i].wrapping_sub(1),
                    };
                }
                let mut mutant = reseal(&bytes, &p, None).expect("reseal");
                if rng.chance(0.25) {
                    mutant[rng.below(240)] ^= 1 << rng.below(8);
                    fix_preamble_checksum(&mut mutant);
                }
                let name = format!("seed {seed}, version {version}, a mutant of level {k}");
                match (file::decode(&mutant), octowrap_format::decode(&mutant[..], &DecodeOptions::default())) {
                    (Ok(ours), Ok(_)) => {
                        compare::compare_with_reference(Path::new(&name), &mutant, &ours);
                        accepted += 1;
                    }
                    (Err(ours), Err(theirs)) => {
                        assert_eq!(ours.class.name(), class(&theirs), "{name}: {ours} against {theirs}");
                        rejected += 1;
                    }
                    (ours, theirs) => panic!("{name}: {:?} against {:?}", ours.err(), theirs.err()),
                }
            }
        }
    }
    // Both outcomes are common: the comparison covers validity rules and decoding alike.
    assert!(accepted > 300 && rejected > 300, "{accepted} accepted, {rejected} rejected");
}
