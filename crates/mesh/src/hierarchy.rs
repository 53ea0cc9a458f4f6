//! The multiresolution hierarchy that reconstruction produces and the MRQ format stores.
//!
//! Level 0 is any polygon mesh (the six faces of the root cube after reconstruction, or any mesh
//! converted to a one-level file). Every face of level `j + 1` either descends from a face of level
//! `j` — it covers the quadrant `q` of that parent face, where quadrant `q` is the quarter of the
//! parent that touches the parent's corner `q` — or was created by irregular refinement and has no
//! parent. This is the paper's subdivision connectivity (Keller et al., §3.4-3.5).

use std::fmt;

use octowrap_geom::Aabb;

use crate::Mesh;

/// Which quarter of its parent quad a face covers: the one touching the parent's corner
/// `Quadrant(q)`, `q` in `0..4`, corners numbered in the parent face's own order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Quadrant(pub u8);

/// Where a face of level `j + 1` comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaceOrigin {
    /// A subface of face `parent` of the level above, covering quadrant `quadrant`.
    Subface {
        /// Face index in the parent level.
        parent: u32,
        /// The quarter of the parent it covers.
        quadrant: Quadrant,
    },
    /// Created by irregular refinement (or by any edit): no parent face.
    Created,
}

/// Octree lattice coordinates of a level's elements, when the level came from an octree:
/// a codec can name vertices by lattice point instead of coding positions from scratch.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LevelLattice {
    /// Per face: the voxel `(x, y, z)` in `[0, 2^level)^3` and the side `0..6`
    /// (`+X, -X, +Y, -Y, +Z, -Z`) the face lies on.
    pub face_slots: Vec<([u32; 3], u8)>,
    /// Per vertex: the lattice corner `(x, y, z)` in `[0, 2^level]^3` it was made from.
    pub vertex_corners: Vec<[u32; 3]>,
}

/// One level of a [`Hierarchy`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Level {
    /// The level's mesh (quads for reconstructed levels).
    pub mesh: Mesh,
    /// One entry per face: its parent link. Level 0 has every face [`FaceOrigin::Created`].
    pub origins: Vec<FaceOrigin>,
    /// Lattice coordinates, when the level came from an octree.
    pub lattice: Option<LevelLattice>,
}

/// A coarse-to-fine sequence of meshes linked by subdivision connectivity.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hierarchy {
    /// Levels, coarsest (0) first.
    pub levels: Vec<Level>,
    /// The octree root cube, when the hierarchy came from an octree: level `j`'s voxels have edge
    /// `cube.size().x / 2^j`.
    pub cube: Option<Aabb>,
}

/// A broken parent link or per-face array in a [`Hierarchy`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HierarchyError {
    /// A level's `origins` (or lattice arrays) do not have one entry per face (vertex).
    LengthMismatch {
        /// The level.
        level: usize,
        /// What has the wrong length.
        what: &'static str,
        /// Expected entries.
        expected: usize,
        /// Entries found.
        found: usize,
    },
    /// A face names a parent that does not exist, or a quadrant outside `0..4`, or sits at level 0
    /// with a parent.
    BadParent {
        /// The level of the child face.
        level: usize,
        /// The child face.
        face: usize,
    },
    /// Two faces claim the same quadrant of the same parent.
    SharedQuadrant {
        /// The level of the child faces.
        level: usize,
        /// The second face claiming it.
        face: usize,
    },
}

impl fmt::Display for HierarchyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LengthMismatch { level, what, expected, found } => {
                write!(f, "level {level}: {what} has {found} entries, expected {expected}")
            }
            Self::BadParent { level, face } => {
                write!(f, "level {level}: face {face} has an invalid parent link")
            }
            Self::SharedQuadrant { level, face } => {
                write!(f, "level {level}: face {face} claims a parent quadrant that another face already covers")
            }
        }
    }
}

impl std::error::Error for HierarchyError {}

impl Hierarchy {
    /// A one-level hierarchy holding `mesh`, every face created.
    pub fn single(mesh: Mesh) -> Self {
        let origins = vec![FaceOrigin::Created; mesh.faces.len()];
        Self { levels: vec![Level { mesh, origins, lattice: None }], cube: None }
    }

    /// The finest level, if any.
    pub fn finest(&self) -> Option<&Level> {
        self.levels.last()
    }

    /// Checks array lengths and parent links: every parent exists in the level above, every
    /// quadrant is in `0..4` and names a corner of the parent, and no two faces share a
    /// `(parent, quadrant)`.
    pub fn check_links(&self) -> Result<(), HierarchyError> {
        for (level, l) in self.levels.iter().enumerate() {
            let faces = l.mesh.faces.len();
            let mismatch = |what, expected, found| HierarchyError::LengthMismatch { level, what, expected, found };
            if l.origins.len() != faces {
                return Err(mismatch("origins", faces, l.origins.len()));
            }
            if let Some(lat) = &l.lattice {
                if lat.face_slots.len() != faces {
                    return Err(mismatch("lattice.face_slots", faces, lat.face_slots.len()));
                }
                if lat.vertex_corners.len() != l.mesh.vertices.len() {
                    return Err(mismatch("lattice.vertex_corners", l.mesh.vertices.len(), lat.vertex_corners.len()));
                }
            }
            let parent = level.checked_sub(1).map(|p| &self.levels[p].mesh.faces);
            let mut seen = std::collections::HashSet::new();
            for (face, o) in l.origins.iter().enumerate() {
                let FaceOrigin::Subface { parent: p, quadrant } = *o else {
                    continue;
                };
                let Some(pf) = parent else {
                    return Err(HierarchyError::BadParent { level, face });
                };
                if p as usize >= pf.len() || usize::from(quadrant.0) >= pf.face(p as usize).len().min(4) {
                    return Err(HierarchyError::BadParent { level, face });
                }
                if !seen.insert((p, quadrant)) {
                    return Err(HierarchyError::SharedQuadrant { level, face });
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FaceList;
    use octowrap_geom::DVec3;

    fn quad_level(n: usize) -> Mesh {
        let mut m = Mesh::from_positions(vec![DVec3::ZERO; 4 * n]);
        m.faces =
            FaceList::from_quads(&(0..n as u32).map(|i| [4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3]).collect::<Vec<_>>());
        m
    }

    #[test]
    fn links_are_checked() {
        let mut h = Hierarchy::single(quad_level(1));
        let sub = |q| FaceOrigin::Subface { parent: 0, quadrant: Quadrant(q) };
        h.levels.push(Level { mesh: quad_level(3), origins: vec![sub(0), sub(3), FaceOrigin::Created], lattice: None });
        assert_eq!(h.check_links(), Ok(()));
        h.levels[1].origins[1] = sub(0);
        assert_eq!(h.check_links(), Err(HierarchyError::SharedQuadrant { level: 1, face: 1 }));
        h.levels[1].origins[1] = sub(4);
        assert_eq!(h.check_links(), Err(HierarchyError::BadParent { level: 1, face: 1 }));
        h.levels[1].origins[1] = FaceOrigin::Subface { parent: 1, quadrant: Quadrant(0) };
        assert_eq!(h.check_links(), Err(HierarchyError::BadParent { level: 1, face: 1 }));
        h.levels[1].origins.pop();
        assert!(matches!(h.check_links(), Err(HierarchyError::LengthMismatch { level: 1, .. })));
        h.levels[0].origins[0] = sub(0);
        assert_eq!(h.check_links(), Err(HierarchyError::BadParent { level: 0, face: 0 }));
    }
}
