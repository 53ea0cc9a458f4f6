//! Re-encodes MRQ files at 12 bits and prints per-level sizes and decode timing:
//! `cargo run --release -p octowrap-format --example measure -- FILE.mrq...`
#![allow(clippy::print_stdout)]

use std::time::Instant;

use octowrap_format::{DecodeOptions, EncodeOptions, Quantization, decode, encode_with_stats, read_path};

fn main() {
    for path in std::env::args().skip(1) {
        let h = read_path(path.as_ref(), &DecodeOptions::default()).expect("reads").hierarchy;
        let opts = EncodeOptions::with_quantization(Quantization::Bits(12));
        let t = Instant::now();
        let (bytes, stats) = encode_with_stats(&h, &opts).expect("encodes");
        let enc = t.elapsed().as_secs_f64();
        let finest = h.levels.last().unwrap().mesh.vertex_count() as f64;
        println!(
            "{path}: {} bytes, {:.2} bits/finest vertex, encode {:.1} ms",
            bytes.len(),
            bytes.len() as f64 * 8.0 / finest,
            enc * 1e3
        );
        for (k, (s, l)) in stats.iter().zip(&h.levels).enumerate() {
            let v = l.mesh.vertex_count().max(1) as f64;
            println!(
                "  level {k}: mode {} {:>7} vertices {:>7} faces  topo {:>6} B ({:.2} b/v)  geo {:>7} B ({:.2} b/v)",
                s.mode,
                l.mesh.vertex_count(),
                l.mesh.faces.len(),
                s.topology,
                s.topology as f64 * 8.0 / v,
                s.geometry,
                s.geometry as f64 * 8.0 / v
            );
        }
        for (k, e) in residual_entropy(&bytes).iter().enumerate() {
            println!(
                "  level {k}: residual entropy x {:.2} y {:.2} z {:.2} bits (sum {:.2})",
                e[0],
                e[1],
                e[2],
                e[0] + e[1] + e[2]
            );
        }
        if let Some(dir) = std::env::var_os("MEASURE_SAVE") {
            let name = std::path::Path::new(&path).file_name().unwrap();
            std::fs::write(std::path::Path::new(&dir).join(name).with_extension("q12.mrq"), &bytes).unwrap();
        }
        if let Some(p) = octowrap_format::fuzzing::payloads(&bytes).and_then(|p| p.last().cloned()) {
            let names = [
                "masks", "depths", "rot", "created", "sizes", "corners", "extra", "splits", "exc", "choices", "raw",
                "geo",
            ];
            let sizes: Vec<usize> =
                (0..12).map(|i| u32::from_le_bytes(p[16 + 4 * i..20 + 4 * i].try_into().unwrap()) as usize).collect();
            let mut at = 64;
            let mut line = String::from("  finest level streams (raw -> zstd bytes):");
            for (i, &n) in sizes.iter().enumerate() {
                if n > 0 {
                    let z = zstd::bulk::compress(&p[at..at + n], 19).unwrap().len();
                    line += &[" ", names[i], "=", &n.to_string(), "->", &z.to_string()].concat();
                }
                at += n;
            }
            println!("{line}");
        }
        let all: usize = h.levels.iter().map(|l| l.mesh.vertex_count()).sum();
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let t = Instant::now();
            let f = decode(&bytes[..], &DecodeOptions::default()).expect("decodes");
            best = best.min(t.elapsed().as_secs_f64());
            assert_eq!(f.hierarchy.levels.len(), h.levels.len());
        }
        println!("  decode {:.2} ms, {:.1} M vertices/s", best * 1e3, all as f64 / best / 1e6);
    }
}

/// Order-0 entropy (bits per value) of each axis' residuals in each level's geometry stream.
#[allow(dead_code)]
pub fn residual_entropy(bytes: &[u8]) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for p in octowrap_format::fuzzing::payloads(bytes).expect("payloads") {
        let nv = u32::from_le_bytes(p[4..8].try_into().unwrap()) as usize;
        let sizes: Vec<usize> =
            (0..12).map(|i| u32::from_le_bytes(p[16 + 4 * i..20 + 4 * i].try_into().unwrap()) as usize).collect();
        let mut at = 64 + sizes[..11].iter().sum::<usize>();
        let mut e = [0.0; 3];
        for ax in &mut e {
            let planes = p[at] as usize;
            at += 1;
            let mut vals = vec![0u64; nv];
            for pl in 0..planes {
                for v in 0..nv {
                    vals[v] |= u64::from(p[at + pl * nv + v]) << (8 * pl);
                }
            }
            at += planes * nv;
            let mut counts = std::collections::BTreeMap::new();
            for v in vals {
                *counts.entry(v).or_insert(0usize) += 1;
            }
            *ax = counts
                .values()
                .map(|&c| {
                    let q = c as f64 / nv as f64;
                    -q * q.log2()
                })
                .sum::<f64>();
        }
        out.push(e);
    }
    out
}
