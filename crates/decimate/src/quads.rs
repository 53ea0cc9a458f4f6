//! The triangulation decimation runs on, and the re-pairing of triangles into quads after
//! decimating a quad-dominant mesh.
//!
//! Decimation runs on the triangulation ([`triangulate`]: each quad split along its shorter
//! diagonal, each larger polygon fanned from its first corner), so a
//! quad-dominant input would come out all triangles. This pass merges pairs of triangles that
//! share an edge back into quads, greedily in order of a score, a maximum matching in the spirit
//! of Remacle et al., "Blossom-Quad" (2012) but greedy: only convex pairs whose normals differ by
//! less than [`MAX_FOLD_DEGREES`] qualify, and lower scores (flatter pairs whose corners are
//! closer to right angles) are merged first. Merging two triangles across their shared edge keeps
//! every other edge and every vertex fan as it was, so manifoldness and orientation are unchanged.

use octowrap_geom::DVec3;
use octowrap_mesh::{FaceList, Mesh, PointCloud};

/// Largest angle between the two triangles' normals for a merge.
pub const MAX_FOLD_DEGREES: f64 = 30.0;

/// Polygons of this many corners or more lose their repeated corners before they are fanned.
const CLEANED_FROM: usize = 5;

/// Polygons of this many corners or more (after losing their repeated corners) are cut into a
/// strip instead of a fan.
const STRIP_FROM: usize = 16;

/// The triangles of `mesh` ([`Mesh::triangles`]), except for polygons of five or more corners:
/// * such a polygon first loses every corner equal to the one after it (cyclically):
///   `a a a b b b c c c` is the polygon `a b c`. Fanned as given, such a polygon makes a zero-area
///   sliver per repeated corner, all meeting at the first corner, and those slivers (frozen, and
///   measured by the Hausdorff certification piece by piece) cost time quadratic in their number.
///   A polygon left with fewer than three corners is fanned as given;
/// * a polygon then of [`STRIP_FROM`] corners or more is cut into a strip that zigzags between
///   its two ends (`0 1 n-1`, `1 n-2 n-1`, `1 2 n-2`, ...) rather than fanned: a fan gives its
///   first corner one triangle per corner, and every collapse next to a vertex of valence `n`
///   costs `O(n)`, so a fan of `n` corners costs `O(n²)`; in the strip no vertex has more than
///   four triangles. For a convex polygon both are valid triangulations of the same area.
///
/// Triangles and quads are always kept as they are, so their defects stay exactly as they were.
pub(crate) fn triangulate(mesh: &Mesh) -> Vec<[u32; 3]> {
    let repeats = |f: &[u32]| f.len() >= CLEANED_FROM && (0..f.len()).any(|i| f[i] == f[(i + 1) % f.len()]);
    if !mesh.faces.iter().any(|f| f.len() >= STRIP_FROM || repeats(f)) {
        return mesh.triangles();
    }
    let mut out = Vec::with_capacity(mesh.faces.corner_count());
    let mut kept = Vec::new();
    let mut one =
        Mesh { vertices: PointCloud::from_positions(mesh.vertices.positions.clone()), faces: FaceList::default() };
    for f in mesh.faces.iter() {
        let mut face = f;
        if repeats(f) {
            kept.clear();
            for (i, &v) in f.iter().enumerate() {
                if v != f[(i + 1) % f.len()] {
                    kept.push(v);
                }
            }
            if kept.len() >= 3 {
                face = &kept;
            }
        }
        if face.len() >= STRIP_FROM {
            strip(face, &mut out);
        } else {
            // Quads split along their shorter diagonal, smaller polygons fanned, as Mesh does.
            one.faces = FaceList::default();
            one.faces.push(face);
            out.extend(one.triangles());
        }
    }
    out
}

/// Appends the `n - 2` triangles of a strip across polygon `f` (see [`triangulate`]), each in the
/// polygon's orientation.
fn strip(f: &[u32], out: &mut Vec<[u32; 3]>) {
    let (mut l, mut r) = (0, f.len() - 1);
    let mut left = true;
    while l + 1 < r {
        if left {
            out.push([f[l], f[l + 1], f[r]]);
            l += 1;
        } else {
            out.push([f[l], f[r - 1], f[r]]);
            r -= 1;
        }
        left = !left;
    }
}

/// Merges triangle pairs into quads (see the module docs). Faces come out in the order of their
/// first triangle: a merged pair where its lower-numbered triangle was.
pub(crate) fn pair(pos: &[DVec3], tris: &[[u32; 3]]) -> FaceList {
    // Directed half-edges sorted by (from, to), to find each edge's opposite side.
    let mut half: Vec<(u64, u32)> = Vec::with_capacity(tris.len() * 3);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            half.push(((u64::from(tri[k]) << 32) | u64::from(tri[(k + 1) % 3]), t as u32));
        }
    }
    half.sort_unstable();
    let cos_max = MAX_FOLD_DEGREES.to_radians().cos();
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| pos[i as usize]);
        (b - a).cross(c - a)
    };
    let mut cands: Vec<(f64, u32, u32, [u32; 4])> = Vec::new();
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (u, v, w) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let key = (u64::from(v) << 32) | u64::from(u);
            let lo = half.partition_point(|h| h.0 < key);
            let hi = half.partition_point(|h| h.0 <= key);
            // Exactly one opposite side, and the forward side unique too.
            if hi - lo != 1 {
                continue;
            }
            let o = half[lo].1;
            if o as usize <= t {
                continue;
            }
            let fwd = (u64::from(u) << 32) | u64::from(v);
            if half.partition_point(|h| h.0 <= fwd) - half.partition_point(|h| h.0 < fwd) != 1 {
                continue;
            }
            let other = tris[o as usize];
            let Some(x) = other.into_iter().find(|&y| y != u && y != v) else { continue };
            if x == w {
                continue;
            }
            let quad = [u, x, v, w];
            if let Some(score) = score(pos, quad, normal(tri), normal(&other), cos_max) {
                cands.push((score, t as u32, o, quad));
            }
        }
    }
    cands.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut partner: Vec<Option<(u32, [u32; 4])>> = vec![None; tris.len()];
    let mut used = vec![false; tris.len()];
    for &(_, t, o, quad) in &cands {
        if used[t as usize] || used[o as usize] {
            continue;
        }
        used[t as usize] = true;
        used[o as usize] = true;
        partner[t.min(o) as usize] = Some((t.max(o), quad));
    }
    let mut faces = FaceList::with_capacity(tris.len(), tris.len() * 3);
    for (t, tri) in tris.iter().enumerate() {
        match partner[t] {
            Some((_, quad)) => faces.push(&quad),
            None if !used[t] => faces.push(tri),
            None => {}
        }
    }
    faces
}

/// The merge score of quad `q` (lower is better), or `None` when it is folded or not convex.
fn score(pos: &[DVec3], q: [u32; 4], n1: DVec3, n2: DVec3, cos_max: f64) -> Option<f64> {
    let (l1, l2) = (n1.length(), n2.length());
    if l1 == 0.0 || l2 == 0.0 {
        return None;
    }
    let fold = n1.dot(n2) / (l1 * l2);
    if fold < cos_max {
        return None;
    }
    let n = n1 / l1 + n2 / l2;
    let p = q.map(|i| pos[i as usize]);
    let mut squareness = 0.0;
    for k in 0..4 {
        let (prev, at, next) = (p[(k + 3) % 4], p[k], p[(k + 1) % 4]);
        let (e1, e2) = (next - at, prev - at);
        // Convex: each corner turns the same way as the pair's normal.
        if e1.cross(e2).dot(n) <= 0.0 {
            return None;
        }
        let c = e1.dot(e2) / (e1.length() * e2.length());
        squareness += c.abs();
    }
    Some((1.0 - fold) + squareness / 4.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_polygon_with_repeated_corners_is_fanned_without_slivers() {
        // A 3,000-corner polygon: each of 1,000 corners of a circle three times.
        let n = 1000u32;
        let pos: Vec<DVec3> = (0..n)
            .map(|i| {
                let a = f64::from(i) / f64::from(n) * std::f64::consts::TAU;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let mut mesh = Mesh::from_positions(pos);
        let corners: Vec<u32> = (0..n).flat_map(|i| [i; 3]).collect();
        mesh.faces.push(&corners);
        assert_eq!(mesh.triangles().len(), 2998, "fanned as given");
        let tris = triangulate(&mesh);
        assert_eq!(tris.len(), 998, "the 1,000-gon's strip");
        assert!(tris.iter().all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
        assert!(max_valence(&tris) <= 4, "a strip, not a fan");
        // Repeats across the wrap-around, and faces left as they are.
        mesh.faces = FaceList::default();
        mesh.faces.push(&[0, 1, 2, 3, 0]);
        mesh.faces.push(&[4, 4, 5]);
        mesh.faces.push(&[6, 6, 7, 8]);
        mesh.faces.push(&[9, 9, 9, 9, 9]);
        let tris = triangulate(&mesh);
        assert_eq!(tris[..2], [[0, 1, 2], [0, 2, 3]]);
        assert_eq!(tris[2], [4, 4, 5], "a degenerate triangle stays");
        assert_eq!(tris.len(), 2 + 1 + 2 + 3, "the quad's two and the all-repeated polygon's three as given");
    }

    /// The most triangles at one vertex.
    fn max_valence(tris: &[[u32; 3]]) -> usize {
        let mut count = std::collections::HashMap::new();
        for &v in tris.iter().flatten() {
            *count.entry(v).or_insert(0usize) += 1;
        }
        count.values().copied().max().unwrap_or(0)
    }

    #[test]
    fn a_large_polygon_is_cut_into_a_strip_covering_it_once() {
        // A convex 40-gon (the unit circle), and a 15-gon below the strip's threshold.
        let circle = |n: u32, from: u32| -> Vec<DVec3> {
            (0..n)
                .map(|i| {
                    let a = f64::from(i + from) / f64::from(n) * std::f64::consts::TAU;
                    DVec3::new(a.cos(), a.sin(), 0.0)
                })
                .collect()
        };
        let mut pos = circle(40, 0);
        pos.extend(circle(15, 0));
        let mut mesh = Mesh::from_positions(pos.clone());
        mesh.faces.push(&(0..40).collect::<Vec<u32>>());
        mesh.faces.push(&(40..55).collect::<Vec<u32>>());
        let tris = triangulate(&mesh);
        assert_eq!(tris.len(), 38 + 13);
        let (big, small) = tris.split_at(38);
        assert_eq!(small, &mesh.triangles()[38..], "the 15-gon is fanned as Mesh fans it");
        assert!(max_valence(big) <= 4, "no vertex of the strip has more than four triangles");
        // Every triangle is counter-clockwise, as the polygon, and together they cover its area once.
        let area = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            (b - a).cross(c - a).z / 2.0
        };
        assert!(big.iter().all(|t| area(t) > 0.0));
        let polygon = 20.0 * (std::f64::consts::TAU / 40.0).sin();
        assert!((big.iter().map(area).sum::<f64>() - polygon).abs() < 1e-12);
        // Every edge of the polygon is in exactly one triangle, every diagonal in two.
        let mut edges = std::collections::HashMap::new();
        for t in big {
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            let side = b - a == 1 || (a, b) == (0, 39);
            assert_eq!(n, if side { 1 } else { 2 }, "edge {a}-{b}");
        }
        assert_eq!(edges.len(), 40 + 37);
    }

    #[test]
    fn a_split_square_becomes_one_quad_and_a_fold_does_not() {
        let pos = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let f = pair(&pos, &[[0, 1, 2], [0, 2, 3]]);
        assert_eq!(f.len(), 1);
        assert_eq!(f.face(0).len(), 4);
        let folded = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.0, 0.0, 1.0)];
        assert_eq!(pair(&folded, &[[0, 1, 2], [0, 2, 3]]).len(), 2);
    }
}
