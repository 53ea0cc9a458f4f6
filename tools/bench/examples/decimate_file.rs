//! Decimates one mesh file to a ratio and prints the report as JSON (a profiling aid):
//! `cargo run --release -p octowrap-bench --example decimate_file -- MESH RATIO`.
#![allow(clippy::print_stdout)]

use std::path::Path;
use std::time::Instant;

use octowrap_decimate::{DecimateOptions, decimate_with_progress};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(path), Some(ratio)) = (args.get(1), args.get(2).and_then(|r| r.parse::<f64>().ok())) else {
        println!("usage: decimate_file MESH RATIO");
        return;
    };
    let mesh = octowrap_io::read_path(Path::new(path), &octowrap_io::ReadOptions::default()).expect("readable mesh");
    let target = (mesh.faces.len() as f64 * ratio).round() as usize;
    let t = Instant::now();
    let mut passes = Vec::new();
    let mut opts = DecimateOptions::target_faces(target);
    // The measurement is timed on its own below.
    opts.measure = false;
    let out = decimate_with_progress(&mesh, &opts, &mut |n| {
        passes.push((n, t.elapsed().as_secs_f64()));
    })
    .expect("decimates");
    println!("{:.3} s", t.elapsed().as_secs_f64());
    println!("{passes:?}");
    let t = Instant::now();
    let c = octowrap_decimate::metrics::certified_hausdorff(&mesh, &out.mesh);
    println!("certified Hausdorff {c:?} in {:.3} s", t.elapsed().as_secs_f64());
    println!("{}", serde_json::to_string_pretty(&out.report).unwrap_or_default());
}
