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
//! face corners (a compressed list of corner incidences, in face order, 4 bytes per corner), so
//! vertices are relaxed in parallel and every sum is added in the same order whatever the number
//! of threads.

use octowrap_geom::DVec3;
use rayon::prelude::*;

use crate::mapping::TangentPlane;

/// Runs `passes` relaxation passes over the quads.
pub(crate) fn relax(positions: &mut [DVec3], planes: &[Option<TangentPlane>], quads: &[[u32; 4]], passes: u32) {
    if passes == 0 || quads.is_empty() {
        return;
    }
    let n = positions.len();
    // Corner incidences of every vertex (`4 f + k`), in face order.
    let mut first = vec![0u32; n + 1];
    for q in quads {
        for &v in q {
            first[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        first[i + 1] += first[i];
    }
    let mut incidences = vec![0u32; 4 * quads.len()];
    {
        let mut fill = first.clone();
        for (f, q) in quads.iter().enumerate() {
            for (k, &v) in q.iter().enumerate() {
                let at = &mut fill[v as usize];
                incidences[*at as usize] = (4 * f + k) as u32;
                *at += 1;
            }
        }
    }
    let mut next = vec![DVec3::ZERO; n];
    for _ in 0..passes {
        let old: &[DVec3] = positions;
        next.par_iter_mut().enumerate().for_each(|(v, out)| {
            let corners = &incidences[first[v] as usize..first[v + 1] as usize];
            *out = match planes[v] {
                Some(plane) if !corners.is_empty() => {
                    let mut sum = DVec3::ZERO;
                    for &c in corners {
                        let q = &quads[(c / 4) as usize];
                        let k = (c % 4) as usize;
                        sum += old[q[(k + 1) % 4] as usize] + old[q[(k + 3) % 4] as usize];
                    }
                    plane.project(sum / f64::from(2 * corners.len() as u32))
                }
                _ => old[v],
            };
        });
        positions.par_iter_mut().zip(&next).for_each(|(p, q)| *p = *q);
    }
}
