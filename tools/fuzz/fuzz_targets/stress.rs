//! Not a libFuzzer target: a plain loop of random payload mutations (like the `hostile` tests)
//! built with this crate's overflow checks, for machines without cargo-fuzz.
//! `cargo run --release --bin stress -- [ITERATIONS]`
#![allow(clippy::print_stdout)]

use octowrap_format::fuzzing::{payloads, reseal};
use octowrap_format::synthetic::{Edits, Rng, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::{DecodeOptions, EncodeOptions, Limits, Quantization, decode, encode};
use octowrap_mesh::Hierarchy;

fn placed(mut h: Hierarchy, q: &EncodeOptions) -> Hierarchy {
    octowrap_format::place_on_prediction_lines(&mut h, q).unwrap();
    h
}

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(20000);
    let q = EncodeOptions::with_quantization(Quantization::Bits(12));
    let files = [
        encode(&cube_hierarchy(3, Edits::default(), 1), &q).unwrap(),
        encode(&without_lattice(cube_hierarchy(3, Edits::default(), 2)), &q).unwrap(),
        encode(&Hierarchy::single(polygon_mesh(30, 20, 3)), &q).unwrap(),
        encode(&cube_hierarchy(3, Edits::default(), 4), &EncodeOptions::with_quantization(Quantization::Exact)).unwrap(),
        // Line geometry (spec §6.6), lattice and generic.
        encode(&placed(cube_hierarchy(3, Edits::default(), 5), &q), &q).unwrap(),
        encode(&placed(without_lattice(cube_hierarchy(3, Edits::default(), 6)), &q), &q).unwrap(),
    ];
    let mut opts = DecodeOptions::default();
    opts.limits = Limits::strict();
    let mut rng = Rng::new(42);
    let mut errors = 0;
    for i in 0..n {
        let bytes = &files[i % files.len()];
        let mut p = payloads(bytes).unwrap();
        let k = rng.below(p.len());
        for _ in 0..=rng.below(4) {
            let len = p[k].len();
            match rng.below(4) {
                0 => p[k][rng.below(len)] ^= 1 << rng.below(8),
                1 => p[k][rng.below(len)] = rng.next_u64() as u8,
                2 => p[k][rng.below(len.min(80))] = rng.next_u64() as u8, // header and stream table
                _ => p[k].truncate(rng.below(len)),
            }
            if p[k].is_empty() {
                break;
            }
        }
        let file = reseal(bytes, &p, None).unwrap();
        if decode(&file[..], &opts).is_err() {
            errors += 1;
        }
    }
    println!("{n} mutated files, {errors} rejected, no panic");
}
