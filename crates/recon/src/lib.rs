//! Surface reconstruction from unorganized point clouds into a multiresolution quad hierarchy,
//! after Keller, Hering-Bertram & Hagen, *Surface Reconstruction from Unorganized 3D Point
//! Clouds* (sections 3.1-4.2).
//!
//! One entry point, [`reconstruct`] (or [`reconstruct_with`] for timings and progress), turns
//! points into a [`Hierarchy`]: level 0 is the bounding cube's six faces, and every level `j`
//! is a two-manifold quad mesh (possibly with boundary where the data has holes) wrapped around
//! the occupied voxels of octree level `j`, its vertices mapped onto tangent planes of the
//! points, every face linked to its parent face and quadrant one level up or marked created.
//!
//! ```
//! use octowrap_recon::{reconstruct, ReconOptions, MaxLevel};
//! use octowrap_geom::DVec3;
//!
//! // A sampled sphere.
//! let pts: Vec<DVec3> = (0..4000)
//!     .map(|i| {
//!         let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / 4000.0;
//!         let phi = f64::from(i) * 2.399_963;
//!         let r = (1.0 - z * z).sqrt();
//!         DVec3::new(r * phi.cos(), r * phi.sin(), z)
//!     })
//!     .collect();
//! let mut opts = ReconOptions::default();
//! opts.max_level = MaxLevel::Level(4);
//! let h = reconstruct(&pts, &opts).unwrap();
//! assert_eq!(h.levels.len(), 5);
//! assert!(h.check_links().is_ok());
//! assert!(h.levels.iter().all(|l| l.mesh.faces.all_quads()));
//! ```
//!
//! # The pipeline, one module per stage
//! | stage | module | paper |
//! |---|---|---|
//! | hierarchical space partitioning | `octree` | §3.2 |
//! | which slots may hold faces (oriented sheets) | `sheet` | §3.4-3.5 stop rules |
//! | regular refinement `R` | `regular` | §3.4 |
//! | irregular refinement `I` (closure, diagonal case) | `irregular` | §3.5 |
//! | vertex extraction, vertex and edge splits | `extract` | §3.5, Fig. 5 |
//! | vertex mapping | `mapping` | §3.6 |
//! | relaxation | `relax` | §3.6.1 |
//! | least-squares fit to the points (beyond the paper) | `fitting` | after §3.6.1 |
//! | density limit, subdivision beyond it | `sparse` | §4.2 |
//! | trusted level per region (optional) | `regions` | §4.2 |
//! | gaps of sparsely sampled sheets | `octree` (`fill_gaps`) | §4.2 |
//!
//! # Readings of the paper
//! Where the paper is vague we took these readings (each module's docs give the details):
//!
//! * **Faces are slots (§3.3).** A face is a pair (voxel, side) with the side's neighbour empty,
//!   at most one per slot, oriented outwards. A level's mesh is a set of slots; two faces are
//!   linked exactly when each is the other's partner across their common lattice edge (convex,
//!   flat, concave or diagonal, §3.5 cases 1-3), so the rules only decide which slots exist.
//! * **Regular refinement (§3.4)**: subface to `c_out` if occupied, else `c_in`; "not onto a
//!   subvoxel with a face on the opposite side" is read order-independently as "`c_out` wins".
//! * **Stop rules (§3.5 rules 1 and 2)** are replaced by one order-independent predicate on slots,
//!   the oriented-sheet mask of `sheet`: a voxel whose neighbourhood is a flat single sheet of
//!   points, oriented outwards by the coarser level's faces, refuses faces looking into the object.
//!   Read literally, the paper's rules depend on visiting order, and in a prototype they both let
//!   holes close and refused to wrap one-voxel protrusions. A voxel too curved or too thinly
//!   sampled for a plane of its own leans with its oriented neighbours when its points continue
//!   their sheet in one thin layer (the curling rim of a hole), so the wrapping does not take the
//!   inside of the shell there.
//! * **The diagonal case (§3.5 case 3b)** is decided per voxel pair from one plane fitted to both
//!   voxels' points (pass unless the joint RMS residual exceeds 0.2 voxel with 4+ points each),
//!   not from the two voxels' separate normals, which broke sampled spheres.
//! * **Vertex and edge splits (§3.5, Fig. 5)** happen by construction: vertices are the fans of
//!   linked faces around each lattice point, so they are manifold; a remaining pinched diagonal
//!   edge has its decision flipped (the edge split).
//! * **Vertex mapping (§3.6)**: `W` = the voxels of the vertex's fan; the `2|p - v| < l` filter;
//!   growth to adjacent voxels under 3 points. Level 0 (the root cube) is not mapped. The
//!   paper's plane is the default; [`ReconOptions::quadric_mapping`] puts a wrapped level's
//!   vertex instead onto a weighted height-field quadric of `W`'s points within one edge
//!   (Gaussian weights of half an edge). Without the fit below, the quadric was 3-8 % closer to
//!   the points on the bunny at levels 1-5 and 1-5 % on the dragon at levels 2-7, for about 30 %
//!   more mapping time; with the fit, the plane is as close (within 1-3 %, better or worse by
//!   level; `tools/bench/RESULTS.md`) and the whole reconstruction 4-6 % cheaper, so the plane
//!   became the default again.
//! * **Relaxation (§3.6.1)**: Laplacian to the one-ring centroid, then re-projection on the
//!   vertex's own plane. The paper relaxes every level; measured (`tools/bench/RESULTS.md`), it
//!   lowers the bunny's points-to-mesh error by up to 19 % from level 4 on but raises it by up to
//!   2x at levels 1-2 (the centroid of a coarse one-ring lies far inside), and is neutral on the
//!   dragon past level 3. So the default is the paper's 4 passes from level 4 on
//!   ([`ReconOptions::relax_from_level`]).
//! * **Fit to the points (beyond the paper)**: the mapping puts every vertex on its tangent
//!   plane, so the vertices lie on the surface but the faces between them do not: a coarse face
//!   spans a curved patch, and its points stay far from it. After the relaxation, every level of
//!   at most [`ReconOptions::fit_max_faces`] faces has its vertices fitted to the points by least
//!   squares with the connectivity fixed ([`ReconOptions::fit_passes`] passes of projection and
//!   a sparse solve, after Hoppe et al.'s mesh optimisation), with a weak pull towards the mapped
//!   positions and a weak membrane that keeps thinly sampled vertices with their neighbours.
//!   Measured (`tools/bench/RESULTS.md`): on the bunny the points-to-mesh RMS of levels 1-7 falls
//!   from .0337 .0222 .0113 .0057 .0023 .00093 .00039 to .0223 .0142 .0060 .0021 .00080 .00024
//!   .00008 (the paper's Table 3: .0259 .0095 .0036 .0011 .0004 .00014 for levels 1-6), falling
//!   1.6-3.3x per level, while the vertices stay as near the points as before. Off with
//!   `fit_passes = 0`.
//! * **Sparse data (§4.2)**: a level is trusted while the median points per occupied voxel is at
//!   least 8; [`MaxLevel::Auto`] stops there; deeper levels asked for are subdivided and mapped.
//! * **Gaps of sparse sheets (§4.2 with §3.5's holes)**: the paper keeps holes "where the data
//!   has holes" and warns that below the sampling density the mesh fragments (Fig. 8(b)). A
//!   trusted level can still be locally too sparse: on the dragon's thinly sampled underside the
//!   level-7 voxels hold 1-5 points and leave one-voxel gaps in a one-voxel-thick layer, which
//!   the oriented-sheet mask rightly keeps open as it keeps any hole in a sheet. We read such a
//!   gap as missing samples, not a hole: before a level is wrapped, an empty voxel on the surface
//!   (one of its two neighbours along some axis empty) with at least 3 of its 4 neighbours
//!   across that axis occupied, by at most 8 points each on average, whose points form a flat
//!   sheet across the axis (spread along it under 0.2 voxel: not the walls and floor of a narrow
//!   groove, which a first version bridged, doubling the dragon's level-7 error), is added as a
//!   voxel without points ([`ReconOptions::fill_gaps`]). Dense data keeps its holes (a one-voxel
//!   hole among voxels of more than 8 points stays), and the bunny's open bottom, many voxels
//!   wide, stays open. Dragon level 7: 52 boundary loops before, 23 after, same error.
//! * **Trusted level per region (§4.2)**, optional ([`ReconOptions::region_levels`], off by
//!   default): the paper's "fix the topology at a coarser level" read per region, as in the
//!   prototype's fourth round (`../shared/docs/reconstruction.md`). Before level `j + 1`, a voxel
//!   whose 3x3x3 block holds fewer than `tau` ([`ReconOptions::region_density`]) points per
//!   occupied child is sparse (grown by its 26 neighbours, sparse below); its eight children are
//!   all present at `j + 1` (*filled*), so the wrapped level reproduces its parent's faces split
//!   1:4 there, inside one crack-free lattice mesh. Filled voxels allow their parent's subfaces,
//!   plus the transition's steps: a slot looking into an empty child of a dense voxel, unless it
//!   is inwards of a parent face the child lies on and behind every oriented sheet around (its
//!   parent's, the dense voxel's, the dense voxels' around the empty one). The prototype's "every
//!   slot within one voxel of a dense voxel" wrapped the inner side of a sampled bowl; the
//!   sheet-angle test of `sheet` kept the wrong-way steps (a filled region is up to a voxel
//!   thicker than its points) closed and cracked the border; the steps into dense voxels' empty
//!   children alone left one-quad pits (bunny level 6: 17 boundary loops, 5 with the sheets
//!   around). Diagonal edges between filled voxels take the parents' decisions; their vertices
//!   start on the parent face (bilinear) and are mapped as on subdivided levels. Regions start
//!   past the global limit: `region_levels` levels are wrapped there where some region is dense,
//!   and a level where every voxel is sparse is plain subdivision. Marking regions inside the
//!   trusted levels too (the prototype) was measured worse: at `tau = 10` the bunny's level 5
//!   went from RMS .00228 to .00290 and its level 7 from .00039 to .00169, the dragon's level 7
//!   from .00159 to .00201 with 68 boundary loops instead of 23: the rims it subdivides are where
//!   the coarser topology lies furthest from the points. Past the limit, `tau = 10` finds no
//!   dense region on the Rabbit or the bunny; `tau = 4` (the default) cuts the dragon's level 8
//!   from .00134 (subdivided) to .00039 with 69 boundary loops (1,552 wrapped everywhere) but
//!   finds nothing dense on the Rabbit or the bunny; `tau = 3` wraps the bunny's level 6 (RMS
//!   .00093 -> .00090, level 7 .00039 -> .00037, 5 loops) but leaves the dragon's level 8 with 309
//!   loops; the Rabbit gains most at 2.75 (level 6 .00214 -> .00137). Below about 5 points per
//!   child a region that counts as dense can break into sampling holes (a sphere sampled thinly
//!   on one half: 3 loops at 3-4, none at 5). Off by default because on the 4.3 M-point case it
//!   would wrap levels 9-10 (see `tools/bench/RESULTS.md`).
//!
//! # Coordinates and determinism
//! All stages work in a local frame, the root cube scaled to `[0, 1)^3` (points in `f32`, fits in
//! `f64` relative to each vertex); output positions are world `f64`. Every parallel stage either
//! maps items independently or computes a set whose content does not depend on order, and every
//! output array is sorted (faces in Morton order of their slots, vertices by first use), so the
//! output is the same whatever the number of threads.
#![deny(missing_docs)]

mod cellmoments;
mod extract;
mod fit;
mod fitting;
mod irregular;
mod keymap;
mod lattice;
mod mapping;
mod octree;
mod rankmap;
mod regions;
mod regular;
mod relax;
mod sheet;
mod sparse;

use std::time::{Duration, Instant};

use octowrap_geom::{DVec3, morton};
use octowrap_mesh::{FaceList, FaceOrigin, Hierarchy, Level, LevelLattice, Mesh, PointCloud};
use rayon::prelude::*;

use crate::irregular::Decisions;
use crate::lattice::{MAX_LEVEL, unslot};
use crate::octree::{Octree, voxel_size};
use crate::rankmap::RankMap;

/// The deepest level supported (slot keys pack a level-`j` Morton code in `3 j + 3` bits).
pub const DEEPEST_LEVEL: u32 = MAX_LEVEL;

/// How deep to reconstruct.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaxLevel {
    /// Stop at the deepest level the sampling density supports (§4.2): the last level whose median
    /// number of points per occupied voxel is at least [`ReconOptions::min_median_points`]
    /// (at least level 1, at most [`AUTO_CAP`]); with [`ReconOptions::region_levels`], up to that
    /// many levels deeper while some region is dense enough ([`ReconOptions::region_density`]).
    Auto,
    /// Build exactly this many levels below the root (`1..=`[`DEEPEST_LEVEL`]); levels beyond the
    /// density limit follow [`ReconOptions::sparse`].
    Level(u32),
}

/// The deepest level [`MaxLevel::Auto`] goes to.
pub const AUTO_CAP: u32 = 16;

/// What to do with levels deeper than the sampling density supports (§4.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SparseMode {
    /// Fix the topology at the last trusted level; deeper levels split every quad into four and
    /// map the vertices again (the paper's advice). Faces grow exactly 4x per level.
    Subdivide,
    /// Wrap the voxels anyway: the mesh follows the data and fragments where it is sparse
    /// (the paper's Fig. 8(b)).
    Wrap,
}

/// Reconstruction options. Construct with [`ReconOptions::default`] and set fields.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ReconOptions {
    /// Finest level. Default [`MaxLevel::Auto`].
    pub max_level: MaxLevel,
    /// Relaxation passes per level (§3.6.1), applied from [`ReconOptions::relax_from_level`] on.
    /// Default 4, as in the paper.
    pub relax_passes: u32,
    /// The coarsest level relaxed. Default 4: measured on the bunny, 4 passes cut the
    /// points-to-mesh error by 3-19 % at levels 4-7 but raise it by up to 2x at levels 1-2, where
    /// the one-ring centroid of a coarse hull lies far inside the surface; on the dragon they are
    /// neutral from level 3 on (`tools/bench/RESULTS.md`).
    pub relax_from_level: u32,
    /// Padding of the root cube, as a fraction of the points' longest extent on each side.
    /// Default 0.01.
    pub padding: f64,
    /// A level's topology is trusted while the median points per occupied voxel is at least this.
    /// Default 8.
    pub min_median_points: f64,
    /// Levels beyond the density limit. Default [`SparseMode::Subdivide`].
    pub sparse: SparseMode,
    /// Most faces any level may have; a deeper level that would exceed it is an error
    /// ([`ReconError::TooManyFaces`]) rather than an allocation failure. Default 200 million.
    pub max_faces: u64,
    /// Map the vertices of wrapped levels onto a weighted height-field quadric of the points
    /// within one voxel edge (Gaussian weights of half an edge, in the weighted plane's frame;
    /// the paper's plane under 10 points) instead of the paper's plane (§3.6). Default false:
    /// with the least-squares fit ([`ReconOptions::fit_passes`]) the plane is as close to the
    /// points and cheaper (see `tools/bench/RESULTS.md`).
    pub quadric_mapping: bool,
    /// Fill one-voxel gaps of sparsely sampled sheets before wrapping a level (from level 2 on):
    /// an empty voxel on the surface with at least 3 of its 4 in-plane neighbours occupied by at
    /// most 8 points each on average, lying in a flat sheet across the gap. Without it, the
    /// oriented-sheet mask keeps such gaps open like real holes (the dragon's level 7: 52
    /// boundary loops, 23 with it). Default true.
    pub fill_gaps: bool,
    /// The per-region trusted level (module `regions`), used past the global density limit when
    /// [`ReconOptions::region_levels`] is not 0: before level `j + 1` is built, a voxel of level
    /// `j` whose 3x3x3 block holds fewer than this many points per occupied child is sparse (with
    /// its 26 neighbours, and everything below it), and its region is subdivided inside the
    /// wrapped level. Default 4 (the prototype used 10, which on our data wraps nothing past the
    /// limit; at 3 the dragon's level 8 breaks into 309 boundary loops, 69 at 4;
    /// `tools/bench/RESULTS.md` has the measurements).
    pub region_density: f64,
    /// Levels past the global density limit ([`ReconOptions::min_median_points`]) that are still
    /// wrapped where some region is dense enough ([`ReconOptions::region_density`]); deeper
    /// levels, or a level where every voxel is sparse, are subdivided. Default 0 (off): on the
    /// issue's 4.3 M-point case it would wrap level 9, which costs several times the subdivision.
    pub region_levels: u32,
    /// Passes of the least-squares fit of every level's vertices to the points (module
    /// `fitting`, after the mapping and relaxation: the points-to-mesh distance is minimised with
    /// the connectivity fixed; subdivided levels take at most 2). 0 keeps the paper's mapping
    /// alone. Default 3.
    pub fit_passes: u32,
    /// Sample points per face for the fit (a fixed stride of the points). Default 4.
    pub fit_samples: u32,
    /// The fit runs on levels with at most this many faces: its cost grows with the faces, and
    /// the issue's 4.3 M-point case must reach level 10 (2.2 M faces) in 3 s, so its levels 8-10
    /// keep the mapping alone. Default 100,000 (every level of the bench's Rabbit, bunny and
    /// dragon hierarchies). A subdivided level past the limit is mapped afresh and can lie
    /// further from the points than the fitted level above it.
    pub fit_max_faces: usize,
}

impl Default for ReconOptions {
    fn default() -> Self {
        Self {
            max_level: MaxLevel::Auto,
            relax_passes: 4,
            relax_from_level: 4,
            padding: 0.01,
            min_median_points: 8.0,
            sparse: SparseMode::Subdivide,
            quadric_mapping: false,
            fill_gaps: true,
            region_density: 4.0,
            region_levels: 0,
            fit_passes: 3,
            fit_samples: 4,
            fit_max_faces: 100_000,
            max_faces: 200_000_000,
        }
    }
}

/// Why reconstruction could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ReconError {
    /// No points.
    #[error("the point cloud is empty")]
    Empty,
    /// Some coordinates are NaN or infinite.
    #[error("{count} of {total} points have NaN or infinite coordinates; remove them first")]
    NonFinite {
        /// Points with a non-finite coordinate.
        count: usize,
        /// All points.
        total: usize,
    },
    /// Too few distinct positions to span a surface.
    #[error("only {distinct} distinct point position(s); reconstruction needs at least {needed}")]
    TooFewDistinct {
        /// Distinct positions found (at 2^-21 of the bounding cube).
        distinct: usize,
        /// Distinct positions needed.
        needed: usize,
    },
    /// More points than 32-bit indices can hold.
    #[error("{count} points; at most {max} are supported")]
    TooManyPoints {
        /// Points given.
        count: usize,
        /// The limit.
        max: usize,
    },
    /// A level would have more faces than [`ReconOptions::max_faces`] (subdividing far past the
    /// density limit multiplies faces by 4 per level).
    #[error("level {level} would have {faces} faces, more than the limit of {max}; ask for a coarser level")]
    TooManyFaces {
        /// The level.
        level: u32,
        /// Its face count.
        faces: u64,
        /// The limit.
        max: u64,
    },
    /// The requested level is 0 or too deep.
    #[error("level {requested} is outside the supported range 1..={max}")]
    BadLevel {
        /// The level asked for.
        requested: u32,
        /// The deepest supported level.
        max: u32,
    },
}

/// A stage of the pipeline, for progress reports and timings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Octree partitioning (§3.2).
    Partitioning,
    /// Oriented-sheet mask and regular refinement (§3.4).
    Regular,
    /// Irregular refinement, vertex extraction, splits (§3.5); subdivision on sparse levels.
    Irregular,
    /// Vertex mapping (§3.6).
    Mapping,
    /// Relaxation (§3.6.1).
    Relaxation,
}

/// A progress report: `stage` of `level` is starting; `levels` is the finest level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// The level being built.
    pub level: u32,
    /// The finest level that will be built (known after partitioning; until then the finest
    /// partitioned so far).
    pub levels: u32,
    /// The stage starting.
    pub stage: Stage,
}

/// Wall time of each stage of one level (the columns of the paper's Table 2).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimings {
    /// Octree partitioning of this level and the filling of its sparse sheets' gaps (the trusted
    /// level also carries the sums of the voxels' moments; level 0 the points' sort).
    pub partitioning: Duration,
    /// Mask and regular refinement.
    pub regular: Duration,
    /// Closure, extraction and splits (or subdivision).
    pub irregular: Duration,
    /// Vertex mapping.
    pub mapping: Duration,
    /// Relaxation.
    pub relaxation: Duration,
}

impl StageTimings {
    /// Sum of all stages.
    pub fn total(&self) -> Duration {
        self.partitioning + self.regular + self.irregular + self.mapping + self.relaxation
    }
}

/// How a level was made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelKind {
    /// The six faces of the root cube.
    Root,
    /// Wrapped around the occupied voxels (§3.4-3.5).
    Wrapped,
    /// Subdivided from the level above (§4.2).
    Subdivided,
}

/// Figures about one level.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelReport {
    /// The level.
    pub level: u32,
    /// How it was made.
    pub kind: LevelKind,
    /// Occupied voxels.
    pub voxels: usize,
    /// Median points per occupied voxel.
    pub median_points: f64,
    /// Faces.
    pub faces: usize,
    /// Vertices.
    pub vertices: usize,
    /// Faces created by the closure (no parent).
    pub created: usize,
    /// Voxels whose oriented sheet constrained faces.
    pub oriented_voxels: usize,
    /// Diagonal decisions flipped to split pinched edges.
    pub flips: usize,
    /// Faces dropped on edges that flipping could not split.
    pub dropped: usize,
    /// Empty voxels filled in as gaps of a sparsely sampled sheet (see the crate docs).
    pub filled: usize,
    /// Voxels of sparse regions, present with or without points ([`ReconOptions::region_density`]).
    pub sparse_voxels: usize,
    /// Stage timings.
    pub timings: StageTimings,
}

/// A reconstruction with its report.
#[derive(Clone, Debug)]
pub struct Reconstruction {
    /// The levels.
    pub hierarchy: Hierarchy,
    /// Per-level figures and timings, level 0 first.
    pub levels: Vec<LevelReport>,
    /// The deepest level whose topology the density supports.
    pub trusted_level: u32,
}

/// Reconstructs `points` (world coordinates) into a hierarchy.
///
/// Guarantees, for every level `j >= 1`: all faces are quads oriented outwards (counter-clockwise
/// seen from outside); every edge has one or two faces, and two faces on an edge run it in opposite
/// directions; every vertex has a single fan of faces; every face names its parent face and quadrant
/// in level `j - 1` or is [`FaceOrigin::Created`]; `lattice` names each face's voxel and side and each
/// vertex's lattice corner at level `j`; [`Hierarchy::cube`] is the root cube. Level 0 is the root
/// cube's six faces. The output depends only on `points` and `opts`, not on the thread count.
///
/// Errors on empty input, non-finite coordinates, fewer than 3 distinct positions, more than
/// `u32::MAX - 1` points, or a requested level outside `1..=`[`DEEPEST_LEVEL`].
pub fn reconstruct(points: &[DVec3], opts: &ReconOptions) -> Result<Hierarchy, ReconError> {
    reconstruct_with(points, opts, &mut |_| {}).map(|r| r.hierarchy)
}

/// Like [`reconstruct`], reporting progress through `progress` (called on the calling thread at
/// the start of every stage of every level) and returning per-level figures and timings.
#[allow(clippy::too_many_lines)] // the pipeline, stage by stage, reads best in one piece
pub fn reconstruct_with(
    points: &[DVec3],
    opts: &ReconOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Reconstruction, ReconError> {
    if points.is_empty() {
        return Err(ReconError::Empty);
    }
    let bad = points.par_iter().filter(|p| !p.is_finite()).count();
    if bad > 0 {
        return Err(ReconError::NonFinite { count: bad, total: points.len() });
    }
    let max_points = u32::MAX as usize - 1;
    if points.len() > max_points {
        return Err(ReconError::TooManyPoints { count: points.len(), max: max_points });
    }
    if let MaxLevel::Level(n) = opts.max_level {
        if n == 0 || n > MAX_LEVEL {
            return Err(ReconError::BadLevel { requested: n, max: MAX_LEVEL });
        }
    }
    let padding = if opts.padding.is_finite() { opts.padding.clamp(0.0, 1.0) } else { 0.01 };

    // §3.2: partitioning.
    let t = Instant::now();
    progress(Progress { level: 0, levels: 0, stage: Stage::Partitioning });
    let mut tree = Octree::new(points, padding);
    if tree.distinct < 3 {
        return Err(ReconError::TooFewDistinct { distinct: tree.distinct, needed: 3 });
    }
    let mut part_times = vec![t.elapsed()];
    // The trusted level is the last before the first level whose median falls below the bound.
    let mut failed: Option<u32> = None;
    let (mut finest, mut trusted) = loop {
        let j = tree.depth();
        if failed.is_none() && j >= 1 && tree.levels[j as usize].median_count() < opts.min_median_points {
            failed = Some(j);
        }
        let trusted_so_far = failed.map_or(j, |f| (f - 1).max(1));
        match opts.max_level {
            MaxLevel::Auto if failed.is_some() || j >= AUTO_CAP => break (trusted_so_far, trusted_so_far),
            // Stop once the trusted level is known and the levels the mapping needs exist.
            MaxLevel::Level(n) if j >= n || (failed.is_some() && j + 1 >= n && j > trusted_so_far) => {
                break (n, trusted_so_far.min(n));
            }
            _ => {}
        }
        let t = Instant::now();
        progress(Progress { level: j + 1, levels: j + 1, stage: Stage::Partitioning });
        tree.push_level();
        part_times.push(t.elapsed());
    };
    // Regions ([`regions`]): sparse regions of wrapped levels are subdivided inside them; past
    // the global limit, up to `region_levels` more levels are wrapped while some region is dense.
    let tau = opts.region_density;
    let regions = opts.sparse == SparseMode::Subdivide && opts.region_levels > 0 && tau.is_finite() && tau > 0.0;
    if opts.sparse == SparseMode::Wrap {
        trusted = finest;
    }
    // The last level the global criterion trusts everywhere: regions start below it.
    let global = trusted;
    if regions {
        // `Auto` goes as deep as the regions are wrapped.
        let auto = opts.max_level == MaxLevel::Auto;
        let bound = if auto { AUTO_CAP } else { finest };
        let last = bound.min(trusted.saturating_add(opts.region_levels)).min(MAX_LEVEL);
        while trusted < last {
            while tree.depth() < trusted + 1 {
                let t = Instant::now();
                tree.push_level();
                part_times.push(t.elapsed());
            }
            if !regions::any_dense(&tree.levels[trusted as usize], &tree.levels[trusted as usize + 1], tau) {
                break;
            }
            trusted += 1;
        }
        if auto {
            finest = trusted;
        }
    }
    // The mapping of a wrapped level j queries level j + 1; of a subdivided level k, level
    // k - 1 (its points, summed per child). Nothing deeper is kept (or built).
    let keep = (trusted + 1).max(finest.saturating_sub(1)).min(MAX_LEVEL);
    while tree.depth() > keep {
        tree.levels.pop();
        part_times.pop();
    }
    while tree.depth() < keep {
        let t = Instant::now();
        tree.push_level();
        part_times.push(t.elapsed());
    }
    let t = Instant::now();
    // Moments are needed down to the trusted level only (sheets, diagonal tests, mapping fallback).
    tree.finish(trusted);
    part_times[trusted as usize] += t.elapsed();

    let mut levels: Vec<Level> = Vec::new();
    let mut reports: Vec<LevelReport> = Vec::new();

    // Level 0: the root cube.
    let root_slots: Vec<u64> = (0..6u8).map(|d| lattice::slot(0, d)).collect();
    let (ex, _) = extract::extract(&root_slots, &Decisions::new(&tree.levels[0]));
    let root_pos: Vec<DVec3> =
        ex.corners.iter().map(|c| DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]))).collect();
    let mut prev = LevelState {
        slots: root_slots,
        quads: ex.quads,
        corners: ex.corners,
        positions: root_pos,
        origins: vec![FaceOrigin::Created; 6],
    };
    reports.push(LevelReport {
        level: 0,
        kind: LevelKind::Root,
        voxels: 1,
        median_points: points.len() as f64,
        faces: 6,
        vertices: 8,
        created: 6,
        oriented_voxels: 0,
        flips: 0,
        dropped: 0,
        filled: 0,
        sparse_voxels: 0,
        timings: StageTimings { partitioning: part_times[0], ..StageTimings::default() },
    });
    levels.push(prev.take_level(&tree, false));

    // The mask and the flips of the wrapped levels above, for the filled voxels of the next.
    let mut prev_mask: Option<sheet::Mask> = None;
    let mut flips_by_level: Vec<std::collections::BTreeSet<(u64, u64)>> = vec![std::collections::BTreeSet::new()];
    for j in 1..=finest {
        // The sparse regions of level j - 1 (past the global limit), before gaps are filled
        // (they hold no points).
        let mut marks = (regions && j > global && j <= trusted)
            .then(|| regions::mark(&tree.levels[j as usize - 1], &tree.levels[j as usize], tau));
        if marks.as_ref().is_some_and(|m| m.iter().all(|&s| s)) {
            // Every voxel is sparse: this level and the deeper ones are plain subdivision.
            trusted = j - 1;
            marks = None;
        }
        // One-voxel gaps of sparsely sampled sheets are filled before the level is wrapped
        // (timed with the level's partitioning).
        let t = Instant::now();
        let filled = if opts.fill_gaps && (2..=trusted).contains(&j) { tree.levels[j as usize].fill_gaps() } else { 0 };
        let gap_time = t.elapsed();
        let here = tree.levels.get(j as usize);
        let (voxels, median_points) =
            (here.map_or(0, octree::Cells::len), here.map_or(0.0, octree::Cells::median_count));
        // Sparse regions: the children of sparse voxels are all present.
        let sparse_voxels = match marks {
            Some(marks) => {
                let (above, here) = tree.levels.split_at_mut(j as usize);
                regions::fill(&mut here[0], &above[j as usize - 1], &marks)
            }
            None => 0,
        };
        let mut rep = LevelReport {
            level: j,
            kind: LevelKind::Wrapped,
            voxels,
            median_points,
            faces: 0,
            vertices: 0,
            created: 0,
            oriented_voxels: 0,
            flips: 0,
            dropped: 0,
            filled,
            sparse_voxels,
            timings: StageTimings {
                partitioning: part_times.get(j as usize).copied().unwrap_or_default() + gap_time,
                ..StageTimings::default()
            },
        };
        let mut stage = |s| progress(Progress { level: j, levels: finest, stage: s });
        let next = if j <= trusted {
            let cells = &tree.levels[j as usize];
            let coarse = &tree.levels[j as usize - 1];
            // §3.4: mask and regular refinement.
            stage(Stage::Regular);
            let t = Instant::now();
            let prev_index = RankMap::from_sorted(&prev.slots);
            let mask = sheet::build(&tree, cells, coarse, &prev_index, prev_mask.as_ref());
            rep.oriented_voxels = mask.signed_count();
            let initial = regular::refine(&prev.slots, &prev_index, cells, &mask);
            rep.timings.regular = t.elapsed();
            // §3.5: closure, extraction, splits.
            stage(Stage::Irregular);
            let t = Instant::now();
            let mut dec = Decisions::with_parents(cells, &tree.levels[..j as usize], &flips_by_level);
            let (mut slots, mut origins, created) = irregular::close(initial, cells, &mask, &dec);
            rep.created = created;
            let mut tried = std::collections::BTreeSet::new();
            let ex = loop {
                let (ex, bad) = extract::extract(&slots, &dec);
                if bad.is_empty() {
                    break ex;
                }
                let mut drop = vec![false; slots.len()];
                for b in bad {
                    match b.diagonal {
                        Some(p) if tried.insert(p) => {
                            dec.flips.insert(p);
                            rep.flips += 1;
                        }
                        _ => {
                            for f in b.faces {
                                drop[f as usize] = true;
                            }
                        }
                    }
                }
                let before = slots.len();
                let mut keep = drop.iter().map(|d| !d);
                slots.retain(|_| keep.next().unwrap_or(true));
                let mut keep = drop.iter().map(|d| !d);
                origins.retain(|_| keep.next().unwrap_or(true));
                rep.dropped += before - slots.len();
            };
            rep.timings.irregular = t.elapsed();
            let flips = std::mem::take(&mut dec.flips);
            drop(dec);
            let h = voxel_size(j);
            let mut positions: Vec<DVec3> =
                ex.corners.iter().map(|c| DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2])) * h).collect();
            if sparse_voxels > 0 {
                regions::start_on_parents(
                    &regions::Faces { slots: &slots, origins: &origins, quads: &ex.quads, corners: &ex.corners },
                    cells,
                    &regions::Parents { quads: &prev.quads, corners: &prev.corners, positions: &prev.positions },
                    &mut positions,
                );
            }
            // Kept for the next level's filled voxels, if it is wrapped.
            if regions && j < trusted {
                flips_by_level.push(flips);
                prev_mask = Some(mask);
            } else {
                prev_mask = None;
            }
            LevelState { slots, quads: ex.quads, corners: ex.corners, positions, origins }
        } else {
            // Check the finest level's face count before building any subdivided level.
            let faces = (prev.quads.len() as u64).saturating_mul(4u64.saturating_pow(finest - j + 1));
            if faces > opts.max_faces.min(u64::from(u32::MAX / 4)) {
                return Err(ReconError::TooManyFaces { level: finest, faces, max: opts.max_faces });
            }
            rep.kind = LevelKind::Subdivided;
            stage(Stage::Irregular);
            let t = Instant::now();
            let s = sparse::subdivide(&prev.quads, &prev.corners, &prev.slots, &prev.positions);
            rep.timings.irregular = t.elapsed();
            LevelState {
                slots: s.slots,
                quads: s.quads,
                corners: s.corners,
                positions: s.positions,
                origins: s.origins,
            }
        };
        let mut next = next;
        // The level above is no longer needed (its output level is already built).
        drop(std::mem::take(&mut prev));
        // §3.6: vertex mapping.
        stage(Stage::Mapping);
        let t = Instant::now();
        let planes = if rep.kind == LevelKind::Wrapped {
            let cells = &tree.levels[j as usize];
            let face_cells: Vec<u32> = next
                .slots
                .par_iter()
                .map(|&s| cells.find(unslot(s).0).expect("faces lie on occupied voxels") as u32)
                .collect();
            let coarse = &tree.levels[j as usize - 1];
            mapping::map_wrapped(
                &tree,
                cells,
                coarse,
                &next.quads,
                &face_cells,
                &mut next.positions,
                opts.quadric_mapping,
            )
        } else {
            mapping::map_free(&tree, j, &mut next.positions)
        };
        rep.timings.mapping = t.elapsed();
        let fit_here = opts.fit_passes > 0 && next.quads.len() <= opts.fit_max_faces;
        if j == finest && !fit_here {
            // The points and voxels are no longer needed: free them before the relaxation's
            // buffers and the output's conversions (this keeps the finest level's peak down).
            tree.release();
        }
        // §3.6.1: relaxation.
        stage(Stage::Relaxation);
        let t = Instant::now();
        let passes = if j >= opts.relax_from_level { opts.relax_passes } else { 0 };
        relax::relax(&mut next.positions, &planes, &next.quads, passes);
        drop(planes);
        if fit_here {
            // The deepest level kept holds the faces' voxels (a wrapped level's own, a
            // subdivided level's parents).
            let g = j.min(tree.depth());
            let grid = &tree.levels[g as usize];
            let face_voxel: Vec<u32> = if rep.kind == LevelKind::Wrapped {
                // A wrapped face's own voxel.
                next.slots.par_iter().map(|&s| grid.find(unslot(s).0).map_or(u32::MAX, |i| i as u32)).collect()
            } else {
                // A subdivided face's voxel may be empty: the voxel of its centre, if occupied.
                let cells = f64::from(1u32 << g);
                next.quads
                    .par_iter()
                    .map(|q| {
                        let c = q.iter().fold(DVec3::ZERO, |s, &v| s + next.positions[v as usize]) * 0.25;
                        let k = c.map(|x| (x * cells).clamp(0.0, cells - 1.0)).as_uvec3();
                        grid.find(morton::encode(k.x, k.y, k.z)).map_or(u32::MAX, |i| i as u32)
                    })
                    .collect()
            };
            let input = fitting::Input { points: &tree.points, grid, face_voxel: &face_voxel };
            // A subdivided level starts from its fitted parent's surface: two passes do what
            // three do on a wrapped level (measured: the bunny's level 6 .00024 with three,
            // .00025 with two), at two thirds of the cost.
            let passes = if rep.kind == LevelKind::Wrapped { opts.fit_passes } else { opts.fit_passes.min(2) };
            fitting::fit(&input, &next.quads, &mut next.positions, passes, opts.fit_samples);
            if j == finest {
                tree.release();
            }
        }
        rep.timings.relaxation = t.elapsed();
        rep.faces = next.quads.len();
        rep.vertices = next.corners.len();
        levels.push(next.take_level(&tree, j == finest));
        reports.push(rep);
        prev = next;
    }
    let hierarchy = Hierarchy { levels, cube: Some(tree.frame.cube()) };
    Ok(Reconstruction { hierarchy, levels: reports, trusted_level: trusted })
}

/// One level while it is being built (local coordinates).
#[derive(Default)]
struct LevelState {
    slots: Vec<u64>,
    quads: Vec<[u32; 4]>,
    corners: Vec<[u32; 3]>,
    positions: Vec<DVec3>,
    origins: Vec<FaceOrigin>,
}

impl LevelState {
    /// The output level; moves the origins out (the next level does not need them), and with
    /// `last` also the positions, corners and quads (converted in place, no copies at the
    /// finest level).
    fn take_level(&mut self, tree: &Octree, last: bool) -> Level {
        let world: Vec<DVec3> = if last {
            let mut p = std::mem::take(&mut self.positions);
            p.par_iter_mut().for_each(|p| *p = tree.frame.to_world(*p));
            p
        } else {
            self.positions.par_iter().map(|&p| tree.frame.to_world(p)).collect()
        };
        let vertex_corners = if last { std::mem::take(&mut self.corners) } else { self.corners.clone() };
        let faces = if last {
            FaceList::from_quad_vec(std::mem::take(&mut self.quads))
        } else {
            FaceList::from_quads(&self.quads)
        };
        let mesh = Mesh { vertices: PointCloud::from_positions(world), faces };
        let face_slots = self
            .slots
            .par_iter()
            .map(|&s| {
                let (code, side) = unslot(s);
                (morton::decode(code), side)
            })
            .collect();
        Level {
            mesh,
            origins: std::mem::take(&mut self.origins),
            lattice: Some(LevelLattice { face_slots, vertex_corners }),
        }
    }
}
