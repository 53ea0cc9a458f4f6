//! Spec §6.8: the geometry of mode 3, read straight through.

use super::block::{BlockHeader, FileContext};
use super::geometry::{Line, Values};
use super::primitives::{Result, bit_len, clamp3};
use super::topology::{Level, OFF, Topology, corner_list, pos};

/// `F`: fraction bits of a direction.
const F: u32 = 12;

/// `dir(n)` with `T = line_shift + F`.
fn dir(n: [i64; 3], t: u32) -> [i64; 3] {
    let m = n.iter().map(|x| x.unsigned_abs()).max().expect("three components");
    if m == 0 {
        return [0, 0, 1 << t];
    }
    let len = bit_len(m);
    if len > t + 1 { n.map(|x| x >> (len - 1 - t)) } else { n.map(|x| x << (t + 1 - len)) }
}

/// The lattice point `(c << grid_bits) >> k` of a lattice corner.
fn lattice_point(c: [u32; 3], k: usize, bits: u32) -> [i64; 3] {
    c.map(|x| ((u64::from(x) << bits) >> k) as i64)
}

pub fn decode(
    k: usize,
    h: &BlockHeader,
    file: FileContext,
    topo: &Topology,
    parent: &Level,
    values: &mut Values,
) -> Result<Vec<[i64; 3]>> {
    let nv = topo.vertex_count;
    let level = &topo.level;
    let t = h.line_shift + F;
    let vc = level.vertex_corners.as_ref().expect("mode 3 has lattice corners");
    let corners = corner_list(&level.faces);
    // Context: the first corner that resolved to v, is no exception and lies in a subface; its
    // parent face and stencil position (a, b). The first corner of every vertex.
    let mut context: Vec<Option<(usize, usize, usize)>> = vec![None; nv];
    let mut first: Vec<Option<usize>> = vec![None; nv];
    for (c, &(f, i)) in corners.iter().enumerate() {
        let v = level.faces[f][i] as usize;
        if first[v].is_none() {
            first[v] = Some(c);
        }
        if let (None, Some((p, q)), Some(s)) = (context[v], level.origins[f], topo.pos[c]) {
            let tt = pos(topo.parent_quads[p as usize].1, usize::from(q));
            let a = OFF[tt].0 + OFF[usize::from(s)].0;
            let b = OFF[tt].1 + OFF[usize::from(s)].1;
            context[v] = Some((p as usize, a as usize, b as usize));
        }
    }
    // Directions: per parent face, u and R.
    let directions: Vec<([i64; 3], i128)> = topo
        .parent_quads
        .iter()
        .map(|&(quad, _)| {
            let g = quad.map(|i| parent.q[i as usize]);
            let e1 = [g[2][0] - g[0][0], g[2][1] - g[0][1], g[2][2] - g[0][2]];
            let e2 = [g[3][0] - g[1][0], g[3][1] - g[1][1], g[3][2] - g[1][2]];
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let u = dir(n, t);
            let den = (4 * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2])) >> F;
            (u, (1i128 << 62) / i128::from(den))
        })
        .collect();
    let mut q = vec![[0i64; 3]; nv];
    // Pass A: vertices with a context, in increasing index order.
    for v in 0..nv {
        let Some((p, a, b)) = context[v] else { continue };
        let quad = topo.parent_quads[p].0;
        let g = quad.map(|i| parent.q[i as usize]);
        let (u, r) = directions[p];
        let (a, b) = (a as i64, b as i64);
        let w = [(2 - a) * (2 - b), a * (2 - b), a * b, (2 - a) * b];
        let s: [i64; 3] = [0, 1, 2].map(|x| (0..4).map(|i| w[i] * g[i][x]).sum());
        let l = lattice_point(vc[v], k, file.grid_bits);
        let (origin, jpred) = if h.predictor == 1 {
            (s.map(|x| (x + 2) >> 2), 0)
        } else {
            let dot: i64 = (0..3).map(|x| (s[x] - 4 * l[x]) * u[x]).sum();
            let j = (i128::from(dot) * r + (1i128 << 61)) >> 62;
            (l, j.clamp(-(1 << 30), 1 << 30) as i64)
        };
        let line = Line::Fixed { origin, u };
        let point = clamp3(line.point(jpred));
        q[v] = values.decode_vertex(v, point, h.lines.then_some(&line), jpred)?.0;
    }
    // Pass B: the others, in increasing index order.
    for v in 0..nv {
        if context[v].is_some() {
            continue;
        }
        let l = lattice_point(vc[v], k, file.grid_bits);
        let (origin, n) = match first[v] {
            None => (l, [0i64; 3]),
            Some(c) => {
                let (f, i) = corners[c];
                let face = &level.faces[f];
                let (x, y) = (face[(i + 3) % 4] as usize, face[(i + 1) % 4] as usize);
                let counting: Vec<usize> = [x, y].into_iter().filter(|&w| context[w].is_some() || w < v).collect();
                let mut d = [0i64; 3];
                for &w in &counting {
                    let lw = lattice_point(vc[w], k, file.grid_bits);
                    d = [0, 1, 2].map(|x| d[x] + q[w][x] - lw[x]);
                }
                let origin = match counting.len() {
                    0 => l,
                    1 => [0, 1, 2].map(|x| l[x] + d[x]),
                    _ => [0, 1, 2].map(|x| l[x] + ((d[x] + 1) >> 1)),
                };
                let side = level.slots.as_ref().expect("mode 3 has slots")[f].1;
                let mut n = [0i64; 3];
                n[usize::from(side / 2)] = if side % 2 == 0 { 1 } else { -1 };
                (origin, n)
            }
        };
        let origin = clamp3(origin);
        let line = Line::Fixed { origin, u: dir(n, t) };
        q[v] = values.decode_vertex(v, origin, h.lines.then_some(&line), 0)?.0;
    }
    Ok(q)
}
