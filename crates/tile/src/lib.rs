//! Tiled reconstruction: scenes larger than one machine's memory cut into tiles that separate
//! workers reconstruct, then welded into one mesh.
//!
//! The anchors are Kazhdan & Hoppe's *Distributed Poisson Surface Reconstruction* (2023: one
//! low-resolution pass shared by all, high-resolution work per node), Entwine's subset builds and
//! PDAL's `filters.splitter`. The stages, one module each:
//!
//! | stage | module | what it does |
//! |---|---|---|
//! | plan | `plan` | one global root cube, the finest level, tiles as octree cells under a point budget, the halo |
//! | header pass | `header` | LAS/LAZ bounds and counts from the public header block, without reading points |
//! | split | `split`, `points` | each input's points binned into per-tile files (own cell plus halo); parts merged per tile |
//! | ownership | `own` | the options and anchor points a tile's reconstruction runs with; the faces a tile keeps |
//! | merge | `merge` | the kept faces of every tile as one mesh, vertices welded by lattice corner and position |
//!
//! # One lattice for every tile
//! The plan's root cube is the cube the untiled run uses: the bounding box of all points made
//! cubic and padded by [`Plan::padding`] of its longest extent on every side
//! ([`octowrap_geom::Aabb::bounding_cube`]). A tile's reconstruction sees its own points, its
//! halo, and two *anchor points* at two opposite corners of the global cube with no padding, so
//! the reconstruction's own cube is the global one and every tile's octree lattice at every level
//! is the same global lattice. The anchors occupy the two corner voxels of the finest level;
//! the padding keeps every data point out of them (the plan checks it), and no tile keeps a face
//! of those two voxels ([`own`]).
//!
//! # Ownership
//! A face of the finest level `K` is the pair (voxel, side). It belongs to the tile whose octree
//! cell contains its voxel: cells are half-open, so each voxel lies in exactly one cell and each
//! face has exactly one owner. Vertices are not owned: both tiles beside a border compute the
//! border's vertices, and the merge welds a vertex pair that names the same lattice corner at the
//! same position.
//!
//! # The halo: how far every stage reaches
//! A face of level `K` depends on points in a neighbourhood of its voxel. In voxels of level `K`
//! (edge `h = cube / 2^K`), stage by stage (the recon crate's modules):
//!
//! * occupancy and the gap filling (`octree`): the voxel and its face neighbours: 1;
//! * the oriented-sheet mask (`sheet`): a plane fitted to the 3x3x3 block: 1; signs voted by the
//!   26 neighbours: 1 more;
//! * the diagonal decision (`irregular`): one plane fitted to two voxels across an edge: 1;
//! * vertex mapping (`mapping`): the voxels of the vertex's fan, grown by their neighbours under
//!   3 points, points within half an edge: 2;
//! * relaxation (`relax`): each pass moves a vertex to its one-ring centroid: one ring per pass,
//!   4 passes: 4;
//! * the least-squares fit (`least_squares`): each of the 3 passes couples a vertex with its
//!   one-ring through the membrane: 3 (its sparse solve is global, so this bound holds only for
//!   the local terms; the coupling beyond decays but does not vanish).
//!
//! Sheet, diagonal and mapping overlap in the same neighbourhood (a fan's voxels are the
//! voxel's own block), so the reach is `1 + 1 + 2 + 4 + 3 = 11` voxels of level `K`; the plan's
//! default halo is 12 ([`DEFAULT_HALO_VOXELS`]). Coarser levels reach `2^(K - j)` times as far
//! in world units, and their topology hangs on the whole chain of coarser levels (regular
//! refinement carries every face down from level 0), so no finite halo makes a tile's coarse
//! levels equal to the untiled run's: the merged mesh is the finest level, and coarse levels of a
//! tiled run need one global pass over a subsample (the recon crate does not offer it).
//!
//! # Seams, measured
//! `autzen_trim.laz` (110,000 points, finest level 7, voxel 9.38 m) planned with
//! `--points-per-tile 60000` gives the cube's 8 octants as tiles (the scan straddles the cube's
//! middle height). Merged level 7 against the untiled run (`octowrap validate`): 11,634 faces in
//! both, no face on another tile's slot; 443 border vertices welded, 174 left apart because the
//! two tiles computed different positions; 2,224 boundary edges against 1,874 (the 350 more lie
//! along seams), 9 non-manifold vertices, and the
//! untiled run's manifold, oriented surface otherwise. On a sampled sphere cut into octants (the
//! `seams` test) the merged slots equal the untiled run's exactly. So the topology of the finest
//! level is local within the halo; the positions are not, and these reconstruction changes
//! would make them so:
//!
//! 1. `ReconOptions::cube` (a given root cube) in place of the anchor points and zero padding;
//! 2. `ReconOptions::trusted_level` (the density limit decided by the plan over all inputs);
//! 3. the least-squares fit (`least_squares`) solved per tile with the vertices of faces outside
//!    the tile's cell held fixed at positions both tiles share, or solved in windows whose
//!    borders are pinned: its sparse solve couples every vertex of a component today;
//! 4. relaxation and mapping of border vertices computed from the halo's points only, with the
//!    one-ring taken from the lattice (both tiles see the same faces around a border vertex);
//! 5. coarse levels from one global pass over a subsample (levels above the tile depth), handed
//!    to every tile as the parent level its regular refinement starts from
//!    (`reconstruct_from(parent: &Level, ...)`), so parent links and MRQ prediction agree across
//!    tiles and the merged hierarchy, not only its finest level, is seamless.
#![deny(missing_docs)]

mod error;
mod header;
pub mod merge;
pub mod own;
pub mod plan;
pub mod points;
pub mod split;

pub use error::Error;
pub use header::{LasHeader, read_las_header};
pub use plan::{DEFAULT_HALO_VOXELS, Plan, PlanOptions, Tile};
