//! Whole-file decoding (spec §3 File structure, §7.1 Order of checks): the preamble, then each
//! level in order: its stored bytes, their checksum, streaming decompression capped at the
//! declared size, and the level block; nothing may follow the last level.

use std::io::Read;

use octowrap_mesh::{Aabb, DVec3, FaceList, FaceOrigin, Hierarchy, Level, LevelLattice, Mesh, Quadrant};
use xxhash_rust::xxh3::xxh3_64;

use crate::block::{BLOCK_HEADER_SIZE, BlockHeader, GridInfo};
use crate::container::{self, ENTRY_SIZE, FLAG_CUBE, FLAG_EXACT, FLAG_TIED, HEADER_SIZE, LevelEntry, MAGIC, Preamble};
use crate::error::{DecodeError, Where};
use crate::level_decode::{self, PlainLevel};
use crate::topology::NO_PARENT;
use crate::{DecodeOptions, FileInfo, Limits, MrqFile};

/// Reads `n` bytes without trusting `n` for the allocation: the buffer grows with the input.
fn read_vec(r: &mut impl Read, n: u64, offset: u64, what: &str) -> Result<Vec<u8>, DecodeError> {
    let mut v = Vec::with_capacity(n.min(1 << 20) as usize);
    r.take(n).read_to_end(&mut v)?;
    if (v.len() as u64) < n {
        return Err(DecodeError::Truncated { offset, what: what.to_owned(), needed: n, got: v.len() as u64 });
    }
    Ok(v)
}

/// [`read_vec`] into a reused buffer.
fn read_into(r: &mut impl Read, buf: &mut Vec<u8>, n: u64, offset: u64, what: &str) -> Result<(), DecodeError> {
    buf.clear();
    buf.reserve(n.min(1 << 20) as usize);
    r.take(n).read_to_end(buf)?;
    if (buf.len() as u64) < n {
        return Err(DecodeError::Truncated { offset, what: what.to_owned(), needed: n, got: buf.len() as u64 });
    }
    Ok(())
}

pub fn read_preamble(r: &mut impl Read, limits: &Limits) -> Result<Preamble, DecodeError> {
    let mut head = [0u8; HEADER_SIZE];
    // A short file that does not even start with the magic is not an MRQ file.
    let mut got = 0;
    while got < HEADER_SIZE {
        match r.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    let header = check_head(&head, got, limits)?;
    let rest =
        read_vec(r, rest_len(&header), HEADER_SIZE as u64, "level table, chunk index, metadata and preamble checksum")?;
    container::parse_rest(header, &head, &rest, limits)
}

/// Checks the first `got` bytes of a file (spec §7.1 steps 1 and 2) and parses its header.
pub fn check_head(head: &[u8; HEADER_SIZE], got: usize, limits: &Limits) -> Result<container::FileHeader, DecodeError> {
    let m = got.min(8);
    if head[..m] != MAGIC[..m] {
        return Err(DecodeError::BadMagic { found: head[..m].to_vec() });
    }
    if got < HEADER_SIZE {
        return Err(DecodeError::Truncated {
            offset: 0,
            what: "file header".into(),
            needed: HEADER_SIZE as u64,
            got: got as u64,
        });
    }
    container::parse_header(head, limits)
}

/// Bytes of the preamble after the header.
pub fn rest_len(header: &container::FileHeader) -> u64 {
    ENTRY_SIZE as u64 * u64::from(header.level_count)
        + container::CHUNK_ENTRY_SIZE as u64 * u64::from(header.chunk_count)
        + u64::from(header.metadata_size)
        + 8
}

/// Reads only the preamble: levels, sizes, counts, quantization, metadata.
pub fn read_info(mut r: impl Read, limits: &Limits) -> Result<FileInfo, DecodeError> {
    Ok(FileInfo::from_preamble(&read_preamble(&mut r, limits)?))
}

/// Buffers a thread's decodes share: the zstd context, the stored and decompressed bytes of a
/// level, and the level decoder's arrays. Kept between calls unless they grew beyond
/// [`KEPT_BUFFER_BYTES`], so that decoding many small files does not allocate (and fault in) the
/// same memory again and again.
#[derive(Default)]
struct DecodeBuffers {
    unzstd: Option<zstd::zstd_safe::DCtx<'static>>,
    stored: Vec<u8>,
    payload: Vec<u8>,
    level: level_decode::Scratch,
}

/// The most buffer memory a thread keeps between decodes.
const KEPT_BUFFER_BYTES: usize = 64 << 20;

thread_local! {
    static BUFFERS: std::cell::RefCell<Option<DecodeBuffers>> = const { std::cell::RefCell::new(None) };
}

/// Decodes levels `0..=opts.max_level` (all by default) from `r`, reading the input in order and
/// nothing beyond the last level asked for.
///
/// One call decodes on the calling thread. The thread keeps the decoder's working buffers (up to
/// 64 MiB) for its next call; the returned hierarchy is always freshly allocated.
pub fn decode(mut r: impl Read, opts: &DecodeOptions) -> Result<MrqFile, DecodeError> {
    let pre = read_preamble(&mut r, &opts.limits)?;
    let mut buffers = BUFFERS.with(|b| b.borrow_mut().take()).unwrap_or_default();
    let out = decode_levels(&mut r, &pre, opts, &mut buffers);
    let kept = buffers.stored.capacity() + buffers.payload.capacity() + buffers.level.capacity_bytes();
    if kept <= KEPT_BUFFER_BYTES {
        BUFFERS.with(|b| *b.borrow_mut() = Some(buffers));
    }
    Ok(MrqFile { info: FileInfo::from_preamble(&pre), hierarchy: out? })
}

/// The levels of [`decode`], after the preamble.
fn decode_levels(
    r: &mut impl Read,
    pre: &Preamble,
    opts: &DecodeOptions,
    buffers: &mut DecodeBuffers,
) -> Result<Hierarchy, DecodeError> {
    let n = pre.levels.len() as u32;
    let last = match opts.max_level {
        Some(k) if k >= n => return Err(DecodeError::NoSuchLevel { requested: k, available: n }),
        Some(k) => k,
        None => n - 1,
    };
    let h = &pre.header;
    let gi = GridInfo {
        exact: h.flags & FLAG_EXACT != 0,
        tied: h.flags & FLAG_TIED != 0,
        bits: h.grid_bits,
        version: h.version,
    };
    let origin = DVec3::from_array(h.origin);
    let mut out = Hierarchy {
        levels: Vec::with_capacity(last as usize + 1),
        cube: (h.flags & FLAG_CUBE != 0)
            .then(|| Aabb { min: DVec3::from_array(h.cube_min), max: DVec3::from_array(h.cube_max) }),
    };
    let mut parent: Option<PlainLevel> = None;
    // One decompression context for all levels (its buffers are reused).
    let unzstd = match &mut buffers.unzstd {
        Some(z) => z,
        none => none.insert(zstd::zstd_safe::DCtx::try_create().ok_or_else(|| DecodeError::Zstd {
            level: 0,
            offset: 0,
            reason: "cannot create a decompression context".into(),
        })?),
    };
    let chunked = h.version >= container::CHUNKED_VERSION;
    // Version 5: the level above, decoded chunk by chunk (the next level's parents), merged and
    // converted while the next level's chunks decode.
    let mut above: Option<crate::chunked::LevelParts> = None;
    for k in 0..=last {
        let e = &pre.levels[k as usize];
        let stored = &mut buffers.stored;
        read_into(r, stored, e.stored_size, e.offset, &format!("level {k}"))?;
        let computed = xxh3_64(stored);
        if computed != e.checksum {
            return Err(DecodeError::ChecksumMismatch {
                place: Where::Level(k),
                offset: e.offset,
                stored: e.checksum,
                computed,
            });
        }
        if chunked {
            let stored: &[u8] = stored;
            let (this, merged) = rayon::join(
                || crate::chunked::decode_level_parts(pre, k, stored, above.as_ref()),
                || above.as_ref().map(|a| crate::chunked::merge_level(pre, a).map(|lv| into_level(lv, origin, h.step))),
            );
            // The level above's error first, as a decoder taking the levels in order finds it.
            if let Some(m) = merged {
                out.levels.push(m?);
            }
            above = Some(this?);
            continue;
        }
        let payload = &mut buffers.payload;
        decompress_level(unzstd, stored, (k, e), payload, |head| BlockHeader::parse(k, head, e, gi).map(drop))?;
        let lv = level_decode::decode_level(k, payload, e, parent.as_ref(), gi, &mut buffers.level)?;
        // The parent is no longer needed: its arrays move into the output.
        if let Some(p) = parent.replace(lv) {
            out.levels.push(into_level(p, origin, h.step));
        }
    }
    out.levels.extend(parent.map(|p| into_level(p, origin, h.step)));
    if let Some(a) = above {
        out.levels.push(into_level(crate::chunked::merge_last_level(pre, a)?, origin, h.step));
    }
    if last + 1 == n {
        reject_trailing_bytes(r, &pre.levels[last as usize], last)?;
    }
    Ok(out)
}

/// Fails when the input holds bytes after the last level (spec §3.5: a decoder rejects them).
fn reject_trailing_bytes(r: &mut impl Read, e: &LevelEntry, k: u32) -> Result<(), DecodeError> {
    let mut byte = [0u8; 1];
    loop {
        match r.read(&mut byte) {
            Ok(0) => return Ok(()),
            Ok(_) => {
                return Err(DecodeError::Invalid {
                    place: Where::Level(k),
                    offset: e.offset + e.stored_size,
                    what: "end of file",
                    reason: "bytes follow the last level".into(),
                });
            }
            Err(x) if x.kind() == std::io::ErrorKind::Interrupted => {}
            Err(x) => return Err(x.into()),
        }
    }
}

/// Decompresses level `k`'s stored bytes (one zstd frame, spec §3.5) into `payload`, streaming:
/// the first [`BLOCK_HEADER_SIZE`] bytes go to `check_header` before anything more is
/// decompressed; then the output grows with what the frame produces, never beyond `raw_size` (a
/// frame that expands further fails as soon as it passes that size); nothing may follow the frame.
pub(crate) fn decompress_level(
    unzstd: &mut zstd::zstd_safe::DCtx<'static>,
    stored: &[u8],
    (k, e): (u32, &LevelEntry),
    payload: &mut Vec<u8>,
    check_header: impl FnOnce(&[u8]) -> Result<(), DecodeError>,
) -> Result<(), DecodeError> {
    use zstd::zstd_safe::{InBuffer, OutBuffer, ResetDirective, get_error_name};
    let zerr = |reason: String| DecodeError::Zstd { level: k, offset: e.offset, reason };
    match zstd::zstd_safe::get_frame_content_size(stored) {
        Ok(Some(size)) if size == e.raw_size => {}
        Ok(Some(size)) => {
            return Err(zerr(format!("frame holds {size} bytes, the level table says {}", e.raw_size)));
        }
        Ok(None) => return Err(zerr("the frame does not state its content size".into())),
        Err(_) => return Err(zerr("not a zstd frame".into())),
    }
    let raw = usize::try_from(e.raw_size).map_err(|_| zerr("raw_size does not fit in memory".into()))?;
    unzstd.reset(ResetDirective::SessionOnly).map_err(|c| zerr(get_error_name(c).into()))?;
    let mut input = InBuffer::around(stored);
    let mut hint = 1;
    // The block header first, into a buffer of its own size.
    let mut head = [0u8; BLOCK_HEADER_SIZE];
    let head_len = raw.min(BLOCK_HEADER_SIZE);
    let mut output = OutBuffer::around(&mut head[..head_len]);
    while output.pos() < head_len && hint != 0 {
        let before = (input.pos(), output.pos());
        hint = unzstd.decompress_stream(&mut output, &mut input).map_err(|c| zerr(get_error_name(c).into()))?;
        if (input.pos(), output.pos()) == before {
            return Err(zerr("the frame ends early".into()));
        }
    }
    let got = output.pos();
    payload.clear();
    payload.extend_from_slice(&head[..got]);
    if got == BLOCK_HEADER_SIZE {
        check_header(&head)?;
    }
    // The rest: what the stored bytes can plausibly expand to is reserved at once, more as it comes.
    payload.reserve(raw.min(stored.len().saturating_mul(64).max(1 << 16)));
    while hint != 0 {
        if payload.len() == payload.capacity() {
            // One byte beyond `raw`, so that a frame expanding further shows itself.
            payload.reserve((raw + 1 - payload.len().min(raw)).min(payload.len().max(1 << 16)));
        }
        let before = (input.pos(), payload.len());
        let len = payload.len();
        let mut output = OutBuffer::around_pos(payload, len);
        hint = unzstd.decompress_stream(&mut output, &mut input).map_err(|c| zerr(get_error_name(c).into()))?;
        if payload.len() > raw {
            return Err(zerr(format!("the frame expands beyond the {raw} bytes the level table declares")));
        }
        if hint != 0 && (input.pos(), payload.len()) == before {
            return Err(zerr("the frame ends early".into()));
        }
    }
    if input.pos() != stored.len() {
        return Err(zerr(format!("{} bytes follow the frame", stored.len() - input.pos())));
    }
    if payload.len() != raw {
        return Err(zerr(format!("decompressed to {} bytes, the level table says {raw}", payload.len())));
    }
    Ok(())
}

/// Decodes a whole file held in memory, with [`Limits::strict`]-free default limits.
pub fn decode_bytes(bytes: &[u8], opts: &DecodeOptions) -> Result<MrqFile, DecodeError> {
    decode(bytes, opts)
}

pub fn to_level(lv: &PlainLevel, origin: DVec3, step: f64) -> Level {
    into_level(lv.clone(), origin, step)
}

/// A decoded level as a [`Level`]: grid coordinates to positions (spec §6.7), arrays moved where
/// the types allow.
fn into_level(lv: PlainLevel, origin: DVec3, step: f64) -> Level {
    let positions: Vec<DVec3> = if lv.exact.is_empty() && !lv.q.is_empty() {
        lv.q.iter().map(|q| origin + DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) * step).collect()
    } else {
        lv.exact.iter().map(|p| DVec3::from_array(*p)).collect()
    };
    let quads = lv.offsets.iter().enumerate().all(|(f, &o)| o as usize == 4 * f);
    let faces = if quads {
        let q: Vec<[u32; 4]> = lv.indices.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
        FaceList::from_quads(&q)
    } else {
        let mut faces = FaceList::with_capacity(lv.parents.len(), lv.indices.len());
        for w in lv.offsets.windows(2) {
            faces.push(&lv.indices[w[0] as usize..w[1] as usize]);
        }
        faces
    };
    let origins = lv
        .parents
        .iter()
        .zip(&lv.quadrants)
        .map(|(&p, &q)| {
            if p == NO_PARENT { FaceOrigin::Created } else { FaceOrigin::Subface { parent: p, quadrant: Quadrant(q) } }
        })
        .collect();
    let lattice = match (lv.slots, lv.corners) {
        (Some(face_slots), Some(vertex_corners)) => Some(LevelLattice { face_slots, vertex_corners }),
        _ => None,
    };
    Level { mesh: Mesh { vertices: octowrap_mesh::PointCloud::from_positions(positions), faces }, origins, lattice }
}
