//! Names and splits (spec §5.5) and corners (§5.6) of modes 1 and 2: the level's name set (the
//! sorted distinct names its corners predict, found in linear time, plus the extra names), the
//! vertices of each name, and every corner's vertex.

use crate::block::{Mode, s};
use crate::bytes::{Reader, put_varint, unzigzag, zigzag};
use crate::error::{DecodeError, Where};
use crate::level_encode::{CornerPlan, Streams};
use crate::topology::slots as lattice;
use crate::topology::{NO_POS, NONE};

/// The sorted distinct predicted names (into `names`), and per corner the index of its name
/// (into `name_of`; `NONE` for corners without a prediction). `bounds`: the smallest and largest
/// name and the number of predicted corners, when the caller knows them (every corner predicted). Dense names go through a bitmap
/// with ranks (`bits`, `rank`: scratch); others through an LSD radix sort on 11-bit digits,
/// skipping the digits where all names agree, with (name - smallest name, corner) packed in one
/// `u64` when both fit. Linear in the corner count either way.
pub fn sort_names(
    pred: &[u64],
    bounds: Option<(u64, u64, usize)>,
    names: &mut Vec<u64>,
    name_of: &mut Vec<u32>,
    bits: &mut Vec<u64>,
    rank: &mut Vec<u32>,
) {
    let (lo, hi, n) = bounds.unwrap_or_else(|| {
        let (mut lo, mut hi) = (u64::MAX, 0u64);
        let mut n = 0usize;
        for &p in pred {
            if p != u64::MAX {
                lo = lo.min(p);
                hi = hi.max(p);
                n += 1;
            }
        }
        (lo, hi, n)
    });
    names.clear();
    name_of.clear();
    name_of.resize(pred.len(), NONE);
    if n == 0 {
        return;
    }
    if (hi - lo) / 64 < n as u64 {
        // Dense names (every generic level, lattice levels of a surface): a bitmap of the names
        // and a rank per 64-bit word; no more memory than the sort would take.
        let words = ((hi - lo) / 64 + 1) as usize;
        bits.clear();
        bits.resize(words, 0);
        for &p in pred {
            if p != u64::MAX {
                let x = p - lo;
                bits[(x / 64) as usize] |= 1 << (x % 64);
            }
        }
        rank.clear();
        rank.reserve(words);
        let mut acc = 0u32;
        for (w, &b) in bits.iter().enumerate() {
            rank.push(acc);
            acc += b.count_ones();
            let mut b = b;
            while b != 0 {
                names.push(lo + 64 * w as u64 + u64::from(b.trailing_zeros()));
                b &= b - 1;
            }
        }
        for (c, &p) in pred.iter().enumerate() {
            if p != u64::MAX {
                let x = p - lo;
                let w = (x / 64) as usize;
                name_of[c] = rank[w] + (bits[w] & ((1u64 << (x % 64)) - 1)).count_ones();
            }
        }
        return;
    }
    let kbits = 64 - (hi - lo).leading_zeros();
    let cbits = 64 - (pred.len() as u64).leading_zeros();
    if kbits + cbits <= 64 {
        let mut keys: Vec<u64> = Vec::with_capacity(n);
        for (c, &p) in pred.iter().enumerate() {
            if p != u64::MAX {
                keys.push((p - lo) << cbits | c as u64);
            }
        }
        let mut tmp = vec![0u64; n];
        radix_passes(&mut keys, &mut tmp, cbits, cbits + kbits, |x| x);
        let cmask = (1u64 << cbits) - 1;
        for &x in &keys {
            let key = (x >> cbits) + lo;
            if names.last() != Some(&key) {
                names.push(key);
            }
            name_of[(x & cmask) as usize] = names.len() as u32 - 1;
        }
    } else {
        let mut pairs: Vec<(u64, u32)> = Vec::with_capacity(n);
        for (c, &p) in pred.iter().enumerate() {
            if p != u64::MAX {
                pairs.push((p - lo, c as u32));
            }
        }
        let mut tmp = vec![(0u64, 0u32); n];
        radix_passes(&mut pairs, &mut tmp, 0, kbits, |x| x.0);
        for &(key, c) in &pairs {
            let key = key + lo;
            if names.last() != Some(&key) {
                names.push(key);
            }
            name_of[c as usize] = names.len() as u32 - 1;
        }
    }
}

/// Stable LSD radix sort of `items` by bits `from .. to` of `key(item)`, 11 bits per pass; passes
/// whose digit is the same for every item are skipped.
fn radix_passes<T: Copy>(items: &mut Vec<T>, tmp: &mut Vec<T>, from: u32, to: u32, key: impl Fn(T) -> u64) {
    let mut count = [0u32; 2048];
    let mut shift = from;
    while shift < to {
        count.fill(0);
        for &x in items.iter() {
            count[((key(x) >> shift) & 2047) as usize] += 1;
        }
        if count.iter().any(|&c| c as usize == items.len()) {
            shift += 11;
            continue;
        }
        let mut acc = 0u32;
        for c in &mut count {
            let here = *c;
            *c = acc;
            acc += here;
        }
        for &x in items.iter() {
            let d = ((key(x) >> shift) & 2047) as usize;
            tmp[count[d] as usize] = x;
            count[d] += 1;
        }
        std::mem::swap(items, tmp);
        shift += 11;
    }
}

/// The buffers of [`decode_names`].
#[derive(Default)]
pub struct NameScratch {
    /// The level's names, sorted.
    pub names: Vec<u64>,
    /// Per corner: the index of its name, or [`NONE`].
    pub name_of: Vec<u32>,
    /// [`sort_names`]' bitmap and ranks.
    pub bits: Vec<u64>,
    /// See `bits`.
    pub rank: Vec<u32>,
}

impl NameScratch {
    /// Bytes held by the buffers.
    pub fn capacity_bytes(&self) -> usize {
        self.names.capacity() * 8 + self.name_of.capacity() * 4 + self.bits.capacity() * 8 + self.rank.capacity() * 4
    }
}

/// A refinement level's names (§5.5) and how many vertices each has.
pub struct NameSet<'a> {
    /// The name set, sorted.
    pub names: &'a [u64],
    /// Per corner: the index of its name, or [`NONE`] (explicit corners).
    pub name_of: &'a [u32],
    /// Per name: its vertex count.
    pub count: Vec<u32>,
    /// Number of split entries.
    pub nsplit: usize,
}

/// Decodes the name set and splits of a mode 1 or 2 level of depth `k` (§5.5) from the
/// corners' predicted names `pred` (`name_bounds`: their range and number when every corner
/// has one) and the `extra_names` and `splits` streams.
pub fn decode_names<'a>(
    (k, mode, nv): (u32, Mode, usize),
    st: &mut [Reader<'_>],
    pred: &[u64],
    name_bounds: Option<(u64, u64, usize)>,
    scratch: &'a mut NameScratch,
) -> Result<NameSet<'a>, DecodeError> {
    // §5.5: the name set and splits.
    // Predicted names, sorted once (radix); `name_of[c]` = the index of corner c's name.
    let NameScratch { names, name_of, bits, rank } = scratch;
    sort_names(pred, name_bounds, names, name_of, bits, rank);
    let r = &mut st[s::EXTRA_NAMES];
    let ne = r.varint_max(nv as u64, "extra name count")? as usize;
    if ne > r.remaining() {
        return Err(r.invalid(format!("{ne} extra names do not fit in the stream")));
    }
    let mut extras = Vec::with_capacity(ne);
    let mut name = 0u64;
    for i in 0..ne {
        let gap = r.varint()?;
        name = if i == 0 { Some(gap) } else { name.checked_add(1).and_then(|x| x.checked_add(gap)) }
            .filter(|&x| x != u64::MAX)
            .ok_or_else(|| r.invalid("extra name overflows"))?;
        if names.binary_search(&name).is_ok() {
            return Err(r.invalid(format!("extra name {name} is already a predicted name")));
        }
        if mode == Mode::Lattice && lattice::corner_from_key(name, k).is_none() {
            return Err(r.invalid(format!("extra name {name} is not a lattice corner of level {k}")));
        }
        extras.push(name);
    }
    if !extras.is_empty() {
        // Merge the extras in and shift the corners' name indices.
        let mut merged = Vec::with_capacity(names.len() + extras.len());
        let mut shift = Vec::with_capacity(names.len());
        let mut e = 0;
        for &n in names.iter() {
            while e < extras.len() && extras[e] < n {
                merged.push(extras[e]);
                e += 1;
            }
            shift.push(merged.len() as u32);
            merged.push(n);
        }
        merged.extend_from_slice(&extras[e..]);
        for x in name_of.iter_mut() {
            if *x != NONE {
                *x = shift[*x as usize];
            }
        }
        *names = merged;
    }
    let mut count = vec![1u32; names.len()];
    let r = &mut st[s::SPLITS];
    let nsplit = r.varint_max(names.len() as u64, "split count")? as usize;
    let mut idx = 0usize;
    // Vertices: one per name without a split entry, plus the counts of the entries.
    let mut counted = 0u64;
    for i in 0..nsplit {
        let gap = r.varint_max(names.len() as u64, "split index gap")? as usize;
        idx = if i == 0 { gap } else { idx + 1 + gap };
        if idx >= names.len() {
            return Err(r.invalid(format!("split names index {idx}, there are {} names", names.len())));
        }
        let at = r.offset();
        let c = r.varint_max(nv as u64, "split vertex count")?;
        if c == 1 {
            return Err(DecodeError::Invalid {
                place: Where::Payload(k),
                offset: at,
                what: "splits",
                reason: "a split entry must not say 1".into(),
            });
        }
        counted += c;
        if counted > nv as u64 {
            return Err(r.invalid("splits make more vertices than vertex_count"));
        }
        count[idx] = c as u32;
    }
    let total = counted + (names.len() - nsplit) as u64;
    if total != nv as u64 {
        return Err(st[s::SPLITS].invalid(format!("names and splits make {total} vertices, vertex_count is {nv}")));
    }
    Ok(NameSet { names, name_of, count, nsplit })
}

/// Resolves every corner of a mode 1 or 2 level to its vertex (§5.6 Corners) into `indices`:
/// through its name and, for split names, a choice; exceptions name their vertex; explicit
/// corners (no prediction) read theirs from `corners`. Clears `pos` at exceptions.
pub fn decode_corners(
    [nv, nc]: [usize; 2],
    st: &mut [Reader<'_>],
    (pred, name_bounds): (&[u64], Option<(u64, u64, usize)>),
    set: &NameSet<'_>,
    (indices, pos): (&mut [u32], &mut [u8]),
) -> Result<(), DecodeError> {
    let NameSet { names, name_of, count, nsplit } = set;
    let nsplit = *nsplit;
    // §5.6: corners to vertices.
    let nexc = st[s::EXCEPTIONS].varint_max(nc as u64, "exception count")? as usize;
    let explicit = name_bounds.is_none() && pred.contains(&u64::MAX);
    if nsplit == 0 && !explicit {
        // One vertex per name, numbered as the names: corner c's vertex is its name's index,
        // then the exceptions.
        indices.copy_from_slice(name_of);
        let r = &mut st[s::EXCEPTIONS];
        let mut at = 0u64;
        for i in 0..nexc {
            let c = if i == 0 {
                r.varint_max(nc as u64, "exception position")?
            } else {
                at + 1 + r.varint_max(nc as u64, "exception position gap")?
            };
            if c >= nc as u64 {
                return Err(r.invalid(format!("exception position {c} is beyond the corners")));
            }
            let v = r.varint_max(nv.saturating_sub(1) as u64, "exception vertex")?;
            if nv == 0 {
                return Err(r.invalid("exception in a level without vertices"));
            }
            indices[c as usize] = v as u32;
            pos[c as usize] = NO_POS;
            at = c;
        }
    } else {
        let mut first = Vec::with_capacity(names.len() + 1);
        let mut acc = 0u32;
        for &c in count {
            first.push(acc);
            acc += c;
        }
        first.push(acc);
        let mut exc_left = nexc;
        let mut next_exc =
            if nexc > 0 { Some(st[s::EXCEPTIONS].varint_max(nc as u64, "exception position")?) } else { None };
        let mut prev_explicit = 0i64;
        for c in 0..nc {
            if pred[c] == u64::MAX {
                prev_explicit = prev_explicit.wrapping_add(unzigzag(st[s::CORNERS].varint()?));
                if prev_explicit < 0 || prev_explicit >= nv as i64 {
                    return Err(st[s::CORNERS].invalid(format!("vertex index {prev_explicit} out of range 0..{nv}")));
                }
                indices[c] = prev_explicit as u32;
                if next_exc == Some(c as u64) {
                    return Err(st[s::EXCEPTIONS].invalid(format!("exception at corner {c}, which has no prediction")));
                }
                continue;
            }
            if next_exc == Some(c as u64) {
                let r = &mut st[s::EXCEPTIONS];
                let v = r.varint_max(nv.saturating_sub(1) as u64, "exception vertex")?;
                if nv == 0 {
                    return Err(r.invalid("exception in a level without vertices"));
                }
                indices[c] = v as u32;
                pos[c] = NO_POS;
                exc_left -= 1;
                next_exc = if exc_left > 0 {
                    let gap = r.varint_max(nc as u64, "exception position gap")?;
                    Some(c as u64 + 1 + gap)
                } else {
                    None
                };
                continue;
            }
            let i = name_of[c] as usize;
            let k2 = count[i];
            if k2 == 0 {
                return Err(st[s::CHOICES].invalid(format!("corner {c} names {} which has no vertex", pred[c])));
            }
            let choice = if k2 == 1 { 0 } else { st[s::CHOICES].varint_max(u64::from(k2 - 1), "choice")? as u32 };
            indices[c] = first[i] + choice;
        }
        if let Some(p) = next_exc {
            return Err(st[s::EXCEPTIONS].invalid(format!("exception position {p} is beyond the corners")));
        }
    }
    Ok(())
}

/// The name set of §5.5 (the predicted names and the vertices' names, merged), each with its
/// first vertex in canonical order and its vertex count.
fn name_set(vorder: &[u32], vname: &[u64], predicted: &[u64]) -> Vec<(u64, u32, u32)> {
    let mut names: Vec<(u64, u32, u32)> = Vec::with_capacity(predicted.len() + 16);
    let mut vi = 0usize;
    let mut pi = 0usize;
    loop {
        let vn = vorder.get(vi).map(|&v| vname[v as usize]);
        let pn = predicted.get(pi).copied();
        let nm = match (vn, pn) {
            (None, None) => break,
            (Some(a), Some(b)) => a.min(b),
            (Some(a), None) => a,
            (None, Some(b)) => b,
        };
        let first = vi as u32;
        while vi < vorder.len() && vname[vorder[vi] as usize] == nm {
            vi += 1;
        }
        if pn == Some(nm) {
            pi += 1;
        }
        names.push((nm, first, vi as u32 - first));
    }
    names
}

/// Encodes the name set, splits and corners of a mode 1 or 2 level (§5.5, §5.6): vertex names
/// (lattice keys, or the subdivision name their corners predict, or fresh names after
/// `name_base_free`), the vertex order by name (§5.5), extra names, splits, choices, exceptions
/// and explicit corners. Returns the corners' canonical vertices and `vorder[new] = old`.
#[allow(clippy::needless_range_loop)]
pub fn encode(
    k: u32,
    mode: Mode,
    nv: usize,
    input_corners: Option<&[[u32; 3]]>,
    plan: &mut CornerPlan,
    st: &mut Streams,
) -> (Vec<u32>, Vec<u32>) {
    let CornerPlan { vertex: corner_vertex, pred, pos, name_base_free, .. } = plan;
    // Vertex names (§5.5) and vertex order by name (§5.5).
    let mut vname = vec![u64::MAX; nv];
    let mut first_seen = vec![u64::MAX; nv];
    if let Some(corners) = input_corners.filter(|_| mode == Mode::Lattice) {
        for v in 0..nv {
            vname[v] = lattice::corner_key(corners[v], k);
        }
    }
    for (c, &v) in corner_vertex.iter().enumerate() {
        let v = v as usize;
        if first_seen[v] == u64::MAX {
            first_seen[v] = c as u64;
        }
        if mode == Mode::Generic && vname[v] == u64::MAX && pred[c] != u64::MAX {
            vname[v] = pred[c];
        }
    }
    if mode == Mode::Generic {
        let mut next = *name_base_free;
        for &v in corner_vertex.iter() {
            if vname[v as usize] == u64::MAX {
                vname[v as usize] = next;
                next += 1;
            }
        }
        for n in &mut vname {
            if *n == u64::MAX {
                *n = next;
                next += 1;
            }
        }
    }
    let mut vorder: Vec<u32> = (0..nv as u32).collect();
    vorder.sort_by_key(|&v| (vname[v as usize], first_seen[v as usize], v));
    let mut vnew = vec![0u32; nv];
    for (new, &old) in vorder.iter().enumerate() {
        vnew[old as usize] = new as u32;
    }
    let mut predicted: Vec<u64> = pred.iter().copied().filter(|&x| x != u64::MAX).collect();
    predicted.sort_unstable();
    predicted.dedup();
    let names = name_set(&vorder, &vname, &predicted);
    let extras: Vec<u64> = names.iter().map(|n| n.0).filter(|n| predicted.binary_search(n).is_err()).collect();
    put_varint(&mut st.0[s::EXTRA_NAMES], extras.len() as u64);
    for (i, &n) in extras.iter().enumerate() {
        put_varint(&mut st.0[s::EXTRA_NAMES], if i == 0 { n } else { n - extras[i - 1] - 1 });
    }
    let splits: Vec<(usize, u32)> = names.iter().enumerate().filter(|(_, n)| n.2 != 1).map(|(i, n)| (i, n.2)).collect();
    put_varint(&mut st.0[s::SPLITS], splits.len() as u64);
    for (j, &(i, count)) in splits.iter().enumerate() {
        put_varint(&mut st.0[s::SPLITS], if j == 0 { i as u64 } else { (i - splits[j - 1].0 - 1) as u64 });
        put_varint(&mut st.0[s::SPLITS], u64::from(count));
    }
    // Corners (§5.6).
    let mut indices = Vec::with_capacity(corner_vertex.len());
    let mut exceptions: Vec<(usize, u32)> = Vec::new();
    let mut prev_explicit = 0i64;
    for (c, &v) in corner_vertex.iter().enumerate() {
        let nvx = vnew[v as usize];
        indices.push(nvx);
        if pred[c] == u64::MAX {
            put_varint(&mut st.0[s::CORNERS], zigzag(i64::from(nvx) - prev_explicit));
            prev_explicit = i64::from(nvx);
            continue;
        }
        if vname[v as usize] != pred[c] {
            exceptions.push((c, nvx));
            pos[c] = NO_POS;
            continue;
        }
        let i = names.binary_search_by_key(&pred[c], |n| n.0).expect("name present");
        if names[i].2 > 1 {
            put_varint(&mut st.0[s::CHOICES], u64::from(nvx - names[i].1));
        }
    }
    put_varint(&mut st.0[s::EXCEPTIONS], exceptions.len() as u64);
    for (j, &(c, v)) in exceptions.iter().enumerate() {
        put_varint(&mut st.0[s::EXCEPTIONS], if j == 0 { c as u64 } else { (c - exceptions[j - 1].0 - 1) as u64 });
        put_varint(&mut st.0[s::EXCEPTIONS], u64::from(v));
    }
    (indices, vorder)
}

#[cfg(test)]
mod tests {
    use super::sort_names;
    use crate::topology::NONE;

    /// [`sort_names`] on buffers that hold something already.
    fn sorted(pred: &[u64]) -> (Vec<u64>, Vec<u32>) {
        let (mut names, mut name_of) = (vec![7], vec![1, 2]);
        sort_names(pred, None, &mut names, &mut name_of, &mut vec![5; 3], &mut Vec::new());
        if !pred.is_empty() && !pred.contains(&u64::MAX) {
            // With the bounds given, as lattice levels do.
            let bounds = (*pred.iter().min().unwrap(), *pred.iter().max().unwrap(), pred.len());
            let (mut n2, mut of2) = (Vec::new(), Vec::new());
            sort_names(pred, Some(bounds), &mut n2, &mut of2, &mut Vec::new(), &mut Vec::new());
            assert_eq!((&n2, &of2), (&names, &name_of));
        }
        (names, name_of)
    }

    fn naive(pred: &[u64]) -> (Vec<u64>, Vec<u32>) {
        let mut names: Vec<u64> = pred.iter().copied().filter(|&p| p != u64::MAX).collect();
        names.sort_unstable();
        names.dedup();
        let of = pred.iter().map(|p| names.binary_search(p).map_or(NONE, |i| i as u32)).collect();
        (names, of)
    }

    #[test]
    fn names_by_bitmap_and_by_sort_agree_with_a_plain_sort() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for (n, spread, base) in
            [(0usize, 1u64, 0u64), (1, 1, 5), (500, 300, 0), (500, 1 << 40, 7), (300, u64::MAX - 9, 0)]
        {
            let pred: Vec<u64> =
                (0..n).map(|_| if next() % 5 == 0 { u64::MAX } else { base + next() % spread.max(1) }).collect();
            assert_eq!(sorted(&pred), naive(&pred), "n {n} spread {spread}");
        }
        assert_eq!(sorted(&[u64::MAX - 1, 0, 3, u64::MAX]), naive(&[u64::MAX - 1, 0, 3, u64::MAX]));
    }
}
