//! Quadric-error edge collapse on a triangle list, in passes.
//!
//! Sources: Garland & Heckbert, "Surface Simplification Using Quadric Error Metrics" (SIGGRAPH
//! 1997): §4 (pair contraction), §5 (quadrics, optimal placement with a fallback on the edge);
//! Dey, Edelsbrunner, Guha, Nekhayev, "Topology Preserving Edge Contraction" (1999): the link
//! condition; Kapoulkine, meshoptimizer `src/simplifier.cpp`: area-weighted quadrics normalized by
//! their weight, boundary quadrics, and collapses applied in passes over a sorted candidate list
//! with each vertex touched at most once per pass (what makes the candidate costs exact and the
//! work parallel).
//!
//! One pass: (1) every edge gets a collapse candidate (which endpoint goes, where the kept one
//! moves, the quadric error there), in parallel; (2) candidates are sorted by `(error, kept,
//! removed)`, a total order, so the result does not depend on the thread count; (3) candidates are
//! applied in order, each after the link condition, the boundary rules and the normal-flip test on
//! the current mesh, until the triangle target, the error bound, or 1.5 times the error of the
//! candidate that would reach the target (so that one pass does not spend cheap and dear collapses
//! alike). A vertex kept or removed in a pass takes no further part in that pass.

use octowrap_geom::DVec3;
use rayon::prelude::*;

use crate::quadric::Quadric;

/// What a vertex may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// One closed fan: may be removed into any neighbour, or keep and move.
    Interior,
    /// One open fan (on a boundary): removed only along a boundary edge into a border vertex.
    Border,
    /// On a boundary with `lock_border`: never moves, never removed; interior neighbours may be
    /// removed into it.
    Locked,
    /// Non-manifold, or on a non-manifold, mis-oriented or degenerate face: untouched, and no
    /// edge at it collapses, so the defect stays exactly as it was.
    Frozen,
}

/// Why decimation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stop {
    /// The face target was reached.
    TargetReached,
    /// Every remaining collapse would exceed the error bound.
    ErrorBound,
    /// No remaining collapse keeps the mesh manifold and unflipped.
    NoValidCollapse,
}

/// Vertex → incident triangles, compressed rows.
pub(crate) struct Csr {
    off: Vec<u32>,
    items: Vec<u32>,
}

impl Csr {
    pub(crate) fn build(n: usize, tris: &[[u32; 3]]) -> Self {
        let mut off = vec![0u32; n + 1];
        for t in tris {
            for &v in t {
                off[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            off[i + 1] += off[i];
        }
        let mut fill = off.clone();
        let mut items = vec![0u32; off[n] as usize];
        for (ti, t) in tris.iter().enumerate() {
            for &v in t {
                let slot = &mut fill[v as usize];
                items[*slot as usize] = ti as u32;
                *slot += 1;
            }
        }
        Self { off, items }
    }

    /// Vertex -> incident polygons of `faces` (a polygon using a vertex twice is listed twice).
    pub(crate) fn build_polygons(n: usize, faces: &octowrap_mesh::FaceList) -> Self {
        let mut off = vec![0u32; n + 1];
        for &v in faces.indices() {
            off[v as usize + 1] += 1;
        }
        for i in 0..n {
            off[i + 1] += off[i];
        }
        let mut fill = off.clone();
        let mut items = vec![0u32; off[n] as usize];
        for (fi, f) in faces.iter().enumerate() {
            for &v in f {
                let slot = &mut fill[v as usize];
                items[*slot as usize] = fi as u32;
                *slot += 1;
            }
        }
        Self { off, items }
    }

    pub(crate) fn of(&self, v: u32) -> &[u32] {
        &self.items[self.off[v as usize] as usize..self.off[v as usize + 1] as usize]
    }
}

/// Whether some triangle at `from` has the directed edge `from → to`.
fn has_half_edge(adj: &Csr, tris: &[[u32; 3]], from: u32, to: u32) -> bool {
    adj.of(from).iter().any(|&t| {
        let tri = tris[t as usize];
        (0..3).any(|k| tri[k] == from && tri[(k + 1) % 3] == to)
    })
}

/// The vertex kinds: a vertex is `Interior` or `Border` when its incident triangles are
/// non-degenerate, use every edge at the vertex at most once per direction, and form one fan.
pub(crate) fn classify(n: usize, tris: &[[u32; 3]], adj: &Csr, lock_border: bool) -> Vec<Kind> {
    (0..n as u32)
        .into_par_iter()
        .map_init(|| (Vec::new(), Vec::new()), |(link, prevs), v| vertex_kind(v, tris, adj, lock_border, link, prevs))
        .collect()
}

/// The kind of vertex `v` (see [`classify`]); `link` and `prevs` are scratch space.
fn vertex_kind(
    v: u32,
    tris: &[[u32; 3]],
    adj: &Csr,
    lock_border: bool,
    link: &mut Vec<(u32, u32)>,
    prevs: &mut Vec<u32>,
) -> Kind {
    let ts = adj.of(v);
    if ts.is_empty() {
        return Kind::Interior;
    }
    // The link of v: for each triangle, the edge next -> prev opposite v.
    let (link, prevs): (&mut Vec<(u32, u32)>, &mut Vec<u32>) = (link, prevs);
    link.clear();
    prevs.clear();
    for &t in ts {
        let tri = tris[t as usize];
        let k = tri.iter().position(|&x| x == v).unwrap_or(0);
        let (next, prev) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
        if next == v || prev == v || next == prev {
            return Kind::Frozen;
        }
        link.push((next, prev));
    }
    if link.len() <= 12 {
        return classify_small(link, lock_border);
    }
    link.sort_unstable();
    prevs.extend(link.iter().map(|e| e.1));
    prevs.sort_unstable();
    if link.windows(2).any(|w| w[0].0 == w[1].0) || prevs.windows(2).any(|w| w[0] == w[1]) {
        return Kind::Frozen;
    }
    // Paths start at link vertices with no incoming link edge.
    let mut starts = link.iter().map(|e| e.0).filter(|x| prevs.binary_search(x).is_err());
    let (first, open) = (starts.next(), starts.next());
    if open.is_some() {
        return Kind::Frozen;
    }
    let starts = first;
    let mut at = starts.unwrap_or(link[0].0);
    let mut steps = 0;
    while let Ok(i) = link.binary_search_by_key(&at, |e| e.0) {
        steps += 1;
        at = link[i].1;
        if steps > link.len() || (starts.is_none() && at == link[0].0) {
            break;
        }
    }
    match (steps == link.len(), starts.is_none()) {
        (false, _) => Kind::Frozen,
        (true, true) => Kind::Interior,
        (true, false) if lock_border => Kind::Locked,
        (true, false) => Kind::Border,
    }
}

/// [`classify`] for a small link (`next -> prev` edges), by linear scans.
fn classify_small(link: &[(u32, u32)], lock_border: bool) -> Kind {
    let n = link.len();
    let mut start = None;
    for (i, e) in link.iter().enumerate() {
        // Each link vertex starts and ends at most one link edge.
        if link[i + 1..].iter().any(|f| f.0 == e.0 || f.1 == e.1) {
            return Kind::Frozen;
        }
        if !link.iter().any(|f| f.1 == e.0) {
            if start.is_some() {
                return Kind::Frozen;
            }
            start = Some(e.0);
        }
    }
    let first = start.unwrap_or(link[0].0);
    let mut at = first;
    let mut steps = 0;
    while let Some(e) = link.iter().find(|e| e.0 == at) {
        steps += 1;
        at = e.1;
        if steps > n || (start.is_none() && at == first) {
            break;
        }
    }
    match (steps == n, start.is_none()) {
        (false, _) => Kind::Frozen,
        (true, true) => Kind::Interior,
        (true, false) if lock_border => Kind::Locked,
        (true, false) => Kind::Border,
    }
}

/// Weight of the boundary planes, relative to the squared edge length.
const BOUNDARY_WEIGHT: f64 = 2.0;

/// The area-weighted face-plane quadric of `v`, plus the plane through each boundary edge at `v`
/// perpendicular to its face.
fn vertex_quadric(v: u32, kind: Kind, pos: &[DVec3], tris: &[[u32; 3]], adj: &Csr) -> Quadric {
    // Face planes are recomputed at each of their three corners: cheaper than reading them back
    // from a per-face array that would not fit in cache.
    let plane = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| pos[i as usize]);
        let n = (b - a).cross(c - a);
        let len = n.length();
        if len > 0.0 {
            let u = n / len;
            (Quadric::plane_through(a, u, len * 0.5), u)
        } else {
            (Quadric::default(), DVec3::ZERO)
        }
    };
    let mut q = Quadric::default();
    for &t in adj.of(v) {
        let (fq, normal) = plane(&tris[t as usize]);
        q.add(&fq);
        // Only border (and frozen) vertices can lie on a boundary edge.
        if kind == Kind::Interior {
            continue;
        }
        let tri = tris[t as usize];
        for k in 0..3 {
            let (x, y) = (tri[k], tri[(k + 1) % 3]);
            if (x == v || y == v) && !has_half_edge(adj, tris, y, x) {
                let e = pos[y as usize] - pos[x as usize];
                let m = e.cross(normal).normalize_or_zero();
                if m != DVec3::ZERO {
                    q.add(&Quadric::plane_through(pos[x as usize], m, BOUNDARY_WEIGHT * e.length_squared()));
                }
            }
        }
    }
    q
}

/// [`classify`] and the vertex quadrics, in one walk over each vertex's triangles.
fn kinds_and_quadrics(pos: &[DVec3], tris: &[[u32; 3]], adj: &Csr, lock_border: bool) -> (Vec<Kind>, Vec<Quadric>) {
    (0..pos.len() as u32)
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(link, prevs), v| {
                let k = vertex_kind(v, tris, adj, lock_border, link, prevs);
                (k, vertex_quadric(v, k, pos, tris, adj))
            },
        )
        .unzip()
}

#[derive(Clone, Copy, Debug)]
struct Candidate {
    cost: f64,
    keep: u32,
    remove: u32,
    to: DVec3,
}

/// How many candidates ahead the collapse loop loads its vertices' data; their first triangles
/// are loaded half as far ahead ([`prefetch`]).
const PREFETCH: usize = 8;

/// The collapse loop is bound by memory latency (candidates come in cost order, scattered over
/// the mesh): this touches what the candidates after `order[at]` will read, so that their cache
/// misses overlap the current one's work.
fn prefetch(
    order: &[(u64, u32, u32)],
    at: usize,
    touched: &[u32],
    quadrics: &[Quadric],
    pos: &[DVec3],
    adj: &Csr,
    tris: &[[u32; 3]],
) {
    if let Some(&(_, x, y)) = order.get(at + PREFETCH) {
        let (x, y) = (x as usize, y as usize);
        std::hint::black_box((touched[x], touched[y], quadrics[x].weight(), quadrics[y].weight()));
        std::hint::black_box((pos[x].x, pos[y].x, adj.off[x], adj.off[y]));
    }
    if let Some(&(_, x, y)) = order.get(at + PREFETCH / 2) {
        for v in [x, y] {
            if let Some(&t) = adj.of(v).first() {
                std::hint::black_box(tris[t as usize][0]);
            }
        }
    }
}

/// A triangle removed during a pass (in its first corner; vertex numbers stay below `u32::MAX`).
const DEAD: u32 = u32::MAX;

/// Sort key of a half-edge that makes no candidate.
const NONE: u64 = u64::MAX;
/// Sort key of a candidate over the error bound.
const OVER: u64 = u64::MAX - 1;

/// The result of [`run`].
pub(crate) struct Outcome {
    /// The remaining triangles, over the input's vertex numbering.
    pub tris: Vec<[u32; 3]>,
    /// Positions by input vertex number (moved ones updated).
    pub pos: Vec<DVec3>,
    /// The largest error (mean squared distance) of an applied collapse.
    pub max_cost: f64,
    /// For each vertex, the surviving vertex it was collapsed into (itself when it survived or
    /// is unused).
    pub rep: Vec<u32>,
    pub collapses: usize,
    pub passes: usize,
    pub frozen: usize,
    pub stop: Stop,
}

/// Collapses edges of `tris` until at most `target` triangles remain or every collapse would cost
/// more than `max_cost`. Vertices marked in `keep` (empty: none) are treated as frozen: no edge at
/// them collapses. `progress` gets the live triangle count after each pass.
pub(crate) fn run(
    mut pos: Vec<DVec3>,
    mut tris: Vec<[u32; 3]>,
    lock_border: bool,
    keep: &[bool],
    target: usize,
    max_cost: f64,
    progress: &mut dyn FnMut(usize),
) -> Outcome {
    let n = pos.len();
    let mut adj = Csr::build(n, &tris);
    let (mut kind, mut quadrics) = kinds_and_quadrics(&pos, &tris, &adj, lock_border);
    let frozen = kind.iter().filter(|&&k| k == Kind::Frozen).count();
    for (k, _) in kind.iter_mut().zip(keep).filter(|(_, keep)| **keep) {
        *k = Kind::Frozen;
    }
    let mut rep: Vec<u32> = (0..n as u32).collect();
    let mut touched = vec![0u32; n];
    let mut scratch = Marks { mark: vec![0; n], stamp: 0 };
    let (mut reached, mut collapses, mut passes) = (0.0f64, 0usize, 0usize);
    let stop = loop {
        if tris.len() <= target {
            break Stop::TargetReached;
        }
        passes += 1;
        let pass = passes as u32;
        let mut order = edge_keys(&pos, &quadrics, &kind, &adj, &tris, max_cost);
        let over_bound = order.par_iter().any(|e| e.0 == OVER);
        order.retain(|e| e.0 < OVER);
        // The pass stops at 1.5 times the error of the candidate that would reach the target (its
        // rank found by selection), so only the candidates below that are sorted, the rest only
        // when nothing below was valid.
        let goal = (tris.len() - target).div_ceil(2);
        let mut limit =
            if goal < order.len() { f64::from_bits(order.select_nth_unstable(goal).1.0) * 1.5 } else { f64::INFINITY }
                .min(max_cost);
        let mut rest: Vec<(u64, u32, u32)> = Vec::new();
        order.retain(|e| {
            let keep = f64::from_bits(e.0) <= limit;
            if !keep {
                rest.push(*e);
            }
            keep
        });
        order.par_sort_unstable();
        let mut live = tris.len();
        let mut applied = 0;
        let mut at = 0;
        loop {
            if at == order.len() {
                // Nothing cheap was valid: take the dearer candidates rather than stop.
                if applied > 0 || rest.is_empty() {
                    break;
                }
                rest.par_sort_unstable();
                order = std::mem::take(&mut rest);
                at = 0;
                limit = max_cost;
            }
            let (bits, a, b) = order[at];
            prefetch(&order, at, &touched, &quadrics, &pos, &adj, &tris);
            at += 1;
            let cost = f64::from_bits(bits);
            if live <= target || cost > limit {
                break;
            }
            if touched[a as usize] == pass || touched[b as usize] == pass {
                continue;
            }
            // Neither end has changed since the candidate was made, so this gives it back exactly.
            let Some(c) = edge_candidate(&pos, &quadrics, &kind, &adj, &tris, a.min(b), a.max(b), false) else {
                continue;
            };
            let view = View { pos: &pos, tris: &tris, adj: &adj, kind: &kind };
            if c.keep != a || !view.can_collapse(a, b, c.to, &mut scratch) {
                continue;
            }
            for &t in adj.of(b) {
                let t = t as usize;
                if tris[t][0] == DEAD {
                    continue;
                }
                if tris[t].contains(&a) {
                    tris[t] = [DEAD; 3];
                    live -= 1;
                } else {
                    for v in &mut tris[t] {
                        if *v == b {
                            *v = a;
                        }
                    }
                }
            }
            pos[a as usize] = c.to;
            quadrics[a as usize] = quadrics[a as usize].sum(&quadrics[b as usize]);
            touched[a as usize] = pass;
            touched[b as usize] = pass;
            rep[b as usize] = a;
            reached = reached.max(cost);
            applied += 1;
        }
        collapses += applied;
        tris.retain(|t| t[0] != DEAD);
        progress(tris.len());
        if applied == 0 {
            break if over_bound { Stop::ErrorBound } else { Stop::NoValidCollapse };
        }
        adj = Csr::build(n, &tris);
    };
    resolve(&mut rep);
    Outcome { tris, pos, max_cost: reached, rep, collapses, passes, frozen, stop }
}

/// Points each removed vertex at the survivor it went into (`rep` holds the vertex each one went
/// into directly, which may have gone later).
fn resolve(rep: &mut [u32]) {
    for v in 0..rep.len() {
        let mut r = rep[v];
        while rep[r as usize] != r {
            r = rep[r as usize];
        }
        rep[v] = r;
    }
}

/// One sort key per edge: (error bits, kept, removed). Errors are >= 0, so their bit patterns
/// sort like the numbers, and (kept, removed) is unique per edge: a total order, the same
/// whatever the thread count. Half-edges that make no candidate get [`NONE`], over-bound edges
/// [`OVER`].
fn edge_keys(
    pos: &[DVec3],
    quadrics: &[Quadric],
    kind: &[Kind],
    adj: &Csr,
    tris: &[[u32; 3]],
    max_cost: f64,
) -> Vec<(u64, u32, u32)> {
    (0..tris.len() * 3)
        .into_par_iter()
        .map(|h| {
            let tri = tris[h / 3];
            let (i, j) = (tri[h % 3], tri[(h + 1) % 3]);
            match edge_candidate(pos, quadrics, kind, adj, tris, i, j, true) {
                Some(c) if c.cost <= max_cost => (c.cost.to_bits(), c.keep, c.remove),
                Some(_) => (OVER, 0, 0),
                None => (NONE, 0, 0),
            }
        })
        .collect()
}

/// The candidate of edge `i-j`. With `half_edge`, `i -> j` is a half-edge of the mesh and the
/// candidate is made only once per edge: from its half-edge with `i < j`, or from its only one.
#[allow(clippy::too_many_arguments)]
fn edge_candidate(
    pos: &[DVec3],
    quadrics: &[Quadric],
    kind: &[Kind],
    adj: &Csr,
    tris: &[[u32; 3]],
    i: u32,
    j: u32,
    half_edge: bool,
) -> Option<Candidate> {
    // A boundary edge joins two non-interior vertices: skip the search otherwise.
    let interior = kind[i as usize] == Kind::Interior || kind[j as usize] == Kind::Interior;
    let boundary = !interior && (!has_half_edge(adj, tris, i, j) || !has_half_edge(adj, tris, j, i));
    if half_edge && i > j && !boundary {
        return None;
    }
    candidate(pos, quadrics, kind, i.min(j), i.max(j), boundary)
}

/// Where the collapse of edge `i-j` (`i < j`) would put the kept vertex, and at what error.
fn candidate(pos: &[DVec3], quadrics: &[Quadric], kind: &[Kind], i: u32, j: u32, boundary: bool) -> Option<Candidate> {
    use Kind::{Border, Interior, Locked};
    let (ki, kj) = (kind[i as usize], kind[j as usize]);
    // May x be removed into y?
    let can = |x: Kind, y: Kind| match (x, y) {
        (Interior, Interior | Border | Locked) => true,
        (Border, Border | Locked) => boundary,
        _ => false,
    };
    let (pi, pj) = (pos[i as usize], pos[j as usize]);
    let q = quadrics[i as usize].sum(&quadrics[j as usize]);
    let (keep, remove, to) = match (can(ki, kj), can(kj, ki)) {
        (true, true) => {
            let to = if ki == Interior {
                q.optimum()
                    .filter(|p| p.distance(0.5 * (pi + pj)) <= pi.distance(pj))
                    .unwrap_or_else(|| q.segment_optimum(pi, pj))
            } else {
                q.segment_optimum(pi, pj)
            };
            (i.min(j), i.max(j), to)
        }
        (true, false) => (j, i, pj),
        (false, true) => (i, j, pi),
        (false, false) => return None,
    };
    let cost = q.error(to);
    cost.is_finite().then_some(Candidate { cost, keep, remove, to })
}

/// Per-vertex stamps for the neighbourhood tests (reset when the stamp would wrap).
struct Marks {
    mark: Vec<u32>,
    stamp: u32,
}

impl Marks {
    fn next(&mut self) -> u32 {
        if self.stamp > u32::MAX - 8 {
            self.mark.fill(0);
            self.stamp = 0;
        }
        self.stamp += 3;
        self.stamp
    }
}

/// The mesh during a pass.
struct View<'a> {
    pos: &'a [DVec3],
    tris: &'a [[u32; 3]],
    adj: &'a Csr,
    kind: &'a [Kind],
}

impl View<'_> {
    fn live(&self, v: u32) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.adj.of(v).iter().map(|&t| self.tris[t as usize]).filter(|t| t[0] != DEAD)
    }

    /// Whether removing `b` into `a` (moved to `to`) keeps the mesh manifold and unflipped: the
    /// edge has one or two triangles with distinct apexes; the common neighbours of `a` and `b`
    /// are exactly those apexes (the link condition); two border vertices join only along a
    /// boundary edge; the joined vertex keeps at least 3 neighbours (2 on a border), so no
    /// component shrinks to a double-sided sliver; no surviving triangle around `a` or `b` turns
    /// its normal by 90 degrees or more.
    fn can_collapse(&self, a: u32, b: u32, to: DVec3, marks: &mut Marks) -> bool {
        let flips = |v: u32, tri: [u32; 3]| {
            let p = |i: u32| self.pos[i as usize];
            let (x, y, z) = (p(tri[0]), p(tri[1]), p(tri[2]));
            let before = (y - x).cross(z - x);
            let q = |i: u32| if i == v { to } else { p(i) };
            let (x, y, z) = (q(tri[0]), q(tri[1]), q(tri[2]));
            let after = (y - x).cross(z - x);
            before != DVec3::ZERO && before.dot(after) <= 1e-4 * before.length() * after.length()
        };
        let moves_a = to != self.pos[a as usize];
        let s = marks.next();
        let mark = &mut marks.mark;
        let mut shared = 0usize;
        let mut apex = [u32::MAX; 2];
        let mut degree = 0usize;
        // One walk around b: the edge's triangles, b's neighbours, and flips of b's other faces.
        for tri in self.live(b) {
            if tri.contains(&a) {
                if shared < 2 {
                    apex[shared] = tri.into_iter().find(|&v| v != a && v != b).unwrap_or(u32::MAX);
                }
                shared += 1;
            } else if flips(b, tri) {
                return false;
            }
            for v in tri {
                if v != b && v != a && mark[v as usize] != s {
                    mark[v as usize] = s;
                    degree += 1;
                }
            }
        }
        if shared == 0 || shared > 2 || (shared == 2 && apex[0] == apex[1]) {
            return false;
        }
        let (ka, kb) = (self.kind[a as usize], self.kind[b as usize]);
        let border = ka != Kind::Interior || kb != Kind::Interior;
        if ka != Kind::Interior && kb != Kind::Interior && shared != 1 {
            return false;
        }
        // One walk around a: common neighbours (the link condition) and flips of a's other faces.
        let mut common = 0usize;
        for tri in self.live(a) {
            if moves_a && !tri.contains(&b) && flips(a, tri) {
                return false;
            }
            for v in tri {
                if v == a || v == b {
                    continue;
                }
                let m = &mut mark[v as usize];
                if *m == s {
                    if !apex.contains(&v) {
                        return false;
                    }
                    *m = s + 1;
                    common += 1;
                } else if *m != s + 1 && *m != s + 2 {
                    *m = s + 2;
                    degree += 1;
                }
            }
        }
        common == shared && degree >= if border { 2 } else { 3 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_of_a_fan_a_strip_and_a_bowtie() {
        // A closed fan around 0 (a pyramid seen from the apex) is interior at 0.
        let tris = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        let adj = Csr::build(5, &tris);
        let k = classify(5, &tris, &adj, false);
        assert_eq!(k[0], Kind::Interior);
        assert_eq!(k[1], Kind::Border);
        assert_eq!(classify(5, &tris, &adj, true)[1], Kind::Locked);
        // Two triangles touching at vertex 0 only: a bow-tie, frozen.
        let bow = [[0, 1, 2], [0, 3, 4]];
        let adj = Csr::build(5, &bow);
        assert_eq!(classify(5, &bow, &adj, false)[0], Kind::Frozen);
        // A flipped neighbour: edge 0-1 used twice in the same direction.
        // Valence 20 (the sorted path): a closed fan is interior, an open one border, two closed
        // fans sharing the centre frozen.
        let fan = |first: u32, n: u32, closed: bool| -> Vec<[u32; 3]> {
            (0..n).filter(|&i| closed || i + 1 < n).map(|i| [0, first + i, first + (i + 1) % n]).collect()
        };
        let closed = fan(1, 20, true);
        let adj = Csr::build(41, &closed);
        assert_eq!(classify(41, &closed, &adj, false)[0], Kind::Interior);
        let open = fan(1, 20, false);
        let adj = Csr::build(41, &open);
        assert_eq!(classify(41, &open, &adj, false)[0], Kind::Border);
        let mut two = fan(1, 20, true);
        two.extend(fan(21, 20, true));
        let adj = Csr::build(41, &two);
        assert_eq!(classify(41, &two, &adj, false)[0], Kind::Frozen);
        let flip = [[0, 1, 2], [0, 1, 3]];
        let adj = Csr::build(4, &flip);
        assert_eq!(classify(4, &flip, &adj, false)[0], Kind::Frozen);
    }
}
