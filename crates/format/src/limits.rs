//! Decoder limits (spec §7.2 Limits): upper bounds on what a file may claim, checked before
//! allocating for it.

/// Upper bounds a decoder checks before allocating; one struct for every entry point
/// ([`crate::decode`], [`crate::read_info`], [`crate::read_path`] through [`crate::DecodeOptions`]).
///
/// Every declared count is first checked against what the file's bytes can hold (a face, a
/// corner, a listed vertex each take at least one byte of some stream; spec §4.2, §5), then against
/// these limits. What costs no bytes (vertices whose residuals are all zero, a zstd frame of one
/// repeated byte) is bounded by these limits alone, so they bound the memory a file can claim:
/// decoding takes about 250 bytes per vertex of the largest level (working arrays and the
/// returned hierarchy). The defaults (below) suit meshes of up to ~250 M vertices; lower them (or
/// use [`Limits::strict`]) for untrusted input on small machines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Limits {
    /// Most levels in a file (default 32).
    pub max_levels: u32,
    /// Largest stored or decompressed level in bytes (default 4 GiB).
    pub max_level_bytes: u64,
    /// Most vertices per level (default 2^28).
    pub max_vertices: u32,
    /// Most faces per level (default 2^28).
    pub max_faces: u32,
    /// Most face corners per level (default 2^30).
    pub max_corners: u32,
    /// Largest metadata block in bytes (default 16 MiB).
    pub max_metadata_bytes: u32,
    /// Most chunks in a file (version 5, spec §11; default 2^20).
    pub max_chunks: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_levels: 32,
            max_level_bytes: 4 << 30,
            max_vertices: 1 << 28,
            max_faces: 1 << 28,
            max_corners: 1 << 30,
            max_metadata_bytes: 16 << 20,
            max_chunks: 1 << 20,
        }
    }
}

impl Limits {
    /// Small limits for untrusted input in tests and fuzzing (64 MiB levels, 1 M elements).
    pub fn strict() -> Self {
        Self {
            max_levels: 24,
            max_level_bytes: 64 << 20,
            max_vertices: 1 << 20,
            max_faces: 1 << 20,
            max_corners: 1 << 22,
            max_metadata_bytes: 1 << 20,
            max_chunks: 1 << 16,
        }
    }
}
