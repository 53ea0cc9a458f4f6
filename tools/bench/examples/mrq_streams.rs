//! Where the bits of an MRQ file go: per level and per stream (spec §4.2), the stream's raw bytes,
//! its size compressed alone with zstd (level 19), and the geometry stream's parts (line flags,
//! line parameters, residuals; byte-plane files of versions 2 and 3) with the order-0 entropy of
//! their values, in bits per finest vertex:
//! `cargo run --release -p octowrap-bench --example mrq_streams -- FILE.mrq...`.
#![allow(clippy::print_stdout)]

use std::collections::BTreeMap;
use std::fmt::Write;

/// Streams of spec §4.2, abbreviated.
const NAMES: [&str; 12] = [
    "masks",
    "depths",
    "rotations",
    "created",
    "sizes",
    "corners",
    "extra",
    "splits",
    "exceptions",
    "choices",
    "raw",
    "geometry",
];

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"))
}

fn u64_at(b: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(b[o..o + 8].try_into().expect("8 bytes"))
}

fn zstd_bits(b: &[u8]) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    zstd::bulk::compress(b, 19).expect("compresses").len() as f64 * 8.0
}

/// Order-0 entropy of `values`, in bits (the whole sequence).
fn entropy_bits(values: &[u64]) -> f64 {
    let mut counts: BTreeMap<u64, usize> = BTreeMap::new();
    for &v in values {
        *counts.entry(v).or_default() += 1;
    }
    let n = values.len() as f64;
    counts.values().map(|&c| -(c as f64) * (c as f64 / n).log2()).sum()
}

/// Reads a byte-plane block (spec §1.5) of `n` values.
fn planes(b: &[u8], at: &mut usize, n: usize) -> (Vec<u64>, usize) {
    let start = *at;
    let p = usize::from(b[*at]);
    *at += 1;
    let mut v = vec![0u64; n];
    for plane in 0..p {
        for (i, x) in v.iter_mut().enumerate() {
            *x |= u64::from(b[*at + plane * n + i]) << (8 * plane);
        }
    }
    *at += p * n;
    (v, *at - start)
}

fn main() {
    for path in std::env::args().skip(1) {
        let file = std::fs::read(&path).expect("reads");
        let levels = u32_at(&file, 16) as usize;
        let version = u16::from_le_bytes([file[8], file[9]]);
        let mut blocks = Vec::new();
        for k in 0..levels {
            let e = 112 + 48 * k;
            let (off, size) = (u64_at(&file, e) as usize, u64_at(&file, e + 8) as usize);
            blocks.push((size, zstd::decode_all(&file[off..off + size]).expect("zstd")));
        }
        let finest = f64::from(u32_at(&blocks[levels - 1].1, 4));
        println!(
            "{path}: version {version}, {} bytes, {:.2} bits per finest vertex",
            file.len(),
            file.len() as f64 * 8.0 / finest
        );
        println!(
            "(bits per finest vertex; `z` each stream compressed alone at zstd 19, `H0` order-0 entropy of the values)"
        );
        let mut totals = [0.0f64; 12];
        let mut geo_parts = [0.0f64; 6];
        for (k, (stored, block)) in blocks.iter().enumerate() {
            let nv = u32_at(block, 4) as usize;
            let mut at = 64;
            let mut line = format!(
                "L{k} mode {} pred {} nv {nv} stored {:.3}:",
                block[0],
                block[2],
                *stored as f64 * 8.0 / finest
            );
            let mut geo = &block[0..0];
            for (i, name) in NAMES.iter().enumerate() {
                let n = u32_at(block, 16 + 4 * i) as usize;
                let bytes = &block[at..at + n];
                at += n;
                if n == 0 {
                    continue;
                }
                let z = zstd_bits(bytes) / finest;
                totals[i] += z;
                let _ = write!(line, " {name} {n}B z{z:.3}");
                if i == 11 {
                    geo = bytes;
                }
            }
            println!("{line}");
            if version <= 3 && block[0] != 0 && block[2] & 2 != 0 && !geo.is_empty() {
                let mut g = 0;
                let flags = &geo[..nv.div_ceil(8)];
                g += flags.len();
                let nl: usize = flags.iter().map(|b| b.count_ones() as usize).sum();
                let (params, pb) = planes(geo, &mut g, nl);
                let mut res = Vec::new();
                let mut rb = 0;
                for _ in 0..3 {
                    let (r, b) = planes(geo, &mut g, nv - nl);
                    rb += b;
                    res.extend(r);
                }
                let parts = [
                    zstd_bits(flags) / finest,
                    zstd_bits(&geo[flags.len()..flags.len() + pb]) / finest,
                    entropy_bits(&params) / finest,
                    zstd_bits(&geo[flags.len() + pb..flags.len() + pb + rb]) / finest,
                    entropy_bits(&res) / finest,
                    nl as f64,
                ];
                for (t, p) in geo_parts.iter_mut().zip(parts) {
                    *t += p;
                }
                println!(
                    "   geometry: {nl} line vertices of {nv}; flags z{:.3}, params z{:.3} H0 {:.3}, residuals of {} z{:.3} H0 {:.3}",
                    parts[0],
                    parts[1],
                    parts[2],
                    nv - nl,
                    parts[3],
                    parts[4]
                );
            }
        }
        let mut line = String::from("total, streams alone:");
        for (i, name) in NAMES.iter().enumerate() {
            if totals[i] > 0.0 {
                let _ = write!(line, " {name} {:.3}", totals[i]);
            }
        }
        println!("{line}");
        println!(
            "geometry parts: flags {:.3}, params z {:.3} (H0 {:.3}), residuals z {:.3} (H0 {:.3})",
            geo_parts[0], geo_parts[1], geo_parts[2], geo_parts[3], geo_parts[4]
        );
    }
}
