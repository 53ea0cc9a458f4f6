//! Round trips: topology exact (in the canonical order), every vertex within half a grid step on
//! every axis at every level, deterministic bytes, partial decoding.

use octowrap_format::synthetic::{Edits, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::{
    DecodeError, DecodeOptions, EncodeOptions, Quantization, canonical, decode, encode, encode_with_stats, read_info,
};
use octowrap_mesh::{Hierarchy, Mesh};

/// Checks `decode(encode(h))` against `canonical(h)`.
fn check(h: &Hierarchy, opts: &EncodeOptions) -> Vec<u8> {
    let bytes = encode(h, opts).expect("encodes");
    assert_eq!(bytes, encode(h, opts).unwrap(), "encoding twice gives the same bytes");
    let want = canonical(h, opts).expect("canonical");
    assert_eq!(encode(&want, opts).unwrap(), bytes, "the canonical form encodes to the same bytes");
    let got = decode(&bytes[..], &DecodeOptions::default()).expect("decodes").hierarchy;
    assert_eq!(got.levels.len(), want.levels.len());
    assert_eq!(got.cube, want.cube);
    let step = match decode(&bytes[..], &DecodeOptions::default()).unwrap().info.grid {
        Some(g) => g.step,
        None => 0.0,
    };
    for (k, (g, w)) in got.levels.iter().zip(&want.levels).enumerate() {
        assert_eq!(g.mesh.faces, w.mesh.faces, "level {k} faces");
        assert_eq!(g.origins, w.origins, "level {k} origins");
        assert_eq!(g.lattice, w.lattice, "level {k} lattice");
        assert_eq!(g.mesh.vertices.len(), w.mesh.vertices.len());
        for (v, (a, b)) in g.mesh.vertices.positions.iter().zip(&w.mesh.vertices.positions).enumerate() {
            let err = (*a - *b).abs().max_element();
            assert!(
                err <= step * 0.5 * (1.0 + 1e-9) + 1e-12 * b.abs().max_element(),
                "level {k} vertex {v}: {err} > {step}/2"
            );
        }
    }
    // Same multiset of topology as the input: face counts and vertex counts agree.
    for (g, i) in got.levels.iter().zip(&h.levels) {
        assert_eq!(g.mesh.faces.len(), i.mesh.faces.len());
        assert_eq!(g.mesh.vertices.len(), i.mesh.vertices.len());
    }
    bytes
}

#[test]
fn lattice_hierarchy_round_trips() {
    for seed in 0..4 {
        let h = cube_hierarchy(5, Edits::default(), seed);
        // Version 3 (the default) codes lattice levels in mode 3, version 2 in mode 2.
        for (version, mode) in [(3u16, 3u8), (2, 2)] {
            let mut opts = EncodeOptions::with_quantization(Quantization::Bits(12));
            opts.version = version;
            let (bytes, stats) = encode_with_stats(&h, &opts).unwrap();
            assert!(stats[1..].iter().all(|s| s.mode == mode), "lattice mode used: {stats:?}");
            assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), version);
            check(&h, &opts);
        }
        check(&h, &EncodeOptions::with_quantization(Quantization::Bits(12)));
        check(&h, &EncodeOptions::with_quantization(Quantization::Bits(20)));
        check(&h, &EncodeOptions::with_quantization(Quantization::Exact));
        check(&h, &EncodeOptions::with_quantization(Quantization::Step(0.001)));
    }
}

#[test]
fn generic_hierarchy_round_trips() {
    for seed in 0..4 {
        let h = without_lattice(cube_hierarchy(5, Edits::default(), seed));
        let (_, stats) = encode_with_stats(&h, &EncodeOptions::default()).unwrap();
        assert!(stats[1..].iter().all(|s| s.mode == 1));
        check(&h, &EncodeOptions::with_quantization(Quantization::Bits(12)));
        check(&h, &EncodeOptions::with_quantization(Quantization::Exact));
    }
}

#[test]
fn canonical_subdivision_costs_next_to_nothing() {
    for h in [cube_hierarchy(6, Edits::none(), 1), without_lattice(cube_hierarchy(6, Edits::none(), 1))] {
        let (_, stats) = encode_with_stats(&h, &EncodeOptions::with_quantization(Quantization::Bits(12))).unwrap();
        let last = h.levels.last().unwrap();
        let bits = stats.last().unwrap().topology as f64 * 8.0 / last.mesh.vertices.len() as f64;
        assert!(bits < 0.1, "topology of a pure subdivision: {bits} bits per vertex ({stats:?})");
        check(&h, &EncodeOptions::with_quantization(Quantization::Bits(12)));
    }
}

#[test]
fn one_level_meshes_round_trip_exactly() {
    for (n, f, seed) in [(0, 0, 0), (1, 0, 1), (3, 1, 2), (100, 80, 3), (2000, 1500, 4)] {
        let m = polygon_mesh(n, f, seed);
        let h = Hierarchy::single(m.clone());
        let bytes = check(&h, &EncodeOptions::with_quantization(Quantization::Exact));
        let got = decode(&bytes[..], &DecodeOptions::default()).unwrap().hierarchy;
        assert_eq!(got.levels[0].mesh, m, "exact files keep everything, order included");
        check(&h, &EncodeOptions::with_quantization(Quantization::Bits(16)));
    }
}

#[test]
fn partial_decoding_reads_only_the_prefix() {
    let h = cube_hierarchy(5, Edits::default(), 9);
    let bytes = encode(&h, &EncodeOptions::default()).unwrap();
    let info = read_info(&bytes[..], &octowrap_format::Limits::default()).unwrap();
    for k in 0..5u32 {
        let e = &info.levels[k as usize];
        let end = (e.offset + e.stored_size) as usize;
        // Only the bytes up to the end of level k are available: still decodes levels 0..=k.
        let f = decode(&bytes[..end], &DecodeOptions::up_to(k)).unwrap();
        assert_eq!(f.hierarchy.levels.len(), k as usize + 1);
        let full = decode(&bytes[..], &DecodeOptions::default()).unwrap();
        assert_eq!(f.hierarchy.levels[..], full.hierarchy.levels[..=k as usize]);
    }
    assert!(matches!(decode(&bytes[..], &DecodeOptions::up_to(5)), Err(DecodeError::NoSuchLevel { .. })));
}

#[test]
fn bad_inputs_are_refused() {
    let h = Hierarchy::single(Mesh::default());
    assert!(encode(&Hierarchy::default(), &EncodeOptions::default()).is_err());
    assert!(encode(&h, &EncodeOptions::with_quantization(Quantization::Bits(0))).is_err());
    assert!(encode(&h, &EncodeOptions::with_quantization(Quantization::Step(-1.0))).is_err());
    let mut m = polygon_mesh(4, 2, 1);
    m.vertices.positions[0].x = f64::NAN;
    assert!(encode(&Hierarchy::single(m), &EncodeOptions::default()).is_err());
}

/// Residuals and local biases near the grid's range (spec §6.2's sums leave 32 bits): the
/// vertices of every other level moved by up to 0.45 of the cube on a 28-bit grid, so that
/// neighbour sums take the geometry pass's 64-bit path as well as its 32-bit one.
#[test]
fn huge_residuals_round_trip() {
    let mut rng = octowrap_format::synthetic::Rng::new(7);
    let mut h = cube_hierarchy(4, Edits::default(), 3);
    for (k, level) in h.levels.iter_mut().enumerate() {
        let noise = if k % 2 == 0 { 0.9 } else { 1e-6 };
        for p in &mut level.mesh.vertices.positions {
            for a in 0..3 {
                p[a] = 0.5 * p[a] + noise * (rng.f64() - 0.5);
            }
        }
    }
    for bits in [28, 12] {
        check(&h, &EncodeOptions::with_quantization(Quantization::Bits(bits)));
    }
}

/// The decoder keeps its working buffers per thread: decoding files of different sizes and kinds
/// one after another, with a failure between them, gives what a fresh thread gives.
#[test]
fn decodes_on_one_thread_match_fresh_threads() {
    let q12 = EncodeOptions::with_quantization(Quantization::Bits(12));
    let files = [
        encode(&cube_hierarchy(6, Edits::default(), 1), &q12).unwrap(),
        encode(&without_lattice(cube_hierarchy(4, Edits::default(), 2)), &q12).unwrap(),
        encode(&cube_hierarchy(3, Edits::none(), 0), &EncodeOptions::with_quantization(Quantization::Exact)).unwrap(),
    ];
    let fresh: Vec<_> = files
        .iter()
        .map(|b| {
            let b = b.clone();
            std::thread::spawn(move || decode(&b[..], &DecodeOptions::default()).unwrap()).join().unwrap()
        })
        .collect();
    for round in 0..2 {
        for (i, b) in files.iter().enumerate() {
            assert_eq!(decode(&b[..], &DecodeOptions::default()).unwrap(), fresh[i], "file {i}, round {round}");
            // A corrupt last level (resealed, so that its decoding starts): whether it fails half-way
            // or decodes, the next decode must not see its leftovers.
            let mut payloads = octowrap_format::fuzzing::payloads(b).unwrap();
            let last = payloads.last_mut().unwrap();
            let at = last.len() * (round + 1) / 3;
            last[at] ^= 0x5a;
            let bad = octowrap_format::fuzzing::reseal(b, &payloads, None).unwrap();
            let _ = decode(&bad[..], &DecodeOptions::default());
        }
    }
}
