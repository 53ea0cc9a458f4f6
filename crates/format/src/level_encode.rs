//! The level encoder, the inverse of `level_decode`: it picks the mode (§4.1), puts the level in
//! the order of its decoded level (spec §5.4, §5.7, §5.9: the order the decoder produces),
//! predicts every corner, and writes the streams: each mode's names and corners in `crate::topology`, the geometry in
//! `crate::geometry::residuals`. Deterministic: no hash-map iteration reaches the output.

use crate::block::{BLOCK_FLAG_LATTICE, Mode, STREAM_COUNT, s};
use crate::bytes::put_varint;
use crate::error::EncodeError;
use crate::geometry::residuals::choose_geometry;
use crate::level_decode::PlainLevel;
use crate::topology::slots;
use crate::topology::slots::{self as lattice, MAX_LATTICE_DEPTH};
use crate::topology::{NO_PARENT, NO_POS, Parent, base, best_rotation, first_use, names, number_edges, rotated};

/// One input level on plain arrays, parents already numbered in the parent's canonical order.
pub struct InputLevel<'a> {
    /// Face offsets.
    pub offsets: &'a [u32],
    /// Face corners.
    pub indices: &'a [u32],
    /// Per face: canonical parent face, or `NO_PARENT`.
    pub parents: Vec<u32>,
    /// Per face: quadrant.
    pub quadrants: Vec<u8>,
    /// Lattice slots.
    pub slots: Option<&'a [([u32; 3], u8)]>,
    /// Lattice corners.
    pub corners: Option<&'a [[u32; 3]]>,
    /// Grid coordinates (quantized files) in input vertex order.
    pub q: Vec<[i64; 3]>,
    /// Exact positions (exact files) in input vertex order.
    pub exact: Vec<[f64; 3]>,
    /// Only order and topology are wanted (line placement): the geometry stream stays empty.
    pub topology_only: bool,
}

/// The encoded level: payload, what the decoder will rebuild, and the face permutation
/// (`face_new[old]`).
pub struct Encoded {
    /// The decompressed level block.
    pub payload: Vec<u8>,
    /// The canonical level.
    pub level: PlainLevel,
    /// New index of every input face.
    pub face_new: Vec<u32>,
    /// Input index of every canonical vertex (`vertex_old[new]`).
    pub vertex_old: Vec<u32>,
    /// Bytes of topology streams and of the geometry stream (before zstd).
    pub split_bytes: (usize, usize),
    /// Coding mode.
    pub mode: Mode,
    /// The block's `predictor` byte (lattice predictor, line bit).
    pub predictor: u8,
    /// The block's `line_shift` (spec §6.6).
    pub line_shift: u32,
    /// Per corner: canonical position for geometry contexts (`NO_POS` for none).
    pub pos: Vec<u8>,
    /// Lattice mode: the parent's canonical quads.
    pub parent_quads: Vec<([u32; 4], u8)>,
}

/// The twelve streams of a level block being written (spec §4.2).
pub struct Streams(pub [Vec<u8>; STREAM_COUNT]);

impl Streams {
    /// Twelve empty streams.
    pub fn new() -> Self {
        Self(std::array::from_fn(|_| Vec::new()))
    }
}

fn face(offsets: &[u32], indices: &[u32], f: usize) -> std::ops::Range<usize> {
    let _ = indices;
    offsets[f] as usize..offsets[f + 1] as usize
}

/// Encodes level `k` (`parent` is the canonical level `k - 1`, `None` for level 0): the mode
/// (§4.1), the decoded level's face order (§5.3, §5.4), every corner's prediction, the names,
/// splits and corners of the mode (§5.5, §5.6, §5.9), the face streams (§5.3, §5.4), then the
/// geometry (§6).
pub fn encode_level(
    k: u32,
    input: &InputLevel<'_>,
    parent: Option<&PlainLevel>,
    exact: bool,
    tied: bool,
    bits: u32,
    version: u16,
) -> Result<Encoded, EncodeError> {
    let nv = input.q.len().max(input.exact.len());
    let has_lattice = has_valid_lattice(k, input)?;
    let Some(parent) = parent else {
        return Ok(base::encode(k, input, has_lattice, (bits, exact)));
    };
    let mut st = Streams::new();
    let pp = parent.as_parent();
    let lattice_plan =
        if has_lattice && (exact || tied) && parent.slots.is_some() { plan_lattice(input, &pp) } else { None };
    let mode = match lattice_plan {
        Some(_) if version >= 3 => Mode::FastLattice,
        Some(_) => Mode::Lattice,
        None => Mode::Generic,
    };
    let (order, face_new) = face_order(k, input, lattice_plan.as_ref())?;
    let mut plan = corner_predictions(k, input, parent, &order, lattice_plan.as_ref());
    let (indices, vorder) = if mode == Mode::FastLattice {
        let corners = input.corners.expect("lattice");
        first_use::encode(k, corners, (&plan.vertex, &plan.pred), &mut plan.pos, nv, &mut st)
    } else {
        names::encode(k, mode, nv, input.corners, &mut plan, &mut st)
    };
    let nsub = order.iter().filter(|&&f| input.parents[f as usize] != NO_PARENT).count();
    let faces = FaceOrder { order: &order, nsub, vorder: &vorder, lattice_plan: lattice_plan.as_ref() };
    let level = PlainLevel { offsets: std::mem::take(&mut plan.offsets), indices, ..PlainLevel::default() };
    let mut level =
        face_streams(k, mode, input, &pp, &faces, has_lattice, level, std::mem::take(&mut plan.rotations), &mut st);
    level.q = if input.q.is_empty() { Vec::new() } else { vorder.iter().map(|&v| input.q[v as usize]).collect() };
    level.exact =
        if input.exact.is_empty() { Vec::new() } else { vorder.iter().map(|&v| input.exact[v as usize]).collect() };
    let (predictor, line_shift, quads) =
        choose_geometry(k, (mode, version), (bits, exact), &level, parent, &plan.pos, input.topology_only, &mut st);
    let mut e = finish(st, (mode, predictor, line_shift), has_lattice, level, face_new, vorder);
    e.pos = plan.pos;
    e.parent_quads = quads;
    Ok(e)
}

/// Whether level `k` carries lattice coordinates the format can hold (depth at most 20); fails
/// when they lie outside `[0, 2^k]`.
fn has_valid_lattice(k: u32, input: &InputLevel<'_>) -> Result<bool, EncodeError> {
    let has_lattice = input.slots.is_some() && input.corners.is_some() && k <= MAX_LATTICE_DEPTH;
    if has_lattice {
        let (slots, corners) = (input.slots.expect("has"), input.corners.expect("has"));
        if slots.iter().any(|&(v, d)| !lattice::slot_in_range(v, d, k))
            || corners.iter().any(|&c| !lattice::corner_in_range(c, k))
        {
            return Err(EncodeError::Unsupported {
                level: k as usize,
                reason: format!("lattice coordinates outside [0, 2^{k}]"),
            });
        }
    }
    Ok(has_lattice)
}

/// The decoded level's face order (§5.4 step 3, §5.3 Streams): subfaces by (parent, quadrant),
/// then created faces (by Morton slot key in lattice levels); as `order[new] = old` and
/// `face_new[old] = new`. Subfaces must be quads.
fn face_order(
    k: u32,
    input: &InputLevel<'_>,
    lattice_plan: Option<&LatticePlan>,
) -> Result<(Vec<u32>, Vec<u32>), EncodeError> {
    let nf = input.parents.len();
    // Face order (§5.3, §5.4): subfaces by (parent, quadrant), then created faces.
    let mut order: Vec<u32> = (0..nf as u32).collect();
    let created_key = |f: usize| -> u64 {
        match lattice_plan {
            Some(pl) => pl.keys[f],
            None => f as u64,
        }
    };
    order.sort_by_key(|&f| {
        let f = f as usize;
        if input.parents[f] == NO_PARENT {
            (1u8, u64::MAX, created_key(f))
        } else {
            (0, u64::from(input.parents[f]) << 8 | u64::from(input.quadrants[f]), 0)
        }
    });
    let mut face_new = vec![0u32; nf];
    for (new, &old) in order.iter().enumerate() {
        face_new[old as usize] = new as u32;
    }
    for &f in &order {
        let f = f as usize;
        if input.parents[f] != NO_PARENT && input.offsets[f + 1] - input.offsets[f] != 4 {
            return Err(EncodeError::Unsupported {
                level: k as usize,
                reason: format!(
                    "face {f} descends from a parent but has {} corners; subfaces are quads",
                    input.offsets[f + 1] - input.offsets[f]
                ),
            });
        }
    }

    Ok((order, face_new))
}

/// Per corner of the level in canonical face order: its input vertex, predicted name (lattice
/// key, or subdivision name; `u64::MAX` for explicit corners), canonical position, and per face
/// its rotation byte (§5.2-§5.4).
pub struct CornerPlan {
    /// Per corner: its input vertex.
    pub vertex: Vec<u32>,
    /// Per corner: its predicted name, or `u64::MAX`.
    pub pred: Vec<u64>,
    /// Per corner: its canonical position, or `NO_POS`.
    pub pos: Vec<u8>,
    /// Face offsets in canonical order.
    pub offsets: Vec<u32>,
    /// Per subface (and lattice face): its rotation byte.
    pub rotations: Vec<u8>,
    /// The first name after the canonical subdivision's (mode 1's names for unpredicted vertices).
    pub name_base_free: u64,
}

#[allow(clippy::needless_range_loop)] // corners by index: vertex, prediction and position together
fn corner_predictions(
    k: u32,
    input: &InputLevel<'_>,
    parent: &PlainLevel,
    order: &[u32],
    lattice_plan: Option<&LatticePlan>,
) -> CornerPlan {
    let nf = input.parents.len();
    let pp = parent.as_parent();
    // Per (new-order) corner: input vertex, predicted name, canonical position.
    let mut corner_vertex = Vec::with_capacity(input.indices.len());
    let mut pred = Vec::with_capacity(input.indices.len());
    let mut pos = Vec::with_capacity(input.indices.len());
    let mut offsets = Vec::with_capacity(nf + 1);
    offsets.push(0u32);
    let mut rotations = Vec::new();
    let (edge_of_corner, ne) = number_edges(pp.offsets, pp.indices);
    let pv = parent.q.len().max(parent.exact.len()) as u64;
    let name_base_free = pv + u64::from(ne) + pp.face_count() as u64;
    for &f in order {
        let f = f as usize;
        let r = face(input.offsets, input.indices, f);
        let verts = &input.indices[r];
        let is_sub = input.parents[f] != NO_PARENT;
        if let Some(pl) = lattice_plan {
            let (v, d) = pl.slots[f];
            let sc = lattice::slot_corners(v, d);
            let corners = input.corners.expect("lattice");
            let rot = best_rotation(|rot, i| corners[verts[i] as usize] == sc[rotated(rot, i)]);
            rotations.push(rot);
            for i in 0..4 {
                let cp = rotated(rot, i);
                pred.push(lattice::corner_key(sc[cp], k));
                pos.push(if is_sub { cp as u8 } else { NO_POS });
                corner_vertex.push(verts[i]);
            }
        } else if is_sub {
            let pf = input.parents[f] as usize;
            let qd = usize::from(input.quadrants[f]);
            let pface = pp.face(pf);
            let n = pface.len();
            let base = pp.offsets[pf] as usize;
            let layout = [
                u64::from(pface[qd]),
                pv + u64::from(edge_of_corner[base + qd]),
                pv + u64::from(ne) + pf as u64,
                pv + u64::from(edge_of_corner[base + (qd + n - 1) % n]),
            ];
            let rot = generic_rotation(input, parent, pface, qd, verts);
            rotations.push(rot);
            for i in 0..4 {
                let cp = rotated(rot, i);
                pred.push(layout[cp]);
                pos.push(cp as u8);
                corner_vertex.push(verts[i]);
            }
        } else {
            for &v in verts {
                pred.push(u64::MAX);
                pos.push(NO_POS);
                corner_vertex.push(v);
            }
        }
        offsets.push(corner_vertex.len() as u32);
    }

    CornerPlan { vertex: corner_vertex, pred, pos, offsets, rotations, name_base_free }
}

/// The canonical orders of a refinement level's faces and vertices.
struct FaceOrder<'a> {
    /// `order[new] = old` for faces.
    order: &'a [u32],
    /// Number of subfaces (they come first).
    nsub: usize,
    /// `vorder[new] = old` for vertices.
    vorder: &'a [u32],
    /// The lattice plan of a mode 2 or 3 level.
    lattice_plan: Option<&'a LatticePlan>,
}

/// The face streams (§5.3, §5.4): child masks, then for lattice levels depth bits and created-face
/// keys, for generic levels the created faces' sizes; rotations; the level's per-face arrays and
/// lattice coordinates in canonical order (raw lattice for a generic level that has them).
#[allow(clippy::too_many_arguments)]
fn face_streams(
    k: u32,
    mode: Mode,
    input: &InputLevel<'_>,
    pp: &Parent<'_>,
    faces: &FaceOrder<'_>,
    has_lattice: bool,
    mut level: PlainLevel,
    rotations: Vec<u8>,
    st: &mut Streams,
) -> PlainLevel {
    let FaceOrder { order, nsub, vorder, lattice_plan } = *faces;
    // Face structure streams (§5.3, §5.4).
    level.parents = order.iter().map(|&f| input.parents[f as usize]).collect();
    level.quadrants = order.iter().map(|&f| input.quadrants[f as usize]).collect();
    let mut sub_iter = level.parents.iter().zip(&level.quadrants).peekable();
    for pf in 0..pp.face_count() {
        let n = pp.face(pf).len();
        let mut mask = vec![0u8; n.div_ceil(8)];
        while let Some(&(&p, &q)) = sub_iter.peek() {
            if p as usize != pf {
                break;
            }
            mask[usize::from(q) / 8] |= 1 << (q % 8);
            sub_iter.next();
        }
        if mode.is_lattice() && n != 4 {
            unreachable!("lattice parents are quads");
        }
        st.0[s::CHILD_MASKS].extend(mask);
    }
    if let Some(pl) = lattice_plan {
        let mut byte = 0u8;
        for (i, &f) in order.iter().take(nsub).enumerate() {
            byte |= u8::from(pl.inner[f as usize]) << (i % 8);
            if i % 8 == 7 {
                st.0[s::DEPTHS].push(byte);
                byte = 0;
            }
        }
        if nsub % 8 != 0 {
            st.0[s::DEPTHS].push(byte);
        }
        let mut prev = 0u64;
        for (i, &f) in order.iter().skip(nsub).enumerate() {
            let key = pl.keys[f as usize];
            put_varint(&mut st.0[s::CREATED_KEYS], if i == 0 { key } else { key - prev - 1 });
            prev = key;
        }
        st.0[s::ROTATIONS] = rotations;
        level.slots = Some(order.iter().map(|&f| pl.slots[f as usize]).collect());
        let corners = input.corners.expect("lattice");
        level.corners = Some(vorder.iter().map(|&v| corners[v as usize]).collect());
    } else {
        st.0[s::ROTATIONS] = rotations;
        for &f in order.iter().skip(nsub) {
            let f = f as usize;
            put_varint(&mut st.0[s::FACE_SIZES], u64::from(input.offsets[f + 1] - input.offsets[f] - 3));
        }
        if has_lattice {
            level.slots = input.slots.map(|sl| order.iter().map(|&f| sl[f as usize]).collect());
            level.corners = input.corners.map(|c| vorder.iter().map(|&v| c[v as usize]).collect());
            slots::encode_raw_lattice(st, &level, k);
        }
    }
    level
}

pub fn finish(
    st: Streams,
    (mode, predictor, line_shift): (Mode, u8, u32),
    has_lattice: bool,
    level: PlainLevel,
    face_new: Vec<u32>,
    vertex_old: Vec<u32>,
) -> Encoded {
    let nv = vertex_old.len();
    let mut payload = Vec::new();
    payload.push(mode as u8);
    payload.push(if has_lattice { BLOCK_FLAG_LATTICE } else { 0 });
    payload.extend([predictor, line_shift as u8]);
    payload.extend((nv as u32).to_le_bytes());
    payload.extend((level.parents.len() as u32).to_le_bytes());
    payload.extend((level.indices.len() as u32).to_le_bytes());
    for sv in &st.0 {
        payload.extend((sv.len() as u32).to_le_bytes());
    }
    let geo = st.0[s::GEOMETRY].len();
    let topo: usize = st.0.iter().map(Vec::len).sum::<usize>() - geo;
    for sv in st.0 {
        payload.extend(sv);
    }
    Encoded {
        payload,
        level,
        face_new,
        vertex_old,
        split_bytes: (topo, geo),
        mode,
        predictor,
        line_shift,
        pos: Vec::new(),
        parent_quads: Vec::new(),
    }
}

/// Generic-mode rotation: the one placing the child's corners nearest to the canonical
/// subdivision's points (parent corner, edge midpoints, centroid).
fn generic_rotation(input: &InputLevel<'_>, parent: &PlainLevel, pface: &[u32], qd: usize, verts: &[u32]) -> u8 {
    let n = pface.len();
    let pt = |v: u32| -> [f64; 3] {
        if parent.exact.is_empty() { parent.q[v as usize].map(|x| x as f64) } else { parent.exact[v as usize] }
    };
    let ct = |v: u32| -> [f64; 3] {
        if input.exact.is_empty() { input.q[v as usize].map(|x| x as f64) } else { input.exact[v as usize] }
    };
    let mid = |a: [f64; 3], b: [f64; 3]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])];
    let mut cen = [0.0; 3];
    for &v in pface {
        let p = pt(v);
        for a in 0..3 {
            cen[a] += p[a] / n as f64;
        }
    }
    let c = pt(pface[qd]);
    let layout = [c, mid(c, pt(pface[(qd + 1) % n])), cen, mid(pt(pface[(qd + n - 1) % n]), c)];
    let mut best = (f64::INFINITY, 0u8);
    for rot in 0..8u8 {
        let mut cost = 0.0;
        for (i, &v) in verts.iter().enumerate() {
            let a = ct(v);
            let b = layout[rotated(rot, i)];
            cost += (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2);
        }
        if cost < best.0 {
            best = (cost, rot);
        }
    }
    best.1
}

struct LatticePlan {
    slots: Vec<([u32; 3], u8)>,
    inner: Vec<bool>,
    keys: Vec<u64>,
}

/// Checks that a level can use lattice mode and works out depths and created-face keys.
fn plan_lattice(input: &InputLevel<'_>, pp: &Parent<'_>) -> Option<LatticePlan> {
    let quads = pp.canonical_quads().ok()?;
    let slots = input.slots?;
    let pslots = pp.slots?;
    let nf = input.parents.len();
    let mut inner = vec![false; nf];
    let mut keys = vec![0u64; nf];
    let mut created = Vec::new();
    for f in 0..nf {
        if input.offsets[f + 1] - input.offsets[f] != 4 {
            return None;
        }
        let (v, d) = slots[f];
        keys[f] = lattice::morton_slot_key(v, d);
        if input.parents[f] == NO_PARENT {
            created.push(keys[f]);
            continue;
        }
        let pf = input.parents[f] as usize;
        let (pv, pd) = pslots[pf];
        let pc = lattice::slot_corners(pv, pd)[rotated(quads[pf].1, usize::from(input.quadrants[f]))];
        if lattice::child_slot(pv, pd, pc, false) == Some((v, d)) {
            inner[f] = false;
        } else if lattice::child_slot(pv, pd, pc, true) == Some((v, d)) {
            inner[f] = true;
        } else {
            return None;
        }
    }
    created.sort_unstable();
    if created.windows(2).any(|w| w[0] == w[1]) {
        return None;
    }
    Some(LatticePlan { slots: slots.to_vec(), inner, keys })
}
