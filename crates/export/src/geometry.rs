//! Render-ready vertex streams for one level: triangles, smooth normals split at creases, colours.
//!
//! Triangulation is [`Mesh::triangles`] (quads along their shorter diagonal, the `0-2` diagonal on
//! a tie). Normals follow the usual area-weighted average (Max, "Weights for computing vertex
//! normals from facet normals", JGT 1999, compares the weightings; area weighting is the common
//! default of DCC tools): each triangle adds its unnormalized cross product, whose length is twice
//! its area, to its corners. With a crease angle, a corner only averages the triangles around its
//! vertex whose normals lie within that angle of its own triangle's normal; corners of one vertex
//! that end up with different normals become different output vertices (the split).

use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::{Mesh, Rgb};

/// The normal given to a vertex whose triangles all have zero area (so no direction is defined):
/// glTF requires unit normals.
pub(crate) const FALLBACK_NORMAL: Vec3 = Vec3::Z;

/// One level, ready to be written as a triangle primitive.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Streams {
    /// Output vertex positions.
    pub positions: Vec<DVec3>,
    /// Unit normals, one per output vertex.
    pub normals: Vec<Vec3>,
    /// Colours, one per output vertex, when asked for and present.
    pub colors: Option<Vec<Rgb>>,
    /// Triangle corners, three per triangle, indexing the output vertices.
    pub indices: Vec<u32>,
}

/// Builds the streams of `mesh`, whose indices must already be checked. `crease_cos` is the cosine
/// of the crease angle (`None`: smooth everywhere, no split). Triangles that name a vertex twice
/// cover no area and are not written (a face `f 1 1 1` draws nothing, and thousands of them at
/// one vertex would only slow every consumer down). Vertices no triangle uses are dropped; the
/// others keep their order (without a crease) or are grouped by source vertex in source order.
pub(crate) fn build(mesh: &Mesh, crease_cos: Option<f64>, with_colors: bool) -> Streams {
    let p = &mesh.vertices.positions;
    let mut tris = mesh.triangles();
    tris.retain(|&[a, b, c]| a != b && b != c && a != c);
    let cross: Vec<DVec3> = tris
        .iter()
        .map(|&[a, b, c]| {
            let (a, b, c) = (p[a as usize], p[b as usize], p[c as usize]);
            (b - a).cross(c - a)
        })
        .collect();
    // Vertex -> incident triangles, compressed-row form, triangles ascending.
    let n = p.len();
    let mut start = vec![0u32; n + 1];
    for t in &tris {
        for &v in t {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut incident = vec![0u32; start[n] as usize];
    for (ti, t) in tris.iter().enumerate() {
        for &v in t {
            incident[fill[v as usize] as usize] = ti as u32;
            fill[v as usize] += 1;
        }
    }
    let around = |v: usize| &incident[start[v] as usize..start[v + 1] as usize];
    let smooth: Vec<Vec3> = (0..n).map(|v| unit(around(v).iter().map(|&t| cross[t as usize]).sum())).collect();
    let unit_face: Vec<DVec3> = cross.iter().map(|c| c.try_normalize().unwrap_or(DVec3::ZERO)).collect();

    let mut out = Streams { indices: vec![0; tris.len() * 3], ..Streams::default() };
    let src_colors = if with_colors { mesh.vertices.colors.as_ref().filter(|c| c.len() == n) } else { None };
    let mut colors = src_colors.map(|_| Vec::new());
    // Per source vertex: the output vertices made from it, with their normals.
    let mut made: Vec<(Vec3, u32)> = Vec::new();
    let mut fan = Fan::default();
    for v in 0..n {
        made.clear();
        let creased = crease_cos.map(|cos| fan.creased(around(v), &unit_face, &cross, cos));
        for &t in around(v) {
            let t = t as usize;
            let normal = match &creased {
                Some(Some(groups)) if unit_face[t] != DVec3::ZERO => fan.normal_of(groups, unit_face[t]),
                _ => smooth[v],
            };
            let id = if let Some(&(_, id)) =
                made.iter().find(|(m, _)| m.to_array().map(f32::to_bits) == normal.to_array().map(f32::to_bits))
            {
                id
            } else {
                let id = out.positions.len() as u32;
                out.positions.push(p[v]);
                out.normals.push(normal);
                if let (Some(dst), Some(src)) = (colors.as_mut(), src_colors) {
                    dst.push(src[v]);
                }
                made.push((normal, id));
                id
            };
            for (k, &c) in tris[t].iter().enumerate() {
                if c as usize == v {
                    out.indices[t * 3 + k] = id;
                }
            }
        }
    }
    out.colors = colors;
    out
}

/// Past this many differently oriented triangles around one vertex, the vertex keeps one smooth
/// normal: the crease test compares every pair of orientations, and a hostile fan of millions of
/// triangles must not take quadratic time.
pub(crate) const MAX_CREASE_ORIENTATIONS: usize = 512;

/// Scratch space for the crease normals around one vertex.
#[derive(Default)]
struct Fan {
    /// (unit face normal bits, summed area vectors of the triangles with that normal).
    groups: Vec<([u64; 3], DVec3)>,
}

impl Fan {
    /// Groups the triangles `around` a vertex by exact orientation and gives each group the
    /// area-weighted sum over the groups within the crease; `None` when the vertex has more than
    /// [`MAX_CREASE_ORIENTATIONS`] orientations. Degenerate triangles take no part.
    fn creased(&mut self, around: &[u32], unit_face: &[DVec3], cross: &[DVec3], cos: f64) -> Option<Vec<Vec3>> {
        self.groups.clear();
        for &t in around {
            let u = unit_face[t as usize];
            if u != DVec3::ZERO {
                self.groups.push((u.to_array().map(f64::to_bits), cross[t as usize]));
            }
        }
        self.groups.sort_unstable_by_key(|g| g.0);
        self.groups.dedup_by(|b, a| {
            let same = a.0 == b.0;
            if same {
                a.1 += b.1;
            }
            same
        });
        if self.groups.len() > MAX_CREASE_ORIENTATIONS {
            return None;
        }
        let dirs: Vec<DVec3> = self.groups.iter().map(|g| DVec3::from_array(g.0.map(f64::from_bits))).collect();
        Some(
            dirs.iter()
                .map(|&d| unit(dirs.iter().zip(&self.groups).filter(|(o, _)| o.dot(d) >= cos).map(|(_, g)| g.1).sum()))
                .collect(),
        )
    }

    /// The creased normal of a triangle with unit normal `u` (one of the grouped orientations).
    fn normal_of(&self, normals: &[Vec3], u: DVec3) -> Vec3 {
        let key = u.to_array().map(f64::to_bits);
        self.groups.binary_search_by_key(&key, |g| g.0).map_or(FALLBACK_NORMAL, |i| normals[i])
    }
}

/// `v` normalized to an `f32` unit vector, or [`FALLBACK_NORMAL`] when it has no direction.
fn unit(v: DVec3) -> Vec3 {
    v.try_normalize().map_or(FALLBACK_NORMAL, |u| {
        let f = u.as_vec3();
        f.try_normalize().unwrap_or(FALLBACK_NORMAL)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use octowrap_mesh::FaceList;

    /// Two unit squares meeting at a right angle along the X axis (a folded sheet).
    fn fold() -> Mesh {
        let mut m = Mesh::from_positions(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, 1.0),
        ]);
        m.faces = FaceList::from_quads(&[[0, 1, 2, 3], [0, 5, 4, 1]]);
        m
    }

    #[test]
    fn smooth_normals_average_by_area_and_keep_vertices() {
        let s = build(&fold(), None, true);
        assert_eq!(s.positions.len(), 6);
        assert_eq!(s.indices.len(), 12);
        // Quad 0 faces +Z, quad 1 faces +Y ((5-0) x (4-0) = Z x (X+Z) = Y), with equal areas: the
        // shared edge gets the bisector, the other vertices their face's normal.
        let bisector = Vec3::new(0.0, 1.0, 1.0).normalize();
        assert!((s.normals[0] - bisector).length() < 1e-6, "{}", s.normals[0]);
        assert!((s.normals[2] - Vec3::Z).length() < 1e-6);
        assert!(s.colors.is_none(), "the mesh has no colours");
    }

    #[test]
    fn a_crease_splits_the_shared_edge() {
        let m = fold();
        let s = build(&m, Some(45f64.to_radians().cos()), false);
        // Vertices 0 and 1 each split in two: 6 + 2.
        assert_eq!(s.positions.len(), 8);
        for t in s.indices.chunks(3) {
            let n: Vec<Vec3> = t.iter().map(|&i| s.normals[i as usize]).collect();
            assert!(n.iter().all(|x| (*x - n[0]).length() < 1e-6), "flat faces after the split: {n:?}");
        }
        // A crease wider than the fold keeps the surface smooth.
        assert_eq!(build(&m, Some(100f64.to_radians().cos()), false).positions.len(), 6);
    }

    #[test]
    fn a_huge_fan_keeps_one_smooth_normal_in_linear_time() {
        // A cone of 100 000 triangles around the apex, each with its own orientation.
        let k = 100_000u32;
        let mut positions = vec![DVec3::Z];
        positions.extend((0..k).map(|i| {
            let a = f64::from(i) / f64::from(k) * std::f64::consts::TAU;
            DVec3::new(a.cos(), a.sin(), 0.0)
        }));
        let mut m = Mesh::from_positions(positions);
        m.faces = FaceList::from_triangles(&(0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect::<Vec<_>>());
        let s = build(&m, Some(0.99), false);
        let apex: std::collections::BTreeSet<u32> = s.indices.chunks(3).map(|t| t[0]).collect();
        assert_eq!(apex.len(), 1, "the apex is not split");
        assert!((s.normals[*apex.first().unwrap() as usize] - Vec3::Z).length() < 1e-4);
    }

    #[test]
    fn triangles_naming_a_vertex_twice_are_not_written() {
        let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::Y]);
        for _ in 0..1000 {
            m.faces.push(&[0, 0, 0]);
            m.faces.push(&[0, 1, 1]);
        }
        m.faces.push(&[0, 1, 2]);
        let s = build(&m, None, false);
        assert_eq!(s.indices, vec![0, 1, 2]);
        assert_eq!(s.positions.len(), 3);
        assert_eq!(s.normals, vec![Vec3::Z; 3]);
    }

    #[test]
    fn degenerate_and_unused_vertices() {
        let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0, DVec3::Y]);
        m.faces.push(&[0, 1, 2]); // zero area
        m.vertices.colors = Some(vec![[1, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 12]]);
        let s = build(&m, Some(0.5), true);
        assert_eq!(s.positions.len(), 3, "vertex 3 is unused");
        assert!(s.normals.iter().all(|&n| n == FALLBACK_NORMAL));
        assert_eq!(s.colors.as_deref(), Some(&[[1, 2, 3], [4, 5, 6], [7, 8, 9]][..]));
        assert_eq!(s.indices, vec![0, 1, 2]);
    }
}
