//! Topology of mode 3 (spec §5.9, lattice refinement with first-use numbering): vertices
//! numbered by first use in corner order, found by their lattice keys in an open-addressing table;
//! keys with several vertices listed once (`splits`), their corners picking one by ordinal
//! (`choices`). The face streams are mode 2's (`super::lattice`).

use crate::block::s;
use crate::bytes::{Reader, put_varint, zigzag};
use crate::error::DecodeError;
use crate::geometry::fixed::{Contexts, OFFSETS};
use crate::level_encode::Streams;
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

/// The open-addressing table of a level's keys (§5.9): per key its vertex, or for split keys the
/// list of their vertices so far.
struct KeyTable<'s> {
    keys: &'s mut [u64],
    values: &'s mut [u32],
    split_vertices: &'s mut Vec<Vec<u32>>,
    mask: usize,
}

/// The vertices numbered so far: per vertex its lattice corner, and the contexts found on the way.
struct Numbering<'s> {
    corners: Vec<[u32; 3]>,
    ctx: &'s mut Contexts,
    keys_at: CornerKeys,
    nv: usize,
}

impl Numbering<'_> {
    /// Numbers a new vertex at `key`, first used by corner `c`; fails when `vertex_count` is
    /// reached (the error from `r`).
    #[inline]
    fn push(&mut self, key: u64, c: usize, r: &Reader<'_>) -> Result<u32, DecodeError> {
        let v = self.corners.len();
        if v == self.nv {
            return Err(r.invalid(format!("corners number more than vertex_count ({}) vertices", self.nv)));
        }
        self.corners.push(self.keys_at.corner(key));
        self.ctx.first[v] = c as u32;
        Ok(v as u32)
    }
}

/// Corner resolution of mode 3 (spec §5.9): `pred[c]` is corner `c`'s predicted lattice key
/// (depth `k`, valid); fills `indices` (corner to vertex, first-use numbering), clears `pos[c]` at
/// exception corners (and `rotation_hints` of their faces), and returns every vertex's lattice
/// corner. The contexts of [`crate::geometry::fixed::contexts`] are found on the way (the decoder
/// needs no second pass).
pub fn resolve(
    k: u32,
    nv: usize,
    (pred, pos): (&[u64], &mut [u8]),
    (indices, rotation_hints): (&mut [u32], &mut [u8]),
    st: ResolveStreams<'_, '_>,
    faces: LevelFaces<'_>,
    (scratch, ctx): (&mut ResolveScratch, &mut Contexts),
) -> Result<Vec<[u32; 3]>, DecodeError> {
    let nc = pred.len();
    ctx.reset(nv);
    let mut table = split_keys(k, nv, nc, st.splits, scratch)?;
    let mut numbering = Numbering { corners: Vec::with_capacity(nv), ctx, keys_at: CornerKeys::new(k), nv };
    let exceptions = ExceptionList::read(st.exceptions, nc)?;
    let streams = (exceptions, st.exceptions, st.choices);
    number_corners(k, (pred, pos), (indices, rotation_hints), streams, faces, &mut table, &mut numbering)?;
    unused_vertices(k, nv, st.extras, &mut numbering)?;
    Ok(numbering.corners)
}

/// Reads the split keys (a gap list, strictly increasing, each a lattice corner of depth `k`) into
/// a fresh key table sized for `nv` vertices.
fn split_keys<'s>(
    k: u32,
    nv: usize,
    nc: usize,
    r: &mut Reader<'_>,
    scratch: &'s mut ResolveScratch,
) -> Result<KeyTable<'s>, DecodeError> {
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
            .filter(|&x| lattice::corner_from_key(x, k).is_some())
            .ok_or_else(|| r.invalid(format!("split key {i} is not a lattice corner of level {k}")))?;
        let e = probe(keys, key, mask);
        keys[e] = key + 1;
        values[e] = SPLIT | i as u32;
        split_vertices.push(Vec::new());
    }
    Ok(KeyTable { keys, values, split_vertices, mask })
}

/// The exception positions of a level: a count, then a gap list read one at a time.
struct ExceptionList {
    left: usize,
    next: usize,
}

impl ExceptionList {
    fn read(e: &mut Reader<'_>, nc: usize) -> Result<Self, DecodeError> {
        let left = e.varint_max(nc as u64, "exception count")? as usize;
        let next = if left > 0 { e.varint_max(nc as u64, "exception position")? as usize } else { usize::MAX };
        Ok(Self { left, next })
    }

    /// Moves past the exception at corner `c`.
    fn advance(&mut self, e: &mut Reader<'_>, nc: usize, c: usize) -> Result<(), DecodeError> {
        self.left -= 1;
        self.next = if self.left > 0 {
            let gap = e.varint_max(nc as u64, "exception position gap")? as usize;
            c + 1 + gap
        } else {
            usize::MAX
        };
        Ok(())
    }
}

/// Numbers the corners in order (§5.9): exceptions name an earlier vertex or a new one at a key
/// near the prediction; other corners find their key's vertex, number a new one, or pick one of a
/// split key's vertices.
fn number_corners(
    k: u32,
    (pred, pos): (&[u64], &mut [u8]),
    (indices, rotation_hints): (&mut [u32], &mut [u8]),
    (mut exc, e, ch): (ExceptionList, &mut Reader<'_>, &mut Reader<'_>),
    (parents, quadrants, parent_quads): LevelFaces<'_>,
    table: &mut KeyTable<'_>,
    numbering: &mut Numbering<'_>,
) -> Result<(), DecodeError> {
    let nc = pred.len();
    let (mut fpf, mut fu, mut fw) = (NONE, 0u8, 0u8);
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
        if c == exc.next {
            indices[c] = exception_vertex(k, c, pred[c], e, table, numbering)?;
            pos[c] = NO_POS;
            // The face's corners no longer all sit on its slot's canonical corners.
            rotation_hints[c / 4] = u8::MAX;
            exc.advance(e, nc, c)?;
            continue;
        }
        let v = predicted_vertex(c, pred[c], ch, table, numbering)?;
        indices[c] = v;
        let sp = pos[c];
        let ctx = &mut *numbering.ctx;
        if sp != NO_POS && ctx.face[v as usize] == NONE {
            let (eu, ew) = OFFSETS[usize::from(sp & 3)];
            ctx.face[v as usize] = fpf;
            ctx.stencil[v as usize] = 3 * (fu + eu) + (fw + ew);
        }
    }
    if exc.next != usize::MAX {
        return Err(e.invalid(format!("exception position {} is beyond the corners", exc.next)));
    }
    Ok(())
}

/// The vertex of exception corner `c`: an earlier vertex, or a new one at the predicted key
/// moved by a zigzag delta (a valid key, new or split).
fn exception_vertex(
    k: u32,
    c: usize,
    pred: u64,
    e: &mut Reader<'_>,
    table: &mut KeyTable<'_>,
    numbering: &mut Numbering<'_>,
) -> Result<u32, DecodeError> {
    let next = numbering.corners.len();
    let v = e.varint_max(next as u64, "exception vertex")? as usize;
    if v == next {
        if next == numbering.nv {
            return Err(e.invalid(format!("corners number more than vertex_count ({next}) vertices")));
        }
        let d = crate::bytes::unzigzag(e.varint()?);
        let key = pred
            .checked_add_signed(d)
            .filter(|&x| lattice::corner_from_key(x, k).is_some())
            .ok_or_else(|| e.invalid(format!("exception key at corner {c} is not a lattice corner")))?;
        let slot = probe(table.keys, key, table.mask);
        let is_new = table.keys[slot] == 0;
        let is_split = !is_new && table.values[slot] & SPLIT != 0;
        if !is_new && !is_split {
            return Err(e.invalid(format!("two vertices at key {key}, which is not a split key")));
        }
        numbering.push(key, c, e)?;
        if is_new {
            table.keys[slot] = key + 1;
            table.values[slot] = v as u32;
        } else {
            table.split_vertices[(table.values[slot] & !SPLIT) as usize].push(v as u32);
        }
    }
    Ok(v as u32)
}

/// The vertex of corner `c` at its predicted key: the key's vertex, a new one, or (split keys)
/// the one its choice names.
#[inline]
fn predicted_vertex(
    c: usize,
    key: u64,
    ch: &mut Reader<'_>,
    table: &mut KeyTable<'_>,
    numbering: &mut Numbering<'_>,
) -> Result<u32, DecodeError> {
    let slot = probe(table.keys, key, table.mask);
    if table.keys[slot] == 0 {
        let v = numbering.push(key, c, ch)?;
        table.keys[slot] = key + 1;
        table.values[slot] = v;
        return Ok(v);
    }
    if table.values[slot] & SPLIT == 0 {
        return Ok(table.values[slot]);
    }
    let list = &mut table.split_vertices[(table.values[slot] & !SPLIT) as usize];
    let o = ch.varint_max(list.len() as u64, "choice")? as usize;
    if o < list.len() {
        return Ok(list[o]);
    }
    let v = numbering.push(key, c, ch)?;
    table.split_vertices[(table.values[slot] & !SPLIT) as usize].push(v);
    Ok(v)
}

/// The vertices no corner uses (`extra_names`): their count, which must complete
/// `vertex_count`, and their keys as zigzag deltas.
fn unused_vertices(k: u32, nv: usize, r: &mut Reader<'_>, numbering: &mut Numbering<'_>) -> Result<(), DecodeError> {
    let corners = &mut numbering.corners;
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
            .filter(|&x| lattice::corner_from_key(x, k).is_some())
            .ok_or_else(|| r.invalid("extra vertex key is not a lattice corner"))?;
        corners.push(numbering.keys_at.corner(key));
    }
    Ok(())
}

/// Mode 3's vertex numbering (spec §5.9): vertices by first use in corner order, the split keys,
/// exceptions and choices, and the vertices no corner uses. Returns the corners' new vertex
/// indices and the input index of every new vertex.
pub fn encode(
    k: u32,
    corners: &[[u32; 3]],
    (corner_vertex, pred): (&[u32], &[u64]),
    pos: &mut [u8],
    nv: usize,
    st: &mut Streams,
) -> (Vec<u32>, Vec<u32>) {
    let vkey: Vec<u64> = corners.iter().map(|&c| lattice::corner_key(c, k)).collect();
    let mut used = vec![false; nv];
    for &v in corner_vertex {
        used[v as usize] = true;
    }
    // Keys of two or more vertices that corners use are split keys.
    let mut keyed: Vec<u64> = (0..nv).filter(|&v| used[v]).map(|v| vkey[v]).collect();
    keyed.sort_unstable();
    let mut split_keys: Vec<u64> = keyed.windows(2).filter(|w| w[0] == w[1]).map(|w| w[0]).collect();
    split_keys.dedup();
    put_varint(&mut st.0[s::SPLITS], split_keys.len() as u64);
    for (i, &key) in split_keys.iter().enumerate() {
        put_varint(&mut st.0[s::SPLITS], if i == 0 { key } else { key - split_keys[i - 1] - 1 });
    }
    let mut lists: std::collections::BTreeMap<u64, Vec<u32>> =
        split_keys.iter().map(|&key| (key, Vec::new())).collect();
    let mut vnew = vec![u32::MAX; nv];
    let mut vorder: Vec<u32> = Vec::with_capacity(nv);
    let mut indices = Vec::with_capacity(corner_vertex.len());
    let mut exceptions: Vec<(usize, u32, Option<i64>)> = Vec::new();
    for (c, &v) in corner_vertex.iter().enumerate() {
        let vi = v as usize;
        let new = vnew[vi] == u32::MAX;
        if new {
            vnew[vi] = vorder.len() as u32;
            vorder.push(v);
        }
        let x = vnew[vi];
        indices.push(x);
        if vkey[vi] != pred[c] {
            exceptions.push((c, x, new.then(|| vkey[vi] as i64 - pred[c] as i64)));
            pos[c] = NO_POS;
            if new {
                if let Some(l) = lists.get_mut(&vkey[vi]) {
                    l.push(x);
                }
            }
            continue;
        }
        if let Some(l) = lists.get_mut(&pred[c]) {
            let o = l.iter().position(|&y| y == x).unwrap_or_else(|| {
                l.push(x);
                l.len() - 1
            });
            put_varint(&mut st.0[s::CHOICES], o as u64);
        }
    }
    let e = &mut st.0[s::EXCEPTIONS];
    put_varint(e, exceptions.len() as u64);
    for (j, &(c, x, key)) in exceptions.iter().enumerate() {
        put_varint(e, if j == 0 { c as u64 } else { (c - exceptions[j - 1].0 - 1) as u64 });
        put_varint(e, u64::from(x));
        if let Some(d) = key {
            put_varint(e, zigzag(d));
        }
    }
    // Vertices no corner uses, by key.
    let mut extras: Vec<u32> = (0..nv as u32).filter(|&v| !used[v as usize]).collect();
    extras.sort_by_key(|&v| (vkey[v as usize], v));
    let r = &mut st.0[s::EXTRA_NAMES];
    put_varint(r, extras.len() as u64);
    let mut prev = 0i64;
    for &v in &extras {
        let key = vkey[v as usize] as i64;
        put_varint(r, zigzag(key - prev));
        prev = key;
        vorder.push(v);
    }
    (indices, vorder)
}
