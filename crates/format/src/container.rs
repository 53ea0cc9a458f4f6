//! The container of spec §3 File structure: the file header (§3.1), level table (§3.2), metadata
//! block (§3.3) and preamble checksum (§3.4), and what they say about a file ([`FileInfo`]).
//!
//! The header and table entries are serialized with bincode 2.0.1 (fixed-width little-endian
//! integers, arrays without length prefixes), whose bytes spec §3 defines independently; the unit
//! test `header_bytes_match_the_spec` checks that the two agree byte for byte.

use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::xxh3_64;

use crate::error::{DecodeError, Where};

/// The eight bytes every MRQ file starts with.
pub const MAGIC: [u8; 8] = [0x89, b'M', b'R', b'Q', 0x0D, 0x0A, 0x1A, 0x0A];
/// Size of the file header in bytes.
pub const HEADER_SIZE: usize = 112;
/// Size of one level-table entry in bytes.
pub const ENTRY_SIZE: usize = 48;
/// Size of one chunk-index entry in bytes (version 5, spec §11.2).
pub const CHUNK_ENTRY_SIZE: usize = 88;
/// The first version whose levels are stored as chunks (spec §11).
pub const CHUNKED_VERSION: u16 = 5;
/// `parent` of a chunk that refines no chunk (spec §11.2).
pub const NO_CHUNK: u32 = u32::MAX;

/// Header flag: the file records the octree cube (`cube_min`, `cube_max` are meaningful).
pub const FLAG_CUBE: u32 = 1;
/// Header flag: positions are stored exactly as IEEE-754 binary64 (no quantization).
pub const FLAG_EXACT: u32 = 2;
/// Header flag: the grid is tied to the cube (`origin = cube_min`, `step = edge / 2^grid_bits`).
pub const FLAG_TIED: u32 = 4;
const KNOWN_FLAGS: u32 = FLAG_CUBE | FLAG_EXACT | FLAG_TIED;

/// The file header (spec §3.1), field names as in the spec.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileHeader {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// Format version; this crate writes and reads [`crate::FORMAT_VERSION`].
    pub version: u16,
    /// [`HEADER_SIZE`].
    pub header_size: u16,
    /// `FLAG_*` bits; the others are reserved and must be zero.
    pub flags: u32,
    /// Number of levels (at least 1).
    pub level_count: u32,
    /// Grid resolution in bits when the grid is tied to the cube (informative otherwise); 0 for
    /// exact files.
    pub grid_bits: u32,
    /// World position of grid coordinate `(0, 0, 0)`.
    pub origin: [f64; 3],
    /// Grid step in world units (0 for exact files).
    pub step: f64,
    /// Octree cube, smallest corner.
    pub cube_min: [f64; 3],
    /// Octree cube, largest corner.
    pub cube_max: [f64; 3],
    /// Size in bytes of the metadata block.
    pub metadata_size: u32,
    /// Version 5: the number of chunk-index entries (spec §11.2); reserved (zero) before.
    pub chunk_count: u32,
}

/// One level-table entry (spec §3.2).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LevelEntry {
    /// File offset of the level's stored bytes.
    pub offset: u64,
    /// Size of the stored (zstd) bytes.
    pub stored_size: u64,
    /// Size of the decompressed level block.
    pub raw_size: u64,
    /// XXH3-64 (seed 0) of the stored bytes.
    pub checksum: u64,
    /// Vertices of the level.
    pub vertex_count: u32,
    /// Faces of the level.
    pub face_count: u32,
    /// Face corners of the level (sum of face sizes).
    pub corner_count: u32,
    /// Version 5: the depth of the level's chunk cells (spec §11.1); reserved (zero) before.
    pub cell_depth: u32,
}

/// One chunk-index entry (spec §11.2, version 5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChunkEntry {
    /// File offset of the chunk's stored bytes.
    pub offset: u64,
    /// XXH3-64 (seed 0) of the stored bytes.
    pub checksum: u64,
    /// Size of the stored (zstd) bytes.
    pub stored_size: u32,
    /// Size of the decompressed level block.
    pub raw_size: u32,
    /// The chunk of the level above that this one refines, or [`NO_CHUNK`].
    pub parent: u32,
    /// The level.
    pub level: u16,
    /// Reserved, must be zero.
    pub reserved: u16,
    /// The chunk's cell at its level's `cell_depth`.
    pub cell: [u32; 3],
    /// Vertices of the chunk.
    pub vertex_count: u32,
    /// Faces of the chunk.
    pub face_count: u32,
    /// Corners of the chunk.
    pub corner_count: u32,
    /// Smallest corner of the box around the chunk's vertices (rounded down to binary32).
    pub bbox_min: [f32; 3],
    /// Largest corner (rounded up).
    pub bbox_max: [f32; 3],
    /// Geometric error in model units: the chunk surface's certified Hausdorff distance to the
    /// finest level over the chunk's cell; negative when the writer did not measure it.
    pub geometric_error: f32,
    /// Reserved, must be zero.
    pub reserved2: u32,
}

/// The metadata block (spec §3.3).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Metadata {
    /// Length unit of positions (`"m"`, `"mm"`, ...; empty when unknown).
    pub units: String,
    /// Where the data came from (a file name, a scan id; free text).
    pub source: String,
    /// The program that wrote the file.
    pub generator: String,
    /// Further key-value pairs, in the order given.
    pub entries: Vec<(String, String)>,
}

/// The [`Metadata::entries`] key holding the coordinate reference system of the positions: OGC
/// WKT, or `EPSG:N`. Without it, positions are in a local frame.
pub const CRS_KEY: &str = "crs";

fn config() -> impl bincode::config::Config {
    // The limit bounds what a hostile length prefix can make bincode allocate.
    bincode::config::standard().with_little_endian().with_fixed_int_encoding().with_limit::<{ 1 << 26 }>()
}

/// Serializes a header, table entry or metadata block to its spec bytes.
pub fn to_bytes<T: Serialize>(v: &T) -> Vec<u8> {
    bincode::serde::encode_to_vec(v, config()).expect("plain structs always serialize")
}

pub(crate) fn from_bytes<T: serde::de::DeserializeOwned>(
    b: &[u8],
    offset: u64,
    what: &'static str,
) -> Result<T, DecodeError> {
    match bincode::serde::decode_from_slice::<T, _>(b, config()) {
        Ok((v, used)) if used == b.len() => Ok(v),
        Ok((_, used)) => Err(DecodeError::Invalid {
            place: Where::Preamble,
            offset: offset + used as u64,
            what,
            reason: format!("{} bytes left over", b.len() - used),
        }),
        Err(e) => Err(DecodeError::Invalid { place: Where::Preamble, offset, what, reason: e.to_string() }),
    }
}

/// Everything the preamble says.
#[derive(Clone, Debug, PartialEq)]
pub struct Preamble {
    /// The header.
    pub header: FileHeader,
    /// One entry per level.
    pub levels: Vec<LevelEntry>,
    /// Version 5: the chunk index (empty before).
    pub chunks: Vec<ChunkEntry>,
    /// The metadata block.
    pub metadata: Metadata,
}

impl Preamble {
    /// Size in bytes of the whole preamble (header, table, chunk index, metadata, checksum).
    pub fn size(&self) -> u64 {
        HEADER_SIZE as u64
            + ENTRY_SIZE as u64 * self.levels.len() as u64
            + CHUNK_ENTRY_SIZE as u64 * self.chunks.len() as u64
            + u64::from(self.header.metadata_size)
            + 8
    }

    /// The preamble's bytes, checksum included. `header.metadata_size` must already be right.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = to_bytes(&self.header);
        for e in &self.levels {
            out.extend(to_bytes(e));
        }
        for c in &self.chunks {
            out.extend(to_bytes(c));
        }
        out.extend(to_bytes(&self.metadata));
        let sum = xxh3_64(&out);
        out.extend(sum.to_le_bytes());
        out
    }
}

/// Parses and checks the fixed header (the first [`HEADER_SIZE`] bytes).
pub fn parse_header(b: &[u8; HEADER_SIZE], limits: &crate::Limits) -> Result<FileHeader, DecodeError> {
    if b[..8] != MAGIC {
        return Err(DecodeError::BadMagic { found: b[..8].to_vec() });
    }
    let h: FileHeader = from_bytes(b, 0, "file header")?;
    if !(1..=crate::FORMAT_VERSION).contains(&h.version) {
        return Err(DecodeError::UnsupportedVersion { found: h.version });
    }
    let bad = |offset: u64, reason: String| DecodeError::Invalid {
        place: Where::Preamble,
        offset,
        what: "file header",
        reason,
    };
    if usize::from(h.header_size) != HEADER_SIZE {
        return Err(bad(10, format!("header_size is {}, must be {HEADER_SIZE}", h.header_size)));
    }
    if h.flags & !KNOWN_FLAGS != 0 {
        return Err(bad(12, format!("reserved flag bits set: {:#x}", h.flags & !KNOWN_FLAGS)));
    }
    if h.level_count == 0 {
        return Err(bad(16, "level_count is 0".into()));
    }
    if h.level_count > limits.max_levels {
        return Err(DecodeError::LimitExceeded {
            place: Where::Preamble,
            offset: 16,
            what: "level_count",
            value: h.level_count.into(),
            limit: limits.max_levels.into(),
        });
    }
    if h.version < CHUNKED_VERSION && h.chunk_count != 0 {
        return Err(bad(108, "reserved field is not zero".into()));
    }
    if h.chunk_count > limits.max_chunks {
        return Err(DecodeError::LimitExceeded {
            place: Where::Preamble,
            offset: 108,
            what: "chunk_count",
            value: h.chunk_count.into(),
            limit: limits.max_chunks.into(),
        });
    }
    if !h.origin.iter().chain(&h.cube_min).chain(&h.cube_max).chain([&h.step]).all(|v| v.is_finite()) {
        return Err(bad(24, "origin, step or cube is not finite".into()));
    }
    let exact = h.flags & FLAG_EXACT != 0;
    if exact {
        if h.step != 0.0 || h.grid_bits != 0 || h.flags & FLAG_TIED != 0 {
            return Err(bad(20, "an exact file must have step 0, grid_bits 0 and no tied grid".into()));
        }
    } else {
        if h.step <= 0.0 {
            return Err(bad(48, format!("step must be positive, found {}", h.step)));
        }
        if h.grid_bits > crate::MAX_GRID_BITS {
            return Err(bad(20, format!("grid_bits {} exceeds {}", h.grid_bits, crate::MAX_GRID_BITS)));
        }
    }
    if h.flags & FLAG_TIED != 0 && h.flags & FLAG_CUBE == 0 {
        return Err(bad(12, "the grid is tied to a cube the file does not record".into()));
    }
    if h.flags & FLAG_CUBE == 0 && h.cube_min.iter().chain(&h.cube_max).any(|x| x.to_bits() != 0) {
        return Err(bad(56, "cube fields must be zero when no cube is recorded".into()));
    }
    if h.metadata_size > limits.max_metadata_bytes {
        return Err(DecodeError::LimitExceeded {
            place: Where::Preamble,
            offset: 104,
            what: "metadata_size",
            value: h.metadata_size.into(),
            limit: limits.max_metadata_bytes.into(),
        });
    }
    Ok(h)
}

/// Parses and checks the level table and metadata (`rest` = the bytes after the header up to and
/// including the preamble checksum), given the header and the header bytes.
pub fn parse_rest(
    header: FileHeader,
    header_bytes: &[u8],
    rest: &[u8],
    limits: &crate::Limits,
) -> Result<Preamble, DecodeError> {
    let n = header.level_count as usize;
    let index_end = n * ENTRY_SIZE;
    let table_end = index_end + header.chunk_count as usize * CHUNK_ENTRY_SIZE;
    let meta_end = table_end + header.metadata_size as usize;
    debug_assert_eq!(rest.len(), meta_end + 8);
    let stored = u64::from_le_bytes(rest[meta_end..].try_into().expect("8 bytes"));
    let computed = {
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        h.update(header_bytes);
        h.update(&rest[..meta_end]);
        h.digest()
    };
    if stored != computed {
        return Err(DecodeError::ChecksumMismatch { place: Where::Preamble, offset: 0, stored, computed });
    }
    let preamble_size = (HEADER_SIZE + meta_end + 8) as u64;
    let chunked = header.version >= CHUNKED_VERSION;
    let mut levels = Vec::with_capacity(n);
    let mut next = preamble_size;
    for k in 0..n {
        let at = HEADER_SIZE + k * ENTRY_SIZE;
        let e: LevelEntry = from_bytes(&rest[k * ENTRY_SIZE..(k + 1) * ENTRY_SIZE], at as u64, "level table entry")?;
        let bad = |off: usize, reason: String| DecodeError::Invalid {
            place: Where::Preamble,
            offset: (at + off) as u64,
            what: "level table entry",
            reason: format!("level {k}: {reason}"),
        };
        if e.offset != next {
            return Err(bad(0, format!("offset is {}, levels must follow each other: expected {next}", e.offset)));
        }
        if !chunked && e.cell_depth != 0 {
            return Err(bad(44, "reserved field is not zero".into()));
        }
        if chunked {
            let prev = levels.last().map_or(0, |p: &LevelEntry| p.cell_depth);
            let most = if k == 0 { 0 } else { (k as u32 - 1).min(crate::topology::slots::MAX_LATTICE_DEPTH) };
            if e.cell_depth < prev || e.cell_depth > most.max(prev) {
                return Err(bad(
                    44,
                    format!("cell_depth is {}, must be in {prev}..={} (spec §11.1)", e.cell_depth, most.max(prev)),
                ));
            }
        }
        let limit = |off: usize, what: &'static str, value: u64, limit: u64| {
            if value > limit {
                Err(DecodeError::LimitExceeded {
                    place: Where::Preamble,
                    offset: (at + off) as u64,
                    what,
                    value,
                    limit,
                })
            } else {
                Ok(())
            }
        };
        limit(8, "stored_size", e.stored_size, limits.max_level_bytes)?;
        limit(16, "raw_size", e.raw_size, limits.max_level_bytes)?;
        limit(32, "vertex_count", e.vertex_count.into(), limits.max_vertices.into())?;
        limit(36, "face_count", e.face_count.into(), limits.max_faces.into())?;
        limit(40, "corner_count", e.corner_count.into(), limits.max_corners.into())?;
        next = e.offset + e.stored_size;
        levels.push(e);
    }
    let chunks = if chunked {
        crate::chunked::parse_index(&rest[index_end..table_end], HEADER_SIZE + index_end, &levels, limits)?
    } else {
        Vec::new()
    };
    let metadata: Metadata = from_bytes(&rest[table_end..meta_end], (HEADER_SIZE + table_end) as u64, "metadata")?;
    Ok(Preamble { header, levels, chunks, metadata })
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
    /// Version 5: the depth of the level's chunk cells (0 before).
    pub cell_depth: u32,
    /// Version 5: the level's chunks (1 before).
    pub chunk_count: u32,
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
    /// The description of a checked preamble.
    pub fn from_preamble(p: &Preamble) -> Self {
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
                .enumerate()
                .map(|(k, e)| LevelInfo {
                    cell_depth: e.cell_depth,
                    chunk_count: if h.version >= CHUNKED_VERSION {
                        p.chunks.iter().filter(|c| usize::from(c.level) == k).count() as u32
                    } else {
                        1
                    },
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_bytes_match_the_spec() {
        let h = FileHeader {
            magic: MAGIC,
            version: 1,
            header_size: HEADER_SIZE as u16,
            flags: FLAG_CUBE | FLAG_TIED,
            level_count: 3,
            grid_bits: 12,
            origin: [1.0, -2.0, 0.5],
            step: 0.25,
            cube_min: [1.0, -2.0, 0.5],
            cube_max: [2.0, -1.0, 1.5],
            metadata_size: 40,
            chunk_count: 0,
        };
        // Written by hand from spec §3.1.
        let mut want = MAGIC.to_vec();
        want.extend(1u16.to_le_bytes());
        want.extend(112u16.to_le_bytes());
        want.extend(5u32.to_le_bytes());
        want.extend(3u32.to_le_bytes());
        want.extend(12u32.to_le_bytes());
        for v in [1.0f64, -2.0, 0.5, 0.25, 1.0, -2.0, 0.5, 2.0, -1.0, 1.5] {
            want.extend(v.to_le_bytes());
        }
        want.extend(40u32.to_le_bytes());
        want.extend(0u32.to_le_bytes());
        assert_eq!(to_bytes(&h), want);
        assert_eq!(want.len(), HEADER_SIZE);

        let e = LevelEntry {
            offset: 0x0102,
            stored_size: 7,
            raw_size: 9,
            checksum: 0xdead_beef,
            vertex_count: 4,
            face_count: 1,
            corner_count: 4,
            cell_depth: 0,
        };
        let mut want = Vec::new();
        for v in [0x0102u64, 7, 9, 0xdead_beef] {
            want.extend(v.to_le_bytes());
        }
        for v in [4u32, 1, 4, 0] {
            want.extend(v.to_le_bytes());
        }
        assert_eq!(to_bytes(&e), want);

        let m = Metadata {
            units: "m".into(),
            source: "ab".into(),
            generator: String::new(),
            entries: vec![("k".into(), "v".into())],
        };
        let mut want = Vec::new();
        want.extend(1u64.to_le_bytes());
        want.push(b'm');
        want.extend(2u64.to_le_bytes());
        want.extend(b"ab");
        want.extend(0u64.to_le_bytes());
        want.extend(1u64.to_le_bytes());
        want.extend(1u64.to_le_bytes());
        want.push(b'k');
        want.extend(1u64.to_le_bytes());
        want.push(b'v');
        assert_eq!(to_bytes(&m), want);
    }
}
