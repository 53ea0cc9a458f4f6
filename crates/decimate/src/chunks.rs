//! Geometric errors of MRQ chunks (spec §11.2 `geometric_error`): per chunk of a version 5 file,
//! the certified Hausdorff distance between the chunk's surface and the finest level's surface
//! over the chunk's cell, raised to its children's largest so that it never grows from a chunk to
//! the chunks refining it. A view-dependent client turns it into a screen-space error.

pub use octowrap_format::select::{ViewSelection, select_for_error};
use octowrap_format::{ChunkInfo, ChunkedMrq, DecodeOptions, EncodeError, EncodeOptions, Limits};
use octowrap_mesh::Hierarchy;
use rayon::prelude::*;

/// Writes [`encode_measured`]'s bytes to `path` atomically ([`octowrap_fsutil::write_file`]: a
/// replaced file keeps its mode and owner, and is replaced only once the new one is complete).
pub fn write_measured(path: &std::path::Path, h: &Hierarchy, opts: &EncodeOptions) -> Result<(), EncodeError> {
    let bytes = encode_measured(h, opts)?;
    octowrap_fsutil::write_file(path, &octowrap_fsutil::WriteOptions::default(), |w| w.write_all(&bytes))
        .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| EncodeError::Io(e))
}

/// `h` encoded as MRQ with `opts`; in a chunked file (version 5) every chunk's geometric error is
/// measured ([`chunk_errors`]) and stored in the chunk index. Deterministic, whatever the thread
/// count.
pub fn encode_measured(h: &Hierarchy, opts: &EncodeOptions) -> Result<Vec<u8>, EncodeError> {
    let mut bytes = octowrap_format::encode(h, opts)?;
    if opts.version < 5 {
        return Ok(bytes);
    }
    // The file was just written: reading it back cannot fail but on a bug, said as such.
    let fail = |e: octowrap_format::DecodeError| {
        EncodeError::Io(std::io::Error::other(format!("reading back the file just encoded: {e}")))
    };
    let chunks = ChunkedMrq::open(&bytes[..], &Limits::default()).map_err(fail)?.chunks();
    let decoded = octowrap_format::decode(&bytes[..], &DecodeOptions::default()).map_err(fail)?.hierarchy;
    let errors = chunk_errors(&decoded, &chunks);
    octowrap_format::set_chunk_errors(&mut bytes, &errors).map_err(fail)?;
    Ok(bytes)
}

/// The geometric error of every chunk of a version 5 file, `chunks` as its index lists them and
/// `h` as the file decodes (each level's faces chunk after chunk, spec §11.4): the certified
/// Hausdorff distance's upper bound between the chunk's faces and the finest level's faces whose
/// voxels lie in the chunk's cell (all of the finest level without lattice coordinates), then the
/// largest of its own and of every chunk refining it. Chunks of the finest level have 0.
pub fn chunk_errors(h: &Hierarchy, chunks: &[ChunkInfo]) -> Vec<f32> {
    let Some(finest) = h.levels.last() else { return vec![0.0; chunks.len()] };
    let fk = h.levels.len() - 1;
    // Each chunk's first face in its level.
    let mut first = vec![0u32; chunks.len()];
    let mut next = vec![0u32; h.levels.len()];
    for (i, c) in chunks.iter().enumerate() {
        let k = c.level as usize;
        if k < next.len() {
            first[i] = next[k];
            next[k] += c.face_count;
        }
    }
    let measure = |i: usize| -> f64 {
        let c = &chunks[i];
        let k = c.level as usize;
        if k >= fk || c.face_count == 0 {
            return 0.0;
        }
        let Some(level) = h.levels.get(k) else { return 0.0 };
        let faces: Vec<u32> =
            (first[i]..first[i] + c.face_count).filter(|&f| (f as usize) < level.origins.len()).collect();
        let depth = c.cell_depth;
        let region: Vec<u32> = match &finest.lattice {
            Some(l) if depth > 0 => {
                let shift = fk as u32 - depth;
                (0..l.face_slots.len() as u32)
                    .filter(|&f| l.face_slots[f as usize].0.map(|x| x >> shift) == c.cell)
                    .collect()
            }
            _ => (0..finest.origins.len() as u32).collect(),
        };
        let d = crate::metrics::certified_hausdorff(&level.mesh.subset(&faces), &finest.mesh.subset(&region));
        if d.upper.is_finite() { d.upper } else { 0.0 }
    };
    let mut errors: Vec<f32> = (0..chunks.len()).into_par_iter().map(|i| measure(i) as f32).collect();
    // Children after parents in the index: walking backwards raises every parent after its children.
    for i in (0..chunks.len()).rev() {
        if let Some(p) = chunks[i].parent {
            let p = p as usize;
            if p < i {
                errors[p] = errors[p].max(errors[i]);
            }
        }
    }
    errors
}

/// The chunks a view shows ([`octowrap_format::select::select_for_view`] for `camera`).
pub fn select_for_view(chunks: &[ChunkInfo], camera: &crate::Camera, aspect: f64) -> ViewSelection {
    octowrap_format::select::select_for_view(chunks, &camera.view(), aspect)
}

/// Per chunk: whether `camera`'s view frustum meets its bounding box.
pub fn in_view(chunks: &[ChunkInfo], camera: &crate::Camera, aspect: f64) -> Vec<bool> {
    octowrap_format::select::in_view(chunks, &camera.view(), aspect)
}

/// The chunks for a view of the whole surface
/// ([`octowrap_format::select::select_cover_for_view`] for `camera`).
pub fn select_cover_for_view(chunks: &[ChunkInfo], camera: &crate::Camera, aspect: f64) -> ViewSelection {
    octowrap_format::select::select_cover_for_view(chunks, &camera.view(), aspect)
}

/// What a cut through a chunked file keeps coarse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ChunkCriterion {
    /// A camera's screen-space error, for the whole surface (no chunk culled: those out of view
    /// stay at the level where they leave it); the view is taken as 16:9.
    View(crate::Camera),
    /// Every drawn chunk within this error of the finest level (a length, or a share of the
    /// finest level's diagonal).
    MaxError(crate::ErrorBound),
}

/// What a cut through a chunked file read and drew (`octowrap decimate --json`'s `chunk_cut`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChunkCutReport {
    /// Chunks drawn, after the crack rule.
    pub chunks_drawn: usize,
    /// Chunks the crack rule replaced by the chunks refining them.
    pub chunks_refined: u32,
    /// Seams the crack rule could not close (the coarser chunk has no children).
    pub unresolved_seams: u32,
    /// Faces per level, coarsest first.
    pub faces_per_level: Vec<usize>,
    /// The largest geometric error of a drawn chunk (model units), as stored.
    pub max_error: f64,
    /// Bytes read from the file.
    pub bytes_read: u64,
    /// The file's size.
    pub file_bytes: u64,
    /// Read requests.
    pub requests: u64,
}

/// A cut through a chunked file: its mesh and report, and the finest level's face count and
/// diagonal (what a relative error is measured against).
#[derive(Clone, Debug)]
pub struct ChunkCut {
    /// The crack-free mesh.
    pub mesh: octowrap_mesh::Mesh,
    /// What it read and drew.
    pub report: ChunkCutReport,
    /// Faces of the file's finest level.
    pub finest_faces: usize,
    /// The finest level's bounding-box diagonal (its chunks' boxes).
    pub diagonal: f64,
}

/// Cuts the chunked file behind `reader` (of `file_bytes` bytes) for `criterion`: the index's
/// geometric errors choose the chunks, only they and their ancestors are read, and the crack
/// rule stitches them (spec §11.5).
pub fn cut_chunks<S: octowrap_format::RangeSource>(
    reader: &mut ChunkedMrq<S>,
    criterion: &ChunkCriterion,
    file_bytes: u64,
) -> Result<ChunkCut, octowrap_format::CutError> {
    let chunks = reader.chunks();
    let levels = reader.info().levels.len();
    let finest = levels.saturating_sub(1) as u32;
    let finest_faces = chunks.iter().filter(|c| c.level == finest).map(|c| c.face_count as usize).sum();
    let (lo, hi) = chunks.iter().filter(|c| c.level == finest).fold(([f64::MAX; 3], [f64::MIN; 3]), |(lo, hi), c| {
        ([0, 1, 2].map(|a| lo[a].min(f64::from(c.bbox_min[a]))), [0, 1, 2].map(|a| hi[a].max(f64::from(c.bbox_max[a]))))
    });
    let diagonal = (0..3).map(|a| (hi[a] - lo[a]).max(0.0).powi(2)).sum::<f64>().sqrt();
    let selection = match criterion {
        ChunkCriterion::View(c) => select_cover_for_view(&chunks, c, 16.0 / 9.0),
        ChunkCriterion::MaxError(crate::ErrorBound::Absolute(e)) => select_for_error(&chunks, *e),
        ChunkCriterion::MaxError(crate::ErrorBound::Relative(r)) => select_for_error(&chunks, r * diagonal),
    };
    let cut = reader.cut(&selection.drawn)?;
    let read = reader.stats();
    let mut faces_per_level = vec![0usize; levels];
    for &c in &cut.face_chunks {
        faces_per_level[chunks[c as usize].level as usize] += 1;
    }
    let max_error = cut
        .drawn
        .iter()
        .map(|&c| f64::from(chunks[c as usize].geometric_error.unwrap_or(f32::NAN)))
        .fold(0.0, f64::max);
    let report = ChunkCutReport {
        chunks_drawn: cut.drawn.len(),
        chunks_refined: cut.refined,
        unresolved_seams: cut.unresolved,
        faces_per_level,
        max_error,
        bytes_read: read.bytes,
        file_bytes,
        requests: read.requests,
    };
    Ok(ChunkCut { mesh: cut.mesh, report, finest_faces, diagonal })
}
