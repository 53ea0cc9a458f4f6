//! Validates a mesh once and prints the time: the profiling driver for the checks
//! (`valgrind --tool=callgrind target/release/examples/timing`).
//!
//! `cargo run --release -p octowrap-validate --example timing -- [NU NV | MESH-FILE]`: a closed
//! triangulated torus of `2 * NU * NV` faces (default 1000 500), or any mesh the io crate reads.

#![allow(clippy::print_stdout, clippy::print_stderr)] // A command-line tool: printing is its job.

use octowrap_mesh::Mesh;
use octowrap_validate::{Options, validate_mesh};

fn main() {
    if let Some(path) = std::env::args().nth(1).filter(|a| a.parse::<u32>().is_err()) {
        let mesh = match octowrap_io::read_path(std::path::Path::new(&path), &octowrap_io::ReadOptions::default()) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(2);
            }
        };
        return time(&mesh);
    }
    let args: Vec<u32> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (nu, nv) = (args.first().copied().unwrap_or(1000), args.get(1).copied().unwrap_or(500));
    let mesh = octowrap_mesh::shapes::torus(nu, nv, 2.0, 0.7);
    time(&mesh);
}

fn time(mesh: &Mesh) {
    let t = std::time::Instant::now();
    let report = validate_mesh(mesh, &Options::default());
    let secs = t.elapsed().as_secs_f64();
    println!(
        "{} faces: {:.1} ms, {:.1} M faces/s; watertight {}, oriented {}, genus {:?}, {} boundary loops",
        mesh.faces.len(),
        secs * 1e3,
        mesh.faces.len() as f64 / secs / 1e6,
        report.properties.watertight,
        report.properties.oriented,
        report.components.first().and_then(|c| c.genus),
        report.counts.boundary_loops
    );
}
