//! Writes a synthetic hierarchy (`octowrap_format::synthetic::cube_hierarchy`, placed on its
//! prediction lines) as a 12-bit MRQ file, for profiling the decoder on large inputs:
//! `cargo run --release -p octowrap-bench --example synthetic_mrq -- LEVELS OUT.mrq`.
#![allow(clippy::print_stdout)]

use octowrap_format::synthetic::{Edits, cube_hierarchy};
use octowrap_format::{EncodeOptions, Quantization, encode, place_on_prediction_lines};

fn main() {
    let mut args = std::env::args().skip(1);
    let levels: usize = args.next().and_then(|s| s.parse().ok()).expect("LEVELS");
    let out = args.next().expect("OUT.mrq");
    let t = std::time::Instant::now();
    let mut h = cube_hierarchy(levels, Edits::default(), 1);
    let opts = EncodeOptions::with_quantization(Quantization::Bits(12));
    place_on_prediction_lines(&mut h, &opts).expect("places");
    let bytes = encode(&h, &opts).expect("encodes");
    std::fs::write(&out, &bytes).expect("writes");
    let nv: usize = h.levels.iter().map(|l| l.mesh.vertex_count()).sum();
    println!("{out}: {} bytes, {nv} vertices in all levels, {:.1} s", bytes.len(), t.elapsed().as_secs_f64());
}
