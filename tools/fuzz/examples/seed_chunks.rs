//! Seeds for the `chunks` target (see its source for the input layout): small synthetic version 5
//! files (chunk shifts 1 and 2, grid and exact positions, line geometry, without lattice
//! coordinates) and the MRQ files given (any version), each behind selections that are cuts (none,
//! the root, the finest level, levels mixed: the crack rule fills the coarse chunks' edges or
//! refines them) and that are not (a chunk with its parent, a repeated chunk, a chunk past the
//! last). Prints how many of the seeds' cuts succeed, mix levels, refine, are rejected and fail
//! to decode. Run by `./seed.sh`:
//!
//! `cargo run --release --example seed_chunks -- OUT_DIR [FILE.mrq...]`
#![allow(clippy::print_stdout, clippy::print_stderr)] // a command-line tool: it reports what it wrote

use std::path::{Path, PathBuf};

use octowrap_format::synthetic::{Edits, cube_hierarchy, without_lattice};
use octowrap_format::{ChunkInfo, ChunkedMrq, CutError, EncodeOptions, Limits, Quantization, encode};

/// Files over this size are left out (the corpus stays fast to run).
const MAX_FILE: usize = 64 << 10;

/// The synthetic edits without joins: a corner joined to a vertex off its cell's boundary keeps
/// the levels it touches from splitting into cells.
const NO_JOINS: Edits =
    Edits { remove: 0.05, inner: 0.1, create: 0.05, split: 0.01, join: 0.0, noise: 0.2, shuffle: true };

/// Lattice edits alone: children pushed one voxel inwards; no removal, creation, split, join or noise.
const SMOOTH: Edits = Edits { remove: 0.0, inner: 0.1, create: 0.0, split: 0.0, join: 0.0, noise: 0.0, shuffle: true };

fn v5(q: Quantization, shift: u32) -> EncodeOptions {
    let mut o = EncodeOptions::with_quantization(q);
    o.version = 5;
    o.chunk_shift = shift;
    o
}

/// The synthetic files, by name.
fn synthetic() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let q12 = Quantization::Bits(12);
    for (name, levels, edits, seed, q, shift, lines) in [
        ("cube3_shift1_q12", 3, NO_JOINS, 1, q12, 1, false),
        ("cube4_shift1_q12", 4, NO_JOINS, 2, q12, 1, false),
        ("cube4_shift2_q12", 4, NO_JOINS, 3, q12, 2, false),
        ("cube4_shift1_exact", 4, NO_JOINS, 4, Quantization::Exact, 1, false),
        ("cube4_shift2_lines_q12", 4, NO_JOINS, 5, q12, 2, true),
        ("cube4_shift1_joins_q10", 4, Edits::default(), 6, Quantization::Bits(10), 1, false),
        ("cube4_shift1_unedited_q8", 4, Edits::none(), 7, Quantization::Bits(8), 1, false),
        ("cube4_shift2_unedited_exact", 4, Edits::none(), 8, Quantization::Exact, 2, false),
        ("cube5_shift2_unedited_q10", 5, Edits::none(), 9, Quantization::Bits(10), 2, false),
        ("cube4_shift1_smooth_q12", 4, SMOOTH, 10, q12, 1, false),
    ] {
        let mut h = cube_hierarchy(levels, edits, seed);
        let opts = v5(q, shift);
        if lines {
            octowrap_format::place_on_prediction_lines(&mut h, &opts).expect("placed");
        }
        out.push((format!("synthetic_{name}"), encode(&h, &opts).expect("encode")));
    }
    let generic = without_lattice(cube_hierarchy(3, NO_JOINS, 11));
    out.push(("synthetic_cube3_generic_q12".into(), encode(&generic, &v5(q12, 1)).expect("encode")));
    out
}

/// One seed: a selection, the level to extract, behind which the file goes.
struct Seed {
    /// What it is for (the file name's suffix).
    what: &'static str,
    /// The chunk ids (127 at most are kept).
    ids: Vec<u32>,
    /// The ids taken as they are (not modulo the chunk count).
    raw: bool,
    /// The level to extract (the file is resealed by the target: mutations of the preamble and
    /// the stored bytes reach past the checksums).
    level: u8,
    /// Extract in the first selected chunk's box only.
    region: bool,
}

impl Seed {
    fn new(what: &'static str, mut ids: Vec<u32>, level: u8) -> Self {
        ids.truncate(127);
        Self { what, ids, raw: false, level, region: false }
    }

    /// The fuzz input: the selection, then `file`.
    fn input(&self, file: &[u8]) -> Vec<u8> {
        let mut out = vec![
            self.ids.len() as u8 | if self.raw { 0x80 } else { 0 },
            (self.level & 0x3f) | 0x40 | if self.region { 0x80 } else { 0 },
        ];
        for &c in &self.ids {
            out.extend_from_slice(&(c as u16).to_le_bytes());
        }
        out.extend_from_slice(file);
        out
    }
}

/// What the seeds' cuts give: cuts, of them mixing levels and refined by the crack rule, and
/// selections rejected and failing to decode.
#[derive(Default)]
struct Tally {
    cuts: u32,
    mixed: u32,
    refined: u32,
    rejected: u32,
    failed: u32,
}

impl Tally {
    /// Cuts `ids` of `file` (when it opens) as it is (the target reseals it first).
    fn add(&mut self, ids: &[u32], file: &[u8]) {
        let Ok(mut reader) = ChunkedMrq::open(file, &Limits::strict()) else { return };
        let levels: Vec<u32> = reader.chunks().iter().map(|c| c.level).collect();
        match reader.cut(ids) {
            Ok(cut) => {
                self.cuts += 1;
                let drawn: std::collections::HashSet<u32> = cut.drawn.iter().map(|&c| levels[c as usize]).collect();
                self.mixed += u32::from(drawn.len() > 1);
                self.refined += u32::from(cut.refined > 0);
            }
            Err(CutError::Selection(_)) => self.rejected += 1,
            Err(_) => self.failed += 1,
        }
    }
}

/// Whether `a` is an ancestor of `d`.
fn is_ancestor(chunks: &[ChunkInfo], a: u32, d: u32) -> bool {
    std::iter::successors(chunks[d as usize].parent, |&p| chunks[p as usize].parent).any(|x| x == a)
}

/// The seeds of one file.
fn seeds(file: &[u8]) -> Vec<Seed> {
    let Ok(reader) = ChunkedMrq::open(file, &Limits::strict()) else {
        // Not a file the reader opens: one seed, for the open path.
        return vec![Seed::new("open", vec![0], 0)];
    };
    let chunks = reader.chunks();
    let levels = reader.info().levels.len() as u8;
    let finest = chunks.iter().map(|c| c.level).max().unwrap_or(0);
    let of_level =
        |k: u32| -> Vec<u32> { (0..chunks.len() as u32).filter(|&c| chunks[c as usize].level == k).collect() };
    let mut out = vec![Seed::new("none", Vec::new(), 0)];
    if chunks.is_empty() {
        return out;
    }
    let last = levels.saturating_sub(1);
    out.push(Seed { region: true, ..Seed::new("root", vec![0], last) });
    out.push(Seed::new("finest", of_level(finest), last));
    // Mixed levels: every other chunk of the coarsest level split in two or more, the rest of the
    // surface at the finest level (coarse chunks beside finer ones: the crack rule fills their
    // edges, or refines them).
    if let Some(k) = (1..finest).find(|&k| of_level(k).len() > 1) {
        let coarse: Vec<u32> = of_level(k).into_iter().step_by(2).collect();
        let mut mixed = coarse.clone();
        mixed.extend(of_level(finest).into_iter().filter(|&c| !coarse.iter().any(|&a| is_ancestor(&chunks, a, c))));
        mixed.sort_unstable();
        out.push(Seed { region: true, ..Seed::new("mixed", mixed, k as u8) });
    }
    if finest >= 1 {
        // One chunk of the level above the finest amid the finest level's other chunks.
        let one = *of_level(finest - 1).last().expect("a chunk of each level above the finest");
        let mut ids = vec![one];
        ids.extend(of_level(finest).into_iter().filter(|&c| !is_ancestor(&chunks, one, c)));
        out.push(Seed::new("one_coarse", ids, finest as u8));
    }
    // Not cuts: a chunk and its parent, a chunk twice, a chunk past the last; with one past the
    // last level to extract, or level 0.
    if let Some(c) = (0..chunks.len() as u32).rev().find(|&c| chunks[c as usize].parent.is_some()) {
        out.push(Seed::new("with_parent", vec![c, chunks[c as usize].parent.unwrap_or(0)], levels));
    }
    let c = chunks.len() as u32 - 1;
    out.push(Seed::new("twice", vec![c, 0, c], 0));
    out.push(Seed { raw: true, ..Seed::new("missing", vec![0, chunks.len() as u32], 0) });
    out
}

fn main() {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let Some(dir) = args.first() else {
        eprintln!("usage: seed_chunks OUT_DIR [FILE.mrq...]");
        std::process::exit(2);
    };
    std::fs::create_dir_all(dir).expect("create the corpus folder");
    let mut files = synthetic();
    for path in &args[1..] {
        let name = path.file_stem().map_or_else(|| "file".into(), |s| s.to_string_lossy().into_owned());
        match std::fs::read(path) {
            Ok(bytes) => files.push((name, bytes)),
            Err(e) => eprintln!("{}: {e}", path.display()),
        }
    }
    let (mut written, mut tally) = (0, Tally::default());
    for (name, bytes) in &files {
        if bytes.len() > MAX_FILE {
            continue;
        }
        for seed in seeds(bytes) {
            std::fs::write(Path::new(dir).join(format!("{name}-{}", seed.what)), seed.input(bytes))
                .expect("write a seed");
            tally.add(&seed.ids, bytes);
            written += 1;
        }
    }
    let Tally { cuts, mixed, refined, rejected, failed } = tally;
    println!(
        "{written} seeds in {}: {cuts} cuts ({mixed} mixing levels, {refined} refined by the crack rule), {rejected} selections rejected, {failed} failing to decode",
        dir.display()
    );
}
