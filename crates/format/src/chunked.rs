//! Version 5 files (spec §11 Chunks): the chunk index, decoding a level from its chunks (in
//! parallel), merging them into the level, and reading only some chunks through a byte-range
//! source ([`ChunkedMrq`]).

use std::collections::HashMap;
use std::io::{Read, Seek, SeekFrom};

use octowrap_mesh::{Aabb, DVec3, FaceList, Mesh};
use rayon::prelude::*;
use xxhash_rust::xxh3::xxh3_64;

use crate::block::{BlockHeader, GridInfo};
use crate::container::{
    self, CHUNK_ENTRY_SIZE, CHUNKED_VERSION, ChunkEntry, ENTRY_SIZE, FLAG_EXACT, FLAG_TIED, HEADER_SIZE, LevelEntry,
    NO_CHUNK, Preamble,
};
use crate::error::{DecodeError, Where};
use crate::level_decode::{self, PlainLevel};
use crate::topology::NO_PARENT;
use crate::{FileInfo, Limits};

/// Parses and checks the chunk index (spec §11.2) against the level table.
pub fn parse_index(
    bytes: &[u8],
    file_offset: usize,
    levels: &[LevelEntry],
    limits: &Limits,
) -> Result<Vec<ChunkEntry>, DecodeError> {
    let n = bytes.len() / CHUNK_ENTRY_SIZE;
    let mut out: Vec<ChunkEntry> = Vec::with_capacity(n);
    // Per level: (chunks, next offset, stored, raw, faces, corners, most vertices, vertex sum).
    let mut sums: Vec<LevelSums> = vec![(0, 0, 0, 0, 0, 0, 0, 0); levels.len()];
    for (k, e) in levels.iter().enumerate() {
        sums[k].1 = e.offset;
    }
    for i in 0..n {
        let at = file_offset + i * CHUNK_ENTRY_SIZE;
        let c: ChunkEntry = container::from_bytes(
            &bytes[i * CHUNK_ENTRY_SIZE..(i + 1) * CHUNK_ENTRY_SIZE],
            at as u64,
            "chunk index entry",
        )?;
        let bad = |off: usize, reason: String| DecodeError::Invalid {
            place: Where::Preamble,
            offset: (at + off) as u64,
            what: "chunk index entry",
            reason: format!("chunk {i}: {reason}"),
        };
        if c.reserved != 0 || c.reserved2 != 0 {
            return Err(bad(30, "reserved field is not zero".into()));
        }
        let k = usize::from(c.level);
        if k >= levels.len() {
            return Err(bad(28, format!("level {k}, the file has {}", levels.len())));
        }
        if out.last().is_some_and(|p| usize::from(p.level) > k) {
            return Err(bad(28, "chunks must be listed level by level, coarse to fine".into()));
        }
        let depth = levels[k].cell_depth;
        if c.cell.iter().any(|&x| u64::from(x) >= 1u64 << depth) {
            return Err(bad(
                32,
                format!("cell {:?} lies outside the {}^3 cells of depth {depth}", c.cell, 1u64 << depth),
            ));
        }
        if let Some(p) = out.last().filter(|p| usize::from(p.level) == k) {
            if crate::chunks::cell_morton(p.cell) >= crate::chunks::cell_morton(c.cell) {
                return Err(bad(
                    32,
                    "a level's chunks must be listed in increasing Morton order of their cells".into(),
                ));
            }
        }
        if c.parent != NO_CHUNK {
            let Some(p) = out.get(c.parent as usize) else {
                return Err(bad(24, format!("parent chunk {} is not listed before it", c.parent)));
            };
            if usize::from(p.level) + 1 != k {
                return Err(bad(
                    24,
                    format!("parent chunk {} is of level {}, not {}", c.parent, p.level, k.wrapping_sub(1)),
                ));
            }
            let up = depth - levels[k - 1].cell_depth;
            if p.cell != c.cell.map(|x| x >> up) {
                return Err(bad(
                    24,
                    format!("parent chunk {}'s cell {:?} does not hold cell {:?}", c.parent, p.cell, c.cell),
                ));
            }
        }
        check_limits(&c, at, limits)?;
        if !c.bbox_min.iter().chain(&c.bbox_max).chain([&c.geometric_error]).all(|x| x.is_finite()) {
            return Err(bad(56, "bounding box or geometric error is not finite".into()));
        }
        if c.vertex_count > 0 && (0..3).any(|a| c.bbox_min[a] > c.bbox_max[a]) {
            return Err(bad(56, "bounding box minimum exceeds its maximum".into()));
        }
        let s = &mut sums[k];
        if c.offset != s.1 {
            return Err(bad(
                0,
                format!("offset is {}, a level's chunks follow each other: expected {}", c.offset, s.1),
            ));
        }
        s.0 += 1;
        s.1 += u64::from(c.stored_size);
        s.2 += u64::from(c.stored_size);
        s.3 += u64::from(c.raw_size);
        s.4 += u64::from(c.face_count);
        s.5 += u64::from(c.corner_count);
        s.6 = s.6.max(u64::from(c.vertex_count));
        s.7 += u64::from(c.vertex_count);
        out.push(c);
    }
    check_sums(levels, &sums)?;
    Ok(out)
}

/// A chunk's sizes and counts against the decoder's limits (spec §7.2); `at` is its entry's offset.
fn check_limits(c: &ChunkEntry, at: usize, limits: &Limits) -> Result<(), DecodeError> {
    let limit = |off: usize, what: &'static str, value: u64, limit: u64| {
        if value > limit {
            Err(DecodeError::LimitExceeded { place: Where::Preamble, offset: (at + off) as u64, what, value, limit })
        } else {
            Ok(())
        }
    };
    limit(16, "chunk stored_size", c.stored_size.into(), limits.max_level_bytes)?;
    limit(20, "chunk raw_size", c.raw_size.into(), limits.max_level_bytes)?;
    limit(44, "chunk vertex_count", c.vertex_count.into(), limits.max_vertices.into())?;
    limit(48, "chunk face_count", c.face_count.into(), limits.max_faces.into())?;
    limit(52, "chunk corner_count", c.corner_count.into(), limits.max_corners.into())?;
    Ok(())
}

/// Per level: (chunks, next offset, stored, raw, faces, corners, most vertices, vertex sum).
type LevelSums = (u64, u64, u64, u64, u64, u64, u64, u64);

/// The chunk index's sums against the level table (spec §11.2).
fn check_sums(levels: &[LevelEntry], sums: &[LevelSums]) -> Result<(), DecodeError> {
    for (k, (e, s)) in levels.iter().zip(sums).enumerate() {
        let at = (HEADER_SIZE + k * ENTRY_SIZE) as u64;
        let bad = |reason: String| DecodeError::Invalid {
            place: Where::Preamble,
            offset: at,
            what: "level table entry",
            reason: format!("level {k}: {reason}"),
        };
        if (s.2, s.3, s.4, s.5) != (e.stored_size, e.raw_size, u64::from(e.face_count), u64::from(e.corner_count)) {
            return Err(bad(format!(
                "its {} chunks hold {} stored and {} raw bytes, {} faces and {} corners; the level table says {}, {}, {} and {}",
                s.0, s.2, s.3, s.4, s.5, e.stored_size, e.raw_size, e.face_count, e.corner_count
            )));
        }
        let nv = u64::from(e.vertex_count);
        if nv < s.6 || nv > s.7 {
            return Err(bad(format!("vertex_count {nv} is not between {} and {} (its chunks' vertices)", s.6, s.7)));
        }
    }
    Ok(())
}

/// The chunks of a version 1-4 file: one per level, each refining the one before.
pub fn whole_levels(pre: &Preamble) -> Vec<ChunkEntry> {
    let (lo, hi) = if pre.header.flags & container::FLAG_CUBE != 0 {
        (pre.header.cube_min.map(|x| x as f32), pre.header.cube_max.map(|x| x as f32))
    } else {
        ([f32::MIN; 3], [f32::MAX; 3])
    };
    pre.levels
        .iter()
        .enumerate()
        .map(|(k, e)| ChunkEntry {
            offset: e.offset,
            checksum: e.checksum,
            stored_size: u32::try_from(e.stored_size).unwrap_or(u32::MAX),
            raw_size: u32::try_from(e.raw_size).unwrap_or(u32::MAX),
            parent: if k == 0 { NO_CHUNK } else { k as u32 - 1 },
            level: k as u16,
            reserved: 0,
            cell: [0; 3],
            vertex_count: e.vertex_count,
            face_count: e.face_count,
            corner_count: e.corner_count,
            bbox_min: lo,
            bbox_max: hi,
            geometric_error: -1.0,
            reserved2: 0,
        })
        .collect()
}

/// `e` with its place moved from level `k`'s payload to chunk `c`'s.
fn in_chunk(e: DecodeError, c: u32) -> DecodeError {
    let re = |p: Where| match p {
        Where::Payload(k) => Where::ChunkPayload(k, c),
        Where::Level(k) => Where::Chunk(k, c),
        other => other,
    };
    match e {
        DecodeError::Invalid { place, offset, what, reason } => {
            DecodeError::Invalid { place: re(place), offset, what, reason }
        }
        DecodeError::LimitExceeded { place, offset, what, value, limit } => {
            DecodeError::LimitExceeded { place: re(place), offset, what, value, limit }
        }
        DecodeError::ChecksumMismatch { place, offset, stored, computed } => {
            DecodeError::ChecksumMismatch { place: re(place), offset, stored, computed }
        }
        other => other,
    }
}

/// The level entry a chunk's block is checked against (spec §11.3: the chunk's own counts).
fn chunk_as_level(c: &ChunkEntry) -> LevelEntry {
    LevelEntry {
        offset: c.offset,
        stored_size: c.stored_size.into(),
        raw_size: c.raw_size.into(),
        checksum: c.checksum,
        vertex_count: c.vertex_count,
        face_count: c.face_count,
        corner_count: c.corner_count,
        cell_depth: 0,
    }
}

/// The grid description decoding needs.
pub fn grid_info(pre: &Preamble) -> GridInfo {
    let h = &pre.header;
    GridInfo { exact: h.flags & FLAG_EXACT != 0, tied: h.flags & FLAG_TIED != 0, bits: h.grid_bits, version: h.version }
}

/// The parent a chunk without a parent chunk is decoded against: a level with no faces.
fn empty_parent() -> PlainLevel {
    PlainLevel { offsets: vec![0], slots: Some(Vec::new()), corners: Some(Vec::new()), ..PlainLevel::default() }
}

/// Per thread: a zstd context, buffers and the level decoder's scratch.
#[derive(Default)]
struct ChunkBuffers {
    unzstd: Option<zstd::zstd_safe::DCtx<'static>>,
    payload: Vec<u8>,
    level: level_decode::Scratch,
}

thread_local! {
    /// Each thread's chunk buffers, kept from chunk to chunk (a zstd context and the level
    /// decoder's scratch are costly to make afresh for chunks of a few thousand faces).
    static CHUNK_BUFFERS: std::cell::RefCell<ChunkBuffers> = std::cell::RefCell::new(ChunkBuffers::default());
}

/// Checks and decodes chunk `c` (index `ci`) from its stored bytes against its parent chunk.
fn decode_chunk(
    ci: u32,
    c: &ChunkEntry,
    stored: &[u8],
    parent: Option<&PlainLevel>,
    gi: GridInfo,
    buffers: &mut ChunkBuffers,
) -> Result<PlainLevel, DecodeError> {
    let k = u32::from(c.level);
    let computed = xxh3_64(stored);
    if computed != c.checksum {
        return Err(DecodeError::ChecksumMismatch {
            place: Where::Chunk(k, ci),
            offset: c.offset,
            stored: c.checksum,
            computed,
        });
    }
    let unzstd = match &mut buffers.unzstd {
        Some(z) => z,
        none => none.insert(zstd::zstd_safe::DCtx::try_create().ok_or_else(|| DecodeError::Zstd {
            level: k,
            offset: c.offset,
            reason: "cannot create a decompression context".into(),
        })?),
    };
    let e = chunk_as_level(c);
    crate::decoder::decompress_level(unzstd, stored, (k, &e), &mut buffers.payload, |head| {
        BlockHeader::parse(k, head, &e, gi).map(drop)
    })
    .map_err(|x| in_chunk(x, ci))?;
    let empty;
    let parent = match parent {
        Some(p) => Some(p),
        None if k > 0 => {
            empty = empty_parent();
            Some(&empty)
        }
        None => None,
    };
    level_decode::decode_level(k, &buffers.payload, &e, parent, gi, &mut buffers.level).map_err(|x| in_chunk(x, ci))
}

/// Decodes the chunks `todo` (indices into `chunks`, all of one level) from their stored bytes
/// (`stored(i)`), in parallel, each against its parent in `parents` (by chunk index).
fn decode_level_chunks<'a, 'p>(
    chunks: &[ChunkEntry],
    todo: &[u32],
    stored: impl Fn(u32) -> &'a [u8] + Sync,
    parents: impl Fn(u32) -> Option<&'p PlainLevel> + Sync,
    gi: GridInfo,
) -> Result<Vec<PlainLevel>, DecodeError> {
    let one = |buffers: &mut ChunkBuffers, &ci: &u32| {
        let c = &chunks[ci as usize];
        let parent = if c.parent == NO_CHUNK { None } else { parents(c.parent) };
        if c.parent != NO_CHUNK && parent.is_none() {
            return Err(DecodeError::Invalid {
                place: Where::Chunk(u32::from(c.level), ci),
                offset: c.offset,
                what: "chunk",
                reason: format!("its parent chunk {} is not decoded", c.parent),
            });
        }
        decode_chunk(ci, c, stored(ci), parent, gi, buffers)
    };
    let with_buffers = |ci: &u32| {
        CHUNK_BUFFERS.with(|b| {
            let mut b = b.borrow_mut();
            let out = one(&mut b, ci);
            // Kept only up to 64 MiB, as the whole-level decoder keeps its buffers.
            if b.payload.capacity() + b.level.capacity_bytes() > 64 << 20 {
                *b = ChunkBuffers::default();
            }
            out
        })
    };
    if todo.len() == 1 {
        return Ok(vec![with_buffers(&todo[0])?]);
    }
    todo.par_iter().map(with_buffers).collect()
}

/// The identity of a vertex across a level's chunks (spec §11.4): lattice corner and position.
type VertexKey = ([u32; 3], [u64; 3]);

/// Merges decoded chunks of level `k` (in index order; `parent_face_offset[i]`: where chunk
/// `i`'s parent chunk's faces start in the merged parent level) into one level (spec §11.4).
/// `cell_shift`: `k - cell_depth`. Fails when the merged level does not have `expect_vertices`
/// vertices (`None`: any number, for partial levels).
pub fn merge_chunks(
    k: u32,
    parts: Vec<PlainLevel>,
    parent_face_offset: &[u32],
    cell_shift: u32,
    expect_vertices: Option<u32>,
) -> Result<PlainLevel, DecodeError> {
    if parts.len() == 1 && parent_face_offset[0] == 0 {
        let mut one = parts.into_iter().next().expect("one");
        one.rotation_hints = Vec::new();
        one.quad_cache = crate::level_decode::QuadCache::default();
        return check_count(k, one, expect_vertices);
    }
    merge_parts(k, &parts, parent_face_offset, cell_shift, expect_vertices)
}

/// [`merge_chunks`] of borrowed chunks.
fn merge_parts(
    k: u32,
    parts: &[PlainLevel],
    parent_face_offset: &[u32],
    cell_shift: u32,
    expect_vertices: Option<u32>,
) -> Result<PlainLevel, DecodeError> {
    let (nv, nf, nc) = parts
        .iter()
        .fold((0, 0, 0), |(v, f, c), p| (v + p.q.len().max(p.exact.len()), f + p.parents.len(), c + p.indices.len()));
    let mut out = PlainLevel {
        offsets: Vec::with_capacity(nf + 1),
        indices: Vec::with_capacity(nc),
        parents: Vec::with_capacity(nf),
        quadrants: Vec::with_capacity(nf),
        ..PlainLevel::default()
    };
    out.offsets.push(0);
    let grid = parts.iter().any(|p| !p.q.is_empty());
    if grid {
        out.q.reserve(nv);
    } else {
        out.exact.reserve(nv);
    }
    let lattice = parts.iter().all(|p| p.corners.is_some());
    if lattice {
        out.slots = Some(Vec::with_capacity(nf));
        out.corners = Some(Vec::with_capacity(nv));
    }
    let mask = (1u32 << cell_shift) - 1;
    // foldhash is keyed at random per map (and fast): a file cannot choose keys that collide.
    let mut seen: HashMap<VertexKey, u32, foldhash::fast::RandomState> =
        HashMap::with_capacity_and_hasher(nv / 4, foldhash::fast::RandomState::default());
    let mut remap = Vec::new();
    for (i, p) in parts.iter().enumerate() {
        remap.clear();
        let nv = p.q.len().max(p.exact.len());
        for v in 0..nv {
            let key = p.corners.as_ref().map(|c| c[v]).filter(|c| c.iter().any(|&x| x & mask == 0)).map(|c| {
                let pos = if p.exact.is_empty() { p.q[v].map(|x| x as u64) } else { p.exact[v].map(f64::to_bits) };
                (c, pos)
            });
            let next = out.q.len().max(out.exact.len()) as u32;
            let index = match key {
                Some(key) => *seen.entry(key).or_insert(next),
                None => next,
            };
            if index == next {
                if !p.q.is_empty() {
                    out.q.push(p.q[v]);
                }
                if !p.exact.is_empty() {
                    out.exact.push(p.exact[v]);
                }
                if let (Some(oc), Some(pc)) = (&mut out.corners, &p.corners) {
                    oc.push(pc[v]);
                }
            }
            remap.push(index);
        }
        let base = *out.offsets.last().expect("offsets");
        out.offsets.extend(p.offsets[1..].iter().map(|&o| base + o));
        out.indices.extend(p.indices.iter().map(|&v| remap[v as usize]));
        out.parents
            .extend(p.parents.iter().map(|&f| if f == NO_PARENT { NO_PARENT } else { f + parent_face_offset[i] }));
        out.quadrants.extend(&p.quadrants);
        if let (Some(os), Some(ps)) = (&mut out.slots, &p.slots) {
            os.extend(ps);
        }
    }
    check_count(k, out, expect_vertices)
}

fn check_count(k: u32, lv: PlainLevel, expect: Option<u32>) -> Result<PlainLevel, DecodeError> {
    let nv = lv.q.len().max(lv.exact.len());
    match expect {
        Some(e) if nv != e as usize => Err(DecodeError::Invalid {
            place: Where::Level(k),
            offset: 0,
            what: "chunks",
            reason: format!("the level's chunks merge into {nv} vertices, the level table says {e}"),
        }),
        _ => Ok(lv),
    }
}

/// One level of a version 5 file decoded chunk by chunk, before the merge (spec §11.4): the
/// parents of the next level's chunks.
pub struct LevelParts {
    k: u32,
    /// The level's chunks, decoded, in index order.
    parts: Vec<PlainLevel>,
    /// Chunk index → position in `parts`.
    at: HashMap<u32, usize>,
    /// Chunk index → its first face in the merged level.
    face_at: HashMap<u32, u32>,
    /// Per part: where its parent chunk's faces start in the merged level above.
    offsets: Vec<u32>,
}

/// Decodes the chunks of level `k` of a version 5 file from all of its stored bytes (`stored`,
/// starting at the level's offset), in parallel, each against its parent chunk in `above` (the
/// level above, decoded the same way).
pub fn decode_level_parts(
    pre: &Preamble,
    k: u32,
    stored: &[u8],
    above: Option<&LevelParts>,
) -> Result<LevelParts, DecodeError> {
    let e = &pre.levels[k as usize];
    let ids: Vec<u32> =
        pre.chunks.iter().enumerate().filter(|(_, c)| u32::from(c.level) == k).map(|(i, _)| i as u32).collect();
    let chunks = &pre.chunks;
    let slice = |ci: u32| {
        let c = &chunks[ci as usize];
        let from = (c.offset - e.offset) as usize;
        &stored[from..from + c.stored_size as usize]
    };
    let parent = |c: u32| above.and_then(|a| a.at.get(&c).map(|&i| &a.parts[i]));
    let parts = decode_level_chunks(chunks, &ids, slice, parent, grid_info(pre))?;
    let offsets: Vec<u32> = ids
        .iter()
        .map(|&ci| {
            let p = chunks[ci as usize].parent;
            above.and_then(|a| a.face_at.get(&p)).copied().unwrap_or(0)
        })
        .collect();
    let mut face_at = HashMap::new();
    let mut f = 0u32;
    for (&ci, part) in ids.iter().zip(&parts) {
        face_at.insert(ci, f);
        f += part.parents.len() as u32;
    }
    let at = ids.iter().enumerate().map(|(i, &c)| (c, i)).collect();
    Ok(LevelParts { k, parts, at, face_at, offsets })
}

/// The level of `lp`'s chunks, merged (spec §11.4); `lp` stays the next level's parent.
pub fn merge_level(pre: &Preamble, lp: &LevelParts) -> Result<PlainLevel, DecodeError> {
    let e = &pre.levels[lp.k as usize];
    let shift = lp.k - e.cell_depth;
    if lp.parts.len() == 1 && lp.offsets[0] == 0 {
        return merge_chunks(lp.k, lp.parts.clone(), &lp.offsets, shift, Some(e.vertex_count));
    }
    merge_parts(lp.k, &lp.parts, &lp.offsets, shift, Some(e.vertex_count))
}

/// [`merge_level`] of the last level decoded: its chunks move into the result.
pub fn merge_last_level(pre: &Preamble, lp: LevelParts) -> Result<PlainLevel, DecodeError> {
    let e = &pre.levels[lp.k as usize];
    merge_chunks(lp.k, lp.parts, &lp.offsets, lp.k - e.cell_depth, Some(e.vertex_count))
}

/// A byte-range source: a file, a buffer, or an HTTP client that answers range requests.
pub trait RangeSource {
    /// Fills `buf` with the bytes at `offset..offset + buf.len()`; an
    /// [`std::io::ErrorKind::UnexpectedEof`] error when the source ends before.
    fn read_range(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()>;
}

impl RangeSource for &[u8] {
    fn read_range(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        let start = usize::try_from(offset).ok().filter(|&s| s <= self.len());
        match start.and_then(|s| self.get(s..s.checked_add(buf.len())?)) {
            Some(b) => {
                buf.copy_from_slice(b);
                Ok(())
            }
            None => Err(std::io::ErrorKind::UnexpectedEof.into()),
        }
    }
}

impl<S: RangeSource + ?Sized> RangeSource for &mut S {
    fn read_range(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        (**self).read_range(offset, buf)
    }
}

/// A [`RangeSource`] that counts what it serves from another: the requests and bytes an HTTP
/// client in its place would fetch.
#[derive(Clone, Debug)]
pub struct CountingSource<S> {
    /// The source read.
    pub inner: S,
    /// Requests served.
    pub requests: u64,
    /// Bytes served.
    pub bytes: u64,
}

impl<S> CountingSource<S> {
    /// Counts what `inner` serves, from zero.
    pub fn new(inner: S) -> Self {
        Self { inner, requests: 0, bytes: 0 }
    }
}

impl<S: RangeSource> RangeSource for CountingSource<S> {
    fn read_range(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        self.requests += 1;
        self.bytes += buf.len() as u64;
        self.inner.read_range(offset, buf)
    }
}

/// Any [`Read`] + [`Seek`] (a file) as a [`RangeSource`].
pub struct SeekSource<R>(pub R);

impl<R: Read + Seek> RangeSource for SeekSource<R> {
    fn read_range(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        self.0.seek(SeekFrom::Start(offset))?;
        self.0.read_exact(buf)
    }
}

/// Reads and decodes parts of an MRQ file through a [`RangeSource`], fetching only the byte
/// ranges it needs: the preamble in two requests (the header, then the rest), then the chunks
/// asked for and their ancestors, adjacent ones in one request. Files of versions 1-4 read as one
/// chunk per level.
pub struct ChunkedMrq<S> {
    source: S,
    pre: Preamble,
    chunks: Vec<ChunkEntry>,
    requests: u64,
    bytes_read: u64,
    /// The last cut's chunks and their ancestors, decoded (the next cut reuses them).
    decoded: HashMap<u32, PlainLevel>,
}

/// What a [`ChunkedMrq`] read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReadStats {
    /// Range requests made.
    pub requests: u64,
    /// Bytes read.
    pub bytes: u64,
}

/// One chunk, as the index describes it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChunkInfo {
    /// Level.
    pub level: u32,
    /// Cell at the level's cell depth.
    pub cell: [u32; 3],
    /// The level's cell depth (spec §11.1).
    pub cell_depth: u32,
    /// The chunk it refines.
    pub parent: Option<u32>,
    /// File offset of its stored bytes.
    pub offset: u64,
    /// Stored bytes.
    pub stored_size: u32,
    /// Vertices.
    pub vertex_count: u32,
    /// Faces.
    pub face_count: u32,
    /// Bounding box, smallest corner.
    pub bbox_min: [f32; 3],
    /// Bounding box, largest corner.
    pub bbox_max: [f32; 3],
    /// Geometric error in model units (`None`: not measured).
    pub geometric_error: Option<f32>,
}

impl ChunkInfo {
    fn new(c: &ChunkEntry, cell_depth: u32) -> Self {
        Self {
            level: c.level.into(),
            cell: c.cell,
            cell_depth,
            parent: (c.parent != NO_CHUNK).then_some(c.parent),
            offset: c.offset,
            stored_size: c.stored_size,
            vertex_count: c.vertex_count,
            face_count: c.face_count,
            bbox_min: c.bbox_min,
            bbox_max: c.bbox_max,
            geometric_error: (c.geometric_error >= 0.0).then_some(c.geometric_error),
        }
    }
}

impl<S: RangeSource> ChunkedMrq<S> {
    /// Reads and checks the preamble (two range requests).
    pub fn open(mut source: S, limits: &Limits) -> Result<Self, DecodeError> {
        let mut head = [0u8; HEADER_SIZE];
        let mut requests = 1;
        if let Err(e) = source.read_range(0, &mut head) {
            if e.kind() != std::io::ErrorKind::UnexpectedEof {
                return Err(e.into());
            }
            // Short: the byte-at-a-time path gives the right error (not MRQ, or truncated).
            let mut got = Vec::new();
            for i in 0..HEADER_SIZE as u64 {
                let mut b = [0u8];
                if source.read_range(i, &mut b).is_err() {
                    break;
                }
                got.push(b[0]);
            }
            return Err(crate::decoder::read_preamble(&mut &got[..], limits).err().unwrap_or(DecodeError::Truncated {
                offset: 0,
                what: "file header".into(),
                needed: HEADER_SIZE as u64,
                got: got.len() as u64,
            }));
        }
        let header = crate::decoder::check_head(&head, HEADER_SIZE, limits)?;
        let rest_len = crate::decoder::rest_len(&header);
        let mut rest = vec![0u8; usize::try_from(rest_len).map_err(|_| std::io::Error::other("preamble too large"))?];
        requests += 1;
        source.read_range(HEADER_SIZE as u64, &mut rest).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                DecodeError::Truncated {
                    offset: HEADER_SIZE as u64,
                    what: "level table, chunk index, metadata and preamble checksum".into(),
                    needed: rest_len,
                    got: 0,
                }
            } else {
                e.into()
            }
        })?;
        let pre = container::parse_rest(header, &head, &rest, limits)?;
        let chunks = if pre.header.version >= CHUNKED_VERSION { pre.chunks.clone() } else { whole_levels(&pre) };
        let bytes_read = HEADER_SIZE as u64 + rest_len;
        Ok(Self { source, pre, chunks, requests, bytes_read, decoded: HashMap::new() })
    }

    /// The file's description.
    pub fn info(&self) -> FileInfo {
        FileInfo::from_preamble(&self.pre)
    }

    /// Every chunk, in index order (level by level).
    pub fn chunks(&self) -> Vec<ChunkInfo> {
        let chunked = self.pre.header.version >= CHUNKED_VERSION;
        self.chunks
            .iter()
            .map(|c| ChunkInfo::new(c, if chunked { self.pre.levels[usize::from(c.level)].cell_depth } else { 0 }))
            .collect()
    }

    /// Range requests and bytes so far.
    pub fn stats(&self) -> ReadStats {
        ReadStats { requests: self.requests, bytes: self.bytes_read }
    }

    /// The chunks of level `k` whose bounding boxes meet `region` (all of them for `None`).
    pub fn chunks_in(&self, k: u32, region: Option<Aabb>) -> Vec<u32> {
        self.chunks
            .iter()
            .enumerate()
            .filter(|(_, c)| u32::from(c.level) == k)
            .filter(|(_, c)| {
                region.is_none_or(|r| {
                    (0..3).all(|a| f64::from(c.bbox_min[a]) <= r.max[a] && f64::from(c.bbox_max[a]) >= r.min[a])
                })
            })
            .map(|(i, _)| i as u32)
            .collect()
    }

    /// Decodes the chunks `wanted` and every ancestor they need, reading each chunk's bytes once
    /// (adjacent chunks in one request); returns every decoded chunk by index.
    pub fn decode_chunks(&mut self, wanted: &[u32]) -> Result<HashMap<u32, PlainLevel>, DecodeError> {
        let mut done = HashMap::new();
        self.decode_into(wanted, &mut done)?;
        Ok(done)
    }

    /// Decodes into `done` the chunks `wanted` and their ancestors that it does not hold yet.
    fn decode_into(&mut self, wanted: &[u32], done: &mut HashMap<u32, PlainLevel>) -> Result<(), DecodeError> {
        let mut need: Vec<u32> = Vec::new();
        let mut mark = vec![false; self.chunks.len()];
        for &w in wanted {
            let mut c = w;
            while (c as usize) < self.chunks.len() && !mark[c as usize] && !done.contains_key(&c) {
                mark[c as usize] = true;
                need.push(c);
                c = self.chunks[c as usize].parent;
            }
        }
        need.sort_unstable();
        // Coalesced reads.
        let mut bytes: HashMap<u32, Vec<u8>> = HashMap::new();
        let mut i = 0;
        while i < need.len() {
            let mut j = i + 1;
            let end = |c: &ChunkEntry| c.offset + u64::from(c.stored_size);
            while j < need.len() && self.chunks[need[j] as usize].offset == end(&self.chunks[need[j - 1] as usize]) {
                j += 1;
            }
            let start = self.chunks[need[i] as usize].offset;
            let stop = end(&self.chunks[need[j - 1] as usize]);
            let mut buf = vec![0u8; (stop - start) as usize];
            self.requests += 1;
            self.bytes_read += stop - start;
            self.source.read_range(start, &mut buf).map_err(|e| {
                if e.kind() == std::io::ErrorKind::UnexpectedEof {
                    let c = &self.chunks[need[i] as usize];
                    DecodeError::Truncated {
                        offset: start,
                        what: format!("level {} chunk {}", c.level, need[i]),
                        needed: stop - start,
                        got: 0,
                    }
                } else {
                    e.into()
                }
            })?;
            for &c in &need[i..j] {
                let from = (self.chunks[c as usize].offset - start) as usize;
                bytes.insert(c, buf[from..from + self.chunks[c as usize].stored_size as usize].to_vec());
            }
            i = j;
        }
        let gi = grid_info(&self.pre);
        let mut i = 0;
        while i < need.len() {
            let k = self.chunks[need[i] as usize].level;
            let j = i + need[i..].iter().take_while(|&&c| self.chunks[c as usize].level == k).count();
            let held: &HashMap<u32, PlainLevel> = done;
            let parts = decode_level_chunks(&self.chunks, &need[i..j], |c| &bytes[&c][..], |c| held.get(&c), gi)?;
            done.extend(need[i..j].iter().copied().zip(parts));
            i = j;
        }
        Ok(())
    }

    /// The crack-free mesh of the cut `drawn` (spec §11.5): chunks no one of which refines
    /// another, fetched with their ancestors (each chunk's bytes once), stitched by the crack
    /// rule, which replaces a chunk by the chunks refining it where it meets another level
    /// without a shared seam ([`crate::stitch`]). The chunks of the cut and their ancestors stay
    /// decoded until the next cut, which reads and decodes only the chunks it adds (a view that
    /// moves a little decodes little).
    pub fn cut(&mut self, drawn: &[u32]) -> Result<crate::Cut, crate::CutError> {
        self.cut_where(drawn, |_| true)
    }

    /// [`Self::cut`] for a view that culls: where the crack rule replaces a chunk by the chunks
    /// refining it, only those for which `keep(chunk index)` holds are drawn (the others are out
    /// of view: neither fetched nor drawn).
    pub fn cut_where(&mut self, drawn: &[u32], keep: impl Fn(u32) -> bool) -> Result<crate::Cut, crate::CutError> {
        use crate::CutError;
        let n = self.chunks.len();
        let mut drawn: Vec<u32> = drawn.to_vec();
        drawn.sort_unstable();
        if let Some(&[c, _]) = drawn.windows(2).find(|w| w[0] == w[1]) {
            return Err(CutError::Selection(format!("chunk {c} is selected twice")));
        }
        if let Some(&c) = drawn.iter().find(|&&c| c as usize >= n) {
            return Err(CutError::Selection(format!("chunk {c} does not exist: the file has {n} chunks")));
        }
        let selected: std::collections::HashSet<u32> = drawn.iter().copied().collect();
        for &c in &drawn {
            let mut a = self.chunks[c as usize].parent;
            while (a as usize) < n {
                if selected.contains(&a) {
                    return Err(CutError::Selection(format!("chunk {c} refines chunk {a}, and both are selected")));
                }
                a = self.chunks[a as usize].parent;
            }
        }
        let mut children: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, c) in self.chunks.iter().enumerate() {
            if (c.parent as usize) < n {
                children[c.parent as usize].push(i as u32);
            }
        }
        let mut done = std::mem::take(&mut self.decoded);
        let mut refined = 0u32;
        let chunked = self.pre.header.version >= CHUNKED_VERSION;
        let h = self.pre.header.clone();
        let origin = DVec3::from_array(h.origin);
        let world = |lv: &PlainLevel, v: usize| {
            if lv.exact.is_empty() {
                origin + DVec3::new(lv.q[v][0] as f64, lv.q[v][1] as f64, lv.q[v][2] as f64) * h.step
            } else {
                DVec3::from_array(lv.exact[v])
            }
        };
        loop {
            if let Err(e) = self.decode_into(&drawn, &mut done) {
                self.decoded = done;
                return Err(e.into());
            }
            let parts: Vec<crate::stitch::Part<'_>> = drawn
                .iter()
                .map(|&c| {
                    let e = &self.chunks[c as usize];
                    let level = u32::from(e.level);
                    let depth = if chunked { self.pre.levels[level as usize].cell_depth } else { 0 };
                    crate::stitch::Part { chunk: c, level, depth, cell: e.cell, lv: &done[&c] }
                })
                .collect();
            let s = crate::stitch::stitch(&parts, world);
            // Each crack: refine its coarsest parts that have children.
            let mut refine: Vec<u32> = Vec::new();
            let mut unresolved = 0u32;
            for c in &s.conflicts {
                let low = c.iter().map(|&p| parts[p as usize].level).min().unwrap_or(0);
                let coarse: Vec<u32> = c
                    .iter()
                    .map(|&p| parts[p as usize].chunk)
                    .filter(|&ch| self.chunks[ch as usize].level as u32 == low && !children[ch as usize].is_empty())
                    .collect();
                if coarse.is_empty() {
                    unresolved += 1;
                } else {
                    refine.extend(coarse);
                }
            }
            refine.sort_unstable();
            refine.dedup();
            if refine.is_empty() {
                let face_chunks = s.face_parts.iter().map(|&p| parts[p as usize].chunk).collect();
                drop(parts);
                self.keep_decoded(&drawn, done);
                let mut mesh = Mesh::from_positions(s.positions);
                mesh.faces = s.faces;
                return Ok(crate::Cut {
                    mesh,
                    face_chunks,
                    lattice: s.lattice,
                    lattice_level: s.lattice_level,
                    drawn,
                    refined,
                    unresolved,
                });
            }
            refined += refine.len() as u32;
            drawn.retain(|c| refine.binary_search(c).is_err());
            drawn.extend(refine.iter().flat_map(|&c| children[c as usize].iter().copied()).filter(|&c| keep(c)));
            drawn.sort_unstable();
        }
    }

    /// Keeps the chunks `drawn` and their ancestors of `done` decoded for the next cut.
    fn keep_decoded(&mut self, drawn: &[u32], mut done: HashMap<u32, PlainLevel>) {
        let mut keep = std::collections::HashSet::new();
        for &c in drawn {
            let mut a = c;
            while (a as usize) < self.chunks.len() && keep.insert(a) {
                a = self.chunks[a as usize].parent;
            }
        }
        done.retain(|c, _| keep.contains(c));
        self.decoded = done;
    }

    /// The faces of level `k` inside `region` (the chunks whose boxes meet it, whole; all of the
    /// level for `None`), merged into one mesh (spec §11.4), positions in world units.
    pub fn extract(&mut self, k: u32, region: Option<Aabb>) -> Result<Mesh, DecodeError> {
        let n = self.pre.levels.len() as u32;
        if k >= n {
            return Err(DecodeError::NoSuchLevel { requested: k, available: n });
        }
        let ids = self.chunks_in(k, region);
        let mut done = self.decode_chunks(&ids)?;
        let parts: Vec<PlainLevel> = ids.iter().map(|c| done.remove(c).expect("decoded")).collect();
        let zeros = vec![0u32; parts.len()];
        let depth = if self.pre.header.version >= CHUNKED_VERSION { self.pre.levels[k as usize].cell_depth } else { 0 };
        let merged =
            if parts.is_empty() { PlainLevel::default() } else { merge_chunks(k, parts, &zeros, k - depth, None)? };
        let h = &self.pre.header;
        let origin = DVec3::from_array(h.origin);
        let positions: Vec<DVec3> = if merged.exact.is_empty() {
            merged.q.iter().map(|q| origin + DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) * h.step).collect()
        } else {
            merged.exact.iter().map(|p| DVec3::from_array(*p)).collect()
        };
        let mut faces = FaceList::with_capacity(merged.parents.len(), merged.indices.len());
        for w in merged.offsets.windows(2) {
            faces.push(&merged.indices[w[0] as usize..w[1] as usize]);
        }
        let mut mesh = Mesh::from_positions(positions);
        mesh.faces = faces;
        Ok(mesh)
    }
}

/// Stores `errors` (one per chunk, in index order) as the chunks' `geometric_error` in the
/// version 5 file `bytes` and reseals its preamble checksum (spec §3.4, §11.2).
pub fn set_chunk_errors(bytes: &mut [u8], errors: &[f32]) -> Result<(), DecodeError> {
    let pre = crate::decoder::read_preamble(&mut &bytes[..], &Limits::default())?;
    let bad =
        |reason: String| DecodeError::Invalid { place: Where::Preamble, offset: 108, what: "chunk index", reason };
    if pre.chunks.len() != errors.len() {
        return Err(bad(format!("{} errors for {} chunks", errors.len(), pre.chunks.len())));
    }
    if let Some(e) = errors.iter().find(|e| !e.is_finite()) {
        return Err(bad(format!("geometric error {e} is not finite")));
    }
    let start = HEADER_SIZE + ENTRY_SIZE * pre.levels.len();
    for (i, e) in errors.iter().enumerate() {
        let at = start + i * CHUNK_ENTRY_SIZE + 80;
        bytes[at..at + 4].copy_from_slice(&e.to_le_bytes());
    }
    let end = usize::try_from(pre.size()).map_err(|_| bad("preamble too large".into()))? - 8;
    let sum = xxh3_64(&bytes[..end]);
    bytes[end..end + 8].copy_from_slice(&sum.to_le_bytes());
    Ok(())
}
