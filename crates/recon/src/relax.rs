//! Relaxation (Keller et al., §3.6.1): Laplacian smoothing, then re-projection.
//!
//! Reading: each pass moves every vertex to the centroid of its one-ring (the vertices it shares
//! an edge with), then projects that centroid onto the vertex's own tangent plane from the
//! mapping (equation (1)); a vertex without a plane (too few points) keeps its place. Passes are
//! synchronous (every vertex reads the previous pass), so the result does not depend on the
//! number of threads. See the crate docs for the measured effect on accuracy and the default.
//!
//! The centroid is summed face by face: every face adds, at each of its corners, the two
//! neighbouring corners. An interior edge lies on two faces, so every neighbour of an interior
//! vertex counts twice and the average is the plain one-ring centroid; at a boundary vertex the
//! two boundary neighbours count once and the others twice. Each vertex pulls these sums from its
//! face corners (a compressed list of its corners' numbers `4 f + k`, in face order, 4 bytes per
//! corner: half the memory of listing the two neighbours, which at the 4.3 M point case's level
//! 10 set the run's peak), so vertices are relaxed in parallel and every sum is added in the same
//! order whatever the number of threads.

use octowrap_geom::DVec3;
use rayon::prelude::*;

use crate::extract::corners_by_vertex;
use crate::mapping::TangentPlane;

/// Runs `passes` relaxation passes over the quads.
pub(crate) fn relax(positions: &mut [DVec3], planes: &[Option<TangentPlane>], quads: &[[u32; 4]], passes: u32) {
    if passes == 0 || quads.is_empty() {
        return;
    }
    let n = positions.len();
    // Every vertex's face corners `4 f + k`, in face order: `corners[first[v]..first[v + 1]]`
    // (4 bytes per corner; each pass reads the two neighbours from the face).
    let (first, corners) = corners_by_vertex(quads, n, |f, k, _| (4 * f + k) as u32);
    let pass = |old: &[DVec3], new: &mut [DVec3]| {
        new.par_iter_mut().enumerate().for_each(|(v, out)| {
            let around = &corners[first[v] as usize..first[v + 1] as usize];
            *out = match planes[v] {
                Some(plane) if !around.is_empty() => {
                    let mut sum = DVec3::ZERO;
                    for &c in around {
                        let (q, k) = (&quads[c as usize / 4], c as usize % 4);
                        sum += old[q[(k + 1) % 4] as usize] + old[q[(k + 3) % 4] as usize];
                    }
                    plane.project(sum / f64::from(2 * around.len() as u32))
                }
                _ => old[v],
            };
        });
    };
    // Passes alternate between the two buffers (no copy back after each pass): pass 1 reads
    // `positions` and writes `next`, pass 2 the other way round; an odd count copies once.
    let mut next = vec![DVec3::ZERO; n];
    for p in 0..passes {
        if p % 2 == 0 {
            pass(positions, &mut next);
        } else {
            pass(&next, positions);
        }
    }
    if passes % 2 == 1 {
        positions.par_iter_mut().zip(&next).for_each(|(p, q)| *p = *q);
    }
}
