//! Spec §3 (file structure) in the order of §7.1, steps 1-5, with the limits of §7.2.

use super::chunks::{self, ChunkEntry};
use super::primitives::{Class, Result, fail, invalid, require};

/// §7.2: the reference decoder's default limits.
pub struct Limits {
    pub levels: u32,
    pub level_bytes: u64,
    pub vertices: u32,
    pub faces: u32,
    pub corners: u32,
    pub metadata_bytes: u32,
    /// Chunk-index entries per file (§11.2); the per-level bounds apply to each chunk.
    pub chunks: u32,
}

pub const DEFAULT_LIMITS: Limits = Limits {
    levels: 32,
    level_bytes: 4 << 30,
    vertices: 1 << 28,
    faces: 1 << 28,
    corners: 1 << 30,
    metadata_bytes: 16 << 20,
    chunks: 1 << 20,
};

/// §3.1 flags.
pub const CUBE: u32 = 1;
pub const EXACT: u32 = 2;
pub const TIED: u32 = 4;

/// §3.1: the file header.
#[derive(Clone, Debug)]
pub struct Header {
    pub version: u16,
    pub flags: u32,
    pub level_count: u32,
    pub grid_bits: u32,
    pub origin: [f64; 3],
    pub step: f64,
    pub cube_min: [f64; 3],
    pub cube_max: [f64; 3],
    pub metadata_size: u32,
    /// Version 5: the number of chunk-index entries (§11.2); 0 before.
    pub chunk_count: u32,
}

/// §3.2: one level table entry.
#[derive(Clone, Debug)]
pub struct Entry {
    pub offset: u64,
    pub stored_size: u64,
    pub raw_size: u64,
    pub checksum: u64,
    pub vertex_count: u32,
    pub face_count: u32,
    pub corner_count: u32,
    /// Version 5: the depth of the level's chunk cells (§11.1); 0 before.
    pub cell_depth: u32,
}

/// §3.3: the metadata block.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Metadata {
    pub units: String,
    pub source: String,
    pub generator: String,
    pub entries: Vec<(String, String)>,
}

/// §3: the preamble, checked.
pub struct Preamble {
    pub header: Header,
    pub entries: Vec<Entry>,
    /// Version 5: the chunk index (§11.2), in listing order.
    pub chunks: Vec<ChunkEntry>,
    pub metadata: Metadata,
}

/// §1.2: the little-endian integers and floats at byte `at`.
pub fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}
pub fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}
pub fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}
fn f64_at(b: &[u8], at: usize) -> f64 {
    f64::from_bits(u64_at(b, at))
}
fn f64x3_at(b: &[u8], at: usize) -> [f64; 3] {
    [f64_at(b, at), f64_at(b, at + 8), f64_at(b, at + 16)]
}

const MAGIC: [u8; 8] = [0x89, 0x4D, 0x52, 0x51, 0x0D, 0x0A, 0x1A, 0x0A];

/// §7.1 steps 1-5: magic, header, rest of the preamble, preamble checksum, level table and
/// metadata.
pub fn read_preamble(file: &[u8], limits: &Limits) -> Result<Preamble> {
    // Step 1 (§3.1): the magic, on the bytes the file has.
    let n = file.len().min(8);
    if file[..n] != MAGIC[..n] {
        return fail(Class::NotMrq, "bad magic");
    }
    // Step 2 (§3.1): the header.
    if file.len() < 112 {
        return fail(Class::Truncated, format!("the file ends inside the header (offset 0), {} bytes", file.len()));
    }
    let h = &file[..112];
    let header = Header {
        version: u16_at(h, 8),
        flags: u32_at(h, 12),
        level_count: u32_at(h, 16),
        grid_bits: u32_at(h, 20),
        origin: f64x3_at(h, 24),
        step: f64_at(h, 48),
        cube_min: f64x3_at(h, 56),
        cube_max: f64x3_at(h, 80),
        metadata_size: u32_at(h, 104),
        chunk_count: u32_at(h, 108),
    };
    if !(1..=5).contains(&header.version) {
        return fail(Class::UnsupportedVersion, format!("version {}", header.version));
    }
    require(u16_at(h, 10) == 112, || "header_size is not 112".into())?;
    require(header.flags & !7 == 0, || "reserved flag bits set".into())?;
    require(header.level_count >= 1, || "level_count 0".into())?;
    if header.level_count > limits.levels {
        return fail(Class::Limit, format!("level_count {} (offset 16)", header.level_count));
    }
    if header.metadata_size > limits.metadata_bytes {
        return fail(Class::Limit, format!("metadata_size {} (offset 104)", header.metadata_size));
    }
    // Before version 5 the field is reserved (§3.1), then it is a count within the limits (§7.2).
    require(header.version >= 5 || header.chunk_count == 0, || "chunk_count before version 5".into())?;
    if header.chunk_count > limits.chunks {
        return fail(Class::Limit, format!("chunk_count {} (offset 108)", header.chunk_count));
    }
    let finite = header.origin.iter().chain(&header.cube_min).chain(&header.cube_max).chain([&header.step]);
    require(finite.into_iter().all(|x| x.is_finite()), || "origin, step or cube not finite".into())?;
    let (exact, tied, cube) = (header.flags & EXACT != 0, header.flags & TIED != 0, header.flags & CUBE != 0);
    if exact {
        require(header.step == 0.0 && header.grid_bits == 0 && !tied, || "exact file with a grid".into())?;
    } else {
        require(header.step > 0.0 && header.grid_bits <= 28, || "grid file without a valid step".into())?;
    }
    require(!tied || cube, || "TIED without CUBE".into())?;
    require(cube || h[56..104].iter().all(|&b| b == 0), || "cube bytes without CUBE".into())?;

    // Step 3 (§3): the rest of the preamble; in version 5 the chunk index follows the table.
    let table_end = 112 + 48 * u64::from(header.level_count);
    let index_end = table_end + 88 * u64::from(header.chunk_count);
    let meta_end = index_end + u64::from(header.metadata_size);
    let preamble_size = meta_end + 8;
    if (file.len() as u64) < preamble_size {
        return fail(Class::Truncated, "the file ends inside the preamble (offset 112)");
    }
    let (table_end, index_end, meta_end) = (table_end as usize, index_end as usize, meta_end as usize);
    // Step 4 (§3.4).
    let stored = u64_at(file, meta_end);
    if xxhash_rust::xxh3::xxh3_64(&file[..meta_end]) != stored {
        return fail(Class::Checksum, "preamble checksum");
    }
    // Step 5 (§3.2): the table, entry by entry.
    let mut entries = Vec::new();
    let mut next = preamble_size;
    for k in 0..header.level_count as usize {
        let e = &file[112 + 48 * k..160 + 48 * k];
        let entry = Entry {
            offset: u64_at(e, 0),
            stored_size: u64_at(e, 8),
            raw_size: u64_at(e, 16),
            checksum: u64_at(e, 24),
            vertex_count: u32_at(e, 32),
            face_count: u32_at(e, 36),
            corner_count: u32_at(e, 40),
            cell_depth: u32_at(e, 44),
        };
        require(entry.offset == next, || format!("level {k} does not follow the level before"))?;
        if header.version >= 5 {
            chunks::check_cell_depth(k, entry.cell_depth, entries.last().map(|p: &Entry| p.cell_depth))?;
        } else {
            require(entry.cell_depth == 0, || format!("level {k}: reserved field"))?;
        }
        let over = entry.stored_size > limits.level_bytes
            || entry.raw_size > limits.level_bytes
            || entry.vertex_count > limits.vertices
            || entry.face_count > limits.faces
            || entry.corner_count > limits.corners;
        if over {
            return fail(Class::Limit, format!("level {k}: a size or count beyond the limits"));
        }
        next = entry.offset.saturating_add(entry.stored_size);
        entries.push(entry);
    }
    // Step 5 (§11.2): the chunk index, then (§3.3) the metadata block.
    let chunks = chunks::read_index(&file[table_end..index_end], &header, &entries, limits)?;
    let metadata = read_metadata(&file[index_end..meta_end])?;
    Ok(Preamble { header, entries, chunks, metadata })
}

/// §3.3: strings are a `u64` length and that many bytes of UTF-8; the fields fill the block.
fn read_metadata(b: &[u8]) -> Result<Metadata> {
    let mut at = 0usize;
    let u64_field = |at: &mut usize| -> Result<u64> {
        if b.len() - *at < 8 {
            return invalid("metadata: a length runs past the block");
        }
        let v = u64_at(b, *at);
        *at += 8;
        Ok(v)
    };
    let string = |at: &mut usize| -> Result<String> {
        let n = u64_field(at)?;
        if n > (b.len() - *at) as u64 {
            return invalid("metadata: a string runs past the block");
        }
        let s = &b[*at..*at + n as usize];
        *at += n as usize;
        match std::str::from_utf8(s) {
            Ok(s) => Ok(s.to_owned()),
            Err(_) => invalid("metadata: a string is not UTF-8"),
        }
    };
    let units = string(&mut at)?;
    let source = string(&mut at)?;
    let generator = string(&mut at)?;
    let count = {
        if b.len() - at < 8 {
            return invalid("metadata: entry_count runs past the block");
        }
        let v = u64_at(b, at);
        at += 8;
        v
    };
    let mut entries = Vec::new();
    for _ in 0..count {
        let key = string(&mut at)?;
        let value = string(&mut at)?;
        entries.push((key, value));
    }
    require(at == b.len(), || "metadata: bytes left over".into())?;
    Ok(Metadata { units, source, generator, entries })
}
