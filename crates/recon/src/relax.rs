//! Relaxation (Keller et al., §3.6.1): Laplacian smoothing, then re-projection.
//!
//! Reading: each pass moves every vertex to the centroid of its one-ring (the vertices it shares
//! an edge with), then projects that centroid onto the vertex's own tangent plane from the
//! mapping (equation (1)); a vertex without a plane (too few points) keeps its place. Passes are
//! synchronous (every vertex reads the previous pass), so the result does not depend on the
//! number of threads. See the crate docs for the measured effect on accuracy and the default.

use octowrap_geom::DVec3;
use rayon::prelude::*;

use crate::mapping::TangentPlane;

/// Runs `passes` relaxation passes over the quads.
pub(crate) fn relax(positions: &mut [DVec3], planes: &[Option<TangentPlane>], quads: &[[u32; 4]], passes: u32) {
    if passes == 0 || quads.is_empty() {
        return;
    }
    let n = positions.len();
    let mut edges: Vec<(u32, u32)> =
        quads.iter().flat_map(|q| (0..4).flat_map(move |k| [(q[k], q[(k + 1) % 4]), (q[(k + 1) % 4], q[k])])).collect();
    edges.par_sort_unstable();
    edges.dedup();
    let mut first = vec![0u32; n + 1];
    for &(a, _) in &edges {
        first[a as usize + 1] += 1;
    }
    for i in 0..n {
        first[i + 1] += first[i];
    }
    let mut next = positions.to_vec();
    for _ in 0..passes {
        next.par_iter_mut().enumerate().for_each(|(v, out)| {
            let ring = &edges[first[v] as usize..first[v + 1] as usize];
            let Some(plane) = planes[v] else { return };
            if ring.is_empty() {
                return;
            }
            let c = ring.iter().map(|&(_, w)| positions[w as usize]).sum::<DVec3>() / ring.len() as f64;
            *out = plane.project(c);
        });
        positions.copy_from_slice(&next);
    }
}
