//! The level decoder: spec §4-§6 read in order. Works on plain arrays; every count is checked
//! against the level-table entry (itself checked against [`crate::Limits`]) before allocating.

use crate::block::{BlockHeader, GridInfo, LINE_PARAM_LIMIT, Mode, s};
use crate::bytes::{Reader, unzigzag};
use crate::container::LevelEntry;
use crate::error::{DecodeError, Where};
use crate::geometry::fixed as fast;
use crate::geometry::predict::{GRID_LIMIT, GeometryScratch, Topo, geometry_pass};
use crate::geometry::residuals::{GridStreams, exact_positions, grid_streams};
use crate::topology::first_use;
use crate::topology::names::sort_names;
use crate::topology::slots as lattice;
use crate::topology::{NO_PARENT, NO_POS, NONE, Parent, ROTATIONS, number_edges, rotated};

/// One decoded level on plain arrays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlainLevel {
    /// Face offsets (CSR, `face_count + 1` entries).
    pub offsets: Vec<u32>,
    /// Face corners.
    pub indices: Vec<u32>,
    /// Per face: parent face in the level above, or `u32::MAX` for a created face.
    pub parents: Vec<u32>,
    /// Per face: the parent quadrant (0 for created faces).
    pub quadrants: Vec<u8>,
    /// Per face: lattice slot, when the level carries lattice coordinates.
    pub slots: Option<Vec<([u32; 3], u8)>>,
    /// Per vertex: lattice corner, when the level carries lattice coordinates.
    pub corners: Option<Vec<[u32; 3]>>,
    /// Grid coordinates of the vertices (quantized files).
    pub q: Vec<[i64; 3]>,
    /// Positions of the vertices (exact files).
    pub exact: Vec<[f64; 3]>,
    /// Mode 3 levels: per face its rotation byte when none of its corners is an exception (then
    /// it is the face's orientation as a parent, spec §5.3), else `u8::MAX`; empty otherwise.
    pub rotation_hints: Vec<u8>,
}

impl PlainLevel {
    /// The level as a parent of the next.
    pub fn as_parent(&self) -> Parent<'_> {
        Parent {
            offsets: &self.offsets,
            indices: &self.indices,
            q: &self.q,
            slots: self.slots.as_deref(),
            corners: self.corners.as_deref(),
            rotation_hints: &self.rotation_hints,
        }
    }
}

/// Buffers reused from level to level (and file to file) by [`decode_level`].
#[derive(Default)]
pub struct Scratch {
    /// The geometry pass's buffers.
    geometry: GeometryScratch,
    /// Per corner: its predicted name, or `u64::MAX`.
    pred: Vec<u64>,
    /// Per corner: its canonical position, or [`NO_POS`].
    pos: Vec<u8>,
    /// [`sort_names`]' bitmap and ranks.
    bits: Vec<u64>,
    rank: Vec<u32>,
    /// The level's names, sorted.
    names: Vec<u64>,
    /// Per corner: the index of its name, or [`NONE`].
    name_of: Vec<u32>,
    /// Mode 3's key table.
    fast_resolve: first_use::ResolveScratch,
    /// Mode 3's geometry buffers.
    fast_geometry: FastGeometryScratch,
}

/// Buffers of [`finish_fast`].
#[derive(Default)]
pub struct FastGeometryScratch {
    pub(crate) contexts: fast::Contexts,
    dirs: Vec<fast::FaceLine>,
    /// Line parameters and x, y, z residuals, zigzagged.
    values: [Vec<u32>; 4],
}

impl Scratch {
    /// Bytes held by the buffers.
    pub fn capacity_bytes(&self) -> usize {
        self.geometry.capacity_bytes()
            + self.pred.capacity() * 8
            + self.pos.capacity()
            + self.bits.capacity() * 8
            + self.rank.capacity() * 4
            + self.names.capacity() * 8
            + self.name_of.capacity() * 4
            + self.fast_resolve.capacity_bytes()
            + self.fast_geometry.contexts.capacity_bytes()
            + self.fast_geometry.dirs.capacity() * size_of::<fast::FaceLine>()
            + self.fast_geometry.values.iter().map(|v| v.capacity() * 4).sum::<usize>()
    }
}

/// Decodes level `k`'s decompressed payload.
#[allow(clippy::too_many_lines)] // one pass through spec §4-§5, in the spec's order
pub fn decode_level(
    k: u32,
    payload: &[u8],
    entry: &LevelEntry,
    parent: Option<&PlainLevel>,
    grid: GridInfo,
    scratch: &mut Scratch,
) -> Result<PlainLevel, DecodeError> {
    let place = Where::Payload(k);
    let header = BlockHeader::parse(k, payload, entry, grid)?;
    let mut st = header.streams(k, payload)?;
    let BlockHeader { mode, has_lattice, predictor, lines, line_shift, counts: [nv, nf, nc], .. } = header;
    let bad = |offset: u64, reason: String| DecodeError::Invalid { place, offset, what: "level block header", reason };

    let mut out = PlainLevel { offsets: Vec::with_capacity(nf + 1), ..PlainLevel::default() };
    out.offsets.push(0);
    out.indices = vec![0u32; nc];
    let mut parent_quads = Vec::new();
    if mode == Mode::Base {
        out.parents = vec![NO_PARENT; nf];
        out.quadrants = vec![0; nf];
        let mut sum = 0u64;
        for _ in 0..nf {
            let n = st[s::FACE_SIZES].varint_max(u64::from(u32::MAX) - 3, "face size")? + 3;
            sum += n;
            if sum > nc as u64 {
                return Err(st[s::FACE_SIZES].invalid("face sizes add up to more than corner_count"));
            }
            out.offsets.push(sum as u32);
        }
        if sum != nc as u64 {
            return Err(st[s::FACE_SIZES].invalid(format!("face sizes add up to {sum}, corner_count is {nc}")));
        }
        let mut prev = 0i64;
        for c in 0..nc {
            prev = prev.wrapping_add(unzigzag(st[s::CORNERS].varint()?));
            if prev < 0 || prev >= nv as i64 {
                return Err(st[s::CORNERS].invalid(format!("vertex index {prev} out of range 0..{nv}")));
            }
            out.indices[c] = prev as u32;
        }
    } else {
        let p = parent.expect("levels above 0 have a parent");
        let pp = p.as_parent();
        // §5.3 / §5.4: subfaces, then created faces; predicted names per corner.
        let Scratch { geometry, pred, pos, bits, rank, names, name_of, fast_resolve, fast_geometry } = scratch;
        pred.clear();
        pred.resize(nc, u64::MAX);
        pos.clear();
        pos.resize(nc, NO_POS);
        let rot_of = |st: &mut [Reader<'_>]| -> Result<u8, DecodeError> {
            let r = st[s::ROTATIONS].u8()?;
            if r & !7 != 0 {
                return Err(st[s::ROTATIONS].invalid(format!("rotation byte {r:#x} has reserved bits set")));
            }
            Ok(r)
        };
        let mut corner = 0usize;
        // The range and count of the predicted names, when every corner has one (lattice levels).
        let mut name_bounds = None;
        let mut slots: Vec<([u32; 3], u8)> = Vec::new();
        if mode.is_lattice() {
            parent_quads = pp.canonical_quads().map_err(|f| {
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
            slots.reserve_exact(nf);
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
                return Err(bad(12, format!("lattice levels are quads: corner_count must be {}", 4 * nf)));
            }
            let rots_at = st[s::ROTATIONS].offset();
            let rots = st[s::ROTATIONS].bytes(nf)?;
            if let Some(f) = rots.iter().position(|&r| r & !7 != 0) {
                let r = &st[s::ROTATIONS];
                return Err(
                    r.invalid_at(rots_at + f as u64, format!("rotation byte {:#x} has reserved bits set", rots[f]))
                );
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
            name_bounds = (nf > 0).then_some((lo, hi, nc));
        } else {
            let (edge_of_corner, ne) = number_edges(pp.offsets, pp.indices);
            let pv = p.q.len().max(p.exact.len()) as u64;
            let (pv, ne, pnf) = (pv, u64::from(ne), pp.face_count() as u64);
            for pf in 0..pp.face_count() {
                let face = pp.face(pf);
                let n = face.len();
                let mask = st[s::CHILD_MASKS].bytes(n.div_ceil(8))?;
                if n % 8 != 0 && mask[n / 8] >> (n % 8) != 0 {
                    return Err(st[s::CHILD_MASKS].invalid("child mask has bits beyond the face's corners"));
                }
                for qd in 0..n {
                    let m = mask[qd / 8];
                    if m >> (qd % 8) & 1 == 0 {
                        continue;
                    }
                    if out.parents.len() == nf || corner + 4 > nc {
                        return Err(st[s::CHILD_MASKS].invalid("more subfaces than face_count or corner_count allow"));
                    }
                    let qd8 = u8::try_from(qd)
                        .map_err(|_| st[s::CHILD_MASKS].invalid("quadrants above 255 cannot be stored"))?;
                    let r = rot_of(&mut st)?;
                    let base = pp.offsets[pf] as usize;
                    let layout = [
                        u64::from(face[qd]),
                        pv + u64::from(edge_of_corner[base + qd]),
                        pv + ne + pf as u64,
                        pv + u64::from(edge_of_corner[base + (qd + n - 1) % n]),
                    ];
                    for i in 0..4 {
                        let cp = rotated(r, i);
                        pred[corner] = layout[cp];
                        pos[corner] = cp as u8;
                        corner += 1;
                    }
                    out.offsets.push(corner as u32);
                    out.parents.push(pf as u32);
                    out.quadrants.push(qd8);
                }
            }
            let _ = pnf;
            for _ in out.parents.len()..nf {
                let n = st[s::FACE_SIZES].varint_max(u64::from(u32::MAX) - 3, "face size")? + 3;
                if (corner as u64) + n > nc as u64 {
                    return Err(st[s::FACE_SIZES].invalid("face sizes add up to more than corner_count"));
                }
                corner += n as usize;
                out.offsets.push(corner as u32);
                out.parents.push(NO_PARENT);
                out.quadrants.push(0);
            }
            if corner != nc {
                return Err(st[s::FACE_SIZES].invalid(format!("faces hold {corner} corners, corner_count is {nc}")));
            }
        }
        if mode == Mode::FastLattice {
            // §5.9: first-use numbering through a table of keys.
            let [_, _, _, _, _, _, extras, splits, exceptions, choices, _, _] = &mut st[..] else {
                unreachable!("twelve streams")
            };
            let streams = first_use::ResolveStreams { splits, exceptions, choices, extras };
            let faces = (&out.parents[..], &out.quadrants[..], &parent_quads[..]);
            let corners = first_use::resolve(
                k,
                nv,
                pred,
                pos,
                &mut out.indices,
                streams,
                fast_resolve,
                faces,
                &mut fast_geometry.contexts,
                &mut out.rotation_hints,
            )?;
            out.corners = Some(corners);
            out.slots = Some(slots);
            out.parents.shrink_to_fit();
            let variant = (predictor, lines, line_shift);
            return finish_fast(k, variant, grid, &mut st, out, p, &parent_quads, fast_geometry);
        }
        // §5.5: the name set and splits.
        // Predicted names, sorted once (radix); `name_of[c]` = the index of corner c's name.
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
                    place,
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
        // §5.6: corners to vertices.
        let nexc = st[s::EXCEPTIONS].varint_max(nc as u64, "exception count")? as usize;
        let explicit = name_bounds.is_none() && pred.contains(&u64::MAX);
        if nsplit == 0 && !explicit {
            // One vertex per name, numbered as the names: corner c's vertex is its name's index,
            // then the exceptions.
            out.indices.copy_from_slice(name_of);
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
                out.indices[c as usize] = v as u32;
                pos[c as usize] = NO_POS;
                at = c;
            }
        } else {
            let mut first = Vec::with_capacity(names.len() + 1);
            let mut acc = 0u32;
            for &c in &count {
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
                        return Err(
                            st[s::CORNERS].invalid(format!("vertex index {prev_explicit} out of range 0..{nv}"))
                        );
                    }
                    out.indices[c] = prev_explicit as u32;
                    if next_exc == Some(c as u64) {
                        return Err(
                            st[s::EXCEPTIONS].invalid(format!("exception at corner {c}, which has no prediction"))
                        );
                    }
                    continue;
                }
                if next_exc == Some(c as u64) {
                    let r = &mut st[s::EXCEPTIONS];
                    let v = r.varint_max(nv.saturating_sub(1) as u64, "exception vertex")?;
                    if nv == 0 {
                        return Err(r.invalid("exception in a level without vertices"));
                    }
                    out.indices[c] = v as u32;
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
                out.indices[c] = first[i] + choice;
            }
            if let Some(p) = next_exc {
                return Err(st[s::EXCEPTIONS].invalid(format!("exception position {p} is beyond the corners")));
            }
        }
        if mode == Mode::Lattice {
            let keys = lattice::CornerKeys::new(k);
            // Valid keys: predicted from slots, or extras checked above.
            let vc = if nsplit == 0 {
                names.iter().map(|&nm| keys.corner(nm)).collect()
            } else {
                let mut vc = Vec::with_capacity(nv);
                for (i, &nm) in names.iter().enumerate() {
                    let c = keys.corner(nm);
                    for _ in 0..count[i] {
                        vc.push(c);
                    }
                }
                vc
            };
            out.corners = Some(vc);
            out.slots = Some(slots);
        }
        out.parents.shrink_to_fit();
        return finish(
            k,
            (mode, predictor, lines, line_shift),
            has_lattice,
            grid,
            &mut st,
            out,
            Some(p),
            pos,
            &parent_quads,
            nv,
            geometry,
        );
    }
    let pos = &mut scratch.pos;
    pos.clear();
    pos.resize(nc, NO_POS);
    finish(
        k,
        (mode, predictor, lines, line_shift),
        has_lattice,
        grid,
        &mut st,
        out,
        None,
        pos,
        &parent_quads,
        nv,
        &mut scratch.geometry,
    )
}

#[allow(clippy::too_many_arguments, clippy::too_many_lines)] // spec §5.8 and §6 in order
fn finish(
    k: u32,
    (mode, predictor, lines, line_shift): (Mode, u8, bool, u32),
    has_lattice: bool,
    grid: GridInfo,
    st: &mut [Reader<'_>],
    mut out: PlainLevel,
    parent: Option<&PlainLevel>,
    pos: &[u8],
    parent_quads: &[([u32; 4], u8)],
    nv: usize,
    geometry: &mut GeometryScratch,
) -> Result<PlainLevel, DecodeError> {
    let nf = out.parents.len();
    if mode != Mode::Lattice && has_lattice {
        let r = &mut st[s::RAW_LATTICE];
        let mut slots = Vec::with_capacity(nf);
        let mut key = 0i64;
        for _ in 0..nf {
            key = key.wrapping_add(unzigzag(r.varint()?));
            let slot = u64::try_from(key)
                .ok()
                .and_then(|x| lattice::slot_from_key(x, k))
                .ok_or_else(|| r.invalid(format!("slot key {key} outside level {k}")))?;
            slots.push(slot);
        }
        let mut corners = Vec::with_capacity(nv);
        key = 0;
        for _ in 0..nv {
            key = key.wrapping_add(unzigzag(r.varint()?));
            let c = u64::try_from(key)
                .ok()
                .and_then(|x| lattice::corner_from_key(x, k))
                .ok_or_else(|| r.invalid(format!("corner key {key} outside level {k}")))?;
            corners.push(c);
        }
        out.slots = Some(slots);
        out.corners = Some(corners);
    }
    let g = &mut st[s::GEOMETRY];
    if grid.exact {
        out.exact = exact_positions(g, nv)?;
    } else {
        // §6.1 / §6.6: with lines, a bitmap of line vertices, their parameters, and the other
        // vertices' residuals, each list in coding order (pass A, then pass B).
        let GridStreams { flags, params, planes } = grid_streams(g, nv, lines)?;
        let mut q = vec![[0i64; 3]; nv];
        let pp = parent.map(PlainLevel::as_parent);
        let topo = Topo {
            mode,
            level: k,
            bits: grid.bits,
            offsets: &out.offsets,
            indices: &out.indices,
            parents: &out.parents,
            quadrants: &out.quadrants,
            corner_pos: pos,
            vertex_corners: out.corners.as_deref(),
            parent_quads: (mode == Mode::Lattice).then_some(parent_quads),
            predictor,
            lines,
            line_shift,
        };
        let geo_off = g.offset();
        let invalid = |reason: String| DecodeError::Invalid {
            place: Where::Payload(k),
            offset: geo_off,
            what: "geometry",
            reason,
        };
        let (mut next_line, mut next_other) = (0usize, 0usize);
        geometry_pass(
            &topo,
            pp.as_ref(),
            &mut q,
            geometry,
            #[inline(always)]
            |v, pr| {
                if lines && flags[v / 8] >> (v % 8) & 1 == 1 {
                    let Some(line) = pr.line else {
                        return Err(invalid(format!("vertex {v} is flagged as a line vertex but has no line")));
                    };
                    let j = pr.param + unzigzag(params.as_ref().expect("lines").get(next_line));
                    next_line += 1;
                    if j.abs() > LINE_PARAM_LIMIT {
                        return Err(invalid(format!("vertex {v} has line parameter {j}, beyond 2^30")));
                    }
                    let out = line.point(j);
                    if out.iter().any(|x| x.abs() > GRID_LIMIT) {
                        return Err(invalid(format!("vertex {v} decodes outside the grid range (|q| > 2^28)")));
                    }
                    return Ok((out, Some(j)));
                }
                let i = if lines { next_other } else { v };
                next_other += 1;
                let mut out = [0i64; 3];
                let point = pr.point();
                for a in 0..3 {
                    out[a] = point[a] + unzigzag(planes[a].get(i));
                    if out[a].abs() > GRID_LIMIT {
                        return Err(invalid(format!("vertex {v} decodes outside the grid range (|q| > 2^28)")));
                    }
                }
                Ok((out, None))
            },
        )?;
        out.q = q;
    }
    for r in st.iter() {
        r.finish()?;
    }
    Ok(out)
}

/// Geometry of a mode 3 level (spec §6.8) and the end-of-block checks.
#[allow(clippy::too_many_arguments)]
fn finish_fast(
    k: u32,
    (predictor, lines, line_shift): (u8, bool, u32),
    grid: GridInfo,
    st: &mut [Reader<'_>],
    mut out: PlainLevel,
    parent: &PlainLevel,
    parent_quads: &[([u32; 4], u8)],
    scratch: &mut FastGeometryScratch,
) -> Result<PlainLevel, DecodeError> {
    let nv = out.corners.as_ref().map_or(0, Vec::len);
    let g = &mut st[s::GEOMETRY];
    if grid.exact {
        out.exact = exact_positions(g, nv)?;
    } else {
        let GridStreams { flags, params, planes } = grid_streams(g, nv, lines)?;
        let FastGeometryScratch { contexts, dirs, values } = scratch;
        // (`contexts` were found by `fast::resolve`.)
        // The stream's values, assembled from their byte planes once (in bulk, not per vertex).
        let [jv, rx, ry, rz] = values;
        match &params {
            Some(p) => p.decode_into(jv),
            None => jv.clear(),
        }
        planes[0].decode_into(rx);
        planes[1].decode_into(ry);
        planes[2].decode_into(rz);
        let topo = fast::FastTopo {
            level: k,
            bits: grid.bits,
            indices: &out.indices,
            slots: out.slots.as_deref().unwrap_or_default(),
            vertex_corners: out.corners.as_deref().unwrap_or_default(),
            contexts,
            parent_quads,
            lines,
            line_shift,
            predictor,
        };
        let mut q = vec![[0i64; 3]; nv];
        let decoded = fast::decode_pass(&topo, &parent.q, &mut q, dirs, flags, jv, [rx, ry, rz]);
        if let Err(v) = decoded {
            return Err(g.invalid(format!(
                "vertex {v} decodes outside the grid range (|q| > 2^28) or has a line parameter beyond 2^30"
            )));
        }
        out.q = q;
    }
    for r in st.iter() {
        r.finish()?;
    }
    Ok(out)
}
