//! Validates a mesh once and prints the time: the profiling driver for the checks
//! (`valgrind --tool=callgrind target/release/examples/validate_timing`).
//!
//! `cargo run --release -p octowrap-bench --example validate_timing -- [NU NV | MESH-FILE]`: a closed
//! triangulated torus of `2 * NU * NV` faces (default 1000 500), or any mesh the io crate reads;
//! `RUNS=N` times it N times and prints the best (the bench takes the best of 7).

#![allow(clippy::print_stdout, clippy::print_stderr)] // A command-line tool: printing is its job.

use octowrap_mesh::Mesh;
use octowrap_validate::{ValidateOptions, validate_mesh};

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
    // Several runs, as the bench does (best of them): the first also pays for the fresh pages
    // the allocator maps; later runs reuse them.
    let runs: usize = std::env::var("RUNS").ok().and_then(|r| r.parse().ok()).unwrap_or(1);
    let (mut secs, mut cpu) = (f64::INFINITY, f64::INFINITY);
    let mut report = None;
    for _ in 0..runs.max(1) {
        let (t, c) = (std::time::Instant::now(), cpu_time::ThreadTime::now());
        report = Some(validate_mesh(mesh, &ValidateOptions::default()));
        secs = secs.min(t.elapsed().as_secs_f64());
        cpu = cpu.min(c.elapsed().as_secs_f64());
    }
    let report = report.expect("at least one run");
    println!(
        "{} faces: {:.1} ms, {:.1} M faces/s ({:.1} ms of thread CPU time); watertight {}, oriented {}, genus {:?}, {} boundary loops",
        mesh.faces.len(),
        secs * 1e3,
        mesh.faces.len() as f64 / secs / 1e6,
        cpu * 1e3,
        report.properties.watertight,
        report.properties.oriented,
        report.components.first().and_then(|c| c.genus),
        report.counts.boundary_loops
    );
}
