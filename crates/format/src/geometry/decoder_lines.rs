//! The decoder's prediction lines for a producer that builds a hierarchy level by level (spec §6.8
//! Geometry of mode 3): normal-mesh geometry by construction.
//!
//! A vertex of a mode 3 level with a parent context costs one number when it lies on its line, and
//! the line depends on the decoded parent alone: its origin on the parent quad's bilinear surface
//! or at the vertex's lattice point, its direction the parent quad's normal in fixed point. A
//! reconstruction that puts each such vertex on its line by construction (the vertex mapping
//! intersects the line with the fitted plane, the relaxation and the fit move one scalar along it)
//! stores exactly what it computed, with no placement pass after it.
//!
//! The split of the work:
//! * [`GridSpec`] is the file's grid: tied to the octree cube (spec §3.1 `TIED`, which mode 3
//!   needs), `2^bits` steps across it. The producer snaps every finished level onto it
//!   ([`GridSpec::snap`]), so that the level it continues from is the level the decoder decodes.
//! * [`DecodedLevels`] holds the hierarchy as the decoder sees it. [`DecodedLevels::push`] takes a
//!   finished level and quantizes and orders it exactly as the encoder does (the encoder's own
//!   code: the same canonical order, parent orientations and canonical quads of spec §5.3).
//! * [`DecodedLevels::lines_for_child_level`] takes the next level's topology (faces, parent links,
//!   lattice coordinates; its positions only need to be finite and on the grid's range) and gives
//!   each of its vertices with a context its [`DecoderLine`]: the line in grid integers, its
//!   predicted parameter, and [`FixedLine::point`] to evaluate `line(j)`, computed by the
//!   decoder's own pass (spec §6.8, pass A). Vertices without a context (only created faces use
//!   them, or every corner that uses them is an exception) get none: their lines depend on the
//!   level's own vertices (pass B), and the producer keeps their three components.
//!
//! The lines are those of a level coded in mode 3 with the predictor and `line_shift` asked for;
//! the encoder tries every predictor and the common spacings and keeps the smallest, which for a
//! level built on these lines is the level's own. A level the encoder cannot code in mode 3 (no
//! lattice coordinates, a parent face that is not a quad, two created faces on one slot) has no
//! lines.

use octowrap_mesh::{Aabb, DVec3, Level};

use crate::block::{MAX_LINE_SHIFT, Mode, PREDICTOR_BILINEAR, PREDICTOR_NORMAL};
use crate::encoder::{Grid, level_input};
use crate::error::EncodeError;
use crate::geometry::fixed::{self, Contexts, FastTopo, FixedLine};
use crate::level_decode::PlainLevel;
use crate::level_encode::{Encoded, encode_level};
use crate::topology::NONE;
use crate::{FORMAT_VERSION, MAX_GRID_BITS, Quantization};

/// Line points per voxel edge of a level, at least, in [`GridSpec::line_shift`] (as a power of
/// two): 64, the spacing of the default reconstruction grid at the finest level, so that heights
/// along lines cost no more accuracy than the grid does.
const LINE_POINTS_PER_VOXEL_LOG2: u32 = 6;

/// A quantization grid tied to an octree cube (spec §3.1 `TIED`): origin at the cube's smallest
/// corner, `2^bits` steps across its largest edge. The grid [`crate::encode`] uses for a hierarchy
/// with this cube under [`GridSpec::quantization`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSpec {
    cube: Aabb,
    bits: u32,
    origin: DVec3,
    step: f64,
}

impl GridSpec {
    /// The grid of `2^bits` steps across `cube`; an error for an empty or flat cube or `bits`
    /// outside `1..=28`.
    pub fn new(cube: Aabb, bits: u32) -> Result<Self, EncodeError> {
        if !(1..=MAX_GRID_BITS).contains(&bits) {
            return Err(EncodeError::Options(format!("quantization bits must be 1..={MAX_GRID_BITS}, got {bits}")));
        }
        let g = Grid::tied(cube, bits)
            .filter(|g| g.step.is_finite() && g.origin.is_finite())
            .ok_or_else(|| EncodeError::Options(format!("the cube {cube:?} is empty, flat or not finite")))?;
        Ok(Self { cube, bits, origin: g.origin, step: g.step })
    }

    /// `grid_bits`.
    pub fn bits(&self) -> u32 {
        self.bits
    }

    /// The grid step, world units.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// The cube the grid is tied to.
    pub fn cube(&self) -> Aabb {
        self.cube
    }

    /// The encoder option that gives this grid for a hierarchy with this cube.
    pub fn quantization(&self) -> Quantization {
        Quantization::Bits(self.bits)
    }

    fn grid(&self) -> Grid {
        Grid { exact: false, tied: true, bits: self.bits, origin: self.origin, step: self.step }
    }

    /// The grid point nearest `p`, in grid integers (as the encoder rounds; not range-checked).
    pub fn quantize(&self, p: DVec3) -> [i64; 3] {
        let g = self.grid().quantize(p);
        [g.x as i64, g.y as i64, g.z as i64]
    }

    /// The world position of grid point `q`, as the decoder computes it (spec §6.7).
    pub fn position(&self, q: [i64; 3]) -> DVec3 {
        self.grid().position(q)
    }

    /// `p` moved to its grid point: what the decoder gives back for it.
    pub fn snap(&self, p: DVec3) -> DVec3 {
        self.position(self.quantize(p))
    }

    /// The `line_shift` for level `k`: the largest spacing of line points that keeps at least 64 of
    /// them per voxel edge of the level (`bits - k - 6`, at least 0, at most 16).
    pub fn line_shift(&self, k: u32) -> u32 {
        self.bits.saturating_sub(k.saturating_add(LINE_POINTS_PER_VOXEL_LOG2)).min(MAX_LINE_SHIFT)
    }
}

/// Where a level's lines pass (spec §6.8, bit 0 of the block's `predictor`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineOrigin {
    /// Predictor 0: through the vertex's lattice point; the predicted parameter is that of the
    /// line point nearest the parent's bilinear point.
    LatticePoint,
    /// Predictor 1: through the parent's bilinear point; the predicted parameter is 0.
    Bilinear,
}

impl LineOrigin {
    fn predictor(self) -> u8 {
        match self {
            Self::LatticePoint => PREDICTOR_NORMAL,
            Self::Bilinear => PREDICTOR_BILINEAR,
        }
    }
}

/// A vertex's prediction line as the decoder computes it (spec §6.8, pass A): the grid points
/// `line.point(j)`, and the parameter the decoder predicts (a vertex on the line costs the
/// difference of its parameter from this one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecoderLine {
    /// The line in grid integers.
    pub line: FixedLine,
    /// The predicted parameter `jpred`.
    pub predicted: i64,
}

/// A hierarchy as the decoder sees it, built level by level: the grid, and the last level pushed,
/// quantized and in the encoder's canonical order (the parent of the next level's lines).
pub struct DecodedLevels {
    grid: GridSpec,
    parent: Option<PlainLevel>,
    parent_face_new: Vec<u32>,
    count: usize,
}

impl DecodedLevels {
    /// No level yet, on `grid`.
    pub fn new(grid: GridSpec) -> Self {
        Self { grid, parent: None, parent_face_new: Vec::new(), count: 0 }
    }

    /// The grid.
    pub fn grid(&self) -> &GridSpec {
        &self.grid
    }

    /// Levels pushed so far (the index the next level gets).
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether no level has been pushed.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    fn encode(&self, level: &Level) -> Result<Encoded, EncodeError> {
        let k = self.count;
        if k >= 32 {
            return Err(EncodeError::Unsupported { level: k, reason: "more than 32 levels".into() });
        }
        check_origins(level, k, self.parent.as_ref().map_or(0, |p| p.parents.len()))?;
        let mut input = level_input(level, k, &self.grid.grid(), &self.parent_face_new)?;
        input.topology_only = true;
        encode_level(k as u32, &input, self.parent.as_ref(), false, true, self.grid.bits, FORMAT_VERSION)
    }

    /// Appends a finished level (its positions as the file will hold them: the encoder quantizes
    /// them with [`GridSpec::quantize`], so a producer that snapped them loses nothing). Its parent
    /// links must name faces of the level pushed before it.
    pub fn push(&mut self, level: &Level) -> Result<(), EncodeError> {
        let enc = self.encode(level)?;
        self.parent_face_new = enc.face_new;
        self.parent = Some(enc.level);
        self.count += 1;
        Ok(())
    }

    /// The decoder's line of every vertex of `child` (the level to be pushed next) that has a
    /// parent context, for a mode 3 block with the given line origin and `line_shift` (at most
    /// 16; [`GridSpec::line_shift`] is the usual one), indexed like `child`'s vertices. `None`
    /// for a vertex without a context, and for every vertex when no level is pushed yet or the
    /// encoder would not code `child` in mode 3 (see the module documentation).
    pub fn lines_for_child_level(
        &self,
        child: &Level,
        origin: LineOrigin,
        line_shift: u32,
    ) -> Result<Vec<Option<DecoderLine>>, EncodeError> {
        let nv = child.mesh.vertex_count();
        let mut out = vec![None; nv];
        let Some(parent) = &self.parent else { return Ok(out) };
        if line_shift > MAX_LINE_SHIFT {
            return Err(EncodeError::Options(format!("line_shift must be at most {MAX_LINE_SHIFT}, got {line_shift}")));
        }
        let enc = self.encode(child)?;
        if enc.mode != Mode::FastLattice {
            return Ok(out);
        }
        let contexts = level_contexts(&enc);
        let topo = fast_topo(&enc, &contexts, (self.count as u32, self.grid.bits, origin.predictor(), line_shift));
        let mut q = vec![[0i64; 3]; enc.level.q.len()];
        let _: Result<(), ()> = fixed::fast_pass(&topo, &parent.q, &mut q, &mut Vec::new(), |v, pr| {
            if contexts.face[v] != NONE {
                if let Some(line) = pr.line {
                    out[enc.vertex_old[v] as usize] = Some(DecoderLine { line, predicted: pr.param });
                }
            }
            Ok(enc.level.q[v])
        });
        Ok(out)
    }
}

/// Fails unless `level` has one origin per face and every subface names a face of a parent with
/// `parent_faces` faces (none for level 0; the encoder's renumbering indexes by it).
fn check_origins(level: &Level, k: usize, parent_faces: usize) -> Result<(), EncodeError> {
    use octowrap_mesh::FaceOrigin;
    let bad = level
        .origins
        .iter()
        .any(|o| matches!(*o, FaceOrigin::Subface { parent, .. } if parent as usize >= parent_faces));
    if bad || level.origins.len() != level.mesh.faces.len() {
        return Err(EncodeError::Unsupported {
            level: k,
            reason: "parent links do not match the level pushed before".into(),
        });
    }
    Ok(())
}

/// The contexts of an encoded mode 3 level (spec §6.8).
pub(crate) fn level_contexts(enc: &Encoded) -> Contexts {
    let level = &enc.level;
    let mut contexts = Contexts::default();
    fixed::contexts(
        &level.indices,
        &level.parents,
        &level.quadrants,
        &enc.pos,
        &enc.parent_quads,
        level.q.len(),
        &mut contexts,
    );
    contexts
}

/// What the mode 3 geometry pass reads about an encoded level, with lines of the given predictor
/// and spacing: `(k, grid_bits, predictor, line_shift)`.
pub(crate) fn fast_topo<'a>(
    enc: &'a Encoded,
    contexts: &'a Contexts,
    (k, bits, predictor, line_shift): (u32, u32, u8, u32),
) -> FastTopo<'a> {
    crate::geometry::residuals::level_topo(
        &enc.level,
        contexts,
        &enc.parent_quads,
        (k, bits),
        (predictor, line_shift, true),
    )
}

#[cfg(test)]
mod tests {
    use octowrap_mesh::{FaceOrigin, Hierarchy};

    use super::{DecodedLevels, GridSpec, LineOrigin};
    use crate::block::{Mode, PREDICTOR_LINES};
    use crate::bytes::{Reader, unzigzag};
    use crate::encoder::encode_levels;
    use crate::geometry::residuals::grid_values;
    use crate::synthetic::{Edits, cube_hierarchy};
    use crate::{DecodeOptions, EncodeOptions, Where, decode_bytes, encode, place_on_prediction_lines};

    /// A synthetic hierarchy placed on its lines, with its 12-bit grid.
    fn placed(levels: usize) -> (Hierarchy, GridSpec, EncodeOptions) {
        let mut h = cube_hierarchy(levels, Edits::default(), 1);
        let grid = GridSpec::new(h.cube.expect("a cube"), 12).unwrap();
        let opts = EncodeOptions::with_quantization(grid.quantization());
        place_on_prediction_lines(&mut h, &opts).unwrap();
        (h, grid, opts)
    }

    /// Every line vertex of every mode 3 level of a file decodes to `line(J)` of the line the API
    /// gives it, with `J` its predicted parameter plus the file's stored difference: the API's
    /// lines, predictions and context vertices are the decoder's.
    #[test]
    fn lines_are_the_decoders() {
        let (h, grid, opts) = placed(7);
        let decoded = decode_bytes(&encode(&h, &opts).unwrap(), &DecodeOptions::default()).unwrap().hierarchy;
        let mut blocks = Vec::new();
        encode_levels(&h, &opts, |enc| {
            blocks.push((enc.payload.clone(), enc.split_bytes.1, enc.mode, enc.predictor, enc.line_shift));
            Ok(())
        })
        .unwrap();
        let mut levels = DecodedLevels::new(grid);
        let (mut checked, mut total) = (0, 0);
        for (k, level) in decoded.levels.iter().enumerate() {
            let (payload, geometry, mode, predictor, shift) = &blocks[k];
            let nv = level.mesh.vertex_count();
            if *mode == Mode::FastLattice && predictor & PREDICTOR_LINES != 0 {
                let origin = if predictor & 1 == 0 { LineOrigin::LatticePoint } else { LineOrigin::Bilinear };
                let lines = levels.lines_for_child_level(level, origin, *shift).unwrap();
                let mut r = Reader::new(&payload[payload.len() - geometry..], 0, Where::Payload(k as u32), "geometry");
                let mut values = Default::default();
                let flags = grid_values(&mut r, nv, true, &mut values).unwrap();
                let params = &values[0];
                // Coding order: the vertices with a context first, by index.
                let mut i = 0;
                for (v, line) in lines.iter().enumerate() {
                    let Some(line) = line else { continue };
                    if flags[v / 8] >> (v % 8) & 1 == 0 {
                        continue;
                    }
                    let j = line.predicted + unzigzag(u64::from(params[i]));
                    i += 1;
                    assert_eq!(
                        grid.position(line.line.point(j)),
                        level.mesh.vertices.positions[v],
                        "level {k} vertex {v}"
                    );
                    checked += 1;
                }
                total += nv;
            }
            levels.push(level).unwrap();
        }
        assert_eq!(levels.len(), decoded.levels.len());
        assert!(checked * 2 > total && checked > 1000, "{checked} line vertices checked of {total}");
    }

    /// Each predictor's lines: the vertices with a context have one, through the lattice point
    /// (predictor 0) or with parameter 0 predicted (predictor 1); no level pushed, no lines.
    #[test]
    fn origins_and_shifts() {
        let (h, grid, _) = placed(4);
        let mut levels = DecodedLevels::new(grid);
        assert!(
            levels
                .lines_for_child_level(&h.levels[0], LineOrigin::LatticePoint, 0)
                .unwrap()
                .iter()
                .all(Option::is_none)
        );
        levels.push(&h.levels[0]).unwrap();
        levels.push(&h.levels[1]).unwrap();
        let a = levels.lines_for_child_level(&h.levels[2], LineOrigin::LatticePoint, grid.line_shift(2)).unwrap();
        let b = levels.lines_for_child_level(&h.levels[2], LineOrigin::Bilinear, 0).unwrap();
        assert_eq!(a.len(), h.levels[2].mesh.vertex_count());
        assert!(a.iter().filter(|l| l.is_some()).count() > a.len() / 2);
        let corners = &h.levels[2].lattice.as_ref().unwrap().vertex_corners;
        for (v, (x, y)) in a.iter().zip(&b).enumerate() {
            assert_eq!(x.is_some(), y.is_some(), "vertex {v}");
            if let (Some(x), Some(y)) = (x, y) {
                // Lattice point of depth 2 on 12 bits: corner << 10.
                assert_eq!(x.line.base, corners[v].map(|c| i64::from(c) << 10), "vertex {v}");
                assert_eq!(y.predicted, 0);
                // 64 line points per level-2 voxel of 2^10 steps: 2^4 steps apart.
                let top = x.line.u.iter().map(|u| u.unsigned_abs()).max().unwrap();
                assert!((1 << 16..1 << 17).contains(&top), "{top}");
            }
        }
        assert_eq!(grid.line_shift(2), 4);
        assert_eq!(grid.line_shift(7), 0);
        assert!(levels.lines_for_child_level(&h.levels[2], LineOrigin::Bilinear, 17).is_err());
    }

    /// A level whose parent links do not fit the level pushed before is refused, not a panic.
    #[test]
    fn mismatched_levels_are_refused() {
        let (h, grid, _) = placed(3);
        let mut levels = DecodedLevels::new(grid);
        assert!(levels.push(&h.levels[1]).is_err(), "level 1 as level 0");
        levels.push(&h.levels[0]).unwrap();
        let mut bad = h.levels[1].clone();
        bad.origins[0] = FaceOrigin::Subface { parent: 1000, quadrant: octowrap_mesh::Quadrant(0) };
        assert!(levels.lines_for_child_level(&bad, LineOrigin::Bilinear, 0).is_err());
        assert!(levels.push(&bad).is_err());
        assert!(GridSpec::new(octowrap_mesh::Aabb::EMPTY, 12).is_err());
        assert!(GridSpec::new(h.cube.unwrap(), 0).is_err());
    }
}
