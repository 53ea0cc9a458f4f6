//! Split: each input's points binned into per-tile parts (one task per input), and the parts of
//! one tile merged in the plan's input order (one task per tile). A point goes to the tile whose
//! cell contains it and to every tile whose cell lies within the halo ([`Plan::halo`]) of it.

use std::path::{Path, PathBuf};

use octowrap_geom::{DVec3, morton};

use crate::plan::Quantizer;
use crate::{Error, Plan, points};

/// The part one input gives one tile: `DIR/tile-ID.input-I.pts`.
pub fn part_path(dir: &Path, tile: u32, input: usize) -> PathBuf {
    dir.join(format!("tile-{tile}.input-{input}.pts"))
}

/// All of a tile's points: `DIR/tile-ID.pts`.
pub fn tile_path(dir: &Path, tile: u32) -> PathBuf {
    dir.join(format!("tile-{tile}.pts"))
}

/// The points of `points` for each tile of the plan (own cell plus halo), in input order.
/// A point outside every tile and halo (possible only for points outside the plan's bounds)
/// goes nowhere.
pub fn bin(plan: &Plan, points: &[DVec3]) -> Vec<Vec<DVec3>> {
    let index = plan.cell_index();
    let mut depths: Vec<u32> = plan.tiles.iter().map(|t| t.depth).collect();
    depths.sort_unstable();
    depths.dedup();
    let quant = Quantizer::new(DVec3::from(plan.cube_min), plan.cube_edge);
    let h = plan.halo();
    let boxes: Vec<_> = plan.tiles.iter().map(|t| plan.cell_box(t)).collect();
    let mut out = vec![Vec::new(); plan.tiles.len()];
    let mut hit = Vec::new();
    for &p in points {
        hit.clear();
        for &d in &depths {
            // The cells at depth `d` the halo box around `p` touches.
            let lo = quant.cell(p - DVec3::splat(h), d);
            let hi = quant.cell(p + DVec3::splat(h), d);
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        if let Some(&i) = index.get(&(d, morton::encode(x, y, z))) {
                            hit.push(i);
                        }
                    }
                }
            }
        }
        hit.sort_unstable();
        hit.dedup();
        for &i in &hit {
            let b = &boxes[i];
            let own = quant.cell(p, plan.tiles[i].depth) == plan.tiles[i].cell;
            let near = (b.min - DVec3::splat(h)).cmple(p).all() && p.cmple(b.max + DVec3::splat(h)).all();
            if own || near {
                out[i].push(p);
            }
        }
    }
    out
}

/// Splits input `input` of the plan: reads it and writes one part per tile into `dir` (empty
/// parts too, so that a tile's merge can tell a missing part from an empty one). Returns the
/// points written per tile.
pub fn split_input(
    plan: &Plan,
    input: usize,
    dir: &Path,
    opts: &octowrap_fsutil::WriteOptions,
) -> Result<Vec<usize>, Error> {
    let Some(inp) = plan.inputs.get(input) else {
        return Err(Error::Plan(format!("no input {input}: the plan has {}", plan.inputs.len())));
    };
    let mesh = octowrap_io::read_path(&inp.path, &octowrap_io::ReadOptions::default())?;
    let pts = mesh.vertices.positions;
    if pts.len() as u64 != inp.points {
        return Err(Error::Plan(format!(
            "{}: {} points, the plan counted {}: the input changed since it was planned",
            inp.path.display(),
            pts.len(),
            inp.points
        )));
    }
    let bins = bin(plan, &pts);
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for (t, b) in bins.iter().enumerate() {
        points::write(&part_path(dir, t as u32, input), b, opts)?;
    }
    Ok(bins.iter().map(Vec::len).collect())
}

/// Merges the parts of tile `tile` in `dir` (every input's, in the plan's order) into
/// [`tile_path`]. Returns the tile's number of points.
pub fn merge_parts(plan: &Plan, tile: u32, dir: &Path, opts: &octowrap_fsutil::WriteOptions) -> Result<usize, Error> {
    plan.tile(tile)?;
    let mut all = Vec::new();
    for i in 0..plan.inputs.len() {
        all.extend(points::read(&part_path(dir, tile, i))?);
    }
    points::write(&tile_path(dir, tile), &all, opts)?;
    Ok(all.len())
}
