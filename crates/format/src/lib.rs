//! The MRQ codec: octowrap's file format for multiresolution quad-mesh hierarchies, as specified in
//! `spec/FORMAT.md` (the spec is normative; this crate mirrors it and uses its field names).
//!
//! An MRQ file holds a [`Hierarchy`] coarse to fine. Level 0 is any polygon mesh; every finer level
//! is coded against the decoded level above it: the canonical subdivision of the parent (spec §5),
//! topology edits (children removed, faces created, vertices split or joined), and vertex residuals
//! on one quantization grid against a prediction from the decoded parent (spec §6). Every decoded
//! vertex lies within half a grid step of the encoder's input on every axis, at every level.
//!
//! The container (spec §3) puts a header, a level table (offsets, sizes, XXH3 checksums) and
//! metadata first, so a reader holding the first bytes knows where every level lies; each level is
//! one zstd frame. [`decode`] reads levels `0..=k` from any [`Read`] and stops there.
//!
//! In version 5 (the default) every level is split into **chunks** (spec §11): the faces of one
//! octree cell, coded against the chunk of the level above that they refine, each its own zstd
//! frame with a checksum, listed in a chunk index in the preamble (byte range, counts, bounding
//! box, geometric error). [`ChunkedMrq`] reads the preamble in two range requests and then only the
//! chunks asked for and their ancestors, over any [`RangeSource`] (a file through [`SeekSource`],
//! a buffer, an HTTP client); the chunks of a level decode in parallel, with the same output
//! whatever the thread count. A view takes chunks of different levels, fine where it looks:
//! [`select`] chooses them for a camera or an error bound from the index alone, and
//! [`ChunkedMrq::cut`] fetches them and makes their mesh crack-free by the crack rule of spec
//! §11.5 (shared seam vertices, T-junctions turned into polygon corners, and a chunk refined
//! where two levels do not fit).
//!
//! ```
//! use octowrap_format::{ChunkedMrq, EncodeOptions, Limits, encode};
//! use octowrap_format::synthetic::{Edits, cube_hierarchy};
//!
//! let mut opts = EncodeOptions::default();
//! opts.chunk_shift = 1; // small chunks for this small hierarchy
//! let bytes = encode(&cube_hierarchy(5, Edits::none(), 1), &opts).unwrap();
//! let mut file = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
//! let chunks = file.chunks();
//! // Level 3 everywhere, but level 4 in the first level-3 chunk's cell: a cut of two levels.
//! let level3: Vec<u32> = (0..chunks.len() as u32).filter(|&c| chunks[c as usize].level == 3).collect();
//! let mut drawn = level3[1..].to_vec();
//! drawn.extend((0..chunks.len() as u32).filter(|&c| chunks[c as usize].parent == Some(level3[0])));
//! let cut = file.cut(&drawn).unwrap();
//! assert_eq!(cut.unresolved, 0);
//! assert!(cut.mesh.faces.len() > 0);
//! ```
//!
//! ```
//! use octowrap_format::{decode, encode, DecodeOptions, EncodeOptions};
//! use octowrap_mesh::{DVec3, FaceList, Hierarchy, Mesh};
//!
//! let mut mesh = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
//! mesh.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
//! let bytes = encode(&Hierarchy::single(mesh), &EncodeOptions::default()).unwrap();
//! let file = decode(&bytes[..], &DecodeOptions::default()).unwrap();
//! assert_eq!(file.hierarchy.levels[0].mesh.faces.face(0), &[0, 1, 2, 3]);
//! ```
//!
//! Decoding never panics on hostile input: every failure is a [`DecodeError`] naming the region and
//! byte offset, and every allocation is checked against [`Limits`] first. Encoding is
//! deterministic: the same hierarchy and options give the same bytes.
//!
//! Face and vertex order: level 0 keeps the input order; finer levels are stored in the order
//! of their decoded level (spec §5.4, §5.7, §5.9, and Appendix A "Order": subfaces by parent and
//! quadrant, then created faces; vertices by name in modes 1 and 2, by first use in mode 3). Use
//! [`canonical`] to put a hierarchy in that order (positions unchanged), for comparisons.
//!
//! # Design (why the format looks like this)
//! * **Vertices are named, not numbered** (spec §5.5). In a lattice level a vertex's name is its
//!   octree lattice corner, so a face's corners follow from its slot, and only the rare split
//!   vertices and exceptions cost bits; reconstruction's voxel staircases (children pushed one
//!   voxel inwards, faces created by the closure) need no renaming. Without lattice coordinates the
//!   names are the canonical subdivision's (parent vertex, edge, face), so a level that equals the
//!   subdivision of its parent costs a few bytes of topology.
//! * **One grid for all levels, tied to the octree cube** (`2^bits` steps across it), so that
//!   every lattice point is an integer grid point and residuals are exact integers: prediction runs
//!   on decoded coordinates, and the error bound (half a step) holds at every level.
//! * **Prediction from the decoded parent**: the lattice point moved along the parent's normal, or
//!   the parent's bilinear point, whichever the encoder finds smaller per level, plus 3/4 of the
//!   mean correction already needed by decoded neighbours.
//! * **One number per vertex on its prediction line** (spec §6.6): the decoder derives a line for
//!   every vertex from the decoded parent (the base prediction and the parent face's normal); a
//!   vertex on it costs its parameter along it instead of three residuals.
//!   [`place_on_prediction_lines`] moves a hierarchy's vertices onto their lines along their tangent
//!   planes, so the file stores what the caller holds exactly; vertices elsewhere still round-trip
//!   within half a step.
//! * **First-use numbering and integer geometry for decoding speed** (mode 3, spec §5.9, §6.8;
//!   [`EncodeOptions::version`] 3, the default): lattice refinements keep mode 2's face streams but
//!   number vertices by first use (a key table, no sorted name set) and predict geometry in
//!   integers from the parent alone (a fixed-point line along the parent quad's exact normal);
//!   about 1.7 times fewer decoder instructions per vertex than mode 2 at the same size.
//! * **Byte planes + zstd**: residuals and symbols go to separate streams, least significant
//!   byte planes first, one zstd frame per level: zstd comes within about 3 % of the order-0
//!   entropy of the residuals on the bunny and dragon hierarchies, so an adaptive entropy coder
//!   pays only with better context modelling.
//! * **Hostile input**: the container checks a header and table checksum before trusting any
//!   offset, each level's XXH3 before decompressing it; decompression streams, the block header
//!   first, capped at the declared size; every declared count is checked against the bytes that
//!   must hold it and against [`Limits`] before anything is allocated for it.
//!
//! # Layout (the spec's sections, one module each)
//! * `container` — §3 File structure: header, level table, metadata, preamble checksum.
//! * `block` — §4 Level block: block header, streams, the counts the streams can hold.
//! * `topology` — §5 Topology: `base` (mode 0, §5.1), `generic` (mode 1, §5.4), `lattice`
//!   (lattice faces of modes 2 and 3, §5.3; mode 2's lattice corners, §5.7), `first_use` (mode 3,
//!   §5.9), `names` (§5.5, §5.6), `slots` (lattice keys, §5.3, §5.8).
//! * `geometry` — §6 Geometry: `predict` (modes 0-2, §6.2-§6.7), `fixed` (mode 3, §6.8),
//!   `residuals` (the stream, §6.1).
//! * `decoder`, `encoder` — §7 and §8: whole files, level after level; `level_decode` and
//!   `level_encode` take one level block through §4-§6 in order. The encoder of a level writes all
//!   streams of its mode in one pass over its faces (the modes share the face order of §5.3 and
//!   §5.4), so it stays one module beside the decoder's per-mode files.
//! * `bytes` — §1 Conventions: varints, zigzag, byte planes, the bounds-checked reader.
//! * `limits`, `error` — §7.2 Limits and §7.3 Errors.
//! * `placement` — Appendix A "Line placement": moving vertices onto their prediction lines.
//! * `chunks`, `chunked` — §11 Chunks: the encoder's plan of cells and chunks; the chunk index,
//!   the parallel decode and merge of a level's chunks, and [`ChunkedMrq`].
//! * `select`, `stitch` — §11.5 Cuts: which chunks a view needs, and the crack rule.

mod block;
mod bytes;
mod chunked;
mod chunks;
mod container;
#[cfg(feature = "testing")]
pub mod cut_check;
mod decoder;
mod encoder;
mod entropy;
mod error;
#[cfg(feature = "testing")]
pub mod fuzzing;
mod geometry;
mod level_decode;
mod level_encode;
mod limits;
mod placement;
pub mod select;
mod stitch;
#[cfg(feature = "testing")]
pub mod synthetic;
#[cfg(feature = "testing")]
pub mod tamper;
mod topology;

use std::path::Path;

use octowrap_mesh::{DVec3, Hierarchy};

pub use chunked::{ChunkInfo, ChunkedMrq, CountingSource, RangeSource, ReadStats, SeekSource, set_chunk_errors};
pub use chunks::CHUNK_SHIFT;
pub use container::{CRS_KEY, FileInfo, GridDescription, LevelInfo, Metadata, MetadataInfo};
pub use decoder::{decode, decode_bytes, read_info};
pub use encoder::{encode, encode_to, encode_with_stats};
pub use error::{DecodeError, EncodeError, Where};
pub use geometry::decoder_lines::{DecodedLevels, DecoderLine, GridSpec, LineOrigin};
pub use geometry::fixed::FixedLine;
pub use limits::Limits;
pub use placement::{LinePlacement, place_on_prediction_lines};
pub use stitch::{Cut, CutError};

/// The newest format version (spec §3.1). The decoder reads every version from 1 to this; the
/// encoder writes versions 2 to this ([`EncodeOptions::version`]).
pub const FORMAT_VERSION: u16 = 5;
/// The version [`EncodeOptions::default`] writes.
pub const DEFAULT_VERSION: u16 = 5;
/// The finest grid a file may use: `2^28` steps across the cube.
pub const MAX_GRID_BITS: u32 = 28;

/// Grid steps per voxel of a hierarchy's finest level, as a power of two, in the default
/// quantization of a reconstruction: with a 64th of a voxel, quantization adds at most about 1 %
/// to any level's points-to-mesh error (bunny, level 6: +0.8 %; a 16th adds 11 %, a 32nd 3 %).
pub const GRID_STEPS_PER_FINEST_VOXEL_LOG2: u32 = 6;

/// The default grid bits for a reconstructed hierarchy whose finest level is `finest`: tied to
/// the cube, `2^(finest + 6)` steps across it (a 64th of the finest voxel), within 1 to
/// [`MAX_GRID_BITS`]. `octowrap reconstruct -o x.mrq` and the Python package's `save` use it.
pub fn reconstruction_grid_bits(finest: usize) -> u32 {
    let finest = u32::try_from(finest).unwrap_or(u32::MAX);
    finest.saturating_add(GRID_STEPS_PER_FINEST_VOXEL_LOG2).clamp(1, MAX_GRID_BITS)
}

/// How vertex positions are stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Quantization {
    /// Exactly, as IEEE-754 binary64 (lossless, large).
    Exact,
    /// On a grid of `2^bits` steps across the octree cube (or across the bounding box's longest
    /// edge when the hierarchy has no cube). `1..=28`.
    Bits(u32),
    /// On a grid with this step in world units, anchored at the cube's (or bounding box's) minimum.
    Step(f64),
}

/// Encoder options. Defaults: 16-bit grid, zstd level 19, empty metadata.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct EncodeOptions {
    /// How positions are stored (default `Bits(16)`).
    pub quantization: Quantization,
    /// zstd compression level, 1..=22 (default 19).
    pub zstd_level: i32,
    /// Units, source and further key-value pairs to record.
    pub metadata: Metadata,
    /// Format version to write, 2 to 5 (default 4). Version 3 codes lattice refinements in mode 3
    /// (spec §5.9, §6.8: vertices numbered by first use, integer geometry from the parent), which
    /// decodes faster; version 2 codes them in mode 2 (§5.7, §6.2-§6.6); version 4 adds value
    /// blocks (§6.9); version 5 stores every level in chunks (§11).
    pub version: u16,
    /// Version 5: level `k`'s chunk cells have depth `k - chunk_shift` (at least 0), so that a
    /// chunk holds some `4^chunk_shift` faces (default [`CHUNK_SHIFT`]).
    pub chunk_shift: u32,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        Self {
            quantization: Quantization::Bits(16),
            zstd_level: 19,
            metadata: Metadata::default(),
            version: DEFAULT_VERSION,
            chunk_shift: CHUNK_SHIFT,
        }
    }
}

impl EncodeOptions {
    /// Options with the given quantization and the other defaults.
    pub fn with_quantization(quantization: Quantization) -> Self {
        Self { quantization, ..Self::default() }
    }
}

/// Decoder options.
#[derive(Clone, Copy, Debug, Default)]
#[non_exhaustive]
pub struct DecodeOptions {
    /// Limits checked before allocating.
    pub limits: Limits,
    /// Decode levels `0..=k` only (`None`: all). The rest of the input is not read.
    pub max_level: Option<u32>,
}

impl DecodeOptions {
    /// Options decoding levels `0..=k` only.
    pub fn up_to(k: u32) -> Self {
        Self { max_level: Some(k), ..Self::default() }
    }
}

/// A decoded file: its description and the levels asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct MrqFile {
    /// The preamble's description of the whole file.
    pub info: FileInfo,
    /// The decoded levels (`0..=max_level`).
    pub hierarchy: Hierarchy,
}

/// Per-level sizes, for reports and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LevelStats {
    /// Level coding mode (0 base, 1 generic, 2 lattice).
    pub mode: u8,
    /// The block's `predictor` byte: bit 0 the lattice predictor, bit 1 line geometry (spec §4.1).
    pub predictor: u8,
    /// The block's `line_shift` (spec §6.6).
    pub line_shift: u32,
    /// Stored bytes of the level (one zstd frame).
    pub stored: usize,
    /// Bytes of the topology streams, zstd-compressed on their own.
    pub topology: usize,
    /// Bytes of the geometry stream, zstd-compressed on its own.
    pub geometry: usize,
}

/// `h` in the order of its decoded levels (spec §5.1, §5.4, §5.7, §5.9; Appendix A "Order") — the
/// order [`decode`] returns when `h` is encoded with `opts` — with the input positions (not
/// quantized). Encoding the result with `opts` gives the same bytes as encoding `h`.
pub fn canonical(h: &Hierarchy, opts: &EncodeOptions) -> Result<Hierarchy, EncodeError> {
    if opts.version >= container::CHUNKED_VERSION {
        return encoder::canonical_chunked(h, opts);
    }
    let mut out = Hierarchy { levels: Vec::with_capacity(h.levels.len()), cube: h.cube };
    encoder::encode_levels(h, opts, |enc| {
        let k = out.levels.len();
        let mut level = decoder::to_level(&enc.level, DVec3::ZERO, 1.0);
        let src = &h.levels[k].mesh.vertices.positions;
        level.mesh.vertices.positions = enc.vertex_old.iter().map(|&v| src[v as usize]).collect();
        out.levels.push(level);
        Ok(())
    })?;
    Ok(out)
}

/// Writes `h` to `path` with [`octowrap_fsutil::write_file`]: atomically through a temporary
/// file in the same folder, keeping a replaced file's mode and owner and a symbolic link's link.
pub fn write_path(path: &Path, h: &Hierarchy, opts: &EncodeOptions) -> Result<(), EncodeError> {
    let bytes = encode(h, opts)?;
    octowrap_fsutil::write_file(path, &octowrap_fsutil::WriteOptions::default(), |w| w.write_all(&bytes))
        .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| EncodeError::Io(e))
}

/// Reads an MRQ file from `path` (buffered, streaming: levels beyond `opts.max_level` are not read).
pub fn read_path(path: &Path, opts: &DecodeOptions) -> Result<MrqFile, DecodeError> {
    let f = std::fs::File::open(path)?;
    decode(std::io::BufReader::with_capacity(1 << 20, f), opts)
}

/// Whether `bytes` start with the MRQ magic number.
pub fn is_mrq(bytes: &[u8]) -> bool {
    bytes.len() >= 8 && bytes[..8] == container::MAGIC
}
