//! MRQ without accuracy loss: the levels `octowrap reconstruct -o X.mrq` writes (every refined
//! vertex with a decoder line computed on it inside the reconstruction,
//! `ReconOptions::decoder_lines`) against the unconstrained reconstruction written with
//! `--keep-positions`, both encoded on the default grid (64 steps per finest voxel) and decoded.
//! Per level: points-to-mesh RMS (fraction of the points' bounding-box diagonal) and
//! self-intersecting face pairs; per file: bits per finest vertex (also at 12-bit quantization);
//! the reconstruction's time with and without lines; and the time of writing the MRQ against a
//! PLY for the 4.3 M-point case.

use std::time::Instant;

use octowrap_format::{DecodeOptions, EncodeOptions, Quantization, decode_bytes, encode};
use octowrap_geom::{Aabb, DVec3};
use octowrap_mesh::Hierarchy;
use octowrap_recon::{DecoderGrid, MaxLevel, ReconOptions, Reconstruction};
use octowrap_validate::{ValidateOptions, validate_mesh};

use crate::util::{headline, points_to_mesh_rms, shared_data};

/// The reconstruction with `lines` (or free), timed.
fn reconstruct(points: &[DVec3], level: MaxLevel, lines: Option<DecoderGrid>) -> (f64, Reconstruction) {
    let mut opts = ReconOptions::default();
    opts.max_level = level;
    opts.decoder_lines = lines;
    let t = Instant::now();
    let r = octowrap_recon::reconstruct_with_progress(points, &opts, &mut |_| {}).expect("reconstructs");
    (t.elapsed().as_secs_f64(), r)
}

/// The file's bytes and the hierarchy it decodes to, on grid `q`.
fn round_trip(h: &Hierarchy, q: Quantization) -> (usize, Hierarchy) {
    let bytes = encode(h, &EncodeOptions::with_quantization(q)).expect("encodes");
    let decoded = decode_bytes(&bytes, &DecodeOptions::default()).expect("decodes").hierarchy;
    (bytes.len(), decoded)
}

fn bits_per_finest(bytes: usize, h: &Hierarchy) -> f64 {
    bytes as f64 * 8.0 / h.levels.last().map_or(1, |l| l.mesh.vertex_count()).max(1) as f64
}

fn self_intersections(h: &Hierarchy, k: usize) -> usize {
    let mut o = ValidateOptions::default();
    o.self_intersections = true;
    validate_mesh(&h.levels[k].mesh, &o).counts.self_intersections.unwrap_or(0)
}

/// One scan's table and headlines; returns the worst RMS change (percent) over its levels.
fn model(name: &str, points: &[DVec3], level: MaxLevel, timed: bool) {
    let diag = Aabb::from_points(points).diagonal();
    let (free_s, free) = reconstruct(points, level, None);
    let (line_s, lines) = reconstruct(points, level, Some(DecoderGrid::Finest));
    let grid = lines.line_grid.expect("a grid");
    let (free_bytes, free_dec) = round_trip(&free.hierarchy, grid.quantization());
    let (line_bytes, line_dec) = round_trip(&lines.hierarchy, grid.quantization());
    let (_, l12) = reconstruct(points, level, Some(DecoderGrid::Bits(12)));
    let (l12_bytes, l12_dec) = round_trip(&l12.hierarchy, Quantization::Bits(12));
    let (f12_bytes, _) = round_trip(&free.hierarchy, Quantization::Bits(12));
    let finest = line_dec.levels.len() - 1;
    outln!("### {name}: {} points, levels 0-{finest}, default grid {} bits", points.len(), grid.bits());
    outln!();
    outln!(
        "| level | vertices | on lines | RMS free (--keep-positions) | RMS on lines (default) | change | RMS on lines, 12 bits | self-intersections free | on lines |"
    );
    outln!("|---|---|---|---|---|---|---|---|---|");
    let mut worst: f64 = f64::NEG_INFINITY;
    let mut extra_si = 0i64;
    for k in 1..=finest {
        let rms = |h: &Hierarchy| points_to_mesh_rms(points, &h.levels[k].mesh) / diag;
        let (a, b, c) = (rms(&free_dec), rms(&line_dec), rms(&l12_dec));
        let change = (b / a - 1.0) * 100.0;
        worst = worst.max(change);
        let (sa, sb) = (self_intersections(&free_dec, k), self_intersections(&line_dec, k));
        extra_si += sb as i64 - sa as i64;
        outln!(
            "| {k} | {} | {} | {a:.6} | {b:.6} | {change:+.1} % | {c:.6} | {sa} | {sb} |",
            line_dec.levels[k].mesh.vertex_count(),
            lines.levels[k].on_lines,
        );
    }
    outln!();
    let (bf, bl) = (bits_per_finest(free_bytes, &free_dec), bits_per_finest(line_bytes, &line_dec));
    let (bf12, bl12) = (bits_per_finest(f12_bytes, &free_dec), bits_per_finest(l12_bytes, &l12_dec));
    outln!(
        "Bits per finest vertex, all levels: on lines {bl:.2} (free {bf:.2}) on the default grid; at 12 bits {bl12:.2} (free {bf12:.2}). \
         Reconstruction {line_s:.3} s on lines, {free_s:.3} s free ({:+.1} %).",
        (line_s / free_s - 1.0) * 100.0
    );
    outln!();
    headline(
        format!("{name}: worst per-level points-to-mesh RMS change, MRQ on lines vs --keep-positions"),
        format!("{worst:+.1} %"),
        "≤ +5 %",
        Some(worst <= 5.0),
    );
    headline(
        format!("{name}: self-intersecting pairs on lines minus free, all levels"),
        format!("{extra_si:+}"),
        "≤ 0",
        Some(extra_si <= 0),
    );
    if timed {
        headline(
            format!("{name}: bits per finest vertex, all levels, default grid / 12 bits"),
            format!("{bl:.2} / {bl12:.2}"),
            "≤ 12",
            Some(bl <= 12.0 && bl12 <= 12.0),
        );
        headline(
            format!("{name}: reconstruction time on lines vs free"),
            format!("{line_s:.3} s vs {free_s:.3} s ({:+.1} %)", (line_s / free_s - 1.0) * 100.0),
            "≤ +10 %",
            Some(line_s <= 1.1 * free_s),
        );
    }
}

/// The 4.3 M-point case (the reconstruction area's): what `reconstruct -o X.ply` does (free
/// reconstruction, the finest level written as PLY) against `-o X.mrq` (on lines, every level
/// encoded and written).
fn large_case(dragon: &octowrap_mesh::Mesh) {
    let diag = dragon.vertices.bounds().diagonal();
    let pts = crate::recon::resample(dragon, 4_300_000, 2e-4 * diag);
    let tmp = std::env::temp_dir().join("octowrap-bench-accuracy");
    let _ = std::fs::create_dir_all(&tmp);
    let t = Instant::now();
    let (_, free) = reconstruct(&pts, MaxLevel::Level(10), None);
    let finest = free.hierarchy.levels.last().expect("levels");
    octowrap_io::write_path(&tmp.join("large.ply"), &finest.mesh, &octowrap_io::WriteOptions::default())
        .expect("writes");
    let ply_s = t.elapsed().as_secs_f64();
    drop(free);
    let t = Instant::now();
    let (recon_s, lines) = reconstruct(&pts, MaxLevel::Level(10), Some(DecoderGrid::Finest));
    let q = lines.line_grid.expect("a grid").quantization();
    let t_enc = Instant::now();
    octowrap_format::write_path(&tmp.join("large.mrq"), &lines.hierarchy, &EncodeOptions::with_quantization(q))
        .expect("writes");
    let enc_s = t_enc.elapsed().as_secs_f64();
    let mrq_s = t.elapsed().as_secs_f64();
    let vertices: usize = lines.hierarchy.levels.iter().map(|l| l.mesh.vertex_count()).sum();
    let _ = std::fs::remove_dir_all(&tmp);
    outln!(
        "4.3 M points to level 10: -o X.ply {ply_s:.2} s; -o X.mrq {mrq_s:.2} s ({:+.1} %: reconstruction on lines \
         {recon_s:.2} s, encoding and writing {enc_s:.2} s, {:.2} M vertices a second).",
        (mrq_s / ply_s - 1.0) * 100.0,
        vertices as f64 / enc_s / 1e6
    );
    outln!();
    headline(
        "4.3 M points to level 10: writing the MRQ (on lines) against the PLY",
        format!("{mrq_s:.2} s vs {ply_s:.2} s ({:+.1} %)", (mrq_s / ply_s - 1.0) * 100.0),
        "≤ +30 %",
        Some(mrq_s <= 1.3 * ply_s),
    );
}

/// Prints the accuracy section.
pub fn report() {
    outln!("## Accuracy: MRQ on decoder lines against free positions");
    outln!();
    outln!("Levels of `reconstruct -o X.mrq` (vertices computed on the decoder's lines) against `--keep-positions`");
    outln!("(free vertices), each encoded on the default grid and decoded; RMS as a fraction of the diagonal.");
    outln!();
    let Some(dir) = shared_data() else {
        outln!("(shared data absent: skipped)");
        return;
    };
    let load = |rel: &str| match octowrap_io::read_path(&dir.join(rel), &octowrap_io::ReadOptions::default()) {
        Ok(m) => Some(m),
        Err(e) => {
            outln!("(skipped {rel}: {e})");
            None
        }
    };
    let cases = [
        ("Rabbit (bun_zipper_res2)", "stanford-bunny/reconstruction/bun_zipper_res2.ply", MaxLevel::Level(6), false),
        ("bunny", "stanford-bunny/reconstruction/bun_zipper.ply", MaxLevel::Level(6), true),
        ("dragon", "stanford-dragon/dragon_vrip.ply.gz", MaxLevel::Level(7), true),
        ("autzen_trim.laz", "lidar-las/autzen_trim.laz", MaxLevel::Auto, false),
    ];
    let mut dragon = None;
    for (name, rel, level, timed) in cases {
        if let Some(m) = load(rel) {
            model(name, &m.vertices.positions, level, timed);
            if name == "dragon" {
                dragon = Some(m);
            }
        }
    }
    if let Some(m) = dragon.filter(|_| std::env::var_os("OCTOWRAP_BENCH_QUICK").is_none()) {
        large_case(&m);
    }
}
