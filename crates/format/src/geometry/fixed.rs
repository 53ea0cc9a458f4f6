//! Geometry of mode 3 (spec §6.8 Geometry of mode 3): integer prediction from the decoded parent
//! alone, for decoding speed. A version 2 lattice level spends most of its decoder's work on rules
//! of the format itself: ranking every corner's predicted name among the sorted names of the level
//! (§5.5), binary64 predictors (§6.3, §6.6) and averaged biases of all neighbours (§6.2). Mode 3
//! keeps mode 2's face streams (child masks, depth bits, created-face keys, rotation bytes: the same
//! bits) and changes the rest:
//!
//! * **Vertices are numbered by first use** in corner order. A corner's predicted lattice key finds
//!   its vertex in a per-level open-addressing table (a lookup, no sort, no ranking); keys with
//!   several vertices are listed once (`splits`) and their corners pick one by ordinal (`choices`).
//! * **Geometry in integers from the parent alone**: a vertex with a parent context is predicted at
//!   the parent quad's bilinear point above its lattice position (the stencil of §6.3 with the
//!   quantities known from the corner's canonical position, no lattice coordinates needed), and its
//!   line runs along the parent quad's normal `(G_2 - G_0) x (G_3 - G_1)`, exact in `i64`, scaled by
//!   a power of two into a 12-bit fixed-point direction (no division). The line parameter is
//!   predicted as 0 (no neighbour averaging). A vertex without a context is predicted from the two
//!   neighbours of its first corner and lined up along its first face's axis.
//!
//! Encoder, decoder and line placement share [`fast_pass`] and [`contexts`], so they cannot
//! disagree on a prediction.

use crate::geometry::predict::GRID_LIMIT;
use crate::topology::ROTATIONS;
use crate::topology::{NO_PARENT, NO_POS, NONE};

/// Fraction bits of a mode 3 line direction (spec §6.8).
pub const DIRECTION_FRACTION_BITS: u32 = 12;

/// In-plane offsets `(u, w)` of a slot's canonical corners (spec §5.3).
pub const OFFSETS: [(u8, u8); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

/// Bilinear weights of the parent's canonical corners at stencil position `(a, b)`, `a, b` in
/// `0..3`, indexed `3 a + b` (spec §6.3's `(2-a)(2-b), a(2-b), ab, (2-a)b`).
const WEIGHTS: [[i64; 4]; 9] = {
    let mut t = [[0i64; 4]; 9];
    let mut i = 0;
    while i < 9 {
        let (a, b) = ((i / 3) as i64, (i % 3) as i64);
        t[i] = [(2 - a) * (2 - b), a * (2 - b), a * b, (2 - a) * b];
        i += 1;
    }
    t
};

/// A mode 3 prediction line (spec §6.8): the grid points
/// `base + ((j * u + 2^(F-1)) >> F)` for integer `j`, `F` = [`DIRECTION_FRACTION_BITS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedLine {
    /// The point of parameter 0.
    pub base: [i64; 3],
    /// The direction, fixed point with `F` fraction bits; its largest component has magnitude in
    /// `[2^(shift + F), 2^(shift + F + 1))`.
    pub u: [i64; 3],
}

impl FixedLine {
    /// The grid point of parameter `j` (`|j| <= 2^30`; no overflow: `|u| < 2^29`).
    #[inline]
    pub fn point(&self, j: i64) -> [i64; 3] {
        let half = 1i64 << (DIRECTION_FRACTION_BITS - 1);
        [
            self.base[0] + ((j * self.u[0] + half) >> DIRECTION_FRACTION_BITS),
            self.base[1] + ((j * self.u[1] + half) >> DIRECTION_FRACTION_BITS),
            self.base[2] + ((j * self.u[2] + half) >> DIRECTION_FRACTION_BITS),
        ]
    }

    /// The axis of the largest direction component (the first of equal ones).
    fn main_axis(&self) -> usize {
        let m = self.u.map(i64::unsigned_abs);
        if m[0] >= m[1] && m[0] >= m[2] {
            0
        } else if m[1] >= m[2] {
            1
        } else {
            2
        }
    }

    /// The parameter of grid point `q` when `q` lies on the line (`|j| <= 2^30`).
    pub fn param(&self, q: [i64; 3]) -> Option<i64> {
        let a = self.main_axis();
        let u = self.u[a];
        if u == 0 {
            return None;
        }
        // Grid coordinates and bases lie within 2^40 (far wider than the grid range), so
        // `d * 2^F` fits in an i64.
        let d = q[a].checked_sub(self.base[a]).filter(|d| d.unsigned_abs() < 1 << 40)?;
        // Near d * 2^F / u; the rounding of `point` moves it by less than one.
        let approx = (d << DIRECTION_FRACTION_BITS).div_euclid(u);
        [approx, approx + 1, approx - 1, approx + 2, approx - 2]
            .into_iter()
            .find(|&j| j.abs() <= crate::block::LINE_PARAM_LIMIT && self.point(j) == q)
    }

    /// The grid displacement of one parameter step, as binary64 (for line placement).
    pub fn unit(&self) -> [f64; 3] {
        let s = f64::from(1u32 << DIRECTION_FRACTION_BITS);
        self.u.map(|x| x as f64 / s)
    }
}

/// The mode 3 direction of normal `n` (spec §6.8): `n` scaled by a power of two so that its largest
/// component has magnitude in `[2^(shift + F), 2^(shift + F + 1))`; `(0, 0, 2^(shift + F))` for a zero
/// normal. `|n_a| < 2^62`, `shift <= 16`.
#[inline]
pub fn direction(n: [i64; 3], shift: u32) -> [i64; 3] {
    let m = n[0].unsigned_abs().max(n[1].unsigned_abs()).max(n[2].unsigned_abs());
    let top = shift + DIRECTION_FRACTION_BITS;
    if m == 0 {
        return [0, 0, 1 << top];
    }
    let len = 64 - m.leading_zeros(); // bit length, >= 1
    if len > top + 1 {
        let e = len - 1 - top;
        [n[0] >> e, n[1] >> e, n[2] >> e]
    } else {
        let e = top + 1 - len;
        [n[0] << e, n[1] << e, n[2] << e]
    }
}

/// What [`fast_pass`] predicts for one vertex: the point (base of the line) and, in a `LINES`
/// level, the line.
#[derive(Clone, Copy, Debug)]
pub struct FastPrediction {
    /// The predicted point, clamped to the grid range.
    pub point: [i64; 3],
    /// The vertex's prediction line (`LINES` levels).
    pub line: Option<FixedLine>,
    /// The predicted line parameter.
    pub param: i64,
}

/// Per vertex of a mode 3 level, what its geometry depends on (spec §6.8): its first corner, and
/// its context's parent face and stencil position (`3 a + b`).
#[derive(Clone, Debug, Default)]
pub struct Contexts {
    /// Per vertex: the first corner that uses it, or [`NONE`].
    pub first: Vec<u32>,
    /// Per vertex: the parent face of its context corner, or [`NONE`] (no context).
    pub face: Vec<u32>,
    /// Per vertex with a context: the stencil position `3 a + b` of its context corner.
    pub stencil: Vec<u8>,
}

impl Contexts {
    /// Every one of `nv` vertices without a first corner or a context.
    pub fn reset(&mut self, nv: usize) {
        self.first.clear();
        self.first.resize(nv, NONE);
        self.face.clear();
        self.face.resize(nv, NONE);
        self.stencil.clear();
        self.stencil.resize(nv, 0);
    }

    /// Bytes held.
    pub fn capacity_bytes(&self) -> usize {
        self.first.capacity() * 4 + self.face.capacity() * 4 + self.stencil.capacity()
    }
}

/// The contexts of a mode 3 level (spec §6.8): per vertex its first corner, and its first corner
/// that belongs to a subface and kept its canonical position (`pos[c] != NO_POS`), with the
/// stencil position of that corner in the parent quad. Quads only (`indices.len() = 4 faces`).
pub fn contexts(
    indices: &[u32],
    parents: &[u32],
    quadrants: &[u8],
    pos: &[u8],
    parent_rotations: &[([u32; 4], u8)],
    nv: usize,
    out: &mut Contexts,
) {
    out.reset(nv);
    for (c, &v) in indices.iter().enumerate() {
        let v = v as usize;
        if out.first[v] == NONE {
            out.first[v] = c as u32;
        }
        let s = pos[c];
        if s != NO_POS && out.face[v] == NONE {
            let f = c / 4;
            let pf = parents[f];
            debug_assert_ne!(pf, NO_PARENT);
            let corner = ROTATIONS[usize::from(parent_rotations[pf as usize].1 & 7)][usize::from(quadrants[f] & 3)];
            let (du, dw) = OFFSETS[usize::from(corner)];
            let (eu, ew) = OFFSETS[usize::from(s & 3)];
            out.face[v] = pf;
            out.stencil[v] = 3 * (du + eu) + (dw + ew);
        }
    }
}

/// Everything [`fast_pass`] reads about a mode 3 level.
pub struct FastTopo<'a> {
    /// Level index `k`.
    pub level: u32,
    /// Grid bits of the tied grid.
    pub bits: u32,
    /// Corner indices (quads: corner `c` is corner `c mod 4` of face `c / 4`).
    pub indices: &'a [u32],
    /// Per face: its lattice slot.
    pub slots: &'a [([u32; 3], u8)],
    /// Per vertex: its lattice corner.
    pub vertex_corners: &'a [[u32; 3]],
    /// Per vertex: first corner and context.
    pub contexts: &'a Contexts,
    /// Per parent face: its canonical quad (spec §5.3).
    pub parent_quads: &'a [([u32; 4], u8)],
    /// Line geometry.
    pub lines: bool,
    /// Line spacing exponent.
    pub line_shift: u32,
    /// `predictor` bit 0: 0 lines through lattice points, 1 through bilinear points.
    pub predictor: u8,
}

#[inline]
fn lattice_point(c: [u32; 3], depth: u32, bits: u32) -> [i64; 3] {
    // `(x << bits) >> depth` with one shift (x < 2^21, bits <= 28: nothing is lost).
    let at = |x: u32| {
        let x = u64::from(x);
        (if bits >= depth { x << (bits - depth) } else { x >> (depth - bits) }) as i64
    };
    [at(c[0]), at(c[1]), at(c[2])]
}

#[inline]
fn clamp(p: [i64; 3]) -> [i64; 3] {
    [p[0].clamp(-GRID_LIMIT, GRID_LIMIT), p[1].clamp(-GRID_LIMIT, GRID_LIMIT), p[2].clamp(-GRID_LIMIT, GRID_LIMIT)]
}

/// `S` of spec §6.8 (four times the bilinear point) at stencil position `stencil` (`3 a + b`) of
/// the parent quad with grid points `g`.
#[allow(clippy::inline_always)] // once per vertex in the hot loops
#[inline(always)]
fn stencil_sum(g: &[[i64; 3]; 4], stencil: u8) -> [i64; 3] {
    let w = WEIGHTS[usize::from(stencil)];
    let mut s = [0i64; 3];
    for a in 0..3 {
        s[a] = w[0] * g[0][a] + w[1] * g[1][a] + w[2] * g[2][a] + w[3] * g[3][a];
    }
    s
}

/// What every vertex of one parent face shares (spec §6.8): the line direction `u` and the
/// reciprocal `R` of the projection's denominator.
#[derive(Clone, Copy, Debug, Default)]
pub struct FaceLine {
    u: [i64; 3],
    recip: i64,
}

impl FaceLine {
    fn new(n: [i64; 3], shift: u32) -> Self {
        let u = direction(n, shift);
        // den = (4 u.u) >> F >= 2^(F + 2): |u_max| >= 2^F.
        let uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        let den = (4 * uu) >> DIRECTION_FRACTION_BITS;
        Self { u, recip: (1i64 << 62) / den }
    }
}

/// The pass A prediction of spec §6.8 for a vertex with a context: the line's origin and the
/// predicted parameter (the predicted point is [`pass_a_point`]). Predictor 0: the line through
/// the vertex's lattice point `L`, parameter of the projection of the bilinear point onto it;
/// predictor 1: the line through the bilinear point, parameter 0.
#[allow(clippy::inline_always)] // once per vertex in the hot loops
#[inline(always)]
fn pass_a(s: [i64; 3], fl: &FaceLine, corner: [u32; 3], t: &FastTopo<'_>) -> ([i64; 3], i64) {
    if t.predictor != 0 {
        return ([(s[0] + 2) >> 2, (s[1] + 2) >> 2, (s[2] + 2) >> 2], 0);
    }
    let l = lattice_point(corner, t.level, t.bits);
    let u = fl.u;
    let dot = (s[0] - 4 * l[0]) * u[0] + (s[1] - 4 * l[1]) * u[1] + (s[2] - 4 * l[2]) * u[2];
    let jp = ((i128::from(dot) * i128::from(fl.recip) + (1 << 61)) >> 62) as i64;
    (l, jp.clamp(-crate::block::LINE_PARAM_LIMIT, crate::block::LINE_PARAM_LIMIT))
}

/// The pass A prediction of vertex `v` (spec §6.8): its line's origin, predicted parameter and
/// direction (its parent face's), or `None` when `v` has no context. Shared by the decoder's loop
/// and [`fast_pass`].
#[allow(clippy::inline_always)] // once per vertex in the hot loops
#[inline(always)]
fn pass_a_vertex(t: &FastTopo<'_>, pq: &[[i64; 3]], dirs: &[FaceLine], v: usize) -> Option<([i64; 3], i64, [i64; 3])> {
    let pf = t.contexts.face[v];
    if pf == NONE {
        return None;
    }
    let quad = t.parent_quads[pf as usize].0;
    let fl = &dirs[pf as usize];
    let g = [pq[quad[0] as usize], pq[quad[1] as usize], pq[quad[2] as usize], pq[quad[3] as usize]];
    let s = stencil_sum(&g, t.contexts.stencil[v]);
    let (origin, jp) = pass_a(s, fl, t.vertex_corners[v], t);
    Some((origin, jp, fl.u))
}

/// The predicted point of a pass A vertex (spec §6.8): `clamp(line(jpred))` (the origin itself
/// under predictor 1, where `jpred = 0`).
#[allow(clippy::inline_always)] // once per vertex in the hot loops
#[inline(always)]
fn pass_a_point(origin: [i64; 3], jp: i64, u: [i64; 3]) -> [i64; 3] {
    let half = 1i64 << (DIRECTION_FRACTION_BITS - 1);
    clamp([
        origin[0] + ((jp * u[0] + half) >> DIRECTION_FRACTION_BITS),
        origin[1] + ((jp * u[1] + half) >> DIRECTION_FRACTION_BITS),
        origin[2] + ((jp * u[2] + half) >> DIRECTION_FRACTION_BITS),
    ])
}

/// The line of every parent face (spec §6.8): its canonical quad's normal, scaled.
fn parent_directions(parent_quads: &[([u32; 4], u8)], pq: &[[i64; 3]], shift: u32, dirs: &mut Vec<FaceLine>) {
    dirs.clear();
    dirs.extend(parent_quads.iter().map(|&(quad, _)| {
        let g = quad.map(|i| pq[i as usize]);
        let e1 = [g[2][0] - g[0][0], g[2][1] - g[0][1], g[2][2] - g[0][2]];
        let e2 = [g[3][0] - g[1][0], g[3][1] - g[1][1], g[3][2] - g[1][2]];
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        FaceLine::new(n, shift)
    }));
}

/// The base and line normal of a vertex without a context (spec §6.8): its lattice point moved by
/// the mean offset of the counted neighbours at its first corner, and its first face's axis.
fn no_context_base(t: &FastTopo<'_>, q: &[[i64; 3]], v: usize) -> ([i64; 3], [i64; 3]) {
    let ctx = t.contexts;
    let l = lattice_point(t.vertex_corners[v], t.level, t.bits);
    let c = ctx.first[v];
    let (mut base, mut n) = (l, [0i64; 3]);
    if c != NONE {
        let c = c as usize;
        let (f, i) = (c / 4, c % 4);
        let prev = t.indices[4 * f + (i + 3) % 4] as usize;
        let next = t.indices[4 * f + (i + 1) % 4] as usize;
        let mut sum = [0i64; 3];
        let mut m = 0;
        for u in [prev, next] {
            if ctx.face[u] != NONE || u < v {
                let lu = lattice_point(t.vertex_corners[u], t.level, t.bits);
                for a in 0..3 {
                    sum[a] += q[u][a] - lu[a];
                }
                m += 1;
            }
        }
        if m == 1 {
            base = [l[0] + sum[0], l[1] + sum[1], l[2] + sum[2]];
        } else if m == 2 {
            base = [l[0] + ((sum[0] + 1) >> 1), l[1] + ((sum[1] + 1) >> 1), l[2] + ((sum[2] + 1) >> 1)];
        }
        let side = t.slots[f].1;
        n[usize::from(side / 2)] = if side % 2 == 0 { 1 } else { -1 };
    }
    (clamp(base), n)
}

/// The decoder's form of [`fast_pass`] (the same predictions, spec §6.8), without a callback: the
/// geometry stream's values already assembled (`flags`: the line flags, empty without `LINES`;
/// `params`, `res`: zigzagged line parameters and x, y, z residuals in coding order, or by vertex
/// without `LINES`). `Err(v)`: vertex `v` decodes outside the grid range or has a line parameter
/// beyond the limit.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
pub fn decode_pass(
    t: &FastTopo<'_>,
    pq: &[[i64; 3]],
    q: &mut [[i64; 3]],
    dirs: &mut Vec<FaceLine>,
    flags: &[u8],
    params: &[u32],
    res: [&[u32]; 3],
) -> Result<(), usize> {
    let nv = q.len();
    let ctx = t.contexts;
    let lines = t.lines;
    parent_directions(t.parent_quads, pq, t.line_shift, dirs);
    let unz = |x: u32| i64::from(x >> 1) ^ -i64::from(x & 1);
    let half = 1i64 << (DIRECTION_FRACTION_BITS - 1);
    let limit = crate::block::LINE_PARAM_LIMIT;
    // Pass A, written out (no closure: its captures would live in memory).
    let mut missing = false;
    let (mut il, mut io) = (0usize, 0usize);
    let mut bad = false;
    for v in 0..nv {
        let Some((b, jp, u)) = pass_a_vertex(t, pq, dirs, v) else {
            missing = true;
            continue;
        };
        let p = if lines && flags[v / 8] >> (v % 8) & 1 == 1 {
            let j = jp + unz(params[il]);
            il += 1;
            bad |= j.abs() > limit;
            [
                b[0] + ((j * u[0] + half) >> DIRECTION_FRACTION_BITS),
                b[1] + ((j * u[1] + half) >> DIRECTION_FRACTION_BITS),
                b[2] + ((j * u[2] + half) >> DIRECTION_FRACTION_BITS),
            ]
        } else {
            let i = if lines { io } else { v };
            io += 1;
            let point = pass_a_point(b, jp, u);
            [point[0] + unz(res[0][i]), point[1] + unz(res[1][i]), point[2] + unz(res[2][i])]
        };
        bad |= p[0].abs() > GRID_LIMIT || p[1].abs() > GRID_LIMIT || p[2].abs() > GRID_LIMIT;
        if bad {
            return Err(v);
        }
        q[v] = p;
    }
    if missing {
        for v in 0..nv {
            if ctx.face[v] != NONE {
                continue;
            }
            let (base, n) = no_context_base(t, q, v);
            let p = if lines && flags[v / 8] >> (v % 8) & 1 == 1 {
                let u = direction(n, t.line_shift);
                let j = unz(params[il]);
                il += 1;
                if j.abs() > limit {
                    return Err(v);
                }
                FixedLine { base, u }.point(j)
            } else {
                let i = if lines { io } else { v };
                io += 1;
                [base[0] + unz(res[0][i]), base[1] + unz(res[1][i]), base[2] + unz(res[2][i])]
            };
            if p[0].abs() > GRID_LIMIT || p[1].abs() > GRID_LIMIT || p[2].abs() > GRID_LIMIT {
                return Err(v);
            }
            q[v] = p;
        }
    }
    Ok(())
}

/// Runs the geometry predictor of spec §6.8 over a mode 3 level in coding order (vertices with a
/// context in index order, then the others in index order), calling `step(v, prediction)` for
/// each; `step` returns the vertex's grid coordinates (within [`GRID_LIMIT`]). `pq`: the parent's
/// grid coordinates; `dirs`: scratch.
#[allow(clippy::needless_range_loop)] // vertices by index: the callback and the neighbours need it
pub fn fast_pass<E>(
    t: &FastTopo<'_>,
    pq: &[[i64; 3]],
    q: &mut [[i64; 3]],
    dirs: &mut Vec<FaceLine>,
    mut step: impl FnMut(usize, &FastPrediction) -> Result<[i64; 3], E>,
) -> Result<(), E> {
    let nv = q.len();
    let ctx = t.contexts;
    parent_directions(t.parent_quads, pq, t.line_shift, dirs);
    let mut missing = false;
    for v in 0..nv {
        let Some((base, param, u)) = pass_a_vertex(t, pq, dirs, v) else {
            missing = true;
            continue;
        };
        let point = pass_a_point(base, param, u);
        let line = if t.lines { Some(FixedLine { base, u }) } else { None };
        q[v] = step(v, &FastPrediction { point, line, param })?;
    }
    if !missing {
        return Ok(());
    }
    for v in 0..nv {
        if ctx.face[v] != NONE {
            continue;
        }
        let (base, n) = no_context_base(t, q, v);
        let line = if t.lines { Some(FixedLine { base, u: direction(n, t.line_shift) }) } else { None };
        q[v] = step(v, &FastPrediction { point: base, line, param: 0 })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{DIRECTION_FRACTION_BITS, FixedLine, direction};

    #[test]
    fn directions_are_scaled_normals() {
        for (n, shift) in [([3i64, -7, 2], 0u32), ([0, 0, 0], 3), ([1 << 58, 1 << 57, -(1 << 50)], 16), ([-5, 1, 0], 1)]
        {
            let u = direction(n, shift);
            let top = u.iter().map(|x| x.unsigned_abs()).max().unwrap();
            assert!(top >= 1 << (shift + DIRECTION_FRACTION_BITS) && top < 1 << (shift + DIRECTION_FRACTION_BITS + 1));
            // Same direction: the cross product with n vanishes up to the scaling's rounding.
            if n != [0, 0, 0] {
                let sign = |x: i64| x.signum();
                assert_eq!(u.map(sign), n.map(sign), "{n:?}");
            }
        }
    }

    #[test]
    fn every_line_point_has_one_parameter() {
        for (n, shift) in [([3i64, -7, 2], 0u32), ([0, 0, 0], 3), ([1 << 40, 1 << 40, -(1 << 40)], 0), ([-5, 1, 0], 1)]
        {
            let line = FixedLine { base: [10, -20, 30], u: direction(n, shift) };
            for j in (-300i64..300).chain([1 << 30, -(1 << 30)]) {
                let q = line.point(j);
                assert_eq!(line.param(q), Some(j), "{n:?} j {j}");
                let off = [q[0] + 1, q[1], q[2] + 1];
                if let Some(i) = line.param(off) {
                    assert_eq!(line.point(i), off);
                }
            }
        }
    }
}
