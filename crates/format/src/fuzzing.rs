//! Helpers for fuzzing and conformance tests (feature `testing`): rewrite a level's decompressed
//! payload and reseal the file (recompress, fix sizes, offsets and checksums), so that mutations
//! reach the level decoder instead of stopping at a checksum.

use crate::Limits;
use crate::container::{self, ENTRY_SIZE, HEADER_SIZE, Preamble};
use crate::decoder::read_preamble;

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
