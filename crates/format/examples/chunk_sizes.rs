//! An MRQ file's hierarchy re-encoded as version 4 (unchunked) and version 5 (chunks, spec §11)
//! at each chunk shift given: total bytes, per level bytes and chunks, and a check that the
//! version 5 file decodes to the same levels.
//!
//! `cargo run --release -p octowrap-format --example chunk_sizes -- FILE.mrq [SHIFT...]`
#![allow(clippy::print_stdout, clippy::print_stderr)] // a measuring tool: its output is the figures
use octowrap_format::{DecodeOptions, EncodeOptions, Quantization, decode_bytes, encode_with_stats, read_path};
use octowrap_mesh::Level;

/// The level's faces as sorted lists of vertex positions (bit patterns), sorted.
fn face_set(l: &Level) -> Vec<Vec<[u64; 3]>> {
    let p = &l.mesh.vertices.positions;
    let mut out: Vec<Vec<[u64; 3]>> =
        l.mesh.faces.iter().map(|f| f.iter().map(|&v| p[v as usize].to_array().map(f64::to_bits)).collect()).collect();
    out.sort();
    out
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: chunk_sizes FILE.mrq [SHIFT...]");
        std::process::exit(2);
    };
    let file = read_path(path.as_ref(), &DecodeOptions::default()).expect("read");
    let bits = file.info.grid.as_ref().map_or(16, |g| g.bits);
    let mut opts = EncodeOptions::with_quantization(Quantization::Bits(bits));
    opts.version = 4;
    let (v4, stats4) = encode_with_stats(&file.hierarchy, &opts).expect("encode");
    let reference = decode_bytes(&v4, &DecodeOptions::default()).expect("decode v4").hierarchy;
    println!("version 4: {} bytes", v4.len());
    opts.version = 5;
    for shift in args[1..].iter().map(|s| s.parse::<u32>().expect("shift")) {
        opts.chunk_shift = shift;
        let t = std::time::Instant::now();
        let (v5, stats5) = encode_with_stats(&file.hierarchy, &opts).expect("encode v5");
        let te = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let back = decode_bytes(&v5, &DecodeOptions::default()).expect("decode v5");
        let td = t.elapsed().as_secs_f64();
        let speed = |bytes: &[u8], threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
            let mut best = f64::INFINITY;
            for _ in 0..15 {
                let t = std::time::Instant::now();
                pool.install(|| decode_bytes(bytes, &DecodeOptions::default()).expect("decode"));
                best = best.min(t.elapsed().as_secs_f64());
            }
            best
        };
        let finest = back.hierarchy.levels.last().map_or(0, |l| l.mesh.vertices.len()) as f64 / 1e6;
        let (t4, t51, t52) = (speed(&v4, 1), speed(&v5, 1), speed(&v5, 2));
        println!(
            "  decode, whole file, best of 15: version 4 on 1 thread {:.1} ms; version 5 on 1 thread {:.1} ms, on 2 threads {:.1} ms ({:.2}x); finest-level M vertices/s: {:.2}, {:.2}, {:.2}",
            t4 * 1e3,
            t51 * 1e3,
            t52 * 1e3,
            t51 / t52,
            finest / t4,
            finest / t51,
            finest / t52
        );
        let chunks =
            octowrap_format::ChunkedMrq::open(&v5[..], &octowrap_format::Limits::default()).expect("open").chunks();
        println!(
            "shift {shift}: {} bytes ({:+.1} %), {} chunks, encode {te:.3} s, decode {td:.3} s",
            v5.len(),
            100.0 * (v5.len() as f64 / v4.len() as f64 - 1.0),
            chunks.len()
        );
        for (k, (a, b)) in stats4.iter().zip(&stats5).enumerate() {
            let n = chunks.iter().filter(|c| c.level as usize == k).count();
            let same = face_set(&reference.levels[k]) == face_set(&back.hierarchy.levels[k]);
            println!(
                "  level {k}: {n} chunks, {} bytes against {} ({:+.1} %), same faces: {same}",
                b.stored,
                a.stored,
                100.0 * (b.stored as f64 / a.stored.max(1) as f64 - 1.0)
            );
        }
    }
}
