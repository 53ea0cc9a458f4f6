//! Topology of mode 3 (spec §5.9, lattice refinement with first-use numbering): vertices
//! numbered by first use in corner order, found by their lattice keys in an open-addressing table;
//! keys with several vertices listed once (`splits`), their corners picking one by ordinal
//! (`choices`). The face streams are mode 2's (`super::lattice`).

use crate::bytes::Reader;
use crate::error::DecodeError;
use crate::geometry::fixed::{Contexts, OFFSETS};
use crate::topology::ROTATIONS;
use crate::topology::slots::{self as lattice, CornerKeys};
use crate::topology::{NO_PARENT, NO_POS, NONE};

/// The decoder's buffers for [`resolve`], reused from level to level.
#[derive(Default)]
pub struct ResolveScratch {
    /// Open-addressing table: `key + 1` (0: empty).
    keys: Vec<u64>,
    /// Per table entry: the key's vertex, or `SPLIT | split index`.
    values: Vec<u32>,
    /// Vertices of each split key, in numbering order.
    split_vertices: Vec<Vec<u32>>,
}

impl ResolveScratch {
    /// Bytes held.
    pub fn capacity_bytes(&self) -> usize {
        self.keys.capacity() * 8 + self.values.capacity() * 4
    }
}

const SPLIT: u32 = 1 << 31;

/// The home entry of `key` in a table of `mask + 1` (a power of two, at least 2) entries: the top
/// bits of a multiplicative hash (the best mixed ones; lattice keys are very regular).
#[inline]
fn slot_of(key: u64, mask: usize) -> usize {
    (key.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> (mask as u64).leading_zeros()) as usize & mask
}

/// Finds `key`'s table entry, or the empty entry where it would go.
#[inline]
fn probe(keys: &[u64], key: u64, mask: usize) -> usize {
    let mut i = slot_of(key, mask);
    loop {
        let k = keys[i];
        if k == key + 1 || k == 0 {
            return i;
        }
        i = (i + 1) & mask;
    }
}

/// The streams [`resolve`] reads.
pub struct ResolveStreams<'s, 'a> {
    /// `splits`.
    pub splits: &'s mut Reader<'a>,
    /// `exceptions`.
    pub exceptions: &'s mut Reader<'a>,
    /// `choices`.
    pub choices: &'s mut Reader<'a>,
    /// `extra_names`.
    pub extras: &'s mut Reader<'a>,
}

/// What [`resolve`] reads of the level's faces: per face its parent and quadrant, per parent face
/// its canonical quad and orientation.
pub type LevelFaces<'a> = (&'a [u32], &'a [u8], &'a [([u32; 4], u8)]);

#[allow(clippy::too_many_lines, clippy::too_many_arguments)] // spec §5.9 in order
/// Corner resolution of mode 3 (spec §5.9): `pred[c]` is corner `c`'s predicted lattice key
/// (depth `k`, valid); fills `indices` (corner to vertex, first-use numbering), clears `pos[c]` at
/// exception corners (and `rotation_hints` of their faces), and returns every vertex's lattice
/// corner.
pub fn resolve(
    k: u32,
    nv: usize,
    pred: &[u64],
    pos: &mut [u8],
    indices: &mut [u32],
    st: ResolveStreams<'_, '_>,
    scratch: &mut ResolveScratch,
    (parents, quadrants, parent_quads): LevelFaces<'_>,
    ctx: &mut Contexts,
    rotation_hints: &mut [u8],
) -> Result<Vec<[u32; 3]>, DecodeError> {
    let nc = pred.len();
    // The contexts of [`contexts`], found on the way (the decoder needs no second pass).
    ctx.first.clear();
    ctx.first.resize(nv, NONE);
    ctx.face.clear();
    ctx.face.resize(nv, NONE);
    ctx.stencil.clear();
    ctx.stencil.resize(nv, 0);
    let (mut fpf, mut fu, mut fw) = (NONE, 0u8, 0u8);
    let keys_at = CornerKeys::new(k);
    let valid = |key: u64| lattice::corner_from_key(key, k).is_some();
    // Split keys: a gap list (strictly increasing), each valid.
    let r = st.splits;
    let ns = r.varint_max(nc as u64, "split key count")? as usize;
    if ns > r.remaining() {
        return Err(r.invalid(format!("{ns} split keys do not fit in the stream")));
    }
    let cap = (2 * (nv + ns) + 2).next_power_of_two();
    let mask = cap - 1;
    let ResolveScratch { keys, values, split_vertices } = scratch;
    keys.clear();
    keys.resize(cap, 0);
    values.clear();
    values.resize(cap, 0);
    split_vertices.clear();
    let mut key = 0u64;
    for i in 0..ns {
        let gap = r.varint()?;
        key = if i == 0 { Some(gap) } else { key.checked_add(1).and_then(|x| x.checked_add(gap)) }
            .filter(|&x| valid(x))
            .ok_or_else(|| r.invalid(format!("split key {i} is not a lattice corner of level {k}")))?;
        let e = probe(keys, key, mask);
        keys[e] = key + 1;
        values[e] = SPLIT | i as u32;
        split_vertices.push(Vec::new());
    }
    let mut corners: Vec<[u32; 3]> = Vec::with_capacity(nv);
    // Registers a new vertex under `key` (spec §5.9: every numbered vertex is found by its key).
    let e = st.exceptions;
    let nexc = e.varint_max(nc as u64, "exception count")? as usize;
    let mut exc_left = nexc;
    let mut next_exc = if nexc > 0 { e.varint_max(nc as u64, "exception position")? as usize } else { usize::MAX };
    let ch = st.choices;
    let too_many = |r: &Reader<'_>| r.invalid(format!("corners number more than vertex_count ({nv}) vertices"));
    for c in 0..nc {
        if c % 4 == 0 {
            // A new face: its parent and the in-plane offsets of its quadrant's corner.
            let f = c / 4;
            fpf = parents[f];
            if fpf != NO_PARENT {
                let t = ROTATIONS[usize::from(parent_quads[fpf as usize].1 & 7)][usize::from(quadrants[f] & 3)];
                (fu, fw) = OFFSETS[usize::from(t)];
            }
        }
        if c == next_exc {
            let next = corners.len();
            let v = e.varint_max(next as u64, "exception vertex")? as usize;
            if v == next {
                if next == nv {
                    return Err(too_many(e));
                }
                let d = crate::bytes::unzigzag(e.varint()?);
                let key = pred[c]
                    .checked_add_signed(d)
                    .filter(|&x| valid(x))
                    .ok_or_else(|| e.invalid(format!("exception key at corner {c} is not a lattice corner")))?;
                let slot = probe(keys, key, mask);
                if keys[slot] == 0 {
                    keys[slot] = key + 1;
                    values[slot] = v as u32;
                } else if values[slot] & SPLIT != 0 {
                    split_vertices[(values[slot] & !SPLIT) as usize].push(v as u32);
                } else {
                    return Err(e.invalid(format!("two vertices at key {key}, which is not a split key")));
                }
                corners.push(keys_at.corner(key));
                ctx.first[v] = c as u32;
            }
            indices[c] = v as u32;
            pos[c] = NO_POS;
            // The face's corners no longer all sit on its slot's canonical corners.
            rotation_hints[c / 4] = u8::MAX;
            exc_left -= 1;
            next_exc = if exc_left > 0 {
                let gap = e.varint_max(nc as u64, "exception position gap")? as usize;
                c + 1 + gap
            } else {
                usize::MAX
            };
            continue;
        }
        let key = pred[c];
        let slot = probe(keys, key, mask);
        let v = if keys[slot] == 0 {
            let v = corners.len();
            if v == nv {
                return Err(too_many(ch));
            }
            keys[slot] = key + 1;
            values[slot] = v as u32;
            corners.push(keys_at.corner(key));
            ctx.first[v] = c as u32;
            v as u32
        } else if values[slot] & SPLIT == 0 {
            values[slot]
        } else {
            let list = &mut split_vertices[(values[slot] & !SPLIT) as usize];
            let o = ch.varint_max(list.len() as u64, "choice")? as usize;
            if o == list.len() {
                let v = corners.len();
                if v == nv {
                    return Err(too_many(ch));
                }
                list.push(v as u32);
                corners.push(keys_at.corner(key));
                ctx.first[v] = c as u32;
                v as u32
            } else {
                list[o]
            }
        };
        indices[c] = v;
        let sp = pos[c];
        if sp != NO_POS && ctx.face[v as usize] == NONE {
            let (eu, ew) = OFFSETS[usize::from(sp & 3)];
            ctx.face[v as usize] = fpf;
            ctx.stencil[v as usize] = 3 * (fu + eu) + (fw + ew);
        }
    }
    if next_exc != usize::MAX {
        return Err(e.invalid(format!("exception position {next_exc} is beyond the corners")));
    }
    // Vertices no corner uses: their keys as zigzag deltas.
    let r = st.extras;
    let left = nv - corners.len();
    let n = r.varint_max(left as u64, "extra vertex count")? as usize;
    if n != left {
        return Err(r.invalid(format!("{} vertices numbered and {n} extra, vertex_count is {nv}", corners.len())));
    }
    let mut key = 0u64;
    for _ in 0..n {
        let d = crate::bytes::unzigzag(r.varint()?);
        key = key
            .checked_add_signed(d)
            .filter(|&x| valid(x))
            .ok_or_else(|| r.invalid("extra vertex key is not a lattice corner"))?;
        corners.push(keys_at.corner(key));
    }
    Ok(corners)
}
