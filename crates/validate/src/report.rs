//! The validation report: counts, per-component topology, properties, and findings with stable
//! codes.

use serde::Serialize;

/// Stable issue codes. The string form (`E-NONMANIFOLD-EDGE`, ...) never changes meaning; new
/// codes may be added. The letter says the default severity: `E` error, `W` warning, `I` info.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[non_exhaustive]
pub enum Code {
    /// A face refers to a vertex that does not exist.
    #[serde(rename = "E-INDEX-RANGE")]
    IndexRange,
    /// A face has fewer than 3 vertices.
    #[serde(rename = "E-FACE-SIZE")]
    FaceSize,
    /// A vertex has a NaN or infinite coordinate.
    #[serde(rename = "E-NONFINITE-VERTEX")]
    NonFiniteVertex,
    /// An edge has more than two face sides.
    #[serde(rename = "E-NONMANIFOLD-EDGE")]
    NonManifoldEdge,
    /// The faces around a vertex form more than one fan.
    #[serde(rename = "E-NONMANIFOLD-VERTEX")]
    NonManifoldVertex,
    /// A directed edge is used by more than one face: neighbours disagree on orientation.
    #[serde(rename = "E-ORIENTATION")]
    Orientation,
    /// A face repeats a vertex index.
    #[serde(rename = "W-DEGENERATE-FACE")]
    DegenerateFace,
    /// A face has zero area (collinear or coincident corners).
    #[serde(rename = "W-ZERO-AREA-FACE")]
    ZeroAreaFace,
    /// A face has the same vertex cycle as an earlier face (either direction).
    #[serde(rename = "W-DUPLICATE-FACE")]
    DuplicateFace,
    /// A vertex has exactly the position of an earlier vertex.
    #[serde(rename = "W-DUPLICATE-VERTEX")]
    DuplicateVertex,
    /// A vertex is used by no face.
    #[serde(rename = "W-UNUSED-VERTEX")]
    UnusedVertex,
    /// An edge has one face side: the surface has a boundary (a hole) there.
    #[serde(rename = "I-BOUNDARY-EDGE")]
    BoundaryEdge,
    /// A hierarchy level's parent links are broken.
    #[serde(rename = "E-PARENT-LINK")]
    ParentLink,
    /// Two faces cross or overlap beyond the edge or vertex they share.
    #[serde(rename = "E-SELF-INTERSECTION")]
    SelfIntersection,
}

impl Code {
    /// Every code, in report order.
    pub const ALL: [Self; 14] = [
        Self::IndexRange,
        Self::FaceSize,
        Self::NonFiniteVertex,
        Self::NonManifoldEdge,
        Self::NonManifoldVertex,
        Self::Orientation,
        Self::SelfIntersection,
        Self::ParentLink,
        Self::DegenerateFace,
        Self::ZeroAreaFace,
        Self::DuplicateFace,
        Self::DuplicateVertex,
        Self::UnusedVertex,
        Self::BoundaryEdge,
    ];

    /// The stable string form.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::IndexRange => "E-INDEX-RANGE",
            Self::FaceSize => "E-FACE-SIZE",
            Self::NonFiniteVertex => "E-NONFINITE-VERTEX",
            Self::NonManifoldEdge => "E-NONMANIFOLD-EDGE",
            Self::NonManifoldVertex => "E-NONMANIFOLD-VERTEX",
            Self::Orientation => "E-ORIENTATION",
            Self::DegenerateFace => "W-DEGENERATE-FACE",
            Self::ZeroAreaFace => "W-ZERO-AREA-FACE",
            Self::DuplicateFace => "W-DUPLICATE-FACE",
            Self::DuplicateVertex => "W-DUPLICATE-VERTEX",
            Self::UnusedVertex => "W-UNUSED-VERTEX",
            Self::BoundaryEdge => "I-BOUNDARY-EDGE",
            Self::ParentLink => "E-PARENT-LINK",
            Self::SelfIntersection => "E-SELF-INTERSECTION",
        }
    }

    /// The default severity, from the code's letter.
    pub fn severity(self) -> Severity {
        match self.as_str().as_bytes()[0] {
            b'E' => Severity::Error,
            b'W' => Severity::Warning,
            _ => Severity::Info,
        }
    }

    /// One line saying what the code means.
    pub fn description(self) -> &'static str {
        match self {
            Self::IndexRange => "face refers to a vertex that does not exist",
            Self::FaceSize => "face has fewer than 3 vertices",
            Self::NonFiniteVertex => "vertex has a NaN or infinite coordinate",
            Self::NonManifoldEdge => "edge shared by more than two faces",
            Self::NonManifoldVertex => "faces around a vertex form more than one fan",
            Self::Orientation => "neighbouring faces traverse a shared edge in the same direction",
            Self::DegenerateFace => "face repeats a vertex",
            Self::ZeroAreaFace => "face has zero area",
            Self::DuplicateFace => "face has the same vertices as an earlier face",
            Self::DuplicateVertex => "vertex has exactly the position of an earlier vertex",
            Self::UnusedVertex => "vertex used by no face",
            Self::BoundaryEdge => "edge with a single face (a boundary or hole)",
            Self::ParentLink => "face's parent link or quadrant is invalid",
            Self::SelfIntersection => "two faces cross or overlap beyond what they share",
        }
    }
}

impl std::fmt::Display for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// How serious a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Breaks two-manifoldness or validity.
    Error,
    /// Legal but usually unwanted.
    Warning,
    /// Worth knowing (holes).
    Info,
}

/// A mesh element a finding points at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Element {
    /// A vertex index.
    Vertex(u32),
    /// A face index.
    Face(u32),
    /// An edge, as its two vertex indices (smaller first).
    Edge(u32, u32),
    /// A pair of faces (smaller first).
    Faces(u32, u32),
}

/// One kind of defect found, with how many and (up to a cap) which elements.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Finding {
    /// The stable code.
    pub code: Code,
    /// Its severity.
    pub severity: Severity,
    /// How many elements have this defect.
    pub count: usize,
    /// The first elements (at most [`ValidateOptions::max_elements`](crate::ValidateOptions::max_elements)).
    pub elements: Vec<Element>,
    /// A human sentence.
    pub message: String,
}

/// Counts of every checked property.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    /// Edges with one face side.
    pub boundary_edges: usize,
    /// Connected chains of boundary edges (holes and borders).
    pub boundary_loops: usize,
    /// Edges with more than two face sides.
    pub non_manifold_edges: usize,
    /// Used vertices whose faces form more than one fan.
    pub non_manifold_vertices: usize,
    /// Directed edges used by more than one face side.
    pub orientation_conflicts: usize,
    /// Faces that repeat a vertex index.
    pub degenerate_faces: usize,
    /// Faces of zero area.
    pub zero_area_faces: usize,
    /// Faces with the vertex cycle of an earlier face.
    pub duplicate_faces: usize,
    /// Vertices at exactly the position of an earlier vertex.
    pub duplicate_vertices: usize,
    /// Vertices used by no face.
    pub unused_vertices: usize,
    /// Vertices with a NaN or infinite coordinate.
    pub non_finite_vertices: usize,
    /// Faces with an index out of range.
    pub out_of_range_faces: usize,
    /// Faces with fewer than 3 vertices.
    pub short_faces: usize,
    /// Pairs of faces that intersect; absent unless the (slower) check was asked for.
    pub self_intersections: Option<usize>,
}

/// Topology of one connected component (faces joined through shared vertices).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Component {
    /// Faces in the component.
    pub faces: usize,
    /// Vertices used by those faces.
    pub vertices: usize,
    /// Distinct edges of those faces.
    pub edges: usize,
    /// Boundary edges.
    pub boundary_edges: usize,
    /// `V - E + F`.
    pub euler_characteristic: i64,
    /// Every edge has exactly two face sides, every vertex one fan.
    pub closed_manifold: bool,
    /// No orientation conflicts.
    pub oriented: bool,
    /// `(2 - χ) / 2` for a closed, manifold, oriented component; absent otherwise.
    pub genus: Option<i64>,
}

/// The properties `--require` can ask for; see the crate docs for their definitions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Properties {
    /// Valid indices, faces of 3+ vertices, every edge 1 or 2 face sides, every vertex one fan.
    pub manifold: bool,
    /// Manifold, and no directed edge used twice.
    pub oriented: bool,
    /// No boundary edges.
    pub closed: bool,
    /// Manifold and closed.
    pub watertight: bool,
    /// Finite coordinates, no degenerate, zero-area or duplicate faces.
    pub clean: bool,
    /// No two faces intersect beyond what they share; absent unless the check was asked for.
    pub intersection_free: Option<bool>,
}

/// The full result for one mesh.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshReport {
    /// Number of vertices (all, used or not).
    pub vertices: usize,
    /// Number of faces.
    pub faces: usize,
    /// Distinct edges.
    pub edges: usize,
    /// Vertices merged by welding before the checks (0 without welding).
    pub welded_vertices: usize,
    /// `V - E + F` over used vertices, distinct edges and checked faces.
    pub euler_characteristic: i64,
    /// Every count.
    pub counts: Counts,
    /// The properties.
    pub properties: Properties,
    /// Connected components, largest (by faces) first.
    pub components: Vec<Component>,
    /// Findings, errors first.
    pub findings: Vec<Finding>,
}
