//! Structure-aware: the input's first bytes pick a seed file (a synthetic hierarchy; bit 3 of the
//! first byte: placed on its prediction lines, so that levels code line geometry) and a level; the
//! rest overwrites that level's decompressed payload, and the file is resealed (checksums fixed)
//! so that the mutation reaches the level decoder. Must never panic.
//!
//! The 16 seed files (the first byte's low four bits) are encoded once per process: encoding a
//! hierarchy costs far more than decoding one, and it does not depend on the fuzz bytes.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use octowrap_format::fuzzing::{payloads, reseal};
use octowrap_format::synthetic::{Edits, cube_hierarchy, without_lattice};
use octowrap_format::{DecodeOptions, EncodeOptions, Limits, Quantization, decode, encode};

/// A seed file and its levels' decompressed payloads.
type Seed = Option<(Vec<u8>, Vec<Vec<u8>>)>;

/// The seed file for the low four bits of the first byte.
fn seed(which: u8) -> Seed {
    let h = cube_hierarchy(3, Edits::default(), u64::from(which % 4));
    let mut h = if which & 4 != 0 { without_lattice(h) } else { h };
    let q12 = EncodeOptions::with_quantization(Quantization::Bits(12));
    if which & 8 != 0 {
        // Line geometry (spec §6.6): vertices placed on their prediction lines.
        octowrap_format::place_on_prediction_lines(&mut h, &q12).ok()?;
    }
    let bytes = encode(&h, &q12).ok()?;
    let p = payloads(&bytes)?;
    Some((bytes, p))
}

fn seeds() -> &'static [Seed] {
    static SEEDS: OnceLock<Vec<Seed>> = OnceLock::new();
    SEEDS.get_or_init(|| (0..16).map(seed).collect())
}

fuzz_target!(|data: &[u8]| {
    let [which, level, rest @ ..] = data else { return };
    let Some((bytes, p)) = &seeds()[usize::from(which & 15)] else { return };
    let mut p = p.clone();
    let k = usize::from(*level) % p.len();
    // XOR the fuzz bytes over the payload, keeping its length unless the input is longer.
    for (i, b) in rest.iter().enumerate() {
        if i < p[k].len() {
            p[k][i] ^= b;
        } else {
            p[k].push(*b);
        }
    }
    let Some(file) = reseal(bytes, &p, None) else { return };
    let mut opts = DecodeOptions::default();
    opts.limits = Limits::strict();
    let _ = decode(&file[..], &opts);
});
