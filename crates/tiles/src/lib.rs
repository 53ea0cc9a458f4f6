//! OGC 3D Tiles 1.1 export of octowrap hierarchies: a `tileset.json` and one binary glTF (`.glb`)
//! per tile, for `CesiumJS`, `3DTilesRendererJS` and other 3D Tiles clients.
//!
//! Written against the OGC 3D Tiles 1.1 specification (OGC 22-025r4): tileset JSON (§6.7), tiles,
//! bounding volumes, geometric error and `REPLACE` refinement (§6.4-6.6), glTF content (§7.8).
//!
//! # What a tileset holds
//! * Tiles follow the hierarchy ([`partition`]): a tile is one level's faces inside one octree
//!   cell, its children the next level's faces in that cell's children; the coarse levels that
//!   fit one tile are chained above them. The [`partition::Partition`] trait is all the writer
//!   sees of this, so other partitions (MRQ chunks) become tiles the same way.
//! * Every tile refines by `REPLACE`; its bounding volume is the tightest axis-aligned box of its
//!   content and of its children's boxes, so each child's volume lies inside its parent's.
//! * A tile's `geometricError` is measured: the certified upper bound of the symmetric Hausdorff
//!   distance between the tile's faces and the finest level's faces over the same region
//!   ([`octowrap_decimate::metrics::certified_hausdorff`]), then raised to its children's largest
//!   so it never grows from parent to child. Finest tiles have 0.
//! * Contents are written as they are made, with the glTF writer of `octowrap-export`
//!   (`KHR_mesh_quantization` and `EXT_meshopt_compression` on request); only each tile's box,
//!   error and size stay in memory until `tileset.json` is written, last.
//! * With [`TilesOptions::implicit`], the tiles below the coarsest cut level are an implicit
//!   octree (3D Tiles 1.1 §6.8): subtree files with availability bitstreams ([`implicit`]).
//! * Georeferencing ([`georef`]): with a CRS, positions go to a local east-north-up frame in
//!   metres at the data's centre and the root tile's `transform` takes that frame to
//!   Earth-centred coordinates (EPSG:4978); without one, the frame is the input's own, its origin
//!   moved to the data's centre by the root transform (so `f32` positions stay small).
//!
//! # No cracks: a pushed-back flange
//! Neighbouring tiles drawn at different levels meet along borders that the two levels place a
//! little differently (each level's vertices are fitted to the surface on their own). Each tile's
//! content carries a **flange**: the ring of the same level's faces that touch it from
//! neighbouring tiles, hanging on the tile's own border vertices, its outer vertices pushed back
//! along the surface normal by the level's largest tile error ([`content`]). Where the neighbour
//! is drawn at the same level, its surface covers the flange; where it is drawn at another level,
//! the flange (or the neighbour's) fills the sliver between the two borders.
//!
//! Why a flange: *skirts* (walls hanging down from the border, as terrain tilers use) only close
//! gaps that lie along the view direction of a height field, while here the two levels' borders
//! are also offset sideways, on a closed surface with no "down". *Boundary snapping* moves the
//! finer level's border vertices onto the coarser one's edges, which leaves the finest level
//! wrong along every tile border and must chain through all levels. A *partition whose borders
//! both levels share* needs borders frozen while the levels are made (as Nexus builds them);
//! reconstructed levels are given. The flange leaves every level's own vertices where they are,
//! works whatever level the neighbour shows (the client may draw any mix that `REPLACE` allows),
//! and costs about one ring of faces per tile.
//!
//! # How it is checked
//! [`check`] holds the structural rules of the specification (explicit tiles and implicit
//! subtrees). The tests add the Khronos glTF-Validator on every tile and two real clients,
//! `3DTilesRendererJS` and `CesiumJS`, in headless Chromium (`tools/tiles-check/check-clients.mjs`):
//! far tiles stay coarse, near ones reach the finest level, no console errors. Cracks are
//! measured in pixels twice: by a software rasterizer over the tiles a screen-space-error cut
//! selects (`tests/tileset.rs`), and in 3DTilesRendererJS, whose own selection is rendered against
//! a render of the finest level from the same camera (`tests/clients.rs`); the pixels the finest
//! level covers and the tiled view leaves empty count, silhouette differences included.
//!
//! The output depends only on the input and the options: the same call gives the same bytes,
//! whatever the thread count.

#![deny(missing_docs)]

pub mod check;
mod content;
pub mod georef;
pub mod implicit;
pub mod partition;
pub mod tileset;
mod write;

use std::path::Path;

pub use georef::Frame;
use octowrap_mesh::Hierarchy;
pub use partition::OctreePartition;

/// Why an export or a check could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The hierarchy breaks the mesh or hierarchy rules.
    #[error("invalid hierarchy: {0}")]
    Invalid(String),
    /// The CRS could not be read or a point could not be converted.
    #[error("coordinate reference system: {0}")]
    Crs(String),
    /// A tile's glTF could not be made.
    #[error(transparent)]
    Export(#[from] octowrap_export::Error),
    /// Reading or writing a file failed.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// What failed.
        source: std::io::Error,
    },
}

impl Error {
    pub(crate) fn invalid(message: impl Into<String>) -> Self {
        Self::Invalid(message.into())
    }

    pub(crate) fn io(file: &str, source: std::io::Error) -> Self {
        Self::Io { file: file.to_owned(), source }
    }
}

/// How to export. Build it with [`TilesOptions::default`] and set fields.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct TilesOptions {
    /// The tile partition. Default: [`OctreePartition::default`].
    pub partition: OctreePartition,
    /// `KHR_mesh_quantization` in every tile. Default: off.
    pub quantize: bool,
    /// `EXT_meshopt_compression` in every tile. Default: off.
    pub meshopt: bool,
    /// Vertex colours, when the input has them. Default: on.
    pub colors: bool,
    /// The crack-hiding flange around every tile (see the crate docs); off only to see what it
    /// hides. Default: on.
    pub flange: bool,
    /// Key-value pairs recorded in the tileset's `extras`, in this order.
    pub metadata: Vec<(String, String)>,
    /// Refuse to replace an existing `tileset.json`. Default: off.
    pub no_clobber: bool,
    /// Implicit tiling below the coarsest cut level ([`implicit`]): subtree files instead of
    /// explicit tiles. Default: off.
    pub implicit: bool,
}

impl Default for TilesOptions {
    fn default() -> Self {
        Self {
            partition: OctreePartition::default(),
            quantize: false,
            meshopt: false,
            colors: true,
            flange: true,
            metadata: Vec::new(),
            no_clobber: false,
            implicit: false,
        }
    }
}

/// What an export wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Tiles in the tree.
    pub tiles: usize,
    /// Tiles with content (a `.glb` each).
    pub content_tiles: usize,
    /// Levels of the hierarchy.
    pub levels: usize,
    /// Bytes written (every `.glb` and `tileset.json`).
    pub bytes: u64,
    /// The root tile's geometric error (tileset units: metres when georeferenced).
    pub root_error: f64,
    /// The frame the tileset is in.
    pub frame: String,
}

/// Writes `h` as a tileset: `path` (the `tileset.json`) and the tiles under `tiles/` beside it.
/// See the crate docs for what it holds. Each file is written whole or not at all
/// ([`octowrap_fsutil::write_file`]); `tileset.json` is written last, so a failed export leaves
/// no tileset naming missing tiles.
///
/// ```no_run
/// use octowrap_tiles::{Frame, TilesOptions, write_tileset};
/// # let hierarchy = octowrap_mesh::Hierarchy::default();
/// let summary = write_tileset("out/tileset.json".as_ref(), hierarchy, &Frame::Local, &TilesOptions::default())?;
/// println!("{} tiles, {} bytes", summary.tiles, summary.bytes);
/// # Ok::<(), octowrap_tiles::Error>(())
/// ```
pub fn write_tileset(path: &Path, h: Hierarchy, frame: &Frame, opts: &TilesOptions) -> Result<Summary, Error> {
    write::write_tileset(path, h, frame, opts)
}
