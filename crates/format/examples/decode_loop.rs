//! Decodes an MRQ file many times (for profiling): `decode_loop FILE.mrq [N]`.
#![allow(clippy::print_stdout)]

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next().expect("FILE.mrq");
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(50);
    let bytes = std::fs::read(path).expect("reads");
    let t = std::time::Instant::now();
    let mut vertices = 0;
    for _ in 0..n {
        let f = octowrap_format::decode(&bytes[..], &octowrap_format::DecodeOptions::default()).expect("decodes");
        vertices += f.hierarchy.levels.iter().map(|l| l.mesh.vertex_count()).sum::<usize>();
    }
    let s = t.elapsed().as_secs_f64();
    println!("{:.1} M vertices/s", vertices as f64 / s / 1e6);
}
