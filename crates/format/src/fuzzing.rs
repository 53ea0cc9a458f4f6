//! Helpers for fuzzing and conformance tests (feature `testing`): rewrite a level's decompressed
//! payload and reseal the file (recompress, fix sizes, offsets and checksums), so that mutations
//! reach the level decoder instead of stopping at a checksum.

use crate::Limits;
use crate::container::Preamble;
use crate::decoder::read_preamble;

/// Decompressed payload of every level of a valid file (`None` for a version 5 file with a level
/// of more than one chunk).
pub fn payloads(bytes: &[u8]) -> Option<Vec<Vec<u8>>> {
    let mut r = bytes;
    let pre = read_preamble(&mut r, &Limits::default()).ok()?;
    if !one_chunk_per_level(&pre) {
        return None;
    }
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
    if !one_chunk_per_level(&pre) {
        return None;
    }
    let mut offset = pre.size();
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
    sync_chunks(&mut pre);
    let mut out = pre.to_bytes();
    for s in stored_all {
        out.extend(s);
    }
    Some(out)
}

/// Whether every level is one frame: files before version 5, and version 5 files whose levels
/// have one chunk each.
pub(crate) fn one_chunk_per_level(pre: &Preamble) -> bool {
    pre.chunks.is_empty() || pre.chunks.len() == pre.levels.len()
}

/// In a version 5 file of one chunk per level, each chunk entry made to match its level's entry.
pub(crate) fn sync_chunks(pre: &mut Preamble) {
    for c in &mut pre.chunks {
        let e = &pre.levels[usize::from(c.level)];
        c.offset = e.offset;
        c.stored_size = u32::try_from(e.stored_size).unwrap_or(u32::MAX);
        c.raw_size = u32::try_from(e.raw_size).unwrap_or(u32::MAX);
        c.checksum = e.checksum;
        (c.vertex_count, c.face_count, c.corner_count) = (e.vertex_count, e.face_count, e.corner_count);
    }
}

/// Range decodes `data` as the coded bytes of a value block of `count` values (spec §6.9);
/// `None` when they are invalid. Never panics, whatever the bytes.
pub fn range_decode(data: &[u8], count: usize) -> Option<Vec<u32>> {
    let mut out = Vec::new();
    crate::entropy::values::range_decode(data, count, &mut out).ok()?;
    Some(out)
}

/// Range codes `values` as a value block's coded bytes (spec §6.9).
pub fn range_code(values: &[u32]) -> Vec<u8> {
    crate::entropy::values::range_code(values)
}
