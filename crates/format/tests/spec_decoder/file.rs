//! Spec §7.1: a whole file, preamble then level by level, and the positions of §6.7.

use super::block;
use super::container::{self, CUBE, DEFAULT_LIMITS, Metadata};
use super::primitives::{self, Result};
use super::topology::Level;

/// A file decoded by the spec decoder.
pub struct File {
    pub cube: Option<([f64; 3], [f64; 3])>,
    pub metadata: Metadata,
    pub levels: Vec<Level>,
    /// Per level, per vertex: its position (§6.7).
    pub positions: Vec<Vec<[f64; 3]>>,
}

/// §7.1: the whole file, level by level.
pub fn decode(bytes: &[u8]) -> Result<File> {
    let pre = container::read_preamble(bytes, &DEFAULT_LIMITS)?;
    let h = &pre.header;
    let ctx = block::FileContext::new(h);
    let mut levels: Vec<Level> = Vec::new();
    let mut above = std::collections::BTreeMap::new();
    for (k, e) in pre.entries.iter().enumerate() {
        if h.version >= 5 {
            // §11: the level from its chunks.
            let (level, chunks) = super::chunks::decode_level(bytes, k, e, &pre.chunks, ctx, &above)?;
            levels.push(level);
            above = chunks;
            continue;
        }
        let raw = block::payload(bytes, k, e)?;
        let level = block::decode_level(k, &raw, e, ctx, levels.last())?;
        levels.push(level);
    }
    // §3.5 and §7.1 step 7: the file ends with the last level's stored bytes.
    let end = pre.entries.last().map_or(0, |e| e.offset + e.stored_size);
    if end != bytes.len() as u64 {
        return primitives::invalid(format!("bytes follow the last level (offset {end})"));
    }
    // §6.7.
    let positions = levels
        .iter()
        .map(|l| {
            if ctx.exact {
                l.exact.clone()
            } else {
                l.q.iter()
                    .map(|q| [0, 1, 2].map(|a| h.origin[a] + primitives::to_f64(i128::from(q[a])) * h.step))
                    .collect()
            }
        })
        .collect();
    let cube = (h.flags & CUBE != 0).then_some((h.cube_min, h.cube_max));
    Ok(File { cube, metadata: pre.metadata, levels, positions })
}
