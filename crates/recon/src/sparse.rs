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
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};

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

/// The edge points of `quads` (over `nv` vertices): per face edge `4 f + k`, its edge point's
/// number, and per edge point, its two ends `(smaller, larger)`; edge points are numbered from `nv`
/// in the order of their ends, and the first one after them is returned too.
fn edge_points(quads: &[[u32; 4]], nv: usize) -> (Vec<u32>, Vec<(u32, u32)>, u32) {
    let nf = quads.len();
    let ends = |q: &[u32; 4], k: usize| {
        let (a, b) = (q[k], q[(k + 1) % 4]);
        (a.min(b), a.max(b))
    };
    // Face edges `4 f + k` grouped by their smaller vertex (a counting sort), then by the larger
    // one and the face edge within each group: the order of sorting `(min, max, 4 f + k)`, in O(n)
    // and with 8 bytes per face edge.
    let first: Vec<u32> = {
        let counts: Vec<AtomicU32> = (0..=nv).into_par_iter().map(|_| AtomicU32::new(0)).collect();
        quads.par_iter().for_each(|q| {
            for k in 0..4 {
                counts[ends(q, k).0 as usize + 1].fetch_add(1, Relaxed);
            }
        });
        let mut first: Vec<u32> = counts.into_iter().map(AtomicU32::into_inner).collect();
        for i in 0..nv {
            first[i + 1] += first[i];
        }
        first
    };
    let group = |a: usize| first[a] as usize..first[a + 1] as usize;
    // `larger << 32 | face edge`, so that sorting the words sorts the pairs.
    let mut edges: Vec<u64> = {
        let fill: Vec<AtomicU32> = first[..nv].par_iter().map(|&f| AtomicU32::new(f)).collect();
        let edges: Vec<AtomicU64> = (0..4 * nf).into_par_iter().map(|_| AtomicU64::new(0)).collect();
        quads.par_iter().enumerate().for_each(|(f, q)| {
            for k in 0..4 {
                let (a, b) = ends(q, k);
                let at = fill[a as usize].fetch_add(1, Relaxed);
                edges[at as usize].store(u64::from(b) << 32 | (4 * f + k) as u64, Relaxed);
            }
        });
        edges.into_iter().map(AtomicU64::into_inner).collect()
    };
    {
        let mut groups: Vec<&mut [u64]> = Vec::with_capacity(nv);
        let mut rest = edges.as_mut_slice();
        for w in first.windows(2) {
            let (here, tail) = rest.split_at_mut((w[1] - w[0]) as usize);
            if here.len() > 1 {
                groups.push(here);
            }
            rest = tail;
        }
        groups.into_par_iter().for_each(<[u64]>::sort_unstable);
    }
    // Edge points: one per distinct `(a, b)`, numbered from `V` in that order.
    let distinct_in = |a: usize| {
        let g = &edges[group(a)];
        g.iter().enumerate().filter(|&(i, e)| i == 0 || e >> 32 != g[i - 1] >> 32).count() as u32
    };
    let mut start: Vec<u32> = (0..nv).into_par_iter().map(distinct_in).collect();
    let mut total = nv as u32;
    for s in &mut start {
        let here = *s;
        *s = total;
        total += here;
    }
    let base = total;
    let edge_vertex: Vec<u32> = {
        let ev: Vec<AtomicU32> = (0..4 * nf).into_par_iter().map(|_| AtomicU32::new(0)).collect();
        (0..nv).into_par_iter().for_each(|a| {
            let g = &edges[group(a)];
            let mut id = start[a];
            for (i, &e) in g.iter().enumerate() {
                if i > 0 && e >> 32 != g[i - 1] >> 32 {
                    id += 1;
                }
                ev[(e & 0xffff_ffff) as usize].store(id, Relaxed);
            }
        });
        ev.into_iter().map(AtomicU32::into_inner).collect()
    };
    let edge_ends: Vec<(u32, u32)> = (0..nv)
        .into_par_iter()
        .flat_map_iter(|a| {
            let g = &edges[group(a)];
            g.iter()
                .enumerate()
                .filter(move |&(i, e)| i == 0 || e >> 32 != g[i - 1] >> 32)
                .map(move |(_, e)| (a as u32, (e >> 32) as u32))
        })
        .collect();
    (edge_vertex, edge_ends, base)
}

/// Splits every quad into four.
///
/// Every step runs in parallel and gives the numbering of the sequential definition: vertices
/// `0..V` are the parents' (corners doubled), then one edge point per distinct edge in the order of
/// `(smaller, larger)` vertex, then one face point per face, and finally all of them renumbered
/// along the Morton curve of their corners (ties in the order of that numbering). Scattered writes
/// (the edges' counting sort, each face edge's edge point, the renumbering) go through atomics, the
/// only way to write to data-dependent places from several threads without `unsafe`; every atomic
/// value is fixed by the input alone (the counting sort's order inside a group is restored by
/// sorting the group), so the output does not depend on the threads.
pub(crate) fn subdivide(quads: &[[u32; 4]], corners: &[[u32; 3]], slots: &[u64], positions: &[DVec3]) -> Subdivided {
    let (nv, nf) = (corners.len(), quads.len());
    let (edge_vertex, edge_ends, base) = edge_points(quads, nv);
    // Four children per face: child `k` starts at the parent's corner `k`; the face point of face
    // `f` is vertex `base + f`.
    let mut quads_out: Vec<[u32; 4]> = vec![[0; 4]; 4 * nf];
    quads_out.par_chunks_mut(4).zip(quads.par_iter()).enumerate().for_each(|(f, (out, q))| {
        let centre = base + f as u32;
        let ev = &edge_vertex[4 * f..4 * f + 4];
        for (k, o) in out.iter_mut().enumerate() {
            *o = [q[k], ev[k], centre, ev[(k + 3) % 4]];
        }
    });
    drop(edge_vertex);
    // Child `k`'s voxel is the parent voxel's child at the parent's corner `k`: the corner's
    // in-plane offset from the voxel, read from its lattice corner (a subdivided parent's quads
    // start at any of their slot's corners, so `k` is not the slot's corner `k`).
    let mut slots_out: Vec<u64> = vec![0; 4 * slots.len()];
    slots_out.par_chunks_mut(4).zip(slots.par_iter().zip(quads.par_iter())).for_each(|(out, (&s, q))| {
        let (code, d) = unslot(s);
        let pc = morton::decode(code);
        let a = axis(d);
        let (b, cax) = plane_axes(a);
        for (k, o) in out.iter_mut().enumerate() {
            let at = corners[q[k] as usize];
            let off = match (at[b].checked_sub(pc[b]), at[cax].checked_sub(pc[cax])) {
                (Some(ob @ 0..=1), Some(oc @ 0..=1)) => [ob, oc],
                _ => corner_offset(d, k),
            };
            let mut child = pc.map(|x| 2 * x);
            child[b] += off[0];
            child[cax] += off[1];
            child[a] += u32::from(sign(d) > 0);
            *o = slot(morton::encode(child[0], child[1], child[2]), d);
        }
    });
    let origins: Vec<FaceOrigin> = (0..4 * nf)
        .into_par_iter()
        .map(|i| FaceOrigin::Subface { parent: (i / 4) as u32, quadrant: Quadrant((i % 4) as u8) })
        .collect();
    // Vertex `i` of the numbering above, without storing it: its corner and initial position
    // (parents kept, edge points at midpoints, face points at centroids).
    let (ne, total) = (edge_ends.len(), base as usize + nf);
    let corner = |i: usize| -> [u32; 3] {
        if i < nv {
            corners[i].map(|x| 2 * x)
        } else if i < nv + ne {
            let (a, b) = edge_ends[i - nv];
            let (ca, cb) = (corners[a as usize], corners[b as usize]);
            [ca[0] + cb[0], ca[1] + cb[1], ca[2] + cb[2]]
        } else {
            let c: [[u32; 3]; 4] = quads[i - nv - ne].map(|v| corners[v as usize]);
            std::array::from_fn(|a| (c[0][a] + c[1][a] + c[2][a] + c[3][a]) / 2)
        }
    };
    let position = |i: usize| -> DVec3 {
        if i < nv {
            positions[i]
        } else if i < nv + ne {
            let (a, b) = edge_ends[i - nv];
            (positions[a as usize] + positions[b as usize]) * 0.5
        } else {
            quads[i - nv - ne].iter().map(|&v| positions[v as usize]).sum::<DVec3>() * 0.25
        }
    };
    // Number the vertices along the Morton curve of their lattice corners, so that the mapping,
    // which visits them in order, queries nearby voxels one after the other.
    // Corners of this level have up to `level + 1` bits per axis: as many as the doubled parent
    // corners (an edge or face point's coordinate is at most twice its largest end's).
    let bits = corners.par_iter().map(|c| c[0] | c[1] | c[2]).reduce(|| 0, |a, b| a | b) << 1;
    let codes: Vec<u64> = (0..total)
        .into_par_iter()
        .map(|i| {
            let c = corner(i);
            morton::encode(c[0], c[1], c[2])
        })
        .collect();
    let order = crate::octree::sort_by_code(&codes, 3 * (32 - bits.leading_zeros()), |i| i as u32);
    drop(codes);
    let rank: Vec<u32> = {
        let rank: Vec<AtomicU32> = (0..total).into_par_iter().map(|_| AtomicU32::new(0)).collect();
        order.par_iter().enumerate().for_each(|(new, &(_, old))| rank[old as usize].store(new as u32, Relaxed));
        rank.into_iter().map(AtomicU32::into_inner).collect()
    };
    let new_corners: Vec<[u32; 3]> = order.par_iter().map(|&(_, old)| corner(old as usize)).collect();
    let new_positions: Vec<DVec3> = order.par_iter().map(|&(_, old)| position(old as usize)).collect();
    drop(order);
    quads_out.par_iter_mut().for_each(|q| *q = q.map(|v| rank[v as usize]));
    Subdivided { quads: quads_out, corners: new_corners, slots: slots_out, origins, positions: new_positions }
}
