//! Decodes MRQ files many times (for profiling) and prints a digest of each decoded hierarchy (for
//! checking that a decoder change keeps the output):
//! `cargo run --release -p octowrap-bench --example decode_loop -- [-n N] FILE.mrq...`.
#![allow(clippy::print_stdout)]

use std::hash::{Hash, Hasher};

use octowrap_mesh::Hierarchy;

/// A hash of everything a decoded hierarchy holds (positions bit for bit).
fn digest(h: &Hierarchy) -> u64 {
    let mut s = std::collections::hash_map::DefaultHasher::new();
    for l in &h.levels {
        for p in &l.mesh.vertices.positions {
            p.to_array().map(f64::to_bits).hash(&mut s);
        }
        l.mesh.faces.offsets().hash(&mut s);
        l.mesh.faces.indices().hash(&mut s);
        format!("{:?}", l.origins).hash(&mut s);
        format!("{:?}", l.lattice).hash(&mut s);
    }
    s.finish()
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut n = 50;
    let mut want_digest = false;
    loop {
        match args.first().map(String::as_str) {
            Some("-n") => {
                n = args.get(1).and_then(|s| s.parse().ok()).expect("-n N");
                args.drain(..2);
            }
            Some("-d") => {
                want_digest = true;
                args.remove(0);
            }
            _ => break,
        }
    }
    for path in &args {
        let bytes = std::fs::read(path).expect("reads");
        let opts = octowrap_format::DecodeOptions::default();
        if want_digest {
            let first = octowrap_format::decode(&bytes[..], &opts).expect("decodes");
            println!("{path}: digest {:016x}", digest(&first.hierarchy));
        }
        if n == 0 {
            continue;
        }
        let t = std::time::Instant::now();
        let mut vertices = 0;
        for _ in 0..n {
            let f = octowrap_format::decode(&bytes[..], &opts).expect("decodes");
            vertices += f.hierarchy.levels.iter().map(|l| l.mesh.vertex_count()).sum::<usize>();
        }
        let s = t.elapsed().as_secs_f64();
        println!("{path}: {:.1} M vertices/s", vertices as f64 / s / 1e6);
    }
}
