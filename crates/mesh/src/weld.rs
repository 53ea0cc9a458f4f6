//! Merging vertices with exactly equal positions.

use std::collections::HashMap;

use crate::Mesh;

impl Mesh {
    /// Merges vertices whose positions are bit-for-bit equal (`-0.0` and `0.0` count as equal; NaN
    /// positions are never merged), keeping the first occurrence of each position and its
    /// attributes, and renumbering faces. Vertices keep their first-seen order, so the result is
    /// deterministic.
    ///
    /// STL stores each triangle's corners separately; welding turns such a triangle soup into an
    /// indexed mesh whose connectivity can be checked. Returns the number of vertices merged away.
    pub fn weld_exact(&mut self) -> usize {
        let n = self.vertices.len();
        let key = |p: octowrap_geom::DVec3| {
            // +0.0 for -0.0, so that the two zeros weld.
            [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f64::to_bits)
        };
        let mut first: HashMap<[u64; 3], u32> = HashMap::with_capacity(n);
        let mut remap = Vec::with_capacity(n);
        let mut keep = Vec::with_capacity(n);
        for (i, p) in self.vertices.positions.iter().enumerate() {
            let new = keep.len() as u32;
            let id = if p.is_nan() { new } else { *first.entry(key(*p)).or_insert(new) };
            if id == new {
                keep.push(i);
            }
            remap.push(id);
        }
        let merged = n - keep.len();
        if merged == 0 {
            return 0;
        }
        let v = &mut self.vertices;
        v.positions = keep.iter().map(|&i| v.positions[i]).collect();
        if let Some(a) = v.normals.as_mut() {
            *a = keep.iter().map(|&i| a[i]).collect();
        }
        if let Some(a) = v.colors.as_mut() {
            *a = keep.iter().map(|&i| a[i]).collect();
        }
        if let Some(a) = v.intensities.as_mut() {
            *a = keep.iter().map(|&i| a[i]).collect();
        }
        let mut faces = crate::FaceList::with_capacity(self.faces.len(), self.faces.corner_count());
        for f in self.faces.iter() {
            faces.push_iter(f.iter().map(|&i| remap.get(i as usize).copied().unwrap_or(i)));
        }
        self.faces = faces;
        merged
    }
}

#[cfg(test)]
mod tests {
    use crate::{FaceList, Mesh};
    use octowrap_geom::DVec3;

    #[test]
    fn welds_a_triangle_soup_into_a_quad_pair() {
        let a = DVec3::ZERO;
        let b = DVec3::X;
        let c = DVec3::ONE;
        let d = DVec3::new(-0.0, 1.0, 1.0);
        let mut m = Mesh::from_positions(vec![a, b, c, a, c, DVec3::new(0.0, 1.0, 1.0), d]);
        m.vertices.intensities = Some(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
        m.faces = FaceList::from_triangles(&[[0, 1, 2], [3, 4, 5]]);
        m.faces.push(&[6, 0, 1]);
        assert_eq!(m.weld_exact(), 3);
        assert_eq!(m.vertices.positions, vec![a, b, c, DVec3::new(0.0, 1.0, 1.0)]);
        assert_eq!(m.vertices.intensities.as_deref(), Some(&[1.0, 2.0, 3.0, 6.0][..]));
        assert_eq!(m.faces.iter().collect::<Vec<_>>(), vec![&[0, 1, 2][..], &[0, 2, 3], &[3, 0, 1]]);
        assert_eq!(m.weld_exact(), 0);
    }

    #[test]
    fn nan_positions_stay_apart() {
        let mut m = Mesh::from_positions(vec![DVec3::NAN, DVec3::NAN]);
        assert_eq!(m.weld_exact(), 0);
        assert_eq!(m.vertex_count(), 2);
    }
}
