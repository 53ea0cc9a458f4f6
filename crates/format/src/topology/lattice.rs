//! Lattice faces (spec §5.3) and mode 2, lattice refinement (§5.7): faces on octree slots, children
//! of parent faces by child masks and depth bits, created faces by slot keys; corners predicted
//! as lattice corner keys. Mode 3 (§5.9) reads the same face streams.

use crate::block::{Mode, s};
use crate::bytes::Reader;
use crate::error::{DecodeError, Where};
use crate::level_decode::PlainLevel;
use crate::topology::names::NameSet;
use crate::topology::slots as lattice;
use crate::topology::{NO_PARENT, Parent, ROTATIONS, rotated};

/// The faces of a lattice level, as the rest of the level needs them.
pub struct LatticeFaces<'a> {
    /// Per face its slot.
    pub slots: Vec<([u32; 3], u8)>,
    /// Per parent face its canonical quad and orientation.
    pub parent_quads: std::borrow::Cow<'a, [crate::topology::Quad]>,
    /// The smallest and largest predicted key and the number of predicted corners.
    pub name_bounds: Option<(u64, u64, usize)>,
}

fn header_error(k: u32, offset: u64, reason: String) -> DecodeError {
    DecodeError::Invalid { place: Where::Payload(k), offset, what: "level block header", reason }
}

/// Decodes the faces of a mode 2 or 3 level of depth `k` below parent `pp` (§5.3): into `out`
/// their offsets, parents and quadrants (and for mode 3 the rotation bytes), per corner its
/// predicted key into `pred` and, for subface corners, its canonical position into `pos`.
pub fn decode_faces<'a>(
    k: u32,
    mode: Mode,
    st: &mut [Reader<'_>],
    pp: &Parent<'a>,
    [nf, nc]: [usize; 2],
    (out, pred, pos): (&mut PlainLevel, &mut [u64], &mut [u8]),
) -> Result<LatticeFaces<'a>, DecodeError> {
    let parent_quads = pp.canonical_quads().map_err(|f| {
        st[s::CHILD_MASKS].invalid(format!("lattice mode needs a lattice parent of quads (parent face {f})"))
    })?;
    let pslots = pp.slots.expect("checked");
    let max_key = 6u64 << (3 * k); // slot keys at depth k are below 6 N^3 (k <= 20)
    // Child masks, one byte per parent face, then one depth bit per subface.
    let masks_at = st[s::CHILD_MASKS].offset();
    let masks = st[s::CHILD_MASKS].bytes(pslots.len())?;
    let mut sub = 0usize;
    for (i, &mask) in masks.iter().enumerate() {
        if mask & 0xf0 != 0 {
            let r = &st[s::CHILD_MASKS];
            return Err(r.invalid_at(masks_at + i as u64, format!("child mask {mask:#x} has bits above 3")));
        }
        sub += mask.count_ones() as usize;
        if sub > nf {
            return Err(st[s::CHILD_MASKS].invalid_at(masks_at + i as u64, "more subfaces than face_count"));
        }
    }
    let depths = st[s::DEPTHS].bytes(sub.div_ceil(8))?;
    if sub % 8 != 0 && depths[sub / 8] >> (sub % 8) != 0 {
        return Err(st[s::DEPTHS].invalid("unused depth bits are not zero"));
    }
    let mut slots: Vec<([u32; 3], u8)> = Vec::with_capacity(nf);
    out.parents.reserve_exact(nf);
    out.quadrants.reserve_exact(nf);
    let mut i = 0usize;
    for (pf, &mask) in masks.iter().enumerate() {
        if mask == 0 {
            continue;
        }
        let (pv, pd) = pslots[pf];
        let prot = parent_quads[pf].1;
        for qd in 0..4u8 {
            if mask >> qd & 1 == 0 {
                continue;
            }
            let inner = depths[i / 8] >> (i % 8) & 1 == 1;
            slots.push(lattice::child_slot_at(pv, pd, rotated(prot, usize::from(qd)), inner));
            out.parents.push(pf as u32);
            out.quadrants.push(qd);
            i += 1;
        }
    }
    let mut key = 0u64;
    for i in sub..nf {
        let gap = st[s::CREATED_KEYS].varint_max(max_key, "slot key gap")?;
        key = if i == sub { gap } else { key + 1 + gap };
        let slot = lattice::slot_from_morton_key(key, k)
            .ok_or_else(|| st[s::CREATED_KEYS].invalid(format!("slot key {key} outside level {k}")))?;
        slots.push(slot);
        out.parents.push(NO_PARENT);
        out.quadrants.push(0);
    }
    if nc != 4 * nf {
        return Err(header_error(k, 12, format!("lattice levels are quads: corner_count must be {}", 4 * nf)));
    }
    let rots_at = st[s::ROTATIONS].offset();
    let rots = st[s::ROTATIONS].bytes(nf)?;
    if let Some(f) = rots.iter().position(|&r| r & !7 != 0) {
        let r = &st[s::ROTATIONS];
        return Err(r.invalid_at(rots_at + f as u64, format!("rotation byte {:#x} has reserved bits set", rots[f])));
    }
    out.offsets.extend((1..=nf as u32).map(|f| 4 * f));
    if mode == Mode::FastLattice {
        out.rotation_hints = rots.to_vec();
    }
    let (mut lo, mut hi) = (u64::MAX, 0);
    for (f, (slot, &r)) in slots.iter().zip(rots).enumerate() {
        let keys = lattice::slot_corner_keys(slot.0, slot.1, k);
        // A slot's smallest and largest corner keys are its canonical corners 0 and 2.
        lo = lo.min(keys[0]);
        hi = hi.max(keys[2]);
        let cps = ROTATIONS[usize::from(r)];
        let c = 4 * f;
        for i in 0..4 {
            pred[c + i] = keys[usize::from(cps[i] & 3)];
        }
        if f < sub {
            pos[c..c + 4].copy_from_slice(&cps);
        }
    }
    let name_bounds = (nf > 0).then_some((lo, hi, nc));
    Ok(LatticeFaces { slots, parent_quads, name_bounds })
}

/// The lattice corner of every vertex of a mode 2 level: its name read back as a corner key (§5.7
/// step 4), vertices in name order, a split name's vertices together (§5.5).
pub fn vertex_corners(k: u32, nv: usize, set: &NameSet<'_>) -> Vec<[u32; 3]> {
    let NameSet { names, count, nsplit, .. } = set;
    let keys = lattice::CornerKeys::new(k);
    // Valid keys: predicted from slots, or extras checked above.
    if *nsplit == 0 {
        return names.iter().map(|&nm| keys.corner(nm)).collect();
    }
    let mut vc = Vec::with_capacity(nv);
    for (i, &nm) in names.iter().enumerate() {
        let c = keys.corner(nm);
        for _ in 0..count[i] {
            vc.push(c);
        }
    }
    vc
}
