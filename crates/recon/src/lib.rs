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
//! `pipeline` runs the stages in the paper's order, one named function each; the modules do the
//! work.
//!
//! | stage | module | paper |
//! |---|---|---|
//! | the sequence of stages | `pipeline` | §3.1 |
//! | hierarchical space partitioning | `octree` | §3.2 |
//! | which slots may hold faces (oriented sheets) | `sheet` | §3.4-3.5 stop rules |
//! | regular refinement `R` | `regular` | §3.4 |
//! | irregular refinement `I` (closure, diagonal case) | `irregular` | §3.5 |
//! | vertex extraction, vertex and edge splits | `extract` | §3.5, Fig. 5 |
//! | vertex mapping (closed-form plane fit: `plane_fit`) | `mapping` | §3.6 |
//! | relaxation | `relax` | §3.6.1 |
//! | least-squares fit to the points (beyond the paper) | `least_squares` | after §3.6.1 |
//! | density limit, subdivision beyond it | `sparse` | §4.2 |
//! | trusted level per region (optional) | `regions` | §4.2 |
//! | gaps of sparsely sampled sheets | `octree` (`fill_gaps`) | §4.2 |
//!
//! # Readings of the paper
//! Where the paper leaves a choice open, the code reads it as follows (each module's docs give
//! the details; the repository's `docs/decisions.md` lists the alternatives measured against
//! these readings):
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
//!   Read literally, the paper's rules depend on visiting order; they let holes close and refuse
//!   to wrap one-voxel protrusions. A voxel too curved or too thinly sampled for a plane of its
//!   own leans with its oriented neighbours when its points continue their sheet in one thin
//!   layer (the curling rim of a hole), so the wrapping does not take the inside of the shell
//!   there.
//! * **The diagonal case (§3.5 case 3b)** is decided per voxel pair from one plane fitted to both
//!   voxels' points (pass unless the joint RMS residual exceeds 0.2 voxel with 4+ points each),
//!   not from the two voxels' separate normals, which make false breaks on sampled spheres.
//! * **Vertex and edge splits (§3.5, Fig. 5)** happen by construction: vertices are the fans of
//!   linked faces around each lattice point, so they are manifold; a remaining pinched diagonal
//!   edge has its decision flipped (the edge split).
//! * **Vertex mapping (§3.6)**: `W` = the voxels of the vertex's fan; the `2|p - v| < l` filter;
//!   growth to adjacent voxels under 3 points. Level 0 (the root cube) is not mapped. A vertex
//!   goes onto the paper's plane; [`ReconOptions::quadric_mapping`] puts a wrapped level's vertex
//!   instead onto a weighted height-field quadric of `W`'s points within one edge (Gaussian
//!   weights of half an edge). After the least-squares fit below, the plane is as close to the
//!   points as the quadric (within 1-3 %, better or worse by level) and the whole reconstruction
//!   4-6 % cheaper (`docs/decisions.md`, "Vertex mapping").
//! * **Relaxation (§3.6.1)**: Laplacian to the one-ring centroid, then re-projection on the
//!   vertex's own plane. The paper relaxes every level; measured (`docs/decisions.md`), it
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
//!   Measured (`docs/decisions.md`, "Least-squares fit"): on the bunny the points-to-mesh RMS of levels 1-7 is
//!   .0223 .0142 .0060 .0021 .00080 .00024 .00008 with the fit and .0337 .0222 .0113 .0057 .0023
//!   .00093 .00039 without (the paper's Table 3: .0259 .0095 .0036 .0011 .0004 .00014 for levels
//!   1-6), 1.6-3.3x closer per level, with the vertices as near the points as the mapping puts
//!   them. Off with `fit_passes = 0`.
//! * **Sparse data (§4.2)**: a level is trusted while the median points per occupied voxel is at
//!   least 8; deeper levels are subdivided and mapped.
//! * **The finest level, [`MaxLevel::Auto`]** (the default): the trusted level shows only the
//!   detail that a median voxel's 8 points pin down, far coarser than the points themselves (the
//!   bunny's level 5: 3,854 faces for 35,947 points, RMS 8.1e-4 of the diagonal). Past it, levels
//!   are subdivided, mapped (§4.2) and fitted while the points-to-mesh RMS keeps falling by at
//!   least [`ReconOptions::auto_min_gain`] (1.5x) per level; a level whose error does not is
//!   dropped. No level is built with more faces than [`ReconOptions::auto_faces_per_point`] (3)
//!   times the input points, nor than [`ReconOptions::auto_max_faces`] (400,000): past that the
//!   mesh has more vertices than the data has samples, and the fit has nothing left to follow
//!   (the kitten's level 7, 9 faces per point, is 1.07x closer than its level 6). At most 3
//!   levels past the trusted one. [`Reconstruction::auto`] says which level was chosen and why.
//!   Measured (RMS / diagonal): the bunny stops at level 7 (61,664 faces, 7.8e-5; level 8 would
//!   have 6.9 faces per point), Lucy at 8 (92,032, 4.0e-4), the kitten at 6 (12,000, 1.9e-4),
//!   the dragon at 8 (170,300).
//! * **Gaps of sparse sheets (§4.2 with §3.5's holes)**: the paper keeps holes "where the data
//!   has holes" and warns that below the sampling density the mesh fragments (Fig. 8(b)). A
//!   trusted level can still be locally too sparse: on the dragon's thinly sampled underside the
//!   level-7 voxels hold 1-5 points and leave one-voxel gaps in a one-voxel-thick layer, which
//!   the oriented-sheet mask rightly keeps open as it keeps any hole in a sheet. Such a gap is
//!   read as missing samples, not a hole: before a level is wrapped, an empty voxel on the
//!   surface (one of its two neighbours along some axis empty) with at least 3 of its 4
//!   neighbours across that axis occupied, by at most 8 points each on average, whose points form
//!   a flat sheet across the axis (spread along it under 0.2 voxel: not the walls and floor of a
//!   narrow groove, whose bridging doubles the dragon's level-7 error), is added as a voxel
//!   without points ([`ReconOptions::fill_gaps`]). Dense data keeps its holes (a one-voxel hole
//!   among voxels of more than 8 points stays), and the bunny's open bottom, many voxels wide,
//!   stays open. On the dragon's level 7 the filling leaves 23 boundary loops instead of 52, at
//!   the same error.
//! * **Trusted level per region (§4.2)**, optional ([`ReconOptions::region_levels`], off by
//!   default): the paper's "fix the topology at a coarser level" read per region. Before level
//!   `j + 1`, a voxel whose 3x3x3 block holds fewer than `tau` ([`ReconOptions::region_density`])
//!   points per occupied child is sparse (grown by its 26 neighbours, sparse below); its eight
//!   children are all present at `j + 1` (*filled*), so the wrapped level reproduces its parent's
//!   faces split 1:4 there, inside one crack-free lattice mesh. Filled voxels allow their
//!   parent's subfaces, plus the transition's steps: a slot looking into an empty child of a
//!   dense voxel, unless it is inwards of a parent face the child lies on and behind every
//!   oriented sheet around (its parent's, the dense voxel's, the dense voxels' around the empty
//!   one). Diagonal edges between filled voxels take the parents' decisions; their vertices start
//!   on the parent face (bilinear) and are mapped as on subdivided levels. Regions start past the
//!   global limit: `region_levels` levels are wrapped there where some region is dense, and a
//!   level where every voxel is sparse is plain subdivision. At `tau = 4` (the default) the
//!   dragon's level 8 has RMS .00039 with 69 boundary loops against .00134 subdivided; the bunny
//!   and the Rabbit have no dense region past the limit at 4. Below about 5 points per child a
//!   region that counts as dense can break into sampling holes (a sphere sampled thinly on one
//!   half: 3 loops at `tau` 3-4, none at 5). Off by default because on a 4.3 M-point scan it
//!   wraps levels 9-10 (`docs/decisions.md`, "Trusted level per region").
//!
//! # Coordinates and determinism
//! All stages work in a local frame, the root cube scaled to `[0, 1)^3` (points in `f32`, fits in
//! `f64` relative to each vertex); output positions are world `f64`. Every parallel stage either
//! maps items independently or computes a set whose content does not depend on order, and every
//! output array is sorted (faces in Morton order of their slots, vertices by first use), so the
//! output is the same whatever the number of threads.
#![deny(missing_docs)]

mod autolevel;
mod cellmoments;
mod extract;
mod irregular;
mod keymap;
mod lattice;
mod least_squares;
mod lines;
mod mapping;
mod octree;
mod pipeline;
mod plane_fit;
mod rankmap;
mod regions;
mod regular;
mod relax;
mod sheet;
mod sparse;
mod untangle;

use std::time::Duration;

use octowrap_geom::DVec3;
use octowrap_mesh::Hierarchy;

use crate::lattice::MAX_LEVEL;
pub use crate::pipeline::reconstruct_with_progress;

/// The deepest level supported (slot keys pack a level-`j` Morton code in `3 j + 3` bits).
pub const DEEPEST_LEVEL: u32 = MAX_LEVEL;

/// How deep to reconstruct.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaxLevel {
    /// Start from the deepest level the sampling density supports (§4.2): the last level whose
    /// median number of points per occupied voxel is at least [`ReconOptions::min_median_points`]
    /// (at least level 1, at most [`AUTO_CAP`]); with [`ReconOptions::region_levels`], up to that
    /// many levels deeper while some region is dense enough ([`ReconOptions::region_density`]).
    /// Then, with [`SparseMode::Subdivide`], go on subdividing while each level cuts the
    /// points-to-mesh RMS by [`ReconOptions::auto_min_gain`] and the next level's faces stay
    /// within [`ReconOptions::auto_faces_per_point`] times the points (see the crate docs and
    /// [`Reconstruction::auto`]).
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
    /// neutral from level 3 on (`docs/decisions.md`, "Relaxation from level 4").
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
    /// ([`Error::TooManyFaces`]) rather than an allocation failure. Default 200 million.
    pub max_faces: u64,
    /// Map the vertices of wrapped levels onto a weighted height-field quadric of the points
    /// within one voxel edge (Gaussian weights of half an edge, in the weighted plane's frame;
    /// the paper's plane under 10 points) instead of the paper's plane (§3.6). Default false:
    /// with the least-squares fit ([`ReconOptions::fit_passes`]) the plane is as close to the
    /// points and cheaper (`docs/decisions.md`, "Vertex mapping").
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
    /// wrapped level. Default 4: at 10 nothing past the limit is dense on the bunny, the Rabbit
    /// or the dragon; at 3 the dragon's level 8 breaks into 309 boundary loops, 69 at 4
    /// (`docs/decisions.md`, "Trusted level per region").
    pub region_density: f64,
    /// Levels past the global density limit ([`ReconOptions::min_median_points`]) that are still
    /// wrapped where some region is dense enough ([`ReconOptions::region_density`]); deeper
    /// levels, or a level where every voxel is sparse, are subdivided. Default 0 (off): on a 4.3
    /// M-point scan it wraps level 9, which costs several times the subdivision.
    pub region_levels: u32,
    /// Passes of the least-squares fit of every level's vertices to the points (module
    /// `least_squares`, after the mapping and relaxation: the points-to-mesh distance is minimised with
    /// the connectivity fixed; subdivided levels take at most 2). 0 keeps the paper's mapping
    /// alone. Default 3.
    pub fit_passes: u32,
    /// Sample points per face for the fit (a fixed stride of the points). Default 4.
    pub fit_samples: u32,
    /// The fit runs on levels with at most this many faces: its cost grows with the faces, and
    /// a 4.3 M-point scan reaches level 10 (2.2 M faces) in 3 s with its levels 8-10 keeping the
    /// mapping alone. Default 100,000 (every level of the bench's Rabbit, bunny and
    /// dragon hierarchies). A subdivided level past the limit is mapped afresh and can lie
    /// further from the points than the fitted level above it.
    pub fit_max_faces: usize,
    /// [`MaxLevel::Auto`] keeps a subdivided level only when its points-to-mesh RMS is at most
    /// the parent level's divided by this. Default 1.5 (subdivided levels that follow the points
    /// fall 1.7-3.4x per level on the bunny, Lucy and the kitten; past the data's detail 1.05x).
    pub auto_min_gain: f64,
    /// [`MaxLevel::Auto`] builds no level with more faces than this many per input point.
    /// Default 3.
    pub auto_faces_per_point: f64,
    /// [`MaxLevel::Auto`] builds no level with more faces than this. Default 400,000: the
    /// dragon (437,645 points) stops at level 8 (170,300 faces) rather than 9 (681,200).
    pub auto_max_faces: usize,
    /// Levels with at most this many faces are tested for intersecting faces and repaired
    /// locally (module `untangle`: the vertices of intersecting faces move towards their
    /// neighbours' centroid until no pair is left; the connectivity is kept). Default 0 (off):
    /// the repair clears every pair of the bunny's levels 1-7 but smooths Lucy's finest level to
    /// 3x its points-to-mesh RMS, so it runs only when asked (250,000 tests the levels up to
    /// the dragon's; the test costs about as much as the fit per face).
    pub untangle_max_faces: usize,
    /// Compute every refined vertex that has a line in the MRQ decoder's prediction (spec §6.8)
    /// as one scalar along that line (normal-mesh geometry, module `lines`): the file written
    /// with [`Reconstruction::line_grid`] then holds each such vertex as one number and decodes
    /// every level to the positions reconstructed (each on a grid point). `None` (the default)
    /// leaves the vertices free.
    pub decoder_lines: Option<DecoderGrid>,
    /// With [`ReconOptions::decoder_lines`]: how far, in voxel edges of its level, a vertex's
    /// position after the mapping, relaxation and the fit's free passes may lie from its decoder
    /// line for it to go onto the line (one number in the file); farther vertices keep three
    /// components. Two more passes of the fit then move the line vertices along their lines and
    /// the free ones in space (on levels the fit skips, [`ReconOptions::fit_max_faces`], the
    /// vertices within reach go to their lines' nearest points, with no refit).
    /// Infinite: every vertex with a line is computed on it from the mapping on (the mapping
    /// meets the line with the tangent plane, the relaxation holds it, the fit moves its scalar;
    /// 6-67 % further from the points per level on the bunny and the dragon). Default 0.3: every
    /// level within +5 % of the free reconstruction's points-to-mesh RMS on the Rabbit, the
    /// bunny, the dragon and `autzen_trim.laz`, with 58-90 % of the finest level's vertices on
    /// lines (0.4: up to +20 %; 0.1: up to +4 %, 24-67 % on lines).
    pub line_reach: f64,
}

/// The grid of the MRQ file the levels are built for ([`ReconOptions::decoder_lines`]): tied to
/// the root cube, `2^bits` steps across it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecoderGrid {
    /// [`octowrap_format::reconstruction_grid_bits`] of the finest level: 64 steps per finest
    /// voxel edge.
    Finest,
    /// This many bits (`1..=28`).
    Bits(u32),
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
            auto_min_gain: 1.5,
            auto_faces_per_point: 3.0,
            auto_max_faces: 400_000,
            untangle_max_faces: 0,
            max_faces: 200_000_000,
            decoder_lines: None,
            line_reach: 0.3,
        }
    }
}

/// Why reconstruction could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
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
    /// The points span an extent the local frame cannot normalise: a subnormal one (whose
    /// reciprocal is infinite) or one too large to pad.
    #[error(
        "the points span {extent:.3e}, outside the extent {min:.3e} to {max:.3e} that 64-bit coordinates can normalise; \
         rescale them"
    )]
    ExtentOutOfRange {
        /// The largest side of the points' bounding box.
        extent: f64,
        /// The smallest extent supported.
        min: f64,
        /// The largest extent supported.
        max: f64,
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
    /// The MRQ decoder's lines could not be computed for a level ([`ReconOptions::decoder_lines`]:
    /// a grid outside `1..=28` bits, a level the format cannot hold).
    #[error("decoder lines of level {level}: {reason}")]
    DecoderLines {
        /// The level.
        level: u32,
        /// What the format reported.
        reason: String,
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
    /// Intersecting face pairs before and after the repair (`None`: the level has more than
    /// [`ReconOptions::untangle_max_faces`] faces and was not tested).
    pub intersecting: Option<(usize, usize)>,
    /// Vertices computed as one scalar on their decoder line ([`ReconOptions::decoder_lines`]).
    pub on_lines: usize,
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
    /// With [`MaxLevel::Auto`] and [`SparseMode::Subdivide`]: how the finest level was chosen.
    pub auto: Option<AutoChoice>,
    /// The grid the levels lie on with [`ReconOptions::decoder_lines`]: encode with its
    /// [`GridSpec::quantization`](octowrap_format::GridSpec::quantization).
    pub line_grid: Option<octowrap_format::GridSpec>,
}

/// How [`MaxLevel::Auto`] chose the finest level.
#[derive(Clone, Debug, PartialEq)]
pub struct AutoChoice {
    /// The finest level.
    pub level: u32,
    /// The deepest level the density supports (the first one measured).
    pub trusted: u32,
    /// Why no deeper level was kept.
    pub stop: AutoStop,
    /// The points-to-mesh RMS (world units) of every level measured and kept, coarsest first.
    pub errors: Vec<(u32, f64)>,
}

/// Why [`MaxLevel::Auto`] kept no deeper level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AutoStop {
    /// Level `level` cut the RMS by only `gain` (below [`ReconOptions::auto_min_gain`]), so it
    /// was dropped.
    SmallGain {
        /// The level dropped.
        level: u32,
        /// Its parent's RMS over its own.
        gain: f64,
    },
    /// The next level would have `next_faces` faces, more than `limit`:
    /// [`ReconOptions::auto_faces_per_point`] times the points, [`ReconOptions::auto_max_faces`]
    /// or [`ReconOptions::max_faces`], whichever is least.
    TooManyFaces {
        /// Faces of the next level.
        next_faces: u64,
        /// The limit.
        limit: u64,
    },
    /// The level is 3 past the trusted level, or the deepest supported.
    Deepest,
}

/// Reconstructs `points` (world coordinates) into a hierarchy.
///
/// Guarantees, for every level `j >= 1`: all faces are quads oriented outwards (counter-clockwise
/// seen from outside); every edge has one or two faces, and two faces on an edge run it in opposite
/// directions; every vertex has a single fan of faces; every face names its parent face and quadrant
/// in level `j - 1` or is [`FaceOrigin::Created`](octowrap_mesh::FaceOrigin::Created); `lattice` names each face's voxel and side and each
/// vertex's lattice corner at level `j`; [`Hierarchy::cube`] is the root cube. Level 0 is the root
/// cube's six faces. The output depends only on `points` and `opts`, not on the thread count.
///
/// Errors on empty input, non-finite coordinates, fewer than 3 distinct positions, more than
/// `u32::MAX - 1` points, or a requested level outside `1..=`[`DEEPEST_LEVEL`].
pub fn reconstruct(points: &[DVec3], opts: &ReconOptions) -> Result<Hierarchy, Error> {
    reconstruct_with_progress(points, opts, &mut |_| {}).map(|r| r.hierarchy)
}
