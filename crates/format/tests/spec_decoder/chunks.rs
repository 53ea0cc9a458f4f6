//! Spec §11 (chunks, version 5): cell depths (§11.1), the chunk index (§11.2), chunk blocks
//! (§11.3) and the level merged from its chunks (§11.4).

use std::collections::BTreeMap;

use super::block::{self, FileContext};
use super::container::{Entry, Header, Limits, u16_at, u32_at, u64_at};
use super::primitives::{Class, Result, SpecError, fail, require};
use super::topology::Level;

/// `parent` of a chunk that refines no chunk (§11.2).
const NO_PARENT: u32 = 0xFFFF_FFFF;

/// §11.2: one chunk-index entry.
#[derive(Clone, Debug)]
pub struct ChunkEntry {
    pub offset: u64,
    pub checksum: u64,
    pub stored_size: u32,
    pub raw_size: u32,
    /// The index of the chunk of level `level - 1` this one refines, if any.
    pub parent: Option<usize>,
    pub level: usize,
    pub cell: [u32; 3],
    pub vertex_count: u32,
    pub face_count: u32,
    pub corner_count: u32,
}

impl ChunkEntry {
    /// The chunk as the level table entry its block is checked against (§11.3: the block header's
    /// counts equal the chunk entry's).
    fn as_entry(&self, cell_depth: u32) -> Entry {
        Entry {
            offset: self.offset,
            stored_size: u64::from(self.stored_size),
            raw_size: u64::from(self.raw_size),
            checksum: self.checksum,
            vertex_count: self.vertex_count,
            face_count: self.face_count,
            corner_count: self.corner_count,
            cell_depth,
        }
    }
}

/// §11.1: level `k`'s cell depth `d`, given the level above's (`None` at level 0).
pub fn check_cell_depth(k: usize, d: u32, above: Option<u32>) -> Result<()> {
    let ok = match above {
        None => d == 0,
        Some(above) => above <= d && (d as usize) < k && d <= 20,
    };
    require(ok, || format!("level {k}: cell_depth {d}"))
}

/// §11.2: the Morton code of a cell (bit `b` of axis `a` at bit `3b + a`).
fn morton(cell: [u32; 3]) -> u64 {
    let mut m = 0u64;
    for b in 0..21 {
        for (a, &x) in cell.iter().enumerate() {
            m |= u64::from(x >> b & 1) << (3 * b + a);
        }
    }
    m
}

/// §11.2: the chunk index (`index` is its bytes), entry by entry, then its sums against the level
/// table (§7.1 step 5).
pub fn read_index(index: &[u8], header: &Header, levels: &[Entry], limits: &Limits) -> Result<Vec<ChunkEntry>> {
    let mut chunks: Vec<ChunkEntry> = Vec::new();
    let mut next_offset = 0u64; // where the next chunk of the current level starts
    for i in 0..header.chunk_count as usize {
        let b = &index[88 * i..88 * (i + 1)];
        let what = || format!("chunk {i}");
        let level = usize::from(u16_at(b, 28));
        require(u16_at(b, 30) == 0 && u32_at(b, 84) == 0, || format!("{}: reserved field", what()))?;
        require(level < levels.len(), || format!("{}: level {level}", what()))?;
        let raw_parent = u32_at(b, 24);
        let chunk = ChunkEntry {
            offset: u64_at(b, 0),
            checksum: u64_at(b, 8),
            stored_size: u32_at(b, 16),
            raw_size: u32_at(b, 20),
            parent: (raw_parent != NO_PARENT).then_some(raw_parent as usize),
            level,
            cell: [u32_at(b, 32), u32_at(b, 36), u32_at(b, 40)],
            vertex_count: u32_at(b, 44),
            face_count: u32_at(b, 48),
            corner_count: u32_at(b, 52),
        };
        // The cell, and the listing order: level by level, then by increasing Morton code.
        let d = levels[level].cell_depth;
        require(chunk.cell.iter().all(|&x| u64::from(x) < 1u64 << d), || format!("{}: cell beyond depth {d}", what()))?;
        let first_of_level = chunks.last().is_none_or(|p| p.level < level);
        let in_order =
            chunks.last().is_none_or(|p| p.level < level || (p.level == level && morton(p.cell) < morton(chunk.cell)));
        require(in_order, || format!("{}: listed out of order", what()))?;
        // The parent: an earlier chunk of level `level - 1` whose cell holds this one's.
        if let Some(p) = chunk.parent {
            let holds = p < i && level >= 1 && chunks[p].level == level - 1 && {
                let shift = d - levels[level - 1].cell_depth;
                chunks[p].cell == chunk.cell.map(|x| x >> shift)
            };
            require(holds, || format!("{}: parent {p} is no chunk holding its cell", what()))?;
        }
        // The chunks of a level lie back to back from the level's offset.
        if first_of_level {
            next_offset = levels[level].offset;
        }
        require(chunk.offset == next_offset, || format!("{}: does not start where the chunk before ends", what()))?;
        next_offset = chunk.offset.saturating_add(u64::from(chunk.stored_size));
        let over = u64::from(chunk.stored_size) > limits.level_bytes
            || u64::from(chunk.raw_size) > limits.level_bytes
            || chunk.vertex_count > limits.vertices
            || chunk.face_count > limits.faces
            || chunk.corner_count > limits.corners;
        if over {
            return fail(Class::Limit, format!("{}: a size or count beyond the limits", what()));
        }
        // The box and the geometric error.
        let f32_at = |at: usize| f32::from_bits(u32_at(b, at));
        let (lo, hi) = ([0, 1, 2].map(|a| f32_at(56 + 4 * a)), [0, 1, 2].map(|a| f32_at(68 + 4 * a)));
        let finite = lo.iter().chain(&hi).chain(&[f32_at(80)]).all(|x| x.is_finite());
        require(finite, || format!("{}: bbox or geometric_error not finite", what()))?;
        let boxed = chunk.vertex_count == 0 || (0..3).all(|a| lo[a] <= hi[a]);
        require(boxed, || format!("{}: bbox_min above bbox_max", what()))?;
        chunks.push(chunk);
    }
    // Per level, the sums against the level table (version 5; before it there are no chunks).
    for (k, e) in levels.iter().enumerate().filter(|_| header.version >= 5) {
        let of_level: Vec<&ChunkEntry> = chunks.iter().filter(|c| c.level == k).collect();
        let sum = |f: fn(&ChunkEntry) -> u32| of_level.iter().map(|&c| u64::from(f(c))).sum::<u64>();
        let sums = (sum(|c| c.stored_size), sum(|c| c.raw_size), sum(|c| c.face_count), sum(|c| c.corner_count));
        let want = (e.stored_size, e.raw_size, u64::from(e.face_count), u64::from(e.corner_count));
        require(sums == want, || format!("level {k}: its chunks' sizes and counts do not add up"))?;
        let largest = of_level.iter().map(|c| c.vertex_count).max().unwrap_or(0);
        let between = largest <= e.vertex_count && u64::from(e.vertex_count) <= sum(|c| c.vertex_count);
        require(between, || format!("level {k}: vertex_count {} not between its chunks'", e.vertex_count))?;
    }
    Ok(chunks)
}

/// A decoded chunk (§11.3) and where its faces start in its decoded level (§11.4).
pub struct DecodedChunk {
    pub level: Level,
    pub face_offset: u32,
}

/// §11.3 and §11.4, §7.1 step 6: level `k` (table entry `e`) of a version 5 file from its chunks
/// (`chunks`: the whole chunk index), each decoded against its parent chunk in `above` (level
/// `k - 1`'s decoded chunks by index). Returns the decoded level and level `k`'s decoded chunks.
pub fn decode_level(
    bytes: &[u8],
    k: usize,
    e: &Entry,
    chunks: &[ChunkEntry],
    file: FileContext,
    above: &BTreeMap<usize, DecodedChunk>,
) -> Result<(Level, BTreeMap<usize, DecodedChunk>)> {
    // §3.5: the level's stored bytes and its checksum, over all of its chunks.
    block::stored_bytes(bytes, &format!("level {k}"), e.offset, e.stored_size, e.checksum)?;
    // §11.3: each chunk, in index order.
    let empty = Level { slots: Some(Vec::new()), vertex_corners: Some(Vec::new()), ..Level::default() };
    let mut decoded = BTreeMap::new();
    let mut face_offset = 0u32;
    for (i, c) in chunks.iter().enumerate().filter(|(_, c)| c.level == k) {
        let what = format!("level {k} chunk {i}");
        let parent = match c.parent {
            _ if k == 0 => None,
            Some(p) => Some(&above[&p].level),
            None => Some(&empty),
        };
        let level = decode_chunk(bytes, &what, c, e.cell_depth, file, parent)
            .map_err(|err| SpecError { what: format!("{what}: {}", err.what), ..err })?;
        decoded.insert(i, DecodedChunk { level, face_offset });
        face_offset += c.face_count;
    }
    let level = merge(k, e, chunks, &decoded, above)?;
    Ok((level, decoded))
}

/// §11.3: one chunk's stored bytes (checksum, frame) and block, decoded as a level of its own, its
/// faces checked to lie in its cell.
fn decode_chunk(
    bytes: &[u8],
    what: &str,
    c: &ChunkEntry,
    cell_depth: u32,
    file: FileContext,
    parent: Option<&Level>,
) -> Result<Level> {
    let stored = block::stored_bytes(bytes, what, c.offset, u64::from(c.stored_size), c.checksum)?;
    let raw = block::decompress(what, stored, u64::from(c.raw_size))?;
    let level = block::decode_level(c.level, &raw, &c.as_entry(cell_depth), file, parent)?;
    // §11.1: a level without lattice coordinates has cell depth 0; every face lies in the cell.
    match &level.slots {
        None => require(cell_depth == 0, || "no lattice coordinates at a cell depth above 0".into())?,
        Some(slots) => {
            let shift = c.level as u32 - cell_depth;
            let inside = slots.iter().all(|(v, _)| v.map(|x| x >> shift) == c.cell);
            require(inside, || "a face outside the chunk's cell".into())?;
        }
    }
    Ok(level)
}

/// §11.4: the decoded level of level `k`'s decoded chunks: their faces in index order (subfaces'
/// parents renumbered into the decoded level above), their vertices merged on cell boundaries.
fn merge(
    k: usize,
    e: &Entry,
    chunks: &[ChunkEntry],
    decoded: &BTreeMap<usize, DecodedChunk>,
    above: &BTreeMap<usize, DecodedChunk>,
) -> Result<Level> {
    let lattice = !decoded.is_empty() && decoded.values().all(|d| d.level.slots.is_some());
    let mut out = Level { slots: lattice.then(Vec::new), vertex_corners: lattice.then(Vec::new), ..Level::default() };
    let cell_side = 1u64 << (k as u32 - e.cell_depth).min(63); // 2^(s_k)
    // Boundary vertices numbered from earlier chunks, by lattice corner and coordinate bits.
    let mut numbered: BTreeMap<([u32; 3], [u64; 3]), u32> = BTreeMap::new();
    let mut count = 0u32;
    for (&i, d) in decoded {
        let l = &d.level;
        let n = l.q.len().max(l.exact.len());
        let mut index = Vec::with_capacity(n);
        let mut new_on_boundary = Vec::new();
        for v in 0..n {
            let corner = l.vertex_corners.as_ref().map(|c| c[v]);
            let key =
                corner.filter(|c| c.iter().any(|&x| u64::from(x) % cell_side == 0)).map(|c| (c, coordinate_bits(l, v)));
            if let Some(&j) = key.as_ref().and_then(|key| numbered.get(key)) {
                index.push(j);
                continue;
            }
            index.push(count);
            if let Some(key) = key {
                new_on_boundary.push((key, count));
            }
            if let (Some(out_corners), Some(c)) = (out.vertex_corners.as_mut(), corner) {
                out_corners.push(c);
            }
            if l.exact.is_empty() {
                out.q.push(l.q[v]);
            } else {
                out.exact.push(l.exact[v]);
            }
            count += 1;
        }
        // Only vertices of earlier chunks merge: this chunk's join the table after it.
        for (key, j) in new_on_boundary {
            numbered.entry(key).or_insert(j);
        }
        let parent_offset = chunks[i].parent.map_or(0, |p| above[&p].face_offset);
        out.faces.extend(l.faces.iter().map(|f| f.iter().map(|&v| index[v as usize]).collect()));
        out.origins.extend(l.origins.iter().map(|o| o.map(|(p, q)| (parent_offset + p, q))));
        if let (Some(out_slots), Some(slots)) = (out.slots.as_mut(), &l.slots) {
            out_slots.extend_from_slice(slots);
        }
    }
    require(count == e.vertex_count, || {
        format!("level {k}: its chunks merge into {count} vertices, not {}", e.vertex_count)
    })?;
    Ok(out)
}

/// §11.4: a vertex's grid coordinates, or in exact files its position's bit patterns.
fn coordinate_bits(l: &Level, v: usize) -> [u64; 3] {
    if l.exact.is_empty() { l.q[v].map(|x| x as u64) } else { l.exact[v].map(f64::to_bits) }
}
