//! Spec §6.1-§6.7: the `geometry` stream, and the geometry of modes 0, 1 and 2 (two passes,
//! the lattice, subdivision and neighbour predictors, line geometry). Mode 3 is in `geometry3`.

use super::block::{BlockHeader, FileContext};
use super::geometry3;
use super::primitives::{
    GRID, Result, Stream, clamp3, cross128, require, round_away, round_div, sub3, three_times_saturated, to_f64,
    unzigzag, wide,
};
use super::topology::{Level, Topology, axes, canonical_corners, corner_list};
use super::values;

/// A vertex's line (§6.6 for modes 1 and 2, §6.8 for mode 3): its point of parameter `j`.
pub enum Line {
    /// §6.6: `base + round_away(to_f64(j) * u)`.
    Float { base: [i64; 3], u: [f64; 3] },
    /// §6.8: `O + ((j u + 2^(F-1)) >> F)`.
    Fixed { origin: [i64; 3], u: [i64; 3] },
}

impl Line {
    pub fn point(&self, j: i64) -> [i64; 3] {
        match self {
            Line::Float { base, u } => {
                let mut out = [0i64; 3];
                for a in 0..3 {
                    let step = round_away(to_f64(i128::from(j)) * u[a]);
                    out[a] = i64::try_from(i128::from(base[a]) + i128::from(step)).unwrap_or(i64::MAX);
                }
                out
            }
            Line::Fixed { origin, u } => {
                let mut out = [0i64; 3];
                for a in 0..3 {
                    out[a] = origin[a] + ((j * u[a] + (1 << 11)) >> 12);
                }
                out
            }
        }
    }
}

/// §6.1: the grid layout of the `geometry` stream, consumed vertex by vertex.
pub struct Values {
    lines: bool,
    flags: Vec<u8>,
    params: Vec<u64>,
    residuals: [Vec<u64>; 3],
    next_param: usize,
    next_residual: usize,
}

impl Values {
    /// `coded`: mode 3 of a version 4 file, whose value sequences are value blocks (§6.9).
    fn read(g: &mut Stream<'_>, nv: usize, lines: bool, coded: bool) -> Result<Self> {
        let mut flags = Vec::new();
        let mut n_lines = 0;
        if lines {
            flags = g.bytes(nv.div_ceil(8))?.to_vec();
            require(nv % 8 == 0 || flags[nv / 8] >> (nv % 8) == 0, || "unused line flag bits".into())?;
            n_lines = (0..nv).filter(|&v| flags[v / 8] >> (v % 8) & 1 == 1).count();
        }
        let mut block = |n: usize| if coded { values::read(g, n) } else { g.plane_block(n, 4) };
        let params = if lines { block(n_lines)? } else { Vec::new() };
        let residuals = [block(nv - n_lines)?, block(nv - n_lines)?, block(nv - n_lines)?];
        Ok(Self { lines, flags, params, residuals, next_param: 0, next_residual: 0 })
    }

    pub fn is_line_vertex(&self, v: usize) -> bool {
        self.lines && self.flags[v / 8] >> (v % 8) & 1 == 1
    }

    /// §6.1 "Decoding a vertex": its grid coordinates and, for a line vertex, its parameter.
    pub fn decode_vertex(
        &mut self,
        v: usize,
        point: [i64; 3],
        line: Option<&Line>,
        jpred: i64,
    ) -> Result<([i64; 3], Option<i64>)> {
        let (q, j) = if self.is_line_vertex(v) {
            let value = self.params[self.next_param];
            self.next_param += 1;
            let j = i128::from(jpred) + i128::from(unzigzag(value));
            require(j.abs() <= 1 << 30, || format!("vertex {v}: line parameter {j}"))?;
            let j = j as i64;
            (line.expect("every vertex of a LINES level has a line").point(j), Some(j))
        } else {
            let i = if self.lines { self.next_residual } else { v };
            self.next_residual += 1;
            let r = [0, 1, 2].map(|a| unzigzag(self.residuals[a][i]));
            ([0, 1, 2].map(|a| point[a] + r[a]), None)
        };
        require(q.iter().all(|x| x.abs() <= GRID), || format!("vertex {v} outside the grid range"))?;
        Ok((q, j))
    }
}

/// §6: the positions of a level whose topology is decoded.
pub fn decode(
    k: usize,
    h: &BlockHeader,
    file: FileContext,
    g: &mut Stream<'_>,
    topo: Topology,
    parent: Option<&Level>,
) -> Result<Level> {
    let nv = topo.vertex_count;
    if file.exact {
        // §6.1, exact files.
        let planes = [g.plane_block(nv, 8)?, g.plane_block(nv, 8)?, g.plane_block(nv, 8)?];
        let mut level = topo.level;
        level.exact = (0..nv).map(|v| [0, 1, 2].map(|a| f64::from_bits(planes[a][v]))).collect();
        require(level.exact.iter().flatten().all(|x| x.is_finite()), || "a coordinate is not finite".into())?;
        return Ok(level);
    }
    let mut values = Values::read(g, nv, h.lines, h.mode == 3 && file.version >= 4)?;
    let q = if h.mode == 3 {
        geometry3::decode(k, h, file, &topo, parent.expect("mode 3 has a parent"), &mut values)?
    } else {
        two_passes(k, h, file, &topo, parent, &mut values)?
    };
    let mut level = topo.level;
    level.q = q;
    Ok(level)
}

/// §6.2: contexts and passes of modes 0, 1 and 2.
fn two_passes(
    k: usize,
    h: &BlockHeader,
    file: FileContext,
    topo: &Topology,
    parent: Option<&Level>,
    values: &mut Values,
) -> Result<Vec<[i64; 3]>> {
    let passes = TwoPasses::new(k, h, file, topo, parent);
    let nv = topo.vertex_count;
    let mut decoded = Decoded { q: vec![[0i64; 3]; nv], base: vec![[0i64; 3]; nv], param: vec![None; nv] };
    for v in 0..nv {
        if passes.context[v].is_some() {
            passes.pass_a(v, values, &mut decoded)?;
        }
    }
    for v in 0..nv {
        if passes.context[v].is_none() {
            passes.pass_b(v, values, &mut decoded)?;
        }
    }
    Ok(decoded.q)
}

/// What §6.2's passes have decoded so far, per vertex: its grid point, its prediction base and its
/// line parameter.
struct Decoded {
    q: Vec<[i64; 3]>,
    base: Vec<[i64; 3]>,
    param: Vec<Option<i64>>,
}

/// A level's vertices as §6.2's passes see them: contexts and neighbour entries.
struct TwoPasses<'a> {
    k: usize,
    h: &'a BlockHeader,
    file: FileContext,
    topo: &'a Topology,
    parent: Option<&'a Level>,
    corners: Vec<(usize, usize)>,
    /// Per vertex, its context: the first corner in level order that resolved to the vertex,
    /// belongs to a subface and has a canonical position.
    context: Vec<Option<usize>>,
    /// Per vertex, per corner of it: (previous, next).
    neighbours: Vec<Vec<(usize, usize)>>,
}

impl<'a> TwoPasses<'a> {
    fn new(k: usize, h: &'a BlockHeader, file: FileContext, topo: &'a Topology, parent: Option<&'a Level>) -> Self {
        let nv = topo.vertex_count;
        let level = &topo.level;
        let corners = corner_list(&level.faces);
        let mut context: Vec<Option<usize>> = vec![None; nv];
        if h.mode != 0 {
            for (c, &(f, i)) in corners.iter().enumerate() {
                let v = level.faces[f][i] as usize;
                if context[v].is_none() && level.origins[f].is_some() && topo.pos[c].is_some() {
                    context[v] = Some(c);
                }
            }
        }
        let mut neighbours: Vec<Vec<(usize, usize)>> = vec![Vec::new(); nv];
        for face in &level.faces {
            let n = face.len();
            for i in 0..n {
                neighbours[face[i] as usize].push((face[(i + n - 1) % n] as usize, face[(i + 1) % n] as usize));
            }
        }
        Self { k, h, file, topo, parent, corners, context, neighbours }
    }

    /// The neighbour entries of `v`, both of each pair.
    fn entries(&self, v: usize) -> impl Iterator<Item = usize> + '_ {
        self.neighbours[v].iter().flat_map(|&(a, b)| [a, b])
    }

    /// Pass A for vertex `v`, which has a context.
    fn pass_a(&self, v: usize, values: &mut Values, d: &mut Decoded) -> Result<()> {
        let (h, topo) = (self.h, self.topo);
        let c = self.context[v].expect("pass A takes vertices with a context");
        let (f, _) = self.corners[c];
        let (p, quadrant) = topo.level.origins[f].expect("a context lies in a subface");
        let parent = self.parent.expect("a context has a parent");
        // Step 1: P from §6.4 or §6.3.
        let p_pred = if h.mode == 1 {
            subdivision_predictor(parent, p as usize, usize::from(quadrant), topo.pos[c].expect("context"))
        } else {
            lattice_predictor(self.k, h, self.file, topo, parent, p as usize, v)
        };
        d.base[v] = clamp3(p_pred);
        // Step 2: the local bias of counting entries.
        let counting: Vec<usize> = self.entries(v).filter(|&u| u < v && self.context[u].is_some()).collect();
        let point = if counting.is_empty() {
            clamp3(d.base[v])
        } else {
            let m = counting.len() as i128;
            clamp3([0, 1, 2].map(|a| {
                let sum: i128 = counting.iter().map(|&u| i128::from(d.q[u][a] - d.base[u][a])).sum();
                d.base[v][a] + round_div(three_times_saturated(sum), 4 * m)
            }))
        };
        // Step 3: the line (§6.6, pass A).
        let (line, jpred) = if h.lines { self.pass_a_line(v, p as usize, values, d) } else { (None, 0) };
        // Step 4.
        (d.q[v], d.param[v]) = values.decode_vertex(v, point, line.as_ref(), jpred)?;
        Ok(())
    }

    /// §6.6, pass A: the line of vertex `v` under parent face `p`, and its parameter's prediction.
    fn pass_a_line(&self, v: usize, p: usize, values: &Values, d: &Decoded) -> (Option<Line>, i64) {
        let parent = self.parent.expect("a context has a parent");
        let normal =
            if self.h.mode == 1 { newell_normal(parent, p) } else { quad_normal(parent, self.topo.parent_quads[p].0) };
        let line = Line::Float { base: d.base[v], u: direction(normal.map(to_f64), self.h.line_shift) };
        let js: Vec<i64> = self
            .entries(v)
            .filter(|&u| u < v && self.context[u].is_some() && values.is_line_vertex(u))
            .map(|u| d.param[u].expect("decoded in pass A"))
            .collect();
        let jpred = if js.is_empty() {
            0
        } else {
            let sum: i128 = js.iter().map(|&j| i128::from(j)).sum();
            round_div(three_times_saturated(sum), 4 * js.len() as i128)
        };
        (Some(line), jpred)
    }

    /// The lattice point of vertex `v` (mode 2), the origin otherwise.
    fn lattice_point(&self, v: usize) -> [i64; 3] {
        match &self.topo.level.vertex_corners {
            Some(vc) if self.h.mode == 2 => vc[v].map(|x| ((u64::from(x) << self.file.grid_bits) >> self.k) as i64),
            _ => [0; 3],
        }
    }

    /// Pass B for vertex `v`, which has no context.
    fn pass_b(&self, v: usize, values: &mut Values, d: &mut Decoded) -> Result<()> {
        let h = self.h;
        let q = &d.q;
        // Step 1: §6.5.
        let counts = |u: usize| self.context[u].is_some() || u < v;
        let counting: Vec<usize> = self.entries(v).filter(|&u| counts(u)).collect();
        let lv = self.lattice_point(v);
        let pred = if !counting.is_empty() {
            let m = counting.len() as i128;
            [0, 1, 2].map(|a| {
                let sum: i128 = counting.iter().map(|&u| i128::from(q[u][a] - self.lattice_point(u)[a])).sum();
                lv[a] + round_div(sum, m)
            })
        } else if h.mode == 2 {
            lv
        } else if v > 0 {
            q[v - 1]
        } else {
            [0; 3]
        };
        let b = clamp3(pred);
        // Step 2: the line (§6.6, pass B): the fan of counting neighbours around `b`.
        let line = h.lines.then(|| {
            let mut n = [0i128; 3];
            for &(a, c) in &self.neighbours[v] {
                if counts(a) && counts(c) {
                    let f = cross128(wide(sub3(q[c], b)), wide(sub3(q[a], b)));
                    n = [n[0] + f[0], n[1] + f[1], n[2] + f[2]];
                }
            }
            Line::Float { base: b, u: direction(n.map(to_f64), h.line_shift) }
        });
        // Step 3.
        (d.q[v], d.param[v]) = values.decode_vertex(v, b, line.as_ref(), 0)?;
        Ok(())
    }
}

/// §6.3: the lattice predictors of mode 2 for vertex `v` under parent face `p`.
fn lattice_predictor(
    k: usize,
    h: &BlockHeader,
    file: FileContext,
    topo: &Topology,
    parent: &Level,
    p: usize,
    v: usize,
) -> [i64; 3] {
    let (vp, d) = parent.slots.as_ref().expect("lattice parent")[p];
    let sc0 = canonical_corners(vp, d)[0];
    let quad = topo.parent_quads[p].0;
    let g = quad.map(|i| parent.q[i as usize]);
    let c = topo.level.vertex_corners.as_ref().expect("lattice level")[v];
    let (u, w) = axes(d);
    let a = (i64::from(c[u]) - 2 * i64::from(sc0[u])).clamp(0, 2);
    let b = (i64::from(c[w]) - 2 * i64::from(sc0[w])).clamp(0, 2);
    let weights = [(2 - a) * (2 - b), a * (2 - b), a * b, (2 - a) * b];
    let s: [i128; 3] = [0, 1, 2].map(|x| (0..4).map(|i| i128::from(weights[i] * g[i][x])).sum());
    let l: [i64; 3] = c.map(|x| ((u64::from(x) << file.grid_bits) >> k) as i64);
    let n = quad_normal(parent, quad);
    let dd: [i128; 3] = [0, 1, 2].map(|x| s[x] - 4 * i128::from(l[x]));
    let nf = n.map(to_f64);
    let df = dd.map(to_f64);
    let nn = (nf[0] * nf[0] + nf[1] * nf[1]) + nf[2] * nf[2];
    if h.predictor == 1 || nn == 0.0 {
        return s.map(|x| round_div(x, 4));
    }
    let t = ((nf[0] * df[0] + nf[1] * df[1]) + nf[2] * df[2]) / (4.0 * nn);
    [0, 1, 2].map(|x| l[x].saturating_add(round_away(nf[x] * t)))
}

/// §6.3: `n = (G_2 - G_0) x (G_3 - G_1)` of a canonical quad.
fn quad_normal(parent: &Level, quad: [u32; 4]) -> [i128; 3] {
    let g = quad.map(|i| wide(parent.q[i as usize]));
    let e1 = [g[2][0] - g[0][0], g[2][1] - g[0][1], g[2][2] - g[0][2]];
    let e2 = [g[3][0] - g[1][0], g[3][1] - g[1][1], g[3][2] - g[1][2]];
    cross128(e1, e2)
}

/// §6.4: the subdivision predictor of mode 1.
fn subdivision_predictor(parent: &Level, p: usize, q: usize, s: u8) -> [i64; 3] {
    let face = &parent.faces[p];
    let n = face.len();
    let g = |j: usize| wide(parent.q[face[j % n] as usize]);
    let two = |x: [i128; 3], y: [i128; 3]| [0, 1, 2].map(|a| round_div(x[a] + y[a], 2));
    match s {
        0 => parent.q[face[q] as usize],
        1 => two(g(q), g(q + 1)),
        2 => [0, 1, 2].map(|a| round_div((0..n).map(|j| g(j)[a]).sum(), n as i128)),
        _ => two(g(q + n - 1), g(q)),
    }
}

/// §6.6: Newell's normal of parent face `p`.
fn newell_normal(parent: &Level, p: usize) -> [i128; 3] {
    let face = &parent.faces[p];
    let n = face.len();
    let mut out = [0i128; 3];
    for i in 0..n {
        let c = cross128(wide(parent.q[face[i] as usize]), wide(parent.q[face[(i + 1) % n] as usize]));
        out = [out[0] + c[0], out[1] + c[1], out[2] + c[2]];
    }
    out
}

/// §6.6: the direction `u` of a normal.
fn direction(nf: [f64; 3], line_shift: u32) -> [f64; 3] {
    let m = nf[0].abs().max(nf[1].abs()).max(nf[2].abs());
    let scale = to_f64(1i128 << line_shift);
    if m == 0.0 {
        return [0.0, 0.0, scale];
    }
    nf.map(|x| (x / m) * scale)
}
