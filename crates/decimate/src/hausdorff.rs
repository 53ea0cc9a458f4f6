//! Certified Hausdorff distance between two triangle sets: a lower and an upper bound that
//! enclose the true (continuous) symmetric Hausdorff distance, the upper within a relative
//! tolerance of the lower.
//!
//! Sources: Guthe, Borodin, Klein, "Fast and accurate Hausdorff distance calculation between
//! meshes" (WSCG 2005): subdivide the triangles of one surface, keep an upper bound of each
//! piece's distance to the other surface, and refine only the pieces whose bound exceeds the
//! largest distance found so far (branch and bound); Aspert, Santa-Cruz, Ebrahimi, "MESH:
//! measuring errors between surfaces using the Hausdorff distance" (ICME 2002) for the one-sided
//! and symmetric definitions.
//!
//! # Bounds of one piece
//! A piece is a triangle `t` of the `from` surface (or a part of one from longest-edge
//! bisection) with corners `pᵢ`, their exact distances `dᵢ` to the `to` surface (a BVH query) and
//! their nearest triangles `Tᵢ`. Every point of `t` is within the smaller of:
//! * **Lipschitz**: `max dᵢ + ρ`, `ρ` the largest distance from the centroid to a corner (the
//!   distance to a set is 1-Lipschitz, and every point of `t` is within `ρ` of some corner:
//!   `minᵢ |p − pᵢ|² ≤ Σ λᵢ |p − pᵢ|² ≤ maxᵢ |pᵢ − c|²` for barycentric `λ`);
//! * **convexity**: the distance to one triangle `T` is a convex function, so its maximum over
//!   `t` is at a corner: `maxᵢ d(pᵢ, T)` for each `T` among the `Tᵢ`; and when two of them share
//!   an edge, `t` is split by the plane through that edge bisecting the two triangles' in-plane
//!   directions, each side bounded by its own triangle at the side's corners (this settles the
//!   pieces that straddle an edge of a flat region in one step); the same with each `Tᵢ` and the
//!   triangles across its edges.
//!
//! # The search
//! `lower` is the largest exact corner distance found. A piece whose bound is at most
//! `lower · (1 + relative) + absolute` is settled; the others are split in two at the midpoint of
//! their longest edge (one new corner query, seeded with an end's nearest triangle) and tried
//! again, so the
//! result satisfies `lower ≤ true distance ≤ upper ≤ lower · (1 + relative) + absolute`. A piece
//! 80 splits deep, or any piece once the pieces in flight exceed a budget, is settled with its
//! bound as it is: `upper` is then still a true bound, only looser ([`Certified::converged`] is
//! false). Each round runs in parallel into ordered arrays and maxima are exact, so the result
//! does not depend on the thread count.

use octowrap_geom::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::metrics::{Bvh, Triangles, point_triangle_squared};

/// A certified distance: `lower ≤ true ≤ upper`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Certified {
    /// The largest exact distance found at a sample (a lower bound of the true distance).
    pub lower: f64,
    /// An upper bound of the true distance.
    pub upper: f64,
    /// Whether `upper ≤ lower · (1 + relative) + absolute` was reached (false only when the
    /// refinement budget ran out).
    pub converged: bool,
}

/// How tight [`symmetric`] makes its bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Tolerance {
    pub relative: f64,
    pub absolute: f64,
}

/// The tolerance used throughout the crate: 1 % relative, `1e-7` of `diagonal` absolute.
pub(crate) fn tolerance(diagonal: f64) -> Tolerance {
    Tolerance { relative: 0.01, absolute: 1e-7 * diagonal }
}

/// Deepest split of one input triangle.
const MAX_DEPTH: u8 = 80;

/// Pieces in flight in one round before the search gives up tightening.
const BUDGET: usize = 200_000;

/// A triangle set as positions and indexed triangles, with a BVH over them.
struct Side<'a> {
    pos: &'a [DVec3],
    tris: &'a [[u32; 3]],
    corners: &'a Triangles,
    bvh: &'a Bvh<'a>,
    /// The triangle across each edge `k` (`tris[t][k] -> tris[t][k + 1]`), when exactly one.
    across: Vec<[u32; 3]>,
}

/// The triangle across each edge of each triangle (see [`Side::across`]).
fn across(tris: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let key = |u: u32, v: u32| (u64::from(u.min(v)) << 32) | u64::from(u.max(v));
    let mut edges: Vec<(u64, u32)> = tris
        .iter()
        .enumerate()
        .flat_map(|(t, tri)| (0..3).map(move |k| (key(tri[k], tri[(k + 1) % 3]), t as u32)))
        .collect();
    edges.par_sort_unstable();
    let mut out = vec![[u32::MAX; 3]; tris.len()];
    for run in edges.chunk_by(|a, b| a.0 == b.0) {
        if let &[(e, t1), (_, t2)] = run {
            for (t, o) in [(t1, t2), (t2, t1)] {
                let tri = tris[t as usize];
                if let Some(k) = (0..3).find(|&k| key(tri[k], tri[(k + 1) % 3]) == e) {
                    out[t as usize][k] = o;
                }
            }
        }
    }
    out
}

/// The certified symmetric Hausdorff distance between triangles `ta` over `pa` and `tb` over `pb`
/// (see the module docs). A side without triangles is at infinite distance from a side with some,
/// and two empty sides at zero.
pub(crate) fn symmetric(pa: &[DVec3], ta: &[[u32; 3]], pb: &[DVec3], tb: &[[u32; 3]], tol: Tolerance) -> Certified {
    symmetric_over(pa, ta, pb, tb, tol, f64::INFINITY).0
}

/// [`symmetric`], and the triangles of each side where a point farther than `over` from the other
/// side was found (sorted, without repeats).
pub(crate) fn symmetric_over(
    pa: &[DVec3],
    ta: &[[u32; 3]],
    pb: &[DVec3],
    tb: &[[u32; 3]],
    tol: Tolerance,
    over: f64,
) -> (Certified, [Vec<u32>; 2]) {
    if ta.is_empty() || tb.is_empty() {
        let d = if ta.is_empty() && tb.is_empty() { 0.0 } else { f64::INFINITY };
        return (Certified { lower: d, upper: d, converged: true }, [Vec::new(), Vec::new()]);
    }
    let (ca, cb) = (Triangles::from_indexed(pa, ta), Triangles::from_indexed(pb, tb));
    let (ba, bb) = (Bvh::new(&ca), Bvh::new(&cb));
    let a = Side { pos: pa, tris: ta, corners: &ca, bvh: &ba, across: across(ta) };
    let b = Side { pos: pb, tris: tb, corners: &cb, bvh: &bb, across: across(tb) };
    let (ab, over_a) = one_sided(&a, &b, tol, 0.0, over);
    let (ba, over_b) = one_sided(&b, &a, tol, ab.lower, over);
    let c = Certified {
        lower: ab.lower.max(ba.lower),
        upper: ab.upper.max(ba.upper),
        converged: ab.converged && ba.converged,
    };
    (c, [over_a, over_b])
}

/// A piece of a `from` triangle.
#[derive(Clone, Copy, Debug)]
struct Piece {
    p: [DVec3; 3],
    /// Exact distances of the corners to `to`.
    d: [f64; 3],
    /// Nearest `to` triangle of each corner.
    near: [u32; 3],
    depth: u8,
    /// The `from` triangle it is part of.
    tri: u32,
}

impl Piece {
    fn farthest(&self) -> f64 {
        self.d[0].max(self.d[1]).max(self.d[2])
    }
}

/// The certified one-sided distance from `from` to `to`, starting from a known lower bound, and
/// the `from` triangles where a point farther than `over` was found.
fn one_sided(from: &Side<'_>, to: &Side<'_>, tol: Tolerance, lower: f64, over: f64) -> (Certified, Vec<u32>) {
    let mut used = vec![false; from.pos.len()];
    for &v in from.tris.iter().flatten() {
        used[v as usize] = true;
    }
    // In fixed chunks (not per thread, so the hints and thus the tie-breaks between equally near
    // triangles do not depend on the thread count), each query seeded with the previous answer.
    let mut at: Vec<(f64, u32)> = vec![(0.0, u32::MAX); from.pos.len()];
    at.par_chunks_mut(256).enumerate().for_each(|(c, out)| {
        let mut hint = None;
        for (k, slot) in out.iter_mut().enumerate() {
            let v = c * 256 + k;
            if used[v] {
                let (d2, t) = to.bvh.nearest(from.pos[v], hint);
                *slot = (d2.sqrt(), t);
                hint = Some(t);
            }
        }
    });
    let mut lower = at.iter().fold(lower, |m, x| m.max(x.0));
    let threshold = |l: f64| l * (1.0 + tol.relative) + tol.absolute;
    let limit = threshold(lower);
    let mut found: Vec<u32> = from
        .tris
        .iter()
        .enumerate()
        .filter(|(_, t)| t.iter().any(|&v| at[v as usize].0 > over))
        .map(|(i, _)| i as u32)
        .collect();
    let first: Vec<(f64, Option<Piece>)> = from
        .tris
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            let piece = Piece {
                p: t.map(|v| from.pos[v as usize]),
                d: t.map(|v| at[v as usize].0),
                near: t.map(|v| at[v as usize].1),
                depth: 0,
                tri: i as u32,
            };
            let b = bound(to, &piece, limit);
            if b <= limit { (b, None) } else { (0.0, Some(piece)) }
        })
        .collect();
    let mut settled = first.iter().fold(0.0f64, |m, x| m.max(x.0));
    let mut work: Vec<Piece> = first.into_iter().filter_map(|x| x.1).collect();
    let mut converged = true;
    while !work.is_empty() {
        if work.len() > BUDGET {
            let limit = threshold(lower);
            let b = work.par_iter().map(|pc| bound(to, pc, limit)).reduce(|| 0.0, f64::max);
            settled = settled.max(b);
            converged &= b <= limit;
            break;
        }
        let children: Vec<Piece> = work.par_iter().flat_map_iter(|pc| split(to, pc)).collect();
        lower = children.iter().fold(lower, |m, c| m.max(c.farthest()));
        found.extend(children.iter().filter(|c| c.farthest() > over).map(|c| c.tri));
        let limit = threshold(lower);
        let bounds: Vec<f64> = children.par_iter().map(|c| bound(to, c, limit)).collect();
        work = Vec::new();
        for (c, b) in children.into_iter().zip(bounds) {
            if b <= limit || c.depth >= MAX_DEPTH {
                settled = settled.max(b);
                converged &= b <= limit;
            } else {
                work.push(c);
            }
        }
    }
    found.sort_unstable();
    found.dedup();
    (Certified { lower, upper: lower.max(settled), converged }, found)
}

/// The two pieces of a split at the midpoint of the longest edge, the new corner queried (seeded
/// with an end's nearest triangle). Longest-edge bisection keeps slivers, and the segments that
/// degenerate triangles are, from piling up pieces around a point.
fn split(to: &Side<'_>, pc: &Piece) -> [Piece; 2] {
    let len = |i: usize| pc.p[i].distance_squared(pc.p[(i + 1) % 3]);
    let i = if len(0) >= len(1) && len(0) >= len(2) {
        0
    } else if len(1) >= len(2) {
        1
    } else {
        2
    };
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let m = 0.5 * (pc.p[i] + pc.p[j]);
    let (d2, t) = to.bvh.nearest(m, Some(pc.near[i]));
    let d = d2.sqrt();
    let depth = pc.depth + 1;
    [
        Piece {
            p: [pc.p[i], m, pc.p[k]],
            d: [pc.d[i], d, pc.d[k]],
            near: [pc.near[i], t, pc.near[k]],
            depth,
            tri: pc.tri,
        },
        Piece {
            p: [m, pc.p[j], pc.p[k]],
            d: [d, pc.d[j], pc.d[k]],
            near: [t, pc.near[j], pc.near[k]],
            depth,
            tri: pc.tri,
        },
    ]
}

/// An upper bound of the distance from every point of `pc` to `to` (see the module docs); the
/// convexity bounds are tried only when the Lipschitz one is above `limit`.
fn bound(to: &Side<'_>, pc: &Piece, limit: f64) -> f64 {
    let c = (pc.p[0] + pc.p[1] + pc.p[2]) / 3.0;
    let rho = pc.p.iter().map(|&p| p.distance_squared(c)).fold(0.0, f64::max).sqrt();
    let lipschitz = pc.d[0].max(pc.d[1]).max(pc.d[2]) + rho;
    if lipschitz <= limit {
        return lipschitz;
    }
    let dist = |p: DVec3, t: u32| point_triangle_squared(p, &to.corners.corners[t as usize]).sqrt();
    let mut cands = [u32::MAX; 3];
    let mut n = 0;
    for &t in &pc.near {
        if t != u32::MAX && !cands[..n].contains(&t) {
            cands[n] = t;
            n += 1;
        }
    }
    let mut best = lipschitz;
    for &t in &cands[..n] {
        best = best.min(pc.p.iter().map(|&p| dist(p, t)).fold(0.0, f64::max));
    }
    if best <= limit {
        return best;
    }
    // Pairs sharing an edge: two of the candidates, or a candidate and a triangle across one of
    // its edges (the nearest triangle of a corner near an edge is a toss-up between the two).
    for i in 0..n {
        for j in i + 1..n {
            if let Some(b) = split_bound(to, pc, cands[i], cands[j]) {
                best = best.min(b);
            }
        }
        for &o in &to.across[cands[i] as usize] {
            if o != u32::MAX && !cands[..n].contains(&o) && best > limit {
                if let Some(b) = split_bound(to, pc, cands[i], o) {
                    best = best.min(b);
                }
            }
        }
    }
    best
}

/// The bound of `pc` split by the plane through the edge shared by `t1` and `t2` (`None` when
/// they share no edge): each side bounded by its triangle at the side's corners.
fn split_bound(to: &Side<'_>, pc: &Piece, t1: u32, t2: u32) -> Option<f64> {
    let (a, b) = (to.tris[t1 as usize], to.tris[t2 as usize]);
    let mut shared = a.into_iter().filter(|v| b.contains(v));
    let (Some(u), Some(v), None) = (shared.next(), shared.next(), shared.next()) else { return None };
    let third = |t: [u32; 3]| t.into_iter().find(|&x| x != u && x != v);
    let (a1, a2) = (third(a)?, third(b)?);
    let p = |i: u32| to.pos[i as usize];
    let (pu, e) = (p(u), p(v) - p(u));
    let e2 = e.length_squared();
    if e2 <= 0.0 {
        return None;
    }
    let perp = |x: DVec3| {
        let r = x - pu;
        (r - e * (r.dot(e) / e2)).normalize_or_zero()
    };
    let m = perp(p(a1)) - perp(p(a2));
    if m == DVec3::ZERO {
        return None;
    }
    let dist = |q: DVec3, t: u32| point_triangle_squared(q, &to.corners.corners[t as usize]).sqrt();
    let s = pc.p.map(|q| (q - pu).dot(m));
    let (mut up, mut down) = (0.0f64, 0.0f64);
    for i in 0..3 {
        let j = (i + 1) % 3;
        if s[i] >= 0.0 {
            up = up.max(dist(pc.p[i], t1));
        }
        if s[i] <= 0.0 {
            down = down.max(dist(pc.p[i], t2));
        }
        if (s[i] > 0.0 && s[j] < 0.0) || (s[i] < 0.0 && s[j] > 0.0) {
            let x = pc.p[i] + (pc.p[j] - pc.p[i]) * (s[i] / (s[i] - s[j]));
            up = up.max(dist(x, t1));
            down = down.max(dist(x, t2));
        }
    }
    Some(up.max(down))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: u32, z: impl Fn(f64, f64) -> f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let m = octowrap_mesh::shapes::triangulated_grid(n, n, [false, false], |v, u| DVec3::new(u, v, z(u, v)));
        (m.vertices.positions.clone(), m.triangles())
    }

    const TOL: Tolerance = Tolerance { relative: 0.01, absolute: 1e-12 };

    #[test]
    fn a_bump_against_a_plane_is_its_height() {
        // A fine grid with a tent-shaped bump of height 0.1 against a 2x2 flat grid: the
        // Hausdorff distance is the height of the bump's top.
        let (pa, ta) = grid(40, |u, v| (0.1 - 0.5 * ((u - 0.5).abs() + (v - 0.5).abs())).max(0.0));
        let (pb, tb) = grid(2, |_, _| 0.0);
        let c = symmetric(&pa, &ta, &pb, &tb, TOL);
        assert!(c.converged);
        assert!(c.lower <= 0.1 + 1e-12 && c.upper >= 0.1 - 1e-12, "{c:?}");
        assert!(c.upper <= c.lower * 1.01 + 1e-12, "{c:?}");
        // The same surface: zero, settled at once even though the triangulations differ.
        let (pc, tc) = grid(7, |_, _| 0.0);
        let c = symmetric(&pc, &tc, &pb, &tb, TOL);
        assert!(c.converged && c.upper <= 1e-12, "{c:?}");
    }

    #[test]
    fn the_upper_bound_holds_between_samples() {
        // A coarse plane over a dense wave: the true distance is at a wave crest between the
        // coarse mesh's vertices; dense sampling of both sides never exceeds the upper bound.
        let (pa, ta) = grid(60, |u, v| 0.02 * (9.0 * u).sin() * (7.0 * v).cos());
        let (pb, tb) = grid(3, |u, _| 0.01 * u);
        let c = symmetric(&pa, &ta, &pb, &tb, TOL);
        let to_mesh = |p: &[DVec3], t: &[[u32; 3]]| {
            let mut m = octowrap_mesh::Mesh::from_positions(p.to_vec());
            m.faces = octowrap_mesh::FaceList::from_triangles(t);
            m
        };
        let d = crate::metrics::distance(
            &to_mesh(&pa, &ta),
            &to_mesh(&pb, &tb),
            &crate::metrics::Sampling::with_samples(400_000),
        );
        assert!(d.hausdorff <= c.upper, "{d:?} {c:?}");
        assert!(d.hausdorff >= c.upper * 0.98, "{d:?} {c:?}");
    }
}
