//! The crate's one error type.

use octowrap_mesh::{HierarchyError, IndexError};

/// Why a decimation or a hierarchy cut could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The input breaks the mesh rules (an index out of range, a face of fewer than 3 vertices).
    #[error("invalid mesh: {0}")]
    InvalidMesh(#[from] IndexError),
    /// A vertex used by a face has a NaN or infinite coordinate.
    #[error("invalid mesh: vertex {vertex} has a non-finite coordinate")]
    NonFinite {
        /// The vertex.
        vertex: u32,
    },
    /// The hierarchy's parent links or per-face arrays are broken.
    #[error("invalid hierarchy: {0}")]
    InvalidHierarchy(#[from] HierarchyError),
    /// The hierarchy has no levels.
    #[error("the hierarchy has no levels")]
    EmptyHierarchy,
    /// An option is out of its range or the options ask for nothing.
    #[error("invalid option {option}: {reason}")]
    InvalidOption {
        /// The option's name.
        option: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The camera description is malformed.
    #[error("invalid camera: {0}")]
    Camera(String),
}

impl Error {
    pub(crate) fn option(option: &'static str, reason: impl Into<String>) -> Self {
        Self::InvalidOption { option, reason: reason.into() }
    }
}
