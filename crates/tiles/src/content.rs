//! A tile's content mesh: its faces, the crack-hiding flange around them, and the glTF axes.
//!
//! # The flange
//! Around a tile's faces, the flange is the ring of the same level's faces that touch the tile
//! (share a vertex with it) but belong to neighbouring tiles. The ring keeps the vertices it
//! shares with the tile, so it hangs on the tile's border without a gap, and its outer vertices
//! are pushed back along the level's vertex normals by `push_back` (the level's largest tile
//! error): where a neighbour is drawn, its own surface lies in front of the flange and hides it;
//! where the neighbour is drawn at another level, whose border runs a little beside this one, the
//! flange fills the sliver between the two borders. See the crate docs for why this and not
//! skirts or snapping.
//!
//! # Axes
//! glTF is y-up and 3D Tiles clients turn content to z-up (`(x, y, z) -> (x, -z, y)`) before the
//! tile transforms apply, so positions are written as `(x, z, -y)`: the client then sees the
//! tileset frame's own `(x, y, z)`.

use octowrap_geom::DVec3;
use octowrap_mesh::{FaceList, Mesh};

/// One level's vertex-to-face incidence and vertex normals.
pub(crate) struct LevelGeometry<'a> {
    pub mesh: &'a Mesh,
    start: Vec<u32>,
    faces_at: Vec<u32>,
    normals: Vec<DVec3>,
}

impl<'a> LevelGeometry<'a> {
    pub fn new(mesh: &'a Mesh) -> Self {
        let n = mesh.vertex_count();
        let mut start = vec![0u32; n + 1];
        for f in mesh.faces.iter() {
            for &v in f {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut faces_at = vec![0u32; start[n] as usize];
        let mut normals = vec![DVec3::ZERO; n];
        let p = &mesh.vertices.positions;
        for (fi, f) in mesh.faces.iter().enumerate() {
            // Newell's normal: the polygon's area vector, for quads and triangles alike.
            let mut area = DVec3::ZERO;
            for (k, &a) in f.iter().enumerate() {
                area += p[a as usize].cross(p[f[(k + 1) % f.len()] as usize]);
            }
            for &v in f {
                faces_at[fill[v as usize] as usize] = fi as u32;
                fill[v as usize] += 1;
                normals[v as usize] += area;
            }
        }
        for n in &mut normals {
            *n = n.try_normalize().unwrap_or(DVec3::ZERO);
        }
        Self { mesh, start, faces_at, normals }
    }

    fn around(&self, v: u32) -> &[u32] {
        &self.faces_at[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }

    /// The flange faces of the tile holding `faces`: faces touching them whose tile (`tile_of`)
    /// is not `tile`, ascending.
    pub fn flange(&self, faces: &[u32], tile_of: &[u32], tile: u32) -> Vec<u32> {
        let mut out: Vec<u32> = faces
            .iter()
            .flat_map(|&f| self.mesh.faces.face(f as usize).iter())
            .flat_map(|&v| self.around(v).iter().copied())
            .filter(|&g| tile_of[g as usize] != tile)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The content mesh: `faces`, then `flange` with its outer vertices pushed back by
    /// `push_back`, positions in glTF axes (see the module docs). Vertex colours are kept.
    pub fn content(&self, faces: &[u32], flange: &[u32], push_back: f64) -> Mesh {
        let mut map = vec![u32::MAX; self.mesh.vertex_count()];
        let src = &self.mesh.vertices;
        let mut out = Mesh::default();
        let mut colors = src.colors.as_ref().map(|_| Vec::new());
        let mut list = FaceList::with_capacity(faces.len() + flange.len(), 4 * (faces.len() + flange.len()));
        for (set, push) in [(faces, 0.0), (flange, push_back)] {
            for &f in set {
                let face = self.mesh.faces.face(f as usize);
                list.push_iter(face.iter().map(|&v| {
                    if map[v as usize] == u32::MAX {
                        map[v as usize] = out.vertices.positions.len() as u32;
                        let p = src.positions[v as usize] - self.normals[v as usize] * push;
                        out.vertices.positions.push(DVec3::new(p.x, p.z, -p.y));
                        if let (Some(dst), Some(c)) = (colors.as_mut(), src.colors.as_ref()) {
                            dst.push(c[v as usize]);
                        }
                    }
                    map[v as usize]
                }));
            }
        }
        out.faces = list;
        out.vertices.colors = colors;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3x1 strip of unit quads in the z = 0 plane, facing +z.
    fn strip() -> Mesh {
        let pos = (0..8).map(|i| DVec3::new(f64::from(i % 4), f64::from(i / 4), 0.0)).collect();
        let mut m = Mesh::from_positions(pos);
        m.faces = FaceList::from_quads(&[[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6]]);
        m
    }

    #[test]
    fn flange_hangs_on_the_border() {
        let m = strip();
        let g = LevelGeometry::new(&m);
        // Tiles: face 0 in tile 0, faces 1 and 2 in tile 1.
        let tile_of = [0, 1, 1];
        assert_eq!(g.flange(&[0], &tile_of, 0), vec![1]);
        assert_eq!(g.flange(&[1, 2], &tile_of, 1), vec![0]);
        let c = g.content(&[0], &[1], 0.5);
        assert_eq!(c.faces.len(), 2);
        assert_eq!(c.vertex_count(), 6, "the flange shares the border vertices");
        // Axes: (x, y, z) -> (x, z, -y); the outer flange vertices (2 and 6) go 0.5 down.
        let p = &c.vertices.positions;
        assert!(p.contains(&DVec3::new(1.0, 0.0, -1.0)), "{p:?}");
        assert!(p.contains(&DVec3::new(2.0, -0.5, -1.0)), "{p:?}");
        assert!(!p.contains(&DVec3::new(1.0, -0.5, -1.0)), "a border vertex moved: {p:?}");
        assert_eq!(m.subset(&[2]).vertex_count(), 4);
    }
}
