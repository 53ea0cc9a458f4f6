//! Issue 4 figures: the MRQ codec. Bits per finest-level vertex for the whole file (all levels) at
//! 12-bit quantization, split into topology and geometry; encode time; decode speed on one core.
//! Hierarchies: synthetic ones (`octowrap_format::synthetic`), and the bunny (levels 0-6) and the
//! dragon (levels 0-7) reconstructed by `octowrap_recon::reconstruct` when the shared data is
//! present. `OCTOWRAP_DUMP_FINEST=DIR` also writes each finest level (decoded) as PLY for the Draco
//! script, and each whole hierarchy as an exact MRQ file.

use octowrap_format::synthetic::{Edits, cube_hierarchy, without_lattice};
use octowrap_format::{DecodeOptions, EncodeOptions, Quantization, decode, encode_with_stats};
use octowrap_mesh::Hierarchy;

use crate::util::{best_of, shared_data};

fn row(name: &str, h: &Hierarchy) {
    let opts = EncodeOptions::with_quantization(Quantization::Bits(12));
    let (enc_s, (bytes, stats)) = best_of(3, || encode_with_stats(h, &opts).expect("encodes"));
    let (dec_s, file) = best_of(5, || decode(&bytes[..], &DecodeOptions::default()).expect("decodes"));
    let finest = h.levels.last().map_or(0, |l| l.mesh.vertex_count()).max(1) as f64;
    let all_vertices: usize = file.hierarchy.levels.iter().map(|l| l.mesh.vertex_count()).sum();
    let topo: usize = stats.iter().map(|s| s.topology).sum();
    let geo: usize = stats.iter().map(|s| s.geometry).sum();
    let modes: String = stats.iter().map(|s| char::from(b'0' + s.mode)).collect();
    println!(
        "| {name} | {} | {:.0} | {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {modes} |",
        h.levels.len() - 1,
        finest,
        bytes.len(),
        bytes.len() as f64 * 8.0 / finest,
        topo as f64 * 8.0 / finest,
        geo as f64 * 8.0 / finest,
        enc_s * 1e3,
        all_vertices as f64 / dec_s / 1e6,
    );
    // The decoded finest level, for the Draco comparison at the end of the section.
    let tmp = std::env::temp_dir().join("octowrap-bench-format");
    if std::fs::create_dir_all(&tmp).is_ok() && name.contains("recon") {
        let path = tmp.join(format!("{}.ply", name.split(' ').next().unwrap_or("mesh")));
        let mesh = &file.hierarchy.levels.last().expect("levels").mesh;
        let _ = octowrap_io::write_path(&path, mesh, &octowrap_io::WriteOptions::default());
    }
    if let Some(dir) = std::env::var_os("OCTOWRAP_DUMP_FINEST") {
        let path = std::path::Path::new(&dir).join(format!("{}.ply", name.replace([' ', '/', ','], "_")));
        let exact = EncodeOptions::with_quantization(Quantization::Exact);
        let mrq = path.with_extension("mrq");
        if let Err(e) = octowrap_format::write_path(&mrq, h, &exact) {
            eprintln!("cannot write {}: {e}", mrq.display());
        }
        let mesh = &file.hierarchy.levels.last().expect("levels").mesh;
        if let Err(e) = octowrap_io::write_path(&path, mesh, &octowrap_io::WriteOptions::default()) {
            eprintln!("cannot write {}: {e}", path.display());
        }
    }
}

fn recon(name: &str, file: &std::path::Path, level: u32) -> Option<Hierarchy> {
    let cloud = match octowrap_io::read_path(file, &octowrap_io::ReadOptions::default()) {
        Ok(m) => m.vertices.positions,
        Err(e) => {
            eprintln!("{name}: cannot read {}: {e}", file.display());
            return None;
        }
    };
    let mut opts = octowrap_recon::ReconOptions::default();
    opts.max_level = octowrap_recon::MaxLevel::Level(level);
    match octowrap_recon::reconstruct(&cloud, &opts) {
        Ok(h) => Some(h),
        Err(e) => {
            eprintln!("{name}: reconstruction failed: {e}");
            None
        }
    }
}

/// Prints the format section.
pub fn report() {
    println!("## Format (issue 4): MRQ at 12-bit quantization");
    println!();
    println!("Bits per finest-level vertex for the whole file (every level). Topology and geometry are the");
    println!("level blocks' topology streams and geometry stream compressed apart (their sum is within a");
    println!("few bytes of the file). Decode: all levels, one core, M vertices (all levels) per second.");
    println!("Modes per level: 0 base, 1 generic refinement, 2 lattice refinement.");
    println!();
    println!(
        "| hierarchy | finest level | finest vertices | bytes | bits/vertex | topology | geometry | encode ms | decode Mv/s | modes |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    row("synthetic cube, lattice", &cube_hierarchy(8, Edits::default(), 1));
    row("synthetic cube, no lattice", &without_lattice(cube_hierarchy(8, Edits::default(), 1)));
    row("synthetic cube, pure subdivision", &cube_hierarchy(8, Edits::none(), 1));
    match shared_data() {
        Some(dir) => {
            for (name, rel, level) in [
                ("bunny", "stanford-bunny/reconstruction/bun_zipper.ply", 6),
                ("dragon", "stanford-dragon/dragon_vrip.ply.gz", 7),
            ] {
                if let Some(h) = recon(name, &dir.join(rel), level) {
                    row(&format!("{name} (recon)"), &h);
                }
            }
        }
        None => println!("(shared data absent: bunny and dragon skipped)"),
    }
    println!();
    draco();
}

/// Draco at 12 bits on the same decoded finest levels (triangulated), through
/// `tools/bench/draco_bits.py` and Python's DracoPy, when available.
fn draco() {
    let tmp = std::env::temp_dir().join("octowrap-bench-format");
    let meshes: Vec<_> = ["bunny.ply", "dragon.ply"].iter().map(|m| tmp.join(m)).filter(|p| p.is_file()).collect();
    if meshes.is_empty() {
        return;
    }
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("draco_bits.py");
    match std::process::Command::new("python3").arg(&script).args(&meshes).output() {
        Ok(out) if out.status.success() => {
            println!("Draco (DracoPy, 12-bit, compression level 10) on the same finest levels alone:");
            println!();
            for line in String::from_utf8_lossy(&out.stdout).lines() {
                println!("    {line}");
            }
        }
        _ => println!("Draco comparison skipped: `python3 -c 'import DracoPy'` fails here (pip install DracoPy)."),
    }
    println!();
}
