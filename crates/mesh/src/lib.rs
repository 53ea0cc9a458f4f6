//! octowrap's data model.
//!
//! * [`PointCloud`]: positions with optional per-point normals, colours and intensities.
//! * [`FaceList`]: polygons of 3 or more vertices in compressed-row form (triangles, quads and
//!   n-gons side by side).
//! * [`Mesh`]: a point cloud (its vertices) plus a face list. A point cloud read from disk is a
//!   mesh with no faces, so every reader returns a [`Mesh`].
//! * [`Hierarchy`]: the multiresolution result of reconstruction, one [`Level`] per octree depth,
//!   each face linked to its parent face and quadrant one level up ([`FaceOrigin`]).
//!
//! # Coordinates
//! Positions are `f64` ([`DVec3`]) throughout. We chose `f64` over an `f64` origin with `f32`
//! offsets because several inputs (LAS scaled integers, E57 doubles, UTM coordinates spanning
//! tens of kilometres) need more than `f32`'s 24-bit mantissa across the whole extent, and one
//! representation is simpler than two. Normals are `f32` ([`Vec3`]): they are unit vectors.
//!
//! ```
//! use octowrap_mesh::{Mesh, PointCloud, FaceList};
//! use octowrap_geom::DVec3;
//!
//! let mut mesh = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::ONE, DVec3::Y]);
//! mesh.faces.push(&[0, 1, 2, 3]);
//! mesh.faces.push(&[0, 2, 1]);
//! assert_eq!(mesh.faces.len(), 2);
//! assert_eq!(mesh.faces.face(0), &[0, 1, 2, 3]);
//! assert_eq!(mesh.faces.size_histogram(), vec![(3, 1), (4, 1)]);
//! assert!(mesh.check_indices().is_ok());
//! // The quad splits along its shorter diagonal, the triangle stays.
//! assert_eq!(mesh.triangles().len(), 3);
//! ```

mod cloud;
mod faces;
mod hierarchy;
#[cfg(feature = "testing")]
pub mod shapes;
mod weld;

pub use cloud::{PointCloud, Rgb};
pub use faces::{FaceList, IndexError};
pub use hierarchy::{FaceOrigin, Hierarchy, HierarchyError, Level, LevelLattice, Quadrant};
pub use octowrap_geom::{Aabb, DVec3, Vec3};

/// A polygon mesh: vertices with their attributes, and faces indexing them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// The vertices and their optional attributes.
    pub vertices: PointCloud,
    /// The faces (possibly none: a point cloud).
    pub faces: FaceList,
}

impl Mesh {
    /// A mesh with the given vertex positions and no faces or attributes.
    pub fn from_positions(positions: Vec<DVec3>) -> Self {
        Self { vertices: PointCloud::from_positions(positions), faces: FaceList::default() }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// The faces `faces` of this mesh (indices in range) as a mesh of their own: its vertices
    /// are those the faces use, in order of first use, positions only.
    #[must_use]
    pub fn subset(&self, faces: &[u32]) -> Self {
        let mut map = vec![u32::MAX; self.vertex_count()];
        let mut out = Self::default();
        let mut list = FaceList::with_capacity(faces.len(), 4 * faces.len());
        for &f in faces {
            list.push_iter(self.faces.face(f as usize).iter().map(|&v| {
                if map[v as usize] == u32::MAX {
                    map[v as usize] = out.vertices.positions.len() as u32;
                    out.vertices.positions.push(self.vertices.positions[v as usize]);
                }
                map[v as usize]
            }));
        }
        out.faces = list;
        out
    }

    /// The faces as triangles, deterministically: quads split along their shorter diagonal (the
    /// `0-2` diagonal on a tie), other polygons fanned from their first corner, triangles as they
    /// are; faces of fewer than 3 vertices give none. Out-of-range indices are passed through
    /// (positions read as the origin), so check [`Mesh::check_indices`] first.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let p = &self.vertices.positions;
        let pos = |i: u32| p.get(i as usize).copied().unwrap_or(DVec3::ZERO);
        let mut out = Vec::with_capacity(self.faces.corner_count());
        for f in self.faces.iter() {
            if let &[a, b, c, d] = f {
                if pos(a).distance_squared(pos(c)) <= pos(b).distance_squared(pos(d)) {
                    out.extend([[a, b, c], [a, c, d]]);
                } else {
                    out.extend([[a, b, d], [b, c, d]]);
                }
            } else if let Some((&first, rest)) = f.split_first() {
                out.extend(rest.windows(2).map(|w| [first, w[0], w[1]]));
            }
        }
        out
    }

    /// Checks that every face index is below the vertex count and every face has 3 or more vertices.
    pub fn check_indices(&self) -> Result<(), IndexError> {
        self.faces.check(self.vertices.len())
    }
}
