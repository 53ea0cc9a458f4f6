//! Version 5 chunks (spec §11): chunked files decode to their canonical hierarchy, parts of a
//! level decode from their own bytes and their ancestors' through a byte-range source, and the
//! result does not depend on the thread count.

use octowrap_format::synthetic::{Edits, Rng, cube_hierarchy, shuffle};
use octowrap_format::{
    ChunkedMrq, CountingSource, DecodeOptions, EncodeOptions, Limits, Quantization, canonical, decode, encode,
    read_info,
};
use octowrap_mesh::{Aabb, DVec3, Hierarchy, Mesh};

/// The synthetic edits without joins: a corner joined to a vertex off its cell's boundary keeps
/// the levels it touches from splitting (see `joined_vertices_off_the_boundaries_coarsen_the_cells`).
const NO_JOINS: Edits =
    Edits { remove: 0.05, inner: 0.1, create: 0.05, split: 0.01, join: 0.0, noise: 0.2, shuffle: true };

fn v5(q: Quantization, shift: u32) -> EncodeOptions {
    let mut o = EncodeOptions::with_quantization(q);
    o.version = 5;
    o.chunk_shift = shift;
    o
}

/// Faces of `m` as sorted vertex position bit patterns, sorted: a mesh up to vertex and face order.
fn faces(m: &Mesh) -> Vec<Vec<[u64; 3]>> {
    let p = &m.vertices.positions;
    let mut out: Vec<Vec<[u64; 3]>> =
        m.faces.iter().map(|f| f.iter().map(|&v| p[v as usize].to_array().map(f64::to_bits)).collect()).collect();
    out.sort();
    out
}

/// `h` with positions moved to the grid points the file holds.
fn quantized(h: &Hierarchy, step: f64, origin: DVec3) -> Hierarchy {
    let mut h = h.clone();
    for l in &mut h.levels {
        for p in &mut l.mesh.vertices.positions {
            *p = origin + ((*p - origin) / step).round() * step;
        }
    }
    h
}

#[test]
fn chunked_files_decode_to_their_canonical_hierarchy() {
    for (seed, shift, q) in
        [(1, 1, Quantization::Bits(12)), (2, 2, Quantization::Bits(14)), (3, 1, Quantization::Exact)]
    {
        let mut h = cube_hierarchy(5, NO_JOINS, seed);
        shuffle(&mut h, &mut Rng::new(seed));
        let opts = v5(q, shift);
        let bytes = encode(&h, &opts).unwrap();
        let info = read_info(&bytes[..], &Limits::default()).unwrap();
        assert_eq!(info.version, 5);
        // The shift splits the finer levels into several chunks.
        assert!(info.levels[4].chunk_count > 4, "seed {seed}: {} chunks at level 4", info.levels[4].chunk_count);
        assert_eq!(info.levels[4].cell_depth, 4 - shift);
        let file = decode(&bytes[..], &DecodeOptions::default()).unwrap();
        let want = canonical(&h, &opts).unwrap();
        let want = match (q, &info.grid) {
            (Quantization::Exact, _) => want,
            (_, Some(g)) => quantized(&want, g.step, DVec3::from_array(g.origin)),
            _ => unreachable!("a grid file has a grid"),
        };
        assert_eq!(file.hierarchy, want, "seed {seed}");
        file.hierarchy.check_links().unwrap();
        // The same levels as the unchunked file, up to order.
        let mut v4 = opts.clone();
        v4.version = 4;
        let whole = decode(&encode(&h, &v4).unwrap()[..], &DecodeOptions::default()).unwrap();
        for (a, b) in whole.hierarchy.levels.iter().zip(&file.hierarchy.levels) {
            assert_eq!(faces(&a.mesh), faces(&b.mesh), "seed {seed}");
        }
    }
}

#[test]
fn a_region_reads_only_its_chunks_and_their_ancestors() {
    let h = cube_hierarchy(6, NO_JOINS, 5);
    let bytes = encode(&h, &v5(Quantization::Bits(14), 2)).unwrap();
    let full = decode(&bytes[..], &DecodeOptions::default()).unwrap();
    let finest = 5;
    let mut src = CountingSource::new(&bytes[..]);
    let mut reader = ChunkedMrq::open(&mut src, &Limits::default()).unwrap();
    // The preamble: two requests.
    assert_eq!(reader.stats().requests, 2);
    let preamble = reader.stats().bytes;
    let corner = Aabb { min: DVec3::splat(-0.1), max: DVec3::splat(0.2) };
    let part = reader.extract(finest, Some(corner)).unwrap();
    let stats = reader.stats();
    drop(reader);
    assert_eq!((src.requests, src.bytes), (stats.requests, stats.bytes));
    let ids: Vec<_> = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap().chunks_in(finest, Some(corner));
    let all = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap().chunks_in(finest, None);
    assert!(!ids.is_empty() && ids.len() * 4 < all.len(), "{} of {} chunks", ids.len(), all.len());
    assert!(stats.bytes - preamble < (bytes.len() as u64 - preamble) / 3, "read {} of {}", stats.bytes, bytes.len());
    // Every face of the full level with a vertex in the region is in the part, and the part's
    // faces are faces of the full level.
    let level = &full.hierarchy.levels[finest as usize].mesh;
    let inside = |p: DVec3| (0..3).all(|a| p[a] >= corner.min[a] && p[a] <= corner.max[a]);
    let want: Vec<_> = faces(level)
        .into_iter()
        .filter(|f| f.iter().any(|v| inside(DVec3::from_array(v.map(f64::from_bits)))))
        .collect();
    let got = faces(&part);
    let all_faces = faces(level);
    assert!(got.iter().all(|f| all_faces.binary_search(f).is_ok()));
    assert!(want.iter().all(|f| got.binary_search(f).is_ok()), "a face in the region is missing");
    // The whole level through the reader equals the full decode's.
    let mut reader = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
    assert_eq!(faces(&reader.extract(finest, None).unwrap()), all_faces);
}

#[test]
fn decoding_does_not_depend_on_the_thread_count() {
    let h = cube_hierarchy(6, NO_JOINS, 8);
    let bytes = encode(&h, &v5(Quantization::Bits(14), 2)).unwrap();
    let decode_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| decode(&bytes[..], &DecodeOptions::default()).unwrap().hierarchy)
    };
    assert_eq!(decode_on(1), decode_on(2));
    let encode_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| encode(&h, &v5(Quantization::Bits(14), 2)).unwrap())
    };
    assert_eq!(encode_on(1), bytes);
    assert_eq!(encode_on(2), bytes);
}

#[test]
fn a_chunk_with_a_bad_checksum_fails_where_it_lies() {
    let h = cube_hierarchy(5, NO_JOINS, 4);
    let mut bytes = encode(&h, &v5(Quantization::Bits(12), 1)).unwrap();
    let reader = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
    let chunks = reader.chunks();
    let (i, c) = chunks.iter().enumerate().rfind(|(_, c)| c.level == 4).unwrap();
    bytes[c.offset as usize + 5] ^= 1;
    let mut reader = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
    match reader.decode_chunks(&[i as u32]) {
        Err(octowrap_format::DecodeError::ChecksumMismatch { place, offset, .. }) => {
            assert_eq!(place, octowrap_format::Where::Chunk(4, i as u32));
            assert_eq!(offset, c.offset);
        }
        other => panic!("expected a checksum error, got {:?}", other.map(|m| m.len())),
    }
    // The chunks before it still decode.
    assert!(reader.decode_chunks(&[0, 1]).is_ok());
}

#[test]
fn joined_vertices_off_the_boundaries_coarsen_the_cells() {
    // Joins make corners use vertices of other voxels, some of them across a cell boundary: the
    // encoder then splits the levels into fewer, larger cells (or none), and the file still
    // decodes to its canonical hierarchy.
    let h = cube_hierarchy(5, Edits { join: 0.02, ..NO_JOINS }, 6);
    let opts = v5(Quantization::Bits(12), 1);
    let bytes = encode(&h, &opts).unwrap();
    let info = read_info(&bytes[..], &Limits::default()).unwrap();
    assert!(info.levels[4].cell_depth < 3, "cell depth {}", info.levels[4].cell_depth);
    let file = decode(&bytes[..], &DecodeOptions::default()).unwrap();
    let g = info.grid.unwrap();
    assert_eq!(file.hierarchy, quantized(&canonical(&h, &opts).unwrap(), g.step, DVec3::from_array(g.origin)));
}

/// A random cut of `chunks` (spec §11.5): from every root chunk, each chunk is replaced by the
/// chunks refining it with probability 3/4 (always when it is its level's one chunk).
fn random_cut(chunks: &[octowrap_format::ChunkInfo], rng: &mut Rng) -> Vec<u32> {
    let mut children: Vec<Vec<u32>> = vec![Vec::new(); chunks.len()];
    let mut stack = Vec::new();
    for (i, c) in chunks.iter().enumerate() {
        match c.parent {
            Some(p) => children[p as usize].push(i as u32),
            None => stack.push(i as u32),
        }
    }
    let mut out = Vec::new();
    while let Some(c) = stack.pop() {
        if !children[c as usize].is_empty() && (chunks[c as usize].cell_depth == 0 || rng.below(4) != 0) {
            stack.extend(&children[c as usize]);
        } else {
            out.push(c);
        }
    }
    out
}

/// Open directed edges and edges used twice in a mesh.
fn open_and_twice(m: &Mesh) -> (usize, usize) {
    let mut half = std::collections::HashSet::new();
    let mut twice = 0;
    for f in m.faces.iter() {
        for i in 0..f.len() {
            twice += usize::from(!half.insert((f[i], f[(i + 1) % f.len()])));
        }
    }
    (half.iter().filter(|&&(a, b)| !half.contains(&(b, a))).count(), twice)
}

#[test]
fn every_cut_of_a_closed_hierarchy_is_closed() {
    // The canonical subdivision of the cube's surface: every level closed, so every cut must be.
    let h = cube_hierarchy(6, Edits::none(), 3);
    let bytes = encode(&h, &v5(Quantization::Bits(14), 1)).unwrap();
    let mut reader = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
    let chunks = reader.chunks();
    let mut rng = Rng::new(11);
    let mut levels_mixed = 0;
    for _ in 0..25 {
        let drawn = random_cut(&chunks, &mut rng);
        let cut = reader.cut(&drawn).unwrap();
        let mut levels: Vec<u32> = cut.drawn.iter().map(|&c| chunks[c as usize].level).collect();
        levels.sort_unstable();
        levels.dedup();
        levels_mixed += usize::from(levels.len() > 1);
        assert_eq!(open_and_twice(&cut.mesh), (0, 0), "cut {drawn:?} (drawn {:?})", cut.drawn);
        assert_eq!(cut.unresolved, 0);
        assert_eq!(cut.face_chunks.len(), cut.mesh.faces.len());
        // Every face of a drawn chunk is in the cut.
        let faces: u32 = cut.drawn.iter().map(|&c| chunks[c as usize].face_count).sum();
        assert_eq!(cut.mesh.faces.len() as u32, faces);
    }
    assert!(levels_mixed >= 20, "{levels_mixed} of 25 cuts mix levels");
}

#[test]
fn cuts_of_an_edited_hierarchy_leave_open_only_the_levels_own_open_edges() {
    // Removed and split faces and noise: the levels have holes and differ in topology.
    let edits = Edits { remove: 0.05, split: 0.01, noise: 0.2, shuffle: true, ..Edits::none() };
    let h = cube_hierarchy(6, edits, 5);
    let bytes = encode(&h, &v5(Quantization::Bits(14), 2)).unwrap();
    let whole = decode(&bytes[..], &DecodeOptions::default()).unwrap().hierarchy;
    let open = octowrap_format::cut_check::open_edges(&whole);
    let mut reader = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
    let chunks = reader.chunks();
    let levels: Vec<u32> = chunks.iter().map(|c| c.level).collect();
    let mut rng = Rng::new(12);
    let mut refined = 0;
    for _ in 0..25 {
        let drawn = random_cut(&chunks, &mut rng);
        let cut = reader.cut(&drawn).unwrap();
        refined += cut.refined;
        let cracks = octowrap_format::cut_check::cut_cracks(&cut, &levels, &open);
        assert_eq!(cracks, octowrap_format::cut_check::CutCracks::default(), "cut {drawn:?}");
        assert_eq!(cut.unresolved, 0, "cut {drawn:?}");
    }
    assert!(refined > 0, "the crack rule had nothing to do: the test shows nothing");
}

#[test]
fn a_cut_does_not_depend_on_the_thread_count() {
    let h = cube_hierarchy(6, NO_JOINS, 9);
    let bytes = encode(&h, &v5(Quantization::Bits(14), 2)).unwrap();
    let chunks = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap().chunks();
    let drawn = random_cut(&chunks, &mut Rng::new(4));
    let cut_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let cut = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap().cut(&drawn).unwrap();
            (cut.mesh, cut.face_chunks, cut.drawn)
        })
    };
    assert_eq!(cut_on(1), cut_on(2));
}

#[test]
fn a_selection_that_is_no_cut_is_refused() {
    let h = cube_hierarchy(5, NO_JOINS, 2);
    let bytes = encode(&h, &v5(Quantization::Bits(14), 1)).unwrap();
    let mut reader = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
    let chunks = reader.chunks();
    let child = chunks.iter().position(|c| c.parent.is_some()).unwrap() as u32;
    let parent = chunks[child as usize].parent.unwrap();
    let n = chunks.len() as u32;
    for (drawn, says) in
        [(vec![child, child], "selected twice"), (vec![n], "does not exist"), (vec![parent, child], "refines chunk")]
    {
        let e = reader.cut(&drawn).unwrap_err().to_string();
        assert!(e.contains(says), "{drawn:?}: {e}");
    }
}

#[test]
fn a_second_cut_reuses_the_chunks_the_first_decoded() {
    let h = cube_hierarchy(6, NO_JOINS, 6);
    let bytes = encode(&h, &v5(Quantization::Bits(14), 2)).unwrap();
    let mut reader = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap();
    let chunks = reader.chunks();
    let drawn = random_cut(&chunks, &mut Rng::new(8));
    let first = reader.cut(&drawn).unwrap();
    let read = reader.stats();
    let again = reader.cut(&drawn).unwrap();
    assert_eq!(reader.stats(), read, "nothing is read again");
    assert_eq!((again.mesh, again.drawn), (first.mesh.clone(), first.drawn.clone()));
    // Another cut reads only the chunks it adds, and gives what a fresh reader gives.
    let other = random_cut(&chunks, &mut Rng::new(9));
    let cut = reader.cut(&other).unwrap();
    let fresh = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap().cut(&other).unwrap();
    assert_eq!((cut.mesh, cut.drawn), (fresh.mesh, fresh.drawn));
}
