//! Distances between two surfaces: sampled symmetric Hausdorff and RMS distance, in the manner of
//! Metro (Cignoni, Rocchini, Scopigno, "Metro: measuring error on simplified surfaces", 1998).
//!
//! # Definition
//! Both meshes are taken as their triangles ([`Mesh::triangles`]). The samples of a mesh are
//! * every vertex used by a face, and
//! * per triangle `t` of area `Aₜ`, the centroids of the `n²` congruent sub-triangles of its
//!   `n`-fold regular subdivision, `n = ⌈√(S · Aₜ / A)⌉`, where `A` is the total area and `S` is
//!   [`Sampling::samples`]: about `S` samples spread evenly by area, at least one per triangle.
//!   Each carries the weight `Aₜ / n²`.
//!
//! The one-sided distance from `X` to `Y` measures, for every sample `p` of `X`, the exact
//! Euclidean distance `d(p, Y)` to the nearest point of `Y`'s triangles (a bounding-volume
//! hierarchy over `Y`, exact point-triangle distance). Its **maximum** is taken over all samples;
//! its **RMS** is `√(Σ w d² / Σ w)` over the face samples (area-weighted, vertices unweighted).
//! The **symmetric** Hausdorff distance is the larger of the two one-sided maxima, and the
//! symmetric RMS the larger of the two one-sided RMS values (Metro's convention).
//!
//! Sampling is a lower bound on the true Hausdorff distance that tightens as `S` grows.
//! Results are deterministic: samples are generated in face order, distances computed in
//! parallel into an ordered array and summed in order, so the thread count does not change a bit.
//!
//! ```
//! use octowrap_decimate::metrics::{distance, Sampling};
//! use octowrap_mesh::{FaceList, Mesh};
//! use octowrap_geom::DVec3;
//!
//! let square = |z: f64| {
//!     let mut m = Mesh::from_positions(vec![
//!         DVec3::new(0.0, 0.0, z), DVec3::new(1.0, 0.0, z), DVec3::new(1.0, 1.0, z), DVec3::new(0.0, 1.0, z),
//!     ]);
//!     m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
//!     m
//! };
//! let d = distance(&square(0.0), &square(0.25), &Sampling::default());
//! assert!((d.hausdorff - 0.25).abs() < 1e-12);
//! assert!((d.rms - 0.25).abs() < 1e-12);
//! ```

use octowrap_geom::{Aabb, DVec3, morton};
use octowrap_mesh::Mesh;
use rayon::prelude::*;
use serde::Serialize;

pub use crate::hausdorff::Certified;

/// How densely to sample (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Sampling {
    /// Approximate number of area samples per mesh, besides the vertices. Default 200,000.
    pub samples: usize,
}

impl Default for Sampling {
    fn default() -> Self {
        Self { samples: 200_000 }
    }
}

impl Sampling {
    /// About `samples` area samples per mesh.
    pub fn with_samples(samples: usize) -> Self {
        Self { samples }
    }
}

/// Distances from one mesh to another (see the module docs), in the meshes' units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct OneSided {
    /// Largest sample distance.
    pub max: f64,
    /// Area-weighted RMS of the face-sample distances.
    pub rms: f64,
    /// Area-weighted mean of the face-sample distances.
    pub mean: f64,
    /// Samples measured (vertices and face samples).
    pub samples: usize,
}

/// The symmetric distances between two meshes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Distance {
    /// `max(a_to_b.max, b_to_a.max)`.
    pub hausdorff: f64,
    /// `max(a_to_b.rms, b_to_a.rms)`.
    pub rms: f64,
    /// From the first mesh to the second.
    pub a_to_b: OneSided,
    /// From the second mesh to the first.
    pub b_to_a: OneSided,
}

/// The symmetric sampled distance between `a` and `b`. A mesh without faces has no samples and
/// no surface: distances to it are infinite, from it zero.
pub fn distance(a: &Mesh, b: &Mesh, sampling: &Sampling) -> Distance {
    let (ta, tb) = (Triangles::new(a), Triangles::new(b));
    let (ba, bb) = (Bvh::new(&ta), Bvh::new(&tb));
    let a_to_b = one_sided_tris(&ta, &bb, *sampling);
    let b_to_a = one_sided_tris(&tb, &ba, *sampling);
    Distance { hausdorff: a_to_b.max.max(b_to_a.max), rms: a_to_b.rms.max(b_to_a.rms), a_to_b, b_to_a }
}

/// The certified symmetric Hausdorff distance between `a` and `b` (their triangles, as
/// [`Mesh::triangles`] makes them; faces with an index out of range skipped): `lower ≤ true distance ≤ upper`, with
/// `upper ≤ lower · 1.01 + 1e-7 · diagonal` (the diagonal of both meshes' bounding box) unless
/// [`Certified::converged`] is false. Branch and bound over subdivided triangles with exact
/// point-triangle distances: no point of either surface is farther than `upper` from the other,
/// between samples included. Deterministic whatever the thread count. The search and its
/// bounds: `hausdorff.rs`.
pub fn certified_hausdorff(a: &Mesh, b: &Mesh) -> Certified {
    let (pa, pb) = (&a.vertices.positions, &b.vertices.positions);
    // Faces with an index out of range are skipped.
    let (mut ta, mut tb) = (a.triangles(), b.triangles());
    ta.retain(|t| t.iter().all(|&v| (v as usize) < pa.len()));
    tb.retain(|t| t.iter().all(|&v| (v as usize) < pb.len()));
    let mut bounds = Aabb::from_points(ta.iter().flatten().map(|&v| &pa[v as usize]));
    for &v in tb.iter().flatten() {
        bounds.grow(pb[v as usize]);
    }
    let diagonal = if bounds.is_empty() { 0.0 } else { bounds.diagonal() };
    crate::hausdorff::symmetric(pa, &ta, pb, &tb, crate::hausdorff::tolerance(diagonal))
}

/// The one-sided sampled distance from `from` to `to`.
pub fn one_sided(from: &Mesh, to: &Mesh, sampling: &Sampling) -> OneSided {
    let t = Triangles::new(to);
    one_sided_tris(&Triangles::new(from), &Bvh::new(&t), *sampling)
}

fn one_sided_tris(from: &Triangles, to: &Bvh<'_>, sampling: Sampling) -> OneSided {
    let samples = from.samples(sampling.samples);
    // Consecutive samples lie on one triangle or on neighbours: each query starts from the
    // previous one's nearest triangle (the distance found does not depend on the hint). Fixed
    // chunks, not one per thread, keep the work the same whatever the thread count.
    let mut d2 = vec![0.0f64; samples.len()];
    d2.par_chunks_mut(256).zip(samples.par_chunks(256)).for_each(|(out, s)| {
        let mut hint = None;
        for (d, s) in out.iter_mut().zip(s) {
            let (e, t) = to.nearest(s.0, hint);
            *d = e;
            hint = (t != u32::MAX).then_some(t);
        }
    });
    let (mut max2, mut sum2, mut sum1, mut wsum) = (0.0f64, 0.0, 0.0, 0.0);
    for (s, d) in samples.iter().zip(&d2) {
        max2 = max2.max(*d);
        sum2 += s.1 * d;
        sum1 += s.1 * d.sqrt();
        wsum += s.1;
    }
    let (rms, mean) = if wsum > 0.0 { ((sum2 / wsum).sqrt(), sum1 / wsum) } else { (0.0, 0.0) };
    OneSided { max: max2.sqrt(), rms, mean, samples: samples.len() }
}

/// The unsigned distance from each of `points` to the nearest point of `mesh`'s triangles (its
/// faces as [`Mesh::triangles`] splits them; faces with an index out of range skipped), in the
/// order of `points`, in the mesh's units: exact point-triangle distances over the same
/// bounding-volume hierarchy as [`one_sided`]. Every distance is infinite when the mesh has no
/// faces. Deterministic whatever the thread count (each distance is exact; the search's hint,
/// the previous point's nearest triangle, only speeds it up).
///
/// ```
/// use octowrap_decimate::metrics::point_distances;
/// use octowrap_mesh::{FaceList, Mesh};
/// use octowrap_geom::DVec3;
///
/// let mut square = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
/// square.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
/// let d = point_distances(&[DVec3::new(0.5, 0.5, 2.0), DVec3::new(4.0, 0.0, 0.0), DVec3::Y], &square);
/// assert_eq!(d, vec![2.0, 3.0, 0.0]);
/// ```
pub fn point_distances(points: &[DVec3], mesh: &Mesh) -> Vec<f64> {
    let pos = &mesh.vertices.positions;
    let mut tris = mesh.triangles();
    tris.retain(|t| t.iter().all(|&v| (v as usize) < pos.len()));
    let t = Triangles::from_indexed(pos, &tris);
    let bvh = Bvh::new(&t);
    let mut out = vec![0.0f64; points.len()];
    // Fixed chunks (not one per thread), each seeding a query with the previous one's triangle.
    out.par_chunks_mut(256).zip(points.par_chunks(256)).for_each(|(out, p)| {
        let mut hint = None;
        for (d, &p) in out.iter_mut().zip(p) {
            let (e, t) = bvh.nearest(p, hint);
            *d = e.sqrt();
            hint = (t != u32::MAX).then_some(t);
        }
    });
    out
}

/// A mesh's triangles as corner positions.
pub(crate) struct Triangles {
    pub(crate) corners: Vec<[DVec3; 3]>,
    used: Vec<DVec3>,
}

impl Triangles {
    pub(crate) fn new(m: &Mesh) -> Self {
        let p = &m.vertices.positions;
        let at = |i: u32| p.get(i as usize).copied().unwrap_or(DVec3::ZERO);
        let tris = m.triangles();
        let mut seen = vec![false; p.len()];
        for &i in tris.iter().flatten() {
            if let Some(s) = seen.get_mut(i as usize) {
                *s = true;
            }
        }
        let used = p.iter().zip(&seen).filter(|(_, s)| **s).map(|(q, _)| *q).collect();
        Self { corners: tris.iter().map(|t| t.map(at)).collect(), used }
    }

    /// The triangles `tris` over `pos` (indices must be in range).
    pub(crate) fn from_indexed(pos: &[DVec3], tris: &[[u32; 3]]) -> Self {
        Self { corners: tris.iter().map(|t| t.map(|i| pos[i as usize])).collect(), used: Vec::new() }
    }

    #[cfg(test)]
    pub(crate) fn from_corners(corners: Vec<[DVec3; 3]>) -> Self {
        let used = corners.iter().flatten().copied().collect();
        Self { corners, used }
    }

    /// `(point, weight)` samples: the used vertices (weight 0), then the face samples.
    fn samples(&self, budget: usize) -> Vec<(DVec3, f64)> {
        let area = |c: &[DVec3; 3]| 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
        let total: f64 = self.corners.iter().map(area).sum();
        let mut out: Vec<(DVec3, f64)> = self.used.iter().map(|&p| (p, 0.0)).collect();
        for c in &self.corners {
            let a = area(c);
            let n = if total > 0.0 { (budget as f64 * a / total).sqrt().ceil().clamp(1.0, 4096.0) as u32 } else { 1 };
            let w = a / f64::from(n * n);
            let (e1, e2) = ((c[1] - c[0]) / f64::from(n), (c[2] - c[0]) / f64::from(n));
            for i in 0..n {
                for j in 0..n - i {
                    let (fi, fj) = (f64::from(i), f64::from(j));
                    out.push((c[0] + e1 * (fi + 1.0 / 3.0) + e2 * (fj + 1.0 / 3.0), w));
                    if i + j + 1 < n {
                        out.push((c[0] + e1 * (fi + 2.0 / 3.0) + e2 * (fj + 2.0 / 3.0), w));
                    }
                }
            }
        }
        out
    }
}

pub(crate) use octowrap_geom::point_triangle_squared;

/// A bounding-volume hierarchy over triangles: the triangles in Morton order of their centroids,
/// split where the codes' highest differing bit changes, down to leaves of up to 4 triangles.
pub(crate) struct Bvh<'a> {
    tris: &'a Triangles,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

struct Node {
    bounds: Aabb,
    /// Leaf: `first..first + count` in `order`; inner (`count == 0`): children `first`, `first + 1`.
    first: u32,
    count: u32,
}

const LEAF: usize = 4;

/// Fills node `node` over `order[lo..hi]` and its subtree, split where the highest bit of the
/// Morton codes `codes` (sorted, beside `order`) changes, or in halves among equal codes (a
/// linear BVH, Lauterbach et al. 2009); returns its bounds.
fn build(
    tris: &Triangles,
    order: &[u32],
    codes: &[u64],
    nodes: &mut Vec<Node>,
    node: usize,
    lo: usize,
    hi: usize,
) -> Aabb {
    if hi - lo <= LEAF {
        let mut b = Aabb::default();
        for &t in &order[lo..hi] {
            for &p in &tris.corners[t as usize] {
                b.grow(p);
            }
        }
        nodes[node] = Node { bounds: b, first: lo as u32, count: (hi - lo) as u32 };
        return b;
    }
    let first = nodes.len();
    nodes.push(Node { bounds: Aabb::default(), first: 0, count: 0 });
    nodes.push(Node { bounds: Aabb::default(), first: 0, count: 0 });
    let (a, z) = (codes[lo], codes[hi - 1]);
    let mid = if a == z {
        lo + (hi - lo) / 2
    } else {
        let bit = (a ^ z).ilog2();
        lo + codes[lo..hi].partition_point(|&c| c & (1u64 << bit) == 0)
    };
    let mut b = build(tris, order, codes, nodes, first, lo, mid);
    let r = build(tris, order, codes, nodes, first + 1, mid, hi);
    b.grow(r.min);
    b.grow(r.max);
    nodes[node] = Node { bounds: b, first: first as u32, count: 0 };
    b
}

impl<'a> Bvh<'a> {
    pub(crate) fn new(tris: &'a Triangles) -> Self {
        let centroid: Vec<DVec3> = tris.corners.par_iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).collect();
        let bounds = Aabb::from_points(centroid.iter());
        let (lo, size) = (bounds.min, bounds.size().max_element().max(f64::MIN_POSITIVE));
        let cell =
            |x: f64, o: f64| (((x - o) / size) * f64::from(1u32 << 21)).clamp(0.0, f64::from((1u32 << 21) - 1)) as u32;
        let codes: Vec<u64> =
            centroid.par_iter().map(|c| morton::encode(cell(c.x, lo.x), cell(c.y, lo.y), cell(c.z, lo.z))).collect();
        let mut order: Vec<u32> = (0..tris.corners.len() as u32).collect();
        order.par_sort_unstable_by_key(|&t| (codes[t as usize], t));
        let sorted: Vec<u64> = order.iter().map(|&t| codes[t as usize]).collect();
        let mut nodes = vec![Node { bounds: Aabb::default(), first: 0, count: 0 }];
        if !order.is_empty() {
            build(tris, &order, &sorted, &mut nodes, 0, 0, order.len());
        }
        Self { tris, nodes, order }
    }

    /// Squared distance from `p` to the nearest triangle (infinite when there are none).
    #[cfg(test)]
    pub(crate) fn nearest_squared(&self, p: DVec3) -> f64 {
        self.nearest(p, None).0
    }

    /// The squared distance from `p` to the nearest triangle and that triangle's index (infinite
    /// and `u32::MAX` when there are none). `hint`, a triangle likely to be near, only speeds the
    /// search up; ties go to the triangle met first, so the answer is deterministic.
    pub(crate) fn nearest(&self, p: DVec3, hint: Option<u32>) -> (f64, u32) {
        if self.order.is_empty() {
            return (f64::INFINITY, u32::MAX);
        }
        let box2 = |b: &Aabb| {
            let d = (b.min - p).max(p - b.max).max(DVec3::ZERO);
            d.length_squared()
        };
        let (mut best, mut best_tri) = match hint {
            Some(t) if (t as usize) < self.tris.corners.len() => {
                (point_triangle_squared(p, &self.tris.corners[t as usize]), t)
            }
            _ => (f64::INFINITY, u32::MAX),
        };
        // The tree is at most about log2(n) deep and each step pops one node and pushes two.
        let mut stack: [(u32, f64); 96] = [(0, 0.0); 96];
        stack[0] = (0, box2(&self.nodes[0].bounds));
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (i, d) = stack[top];
            if d >= best {
                continue;
            }
            let n = &self.nodes[i as usize];
            if n.count > 0 {
                for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    // The triangle's own box first: it is never farther than the triangle, so a
                    // box at `best` or beyond cannot hold a nearer point.
                    let c = &self.tris.corners[t as usize];
                    let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
                    if (lo - p).max(p - hi).max(DVec3::ZERO).length_squared() >= best {
                        continue;
                    }
                    let e = point_triangle_squared(p, c);
                    if e < best {
                        best = e;
                        best_tri = t;
                    }
                }
                continue;
            }
            let (l, r) = (n.first, n.first + 1);
            let (dl, dr) = (box2(&self.nodes[l as usize].bounds), box2(&self.nodes[r as usize].bounds));
            // Visit the nearer child first: push it last.
            if dl <= dr {
                stack[top] = (r, dr);
                stack[top + 1] = (l, dl);
            } else {
                stack[top] = (l, dl);
                stack[top + 1] = (r, dr);
            }
            top += 2;
        }
        (best, best_tri)
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact results are expected
mod tests {
    use super::*;

    #[test]
    fn point_triangle_regions() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!((point_triangle_squared(DVec3::new(0.2, 0.2, 1.0), &t) - 1.0).abs() < 1e-15);
        assert!((point_triangle_squared(DVec3::new(-1.0, -1.0, 0.0), &t) - 2.0).abs() < 1e-15);
        assert!((point_triangle_squared(DVec3::new(1.0, 1.0, 0.0), &t) - 0.5).abs() < 1e-15);
        assert!((point_triangle_squared(DVec3::new(0.5, -2.0, 0.0), &t) - 4.0).abs() < 1e-15);
        let flat = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert!((point_triangle_squared(DVec3::new(1.0, 1.0, 0.0), &flat) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn point_distances_agree_with_brute_force() {
        let mut rng = octowrap_geom::SplitMix64::new(11);
        let mut r = || rng.f64();
        let positions: Vec<DVec3> = (0..60).map(|_| DVec3::new(r(), r(), r())).collect();
        let quads: Vec<[u32; 4]> = (0..40).map(|i| [i, i + 5, i + 11, i + 19].map(|v| v % 60)).collect();
        let mut mesh = Mesh::from_positions(positions);
        mesh.faces = octowrap_mesh::FaceList::from_quads(&quads);
        let points: Vec<DVec3> = (0..500).map(|_| DVec3::new(r(), r(), r()) * 1.6 - 0.3).collect();
        let got = point_distances(&points, &mesh);
        let tris = Triangles::new(&mesh);
        for (p, d) in points.iter().zip(&got) {
            let brute = tris.corners.iter().map(|c| point_triangle_squared(*p, c)).fold(f64::INFINITY, f64::min);
            assert_eq!(*d, brute.sqrt());
        }
        // The thread count changes no bit.
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        assert_eq!(one.install(|| point_distances(&points, &mesh)), got);
        // No faces (or only faces out of range): no surface, every distance infinite.
        mesh.faces = octowrap_mesh::FaceList::from_quads(&[[0, 1, 99, 98]]);
        assert!(point_distances(&points[..3], &mesh).iter().all(|d| d.is_infinite()));
        assert!(point_distances(&[], &mesh).is_empty());
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        let mut rng = octowrap_geom::SplitMix64::new(7);
        let mut r = || rng.f64();
        let corners: Vec<[DVec3; 3]> = (0..300)
            .map(|_| {
                let c = DVec3::new(r(), r(), r());
                [c, c + DVec3::new(r(), r(), r()) * 0.1, c + DVec3::new(r(), r(), r()) * 0.1]
            })
            .collect();
        let tris = Triangles::from_corners(corners);
        let bvh = Bvh::new(&tris);
        for _ in 0..200 {
            let p = DVec3::new(r(), r(), r()) * 1.4 - 0.2;
            let brute = tris.corners.iter().map(|c| point_triangle_squared(p, c)).fold(f64::INFINITY, f64::min);
            assert_eq!(bvh.nearest_squared(p), brute);
            // Any hint, near or far, leaves the distance exact (the sampled distance seeds
            // each query with the previous one's answer).
            let hint = (r() * 300.0) as u32 % 300;
            assert_eq!(bvh.nearest(p, Some(hint)).0, brute);
        }
    }
}
