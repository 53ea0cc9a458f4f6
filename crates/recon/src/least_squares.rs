//! Least-squares fit of a level's vertices to the points, after the mapping and relaxation
//! (beyond the paper: [`crate::ReconOptions::fit_passes`]).
//!
//! The paper's vertex mapping (§3.6) puts every vertex on a plane fitted to the points near it,
//! which makes the vertices lie on the surface but not the faces between them: on a coarse level
//! a face spans a curved patch, and the points between the corners stay far from it (on the
//! bunny's level 3 the mapping alone leaves the points-to-mesh RMS at 3x the paper's Table 3,
//! with the vertices on their planes). This stage keeps the connectivity and moves the vertices to minimise the
//! squared distance from the points to the mesh, in the manner of Hoppe et al.'s mesh
//! optimisation (SIGGRAPH 1993, `E_dist`), alternating two steps for a fixed number of passes:
//!
//! 1. **Projection**: every sample point (a fixed stride of the level's points, about
//!    [`crate::ReconOptions::fit_samples`] per face) finds the nearest point of the mesh among the
//!    faces of its own voxel and its six side neighbours (all 26 neighbours when those have none;
//!    a wrapped face belongs to its slot's voxel, a subdivided one to the voxel of its centre),
//!    each quad split along its shorter diagonal as [`octowrap_mesh::Mesh::triangles`] splits it,
//!    as weights of the quad's corners. Samples with no face that near (over a hole) are left
//!    out. Later passes start from the previous foot and look at the faces around it only when
//!    the foot lies on its face's border.
//! 2. **Solve**: with the weights fixed, the positions `x` minimising
//!    `sum_p |p - sum_k w_pk x_k|^2 + m (lambda sum_v |x_v - x0_v|^2 + kappa sum_e |d_e - d0_e|^2)`
//!    (`x0` the positions before the pass, `d_e` an edge's vector, `m` the samples per vertex,
//!    `lambda` = [`STIFFNESS`], `kappa` = [`MEMBRANE`]) solve a sparse symmetric positive
//!    definite system, the same for the three coordinates, by a few conjugate-gradient steps
//!    (Jacobi preconditioner). The membrane term keeps a vertex that few samples see moving
//!    with its neighbours: without it such vertices stray up to 0.2 of the diagonal from the
//!    points on the Rabbit's subdivided level 6; with it they stay as near as the mapping puts
//!    them, and the subdivided levels come out closer to the points too.
//!
//! **On decoder lines** (module `lines`): a vertex with a line has one unknown, its scalar along
//! the line (`x_v = o_v + s_v d_v`), and the others three. The same system is then solved over
//! that subspace by projected conjugate gradients: the residual and the preconditioned residual
//! of a line vertex are projected onto its direction, so every step moves it along its line
//! only, and the step lengths are one scalar over all unknowns (the three coordinates couple).
//!
//! Each pass lowers the energy, so the points-to-mesh distance falls; the regulariser keeps
//! vertices without points in place and the system well posed. Measured on the bunny (see
//! `docs/decisions.md`, "Least-squares fit"), the points-to-mesh RMS of levels 1-7 falls 1.5-4.9x.
//!
//! Determinism: the projections are independent per point, every sum runs in a fixed order
//! (faces' sums in point order, each vertex's in its face-corner order, dot products in fixed
//! chunks), so the result does not depend on the number of threads.

use octowrap_geom::glam::Vec3;
use octowrap_geom::{DVec3, closest_on_triangle};
use rayon::prelude::*;

use crate::extract::corners_by_vertex;
use crate::lattice::offset;
use crate::octree::Cells;

/// The regulariser's weight `lambda`, relative to the samples per vertex.
pub(crate) const STIFFNESS: f64 = 1e-3;

/// The membrane term's weight `kappa`, relative to the samples per vertex.
pub(crate) const MEMBRANE: f64 = 0.03;

/// Conjugate-gradient iterations per pass at most.
const CG_ITERATIONS: usize = 5;

/// Relative residual at which conjugate gradients stop.
const CG_TOLERANCE: f64 = 1e-3;

/// The 27 voxel offsets of a 3x3x3 block, nearest first: the voxel, its 6 side neighbours, the
/// 12 edge and the 8 corner neighbours.
const BY_RING: [[i32; 3]; 27] = {
    let mut out = [[0; 3]; 27];
    let mut n = 0;
    let mut ring = 0;
    while ring <= 3 {
        let mut i: i32 = 0;
        while i < 27 {
            let d = [i % 3 - 1, (i / 3) % 3 - 1, i / 9 - 1];
            if d[0].abs() + d[1].abs() + d[2].abs() == ring {
                out[n] = d;
                n += 1;
            }
            i += 1;
        }
        ring += 1;
    }
    out
};

/// Fewest items per parallel task in the per-vertex and per-sample loops.
const MIN_LEN: usize = 1024;

/// Chunk size of the deterministic dot products.
const CHUNK: usize = 4096;

/// What the fit works on: the points (local coordinates, in Morton order), the voxels of one
/// level over them, and for every face the voxel (index into `grid`) it lies on, or `u32::MAX`.
pub(crate) struct Input<'a> {
    /// The points, in Morton order.
    pub points: &'a [Vec3],
    /// Voxels whose point ranges cover `points`.
    pub grid: &'a Cells,
    /// Per face, its voxel in `grid` (`u32::MAX` for none).
    pub face_voxel: &'a [u32],
}

/// One sample's nearest point: its face, the weights of the face's four corners, the point.
#[derive(Clone, Copy)]
struct Foot {
    face: u32,
    weights: [f64; 4],
    point: DVec3,
}

/// Fits `positions` to the points for `passes` passes, with about `samples` sample points per
/// face. `dirs` is empty (every vertex free) or gives each vertex's unit line direction, zero for
/// a free vertex: a vertex with a direction moves along it only.
pub(crate) fn fit(
    input: &Input<'_>,
    quads: &[[u32; 4]],
    positions: &mut [DVec3],
    (passes, samples): (u32, u32),
    dirs: &[DVec3],
) {
    fit_switching(input, quads, positions, (passes, samples), dirs.to_vec(), None);
}

/// Before pass `at` of a fit: puts vertices onto their lines and returns every vertex's unit
/// line direction (zero for a free vertex), which the passes from `at` on keep them on.
pub(crate) type Switch<'a> = (u32, &'a mut dyn FnMut(&mut [DVec3]) -> Vec<DVec3>);

/// [`fit`], whose passes from `switch.0` on move the vertices that `switch.1` puts on lines
/// along their lines only: the free passes before it place the level, the constrained ones
/// after it let the free vertices and the line scalars make up for the tangential freedom the
/// line vertices lose.
pub(crate) fn fit_switching(
    input: &Input<'_>,
    quads: &[[u32; 4]],
    positions: &mut [DVec3],
    (passes, samples): (u32, u32),
    mut dirs: Vec<DVec3>,
    mut switch: Option<Switch<'_>>,
) {
    let grid = input.grid;
    if passes == 0 || quads.is_empty() || input.points.is_empty() || grid.len() == 0 {
        return;
    }
    // Faces per voxel (counting sort, faces ascending in each voxel).
    let nv = grid.len();
    let mut first = vec![0u32; nv + 1];
    for &c in input.face_voxel {
        if (c as usize) < nv {
            first[c as usize + 1] += 1;
        }
    }
    for i in 0..nv {
        first[i + 1] += first[i];
    }
    let mut faces_of = vec![0u32; first[nv] as usize];
    {
        let mut fill = first.clone();
        for (f, &c) in input.face_voxel.iter().enumerate() {
            if (c as usize) < nv {
                faces_of[fill[c as usize] as usize] = f as u32;
                fill[c as usize] += 1;
            }
        }
    }
    let total = input.points.len();
    let stride = total.div_ceil((samples.max(1) as usize).saturating_mul(quads.len())).max(1);
    let incidence = Incidence::new(quads, positions.len());
    let pattern = Pattern::new(quads, &incidence);
    // The first projection searches the faces around each sample's voxel; later ones the faces
    // around the previous foot (the mesh moved little).
    let faces = VoxelFaces { first: &first, faces: &faces_of };
    let mut feet = project(input, &faces, quads, positions, stride);
    drop(faces_of);
    if feet.is_empty() {
        return;
    }
    // The passes' arrays, allocated once (fresh pages cost a page fault each: the fit of the
    // 4.3 M point case's level 7 faulted 13.4 K pages with arrays made anew every pass, 8.7 K
    // with them kept).
    let mut work = Work::default();
    for pass in 0..passes {
        if let Some((_, on_lines)) = switch.as_mut().filter(|(at, _)| *at == pass) {
            dirs = on_lines(positions);
        }
        if pass > 0 {
            splits_into(quads, positions, &mut work.splits);
            reproject(&mut feet, &incidence, quads, positions, &work.splits);
        }
        system(&feet, quads, &incidence, &pattern, positions, &mut work);
        if dirs.is_empty() {
            conjugate_gradients(&pattern, positions, &mut work);
        } else {
            projected_conjugate_gradients(&pattern, positions, &mut work, &dirs);
        }
    }
}

/// The arrays of a pass, kept from pass to pass.
#[derive(Default)]
struct Work {
    /// [`splits_into`] of the current positions.
    splits: Vec<bool>,
    /// The feet grouped by face: face `f`'s are `order[start[f]..start[f + 1]]`.
    start: Vec<u32>,
    order: Vec<u32>,
    /// Per face, the 4x4 sum of its feet's weight products and their weighted sums.
    gram: Vec<[[f64; 4]; 4]>,
    rhs: Vec<[DVec3; 4]>,
    /// The matrix's values (in [`Pattern`]'s places), right-hand side and diagonal.
    values: Vec<f64>,
    b: Vec<DVec3>,
    diag: Vec<f64>,
    /// Conjugate gradients' vectors.
    ap: Vec<DVec3>,
    r: Vec<DVec3>,
    z: Vec<DVec3>,
    p: Vec<DVec3>,
}

/// Moves every foot to the nearest point of its face or, when it lies on the face's border
/// (a corner weight of zero), of the faces sharing a vertex with it.
fn reproject(feet: &mut [Foot], inc: &Incidence, quads: &[[u32; 4]], x: &[DVec3], splits: &[bool]) {
    feet.par_iter_mut().with_min_len(MIN_LEN).for_each(|foot| {
        let p = foot.point;
        let mut best = f64::INFINITY;
        let face = foot.face;
        let mut found = *foot;
        nearest_on_face(p, face, &quads[face as usize], x, splits[face as usize], &mut best, &mut found);
        let w = found.weights;
        // Inside the face (or on its diagonal) no neighbour is nearer; on its border, the faces
        // around the corners of the border edge (or the corner) it lies on may be.
        let on = |k: usize| w[k] > 0.0;
        let border = (0..4).any(|k| !(on((k + 2) % 4) || on((k + 1) % 4) && on((k + 3) % 4)));
        if border {
            let q = quads[face as usize];
            for k in (0..4).filter(|&k| on(k)) {
                for &(f, _) in inc.of(q[k] as usize) {
                    if f != face {
                        nearest_on_face(p, f, &quads[f as usize], x, splits[f as usize], &mut best, &mut found);
                    }
                }
            }
        }
        *foot = found;
    });
}

/// Updates `best` and `foot` when face `f` has a point nearer to `p` than `best`.
#[inline]
fn nearest_on_face(p: DVec3, f: u32, q: &[u32; 4], x: &[DVec3], other: bool, best: &mut f64, foot: &mut Foot) {
    let tris = if other { [[0, 1, 3], [1, 2, 3]] } else { [[0, 1, 2], [0, 2, 3]] };
    for tri in tris {
        let t = tri.map(|k: usize| x[q[k] as usize]);
        let (w, d2) = closest_on_triangle(p, &t);
        if d2 < *best {
            *best = d2;
            let mut weights = [0.0; 4];
            for (m, &c) in tri.iter().enumerate() {
                weights[c] = w[m];
            }
            *foot = Foot { face: f, weights, point: p };
        }
    }
}

/// Per face, whether it splits along its `1-3` diagonal (the shorter one; `0-2` on a tie), as
/// [`octowrap_mesh::Mesh::triangles`] splits it, into `out`.
fn splits_into(quads: &[[u32; 4]], x: &[DVec3], out: &mut Vec<bool>) {
    out.resize(quads.len(), false);
    out.par_iter_mut().zip(quads.par_iter()).for_each(|(s, q)| {
        let p = |k: usize| x[q[k] as usize];
        *s = p(0).distance_squared(p(2)) > p(1).distance_squared(p(3));
    });
}

/// Squared distance from `p` to the box `[lo, hi]`.
#[inline]
fn box_d2(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let d = (lo - p).max(p - hi).max(DVec3::ZERO);
    d.length_squared()
}

/// The nearest mesh point of every sample (every `stride`-th point), in point order.
/// The faces of every voxel of the grid: voxel `i`'s are `faces[first[i]..first[i + 1]]`.
struct VoxelFaces<'a> {
    first: &'a [u32],
    faces: &'a [u32],
}

impl VoxelFaces<'_> {
    /// Appends to `out` the candidate faces of voxel `code` of `grid`: its own and its six side
    /// neighbours', or when these have none those of all 26 neighbours. (Later passes walk from
    /// each foot to the faces around it, so a first foot one face away from the nearest is
    /// corrected there.)
    fn candidates(&self, grid: &Cells, code: u64, out: &mut Vec<u32>) {
        out.clear();
        for (k, d) in BY_RING.iter().enumerate() {
            if k == 7 && !out.is_empty() {
                break;
            }
            let Some(n) = offset(code, *d, grid.level) else { continue };
            if let Some(i) = grid.find(n) {
                out.extend_from_slice(&self.faces[self.first[i] as usize..self.first[i + 1] as usize]);
            }
        }
    }
}

fn project(
    input: &Input<'_>,
    voxel_faces: &VoxelFaces<'_>,
    quads: &[[u32; 4]],
    x: &[DVec3],
    stride: usize,
) -> Vec<Foot> {
    let mut splits = Vec::new();
    splits_into(quads, x, &mut splits);
    let boxes: Vec<(DVec3, DVec3)> = quads
        .par_iter()
        .map(|q| {
            let p = q.map(|v| x[v as usize]);
            (p[0].min(p[1]).min(p[2]).min(p[3]), p[0].max(p[1]).max(p[2]).max(p[3]))
        })
        .collect();
    let grid = input.grid;
    let per_voxel: Vec<Vec<Foot>> = (0..grid.len())
        .into_par_iter()
        .with_min_len(64)
        .map_init(Vec::new, |cands, i| {
            let mut out = Vec::new();
            let r = grid.range(i);
            // Voxels without a sample need no candidates.
            if r.start.div_ceil(stride) * stride >= r.end {
                return out;
            }
            voxel_faces.candidates(grid, grid.keys[i], cands);
            if cands.is_empty() {
                return out;
            }
            // Samples at multiples of the stride (the same points whatever the voxels).
            let start = r.start.div_ceil(stride) * stride;
            for k in (start..r.end).step_by(stride) {
                let p = input.points[k].as_dvec3();
                let mut best = f64::INFINITY;
                let mut foot = Foot { face: u32::MAX, weights: [0.0; 4], point: p };
                for &f in cands.iter() {
                    let (lo, hi) = boxes[f as usize];
                    if box_d2(p, lo, hi) < best {
                        nearest_on_face(p, f, &quads[f as usize], x, splits[f as usize], &mut best, &mut foot);
                    }
                }
                if foot.face != u32::MAX {
                    out.push(foot);
                }
            }
            out
        })
        .collect();
    per_voxel.concat()
}

/// Every vertex's face corners, in face order (`first[v]..first[v + 1]` into `corners`, each
/// `(face, corner)`).
struct Incidence {
    first: Vec<u32>,
    corners: Vec<(u32, u8)>,
}

impl Incidence {
    fn new(quads: &[[u32; 4]], n: usize) -> Self {
        let (first, corners) = corners_by_vertex(quads, n, |f, k, _| (f as u32, k as u8));
        Self { first, corners }
    }

    fn of(&self, v: usize) -> &[(u32, u8)] {
        &self.corners[self.first[v] as usize..self.first[v + 1] as usize]
    }
}

/// Deterministic dot product of two vector fields, per coordinate.
fn dot(a: &[DVec3], b: &[DVec3]) -> DVec3 {
    let parts: Vec<DVec3> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(a, b)| a.iter().zip(b).map(|(x, y)| *x * *y).sum::<DVec3>())
        .collect();
    parts.iter().copied().sum()
}

/// The matrix's sparsity pattern, the same in every pass (the connectivity is fixed): row `v`
/// has the columns `columns[start[v]..start[v + 1]]`: `v` itself, then the corners of its faces
/// in face-corner order, each once. `at[i]` gives, for face corner `i` of the incidence lists,
/// the place in its vertex's row of each of the face's four corners.
struct Pattern {
    start: Vec<u32>,
    columns: Vec<u32>,
    at: Vec<[u32; 4]>,
}

/// A chunk of [`Pattern`]'s rows: their lengths, columns and places.
type PatternPart = (Vec<u32>, Vec<u32>, Vec<[u32; 4]>);

impl Pattern {
    fn new(quads: &[[u32; 4]], inc: &Incidence) -> Self {
        let n = inc.first.len() - 1;
        // Per chunk of rows: their lengths, columns and places.
        let parts: Vec<PatternPart> = (0..n)
            .collect::<Vec<usize>>()
            .par_chunks(CHUNK)
            .map(|vs| {
                let mut lens = Vec::with_capacity(vs.len());
                let mut columns: Vec<u32> = Vec::with_capacity(10 * vs.len());
                let mut at = Vec::with_capacity(4 * vs.len());
                for &v in vs {
                    let row = columns.len();
                    columns.push(v as u32);
                    for &(f, _) in inc.of(v) {
                        let mut places = [0u32; 4];
                        for (c, &w) in quads[f as usize].iter().enumerate() {
                            let k = columns[row..].iter().position(|&e| e == w).unwrap_or_else(|| {
                                columns.push(w);
                                columns.len() - 1 - row
                            });
                            places[c] = k as u32;
                        }
                        at.push(places);
                    }
                    lens.push((columns.len() - row) as u32);
                }
                (lens, columns, at)
            })
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        start.push(0u32);
        let mut columns = Vec::with_capacity(parts.iter().map(|p| p.1.len()).sum());
        let mut at = Vec::with_capacity(inc.corners.len());
        for (lens, c, a) in parts {
            for l in lens {
                start.push(start[start.len() - 1] + l);
            }
            columns.extend(c);
            at.extend(a);
        }
        Self { start, columns, at }
    }

    /// Row `v`'s columns.
    fn row(&self, v: usize) -> std::ops::Range<usize> {
        self.start[v] as usize..self.start[v + 1] as usize
    }
}

/// The pass's system, into `work`: the matrix's values (in [`Pattern`]'s places), the
/// right-hand side and the diagonal.
fn system(feet: &[Foot], quads: &[[u32; 4]], inc: &Incidence, pattern: &Pattern, x: &[DVec3], work: &mut Work) {
    let n = x.len();
    // Per face: the 4x4 sum of weight products and the weighted sum of points, in point order.
    let start = &mut work.start;
    start.clear();
    start.resize(quads.len() + 1, 0);
    for f in feet {
        start[f.face as usize + 1] += 1;
    }
    for i in 0..quads.len() {
        start[i + 1] += start[i];
    }
    let order = &mut work.order;
    order.resize(feet.len(), 0);
    {
        let mut fill = start.clone();
        for (i, f) in feet.iter().enumerate() {
            order[fill[f.face as usize] as usize] = i as u32;
            fill[f.face as usize] += 1;
        }
    }
    let (start, order) = (&work.start, &work.order);
    work.gram.resize(quads.len(), [[0.0; 4]; 4]);
    work.rhs.resize(quads.len(), [DVec3::ZERO; 4]);
    work.gram.par_iter_mut().zip(work.rhs.par_iter_mut()).enumerate().for_each(|(f, (g, r))| {
        *g = [[0.0; 4]; 4];
        *r = [DVec3::ZERO; 4];
        for &i in &order[start[f] as usize..start[f + 1] as usize] {
            let foot = &feet[i as usize];
            let w = foot.weights;
            for a in 0..4 {
                r[a] += foot.point * w[a];
                for b in 0..4 {
                    g[a][b] += w[a] * w[b];
                }
            }
        }
    });
    let (gram, rhs) = (&work.gram, &work.rhs);
    let per_vertex = feet.len() as f64 / n as f64;
    let m = STIFFNESS * per_vertex;
    let kappa = MEMBRANE * per_vertex;
    // The membrane term's Laplacian of `p` at `v`: every face corner adds its two edges.
    let laplacian = |p: &[DVec3], v: usize| -> DVec3 {
        inc.of(v).iter().fold(DVec3::ZERO, |s, &(f, k)| {
            let q = &quads[f as usize];
            let k = k as usize;
            s + (p[v] * 2.0 - p[q[(k + 1) % 4] as usize] - p[q[(k + 3) % 4] as usize])
        })
    };
    // Per row, in one walk over its face corners: the right-hand side `b = A^T p + m x0 +
    // kappa L x0`, the diagonal (for the preconditioner) and the matrix's values. Every face
    // corner adds its 4x4 block's row and its two membrane edges, in corner order (each entry's
    // terms are added in the same order as by searching the row for each column).
    let x0 = x;
    work.b.resize(n, DVec3::ZERO);
    work.diag.resize(n, 0.0);
    work.values.resize(pattern.columns.len(), 0.0);
    let mut rows: Vec<(usize, &mut [f64])> = Vec::with_capacity(n.div_ceil(CHUNK));
    let mut rest = work.values.as_mut_slice();
    for first in (0..n).step_by(CHUNK) {
        let last = (first + CHUNK).min(n);
        let len = (pattern.start[last] - pattern.start[first]) as usize;
        let (here, tail) = rest.split_at_mut(len);
        rows.push((first, here));
        rest = tail;
    }
    rows.into_par_iter().zip(work.b.par_chunks_mut(CHUNK)).zip(work.diag.par_chunks_mut(CHUNK)).for_each(
        |(((first, out), b), diag)| {
            let base = pattern.start[first] as usize;
            for (i, v) in (first..(first + CHUNK).min(n)).enumerate() {
                let span = pattern.row(v);
                let row = &mut out[span.start - base..span.end - base];
                row.fill(0.0);
                row[0] = m;
                let (mut rhs_v, mut diag_v) = (x0[v] * m + laplacian(x0, v) * kappa, m);
                let corners = inc.first[v] as usize;
                for (i, &(f, k)) in inc.of(v).iter().enumerate() {
                    let places = pattern.at[corners + i];
                    let k = k as usize;
                    let g = &gram[f as usize][k];
                    rhs_v += rhs[f as usize][k];
                    diag_v = diag_v + g[k] + 2.0 * kappa;
                    for c in 0..4 {
                        row[places[c] as usize] += g[c];
                    }
                    row[0] += 2.0 * kappa;
                    row[places[(k + 1) % 4] as usize] -= kappa;
                    row[places[(k + 3) % 4] as usize] -= kappa;
                }
                b[i] = rhs_v;
                diag[i] = diag_v;
            }
        },
    );
}

/// `out = rows p`, the matrix's values in [`Pattern`]'s places, in fixed chunks.
fn multiply(pattern: &Pattern, values: &[f64], p: &[DVec3], out: &mut [DVec3]) {
    out.par_chunks_mut(CHUNK).enumerate().for_each(|(i, o)| {
        for (k, o) in o.iter_mut().enumerate() {
            let v = i * CHUNK + k;
            let row = pattern.row(v);
            *o = pattern.columns[row.clone()]
                .iter()
                .zip(&values[row])
                .fold(DVec3::ZERO, |s, (&c, &a)| s + p[c as usize] * a);
        }
    });
}

/// A few preconditioned conjugate-gradient steps on `rows x = b`, from `x`, the three
/// coordinates at once.
fn conjugate_gradients(pattern: &Pattern, x: &mut [DVec3], work: &mut Work) {
    let n = x.len();
    let Work { values, b, diag, ap, r, z, p, .. } = work;
    let (values, b, diag) = (&values[..], &b[..], &diag[..]);
    // Every vector loop runs in fixed chunks (few tasks on small levels; the partial sums of the
    // dot products are the chunks', added in order).
    let apply = |p: &[DVec3], out: &mut [DVec3]| multiply(pattern, values, p, out);
    // Preconditioned conjugate gradients, the three coordinates at once.
    for v in [&mut *ap, &mut *r, &mut *z, &mut *p] {
        v.resize(n, DVec3::ZERO);
    }
    apply(x, ap);
    r.par_iter_mut().zip(b.par_iter().zip(ap.par_iter())).for_each(|(r, (b, a))| *r = *b - *a);
    z.par_iter_mut().zip(r.par_iter().zip(diag.par_iter())).for_each(|(z, (r, d))| *z = *r / *d);
    p.copy_from_slice(z);
    let mut rz = dot(r, z);
    let mut rr = dot(r, r);
    // Relative to the first residual (the pass's whole correction).
    let stop = rr * (CG_TOLERANCE * CG_TOLERANCE);
    for _ in 0..CG_ITERATIONS {
        if rr.cmple(stop).all() {
            break;
        }
        apply(p, ap);
        let pap = dot(p, ap);
        // A coordinate that has converged (or has nothing to do) takes no step.
        let alpha = DVec3::select(pap.cmpgt(DVec3::ZERO), rz / pap, DVec3::ZERO);
        let parts: Vec<(DVec3, DVec3)> = x
            .par_chunks_mut(CHUNK)
            .zip(r.par_chunks_mut(CHUNK))
            .zip(z.par_chunks_mut(CHUNK))
            .zip(p.par_chunks(CHUNK).zip(ap.par_chunks(CHUNK)).zip(diag.par_chunks(CHUNK)))
            .map(|(((x, r), z), ((p, ap), d))| {
                let (mut rz, mut rr) = (DVec3::ZERO, DVec3::ZERO);
                for i in 0..x.len() {
                    x[i] += alpha * p[i];
                    r[i] -= alpha * ap[i];
                    z[i] = r[i] / d[i];
                    rz += r[i] * z[i];
                    rr += r[i] * r[i];
                }
                (rz, rr)
            })
            .collect();
        let rz_new: DVec3 = parts.iter().map(|p| p.0).sum();
        rr = parts.iter().map(|p| p.1).sum();
        let beta = DVec3::select(rz.cmpgt(DVec3::ZERO), rz_new / rz, DVec3::ZERO);
        rz = rz_new;
        p.par_chunks_mut(CHUNK).zip(z.par_chunks(CHUNK)).for_each(|(p, z)| {
            for (p, z) in p.iter_mut().zip(z) {
                *p = *z + beta * *p;
            }
        });
    }
}

/// [`conjugate_gradients`] over the subspace where every vertex with a direction (`dirs[v]`
/// unit, zero for a free vertex) moves along it only: preconditioned conjugate gradients with the
/// residual projected per vertex, one step length for all unknowns.
fn projected_conjugate_gradients(pattern: &Pattern, x: &mut [DVec3], work: &mut Work, dirs: &[DVec3]) {
    let n = x.len();
    let Work { values, b, diag, ap, r, z, p, .. } = work;
    let (values, b, diag) = (&values[..], &b[..], &diag[..]);
    let project = |v: usize, a: DVec3| {
        let d = dirs[v];
        if d == DVec3::ZERO { a } else { d * d.dot(a) }
    };
    let apply = |p: &[DVec3], out: &mut [DVec3]| multiply(pattern, values, p, out);
    let total = |a: &[DVec3], b: &[DVec3]| dot(a, b).element_sum();
    for v in [&mut *ap, &mut *r, &mut *z, &mut *p] {
        v.resize(n, DVec3::ZERO);
    }
    apply(x, ap);
    r.par_iter_mut().zip(b.par_iter().zip(ap.par_iter())).enumerate().for_each(|(v, (r, (b, a)))| {
        *r = project(v, *b - *a);
    });
    z.par_iter_mut().zip(r.par_iter().zip(diag.par_iter())).for_each(|(z, (r, d))| *z = *r / *d);
    p.copy_from_slice(z);
    let mut rz = total(r, z);
    let mut rr = total(r, r);
    let stop = rr * (CG_TOLERANCE * CG_TOLERANCE);
    for _ in 0..CG_ITERATIONS {
        if rr <= stop {
            break;
        }
        apply(p, ap);
        let pap = total(p, ap);
        if pap.is_nan() || pap <= 0.0 {
            break;
        }
        let alpha = rz / pap;
        let parts: Vec<(f64, f64)> = x
            .par_chunks_mut(CHUNK)
            .zip(r.par_chunks_mut(CHUNK))
            .zip(z.par_chunks_mut(CHUNK))
            .zip(p.par_chunks(CHUNK).zip(ap.par_chunks(CHUNK)).zip(diag.par_chunks(CHUNK)))
            .enumerate()
            .map(|(chunk, (((x, r), z), ((p, ap), d)))| {
                let (mut rz, mut rr) = (0.0, 0.0);
                for i in 0..x.len() {
                    x[i] += alpha * p[i];
                    r[i] = project(chunk * CHUNK + i, r[i] - alpha * ap[i]);
                    z[i] = r[i] / d[i];
                    rz += r[i].dot(z[i]);
                    rr += r[i].length_squared();
                }
                (rz, rr)
            })
            .collect();
        let rz_new: f64 = parts.iter().map(|p| p.0).sum();
        rr = parts.iter().map(|p| p.1).sum();
        let beta = if rz > 0.0 { rz_new / rz } else { 0.0 };
        rz = rz_new;
        p.par_chunks_mut(CHUNK).zip(z.par_chunks(CHUNK)).for_each(|(p, z)| {
            for (p, z) in p.iter_mut().zip(z) {
                *p = *z + beta * *p;
            }
        });
    }
}
