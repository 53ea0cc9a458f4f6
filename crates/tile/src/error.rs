//! The crate's error type.

use std::path::PathBuf;

/// Why a tiling step failed. Every variant names the file it concerns.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A point cloud could not be read.
    #[error(transparent)]
    Read(#[from] octowrap_io::Error),
    /// A file breaks its format (the offset is in bytes from the start).
    #[error("{path}: at byte {offset}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Where.
        offset: u64,
        /// What was expected and found.
        message: String,
    },
    /// The inputs or options cannot be tiled (the message says why).
    #[error("{0}")]
    Plan(String),
    /// The reconstruction of a tile failed.
    #[error("reconstructing tile {tile}: {source}")]
    Recon {
        /// The tile.
        tile: u32,
        /// The cause.
        source: octowrap_recon::Error,
    },
}

impl Error {
    /// An [`Error::Invalid`].
    pub(crate) fn invalid(path: &std::path::Path, offset: u64, message: impl Into<String>) -> Self {
        Self::Invalid { path: path.to_path_buf(), offset, message: message.into() }
    }

    /// An [`Error::Io`].
    pub(crate) fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        Self::Io { path: path.to_path_buf(), source }
    }
}
