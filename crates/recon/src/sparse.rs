//! Sparse data (Keller et al., §4.2): where the sampling density stops supporting refinement, fix
//! the topology and continue by subdivision plus vertex mapping.
//!
//! Reading: the paper notes that beyond "a point density induced threshold" the mesh fragments
//! (Fig. 8(b)) and suggests fixing the topology at a coarser level, then subdividing and mapping.
//! It gives no threshold. We trust a level's topology while the median number of points per
//! occupied voxel is at least [`crate::ReconOptions::min_median_points`] (default 8: a plane fit
//! needs 3 points, and the 3x3x3 sheet of [`crate::sheet`] needs a few per voxel to orient; on
//! the bunny the median falls about 4x per level, 13 at level 5 and 3 at level 6, where the
//! wrapped mesh starts to fragment). [`crate::MaxLevel::Auto`] stops at the last trusted level.
//! Deeper levels asked for are made by splitting every quad into four (shared edge midpoints and a
//! face point; child `i` covers the parent's quadrant `i` and starts at the parent's corner `i`;
//! vertices numbered along the Morton curve of their lattice corners), so
//! faces grow exactly 4x and the topology stays manifold; every vertex is then mapped again
//! ([`crate::mapping::map_free`]). [`crate::SparseMode::Wrap`] wraps such levels anyway.

use octowrap_geom::{DVec3, morton};
use octowrap_mesh::{FaceOrigin, Quadrant};
use rayon::prelude::*;

use crate::lattice::{axis, corner_offset, plane_axes, sign, slot, unslot};

/// A subdivided level's connectivity.
#[derive(Debug, Default)]
pub(crate) struct Subdivided {
    /// Quads, four per parent face, in parent order.
    pub quads: Vec<[u32; 4]>,
    /// Lattice corner of every vertex (at the new level).
    pub corners: Vec<[u32; 3]>,
    /// Slot of every face: the parent quadrant's outer child voxel and the parent's side.
    pub slots: Vec<u64>,
    /// Parent and quadrant of every face.
    pub origins: Vec<FaceOrigin>,
    /// Initial positions: parents kept, edge and face points at midpoints and centroids.
    pub positions: Vec<DVec3>,
}

/// Splits every quad into four.
pub(crate) fn subdivide(quads: &[[u32; 4]], corners: &[[u32; 3]], slots: &[u64], positions: &[DVec3]) -> Subdivided {
    // Face edges `4 f + k` grouped by their smaller vertex (a counting sort, stable), then by the
    // larger one within each group: the order of sorting `(min, max, 4 f + k)`, in O(n) and with
    // 8 bytes per face edge.
    let ends = |f: usize, k: usize| {
        let (a, b) = (quads[f][k], quads[f][(k + 1) % 4]);
        (a.min(b), a.max(b))
    };
    let mut first = vec![0u32; corners.len() + 1];
    for f in 0..quads.len() {
        for k in 0..4 {
            first[ends(f, k).0 as usize + 1] += 1;
        }
    }
    for i in 0..corners.len() {
        first[i + 1] += first[i];
    }
    let mut edges = vec![(0u32, 0u32); 4 * quads.len()];
    {
        let mut fill = first.clone();
        for f in 0..quads.len() {
            for k in 0..4 {
                let (a, b) = ends(f, k);
                edges[fill[a as usize] as usize] = (b, (4 * f + k) as u32);
                fill[a as usize] += 1;
            }
        }
    }
    for w in first.windows(2) {
        edges[w[0] as usize..w[1] as usize].sort_unstable();
    }
    // Edge point of every face edge.
    let mut edge_vertex = vec![0u32; 4 * quads.len()];
    // At most one edge point per face edge and one face point per face: reserved up front so
    // that the vectors never move (pages reserved but never written are not resident).
    let most = corners.len() + 5 * quads.len();
    let mut out_corners: Vec<[u32; 3]> = Vec::with_capacity(most);
    out_corners.par_extend(corners.par_iter().map(|c| c.map(|x| 2 * x)));
    let mut out_pos: Vec<DVec3> = Vec::with_capacity(most);
    out_pos.par_extend(positions.par_iter().copied());
    for (a, w) in first.windows(2).enumerate() {
        let group = &edges[w[0] as usize..w[1] as usize];
        let mut i = 0;
        while i < group.len() {
            let b = group[i].0;
            let id = out_corners.len() as u32;
            let (ca, cb) = (corners[a], corners[b as usize]);
            out_corners.push([ca[0] + cb[0], ca[1] + cb[1], ca[2] + cb[2]]);
            out_pos.push((positions[a] + positions[b as usize]) * 0.5);
            while i < group.len() && group[i].0 == b {
                edge_vertex[group[i].1 as usize] = id;
                i += 1;
            }
        }
    }
    drop(edges);
    drop(first);
    // Face points, then four children per face (in parallel: the face point of face `f` is
    // vertex `base + f`, so the numbering does not depend on the order of work).
    let base = out_corners.len() as u32;
    out_corners.par_extend(quads.par_iter().map(|q| {
        let c: [[u32; 3]; 4] = q.map(|v| corners[v as usize]);
        std::array::from_fn(|a| (c[0][a] + c[1][a] + c[2][a] + c[3][a]) / 2)
    }));
    out_pos.par_extend(quads.par_iter().map(|q| q.iter().map(|&v| positions[v as usize]).sum::<DVec3>() * 0.25));
    let mut quads_out: Vec<[u32; 4]> = vec![[0; 4]; 4 * quads.len()];
    quads_out.par_chunks_mut(4).zip(quads.par_iter()).enumerate().for_each(|(f, (out, q))| {
        let centre = base + f as u32;
        let ev = &edge_vertex[4 * f..4 * f + 4];
        for (k, o) in out.iter_mut().enumerate() {
            *o = [q[k], ev[k], centre, ev[(k + 3) % 4]];
        }
    });
    drop(edge_vertex);
    let mut slots_out: Vec<u64> = vec![0; 4 * slots.len()];
    slots_out.par_chunks_mut(4).zip(slots.par_iter()).for_each(|(out, &s)| {
        let (code, d) = unslot(s);
        let pc = morton::decode(code);
        let a = axis(d);
        let (b, cax) = plane_axes(a);
        for (k, o) in out.iter_mut().enumerate() {
            let off = corner_offset(d, k);
            let mut child = pc.map(|x| 2 * x);
            child[b] += off[0];
            child[cax] += off[1];
            child[a] += u32::from(sign(d) > 0);
            *o = slot(morton::encode(child[0], child[1], child[2]), d);
        }
    });
    let origins: Vec<FaceOrigin> = (0..4 * quads.len())
        .into_par_iter()
        .map(|i| FaceOrigin::Subface { parent: (i / 4) as u32, quadrant: Quadrant((i % 4) as u8) })
        .collect();
    // Number the vertices along the Morton curve of their lattice corners, so that the mapping,
    // which visits them in order, queries nearby voxels one after the other.
    let mut order: Vec<(u64, u32)> =
        out_corners.par_iter().enumerate().map(|(i, c)| (morton::encode(c[0], c[1], c[2]), i as u32)).collect();
    // Corners of this level have up to `level + 1` bits per axis.
    let bits = out_corners.iter().flatten().fold(0u32, |a, &b| a | b);
    crate::octree::sort_codes(&mut order, 3 * (32 - bits.leading_zeros()));
    let mut rank = vec![0u32; order.len()];
    for (new, &(_, old)) in order.iter().enumerate() {
        rank[old as usize] = new as u32;
    }
    // Each copy in turn, its source freed at once (this is the peak of a subdivided level).
    let new_corners: Vec<[u32; 3]> = order.par_iter().map(|&(_, old)| out_corners[old as usize]).collect();
    drop(out_corners);
    let new_positions: Vec<DVec3> = order.par_iter().map(|&(_, old)| out_pos[old as usize]).collect();
    drop(out_pos);
    drop(order);
    quads_out.par_iter_mut().for_each(|q| *q = q.map(|v| rank[v as usize]));
    Subdivided { quads: quads_out, corners: new_corners, slots: slots_out, origins, positions: new_positions }
}
