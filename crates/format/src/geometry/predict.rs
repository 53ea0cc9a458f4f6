//! Geometry of modes 0-2 (spec §6.2-§6.7): the context and the two passes, the lattice
//! predictors (§6.3), the subdivision predictor (§6.4), the neighbour predictor (§6.5) and line
//! geometry (§6.6).
//!
//! The geometry pass ([`geometry_pass`]) is one function used by both directions, so that encoder
//! and decoder cannot disagree on a prediction.

use crate::block::{Mode, PREDICTOR_BILINEAR, PREDICTOR_NORMAL};
pub use crate::geometry::lines::Line;
use crate::topology::slots as lattice;
use crate::topology::{NO_PARENT, NO_POS, NONE, Parent};

/// The largest grid coordinate magnitude: the grid range of spec §1.7.
pub const GRID_LIMIT: i64 = 1 << 28;

/// `a / b` rounded to the nearest integer, halves upwards (`b > 0`).
#[inline]
pub fn round_div(a: i64, b: i64) -> i64 {
    if b & (b - 1) == 0 && a.unsigned_abs() < 1 << 61 && b < 1 << 61 {
        // floor((2a + b) / 2b) for a power of two b: an arithmetic shift.
        (2 * a + b) >> (b.trailing_zeros() + 1)
    } else if a.unsigned_abs() < 1 << 29 && b < 1 << 29 {
        // The common case in 32 bits (a faster division).
        (2 * a as i32 + b as i32).div_euclid(2 * b as i32) as i64
    } else if a.unsigned_abs() < 1 << 60 && b < 1 << 60 {
        (2 * a + b).div_euclid(2 * b)
    } else {
        // Exact for any operands a hostile file can produce.
        ((2 * i128::from(a) + i128::from(b)).div_euclid(2 * i128::from(b))) as i64
    }
}
/// Where a refinement level's faces and corners come from, as the geometry pass needs it.
pub struct Topo<'a> {
    /// Coding mode.
    pub mode: Mode,
    /// Level index `k`.
    pub level: u32,
    /// Grid bits of a tied grid (lattice mode only).
    pub bits: u32,
    /// Face offsets of the level.
    pub offsets: &'a [u32],
    /// Face corner indices of the level.
    pub indices: &'a [u32],
    /// Per face: parent face or [`NO_PARENT`].
    pub parents: &'a [u32],
    /// Per face: quadrant (meaningful for subfaces).
    pub quadrants: &'a [u8],
    /// Per corner: the canonical position it was predicted at (`0..4`), or [`NO_POS`] when it has no
    /// prediction or is an exception.
    pub corner_pos: &'a [u8],
    /// Per vertex: its lattice corner (lattice mode).
    pub vertex_corners: Option<&'a [[u32; 3]]>,
    /// Lattice mode: parent slots and canonical quads.
    pub parent_quads: Option<&'a [([u32; 4], u8)]>,
    /// Lattice mode: [`PREDICTOR_NORMAL`] or [`PREDICTOR_BILINEAR`].
    pub predictor: u8,
    /// Prediction lines (spec §6.6): every vertex also gets a line and a predicted parameter.
    pub lines: bool,
    /// Line spacing exponent (spec §6.6): consecutive line points are `2^line_shift` apart along
    /// the direction's largest axis.
    pub line_shift: u32,
}

/// What pass A or B predicts for one vertex.
#[derive(Clone, Copy, Debug)]
pub struct Prediction {
    /// In line mode: the vertex's prediction line.
    pub line: Option<Line>,
    /// The predicted line parameter (0 without a line).
    pub param: i64,
    /// The base prediction, and (pass A) the sum and count of the counted neighbours' biases:
    /// [`Prediction::point`] adds their local bias only when asked (a line vertex needs none).
    base: [i64; 3],
    bias_sum: [i64; 3],
    bias_count: i64,
}

impl Prediction {
    /// The point prediction (base plus local bias, or the neighbour predictor), clamped.
    #[inline]
    pub fn point(&self) -> [i64; 3] {
        let mut p = self.base;
        if self.bias_count > 0 {
            for (x, s) in p.iter_mut().zip(self.bias_sum) {
                *x += round_div(s.saturating_mul(3), 4 * self.bias_count);
            }
        }
        clamp(p)
    }
}

/// `S` of spec §6.3: four times the parent's bilinear point above `corner`. The slot's canonical
/// corner 0 equals its voxel on both in-plane axes.
#[inline]
fn bilinear_sum_of(p: &[[i64; 3]; 4], slot: ([u32; 3], u8), corner: [u32; 3]) -> [i64; 3] {
    let (u, w) = lattice::plane_axes(slot.1);
    let a = (i64::from(corner[u]) - 2 * i64::from(slot.0[u])).clamp(0, 2);
    let b = (i64::from(corner[w]) - 2 * i64::from(slot.0[w])).clamp(0, 2);
    let wts = [(2 - a) * (2 - b), a * (2 - b), a * b, (2 - a) * b];
    let mut s = [0i64; 3];
    for i in 0..4 {
        for k in 0..3 {
            s[k] += wts[i] * p[i][k];
        }
    }
    s
}

/// `round_away` of spec §1.7 (halves away from zero), saturated to `i64`; NaN gives 0. Exact
/// without a library call: below 2^52 the fraction `x - trunc(x)` is exact; above, `x` is an
/// integer.
#[inline]
pub fn round_away(x: f64) -> i64 {
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        return x as i64;
    }
    let i = x as i64;
    let frac = x - i as f64;
    // Branch-free: the fraction's sign and size are data, not a pattern a predictor learns.
    i + i64::from(frac >= 0.5) - i64::from(frac <= -0.5)
}

/// Reusable buffers of [`geometry_pass`]: a decoder keeps one across its levels, so that big
/// arrays are not allocated (and their pages faulted in) once per level.
#[derive(Default)]
pub struct GeometryScratch {
    /// Per vertex: its context corner (§6.2) or [`NONE`].
    ctx: Vec<u32>,
    /// Per vertex with a context: the face of the context corner.
    ctx_face: Vec<u32>,
    /// Per vertex: the end of its incident corners (after the fill pass).
    end: Vec<u32>,
    /// Previous and next vertex of every incident corner, grouped by vertex.
    nbr: Vec<u32>,
    /// Per vertex: `[B_x, B_y, B_z, 1, J, 1 if line vertex, 0, 0]` once decoded in pass A.
    bias: Vec<[i32; 8]>,
    /// Per parent face: its normal and line direction (lines, or lattice predictor 0).
    faces: Vec<FaceNormal>,
}

impl GeometryScratch {
    /// Bytes held by the buffers.
    pub fn capacity_bytes(&self) -> usize {
        (self.ctx.capacity() + self.ctx_face.capacity() + self.end.capacity() + self.nbr.capacity()) * 4
            + self.bias.capacity() * size_of::<[i32; 8]>()
            + self.faces.capacity() * size_of::<FaceNormal>()
    }
}

/// What every vertex of one parent face shares in pass A: the face's normal `nf` (§6.3 or §6.6),
/// `4 nn` of §6.3, and the line direction `u` of §6.6.
#[derive(Clone, Copy, Default)]
struct FaceNormal {
    nf: [f64; 3],
    nn4: f64,
    u: [f64; 3],
}

/// The normal of a face whose normal is not needed.
const NO_NORMAL: FaceNormal = FaceNormal { nf: [0.0; 3], nn4: 0.0, u: [0.0; 3] };

impl FaceNormal {
    #[inline]
    fn new(n: [f64; 3], shift: u32) -> Self {
        let nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        Self { nf: n, nn4: 4.0 * nn, u: Line::direction(n, shift) }
    }
}

/// Resizes `v` to `n` elements without rewriting the ones it holds (for buffers that the caller
/// overwrites entirely).
fn at_least<T: Copy + Default>(v: &mut Vec<T>, n: usize) -> &mut [T] {
    if v.len() < n {
        v.resize(n, T::default());
    }
    &mut v[..n]
}

/// Runs the geometry predictor of spec §6 over a level in the normative order and calls
/// `step(v, prediction)` for every vertex; `step` returns the vertex's grid coordinates and, for a
/// vertex coded on its prediction line, its line parameter (the decoder adds the residual, the
/// encoder records the residual and returns the target).
///
/// Flat arrays only: per vertex its context corner and face, and its neighbours (previous and
/// next corner of every incident corner, in corner order) as one CSR list built by counting; per
/// parent face its normal and line direction, computed once. `step` must return grid
/// coordinates within [`GRID_LIMIT`] and line parameters within [`LINE_PARAM_LIMIT`].
pub fn geometry_pass<E>(
    topo: &Topo<'_>,
    parent: Option<&Parent<'_>>,
    q: &mut [[i64; 3]],
    scratch: &mut GeometryScratch,
    mut step: impl FnMut(usize, &Prediction) -> Result<([i64; 3], Option<i64>), E>,
) -> Result<(), E> {
    let nv = q.len();
    let GeometryScratch { ctx, ctx_face, end, nbr, bias, faces } = scratch;
    ctx.clear();
    ctx.resize(nv, NONE);
    let ctx_face = at_least(ctx_face, nv);
    end.clear();
    end.resize(nv + 1, 0);
    let missing = contexts_and_degrees(topo, parent.is_some(), ctx, ctx_face, end);
    let nbr = at_least(nbr, 2 * topo.indices.len());
    neighbours(topo, end, nbr);
    let near = Near { nbr, end };
    if let Some(p) = parent {
        pass_a(topo, p, q, (ctx, ctx_face), &near, (bias, faces), &mut step)?;
    }
    if missing == 0 {
        return Ok(());
    }
    pass_b(topo, q, ctx, &near, &mut step)
}

/// The context of every vertex (§6.2): its first predicted, non-exception subface corner, and that
/// corner's face; in the same pass, every vertex's corner count (into `end[v + 1]`). Returns the
/// number of vertices without a context.
#[allow(clippy::needless_range_loop)] // corners by index: the context is a corner index
fn contexts_and_degrees(
    topo: &Topo<'_>,
    has_parent: bool,
    ctx: &mut [u32],
    ctx_face: &mut [u32],
    end: &mut [u32],
) -> usize {
    let (offsets, indices) = (topo.offsets, topo.indices);
    let mut missing = ctx.len();
    for f in 0..offsets.len() - 1 {
        let (a, b) = (offsets[f] as usize, offsets[f + 1] as usize);
        if has_parent && topo.parents[f] != NO_PARENT {
            for c in a..b {
                let v = indices[c] as usize;
                end[v + 1] += 1;
                if topo.corner_pos[c] != NO_POS && ctx[v] == NONE {
                    ctx[v] = c as u32;
                    ctx_face[v] = f as u32;
                    missing -= 1;
                }
            }
        } else {
            for &v in &indices[a..b] {
                end[v as usize + 1] += 1;
            }
        }
    }
    missing
}

/// Every vertex's neighbour entries (§6.2): `nbr[2 j]`, `nbr[2 j + 1]` are the previous and next
/// vertex of the `j`-th incident corner; vertex v's corners are `j` in `end[v - 1] .. end[v]`
/// afterwards, in corner order (`end` holds the corner counts on entry).
fn neighbours(topo: &Topo<'_>, end: &mut [u32], nbr: &mut [u32]) {
    let (offsets, indices) = (topo.offsets, topo.indices);
    for i in 0..end.len() - 1 {
        end[i + 1] += end[i];
    }
    for f in 0..offsets.len() - 1 {
        let face = &indices[offsets[f] as usize..offsets[f + 1] as usize];
        let n = face.len();
        if let &[v0, v1, v2, v3] = face {
            // Quads, the common case, unrolled.
            for (v, prev, next) in [(v0, v3, v1), (v1, v0, v2), (v2, v1, v3), (v3, v2, v0)] {
                let j = end[v as usize] as usize;
                end[v as usize] += 1;
                nbr[2 * j] = prev;
                nbr[2 * j + 1] = next;
            }
            continue;
        }
        let mut prev = face[n - 1];
        for (i, &v) in face.iter().enumerate() {
            let next = face[if i + 1 == n { 0 } else { i + 1 }];
            let j = end[v as usize] as usize;
            end[v as usize] += 1;
            nbr[2 * j] = prev;
            nbr[2 * j + 1] = next;
            prev = v;
        }
    }
}

/// The neighbour lists of [`neighbours`].
struct Near<'a> {
    nbr: &'a [u32],
    end: &'a [u32],
}

impl Near<'_> {
    /// The previous and next vertices of `v`'s corners, in pairs.
    #[inline]
    fn of(&self, v: usize) -> &[u32] {
        let begin = if v == 0 { 0 } else { self.end[v - 1] as usize };
        &self.nbr[2 * begin..2 * self.end[v] as usize]
    }
}

/// Pass A (§6.2): every vertex with a parent context, in index order, predicted from the parent
/// (§6.3 lattice, §6.4 subdivision) plus the local bias of its decoded neighbours, with its line
/// (§6.6). `bias` stays zero for vertices not decoded yet and for vertices without a context, so
/// the sums need no test.
fn pass_a<E>(
    topo: &Topo<'_>,
    p: &Parent<'_>,
    q: &mut [[i64; 3]],
    (ctx, ctx_face): (&[u32], &[u32]),
    near: &Near<'_>,
    (bias, faces): (&mut Vec<[i32; 8]>, &mut Vec<FaceNormal>),
    step: &mut impl FnMut(usize, &Prediction) -> Result<([i64; 3], Option<i64>), E>,
) -> Result<(), E> {
    let nv = q.len();
    bias.clear();
    bias.resize(nv, [0; 8]);
    let lattice_mode = topo.mode == Mode::Lattice;
    let lines = topo.lines;
    let want_normal = lines || (lattice_mode && topo.predictor == PREDICTOR_NORMAL);
    let quads = topo.parent_quads.unwrap_or(&[]);
    faces.clear();
    if want_normal {
        parent_normals(topo, p, faces);
    }
    // A bound on the magnitude of any bias or parameter so far: sums of few small terms run
    // in 32 bits.
    let mut max_abs = 1i64;
    for v in 0..nv {
        let c = ctx[v];
        if c == NONE {
            continue;
        }
        let f = ctx_face[v] as usize;
        let pf = topo.parents[f] as usize;
        let fnorm = if want_normal { &faces[pf] } else { &NO_NORMAL };
        let pred = if lattice_mode {
            let slots = p.slots.expect("lattice parent");
            let corners = topo.vertex_corners.expect("lattice level");
            lattice_pred(p.q, quads[pf].0, slots[pf], corners[v], topo.level, topo.bits, topo.predictor, fnorm)
        } else {
            subdivision_pred(p, pf, usize::from(topo.quadrants[f]), topo.corner_pos[c as usize])
        };
        // Local bias (§6.2): 3/4 of the mean correction of already decoded neighbours.
        let base = clamp(pred);
        let sum = bias_sum(near.of(v), bias, max_abs);
        let (line, param) = if lines {
            let jp = if sum[5] > 0 { round_div(sum[4].saturating_mul(3), 4 * sum[5]) } else { 0 };
            (Some(Line { base, u: fnorm.u }), jp)
        } else {
            (None, 0)
        };
        let pr = Prediction { line, param, base, bias_sum: [sum[0], sum[1], sum[2]], bias_count: sum[3] };
        let (qv, j) = step(v, &pr)?;
        q[v] = qv;
        let (jv, on) = j.map_or((0, 0), |j| (j, 1));
        let b = [qv[0] - base[0], qv[1] - base[1], qv[2] - base[2]];
        // An upper bound of the largest magnitude (at most twice it): ORs, no compares.
        max_abs |= (b[0] ^ b[0] >> 63) | (b[1] ^ b[1] >> 63) | (b[2] ^ b[2] >> 63) | (jv ^ jv >> 63);
        bias[v] = [b[0] as i32, b[1] as i32, b[2] as i32, 1, jv as i32, on, 0, 0];
    }
    Ok(())
}

/// The normal and line direction of every parent face (§6.3, §6.6): of its canonical quad in
/// lattice mode, Newell's otherwise.
fn parent_normals(topo: &Topo<'_>, p: &Parent<'_>, faces: &mut Vec<FaceNormal>) {
    faces.reserve(p.face_count());
    if topo.mode == Mode::Lattice {
        let quads = topo.parent_quads.expect("lattice mode has parent quads");
        faces.extend(quads.iter().map(|&(quad, _)| FaceNormal::new(quad_normal(p.q, quad), topo.line_shift)));
    } else {
        faces.extend((0..p.face_count()).map(|pf| FaceNormal::new(newell_normal(p.q, p.face(pf)), topo.line_shift)));
    }
}

/// The subdivision predictor (§6.4) of a corner at canonical position `cp` of quadrant `qd` of
/// parent face `pf`: the parent vertex, edge midpoint or face centroid.
#[inline]
fn subdivision_pred(p: &Parent<'_>, pf: usize, qd: usize, cp: u8) -> [i64; 3] {
    let face = p.face(pf);
    let n = face.len();
    let at = |i: usize| p.q[face[i % n] as usize];
    let two = |x: [i64; 3], y: [i64; 3]| map3([0, 1, 2], |a| round_div(x[a] + y[a], 2));
    match cp {
        0 => at(qd),
        1 => two(at(qd), at(qd + 1)),
        2 => {
            let mut sum = [0i64; 3];
            for &u in face {
                for (s, x) in sum.iter_mut().zip(p.q[u as usize]) {
                    *s += x;
                }
            }
            map3(sum, |s| round_div(s, n as i64))
        }
        _ => two(at(qd + n - 1), at(qd)),
    }
}

/// The sums of the first six `bias` entries of the neighbours `near` (§6.2): in 32 bits when
/// `max_abs` bounds every term so that no partial sum can leave them, else in 64 bits, saturating
/// only when even that could overflow.
#[inline]
#[allow(clippy::needless_range_loop)] // eight lanes at once
fn bias_sum(near: &[u32], bias: &[[i32; 8]], max_abs: i64) -> [i64; 6] {
    if (near.len() as i64).saturating_mul(max_abs) < 1 << 30 {
        // Every term is below `max_abs + 1 <= 2 max_abs` in magnitude: no partial sum can
        // leave 32 bits.
        let mut acc = [0i32; 8];
        for &u in near {
            let b = &bias[u as usize];
            for k in 0..8 {
                acc[k] += b[k];
            }
        }
        map6(|k| i64::from(acc[k]))
    } else if near.len() < 1 << 30 {
        // At most 2^30 terms of magnitude at most 2^30: no sum can saturate.
        let mut acc = [0i64; 6];
        for &u in near {
            let b = &bias[u as usize];
            for k in 0..6 {
                acc[k] += i64::from(b[k]);
            }
        }
        acc
    } else {
        let mut acc = [0i64; 6];
        for &u in near {
            let b = &bias[u as usize];
            for k in 0..6 {
                acc[k] = acc[k].saturating_add(i64::from(b[k]));
            }
        }
        acc
    }
}

/// Pass B (§6.2, with the neighbour predictor of §6.5): the vertices without a context, in index
/// order, each predicted from its neighbours decoded so far (relative to their lattice points in
/// lattice mode), with its line.
fn pass_b<E>(
    topo: &Topo<'_>,
    q: &mut [[i64; 3]],
    ctx: &[u32],
    near: &Near<'_>,
    step: &mut impl FnMut(usize, &Prediction) -> Result<([i64; 3], Option<i64>), E>,
) -> Result<(), E> {
    let lattice_mode = topo.mode == Mode::Lattice;
    let lp = |v: usize| -> [i64; 3] {
        match topo.vertex_corners {
            Some(vc) if lattice_mode => lattice::lattice_point(vc[v], topo.level, topo.bits),
            _ => [0; 3],
        }
    };
    for v in 0..q.len() {
        if ctx[v] != NONE {
            continue;
        }
        let mut sum = [0i64; 3];
        let mut count = 0i64;
        for &u in near.of(v) {
            let u = u as usize;
            if ctx[u] != NONE || u < v {
                let l = lp(u);
                for k in 0..3 {
                    sum[k] = sum[k].saturating_add(q[u][k] - l[k]);
                }
                count += 1;
            }
        }
        let l = lp(v);
        let pred = if count > 0 {
            [l[0] + round_div(sum[0], count), l[1] + round_div(sum[1], count), l[2] + round_div(sum[2], count)]
        } else if lattice_mode {
            l
        } else if v > 0 {
            q[v - 1]
        } else {
            [0; 3]
        };
        let base = clamp(pred);
        let line = topo
            .lines
            .then(|| Line::new(base, fan_normal(near.of(v), q, base, |u| ctx[u] != NONE || u < v), topo.line_shift));
        q[v] = step(v, &Prediction { line, param: 0, base, bias_sum: [0; 3], bias_count: 0 })?.0;
    }
    Ok(())
}

#[inline]
fn map6(f: impl Fn(usize) -> i64) -> [i64; 6] {
    [f(0), f(1), f(2), f(3), f(4), f(5)]
}

/// The normal of the fan of decoded neighbours around `base` (spec §6.6, pass B): the sum over the
/// vertex's corners whose previous and next vertices `a`, `b` both count of
/// `(Q_b - base) x (Q_a - base)`, exact in 128 bits, then rounded to binary64.
fn fan_normal(near: &[u32], q: &[[i64; 3]], base: [i64; 3], counts: impl Fn(usize) -> bool) -> [f64; 3] {
    let mut acc = [0i128; 3];
    for pair in near.chunks_exact(2) {
        let (a, b) = (pair[0] as usize, pair[1] as usize);
        if counts(a) && counts(b) {
            let da = map3([0, 1, 2], |k| i128::from(q[a][k] - base[k]));
            let db = map3([0, 1, 2], |k| i128::from(q[b][k] - base[k]));
            acc[0] += db[1] * da[2] - db[2] * da[1];
            acc[1] += db[2] * da[0] - db[0] * da[2];
            acc[2] += db[0] * da[1] - db[1] * da[0];
        }
    }
    map3(acc, |x| x as f64)
}

/// `[f(a[0]), f(a[1]), f(a[2])]`: inlined where std's array `map` was not, in the hot loops.
#[allow(clippy::inline_always)] // measured: a call per coordinate triple in the hot loops otherwise
#[inline(always)]
pub(crate) fn map3<T: Copy, U>(a: [T; 3], f: impl Fn(T) -> U) -> [U; 3] {
    [f(a[0]), f(a[1]), f(a[2])]
}

/// The parent grid points of a canonical quad.
#[inline]
fn quad_points(pq: &[[i64; 3]], quad: [u32; 4]) -> [[i64; 3]; 4] {
    [pq[quad[0] as usize], pq[quad[1] as usize], pq[quad[2] as usize], pq[quad[3] as usize]]
}

#[allow(clippy::inline_always)] // as map3
#[inline(always)]
fn clamp(p: [i64; 3]) -> [i64; 3] {
    map3(p, |x| x.clamp(-GRID_LIMIT, GRID_LIMIT))
}

/// The normal `n` of spec §6.3 of a canonical quad, `(G_2 - G_0) x (G_3 - G_1)` (exact: `|G| <=
/// 2^28`), as binary64.
#[inline]
fn quad_normal(pq: &[[i64; 3]], quad: [u32; 4]) -> [f64; 3] {
    let p = quad_points(pq, quad);
    let e1 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let e2 = [p[3][0] - p[1][0], p[3][1] - p[1][1], p[3][2] - p[1][2]];
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    map3(n, |x| x as f64)
}

/// The lattice predictor `P` of spec §6.3 (`predictor` 0 or 1), given the parent face's normal
/// (`fnorm`, used by predictor 0 only).
#[allow(clippy::inline_always, clippy::too_many_arguments)] // see below
#[inline(always)]
fn lattice_pred(
    pq: &[[i64; 3]],
    quad: [u32; 4],
    slot: ([u32; 3], u8),
    corner: [u32; 3],
    level: u32,
    bits: u32,
    predictor: u8,
    fnorm: &FaceNormal,
) -> [i64; 3] {
    // (`inline(always)`: called once per vertex, from one place; a call would pass its eight
    // arguments through memory.)
    let p = quad_points(pq, quad);
    let s = bilinear_sum_of(&p, slot, corner);
    if predictor == PREDICTOR_BILINEAR || fnorm.nn4 == 0.0 {
        return map3(s, |x| round_div(x, 4));
    }
    let nf = fnorm.nf;
    let l = lattice::lattice_point(corner, level, bits);
    let d = [(s[0] - 4 * l[0]) as f64, (s[1] - 4 * l[1]) as f64, (s[2] - 4 * l[2]) as f64];
    let t = (nf[0] * d[0] + nf[1] * d[1] + nf[2] * d[2]) / fnorm.nn4;
    map3([0, 1, 2], |k| l[k].saturating_add(round_away(nf[k] * t)))
}

/// Newell's normal of a parent face (spec §6.6): the sum of `G_i x G_(i+1)` over its corners,
/// exact in 128 bits, then each component rounded to binary64.
pub fn newell_normal(pq: &[[i64; 3]], face: &[u32]) -> [f64; 3] {
    let n = face.len();
    let mut acc = [0i128; 3];
    for i in 0..n {
        let a = pq[face[i] as usize].map(i128::from);
        let b = pq[face[if i + 1 == n { 0 } else { i + 1 }] as usize].map(i128::from);
        acc[0] += a[1] * b[2] - a[2] * b[1];
        acc[1] += a[2] * b[0] - a[0] * b[2];
        acc[2] += a[0] * b[1] - a[1] * b[0];
    }
    map3(acc, |x| x as f64)
}

#[cfg(test)]
mod tests {
    use super::{Line, round_away, round_div};
    use crate::block::LINE_PARAM_LIMIT;

    #[test]
    fn every_line_point_has_one_parameter() {
        let normals = [[3.0, -7.0, 2.0], [0.0, 0.0, 0.0], [1e9, 1e9, -1e9], [-5.0, 0.5, 0.0], [0.0, -2.0, 2.0]];
        for (n, shift) in normals.into_iter().zip([0, 3, 0, 1, 16]) {
            let line = Line::new([10, -20, 30], n, shift);
            let top = f64::from(1u32 << shift);
            assert!(line.u.iter().any(|x| x.abs().to_bits() == top.to_bits()), "{n:?}");
            for j in (-300..300).chain([LINE_PARAM_LIMIT, -LINE_PARAM_LIMIT]) {
                let q = line.point(j);
                assert_eq!(line.param(q), Some(j), "{n:?} j {j}");
                // A point off the line has no parameter.
                let off = [q[0] + 1, q[1] + 1, q[2] + 1];
                if let Some(i) = line.param(off) {
                    assert_eq!(line.point(i), off);
                }
            }
            assert_eq!(line.param(line.point(LINE_PARAM_LIMIT + 1)), None);
        }
    }

    #[test]
    fn round_away_matches_the_library() {
        let xs =
            [0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, 0.499_999_999_999_999_94, -0.499_999_999_999_999_94, 1e15 + 0.5];
        let more = [4_503_599_627_370_495.5, 9.3e18, -9.3e18, 1e300, -1e300, f64::NAN, f64::INFINITY, 123.456, -7.7];
        for &x in xs.iter().chain(&more) {
            assert_eq!(round_away(x), x.round() as i64, "{x}");
        }
    }

    #[test]
    fn round_div_matches_the_wide_formula() {
        let wide = |a: i64, b: i64| ((2 * i128::from(a) + i128::from(b)).div_euclid(2 * i128::from(b))) as i64;
        let vals = [0i64, 1, -1, 2, -2, 3, -3, 5, -7, 1 << 28, -(1 << 28), (1 << 29) - 1, 1 << 29, 1 << 40, -(1 << 40)];
        let big = [(1i64 << 60) + 3, -(1i64 << 60) - 5, (1 << 61) - 1, 1 << 61, i64::MAX / 2, i64::MIN / 2];
        let divs = [1i64, 2, 3, 4, 5, 8, 12, 16, 1 << 28, (1 << 29) + 1, 1 << 30, 1 << 40, 1 << 60, 1 << 61, 1 << 62];
        for &a in vals.iter().chain(&big) {
            for &b in &divs {
                assert_eq!(round_div(a, b), wide(a, b), "{a} / {b}");
            }
        }
    }
}
