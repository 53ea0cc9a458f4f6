//! glTF 2.0 export of octowrap meshes and multiresolution hierarchies, as one `.glb` file or a
//! `.gltf` JSON file with a `.bin` beside it.
//!
//! Written against the glTF 2.0 specification (Khronos, 2021) and the extensions it can use:
//! `MSFT_lod` (a level-of-detail chain of nodes, with `MSFT_screencoverage` switching hints),
//! `KHR_mesh_quantization` (integer vertex attributes) and `EXT_meshopt_compression` (compressed
//! buffer views, encoded with meshoptimizer through the `meshopt` crate).
//!
//! What a file holds, per exported level: one mesh with one triangle primitive and one node named
//! `level K`. Quads are split along their shorter diagonal ([`octowrap_mesh::Mesh::triangles`]),
//! and triangles that name a vertex twice (no area) are left out;
//! normals are smooth, area-weighted, and split where faces meet at more than the crease angle
//! ([`ExportOptions::crease_angle_deg`]); vertex colours are written when the input has them. The
//! level's numbers (level, faces, quads, geometric error) go in the mesh's `extras.octowrap`; the
//! input's metadata ([`ExportOptions::metadata`]) in `asset.extras.octowrap`.
//!
//! * Indices are `u16` when every index fits below 65535 (the primitive-restart value), else `u32`.
//! * [`Levels::All`] writes every level and chains them with `MSFT_lod` from the finest node (the
//!   only node in the scene; loaders without the extension show the finest level). The hints are
//!   derived from each level's mean edge length: see [`lod`].
//! * With [`ExportOptions::quantize`], positions are `i16` on a grid spanning the exported levels'
//!   bounding box, mapped back by each node's translation and uniform scale, and normals `i8`;
//!   `KHR_mesh_quantization` is then used and required.
//! * With [`ExportOptions::meshopt`], triangles are first reordered for the vertex cache and
//!   vertices by first use (the same triangles and winding; Forsyth's order, or Tipsify's linear
//!   one where a vertex's valence would make Forsyth's quadratic), then every buffer view is stored
//!   compressed (attribute codec version 0, triangle index codec); the uncompressed layout is a
//!   fallback buffer with no data, so `EXT_meshopt_compression` is used and required, as its
//!   specification says.
//!
//! The output depends only on the input and the options: the same call gives the same bytes.
//!
//! ```
//! use octowrap_export::{ExportOptions, Levels, to_glb};
//! use octowrap_mesh::{DVec3, FaceList, Hierarchy, Mesh};
//!
//! let mut mesh = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
//! mesh.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
//! let mut options = ExportOptions::default();
//! options.levels = Levels::All;
//! options.quantize = true;
//! let (glb, summary) = to_glb(&Hierarchy::single(mesh), &options)?;
//! assert_eq!(&glb[..4], b"glTF");
//! // Deterministic: the same input and options give the same bytes.
//! assert_eq!(summary.bytes, glb.len() as u64);
//! assert_eq!(glb, to_glb(&Hierarchy::single(mesh_again()), &options)?.0);
//! # fn mesh_again() -> Mesh {
//! #     let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
//! #     m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
//! #     m
//! # }
//! # Ok::<(), octowrap_export::Error>(())
//! ```

#![deny(missing_docs)]

mod document;
mod error;
mod geometry;
pub mod lod;
mod write;

pub use error::Error;
pub use write::{Container, write_path};

use octowrap_mesh::Hierarchy;

/// Which levels of a hierarchy to write.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Levels {
    /// The finest (last) level only.
    #[default]
    Finest,
    /// Every level, chained with `MSFT_lod` (finest first).
    All,
    /// Level `k` only (0 = coarsest).
    One(usize),
}

/// How to export. Build it with [`ExportOptions::default`] and set fields.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ExportOptions {
    /// The levels to write. Default: [`Levels::Finest`].
    pub levels: Levels,
    /// `KHR_mesh_quantization`: `i16` positions with a node transform, `i8` normals. Default: off.
    pub quantize: bool,
    /// `EXT_meshopt_compression` on every buffer view. Default: off.
    pub meshopt: bool,
    /// Faces meeting at more than this angle (degrees, `0..=180`) get separate normals along their
    /// shared edge; `None` (the default) gives smooth normals everywhere. A vertex with more than
    /// 512 differently oriented triangles around it keeps one smooth normal (the crease test is
    /// quadratic in that number).
    pub crease_angle_deg: Option<f64>,
    /// Write vertex colours (`COLOR_0`, linear, `u16` normalized) when the input has them.
    /// Default: on.
    pub colors: bool,
    /// The projected geometric error, as a fraction of the viewport height, that the
    /// `MSFT_screencoverage` hints tolerate before switching to a finer level. Default: 1/1080
    /// (one pixel of a 1080-pixel-high view).
    pub max_screen_error: f64,
    /// Key-value pairs recorded in `asset.extras.octowrap` (units, source, ...), in this order.
    pub metadata: Vec<(String, String)>,
    /// [`write_path`]: refuse to replace an existing file. Default: off.
    pub no_clobber: bool,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            levels: Levels::Finest,
            quantize: false,
            meshopt: false,
            crease_angle_deg: None,
            colors: true,
            max_screen_error: 1.0 / 1080.0,
            metadata: Vec::new(),
            no_clobber: false,
        }
    }
}

/// What one exported level holds.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelSummary {
    /// The level's number in the hierarchy (0 = coarsest).
    pub level: usize,
    /// Polygons of the source level.
    pub source_faces: usize,
    /// Vertices written (the used source vertices, plus the copies made by crease splits).
    pub vertices: usize,
    /// Triangles written.
    pub triangles: usize,
    /// Whether the indices are `u32` (else `u16`).
    pub u32_indices: bool,
    /// The level's geometric error estimate (mean edge length, input units).
    pub geometric_error: f64,
}

/// What an export wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The exported levels, finest first (the order of the `MSFT_lod` chain).
    pub levels: Vec<LevelSummary>,
    /// `MSFT_screencoverage` values, one per exported level (empty for a single level).
    pub screen_coverage: Vec<f64>,
    /// `extensionsUsed`, sorted.
    pub extensions_used: Vec<String>,
    /// `extensionsRequired`, sorted.
    pub extensions_required: Vec<String>,
    /// Bytes written (GLB: the whole file; glTF: JSON plus binary).
    pub bytes: u64,
}

/// Exports `h` as one GLB file in memory, with a summary of what it holds. See the crate docs for
/// what the file holds.
///
/// Fails with [`Error::Invalid`] when the hierarchy has no levels, the asked level does not
/// exist, an exported level has no faces, broken indices or non-finite positions, or an option is
/// out of range; with [`Error::LimitExceeded`] when the result would exceed GLB's 4 GiB.
pub fn to_glb(h: &Hierarchy, opts: &ExportOptions) -> Result<(Vec<u8>, Summary), Error> {
    let built = document::build(h, opts, None)?;
    write::glb(built)
}

/// Exports `h` as glTF JSON plus its binary buffer, which the JSON names by `bin_uri` (a relative
/// URI such as `model.bin`). Errors as [`to_glb`].
pub fn to_gltf(h: &Hierarchy, opts: &ExportOptions, bin_uri: &str) -> Result<(Vec<u8>, Vec<u8>, Summary), Error> {
    let built = document::build(h, opts, Some(bin_uri))?;
    Ok(write::gltf(built))
}
