//! Merge: the finest level of every tile, as each tile owns it, into one mesh. A vertex of one
//! tile and a vertex of another are welded when they name the same lattice corner at the same
//! position (bit for bit): both tiles computed the border vertex the same way. Vertices of one
//! tile are never welded with each other (they are the tile's vertex splits).

use std::collections::HashMap;

use octowrap_mesh::{FaceList, FaceOrigin, Level, LevelLattice, Mesh, PointCloud};

use crate::Error;

/// Figures of a merge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MergeReport {
    /// Faces of the merged mesh.
    pub faces: usize,
    /// Vertices of the merged mesh.
    pub vertices: usize,
    /// Vertices welded with another tile's.
    pub welded: usize,
    /// Tile vertices on a lattice corner another tile also has, left apart because their
    /// positions differ (each is a crack along a seam).
    pub unwelded: usize,
    /// Faces on a slot (voxel, side) another tile's face also holds (ownership broken).
    pub duplicate_slots: usize,
}

/// Merges `tiles` (each the finest level one tile owns, with lattice coordinates) in order.
pub fn merge(tiles: &[Level]) -> Result<(Level, MergeReport), Error> {
    let mut positions = Vec::new();
    let mut corners = Vec::new();
    let mut faces = FaceList::default();
    let mut slots = Vec::new();
    // (corner, position bits) -> merged vertex and the tile that made it.
    let mut by_key: HashMap<([u32; 3], [u64; 3]), (u32, usize)> = HashMap::new();
    let mut corners_seen: HashMap<[u32; 3], usize> = HashMap::new();
    let mut slot_seen: HashMap<([u32; 3], u8), usize> = HashMap::new();
    let mut rep = MergeReport::default();
    for (t, level) in tiles.iter().enumerate() {
        let Some(lat) = &level.lattice else {
            return Err(Error::Plan(format!("tile level {t} has no lattice coordinates")));
        };
        let mut map = Vec::with_capacity(level.mesh.vertices.len());
        for (v, p) in level.mesh.vertices.positions.iter().enumerate() {
            let c = lat.vertex_corners[v];
            let key = (c, p.to_array().map(f64::to_bits));
            match by_key.get(&key) {
                Some(&(m, owner)) if owner != t => {
                    rep.welded += 1;
                    map.push(m);
                }
                _ => {
                    if corners_seen.get(&c).is_some_and(|&o| o != t) {
                        rep.unwelded += 1;
                    }
                    corners_seen.entry(c).or_insert(t);
                    let m = positions.len() as u32;
                    positions.push(*p);
                    corners.push(c);
                    by_key.entry(key).or_insert((m, t));
                    map.push(m);
                }
            }
        }
        for (f, face) in level.mesh.faces.iter().enumerate() {
            faces.push_iter(face.iter().map(|&v| map[v as usize]));
            let s = lat.face_slots[f];
            if slot_seen.insert(s, t).is_some_and(|o| o != t) {
                rep.duplicate_slots += 1;
            }
            slots.push(s);
        }
    }
    rep.faces = faces.len();
    rep.vertices = positions.len();
    let origins = vec![FaceOrigin::Created; faces.len()];
    let level = Level {
        mesh: Mesh { vertices: PointCloud::from_positions(positions), faces },
        origins,
        lattice: Some(LevelLattice { face_slots: slots, vertex_corners: corners }),
    };
    Ok((level, rep))
}
