//! The level block of spec §4: the block header (§4.1, 64 bytes) and the twelve streams that
//! follow it (§4.2).
//!
//! [`BlockHeader::parse`] checks every rule of §4.1 that the header alone decides, including that
//! each declared count fits in the streams that must hold it, so that a decoder can read the first
//! 64 decompressed bytes of a level, check them, and only then decompress the rest.
//! [`BlockHeader::streams`] cuts a whole payload into its streams and checks §4.2's table of
//! which streams each mode uses.

use crate::bytes::Reader;
use crate::container::LevelEntry;
use crate::error::{DecodeError, Where};
use crate::topology::slots::MAX_LATTICE_DEPTH;

/// Level block header size in bytes (spec §4.1).
pub const BLOCK_HEADER_SIZE: usize = 64;
/// Number of streams in every level block.
pub const STREAM_COUNT: usize = 12;

/// Stream names, in block order (spec §4.2).
pub const STREAM_NAMES: [&str; STREAM_COUNT] = [
    "child_masks",
    "depths",
    "rotations",
    "created_keys",
    "face_sizes",
    "corners",
    "extra_names",
    "splits",
    "exceptions",
    "choices",
    "raw_lattice",
    "geometry",
];

/// Stream indices.
pub mod s {
    pub const CHILD_MASKS: usize = 0;
    pub const DEPTHS: usize = 1;
    pub const ROTATIONS: usize = 2;
    pub const CREATED_KEYS: usize = 3;
    pub const FACE_SIZES: usize = 4;
    pub const CORNERS: usize = 5;
    pub const EXTRA_NAMES: usize = 6;
    pub const SPLITS: usize = 7;
    pub const EXCEPTIONS: usize = 8;
    pub const CHOICES: usize = 9;
    pub const RAW_LATTICE: usize = 10;
    pub const GEOMETRY: usize = 11;
}

/// Level coding modes (spec §4.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Level 0: a polygon mesh coded on its own.
    Base = 0,
    /// A refinement named by canonical-subdivision slots.
    Generic = 1,
    /// A refinement named by octree lattice points.
    Lattice = 2,
    /// Format version 3: a lattice refinement with vertices numbered by first use and integer
    /// geometry from the parent (spec §5.9, §6.8).
    FastLattice = 3,
}

impl Mode {
    /// Whether the level is a lattice refinement (mode 2 or 3): faces on slots, named by lattice
    /// keys.
    pub fn is_lattice(self) -> bool {
        matches!(self, Mode::Lattice | Mode::FastLattice)
    }

    /// The mode of a `mode` byte in a file of format `version`, if defined there.
    pub fn from_byte(b: u8, version: u16) -> Option<Self> {
        match b {
            0 => Some(Mode::Base),
            1 => Some(Mode::Generic),
            2 => Some(Mode::Lattice),
            3 if version >= 3 => Some(Mode::FastLattice),
            _ => None,
        }
    }

    /// The streams the mode uses (§4.2).
    pub fn streams(self, has_lattice: bool) -> &'static [usize] {
        use s::{CORNERS, FACE_SIZES, GEOMETRY, RAW_LATTICE};
        match (self, has_lattice) {
            (Mode::Base, false) => &[FACE_SIZES, CORNERS, GEOMETRY],
            (Mode::Base, true) => &[FACE_SIZES, CORNERS, RAW_LATTICE, GEOMETRY],
            (Mode::Generic, false) => &[0, 2, 4, 5, 6, 7, 8, 9, 11],
            (Mode::Generic, true) => &[0, 2, 4, 5, 6, 7, 8, 9, 10, 11],
            (Mode::Lattice | Mode::FastLattice, _) => &[0, 1, 2, 3, 6, 7, 8, 9, 11],
        }
    }
}

/// Block flag: the level carries lattice coordinates.
pub const BLOCK_FLAG_LATTICE: u8 = 1;

/// Lattice predictor 0: the lattice point moved along the parent normal (spec §6.3).
pub const PREDICTOR_NORMAL: u8 = 0;
/// Lattice predictor 1: the parent surface's bilinear point (spec §6.3).
pub const PREDICTOR_BILINEAR: u8 = 1;
/// Bit 1 of the block's `predictor` byte: the geometry stream has the line layout (spec §6.1, §6.6).
pub const PREDICTOR_LINES: u8 = 2;
/// The largest magnitude of a line parameter `J` (spec §6.1, "Decoding a vertex").
pub const LINE_PARAM_LIMIT: i64 = 1 << 30;
/// The largest line spacing exponent (spec §4.1, `line_shift`).
pub const MAX_LINE_SHIFT: u32 = 16;

/// How positions are stored, from the file header (spec §3.1).
#[derive(Clone, Copy, Debug)]
pub struct GridInfo {
    /// Positions stored exactly (binary64).
    pub exact: bool,
    /// The grid is tied to the octree cube.
    pub tied: bool,
    /// Grid bits.
    pub bits: u32,
    /// File format version (line geometry needs version 2, mode 3 version 3).
    pub version: u16,
}

/// A checked level block header (spec §4.1), field names as in the spec.
#[derive(Clone, Copy, Debug)]
pub struct BlockHeader {
    /// `mode`.
    pub mode: Mode,
    /// Bit `LATTICE` of `block_flags`: the level has lattice coordinates.
    pub has_lattice: bool,
    /// Bit 0 of `predictor`: the lattice predictor of pass A (§6.3).
    pub predictor: u8,
    /// Bit 1 of `predictor` (`LINES`): line geometry (§6.6).
    pub lines: bool,
    /// `line_shift`.
    pub line_shift: u32,
    /// `vertex_count`, `face_count`, `corner_count`.
    pub counts: [usize; 3],
    /// `stream_size`, in the order of §4.2.
    pub sizes: [usize; STREAM_COUNT],
    /// The geometry stream holds value blocks (§6.9: mode 3 of a version 4 grid file), which
    /// may take less than a byte per vertex.
    pub value_blocks: bool,
}

impl BlockHeader {
    /// Reads and checks level `k`'s block header from the first [`BLOCK_HEADER_SIZE`] bytes of its
    /// payload (`head` may be longer): every rule of §4.1 except the ones that need the geometry
    /// stream's bytes (see [`Self::streams`]).
    pub fn parse(k: u32, head: &[u8], entry: &LevelEntry, grid: GridInfo) -> Result<Self, DecodeError> {
        let place = Where::Payload(k);
        let mut r = Reader::new(head, 0, place, "level block header");
        let bad =
            |offset: u64, reason: String| DecodeError::Invalid { place, offset, what: "level block header", reason };
        let mode = Mode::from_byte(r.u8()?, grid.version).ok_or_else(|| bad(0, format!("unknown mode {}", head[0])))?;
        if (mode == Mode::Base) != (k == 0) {
            return Err(bad(0, format!("mode {} is not allowed at level {k}", mode as u8)));
        }
        let flags = r.u8()?;
        if flags & !BLOCK_FLAG_LATTICE != 0 {
            return Err(bad(1, format!("reserved flag bits set: {flags:#x}")));
        }
        let has_lattice = flags & BLOCK_FLAG_LATTICE != 0;
        if has_lattice && k > MAX_LATTICE_DEPTH {
            return Err(bad(1, format!("lattice coordinates are not allowed below level {MAX_LATTICE_DEPTH}")));
        }
        if mode.is_lattice() && (!has_lattice || !(grid.exact || grid.tied)) {
            return Err(bad(0, "lattice mode needs the lattice flag and an exact or cube-tied grid".into()));
        }
        let predictor_byte = r.u8()?;
        let lines = predictor_byte & PREDICTOR_LINES != 0;
        let predictor = predictor_byte & !PREDICTOR_LINES;
        if predictor > u8::from(mode.is_lattice()) {
            return Err(bad(2, format!("predictor {predictor} is not defined for mode {}", mode as u8)));
        }
        if lines && (mode == Mode::Base || grid.exact || grid.version < 2) {
            return Err(bad(2, "line geometry needs a refinement level of a grid file of version 2 or later".into()));
        }
        let line_shift = u32::from(r.u8()?);
        if line_shift > if lines { MAX_LINE_SHIFT } else { 0 } {
            return Err(bad(3, format!("line_shift {line_shift} (0 without LINES, at most {MAX_LINE_SHIFT})")));
        }
        let (nv, nf, nc) = (r.u32()?, r.u32()?, r.u32()?);
        if (nv, nf, nc) != (entry.vertex_count, entry.face_count, entry.corner_count) {
            return Err(bad(4, "vertex, face or corner count differs from the level table".into()));
        }
        let mut sizes = [0usize; STREAM_COUNT];
        let mut total = BLOCK_HEADER_SIZE as u64;
        for sz in &mut sizes {
            let n = r.u32()?;
            *sz = n as usize;
            total += u64::from(n);
        }
        if total != entry.raw_size {
            return Err(bad(16, format!("streams take {total} bytes, the level table says {}", entry.raw_size)));
        }
        let header = Self {
            mode,
            has_lattice,
            predictor,
            lines,
            line_shift,
            counts: [nv as usize, nf as usize, nc as usize],
            sizes,
            value_blocks: mode == Mode::FastLattice && !grid.exact && grid.version >= 4,
        };
        header.justify_counts().map_err(|(at, reason)| bad(at, reason))?;
        Ok(header)
    }

    /// Checks the declared counts against what the streams can hold, before anything is
    /// allocated for them: every face and corner takes at least one byte of some stream (§5.1,
    /// §5.3, §5.4, §5.9), and so does every vertex with lattice coordinates listed (§5.8) or
    /// numbered by first use (§5.9). Fails with the header offset of the count.
    fn justify_counts(&self) -> Result<(), (u64, String)> {
        let len = |i: usize| self.sizes[i] as u64;
        let [nv, nf, nc] = self.counts.map(|n| n as u64);
        let (max_faces, max_corners) = match self.mode {
            Mode::Base => (len(s::FACE_SIZES), len(s::CORNERS)),
            Mode::Generic => (len(s::ROTATIONS) + len(s::FACE_SIZES), 4 * len(s::ROTATIONS) + len(s::CORNERS)),
            Mode::Lattice | Mode::FastLattice => (len(s::ROTATIONS), 4 * len(s::ROTATIONS)),
        };
        if nf > max_faces {
            return Err((8, overflow("face_count", nf, max_faces)));
        }
        if nc > max_corners {
            return Err((12, overflow("corner_count", nc, max_corners)));
        }
        if self.has_lattice && !self.mode.is_lattice() && nv + nf > len(s::RAW_LATTICE) {
            return Err((4, overflow("vertex_count plus face_count", nv + nf, len(s::RAW_LATTICE))));
        }
        if self.mode == Mode::FastLattice && nv > nc + len(s::EXTRA_NAMES) {
            return Err((4, overflow("vertex_count", nv, nc + len(s::EXTRA_NAMES))));
        }
        Ok(())
    }

    /// Cuts level `k`'s whole payload (header included) into its twelve streams, checks that the
    /// streams the mode does not use are empty (§4.2), and that the geometry stream can hold
    /// `vertex_count` vertices ([`geometry_vertex_bound`]).
    pub fn streams<'a>(&self, k: u32, payload: &'a [u8]) -> Result<[Reader<'a>; STREAM_COUNT], DecodeError> {
        let place = Where::Payload(k);
        let mut at = BLOCK_HEADER_SIZE;
        let streams: [Reader<'a>; STREAM_COUNT] = std::array::from_fn(|i| {
            let end = (at + self.sizes[i]).min(payload.len());
            let r = Reader::new(&payload[at.min(end)..end], at as u64, place, STREAM_NAMES[i]);
            at = end;
            r
        });
        if at != payload.len() || streams.iter().zip(&self.sizes).any(|(r, &n)| r.remaining() != n) {
            return Err(DecodeError::Invalid {
                place,
                offset: 16,
                what: "level block header",
                reason: format!("the streams do not fill the {}-byte payload", payload.len()),
            });
        }
        let used = self.mode.streams(self.has_lattice);
        for (i, r) in streams.iter().enumerate() {
            if !used.contains(&i) && r.remaining() != 0 {
                return Err(r.invalid(format!("stream must be empty in mode {}", self.mode as u8)));
            }
        }
        let nv = self.counts[0] as u64;
        let bound =
            if self.value_blocks { None } else { geometry_vertex_bound(streams[s::GEOMETRY].rest(), self.lines) };
        if let Some(max) = bound {
            if nv > max {
                return Err(DecodeError::Invalid {
                    place,
                    offset: 4,
                    what: "level block header",
                    reason: overflow("vertex_count", nv, max),
                });
            }
        }
        Ok(streams)
    }
}

fn overflow(what: &str, n: u64, max: u64) -> String {
    format!("{what} {n} exceeds the {max} that the streams can hold")
}

/// The most vertices a geometry stream of these bytes can describe (§6.1, §6.6): with line
/// geometry its bitmap takes a bit per vertex; otherwise the first residual block with a byte
/// plane takes a byte per vertex. `None` when every block has zero planes (the vertices then cost
/// no bytes, and only [`crate::Limits`] bounds them) or the stream is too short to tell (reading it
/// fails later).
fn geometry_vertex_bound(g: &[u8], lines: bool) -> Option<u64> {
    if lines {
        return Some(8 * g.len() as u64);
    }
    for (at, &planes) in g.iter().enumerate().take(3) {
        if planes > 0 {
            return Some((g.len() - at - 1) as u64 / u64::from(planes));
        }
    }
    None
}
