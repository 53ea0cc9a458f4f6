//! A tile's reconstruction: the options and anchor points that put it on the global lattice
//! (crate docs, "One lattice for every tile"), and the faces it keeps (crate docs,
//! "Ownership").

use octowrap_geom::{DVec3, morton};
use octowrap_mesh::{FaceList, Hierarchy, Level, LevelLattice, Mesh, PointCloud};
use octowrap_recon::{MaxLevel, ReconOptions};

use crate::plan::Quantizer;
use crate::{Error, Plan, Tile};

/// The two anchor points: the global cube's smallest and largest corners. With no padding, the
/// bounding cube of any points inside the global cube plus these two is the global cube.
pub fn anchors(plan: &Plan) -> [DVec3; 2] {
    let c = plan.cube();
    [c.min, c.max]
}

/// `base` set up for a tile of `plan`: no padding (the anchors span the cube), exactly
/// [`Plan::level`] levels, every level wrapped (the density limit is the plan's, decided over
/// all inputs, not over one tile's points).
pub fn recon_options(plan: &Plan, base: &ReconOptions) -> ReconOptions {
    let mut o = base.clone();
    o.padding = 0.0;
    o.max_level = MaxLevel::Level(plan.level);
    o.min_median_points = f64::MIN_POSITIVE;
    o
}

/// Reconstructs tile `id` from its points (own cell and halo) on the plan's lattice and keeps,
/// at the finest level, only the faces it owns. The coarser levels stay whole: they are the
/// tile's own view of the scene and differ from the untiled run's (crate docs, "The halo").
pub fn reconstruct_tile(plan: &Plan, id: u32, points: &[DVec3], base: &ReconOptions) -> Result<Hierarchy, Error> {
    let tile = *plan.tile(id)?;
    let mut pts = Vec::with_capacity(points.len() + 2);
    pts.extend_from_slice(points);
    pts.extend(anchors(plan));
    let opts = recon_options(plan, base);
    let mut h = octowrap_recon::reconstruct(&pts, &opts).map_err(|source| Error::Recon { tile: id, source })?;
    let cube = h.cube.unwrap_or(plan.cube());
    let (a, b) = (cube.min - plan.cube().min, cube.max - plan.cube().max);
    if a.abs().max_element().max(b.abs().max_element()) > plan.cube_edge * 1e-12 {
        return Err(Error::Plan(format!("tile {id}: the reconstruction's cube {cube:?} is not the plan's")));
    }
    let finest = h.levels.last_mut().expect("at least the root level");
    *finest = keep_owned(plan, &tile, plan.level, finest)?;
    Ok(h)
}

/// Whether a voxel of level `level` lies in the tile's cell.
pub fn owns(tile: &Tile, level: u32, voxel: [u32; 3]) -> bool {
    let s = level - tile.depth;
    voxel.map(|c| c >> s) == tile.cell
}

/// The faces of `level` (octree level `k`, at least the tile's depth) that the tile owns, with
/// the vertices they use. Faces of an anchor's voxel are dropped where no data point reaches
/// that voxel (always at the plan's finest level, which the plan checks).
pub fn keep_owned(plan: &Plan, tile: &Tile, k: u32, level: &Level) -> Result<Level, Error> {
    let Some(lat) = &level.lattice else {
        return Err(Error::Plan(format!("level {k} has no lattice coordinates")));
    };
    if k < tile.depth || lat.face_slots.len() != level.mesh.faces.len() {
        return Err(Error::Plan(format!("level {k} cannot be cut by tile {} of depth {}", tile.id, tile.depth)));
    }
    let quant = Quantizer::new(DVec3::from(plan.cube_min), plan.cube_edge);
    let top = (1u32 << k) - 1;
    let data = [quant.cell(DVec3::from(plan.bounds_min), k), quant.cell(DVec3::from(plan.bounds_max), k)];
    let anchor = |v: [u32; 3]| (v == [0; 3] && data[0] != [0; 3]) || (v == [top; 3] && data[1] != [top; 3]);
    let keep: Vec<usize> = (0..level.mesh.faces.len())
        .filter(|&f| {
            let (v, _) = lat.face_slots[f];
            owns(tile, k, v) && !anchor(v)
        })
        .collect();
    Ok(subset(level, &keep))
}

/// The faces `keep` of `level` (in that order) with their used vertices, renumbered by first use.
pub(crate) fn subset(level: &Level, keep: &[usize]) -> Level {
    let mesh = &level.mesh;
    let lat = level.lattice.as_ref();
    let mut map = vec![u32::MAX; mesh.vertices.len()];
    let mut order = Vec::new();
    let mut faces = FaceList::with_capacity(keep.len(), 4 * keep.len());
    for &f in keep {
        let face: Vec<u32> = mesh
            .faces
            .face(f)
            .iter()
            .map(|&v| {
                if map[v as usize] == u32::MAX {
                    map[v as usize] = order.len() as u32;
                    order.push(v as usize);
                }
                map[v as usize]
            })
            .collect();
        faces.push(&face);
    }
    let mut vertices = PointCloud::from_positions(order.iter().map(|&v| mesh.vertices.positions[v]).collect());
    vertices.normals = mesh.vertices.normals.as_ref().map(|n| order.iter().map(|&v| n[v]).collect());
    vertices.colors = mesh.vertices.colors.as_ref().map(|c| order.iter().map(|&v| c[v]).collect());
    vertices.intensities = mesh.vertices.intensities.as_ref().map(|c| order.iter().map(|&v| c[v]).collect());
    Level {
        mesh: Mesh { vertices, faces },
        origins: keep.iter().map(|&f| level.origins[f]).collect(),
        lattice: lat.map(|l| LevelLattice {
            face_slots: keep.iter().map(|&f| l.face_slots[f]).collect(),
            vertex_corners: order.iter().map(|&v| l.vertex_corners[v]).collect(),
        }),
    }
}

/// The Morton code of a tile's cell, for ordering.
pub fn cell_code(tile: &Tile) -> u64 {
    morton::encode(tile.cell[0], tile.cell[1], tile.cell[2])
}
