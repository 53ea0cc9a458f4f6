//! Encodes the hierarchies of MRQ files again, many times (for profiling the encoder alone), on the
//! file's own grid, and prints the encoder's speed in vertices (all levels) per second on one thread
//! and whether the output equals the input file:
//! `cargo run --release -p octowrap-bench --example encode_loop -- [-n N] [-z ZSTD_LEVEL] [-o DIR] FILE.mrq...`
//! (`-o`: also writes each output to DIR under its input's name).
#![allow(clippy::print_stdout)]

use octowrap_format::{DecodeOptions, EncodeOptions, Quantization, decode, encode};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut n = 5;
    let mut zstd_level = None;
    let mut out_dir = None;
    loop {
        match args.first().map(String::as_str) {
            Some("-n") => n = args.get(1).and_then(|s| s.parse().ok()).expect("-n N"),
            Some("-z") => zstd_level = Some(args.get(1).and_then(|s| s.parse().ok()).expect("-z LEVEL")),
            Some("-o") => out_dir = Some(std::path::PathBuf::from(args.get(1).expect("-o DIR"))),
            _ => break,
        }
        args.drain(..2);
    }
    for path in &args {
        let bytes = std::fs::read(path).expect("reads");
        let file = decode(&bytes[..], &DecodeOptions::default()).expect("decodes");
        let quantization = file.info.grid.map_or(Quantization::Exact, |g| Quantization::Bits(g.bits));
        let mut opts = EncodeOptions::with_quantization(quantization);
        opts.metadata.source.clone_from(&file.info.metadata.source);
        opts.metadata.generator.clone_from(&file.info.metadata.generator);
        if let Some(z) = zstd_level {
            opts.zstd_level = z;
        }
        let vertices: usize = file.hierarchy.levels.iter().map(|l| l.mesh.vertex_count()).sum();
        let mut out = Vec::new();
        let t = std::time::Instant::now();
        for _ in 0..n.max(1) {
            out = encode(&file.hierarchy, &opts).expect("encodes");
        }
        let s = t.elapsed().as_secs_f64() / n.max(1) as f64;
        if let Some(dir) = &out_dir {
            let name = std::path::Path::new(path).file_name().expect("a file name");
            std::fs::write(dir.join(name), &out).expect("writes");
        }
        let again = decode(&out[..], &DecodeOptions::default()).expect("decodes its own output");
        let same = again
            .hierarchy
            .levels
            .iter()
            .zip(&file.hierarchy.levels)
            .all(|(a, b)| a.mesh.vertices.positions == b.mesh.vertices.positions && a.mesh.faces == b.mesh.faces);
        let finest = file.hierarchy.levels.last().map_or(1, |l| l.mesh.vertex_count()) as f64;
        println!(
            "{path}: {} -> {} bytes ({:.2} bits per finest vertex), {:.1} ms, {:.2} M vertices/s, same levels: {same}",
            bytes.len(),
            out.len(),
            out.len() as f64 * 8.0 / finest,
            s * 1e3,
            vertices as f64 / s / 1e6
        );
    }
}
