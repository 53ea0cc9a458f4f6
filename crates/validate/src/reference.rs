//! The plain implementation the ring walk of [`crate::check`] is tested against (compiled for the
//! tests only).
//!
//! Edges are found by bucketing half-edges on their smaller vertex (a counting sort, O(corners)),
//! then sorting each small bucket; fans by union-find over face corners joined across shared
//! edges; components by union-find over vertices joined by faces. Everything is deterministic:
//! no hash-map order reaches the report.

use octowrap_mesh::Mesh;

use crate::check::{Collector, EdgeTally, ElementChecks, VertexTallies, components, finish, has_repeat, zero_area};
use crate::report::{Code, Counts, Element, MeshReport};
use crate::{Options, dsu::Dsu};

/// One face side of an edge: the corner where it starts and whether it runs from the smaller
/// vertex to the larger.
#[derive(Clone, Copy)]
struct Side {
    other: u32,
    face: u32,
    forward: bool,
    /// Corner index (into the face list's index array) of the side's smaller vertex.
    corner_lo: u32,
    /// Corner index of the larger vertex.
    corner_hi: u32,
}

/// Runs every check on `mesh` (already welded if asked). One pass per check, in report order; the
/// passes share the face-usability, edge and union-find arrays, hence one long function.
#[allow(clippy::too_many_lines)]
pub(crate) fn check(mesh: &Mesh, opts: &Options, welded_vertices: usize) -> MeshReport {
    let n = mesh.vertex_count();
    let faces = &mesh.faces;
    let idx = faces.indices();
    let offs = faces.offsets();
    let mut counts = Counts::default();
    let mut out = Collector { cap: opts.max_elements, findings: Vec::new() };

    // Face-level checks; `usable[f]` marks faces that take part in the topology.
    let mut usable = vec![true; faces.len()];
    let (mut short, mut range, mut degen) = (Vec::new(), Vec::new(), Vec::new());
    for (f, face) in faces.iter().enumerate() {
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
        }
    }
    let non_finite: Vec<u32> = (0..n as u32).filter(|&v| !mesh.vertices.positions[v as usize].is_finite()).collect();
    let mut used = vec![false; n];
    for (f, face) in faces.iter().enumerate() {
        if usable[f] {
            for &i in face {
                used[i as usize] = true;
            }
        }
    }
    let unused: Vec<u32> = (0..n as u32).filter(|&v| !used[v as usize]).collect();
    // The plain way: the first vertex at each exact position (`-0.0 = 0.0`, NaN never equal).
    let mut first = std::collections::BTreeMap::new();
    let duplicate_vertices: Vec<u32> = (0..n as u32)
        .filter(|&v| {
            let q = mesh.vertices.positions[v as usize];
            !q.is_nan() && first.insert([q.x + 0.0, q.y + 0.0, q.z + 0.0].map(f64::to_bits), v).is_some()
        })
        .collect();
    let zero_area: Vec<u32> = (0..faces.len())
        .filter(|&f| usable[f] && zero_area(&mesh.vertices.positions, faces.face(f)))
        .map(|f| f as u32)
        .collect();
    ElementChecks { short, range, degenerate: degen, zero_area, non_finite, unused, duplicate_vertices }.report(
        n,
        &mut counts,
        &mut out,
    );
    // Half-edges bucketed by their smaller vertex.
    let mut bucket_len = vec![0u32; n + 1];
    for (f, w) in offs.windows(2).enumerate() {
        if !usable[f] {
            continue;
        }
        let (s, e) = (w[0] as usize, w[1] as usize);
        for c in s..e {
            let (a, b) = (idx[c], idx[if c + 1 == e { s } else { c + 1 }]);
            if a != b {
                bucket_len[a.min(b) as usize + 1] += 1;
            }
        }
    }
    for v in 0..n {
        bucket_len[v + 1] += bucket_len[v];
    }
    let starts = bucket_len;
    let mut fill = starts.clone();
    let mut sides = vec![Side { other: 0, face: 0, forward: false, corner_lo: 0, corner_hi: 0 }; starts[n] as usize];
    for (f, w) in offs.windows(2).enumerate() {
        if !usable[f] {
            continue;
        }
        let (s, e) = (w[0] as usize, w[1] as usize);
        for c in s..e {
            let c2 = if c + 1 == e { s } else { c + 1 };
            let (a, b) = (idx[c], idx[c2]);
            if a == b {
                continue;
            }
            let (lo, hi, forward, clo, chi) = if a < b { (a, b, true, c, c2) } else { (b, a, false, c2, c) };
            let slot = &mut fill[lo as usize];
            sides[*slot as usize] =
                Side { other: hi, face: f as u32, forward, corner_lo: clo as u32, corner_hi: chi as u32 };
            *slot += 1;
        }
    }

    // Walk edges: valence, orientation, fan unions, components, duplicate faces.
    let mut corners = Dsu::new(idx.len());
    let mut comp = Dsu::new(n);
    let mut duplicate = vec![false; faces.len()];
    let mut boundary_vertices = Dsu::new(n);
    let mut is_boundary_vertex = vec![false; n];
    let (mut boundary, mut nm_edges, mut conflicts) = (Vec::new(), Vec::new(), Vec::new());
    let mut edge_count = 0usize;
    // Per-vertex edge data for the components, keyed by the edge's smaller vertex.
    let mut edges_at = vec![(0u32, EdgeTally::default()); n];
    for lo in 0..n {
        let bucket = &mut sides[starts[lo] as usize..starts[lo + 1] as usize];
        sort_sides(bucket);
        let mut i = 0;
        while i < bucket.len() {
            let hi = bucket[i].other;
            let mut j = i;
            while j < bucket.len() && bucket[j].other == hi {
                j += 1;
            }
            let group = &bucket[i..j];
            let e = Element::Edge(lo as u32, hi);
            comp.union(lo, hi as usize);
            if group.len() > 1 {
                mark_duplicates(group, faces, &mut duplicate);
            }
            edge_count += 1;
            edges_at[lo].0 += 1;
            match group.len() {
                1 => {
                    boundary.push(e);
                    edges_at[lo].1.boundary += 1;
                    is_boundary_vertex[lo] = true;
                    is_boundary_vertex[hi as usize] = true;
                    boundary_vertices.union(lo, hi as usize);
                }
                2 => {}
                _ => {
                    nm_edges.push(e);
                    edges_at[lo].1.non_manifold += 1;
                }
            }
            let fwd = group.iter().filter(|s| s.forward).count();
            let bwd = group.len() - fwd;
            let c = usize::from(fwd > 1) + usize::from(bwd > 1);
            if c > 0 {
                conflicts.push(e);
                counts.orientation_conflicts += c;
                edges_at[lo].1.conflicts += c as u32;
            }
            for w in group.windows(2) {
                corners.union(w[0].corner_lo as usize, w[1].corner_lo as usize);
                corners.union(w[0].corner_hi as usize, w[1].corner_hi as usize);
            }
            i = j;
        }
    }
    let dup_faces: Vec<u32> = (0..faces.len() as u32).filter(|&f| duplicate[f as usize]).collect();
    counts.duplicate_faces = dup_faces.len();
    out.add(
        Code::DuplicateFace,
        dup_faces.iter().map(|&f| Element::Face(f)),
        dup_faces.len(),
        format!("faces repeating an earlier face (same vertex cycle, either way round): {}", dup_faces.len()),
    );
    counts.boundary_edges = boundary.len();
    counts.non_manifold_edges = nm_edges.len();
    out.add(
        Code::NonManifoldEdge,
        nm_edges.iter().copied(),
        nm_edges.len(),
        format!("edges shared by more than two faces: {}", nm_edges.len()),
    );
    let conflict_edges = conflicts.len();
    out.add(
        Code::Orientation,
        conflicts,
        counts.orientation_conflicts,
        format!(
            "directed edges used by two faces, where neighbours disagree on orientation: {} (on {conflict_edges} edge(s))",
            counts.orientation_conflicts
        ),
    );

    // Fans: a used vertex is manifold when all its corners join into one fan.
    let mut fans = vec![0u32; n];
    for (f, w) in offs.windows(2).enumerate() {
        if usable[f] {
            for c in w[0] as usize..w[1] as usize {
                if corners.find(c) == c {
                    fans[idx[c] as usize] += 1;
                }
            }
        }
    }
    let nm_vertices: Vec<u32> = (0..n as u32).filter(|&v| fans[v as usize] > 1).collect();
    counts.non_manifold_vertices = nm_vertices.len();
    out.add(
        Code::NonManifoldVertex,
        nm_vertices.iter().map(|&v| Element::Vertex(v)),
        nm_vertices.len(),
        format!("vertices joining more than one fan of faces: {}", nm_vertices.len()),
    );

    // Boundary loops: connected chains of boundary edges.
    counts.boundary_loops = (0..n).filter(|&v| is_boundary_vertex[v] && boundary_vertices.find(v) == v).count();
    let loops = counts.boundary_loops;
    out.add(
        Code::BoundaryEdge,
        boundary.iter().copied(),
        boundary.len(),
        format!("boundary edges: {}, in {loops} loop(s) (holes or borders)", boundary.len()),
    );

    // Components: vertices joined through edges.
    let tallies = VertexTallies {
        edges: edges_at.iter().map(|t| t.0).collect(),
        irregular: (0..n as u32)
            .filter(|&v| edges_at[v as usize].1 != EdgeTally::default())
            .map(|v| (v, edges_at[v as usize].1))
            .collect(),
        non_manifold: nm_vertices.clone(),
    };
    let components = components(faces, crate::check::arity(faces), None, &usable, &used, &mut comp, &tallies);

    let used_count = used.iter().filter(|&&u| u).count();
    let checked_faces = usable.iter().filter(|&&u| u).count();
    let euler = used_count as i64 - edge_count as i64 + checked_faces as i64;
    finish(mesh, opts, &usable, counts, out, welded_vertices, edge_count, euler, components)
}

/// Sorts one vertex's sides by (other vertex, direction, corner): insertion sort for the usual
/// handful, the standard sort beyond.
fn sort_sides(bucket: &mut [Side]) {
    let key = |s: &Side| (s.other, !s.forward, s.corner_lo);
    if bucket.len() > 16 {
        bucket.sort_unstable_by_key(key);
        return;
    }
    for i in 1..bucket.len() {
        let mut j = i;
        while j > 0 && key(&bucket[j - 1]) > key(&bucket[j]) {
            bucket.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// Marks the faces of an edge's sides that repeat an earlier face: the same vertex cycle, in
/// either direction and from any starting corner. Two such faces share every edge, so each face is
/// compared only at its first edge, with the earlier faces on that edge.
fn mark_duplicates(group: &[Side], faces: &octowrap_mesh::FaceList, duplicate: &mut [bool]) {
    let offs = faces.offsets();
    for x in group {
        let start = if x.forward { x.corner_lo } else { x.corner_hi };
        if start != offs[x.face as usize] || duplicate[x.face as usize] {
            continue;
        }
        let fx = faces.face(x.face as usize);
        if group.iter().any(|y| y.face < x.face && same_cycle(fx, faces.face(y.face as usize))) {
            duplicate[x.face as usize] = true;
        }
    }
}

/// Whether `a` and `b` are the same cycle of vertices, up to rotation and reversal.
fn same_cycle(a: &[u32], b: &[u32]) -> bool {
    let n = a.len();
    if n != b.len() {
        return false;
    }
    let Some(k) = b.iter().position(|&v| v == a[0]) else { return false };
    let forward = (0..n).all(|i| a[i] == b[(k + i) % n]);
    forward || (0..n).all(|i| a[i] == b[(k + n - i) % n])
}
