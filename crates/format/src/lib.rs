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
//! Decoding never panics on hostile input: every failure is an [`Error`] naming the region and
//! byte offset, and every allocation is checked against [`Limits`] first. Encoding is
//! deterministic: the same hierarchy and options give the same bytes.
//!
//! Face and vertex order: level 0 keeps the input order; finer levels are stored in the canonical
//! order of spec §5.7 (subfaces by parent and quadrant, then created faces; vertices by name). Use
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
//! * **One number per vertex on its prediction line** (spec §6.6, format version 2): the decoder
//!   derives a line for every vertex from the decoded parent (the base prediction and the parent
//!   face's normal); a vertex on it costs its parameter along it instead of three residuals.
//!   [`place_on_prediction_lines`] moves a hierarchy's vertices onto their lines along their tangent
//!   planes (a co-design with reconstruction, see `docs/format-notes.md`), so the file stores what
//!   the caller holds exactly; vertices elsewhere still round-trip within half a step.
//! * **Format version 3, for decoding speed** (spec §5.9, §6.8; [`EncodeOptions::version`]):
//!   lattice refinements in mode 3 keep mode 2's face streams but number vertices by first use (a
//!   key table, no sorted name set) and predict geometry in integers from the parent alone (a
//!   fixed-point line along the parent quad's exact normal, the parameter of the parent surface's
//!   point predicted); about 1.7 times fewer decoder instructions per vertex than version 2 at
//!   the same size (`tools/bench/RESULTS.md`); the default since 2026-12-01 (version 2 on request).
//! * **Byte planes + zstd**: residuals and symbols go to separate streams, least significant
//!   byte planes first, one zstd frame per level. Measured against the order-0 entropy of the
//!   residuals, zstd is within about 3 % on the bunny and dragon hierarchies, so an adaptive
//!   entropy coder would only pay with better context modelling.
//! * **Hostile input**: the container checks a header and table checksum before trusting any
//!   offset, each level's XXH3 before decompressing it, and [`Limits`] before allocating.

mod bytes;
mod container;
mod decode;
mod encode;
mod error;
mod fast;
mod lattice;
mod level;
mod lines;
pub mod synthetic;

use std::io::{Read, Write};
use std::path::Path;

use octowrap_mesh::{Aabb, DVec3, FaceList, FaceOrigin, Hierarchy, Level, LevelLattice, Mesh, Quadrant};
use xxhash_rust::xxh3::xxh3_64;

pub use container::Metadata;
pub use error::{EncodeError, Error, Where};
pub use lines::{LinePlacement, place_on_prediction_lines};

use container::{ENTRY_SIZE, FLAG_CUBE, FLAG_EXACT, FLAG_TIED, FileHeader, HEADER_SIZE, LevelEntry, MAGIC, Preamble};
use decode::{GridInfo, PlainLevel};
use encode::InputLevel;
use level::NO_PARENT;

/// The format version this crate writes by default (spec §3.1); [`EncodeOptions::version`] selects
/// another.
pub const FORMAT_VERSION: u16 = 3;
/// The newest format version this crate reads and writes; it reads every version from 1 to this.
pub const LATEST_FORMAT_VERSION: u16 = 3;
/// The finest grid a file may use: `2^28` steps across the cube.
pub const MAX_GRID_BITS: u32 = 28;

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
    /// Format version to write, 2 or 3 (default [`FORMAT_VERSION`], 3). Version 3 codes lattice
    /// refinements in mode 3 (spec §5.9, §6.8: vertices numbered by first use, integer geometry
    /// from the parent), which decodes faster; version 2 codes them in mode 2 (§5.3, §6.2-§6.6).
    pub version: u16,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        Self {
            quantization: Quantization::Bits(16),
            zstd_level: 19,
            metadata: Metadata::default(),
            version: FORMAT_VERSION,
        }
    }
}

impl EncodeOptions {
    /// Options with the given quantization and the other defaults.
    pub fn with_quantization(quantization: Quantization) -> Self {
        Self { quantization, ..Self::default() }
    }
}

/// Upper bounds a decoder checks before allocating. Defaults suit meshes of up to ~250 M vertices;
/// decoding takes a few hundred bytes of memory per vertex of the largest level (about 250 measured
/// on a lattice hierarchy: working arrays and the returned hierarchy), so lower `max_vertices` (or
/// use [`Limits::strict`]) for untrusted input on small machines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Limits {
    /// Most levels in a file (default 32).
    pub max_levels: u32,
    /// Largest stored or decompressed level in bytes (default 4 GiB).
    pub max_level_bytes: u64,
    /// Most vertices per level (default 2^28).
    pub max_vertices: u32,
    /// Most faces per level (default 2^28).
    pub max_faces: u32,
    /// Most face corners per level (default 2^30).
    pub max_corners: u32,
    /// Largest metadata block in bytes (default 16 MiB).
    pub max_metadata_bytes: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_levels: 32,
            max_level_bytes: 4 << 30,
            max_vertices: 1 << 28,
            max_faces: 1 << 28,
            max_corners: 1 << 30,
            max_metadata_bytes: 16 << 20,
        }
    }
}

impl Limits {
    /// Small limits for untrusted input in tests and fuzzing (64 MiB levels, 1 M elements).
    pub fn strict() -> Self {
        Self {
            max_levels: 24,
            max_level_bytes: 64 << 20,
            max_vertices: 1 << 20,
            max_faces: 1 << 20,
            max_corners: 1 << 22,
            max_metadata_bytes: 1 << 20,
        }
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

/// What the preamble of a file says about one level.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct LevelInfo {
    /// File offset of the stored bytes.
    pub offset: u64,
    /// Stored (zstd) size in bytes.
    pub stored_size: u64,
    /// Decompressed size in bytes.
    pub raw_size: u64,
    /// XXH3-64 of the stored bytes.
    pub checksum: u64,
    /// Vertices.
    pub vertex_count: u32,
    /// Faces.
    pub face_count: u32,
    /// Face corners.
    pub corner_count: u32,
}

/// What the preamble of a file says.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FileInfo {
    /// Format version.
    pub version: u16,
    /// `None` for exact files; else the grid.
    pub grid: Option<GridDescription>,
    /// The octree cube, when recorded.
    pub cube: Option<([f64; 3], [f64; 3])>,
    /// Metadata.
    pub metadata: MetadataInfo,
    /// One entry per level.
    pub levels: Vec<LevelInfo>,
    /// Bytes before the first level (header, table, metadata, checksum).
    pub preamble_size: u64,
}

/// The quantization grid of a file.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GridDescription {
    /// World position of grid point (0, 0, 0).
    pub origin: [f64; 3],
    /// Grid step in world units.
    pub step: f64,
    /// Bits (steps across the cube = 2^bits when tied).
    pub bits: u32,
    /// Whether the grid is tied to the cube.
    pub tied_to_cube: bool,
}

/// Metadata, for reports.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct MetadataInfo {
    /// Length unit.
    pub units: String,
    /// Source.
    pub source: String,
    /// Writer.
    pub generator: String,
    /// Further pairs.
    pub entries: Vec<(String, String)>,
}

impl FileInfo {
    fn from_preamble(p: &Preamble) -> Self {
        let h = &p.header;
        Self {
            version: h.version,
            grid: (h.flags & FLAG_EXACT == 0).then_some(GridDescription {
                origin: h.origin,
                step: h.step,
                bits: h.grid_bits,
                tied_to_cube: h.flags & FLAG_TIED != 0,
            }),
            cube: (h.flags & FLAG_CUBE != 0).then_some((h.cube_min, h.cube_max)),
            metadata: MetadataInfo {
                units: p.metadata.units.clone(),
                source: p.metadata.source.clone(),
                generator: p.metadata.generator.clone(),
                entries: p.metadata.entries.clone(),
            },
            levels: p
                .levels
                .iter()
                .map(|e| LevelInfo {
                    offset: e.offset,
                    stored_size: e.stored_size,
                    raw_size: e.raw_size,
                    checksum: e.checksum,
                    vertex_count: e.vertex_count,
                    face_count: e.face_count,
                    corner_count: e.corner_count,
                })
                .collect(),
            preamble_size: p.size(),
        }
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

struct Grid {
    exact: bool,
    tied: bool,
    bits: u32,
    origin: DVec3,
    step: f64,
}

impl Grid {
    /// Grid coordinates of `p`, rounded to the nearest grid point (not range-checked).
    fn quantize(&self, p: DVec3) -> DVec3 {
        ((p - self.origin) / self.step).round()
    }

    /// The world position of grid point `q` (spec §6.7), as the decoder computes it.
    fn position(&self, q: [i64; 3]) -> DVec3 {
        self.origin + DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) * self.step
    }
}

fn choose_grid(h: &Hierarchy, q: Quantization) -> Result<Grid, EncodeError> {
    let exact = Grid { exact: true, tied: false, bits: 0, origin: DVec3::ZERO, step: 0.0 };
    let bounds = || {
        let mut b = Aabb::EMPTY;
        for l in &h.levels {
            for p in &l.mesh.vertices.positions {
                b.grow(*p);
            }
        }
        if b.is_empty() { Aabb { min: DVec3::ZERO, max: DVec3::ZERO } } else { b }
    };
    match q {
        Quantization::Exact => Ok(exact),
        Quantization::Bits(bits) => {
            if !(1..=MAX_GRID_BITS).contains(&bits) {
                return Err(EncodeError::Options(format!("quantization bits must be 1..={MAX_GRID_BITS}, got {bits}")));
            }
            if let Some(c) = h.cube.filter(|c| !c.is_empty() && c.size().max_element() > 0.0) {
                let edge = c.size().max_element();
                Ok(Grid { exact: false, tied: true, bits, origin: c.min, step: edge / f64::from(1u32 << bits) })
            } else {
                let b = bounds();
                let ext = b.size().max_element();
                let step = if ext > 0.0 { ext / f64::from((1u32 << bits) - 1).max(1.0) } else { 1.0 };
                Ok(Grid { exact: false, tied: false, bits, origin: b.min, step })
            }
        }
        Quantization::Step(step) => {
            if !(step.is_finite() && step > 0.0) {
                return Err(EncodeError::Options(format!("the step must be positive and finite, got {step}")));
            }
            let origin = h.cube.filter(|c| !c.is_empty()).map_or_else(|| bounds().min, |c| c.min);
            Ok(Grid { exact: false, tied: false, bits: 0, origin, step })
        }
    }
}

/// Fails unless `opts.version` is a version this crate writes (2 or 3).
fn check_version(opts: &EncodeOptions) -> Result<(), EncodeError> {
    if !(2..=LATEST_FORMAT_VERSION).contains(&opts.version) {
        return Err(EncodeError::Options(format!(
            "format version {} cannot be written (2..={LATEST_FORMAT_VERSION})",
            opts.version
        )));
    }
    Ok(())
}

/// Encodes `h` into a byte vector. See [`encode_to`].
pub fn encode(h: &Hierarchy, opts: &EncodeOptions) -> Result<Vec<u8>, EncodeError> {
    Ok(encode_inner(h, opts)?.0)
}

/// Encodes `h` and reports per-level sizes (for benchmarks).
pub fn encode_with_stats(h: &Hierarchy, opts: &EncodeOptions) -> Result<(Vec<u8>, Vec<LevelStats>), EncodeError> {
    encode_inner(h, opts)
}

/// Encodes `h` to any writer. The hierarchy's links are checked first; positions must be finite.
/// Level `k + 1` is stored in the canonical order of spec §5.7.
pub fn encode_to(w: &mut impl Write, h: &Hierarchy, opts: &EncodeOptions) -> Result<(), EncodeError> {
    w.write_all(&encode(h, opts)?)?;
    Ok(())
}

fn encode_levels(
    h: &Hierarchy,
    opts: &EncodeOptions,
    mut each: impl FnMut(&encode::Encoded) -> Result<(), EncodeError>,
) -> Result<Grid, EncodeError> {
    if h.levels.is_empty() {
        return Err(EncodeError::Empty);
    }
    if h.levels.len() > 32 {
        return Err(EncodeError::Unsupported { level: 32, reason: "more than 32 levels".into() });
    }
    h.check_links()?;
    check_version(opts)?;
    let grid = choose_grid(h, opts.quantization)?;
    let mut parent: Option<PlainLevel> = None;
    let mut parent_face_new: Vec<u32> = Vec::new();
    for k in 0..h.levels.len() {
        let input = input_level(h, k, &grid, &parent_face_new)?;
        let enc =
            encode::encode_level(k as u32, &input, parent.as_ref(), grid.exact, grid.tied, grid.bits, opts.version)?;
        each(&enc)?;
        parent_face_new = enc.face_new;
        parent = Some(enc.level);
    }
    Ok(grid)
}

/// Level `k` of `h` on plain arrays: positions quantized on `grid`, parents renumbered through
/// `parent_face_new` (the parent level's canonical face order).
fn input_level<'a>(
    h: &'a Hierarchy,
    k: usize,
    grid: &Grid,
    parent_face_new: &[u32],
) -> Result<InputLevel<'a>, EncodeError> {
    let l = &h.levels[k];
    let mesh = &l.mesh;
    mesh.check_indices().map_err(|source| EncodeError::Faces { level: k, source })?;
    if mesh.vertices.len() > u32::MAX as usize / 2 || mesh.faces.corner_count() > u32::MAX as usize / 2 {
        return Err(EncodeError::Unsupported { level: k, reason: "too many vertices or corners".into() });
    }
    let mut q = Vec::new();
    let mut exact = Vec::new();
    for (v, p) in mesh.vertices.positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(EncodeError::NonFinite { level: k, vertex: v });
        }
        if grid.exact {
            exact.push(p.to_array());
        } else {
            let g = grid.quantize(*p);
            if g.abs().max_element() > level::GRID_LIMIT as f64 {
                return Err(EncodeError::OutOfGrid { level: k, vertex: v });
            }
            q.push([g.x as i64, g.y as i64, g.z as i64]);
        }
    }
    let (parents, quadrants) = l
        .origins
        .iter()
        .map(|o| match *o {
            FaceOrigin::Subface { parent, quadrant } => (parent_face_new[parent as usize], quadrant.0),
            FaceOrigin::Created => (NO_PARENT, 0),
        })
        .unzip();
    Ok(InputLevel {
        offsets: mesh.faces.offsets(),
        indices: mesh.faces.indices(),
        parents,
        quadrants,
        slots: l.lattice.as_ref().map(|x| &x.face_slots[..]),
        corners: l.lattice.as_ref().map(|x| &x.vertex_corners[..]),
        q,
        exact,
        topology_only: false,
    })
}

fn encode_inner(h: &Hierarchy, opts: &EncodeOptions) -> Result<(Vec<u8>, Vec<LevelStats>), EncodeError> {
    let mut blocks = Vec::with_capacity(h.levels.len());
    let mut stats = Vec::with_capacity(h.levels.len());
    let grid = encode_levels(h, opts, |enc| {
        let stored = zstd::bulk::compress(&enc.payload, opts.zstd_level)?;
        let geo_start = enc.payload.len() - enc.split_bytes.1;
        let topology = zstd::bulk::compress(&enc.payload[..geo_start], opts.zstd_level)?.len();
        let geometry = zstd::bulk::compress(&enc.payload[geo_start..], opts.zstd_level)?.len();
        stats.push(LevelStats {
            mode: enc.payload[0],
            predictor: enc.predictor,
            line_shift: enc.line_shift,
            stored: stored.len(),
            topology,
            geometry,
        });
        let lv = &enc.level;
        let counts = (lv.q.len().max(lv.exact.len()) as u32, lv.parents.len() as u32, lv.indices.len() as u32);
        blocks.push((enc.payload.len() as u64, stored, counts));
        Ok(())
    })?;
    let metadata_bytes = container::to_bytes(&opts.metadata);
    let mut flags = 0;
    if h.cube.is_some() {
        flags |= FLAG_CUBE;
    }
    if grid.exact {
        flags |= FLAG_EXACT;
    }
    if grid.tied {
        flags |= FLAG_TIED;
    }
    let (cube_min, cube_max) = h.cube.map_or(([0.0; 3], [0.0; 3]), |c| (c.min.to_array(), c.max.to_array()));
    let header = FileHeader {
        magic: MAGIC,
        version: opts.version,
        header_size: HEADER_SIZE as u16,
        flags,
        level_count: blocks.len() as u32,
        grid_bits: grid.bits,
        origin: grid.origin.to_array(),
        step: grid.step,
        cube_min,
        cube_max,
        metadata_size: u32::try_from(metadata_bytes.len())
            .map_err(|_| EncodeError::Options("metadata larger than 4 GiB".into()))?,
        reserved: 0,
    };
    let mut offset = (HEADER_SIZE + ENTRY_SIZE * blocks.len() + metadata_bytes.len() + 8) as u64;
    let mut levels = Vec::with_capacity(blocks.len());
    for (raw, stored, (nv, nf, nc)) in &blocks {
        levels.push(LevelEntry {
            offset,
            stored_size: stored.len() as u64,
            raw_size: *raw,
            checksum: xxh3_64(stored),
            vertex_count: *nv,
            face_count: *nf,
            corner_count: *nc,
            reserved: 0,
        });
        offset += stored.len() as u64;
    }
    let pre = Preamble { header, levels, metadata: opts.metadata.clone() };
    let mut out = pre.to_bytes();
    for (_, stored, _) in blocks {
        out.extend(stored);
    }
    Ok((out, stats))
}

/// Reads `n` bytes without trusting `n` for the allocation: the buffer grows with the input.
fn read_vec(r: &mut impl Read, n: u64, offset: u64, what: &str) -> Result<Vec<u8>, Error> {
    let mut v = Vec::with_capacity(n.min(1 << 20) as usize);
    r.take(n).read_to_end(&mut v)?;
    if (v.len() as u64) < n {
        return Err(Error::Truncated { offset, what: what.to_owned(), needed: n, got: v.len() as u64 });
    }
    Ok(v)
}

/// [`read_vec`] into a reused buffer.
fn read_into(r: &mut impl Read, buf: &mut Vec<u8>, n: u64, offset: u64, what: &str) -> Result<(), Error> {
    buf.clear();
    buf.reserve(n.min(1 << 20) as usize);
    r.take(n).read_to_end(buf)?;
    if (buf.len() as u64) < n {
        return Err(Error::Truncated { offset, what: what.to_owned(), needed: n, got: buf.len() as u64 });
    }
    Ok(())
}

fn read_preamble(r: &mut impl Read, limits: &Limits) -> Result<Preamble, Error> {
    let mut head = [0u8; HEADER_SIZE];
    // A short file that does not even start with the magic is not an MRQ file.
    let mut got = 0;
    while got < HEADER_SIZE {
        match r.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    let m = got.min(8);
    if head[..m] != MAGIC[..m] {
        return Err(Error::BadMagic { found: head[..m].to_vec() });
    }
    if got < HEADER_SIZE {
        return Err(Error::Truncated {
            offset: 0,
            what: "file header".into(),
            needed: HEADER_SIZE as u64,
            got: got as u64,
        });
    }
    let header = container::parse_header(&head, limits)?;
    let rest_len = ENTRY_SIZE as u64 * u64::from(header.level_count) + u64::from(header.metadata_size) + 8;
    let rest = read_vec(r, rest_len, HEADER_SIZE as u64, "level table, metadata and preamble checksum")?;
    container::parse_rest(header, &head, &rest, limits)
}

/// Reads only the preamble: levels, sizes, counts, quantization, metadata.
pub fn read_info(mut r: impl Read, limits: &Limits) -> Result<FileInfo, Error> {
    Ok(FileInfo::from_preamble(&read_preamble(&mut r, limits)?))
}

/// Buffers a thread's decodes share: the zstd context, the stored and decompressed bytes of a
/// level, and the level decoder's arrays. Kept between calls unless they grew beyond
/// [`KEPT_BUFFER_BYTES`], so that decoding many small files does not allocate (and fault in) the
/// same memory again and again.
#[derive(Default)]
struct DecodeBuffers {
    unzstd: Option<zstd::bulk::Decompressor<'static>>,
    stored: Vec<u8>,
    payload: Vec<u8>,
    level: decode::Scratch,
}

/// The most buffer memory a thread keeps between decodes.
const KEPT_BUFFER_BYTES: usize = 64 << 20;

thread_local! {
    static BUFFERS: std::cell::RefCell<Option<DecodeBuffers>> = const { std::cell::RefCell::new(None) };
}

/// Decodes levels `0..=opts.max_level` (all by default) from `r`, reading the input in order and
/// nothing beyond the last level asked for.
///
/// One call decodes on the calling thread. The thread keeps the decoder's working buffers (up to
/// 64 MiB) for its next call; the returned hierarchy is always freshly allocated.
pub fn decode(mut r: impl Read, opts: &DecodeOptions) -> Result<MrqFile, Error> {
    let pre = read_preamble(&mut r, &opts.limits)?;
    let mut buffers = BUFFERS.with(|b| b.borrow_mut().take()).unwrap_or_default();
    let out = decode_levels(&mut r, &pre, opts, &mut buffers);
    let kept = buffers.stored.capacity() + buffers.payload.capacity() + buffers.level.capacity_bytes();
    if kept <= KEPT_BUFFER_BYTES {
        BUFFERS.with(|b| *b.borrow_mut() = Some(buffers));
    }
    Ok(MrqFile { info: FileInfo::from_preamble(&pre), hierarchy: out? })
}

/// The levels of [`decode`], after the preamble.
fn decode_levels(
    r: &mut impl Read,
    pre: &Preamble,
    opts: &DecodeOptions,
    buffers: &mut DecodeBuffers,
) -> Result<Hierarchy, Error> {
    let n = pre.levels.len() as u32;
    let last = match opts.max_level {
        Some(k) if k >= n => return Err(Error::NoSuchLevel { requested: k, available: n }),
        Some(k) => k,
        None => n - 1,
    };
    let h = &pre.header;
    let gi = GridInfo {
        exact: h.flags & FLAG_EXACT != 0,
        tied: h.flags & FLAG_TIED != 0,
        bits: h.grid_bits,
        version: h.version,
    };
    let origin = DVec3::from_array(h.origin);
    let mut out = Hierarchy {
        levels: Vec::with_capacity(last as usize + 1),
        cube: (h.flags & FLAG_CUBE != 0)
            .then(|| Aabb { min: DVec3::from_array(h.cube_min), max: DVec3::from_array(h.cube_max) }),
    };
    let mut parent: Option<PlainLevel> = None;
    // One decompression context for all levels (its buffers are reused).
    let unzstd = match &mut buffers.unzstd {
        Some(z) => z,
        none => none.insert(zstd::bulk::Decompressor::new().map_err(|x| Error::Zstd {
            level: 0,
            offset: 0,
            reason: x.to_string(),
        })?),
    };
    for k in 0..=last {
        let e = &pre.levels[k as usize];
        let stored = &mut buffers.stored;
        read_into(r, stored, e.stored_size, e.offset, &format!("level {k}"))?;
        let computed = xxh3_64(stored);
        if computed != e.checksum {
            return Err(Error::ChecksumMismatch {
                place: Where::Level(k),
                offset: e.offset,
                stored: e.checksum,
                computed,
            });
        }
        let zerr = |reason: String| Error::Zstd { level: k, offset: e.offset, reason };
        match zstd::zstd_safe::get_frame_content_size(stored) {
            Ok(Some(size)) if size == e.raw_size => {}
            Ok(Some(size)) => {
                return Err(zerr(format!("frame holds {size} bytes, the level table says {}", e.raw_size)));
            }
            Ok(None) => return Err(zerr("the frame does not state its content size".into())),
            Err(_) => return Err(zerr("not a zstd frame".into())),
        }
        // The size is checked against the limits (level table) and stated by the frame.
        let payload = &mut buffers.payload;
        payload.clear();
        payload.reserve(e.raw_size as usize);
        unzstd.decompress_to_buffer(stored.as_slice(), payload).map_err(|x| zerr(x.to_string()))?;
        if payload.len() as u64 != e.raw_size {
            return Err(zerr(format!("decompressed to {} bytes, the level table says {}", payload.len(), e.raw_size)));
        }
        let lv = decode::decode_level(k, payload, e, parent.as_ref(), gi, &mut buffers.level)?;
        // The parent is no longer needed: its arrays move into the output.
        if let Some(p) = parent.replace(lv) {
            out.levels.push(into_level(p, origin, h.step));
        }
    }
    out.levels.extend(parent.map(|p| into_level(p, origin, h.step)));
    Ok(out)
}

/// Decodes a whole file held in memory, with [`Limits::strict`]-free default limits.
pub fn decode_bytes(bytes: &[u8], opts: &DecodeOptions) -> Result<MrqFile, Error> {
    decode(bytes, opts)
}

fn to_level(lv: &PlainLevel, origin: DVec3, step: f64) -> Level {
    into_level(lv.clone(), origin, step)
}

/// A decoded level as a [`Level`]: grid coordinates to positions (spec §6.7), arrays moved where
/// the types allow.
fn into_level(lv: PlainLevel, origin: DVec3, step: f64) -> Level {
    let positions: Vec<DVec3> = if lv.exact.is_empty() && !lv.q.is_empty() {
        lv.q.iter().map(|q| origin + DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) * step).collect()
    } else {
        lv.exact.iter().map(|p| DVec3::from_array(*p)).collect()
    };
    let quads = lv.offsets.iter().enumerate().all(|(f, &o)| o as usize == 4 * f);
    let faces = if quads {
        let q: Vec<[u32; 4]> = lv.indices.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
        FaceList::from_quads(&q)
    } else {
        let mut faces = FaceList::with_capacity(lv.parents.len(), lv.indices.len());
        for w in lv.offsets.windows(2) {
            faces.push(&lv.indices[w[0] as usize..w[1] as usize]);
        }
        faces
    };
    let origins = lv
        .parents
        .iter()
        .zip(&lv.quadrants)
        .map(|(&p, &q)| {
            if p == NO_PARENT { FaceOrigin::Created } else { FaceOrigin::Subface { parent: p, quadrant: Quadrant(q) } }
        })
        .collect();
    let lattice = match (lv.slots, lv.corners) {
        (Some(face_slots), Some(vertex_corners)) => Some(LevelLattice { face_slots, vertex_corners }),
        _ => None,
    };
    Level { mesh: Mesh { vertices: octowrap_mesh::PointCloud::from_positions(positions), faces }, origins, lattice }
}

/// `h` in the canonical order of spec §5.7 — the order [`decode`] returns when `h` is encoded
/// with `opts` — with the input positions (not quantized). Encoding the result with `opts` gives
/// the same bytes as encoding `h`.
pub fn canonical(h: &Hierarchy, opts: &EncodeOptions) -> Result<Hierarchy, EncodeError> {
    let mut out = Hierarchy { levels: Vec::with_capacity(h.levels.len()), cube: h.cube };
    encode_levels(h, opts, |enc| {
        let k = out.levels.len();
        let mut level = to_level(&enc.level, DVec3::ZERO, 1.0);
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
pub fn read_path(path: &Path, opts: &DecodeOptions) -> Result<MrqFile, Error> {
    let f = std::fs::File::open(path)?;
    decode(std::io::BufReader::with_capacity(1 << 20, f), opts)
}

/// Whether `bytes` start with the MRQ magic number.
pub fn is_mrq(bytes: &[u8]) -> bool {
    bytes.len() >= 8 && bytes[..8] == MAGIC
}

/// Helpers for fuzzing and conformance tests: rewrite a level's decompressed payload and reseal
/// the file (recompress, fix sizes, offsets and checksums), so that mutations reach the level
/// decoder instead of stopping at a checksum.
#[doc(hidden)]
pub mod fuzzing {
    use super::{ENTRY_SIZE, HEADER_SIZE, Limits, Preamble, container, read_preamble};

    /// Decompressed payload of every level of a valid file.
    pub fn payloads(bytes: &[u8]) -> Option<Vec<Vec<u8>>> {
        let mut r = bytes;
        let pre = read_preamble(&mut r, &Limits::default()).ok()?;
        pre.levels
            .iter()
            .map(|e| {
                let s = bytes.get(e.offset as usize..(e.offset + e.stored_size) as usize)?;
                zstd::bulk::decompress(s, e.raw_size as usize).ok()
            })
            .collect()
    }

    /// Rebuilds a file from `bytes`' preamble and the given level payloads (table counts kept
    /// unless `counts` overrides them as `(vertices, faces, corners)` per level).
    pub fn reseal(bytes: &[u8], payloads: &[Vec<u8>], counts: Option<&[(u32, u32, u32)]>) -> Option<Vec<u8>> {
        let mut r = bytes;
        let mut pre: Preamble = read_preamble(&mut r, &Limits::default()).ok()?;
        if payloads.len() != pre.levels.len() {
            return None;
        }
        let mut offset = (HEADER_SIZE + ENTRY_SIZE * pre.levels.len()) as u64 + u64::from(pre.header.metadata_size) + 8;
        let mut stored_all = Vec::new();
        for (k, (e, p)) in pre.levels.iter_mut().zip(payloads).enumerate() {
            let stored = zstd::bulk::compress(p, 1).ok()?;
            e.offset = offset;
            e.stored_size = stored.len() as u64;
            e.raw_size = p.len() as u64;
            e.checksum = xxhash_rust::xxh3::xxh3_64(&stored);
            if let Some(c) = counts {
                (e.vertex_count, e.face_count, e.corner_count) = c[k];
            }
            offset += stored.len() as u64;
            stored_all.push(stored);
        }
        let _ = container::HEADER_SIZE;
        let mut out = pre.to_bytes();
        for s in stored_all {
            out.extend(s);
        }
        Some(out)
    }
}

#[doc(hidden)]
pub mod tamper {
    //! Byte surgery for building invalid conformance files.

    /// Recomputes the preamble checksum of `bytes` in place (after editing header, table or
    /// metadata bytes). Returns `false` when the preamble cannot be located.
    pub fn fix_preamble_checksum(bytes: &mut [u8]) -> bool {
        if bytes.len() < super::HEADER_SIZE {
            return false;
        }
        let levels = u32::from_le_bytes(bytes[16..20].try_into().expect("4 bytes")) as usize;
        let meta = u32::from_le_bytes(bytes[104..108].try_into().expect("4 bytes")) as usize;
        let end = super::HEADER_SIZE + super::ENTRY_SIZE * levels + meta;
        if bytes.len() < end + 8 {
            return false;
        }
        let sum = xxhash_rust::xxh3::xxh3_64(&bytes[..end]);
        bytes[end..end + 8].copy_from_slice(&sum.to_le_bytes());
        true
    }
}
