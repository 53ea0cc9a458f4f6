//! Line placement (spec §6.6 Line geometry, Appendix A "Line placement"): the encoder side
//! of one-number geometry, a co-design with reconstruction. A refinement level's vertex with a
//! parent context has a *prediction line* that the decoder derives from the decoded parent alone
//! (the base prediction of §6.3 / §6.4 and the parent face's normal). A vertex that lies on its
//! line costs one number (its parameter along the line) instead of three residuals.
//! [`place_on_prediction_lines`] moves a hierarchy's vertices onto their lines, coarse to fine,
//! each along its own tangent plane, so that the surface barely moves and the file still stores
//! exactly what the caller holds (every moved vertex sits on a grid point).

use octowrap_mesh::{Aabb, DVec3, FaceList, Hierarchy, Mesh};

use crate::EncodeOptions;
use crate::block::{LINE_PARAM_LIMIT, MAX_LINE_SHIFT, Mode, PREDICTOR_BILINEAR, PREDICTOR_NORMAL};
use crate::encoder::{Grid, choose_grid, input_level};
use crate::error::EncodeError;
use crate::geometry::decoder_lines::{fast_topo, level_contexts};
use crate::geometry::fixed::{self as fast, FixedLine};
use crate::geometry::predict::{GRID_LIMIT, GeometryScratch, Line, Topo, geometry_pass};
use crate::level_decode::PlainLevel;
use crate::level_encode::{self as encode, Encoded};

/// What [`place_on_prediction_lines`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct LinePlacement {
    /// Vertices moved onto their prediction line (or found on it already).
    pub placed: usize,
    /// Vertices with a line that stayed where they were: the line meets their tangent plane at
    /// a grazing angle or too far away (more than [`LinePlacement::max_move_voxels`] of their
    /// level's voxel), a move would change the grid of a file without an octree cube, or the
    /// move would harm the mesh ([`LinePlacement::reverted`]).
    pub kept: usize,
    /// Vertices not slid onto a line: levels 0 and 1 (see
    /// [`LinePlacement::first_placed_level`]), and vertices whose line is degenerate.
    pub without_line: usize,
    /// Of the kept vertices, those whose move was undone because it would have folded or
    /// collapsed one of their faces, or put them on the exact position of another vertex (see
    /// [`place_on_prediction_lines`]).
    pub reverted: usize,
    /// The largest move, world units.
    pub max_move: f64,
    /// The root mean square move over placed vertices, world units.
    pub rms_move: f64,
}

impl LinePlacement {
    /// The largest move allowed, in voxels of the vertex's level (edge of the octree cube over
    /// `2^k`, or of the bounding box's longest edge without a cube).
    pub const fn max_move_voxels() -> f64 {
        1.5
    }

    /// The coarsest level whose vertices move onto their lines (level 1, a handful of vertices
    /// around the whole object, only moves to its grid points: its tangent planes are too rough).
    pub const fn first_placed_level() -> usize {
        2
    }
}

/// Line points per voxel edge of the vertex's level, at least (spec §6.6 `line_shift`, Appendix A):
/// the height error is then at most about 1/32 of a voxel (RMS 1/55), far below the
/// reconstruction's own.
const LINE_POINTS_PER_VOXEL: f64 = 16.0;

/// The smallest cosine between a vertex's line and its tangent plane's normal for which the
/// vertex slides to their intersection (60 degrees).
const MIN_COSINE: f64 = 0.5;

/// Moves the vertices of every refinement level of `h` onto their prediction lines (spec §6.6),
/// so that [`crate::encode`] with the same `opts` codes them with one number each.
///
/// Coarse to fine, each level is quantized and ordered exactly as the encoder will (so the parent
/// every line comes from is the decoded parent); each vertex with a line slides along it to where
/// it meets the vertex's tangent plane (the plane through the vertex's position, normal to the
/// area-weighted normal of the level's mesh there), to the nearest line point on the grid. The
/// new position is that grid point's world position, so the file holds it exactly. Lattice levels
/// take the lattice predictor (§6.3) whose lines need the smaller moves. Vertices whose line
/// meets the plane at a grazing angle or too far away stay where they are (the encoder codes them
/// with three residuals), and so do the vertices of level 1. So do the vertices whose move would
/// fold, flip or collapse one of their faces, or land on another vertex's exact position (the
/// level's moves are checked together once placed, and the level is placed again without the
/// harmful ones, so that the vertices placed after them get lines through where they stay). Every other vertex, level 0's included, moves to its grid point (at most
/// half a step per axis), so that the file holds the result exactly. Topology and order are
/// unchanged.
///
/// Exact files (`Quantization::Exact`) have no lines: `h` is left as it is. Without an octree
/// cube the grid follows the bounding box of all positions; vertices on that box then stay, and no
/// vertex leaves it, so the grid does not change. Deterministic: the same input gives the same
/// output.
pub fn place_on_prediction_lines(h: &mut Hierarchy, opts: &EncodeOptions) -> Result<LinePlacement, EncodeError> {
    if h.levels.is_empty() {
        return Err(EncodeError::Empty);
    }
    h.check_links()?;
    let grid = choose_grid(h, opts.quantization)?;
    let mut stats = LinePlacement::default();
    if grid.exact {
        stats.without_line = h.levels.iter().map(|l| l.mesh.vertex_count()).sum();
        return Ok(stats);
    }
    let mut bounds = Aabb::EMPTY;
    for l in &h.levels {
        for p in &l.mesh.vertices.positions {
            bounds.grow(*p);
        }
    }
    let guard = (!grid.tied).then_some(bounds);
    let extent =
        h.cube.filter(|c| !c.is_empty()).map_or_else(|| bounds.size().max_element(), |c| c.size().max_element());
    let mut sum_sq = 0.0;
    let mut parent: Option<PlainLevel> = None;
    let mut parent_face_new: Vec<u32> = Vec::new();
    for k in 0..h.levels.len() {
        let enc = encode_one(h, k, &grid, &parent_face_new, parent.as_ref(), opts.version)?;
        let Some(pl) = parent.as_ref().filter(|_| k >= LinePlacement::first_placed_level()) else {
            stats.without_line += enc.vertex_old.len();
            snap(&mut h.levels[k].mesh.vertices.positions, &grid, guard.as_ref(), |_| true);
            let enc = encode_one(h, k, &grid, &parent_face_new, parent.as_ref(), opts.version)?;
            parent_face_new = enc.face_new;
            parent = Some(enc.level);
            continue;
        };
        let voxel = extent / f64::from(1u32 << k.min(30));
        let limit = LinePlacement::max_move_voxels() * voxel;
        // Line points at most a 16th of a voxel apart (spec §6.6, line_shift): coarse levels need
        // no finer heights, and each halving of the spacing costs a bit per vertex.
        let line_shift =
            ((voxel / grid.step / LINE_POINTS_PER_VOXEL).log2().floor().max(0.0) as u32).min(MAX_LINE_SHIFT);
        let normals = vertex_normals(&h.levels[k].mesh);
        // Per vertex: how far it may move (refused moves: -inf).
        let mut reach = vec![limit; h.levels[k].mesh.vertex_count()];
        let candidates: &[u8] =
            if enc.mode.is_lattice() { &[PREDICTOR_NORMAL, PREDICTOR_BILINEAR] } else { &[PREDICTOR_NORMAL] };
        let before = h.levels[k].mesh.vertices.positions.clone();
        let faces = &h.levels[k].mesh.faces;
        let choose = |reach: &[f64]| {
            let mut best: Option<Candidate> = None;
            for &predictor in candidates {
                let place = if enc.mode == Mode::FastLattice { place_level_fast } else { place_level };
                let c = place(&LevelPlacement {
                    enc: &enc,
                    parent: pl,
                    block: (k as u32, grid.bits, predictor, line_shift),
                    positions: &before,
                    normals: &normals,
                    reach,
                    slide: &|line: &dyn PlacementLine, x: DVec3, n: DVec3, r: f64| {
                        slide(line, x, n, &grid, r, guard.as_ref())
                    },
                    limit,
                });
                if best.as_ref().is_none_or(|b| c.cost < b.cost) {
                    best = Some(c);
                }
            }
            best.expect("one candidate at least")
        };
        let mut base = before.clone();
        snap(&mut base, &grid, guard.as_ref(), |_| true);
        let areas = face_areas(faces, &base);
        let (best, mut positions, mut moved, refused) = place_guarded(faces, &base, &areas, &mut reach, &choose);
        stats.reverted += refused;
        let undone = revert_harmful_moves(faces, &base, &areas, &mut positions, &mut moved);
        stats.reverted += undone;
        stats.kept += best.kept + undone;
        stats.without_line += best.none;
        for &(old, p) in best.moves.iter().filter(|m| moved[m.0 as usize]) {
            let d = (p - before[old as usize]).length();
            stats.max_move = stats.max_move.max(d);
            sum_sq += d * d;
            stats.placed += 1;
        }
        h.levels[k].mesh.vertices.positions = positions;
        // The level as the encoder will now see it: the parent of the next.
        let enc = encode_one(h, k, &grid, &parent_face_new, parent.as_ref(), opts.version)?;
        parent_face_new = enc.face_new;
        parent = Some(enc.level);
    }
    if stats.placed > 0 {
        stats.rms_move = (sum_sq / stats.placed as f64).sqrt();
    }
    Ok(stats)
}

/// Places a level (`choose`, given how far each vertex may move), refuses the moves that harm the
/// mesh ([`harmful_moves`]) and places again without them (the vertices placed on lines through
/// a refused one then get lines through where it stays), up to [`PLACEMENT_ROUNDS`] times. A
/// vertex that does not move goes to its grid point (`base`), so that the file holds it exactly;
/// the checks see it there. Returns the last placement, the positions and moved flags it gives,
/// and the number of moves refused (harm left after the last round is for the caller to undo).
fn place_guarded(
    faces: &FaceList,
    base: &[DVec3],
    areas: &[DVec3],
    reach: &mut [f64],
    choose: &dyn Fn(&[f64]) -> Candidate,
) -> (Candidate, Vec<DVec3>, Vec<bool>, usize) {
    let mut positions = base.to_vec();
    let mut moved = vec![false; positions.len()];
    let mut refused = 0;
    for round in 1.. {
        let best = choose(reach);
        positions.copy_from_slice(base);
        moved.fill(false);
        for &(old, p) in &best.moves {
            positions[old as usize] = p;
            moved[old as usize] = true;
        }
        let harm = harmful_moves(faces, base, areas, &positions, &moved);
        if harm.is_empty() || round == PLACEMENT_ROUNDS {
            return (best, positions, moved, refused);
        }
        for v in harm {
            reach[v as usize] = f64::NEG_INFINITY;
            refused += 1;
        }
    }
    unreachable!("the rounds end at PLACEMENT_ROUNDS")
}

fn encode_one(
    h: &Hierarchy,
    k: usize,
    grid: &Grid,
    parent_face_new: &[u32],
    parent: Option<&PlainLevel>,
    version: u16,
) -> Result<Encoded, EncodeError> {
    let mut input = input_level(h, k, grid, parent_face_new)?;
    input.topology_only = true;
    encode::encode_level(k as u32, &input, parent, grid.exact, grid.tied, grid.bits, version)
}

/// One lattice predictor's placement of a level: the moves (input vertex, new position), vertices
/// kept, vertices without a line, and the cost (squared moves, a kept vertex counting as a move of
/// the limit).
struct Candidate {
    moves: Vec<(u32, DVec3)>,
    kept: usize,
    none: usize,
    cost: f64,
}

/// What the placement of one level under one predictor reads.
struct LevelPlacement<'a> {
    /// The level as the encoder orders it.
    enc: &'a Encoded,
    /// The decoded parent.
    parent: &'a PlainLevel,
    /// `(k, grid_bits, predictor, line_shift)` of the block.
    block: (u32, u32, u8, u32),
    /// The level's positions and vertex normals (input order).
    positions: &'a [DVec3],
    normals: &'a [DVec3],
    /// How far each vertex may move (refused moves: -inf).
    reach: &'a [f64],
    /// Where a vertex lands on its line.
    slide: &'a Slide<'a>,
    /// The largest move; a kept vertex costs its square.
    limit: f64,
}

impl LevelPlacement<'_> {
    /// The candidate's answer for the vertex `v` (coding order) with line `line`: its grid point,
    /// and the move recorded in `c`.
    fn visit(&self, c: &mut Candidate, v: usize, line: Option<&dyn PlacementLine>) -> [i64; 3] {
        let old = self.enc.vertex_old[v];
        let x = self.positions[old as usize];
        let Some(line) = line else {
            c.none += 1;
            return self.enc.level.q[v];
        };
        if let Some((p, g)) = (self.slide)(line, x, self.normals[old as usize], self.reach[old as usize]) {
            c.cost += (p - x).length_squared();
            c.moves.push((old, p));
            g
        } else {
            c.kept += 1;
            c.cost += self.limit * self.limit;
            self.enc.level.q[v]
        }
    }
}

/// Places one level under lattice predictor `predictor`, in coding order (spec §6.2, §6.8): every
/// vertex's line comes from the decoded parent (pass A) or from the level's vertices placed before
/// it (pass B), so the geometry pass itself drives the placement.
fn place_level(a: &LevelPlacement<'_>) -> Candidate {
    let (enc, parent, (k, bits, predictor, line_shift)) = (a.enc, a.parent, a.block);
    let level = &enc.level;
    let topo = Topo {
        mode: enc.mode,
        level: k,
        bits,
        offsets: &level.offsets,
        indices: &level.indices,
        parents: &level.parents,
        quadrants: &level.quadrants,
        corner_pos: &enc.pos,
        vertex_corners: level.corners.as_deref(),
        parent_quads: (enc.mode == Mode::Lattice).then_some(&enc.parent_quads[..]),
        predictor,
        lines: true,
        line_shift,
    };
    let mut c = Candidate { moves: Vec::new(), kept: 0, none: 0, cost: 0.0 };
    let mut q = vec![[0i64; 3]; level.q.len()];
    let pp = parent.as_parent();
    let _: Result<(), ()> = geometry_pass(&topo, Some(&pp), &mut q, &mut GeometryScratch::default(), |v, pr| {
        Ok((a.visit(&mut c, v, pr.line.as_ref().map(|l| l as &dyn PlacementLine)), None))
    });
    c
}

/// Slides a vertex (position, normal) along a line: where it lands (world, grid), if it moves.
type Slide<'a> = dyn Fn(&dyn PlacementLine, DVec3, DVec3, f64) -> Option<(DVec3, [i64; 3])> + 'a;

/// A prediction line as placement sees it: version 2's (spec §6.6) or mode 3's (§6.8).
trait PlacementLine {
    /// The point of parameter 0.
    fn base(&self) -> [i64; 3];
    /// The grid displacement of one parameter step (approximately, for the slide).
    fn unit(&self) -> [f64; 3];
    /// The grid point of parameter `j`.
    fn point(&self, j: i64) -> [i64; 3];
}

impl PlacementLine for Line {
    fn base(&self) -> [i64; 3] {
        self.base
    }
    fn unit(&self) -> [f64; 3] {
        self.u
    }
    fn point(&self, j: i64) -> [i64; 3] {
        Line::point(self, j)
    }
}

impl PlacementLine for FixedLine {
    fn base(&self) -> [i64; 3] {
        self.base
    }
    fn unit(&self) -> [f64; 3] {
        FixedLine::unit(self)
    }
    fn point(&self, j: i64) -> [i64; 3] {
        FixedLine::point(self, j)
    }
}

/// [`place_level`] for a mode 3 level (spec §6.8): lines from [`fast::fast_pass`].
fn place_level_fast(a: &LevelPlacement<'_>) -> Candidate {
    let (enc, parent, (k, bits, predictor, line_shift)) = (a.enc, a.parent, a.block);
    let level = &enc.level;
    let nv = level.q.len();
    let contexts = level_contexts(enc);
    let topo = fast_topo(enc, &contexts, (k, bits, predictor, line_shift));
    let mut c = Candidate { moves: Vec::new(), kept: 0, none: 0, cost: 0.0 };
    let mut q = vec![[0i64; 3]; nv];
    let _: Result<(), ()> = fast::fast_pass(&topo, &parent.q, &mut q, &mut Vec::new(), |v, pr| {
        Ok(a.visit(&mut c, v, pr.line.as_ref().map(|l| l as &dyn PlacementLine)))
    });
    c
}

/// Where `x` lands when it slides along `line` to its tangent plane (normal `n`), snapped to the
/// line's nearest grid point; `None` when it should stay.
fn slide(
    line: &dyn PlacementLine,
    x: DVec3,
    n: DVec3,
    grid: &Grid,
    limit: f64,
    guard: Option<&Aabb>,
) -> Option<(DVec3, [i64; 3])> {
    if let Some(b) = guard {
        // A vertex on the bounding box holds the grid in place.
        if (0..3).any(|a| x[a] <= b.min[a] || x[a] >= b.max[a]) {
            return None;
        }
    }
    let u = DVec3::from_array(line.unit());
    let un = u.dot(n);
    if n == DVec3::ZERO || un.abs() < MIN_COSINE * u.length() {
        return None;
    }
    let base = grid.position(line.base());
    // World point of parameter s: base + s * step * u.
    let s = (x - base).dot(n) / (un * grid.step);
    if !s.is_finite() || s.abs() > LINE_PARAM_LIMIT as f64 {
        return None;
    }
    let q = line.point(s.round() as i64);
    if q.iter().any(|c| c.abs() > GRID_LIMIT) {
        return None;
    }
    let p = grid.position(q);
    let back = grid.quantize(p);
    if back != DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) || (p - x).length() > limit {
        return None;
    }
    if let Some(b) = guard {
        if (0..3).any(|a| p[a] < b.min[a] || p[a] > b.max[a]) {
            return None;
        }
    }
    Some((p, q))
}

/// How many times a level is placed, each time without the moves that harmed the mesh the time
/// before (see [`harmful_moves`]).
const PLACEMENT_ROUNDS: usize = 8;

/// The smallest fraction of a face's vector area (Newell), measured along its direction before
/// the moves, that the face must keep after them: less means the moves folded or collapsed it.
const MIN_AREA_KEPT: f64 = 0.1;

/// The moved vertices (`moved[v]`, from `before[v]` to `positions[v]`) whose moves harm the
/// mesh, ascending: per face whose vector area along its former direction (`areas`, the faces'
/// vector areas at `before`) falls below [`MIN_AREA_KEPT`] of what it was (a fold, a flip or a
/// collapse) or with two corners at one point, its largest move; and every moved vertex at the
/// exact position of another vertex.
fn harmful_moves(faces: &FaceList, before: &[DVec3], areas: &[DVec3], positions: &[DVec3], moved: &[bool]) -> Vec<u32> {
    let mut harm = Vec::new();
    for (f, &old) in faces.iter().zip(areas) {
        if !f.iter().any(|&v| moved[v as usize]) {
            continue;
        }
        let new = vector_area(positions, f);
        let len2 = old.length_squared();
        let kept = new.dot(old).partial_cmp(&(MIN_AREA_KEPT * len2));
        let folded = len2 > 0.0 && !matches!(kept, Some(std::cmp::Ordering::Greater | std::cmp::Ordering::Equal));
        let pinched = f
            .iter()
            .enumerate()
            .any(|(i, &a)| f[i + 1..].iter().any(|&b| positions[a as usize] == positions[b as usize]));
        if folded || pinched {
            // The face's largest move (the first of equal ones).
            let far = |v: u32| positions[v as usize].distance_squared(before[v as usize]);
            let worst = f.iter().copied().filter(|&v| moved[v as usize]).fold(None, |w: Option<u32>, v| match w {
                Some(w) if far(w) >= far(v) => Some(w),
                _ => Some(v),
            });
            harm.extend(worst);
        }
    }
    // Bit patterns, -0 as 0: the validator's duplicate test.
    let key = |p: DVec3| [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f64::to_bits);
    let mut keyed: Vec<([u64; 3], u32)> = positions.iter().zip(0..).map(|(&p, v)| (key(p), v)).collect();
    keyed.sort_unstable();
    for run in keyed.chunk_by(|a, b| a.0 == b.0).filter(|run| run.len() > 1) {
        harm.extend(run.iter().map(|&(_, v)| v).filter(|&v| moved[v as usize]));
    }
    harm.sort_unstable();
    harm.dedup();
    harm
}

/// Undoes the [`harmful_moves`] until none is left (each round undoes one move at least, and a
/// face with all its moves undone is as it was). Returns the number of moves undone.
fn revert_harmful_moves(
    faces: &FaceList,
    before: &[DVec3],
    areas: &[DVec3],
    positions: &mut [DVec3],
    moved: &mut [bool],
) -> usize {
    let mut reverted = 0;
    loop {
        let harm = harmful_moves(faces, before, areas, positions, moved);
        if harm.is_empty() {
            return reverted;
        }
        for v in harm {
            moved[v as usize] = false;
            positions[v as usize] = before[v as usize];
            reverted += 1;
        }
    }
}

/// Every face's [`vector_area`] at `positions`.
fn face_areas(faces: &FaceList, positions: &[DVec3]) -> Vec<DVec3> {
    faces.iter().map(|f| vector_area(positions, f)).collect()
}

/// A face's vector area (Newell's method: half the sum of its edges' cross products).
fn vector_area(p: &[DVec3], f: &[u32]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, &a) in f.iter().enumerate() {
        n += p[a as usize].cross(p[f[(i + 1) % f.len()] as usize]);
    }
    0.5 * n
}

/// Moves each selected position to its grid point (at most half a step per axis), unless that
/// would change an untied grid's bounding box.
fn snap(positions: &mut [DVec3], grid: &Grid, guard: Option<&Aabb>, selected: impl Fn(usize) -> bool) {
    for (v, x) in positions.iter_mut().enumerate() {
        if !selected(v) {
            continue;
        }
        let g = grid.quantize(*x);
        if g.abs().max_element() > GRID_LIMIT as f64 {
            continue; // the encoder reports it
        }
        let p = grid.position([g.x as i64, g.y as i64, g.z as i64]);
        let inside = guard
            .is_none_or(|b| (0..3).all(|a| b.min[a] < x[a] && x[a] < b.max[a] && b.min[a] <= p[a] && p[a] <= b.max[a]));
        if inside && grid.quantize(p) == g {
            *x = p;
        }
    }
}

/// Unit area-weighted vertex normals (Newell's normal of every face, summed at its corners); zero
/// where they cancel.
fn vertex_normals(mesh: &Mesh) -> Vec<DVec3> {
    let pos = &mesh.vertices.positions;
    let mut out = vec![DVec3::ZERO; pos.len()];
    for f in mesh.faces.iter() {
        let n = vector_area(pos, f);
        for &a in f {
            out[a as usize] += n;
        }
    }
    for n in &mut out {
        *n = n.try_normalize().unwrap_or(DVec3::ZERO);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2x2 grid of unit quads in the plane z = 0 (vertex `3 * y + x`), counter-clockwise.
    fn grid() -> (FaceList, Vec<DVec3>) {
        let p = (0..9).map(|i| DVec3::new(f64::from(i % 3), f64::from(i / 3), 0.0)).collect();
        let quad = |x: u32, y: u32| [3 * y + x, 3 * y + x + 1, 3 * y + x + 4, 3 * y + x + 3];
        (FaceList::from_quads(&[quad(0, 0), quad(1, 0), quad(0, 1), quad(1, 1)]), p)
    }

    fn apply(before: &[DVec3], moves: &[(u32, DVec3)]) -> (Vec<DVec3>, Vec<bool>) {
        let mut p = before.to_vec();
        let mut moved = vec![false; p.len()];
        for &(v, x) in moves {
            p[v as usize] = x;
            moved[v as usize] = true;
        }
        (p, moved)
    }

    #[test]
    fn harmless_moves_stay() {
        let (faces, before) = grid();
        // The centre slides within its four quads, a corner along the boundary, one out of plane.
        let moves = [(4, DVec3::new(1.3, 0.8, 0.0)), (0, DVec3::new(0.2, 0.0, 0.0)), (8, DVec3::new(2.0, 2.0, 0.4))];
        let (mut p, mut moved) = apply(&before, &moves);
        assert_eq!(revert_harmful_moves(&faces, &before, &face_areas(&faces, &before), &mut p, &mut moved), 0);
        for (v, x) in moves {
            assert_eq!(p[v as usize], x);
            assert!(moved[v as usize]);
        }
    }

    #[test]
    fn a_fold_is_undone() {
        let (faces, before) = grid();
        // The centre jumps past the far corner of quad (1, 1): that quad flips, the others stretch.
        let (mut p, mut moved) = apply(&before, &[(4, DVec3::new(2.5, 2.5, 0.0)), (1, DVec3::new(1.1, 0.0, 0.0))]);
        assert_eq!(revert_harmful_moves(&faces, &before, &face_areas(&faces, &before), &mut p, &mut moved), 1);
        assert_eq!(p[4], before[4]);
        assert!(!moved[4]);
        // The boundary vertex's own move harmed nothing and stays.
        assert_eq!(p[1], DVec3::new(1.1, 0.0, 0.0));
        assert!(moved[1]);
    }

    #[test]
    fn a_collapse_and_a_duplicate_are_undone() {
        let (faces, mut before) = grid();
        // Vertex 2 lands exactly on vertex 1 (collapsing an edge of quad (1, 0)); vertex 6 on a
        // tenth vertex, in no face, at (0, 2.5) (a harmless stretch of quad (0, 1) otherwise).
        before.push(DVec3::new(0.0, 2.5, 0.0));
        let (mut p, mut moved) = apply(&before, &[(2, before[1]), (6, before[9]), (0, DVec3::new(0.2, 0.0, 0.0))]);
        assert_eq!(revert_harmful_moves(&faces, &before, &face_areas(&faces, &before), &mut p, &mut moved), 2);
        assert_eq!((p[2], p[6]), (before[2], before[6]));
        assert_eq!(moved, [true, false, false, false, false, false, false, false, false, false]);
    }

    #[test]
    fn undoing_repeats_until_nothing_harms() {
        let (faces, mut before) = grid();
        // A tenth vertex in no face, at (3, 1). Vertices 4 and 5 move together harmlessly, but 5
        // lands on the tenth vertex and is undone; with 5 back, 4's move folds quad (1, 0), so a
        // second round undoes it too. Vertex 7's move is harmless either way and stays.
        before.push(DVec3::new(3.0, 1.0, 0.0));
        let moves = [(4, DVec3::new(2.6, 0.5, 0.0)), (5, DVec3::new(3.0, 1.0, 0.0)), (7, DVec3::new(1.0, 1.9, 0.0))];
        let (mut p, mut moved) = apply(&before, &moves);
        assert_eq!(revert_harmful_moves(&faces, &before, &face_areas(&faces, &before), &mut p, &mut moved), 2);
        assert_eq!(moved, [false, false, false, false, false, false, false, true, false, false]);
        assert_eq!(p[..7], before[..7]);
    }
}
