//! Chunked MRQ files (format version 5, spec §11). The bunny and the dragon reconstructed as the
//! format area reconstructs them (same levels), and the LiDAR tile `autzen_trim.laz` (levels
//! chosen by the reconstruction, as the accuracy area reconstructs it), each placed on its version
//! 4 prediction lines at 12-bit quantization, then encoded as version 4 (unchunked) and as version
//! 5 at chunk shifts 7, 6 and 5, every chunk's geometric error measured
//! (`octowrap_decimate::chunks::encode_measured`, what `octowrap reconstruct` writes):
//!
//! - sizes: bytes, bits per finest vertex, overhead over version 4, chunks, per level too, and a
//!   check that each version 5 file decodes to the version 4 file's levels; Draco's size of the
//!   finest level alone beside them;
//! - bytes read by a view: the dragon's head close-up (`fixtures/cameras/dragon-head.json`) through
//!   a byte-range source that counts what it serves, culled to the view and for the whole surface;
//! - decode speed of the whole file in finest-level vertices per second: version 4 on one thread,
//!   version 5 on one and on two threads, and Draco's decoder (DracoPy) on the finest level.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use octowrap_decimate::Camera;
use octowrap_decimate::chunks::{encode_measured, in_view, select_cover_for_view, select_for_view};
use octowrap_format::{
    ChunkInfo, ChunkedMrq, CountingSource, DecodeOptions, EncodeOptions, Limits, Quantization, decode_bytes,
    encode_with_stats, place_on_prediction_lines,
};
use octowrap_mesh::{Hierarchy, Level};
use octowrap_recon::MaxLevel;

use crate::format::{DRACO_SKIPPED, DracoFigures, SCANS, draco_figures, recon};
use crate::util::{best_of, best_of_cpu, headline, shared_data};

/// The chunk shifts measured (spec §11.1: level `k`'s cells have depth `k - shift`).
const SHIFTS: [u32; 3] = [7, 6, 5];
/// Decodes timed per file (best kept), after one warm-up decode.
const DECODE_RUNS: usize = 30;
/// The viewport's width over its height for the view.
const ASPECT: f64 = 16.0 / 9.0;
/// Targets: chunking's size overhead (%), the share of the file a close-up reads, the decoder's
/// speed against Draco's on one thread, and two threads against one.
const MAX_OVERHEAD: f64 = 5.0;
const MAX_VIEW_SHARE: f64 = 0.25;
const MIN_VS_DRACO: f64 = 2.5;
const MIN_TWO_THREADS: f64 = 1.7;

/// Encoder options: 12-bit grid, `version`, `chunk_shift`.
fn options(version: u16, shift: u32) -> EncodeOptions {
    let mut o = EncodeOptions::with_quantization(Quantization::Bits(12));
    o.version = version;
    o.chunk_shift = shift;
    o
}

/// One hierarchy and its files.
struct Model {
    name: &'static str,
    /// Vertices of the finest level.
    finest: usize,
    /// Faces per level.
    faces: Vec<usize>,
    /// Version 4 (unchunked).
    v4: Vec<u8>,
    /// Version 5: shift, bytes, encode (with the errors' measurement) seconds, and whether the
    /// file decodes to the version 4 file's levels.
    v5: Vec<(u32, Vec<u8>, f64, bool)>,
    /// Topology and geometry bytes (each zstd-compressed alone, summed over chunks): version 4,
    /// then per shift.
    split: Vec<(usize, usize)>,
    /// The version 4 file's finest level, decoded, as PLY (for Draco).
    ply: PathBuf,
}

/// The level's faces as sorted lists of vertex positions (bit patterns), sorted: equal for two
/// levels with the same faces whatever their numbering.
fn face_set(l: &Level) -> Vec<Vec<[u64; 3]>> {
    let p = &l.mesh.vertices.positions;
    let mut out: Vec<Vec<[u64; 3]>> =
        l.mesh.faces.iter().map(|f| f.iter().map(|&v| p[v as usize].to_array().map(f64::to_bits)).collect()).collect();
    out.sort();
    out
}

fn same_levels(a: &Hierarchy, b: &Hierarchy) -> bool {
    a.levels.len() == b.levels.len() && a.levels.iter().zip(&b.levels).all(|(x, y)| face_set(x) == face_set(y))
}

/// The chunk index of a file (one chunk per level before version 5).
fn index(bytes: &[u8]) -> Vec<ChunkInfo> {
    ChunkedMrq::open(bytes, &Limits::default()).expect("opens").chunks()
}

/// `h` placed on its lines and encoded every way; `None` when the placement fails.
fn model(name: &'static str, mut h: Hierarchy, tmp: &Path) -> Option<Model> {
    if let Err(e) = place_on_prediction_lines(&mut h, &options(4, 0)) {
        outln!("({name} skipped: placement on lines failed: {e})");
        return None;
    }
    let v4 = encode_measured(&h, &options(4, 0)).expect("encodes");
    let reference = decode_bytes(&v4, &DecodeOptions::default()).expect("decodes").hierarchy;
    let v5 = SHIFTS
        .iter()
        .map(|&shift| {
            let (secs, bytes) = best_of(1, || encode_measured(&h, &options(5, shift)).expect("encodes"));
            let back = decode_bytes(&bytes, &DecodeOptions::default()).expect("decodes").hierarchy;
            let same = same_levels(&reference, &back);
            (shift, bytes, secs, same)
        })
        .collect();
    let split = std::iter::once(options(4, 0))
        .chain(SHIFTS.iter().map(|&shift| options(5, shift)))
        .map(|o| {
            let (_, stats) = encode_with_stats(&h, &o).expect("encodes");
            (stats.iter().map(|l| l.topology).sum(), stats.iter().map(|l| l.geometry).sum())
        })
        .collect();
    let ply = tmp.join(format!("{name}.ply"));
    let finest = &reference.levels.last().expect("levels").mesh;
    if let Err(e) = octowrap_io::write_path(&ply, finest, &octowrap_io::WriteOptions::default()) {
        eprintln!("cannot write {}: {e}", ply.display());
    }
    Some(Model {
        name,
        finest: finest.vertex_count().max(1),
        faces: reference.levels.iter().map(|l| l.mesh.faces.len()).collect(),
        v4,
        v5,
        split,
        ply,
    })
}

/// Prints the chunks section.
pub fn report() {
    outln!("## Chunks: size, bytes read by a view, decode speed (format version 5)");
    outln!();
    outln!("The bunny and the dragon reconstructed as in the format area (levels 0-6, 0-7), and the LiDAR tile");
    outln!("autzen_trim.laz (levels chosen by the reconstruction), placed on their version 4 prediction lines,");
    outln!("at 12-bit quantization: version 4 (unchunked) against version 5 at chunk shifts 7, 6 and 5 (chunks");
    outln!("of some 4^shift faces), every chunk's geometric error measured (`chunks::encode_measured`).");
    outln!();
    let Some(dir) = shared_data() else {
        outln!("(shared data absent: skipped)");
        return;
    };
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let scans = SCANS.iter().map(|&(name, rel, level)| (name, rel, MaxLevel::Level(level))).chain([(
        "autzen_trim.laz",
        "lidar-las/autzen_trim.laz",
        MaxLevel::Auto,
    )]);
    let mut models = Vec::new();
    for (name, rel, level) in scans {
        let (secs, r) = best_of(1, || recon(name, &dir.join(rel), level));
        let Some((cloud, h)) = r else {
            outln!("({name} skipped: see standard error)");
            continue;
        };
        outln!("{name}: {} points, levels 0-{}, reconstructed in {secs:.2} s.", cloud.len(), h.levels.len() - 1);
        models.extend(model(name, h, tmp.path()));
    }
    outln!();
    let plys: Vec<PathBuf> = models.iter().map(|m| m.ply.clone()).collect();
    let draco = draco_figures(&plys, DECODE_RUNS);
    if draco.is_none() {
        outln!("{DRACO_SKIPPED}");
        outln!();
    }
    sizes(&models, draco.as_deref());
    outln!("Per level: stored bytes as version 4 and at each shift (change, chunks).");
    outln!();
    for m in &models {
        per_level(m);
    }
    split(&models);
    if let Some(dragon) = models.iter().find(|m| m.name == "dragon") {
        view(dragon);
    }
    decode_speed(&models, draco.as_deref());
}

/// Where chunking's bytes go: the topology and geometry streams, each compressed alone.
fn split(models: &[Model]) {
    outln!("Where the bytes go: topology and geometry streams, each zstd-compressed on its own (summed over");
    outln!("levels and chunks; the stored frames compress them together), and their change over version 4.");
    outln!();
    outln!("| hierarchy | file | topology bytes | change | geometry bytes | change |");
    outln!("|---|---|---|---|---|---|");
    for m in models {
        let (t4, g4) = m.split[0];
        let change = |a: usize, b: usize| format!("{:+.1} %", (a as f64 / b.max(1) as f64 - 1.0) * 100.0);
        outln!("| {} | version 4 | {t4} | | {g4} | |", m.name);
        for ((shift, ..), &(t, g)) in m.v5.iter().zip(&m.split[1..]) {
            outln!("| | version 5, shift {shift} | {t} | {} | {g} | {} |", change(t, t4), change(g, g4));
        }
    }
    outln!();
}

/// The size table and its headlines.
fn sizes(models: &[Model], draco: Option<&[DracoFigures]>) {
    outln!("### Size");
    outln!();
    outln!("Whole file (every level); bits per vertex of the finest level. Draco: the finest level alone");
    outln!("(quads split in two triangles), 12-bit, compression level 10. Encode: with the chunks' errors measured.");
    outln!();
    outln!(
        "| hierarchy | file | bytes | bits/finest vertex | over version 4 | chunks | decodes to version 4's levels | encode s |"
    );
    outln!("|---|---|---|---|---|---|---|---|");
    for (i, m) in models.iter().enumerate() {
        let bits = |n: usize| n as f64 * 8.0 / m.finest as f64;
        outln!(
            "| {} ({} finest vertices) | version 4 | {} | {:.2} | | {} levels | | |",
            m.name,
            m.finest,
            m.v4.len(),
            bits(m.v4.len()),
            m.faces.len()
        );
        for (shift, bytes, secs, same) in &m.v5 {
            let over = (bytes.len() as f64 / m.v4.len() as f64 - 1.0) * 100.0;
            outln!(
                "| | version 5, shift {shift} | {} | {:.2} | {over:+.1} % | {} | {} | {secs:.2} |",
                bytes.len(),
                bits(bytes.len()),
                index(bytes).len(),
                if *same { "yes" } else { "**no**" }
            );
            headline(
                format!("{}: version 5 at chunk shift {shift}, size over the same hierarchy as version 4", m.name),
                format!("{over:+.1} % ({} vs {} bytes)", bytes.len(), m.v4.len()),
                format!("≤ +{MAX_OVERHEAD:.0} %"),
                Some(over <= MAX_OVERHEAD && *same),
            );
        }
        if let Some(d) = draco.map(|d| &d[i]) {
            outln!(
                "| | Draco, finest level alone ({} vertices) | {} | {:.2} | | | | |",
                d.vertices,
                d.bytes,
                bits(d.bytes)
            );
        }
    }
    outln!();
}

/// Bytes and chunks per level, version 4 against each shift.
fn per_level(m: &Model) {
    let v4 = index(&m.v4);
    let v5: Vec<Vec<ChunkInfo>> = m.v5.iter().map(|(_, b, _, _)| index(b)).collect();
    let shifts = m.v5.iter().fold(String::new(), |mut t, (s, ..)| {
        let _ = write!(t, " shift {s}: bytes (chunks) |");
        t
    });
    outln!("| {} level | faces | version 4 bytes |{shifts}", m.name);
    outln!("|---|---|---|{}", "---|".repeat(m.v5.len()));
    for (k, faces) in m.faces.iter().enumerate() {
        let of_level = |cs: &[ChunkInfo]| cs.iter().filter(|c| c.level as usize == k).cloned().collect::<Vec<_>>();
        let stored = |cs: &[ChunkInfo]| cs.iter().map(|c| u64::from(c.stored_size)).sum::<u64>();
        let base = stored(&of_level(&v4));
        let cells = v5.iter().fold(String::new(), |mut t, cs| {
            let mine = of_level(cs);
            let b = stored(&mine);
            let _ = write!(t, " {b} ({:+.1} %, {}) |", (b as f64 / base.max(1) as f64 - 1.0) * 100.0, mine.len());
            t
        });
        outln!("| {k} | {faces} | {base} |{cells}");
    }
    outln!();
}

/// What one cut of the view read and drew.
struct ViewRow {
    read: u64,
    requests: u64,
    selected: usize,
    drawn: usize,
    finest_drawn: usize,
    /// Drawn chunks in view that are not of the finest level though chunks refine them.
    coarse_in_view: usize,
    refined: u32,
    faces: usize,
}

/// The dragon's head close-up at every shift: the cut culled to the view, and the whole surface.
fn view(m: &Model) {
    let path = octowrap_testdata::workspace_root().join("fixtures/cameras/dragon-head.json");
    let camera = match std::fs::read_to_string(&path)
        .map_err(|e| e.to_string())
        .and_then(|t| Camera::from_json(&t).map_err(|e| e.to_string()))
    {
        Ok(c) => c,
        Err(e) => {
            outln!("(view skipped: cannot read {}: {e})", path.display());
            return;
        }
    };
    outln!("### Bytes read by a view: the dragon's head close-up");
    outln!();
    outln!("`fixtures/cameras/dragon-head.json`, 16:9, through a byte-range source counting what it serves. In view:");
    outln!("`chunks::select_for_view`, then `ChunkedMrq::cut_where` drawing only chunks in view; whole surface:");
    outln!("`select_cover_for_view`, then `cut`. Drawn: after the crack rule's refinements. Coarse in view: drawn");
    outln!("chunks in view that chunks refine but are not of the finest level.");
    outln!();
    outln!(
        "| shift | cut | bytes read | of the file | requests | chunks selected | drawn | of the finest level | coarse in view | refined by the crack rule | faces |"
    );
    outln!("|---|---|---|---|---|---|---|---|---|---|---|");
    for (shift, bytes, ..) in &m.v5 {
        for culled in [true, false] {
            let what = if culled { "in view" } else { "whole surface" };
            let r = match view_cut(bytes, &camera, culled) {
                Ok(r) => r,
                Err(e) => {
                    outln!("| {shift} | {what} | cut failed: {e} | | | | | | | | |");
                    if culled {
                        headline(format!("dragon head close-up, chunk shift {shift}"), "cut failed", "–", Some(false));
                    }
                    continue;
                }
            };
            let share = r.read as f64 / bytes.len() as f64;
            outln!(
                "| {shift} | {what} | {} | {:.1} % | {} | {} | {} | {} | {} | {} | {} |",
                r.read,
                share * 100.0,
                r.requests,
                r.selected,
                r.drawn,
                r.finest_drawn,
                r.coarse_in_view,
                r.refined,
                r.faces
            );
            if culled {
                let finest = if r.coarse_in_view == 0 {
                    "every chunk in view finest".to_owned()
                } else {
                    format!("{} chunks in view coarser", r.coarse_in_view)
                };
                headline(
                    format!(
                        "dragon head close-up, chunk shift {shift}: bytes read, every chunk in view at its finest level"
                    ),
                    format!(
                        "{:.1} % of the file ({} of {} bytes, {} requests); {finest}",
                        share * 100.0,
                        r.read,
                        bytes.len(),
                        r.requests
                    ),
                    format!("≤ {:.0} %, every chunk in view finest", MAX_VIEW_SHARE * 100.0),
                    Some(share <= MAX_VIEW_SHARE && r.coarse_in_view == 0),
                );
            }
        }
    }
    outln!();
}

/// One cut of `camera`'s view of the file `bytes` through a counting source: culled to the view
/// (`select_for_view`, `cut_where`) or of the whole surface (`select_cover_for_view`, `cut`).
fn view_cut(bytes: &[u8], camera: &Camera, culled: bool) -> Result<ViewRow, octowrap_format::CutError> {
    let chunks = index(bytes);
    let finest = chunks.iter().map(|c| c.level).max().unwrap_or(0);
    let mut has_child = vec![false; chunks.len()];
    for c in &chunks {
        if let Some(p) = c.parent {
            has_child[p as usize] = true;
        }
    }
    let seen = in_view(&chunks, camera, ASPECT);
    let selection =
        if culled { select_for_view(&chunks, camera, ASPECT) } else { select_cover_for_view(&chunks, camera, ASPECT) };
    let mut source = CountingSource::new(bytes);
    let mut reader = ChunkedMrq::open(&mut source, &Limits::default()).expect("opens");
    let cut = if culled {
        reader.cut_where(&selection.drawn, |c| seen[c as usize])?
    } else {
        reader.cut(&selection.drawn)?
    };
    drop(reader);
    let level = |c: u32| chunks[c as usize].level;
    Ok(ViewRow {
        read: source.bytes,
        requests: source.requests,
        selected: selection.drawn.len(),
        drawn: cut.drawn.len(),
        finest_drawn: cut.drawn.iter().filter(|&&c| level(c) == finest).count(),
        coarse_in_view: cut
            .drawn
            .iter()
            .filter(|&&c| seen[c as usize] && level(c) != finest && has_child[c as usize])
            .count(),
        refined: cut.refined,
        faces: cut.mesh.faces.len(),
    })
}

/// Best wall seconds of `DECODE_RUNS` decodes of `bytes` on `pool` after a warm-up, and the least
/// CPU time of the thread running them (meaningful on a one-thread pool only).
fn timed_decode(pool: &rayon::ThreadPool, bytes: &[u8]) -> (f64, f64) {
    pool.install(|| {
        let _ = decode_bytes(bytes, &DecodeOptions::default()).expect("decodes");
        let (wall, cpu, _) =
            best_of_cpu(DECODE_RUNS, || decode_bytes(bytes, &DecodeOptions::default()).expect("decodes"));
        (wall, cpu)
    })
}

/// The decode table and its headlines.
fn decode_speed(models: &[Model], draco: Option<&[DracoFigures]>) {
    let pool = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().expect("a thread pool");
    let (one, two) = (pool(1), pool(2));
    outln!("### Decode speed");
    outln!();
    outln!(
        "The whole file (every level), best of {DECODE_RUNS} after a warm-up decode, in M finest-level vertices per second"
    );
    outln!("of wall time and of the decoding thread's CPU time (one thread); Draco's decoder (DracoPy.decode, from");
    outln!("Python, so its time includes copying the result into NumPy arrays) on its encoding of the finest level");
    outln!("alone, in the same run. Against Draco: CPU rates; two threads against one: wall rates.");
    outln!();
    outln!("| hierarchy | file | threads | decode ms | finest Mv/s | Mv/s CPU | vs Draco | vs one thread |");
    outln!("|---|---|---|---|---|---|---|---|");
    for (i, m) in models.iter().enumerate() {
        let mv = |secs: f64| m.finest as f64 / secs / 1e6;
        let draco = draco.and_then(|d| d[i].decode);
        let vs_draco = |cpu: f64| draco.map(|(_, dc)| dc / cpu);
        let ratio = |r: Option<f64>| r.map_or_else(String::new, |r| format!("{r:.2}x"));
        let (w4, c4) = timed_decode(&one, &m.v4);
        outln!(
            "| {} | version 4 | 1 | {:.2} | {:.2} | {:.2} | {} | |",
            m.name,
            w4 * 1e3,
            mv(w4),
            mv(c4),
            ratio(vs_draco(c4))
        );
        let mut one_vs_draco = Vec::new();
        let mut two_vs_one = Vec::new();
        for (shift, bytes, ..) in &m.v5 {
            let (w1, c1) = timed_decode(&one, bytes);
            let (w2, _) = timed_decode(&two, bytes);
            outln!(
                "| | version 5, shift {shift} | 1 | {:.2} | {:.2} | {:.2} | {} | |",
                w1 * 1e3,
                mv(w1),
                mv(c1),
                ratio(vs_draco(c1))
            );
            outln!("| | version 5, shift {shift} | 2 | {:.2} | {:.2} | | | {:.2}x |", w2 * 1e3, mv(w2), w1 / w2);
            one_vs_draco.push((*shift, vs_draco(c1)));
            two_vs_one.push((*shift, w1 / w2));
        }
        if let Some((dw, dc)) = draco {
            outln!("| | Draco, finest level alone | 1 | {:.2} | {:.2} | {:.2} | 1.00x | |", dw * 1e3, mv(dw), mv(dc));
        }
        let shifts = |v: &[(u32, Option<f64>)]| {
            let s: Vec<String> = v.iter().map(|(s, _)| s.to_string()).collect();
            let r: Vec<String> =
                v.iter().map(|(_, r)| r.map_or_else(|| "?".to_owned(), |r| format!("{r:.2}x"))).collect();
            (s.join("/"), r.join(" / "))
        };
        let (names, figures) = shifts(&one_vs_draco);
        let all_draco = one_vs_draco.iter().map(|(_, r)| *r).collect::<Option<Vec<f64>>>();
        headline(
            format!("{}: version 5 decode on one thread against Draco's decoder, shifts {names}", m.name),
            if draco.is_some() { figures } else { "Draco not measured (no DracoPy)".to_owned() },
            format!("≥ {MIN_VS_DRACO}x"),
            all_draco.map(|v| v.iter().all(|&r| r >= MIN_VS_DRACO)),
        );
        let wrapped: Vec<(u32, Option<f64>)> = two_vs_one.iter().map(|&(s, r)| (s, Some(r))).collect();
        let (names, figures) = shifts(&wrapped);
        headline(
            format!("{}: version 5 decode on two threads against one, shifts {names}", m.name),
            figures,
            format!("≥ {MIN_TWO_THREADS}x"),
            Some(two_vs_one.iter().all(|&(_, r)| r >= MIN_TWO_THREADS)),
        );
    }
    outln!();
}
