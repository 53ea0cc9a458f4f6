//! Typed errors (spec §7.3 Errors). Decoding errors name where the problem lies (the preamble or level `k`, and a
//! byte offset) and what is wrong; encoding errors name the offending level and element.

use std::fmt;

/// A region of an MRQ file, for error messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Where {
    /// The preamble: file header, level table, metadata and preamble checksum. Offsets are file
    /// offsets.
    Preamble,
    /// The stored (compressed) bytes of level `k`. Offsets are file offsets.
    Level(u32),
    /// The decompressed payload of level `k`. Offsets count from the payload's first byte.
    Payload(u32),
    /// The stored (compressed) bytes of chunk `c` of level `k` (version 5). File offsets.
    Chunk(u32, u32),
    /// The decompressed payload of chunk `c` of level `k`. Offsets count from its first byte.
    ChunkPayload(u32, u32),
}

impl fmt::Display for Where {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Preamble => write!(f, "preamble, file byte"),
            Self::Level(k) => write!(f, "level {k}, file byte"),
            Self::Payload(k) => write!(f, "level {k}, decompressed payload byte"),
            Self::Chunk(k, c) => write!(f, "level {k}, chunk {c}, file byte"),
            Self::ChunkPayload(k, c) => write!(f, "level {k}, chunk {c}, decompressed payload byte"),
        }
    }
}

/// Why an MRQ file could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// The file does not start with the MRQ magic number.
    #[error("not an MRQ file: bad magic number at byte 0 (found {found:02x?})")]
    BadMagic {
        /// The first bytes found.
        found: Vec<u8>,
    },
    /// The file's format version is not one this reader implements.
    #[error(
        "unsupported MRQ format version {found} at byte 8 (this reader implements versions 1 to {})",
        crate::FORMAT_VERSION
    )]
    UnsupportedVersion {
        /// The version found.
        found: u16,
    },
    /// The input ended before the structure being read was complete.
    #[error("truncated at byte {offset}: {what} needs {needed} bytes, the input ended after {got}")]
    Truncated {
        /// File offset where the incomplete structure starts.
        offset: u64,
        /// The structure being read.
        what: String,
        /// Bytes it needs.
        needed: u64,
        /// Bytes available.
        got: u64,
    },
    /// A stored checksum does not match the bytes it covers.
    #[error("checksum mismatch in {place} {offset}: stored {stored:016x}, computed {computed:016x}")]
    ChecksumMismatch {
        /// The region whose checksum failed.
        place: Where,
        /// File offset of the region's first byte.
        offset: u64,
        /// The checksum in the file.
        stored: u64,
        /// The checksum of the bytes read.
        computed: u64,
    },
    /// A declared size or count exceeds the caller's [`crate::Limits`].
    #[error("limit exceeded at {place} {offset}: {what} is {value}, the limit is {limit}")]
    LimitExceeded {
        /// Where the declared value sits.
        place: Where,
        /// Its offset.
        offset: u64,
        /// Which limit.
        what: &'static str,
        /// The declared value.
        value: u64,
        /// The limit.
        limit: u64,
    },
    /// The bytes break a rule of the format (a reserved field not zero, an index out of range, an
    /// invalid topology edit, ...).
    #[error("invalid {what} at {place} {offset}: {reason}")]
    Invalid {
        /// Where.
        place: Where,
        /// Offset within that region.
        offset: u64,
        /// The structure or stream.
        what: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// zstd could not decompress a level's stored bytes.
    #[error("level {level} at file byte {offset}: zstd frame is corrupt: {reason}")]
    Zstd {
        /// The level.
        level: u32,
        /// File offset of the level's stored bytes.
        offset: u64,
        /// zstd's message.
        reason: String,
    },
    /// The caller asked for a level the file does not hold.
    #[error("level {requested} requested, but the file holds {available} levels")]
    NoSuchLevel {
        /// The level asked for.
        requested: u32,
        /// Levels in the file.
        available: u32,
    },
    /// Reading failed.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

/// Why a hierarchy could not be encoded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// The hierarchy has no levels.
    #[error("the hierarchy has no levels")]
    Empty,
    /// Parent links or per-element arrays are broken.
    #[error("broken hierarchy: {0}")]
    Links(#[from] octowrap_mesh::HierarchyError),
    /// A level's faces refer to missing vertices or have fewer than 3 corners.
    #[error("level {level}: {source}")]
    Faces {
        /// The level.
        level: usize,
        /// The face-list problem.
        source: octowrap_mesh::IndexError,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("level {level}: vertex {vertex} has a non-finite coordinate")]
    NonFinite {
        /// The level.
        level: usize,
        /// The vertex.
        vertex: usize,
    },
    /// A quantized coordinate falls outside the grid range of spec §1.7.
    #[error("level {level}: vertex {vertex} lies outside the quantization grid (|q| > 2^28 steps); use a coarser step")]
    OutOfGrid {
        /// The level.
        level: usize,
        /// The vertex.
        vertex: usize,
    },
    /// Something the format cannot hold (explained).
    #[error("level {level}: {reason}")]
    Unsupported {
        /// The level.
        level: usize,
        /// What cannot be stored.
        reason: String,
    },
    /// The options are unusable (explained).
    #[error("bad encode options: {0}")]
    Options(String),
    /// Writing failed.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}
