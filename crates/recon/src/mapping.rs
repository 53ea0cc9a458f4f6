//! Vertex mapping (Keller et al., §3.6): every vertex moves onto the plane fitted to the points
//! around it.
//!
//! Reading: for a vertex of a wrapped level, `W` is the set of voxels carrying the faces of its
//! fan (so the two sides of a thin part, which are different vertices on the same lattice corner,
//! see different points). `P` is their points within half a voxel edge of the vertex
//! (`2 |p - v| < l`, the paper's filter). With fewer than 3 points, `W` grows by every voxel
//! adjacent to it (sharing a vertex, edge or face, the paper's `W'`), first with the radius
//! doubled to `l` (those points lie in the 2x2x2 voxels around the corner), then without the
//! filter (summing the voxels' moments). The plane is the PCA fit (centroid `c`, normal of the
//! smallest covariance eigenvalue) and the vertex moves to `v - ((v - c) . n) n` (equation (1)).
//! A vertex with fewer than 3 points even then keeps its place. Moments are accumulated relative
//! to the vertex, in `f64`, so the fit does not lose precision at fine levels.
//!
//! Beyond the paper, as an option ([`crate::ReconOptions::quadric_mapping`], off by default):
//! with at least 10 points of `W` within one edge, the vertex goes onto a weighted height-field
//! quadric instead (Gaussian weights of half an edge; a weighted plane, then `z(a, b)` of
//! degree 2 over it by weighted least squares; the vertex moves along the plane normal onto
//! it), which follows curved surfaces between lattice corners better. Big voxels are sampled
//! with a fixed stride (about 256 points). The least-squares fit ([`crate::least_squares`]) moves
//! the vertices afterwards anyway, so the quadric does not pay for its cost by default.
//!
//! Vertices of subdivided levels ([`crate::sparse`]) have no fan voxels of their own. A vertex of
//! subdivided level `k` (voxel edge `l`) goes onto the plane of the points in the 2x2x2
//! level-`k` voxels around the lattice corner nearest to it (a box of `2 l`, centred within
//! `l / 2` of the vertex on every axis), with fewer than 3 points onto that of the 2x2x2
//! level-`k - 1` voxels around their nearest corner (`4 l`). Both come from per-voxel moments
//! ([`crate::cellmoments`], one pass over the points per level), not from the points, which on
//! deep subdivided levels would cost about 50 points per vertex (the 4.3 M-point dragon at level
//! 10). Against the points within `l`, then `2 l`, of the vertex (a ball, point by point), the
//! box moves the bunny's points-to-mesh RMS of the subdivided levels by -20 % to +13 % (finest
//! levels better, the first subdivided level worse; `docs/decisions.md`, "Subdivided levels mapped
//! from per-voxel moments").

use octowrap_geom::glam::Vec3;
use octowrap_geom::{DVec3, Moments, morton};
use rayon::prelude::*;

use crate::cellmoments::{ChildMoments, Units};
use crate::extract::corners_by_vertex;
use crate::lattice::block;
use crate::octree::{Cells, Octree};

/// A fitted tangent plane, in local coordinates, kept compact (`f32`: 2^-24 of the root cube,
/// far below any voxel) for the relaxation; the mapping itself projects in `f64`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TangentPlane {
    point: Vec3,
    normal: Vec3,
}

impl TangentPlane {
    /// A plane through `point` with unit `normal`.
    pub(crate) fn new(point: DVec3, normal: DVec3) -> Self {
        Self { point: point.as_vec3(), normal: normal.as_vec3() }
    }

    /// Where the line through `origin` along unit `dir` meets the plane (its distance from
    /// `origin` along `dir`), unless the line meets it at a grazing angle.
    fn meet(&self, origin: DVec3, dir: DVec3) -> Option<f64> {
        let n = self.normal.as_dvec3();
        let cos = n.dot(dir);
        (cos.abs() >= MIN_LINE_COSINE).then(|| (self.point.as_dvec3() - origin).dot(n) / cos)
    }

    /// Orthogonal projection onto the plane (equation (1)).
    #[inline]
    pub(crate) fn project(&self, v: DVec3) -> DVec3 {
        let n = self.normal.as_dvec3();
        v - n * (v - self.point.as_dvec3()).dot(n)
    }
}

/// The smallest cosine between a vertex's decoder line and its plane's normal for which the
/// vertex goes where the line meets the plane (60 degrees); at more grazing angles it goes to the
/// line's point nearest its orthogonal projection.
const MIN_LINE_COSINE: f64 = 0.5;

/// How far, in voxel edges of the level, a line's meeting point may lie from the orthogonal
/// projection before the line's point nearest that projection is taken instead.
const MAX_LINE_REACH: f64 = 1.5;

/// Normal-mesh mapping (module `lines`): moves every vertex with a decoder line from where the
/// mapping put it (`positions`, each on its plane) to where its line meets its plane, or, at a
/// grazing angle, too far (more than 1.5 `voxel`) or without a plane, to the line's point
/// nearest it. Vertices without a line stay. `lines` is empty or indexed like `positions`.
pub(crate) fn onto_lines(
    positions: &mut [DVec3],
    planes: &[Option<TangentPlane>],
    lines: &[Option<crate::lines::LocalLine>],
    voxel: f64,
) {
    if lines.is_empty() {
        return;
    }
    positions.par_iter_mut().zip(planes).zip(lines).for_each(|((x, plane), line)| {
        let Some(line) = line else { return };
        let met = plane
            .and_then(|p| p.meet(line.origin, line.dir))
            .map(|s| line.origin + line.dir * s)
            .filter(|p| p.is_finite() && p.distance(*x) <= MAX_LINE_REACH * voxel);
        *x = met.unwrap_or_else(|| line.nearest(*x));
    });
}

/// Puts every vertex with a decoder line within `reach` of its line on the line's point nearest
/// it, and takes the line off the others (they keep three components).
pub(crate) fn near_lines(positions: &mut [DVec3], lines: &mut [Option<crate::lines::LocalLine>], reach: f64) {
    positions.par_iter_mut().zip(lines.par_iter_mut()).for_each(|(x, line)| {
        let Some(l) = line else { return };
        let p = l.nearest(*x);
        if p.is_finite() && p.distance(*x) <= reach {
            *x = p;
        } else {
            *line = None;
        }
    });
}

/// The smallest fraction of a face's vector area, measured along its direction before the
/// vertices went onto their lines, that it must keep: less means the lines folded or collapsed it.
const MIN_AREA_KEPT: f64 = 0.1;

/// Takes the line off the vertices whose move onto it (from `before`, the orthogonal mapping)
/// folds, flips or collapses a face (its vector area along its former direction falls below a
/// tenth): per such face, its vertex that moved most goes back to `before` and keeps three
/// components, until no face is folded. Returns the number of vertices freed.
pub(crate) fn free_folding_lines(
    positions: &mut [DVec3],
    before: &[DVec3],
    quads: &[[u32; 4]],
    lines: &mut [Option<crate::lines::LocalLine>],
) -> usize {
    unfold(positions, before, quads, lines, true)
}

/// After the fit's constrained passes (which move every vertex, from `before`, the positions at
/// the snap): per face folded, flipped or collapsed against `before`, its vertex that moved
/// most, with a line or not, goes back to `before` (a line vertex losing its line), until no
/// face is folded. Returns the number of vertices put back.
pub(crate) fn unfold_refit(
    positions: &mut [DVec3],
    before: &[DVec3],
    quads: &[[u32; 4]],
    lines: &mut [Option<crate::lines::LocalLine>],
) -> usize {
    unfold(positions, before, quads, lines, false)
}

/// [`free_folding_lines`] (`only_lines`: only line vertices move back) and [`unfold_refit`].
fn unfold(
    positions: &mut [DVec3],
    before: &[DVec3],
    quads: &[[u32; 4]],
    lines: &mut [Option<crate::lines::LocalLine>],
    only_lines: bool,
) -> usize {
    let area = |p: &[DVec3], q: &[u32; 4]| {
        (0..4).fold(DVec3::ZERO, |s, i| s + p[q[i] as usize].cross(p[q[(i + 1) % 4] as usize]))
    };
    let mut freed = 0;
    loop {
        let worst: Vec<u32> = quads
            .par_iter()
            .filter_map(|q| {
                let moved = |v: u32| {
                    (!only_lines || lines[v as usize].is_some()) && positions[v as usize] != before[v as usize]
                };
                if !q.iter().any(|&v| moved(v)) {
                    return None;
                }
                let (old, new) = (area(before, q), area(positions, q));
                if new.dot(old) >= MIN_AREA_KEPT * old.length_squared() {
                    return None;
                }
                let far = |v: u32| positions[v as usize].distance_squared(before[v as usize]);
                q.iter().copied().filter(|&v| moved(v)).reduce(|a, b| if far(b) > far(a) { b } else { a })
            })
            .collect();
        if worst.is_empty() {
            return freed;
        }
        for v in worst {
            let had_line = lines[v as usize].take().is_some();
            if had_line || (!only_lines && positions[v as usize] != before[v as usize]) {
                positions[v as usize] = before[v as usize];
                freed += 1;
            }
        }
    }
}

/// Most points of one voxel that [`gather`] tests: above this, every `k`-th point (the points
/// are in Morton order, so the sample spreads over the whole voxel). A plane fit needs far fewer;
/// the coarse levels of large scans hold hundreds of thousands of points per voxel (the 4.3 M
/// point case's levels 1-4 spent 0.08 s mapping a few hundred vertices, mostly on one thread).
const GATHER_CAP: usize = 4096;

/// Sums the points of `cell` within `radius` of `x`, relative to `x` (in `f64`; a fixed stride
/// of them in voxels of more than [`GATHER_CAP`] points).
#[inline]
fn gather(tree: &Octree, cells: &Cells, cell: usize, x: DVec3, radius: f64, m: &mut Moments) {
    let points = &tree.points[cells.range(cell)];
    let r2 = radius * radius;
    for p in points.iter().step_by(points.len().div_ceil(GATHER_CAP).max(1)) {
        let d = p.as_dvec3() - x;
        if d.length_squared() < r2 {
            m.add(d);
        }
    }
}

/// `t.round()` as `i64` per axis (rounding half away from zero, saturating, NaN to 0), bit for bit,
/// without `f64::round`: x86-64's baseline has no rounding instruction, so that is a library call
/// (about 30 instructions; 0.2 G at the 4.3 M case's level 10).
#[inline]
fn round_coords(t: DVec3) -> [i64; 3] {
    t.to_array().map(round_i64)
}

/// `t.round() as i64`, exactly: `t - trunc(t)` is exact below `2^52`, and above it `t` is an
/// integer.
#[inline]
fn round_i64(t: f64) -> i64 {
    let i = t as i64;
    let f = t - i as f64;
    if f >= 0.5 {
        i.saturating_add(1)
    } else if f <= -0.5 {
        i.saturating_sub(1)
    } else {
        i
    }
}

/// Fits a plane to moments taken relative to `x` and projects `x` on it (in `f64`).
fn fit(m: &Moments, x: DVec3) -> (DVec3, Option<TangentPlane>) {
    match crate::plane_fit::normal(m) {
        Some((c, n)) => (x - n * (-c).dot(n), Some(TangentPlane::new(c + x, n))),
        None => (x, None),
    }
}

/// Maps the vertices of a wrapped level. `face_cells[f]` is the voxel (index into `cells`) of
/// face `f`; `start` the vertices' initial positions. A vertex whose faces all lie on filled
/// voxels ([`crate::regions`]) is mapped as on a subdivided level ([`map_filled`]), from the
/// moments of `cells` and of `coarse` (the level above).
#[allow(clippy::too_many_arguments)] // the level, its parents, its faces and the options
pub(crate) fn map_wrapped(
    tree: &Octree,
    cells: &Cells,
    coarse: &Cells,
    quads: &[[u32; 4]],
    face_cells: &[u32],
    positions: &mut [DVec3],
    quadric: bool,
) -> Vec<Option<TangentPlane>> {
    let n = positions.len();
    let (fan, first, end) = fans(quads, face_cells, n);
    let l = cells.voxel();
    let level = cells.level;
    let one = |(near, keys): &mut (Vec<(DVec3, f64)>, Vec<u64>), v: usize, x: DVec3| -> (DVec3, Option<TangentPlane>) {
        let w = || fan[first[v] as usize..end[v] as usize].iter().map(|&c| c as usize);
        if !cells.filled.is_empty() && w().all(|c| cells.is_filled(c)) {
            return map_filled(cells, coarse, x);
        }
        if quadric {
            // The points of W within one edge, for the weighted quadric.
            near.clear();
            // Big voxels hold many points: a fixed stride keeps about 256, plenty for six unknowns.
            let total: usize = w().map(|c| cells.range(c).len()).sum();
            let stride = (total / 256).max(1);
            let inv_h2 = 4.0 / (l * l);
            for c in w() {
                for p in tree.points[cells.range(c)].iter().step_by(stride) {
                    let d = p.as_dvec3() - x;
                    let d2 = d.length_squared();
                    if d2 < l * l {
                        near.push((d, (-d2 * inv_h2).exp()));
                    }
                }
            }
            if let Some((offset, normal)) = quadric_fit(near, 0.5 * l) {
                return (x + offset, Some(TangentPlane::new(x + offset, normal)));
            }
        }
        let mut m = Moments::default();
        // The points within l/2 of a lattice corner lie in the children touching it.
        let corner = round_coords(x / l).map(|a| a as f64);
        let corner = DVec3::from_array(corner);
        let exact = (x / l - corner).abs().max_element() < 1e-9;
        match (tree.levels.get(level as usize + 1), exact) {
            (Some(children), true) => {
                let k = [corner.x as u32, corner.y as u32, corner.z as u32];
                for c in w() {
                    let v = morton::decode(cells.keys[c]);
                    let child = morton::encode(v[0] + k[0], v[1] + k[1], v[2] + k[2]);
                    if let Some(ci) = children.find(child) {
                        gather(tree, children, ci, x, 0.5 * l, &mut m);
                    }
                }
            }
            _ => {
                for c in w() {
                    gather(tree, cells, c, x, 0.5 * l, &mut m);
                }
            }
        }
        if m.count < 3.0 {
            // W' within radius l: the ball lies in the 2x2x2 voxels around the corner.
            m = Moments::default();
            gather_ball(tree, cells, x, l, &mut m, &mut BallCache::default());
        }
        if m.count < 3.0 {
            // All points of W': the voxels adjacent to W, by their moments.
            // Their keys, sorted and deduplicated before they are looked up (the fan's voxels
            // share most neighbours); indices ascend with keys, so the voxels are merged in the
            // order of their indices.
            keys.clear();
            keys.extend(w().flat_map(|c| block(cells.keys[c], level).into_iter().flatten()));
            keys.sort_unstable();
            keys.dedup();
            let mut all = Moments::default();
            for &k in keys.iter() {
                if let Some(c) = cells.find(k) {
                    all.merge(&cells.moments[c]);
                }
            }
            if let Some((c, n)) = crate::plane_fit::normal(&all) {
                let projected = x - n * (x - c).dot(n);
                return (projected, Some(TangentPlane::new(c, n)));
            }
        }
        fit(&m, x)
    };
    // In place: a vertex reads only its own start position.
    positions
        .par_iter_mut()
        .enumerate()
        .map_init(
            || (Vec::new(), Vec::new()),
            |scratch, (v, out)| {
                let (p, plane) = one(scratch, v, *out);
                *out = p;
                plane
            },
        )
        .collect()
}

/// The voxels of every vertex's fan (`face_cells[f]` is face `f`'s voxel), ascending and distinct:
/// `fan[first[v]..end[v]]` for each of the `n` vertices. A counting sort of the face corners by
/// vertex, then each vertex's few voxels sorted and deduplicated in place: the lists a sort of
/// all (vertex, voxel) pairs gave, without that sort (0.56 G instructions at the 4.3 M case's
/// level 8).
fn fans(quads: &[[u32; 4]], face_cells: &[u32], n: usize) -> (Vec<u32>, Vec<u32>, Vec<u32>) {
    let (first, mut fan) = corners_by_vertex(quads, n, |f, _, _| face_cells[f]);
    let mut end = first[1..].to_vec();
    for (v, e) in end.iter_mut().enumerate() {
        let list = &mut fan[first[v] as usize..*e as usize];
        list.sort_unstable();
        let mut kept = 0;
        for i in 0..list.len() {
            if i == 0 || list[i] != list[kept - 1] {
                list[kept] = list[i];
                kept += 1;
            }
        }
        *e = first[v] + kept as u32;
    }
    (fan, first, end)
}

/// Maps a vertex at `x` of a filled region of level `cells.level` (edge `l`) as on a subdivided
/// level ([`map_free`]): onto the plane of the points of the 2x2x2 voxels of `cells` around the
/// lattice corner nearest to `x`, with fewer than 3 points of the 2x2x2 voxels of `coarse` (the
/// level above) around theirs; from the voxels' moments.
fn map_filled(cells: &Cells, coarse: &Cells, x: DVec3) -> (DVec3, Option<TangentPlane>) {
    let mut m = Moments::default();
    for level in [cells, coarse] {
        let h = level.voxel();
        let n = 1i64 << level.level;
        let c = round_coords(x / h);
        for o in 0..8usize {
            let v = [c[0] - 1 + (o & 1) as i64, c[1] - 1 + ((o >> 1) & 1) as i64, c[2] - 1 + (o >> 2) as i64];
            if v.iter().any(|&a| a < 0 || a >= n) {
                continue;
            }
            if let Some(i) = level.find(morton::encode(v[0] as u32, v[1] as u32, v[2] as u32)) {
                if let Some(src) = level.moments.get(i) {
                    add_relative(src, x, &mut m);
                }
            }
        }
        if m.count >= 3.0 {
            break;
        }
        m = Moments::default();
    }
    fit(&m, x)
}

/// Adds `src` (moments of points in local coordinates) to `m`, relative to `x`.
fn add_relative(src: &Moments, x: DVec3, m: &mut Moments) {
    let (n, s, o) = (src.count, src.sum, src.outer);
    if n <= 0.0 {
        return;
    }
    // sum (p - x)(p - x)^T = sum p p^T - s x^T - x s^T + n x x^T.
    m.count += n;
    m.sum += s - x * n;
    m.outer[0] += o[0] - 2.0 * s.x * x.x + n * x.x * x.x;
    m.outer[1] += o[1] - s.x * x.y - x.x * s.y + n * x.x * x.y;
    m.outer[2] += o[2] - s.x * x.z - x.x * s.z + n * x.x * x.z;
    m.outer[3] += o[3] - 2.0 * s.y * x.y + n * x.y * x.y;
    m.outer[4] += o[4] - s.y * x.z - x.y * s.z + n * x.y * x.z;
    m.outer[5] += o[5] - 2.0 * s.z * x.z + n * x.z * x.z;
}

/// Fewest points for the quadric; below, the plane of the paper.
const QUADRIC_MIN: usize = 10;

/// The weighted height-field quadric through `points` (relative to the vertex): Gaussian weights
/// of width `h`, a weighted plane, then `z = c0 + c1 a + c2 b + c3 a^2 + c4 ab + c5 b^2` over it by
/// weighted least squares. Returns the vertex's move (its foot on the quadric along the plane
/// normal) and the quadric's normal there; `None` with too few points or a move beyond `4 h`.
#[allow(clippy::needless_range_loop)] // a small dense symmetric matrix
fn quadric_fit(points: &[(DVec3, f64)], h: f64) -> Option<(DVec3, DVec3)> {
    if points.len() < QUADRIC_MIN {
        return None;
    }
    let mut m = Moments::default();
    for &(p, w) in points {
        m.add_weighted(p, w);
    }
    let (c, n) = crate::plane_fit::normal(&m)?;
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    // The normal equations, upper triangle (the matrix is symmetric).
    let mut ata = [[0.0f64; 6]; 6];
    let mut atz = [0.0f64; 6];
    let inv = 1.0 / h;
    for &(p, w) in points {
        let d = p - c;
        let (a, b, z) = (d.dot(u) * inv, d.dot(v) * inv, d.dot(n));
        let phi = [1.0, a, b, a * a, a * b, b * b];
        for i in 0..6 {
            let wi = w * phi[i];
            atz[i] += wi * z;
            for j in i..6 {
                ata[i][j] += wi * phi[j];
            }
        }
    }
    for i in 1..6 {
        for j in 0..i {
            ata[i][j] = ata[j][i];
        }
    }
    let trace: f64 = (0..6).map(|i| ata[i][i]).sum();
    for (i, row) in ata.iter_mut().enumerate() {
        row[i] += 1e-9 * trace;
    }
    let coef = solve6(ata, atz)?;
    let (a0, b0) = ((-c).dot(u) / h, (-c).dot(v) / h);
    let z0 = coef[0] + coef[1] * a0 + coef[2] * b0 + coef[3] * a0 * a0 + coef[4] * a0 * b0 + coef[5] * b0 * b0;
    let offset = c + u * (a0 * h) + v * (b0 * h) + n * z0;
    if !offset.is_finite() || offset.length() > 4.0 * h {
        return None;
    }
    let (za, zb) =
        ((coef[1] + 2.0 * coef[3] * a0 + coef[4] * b0) / h, (coef[2] + coef[4] * a0 + 2.0 * coef[5] * b0) / h);
    let normal = (n - u * za - v * zb).normalize_or_zero();
    (normal != DVec3::ZERO).then_some((offset, normal))
}

/// Solves the 6x6 system by Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)] // row operations on a small dense matrix
fn solve6(mut a: [[f64; 6]; 6], mut b: [f64; 6]) -> Option<[f64; 6]> {
    for col in 0..6 {
        let pivot = (col..6).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..6 {
            let f = a[row][col] / a[col][col];
            for k in col..6 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 6];
    for row in (0..6).rev() {
        let mut s = b[row];
        for k in row + 1..6 {
            s -= a[row][k] * x[k];
        }
        x[row] = s / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The voxels [`gather_ball`] looked up around its last corner: consecutive vertices (numbered
/// along the Morton curve) often share the corner, and the look-ups are cache misses.
#[derive(Clone, Copy, Debug, Default)]
struct BallCache {
    /// Level and corner of the entries.
    corner: Option<(u32, [i64; 3])>,
    /// Per voxel around the corner (in [`gather_ball`]'s order): its index, [`ABSENT`] or
    /// [`UNKNOWN`].
    found: [u32; 8],
}

/// [`BallCache`]: not looked up yet.
const UNKNOWN: u32 = u32::MAX;
/// [`BallCache`]: not occupied.
const ABSENT: u32 = u32::MAX - 1;

/// Padding of voxel boxes in the reach test of [`gather_ball`] (local units).
const PAD: f64 = 1.0 / (1u64 << 20) as f64;

/// Sums the points within `radius` of `x` from the 2x2x2 voxels of `cells` around the lattice
/// corner nearest to `x`; complete when `radius` is at most half a voxel.
fn gather_ball(tree: &Octree, cells: &Cells, x: DVec3, radius: f64, m: &mut Moments, cache: &mut BallCache) {
    let h = cells.voxel();
    let n = 1i64 << cells.level;
    let c = round_coords(x / h);
    let r2 = radius * radius;
    // Per axis, the two voxel coordinates around the corner and the squared distance from `x` to
    // their slabs. Voxels out of reach are skipped before they are looked up (a ball of half a
    // voxel misses the far voxels when `x` is off the corner along two or three axes). Slabs are
    // padded by 2^-20 (points are `f32`, 2^-24 of the cube, and may stick out of their voxel by
    // that much), so no point within `radius` is ever skipped: the sums do not change.
    let mut coord = [[0i64; 2]; 3];
    let mut t2 = [[0.0f64; 2]; 3];
    for a in 0..3 {
        for k in 0..2 {
            let v = c[a] - 1 + k as i64;
            coord[a][k] = v;
            let lo = v as f64 * h - PAD;
            let t = (lo - x[a]).max(x[a] - (lo + h + 2.0 * PAD)).max(0.0);
            t2[a][k] = t * t;
        }
    }
    let corner = c;
    if cache.corner != Some((cells.level, corner)) {
        *cache = BallCache { corner: Some((cells.level, corner)), found: [UNKNOWN; 8] };
    }
    for o in 0..8usize {
        let k = [o & 1, (o >> 1) & 1, o >> 2];
        let v = [coord[0][k[0]], coord[1][k[1]], coord[2][k[2]]];
        if v.iter().any(|&a| a < 0 || a >= n) || t2[0][k[0]] + t2[1][k[1]] + t2[2][k[2]] >= r2 {
            continue;
        }
        if cache.found[o] == UNKNOWN {
            let code = morton::encode(v[0] as u32, v[1] as u32, v[2] as u32);
            cache.found[o] = cells.find(code).map_or(ABSENT, |i| i as u32);
        }
        if let Some(i) = (cache.found[o] != ABSENT).then_some(cache.found[o] as usize) {
            gather(tree, cells, i, x, radius, m);
        }
    }
}

/// Maps free vertices (of a subdivided level `level`, voxel edge `l`) onto the plane of the
/// points in the 2x2x2 level-`level` voxels around the lattice corner nearest to each (a box of
/// `2 l` whose centre is within `l / 2` of the vertex on every axis), from those voxels' moments
/// ([`ChildMoments`]); with fewer than 3 points, onto the points within `2 l` (the 2x2x2
/// level-`level - 2` voxels around it).
pub(crate) fn map_free(tree: &Octree, level: u32, positions: &mut [DVec3]) -> Vec<Option<TangentPlane>> {
    let parents = &tree.levels[level as usize - 1];
    let kids = ChildMoments::new(tree, parents);
    // In chunks of consecutive vertices, each with its look-up cache; the cache only saves
    // look-ups, so the result does not depend on the chunking.
    let mut planes = vec![None; positions.len()];
    positions.par_chunks_mut(1024).zip(planes.par_chunks_mut(1024)).for_each(|(positions, planes)| {
        let mut cache = Lookups::new();
        for (out, plane) in positions.iter_mut().zip(planes) {
            let (p, fitted) = map_one_free(parents, &kids, *out, &mut cache);
            *out = p;
            *plane = fitted;
        }
    });
    planes
}

/// A direct-mapped cache of voxel look-ups (consecutive vertices query nearby voxels, and the
/// look-ups are cache misses in a large table).
struct Lookups {
    keys: [u64; 64],
    found: [u32; 64],
}

impl Lookups {
    fn new() -> Self {
        Self { keys: [u64::MAX; 64], found: [0; 64] }
    }

    /// The index of voxel `v` in `cells`, if occupied. Direct-mapped on the low two bits of
    /// each coordinate, so the voxels of any 4x4x4 block never evict each other.
    #[inline(always)]
    #[allow(clippy::inline_always)] // 14 M calls at the 4.3 M case's level 10, not inlined otherwise
    fn find(&mut self, cells: &Cells, v: [u32; 3]) -> Option<usize> {
        let key = u64::from(v[0]) | u64::from(v[1]) << 21 | u64::from(v[2]) << 42;
        let slot = (v[0] & 3 | (v[1] & 3) << 2 | (v[2] & 3) << 4) as usize;
        if self.keys[slot] != key {
            self.keys[slot] = key;
            self.found[slot] = cells.find(morton::encode(v[0], v[1], v[2])).map_or(ABSENT, |i| i as u32);
        }
        (self.found[slot] != ABSENT).then_some(self.found[slot] as usize)
    }
}

/// The octants `o` (bit `a` of `o` set: `c[a]`, clear: `c[a] - 1` on axis `a`) of the 2x2x2
/// voxels around lattice corner `c` that lie inside `[0, n)^3`, as a bit mask.
#[inline]
fn octants_inside(c: [i64; 3], n: i64) -> u8 {
    let mut inside = 0xffu8;
    for (a, low) in [0x55u8, 0x33, 0x0f].into_iter().enumerate() {
        let mut axis = 0;
        if (1..=n).contains(&c[a]) {
            axis |= low;
        }
        if (0..n).contains(&c[a]) {
            axis |= !low;
        }
        inside &= axis;
    }
    inside
}

/// Maps one free vertex at `x` (see [`map_free`]).
///
/// The children's counts decide the fallback before any moments are summed (about a third of
/// the vertices at the 4.3 M case's level 10 fall back), and the moments are summed in units of
/// the voxel edge ([`Units`]): the same sums, in the same order, as summing in local units.
#[inline(never)]
fn map_one_free(parents: &Cells, kids: &ChildMoments, x: DVec3, cache: &mut Lookups) -> (DVec3, Option<TangentPlane>) {
    let l = crate::octree::voxel_size(kids.level);
    let n = 1i64 << kids.level;
    let c = round_coords(x / l);
    // The children `c - 1` and `c` on each axis, as octants `o` of the 2x2x2 box (bit `a` set:
    // `c` on axis `a`), visited in ascending order, those inside `[0, n)^3` only (a mask per
    // axis, no test per child). The two children have one parent when `c` is odd, two when even
    // (`c`'s parent is then the next one): parent `o & up` of the box's 2x2x2 parents, each
    // distinct parent looked up once.
    let inside = octants_inside(c, n);
    let up = (0..3).fold(0usize, |u, a| u | usize::from(c[a] & 1 == 0) << a);
    let lo = c.map(|a| (a - 1) as u32);
    let mut found = [UNKNOWN; 8];
    let mut hits = [(0u32, [0u32; 3]); 8];
    let (mut hit, mut count) = (0, 0u32);
    let mut todo = inside;
    while todo != 0 {
        let o = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        let v = [
            lo[0].wrapping_add((o & 1) as u32),
            lo[1].wrapping_add(((o >> 1) & 1) as u32),
            lo[2].wrapping_add((o >> 2) as u32),
        ];
        let k = o & up;
        if found[k] == UNKNOWN {
            found[k] = cache.find(parents, v.map(|a| a >> 1)).map_or(ABSENT, |p| p as u32);
        }
        if found[k] != ABSENT {
            if let Some(i) = kids.child(found[k] as usize, v) {
                hits[hit] = (i as u32, v);
                hit += 1;
                count = count.saturating_add(kids.count(i));
            }
        }
    }
    let mut m = Moments::default();
    if count >= 3 {
        let units = Units(l);
        let xu = units.of(x);
        for &(i, v) in &hits[..hit] {
            kids.add_child(i as usize, v, xu, &mut m);
        }
        units.scale(&mut m);
    } else {
        // The 2x2x2 parents around the nearest corner of theirs.
        let units = Units(2.0 * l);
        let xu = units.of(x);
        let c = round_coords(x / (2.0 * l));
        let lo = c.map(|a| (a - 1) as u32);
        let mut todo = octants_inside(c, n / 2);
        while todo != 0 {
            let o = todo.trailing_zeros();
            todo &= todo - 1;
            let v = [lo[0].wrapping_add(o & 1), lo[1].wrapping_add((o >> 1) & 1), lo[2].wrapping_add(o >> 2)];
            if let Some(p) = cache.find(parents, v) {
                kids.add_parent(p, v, xu, &mut m);
            }
        }
        units.scale(&mut m);
    }
    fit(&m, x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integer rounding is `f64::round` as `i64`, bit for bit, at halves, their neighbours,
    /// the largest values and non-finite input.
    #[test]
    fn round_i64_is_round() {
        let mut cases = vec![0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, 0.499_999_999_999_999_94, f64::NAN];
        cases.extend([f64::INFINITY, f64::NEG_INFINITY, f64::MAX, f64::MIN, 9.3e18, -9.3e18, 4.5e15 + 0.5]);
        for k in -2000..2000 {
            let h = f64::from(k) + 0.5;
            cases.extend([h, h.next_up(), h.next_down(), f64::from(k) / 7.0, f64::from(k) * 1.0e-3]);
        }
        for e in 40..66 {
            let big = 2f64.powi(e);
            cases.extend([big, big.next_down(), -big, big + 0.5, -(big - 0.5)]);
        }
        for t in cases {
            assert_eq!(round_i64(t), t.round() as i64, "{t:e}");
        }
    }
}
