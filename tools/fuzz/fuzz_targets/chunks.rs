//! The chunked reader (format version 5, spec §11) and its crack-free cut (§11.5) through
//! `ChunkedMrq`. The input: a selection, then the file.
//!
//! - byte 0: bits 0-6 the number `n` of chunk ids; bit 7 set: the ids are taken as they are (they
//!   may name chunks the file does not have), clear: modulo the chunk count;
//! - byte 1: bits 0-5 the level to extract, modulo the level count plus one (one past the last
//!   level must fail); bit 6 set: the file is resealed first (every level's and chunk's checksum
//!   and the preamble checksum recomputed, so that mutations of the preamble and of the stored
//!   bytes reach the index checks, zstd and the chunk decoder); bit 7 set: extract only the chunks
//!   meeting the first selected chunk's box;
//! - `n` chunk ids, `u16` little-endian each (a selection may repeat an id, or hold a chunk and
//!   one of its ancestors: not a cut);
//! - the rest: the file, opened under `Limits::strict()`.
//!
//! Then `chunks()`, `extract` of the level, `decode_chunks` and `cut` of the selection. Never
//! panics; and:
//! - the chunk index: a parent is listed before its child, one level above it;
//! - `extract`: fails past the last level; faces index existing vertices, 3 corners or more;
//! - `decode_chunks`: decodes exactly the chunks asked for (those that exist) and their
//!   ancestors, each with its index entry's face and vertex counts;
//! - `cut`: `CutError::Selection` exactly when the selection is not a cut (a repeated id, a chunk
//!   that does not exist, a chunk refining another selected); a cut whose chunks do not decode
//!   fails with `CutError::Decode`; a successful cut's faces index existing vertices, have 3
//!   corners or more and one chunk each (`face_chunks`), a drawn one; a lattice point per vertex;
//!   `drawn` strictly increasing, existing chunks, none an ancestor of another, each the
//!   selection's chunk or a descendant of one, and every selected chunk drawn or an ancestor of a
//!   drawn one (the selection itself when nothing was refined); `lattice_level` the finest level
//!   drawn.
//!
//! `./seed.sh` seeds the corpus with small synthetic version 5 files (chunk shifts 1 and 2) and
//! the conformance files, each behind selections that are cuts, mixed-level cuts and not cuts.
#![no_main]

use std::collections::HashSet;

use libfuzzer_sys::fuzz_target;
use octowrap_format::{ChunkInfo, ChunkedMrq, CutError, Limits};
use octowrap_mesh::{Aabb, DVec3, Mesh};

/// Recomputes in place the XXH3-64 checksums of `file`'s stored bytes, per level (spec §3.2) and
/// per chunk (§11.2), where the entries and the ranges they name lie in the file, then the
/// preamble checksum (§3.4).
fn reseal(file: &mut [u8]) {
    const HEADER: usize = 112;
    const LEVEL_ENTRY: usize = 48;
    const CHUNK_ENTRY: usize = 88;
    let u32_at = |b: &[u8], at: usize| b.get(at..at + 4).map_or(0, |x| u32::from_le_bytes(x.try_into().expect("4")));
    let u64_at = |b: &[u8], at: usize| b.get(at..at + 8).map_or(0, |x| u64::from_le_bytes(x.try_into().expect("8")));
    if file.len() < HEADER {
        return;
    }
    let version = u16::from_le_bytes([file[8], file[9]]);
    let levels = u32_at(file, 16) as usize;
    let chunks = if version >= 5 { u32_at(file, 108) as usize } else { 0 };
    let sum = |file: &[u8], offset: u64, size: u64| {
        let start = usize::try_from(offset).ok()?;
        let end = start.checked_add(usize::try_from(size).ok()?)?;
        Some(xxhash_rust::xxh3::xxh3_64(file.get(start..end)?))
    };
    let mut at = HEADER;
    // Level table, then chunk index: (entries, entry size, the size's place and width, the
    // checksum's place; the offset comes first).
    for (count, entry, size_at, size_width, sum_at) in
        [(levels, LEVEL_ENTRY, 8, 8, 24), (chunks, CHUNK_ENTRY, 16, 4, 8)]
    {
        for _ in 0..count {
            if at + entry > file.len() {
                break;
            }
            let size = if size_width == 8 { u64_at(file, at + size_at) } else { u64::from(u32_at(file, at + size_at)) };
            if let Some(s) = sum(file, u64_at(file, at), size) {
                file[at + sum_at..at + sum_at + 8].copy_from_slice(&s.to_le_bytes());
            }
            at += entry;
        }
    }
    octowrap_format::tamper::fix_preamble_checksum(file);
}

/// The ancestors of chunk `c` (its parent, its parent's parent, ...), nearest first.
fn ancestors(chunks: &[ChunkInfo], c: u32) -> impl Iterator<Item = u32> + '_ {
    std::iter::successors(chunks[c as usize].parent, move |&p| chunks[p as usize].parent)
}

/// Whether chunk `a` is an ancestor of chunk `d`.
fn is_ancestor(chunks: &[ChunkInfo], a: u32, d: u32) -> bool {
    ancestors(chunks, d).any(|x| x == a)
}

/// Every face of `m` indexes an existing vertex and has 3 corners or more (spec §2).
fn faces_hold(m: &Mesh, what: &str) {
    let nv = m.vertices.len();
    for (i, f) in m.faces.iter().enumerate() {
        assert!(f.len() >= 3, "{what}: face {i} has {} corners", f.len());
        assert!(f.iter().all(|&v| (v as usize) < nv), "{what}: face {i} {f:?} indexes past {nv} vertices");
    }
}

fuzz_target!(|data: &[u8]| {
    let [count, level, rest @ ..] = data else { return };
    let (raw, n) = (count & 0x80 != 0, usize::from(count & 0x7f));
    let Some((ids, file)) = rest.split_at_checked(2 * n) else { return };
    let mut owned;
    let file = if level & 0x40 != 0 {
        owned = file.to_vec();
        reseal(&mut owned);
        &owned[..]
    } else {
        file
    };
    let Ok(mut reader) = ChunkedMrq::open(file, &Limits::strict()) else { return };
    let chunks = reader.chunks();
    let nc = chunks.len();
    // The index check promises what the ancestor walks below rely on.
    for (i, c) in chunks.iter().enumerate() {
        if let Some(p) = c.parent {
            assert!((p as usize) < i, "chunk {i}'s parent {p} is not listed before it");
            assert_eq!(chunks[p as usize].level + 1, c.level, "chunk {i}'s parent {p} is not one level above it");
        }
    }
    let selection: Vec<u32> = ids
        .chunks_exact(2)
        .map(|b| u32::from(u16::from_le_bytes([b[0], b[1]])))
        .map(|id| if raw || nc == 0 { id } else { id % nc as u32 })
        .collect();

    // One level, whole or in the first selected chunk's box.
    let levels = reader.info().levels.len() as u32;
    let k = u32::from(level & 0x3f) % (levels + 1);
    let region =
        (level & 0x80 != 0).then(|| selection.first().and_then(|&c| chunks.get(c as usize))).flatten().map(|c| Aabb {
            min: DVec3::from_array(c.bbox_min.map(f64::from)),
            max: DVec3::from_array(c.bbox_max.map(f64::from)),
        });
    if let Ok(m) = reader.extract(k, region) {
        assert!(k < levels, "level {k} of {levels} extracted");
        faces_hold(&m, "extract");
    }

    // The selection's chunks and their ancestors, exactly.
    let decoded = reader.decode_chunks(&selection).ok();
    if let Some(done) = &decoded {
        let mut want: HashSet<u32> = HashSet::new();
        for &c in selection.iter().filter(|&&c| (c as usize) < nc) {
            want.insert(c);
            want.extend(ancestors(&chunks, c));
        }
        let got: HashSet<u32> = done.keys().copied().collect();
        assert_eq!(got, want, "decode_chunks({selection:?})");
        for (&c, lv) in done {
            let info = &chunks[c as usize];
            let faces = lv.offsets.len().saturating_sub(1);
            let vertices = lv.q.len().max(lv.exact.len());
            assert_eq!(faces, info.face_count as usize, "chunk {c}'s faces");
            assert_eq!(lv.parents.len(), faces, "chunk {c}'s face parents");
            assert_eq!(vertices, info.vertex_count as usize, "chunk {c}'s vertices");
        }
    }

    // The cut: a selection error exactly when the selection is not a cut.
    let mut sorted = selection.clone();
    sorted.sort_unstable();
    let is_cut = sorted.windows(2).all(|w| w[0] != w[1])
        && sorted.iter().all(|&c| (c as usize) < nc)
        && !sorted.iter().any(|&c| ancestors(&chunks, c).any(|a| sorted.binary_search(&a).is_ok()));
    let cut = match reader.cut(&selection) {
        Err(CutError::Selection(why)) => {
            assert!(!is_cut, "the cut {selection:?} rejected: {why}");
            return;
        }
        Err(e) => {
            assert!(is_cut, "{selection:?} is not a cut, yet not rejected as one: {e}");
            return;
        }
        Ok(cut) => {
            assert!(is_cut, "{selection:?} is not a cut, yet cut");
            cut
        }
    };
    // The cut decodes the selection first: what decode_chunks could not decode, it cannot either.
    assert!(decoded.is_some(), "the cut {selection:?} decoded what decode_chunks could not");
    faces_hold(&cut.mesh, "cut");
    assert_eq!(cut.face_chunks.len(), cut.mesh.faces.len(), "face_chunks");
    assert_eq!(cut.lattice.len(), cut.mesh.vertices.len(), "a lattice point per vertex");
    let d = &cut.drawn;
    assert!(d.windows(2).all(|w| w[0] < w[1]), "drawn {d:?} is not strictly increasing");
    assert!(d.iter().all(|&c| (c as usize) < nc), "drawn {d:?}: a chunk past {nc}");
    for &a in d {
        for &b in d {
            assert!(!is_ancestor(&chunks, a, b), "drawn chunk {a} is an ancestor of drawn chunk {b}");
        }
    }
    let drawn: HashSet<u32> = d.iter().copied().collect();
    assert!(cut.face_chunks.iter().all(|c| drawn.contains(c)), "a face of a chunk not drawn");
    for &c in d {
        assert!(
            sorted.binary_search(&c).is_ok() || ancestors(&chunks, c).any(|a| sorted.binary_search(&a).is_ok()),
            "drawn chunk {c} is neither selected nor refines a selected chunk"
        );
    }
    for &s in &sorted {
        assert!(
            drawn.contains(&s) || d.iter().any(|&c| is_ancestor(&chunks, s, c)),
            "selected chunk {s} is neither drawn nor refined by a drawn chunk"
        );
    }
    if cut.refined == 0 {
        assert_eq!(d, &sorted, "nothing refined, yet the drawn chunks are not the selection");
    }
    let finest = d.iter().map(|&c| chunks[c as usize].level).max().unwrap_or(0);
    assert_eq!(cut.lattice_level, finest, "lattice_level");
});
