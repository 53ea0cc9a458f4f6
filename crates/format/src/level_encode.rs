//! The level encoder: the inverse of `decode.rs`. It puts each level in the canonical order of
//! spec §5.7 (the order the decoder produces), picks the lattice mode when the level allows it,
//! and writes the streams. Deterministic: no hash-map iteration reaches the output.

use crate::block::{BLOCK_FLAG_LATTICE, MAX_LINE_SHIFT, Mode, PREDICTOR_LINES, STREAM_COUNT, s};
use crate::bytes::{put_planes, put_varint, zigzag};
use crate::error::EncodeError;
use crate::geometry::fixed as fast;
use crate::geometry::predict::{GeometryScratch, Topo, geometry_pass};
use crate::geometry::residuals::put_grid_streams;
use crate::level_decode::PlainLevel;
use crate::topology::slots::{self as lattice, MAX_LATTICE_DEPTH};
use crate::topology::{NO_PARENT, NO_POS, Parent, best_rotation, number_edges, rotated};

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

struct Streams([Vec<u8>; STREAM_COUNT]);

impl Streams {
    fn new() -> Self {
        Self(std::array::from_fn(|_| Vec::new()))
    }
}

fn face(offsets: &[u32], indices: &[u32], f: usize) -> std::ops::Range<usize> {
    let _ = indices;
    offsets[f] as usize..offsets[f + 1] as usize
}

/// Encodes level `k` (`parent` is the canonical level `k - 1`, `None` for level 0).
#[allow(clippy::too_many_lines, clippy::needless_range_loop)] // mirrors decode_level step by step
pub fn encode_level(
    k: u32,
    input: &InputLevel<'_>,
    parent: Option<&PlainLevel>,
    exact: bool,
    tied: bool,
    bits: u32,
    version: u16,
) -> Result<Encoded, EncodeError> {
    let nf = input.parents.len();
    let nv = input.q.len().max(input.exact.len());
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
    let mut st = Streams::new();
    let Some(parent) = parent else {
        // Base mode: order kept as given.
        let mut level = PlainLevel {
            offsets: input.offsets.to_vec(),
            indices: input.indices.to_vec(),
            parents: vec![NO_PARENT; nf],
            quadrants: vec![0; nf],
            ..PlainLevel::default()
        };
        for w in input.offsets.windows(2) {
            put_varint(&mut st.0[s::FACE_SIZES], u64::from(w[1] - w[0] - 3));
        }
        let mut prev = 0i64;
        for &i in input.indices {
            put_varint(&mut st.0[s::CORNERS], zigzag(i64::from(i) - prev));
            prev = i64::from(i);
        }
        if has_lattice {
            level.slots = input.slots.map(<[_]>::to_vec);
            level.corners = input.corners.map(<[_]>::to_vec);
            raw_lattice(&mut st, &level, k);
        }
        level.q.clone_from(&input.q);
        level.exact.clone_from(&input.exact);
        let pos = vec![NO_POS; input.indices.len()];
        st.0[s::GEOMETRY] = geometry(&level, Mode::Base, k, bits, exact, None, &pos, &[], (0, 0)).0;
        let mut e =
            finish(st, (Mode::Base, 0, 0), has_lattice, level, (0..nf as u32).collect(), (0..nv as u32).collect());
        e.pos = pos;
        return Ok(e);
    };
    let pp = parent.as_parent();
    let lattice_plan =
        if has_lattice && (exact || tied) && parent.slots.is_some() { plan_lattice(input, &pp) } else { None };
    let mode = match lattice_plan {
        Some(_) if version >= 3 => Mode::FastLattice,
        Some(_) => Mode::Lattice,
        None => Mode::Generic,
    };

    // Face order (§5.7): subfaces by (parent, quadrant), then created faces.
    let mut order: Vec<u32> = (0..nf as u32).collect();
    let created_key = |f: usize| -> u64 {
        match &lattice_plan {
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
    for &f in &order {
        let f = f as usize;
        let r = face(input.offsets, input.indices, f);
        let verts = &input.indices[r];
        let is_sub = input.parents[f] != NO_PARENT;
        if let Some(pl) = &lattice_plan {
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

    let (indices, vorder) = if mode == Mode::FastLattice {
        fast_names(k, input.corners.expect("lattice"), &corner_vertex, &pred, &mut pos, nv, &mut st)
    } else {
        // Vertex names (§5.5) and canonical vertex order (§5.7).
        let mut vname = vec![u64::MAX; nv];
        let mut first_seen = vec![u64::MAX; nv];
        if let Some(corners) = input.corners.filter(|_| mode == Mode::Lattice) {
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
            let mut next = name_base_free;
            for &v in &corner_vertex {
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
        // The name set (predicted names and the vertices' names), each with its first vertex and count.
        let mut names: Vec<(u64, u32, u32)> = Vec::with_capacity(predicted.len() + 16);
        {
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
        }
        let extras: Vec<u64> = names.iter().map(|n| n.0).filter(|n| predicted.binary_search(n).is_err()).collect();
        put_varint(&mut st.0[s::EXTRA_NAMES], extras.len() as u64);
        for (i, &n) in extras.iter().enumerate() {
            put_varint(&mut st.0[s::EXTRA_NAMES], if i == 0 { n } else { n - extras[i - 1] - 1 });
        }
        let splits: Vec<(usize, u32)> =
            names.iter().enumerate().filter(|(_, n)| n.2 != 1).map(|(i, n)| (i, n.2)).collect();
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
    };

    // Face structure streams (§5.3, §5.4).
    let mut level = PlainLevel { offsets, indices, ..PlainLevel::default() };
    level.parents = order.iter().map(|&f| input.parents[f as usize]).collect();
    level.quadrants = order.iter().map(|&f| input.quadrants[f as usize]).collect();
    let mut sub_iter = level.parents.iter().zip(&level.quadrants).peekable();
    let nsub = level.parents.iter().filter(|&&p| p != NO_PARENT).count();
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
    if let Some(pl) = &lattice_plan {
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
            raw_lattice(&mut st, &level, k);
        }
    }
    level.q = if input.q.is_empty() { Vec::new() } else { vorder.iter().map(|&v| input.q[v as usize]).collect() };
    level.exact =
        if input.exact.is_empty() { Vec::new() } else { vorder.iter().map(|&v| input.exact[v as usize]).collect() };
    let quads = if mode.is_lattice() { pp.canonical_quads().unwrap_or_default() } else { Vec::new() };
    let mut predictor = 0u8;
    let mut line_shift = 0u32;
    if !input.topology_only {
        st.0[s::GEOMETRY] = geometry(&level, mode, k, bits, exact, Some(parent), &pos, &quads, (0, 0)).0;
        if !exact {
            // Keep whichever predictor (spec §6.3), layout and line spacing (§6.6) compresses best.
            let size = |b: &[u8]| zstd::bulk::compress(b, 3).map_or(b.len(), |c| c.len());
            let mut best = size(&st.0[s::GEOMETRY]);
            let mut consider = |bytes: Vec<u8>, variant: (u8, u32), st: &mut Streams| {
                let n = size(&bytes);
                if n < best {
                    best = n;
                    st.0[s::GEOMETRY] = bytes;
                    (predictor, line_shift) = variant;
                }
            };
            if mode.is_lattice() {
                consider(geometry(&level, mode, k, bits, exact, Some(parent), &pos, &quads, (1, 0)).0, (1, 0), &mut st);
            }
            let line_predictors: &[u8] = if mode.is_lattice() { &[0, 1] } else { &[0] };
            for &p in line_predictors {
                let variant = p | PREDICTOR_LINES;
                let (bytes, js) = geometry(&level, mode, k, bits, exact, Some(parent), &pos, &quads, (variant, 0));
                consider(bytes, (variant, 0), &mut st);
                let shift = common_shift(&js);
                if shift > 0 {
                    let bytes = geometry(&level, mode, k, bits, exact, Some(parent), &pos, &quads, (variant, shift)).0;
                    consider(bytes, (variant, shift), &mut st);
                }
            }
        }
    }
    let mut e = finish(st, (mode, predictor, line_shift), has_lattice, level, face_new, vorder);
    e.pos = pos;
    e.parent_quads = quads;
    Ok(e)
}

fn raw_lattice(st: &mut Streams, level: &PlainLevel, k: u32) {
    let r = &mut st.0[s::RAW_LATTICE];
    let mut prev = 0i64;
    for &(v, d) in level.slots.as_deref().unwrap_or_default() {
        let key = lattice::slot_key(v, d, k) as i64;
        put_varint(r, zigzag(key - prev));
        prev = key;
    }
    prev = 0;
    for &c in level.corners.as_deref().unwrap_or_default() {
        let key = lattice::corner_key(c, k) as i64;
        put_varint(r, zigzag(key - prev));
        prev = key;
    }
}

/// The geometry stream (§6.1) of a level under the given predictor.
#[allow(clippy::too_many_arguments)]
fn geometry(
    level: &PlainLevel,
    mode: Mode,
    k: u32,
    bits: u32,
    exact: bool,
    parent: Option<&PlainLevel>,
    pos: &[u8],
    quads: &[([u32; 4], u8)],
    (predictor, line_shift): (u8, u32),
) -> (Vec<u8>, Vec<i64>) {
    let mut g = Vec::new();
    if mode == Mode::FastLattice && !exact {
        return fast_geometry(level, k, bits, parent.expect("refinement"), pos, quads, (predictor, line_shift));
    }
    if exact {
        for a in 0..3 {
            let vals: Vec<u64> = level.exact.iter().map(|p| p[a].to_bits()).collect();
            put_planes(&mut g, &vals);
        }
        return (g, Vec::new());
    }
    let nv = level.q.len();
    let lines = predictor & PREDICTOR_LINES != 0;
    let target = &level.q;
    let pp = parent.map(PlainLevel::as_parent);
    let topo = Topo {
        mode,
        level: k,
        bits,
        offsets: &level.offsets,
        indices: &level.indices,
        parents: &level.parents,
        quadrants: &level.quadrants,
        corner_pos: pos,
        vertex_corners: level.corners.as_deref(),
        parent_quads: (mode == Mode::Lattice).then_some(quads),
        predictor: predictor & !PREDICTOR_LINES,
        lines,
        line_shift,
    };
    // Without lines: residuals by vertex index. With lines (§6.6): line flags, then parameters
    // and the other vertices' residuals in coding order.
    let mut res = [Vec::with_capacity(nv), Vec::with_capacity(nv), Vec::with_capacity(nv)];
    let mut params = Vec::new();
    let mut js = Vec::new();
    let mut flags = vec![0u8; if lines { nv.div_ceil(8) } else { 0 }];
    let mut q = vec![[0i64; 3]; nv];
    let mut order = Vec::with_capacity(if lines { 0 } else { nv });
    let _: Result<(), ()> = geometry_pass(&topo, pp.as_ref(), &mut q, &mut GeometryScratch::default(), |v, pr| {
        let t = target[v];
        if let Some(j) = pr.line.and_then(|l| l.param(t)) {
            flags[v / 8] |= 1 << (v % 8);
            params.push(zigzag(j - pr.param));
            js.push(j);
            return Ok((t, Some(j)));
        }
        let point = pr.point();
        for a in 0..3 {
            res[a].push(zigzag(t[a] - point[a]));
        }
        order.push(v as u32);
        Ok((t, None))
    });
    put_grid_streams(&mut g, lines.then_some((&flags[..], &params[..])), res, &order, nv);
    (g, js)
}

/// The geometry stream of a mode 3 level (spec §6.8) of a grid file.
fn fast_geometry(
    level: &PlainLevel,
    k: u32,
    bits: u32,
    parent: &PlainLevel,
    pos: &[u8],
    quads: &[([u32; 4], u8)],
    (predictor, line_shift): (u8, u32),
) -> (Vec<u8>, Vec<i64>) {
    let nv = level.q.len();
    let lines = predictor & PREDICTOR_LINES != 0;
    let mut contexts = fast::Contexts::default();
    fast::contexts(&level.indices, &level.parents, &level.quadrants, pos, quads, nv, &mut contexts);
    let topo = fast::FastTopo {
        level: k,
        bits,
        indices: &level.indices,
        slots: level.slots.as_deref().unwrap_or_default(),
        vertex_corners: level.corners.as_deref().unwrap_or_default(),
        contexts: &contexts,
        parent_quads: quads,
        lines,
        line_shift,
        predictor: predictor & 1,
    };
    let target = &level.q;
    let mut res = [Vec::with_capacity(nv), Vec::with_capacity(nv), Vec::with_capacity(nv)];
    let mut params = Vec::new();
    let mut js = Vec::new();
    let mut flags = vec![0u8; if lines { nv.div_ceil(8) } else { 0 }];
    let mut order = Vec::with_capacity(if lines { 0 } else { nv });
    let mut q = vec![[0i64; 3]; nv];
    let _: Result<(), ()> = fast::fast_pass(&topo, &parent.q, &mut q, &mut Vec::new(), |v, pr| {
        let t = target[v];
        if let Some(j) = pr.line.and_then(|l| l.param(t)) {
            flags[v / 8] |= 1 << (v % 8);
            params.push(zigzag(j - pr.param));
            js.push(j);
            return Ok(t);
        }
        for a in 0..3 {
            res[a].push(zigzag(t[a] - pr.point[a]));
        }
        order.push(v as u32);
        Ok(t)
    });
    let mut g = Vec::new();
    put_grid_streams(&mut g, lines.then_some((&flags[..], &params[..])), res, &order, nv);
    (g, js)
}

/// Mode 3's vertex numbering (spec §5.9): vertices by first use in corner order, the split keys,
/// exceptions and choices, and the vertices no corner uses. Returns the corners' new vertex
/// indices and the input index of every new vertex.
fn fast_names(
    k: u32,
    corners: &[[u32; 3]],
    corner_vertex: &[u32],
    pred: &[u64],
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

/// The largest line spacing exponent (spec §6.6) that at least 15 in 16 of the nonzero line
/// parameters `js` (found with spacing 1) are multiples of; 0 when there are none.
fn common_shift(js: &[i64]) -> u32 {
    let nonzero: Vec<u32> = js.iter().filter(|&&j| j != 0).map(|j| j.trailing_zeros()).collect();
    if nonzero.is_empty() {
        return 0;
    }
    let mut best = 0;
    for shift in 1..=MAX_LINE_SHIFT {
        let fits = nonzero.iter().filter(|&&z| z >= shift).count();
        if fits * 16 >= nonzero.len() * 15 {
            best = shift;
        } else {
            break;
        }
    }
    best
}

fn finish(
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
