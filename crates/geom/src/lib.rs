//! Math vocabulary shared by every octowrap crate, built on [`glam`].
//!
//! * [`Aabb`]: axis-aligned bounding boxes in `f64` world units, and the padded cube the octree
//!   starts from ([`Aabb::bounding_cube`]).
//! * [`Moments`] and [`Plane`]: first and second moments of a point set and the least-squares plane
//!   they define (principal component analysis), the tool of the paper's vertex mapping (§3.6).
//! * [`sym_eigen3`]: eigen-decomposition of a symmetric 3x3 matrix (cyclic Jacobi), since glam has none.
//! * [`morton`]: 3D Morton (Z-order) codes, 21 bits per axis, for octree cells.
//! * `SplitMix64` (feature `testing`): a deterministic pseudo-random generator for tests, fixtures
//!   and benchmarks.
//!
//! # Precision
//! World coordinates are `f64` ([`glam::DVec3`]) everywhere in octowrap's data model, so that
//! georeferenced LiDAR (UTM eastings near 600,000 m, ellipsoidal heights) keeps sub-millimetre
//! precision through every round trip. Algorithms that want speed may convert to a local `f32`
//! frame internally; they state it in their own docs.

pub mod cell;
pub mod morton;

mod aabb;
mod distance;
mod eigen;
mod plane;
#[cfg(any(test, feature = "testing"))]
mod random;

pub use aabb::Aabb;
pub use distance::{closest_on_triangle, point_triangle_squared};
pub use eigen::{SymEigen3, sym_eigen3};
pub use glam;
pub use glam::{DMat3, DVec3, Vec3};
pub use plane::{Moments, Plane};
#[cfg(any(test, feature = "testing"))]
pub use random::SplitMix64;
