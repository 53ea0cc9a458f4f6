//! Self-intersection detection with exact predicates.
//!
//! Faces are fan-triangulated (corner 0 with each following edge); triangles of the same face are
//! not tested against each other, and triangles with zero area are skipped (they are reported as
//! `W-ZERO-AREA-FACE`). A uniform grid over the triangles' boxes finds candidate pairs; each pair is
//! then decided exactly with Shewchuk's adaptive `orient3d`/`orient2d` predicates (the `robust`
//! crate), by how many vertices the two triangles share:
//!
//! * none: they intersect when an edge of one meets the other (closed sets, coplanar overlap and
//!   touching included);
//! * one vertex `v`: they intersect beyond `v` when the edge opposite `v` in one meets the other,
//!   or an edge at `v` runs into the other triangle (it then lies in that triangle's plane);
//! * an edge: they intersect beyond it only when they are coplanar and fold onto the same side;
//! * three (a duplicate face): not tested here (`W-DUPLICATE-FACE` reports it).
//!
//! Touching along a shared edge or at a shared vertex is therefore never reported: these are the
//! contacts a valid mesh has everywhere.

use octowrap_geom::DVec3;
use octowrap_mesh::Mesh;
use rayon::prelude::*;
use robust::{Coord, Coord3D, orient2d, orient3d};

#[derive(Clone, Copy)]
struct Tri {
    face: u32,
    v: [u32; 3],
    lo: DVec3,
    hi: DVec3,
}

/// Face pairs `(f, g)`, `f < g`, that intersect beyond their shared elements; sorted, distinct.
pub(crate) fn self_intersections(mesh: &Mesh, usable: &[bool]) -> Vec<(u32, u32)> {
    let p = &mesh.vertices.positions;
    let mut tris = Vec::new();
    for (f, face) in mesh.faces.iter().enumerate() {
        if !usable[f] || face.iter().any(|&i| !p[i as usize].is_finite()) {
            continue;
        }
        for k in 1..face.len() - 1 {
            let v = [face[0], face[k], face[k + 1]];
            let [a, b, c] = v.map(|i| p[i as usize]);
            if is_collinear(a, b, c) {
                continue;
            }
            tris.push(Tri { face: f as u32, v, lo: a.min(b).min(c), hi: a.max(b).max(c) });
        }
    }
    if tris.len() < 2 {
        return Vec::new();
    }
    let candidates = candidate_pairs(&tris);
    let mut hits: Vec<(u32, u32)> = candidates
        .par_iter()
        .filter_map(|&(i, j)| {
            let (s, t) = (&tris[i as usize], &tris[j as usize]);
            intersect(p, s, t).then(|| (s.face.min(t.face), s.face.max(t.face)))
        })
        .collect();
    hits.sort_unstable();
    hits.dedup();
    hits
}

fn is_collinear(a: DVec3, b: DVec3, c: DVec3) -> bool {
    // Exactly collinear when all three coordinate-plane projections are (orient2d is exact).
    let xy = orient2d(Coord { x: a.x, y: a.y }, Coord { x: b.x, y: b.y }, Coord { x: c.x, y: c.y });
    let yz = orient2d(Coord { x: a.y, y: a.z }, Coord { x: b.y, y: b.z }, Coord { x: c.y, y: c.z });
    let zx = orient2d(Coord { x: a.z, y: a.x }, Coord { x: b.z, y: b.x }, Coord { x: c.z, y: c.x });
    xy == 0.0 && yz == 0.0 && zx == 0.0
}

/// Pairs of triangles of different faces whose boxes overlap, each pair once, by a uniform grid
/// whose cell is about twice the mean triangle size.
fn candidate_pairs(tris: &[Tri]) -> Vec<(u32, u32)> {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    let mut mean = 0.0;
    for t in tris {
        lo = lo.min(t.lo);
        hi = hi.max(t.hi);
        mean += (t.hi - t.lo).max_element();
    }
    mean /= tris.len() as f64;
    let extent = (hi - lo).max_element();
    // At most about 2^20 cells per axis; never a zero cell.
    let cell = (2.0 * mean).max(extent / f64::from(1 << 20)).max(f64::MIN_POSITIVE);
    let key = |p: DVec3| ((p - lo) / cell).floor().as_ivec3().clamp(glam_ivec(0), glam_ivec((1 << 20) - 1));
    let pack = |c: octowrap_geom::glam::IVec3| (c.x as u64) << 42 | (c.y as u64) << 21 | c.z as u64;
    let mut entries: Vec<(u64, u32)> = Vec::with_capacity(tris.len() * 2);
    for (i, t) in tris.iter().enumerate() {
        let (a, b) = (key(t.lo), key(t.hi));
        let span = (b - a + 1).as_i64vec3();
        if span.x * span.y * span.z > 4096 {
            // A huge triangle: test it against everything (rare: sliver across the model).
            entries.push((u64::MAX, i as u32));
            continue;
        }
        for x in a.x..=b.x {
            for y in a.y..=b.y {
                for z in a.z..=b.z {
                    entries.push((pack(octowrap_geom::glam::IVec3::new(x, y, z)), i as u32));
                }
            }
        }
    }
    entries.sort_unstable();
    let huge: Vec<u32> = entries.iter().filter(|e| e.0 == u64::MAX).map(|e| e.1).collect();
    let overlap = |s: &Tri, t: &Tri| s.lo.cmple(t.hi).all() && t.lo.cmple(s.hi).all();
    let mut pairs = Vec::new();
    let mut i = 0;
    while i < entries.len() && entries[i].0 != u64::MAX {
        let mut j = i;
        while j < entries.len() && entries[j].0 == entries[i].0 {
            j += 1;
        }
        let cell_key = entries[i].0;
        let group = &entries[i..j];
        for (x, &(_, a)) in group.iter().enumerate() {
            for &(_, b) in &group[x + 1..] {
                let (s, t) = (&tris[a as usize], &tris[b as usize]);
                if s.face == t.face || !overlap(s, t) {
                    continue;
                }
                // Report the pair only in the cell holding the lower corner of the boxes' overlap.
                if pack(key(s.lo.max(t.lo))) == cell_key {
                    pairs.push((a.min(b), a.max(b)));
                }
            }
        }
        i = j;
    }
    for &h in &huge {
        for (k, t) in tris.iter().enumerate() {
            let k = k as u32;
            if k != h && t.face != tris[h as usize].face && overlap(t, &tris[h as usize]) {
                pairs.push((h.min(k), h.max(k)));
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

fn glam_ivec(v: i32) -> octowrap_geom::glam::IVec3 {
    octowrap_geom::glam::IVec3::splat(v)
}

fn c3(p: DVec3) -> Coord3D<f64> {
    Coord3D { x: p.x, y: p.y, z: p.z }
}

fn o3(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    orient3d(c3(a), c3(b), c3(c), c3(d))
}

/// A projection onto the coordinate plane that keeps triangle `abc` non-degenerate.
#[derive(Clone, Copy)]
struct Proj(usize, usize);

impl Proj {
    fn for_triangle(a: DVec3, b: DVec3, c: DVec3) -> Self {
        let n = (b - a).cross(c - a).abs();
        if n.x >= n.y && n.x >= n.z {
            Self(1, 2)
        } else if n.y >= n.z {
            Self(2, 0)
        } else {
            Self(0, 1)
        }
    }

    fn at(self, p: DVec3) -> Coord<f64> {
        Coord { x: p[self.0], y: p[self.1] }
    }

    fn orient(self, a: DVec3, b: DVec3, c: DVec3) -> f64 {
        orient2d(self.at(a), self.at(b), self.at(c))
    }
}

fn sign(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// Whether closed segment `pq` meets the closed triangle `abc` (3D, exact).
fn segment_triangle(p: DVec3, q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    let (sp, sq) = (sign(o3(a, b, c, p)), sign(o3(a, b, c, q)));
    if sp * sq > 0 {
        return false;
    }
    if sp == 0 && sq == 0 {
        return coplanar_segment_triangle(Proj::for_triangle(a, b, c), p, q, a, b, c);
    }
    let s = [sign(o3(p, q, a, b)), sign(o3(p, q, b, c)), sign(o3(p, q, c, a))];
    !(s.contains(&1) && s.contains(&-1))
}

/// Whether closed segment `pq` meets the closed triangle `abc`, all in one plane.
fn coplanar_segment_triangle(pr: Proj, p: DVec3, q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    point_in_triangle(pr, p, a, b, c)
        || point_in_triangle(pr, q, a, b, c)
        || segments_meet(pr, p, q, a, b)
        || segments_meet(pr, p, q, b, c)
        || segments_meet(pr, p, q, c, a)
}

fn point_in_triangle(pr: Proj, p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    let s = [sign(pr.orient(a, b, p)), sign(pr.orient(b, c, p)), sign(pr.orient(c, a, p))];
    !(s.contains(&1) && s.contains(&-1))
}

/// Closed 2D segments `pq` and `rs` share a point.
fn segments_meet(pr: Proj, p: DVec3, q: DVec3, r: DVec3, s: DVec3) -> bool {
    let d1 = sign(pr.orient(r, s, p));
    let d2 = sign(pr.orient(r, s, q));
    let d3 = sign(pr.orient(p, q, r));
    let d4 = sign(pr.orient(p, q, s));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    let on = |d: i8, a: DVec3, b: DVec3, x: DVec3| {
        let (x, a, b) = (pr.at(x), pr.at(a), pr.at(b));
        d == 0 && x.x >= a.x.min(b.x) && x.x <= a.x.max(b.x) && x.y >= a.y.min(b.y) && x.y <= a.y.max(b.y)
    };
    on(d1, r, s, p) || on(d2, r, s, q) || on(d3, p, q, r) || on(d4, p, q, s)
}

/// Whether the ray from `v` through `a` enters triangle `(v, c, d)` (coplanar with it) beyond `v`.
fn ray_enters_wedge(pr: Proj, v: DVec3, a: DVec3, c: DVec3, d: DVec3) -> bool {
    let w = sign(pr.orient(v, c, d));
    let s1 = sign(pr.orient(v, c, a));
    let s2 = sign(pr.orient(v, a, d));
    let forward = |x: DVec3| (a - v).dot(x - v) > 0.0;
    if s1 == 0 {
        return forward(c);
    }
    if s2 == 0 {
        return forward(d);
    }
    s1 == w && s2 == w
}

fn intersect(p: &[DVec3], s: &Tri, t: &Tri) -> bool {
    let shared: Vec<(usize, usize)> =
        (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).filter(|&(i, j)| s.v[i] == t.v[j]).collect();
    let sp = s.v.map(|i| p[i as usize]);
    let tp = t.v.map(|i| p[i as usize]);
    match shared.len() {
        0 => {
            (0..3).any(|k| segment_triangle(sp[k], sp[(k + 1) % 3], tp[0], tp[1], tp[2]))
                || (0..3).any(|k| segment_triangle(tp[k], tp[(k + 1) % 3], sp[0], sp[1], sp[2]))
        }
        1 => {
            let (i, j) = shared[0];
            let v = sp[i];
            let (a, b) = (sp[(i + 1) % 3], sp[(i + 2) % 3]);
            let (c, d) = (tp[(j + 1) % 3], tp[(j + 2) % 3]);
            if segment_triangle(a, b, v, c, d) || segment_triangle(c, d, v, a, b) {
                return true;
            }
            let pt = Proj::for_triangle(v, c, d);
            let ps = Proj::for_triangle(v, a, b);
            [a, b].iter().any(|&x| o3(v, c, d, x) == 0.0 && ray_enters_wedge(pt, v, x, c, d))
                || [c, d].iter().any(|&x| o3(v, a, b, x) == 0.0 && ray_enters_wedge(ps, v, x, a, b))
        }
        2 => {
            let ((i0, j0), (i1, j1)) = (shared[0], shared[1]);
            let (v, w) = (sp[i0], sp[i1]);
            let (a, b) = (sp[3 - i0 - i1], tp[3 - j0 - j1]);
            if o3(v, w, a, b) != 0.0 {
                return false;
            }
            let pr = Proj::for_triangle(v, w, a);
            sign(pr.orient(v, w, a)) * sign(pr.orient(v, w, b)) > 0
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octowrap_mesh::FaceList;

    fn count(points: &[[f64; 3]], tris: &[[u32; 3]]) -> Vec<(u32, u32)> {
        let mut m = Mesh::from_positions(points.iter().map(|p| DVec3::from_array(*p)).collect());
        m.faces = FaceList::from_triangles(tris);
        self_intersections(&m, &vec![true; tris.len()])
    }

    #[test]
    fn crossing_triangles() {
        let pts =
            [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [3.0, 3.0, 0.0]];
        assert_eq!(count(&pts, &[[0, 1, 2], [3, 4, 5]]), vec![(0, 1)]);
        // Moved away: no contact.
        let far =
            [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [5.5, 5.5, -1.0], [5.5, 5.5, 1.0], [8.0, 8.0, 0.0]];
        assert!(count(&far, &[[0, 1, 2], [3, 4, 5]]).is_empty());
    }

    #[test]
    fn shared_edge_and_vertex_contacts_are_not_intersections() {
        // Two triangles of a flat square, and a third folded up along an edge.
        let pts =
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, -1.0, 1.0], [2.0, 2.0, 0.0]];
        assert!(count(&pts, &[[0, 1, 2], [0, 2, 3], [1, 0, 4], [2, 5, 1]]).is_empty());
    }

    #[test]
    fn coplanar_fold_over_a_shared_edge_is_an_intersection() {
        let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 0.0]];
        assert_eq!(count(&pts, &[[0, 1, 2], [1, 0, 3]]), vec![(0, 1)]);
    }

    #[test]
    fn shared_vertex_with_a_piercing_edge() {
        // Triangle 1 shares vertex 0 with triangle 0 and its edge 0-4 runs inside triangle 0's plane
        // into it; no opposite edge crosses.
        let pts = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0], [0.5, 0.5, 0.0]];
        assert_eq!(count(&pts, &[[0, 1, 2], [0, 3, 4]]), vec![(0, 1)]);
        // The same, with the edge leaving the plane: touching at the vertex only.
        let pts2 = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0], [-0.5, -0.5, 0.5]];
        assert!(count(&pts2, &[[0, 1, 2], [0, 3, 4]]).is_empty());
    }

    #[test]
    fn coplanar_overlap_without_shared_vertices() {
        let pts =
            [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [1.0, 1.0, 0.0], [2.0, 1.0, 0.0], [1.0, 2.0, 0.0]];
        assert_eq!(count(&pts, &[[0, 1, 2], [3, 4, 5]]), vec![(0, 1)]);
    }
}
