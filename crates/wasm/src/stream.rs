//! Level-by-level streaming of one MRQ file from byte ranges (spec §3: the preamble first, then
//! the levels coarse to fine, each one zstd frame coded against the level above it).
//!
//! The caller fetches the ranges [`Stream::next_range`] names, hands each to [`Stream::push`], and
//! decodes the finest level whose bytes are all present ([`Stream::ready_level`],
//! [`Stream::decode`]). `next_range` is the one place that decides what to fetch: it asks for the
//! preamble, then for the next level, until the file ends or the next level would not fit in the
//! memory budget.

use std::ops::Range;

use octowrap_format::{DecodeError, DecodeOptions, FileInfo, Limits};

/// Bytes asked for by the first request: the preamble and, in a reconstructed file, the coarse
/// levels up to a few thousand faces (the dragon's levels 0 to 5 take 10.5 KB), so that the
/// first frame needs one request.
pub const FIRST_REQUEST_BYTES: u64 = 16 << 10;

/// Why a stream cannot go on. Each names the byte offset it concerns.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StreamError {
    /// The MRQ decoder rejected the bytes (bad magic, checksum, invalid level, ...).
    #[error(transparent)]
    Decode(#[from] DecodeError),
    /// Bytes arrived that do not continue the prefix already held.
    #[error("bytes at offset {offset} do not continue the {held} bytes already received")]
    OutOfOrder {
        /// Offset of the bytes pushed.
        offset: u64,
        /// Bytes held (the prefix `0..held`).
        held: u64,
    },
    /// The file is shorter than its preamble or level table says.
    #[error("truncated file: it ends at byte {len}, but {what} needs bytes {start}..{end}")]
    Truncated {
        /// The file length.
        len: u64,
        /// The structure that does not fit.
        what: String,
        /// Its first byte.
        start: u64,
        /// One past its last byte.
        end: u64,
    },
    /// The file goes on after its last level.
    #[error("corrupted file: {extra} bytes follow the last level, which ends at byte {end}")]
    TrailingBytes {
        /// One past the last level's last byte.
        end: u64,
        /// Bytes after it.
        extra: u64,
    },
    /// Two responses gave different file lengths.
    #[error("the file changed while it was read: its length was {before} bytes, now {now}")]
    FileChanged {
        /// The length first reported.
        before: u64,
        /// The length reported now.
        now: u64,
    },
    /// A view's chunk selection is not a cut (spec §11.5).
    #[error("bad chunk selection: {0}")]
    Selection(String),
    /// A level was asked for before its bytes arrived.
    #[error("level {level} is not ready: it needs bytes up to {end}, {held} have arrived")]
    NotReady {
        /// The level.
        level: u32,
        /// One past its last byte.
        end: u64,
        /// Bytes held.
        held: u64,
    },
}

/// Where the first requests end while the preamble is not all in: at least
/// [`FIRST_REQUEST_BYTES`], the preamble's length once the header says it (`preamble_len`), and
/// no further than the file's length when known (a short file's first request may run past its
/// end). Fails when the preamble does not fit in the file.
pub(crate) fn preamble_end(file_len: Option<u64>, preamble_len: Option<u64>) -> Result<u64, StreamError> {
    let want = preamble_len.unwrap_or(0).max(FIRST_REQUEST_BYTES);
    match (file_len, preamble_len) {
        (Some(len), Some(p)) if p > len => {
            Err(StreamError::Truncated { len, what: "the preamble".into(), start: 0, end: p })
        }
        (Some(len), _) => Ok(want.min(len)),
        (None, _) => Ok(want),
    }
}

/// Records a file's length in `slot`; fails when a length recorded before differs (the file
/// changed while it was being read).
pub(crate) fn record_len(slot: &mut Option<u64>, len: u64) -> Result<(), StreamError> {
    match *slot {
        Some(before) if before != len => Err(StreamError::FileChanged { before, now: len }),
        _ => {
            *slot = Some(len);
            Ok(())
        }
    }
}

/// One decoded level as triangle arrays for a GPU: positions in world units, three `f32` per
/// vertex; three vertex indices per triangle (quads split along their shorter diagonal, as
/// [`octowrap_mesh::Mesh::triangles`] does).
#[derive(Clone, Debug, PartialEq)]
pub struct LevelMesh {
    /// The level's index (0 is the coarsest).
    pub level: u32,
    /// `x, y, z` per vertex.
    pub positions: Vec<f32>,
    /// `a, b, c` per triangle.
    pub triangles: Vec<u32>,
    /// The level's polygon faces (before triangulation).
    pub faces: u32,
}

/// The state of one file being streamed: the prefix of its bytes received so far and, once the
/// preamble is in, its description.
#[derive(Debug)]
pub struct Stream {
    bytes: Vec<u8>,
    file_len: Option<u64>,
    info: Option<FileInfo>,
    /// Bytes the preamble needs, once the header says (before the whole preamble is in).
    preamble_len: Option<u64>,
    budget_bytes: u64,
    limits: Limits,
}

impl Stream {
    /// A stream that fetches levels while their estimated decoding memory
    /// ([`Stream::memory_estimate`]) stays within `budget_bytes`.
    pub fn new(budget_bytes: u64) -> Self {
        Self {
            bytes: Vec::new(),
            file_len: None,
            info: None,
            preamble_len: None,
            budget_bytes,
            limits: Limits::default(),
        }
    }

    /// Bytes received (the prefix `0..held`).
    pub fn held(&self) -> u64 {
        self.bytes.len() as u64
    }

    /// The preamble's description of the file, once it has arrived.
    pub fn info(&self) -> Option<&FileInfo> {
        self.info.as_ref()
    }

    /// Records the file's length (from a `Content-Range` header). Fails when a length recorded
    /// before differs (the file changed while it was being read); a length that contradicts the
    /// level table is reported by [`Stream::next_range`], once the levels before the damage are in.
    pub fn set_file_len(&mut self, len: u64) -> Result<(), StreamError> {
        record_len(&mut self.file_len, len)
    }

    /// Adds bytes fetched from `offset`. They must start within or at the end of the prefix held;
    /// bytes already held are skipped. Parses the preamble as soon as it is complete.
    pub fn push(&mut self, offset: u64, data: &[u8]) -> Result<(), StreamError> {
        let held = self.held();
        if offset > held {
            return Err(StreamError::OutOfOrder { offset, held });
        }
        let skip = usize::try_from(held - offset).unwrap_or(usize::MAX);
        if let Some(new) = data.get(skip..) {
            self.bytes.extend_from_slice(new);
        }
        if self.info.is_none() {
            match octowrap_format::read_info(&self.bytes[..], &self.limits) {
                Ok(info) => {
                    self.preamble_len = Some(info.preamble_size);
                    self.info = Some(info);
                }
                // The preamble is not all in yet: the error says how much it needs.
                Err(DecodeError::Truncated { offset, needed, got, .. })
                    if got < needed && offset + got == self.held() =>
                {
                    self.preamble_len = Some(offset + needed);
                }
                Err(e) => return Err(e.into()),
            }
        }
        Ok(())
    }

    /// The next byte range to fetch (start inclusive, end exclusive), or `None` when everything
    /// wanted has arrived: the preamble first (at least [`FIRST_REQUEST_BYTES`]), then the next
    /// level while it fits in the memory budget. Fails when the file length is known and the
    /// next structure does not fit in it, or bytes follow the last level.
    pub fn next_range(&self) -> Result<Option<Range<u64>>, StreamError> {
        let held = self.held();
        let Some(info) = &self.info else {
            let end = preamble_end(self.file_len, self.preamble_len)?;
            return Ok((end > held).then_some(held..end));
        };
        let next = self.ready_level().map_or(0, |k| k + 1);
        if next as usize >= info.levels.len() {
            let end = info.levels.last().map_or(info.preamble_size, |l| l.offset.saturating_add(l.stored_size));
            return match self.file_len {
                Some(len) if len > end => Err(StreamError::TrailingBytes { end, extra: len - end }),
                _ => Ok(None),
            };
        }
        if self.memory_estimate(next) > self.budget_bytes {
            return Ok(None);
        }
        let want = level_end(info, next);
        match self.file_len {
            Some(len) if want > len => Err(StreamError::Truncated {
                len,
                what: format!("level {next}"),
                start: info.levels[next as usize].offset,
                end: want,
            }),
            _ => Ok((want > held).then_some(held..want)),
        }
    }

    /// The finest level whose bytes have all arrived.
    pub fn ready_level(&self) -> Option<u32> {
        let info = self.info.as_ref()?;
        let held = self.held();
        (0..info.levels.len() as u32).rev().find(|&k| level_end(info, k) <= held)
    }

    /// Estimated peak memory, in bytes, of holding the file up to level `k` and decoding it: the
    /// bytes, every level `0..=k` as decoded meshes (positions as `f64`, faces, parent links), the
    /// finest level's decompressed payload and its triangle arrays. `u64::MAX` for a level the
    /// file does not have.
    pub fn memory_estimate(&self, k: u32) -> u64 {
        let Some(info) = &self.info else { return u64::MAX };
        let Some(last) = info.levels.get(k as usize) else { return u64::MAX };
        let levels: u64 = info.levels[..=k as usize]
            .iter()
            .map(|l| 24 * u64::from(l.vertex_count) + 16 * u64::from(l.face_count) + 4 * u64::from(l.corner_count))
            .sum();
        let arrays = 12 * u64::from(last.vertex_count) + 6 * u64::from(last.corner_count);
        level_end(info, k) + levels + 2 * last.raw_size + arrays
    }

    /// Decodes level `k` (and, as the format requires, the levels above it) from the bytes held.
    pub fn decode(&self, k: u32) -> Result<LevelMesh, StreamError> {
        let held = self.held();
        let info = self.info.as_ref().ok_or(StreamError::NotReady { level: k, end: held + 1, held })?;
        if k as usize >= info.levels.len() {
            return Err(DecodeError::NoSuchLevel { requested: k, available: info.levels.len() as u32 }.into());
        }
        let end = level_end(info, k);
        if end > held {
            return Err(StreamError::NotReady { level: k, end, held });
        }
        let mut opts = DecodeOptions::up_to(k);
        opts.limits = self.limits;
        let mut file = octowrap_format::decode(&self.bytes[..end as usize], &opts)?;
        let level = file.hierarchy.levels.swap_remove(k as usize);
        let mesh = &level.mesh;
        let positions = mesh.vertices.positions.iter().flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
        let triangles = mesh.triangles().into_iter().flatten().collect();
        Ok(LevelMesh { level: k, positions, triangles, faces: mesh.faces.len() as u32 })
    }
}

/// One past the last byte of level `k`.
fn level_end(info: &FileInfo, k: u32) -> u64 {
    let l = &info.levels[k as usize];
    l.offset.saturating_add(l.stored_size)
}
