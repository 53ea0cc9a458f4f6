//! Normal-mesh geometry by construction: the refined vertices of every level computed as one
//! scalar along the line the MRQ decoder predicts them on (spec §6.8), after Guskov, Vidimče,
//! Sweldens & Schröder, *Normal Meshes* (SIGGRAPH 2000), and Khodakovsky & Guskov, *Compression
//! of Normal Meshes* (2003).
//!
//! With [`crate::ReconOptions::decoder_lines`], every finished level is snapped to the file's
//! grid and handed to [`octowrap_format::DecodedLevels`], which quantizes and orders it exactly as
//! the encoder does. Before the next level is mapped, the decoder's line of each of its vertices
//! with a parent context comes from that decoded parent ([`LineRun::lines`]). Two ways to use
//! the lines ([`crate::ReconOptions::line_reach`]):
//!
//! * **By construction** (infinite reach): the vertex mapping meets the line with the fitted
//!   plane (`mapping::onto_lines`), the relaxation holds the vertex, and the least-squares fit
//!   moves its scalar along the line. Every vertex with a line costs one number, but a normal
//!   mesh has no tangential freedom: measured on the bunny (levels 2-6), the dragon (2-7) and
//!   `autzen_trim.laz`, points-to-mesh RMS rises by 6-67 % per level against free vertices,
//!   and self-intersecting face pairs multiply (`tools/bench`, accuracy area).
//! * **Near lines** (the default, 0.3 voxel): the level is placed free (mapping, relaxation and
//!   the fit's first two passes as without lines), a vertex that lies within the reach of its
//!   line goes to the line's nearest point (the others keep three components), and two more
//!   passes of the fit move the line vertices along their lines and the free ones in space, so
//!   the free vertices around a snapped one make up for its lost tangential freedom. RMS stays
//!   within +5 % of the free levels on every level measured, while 58-90 % of the finest
//!   level's vertices cost one number (without the constrained passes, the same reach costs up
//!   to +26 %).
//!
//! The finished level puts every line vertex on its line's nearest point ([`LineRun::snap`]) and
//! every other vertex on its grid point: the file decodes to the positions the reconstruction
//! computed, bit for bit.
//!
//! Lines pass through the vertex's lattice point on wrapped levels (the mapping starts there) and
//! through the parent's bilinear point on subdivided ones (their vertices start on the parent
//! surface); their direction is the decoded parent quad's normal. Levels 0 and 1 have no lines:
//! level 1's vertices are the corners of a hull around the whole object, and a line along the
//! root cube's face normals is a poor constraint for them (they cost three numbers each, a few
//! dozen vertices).

use octowrap_format::{DecodedLevels, FixedLine, GridSpec, LineOrigin};
use octowrap_geom::DVec3;
use octowrap_mesh::Level;
use rayon::prelude::*;

use crate::Error;
use crate::octree::Frame;

/// The first level whose vertices move along lines.
pub(crate) const FIRST_LINE_LEVEL: u32 = 2;

/// Largest parameter magnitude a line vertex takes (spec §6.8 bounds it by `2^30`).
const PARAM_LIMIT: f64 = (1u64 << 29) as f64;

/// A vertex's decoder line in local coordinates: `origin + s * dir` (`dir` unit), with `s = j *
/// spacing` at line point `j`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LocalLine {
    /// The point of parameter 0 (local).
    pub origin: DVec3,
    /// Unit direction (local).
    pub dir: DVec3,
    /// Local length of one parameter step.
    pub spacing: f64,
    /// The line in grid integers.
    fixed: FixedLine,
}

impl LocalLine {
    /// The point of the line nearest `x`.
    pub(crate) fn nearest(&self, x: DVec3) -> DVec3 {
        self.origin + self.dir * (x - self.origin).dot(self.dir)
    }
}

/// The decoder's view of the levels built so far, and the frame between local and world
/// coordinates.
pub(crate) struct LineRun {
    levels: DecodedLevels,
    frame: Frame,
}

impl LineRun {
    /// No level yet, on a grid of `2^bits` steps across the frame's cube.
    pub(crate) fn new(frame: Frame, bits: u32) -> Result<Self, Error> {
        let grid = GridSpec::new(frame.cube(), bits).map_err(|e| lines_error(0, &e))?;
        Ok(Self { levels: DecodedLevels::new(grid), frame })
    }

    /// The grid.
    pub(crate) fn grid(&self) -> GridSpec {
        *self.levels.grid()
    }

    fn to_local(&self, w: DVec3) -> DVec3 {
        (w - self.frame.origin) / self.frame.edge
    }

    /// Appends a finished level (world positions, already [`LineRun::snap`]ped).
    pub(crate) fn push(&mut self, level: &Level) -> Result<(), Error> {
        let k = self.levels.len() as u32;
        self.levels.push(level).map_err(|e| lines_error(k, &e))
    }

    /// The line of every vertex of `child` (the next level: its topology, positions anywhere in
    /// the cube) with a parent context, through its lattice point or the parent's bilinear point
    /// (`origin`), with the grid's usual spacing for the level; empty before
    /// [`FIRST_LINE_LEVEL`].
    pub(crate) fn lines(&self, child: &Level, origin: LineOrigin) -> Result<Vec<Option<LocalLine>>, Error> {
        let k = self.levels.len() as u32;
        if k < FIRST_LINE_LEVEL {
            return Ok(Vec::new());
        }
        let grid = self.grid();
        let lines =
            self.levels.lines_for_child_level(child, origin, grid.line_shift(k)).map_err(|e| lines_error(k, &e))?;
        let unit = grid.step() / self.frame.edge;
        Ok(lines
            .par_iter()
            .map(|l| {
                let fixed = l.as_ref()?.line;
                let u = DVec3::from_array(fixed.unit()) * unit;
                let spacing = u.length();
                let dir = u.try_normalize()?;
                let origin = self.to_local(grid.position(fixed.base));
                Some(LocalLine { origin, dir, spacing, fixed })
            })
            .collect())
    }

    /// Puts world positions of a [`LineRun::snap`]ped level (each within rounding of a grid
    /// point) exactly on their grid points, bit for bit what the decoder computes.
    pub(crate) fn exact(&self, world: &mut [DVec3]) {
        let grid = self.grid();
        world.par_iter_mut().for_each(|p| *p = grid.snap(*p));
    }

    /// Puts every vertex with a line on the line point nearest it (`J`, its scalar as the file
    /// stores it), and every other vertex on its grid point.
    pub(crate) fn snap(&self, positions: &mut [DVec3], lines: &[Option<LocalLine>]) {
        let grid = self.grid();
        let frame = self.frame;
        positions.par_iter_mut().enumerate().for_each(|(v, x)| {
            let world = match lines.get(v).copied().flatten() {
                Some(l) => {
                    let s = (*x - l.origin).dot(l.dir) / l.spacing;
                    let j = if s.is_finite() { s.round().clamp(-PARAM_LIMIT, PARAM_LIMIT) as i64 } else { 0 };
                    grid.position(l.fixed.point(j))
                }
                None => grid.snap(frame.to_world(*x)),
            };
            *x = (world - frame.origin) / frame.edge;
        });
    }
}

fn lines_error(level: u32, e: &octowrap_format::EncodeError) -> Error {
    Error::DecoderLines { level, reason: e.to_string() }
}
