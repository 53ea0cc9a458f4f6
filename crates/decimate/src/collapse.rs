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
//! moves, the quadric error there), in parallel; (2) the pass's error limit is 1.5 times the error
//! of the candidate that would reach the triangle target (its rank found by a histogram and a
//! selection), so that one pass does not spend cheap and dear collapses alike; (3) candidates
//! under the limit are applied in order of `(error, kept, removed)`, a total order, each after the
//! link condition, the boundary rules and the normal-flip test on the current mesh, until the
//! triangle target or the limit. A vertex kept or removed in a pass takes no further part in it.
//!
//! Step (3) runs mostly in parallel: vertices, numbered in Morton
//! order, are cut into blocks of consecutive numbers (compact regions of the surface, whose data
//! stays in a core's cache), triangles are grouped by the block of their lowest vertex, and a
//! collapse whose two vertices have all their triangles in one block reads and writes only that
//! block's data. Those collapses run block by block in parallel, each block's in cost order, as
//! long as they cannot reach the target (each removes at most two triangles: only the cheapest
//! candidates are taken when the target is near); the others then follow in cost order over the
//! whole mesh. The blocks depend on the vertex count only, so the result is the same, bit for bit,
//! whatever the thread count.

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

    /// [`Csr::build`] of `tris` grouped by the block of their lowest vertex (block `k`'s from
    /// `start[k]` on), in parallel over the blocks. A triangle's vertices are in its block or a
    /// later one, so a vertex's row holds the triangles of earlier blocks (few, added first, in
    /// order) and then those of its own block: the rows come out as [`Csr::build`] makes them.
    fn build_blocked(n: usize, tris: &[[u32; 3]], start: &[u32], blocks: Blocks) -> Self {
        let len = blocks.len();
        let range = |k: usize| start[k] as usize..start[k + 1] as usize;
        let own = |k: usize, v: u32| blocks.of(v) == k;
        // Own-block corners counted per block; corners in later blocks listed, in triangle order.
        let mut off = vec![0u32; n + 1];
        let foreign: Vec<Vec<(u32, u32)>> = off[1..]
            .par_chunks_mut(len)
            .enumerate()
            .map(|(k, counts)| {
                let mut foreign = Vec::new();
                for (t, tri) in tris[range(k)].iter().enumerate() {
                    for &v in tri {
                        if own(k, v) {
                            counts[v as usize - k * len] += 1;
                        } else {
                            foreign.push((v, (start[k] as usize + t) as u32));
                        }
                    }
                }
                foreign
            })
            .collect();
        for &(v, _) in foreign.iter().flatten() {
            off[v as usize + 1] += 1;
        }
        for i in 0..n {
            off[i + 1] += off[i];
        }
        let mut fill = off.clone();
        let mut items = vec![0u32; off[n] as usize];
        for &(v, t) in foreign.iter().flatten() {
            let slot = &mut fill[v as usize];
            items[*slot as usize] = t;
            *slot += 1;
        }
        let mut rows: Vec<&mut [u32]> = Vec::with_capacity(blocks.count);
        let mut rest = &mut items[..];
        for k in 0..n.div_ceil(len) {
            let (lo, hi) = (off[k * len], off[((k + 1) * len).min(n)]);
            let (mine, after) = std::mem::take(&mut rest).split_at_mut((hi - lo) as usize);
            rows.push(mine);
            rest = after;
        }
        fill[..n].par_chunks_mut(len).zip(rows).enumerate().for_each(|(k, (fill, rows))| {
            let base = off[k * len];
            for (t, tri) in tris[range(k)].iter().enumerate() {
                for &v in tri {
                    if own(k, v) {
                        let slot = &mut fill[v as usize - k * len];
                        rows[(*slot - base) as usize] = (start[k] as usize + t) as u32;
                        *slot += 1;
                    }
                }
            }
        });
        Self { off, items }
    }

    pub(crate) fn of(&self, v: u32) -> &[u32] {
        &self.items[self.off[v as usize] as usize..self.off[v as usize + 1] as usize]
    }
}

/// Whether some triangle at `from` has the directed edge `from → to`. Such a triangle is in the
/// lists of both ends, so the shorter is searched: next to a vertex of valence `k` (thousands of
/// zero-area faces gathered into one vertex) each search is then `O(1)` instead of `O(k)`. Both
/// ends' lists hold every triangle with both ends as corners while neither end has been touched
/// in the pass (a collapse gives a triangle a new corner only in the kept vertex), which is when
/// the collapse loop asks.
fn has_half_edge<T: Tris + ?Sized>(adj: &Csr, tris: &T, from: u32, to: u32) -> bool {
    let (a, b) = (adj.of(from), adj.of(to));
    let shorter = if b.len() < a.len() { b } else { a };
    shorter.iter().any(|&t| {
        let tri = tris.tri(t);
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
        // Only border (and frozen) vertices can lie on a boundary edge, and a degenerate face
        // (no normal) gives its boundary edges no plane: skip the search for the opposite side,
        // whose cost grows with the valence (a vertex gathering thousands of zero-area faces).
        if kind == Kind::Interior || normal == DVec3::ZERO {
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

/// Triangles by their number.
trait Tris {
    fn tri(&self, t: u32) -> [u32; 3];
}

impl Tris for [[u32; 3]] {
    #[inline]
    fn tri(&self, t: u32) -> [u32; 3] {
        self[t as usize]
    }
}

/// What a candidate is made from: positions, quadrics and triangles, by their numbers in the
/// whole mesh.
trait Store: Tris {
    fn pos(&self, v: u32) -> DVec3;
    fn quadric(&self, v: u32) -> &Quadric;
}

/// The whole mesh, read only: candidates are made from it in parallel.
struct Whole<'a> {
    pos: &'a [DVec3],
    quadrics: &'a [Quadric],
    tris: &'a [[u32; 3]],
}

impl Tris for Whole<'_> {
    #[inline]
    fn tri(&self, t: u32) -> [u32; 3] {
        self.tris[t as usize]
    }
}

impl Store for Whole<'_> {
    #[inline]
    fn pos(&self, v: u32) -> DVec3 {
        self.pos[v as usize]
    }

    #[inline]
    fn quadric(&self, v: u32) -> &Quadric {
        &self.quadrics[v as usize]
    }
}

/// Vertices in Morton order are split into blocks of `1 << shift` consecutive numbers (each
/// block a compact region of the surface). A collapse whose two vertices have all their triangles
/// within one block reads and writes only that block's data (its vertices, and the triangles
/// whose lowest vertex is in it), so the blocks' collapses run in parallel; the others follow.
#[derive(Clone, Copy, Debug)]
struct Blocks {
    shift: u32,
    count: usize,
}

/// Blocks per mesh, aimed at: larger blocks leave fewer collapses across blocks to the
/// sequential loop, smaller ones keep a block's data closer in cache (16 did best of 16, 32, 64
/// and 128 on the dragon).
const BLOCKS: usize = 16;
/// Smallest block, in vertices.
const MIN_BLOCK: usize = 4096;

impl Blocks {
    fn new(n: usize) -> Self {
        let len = (n / BLOCKS).max(MIN_BLOCK).next_power_of_two();
        Self { shift: len.trailing_zeros(), count: n.div_ceil(len).max(1) }
    }

    fn len(self) -> usize {
        1 << self.shift
    }

    fn of(self, v: u32) -> usize {
        (v >> self.shift) as usize
    }
}

/// The live triangles of `tris`, ordered by the block of their lowest vertex (stably), where each
/// block's triangles start (one entry more than blocks), and the vertex -> triangle adjacency of
/// the result. `sources` cuts `tris` into consecutive ranges (where each starts, and the end),
/// which are sorted in parallel; the result is that of a sequential stable counting sort and of
/// [`Csr::build`].
fn rebuild(tris: &[[u32; 3]], sources: &[u32], blocks: Blocks, n: usize) -> (Vec<[u32; 3]>, Vec<u32>, Csr) {
    let k = blocks.count;
    let home = |t: &[u32; 3]| blocks.of(t[0].min(t[1]).min(t[2]));
    let ranges: Vec<&[[u32; 3]]> = sources.windows(2).map(|w| &tris[w[0] as usize..w[1] as usize]).collect();
    let counts: Vec<Vec<u32>> = ranges
        .par_iter()
        .map(|r| {
            let mut c = vec![0u32; k];
            for t in r.iter().filter(|t| t[0] != DEAD) {
                c[home(t)] += 1;
            }
            c
        })
        .collect();
    // The output by block, then by source range: each range's share of each block is one slice.
    let total: usize = counts.iter().flatten().map(|&c| c as usize).sum();
    let mut out = vec![[0u32; 3]; total];
    let mut start = Vec::with_capacity(k + 1);
    let mut slots: Vec<Vec<&mut [[u32; 3]]>> = ranges.iter().map(|_| Vec::with_capacity(k)).collect();
    let mut rest = &mut out[..];
    let mut at = 0u32;
    for h in 0..k {
        start.push(at);
        for (s, c) in counts.iter().enumerate() {
            let (mine, after) = std::mem::take(&mut rest).split_at_mut(c[h] as usize);
            slots[s].push(mine);
            rest = after;
            at += c[h];
        }
    }
    start.push(at);
    ranges.into_par_iter().zip(slots).for_each(|(r, mut dst)| {
        let mut fill = vec![0usize; k];
        for t in r.iter().filter(|t| t[0] != DEAD) {
            let h = home(t);
            dst[h][fill[h]] = *t;
            fill[h] += 1;
        }
    });
    let adj = Csr::build_blocked(n, &out, &start, blocks);
    (out, start, adj)
}

/// Whether every triangle at each vertex lies within the vertex's block.
fn inside(blocks: Blocks, adj: &Csr, tris: &[[u32; 3]]) -> Vec<bool> {
    (0..adj.off.len().saturating_sub(1) as u32)
        .into_par_iter()
        .map(|v| {
            let home = blocks.of(v);
            adj.of(v).iter().all(|&t| tris[t as usize].iter().all(|&u| blocks.of(u) == home))
        })
        .collect()
}

/// How many candidates ahead the sequential collapse loop loads its vertices' data; their first
/// triangles are loaded half as far ahead ([`Part::prefetch`]).
const PREFETCH: usize = 8;

/// A triangle removed during a pass (in its first corner; vertex numbers stay below `u32::MAX`).
const DEAD: u32 = u32::MAX;

/// A candidate's sort key: (error bits, kept, removed).
type Key = (u64, u32, u32);

/// What collapses change: the data of one block (its vertices from `vbase` on, and its triangles
/// from `tbase` on), or of the whole mesh (both bases 0). Vertices and triangles keep their
/// numbers in the whole mesh.
struct Part<'a> {
    vbase: u32,
    tbase: u32,
    pos: &'a mut [DVec3],
    quadrics: &'a mut [Quadric],
    /// The pass that last kept or removed each vertex.
    touched: &'a mut [u32],
    rep: &'a mut [u32],
    /// Per-vertex stamps for the neighbourhood tests (reset when `stamp` would wrap).
    mark: &'a mut [u32],
    stamp: u32,
    tris: &'a mut [[u32; 3]],
}

impl Tris for Part<'_> {
    #[inline]
    fn tri(&self, t: u32) -> [u32; 3] {
        self.tris[(t - self.tbase) as usize]
    }
}

impl Store for Part<'_> {
    #[inline]
    fn pos(&self, v: u32) -> DVec3 {
        self.pos[(v - self.vbase) as usize]
    }

    #[inline]
    fn quadric(&self, v: u32) -> &Quadric {
        &self.quadrics[(v - self.vbase) as usize]
    }
}

impl Part<'_> {
    /// Removes `b` into `a` when that is the candidate of the edge, neither has been touched in
    /// this pass, and the collapse keeps the mesh manifold and unflipped; returns the number of
    /// triangles removed (at least one), or `None`.
    fn collapse(&mut self, kind: &[Kind], adj: &Csr, pass: u32, a: u32, b: u32) -> Option<usize> {
        let (la, lb) = ((a - self.vbase) as usize, (b - self.vbase) as usize);
        if self.touched[la] == pass || self.touched[lb] == pass {
            return None;
        }
        // Neither end has changed since the candidate was made, so this gives it back exactly.
        let c = edge_candidate(&*self, kind, adj, a.min(b), a.max(b), false)?;
        if c.keep != a || !self.can_collapse(kind, adj, a, b, c.to) {
            return None;
        }
        let mut removed = 0;
        for &t in adj.of(b) {
            let tri = &mut self.tris[(t - self.tbase) as usize];
            if tri[0] == DEAD {
                continue;
            }
            if tri.contains(&a) {
                *tri = [DEAD; 3];
                removed += 1;
            } else {
                for v in tri {
                    if *v == b {
                        *v = a;
                    }
                }
            }
        }
        self.pos[la] = c.to;
        self.quadrics[la] = self.quadrics[la].sum(&self.quadrics[lb]);
        self.touched[la] = pass;
        self.touched[lb] = pass;
        self.rep[lb] = a;
        Some(removed)
    }

    /// Whether removing `b` into `a` (moved to `to`) keeps the mesh manifold and unflipped: the
    /// edge has one or two triangles with distinct apexes; the common neighbours of `a` and `b`
    /// are exactly those apexes (the link condition); two border vertices join only along a
    /// boundary edge; the joined vertex keeps at least 3 neighbours (2 on a border), so no
    /// component shrinks to a double-sided sliver; no surviving triangle around `a` or `b` turns
    /// its normal by 90 degrees or more.
    fn can_collapse(&mut self, kind: &[Kind], adj: &Csr, a: u32, b: u32, to: DVec3) -> bool {
        if self.stamp > u32::MAX - 8 {
            self.mark.fill(0);
            self.stamp = 0;
        }
        self.stamp += 3;
        let s = self.stamp;
        let (vbase, tbase) = (self.vbase, self.tbase);
        let (pos, tris, mark) = (&*self.pos, &*self.tris, &mut *self.mark);
        let p = |i: u32| pos[(i - vbase) as usize];
        let live = |v: u32| adj.of(v).iter().map(move |&t| tris[(t - tbase) as usize]).filter(|t| t[0] != DEAD);
        let flips = |v: u32, tri: [u32; 3]| {
            let (x, y, z) = (p(tri[0]), p(tri[1]), p(tri[2]));
            let before = (y - x).cross(z - x);
            let q = |i: u32| if i == v { to } else { p(i) };
            let (x, y, z) = (q(tri[0]), q(tri[1]), q(tri[2]));
            let after = (y - x).cross(z - x);
            before != DVec3::ZERO && before.dot(after) <= 1e-4 * before.length() * after.length()
        };
        let moves_a = to != p(a);
        let mut shared = 0usize;
        let mut apex = [u32::MAX; 2];
        let mut degree = 0usize;
        // One walk around b: the edge's triangles, b's neighbours, and flips of b's other faces.
        for tri in live(b) {
            if tri.contains(&a) {
                if shared < 2 {
                    apex[shared] = tri.into_iter().find(|&v| v != a && v != b).unwrap_or(u32::MAX);
                }
                shared += 1;
            } else if flips(b, tri) {
                return false;
            }
            for v in tri {
                let m = &mut mark[(v - vbase) as usize];
                if v != b && v != a && *m != s {
                    *m = s;
                    degree += 1;
                }
            }
        }
        if shared == 0 || shared > 2 || (shared == 2 && apex[0] == apex[1]) {
            return false;
        }
        let (ka, kb) = (kind[a as usize], kind[b as usize]);
        let border = ka != Kind::Interior || kb != Kind::Interior;
        if ka != Kind::Interior && kb != Kind::Interior && shared != 1 {
            return false;
        }
        // One walk around a: common neighbours (the link condition) and flips of a's other faces.
        let mut common = 0usize;
        for tri in live(a) {
            if moves_a && !tri.contains(&b) && flips(a, tri) {
                return false;
            }
            for v in tri {
                if v == a || v == b {
                    continue;
                }
                let m = &mut mark[(v - vbase) as usize];
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

    /// Applies the candidates of `order` whose two vertices have all their triangles in one block,
    /// block by block in parallel (each block's in cost order, on the block's own [`Part`]);
    /// the others go to `late`. `self` is the whole mesh, `tstart` where each block's triangles
    /// start. Returns the collapses applied, the triangles removed and the largest error applied.
    #[allow(clippy::too_many_arguments)]
    fn in_blocks(
        &mut self,
        blocks: Blocks,
        tstart: &[u32],
        kind: &[Kind],
        adj: &Csr,
        pass: u32,
        order: Vec<(u64, u32, u32)>,
        late: &mut Vec<(u64, u32, u32)>,
    ) -> (usize, usize, f64) {
        let inside = inside(blocks, adj, self.tris);
        // Each list is sorted before use, so the order the lists are filled in does not matter.
        let empty = || -> (Vec<Vec<Key>>, Vec<Key>) { (vec![Vec::new(); blocks.count], Vec::new()) };
        let (lists, across) = order
            .par_iter()
            .with_min_len(1 << 14)
            .fold(empty, |(mut lists, mut across), &e| {
                if inside[e.1 as usize] && inside[e.2 as usize] {
                    lists[blocks.of(e.1)].push(e);
                } else {
                    across.push(e);
                }
                (lists, across)
            })
            .reduce(empty, |(mut lists, mut across), (more, rest)| {
                for (l, m) in lists.iter_mut().zip(more) {
                    l.extend(m);
                }
                across.extend(rest);
                (lists, across)
            });
        drop(order);
        late.extend(across);
        let len = blocks.len();
        let mut parts = Vec::with_capacity(blocks.count);
        let mut tris = &mut *self.tris;
        let vertices = self.pos.chunks_mut(len).zip(self.quadrics.chunks_mut(len)).zip(self.touched.chunks_mut(len));
        for (k, (((pos, quadrics), touched), (rep, mark))) in
            vertices.zip(self.rep.chunks_mut(len).zip(self.mark.chunks_mut(len))).enumerate()
        {
            let (mine, after) = std::mem::take(&mut tris).split_at_mut((tstart[k + 1] - tstart[k]) as usize);
            tris = after;
            let (vbase, tbase, stamp) = ((k * len) as u32, tstart[k], self.stamp);
            parts.push(Part { vbase, tbase, pos, quadrics, touched, rep, mark, stamp, tris: mine });
        }
        let done: Vec<(usize, usize, f64, u32)> = parts
            .into_par_iter()
            .zip(lists)
            .map(|(mut part, mut list)| {
                list.sort_unstable();
                let (mut applied, mut removed, mut reached) = (0, 0, 0.0f64);
                for (bits, a, b) in list {
                    if let Some(r) = part.collapse(kind, adj, pass, a, b) {
                        applied += 1;
                        removed += r;
                        reached = reached.max(f64::from_bits(bits));
                    }
                }
                (applied, removed, reached, part.stamp)
            })
            .collect();
        let mut total = (0, 0, 0.0f64);
        for (a, r, c, s) in done {
            total = (total.0 + a, total.1 + r, total.2.max(c));
            self.stamp = self.stamp.max(s);
        }
        total
    }

    /// The sequential loop over the whole mesh is bound by memory latency (candidates come in cost
    /// order, scattered over the mesh): this touches what the candidates after `order[at]` will
    /// read, so that their cache misses overlap the current one's work.
    fn prefetch(&self, order: &[(u64, u32, u32)], at: usize, adj: &Csr) {
        if let Some(&(_, x, y)) = order.get(at + PREFETCH) {
            let (x, y) = ((x - self.vbase) as usize, (y - self.vbase) as usize);
            std::hint::black_box((
                self.touched[x],
                self.touched[y],
                self.quadrics[x].weight(),
                self.quadrics[y].weight(),
            ));
            std::hint::black_box((self.pos[x].x, self.pos[y].x, adj.off[x], adj.off[y]));
        }
        if let Some(&(_, x, y)) = order.get(at + PREFETCH / 2) {
            for v in [x, y] {
                if let Some(&t) = adj.of(v).first() {
                    std::hint::black_box(self.tri(t)[0]);
                }
            }
        }
    }
}

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
    tris: &[[u32; 3]],
    lock_border: bool,
    keep: &[bool],
    target: usize,
    max_cost: f64,
    progress: &mut dyn FnMut(usize),
) -> Outcome {
    let n = pos.len();
    let blocks = Blocks::new(n);
    // The input in as many ranges as blocks, sorted in parallel.
    let sources: Vec<u32> = (0..=blocks.count).map(|k| (tris.len() * k / blocks.count) as u32).collect();
    let (mut tris, mut tstart, mut adj) = rebuild(tris, &sources, blocks, n);
    let (mut kind, mut quadrics) = kinds_and_quadrics(&pos, &tris, &adj, lock_border);
    let frozen = kind.iter().filter(|&&k| k == Kind::Frozen).count();
    for (k, _) in kind.iter_mut().zip(keep).filter(|(_, keep)| **keep) {
        *k = Kind::Frozen;
    }
    let mut rep: Vec<u32> = (0..n as u32).collect();
    let mut touched = vec![0u32; n];
    let mut mark = vec![0u32; n];
    let mut stamp = 0u32;
    let (mut reached, mut collapses, mut passes) = (0.0f64, 0usize, 0usize);
    // Every candidate of the pass, over `max_cost` or not.
    let mut all: Vec<Key> = Vec::new();
    let stop = loop {
        if tris.len() <= target {
            break Stop::TargetReached;
        }
        passes += 1;
        let pass = passes as u32;
        all = edge_keys(
            &Whole { pos: &pos, quadrics: &quadrics, tris: &tris },
            &kind,
            &adj,
            (pass > 1).then_some((&all[..], &touched[..], pass - 1)),
        );
        let (bounded, over_bound) = within(&all, max_cost);
        let keys = if over_bound { &bounded } else { &all };
        // The pass stops at 1.5 times the error of the candidate that would reach the target (its
        // rank found by selection), so only the candidates below that are sorted, the rest only
        // when nothing below was valid.
        let goal = (tris.len() - target).div_ceil(2);
        let mut limit = if goal < keys.len() { cost_at_rank(keys, goal) * 1.5 } else { f64::INFINITY }.min(max_cost);
        let mut order: Vec<(u64, u32, u32)> =
            keys.par_iter().filter(|e| f64::from_bits(e.0) <= limit).copied().collect();
        let mut live = tris.len();
        let mut applied = 0;
        // Each collapse takes two vertices out of the pass and removes at most two triangles, so
        // the `m` cheapest candidates (all of them when there are not more collapses than half
        // the vertices) cannot reach the target: those inside a block run in parallel, each
        // block's in cost order; the others follow in cost order over the whole mesh.
        let m = (live - target - 1) / 2;
        let vertices = (0..n).into_par_iter().filter(|&v| adj.off[v + 1] > adj.off[v]).count();
        let mut late = if m >= vertices / 2 || m >= order.len() {
            Vec::new()
        } else {
            order.select_nth_unstable(m);
            order.split_off(m)
        };
        let mut whole = Part {
            vbase: 0,
            tbase: 0,
            pos: &mut pos,
            quadrics: &mut quadrics,
            touched: &mut touched,
            rep: &mut rep,
            mark: &mut mark,
            stamp,
            tris: &mut tris,
        };
        if !order.is_empty() {
            let (a, r, c) = whole.in_blocks(blocks, &tstart, &kind, &adj, pass, order, &mut late);
            applied += a;
            live -= r;
            reached = reached.max(c);
        }
        late.par_sort_unstable();
        let mut order = late;
        let mut at = 0;
        loop {
            if at == order.len() {
                // Nothing cheap was valid: take the dearer candidates rather than stop.
                if applied > 0 || limit >= max_cost {
                    break;
                }
                order = keys.par_iter().filter(|e| f64::from_bits(e.0) > limit).copied().collect();
                order.par_sort_unstable();
                at = 0;
                limit = max_cost;
                continue;
            }
            let (bits, a, b) = order[at];
            whole.prefetch(&order, at, &adj);
            at += 1;
            let cost = f64::from_bits(bits);
            if live <= target || cost > limit {
                break;
            }
            if let Some(r) = whole.collapse(&kind, &adj, pass, a, b) {
                live -= r;
                reached = reached.max(cost);
                applied += 1;
            }
        }
        stamp = whole.stamp;
        collapses += applied;
        (tris, tstart, adj) = rebuild(&tris, &tstart, blocks, n);
        progress(tris.len());
        if applied == 0 {
            break if over_bound { Stop::ErrorBound } else { Stop::NoValidCollapse };
        }
    };
    resolve(&mut rep);
    Outcome { tris, pos, max_cost: reached, rep, collapses, passes, frozen, stop }
}

/// Buckets of [`cost_at_rank`]: keys by their top 16 bits (sign, exponent and 4 mantissa bits of
/// the cost).
const RANK_BUCKETS: usize = 1 << 16;

/// The cost of the key of rank `rank` (0-based) in sorted order, from a parallel histogram of
/// the keys' top bits and a selection within the bucket holding that rank: the same key as a
/// full sort would put there.
fn cost_at_rank(keys: &[(u64, u32, u32)], rank: usize) -> f64 {
    let bucket = |e: &(u64, u32, u32)| (e.0 >> 48) as usize;
    let hist = keys
        .par_chunks(1 << 17)
        .map(|c| {
            let mut h = vec![0u32; RANK_BUCKETS];
            for e in c {
                h[bucket(e)] += 1;
            }
            h
        })
        .reduce(
            || vec![0u32; RANK_BUCKETS],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    *x += y;
                }
                a
            },
        );
    let mut before = 0usize;
    let mut at = 0;
    for (k, &c) in hist.iter().enumerate() {
        if before + c as usize > rank {
            at = k;
            break;
        }
        before += c as usize;
    }
    let mut within: Vec<(u64, u32, u32)> = keys.par_iter().filter(|e| bucket(e) == at).copied().collect();
    f64::from_bits(within.select_nth_unstable(rank - before).1.0)
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

/// One sort key per edge that makes a candidate: (error bits, kept, removed), over `max_cost`
/// or not. Errors are >= 0, so their bit patterns sort like the numbers, and (kept, removed) is
/// unique per edge: a total order, the same whatever the thread count.
///
/// A candidate depends only on its two vertices (positions, quadrics, kinds) and on whether its
/// edge is a boundary edge, which changes only when one of them is kept or removed. With `prev`
/// (the previous pass's keys and the vertices it touched, `touched[v] == last`), the keys of
/// edges with both vertices untouched are taken from it and only the others are made again: the
/// same set as making them all.
fn edge_keys(s: &Whole<'_>, kind: &[Kind], adj: &Csr, prev: Option<(&[Key], &[u32], u32)>) -> Vec<Key> {
    let changed = |v: u32| prev.is_none_or(|(_, touched, last)| touched[v as usize] == last);
    let mut keys: Vec<Key> = match prev {
        Some((old, ..)) => old.par_iter().filter(|e| !changed(e.1) && !changed(e.2)).copied().collect(),
        None => Vec::new(),
    };
    keys.par_extend(s.tris.par_iter().flat_map_iter(|tri| {
        (0..3).filter_map(move |k| {
            let (i, j) = (tri[k], tri[(k + 1) % 3]);
            if !changed(i) && !changed(j) {
                return None;
            }
            let c = edge_candidate(s, kind, adj, i, j, true)?;
            Some((c.cost.to_bits(), c.keep, c.remove))
        })
    }));
    keys
}

/// The keys of `all` within `max_cost`, and whether some key was over it.
fn within(all: &[Key], max_cost: f64) -> (Vec<Key>, bool) {
    let bound = max_cost.to_bits();
    let over = max_cost < f64::INFINITY && all.par_iter().any(|e| e.0 > bound);
    (if over { all.par_iter().filter(|e| e.0 <= bound).copied().collect() } else { Vec::new() }, over)
}

/// The candidate of edge `i-j`. With `half_edge`, `i -> j` is a half-edge of the mesh and the
/// candidate is made only once per edge: from its half-edge with `i < j`, or from its only one.
fn edge_candidate<S: Store + ?Sized>(
    s: &S,
    kind: &[Kind],
    adj: &Csr,
    i: u32,
    j: u32,
    half_edge: bool,
) -> Option<Candidate> {
    // A boundary edge joins two non-interior vertices: skip the search otherwise.
    let interior = kind[i as usize] == Kind::Interior || kind[j as usize] == Kind::Interior;
    if half_edge && i > j && interior {
        return None;
    }
    let boundary = !interior && (!has_half_edge(adj, s, i, j) || !has_half_edge(adj, s, j, i));
    if half_edge && i > j && !boundary {
        return None;
    }
    candidate(s, kind, i.min(j), i.max(j), boundary)
}

/// Where the collapse of edge `i-j` (`i < j`) would put the kept vertex, and at what error.
fn candidate<S: Store + ?Sized>(s: &S, kind: &[Kind], i: u32, j: u32, boundary: bool) -> Option<Candidate> {
    use Kind::{Border, Interior, Locked};
    let (ki, kj) = (kind[i as usize], kind[j as usize]);
    // May x be removed into y?
    let can = |x: Kind, y: Kind| match (x, y) {
        (Interior, Interior | Border | Locked) => true,
        (Border, Border | Locked) => boundary,
        _ => false,
    };
    let (pi, pj) = (s.pos(i), s.pos(j));
    let q = s.quadric(i).sum(s.quadric(j));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_regrouping_and_adjacency_match_the_sequential_ones() {
        // A 100 x 100 grid with scattered vertex numbers (so that many triangles span blocks),
        // some triangles dead, cut into uneven source ranges.
        let side = 100u32;
        let n = (side * side) as usize;
        let scatter = |v: u32| (v * 7919) % (side * side);
        let mut tris = Vec::new();
        for y in 0..side - 1 {
            for x in 0..side - 1 {
                let v = y * side + x;
                tris.push([v, v + 1, v + side + 1].map(scatter));
                tris.push([v, v + side + 1, v + side].map(scatter));
            }
        }
        for t in tris.iter_mut().step_by(7) {
            *t = [DEAD; 3];
        }
        let blocks = Blocks::new(n);
        assert!(blocks.count >= 3);
        let sources = [0, 5, 4000, 4001, tris.len() as u32];
        let (out, start, adj) = rebuild(&tris, &sources, blocks, n);
        let mut want: Vec<[u32; 3]> = tris.iter().copied().filter(|t| t[0] != DEAD).collect();
        want.sort_by_key(|t| blocks.of(t[0].min(t[1]).min(t[2])));
        assert_eq!(out, want);
        for k in 0..blocks.count {
            let range = &out[start[k] as usize..start[k + 1] as usize];
            assert!(range.iter().all(|t| blocks.of(t[0].min(t[1]).min(t[2])) == k));
        }
        assert_eq!(start[blocks.count] as usize, out.len());
        let seq = Csr::build(n, &out);
        assert_eq!((adj.off, adj.items), (seq.off, seq.items));
    }

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
