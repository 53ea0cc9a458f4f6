//! Error-bounded decimation of polygon meshes, and adaptive crack-free cuts through MRQ
//! hierarchies.
//!
//! # General decimation: [`decimate`]
//! Quadric-error edge collapse (Garland & Heckbert 1997) on any triangle or polygon mesh, to a
//! face target ([`DecimateOptions::target_faces`]), an error bound ([`DecimateOptions::max_error`],
//! absolute or relative to the bounding-box diagonal), or both. The kept vertex of a collapse goes
//! to the quadric's optimum when that is well conditioned and near the edge, else to the best
//! point of the edge (the fallback). Algorithm and sources: `collapse.rs`.
//!
//! **Guarantees.** The output is never less manifold than the input:
//! * vertices that are non-manifold in the input, or lie on a non-manifold, mis-oriented or
//!   degenerate face, are *frozen*: no edge at them collapses, so each defect stays as it was and
//!   no new one appears;
//! * every collapse passes the link condition (Dey et al. 1999), so no non-manifold edge or
//!   vertex is created; a closed component never shrinks below a tetrahedron, and an open one
//!   never loses its last triangle;
//! * boundaries are preserved: a boundary vertex only collapses along a boundary edge into
//!   another boundary vertex, and boundary quadrics keep the boundary in place; with
//!   [`DecimateOptions::lock_border`] boundary vertices do not move at all;
//! * no face flips: a collapse is refused when any surviving face around it would turn its
//!   normal by 90 degrees or more (or become degenerate), and collapses keep each face's winding,
//!   so orientation is preserved.
//!
//! `tests/manifold.rs` proves these with `octowrap_validate` on closed, open and defective
//! fixtures and on the Stanford meshes.
//!
//! **Error.** [`DecimateReport::error`] is the symmetric Hausdorff distance between the input
//! and the output, *measured* after decimating and *certified*: an upper bound that no point of
//! either surface exceeds (between samples included), within 1 % of the largest distance actually
//! found ([`metrics::certified_hausdorff`], a branch and bound over subdivided triangles,
//! `hausdorff.rs`). [`DecimateOptions::max_error`] bounds this same quantity: collapses are steered
//! by the quadric error (an area-weighted RMS distance to the planes a vertex stands for, 2 to 5
//! times below the Hausdorff distance), so the collapse runs under a quadric threshold calibrated
//! from the bound, the result is measured, and the run is redone from the input with a lower
//! threshold while the measurement is over the bound (the input itself is returned if six runs
//! all fail). The quadric estimate stays in the report as [`DecimateReport::quadric_error`].
//!
//! **Quad-dominant input** (half or more of the faces quads): decimation runs on the
//! triangulation ([`octowrap_mesh::Mesh::triangles`]: quads split along their shorter diagonal,
//! polygons fanned), aiming at twice the face target in triangles, and the result is re-paired
//! into quads where two triangles sharing an edge make a convex, nearly planar quad (`quads.rs`);
//! unpaired triangles stay triangles. The face target counts the faces as written (a quad is one
//! face, an unpaired triangle another): when pairing leaves more faces than the target, the run
//! is redone with a triangle target lowered in proportion, so the target is always met. The output is a valid polygon mesh in any writable format.
//! [`QuadMode`] forces either behaviour.
//!
//! **Determinism.** Candidate collapses are sorted by a total order; they are applied block by
//! block in parallel (blocks of consecutive vertex numbers, set by the vertex count alone: a
//! collapse runs there when all it reads and writes lies in its block), then the rest in order
//! over the whole mesh; other parallel work only fills ordered arrays. So the output is the
//! same, bit for bit, whatever the thread count.
//!
//! ```
//! use octowrap_decimate::{decimate, DecimateOptions, ErrorBound};
//! use octowrap_mesh::{FaceList, Mesh};
//! use octowrap_geom::DVec3;
//!
//! // A flat 10 x 10 grid of quads: decimation removes interior vertices at zero error.
//! let n = 11u32;
//! let pos = (0..n * n).map(|i| DVec3::new(f64::from(i % n), f64::from(i / n), 0.0)).collect();
//! let mut grid = Mesh::from_positions(pos);
//! let quads: Vec<[u32; 4]> = (0..n - 1)
//!     .flat_map(|y| (0..n - 1).map(move |x| [y * n + x, y * n + x + 1, (y + 1) * n + x + 1, (y + 1) * n + x]))
//!     .collect();
//! grid.faces = FaceList::from_quads(&quads);
//! let mut opts = DecimateOptions::target_faces(10);
//! opts.max_error = Some(ErrorBound::Relative(1e-6));
//! let out = decimate(&grid, &opts)?;
//! assert!(out.report.output_faces <= 10);
//! assert!(out.report.error.unwrap() <= 1e-6 * out.report.diagonal);
//! # Ok::<(), octowrap_decimate::Error>(())
//! ```
//!
//! # Hierarchy cuts: [`cut`]
//! For an MRQ hierarchy, [`cut`] builds the mesh that uses, region by region, the coarsest level
//! whose distance to the finest level is at most a bound: a fixed bound in world units
//! ([`CutCriterion::MaxError`]), or a screen-space error in pixels for a [`Camera`]
//! ([`CutCriterion::View`], view-dependent refinement). Definitions, stitching and the
//! crack-freeness argument are in `cut.rs` and on [`cut`].
//!
//! # Distances: [`metrics`]
//! The certified symmetric Hausdorff distance between two meshes
//! ([`metrics::certified_hausdorff`]: a lower and an upper bound of the true distance, 1 % apart,
//! by branch and bound over subdivided triangles; `hausdorff.rs`), and the sampled symmetric
//! Hausdorff and RMS distances ([`metrics::distance`]; BVH and exact point-triangle distance),
//! defined precisely in the module docs.

pub mod chunks;
mod collapse;
mod cut;
mod decimate;
mod error;
mod hausdorff;
pub mod metrics;
mod quadric;
mod quads;

pub use collapse::Stop;
pub use cut::{Camera, CutCriterion, CutReport, HierarchyCut, cut};
pub use decimate::{
    DecimateOptions, DecimateReport, Decimated, ErrorBound, QuadMode, decimate, decimate_with_progress,
};
pub use error::Error;
pub use quads::MAX_FOLD_DEGREES;
