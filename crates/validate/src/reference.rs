//! The plain implementation the ring walk of [`crate::check`] is tested against (compiled for the
//! tests only).
//!
//! Edges are found by bucketing half-edges on their smaller vertex (a counting sort, O(corners)),
//! then sorting each small bucket; fans by union-find over face corners joined across shared
//! edges; components by union-find over vertices joined by faces. Everything is deterministic:
//! no hash-map order reaches the report.

use octowrap_mesh::Mesh;

use crate::check::{
    Collector, EdgeFindings, EdgeTally, ElementChecks, VertexTallies, components, finish, has_repeat, report_edges,
    zero_area,
};
use crate::report::{Counts, Element, MeshReport};
use crate::{ValidateOptions, dsu::Dsu};

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

/// Runs every check on `mesh` (already welded if asked). One pass per check, in report order;
/// the passes share the face-usability, edge and union-find arrays.
pub(crate) fn check(mesh: &Mesh, opts: &ValidateOptions, welded_vertices: usize) -> MeshReport {
    let n = mesh.vertex_count();
    let faces = &mesh.faces;
    let mut counts = Counts::default();
    let mut out = Collector { cap: opts.max_elements, findings: Vec::new() };
    let (usable, used) = element_checks(mesh, &mut counts, &mut out);
    let (starts, sides) = half_edges(mesh, &usable);
    let Edges {
        count,
        boundary,
        nm_edges,
        conflicts,
        conflict_count,
        mut corners,
        mut comp,
        duplicate,
        boundary_vertices,
        is_boundary_vertex,
        edges_at,
    } = walk_edges(mesh, &starts, sides);
    let dup_faces: Vec<u32> = (0..faces.len() as u32).filter(|&f| duplicate[f as usize]).collect();
    let tallies = VertexTallies {
        edges: edges_at.iter().map(|t| t.0).collect(),
        irregular: (0..n as u32)
            .filter(|&v| edges_at[v as usize].1 != EdgeTally::default())
            .map(|v| (v, edges_at[v as usize].1))
            .collect(),
        non_manifold: non_manifold_vertices(mesh, &usable, &mut corners),
    };
    let found = EdgeFindings { edge_count: count, boundary, non_manifold: nm_edges, conflicts, conflict_count };
    report_edges(n, &dup_faces, found, &tallies, Some((boundary_vertices, is_boundary_vertex)), &mut counts, &mut out);
    let components = components(faces, crate::check::arity(faces), None, &usable, &used, &mut comp, &tallies);

    let used_count = used.iter().filter(|&&u| u).count();
    let checked_faces = usable.iter().filter(|&&u| u).count();
    let euler = used_count as i64 - count as i64 + checked_faces as i64;
    finish(mesh, opts, &usable, counts, out, welded_vertices, count, euler, components)
}

/// The face- and vertex-level checks, reported; returns which faces take part in the topology
/// and which vertices they use.
fn element_checks(mesh: &Mesh, counts: &mut Counts, out: &mut Collector) -> (Vec<bool>, Vec<bool>) {
    let n = mesh.vertex_count();
    let faces = &mesh.faces;
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
    ElementChecks { short, range, degenerate: degen, zero_area, non_finite, unused, duplicate_vertices }
        .report(n, counts, out);
    (usable, used)
}

/// The usable faces' half-edges bucketed by their smaller vertex (a counting sort): bucket `v` is
/// `sides[starts[v]..starts[v + 1]]`.
fn half_edges(mesh: &Mesh, usable: &[bool]) -> (Vec<u32>, Vec<Side>) {
    let n = mesh.vertex_count();
    let idx = mesh.faces.indices();
    let offs = mesh.faces.offsets();
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
    (starts, sides)
}

/// What the edge walk finds.
struct Edges {
    count: usize,
    boundary: Vec<Element>,
    nm_edges: Vec<Element>,
    conflicts: Vec<Element>,
    /// Directed edges used twice in the same direction.
    conflict_count: usize,
    /// Face corners joined across shared edges (their classes are fans).
    corners: Dsu,
    /// Vertices joined by edges.
    comp: Dsu,
    duplicate: Vec<bool>,
    /// Vertices joined by boundary edges, and which vertices have one.
    boundary_vertices: Dsu,
    is_boundary_vertex: Vec<bool>,
    /// Per vertex, the edges at it as their smaller vertex and their defects.
    edges_at: Vec<(u32, EdgeTally)>,
}

/// Walks the edges bucket by bucket: valence, orientation, fan unions, components, duplicate
/// faces.
fn walk_edges(mesh: &Mesh, starts: &[u32], mut sides: Vec<Side>) -> Edges {
    let n = mesh.vertex_count();
    let faces = &mesh.faces;
    let mut e = Edges {
        count: 0,
        boundary: Vec::new(),
        nm_edges: Vec::new(),
        conflicts: Vec::new(),
        conflict_count: 0,
        corners: Dsu::new(faces.indices().len()),
        comp: Dsu::new(n),
        duplicate: vec![false; faces.len()],
        boundary_vertices: Dsu::new(n),
        is_boundary_vertex: vec![false; n],
        edges_at: vec![(0u32, EdgeTally::default()); n],
    };
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
            let edge = Element::Edge(lo as u32, hi);
            e.comp.union(lo, hi as usize);
            if group.len() > 1 {
                mark_duplicates(group, faces, &mut e.duplicate);
            }
            e.count += 1;
            e.edges_at[lo].0 += 1;
            match group.len() {
                1 => {
                    e.boundary.push(edge);
                    e.edges_at[lo].1.boundary += 1;
                    e.is_boundary_vertex[lo] = true;
                    e.is_boundary_vertex[hi as usize] = true;
                    e.boundary_vertices.union(lo, hi as usize);
                }
                2 => {}
                _ => {
                    e.nm_edges.push(edge);
                    e.edges_at[lo].1.non_manifold += 1;
                }
            }
            let fwd = group.iter().filter(|s| s.forward).count();
            let bwd = group.len() - fwd;
            let c = usize::from(fwd > 1) + usize::from(bwd > 1);
            if c > 0 {
                e.conflicts.push(edge);
                e.conflict_count += c;
                e.edges_at[lo].1.conflicts += c as u32;
            }
            for w in group.windows(2) {
                e.corners.union(w[0].corner_lo as usize, w[1].corner_lo as usize);
                e.corners.union(w[0].corner_hi as usize, w[1].corner_hi as usize);
            }
            i = j;
        }
    }
    e
}

/// Fans: a used vertex is manifold when all its corners join into one fan. Returns the vertices
/// with more than one.
fn non_manifold_vertices(mesh: &Mesh, usable: &[bool], corners: &mut Dsu) -> Vec<u32> {
    let n = mesh.vertex_count();
    let idx = mesh.faces.indices();
    let mut fans = vec![0u32; n];
    for (f, w) in mesh.faces.offsets().windows(2).enumerate() {
        if usable[f] {
            for c in w[0] as usize..w[1] as usize {
                if corners.find(c) == c {
                    fans[idx[c] as usize] += 1;
                }
            }
        }
    }
    (0..n as u32).filter(|&v| fans[v as usize] > 1).collect()
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
