//! Times the large case of `tools/bench`: the dragon resampled to 4.3 M points (built by the bench, cached
//! as raw `f64` triples in a file) reconstructed to level 10. For profiling:
//! `cargo run --release -p octowrap-bench --example recon_big -- /tmp/pts.bin`, where the file is
//! written on first use from `../shared/data/stanford-dragon/dragon_vrip.ply.gz`. A path ending
//! in `.ply` or `.ply.gz` is read as a point cloud instead (the bunny, the dragon's own points).
//! Prints a checksum of every level's positions and faces, and one of all levels.
#![allow(clippy::print_stdout, clippy::print_stderr)]

use std::time::Instant;

use octowrap_geom::DVec3;
use octowrap_recon::{MaxLevel, ReconOptions, reconstruct_with_progress};

#[path = "../src/stages.rs"]
mod stages;

/// Area-uniform samples of the dragon with Gaussian noise of `sigma` (the bench's generator).
fn resample(mesh: &octowrap_mesh::Mesh, n: usize, sigma: f64) -> Vec<DVec3> {
    let sampler = octowrap_mesh::shapes::SurfaceSampler::new(mesh);
    (0..n as u64).map(|i| sampler.point(i, sigma)).collect()
}

/// Called at the start of every stage: `valgrind --tool=callgrind --dump-before='*stage_marker*'`
/// then writes one profile part per stage (all threads' instructions since the previous one).
#[inline(never)]
fn stage_marker(level: u32, stage: octowrap_recon::Stage) {
    std::hint::black_box((level, stage));
}

fn main() {
    let mut args = std::env::args().skip(1);
    let cache = args.next().unwrap_or_else(|| "/tmp/octowrap-big.bin".into());
    let level: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(10);
    let path = std::path::Path::new(&cache);
    let ply = |ext: &str| path.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext));
    let pts: Vec<DVec3> = if ply("ply") || (ply("gz") && cache.to_ascii_lowercase().ends_with(".ply.gz")) {
        let m = octowrap_io::read_path(cache.as_ref(), &octowrap_io::ReadOptions::default()).expect("points");
        m.vertices.positions
    } else if let Ok(bytes) = std::fs::read(&cache) {
        bytes
            .chunks_exact(24)
            .map(|c| {
                let f = |i: usize| f64::from_le_bytes(c[8 * i..8 * i + 8].try_into().unwrap_or_default());
                DVec3::new(f(0), f(1), f(2))
            })
            .collect()
    } else {
        let path = octowrap_testdata::data_root().join("stanford-dragon/dragon_vrip.ply.gz");
        let m = octowrap_io::read_path(&path, &octowrap_io::ReadOptions::default()).expect("dragon");
        let diag = m.vertices.bounds().diagonal();
        // A cache named `*raw*` holds the dragon's own vertices (a smaller case for profiling).
        let pts =
            if cache.contains("raw") { m.vertices.positions.clone() } else { resample(&m, 4_300_000, 2e-4 * diag) };
        let bytes: Vec<u8> = pts.iter().flat_map(|p| [p.x, p.y, p.z]).flat_map(f64::to_le_bytes).collect();
        let _ = std::fs::write(&cache, bytes);
        pts
    };
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(level);
    // OCTOWRAP_FIT_PASSES=N overrides the fit's passes (0: off), for profiling.
    if let Some(n) = std::env::var("OCTOWRAP_FIT_PASSES").ok().and_then(|s| s.parse().ok()) {
        o.fit_passes = n;
    }
    // OCTOWRAP_QUADRIC=0 or 1 sets the wrapped levels' mapping (plane or quadric), for profiling.
    if let Some(q) = std::env::var("OCTOWRAP_QUADRIC").ok().and_then(|s| s.parse::<u8>().ok()) {
        o.quadric_mapping = q != 0;
    }
    let t = Instant::now();
    // OCTOWRAP_HWM=1: the peak resident memory so far at the start of every stage.
    let hwm = std::env::var_os("OCTOWRAP_HWM").is_some();
    let status = |field: &str| -> String {
        std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| s.lines().find(|l| l.starts_with(field)).map(str::to_owned))
            .unwrap_or_default()
    };
    let r = reconstruct_with_progress(&pts, &o, &mut |p| {
        stage_marker(p.level, p.stage);
        if hwm {
            eprintln!("{:?} {} {}", p.stage, p.level, status("VmHWM:"));
        }
    })
    .expect("reconstructs");
    if hwm {
        eprintln!("end {} {}", status("VmHWM:"), status("VmRSS:"));
    }
    let secs = t.elapsed().as_secs_f64();
    print!("{}", stages::stage_table(&r));
    let voxels: Vec<String> = r.levels.iter().map(|l| l.voxels.to_string()).collect();
    println!("voxels per level: {}", voxels.join(" "));
    // A checksum of the output, to compare runs.
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut per_level = Vec::new();
    for l in &r.hierarchy.levels {
        let mut own = 0xcbf2_9ce4_8422_2325u64;
        for p in &l.mesh.vertices.positions {
            for v in [p.x, p.y, p.z] {
                h = (h ^ v.to_bits()).wrapping_mul(0x100_0000_01b3);
                own = (own ^ v.to_bits()).wrapping_mul(0x100_0000_01b3);
            }
        }
        for f in l.mesh.faces.iter() {
            for &v in f {
                h = (h ^ u64::from(v)).wrapping_mul(0x100_0000_01b3);
                own = (own ^ u64::from(v)).wrapping_mul(0x100_0000_01b3);
            }
        }
        per_level.push(format!("{:04x}", own & 0xffff));
    }
    println!("levels {}", per_level.join(" "));
    println!("total {secs:.3} s, checksum {h:016x}");
}
