//! Spec §3.5 (stored levels) and §4 (the level block): from a level's stored bytes to its block
//! header and twelve streams, then the mode's sections (§5, §6) in order.

use super::container::{EXACT, Entry, Header, TIED};
use super::geometry;
use super::primitives::{Class, Result, Stream, fail, invalid, require};
use super::topology::{self, Level};

/// §4.2: the streams, by number. Streams 6 and 7 have other names in mode 3.
pub const CHILD_MASKS: usize = 0;
pub const DEPTHS: usize = 1;
pub const ROTATIONS: usize = 2;
pub const CREATED_KEYS: usize = 3;
pub const FACE_SIZES: usize = 4;
pub const CORNERS: usize = 5;
pub const EXTRA_NAMES: usize = 6;
pub const EXTRA_KEYS: usize = 6;
pub const SPLITS: usize = 7;
pub const SPLIT_KEYS: usize = 7;
pub const EXCEPTIONS: usize = 8;
pub const CHOICES: usize = 9;
pub const RAW_LATTICE: usize = 10;
pub const GEOMETRY: usize = 11;

/// §4.2: the stream names of modes 0-2.
const NAMES: [&str; 12] = [
    "child_masks",
    "depths",
    "rotations",
    "created_keys",
    "face_sizes",
    "corners",
    "extra_names",
    "splits",
    "exceptions",
    "choices",
    "raw_lattice",
    "geometry",
];

/// §4.1: the block header's fields a level's sections need.
#[derive(Clone, Copy, Debug)]
pub struct BlockHeader {
    pub mode: u8,
    pub lattice: bool,
    /// Bit 0 of `predictor`.
    pub predictor: u8,
    /// Bit 1 of `predictor`.
    pub lines: bool,
    pub line_shift: u32,
    pub vertex_count: usize,
    pub face_count: usize,
    pub corner_count: usize,
}

/// What every level's sections read from the file header.
#[derive(Clone, Copy, Debug)]
pub struct FileContext {
    pub version: u16,
    pub exact: bool,
    pub tied: bool,
    pub grid_bits: u32,
}

impl FileContext {
    pub fn new(h: &Header) -> Self {
        Self { version: h.version, exact: h.flags & EXACT != 0, tied: h.flags & TIED != 0, grid_bits: h.grid_bits }
    }
}

/// §3.5 and §7.1 step 6: the stored bytes of level `k`, checked and decompressed.
pub fn payload(file: &[u8], k: usize, e: &Entry) -> Result<Vec<u8>> {
    let what = format!("level {k}");
    let stored = stored_bytes(file, &what, e.offset, e.stored_size, e.checksum)?;
    decompress(&what, stored, e.raw_size)
}

/// §3.5: the `size` stored bytes at `offset` of a level (or chunk, §11.3), `what`: all in the file,
/// their XXH3-64 equal to `checksum`.
pub fn stored_bytes<'a>(file: &'a [u8], what: &str, offset: u64, size: u64, checksum: u64) -> Result<&'a [u8]> {
    let end = offset.checked_add(size).filter(|&end| end <= file.len() as u64);
    let Some(end) = end else {
        return fail(Class::Truncated, format!("the file ends inside {what} (offset {offset})"));
    };
    let stored = &file[offset as usize..end as usize];
    if xxhash_rust::xxh3::xxh3_64(stored) != checksum {
        return fail(Class::Checksum, what);
    }
    Ok(stored)
}

/// §3.5: checked stored bytes are one zstd frame stating its content size, equal to `raw_size`,
/// which it decompresses to.
pub fn decompress(what: &str, stored: &[u8], raw_size: u64) -> Result<Vec<u8>> {
    match zstd::zstd_safe::get_frame_content_size(stored) {
        Ok(Some(size)) if size == raw_size => {}
        _ => return invalid(format!("{what}: the frame does not state raw_size")),
    }
    let Ok(raw) = zstd::bulk::decompress(stored, raw_size as usize) else {
        return invalid(format!("{what}: corrupt zstd frame"));
    };
    require(raw.len() as u64 == raw_size, || format!("{what}: decompressed size"))?;
    Ok(raw)
}

/// §4.1: the block header, checked against the table entry; the twelve streams.
pub fn split<'a>(k: usize, raw: &'a [u8], e: &Entry, file: FileContext) -> Result<(BlockHeader, Vec<Stream<'a>>)> {
    require(raw.len() >= 64, || "block shorter than its header".into())?;
    let u32_at = |at: usize| u32::from_le_bytes(raw[at..at + 4].try_into().expect("4 bytes"));
    let mode = raw[0];
    let valid_mode = mode <= 2 || (mode == 3 && file.version >= 3);
    require(valid_mode, || format!("level {k}: mode {mode}"))?;
    require((mode == 0) == (k == 0), || format!("level {k}: mode {mode}"))?;
    let flags = raw[1];
    require(flags & !1 == 0, || "reserved block flag bits".into())?;
    let lattice = flags & 1 != 0;
    require(!lattice || k <= 20, || "LATTICE below level 20".into())?;
    if mode >= 2 {
        require(lattice && (file.exact || file.tied), || "lattice mode without LATTICE or a tied grid".into())?;
    }
    let predictor = raw[2];
    require(predictor & 1 == 0 || mode >= 2, || "predictor bit 0 in mode 0 or 1".into())?;
    let lines = predictor & 2 != 0;
    require(!lines || (mode != 0 && !file.exact && file.version >= 2), || "LINES not allowed here".into())?;
    require(predictor & !3 == 0, || "reserved predictor bits".into())?;
    let line_shift = u32::from(raw[3]);
    require(if lines { line_shift <= 16 } else { line_shift == 0 }, || format!("line_shift {line_shift}"))?;
    let counts = (u32_at(4), u32_at(8), u32_at(12));
    require(counts == (e.vertex_count, e.face_count, e.corner_count), || "counts differ from the table".into())?;
    let sizes: Vec<u64> = (0..12).map(|i| u64::from(u32_at(16 + 4 * i))).collect();
    require(64 + sizes.iter().sum::<u64>() == raw.len() as u64, || "stream sizes do not fill the block".into())?;
    let mut streams = Vec::new();
    let mut at = 64usize;
    for (i, &size) in sizes.iter().enumerate() {
        let name = match (i, mode) {
            (EXTRA_KEYS, 3) => "extra_keys",
            (SPLIT_KEYS, 3) => "split_keys",
            _ => NAMES[i],
        };
        streams.push(Stream::new(name, &raw[at..at + size as usize]));
        at += size as usize;
    }
    // §4.2: the streams each mode uses.
    let used: &[usize] = match mode {
        0 => &[FACE_SIZES, CORNERS, RAW_LATTICE, GEOMETRY],
        1 => &[
            CHILD_MASKS,
            ROTATIONS,
            FACE_SIZES,
            CORNERS,
            EXTRA_NAMES,
            SPLITS,
            EXCEPTIONS,
            CHOICES,
            RAW_LATTICE,
            GEOMETRY,
        ],
        _ => &[CHILD_MASKS, DEPTHS, ROTATIONS, CREATED_KEYS, EXTRA_NAMES, SPLITS, EXCEPTIONS, CHOICES, GEOMETRY],
    };
    for (i, s) in streams.iter().enumerate() {
        let unused = !used.contains(&i) || (i == RAW_LATTICE && !lattice);
        require(!unused || s.remaining() == 0, || format!("{} must be empty in mode {mode}", s.name))?;
    }
    let header = BlockHeader {
        mode,
        lattice,
        predictor: predictor & 1,
        lines,
        line_shift,
        vertex_count: counts.0 as usize,
        face_count: counts.1 as usize,
        corner_count: counts.2 as usize,
    };
    Ok((header, streams))
}

/// Level `k` from its payload: §4, then the mode's topology (§5) and geometry (§6) sections, then
/// §4.1's rule that every stream is read to its end.
pub fn decode_level(k: usize, raw: &[u8], e: &Entry, file: FileContext, parent: Option<&Level>) -> Result<Level> {
    let (h, mut streams) = split(k, raw, e, file)?;
    let topo = match h.mode {
        0 => topology::mode0(&h, &mut streams)?,
        1 => topology::mode1(k, &h, &mut streams, parent.expect("level k > 0 has a parent"))?,
        2 => topology::mode2(k, &h, &mut streams, parent.expect("level k > 0 has a parent"))?,
        _ => topology::mode3(k, &h, &mut streams, parent.expect("level k > 0 has a parent"))?,
    };
    let level = geometry::decode(k, &h, file, &mut streams[GEOMETRY], topo, parent)?;
    for s in &streams {
        s.finish()?;
    }
    Ok(level)
}
