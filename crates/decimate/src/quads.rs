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

/// The triangles of `mesh` ([`Mesh::triangles`]), except that a polygon of five or more corners
/// first loses every corner equal to the one after it (cyclically): `a a a b b b c c c` is the
/// polygon `a b c`. Fanned as given, such a polygon makes a zero-area sliver per repeated corner,
/// all meeting at the first corner, and those slivers (frozen, and measured by the Hausdorff
/// certification piece by piece) cost time quadratic in their number. A polygon left with fewer
/// than three corners is fanned as given. Triangles and quads are always kept as they are, so
/// their defects stay exactly as they were.
pub(crate) fn triangulate(mesh: &Mesh) -> Vec<[u32; 3]> {
    let repeats = |f: &[u32]| f.len() >= CLEANED_FROM && (0..f.len()).any(|i| f[i] == f[(i + 1) % f.len()]);
    if !mesh.faces.iter().any(repeats) {
        return mesh.triangles();
    }
    let mut faces = FaceList::with_capacity(mesh.faces.len(), mesh.faces.corner_count());
    let mut kept = Vec::new();
    for f in mesh.faces.iter() {
        if !repeats(f) {
            faces.push(f);
            continue;
        }
        kept.clear();
        for (i, &v) in f.iter().enumerate() {
            if v != f[(i + 1) % f.len()] {
                kept.push(v);
            }
        }
        faces.push(if kept.len() >= 3 { &kept } else { f });
    }
    Mesh { vertices: PointCloud::from_positions(mesh.vertices.positions.clone()), faces }.triangles()
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
        assert_eq!(tris.len(), 998, "the 1,000-gon's fan");
        assert!(tris.iter().all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
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
