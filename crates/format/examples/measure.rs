//! Re-encodes MRQ files at 12 bits and prints per-level sizes and decode timing:
//! `cargo run --release -p octowrap-format --example measure -- FILE.mrq...`
#![allow(clippy::print_stdout)]

use std::time::Instant;

use octowrap_format::{DecodeOptions, EncodeOptions, Quantization, decode, encode_with_stats, read_path};

fn main() {
    for path in std::env::args().skip(1) {
        let mut h = read_path(path.as_ref(), &DecodeOptions::default()).expect("reads").hierarchy;
        let mut opts = EncodeOptions::with_quantization(Quantization::Bits(12));
        if let Some(v) = std::env::var("MEASURE_VERSION").ok().and_then(|v| v.parse().ok()) {
            opts.version = v;
        }
        if std::env::var_os("MEASURE_PLACE").is_some() {
            let t = Instant::now();
            let p = octowrap_format::place_on_prediction_lines(&mut h, &opts).expect("places");
            println!("placed on lines in {:.1} ms: {p:?}", t.elapsed().as_secs_f64() * 1e3);
        }
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
                "  level {k}: mode {} pred {} shift {} {:>7} vertices {:>7} faces  topo {:>6} B ({:.2} b/v)  geo {:>7} B ({:.2} b/v)",
                s.mode,
                s.predictor,
                s.line_shift,
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
            if p[2] & 2 != 0 {
                // Line geometry (spec §6.6): flags, parameters, other vertices' residuals.
                let nv = u32::from_le_bytes(p[4..8].try_into().unwrap()) as usize;
                let geo = &p[at - sizes[11]..at];
                let nf = nv.div_ceil(8);
                let lines: usize = geo[..nf].iter().map(|b| b.count_ones() as usize).sum();
                let params_end = nf + 1 + usize::from(geo[nf]) * lines;
                let z = |b: &[u8]| zstd::bulk::compress(b, 19).unwrap().len();
                println!(
                    "  finest level geometry: {lines} line vertices, {} others; flags {} B, parameters {} B, residuals {} B (zstd apart)",
                    nv - lines,
                    z(&geo[..nf]),
                    z(&geo[nf..params_end]),
                    z(&geo[params_end..])
                );
            }
        }
        if std::env::var_os("MEASURE_CREATED").is_some() {
            created_key_orders(&h);
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
        if p[2] & 2 != 0 {
            // Line geometry (spec §6.6): another layout; not measured here.
            out.push([f64::NAN; 3]);
            continue;
        }
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

/// Compressed size of the created faces' slot keys under z-major and Morton order (experiment).
#[allow(dead_code)]
pub fn created_key_orders(h: &octowrap_mesh::Hierarchy) {
    fn spread(x: u32) -> u64 {
        let mut v = u64::from(x) & 0x1f_ffff;
        v = (v | v << 32) & 0x1f_0000_0000_ffff;
        v = (v | v << 16) & 0x1f_0000_ff00_00ff;
        v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
        v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
        v = (v | v << 2) & 0x1249_2492_4924_9249;
        v
    }
    for (k, l) in h.levels.iter().enumerate().skip(1) {
        let Some(lat) = &l.lattice else { continue };
        let n = 1u64 << k;
        let mut zmaj = Vec::new();
        let mut mort = Vec::new();
        for (f, o) in l.origins.iter().enumerate() {
            if *o == octowrap_mesh::FaceOrigin::Created {
                let (v, d) = lat.face_slots[f];
                zmaj.push(((u64::from(v[2]) * n + u64::from(v[1])) * n + u64::from(v[0])) * 6 + u64::from(d));
                mort.push((spread(v[0]) | spread(v[1]) << 1 | spread(v[2]) << 2) * 6 + u64::from(d));
            }
        }
        let size = |mut keys: Vec<u64>| {
            keys.sort_unstable();
            let mut b = Vec::new();
            for (i, &x) in keys.iter().enumerate() {
                let mut g = if i == 0 { x } else { x - keys[i - 1] - 1 };
                while g >= 0x80 {
                    b.push((g as u8) | 0x80);
                    g >>= 7;
                }
                b.push(g as u8);
            }
            zstd::bulk::compress(&b, 19).unwrap().len()
        };
        let c = zmaj.len();
        println!("  level {k}: {c} created, z-major {} B, Morton {} B", size(zmaj), size(mort));
    }
}
