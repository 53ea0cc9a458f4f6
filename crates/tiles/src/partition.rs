//! The tile partition: which faces of which level each tile holds, and the tile tree.
//!
//! A [`Partition`] turns a hierarchy into a [`TileTree`]; the writer only sees the tree, so another
//! partition (MRQ chunks) plugs in without touching it. [`OctreePartition`] is the one the export
//! uses.
//!
//! # The octree partition
//! Levels `0..=base` are one tile each, chained from the coarsest (the root tile) down: `base` is
//! the finest level with at most [`OctreePartition::target_faces`] faces. Level `base + d` is cut
//! by the octree cells of depth `d` of the hierarchy's cube (the octree root cube, or the bounding
//! cube of every level): a tile is that level's faces inside one cell, its children the next
//! level's faces in that cell's eight children.
//!
//! A face's cell follows its parent: a subface goes to the child of its parent's cell whose octant
//! holds the subface's centroid, so a tile's children hold exactly the faces descending from the
//! tile's faces (plus faces created in the cell), and every tile's region nests in its parent's. A
//! created face goes to the cell of depth `d` holding its centroid. Cells holding no face but with
//! descendants that do become tiles without content.

use octowrap_geom::{Aabb, DVec3};
use octowrap_mesh::{FaceOrigin, Hierarchy, Mesh};

use crate::Error;

/// An octree cell: depth and integer coordinates in `[0, 2^depth)^3`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cell {
    /// Depth below the root cube (0 = the cube itself).
    pub depth: u8,
    /// Coordinates in units of the cell's edge.
    pub xyz: [u32; 3],
}

impl Cell {
    /// The root cube.
    pub const ROOT: Self = Self { depth: 0, xyz: [0; 3] };

    /// The parent cell (the root is its own parent).
    #[must_use]
    pub fn parent(self) -> Self {
        if self.depth == 0 { self } else { Self { depth: self.depth - 1, xyz: self.xyz.map(|c| c >> 1) } }
    }

    /// The ancestor at `depth` (`depth <= self.depth`).
    #[must_use]
    pub fn ancestor(self, depth: u8) -> Self {
        let shift = self.depth - depth;
        Self { depth, xyz: self.xyz.map(|c| c >> shift) }
    }

    /// Child `octant` (bit 0: x, bit 1: y, bit 2: z).
    #[must_use]
    pub fn child(self, octant: u8) -> Self {
        let bit = |k: u8| u32::from((octant >> k) & 1);
        Self {
            depth: self.depth + 1,
            xyz: [self.xyz[0] * 2 + bit(0), self.xyz[1] * 2 + bit(1), self.xyz[2] * 2 + bit(2)],
        }
    }

    /// The cell's box inside `cube`.
    pub fn bounds(self, cube: &Aabb) -> Aabb {
        let edge = cube.size() / f64::from(1u32 << self.depth);
        let min = cube.min + DVec3::new(f64::from(self.xyz[0]), f64::from(self.xyz[1]), f64::from(self.xyz[2])) * edge;
        Aabb { min, max: min + edge }
    }
}

/// One tile of a [`TileTree`].
#[derive(Clone, Debug, PartialEq)]
pub struct TileNode {
    /// The hierarchy level the tile's faces come from.
    pub level: usize,
    /// The octree cell the tile covers.
    pub cell: Cell,
    /// The level's faces the tile holds, ascending (empty: a tile without content).
    pub faces: Vec<u32>,
    /// Child tiles (indices into [`TileTree::nodes`]), ascending by cell.
    pub children: Vec<usize>,
}

/// Tiles as a tree; node 0 is the root. Parents come before their children.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TileTree {
    /// The tiles, parents first.
    pub nodes: Vec<TileNode>,
    /// The cube whose octree cells the tiles cover.
    pub cube: Aabb,
    /// Per tile: the finest level's faces over the same region (ascending), for its error.
    pub regions: Vec<Vec<u32>>,
}

/// Cuts a hierarchy into tiles.
pub trait Partition {
    /// The tile tree of `h`: every face of every level in exactly one tile, each tile's children
    /// the next level's faces over the same region, and for each tile the finest faces over that
    /// region.
    fn tiles(&self, h: &Hierarchy) -> Result<TileTree, Error>;
}

/// The octree partition (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct OctreePartition {
    /// Faces above which a level is cut into cells. Default: 16384.
    pub target_faces: usize,
}

impl Default for OctreePartition {
    fn default() -> Self {
        Self { target_faces: 16384 }
    }
}

fn centroid(mesh: &Mesh, face: &[u32]) -> DVec3 {
    let p = &mesh.vertices.positions;
    face.iter().map(|&v| p[v as usize]).sum::<DVec3>() / face.len() as f64
}

/// Deepest cell level the partition makes: coordinates stay exact in `u32` and `f64`.
const MAX_DEPTH: usize = 20;

/// Refuses a hierarchy the partition cannot tile: no levels, broken links or indices, a
/// non-finite vertex, a level without faces.
fn check_tileable(h: &Hierarchy) -> Result<(), Error> {
    if h.levels.is_empty() {
        return Err(Error::invalid("the hierarchy has no levels"));
    }
    h.check_links().map_err(|e| Error::invalid(e.to_string()))?;
    for (k, l) in h.levels.iter().enumerate() {
        l.mesh.check_indices().map_err(|e| Error::invalid(format!("level {k}: {e}")))?;
        if let Some(v) = l.mesh.vertices.positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::invalid(format!("level {k}: vertex {v} has a non-finite coordinate")));
        }
        if l.mesh.faces.is_empty() {
            return Err(Error::invalid(format!("level {k} has no faces: every level of a tileset needs some")));
        }
    }
    Ok(())
}

/// The cube the cells divide: the hierarchy's own, else a bounding cube of every level.
fn cube_of(h: &Hierarchy) -> Aabb {
    h.cube
        .filter(|c| !c.is_empty() && c.size().min_element() > 0.0)
        .or_else(|| {
            let mut b = Aabb::EMPTY;
            for l in &h.levels {
                for p in &l.mesh.vertices.positions {
                    b.grow(*p);
                }
            }
            b.bounding_cube(0.001)
        })
        .unwrap_or(Aabb { min: DVec3::ZERO, max: DVec3::ONE })
}

/// Per level, each face's cell: the root up to `base`; below it, a subface takes the octant of
/// its parent's cell that holds its centroid, a created face the cell of its centroid.
fn face_cells(h: &Hierarchy, base: usize, cube: &Aabb) -> Vec<Vec<Cell>> {
    let mut cells: Vec<Vec<Cell>> = Vec::with_capacity(h.levels.len());
    for (k, level) in h.levels.iter().enumerate() {
        let mesh = &level.mesh;
        let of_level: Vec<Cell> = if k <= base {
            vec![Cell::ROOT; mesh.faces.len()]
        } else {
            let depth = (k - base) as u8;
            let parent_cells = &cells[k - 1];
            mesh.faces
                .iter()
                .zip(&level.origins)
                .map(|(f, o)| {
                    let c = centroid(mesh, f);
                    match *o {
                        FaceOrigin::Subface { parent, .. } => {
                            let pc = parent_cells[parent as usize];
                            let mid = pc.bounds(cube).center();
                            let octant =
                                u8::from(c.x >= mid.x) | (u8::from(c.y >= mid.y) << 1) | (u8::from(c.z >= mid.z) << 2);
                            pc.child(octant)
                        }
                        FaceOrigin::Created => {
                            let n = f64::from(1u32 << depth);
                            let rel = ((c - cube.min) / cube.size() * n).floor();
                            let max = (1u32 << depth) - 1;
                            let at = |x: f64| (x.max(0.0) as u32).min(max);
                            Cell { depth, xyz: [at(rel.x), at(rel.y), at(rel.z)] }
                        }
                    }
                })
                .collect()
        };
        cells.push(of_level);
    }
    cells
}

impl Partition for OctreePartition {
    fn tiles(&self, h: &Hierarchy) -> Result<TileTree, Error> {
        check_tileable(h)?;
        let cube = cube_of(h);
        let base = (0..h.levels.len())
            .rev()
            .find(|&k| h.levels[k].mesh.faces.len() <= self.target_faces)
            .unwrap_or(0)
            .max(h.levels.len().saturating_sub(MAX_DEPTH + 1));
        let cells = face_cells(h, base, &cube);
        // Tiles: (level, cell) keys of every face and of every ancestor of one.
        let mut keys: Vec<(usize, Cell)> = Vec::new();
        for (k, of_level) in cells.iter().enumerate() {
            keys.extend(of_level.iter().map(|&c| (k, c)));
        }
        keys.sort_unstable();
        keys.dedup();
        let mut all = keys.clone();
        for &(k, c) in &keys {
            let (mut k, mut c) = (k, c);
            while k > 0 {
                c = if k > base { c.parent() } else { c };
                k -= 1;
                all.push((k, c));
            }
        }
        all.sort_unstable();
        all.dedup();
        let index = |k: usize, c: Cell| all.binary_search(&(k, c)).expect("every tile's parent was added");
        let mut nodes: Vec<TileNode> = all
            .iter()
            .map(|&(level, cell)| TileNode { level, cell, faces: Vec::new(), children: Vec::new() })
            .collect();
        for (k, of_level) in cells.iter().enumerate() {
            for (f, &c) in of_level.iter().enumerate() {
                nodes[index(k, c)].faces.push(f as u32);
            }
        }
        for (i, &(k, c)) in all.iter().enumerate() {
            if k > 0 {
                let p = index(k - 1, if k > base { c.parent() } else { c });
                nodes[p].children.push(i);
            }
        }
        // Regions: the finest faces under each tile's cell.
        let finest = h.levels.len() - 1;
        let mut regions = vec![Vec::new(); nodes.len()];
        let everything: Vec<u32> = (0..h.levels[finest].mesh.faces.len() as u32).collect();
        for k in 0..=base.min(finest) {
            regions[index(k, Cell::ROOT)].clone_from(&everything);
        }
        for (f, &c) in cells[finest].iter().enumerate() {
            for k in base + 1..=finest {
                regions[index(k, c.ancestor((k - base) as u8))].push(f as u32);
            }
        }
        Ok(TileTree { nodes, cube, regions })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_nest() {
        let c = Cell::ROOT.child(5).child(2);
        assert_eq!(c, Cell { depth: 2, xyz: [2, 1, 2] });
        assert_eq!(c.parent(), Cell { depth: 1, xyz: [1, 0, 1] });
        assert_eq!(c.ancestor(0), Cell::ROOT);
        let cube = Aabb { min: DVec3::ZERO, max: DVec3::splat(4.0) };
        assert_eq!(c.bounds(&cube), Aabb { min: DVec3::new(2.0, 1.0, 2.0), max: DVec3::new(3.0, 2.0, 3.0) });
    }
}
