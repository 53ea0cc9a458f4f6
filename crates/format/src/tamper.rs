//! Byte surgery for building invalid conformance and hostile files (feature `testing`).

use crate::Limits;
use crate::container::{CHUNK_ENTRY_SIZE, ENTRY_SIZE, HEADER_SIZE};
use crate::decoder::read_preamble;

/// Recomputes the preamble checksum of `bytes` in place (after editing header, table or
/// metadata bytes). Returns `false` when the preamble cannot be located.
pub fn fix_preamble_checksum(bytes: &mut [u8]) -> bool {
    if bytes.len() < HEADER_SIZE {
        return false;
    }
    let levels = u32::from_le_bytes(bytes[16..20].try_into().expect("4 bytes")) as usize;
    let meta = u32::from_le_bytes(bytes[104..108].try_into().expect("4 bytes")) as usize;
    let version = u16::from_le_bytes(bytes[8..10].try_into().expect("2 bytes"));
    let chunks =
        if version >= 5 { u32::from_le_bytes(bytes[108..112].try_into().expect("4 bytes")) as usize } else { 0 };
    let end = HEADER_SIZE + ENTRY_SIZE * levels + CHUNK_ENTRY_SIZE * chunks + meta;
    if bytes.len() < end + 8 {
        return false;
    }
    let sum = xxhash_rust::xxh3::xxh3_64(&bytes[..end]);
    bytes[end..end + 8].copy_from_slice(&sum.to_le_bytes());
    true
}

/// `bytes` with level `k`'s stored bytes replaced by `stored` and its `raw_size` set to
/// `raw_size`: the level table's sizes, offsets and checksums and the preamble checksum are
/// recomputed, so that the file reaches the level's decompression. `None` when `bytes` is not
/// a readable file or has no level `k`.
pub fn replace_stored(bytes: &[u8], k: usize, stored: &[u8], raw_size: u64) -> Option<Vec<u8>> {
    let mut r = bytes;
    let mut pre = read_preamble(&mut r, &Limits::default()).ok()?;
    if !crate::fuzzing::one_chunk_per_level(&pre) {
        return None;
    }
    let mut levels: Vec<Vec<u8>> = pre
        .levels
        .iter()
        .map(|e| bytes.get(e.offset as usize..(e.offset + e.stored_size) as usize).map(<[u8]>::to_vec))
        .collect::<Option<_>>()?;
    *levels.get_mut(k)? = stored.to_vec();
    pre.levels[k].raw_size = raw_size;
    let mut offset = pre.size();
    for (e, s) in pre.levels.iter_mut().zip(&levels) {
        e.offset = offset;
        e.stored_size = s.len() as u64;
        e.checksum = xxhash_rust::xxh3::xxh3_64(s);
        offset += s.len() as u64;
    }
    crate::fuzzing::sync_chunks(&mut pre);
    let mut out = pre.to_bytes();
    for s in levels {
        out.extend(s);
    }
    Some(out)
}
