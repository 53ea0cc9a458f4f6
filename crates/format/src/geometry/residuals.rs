//! The geometry stream's layout (spec §6.1 The `geometry` stream, §6.6 Line geometry): exact
//! positions as byte planes of binary64 bit patterns; grid residuals as three byte-plane blocks,
//! preceded with `LINES` by the bitmap of line vertices and their parameters. Both directions; the
//! encoder computes the residuals with the prediction passes and keeps the predictor, layout and
//! line spacing that compress best.

use crate::block::{MAX_LINE_SHIFT, Mode, PREDICTOR_LINES, s};
use crate::bytes::{Planes, Reader, put_planes, zigzag};
use crate::entropy::values::{put_values, read_values};
use crate::error::DecodeError;
use crate::geometry::fixed as fast;
use crate::geometry::predict::{GeometryScratch, Topo, geometry_pass};
use crate::level_decode::PlainLevel;
use crate::level_encode::Streams;

/// The exact geometry of a level (spec §6.1): three planes of `f64` bit patterns, every
/// coordinate finite.
pub fn exact_positions(g: &mut Reader<'_>, nv: usize) -> Result<Vec<[f64; 3]>, DecodeError> {
    let planes = [g.planes(nv, 8)?, g.planes(nv, 8)?, g.planes(nv, 8)?];
    let exact: Vec<[f64; 3]> = (0..nv).map(|v| planes.each_ref().map(|p| f64::from_bits(p[v]))).collect();
    if let Some(v) = exact.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(g.invalid(format!("vertex {v} has a non-finite coordinate")));
    }
    Ok(exact)
}

/// The parts of a grid level's geometry stream (spec §6.1, §6.6, §6.8), in stream order.
pub struct GridStreams<'a> {
    /// With `LINES`: one bit per vertex, set for line vertices (empty without).
    pub flags: &'a [u8],
    /// With `LINES`: the line vertices' parameters.
    pub params: Option<Planes<'a>>,
    /// The other vertices' three residuals.
    pub planes: [Planes<'a>; 3],
}

/// With lines, the bitmap of line vertices (spec §6.1; unused bits zero) and the number of line
/// vertices; without, nothing.
fn line_flags<'a>(g: &mut Reader<'a>, nv: usize, lines: bool) -> Result<(&'a [u8], usize), DecodeError> {
    if !lines {
        return Ok((&[], 0));
    }
    let flags = g.bytes(nv.div_ceil(8))?;
    if nv % 8 != 0 && flags[nv / 8] >> (nv % 8) != 0 {
        return Err(g.invalid("unused line flag bits are not zero"));
    }
    Ok((flags, flags.iter().map(|b| b.count_ones() as usize).sum()))
}

/// Reads the layout of a grid level's geometry stream: with lines, the bitmap of line vertices
/// (unused bits zero) and their parameters, then the residual planes of the others.
pub fn grid_streams<'a>(g: &mut Reader<'a>, nv: usize, lines: bool) -> Result<GridStreams<'a>, DecodeError> {
    let (flags, line_count) = line_flags(g, nv, lines)?;
    let params = if lines { Some(g.plane_view(line_count, 4)?) } else { None };
    let rest = nv - line_count;
    let planes = [g.plane_view(rest, 4)?, g.plane_view(rest, 4)?, g.plane_view(rest, 4)?];
    Ok(GridStreams { flags, params, planes })
}

/// Writes the layout of a grid level's geometry stream (spec §6.1, §6.6, §6.8): with lines, the
/// bitmap of line vertices and their parameters, then the other vertices' residuals in coding
/// order; without, the residuals of every vertex, put back in vertex order (`order` lists the
/// vertices in coding order).
pub fn put_grid_streams(
    g: &mut Vec<u8>,
    lines: Option<(&[u8], &[u64])>,
    mut res: [Vec<u64>; 3],
    order: &[u32],
    nv: usize,
) {
    if let Some((flags, params)) = lines {
        g.extend(flags);
        put_planes(g, params);
    } else {
        for r in &mut res {
            let mut by_vertex = vec![0u64; nv];
            for (i, &v) in order.iter().enumerate() {
                by_vertex[v as usize] = r[i];
            }
            *r = by_vertex;
        }
    }
    for r in &res {
        put_planes(g, r);
    }
}

/// Reads a mode 3 geometry stream of version 4 (spec §6.1, §6.9): with lines, the bitmap of line
/// vertices (unused bits zero), then the value blocks of the line parameters and of the other
/// vertices' x, y, z residuals, into `values` (`[params, x, y, z]`). Returns the bitmap (empty
/// without lines).
pub fn grid_values<'a>(
    g: &mut Reader<'a>,
    nv: usize,
    lines: bool,
    values: &mut [Vec<u32>; 4],
) -> Result<&'a [u8], DecodeError> {
    let (flags, line_count) = line_flags(g, nv, lines)?;
    let [params, x, y, z] = values;
    if lines {
        read_values(g, line_count, params)?;
    } else {
        params.clear();
    }
    for r in [x, y, z] {
        read_values(g, nv - line_count, r)?;
    }
    Ok(flags)
}

/// The geometry stream (§6) of a refinement level: the predictor (§6.3), layout and line spacing
/// (§6.6) that compress best: mode 3 levels of version 4 files by [`choose_coded`], the others by
/// their size under zstd.
/// Returns the block's `predictor` byte, its `line_shift`, and the parent's canonical quads
/// (lattice levels).
#[allow(clippy::too_many_arguments)]
pub fn choose_geometry(
    k: u32,
    (mode, version): (Mode, u16),
    (bits, exact): (u32, bool),
    level: &PlainLevel,
    parent: &PlainLevel,
    pos: &[u8],
    topology_only: bool,
    st: &mut Streams,
) -> (u8, u32, Vec<([u32; 4], u8)>) {
    let pp = parent.as_parent();
    let quads = if mode.is_lattice() {
        pp.canonical_quads().map(std::borrow::Cow::into_owned).unwrap_or_default()
    } else {
        Vec::new()
    };
    let mut predictor = 0u8;
    let mut line_shift = 0u32;
    if topology_only {
        return (predictor, line_shift, quads);
    }
    let coded = mode == Mode::FastLattice && !exact && version >= 4;
    if coded {
        (predictor, line_shift) = choose_coded(level, k, bits, parent, pos, &quads, st);
        return (predictor, line_shift, quads);
    }
    let stream = |variant: (u8, u32)| geometry(level, mode, k, bits, exact, Some(parent), pos, &quads, variant);
    st.0[s::GEOMETRY] = stream((0, 0)).0;
    if exact {
        return (predictor, line_shift, quads);
    }
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
        consider(stream((1, 0)).0, (1, 0), st);
    }
    let line_predictors: &[u8] = if mode.is_lattice() { &[0, 1] } else { &[0] };
    for &p in line_predictors {
        let variant = p | PREDICTOR_LINES;
        let (bytes, js) = stream((variant, 0));
        consider(bytes, (variant, 0), st);
        let shift = common_shift(&js);
        if shift > 0 {
            consider(stream((variant, shift)).0, (variant, shift), st);
        }
    }
    (predictor, line_shift, quads)
}

/// The mode 3 prediction inputs (spec §6.8) of a canonical level.
pub(crate) fn level_topo<'a>(
    level: &'a PlainLevel,
    contexts: &'a fast::Contexts,
    quads: &'a [([u32; 4], u8)],
    (k, bits): (u32, u32),
    (predictor, line_shift, lines): (u8, u32, bool),
) -> fast::FastTopo<'a> {
    fast::FastTopo {
        level: k,
        bits,
        indices: &level.indices,
        slots: level.slots.as_deref().unwrap_or_default(),
        vertex_corners: level.corners.as_deref().unwrap_or_default(),
        contexts,
        parent_quads: quads,
        lines,
        line_shift,
        predictor,
    }
}

/// The values of a mode 3 level's geometry under one lattice predictor and line spacing (spec
/// §6.8), for both layouts of §6.1 (their predictions are the same): per vertex in coding order
/// its line parameter when it lies on its line, and its residuals always.
struct FastValues {
    /// Line flags (§6.1).
    flags: Vec<u8>,
    /// Zigzagged line parameter differences of the line vertices, in coding order.
    params: Vec<u32>,
    /// The line vertices' parameters.
    js: Vec<i64>,
    /// Zigzagged residuals of the other vertices, in coding order.
    line_residuals: [Vec<u32>; 3],
    /// Zigzagged residuals of every vertex, by vertex index.
    residuals: [Vec<u32>; 3],
    /// Estimated bits of the layout with lines and of the one without.
    cost: (u64, u64),
}

/// Estimated bits of a value (its Elias gamma code): enough to rank layouts and predictors.
#[inline]
fn gamma_bits(x: u32) -> u64 {
    u64::from(2 * (32 - (x + 1).leading_zeros()) - 1)
}

/// One pass of spec §6.8 over a mode 3 level (lines on, so that both layouts come out of it).
#[allow(clippy::too_many_arguments)]
fn fast_values(
    level: &PlainLevel,
    k: u32,
    bits: u32,
    parent: &PlainLevel,
    contexts: &fast::Contexts,
    quads: &[([u32; 4], u8)],
    (predictor, line_shift): (u8, u32),
) -> FastValues {
    let nv = level.q.len();
    let topo = level_topo(level, contexts, quads, (k, bits), (predictor, line_shift, true));
    let target = &level.q;
    let mut out = FastValues {
        flags: vec![0u8; nv.div_ceil(8)],
        params: Vec::with_capacity(nv),
        js: Vec::with_capacity(nv),
        line_residuals: [Vec::new(), Vec::new(), Vec::new()],
        residuals: [vec![0; nv], vec![0; nv], vec![0; nv]],
        cost: (nv as u64, 0),
    };
    let mut q = vec![[0i64; 3]; nv];
    let _: Result<(), ()> = fast::fast_pass(&topo, &parent.q, &mut q, &mut Vec::new(), |v, pr| {
        let t = target[v];
        let r = [0, 1, 2].map(|a| zigzag(t[a] - pr.point[a]) as u32);
        let rc: u64 = r.iter().map(|&x| gamma_bits(x)).sum();
        for (all, &x) in out.residuals.iter_mut().zip(&r) {
            all[v] = x;
        }
        out.cost.1 += rc;
        let on_line =
            pr.line.and_then(|l| l.param(t)).and_then(|j| u32::try_from(zigzag(j - pr.param)).ok().map(|z| (j, z)));
        if let Some((j, z)) = on_line {
            out.flags[v / 8] |= 1 << (v % 8);
            out.params.push(z);
            out.js.push(j);
            out.cost.0 += gamma_bits(z);
        } else {
            for (others, &x) in out.line_residuals.iter_mut().zip(&r) {
                others.push(x);
            }
            out.cost.0 += rc;
        }
        Ok(t)
    });
    out
}

/// The geometry stream of a mode 3 level of a version 4 grid file (spec §6.1, §6.8, §6.9): both
/// lattice predictors, with and without lines, and a coarser line spacing where the parameters
/// allow it, ranked by their estimated coded size (one prediction pass per predictor); the best
/// is range coded. Returns the `predictor` byte and `line_shift`.
fn choose_coded(
    level: &PlainLevel,
    k: u32,
    bits: u32,
    parent: &PlainLevel,
    pos: &[u8],
    quads: &[([u32; 4], u8)],
    st: &mut Streams,
) -> (u8, u32) {
    let nv = level.q.len();
    let mut contexts = fast::Contexts::default();
    fast::contexts(&level.indices, &level.parents, &level.quadrants, pos, quads, nv, &mut contexts);
    // Candidates (estimated bits, predictor byte, line_shift, pass), the first of equal ones kept.
    let mut passes = Vec::new();
    let mut candidates = Vec::new();
    for p in [0u8, 1] {
        let values = fast_values(level, k, bits, parent, &contexts, quads, (p, 0));
        let shift = common_shift(&values.js);
        candidates.push((values.cost.1, p, 0, passes.len()));
        candidates.push((values.cost.0, p | PREDICTOR_LINES, 0, passes.len()));
        passes.push(values);
        if shift > 0 {
            let shifted = fast_values(level, k, bits, parent, &contexts, quads, (p, shift));
            candidates.push((shifted.cost.0, p | PREDICTOR_LINES, shift, passes.len()));
            passes.push(shifted);
        }
    }
    let &(_, predictor, line_shift, i) = candidates.iter().min_by_key(|c| c.0).expect("candidates");
    let values = &passes[i];
    let g = &mut st.0[s::GEOMETRY];
    g.clear();
    if predictor & PREDICTOR_LINES != 0 {
        g.extend(&values.flags);
        put_values(g, &values.params);
        for r in &values.line_residuals {
            put_values(g, r);
        }
    } else {
        for r in &values.residuals {
            put_values(g, r);
        }
    }
    (predictor, line_shift)
}

/// The geometry stream (§6.1) of a level under the given predictor.
#[allow(clippy::too_many_arguments)]
pub fn geometry(
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

/// The geometry stream of a mode 3 level (spec §6.8) of a grid file of version 3.
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
    let topo = level_topo(level, &contexts, quads, (k, bits), (predictor & 1, line_shift, lines));
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
