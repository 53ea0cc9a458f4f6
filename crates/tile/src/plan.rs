//! The plan: one global root cube, the finest level, the tiles and their halo, decided from the
//! inputs' headers and one counting pass over their points, and saved as JSON for every later
//! step (split, per-tile reconstruction, merge) to share.
//!
//! Tiles are octree cells of the global cube, found adaptively: starting from the root, a cell
//! holding more than [`PlanOptions::points_per_tile`] points splits into its eight children, and
//! empty children are dropped. The counts come from a histogram of the points at
//! [`PlanOptions::histogram_depth`] (one entry per occupied voxel of that depth), which also gives
//! the median points per occupied voxel of every level: the finest level is the last level
//! whose median is at least [`PlanOptions::min_median_points`] (the reconstruction's own density
//! limit, §4.2 of the paper, computed over all inputs at once).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use octowrap_geom::{Aabb, DVec3, morton};
use serde::{Deserialize, Serialize};

use crate::{Error, header};

/// Default halo in voxels of the finest level (the crate docs derive it).
pub const DEFAULT_HALO_VOXELS: u32 = 12;

/// What a plan file says it is.
const KIND: &str = "octowrap tile plan";
/// The plan file's version.
const VERSION: u32 = 1;

/// How to plan. Construct with [`PlanOptions::default`] and set fields.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct PlanOptions {
    /// Most points a tile's own cell may hold before it splits (a cell at
    /// [`PlanOptions::max_tile_depth`] may hold more). Default 2 million.
    pub points_per_tile: u64,
    /// Halo width in voxels of the finest level. Default [`DEFAULT_HALO_VOXELS`].
    pub halo_voxels: u32,
    /// The finest level; `None` decides it from the density. Default `None`.
    pub level: Option<u32>,
    /// Padding of the root cube, as the reconstruction's [`octowrap_recon::ReconOptions::padding`].
    /// Default 0.01.
    pub padding: f64,
    /// The density limit of the finest level. Default 8, the reconstruction's.
    pub min_median_points: f64,
    /// Depth of the counting histogram (bounds the finest level found and the tile depth).
    /// Default 12.
    pub histogram_depth: u32,
    /// Deepest tile; `None`: two levels above the finest. Default `None`.
    pub max_tile_depth: Option<u32>,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            points_per_tile: 2_000_000,
            halo_voxels: DEFAULT_HALO_VOXELS,
            level: None,
            padding: 0.01,
            min_median_points: 8.0,
            histogram_depth: 12,
            max_tile_depth: None,
        }
    }
}

/// One input of the plan.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Input {
    /// The file, as given.
    pub path: PathBuf,
    /// Its number of points.
    pub points: u64,
    /// Whether its bounds came from a LAS/LAZ header (else from reading its points).
    pub bounds_from_header: bool,
}

/// One tile: an octree cell of the global cube.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Tile {
    /// Its number, its index in [`Plan::tiles`] (the cells in Morton order, coarser first).
    pub id: u32,
    /// The cell's octree depth.
    pub depth: u32,
    /// The cell's integer coordinates at its depth, each in `0..2^depth`.
    pub cell: [u32; 3],
    /// Points in the cell (without the halo).
    pub points: u64,
}

/// A tiling plan (the JSON file every step reads).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Always `octowrap tile plan`.
    pub kind: String,
    /// The plan file's version (1).
    pub version: u32,
    /// The inputs, in the order given.
    pub inputs: Vec<Input>,
    /// The smallest corner of all points' bounding box.
    pub bounds_min: [f64; 3],
    /// The largest corner of all points' bounding box.
    pub bounds_max: [f64; 3],
    /// The padding the cube was made with.
    pub padding: f64,
    /// The global root cube's smallest corner.
    pub cube_min: [f64; 3],
    /// The global root cube's edge (world units).
    pub cube_edge: f64,
    /// The finest level every tile reconstructs.
    pub level: u32,
    /// The halo width in voxels of [`Plan::level`].
    pub halo_voxels: u32,
    /// The point budget the tiles were split with.
    pub points_per_tile: u64,
    /// The tiles.
    pub tiles: Vec<Tile>,
}

/// The voxel codes of points at a depth, mirroring the reconstruction's octree (21-bit codes of
/// the point's place in the cube, shifted down).
pub(crate) struct Quantizer {
    origin: DVec3,
    inv: f64,
}

impl Quantizer {
    pub(crate) fn new(cube_min: DVec3, edge: f64) -> Self {
        Self { origin: cube_min, inv: 1.0 / edge }
    }

    /// The point's integer coordinates at `depth`.
    pub(crate) fn cell(&self, p: DVec3, depth: u32) -> [u32; 3] {
        let full = f64::from(1u32 << morton::MAX_DEPTH);
        let top = (1u32 << morton::MAX_DEPTH) - 1;
        let u = (p - self.origin) * self.inv;
        let q = |x: f64| ((x * full).max(0.0) as u32).min(top) >> (morton::MAX_DEPTH - depth);
        [q(u.x), q(u.y), q(u.z)]
    }
}

impl Plan {
    /// The global root cube.
    pub fn cube(&self) -> Aabb {
        let min = DVec3::from(self.cube_min);
        Aabb { min, max: min + DVec3::splat(self.cube_edge) }
    }

    /// The edge of a voxel of the finest level.
    pub fn voxel_edge(&self) -> f64 {
        self.cube_edge / f64::from(1u32 << self.level)
    }

    /// The halo width in world units.
    pub fn halo(&self) -> f64 {
        self.voxel_edge() * f64::from(self.halo_voxels)
    }

    /// The world box of a tile's cell.
    pub fn cell_box(&self, t: &Tile) -> Aabb {
        let e = self.cube_edge / f64::from(1u32 << t.depth);
        let min = DVec3::from(self.cube_min)
            + DVec3::new(f64::from(t.cell[0]), f64::from(t.cell[1]), f64::from(t.cell[2])) * e;
        Aabb { min, max: min + DVec3::splat(e) }
    }

    /// The tile with this id.
    pub fn tile(&self, id: u32) -> Result<&Tile, Error> {
        self.tiles.get(id as usize).ok_or_else(|| {
            Error::Plan(format!("no tile {id}: the plan has tiles 0 to {}", self.tiles.len().saturating_sub(1)))
        })
    }

    /// Reads and checks a plan file.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let plan: Self = serde_json::from_slice(&bytes).map_err(|e| {
            Error::invalid(
                path,
                e.line() as u64,
                format!("not a plan file: {e} (line {}, column {})", e.line(), e.column()),
            )
        })?;
        plan.check().map_err(|m| Error::invalid(path, 0, m))?;
        Ok(plan)
    }

    /// Writes the plan as JSON, atomically.
    pub fn save(&self, path: &Path, opts: &octowrap_fsutil::WriteOptions) -> Result<(), Error> {
        let json = serde_json::to_vec_pretty(self).map_err(|e| Error::Plan(e.to_string()))?;
        octowrap_fsutil::write_file(path, opts, |w| w.write_all(&json)).map_err(|e| match e {
            octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e) => Error::io(path, e),
        })
    }

    /// Checks what every later step relies on.
    fn check(&self) -> Result<(), String> {
        if self.kind != KIND || self.version != VERSION {
            return Err(format!("expected `{KIND}` version {VERSION}, found `{}` version {}", self.kind, self.version));
        }
        if !(self.cube_edge.is_finite() && self.cube_edge > 0.0 && DVec3::from(self.cube_min).is_finite()) {
            return Err("the cube is not finite".into());
        }
        if self.level == 0 || self.level > octowrap_recon::DEEPEST_LEVEL {
            return Err(format!("level {} outside 1..={}", self.level, octowrap_recon::DEEPEST_LEVEL));
        }
        for (i, t) in self.tiles.iter().enumerate() {
            if t.id as usize != i || t.depth > self.level || t.cell.iter().any(|&c| u64::from(c) >= 1u64 << t.depth) {
                return Err(format!("tile {i} is not a cell of the cube above level {}: {t:?}", self.level));
            }
        }
        Ok(())
    }

    /// The tiles as a lookup from (depth, Morton code of the cell) to the tile's index.
    pub(crate) fn cell_index(&self) -> HashMap<(u32, u64), usize> {
        self.tiles
            .iter()
            .enumerate()
            .map(|(i, t)| ((t.depth, morton::encode(t.cell[0], t.cell[1], t.cell[2])), i))
            .collect()
    }
}

/// Plans the tiling of `inputs` (see the module docs). Reads each LAS/LAZ input's header for its
/// bounds; every other format is read in full once for its bounds (the readers have no
/// streaming mode). Then reads every input once more, one at a time, to count its points per
/// voxel of [`PlanOptions::histogram_depth`].
pub fn build(inputs: &[PathBuf], opts: &PlanOptions) -> Result<Plan, Error> {
    if inputs.is_empty() {
        return Err(Error::Plan("no inputs to plan".into()));
    }
    if opts.points_per_tile == 0 {
        return Err(Error::Plan("the point budget per tile must be at least 1".into()));
    }
    let depth = opts.histogram_depth.clamp(1, morton::MAX_DEPTH);
    let read_opts = octowrap_io::ReadOptions::default();
    let mut listed = Vec::with_capacity(inputs.len());
    let mut bounds = Aabb::EMPTY;
    for path in inputs {
        let (points, b, from_header) = if let Some(h) = header::read_las_header(path)? {
            (h.points, h.bounds, true)
        } else {
            let mesh = octowrap_io::read_path(path, &read_opts)?;
            (mesh.vertices.len() as u64, mesh.vertices.bounds(), false)
        };
        bounds = bounds.union(&b);
        listed.push(Input { path: path.clone(), points, bounds_from_header: from_header });
    }
    let Some(cube) = bounds.bounding_cube(opts.padding) else {
        return Err(Error::Plan("the inputs hold no points".into()));
    };
    let edge = cube.size().x;
    let quant = Quantizer::new(cube.min, edge);
    let mut hist: BTreeMap<u64, u64> = BTreeMap::new();
    for (input, path) in listed.iter_mut().zip(inputs) {
        let mesh = octowrap_io::read_path(path, &read_opts)?;
        let pts = &mesh.vertices.positions;
        if let Some(i) = pts.iter().position(|p| !bounds.contains(*p)) {
            return Err(Error::Plan(format!(
                "{}: point {i} at {:?} lies outside the header's bounds {:?} .. {:?}",
                path.display(),
                pts[i],
                bounds.min,
                bounds.max
            )));
        }
        input.points = pts.len() as u64;
        for p in pts {
            let [x, y, z] = quant.cell(*p, depth);
            *hist.entry(morton::encode(x, y, z)).or_insert(0) += 1;
        }
    }
    let level = match opts.level {
        Some(k) if k == 0 || k > octowrap_recon::DEEPEST_LEVEL => {
            return Err(Error::Plan(format!("level {k} outside 1..={}", octowrap_recon::DEEPEST_LEVEL)));
        }
        Some(k) => k,
        None => density_level(&hist, depth, opts.min_median_points),
    };
    // The anchor points sit in the finest level's two corner voxels: no data may.
    let corner = [0, (1u32 << level) - 1];
    for c in corner {
        if quant.cell(bounds.min, level) == [c; 3] || quant.cell(bounds.max, level) == [c; 3] {
            return Err(Error::Plan(format!(
                "at level {level} the points reach a corner voxel of the cube: raise the padding"
            )));
        }
    }
    let max_tile = opts.max_tile_depth.unwrap_or(level.saturating_sub(2)).min(level).min(depth);
    let mut tiles = Vec::new();
    split_cells(&hist, depth, 0, 0, max_tile, opts.points_per_tile, &mut tiles);
    tiles.sort_by_key(|&(d, code, _)| (d, code));
    let tiles = tiles
        .into_iter()
        .enumerate()
        .map(|(i, (d, code, n))| Tile { id: i as u32, depth: d, cell: morton::decode(code), points: n })
        .collect();
    Ok(Plan {
        kind: KIND.into(),
        version: VERSION,
        inputs: listed,
        bounds_min: bounds.min.into(),
        bounds_max: bounds.max.into(),
        padding: opts.padding,
        cube_min: cube.min.into(),
        cube_edge: edge,
        level,
        halo_voxels: opts.halo_voxels,
        points_per_tile: opts.points_per_tile,
        tiles,
    })
}

/// Points of the histogram (at `depth`) inside the cell `code` of depth `d`.
fn count(hist: &BTreeMap<u64, u64>, depth: u32, d: u32, code: u64) -> u64 {
    let shift = 3 * (depth - d);
    let lo = code << shift;
    let hi = (code + 1) << shift;
    hist.range(lo..hi).map(|(_, n)| n).sum()
}

/// Adds the cell `code` of depth `d`, or its non-empty children while it is over the budget.
fn split_cells(
    hist: &BTreeMap<u64, u64>,
    depth: u32,
    d: u32,
    code: u64,
    max: u32,
    budget: u64,
    out: &mut Vec<(u32, u64, u64)>,
) {
    let n = count(hist, depth, d, code);
    if n == 0 {
        return;
    }
    if n <= budget || d >= max {
        out.push((d, code, n));
        return;
    }
    for child in 0..8 {
        split_cells(hist, depth, d + 1, (code << 3) | child, max, budget, out);
    }
}

/// The reconstruction's density limit over the histogram: the last level (at least 1) before
/// the first whose median points per occupied voxel falls below `min_median`.
fn density_level(hist: &BTreeMap<u64, u64>, depth: u32, min_median: f64) -> u32 {
    for j in 1..=depth {
        let shift = 3 * (depth - j);
        let mut counts: Vec<u64> = Vec::new();
        let mut last = None;
        for (&code, &n) in hist {
            let c = code >> shift;
            if last == Some(c) {
                *counts.last_mut().expect("pushed") += n;
            } else {
                counts.push(n);
                last = Some(c);
            }
        }
        let mid = counts.len() / 2;
        let (_, m, _) = counts.select_nth_unstable(mid);
        if (*m as f64) < min_median {
            return (j - 1).max(1);
        }
    }
    depth
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hist_of(points: &[[u32; 3]]) -> BTreeMap<u64, u64> {
        let mut h = BTreeMap::new();
        for p in points {
            *h.entry(morton::encode(p[0], p[1], p[2])).or_insert(0) += 1;
        }
        h
    }

    #[test]
    fn cells_split_only_over_budget() {
        // Depth-3 histogram: 10 points in the corner voxel, 1 in the opposite one.
        let mut pts = vec![[0, 0, 0]; 10];
        pts.push([7, 7, 7]);
        let h = hist_of(&pts);
        let mut out = Vec::new();
        split_cells(&h, 3, 0, 0, 3, 5, &mut out);
        out.sort_unstable();
        // The root (11) splits; child 7 (1 point) stays whole; child 0 (10) splits down to depth 3.
        assert_eq!(out, vec![(1, 7, 1), (3, 0, 10)]);
        let total: u64 = out.iter().map(|t| t.2).sum();
        assert_eq!(total, 11);
        let mut out = Vec::new();
        split_cells(&h, 3, 0, 0, 3, 11, &mut out);
        assert_eq!(out, vec![(0, 0, 11)]);
    }

    #[test]
    fn density_level_follows_the_median() {
        // 64 points per voxel at depth 1 in 8 voxels: 8 per voxel at depth 2, 1 at depth 3.
        let mut pts = Vec::new();
        for x in 0..8 {
            for y in 0..8 {
                for z in 0..8 {
                    pts.push([x, y, z]);
                }
            }
        }
        let h = hist_of(&pts);
        assert_eq!(density_level(&h, 3, 8.0), 2);
        assert_eq!(density_level(&h, 3, 1.0), 3);
        assert_eq!(density_level(&h, 3, 100.0), 1);
    }
}
