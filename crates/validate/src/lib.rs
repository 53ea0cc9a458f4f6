//! Two-manifold validation of polygon meshes and multiresolution hierarchies, built for CI.
//!
//! The checks run on the raw indexed face list, the one form that can hold broken input, so a
//! broken mesh is described, not rejected. Each defect becomes a [`Finding`] with a stable
//! [`Code`], a severity, a count, and the first offending elements (capped by
//! [`ValidateOptions::max_elements`]).
//!
//! # Definitions
//! Tools disagree on these words (trimesh, MeshLab and Open3D each mean something else by
//! "watertight"), so here is what octowrap means:
//!
//! * **Edge**: an unordered pair of distinct vertex indices that follow each other in some face
//!   (cyclically). Its *sides* are the faces' traversals of it; a face that uses an edge twice
//!   gives it two sides.
//! * **Boundary edge**: an edge with one side. **Boundary loop**: a connected set of boundary
//!   edges (two holes touching at one vertex count as one loop).
//! * **Non-manifold edge**: an edge with more than two sides.
//! * **Fan**: the faces around a vertex that are connected to each other through edges at that
//!   vertex. A **non-manifold vertex** has more than one fan (an hourglass or bow-tie).
//! * **Orientation conflict**: a directed edge `a → b` traversed by more than one side. Each such
//!   directed edge counts once, so an edge whose two faces both run `a → b` is one conflict, and a
//!   non-manifold edge with sides `a→b, a→b, b→a, b→a` is two.
//! * **Manifold**: every index in range, every face of 3 or more vertices, no non-manifold edges
//!   and no non-manifold vertices. Boundaries are allowed (a manifold with boundary).
//! * **Oriented**: manifold and free of orientation conflicts.
//! * **Closed**: no boundary edges.
//! * **Watertight**: manifold and closed. (Orientation is a separate property: require both.)
//! * **Clean**: finite coordinates, no degenerate (repeated-index), zero-area or duplicate faces.
//! * **Intersection-free** (checked on request): no two faces share a point beyond the edge or
//!   vertex they have in common. Faces are fan-triangulated for the test and decided with exact
//!   predicates, so coplanar and touching faces give no false positives (see `intersect.rs`).
//! * **Component**: a maximal set of faces connected through shared vertices. Its **Euler
//!   characteristic** is `χ = V − E + F` over its used vertices, distinct edges and faces; a closed,
//!   manifold, oriented component has genus `(2 − χ) / 2`.
//!
//! Zero area is judged by the vector area (Newell's method) relative to the face's squared size
//! (`|A| ≤ 1e-12 · r²`), so the test does not depend on units. Duplicate vertices have bit-equal
//! positions (`-0.0 = 0.0`); duplicate faces have the same cycle of vertices as an earlier face, from
//! any corner and in either direction.
//!
//! ```
//! use octowrap_mesh::{FaceList, Mesh};
//! use octowrap_geom::DVec3;
//! use octowrap_validate::{validate_mesh, Code, ValidateOptions};
//!
//! // Three triangles on one edge: the "three_faces_one_edge" pathology.
//! let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Y]);
//! m.faces = FaceList::from_triangles(&[[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
//! let report = validate_mesh(&m, &ValidateOptions::default());
//! assert_eq!(report.counts.non_manifold_edges, 1);
//! assert!(!report.properties.manifold);
//! assert_eq!(report.findings[0].code, Code::NonManifoldEdge);
//! ```

mod check;
mod dsu;
mod intersect;
mod output;
#[cfg(test)]
mod reference;
mod report;

pub use output::{FileResult, Format, Outcome, Requirement, write_report};
pub use report::{Code, Component, Counts, Element, Finding, MeshReport, Properties, Severity};

use octowrap_mesh::{Hierarchy, Mesh};
use serde::Serialize;

/// What to check and how much to report.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ValidateOptions {
    /// Most elements listed per finding (the count is always complete). Default 100.
    pub max_elements: usize,
    /// Merge vertices with bit-equal positions before the topology checks (STL stores every
    /// triangle corner separately, so its topology exists only after welding). Default false.
    pub weld: bool,
    /// Also look for faces that cross or overlap (exact predicates; slower). Default false.
    pub self_intersections: bool,
}

impl Default for ValidateOptions {
    fn default() -> Self {
        Self { max_elements: 100, weld: false, self_intersections: false }
    }
}

/// Checks one mesh. See the crate docs for what each property means.
pub fn validate_mesh(mesh: &Mesh, opts: &ValidateOptions) -> MeshReport {
    if opts.weld {
        let mut m = mesh.clone();
        let merged = m.weld_exact();
        check::check(&m, opts, merged)
    } else {
        check::check(mesh, opts, 0)
    }
}

/// The face pairs `(f, g)`, `f < g`, that intersect beyond their shared edge or vertex, sorted:
/// the `self_intersections` check alone (faces with fewer than 3 corners or an index out of
/// range are left out).
pub fn intersecting_face_pairs(mesh: &Mesh) -> Vec<(u32, u32)> {
    let n = mesh.vertex_count();
    let usable: Vec<bool> = mesh.faces.iter().map(|f| f.len() >= 3 && f.iter().all(|&i| (i as usize) < n)).collect();
    intersect::self_intersections(mesh, &usable)
}

/// The checks of every level of a hierarchy, plus its parent links.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HierarchyReport {
    /// One report per level, coarsest first.
    pub levels: Vec<MeshReport>,
    /// Broken parent links (`E-PARENT-LINK`), if any.
    pub links: Vec<Finding>,
}

impl HierarchyReport {
    /// Whether every level has `property` and the links are valid.
    pub fn all_levels(&self, property: impl Fn(&Properties) -> bool) -> bool {
        self.links.is_empty() && self.levels.iter().all(|l| property(&l.properties))
    }
}

/// Checks every level of `h` and the parent links between levels.
pub fn validate_hierarchy(h: &Hierarchy, opts: &ValidateOptions) -> HierarchyReport {
    let levels = h.levels.iter().map(|l| validate_mesh(&l.mesh, opts)).collect();
    let links = match h.check_links() {
        Ok(()) => Vec::new(),
        Err(e) => {
            let elements = match e {
                octowrap_mesh::HierarchyError::BadParent { face, .. }
                | octowrap_mesh::HierarchyError::SharedQuadrant { face, .. } => vec![Element::Face(face as u32)],
                octowrap_mesh::HierarchyError::LengthMismatch { .. } => Vec::new(),
            };
            vec![Finding {
                code: Code::ParentLink,
                severity: Severity::Error,
                count: 1,
                elements,
                message: e.to_string(),
            }]
        }
    };
    HierarchyReport { levels, links }
}
