//! The mesh checks, over the raw indexed face list.
//!
//! One counting sort puts every corner of a usable face into its vertex's *ring*, as the pair
//! (previous vertex, next vertex) of its face. Everything topological is then decided vertex by
//! vertex from that ring alone, which the sort laid out contiguously:
//!
//! * an edge `{v, x}` at `v` has one side per ring entry whose next vertex is `x` (the face runs
//!   `v → x`) and one per entry whose previous vertex is `x` (`x → v`), so its valence and its
//!   orientation conflicts are read off the ring of its smaller vertex;
//! * the fans of `v` are the classes of its corners joined through shared edges.
//!
//! Most vertices of most meshes are regular: stepping from each corner to the corner across its
//! incoming edge walks the whole ring once. [`regular_ring`] recognises such a vertex with a few
//! compares and decides it directly (an interior vertex by [`closed_fan`] alone, with one vector
//! compare per corner in rings of up to 8 corners); any other vertex goes through
//! [`general_ring`], which sorts the ring's edge sides and joins corners with a small union-find.
//! Both give the same answer wherever both apply: a test runs the general path on every vertex
//! and compares, and another compares the whole report with a plain edge-sorting implementation
//! on random broken meshes.
//!
//! Components come from a union-find over vertices joined by edges; duplicate faces from the
//! vertices where two corners have the same two neighbours. Only what is irregular is kept per
//! vertex, so a clean mesh costs little memory. Everything is deterministic: no hash-map order
//! reaches the report, and lists come out in vertex or face order.

use octowrap_geom::DVec3;
use octowrap_mesh::{FaceList, Mesh};
use wide::{CmpEq, i32x8};

use crate::report::{Code, Component, Counts, Element, Finding, MeshReport, Properties};
use crate::{ValidateOptions, dsu::Dsu};

/// The edge defects counted at a vertex (on edges where it is the smaller vertex).
#[derive(Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct EdgeTally {
    pub(crate) boundary: u32,
    pub(crate) non_manifold: u32,
    pub(crate) conflicts: u32,
}

/// Per-vertex results for the components: edge counts, and the vertices with defects.
pub(crate) struct VertexTallies {
    /// Edges at each vertex, as their smaller vertex.
    pub(crate) edges: Vec<u32>,
    /// Vertices with boundary, non-manifold or conflicting edges (as the smaller vertex), ascending.
    pub(crate) irregular: Vec<(u32, EdgeTally)>,
    /// Vertices with more than one fan, ascending.
    pub(crate) non_manifold: Vec<u32>,
}

pub(crate) struct Collector {
    pub(crate) cap: usize,
    pub(crate) findings: Vec<Finding>,
}

impl Collector {
    pub(crate) fn add(
        &mut self,
        code: Code,
        elements: impl IntoIterator<Item = Element>,
        count: usize,
        message: String,
    ) {
        if count == 0 {
            return;
        }
        let elements = elements.into_iter().take(self.cap).collect();
        self.findings.push(Finding { code, severity: code.severity(), count, elements, message });
    }
}

/// One corner in its vertex's ring: the previous and the next vertex of its face. (A plain
/// array, so that the ring's allocation comes zeroed from the system instead of being filled.)
type RingEntry = [u32; 2];

/// The largest ring [`regular_ring`] looks at; larger rings take the general path.
const LANES: usize = 32;
/// "No corner" in [`regular_ring`]'s tables.
const NONE: u8 = u8::MAX;

/// Rings of up to this many corners are searched by vector compares (most vertices of most
/// meshes: the valence of a regular triangle mesh is 6, of a quad mesh 4).
const SHORT_RING: usize = 8;

/// What the edge walk found, in report order.
#[derive(Default)]
pub(crate) struct EdgeFindings {
    pub(crate) edge_count: usize,
    pub(crate) boundary: Vec<Element>,
    pub(crate) non_manifold: Vec<Element>,
    pub(crate) conflicts: Vec<Element>,
    pub(crate) conflict_count: usize,
}

/// The state of the walk over the rings.
struct Walk {
    tallies: VertexTallies,
    /// The current vertex's defects, pushed to `tallies.irregular` when it is done.
    current: EdgeTally,
    comp: Dsu,
    boundary_vertices: Option<(Dsu, Vec<bool>)>,
    /// Vertices where two corners have the same two neighbours: where duplicate faces can be.
    duplicate_candidates: Vec<u32>,
    found: EdgeFindings,
    /// Scratch for the general path, reused across vertices.
    sides: Vec<u64>,
    local: Dsu,
    keys: Vec<u64>,
}

impl Walk {
    /// Records the edge `{v, x}` (with `v < x`) and its sides: `fwd` run `v → x`, `bwd` run `x → v`.
    fn edge(&mut self, v: u32, x: u32, fwd: usize, bwd: usize) {
        self.tallies.edges[v as usize] += 1;
        self.found.edge_count += 1;
        self.comp.union(v as usize, x as usize);
        if fwd == 1 && bwd == 1 {
            return;
        }
        let e = Element::Edge(v, x);
        let t = &mut self.current;
        match fwd + bwd {
            1 => {
                t.boundary += 1;
                self.found.boundary.push(e);
                let n = self.tallies.edges.len();
                let (dsu, on) = self.boundary_vertices.get_or_insert_with(|| (Dsu::new(n), vec![false; n]));
                dsu.union(v as usize, x as usize);
                on[v as usize] = true;
                on[x as usize] = true;
            }
            2 => {}
            _ => {
                t.non_manifold += 1;
                self.found.non_manifold.push(e);
            }
        }
        let c = usize::from(fwd > 1) + usize::from(bwd > 1);
        if c > 0 {
            t.conflicts += c as u32;
            self.found.conflicts.push(e);
            self.found.conflict_count += c;
        }
    }
}

/// Calls `body(face index, face)` for every face; with `K > 0` every face has `K` corners, which
/// the compiler then knows.
#[allow(clippy::inline_always)] // Measured: without it the face passes are not specialised.
#[inline(always)]
fn for_each_face<const K: usize>(faces: &FaceList, mut body: impl FnMut(usize, &[u32])) {
    let idx = faces.indices();
    if K == 0 {
        for (f, w) in faces.offsets().windows(2).enumerate() {
            body(f, &idx[w[0] as usize..w[1] as usize]);
        }
    } else {
        for (f, face) in idx.chunks_exact(K.max(1)).enumerate() {
            body(f, face);
        }
    }
}

/// 3 or 4 when every face has that many corners, else 0.
pub(crate) fn arity(faces: &FaceList) -> usize {
    let corners = faces.corner_count();
    if corners == 3 * faces.len() && faces.all_triangles() {
        3
    } else if corners == 4 * faces.len() && faces.all_quads() {
        4
    } else {
        0
    }
}

/// Runs `for_each_face` with the face size fixed where the mesh allows (see [`arity`]).
macro_rules! faces_by_arity {
    ($faces:expr, $arity:expr, $body:expr) => {{
        match $arity {
            3 => for_each_face::<3>($faces, $body),
            4 => for_each_face::<4>($faces, $body),
            _ => for_each_face::<0>($faces, $body),
        }
    }};
}

/// The checks whose findings are plain lists of faces or vertices, each ascending.
pub(crate) struct ElementChecks {
    /// Faces of fewer than 3 vertices.
    pub(crate) short: Vec<u32>,
    /// Faces with an index out of range.
    pub(crate) range: Vec<u32>,
    /// Faces repeating a vertex.
    pub(crate) degenerate: Vec<u32>,
    /// Usable faces of zero area.
    pub(crate) zero_area: Vec<u32>,
    pub(crate) non_finite: Vec<u32>,
    pub(crate) unused: Vec<u32>,
    pub(crate) duplicate_vertices: Vec<u32>,
}

impl ElementChecks {
    /// Sets their counts and adds their findings.
    pub(crate) fn report(self, n: usize, counts: &mut Counts, out: &mut Collector) {
        let faces = |l: &[u32]| l.iter().map(|&f| Element::Face(f)).collect::<Vec<_>>();
        let vertices = |l: &[u32]| l.iter().map(|&v| Element::Vertex(v)).collect::<Vec<_>>();
        counts.short_faces = self.short.len();
        counts.out_of_range_faces = self.range.len();
        counts.degenerate_faces = self.degenerate.len();
        counts.zero_area_faces = self.zero_area.len();
        counts.non_finite_vertices = self.non_finite.len();
        counts.unused_vertices = self.unused.len();
        counts.duplicate_vertices = self.duplicate_vertices.len();
        let lists = [
            (Code::FaceSize, faces(&self.short), format!("faces with fewer than 3 vertices: {}", self.short.len())),
            (
                Code::IndexRange,
                faces(&self.range),
                format!("faces referring to vertices beyond the {n} that exist: {}", self.range.len()),
            ),
            (
                Code::DegenerateFace,
                faces(&self.degenerate),
                format!("faces repeating a vertex: {}", self.degenerate.len()),
            ),
            (Code::ZeroAreaFace, faces(&self.zero_area), format!("faces of zero area: {}", self.zero_area.len())),
            (
                Code::NonFiniteVertex,
                vertices(&self.non_finite),
                format!("vertices with NaN or infinite coordinates: {}", self.non_finite.len()),
            ),
            (Code::UnusedVertex, vertices(&self.unused), format!("vertices used by no face: {}", self.unused.len())),
            (
                Code::DuplicateVertex,
                vertices(&self.duplicate_vertices),
                format!("vertices at the exact position of an earlier vertex: {}", self.duplicate_vertices.len()),
            ),
        ];
        for (code, elements, message) in lists {
            let count = elements.len();
            out.add(code, elements, count, message);
        }
    }
}

/// Runs every check on `mesh` (already welded if asked).
pub(crate) fn check(mesh: &Mesh, opts: &ValidateOptions, welded_vertices: usize) -> MeshReport {
    check_with(mesh, opts, welded_vertices, false)
}

/// [`check`], optionally with every vertex through the general path (for the tests). One pass
/// per check, in report order; the passes share the face-usability and ring arrays.
pub(crate) fn check_with(
    mesh: &Mesh,
    opts: &ValidateOptions,
    welded_vertices: usize,
    general_only: bool,
) -> MeshReport {
    let n = mesh.vertex_count();
    let faces = &mesh.faces;
    let arity = arity(faces);
    let mut counts = Counts::default();
    let mut out = Collector { cap: opts.max_elements, findings: Vec::new() };
    let FacePass { usable, ring_end } = face_checks(mesh, arity, &mut counts, &mut out);
    let (ring, ring_start) = rings(faces, arity, &usable, ring_end);
    let walk = walk_rings(n, &ring, &ring_start, general_only);
    drop(ring);
    let Walk { tallies, mut comp, boundary_vertices, duplicate_candidates, found, .. } = walk;
    let dup_faces = duplicate_faces(faces, &usable, n, &duplicate_candidates);
    let edge_count = found.edge_count;
    report_edges(n, &dup_faces, found, &tallies, boundary_vertices, &mut counts, &mut out);

    // Components: vertices joined through edges.
    let used: Vec<bool> = ring_start.windows(2).map(|w| w[1] > w[0]).collect();
    let components = components(faces, arity, Some(&ring_start), &usable, &used, &mut comp, &tallies);
    let used_count = used.iter().filter(|&&u| u).count();
    let checked_faces = usable.iter().filter(|&&u| u).count();
    let euler = used_count as i64 - edge_count as i64 + checked_faces as i64;
    finish(mesh, opts, &usable, counts, out, welded_vertices, edge_count, euler, components)
}

/// What the face-level pass hands on: `usable[f]` marks the faces that take part in the topology,
/// `ring_end[v]` counts vertex `v`'s corners among them (`n + 1` entries, the last 0).
struct FacePass {
    usable: Vec<bool>,
    ring_end: Vec<u32>,
}

/// The face- and vertex-level checks (short, out-of-range, degenerate and zero-area faces;
/// non-finite, unused and duplicate vertices), reported; the same pass counts each vertex's
/// corners.
fn face_checks(mesh: &Mesh, arity: usize, counts: &mut Counts, out: &mut Collector) -> FacePass {
    let n = mesh.vertex_count();
    let faces = &mesh.faces;
    let p = &mesh.vertices.positions;
    let mut usable = vec![true; faces.len()];
    let (mut short, mut range, mut degen, mut zero) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut ring_end = vec![0u32; n + 1];
    faces_by_arity!(faces, arity, |f, face: &[u32]| {
        if face.len() < 3 {
            short.push(f as u32);
            usable[f] = false;
        } else if face.iter().any(|&i| i as usize >= n) {
            range.push(f as u32);
            usable[f] = false;
        } else if has_repeat(face) {
            // Reported, and kept out of the topology: a face like [a, b, b] has no area, and its
            // sides would make a spurious non-manifold edge a-b.
            degen.push(f as u32);
            usable[f] = false;
        } else {
            for &i in face {
                ring_end[i as usize] += 1;
            }
            if zero_area(p, face) {
                zero.push(f as u32);
            }
        }
    });
    let unused: Vec<u32> = (0..n as u32).filter(|&v| ring_end[v as usize] == 0).collect();
    let (non_finite, duplicate_vertices) = vertex_checks(p);
    ElementChecks { short, range, degenerate: degen, zero_area: zero, non_finite, unused, duplicate_vertices }
        .report(n, counts, out);
    FacePass { usable, ring_end }
}

/// The rings: a counting sort of the usable faces' corners by vertex, each corner as its
/// (previous, next) vertex pair. After the running sum `ring_end[v]` is the end of v's ring;
/// filling each ring from its end leaves it at the ring's start, so the returned
/// `ring_start[v]..ring_start[v + 1]` is v's ring (and `ring_start[n]` the total). The ring array
/// is padded so that every ring can be read as a window of `SHORT_RING` entries.
fn rings(faces: &FaceList, arity: usize, usable: &[bool], mut ring_end: Vec<u32>) -> (Vec<RingEntry>, Vec<u32>) {
    let n = ring_end.len() - 1;
    for v in 0..n {
        ring_end[v + 1] += ring_end[v];
    }
    let mut ring: Vec<RingEntry> = vec![[0; 2]; ring_end[n] as usize + SHORT_RING];
    {
        let fill = &mut ring_end[..n];
        faces_by_arity!(faces, arity, |f, face: &[u32]| {
            if !usable[f] {
                return;
            }
            let k = face.len();
            let mut prev = face[k - 1];
            for (j, &v) in face.iter().enumerate() {
                let next = face[if j + 1 == k { 0 } else { j + 1 }];
                let slot = &mut fill[v as usize];
                *slot -= 1;
                ring[*slot as usize] = [prev, next];
                prev = v;
            }
        });
    }
    (ring, ring_end)
}

/// Walks every vertex's ring: edges (valence, orientation), fans, components, duplicate-face
/// candidates. A regular ring takes the fast path unless `general_only`.
fn walk_rings(n: usize, ring: &[RingEntry], ring_start: &[u32], general_only: bool) -> Walk {
    let mut walk = Walk {
        tallies: VertexTallies { edges: vec![0; n], irregular: Vec::new(), non_manifold: Vec::new() },
        current: EdgeTally::default(),
        comp: Dsu::new(n),
        boundary_vertices: None,
        duplicate_candidates: Vec::new(),
        found: EdgeFindings::default(),
        sides: Vec::new(),
        local: Dsu::new(0),
        keys: Vec::new(),
    };
    for v in 0..n {
        let (a, b) = (ring_start[v] as usize, ring_start[v + 1] as usize);
        let r = &ring[a..b];
        let window: &[RingEntry; SHORT_RING] = ring[a..a + SHORT_RING].try_into().expect("the ring is padded");
        if r.is_empty() {
            continue;
        }
        let v = v as u32;
        if general_only || !regular_ring(v, r, window, &mut walk) {
            general_ring(v, r, &mut walk);
        }
        if walk.current != EdgeTally::default() {
            walk.tallies.irregular.push((v, std::mem::take(&mut walk.current)));
        }
    }
    walk
}

/// Reports what the ring walk found: duplicate faces, non-manifold edges, orientation conflicts,
/// non-manifold vertices, and boundary edges with their loops (connected chains of boundary
/// edges).
pub(crate) fn report_edges(
    n: usize,
    dup_faces: &[u32],
    found: EdgeFindings,
    tallies: &VertexTallies,
    boundary_vertices: Option<(Dsu, Vec<bool>)>,
    counts: &mut Counts,
    out: &mut Collector,
) {
    counts.duplicate_faces = dup_faces.len();
    out.add(
        Code::DuplicateFace,
        dup_faces.iter().map(|&f| Element::Face(f)),
        dup_faces.len(),
        format!("faces repeating an earlier face (same vertex cycle, either way round): {}", dup_faces.len()),
    );
    counts.boundary_edges = found.boundary.len();
    counts.non_manifold_edges = found.non_manifold.len();
    counts.orientation_conflicts = found.conflict_count;
    out.add(
        Code::NonManifoldEdge,
        found.non_manifold.iter().copied(),
        found.non_manifold.len(),
        format!("edges shared by more than two faces: {}", found.non_manifold.len()),
    );
    let conflict_edges = found.conflicts.len();
    out.add(
        Code::Orientation,
        found.conflicts,
        counts.orientation_conflicts,
        format!(
            "directed edges used by two faces, where neighbours disagree on orientation: {} (on {conflict_edges} edge(s))",
            counts.orientation_conflicts
        ),
    );
    let nm_vertices = &tallies.non_manifold;
    counts.non_manifold_vertices = nm_vertices.len();
    out.add(
        Code::NonManifoldVertex,
        nm_vertices.iter().map(|&v| Element::Vertex(v)),
        nm_vertices.len(),
        format!("vertices joining more than one fan of faces: {}", nm_vertices.len()),
    );
    counts.boundary_loops = match boundary_vertices {
        Some((mut dsu, on)) => (0..n).filter(|&v| on[v] && dsu.find(v) == v).count(),
        None => 0,
    };
    let loops = counts.boundary_loops;
    out.add(
        Code::BoundaryEdge,
        found.boundary.iter().copied(),
        found.boundary.len(),
        format!("boundary edges: {}, in {loops} loop(s) (holes or borders)", found.boundary.len()),
    );
}

/// Properties, the optional self-intersection test, and the sorted findings: the end of a check.
#[allow(clippy::too_many_arguments)]
pub(crate) fn finish(
    mesh: &Mesh,
    opts: &ValidateOptions,
    usable: &[bool],
    mut counts: Counts,
    mut out: Collector,
    welded_vertices: usize,
    edges: usize,
    euler_characteristic: i64,
    components: Vec<Component>,
) -> MeshReport {
    let manifold = counts.short_faces == 0
        && counts.out_of_range_faces == 0
        && counts.non_manifold_edges == 0
        && counts.non_manifold_vertices == 0;
    let mut properties = Properties {
        manifold,
        oriented: manifold && counts.orientation_conflicts == 0,
        closed: counts.boundary_edges == 0,
        watertight: manifold && counts.boundary_edges == 0,
        clean: counts.non_finite_vertices == 0
            && counts.degenerate_faces == 0
            && counts.zero_area_faces == 0
            && counts.duplicate_faces == 0,
        intersection_free: None,
    };
    if opts.self_intersections {
        let pairs = crate::intersect::self_intersections(mesh, usable);
        counts.self_intersections = Some(pairs.len());
        properties.intersection_free = Some(pairs.is_empty());
        out.add(
            Code::SelfIntersection,
            pairs.iter().map(|&(f, g)| Element::Faces(f, g)),
            pairs.len(),
            format!("pairs of intersecting faces: {}", pairs.len()),
        );
    }
    let mut findings = out.findings;
    findings.sort_by_key(|f| (f.severity, Code::ALL.iter().position(|c| *c == f.code)));
    MeshReport {
        vertices: mesh.vertex_count(),
        faces: mesh.faces.len(),
        edges,
        welded_vertices,
        euler_characteristic,
        counts,
        properties,
        components,
        findings,
    }
}

/// Decides a regular vertex: stepping from each corner to the corner whose outgoing edge is its
/// incoming edge walks the whole ring, either round (an interior vertex) or from the one corner
/// whose outgoing edge is a boundary to the one whose incoming edge is (a boundary vertex). The
/// step is taken to the *first* such corner and must never reach a corner twice; that alone
/// proves every neighbour is the next vertex of at most one corner and the previous vertex of at
/// most one, so the vertex has one fan and each of its edges one side, or two of opposite
/// directions. Returns false, having recorded nothing, for any other vertex.
fn regular_ring(v: u32, r: &[RingEntry], window: &[RingEntry; SHORT_RING], walk: &mut Walk) -> bool {
    let k = r.len();
    if k > LANES {
        return false;
    }
    if closed_fan(r, window) {
        // An interior vertex: every neighbour is the next vertex of one corner and the previous
        // vertex of another, so each edge has two sides of opposite directions.
        let mut interior = 0;
        for &[_, x] in r {
            if x > v {
                interior += 1;
                walk.comp.union(v as usize, x as usize);
            }
        }
        walk.tallies.edges[v as usize] += interior;
        walk.found.edge_count += interior as usize;
        if k == 2 {
            walk.duplicate_candidates.push(v);
        }
        return true;
    }
    let mut across = [NONE; LANES];
    let (mut reached, mut open_in) = (0u32, NONE);
    for (i, e) in r.iter().enumerate() {
        match r.iter().position(|o| o[1] == e[0]) {
            Some(j) => {
                if reached & 1 << j != 0 {
                    return false;
                }
                reached |= 1 << j;
                across[i] = j as u8;
            }
            None if open_in == NONE => open_in = i as u8,
            None => return false,
        }
    }
    // With an open incoming edge, exactly one corner is never reached: the walk starts there,
    // and its outgoing edge must be no corner's incoming edge.
    let first = if open_in == NONE {
        0
    } else {
        let f = (!reached).trailing_zeros() as usize;
        let x = r[f][1];
        if r.iter().any(|o| o[0] == x) {
            return false;
        }
        f
    };
    let (mut i, mut seen) = (first, 1);
    loop {
        let j = across[i];
        if j == NONE || usize::from(j) == first {
            break;
        }
        i = usize::from(j);
        seen += 1;
    }
    if seen != k {
        return false;
    }
    // Edges at their smaller vertex: every next vertex (two sides, but one for the boundary's
    // outgoing edge), and the boundary's incoming edge, whose vertex is no next vertex. Boundary
    // edges are recorded in increasing order of the other vertex, as the report lists them.
    let (b_in, b_out) = if open_in == NONE { (0, 0) } else { (r[usize::from(open_in)][0], r[first][1]) };
    let mut interior = 0;
    for &[_, x] in r {
        if x > v && (open_in == NONE || x != b_out) {
            interior += 1;
            walk.comp.union(v as usize, x as usize);
        }
    }
    walk.tallies.edges[v as usize] += interior;
    walk.found.edge_count += interior as usize;
    if open_in != NONE {
        let mut open = [(b_in, 0, 1), (b_out, 1, 0)];
        open.sort_unstable();
        for (x, fwd, bwd) in open {
            if x > v {
                walk.edge(v, x, fwd, bwd);
            }
        }
    } else if k == 2 {
        // Two faces with one cycle share all their vertices; at a regular vertex they can only
        // be its two faces (a third face would leave a second fan).
        walk.duplicate_candidates.push(v);
    }
    true
}

/// Whether stepping from corner 0 to the first corner across its incoming edge comes back to
/// corner 0 after exactly `r.len()` steps, and never earlier: the common case of an interior
/// vertex, told with one search per corner. The steps then visit every corner once (a corner
/// reached twice would repeat the steps after it and never come back to corner 0), so the step
/// is a one-to-one map of the corners onto themselves. Since it goes to the *first* matching
/// corner, no two corners share a next vertex (the later one could not be reached) and, being
/// one-to-one, no two share a previous vertex: one fan, each edge with two opposite sides.
///
/// `window` is the ring followed by whatever comes after it, `SHORT_RING` entries in all. A ring
/// that fits is searched by comparing all its next vertices at once (two SSE2 compares): on
/// scanned meshes, whose neighbours come in no fixed order, a search that stops at the match
/// mispredicts its exit at almost every corner.
fn closed_fan(r: &[RingEntry], window: &[RingEntry; SHORT_RING]) -> bool {
    let k = r.len();
    if k > SHORT_RING {
        return closed_fan_long(r);
    }
    // Lanes hold vertex indices; the cast to i32 keeps equality.
    let next = i32x8::new(std::array::from_fn(|j| window[j][1] as i32));
    let live = (1u32 << k) - 1;
    let mut i = 0;
    for step in 1..=k {
        let prev = i32x8::splat(r[i][0] as i32);
        let m = next.cmp_eq(prev).move_mask() as u32 & live;
        if m == 0 {
            return false;
        }
        i = m.trailing_zeros() as usize;
        if i == 0 {
            return step == k;
        }
    }
    false
}

/// [`closed_fan`] for rings of more than [`SHORT_RING`] corners.
fn closed_fan_long(r: &[RingEntry]) -> bool {
    let mut i = 0;
    for step in 1..=r.len() {
        let prev = r[i][0];
        match r.iter().position(|o| o[1] == prev) {
            Some(0) => return step == r.len(),
            Some(j) => i = j,
            None => return false,
        }
    }
    false
}

/// Decides any vertex: sorts the edge sides of the ring by neighbour, records the edges at their
/// smaller vertex, and counts fans as the classes of corners joined through shared edges.
fn general_ring(v: u32, r: &[RingEntry], walk: &mut Walk) {
    let k = r.len();
    // A side as (neighbour, direction, corner position in the ring): v → x first.
    let mut sides = std::mem::take(&mut walk.sides);
    sides.clear();
    for (i, &[prev, next]) in r.iter().enumerate() {
        sides.push(u64::from(next) << 32 | i as u64);
        sides.push(u64::from(prev) << 32 | 1 << 31 | i as u64);
    }
    sides.sort_unstable();
    walk.local.reset(k);
    let mut a = 0;
    while a < sides.len() {
        let x = (sides[a] >> 32) as u32;
        let mut b = a + 1;
        while b < sides.len() && (sides[b] >> 32) as u32 == x {
            b += 1;
        }
        let group = &sides[a..b];
        for w in group.windows(2) {
            walk.local.union((w[0] & 0x7fff_ffff) as usize, (w[1] & 0x7fff_ffff) as usize);
        }
        if v < x {
            let bwd = group.iter().filter(|&&s| s & 1 << 31 != 0).count();
            walk.edge(v, x, group.len() - bwd, bwd);
        }
        a = b;
    }
    walk.sides = sides;
    if (0..k).filter(|&i| walk.local.find(i) == i).count() > 1 {
        walk.tallies.non_manifold.push(v);
    }
    // Duplicate faces: two corners with the same two neighbours, in either order.
    let mut keys = std::mem::take(&mut walk.keys);
    keys.clear();
    keys.extend(r.iter().map(|&[a, b]| u64::from(a.min(b)) << 32 | u64::from(a.max(b))));
    keys.sort_unstable();
    if keys.windows(2).any(|w| w[0] == w[1]) {
        walk.duplicate_candidates.push(v);
    }
    walk.keys = keys;
}

/// The faces that repeat the cycle of an earlier face (same vertex cycle, from any corner, either
/// way round), ascending. Two such faces meet at each of their vertices with the same two
/// neighbours, so only the faces at the `candidates` the walk found are compared.
fn duplicate_faces(faces: &FaceList, usable: &[bool], n: usize, candidates: &[u32]) -> Vec<u32> {
    if candidates.is_empty() {
        return Vec::new();
    }
    let mut is_candidate = vec![false; n];
    for &v in candidates {
        is_candidate[v as usize] = true;
    }
    // (vertex, smaller neighbour, larger neighbour, face) for every corner at a candidate.
    let mut corners: Vec<(u32, u32, u32, u32)> = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        if !usable[f] {
            continue;
        }
        let k = face.len();
        for j in 0..k {
            let v = face[j];
            if is_candidate[v as usize] {
                let (a, b) = (face[(j + k - 1) % k], face[(j + 1) % k]);
                corners.push((v, a.min(b), a.max(b), f as u32));
            }
        }
    }
    corners.sort_unstable();
    let mut dups = Vec::new();
    let mut cycles: Vec<(Vec<u32>, u32)> = Vec::new();
    for group in corners.chunk_by(|x, y| (x.0, x.1, x.2) == (y.0, y.1, y.2)) {
        if group.len() < 2 {
            continue;
        }
        cycles.clear();
        cycles.extend(group.iter().map(|c| (canonical_cycle(faces.face(c.3 as usize)), c.3)));
        cycles.sort_unstable();
        dups.extend(cycles.windows(2).filter(|w| w[0].0 == w[1].0).map(|w| w[1].1));
    }
    dups.sort_unstable();
    dups.dedup();
    dups
}

/// The face's cycle from its smallest vertex, toward the smaller of that vertex's two neighbours:
/// equal for two faces exactly when they are the same cycle up to rotation and reversal.
fn canonical_cycle(face: &[u32]) -> Vec<u32> {
    let n = face.len();
    let s = (0..n).min_by_key(|&i| face[i]).unwrap_or(0);
    let (fwd, bwd) = (face[(s + 1) % n], face[(s + n - 1) % n]);
    if fwd <= bwd {
        (0..n).map(|i| face[(s + i) % n]).collect()
    } else {
        (0..n).map(|i| face[(s + n - i) % n]).collect()
    }
}

pub(crate) fn has_repeat(face: &[u32]) -> bool {
    if let &[a, b, c] = face {
        a == b || b == c || a == c
    } else if face.len() <= 8 {
        face.iter().enumerate().any(|(i, a)| face[i + 1..].contains(a))
    } else {
        let mut s = face.to_vec();
        s.sort_unstable();
        s.windows(2).any(|w| w[0] == w[1])
    }
}

/// Zero area by the vector area (Newell's method), relative to the face's squared size, so the
/// test does not depend on the model's units.
#[allow(clippy::inline_always)] // Measured: not inlined into the face pass otherwise.
#[inline(always)]
pub(crate) fn zero_area(p: &[DVec3], face: &[u32]) -> bool {
    if let &[a, b, c] = face {
        let o = p[a as usize];
        let (a, b) = (p[b as usize] - o, p[c as usize] - o);
        let size2 = a.length_squared().max(b.length_squared());
        return a.cross(b).length().partial_cmp(&(size2 * 1e-12)) != Some(std::cmp::Ordering::Greater);
    }
    let o = p[face[0] as usize];
    let mut area = octowrap_geom::DVec3::ZERO;
    let mut size2 = 0.0f64;
    for k in 1..face.len() - 1 {
        let a = p[face[k] as usize] - o;
        let b = p[face[k + 1] as usize] - o;
        area += a.cross(b);
        size2 = size2.max(a.length_squared()).max(b.length_squared());
    }
    // Written so that NaN areas count as zero.
    area.length().partial_cmp(&(size2 * 1e-12)) != Some(std::cmp::Ordering::Greater)
}

/// The vertices with a NaN or infinite coordinate, and those at the bit-exact position
/// (`-0.0 = 0.0`) of an earlier vertex (NaN positions never match), each ascending, from one pass
/// over the positions and a second over the few that may repeat. The first pass marks the hash
/// slots that more than one vertex falls in (two bit sets of about eight bits per vertex, so
/// they stay in cache); the second collects the vertices in such slots, a small fraction, with
/// their hashes, and only those go through an exact hash table sized for them at once.
pub(crate) fn vertex_checks(p: &[DVec3]) -> (Vec<u32>, Vec<u32>) {
    let key = |v: DVec3| [v.x + 0.0, v.y + 0.0, v.z + 0.0].map(f64::to_bits);
    // A multiply-xorshift mix: every input bit reaches the high bits and, by the shift, the low
    // bits the table uses.
    let hash = |[x, y, z]: [u64; 3]| {
        let h = (x ^ y.rotate_left(21) ^ z.rotate_left(42)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        h ^ h >> 29
    };
    let bits = (p.len() * 8).next_power_of_two().max(64);
    let slot = |h: u64| (h as usize & (bits - 1), 1u64 << (h & 63));
    let (mut seen, mut shared) = (vec![0u64; bits / 64], vec![0u64; bits / 64]);
    let (mut any_shared, mut non_finite) = (false, Vec::new());
    for (i, v) in p.iter().enumerate() {
        if !v.is_finite() {
            non_finite.push(i as u32);
            if v.is_nan() {
                continue;
            }
        }
        let (s, b) = slot(hash(key(*v)));
        let again = seen[s >> 6] & b;
        any_shared |= again != 0;
        shared[s >> 6] |= again;
        seen[s >> 6] |= b;
    }
    drop(seen);
    let mut dups = Vec::new();
    if !any_shared {
        return (non_finite, dups);
    }
    let mut candidates: Vec<(u64, u32)> = Vec::new();
    for (i, v) in p.iter().enumerate() {
        if !v.is_nan() {
            let h = hash(key(*v));
            let (s, b) = slot(h);
            if shared[s >> 6] & b != 0 {
                candidates.push((h, i as u32));
            }
        }
    }
    drop(shared);
    let mut table = hashbrown::HashTable::<(u64, u32)>::with_capacity(candidates.len());
    for (h, i) in candidates {
        let k = key(p[i as usize]);
        match table.entry(h, |&(g, j)| g == h && key(p[j as usize]) == k, |&(g, _)| g) {
            hashbrown::hash_table::Entry::Occupied(_) => dups.push(i),
            hashbrown::hash_table::Entry::Vacant(e) => {
                e.insert((h, i));
            }
        }
    }
    (non_finite, dups)
}

/// The components, largest first. With `rings` (each vertex's ring offsets) and all faces of
/// `arity` corners, a component's faces are its corners over `arity`; otherwise they are counted
/// face by face.
pub(crate) fn components(
    faces: &FaceList,
    arity: usize,
    rings: Option<&[u32]>,
    usable: &[bool],
    used: &[bool],
    comp: &mut Dsu,
    tallies: &VertexTallies,
) -> Vec<Component> {
    let n = used.len();
    // Dense component ids in order of first vertex, for determinism.
    let mut id = vec![u32::MAX; n];
    let mut list: Vec<Component> = Vec::new();
    for v in 0..n {
        if !used[v] {
            continue;
        }
        let r = comp.find(v);
        if id[r] == u32::MAX {
            id[r] = list.len() as u32;
            list.push(Component {
                faces: 0,
                vertices: 0,
                edges: 0,
                boundary_edges: 0,
                euler_characteristic: 0,
                closed_manifold: true,
                oriented: true,
                genus: None,
            });
        }
        id[v] = id[r];
        let c = &mut list[id[r] as usize];
        c.vertices += 1;
        c.edges += tallies.edges[v] as usize;
        if let Some(rings) = rings {
            c.faces += (rings[v + 1] - rings[v]) as usize;
        }
    }
    for &(v, t) in &tallies.irregular {
        let c = &mut list[id[v as usize] as usize];
        c.boundary_edges += t.boundary as usize;
        c.oriented &= t.conflicts == 0;
        c.closed_manifold &= t.non_manifold == 0;
    }
    for &v in &tallies.non_manifold {
        list[id[v as usize] as usize].closed_manifold = false;
    }
    if let (Some(_), 3 | 4) = (rings, arity) {
        for c in &mut list {
            c.faces /= arity;
        }
    } else {
        for c in &mut list {
            c.faces = 0;
        }
        faces_by_arity!(faces, arity, |f, face: &[u32]| {
            if usable[f] {
                list[id[face[0] as usize] as usize].faces += 1;
            }
        });
    }
    let mut out: Vec<Component> = list
        .into_iter()
        .map(|mut c| {
            c.euler_characteristic = c.vertices as i64 - c.edges as i64 + c.faces as i64;
            c.closed_manifold &= c.boundary_edges == 0;
            if c.closed_manifold && c.oriented && c.euler_characteristic % 2 == 0 {
                c.genus = Some((2 - c.euler_characteristic) / 2);
            }
            c
        })
        .collect();
    out.sort_by_key(|c| std::cmp::Reverse(c.faces));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference;
    use octowrap_geom::DVec3;
    use octowrap_mesh::FaceList;
    use proptest::prelude::*;

    /// A mesh of random polygons over few vertices, so that every pathology turns up: shared
    /// edges of any valence, both orientations, fans touching at a vertex, duplicate and repeated
    /// faces, indices out of range, coincident and non-finite vertices.
    fn arb_mesh() -> impl Strategy<Value = Mesh> {
        (4u32..14, prop::collection::vec((3usize..6, any::<u64>()), 0..40), any::<u64>()).prop_map(|(n, fs, seed)| {
            let mut rng = octowrap_geom::SplitMix64::new(seed);
            let pos: Vec<DVec3> = (0..n)
                .map(|_| match rng.next_u64() % 14 {
                    0 => DVec3::ZERO,
                    1 => DVec3::new(f64::NAN, 0.0, 0.0),
                    2 => DVec3::new(-0.0, 0.0, -0.0),
                    3 => DVec3::new(f64::INFINITY, 1.0, 0.0),
                    _ => DVec3::new(
                        (rng.next_u64() % 5) as f64,
                        (rng.next_u64() % 5) as f64,
                        (rng.next_u64() % 3) as f64,
                    ),
                })
                .collect();
            let mut faces = FaceList::default();
            for (len, s) in fs {
                let mut r = octowrap_geom::SplitMix64::new(s);
                let range = if r.next_u64() % 20 == 0 { n + 2 } else { n };
                let face: Vec<u32> = (0..len).map(|_| (r.next_u64() % u64::from(range)) as u32).collect();
                faces.push(&face);
                // Often repeat a face, either way round, to make duplicates and pillows.
                match r.next_u64() % 6 {
                    0 => faces.push(&face),
                    1 => faces.push(&face.iter().rev().copied().collect::<Vec<_>>()),
                    _ => {}
                }
            }
            let mut m = Mesh::from_positions(pos);
            m.faces = faces;
            m
        })
    }

    /// A triangulated torus, or a cylinder (open at both ends) when `open`.
    fn torus(nu: u32, nv: u32, open: bool) -> Mesh {
        if open {
            octowrap_mesh::shapes::triangulated_grid(nu, nv, [false, true], |u, v| {
                let a = v * std::f64::consts::TAU;
                DVec3::new(a.cos(), a.sin(), u)
            })
        } else {
            octowrap_mesh::shapes::torus(nu, nv, 2.0, 0.7)
        }
    }

    fn all_paths_agree(m: &Mesh) {
        let opts = ValidateOptions::default();
        let fast = check_with(m, &opts, m.vertex_count(), false);
        let general = check_with(m, &opts, m.vertex_count(), true);
        let plain = reference::check(m, &opts, m.vertex_count());
        assert_eq!(fast, general, "regular-vertex path differs from the general path");
        assert_eq!(fast, plain, "ring walk differs from the plain edge-sorting implementation");
    }

    #[test]
    fn regular_meshes_take_the_fast_path_and_agree() {
        for open in [false, true] {
            let m = torus(12, 9, open);
            all_paths_agree(&m);
            let r = check(&m, &ValidateOptions::default(), m.vertex_count());
            assert!(r.properties.manifold && r.properties.oriented);
            assert_eq!(r.properties.closed, !open);
            assert_eq!(r.counts.boundary_loops, if open { 2 } else { 0 });
        }
    }

    /// The vertex checks at a size where the bit sets pass on a fraction of the vertices, against
    /// a plain ordered map: repeats near and far from their first copy, signed zeros, NaN and
    /// infinities.
    #[test]
    fn vertex_checks_agree_with_a_plain_map() {
        let mut rng = octowrap_geom::SplitMix64::new(11);
        let mut p: Vec<DVec3> =
            (0..200_000).map(|_| DVec3::new(rng.f64(), rng.f64(), (rng.next_u64() % 1000) as f64)).collect();
        for i in (0..p.len()).step_by(97) {
            let from = rng.below(p.len());
            p[i] = p[from];
        }
        p[5] = DVec3::new(0.0, -0.0, 0.0);
        p[6] = DVec3::new(-0.0, 0.0, 0.0);
        p[7] = DVec3::new(f64::NAN, 0.0, 0.0);
        p[8] = DVec3::new(f64::NAN, 0.0, 0.0);
        p[9] = DVec3::new(f64::NEG_INFINITY, 0.0, 0.0);
        p[10] = DVec3::new(f64::NEG_INFINITY, 0.0, 0.0);
        let (non_finite, dups) = vertex_checks(&p);
        let mut first = std::collections::BTreeMap::new();
        let plain: Vec<u32> = (0..p.len() as u32)
            .filter(|&v| {
                let q = p[v as usize];
                !q.is_nan() && first.insert([q.x + 0.0, q.y + 0.0, q.z + 0.0].map(f64::to_bits), v).is_some()
            })
            .collect();
        assert!(plain.len() > 2000, "the case has repeats: {}", plain.len());
        assert!(plain.contains(&6) && plain.contains(&10) && !plain.contains(&8));
        assert_eq!(dups, plain);
        assert_eq!(non_finite, vec![7, 8, 9, 10]);
    }

    /// Rings short enough for the vector search and longer ones: a double cone whose two apexes
    /// have `sides` neighbours; closed, with two faces moved onto a second top apex (two open
    /// fans), with the apexes pinched into one vertex of two closed fans, and with a face flipped.
    #[test]
    fn fans_of_every_valence_agree() {
        for sides in 3u32..=20 {
            let (top, bottom) = (sides, sides + 1);
            let mut pos: Vec<DVec3> = (0..sides)
                .map(|i| {
                    let a = f64::from(i) * std::f64::consts::TAU / f64::from(sides);
                    DVec3::new(a.cos(), a.sin(), 0.0)
                })
                .collect();
            pos.extend([DVec3::Z, -DVec3::Z]);
            let mut faces: Vec<[u32; 3]> = Vec::new();
            for i in 0..sides {
                let j = (i + 1) % sides;
                faces.push([i, j, top]);
                faces.push([j, i, bottom]);
            }
            let build = |faces: &[[u32; 3]], pos: &[DVec3]| {
                let mut m = Mesh::from_positions(pos.to_vec());
                for f in faces {
                    m.faces.push(f);
                }
                m
            };
            let closed = build(&faces, &pos);
            all_paths_agree(&closed);
            let r = check(&closed, &ValidateOptions::default(), closed.vertex_count());
            assert!(r.properties.watertight && r.properties.oriented, "{sides} sides");
            assert_eq!(r.components[0].genus, Some(0));

            // Two top faces moved onto a second apex at the same place: the top ring splits in two.
            let mut split = faces.clone();
            pos.push(DVec3::Z);
            split[0][2] = sides + 2;
            split[2][2] = sides + 2;
            let m = build(&split, &pos);
            all_paths_agree(&m);
            assert!(!check(&m, &ValidateOptions::default(), m.vertex_count()).properties.closed, "{sides} sides");

            // A second double cone whose top apex is the first one's: a vertex of two closed fans.
            let copy = sides + 3;
            let mut pinched = faces.clone();
            pinched.extend(faces.iter().map(|f| f.map(|i| if i == top { top } else { i + copy })));
            let mut twice = pos.clone();
            twice.extend(pos.iter().map(|p| *p + DVec3::X * 3.0));
            let m = build(&pinched, &twice);
            all_paths_agree(&m);
            let r = check(&m, &ValidateOptions::default(), m.vertex_count());
            assert_eq!(r.counts.non_manifold_vertices, 1, "{sides} sides");
            assert_eq!((r.counts.non_manifold_edges, r.counts.boundary_edges), (0, 0), "{sides} sides");

            let mut flipped = faces.clone();
            flipped[1].swap(0, 1);
            let m = build(&flipped, &pos);
            all_paths_agree(&m);
            let r = check(&m, &ValidateOptions::default(), m.vertex_count());
            assert!(r.properties.watertight && !r.properties.oriented, "{sides} sides");
        }
    }

    #[test]
    fn a_two_face_pillow_is_a_closed_sphere_of_duplicate_faces() {
        let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::Y]);
        m.faces = FaceList::from_triangles(&[[0, 1, 2], [2, 1, 0]]);
        all_paths_agree(&m);
        let r = check(&m, &ValidateOptions::default(), 3);
        assert!(r.properties.watertight && r.properties.oriented);
        assert_eq!(r.counts.duplicate_faces, 1);
        assert_eq!(r.components[0].genus, Some(0));
    }

    /// A torus, triangulated or in quads, with random faces removed (holes, borders, vertices
    /// where two holes touch), flipped (orientation conflicts) or repeated: mostly regular
    /// vertices with defects among them, where the fast path must stop exactly where it should.
    fn arb_damaged_torus() -> impl Strategy<Value = Mesh> {
        (3u32..9, 3u32..8, any::<bool>(), any::<u64>()).prop_map(|(nu, nv, quads, seed)| {
            let mut m = torus(nu, nv, false);
            let mut rng = octowrap_geom::SplitMix64::new(seed);
            let rate = rng.below(5);
            let source: Vec<Vec<u32>> = if quads {
                m.faces.iter().collect::<Vec<_>>().chunks(2).map(|t| vec![t[0][0], t[0][1], t[0][2], t[1][2]]).collect()
            } else {
                m.faces.iter().map(<[u32]>::to_vec).collect()
            };
            let mut faces = FaceList::default();
            for mut f in source {
                match rng.below(24) {
                    x if x < rate => continue,
                    5 => f.reverse(),
                    6 => faces.push(&f),
                    7 => faces.push(&f.iter().rev().copied().collect::<Vec<_>>()),
                    _ => {}
                }
                faces.push(&f);
            }
            m.faces = faces;
            m
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        #[test]
        fn ring_walk_matches_on_damaged_surfaces(m in arb_damaged_torus()) {
            all_paths_agree(&m);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn ring_walk_matches_the_plain_implementation(m in arb_mesh()) {
            all_paths_agree(&m);
        }
    }
}
